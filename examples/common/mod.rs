//! Shared example code: window, plugins, on-screen help and stats, and a screenshot mode.
//!
//! Run any example with `VERLET_SCREENSHOT=out.png` to save a PNG after
//! `VERLET_SCREENSHOT_FRAMES` frames (default 180) and exit.
#![allow(dead_code)] // each example uses a subset

use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, save_to_disk};
use bevy_verlet_physics::prelude::*;

/// Controls every example shares (handled by `VerletInteractionPlugin`).
pub const COMMON_CONTROLS: &str =
    "G gravity | P pause | Enter step (paused) | H hide lines | R reset";

/// An app with a 1280×720 window, the Verlet plugins, and the help and stats overlay.
///
/// Bevy's default font covers ASCII only: keep `title` and `controls` ASCII.
pub fn app(title: &str, controls: &str) -> App {
    let mut app = App::new();
    app.add_plugins(DefaultPlugins.set(WindowPlugin {
        primary_window: Some(Window {
            title: title.to_string(),
            resolution: (1280, 720).into(),
            ..default()
        }),
        ..default()
    }))
    .add_plugins((
        VerletPlugin::default(),
        VerletDebugPlugin,
        VerletInteractionPlugin,
    ))
    .insert_resource(ClearColor(Color::srgb(0.08, 0.09, 0.11)))
    .insert_resource(Help(format!("{title}\n{controls}\n{COMMON_CONTROLS}")))
    .init_resource::<TornCount>()
    .add_systems(Startup, spawn_overlay)
    .add_systems(Update, (count_tears, update_overlay).chain());
    if let Ok(path) = std::env::var("VERLET_SCREENSHOT") {
        let frames = std::env::var("VERLET_SCREENSHOT_FRAMES")
            .ok()
            .and_then(|f| f.parse().ok())
            .unwrap_or(180);
        app.insert_resource(ScreenshotPlan {
            path,
            frames,
            frame: 0,
        })
        .add_systems(Update, screenshot);
    }
    app
}

/// Whether the example runs in screenshot mode (`VERLET_SCREENSHOT` set).
pub fn screenshot_mode() -> bool {
    std::env::var_os("VERLET_SCREENSHOT").is_some()
}

/// Prints the controls to the terminal too.
pub fn print_controls(app: &App) {
    println!("{}", app.world().resource::<Help>().0);
}

#[derive(Resource)]
struct Help(String);

/// Sticks torn or cut since startup.
#[derive(Resource, Default)]
pub struct TornCount(pub u64);

#[derive(Component)]
struct StatsText;

fn spawn_overlay(mut commands: Commands, help: Res<Help>) {
    commands.spawn((
        Text::new(help.0.clone()),
        TextFont::from_font_size(15.0),
        TextColor(Color::srgb(0.85, 0.88, 0.92)),
        Node {
            position_type: PositionType::Absolute,
            top: Val::Px(8.0),
            left: Val::Px(10.0),
            ..default()
        },
    ));
    commands.spawn((
        StatsText,
        Text::new(""),
        TextFont::from_font_size(15.0),
        TextColor(Color::srgb(0.6, 0.9, 0.6)),
        Node {
            position_type: PositionType::Absolute,
            bottom: Val::Px(8.0),
            left: Val::Px(10.0),
            ..default()
        },
    ));
}

fn count_tears(mut torn: MessageReader<StickTorn>, mut count: ResMut<TornCount>) {
    count.0 += torn.read().count() as u64;
}

fn update_overlay(
    stats: Res<VerletStats>,
    config: Res<VerletConfig>,
    gravity: Res<Gravity>,
    torn: Res<TornCount>,
    mut text: Query<&mut Text, With<StatsText>>,
) {
    let Ok(mut text) = text.single_mut() else {
        return;
    };
    text.0 = format!(
        "particles {}  sticks {}  islands {} ({} asleep, {} symmetric)  torn {}  solver {:.0} us/step  {} substeps{} x {} iterations  gravity {}{}",
        stats.particles,
        stats.sticks,
        stats.islands,
        stats.sleeping_islands,
        stats.symmetric_islands,
        torn.0,
        stats.step_micros,
        config.substeps,
        config
            .line_substeps
            .map_or(String::new(), |n| format!(" (ropes {})", n.max(1))),
        config.iterations,
        if gravity.0 == Vec3::ZERO { "off" } else { "on" },
        if config.paused { "  [paused]" } else { "" },
    );
}

#[derive(Resource)]
struct ScreenshotPlan {
    path: String,
    frames: u32,
    frame: u32,
}

fn screenshot(
    mut plan: ResMut<ScreenshotPlan>,
    mut commands: Commands,
    mut exit: MessageWriter<AppExit>,
) {
    plan.frame += 1;
    if plan.frame == plan.frames {
        commands
            .spawn(Screenshot::primary_window())
            .observe(save_to_disk(plan.path.clone()));
    }
    if plan.frame == plan.frames + 30 {
        exit.write(AppExit::Success);
    }
}

/// Marks an example's own scene entities (sprites, meshes, lights…) so a reset removes them.
#[derive(Component)]
pub struct SceneEntity;

/// The function that spawns an example's scene.
#[derive(Resource)]
struct SceneSpawner(fn(&mut Commands));

/// Spawns the scene at startup and again on every [`ResetRequested`] (R), after despawning
/// every composite, collider and [`SceneEntity`].
pub fn add_scene(app: &mut App, spawn: fn(&mut Commands)) {
    app.insert_resource(SceneSpawner(spawn))
        .add_systems(
            Startup,
            |mut commands: Commands, spawner: Res<SceneSpawner>| (spawner.0)(&mut commands),
        )
        .add_systems(Update, reset_scene);
}

type SceneFilter = Or<(With<Composite>, With<VerletCollider>, With<SceneEntity>)>;

fn reset_scene(
    mut requests: MessageReader<ResetRequested>,
    spawner: Res<SceneSpawner>,
    scene: Query<Entity, SceneFilter>,
    mut commands: Commands,
) {
    if requests.read().count() == 0 {
        return;
    }
    for entity in &scene {
        commands.entity(entity).try_despawn();
    }
    (spawner.0)(&mut commands);
}
