//! Scene 7: a double pendulum — two 0.5 m rigid arms, unit masses, released at rest with both
//! arms horizontal.
//!
//! The motion is chaotic, so only the energy has a reference: it is conserved. Measured: the
//! energy left after 10 s and 60 s, `(E − E_min)/(E₀ − E_min)` with `E_min` the energy hanging at
//! rest, velocities from the last substep (`(x − x*)/h`, the solver's own velocity). The energy
//! lost can exceed 100 %: an under-converged solve leaves the arms stretched, hanging below
//! `E_min`.

use super::{Column, Scene, Setting, TIMESTEP, Unit, add_pinned, add_rod, step, steps_in};
use bevy_verlet_physics::solver::{Solver, StepConfig};
use glam::DVec3;

/// The double pendulum.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DoublePendulum {
    /// Simulated seconds.
    pub seconds: f64,
}

impl Default for DoublePendulum {
    fn default() -> Self {
        Self { seconds: 60.0 }
    }
}

/// Gravity (m/s²).
const G: f64 = 9.81;
/// Arm length (m).
const ARM: f64 = 0.5;

/// Total energy of the two bobs (unit masses) with velocities over the substep `h`, relative to
/// hanging at rest.
fn energy(solver: &Solver, h: f64) -> f64 {
    let p = &solver.particles;
    let potential: f64 = (1..3).map(|i| G * p.position[i].y).sum();
    potential + p.kinetic_energy(h) + G * 3.0 * ARM
}

impl Scene for DoublePendulum {
    fn name(&self) -> String {
        format!("Double pendulum ({} s)", self.seconds)
    }

    fn columns(&self) -> Vec<Column> {
        vec![
            Column {
                name: "energy lost at the end",
                unit: Unit::Percent,
            },
            Column {
                name: "energy left at 10 s",
                unit: Unit::Percent,
            },
        ]
    }

    fn build(&self, setting: &Setting) -> (Solver, StepConfig) {
        let mut solver = Solver::default();
        let pivot = add_pinned(&mut solver, DVec3::ZERO);
        let first = solver.add_particle(DVec3::X * ARM, 1.0);
        let second = solver.add_particle(DVec3::X * 2.0 * ARM, 1.0);
        add_rod(&mut solver, pivot, first);
        add_rod(&mut solver, first, second);
        (solver, setting.config(DVec3::new(0.0, -G, 0.0), 0.0))
    }

    fn measure(&self, setting: &Setting) -> Vec<f64> {
        let (mut solver, config) = self.build(setting);
        let h = config.substep();
        let initial = energy(&solver, h);
        let mut at_ten = f64::NAN;
        for n in 1..=steps_in(self.seconds) {
            step(&mut solver, setting, &config, |_, _| {});
            if (n as f64 * TIMESTEP - 10.0).abs() < 0.5 * TIMESTEP {
                at_ten = energy(&solver, h) / initial;
            }
        }
        vec![1.0 - energy(&solver, h) / initial, at_ten]
    }

    fn bench_seconds(&self) -> f64 {
        4.0
    }
}
