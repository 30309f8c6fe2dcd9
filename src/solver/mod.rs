//! The solver core: dense arrays and plain functions, no Bevy types.
//!
//! # Algorithm
//!
//! This is Jakobsen's "Advanced Character Physics" (GDC 2001) — Verlet integration followed by
//! iterative relaxation of stick constraints — written as what it is equivalent to, Position
//! Based Dynamics, with the two improvements that make it accurate:
//!
//! * **XPBD compliance** (Macklin, Müller, Chentanez, "XPBD", MIG 2016): each stick has a
//!   compliance `α` (inverse stiffness, physical units) instead of a per-iteration stiffness
//!   factor, so a material behaves the same at any iteration count and timestep.
//! * **Substeps** (Macklin et al., "Small Steps in Physics Simulation", SCA 2019): the fixed step
//!   is split into `S` substeps, each running integrate → relax × N → constrain. For the same
//!   number of projections, small steps leave far less stretch (error ∝ S⁻² instead of ∝ N⁻¹)
//!   and lose far less energy than iterations.
//!
//! One fixed step of length `Δt` with `S` substeps of `h = Δt/S`:
//!
//! ```text
//! for s in 1..=S:
//!     integrate   x' = x + (x − x*)·exp(−c·h) + g·h²,  x* = x      (movable particles)
//!     pins        x = lerp(target_from, target_to, s/S)              (kinematic, w = 0)
//!     relax × N   sticks: lines solved exactly (chains, trees) or    Gauss–Seidel, in place
//!                 swept (XPBD; with a hierarchy: coarse levels
//!                 first); angles (XPBD), tethers (one-sided)
//!     constrain   boxes, planes, spheres: project out, restitution and friction
//! tear            sticks whose post-solve strain exceeds their threshold
//! ```
//!
//! # Solver 2: lines
//!
//! Gauss–Seidel carries a correction one or two sticks per sweep and a projection at the end of
//! a step damps like backward Euler. Islands that are chains or trees are therefore covered by
//! [`lines`] and each line is solved exactly per Newton pass ([`direct`]: a tridiagonal solve,
//! Baraff 1996; Deul et al. 2018), correcting along the sticks' start-of-substep directions
//! (SHAKE, Ryckaert et al. 1977), which keeps energy. [`Method`] (per solver, per island) picks
//! lines or sweeps; [`Method::Auto`] picks by the island's shape in [`Solver::organize`].
//! [`Method::Hierarchy`] (picked for large meshes hung from a few pins) sweeps a mesh between
//! passes over coarse levels of long-range sticks along it ([`hierarchy`], after Müller 2008),
//! which carry a cloth's load to a few pins at once.
//!
//! Pinned particles have inverse mass 0 (Jakobsen: "infinite mass"), so constraints move only the
//! free end and two pins never fight. Everything is `f64`: see [`Particles`] for why.
//!
//! # Scale
//!
//! [`Solver::organize`] (the Bevy layer calls it on every topology change) splits the particles
//! into [`islands`] — groups connected by sticks — and reorders the arrays so each island is a
//! contiguous range; large mesh-like islands get their sticks sorted into [`colouring`] batches
//! (sticks that share no particle), i.e. Gauss–Seidel by colour. Islands can then be stepped
//! with their own settings ([`IslandSettings`]), skipped while asleep ([`Sleep`]), and spread
//! over threads by an [`Executor`] ([`Solver::step_with`]) with bit-identical results.
//!
//! ```
//! use bevy_verlet_physics::solver::{Solver, StepConfig, StickKind};
//! use glam::DVec3;
//! // A pendulum: a pinned pivot and a 1 m stick.
//! let mut solver = Solver::default();
//! let pivot = solver.add_particle(DVec3::ZERO, 0.0);
//! let bob = solver.add_particle(DVec3::X, 1.0);
//! solver.pin(pivot, DVec3::ZERO);
//! solver.sticks.push([pivot, bob], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
//! let config = StepConfig { substeps: 16, ..StepConfig::default() };
//! for _ in 0..64 {
//!     solver.step(&config);
//! }
//! let length = (solver.particles.position[1] - solver.particles.position[0]).length();
//! assert!((length - 1.0).abs() < 1e-9);
//! ```

mod angles;
pub mod attachments;
pub mod bodies;
pub mod collider_grid;
mod colliders;
pub mod colouring;
pub mod contacts;
pub mod direct;
pub mod external;
pub mod geodesic;
pub mod hierarchy;
mod integrate;
pub mod islands;
mod kkt;
pub mod line_substeps;
pub mod lines;
pub mod lone_stick;
pub mod parallel;
mod particles;
mod pins;
mod shared;
mod step;
mod sticks;
mod sym3;
pub mod symmetric;
mod tear;
mod tethers;
pub mod tree;

pub use angles::{Angles, relax_angles};
pub use attachments::{
    Attachment, AttachmentScratch, EXACT_SHARING_UP_TO, lump, release, relump, settle_pulls,
};
pub use bodies::{Body, Pose};
pub use colliders::{Collider, Shape, constrain};
pub use colouring::Batch;
pub use contacts::{ContactParticle, ContactShape, ExternalCollider, Layers, collide_particle};
pub use external::{COUPLING_CONTRACTION, COUPLING_ROUNDS, COUPLING_TOLERANCE, External};
pub use hierarchy::{Hierarchy, HierarchySet};
pub use integrate::{consistent_previous, integrate, resubstep};
pub use islands::{
    Island, IslandSettings, Islands, ReadOnly, Reorder, Sleep, substeps_aligned_with,
};
pub use lines::{Line, LineSet, Method};
pub use parallel::{Executor, ScopedThreads, Serial};
pub use particles::Particles;
pub use pins::Pins;
pub use step::GlobalSubstep;
pub use sticks::{StickKind, Sticks, relax_sticks};
pub use symmetric::SYMMETRIC_MASS_RATIO;
pub use tear::tear;
pub use tethers::{DEFAULT_TETHER_ANCHORS, MAX_TETHER_ANCHORS, Tethers, relax_tethers};
pub use tree::{MAX_CLOSINGS, Tree, TreeSet};

use glam::DVec3;

/// Settings of one fixed step.
///
/// ```
/// use bevy_verlet_physics::solver::StepConfig;
/// let config = StepConfig { substeps: 8, iterations: 1, ..StepConfig::default() };
/// assert_eq!(config.substep(), config.timestep / 8.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepConfig {
    /// Length of the fixed step in seconds.
    pub timestep: f64,
    /// Substeps per fixed step (≥ 1).
    pub substeps: u32,
    /// Relaxation iterations per substep (≥ 1).
    pub iterations: u32,
    /// Gravity (acceleration of every movable particle).
    pub gravity: DVec3,
    /// Linear damping rate `c` in 1/s: velocities decay as `exp(−c·t)`. `0` = none.
    pub damping: f64,
    /// When islands fall asleep (`None`: never).
    pub sleep: Option<Sleep>,
    /// Islands solved by lines correct along each stick's direction at the start of the
    /// substep (SHAKE, energy-conserving) instead of its current direction (the XPBD
    /// projection, which damps). See [`direct`].
    pub shake: bool,
    /// Islands solved by sweeps whose heaviest movable particle is more than this many times
    /// their lightest run their iterations in forward–backward pairs (symmetric Gauss–Seidel:
    /// a forward sweep alone can grow without bound there, see [`symmetric`]). Default
    /// [`SYMMETRIC_MASS_RATIO`] (8); `f64::INFINITY` (or NaN): never; below 1 (`0`): every swept
    /// island, equal masses too.
    pub symmetric_mass_ratio: f64,
    /// Substeps of tree-shaped islands solved by lines — chains, ropes, pendulums and trees
    /// under [`Method::Auto`] ([`Island::takes_line_substeps`]) — that have no
    /// [`IslandSettings`] of their own; `None`: the step's `substeps`, as for every other
    /// island; `Some(0)` is taken as 1. Their solve is exact at any substep count, so fewer
    /// substeps cost them no stretch, only accuracy in time; in a step where they are hit hard
    /// they take `substeps` ([`line_substeps`]), and a step longer than 1/64 s gives them more,
    /// so that none is longer than that, up to `substeps`
    /// ([`line_substeps::line_substep_count`]). At 2 the report's pendulums, double pendulum
    /// and hanging chain take a quarter of the time of 8 substeps of lines, the swinging chains
    /// about half (the crate README, "Configuration"). Iterations stay the step's.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{Solver, StepConfig, StickKind};
    /// use glam::DVec3;
    /// let mut solver = Solver::default();
    /// let pin = solver.add_particle(DVec3::ZERO, 0.0);
    /// solver.pin(pin, DVec3::ZERO);
    /// let bob = solver.add_particle(DVec3::X, 1.0);
    /// solver.sticks.push([pin, bob], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
    /// solver.organize();
    /// // Cloth and ragdolls swept at 8 substeps, ropes and chains solved exactly at 2.
    /// let config = StepConfig { line_substeps: Some(2), ..StepConfig::default() };
    /// solver.step(&config);
    /// assert_eq!(solver.state_substep_of(bob), Some(config.timestep / 2.0));
    /// ```
    pub line_substeps: Option<u32>,
}

impl Default for StepConfig {
    fn default() -> Self {
        Self {
            timestep: 1.0 / 64.0,
            substeps: 8,
            iterations: 1,
            gravity: DVec3::new(0.0, -9.81, 0.0),
            damping: 0.0,
            sleep: None,
            shake: true,
            symmetric_mass_ratio: SYMMETRIC_MASS_RATIO,
            line_substeps: None,
        }
    }
}

impl StepConfig {
    /// Length of one substep.
    pub fn substep(&self) -> f64 {
        self.timestep / self.substeps.max(1) as f64
    }

    /// The context of substep `index` (1-based) of this step.
    pub fn substep_context(&self, index: u32) -> Substep {
        let h = self.substep();
        Substep {
            h,
            index,
            count: self.substeps.max(1),
            iterations: self.iterations.max(1),
            gravity: self.gravity,
            damping_factor: (-self.damping * h).exp(),
            // Multipliers matter only when a substep iterates more than once.
            accumulate: self.iterations > 1,
            shake: self.shake,
        }
    }
}

/// Everything one substep needs (see [`StepConfig::substep_context`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Substep {
    /// Substep length in seconds.
    pub h: f64,
    /// 1-based index of this substep in the fixed step.
    pub index: u32,
    /// Substeps in the fixed step.
    pub count: u32,
    /// Relaxation iterations.
    pub iterations: u32,
    /// Gravity.
    pub gravity: DVec3,
    /// Per-substep velocity factor `exp(−c·h)`.
    pub damping_factor: f64,
    /// Whether XPBD multipliers accumulate across iterations.
    pub accumulate: bool,
    /// Lines correct along start-of-substep directions (see [`StepConfig::shake`]).
    pub shake: bool,
}

/// Everything the solver simulates, in dense arrays.
///
/// The arrays are public: build them directly or with the helpers, step with [`Solver::step`],
/// read positions from [`Particles::position`]. The Bevy layer keeps one `Solver` and rebuilds
/// its topology only when entities change.
#[derive(Clone, Debug, Default)]
pub struct Solver {
    /// Particle state.
    pub particles: Particles,
    /// Distance constraints.
    pub sticks: Sticks,
    /// Angle constraints.
    pub angles: Angles,
    /// Pinned (kinematic) particles.
    pub pins: Pins,
    /// Long-range attachments, derived from the topology (see [`Solver::rebuild_tethers`]).
    pub tethers: Tethers,
    /// Which particles want tethers.
    pub tethered: Vec<bool>,
    /// World colliders.
    pub colliders: Vec<Collider>,
    /// Indices of the sticks torn by the last [`Solver::step`].
    pub torn: Vec<u32>,
    /// Islands, their colour batches and sleep states (see [`Solver::organize`]): read-only
    /// lists, used by the step only while they match the topology ([`Solver::is_organized`]).
    pub islands: Islands,
    /// Per-island overrides: the island containing the particle uses these settings (applied
    /// by [`Solver::organize`]).
    pub island_settings: Vec<(u32, IslandSettings)>,
    /// How islands are solved unless overridden (applied by [`Solver::organize`]): by default
    /// [`Method::Auto`] — chains and trees by lines, large meshes without tethers hung from a few
    /// pins with a hierarchy, everything else by sweeps.
    pub method: Method,
    /// Per-island method overrides: the island containing the particle is solved this way
    /// (applied by [`Solver::organize`]).
    pub island_methods: Vec<(u32, Method)>,
    /// Particle slots attached to another engine's bodies in this step (set by
    /// [`External::begin_step`]; in any order, a slot that is no particle is ignored): their
    /// islands step with the bodies — the step's substeps, not [`StepConfig::line_substeps`]
    /// (see [`line_substeps`]), or more where another island's override takes more, as the
    /// bodies do ([`Island::steps_with_bodies`]) — unless they have an override of their own.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{Solver, StepConfig, StickKind};
    /// use glam::DVec3;
    /// // Two pendulums; the bob of the second is tied to a body.
    /// let mut solver = Solver::default();
    /// let mut bobs = Vec::new();
    /// for x in [0.0, 5.0] {
    ///     let pin = solver.add_particle(DVec3::X * x, 0.0);
    ///     solver.pin(pin, DVec3::X * x);
    ///     let bob = solver.add_particle(DVec3::X * (x + 1.0), 1.0);
    ///     solver.sticks.push([pin, bob], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
    ///     bobs.push(bob);
    /// }
    /// solver.organize();
    /// let config = StepConfig { line_substeps: Some(2), ..StepConfig::default() };
    /// solver.attached = vec![99, bobs[1]]; // (99 is no particle)
    /// solver.step(&config);
    /// assert_eq!(solver.state_substep_of(bobs[0]), Some(config.timestep / 2.0));
    /// assert_eq!(solver.state_substep_of(bobs[1]), Some(config.timestep / 8.0));
    /// ```
    pub attached: Vec<u32>,
    /// Scratch of [`Solver::organize`]'s line cover.
    pub(crate) line_builder: lines::LineBuilder,
    /// Scratch of the line solves.
    pub(crate) line_scratch: direct::LineScratch,
    /// Newton passes of every line solve so far (see [`Solver::line_passes`]).
    pub(crate) line_passes: direct::PassCounter,
    /// Particles whose islands must wake before the next step (see [`Solver::wake`]).
    pub(crate) wake_requests: Vec<u32>,
    /// The step in progress (set by [`Solver::begin_step`]).
    pub(crate) current: Option<StepConfig>,
    /// The previous step's settings and colliders (a change wakes every island).
    pub(crate) last_config: Option<StepConfig>,
    pub(crate) last_colliders: Vec<Collider>,
    /// Scratch counters of the parallel relaxation.
    pub(crate) counters: parallel::Counters,
    /// Sticks were cut since the tethers were built: rebuild them before the next step.
    pub(crate) tethers_stale: bool,
    /// See [`Solver::verlet_substep`].
    pub(crate) verlet_substep: Option<f64>,
    /// The crate's colliders by place (rebuilt when they change).
    pub(crate) collider_grid: collider_grid::ColliderGrid,
}

impl Solver {
    /// Removes everything, keeping the allocations.
    pub fn clear(&mut self) {
        self.particles.clear();
        self.sticks.clear();
        self.angles.clear();
        self.pins.clear();
        self.tethers.clear();
        self.tethered.clear();
        self.colliders.clear();
        self.torn.clear();
        self.island_settings.clear();
        self.island_methods.clear();
        self.wake_requests.clear();
        self.attached.clear();
        self.tethers_stale = false;
        self.islands.list.0.clear();
        self.islands.batches.0.clear();
        self.islands.lines.clear();
    }

    /// Adds a particle at rest at `position` and returns its index. (For a particle that must
    /// start moving, push to [`Solver::particles`] with a previous position from
    /// [`consistent_previous`].)
    pub fn add_particle(&mut self, position: DVec3, inverse_mass: f64) -> u32 {
        self.tethered.push(false);
        self.particles
            .push(position, position, inverse_mass, 0.0, 0)
    }

    /// Pins particle `i` at `target`: it becomes kinematic (inverse mass 0) and is placed there.
    pub fn pin(&mut self, i: u32, target: DVec3) {
        self.particles.inverse_mass[i as usize] = 0.0;
        self.particles.position[i as usize] = target;
        self.particles.previous[i as usize] = target;
        self.pins.push(i, target);
    }

    /// Recomputes the tethers of the particles flagged in [`Solver::tethered`].
    pub fn rebuild_tethers(&mut self) {
        self.tethers_stale = false;
        let organized = self.is_organized();
        self.tethered.resize(self.particles.len(), false);
        self.tethers
            .rebuild(&self.particles, &self.sticks, &self.pins, &self.tethered);
        self.assign_tether_ranges();
        // Islands that matched the topology still do if every tether stays in one island (a
        // torn stick made whole again could join two).
        if organized && self.tethers_within_islands() {
            self.islands.stamps = self.stamps();
        }
    }

    /// `true` when every tether joins two particles of one island.
    fn tethers_within_islands(&self) -> bool {
        let islands = &self.islands;
        let tethers = &self.tethers;
        (0..tethers.len()).all(|i| {
            let island = islands.of_particle(tethers.particle[i]);
            island.is_some() && island == islands.of_particle(tethers.anchor[i])
        })
    }

    /// The last step's global substep length (s, [`StepConfig::substep`]), `None` before the
    /// first step ([`Solver::clear`] keeps it: states written after it keep their meaning). A particle's Verlet state `x − x*` is its velocity times the substep of its
    /// island ([`Solver::state_substep_of`]); a state written for no island yet (a new
    /// particle) or after [`Solver::organize`] refers to this one (to the first step's before
    /// the first step). Each step re-expresses every island's states for the substeps it takes
    /// (see [`resubstep`]), so a new `StepConfig::substeps`, timestep or island count keeps
    /// every velocity.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{Solver, StepConfig};
    /// use glam::DVec3;
    /// let mut solver = Solver::default();
    /// let p = solver.add_particle(DVec3::ZERO, 1.0) as usize;
    /// let mut config = StepConfig { gravity: DVec3::ZERO, ..StepConfig::default() };
    /// solver.particles.previous[p] = DVec3::new(-config.substep(), 0.0, 0.0); // 1 m/s
    /// solver.organize();
    /// solver.step(&config);
    /// assert_eq!(solver.verlet_substep(), Some(config.substep()));
    /// config.substeps = 2; // fewer, longer substeps: still 1 m/s
    /// let before = solver.particles.position[p].x;
    /// solver.step(&config);
    /// let speed = (solver.particles.position[p].x - before) / config.timestep;
    /// assert!((speed - 1.0).abs() < 1e-9);
    /// ```
    pub fn verlet_substep(&self) -> Option<f64> {
        self.verlet_substep
    }

    /// The substep length (s) particle `slot`'s Verlet state `x − x*` refers to: its island's
    /// last substep, else [`Solver::verlet_substep`]; `None` before the first step. Write its
    /// `previous` for this substep to give it a velocity.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{IslandSettings, Solver, StepConfig};
    /// use glam::DVec3;
    /// let mut solver = Solver::default();
    /// let p = solver.add_particle(DVec3::ZERO, 1.0);
    /// solver.island_settings.push((p, IslandSettings { substeps: 2, iterations: 1 }));
    /// solver.organize();
    /// let config = StepConfig::default();
    /// solver.step(&config);
    /// assert_eq!(solver.state_substep_of(p), Some(config.timestep / 2.0));
    /// ```
    pub fn state_substep_of(&self, slot: u32) -> Option<f64> {
        let island = self
            .islands
            .of_particle(slot)
            .map(|k| &self.islands.list[k]);
        match island {
            Some(island) if island.state_substep > 0.0 => Some(island.state_substep),
            _ => self.verlet_substep,
        }
    }

    /// Re-expresses every island's Verlet states for [`Solver::verlet_substep`] (velocities
    /// kept) and forgets the islands' own substeps: before the islands are rebuilt, so that
    /// particles from islands of different counts meet in one convention.
    pub(crate) fn states_to_verlet_substep(&mut self) {
        let (Some(to), Some(config)) = (self.verlet_substep, self.last_config) else {
            return;
        };
        let particles = &mut self.particles;
        for island in &mut self.islands.list.0 {
            let from = std::mem::take(&mut island.state_substep);
            let slots = island.particles.start as usize..island.particles.end as usize;
            if !island.asleep && slots.end <= particles.len() {
                resubstep(particles, slots, config.gravity, from, to);
            }
        }
    }

    /// How many Newton passes the line solves have taken since the solver was made (a cost
    /// figure: a converged line takes none, a hanging chain about one per substep).
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Solver;
    /// assert_eq!(Solver::default().line_passes(), 0);
    /// ```
    pub fn line_passes(&self) -> u64 {
        self.line_passes
            .0
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    /// One relaxation sweep over every constraint, whole arrays in order, ignoring islands:
    /// sticks, then angles, then tethers.
    pub fn relax(&mut self, h: f64, accumulate: bool) {
        relax_sticks(&mut self.particles, &mut self.sticks, h, accumulate);
        if !self.angles.is_empty() {
            relax_angles(&mut self.particles, &mut self.angles, h, accumulate);
        }
        if !self.tethers.is_empty() {
            relax_tethers(&mut self.particles, &self.tethers);
        }
    }
}

#[cfg(test)]
mod tests;
