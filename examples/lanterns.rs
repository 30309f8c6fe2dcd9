//! Lanterns on ropes hung from several posts: a rope across three posts with four heavy
//! lanterns on strings, and a chandelier held by three ropes. Trees held by three or more pins
//! are split at their pins and solved exactly (`solver::tree`): the ropes do not stretch under
//! lanterns 100 times a link's mass.
//!
//! `cargo run --release --features examples --example lanterns`

mod common;

use bevy::prelude::*;
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::scenes;

fn main() {
    let mut app = common::app(
        "lanterns - trees held by several pins",
        "left drag: grab a lantern or a rope (release to throw) | right drag: cut",
    );
    app.insert_resource(Gravity::PIXELS)
        .add_systems(Startup, |mut commands: Commands| {
            commands.spawn(Camera2d);
        });
    // The rope and the chandelier (see `scenes::lanterns`).
    common::add_scene(&mut app, |commands| {
        scenes::lanterns(commands);
    });
    common::print_controls(&app);
    app.run();
}
