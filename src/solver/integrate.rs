//! Verlet integration (Jakobsen 2001, §"Verlet integration").
//!
//! `x' = x + (x − x*)·d + a·h²`, then `x* = x`. The damping factor `d = exp(−c·h)` is the exact
//! solution of `v' = −c·v` over one substep, so the damping rate `c` (1/s) means the same thing at
//! every substep count and frame rate (the seeds' per-step `0.99` does not). Gravity is not
//! multiplied by ½ (the Tuts+ seed's `½·a·dt²` in a position-Verlet recurrence halves gravity).
//!
//! Immovable particles (`inverse_mass == 0`) do not move here; kinematic ones are placed on their
//! pin targets by [`Pins::drive`](super::Pins::drive) right after.

use super::Particles;
use super::shared::Shared;
use glam::DVec3;
use std::ops::Range;

/// Advances every movable particle by one substep of length `h` under `gravity`, with the
/// per-substep velocity factor `damping_factor` (`1.0` = no damping).
///
/// ```
/// use bevy_verlet_physics::solver::{integrate, Particles};
/// use glam::DVec3;
/// let mut p = Particles::default();
/// p.push(DVec3::ZERO, DVec3::ZERO, 1.0, 0.0, 0);
/// integrate(&mut p, DVec3::new(0.0, -10.0, 0.0), 0.1, 1.0);
/// assert!((p.position[0].y + 0.1).abs() < 1e-12); // a·h² = −10 · 0.01
/// ```
pub fn integrate(particles: &mut Particles, gravity: DVec3, h: f64, damping_factor: f64) {
    let range = 0..particles.len();
    integrate_range(
        &Shared::new(&mut particles.position),
        &Shared::new(&mut particles.previous),
        &particles.inverse_mass,
        range,
        gravity,
        h,
        damping_factor,
    );
}

/// [`integrate`] over the particles in `range` (which no other task touches).
pub(crate) fn integrate_range(
    position: &Shared<DVec3>,
    previous: &Shared<DVec3>,
    inverse_mass: &[f64],
    range: Range<usize>,
    gravity: DVec3,
    h: f64,
    damping_factor: f64,
) {
    let step = gravity * (h * h);
    for i in range {
        let current = position.get(i);
        if inverse_mass[i] > 0.0 {
            position.set(
                i,
                current + (current - previous.get(i)) * damping_factor + step,
            );
        }
        previous.set(i, current);
    }
}

/// The previous position that makes a particle at `position` with instantaneous velocity
/// `velocity` follow the exact constant-acceleration curve `x₀ + v₀t + ½at²` under Verlet with
/// substep `h` (Dummer 2005: `x₋₁ = x₀ − v₀h + ½ah²`). The seeds' `x₋₁ = x₀` instead lags the exact
/// curve by half a step of velocity.
///
/// ```
/// use bevy_verlet_physics::solver::consistent_previous;
/// use glam::DVec3;
/// let prev = consistent_previous(DVec3::ZERO, DVec3::ZERO, DVec3::new(0.0, -10.0, 0.0), 0.1);
/// assert!((prev.y + 0.05).abs() < 1e-12);
/// ```
pub fn consistent_previous(position: DVec3, velocity: DVec3, acceleration: DVec3, h: f64) -> DVec3 {
    position - velocity * h + acceleration * (0.5 * h * h)
}

/// Re-expresses the Verlet state of the particles in `range` for substeps of `to` seconds
/// instead of `from`: each keeps its velocity `v = (x − x*)/h + a·h/2` (`a` = `gravity` for
/// movable particles, as in [`consistent_previous`]), and gets `x* = x − v·to + a·to²/2`; one
/// placed at rest (`x* = x`, as [`Solver::add_particle`](super::Solver::add_particle), pins
/// and sleep leave it) stays so. A
/// Verlet state holds the velocity times the substep, so without this a particle whose island
/// changes its substep count (an `IslandOverride`, a new `VerletConfig::substeps`, `line_substeps`
/// or a hit that suspends it) would change
/// speed by their ratio.
///
/// ```
/// use bevy_verlet_physics::solver::{resubstep, Particles};
/// use glam::DVec3;
/// let mut p = Particles::default();
/// p.push(DVec3::ZERO, DVec3::new(-0.1, 0.0, 0.0), 1.0, 0.0, 0); // 1 m/s at h = 0.1 s
/// resubstep(&mut p, 0..1, DVec3::ZERO, 0.1, 0.025);
/// assert!((p.previous[0].x + 0.025).abs() < 1e-15); // still 1 m/s at h = 0.025 s
/// ```
pub fn resubstep(
    particles: &mut Particles,
    range: Range<usize>,
    gravity: DVec3,
    from: f64,
    to: f64,
) {
    if from == to || from <= 0.0 || to <= 0.0 {
        return;
    }
    for i in range {
        let x = particles.position[i];
        if particles.previous[i] == x {
            continue; // placed at rest (`add_particle`, a pin, sleep): at rest in any substep
        }
        let a = if particles.inverse_mass[i] > 0.0 {
            gravity
        } else {
            DVec3::ZERO
        };
        let velocity = (x - particles.previous[i]) / from + a * (0.5 * from);
        particles.previous[i] = consistent_previous(x, velocity, a, to);
    }
}
