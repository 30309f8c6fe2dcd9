// The way out of a shape made of solid parts: a compound (`Collider::compound`, a convex
// decomposition) and, in 2D, a triangle mesh (its triangles). Shared by `avian2d` and `avian3d`
// (included by each, before `common.rs`); each module defines `solid_parts` and
// `exit_directions` for its dimension.
//
// parry projects a point inside such a shape onto the nearest boundary of any one part, and
// that boundary may lie between two parts, inside the shape: a particle put inside next to one
// was pushed to one radius from it and stayed inside (2 cm beside the shared side of two
// boxes, it ended 5 cm inside). Here a point held by one part alone, whose nearest boundary
// point has no other part just beyond it, leaves there: that is the shape's nearest outside
// point. Elsewhere (next to a boundary between parts, or where parts overlap) it leaves along
// straight rays — towards its part's nearest boundary point, and along the fixed directions of
// the shape's frame (`exit_directions`) — each crossing part after part until it comes out of
// the shape (`ray_exit`; at most `EXIT_PARTS` parts), and the nearest of those exits is the
// way out. That is the nearest outside point where a ray reaches it (straight up through the
// top of two boxes side by side); through a flat side elsewhere at most 2 % (2D) or 13 % (3D)
// farther, no direction being more than 11.25° (2D) or 27.6° (3D) from a fixed one; more
// near an inner corner, where the ray nearest the corner's direction may pass it. The contact
// then pushes the particle out along the surface's normal in the next substep. A 2D triangle
// mesh needs no rays where its triangles meet edge to edge: its outline — the edges of one
// triangle only, found once per shape (`inside_of_mesh`, `MeshInside::Outline`) — is then its
// outside, and a point in one of its triangles leaves by the outline's nearest point, exactly
// (`project_on_outline`); where a triangle lies just beyond that point (a T-junction,
// overlapping triangles), by the rays. (Triangles that overlap along a shared side — a
// duplicated triangle, a folded mesh — drop that side from the outline: a particle there
// leaves by a farther side.) A point in no part is left to parry's projection, which
// is right there (the nearest boundary point of any part is on the outside when the point is in
// none); it costs one more look-up of the parts whose bounds hold it, a point inside a part a
// few more, and rays only next to a boundary between parts.

use parry::query::Ray;
use parry::shape::{CompositeShape, TypedCompositeShape};

/// The most parts a ray out of a shape made of parts crosses before it is given up (a point
/// deeper than that in a finely divided shape along every ray is left to parry's projection).
const EXIT_PARTS: usize = 64;

/// For `local` (in the shape's frame) inside a part of a shape made of solid parts (see
/// `solid_parts`): its way out (see the top of this file), and `true`; `None` for other shapes
/// and for a point in no part.
fn project_out_of_parts(shape: &parry::shape::SharedShape, local: Vector) -> Option<(Vector, bool)> {
    let parts = solid_parts(shape)?;
    let holder = part_holding(parts, local, None)?;
    let nudge = nudge(parts, holder, local);
    let nearest = project_on_part(parts, holder, local).filter(|nearest| nearest.is_finite());
    // (Undefined at a ball part's centre, or for a point on its part's boundary.)
    let towards_nearest = nearest
        .map(|nearest| nearest - local)
        .filter(|outward| outward.length() > nudge)
        .map(|outward| outward.normalize());
    if let Some(nearest) = nearest {
        // The part's nearest boundary point is the shape's nearest outside point if no other
        // part lies just beyond it (any way out leaves this part first) — or, for a point on
        // that boundary within rounding (a particle resting there), if no other part holds it.
        let free = match towards_nearest {
            Some(direction) => nearest + direction * nudge,
            None => nearest,
        };
        if part_holding(parts, free, Some(holder)).is_none() {
            return Some((nearest, true));
        }
    }
    // (No exit can be nearer than the part's own boundary: an exit that near ends the search.)
    let least = nearest.map_or(0.0, |nearest| (nearest - local).length()) + nudge;
    let mut best: Option<(f32, Vector)> = None;
    for direction in towards_nearest.into_iter().chain(exit_directions()) {
        let Some(exit) = ray_exit(parts, holder, local, direction, nudge) else {
            continue;
        };
        let distance = (exit - local).length();
        if best.is_none_or(|(shortest, _)| distance < shortest) {
            best = Some((distance, exit));
        }
        if distance <= least {
            break;
        }
    }
    // (Where no ray comes out, the part's own nearest boundary point: still inside-out, never
    // parry's answer from another part, which may call the point outside.)
    best.map(|(_, exit)| exit).or(nearest).map(|exit| (exit, true))
}

/// A step past a part's boundary, to see which part, if any, lies beyond it: 10⁻⁵ of `local`'s
/// largest coordinate and part `part`'s size — a few hundred times `f32`'s rounding there, and
/// not of the whole shape's size, which in a large one would make a seam near a point pass for
/// its outside.
fn nudge(parts: &dyn CompositeShape, part: u32, local: Vector) -> f32 {
    let size = parts
        .map_untyped_part_at(part, |pose, shape, _| match pose {
            Some(pose) => shape.compute_aabb(pose).extents().length(),
            None => shape.compute_local_aabb().extents().length(),
        })
        .filter(|size| size.is_finite())
        .unwrap_or(0.0);
    1e-5 * (size + local.abs().max_element())
}

/// For `local` (in the shape's frame) in a triangle of a 2D triangle mesh whose `outline` (the
/// edges of one triangle only) is known: the nearest point of the outline — the mesh's nearest
/// outside point where its triangles meet edge to edge — and `true`; where a triangle lies just
/// beyond that point (a T-junction, triangles overlapping), the rays' way out
/// ([`project_out_of_parts`]); `None` for a point in no triangle (left to parry's projection).
fn project_on_outline(
    shape: &parry::shape::SharedShape,
    outline: &parry::shape::Polyline,
    local: Vector,
) -> Option<(Vector, bool)> {
    let parts = solid_parts(shape)?;
    let holder = part_holding(parts, local, None)?;
    let nearest = outline.project_local_point(local, false).point;
    let (outward, nudge) = (nearest - local, nudge(parts, holder, local));
    let depth = outward.length();
    if depth <= nudge || part_holding(parts, nearest + outward * (nudge / depth), None).is_none() {
        return Some((nearest, true));
    }
    project_out_of_parts(shape, local)
}

/// Where a ray from `origin` inside part `part` along unit `direction` comes out of the shape:
/// it leaves part after part until no other part holds the point just past where it left
/// one. `None` after [`EXIT_PARTS`] parts, or where a part reports no way out.
fn ray_exit(
    parts: &dyn CompositeShape,
    mut part: u32,
    mut origin: Vector,
    direction: Vector,
    nudge: f32,
) -> Option<Vector> {
    for _ in 0..EXIT_PARTS {
        let ray = Ray::new(origin, direction);
        let out = parts.map_untyped_part_at(part, |pose, shape, _| match pose {
            Some(pose) => shape.cast_ray(pose, &ray, f32::MAX, false),
            None => shape.cast_local_ray(&ray, f32::MAX, false),
        })??;
        let exit = origin + direction * out;
        let beyond = exit + direction * nudge;
        match part_holding(parts, beyond, Some(part)) {
            None => return Some(exit),
            Some(next) => (part, origin) = (next, beyond),
        }
    }
    None
}

/// A part of `parts` that holds `point` (its frame), other than `except`. A triangle of (nearly)
/// no area holds nothing: parry's test would call every point of the band along it inside.
fn part_holding(parts: &dyn CompositeShape, point: Vector, except: Option<u32>) -> Option<u32> {
    let mut candidates = parts
        .bvh()
        .leaves(|node| node.aabb().contains_local_point(point));
    let holds = |pose: Option<&parry::math::Pose>, shape: &dyn parry::shape::Shape| {
        let flat = |t: &parry::shape::Triangle| 2.0 * t.area() <= 1e-6 * t.perimeter().powi(2);
        if shape.as_triangle().is_some_and(flat) {
            return false;
        }
        match pose {
            Some(pose) => shape.contains_point(pose, point),
            None => shape.contains_local_point(point),
        }
    };
    candidates.find(|&id| {
        Some(id) != except
            && parts
                .map_untyped_part_at(id, |pose, shape, _| holds(pose, shape))
                .unwrap_or(false)
    })
}

/// The point of part `part`'s boundary nearest `point` (the shape's frame).
fn project_on_part(parts: &dyn CompositeShape, part: u32, point: Vector) -> Option<Vector> {
    parts.map_untyped_part_at(part, |pose, shape, _| match pose {
        Some(pose) => shape.project_point(pose, point, false).point,
        None => shape.project_local_point(point, false).point,
    })
}
