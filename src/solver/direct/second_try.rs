//! A second try at a line's projection that converged on a far root, or did not converge.
//!
//! # Why
//! The projection of a substep is the point nearest its prediction (mass-weighted) that satisfies
//! the constraints. Where the start of the substep satisfies them too (the last substep
//! converged, the pins stand still, the sticks are rigid), the projection is never farther from
//! the prediction than that start; Newton passes may still converge on another root of the
//! equations, farther away — a heavy load thrown round its pin, with energy the line never had.
//! In a scratch variant of the random chains and trees of `tests/direct.rs` with their pins
//! waving 5 cm (one scene kept as `a_rope_between_waving_pins_never_blows_up`) one such root
//! followed another until a rope stretched 10⁶ times its links' length. Trees have had this
//! second try since they got curvature passes
//! ([`TreeSolve::second_try`](super::super::tree::TreeSolve)).
//!
//! # How
//! Where a line alone in its island and within reach of its curvature passes (see
//! [`LineSolve::project`]) ends converged but farther from its prediction than
//! [`WARM_START_REACH`] times the start of the substep is and farther
//! than the start plus its pins' reach ([`LineSolve::pins_reach`]: a point that satisfies the
//! constraints once the pins moved is that much farther at most), or ends unconverged while its
//! pins stand still, its iterate is kept and full Newton passes run from the start of the
//! substep (λ = 0). Their result stays where it converged nearer the prediction, or where the
//! first did not converge and it is near enough to be a projection (within the bound above);
//! else the first iterate is put back. Where the prediction is beyond
//! [`CURVATURE_BELOW`](super::CURVATURE_BELOW) (no curvature passes ran) the same holds, but
//! only from a start whose rigid sticks are within [`NEARLY_ON`](super::NEARLY_ON) of their
//! constraints — the argument above needs that start; from any start the second tries changed
//! how `pin_teleported_a_kilometre_away`'s rope settled after its yank (1.26 J at 4 s, then
//! +0.22 J, beyond that test's bound). Measured with that scan: at one substep kicked by
//! 30 m/s 42 → 25 of 506 scenes failing, seeds 1000–2200 82 → 46 stretched beyond 1 %, pins
//! jumping at one substep 747 → 739 of 1033, pins waving 20 cm at one substep 679 → 656 of
//! 946; the other rows unchanged.
//!
//! Measured with that scan (failing: strain ≥ 1 % or energy +10 % of a scene's scale): waving
//! pins, 946 scenes at 8 × 1, largest strain 1.2·10⁶ → 662 link lengths (186 failing either
//! way, most pulling a rope between two pins beyond its length); kicked by 30 m/s at one
//! substep 71 → 66 of 506 failing, at two 12 → 7 of 1033, by 60 m/s at four 7 → 2; pins
//! jumping 5 cm every two steps at one, two, eight substeps 768, 844, 877 → 764, 839, 877 of
//! 1033; the other rows of the scan unchanged. (Measured with that scan's variants,
//! 946–2109 scenes each: the bound at `1 + 10⁻⁶` times the start, as trees have it, changed
//! how `pin_teleported_a_kilometre_away` in `tests/hard_cases.rs` came to rest, 1.2 mm off;
//! unconverged lines tried again while their pins move too, one waving scene gained
//! 7500 times its scale instead of 2800.) The measure of distances costs one traversal per
//! projected substep: valgrind's instruction counts at 8 × 1 (a scratch profile of the
//! report's scenes) +1.6 % on the whipping 1000:1 chain, +0.9 % on the 200-link chain, the
//! same Newton passes (7628, 5085).

use super::curvature::Root;
use super::{LineRef, LineSolve, MAX_PASSES, WARM_START_REACH};

impl LineSolve<'_, '_> {
    /// The second try (see the module's docs) after passes that ended `converged` or not, with
    /// the line's curvature `root`. Returns the passes taken and whether the line converged.
    ///
    /// # Safety
    /// As for [`LineSolve::full_newton`]; [`LineSolve::keeps_prediction`] holds.
    pub(super) unsafe fn second_try(
        &self,
        line: &LineRef,
        root: Root,
        converged: bool,
    ) -> (u32, bool) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (caller).
        unsafe {
            let (first, start) = self.distances(line);
            let near_start = |iterate: f64, reach: f64| {
                iterate <= WARM_START_REACH * WARM_START_REACH * start
                    || iterate.sqrt() <= start.sqrt() + reach.sqrt()
            };
            let skip = if converged {
                near_start(first, self.pins_reach(line))
            } else {
                self.pins_reach(line) > 0.0
            };
            if skip {
                return (0, converged);
            }
            self.swap_iterate(line, true);
            let (passes, again) = self.full_newton(line, root, MAX_PASSES);
            let (second, _) = self.distances(line);
            // (The second kept over a NaN first; from an unconverged first
            // only where it is near enough to be a projection, as trees' `plausible` has it.)
            let nearer = !converged || second < first || first.is_nan();
            let kept = again && nearer && (converged || near_start(second, self.pins_reach(line)));
            if !kept {
                self.swap_iterate(line, false);
            }
            (passes, kept || converged)
        }
    }

    /// `Σ m · d²` over the line's movable particles, `d` the largest move of its immovable
    /// particles this substep: how far (mass-weighted, squared) the start of the substep may be
    /// from a point that satisfies the constraints once the pins moved (the line moved with its
    /// pin).
    ///
    /// # Safety
    /// As for [`LineSolve::restore_prediction`].
    pub(super) unsafe fn pins_reach(&self, line: &LineRef) -> f64 {
        let (mut mass, mut moved) = (0.0, 0.0f64);
        for &p in line.particles {
            let p = p as usize;
            // SAFETY: in bounds (`check`, the caller's contract).
            unsafe {
                let w = self.w(p);
                if w > 0.0 {
                    mass += 1.0 / w;
                } else {
                    let by = self.position.get_unchecked(p) - self.previous.get_unchecked(p);
                    moved = moved.max(by.length_squared());
                }
            }
        }
        mass * moved
    }

    /// With `save`, keeps the iterate (the movable particles' positions and the multipliers) in
    /// the scratch and restarts the line from the start of the substep with λ = 0; without, puts
    /// the kept iterate back.
    ///
    /// # Safety
    /// As for [`LineSolve::restore_prediction`].
    pub(super) unsafe fn swap_iterate(&self, line: &LineRef, save: bool) {
        let v = self.scratch;
        // SAFETY: this task alone holds the line, whose indices are in bounds (caller).
        unsafe {
            for (j, &p) in line.particles.iter().enumerate() {
                let p = p as usize;
                if self.w(p) <= 0.0 {
                    continue;
                }
                let slot = line.particle_offset + j;
                if save {
                    v.kept.set_unchecked(slot, self.position.get_unchecked(p));
                    self.position
                        .set_unchecked(p, self.previous.get_unchecked(p));
                } else {
                    self.position.set_unchecked(p, v.kept.get_unchecked(slot));
                }
            }
            for (k, &s) in line.sticks.iter().enumerate() {
                let s = s as usize;
                if save {
                    v.kept_lambda
                        .set_unchecked(line.offset + k, self.lambda.get_unchecked(s));
                    self.lambda.set_unchecked(s, 0.0);
                } else {
                    self.lambda
                        .set_unchecked(s, v.kept_lambda.get_unchecked(line.offset + k));
                }
            }
        }
    }
}
