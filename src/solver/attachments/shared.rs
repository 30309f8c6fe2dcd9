//! Bodies that hold several attachments in a substep: the momentum they share.
//!
//! A correction at one anchor moves the body's other anchors too — `W(r_k, r_j)`
//! ([`Body::inverse_mass_matrix_between`]) — so the two exchanges between a body and the
//! particles riding its anchors are solved for all of a body's attachments at once, in one
//! linear system (`3K` unknowns for `K` attachments, solved through the body's six degrees of
//! freedom: [`solve_joint`]):
//!
//! - [`meet_half_way`]: particles riding turning anchors and their anchors meet where their
//!   masses put them, `Σ_j W(r_k, r_j) q_j + w_k q_k = g_k` for the gaps `g` (a zero-length
//!   joint, see [`lump`](super::lump)), the body corrected by `−q_k` at each anchor;
//! - [`release`]: the impulses `J_k` the constraints gave the lumped particles are shared
//!   between the body (`p_k`) and those particles, `w_k p_k + Σ_j W(r_k, r_j) p_j = w_k J_k`,
//!   so that each particle, put back on its anchor after the body moved, takes exactly the
//!   rest.
//!
//! Momentum is then kept for any number of attachments (to first order in the body's turn per
//! substep), where exchanging with one attachment at a time left what each correction gave the
//! other particles' anchors unaccounted: a free 1 kg box, 20 cm, with a 5-link rope on each
//! side, one of them moving at 2 m/s, lost 0.28 %, 28 % and 82 % of its momentum in 2 s with
//! knots of 1 g, 0.1 kg and 1 kg; now 2.5·10⁻⁷, 1.2·10⁻⁷ and 7.5·10⁻⁸ (`tests/avian2d.rs`).
//!
//! [`inverse_mass`]: the effective inverse mass a rope's solve sees at anchor `k` is how far
//! the anchor can move per unit of its pull while every attachment pulls as hard, each along
//! its last pull with the sign that moves anchor `k` most: `Σ_j |d_k·W(r_k, r_j)·d_j|`. Exact
//! for one attachment and for anchors that coincide; otherwise an upper bound over such
//! pulls — lighter than the part of the body an anchor carries when the pulls share the load,
//! never heavier than any of them makes it. The body's inverse mass at the anchor times the
//! number of attachments, before, was far lighter still: a plank swung level on two parallel
//! ropes had its period 0.34 % short (now 0.04 % long), a platform on four 4.6 % (0.09 %
//! long), and a plank hung in a V from one pin gained 12 % of m·g·L (now 7·10⁻⁶ of it).
//! Measured and not kept: the exact value for pulls in the ratios of the last ones,
//! `Σ_j d_k·W(r_k, r_j)·d_j · s_j/s_k` (the plank's period to 0.06 %, but the modes it makes
//! too heavy — turns — grew: the platform turned by 0.2 rad).

use super::{Attachment, AttachmentScratch};
use crate::solver::Particles;
use crate::solver::bodies::Body;
use glam::{DMat3, DVec3};

/// Above this many attachments taking a substep on one body, each end's effective inverse mass
/// is the body's at its anchor times their number (the cheaper, lighter bound) instead of how
/// far the anchor can move while the others pull as hard (see
/// [`attachments`](crate::solver::attachments)), whose cost grows with the square of the count:
/// a cloth's edge tied along a bar.
///
/// ```
/// assert_eq!(bevy_verlet_physics::solver::EXACT_SHARING_UP_TO, 32);
/// ```
pub const EXACT_SHARING_UP_TO: u32 = 32;

/// Keeps, for every attachment taking this substep on a body with more than one, what
/// [`inverse_mass`] pairs up: its last pull `d`, and `I⁻¹ (r × d)` with `r × d`.
pub(super) fn prepare_pulls(
    attachments: &[Attachment],
    bodies: &[Body],
    scratch: &mut AttachmentScratch,
) {
    scratch.pulls.resize(attachments.len(), [DVec3::ZERO; 3]);
    for (k, a) in attachments.iter().enumerate() {
        let shared = scratch.per_body[a.body as usize];
        if shared <= 1 || shared > EXACT_SHARING_UP_TO || scratch.time_ratio[k].is_nan() {
            continue;
        }
        let body = &bodies[a.body as usize];
        let arm = (body.rotation * a.anchor).cross(a.direction);
        scratch.pulls[k] = [a.direction, body.inverse_inertia() * arm, arm];
    }
}

/// The effective inverse mass a rope's solve sees at attachment `k`'s anchor, along its last
/// pull `d_k`, where its body holds other attachments taking this substep: how far the anchor
/// can move per unit of its pull while every attachment pulls as hard, each along its own last
/// pull and with the sign that moves anchor `k` most — `Σ_j |d_k·W(r_k, r_j)·d_j|` over those
/// whose particle can move, `k` included, with
/// `d_k·W(r_k, r_j)·d_j = w·d_k·d_j + (r_k × d_k)·I⁻¹(r_j × d_j)` ([`prepare_pulls`]). One
/// attachment alone: `d·W(r)·d`, the body's inverse mass there. Above
/// [`EXACT_SHARING_UP_TO`] attachments, that times their number. See the [module docs](self)
/// for what it replaced.
pub(super) fn inverse_mass(
    attachments: &[Attachment],
    k: usize,
    body: &Body,
    scratch: &AttachmentScratch,
) -> f64 {
    let a = &attachments[k];
    let b = a.body as usize;
    let shared = scratch.per_body[b];
    if shared > EXACT_SHARING_UP_TO {
        let r = body.rotation * a.anchor;
        return body.inverse_mass_at(r, a.direction) * f64::from(shared);
    }
    let [d, _, arm] = scratch.pulls[k];
    (scratch.order[scratch.bucket(b)].iter())
        .filter(|&&j| j == k || scratch.own_inverse_mass[j] > 0.0)
        .map(|&j| {
            let [other, turn, _] = scratch.pulls[j];
            (body.inverse_mass * d.dot(other) + arm.dot(turn)).abs()
        })
        .sum()
}

/// Where a body holds more than one attachment taking this substep: the riding particles and
/// their anchors meet half way together — `Σ_j W(r_k, r_j) q_j + w_k q_k = g_k` for their gaps
/// `g` (see [`riding_gap`](super::riding_gap)), the body corrected by `−q_k` at each anchor —
/// so that what each particle's turn takes, the body gives, whatever the others do (met one
/// by one, each moved the other anchors away from their particles unaccounted). The body's
/// other movable particles take part with no gap of their own: they are put on their anchors
/// afterwards, and what the others' corrections move those anchors by is then theirs. Bodies
/// with one are left to [`lump`](super::lump).
pub(super) fn meet_half_way(
    attachments: &[Attachment],
    bodies: &mut [Body],
    particles: &Particles,
    scratch: &mut AttachmentScratch,
) {
    for (b, body) in bodies.iter_mut().enumerate() {
        if scratch.per_body[b] <= 1 || !body.is_dynamic() {
            continue;
        }
        let mut riding = false;
        group_movable(b, scratch, |scratch, k| {
            let (a, ratio) = (&attachments[k], scratch.time_ratio[k]);
            let gap = super::riding_gap(a, body, particles, ratio);
            riding |= gap.is_some();
            gap.unwrap_or(DVec3::ZERO)
        });
        if !riding {
            continue;
        }
        let solved = solve_joint(attachments, body, scratch);
        for (row, &k) in scratch.group.iter().enumerate() {
            let pull = if solved {
                DVec3::from_slice(&scratch.shares[3 * row..3 * row + 3])
            } else {
                // (A singular system: each riding particle met as if it were alone.)
                let (a, ratio) = (&attachments[k], scratch.time_ratio[k]);
                let gap = super::riding_gap(a, body, particles, ratio).unwrap_or(DVec3::ZERO);
                super::meeting_alone(body, scratch.arms[row], scratch.own_inverse_mass[k], gap)
            };
            if pull.is_finite() && pull != DVec3::ZERO {
                body.correct(scratch.arms[row], -pull);
            }
        }
    }
}

/// Moves every body that holds more than one attachment taking this substep by the impulses
/// they took, shared with the particles riding its anchors in one system (see the
/// [module docs](self)); updates those attachments' pull directions. Bodies with one are left to
/// [`release`](super::release).
pub(super) fn release(
    attachments: &mut [Attachment],
    bodies: &mut [Body],
    particles: &Particles,
    scratch: &mut AttachmentScratch,
) {
    for (b, body) in bodies.iter_mut().enumerate() {
        if scratch.per_body[b] <= 1 || !body.is_dynamic() {
            continue;
        }
        // The impulse each lumped particle took (none measurable where it was lumped
        // immovable), times its own inverse mass: `w_k p_k + Σ_j W(r_k, r_j) p_j = w_k J_k`.
        group_movable(b, scratch, |scratch, k| {
            taken(&attachments[k], k, particles, scratch) * scratch.own_inverse_mass[k]
        });
        let solved = solve_joint(attachments, body, scratch);
        for row in 0..scratch.group.len() {
            let k = scratch.group[row];
            let a = &mut attachments[k];
            let impulse = taken(a, k, particles, scratch);
            let r = scratch.arms[row];
            let share = if solved {
                DVec3::from_slice(&scratch.shares[3 * row..3 * row + 3])
            } else {
                // (A singular system: each impulse shared as if its attachment were alone.)
                super::share_alone(body, r, 1.0 / scratch.own_inverse_mass[k], impulse)
            };
            if share.is_finite() && share != DVec3::ZERO {
                body.correct(r, share);
                let ratio = scratch.time_ratio[k];
                if ratio != 1.0 {
                    let slower = (a.body, r, share * (ratio - 1.0));
                    scratch.velocity_corrections.push(slower);
                }
            }
            if impulse != DVec3::ZERO {
                scratch.pulled[k] += impulse;
                a.direction = impulse.normalize();
            }
        }
    }
}

/// Lists body `b`'s attachments taking this substep whose particle can move in
/// `scratch.group`, and beside each, in `scratch.shares`, the right-hand side `rhs` gives it
/// (of the joint system [`solve_joint`] solves).
fn group_movable(
    b: usize,
    scratch: &mut AttachmentScratch,
    mut rhs: impl FnMut(&AttachmentScratch, usize) -> DVec3,
) {
    scratch.group.clear();
    scratch.shares.clear();
    for i in scratch.bucket(b) {
        let k = scratch.order[i];
        if scratch.own_inverse_mass[k] > 0.0 {
            let value = rhs(scratch, k);
            scratch.group.push(k);
            scratch.shares.extend(value.to_array());
        }
    }
}

/// The impulse the constraints gave attachment `k`'s lumped particle (zero where it was lumped
/// immovable: none can be measured).
fn taken(a: &Attachment, k: usize, particles: &Particles, scratch: &AttachmentScratch) -> DVec3 {
    let p = a.particle as usize;
    let w_lumped = particles.inverse_mass[p];
    if w_lumped > 0.0 {
        (particles.position[p] - scratch.placed[k]) / w_lumped
    } else {
        DVec3::ZERO
    }
}

/// Solves the joint system of `body`'s attachments in `scratch.group`,
/// `Σ_j W(r_k, r_j) x_j + w_k x_k = b_k` (`w_k` the particle's own inverse mass), for the
/// right-hand sides in `scratch.shares`, which become the solution; the arms go to
/// `scratch.arms`. `false` where the system is singular.
///
/// `W(r_k, r_j) = U_k M⁻¹ U_jᵀ` with `U_k = [I | −[r_k]ₓ]` and `M⁻¹ = diag(w·I, I⁻¹)` the
/// body's: the coupling has the body's six degrees of freedom only, so the `3K × 3K` system is
/// solved through a 6 × 6 one (Woodbury): `x = D⁻¹b − D⁻¹ U M⁻¹ (I + Uᵀ D⁻¹ U M⁻¹)⁻¹ Uᵀ D⁻¹ b`,
/// `D = diag(w_k)` — linear in `K` (a cloth's edge tied along a bar), and without inverting
/// `M⁻¹`, which a locked axis makes singular.
fn solve_joint(attachments: &[Attachment], body: &Body, scratch: &mut AttachmentScratch) -> bool {
    scratch.arms.clear();
    let arms = (scratch.group.iter()).map(|&k| body.rotation * attachments[k].anchor);
    scratch.arms.extend(arms);
    // `Uᵀ D⁻¹ b` (a force and a torque) and `G = Uᵀ D⁻¹ U` in 3 × 3 blocks.
    let (mut force, mut torque) = (DVec3::ZERO, DVec3::ZERO);
    let (mut g11, mut g12, mut g22) = (DMat3::ZERO, DMat3::ZERO, DMat3::ZERO);
    for (row, &k) in scratch.group.iter().enumerate() {
        let (w, r) = (scratch.own_inverse_mass[k], scratch.arms[row]);
        let y = DVec3::from_slice(&scratch.shares[3 * row..3 * row + 3]) / w;
        force += y;
        torque += r.cross(y);
        let c = cross_matrix(r);
        g11 += DMat3::IDENTITY / w;
        g12 -= c / w;
        g22 -= c * c / w;
    }
    // `G₂₁ = −G₁₂` ([r]ₓ is skew); `I + G M⁻¹`, row-major.
    let (w_body, inertia) = (body.inverse_mass, body.inverse_inertia());
    let blocks = [
        [DMat3::IDENTITY + g11 * w_body, g12 * inertia],
        [-g12 * w_body, DMat3::IDENTITY + g22 * inertia],
    ];
    let mut a = [0.0; 36];
    for (row, column, x, y) in
        (0..4).flat_map(|b| (0..9).map(move |e| (b / 2, b % 2, e / 3, e % 3)))
    {
        a[(3 * row + y) * 6 + 3 * column + x] = blocks[row][column].col(x)[y];
    }
    let mut t = [force.x, force.y, force.z, torque.x, torque.y, torque.z];
    if !solve_in_place(6, &mut a, &mut t) {
        return false;
    }
    // The body's motion `M⁻¹ t`, and each `x_k = (b_k − U_k M⁻¹ t) / w_k`.
    let moved = DVec3::from_slice(&t[..3]) * w_body;
    let turned = inertia * DVec3::from_slice(&t[3..]);
    for (row, &k) in scratch.group.iter().enumerate() {
        let (w, r) = (scratch.own_inverse_mass[k], scratch.arms[row]);
        let b = DVec3::from_slice(&scratch.shares[3 * row..3 * row + 3]);
        let x = (b - (moved + turned.cross(r))) / w;
        scratch.shares[3 * row..3 * row + 3].copy_from_slice(&x.to_array());
    }
    scratch.shares.iter().all(|v| v.is_finite())
}

/// `[r]ₓ`: `[r]ₓ v = r × v`.
fn cross_matrix(r: DVec3) -> DMat3 {
    DMat3::from_cols(r.cross(DVec3::X), r.cross(DVec3::Y), r.cross(DVec3::Z))
}

/// Solves `A x = b` in place (`A` row-major `n × n`, `b` becomes `x`) by Gaussian elimination
/// with partial pivoting; `false` where `A` is singular or the result not finite.
fn solve_in_place(n: usize, a: &mut [f64], b: &mut [f64]) -> bool {
    // (Relative to the largest entry: the system's units are those of its inverse masses.)
    let scale = a[..n * n].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for column in 0..n {
        let pivot = (column..n)
            .max_by(|&i, &j| a[i * n + column].abs().total_cmp(&a[j * n + column].abs()))
            .unwrap_or(column);
        let largest = a[pivot * n + column].abs();
        if largest.is_nan() || largest <= 1e-14 * scale {
            return false;
        }
        if pivot != column {
            for x in 0..n {
                a.swap(pivot * n + x, column * n + x);
            }
            b.swap(pivot, column);
        }
        let diagonal = a[column * n + column];
        for row in column + 1..n {
            let factor = a[row * n + column] / diagonal;
            if factor == 0.0 {
                continue;
            }
            for x in column..n {
                a[row * n + x] -= factor * a[column * n + x];
            }
            b[row] -= factor * b[column];
        }
    }
    for row in (0..n).rev() {
        let tail: f64 = (row + 1..n).map(|x| a[row * n + x] * b[x]).sum();
        b[row] = (b[row] - tail) / a[row * n + row];
    }
    b[..n].iter().all(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::super::{Attachment, AttachmentScratch, lump, release};
    use super::{solve_in_place, solve_joint};
    use crate::solver::{Body, Particles};
    use glam::{DMat3, DQuat, DVec3};

    /// The 6 × 6 solve through the body gives the solution of the full `3K × 3K` system: its
    /// residual, summed block by block, is at rounding level — for 40 attachments on a turned
    /// body with an anisotropic inertia.
    #[test]
    fn the_joint_system_is_solved_through_the_body() {
        let inverse_inertia = DMat3::from_cols(
            DVec3::new(2.0, 0.3, 0.1),
            DVec3::new(0.3, 3.0, -0.2),
            DVec3::new(0.1, -0.2, 4.0),
        );
        let rotation = DQuat::from_rotation_y(0.7);
        let body = Body::dynamic(DVec3::ZERO, rotation, 0.5, inverse_inertia);
        let n = 40;
        let wave = |k: usize, f: f64| (k as f64 * f).sin();
        let anchor = |k| DVec3::new(wave(k, 1.3), wave(k, 2.1), wave(k, 0.7));
        let attachments: Vec<Attachment> = (0..n)
            .map(|k| Attachment::new(k as u32, 0, anchor(k)))
            .collect();
        let b: Vec<DVec3> = (0..n)
            .map(|k| DVec3::new(wave(k, 3.1), wave(k, 0.4), 1.0))
            .collect();
        let mut scratch = AttachmentScratch {
            group: (0..n).collect(),
            own_inverse_mass: (0..n).map(|k| 1.0 + 10.0 * wave(k, 0.9).abs()).collect(),
            shares: b.iter().flat_map(|v| v.to_array()).collect(),
            ..AttachmentScratch::default()
        };
        assert!(solve_joint(&attachments, &body, &mut scratch));
        let x = |j: usize| DVec3::from_slice(&scratch.shares[3 * j..3 * j + 3]);
        for (k, want) in b.iter().enumerate() {
            let r = scratch.arms[k];
            let coupled: DVec3 = (0..n)
                .map(|j| body.inverse_mass_matrix_between(r, scratch.arms[j]) * x(j))
                .sum();
            let residual = coupled + x(k) * scratch.own_inverse_mass[k] - *want;
            assert!(residual.length() < 1e-12, "row {k}: residual {residual}");
        }
    }

    /// Each end's effective inverse mass is `Σ_j |d_k·W(r_k, r_j)·d_j|` over the body's
    /// attachments — up to [`EXACT_SHARING_UP_TO`](super::EXACT_SHARING_UP_TO) of them; beyond,
    /// the body's inverse mass at the anchor times their number.
    #[test]
    fn each_end_sees_the_body_with_the_others_pulling_as_hard() {
        let inverse_inertia = DMat3::from_diagonal(DVec3::new(2.0, 3.0, 4.0));
        let rotation = DQuat::from_rotation_z(0.4);
        for n in [3usize, 40] {
            let mut bodies = [Body::dynamic(DVec3::ZERO, rotation, 0.5, inverse_inertia)];
            let mut particles = Particles::default();
            let wave = |k: usize, f: f64| (k as f64 * f + 0.3).sin();
            let anchor = |k| DVec3::new(wave(k, 1.3), wave(k, 2.1), wave(k, 0.7));
            let mut attachments = Vec::new();
            for k in 0..n {
                let at = bodies[0].rotation * anchor(k);
                particles.push(at, at, 10.0, 0.0, 0);
                let mut a = Attachment::new(k as u32, 0, anchor(k));
                a.direction = DVec3::new(wave(k, 0.5), 1.0, wave(k, 1.7)).normalize();
                attachments.push(a);
            }
            let mut scratch = AttachmentScratch::default();
            lump(
                &attachments,
                &mut bodies,
                &mut particles,
                &mut scratch,
                |_| Some(1.0),
            );
            let body = &bodies[0];
            for (k, a) in attachments.iter().enumerate() {
                let r = body.rotation * a.anchor;
                let want = if n as u32 > super::EXACT_SHARING_UP_TO {
                    body.inverse_mass_at(r, a.direction) * n as f64
                } else {
                    (attachments.iter())
                        .map(|b| {
                            let between =
                                body.inverse_mass_matrix_between(r, body.rotation * b.anchor);
                            a.direction.dot(between * b.direction).abs()
                        })
                        .sum()
                };
                let lumped = 1.0 / (1.0 / 10.0 + 1.0 / want);
                let got = particles.inverse_mass[k];
                assert!(
                    (got - lumped).abs() < 1e-12 * lumped,
                    "{n}, {k}: {got} vs {lumped}"
                );
            }
        }
    }

    #[test]
    fn gaussian_elimination_pivots() {
        // The first pivot is zero: the rows must be swapped.
        let mut a = [0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
        let mut b = [5.0, 3.0, 4.0]; // x = (1, 2, 1)
        assert!(solve_in_place(3, &mut a, &mut b));
        for (x, want) in b.iter().zip([1.0, 2.0, 1.0]) {
            assert!((x - want).abs() < 1e-12, "{b:?}");
        }
        let mut singular = [1.0, 2.0, 2.0, 4.0];
        assert!(!solve_in_place(2, &mut singular, &mut [1.0, 2.0]));
    }

    /// Two particles riding the ends of a spinning rod, each moving straight on at its anchor's
    /// last velocity (the anchors' paths curve): met half way together, the rod and the
    /// particles exchange momentum and keep it, and each particle ends on its anchor.
    #[test]
    fn two_riding_particles_meet_their_spinning_body_half_way_together() {
        let inertia = DMat3::from_diagonal(DVec3::new(2.0, 3.0, 4.0));
        let mut body = Body::dynamic(DVec3::ZERO, DQuat::IDENTITY, 0.5, inertia);
        body.angular_velocity = DVec3::Z * 2.0;
        let h = 0.01;
        let anchors = [DVec3::X, -DVec3::X * 0.5 + DVec3::Y * 0.2];
        let mut particles = Particles::default();
        for a in anchors {
            // At the anchor a substep ago, moving on at its velocity then.
            let velocity = body.point_velocity(a);
            particles.push(a + velocity * h, a, 5.0, 0.0, 0); // 0.2 kg each
        }
        let mut attachments = anchors.map(|a| Attachment::new(0, 0, a));
        attachments[1].particle = 1;
        let own_motion: Vec<DVec3> = (0..2)
            .map(|k| particles.position[k] - particles.previous[k])
            .collect();
        let mut bodies = [body];
        bodies[0].begin_substep(h);
        let predicted = bodies[0].position;
        let mut scratch = AttachmentScratch::default();
        lump(
            &attachments,
            &mut bodies,
            &mut particles,
            &mut scratch,
            |_| Some(1.0),
        );
        // Momentum (mass × length over the substep) the meeting gave the body and the particles.
        let body_change = (bodies[0].position - predicted) * 2.0;
        let particle_change: DVec3 = (0..2)
            .map(|k| {
                let motion = particles.position[k] - particles.previous[k];
                (motion - own_motion[k]) * 5.0f64.recip()
            })
            .sum();
        let given = body_change.length();
        assert!(given > 1e-7, "the body was not moved: {given}");
        // (Met one at a time: 13 % of it lost.)
        let lost = (body_change + particle_change).length();
        assert!(lost < 1e-6 * given, "{body_change} + {particle_change}");
        for (k, a) in attachments.iter().enumerate() {
            assert_eq!(particles.position[k], a.world_anchor(&bodies[0]));
        }
    }

    /// A body with two attachments at opposite ends, the first particle pulled sideways: the
    /// body and both particles together take exactly the impulse the pull gave (to first order
    /// in the body's turn), and each particle ends on its anchor.
    #[test]
    fn two_attachments_share_one_pull_and_keep_its_momentum() {
        let inertia = DMat3::from_diagonal(DVec3::new(2.0, 3.0, 4.0));
        let mut bodies = [Body::dynamic(DVec3::ZERO, DQuat::IDENTITY, 0.5, inertia)];
        let mut particles = Particles::default();
        let anchors = [DVec3::X, -DVec3::X + DVec3::Y * 0.2];
        for a in anchors {
            particles.push(a, a, 5.0, 0.0, 0); // 0.2 kg each
        }
        let mut attachments = anchors.map(|a| Attachment::new(0, 0, a));
        attachments[1].particle = 1;
        let mut scratch = AttachmentScratch::default();
        bodies[0].begin_substep(0.01);
        lump(
            &attachments,
            &mut bodies,
            &mut particles,
            &mut scratch,
            |_| Some(1.0),
        );
        let placed = [particles.position[0], particles.position[1]];
        let pull = DVec3::new(0.0, 1e-7, 2e-8);
        particles.position[0] += pull;
        let impulse = pull / particles.inverse_mass[0];
        release(&mut attachments, &mut bodies, &mut particles, &mut scratch);
        let body_momentum = bodies[0].position * 2.0; // mass × displacement
        let particle_momentum: DVec3 = (0..2)
            .map(|k| (particles.position[k] - placed[k]) / particles.inverse_mass[k])
            .sum();
        let total = body_momentum + particle_momentum;
        // (Measured 5.5e-9 of the pull, ten times more for a ten times larger one: the body's
        // turn, second order. Sharing each pull as if its attachment were alone missed
        // `m₁ W(r₁, r₀) p₀`, a first-order part of it.)
        assert!(
            (total - impulse).length() < 1e-7 * impulse.length(),
            "{total} vs {impulse}"
        );
        for (k, a) in attachments.iter().enumerate() {
            assert_eq!(particles.position[k], a.world_anchor(&bodies[0]));
        }
    }
}
