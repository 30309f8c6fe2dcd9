//! Symmetric sweeps for islands whose masses differ widely: forward, then backward.
//!
//! # Why
//! One Gauss–Seidel sweep projects the sticks one after the other in a fixed order. Linearised
//! about the constraints, projecting stick `i` is the mass-weighted orthogonal projection `Qᵢ`
//! onto its hyperplane, so a forward sweep maps the substep's prediction `y` to `P y` with
//! `P = Q_m ⋯ Q₁`, and Verlet feeds it the last two positions: `x_{n+1} = P (2 x_n − x_{n−1})`.
//! Along an eigenvector of `P` with eigenvalue `μ` a deviation from the constraints grows as
//! `zⁿ`, where `z² − 2 μ z + μ = 0`. For a real `μ` in `[0, 1]` both roots have `|z|² = μ ≤ 1`:
//! stable. But a forward sweep is not self-adjoint (its adjoint, `Q₁ ⋯ Q_m`, is the backward
//! sweep), its eigenvalues can be complex, and then one root leaves the unit circle
//! (`μ = 0.5 i` gives `|z| = 1.2`): a mode that grows a little in every substep, without any
//! input of energy. It shows where a sweep converges slowly — heavy particles hanging on light
//! ones put `μ` near 1, where a small imaginary part is enough. Measured at 8 × 1 (scratch
//! scans, release): 10 × 10 cloths of 5 cm sticks hung by two corners, 15 % of their particles
//! 100 times heavier, kicked by up to 30 m/s — 2 of 100 grew to 10²¹ times their energy scale
//! within 10 s (10¹⁴⁶ by 60 s); 1000 times heavier and kicked by up to 100 m/s, 50 of 100.
//! Random trees of 5 cm sticks closed by three loops each (so swept under [`Method::Auto`]),
//! 15 % of their particles `r` times heavier, 1023 scenes: kicked by up to 30 m/s, one grew to
//! 10⁶⁹ link lengths within 10 s at `r = 30`, four at 100, eight at 1000; kicked by up to
//! 100 m/s, one went to NaN within 5 s at `r = 13`; at `r ≤ 10` none in 60 s.
//!
//! # What the solver does
//! A forward sweep followed by a backward one — symmetric Gauss–Seidel, SSOR with ω = 1
//! (Barrett et al., *Templates for the Solution of Linear Systems*, SIAM 1994, §2.2.4) — is
//! `P = R R*` with `R = Q₁ ⋯ Q_m`: self-adjoint in the mass-weighted inner product, its
//! eigenvalues real and in `[0, 1]`, so the recurrence above cannot grow (`μ = 1`, along the
//! constraints, is free motion). An island solved by sweeps whose heaviest
//! movable particle is more than [`StepConfig::symmetric_mass_ratio`] times its lightest
//! ([`SYMMETRIC_MASS_RATIO`] = 8 by default, below the 13 seen to grow) runs its iterations in
//! forward–backward pairs: one iteration becomes two (twice the sweep's cost), three become
//! four, two cost nothing more. Its XPBD multipliers then accumulate across the pair, as with
//! any two iterations. The same scenes swept symmetrically: none grows — the cloths' energy
//! stays within 0.95 times their scale of its start over 60 s, the trees' within 23 times
//! (kicked by 100 m/s; 9 at 30 m/s). Every other island sweeps forward only, as before
//! (bit-identical results); islands solved by lines are exact (their rare fallback sweeps, a
//! taut segment or an unconverged projection, stay forward).
//!
//! Angle constraints, tethers and a hierarchy's coarse passes run forward in every round, so
//! for an island that has them a pair is no longer exactly `R R*` and the argument above holds
//! for its sticks alone. Measured (release scratch scans, 8 × 1, 10 s): 40 × 40 cloths of 5 cm
//! on two corners (a hierarchy under `Auto`), 15 % of their particles 1000× heavier, kicked by
//! up to 30 m/s — forward alone 16 of 20 grew beyond 100 times their scale (up to 8·10¹⁹),
//! swept forward and back none rose above its start; 10 × 10 tethered weighted cloths grew in
//! neither.
//!
//! Tests: `tests/symmetric_sweeps.rs` (weighted cloths on two corners, forward alone against
//! symmetric; islands within the ratio bit-identical to forward sweeps; 1, 2 and 4 threads the
//! same bits) and `a_weighted_hammock_swung_hard_never_blows_up` in `tests/hard_cases.rs`.
//!
//! The mass ratio is measured at the start of every step (one pass over an awake island's
//! inverse masses), so it follows pins and mass edits made in place: +0.55 % instructions on a
//! swept 50 × 50 cloth at 8 × 1, +1.2 % on a swept 200-link chain (callgrind, release).
//!
//! ```
//! use bevy_verlet_physics::solver::{Solver, StepConfig, StickKind};
//! use glam::DVec3;
//! // A triangle of sticks holding a 100× heavier particle: swept forward and back.
//! let mut solver = Solver::default();
//! for (x, w) in [(0.0, 1.0), (1.0, 1.0), (0.5, 0.01)] {
//!     solver.add_particle(DVec3::new(x, 0.0, 0.0), w);
//! }
//! for ends in [[0, 1], [1, 2], [2, 0]] {
//!     solver.sticks.push(ends, 0.5, 0.0, StickKind::Equal, f64::INFINITY, 0);
//! }
//! solver.organize();
//! solver.step(&StepConfig::default());
//! assert!(solver.islands.list[0].symmetric);
//! ```
//!
//! [`Method::Auto`]: super::Method::Auto
//! [`StepConfig::symmetric_mass_ratio`]: super::StepConfig::symmetric_mass_ratio

use super::Substep;
use super::sticks::SweepOrder;

/// The default [`StepConfig::symmetric_mass_ratio`](super::StepConfig::symmetric_mass_ratio):
/// islands whose movable particles' masses differ by more than this factor are swept forward
/// and back (see the [module docs](self)).
///
/// ```
/// use bevy_verlet_physics::solver::{StepConfig, SYMMETRIC_MASS_RATIO};
/// assert_eq!(StepConfig::default().symmetric_mass_ratio, SYMMETRIC_MASS_RATIO);
/// ```
pub const SYMMETRIC_MASS_RATIO: f64 = 8.0;

/// The ratio of the largest to the smallest mass among the movable particles (inverse mass
/// above 0) of `inverse_mass`; 1 when there are none.
pub(crate) fn mass_ratio(inverse_mass: &[f64]) -> f64 {
    // (Inverse masses: the lightest particle has the largest. Four lanes of branch-free
    // selects, which the compiler turns into vector max/min: this runs every step.)
    let (mut of_lightest, mut of_heaviest) = ([0.0f64; 4], [f64::INFINITY; 4]);
    let (lanes, remainder) = inverse_mass.as_chunks::<4>();
    for chunk in lanes {
        for k in 0..4 {
            let w = chunk[k];
            of_lightest[k] = if w > of_lightest[k] {
                w
            } else {
                of_lightest[k]
            };
            let movable = if w > 0.0 { w } else { f64::INFINITY };
            of_heaviest[k] = if movable < of_heaviest[k] {
                movable
            } else {
                of_heaviest[k]
            };
        }
    }
    for &w in remainder.iter().filter(|&&w| w > 0.0) {
        of_lightest[0] = of_lightest[0].max(w);
        of_heaviest[0] = of_heaviest[0].min(w);
    }
    let of_lightest = of_lightest.into_iter().fold(0.0, f64::max);
    let of_heaviest = of_heaviest.into_iter().fold(f64::INFINITY, f64::min);
    if of_lightest > 0.0 {
        of_lightest / of_heaviest
    } else {
        1.0
    }
}

/// `substep` for an island swept symmetrically: its iterations rounded up to forward–backward
/// pairs, multipliers accumulated across them unless `plain` (plain PBD never accumulates).
pub(crate) fn in_pairs(mut substep: Substep, plain: bool) -> Substep {
    substep.iterations = substep.iterations.next_multiple_of(2);
    substep.accumulate = !plain;
    substep
}

/// The order of round `round` (0-based) of an island's sweeps: every second round of a
/// symmetric island runs backward.
pub(crate) fn order_of(symmetric: bool, round: u32) -> SweepOrder {
    if symmetric && round % 2 == 1 {
        SweepOrder::Backward
    } else {
        SweepOrder::Forward
    }
}

/// The `k`-th of `items` visited in `order` (a backward round visits an island's colour batches
/// last to first).
pub(crate) fn nth_in<T>(order: SweepOrder, items: &[T], k: usize) -> &T {
    match order {
        SweepOrder::Forward => &items[k],
        SweepOrder::Backward => &items[items.len() - 1 - k],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mass_ratio_counts_movable_particles_only() {
        assert_eq!(mass_ratio(&[0.0, 1.0, 0.25, 0.5]), 4.0);
        assert_eq!(mass_ratio(&[0.0, 0.0]), 1.0);
        assert_eq!(mass_ratio(&[]), 1.0);
        assert_eq!(mass_ratio(&[0.5]), 1.0);
    }

    #[test]
    fn rounds_come_in_forward_backward_pairs() {
        let substep = crate::solver::StepConfig::default().substep_context(1);
        for (iterations, rounds) in [(1, 2), (2, 2), (3, 4)] {
            let paired = in_pairs(
                Substep {
                    iterations,
                    ..substep
                },
                false,
            );
            assert_eq!(paired.iterations, rounds);
            assert!(paired.accumulate);
        }
        assert!(!in_pairs(substep, true).accumulate);
        let orders: Vec<_> = (0..4).map(|round| order_of(true, round)).collect();
        use SweepOrder::{Backward, Forward};
        assert_eq!(orders, [Forward, Backward, Forward, Backward]);
        assert!((0..4).all(|round| order_of(false, round) == Forward));
        assert_eq!(
            (
                nth_in(Forward, &[1, 2, 3], 0),
                nth_in(Backward, &[1, 2, 3], 0)
            ),
            (&1, &3)
        );
    }
}
