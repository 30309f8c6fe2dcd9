//! The verlet-js "shapes" demo: tires whose tread and spokes have their own stiffness, a slack
//! bridge pinned at both ends, and a tree held up by angle constraints.
//!
//! `cargo run --release --features examples --example shapes`

mod common;

use bevy::prelude::*;
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::scenes;

fn main() {
    let mut app = common::app(
        "shapes - verlet-js",
        "left drag: grab a tire, the bridge or a branch (release to throw) | right drag: cut",
    );
    app.insert_resource(Gravity::PIXELS)
        .add_systems(Startup, |mut commands: Commands| {
            commands.spawn(Camera2d);
        });
    // Three tires (verlet-js stiffnesses), a bridge and a tree (see `scenes::shapes`).
    common::add_scene(&mut app, |commands| {
        scenes::shapes(commands);
    });
    common::print_controls(&app);
    app.run();
}
