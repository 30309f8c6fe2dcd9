//! Helpers shared by the avian2d and avian3d suites (each includes this file with `#[path]`).

use bevy::prelude::*;
use bevy_verlet_physics::prelude::*;

/// Spawns `rope` into `app`'s world at once (its entities flushed) and returns it.
pub fn spawn_rope(app: &mut App, rope: RopeBuilder) -> Composite {
    let world = app.world_mut();
    let rope = rope.spawn(&mut world.commands());
    world.flush();
    rope
}

/// Kinetic and potential energy (J, `g` = 9.81 m/s² along −y) of the movable ones of
/// `particles`, from the solver's state (velocity over each particle's own substep).
pub fn particles_energy(app: &App, particles: &[Entity]) -> f64 {
    let state = app.world().resource::<VerletState>();
    let (solver, p) = (&state.solver, &state.solver.particles);
    (particles.iter())
        .filter_map(|&e| state.slot(e))
        .filter(|&slot| p.inverse_mass[slot as usize] > 0.0)
        .map(|slot| {
            let (i, h) = (slot as usize, solver.state_substep_of(slot).unwrap());
            let (m, v) = (1.0 / p.inverse_mass[i], (p.position[i] - p.previous[i]) / h);
            0.5 * m * v.length_squared() + m * 9.81 * p.position[i].y
        })
        .sum()
}
