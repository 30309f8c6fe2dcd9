//! The Tuts+ ragdolls: human proportions and masses, joint limits, floor and walls.
//! Click empty space to drop another ragdoll; drag and throw them.
//!
//! `cargo run --release --features examples --example ragdoll`
//!
//! Also shows how to dress a simulation: every bone is a sprite that follows its stick
//! ([`FollowStick`]) and the head is a circle mesh that follows its particle
//! ([`FollowParticle`]). Press H to hide the debug lines and see only the sprites.

mod common;

use bevy::prelude::*;
use bevy_verlet_physics::builders::ragdoll_part::*;
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::scenes;

fn main() {
    let mut app = common::app(
        "ragdoll",
        "click empty space: drop a ragdoll | left drag: grab and throw | S sprites on/off",
    );
    app.insert_resource(Gravity::PIXELS)
        .add_systems(Startup, |mut commands: Commands| {
            commands.spawn(Camera2d);
        })
        .add_systems(Update, (spawn_on_click, dress_ragdolls, toggle_sprites));
    if common::screenshot_mode() {
        app.add_systems(Update, scripted_drops);
    }
    // Five ragdolls standing across the window, with walls and a floor.
    common::add_scene(&mut app, |commands| {
        scenes::ragdolls(commands, 5);
    });
    common::print_controls(&app);
    app.run();
}

/// Left click where no particle is under the cursor drops a new ragdoll there.
fn spawn_on_click(
    buttons: Res<ButtonInput<MouseButton>>,
    interaction: Res<VerletInteraction>,
    mut commands: Commands,
    mut count: Local<u32>,
) {
    if !buttons.just_pressed(MouseButton::Left) || interaction.hovered().is_some() {
        return;
    }
    if let Some(ray) = interaction.cursor_ray() {
        *count += 1;
        let feet = ray.origin.with_z(0.0) - Vec3::Y * scenes::RAGDOLL_HEIGHT * 0.6;
        scenes::spawn_ragdoll(&mut commands, feet, count.is_multiple_of(2));
    }
}

/// Screenshot mode only: drops three more ragdolls, as clicks would.
fn scripted_drops(mut frame: Local<u32>, mut commands: Commands) {
    *frame += 1;
    if let Some(i) = [20, 45, 70].iter().position(|&f| f == *frame) {
        let feet = Vec3::new(-300.0 + 280.0 * i as f32, 120.0, 0.0);
        scenes::spawn_ragdoll(&mut commands, feet, i % 2 == 0);
    }
}

/// Gives every new ragdoll sprites that follow its sticks and a head that follows its particle.
fn dress_ragdolls(
    ragdolls: Query<&Composite, Added<Composite>>,
    particles: Query<&Particle>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<ColorMaterial>>,
    mut commands: Commands,
) {
    for doll in &ragdolls {
        if doll.particles.len() != 11 {
            continue;
        }
        let p = &doll.particles;
        let width = scenes::RAGDOLL_HEIGHT / 7.5 * 0.35;
        // The torso (a soft link, drawn wider) and the rigid bones.
        let torso = (SHOULDER, PELVIS);
        for (i, &(a, b)) in std::iter::once(&torso).chain(&BONES).enumerate() {
            // A 1 × width sprite stretched along the stick (local +X is a → b).
            let shade = if i == 0 { 0.75 } else { 0.55 };
            commands.spawn((
                common::SceneEntity,
                Bone,
                Sprite::from_color(
                    Color::srgb(shade, shade * 0.8, 0.45),
                    Vec2::new(1.0, if i == 0 { width * 2.0 } else { width }),
                ),
                Transform::from_xyz(0.0, 0.0, -1.0),
                FollowStick {
                    a: p[a],
                    b: p[b],
                    stretch: true,
                },
            ));
        }
        let radius = particles.get(p[HEAD]).map_or(10.0, |head| head.radius);
        commands.spawn((
            common::SceneEntity,
            Bone,
            Mesh2d(meshes.add(Circle::new(radius))),
            MeshMaterial2d(materials.add(Color::srgb(0.9, 0.75, 0.6))),
            Transform::from_xyz(0.0, 0.0, -1.0),
            FollowParticle(p[HEAD]),
        ));
    }
}

/// Marks the sprites and meshes that dress a ragdoll.
#[derive(Component)]
struct Bone;

/// S shows or hides the sprites.
fn toggle_sprites(keys: Res<ButtonInput<KeyCode>>, mut bones: Query<&mut Visibility, With<Bone>>) {
    if keys.just_pressed(KeyCode::KeyS) {
        for mut visibility in &mut bones {
            visibility.toggle_visible_hidden();
        }
    }
}
