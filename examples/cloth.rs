//! The Tuts+ "Curtain": a tearable cloth. Drag it, rip it, throw it.
//!
//! `cargo run --release --features examples --example cloth`

mod common;

use bevy::prelude::*;
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::scenes;

fn main() {
    let mut app = common::app(
        "cloth — tearable curtain",
        "left drag: pull the cloth (release to throw) | right drag: tear | pull hard and it rips",
    );
    common::print_controls(&app);
    app.insert_resource(Gravity::PIXELS)
        .add_systems(Startup, setup)
        .add_systems(Update, reset);
    if std::env::var("VERLET_SCREENSHOT").is_ok() {
        app.add_systems(Update, scripted_cut);
    }
    app.run();
}

/// Marks what a reset despawns.
#[derive(Component)]
struct Scene;

fn setup(mut commands: Commands) {
    commands.spawn(Camera2d);
    spawn_curtain(&mut commands);
}

fn spawn_curtain(commands: &mut Commands) {
    let curtain = scenes::curtain(commands);
    commands.entity(curtain.root).insert(Scene);
}

fn reset(
    mut requests: MessageReader<ResetRequested>,
    scene: Query<Entity, With<Scene>>,
    mut commands: Commands,
) {
    if requests.read().count() > 0 {
        common::despawn_all(&mut commands, &scene);
        spawn_curtain(&mut commands);
    }
}

/// Screenshot mode only: rips a slit through the curtain, as a right-drag would.
fn scripted_cut(mut frame: Local<u32>, state: Res<VerletState>, mut commands: Commands) {
    *frame += 1;
    if *frame != 60 {
        return;
    }
    let solver = &state.solver;
    for (i, &[a, b]) in solver.sticks.ends.iter().enumerate() {
        let mid =
            (solver.particles.position[a as usize] + solver.particles.position[b as usize]) * 0.5;
        // A slanted slit from the bottom edge up to the middle.
        let on_slit = (mid.x - (80.0 + 0.5 * (mid.y + 120.0))).abs() < 4.0 && mid.y < 120.0;
        if on_slit && let Some(stick) = state.stick_entity(i) {
            commands.entity(stick).despawn();
        }
    }
}
