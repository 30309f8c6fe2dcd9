//! [`IslandOverride`]: per-island substeps, iterations and solve method.

use bevy::prelude::*;

/// Gives the island of this particle — every particle connected to it by sticks or angle
/// constraints — its own substep and iteration counts instead of [`VerletConfig`]'s. A ragdoll
/// is fine with fewer than a stiff cloth. If several particles of one island carry an override,
/// the larger counts win. Builders add it to every particle with `.island_override(…)`.
///
/// Islands advance in lockstep: each fixed step runs as many global substeps as the most
/// demanding awake island needs, and every island takes its own count of them, evenly spread.
/// An island tied to a rigid body (a `BodyAttachment`, features `avian2d`/`avian3d`) takes the
/// fewest at least its own that divide that global count, which the bodies take (6 of 8 → 8,
/// 3 of 8 → 4), so that each of its substeps ends with one of theirs and the coupling keeps
/// momentum.
///
/// [`IslandOverride::with_method`] also picks how the island is solved (see [`SolveMethod`]):
/// a cloth hanging from a row of pins is solved exactly by lines at a single substep, for less
/// than the default 8 sweeps cost (the crate README, "Solvers"). Changing the method rebuilds the
/// topology.
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
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// fn spawn(mut commands: Commands) {
///     let cloth = ClothBuilder::new(Vec3::ZERO, 30, 30, 0.05).pin_top_row(1).spawn(&mut commands);
///     // This cloth alone: 1 substep, its rows and columns solved exactly.
///     let exact = IslandOverride::new(1, 1).with_method(SolveMethod::Lines);
///     commands.entity(cloth.particles[0]).insert(exact);
/// }
/// # bevy::ecs::system::assert_is_system(spawn);
/// ```
///
/// [`VerletConfig`]: crate::VerletConfig
/// [`SolveMethod`]: crate::SolveMethod
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Eq)]
#[reflect(Component, Debug, Clone)]
pub struct IslandOverride {
    /// Substeps per fixed step (values below 1 count as 1).
    pub substeps: u32,
    /// Relaxation iterations per substep (values below 1 count as 1).
    pub iterations: u32,
    /// How the island is solved (`None`: as [`VerletConfig::method`](crate::VerletConfig) says).
    pub method: Option<crate::SolveMethod>,
}

impl IslandOverride {
    /// `substeps` × `iterations`, solved as the config says.
    pub fn new(substeps: u32, iterations: u32) -> Self {
        Self {
            substeps,
            iterations,
            method: None,
        }
    }

    /// The same override, solving the island by `method`.
    pub fn with_method(self, method: crate::SolveMethod) -> Self {
        Self {
            method: Some(method),
            ..self
        }
    }
}
