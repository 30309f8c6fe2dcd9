//! The [`Particle`] component: a point mass moved by the solver.

use bevy::prelude::*;

/// A point mass moved by the Verlet solver.
///
/// Velocity is implicit, as in Verlet: `velocity = (position − previous_position) / Δt`, where
/// `Δt` is the fixed timestep. After every fixed step the plugin writes the new `position` and
/// the position one step earlier into `previous_position` (so the two bracket the last step, which
/// is also what render interpolation needs).
///
/// Writing to the component moves the particle: changing `position` alone gives it the velocity
/// of that move (how the Tuts+ curtain drags cloth); [`Particle::set_position`] moves it without
/// a velocity kick (the AS3 `setPosition`), [`Particle::set_velocity`] changes only the velocity.
/// When a particle is spawned or edited, `(position − previous_position)/Δt` is taken as its
/// velocity *at that instant*, and the solver starts it on the exact constant-acceleration curve
/// (not the seeds' `x_prev = x`, which lags by half a step of velocity).
///
/// The solver keeps its own `f64` copy of the state, so reading these `f32` fields never costs
/// accuracy, even at 10⁶ px from the origin. Only a real change of `position` or
/// `previous_position` moves the particle: a system that takes `&mut Particle` and writes the
/// same values (or only `inverse_mass` / `radius`) leaves its motion and its sleep alone.
///
/// A particle entity that has a `Transform` gets it written every frame, interpolated between
/// fixed steps, so `(Particle, Sprite)` or `(Particle, Mesh3d)` (both require a `Transform`)
/// draws where the particle is. Builders spawn bare particles: insert a `Transform` or a sprite
/// on `composite.particles` to opt in; particles without one cost nothing.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut particle = Particle::new(Vec3::new(0.0, 2.0, 0.0)).with_mass(2.0);
/// assert_eq!(particle.inverse_mass, 0.5);
/// particle.set_velocity(Vec3::X, 1.0 / 64.0);
/// assert!((particle.velocity(1.0 / 64.0) - Vec3::X).length() < 1e-5);
/// ```
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default, Debug, Clone)]
pub struct Particle {
    /// Current position (world space).
    pub position: Vec3,
    /// Position one fixed step ago.
    pub previous_position: Vec3,
    /// `1 / mass`; `0` makes the particle immovable (an anchor that constraints cannot move).
    pub inverse_mass: f32,
    /// Collision radius for colliders (`0` = a point).
    pub radius: f32,
    /// Slot in the solver's arrays (maintained by the plugin).
    #[reflect(ignore)]
    pub(crate) slot: u32,
}

/// Slot value of a particle the solver has not taken in yet.
pub(crate) const NO_SLOT: u32 = u32::MAX;

impl Default for Particle {
    fn default() -> Self {
        Self::new(Vec3::ZERO)
    }
}

impl Particle {
    /// A particle of mass 1 at rest at `position`.
    pub fn new(position: Vec3) -> Self {
        Self {
            position,
            previous_position: position,
            inverse_mass: 1.0,
            radius: 0.0,
            slot: NO_SLOT,
        }
    }

    /// Sets the mass (`f32::INFINITY` makes it immovable). A mass ≤ 0 or NaN is rejected by the
    /// solver with a warning and treated as 1.
    pub fn with_mass(mut self, mass: f32) -> Self {
        self.inverse_mass = 1.0 / mass;
        self
    }

    /// Sets the inverse mass directly (`0` = immovable).
    pub fn with_inverse_mass(mut self, inverse_mass: f32) -> Self {
        self.inverse_mass = inverse_mass;
        self
    }

    /// Sets the collision radius.
    pub fn with_radius(mut self, radius: f32) -> Self {
        self.radius = radius;
        self
    }

    /// Starts the particle with `velocity`, for a fixed timestep `dt` (usually
    /// `Time::<Fixed>::timestep().as_secs_f32()`, 1/64 s by default).
    pub fn with_velocity(mut self, velocity: Vec3, dt: f32) -> Self {
        self.set_velocity(velocity, dt);
        self
    }

    /// Mass (`INFINITY` when immovable).
    pub fn mass(&self) -> f32 {
        1.0 / self.inverse_mass
    }

    /// Velocity over the last fixed step of length `dt`.
    pub fn velocity(&self, dt: f32) -> Vec3 {
        (self.position - self.previous_position) / dt
    }

    /// Sets the velocity (keeps the position).
    pub fn set_velocity(&mut self, velocity: Vec3, dt: f32) {
        self.previous_position = self.position - velocity * dt;
    }

    /// Moves the particle to `position` and stops it: no velocity kick (AS3 `setPosition`).
    pub fn set_position(&mut self, position: Vec3) {
        self.position = position;
        self.previous_position = position;
    }

    /// Moves the particle by `offset`, keeping its velocity (a teleport).
    pub fn translate(&mut self, offset: Vec3) {
        self.position += offset;
        self.previous_position += offset;
    }

    /// Position interpolated between the last two fixed steps (`fraction` = 0 → previous,
    /// 1 → current); pass `Time::<Fixed>::overstep_fraction()` for smooth rendering.
    pub fn interpolated(&self, fraction: f32) -> Vec3 {
        self.previous_position.lerp(self.position, fraction)
    }
}

/// Marks a particle that should get long-range tethers to its nearest pins (Kim et al. 2012;
/// [`VerletConfig::tether_anchors`](crate::VerletConfig::tether_anchors) of them, two by
/// default), which removes the stretch of long ropes and curtains at no extra iterations.
/// Tethers are rebuilt whenever the topology changes, including after a tear.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut world = World::new();
/// world.spawn((Particle::new(Vec3::ZERO), Tethered));
/// ```
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Component, Default, Debug)]
pub struct Tethered;
