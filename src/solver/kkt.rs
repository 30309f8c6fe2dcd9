//! One Newton step on the projection's KKT system *with the constraints' curvature*, eliminated
//! stick by stick from the leaves of a line or tree towards its root.
//!
//! # The system
//! A substep's projection is the stationary point of `L(x, λ) = ½ |x − x̃|²_M − λ·C(x)`:
//! `R = M (x − x̃) − ∇C(x)ᵀ λ = 0` and `C(x) + α̃ λ = 0`. The line and tree solves take Newton
//! steps along the current directions (Gauss–Newton: `∇C` frozen, its change as the ends move
//! left out). The full step, from the prediction `x̃` with λ warm-started, is
//!
//! ```text
//! (M + Σ_k μ_k H_k) Δx − ∇Cᵀ Δλ = −R,   ∇C Δx + α̃ Δλ = −(C + α̃ λ),   μ_k = −λ_k / d_k
//! ```
//!
//! with `H_k` stick `k`'s curvature `P_k = I − n_k n_kᵀ` on its ends' blocks (`+P` on the
//! diagonal, `−P` between them) and `d_k` its length. A rope's tension makes `μ` large: that
//! is what a heavy load swinging on a chain turns on, and what Gauss–Newton misses.
//!
//! # The elimination
//! Root the line or tree; every other particle `c` has a parent `p` and a parent stick (`n`
//! from `p` to `c`). Leaves first, a particle's equation reduced by the sticks below it reads
//! `E_c Δx_c − μ P Δx_p − n Δλ = g_c`, where the sticks below contribute a [`Subtree`]
//! (`E`, `g`, and their forces `Σ λ n` on `c`). With `G = E_c⁻¹`, `u = G n`:
//!
//! ```text
//! D = n·u + α̃,   a = (n − μ P u) / D,   β = (b − n·G g_c) / D,   b = −(C + α̃ λ)
//! Δλ = a·Δx_p + β,   Δx_c = G g_c + u β + (μ G + u (a − μ n)ᵀ) Δx_p
//! into p:  E += μ P − μ² P G P + D a aᵀ,   g += μ P (G g_c + u β) − n β,   Σλn += λ n
//! ```
//!
//! One symmetric 3 × 3 inverse per particle ([`Sym3`]); with `μ = 0` it is the Gauss–Newton
//! elimination of the line and tree solves. Verified against the dense KKT system in
//! `direct`'s tests. Compression (`λ > 0`) would make `E` indefinite: `μ` is clamped at zero
//! there (Gauss–Newton for that stick). A stick out of its active set (a slack rope) has
//! `λ = 0` and decouples its subtree. Every particle but the root must be movable (`E` would
//! be singular below a pin); a stick from a second immovable particle closes a loop instead
//! ([`closing_load`], [`closing_step`]: its multiplier by a Schur complement, with a unit load
//! carried through the same elimination, [`Reduced::carry`]).
//!
//! ```
//! use bevy_verlet_physics::solver::{Method, Solver, StepConfig, StickKind};
//! use glam::DVec3;
//! // A 1000:1 chain released from horizontal: its projections start with a curvature pass.
//! let mut solver = Solver::default();
//! solver.method = Method::Lines;
//! let pin = solver.add_particle(DVec3::ZERO, 0.0);
//! solver.pin(pin, DVec3::ZERO);
//! for i in 1..=20 {
//!     let w = if i == 20 { 0.001 } else { 1.0 };
//!     solver.add_particle(DVec3::new(0.05 * i as f64, 0.0, 0.0), w);
//!     solver.sticks.push([i - 1, i], 0.05, 0.0, StickKind::Equal, f64::INFINITY, 0);
//! }
//! solver.organize();
//! for _ in 0..64 {
//!     solver.step(&StepConfig::default());
//! }
//! assert!(solver.sticks.max_violation(&solver.particles) < 1e-8);
//! ```

use super::sym3::Sym3;
use glam::DVec3;

/// Relative regularisation of `D` (as the line and tree solves').
const REGULARISATION: f64 = 1e-9;

/// `μ` is held below this many times the child's mass (a pair of coincident ends would make it
/// unbounded). `μ/M` is `(ω h)²` of the link's transverse vibration: 3.7·10³ for a 1 cm link
/// holding 10⁶ times its mass at 8 substeps of 1/64 s. The reduction's rounding error grows as
/// `10⁻¹⁶ μ/M` (its update of `E` is written without cancellation, see [`reduce`]).
const CURVATURE_LIMIT: f64 = 1e8;

/// What the sticks below a particle contribute to its equation.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Subtree {
    /// Their share of `E`.
    pub e: Sym3,
    /// Their share of `g`.
    pub g: DVec3,
    /// `Σ λ n` of the sticks to the particle's children (their forces in `R`).
    pub force: DVec3,
}

impl Subtree {
    /// Both contributions.
    #[inline(always)]
    pub(crate) fn add(&mut self, other: &Subtree) {
        self.e = self.e + other.e;
        self.g += other.g;
        self.force += other.force;
    }
}

/// One stick as the elimination reads it: from its parent end to its child end.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Link {
    /// Unit direction from the parent to the child.
    pub normal: DVec3,
    /// `C = length − rest`.
    pub c: f64,
    /// The stick's length.
    pub length: f64,
    /// `λ` (zero unless the stick is in the system).
    pub lambda: f64,
    /// `α̃ = α / h²`.
    pub alpha: f64,
    /// The child's inverse mass (positive).
    pub inverse_mass: f64,
    /// `M (x − x̃)` at the child: zero at the prediction.
    pub offset: DVec3,
    /// In the system (a rope link while stretched, …).
    pub active: bool,
}

/// One stick reduced: `Δλ = a·Δx_p + β`, `Δx_c = v + μ G Δx_p + u (b·Δx_p)`, `b = a − μ n`.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Reduced {
    g: Sym3,
    mu: f64,
    u: DVec3,
    a: DVec3,
    b: DVec3,
    v: DVec3,
    beta: f64,
    /// `1/D` (zero for a stick out of the system), for [`Reduced::carry`].
    inverse_d: f64,
}

/// The part of a stick's `(v, β)` that a unit load elsewhere adds (see [`Reduced::carry`]).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Load {
    v: DVec3,
    beta: f64,
}

impl Load {
    /// The load's parts `(v, β)`.
    pub(crate) fn parts(&self) -> (DVec3, f64) {
        (self.v, self.beta)
    }

    /// A load from its parts `(v, β)`.
    pub(crate) fn from_parts(v: DVec3, beta: f64) -> Self {
        Self { v, beta }
    }
}

impl Reduced {
    /// As [`Reduced::substitute`], with `(v, β)` added to the stick's own part (the sum of
    /// several loads' parts, each times its amount).
    #[inline(always)]
    pub(crate) fn substitute_added(&self, v: DVec3, beta: f64, parent_dx: DVec3) -> (f64, DVec3) {
        self.substitute_with(self.v + v, self.beta + beta, parent_dx)
    }

    /// `(Δλ, Δx_c)` once the parent's `Δx_p` is known (non-finite parts as zero: a singular
    /// reduction must not spread NaN).
    #[inline(always)]
    pub(crate) fn substitute(&self, parent_dx: DVec3) -> (f64, DVec3) {
        self.substitute_with(self.v, self.beta, parent_dx)
    }

    /// As [`Reduced::substitute`], with `amount` × `load` added to the stick's own part.
    #[inline(always)]
    pub(crate) fn substitute_loaded(
        &self,
        load: &Load,
        amount: f64,
        parent_dx: DVec3,
    ) -> (f64, DVec3) {
        let (v, beta) = (self.v + load.v * amount, self.beta + load.beta * amount);
        self.substitute_with(v, beta, parent_dx)
    }

    /// The response to a unit load alone (no stick's own part), as [`Reduced::substitute`].
    #[inline(always)]
    pub(crate) fn substitute_load(&self, load: &Load, parent_dx: DVec3) -> (f64, DVec3) {
        self.substitute_with(load.v, load.beta, parent_dx)
    }

    #[inline(always)]
    fn substitute_with(&self, v: DVec3, beta: f64, parent_dx: DVec3) -> (f64, DVec3) {
        let d_lambda = self.a.dot(parent_dx) + beta;
        let dx = v + self.g * parent_dx * self.mu + self.u * self.b.dot(parent_dx);
        (
            if d_lambda.is_finite() { d_lambda } else { 0.0 },
            finite_or_zero(dx),
        )
    }

    /// Carries a load through this stick, `normal` its direction: `g` is the load on the
    /// child's equation (what the sticks below pass up, plus any applied to the child itself).
    /// Returns the stick's part of the response and the load passed to the parent — the
    /// homogeneous part of [`reduce`] with the same elimination (`v = G g`, `β = −n·v / D`), for
    /// a second right-hand side such as a loop-closing multiplier's unit force.
    #[inline(always)]
    pub(crate) fn carry(&self, normal: DVec3, g: DVec3) -> (Load, DVec3) {
        let v = self.g * g;
        let beta = -normal.dot(v) * self.inverse_d;
        let moved = v + self.u * beta;
        let up = (moved - normal * normal.dot(moved)) * self.mu - normal * beta;
        (Load { v: moved, beta }, up)
    }
}

/// Reduces `link` with what the sticks below its child contribute (`below`): the stick's
/// substitution, and what it contributes to its parent.
#[inline(always)]
pub(crate) fn reduce(link: &Link, below: &Subtree) -> (Reduced, Subtree) {
    let (n, lambda) = (link.normal, link.lambda);
    let mass = 1.0 / link.inverse_mass;
    let mu = curvature_weight(link);
    // E_c = K + μ P, K = M + E_below, P = I − n nᵀ;
    // g_c = −R_c = −M (x − x̃) + λ n − Σ λ_child n_child + g_below.
    let stiffness = Sym3::diagonal(mass) + below.e;
    let e = stiffness + Sym3::diagonal(mu) + Sym3::outer(n, -mu);
    let g = lambda * n - below.force + below.g - link.offset;
    // G = adj(E) / det: the two divisions below are independent of each other.
    let (adjugate, det) = e.adjugate();
    let adj_n = adjugate * n;
    let n_adj_n = n.dot(adj_n);
    let inverse_det = 1.0 / det;
    // 1/D = det / (n·adj n + α̃ det), D = n·G n + α̃ (regularised).
    let inverse_d = det / (n_adj_n * (1.0 + REGULARISATION) + link.alpha * det);
    let inverse = adjugate * inverse_det;
    let (u, v) = (adj_n * inverse_det, inverse * g);
    if !link.active {
        // (Its child's subtree decouples: `Δx_c = G g`, nothing passed up; `G` kept for a load.)
        let reduced = Reduced {
            g: inverse,
            v,
            ..Default::default()
        };
        return (reduced, Subtree::default());
    }
    let nu = n_adj_n * inverse_det;
    let q = n - (u - n * nu) * mu; // a = q / D
    let a = q * inverse_d;
    let beta = (-(link.c + link.alpha * lambda) - n.dot(v)) * inverse_d;
    let moved = v + u * beta;
    // μ P − μ² P G P + D a aᵀ, where μ P − μ² P G P = μ P G K P with K = E − μ P = M + E_below
    // (μ I − μ² G = μ G (E − μ I) = μ G (K − μ n nᵀ), and n is in P's kernel): written so, it
    // has no cancellation — the other form subtracts terms of size μ²/M to leave one of size M,
    // an error of 10⁻¹⁶ (μ/M)² of M (10⁻⁴ at μ/M = 10⁶, wrong at 10⁸). P Y P's symmetric part,
    // Y = G K: sym(Y) − ½ (n (Y n + Yᵀ n)ᵀ + …) + (n·Y n) n nᵀ.
    let y = inverse.times(stiffness);
    let (yn, ny) = (y * n, y.transpose() * n);
    let up = Subtree {
        e: (Sym3::symmetric_part(&y)
            + Sym3::symmetric_outer(n * -0.5, yn + ny)
            + Sym3::outer(n, n.dot(yn)))
            * mu
            + Sym3::outer(q, inverse_d),
        g: (moved - n * n.dot(moved)) * mu - n * beta,
        force: n * lambda,
    };
    let reduced = Reduced {
        g: inverse,
        mu,
        u,
        a,
        b: a - n * mu,
        v: moved,
        beta,
        inverse_d,
    };
    (reduced, up)
}

/// `μ = −λ/d` of `link`: its tension's weight on the curvature, zero under compression and held
/// below [`CURVATURE_LIMIT`] × the child's mass.
#[inline(always)]
fn curvature_weight(link: &Link) -> f64 {
    (-link.lambda / link.length.max(1e-12)).clamp(0.0, CURVATURE_LIMIT * (1.0 / link.inverse_mass))
}

/// A loop-closing stick from an immovable particle to a movable one it holds (`link` as for
/// [`reduce`], `normal` from the immovable end, `inverse_mass` the movable one's): what it adds
/// to that particle's equation — its curvature `μ P` and its force `λ n` — before the
/// particle's own stick is reduced. Its multiplier's change then follows from a Schur
/// complement (see [`closing_step`]).
#[inline(always)]
pub(crate) fn closing_load(link: &Link) -> Subtree {
    if !link.active {
        return Subtree::default();
    }
    let n = link.normal;
    let mu = curvature_weight(link);
    Subtree {
        e: Sym3::diagonal(mu) + Sym3::outer(n, -mu),
        g: n * link.lambda,
        force: DVec3::ZERO,
    }
}

/// The closing stick's `Δλ` (a Schur complement of one row): the held particle moves by
/// `dx + Δλ · dx_unit` (its step without the closing multiplier's change, and the response to
/// a unit change, which pulls along `normal`), and the stick's linearised constraint
/// `n·Δx + α̃ Δλ = −(C + α̃ λ)` must hold. Zero where the system is singular along the stick (a
/// taut loop; the regularisation of [`reduce`] applies) or anything is not finite.
#[inline(always)]
pub(crate) fn closing_step(link: &Link, dx: DVec3, dx_unit: DVec3) -> f64 {
    if !link.active {
        return -link.lambda;
    }
    let n = link.normal;
    let compliance = n.dot(dx_unit) * (1.0 + REGULARISATION) + link.alpha;
    let step = (-(link.c + link.alpha * link.lambda) - n.dot(dx)) / compliance;
    if compliance > 0.0 && step.is_finite() {
        step
    } else {
        0.0
    }
}

/// The root's `Δx` from the sticks below it (`offset`: its `M (x − x̃)`): zero when it is
/// immovable (`inverse_mass ≤ 0`).
#[inline(always)]
pub(crate) fn root_step(inverse_mass: f64, below: &Subtree, offset: DVec3) -> DVec3 {
    if inverse_mass <= 0.0 {
        return DVec3::ZERO;
    }
    let e = below.e + Sym3::diagonal(1.0 / inverse_mass);
    finite_or_zero(e.inverse() * (below.g - below.force - offset))
}

/// `v`, or zero where it is not finite.
#[inline(always)]
fn finite_or_zero(v: DVec3) -> DVec3 {
    if v.is_finite() { v } else { DVec3::ZERO }
}

/// The Newton step of the dense KKT system, by Gaussian elimination: what the tests compare the
/// elimination with.
#[cfg(test)]
pub(crate) mod dense {
    use glam::DVec3;

    /// Particles, sticks (`[a, b]`, `n` from `a` to `b`) and multipliers at the prediction.
    pub(crate) struct System<'a> {
        pub x: &'a [DVec3],
        pub inverse_mass: &'a [f64],
        pub ends: &'a [[usize; 2]],
        pub lambda: &'a [f64],
        pub rest: &'a [f64],
        pub compliance: &'a [f64],
        pub active: &'a [bool],
        pub inv_h2: f64,
    }

    /// `(Δx, Δλ)` of the full Newton step from `x = x̃` (immovable particles: `Δx = 0`; a stick
    /// out of the system: `Δλ = 0` and no force or curvature).
    pub(crate) fn newton_step(s: &System) -> (Vec<DVec3>, Vec<f64>) {
        let particles = s.x.len();
        let free: Vec<usize> = (0..particles)
            .filter(|&j| s.inverse_mass[j] > 0.0)
            .collect();
        let col = |j: usize| free.iter().position(|&f| f == j).map(|i| 3 * i);
        let nx = 3 * free.len();
        let size = nx + s.ends.len();
        let mut a = vec![vec![0.0; size + 1]; size];
        for (i, &j) in free.iter().enumerate() {
            for d in 0..3 {
                a[3 * i + d][3 * i + d] = 1.0 / s.inverse_mass[j];
            }
        }
        for (k, &[first, second]) in s.ends.iter().enumerate() {
            let row = nx + k;
            if !s.active[k] {
                a[row][row] = 1.0;
                continue;
            }
            let e = s.x[second] - s.x[first];
            let (length, n) = (e.length(), e.normalize());
            let mu = (-s.lambda[k] / length).max(0.0);
            let alpha = s.compliance[k] * s.inv_h2;
            for (j, sign) in [(first, -1.0), (second, 1.0)] {
                let Some(cj) = col(j) else { continue };
                for d in 0..3 {
                    // Stationarity: −∇Cᵀ Δλ = −R = ∇Cᵀ λ (x = x̃); the constraint row ∇C Δx.
                    a[cj + d][row] -= sign * n[d];
                    a[cj + d][size] += sign * n[d] * s.lambda[k];
                    a[row][cj + d] += sign * n[d];
                }
                for (l, other) in [(first, -1.0), (second, 1.0)] {
                    let Some(cl) = col(l) else { continue };
                    for d in 0..3 {
                        for e2 in 0..3 {
                            let p = f64::from(d == e2) - n[d] * n[e2];
                            a[cj + d][cl + e2] += mu * sign * other * p;
                        }
                    }
                }
            }
            a[row][row] += alpha;
            a[row][size] = -(length - s.rest[k] + alpha * s.lambda[k]);
        }
        let solution = gauss(a);
        let mut dx = vec![DVec3::ZERO; particles];
        for (i, &j) in free.iter().enumerate() {
            dx[j] = DVec3::from_slice(&solution[3 * i..3 * i + 3]);
        }
        (dx, solution[nx..].to_vec())
    }

    /// Every stick's ends in `solver`, as indices.
    pub(crate) fn ends_of(solver: &crate::solver::Solver) -> Vec<[usize; 2]> {
        let ends = solver.sticks.ends().iter();
        ends.map(|e| e.map(|p| p as usize)).collect()
    }

    /// Asserts that `solver`'s particles moved from `x` to `position` and its multipliers from
    /// `warm` to `lambda` by the dense system's Newton step (every stick in the system), within
    /// `tolerance` relative to the largest move and to `|Δλ|` (at least `lambda_floor`).
    pub(crate) fn assert_newton_step(
        solver: &crate::solver::Solver,
        (x, position): (&[DVec3], &[DVec3]),
        (warm, lambda): (&[f64], &[f64]),
        inv_h2: f64,
        (tolerance, lambda_floor): (f64, f64),
    ) {
        let ends = ends_of(solver);
        let (want_dx, want_dl) = newton_step(&System {
            x,
            inverse_mass: &solver.particles.inverse_mass,
            ends: &ends,
            lambda: warm,
            rest: &solver.sticks.rest_length,
            compliance: &solver.sticks.compliance,
            active: &vec![true; ends.len()],
            inv_h2,
        });
        let scale = want_dx.iter().map(|d| d.length()).fold(0.0, f64::max);
        for j in 0..x.len() {
            let got = position[j] - x[j];
            assert!(
                (got - want_dx[j]).length() < tolerance * scale,
                "particle {j}: Δx {got} against {}",
                want_dx[j]
            );
        }
        for k in 0..ends.len() {
            let (got, want) = (lambda[k] - warm[k], want_dl[k]);
            assert!(
                (got - want).abs() < tolerance * want.abs().max(lambda_floor),
                "stick {k}: Δλ {got} against {want}"
            );
        }
    }

    /// `(Δx, Δλ)` of one pass of the linearised system in multipliers, stick `k` moving its
    /// ends along `r[k]` (`Δx_b += w_b r Δλ`, `Δx_a −= w_a r Δλ`; SHAKE's start directions, or
    /// the current ones) and its row `n_k·(Δx_b − Δx_a) + α̃_k Δλ_k = −(C_k + α̃_k λ_k)` (`n_k`
    /// the current direction); a stick out of the system is released (`Δλ = −λ`). Unsymmetric
    /// where `r ≠ n`: the Gauss–Newton and SHAKE passes of the line and tree solves.
    pub(crate) fn step_along(s: &System, r: &[DVec3]) -> (Vec<DVec3>, Vec<f64>) {
        let m = s.ends.len();
        let alpha = |k: usize| s.compliance[k] * s.inv_h2;
        let mut a = vec![vec![0.0; m + 1]; m];
        for (k, &[p, q]) in s.ends.iter().enumerate() {
            if !s.active[k] {
                a[k][k] = 1.0;
                a[k][m] = -s.lambda[k];
                continue;
            }
            let d = s.x[q] - s.x[p];
            let n = d.normalize();
            for (j, &[pj, qj]) in s.ends.iter().enumerate() {
                // (How a unit Δλ_j moves particle i.)
                let moved = |i: usize| {
                    let w = s.inverse_mass[i];
                    r[j] * w * (f64::from(i == qj) - f64::from(i == pj))
                };
                a[k][j] = n.dot(moved(q) - moved(p));
            }
            a[k][k] += alpha(k);
            a[k][m] = -(d.length() - s.rest[k] + alpha(k) * s.lambda[k]);
        }
        let dl = gauss(a);
        let mut dx = vec![DVec3::ZERO; s.x.len()];
        for (j, &[p, q]) in s.ends.iter().enumerate() {
            dx[q] += r[j] * s.inverse_mass[q] * dl[j];
            dx[p] -= r[j] * s.inverse_mass[p] * dl[j];
        }
        (dx, dl)
    }

    /// Solves the augmented system `a` (each row ends with its right-hand side).
    fn gauss(mut a: Vec<Vec<f64>>) -> Vec<f64> {
        let n = a.len();
        for i in 0..n {
            let pivot = (i..n).max_by(|&p, &q| a[p][i].abs().total_cmp(&a[q][i].abs()));
            a.swap(i, pivot.unwrap());
            let (above, below) = a.split_at_mut(i + 1);
            let pivot_row = &above[i];
            for row in below {
                let f = row[i] / pivot_row[i];
                for (value, pivot) in row[i..].iter_mut().zip(&pivot_row[i..]) {
                    *value -= f * pivot;
                }
            }
        }
        let mut x = vec![0.0; n];
        for i in (0..n).rev() {
            let sum: f64 = (i + 1..n).map(|j| a[i][j] * x[j]).sum();
            x[i] = (a[i][n] - sum) / a[i][i];
        }
        x
    }
}
