//! Opt-in mouse and keyboard interaction for demos and games: drag particles, cut sticks, toggle
//! gravity, pause and single-step, show or hide the debug lines.
//!
//! Controls (all remappable through [`VerletInteraction`]):
//!
//! | input | action |
//! |---|---|
//! | left drag | grab the nearest particle within `grab_radius` of the cursor (highlighted while hovered or held); release throws it with the cursor's velocity |
//! | right drag | cut every stick within `cut_radius` of the cursor |
//! | G | gravity on / off |
//! | P | pause / resume |
//! | Enter | one fixed step while paused |
//! | H | show / hide the debug gizmos |
//! | R | sends [`ResetRequested`] (the scene decides what a reset is) |
//!
//! A grabbed particle is pinned to the cursor while held (a kinematic pin, so what hangs on it
//! is dragged smoothly and it leaves with the cursor's velocity), then released. The cursor is
//! a ray from the camera, so this works in 2D and 3D: a particle is grabbed if the ray passes
//! within `grab_radius` of it and is dragged in the plane facing the camera.

use crate::state::VerletState;
use crate::{Gravity, Particle, Pin, StickKind, StickTorn, VerletConfig, VerletGizmos};
use bevy::gizmos::config::GizmoConfigStore;
use bevy::prelude::*;
use bevy::window::PrimaryWindow;

/// Sent when the reset key is pressed.
#[derive(Message, Clone, Copy, Debug, Default, PartialEq)]
pub struct ResetRequested;

/// Settings and state of [`VerletInteractionPlugin`].
///
/// ```
/// use bevy_verlet_physics::prelude::*;
/// let mut interaction = VerletInteraction::metres();
/// interaction.cut_radius = 0.02;
/// assert!(interaction.hovered().is_none());
/// ```
#[derive(Resource, Clone, Debug)]
pub struct VerletInteraction {
    /// How close (world units) the cursor ray must pass to grab a particle.
    pub grab_radius: f32,
    /// How close (world units) the cursor ray must pass to cut a stick.
    pub cut_radius: f32,
    /// Mouse button that drags.
    pub drag_button: MouseButton,
    /// Mouse button that cuts.
    pub cut_button: MouseButton,
    /// Gravity toggle key.
    pub gravity_key: KeyCode,
    /// Pause key.
    pub pause_key: KeyCode,
    /// Single-step key.
    pub step_key: KeyCode,
    /// Debug-lines toggle key.
    pub gizmos_key: KeyCode,
    /// Reset key.
    pub reset_key: KeyCode,
    /// Gravity restored by the toggle.
    pub gravity_on: Vec3,
    /// Colour of the hover / grab highlight.
    pub highlight: Color,
    hovered: Option<Entity>,
    grabbed: Option<Grab>,
    cursor_ray: Option<Ray3d>,
}

#[derive(Clone, Copy, Debug)]
struct Grab {
    entity: Entity,
    /// The pin the particle had before it was grabbed.
    original_pin: Option<Pin>,
    /// Distance of the drag plane from the camera, along the ray.
    depth: f32,
}

impl Default for VerletInteraction {
    fn default() -> Self {
        Self {
            grab_radius: 20.0,
            cut_radius: 8.0,
            drag_button: MouseButton::Left,
            cut_button: MouseButton::Right,
            gravity_key: KeyCode::KeyG,
            pause_key: KeyCode::KeyP,
            step_key: KeyCode::Enter,
            gizmos_key: KeyCode::KeyH,
            reset_key: KeyCode::KeyR,
            gravity_on: Gravity::PIXELS.0,
            highlight: Color::srgb(1.0, 0.85, 0.2),
            hovered: None,
            grabbed: None,
            cursor_ray: None,
        }
    }
}

impl VerletInteraction {
    /// Settings for 3D scenes in metres (radii 0.15 m / 0.05 m, gravity 9.81 m/s²).
    pub fn metres() -> Self {
        Self {
            grab_radius: 0.15,
            cut_radius: 0.05,
            gravity_on: Gravity::METRES.0,
            ..Self::default()
        }
    }

    /// The particle under the cursor.
    pub fn hovered(&self) -> Option<Entity> {
        self.hovered
    }

    /// The particle being dragged.
    pub fn grabbed(&self) -> Option<Entity> {
        self.grabbed.map(|g| g.entity)
    }

    /// The ray from the active camera through the cursor this frame (in 2D its origin is the
    /// cursor's world position).
    pub fn cursor_ray(&self) -> Option<Ray3d> {
        self.cursor_ray
    }
}

/// Mouse dragging and cutting, and the keyboard toggles listed in the [module docs](self).
/// Needs a window, a camera and Bevy's input plugin (all in `DefaultPlugins`).
///
/// ```no_run
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// App::new().add_plugins((
///     DefaultPlugins,
///     VerletPlugin::default(),
///     VerletDebugPlugin,
///     VerletInteractionPlugin,
/// ));
/// ```
pub struct VerletInteractionPlugin;

impl Plugin for VerletInteractionPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<VerletInteraction>()
            .add_message::<ResetRequested>()
            .add_systems(
                Update,
                (cursor_ray, keyboard, (hover, drag, cut), highlight).chain(),
            );
    }
}

fn cursor_ray(
    mut interaction: ResMut<VerletInteraction>,
    windows: Query<&Window, With<PrimaryWindow>>,
    cameras: Query<(&Camera, &GlobalTransform)>,
) {
    interaction.cursor_ray = None;
    let Some(cursor) = windows.single().ok().and_then(Window::cursor_position) else {
        return;
    };
    for (camera, transform) in &cameras {
        if !camera.is_active {
            continue;
        }
        if let Ok(ray) = camera.viewport_to_world(transform, cursor) {
            interaction.cursor_ray = Some(ray);
            return;
        }
    }
}

fn keyboard(
    keys: Res<ButtonInput<KeyCode>>,
    interaction: Res<VerletInteraction>,
    mut gravity: ResMut<Gravity>,
    mut config: ResMut<VerletConfig>,
    mut store: ResMut<GizmoConfigStore>,
    mut reset: MessageWriter<ResetRequested>,
) {
    if keys.just_pressed(interaction.gravity_key) {
        gravity.0 = if gravity.0 == Vec3::ZERO {
            interaction.gravity_on
        } else {
            Vec3::ZERO
        };
    }
    if keys.just_pressed(interaction.pause_key) {
        config.paused = !config.paused;
    }
    if keys.just_pressed(interaction.step_key) && config.paused {
        config.step_once();
    }
    if keys.just_pressed(interaction.gizmos_key) {
        let (gizmos, _) = store.config_mut::<VerletGizmos>();
        gizmos.enabled = !gizmos.enabled;
    }
    if keys.just_pressed(interaction.reset_key) {
        reset.write(ResetRequested);
    }
}

/// Distance from `point` to the ray, and the distance along it.
fn ray_distance(ray: Ray3d, point: Vec3) -> (f32, f32) {
    let along = (point - ray.origin).dot(*ray.direction);
    (
        (ray.origin + *ray.direction * along - point).length(),
        along,
    )
}

fn hover(mut interaction: ResMut<VerletInteraction>, particles: Query<(Entity, &Particle)>) {
    interaction.hovered = None;
    let Some(ray) = interaction.cursor_ray else {
        return;
    };
    let mut best = interaction.grab_radius;
    for (entity, particle) in &particles {
        let (distance, along) = ray_distance(ray, particle.position);
        if along > 0.0 && distance < best {
            best = distance;
            interaction.hovered = Some(entity);
        }
    }
}

fn drag(
    mut interaction: ResMut<VerletInteraction>,
    buttons: Res<ButtonInput<MouseButton>>,
    particles: Query<&Particle>,
    mut pins: Query<&mut Pin>,
    mut commands: Commands,
) {
    let interaction = &mut *interaction;
    if buttons.just_pressed(interaction.drag_button)
        && let (Some(entity), Some(ray)) = (interaction.hovered, interaction.cursor_ray)
        && let Ok(particle) = particles.get(entity)
    {
        let (_, depth) = ray_distance(ray, particle.position);
        let original_pin = pins.get(entity).ok().copied();
        interaction.grabbed = Some(Grab {
            entity,
            original_pin,
            depth,
        });
        if original_pin.is_none() {
            commands.entity(entity).insert(Pin::at(particle.position));
        }
    }
    let Some(grab) = interaction.grabbed else {
        return;
    };
    if buttons.just_released(interaction.drag_button) {
        interaction.grabbed = None;
        if grab.original_pin.is_none()
            && let Ok(mut entity) = commands.get_entity(grab.entity)
        {
            // Released: it keeps the pin's last velocity, i.e. the cursor's.
            entity.try_remove::<Pin>();
        }
        return;
    }
    if let Some(ray) = interaction.cursor_ray {
        let target = ray.origin + *ray.direction * grab.depth;
        match pins.get_mut(grab.entity) {
            Ok(mut pin) => pin.set_position(target),
            Err(_) => {
                if let Ok(mut entity) = commands.get_entity(grab.entity) {
                    entity.try_insert(Pin::at(target));
                }
            }
        }
    }
}

fn cut(
    interaction: Res<VerletInteraction>,
    buttons: Res<ButtonInput<MouseButton>>,
    mut state: ResMut<VerletState>,
    config: Res<VerletConfig>,
    mut messages: MessageWriter<StickTorn>,
    mut commands: Commands,
    mut hit: Local<Vec<usize>>,
) {
    if !buttons.pressed(interaction.cut_button) {
        return;
    }
    let Some(ray) = interaction.cursor_ray else {
        return;
    };
    // Work in the plane facing the camera through the ray origin.
    let direction = *ray.direction;
    let u = direction.any_orthonormal_vector();
    let v = direction.cross(u);
    let flat = |p: Vec3| {
        let d = p - ray.origin;
        Vec2::new(d.dot(u), d.dot(v))
    };
    let solver = &state.solver;
    let r2 = interaction.cut_radius * interaction.cut_radius;
    hit.clear();
    for (i, &[a, b]) in solver.sticks.ends.iter().enumerate() {
        if solver.sticks.kind[i] == StickKind::Torn {
            continue;
        }
        let (pa, pb) = (
            solver.particles.position[a as usize].as_vec3(),
            solver.particles.position[b as usize].as_vec3(),
        );
        let (fa, fb) = (flat(pa), flat(pb));
        let segment = fb - fa;
        let t = (-fa.dot(segment) / segment.length_squared().max(1e-12)).clamp(0.0, 1.0);
        if (fa + segment * t).length_squared() <= r2 {
            hit.push(i);
        }
    }
    // Cut in place, as a tear: no topology rebuild, and each stick once (it is torn now).
    for &i in hit.iter() {
        if let Some(message) = state.cut_stick(i) {
            crate::systems::remove_stick(&mut commands, message.stick, config.despawn_torn_sticks);
            messages.write(message);
        }
    }
}

fn highlight(
    interaction: Res<VerletInteraction>,
    particles: Query<&Particle>,
    time: Res<Time<Fixed>>,
    config: Res<VerletConfig>,
    mut gizmos: Gizmos<VerletGizmos>,
) {
    let fraction = config.render_fraction(&time);
    for (entity, scale) in [(interaction.hovered, 1.0), (interaction.grabbed(), 1.4)] {
        if let Some(particle) = entity.and_then(|e| particles.get(e).ok()) {
            let radius = (interaction.grab_radius * 0.4 * scale).max(particle.radius);
            gizmos.circle(
                Isometry3d::from_translation(particle.interpolated(fraction)),
                radius,
                interaction.highlight,
            );
        }
    }
}
