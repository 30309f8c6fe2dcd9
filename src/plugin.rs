//! [`VerletPlugin`] and its system sets.

use crate::state::VerletState;
use crate::systems::{self, StepClock};
use crate::{
    AngleConstraint, ColliderShape, Gravity, Particle, Pin, PinTarget, Stick, StickTorn, Stiffness,
    Tethered, VerletCollider, VerletConfig, VerletStats,
};
use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::{ScheduleLabel, SingleThreadedExecutor};
use bevy::prelude::*;

/// The system sets of one fixed step, in order, in the [`VerletSchedule`].
///
/// The plugin's schedule (`FixedPostUpdate` by default) runs the whole `VerletSchedule` from
/// one system in [`VerletSystems::Substeps`], with the four sets chained around it: order your
/// systems there against them to run before or after the step, e.g.
/// `.before(VerletSystems::Prepare)` to move pins or drag particles (systems in `FixedUpdate`
/// run before the step anyway). To run *between* two phases of the step, add the system to
/// [`VerletSchedule`] instead.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// fn drag(mut particles: Query<&mut Particle>) {}
/// fn inspect(state: Res<VerletState>) {}
/// App::new()
///     .add_systems(FixedPostUpdate, drag.before(VerletSystems::Prepare))
///     .add_systems(VerletSchedule, inspect.after(VerletSystems::Substeps).before(VerletSystems::Tear));
/// ```
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VerletSystems {
    /// Detects topology changes, rebuilds the solver's tables if needed, gathers edits, pin
    /// targets and colliders.
    Prepare,
    /// Runs the [`VerletSubsteps`] schedule once per substep.
    Substeps,
    /// Tears overstrained sticks and sends [`StickTorn`].
    Tear,
    /// Writes positions back into `Particle` components.
    Writeback,
}

/// The schedule of one fixed step, with the sets [`VerletSystems`] chained. The plugin runs it
/// from its fixed schedule with a single-threaded executor (as avian runs its
/// `PhysicsSchedule`): the step's systems are short and strictly ordered, and handing each to
/// the multi-threaded executor cost more than they do.
#[derive(ScheduleLabel, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct VerletSchedule;

/// The schedule run once per substep, with the sets [`VerletSubstepSystems`].
#[derive(ScheduleLabel, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct VerletSubsteps;

/// The system sets of one substep, in order: integrate → relax × N → constrain. Add custom
/// constraints to `Relax` (they can change [`VerletState::solver`]).
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VerletSubstepSystems {
    /// Verlet integration and kinematic pins.
    Integrate,
    /// `iterations` relaxation sweeps over sticks, angle constraints and tethers.
    Relax,
    /// Bounds, ground planes and spheres.
    Constrain,
}

/// Verlet particle physics: adds the components' reflection, the [`VerletConfig`],
/// [`Gravity`] and [`VerletStats`] resources, the [`StickTorn`] message, and the
/// [`VerletSchedule`] run from `FixedPostUpdate` (or the schedule given to
/// [`VerletPlugin::new`]). As in avian, gameplay systems in `FixedUpdate` run before the step
/// without any ordering.
///
/// Bevy's fixed timestep is the accumulator of the seeds: `FixedMain` runs as many 64 Hz steps
/// as real time needs, and `Time<Virtual>` caps a long frame at 250 ms (its `max_delta`), so a
/// hitch runs at most 16 steps instead of spiralling.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// App::new().add_plugins((MinimalPlugins, VerletPlugin::default()));
/// ```
pub struct VerletPlugin {
    schedule: Interned<dyn ScheduleLabel>,
}

impl Default for VerletPlugin {
    fn default() -> Self {
        Self::new(FixedPostUpdate)
    }
}

impl VerletPlugin {
    /// Runs the simulation in `schedule` (it should run at a fixed rate: `FixedPostUpdate`,
    /// the default, or `FixedUpdate`).
    pub fn new(schedule: impl ScheduleLabel) -> Self {
        Self {
            schedule: schedule.intern(),
        }
    }
}

impl Plugin for VerletPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<Particle>()
            .register_type::<crate::Composite>()
            .register_type::<crate::HiddenStick>()
            .register_type::<Tethered>()
            .register_type::<crate::IslandOverride>()
            .register_type::<crate::Sleeping>()
            .register_type::<crate::SolveMethod>()
            .register_type::<Stick>()
            .register_type::<Stiffness>()
            .register_type::<AngleConstraint>()
            .register_type::<Pin>()
            .register_type::<PinTarget>()
            .register_type::<VerletCollider>()
            .register_type::<ColliderShape>()
            .register_type::<VerletConfig>()
            .register_type::<Gravity>()
            .register_type::<VerletStats>()
            .init_resource::<VerletConfig>()
            .init_resource::<Gravity>()
            .init_resource::<VerletStats>()
            .init_resource::<VerletState>()
            .init_resource::<StepClock>()
            .add_message::<StickTorn>();

        crate::transform_sync::plugin(app);

        let mut substeps = Schedule::new(VerletSubsteps);
        substeps.set_executor(SingleThreadedExecutor::new());
        substeps.configure_sets(
            (
                VerletSubstepSystems::Integrate,
                VerletSubstepSystems::Relax,
                VerletSubstepSystems::Constrain,
            )
                .chain(),
        );
        substeps.add_systems((
            systems::integrate.in_set(VerletSubstepSystems::Integrate),
            systems::relax.in_set(VerletSubstepSystems::Relax),
            systems::constrain.in_set(VerletSubstepSystems::Constrain),
        ));
        app.add_schedule(substeps);

        let mut step = Schedule::new(VerletSchedule);
        step.set_executor(SingleThreadedExecutor::new());
        step.configure_sets(
            (
                VerletSystems::Prepare,
                VerletSystems::Substeps,
                VerletSystems::Tear,
                VerletSystems::Writeback,
            )
                .chain(),
        );
        step.add_systems((
            (
                systems::detect_topology_changes,
                systems::decide_step,
                (systems::prepare, systems::count_rebuilds)
                    .chain()
                    .run_if(systems::step_is_active),
            )
                .chain()
                .in_set(VerletSystems::Prepare),
            systems::run_substeps
                .run_if(systems::step_is_active)
                .in_set(VerletSystems::Substeps),
            systems::tear
                .run_if(systems::step_is_active)
                .in_set(VerletSystems::Tear),
            systems::writeback
                .run_if(systems::step_is_active)
                .in_set(VerletSystems::Writeback),
        ));
        app.add_schedule(step);

        let schedule = self.schedule;
        app.configure_sets(
            schedule,
            (
                VerletSystems::Prepare,
                VerletSystems::Substeps,
                VerletSystems::Tear,
                VerletSystems::Writeback,
            )
                .chain(),
        );
        app.add_systems(schedule, systems::run_step.in_set(VerletSystems::Substeps));
    }
}
