//! The first projection pass of a tree's substep with the constraints' curvature (a full Newton
//! step on the projection's KKT system, see [`kkt`]), eliminated from the leaves to the root.
//!
//! # Why
//! A tree whose branches swing with heavy tips — a Y-shaped rope holding lanterns — projects
//! many of its substeps (a free end whips round too fast for SHAKE), and there its Gauss–Newton
//! passes wander as a chain's do (see [`direct`](super::super::direct)'s `curvature`): the
//! tension of the heavy tips turns the links. A tree's pass is already a 3 × 3 elimination per
//! particle, so a curvature pass costs about one ordinary pass, and it runs in every projected
//! substep (after a SHAKE failure too) whose prediction is within
//! [`CURVATURE_BELOW`](super::super::direct::CURVATURE_BELOW) of the constraints. Measured on
//! `tests/direct.rs`'s Y rope (a 50-link trunk, three 30-link branches) released from
//! horizontal, 5 s at 8 × 1 (release; old and new builds interleaved, best of five per run):
//! Newton passes with equal masses 6446 → 5926, with 100× heavier tips 10 839 → 7001, with
//! 1000× tips 28 707 → 7112; time 54.2–56.1 → 52.4–52.9 ms, 84.9–86.9 → 61.7–62.5 ms and
//! 198.9–211.7 → 64.9–66.1 ms (the sweep: 7.8–7.9 ms; quiet runs — the machine is shared). Only
//! in substeps that begin projected, as lines do: 5900, 8329 and 16 938 passes. (Before, the
//! 1000× tips also kept 4.8 % strain in a substep whose passes ran out.) Where Gauss–Newton has
//! not converged after [`FULL_NEWTON_AFTER`](super::super::direct::FULL_NEWTON_AFTER) passes,
//! full Newton passes take over, as for lines: with 10⁵ and 10⁶ times heavier tips the Y rope
//! kept 360–860× its links' lengths without them (81 519 / 81 805 passes), below 10⁻⁹ with them
//! (22 863 / 16 966 passes).
//!
//! A projected substep that ends unconverged, or converged farther from its prediction than
//! the start of the substep is, gets a second try ([`TreeSolve::second_try`]): where the start
//! satisfies the constraints (a converged last substep, still pins, rigid sticks) the
//! projection — the nearest point that does — is never farther, and such a result is another
//! root of the equations (a load thrown round its pin). Full Newton passes from the start then
//! find the near one. Measured with the random scan of `tests/direct.rs` (2109 scenes per
//! kick, `SCAN_SCENES=2400`): energy gains of 11–19 % of a scene's scale at kicks of 2 and
//! 10 m/s gone (largest gain 1.75 %), failures at 100 m/s 6 → 2. The second try also runs
//! where the prediction is beyond [`CURVATURE_BELOW`](super::super::direct::CURVATURE_BELOW)
//! (no curvature pass, Gauss–Newton passes only), its result kept only where it is near enough
//! to be a projection ([`TreeSolve::plausible`]): at one substep kicked by 30 m/s 66 → 42 of
//! 506 scenes failing, the largest energy gain 584 → 2.3 times a scene's scale.

use super::super::direct::{in_system, violation};
use super::super::kkt::{self, Link, Load, Reduced, Subtree};
use super::closings::{Closings, closing_index};
use super::{Closing, MAX_CLOSINGS, Node, TreeSolve, TreeView};
use glam::DVec3;

/// A tree node's share of a curvature pass.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct TreeCurvature {
    /// What the sticks below the node contribute.
    below: Subtree,
    /// The node's parent stick, reduced.
    reduced: Reduced,
    /// The node's `Δx`.
    dx: DVec3,
    /// Where the substep's prediction put the node.
    predicted: DVec3,
    /// In a tree with a closing stick (see [`closure`](super::closure)): the unit load its
    /// children pass up (and the closing stick's, at its held end), the node's part of the
    /// response to it, and its `Δx` per unit change of the closing multiplier.
    carried: DVec3,
    load: Load,
    dx_unit: DVec3,
    /// The first iterate of a projection tried a second time ([`TreeSolve::second_try`]), or
    /// an unconverged one while a sweep is tried instead ([`TreeSolve::fall_back`]): its
    /// position and its parent stick's multiplier.
    kept: DVec3,
    kept_lambda: f64,
}

/// How much nearer (relative, mass-weighted squared distance) than the start of the substep a
/// projection may end and still count as no farther (see [`TreeSolve::second_try`]): at rest
/// the two coincide up to rounding.
const NEARER: f64 = 1e-6;

impl TreeSolve<'_, '_> {
    /// Keeps where the prediction put every node, for [`TreeSolve::full_newton`] and
    /// [`TreeSolve::second_try`].
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`]; `view` passed [`TreeSolve::check`], `c` is as long as it.
    pub(super) unsafe fn keep_prediction(&self, view: &TreeView, c: &mut [TreeCurvature]) {
        for (node, &p) in c.iter_mut().zip(view.particle) {
            // SAFETY: in bounds (`check`) and this task's (caller).
            node.predicted = unsafe { self.position.get_unchecked(p as usize) };
        }
    }

    /// Keeps the start of the substep (`previous`) of every node, for
    /// [`TreeSolve::restore_start`].
    ///
    /// # Safety
    /// As for [`TreeSolve::keep_prediction`].
    pub(super) unsafe fn keep_start(&self, view: &TreeView, c: &mut [TreeCurvature]) {
        for (node, &p) in c.iter_mut().zip(view.particle) {
            // SAFETY: in bounds (`check`) and this task's (caller).
            node.kept = unsafe { self.previous.get_unchecked(p as usize) };
        }
    }

    /// Puts the start of the substep back where [`TreeSolve::keep_start`] kept it, and moves
    /// the current positions back by as much (they were moved with it).
    ///
    /// # Safety
    /// As for [`TreeSolve::keep_prediction`], after [`TreeSolve::keep_start`] this substep.
    pub(super) unsafe fn restore_start(&self, view: &TreeView, c: &[TreeCurvature]) {
        for (node, &p) in c.iter().zip(view.particle) {
            let p = p as usize;
            // SAFETY: in bounds (`check`) and this task's (caller).
            unsafe {
                let moved = self.previous.get_unchecked(p) - node.kept;
                self.previous.set_unchecked(p, node.kept);
                self.position
                    .set_unchecked(p, self.position.get_unchecked(p) - moved);
            }
        }
    }

    /// `(Σ m|x − x̃|², Σ m|x* − x̃|²)` over the tree's movable particles: how far the iterate `x`
    /// and the start of the substep `x*` are from the prediction `x̃` kept this substep.
    ///
    /// # Safety
    /// As for [`TreeSolve::keep_prediction`], which ran this substep.
    unsafe fn distances(&self, view: &TreeView, c: &[TreeCurvature]) -> (f64, f64) {
        let (mut iterate, mut start) = (0.0, 0.0);
        for (node, &p) in c.iter().zip(view.particle) {
            let p = p as usize;
            // SAFETY: in bounds (`check`) and this task's (caller).
            let (w, x, x_start) = unsafe {
                (
                    *self.inverse_mass.get_unchecked(p),
                    self.position.get_unchecked(p),
                    self.previous.get_unchecked(p),
                )
            };
            if w > 0.0 {
                iterate += (x - node.predicted).length_squared() / w;
                start += (x_start - node.predicted).length_squared() / w;
            }
        }
        (iterate, start)
    }

    /// A second try at a projection that ended unconverged, or converged farther from the
    /// prediction than the start of the substep is (mass-weighted). Where that start satisfies
    /// the constraints (the last substep converged, the pins stand still, the sticks are rigid)
    /// the projection — the nearest point that does — is never farther, and such a result is
    /// another root of the equations (a load thrown round a pin: a random rope tree whose 100×
    /// load went from 5 to 19 m/s in one substep, +14 000 J); elsewhere the test is a
    /// heuristic, and a second try that does not converge nearer changes nothing (a review's
    /// scans with pins jumping 0.2 m per step: 4588 second tries, 1240 of them in vain, +2.8 %
    /// passes, failures 11 → 3). Full Newton passes from the start of the substep (λ = 0, the
    /// iterate kept in `c`); their result stays where it converged nearer the prediction (or
    /// the first did not converge) and is near enough to be a projection
    /// ([`TreeSolve::plausible`]), else the first is put back. Returns the passes taken.
    ///
    /// # Safety
    /// As for [`TreeSolve::full_newton`], and the prediction was kept this substep.
    pub(super) unsafe fn second_try(
        &self,
        view: &TreeView,
        (c, more): (&mut [TreeCurvature], &mut [Closing]),
    ) -> (u32, bool) {
        // SAFETY: as above (this function's contract).
        unsafe {
            let converged = self.residual(view) <= super::TOLERANCE;
            let (first, start) = self.distances(view, c);
            if converged && first <= start * (1.0 + NEARER) {
                return (0, true);
            }
            self.swap_iterate(view, c, true);
            let (passes, again) = self.full_newton(view, (c, more), super::MAX_PASSES);
            let (second, _) = self.distances(view, c);
            // (The second kept over a NaN first.)
            let nearer = !converged || second < first || first.is_nan();
            let kept = again && nearer && self.plausible(view, second, start);
            if !kept {
                self.swap_iterate(view, c, false);
            }
            (passes, kept || converged)
        }
    }

    /// Whether a second try's result, `second` (`Σ m|x − x̃|²`) from the prediction with the
    /// start of the substep `start` from it, is near enough to be a projection: no more than
    /// [`WARM_START_REACH`](super::super::direct::WARM_START_REACH) times as far as the start,
    /// or within the start plus the pins' reach (`Σ m · d²`, `d` the pins' largest move this
    /// substep: a point that satisfies the constraints once the pins moved is that much farther
    /// from the start at most) — the bound lines use for their second try (see
    /// `solver::direct`'s `second_try`). Full Newton from a start far off its constraints
    /// (beyond [`CURVATURE_BELOW`](super::super::direct::CURVATURE_BELOW), where second tries
    /// run too) can converge anywhere: measured with the random chains and trees of
    /// `tests/direct.rs` (scratch scans), second tries beyond it without this bound cut the
    /// scenes failing at one substep kicked by 30 m/s from 66 to 42 of 506 but let a tree kicked
    /// by 100 m/s at 8 substeps stretch 5·10⁵ link lengths; with it 42 fail, the largest energy
    /// gain 2.3 times a scene's scale instead of 584, and the 100 m/s scenes as before.
    ///
    /// # Safety
    /// As for [`TreeSolve::keep_prediction`], which kept the prediction this substep.
    unsafe fn plausible(&self, view: &TreeView, second: f64, start: f64) -> bool {
        let r = super::super::direct::WARM_START_REACH;
        // SAFETY: as above (this function's contract).
        second <= r * r * start
            || second.sqrt() <= start.sqrt() + unsafe { self.pins_reach(view) }.sqrt()
    }

    /// `Σ m · d²` over the tree's movable particles, `d` the largest move of its immovable
    /// particles this substep: how far (mass-weighted, squared) the start of the substep may be
    /// from a point that satisfies the constraints once the pins moved (the tree moved with its
    /// pin).
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`]; `view` passed [`TreeSolve::check`].
    unsafe fn pins_reach(&self, view: &TreeView) -> f64 {
        let (mut mass, mut moved) = (0.0, 0.0f64);
        for &p in view.particle {
            let p = p as usize;
            // SAFETY: in bounds (`check`) and this task's (caller).
            let (w, by) = unsafe {
                (
                    *self.inverse_mass.get_unchecked(p),
                    self.position.get_unchecked(p) - self.previous.get_unchecked(p),
                )
            };
            if w > 0.0 {
                mass += 1.0 / w;
            } else {
                moved = moved.max(by.length_squared());
            }
        }
        mass * moved
    }

    /// The largest `|C + α̃λ|/L` at the kept prediction with the last substep's multipliers (the
    /// nodes' warm starts), one-sided where a stick is: the prediction's error with a spring's
    /// stretch that its multiplier balanced left out, which
    /// [`CURVATURE_BELOW`](super::super::direct::CURVATURE_BELOW) bounds where the error itself
    /// is beyond it.
    ///
    /// # Safety
    /// As for [`TreeSolve::keep_prediction`], which kept the prediction this substep.
    pub(super) unsafe fn balanced_error(
        &self,
        view: &TreeView,
        s: &[Node],
        c: &[TreeCurvature],
    ) -> f64 {
        let mut worst: f64 = 0.0;
        for t in 1..c.len() {
            // SAFETY: `t` is a node of the view; in bounds (`check`).
            let (k, parent) = unsafe {
                (
                    *view.stick.get_unchecked(t) as usize,
                    (*view.parent.get_unchecked(t) - view.offset) as usize,
                )
            };
            let rest = self.sticks.rest_length[k].max(1e-12);
            let stretch = (c[t].predicted - c[parent].predicted).length() - rest;
            let balanced = self.sticks.compliance[k] * self.inv_h2 * s[t].warm;
            worst = worst.max(violation(self.sticks.kind[k], stretch + balanced) / rest);
        }
        worst
    }

    /// Whether an unconverged iterate is worse than the prediction it started from (`predicted`
    /// its error), farther from it than [`WARM_START_REACH`](super::super::direct::WARM_START_REACH)
    /// times the start of the substep (mass-weighted), or has thrown its loads
    /// ([`TreeSolve::thrown`]).
    ///
    /// # Safety
    /// As for [`TreeSolve::keep_prediction`], which kept the prediction this substep.
    pub(super) unsafe fn unconverged_too_far(
        &self,
        view: &TreeView,
        c: &[TreeCurvature],
        predicted: f64,
    ) -> bool {
        // SAFETY: as above (this function's contract).
        unsafe {
            let (reach, start) = self.distances(view, c);
            let r = super::super::direct::WARM_START_REACH;
            self.residual(view) > predicted || reach > r * r * start || self.thrown(view, c)
        }
    }

    /// Whether the iterate moved the tree's particles more than
    /// [`THROWN_ABOVE`](super::super::direct::THROWN_ABOVE) times as far from the start of the
    /// substep as the prediction did (mass-weighted squared distances, the prediction's plus
    /// the pins' reach, [`TreeSolve::pins_reach`]).
    ///
    /// # Safety
    /// As for [`TreeSolve::keep_prediction`], which kept the prediction this substep.
    unsafe fn thrown(&self, view: &TreeView, c: &[TreeCurvature]) -> bool {
        let (mut iterate, mut predicted) = (0.0, 0.0);
        for (node, &p) in c.iter().zip(view.particle) {
            let p = p as usize;
            // SAFETY: in bounds (`check`) and this task's (caller).
            let (w, x, start) = unsafe {
                (
                    *self.inverse_mass.get_unchecked(p),
                    self.position.get_unchecked(p),
                    self.previous.get_unchecked(p),
                )
            };
            if w > 0.0 {
                iterate += (x - start).length_squared() / w;
                predicted += (node.predicted - start).length_squared() / w;
            }
        }
        // SAFETY: as above (this function's contract).
        let reach = unsafe { self.pins_reach(view) };
        // (A NaN iterate counts as thrown.)
        iterate > super::super::direct::THROWN_ABOVE * (predicted + reach) || iterate.is_nan()
    }

    /// A sweep from the substep's prediction instead of an unconverged iterate — unless the
    /// iterate is finite, within [`NEARLY_ON`](super::super::direct::NEARLY_ON) of its rigid
    /// sticks' constraints, nearer them than the sweep ([`TreeSolve::violation`]) and not
    /// [`FARTHER_THAN_A_SWEEP`](super::super::direct::FARTHER_THAN_A_SWEEP) from the
    /// prediction: it is then put back (kept in `c` meanwhile), its multipliers of one-sided
    /// sticks out of the system released.
    ///
    /// # Safety
    /// As for [`TreeSolve::keep_prediction`], which kept the prediction this substep.
    pub(super) unsafe fn fall_back(
        &self,
        view: &TreeView,
        s: &mut [Node],
        c: &mut [TreeCurvature],
    ) {
        use super::super::direct::{FARTHER_THAN_A_SWEEP, NEARLY_ON};
        // SAFETY: as above (this function's contract).
        unsafe {
            let (iterate, (moved, _)) = (self.violation(view), self.distances(view, c));
            // (Kept in `c`, the positions then put at the prediction.)
            self.swap_iterate(view, c, true);
            self.restore_prediction(view, c);
            self.sweep(view, s);
            let keeps = iterate < NEARLY_ON
                && iterate < self.violation(view)
                && moved <= FARTHER_THAN_A_SWEEP * self.distances(view, c).0;
            if !keeps {
                return;
            }
            self.swap_iterate(view, c, false);
            for t in 1..c.len() {
                let k = *view.stick.get_unchecked(t) as usize;
                let [a, b] = self.sticks.ends[k].map(|p| p as usize);
                let length = (self.position.get(b) - self.position.get(a)).length();
                let rest = self.sticks.rest_length[k];
                if !in_system(self.sticks.kind[k], length - rest, rest) {
                    self.lambda.set_unchecked(k, 0.0);
                }
            }
        }
    }

    /// The largest violation of the tree's rigid sticks, `|C|/L` one-sided where a stick is
    /// ([`violation`]; a spring's stretch is its own, sticks between immovable particles are
    /// left out); `∞` where a length is not finite.
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`]; `view` passed [`TreeSolve::check`].
    unsafe fn violation(&self, view: &TreeView) -> f64 {
        let mut worst: f64 = 0.0;
        for &k in &view.stick[1..] {
            let k = k as usize;
            let [a, b] = self.sticks.ends[k].map(|p| p as usize);
            let movable = self.inverse_mass[a] + self.inverse_mass[b] > 0.0;
            if !movable || self.sticks.compliance[k] > 0.0 {
                continue;
            }
            // SAFETY: the tree's particles are this task's (caller).
            let d = unsafe { self.position.get(b) - self.position.get(a) };
            let rest = self.sticks.rest_length[k];
            let error = violation(self.sticks.kind[k], d.length() - rest) / rest.max(1e-12);
            if error.is_nan() {
                return f64::INFINITY;
            }
            worst = worst.max(error);
        }
        worst
    }

    /// Puts the tree's movable particles back where the substep's prediction put them (kept by
    /// [`TreeSolve::keep_prediction`]), λ = 0.
    ///
    /// # Safety
    /// As for [`TreeSolve::keep_prediction`], which kept the prediction this substep.
    pub(super) unsafe fn restore_prediction(&self, view: &TreeView, c: &[TreeCurvature]) {
        for (t, node) in c.iter().enumerate() {
            // SAFETY: `t` is a node of the view; in bounds (`check`) and this task's (caller).
            unsafe {
                let p = *view.particle.get_unchecked(t) as usize;
                if *self.inverse_mass.get_unchecked(p) > 0.0 {
                    self.position.set_unchecked(p, node.predicted);
                }
                if t > 0 {
                    self.lambda
                        .set_unchecked(*view.stick.get_unchecked(t) as usize, 0.0);
                }
            }
        }
    }

    /// With `save`, keeps the iterate (positions and multipliers) in `c` and restarts the tree
    /// from the start of the substep with λ = 0; without, puts the kept iterate back.
    ///
    /// # Safety
    /// As for [`TreeSolve::full_newton`].
    unsafe fn swap_iterate(&self, view: &TreeView, c: &mut [TreeCurvature], save: bool) {
        for (t, node) in c.iter_mut().enumerate() {
            // SAFETY: `t` is a node of the view; in bounds (`check`) and this task's (caller).
            unsafe {
                let p = *view.particle.get_unchecked(t) as usize;
                if *self.inverse_mass.get_unchecked(p) > 0.0 {
                    if save {
                        node.kept = self.position.get_unchecked(p);
                        self.position
                            .set_unchecked(p, self.previous.get_unchecked(p));
                    } else {
                        self.position.set_unchecked(p, node.kept);
                    }
                }
                if t > 0 {
                    let k = *view.stick.get_unchecked(t) as usize;
                    if save {
                        node.kept_lambda = self.lambda.get_unchecked(k);
                        self.lambda.set_unchecked(k, 0.0);
                    } else {
                        self.lambda.set_unchecked(k, node.kept_lambda);
                    }
                }
            }
        }
    }

    /// One full Newton pass from the prediction, λ warm-started from the last substep (`s`'s
    /// warm starts).
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`]; `view` passed [`TreeSolve::check`], no particle but the
    /// root (and the closing node, see [`closure`](super::closure)) is immovable, nothing has
    /// moved the tree this substep, and `c` is as long as `s`.
    pub(super) unsafe fn curvature_pass(
        &self,
        view: &TreeView,
        s: &[Node],
        (c, more): (&mut [TreeCurvature], &mut [Closing]),
    ) {
        for (node, &k) in s.iter().zip(view.stick).skip(1) {
            let k = k as usize;
            // SAFETY: a stick of the tree (`check`), this task's (caller).
            unsafe { self.lambda.set_unchecked(k, self.warm_of(k, node.warm)) };
        }
        // SAFETY: as above (this function's contract).
        unsafe { self.eliminate::<false>(view, c, more) };
    }

    /// Full Newton passes from the current iterate (its residual measured against the
    /// prediction [`TreeSolve::keep_prediction`] kept) until the tree is within
    /// [`TOLERANCE`](super::TOLERANCE) or `budget` passes are done. Returns the passes taken
    /// and whether they converged.
    ///
    /// # Safety
    /// As for [`TreeSolve::curvature_pass`], but the tree may have moved since its prediction
    /// was kept, this substep.
    pub(super) unsafe fn full_newton(
        &self,
        view: &TreeView,
        (c, more): (&mut [TreeCurvature], &mut [Closing]),
        budget: u32,
    ) -> (u32, bool) {
        for passes in 0..budget {
            // SAFETY: as above (this function's contract).
            unsafe { self.eliminate::<true>(view, c, more) };
            // SAFETY: as above.
            if unsafe { self.residual(view) } <= super::TOLERANCE {
                return (passes + 1, true);
            }
        }
        (budget, false)
    }

    /// One full Newton pass: leaves to root, then back (see [`kkt`]). With `MOVED`, the tree
    /// may have moved from its prediction (`R` includes `M (x − x̃)`). In a tree with a
    /// closing stick (its root immovable), the stick is left out of the elimination: its
    /// curvature and force join its held end's equation, a unit change of its multiplier is
    /// carried to the root as a second load ([`Reduced::carry`]), and the multiplier comes from
    /// a Schur complement of one row ([`kkt::closing_step`]) — as for a line pinned at both
    /// ends (see `direct`'s `closure`).
    ///
    /// # Safety
    /// As for [`TreeSolve::full_newton`].
    unsafe fn eliminate<const MOVED: bool>(
        &self,
        view: &TreeView,
        c: &mut [TreeCurvature],
        more: &mut [Closing],
    ) {
        if !view.extra.is_empty() {
            // SAFETY: as for this function (caller).
            return unsafe { self.eliminate_many::<MOVED>(view, c, more) };
        }
        for node in c.iter_mut() {
            node.below = Subtree::default();
            node.carried = DVec3::ZERO;
        }
        let mut closing_link = None;
        for t in (1..view.particle.len()).rev() {
            // SAFETY: `t` and its parent (< t) are nodes of the view, every index passed
            // `check`, the particles and multipliers are this task's (caller).
            unsafe {
                let row = self.row(view, t);
                let k = row.stick;
                if !row.active {
                    self.lambda.set_unchecked(k, 0.0);
                }
                let parent = (*view.parent.get_unchecked(t) - view.offset) as usize;
                if Some(t) == view.closing {
                    // (From the immovable end to the held one, as a line's closing stick.)
                    let held = *view.particle.get_unchecked(parent) as usize;
                    let link = Link {
                        normal: -(row.normal * row.sign),
                        c: row.c,
                        length: row.c + *self.sticks.rest_length.get_unchecked(k),
                        lambda: self.lambda.get_unchecked(k),
                        alpha: *self.sticks.compliance.get_unchecked(k) * self.inv_h2,
                        inverse_mass: *self.inverse_mass.get_unchecked(held),
                        offset: DVec3::ZERO,
                        active: row.active,
                    };
                    let into = c.get_unchecked_mut(parent);
                    into.below.add(&kkt::closing_load(&link));
                    into.carried += link.normal;
                    closing_link = Some(link);
                    continue;
                }
                let child = *view.particle.get_unchecked(t) as usize;
                let link = Link {
                    normal: row.normal * row.sign, // (from the parent to the child)
                    c: row.c,
                    length: row.c + *self.sticks.rest_length.get_unchecked(k),
                    lambda: self.lambda.get_unchecked(k),
                    alpha: *self.sticks.compliance.get_unchecked(k) * self.inv_h2,
                    inverse_mass: *self.inverse_mass.get_unchecked(child),
                    offset: if MOVED {
                        self.offset_of(child, c.get_unchecked(t).predicted)
                    } else {
                        DVec3::ZERO
                    },
                    active: row.active,
                };
                let (reduced, up) = kkt::reduce(&link, &c.get_unchecked(t).below);
                let node = c.get_unchecked_mut(t);
                node.reduced = reduced;
                // (Every node of a closed tree, also those before the closing node's turn: they
                // carry nothing, and their load must say so — not what the scratch held.)
                let carried_up = view.closing.map(|_| {
                    let load_up;
                    (node.load, load_up) = reduced.carry(link.normal, node.carried);
                    load_up
                });
                let into = c.get_unchecked_mut(parent);
                into.below.add(&up);
                if let Some(load_up) = carried_up {
                    into.carried += load_up;
                }
            }
        }
        // (The closing multiplier's change; zero without a closing stick.)
        // SAFETY: as above.
        let d_closing =
            closing_link.map_or(0.0, |link| unsafe { self.closing_change(view, c, &link) });
        let root = view.particle[0] as usize;
        let root_offset = if MOVED {
            // SAFETY: as above.
            unsafe { self.offset_of(root, c[0].predicted) }
        } else {
            DVec3::ZERO
        };
        c[0].dx = kkt::root_step(self.inverse_mass[root], &c[0].below, root_offset);
        // SAFETY: as above.
        unsafe { self.shift(root, c[0].dx) };
        for t in 1..view.particle.len() {
            // SAFETY: as above.
            unsafe {
                let parent = (*view.parent.get_unchecked(t) - view.offset) as usize;
                let parent_dx = c.get_unchecked(parent).dx;
                let node = c.get_unchecked(t);
                let (d_lambda, dx) = match closing_link {
                    // (The closing node is immovable: its own subtrees hang from a fixed point.)
                    Some(_) if Some(t) == view.closing => (d_closing, DVec3::ZERO),
                    Some(_) => node
                        .reduced
                        .substitute_loaded(&node.load, d_closing, parent_dx),
                    None => node.reduced.substitute(parent_dx),
                };
                c.get_unchecked_mut(t).dx = dx;
                let k = *view.stick.get_unchecked(t) as usize;
                self.lambda
                    .set_unchecked(k, self.lambda.get_unchecked(k) + d_lambda);
                self.shift(*view.particle.get_unchecked(t) as usize, dx);
            }
        }
    }

    /// [`TreeSolve::eliminate`] in a tree with extra closing sticks (its root immovable): each
    /// closing stick's curvature and force join its held end's equation, and a unit change of
    /// each closing multiplier is carried to the root as a load of its own (the first's in
    /// `c`, the others' in `more`, node `t`'s at `t · e + i`); the multipliers' changes then
    /// solve the closing rows' small dense system ([`TreeSolve::closing_changes`]), as the
    /// Gauss–Newton passes' do (see [`closure`](super::closure)).
    ///
    /// # Safety
    /// As for [`TreeSolve::full_newton`].
    unsafe fn eliminate_many<const MOVED: bool>(
        &self,
        view: &TreeView,
        c: &mut [TreeCurvature],
        more: &mut [Closing],
    ) {
        let e = view.extra.len();
        for node in c.iter_mut() {
            node.below = Subtree::default();
            node.carried = DVec3::ZERO;
        }
        for record in more.iter_mut() {
            record.load = DVec3::ZERO;
        }
        let mut links = [None; MAX_CLOSINGS];
        for t in (1..view.particle.len()).rev() {
            // SAFETY: `t` and its parent (< t) are nodes of the view, every index passed
            // `check`, the particles and multipliers are this task's (caller).
            unsafe {
                let row = self.row(view, t);
                let k = row.stick;
                if !row.active {
                    self.lambda.set_unchecked(k, 0.0);
                }
                let parent = (*view.parent.get_unchecked(t) - view.offset) as usize;
                let held = *view.particle.get_unchecked(parent) as usize;
                let child = *view.particle.get_unchecked(t) as usize;
                let closing = closing_index(view, t);
                let mut link = Link {
                    normal: row.normal * row.sign, // (from the parent to the child)
                    c: row.c,
                    length: row.c + *self.sticks.rest_length.get_unchecked(k),
                    lambda: self.lambda.get_unchecked(k),
                    alpha: *self.sticks.compliance.get_unchecked(k) * self.inv_h2,
                    inverse_mass: *self.inverse_mass.get_unchecked(child),
                    offset: DVec3::ZERO,
                    active: row.active,
                };
                if let Some(j) = closing {
                    // (From the immovable end to the held one, as a line's closing stick.)
                    (link.normal, link.inverse_mass) =
                        (-link.normal, *self.inverse_mass.get_unchecked(held));
                    let into = c.get_unchecked_mut(parent);
                    into.below.add(&kkt::closing_load(&link));
                    match j {
                        0 => into.carried += link.normal,
                        j => more[parent * e + j - 1].load += link.normal,
                    }
                    links[j] = Some(link);
                    continue;
                }
                if MOVED {
                    link.offset = self.offset_of(child, c.get_unchecked(t).predicted);
                }
                let (reduced, up) = kkt::reduce(&link, &c.get_unchecked(t).below);
                let node = c.get_unchecked_mut(t);
                node.reduced = reduced;
                let load_up;
                (node.load, load_up) = reduced.carry(link.normal, node.carried);
                let mut ups = [DVec3::ZERO; MAX_CLOSINGS];
                for (record, up) in more[t * e..(t + 1) * e].iter_mut().zip(&mut ups) {
                    let load;
                    (load, *up) = reduced.carry(link.normal, record.load);
                    (record.v, record.beta) = load.parts();
                }
                let into = c.get_unchecked_mut(parent);
                into.below.add(&up);
                into.carried += load_up;
                for (record, up) in more[parent * e..(parent + 1) * e].iter_mut().zip(ups) {
                    record.load += up;
                }
            }
        }
        // SAFETY: as above.
        let d_lambda = unsafe { self.closing_changes(view, (c, more), &links) };
        let root = view.particle[0] as usize;
        let root_offset = match MOVED {
            // SAFETY: as above.
            true => unsafe { self.offset_of(root, c[0].predicted) },
            false => DVec3::ZERO,
        };
        c[0].dx = kkt::root_step(self.inverse_mass[root], &c[0].below, root_offset);
        // SAFETY: as above.
        unsafe { self.shift(root, c[0].dx) };
        for t in 1..view.particle.len() {
            let parent = (view.parent[t] - view.offset) as usize;
            let (parent_dx, node) = (c[parent].dx, &c[t]);
            let (d_lambda, dx) = match closing_index(view, t) {
                // (A closing node is immovable.)
                Some(j) => (d_lambda[j], DVec3::ZERO),
                None => {
                    let (v, beta) = node.load.parts();
                    let (mut v, mut beta) = (v * d_lambda[0], beta * d_lambda[0]);
                    for (record, &change) in more[t * e..(t + 1) * e].iter().zip(&d_lambda[1..]) {
                        (v, beta) = (v + record.v * change, beta + record.beta * change);
                    }
                    node.reduced.substitute_added(v, beta, parent_dx)
                }
            };
            c[t].dx = dx;
            let k = view.stick[t] as usize;
            // SAFETY: as above.
            unsafe {
                self.lambda.set(k, self.lambda.get(k) + d_lambda);
                self.shift(view.particle[t] as usize, dx);
            }
        }
    }

    /// The closing multipliers' changes in a tree with extra closing sticks: a back
    /// substitution from the (immovable) root to the closing sticks' held ends that moves
    /// nothing gives each held end's `Δx⁰` and `Δxⁱ` per unit change of closing multiplier
    /// `i`; then the closing rows `n_j·(Δx⁰ + Σᵢ Δλᵢ Δxⁱ) + α̃_j Δλ_j = −(C_j + α̃_j λ_j)` (a
    /// released row: `Δλ_j = −λ_j`) are solved together. Zero (released rows `−λ`) where
    /// that system is singular.
    ///
    /// # Safety
    /// As for [`TreeSolve::full_newton`], after [`TreeSolve::eliminate_many`]'s traversal.
    unsafe fn closing_changes(
        &self,
        view: &TreeView,
        (c, more): (&mut [TreeCurvature], &mut [Closing]),
        links: &[Option<Link>; MAX_CLOSINGS],
    ) -> [f64; MAX_CLOSINGS] {
        let e = view.extra.len();
        (c[0].dx, c[0].dx_unit) = (DVec3::ZERO, DVec3::ZERO);
        for record in &mut more[..e] {
            record.dx = DVec3::ZERO;
        }
        let held = |j: usize| {
            let node = if j == 0 {
                view.closing
            } else {
                Some(view.extra[j - 1] as usize)
            };
            node.map(|t| (view.parent[t] - view.offset) as usize)
        };
        // (Parents come before their children: the paths to the held ends are done by then.)
        let last = (0..=e).filter_map(held).max().unwrap_or(0);
        for t in 1..=last {
            let parent = (view.parent[t] - view.offset) as usize;
            let (parent_dx, parent_unit) = (c[parent].dx, c[parent].dx_unit);
            let node = &mut c[t];
            node.dx = node.reduced.substitute(parent_dx).1;
            node.dx_unit = node.reduced.substitute_load(&node.load, parent_unit).1;
            for i in 0..e {
                let parent_unit = more[parent * e + i].dx;
                let record = &mut more[t * e + i];
                let load = Load::from_parts(record.v, record.beta);
                record.dx = node.reduced.substitute_load(&load, parent_unit).1;
            }
        }
        let mut rows = Closings::default();
        for (j, link) in links[..=e].iter().enumerate() {
            let (Some(link), Some(held)) = (link, held(j)) else {
                rows.release(j, 0.0);
                continue;
            };
            if !link.active {
                rows.release(j, -link.lambda);
                continue;
            }
            let n = link.normal;
            let units = std::iter::once(c[held].dx_unit).chain(
                more[held * e..(held + 1) * e]
                    .iter()
                    .map(|record| record.dx),
            );
            for (i, unit) in units.enumerate() {
                rows.matrix[j][i] = n.dot(unit);
            }
            rows.diagonal(j, link.alpha);
            rows.rhs[j] = -(link.c + link.alpha * link.lambda) - n.dot(c[held].dx);
        }
        rows.solve(e + 1)
    }

    /// The closing multiplier's change: a back substitution from the (immovable) root to the
    /// closing stick's held end that moves nothing gives that end's `Δx⁰` and `Δx¹` (per unit
    /// change), then the stick's linearised row ([`kkt::closing_step`]).
    ///
    /// # Safety
    /// As for [`TreeSolve::full_newton`], after the elimination of a tree with a closing stick.
    unsafe fn closing_change(&self, view: &TreeView, c: &mut [TreeCurvature], link: &Link) -> f64 {
        let Some(closing) = view.closing else {
            return 0.0;
        };
        let held = (view.parent[closing] - view.offset) as usize;
        (c[0].dx, c[0].dx_unit) = (DVec3::ZERO, DVec3::ZERO);
        // (Parents come before their children: the path to the held end is done by then.)
        for t in 1..=held {
            let parent = (view.parent[t] - view.offset) as usize;
            let (parent_dx, parent_unit) = (c[parent].dx, c[parent].dx_unit);
            let node = &mut c[t];
            node.dx = node.reduced.substitute(parent_dx).1;
            node.dx_unit = node.reduced.substitute_load(&node.load, parent_unit).1;
        }
        kkt::closing_step(link, c[held].dx, c[held].dx_unit)
    }

    /// `M (x − x̃)` of particle `p`, `x̃` its prediction.
    ///
    /// # Safety
    /// `p` is a particle of a tree that passed [`TreeSolve::check`], held by this task.
    #[inline(always)]
    unsafe fn offset_of(&self, p: usize, predicted: DVec3) -> DVec3 {
        // SAFETY: in bounds and this task's (caller).
        unsafe {
            let w = *self.inverse_mass.get_unchecked(p);
            if w <= 0.0 {
                return DVec3::ZERO;
            }
            (self.position.get_unchecked(p) - predicted) * (1.0 / w)
        }
    }

    /// Moves particle `p` by `by` unless it is immovable.
    ///
    /// # Safety
    /// `p` is a particle of a tree that passed [`TreeSolve::check`], held by this task.
    unsafe fn shift(&self, p: usize, by: DVec3) {
        // SAFETY: in bounds and this task's (caller).
        unsafe {
            if *self.inverse_mass.get_unchecked(p) > 0.0 {
                self.position
                    .set_unchecked(p, self.position.get_unchecked(p) + by);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::Node;
    use super::super::test_support::{INV_H2, first_view, run_pass};
    use super::TreeCurvature;
    use crate::solver::{Solver, StickKind, kkt};
    use glam::DVec3;

    /// A pinned trunk of two links forking into three branches of two, bent, with stretched
    /// and compressed links and unequal masses: the pass's `Δx` and `Δλ` against the dense KKT
    /// system's Newton step.
    #[test]
    fn the_pass_is_the_newton_step_of_the_kkt_system_at_forks() {
        let mut solver = Solver::default();
        let pin = solver.add_particle(DVec3::ZERO, 0.0);
        solver.pin(pin, DVec3::ZERO);
        let mut link = |from: u32, to: DVec3, w: f64, rest: f64| {
            let p = solver.add_particle(to, w);
            solver
                .sticks
                .push([from, p], rest, 0.0, StickKind::Equal, f64::INFINITY, 0);
            p
        };
        let a = link(pin, DVec3::new(0.02, -0.11, 0.0), 1.0, 0.1);
        let fork = link(a, DVec3::new(0.05, -0.2, 0.01), 2.0, 0.1);
        for (i, side) in [-1.0, 0.0, 1.0].into_iter().enumerate() {
            let w = [0.5, 0.001, 3.0][i];
            let b = link(
                fork,
                DVec3::new(0.05 + 0.07 * side, -0.29, 0.02 * side),
                1.0,
                0.1,
            );
            link(b, DVec3::new(0.06 + 0.15 * side, -0.37, -0.01), w, 0.12);
        }
        solver.organize();
        let set = solver.islands.lines().trees.clone();
        let view = first_view(&set);
        let sticks = solver.sticks.len();
        let warm: Vec<f64> = (0..sticks).map(|k| -0.5 - 0.3 * k as f64).collect();
        let mut s = vec![Node::default(); view.particle.len()];
        for (node, &k) in s.iter_mut().zip(view.stick).skip(1) {
            node.warm = warm[k as usize];
        }
        let mut c = vec![TreeCurvature::default(); s.len()];
        let (position, lambda) = run_pass(&solver, &vec![0.0; sticks], true, |solve| {
            solve.check(&view);
            // SAFETY: this test alone holds the slices; `check` passed; only the root is pinned.
            unsafe { solve.curvature_pass(&view, &s, (&mut c, &mut [])) };
        });
        // (Within the regularisation of `D`, 10⁻⁹ relative, times the system's conditioning.)
        kkt::dense::assert_newton_step(
            &solver,
            (&solver.particles.position, &position),
            (&warm, &lambda),
            INV_H2,
            (1e-6, 1.0),
        );
    }
}
