// Which side of a hollow avian shape a point is on, for the shapes parry projects onto as bare
// surfaces. Shared by `avian2d` and `avian3d` (included by each, before `common.rs`); each
// module defines `into_footprint`, `side_exit`, `height_under`, `inside_of_mesh` and
// `oriented_mesh_projection` for its dimension.
//
// parry reports no inside for a heightfield, a polyline or a triangle mesh in 3D: a point
// projected on one is always "outside", so a particle whose centre got across the surface was
// pushed out on the far side and stayed there. Two of them do have an inside:
// - a heightfield is ground: over its footprint, below its surface is inside, and its sides
//   are walls straight down from its edges. The height under a point is read off the cell
//   under it (`height_under`, one per dimension), and the closest surface point is searched
//   only within the distance to that point (to the surface over the footprint's nearest point,
//   for a point beside it) — parry's own projection onto a heightfield tests every one of its
//   triangles, for every particle near it, every substep;
// - a closed triangle mesh built with `TrimeshFlags::ORIENTED | MERGE_DUPLICATE_VERTICES` (or
//   `FIX_INTERNAL_EDGES`, which implies both) has pseudo-normals, by which parry decides inside
//   (3D only). Closed — every edge shared by exactly two triangles, by vertex index,
//   `is_closed_mesh`, checked once per shape (`mesh_inside`) — because on an open one (a
//   ground, a one-sided wall) parry would call every point behind a face inside, and pull
//   particles resting behind it through. (Under a mirroring scale parry's test still holds:
//   `a_closed_oriented_triangle_mesh_has_an_inside`.)
// (A 2D triangle mesh is solid: its triangles are, and its outline is the way out of them, see
// `avian/parts.rs`.)
// Polylines and other 3D triangle meshes stay bare surfaces: a particle reaches their far side
// only by being put there (spawned, moved by a system), since a particle moving across one, or
// one moving across a particle, is swept (`solver::contacts`).
// A heightfield's bounds end at its lowest point: a particle deeper than its radius below them
// meets nothing. A heightfield scaled by a negative height is not supported by parry's own
// queries (its bounds turn inside out) and is left as it was.

use parry::math::Vector;
use parry::query::PointQuery;
use parry::shape::{HeightField, SharedShape};

/// What gives a triangle mesh an inside, found once per shape ([`mesh_inside`]).
#[derive(Clone, Default)]
enum MeshInside {
    /// Nothing of its own: in 3D a bare surface; in 2D its triangles (`avian/parts.rs`).
    #[default]
    None,
    /// A closed mesh with pseudo-normals (3D, `is_closed_mesh`): parry's inside.
    #[allow(dead_code)] // (Not in 2D.)
    Closed,
    /// Its outline (2D): the edges of one triangle only, on which the way out of a point in
    /// one of its triangles is (`avian/parts.rs`).
    #[allow(dead_code)] // (Not in 3D.)
    Outline(std::sync::Arc<parry::shape::Polyline>),
}

/// What each triangle mesh found so far has for an inside, by the address of its shape (see
/// [`mesh_inside`]).
type MeshInsides = std::collections::HashMap<usize, (SharedShape, MeshInside)>;

/// [`inside_of_mesh`] for `collider`, found once per triangle mesh shape — shared by several
/// colliders or not — and kept in `cache` with a clone of the shape, so that its address is
/// not reused while it is there (the plugin drops it once nothing else holds the shape).
fn mesh_inside(cache: &mut MeshInsides, collider: &Collider) -> MeshInside {
    let shape = collider.shape_scaled();
    if shape.as_trimesh().is_none() {
        return MeshInside::None;
    }
    let key = std::sync::Arc::as_ptr(&shape.0) as *const () as usize;
    let entry = cache.entry(key);
    let (_, inside) = entry.or_insert_with(|| (shape.clone(), inside_of_mesh(collider)));
    inside.clone()
}

/// For a heightfield or a closed triangle mesh with pseudo-normals: the surface point closest
/// to `point` and whether `point` is inside the shape at `pose`; for a point inside a shape
/// made of solid parts, its way out (`avian/parts.rs`); `None` for other shapes and points
/// (and for a point over or beside a hole in a heightfield).
fn project_with_inside(shape: &AvianShape, pose: Pose, point: DVec3) -> Option<(DVec3, bool)> {
    let parry_shape = shape.collider.shape_scaled();
    let local = from_d(pose.rotation.inverse() * (point - pose.translation));
    let (surface, inside) = match (parry_shape.as_heightfield(), &shape.inside) {
        (Some(field), _) => project_on_heightfield(field, local)?,
        (None, MeshInside::Closed) => oriented_mesh_projection(parry_shape, local)?,
        // (Shapes made of parts: the way out of a point inside, see `avian/parts.rs`.)
        (None, MeshInside::Outline(outline)) => project_on_outline(parry_shape, outline, local)?,
        (None, MeshInside::None) => project_out_of_parts(parry_shape, local)?,
    };
    Some((pose.translation + pose.rotation * to_d(surface), inside))
}

/// The point of `field` closest to `local` (in its frame) and whether `local` is inside it:
/// over its footprint and below its surface — ground, solid down its sides too, so that under
/// its edge the way out may be sideways, through the wall straight down from that edge
/// (`side_exit`). `None` over a hole in it.
fn project_on_heightfield(field: &HeightField, local: Vector) -> Option<(Vector, bool)> {
    if field.scale().y < 0.0 {
        return None;
    }
    // The surface over the footprint's point nearest `local` (`local` itself over it).
    let mut straight = into_footprint(field, local);
    let over = straight == local;
    straight.y = height_under(field, straight)?;
    // The closest point is no farther than that one (rounding aside).
    let distance = (local - straight).length();
    let reach = distance * (1.0 + 1e-4) + 1e-5 * (1.0 + straight.y.abs());
    let surface = field
        .project_local_point_with_max_dist(local, false, reach)
        .map_or(straight, |projection| projection.point);
    let inside = over && local.y < straight.y;
    if inside {
        let (side, across) = side_exit(field, local);
        if across < (local - surface).length() {
            return Some((side, true));
        }
    }
    Some((surface, inside))
}
