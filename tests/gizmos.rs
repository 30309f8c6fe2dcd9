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

#[test]
fn gizmo_plugin_draws_one_line_per_stick_headless() {
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
