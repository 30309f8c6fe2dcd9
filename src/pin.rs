//! The [`Pin`] component: holds a particle at a (possibly moving) world position.

use bevy::prelude::*;

/// Where a pin holds its particle.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Debug, Clone)]
pub enum PinTarget {
    /// A world position; change it to move the pin (e.g. to follow the cursor).
    Position(Vec3),
    /// Another entity: a simulated particle's position plus `offset`, or else `offset` in the
    /// entity's frame, mapped through its up-to-date `GlobalTransform` (its `Transform` and its
    /// parents', computed when the step gathers: a child entity, a rotated or scaled parent).
    Entity {
        /// The entity to follow.
        entity: Entity,
        /// Offset: world-space from a followed particle, local to a followed entity's frame.
        offset: Vec3,
    },
}

/// Holds the particle on the same entity at a world position.
///
/// A pinned particle has infinite mass in the solver (sticks move only the free end) and is
/// kinematic: when the target moves, the particle moves along the straight line from the old
/// target to the new one over the substeps of the next fixed step, dragging what hangs on it
/// smoothly. Remove the component to release the particle (it keeps the pin's last velocity).
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut world = World::new();
/// let hook = world.spawn(Transform::from_xyz(0.0, 5.0, 0.0)).id();
/// world.spawn((Particle::new(Vec3::ZERO), Pin::at(Vec3::ZERO)));
/// world.spawn((Particle::new(Vec3::X), Pin::follow(hook, Vec3::ZERO)));
/// ```
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Debug, Clone)]
pub struct Pin {
    /// Where the particle is held.
    pub target: PinTarget,
}

impl Pin {
    /// Pins at a world position.
    pub fn at(position: Vec3) -> Self {
        Self {
            target: PinTarget::Position(position),
        }
    }

    /// Pins to `entity`: `offset` in its frame (its `GlobalTransform`), or, if `entity` is a
    /// simulated particle, its position plus `offset` (a rope tied to a ragdoll's hand follows
    /// the hand, one step behind).
    pub fn follow(entity: Entity, offset: Vec3) -> Self {
        Self {
            target: PinTarget::Entity { entity, offset },
        }
    }

    /// Moves a position pin to `position` (turns an entity pin into a position pin).
    pub fn set_position(&mut self, position: Vec3) {
        self.target = PinTarget::Position(position);
    }
}
