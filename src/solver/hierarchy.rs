//! Hierarchies: coarse levels that carry a mesh's load across it in one pass (Müller 2008).
//!
//! A Gauss–Seidel sweep carries a correction one or two sticks per pass, so a cloth hung by a
//! few pins stretches until the pins' pull has crossed it. Hierarchical position based dynamics
//! (Müller 2008, "Hierarchical Position Based Dynamics", VRIPHYS) solves coarser copies of the
//! mesh first and hands their corrections down: here, before every sweep of an island solved by
//! [`Method::Hierarchy`](super::Method::Hierarchy),
//!
//! 1. from the coarsest level to the first: the level's sticks are projected once (taking back
//!    [`COARSE_RELAXATION`] of their excess length) — they join
//!    particles a few fine sticks apart and only pull (a coarse stick may not be longer than the
//!    path of rigid sticks it spans, so it never stiffens bending or shear) — using the level's
//!    masses (each coarse particle carries the masses of the finer particles interpolated from
//!    it);
//! 2. the level's corrections are interpolated down to the finer particles that are not on it
//!    (linearly along the lines through them);
//! 3. then the ordinary sweep over the fine sticks.
//!
//! Levels are built from the island's line cover (see [`lines`](super::lines)): a grid's lines
//! are its rows and columns. A particle is on the next level when it is pinned or sits at an
//! even position (or the end) of every line through it — on a grid, every other particle of
//! every other row and column, the corners included — and the next level's lines are the old
//! lines' coarse particles. Only lines of rigid (`compliance == 0`) `Equal`/`AtMost` sticks
//! take part. Levels stop at a few particles.
//!
//! Measured (100 × 100 cloth hung by two corners, 8 × 1, `tests/hard_cases.rs`): largest strain
//! 957 % → 73 % while falling, 515 % → 31 % hanging; the step costs 1.8–2.2× the plain sweep's,
//! as much as 16 swept substeps, which leave 304 % / 143 % (`examples/bench`, see the README).
//! At 4 substeps the hierarchy fluttered (0.8 % of the fall's peak kinetic energy left after
//! 10 s), so it is meant for the default 8 and more. The C prototype
//! `report/prototypes/hpbd_grid.c` has the 2D figures.
//!
//! A hierarchy is dropped for the rest of the topology (the island is swept plainly) once one of
//! its island's sticks is torn, cut, or made soft: coarse sticks across a tear would hold the
//! pieces together. Masses and rest lengths are re-read at the start of every step.
//!
//! ```
//! use bevy_verlet_physics::solver::{Method, Solver, StepConfig, StickKind};
//! use glam::DVec3;
//! // A 9 × 9 grid hung by its two top corners, solved with a hierarchy.
//! let mut solver = Solver::default();
//! let n = 9;
//! for row in 0..n {
//!     for column in 0..n {
//!         let pinned = row == 0 && (column == 0 || column == n - 1);
//!         let at = DVec3::new(column as f64, -(row as f64), 0.0);
//!         solver.add_particle(at, if pinned { 0.0 } else { 1.0 });
//!     }
//! }
//! for row in 0..n {
//!     for column in 0..n {
//!         let i = (row * n + column) as u32;
//!         if column > 0 {
//!             solver.sticks.push([i - 1, i], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
//!         }
//!         if row > 0 {
//!             solver.sticks.push([i - n as u32, i], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
//!         }
//!     }
//! }
//! solver.method = Method::Hierarchy;
//! solver.organize();
//! assert_eq!(solver.islands.list[0].method, Method::Hierarchy);
//! assert!(solver.islands.list[0].hierarchy.is_some());
//! solver.step(&StepConfig::default());
//! ```

use super::lines::{Line, LineSet};
use super::shared::SharedSlice;
use super::{Particles, StickKind, Sticks};
use glam::DVec3;
use std::ops::Range;

/// A level with at most this many particles is not coarsened further.
const COARSEST: usize = 4;

/// At most this many coarse levels.
const MAX_LEVELS: usize = 12;

/// Fraction of a coarse stick's excess length one pass takes back. Measured on a 100 × 100
/// cloth hung by two corners (8 × 1, damping 1/s, 10 s; largest strain falling / hanging,
/// kinetic energy in the last second against the fall's peak): 1.0 → 61 % / 32 % but a
/// lasting flutter (63 J, 0.6 % of the peak); 0.85 → 73 % / 29 %, 4.5 J (0.04 %, as the plain
/// sweep's 6 J); 0.7 → 84 % / 38 %, 5 J; 0.5 → 108 % / 53 %. (Measured before the levels'
/// corrections were summed from the projections rather than read back from the positions —
/// the same method, rounded differently: 0.85 now gives 73 % / 31 %, at most 15 J in the last
/// 2 s, see `tests/hard_cases.rs`.)
pub const COARSE_RELAXATION: f64 = 0.85;

/// Every island's hierarchy (see the [module docs](self)).
#[derive(Clone, Debug, Default)]
pub struct HierarchySet {
    /// The hierarchies, indexed by [`Island::hierarchy`](super::Island::hierarchy).
    pub list: Vec<Hierarchy>,
    /// Scratch nodes needed by all hierarchies together (one slot per node of the largest
    /// level of each).
    pub(crate) nodes: usize,
    /// Masses per particle while the levels' masses are refreshed.
    mass: Vec<f64>,
    /// Per-particle scratch of [`build`], kept across islands and rebuilds.
    marks: Marks,
}

/// One island's coarse levels, finest first.
#[derive(Clone, Debug, Default)]
pub struct Hierarchy {
    /// The coarse levels: `levels[0]` is one step coarser than the island itself.
    pub levels: Vec<Level>,
    /// This hierarchy's slots in the shared node scratch.
    pub(crate) scratch: Range<u32>,
    /// One more than the largest particle slot of any level or child (the solve checks it
    /// against the arrays once, then reads them unchecked).
    slots: usize,
    /// The fine sticks its levels stand on (all must stay rigid and whole).
    fine_sticks: Vec<u32>,
    /// `false` once a fine stick was torn or made soft: the island is swept plainly.
    pub active: bool,
}

/// One coarse level.
#[derive(Clone, Debug, Default)]
pub struct Level {
    /// Its particles (solver slots).
    pub particles: Vec<u32>,
    /// Their inverse masses on this level (`0` for pinned particles).
    pub inverse_mass: Vec<f64>,
    /// Its sticks: ends are indices into [`Level::particles`].
    pub sticks: Vec<CoarseStick>,
    /// Members of the sticks' spans: sticks of the next finer level (fine stick indices for
    /// the first level).
    spans: Vec<u32>,
    /// The finer level's particles that are not on this level, in interpolation order.
    pub children: Vec<Child>,
    /// The order its sticks are projected in: line after line, but up to [`INTERLEAVE`]
    /// consecutive lines that share no particle take turns, stick by stick — the same result
    /// (they touch different particles) without each projection waiting for the last one's
    /// square root.
    order: Vec<u32>,
}

/// At most this many disjoint lines take turns in a level's projection order.
const INTERLEAVE: usize = 4;

/// A coarse stick: it only pulls, when longer than the path it spans.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CoarseStick {
    /// Indices into [`Level::particles`].
    pub ends: [u32; 2],
    /// The ends' solver slots (copied from [`Level::particles`] for the hot loop).
    slots: [u32; 2],
    /// The ends' inverse masses on the level (set with the level's masses).
    inverse_mass: [f64; 2],
    /// Rest length of the spanned path (`INFINITY`: inactive).
    pub max_length: f64,
    /// Range into the level's spans.
    span: Range<u32>,
}

/// A finer particle moved with the corrections of up to four nodes: a node `k` is the level's
/// particle `k` when `k < particles.len()`, else the child `k − particles.len()` (an earlier one).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Child {
    /// The particle (solver slot).
    pub particle: u32,
    /// Its parents' node indices (unused ones have weight 0).
    pub parents: [u32; 4],
    /// Interpolation weights (they sum to 1).
    pub weights: [f64; 4],
}

/// A line of one level while the next is built: particle slots and the sticks between them
/// (fine stick indices on the first level, the level's coarse sticks after).
#[derive(Clone, Debug, Default)]
struct Path {
    particles: Vec<u32>,
    sticks: Vec<u32>,
}

impl HierarchySet {
    /// Removes every hierarchy, keeping the allocations.
    pub fn clear(&mut self) {
        self.list.clear();
        self.nodes = 0;
    }
}

/// `true` when stick `s` may carry a hierarchy: whole, rigid, and pulling.
fn rigid_pull(sticks: &Sticks, s: usize) -> bool {
    sticks.compliance[s] == 0.0 && matches!(sticks.kind[s], StickKind::Equal | StickKind::AtMost)
}

/// Builds the hierarchy of an island from its lines (`lines`, ranges into `set`), appending it
/// to `out`; returns its index, or `None` when the lines give no coarse level.
pub(crate) fn build(
    out: &mut HierarchySet,
    set: &LineSet,
    lines: &[Line],
    (particles, sticks): (&Particles, &Sticks),
) -> Option<u32> {
    let mut paths = first_paths(set, lines, sticks);
    let mut hierarchy = Hierarchy {
        active: true,
        fine_sticks: paths
            .iter()
            .flat_map(|p| p.sticks.iter().copied())
            .collect(),
        ..Hierarchy::default()
    };
    let mut marks = std::mem::take(&mut out.marks);
    marks.ensure(particles.len());
    let mut nodes = 0;
    while hierarchy.levels.len() < MAX_LEVELS {
        let Some((level, next)) = coarsen(&paths, particles, &mut marks) else {
            break;
        };
        nodes = nodes.max(level.particles.len() + level.children.len());
        let done = level.particles.len() <= COARSEST || level.sticks.is_empty();
        hierarchy.levels.push(level);
        paths = next;
        if done {
            break;
        }
    }
    marks.reset();
    out.marks = marks;
    if hierarchy.levels.is_empty() {
        return None;
    }
    hierarchy.slots = hierarchy
        .levels
        .iter()
        .flat_map(|level| {
            let children = level.children.iter().map(|child| &child.particle);
            level.particles.iter().chain(children)
        })
        .map(|&p| p as usize + 1)
        .max()
        .unwrap_or(0);
    hierarchy.scratch = out.nodes as u32..(out.nodes + nodes) as u32;
    out.nodes += nodes;
    out.list.push(hierarchy);
    Some(out.list.len() as u32 - 1)
}

/// The island's lines cut into paths of rigid pulling sticks.
fn first_paths(set: &LineSet, lines: &[Line], sticks: &Sticks) -> Vec<Path> {
    let mut paths = Vec::new();
    for line in lines {
        let ps = &set.particles[line.particles.start as usize..line.particles.end as usize];
        let ss = &set.sticks[line.sticks.start as usize..line.sticks.end as usize];
        let mut path = Path::default();
        for (k, &s) in ss.iter().enumerate() {
            if rigid_pull(sticks, s as usize) {
                if path.particles.is_empty() {
                    path.particles.push(ps[k]);
                }
                path.particles.push(ps[k + 1]);
                path.sticks.push(s);
            } else if !path.sticks.is_empty() {
                paths.push(std::mem::take(&mut path));
            }
        }
        if !path.sticks.is_empty() {
            paths.push(path);
        }
    }
    paths
}

/// Per-particle marks while a level is built: the position of each particle on the level
/// (`u32::MAX`: not on it), whether an odd position of a line excludes it, and the lines
/// through it.
#[derive(Clone, Debug, Default)]
struct Marks {
    coarse_index: Vec<u32>,
    odd: Vec<bool>,
    node: Vec<u32>,
    on_paths: Vec<Vec<(u32, u32)>>,
    touched: Vec<u32>,
    /// Per particle: the run of interleaved lines that last took it (see [`solve_order`]).
    run: Vec<u32>,
    /// Runs started so far (the stamp of [`Marks::run`]).
    runs: u32,
}

impl Marks {
    /// Sizes the marks for `n` particles (new ones unmarked).
    fn ensure(&mut self, n: usize) {
        if self.coarse_index.len() < n {
            self.coarse_index.resize(n, u32::MAX);
            self.odd.resize(n, false);
            self.node.resize(n, u32::MAX);
            self.on_paths.resize(n, Vec::new());
            self.run.resize(n, 0);
        }
    }

    fn reset(&mut self) {
        for &p in &self.touched {
            let p = p as usize;
            self.coarse_index[p] = u32::MAX;
            self.odd[p] = false;
            self.node[p] = u32::MAX;
            self.on_paths[p].clear();
        }
        self.touched.clear();
    }
}

/// One coarsening step: the level built on `paths` and the paths of the next one.
fn coarsen(paths: &[Path], particles: &Particles, marks: &mut Marks) -> Option<(Level, Vec<Path>)> {
    marks.reset();
    let mut order = Vec::new();
    for (k, path) in paths.iter().enumerate() {
        let last = path.particles.len() - 1;
        for (position, &p) in path.particles.iter().enumerate() {
            let slot = p as usize;
            if marks.on_paths[slot].is_empty() {
                marks.touched.push(p);
                order.push(p);
            }
            marks.on_paths[slot].push((k as u32, position as u32));
            marks.odd[slot] |= position % 2 == 1 && position != last;
        }
    }
    let mut level = Level::default();
    for &p in &order {
        let slot = p as usize;
        if particles.inverse_mass[slot] == 0.0 || !marks.odd[slot] {
            marks.coarse_index[slot] = level.particles.len() as u32;
            marks.node[slot] = level.particles.len() as u32;
            level.particles.push(p);
        }
    }
    if level.particles.len() == order.len() || level.particles.len() < 2 {
        return None;
    }
    let next = coarse_sticks(paths, marks, &mut level);
    level.order = solve_order(&next, marks);
    interpolate(paths, &order, marks, &mut level);
    level.inverse_mass = vec![0.0; level.particles.len()];
    Some((level, next))
}

/// The level's sticks, between consecutive coarse particles of every path, and its paths.
fn coarse_sticks(paths: &[Path], marks: &Marks, level: &mut Level) -> Vec<Path> {
    let mut next = Vec::new();
    for path in paths {
        let mut coarse = Path::default();
        let mut span_start = level.spans.len() as u32;
        for (position, &p) in path.particles.iter().enumerate() {
            if position > 0 {
                level.spans.push(path.sticks[position - 1]);
            }
            let index = marks.coarse_index[p as usize];
            if index == u32::MAX {
                continue;
            }
            if let Some(&previous) = coarse.particles.last() {
                let span = span_start..level.spans.len() as u32;
                coarse.sticks.push(level.sticks.len() as u32);
                level.sticks.push(CoarseStick {
                    ends: [marks.coarse_index[previous as usize], index],
                    slots: [previous, p],
                    inverse_mass: [0.0; 2],
                    max_length: f64::INFINITY,
                    span,
                });
            } else {
                // (Sticks before the path's first coarse particle span nothing.)
                level.spans.truncate(span_start as usize);
            }
            span_start = level.spans.len() as u32;
            coarse.particles.push(p);
        }
        level.spans.truncate(span_start as usize);
        if !coarse.sticks.is_empty() {
            next.push(coarse);
        }
    }
    next
}

/// The projection order of a level's sticks (see [`Level::order`]): runs of up to
/// [`INTERLEAVE`] consecutive lines that share no particle, their sticks taken in turn.
fn solve_order(lines: &[Path], marks: &mut Marks) -> Vec<u32> {
    let mut order = Vec::with_capacity(lines.iter().map(|l| l.sticks.len()).sum());
    let mut run: Vec<&Path> = Vec::with_capacity(INTERLEAVE);
    let flush = |run: &mut Vec<&Path>, order: &mut Vec<u32>| {
        let longest = run.iter().map(|l| l.sticks.len()).max().unwrap_or(0);
        for k in 0..longest {
            order.extend(run.iter().filter_map(|l| l.sticks.get(k)));
        }
        run.clear();
    };
    for line in lines {
        let stamp = marks.runs;
        let disjoint = line
            .particles
            .iter()
            .all(|&p| marks.run[p as usize] != stamp);
        if run.len() == INTERLEAVE || !disjoint || run.is_empty() {
            flush(&mut run, &mut order);
            marks.runs += 1;
        }
        let stamp = marks.runs;
        for &p in &line.particles {
            marks.run[p as usize] = stamp;
        }
        run.push(line);
    }
    flush(&mut run, &mut order);
    order
}

/// Gives every finer particle not on the level its parents: along each line through it, the
/// nearest particles on both sides that are on the level or were given parents in an earlier
/// round, weighted by distance along the line (one side only at a line's end).
fn interpolate(paths: &[Path], order: &[u32], marks: &mut Marks, level: &mut Level) {
    let coarse = level.particles.len() as u32;
    let mut pending: Vec<u32> = order
        .iter()
        .copied()
        .filter(|&p| marks.node[p as usize] == u32::MAX)
        .collect();
    let mut found = Vec::new();
    while !pending.is_empty() {
        found.clear();
        for &p in &pending {
            if let Some(child) = parents_of(p, paths, marks) {
                found.push(child);
            }
        }
        if found.is_empty() {
            break;
        }
        for child in &found {
            marks.node[child.particle as usize] = coarse + level.children.len() as u32;
            level.children.push(*child);
        }
        pending.retain(|&p| marks.node[p as usize] == u32::MAX);
    }
}

/// Parents of `p` from the particles that already have a node (see [`interpolate`]).
fn parents_of(p: u32, paths: &[Path], marks: &Marks) -> Option<Child> {
    let mut child = Child {
        particle: p,
        ..Child::default()
    };
    let mut used = 0;
    let mut lines = 0;
    for &(k, position) in &marks.on_paths[p as usize] {
        if used + 2 > 4 {
            break;
        }
        let path = &paths[k as usize].particles;
        let at = position as usize;
        let before = (0..at)
            .rev()
            .find(|&i| marks.node[path[i] as usize] != u32::MAX);
        let after = (at + 1..path.len()).find(|&i| marks.node[path[i] as usize] != u32::MAX);
        let (a, b) = match (before, after) {
            (Some(a), Some(b)) => (a, b),
            (Some(a), None) if at + 1 == path.len() => (a, a),
            (None, Some(b)) if at == 0 => (b, b),
            _ => continue,
        };
        // Linear along the line, by particle count (the lines' sticks are near-equal here).
        let t = if a == b {
            0.0
        } else {
            (at - a) as f64 / (b - a) as f64
        };
        child.parents[used] = marks.node[path[a] as usize];
        child.weights[used] = 1.0 - t;
        child.parents[used + 1] = marks.node[path[b] as usize];
        child.weights[used + 1] = t;
        used += 2;
        lines += 1;
    }
    if lines == 0 {
        return None;
    }
    for w in &mut child.weights[..used] {
        *w /= lines as f64;
    }
    Some(child)
}

impl HierarchySet {
    /// Re-reads masses and rest lengths (start of a step); drops the hierarchies whose fine
    /// sticks are no longer all whole and rigid.
    pub(crate) fn refresh(&mut self, particles: &Particles, sticks: &Sticks) {
        self.mass.resize(particles.len(), 0.0);
        for hierarchy in &mut self.list {
            if !hierarchy.active {
                continue;
            }
            let whole = hierarchy
                .fine_sticks
                .iter()
                .all(|&s| (s as usize) < sticks.len() && rigid_pull(sticks, s as usize));
            if !whole {
                hierarchy.active = false;
                continue;
            }
            refresh_lengths(&mut hierarchy.levels, sticks);
            refresh_masses(&mut hierarchy.levels, particles, &mut self.mass);
        }
    }
}

/// Every coarse stick's rest length: the sum over its span on the finer level.
fn refresh_lengths(levels: &mut [Level], sticks: &Sticks) {
    for i in 0..levels.len() {
        let (finer, rest) = levels.split_at_mut(i);
        let level = &mut rest[0];
        for stick in &mut level.sticks {
            let span = &level.spans[stick.span.start as usize..stick.span.end as usize];
            stick.max_length = match finer.last() {
                None => span.iter().map(|&s| sticks.rest_length[s as usize]).sum(),
                Some(f) => span.iter().map(|&s| f.sticks[s as usize].max_length).sum(),
            };
        }
    }
}

/// Every level's masses: a coarse particle keeps its own and gathers its children's by their
/// weights (children after their parents, so gathered from the last child back).
fn refresh_masses(levels: &mut [Level], particles: &Particles, mass: &mut [f64]) {
    let Some(first) = levels.first() else {
        return;
    };
    let fine = first
        .particles
        .iter()
        .chain(first.children.iter().map(|c| &c.particle));
    for &p in fine {
        let w = particles.inverse_mass[p as usize];
        mass[p as usize] = if w > 0.0 { 1.0 / w } else { f64::INFINITY };
    }
    for level in levels {
        let coarse = level.particles.len();
        for child in level.children.iter().rev() {
            let m = mass[child.particle as usize];
            for (&parent, &w) in child.parents.iter().zip(&child.weights) {
                if w > 0.0 {
                    let k = parent as usize;
                    let slot = if k < coarse {
                        level.particles[k]
                    } else {
                        level.children[k - coarse].particle
                    };
                    mass[slot as usize] += w * m;
                }
            }
        }
        for (w, &p) in level.inverse_mass.iter_mut().zip(&level.particles) {
            let m = mass[p as usize];
            *w = if m.is_finite() && m > 0.0 {
                1.0 / m
            } else {
                0.0
            };
        }
        for stick in &mut level.sticks {
            stick.inverse_mass = stick.ends.map(|e| level.inverse_mass[e as usize]);
        }
    }
}

impl Hierarchy {
    /// One pass over the coarse levels, coarsest first, each level's corrections handed down to
    /// the finer particles not on it (see the [module docs](self)). `fine_inverse_mass` keeps
    /// pinned particles still.
    ///
    /// # Safety
    /// No other task accesses the particles of this hierarchy's island or its scratch slots
    /// while this runs, and `nodes` is this hierarchy's range of the scratch (at least as long
    /// as its largest level's nodes).
    pub(crate) unsafe fn solve(
        &self,
        position: &SharedSlice<DVec3>,
        fine_inverse_mass: &[f64],
        nodes: &mut [DVec3],
    ) {
        // One check per pass instead of one per access: every slot below is under `slots`, and
        // every node index under its level's particles and children (as `build` makes them;
        // the levels cannot be changed from outside the crate).
        assert!(
            self.slots <= position.len().min(fine_inverse_mass.len()),
            "a hierarchy's particles are out of bounds"
        );
        for level in self.levels.iter().rev() {
            let coarse = level.particles.len();
            let nodes = &mut nodes[..coarse + level.children.len()];
            nodes[..coarse].fill(DVec3::ZERO);
            // SAFETY: slots and node indices in bounds (checked above and by construction);
            // the island's particles and the scratch are this task's (caller).
            unsafe {
                level.project(position, nodes);
                level.hand_down(position, fine_inverse_mass, nodes);
            }
        }
    }
}

impl Level {
    /// Projects the level's coarse sticks once (in [`Level::order`]), gathering each coarse
    /// particle's corrections in its node.
    ///
    /// # Safety
    /// The sticks' slots are under `position.len()`, their ends under `nodes.len()`, and no
    /// other task accesses these particles.
    #[inline(always)]
    unsafe fn project(&self, position: &SharedSlice<DVec3>, nodes: &mut [DVec3]) {
        for &k in &self.order {
            let stick = &self.sticks[k as usize];
            let [wa, wb] = stick.inverse_mass;
            let [pa, pb] = stick.slots.map(|s| s as usize);
            // SAFETY: in bounds, this task's (caller).
            let (xa, xb) = unsafe { (position.get_unchecked(pa), position.get_unchecked(pb)) };
            let d = xb - xa;
            let length = d.length();
            // (NaN lengths are skipped: a NaN is never spread from here.)
            if length.is_nan() || length <= stick.max_length || wa + wb <= 0.0 {
                continue;
            }
            let excess = COARSE_RELAXATION * (length - stick.max_length);
            let correction = d * (excess / (length * (wa + wb)));
            let [a, b] = stick.ends.map(|e| e as usize);
            // SAFETY: as above.
            unsafe {
                position.set_unchecked(pa, xa + correction * wa);
                position.set_unchecked(pb, xb - correction * wb);
                *nodes.get_unchecked_mut(a) += correction * wa;
                *nodes.get_unchecked_mut(b) -= correction * wb;
            }
        }
    }

    /// Interpolates the level's corrections to the finer particles not on it (children in
    /// order: a child's parents are coarse particles or earlier children).
    ///
    /// # Safety
    /// The children's particles are under `position.len()` and `fine_inverse_mass.len()`, a
    /// child `k`'s parents under `particles.len() + k`, `nodes` holds the particles' and the
    /// children's nodes, and no other task accesses these particles.
    #[inline(always)]
    unsafe fn hand_down(
        &self,
        position: &SharedSlice<DVec3>,
        fine_inverse_mass: &[f64],
        nodes: &mut [DVec3],
    ) {
        let coarse = self.particles.len();
        for (k, child) in self.children.iter().enumerate() {
            let mut delta = DVec3::ZERO;
            for (&parent, &w) in child.parents.iter().zip(&child.weights) {
                if w > 0.0 {
                    // SAFETY: an earlier node (caller).
                    delta += unsafe { *nodes.get_unchecked(parent as usize) } * w;
                }
            }
            let p = child.particle as usize;
            // SAFETY: in bounds (caller); the child's own node; its particle is this task's.
            unsafe {
                *nodes.get_unchecked_mut(coarse + k) = delta;
                if *fine_inverse_mass.get_unchecked(p) > 0.0 && delta.is_finite() {
                    position.set_unchecked(p, position.get_unchecked(p) + delta);
                }
            }
        }
    }
}
