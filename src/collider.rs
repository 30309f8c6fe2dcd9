//! World colliders: bounds, ground planes and spheres.

use crate::solver::{Collider as CoreCollider, Shape};
use bevy::prelude::*;

/// The shape of a [`VerletCollider`], in the entity's local space: its up-to-date
/// `GlobalTransform` (its `Transform` and its parents') places it, so a collider follows its
/// entity, and scale sizes it (a sphere by the largest scale factor). Without a `Transform`
/// the coordinates are world space. A rotated entity turns a box about its translation (an
/// oriented box), a plane's normal, and a sphere's centre about it.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Debug, Clone)]
pub enum ColliderShape {
    /// Keeps particles inside the box `min..=max` (the seeds' window rectangle; use
    /// `f32::INFINITY` to leave an axis free). A box with `min > max` on an axis is empty and
    /// ignored with a warning; a box smaller than a particle keeps it at the box's centre.
    Bounds {
        /// Lower corner.
        min: Vec3,
        /// Upper corner.
        max: Vec3,
    },
    /// Keeps particles on the side the `normal` points to of the plane through `point`.
    Plane {
        /// A point on the plane.
        point: Vec3,
        /// Normal pointing to the free side.
        normal: Vec3,
    },
    /// Keeps particles out of a sphere (a circle in 2D).
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
    },
}

/// A static or moving obstacle for particles, with restitution and friction. Only scenes that
/// spawn colliders pay for the collision pass.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut world = World::new();
/// world.spawn(VerletCollider::ground(0.0).with_friction(0.5));
/// world.spawn(VerletCollider::bounds_2d(Vec2::new(-640.0, -360.0), Vec2::new(640.0, 360.0)));
/// world.spawn((VerletCollider::sphere(1.0), Transform::from_xyz(0.0, 2.0, 0.0)));
/// ```
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Debug, Clone)]
pub struct VerletCollider {
    /// Shape.
    pub shape: ColliderShape,
    /// Fraction of the normal speed kept after a bounce (0..=1).
    pub restitution: f32,
    /// Coulomb friction coefficient (≥ 0).
    pub friction: f32,
}

impl VerletCollider {
    /// A collider with no bounce and no friction.
    pub fn new(shape: ColliderShape) -> Self {
        Self {
            shape,
            restitution: 0.0,
            friction: 0.0,
        }
    }

    /// A horizontal ground plane at height `y` (normal +Y).
    pub fn ground(y: f32) -> Self {
        Self::new(ColliderShape::Plane {
            point: Vec3::new(0.0, y, 0.0),
            normal: Vec3::Y,
        })
    }

    /// A sphere of `radius` centred on the entity's translation.
    pub fn sphere(radius: f32) -> Self {
        Self::new(ColliderShape::Sphere {
            center: Vec3::ZERO,
            radius,
        })
    }

    /// A 2D rectangle that keeps particles inside (z is free).
    pub fn bounds_2d(min: Vec2, max: Vec2) -> Self {
        Self::new(ColliderShape::Bounds {
            min: min.extend(f32::NEG_INFINITY),
            max: max.extend(f32::INFINITY),
        })
    }

    /// A 3D box that keeps particles inside.
    pub fn bounds(min: Vec3, max: Vec3) -> Self {
        Self::new(ColliderShape::Bounds { min, max })
    }

    /// Sets the restitution.
    pub fn with_restitution(mut self, restitution: f32) -> Self {
        self.restitution = restitution;
        self
    }

    /// Sets the friction.
    pub fn with_friction(mut self, friction: f32) -> Self {
        self.friction = friction;
        self
    }

    /// The solver's collider, placed by an entity's scale, rotation and translation (a turned
    /// box becomes an oriented box about the translation); `None` (with the reason) if any
    /// number is not usable.
    pub(crate) fn to_core(
        self,
        scale: Vec3,
        rotation: Quat,
        translation: Vec3,
    ) -> Result<CoreCollider, &'static str> {
        if !(scale.is_finite() && rotation.is_finite() && translation.is_finite()) {
            return Err("non-finite GlobalTransform");
        }
        let offset = translation.as_dvec3();
        let place = |p: Vec3| (rotation * (p * scale)).as_dvec3() + offset;
        let shape = match self.shape {
            ColliderShape::Bounds { min, max } => {
                if min.is_nan() || max.is_nan() {
                    return Err("bounds with a NaN corner");
                }
                // An empty box (min > max, or a side at the wrong infinity) has no inside to
                // keep a particle in.
                if min.cmpgt(max).any()
                    || min.cmpeq(Vec3::INFINITY).any()
                    || max.cmpeq(Vec3::NEG_INFINITY).any()
                {
                    return Err("bounds with min > max on an axis (an empty box)");
                }
                // (A zero scale times an infinite bound is NaN: such an axis stays free.)
                let scaled = |v: Vec3| {
                    let s = v * scale;
                    Vec3::select(s.is_nan_mask(), v, s)
                };
                let (a, b) = (scaled(min), scaled(max));
                if rotation.abs_diff_eq(Quat::IDENTITY, 1e-6) {
                    Shape::Inside {
                        min: a.min(b).as_dvec3() + offset,
                        max: a.max(b).as_dvec3() + offset,
                    }
                } else {
                    Shape::RotatedInside {
                        pivot: offset,
                        rotation: rotation.normalize().as_dquat(),
                        min: a.min(b).as_dvec3(),
                        max: a.max(b).as_dvec3(),
                    }
                }
            }
            ColliderShape::Plane { point, normal } => {
                // Normals map by the inverse transpose: rotation and 1/scale.
                let normal = (rotation * (normal / scale))
                    .as_dvec3()
                    .try_normalize()
                    .ok_or("plane with a zero or non-finite normal (or a zero scale)")?;
                if !point.is_finite() {
                    return Err("plane with a non-finite point");
                }
                Shape::Plane {
                    point: place(point),
                    normal,
                }
            }
            ColliderShape::Sphere { center, radius } => {
                if !center.is_finite() || !radius.is_finite() || radius < 0.0 {
                    return Err("sphere with a non-finite centre or a negative radius");
                }
                Shape::Sphere {
                    center: place(center),
                    radius: radius as f64 * scale.abs().max_element() as f64,
                }
            }
        };
        Ok(CoreCollider {
            shape,
            restitution: (self.restitution as f64).clamp(0.0, 1.0),
            friction: if self.friction.is_finite() {
                (self.friction as f64).max(0.0)
            } else {
                0.0
            },
        })
    }
}
