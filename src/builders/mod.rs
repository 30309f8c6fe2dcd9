//! Builders that spawn whole composites (verlet-js `Composite`): a parent entity with a
//! [`Composite`] component whose particles and constraints are its children, so despawning the
//! parent despawns everything, and a [`DebugColor`](crate::DebugColor) on it styles the lot.

mod cloth;
mod ragdoll;
mod rope;
mod structure;

pub use cloth::ClothBuilder;
pub use ragdoll::{HiddenStick, RagdollBuilder, part as ragdoll_part};
pub use rope::RopeBuilder;
pub use structure::StructureBuilder;

use crate::{Particle, Stick};
use bevy::prelude::*;

/// The parts of a spawned composite, stored on its parent entity (and returned by the
/// builders' `spawn`). Particles are in builder order (row-major for cloth).
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut world = World::new();
/// let rope = RopeBuilder::new(Vec3::ZERO, Vec3::X, 4).spawn(&mut world.commands());
/// world.flush();
/// assert_eq!(rope.particles.len(), 5);
/// assert_eq!(world.get::<Composite>(rope.root).unwrap().sticks.len(), 4);
/// ```
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Debug, Clone)]
pub struct Composite {
    /// The parent entity (set by `spawn`).
    pub root: Entity,
    /// Particle entities.
    pub particles: Vec<Entity>,
    /// Stick entities.
    pub sticks: Vec<Entity>,
    /// Angle-constraint entities.
    pub angles: Vec<Entity>,
}

impl Composite {
    /// Moves every particle of the composite by `offset` (a teleport: velocities are kept).
    pub fn translate(&self, particles: &mut Query<&mut Particle>, offset: Vec3) {
        let mut iter = particles.iter_many_mut(&self.particles);
        while let Some(mut particle) = iter.fetch_next() {
            particle.translate(offset);
        }
    }
}

/// Shared options of the builders.
#[derive(Clone, Debug)]
pub(crate) struct Material {
    pub mass: f32,
    pub radius: f32,
    pub stiffness: crate::Stiffness,
    pub kind: crate::StickKind,
    pub tear_strain: Option<f32>,
    pub tethers: bool,
    #[cfg(feature = "gizmos")]
    pub color: Option<Color>,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            mass: 1.0,
            radius: 0.0,
            stiffness: crate::Stiffness::Rigid,
            kind: crate::StickKind::Equal,
            tear_strain: None,
            tethers: false,
            #[cfg(feature = "gizmos")]
            color: None,
        }
    }
}

/// Spawns the parent, particles (pinned where asked) and sticks of a composite.
pub(crate) fn spawn_composite(
    commands: &mut Commands,
    name: &str,
    material: &Material,
    points: &[Vec3],
    pinned: &[bool],
    sticks: &[(usize, usize)],
) -> Composite {
    let root = commands.spawn(Name::new(name.to_string())).id();
    #[cfg(feature = "gizmos")]
    if let Some(color) = material.color {
        commands.entity(root).insert(crate::DebugColor(color));
    }
    let particles: Vec<Entity> = points
        .iter()
        .zip(pinned)
        .map(|(&point, &pin)| {
            let particle = Particle::new(point)
                .with_mass(material.mass)
                .with_radius(material.radius);
            let mut entity = commands.spawn((particle, ChildOf(root)));
            if pin {
                entity.insert(crate::Pin::at(point));
            }
            if material.tethers {
                entity.insert(crate::Tethered);
            }
            entity.id()
        })
        .collect();
    let sticks: Vec<Entity> = sticks
        .iter()
        .map(|&(a, b)| {
            let mut stick = Stick::new(particles[a], particles[b])
                .with_stiffness(material.stiffness)
                .with_kind(material.kind);
            stick.tear_strain = material.tear_strain;
            commands.spawn((stick, ChildOf(root))).id()
        })
        .collect();
    let composite = Composite {
        root,
        particles,
        sticks,
        angles: Vec::new(),
    };
    commands.entity(root).insert(composite.clone());
    composite
}

/// Builder methods shared by every builder (mass, stiffness, tearing, tethers, colour).
macro_rules! material_methods {
    () => {
        /// Mass of each particle.
        pub fn mass(mut self, mass: f32) -> Self {
            self.material.mass = mass;
            self
        }

        /// Collision radius of each particle.
        pub fn radius(mut self, radius: f32) -> Self {
            self.material.radius = radius;
            self
        }

        /// Stiffness of every stick.
        pub fn stiffness(mut self, stiffness: $crate::Stiffness) -> Self {
            self.material.stiffness = stiffness;
            self
        }

        /// XPBD compliance of every stick (`0` = rigid).
        pub fn compliance(self, compliance: f32) -> Self {
            self.stiffness($crate::Stiffness::Compliance(compliance))
        }

        /// Direction of action of every stick (e.g. [`StickKind::AtMost`](crate::StickKind)
        /// for a rope that only pulls).
        pub fn kind(mut self, kind: $crate::StickKind) -> Self {
            self.material.kind = kind;
            self
        }

        /// Sticks tear past this strain (post-solve).
        pub fn tear_strain(mut self, strain: f32) -> Self {
            self.material.tear_strain = Some(strain);
            self
        }

        /// Adds long-range tethers to the pins (no stretch at no extra iterations).
        pub fn tethers(mut self, tethers: bool) -> Self {
            self.material.tethers = tethers;
            self
        }

        /// Debug colour of the whole composite.
        #[cfg(feature = "gizmos")]
        pub fn color(mut self, color: impl Into<Color>) -> Self {
            self.material.color = Some(color.into());
            self
        }
    };
}
pub(crate) use material_methods;
