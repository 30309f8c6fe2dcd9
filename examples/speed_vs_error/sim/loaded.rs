//! Scene 3b: a soft chain under a load — XPBD compliance against plain PBD stiffness.
//!
//! A 10-link chain (0.1 m links, 0.1 kg nodes) pinned at the top with a tip 10× heavier, made of
//! a seed-tuned soft [`Material`]. The material's intended stiffness is what the crate's
//! [`Stiffness::Seed`](bevy_verlet_physics::Stiffness::Seed) conversion gives: the compliance
//! `αᵢ` that removes the seed's fraction of the error per seed step. Reference: the static
//! stretch of that material, `Σ αᵢ·Tᵢ / length` with `Tᵢ` the weight below link `i`. Measured
//! after 10 s (damping 2 s⁻¹, mean of the last half second): the stretch relative to the
//! reference. Under [`Law::Xpbd`](super::Law::Xpbd) it should not depend on the budget once the
//! solve converges; under [`Law::Plain`](super::Law::Plain) (the seeds' per-pass `k`) the
//! material gets stiffer with every extra pass and substep.

use super::measure::strain_stats;
use super::{Column, Material, Scene, Setting, Unit, add_pinned, step, steps_in};
use bevy_verlet_physics::solver::{Solver, StepConfig, StickKind};
use glam::DVec3;

/// The chain and its material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Loaded {
    /// The soft material.
    pub material: Material,
    /// Number of links.
    pub links: usize,
    /// Tip mass over node mass.
    pub mass_ratio: f64,
}

/// Link length (m).
const LINK: f64 = 0.1;
/// Node mass (kg).
const NODE_MASS: f64 = 0.1;
/// Gravity (m/s²).
const G: f64 = 9.81;
/// Simulated seconds.
const SECONDS: f64 = 10.0;
/// Velocity damping rate (1/s).
const DAMPING: f64 = 2.0;

impl Loaded {
    /// A 10-link chain with a 10× tip.
    pub fn new(material: Material) -> Self {
        Self {
            material,
            links: 10,
            mass_ratio: 10.0,
        }
    }

    fn inverse_mass(&self, node: usize) -> f64 {
        match node {
            0 => 0.0,
            n if n == self.links => 1.0 / (NODE_MASS * self.mass_ratio),
            _ => 1.0 / NODE_MASS,
        }
    }

    /// The stretch of the intended material at rest: `Σ αᵢ·Tᵢ / (N·l)`.
    pub fn reference_stretch(&self) -> f64 {
        let n = self.links;
        let mut stretch = 0.0;
        for i in 1..=n {
            let w = self.inverse_mass(i - 1) + self.inverse_mass(i);
            let below = NODE_MASS * (self.mass_ratio + (n - i) as f64);
            stretch += self.material.seed_compliance(w) * below * G;
        }
        stretch / (n as f64 * LINK)
    }
}

impl Scene for Loaded {
    fn name(&self) -> String {
        format!(
            "Loaded soft chain ({} links, tip {}×, {})",
            self.links, self.mass_ratio, self.material.name
        )
    }

    fn columns(&self) -> Vec<Column> {
        vec![
            Column {
                name: "stretch / intended − 1",
                unit: Unit::Percent,
            },
            Column {
                name: "stretch",
                unit: Unit::Percent,
            },
        ]
    }

    fn build(&self, setting: &Setting) -> (Solver, StepConfig) {
        let mut solver = Solver::default();
        let mut previous = add_pinned(&mut solver, DVec3::ZERO);
        for i in 1..=self.links {
            let position = DVec3::new(0.0, -LINK * i as f64, 0.0);
            let p = solver.add_particle(position, self.inverse_mass(i));
            let w = self.inverse_mass(i - 1) + self.inverse_mass(i);
            let compliance = self.material.compliance(setting.law, w, setting.h());
            solver.sticks.push(
                [previous, p],
                LINK,
                compliance,
                StickKind::Equal,
                f64::INFINITY,
                0,
            );
            previous = p;
        }
        (solver, setting.config(DVec3::new(0.0, -G, 0.0), DAMPING))
    }

    fn measure(&self, setting: &Setting) -> Vec<f64> {
        let (mut solver, config) = self.build(setting);
        let steps = steps_in(SECONDS);
        let average_from = steps - steps_in(0.5);
        let (mut sum, mut count) = (0.0, 0);
        for n in 0..steps {
            step(&mut solver, setting, &config, |_, _| {});
            if n >= average_from {
                sum += strain_stats(&solver).2;
                count += 1;
            }
        }
        let stretch = sum / count as f64;
        vec![stretch / self.reference_stretch() - 1.0, stretch]
    }
}
