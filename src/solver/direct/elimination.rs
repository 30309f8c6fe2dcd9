//! A Newton pass over a line: the tridiagonal system of its sticks' linearised constraints,
//! eliminated forward and substituted back (Thomas' algorithm; Baraff 1996, "Linear-time
//! dynamics using Lagrange multipliers"), the residual that decides when passes stop
//! ([`LineSolve::newton`]), and the Gauss–Seidel sweep taken where a taut segment makes the
//! system singular. See the [parent module's docs](super).

use super::{
    LineMode, LineRef, LineSolve, NewtonSystem, REGULARISATION, Row, StickKind, SweepOrder,
    in_system_with, newton_passes, relax_stick_range, unit_and_length,
};
use glam::DVec3;

impl LineSolve<'_, '_> {
    /// Newton passes over `line` ([`newton_passes`]: until it is within [`TOLERANCE`](super::TOLERANCE), `budget`
    /// passes are done, or a pass leaves more than `contraction` × the error before it; a warm
    /// start that made the error worse than `predicted` is taken back; `fused`: the error to
    /// start from is measured in the first pass's elimination). Returns the passes taken and
    /// whether it converged.
    ///
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`] (every index below is
    /// accessed unchecked).
    pub(super) unsafe fn newton(
        &self,
        line: &LineRef,
        budget: u32,
        contraction: f64,
        predicted: f64,
        fused: bool,
    ) -> (u32, bool) {
        // SAFETY: this function's contract is `LinePasses::new`'s.
        let mut system = unsafe { LinePasses::new(self, line) };
        newton_passes(&mut system, budget, contraction, predicted, fused)
    }

    /// One Gauss–Seidel sweep over the line's sticks, in order (see [`LineMode::Sweep`]).
    ///
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`] (every index below is
    /// accessed unchecked).
    pub(super) unsafe fn sweep(&self, line: &LineRef) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (this function's
        // contract).
        unsafe {
            for (k, &s) in line.sticks.iter().enumerate() {
                let s = s as usize;
                relax_stick_range(
                    &self.position,
                    self.inverse_mass,
                    self.sticks,
                    &self.lambda,
                    s..s + 1,
                    self.inv_h2,
                    false,
                    false,
                    SweepOrder::Forward,
                );
                self.scratch.warm.set_unchecked(line.offset + k, 0.0);
            }
        }
    }

    /// Stick `k` at the current iterate.
    #[inline(always)]
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`] (every index below is
    /// accessed unchecked).
    pub(super) unsafe fn row(&self, line: &LineRef, k: usize) -> Row {
        // SAFETY: this task alone holds the line, whose indices are in bounds (this function's
        // contract).
        unsafe {
            let s = line.s(k);
            let (p, q) = (line.p(k), line.p(k + 1));
            let (normal, length) = unit_and_length(
                self.position.get_unchecked(q) - self.position.get_unchecked(p),
                s,
            );
            let rest = self.rest(s);
            let c = length - rest;
            let (lambda, kind) = (self.lambda.get_unchecked(s), self.kind(s));
            let inverse_masses = self.w(p) + self.w(q);
            let active =
                inverse_masses > 0.0 && in_system_with(kind, c, lambda * inverse_masses, rest);
            Row {
                normal,
                c,
                active,
                lambda,
                kind,
                inverse_masses,
            }
        }
    }

    /// The largest `|C + α̃λ|/L` of the sticks in the system (the active ones) at the current
    /// iterate.
    ///
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`] (every index below is
    /// accessed unchecked).
    pub(super) unsafe fn residual(&self, line: &LineRef) -> f64 {
        // SAFETY: this task alone holds the line, whose indices are in bounds (this function's
        // contract).
        unsafe {
            let mut worst: f64 = 0.0;
            for k in 0..line.sticks.len() {
                let s = line.s(k);
                let (p, q) = (line.p(k), line.p(k + 1));
                let length =
                    (self.position.get_unchecked(q) - self.position.get_unchecked(p)).length();
                let rest = self.rest(s);
                let lambda = self.lambda.get_unchecked(s);
                let inverse_masses = self.w(p) + self.w(q);
                let residual = line_residual(
                    self.kind(s),
                    [length - rest, rest],
                    lambda,
                    inverse_masses,
                    self.compliance(s) * self.inv_h2,
                );
                worst = worst.max(residual);
            }
            worst
        }
    }

    /// Forward traversal: each stick evaluated at the current iterate and its row eliminated
    /// (Thomas). With `MEASURE`, returns the residual at the iterate, as
    /// [`LineSolve::residual`] does (else 0).
    ///
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`] (every index below is
    /// accessed unchecked).
    pub(super) unsafe fn forward<const MEASURE: bool>(&self, line: &LineRef) -> f64 {
        // SAFETY: this task alone holds the line, whose indices are in bounds (this function's
        // contract).
        unsafe {
            let v = self.scratch;
            let shake = v.mode.get_unchecked(line.offset) == LineMode::Shake;
            let direction = |k: usize, row: &Row| {
                if shake {
                    v.start.get_unchecked(line.offset + k)
                } else {
                    row.normal
                }
            };
            let m = line.sticks.len();
            let (mut upper_prev, mut rhs_prev) = (0.0, 0.0);
            let mut r_prev = DVec3::ZERO;
            let mut row = self.row(line, 0);
            let mut worst: f64 = 0.0;
            for k in 0..m {
                let i = line.offset + k;
                let next = (k + 1 < m).then(|| self.row(line, k + 1));
                let r = direction(k, &row);
                v.direction.set_unchecked(i, r);
                let s = line.s(k);
                let alpha = self.compliance(s) * self.inv_h2;
                if MEASURE {
                    let rest = self.rest(s);
                    let error = line_residual(
                        row.kind,
                        [row.c, rest],
                        row.lambda,
                        row.inverse_masses,
                        alpha,
                    );
                    worst = worst.max(error);
                }
                if !row.active {
                    // Released: Δλ = −λ, whatever the neighbours do (they see its move).
                    v.upper.set_unchecked(i, 0.0);
                    v.rhs.set_unchecked(i, -row.lambda);
                    (upper_prev, rhs_prev) = (0.0, -row.lambda);
                } else {
                    let wp = self.w(line.p(k));
                    let wq = self.w(line.p(k + 1));
                    let n = row.normal;
                    // The XPBD residual: a compliant stick is solved when C = −α̃λ, not C = 0.
                    let residual = row.c + alpha * row.lambda;
                    let diagonal = (wp + wq) * n.dot(r) * (1.0 + REGULARISATION) + alpha;
                    // (An inactive neighbour's row is `Δλ = −λ`: its move enters through the
                    // coupling like any other.)
                    let lower = -wp * n.dot(r_prev);
                    let up = next
                        .as_ref()
                        .map_or(0.0, |next| -wq * n.dot(direction(k + 1, next)));
                    let rhs = -residual;
                    let inverse = 1.0 / (diagonal - lower * upper_prev);
                    upper_prev = up * inverse;
                    rhs_prev = (rhs - lower * rhs_prev) * inverse;
                    v.upper.set_unchecked(i, upper_prev);
                    v.rhs.set_unchecked(i, rhs_prev);
                }
                r_prev = r;
                if let Some(next) = next {
                    row = next;
                }
            }
            worst
        }
    }

    /// Backward traversal: `Δλ` by back substitution, λ updated and every particle moved by
    /// `w_j (r_{j−1} Δλ_{j−1} − r_j Δλ_j)`.
    ///
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`] (every index below is
    /// accessed unchecked).
    pub(super) unsafe fn backward(&self, line: &LineRef) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (this function's
        // contract).
        unsafe {
            let v = self.scratch;
            let m = line.sticks.len();
            let mut after = DVec3::ZERO; // r_{k+1} Δλ_{k+1}
            let mut d_next = 0.0;
            for k in (0..m).rev() {
                let i = line.offset + k;
                let d = v.rhs.get_unchecked(i) - v.upper.get_unchecked(i) * d_next;
                let d = if d.is_finite() { d } else { 0.0 };
                let s = line.s(k);
                self.lambda
                    .set_unchecked(s, self.lambda.get_unchecked(s) + d);
                let here = v.direction.get_unchecked(i) * d;
                self.move_particle(line.p(k + 1), here - after);
                after = here;
                d_next = d;
            }
            self.move_particle(line.p(0), -after);
        }
    }

    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`] (every index below is
    /// accessed unchecked).
    pub(super) unsafe fn shift(&self, p: usize, by: DVec3) {
        // SAFETY: as for `move_particle`.
        unsafe {
            if self.w(p) > 0.0 {
                self.position
                    .set_unchecked(p, self.position.get_unchecked(p) + by);
            }
        }
    }

    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`] (every index below is
    /// accessed unchecked).
    pub(super) unsafe fn move_particle(&self, p: usize, by: DVec3) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (this function's
        // contract).
        unsafe {
            let w = self.w(p);
            if let Some(mirror) = self.mirror.filter(|_| w > 0.0) {
                mirror.set_unchecked(p, mirror.get_unchecked(p) + by * w);
            }
            if w > 0.0 {
                self.position
                    .set_unchecked(p, self.position.get_unchecked(p) + by * w);
            }
        }
    }
}

/// A stick's share of a line's or tree's error relative to its rest length, `[C, L]` its
/// constraint and rest length (`|C + α̃λ|/L` in the system; out of it, the reach of a
/// multiplier not yet released, `|λ| (w_a + w_b)/L`; zero between immovable ends).
#[inline(always)]
pub(crate) fn line_residual(
    kind: StickKind,
    [c, rest]: [f64; 2],
    lambda: f64,
    inverse_masses: f64,
    alpha: f64,
) -> f64 {
    let reach = lambda * inverse_masses;
    let error = if inverse_masses <= 0.0 {
        0.0
    } else if in_system_with(kind, c, reach, rest) {
        (c + alpha * lambda).abs()
    } else {
        reach.abs()
    };
    error / rest.max(1e-12)
}

/// A line's system as [`newton_passes`] drives it (made by [`LinePasses::new`] only).
struct LinePasses<'s, 'a, 'v> {
    solve: &'s LineSolve<'a, 'v>,
    line: &'s LineRef<'s>,
}

impl<'s, 'a, 'v> LinePasses<'s, 'a, 'v> {
    /// `line`'s system in `solve`.
    ///
    /// # Safety
    /// As for [`LineSolve::newton`], for as long as it lives: this task alone holds the line,
    /// whose indices passed [`LineSolve::check`]. Its (safe) methods rely on it.
    unsafe fn new(solve: &'s LineSolve<'a, 'v>, line: &'s LineRef<'s>) -> Self {
        Self { solve, line }
    }
}

impl NewtonSystem for LinePasses<'_, '_, '_> {
    #[inline(always)]
    fn residual(&mut self) -> f64 {
        // SAFETY: the contract of `LinePasses::new`, which made this.
        unsafe { self.solve.residual(self.line) }
    }

    #[inline(always)]
    fn take_back(&mut self) {
        // SAFETY: as for `residual`.
        unsafe { self.solve.take_back(self.line) }
    }

    #[inline(always)]
    fn eliminate(&mut self, measure: bool) -> f64 {
        // SAFETY: as for `residual`.
        unsafe {
            match measure {
                true => self.solve.forward::<true>(self.line),
                false => self.solve.forward::<false>(self.line),
            }
        }
    }

    #[inline(always)]
    fn substitute(&mut self) {
        // SAFETY: as for `residual`.
        unsafe { self.solve.backward(self.line) }
    }
}
