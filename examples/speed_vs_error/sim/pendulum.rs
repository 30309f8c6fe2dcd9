//! Scene 1: a simple pendulum on a rigid stick, released at rest.
//!
//! Reference: the exact period `T = 2π√(L/g) / AGM(1, cos(θ₀/2))`. Measured: the first full
//! period (first to third zero crossing of the angle, sampled every substep and interpolated), and
//! the energy lost over it (`1 − cos θ` at the turning point one period after release, relative to
//! the release). PBD's error at large amplitude is almost all energy loss, which also shortens the
//! period.

use super::measure::{Crossings, Peaks};
use super::{
    Column, Scene, Setting, TIMESTEP, Unit, Units, add_pinned, add_rod, reference, step, steps_in,
};
use bevy_verlet_physics::solver::{Solver, StepConfig};
use glam::DVec3;

/// A pendulum of length 1 m (or 100 px) released at `amplitude_deg` degrees from the vertical.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pendulum {
    /// Release angle in degrees.
    pub amplitude_deg: f64,
    /// Units and placement.
    pub units: Units,
}

impl Pendulum {
    /// Release angle in radians.
    pub fn amplitude(&self) -> f64 {
        self.amplitude_deg.to_radians()
    }

    /// The exact period.
    pub fn exact_period(&self) -> f64 {
        reference::pendulum_period(self.units.scale(), self.units.gravity(), self.amplitude())
    }
}

/// Period error and energy loss of a sampled angle signal `θ(t)` released from `amplitude` at
/// `t = 0`, against the exact period: `[period/exact − 1, energy lost over the first period]`,
/// or `NaN`s if it did not swing three times through the vertical.
pub fn period_metrics(
    crossings: &Crossings,
    peaks: &Peaks,
    amplitude: f64,
    exact: f64,
) -> [f64; 2] {
    let c = &crossings.times;
    if c.len() < 3 {
        return [f64::NAN; 2];
    }
    let period = c[2] - c[0];
    let turning = peaks
        .peaks
        .iter()
        .filter(|(t, _)| *t > c[1] && *t < c[2])
        .map(|&(_, a)| a)
        .fold(f64::NAN, f64::max);
    let energy_left = (1.0 - turning.cos()) / (1.0 - amplitude.cos());
    [period / exact - 1.0, 1.0 - energy_left]
}

impl Scene for Pendulum {
    fn name(&self) -> String {
        format!("Pendulum {}° ({})", self.amplitude_deg, self.units.label())
    }

    fn columns(&self) -> Vec<Column> {
        vec![
            Column {
                name: "period error",
                unit: Unit::Percent,
            },
            Column {
                name: "energy lost per period",
                unit: Unit::Percent,
            },
        ]
    }

    fn build(&self, setting: &Setting) -> (Solver, StepConfig) {
        let mut solver = Solver::default();
        let pivot = self.units.origin();
        let theta = self.amplitude();
        let bob = pivot + self.units.scale() * DVec3::new(theta.sin(), -theta.cos(), 0.0);
        let p = add_pinned(&mut solver, pivot);
        let b = solver.add_particle(bob, 1.0);
        add_rod(&mut solver, p, b);
        let gravity = DVec3::new(0.0, -self.units.gravity(), 0.0);
        (solver, setting.config(gravity, 0.0))
    }

    fn measure(&self, setting: &Setting) -> Vec<f64> {
        let (mut solver, config) = self.build(setting);
        let pivot = self.units.origin();
        let exact = self.exact_period();
        let (mut crossings, mut peaks) = (Crossings::default(), Peaks::default());
        for n in 0..steps_in(4.0 * exact) {
            let start = n as f64 * TIMESTEP;
            step(&mut solver, setting, &config, |s, t| {
                let d = s.particles.position[1] - pivot;
                let angle = d.x.atan2(-d.y);
                crossings.push(start + t, angle);
                peaks.push(start + t, angle);
            });
            if crossings.times.len() >= 3 {
                break;
            }
        }
        period_metrics(&crossings, &peaks, self.amplitude(), exact).to_vec()
    }

    fn bench_seconds(&self) -> f64 {
        4.0
    }
}
