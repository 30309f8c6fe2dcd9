#![doc = include_str!("avian/docs.md")]
//!
//! This module is for `avian2d` (feature `avian2d`): particles move in the XY plane, bodies turn
//! about Z.

use ::avian2d::math::Dir;
use ::avian2d::parry;
use ::avian2d::prelude::*;

/// A body-local anchor (2D).
pub type Anchor = Vec2;

macro_rules! module_name_doc {
    () => {
        "avian2d"
    };
}

fn to_d(v: Vec2) -> DVec3 {
    DVec3::new(f64::from(v.x), f64::from(v.y), 0.0)
}

fn from_d(v: DVec3) -> Vec2 {
    Vec2::new(v.x as f32, v.y as f32)
}

/// A body's `Transform` translation for centre `v` (its depth kept: draw order).
fn translation_from_d(v: DVec3, old: Vec3) -> Vec3 {
    Vec3::new(v.x as f32, v.y as f32, old.z)
}

fn rotation_d(rotation: &Rotation) -> DQuat {
    DQuat::from_rotation_z(f64::from(rotation.as_radians()))
}

fn rotation_from_d(rotation: DQuat) -> Rotation {
    Rotation::radians((2.0 * rotation.z.atan2(rotation.w)) as f32)
}

fn angular_d(angular: &AngularVelocity) -> DVec3 {
    DVec3::new(0.0, 0.0, f64::from(angular.0))
}

fn angular_from_d(angular: DVec3) -> f32 {
    angular.z as f32
}

fn inverse_inertia_d(inertia: &ComputedAngularInertia, _: DQuat) -> DMat3 {
    DMat3::from_diagonal(DVec3::new(0.0, 0.0, f64::from(inertia.inverse())))
}

/// Whether any translation axis, and whether the rotation, is locked.
fn any_locked(locked: &LockedAxes) -> (bool, bool) {
    let translation = locked.is_translation_x_locked() || locked.is_translation_y_locked();
    (translation, locked.is_rotation_locked())
}

/// 2D shapes extend through every depth: particles off the z = 0 plane (draw order) collide.
fn full_depth(lo: DVec3, hi: DVec3) -> (DVec3, DVec3) {
    (lo.with_z(f64::NEG_INFINITY), hi.with_z(f64::INFINITY))
}

/// A 2D surface point at the depth of the particle it was projected from.
fn keep_depth(surface: DVec3, point: DVec3) -> DVec3 {
    surface.with_z(point.z)
}

/// What gives `collider`, a triangle mesh, an inside: its outline — the edges of one triangle
/// only, its vertices merged where they are at exactly the same place — or nothing for a mesh
/// without one (see `avian/parts.rs`). Allocates: run once per shape (`mesh_inside`).
fn inside_of_mesh(collider: &Collider) -> MeshInside {
    let Some(mesh) = collider.shape_scaled().as_trimesh() else {
        return MeshInside::None;
    };
    let vertices = mesh.vertices();
    let mut first_at = std::collections::HashMap::new();
    let same: Vec<u32> = (0..vertices.len() as u32)
        .map(|i| {
            // (`+ 0.0`: −0.0 and 0.0 are the same place.)
            let at = vertices[i as usize].to_array().map(|x| (x + 0.0).to_bits());
            *first_at.entry(at).or_insert(i)
        })
        .collect();
    // (A triangle whose corners merged into fewer than three has no edges.)
    let mut edges: Vec<[u32; 2]> = (mesh.indices().iter())
        .map(|corners| corners.map(|i| same[i as usize]))
        .filter(|[a, b, c]| a != b && b != c && c != a)
        .flat_map(|[a, b, c]| [[a, b], [b, c], [c, a]])
        .map(|[a, b]| [a.min(b), a.max(b)])
        .collect();
    edges.sort_unstable();
    let once: Vec<[u32; 2]> = (edges.chunk_by(|a, b| a == b))
        .filter(|run| run.len() == 1)
        .map(|run| run[0])
        .collect();
    if once.is_empty() {
        return MeshInside::None;
    }
    let outline = parry::shape::Polyline::new(vertices.to_vec(), Some(once));
    MeshInside::Outline(std::sync::Arc::new(outline))
}

/// `None`: a 2D triangle mesh has no pseudo-normals to ask; its inside is its triangles' and its
/// way out its outline (`inside_of_mesh`, see `avian/parts.rs`).
fn oriented_mesh_projection(_: &parry::shape::SharedShape, _: Vec2) -> Option<(Vec2, bool)> {
    None
}

/// The point of `field`'s footprint (its span along x, centred on its origin) nearest
/// `local`, at `local`'s height: `local` itself over the footprint (see `avian/hollow.rs`).
fn into_footprint(field: &parry::shape::HeightField, local: Vec2) -> Vec2 {
    let half = field.scale().x.abs() / 2.0;
    Vec2::new(local.x.max(-half).min(half), local.y)
}

/// For `local` over `field`'s footprint: the nearest point of its two sides (walls straight
/// down from the ground's ends) at `local`'s height, and how far it is.
fn side_exit(field: &parry::shape::HeightField, local: Vec2) -> (Vec2, f32) {
    let half = field.scale().x.abs() / 2.0;
    (
        Vec2::new(half.copysign(local.x), local.y),
        half - local.x.abs(),
    )
}

/// The height of `field` straight over or under `local` (its frame): the segment of the cell
/// under it; `None` outside its footprint or over a hole (see `avian/hollow.rs`).
fn height_under(field: &parry::shape::HeightField, local: Vec2) -> Option<f32> {
    let segment = field.segment_at(field.cell_at_point(local)?)?;
    let (a, b) = (segment.a, segment.b);
    let along = if b.x != a.x {
        (local.x - a.x) / (b.x - a.x)
    } else {
        0.0
    };
    Some(a.y + (b.y - a.y) * along.clamp(0.0, 1.0))
}

/// The parts of a shape made of solid parts: a compound, or a triangle mesh (its triangles are
/// solid in 2D); `None` for other shapes (see `avian/parts.rs`).
fn solid_parts(shape: &parry::shape::SharedShape) -> Option<&dyn parry::shape::CompositeShape> {
    match shape.as_compound() {
        Some(compound) => Some(compound),
        None => Some(shape.as_trimesh()?),
    }
}

/// The fixed directions a point inside a shape made of parts tries to leave it along: 16,
/// 22.5° apart, from the shape's x axis (see `avian/parts.rs`).
fn exit_directions() -> impl Iterator<Item = Vec2> {
    (0..16).map(|k| Vec2::from_angle(k as f32 * std::f32::consts::TAU / 16.0))
}

include!("avian/hollow.rs");
include!("avian/parts.rs");
include!("avian/common.rs");

#[path = "avian/scene2d.rs"]
pub mod scene;
