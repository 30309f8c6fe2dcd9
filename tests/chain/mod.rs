//! A pinned chain on the solver core, shared by the core-level integration tests.

use bevy_verlet_physics::solver::{Solver, StickKind};
use glam::DVec3;

/// Adds a chain of `links` rigid sticks, `length` long in all, pinned at the origin and laid
/// out along `direction` (a unit vector), its last particle `tip_ratio` times as heavy as a
/// link's (1 kg); returns that last particle.
pub fn chain_along(
    solver: &mut Solver,
    (links, length): (usize, f64),
    tip_ratio: f64,
    direction: DVec3,
) -> u32 {
    let link = length / links as f64;
    let pin = solver.add_particle(DVec3::ZERO, 0.0);
    solver.pin(pin, DVec3::ZERO);
    let mut previous = pin;
    for i in 1..=links {
        let w = if i == links { 1.0 / tip_ratio } else { 1.0 };
        let p = solver.add_particle(direction * (link * i as f64), w);
        solver
            .sticks
            .push([previous, p], link, 0.0, StickKind::Equal, f64::INFINITY, 0);
        previous = p;
    }
    previous
}
