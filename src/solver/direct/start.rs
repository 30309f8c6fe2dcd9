//! The start of a line's substep ([`LineSolve::begin`]): the sticks' start directions, the
//! mode (SHAKE, projection or sweep), the warm start from the last multipliers, and taking it
//! back; the start positions stabilised where a violation from before the substep would
//! otherwise turn into velocity ([`LineSolve::stabilise_start`]). See the [parent module's
//! docs](super) for the method and its sources.

use super::{
    Begun, LineMode, LineRef, LineSolve, MAX_PASSES, SHAKE_MIN_COSINE, SHAKE_STIFFNESS_BELOW,
    StickKind, TAUT, WARM_START_REACH, in_system, tension_stiffness, unit_and_length,
};
use glam::DVec3;

impl LineSolve<'_, '_> {
    /// Stick `s`'s warm start from its last multiplier `last`: none without SHAKE configured, and
    /// a one-sided stick's only in the direction it can act.
    ///
    /// # Safety
    /// As for [`LineSolve::rest`].
    #[inline(always)]
    pub(super) unsafe fn warm_of(&self, s: usize, last: f64) -> f64 {
        // SAFETY: in bounds (caller).
        match unsafe { self.kind(s) } {
            _ if !self.shake => 0.0,
            StickKind::Equal => last,
            StickKind::AtMost => last.min(0.0),
            StickKind::AtLeast => last.max(0.0),
            StickKind::Torn => 0.0,
        }
    }

    /// Start of the substep: the start directions, the mode (SHAKE when every stick's predicted
    /// turn is small; a sweep when a rigid segment between immovable particles is taut), and
    /// the warm start `λ = λ_last` applied along the start directions (SHAKE only; taken back
    /// where it reaches too far, see [`WARM_START_REACH`]) — one traversal. `shake`: SHAKE may
    /// be used this substep. Returns the largest `|C|/L` before the warm start.
    ///
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`] (every index below is
    /// accessed unchecked).
    pub(super) unsafe fn begin(&self, line: &LineRef, shake: bool, warm: bool) -> Begun {
        // SAFETY: this task alone holds the line, whose indices are in bounds (this function's
        // contract).
        unsafe {
            let v = self.scratch;
            let mut shake = shake;
            let mut taut = false;
            let (mut predicted, mut violated): (f64, f64) = (0.0, 0.0);
            let (mut stiff, mut mu_before): (f64, f64) = (0.0, 0.0);
            let m = line.sticks.len();
            // (Lines pinned at both ends only, see [`SHAKE_STIFFNESS_BELOW`]; the others skip
            // the sums.)
            let held = self.w(line.p(0)) <= 0.0 && self.w(line.p(m)) <= 0.0;
            let mut before = DVec3::ZERO; // s_{k−1} λ_{k−1}
            // (Whether the warm start moves some particle more than `WARM_START_REACH` times its
            // distance back to the start of the substep: only then are the mass-weighted sums
            // measured, see [`LineSolve::overreaches`]. After a projected substep only, whose
            // multipliers carry its whole correction — a load's catch among them — where SHAKE's
            // are a smooth substep's forces: measured at every substep, the check cost a hanging
            // chain 7 % of its instructions. Lines alone in their island only: where lines share
            // particles, the start of a line's substep does not satisfy its constraints.)
            let checks_reach = self.alone && v.mode.get_unchecked(line.offset) != LineMode::Shake;
            let mut far = false;
            // The last immovable particle, where it is on the line, and the rest length of the
            // rigid sticks since (∞ once a stick that can stretch is passed). (Only with a
            // movable particle between: a stick between two immovable particles is out of the
            // system, never singular — counted taut, it had a rope pinned at two neighbouring
            // particles swept in every substep.)
            let (mut anchor, mut anchor_rest): (Option<DVec3>, f64) = (None, 0.0);
            let mut next_to_anchor = 0;
            let mut x = self.position.get_unchecked(line.p(0));
            for j in 0..=m {
                let p = line.p(j);
                let w = self.w(p);
                if w <= 0.0 {
                    if let Some(at) = anchor
                        && j > next_to_anchor
                    {
                        taut |= (x - at).length() >= anchor_rest * (1.0 - TAUT);
                    }
                    (anchor, anchor_rest, next_to_anchor) = (Some(x), 0.0, j + 1);
                }
                let mut after = DVec3::ZERO;
                let mut x_next = DVec3::ZERO;
                if j < m {
                    let s = line.s(j);
                    let q = line.p(j + 1);
                    let at_start = self.previous.get_unchecked(q) - self.previous.get_unchecked(p);
                    let (start, start_length) = unit_and_length(at_start, s);
                    x_next = self.position.get_unchecked(q);
                    let d = x_next - x;
                    let length = d.length();
                    let (rest, kind) = (self.rest(s), self.kind(s));
                    let inverse_rest = 1.0 / rest.max(1e-12);
                    // (Only rigid sticks: a compliant stick's stretch is its spring's, not an error.)
                    let rigid_equal = kind == StickKind::Equal && self.compliance(s) == 0.0;
                    if rigid_equal && self.w(q) + w > 0.0 {
                        violated = violated.max((start_length - rest).abs() * inverse_rest);
                    }
                    predicted = predicted.max((length - rest).abs() * inverse_rest);
                    shake &= start.dot(d) >= SHAKE_MIN_COSINE * length;
                    v.start.set_unchecked(line.offset + j, start);
                    // (Without SHAKE configured the projection starts from the prediction: it
                    // stays a pure projection. With it, every substep is warm-started, also one
                    // the projection will solve — from the warm start, unless that made the line
                    // worse: measured, starting a substep after a fallback from the prediction
                    // instead took 15 980 instead of 14 285 passes on the swinging 1000:1 chain
                    // of `tests/direct.rs`. Trees start projected substeps from the prediction.
                    // A one-sided stick is warm-started only in the direction it can act.)
                    // (Not for a one-sided stick out of the system at the prediction — a slack
                    // rope link: its warm start was a pull no pass took back; a slack rope
                    // between two pins gained up to 1079 J in 5 s from rest that way, see
                    // `a_slack_rope_between_pins_never_gains_energy` in `tests/direct.rs`.)
                    // (The kept multiplier is forgotten too: a curvature pass warm-starts from it.)
                    let in_system = in_system(kind, length - rest, rest);
                    if !in_system {
                        v.warm.set_unchecked(line.offset + j, 0.0);
                    }
                    // (SHAKE's stability, see [`SHAKE_STIFFNESS_BELOW`]: `μ = max(−λ, 0)/d` of the
                    // sticks at each particle, from the last substep's multipliers.)
                    if held {
                        let mu =
                            tension_stiffness(v.warm.get_unchecked(line.offset + j), start_length);
                        stiff = stiff.max(w * (mu_before + mu));
                        mu_before = mu;
                    }
                    let warm = if warm && in_system {
                        self.warm_of(s, v.warm.get_unchecked(line.offset + j))
                    } else {
                        0.0
                    };
                    self.lambda.set_unchecked(s, warm);
                    after = start * warm;
                    let rigid = matches!(kind, StickKind::Equal | StickKind::AtMost)
                        && self.compliance(s) == 0.0;
                    anchor_rest = if rigid {
                        anchor_rest + rest
                    } else {
                        f64::INFINITY
                    };
                }
                let moved = before - after;
                if self.alone {
                    // (The prediction, for full Newton passes: see `curvature`; and the warm
                    // start's reach.)
                    v.predicted.set_unchecked(line.particle_offset + j, x);
                    if checks_reach {
                        let back = self.previous.get_unchecked(p) - x;
                        far |= (moved * w).length_squared()
                            > WARM_START_REACH * WARM_START_REACH * back.length_squared();
                    }
                }
                if w > 0.0 {
                    self.position.set_unchecked(p, x + moved * w);
                }
                before = after;
                x = x_next;
            }
            if far && self.overreaches(line) {
                self.take_back(line);
            }
            let stable = !held || stiff < SHAKE_STIFFNESS_BELOW;
            let mode = if taut {
                self.take_back(line);
                LineMode::Sweep
            } else if shake && stable {
                LineMode::Shake
            } else {
                LineMode::Project
            };
            v.mode.set_unchecked(line.offset, mode);
            Begun {
                predicted,
                violated,
            }
        }
    }

    /// Whether the warm start just applied moves the line's particles farther from the
    /// prediction than [`WARM_START_REACH`] times their distance from there back to the start
    /// of the substep, mass-weighted: `Σ m|x − x̃|² > R² Σ m|x* − x̃|²`.
    ///
    /// # Safety
    /// As for [`LineSolve::begin`], which kept the prediction (the line is alone).
    pub(super) unsafe fn overreaches(&self, line: &LineRef) -> bool {
        // SAFETY: this task alone holds the line, whose indices are in bounds (this function's
        // contract).
        unsafe {
            let (reach, distance) = self.distances(line);
            reach > WARM_START_REACH * WARM_START_REACH * distance
        }
    }

    /// Moves the line's start-of-substep positions onto its constraints (Newton on the previous
    /// positions) and the current positions by the same amounts, so an initial violation — a
    /// rest length edited, sticks spawned shorter or longer than their ends are apart — is
    /// corrected without turning into velocity (Verlet's velocity is `x − x*`). Without it, an
    /// exact solve fixes a 10 % violation in one substep and launches the line.
    ///
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`] (every index below is
    /// accessed unchecked).
    pub(super) unsafe fn stabilise_start(&self, line: &LineRef) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (this function's
        // contract).
        unsafe {
            let mode = self.scratch.mode.get_unchecked(line.offset);
            self.scratch
                .mode
                .set_unchecked(line.offset, LineMode::Project);
            let start = LineSolve {
                position: self.previous,
                mirror: Some(self.position),
                shake: false,
                first_round: false,
                ..*self
            };
            start.newton(line, MAX_PASSES, f64::INFINITY, f64::INFINITY, false);
            for &s in line.sticks {
                self.lambda.set_unchecked(s as usize, 0.0);
            }
            self.scratch.mode.set_unchecked(line.offset, mode);
        }
    }

    /// The largest `w Σ μ` of the line's particles from the last substep's multipliers, with
    /// rest lengths (see [`CURVATURE_AFTER_SHAKE_ABOVE`](super::CURVATURE_AFTER_SHAKE_ABOVE)).
    ///
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`] (every index below is
    /// accessed unchecked).
    pub(super) unsafe fn warm_stiffness(&self, line: &LineRef) -> f64 {
        // SAFETY: this task alone holds the line, whose indices are in bounds (this function's
        // contract).
        unsafe {
            let warm = self.scratch.warm;
            let (mut stiff, mut mu_before): (f64, f64) = (0.0, 0.0);
            for (k, &s) in line.sticks.iter().enumerate() {
                let rest = self.rest(s as usize);
                let mu = tension_stiffness(warm.get_unchecked(line.offset + k), rest);
                stiff = stiff.max(self.w(line.p(k)) * (mu_before + mu));
                mu_before = mu;
            }
            stiff.max(self.w(line.p(line.sticks.len())) * mu_before)
        }
    }

    /// Takes back everything SHAKE moved this substep and switches the line to the projection.
    ///
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`] (every index below is
    /// accessed unchecked).
    pub(super) unsafe fn restart_without_shake(&self, line: &LineRef) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (this function's
        // contract).
        unsafe {
            self.take_back(line);
            self.scratch
                .mode
                .set_unchecked(line.offset, LineMode::FellBack);
        }
    }

    /// Takes back every correction of this substep so far, when all were along the start
    /// directions (the warm start, SHAKE passes): positions are linear in λ there. λ = 0 after.
    ///
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`] (every index below is
    /// accessed unchecked).
    pub(super) unsafe fn take_back(&self, line: &LineRef) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (this function's
        // contract).
        unsafe {
            let v = self.scratch;
            let mut before = DVec3::ZERO;
            for (j, &p) in line.particles.iter().enumerate() {
                let after = match line.sticks.get(j) {
                    Some(&s) => {
                        let lambda = self.lambda.get_unchecked(s as usize);
                        self.lambda.set_unchecked(s as usize, 0.0);
                        v.start.get_unchecked(line.offset + j) * lambda
                    }
                    None => DVec3::ZERO,
                };
                self.move_particle(p as usize, after - before);
                before = after;
            }
        }
    }
}
