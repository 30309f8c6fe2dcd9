//! What guards a line whose Newton passes do not converge: the prediction kept at the start
//! of its solve, how far the iterate is from its constraints and from that prediction, and
//! the sweep from the prediction it falls back to ([`LineSolve::fall_back`]). See the [parent
//! module's docs](super).

use super::super::shared::SharedSlice;
use super::{
    Begun, CURVATURE_BELOW, FARTHER_THAN_A_SWEEP, LineRef, LineSolve, NEARLY_ON, THROWN_ABOVE,
    in_system, violation,
};
use glam::DVec3;

impl LineSolve<'_, '_> {
    /// Whether the substep's prediction is within [`CURVATURE_BELOW`] of the constraints: its
    /// error, or else its error with a spring's stretch that its last multiplier balanced left
    /// out (`|C + α̃λ|/L`, one-sided where a stick is, measured only then).
    ///
    /// # Safety
    /// As for [`LineSolve::restore_prediction`], and [`LineSolve::keeps_prediction`] holds.
    pub(super) unsafe fn within_reach(&self, line: &LineRef, begun: &Begun) -> bool {
        // SAFETY: as above (this function's contract).
        begun.predicted < CURVATURE_BELOW || unsafe { self.balanced_error(line) } < CURVATURE_BELOW
    }

    /// The largest `|C + α̃λ|/L` at the kept prediction with the last substep's multipliers,
    /// one-sided where a stick is ([`violation`]).
    ///
    /// # Safety
    /// As for [`LineSolve::restore_prediction`], and [`LineSolve::keeps_prediction`] holds.
    pub(super) unsafe fn balanced_error(&self, line: &LineRef) -> f64 {
        let v = self.scratch;
        let mut worst: f64 = 0.0;
        for (k, &s) in line.sticks.iter().enumerate() {
            let s = s as usize;
            // SAFETY: in bounds (`check`, the caller's contract).
            unsafe {
                let at = |j: usize| v.predicted.get_unchecked(line.particle_offset + j);
                let c = (at(k + 1) - at(k)).length() - self.rest(s);
                let balanced =
                    self.compliance(s) * self.inv_h2 * v.warm.get_unchecked(line.offset + k);
                worst = worst.max(violation(self.kind(s), c + balanced) / self.rest(s).max(1e-12));
            }
        }
        worst
    }

    /// Keeps where the lines solved before this one left its particles, as its prediction for the
    /// fall back (a line sharing particles with others, whose [`LineSolve::begin`] does not keep
    /// it). Apart from `begin`'s loop: stored there, the cloth by lines took 3.7 % more
    /// instructions, and the chains, which do not share particles, 0.6 % more; here 2.1 % and
    /// nothing (callgrind, release, 8 × 1).
    ///
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`].
    #[inline(never)]
    pub(super) unsafe fn keep_entry(&self, line: &LineRef) {
        for (j, &p) in line.particles.iter().enumerate() {
            // SAFETY: in bounds (`check`, the caller's contract).
            unsafe {
                let x = self.position.get_unchecked(p as usize);
                self.scratch
                    .predicted
                    .set_unchecked(line.particle_offset + j, x);
            }
        }
    }

    /// Whether [`LineSolve::begin`] kept the substep's prediction of this line's particles (a
    /// line alone in its island, in the substep's first round).
    pub(super) fn keeps_prediction(&self) -> bool {
        self.first_round && self.alone && self.mirror.is_none()
    }

    /// Whether this line's particles were kept where its solve began (in the substep's first
    /// round, without a mirror): the prediction, kept by [`LineSolve::begin`], where the line is
    /// alone in its island, else where the lines solved before it left them, kept by
    /// [`LineSolve::keep_entry`].
    pub(super) fn keeps_entry(&self) -> bool {
        self.first_round && self.mirror.is_none()
    }

    /// After passes that did not converge and left the line worse off than its prediction: a
    /// sweep from the prediction instead — unless the iterate is finite, within [`NEARLY_ON`]
    /// of its rigid sticks' constraints, nearer them than the sweep ([`LineSolve::violation`])
    /// and not [`FARTHER_THAN_A_SWEEP`] from the prediction: it is then put back, its
    /// multipliers of one-sided sticks out of the system released. See the module's docs. (The
    /// prediction is the kept one: for a line sharing particles with others, where the lines
    /// solved before it left them, see [`LineSolve::keeps_entry`].)
    ///
    /// # Safety
    /// As for [`LineSolve::restore_prediction`].
    pub(super) unsafe fn fall_back(&self, line: &LineRef) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (caller).
        unsafe {
            let (iterate, (moved, _)) = (self.violation(line), self.distances(line));
            // (Kept in the scratch, the positions then put at the prediction.)
            self.swap_iterate(line, true);
            self.restore_prediction(line);
            self.sweep(line);
            let keeps = iterate < NEARLY_ON
                && iterate < self.violation(line)
                && moved <= FARTHER_THAN_A_SWEEP * self.distances(line).0;
            if !keeps {
                return;
            }
            self.swap_iterate(line, false);
            for (k, &s) in line.sticks.iter().enumerate() {
                let s = s as usize;
                let (a, b) = (line.p(k), line.p(k + 1));
                let c = (self.position.get_unchecked(b) - self.position.get_unchecked(a)).length()
                    - self.rest(s);
                if !in_system(self.kind(s), c, self.rest(s)) {
                    self.lambda.set_unchecked(s, 0.0);
                }
            }
        }
    }

    /// The largest violation of the line's rigid sticks at the iterate, `|C|/L` one-sided where
    /// a stick is ([`violation`]; a spring's stretch is its own, sticks between
    /// immovable particles are left out); `∞` where a length is not finite.
    ///
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`].
    pub(super) unsafe fn violation(&self, line: &LineRef) -> f64 {
        // SAFETY: as above (this function's contract).
        unsafe { self.violation_at(line, &self.position) }
    }

    /// [`LineSolve::violation`] with the particles at `x` (the iterate, or the start of the
    /// substep).
    ///
    /// # Safety
    /// As for [`LineSolve::violation`]; `x` is as long as the positions.
    pub(super) unsafe fn violation_at(&self, line: &LineRef, x: &SharedSlice<'_, DVec3>) -> f64 {
        let mut worst: f64 = 0.0;
        for (k, &s) in line.sticks.iter().enumerate() {
            let s = s as usize;
            // SAFETY: in bounds (`check`, the caller's contract).
            unsafe {
                let (a, b) = (line.p(k), line.p(k + 1));
                if self.w(a) + self.w(b) <= 0.0 || self.compliance(s) > 0.0 {
                    continue;
                }
                let c = (x.get_unchecked(b) - x.get_unchecked(a)).length() - self.rest(s);
                let error = violation(self.kind(s), c) / self.rest(s).max(1e-12);
                if error.is_nan() {
                    return f64::INFINITY;
                }
                worst = worst.max(error);
            }
        }
        worst
    }

    /// Whether the iterate moved the line's particles more than [`THROWN_ABOVE`] times as far
    /// from the start of the substep as the prediction did (mass-weighted squared distances,
    /// the prediction's plus the pins' reach, [`LineSolve::pins_reach`]).
    ///
    /// # Safety
    /// As for [`LineSolve::restore_prediction`].
    pub(super) unsafe fn thrown(&self, line: &LineRef) -> bool {
        let (mut iterate, mut predicted) = (0.0, 0.0);
        for (j, &p) in line.particles.iter().enumerate() {
            let p = p as usize;
            // SAFETY: in bounds (`check`, the caller's contract).
            unsafe {
                let w = self.w(p);
                if w > 0.0 {
                    let start = self.previous.get_unchecked(p);
                    let at = self
                        .scratch
                        .predicted
                        .get_unchecked(line.particle_offset + j);
                    iterate += (self.position.get_unchecked(p) - start).length_squared() / w;
                    predicted += (at - start).length_squared() / w;
                }
            }
        }
        // SAFETY: as above (this function's contract).
        // (A NaN iterate counts as thrown.)
        iterate.is_nan() || iterate > THROWN_ABOVE * (predicted + unsafe { self.pins_reach(line) })
    }

    /// `(Σ m|x − x̃|², Σ m|x* − x̃|²)` over the line's movable particles: how far the iterate `x`
    /// and the start of the substep `x*` are from the kept prediction `x̃`.
    ///
    /// # Safety
    /// As for [`LineSolve::restore_prediction`].
    pub(super) unsafe fn distances(&self, line: &LineRef) -> (f64, f64) {
        let (mut iterate, mut start) = (0.0, 0.0);
        for (j, &p) in line.particles.iter().enumerate() {
            let p = p as usize;
            // SAFETY: in bounds (`check`, the caller's contract).
            unsafe {
                let w = self.w(p);
                if w > 0.0 {
                    let at = self
                        .scratch
                        .predicted
                        .get_unchecked(line.particle_offset + j);
                    iterate += (self.position.get_unchecked(p) - at).length_squared() / w;
                    start += (self.previous.get_unchecked(p) - at).length_squared() / w;
                }
            }
        }
        (iterate, start)
    }

    /// Puts the line's movable particles back at the kept prediction, λ = 0.
    ///
    /// # Safety
    /// As for [`LineSolve::solve`]; `line` passed [`LineSolve::check`] and
    /// [`LineSolve::keeps_entry`] holds.
    pub(super) unsafe fn restore_prediction(&self, line: &LineRef) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (caller).
        unsafe {
            for (j, &p) in line.particles.iter().enumerate() {
                if self.w(p as usize) > 0.0 {
                    let predicted = self
                        .scratch
                        .predicted
                        .get_unchecked(line.particle_offset + j);
                    self.position.set_unchecked(p as usize, predicted);
                }
            }
            for &s in line.sticks {
                self.lambda.set_unchecked(s as usize, 0.0);
            }
        }
    }
}
