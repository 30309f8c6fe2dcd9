//! Configuration resources: [`VerletConfig`] and [`Gravity`].

use bevy::prelude::*;

/// Solver settings. Insert or change it at any time; changes apply from the next fixed step.
///
/// The default (8 substeps × 1 iteration at Bevy's 64 Hz fixed step) follows "Small Steps"
/// (Macklin et al. 2019): for the same number of projections, substeps leave far less stretch
/// and lose far less energy than iterations (see the crate README for measurements).
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut app = App::new();
/// app.insert_resource(VerletConfig { substeps: 16, ..VerletConfig::default() });
/// let mut config = VerletConfig::accurate();
/// config.paused = true;
/// config.step_once(); // advance exactly one fixed step while paused
/// ```
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Default, Debug, Clone)]
pub struct VerletConfig {
    /// Substeps per fixed step (each runs integrate → relax × iterations → constrain).
    pub substeps: u32,
    /// Relaxation iterations per substep.
    pub iterations: u32,
    /// Linear damping rate in 1/s (velocities decay as `exp(−damping·t)`, independent of the
    /// frame rate and substep count). `0` = none.
    pub damping: f32,
    /// Stops the simulation (see [`VerletConfig::step_once`]).
    pub paused: bool,
    /// Despawn stick entities when they tear (otherwise only their `Stick` is removed).
    pub despawn_torn_sticks: bool,
    /// Fixed steps still to run while paused.
    pub pending_steps: u32,
    /// When resting islands stop being simulated (see [`Sleeping`]).
    pub sleeping: Sleeping,
    /// Spread the solve over Bevy's `ComputeTaskPool` when a scene is large enough (results are
    /// identical either way; `false` keeps everything on the calling thread).
    pub parallel: bool,
    /// How islands are solved (see [`SolveMethod`]; changing it rebuilds the topology).
    pub method: SolveMethod,
    /// Islands solved by lines keep their energy (SHAKE: corrections along each stick's
    /// direction at the start of the substep) instead of losing it like the position
    /// projection does. On by default; off only for comparisons.
    pub shake: bool,
    /// How many of its nearest pins (by distance along the sticks) every
    /// [`Tethered`](crate::Tethered) particle is tethered to, from 1 to 8 (other values are
    /// clamped, with a warning). Two, the default,
    /// hold a cloth hung by two corners: tethered to the nearer corner alone, a particle can
    /// still swing out towards the other, and the cloth stretches almost as much as untethered
    /// (see the crate README, "Hard cases": 4.1× with one, 41 % with two). A further pin seen
    /// within 30° of a nearer one gets no tether (along a pinned top row only the first row
    /// gets two), and one pulled out of reach of the nearest is ignored, so a grabbed cloth
    /// still tears where it is pulled. Changing it rebuilds the topology.
    pub tether_anchors: u32,
    /// An island solved by sweeps whose heaviest movable particle is more than this many times
    /// its lightest runs its iterations in forward–backward pairs (symmetric Gauss–Seidel:
    /// twice the sweep's cost at one iteration). A forward sweep alone can grow without bound
    /// where heavy particles hang on light ones (a cloth hung by two corners with some
    /// particles 100× heavier, kicked: see the crate README, "Hard cases"). Default 8;
    /// `f32::INFINITY`: never; below 1 (`0`): every swept island, equal masses too. NaN is
    /// replaced by the default, with a warning.
    pub symmetric_mass_ratio: f32,
    /// Substeps of ropes, chains, pendulums and trees — tree-shaped islands, which
    /// [`SolveMethod::Auto`] solves exactly by lines — that carry no [`IslandOverride`] of
    /// their own, no tethers and no angle constraints; `None` (the default):
    /// [`VerletConfig::substeps`], as for every other island;
    /// `Some(0)` is taken as 1, and a fixed step longer than 1/64 s (Bevy's default) gives them
    /// more, so that none is longer than 1/64 s, never more than `substeps`
    /// (`solver::line_substeps::line_substep_count`). Their solve is exact at any substep count, so fewer substeps cost
    /// a rope no stretch, only accuracy in time: at `Some(2)` the report's chains stay within
    /// 10⁻⁹ of their lengths, a 120° pendulum's period is off by −0.008 % and a double pendulum
    /// loses 0.2 % of its energy over 60 s, at 0.27–0.42× the time of 8 swept substeps (the
    /// 200-link chain swinging: 1.32–1.33×; the 1000:1 chain whipping from horizontal:
    /// 1.44–1.47×, 4.08–4.10× at 8; see the crate README, "Configuration"). Cloth, ragdolls and
    /// structures keep `substeps`. In a step where a rope is hit hard — a stick, its ends moving
    /// on at their velocities (a pinned end towards its target), would stretch by more than its
    /// length within one of its substeps, or have its ends cross — it takes `substeps`
    /// (`solver::line_substeps`); so does a rope with a spring too stiff for the longer
    /// substep, and one attached to an avian body (it steps with the body).
    ///
    /// ```
    /// use bevy::prelude::*;
    /// use bevy_verlet_physics::prelude::*;
    /// let mut app = App::new();
    /// // Cloth swept at 8 substeps, ropes solved exactly at 2.
    /// app.insert_resource(VerletConfig { line_substeps: Some(2), ..default() });
    /// ```
    ///
    /// [`IslandOverride`]: crate::IslandOverride
    pub line_substeps: Option<u32>,
}

/// How the sticks of an island are solved (the crate README, "Solvers", has the measurements).
///
/// ```
/// use bevy_verlet_physics::prelude::*;
/// # use bevy::prelude::default;
/// // Force Gauss–Seidel sweeps everywhere (the solver before lines existed).
/// let config = VerletConfig { method: SolveMethod::Sweep, ..default() };
/// assert_ne!(config.method, SolveMethod::default());
/// ```
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Default, Debug, Clone)]
pub enum SolveMethod {
    /// Per island: ropes, chains and trees (no loop, no angle constraint) are solved by lines —
    /// exactly, whatever their length and mass ratio, and keeping their energy; a large cloth
    /// (2048 sticks or more) without tethers or tearable sticks hung from one to four pinned
    /// (or immovable) particles with a hierarchy;
    /// other cloth, ragdolls with posture links and braced structures by Gauss–Seidel sweeps.
    #[default]
    Auto,
    /// Gauss–Seidel sweeps over single sticks for every island.
    Sweep,
    /// Every island's sticks covered by lines (paths), each solved directly; lines that share
    /// particles are solved one after the other.
    Lines,
    /// Sweeps between passes over coarse levels of long-range sticks along the island's mesh
    /// (after hierarchical position based dynamics, Müller 2008) that carry a cloth's load to
    /// its pins at once: for cloth hung by a few pins. A 100 × 100 cloth hung by two corners
    /// stretches 29 % at 8 × 1 instead of 957 %, for 1.5× the sweep's cost. Only rigid sticks
    /// carry it; a torn island loses its hierarchy until the next rebuild.
    Hierarchy,
}

impl SolveMethod {
    /// The solver core's equivalent.
    pub(crate) fn core(self) -> crate::solver::Method {
        use crate::solver::Method;
        match self {
            Self::Auto => Method::Auto,
            Self::Sweep => Method::Sweep,
            Self::Lines => Method::Lines,
            Self::Hierarchy => Method::Hierarchy,
        }
    }
}

/// When an island — particles connected by sticks — falls asleep: it is then neither integrated
/// nor solved until something touches it (a pin target moves, a particle is edited, a stick is
/// added or torn, a collider, gravity or [`VerletConfig`] changes, or
/// [`VerletState::wake`](crate::VerletState::wake) is called).
///
/// ```
/// use bevy_verlet_physics::prelude::*;
/// let config = VerletConfig { sleeping: Sleeping::Below { speed: 5.0, time: 1.0 }, ..default() };
/// # use bevy::prelude::default;
/// assert_ne!(config.sleeping, Sleeping::Never);
/// ```
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Default, Debug, Clone)]
pub enum Sleeping {
    /// Islands never sleep.
    Never,
    /// Every movable particle below `0.001·|g|` per second (1 cm/s under
    /// [`Gravity::METRES`], 1 px/s under [`Gravity::PIXELS`]) for 1 s.
    #[default]
    Auto,
    /// Every movable particle below `speed` (units/s) for `time` seconds.
    Below {
        /// Speed threshold in units per second.
        speed: f32,
        /// Seconds below it before the island sleeps.
        time: f32,
    },
}

impl Default for VerletConfig {
    fn default() -> Self {
        Self {
            substeps: 8,
            iterations: 1,
            damping: 0.0,
            paused: false,
            despawn_torn_sticks: true,
            pending_steps: 0,
            sleeping: Sleeping::Auto,
            parallel: true,
            method: SolveMethod::Auto,
            shake: true,
            tether_anchors: crate::solver::DEFAULT_TETHER_ANCHORS as u32,
            symmetric_mass_ratio: crate::solver::SYMMETRIC_MASS_RATIO as f32,
            line_substeps: None,
        }
    }
}

impl VerletConfig {
    /// A preset for accuracy over speed: 32 substeps × 1 iteration.
    pub fn accurate() -> Self {
        Self {
            substeps: 32,
            ..Self::default()
        }
    }

    /// The seeds' style: 1 substep and `iterations` relaxation passes.
    pub fn seed_style(iterations: u32) -> Self {
        Self {
            substeps: 1,
            iterations,
            ..Self::default()
        }
    }

    /// While paused, runs one more fixed step (avian's "step" convention).
    pub fn step_once(&mut self) {
        self.pending_steps += 1;
    }

    /// How far between the last two fixed steps drawn positions are interpolated: `time`'s
    /// overstep fraction, or `1` (the last step's result) while [`VerletConfig::paused`], so
    /// that everything drawn stands still. The plugin's gizmos, `ClothMesh`, followers and
    /// synced `Transform`s use it; use it for your own drawing too.
    ///
    /// ```
    /// use bevy::prelude::*;
    /// use bevy_verlet_physics::prelude::*;
    /// let config = VerletConfig { paused: true, ..default() };
    /// assert_eq!(config.render_fraction(&Time::<Fixed>::default()), 1.0);
    /// ```
    pub fn render_fraction(&self, time: &Time<Fixed>) -> f32 {
        if self.paused {
            1.0
        } else {
            time.overstep_fraction().clamp(0.0, 1.0)
        }
    }
}

/// Acceleration applied to every movable particle. Default `(0, −9.81, 0)` (metres); use
/// [`Gravity::PIXELS`] for 2D scenes in pixels, and `Vec3::ZERO` (or [`Gravity::ZERO`]) to turn
/// it off at run time.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut app = App::new();
/// app.insert_resource(Gravity::PIXELS);
/// assert_eq!(Gravity::PIXELS.0.y, -980.0);
/// ```
#[derive(Resource, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Resource, Default, Debug, Clone)]
pub struct Gravity(pub Vec3);

impl Gravity {
    /// 9.81 m/s² down the Y axis.
    pub const METRES: Gravity = Gravity(Vec3::new(0.0, -9.81, 0.0));
    /// 980 px/s² down the Y axis (the Tuts+ curtain's value; Bevy 2D has Y up).
    pub const PIXELS: Gravity = Gravity(Vec3::new(0.0, -980.0, 0.0));
    /// No gravity.
    pub const ZERO: Gravity = Gravity(Vec3::ZERO);
}

impl Default for Gravity {
    fn default() -> Self {
        Self::METRES
    }
}

/// Per-step statistics, updated after every fixed step.
///
/// ```
/// use bevy_verlet_physics::prelude::*;
/// let stats = VerletStats::default();
/// assert_eq!(stats.torn_total, 0);
/// ```
#[derive(Resource, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Resource, Default, Debug, Clone)]
pub struct VerletStats {
    /// Particles in the solver.
    pub particles: usize,
    /// Active sticks in the solver.
    pub sticks: usize,
    /// Sticks torn since startup.
    pub torn_total: u64,
    /// Fixed steps run since startup.
    pub steps: u64,
    /// Topology rebuilds since startup.
    pub rebuilds: u64,
    /// Wall time of the last fixed step's solve (gather, substeps, tear, scatter, and Bevy's
    /// scheduling between those systems), in µs.
    pub step_micros: f32,
    /// Of which: gathering components into the solver (topology rebuild included), in µs.
    pub gather_micros: f32,
    /// Of which: the solver's substeps and the end of the step (sleep, tearing), in µs.
    pub solve_micros: f32,
    /// Of which: scattering positions back into the components, in µs.
    pub scatter_micros: f32,
    /// Particles put back at their last position since startup because their state diverged
    /// in a step (became NaN, infinite or beyond `f32`'s range; each is also warned about
    /// once). `0` in a healthy scene.
    pub diverged: u64,
    /// Islands (groups of connected particles) in the solver.
    pub islands: usize,
    /// Islands asleep after the last step (see [`Sleeping`]).
    pub sleeping_islands: usize,
    /// Awake islands the last step swept forward and back: solved by sweeps, their masses differ
    /// more than [`VerletConfig::symmetric_mass_ratio`] (each costs twice a forward sweep at one
    /// iteration).
    pub symmetric_islands: usize,
}
