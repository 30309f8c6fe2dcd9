//! The AS3 Verlet chapter's structures: a triangle, a square that collapses, a braced square
//! and the hinge, bouncing inside the window.
//!
//! `cargo run --release --features examples --example structures`
//!
//! The chapter's point: with per-pass stiffness, the iteration count *is* the stiffness. The
//! left half re-derives its sticks' stiffness from the iteration count exactly as the seed code
//! would (0.3 of the error removed per pass), so Up makes it stiffer; the right half is the
//! same material written as an XPBD compliance, and looks the same at any count.

mod common;

use bevy::prelude::*;
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::scenes::{self, STRUCTURE_STIFFNESS, StructuresScene};

fn main() {
    let mut app = common::app(
        "structures - AS3 Verlet chapter",
        "Up / Down: iterations x2 / /2 | S: 1 <-> 8 substeps | left drag: throw a structure",
    );
    // The seeds' setting: one step per frame, iterations are the only accuracy knob.
    app.insert_resource(Gravity::PIXELS)
        .insert_resource(VerletConfig::seed_style(1))
        .add_systems(Startup, (camera_and_labels,))
        .add_systems(Update, (keys, per_pass_stiffness).chain());
    if common::screenshot_mode() {
        // Show the difference: at 16 iterations the left half is stiff, the right is not.
        app.insert_resource(VerletConfig::seed_style(16));
    }
    common::add_scene(&mut app, |commands| {
        let scene = scenes::structures(commands);
        commands.insert_resource(Halves(scene));
    });
    common::print_controls(&app);
    app.run();
}

/// The scene's two halves, so the left one can be re-derived.
#[derive(Resource)]
struct Halves(StructuresScene);

fn camera_and_labels(mut commands: Commands) {
    commands.spawn(Camera2d);
    for (x, label) in [
        (
            -320.0,
            "per-pass stiffness 0.3 (AS3): stiffer with every iteration",
        ),
        (
            320.0,
            "the same material as XPBD compliance: same at any count",
        ),
    ] {
        commands.spawn((
            Text2d::new(label),
            TextFont::from_font_size(16.0),
            TextColor(Color::srgb(0.9, 0.8, 0.5)),
            Transform::from_xyz(x, 250.0, 0.0),
        ));
    }
}

/// Up / Down double or halve the iterations; S switches between 1 and 8 substeps.
fn keys(keys: Res<ButtonInput<KeyCode>>, mut config: ResMut<VerletConfig>) {
    if keys.just_pressed(KeyCode::ArrowUp) {
        config.iterations = (config.iterations * 2).min(64);
    }
    if keys.just_pressed(KeyCode::ArrowDown) {
        config.iterations = (config.iterations / 2).max(1);
    }
    if keys.just_pressed(KeyCode::KeyS) {
        config.substeps = if config.substeps == 1 { 8 } else { 1 };
    }
}

/// Gives the left half the stiffness the seed's code has at the current iteration count.
fn per_pass_stiffness(
    config: Res<VerletConfig>,
    halves: Option<Res<Halves>>,
    time: Res<Time<Fixed>>,
    mut sticks: Query<&mut Stick>,
) {
    let Some(halves) = halves else { return };
    if !config.is_changed() && !halves.is_changed() {
        return;
    }
    let substep = time.timestep().as_secs_f32() / config.substeps as f32;
    let stiffness = scenes::per_pass_stiffness(STRUCTURE_STIFFNESS, config.iterations, substep);
    for composite in &halves.0.per_pass {
        for &entity in &composite.sticks {
            if let Ok(mut stick) = sticks.get_mut(entity) {
                stick.stiffness = stiffness;
            }
        }
    }
}
