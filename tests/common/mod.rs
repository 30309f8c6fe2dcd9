//! Shared helpers for the headless system tests.
#![allow(dead_code)]

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_verlet_physics::prelude::*;

/// Bevy's default fixed timestep (64 Hz).
pub const DT: f32 = 1.0 / 64.0;

/// A headless app with the plugin, advancing exactly one fixed step per `app.update()`.
pub fn app() -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VerletPlugin::default()))
        .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
    app.finish();
    app.cleanup();
    // The first update only sets the clock's baseline and runs no fixed step.
    app.update();
    app
}

/// Runs `n` fixed steps.
pub fn step(app: &mut App, n: usize) {
    for _ in 0..n {
        app.update();
    }
}

/// Spawns with commands and applies them.
pub fn spawn<T>(app: &mut App, f: impl FnOnce(&mut Commands) -> T) -> T {
    let world = app.world_mut();
    let out = f(&mut world.commands());
    world.flush();
    out
}

pub fn particle(app: &App, entity: Entity) -> Particle {
    app.world()
        .get::<Particle>(entity)
        .expect("particle exists")
        .clone()
}

pub fn position(app: &App, entity: Entity) -> Vec3 {
    particle(app, entity).position
}

/// Every particle's position is finite.
pub fn all_finite(app: &mut App) -> bool {
    let world = app.world_mut();
    let mut query = world.query::<&Particle>();
    query
        .iter(world)
        .all(|p| p.position.is_finite() && p.previous_position.is_finite())
}

pub fn count<T: Component>(app: &mut App) -> usize {
    let world = app.world_mut();
    world.query::<&T>().iter(world).count()
}

/// Largest |length/rest − 1| over the sticks in the world.
pub fn max_strain(app: &mut App) -> f32 {
    let world = app.world_mut();
    let sticks: Vec<Stick> = world.query::<&Stick>().iter(world).cloned().collect();
    sticks
        .iter()
        .map(|s| {
            let a = world.get::<Particle>(s.a).unwrap().position;
            let b = world.get::<Particle>(s.b).unwrap().position;
            let rest = s.rest_length.unwrap();
            ((a - b).length() / rest - 1.0).abs()
        })
        .fold(0.0, f32::max)
}

/// A headless app like [`app`], with another time update strategy (the first update, which
/// only sets the clock's baseline, is run).
pub fn app_with_time(strategy: bevy::time::TimeUpdateStrategy) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VerletPlugin::default()))
        .insert_resource(strategy);
    app.finish();
    app.cleanup();
    app.update();
    app
}

/// A particle's `f64` position in the solver (finer than the `f32` component far from the
/// origin); `None` if the solver does not simulate it.
pub fn solver_position(app: &App, entity: Entity) -> Option<glam::DVec3> {
    let state = app.world().resource::<VerletState>();
    let slot = state.slot(entity)? as usize;
    state.solver.particles.position.get(slot).copied()
}

/// Total mechanical energy `Σ ½mv² + m·(−g)·x` of the movable particles in the solver, with
/// velocities over the last substep.
pub fn energy(app: &App) -> f64 {
    let world = app.world();
    let state = world.resource::<VerletState>();
    let g = world.resource::<Gravity>().0.as_dvec3();
    let p = &state.solver.particles;
    let potential: f64 = (0..p.len())
        .filter(|&i| p.inverse_mass[i] > 0.0)
        .map(|i| -g.dot(p.position[i]) / p.inverse_mass[i])
        .sum();
    kinetic_energy(app) + potential
}

/// Kinetic energy of the movable particles in the solver (velocities over the last substep of
/// each particle's island: an `IslandOverride` or `line_substeps` may give it its own).
pub fn kinetic_energy(app: &App) -> f64 {
    let world = app.world();
    let state = world.resource::<VerletState>();
    let config = world.resource::<VerletConfig>();
    let step = world.resource::<Time<Fixed>>().timestep().as_secs_f64();
    let global = step / config.substeps.max(1) as f64;
    let p = &state.solver.particles;
    (0..p.len())
        .filter(|&i| p.inverse_mass[i] > 0.0)
        .map(|i| {
            let h = state.solver.state_substep_of(i as u32).unwrap_or(global);
            0.5 * p.velocity(i, h).length_squared() / p.inverse_mass[i]
        })
        .sum()
}

/// Largest strain `length / rest − 1` (positive = stretched) over the solver's active sticks,
/// in `f64`.
pub fn solver_max_stretch(app: &App) -> f64 {
    let state = app.world().resource::<VerletState>();
    let s = &state.solver.sticks;
    (0..s.len())
        .filter(|&i| s.kind[i] != StickKind::Torn)
        .map(|i| s.strain(i, &state.solver.particles))
        .fold(0.0, f64::max)
}

/// Every position in the solver (current and previous substep) is finite.
pub fn solver_finite(app: &App) -> bool {
    app.world()
        .resource::<VerletState>()
        .solver
        .particles
        .all_finite()
}

/// Checks, right after a fixed step, that the solver's tables match the components: every
/// solver slot is a live particle entity that maps back to it, with the component at the
/// solver's position (and a finite previous position); every particle left out has a
/// non-finite position; every active solver stick is a live `Stick` between the right slots,
/// each at most once; every live `Stick` between two simulated particles (not a self-stick, not
/// of kind `Torn`, not of infinite compliance) is in the solver; and a simulated particle is
/// pinned in the solver iff it has a `Pin`.
pub fn check_consistency(app: &mut App) -> Result<(), String> {
    use std::collections::HashSet;
    let world = app.world_mut();
    let particles: Vec<(Entity, Particle, bool)> = world
        .query::<(Entity, &Particle, Has<Pin>)>()
        .iter(world)
        .map(|(e, p, pinned)| (e, p.clone(), pinned))
        .collect();
    let sticks: Vec<(Entity, Stick)> = world
        .query::<(Entity, &Stick)>()
        .iter(world)
        .map(|(e, s)| (e, s.clone()))
        .collect();
    let state = world.resource::<VerletState>();
    let solver = &state.solver;
    for slot in 0..solver.particles.len() {
        let entity = state
            .particle_entity(slot)
            .ok_or(format!("slot {slot} has no entity"))?;
        if state.slot(entity) != Some(slot as u32) {
            return Err(format!("slot {slot} ({entity}) does not map back"));
        }
        if world.get::<Particle>(entity).is_none() {
            return Err(format!("slot {slot} ({entity}) is not a live particle"));
        }
    }
    let pinned_slots: HashSet<u32> = solver.pins.particle.iter().copied().collect();
    for (entity, particle, pinned) in &particles {
        match state.slot(*entity) {
            Some(slot) => {
                if state.particle_entity(slot as usize) != Some(*entity) {
                    return Err(format!("{entity} maps to slot {slot} of another entity"));
                }
                let x = solver.particles.position[slot as usize].as_vec3();
                if !particle.previous_position.is_finite() {
                    return Err(format!(
                        "{entity}: previous position {}",
                        particle.previous_position
                    ));
                }
                if particle.position != x {
                    return Err(format!(
                        "{entity}: component at {} but solver at {x}",
                        particle.position
                    ));
                }
                if *pinned != pinned_slots.contains(&slot) {
                    return Err(format!("{entity}: Pin {pinned} but solver pin differs"));
                }
            }
            None => {
                if particle.position.is_finite() && particle.previous_position.is_finite() {
                    return Err(format!("{entity} is finite but not simulated"));
                }
            }
        }
    }
    let mut in_solver = HashSet::new();
    for i in 0..solver.sticks.len() {
        if solver.sticks.kind[i] == StickKind::Torn {
            continue;
        }
        let entity = state
            .stick_entity(i)
            .ok_or(format!("stick {i} has no entity"))?;
        let stick = world
            .get::<Stick>(entity)
            .ok_or(format!("solver stick {i} ({entity}) is not a live Stick"))?;
        let ends = [state.slot(stick.a), state.slot(stick.b)];
        if ends != solver.sticks.ends()[i].map(Some) {
            return Err(format!(
                "stick {entity}: ends {ends:?} vs solver {:?}",
                solver.sticks.ends()[i]
            ));
        }
        if !in_solver.insert(entity) {
            return Err(format!("stick {entity} is in the solver twice"));
        }
    }
    for (entity, stick) in &sticks {
        let simulated = state.slot(stick.a).is_some() && state.slot(stick.b).is_some();
        let expected = simulated
            && stick.a != stick.b
            && stick.kind != StickKind::Torn
            && stick.stiffness.compliance(1.0) != f64::INFINITY;
        if expected != in_solver.contains(entity) {
            return Err(format!(
                "stick {entity} ({} → {}): expected in solver {expected}",
                stick.a, stick.b
            ));
        }
    }
    Ok(())
}
