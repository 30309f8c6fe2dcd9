//! Dense particle state: positions, Verlet previous positions, inverse masses, radii.
//!
//! The state is kept in `f64`. Position Verlet recovers velocity from the difference of two
//! positions (`x − x*`); in `f32` that difference loses the `a·h²` term as soon as it falls below
//! the rounding step of `x` (a free fall from 1000 px at 8 substeps fell 63 % short, see the
//! crate README, "Units and precision"). In `f64` the same difference keeps ≥ 9 significant
//! digits at 10⁶ px and 64 substeps, so the solver stays accurate in pixel units and far from the
//! origin without a second representation of the state.

use glam::DVec3;

/// Struct-of-arrays storage for every particle the solver moves.
///
/// Index `i` in every array refers to the same particle. A particle with `inverse_mass == 0`
/// is immovable for constraints (pinned or infinitely heavy); if it is also kinematic (see
/// [`Pins`](super::Pins)) its position is driven by its pin target.
///
/// ```
/// use bevy_verlet_physics::solver::Particles;
/// use glam::DVec3;
/// let mut particles = Particles::default();
/// let i = particles.push(DVec3::ZERO, DVec3::new(1.0, 0.0, 0.0), 0.5, 0.0, 1);
/// assert_eq!(particles.len(), 1);
/// assert_eq!(particles.inverse_mass[i as usize], 0.5);
/// ```
#[derive(Clone, Debug, Default)]
pub struct Particles {
    /// Current positions.
    pub position: Vec<DVec3>,
    /// Positions one substep ago (Verlet `x*`); `position − previous` is the displacement of the
    /// last substep, i.e. velocity × substep.
    pub previous: Vec<DVec3>,
    /// Inverse masses (`0` = immovable).
    pub inverse_mass: Vec<f64>,
    /// Collision radii (`0` = a point).
    pub radius: Vec<f64>,
    /// An opaque handle per particle (the Bevy layer stores `Entity::to_bits`).
    pub handle: Vec<u64>,
}

impl Particles {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// `true` when there are no particles.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Removes every particle, keeping the allocations.
    pub fn clear(&mut self) {
        self.position.clear();
        self.previous.clear();
        self.inverse_mass.clear();
        self.radius.clear();
        self.handle.clear();
    }

    /// Adds a particle at `position` whose previous substep position is `previous`, and returns
    /// its index.
    pub fn push(
        &mut self,
        position: DVec3,
        previous: DVec3,
        inverse_mass: f64,
        radius: f64,
        handle: u64,
    ) -> u32 {
        let index = self.position.len() as u32;
        self.position.push(position);
        self.previous.push(previous);
        self.inverse_mass.push(inverse_mass);
        self.radius.push(radius);
        self.handle.push(handle);
        index
    }

    /// Velocity of particle `i` over the last substep of length `h`.
    pub fn velocity(&self, i: usize, h: f64) -> DVec3 {
        (self.position[i] - self.previous[i]) / h
    }

    /// Total kinetic energy `½ Σ m v²` over the last substep of length `h` (immovable particles
    /// excluded).
    pub fn kinetic_energy(&self, h: f64) -> f64 {
        let mut energy = 0.0;
        for i in 0..self.len() {
            let w = self.inverse_mass[i];
            if w > 0.0 {
                energy += 0.5 * self.velocity(i, h).length_squared() / w;
            }
        }
        energy
    }

    /// `true` when every position is finite.
    pub fn all_finite(&self) -> bool {
        self.position.iter().all(|p| p.is_finite()) && self.previous.iter().all(|p| p.is_finite())
    }
}
