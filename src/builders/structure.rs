//! Stick structures: the AS3 chapter's triangle, square, braced square and hinge, or any list of
//! points and sticks.

use super::{Composite, Material, material_methods, spawn_composite};
use bevy::prelude::*;

/// Spawns a structure from points and sticks between them.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut world = World::new();
/// let square = StructureBuilder::braced_square(Vec3::ZERO, 100.0).spawn(&mut world.commands());
/// assert_eq!(square.sticks.len(), 5);
/// let custom = StructureBuilder::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y])
///     .stick(0, 1)
///     .stick(1, 2)
///     .spawn(&mut world.commands());
/// assert_eq!(custom.sticks.len(), 2);
/// ```
#[derive(Clone, Debug)]
pub struct StructureBuilder {
    points: Vec<Vec3>,
    sticks: Vec<(usize, usize)>,
    pinned: Vec<bool>,
    name: &'static str,
    material: Material,
}

impl StructureBuilder {
    /// A structure with these points and no sticks yet.
    pub fn new(points: Vec<Vec3>) -> Self {
        let pinned = vec![false; points.len()];
        Self {
            points,
            sticks: Vec::new(),
            pinned,
            name: "Structure",
            material: Material::default(),
        }
    }

    /// Adds a stick between points `a` and `b` (out-of-range indices are ignored with a warning).
    pub fn stick(mut self, a: usize, b: usize) -> Self {
        if a < self.points.len() && b < self.points.len() && a != b {
            self.sticks.push((a, b));
        } else {
            warn!("StructureBuilder::stick({a}, {b}): invalid point indices; ignored");
        }
        self
    }

    /// Pins point `i` where it is.
    pub fn pin(mut self, i: usize) -> Self {
        if let Some(p) = self.pinned.get_mut(i) {
            *p = true;
        }
        self
    }

    /// An equilateral triangle of side `size` centred on `center` (AS3 `Triangle`).
    pub fn triangle(center: Vec3, size: f32) -> Self {
        let h = size * 3f32.sqrt() / 2.0;
        let mut b = Self::new(vec![
            center + Vec3::new(0.0, 2.0 * h / 3.0, 0.0),
            center + Vec3::new(-size / 2.0, -h / 3.0, 0.0),
            center + Vec3::new(size / 2.0, -h / 3.0, 0.0),
        ])
        .stick(0, 1)
        .stick(1, 2)
        .stick(2, 0);
        b.name = "Triangle";
        b
    }

    /// A square of side `size` with no brace: it collapses (AS3 `Square1`).
    pub fn square(center: Vec3, size: f32) -> Self {
        let s = size / 2.0;
        let mut b = Self::new(vec![
            center + Vec3::new(-s, s, 0.0),
            center + Vec3::new(s, s, 0.0),
            center + Vec3::new(s, -s, 0.0),
            center + Vec3::new(-s, -s, 0.0),
        ])
        .stick(0, 1)
        .stick(1, 2)
        .stick(2, 3)
        .stick(3, 0);
        b.name = "Square";
        b
    }

    /// A square with a diagonal brace: it keeps its shape (AS3 `Square`).
    pub fn braced_square(center: Vec3, size: f32) -> Self {
        let mut b = Self::square(center, size).stick(0, 2);
        b.name = "BracedSquare";
        b
    }

    /// The AS3 `Hinge`: a triangular base standing on `base_center` with apex `height` above it,
    /// an arm of length `arm` from the apex, and a small weight (a braced triangle of three
    /// points) at the arm's end. The arm swings about the apex.
    pub fn hinge(base_center: Vec3, base_width: f32, height: f32, arm: f32) -> Self {
        let apex = base_center + Vec3::new(0.0, height, 0.0);
        let end = apex + Vec3::new(arm, 0.0, 0.0);
        let w = arm / 35.0; // the seed's weight is 20 px across for a 350 px arm
        let mut b = Self::new(vec![
            apex,
            base_center + Vec3::new(-base_width / 2.0, 0.0, 0.0),
            base_center + Vec3::new(base_width / 2.0, 0.0, 0.0),
            end,
            end + Vec3::new(w, w, 0.0),
            end + Vec3::new(w, -w, 0.0),
            end + Vec3::new(2.0 * w, 0.0, 0.0),
        ])
        // base
        .stick(0, 1)
        .stick(1, 2)
        .stick(2, 0)
        // arm
        .stick(0, 3)
        // weight
        .stick(3, 4)
        .stick(3, 5)
        .stick(4, 5)
        .stick(4, 6)
        .stick(5, 6);
        b.name = "Hinge";
        b
    }

    material_methods!();

    /// Spawns it.
    pub fn spawn(&self, commands: &mut Commands) -> Composite {
        spawn_composite(
            commands,
            self.name,
            &self.material,
            &self.points,
            &self.pinned,
            &self.sticks,
        )
    }
}
