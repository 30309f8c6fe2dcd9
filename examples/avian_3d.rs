//! Verlet cloth and rope in an avian3d world, coupled both ways: a cloth falls over an avian
//! capsule and a crate (an avian body) swings on a Verlet rope into a stack of avian boxes.
//!
//! `cargo run --release --features examples,avian3d --example avian_3d`
//!
//! The recipe: avian's `PhysicsPlugins`, the `VerletPlugin`, then `VerletAvianPlugin`; the same
//! gravity for both (metres: both default to 9.81 m/s² down); a `BodyAttachment` on a particle
//! fixes it to a body.

mod common;

use avian3d::prelude::*;
use bevy::prelude::*;
use bevy_verlet_physics::avian3d::{BodyAttachment, VerletAvianPlugin};
use bevy_verlet_physics::prelude::*;

fn main() {
    let mut app = common::app(
        "avian_3d - Verlet cloth and rope + avian",
        "left drag: pull the cloth or the rope | right drag: cut",
    );
    app.add_plugins((
        PhysicsPlugins::default(),
        PhysicsDebugPlugin,
        VerletAvianPlugin,
    ))
    .insert_resource(VerletInteraction::metres())
    .add_systems(Startup, (camera_and_light, metre_gizmos));
    common::add_scene(&mut app, spawn_scene);
    common::print_controls(&app);
    app.run();
}

fn camera_and_light(mut commands: Commands) {
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.5, 2.2, 4.6).looking_at(Vec3::new(0.3, 0.6, 0.0), Vec3::Y),
    ));
    commands.spawn((
        DirectionalLight::default(),
        Transform::from_xyz(3.0, 6.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
}

/// The debug lines' defaults are in pixels: pins marked 5 cm wide, particles as spheres.
fn metre_gizmos(mut store: ResMut<GizmoConfigStore>) {
    let (_, gizmos) = store.config_mut::<VerletGizmos>();
    gizmos.pin_size = 0.05;
    gizmos.spheres = true;
}

fn spawn_scene(commands: &mut Commands) {
    commands.spawn((
        common::SceneEntity,
        RigidBody::Static,
        Collider::cuboid(8.0, 0.2, 8.0),
        Transform::from_xyz(0.0, -0.1, 0.0),
    ));
    // A capsule lying across X, and a 30 × 30 cloth (5 cm cells) dropped flat over it.
    commands.spawn((
        common::SceneEntity,
        RigidBody::Static,
        Collider::capsule(0.25, 1.2),
        Transform::from_xyz(-0.6, 0.25, 0.0)
            .with_rotation(Quat::from_rotation_z(std::f32::consts::FRAC_PI_2)),
    ));
    ClothBuilder::new(Vec3::new(-1.35, 1.2, -0.75), 30, 30, 0.05)
        .axes(Vec3::X, Vec3::Z)
        .radius(0.01)
        .spawn(commands);
    // A 20 kg crate on a 2 m rope, pulled aside, and a stack of boxes in its way.
    let pin = Vec3::new(1.2, 2.6, 0.0);
    let start = Vec3::new(1.2, 1.2, 1.4);
    let crate_body = commands
        .spawn((
            common::SceneEntity,
            RigidBody::Dynamic,
            Collider::cuboid(0.3, 0.3, 0.3),
            Mass(20.0),
            Transform::from_translation(start),
        ))
        .id();
    let rope = RopeBuilder::new(pin, start + Vec3::Y * 0.15, 20)
        .mass(0.05)
        .radius(0.01)
        .pin_start()
        .spawn(commands);
    // The rope's end is fixed to the crate's top face.
    let end = *rope.particles.last().unwrap();
    commands
        .entity(end)
        .insert(BodyAttachment::new(crate_body, Vec3::Y * 0.15));
    for level in 0..4 {
        commands.spawn((
            common::SceneEntity,
            RigidBody::Dynamic,
            Collider::cuboid(0.25, 0.25, 0.25),
            Mass(1.0),
            Transform::from_xyz(1.2, 0.125 + 0.26 * level as f32, -0.6),
        ));
    }
}
