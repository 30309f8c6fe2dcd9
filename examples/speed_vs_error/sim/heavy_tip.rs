//! Scene 3: a heavy tip — a 100-link rigid chain, 1 m long, pinned at the top, whose last particle
//! is 1000× heavier than a link's.
//!
//! It starts hanging straight down at rest, which is already the exact equilibrium of an
//! inextensible chain: every bit of stretch is solver error (Gauss–Seidel cannot carry the tip's
//! weight up the chain within the budget). Measured after 10 s with light damping (2 s⁻¹): the
//! total stretch (mean over the last half second) and the largest link strain.

use super::measure::strain_stats;
use super::{Column, Scene, Setting, Unit, add_chain, apply_tethers, step, steps_in};
use bevy_verlet_physics::solver::{Solver, StepConfig};
use glam::DVec3;

/// The chain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeavyTip {
    /// Number of links.
    pub links: usize,
    /// Tip mass over link mass.
    pub mass_ratio: f64,
    /// Simulated seconds.
    pub seconds: f64,
}

impl Default for HeavyTip {
    fn default() -> Self {
        Self {
            links: 100,
            mass_ratio: 1000.0,
            seconds: 10.0,
        }
    }
}

/// Velocity damping rate (1/s).
pub const DAMPING: f64 = 2.0;

impl Scene for HeavyTip {
    fn name(&self) -> String {
        format!(
            "Heavy tip ({} links, tip {}× a link)",
            self.links, self.mass_ratio
        )
    }

    fn columns(&self) -> Vec<Column> {
        vec![
            Column {
                name: "stretch",
                unit: Unit::Percent,
            },
            Column {
                name: "max link strain",
                unit: Unit::Percent,
            },
        ]
    }

    fn build(&self, setting: &Setting) -> (Solver, StepConfig) {
        let mut solver = Solver::default();
        add_chain(&mut solver, self.links, 1.0, DVec3::NEG_Y, self.mass_ratio);
        apply_tethers(&mut solver, setting);
        (solver, setting.config(DVec3::new(0.0, -9.81, 0.0), DAMPING))
    }

    fn measure(&self, setting: &Setting) -> Vec<f64> {
        let (mut solver, config) = self.build(setting);
        let steps = steps_in(self.seconds);
        let average_from = steps - steps_in(0.5);
        let (mut sum, mut count) = (0.0, 0);
        for n in 0..steps {
            step(&mut solver, setting, &config, |_, _| {});
            if n >= average_from {
                sum += strain_stats(&solver).2;
                count += 1;
            }
        }
        let (_, max_strain, _) = strain_stats(&solver);
        vec![sum / count as f64, max_strain]
    }
}
