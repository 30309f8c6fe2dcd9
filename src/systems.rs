//! The plugin's systems: prepare (gather) → substeps (integrate → relax × N → constrain) →
//! tear → writeback (scatter).

use crate::executor::with_executor;
use crate::solver::{GlobalSubstep, MAX_TETHER_ANCHORS, Pins, Sleep, StepConfig};
use crate::state::{ParticleData, Problem, RebuildInputs, VerletState};
use crate::{
    AngleConstraint, Gravity, IslandOverride, Particle, Pin, Sleeping, StickTorn, Tethered,
    VerletCollider, VerletConfig, VerletStats,
};
use crate::{Stick, VerletSchedule, VerletSubsteps};
use bevy::ecs::entity::Entities;
use bevy::ecs::system::SystemParam;
use bevy::platform::time::Instant;
use bevy::prelude::*;
use bevy::transform::helper::TransformHelper;
use glam::DVec3;

/// Timing of the step in progress.
#[derive(Resource, Default)]
pub(crate) struct StepClock {
    started: Option<Instant>,
    /// Time spent gathering (prepare) and solving (the substeps) in this step, in µs.
    gather: f32,
    solve: f32,
}

/// Components whose count is compared between runs (see `VerletState::component_counts`).
type CountedComponents<'w, 's> = (
    Query<'w, 's, (), With<Particle>>,
    Query<'w, 's, (), With<Stick>>,
    Query<'w, 's, (), With<AngleConstraint>>,
    Query<'w, 's, (), With<Tethered>>,
);

/// Removal buffers: of the components whose removal changes the topology, then of those whose
/// removal wakes an island (tethers, island overrides).
type Removals<'w, 's> = (
    RemovedComponents<'w, 's, Particle>,
    RemovedComponents<'w, 's, Stick>,
    RemovedComponents<'w, 's, AngleConstraint>,
    RemovedComponents<'w, 's, Tethered>,
    RemovedComponents<'w, 's, IslandOverride>,
);

/// What changed since the last run, read from removal buffers, component counts and change
/// filters. (Pins and parameter edits of sticks and angle constraints need no rebuild: `prepare`
/// applies them in place.)
pub(crate) fn detect_topology_changes(
    mut state: ResMut<VerletState>,
    counted: CountedComponents,
    added_particles: Query<(), Added<Particle>>,
    added_tethers: Query<Entity, Added<Tethered>>,
    changed_overrides: Query<Entity, Changed<IslandOverride>>,
    removals: Removals,
) {
    let (
        mut removed_particles,
        mut removed_sticks,
        mut removed_angles,
        mut removed_tethers,
        mut removed_overrides,
    ) = removals;
    let state = &mut *state;
    // Drain every removal buffer (they are cleared each frame, paused or not). Sticks the solver
    // tore in place are expected to go and change nothing (their count is expected to drop).
    let mut expected = 0;
    let sticks_removed = removed_sticks
        .read()
        .filter(|entity| {
            let torn = state.torn_entities.remove(entity);
            expected += torn as usize;
            !torn
        })
        .count();
    state.component_counts[1] = state.component_counts[1].saturating_sub(expected);
    let removed = removed_particles.read().count() + sticks_removed + removed_angles.read().count();
    // Tethers and island overrides wake the islands they touch (by entity: after any rebuild).
    let tethers_before = state.wake_entities.len();
    state.wake_entities.extend(removed_tethers.read());
    state.wake_entities.extend(&added_tethers);
    let tethers_changed = state.wake_entities.len() > tethers_before;
    let overrides_before = state.wake_entities.len();
    state.wake_entities.extend(removed_overrides.read());
    state.wake_entities.extend(&changed_overrides);
    if state.wake_entities.len() > overrides_before {
        state.overrides_changed = true;
    }
    // The removal buffers keep a removal for two frames only: a frame rate above the fixed rate
    // runs frames with no fixed step, and a removal made then can be gone by the next step. A
    // removal always changes a count unless something was added at the same time, which the
    // change filters see. `count` is O(archetypes).
    let (particles, sticks, angles, tethers) = &counted;
    let counts = [
        particles.count(),
        sticks.count(),
        angles.count(),
        tethers.count(),
    ];
    let counts_changed = counts != state.component_counts;
    if counts_changed {
        state.component_counts = counts;
    }
    if removed > 0 || counts_changed || tethers_changed || !added_particles.is_empty() {
        state.dirty = true;
    }
}

/// Decides whether this fixed step runs (pause and single-step). A step of zero length (the
/// plugin run in a variable-rate schedule on a paused or first frame) does not run: it has no
/// velocity to read from the components.
pub(crate) fn decide_step(
    mut state: ResMut<VerletState>,
    mut config: ResMut<VerletConfig>,
    time: Res<Time>,
) {
    let delta = time.delta_secs_f64();
    let has_length = delta.is_finite() && delta > 0.0;
    state.active = if !has_length {
        false
    } else if !config.paused {
        true
    } else if config.pending_steps > 0 {
        config.pending_steps -= 1;
        true
    } else {
        false
    };
}

/// Run condition: the step runs.
pub(crate) fn step_is_active(state: Res<VerletState>) -> bool {
    state.active
}

/// The step's settings, with unusable values replaced: a non-finite gravity by zero, a NaN or
/// negative damping by none (`+∞` stops every particle, which is what it means), a NaN
/// symmetric mass ratio by the default.
fn step_config(config: &VerletConfig, gravity: &Gravity, time: &Time) -> StepConfig {
    let gravity = if gravity.0.is_finite() {
        gravity.0.as_dvec3()
    } else {
        DVec3::ZERO
    };
    StepConfig {
        timestep: time.delta_secs_f64(),
        substeps: config.substeps.max(1),
        iterations: config.iterations.max(1),
        gravity,
        damping: if config.damping >= 0.0 {
            config.damping as f64
        } else {
            0.0
        },
        sleep: match config.sleeping {
            Sleeping::Never => None,
            Sleeping::Auto => Some(Sleep::for_gravity(gravity.length())),
            // (NaN or negative thresholds never put anything to sleep.)
            Sleeping::Below { speed, time } => Some(Sleep {
                speed: speed as f64,
                time: time as f64,
            }),
        },
        shake: config.shake,
        symmetric_mass_ratio: match config.symmetric_mass_ratio {
            ratio if ratio.is_nan() => crate::solver::SYMMETRIC_MASS_RATIO,
            ratio => ratio as f64,
        },
        line_substeps: config.line_substeps,
    }
}

/// Warns (once) about a gravity or damping that `step_config` had to replace.
fn warn_config(state: &mut VerletState, config: &VerletConfig, gravity: &Gravity) {
    if !gravity.0.is_finite() {
        let g = gravity.0;
        state.warn(Entity::PLACEHOLDER, Problem::Gravity, || {
            format!("Gravity {g} is not finite; using zero")
        });
    }
    if config.damping.is_nan() || config.damping < 0.0 {
        let c = config.damping;
        state.warn(Entity::PLACEHOLDER, Problem::Damping, || {
            format!("VerletConfig damping {c} is NaN or negative; using none")
        });
    }
    if config.symmetric_mass_ratio.is_nan() {
        state.warn(Entity::PLACEHOLDER, Problem::SymmetricMassRatio, || {
            format!(
                "VerletConfig symmetric_mass_ratio is NaN; using {}",
                crate::solver::SYMMETRIC_MASS_RATIO
            )
        });
    }
    let anchors = config.tether_anchors;
    if anchors == 0 || anchors as usize > MAX_TETHER_ANCHORS {
        state.warn(Entity::PLACEHOLDER, Problem::TetherAnchors, || {
            format!(
                "VerletConfig tether_anchors {anchors} is outside 1..={MAX_TETHER_ANCHORS}; using {}",
                anchors.clamp(1, MAX_TETHER_ANCHORS as u32)
            )
        });
    }
}

/// What `prepare` reads besides the particles.
#[derive(SystemParam)]
pub(crate) struct Inputs<'w, 's> {
    config: Res<'w, VerletConfig>,
    gravity: Res<'w, Gravity>,
    time: Res<'w, Time>,
    pins: Query<'w, 's, (Entity, Ref<'static, Pin>, Has<Particle>)>,
    colliders: Query<'w, 's, (Entity, &'static VerletCollider)>,
    overrides: Query<'w, 's, (Entity, &'static IslandOverride)>,
    transforms: TransformHelper<'w, 's>,
    entities: &'w Entities,
}

/// Every particle (for a rebuild), and the changed ones (a `Changed` filter skips the rest
/// without fetching them).
type ParticleQueries<'w, 's> = ParamSet<
    'w,
    's,
    (
        Query<'static, 'static, ParticleData>,
        Query<'static, 'static, (Entity, &'static Particle), Changed<Particle>>,
    ),
>;

/// Every `T` (for a rebuild), and the changed ones.
type EditQueries<'w, 's, T> = ParamSet<
    'w,
    's,
    (
        Query<'static, 'static, (Entity, &'static mut T)>,
        Query<'static, 'static, (Entity, &'static mut T), Changed<T>>,
    ),
>;

/// Gathers what users changed into the solver: topology changes rebuild its tables; particle
/// edits, stick and angle parameters, pins and island overrides apply in place.
pub(crate) fn prepare(
    mut state: ResMut<VerletState>,
    mut clock: ResMut<StepClock>,
    inputs: Inputs,
    mut particles: ParticleQueries,
    mut sticks: EditQueries<Stick>,
    mut angles: EditQueries<AngleConstraint>,
) {
    clock.started = Some(Instant::now());
    let state = &mut *state;
    warn_config(state, &inputs.config, &inputs.gravity);
    let step = step_config(&inputs.config, &inputs.gravity, &inputs.time);
    // (New particles' states refer to the last step's substep: the solver's convention.)
    let (dt, h) = (
        step.timestep,
        state.solver.verlet_substep().unwrap_or(step.substep()),
    );
    // An edited particle the solver does not know (e.g. a rejected one that was fixed) needs a
    // rebuild.
    if !state.dirty {
        for (entity, particle) in &particles.p1() {
            if !state.owns_slot(entity, particle) {
                state.dirty = true;
                break;
            }
        }
    }
    if state.solver.method != inputs.config.method.core() {
        state.solver.method = inputs.config.method.core();
        state.dirty = true;
    }
    let anchors = (inputs.config.tether_anchors as usize).clamp(1, MAX_TETHER_ANCHORS);
    if state.solver.tethers.anchors != anchors {
        state.solver.tethers.anchors = anchors;
        state.dirty = true;
    }
    // Lines are laid out by a rebuild: an override that picks or dropped a method needs one.
    if state.overrides_changed
        && (!state.solver.island_methods.is_empty()
            || inputs.overrides.iter().any(|(_, o)| o.method.is_some()))
    {
        state.dirty = true;
    }
    if !state.dirty {
        reconcile_pins(state, &inputs.pins, &particles.p0());
    }
    edit_constraints(state, &mut sticks.p1(), &mut angles.p1());
    if !state.dirty {
        for (entity, particle) in &particles.p1() {
            state.gather_edit(entity, particle, step.gravity, dt, h);
        }
    }
    // (Also where an edit just gathered takes one: a tree-solved island's particle made
    // immovable or movable in place, see `gather_edit`.)
    if state.dirty {
        let rebuild = RebuildInputs {
            gravity: step.gravity,
            dt,
            h,
        };
        state.rebuild(
            &rebuild,
            &mut particles.p0(),
            &mut sticks.p0(),
            &mut angles.p0(),
            inputs.entities,
        );
    } else if state.overrides_changed {
        state.refresh_island_settings(inputs.overrides.iter());
    }
    state.overrides_changed = false;
    set_pin_targets(state, &inputs.pins, &inputs.transforms);
    state.apply_wakes();
    gather_colliders(state, &inputs.colliders, &inputs.transforms);
    clock.gather = micros_since(clock.started);
}

/// Pins added to or removed from simulated particles since the last step, applied in place
/// (or `state.dirty` set when that takes a rebuild).
fn reconcile_pins(
    state: &mut VerletState,
    pins: &Query<(Entity, Ref<Pin>, Has<Particle>)>,
    particles: &Query<ParticleData>,
) {
    let mut pinned = 0;
    for (entity, ..) in pins.iter() {
        let Some(slot) = state.slot(entity) else {
            continue;
        };
        if state.pin_index(slot).is_none() && !state.add_pin(slot) {
            state.dirty = true;
            return;
        }
        pinned += 1;
    }
    if pinned == state.solver.pins.len() {
        return;
    }
    // A `Pin` was removed: release its particle.
    for index in (0..state.solver.pins.len()).rev() {
        let slot = state.solver.pins.particle[index] as usize;
        let entity = state.particle_entities[slot];
        if pins.contains(entity) {
            continue;
        }
        let Ok((_, particle, ..)) = particles.get(entity) else {
            continue;
        };
        let (w, _) = state.material(entity, particle);
        if !state.remove_pin(index, w) {
            state.dirty = true;
            return;
        }
    }
}

/// Changed sticks and angle constraints: parameters apply in place (or `state.dirty` is set
/// when the change takes a rebuild), and their islands wake.
fn edit_constraints(
    state: &mut VerletState,
    sticks: &mut Query<(Entity, &mut Stick), Changed<Stick>>,
    angles: &mut Query<(Entity, &mut AngleConstraint), Changed<AngleConstraint>>,
) {
    for (entity, mut stick) in sticks.iter_mut() {
        let stick = stick.bypass_change_detection();
        state.wake_entities.extend([stick.a, stick.b]);
        if !state.dirty && !state.edit_stick(entity, stick) {
            state.dirty = true;
        }
    }
    for (entity, mut angle) in angles.iter_mut() {
        let angle = angle.bypass_change_detection();
        state.wake_entities.extend([angle.a, angle.b, angle.c]);
        if !state.dirty && !state.edit_angle(entity, angle) {
            state.dirty = true;
        }
    }
}

/// Pin targets move every step; an edited pin wakes its island.
fn set_pin_targets(
    state: &mut VerletState,
    pins: &Query<(Entity, Ref<Pin>, Has<Particle>)>,
    transforms: &TransformHelper,
) {
    for (entity, pin, is_particle) in pins.iter() {
        let Some(slot) = state.slot(entity) else {
            // (A particle left out for a bad position has been warned about already.)
            if !is_particle {
                state.warn(entity, Problem::PinWithoutParticle, || {
                    "Pin on an entity without a Particle; ignored".to_string()
                });
            }
            continue;
        };
        let Some(index) = state.pin_index(slot) else {
            continue;
        };
        if pin.is_changed() {
            state.wake_entities.push(entity);
        }
        if let Some(target) = state.pin_target(entity, &pin, transforms) {
            state.solver.pins.set_target(index, target);
        }
    }
}

/// The colliders, placed by their entities' up-to-date `GlobalTransform`.
fn gather_colliders(
    state: &mut VerletState,
    colliders: &Query<(Entity, &VerletCollider)>,
    transforms: &TransformHelper,
) {
    state.solver.colliders.clear();
    for (entity, collider) in colliders.iter() {
        let global = transforms
            .compute_global_transform(entity)
            .unwrap_or_default();
        let (scale, rotation, translation) = global.to_scale_rotation_translation();
        match collider.to_core(scale, rotation, translation) {
            Ok(core) => state.solver.colliders.push(core),
            Err(reason) => state.warn(entity, Problem::Collider, || {
                format!("VerletCollider ignored: {reason}")
            }),
        }
    }
}

/// Microseconds since `start` (0 without one).
fn micros_since(start: Option<Instant>) -> f32 {
    start.map_or(0.0, |start| start.elapsed().as_secs_f32() * 1e6)
}

/// Runs one fixed step: the [`VerletSchedule`] (from the plugin's schedule).
pub(crate) fn run_step(world: &mut World) {
    world.run_schedule(VerletSchedule);
}

/// Runs the [`VerletSubsteps`] schedule once per global substep (see [`GlobalSubstep`]). While
/// it holds only the plugin's three systems, their work is done here directly, which saves
/// running a schedule per substep.
pub(crate) fn run_substeps(world: &mut World) {
    let (step, parallel) = {
        let config = world.resource::<VerletConfig>();
        let gravity = world.resource::<Gravity>();
        let time = world.resource::<Time>();
        (step_config(config, gravity, time), config.parallel)
    };
    if step.timestep <= 0.0 {
        return;
    }
    let started = Instant::now();
    let custom = world
        .get_resource::<Schedules>()
        .and_then(|schedules| schedules.get(VerletSubsteps))
        .is_some_and(|schedule| schedule.systems_len() != PLUGIN_SUBSTEP_SYSTEMS);
    let count = world.resource_mut::<VerletState>().solver.begin_step(&step);
    for index in 1..=count {
        let substep = GlobalSubstep {
            config: step,
            index,
            count,
            plain: false,
        };
        if custom {
            world.resource_mut::<VerletState>().substep = Some(substep);
            world.run_schedule(VerletSubsteps);
        } else {
            let solver = &mut world.resource_mut::<VerletState>().into_inner().solver;
            with_executor(parallel, |executor| {
                solver.integrate_substep(&substep, executor);
                solver.relax_substep(&substep, executor);
                solver.constrain_substep(&substep, executor);
            });
        }
    }
    world.resource_mut::<VerletState>().substep = None;
    world.resource_mut::<StepClock>().solve = micros_since(Some(started));
}

/// The systems the plugin adds to [`VerletSubsteps`] (integrate, relax, constrain).
const PLUGIN_SUBSTEP_SYSTEMS: usize = 3;

/// Substep phase 1: Verlet integration and kinematic pins.
pub(crate) fn integrate(mut state: ResMut<VerletState>, config: Res<VerletConfig>) {
    let state = &mut *state;
    if let Some(substep) = state.substep {
        with_executor(config.parallel, |executor| {
            state.solver.integrate_substep(&substep, executor)
        });
    }
}

/// Substep phase 2: `iterations` relaxation sweeps over sticks, angles and tethers.
pub(crate) fn relax(mut state: ResMut<VerletState>, config: Res<VerletConfig>) {
    let state = &mut *state;
    if let Some(substep) = state.substep {
        with_executor(config.parallel, |executor| {
            state.solver.relax_substep(&substep, executor)
        });
    }
}

/// Substep phase 3: colliders.
pub(crate) fn constrain(mut state: ResMut<VerletState>, config: Res<VerletConfig>) {
    let state = &mut *state;
    if let Some(substep) = state.substep {
        with_executor(config.parallel, |executor| {
            state.solver.constrain_substep(&substep, executor)
        });
    }
}

/// Tears overstrained sticks (post-solve strain), reports each once, and removes them.
pub(crate) fn tear(
    mut state: ResMut<VerletState>,
    config: Res<VerletConfig>,
    mut stats: ResMut<VerletStats>,
    mut clock: ResMut<StepClock>,
    mut messages: MessageWriter<StickTorn>,
    mut commands: Commands,
) {
    let state = &mut *state;
    let started = Instant::now();
    let torn = state.solver.finish_step();
    clock.solve += micros_since(Some(started));
    if torn == 0 {
        return;
    }
    state.torn_pending += torn;
    stats.torn_total += torn as u64;
    // Torn in place: the solver skips them from now on, and taking them out of the world
    // costs no rebuild (see `detect_topology_changes`).
    for k in 0..state.solver.torn.len() {
        let index = state.solver.torn[k] as usize;
        if let Some(message) = state.stick_torn(index) {
            state.release_torn(index);
            remove_stick(&mut commands, message.stick, config.despawn_torn_sticks);
            messages.write(message);
        }
    }
}

/// Takes a torn or cut stick out of the world: despawns its entity, or only removes its
/// [`Stick`] (see [`VerletConfig::despawn_torn_sticks`]).
pub(crate) fn remove_stick(commands: &mut Commands, stick: Entity, despawn: bool) {
    if let Ok(mut entity) = commands.get_entity(stick) {
        if despawn {
            entity.try_despawn();
        } else {
            entity.try_remove::<Stick>();
        }
    }
}

/// Scatters the solver's positions back into the `Particle` components (without triggering
/// change detection, so that only users' edits are gathered).
pub(crate) fn writeback(
    mut state: ResMut<VerletState>,
    mut clock: ResMut<StepClock>,
    mut stats: ResMut<VerletStats>,
    mut particles: Query<(Entity, &mut Particle)>,
) {
    let scatter_started = Instant::now();
    let state = &mut *state;
    for (entity, mut particle) in particles.iter_mut() {
        if !state.owns_slot(entity, &particle) {
            continue;
        }
        let slot = particle.slot as usize;
        // Where the particle was at the end of the last step (or an accepted edit): finite.
        let last = state.render_current[slot];
        let pins = &state.solver.pins;
        let solver = &mut state.solver.particles;
        let x = solver.position[slot];
        let limit = DVec3::splat(f32::MAX as f64);
        let position = if x.abs().cmple(limit).all() && solver.previous[slot].is_finite() {
            x.as_vec3()
        } else {
            // NaN, infinite or beyond f32's range (which the component cannot hold): something
            // diverged this step (a huge velocity or gravity, a constraint that cannot be met).
            // Put the particle back where it was, at rest, so that nothing non-finite leaves
            // the step or carries into the next one — a pinned one at its pin (a NaN next to
            // it reaches it as `0 · NaN`; its last position may be an old target).
            let back = pinned_target(pins, slot).unwrap_or(last.as_dvec3());
            solver.position[slot] = back;
            solver.previous[slot] = back;
            stats.diverged += 1;
            state.warn(entity, Problem::Diverged, || {
                format!("Particle's state became {x} (NaN, infinite or beyond f32's range); put back at {back}, at rest")
            });
            back.as_vec3()
        };
        let particle = particle.bypass_change_detection();
        particle.previous_position = last;
        particle.position = position;
        state.render_previous[slot] = last;
        state.render_current[slot] = position;
    }
    stats.particles = state.solver.particles.len();
    stats.sticks = state.solver.sticks.len() - state.torn_pending;
    stats.islands = state.solver.islands.list.len();
    stats.sleeping_islands = state.solver.sleeping_islands();
    stats.symmetric_islands = state.solver.symmetric_islands();
    stats.steps += 1;
    stats.gather_micros = clock.gather;
    stats.solve_micros = clock.solve;
    stats.scatter_micros = micros_since(Some(scatter_started));
    if let Some(started) = clock.started.take() {
        stats.step_micros = started.elapsed().as_secs_f32() * 1e6;
    }
}

/// Where the pin of particle `slot` holds it at the end of this step, if it is pinned (a linear
/// search: only for a particle that diverged).
fn pinned_target(pins: &Pins, slot: usize) -> Option<DVec3> {
    let i = pins.particle.iter().position(|&p| p as usize == slot)?;
    Some(pins.to[i]).filter(|target| target.is_finite())
}

/// Counts rebuilds (runs after prepare).
pub(crate) fn count_rebuilds(
    state: Res<VerletState>,
    mut stats: ResMut<VerletStats>,
    mut seen: Local<u64>,
) {
    if state.generation != *seen {
        *seen = state.generation;
        stats.rebuilds += 1;
    }
}
