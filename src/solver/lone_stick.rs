//! SHAKE for a line of one rigid stick (a pendulum, a lamp on a rod), in closed form.
//!
//! # Why
//! A lone stick is the commonest line and the one whose fixed cost shows: the general line solve
//! ([`direct`](super::direct)) warm-starts it, measures it, eliminates, substitutes and measures
//! it again — five square roots where the sweep takes one. For one stick SHAKE's equation is a
//! scalar quadratic (as in Ryckaert, Ciccotti, Berendsen 1977, one constraint at a time): with
//! `d` the stick at the current positions, `r` its unit direction at the start of the substep,
//! `W = w_p + w_q` and the ends moved by `∓w r λ`,
//!
//! ```text
//! |d + W r λ|² = L²   ⇒   λ = (L² − d·d) / (W (d·r + √((d·r)² − d·d + L²)))
//! ```
//!
//! (the root nearer zero, in the form that does not cancel). It is exact where Newton stops
//! within [`TOLERANCE`](super::direct::TOLERANCE), and it is used where the general solve would
//! run SHAKE (the turn test squared, so the same up to rounding at its boundary): a rigid,
//! two-sided stick with a movable end, in the first round of a substep, not while its line
//! waits after failed SHAKE tries (`SHAKE_BACKOFF_LIMIT`), turning less than [`SHAKE_MIN_COSINE`] allows, its start within
//! `STABILISE_ABOVE` of its length where the start is corrected. It also solves the rare
//! near-tangent substeps where the general SHAKE may give up (a root exists). Everything else
//! (compliance, ropes, edits, fast turns) takes the general solve, and so do later rounds of the
//! substep (iterations > 1) — along the start direction the closed form leaves in the scratch.
//!
//! The quadratic is solved along the start vector unnormalised (`λ = μ |u|`), which keeps the
//! normalisation off the chain of dependent operations that moves the particles.
//!
//! Measured (release, a 1 m pendulum released at 120°, 8 × 1; scratch tests, not kept):
//! callgrind over 6000 steps, 139.7 M instructions for the general solve, 104.2 M for this one
//! with `r` normalised first, 105.2 M unnormalised, against 97.8 M swept; µs per step over
//! 200 000 steps, 2.01–2.06 (general), 1.51–1.58 (normalised), 1.40–1.44 (unnormalised),
//! against 1.27–1.36 swept; 1000 such pendulums (1000 islands), 725–737 µs per step
//! normalised, 641–655 unnormalised, 505–509 swept (one run of each at 650 µs: the machine is
//! shared).

use super::StickKind;
use super::direct::{
    LineMode, LineRef, LineSolve, SHAKE_MIN_COSINE, STABILISE_ABOVE, ShakeBackoff,
};

impl LineSolve<'_, '_> {
    /// Solves `line` in closed form if it is one stick SHAKE applies to (see the module docs):
    /// returns the passes taken (one), or `None` to leave it to the general solve, untouched.
    ///
    /// # Safety
    /// As for [`LineSolve::solve`]: no other task accesses the line's particles, its stick's
    /// multiplier or its scratch while this runs.
    pub(crate) unsafe fn solve_lone_stick(&self, line: &LineRef) -> Option<u32> {
        let (&[p, q], &[s]) = (line.particles, line.sticks) else {
            return None;
        };
        let (p, q, s) = (p as usize, q as usize, s as usize);
        let sticks = self.sticks;
        let rest = sticks.rest_length[s];
        let rigid = sticks.kind[s] == StickKind::Equal && sticks.compliance[s] == 0.0;
        let (wp, wq) = (self.inverse_mass[p], self.inverse_mass[q]);
        let movable = wp + wq;
        // SAFETY: this task alone holds the line (this function's contract); `get` and `set`
        // check their bounds.
        unsafe {
            // (Not while the line waits after failed tries, see `SHAKE_BACKOFF_LIMIT`.)
            let shake = self.shake && self.scratch.backoff.get(line.offset).wait == 0;
            let applies = self.first_round && self.mirror.is_none() && shake && rigid;
            if !(applies && rest > 0.0 && movable > 0.0) {
                return None;
            }
            // (Along the start vector `u` unnormalised, `λ = μ |u|`: the normalisation is off
            // the chain of operations that moves the particles.)
            let u = self.previous.get(q) - self.previous.get(p);
            let start_length = u.length();
            let violated = (start_length - rest).abs() / rest;
            // (As short as `unit_and_length` gives a fixed direction: the general solve's.)
            let degenerate = start_length.is_nan() || start_length <= 1e-12;
            if degenerate || (self.alone && violated > STABILISE_ABOVE) {
                return None;
            }
            let d = self.position.get(q) - self.position.get(p);
            let (along, squared, uu) = (d.dot(u), d.length_squared(), u.length_squared());
            let excess = squared - rest * rest;
            let cosine = SHAKE_MIN_COSINE;
            let discriminant = along * along - uu * excess;
            let turned = along * along < cosine * cosine * squared * uu;
            if along < 0.0 || turned || discriminant < 0.0 {
                return None;
            }
            let mu = -excess / (movable * (along + discriminant.sqrt()));
            let lambda = mu * start_length;
            if !lambda.is_finite() {
                return None;
            }
            let step = u * mu;
            self.position.set(p, self.position.get(p) - step * wp);
            self.position.set(q, self.position.get(q) + step * wq);
            self.lambda.set(s, lambda);
            self.scratch.warm.set(line.offset, lambda);
            // (Later rounds of the substep solve the line by the general SHAKE from here.)
            self.scratch.start.set(line.offset, u / start_length);
            self.scratch.mode.set(line.offset, LineMode::Shake);
            self.scratch
                .backoff
                .set(line.offset, ShakeBackoff::default());
            Some(1)
        }
    }
}
