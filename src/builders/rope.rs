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
    /// The particles' positions when built with [`RopeBuilder::along`].
    points: Option<Vec<Vec3>>,
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
            points: None,
        }
    }

    /// A rope through `points`, one stick between each pair of consecutive points, each as long
    /// as they are apart: a rope that starts sagging, coiled or laid along a path. A rope whose
    /// sticks are longer than its ends are apart (a slack bridge) should be spawned like this,
    /// already slack, rather than straight and then lengthened: a straight chain whose links are
    /// too long is compressed and has to buckle, which launches it. Fewer than two points give
    /// one stick of length 0 at the first point (or the origin).
    ///
    /// ```
    /// use bevy::prelude::*;
    /// use bevy_verlet_physics::prelude::*;
    /// let mut world = World::new();
    /// // A V-shaped slack bridge: two arms of 5 links.
    /// let points = (0..=10).map(|i| Vec3::new(i as f32, -(5.0 - (i as f32 - 5.0).abs()), 0.0));
    /// let bridge = RopeBuilder::along(points).pin_start().pin_end().spawn(&mut world.commands());
    /// assert_eq!(bridge.sticks.len(), 10);
    /// ```
    pub fn along(points: impl IntoIterator<Item = Vec3>) -> Self {
        let mut points: Vec<Vec3> = points.into_iter().collect();
        let first = points.first().copied().unwrap_or(Vec3::ZERO);
        while points.len() < 2 {
            points.push(first);
        }
        let mut rope = Self::new(first, *points.last().unwrap_or(&first), points.len() - 1);
        rope.points = Some(points);
        rope
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
        let points: Vec<Vec3> = match &self.points {
            Some(points) => points.clone(),
            None => (0..=n)
                .map(|i| self.start.lerp(self.end, i as f32 / n as f32))
                .collect(),
        };
        let pinned: Vec<bool> = (0..=n)
            .map(|i| (i == 0 && self.pin_start) || (i == n && self.pin_end))
            .collect();
        let sticks: Vec<(usize, usize)> = (0..n).map(|i| (i, i + 1)).collect();
        spawn_composite(commands, "Rope", &self.material, &points, &pinned, &sticks)
    }
}
