//! A cloth grid on the solver core, shared by the core-level integration tests.

use bevy_verlet_physics::solver::{Solver, StickKind};
use glam::DVec3;

/// An `n × n` cloth (spacing `spacing`, row-major particles and sticks) at `origin`, pinned at
/// `pins` (column, row) pairs.
pub fn cloth(solver: &mut Solver, n: usize, spacing: f64, origin: DVec3, pins: &[(usize, usize)]) {
    let first = solver.particles.len() as u32;
    for row in 0..n {
        for column in 0..n {
            let offset = DVec3::new(column as f64, 0.0, -(row as f64)) * spacing;
            solver.add_particle(origin + offset, 1.0);
        }
    }
    let index = |c: usize, r: usize| first + (r * n + c) as u32;
    for row in 0..n {
        for column in 0..n {
            if column + 1 < n {
                let ends = [index(column, row), index(column + 1, row)];
                solver
                    .sticks
                    .push(ends, spacing, 0.0, StickKind::Equal, f64::INFINITY, 0);
            }
            if row + 1 < n {
                let ends = [index(column, row), index(column, row + 1)];
                solver
                    .sticks
                    .push(ends, spacing, 0.0, StickKind::Equal, f64::INFINITY, 0);
            }
        }
    }
    for &(c, r) in pins {
        let i = index(c, r);
        solver.pin(i, solver.particles.position[i as usize]);
    }
}
