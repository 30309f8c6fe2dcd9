// Which side of a hollow avian shape a point is on, for the shapes parry projects onto as bare
// surfaces. Shared by `avian2d` and `avian3d` (included by each, before `common.rs`); each
// module defines `height_under` and `oriented_mesh_projection` for its dimension.
//
// parry reports no inside for a heightfield, a polyline or a triangle mesh in 3D: a point
// projected on one is always "outside", so a particle whose centre got across the surface was
// pushed out on the far side and stayed there. Two of them do have an inside:
// - a heightfield is ground: below its surface is inside. The height under a point is read off the cell under it
//   (`height_under`, one per dimension), and the closest surface point is searched only within
//   the distance to that point — parry's own projection onto a heightfield tests every one of its
//   triangles, for every particle near it, every substep;
// - a closed triangle mesh built with `TrimeshFlags::ORIENTED` (or `FIX_INTERNAL_EDGES`, which
//   implies it) has pseudo-normals, by which parry decides inside (3D only). Closed — every
//   edge shared by exactly two triangles, `is_closed_mesh`, checked once per collider and again
//   when it changes — because on an open one (a ground, a one-sided wall) parry would call
//   every point behind a face inside, and pull particles resting behind it through.
// Polylines and other triangle meshes stay bare surfaces: a particle reaches their far side
// only by being put there (spawned, moved by a system), since a particle moving across one, or
// one moving across a particle, is swept (`solver::contacts`).
// A heightfield's bounds end at its lowest point: a particle deeper than its radius below them
// meets nothing. A heightfield scaled by a negative height is not supported by parry's own
// queries (its bounds turn inside out) and is left as it was.

use parry::math::Vector;
use parry::query::PointQuery;
use parry::shape::HeightField;

/// For a heightfield or a closed triangle mesh with pseudo-normals: the surface point closest
/// to `point` and whether `point` is inside the shape at `pose`; `None` for other shapes (and
/// for a point outside a heightfield's footprint, or above a hole in it).
fn project_with_inside(shape: &AvianShape, pose: Pose, point: DVec3) -> Option<(DVec3, bool)> {
    let parry_shape = shape.collider.shape_scaled();
    let local = from_d(pose.rotation.inverse() * (point - pose.translation));
    let (surface, inside) = match parry_shape.as_heightfield() {
        Some(field) => project_on_heightfield(field, local)?,
        None if shape.closed => oriented_mesh_projection(parry_shape, local)?,
        None => return None,
    };
    Some((pose.translation + pose.rotation * to_d(surface), inside))
}

/// The point of `field` closest to `local` (in its frame) and whether `local` is below it;
/// `None` outside its footprint or over a hole.
fn project_on_heightfield(field: &HeightField, local: Vector) -> Option<(Vector, bool)> {
    if field.scale().y < 0.0 {
        return None;
    }
    let height = height_under(field, local)?;
    let mut straight = local;
    straight.y = height;
    // The closest point is no farther than the one straight above or below (rounding aside).
    let reach = (local.y - height).abs() * (1.0 + 1e-4) + 1e-5 * (1.0 + height.abs());
    let surface = field
        .project_local_point_with_max_dist(local, false, reach)
        .map_or(straight, |projection| projection.point);
    Some((surface, local.y < height))
}
