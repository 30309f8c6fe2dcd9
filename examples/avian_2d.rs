//! Verlet ropes, cloth and ragdolls in an avian2d world, coupled both ways: a wrecking ball
//! (an avian body) on a Verlet rope smashes a stack of avian boxes, a cloth drapes over an avian
//! capsule, ragdolls tumble down avian ramps, and a crate hangs from a rope you can drag.
//!
//! `cargo run --release --features examples,avian2d --example avian_2d`
//!
//! The recipe: add avian's `PhysicsPlugins` (here in pixels: `with_length_unit(50.0)`), the
//! `VerletPlugin`, then `VerletAvianPlugin`; give both engines the same gravity; put a
//! `BodyAttachment` on a particle to fix it to a body.

mod common;

use avian2d::prelude::*;
use bevy::prelude::*;
use bevy_verlet_physics::avian2d::{BodyAttachment, VerletAvianPlugin};
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::scenes;

/// Gravity in pixels per second², for both engines.
const GRAVITY: f32 = -980.0;

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

fn spawn_scene(commands: &mut Commands) {
    // Ground, walls and two ramps: static avian colliders.
    let wall = |commands: &mut Commands, at: Vec2, size: Vec2, turn: f32| {
        commands.spawn((
            common::SceneEntity,
            RigidBody::Static,
            Collider::rectangle(size.x, size.y),
            Transform::from_translation(at.extend(0.0)).with_rotation(Quat::from_rotation_z(turn)),
        ));
    };
    wall(
        commands,
        Vec2::new(0.0, -340.0),
        Vec2::new(1280.0, 40.0),
        0.0,
    );
    wall(
        commands,
        Vec2::new(-630.0, 0.0),
        Vec2::new(20.0, 720.0),
        0.0,
    );
    wall(commands, Vec2::new(630.0, 0.0), Vec2::new(20.0, 720.0), 0.0);
    wall(
        commands,
        Vec2::new(-420.0, 60.0),
        Vec2::new(300.0, 16.0),
        -0.35,
    );
    wall(
        commands,
        Vec2::new(-200.0, -120.0),
        Vec2::new(260.0, 16.0),
        0.35,
    );

    wrecking_ball(commands);
    box_stack(commands, Vec2::new(380.0, -295.0));
    draped_cloth(commands, Vec2::new(60.0, -230.0));
    // Two ragdolls above the ramps.
    scenes::spawn_ragdoll(commands, Vec3::new(-470.0, 140.0, 0.0), false);
    scenes::spawn_ragdoll(commands, Vec3::new(-380.0, 220.0, 0.0), true);
}

/// A 40 kg ball on a 20-link Verlet rope from a pin, pulled back to the left.
fn wrecking_ball(commands: &mut Commands) {
    let pin = Vec3::new(400.0, 250.0, 0.0);
    let start = Vec3::new(60.0, 150.0, 0.0);
    let ball = commands
        .spawn((
            common::SceneEntity,
            RigidBody::Dynamic,
            Collider::circle(40.0),
            Mass(40.0),
            Transform::from_translation(start),
        ))
        .id();
    let rope = RopeBuilder::new(pin, start, 20)
        .mass(0.2)
        .radius(3.0)
        .pin_start()
        .spawn(commands);
    // The rope's last particle is fixed to the ball's centre: the ball swings on the rope and
    // the rope feels the ball's 40 kg.
    let end = *rope.particles.last().unwrap();
    commands
        .entity(end)
        .insert(BodyAttachment::new(ball, Vec2::ZERO));
}

/// Five rows of avian boxes.
fn box_stack(commands: &mut Commands, base: Vec2) {
    for row in 0..5 {
        for column in 0..3 {
            let at = base + Vec2::new(column as f32 * 52.0, row as f32 * 52.0 + 26.0);
            commands.spawn((
                common::SceneEntity,
                RigidBody::Dynamic,
                Collider::rectangle(50.0, 50.0),
                Transform::from_translation(at.extend(0.0)),
            ));
        }
    }
}

/// A capsule lying on the ground and a 24 × 4 cloth strip dropped over it.
fn draped_cloth(commands: &mut Commands, capsule: Vec2) {
    commands.spawn((
        common::SceneEntity,
        RigidBody::Static,
        Collider::capsule(40.0, 120.0),
        Transform::from_translation(capsule.extend(0.0))
            .with_rotation(Quat::from_rotation_z(std::f32::consts::FRAC_PI_2)),
    ));
    ClothBuilder::new(
        capsule.extend(0.0) + Vec3::new(-120.0, 150.0, 0.0),
        24,
        4,
        10.0,
    )
    .radius(3.0)
    .spawn(commands);
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
