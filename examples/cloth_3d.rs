//! A 3D cloth pinned at two corners falls onto a sphere. Drawn as a textured, lit mesh whose
//! vertices and normals follow the particles ([`ClothMesh`]), and with 3D gizmo lines.
//!
//! `cargo run --release --features examples --example cloth_3d`

mod common;

use bevy::asset::RenderAssetUsages;
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::scenes::{self, CLOTH_3D};

fn main() {
    let mut app = common::app(
        "cloth_3d - cloth on a sphere",
        "M: mesh / lines / both | left drag: pull the cloth | right drag: cut",
    );
    // Metres: default gravity (9.81 m/s²) and grab radii in metres.
    app.insert_resource(VerletInteraction::metres())
        .add_systems(Startup, (camera_and_light, hide_lines))
        .add_systems(Update, cycle_view);
    common::add_scene(&mut app, spawn_scene);
    common::print_controls(&app);
    app.run();
}

fn camera_and_light(mut commands: Commands) {
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(2.4, 2.3, 3.4).looking_at(Vec3::new(0.0, 0.6, 0.0), Vec3::Y),
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 8_000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(3.0, 6.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.insert_resource(GlobalAmbientLight {
        brightness: 400.0,
        ..default()
    });
}

/// The physics scene (cloth, sphere and ground colliders) plus what makes it visible.
fn spawn_scene(commands: &mut Commands) {
    let cloth = scenes::cloth_3d(commands);
    let (columns, rows, _) = CLOTH_3D;
    let cloth_mesh = ClothMesh::new(columns, rows, cloth.particles.clone());
    commands.queue(move |world: &mut World| {
        let mesh = world.resource_mut::<Assets<Mesh>>().add(cloth_mesh.mesh());
        let texture = world.resource_mut::<Assets<Image>>().add(checker());
        let mut materials = world.resource_mut::<Assets<StandardMaterial>>();
        let cloth_material = materials.add(StandardMaterial {
            base_color_texture: Some(texture),
            perceptual_roughness: 0.9,
            double_sided: true,
            cull_mode: None,
            ..default()
        });
        let sphere_material = materials.add(Color::srgb(0.35, 0.45, 0.7));
        let ground_material = materials.add(Color::srgb(0.3, 0.32, 0.3));
        let mut meshes = world.resource_mut::<Assets<Mesh>>();
        // Slightly smaller than the collider so the cloth does not z-fight with it.
        let sphere = meshes.add(Sphere::new(0.49).mesh().uv(48, 24));
        let ground = meshes.add(Plane3d::default().mesh().size(8.0, 8.0));
        world.spawn((
            common::SceneEntity,
            cloth_mesh,
            Mesh3d(mesh),
            MeshMaterial3d(cloth_material),
        ));
        world.spawn((
            common::SceneEntity,
            Mesh3d(sphere),
            MeshMaterial3d(sphere_material),
            Transform::from_xyz(0.0, 0.5, 0.0),
        ));
        world.spawn((
            common::SceneEntity,
            Mesh3d(ground),
            MeshMaterial3d(ground_material),
        ));
    });
}

/// A 256 × 256 red and cream checkerboard.
fn checker() -> Image {
    const SIZE: u32 = 256;
    let data = (0..SIZE * SIZE)
        .flat_map(|i| {
            let (x, y) = (i % SIZE / 32, i / SIZE / 32);
            if (x + y) % 2 == 0 {
                [190, 50, 50, 255]
            } else {
                [235, 225, 205, 255]
            }
        })
        .collect();
    Image::new(
        Extent3d {
            width: SIZE,
            height: SIZE,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        data,
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::RENDER_WORLD,
    )
}

/// What is drawn: the mesh, the debug lines, or both.
#[derive(Resource, Default, Clone, Copy, PartialEq, Eq, Debug)]
enum View {
    #[default]
    Mesh,
    Lines,
    Both,
}

/// Starts with the mesh only (the lines are the debug view).
fn hide_lines(mut store: ResMut<GizmoConfigStore>, mut commands: Commands) {
    store.config_mut::<VerletGizmos>().0.enabled = false;
    commands.init_resource::<View>();
}

/// M cycles mesh → lines → both.
fn cycle_view(
    keys: Res<ButtonInput<KeyCode>>,
    mut view: ResMut<View>,
    mut store: ResMut<GizmoConfigStore>,
    mut cloths: Query<&mut Visibility, With<ClothMesh>>,
) {
    if keys.just_pressed(KeyCode::KeyM) {
        *view = match *view {
            View::Mesh => View::Lines,
            View::Lines => View::Both,
            View::Both => View::Mesh,
        };
        store.config_mut::<VerletGizmos>().0.enabled = *view != View::Mesh;
        for mut visibility in &mut cloths {
            *visibility = if *view == View::Lines {
                Visibility::Hidden
            } else {
                Visibility::Visible
            };
        }
    }
}
