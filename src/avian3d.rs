#![doc = include_str!("avian/docs.md")]
//!
//! This module is for `avian3d` (feature `avian3d`).

use ::avian3d::math::Dir;
use ::avian3d::parry;
use ::avian3d::prelude::*;

/// A body-local anchor (3D).
pub type Anchor = Vec3;

macro_rules! module_name_doc {
    () => {
        "avian3d"
    };
}

fn to_d(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

fn from_d(v: DVec3) -> Vec3 {
    v.as_vec3()
}

/// A body's `Transform` translation for centre `v`.
fn translation_from_d(v: DVec3, _: Vec3) -> Vec3 {
    v.as_vec3()
}

fn rotation_d(rotation: &Rotation) -> DQuat {
    rotation.0.as_dquat()
}

fn rotation_from_d(rotation: DQuat) -> Rotation {
    Rotation(rotation.as_quat())
}

fn angular_d(angular: &AngularVelocity) -> DVec3 {
    angular.0.as_dvec3()
}

fn angular_from_d(angular: DVec3) -> Vec3 {
    angular.as_vec3()
}

fn inverse_inertia_d(inertia: &ComputedAngularInertia, rotation: DQuat) -> DMat3 {
    inertia
        .rotated(rotation.as_quat())
        .inverse()
        .to_mat3()
        .as_dmat3()
}

/// Whether any translation axis, and whether any rotation axis, is locked.
fn any_locked(locked: &LockedAxes) -> (bool, bool) {
    let translation = locked.is_translation_x_locked()
        || locked.is_translation_y_locked()
        || locked.is_translation_z_locked();
    let rotation = locked.is_rotation_x_locked()
        || locked.is_rotation_y_locked()
        || locked.is_rotation_z_locked();
    (translation, rotation)
}

/// 3D bounds as they are.
fn full_depth(lo: DVec3, hi: DVec3) -> (DVec3, DVec3) {
    (lo, hi)
}

/// A 3D surface point as it is.
fn keep_depth(surface: DVec3, _: DVec3) -> DVec3 {
    surface
}

/// What gives `collider`, a triangle mesh, an inside: being closed, with pseudo-normals
/// ([`is_closed_mesh`]), or nothing (see `avian/hollow.rs`). Allocates: run once per shape
/// (`mesh_inside`).
fn inside_of_mesh(collider: &Collider) -> MeshInside {
    match is_closed_mesh(collider) {
        true => MeshInside::Closed,
        false => MeshInside::None,
    }
}

/// Whether `collider` is a triangle mesh with pseudo-normals (`TrimeshFlags::ORIENTED`) whose
/// every edge is shared by exactly two triangles (by vertex index: merge duplicate vertices):
/// closed, so that it has an inside (see `avian/hollow.rs`).
fn is_closed_mesh(collider: &Collider) -> bool {
    let Some(mesh) = collider.shape_scaled().as_trimesh() else {
        return false;
    };
    if mesh.pseudo_normals_if_oriented().is_none() {
        return false;
    }
    let mut edges: Vec<(u32, u32)> = mesh
        .indices()
        .iter()
        .flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    edges.sort_unstable();
    let shared_by_two = |run: &[(u32, u32)]| run.len() == 2;
    !edges.is_empty() && edges.chunk_by(|a, b| a == b).all(shared_by_two)
}

/// A closed triangle mesh with pseudo-normals ([`is_closed_mesh`]): the surface point closest
/// to `local` and whether `local` is inside, by parry's pseudo-normals; `None` for other shapes
/// (see `avian/hollow.rs`).
fn oriented_mesh_projection(
    shape: &parry::shape::SharedShape,
    local: Vec3,
) -> Option<(Vec3, bool)> {
    use parry::query::PointQueryWithLocation;
    let mesh = shape.as_trimesh()?;
    mesh.pseudo_normals_if_oriented()?;
    let (projection, _) = mesh.project_local_point_and_get_location(local, false);
    Some((projection.point, projection.is_inside))
}

/// The point of `field`'s footprint (its ground plan, centred on its origin) nearest `local`,
/// at `local`'s height: `local` itself over the footprint (see `avian/hollow.rs`).
fn into_footprint(field: &parry::shape::HeightField, local: Vec3) -> Vec3 {
    let half = field.scale().abs() / 2.0;
    let x = local.x.max(-half.x).min(half.x);
    let z = local.z.max(-half.z).min(half.z);
    Vec3::new(x, local.y, z)
}

/// For `local` over `field`'s footprint: the nearest point of the footprint's sides (walls
/// straight down from the ground's edges) at `local`'s height, and how far it is.
fn side_exit(field: &parry::shape::HeightField, local: Vec3) -> (Vec3, f32) {
    let half = field.scale().abs() / 2.0;
    let (to_x, to_z) = (half.x - local.x.abs(), half.z - local.z.abs());
    if to_x <= to_z {
        (Vec3::new(half.x.copysign(local.x), local.y, local.z), to_x)
    } else {
        (Vec3::new(local.x, local.y, half.z.copysign(local.z)), to_z)
    }
}

/// The height of `field` straight over or under `local` (its frame): the plane of the cell's
/// triangle whose ground plan holds `local` (edges included, with a margin for rounding);
/// `None` outside its footprint or over a hole (see `avian/hollow.rs`). (A vertical ray cast
/// misses on the grid lines.)
fn height_under(field: &parry::shape::HeightField, local: Vec3) -> Option<f32> {
    let (i, j) = field.cell_at_point(local)?;
    let (first, second) = field.triangles_at(i, j);
    [first, second].into_iter().flatten().find_map(|triangle| {
        let (a, b, c) = (triangle.a, triangle.b, triangle.c);
        let cross = |u: Vec3, v: Vec3| u.x * v.z - u.z * v.x;
        let area = cross(b - a, c - a);
        // Barycentric weights of `local` in the ground plan (x, z).
        let weight_a = cross(b - local, c - local) / area;
        let weight_b = cross(c - local, a - local) / area;
        let weight_c = 1.0 - weight_a - weight_b;
        let inside = [weight_a, weight_b, weight_c].iter().all(|&w| w >= -1e-4);
        (area != 0.0 && inside).then_some(weight_a * a.y + weight_b * b.y + weight_c * c.y)
    })
}

/// The parts of a shape made of solid parts: a compound (a triangle mesh's triangles have no
/// inside in 3D, see `avian/hollow.rs`); `None` for other shapes (see `avian/parts.rs`).
fn solid_parts(shape: &parry::shape::SharedShape) -> Option<&dyn parry::shape::CompositeShape> {
    Some(shape.as_compound()?)
}

/// The fixed directions a point inside a shape made of parts tries to leave it along: the 26
/// from a cube's centre through its faces, edges and corners, in the shape's frame (see
/// `avian/parts.rs`).
fn exit_directions() -> impl Iterator<Item = Vec3> {
    let steps = [-1.0, 0.0, 1.0];
    let corners = steps.into_iter().flat_map(move |x| {
        steps
            .into_iter()
            .flat_map(move |y| steps.into_iter().map(move |z| Vec3::new(x, y, z)))
    });
    corners.filter_map(|d| d.try_normalize())
}

include!("avian/hollow.rs");
include!("avian/parts.rs");
include!("avian/common.rs");
