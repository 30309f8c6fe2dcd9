//! Direct solve of a tree of sticks: exact per Newton pass at forks too.
//!
//! # Why
//! [Lines](super::lines) solve a chain exactly, but a tree's branches are separate lines that
//! meet at forks, coupled there by block Gauss–Seidel: a rope that splits into three loaded
//! branches stretches at the fork as a sweep would (a Y of 50 + 3 × 30 links with 1000× heavier
//! tips: 935 % largest link strain at 8 × 1). Baraff ("Linear-time dynamics using Lagrange
//! multipliers", SIGGRAPH 1996) shows that a system whose constraint graph is a tree factors
//! without fill-in when eliminated from the leaves towards the root; this module does that for
//! particles joined by sticks, in the same XPBD / SHAKE Newton passes as [`direct`](super::direct).
//!
//! # The elimination
//! Root the tree at its immovable particle (or its first one when nothing holds it). Every other
//! particle `j` has a parent stick `k` towards the root and a parent particle `p`. A stick moves
//! its ends along its correction direction `r_k` (start-of-substep direction under SHAKE, else
//! the current one): `Δx_b += w_b r_k Δλ_k`, `Δx_a −= w_a r_k Δλ_k`; its row is
//! `n_k·(Δx_b − Δx_a) + α̃_k Δλ_k = −(C_k + α̃_k λ_k)`. Leaves first, each child stick `i` of `j`
//! has been reduced to `Δλ_i = a_i·Δx_j + β_i`, so
//!
//! ```text
//! A_j Δx_j = w_j s_j r_k Δλ_k + g_j,   A_j = I − w_j Σ_i s_ji r_i a_iᵀ,   g_j = w_j Σ_i s_ji r_i β_i
//! Δx_j = u_j Δλ_k + v_j,               u_j = A_j⁻¹ w_j s_j r_k,           v_j = A_j⁻¹ g_j
//! Δλ_k = a_k·Δx_p + β_k,               a_k = s_j n_k / D_k,   β_k = (b_k − s_j n_k·v_j) / D_k
//! D_k = s_j n_k·u_j + α̃_k,             b_k = −(C_k + α̃_k λ_k)
//! ```
//!
//! (`s_j = ±1`: `+1` when `j` is the stick's second end.) At the root `Δx = A⁻¹ g` (zero when it
//! is immovable); then root to leaves `Δλ_k = a_k·Δx_p + β_k`, `Δx_j = u_j Δλ_k + v_j`. One 3 × 3
//! inverse per particle and pass: O(n), exact for the linearised system whatever the masses. On
//! a chain it is the Thomas algorithm of the line solve.
//!
//! Start violations of rigid sticks above 0.1 % (an edit, a spawn) are corrected on the start
//! positions first, as the line solve does, so they do not become velocity. A projected
//! substep starts with one full Newton pass that includes the constraints' curvature
//! (`curvature`): a Y rope with 1000× heavier tips swinging takes 7112 passes in 5 s instead
//! of 28 707.
//!
//! A projected substep whose passes end unconverged and leave the tree worse off than its
//! prediction (a larger error, or mass-weighted farther from it than
//! [`WARM_START_REACH`](super::direct::WARM_START_REACH) times the start of the substep, or
//! its loads thrown, see `THROWN_ABOVE`) is
//! put back at the prediction and swept once instead, unless the iterate is nearly on its
//! constraints, nearer them than the sweep and not far off (`TreeSolve::fall_back`, with
//! the rule of the lines): a sweep cannot blow up, and Gauss–Newton passes that wander can
//! (random trees at one substep, kicked by 30 m/s: strains to 10¹⁰ link lengths before; see
//! the module docs of [`direct`](super::direct) for the figures).
//!
//! A tree with a second immovable particle (a string of lanterns between two posts) is rooted
//! at the first; the stick to the second closes a loop, its multiplier solved by a Schur
//! complement of one row (`closure`); where the path between the two is pulled taut the tree
//! is swept for the substep. A further particle made immovable in place below the root (a pin
//! added without a rebuild; the Bevy layer rebuilds then) would make the system singular: such
//! a tree is swept for the substep too.
//!
//! Three or more immovable particles split a tree (`split`): nothing moves through an
//! immovable particle, so the parts between them are independent, each rooted at one of its
//! immovable particles. A part held by three to [`MAX_CLOSINGS`] + 1 of them is closed once per
//! further one, the closing multipliers solved together by a small dense system
//! (`closings`); a tree with a part held by more stays on lines. Measured on
//! random chains and trees with loads up to 10⁴× pinned at three or four particles (a scratch
//! scan of 1033 scenes at 8 × 1, half kicked by up to 30 m/s): 355 beyond 100 % strain as
//! lines meeting at forks, none beyond 10⁻⁵ now (`tests/direct.rs`). A stick torn in place or a one-sided stick out of its active set (see
//! `in_system_with`) is a row with `Δλ = −λ` (released): its
//! subtree moves on its own.
//!
//! This file holds the trees' layout and a tree's solve from start to end
//! (`TreeSolve::solve`); beside it: `elimination` (the Newton pass from the leaves to the root
//! and back), `curvature` (full Newton passes), `closings` and `closure` (trees held by
//! several pins), `split` (trees split at their pins).
//!
//! ```
//! use bevy_verlet_physics::solver::{Method, Solver, StepConfig, StickKind};
//! use glam::DVec3;
//! // A Y: one link from a pin, two from its end, heavy tips.
//! let mut solver = Solver::default();
//! let pin = solver.add_particle(DVec3::ZERO, 0.0);
//! solver.pin(pin, DVec3::ZERO);
//! let fork = solver.add_particle(DVec3::NEG_Y, 1.0);
//! let left = solver.add_particle(DVec3::new(-0.6, -1.8, 0.0), 0.001);
//! let middle = solver.add_particle(DVec3::new(0.0, -2.0, 0.0), 0.001);
//! let right = solver.add_particle(DVec3::new(0.6, -1.8, 0.0), 0.001);
//! for [a, b] in [[pin, fork], [fork, left], [fork, middle], [fork, right]] {
//!     solver.sticks.push([a, b], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
//! }
//! solver.organize();
//! assert_eq!(solver.islands.list[0].method, Method::Lines);
//! assert_eq!(solver.islands.list[0].trees.len(), 1);
//! for _ in 0..64 {
//!     solver.step(&StepConfig::default());
//! }
//! assert!(solver.sticks.max_violation(&solver.particles) < 1e-8);
//! ```

use super::direct::{
    Begun, CURVATURE_BELOW, FULL_NEWTON_AFTER, LineMode, MAX_PASSES, NewtonSystem,
    SHAKE_CONTRACTION, SHAKE_MIN_COSINE, SHAKE_PASSES, SHAKE_STIFFNESS_BELOW, STABILISE_ABOVE,
    TOLERANCE, in_system, in_system_with, line_residual, newton_passes, tension_stiffness,
};
use super::lines::Incidence;
use super::shared::SharedSlice;
use super::sticks::{SweepOrder, relax_stick_range, unit_and_length};
use super::{Particles, StickKind, Sticks};
use glam::{DMat3, DVec3};
use std::ops::Range;

mod closings;
mod closure;
mod curvature;
mod elimination;
mod split;
pub(crate) use curvature::TreeCurvature;

/// Relative regularisation of `D_k` (as the line solve's diagonal).
const REGULARISATION: f64 = 1e-9;

/// No parent (the root's parent stick and node).
const NONE: u32 = u32::MAX;

/// One tree: a range of nodes in [`TreeSet`], the root first, every node after its parent.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Tree {
    /// Range into the node arrays of [`TreeSet`].
    pub nodes: Range<u32>,
    /// The node (counted from the tree's first) of its second immovable particle, if it has
    /// one: the stick to its parent closes a loop through the root (see the module docs).
    pub closing: Option<u32>,
    /// Its further closing nodes (a range into [`TreeSet::extra_closing`]): a part of a tree
    /// split at its pins held by three to [`MAX_CLOSINGS`] + 1 immovable particles is closed
    /// once per immovable particle besides its root (see the [module docs](self)).
    pub extra_closings: Range<u32>,
    /// Where its extra closings' records start in the solver's scratch (one per node and
    /// extra closing).
    pub(crate) closing_scratch: u32,
}

impl Tree {
    /// The records of its extra closings in the scratch: one per node and extra closing.
    pub(crate) fn closing_records(&self) -> Range<usize> {
        let nodes = (self.nodes.end - self.nodes.start) as usize;
        let extra = (self.extra_closings.end - self.extra_closings.start) as usize;
        let start = self.closing_scratch as usize;
        start..start + nodes * extra
    }
}

/// The most closing sticks a tree's elimination closes (its immovable particles besides the
/// root): a tree with a part held by more stays on lines.
///
/// ```
/// // A part of a tree held by up to nine pins is solved whole.
/// assert_eq!(bevy_verlet_physics::solver::MAX_CLOSINGS, 8);
/// ```
pub const MAX_CLOSINGS: usize = 8;

/// Every tree-solved island's nodes (breadth-first from the root, tree after tree).
///
/// ```
/// use bevy_verlet_physics::solver::{Solver, StickKind};
/// use glam::DVec3;
/// // A pinned particle with three sticks hanging from it: a tree of four nodes.
/// let mut solver = Solver::default();
/// let pin = solver.add_particle(DVec3::ZERO, 0.0);
/// solver.pin(pin, DVec3::ZERO);
/// for x in [-1.0, 0.0, 1.0] {
///     let p = solver.add_particle(DVec3::new(x, -1.0, 0.0), 1.0);
///     solver.sticks.push([pin, p], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
/// }
/// solver.organize();
/// let trees = &solver.islands.lines().trees;
/// assert_eq!(trees.trees.len(), 1);
/// assert_eq!(trees.particle[0], pin); // the root
/// ```
#[derive(Clone, Debug, Default)]
pub struct TreeSet {
    /// The trees.
    pub trees: Vec<Tree>,
    /// Particle slot of every node.
    pub particle: Vec<u32>,
    /// The stick to the node's parent ([`u32::MAX`] at a root).
    pub stick: Vec<u32>,
    /// The parent node, as an index into the node arrays ([`u32::MAX`] at a root).
    pub parent: Vec<u32>,
    /// The trees' extra closing nodes (counted from their tree's first node; see
    /// [`Tree::extra_closings`]).
    pub extra_closing: Vec<u32>,
}

impl TreeSet {
    /// Removes every tree, keeping the allocations.
    pub fn clear(&mut self) {
        self.trees.clear();
        self.particle.clear();
        self.stick.clear();
        self.parent.clear();
        self.extra_closing.clear();
    }

    /// How many extra closing records the trees' solves need (see
    /// [`Tree::closing_records`]).
    pub(crate) fn closing_records(&self) -> usize {
        self.trees
            .last()
            .map_or(0, |tree| tree.closing_records().end)
    }
}

/// Roots a tree at the island's (first) immovable particle and appends its nodes to `set`;
/// returns the range of its trees in `set.trees`: one, or one per part where three or more
/// immovable particles split it (see [`split`]); empty when the island should stay on lines:
/// no fork (a chain), a part held by more than [`MAX_CLOSINGS`] + 1 immovable particles, or not
/// connected. A
/// second immovable particle becomes the tree's [`closing`](Tree::closing) node. `queue` and
/// `seen` are scratch (`seen` as long as the particles, all `false`, left so).
pub(crate) fn build(
    set: &mut TreeSet,
    (queue, seen): (&mut Vec<u32>, &mut Vec<bool>),
    (particles, sticks): (&Particles, &Sticks),
    island_particles: Range<u32>,
    incidence: &Incidence,
) -> Range<u32> {
    seen.resize(particles.len(), false);
    let scratch = (queue, &mut seen[..]);
    let fork = island_particles.clone().any(|p| incidence.degree(p) > 2);
    let mut immovable = island_particles
        .clone()
        .filter(|&p| particles.inverse_mass[p as usize] <= 0.0);
    let root = immovable.next().unwrap_or(island_particles.start);
    let second = immovable.next();
    if !fork {
        return 0..0;
    }
    if immovable.next().is_some() {
        let parts = (particles, sticks);
        return split::split_at_immovable(set, scratch, parts, island_particles, incidence);
    }
    whole(
        set,
        scratch,
        (sticks, root, second),
        island_particles,
        incidence,
    )
}

/// [`build`]'s tree of an island with at most two immovable particles: rooted at `root`,
/// closed at `second`.
fn whole(
    set: &mut TreeSet,
    (queue, seen): (&mut Vec<u32>, &mut [bool]),
    (sticks, root, second): (&Sticks, u32, Option<u32>),
    island_particles: Range<u32>,
    incidence: &Incidence,
) -> Range<u32> {
    let start = set.particle.len();
    queue.clear();
    queue.push(root);
    seen[root as usize] = true;
    set.particle.push(root);
    set.stick.push(NONE);
    set.parent.push(NONE);
    let mut head = 0;
    while head < queue.len() {
        let (p, node) = (queue[head], (start + head) as u32);
        head += 1;
        for &s in incidence.of(p) {
            let [a, b] = sticks.ends[s as usize];
            let other = if a == p { b } else { a };
            if !seen[other as usize] {
                seen[other as usize] = true;
                queue.push(other);
                set.particle.push(other);
                set.stick.push(s);
                set.parent.push(node);
            }
        }
    }
    for &p in queue.iter() {
        seen[p as usize] = false;
    }
    if queue.len() != island_particles.len() {
        set.particle.truncate(start);
        set.stick.truncate(start);
        set.parent.truncate(start);
        return 0..0;
    }
    let closing = second.and_then(|p| queue.iter().position(|&q| q == p));
    let (extra, records) = (set.extra_closing.len() as u32, set.closing_records() as u32);
    set.trees.push(Tree {
        nodes: start as u32..set.particle.len() as u32,
        closing: closing.map(|t| t as u32),
        extra_closings: extra..extra,
        closing_scratch: records,
    });
    set.trees.len() as u32 - 1..set.trees.len() as u32
}

/// Per node scratch, indexed like the node arrays of [`TreeSet`] (stick: the node's parent
/// stick).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Node {
    /// `A_j = I + Σ pᵢ aᵢᵀ`, accumulated from the children during the forward traversal: with
    /// one child (a chain) as `first_pull`, `first_a` (solved by Sherman–Morrison), in `matrix`
    /// from the second on.
    children: u32,
    first_pull: DVec3,
    first_a: DVec3,
    matrix: DMat3,
    /// `g_j`.
    load: DVec3,
    u: DVec3,
    v: DVec3,
    /// `a_k`, `β_k` of the parent stick.
    a: DVec3,
    beta: f64,
    /// In a tree with a closing stick: the parts of `g_j`, `v_j`, `β_k` and `Δx_j` that a unit
    /// change of the closing multiplier adds (see [`TreeSolve::close`]).
    closing: Closing,
    /// The parent stick's start-of-substep direction and correction direction.
    start: DVec3,
    direction: DVec3,
    /// `Δx_j` of the pass.
    dx: DVec3,
    /// The parent stick's multiplier at the end of the last substep (the next warm start).
    warm: f64,
    /// At a tree's root: how the tree is solved this substep.
    mode: LineMode,
    /// `Σ μ_k = Σ max(−λ_k, 0)/d_k` over the particle's sticks at the start of the substep (SHAKE's
    /// stability, see [`SHAKE_STIFFNESS_BELOW`]).
    stiffness: f64,
}

impl Default for Node {
    fn default() -> Self {
        Self {
            children: 0,
            first_pull: DVec3::ZERO,
            first_a: DVec3::ZERO,
            matrix: DMat3::IDENTITY,
            load: DVec3::ZERO,
            u: DVec3::ZERO,
            v: DVec3::ZERO,
            a: DVec3::ZERO,
            beta: 0.0,
            closing: Closing::default(),
            start: DVec3::ZERO,
            direction: DVec3::ZERO,
            dx: DVec3::ZERO,
            warm: 0.0,
            mode: LineMode::Project,
            stiffness: 0.0,
        }
    }
}

impl Node {
    /// Forgets the children's contributions (before they are accumulated again).
    fn clear(&mut self) {
        self.children = 0;
        self.load = DVec3::ZERO;
        self.closing.load = DVec3::ZERO;
    }

    /// The node's `Δx` and its `Δx¹` per unit change of the first closing multiplier, from its
    /// parent's (non-finite parts as zero).
    fn substitute_closed(&mut self, parent_dx: DVec3, parent_dx1: DVec3) {
        let finite = |x: DVec3| if x.is_finite() { x } else { DVec3::ZERO };
        let step = self.a.dot(parent_dx) + self.beta;
        self.dx = finite(self.u * step + self.v);
        let step = self.a.dot(parent_dx1) + self.closing.beta;
        self.closing.dx = finite(self.u * step + self.closing.v);
    }

    /// Adds a child's `p aᵀ` to `A`.
    fn add_child(&mut self, pull: DVec3, a: DVec3) {
        match self.children {
            0 => (self.first_pull, self.first_a) = (pull, a),
            1 => {
                self.matrix =
                    DMat3::IDENTITY + outer(self.first_pull, self.first_a) + outer(pull, a)
            }
            _ => self.matrix += outer(pull, a),
        }
        self.children += 1;
    }

    /// `(A⁻¹ x, A⁻¹ y)`.
    fn solve_pair(&self, x: DVec3, y: DVec3) -> (DVec3, DVec3) {
        match self.children {
            0 => (x, y),
            1 => {
                // Sherman–Morrison: (I + p aᵀ)⁻¹ z = z − p (a·z) / (1 + a·p).
                let (p, a) = (self.first_pull, self.first_a);
                let scale = 1.0 / (1.0 + a.dot(p));
                (x - p * (a.dot(x) * scale), y - p * (a.dot(y) * scale))
            }
            _ => {
                let inverse = self.matrix.inverse();
                (inverse * x, inverse * y)
            }
        }
    }
}

/// A node's share of the response to a unit change of a tree's closing multiplier (see
/// [`closure`]): its part of `g_j`, `v_j`, `β_k` and `Δx_j`.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Closing {
    load: DVec3,
    v: DVec3,
    beta: f64,
    dx: DVec3,
}

/// Everything one tree solve reads and writes.
#[derive(Clone, Copy)]
pub(crate) struct TreeSolve<'a, 'v> {
    pub position: &'a SharedSlice<'v, DVec3>,
    pub previous: &'a SharedSlice<'v, DVec3>,
    /// Receives every move made to `position` too (set while stabilising the start positions).
    pub mirror: Option<&'a SharedSlice<'v, DVec3>>,
    pub lambda: &'a SharedSlice<'v, f64>,
    pub inverse_mass: &'a [f64],
    pub sticks: &'a Sticks,
    /// `1/h²`.
    pub inv_h2: f64,
    /// Correct along the start-of-substep directions (SHAKE) instead of the current ones.
    pub shake: bool,
    /// First round of the substep: λ starts from the warm start, SHAKE is decided.
    pub first_round: bool,
}

/// One node's parent stick at the current iterate.
struct Row {
    stick: usize,
    /// `s_j`: `+1` when the node is the stick's second end.
    sign: f64,
    normal: DVec3,
    c: f64,
    active: bool,
    /// The stick's multiplier at the iterate (released, `Δλ = −λ`, where it is not active).
    lambda: f64,
    kind: StickKind,
    /// `w_a + w_b`.
    inverse_masses: f64,
}

impl TreeSolve<'_, '_> {
    /// Solves tree `tree` of `set` with its nodes' scratch `s` (indexed from the tree's first
    /// node) and its extra closings' records `more` ([`Tree::closing_records`]); returns the
    /// Newton passes taken.
    ///
    /// # Safety
    /// No other task accesses the tree's particles or its sticks' multipliers while this runs,
    /// and its node arrays hold valid particle and stick indices (as [`build`] makes them).
    pub(crate) unsafe fn solve(
        &self,
        set: &TreeSet,
        tree: &Tree,
        (s, more): (&mut [Node], &mut [Closing]),
        curvature: &mut [TreeCurvature],
    ) -> u32 {
        let view = self.view_of(set, tree);
        assert_eq!(
            s.len(),
            view.particle.len(),
            "one scratch node per tree node"
        );
        // (Fewer extra closings than records where a closing pin was taken away in place.)
        assert!(
            more.len() >= s.len() * view.extra.len(),
            "extra closing records"
        );
        let more = &mut more[..s.len() * view.extra.len()];
        self.check(&view);
        // SAFETY: this task alone holds the tree's particles and multipliers (caller).
        unsafe {
            let mut predicted = f64::INFINITY;
            let keeps = self.first_round
                && curvature.len() == s.len()
                && self.mirror.is_none()
                && self.curvable(&view);
            if self.first_round && (self.pinned_below_root(&view) || self.closing_taut(&view)) {
                s[0].mode = LineMode::Sweep;
            } else if self.first_round {
                // (Not right after a fallback, see [`LineMode::FellBack`].)
                let shake = self.shake && s[0].mode != LineMode::FellBack;
                if keeps {
                    self.keep_prediction(&view, curvature);
                }
                let mut begun = self.begin(&view, s, shake);
                if begun.violated > STABILISE_ABOVE {
                    self.take_back(&view, s);
                    self.stabilise_start(&view, (s, more), curvature);
                    if keeps {
                        self.keep_prediction(&view, curvature);
                    }
                    begun = self.begin(&view, s, shake);
                }
                predicted = begun.predicted;
            }
            if s[0].mode == LineMode::Sweep {
                self.sweep(&view, s);
                return 0;
            }
            // (A projection starts with a curvature pass, and full Newton passes rescue it where
            // Gauss–Newton does not converge, where they apply: see `curvature`.)
            let rescuable = keeps
                && (predicted < CURVATURE_BELOW
                    || self.balanced_error(&view, s, curvature) < CURVATURE_BELOW);
            let rescue = rescuable.then_some(&mut *curvature);
            let (mut passes, mut converged) = if s[0].mode == LineMode::Shake {
                let (passes, converged) =
                    self.newton(&view, (s, more), SHAKE_PASSES, SHAKE_CONTRACTION, predicted);
                if converged {
                    (passes, true)
                } else {
                    self.take_back(&view, s);
                    s[0].mode = LineMode::FellBack;
                    let (taken, converged) = self.project(&view, (s, more), rescue, f64::INFINITY);
                    (passes + taken, converged)
                }
            } else {
                self.project(&view, (s, more), rescue, predicted)
            };
            // (Projected substeps only: SHAKE's result is no projection, nor meant to be one.
            // Also beyond `CURVATURE_BELOW`, where its result must be near enough to keep.)
            if keeps && s[0].mode != LineMode::Shake {
                let (taken, again) = self.second_try(&view, (curvature, more));
                (passes, converged) = (passes + taken, again);
            }
            // (Where the passes left the tree worse off than its prediction, or threw its loads:
            // see the module's docs.)
            if !converged && keeps && self.unconverged_too_far(&view, curvature, predicted) {
                self.fall_back(&view, s, curvature);
            }
            for (node, &k) in s.iter_mut().zip(view.stick).skip(1) {
                node.warm = self.lambda.get(k as usize);
            }
            passes
        }
    }

    /// The projection's Newton passes from the prediction (nothing has moved the tree this
    /// substep). Where `curvature` is given: the first with the constraints' curvature (under
    /// SHAKE, whose warm start it uses), and full Newton passes where Gauss–Newton has not
    /// converged after [`FULL_NEWTON_AFTER`] passes (see [`curvature`]). Returns the passes
    /// taken.
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`], and `view` passed [`TreeSolve::check`].
    unsafe fn project(
        &self,
        view: &TreeView,
        (s, more): (&mut [Node], &mut [Closing]),
        curvature: Option<&mut [TreeCurvature]>,
        predicted: f64,
    ) -> (u32, bool) {
        // SAFETY: as for `solve` (caller).
        unsafe {
            let Some(curvature) = curvature else {
                return self.newton(view, (s, more), MAX_PASSES, f64::INFINITY, predicted);
            };
            let mut passes = 0;
            if self.shake {
                self.curvature_pass(view, s, (curvature, more));
                passes = 1;
            }
            let (taken, converged) = self.newton(
                view,
                (s, more),
                FULL_NEWTON_AFTER - passes,
                f64::INFINITY,
                f64::INFINITY,
            );
            passes += taken;
            if converged {
                return (passes, true);
            }
            let (taken, converged) = self.full_newton(view, (curvature, more), MAX_PASSES - passes);
            (passes + taken, converged)
        }
    }

    /// `tree`'s node arrays in `set`, with its closing nodes while their particles are
    /// immovable (a pin taken away in place leaves a plain tree; where an extra closing's is
    /// taken away, no extra closing is closed — the Bevy layer rebuilds such a tree).
    fn view_of<'s>(&self, set: &'s TreeSet, tree: &Tree) -> TreeView<'s> {
        let nodes = tree.nodes.start as usize..tree.nodes.end as usize;
        let particle = &set.particle[nodes.clone()];
        let held = |t: usize| {
            particle
                .get(t)
                .is_some_and(|&p| self.inverse_mass.get(p as usize).is_some_and(|&w| w <= 0.0))
        };
        let closing = tree.closing.map(|t| t as usize).filter(|&t| held(t));
        let extra = &set.extra_closing
            [tree.extra_closings.start as usize..tree.extra_closings.end as usize];
        let extra = match closing.is_some() && extra.iter().all(|&t| held(t as usize)) {
            true => extra,
            false => &[],
        };
        TreeView {
            particle,
            stick: &set.stick[nodes.clone()],
            parent: &set.parent[nodes],
            offset: tree.nodes.start,
            closing,
            extra,
        }
    }

    /// Panics unless every index the passes below read without bounds checks is in bounds:
    /// node particles, the nodes' sticks and their ends, and parents (each before its child,
    /// as [`build`]'s breadth-first order makes them). One check per solve instead of one per
    /// access.
    fn check(&self, view: &TreeView) {
        let mirror = self.mirror.map_or(usize::MAX, |mirror| mirror.len());
        let particles = [
            self.position.len(),
            self.previous.len(),
            self.inverse_mass.len(),
        ]
        .into_iter()
        .fold(mirror, usize::min);
        let sticks = &self.sticks;
        let stick_count = [
            sticks.ends.len(),
            sticks.rest_length.len(),
            sticks.compliance.len(),
            sticks.kind.len(),
            self.lambda.len(),
        ]
        .into_iter()
        .min()
        .unwrap_or(0);
        let nodes_ok = (1..view.particle.len()).all(|t| {
            let k = view.stick[t] as usize;
            let parent = view.parent[t].wrapping_sub(view.offset) as usize;
            k < stick_count
                && sticks.ends[k].iter().all(|&p| (p as usize) < particles)
                && parent < t
        });
        assert!(
            view.particle.iter().all(|&p| (p as usize) < particles) && nodes_ok,
            "a tree's nodes are out of bounds"
        );
    }

    /// Stick `k`'s warm start from its last multiplier `last`: a one-sided stick's only in the
    /// direction it can act.
    fn warm_of(&self, k: usize, last: f64) -> f64 {
        match self.sticks.kind[k] {
            StickKind::Equal => last,
            StickKind::AtMost => last.min(0.0),
            StickKind::AtLeast => last.max(0.0),
            StickKind::Torn => 0.0,
        }
    }

    /// `true` when curvature passes apply (see [`curvature`]): always, but in a tree with a
    /// closing stick whose root was unpinned in place (they close the loop from an immovable
    /// root only; Gauss–Newton passes close it either way).
    fn curvable(&self, view: &TreeView) -> bool {
        view.closing.is_none() || self.inverse_mass[view.particle[0] as usize] <= 0.0
    }

    /// `true` when a particle other than the root and the closing nodes is immovable (the
    /// closing nodes are, see [`TreeSolve::view_of`]).
    fn pinned_below_root(&self, view: &TreeView) -> bool {
        let closing = usize::from(view.closing.is_some()) + view.extra.len();
        let immovable = (1..view.particle.len())
            .filter(|&t| self.inverse_mass[view.particle[t] as usize] <= 0.0)
            .count();
        immovable > closing
    }

    /// One Gauss–Seidel sweep over the tree's sticks, root to leaves (no warm start after it).
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`].
    unsafe fn sweep(&self, view: &TreeView, s: &mut [Node]) {
        for (node, &k) in s.iter_mut().zip(view.stick).skip(1) {
            let k = k as usize;
            // SAFETY: the stick's particles and multiplier are this task's (caller).
            unsafe {
                relax_stick_range(
                    self.position,
                    self.inverse_mass,
                    self.sticks,
                    self.lambda,
                    k..k + 1,
                    self.inv_h2,
                    false,
                    false,
                    SweepOrder::Forward,
                );
            }
            node.warm = 0.0;
        }
    }

    /// Start of the substep: start directions, the mode (SHAKE when no stick turns more than
    /// ≈ 8° and no particle's tension makes it unstable, see [`SHAKE_STIFFNESS_BELOW`], decided
    /// before the warm start; `shake`: it may be used this substep), and the warm start along the start
    /// directions (SHAKE only). Returns the largest `|C|/L` before the warm start, and the
    /// largest of a rigid stick at the start positions.
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`].
    unsafe fn begin(&self, view: &TreeView, s: &mut [Node], shake: bool) -> Begun {
        let mut shake = shake;
        let (mut predicted, mut violated): (f64, f64) = (0.0, 0.0);
        // SAFETY: the tree's particles and multipliers are this task's (caller).
        unsafe {
            s[0].stiffness = 0.0;
            if !view.extra.is_empty() {
                // (A stretched rope link too where the tree has extra closing sticks: see
                // `stabilise_start`.)
                violated = violated.max(self.stretched_ropes(view));
            }
            for t in 1..s.len() {
                let k = view.stick[t] as usize;
                let node = &mut s[t];
                let [a, b] = self.sticks.ends[k].map(|p| p as usize);
                let (start, start_length) =
                    unit_and_length(self.previous.get(b) - self.previous.get(a), k);
                let d = self.position.get(b) - self.position.get(a);
                let length = d.length();
                let rest = self.sticks.rest_length[k].max(1e-12);
                predicted = predicted.max((length - rest).abs() / rest);
                let rigid =
                    self.sticks.kind[k] == StickKind::Equal && self.sticks.compliance[k] == 0.0;
                if rigid && self.inverse_mass[a] + self.inverse_mass[b] > 0.0 {
                    violated = violated.max((start_length - rest).abs() / rest);
                }
                shake &= start.dot(d) >= SHAKE_MIN_COSINE * length;
                if !in_system(self.sticks.kind[k], length - rest, rest) {
                    // (A slack one-sided stick gets no warm start: a pull no pass takes back.)
                    node.warm = 0.0;
                }
                node.start = start;
                // (Each node after its parent: the parent's sum has begun.)
                let mu = tension_stiffness(node.warm, start_length);
                node.stiffness = mu;
                s[(view.parent[t] - view.offset) as usize].stiffness += mu;
            }
            let stiff = s
                .iter()
                .zip(view.particle)
                .map(|(node, &p)| self.inverse_mass[p as usize] * node.stiffness)
                .fold(0.0, f64::max);
            shake &= stiff < SHAKE_STIFFNESS_BELOW;
            s[0].mode = if shake {
                LineMode::Shake
            } else {
                LineMode::Project
            };
            for (node, &k) in s.iter().zip(view.stick).skip(1) {
                let k = k as usize;
                let warm = if shake {
                    self.warm_of(k, node.warm)
                } else {
                    0.0
                };
                self.lambda.set(k, warm);
                self.move_ends(k, node.start * warm);
            }
        }
        Begun {
            predicted,
            violated,
        }
    }

    /// The largest stretch of the tree's rigid rope links (`AtMost`) at the start of the
    /// substep, relative to their rest lengths.
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`].
    #[inline(never)]
    unsafe fn stretched_ropes(&self, view: &TreeView) -> f64 {
        let mut worst: f64 = 0.0;
        for &k in &view.stick[1..] {
            let k = k as usize;
            let rope = self.sticks.kind[k] == StickKind::AtMost && self.sticks.compliance[k] == 0.0;
            let [a, b] = self.sticks.ends[k].map(|p| p as usize);
            if rope && self.inverse_mass[a] + self.inverse_mass[b] > 0.0 {
                // SAFETY: the tree's particles are this task's (caller).
                let d = unsafe { self.previous.get(b) - self.previous.get(a) };
                let rest = self.sticks.rest_length[k].max(1e-12);
                worst = worst.max((d.length() - rest).max(0.0) / rest);
            }
        }
        worst
    }

    /// Moves the start-of-substep positions onto the constraints (Newton on the previous
    /// positions) and the current positions by the same amounts, so a violation at the start —
    /// an edited rest length, a spawn — is corrected without becoming velocity (as the line
    /// solve's `stabilise_start`). In a tree with extra closing sticks, where its passes end
    /// unconverged and farther off the constraints than they began (start positions no point
    /// satisfies: pins pulled apart beyond the paths between them), the start is left as it
    /// was: such passes had thrown a tree held by four waving pins 2000 link lengths (a
    /// scratch scan; other trees keep their figures, see the module docs).
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`], with `c` as long as `s` (or empty: nothing left as it was).
    unsafe fn stabilise_start(
        &self,
        view: &TreeView,
        (s, more): (&mut [Node], &mut [Closing]),
        c: &mut [TreeCurvature],
    ) {
        let mode = s[0].mode;
        s[0].mode = LineMode::Project;
        let start = TreeSolve {
            position: self.previous,
            mirror: Some(self.position),
            shake: false,
            first_round: false,
            ..*self
        };
        // SAFETY: as for `solve` (caller).
        unsafe {
            let keeps = c.len() == s.len() && !view.extra.is_empty();
            if keeps {
                self.keep_start(view, c);
            }
            let before = start.residual(view);
            let (_, converged) =
                start.newton(view, (s, more), MAX_PASSES, f64::INFINITY, f64::INFINITY);
            let after = start.residual(view);
            let worse = after > before || after.is_nan() || before.is_nan();
            if keeps && !converged && worse {
                self.restore_start(view, c);
            }
            for t in 1..view.particle.len() {
                self.lambda.set(view.stick[t] as usize, 0.0);
            }
        }
        s[0].mode = mode;
    }

    /// Takes back every correction of the substep so far (all along the start directions: the
    /// warm start and SHAKE passes); λ = 0 after.
    ///
    /// # Safety
    /// As for [`TreeSolve::solve`].
    unsafe fn take_back(&self, view: &TreeView, s: &mut [Node]) {
        for (node, &k) in s.iter().zip(view.stick).skip(1) {
            let k = k as usize;
            // SAFETY: as for `solve` (caller).
            unsafe {
                let lambda = self.lambda.get(k);
                self.lambda.set(k, 0.0);
                self.move_ends(k, -node.start * lambda);
            }
        }
    }
}

/// One tree's node arrays.
struct TreeView<'a> {
    particle: &'a [u32],
    stick: &'a [u32],
    parent: &'a [u32],
    /// The tree's first node in the set (parents are absolute indices).
    offset: u32,
    /// The tree's [`closing`](Tree::closing) node while its particle is immovable.
    closing: Option<usize>,
    /// Its [extra closing nodes](Tree::extra_closings) (empty unless `closing` is some).
    extra: &'a [u32],
}

/// Sets each record's `β` from its `v`.
fn set_betas(records: &mut [Closing], beta: impl Fn(DVec3) -> f64) {
    for record in records {
        record.beta = beta(record.v);
    }
}

/// `x yᵀ`.
fn outer(x: DVec3, y: DVec3) -> DMat3 {
    DMat3::from_cols(x * y.x, x * y.y, x * y.z)
}

/// What the tree solve's unit tests share.
#[cfg(test)]
mod test_support {
    use super::{TreeSet, TreeSolve, TreeView};
    use crate::solver::Solver;
    use crate::solver::shared::SharedSlice;
    use glam::DVec3;

    /// `1/h²` of the tests' passes.
    pub(super) const INV_H2: f64 = 4096.0;

    /// The view of `set`'s first tree (its closing nodes, if it has any, taken as immovable).
    pub(super) fn first_view(set: &TreeSet) -> TreeView<'_> {
        let tree = &set.trees[0];
        let nodes = tree.nodes.start as usize..tree.nodes.end as usize;
        TreeView {
            particle: &set.particle[nodes.clone()],
            stick: &set.stick[nodes.clone()],
            parent: &set.parent[nodes],
            offset: tree.nodes.start,
            closing: tree.closing.map(|t| t as usize),
            extra: &set.extra_closing
                [tree.extra_closings.start as usize..tree.extra_closings.end as usize],
        }
    }

    /// Runs `pass` on a solve over copies of `solver`'s positions (as both current and start
    /// positions) and of `lambda`; returns the positions and multipliers it leaves.
    pub(super) fn run_pass(
        solver: &Solver,
        lambda: &[f64],
        shake: bool,
        pass: impl FnOnce(&TreeSolve<'_, '_>),
    ) -> (Vec<DVec3>, Vec<f64>) {
        let mut position = solver.particles.position.clone();
        let mut previous = position.clone();
        let mut lambda = lambda.to_vec();
        {
            let (position, previous) = (
                SharedSlice::new(&mut position),
                SharedSlice::new(&mut previous),
            );
            let lambda = SharedSlice::new(&mut lambda);
            pass(&TreeSolve {
                position: &position,
                previous: &previous,
                mirror: None,
                lambda: &lambda,
                inverse_mass: &solver.particles.inverse_mass,
                sticks: &solver.sticks,
                inv_h2: INV_H2,
                shake,
                first_round: true,
            });
        }
        (position, lambda)
    }
}
