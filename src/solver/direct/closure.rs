//! Curvature and full Newton passes for a line pinned at both ends: the stick to the second pin
//! closes a loop, and its multiplier is solved by a Schur complement of one row.
//!
//! # Why
//! Gauss–Newton passes along the current directions do not converge where a heavy load hangs
//! between two pins (a weight 10⁴ times a link on a V of rope stretched it 1500 % at 8 × 1): the
//! constraints' curvature, which the load's tension makes large, is left out (see
//! [`curvature`](super::curvature)). The curvature elimination runs from a free end towards
//! one root; a second immovable end has no free side to start from.
//!
//! # How
//! Leave out the last stick `c` (from the second pin `P` to the particle `L` it holds) and
//! eliminate the rest from `L` towards the first pin as usual, with `c`'s curvature `μ_c P_c`
//! and force `λ_c n_c` added to `L`'s equation. The step is affine in `c`'s multiplier change:
//! `Δx = Δx⁰ + Δλ_c Δx¹`, where `Δx¹` answers a unit force `n_c` on `L` — a second right-hand
//! side carried through the same elimination ([`Reduced::carry`](kkt::Reduced::carry)), two
//! vectors and a scalar per stick. A back substitution without moving anything gives `Δx⁰_L`
//! and `Δx¹_L`; `c`'s linearised constraint `n_c·Δx_L + α̃ Δλ_c = −(C_c + α̃ λ_c)` then gives
//! `Δλ_c = (b_c − n_c·Δx⁰_L) / (n_c·Δx¹_L + α̃)` ([`kkt::closing_step`]), and a second back
//! substitution applies both parts. That is the Newton step of the whole system, as the
//! dense KKT solve gives it (tested below), in three traversals instead of two.
//!
//! Every pivot is the one-rooted elimination's: the line without `c` has a free end, so
//! nothing is divided by a pivot that the second pin makes small. Only the Schur complement
//! `n_c·Δx¹_L` — how far a unit pull along `c` moves `L` — goes to zero, and it does so where
//! the whole system is singular: a line pulled straight between its pins, which is swept
//! instead (see [`LineMode::Sweep`](super::LineMode::Sweep)). (An earlier attempt eliminated
//! `c` together with `L`'s own stick: its pivot vanished wherever the two sticks ran nearly
//! straight into each other, taut or not, and its errors grew to 10⁵–10¹⁰ there.)
//!
//! This is how a tree-structured direct solver takes loops (Baraff 1996, "Linear-time dynamics
//! using Lagrange multipliers": `k` auxiliary one-dimensional constraints that close loops, at
//! `O(kn)`, through the loop-free system's factorisation and a `k × k` system; here `k = 1`).

use super::super::kkt::{self, Link};
use super::curvature::Root;
use super::{LineRef, LineSolve};
use glam::DVec3;

impl LineSolve<'_, '_> {
    /// One full Newton pass over a line pinned at both ends ([`Root::Both`]); `MOVED` as for
    /// [`LineSolve::curvature_forward`].
    ///
    /// # Safety
    /// As for [`LineSolve::curvature_pass`] (`MOVED = false`) or [`LineSolve::full_newton`]
    /// (`MOVED = true`), and `curvature_root` gave [`Root::Both`] (so `m ≥ 2`).
    pub(super) unsafe fn closed_pass<const MOVED: bool>(&self, line: &LineRef) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (caller).
        unsafe {
            let m = line.sticks.len();
            let closing = self.closing_link::<MOVED>(line);
            // Leaf (the held particle) to root, with the unit load along the closing stick.
            let mut below = kkt::closing_load(&closing);
            let mut load_up = closing.normal;
            for t in 2..=m {
                let (link, k) = self.curvature_input::<MOVED>(line, Root::Both, t);
                let (reduced, load);
                (reduced, below) = kkt::reduce(&link, &below);
                (load, load_up) = reduced.carry(link.normal, load_up);
                let at = line.offset + k;
                self.scratch.curvature.set_unchecked(at, reduced);
                self.scratch.loads.set_unchecked(at, load);
            }
            // (The root is immovable: `Δx = 0` there.)
            let (held, held_unit) = self.held_steps(line);
            let d_closing = kkt::closing_step(&closing, held, held_unit);
            let mut dx = DVec3::ZERO;
            for t in (2..=m).rev() {
                let (c, k, _) = self.curvature_link(line, Root::Both, t);
                let at = line.offset + k;
                let reduced = self.scratch.curvature.get_unchecked(at);
                let load = self.scratch.loads.get_unchecked(at);
                let d_lambda;
                (d_lambda, dx) = reduced.substitute_loaded(&load, d_closing, dx);
                let s = line.s(k);
                self.lambda
                    .set_unchecked(s, self.lambda.get_unchecked(s) + d_lambda);
                self.shift(c, dx);
            }
            let s = line.s(m - 1);
            self.lambda
                .set_unchecked(s, self.lambda.get_unchecked(s) + d_closing);
        }
    }

    /// The closing stick (the line's last) as [`kkt`] reads it: from the second pin to the
    /// particle it holds.
    ///
    /// # Safety
    /// As for [`LineSolve::closed_pass`].
    unsafe fn closing_link<const MOVED: bool>(&self, line: &LineRef) -> Link {
        // SAFETY: in bounds (caller).
        unsafe {
            let (mut link, _) = self.curvature_input::<MOVED>(line, Root::Both, 1);
            link.normal = -link.normal;
            link.inverse_mass = self.w(line.p(line.sticks.len() - 1));
            link
        }
    }

    /// The held particle's step without the closing multiplier's change, and its response to a
    /// unit change: a back substitution that moves nothing.
    ///
    /// # Safety
    /// As for [`LineSolve::closed_pass`], whose elimination ran just before.
    unsafe fn held_steps(&self, line: &LineRef) -> (DVec3, DVec3) {
        // SAFETY: in bounds (caller).
        unsafe {
            let m = line.sticks.len();
            let (mut dx, mut dx_unit) = (DVec3::ZERO, DVec3::ZERO);
            for t in (2..=m).rev() {
                let at = line.offset + m - t;
                let reduced = self.scratch.curvature.get_unchecked(at);
                dx = reduced.substitute(dx).1;
                dx_unit = reduced
                    .substitute_load(&self.scratch.loads.get_unchecked(at), dx_unit)
                    .1;
            }
            (dx, dx_unit)
        }
    }
}
