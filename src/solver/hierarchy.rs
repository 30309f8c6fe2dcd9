//! Hierarchies: coarse levels of long-range sticks that carry a mesh's load across it in one pass.
//!
//! A Gauss–Seidel sweep carries a correction one or two sticks per pass, so a cloth hung by a
//! few pins stretches until the pins' pull has crossed it. Hierarchical position based dynamics
//! (Müller 2008, "Hierarchical Position Based Dynamics", VRIPHYS) solves coarser copies of the
//! mesh first. Here, before every sweep of an island solved by
//! [`Method::Hierarchy`](super::Method::Hierarchy), from the coarsest level to the first, every
//! level's *coarse sticks* are projected (the smaller levels several times: [`Level::passes`]),
//! then the ordinary sweep runs over the fine sticks, then the levels above the first again,
//! as many times each ([`AFTER_SWEEP_FROM_LEVEL`]). A coarse
//! stick joins two particles a few fine sticks apart along a line of the mesh
//! and only pulls: its ends may not be farther apart than the rest length of the path of rigid
//! sticks between them — a bound the fine sticks imply (a path is never shorter than the
//! straight line between its ends), so a coarse stick never stiffens bending or shear, and it
//! is projected with the particles' own masses like any stick: a position-based projection
//! onto a constraint the mesh already obeys, which takes energy out and never puts it in.
//!
//! Müller's method also interpolates each coarse correction to the finer particles between the
//! coarse ones, using level masses gathered from them. Measured here, that is not safe: it
//! moves particles along no constraint's gradient (the coarse constraint is evaluated on the
//! coarse particles alone), and cloths hung by two corners kept fluttering (12 × 12: the
//! kinetic energy of the last 2 s of 10 s at 66–100 % of the fall's peak; 100 × 100 hung by its
//! top row: 6.9 %), where sweeps settle (below 0.01 %). Without it (as here) every tested
//! cloth settles as the sweep does (10 × 10 to 100 × 100; two corners, one corner, the top row:
//! at most 0.025 % of the peak, as the sweep). On the 100 × 100 hung by two corners (falling /
//! hanging): swept 957 % / 515 %; with the interpolation 73 % / 31 %; without it 88 % / 47 %;
//! with the pass after the sweep too, 55 % / 31 %; with the smaller levels projected more often
//! ([`Level::passes`]), **29 % / 20 %** (`tests/hard_cases.rs`).
//!
//! The pass after the sweep (levels above the first): measured on cloths hung by two corners
//! (8 × 1, 10 s, each level projected once then), 100 × 100: 88 % / 47 % → 55 % / 31 %;
//! 50 × 50 (3 s): 42 % → 32 %; 40 × 40 in the plugin: 21 % → 19 %; but 21 × 21:
//! 7.1 % / 3.4 % → 10.9 % / 3.9 % and 12 × 12: 4.1 % / 1.5 % → 6.6 % / 2.2 % (small cloths,
//! which need no hierarchy, lose a little); hung
//! by the top row: about the same; every one settles. It costs 5–7 % of the step on the
//! 100 × 100 (the first level, left out, holds three quarters of the coarse sticks; with it
//! 55 % / 30 %; from the third level only 68 % / 36 %).
//!
//! Levels are built from the island's line cover (see [`lines`](super::lines)): a grid's lines
//! are its rows and columns. A particle is on the next level when it is pinned or sits at an
//! even position (or the end) of every line through it — on a grid, every other particle of
//! every other row and column, the corners included — and the next level's lines are the old
//! lines' coarse particles. Only lines of rigid (`compliance == 0`) `Equal`/`AtMost` sticks
//! take part. Levels stop at a few particles. On a 100 × 100 grid that is 6 500 coarse sticks
//! for 19 800 fine ones. All lines count their positions from the same side (see
//! `first_paths`), so that crossing lines agree on which particles are even.
//!
//! A hierarchy is dropped for the rest of the topology (the island is swept plainly) once one of
//! the sticks its lines hold is torn, cut, or made soft: coarse sticks across a tear would hold
//! the pieces together. Masses and rest lengths are re-read at the start of every step.
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

/// Every path runs the way this direction, about (3, 2, 1)/√14, points (see `first_paths`):
/// parallel lines then count from the same side. Its components are far from each other and from zero so that no
/// usual pose of a grid — axis-aligned, turned by 45° or 90°, tilted — puts a family of lines
/// across it. (Measured against choosing each line's main axis, which ties for lines at 45°:
/// of two-corner cloths from 8 × 8 to 64 × 64 turned by 45° or 135° about z, tilted 45°/45°,
/// 45° about x or 45°/30°, 65 of 145 got another lattice than unturned; a 40 × 40 turned and
/// tilted stretched 57 % instead of 27 % in 3 s.)
const ORIENTATION: DVec3 = DVec3::new(0.8017, 0.5345, 0.2673);

/// A level with at most this many particles is not coarsened further.
const COARSEST: usize = 4;

/// At most this many coarse levels.
const MAX_LEVELS: usize = 12;

/// Fraction of a coarse stick's excess length one pass takes back: all of it, as for a fine
/// stick. (With the interpolation to finer particles this crate no longer does, 1.0 fluttered
/// and 0.85 was used; without it, measured on the 100 × 100 cloth hung by two corners before
/// the pass after the sweep, 1.0 gives 88 % / 47 % and 0.85 gives 91 % / 47 %, both settling;
/// 1.3 and 1.6 give 96 % / 50 % and 135 % / 75 %, the latter fluttering.)
pub const COARSE_RELAXATION: f64 = 1.0;

/// Every island's hierarchy (see the [module docs](self)).
#[derive(Clone, Debug, Default)]
pub struct HierarchySet {
    /// The hierarchies, indexed by [`Island::hierarchy`](super::Island::hierarchy).
    pub list: Vec<Hierarchy>,
    /// Per-particle scratch of [`build`], kept across islands and rebuilds.
    marks: Marks,
}

/// One island's coarse levels, finest first.
#[derive(Clone, Debug, Default)]
pub struct Hierarchy {
    /// The coarse levels: `levels[0]` is one step coarser than the island itself.
    pub levels: Vec<Level>,
    /// One more than the largest particle slot of any level (the solve checks it against the
    /// positions once, then reads them unchecked).
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
    /// Its sticks: ends are indices into [`Level::particles`].
    pub sticks: Vec<CoarseStick>,
    /// Members of the sticks' spans: sticks of the next finer level (fine stick indices for
    /// the first level).
    spans: Vec<u32>,
    /// The order its sticks are projected in: line after line, but up to [`INTERLEAVE`]
    /// consecutive lines that share no particle take turns, stick by stick — the same result
    /// (they touch different particles) without each projection waiting for the last one's
    /// square root.
    order: Vec<u32>,
    /// How many times the level is projected per coarse pass: `√(first / sticks) / 2` rounded,
    /// at least once, where `first` is the first level's stick count (see `level_passes`).
    pub passes: u32,
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
    /// The ends' inverse masses (re-read at the start of every step).
    inverse_mass: [f64; 2],
    /// Rest length of the spanned path (`INFINITY`: inactive).
    pub max_length: f64,
    /// Range into the level's spans.
    span: Range<u32>,
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
    let mut paths = first_paths(set, lines, (particles, sticks));
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
    while hierarchy.levels.len() < MAX_LEVELS {
        let Some((level, next)) = coarsen(&paths, particles, &mut marks) else {
            break;
        };
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
    let first = hierarchy.levels[0].sticks.len();
    for level in &mut hierarchy.levels {
        level.passes = level_passes(first, level.sticks.len());
    }
    hierarchy.slots = hierarchy
        .levels
        .iter()
        .flat_map(|level| &level.particles)
        .map(|&p| p as usize + 1)
        .max()
        .unwrap_or(0);
    out.list.push(hierarchy);
    Some(out.list.len() as u32 - 1)
}

/// The island's lines cut into paths of rigid pulling sticks, all running the way
/// [`ORIENTATION`] points (by their ends). A level keeps the even positions of every line, so
/// crossing lines must count from consistent ends, or a row's coarse particles miss the
/// columns'; the lines are traced in stick order (colour order on a large mesh), which may run
/// one row from the left and the next from the right — measured on a 40 × 40 cloth in the
/// plugin, whose top row came out counted from the right and joined its odd columns to nothing
/// below.
fn first_paths(
    set: &LineSet,
    lines: &[Line],
    (particles, sticks): (&Particles, &Sticks),
) -> Vec<Path> {
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
    // Every path runs the way ORIENTATION points, then all are turned round if that puts more
    // pinned particles at even positions (a cloth hung from its top counts its columns from the
    // top).
    let pinned = |p: u32| particles.inverse_mass[p as usize] == 0.0;
    let mut pins_even = [0usize; 2];
    for path in &mut paths {
        let end = |p: Option<&u32>| p.map_or(DVec3::ZERO, |&p| particles.position[p as usize]);
        let along = end(path.particles.last()) - end(path.particles.first());
        if along.dot(ORIENTATION) < 0.0 {
            path.particles.reverse();
            path.sticks.reverse();
        }
        let last = path.particles.len() - 1;
        for (position, &p) in path.particles.iter().enumerate() {
            if pinned(p) {
                pins_even[0] += usize::from(position % 2 == 0);
                pins_even[1] += usize::from((last - position) % 2 == 0);
            }
        }
    }
    if pins_even[1] > pins_even[0] {
        for path in &mut paths {
            path.particles.reverse();
            path.sticks.reverse();
        }
    }
    paths
}

/// Per-particle marks while a level is built: the position of each particle on the level
/// (`u32::MAX`: not on it), whether an odd position of a line excludes it, and whether a line
/// of the level's paths passes through it.
#[derive(Clone, Debug, Default)]
struct Marks {
    coarse_index: Vec<u32>,
    odd: Vec<bool>,
    seen: Vec<bool>,
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
            self.seen.resize(n, false);
            self.run.resize(n, 0);
        }
    }

    fn reset(&mut self) {
        for &p in &self.touched {
            let p = p as usize;
            self.coarse_index[p] = u32::MAX;
            self.odd[p] = false;
            self.seen[p] = false;
        }
        self.touched.clear();
    }
}

/// One coarsening step: the level built on `paths` and the paths of the next one.
fn coarsen(paths: &[Path], particles: &Particles, marks: &mut Marks) -> Option<(Level, Vec<Path>)> {
    marks.reset();
    let mut order = Vec::new();
    for path in paths {
        let last = path.particles.len() - 1;
        for (position, &p) in path.particles.iter().enumerate() {
            let slot = p as usize;
            if !marks.seen[slot] {
                marks.seen[slot] = true;
                marks.touched.push(p);
                order.push(p);
            }
            marks.odd[slot] |= position % 2 == 1 && position != last;
        }
    }
    let mut level = Level::default();
    for &p in &order {
        let slot = p as usize;
        if particles.inverse_mass[slot] == 0.0 || !marks.odd[slot] {
            marks.coarse_index[slot] = level.particles.len() as u32;
            level.particles.push(p);
        }
    }
    if level.particles.len() == order.len() || level.particles.len() < 2 {
        return None;
    }
    let next = coarse_sticks(paths, marks, &mut level);
    level.order = solve_order(&next, marks);
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

impl HierarchySet {
    /// Re-reads masses and rest lengths (start of a step); drops the hierarchies whose fine
    /// sticks are no longer all whole and rigid.
    pub(crate) fn refresh(&mut self, particles: &Particles, sticks: &Sticks) {
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
            refresh_masses(&mut hierarchy.levels, particles);
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

/// Every coarse stick's inverse masses: its ends' own.
fn refresh_masses(levels: &mut [Level], particles: &Particles) {
    for level in levels {
        for stick in &mut level.sticks {
            stick.inverse_mass = stick.slots.map(|p| particles.inverse_mass[p as usize]);
        }
    }
}

/// The first level of the pass after each sweep (see the [module docs](self)): the levels above
/// the first, whose sticks are a quarter of all coarse sticks on a grid.
pub const AFTER_SWEEP_FROM_LEVEL: usize = 1;

impl Hierarchy {
    /// One pass over the coarse levels from `first` up, coarsest first (see the
    /// [module docs](self)).
    ///
    /// # Safety
    /// No other task accesses the particles of this hierarchy's island while this runs.
    pub(crate) unsafe fn solve(&self, position: &SharedSlice<DVec3>, first: usize) {
        // One check per pass instead of one per access: every slot below is under `slots` (as
        // `build` makes them; the levels cannot be changed from outside the crate).
        assert!(
            self.slots <= position.len(),
            "a hierarchy's particles are out of bounds"
        );
        for level in self.levels.iter().skip(first).rev() {
            for _ in 0..level.passes {
                // SAFETY: slots in bounds (checked above); the island's particles are this
                // task's (caller).
                unsafe { level.project(position) };
            }
        }
    }
}

/// How many times a level of `sticks` coarse sticks is projected per coarse pass, when the
/// first level has `first`: `√(first / sticks) / 2`, rounded, at least once. A coarse level is a
/// mesh of sticks too: one Gauss–Seidel projection carries its corrections a stick or two, and
/// its load has to cross it whole — the more often, the fewer its sticks. On a grid, each level
/// has about a quarter of the sticks of the one below, so the count about doubles per level
/// from the third (100 × 100: 1, 1, 2, 3, 6, 10 and 18 passes for levels of 5100, 1300, 364,
/// 112, 40, 12 and 4 sticks: 7896 projections of coarse sticks per pass instead of 6932). A
/// level that did not shrink (lines of one stick are kept whole on every level) is not
/// projected more often than the one below: no level costs more than a projection of the first,
/// and a repeated one at most a quarter of it.
///
/// Measured on cloths hung by two corners (8 × 1, 10 s, damping 1/s, falling / hanging max
/// strain, solver core alone): 100 × 100 55 % / 31 % → 29 % / 20 %, its step 1074 → 1127 µs
/// (+5 %; the sweep's 767 µs: 1.40× → 1.47×; `examples/bench`, three runs each); 50 × 50
/// 22 % / 14 % → 19 % / 12 %; 12 × 12 and 21 × 21 unchanged (6 % and 11 % falling); all settle
/// as before (kinetic energy of the last 2 s at most 4·10⁻⁵ of the fall's peak). Measured too:
/// doubling from the first level on, 23 % / 17 % at about +18 %; four passes of the levels from
/// the fourth, 31 % / 21 %; each repeat of a level followed by one of the level below, 21 % /
/// 13 % at about +40 %.
fn level_passes(first: usize, sticks: usize) -> u32 {
    let ratio = first as f64 / sticks.max(1) as f64;
    (ratio.sqrt() / 2.0).round().max(1.0) as u32
}

impl Level {
    /// Projects the level's coarse sticks once, in [`Level::order`].
    ///
    /// # Safety
    /// The sticks' slots are under `position.len()`, and no other task accesses these
    /// particles.
    #[inline(always)]
    unsafe fn project(&self, position: &SharedSlice<DVec3>) {
        for &k in &self.order {
            let stick = &self.sticks[k as usize];
            let [wa, wb] = stick.inverse_mass;
            let [pa, pb] = stick.slots.map(|s| s as usize);
            // SAFETY: in bounds, this task's (caller).
            let (xa, xb) = unsafe { (position.get_unchecked(pa), position.get_unchecked(pb)) };
            let d = xb - xa;
            // (A slack stick — most of them in a hanging cloth — is passed over without a square
            // root. NaN lengths and masses are skipped: a NaN is never spread from here.)
            let max = stick.max_length;
            let stretched = d.length_squared() > max * max;
            if !stretched {
                continue;
            }
            let length = d.length();
            let movable = (wa + wb).partial_cmp(&0.0) == Some(std::cmp::Ordering::Greater);
            if length.is_nan() || length <= max || !movable {
                continue;
            }
            let excess = COARSE_RELAXATION * (length - max);
            let correction = d * (excess / (length * (wa + wb)));
            // SAFETY: as above.
            unsafe {
                position.set_unchecked(pa, xa + correction * wa);
                position.set_unchecked(pb, xb - correction * wb);
            }
        }
    }
}
