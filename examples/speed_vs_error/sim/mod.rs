//! The measured half of the report: scenes with known answers, run on the solver core only.
//!
//! A [`Setting`] says how one 64 Hz fixed step spends its budget (substeps × iterations), which
//! constraint law compliant sticks follow, and whether tethers are on. A [`Scene`] builds a
//! [`Solver`] for a setting, runs it, and returns its error metrics against an analytic or
//! semi-analytic reference. Nothing here knows about timing, tables or plots, so the integration
//! test `tests/speed_vs_error.rs` includes this module as is and asserts on the same numbers.

pub mod ballistic;
pub mod catenary;
pub mod cloth;
pub mod double_pendulum;
pub mod f32_reference;
pub mod heavy_tip;
pub mod loaded;
pub mod measure;
pub mod pendulum;
pub mod reference;
pub mod spring;
pub mod swinging;

use bevy_verlet_physics::Stiffness;
use bevy_verlet_physics::solver::{Method, Serial, Solver, StepConfig, StickKind};
use glam::DVec3;

/// Bevy's default fixed step (64 Hz), used by every scene.
pub const TIMESTEP: f64 = 1.0 / 64.0;

/// How a setting spends its budget; one series of the plot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Family {
    /// The seeds' style: one substep per fixed step, `N` relaxation iterations.
    Iterations,
    /// `S` substeps per fixed step, each with this many iterations.
    Substeps(u32),
    /// `S` substeps per fixed step, sticks solved by lines (direct solve, SHAKE): the solver's
    /// [`Method::Lines`] for every island.
    Lines,
    /// `S` substeps per fixed step, one sweep each after a pass over coarse levels: the
    /// solver's [`Method::Hierarchy`] for every island.
    Hierarchy,
}

/// How compliant (soft) sticks are solved. Rigid sticks (compliance 0) are the same under both.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Law {
    /// XPBD: the compliance is a material constant, multipliers accumulate across iterations.
    Xpbd,
    /// Plain PBD, as in the seeds: every projection removes the fraction `k` of the error,
    /// whatever the step and the iteration count.
    Plain,
}

/// One point of the sweep.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Setting {
    /// The series this setting belongs to.
    pub family: Family,
    /// Substeps per fixed step.
    pub substeps: u32,
    /// Relaxation iterations per substep.
    pub iterations: u32,
    /// Long-range attachments from every free particle to its nearest pin.
    pub tethers: bool,
    /// Law of compliant sticks.
    pub law: Law,
    /// How the solver solves its islands ([`Method::Sweep`] unless [`Family::Lines`] or
    /// [`Family::Hierarchy`]).
    pub method: Method,
}

impl Setting {
    /// The seeds' style: 1 substep × `iterations`.
    pub fn seed(iterations: u32) -> Self {
        Self {
            family: Family::Iterations,
            substeps: 1,
            iterations,
            tethers: false,
            law: Law::Xpbd,
            method: Method::Sweep,
        }
    }

    /// `substeps` × `iterations`.
    pub fn substeps(substeps: u32, iterations: u32) -> Self {
        Self {
            family: Family::Substeps(iterations),
            substeps,
            iterations,
            tethers: false,
            law: Law::Xpbd,
            method: Method::Sweep,
        }
    }

    /// `substeps` × 1, solved by lines.
    pub fn lines(substeps: u32) -> Self {
        Self {
            family: Family::Lines,
            method: Method::Lines,
            ..Self::substeps(substeps, 1)
        }
    }

    /// `substeps` × 1, each sweep after a pass over the island's coarse levels.
    pub fn hierarchy(substeps: u32) -> Self {
        Self {
            family: Family::Hierarchy,
            method: Method::Hierarchy,
            ..Self::substeps(substeps, 1)
        }
    }

    /// The same setting with tethers on.
    pub fn with_tethers(self) -> Self {
        Self {
            tethers: true,
            ..self
        }
    }

    /// The same setting with another law.
    pub fn with_law(self, law: Law) -> Self {
        Self { law, ..self }
    }

    /// Projections per constraint per fixed step (`S × N`).
    pub fn budget(&self) -> u32 {
        self.substeps * self.iterations
    }

    /// Substep length in seconds.
    pub fn h(&self) -> f64 {
        TIMESTEP / self.substeps as f64
    }

    /// A short label such as `8x1`, `1x16 +T` or `8x4 plain`.
    pub fn label(&self) -> String {
        let mut label = format!("{}x{}", self.substeps, self.iterations);
        if self.tethers {
            label.push_str(" +T");
        }
        if self.law == Law::Plain {
            label.push_str(" plain");
        }
        if self.method == Method::Lines {
            label.push_str(" lines");
        }
        if self.method == Method::Hierarchy {
            label.push_str(" hier");
        }
        label
    }

    /// The solver configuration of this setting.
    pub fn config(&self, gravity: DVec3, damping: f64) -> StepConfig {
        StepConfig {
            timestep: TIMESTEP,
            substeps: self.substeps,
            iterations: self.iterations,
            gravity,
            damping,
            sleep: None,
            shake: true,
            // Sweeps forward only, the baseline the report has measured since its first run
            // (the crate sweeps islands whose masses differ more than 8× forward and back:
            // `solver::symmetric`; the heavy-tip and loaded soft chains here would be).
            symmetric_mass_ratio: f64::INFINITY,
            // (Each scene is one island: a setting's substeps are its own.)
            line_substeps: None,
        }
    }
}

/// Runs one fixed step exactly as [`Solver::step`] does (integrate → relax × N → constrain per
/// substep, then finish), calling `observe(solver, t)` after every substep with the time `t` since
/// the start of the fixed step. Under [`Law::Plain`] the multipliers are never accumulated, so each
/// projection applies its stick's compliance afresh: that is plain PBD stiffness (see
/// [`Material::compliance`]).
pub fn step(
    solver: &mut Solver,
    setting: &Setting,
    config: &StepConfig,
    mut observe: impl FnMut(&Solver, f64),
) {
    let plain = setting.law == Law::Plain;
    // (Sweep settings step the scene's solver as built, unorganized: one island in order.)
    if setting.method != Method::Sweep && solver.method != setting.method {
        use_method(solver, setting.method);
    }
    solver.step_observed(config, plain, &Serial, |solver, substep| {
        observe(
            solver,
            substep.index as f64 * config.timestep / substep.count as f64,
        )
    });
}

/// Switches `solver` to `method` (organizing it, see [`organize_in_place`]).
pub fn use_method(solver: &mut Solver, method: Method) {
    solver.method = method;
    organize_in_place(solver);
}

/// Organizes `solver` as the plugin does, which must keep every particle where it is: the
/// scenes measure particles by index.
pub fn organize_in_place(solver: &mut Solver) {
    let reorder = solver.organize();
    assert!(
        reorder
            .particles
            .iter()
            .enumerate()
            .all(|(new, &old)| new == old as usize),
        "organizing moved particles: the scene's indices would be wrong"
    );
}

/// Runs `steps` fixed steps without observing anything.
pub fn run(solver: &mut Solver, setting: &Setting, config: &StepConfig, steps: usize) {
    for _ in 0..steps {
        step(solver, setting, config, |_, _| {});
    }
}

/// Fixed steps in `seconds` of simulated time (rounded to the nearest step).
pub fn steps_in(seconds: f64) -> usize {
    (seconds / TIMESTEP).round() as usize
}

/// Constraint projections per fixed step: every active stick, angle and tether, `S × N` times.
pub fn projections_per_step(solver: &Solver, setting: &Setting) -> u64 {
    let sticks = solver
        .sticks
        .kind
        .iter()
        .filter(|&&k| k != StickKind::Torn)
        .count();
    let constraints = sticks + solver.angles.len() + solver.tethers.len();
    constraints as u64 * setting.budget() as u64
}

/// Tethers every movable particle to its nearest pin when the setting asks for it.
pub fn apply_tethers(solver: &mut Solver, setting: &Setting) {
    if setting.tethers {
        for i in 0..solver.particles.len() {
            solver.tethered[i] = solver.particles.inverse_mass[i] > 0.0;
        }
        solver.rebuild_tethers();
    }
}

/// A seed-tuned soft material: the per-projection stiffness `stiffness` of the original code,
/// which ran `iterations` passes per step of `timestep` seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// What the material is (for the report).
    pub name: &'static str,
    /// Fraction of the error one pass removes in the original code.
    pub stiffness: f32,
    /// Passes per step in the original code.
    pub iterations: u32,
    /// Step of the original code in seconds.
    pub timestep: f32,
}

impl Material {
    /// The crate's conversion ([`Stiffness::Seed`]): the compliance that removes the same
    /// fraction of the error per original step, whatever our budget.
    pub fn seed_compliance(&self, w: f64) -> f64 {
        Stiffness::Seed {
            stiffness: self.stiffness,
            iterations: self.iterations,
            timestep: self.timestep,
        }
        .compliance(w)
    }

    /// The compliance a stick of generalized inverse mass `w` gets under `law` at substep `h`.
    /// For [`Law::Plain`] it is `α = w·h²·(1 − k)/k`: with multipliers reset every projection,
    /// `Δλ = −C/(w + α/h²) = −k·C/w`, i.e. each projection removes the fraction `k` of the error,
    /// exactly the seeds' stiffness.
    pub fn compliance(&self, law: Law, w: f64, h: f64) -> f64 {
        match law {
            Law::Xpbd => self.seed_compliance(w),
            Law::Plain => {
                let k = (self.stiffness as f64).clamp(1e-9, 1.0);
                w * h * h * (1.0 - k) / k
            }
        }
    }
}

/// How a metric is printed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    /// A fraction printed as a percentage.
    Percent,
    /// A plain number.
    Number,
    /// Hertz.
    Hertz,
}

/// One measured quantity of a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Column {
    /// Table header.
    pub name: &'static str,
    /// How to print it.
    pub unit: Unit,
}

/// A scene with a known answer.
pub trait Scene {
    /// A short name for tables and progress lines.
    fn name(&self) -> String;
    /// The metrics [`Scene::measure`] returns, in order. The first is the error that is plotted
    /// (its absolute value); `NaN` means "could not be measured" (e.g. the pendulum never swung).
    fn columns(&self) -> Vec<Column>;
    /// A fresh solver and configuration for `setting`, in the scene's initial state.
    fn build(&self, setting: &Setting) -> (Solver, StepConfig);
    /// Runs the scene and measures it.
    fn measure(&self, setting: &Setting) -> Vec<f64>;
    /// Simulated seconds each timing repeat runs at least.
    fn bench_seconds(&self) -> f64 {
        2.0
    }
}

/// A pinned particle at `position`.
pub fn add_pinned(solver: &mut Solver, position: DVec3) -> u32 {
    let i = solver.add_particle(position, 0.0);
    solver.pin(i, position);
    i
}

/// A chain of `links` rigid sticks from a pin at the origin along `direction` (a unit vector),
/// `length` long, its last particle `tip_ratio` × as heavy as the others (unit masses).
pub fn add_chain(solver: &mut Solver, links: usize, length: f64, direction: DVec3, tip_ratio: f64) {
    let link = length / links as f64;
    let mut previous = add_pinned(solver, DVec3::ZERO);
    for i in 1..=links {
        let w = if i == links { 1.0 / tip_ratio } else { 1.0 };
        let p = solver.add_particle(direction * (link * i as f64), w);
        add_rod(solver, previous, p);
        previous = p;
    }
}

/// A rigid two-sided stick at its current length.
pub fn add_rod(solver: &mut Solver, a: u32, b: u32) -> u32 {
    let p = &solver.particles.position;
    let rest = (p[a as usize] - p[b as usize]).length();
    solver
        .sticks
        .push([a, b], rest, 0.0, StickKind::Equal, f64::INFINITY, 0)
}

/// Where and in which units a scene is set up: the solver's state is `f64`, so metres near the
/// origin and pixels far from it must give the same relative errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Units {
    /// Metres, `g = 9.81 m/s²`, at the origin.
    Metres,
    /// Pixels, `g = 980 px/s²`, around `(1000, 1000)` px.
    Pixels,
}

impl Units {
    /// A length scale: 1 m or 100 px.
    pub fn scale(self) -> f64 {
        match self {
            Units::Metres => 1.0,
            Units::Pixels => 100.0,
        }
    }

    /// Gravitational acceleration (magnitude).
    pub fn gravity(self) -> f64 {
        match self {
            Units::Metres => 9.81,
            Units::Pixels => 980.0,
        }
    }

    /// Where the scene is placed.
    pub fn origin(self) -> DVec3 {
        match self {
            Units::Metres => DVec3::ZERO,
            Units::Pixels => DVec3::new(1000.0, 1000.0, 0.0),
        }
    }

    /// A short description.
    pub fn label(self) -> &'static str {
        match self {
            Units::Metres => "m, at the origin",
            Units::Pixels => "px, at (1000, 1000) px",
        }
    }
}
