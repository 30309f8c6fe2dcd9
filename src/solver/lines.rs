//! Lines: an island's sticks covered by paths, for the direct solve of [`direct`](super::direct).
//!
//! A chain of sticks — a rope, a pendulum, one row of a cloth — is a tridiagonal system that a
//! direct solve satisfies exactly in one pass, whatever its length and mass ratio. An island is
//! covered by such paths the way strand solvers treat hair (Han & Harada 2013, TressFX): at every
//! particle, pairs of its sticks that continue each other are joined — both sticks of a particle
//! that has two, and at a particle with more the most opposite pairs first, while they are within
//! 60° of straight — and every chain of joined sticks becomes a [`Line`]. A rope is one line; a grid's rows and columns become lines (and its shear
//! diagonals, diagonal lines); a tree's branches become lines that meet at forks. A line that
//! would close on itself (a ring) is cut open: its last stick goes into the island's *loose*
//! sticks, solved by a Gauss–Seidel sweep after the lines.
//!
//! Lines are then put into groups of lines that share no particle (greedy, in order): a grid's
//! rows form one group, its columns another. Solving group after group is block Gauss–Seidel over
//! lines; the lines of one group are independent.
//!
//! ```
//! use bevy_verlet_physics::solver::{Method, Solver, StickKind};
//! use glam::DVec3;
//! // A three-link rope: one line of three sticks.
//! let mut solver = Solver::default();
//! for i in 0..4 {
//!     solver.add_particle(DVec3::X * i as f64, 1.0);
//! }
//! for i in 0..3 {
//!     solver.sticks.push([i, i + 1], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
//! }
//! solver.organize();
//! let island = &solver.islands.list[0];
//! assert_eq!(island.method, Method::Lines);
//! assert_eq!(solver.islands.lines().lines.len(), 1);
//! assert_eq!(solver.islands.lines().sticks.len(), 3);
//! ```

use super::{Particles, StickKind, Sticks};
use glam::DVec3;
use std::ops::Range;

/// How an island's constraints are solved.
///
/// ```
/// use bevy_verlet_physics::solver::Method;
/// assert_eq!(Method::default(), Method::Auto);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Method {
    /// Chosen per island by [`Solver::organize`](super::Solver::organize): chains and trees (no
    /// loop, no angle constraint) → [`Method::Lines`] (a tree with a fork is solved whole, split
    /// at its pins where it has three or more, see [`tree`](super::tree)); everything else
    /// (rings, meshes, ragdolls with posture links, braced structures) → [`Method::Sweep`].
    #[default]
    Auto,
    /// Gauss–Seidel sweeps over single sticks (in colour order on large meshes).
    Sweep,
    /// Sticks covered by lines, each line solved directly (see [`direct`](super::direct));
    /// sticks no line holds are swept after the lines.
    Lines,
    /// Sweeps between passes over coarse levels of long-range sticks (a hierarchy, see
    /// [`hierarchy`](super::hierarchy)) that carry a mesh's load to its pins at once: for
    /// cloth hung by a few pins. Islands without a mesh to coarsen (chains, single sticks) are
    /// swept plainly. [`Method::Auto`] picks it for large meshes without tethers or tearable
    /// sticks hung from a few pins (see [`HIERARCHY_MAX_PINS`](super::islands::HIERARCHY_MAX_PINS)).
    Hierarchy,
}

/// One path of sticks: `particles[k]` and `particles[k + 1]` are the ends of `sticks[k]`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Line {
    /// Range into [`LineSet::particles`] (one more than `sticks`).
    pub particles: Range<u32>,
    /// Range into [`LineSet::sticks`].
    pub sticks: Range<u32>,
}

/// Every island's lines, in island order, grouped (see the [module docs](self)).
#[derive(Clone, Debug, Default)]
pub struct LineSet {
    /// Every line; an island's lines are contiguous and sorted by group.
    pub lines: Vec<Line>,
    /// Groups of lines that share no particle: ranges into [`LineSet::lines`].
    pub groups: Vec<Range<u32>>,
    /// Particle slots of the lines, line after line.
    pub particles: Vec<u32>,
    /// Stick indices of the lines, line after line.
    pub sticks: Vec<u32>,
    /// Sticks of line islands that no line holds (ring closers), island after island.
    pub loose: Vec<u32>,
    /// The trees of line islands with forks (solved whole, see [`tree`](super::tree)).
    pub trees: super::TreeSet,
}

impl LineSet {
    /// Removes every line, keeping the allocations.
    pub fn clear(&mut self) {
        self.lines.clear();
        self.groups.clear();
        self.particles.clear();
        self.sticks.clear();
        self.loose.clear();
        self.trees.clear();
    }
}

/// Where one island's lines went in a [`LineSet`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct IslandLines {
    /// Ranges into [`LineSet::groups`].
    pub(crate) groups: Range<u32>,
    /// Range into [`LineSet::loose`].
    pub(crate) loose: Range<u32>,
}

/// Cosine below which two sticks at a particle do not continue each other (60° off straight).
const STRAIGHT_ENOUGH: f64 = -0.5;

/// `true` when a connected island with these sticks has no loop (`sticks < particles`): a
/// chain or a tree. Such islands are solved by lines under [`Method::Auto`]. (A ring — an
/// unbraced square, a tire's rim — has a loop: it is swept, as a mechanism should be.)
pub(crate) fn is_chain_or_tree(sticks: usize, particles: usize) -> bool {
    sticks > 0 && sticks < particles
}

/// `true` when a line may follow every bend of the island: a chain, a tree or a ring (no
/// particle with more than two sticks), as opposed to a mesh.
fn bends_freely(sticks: usize, particles: usize, max_degree: usize) -> bool {
    is_chain_or_tree(sticks, particles) || (sticks > 0 && max_degree <= 2)
}

/// Scratch for [`cover`], kept between rebuilds.
#[derive(Clone, Debug, Default)]
pub(crate) struct CoverScratch {
    /// For every stick: the stick that continues it at end 0 and at end 1 (`u32::MAX`: none).
    next: Vec<[u32; 2]>,
    /// Sticks already placed in a line.
    used: Vec<bool>,
    /// The groups (bits 0–63) each particle is in.
    particle_groups: Vec<u64>,
    /// Lines of the island being covered, before grouping.
    pending: Vec<Line>,
    /// Incident sticks of one particle.
    incident: Vec<(u32, DVec3)>,
    /// Per particle: the number (plus one) of the line last traced through it.
    visited: Vec<u32>,
    /// Lines traced so far (the stamp of [`CoverScratch::visited`]).
    traced: u32,
}

/// Covers the sticks `island_sticks` (indices into `sticks`, none torn) of an island whose
/// particles are `island_particles` with lines, appending them to `set`.
/// `incidence(p)` lists the sticks at particle `p` (see [`Incidence`]). In a chain or tree a
/// line follows every bend; in a mesh only straight continuations.
pub(crate) fn cover(
    set: &mut LineSet,
    scratch: &mut CoverScratch,
    particles: &Particles,
    sticks: &Sticks,
    island_sticks: Range<u32>,
    island_particles: Range<u32>,
    incidence: &Incidence,
) -> IslandLines {
    let m = sticks.len();
    scratch.visited.resize(particles.len(), 0);
    scratch.next.resize(m, [u32::MAX; 2]);
    scratch.used.resize(m, false);
    for i in island_sticks.clone() {
        scratch.next[i as usize] = [u32::MAX; 2];
        scratch.used[i as usize] = false;
    }
    let (count, particles_in) = (island_sticks.len(), island_particles.len());
    let max_degree = island_particles.clone().map(|p| incidence.degree(p)).max();
    let bend = bends_freely(count, particles_in, max_degree.unwrap_or(0));
    for p in island_particles.clone() {
        pair_straight_sticks(scratch, (particles, sticks), incidence, p, bend);
    }
    let loose_start = set.loose.len() as u32;
    scratch.pending.clear();
    // Start lines at sticks with a free end first, then what is left (rings).
    for pass in 0..2 {
        for i in island_sticks.clone() {
            let starts_here = scratch.next[i as usize].contains(&u32::MAX);
            if scratch.used[i as usize] || (pass == 0 && !starts_here) {
                continue;
            }
            let line = trace(set, scratch, sticks, i);
            scratch.pending.push(line);
        }
    }
    let groups = group(set, scratch, island_particles);
    IslandLines {
        groups,
        loose: loose_start..set.loose.len() as u32,
    }
}

/// Joins, at particle `p`, the pairs of its sticks that continue each other most straight.
fn pair_straight_sticks(
    scratch: &mut CoverScratch,
    (particles, sticks): (&Particles, &Sticks),
    incidence: &Incidence,
    p: u32,
    bend: bool,
) {
    let at = particles.position[p as usize];
    scratch.incident.clear();
    for &i in incidence.of(p) {
        let [a, b] = sticks.ends[i as usize];
        let other = if a == p { b } else { a };
        let direction = (particles.position[other as usize] - at).normalize_or_zero();
        scratch.incident.push((i, direction));
    }
    // In a chain or tree, two sticks at a particle always continue each other (a chain stays
    // one line however sharply it bends); elsewhere (a mesh's corner) and among more sticks,
    // only pairs close to straight do.
    let threshold = if bend && scratch.incident.len() == 2 {
        f64::INFINITY
    } else {
        STRAIGHT_ENOUGH
    };
    loop {
        let mut best = (threshold, usize::MAX, usize::MAX);
        let incident = &scratch.incident;
        for (j, &(si, di)) in incident.iter().enumerate() {
            for (k, &(sk, dk)) in incident.iter().enumerate().skip(j + 1) {
                let free = |s: u32| scratch.next[s as usize][end_at(sticks, s, p)] == u32::MAX;
                let cosine = di.dot(dk);
                if cosine < best.0 && free(si) && free(sk) {
                    best = (cosine, j, k);
                }
            }
        }
        if best.1 == usize::MAX {
            return;
        }
        let (si, sk) = (scratch.incident[best.1].0, scratch.incident[best.2].0);
        scratch.next[si as usize][end_at(sticks, si, p)] = sk;
        scratch.next[sk as usize][end_at(sticks, sk, p)] = si;
    }
}

/// Which end (0 or 1) of stick `s` is particle `p`.
fn end_at(sticks: &Sticks, s: u32, p: u32) -> usize {
    (sticks.ends[s as usize][0] != p) as usize
}

/// Follows the joined sticks from stick `first` (from its free end if it has one) and appends
/// the line's particles and sticks to `set`. A ring is cut: its last stick goes to the loose,
/// and a line that comes back to one of its own particles stops before it (a line never holds a
/// particle twice; the stick that would close the loop is loose).
fn trace(set: &mut LineSet, scratch: &mut CoverScratch, sticks: &Sticks, first: u32) -> Line {
    scratch.traced = scratch.traced.wrapping_add(1).max(1);
    let stamp = scratch.traced;
    let particles_start = set.particles.len() as u32;
    let sticks_start = set.sticks.len() as u32;
    // Walk away from the free end (end 0 if both or neither are free).
    let free_end = if scratch.next[first as usize][0] == u32::MAX {
        0
    } else if scratch.next[first as usize][1] == u32::MAX {
        1
    } else {
        0
    };
    let mut at = sticks.ends[first as usize][free_end];
    set.particles.push(at);
    scratch.visited[at as usize] = stamp;
    let mut stick = first;
    loop {
        scratch.used[stick as usize] = true;
        let [a, b] = sticks.ends[stick as usize];
        let far = if a == at { b } else { a };
        if scratch.visited[far as usize] == stamp {
            // Back on itself (a ring): the closing stick is swept, not part of the line.
            set.loose.push(stick);
            break;
        }
        scratch.visited[far as usize] = stamp;
        set.sticks.push(stick);
        set.particles.push(far);
        at = far;
        let next = scratch.next[stick as usize][end_at(sticks, stick, at)];
        if next == u32::MAX || scratch.used[next as usize] {
            break;
        }
        stick = next;
    }
    Line {
        particles: particles_start..set.particles.len() as u32,
        sticks: sticks_start..set.sticks.len() as u32,
    }
}

/// Sorts the pending lines into groups that share no particle and appends them to `set`: each
/// line goes into the lowest group none of its particles is in yet (a bitmask per particle, so
/// a grid's rows form one group and its columns another whatever order they were traced in).
/// Past 64 groups every further line gets a group of its own.
fn group(
    set: &mut LineSet,
    scratch: &mut CoverScratch,
    island_particles: Range<u32>,
) -> Range<u32> {
    let groups_start = set.groups.len() as u32;
    let end = island_particles.end as usize;
    if scratch.particle_groups.len() < end {
        scratch.particle_groups.resize(end, 0);
    }
    for p in island_particles {
        scratch.particle_groups[p as usize] = 0;
    }
    let mut group_of = Vec::with_capacity(scratch.pending.len());
    let mut groups = 0;
    for line in &scratch.pending {
        let members = &set.particles[range(&line.particles)];
        let taken = members
            .iter()
            .fold(0u64, |mask, &p| mask | scratch.particle_groups[p as usize]);
        let g = if taken == u64::MAX {
            groups.max(64)
        } else {
            (!taken).trailing_zeros()
        };
        if g < 64 {
            for &p in members {
                scratch.particle_groups[p as usize] |= 1 << g;
            }
        }
        group_of.push(g);
        groups = groups.max(g + 1);
    }
    for g in 0..groups {
        let first = set.lines.len() as u32;
        for (line, _) in scratch
            .pending
            .iter()
            .zip(&group_of)
            .filter(|(_, k)| **k == g)
        {
            set.lines.push(line.clone());
        }
        if set.lines.len() as u32 > first {
            set.groups.push(first..set.lines.len() as u32);
        }
    }
    groups_start..set.groups.len() as u32
}

/// The scratch [`Solver::organize`](super::Solver::organize) keeps for covering islands.
#[derive(Clone, Debug, Default)]
pub(crate) struct LineBuilder {
    pub(crate) incidence: Incidence,
    pub(crate) cover: CoverScratch,
    /// Scratch of [`tree::build`](super::tree::build).
    pub(crate) queue: Vec<u32>,
    pub(crate) seen: Vec<bool>,
    /// Lines of the island whose hierarchy is being built (see [`hierarchy`](super::hierarchy)).
    pub(crate) hierarchy_lines: LineSet,
}

/// The sticks at every particle (compressed rows), for [`cover`].
#[derive(Clone, Debug, Default)]
pub(crate) struct Incidence {
    start: Vec<u32>,
    sticks: Vec<u32>,
}

impl Incidence {
    /// Builds the incidence of the non-torn sticks over `particles` particles.
    pub(crate) fn build(&mut self, sticks: &Sticks, particles: usize) {
        self.start.clear();
        self.start.resize(particles + 1, 0);
        let live = |i: usize| sticks.kind[i] != StickKind::Torn;
        for (i, &[a, b]) in sticks.ends.iter().enumerate() {
            if live(i) {
                self.start[a as usize + 1] += 1;
                self.start[b as usize + 1] += 1;
            }
        }
        for p in 0..particles {
            self.start[p + 1] += self.start[p];
        }
        self.sticks.clear();
        self.sticks.resize(self.start[particles] as usize, 0);
        let mut fill = self.start.clone();
        for (i, &[a, b]) in sticks.ends.iter().enumerate() {
            if live(i) {
                for p in [a, b] {
                    self.sticks[fill[p as usize] as usize] = i as u32;
                    fill[p as usize] += 1;
                }
            }
        }
    }

    /// The sticks at particle `p`.
    pub(crate) fn of(&self, p: u32) -> &[u32] {
        &self.sticks[self.start[p as usize] as usize..self.start[p as usize + 1] as usize]
    }

    /// How many sticks meet at particle `p`.
    pub(crate) fn degree(&self, p: u32) -> usize {
        self.of(p).len()
    }
}

fn range(r: &Range<u32>) -> std::ops::Range<usize> {
    r.start as usize..r.end as usize
}
