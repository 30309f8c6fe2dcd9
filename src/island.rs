//! [`IslandOverride`]: per-island substeps and iterations.

use bevy::prelude::*;

/// Gives the island of this particle — every particle connected to it by sticks or angle
/// constraints — its own substep and iteration counts instead of [`VerletConfig`]'s. A ragdoll
/// is fine with fewer than a stiff cloth. If several particles of one island carry an override,
/// the larger counts win. Builders add it to every particle with `.island_override(…)`.
///
/// Islands advance in lockstep: each fixed step runs as many global substeps as the most
/// demanding awake island needs, and every island takes its own count of them, evenly spread.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// fn spawn(mut commands: Commands) {
///     let a = commands.spawn((Particle::new(Vec3::ZERO), Pin::at(Vec3::ZERO))).id();
///     let b = commands.spawn((Particle::new(Vec3::X), IslandOverride::new(2, 1))).id();
///     commands.spawn(Stick::new(a, b));
/// }
/// # bevy::ecs::system::assert_is_system(spawn);
/// ```
///
/// [`VerletConfig`]: crate::VerletConfig
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Eq)]
#[reflect(Component, Debug, Clone)]
pub struct IslandOverride {
    /// Substeps per fixed step (values below 1 count as 1).
    pub substeps: u32,
    /// Relaxation iterations per substep (values below 1 count as 1).
    pub iterations: u32,
}

impl IslandOverride {
    /// `substeps` × `iterations`.
    pub fn new(substeps: u32, iterations: u32) -> Self {
        Self {
            substeps,
            iterations,
        }
    }
}
