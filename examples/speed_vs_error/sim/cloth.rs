//! Scene 4: a 50 × 50 cloth (1 m square, structural sticks only) pinned along its top row.
//!
//! It starts hanging flat and at rest, which is already the equilibrium of an inextensible cloth,
//! so every bit of strain is solver error. Measured after settling (5 s, damping 2 s⁻¹): mean and
//! largest stick strain, and the stretch of the bottom edge's drop.

use super::measure::strain_stats;
use super::{
    Column, Scene, Setting, Unit, add_pinned, add_rod, apply_tethers, organize_in_place, run,
    steps_in,
};
use bevy_verlet_physics::solver::{Solver, StepConfig};
use glam::DVec3;

/// The cloth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cloth {
    /// Particles per row and per column.
    pub size: usize,
    /// Simulated seconds before measuring.
    pub seconds: f64,
}

impl Default for Cloth {
    fn default() -> Self {
        Self {
            size: 50,
            seconds: 5.0,
        }
    }
}

/// Velocity damping rate (1/s).
pub const DAMPING: f64 = 2.0;

impl Cloth {
    fn spacing(&self) -> f64 {
        1.0 / (self.size - 1) as f64
    }
}

impl Scene for Cloth {
    fn name(&self) -> String {
        format!("Cloth {0}×{0}, top row pinned", self.size)
    }

    fn columns(&self) -> Vec<Column> {
        vec![
            Column {
                name: "max strain",
                unit: Unit::Percent,
            },
            Column {
                name: "mean strain",
                unit: Unit::Percent,
            },
            Column {
                name: "bottom drop stretch",
                unit: Unit::Percent,
            },
        ]
    }

    fn build(&self, setting: &Setting) -> (Solver, StepConfig) {
        let mut solver = Solver::default();
        let (n, d) = (self.size, self.spacing());
        // Row by row from the pinned top, horizontal then vertical stick per particle.
        for row in 0..n {
            for column in 0..n {
                let position = DVec3::new(column as f64 * d - 0.5, -(row as f64) * d, 0.0);
                let i = if row == 0 {
                    add_pinned(&mut solver, position)
                } else {
                    solver.add_particle(position, 1.0)
                };
                if column > 0 {
                    add_rod(&mut solver, i - 1, i);
                }
                if row > 0 {
                    add_rod(&mut solver, i - n as u32, i);
                }
            }
        }
        apply_tethers(&mut solver, setting);
        // As the plugin does: one island, so particles keep their slots; the sticks are
        // reordered by colour (the cloth is large enough).
        organize_in_place(&mut solver);
        (solver, setting.config(DVec3::new(0.0, -9.81, 0.0), DAMPING))
    }

    fn measure(&self, setting: &Setting) -> Vec<f64> {
        let (mut solver, config) = self.build(setting);
        run(&mut solver, setting, &config, steps_in(self.seconds));
        let (mean, max, _) = strain_stats(&solver);
        let n = self.size;
        let p = &solver.particles.position;
        let drop = (0..n).map(|c| -p[(n - 1) * n + c].y).sum::<f64>() / n as f64;
        vec![max, mean, drop - 1.0]
    }

    fn bench_seconds(&self) -> f64 {
        0.25
    }
}
