//! Islands: groups of particles connected by sticks or angle constraints.
//!
//! Islands share no particle, so they can be stepped independently: in parallel, with their own
//! substep and iteration counts ([`IslandSettings`]), or not at all while they sleep (see
//! [`Sleep`]). [`Solver::organize`] finds them (union–find), then *reorders* the arrays so that
//! every island is a contiguous range of particles and of sticks, and the sticks of an island are
//! sorted by colour (see [`colouring`](super::colouring)) and, within a colour, by particle index
//! (so a sweep walks memory forwards). The reordering is returned as a [`Reorder`] so callers can
//! remap their own indices; the Bevy layer does this on every topology change.
//!
//! # Soundness
//!
//! The parallel step trusts the layout: islands share no particle, and the sticks of a batch
//! marked [`Batch::independent`] share none. So no safe code can change it or hand the solver a
//! stale one: the lists are [`ReadOnly`] outside the crate (sleep states change through
//! [`Solver::set_asleep`] and [`Solver::wake`]); the particle indices the layout is built from
//! ([`Sticks::ends`](super::Sticks::ends), [`Angles::particles`](super::Angles::particles),
//! [`Tethers::particle`](super::Tethers::particle) and `anchor`) are read-only fields changed
//! only by methods that take a fresh, never-reused stamp; and [`Islands`] remember the stamps
//! and sizes they were built for. Every phase of the step checks them
//! ([`Solver::is_organized`]) and, on a mismatch — an edit after [`Solver::organize`], or the
//! islands of another solver assigned to this one — treats everything as one island solved on
//! one thread, which is always safe (and the serial result). `tests/soundness.rs` checks this.

use super::colouring::{Batch, MAX_COLOURS, colour_sticks};
use super::line_substeps::line_substep_count;
use super::lines::{LineSet, Method, cover, is_chain_or_tree};
use super::{Solver, StickKind};
use std::ops::Range;

/// Substeps and iterations for one island, overriding the step's (e.g. a ragdoll needs fewer
/// than a stiff cloth).
///
/// ```
/// use bevy_verlet_physics::solver::IslandSettings;
/// let light = IslandSettings { substeps: 2, iterations: 1 };
/// assert_eq!(light.max(IslandSettings { substeps: 4, iterations: 1 }).substeps, 4);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IslandSettings {
    /// Substeps per fixed step (≥ 1).
    pub substeps: u32,
    /// Relaxation iterations per substep (≥ 1).
    pub iterations: u32,
}

impl IslandSettings {
    /// The larger of each count (two overrides on one island: the more accurate wins).
    pub fn max(self, other: Self) -> Self {
        Self {
            substeps: self.substeps.max(other.substeps),
            iterations: self.iterations.max(other.iterations),
        }
    }
}

/// When an island falls asleep: every movable particle slower than `speed` for `time` seconds.
///
/// ```
/// use bevy_verlet_physics::solver::Sleep;
/// let sleep = Sleep::for_gravity(9.81);
/// assert!(sleep.speed > 0.0 && sleep.time > 0.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sleep {
    /// Speed threshold (units per second).
    pub speed: f64,
    /// How long every particle must stay below it (seconds).
    pub time: f64,
}

impl Sleep {
    /// A threshold scaled to gravity `g` (units/s²): below `0.001·g` per second for 1 s, i.e.
    /// 1 cm/s under 9.81 m/s² and 1 px/s under 980 px/s².
    pub fn for_gravity(g: f64) -> Self {
        Self {
            speed: 0.001 * g.abs().max(1e-9),
            time: 1.0,
        }
    }
}

/// One island: contiguous ranges into the solver's arrays, its settings and its sleep state.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Island {
    /// Particle slots.
    pub particles: Range<u32>,
    /// Sticks (sorted by colour).
    pub sticks: Range<u32>,
    /// Its colour batches (indices into [`Islands::batches`]).
    pub batches: Range<u32>,
    /// Angle constraints.
    pub angles: Range<u32>,
    /// Pins.
    pub pins: Range<u32>,
    /// Tethers.
    pub tethers: Range<u32>,
    /// Overrides of the step's substeps and iterations (what it takes is
    /// [`Island::own_settings`]: these — attached to a body, their substeps raised to a count
    /// that divides the bodies', [`substeps_aligned_with`] — else
    /// [`Island::steps_with_bodies`], else `line_substeps` where that applies).
    pub settings: Option<IslandSettings>,
    /// How its sticks are solved (resolved by [`Solver::organize`]: never [`Method::Auto`]
    /// there; an island left at `Auto` is swept).
    pub method: Method,
    /// Its groups of lines (ranges into [`LineSet::groups`]) when solved by lines.
    pub line_groups: Range<u32>,
    /// Its sticks that no line holds (range into [`LineSet::loose`]), swept after the lines.
    pub loose: Range<u32>,
    /// Its trees (a range into [`TreeSet::trees`](super::TreeSet::trees)) when it is solved by
    /// lines and is a tree with a fork: one, or one per part where three or more immovable
    /// particles split it ([`tree`](super::tree)'s `split`); then it has no lines and is solved
    /// whole. Empty otherwise (and where a part hangs on more than
    /// [`MAX_CLOSINGS`](super::MAX_CLOSINGS) + 1 immovable particles).
    pub trees: Range<u32>,
    /// Its hierarchy (index into [`HierarchySet::list`](super::HierarchySet::list)) when it is
    /// solved by [`Method::Hierarchy`] and has a mesh to coarsen (see
    /// [`hierarchy`](super::hierarchy)).
    pub hierarchy: Option<u32>,
    /// `true` while the island sleeps (it is neither integrated nor solved).
    pub asleep: bool,
    /// `true` when its sweeps run forward and back in the current step (set for awake islands by
    /// [`Solver::begin_step`](super::Solver::begin_step): solved by sweeps, its masses differ by
    /// more than [`StepConfig::symmetric_mass_ratio`](super::StepConfig::symmetric_mass_ratio);
    /// see [`symmetric`](super::symmetric)). Not meaningful while the island sleeps.
    pub symmetric: bool,
    /// How long every particle has been below the sleep speed, in seconds.
    pub calm_time: f64,
    /// The substep length (s) its particles' Verlet state `x − x*` refers to (its last
    /// substep), `0` for [`Solver::verlet_substep`](super::Solver::verlet_substep) (a new
    /// island); see [`resubstep`](super::resubstep).
    pub state_substep: f64,
    /// Set by [`Solver::begin_step`](super::Solver::begin_step) for an awake island that could
    /// take [`StepConfig::line_substeps`](super::StepConfig::line_substeps): it is hit hard (a
    /// stick of it would stretch beyond [`HIT_ABOVE`](super::line_substeps::HIT_ABOVE) in one
    /// such substep, or have its ends cross), holds a spring too stiff for them, or has a
    /// particle attached to another engine's body ([`Solver::attached`](super::Solver::attached)),
    /// so it takes the step's substeps in this step — or, attached, the bodies' count where that
    /// is more ([`Island::steps_with_bodies`]; see [`line_substeps`](super::line_substeps)).
    pub keeps_step_substeps: bool,
    /// Set by [`Solver::begin_step`](super::Solver::begin_step) for an awake island that holds
    /// a particle attached to another engine's body ([`Solver::attached`](super::Solver::attached)):
    /// the step's global count of substeps (its busiest island's, which the bodies take) — for
    /// an island without settings of its own where that count exceeds
    /// [`StepConfig::substeps`](super::StepConfig::substeps) (an island given more by an
    /// [`IslandSettings`] override, or `line_substeps` above `substeps`), so that it steps with
    /// the bodies; for one with settings always, which then take the fewest substeps at least
    /// theirs that divide it ([`substeps_aligned_with`]), so that its substeps end with the
    /// bodies'. `None` otherwise. [`Island::own_settings`] takes it after [`Island::settings`]
    /// and before `line_substeps`.
    pub steps_with_bodies: Option<u32>,
}

impl Island {
    /// The step's settings with this island's own applied ([`Island::own_settings`]: its
    /// overrides, or the bodies' count, or `line_substeps`; substeps and iterations ≥ 1).
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{Island, IslandSettings, StepConfig};
    /// let island = Island {
    ///     settings: Some(IslandSettings { substeps: 2, iterations: 3 }),
    ///     ..Island::default()
    /// };
    /// assert_eq!(island.config(&StepConfig::default()).substeps, 2);
    /// ```
    pub fn config(&self, step: &super::StepConfig) -> super::StepConfig {
        configured(step, self.own_settings(step))
    }

    /// [`Island::state_substep`], or `unset` (the substep of a state not yet set per island)
    /// where it is 0.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Island;
    /// assert_eq!(Island::default().state_substep_or(0.25), 0.25);
    /// let island = Island { state_substep: 0.5, ..Island::default() };
    /// assert_eq!(island.state_substep_or(0.25), 0.5);
    /// ```
    pub fn state_substep_or(&self, unset: f64) -> f64 {
        match self.state_substep {
            from if from > 0.0 => from,
            _ => unset,
        }
    }

    /// Its substeps and iterations where they are not the step's: its [`Island::settings`] (where
    /// [`Island::steps_with_bodies`] is set, their substeps raised to the fewest that divide it:
    /// [`substeps_aligned_with`]), else [`Island::steps_with_bodies`] (the bodies' count), else
    /// [`StepConfig::line_substeps`](super::StepConfig::line_substeps) (at least 1, more for a
    /// step longer than 1/64 s: [`line_substep_count`]) if it
    /// [`Island::takes_line_substeps`] and does not [`Island::keeps_step_substeps`] in this step.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{Island, Method, StepConfig};
    /// let step = StepConfig { line_substeps: Some(2), ..StepConfig::default() };
    /// // Two particles, one stick: a pendulum.
    /// let rope = Island { method: Method::Lines, particles: 0..2, sticks: 0..1, ..Island::default() };
    /// assert_eq!(rope.own_settings(&step).map(|s| s.substeps), Some(2));
    /// let cloth = Island { method: Method::Sweep, ..rope.clone() };
    /// assert_eq!(cloth.own_settings(&step), None);
    /// ```
    pub fn own_settings(&self, step: &super::StepConfig) -> Option<IslandSettings> {
        self.own_settings_for(step, line_substep_count(step))
    }

    /// [`Island::own_settings`] with the step's [`line_substep_count`] given (computed once
    /// per step rather than once per island).
    pub(crate) fn own_settings_for(
        &self,
        step: &super::StepConfig,
        line_count: Option<u32>,
    ) -> Option<IslandSettings> {
        let with_bodies = self.steps_with_bodies.map(|substeps| IslandSettings {
            substeps,
            iterations: step.iterations,
        });
        let settings = self.settings.map(|own| match self.steps_with_bodies {
            Some(bodies) => IslandSettings {
                substeps: substeps_aligned_with(own.substeps, bodies),
                ..own
            },
            None => own,
        });
        settings.or(with_bodies).or_else(|| match line_count {
            Some(substeps) if self.takes_line_substeps() && !self.keeps_step_substeps => {
                Some(IslandSettings {
                    substeps,
                    iterations: step.iterations,
                })
            }
            _ => None,
        })
    }

    /// Whether [`StepConfig::line_substeps`](super::StepConfig::line_substeps) applies to it: it
    /// is solved by lines and shaped as a tree (one stick fewer than particles), with no angle
    /// constraint and no tether (both relaxed iteratively), so that its solve is exact whatever
    /// the substep — chains, ropes, pendulums and trees under [`Method::Auto`]; not a cloth or
    /// a ragdoll put on lines.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{Island, Method};
    /// let chain = Island { method: Method::Lines, particles: 0..11, sticks: 0..10, ..Island::default() };
    /// assert!(chain.takes_line_substeps());
    /// let cloth = Island { sticks: 0..180, particles: 0..100, ..chain.clone() };
    /// assert!(!cloth.takes_line_substeps());
    /// ```
    pub fn takes_line_substeps(&self) -> bool {
        let count = |r: &Range<u32>| r.end.saturating_sub(r.start) as usize;
        self.method == Method::Lines
            && self.angles.is_empty()
            && self.tethers.is_empty()
            && is_chain_or_tree(count(&self.sticks), count(&self.particles))
    }
}

/// The fewest substeps, at least `substeps` (and 1), that divide `bodies` — the count the bodies
/// take — so that every substep of an island attached to a body ends where one of the body's
/// does: the coupling hands momentum over substep by substep (see
/// [`attachments`](super::attachments)). An island given 6 of the bodies' 8 would end its
/// substeps up to two thirds of a body substep off theirs (a 0.1 kg knot on a spinning box lost
/// 45 % to 159 % of the momentum at 5 to 7 of 8, `tests/avian2d.rs`). `substeps` where `bodies`
/// is not more.
///
/// ```
/// use bevy_verlet_physics::solver::substeps_aligned_with;
/// assert_eq!(substeps_aligned_with(2, 8), 2);
/// assert_eq!(substeps_aligned_with(3, 8), 4);
/// assert_eq!(substeps_aligned_with(6, 8), 8);
/// assert_eq!(substeps_aligned_with(5, 12), 6);
/// assert_eq!(substeps_aligned_with(0, 8), 1);
/// assert_eq!(substeps_aligned_with(16, 8), 16);
/// ```
pub fn substeps_aligned_with(substeps: u32, bodies: u32) -> u32 {
    let substeps = substeps.max(1);
    if substeps >= bodies {
        return substeps;
    }
    (substeps..=bodies)
        .find(|&n| bodies.is_multiple_of(n))
        .unwrap_or(bodies)
}

/// `step` with `settings` applied, substeps and iterations at least 1 (see [`Island::config`]).
pub(crate) fn configured(
    step: &super::StepConfig,
    settings: Option<IslandSettings>,
) -> super::StepConfig {
    let mut config = *step;
    if let Some(settings) = settings {
        config.substeps = settings.substeps;
        config.iterations = settings.iterations;
    }
    config.substeps = config.substeps.max(1);
    config.iterations = config.iterations.max(1);
    config
}

/// The islands of the current topology.
///
/// Only the solver writes them ([`Solver::organize`], and the step's sleep states): the
/// parallel step trusts that islands share no particle and that the sticks of a batch marked
/// [`Batch::independent`] share none, so the lists are [`ReadOnly`] outside the crate, and the
/// solver uses them only while they match the topology they were built for (see
/// [`Solver::is_organized`]).
///
/// ```
/// use bevy_verlet_physics::solver::Solver;
/// use glam::DVec3;
/// let mut solver = Solver::default();
/// solver.add_particle(DVec3::ZERO, 1.0);
/// solver.organize();
/// assert_eq!(solver.islands.list.len(), 1);
/// assert_eq!(solver.islands.lines().lines.len(), 0);
/// ```
#[derive(Clone, Debug, Default)]
pub struct Islands {
    /// Every island, in order of their first particle.
    pub list: ReadOnly<Island>,
    /// Every colour batch, island after island.
    pub batches: ReadOnly<Batch>,
    /// The lines of the islands solved by [`Method::Lines`] (read with [`Islands::lines`]).
    pub(crate) lines: LineSet,
    /// The hierarchies of the islands solved by [`Method::Hierarchy`].
    pub(crate) hierarchies: super::HierarchySet,
    /// Sizes `[particles, sticks, angles, pins]` the islands were built for; on a mismatch the
    /// solver treats everything as one island in array order.
    pub(crate) signature: [usize; 4],
    /// Stamps of the sticks', angle constraints' and tethers' particle indices the islands
    /// were built for (see [`next_stamp`]); checked like the signature.
    pub(crate) stamps: [u64; 3],
    /// A fresh stamp per build of the lists, also kept in [`Islands::list`] and
    /// [`Islands::batches`]: the public fields can be reassigned (a list saved from an earlier
    /// build put back), which must not pass for organized — the solver trusts the lists' ranges
    /// and their batches' independence to run jobs in parallel, and their hierarchy indices.
    pub(crate) build: u64,
}

impl Islands {
    /// Marks the lists as built together, now.
    fn seal(&mut self) {
        let build = next_stamp();
        self.build = build;
        self.list.1 = build;
        self.batches.1 = build;
    }

    /// `true` when the lists are the ones built with the rest (see [`Islands::build`]).
    fn sealed(&self) -> bool {
        self.build != 0 && self.list.1 == self.build && self.batches.1 == self.build
    }
}

/// A list that the solver builds and everyone else only reads: it dereferences to a slice. It
/// carries the stamp of the build it came from (see [`Solver::is_organized`]).
///
/// ```
/// use bevy_verlet_physics::solver::Solver;
/// use glam::DVec3;
/// let mut solver = Solver::default();
/// solver.add_particle(DVec3::ZERO, 1.0);
/// solver.organize();
/// let list = &solver.islands.list;
/// assert_eq!(list.len(), 1);
/// assert_eq!(list[0].particles, 0..1);
/// assert_eq!(list.iter().count(), 1);
/// ```
#[derive(Clone, Debug)]
pub struct ReadOnly<T>(pub(crate) Vec<T>, pub(crate) u64);

impl<T> Default for ReadOnly<T> {
    fn default() -> Self {
        Self(Vec::new(), 0)
    }
}

/// Compares the items (not which build of the islands they came from).
impl<T: PartialEq> PartialEq for ReadOnly<T> {
    fn eq(&self, other: &Self) -> bool {
        self.0 == other.0
    }
}

impl<T> std::ops::Deref for ReadOnly<T> {
    type Target = [T];

    fn deref(&self) -> &[T] {
        &self.0
    }
}

impl<'a, T> IntoIterator for &'a ReadOnly<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;

    fn into_iter(self) -> Self::IntoIter {
        self.0.iter()
    }
}

/// A fresh topology stamp, never handed out before (by any solver): [`Sticks`](super::Sticks),
/// [`Angles`](super::Angles) and [`Tethers`](super::Tethers) take one on every change of the
/// particle indices they hold, and [`Islands`] remember the stamps they were built for. Equal
/// stamps therefore mean equal indices (a clone keeps its stamp and its contents), so a layout
/// built for other indices — edited after [`Solver::organize`], or taken from another solver —
/// is never used.
pub(crate) fn next_stamp() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

/// Islands with at least this many sticks, and at least 1.5 sticks per particle (meshes such as
/// cloth, not chains or trees), are solved in colour order and may be split across threads;
/// other islands keep the order their sticks were added in and are solved serially. The order
/// of a sweep matters: along a rope built from its pinned end, one in-order sweep carries the
/// pin's correction to the free end, while the colour order (even links, then odd links)
/// carries it two links per sweep (a 20-link rope at 8 × 1 stretched 1.6 % instead of under
/// 1 %; a 10 000-link rope at 1 × 6 stretched 58×); on a large cloth the colour order is the
/// stable one (see [`colouring`](super::colouring)).
pub const COLOUR_MIN_STICKS: usize = 2048;

/// [`Method::Auto`] gives a mesh island (at least [`COLOUR_MIN_STICKS`] sticks, 1.5 per
/// particle) without tethers and without tearable sticks a hierarchy when it hangs from at least
/// one and at most this many immovable particles (pinned or of infinite mass): the load must
/// cross the mesh to reach them, which sweeps carry a row or two per pass (a 100 × 100 cloth on
/// two corners: 957 % / 515 % swept, 29 % / 20 % with a hierarchy at 1.5× the cost). Hung from
/// a whole row the load runs along the columns, which substeps serve as well, and tethers
/// already bound what a hierarchy would.
pub const HIERARCHY_MAX_PINS: usize = 4;

/// `true` for an island big and dense enough to be a mesh (cloth rather than rope or ragdoll):
/// at least [`COLOUR_MIN_STICKS`] sticks and 1.5 per particle. Such islands are swept in colour
/// order, and [`Method::Auto`] may give them a hierarchy.
fn is_mesh(sticks: usize, particles: usize) -> bool {
    sticks >= COLOUR_MIN_STICKS && 2 * sticks >= 3 * particles
}

impl Islands {
    /// The lines of the islands solved by [`Method::Lines`].
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Islands;
    /// assert!(Islands::default().lines().lines.is_empty());
    /// ```
    pub fn lines(&self) -> &LineSet {
        &self.lines
    }

    /// The hierarchies of the islands solved by [`Method::Hierarchy`].
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Islands;
    /// assert!(Islands::default().hierarchies().list.is_empty());
    /// ```
    pub fn hierarchies(&self) -> &super::HierarchySet {
        &self.hierarchies
    }

    /// Index of the island that holds particle `slot` (islands are contiguous and in order).
    pub fn of_particle(&self, slot: u32) -> Option<usize> {
        let k = self
            .list
            .partition_point(|island| island.particles.end <= slot);
        (k < self.list.len()).then_some(k)
    }
}

/// How [`Solver::organize`] reordered the arrays.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Reorder {
    /// `particles[new] = old`: the slot each particle had before.
    pub particles: Vec<u32>,
    /// `sticks[new] = old`: the index each stick had before.
    pub sticks: Vec<u32>,
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let grand = parent[parent[i as usize] as usize];
        parent[i as usize] = grand;
        i = grand;
    }
    i
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra.max(rb) as usize] = ra.min(rb);
    }
}

/// `values[new] = old_values[from[new]]`.
pub(crate) fn permute<T: Clone>(values: &mut Vec<T>, from: &[u32]) {
    let old = std::mem::take(values);
    values.extend(from.iter().map(|&i| old[i as usize].clone()));
}

impl Solver {
    /// Finds the islands and reorders particles and sticks for parallel, cache-friendly solving
    /// (see the [module docs](self)). Call it after changing the topology; until then
    /// [`Solver::step`] treats the whole solver as one island in array order. Pins, angle
    /// constraints, tethers and island settings are remapped; the returned [`Reorder`] tells
    /// where every particle and stick went.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{Solver, StickKind};
    /// use glam::DVec3;
    /// let mut solver = Solver::default();
    /// for x in [0.0, 5.0, 1.0] {
    ///     solver.add_particle(DVec3::X * x, 1.0);
    /// }
    /// solver.sticks.push([0, 2], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
    /// let reorder = solver.organize();
    /// assert_eq!(solver.islands.list.len(), 2); // {0, 2} and {1}
    /// assert_eq!(reorder.particles, vec![0, 2, 1]); // particle 2 now sits in slot 1
    /// assert_eq!(solver.sticks.ends()[0], [0, 1]);
    /// ```
    pub fn organize(&mut self) -> Reorder {
        self.states_to_verlet_substep();
        self.tethered.resize(self.particles.len(), false);
        let grouping = self.group_particles();
        let (order, colour) = self.order_sticks(&grouping);
        self.order_angles(&grouping);
        self.order_pins();
        self.build_island_list(&grouping, &colour);
        self.rebuild_tethers();
        self.resolve_island_settings();
        self.build_lines();
        self.islands.signature = self.signature();
        self.islands.stamps = self.stamps();
        self.islands.seal();
        Reorder {
            particles: grouping.from,
            sticks: order,
        }
    }

    /// Particles: finds the islands (union–find over sticks and angle constraints) and sorts
    /// the particles by island, keeping their order within an island.
    fn group_particles(&mut self) -> Grouping {
        let n = self.particles.len();
        let (island_of, count) = self.components();
        // A counting sort by island.
        let mut start = vec![0u32; count + 1];
        for &k in &island_of {
            start[k as usize + 1] += 1;
        }
        for k in 0..count {
            start[k + 1] += start[k];
        }
        let mut fill = start.clone();
        let mut from = vec![0u32; n];
        let mut new_of = vec![0u32; n];
        for old in 0..n {
            let k = island_of[old] as usize;
            from[fill[k] as usize] = old as u32;
            new_of[old] = fill[k];
            fill[k] += 1;
        }
        self.permute_particles(&from, &new_of);
        let island = from.iter().map(|&old| island_of[old as usize]).collect();
        Grouping {
            island,
            start,
            from,
        }
    }

    /// The island number of every particle (numbered in order of their first particle) and
    /// how many islands there are.
    fn components(&self) -> (Vec<u32>, usize) {
        let n = self.particles.len();
        let mut parent: Vec<u32> = (0..n as u32).collect();
        for (i, &[a, b]) in self.sticks.ends.iter().enumerate() {
            if self.sticks.kind[i] != StickKind::Torn {
                union(&mut parent, a, b);
            }
        }
        for &[a, b, c] in &self.angles.particles {
            union(&mut parent, a, b);
            union(&mut parent, b, c);
        }
        let mut island_of_root = vec![u32::MAX; n];
        let mut island_of = vec![0u32; n];
        let mut count = 0u32;
        for i in 0..n as u32 {
            let root = find(&mut parent, i) as usize;
            if island_of_root[root] == u32::MAX {
                island_of_root[root] = count;
                count += 1;
            }
            island_of[i as usize] = island_of_root[root];
        }
        (island_of, count as usize)
    }

    /// Sticks: by island (torn ones last, outside every island). Large islands are sorted by
    /// colour, then by ends; small ones keep their sweep order (see `COLOUR_MIN_STICKS`), those
    /// with cycles scheduled by [`sweep_levels`] (same result, faster). Returns
    /// the order (`order[new] = old`) and every stick's colour by new index ([`MAX_COLOURS`]:
    /// one serial batch).
    fn order_sticks(&mut self, grouping: &Grouping) -> (Vec<u32>, Vec<u32>) {
        let m = self.sticks.len();
        let sticks = &self.sticks;
        let island_of_stick = |i: u32| grouping.of_stick(sticks, i as usize) as u32;
        let mut sticks_in = vec![0usize; grouping.count()];
        for i in 0..m as u32 {
            if let Some(n) = sticks_in.get_mut(island_of_stick(i) as usize) {
                *n += 1;
            }
        }
        // Per island (torn sticks' island, past the last, is neither).
        let per_island = |test: fn(usize, usize) -> bool| -> Vec<bool> {
            let particles = |island: usize| grouping.particles(island).len();
            (0..grouping.count())
                .map(|island| test(sticks_in[island], particles(island)))
                .collect()
        };
        let coloured = per_island(is_mesh);
        let has_cycles = per_island(|sticks, particles| !is_chain_or_tree(sticks, particles));
        let flag = |flags: &[bool], island: u32| flags.get(island as usize) == Some(&true);
        let level = sweep_levels(sticks, self.particles.len());
        // Keys computed once, each with its stick's index last: an unstable sort then gives
        // the stable order (a key computed per comparison was 72 % of a 200 × 200 cloth's
        // organize).
        let mut keyed: Vec<([u32; 3], u32)> = (0..m as u32)
            .map(|i| {
                let island = island_of_stick(i);
                let [a, b] = sticks.ends[i as usize];
                let key = if flag(&coloured, island) {
                    [island, a.min(b), a.max(b)]
                } else if flag(&has_cycles, island) {
                    [island, level[i as usize], i]
                } else {
                    [island, 0, i]
                };
                (key, i)
            })
            .collect();
        keyed.sort_unstable();
        let order: Vec<u32> = keyed.iter().map(|&(_, i)| i).collect();
        let mut used = vec![0u64; self.particles.len()];
        let mut colour = Vec::with_capacity(m);
        colour_sticks(&sticks.ends, &order, &mut used, &mut colour);
        // By island and colour; within a colour the (island, ends) order stays.
        let mut by_colour: Vec<([u32; 2], u32)> = order
            .iter()
            .zip(&colour)
            .enumerate()
            .map(|(position, (&stick, &c))| {
                let island = island_of_stick(stick);
                let c = if flag(&coloured, island) {
                    c
                } else {
                    MAX_COLOURS
                };
                ([island, c], position as u32)
            })
            .collect();
        by_colour.sort_unstable();
        let colour_of_position: Vec<u32> = by_colour.iter().map(|&([_, c], _)| c).collect();
        let order: Vec<u32> = by_colour
            .iter()
            .map(|&(_, position)| order[position as usize])
            .collect();
        self.permute_sticks(&order);
        (order, colour_of_position)
    }

    /// Angle constraints: by island (stable).
    fn order_angles(&mut self, grouping: &Grouping) {
        let island_of = |i: u32| grouping.island[self.angles.particles[i as usize][1] as usize];
        let mut order: Vec<u32> = (0..self.angles.len() as u32).collect();
        order.sort_by_key(|&i| island_of(i));
        let angles = &mut self.angles;
        permute(&mut angles.particles, &order);
        permute(&mut angles.rest_angle, &order);
        permute(&mut angles.compliance, &order);
        permute(&mut angles.axis, &order);
        permute(&mut angles.lambda, &order);
        angles.stamp = next_stamp();
    }

    /// Pins: by particle.
    fn order_pins(&mut self) {
        let mut order: Vec<u32> = (0..self.pins.len() as u32).collect();
        order.sort_by_key(|&i| self.pins.particle[i as usize]);
        permute(&mut self.pins.particle, &order);
        permute(&mut self.pins.from, &order);
        permute(&mut self.pins.to, &order);
    }

    /// Islands and colour batches: the ranges of the ordered tables (tethers are assigned by
    /// [`Solver::rebuild_tethers`], lines by `build_lines`).
    fn build_island_list(&mut self, grouping: &Grouping, colour: &[u32]) {
        let islands = &mut self.islands;
        islands.list.0.clear();
        islands.batches.0.clear();
        let (mut stick, mut angle, mut pin) = (0usize, 0usize, 0usize);
        for k in 0..grouping.count() {
            let particles = grouping.particles(k);
            let first_stick = stick;
            let first_batch = islands.batches.len() as u32;
            while grouping.of_stick(&self.sticks, stick) == k {
                let batch_start = stick;
                while grouping.of_stick(&self.sticks, stick) == k
                    && colour[stick] == colour[batch_start]
                {
                    stick += 1;
                }
                let batch = batch(&self.sticks, batch_start..stick, colour[batch_start]);
                islands.batches.0.push(batch);
            }
            let first_angle = angle;
            while angle < self.angles.len()
                && grouping.island[self.angles.particles[angle][1] as usize] as usize == k
            {
                angle += 1;
            }
            let first_pin = pin;
            while pin < self.pins.len() && self.pins.particle[pin] < particles.end {
                pin += 1;
            }
            islands.list.0.push(Island {
                particles,
                sticks: first_stick as u32..stick as u32,
                batches: first_batch..islands.batches.len() as u32,
                angles: first_angle as u32..angle as u32,
                pins: first_pin as u32..pin as u32,
                ..Island::default()
            });
        }
    }

    /// After a topology rebuild, lets every island that is unchanged since `old` — the same
    /// particles (matched by [`Particles::handle`](super::Particles::handle), which must be
    /// unique) and as many sticks, angle constraints and pins — keep sleeping; every other
    /// island starts awake. `old_handles[slot]` is the handle the particle in old slot `slot`
    /// had. (The Bevy layer calls this, so spawning a ragdoll does not wake a hundred others.)
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Solver;
    /// use glam::DVec3;
    /// let mut solver = Solver::default();
    /// solver.add_particle(DVec3::ZERO, 1.0);
    /// solver.particles.handle[0] = 7;
    /// solver.organize();
    /// solver.set_asleep(0, true);
    /// let (old, handles) = (solver.islands.clone(), solver.particles.handle.clone());
    /// solver.organize(); // (a rebuild)
    /// solver.keep_sleep_state(&old, &handles);
    /// assert!(solver.islands.list[0].asleep);
    /// ```
    pub fn keep_sleep_state(&mut self, old: &Islands, old_handles: &[u64]) {
        if !old.list.iter().any(|island| island.asleep) {
            return;
        }
        let mut old_island_of = std::collections::HashMap::new();
        for (k, island) in old.list.iter().enumerate() {
            if island.asleep {
                for slot in island.particles.clone() {
                    if let Some(&handle) = old_handles.get(slot as usize) {
                        old_island_of.insert(handle, k);
                    }
                }
            }
        }
        let handles = &self.particles.handle;
        let length = |r: &Range<u32>| r.end - r.start;
        for island in &mut self.islands.list.0 {
            let first = handles[island.particles.start as usize];
            let Some(&k) = old_island_of.get(&first) else {
                continue;
            };
            let before = &old.list[k];
            let unchanged = length(&before.particles) == length(&island.particles)
                && length(&before.sticks) == length(&island.sticks)
                && length(&before.angles) == length(&island.angles)
                && length(&before.pins) == length(&island.pins)
                && island
                    .particles
                    .clone()
                    .all(|slot| old_island_of.get(&handles[slot as usize]) == Some(&k));
            if unchanged {
                island.asleep = true;
                island.calm_time = before.calm_time;
            }
        }
    }

    /// The sizes the islands are checked against.
    pub(crate) fn signature(&self) -> [usize; 4] {
        [
            self.particles.len(),
            self.sticks.len(),
            self.angles.len(),
            self.pins.len(),
        ]
    }

    /// The stamps of the particle indices the islands depend on (see [`next_stamp`]).
    pub(crate) fn stamps(&self) -> [u64; 3] {
        [self.sticks.stamp, self.angles.stamp, self.tethers.stamp]
    }

    /// `true` when [`Solver::islands`] describes the current arrays: built by
    /// [`Solver::organize`] (or the step's one-island fallback) for these sizes and these
    /// stick, angle and tether indices, its lists the ones built with the rest (not a list
    /// saved from an earlier build and put back). The step uses the islands only then —
    /// otherwise it treats everything as one island, which is always safe — so no edit can make
    /// it split work by a stale layout.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{Solver, StickKind};
    /// use glam::DVec3;
    /// let mut solver = Solver::default();
    /// for x in 0..3 {
    ///     solver.add_particle(DVec3::X * x as f64, 1.0);
    /// }
    /// solver.sticks.push([0, 1], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
    /// solver.organize();
    /// assert!(solver.is_organized());
    /// solver.sticks.set_ends(0, [1, 2]);
    /// assert!(!solver.is_organized());
    /// ```
    pub fn is_organized(&self) -> bool {
        self.islands.signature == self.signature()
            && self.islands.stamps == self.stamps()
            && self.islands.sealed()
            && !self.islands.list.is_empty()
    }

    /// Treats everything as one island in array order (the solver was not organized since its
    /// topology last changed). Allocates nothing once the lists have capacity.
    pub(crate) fn use_one_island(&mut self) {
        // (The islands' states meet in one: in one convention, velocities kept.)
        self.states_to_verlet_substep();
        let signature = self.signature();
        let islands = &mut self.islands;
        let asleep = islands.list.first().is_some_and(|i| i.asleep) && islands.list.len() == 1;
        let calm_time = islands.list.first().map_or(0.0, |i| i.calm_time);
        islands.list.0.clear();
        islands.batches.0.clear();
        islands.batches.0.push(Batch {
            sticks: 0..self.sticks.len() as u32,
            independent: false,
            rigid: false,
        });
        islands.list.0.push(Island {
            particles: 0..self.particles.len() as u32,
            sticks: 0..self.sticks.len() as u32,
            batches: 0..1,
            angles: 0..self.angles.len() as u32,
            pins: 0..self.pins.len() as u32,
            tethers: 0..self.tethers.len() as u32,
            settings: None,
            method: Method::Sweep,
            line_groups: 0..0,
            loose: 0..0,
            trees: 0..0,
            hierarchy: None,
            asleep,
            symmetric: false,
            calm_time,
            state_substep: 0.0,
            keeps_step_substeps: false,
            steps_with_bodies: None,
        });
        islands.lines.clear();
        islands.hierarchies.clear();
        islands.signature = signature;
        self.islands.stamps = self.stamps();
        self.islands.seal();
        self.resolve_island_settings();
    }

    /// Gives every island the tethers of its particles (tethers are sorted by particle).
    pub(crate) fn assign_tether_ranges(&mut self) {
        let particle = &self.tethers.particle;
        for island in &mut self.islands.list.0 {
            let start = particle.partition_point(|&p| p < island.particles.start);
            let end = particle.partition_point(|&p| p < island.particles.end);
            island.tethers = start as u32..end as u32;
        }
    }

    /// Picks every island's [`Method`] and covers the sticks of the islands solved by lines.
    fn build_lines(&mut self) {
        let n = self.particles.len();
        self.line_builder.incidence.build(&self.sticks, n);
        let islands = &mut self.islands;
        islands.lines.clear();
        islands.hierarchies.clear();
        for island in &mut islands.list.0 {
            island.method = Method::Auto; // (no override yet)
            island.line_groups = 0..0;
            island.loose = 0..0;
            island.trees = 0..0;
            island.hierarchy = None;
        }
        for &(particle, method) in &self.island_methods {
            if let Some(k) = islands.of_particle(particle) {
                islands.list.0[k].method = method;
            }
        }
        let builder = &mut self.line_builder;
        for island in &mut islands.list.0 {
            let particles = island.particles.clone();
            let sticks = (island.sticks.end - island.sticks.start) as usize;
            let method = match island.method {
                Method::Auto => self.method,
                forced => forced,
            };
            let chain = is_chain_or_tree(sticks, particles.len()) && island.angles.is_empty();
            let few_pins = || {
                let anchors = particles
                    .clone()
                    .filter(|&p| self.particles.inverse_mass[p as usize] == 0.0);
                (1..=HIERARCHY_MAX_PINS).contains(&anchors.count())
            };
            // (Not a tearable mesh: a tear drops the hierarchy until the next rebuild, and the
            // plugin tears in place, so it would change its method at its first tear.)
            let whole = || {
                let (start, end) = (island.sticks.start as usize, island.sticks.end as usize);
                let tear = &self.sticks.tear_strain[start..end];
                tear.iter().all(|t| !t.is_finite())
            };
            let hung_mesh = is_mesh(sticks, particles.len())
                && island.tethers.is_empty()
                && few_pins()
                && whole();
            island.method = match method {
                Method::Auto if chain => Method::Lines,
                Method::Auto if hung_mesh => Method::Hierarchy,
                Method::Lines if sticks > 0 => Method::Lines,
                Method::Hierarchy if sticks > 0 => Method::Hierarchy,
                _ => Method::Sweep,
            };
            if island.method == Method::Hierarchy {
                island.hierarchy = build_hierarchy(
                    &mut islands.hierarchies,
                    builder,
                    (&self.particles, &self.sticks),
                    island,
                );
                continue;
            }
            if island.method != Method::Lines {
                continue;
            }
            if is_chain_or_tree(sticks, particles.len()) {
                island.trees = super::tree::build(
                    &mut islands.lines.trees,
                    (&mut builder.queue, &mut builder.seen),
                    (&self.particles, &self.sticks),
                    particles.clone(),
                    &builder.incidence,
                );
                if !island.trees.is_empty() {
                    continue;
                }
            }
            let covered = cover(
                &mut islands.lines,
                &mut builder.cover,
                &self.particles,
                &self.sticks,
                island.sticks.clone(),
                particles,
                &builder.incidence,
            );
            island.line_groups = covered.groups;
            island.loose = covered.loose;
        }
        self.line_scratch.resize(
            islands.lines.sticks.len(),
            islands.lines.particles.len(),
            &islands.lines.trees,
        );
        islands.hierarchies.refresh(&self.particles, &self.sticks);
    }

    /// Sets [`Island::settings`] from [`Solver::island_settings`] (the larger counts win).
    fn resolve_island_settings(&mut self) {
        for island in &mut self.islands.list.0 {
            island.settings = None;
        }
        for &(particle, settings) in &self.island_settings {
            if let Some(k) = self.islands.of_particle(particle) {
                let island = &mut self.islands.list.0[k];
                island.settings = Some(island.settings.map_or(settings, |s| s.max(settings)));
            }
        }
    }

    fn permute_particles(&mut self, from: &[u32], new_of: &[u32]) {
        let p = &mut self.particles;
        permute(&mut p.position, from);
        permute(&mut p.previous, from);
        permute(&mut p.inverse_mass, from);
        permute(&mut p.radius, from);
        permute(&mut p.handle, from);
        permute(&mut self.tethered, from);
        let remap = |i: &mut u32| *i = new_of[*i as usize];
        self.sticks.ends.iter_mut().flatten().for_each(remap);
        self.angles.particles.iter_mut().flatten().for_each(remap);
        self.pins.particle.iter_mut().for_each(remap);
        self.island_settings.iter_mut().for_each(|(i, _)| remap(i));
        self.island_methods.iter_mut().for_each(|(i, _)| remap(i));
        self.sticks.stamp = next_stamp();
        self.angles.stamp = next_stamp();
    }

    fn permute_sticks(&mut self, from: &[u32]) {
        let s = &mut self.sticks;
        permute(&mut s.ends, from);
        s.stamp = next_stamp();
        permute(&mut s.rest_length, from);
        permute(&mut s.compliance, from);
        permute(&mut s.kind, from);
        permute(&mut s.tear_strain, from);
        permute(&mut s.lambda, from);
        permute(&mut s.handle, from);
        s.tearable.clear();
        for i in 0..s.len() {
            if s.tear_strain[i].is_finite() && s.kind[i] != StickKind::Torn {
                s.tearable.push(i as u32);
            }
        }
    }
}

/// The level of every stick in a Gauss–Seidel sweep in index order: one more than the highest
/// level of the earlier sticks it shares a particle with (torn sticks: 0, they share nothing).
///
/// A sweep reads what the earlier sticks at its two particles wrote, so any order that keeps,
/// at every particle, the order of the sticks there computes exactly the same thing, bit for
/// bit. Sorting by level is such an order, and consecutive sticks of one level share no
/// particle: the processor overlaps them instead of waiting for each square root and division
/// to finish before the next stick can read its result (a 10 × 6 cloth patch in the cloth
/// builder's order: 104 sticks in 28 levels; a chain has one stick per level and gains
/// nothing). This is list scheduling of the sweep's dependency graph (e.g. Sinnen, *Task
/// Scheduling for Parallel Systems*, 2007, ch. 5). `particles`: how many there are.
fn sweep_levels(sticks: &super::Sticks, particles: usize) -> Vec<u32> {
    let mut last = vec![0u32; particles];
    let torn = |i: usize| sticks.kind[i] == StickKind::Torn;
    (0..sticks.len())
        .map(|i| {
            if torn(i) {
                return 0;
            }
            let [a, b] = sticks.ends[i].map(|p| p as usize);
            let level = last[a].max(last[b]) + 1;
            last[a] = level;
            last[b] = level;
            level
        })
        .collect()
}

/// The colour batch of the sticks in `sticks` (all of colour `colour`).
fn batch(sticks: &super::Sticks, range: Range<usize>, colour: u32) -> Batch {
    let rigid = range.clone().all(|i| {
        sticks.kind[i] == StickKind::Equal
            && sticks.compliance[i] == 0.0
            && !sticks.tear_strain[i].is_finite()
    });
    Batch {
        sticks: range.start as u32..range.end as u32,
        independent: colour < MAX_COLOURS,
        rigid,
    }
}

/// Particles grouped by island (see `Solver::group_particles`).
struct Grouping {
    /// `island[slot]`: the island of the particle now in `slot`.
    island: Vec<u32>,
    /// `start[k]..start[k + 1]`: the slots of island `k`.
    start: Vec<u32>,
    /// `from[new] = old` (see [`Reorder::particles`]).
    from: Vec<u32>,
}

impl Grouping {
    fn count(&self) -> usize {
        self.start.len() - 1
    }

    fn particles(&self, k: usize) -> Range<u32> {
        self.start[k]..self.start[k + 1]
    }

    /// Island of stick `i` (`usize::MAX` for a torn one or past the end).
    fn of_stick(&self, sticks: &super::Sticks, i: usize) -> usize {
        match sticks.kind.get(i) {
            Some(StickKind::Torn) | None => usize::MAX,
            Some(_) => self.island[sticks.ends[i][0] as usize] as usize,
        }
    }
}

/// Covers a [`Method::Hierarchy`] island with lines (in the builder's own line set: they are
/// not solved as lines) and builds its hierarchy from them.
fn build_hierarchy(
    hierarchies: &mut super::HierarchySet,
    builder: &mut super::lines::LineBuilder,
    (particles, sticks): (&super::Particles, &super::Sticks),
    island: &Island,
) -> Option<u32> {
    let set = &mut builder.hierarchy_lines;
    set.clear();
    cover(
        set,
        &mut builder.cover,
        particles,
        sticks,
        island.sticks.clone(),
        island.particles.clone(),
        &builder.incidence,
    );
    super::hierarchy::build(hierarchies, set, &set.lines, (particles, sticks))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::Sticks;

    /// A `w × h` grid's sticks in the cloth builder's order (each particle's left, then upper
    /// neighbour), with a few torn.
    fn grid_sticks(w: u32, h: u32) -> Sticks {
        let mut sticks = Sticks::default();
        for y in 0..h {
            for x in 0..w {
                let p = y * w + x;
                let kind = |k: u32| match k % 7 {
                    3 => StickKind::Torn,
                    _ => StickKind::Equal,
                };
                if x > 0 {
                    sticks.push([p - 1, p], 1.0, 0.0, kind(p), f64::INFINITY, 0);
                }
                if y > 0 {
                    sticks.push([p - w, p], 1.0, 0.0, kind(p + 1), f64::INFINITY, 0);
                }
            }
        }
        sticks
    }

    /// A toy Gauss–Seidel sweep with the real one's dependency pattern: every stick reads and
    /// rewrites both of its particles' values (non-linearly, so that any change of order at a
    /// particle changes the bits).
    fn sweep(sticks: &Sticks, order: &[usize], values: &mut [f64]) {
        for &i in order {
            if sticks.kind[i] == StickKind::Torn {
                continue;
            }
            let [a, b] = sticks.ends()[i].map(|p| p as usize);
            let (x, y) = (values[a], values[b]);
            values[a] = (x * 1.3 + y).sin() + 0.1 * i as f64;
            values[b] = (y * 0.7 - x).cos() * 1.1;
        }
    }

    #[test]
    fn sweeping_by_level_computes_the_same_bits_with_independent_neighbours() {
        let sticks = grid_sticks(10, 6);
        let level = sweep_levels(&sticks, 60);
        let in_index_order: Vec<usize> = (0..sticks.len()).collect();
        let mut by_level = in_index_order.clone();
        by_level.sort_by_key(|&i| (level[i], i));
        assert_ne!(by_level, in_index_order, "the test must reorder something");
        // Consecutive sticks of one level share no particle.
        for pair in by_level.windows(2) {
            let ([a, b], [c, d]) = (sticks.ends()[pair[0]], sticks.ends()[pair[1]]);
            let torn =
                sticks.kind[pair[0]] == StickKind::Torn || sticks.kind[pair[1]] == StickKind::Torn;
            if level[pair[0]] == level[pair[1]] && !torn {
                assert!(
                    a != c && a != d && b != c && b != d,
                    "{pair:?} share a particle"
                );
            }
        }
        let levels = level.iter().max().copied().unwrap_or(0) as usize;
        let live = sticks
            .kind
            .iter()
            .filter(|&&k| k != StickKind::Torn)
            .count();
        assert!(3 * levels <= live, "{live} sticks in {levels} levels");
        let start: Vec<f64> = (0..60).map(|p| p as f64 * 0.37).collect();
        let (mut expected, mut got) = (start.clone(), start);
        sweep(&sticks, &in_index_order, &mut expected);
        sweep(&sticks, &by_level, &mut got);
        assert_eq!(
            expected.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            got.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        // The check can fail: swapping two dependent sticks changes the result.
        let mut swapped = in_index_order.clone();
        swapped.swap(0, 1);
        let mut other: Vec<f64> = (0..60).map(|p| p as f64 * 0.37).collect();
        sweep(&sticks, &swapped, &mut other);
        assert_ne!(other, expected);
    }
}
