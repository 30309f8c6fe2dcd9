// Which side of a hollow avian shape a point is on, for the shapes parry projects onto as bare
// surfaces. Shared by `avian2d` and `avian3d` (included by each, before `common.rs`); each
// module defines `height_under` and `oriented_mesh_projection` for its dimension.
//
// parry reports no inside for a heightfield, a polyline or a triangle mesh in 3D: a point
// projected on one is always "outside", so a particle whose centre got across the surface was
// pushed out on the far side and stayed there. Two of them do have an inside:
// - a heightfield is ground: below its surface is inside (above, for a heightfield scaled by a
//   negative height). The height under a point is read off the cell under it
//   (`height_under`, one per dimension), and the closest surface point is searched only within
//   the distance to that point — parry's own projection onto a heightfield tests every one of its
//   triangles, for every particle near it, every substep;
// - a triangle mesh built with `TrimeshFlags::ORIENTED` (or `FIX_INTERNAL_EDGES`, which implies
//   it) is closed and oriented: parry decides inside by its pseudo-normals (3D only).
// Polylines and other triangle meshes stay bare surfaces: a particle reaches their far side
// only by being put there (spawned, moved by a system), since a particle moving across one, or
// one moving across a particle, is swept (`solver::contacts`).

use parry::math::Vector;
use parry::query::PointQuery;
use parry::shape::HeightField;

/// For a heightfield or an oriented triangle mesh: the surface point closest to `point` and
/// whether `point` is inside the shape at `pose`; `None` for other shapes (and for a point
/// outside a heightfield's footprint, or above a hole in it).
fn project_with_inside(collider: &Collider, pose: Pose, point: DVec3) -> Option<(DVec3, bool)> {
    let shape = collider.shape_scaled();
    let local = from_d(pose.rotation.inverse() * (point - pose.translation));
    let (surface, inside) = match shape.as_heightfield() {
        Some(field) => project_on_heightfield(field, local)?,
        None => oriented_mesh_projection(shape, local)?,
    };
    Some((pose.translation + pose.rotation * to_d(surface), inside))
}

/// The point of `field` closest to `local` (in its frame) and whether `local` is below it;
/// `None` outside its footprint or over a hole.
fn project_on_heightfield(field: &HeightField, local: Vector) -> Option<(Vector, bool)> {
    let height = height_under(field, local)?;
    let mut straight = local;
    straight.y = height;
    // The closest point is no farther than the one straight above or below (rounding aside).
    let reach = (local.y - height).abs() * (1.0 + 1e-4) + 1e-5 * (1.0 + height.abs());
    let surface = field
        .project_local_point_with_max_dist(local, false, reach)
        .map_or(straight, |projection| projection.point);
    let below = local.y < height;
    Some((surface, below == (field.scale().y >= 0.0)))
}
