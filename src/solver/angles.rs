//! Angle constraints (verlet-js `AngleConstraint`), solved with XPBD.
//!
//! The angle at the middle particle `b` between the arms `u = a − b` and `v = c − b` is held at a
//! rest angle. With an axis `k` (2D scenes use `+Z`) the angle is signed,
//! `θ = atan2((u × v)·k, u·v)`, measured in the plane normal to `k`, so a branch cannot flip to the
//! mirror side; without an axis it is the unsigned 3D angle in `[0, π]`.
//! The constraint `C = wrap(θ − θ₀)` has the gradients
//! `∇_a θ = −(k × u)/|u|²`, `∇_c θ = (k × v)/|v|²`, `∇_b θ = −∇_a θ − ∇_c θ`
//! (for the unsigned angle `k` is the normal of the plane through the three particles), and is
//! projected as `Δλ = (−C − α̃λ)/(Σ w|∇θ|² + α̃)`, `Δx_i = w_i ∇_i θ Δλ`. Unlike verlet-js, this is
//! mass-weighted and conserves momentum (the corrections sum to zero).
//!
//! The projection is one linearized (Newton) step, exact only to first order in the angle error.
//! That is safe while sticks hold the arms' lengths and the masses are comparable. Without
//! sticks on the arms (the constraint is then scale-free: near a fold the vertex's gradient
//! vanishes and a step can be longer than the arms), with a vertex much lighter than the arm
//! ends (≳ 10:1), or when the angle contradicts sticks that already fix the vertex, the steps
//! can feed energy into the motion until it diverges; random tests of three particles at 4:1
//! mass ratios with stick-held arms stayed bounded.

use super::Particles;
use super::islands::next_stamp;
use super::shared::SharedSlice;
use glam::DVec3;
use std::f64::consts::{PI, TAU};
use std::ops::Range;

/// Struct-of-arrays storage for angle constraints.
///
/// ```
/// use bevy_verlet_physics::solver::{relax_angles, Angles, Particles};
/// use glam::DVec3;
/// let mut p = Particles::default();
/// p.push(DVec3::X, DVec3::X, 1.0, 0.0, 0);
/// p.push(DVec3::ZERO, DVec3::ZERO, 1.0, 0.0, 1);
/// p.push(DVec3::Y, DVec3::Y, 1.0, 0.0, 2);
/// let mut angles = Angles::default();
/// angles.push([0, 1, 2], std::f64::consts::FRAC_PI_4, 0.0, Some(DVec3::Z));
/// for _ in 0..20 { relax_angles(&mut p, &mut angles, 0.01, false); }
/// assert!((angles.angle(0, &p) - std::f64::consts::FRAC_PI_4).abs() < 1e-6);
/// ```
#[derive(Clone, Debug, Default)]
pub struct Angles {
    /// Particle indices `[a, b, c]`; the angle is measured at `b` (read with
    /// [`Angles::particles`]: the solver's islands are built from them).
    pub(crate) particles: Vec<[u32; 3]>,
    /// Rest angles in radians (signed when an axis is given).
    pub rest_angle: Vec<f64>,
    /// XPBD compliances (rad / (N·m); `0` = rigid).
    pub compliance: Vec<f64>,
    /// Axis of the signed angle, or `None` for the unsigned 3D angle.
    pub axis: Vec<Option<DVec3>>,
    /// Accumulated XPBD multipliers of the current substep.
    pub lambda: Vec<f64>,
    /// A stamp that changes with every change of `particles`.
    pub(crate) stamp: u64,
}

impl Angles {
    /// Number of angle constraints.
    pub fn len(&self) -> usize {
        self.particles.len()
    }

    /// `true` when there are none.
    pub fn is_empty(&self) -> bool {
        self.particles.is_empty()
    }

    /// Particle indices `[a, b, c]` of every constraint (the angle is measured at `b`).
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Angles;
    /// let mut angles = Angles::default();
    /// angles.push([0, 1, 2], 1.0, 0.0, None);
    /// assert_eq!(angles.particles(), &[[0, 1, 2]]);
    /// ```
    pub fn particles(&self) -> &[[u32; 3]] {
        &self.particles
    }

    /// Removes every angle constraint.
    pub fn clear(&mut self) {
        self.stamp = next_stamp();
        self.particles.clear();
        self.rest_angle.clear();
        self.compliance.clear();
        self.axis.clear();
        self.lambda.clear();
    }

    /// Adds an angle constraint and returns its index.
    pub fn push(
        &mut self,
        particles: [u32; 3],
        rest_angle: f64,
        compliance: f64,
        axis: Option<DVec3>,
    ) -> usize {
        self.stamp = next_stamp();
        self.particles.push(particles);
        self.rest_angle.push(rest_angle);
        self.compliance.push(compliance);
        self.axis.push(axis.and_then(DVec3::try_normalize));
        self.lambda.push(0.0);
        self.particles.len() - 1
    }

    /// Current angle of constraint `i` (signed about its axis, if any).
    pub fn angle(&self, i: usize, particles: &Particles) -> f64 {
        let [a, b, c] = self.particles[i];
        let p = &particles.position;
        let u = p[a as usize] - p[b as usize];
        let v = p[c as usize] - p[b as usize];
        measure(u, v, self.axis[i]).0
    }
}

/// Signed angle from `u` to `v` about `axis` (or the unsigned angle and the plane normal).
fn measure(u: DVec3, v: DVec3, axis: Option<DVec3>) -> (f64, DVec3) {
    match axis {
        Some(k) => (u.cross(v).dot(k).atan2(u.dot(v)), k),
        None => {
            let normal = u.cross(v);
            let sin = normal.length();
            (
                sin.atan2(u.dot(v)),
                if sin > 0.0 { normal / sin } else { DVec3::ZERO },
            )
        }
    }
}

/// Wraps an angle into `(−π, π]`.
fn wrap(angle: f64) -> f64 {
    let wrapped = (angle + PI).rem_euclid(TAU) - PI;
    if wrapped <= -PI {
        wrapped + TAU
    } else {
        wrapped
    }
}

/// Projects every angle constraint once (one Gauss–Seidel sweep) for a substep of length `h`.
pub fn relax_angles(particles: &mut Particles, angles: &mut Angles, h: f64, accumulate: bool) {
    let mut lambda = std::mem::take(&mut angles.lambda);
    // SAFETY: both slices are borrowed exclusively here; nothing else can access them.
    unsafe {
        relax_angle_range(
            &SharedSlice::new(&mut particles.position),
            &particles.inverse_mass,
            angles,
            &SharedSlice::new(&mut lambda),
            0..angles.len(),
            1.0 / (h * h),
            accumulate,
        );
    }
    angles.lambda = lambda;
}

/// [`relax_angles`] over the angle constraints in `range`.
///
/// # Safety
/// No other task accesses the particles of these constraints, or their multipliers, while this
/// runs.
pub(crate) unsafe fn relax_angle_range(
    position: &SharedSlice<DVec3>,
    inverse_mass: &[f64],
    angles: &Angles,
    lambda: &SharedSlice<f64>,
    range: Range<usize>,
    inv_h2: f64,
    accumulate: bool,
) {
    for i in range {
        let [a, b, c] = angles.particles[i];
        let (a, b, c) = (a as usize, b as usize, c as usize);
        if a == c {
            continue; // both arms on one particle: its corrections cancel
        }
        let w = [inverse_mass[a], inverse_mass[b], inverse_mass[c]];
        // SAFETY: this task alone accesses these particles (caller).
        let (pa, pb, pc) = unsafe { (position.get(a), position.get(b), position.get(c)) };
        let axis = angles.axis[i];
        // Arms projected into the plane of the signed angle.
        let flatten = |x: DVec3| match axis {
            Some(k) => x - k * x.dot(k),
            None => x,
        };
        let u = flatten(pa - pb);
        let v = flatten(pc - pb);
        let (lu, lv) = (u.length_squared(), v.length_squared());
        if lu < 1e-24 || lv < 1e-24 {
            continue;
        }
        let (theta, k) = measure(u, v, axis);
        if k == DVec3::ZERO {
            continue; // collinear unsigned angle: no plane, no direction to rotate
        }
        let grad_a = -k.cross(u) / lu;
        let grad_c = k.cross(v) / lv;
        let grad_b = -grad_a - grad_c;
        let denominator = w[0] * grad_a.length_squared()
            + w[1] * grad_b.length_squared()
            + w[2] * grad_c.length_squared();
        let alpha = angles.compliance[i] * inv_h2;
        if denominator + alpha <= 0.0 {
            continue;
        }
        let constraint = wrap(theta - angles.rest_angle[i]);
        // SAFETY: this task alone accesses these particles and this multiplier (caller).
        unsafe {
            let lambda_i = if accumulate { lambda.get(i) } else { 0.0 };
            let d_lambda = (-constraint - alpha * lambda_i) / (denominator + alpha);
            if accumulate {
                lambda.set(i, lambda_i + d_lambda);
            }
            position.set(a, pa + grad_a * (w[0] * d_lambda));
            position.set(b, pb + grad_b * (w[1] * d_lambda));
            position.set(c, pc + grad_c * (w[2] * d_lambda));
        }
    }
}
