//! Trackers that turn a sampled signal into zero crossings and turning points, and strain
//! statistics of a stick network.

use bevy_verlet_physics::solver::{Solver, StickKind};

/// Times at which a sampled signal changes sign, linearly interpolated between samples.
#[derive(Clone, Debug, Default)]
pub struct Crossings {
    last: Option<(f64, f64)>,
    /// Crossing times, in order.
    pub times: Vec<f64>,
}

impl Crossings {
    /// Adds the sample `value` at time `t`.
    pub fn push(&mut self, t: f64, value: f64) {
        if let Some((t0, v0)) = self.last
            && ((v0 < 0.0 && value >= 0.0) || (v0 > 0.0 && value <= 0.0))
            && value != v0
        {
            self.times.push(t0 + (t - t0) * v0 / (v0 - value));
        }
        self.last = Some((t, value));
    }
}

/// Local maxima of `|value|` of a sampled signal, refined by a parabola through the three samples
/// around each maximum (samples must be equally spaced in time).
#[derive(Clone, Debug, Default)]
pub struct Peaks {
    window: Vec<(f64, f64)>,
    /// `(time, |value|)` of every local maximum, in order.
    pub peaks: Vec<(f64, f64)>,
}

impl Peaks {
    /// Adds the sample `value` at time `t`.
    pub fn push(&mut self, t: f64, value: f64) {
        self.window.push((t, value.abs()));
        if self.window.len() > 3 {
            self.window.remove(0);
        }
        if let [(_, a), (t1, b), (t2, c)] = self.window[..]
            && b > a
            && b >= c
        {
            let dt = t2 - t1;
            let curvature = a - 2.0 * b + c;
            let (offset, peak) = if curvature < 0.0 {
                let offset = 0.5 * (a - c) / curvature;
                (offset, b - 0.25 * (a - c) * offset)
            } else {
                (0.0, b)
            };
            self.peaks.push((t1 + offset * dt, peak));
        }
    }
}

/// Strain statistics of the active two-sided and at-most sticks: `(mean, max)` of
/// `length/rest − 1` (stretch positive), and the stretch of their summed length.
pub fn strain_stats(solver: &Solver) -> (f64, f64, f64) {
    let p = &solver.particles.position;
    let sticks = &solver.sticks;
    let (mut sum, mut max, mut count) = (0.0, f64::NEG_INFINITY, 0usize);
    let (mut length, mut rest) = (0.0, 0.0);
    for i in 0..sticks.len() {
        if matches!(sticks.kind[i], StickKind::Torn | StickKind::AtLeast) {
            continue;
        }
        let [a, b] = sticks.ends()[i];
        let l = (p[a as usize] - p[b as usize]).length();
        let strain = l / sticks.rest_length[i] - 1.0;
        sum += strain;
        max = max.max(strain);
        count += 1;
        length += l;
        rest += sticks.rest_length[i];
    }
    (sum / count.max(1) as f64, max, length / rest - 1.0)
}
