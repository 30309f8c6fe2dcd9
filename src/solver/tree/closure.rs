//! A tree held by two immovable particles (a string of lanterns hung between two posts, a
//! Y-shaped rope hung by two of its ends): the stick to the second one closes a loop.
//!
//! # Why
//! The elimination of [`tree`](super) roots a tree at its immovable particle and reduces every
//! stick towards it; a second immovable particle cannot be reduced (nothing below its stick
//! can move: its pivot is zero), so such trees used to be covered by lines meeting at forks,
//! which block Gauss–Seidel couples a stick or two per pass — a rope of 40 links between two
//! posts carrying three strings of 10 links stretched 4.0 % (equal masses), 5.6 % (10×
//! weights) and 30 % (100×) swinging for 5 s (a review's measurement; swept: 18 %, 26 %, 101 %),
//! where the same tree on one post stays below 10⁻⁹.
//!
//! # The step
//! Baraff 1996 ("Linear-time dynamics using Lagrange multipliers") closes loops with auxiliary
//! constraints solved by a Schur complement. Here the closing stick `k` is the one from the
//! second immovable particle `B` to its parent `c`. The forward traversal leaves it out and
//! carries, beside each node's load `g_j`, the load a unit change of `Δλ_k` puts on `c`
//! (`∓w_c r_k`, the stick's pull on its other end) up to the root: `g¹`, `v¹ = A⁻¹ g¹`,
//! `β¹ = −n·v¹ / D`. Substituting from the root along the path to `c` gives `c`'s move without
//! the change and per unit of it, `Δx_c + Δλ_k Δx¹_c`; the closing row (its end `B` does not
//! move) `−n_k·Δx_c + α̃_k Δλ_k = −(C_k + α̃_k λ_k)` then gives
//!
//! ```text
//! Δλ_k = (−(C_k + α̃_k λ_k) + n_k·Δx_c) / (α̃_k − n_k·Δx¹_c)
//! ```
//!
//! and every node's substitution takes it in (`v += Δλ_k v¹`, `β += Δλ_k β¹`) before the usual
//! substitution from the root moves the particles. One extra 3 × 3 solve per node and a
//! substitution of the nodes up to `c`: O(n), exact for the linearised system (checked
//! against the dense one below). Under SHAKE the same equations hold along the start
//! directions.
//!
//! A rigid path between the two pulled to within 0.1 % of its length makes the loop's system
//! singular (as for a line between two pins): the tree is swept for that substep. Curvature and
//! full Newton passes (see [`curvature`](super::curvature)) close the loop the same way, with
//! [`kkt`](super::super::kkt)'s second load ([`Reduced::carry`](super::super::kkt::Reduced::carry),
//! [`closing_step`](super::super::kkt::closing_step)), as a line pinned at both ends does — from
//! a pinned root only (a root unpinned in place takes Gauss–Newton passes). Measured on 54
//! bridles (a scratch scan: pins 0–0.8 m apart, lamps 1–10⁴× a link, kicks up to 0.2 m in the
//! first substep, damping 0 and 0.5/s, 10 s at 8 × 1): with Gauss–Newton passes only, lamps 10⁴×
//! kicked stretched 540–10 500 % in 76 000–162 000 Newton passes; with the loop closed in the
//! curvature passes too, those kicked 0.02 m stay below 10⁻⁹ (one of six: 780 %) in 10 000–18 000
//! passes, those kicked 0.2 m (100 m/s) still 6500–10 500 %. Three or more immovable particles
//! split the tree at them ([`split`](super::split)), and a part held by more than two is
//! closed more than once ([`closings`](super::closings)).

use super::super::StickKind;
use super::super::direct::TAUT;
use super::{Closing, Node, REGULARISATION, TreeSolve, TreeView};
use glam::DVec3;

impl TreeSolve<'_, '_> {
    /// `true` when the path between the root and the closing node is rigid and within
    /// [`TAUT`] of its full length: the loop's system is singular there (as for a line between
    /// two pins, which is swept for the substep too). Never where nothing closes a loop through
    /// a movable particle: the closing stick runs from the root itself (between two pins, it is
    /// out of the system), or the root was unpinned in place (a review found both swept whole
    /// before: a beam between two posts with weights hanging from them, 6.2 % and 42 % strain
    /// where lines leave 10⁻¹⁰; a Y rope hanging straight from its second pin, 24 % and 92 %).
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`].
    pub(super) unsafe fn closing_taut(&self, view: &TreeView) -> bool {
        let Some(closing) = view.closing else {
            return false;
        };
        // SAFETY: as for this function (caller).
        if !view.extra.is_empty() && unsafe { self.extra_taut(view) } {
            return true;
        }
        let root_movable = self.inverse_mass[view.particle[0] as usize] > 0.0;
        if root_movable || view.parent[closing] == view.offset {
            return false;
        }
        let mut rest = 0.0;
        let mut t = closing;
        while t != 0 {
            let k = view.stick[t] as usize;
            let rigid = matches!(self.sticks.kind[k], StickKind::Equal | StickKind::AtMost)
                && self.sticks.compliance[k] == 0.0;
            if !rigid {
                return false;
            }
            rest += self.sticks.rest_length[k];
            t = (view.parent[t] - view.offset) as usize;
        }
        // SAFETY: the tree's particles are this task's (caller).
        let apart = unsafe {
            self.position.get(view.particle[closing] as usize)
                - self.position.get(view.particle[0] as usize)
        };
        apart.length() >= rest * (1.0 - TAUT)
    }

    /// The closing stick's `Δλ` (a Schur complement of one row, after Baraff 1996's loop-closing
    /// constraints): the closing node's parent `c` moves by `Δx_c + Δλ Δx¹_c` (substituted from
    /// the root along its path: its move without the closing multiplier's change, and the
    /// response to a unit change), and the closing stick's row `−n·Δx_c + α̃ Δλ = −(C + α̃ λ)`
    /// (its immovable end does not move) must hold. Then every node's substitution takes the
    /// change in: `v += Δλ v¹`, `β += Δλ β¹`, and the closing node's own is `Δλ`. Zero where
    /// the loop's system is singular along the stick or anything is not finite; a closing stick
    /// out of the system is released (`Δλ = −λ`).
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`], after [`TreeSolve::forward`] with `CLOSED`.
    pub(super) unsafe fn close(&self, view: &TreeView, (s, more): (&mut [Node], &mut [Closing])) {
        if !view.extra.is_empty() {
            // SAFETY: as for this function (caller).
            return unsafe { self.close_many(view, s, more) };
        }
        let Some(closing) = view.closing else {
            return;
        };
        let root = view.particle[0] as usize;
        (s[0].dx, s[0].closing.dx) = if self.inverse_mass[root] > 0.0 {
            s[0].solve_pair(s[0].load, s[0].closing.load)
        } else {
            (DVec3::ZERO, DVec3::ZERO)
        };
        // (Parents come before their children: the path to `c` is substituted by `c`.)
        let c = (view.parent[closing] - view.offset) as usize;
        for t in 1..=c {
            let parent = (view.parent[t] - view.offset) as usize;
            let (parent_dx, parent_dx1) = (s[parent].dx, s[parent].closing.dx);
            s[t].substitute_closed(parent_dx, parent_dx1);
        }
        // SAFETY: as for `solve` (caller).
        let row = unsafe { self.row(view, closing) };
        let d_lambda = if row.active {
            let n = row.normal * row.sign;
            let alpha = self.sticks.compliance[row.stick] * self.inv_h2;
            let compliance = -n.dot(s[c].closing.dx) * (1.0 + REGULARISATION) + alpha;
            let step = (-(row.c + alpha * row.lambda) + n.dot(s[c].dx)) / compliance;
            if compliance > 0.0 && step.is_finite() {
                step
            } else {
                0.0
            }
        } else {
            -row.lambda
        };
        s[0].load += s[0].closing.load * d_lambda;
        for node in &mut s[1..] {
            node.v += node.closing.v * d_lambda;
            node.beta += node.closing.beta * d_lambda;
        }
        let node = &mut s[closing];
        (node.a, node.u, node.v, node.beta) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, d_lambda);
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{INV_H2, first_view, run_pass};
    use super::super::{Closing, Node, TreeCurvature};
    use crate::solver::direct::LineMode;
    use crate::solver::{Solver, StickKind, kkt};
    use glam::DVec3;

    /// A path of four bent links between two pins with a branch of two links from its middle
    /// (unequal masses, links stretched and compressed, one compliant): one Gauss–Newton pass of
    /// the closed tree (projected, from λ = 0) against the dense linearised system's step.
    #[test]
    fn a_pass_closes_the_loop_as_the_dense_system_does() {
        let mut solver = Solver::default();
        let a = solver.add_particle(DVec3::ZERO, 0.0);
        solver.pin(a, DVec3::ZERO);
        let mut link = |from: u32, to: DVec3, w: f64, rest: f64, compliance: f64| {
            let p = solver.add_particle(to, w);
            solver.sticks.push(
                [from, p],
                rest,
                compliance,
                StickKind::Equal,
                f64::INFINITY,
                0,
            );
            p
        };
        let p1 = link(a, DVec3::new(0.09, -0.05, 0.01), 1.0, 0.1, 0.0);
        let fork = link(p1, DVec3::new(0.2, -0.08, 0.0), 2.0, 0.12, 0.0);
        let p3 = link(fork, DVec3::new(0.3, -0.04, -0.02), 0.5, 0.1, 1e-4);
        let branch = link(fork, DVec3::new(0.21, -0.19, 0.01), 1.0, 0.1, 0.0);
        link(branch, DVec3::new(0.23, -0.3, 0.0), 0.01, 0.1, 0.0);
        let b = solver.add_particle(DVec3::new(0.41, 0.0, 0.0), 0.0);
        solver.pin(b, DVec3::new(0.41, 0.0, 0.0));
        solver
            .sticks
            .push([b, p3], 0.1, 2e-5, StickKind::Equal, f64::INFINITY, 0);
        solver.organize();
        // (Then the root unpinned in place, as the Bevy layer does without a rebuild: the root
        // moves, the closing stick still closes the loop.)
        for root_movable in [false, true] {
            let root = solver.islands.lines().trees.particle[0] as usize;
            solver.particles.inverse_mass[root] = if root_movable { 0.7 } else { 0.0 };
            closed_pass_matches_dense(&solver, false);
        }
        // A curvature pass (full Newton, λ warm-started: tensions and one push) closes the loop
        // too, from the pinned root.
        let root = solver.islands.lines().trees.particle[0] as usize;
        solver.particles.inverse_mass[root] = 0.0;
        closed_pass_matches_dense(&solver, true);
    }

    /// One pass of `solver`'s closed tree against the dense system's step: Gauss–Newton from
    /// λ = 0, or with `curvature` a curvature pass from warm-started multipliers.
    fn closed_pass_matches_dense(solver: &Solver, curvature: bool) {
        let set = solver.islands.lines().trees.clone();
        let view = first_view(&set);
        // (The root is the first pin; the closing nodes the others, still immovable.)
        let closing = view.closing.expect("two pins: a closed tree");
        for t in view.extra.iter().map(|&t| t as usize).chain([closing]) {
            assert_eq!(
                solver.particles.inverse_mass[view.particle[t] as usize],
                0.0
            );
        }
        let sticks = solver.sticks.len();
        let warm: Vec<f64> = (0..sticks)
            .map(|k| match (curvature, k) {
                (false, _) => 0.0,
                (true, 2) => 0.4,
                (true, k) => -0.5 - 0.3 * k as f64,
            })
            .collect();
        let mut s = vec![Node::default(); view.particle.len()];
        for (node, &k) in s.iter_mut().zip(view.stick).skip(1) {
            node.warm = warm[k as usize];
        }
        let mut c = vec![TreeCurvature::default(); s.len()];
        let mut more = stale_records(s.len() * view.extra.len());
        let (position, lambda) = run_pass(solver, &vec![0.0; sticks], false, |solve| {
            solve.check(&view);
            // SAFETY: this test alone holds the slices; `check` passed; the closing nodes and
            // the root are the only immovable particles.
            unsafe {
                if curvature {
                    solve.curvature_pass(&view, &s, (&mut c, &mut more));
                } else {
                    solve.gauss_newton_forward::<false>(&view, (&mut s, &mut more));
                    solve.close(&view, (&mut s, &mut more));
                    solve.backward(&view, &mut s);
                }
            }
        });
        // (With λ = 0 the full Newton step is Gauss–Newton's: no curvature term.)
        kkt::dense::assert_newton_step(
            solver,
            (&solver.particles.position, &position),
            (&warm, &lambda),
            INV_H2,
            (1e-7, 1e-3),
        );
    }

    /// Variants of a closed tree — a rope continuing past the second pin, the closing stick
    /// stored either way round and compliant, a slack rope link on the path between the pins
    /// (released), the root unpinned in place — one pass along the start directions (SHAKE,
    /// turned from the current ones) or the current ones (Gauss–Newton), λ from 0 or not: the
    /// closed elimination against the dense unsymmetric system's step (`kkt::dense::step_along`;
    /// after a review's check of 9b1a266).
    #[test]
    fn shake_and_gauss_newton_passes_close_the_loop_as_the_dense_system_does() {
        for variant in 0..16 {
            let [past, flip, compliant, released] = [1, 2, 4, 8].map(|bit| variant & bit != 0);
            let mut solver = variant_scene(past, flip, compliant, released);
            for root_movable in [false, true] {
                let root = solver.islands.lines().trees.particle[0] as usize;
                solver.particles.inverse_mass[root] = if root_movable { 0.7 } else { 0.0 };
                for (shake, lambda) in [(false, 0.0), (false, -0.3), (true, 0.0), (true, -0.3)] {
                    one_pass_matches_dense(&solver, shake, lambda);
                }
            }
        }
    }

    /// A tree held by four immovable particles (a rope between two posts, a branch from its
    /// middle to a third post and one from that branch to a fourth, a heavy free end below):
    /// split at its pins it stays one part, closed three times. Variants — a slack rope link
    /// released, one closing stick compliant, the root unpinned in place — one pass along the
    /// start directions (SHAKE) or the current ones (Gauss–Newton), λ from 0 or not, against
    /// the dense unsymmetric system's step; and (no stick released) a curvature pass against
    /// the dense full Newton step.
    #[test]
    fn passes_close_several_loops_as_the_dense_system_does() {
        for variant in 0..4 {
            let [released, compliant] = [1, 2].map(|bit| variant & bit != 0);
            let mut solver = several_loops(released, compliant);
            let set = solver.islands.lines().trees.clone();
            assert_eq!(set.trees.len(), 1, "one part");
            assert!(set.trees[0].closing.is_some());
            assert_eq!(set.trees[0].extra_closings.len(), 2, "closed three times");
            for root_movable in [false, true] {
                let root = set.particle[0] as usize;
                solver.particles.inverse_mass[root] = if root_movable { 0.7 } else { 0.0 };
                for (shake, lambda) in [(false, 0.0), (false, -0.3), (true, 0.0), (true, -0.3)] {
                    one_pass_matches_dense(&solver, shake, lambda);
                }
            }
            // Gauss–Newton from λ = 0 and a curvature pass (full Newton, λ warm-started), from
            // the pinned root (every stick in the system: the dense step's assumption).
            let root = set.particle[0] as usize;
            solver.particles.inverse_mass[root] = 0.0;
            if !released {
                closed_pass_matches_dense(&solver, false);
                closed_pass_matches_dense(&solver, true);
            }
        }
    }

    /// `n` extra closing records with loads left in them, as a curvature pass leaves them for
    /// the Gauss–Newton pass after it (a review found them read): the passes must not use them.
    fn stale_records(n: usize) -> Vec<Closing> {
        let stale = Closing {
            load: DVec3::new(0.3, -0.2, 0.1),
            ..Closing::default()
        };
        vec![stale; n]
    }

    /// The tree of [`passes_close_several_loops_as_the_dense_system_does`].
    fn several_loops(released: bool, compliant: bool) -> Solver {
        let mut solver = Solver::default();
        let mut post = |at: DVec3| {
            let p = solver.add_particle(at, 0.0);
            solver.pin(p, at);
            p
        };
        let posts = [
            post(DVec3::ZERO),
            post(DVec3::new(0.41, 0.0, 0.0)),
            post(DVec3::new(0.2, -0.45, 0.1)),
            post(DVec3::new(0.45, -0.3, -0.05)),
        ];
        let mut particle = |at: DVec3, w: f64| solver.add_particle(at, w);
        let p1 = particle(DVec3::new(0.09, -0.05, 0.01), 1.0);
        let fork = particle(DVec3::new(0.2, -0.1, 0.0), 2.0);
        let p3 = particle(DVec3::new(0.31, -0.04, -0.02), 0.5);
        let branch = particle(DVec3::new(0.21, -0.22, 0.03), 1.0);
        let twig = particle(DVec3::new(0.33, -0.26, 0.0), 0.3);
        let weight = particle(DVec3::new(0.2, -0.33, 0.05), 0.01);
        let mut link = |[a, b]: [u32; 2], kind: StickKind, compliance: f64| {
            let x = &solver.particles.position;
            let rest = (x[b as usize] - x[a as usize]).length() * 1.02;
            let rest = if kind == StickKind::AtMost {
                rest * 1.5
            } else {
                rest
            };
            solver
                .sticks
                .push([a, b], rest, compliance, kind, f64::INFINITY, 0);
        };
        let rope = if released {
            StickKind::AtMost
        } else {
            StickKind::Equal
        };
        let soft = if compliant { 3e-4 } else { 0.0 };
        link([posts[0], p1], StickKind::Equal, 0.0);
        link([p1, fork], rope, 0.0);
        link([fork, p3], StickKind::Equal, 0.0);
        link([posts[1], p3], StickKind::Equal, soft);
        link([fork, branch], StickKind::Equal, 0.0);
        link([branch, posts[2]], StickKind::Equal, 0.0);
        link([branch, twig], StickKind::Equal, 0.0);
        link([twig, posts[3]], StickKind::Equal, 2e-5);
        link([branch, weight], StickKind::Equal, 0.0);
        solver.organize();
        solver
    }

    /// The closed tree of [`a_pass_closes_the_loop_as_the_dense_system_does`], varied.
    fn variant_scene(past: bool, flip: bool, compliant: bool, released: bool) -> Solver {
        let mut solver = Solver::default();
        let a = solver.add_particle(DVec3::ZERO, 0.0);
        solver.pin(a, DVec3::ZERO);
        let mut link = |from: u32, to: DVec3, w: f64, rest: f64, kind: StickKind| {
            let p = solver.add_particle(to, w);
            solver
                .sticks
                .push([from, p], rest, 0.0, kind, f64::INFINITY, 0);
            p
        };
        let p1 = link(a, DVec3::new(0.09, -0.05, 0.01), 1.0, 0.1, StickKind::Equal);
        let (rest, kind) = match released {
            true => (0.2, StickKind::AtMost),
            false => (0.12, StickKind::Equal),
        };
        let fork = link(p1, DVec3::new(0.2, -0.08, 0.0), 2.0, rest, kind);
        let p3 = link(
            fork,
            DVec3::new(0.3, -0.04, -0.02),
            0.5,
            0.1,
            StickKind::Equal,
        );
        let branch = link(
            fork,
            DVec3::new(0.21, -0.19, 0.01),
            1.0,
            0.1,
            StickKind::Equal,
        );
        link(
            branch,
            DVec3::new(0.23, -0.3, 0.0),
            0.01,
            0.1,
            StickKind::Equal,
        );
        let b = solver.add_particle(DVec3::new(0.41, 0.0, 0.0), 0.0);
        solver.pin(b, DVec3::new(0.41, 0.0, 0.0));
        let ends = if flip { [p3, b] } else { [b, p3] };
        let compliance = if compliant { 3e-4 } else { 0.0 };
        solver
            .sticks
            .push(ends, 0.1, compliance, StickKind::Equal, f64::INFINITY, 0);
        if past {
            let mut link = |from: u32, to: DVec3, w: f64| {
                let p = solver.add_particle(to, w);
                solver
                    .sticks
                    .push([from, p], 0.1, 0.0, StickKind::Equal, f64::INFINITY, 0);
                p
            };
            let q1 = link(b, DVec3::new(0.5, -0.03, 0.0), 0.3);
            link(q1, DVec3::new(0.52, -0.14, 0.01), 3.0);
            link(b, DVec3::new(0.4, -0.05, 0.02), 1.0);
        }
        solver.organize();
        solver
    }

    /// One pass of `solver`'s closed tree (SHAKE along directions turned from the current ones,
    /// or Gauss–Newton), every multiplier starting at `lambda`, against the dense step.
    fn one_pass_matches_dense(solver: &Solver, shake: bool, lambda: f64) {
        let set = solver.islands.lines().trees.clone();
        let view = first_view(&set);
        let x = &solver.particles.position;
        let ends = kkt::dense::ends_of(solver);
        let r: Vec<DVec3> = (0..ends.len())
            .map(|k| {
                let n = (x[ends[k][1]] - x[ends[k][0]]).normalize();
                let turn = DVec3::new(0.05, -0.03, 0.04) * ((k % 3) as f64 - 1.0);
                if shake {
                    (n + turn + DVec3::new(0.0, 0.02, -0.03)).normalize()
                } else {
                    n
                }
            })
            .collect();
        let mut s = vec![Node::default(); view.particle.len()];
        for t in 1..s.len() {
            s[t].start = r[view.stick[t] as usize];
        }
        s[0].mode = if shake {
            LineMode::Shake
        } else {
            LineMode::Project
        };
        let warm: Vec<f64> = (0..ends.len())
            .map(|k| lambda * (1.0 + 0.1 * k as f64))
            .collect();
        let mut active = Vec::new();
        let mut more = stale_records(s.len() * view.extra.len());
        let (position, after) = run_pass(solver, &warm, shake, |solve| {
            solve.check(&view);
            // SAFETY: this test alone holds the slices; `check` passed; the root and the closing
            // node are the only particles that may be immovable.
            unsafe {
                active = (0..ends.len())
                    .map(|k| {
                        let t = (1..s.len()).find(|&t| view.stick[t] as usize == k);
                        solve.row(&view, t.unwrap()).active
                    })
                    .collect();
                solve.gauss_newton_forward::<false>(&view, (&mut s, &mut more));
                solve.close(&view, (&mut s, &mut more));
                solve.backward(&view, &mut s);
            }
        });
        let (want_dx, want_dl) = kkt::dense::step_along(
            &kkt::dense::System {
                x,
                inverse_mass: &solver.particles.inverse_mass,
                ends: &ends,
                lambda: &warm,
                rest: &solver.sticks.rest_length,
                compliance: &solver.sticks.compliance,
                active: &active,
                inv_h2: INV_H2,
            },
            &r,
        );
        let scale = want_dx.iter().map(|d| d.length()).fold(0.0, f64::max);
        for j in 0..x.len() {
            let got = position[j] - x[j];
            assert!(
                (got - want_dx[j]).length() < 1e-7 * scale,
                "shake {shake}, λ {lambda}: particle {j}: Δx {got} against {}",
                want_dx[j]
            );
        }
        for k in 0..ends.len() {
            let (got, want) = (after[k] - warm[k], want_dl[k]);
            assert!(
                (got - want).abs() < 1e-7 * want.abs().max(1e-3),
                "shake {shake}, λ {lambda}: stick {k}: Δλ {got} against {want}"
            );
        }
    }
}
