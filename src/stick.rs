//! The [`Stick`] component: a distance constraint between two particle entities.

use crate::solver::StickKind;
use bevy::prelude::*;

/// How stiff a stick (or angle constraint) is.
///
/// ```
/// use bevy_verlet_physics::prelude::*;
/// let rope_link = Stiffness::Rigid;
/// let spring = Stiffness::Compliance(1e-4); // m/N: stretches 0.1 mm per newton
/// // The Tuts+ ragdoll's 0.8 link, tuned at 3 iterations per 16 ms step:
/// let seed = Stiffness::Seed { stiffness: 0.8, iterations: 3, timestep: 0.016 };
/// assert_ne!(rope_link, spring);
/// assert_ne!(spring, seed);
/// ```
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Default, Debug, Clone)]
pub enum Stiffness {
    /// Infinitely stiff (compliance 0).
    #[default]
    Rigid,
    /// XPBD compliance α = 1/k (length per force). Behaves the same at any substep and
    /// iteration count.
    Compliance(f32),
    /// A seed-style per-iteration stiffness `k ∈ (0, 1]` as tuned in the original code, which ran
    /// `iterations` relaxation passes per step of `timestep` seconds. It is converted once to the
    /// compliance that removes the same fraction of the error per step of that size,
    /// `k_step = 1 − (1 − k)^iterations`, `α = (w_a + w_b)·timestep²·(1 − k_step)/k_step`, so the
    /// stick feels the same whatever our iteration and substep counts are.
    Seed {
        /// Fraction of the error removed per pass in the original code.
        stiffness: f32,
        /// Passes per step in the original code.
        iterations: u32,
        /// Step of the original code, in seconds.
        timestep: f32,
    },
}

impl Stiffness {
    /// The XPBD compliance for a constraint whose generalized inverse mass is `w`.
    pub fn compliance(&self, w: f64) -> f64 {
        match *self {
            Stiffness::Rigid => 0.0,
            Stiffness::Compliance(alpha) => alpha as f64,
            Stiffness::Seed {
                stiffness,
                iterations,
                timestep,
            } => {
                let k = (stiffness as f64).clamp(1e-9, 1.0);
                let k_step = 1.0 - (1.0 - k).powi(iterations.max(1) as i32);
                let h = timestep as f64;
                w * h * h * (1.0 - k_step) / k_step
            }
        }
    }
}

/// A distance constraint between two [`Particle`](crate::Particle) entities.
///
/// `rest_length: None` takes the distance between the particles when the solver first sees the
/// stick, and writes it back. `tear_strain: Some(s)` removes the stick once its length exceeds
/// `(1 + s) × rest_length` after a solve (a [`StickTorn`](crate::StickTorn) message reports it).
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut world = World::new();
/// let a = world.spawn(Particle::new(Vec3::ZERO)).id();
/// let b = world.spawn(Particle::new(Vec3::X)).id();
/// world.spawn(Stick::new(a, b).rope().with_tear_strain(0.5));
/// ```
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Debug, Clone)]
pub struct Stick {
    /// First particle entity.
    pub a: Entity,
    /// Second particle entity.
    pub b: Entity,
    /// Rest length; `None` = the distance at creation.
    pub rest_length: Option<f32>,
    /// Stiffness.
    pub stiffness: Stiffness,
    /// Which way it acts.
    pub kind: StickKind,
    /// Strain past which it tears (`None` = never).
    pub tear_strain: Option<f32>,
}

impl Stick {
    /// A rigid stick whose rest length is the distance at creation.
    pub fn new(a: Entity, b: Entity) -> Self {
        Self {
            a,
            b,
            rest_length: None,
            stiffness: Stiffness::Rigid,
            kind: StickKind::Equal,
            tear_strain: None,
        }
    }

    /// Sets the rest length.
    pub fn with_rest_length(mut self, rest_length: f32) -> Self {
        self.rest_length = Some(rest_length);
        self
    }

    /// Sets the stiffness.
    pub fn with_stiffness(mut self, stiffness: Stiffness) -> Self {
        self.stiffness = stiffness;
        self
    }

    /// Sets the XPBD compliance (`0` = rigid).
    pub fn with_compliance(self, compliance: f32) -> Self {
        self.with_stiffness(Stiffness::Compliance(compliance))
    }

    /// Sets the direction of action.
    pub fn with_kind(mut self, kind: StickKind) -> Self {
        self.kind = kind;
        self
    }

    /// Only pulls (a rope link): [`StickKind::AtMost`].
    pub fn rope(self) -> Self {
        self.with_kind(StickKind::AtMost)
    }

    /// Only pushes (a strut, a joint limit): [`StickKind::AtLeast`].
    pub fn strut(self) -> Self {
        self.with_kind(StickKind::AtLeast)
    }

    /// Tears once stretched past `(1 + strain) × rest_length`.
    pub fn with_tear_strain(mut self, strain: f32) -> Self {
        self.tear_strain = Some(strain);
        self
    }
}

/// An angle constraint (verlet-js `AngleConstraint`): keeps the angle at particle `b` between
/// `a` and `c` at `rest_angle`.
///
/// With `axis: Some(k)` the angle is signed about `k` (2D scenes: `Vec3::Z`, the default), so it
/// cannot flip to the mirror side; with `None` it is the unsigned 3D angle.
///
/// It holds only the angle: hold both arms (`a`–`b`, `b`–`c`) with sticks. The projection is
/// linear in the angle, which is only safe while the arms keep their lengths: with free arms,
/// with a vertex more than a few times lighter than the arm ends, or with both arm ends pinned
/// while sticks already fix the vertex (the angle then contradicts the sticks), it can gain
/// energy and diverge. The plugin then puts the diverging particles back (see
/// [`VerletStats::diverged`](crate::VerletStats::diverged)).
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut world = World::new();
/// let [a, b, c] = [Vec3::X, Vec3::ZERO, Vec3::Y].map(|p| world.spawn(Particle::new(p)).id());
/// world.spawn(AngleConstraint::new(a, b, c).with_compliance(1e-3));
/// ```
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Debug, Clone)]
pub struct AngleConstraint {
    /// First arm's particle.
    pub a: Entity,
    /// The vertex.
    pub b: Entity,
    /// Second arm's particle.
    pub c: Entity,
    /// Rest angle in radians; `None` = the angle at creation.
    pub rest_angle: Option<f32>,
    /// Stiffness (compliance in rad per N·m).
    pub stiffness: Stiffness,
    /// Axis of the signed angle, or `None` for the unsigned 3D angle.
    pub axis: Option<Vec3>,
}

impl AngleConstraint {
    /// A rigid angle constraint in the XY plane, holding the angle at creation.
    pub fn new(a: Entity, b: Entity, c: Entity) -> Self {
        Self {
            a,
            b,
            c,
            rest_angle: None,
            stiffness: Stiffness::Rigid,
            axis: Some(Vec3::Z),
        }
    }

    /// Sets the rest angle (radians).
    pub fn with_rest_angle(mut self, angle: f32) -> Self {
        self.rest_angle = Some(angle);
        self
    }

    /// Sets the compliance.
    pub fn with_compliance(mut self, compliance: f32) -> Self {
        self.stiffness = Stiffness::Compliance(compliance);
        self
    }

    /// Sets the stiffness.
    pub fn with_stiffness(mut self, stiffness: Stiffness) -> Self {
        self.stiffness = stiffness;
        self
    }

    /// Measures the unsigned 3D angle instead of the signed one about an axis.
    pub fn unsigned(mut self) -> Self {
        self.axis = None;
        self
    }
}

bevy::reflect::impl_reflect_opaque!((in bevy_verlet_physics::solver) StickKind(
    Clone, Debug, Default, PartialEq, Hash
));
