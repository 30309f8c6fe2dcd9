//! The first projection pass of a substep with the constraints' curvature (a full Newton step on
//! the projection's KKT system), for a line that is its island's only one (a chain, a rope).
//!
//! # Why
//! Where SHAKE fails (links turning fast) a line is projected: Newton along the *current*
//! directions, from the prediction. That is Gauss–Newton — it leaves out how a stick's
//! direction turns as its ends move, the constraints' curvature, which a heavy load's tension
//! makes large — and on a whipping 1000:1 chain it wanders for five to ten passes before it
//! converges. One full Newton step on the projection's KKT system — the curvature included,
//! eliminated from the line's free end towards its root, see [`kkt`] — from the prediction, with
//! λ warm-started from the last substep, does what Gauss–Newton takes many passes for; later
//! passes are the usual ones along the current directions.
//!
//! # When
//! In the C prototype `report/prototypes/whip_substep.c` one such pass at the start of every
//! projection (mode `kkt1`) takes the whipping 1000:1 chain's projections from 8.2 Newton passes
//! per substep to 3.0 (a curvature pass in every pass: 3.1) and 15 795 passes in all to 6646. But
//! the crate's pass costs about five ordinary ones (62 against 12.6 ns per particle on a
//! 200-link line, a scratch benchmark; the elimination is bound by its ~600 instructions per
//! particle, not by its chain of dependent operations), so
//! where it saves fewer passes it costs time: in a scratch build running it in every projected
//! substep, the swinging 1000:1 chain took 18 % less time and the 200-link chain (equal masses)
//! 8 % more. It runs where it pays: in a substep that *begins* projected (while a line waits
//! after failed SHAKE tries, or with a link predicted to turn too far); after SHAKE failed in the same
//! substep only where the line's tension is stiff
//! ([`CURVATURE_AFTER_SHAKE_ABOVE`](super::CURVATURE_AFTER_SHAKE_ABOVE): the 1000:1 chain's
//! projections after a failure took 8.6 Gauss–Newton passes each); and where the prediction is within
//! [`CURVATURE_BELOW`](super::CURVATURE_BELOW) of the constraints. Measured (release, 8 × 1,
//! 5 s from horizontal; old and new builds interleaved, three runs of the best of five): 1000:1
//! chain 14 285 → 10 331 Newton passes, 26.8–26.9 → 23.6–23.7 ms; 200 links 6613 → 5471 passes,
//! 31.4–32.3 → 30.2 ms (one run of each new figure was disturbed: 25.5 and 42.6 ms); valgrind
//! callgrind, whole runs: −16.2 % and −7.2 % instructions. Largest strain below 10⁻⁹ either way.
//!
//! Compression (`λ > 0`) would make `E` indefinite: `μ` is clamped at zero there (Gauss–Newton
//! for that stick). A stick out of its active set (a slack rope) has `λ = 0` and decouples its
//! subtree. Only the root — the end eliminated last — may be immovable, or both ends: the
//! stick to the second pin then closes a loop, solved by a Schur complement
//! ([`closure`](super::closure)). A line pinned inside is eliminated stretch by stretch
//! between its immovable particles, which decouple the sticks on either side of them
//! ([`Root::Segments`]; `E` would be singular below a pin).

use super::super::kkt::{self, Link, Subtree};
use super::{LineRef, LineSolve};
use glam::DVec3;

/// Which end of a line the elimination ends at.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Root {
    First,
    Last,
    /// Both ends immovable: eliminated towards the first, the last stick closing the loop (see
    /// [`closure`](super::closure)).
    Both,
    /// Immovable particles inside the line: each stretch between them (or between one and a
    /// free end) is eliminated on its own with its own root — an immovable particle decouples
    /// the sticks on either side of it.
    Segments,
}

impl LineSolve<'_, '_> {
    /// Where the curvature pass may run on `line`: every particle movable but possibly its
    /// ends (the root, an immovable end if there is one; both, see [`Root::Both`]), or in
    /// stretches between immovable particles ([`Root::Segments`]).
    ///
    /// # Safety
    /// `line` passed [`LineSolve::check`].
    pub(super) unsafe fn curvature_root(&self, line: &LineRef) -> Option<Root> {
        // SAFETY: in bounds (`check`, this function's contract).
        unsafe {
            let m = line.sticks.len();
            if !(1..m).all(|j| self.w(line.p(j)) > 0.0) {
                return Some(Root::Segments);
            }
            match (self.w(line.p(0)) > 0.0, self.w(line.p(m)) > 0.0) {
                (true, false) => Some(Root::Last),
                (_, true) => Some(Root::First),
                (false, false) => (m >= 2).then_some(Root::Both),
            }
        }
    }

    /// The line's child particle and stick at elimination step `t` (`t = 1..=m`, leaf
    /// first), and the child's index in the line.
    ///
    /// # Safety
    /// `line` passed [`LineSolve::check`], `1 ≤ t ≤ m`.
    #[inline(always)]
    pub(super) unsafe fn curvature_link(
        &self,
        line: &LineRef,
        root: Root,
        t: usize,
    ) -> (usize, usize, usize) {
        // SAFETY: in bounds (caller).
        unsafe {
            let m = line.sticks.len();
            match root {
                Root::First | Root::Both | Root::Segments => (line.p(m - t + 1), m - t, m - t + 1),
                Root::Last => (line.p(t - 1), t - 1, t - 1),
            }
        }
    }

    /// One full Newton pass from the prediction, λ warm-started from the last substep.
    ///
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`]; `root` from
    /// [`LineSolve::curvature_root`]; nothing has moved the line this substep.
    pub(super) unsafe fn curvature_pass(&self, line: &LineRef, root: Root) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (this function's
        // contract).
        unsafe {
            // (Only sticks in the system at the prediction: `begin` forgot the others' kept
            // multipliers, a slack rope link's.)
            for (k, &s) in line.sticks.iter().enumerate() {
                let warm = self.scratch.warm.get_unchecked(line.offset + k);
                self.lambda
                    .set_unchecked(s as usize, self.warm_of(s as usize, warm));
            }
            self.newton_pass::<false>(line, root);
        }
    }

    /// One full Newton pass over `line` with root `root` (see [`kkt`]); `MOVED` as for
    /// [`LineSolve::curvature_forward`].
    ///
    /// # Safety
    /// As for [`LineSolve::curvature_pass`] (`MOVED = false`, λ warm-started) or
    /// [`LineSolve::full_newton`] (`MOVED = true`).
    unsafe fn newton_pass<const MOVED: bool>(&self, line: &LineRef, root: Root) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (caller).
        unsafe {
            match root {
                Root::Both => self.closed_pass::<MOVED>(line),
                Root::Segments => self.segment_passes::<MOVED>(line),
                Root::First | Root::Last => {
                    let root_offset = if MOVED {
                        let j = if root == Root::First {
                            0
                        } else {
                            line.sticks.len()
                        };
                        self.offset_of(line, line.p(j), j)
                    } else {
                        DVec3::ZERO
                    };
                    let below = self.curvature_forward::<MOVED>(line, root);
                    self.curvature_backward(line, root, below, root_offset);
                }
            }
        }
    }

    /// [`LineSolve::newton_pass`] on each stretch of `line` between its immovable particles
    /// ([`Root::Segments`]), each with the root it takes alone.
    ///
    /// # Safety
    /// As for [`LineSolve::newton_pass`].
    unsafe fn segment_passes<const MOVED: bool>(&self, line: &LineRef) {
        // SAFETY: the stretches are sub-slices of `line` with their scratch offsets moved
        // along, so every index they use is one of `line`'s (caller).
        unsafe {
            let m = line.sticks.len();
            let mut start = 0;
            for end in 1..=m {
                if end < m && self.w(line.p(end)) > 0.0 {
                    continue;
                }
                let stretch = LineRef {
                    particles: &line.particles[start..=end],
                    sticks: &line.sticks[start..end],
                    offset: line.offset + start,
                    particle_offset: line.particle_offset + start,
                };
                match self.curvature_root(&stretch) {
                    Some(root) => self.newton_pass::<MOVED>(&stretch, root),
                    // A stick between two adjacent immovable particles (islands join pins too):
                    // out of the system, released as every pass releases it.
                    None => self.lambda.set_unchecked(line.s(start), 0.0),
                }
                start = end;
            }
        }
    }

    /// Full Newton passes from the current iterate (the projection's residual `R` measured
    /// against the substep's prediction, which [`LineSolve::begin`] kept) until the line is
    /// within [`TOLERANCE`](super::TOLERANCE) or `budget` passes are done. Returns the passes
    /// taken and whether it converged.
    ///
    /// # Safety
    /// As for [`LineSolve::curvature_pass`], but the line may have moved this substep; the line
    /// is its island's only one, so `begin` kept its prediction.
    pub(super) unsafe fn full_newton(
        &self,
        line: &LineRef,
        root: Root,
        budget: u32,
    ) -> (u32, bool) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (caller).
        unsafe {
            for passes in 0..budget {
                self.newton_pass::<true>(line, root);
                if self.residual(line) <= super::TOLERANCE {
                    return (passes + 1, true);
                }
            }
            (budget, false)
        }
    }

    /// `M (x − x̃)` of the line's particle `p` (its index `j`), `x̃` the substep's prediction.
    ///
    /// # Safety
    /// As for [`LineSolve::full_newton`].
    #[inline(always)]
    pub(super) unsafe fn offset_of(&self, line: &LineRef, p: usize, j: usize) -> DVec3 {
        // SAFETY: in bounds (caller).
        unsafe {
            let w = self.w(p);
            if w <= 0.0 {
                return DVec3::ZERO;
            }
            let predicted = self
                .scratch
                .predicted
                .get_unchecked(line.particle_offset + j);
            (self.position.get_unchecked(p) - predicted) * (1.0 / w)
        }
    }

    /// Leaf to root: each stick reduced (see [`kkt`]); returns what the sticks contribute to
    /// the root.
    ///
    /// # Safety
    /// As for [`LineSolve::curvature_pass`], and `root` from [`LineSolve::curvature_root`].
    /// With `MOVED`, the line may have moved from the prediction (`R` includes `M (x − x̃)`).
    unsafe fn curvature_forward<const MOVED: bool>(&self, line: &LineRef, root: Root) -> Subtree {
        // SAFETY: this task alone holds the line, whose indices are in bounds (caller).
        unsafe {
            let mut below = Subtree::default();
            for t in 1..=line.sticks.len() {
                let (link, k) = self.curvature_input::<MOVED>(line, root, t);
                let reduced;
                (reduced, below) = kkt::reduce(&link, &below);
                self.scratch
                    .curvature
                    .set_unchecked(line.offset + k, reduced);
            }
            below
        }
    }

    /// The elimination's stick at step `t` (see [`LineSolve::curvature_link`]) as [`kkt`] reads
    /// it, and its index in the line; its multiplier is zeroed where it is out of the system.
    ///
    /// # Safety
    /// As for [`LineSolve::curvature_forward`], `1 ≤ t ≤ m`.
    #[inline(always)]
    pub(super) unsafe fn curvature_input<const MOVED: bool>(
        &self,
        line: &LineRef,
        root: Root,
        t: usize,
    ) -> (Link, usize) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (caller).
        unsafe {
            let (c, k, j) = self.curvature_link(line, root, t);
            let s = line.s(k);
            let row = self.row(line, k);
            if !row.active {
                self.lambda.set_unchecked(s, 0.0);
            }
            let link = Link {
                // (From the parent to the child.)
                normal: if root == Root::Last {
                    -row.normal
                } else {
                    row.normal
                },
                c: row.c,
                length: row.c + self.rest(s),
                lambda: if row.active {
                    self.lambda.get_unchecked(s)
                } else {
                    0.0
                },
                alpha: self.compliance(s) * self.inv_h2,
                inverse_mass: self.w(c),
                offset: if MOVED {
                    self.offset_of(line, c, j)
                } else {
                    DVec3::ZERO
                },
                active: row.active,
            };
            (link, k)
        }
    }

    /// Root to leaf: `Δx` and `Δλ` substituted, particles moved and λ updated.
    ///
    /// # Safety
    /// As for [`LineSolve::curvature_forward`], which ran just before.
    unsafe fn curvature_backward(
        &self,
        line: &LineRef,
        root: Root,
        below: Subtree,
        root_offset: DVec3,
    ) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (caller).
        unsafe {
            let m = line.sticks.len();
            let root_particle = match root {
                Root::Last => line.p(m),
                _ => line.p(0),
            };
            let mut dx = kkt::root_step(self.w(root_particle), &below, root_offset);
            self.shift(root_particle, dx);
            for t in (1..=m).rev() {
                let (c, k, _) = self.curvature_link(line, root, t);
                let s = line.s(k);
                let d_lambda;
                (d_lambda, dx) = self
                    .scratch
                    .curvature
                    .get_unchecked(line.offset + k)
                    .substitute(dx);
                self.lambda
                    .set_unchecked(s, self.lambda.get_unchecked(s) + d_lambda);
                self.shift(c, dx);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{LineRef, LineScratch, LineSolve, LineViews, in_system, in_system_with};
    use crate::solver::kkt;
    use crate::solver::shared::SharedSlice;
    use crate::solver::{StickKind, Sticks};
    use glam::DVec3;

    /// A bent line of five particles: inverse masses `w` (0 = immovable), tensions `lambda`.
    struct Case {
        x: Vec<DVec3>,
        w: Vec<f64>,
        lambda: Vec<f64>,
        rest: Vec<f64>,
        compliance: Vec<f64>,
        kind: Vec<StickKind>,
    }

    fn case(w: [f64; 5]) -> Case {
        let x = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.11, -0.02, 0.01),
            DVec3::new(0.19, -0.09, 0.03),
            DVec3::new(0.22, -0.2, -0.02),
            DVec3::new(0.3, -0.27, 0.05),
        ];
        Case {
            x,
            w: w.to_vec(),
            lambda: vec![-3.0, -2.5, 0.7, -1.0],
            rest: vec![0.1, 0.1, 0.12, 0.1],
            compliance: vec![0.0, 1e-4, 0.0, 0.0],
            kind: vec![StickKind::Equal; 4],
        }
    }

    /// Whether stick `k` is in the system (a rope link while stretched; never a stick between
    /// two immovable particles).
    fn active(c: &Case, k: usize) -> bool {
        if c.w[k] + c.w[k + 1] <= 0.0 {
            return false;
        }
        let stretch = (c.x[k + 1] - c.x[k]).length() - c.rest[k];
        // (The pass's warm start: a one-sided stick's only where it can act and it is in the
        // system at the prediction; then the primal–dual rule with that multiplier.)
        let warm = match c.kind[k] {
            StickKind::AtMost if in_system(c.kind[k], stretch, c.rest[k]) => c.lambda[k].min(0.0),
            StickKind::Equal => c.lambda[k],
            _ => 0.0,
        };
        let reach = warm * (c.w[k] + c.w[k + 1]);
        in_system_with(c.kind[k], stretch, reach, c.rest[k])
    }

    const INV_H2: f64 = 4096.0;

    /// Runs `f` on the case's line (positions `position`, multipliers `lambda`, scratch
    /// `scratch`), after its bounds check.
    fn on_line<R>(
        c: &Case,
        (position, lambda, scratch): (&mut [DVec3], &mut [f64], &mut LineScratch),
        f: impl FnOnce(&LineSolve, &LineRef) -> R,
    ) -> R {
        let mut sticks = Sticks::default();
        for k in 0..4 {
            let (rest, compliance) = (c.rest[k], c.compliance[k]);
            let ends = [k as u32, k as u32 + 1];
            sticks.push(ends, rest, compliance, c.kind[k], f64::INFINITY, 0);
        }
        let mut previous = c.x.clone();
        let solve = LineSolve {
            position: SharedSlice::new(position),
            previous: SharedSlice::new(&mut previous),
            mirror: None,
            lambda: SharedSlice::new(lambda),
            inverse_mass: &c.w,
            sticks: &sticks,
            scratch: LineViews::new(scratch),
            inv_h2: INV_H2,
            shake: true,
            first_round: true,
            alone: true,
        };
        let line = LineRef {
            particles: &[0, 1, 2, 3, 4],
            sticks: &[0, 1, 2, 3],
            offset: 0,
            particle_offset: 0,
        };
        solve.check(&line);
        f(&solve, &line)
    }

    /// The pass's `Δx` and `Δλ`, or `None` where it does not apply.
    fn by_pass(c: &Case) -> Option<(Vec<DVec3>, Vec<f64>)> {
        let mut position = c.x.clone();
        let mut lambda = [0.0; 4];
        let mut scratch = LineScratch::default();
        scratch.resize(4, 5, &Default::default());
        scratch.warm.copy_from_slice(&c.lambda);
        let slices = (&mut position[..], &mut lambda[..], &mut scratch);
        // SAFETY: this test alone holds the slices; `check` passed; nothing moved the line.
        let applied = on_line(c, slices, |solve, line| unsafe {
            let root = solve.curvature_root(line)?;
            solve.curvature_pass(line, root);
            Some(())
        });
        applied.map(|()| {
            let dx = position.iter().zip(&c.x).map(|(a, b)| *a - *b).collect();
            let dl = lambda.iter().zip(&c.lambda).map(|(a, b)| a - b).collect();
            (dx, dl)
        })
    }

    /// The same Newton step from the dense KKT system.
    fn dense(c: &Case) -> (Vec<DVec3>, Vec<f64>) {
        let ends: Vec<[usize; 2]> = (0..4).map(|k| [k, k + 1]).collect();
        let active: Vec<bool> = (0..4).map(|k| active(c, k)).collect();
        kkt::dense::newton_step(&kkt::dense::System {
            x: &c.x,
            inverse_mass: &c.w,
            ends: &ends,
            lambda: &c.lambda,
            rest: &c.rest,
            compliance: &c.compliance,
            active: &active,
            inv_h2: INV_H2,
        })
    }

    fn assert_matches_dense(c: Case) {
        let (dx, dl) = by_pass(&c).expect("the curvature pass applies");
        let (want_dx, want_dl) = dense(&c);
        // (Within the regularisation of `D`, 10⁻⁹ relative, times the system's conditioning.)
        let scale = want_dx.iter().map(|d| d.length()).fold(0.0, f64::max);
        for (got, want) in dx.iter().zip(&want_dx) {
            assert!(
                (*got - *want).length() < 1e-6 * scale,
                "Δx {got} against {want}"
            );
        }
        // (A stick out of the system ends at λ = 0: its Δλ is minus its warm start.)
        let want_dl: Vec<f64> = (0..4)
            .map(|k| {
                if active(&c, k) {
                    want_dl[k]
                } else {
                    -c.lambda[k]
                }
            })
            .collect();
        for (got, want) in dl.iter().zip(&want_dl) {
            assert!(
                (got - want).abs() < 1e-6 * want.abs().max(1.0),
                "Δλ {got} against {want}"
            );
        }
    }

    #[test]
    fn the_pass_is_the_newton_step_of_the_kkt_system() {
        // Pinned first, a heavy tip; pinned last; free.
        assert_matches_dense(case([0.0, 1.0, 2.0, 0.5, 0.001]));
        assert_matches_dense(case([0.001, 1.0, 2.0, 0.5, 0.0]));
        assert_matches_dense(case([3.0, 1.0, 2.0, 0.5, 0.001]));
        // Rope links: the third made 0.13 long (its ends 0.1245 apart) is slack, the others
        // stretched.
        let mut ropes = case([0.0, 1.0, 2.0, 0.5, 0.001]);
        ropes.kind = vec![StickKind::AtMost; 4];
        ropes.rest[2] = 0.13;
        assert!(!active(&ropes, 2) && active(&ropes, 0) && active(&ropes, 3));
        assert_matches_dense(ropes);
    }

    /// A second try's save restarts the line from the start of the substep with λ = 0 (pins left
    /// where they are), and its restore puts the iterate back bit for bit
    /// (`LineSolve::swap_iterate`, see [`second_try`](super::super::second_try)).
    #[test]
    fn a_second_try_saves_and_restores_the_iterate_exactly() {
        let c = case([0.0, 1.0, 2.0, 0.5, 0.001]);
        let moved = |j: usize| c.x[j] + DVec3::new(0.013, -0.007, 0.002) * (j as f64 + 0.3);
        let iterate: Vec<DVec3> = (0..5).map(moved).collect();
        let multipliers = [-0.2, -0.1, 0.05, -0.3];
        let (mut position, mut lambda) = (iterate.clone(), multipliers);
        let mut scratch = LineScratch::default();
        scratch.resize(4, 5, &Default::default());
        let slices = (&mut position[..], &mut lambda[..], &mut scratch);
        // SAFETY: this test alone holds the slices; `check` passed.
        let (restarted, zeroed) = on_line(&c, slices, |solve, line| unsafe {
            solve.swap_iterate(line, true);
            let at: Vec<DVec3> = (0..5).map(|j| solve.position.get(j)).collect();
            let zeroed = (0..4).all(|k| solve.lambda.get(k) == 0.0);
            solve.swap_iterate(line, false);
            (at, zeroed)
        });
        // The start of the substep is `c.x` (`on_line`'s previous positions); the pin stays.
        assert_eq!(restarted[0], iterate[0]);
        assert_eq!(restarted[1..], c.x[1..]);
        assert!(zeroed);
        assert_eq!(position, iterate);
        assert_eq!(lambda, multipliers);
    }

    /// Full Newton passes from an iterate moved off the prediction (`M (x − x̃) ≠ 0`) converge
    /// to the projection: the constraints hold and `M (x − x̃) = ∇C(x)ᵀ λ` (rigid sticks), for
    /// a line rooted at either end.
    #[test]
    fn full_newton_from_a_moved_iterate_reaches_the_projection() {
        for w in [[0.0, 1.0, 2.0, 0.5, 0.001], [0.001, 1.0, 2.0, 0.5, 0.0]] {
            let mut c = case(w);
            c.compliance = vec![0.0; 4];
            // The prediction `c.x`; the iterate moved off it, λ made up.
            let mut position: Vec<DVec3> = (0..5)
                .map(|j| {
                    c.x[j] + DVec3::new(0.003, -0.002, 0.001) * (j as f64) * f64::from(w[j] > 0.0)
                })
                .collect();
            let mut lambda = [-0.2, -0.1, 0.05, -0.3];
            let mut scratch = LineScratch::default();
            scratch.resize(4, 5, &Default::default());
            scratch.predicted.copy_from_slice(&c.x);
            let slices = (&mut position[..], &mut lambda[..], &mut scratch);
            // SAFETY: this test alone holds the slices; `check` passed; the prediction is kept.
            let (passes, converged) = on_line(&c, slices, |solve, line| unsafe {
                let root = solve.curvature_root(line).unwrap();
                solve.full_newton(line, root, 16)
            });
            assert!(converged && passes <= 8, "{passes} passes");
            for j in 0..5 {
                if w[j] <= 0.0 {
                    continue;
                }
                let mut force = DVec3::ZERO; // ∇C(x)ᵀ λ at particle j
                for k in 0..4 {
                    let n = (position[k + 1] - position[k]).normalize();
                    if k + 1 == j {
                        force += n * lambda[k];
                    }
                    if k == j {
                        force -= n * lambda[k];
                    }
                }
                let stationary = (position[j] - c.x[j]) / w[j] - force;
                assert!(
                    stationary.length() < 1e-6,
                    "R = {stationary} at particle {j}"
                );
            }
        }
    }

    /// A line pinned at both ends (the last stick closing the loop, see
    /// [`closure`](super::super::closure)) takes the same step as the dense system — also where
    /// the stick to the second pin runs almost straight on from the one before it (where
    /// eliminating the two together divided by a vanishing pivot), with and without tension;
    /// and lines pinned inside.
    #[test]
    fn lines_pinned_at_both_ends_or_inside_take_the_newton_step() {
        assert_matches_dense(case([0.0, 1.0, 2.0, 0.5, 0.0]));
        assert_matches_dense(case([0.0, 0.001, 2.0, 1.0, 0.0]));
        let mut ropes = case([0.0, 1.0, 2.0, 0.5, 0.0]);
        ropes.kind = vec![StickKind::AtMost; 4];
        ropes.rest[3] = 0.13;
        // (No pull kept to warm-start: `begin` forgets a slack link's, which this test skips.)
        ropes.lambda[3] = 0.4;
        assert!(!active(&ropes, 3) && active(&ropes, 0));
        assert_matches_dense(ropes);
        for bend in [1e-2, 1e-4, 1e-6] {
            for lambda in [0.0, -3.0] {
                let mut straight = case([0.0, 1.0, 2.0, 0.5, 0.0]);
                // The last stick continues the third within `bend` radians.
                let along = (straight.x[3] - straight.x[2]).normalize();
                let aside = along.cross(DVec3::Z).normalize();
                straight.x[4] = straight.x[3] + (along + aside * bend).normalize() * 0.1;
                straight.lambda = vec![lambda; 4];
                assert_matches_dense(straight);
            }
        }
        // Pinned inside: each stretch between the pins (or a pin and a free end) on its own.
        assert_matches_dense(case([1.0, 1.0, 0.0, 0.5, 1.0]));
        assert_matches_dense(case([0.0, 1.0, 0.0, 0.5, 0.0]));
        assert_matches_dense(case([0.0, 0.001, 2.0, 0.0, 1.0]));
        assert_matches_dense(case([1.0, 0.0, 2.0, 0.0, 0.5]));
        // Two adjacent pins inside: the stick between them is out of the system.
        assert_matches_dense(case([1.0, 0.0, 0.0, 0.5, 1.0]));
    }
}
