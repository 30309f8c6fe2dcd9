//! Kinematic pins.
//!
//! A pinned particle has inverse mass `0` in the solver, so sticks move only the free end
//! (Jakobsen: "infinite mass"). The seeds instead snap pinned particles back after every pass,
//! which removes only half of a stick's error per pass next to a pin and lets two pins fight.
//!
//! A pin's target may move between fixed steps (a cursor, another entity). The solver moves the
//! pinned particle along the straight line from the old target to the new one, a fraction per
//! substep, so whatever hangs on it is dragged smoothly and the pinned particle carries the right
//! velocity into the constraints.

use super::Particles;
use super::shared::Shared;
use glam::DVec3;
use std::ops::Range;

/// Pinned particles and their targets for the current fixed step.
///
/// ```
/// use bevy_verlet_physics::solver::{Particles, Pins};
/// use glam::DVec3;
/// let mut p = Particles::default();
/// p.push(DVec3::ZERO, DVec3::ZERO, 0.0, 0.0, 0);
/// let mut pins = Pins::default();
/// pins.push(0, DVec3::ZERO);
/// pins.set_target(0, DVec3::X * 4.0);
/// pins.drive(&mut p, 0.5); // halfway through the step
/// assert_eq!(p.position[0], DVec3::X * 2.0);
/// ```
#[derive(Clone, Debug, Default)]
pub struct Pins {
    /// Pinned particle indices.
    pub particle: Vec<u32>,
    /// Target at the start of the current fixed step.
    pub from: Vec<DVec3>,
    /// Target at the end of the current fixed step.
    pub to: Vec<DVec3>,
}

impl Pins {
    /// Number of pins.
    pub fn len(&self) -> usize {
        self.particle.len()
    }

    /// `true` when nothing is pinned.
    pub fn is_empty(&self) -> bool {
        self.particle.is_empty()
    }

    /// Removes every pin, keeping the allocations.
    pub fn clear(&mut self) {
        self.particle.clear();
        self.from.clear();
        self.to.clear();
    }

    /// Pins `particle` at `target` and returns the pin's index. The particle's inverse mass must
    /// be set to `0` by the caller.
    pub fn push(&mut self, particle: u32, target: DVec3) -> usize {
        self.particle.push(particle);
        self.from.push(target);
        self.to.push(target);
        self.particle.len() - 1
    }

    /// Sets where pin `i` must be at the end of the next fixed step; it starts from where the
    /// previous step left it.
    pub fn set_target(&mut self, i: usize, target: DVec3) {
        self.from[i] = self.to[i];
        self.to[i] = target;
    }

    /// Places every pinned particle at its target interpolated to `fraction` (0..=1) of the fixed
    /// step. Called after integration in each substep.
    pub fn drive(&self, particles: &mut Particles, fraction: f64) {
        self.drive_range(
            &Shared::new(&mut particles.position),
            0..self.len(),
            fraction,
        );
    }

    /// [`Pins::drive`] for the pins in `range`.
    pub(crate) fn drive_range(&self, position: &Shared<DVec3>, range: Range<usize>, fraction: f64) {
        for i in range {
            let target = self.from[i].lerp(self.to[i], fraction);
            position.set(self.particle[i] as usize, target);
        }
    }

    /// `true` when a pin in `range` moves during this fixed step.
    pub(crate) fn moving(&self, range: Range<usize>) -> bool {
        range.into_iter().any(|i| self.from[i] != self.to[i])
    }
}
