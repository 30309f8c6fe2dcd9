//! Ropes and chains.

use super::{Composite, Material, material_methods, spawn_composite};
use bevy::prelude::*;

/// Spawns a rope (or chain) of `links` sticks between two points.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut world = World::new();
/// let rope = RopeBuilder::new(Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), 20)
///     .pin_start()
///     .mass(0.1)
///     .tethers(true)
///     .spawn(&mut world.commands());
/// world.flush();
/// assert!(world.get::<Pin>(rope.particles[0]).is_some());
/// ```
#[derive(Clone, Debug)]
pub struct RopeBuilder {
    start: Vec3,
    end: Vec3,
    links: usize,
    pin_start: bool,
    pin_end: bool,
    material: Material,
}

impl RopeBuilder {
    /// A rope from `start` to `end` made of `links` equal sticks (at least 1).
    pub fn new(start: Vec3, end: Vec3, links: usize) -> Self {
        Self {
            start,
            end,
            links: links.max(1),
            pin_start: false,
            pin_end: false,
            material: Material::default(),
        }
    }

    /// Pins the first particle where it is.
    pub fn pin_start(mut self) -> Self {
        self.pin_start = true;
        self
    }

    /// Pins the last particle where it is.
    pub fn pin_end(mut self) -> Self {
        self.pin_end = true;
        self
    }

    material_methods!();

    /// Spawns it.
    pub fn spawn(&self, commands: &mut Commands) -> Composite {
        let n = self.links;
        let points: Vec<Vec3> = (0..=n)
            .map(|i| self.start.lerp(self.end, i as f32 / n as f32))
            .collect();
        let pinned: Vec<bool> = (0..=n)
            .map(|i| (i == 0 && self.pin_start) || (i == n && self.pin_end))
            .collect();
        let sticks: Vec<(usize, usize)> = (0..n).map(|i| (i, i + 1)).collect();
        spawn_composite(commands, "Rope", &self.material, &points, &pinned, &sticks)
    }
}
