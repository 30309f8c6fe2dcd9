//! Debug rendering with gizmos: sticks as lines (optionally coloured by strain), pins marked,
//! particles with a radius as circles; interpolated between the last two fixed steps.

use crate::StickKind;
use crate::state::VerletState;
use bevy::prelude::*;

/// The gizmo config group of the Verlet debug lines, with its style. Toggle or restyle at run
/// time through `GizmoConfigStore`:
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// fn toggle(mut store: ResMut<GizmoConfigStore>) {
///     let (config, style) = store.config_mut::<VerletGizmos>();
///     config.enabled = !config.enabled;
///     style.strain_colors = true;
/// }
/// # bevy::ecs::system::assert_is_system(toggle);
/// ```
#[derive(Reflect, GizmoConfigGroup, Clone, Debug)]
#[reflect(Default)]
pub struct VerletGizmos {
    /// Colour of sticks without a [`DebugColor`].
    pub stick_color: Color,
    /// Colour pins are marked with (`None` = not drawn).
    pub pin_color: Option<Color>,
    /// Colour of particle circles (`None` = not drawn). Particles with a radius are drawn with
    /// it; others with [`VerletGizmos::particle_size`].
    pub particle_color: Option<Color>,
    /// Radius of the circle drawn for a particle without a collision radius (`0` = none).
    pub particle_size: f32,
    /// Size of the pin marker.
    pub pin_size: f32,
    /// Blend stick colours towards red as their strain grows to [`VerletGizmos::strain_scale`].
    pub strain_colors: bool,
    /// Strain drawn fully red.
    pub strain_scale: f32,
    /// Draw circles as spheres (3D scenes).
    pub spheres: bool,
    /// Colour of bounds and sphere colliders (`None` = not drawn; planes are never drawn).
    pub collider_color: Option<Color>,
    /// Opacity of the sticks of sleeping islands (`1` = drawn like the others).
    pub sleeping_alpha: f32,
}

impl Default for VerletGizmos {
    fn default() -> Self {
        Self {
            stick_color: Color::srgb(0.85, 0.85, 0.85),
            pin_color: Some(Color::srgb(1.0, 0.3, 0.3)),
            particle_color: Some(Color::srgb(0.5, 0.8, 1.0)),
            particle_size: 0.0,
            pin_size: 3.0,
            strain_colors: false,
            strain_scale: 0.1,
            spheres: false,
            collider_color: Some(Color::srgb(0.35, 0.38, 0.45)),
            sleeping_alpha: 0.45,
        }
    }
}

/// Debug colour of a stick, or (on a composite's parent) of all its sticks — verlet-js's
/// per-composite draw hooks.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut world = World::new();
/// RopeBuilder::new(Vec3::ZERO, Vec3::X, 3).color(Color::srgb(1.0, 0.5, 0.0)).spawn(&mut world.commands());
/// ```
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Debug, Clone)]
pub struct DebugColor(pub Color);

/// Alias kept for discoverability: the style lives in [`VerletGizmos`].
pub type VerletDebugConfig = VerletGizmos;

/// Draws the simulation with gizmos (needs Bevy's `GizmoPlugin`, part of `DefaultPlugins`).
///
/// ```no_run
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// App::new().add_plugins((DefaultPlugins, VerletPlugin::default(), VerletDebugPlugin));
/// ```
pub struct VerletDebugPlugin;

impl Plugin for VerletDebugPlugin {
    fn build(&self, app: &mut App) {
        app.init_gizmo_group::<VerletGizmos>()
            .register_type::<DebugColor>()
            .init_resource::<StickColors>()
            .add_systems(PostUpdate, (cache_stick_colors, draw).chain());
        crate::cloth_mesh::plugin(app);
    }
}

/// Per-stick colours, rebuilt when the topology changes.
#[derive(Resource, Default)]
struct StickColors {
    generation: u64,
    /// `None` = hidden; `Some(None)` = default colour.
    colors: Vec<Option<Option<Color>>>,
}

fn cache_stick_colors(
    state: Res<VerletState>,
    mut cache: ResMut<StickColors>,
    colors: Query<(
        Option<&DebugColor>,
        Option<&ChildOf>,
        Has<crate::HiddenStick>,
    )>,
    parents: Query<&DebugColor>,
) {
    if cache.generation == state.generation && cache.colors.len() == state.stick_entities.len() {
        return;
    }
    cache.generation = state.generation;
    cache.colors.clear();
    for &stick in &state.stick_entities {
        let color = match colors.get(stick) {
            Ok((_, _, true)) => None,
            Ok((Some(color), _, _)) => Some(Some(color.0)),
            Ok((None, Some(parent), _)) => Some(parents.get(parent.parent()).ok().map(|c| c.0)),
            _ => Some(None),
        };
        cache.colors.push(color);
    }
}

fn draw(
    state: Res<VerletState>,
    cache: Res<StickColors>,
    time: Res<Time<Fixed>>,
    config: Res<crate::VerletConfig>,
    mut gizmos: Gizmos<VerletGizmos>,
) {
    let style = gizmos.config_ext.clone();
    let fraction = config.render_fraction(&time);
    let solver = &state.solver;
    if state.render_current.len() != solver.particles.len() {
        return;
    }
    let position = |slot: u32| state.render_position(slot as usize, fraction);
    // Islands hold sticks in contiguous ranges, in order: follow them with a cursor.
    let islands = if solver.is_organized() {
        &solver.islands.list[..]
    } else {
        &[]
    };
    let mut island = 0;
    for (i, &[a, b]) in solver.sticks.ends.iter().enumerate() {
        if solver.sticks.kind[i] == StickKind::Torn {
            continue;
        }
        let Some(color) = cache.colors.get(i).copied().unwrap_or(Some(None)) else {
            continue; // hidden
        };
        let mut color = color.unwrap_or(style.stick_color);
        while island < islands.len() && islands[island].sticks.end as usize <= i {
            island += 1;
        }
        if islands.get(island).is_some_and(|k| k.asleep) {
            color = color.with_alpha(color.alpha() * style.sleeping_alpha);
        }
        let (pa, pb) = (position(a), position(b));
        if style.strain_colors {
            let rest = solver.sticks.rest_length[i] as f32;
            if rest > 0.0 {
                let strain = ((pa - pb).length() / rest - 1.0).abs();
                let t = (strain / style.strain_scale.max(1e-6)).min(1.0);
                color = color.mix(&Color::srgb(1.0, 0.1, 0.1), t);
            }
        }
        gizmos.line(pa, pb, color);
    }
    if let Some(color) = style.pin_color {
        for &p in &solver.pins.particle {
            let center = position(p);
            let s = style.pin_size;
            gizmos.line(
                center + Vec3::new(-s, -s, 0.0),
                center + Vec3::new(s, s, 0.0),
                color,
            );
            gizmos.line(
                center + Vec3::new(-s, s, 0.0),
                center + Vec3::new(s, -s, 0.0),
                color,
            );
        }
    }
    if let Some(color) = style.particle_color {
        for slot in 0..solver.particles.len() {
            let radius = match solver.particles.radius[slot] as f32 {
                r if r > 0.0 => r,
                _ => style.particle_size,
            };
            if radius <= 0.0 {
                continue;
            }
            let center = position(slot as u32);
            if style.spheres {
                gizmos.sphere(Isometry3d::from_translation(center), radius, color);
            } else {
                gizmos.circle(Isometry3d::from_translation(center), radius, color);
            }
        }
    }
    if let Some(color) = style.collider_color {
        draw_colliders(&mut gizmos, &solver.colliders, style.spheres, color);
    }
}

/// Bounds as rectangles (2D: infinite depth) or boxes, spheres as circles or spheres.
fn draw_colliders(
    gizmos: &mut Gizmos<VerletGizmos>,
    colliders: &[crate::solver::Collider],
    spheres: bool,
    color: Color,
) {
    use crate::solver::Shape;
    for collider in colliders {
        match collider.shape {
            Shape::Inside { min, max } => {
                let (min, max) = (min.as_vec3(), max.as_vec3());
                if !(min.x.is_finite()
                    && max.x.is_finite()
                    && min.y.is_finite()
                    && max.y.is_finite())
                {
                    continue;
                }
                let center = (min + max) * 0.5;
                if min.z.is_finite() && max.z.is_finite() {
                    let transform = Transform::from_translation(center).with_scale(max - min);
                    gizmos.cube(transform, color);
                } else {
                    let isometry = Isometry3d::from_translation(center.with_z(0.0));
                    gizmos.rect(isometry, (max - min).truncate(), color);
                }
            }
            Shape::RotatedInside {
                pivot,
                rotation,
                min,
                max,
            } => {
                let (min, max, rotation) = (min.as_vec3(), max.as_vec3(), rotation.as_quat());
                if !(min.truncate().is_finite() && max.truncate().is_finite()) {
                    continue;
                }
                let center = pivot.as_vec3() + rotation * ((min + max) * 0.5).with_z(0.0);
                if min.z.is_finite() && max.z.is_finite() {
                    let center = pivot.as_vec3() + rotation * ((min + max) * 0.5);
                    let transform = Transform::from_translation(center)
                        .with_rotation(rotation)
                        .with_scale(max - min);
                    gizmos.cube(transform, color);
                } else {
                    let isometry = Isometry3d::new(center, rotation);
                    gizmos.rect(isometry, (max - min).truncate(), color);
                }
            }
            Shape::Sphere { center, radius } => {
                let isometry = Isometry3d::from_translation(center.as_vec3());
                if spheres {
                    gizmos.sphere(isometry, radius as f32, color);
                } else {
                    gizmos.circle(isometry, radius as f32, color);
                }
            }
            Shape::Plane { .. } => {}
        }
    }
}
