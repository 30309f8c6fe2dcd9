//! A contrast, not the crate: the same position-Verlet + projection loop with `f32` state, as a
//! Bevy `Vec3`-based solver would keep it.
//!
//! Position Verlet recovers velocity from `x − x*`; in `f32` that difference loses the `g·h²`
//! term once it falls below the rounding step of `x`, which at 1000 px is 6e-5 px. The crate's
//! solver keeps `f64` state for that reason; these loops show what it avoids.

use super::measure::{Crossings, Peaks};
use super::pendulum::{Pendulum, period_metrics};
use super::{TIMESTEP, Units, steps_in};
use glam::Vec2;

/// Period error and energy loss per period (as [`Pendulum`] measures them) of an `f32` pendulum
/// with `substeps` per 64 Hz step, one projection each.
pub fn pendulum(pendulum: &Pendulum, substeps: u32) -> [f64; 2] {
    let units = pendulum.units;
    let origin = units.origin();
    let pivot = Vec2::new(origin.x as f32, origin.y as f32);
    let length = units.scale() as f32;
    let theta = pendulum.amplitude() as f32;
    let mut x = pivot + length * Vec2::new(theta.sin(), -theta.cos());
    let mut previous = x;
    let h = (TIMESTEP / substeps as f64) as f32;
    let gravity_step = Vec2::new(0.0, -units.gravity() as f32) * (h * h);
    let exact = pendulum.exact_period();
    let (mut crossings, mut peaks) = (Crossings::default(), Peaks::default());
    let total = steps_in(4.0 * exact) * substeps as usize;
    for k in 1..=total {
        let current = x;
        x = current + (current - previous) + gravity_step;
        previous = current;
        let arm = x - pivot;
        x = pivot + arm * (length / arm.length());
        let t = k as f64 * TIMESTEP / substeps as f64;
        let (dx, dy) = ((x.x - pivot.x) as f64, (x.y - pivot.y) as f64);
        let angle = dx.atan2(-dy);
        crossings.push(t, angle);
        peaks.push(t, angle);
        if crossings.times.len() >= 3 {
            break;
        }
    }
    period_metrics(&crossings, &peaks, pendulum.amplitude(), exact)
}

/// Position error after 1 s relative to the distance travelled, of an `f32` particle thrown with
/// `velocity` (scale units per second) from the consistent start, `substeps` per 64 Hz step.
pub fn ballistic(units: Units, velocity: Vec2, substeps: u32) -> f64 {
    let origin = units.origin();
    let x0 = Vec2::new(origin.x as f32, origin.y as f32);
    let v0 = velocity * units.scale() as f32;
    let g = Vec2::new(0.0, -units.gravity() as f32);
    let h = (TIMESTEP / substeps as f64) as f32;
    let mut x = x0;
    let mut previous = x0 - v0 * h + 0.5 * g * h * h;
    for _ in 0..steps_in(1.0) * substeps as usize {
        let current = x;
        x = current + (current - previous) + g * (h * h);
        previous = current;
    }
    // Exact answer in f64.
    let exact = |i: usize| {
        let (x0, v0, g) = (x0[i] as f64, v0[i] as f64, g[i] as f64);
        x0 + v0 + 0.5 * g
    };
    let error = ((x.x as f64 - exact(0)).powi(2) + (x.y as f64 - exact(1)).powi(2)).sqrt();
    let travelled = ((exact(0) - x0.x as f64).powi(2) + (exact(1) - x0.y as f64).powi(2)).sqrt();
    error / travelled
}
