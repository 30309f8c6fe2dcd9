//! Trees closed more than once: a part of a tree split at its pins (see [`split`](super::split))
//! held by three to [`MAX_CLOSINGS`] + 1 immovable particles.
//!
//! # The step
//! As for one closing stick ([`closure`](super::closure)), after Baraff 1996: the forward
//! traversal leaves every closing stick out and carries, beside each node's load, the load a
//! unit change of each closing multiplier puts on its held end (the first closing stick's in
//! the nodes, the others' in extra records, one per node and extra closing). Substituting from
//! the root along the paths to the held ends gives each held end `c_j`'s move without the
//! changes and per unit of each, `Δx⁰_{c_j} + Σᵢ Δλᵢ Δxⁱ_{c_j}`, and the closing rows make a
//! small dense system
//!
//! ```text
//! Σᵢ (−n_j·Δxⁱ_{c_j}) Δλᵢ + α̃_j Δλ_j = −(C_j + α̃_j λ_j) + n_j·Δx⁰_{c_j}
//! ```
//!
//! (a released row reads `Δλ_j = −λ_j`), solved by Gaussian elimination with partial pivoting;
//! every node's substitution then takes the changes in. O(n · m) for `m` closing sticks, exact
//! for the linearised system (checked against the dense one in `closure`'s tests). Full Newton
//! passes close the loops the same way (`curvature`'s `eliminate_many`). Where the path between
//! any two of the tree's immovable particles is rigid and within [`TAUT`] of its length, the
//! rows are singular: the tree is swept for that substep.
//!
//! ```
//! use bevy_verlet_physics::solver::{Method, Solver, StepConfig, StickKind};
//! use glam::DVec3;
//! // A Y rope held by its three ends, a heavy weight hanging from its fork.
//! let mut solver = Solver::default();
//! let posts = [(-1.0, 0.0), (1.0, 0.0), (0.0, 1.0)].map(|(x, z)| {
//!     let at = DVec3::new(x, 0.0, z);
//!     let p = solver.add_particle(at, 0.0);
//!     solver.pin(p, at);
//!     p
//! });
//! let fork = solver.add_particle(DVec3::new(0.0, -0.5, 0.3), 1.0);
//! let weight = solver.add_particle(DVec3::new(0.0, -1.5, 0.3), 0.001);
//! for post in posts {
//!     let rest = (solver.particles.position[post as usize] - DVec3::new(0.0, -0.5, 0.3)).length();
//!     solver.sticks.push([post, fork], rest, 0.0, StickKind::Equal, f64::INFINITY, 0);
//! }
//! solver.sticks.push([fork, weight], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
//! solver.organize();
//! let island = &solver.islands.list[0];
//! assert_eq!(island.method, Method::Lines);
//! let tree = &solver.islands.lines().trees.trees[island.trees.start as usize];
//! assert_eq!(tree.extra_closings.len(), 1);
//! for _ in 0..64 {
//!     solver.step(&StepConfig::default());
//! }
//! assert!(solver.sticks.max_violation(&solver.particles) < 1e-8);
//! ```

use super::super::StickKind;
use super::super::direct::TAUT;
use super::{Closing, MAX_CLOSINGS, Node, REGULARISATION, TreeSolve, TreeView};
use glam::DVec3;

/// The closing rows' small dense system (see the [module docs](self)).
#[derive(Default)]
pub(super) struct Closings {
    /// `S`: row `j` is closing stick `j`'s (the first closing stick, then the extra ones).
    pub(super) matrix: [[f64; MAX_CLOSINGS]; MAX_CLOSINGS],
    /// `b`.
    pub(super) rhs: [f64; MAX_CLOSINGS],
    /// Released rows' changes.
    released: [Option<f64>; MAX_CLOSINGS],
}

impl Closings {
    /// Row `j` reads `Δλ_j = change` (a released stick: `−λ`).
    pub(super) fn release(&mut self, j: usize, change: f64) {
        self.matrix[j] = [0.0; MAX_CLOSINGS];
        (self.matrix[j][j], self.rhs[j], self.released[j]) = (1.0, change, Some(change));
    }

    /// Regularises row `j`'s diagonal (relatively, as the eliminations' pivots) and adds its
    /// compliance `α̃`.
    pub(super) fn diagonal(&mut self, j: usize, alpha: f64) {
        self.matrix[j][j] = self.matrix[j][j] * (1.0 + REGULARISATION) + alpha;
    }

    /// The changes of the first `m` rows: zero (released rows theirs) where the system is
    /// singular or its solution is not finite.
    pub(super) fn solve(mut self, m: usize) -> [f64; MAX_CLOSINGS] {
        let fallback = self.released.map(|change| change.unwrap_or(0.0));
        solve_dense(&mut self.matrix, self.rhs, m).unwrap_or(fallback)
    }
}

/// Which closing stick node `t`'s parent stick is: `0` the tree's closing node, `i + 1` its
/// `i`-th extra one.
#[inline(always)]
pub(super) fn closing_index(view: &TreeView, t: usize) -> Option<usize> {
    if Some(t) == view.closing {
        return Some(0);
    }
    view.extra
        .iter()
        .position(|&x| x as usize == t)
        .map(|i| i + 1)
}

impl TreeSolve<'_, '_> {
    /// [`TreeSolve::close`] with extra closing sticks: the closing node's parent and each
    /// extra one's move by `Δx_c + Σᵢ Δλᵢ Δxⁱ_c`, so the closing rows make a small dense
    /// system `S Δλ = b` (`S_ji = −n_j·Δxⁱ_{c_j}`, plus `α̃_j` on the diagonal; a released
    /// row reads `Δλ_j = −λ_j`), solved by Gaussian elimination; every node's substitution
    /// then takes the changes in. Zero changes (released rows `−λ`) where `S` is singular or
    /// anything is not finite.
    ///
    /// # Safety
    /// As for [`TreeSolve::close`].
    pub(super) unsafe fn close_many(&self, view: &TreeView, s: &mut [Node], more: &mut [Closing]) {
        let Some(first) = view.closing else {
            return;
        };
        let e = view.extra.len();
        let m = e + 1;
        let node_of = |j: usize| {
            if j == 0 {
                first
            } else {
                view.extra[j - 1] as usize
            }
        };
        let held = |j: usize| (view.parent[node_of(j)] - view.offset) as usize;
        substitute_unit_moves(
            self.inverse_mass[view.particle[0] as usize] > 0.0,
            view,
            s,
            more,
        );
        let mut rows = Closings::default();
        for j in 0..m {
            let c = held(j);
            // SAFETY: as for `solve` (caller).
            let row = unsafe { self.row(view, node_of(j)) };
            if !row.active {
                rows.release(j, -row.lambda);
                continue;
            }
            let n = row.normal * row.sign;
            let alpha = self.sticks.compliance[row.stick] * self.inv_h2;
            for (i, entry) in rows.matrix[j][..m].iter_mut().enumerate() {
                let dx = if i == 0 {
                    s[c].closing.dx
                } else {
                    more[c * e + i - 1].dx
                };
                *entry = -n.dot(dx);
            }
            rows.diagonal(j, alpha);
            rows.rhs[j] = -(row.c + alpha * row.lambda) + n.dot(s[c].dx);
        }
        let d_lambda = rows.solve(m);
        take_in(&d_lambda, e, s, more);
        for (j, &change) in d_lambda[..m].iter().enumerate() {
            let node = &mut s[node_of(j)];
            (node.a, node.u, node.v, node.beta) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, change);
        }
    }
}

/// Every node's substitution takes the closing multipliers' changes in (`d_lambda[0]` the
/// first closing stick's, `d_lambda[i + 1]` extra `i`'s): `g₀ += Σ Δλ g⁰ⁱ` at the root,
/// `v += Σ Δλ vⁱ` and `β += Σ Δλ βⁱ` at every other node.
fn take_in(d_lambda: &[f64; MAX_CLOSINGS], e: usize, s: &mut [Node], more: &[Closing]) {
    s[0].load += s[0].closing.load * d_lambda[0];
    for (record, &change) in more[..e].iter().zip(&d_lambda[1..]) {
        s[0].load += record.load * change;
    }
    for (t, node) in s.iter_mut().enumerate().skip(1) {
        node.v += node.closing.v * d_lambda[0];
        node.beta += node.closing.beta * d_lambda[0];
        for (record, &change) in more[t * e..(t + 1) * e].iter().zip(&d_lambda[1..]) {
            node.v += record.v * change;
            node.beta += record.beta * change;
        }
    }
}

/// The moves `Δx_j` (without the closing multipliers' changes) and per unit change of each
/// closing multiplier, substituted from the root (movable or not) to the last closing node's
/// parent (parents come before their children).
fn substitute_unit_moves(
    root_movable: bool,
    view: &TreeView,
    s: &mut [Node],
    more: &mut [Closing],
) {
    let finite = |x: DVec3| if x.is_finite() { x } else { DVec3::ZERO };
    let e = view.extra.len();
    if root_movable {
        (s[0].dx, s[0].closing.dx) = s[0].solve_pair(s[0].load, s[0].closing.load);
        for record in &mut more[..e] {
            record.dx = s[0].solve_pair(record.load, DVec3::ZERO).0;
        }
    } else {
        (s[0].dx, s[0].closing.dx) = (DVec3::ZERO, DVec3::ZERO);
        for record in &mut more[..e] {
            record.dx = DVec3::ZERO;
        }
    }
    let closings = view
        .closing
        .into_iter()
        .chain(view.extra.iter().map(|&t| t as usize));
    let last = closings.map(|t| view.parent[t] - view.offset).max();
    for t in 1..=last.unwrap_or(0) as usize {
        let parent = (view.parent[t] - view.offset) as usize;
        let (parent_dx, parent_dx1) = (s[parent].dx, s[parent].closing.dx);
        let node = &mut s[t];
        node.substitute_closed(parent_dx, parent_dx1);
        for i in 0..e {
            let parent_dx = more[parent * e + i].dx;
            let record = &mut more[t * e + i];
            record.dx = finite(node.u * (node.a.dot(parent_dx) + record.beta) + record.v);
        }
    }
}

impl TreeSolve<'_, '_> {
    /// `true` when, in a tree with extra closing sticks, the path between two of its
    /// immovable particles (the root, the closing nodes) is rigid and within [`TAUT`] of its
    /// full length: the closing rows' system is singular there.
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`].
    pub(super) unsafe fn extra_taut(&self, view: &TreeView) -> bool {
        let mut held = [0; MAX_CLOSINGS + 1];
        let closings = view.closing.into_iter();
        let closings = closings.chain(view.extra.iter().map(|&t| t as usize));
        let mut count = 1; // (the root first)
        for (slot, t) in held[1..].iter_mut().zip(closings) {
            (*slot, count) = (t, count + 1);
        }
        let mut taut = false;
        for (i, &a) in held[..count].iter().enumerate() {
            for &b in &held[i + 1..count] {
                // SAFETY: as for this function (caller).
                taut |= unsafe { self.path_taut(view, a, b) };
            }
        }
        taut
    }

    /// `true` when the path between nodes `a` and `b` is rigid and their particles are within
    /// [`TAUT`] of its length apart.
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`].
    unsafe fn path_taut(&self, view: &TreeView, a: usize, b: usize) -> bool {
        let [p, q] = [a, b].map(|t| view.particle[t] as usize);
        let (mut a, mut b, mut rest) = (a, b, 0.0);
        // (Parents come before their children: the larger index climbs until they meet.)
        while a != b {
            let t = if a > b { &mut a } else { &mut b };
            let k = view.stick[*t] as usize;
            let rigid = matches!(self.sticks.kind[k], StickKind::Equal | StickKind::AtMost)
                && self.sticks.compliance[k] == 0.0;
            if !rigid {
                return false;
            }
            rest += self.sticks.rest_length[k];
            *t = (view.parent[*t] - view.offset) as usize;
        }
        // SAFETY: the tree's particles are this task's (caller).
        let apart = unsafe { self.position.get(q) - self.position.get(p) };
        apart.length() >= rest * (1.0 - TAUT)
    }
}

/// Solves the leading `m × m` system `A x = b` by Gaussian elimination with partial
/// pivoting; `None` where a pivot is zero or the solution is not finite.
fn solve_dense(
    a: &mut [[f64; MAX_CLOSINGS]; MAX_CLOSINGS],
    mut b: [f64; MAX_CLOSINGS],
    m: usize,
) -> Option<[f64; MAX_CLOSINGS]> {
    for k in 0..m {
        let pivot = (k..m).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))?;
        a.swap(k, pivot);
        b.swap(k, pivot);
        let row = a[k];
        if row[k] == 0.0 || !row[k].is_finite() {
            return None;
        }
        for i in k + 1..m {
            let factor = a[i][k] / row[k];
            for (entry, &above) in a[i][k..m].iter_mut().zip(&row[k..m]) {
                *entry -= factor * above;
            }
            b[i] -= factor * b[k];
        }
    }
    let mut x = [0.0; MAX_CLOSINGS];
    for k in (0..m).rev() {
        let sum: f64 = (k + 1..m).map(|j| a[k][j] * x[j]).sum();
        x[k] = (b[k] - sum) / a[k][k];
    }
    x[..m].iter().all(|x| x.is_finite()).then_some(x)
}
