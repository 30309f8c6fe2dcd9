//! Scene 5: a stiff spring made from compliance.
//!
//! A 1 kg particle on a stick of compliance `α` to a pin, no gravity, released 1 cm from rest
//! length along the stick. Reference: `ω = √(k/m)`, `k = 1/α`, undamped. The motion stays on a
//! line, so the solver is a linear two-step recurrence in the displacement `δ`; fitting
//! `δₙ₊₁ = a·δₙ + b·δₙ₋₁` to the substep samples of the first second gives its discrete
//! frequency `θ/h` (`cos θ = a/(2√−b)`) and decay `√−b` per substep exactly, without
//! zero-crossing interpolation. One XPBD projection per substep is implicit Euler: frequency ratio
//! `atan(ωh)/(ωh)`, amplitude `(1 + ω²h²)^(−1/(2h))` after one second — the measured values are
//! printed next to that prediction.

use super::{Column, Law, Material, Scene, Setting, Unit, add_pinned, reference, step, steps_in};
use bevy_verlet_physics::solver::{Solver, StepConfig, StickKind};
use glam::DVec3;
use std::f64::consts::TAU;

/// What sets the spring's stiffness.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Stiff {
    /// A physical compliance chosen for this frequency (Hz).
    Frequency(f64),
    /// A seed-tuned material (its [`Material::compliance`] under the setting's law).
    Seed(Material),
}

/// The spring scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spring {
    /// Its stiffness.
    pub stiff: Stiff,
}

/// Rest length (m).
const REST: f64 = 1.0;
/// Initial stretch (m).
const AMPLITUDE: f64 = 0.01;

impl Spring {
    /// Intended compliance (for a seed material: the crate's `Stiffness::Seed` conversion).
    pub fn intended_compliance(&self) -> f64 {
        match self.stiff {
            Stiff::Frequency(f) => 1.0 / (TAU * f).powi(2),
            Stiff::Seed(material) => material.seed_compliance(1.0),
        }
    }

    /// Intended angular frequency `√(k/m)` with `m = 1`.
    pub fn omega(&self) -> f64 {
        1.0 / self.intended_compliance().sqrt()
    }
}

/// Fits `δₙ₊₁ = a·δₙ + b·δₙ₋₁` by least squares and returns `(θ, r)`: the rotation and the decay
/// per sample (`NaN` if it does not oscillate).
pub fn fit_oscillation(samples: &[f64]) -> (f64, f64) {
    let (mut s11, mut s12, mut s22, mut r1, mut r2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for w in samples.windows(3) {
        let (x1, x0, y) = (w[1], w[0], w[2]);
        s11 += x1 * x1;
        s12 += x1 * x0;
        s22 += x0 * x0;
        r1 += x1 * y;
        r2 += x0 * y;
    }
    let det = s11 * s22 - s12 * s12;
    let a = (r1 * s22 - r2 * s12) / det;
    let b = (s11 * r2 - s12 * r1) / det;
    if b >= 0.0 || !a.is_finite() {
        return (f64::NAN, f64::NAN);
    }
    let r = (-b).sqrt();
    ((a / (2.0 * r)).clamp(-1.0, 1.0).acos(), r)
}

impl Scene for Spring {
    fn name(&self) -> String {
        match self.stiff {
            Stiff::Frequency(f) => format!("Spring {f} Hz (XPBD compliance)"),
            Stiff::Seed(m) => format!(
                "Seed spring ({}, intended {:.2} Hz)",
                m.name,
                self.omega() / TAU
            ),
        }
    }

    fn columns(&self) -> Vec<Column> {
        vec![
            Column {
                name: "frequency error",
                unit: Unit::Percent,
            },
            Column {
                name: "amplitude after 1 s",
                unit: Unit::Percent,
            },
            Column {
                name: "implicit Euler: frequency error",
                unit: Unit::Percent,
            },
            Column {
                name: "implicit Euler: amplitude after 1 s",
                unit: Unit::Percent,
            },
        ]
    }

    fn build(&self, setting: &Setting) -> (Solver, StepConfig) {
        let mut solver = Solver::default();
        let pin = add_pinned(&mut solver, DVec3::ZERO);
        let bob = solver.add_particle(DVec3::X * (REST + AMPLITUDE), 1.0);
        let compliance = match self.stiff {
            Stiff::Frequency(_) => self.intended_compliance(),
            Stiff::Seed(material) => material.compliance(setting.law, 1.0, setting.h()),
        };
        solver.sticks.push(
            [pin, bob],
            REST,
            compliance,
            StickKind::Equal,
            f64::INFINITY,
            0,
        );
        (solver, setting.config(DVec3::ZERO, 0.0))
    }

    fn measure(&self, setting: &Setting) -> Vec<f64> {
        let (mut solver, config) = self.build(setting);
        let mut samples = vec![AMPLITUDE];
        for _ in 0..steps_in(1.0) {
            step(&mut solver, setting, &config, |s, _| {
                samples.push(s.particles.position[1].x - REST);
            });
        }
        // Keep the samples well above the rounding of the 1 m rest length.
        let usable = samples
            .iter()
            .rposition(|d| d.abs() > 1e-9 * AMPLITUDE)
            .map_or(0, |i| i + 1);
        let h = setting.h();
        let (theta, r) = fit_oscillation(&samples[..usable.max(3)]);
        let omega = self.omega();
        let ie = |f: fn(f64, f64) -> f64| match (setting.law, self.stiff) {
            (Law::Plain, Stiff::Seed(_)) => f64::NAN,
            _ => f(omega, h),
        };
        vec![
            theta / (h * omega) - 1.0,
            r.powf(1.0 / h),
            ie(reference::implicit_euler_frequency_ratio) - 1.0,
            ie(reference::implicit_euler_amplitude_per_second),
        ]
    }
}
