//! Ragdolls after the Tuts+ "Curtain" ragdolls (J. Counts, `Body.pde`), done better.
//!
//! Eleven particles with the original masses (head 4, shoulder 26, elbows 2, hands 2, pelvis 15,
//! knees 10, feet 5) and lengths in units of the head length `hl = height / 7.5`. Differences
//! from the seed:
//! * the neck is `1.25·hl` as the seed meant (its `5/4` is Java integer division = 1);
//! * the body spawns in a standing pose instead of all points within ±5 px of one spot (a
//!   collapsed start the constraints then blow apart);
//! * the seed's soft links (torso 0.8, "invisible" pelvis–head 0.02 and foot–shoulder 0.001,
//!   tuned at 3 passes per 16 ms step) become [`Stiffness::Seed`]
//!   compliances, so they feel the same at any substep count;
//! * elbows and knees get joint limits: one-sided (at-least) sticks between the outer
//!   particles whose length comes from the law of cosines, `√(A² + B² − 2AB·cos θ_min)` — the
//!   method the article describes but the seed does not use;
//! * the head is a particle with a collision radius (the seed's `Circle`), so it collides with
//!   every collider, not only the window edges.

use super::{Composite, Material, spawn_composite};
use crate::{Stick, StickKind, Stiffness};
use bevy::prelude::*;

/// Particle order of a ragdoll's [`Composite::particles`].
pub mod part {
    /// Head (radius 0.75·hl).
    pub const HEAD: usize = 0;
    /// Shoulder (neck base).
    pub const SHOULDER: usize = 1;
    /// Left elbow.
    pub const LEFT_ELBOW: usize = 2;
    /// Right elbow.
    pub const RIGHT_ELBOW: usize = 3;
    /// Left hand.
    pub const LEFT_HAND: usize = 4;
    /// Right hand.
    pub const RIGHT_HAND: usize = 5;
    /// Pelvis.
    pub const PELVIS: usize = 6;
    /// Left knee.
    pub const LEFT_KNEE: usize = 7;
    /// Right knee.
    pub const RIGHT_KNEE: usize = 8;
    /// Left foot.
    pub const LEFT_FOOT: usize = 9;
    /// Right foot.
    pub const RIGHT_FOOT: usize = 10;

    /// The rigid bones (the seed's stiffness-1 links), as pairs of the indices above. They are
    /// the ragdoll's first sticks, in this order.
    pub const BONES: [(usize, usize); 9] = [
        (HEAD, SHOULDER),
        (SHOULDER, LEFT_ELBOW),
        (SHOULDER, RIGHT_ELBOW),
        (LEFT_ELBOW, LEFT_HAND),
        (RIGHT_ELBOW, RIGHT_HAND),
        (PELVIS, LEFT_KNEE),
        (PELVIS, RIGHT_KNEE),
        (LEFT_KNEE, LEFT_FOOT),
        (RIGHT_KNEE, RIGHT_FOOT),
    ];
}

/// The seed's stiffness setting: 3 relaxation passes per 16 ms step.
fn seed(stiffness: f32) -> Stiffness {
    Stiffness::Seed {
        stiffness,
        iterations: 3,
        timestep: 0.016,
    }
}

/// Marks a stick that is part of the physics but not drawn (the seed's "invisible links").
///
/// ```
/// use bevy_verlet_physics::prelude::*;
/// let _ = HiddenStick;
/// ```
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Component, Default, Debug)]
pub struct HiddenStick;

/// Spawns a ragdoll standing with its feet at `feet` (2D, Y up), `height` tall from feet to
/// shoulders (the seed's `bodyHeight`), with masses scaled by `mass_scale` (1 = the seed's
/// 83 units).
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut world = World::new();
/// let doll = RagdollBuilder::new(Vec3::new(0.0, -300.0, 0.0), 120.0).spawn(&mut world.commands());
/// assert_eq!(doll.particles.len(), 11);
/// ```
#[derive(Clone, Debug)]
pub struct RagdollBuilder {
    feet: Vec3,
    height: f32,
    mass_scale: f32,
    elbow_limit: f32,
    knee_limit: f32,
    mirror: bool,
    #[cfg(feature = "gizmos")]
    color: Option<Color>,
}

impl RagdollBuilder {
    /// A ragdoll `height` tall standing on `feet`.
    pub fn new(feet: Vec3, height: f32) -> Self {
        Self {
            feet,
            height,
            mass_scale: 1.0,
            elbow_limit: 25f32.to_radians(),
            knee_limit: 35f32.to_radians(),
            mirror: false,
            #[cfg(feature = "gizmos")]
            color: None,
        }
    }

    /// Scales every mass (the seed's total is 83).
    pub fn mass_scale(mut self, scale: f32) -> Self {
        self.mass_scale = scale;
        self
    }

    /// Smallest elbow and knee angles (radians) the joint limits allow.
    pub fn joint_limits(mut self, elbow: f32, knee: f32) -> Self {
        self.elbow_limit = elbow;
        self.knee_limit = knee;
        self
    }

    /// Mirrors the pose left–right (for variety when spawning many).
    pub fn mirrored(mut self, mirror: bool) -> Self {
        self.mirror = mirror;
        self
    }

    /// Debug colour.
    #[cfg(feature = "gizmos")]
    pub fn color(mut self, color: impl Into<Color>) -> Self {
        self.color = Some(color.into());
        self
    }

    /// Head length `hl = height / 7.5`, the unit of every length.
    pub fn head_length(&self) -> f32 {
        self.height / 7.5
    }

    /// Spawns it; particles are ordered as in [`part`].
    pub fn spawn(&self, commands: &mut Commands) -> Composite {
        use part::*;
        let hl = self.head_length();
        let s = if self.mirror { -1.0 } else { 1.0 };
        let at = |x: f32, y: f32| self.feet + Vec3::new(s * x * hl, y * hl, 0.0);
        // Standing pose; lengths match the links below.
        let pelvis = at(0.0, 4.0);
        let shoulder = at(0.0, 7.5);
        let arm = |side: f32, elbow_dx: f32| {
            let elbow = shoulder
                + Vec3::new(
                    s * side * elbow_dx * hl,
                    -(1.5f32.powi(2) - elbow_dx.powi(2)).sqrt() * hl,
                    0.0,
                );
            let hand = elbow + Vec3::new(s * side * 0.6 * hl, -(4.0f32 - 0.36).sqrt() * hl, 0.0);
            (elbow, hand)
        };
        let (left_elbow, left_hand) = arm(-1.0, 0.5);
        let (right_elbow, right_hand) = arm(1.0, 0.7);
        let leg = |side: f32| {
            let knee = pelvis + Vec3::new(s * side * 0.4 * hl, -(4.0f32 - 0.16).sqrt() * hl, 0.0);
            let foot = knee + Vec3::new(s * side * 0.1 * hl, -(4.0f32 - 0.01).sqrt() * hl, 0.0);
            (knee, foot)
        };
        let (left_knee, left_foot) = leg(-1.0);
        let (right_knee, right_foot) = leg(1.0);
        let points = [
            shoulder + Vec3::new(0.0, 1.25 * hl, 0.0),
            shoulder,
            left_elbow,
            right_elbow,
            left_hand,
            right_hand,
            pelvis,
            left_knee,
            right_knee,
            left_foot,
            right_foot,
        ];
        let masses = [4.0, 26.0, 2.0, 2.0, 2.0, 2.0, 15.0, 10.0, 10.0, 5.0, 5.0];
        let material = Material {
            #[cfg(feature = "gizmos")]
            color: self.color,
            ..Material::default()
        };
        let mut composite = spawn_composite(
            commands,
            "Ragdoll",
            &material,
            &points,
            &[false; 11],
            &BONES,
        );
        let p = composite.particles.clone();
        for (i, &entity) in p.iter().enumerate() {
            let mut particle =
                crate::Particle::new(points[i]).with_mass(masses[i] * self.mass_scale);
            if i == HEAD {
                particle = particle.with_radius(0.75 * hl);
            }
            commands.entity(entity).insert(particle);
        }
        let root = composite.root;
        let mut add = |commands: &mut Commands, stick: Stick, hidden: bool| {
            let mut entity = commands.spawn((stick, ChildOf(root)));
            if hidden {
                entity.insert(HiddenStick);
            }
            composite.sticks.push(entity.id());
        };
        // The seed's soft torso.
        add(
            commands,
            Stick::new(p[SHOULDER], p[PELVIS]).with_stiffness(seed(0.8)),
            false,
        );
        // Invisible posture links: keep the head from tilting, resist folding the legs up.
        add(
            commands,
            Stick::new(p[PELVIS], p[HEAD]).with_stiffness(seed(0.02)),
            true,
        );
        add(
            commands,
            Stick::new(p[LEFT_FOOT], p[SHOULDER]).with_stiffness(seed(0.001)),
            true,
        );
        add(
            commands,
            Stick::new(p[RIGHT_FOOT], p[SHOULDER]).with_stiffness(seed(0.001)),
            true,
        );
        // Joint limits by the law of cosines: the outer particles may not come closer than the
        // distance that makes the joint angle θ_min.
        let limit = |a: f32, b: f32, angle: f32| (a * a + b * b - 2.0 * a * b * angle.cos()).sqrt();
        let elbow = limit(1.5 * hl, 2.0 * hl, self.elbow_limit);
        let knee = limit(2.0 * hl, 2.0 * hl, self.knee_limit);
        for (a, b, rest) in [
            (SHOULDER, LEFT_HAND, elbow),
            (SHOULDER, RIGHT_HAND, elbow),
            (PELVIS, LEFT_FOOT, knee),
            (PELVIS, RIGHT_FOOT, knee),
        ] {
            let strut = Stick::new(p[a], p[b])
                .with_rest_length(rest)
                .with_kind(StickKind::AtLeast);
            add(commands, strut, true);
        }
        commands.entity(root).insert(composite.clone());
        composite
    }
}
