//! The debug renderer runs headless and emits one line per stick.
#![cfg(feature = "gizmos")]

mod common;
use bevy::gizmos::config::GizmoConfigStore;
use bevy::gizmos::{GizmoAsset, GizmoHandles};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_verlet_physics::prelude::*;
use std::any::TypeId;

fn line_points(app: &App) -> usize {
    let handles = app.world().resource::<GizmoHandles>();
    let Some(Some(handle)) = handles.handles().get(&TypeId::of::<VerletGizmos>()) else {
        return 0;
    };
    let assets = app.world().resource::<Assets<GizmoAsset>>();
    assets
        .get(handle)
        .map_or(0, |asset| asset.buffer().list_positions.len())
}

/// A headless app with the debug renderer (bevy 0.19 gizmos need `AssetPlugin` and
/// `MeshPlugin`), one fixed step per update, clock started.
fn gizmo_app() -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin::default(),
        bevy::mesh::MeshPlugin,
        bevy::gizmos::GizmoPlugin,
        VerletPlugin::default(),
        VerletDebugPlugin,
    ))
    .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
    app.finish();
    app.cleanup();
    app.update();
    app
}

#[test]
fn gizmo_plugin_draws_one_line_per_stick_headless() {
    let mut app = gizmo_app();
    {
        let mut store = app.world_mut().resource_mut::<GizmoConfigStore>();
        let (_, style) = store.config_mut::<VerletGizmos>();
        style.pin_color = None;
        style.particle_color = None;
    }
    let world = app.world_mut();
    let cloth = ClothBuilder::new(Vec3::ZERO, 4, 3, 1.0)
        .pin_top_row(1)
        .spawn(&mut world.commands());
    world.flush();
    for _ in 0..3 {
        app.update();
    }
    let sticks = 3 * 3 + 4 * 2;
    assert_eq!(cloth.sticks.len(), sticks);
    assert_eq!(line_points(&app), 2 * sticks);

    // Pins add two lines each when shown.
    {
        let mut store = app.world_mut().resource_mut::<GizmoConfigStore>();
        store.config_mut::<VerletGizmos>().1.pin_color = Some(Color::WHITE);
    }
    app.update();
    assert_eq!(line_points(&app), 2 * sticks + 4 * 4);

    // Disabling the group draws nothing.
    {
        let mut store = app.world_mut().resource_mut::<GizmoConfigStore>();
        store.config_mut::<VerletGizmos>().0.enabled = false;
    }
    app.update();
    assert_eq!(line_points(&app), 0);
}

#[test]
fn cloth_mesh_vertices_and_normals_follow_the_particles() {
    let mut app = gizmo_app();
    let (columns, rows) = (6, 5);
    let cloth = common::spawn(&mut app, |c| {
        ClothBuilder::new(Vec3::ZERO, columns, rows, 0.1)
            .axes(Vec3::X, Vec3::Z)
            .pin_top_corners()
            .spawn(c)
    });
    let cloth_mesh = ClothMesh::new(columns, rows, cloth.particles.clone());
    let mesh = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(cloth_mesh.mesh());
    app.world_mut().spawn((cloth_mesh, Mesh3d(mesh.clone())));
    common::step(&mut app, 30);
    let world = app.world();
    let mesh = world.resource::<Assets<Mesh>>().get(&mesh).unwrap();
    let positions = mesh
        .attribute(Mesh::ATTRIBUTE_POSITION)
        .unwrap()
        .as_float3()
        .unwrap();
    let Some(bevy::mesh::VertexAttributeValues::Float32x3(normals)) =
        mesh.attribute(Mesh::ATTRIBUTE_NORMAL)
    else {
        panic!("no normals");
    };
    // The in-place normals are Bevy's area-weighted smooth normals of the same mesh.
    let mut reference = mesh.clone();
    reference.compute_area_weighted_normals();
    let Some(bevy::mesh::VertexAttributeValues::Float32x3(expected_normals)) =
        reference.attribute(Mesh::ATTRIBUTE_NORMAL)
    else {
        panic!("no reference normals");
    };
    for (i, (n, e)) in normals.iter().zip(expected_normals).enumerate() {
        let (n, e) = (Vec3::from(*n), Vec3::from(*e));
        assert!((n - e).length() < 1e-4, "normal {i}: {n} vs {e}");
    }
    let fraction = world.resource::<Time<Fixed>>().overstep_fraction();
    for (i, &entity) in cloth.particles.iter().enumerate() {
        let expected = world
            .get::<Particle>(entity)
            .unwrap()
            .interpolated(fraction);
        assert_eq!(Vec3::from(positions[i]), expected, "vertex {i}");
        let n = Vec3::from(normals[i]);
        assert!((n.length() - 1.0).abs() < 1e-4, "normal {i} = {n}");
    }
    // The cloth has fallen from its flat start, so the mesh is not flat any more.
    assert!(positions.iter().any(|p| p[1] < -0.05));
}

/// Opacity of every line the debug renderer emitted last frame.
fn line_alphas(app: &App) -> Vec<f32> {
    let handles = app.world().resource::<GizmoHandles>();
    let Some(Some(handle)) = handles.handles().get(&TypeId::of::<VerletGizmos>()) else {
        return Vec::new();
    };
    let assets = app.world().resource::<Assets<GizmoAsset>>();
    assets.get(handle).map_or(Vec::new(), |asset| {
        asset.buffer().list_colors.iter().map(|c| c.alpha).collect()
    })
}

#[test]
fn sleeping_islands_are_drawn_faded() {
    let mut app = gizmo_app();
    {
        let mut store = app.world_mut().resource_mut::<GizmoConfigStore>();
        let (_, style) = store.config_mut::<VerletGizmos>();
        style.pin_color = None;
        style.particle_color = None;
    }
    app.insert_resource(VerletConfig {
        damping: 5.0,
        ..default()
    });
    let rope = {
        let world = app.world_mut();
        let rope = RopeBuilder::new(Vec3::ZERO, Vec3::new(0.0, -1.0, 0.0), 4)
            .pin_start()
            .spawn(&mut world.commands());
        world.flush();
        rope
    };
    app.update();
    assert!(line_alphas(&app).iter().all(|&a| a == 1.0));
    let mut steps = 0;
    while !app
        .world()
        .resource::<VerletState>()
        .is_sleeping(rope.particles[1])
    {
        app.update();
        steps += 1;
        assert!(steps < 64 * 10, "the hanging rope falls asleep");
    }
    app.update();
    let alphas = line_alphas(&app);
    assert_eq!(alphas.len(), 8, "four sticks, two points each");
    assert!(
        alphas.iter().all(|&a| (a - 0.45).abs() < 1e-6),
        "{alphas:?}"
    );
}
