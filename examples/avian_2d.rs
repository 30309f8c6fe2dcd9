//! Verlet ropes, cloth and ragdolls in an avian2d world, coupled both ways: a wrecking ball
//! (an avian body) on a Verlet rope smashes a stack of avian boxes, a cloth drapes over an avian
//! capsule, ragdolls tumble down avian ramps, and a crate hangs from a rope you can drag.
//!
//! `cargo run --release --features examples,avian2d --example avian_2d`
//!
//! The recipe: add avian's `PhysicsPlugins` (here in pixels: `with_length_unit(50.0)`), the
//! `VerletPlugin`, then `VerletAvianPlugin`; give both engines the same gravity; put a
//! `BodyAttachment` on a particle to fix it to a body. The scene itself is the library function
//! `bevy_verlet_physics::avian2d::scene::spawn` (so `tests/avian2d.rs` steps what this shows).

mod common;

use avian2d::prelude::*;
use bevy::prelude::*;
use bevy_verlet_physics::avian2d::VerletAvianPlugin;
use bevy_verlet_physics::avian2d::scene::{self, GRAVITY};
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::scenes;

fn main() {
    let mut app = common::app(
        "avian_2d - Verlet + avian, both ways",
        "left drag: pull ropes, cloth, ragdolls | right drag: cut | click empty space: drop a ragdoll",
    );
    app.add_plugins((
        PhysicsPlugins::default().with_length_unit(50.0),
        PhysicsDebugPlugin,
        VerletAvianPlugin,
    ))
    .insert_resource(bevy_verlet_physics::Gravity(Vec3::Y * GRAVITY))
    .insert_resource(avian2d::prelude::Gravity(Vec2::Y * GRAVITY))
    .add_systems(Startup, |mut commands: Commands| {
        commands.spawn(Camera2d);
    })
    .add_systems(Update, drop_ragdoll_on_click);
    common::add_scene(&mut app, spawn_scene);
    common::print_controls(&app);
    app.run();
}

/// The library's scene (`bevy_verlet_physics::avian2d::scene`); its avian bodies are marked so
/// that a reset (R) removes them (composites are removed anyway).
fn spawn_scene(commands: &mut Commands) {
    let scene = scene::spawn(commands);
    for entity in scene.avian_entities() {
        commands.entity(entity).insert(common::SceneEntity);
    }
}

/// Left click where no particle is under the cursor drops a ragdoll there.
fn drop_ragdoll_on_click(
    buttons: Res<ButtonInput<MouseButton>>,
    interaction: Res<VerletInteraction>,
    mut commands: Commands,
) {
    if !buttons.just_pressed(MouseButton::Left) || interaction.hovered().is_some() {
        return;
    }
    if let Some(ray) = interaction.cursor_ray() {
        let feet = ray.origin.with_z(0.0) - Vec3::Y * scenes::RAGDOLL_HEIGHT * 0.6;
        scenes::spawn_ragdoll(&mut commands, feet, false);
    }
}
