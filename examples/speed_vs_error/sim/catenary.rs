//! Scene 2: a hanging chain pinned at both ends — 50 rigid links, 1 m long, span 0.8 m.
//!
//! Released at rest as a "V" (two straight halves, every link at its rest length), it swings and
//! settles under light damping (2 s⁻¹, 20 s). Reference: the discrete catenary of equal links
//! with equal node masses (exact for this model), see [`reference::discrete_catenary`]; the
//! continuous catenary of the same length and span is also reported. Measured: sag error against
//! both, the largest node distance from the discrete catenary (relative to the length), the
//! largest link strain, and the largest speed left (to show it settled).

use super::measure::strain_stats;
use super::{Column, Scene, Setting, Unit, add_pinned, add_rod, apply_tethers, reference, run};
use super::{step, steps_in};
use bevy_verlet_physics::solver::{Solver, StepConfig};
use glam::DVec3;

/// The chain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Catenary {
    /// Number of links.
    pub links: usize,
    /// Total length (m).
    pub length: f64,
    /// Distance between the pins as a fraction of the length.
    pub span_ratio: f64,
    /// Simulated seconds before measuring.
    pub seconds: f64,
}

impl Default for Catenary {
    fn default() -> Self {
        Self {
            links: 50,
            length: 1.0,
            span_ratio: 0.8,
            seconds: 20.0,
        }
    }
}

/// Velocity damping rate while settling (1/s).
pub const DAMPING: f64 = 2.0;

impl Catenary {
    fn link(&self) -> f64 {
        self.length / self.links as f64
    }

    fn span(&self) -> f64 {
        self.length * self.span_ratio
    }

    /// Sag of the discrete and the continuous catenary.
    pub fn reference_sags(&self) -> (f64, f64) {
        let nodes = reference::discrete_catenary(self.links, self.link(), self.span());
        let lowest = nodes.iter().map(|n| n.1).fold(f64::INFINITY, f64::min);
        (
            -lowest,
            reference::continuous_catenary_sag(self.length, self.span()),
        )
    }
}

impl Scene for Catenary {
    fn name(&self) -> String {
        format!(
            "Catenary ({} links, span {} % of length)",
            self.links,
            self.span_ratio * 100.0
        )
    }

    fn columns(&self) -> Vec<Column> {
        vec![
            Column {
                name: "sag error",
                unit: Unit::Percent,
            },
            Column {
                name: "sag vs continuous catenary",
                unit: Unit::Percent,
            },
            Column {
                name: "max node offset / length",
                unit: Unit::Percent,
            },
            Column {
                name: "max link strain",
                unit: Unit::Percent,
            },
            Column {
                name: "residual speed (m/s)",
                unit: Unit::Number,
            },
        ]
    }

    fn build(&self, setting: &Setting) -> (Solver, StepConfig) {
        let mut solver = Solver::default();
        let (n, l, half) = (self.links, self.link(), 0.5 * self.span());
        let (cos, sin) = (self.span_ratio, (1.0 - self.span_ratio.powi(2)).sqrt());
        let node = |j: usize| {
            // Distance along the chain from the nearer pin, folded into a V.
            let s = j.min(n - j) as f64 * l;
            let x = if j <= n / 2 {
                -half + s * cos
            } else {
                half - s * cos
            };
            DVec3::new(x, -s * sin, 0.0)
        };
        let mut previous = add_pinned(&mut solver, node(0));
        for j in 1..=n {
            let p = if j == n {
                add_pinned(&mut solver, node(j))
            } else {
                solver.add_particle(node(j), 1.0)
            };
            add_rod(&mut solver, previous, p);
            previous = p;
        }
        apply_tethers(&mut solver, setting);
        let gravity = DVec3::new(0.0, -9.81, 0.0);
        (solver, setting.config(gravity, DAMPING))
    }

    fn measure(&self, setting: &Setting) -> Vec<f64> {
        let (mut solver, config) = self.build(setting);
        run(&mut solver, setting, &config, steps_in(self.seconds) - 1);
        let mut speed = 0.0f64;
        step(&mut solver, setting, &config, |s, _| {
            let h = config.substep();
            speed = (0..s.particles.len())
                .map(|i| s.particles.velocity(i, h).length())
                .fold(0.0, f64::max);
        });
        let reference = reference::discrete_catenary(self.links, self.link(), self.span());
        let (sag, continuous) = self.reference_sags();
        let p = &solver.particles.position;
        let left = DVec3::new(-0.5 * self.span(), 0.0, 0.0);
        let lowest = p.iter().map(|q| q.y).fold(f64::INFINITY, f64::min);
        let offset = p
            .iter()
            .zip(&reference)
            .map(|(q, &(x, y))| (*q - (left + DVec3::new(x, y, 0.0))).length())
            .fold(0.0, f64::max);
        let (_, max_strain, _) = strain_stats(&solver);
        vec![
            -lowest / sag - 1.0,
            -lowest / continuous - 1.0,
            offset / self.length,
            max_strain,
            speed,
        ]
    }
}
