//! The Tuts+ "Curtain": a tearable cloth. Drag it, rip it, throw it.
//!
//! `cargo run --release --features examples --example cloth`

mod common;

use bevy::prelude::*;
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::scenes;

fn main() {
    let mut app = common::app(
        "cloth - tearable curtain",
        "left drag: pull the cloth (release to throw) | right drag: tear | pull hard and it rips",
    );
    // The scene is in pixels: g = 980 px/s².
    app.insert_resource(Gravity::PIXELS)
        .add_systems(Startup, |mut commands: Commands| {
            commands.spawn(Camera2d);
        });
    // 100 × 60 particles, top row pinned, tears at 150 % strain (see `scenes::curtain`).
    common::add_scene(&mut app, |commands| {
        scenes::curtain(commands);
    });
    if common::screenshot_mode() {
        app.add_systems(Update, scripted_cut);
    }
    common::print_controls(&app);
    app.run();
}

/// Screenshot mode only: rips a slanted slit through the curtain, as a right-drag would.
fn scripted_cut(
    mut frame: Local<u32>,
    state: Res<VerletState>,
    mut torn: MessageWriter<StickTorn>,
    mut commands: Commands,
) {
    *frame += 1;
    if *frame != 60 {
        return;
    }
    let solver = &state.solver;
    for (i, &[a, b]) in solver.sticks.ends().iter().enumerate() {
        let mid =
            (solver.particles.position[a as usize] + solver.particles.position[b as usize]) * 0.5;
        let on_slit = (mid.x - (80.0 + 0.5 * (mid.y + 120.0))).abs() < 4.0 && mid.y < 120.0;
        if on_slit && let Some(message) = state.stick_torn(i) {
            commands.entity(message.stick).despawn();
            torn.write(message);
        }
    }
}
