//! A Newton pass over a tree: its linearised constraints eliminated from the leaves towards
//! the root and substituted back (Baraff 1996, "Linear-time dynamics using Lagrange
//! multipliers"), with the closing sticks of a tree held by several pins carried as extra
//! columns, the residual that decides when passes stop ([`TreeSolve::newton`]). See the
//! [parent module's docs](super).

use super::{
    Closing, LineMode, NewtonSystem, Node, REGULARISATION, Row, TreeSolve, TreeView, closings,
    in_system_with, line_residual, newton_passes, set_betas, unit_and_length,
};
use glam::DVec3;

impl TreeSolve<'_, '_> {
    /// Newton passes over the tree ([`newton_passes`]: until it is within [`TOLERANCE`](super::TOLERANCE),
    /// `budget` passes are done, or a pass leaves more than `contraction` × the error before it;
    /// a warm start that made things worse than `predicted` is taken back first).
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`].
    pub(super) unsafe fn newton(
        &self,
        view: &TreeView,
        (nodes, closings): (&mut [Node], &mut [Closing]),
        budget: u32,
        contraction: f64,
        predicted: f64,
    ) -> (u32, bool) {
        // SAFETY: this function's contract is `TreePasses::new`'s.
        let mut system = unsafe { TreePasses::new(self, view, (nodes, closings)) };
        newton_passes(&mut system, budget, contraction, predicted, false)
    }

    /// The parent stick of node `t` at the current iterate.
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`].
    #[inline(always)]
    pub(super) unsafe fn row(&self, view: &TreeView, t: usize) -> Row {
        // SAFETY: `t` is a node of the view and every index below passed `check` (caller).
        let (k, [a, b], d) = unsafe {
            let k = *view.stick.get_unchecked(t) as usize;
            let [a, b] = self.sticks.ends.get_unchecked(k).map(|p| p as usize);
            (
                k,
                [a, b],
                self.position.get_unchecked(b) - self.position.get_unchecked(a),
            )
        };
        let (normal, length) = unit_and_length(d, k);
        // SAFETY: as above.
        let (rest, kind, inverse_masses, node, lambda) = unsafe {
            (
                *self.sticks.rest_length.get_unchecked(k),
                *self.sticks.kind.get_unchecked(k),
                self.inverse_mass.get_unchecked(a) + self.inverse_mass.get_unchecked(b),
                *view.particle.get_unchecked(t),
                self.lambda.get_unchecked(k),
            )
        };
        let c = length - rest;
        let active = inverse_masses > 0.0 && in_system_with(kind, c, lambda * inverse_masses, rest);
        let sign = if b as u32 == node { 1.0 } else { -1.0 };
        Row {
            stick: k,
            sign,
            normal,
            c,
            active,
            lambda,
            kind,
            inverse_masses,
        }
    }

    /// The largest `|C + α̃λ|/L` of the active sticks (those [`TreeSolve::forward`] eliminates:
    /// in the modes that eliminate, every particle but the root can move).
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`].
    pub(super) unsafe fn residual(&self, view: &TreeView) -> f64 {
        let mut worst: f64 = 0.0;
        for &k in &view.stick[1..] {
            let k = k as usize;
            let [a, b] = self.sticks.ends[k].map(|p| p as usize);
            // SAFETY: the tree's particles and multipliers are this task's (caller).
            let (d, lambda) = unsafe {
                (
                    self.position.get(b) - self.position.get(a),
                    self.lambda.get(k),
                )
            };
            let rest = self.sticks.rest_length[k];
            let residual = line_residual(
                self.sticks.kind[k],
                [d.length() - rest, rest],
                lambda,
                self.inverse_mass[a] + self.inverse_mass[b],
                self.sticks.compliance[k] * self.inv_h2,
            );
            worst = worst.max(residual);
        }
        worst
    }

    /// [`TreeSolve::forward`], carrying the closing multiplier's load where the tree has one.
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`].
    pub(super) unsafe fn gauss_newton_forward<const MEASURE: bool>(
        &self,
        view: &TreeView,
        (s, more): (&mut [Node], &mut [Closing]),
    ) -> f64 {
        // SAFETY: as for `solve` (caller).
        unsafe {
            match (view.closing.is_some(), view.extra.is_empty()) {
                (false, _) => self.forward::<MEASURE, false, false>(view, (s, &mut [])),
                (true, true) => self.forward::<MEASURE, true, false>(view, (s, &mut [])),
                (true, false) => self.forward::<MEASURE, true, true>(view, (s, more)),
            }
        }
    }

    /// Leaves to root: every stick reduced to `Δλ_k = a_k·Δx_p + β_k`. With `MEASURE`, returns
    /// the residual at the iterate, as [`TreeSolve::residual`] does (else 0). With `CLOSED`, the
    /// closing stick is left out of the reduction and a unit change of its multiplier is carried
    /// as a second load (`g¹`, `v¹ = A⁻¹ g¹`, `β¹ = −n·v¹ / D`) for [`TreeSolve::close`]; each
    /// extra closing stick's likewise with `MANY`, in `more` (node `t`'s at `t · e + i`, `e`
    /// extra closings).
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`].
    pub(super) unsafe fn forward<const MEASURE: bool, const CLOSED: bool, const MANY: bool>(
        &self,
        view: &TreeView,
        (s, more): (&mut [Node], &mut [Closing]),
    ) -> f64 {
        let shake = s[0].mode == LineMode::Shake;
        let mut worst: f64 = 0.0;
        let e = if MANY { view.extra.len() } else { 0 };
        // (Every other node clears its accumulators once it has used them, below.)
        s[0].clear();
        if MANY {
            // (Every record: a curvature pass between two of these leaves its loads.)
            for record in more.iter_mut() {
                record.load = DVec3::ZERO;
            }
        }
        for t in (1..view.particle.len()).rev() {
            // SAFETY: the tree's particles and multipliers are this task's, `t` and its parent
            // (< t) are nodes of `s` (as long as the view), and every index passed `check`
            // (caller).
            unsafe {
                let row = self.row(view, t);
                let (earlier, from_t) = s.split_at_mut_unchecked(t);
                let node = from_t.get_unchecked_mut(0);
                let r = if shake { node.start } else { row.normal };
                node.direction = r;
                let w = *self
                    .inverse_mass
                    .get_unchecked(*view.particle.get_unchecked(t) as usize);
                (node.u, node.v) = if w > 0.0 {
                    node.solve_pair(r * (w * row.sign), node.load)
                } else {
                    (DVec3::ZERO, DVec3::ZERO)
                };
                if CLOSED {
                    node.closing.v = if w > 0.0 {
                        node.solve_pair(node.closing.load, DVec3::ZERO).0
                    } else {
                        DVec3::ZERO
                    };
                    if MANY {
                        for record in &mut more[t * e..(t + 1) * e] {
                            record.v = match w > 0.0 {
                                true => node.solve_pair(record.load, DVec3::ZERO).0,
                                false => DVec3::ZERO,
                            };
                            record.load = DVec3::ZERO;
                        }
                    }
                }
                node.clear();
                let k = row.stick;
                let alpha = *self.sticks.compliance.get_unchecked(k) * self.inv_h2;
                let residual = row.c + alpha * row.lambda;
                if MEASURE {
                    let rest = *self.sticks.rest_length.get_unchecked(k);
                    let error = line_residual(
                        row.kind,
                        [row.c, rest],
                        row.lambda,
                        row.inverse_masses,
                        alpha,
                    );
                    worst = worst.max(error);
                }
                let parent = (*view.parent.get_unchecked(t) - view.offset) as usize;
                let closing = match (CLOSED, MANY) {
                    (false, _) => None,
                    (true, true) => closings::closing_index(view, t),
                    (true, false) => (Some(t) == view.closing).then_some(0),
                };
                if let Some(j) = closing {
                    // A closing stick: its multiplier is solved by `close`; a unit change of it
                    // loads its other end, `∓w r`.
                    (node.a, node.beta, node.closing.beta) = (DVec3::ZERO, 0.0, 0.0);
                    if MANY {
                        set_betas(&mut more[t * e..(t + 1) * e], |_| 0.0);
                    }
                    let wp = *self
                        .inverse_mass
                        .get_unchecked(*view.particle.get_unchecked(parent) as usize);
                    let unit = r * (wp * row.sign);
                    match j {
                        0 => earlier.get_unchecked_mut(parent).closing.load -= unit,
                        j => more[parent * e + j - 1].load -= unit,
                    }
                    continue;
                }
                let n = row.normal * row.sign;
                let d = n.dot(node.u) * (1.0 + REGULARISATION) + alpha;
                if !row.active {
                    // Released: Δλ = −λ, whatever its parent does (which sees its move; it
                    // needs no pivot).
                    node.a = DVec3::ZERO;
                    node.beta = -row.lambda;
                    node.closing.beta = 0.0;
                    if MANY {
                        set_betas(&mut more[t * e..(t + 1) * e], |_| 0.0);
                    }
                } else if d == 0.0 || !d.is_finite() {
                    // (Under SHAKE the system is not symmetric and a pivot may be negative;
                    // zero is a stick no particle of its subtree can move: an immovable child,
                    // which `build` roots at, or a pin added in place.)
                    node.a = DVec3::ZERO;
                    node.beta = 0.0;
                    node.closing.beta = 0.0;
                    if MANY {
                        set_betas(&mut more[t * e..(t + 1) * e], |_| 0.0);
                    }
                    continue;
                } else {
                    node.a = n / d;
                    node.beta = (-residual - n.dot(node.v)) / d;
                    if CLOSED {
                        node.closing.beta = -n.dot(node.closing.v) / d;
                        if MANY {
                            set_betas(&mut more[t * e..(t + 1) * e], |v| -n.dot(v) / d);
                        }
                    }
                }
                // Into the parent: A_p −= w_p s_p r aᵀ, g_p += w_p s_p r β (s_p = −s_j).
                let wp = *self
                    .inverse_mass
                    .get_unchecked(*view.particle.get_unchecked(parent) as usize);
                let pull = r * (wp * row.sign);
                if MANY {
                    for i in 0..e {
                        let beta = more[t * e + i].beta;
                        more[parent * e + i].load -= pull * beta;
                    }
                }
                let parent = earlier.get_unchecked_mut(parent);
                parent.add_child(pull, node.a);
                parent.load -= pull * node.beta;
                if CLOSED {
                    parent.closing.load -= pull * node.closing.beta;
                }
            }
        }
        worst
    }

    /// Root to leaves: `Δλ_k = a_k·Δx_p + β_k`, `Δx_j = u_j Δλ_k + v_j`; λ updated and each
    /// stick's ends moved by `±w r_k Δλ_k` (the same motion, up to rounding, but exactly what
    /// λ says: [`TreeSolve::take_back`] relies on it).
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`].
    pub(super) unsafe fn backward(&self, view: &TreeView, s: &mut [Node]) {
        let root = view.particle[0] as usize;
        s[0].dx = if self.inverse_mass[root] > 0.0 {
            s[0].solve_pair(s[0].load, DVec3::ZERO).0
        } else {
            DVec3::ZERO
        };
        for t in 1..view.particle.len() {
            // SAFETY: as in `forward` (`t` and its parent are nodes of `s`, every index passed
            // `check`; the particles and multipliers are this task's).
            unsafe {
                let parent = (*view.parent.get_unchecked(t) - view.offset) as usize;
                let parent_dx = s.get_unchecked(parent).dx;
                let node = s.get_unchecked_mut(t);
                let step = node.a.dot(parent_dx) + node.beta;
                let step = if step.is_finite() { step } else { 0.0 };
                let dx = node.u * step + node.v;
                node.dx = if dx.is_finite() { dx } else { DVec3::ZERO };
                let k = *view.stick.get_unchecked(t) as usize;
                self.lambda
                    .set_unchecked(k, self.lambda.get_unchecked(k) + step);
                self.move_ends(k, node.direction * step);
            }
        }
    }

    /// Moves stick `k`'s ends by `r λ` (second end `+w_b`, first end `−w_a`).
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`], and `k` is a stick of a tree that passed
    /// [`TreeSolve::check`] (read without bounds checks).
    pub(super) unsafe fn move_ends(&self, k: usize, by: DVec3) {
        // SAFETY: `k` is a stick of the tree, which passed `check` with its ends (caller).
        let [a, b] = unsafe { self.sticks.ends.get_unchecked(k) }.map(|p| p as usize);
        for (p, sign) in [(a, -1.0), (b, 1.0)] {
            // SAFETY: as above; the particles are this task's (caller).
            unsafe {
                let w = *self.inverse_mass.get_unchecked(p);
                if w > 0.0 {
                    let by = by * (w * sign);
                    self.position
                        .set_unchecked(p, self.position.get_unchecked(p) + by);
                    if let Some(mirror) = self.mirror {
                        mirror.set_unchecked(p, mirror.get_unchecked(p) + by);
                    }
                }
            }
        }
    }
}

/// A tree's system as [`newton_passes`] drives it (made by [`TreePasses::new`] only).
struct TreePasses<'s, 'a, 'v> {
    solve: &'s TreeSolve<'a, 'v>,
    view: &'s TreeView<'s>,
    nodes: &'s mut [Node],
    closings: &'s mut [Closing],
}

impl<'s, 'a, 'v> TreePasses<'s, 'a, 'v> {
    /// The system of the tree `view` in `solve`, with its scratch.
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`], for as long as it lives. Its (safe) methods rely on it.
    unsafe fn new(
        solve: &'s TreeSolve<'a, 'v>,
        view: &'s TreeView<'s>,
        (nodes, closings): (&'s mut [Node], &'s mut [Closing]),
    ) -> Self {
        Self {
            solve,
            view,
            nodes,
            closings,
        }
    }
}

impl NewtonSystem for TreePasses<'_, '_, '_> {
    #[inline(always)]
    fn residual(&mut self) -> f64 {
        // SAFETY: the contract of `TreePasses::new`, which made this.
        unsafe { self.solve.residual(self.view) }
    }

    #[inline(always)]
    fn take_back(&mut self) {
        // SAFETY: as for `residual`.
        unsafe { self.solve.take_back(self.view, self.nodes) }
    }

    #[inline(always)]
    fn eliminate(&mut self, measure: bool) -> f64 {
        let system = (&mut *self.nodes, &mut *self.closings);
        // SAFETY: as for `residual`.
        unsafe {
            match measure {
                true => self.solve.gauss_newton_forward::<true>(self.view, system),
                false => self.solve.gauss_newton_forward::<false>(self.view, system),
            }
        }
    }

    #[inline(always)]
    fn substitute(&mut self) {
        // SAFETY: as for `residual`.
        unsafe {
            if self.view.closing.is_some() {
                self.solve.close(self.view, (self.nodes, self.closings));
            }
            self.solve.backward(self.view, self.nodes);
        }
    }
}
