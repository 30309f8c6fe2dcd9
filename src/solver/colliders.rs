//! Constraints from the world: boxes (bounds, axis-aligned or rotated), planes (ground) and
//! spheres, with restitution and friction.
//!
//! A particle (with its radius) that penetrates a shape is projected to its surface (Jakobsen's
//! "collision by projection"). Projection alone turns the penetration into a velocity change;
//! the response is then made explicit by rewriting the Verlet previous position: the normal part
//! of the substep velocity is reflected with `restitution` when the particle moves into the
//! surface faster than gravity alone could make it within a substep (resting contact does not
//! bounce), and the tangential part loses `friction × |normal speed|` (Coulomb), stopping if
//! that exceeds it.

use super::Particles;
use super::shared::Shared;
use glam::{DQuat, DVec3};
use std::ops::Range;

/// The shape of a collider.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// Keeps particles inside the box `min..=max` (the seeds' window rectangle). Use infinite
    /// bounds on an axis to leave it free (2D scenes: `z` from −∞ to ∞).
    Inside {
        /// Lower corner.
        min: DVec3,
        /// Upper corner.
        max: DVec3,
    },
    /// Keeps particles inside a rotated box: `min..=max` in the box's own frame, which is
    /// placed at `pivot` and turned by `rotation` (a world point `x` is at
    /// `rotation⁻¹·(x − pivot)` in that frame). Infinite bounds leave a local axis free.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{constrain, Collider, Particles, Shape};
    /// use glam::{DQuat, DVec3};
    /// // A 2 × 2 box turned 45° about Z: its corner (1, 1) is at (0, √2).
    /// let shape = Shape::RotatedInside {
    ///     pivot: DVec3::ZERO,
    ///     rotation: DQuat::from_rotation_z(std::f64::consts::FRAC_PI_4),
    ///     min: DVec3::new(-1.0, -1.0, f64::NEG_INFINITY),
    ///     max: DVec3::new(1.0, 1.0, f64::INFINITY),
    /// };
    /// let mut p = Particles::default();
    /// p.push(DVec3::new(0.0, 2.0, 0.0), DVec3::new(0.0, 2.0, 0.0), 1.0, 0.0, 0);
    /// constrain(&mut p, &[Collider { shape, restitution: 0.0, friction: 0.0 }], 0.0);
    /// assert!((p.position[0] - DVec3::new(0.0, 2f64.sqrt(), 0.0)).length() < 1e-12);
    /// ```
    RotatedInside {
        /// Where the box's frame is.
        pivot: DVec3,
        /// How the box's frame is turned (a unit quaternion).
        rotation: DQuat,
        /// Lower corner, in the box's frame.
        min: DVec3,
        /// Upper corner, in the box's frame.
        max: DVec3,
    },
    /// Keeps particles on the side of the plane its unit `normal` points to.
    Plane {
        /// A point on the plane.
        point: DVec3,
        /// Unit normal pointing to the free side.
        normal: DVec3,
    },
    /// Keeps particles out of a sphere (a circle in 2D).
    Sphere {
        /// Centre.
        center: DVec3,
        /// Radius.
        radius: f64,
    },
}

/// A collider: a shape and its surface response.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Collider {
    /// The shape.
    pub shape: Shape,
    /// Fraction of the normal speed kept after a bounce (0 = no bounce, 1 = elastic).
    pub restitution: f64,
    /// Coulomb friction coefficient (0 = frictionless).
    pub friction: f64,
}

/// Contact of a particle with a surface: outward unit normal and penetration depth (≥ 0).
fn contact(shape: &Shape, x: DVec3, radius: f64) -> Option<(DVec3, f64)> {
    match *shape {
        Shape::Plane { point, normal } => {
            let depth = radius - (x - point).dot(normal);
            (depth > 0.0).then_some((normal, depth))
        }
        Shape::Sphere { center, radius: r } => {
            let delta = x - center;
            let distance = delta.length();
            let depth = r + radius - distance;
            if depth <= 0.0 {
                return None;
            }
            // A particle exactly at the centre is pushed out along +Y (any fixed axis works).
            let normal = if distance > 1e-12 {
                delta / distance
            } else {
                DVec3::Y
            };
            Some((normal, depth))
        }
        Shape::Inside { .. } | Shape::RotatedInside { .. } => None,
    }
}

/// Keeps a particle at `x` with substep velocity `velocity` inside the box `min..=max` of the
/// frame `(pivot, rotation)` (`None`: world axes): the new position and velocity, or `None` if
/// it is inside. Each local axis it was clamped on responds with that axis (turned to world) as
/// the normal.
fn keep_inside(
    (x, velocity, radius): (DVec3, DVec3, f64),
    frame: Option<(DVec3, DQuat)>,
    (min, max): (DVec3, DVec3),
    collider: &Collider,
    resting_speed: f64,
) -> Option<(DVec3, DVec3)> {
    let material = (collider.restitution, collider.friction);
    let to_world = |v: DVec3| frame.map_or(v, |(_, rotation)| rotation * v);
    let local = frame.map_or(x, |(pivot, rotation)| rotation.inverse() * (x - pivot));
    let lo = min + DVec3::splat(radius);
    let hi = max - DVec3::splat(radius);
    // A box smaller than the particle keeps it at the centre.
    let clamped = local.max(lo).min(hi);
    let clamped = DVec3::select(lo.cmpgt(hi), (min + max) * 0.5, clamped);
    if clamped == local {
        return None;
    }
    let mut velocity = velocity;
    for axis in 0..3 {
        if clamped[axis] != local[axis] {
            let mut normal = DVec3::ZERO;
            normal[axis] = if clamped[axis] > local[axis] {
                1.0
            } else {
                -1.0
            };
            velocity = respond(velocity, to_world(normal), material, resting_speed);
        }
    }
    let world = frame.map_or(clamped, |(pivot, rotation)| pivot + rotation * clamped);
    Some((world, velocity))
}

/// Surface response for a particle whose substep velocity (displacement per substep) before
/// projection was `velocity`, against a surface with unit `normal`: the new velocity.
pub(crate) fn respond(
    velocity: DVec3,
    normal: DVec3,
    (restitution, friction): (f64, f64),
    resting_speed: f64,
) -> DVec3 {
    let normal_speed = velocity.dot(normal);
    if normal_speed >= 0.0 {
        return velocity; // already leaving the surface
    }
    let tangential = velocity - normal * normal_speed;
    let tangential_speed = tangential.length();
    let reduced = (tangential_speed + friction * normal_speed).max(0.0);
    let tangential = if tangential_speed > 0.0 {
        tangential * (reduced / tangential_speed)
    } else {
        tangential
    };
    let bounce = if -normal_speed > resting_speed {
        -restitution * normal_speed
    } else {
        0.0
    };
    tangential + normal * bounce
}

/// Pushes every movable particle out of every collider, for a substep in which gravity changes
/// a velocity by `gravity_step` (= |g|·h², per-substep displacement units).
///
/// ```
/// use bevy_verlet_physics::solver::{constrain, Collider, Particles, Shape};
/// use glam::DVec3;
/// let mut p = Particles::default();
/// p.push(DVec3::new(0.0, -0.5, 0.0), DVec3::ZERO, 1.0, 0.0, 0);
/// let ground = Collider { shape: Shape::Plane { point: DVec3::ZERO, normal: DVec3::Y }, restitution: 0.0, friction: 0.0 };
/// constrain(&mut p, &[ground], 0.0);
/// assert_eq!(p.position[0].y, 0.0);
/// ```
pub fn constrain(particles: &mut Particles, colliders: &[Collider], gravity_step: f64) {
    let range = 0..particles.len();
    let Particles {
        position,
        previous,
        inverse_mass,
        radius,
        ..
    } = particles;
    constrain_range(
        &Shared::new(position),
        &Shared::new(previous),
        (inverse_mass, radius),
        colliders,
        range,
        gravity_step,
    );
}

/// [`constrain`] for the particles in `range` (which no other task touches), given their
/// inverse masses and radii.
pub(crate) fn constrain_range(
    position: &Shared<DVec3>,
    previous: &Shared<DVec3>,
    (inverse_mass, radii): (&[f64], &[f64]),
    colliders: &[Collider],
    range: Range<usize>,
    gravity_step: f64,
) {
    let resting_speed = 2.0 * gravity_step;
    for collider in colliders {
        for i in range.clone() {
            if inverse_mass[i] <= 0.0 {
                continue;
            }
            let radius = radii[i];
            let x = position.get(i);
            let velocity = x - previous.get(i);
            match collider.shape {
                Shape::Inside { min, max } | Shape::RotatedInside { min, max, .. } => {
                    let frame = match collider.shape {
                        Shape::RotatedInside {
                            pivot, rotation, ..
                        } => Some((pivot, rotation)),
                        _ => None,
                    };
                    let particle = (x, velocity, radius);
                    let inside = keep_inside(particle, frame, (min, max), collider, resting_speed);
                    if let Some((clamped, velocity)) = inside {
                        position.set(i, clamped);
                        previous.set(i, clamped - velocity);
                    }
                }
                ref shape => {
                    let material = (collider.restitution, collider.friction);
                    if let Some((normal, depth)) = contact(shape, x, radius) {
                        let projected = x + normal * depth;
                        position.set(i, projected);
                        previous.set(
                            i,
                            projected - respond(velocity, normal, material, resting_speed),
                        );
                    }
                }
            }
        }
    }
}
