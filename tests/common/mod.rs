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
