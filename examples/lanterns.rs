//! Lanterns on ropes hung from several posts: a rope across three posts with four heavy
//! lanterns on strings, and a chandelier held by three ropes. Trees held by three or more pins
//! are split at their pins and solved exactly (`solver::tree`): the ropes do not stretch under
//! lanterns 100 times a link's mass. L gives the ropes 2 substeps of their own while the step
//! keeps 8 (`VerletConfig::line_substeps`): exact all the same, at a fraction of the solve time
//! (the status line shows it).
//!
//! `cargo run --release --features examples --example lanterns`

mod common;

use bevy::prelude::*;
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::scenes;

fn main() {
    let mut app = common::app(
        "lanterns - trees held by several pins",
        "left drag: grab a lantern or a rope (release to throw) | right drag: cut | L: ropes at 2 substeps on/off",
    );
    app.insert_resource(Gravity::PIXELS)
        .add_systems(Startup, |mut commands: Commands| {
            commands.spawn(Camera2d);
        });
    // The rope and the chandelier (see `scenes::lanterns`).
    common::add_scene(&mut app, |commands| {
        scenes::lanterns(commands);
    });
    app.add_systems(Update, toggle_line_substeps);
    common::print_controls(&app);
    app.run();
}

/// L switches the ropes between the step's substeps and 2 of their own.
fn toggle_line_substeps(keys: Res<ButtonInput<KeyCode>>, mut config: ResMut<VerletConfig>) {
    if keys.just_pressed(KeyCode::KeyL) {
        config.line_substeps = match config.line_substeps {
            None => Some(2),
            Some(_) => None,
        };
    }
}
