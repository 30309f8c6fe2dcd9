//! Reference answers: closed forms and small root-finds, independent of the solver.

use std::f64::consts::PI;

/// Arithmetic–geometric mean of `a` and `b`.
pub fn agm(mut a: f64, mut b: f64) -> f64 {
    for _ in 0..64 {
        let (next_a, next_b) = (0.5 * (a + b), (a * b).sqrt());
        if (next_a - next_b).abs() <= 1e-16 * next_a {
            return next_a;
        }
        (a, b) = (next_a, next_b);
    }
    a
}

/// Exact period of a simple pendulum of length `length` under `gravity` released at rest from
/// `amplitude` radians: `T = 4√(L/g)·K(sin(θ₀/2)) = 2π√(L/g) / AGM(1, cos(θ₀/2))`.
pub fn pendulum_period(length: f64, gravity: f64, amplitude: f64) -> f64 {
    2.0 * PI * (length / gravity).sqrt() / agm(1.0, (0.5 * amplitude).cos())
}

/// Shape of a discrete catenary: `links` equal links of `link` length between two pins at the
/// same height `span` apart, equal masses on the free nodes. Link `j` makes the angle
/// `φⱼ = atan(c·(j − (N−1)/2))` with the horizontal (`c = m·g/H`), `c` solved by bisection from
/// `Σ l·cos φⱼ = span`. Returns the node positions `(x, y)` from the left pin at `(0, 0)`.
pub fn discrete_catenary(links: usize, link: f64, span: f64) -> Vec<(f64, f64)> {
    let centre = (links as f64 - 1.0) / 2.0;
    let width = |c: f64| -> f64 {
        (0..links)
            .map(|j| link / (1.0 + (c * (j as f64 - centre)).powi(2)).sqrt())
            .sum()
    };
    let (mut low, mut high) = (0.0, 1.0);
    while width(high) > span {
        high *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (low + high);
        if width(mid) > span {
            low = mid;
        } else {
            high = mid;
        }
    }
    let c = 0.5 * (low + high);
    let mut nodes = vec![(0.0, 0.0)];
    let (mut x, mut y) = (0.0, 0.0);
    for j in 0..links {
        let phi = (c * (j as f64 - centre)).atan();
        x += link * phi.cos();
        y += link * phi.sin();
        nodes.push((x, y));
    }
    nodes
}

/// Sag (depth of the lowest point below the pins) of a continuous catenary of `length` hung
/// between pins `span` apart: `length = 2a·sinh(span/2a)`, sag `= a·(cosh(span/2a) − 1)`.
pub fn continuous_catenary_sag(length: f64, span: f64) -> f64 {
    let arc = |a: f64| 2.0 * a * (span / (2.0 * a)).sinh();
    // arc(a) decreases from ∞ (a → 0) to span (a → ∞).
    let (mut low, mut high) = (span * 1e-3, span);
    while arc(high) > length {
        high *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (low + high);
        if arc(mid) > length {
            low = mid;
        } else {
            high = mid;
        }
    }
    let a = 0.5 * (low + high);
    a * ((span / (2.0 * a)).cosh() - 1.0)
}

/// XPBD with one projection per step of length `h` is implicit Euler for a linear spring of
/// angular frequency `ω`: the discrete frequency is `atan(ωh)/h`. Returns that frequency divided
/// by `ω`.
pub fn implicit_euler_frequency_ratio(omega: f64, h: f64) -> f64 {
    (omega * h).atan() / (omega * h)
}

/// Amplitude left after one second of implicit Euler steps of length `h` for a spring of angular
/// frequency `ω`: `(1 + ω²h²)^(−1/(2h))`.
pub fn implicit_euler_amplitude_per_second(omega: f64, h: f64) -> f64 {
    (1.0 + omega * omega * h * h).powf(-0.5 / h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn period_matches_the_series() {
        // T/T₀ at 90° is 1.18034 (numerics reference, §4 T2).
        let t0 = 2.0 * PI;
        assert!((pendulum_period(1.0, 1.0, PI / 2.0) / t0 - 1.18034).abs() < 1e-5);
    }

    #[test]
    fn catenary_matches_the_reference_note() {
        // N = 20, S = 1 m, d = 0.8 m: discrete sag 0.26579 m, continuous 0.26544 m.
        let nodes = discrete_catenary(20, 0.05, 0.8);
        assert!((-nodes[10].1 - 0.26579).abs() < 1e-5);
        assert!((continuous_catenary_sag(1.0, 0.8) - 0.26544).abs() < 1e-5);
    }
}
