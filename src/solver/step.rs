//! One fixed step over islands: begin (wake, pick the substep count) → per substep integrate,
//! relax, constrain → finish (tear, sleep).
//!
//! Islands advance in lockstep through `L` *global* substeps, `L` being the largest substep
//! count of any awake island. An island with `S ≤ L` substeps takes its `j`-th substep at the
//! first global substep `k` with `k·S/L ≥ j`, so every island takes exactly its own count, evenly
//! spread, with its own `h = Δt/S`. Sleeping islands take none.
//!
//! Work is spread over an [`Executor`]: a large island's colour batches are split across
//! threads, small islands are grouped into one job per thread, particle loops are split into
//! ranges — each only when there is enough work for every thread (see
//! [`parallel`](super::parallel)). Jobs never share a particle, so the result does not depend on
//! the executor or the thread count.

use super::angles::relax_angle_range;
use super::colliders::constrain_range;
use super::direct::{LineRef, LineScratch, LineSolve, LineViews};
use super::hierarchy::AFTER_SWEEP_FROM_LEVEL;
use super::integrate::{integrate_range, resubstep};
use super::line_substeps::{holds_any, keeps_step_substeps, line_substep_count};
use super::lines::Method;
use super::parallel::{
    Executor, PARALLEL_CHUNK_STICKS, PARALLEL_MIN_PARTICLES_PER_JOB, PARALLEL_MIN_STICK_ITERATIONS,
    PARALLEL_MIN_WORK_PER_JOB, Serial, job_count, part,
};
use super::shared::SharedSlice;
use super::sticks::{SweepOrder, relax_stick_range};
use super::symmetric::{in_pairs, mass_ratio, nth_in, order_of};
use super::tethers::relax_tether_range;
use super::tree::TreeSolve;
use super::{Island, IslandSettings, Particles, Solver, StepConfig, Substep, tear};
use glam::DVec3;
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Global substep `index` of `count` in the fixed step configured by `config`.
///
/// Islands advance in lockstep through `count` global substeps, `count` being the largest
/// substep count of any awake island ([`Solver::begin_step`]). An island with `S ≤ count`
/// substeps takes its `j`-th substep at the first global substep `k` with `k·S/count ≥ j`
/// ([`GlobalSubstep::for_island`]), so every island takes exactly its own count, evenly
/// spread, with its own `h = Δt/S`. Sleeping islands take none.
///
/// ```
/// use bevy_verlet_physics::solver::{GlobalSubstep, Solver, StepConfig, Serial};
/// let mut solver = Solver::default();
/// let config = StepConfig::default();
/// let count = solver.begin_step(&config);
/// for index in 1..=count {
///     let substep = GlobalSubstep { config, index, count, plain: false };
///     solver.integrate_substep(&substep, &Serial);
///     solver.relax_substep(&substep, &Serial);
///     solver.constrain_substep(&substep, &Serial);
/// }
/// solver.finish_step();
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GlobalSubstep {
    /// The step's settings (islands may override substeps and iterations).
    pub config: StepConfig,
    /// 1-based index.
    pub index: u32,
    /// Global substeps in this fixed step (from [`Solver::begin_step`]).
    pub count: u32,
    /// Never accumulate XPBD multipliers (plain PBD: for comparisons only).
    pub plain: bool,
}

impl GlobalSubstep {
    /// The substep `island` takes now, or `None` if it takes none (asleep, or not due). For an
    /// island swept symmetrically ([`Island::symmetric`]) its iterations come in
    /// forward–backward pairs (see [`symmetric`](super::symmetric)).
    pub fn for_island(&self, island: &Island) -> Option<Substep> {
        if island.asleep {
            return None;
        }
        let substep = self.for_config(island.config(&self.config))?;
        Some(self.paired_if(island.symmetric, substep))
    }

    /// `substep` in forward–backward pairs if `symmetric` (see [`symmetric`](super::symmetric)).
    fn paired_if(&self, symmetric: bool, substep: Substep) -> Substep {
        if symmetric {
            in_pairs(substep, self.plain)
        } else {
            substep
        }
    }

    /// The substep an awake island of (clamped) `config` takes now, if any.
    fn for_config(&self, config: StepConfig) -> Option<Substep> {
        let substeps = config.substeps;
        let count = self.count.max(substeps);
        // (An island that takes every global substep — most do — needs no division: it was
        // 9 % of the instructions of a scene of 1000 pendulums, asked several times per
        // substep per island.)
        let j = if count == substeps {
            self.index
        } else {
            let j = self.index * substeps / count;
            if j == (self.index - 1) * substeps / count {
                return None;
            }
            j
        };
        let mut substep = config.substep_context(j);
        if self.plain {
            substep.accumulate = false;
        }
        Some(substep)
    }
}

/// Positions, previous positions, multipliers and line scratch, shareable between jobs.
struct Views<'a> {
    position: SharedSlice<'a, DVec3>,
    previous: SharedSlice<'a, DVec3>,
    stick_lambda: SharedSlice<'a, f64>,
    angle_lambda: SharedSlice<'a, f64>,
    lines: LineViews<'a>,
}

/// One step of an iteration of a large island solved on every thread.
enum IslandStep<'a> {
    /// A hierarchy's coarse pass from this level up (one thread).
    Coarse(usize),
    /// A colour batch (split between the threads when independent), visited in this order.
    Batch(&'a super::Batch, SweepOrder),
    /// Angles and tethers (one thread).
    Rest,
}

/// The arrays the views borrow, moved out of the solver for a phase (no allocation).
struct Taken {
    position: Vec<DVec3>,
    previous: Vec<DVec3>,
    stick_lambda: Vec<f64>,
    angle_lambda: Vec<f64>,
    lines: LineScratch,
}

impl Solver {
    /// Runs one fixed step: `S` × (integrate → relax × N → constrain), then tear. Torn stick
    /// indices are left in [`Solver::torn`]; tethers are rebuilt if anything tore.
    pub fn step(&mut self, config: &StepConfig) {
        self.step_with(config, &Serial);
    }

    /// [`Solver::step`], spreading work over `executor` (same result as serial).
    pub fn step_with(&mut self, config: &StepConfig, executor: &dyn Executor) {
        self.step_observed(config, false, executor, |_, _| {});
    }

    /// [`Solver::step_with`], calling `observe(solver, substep)` after every global substep;
    /// `plain` never accumulates XPBD multipliers (plain PBD, for comparisons). Returns how many
    /// sticks tore.
    pub fn step_observed(
        &mut self,
        config: &StepConfig,
        plain: bool,
        executor: &dyn Executor,
        mut observe: impl FnMut(&Solver, &GlobalSubstep),
    ) -> usize {
        let count = self.begin_step(config);
        for index in 1..=count {
            let substep = GlobalSubstep {
                config: *config,
                index,
                count,
                plain,
            };
            self.integrate_substep(&substep, executor);
            self.relax_substep(&substep, executor);
            self.constrain_substep(&substep, executor);
            observe(self, &substep);
        }
        self.finish_step()
    }

    /// Starts a fixed step: checks the islands (one island in array order if the topology
    /// changed since [`Solver::organize`]), wakes islands that were touched, and returns how many
    /// global substeps the step takes (see [`GlobalSubstep`]).
    pub fn begin_step(&mut self, config: &StepConfig) -> u32 {
        if self.tethers_stale {
            self.rebuild_tethers();
        }
        self.check_layout();
        self.islands
            .hierarchies
            .refresh(&self.particles, &self.sticks);
        // (A NaN mass ratio means never, as infinity does: kept as infinity, or NaN ≠ NaN would
        // read as a new configuration, waking every island, in every step.)
        let mut config_kept = *config;
        if config_kept.symmetric_mass_ratio.is_nan() {
            config_kept.symmetric_mass_ratio = f64::INFINITY;
        }
        let changed =
            self.last_config != Some(config_kept) || self.colliders != self.last_colliders;
        if self.colliders != self.last_colliders || !self.collider_grid.is_active() {
            let bounds = self.colliders.iter().map(|c| c.shape.bounds());
            self.collider_grid.build(bounds);
        }
        if changed || config.sleep.is_none() {
            self.wake_all();
        }
        self.last_config = Some(config_kept);
        self.last_colliders.clone_from(&self.colliders);
        for i in 0..self.wake_requests.len() {
            if let Some(k) = self.islands.of_particle(self.wake_requests[i]) {
                let island = &mut self.islands.list.0[k];
                island.asleep = false;
                island.calm_time = 0.0;
            }
        }
        self.wake_requests.clear();
        let pins = &self.pins;
        let mut count = 1;
        // Each awake island's Verlet state in the substep it takes now, its velocities kept
        // (see [`Island::state_substep`]): only where a count or the timestep changed. (A
        // sleeping island rests with `x* = x`: left alone.)
        let global = config.substep();
        let unset = self.verlet_substep.unwrap_or(global);
        // (Sorted here, for `holds_any`: set in any order.)
        if !self.attached.is_sorted() {
            self.attached.sort_unstable();
        }
        for island in &mut self.islands.list.0 {
            if island.asleep && pins.moving(range(&island.pins)) {
                island.asleep = false;
                island.calm_time = 0.0;
            }
            if island.asleep {
                continue;
            }
            // (Turned off, or solved by lines: no pass over the masses.)
            island.symmetric = config.symmetric_mass_ratio < f64::INFINITY
                && island.method != Method::Lines
                && !island.sticks.is_empty()
                && mass_ratio(&self.particles.inverse_mass[range(&island.particles)])
                    > config.symmetric_mass_ratio;
            let arrays = (&self.particles, &self.sticks, &self.pins);
            let attached = holds_any(&island.particles, &self.attached);
            island.keeps_step_substeps =
                keeps_step_substeps(island, arrays, attached, config, unset);
            island.steps_with_bodies = None;
            let own = island
                .own_settings(config)
                .map(|own| super::islands::configured(config, Some(own)));
            count = count.max(own.map_or(config.substeps, |c| c.substeps));
            if attached {
                // (Its substep waits for the step's count: see `step_with_bodies`.)
                continue;
            }
            let h = own.map_or(global, |c| c.substep());
            resubstep_island(&mut self.particles, island, config.gravity, (unset, h));
        }
        self.step_with_bodies(config, count, unset);
        self.current = Some(*config);
        count
    }

    /// Gives every awake island that holds an attached particle ([`Solver::attached`]) the
    /// step's `count` of substeps, which the bodies take — more than its own where another
    /// island has an override with more — or, with settings of its own, the fewest at least
    /// theirs that divide it ([`Island::steps_with_bodies`]): the coupling keeps momentum best
    /// substep by substep (see [`attachments`](super::attachments)).
    fn step_with_bodies(&mut self, config: &StepConfig, count: u32, unset: f64) {
        if self.attached.is_empty() {
            return;
        }
        for island in &mut self.islands.list.0 {
            if island.asleep || !holds_any(&island.particles, &self.attached) {
                continue;
            }
            let with_bodies = island.settings.is_some() || count > config.substeps;
            island.steps_with_bodies = with_bodies.then_some(count);
            let own = island.own_settings(config);
            let h = super::islands::configured(config, own).substep();
            resubstep_island(&mut self.particles, island, config.gravity, (unset, h));
        }
    }

    /// Wakes the island of particle `slot` before the next step (a particle was moved, a
    /// constraint edited; the Bevy layer calls this for every edit it gathers).
    pub fn wake(&mut self, slot: u32) {
        self.wake_requests.push(slot);
    }

    /// Puts island `island` to sleep (at rest: its previous positions become its positions) or
    /// wakes it; out-of-range indices are ignored.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Solver;
    /// use glam::DVec3;
    /// let mut solver = Solver::default();
    /// solver.add_particle(DVec3::ZERO, 1.0);
    /// solver.organize();
    /// solver.set_asleep(0, true);
    /// assert_eq!(solver.sleeping_islands(), 1);
    /// ```
    pub fn set_asleep(&mut self, island: usize, asleep: bool) {
        let Some(island) = self.islands.list.0.get_mut(island) else {
            return;
        };
        island.asleep = asleep;
        island.calm_time = 0.0;
        if asleep {
            let p = &mut self.particles;
            for i in range(&island.particles) {
                if let (Some(&x), Some(previous)) = (p.position.get(i), p.previous.get_mut(i)) {
                    *previous = x;
                }
            }
        }
    }

    /// Wakes every island.
    pub fn wake_all(&mut self) {
        for island in &mut self.islands.list.0 {
            island.asleep = false;
            island.calm_time = 0.0;
        }
    }

    /// How many islands sleep.
    pub fn sleeping_islands(&self) -> usize {
        self.islands.list.iter().filter(|i| i.asleep).count()
    }

    /// How many awake islands the last step swept forward and back ([`Island::symmetric`]:
    /// their masses differ more than [`StepConfig::symmetric_mass_ratio`]).
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{Solver, StepConfig, StickKind};
    /// use glam::DVec3;
    /// // A triangle (a loop: swept) holding a 100× heavier particle.
    /// let mut solver = Solver::default();
    /// for (x, w) in [(0.0, 1.0), (1.0, 1.0), (0.5, 0.01)] {
    ///     solver.add_particle(DVec3::new(x, 0.0, 0.0), w);
    /// }
    /// for ends in [[0, 1], [1, 2], [2, 0]] {
    ///     solver.sticks.push(ends, 0.5, 0.0, StickKind::Equal, f64::INFINITY, 0);
    /// }
    /// solver.organize();
    /// solver.step(&StepConfig::default());
    /// assert_eq!(solver.symmetric_islands(), 1);
    /// ```
    pub fn symmetric_islands(&self) -> usize {
        self.islands
            .list
            .iter()
            .filter(|i| i.symmetric && !i.asleep)
            .count()
    }

    /// First phase of a substep: Verlet integration, kinematic pins placed on their interpolated
    /// targets, XPBD multipliers reset.
    pub fn integrate_substep(&mut self, global: &GlobalSubstep, executor: &dyn Executor) {
        self.check_layout();
        let mut taken = self.take();
        let islands = &self.islands;
        {
            let views = views(&mut taken);
            let particles = &self.particles;
            for_due_particles(&islands.list, global, executor, &|slots, substep| {
                // SAFETY: `slots` is this job's part of the particles of one or more islands
                // next to each other: parts of one range are disjoint, islands are disjoint
                // (the layout matches the topology: `check_layout`), each island is in one
                // range — the same ranges in every job, which all build them from the same
                // islands and substep — and each part runs once (`run_jobs`).
                let (position, previous) = unsafe {
                    (
                        views.position.part(slots.clone()),
                        views.previous.part(slots.clone()),
                    )
                };
                integrate_range(
                    &position,
                    &previous,
                    &particles.inverse_mass,
                    slots,
                    substep.gravity,
                    substep.h,
                    substep.damping_factor,
                );
            });
            // SAFETY: no job runs any more (serial from here on).
            let (position, stick_lambda, angle_lambda) = unsafe {
                (
                    views.position.part(0..views.position.len()),
                    views.stick_lambda.part(0..views.stick_lambda.len()),
                    views.angle_lambda.part(0..views.angle_lambda.len()),
                )
            };
            for (island, substep) in due(&islands.list, global) {
                let fraction = substep.index as f64 / substep.count as f64;
                self.pins
                    .drive_range(&position, range(&island.pins), fraction);
                if substep.accumulate {
                    for i in range(&island.sticks) {
                        stick_lambda.set(i, 0.0);
                    }
                    for i in range(&island.angles) {
                        angle_lambda.set(i, 0.0);
                    }
                }
            }
        }
        self.give_back(taken);
    }

    /// Second phase of a substep: `iterations` relaxation sweeps (sticks by colour, angle
    /// constraints, tethers) per due island.
    pub fn relax_substep(&mut self, global: &GlobalSubstep, executor: &dyn Executor) {
        self.check_layout();
        let threads = executor.threads();
        // Large coloured islands are solved on every thread; the rest in groups.
        let big = |island: &Island, substep: &Substep, batches: &[super::Batch]| {
            threads > 1
                && island.method != Method::Lines
                && len(&island.sticks) * substep.iterations as usize
                    >= PARALLEL_MIN_STICK_ITERATIONS
                && batches[range(&island.batches)]
                    .iter()
                    .any(|b| b.independent)
        };
        // (On one thread no island is big and there is one job: the passes over the islands
        // that only size the parallel work are skipped.)
        let parallel = threads > 1;
        let mut counters = 0;
        if parallel {
            for (island, substep) in due(&self.islands.list, global) {
                if big(island, &substep, &self.islands.batches) {
                    // (Batches, the rest, and a hierarchy's two coarse passes.)
                    let per_iteration = len(&island.batches) + 3;
                    counters = counters.max(2 * per_iteration * substep.iterations as usize);
                }
            }
        }
        self.counters.ensure(counters);
        let mut taken = self.take();
        let islands = &self.islands;
        {
            let views = views(&mut taken);
            let is_big =
                |island: &Island, substep: &Substep| big(island, substep, &islands.batches);
            if parallel {
                for (island, substep) in due(&islands.list, global).filter(|(i, s)| is_big(i, s)) {
                    self.relax_island_parallel(&views, islands, island, &substep, executor);
                }
            }
            // Small islands in groups of similar work, one group per job.
            let work = |island: &Island, substep: &Substep| {
                len(&island.particles) + len(&island.sticks) * substep.iterations as usize
            };
            let small = || due(&islands.list, global).filter(|(i, s)| !is_big(i, s));
            let total: usize = if parallel {
                small().map(|(i, s)| work(i, &s)).sum()
            } else {
                0
            };
            let jobs = job_count(executor, total, PARALLEL_MIN_WORK_PER_JOB);
            let relax_group = |job: usize| {
                let (mut done, mut passes) = (0, 0);
                for (island, substep) in small() {
                    // An island belongs to the job its first unit of work falls in.
                    if jobs == 1 || done * jobs / total.max(1) == job {
                        // SAFETY: each island belongs to one job, each job runs once
                        // (`run_jobs`), islands share nothing (the layout matches the
                        // topology: `check_layout`), and the large islands ran before.
                        passes += unsafe { self.relax_island(&views, islands, island, &substep) };
                    }
                    done += work(island, &substep);
                }
                // (Counted once per job: an atomic add per island was measurable with many.)
                self.line_passes.0.fetch_add(passes, Ordering::Relaxed);
            };
            run_jobs(executor, jobs, &relax_group);
        }
        self.give_back(taken);
    }

    /// A later round of the relaxation (no warm start; multipliers carried on) for the islands
    /// solved by lines that take global substep `global` and hold one of `particles` (sorted),
    /// on the calling thread. For another engine's bodies: after they took their attached
    /// particles' pull, the ropes are solved again from where the bodies put their ends (see
    /// [`External::after_relax`](super::External::after_relax)). Returns whether an island was
    /// solved.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{GlobalSubstep, Serial, Solver, StepConfig, StickKind};
    /// use glam::DVec3;
    /// let mut solver = Solver::default();
    /// let pin = solver.add_particle(DVec3::ZERO, 0.0);
    /// solver.pin(pin, DVec3::ZERO);
    /// let end = solver.add_particle(DVec3::new(0.0, -1.0, 0.0), 1.0);
    /// solver.sticks.push([pin, end], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
    /// solver.organize();
    /// let config = StepConfig::default();
    /// let count = solver.begin_step(&config);
    /// let substep = GlobalSubstep { config, index: 1, count, plain: false };
    /// solver.integrate_substep(&substep, &Serial);
    /// solver.relax_substep(&substep, &Serial);
    /// solver.particles.position[end as usize].y -= 0.01; // moved after the solve
    /// assert!(solver.relax_lines_again(&substep, &[end]));
    /// assert!(solver.sticks.max_violation(&solver.particles) < 1e-9);
    /// ```
    pub fn relax_lines_again(&mut self, global: &GlobalSubstep, particles: &[u32]) -> bool {
        self.check_layout();
        let mut taken = self.take();
        let islands = &self.islands;
        let (mut solved, mut passes) = (false, 0);
        {
            let views = views(&mut taken);
            for (island, substep) in due(&islands.list, global) {
                if !lines_holding(island, particles) {
                    continue;
                }
                // SAFETY: one task holds every island (this thread), and its layout matches the
                // topology (`check_layout`).
                passes += unsafe {
                    let passes = self.solve_lines_of(&views, islands, island, &substep, false);
                    self.relax_rest_of(&views, island, &substep);
                    passes
                };
                solved = true;
            }
        }
        self.line_passes.0.fetch_add(passes, Ordering::Relaxed);
        self.give_back(taken);
        solved
    }

    /// Whether [`Solver::relax_lines_again`] would solve an island: one solved by lines, due in
    /// `global`, holds one of `particles` (sorted).
    pub(crate) fn has_lines_again(&self, global: &GlobalSubstep, particles: &[u32]) -> bool {
        due(&self.islands.list, global).any(|(island, _)| lines_holding(island, particles))
    }

    /// Third phase of a substep: colliders (skipped when there are none).
    pub fn constrain_substep(&mut self, global: &GlobalSubstep, executor: &dyn Executor) {
        if self.colliders.is_empty() {
            return;
        }
        self.check_layout();
        let mut taken = self.take();
        let islands = &self.islands;
        {
            let views = views(&mut taken);
            let particles = &self.particles;
            for_due_particles(&islands.list, global, executor, &|slots, substep| {
                let gravity_step = substep.gravity.length() * substep.h * substep.h;
                // SAFETY: as for the integration: this job's part of one or more islands'
                // particles.
                let (position, previous) = unsafe {
                    (
                        views.position.part(slots.clone()),
                        views.previous.part(slots.clone()),
                    )
                };
                constrain_range(
                    &position,
                    &previous,
                    (&particles.inverse_mass, &particles.radius),
                    (&self.colliders, &self.collider_grid),
                    slots,
                    gravity_step,
                );
            });
        }
        self.give_back(taken);
    }

    /// The particle ranges that take global substep `global`, each with its island's substep
    /// (written into `out`, which is cleared first; no allocation once it has grown). For
    /// passes outside the solver that must follow the islands' substeps (e.g. contacts with
    /// another engine's colliders).
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{GlobalSubstep, Solver, StepConfig};
    /// use glam::DVec3;
    /// let mut solver = Solver::default();
    /// solver.add_particle(DVec3::ZERO, 1.0);
    /// solver.organize();
    /// let config = StepConfig::default();
    /// let count = solver.begin_step(&config);
    /// let mut due = Vec::new();
    /// solver.due_ranges(&GlobalSubstep { config, index: 1, count, plain: false }, &mut due);
    /// assert_eq!(due[0].0, 0..1);
    /// ```
    pub fn due_ranges(&mut self, global: &GlobalSubstep, out: &mut Vec<(Range<usize>, Substep)>) {
        self.check_layout();
        out.clear();
        out.extend(
            due(&self.islands.list, global).map(|(island, s)| (range(&island.particles), s)),
        );
    }

    /// Ends a fixed step: pins start the next step where this one left them, overstrained sticks
    /// tear (post-solve strain), and calm islands fall asleep. Returns how many sticks tore;
    /// their indices are in [`Solver::torn`]. Tethers are rebuilt after a tear.
    pub fn finish_step(&mut self) -> usize {
        if let Some(config) = self.current.take() {
            self.update_sleep(&config);
            self.verlet_substep = Some(config.substep());
        }
        self.pins.from.clone_from_slice(&self.pins.to);
        self.torn.clear();
        if self.sticks.tearable.is_empty() {
            return 0;
        }
        let torn = tear(&self.particles, &mut self.sticks, &mut self.torn);
        if torn > 0 {
            // Torn sticks must be skipped: no batch is known all-rigid any more.
            for batch in &mut self.islands.batches.0 {
                batch.rigid = false;
            }
            // A torn island is no longer calm.
            for &stick in &self.torn {
                let particle = self.sticks.ends[stick as usize][0];
                self.wake_requests.push(particle);
            }
            if !self.tethers.is_empty() {
                self.rebuild_tethers();
            }
        }
        torn
    }

    /// Counts calm time and puts islands to sleep (at rest: previous = position).
    fn update_sleep(&mut self, config: &StepConfig) {
        let Some(sleep) = config.sleep else {
            return;
        };
        let p = &mut self.particles;
        for island in &mut self.islands.list.0 {
            if island.asleep {
                continue;
            }
            let h = island.config(config).substep();
            let limit = (sleep.speed * h).powi(2);
            let calm = !self.pins.moving(range(&island.pins))
                && range(&island.particles).all(|i| {
                    p.inverse_mass[i] <= 0.0
                        || (p.position[i] - p.previous[i]).length_squared() <= limit
                });
            if !calm {
                island.calm_time = 0.0;
                continue;
            }
            island.calm_time += config.timestep;
            if island.calm_time >= sleep.time {
                island.asleep = true;
                for i in range(&island.particles) {
                    p.previous[i] = p.position[i];
                }
            }
        }
    }

    /// One island's relaxation on the calling thread: its sticks in order, then angles and
    /// tethers, `iterations` times. Returns the Newton passes of its lines or tree.
    ///
    /// # Safety
    /// No other task accesses the island's particles, its sticks' and angle constraints'
    /// multipliers or its lines' scratch while this runs.
    unsafe fn relax_island(
        &self,
        views: &Views,
        islands: &super::Islands,
        island: &Island,
        substep: &Substep,
    ) -> u64 {
        let mut passes = 0;
        let batches = &islands.batches[range(&island.batches)];
        for round in 0..substep.iterations {
            // SAFETY: everything below belongs to this island, which this task holds (caller).
            unsafe {
                if island.method == Method::Lines {
                    passes += self.solve_lines_of(views, islands, island, substep, round == 0);
                } else {
                    self.solve_hierarchy_of(views, islands, island, 0);
                    let order = order_of(island.symmetric, round);
                    for k in 0..batches.len() {
                        let batch = nth_in(order, batches, k);
                        self.relax_sticks_of(views, substep, batch, order);
                    }
                    self.solve_hierarchy_of(views, islands, island, AFTER_SWEEP_FROM_LEVEL);
                }
                self.relax_rest_of(views, island, substep);
            }
        }
        passes
    }

    /// An island's pass over its hierarchy's coarse levels from `first` up, if it has an active
    /// hierarchy.
    ///
    /// # Safety
    /// No other task accesses the island's particles while this runs.
    unsafe fn solve_hierarchy_of(
        &self,
        views: &Views,
        islands: &super::Islands,
        island: &Island,
        first: usize,
    ) {
        let Some(hierarchy) = island
            .hierarchy
            .and_then(|k| islands.hierarchies.list.get(k as usize))
            .filter(|h| h.active)
        else {
            return;
        };
        // SAFETY: the hierarchy's particles are the island's, which this task holds (caller).
        unsafe { hierarchy.solve(&views.position, first) };
    }

    /// One round of an island's trees, one after the other (they share no movable particle:
    /// see [`tree`](super::tree)). Returns the Newton passes taken.
    ///
    /// # Safety
    /// As for [`Solver::solve_lines_of`].
    unsafe fn solve_trees_of(
        &self,
        views: &Views,
        set: &super::TreeSet,
        island: &Island,
        substep: &Substep,
        first_round: bool,
    ) -> u64 {
        let solve = TreeSolve {
            position: &views.position,
            previous: &views.previous,
            mirror: None,
            lambda: &views.stick_lambda,
            inverse_mass: &self.particles.inverse_mass,
            sticks: &self.sticks,
            inv_h2: 1.0 / (substep.h * substep.h),
            shake: substep.shake,
            first_round,
        };
        let mut passes = 0;
        for tree in &set.trees[range(&island.trees)] {
            let nodes = tree.nodes.start as usize..tree.nodes.end as usize;
            // SAFETY: the tree's nodes, particles and sticks are the island's (the layout
            // matches the topology), which this task holds (caller).
            passes += unsafe {
                let curvature = views.lines.tree_curvature.slice_mut(nodes.clone());
                let more = views.lines.tree_closings.slice_mut(tree.closing_records());
                let nodes = views.lines.trees.slice_mut(nodes);
                solve.solve(set, tree, (nodes, more), curvature)
            } as u64;
        }
        passes
    }

    /// One round of an island's lines (group after group: block Gauss–Seidel over lines), then
    /// its loose sticks. Returns the Newton passes taken.
    ///
    /// # Safety
    /// No other task accesses the island's particles, its sticks' and angle constraints'
    /// multipliers or its lines' scratch while this runs.
    unsafe fn solve_lines_of(
        &self,
        views: &Views,
        islands: &super::Islands,
        island: &Island,
        substep: &Substep,
        first_round: bool,
    ) -> u64 {
        let set = &islands.lines;
        if !island.trees.is_empty() {
            // SAFETY: as for this function (caller).
            return unsafe { self.solve_trees_of(views, &set.trees, island, substep, first_round) };
        }
        let solve = LineSolve {
            position: views.position,
            previous: views.previous,
            mirror: None,
            lambda: views.stick_lambda,
            inverse_mass: &self.particles.inverse_mass,
            sticks: &self.sticks,
            scratch: views.lines,
            inv_h2: 1.0 / (substep.h * substep.h),
            shake: substep.shake,
            first_round,
            alone: island.line_groups.len() == 1
                && set.groups[range(&island.line_groups)]
                    .first()
                    .is_some_and(|group| group.len() == 1)
                && island.loose.is_empty(),
        };
        let mut passes = 0;
        for group in &set.groups[range(&island.line_groups)] {
            for line in &set.lines[range(group)] {
                // SAFETY: the line's particles, sticks and scratch are the island's (the
                // layout matches the topology), which this task holds (caller).
                passes += unsafe { solve.solve(&LineRef::of(line, set)) } as u64;
            }
        }
        for &stick in &set.loose[range(&island.loose)] {
            let sticks = stick as usize..stick as usize + 1;
            // SAFETY: a stick of the island, which this task holds (caller).
            unsafe { self.relax_stick_part(views, substep, sticks, false, SweepOrder::Forward) };
        }
        passes
    }

    /// One large island's relaxation on every thread of `executor`: colour batch after colour
    /// batch, each cut into chunks of [`PARALLEL_CHUNK_STICKS`] that the threads claim from a
    /// shared counter; a thread moves to the next batch once every chunk of this one is done.
    /// No thread ever waits for another to *start* (a late thread finds every chunk claimed and
    /// catches up), so it cannot deadlock on a busy pool, and the chunks — hence the result —
    /// do not depend on the thread count. One hand-off per substep instead of one per batch.
    fn relax_island_parallel(
        &self,
        views: &Views,
        islands: &super::Islands,
        island: &Island,
        substep: &Substep,
        executor: &dyn Executor,
    ) {
        let batches = &islands.batches[range(&island.batches)];
        let has_rest = !island.angles.is_empty() || !island.tethers.is_empty();
        // A hierarchy's coarse passes are the steps before and after the batches, on one thread.
        let coarse = usize::from(island.method == Method::Hierarchy);
        let per_iteration = 2 * coarse + batches.len() + has_rest as usize;
        let round_of = |g: usize| (g / per_iteration) as u32;
        // (Every second round of a symmetric island visits the batches backward.)
        let step_of = |g: usize| match (g % per_iteration).checked_sub(coarse) {
            None => IslandStep::Coarse(0),
            Some(b) if b < batches.len() => {
                let order = order_of(island.symmetric, round_of(g));
                IslandStep::Batch(nth_in(order, batches, b), order)
            }
            Some(b) if b == batches.len() && coarse == 1 => {
                IslandStep::Coarse(AFTER_SWEEP_FROM_LEVEL)
            }
            Some(_) => IslandStep::Rest,
        };
        let steps = per_iteration * substep.iterations as usize;
        let counters = &self.counters.0[..2 * steps];
        for counter in counters {
            counter.store(0, Ordering::Relaxed);
        }
        let chunks_of = |g: usize| match step_of(g) {
            IslandStep::Batch(batch, _) if batch.independent => {
                batch.sticks.len().div_ceil(PARALLEL_CHUNK_STICKS)
            }
            _ => 1,
        };
        let job = |_: usize| {
            for g in 0..steps {
                let chunks = chunks_of(g);
                let (claimed, done) = (&counters[2 * g], &counters[2 * g + 1]);
                loop {
                    let chunk = claimed.fetch_add(1, Ordering::Relaxed) as usize;
                    if chunk >= chunks {
                        break;
                    }
                    // SAFETY: only this step's chunks run now (every thread waits for all of them
                    // before the next step) and each chunk runs once (claimed). The chunks of an
                    // independent batch share no particle or stick (the layout matches the
                    // topology: `check_layout`); any other step is one chunk. The island is
                    // disjoint from every other (small islands run after this call returns).
                    unsafe {
                        match step_of(g) {
                            IslandStep::Coarse(first) => {
                                self.solve_hierarchy_of(views, islands, island, first)
                            }
                            IslandStep::Batch(batch, order) => {
                                let sticks = part(range(&batch.sticks), chunk, chunks);
                                self.relax_stick_part(views, substep, sticks, batch.rigid, order);
                            }
                            IslandStep::Rest => self.relax_rest_of(views, island, substep),
                        }
                    }
                    // (Release: the next batch's claimers see these positions.)
                    done.fetch_add(1, Ordering::Release);
                }
                let mut spins = 0u32;
                while (done.load(Ordering::Acquire) as usize) < chunks {
                    spins += 1;
                    if spins < 4096 {
                        std::hint::spin_loop();
                    } else {
                        std::thread::yield_now();
                    }
                }
            }
        };
        // The job ignores its index (threads claim chunks from the counters), so an executor
        // that runs it twice at once only adds a helper; one that never runs it is caught here.
        executor.run(executor.threads(), &job);
        if let Some(last) = steps.checked_sub(1) {
            let done = counters[2 * last + 1].load(Ordering::Acquire) as usize;
            assert!(
                done >= chunks_of(last),
                "the Executor returned before running its jobs"
            );
        }
    }

    /// One sweep over a colour batch.
    ///
    /// # Safety
    /// No other task accesses the particles of the batch's sticks, or their multipliers, while
    /// this runs.
    unsafe fn relax_sticks_of(
        &self,
        views: &Views,
        substep: &Substep,
        batch: &super::Batch,
        order: SweepOrder,
    ) {
        let sticks = range(&batch.sticks);
        // SAFETY: this task holds the batch (caller).
        unsafe { self.relax_stick_part(views, substep, sticks, batch.rigid, order) };
    }

    /// One sweep over the sticks in `sticks`.
    ///
    /// # Safety
    /// No other task accesses the particles of these sticks, or their multipliers, while this
    /// runs.
    unsafe fn relax_stick_part(
        &self,
        views: &Views,
        substep: &Substep,
        sticks: Range<usize>,
        rigid: bool,
        order: SweepOrder,
    ) {
        // SAFETY: this task holds these sticks (caller).
        unsafe {
            relax_stick_range(
                &views.position,
                &self.particles.inverse_mass,
                &self.sticks,
                &views.stick_lambda,
                sticks,
                1.0 / (substep.h * substep.h),
                substep.accumulate,
                rigid,
                order,
            );
        }
    }

    /// An island's angle constraints and tethers (one sweep).
    ///
    /// # Safety
    /// No other task accesses the island's particles or its angle constraints' multipliers
    /// while this runs.
    unsafe fn relax_rest_of(&self, views: &Views, island: &Island, substep: &Substep) {
        let inverse_mass = &self.particles.inverse_mass;
        if !island.angles.is_empty() {
            // SAFETY: the island's constraints join its own particles (the layout matches the
            // topology), which this task holds (caller).
            unsafe {
                relax_angle_range(
                    &views.position,
                    inverse_mass,
                    &self.angles,
                    &views.angle_lambda,
                    range(&island.angles),
                    1.0 / (substep.h * substep.h),
                    substep.accumulate,
                )
            };
        }
        if !island.tethers.is_empty() {
            // SAFETY: as above (tethers are rebuilt from the solver's own sticks).
            unsafe {
                relax_tether_range(
                    &views.position,
                    inverse_mass,
                    &self.tethers,
                    range(&island.tethers),
                )
            };
        }
    }

    /// Falls back to one island in array order when the islands do not describe the current
    /// topology ([`Solver::is_organized`]): every phase checks, because the parallel paths
    /// trust the islands (disjoint) and the batches marked independent (no shared particle).
    fn check_layout(&mut self) {
        if !self.is_organized() {
            self.use_one_island();
        }
    }

    /// Moves the arrays jobs write out of the solver (so the rest can be shared read-only). The
    /// islands stay, read in place: moving them out and back (about 0.5 KB, three times per
    /// substep) was 27 % of a lone pendulum's instructions (callgrind, 20 000 steps at 8 × 1:
    /// 618 → 449 million).
    fn take(&mut self) -> Taken {
        Taken {
            position: std::mem::take(&mut self.particles.position),
            previous: std::mem::take(&mut self.particles.previous),
            stick_lambda: std::mem::take(&mut self.sticks.lambda),
            angle_lambda: std::mem::take(&mut self.angles.lambda),
            lines: std::mem::take(&mut self.line_scratch),
        }
    }

    fn give_back(&mut self, taken: Taken) {
        self.particles.position = taken.position;
        self.particles.previous = taken.previous;
        self.sticks.lambda = taken.stick_lambda;
        self.angles.lambda = taken.angle_lambda;
        self.line_scratch = taken.lines;
    }
}

fn views(taken: &mut Taken) -> Views<'_> {
    Views {
        position: SharedSlice::new(&mut taken.position),
        previous: SharedSlice::new(&mut taken.previous),
        stick_lambda: SharedSlice::new(&mut taken.stick_lambda),
        angle_lambda: SharedSlice::new(&mut taken.angle_lambda),
        lines: LineViews::new(&mut taken.lines),
    }
}

/// Runs `f(slots, substep)` over the particles of every due island, each range cut into
/// near-equal parts across jobs when there are enough particles for every thread. Islands next
/// to each other in the particle arrays that take the same substep are passed as one range
/// (`f` treats every particle alike): a scene of 1000 pendulums made 1000 calls per substep.
fn for_due_particles(
    islands: &[Island],
    global: &GlobalSubstep,
    executor: &dyn Executor,
    f: &(dyn Fn(Range<usize>, &Substep) + Sync),
) {
    // (One thread: one job, and no pass to size the work.)
    let work: usize = if executor.threads() > 1 {
        due(islands, global)
            .map(|(island, _)| len(&island.particles))
            .sum()
    } else {
        0
    };
    let jobs = job_count(executor, work, PARALLEL_MIN_PARTICLES_PER_JOB);
    let job = |job: usize| {
        let mut run: Option<(Range<usize>, Substep)> = None;
        for (island, substep) in due(islands, global) {
            let slots = range(&island.particles);
            match &mut run {
                Some((joined, same)) if joined.end == slots.start && *same == substep => {
                    joined.end = slots.end;
                }
                _ => {
                    if let Some((joined, substep)) = run.replace((slots, substep)) {
                        f(part(joined, job, jobs), &substep);
                    }
                }
            }
        }
        if let Some((joined, substep)) = run {
            f(part(joined, job, jobs), &substep);
        }
    };
    run_jobs(executor, jobs, &job);
}

/// Runs `job(0)`, …, `job(jobs − 1)` on `executor`, each exactly once *whatever the executor
/// does*: [`Executor`] is a safe trait, so the solver does not trust the indices it passes.
/// Every call the executor makes claims job indices from one atomic counter until none is
/// left — an executor that runs a job twice (even at the same time), or runs job 0 only, still
/// runs each index once, so two threads never work on the same particles. An executor that
/// returns without calling the job at all panics (the work would be silently skipped).
fn run_jobs(executor: &dyn Executor, jobs: usize, job: &(dyn Fn(usize) + Sync)) {
    if jobs <= 1 {
        (0..jobs).for_each(job);
        return;
    }
    let next = AtomicUsize::new(0);
    let finished = AtomicUsize::new(0);
    executor.run(jobs, &|_| {
        loop {
            let claimed = next.fetch_add(1, Ordering::Relaxed);
            if claimed >= jobs {
                break;
            }
            job(claimed);
            // (Release: the caller sees the job's writes once it has seen the count.)
            finished.fetch_add(1, Ordering::Release);
        }
    });
    assert_eq!(
        finished.load(Ordering::Acquire),
        jobs,
        "the Executor returned before running its jobs"
    );
}

/// The islands that take a substep now, with their substep contexts (a symmetric island's
/// iterations in pairs, see [`GlobalSubstep::for_island`]).
/// Whether `island` is solved by lines and holds one of `particles` (sorted).
fn lines_holding(island: &Island, particles: &[u32]) -> bool {
    let slots = range(&island.particles);
    let first = particles.partition_point(|&p| (p as usize) < slots.start);
    island.method == Method::Lines
        && particles
            .get(first)
            .is_some_and(|&p| slots.contains(&(p as usize)))
}

fn due<'a>(
    islands: &'a [Island],
    global: &'a GlobalSubstep,
) -> impl Iterator<Item = (&'a Island, Substep)> + 'a {
    // (Islands without settings of their own all take the step's substep: computed once, not
    // once per island — its division and `exp` were most of the cost of walking the islands.)
    // (So are those of islands that take `line_substeps`, and of islands that step with the
    // bodies, `Island::steps_with_bodies`.)
    let configured = |own| global.for_config(super::islands::configured(&global.config, own));
    let shared = configured(None);
    let own_of = |substeps| IslandSettings {
        substeps,
        iterations: global.config.iterations,
    };
    let line_count = line_substep_count(&global.config);
    let line_own = line_count.map(own_of);
    let lines = line_own.and_then(|own| configured(Some(own)));
    let bodies_own = own_of(global.count);
    let more = global.count > global.config.substeps;
    let with_bodies = more.then(|| configured(Some(bodies_own)));
    islands.iter().filter_map(move |island| {
        let substep = match island.own_settings_for(&global.config, line_count) {
            _ if island.asleep => None,
            None => shared,
            Some(own) if Some(own) == line_own => lines,
            Some(own) if own == bodies_own && with_bodies.is_some() => with_bodies.flatten(),
            Some(own) => configured(Some(own)),
        };
        substep.map(|s| (island, global.paired_if(island.symmetric, s)))
    })
}

/// Re-expresses `island`'s Verlet state for a substep of `h` (from its own, or `unset` where it
/// has none yet; see [`resubstep`]) and records it.
fn resubstep_island(
    particles: &mut Particles,
    island: &mut Island,
    gravity: DVec3,
    (unset, h): (f64, f64),
) {
    let from = island.state_substep_or(unset);
    if from != h {
        resubstep(particles, range(&island.particles), gravity, from, h);
    }
    island.state_substep = h;
}

pub(crate) fn range(r: &Range<u32>) -> Range<usize> {
    r.start as usize..r.end as usize
}

fn len(r: &Range<u32>) -> usize {
    (r.end - r.start) as usize
}
