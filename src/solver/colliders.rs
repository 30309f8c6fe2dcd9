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
use super::collider_grid::ColliderGrid;
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

impl Shape {
    /// Axis-aligned bounds: a sphere's box; unbounded for the others (they reach everywhere).
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Shape;
    /// use glam::DVec3;
    /// let ball = Shape::Sphere { center: DVec3::X, radius: 0.5 };
    /// assert_eq!(ball.bounds(), (DVec3::new(0.5, -0.5, -0.5), DVec3::new(1.5, 0.5, 0.5)));
    /// ```
    pub fn bounds(&self) -> (DVec3, DVec3) {
        match *self {
            Shape::Sphere { center, radius } => (center - radius, center + radius),
            _ => (DVec3::NEG_INFINITY, DVec3::INFINITY),
        }
    }
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
    let mut grid = ColliderGrid::default();
    grid.build(colliders.iter().map(|c| c.shape.bounds()));
    constrain_range(
        &Shared::new(position),
        &Shared::new(previous),
        (inverse_mass, radius),
        (colliders, &grid),
        range,
        gravity_step,
    );
}

/// [`constrain`] for the particles in `range` (which no other task touches), given their
/// inverse masses and radii. With a `grid` over the colliders (see
/// [`ColliderGrid`]) each particle meets only the colliders
/// near it, in their order: the same result as meeting them all, unless a contact pushes it
/// farther than its radius plus its motion (out of a deep overlap).
pub(crate) fn constrain_range(
    position: &Shared<DVec3>,
    previous: &Shared<DVec3>,
    (inverse_mass, radii): (&[f64], &[f64]),
    (colliders, grid): (&[Collider], &ColliderGrid),
    range: Range<usize>,
    gravity_step: f64,
) {
    let resting_speed = 2.0 * gravity_step;
    if !grid.is_active() {
        for collider in colliders {
            for i in range.clone() {
                if inverse_mass[i] > 0.0 {
                    let state = (position, previous, radii[i]);
                    constrain_particle(state, i, collider, resting_speed);
                }
            }
        }
        return;
    }
    let mut near = [0u32; NEAR];
    for i in range {
        if inverse_mass[i] <= 0.0 {
            continue;
        }
        // (Grown by what a contact may push it: its radius and its motion again.)
        let x = position.get(i);
        let reach = 2.0 * radii[i] + (x - previous.get(i)).length();
        let state = (position, previous, radii[i]);
        match grid.near_sorted(x - reach, x + reach, &mut near) {
            Some(count) => near[..count]
                .iter()
                .for_each(|&k| constrain_particle(state, i, &colliders[k as usize], resting_speed)),
            None => colliders
                .iter()
                .for_each(|collider| constrain_particle(state, i, collider, resting_speed)),
        }
    }
}

/// Colliders a particle's query holds at most (more: it meets them all).
const NEAR: usize = 64;

/// One collider's constraint on particle `i`.
fn constrain_particle(
    (position, previous, radius): (&Shared<DVec3>, &Shared<DVec3>, f64),
    i: usize,
    collider: &Collider,
    resting_speed: f64,
) {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// With the grid each particle meets only the colliders near it, in their order, which
    /// must give what meeting them all gives, bit for bit: 2000 particles, moving, among 300
    /// spheres of mixed sizes, a floor plane and a bounding box, 200 substeps.
    #[test]
    fn the_grid_changes_nothing_but_the_cost() {
        let mut seed = 7u64;
        let mut random = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut colliders = vec![
            Collider {
                shape: Shape::Plane {
                    point: DVec3::ZERO,
                    normal: DVec3::Y,
                },
                restitution: 0.2,
                friction: 0.5,
            },
            Collider {
                shape: Shape::Inside {
                    min: DVec3::splat(-1.0),
                    max: DVec3::splat(11.0),
                },
                restitution: 0.5,
                friction: 0.1,
            },
        ];
        for _ in 0..300 {
            let center = DVec3::new(random(), random(), random()) * 10.0;
            let radius = 0.05 + 0.4 * random() * random();
            let (restitution, friction) = (random(), random());
            let shape = Shape::Sphere { center, radius };
            colliders.push(Collider {
                shape,
                restitution,
                friction,
            });
        }
        let mut particles = Particles::default();
        for _ in 0..2000 {
            let x = DVec3::new(random(), random(), random()) * 10.0;
            let v = (DVec3::new(random(), random(), random()) - 0.5) * 0.05;
            particles.push(x, x - v, 1.0, 0.02 + 0.05 * random(), 0);
        }
        let mut grid = ColliderGrid::default();
        grid.build(colliders.iter().map(|c| c.shape.bounds()));
        assert!(grid.is_active());
        let none = ColliderGrid::default();
        let run = |grid: &ColliderGrid| {
            let mut p = particles.clone();
            for _ in 0..200 {
                for i in 0..p.len() {
                    let v = p.position[i] - p.previous[i];
                    p.previous[i] = p.position[i];
                    p.position[i] += v + DVec3::new(0.0, -1e-3, 0.0);
                }
                let Particles {
                    position,
                    previous,
                    inverse_mass,
                    radius,
                    ..
                } = &mut p;
                let (position, previous) = (Shared::new(position), Shared::new(previous));
                let range = 0..inverse_mass.len();
                let state = (&inverse_mass[..], &radius[..]);
                constrain_range(&position, &previous, state, (&colliders, grid), range, 1e-3);
            }
            p
        };
        let (with, without) = (run(&grid), run(&none));
        let bits = |p: &Particles| {
            p.position
                .iter()
                .map(|x| x.to_array().map(f64::to_bits))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&with), bits(&without));
    }
}
