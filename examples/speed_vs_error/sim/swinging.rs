//! Scene 3c: a chain released from horizontal — the heavy tip's chain (100 links, 1 m, tip
//! 1000× a link) and a 200-link uniform chain (2 m) — swinging for 5 s without damping.
//!
//! An inextensible chain never stretches, so every bit of stretch is solver error; a falling
//! chain also whips, which is where a sweep stretches most (Gauss–Seidel cannot carry the tip's
//! pull up the chain within one sweep) and where a direct solve needs its Newton passes.
//! Measured: the largest link strain at any step, and the mean total stretch over the run.

use super::measure::strain_stats;
use super::{Column, Scene, Setting, Unit, add_chain, apply_tethers, step, steps_in};
use bevy_verlet_physics::solver::{Solver, StepConfig};
use glam::DVec3;

/// The chain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Swinging {
    /// Number of links.
    pub links: usize,
    /// Length in metres.
    pub length: f64,
    /// Tip mass over link mass.
    pub tip_ratio: f64,
    /// Simulated seconds.
    pub seconds: f64,
}

impl Swinging {
    /// The heavy tip's chain, released from horizontal.
    pub fn heavy_tip() -> Self {
        Self {
            links: 100,
            length: 1.0,
            tip_ratio: 1000.0,
            seconds: 5.0,
        }
    }

    /// 200 equal links, 2 m, from one pin.
    pub fn two_hundred() -> Self {
        Self {
            links: 200,
            length: 2.0,
            tip_ratio: 1.0,
            seconds: 5.0,
        }
    }
}

impl Scene for Swinging {
    fn name(&self) -> String {
        format!(
            "Swinging chain ({} links, {} m, tip {}× a link, from horizontal)",
            self.links, self.length, self.tip_ratio
        )
    }

    fn columns(&self) -> Vec<Column> {
        vec![
            Column {
                name: "max link strain",
                unit: Unit::Percent,
            },
            Column {
                name: "mean total stretch",
                unit: Unit::Percent,
            },
        ]
    }

    fn build(&self, setting: &Setting) -> (Solver, StepConfig) {
        let mut solver = Solver::default();
        add_chain(
            &mut solver,
            self.links,
            self.length,
            DVec3::X,
            self.tip_ratio,
        );
        apply_tethers(&mut solver, setting);
        (solver, setting.config(DVec3::new(0.0, -9.81, 0.0), 0.0))
    }

    fn measure(&self, setting: &Setting) -> Vec<f64> {
        let (mut solver, config) = self.build(setting);
        let steps = steps_in(self.seconds);
        let (mut worst, mut sum): (f64, f64) = (0.0, 0.0);
        for _ in 0..steps {
            step(&mut solver, setting, &config, |_, _| {});
            let (_, max_strain, total) = strain_stats(&solver);
            worst = worst.max(max_strain);
            sum += total;
        }
        vec![worst, sum / steps as f64]
    }
}
