//! Scene 6: free fall and projectile.
//!
//! Reference: `x(t) = x₀ + v₀t + ½gt²`. Position Verlet is exact for a constant acceleration when
//! it starts from the consistent previous position `x₋₁ = x₀ − v₀h + ½gh²`
//! ([`consistent_previous`]); the seeds start with `x₋₁ = x₀` (or `x₀ − v₀h`) and lag by `½·g·h·t`.
//! Measured: the position error after 1 s relative to the distance travelled.

use super::{Column, Scene, Setting, Unit, Units, run, steps_in};
use bevy_verlet_physics::solver::{Solver, StepConfig, consistent_previous};
use glam::DVec3;

/// How the Verlet history is started.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Start {
    /// `x₋₁ = x₀ − v₀h + ½gh²`: exact.
    Consistent,
    /// `x₋₁ = x₀ − v₀h`, the seeds' start (at rest: `x₋₁ = x₀`).
    Seed,
}

/// A single particle thrown with `velocity` (in units of the scale per second) for 1 s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ballistic {
    /// Initial velocity in scale units per second; zero for a free fall.
    pub velocity: DVec3,
    /// Units and placement.
    pub units: Units,
    /// History start.
    pub start: Start,
}

impl Ballistic {
    /// Simulated time.
    pub const SECONDS: f64 = 1.0;

    fn v0(&self) -> DVec3 {
        self.velocity * self.units.scale()
    }

    fn g(&self) -> DVec3 {
        DVec3::new(0.0, -self.units.gravity(), 0.0)
    }

    /// The exact position at `t`.
    pub fn exact(&self, t: f64) -> DVec3 {
        self.units.origin() + self.v0() * t + 0.5 * self.g() * t * t
    }
}

impl Scene for Ballistic {
    fn name(&self) -> String {
        let what = if self.velocity == DVec3::ZERO {
            "Free fall"
        } else {
            "Projectile"
        };
        let start = match self.start {
            Start::Consistent => "consistent start",
            Start::Seed => "seed start",
        };
        format!("{what} ({}, {start})", self.units.label())
    }

    fn columns(&self) -> Vec<Column> {
        vec![Column {
            name: "position error after 1 s / distance",
            unit: Unit::Number,
        }]
    }

    fn build(&self, setting: &Setting) -> (Solver, StepConfig) {
        let mut solver = Solver::default();
        let x0 = self.units.origin();
        let config = setting.config(self.g(), 0.0);
        let h = config.substep();
        let previous = match self.start {
            Start::Consistent => consistent_previous(x0, self.v0(), self.g(), h),
            Start::Seed => x0 - self.v0() * h,
        };
        solver.add_particle(x0, 1.0);
        solver.particles.previous[0] = previous;
        (solver, config)
    }

    fn measure(&self, setting: &Setting) -> Vec<f64> {
        let (mut solver, config) = self.build(setting);
        run(&mut solver, setting, &config, steps_in(Self::SECONDS));
        let exact = self.exact(Self::SECONDS);
        let travelled = (exact - self.units.origin()).length();
        vec![(solver.particles.position[0] - exact).length() / travelled]
    }
}
