//! Bodies that hold several attachments in a substep: the momentum they share.
//!
//! A correction at one anchor moves the body's other anchors too — `W(r_k, r_j)`
//! ([`Body::inverse_mass_matrix_between`]) — so the two exchanges between a body and the
//! particles riding its anchors are solved for all of a body's attachments at once, in one
//! small linear system (`3K` unknowns for `K` attachments, Gaussian elimination):
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
//! knots of 1 g, 0.1 kg and 1 kg; now 3·10⁻⁷, 1.4·10⁻⁷ and 3·10⁻⁸ (`tests/avian2d.rs`). The
//! effective mass a rope's solve sees at each anchor is still the body's own there, shared
//! between its attachments (a plank swung on two parallel ropes: period 0.34 % short, was
//! 1.6 %).

use super::{Attachment, AttachmentScratch};
use crate::solver::Particles;
use crate::solver::bodies::Body;
use glam::{DMat3, DVec3};

/// Where a body holds more than one attachment taking this substep: the riding particles and
/// their anchors meet half way together — `Σ_j W(r_k, r_j) q_j + w_k q_k = g_k` for their gaps
/// `g` (see [`riding_gap`](super::riding_gap)), the body corrected by `−q_k` at each anchor —
/// so that what each particle's turn takes, the body gives, whatever the others do (met one
/// by one, each moved the other anchors away from their particles unaccounted). Bodies with
/// one are left to [`lump`](super::lump).
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
        scratch.group.clear();
        scratch.shares.clear();
        for (k, a) in attachments.iter().enumerate() {
            let ratio = scratch.time_ratio[k];
            if a.body as usize != b || ratio.is_nan() {
                continue;
            }
            if let Some(gap) = super::riding_gap(a, body, particles, ratio) {
                scratch.group.push(k);
                scratch.shares.extend(gap.to_array());
            }
        }
        if scratch.group.is_empty() {
            continue;
        }
        let solved = solve_joint(attachments, body, scratch);
        for row in 0..scratch.group.len() {
            let pull = DVec3::from_slice(&scratch.shares[3 * row..3 * row + 3]);
            if solved && pull.is_finite() {
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
        scratch.group.clear();
        scratch.shares.clear();
        for (k, a) in attachments.iter().enumerate() {
            let lumped = !scratch.body_inverse_mass[k].is_nan();
            if a.body as usize != b || !lumped || scratch.own_inverse_mass[k] <= 0.0 {
                continue;
            }
            scratch.group.push(k);
            let impulse = taken(a, k, particles, scratch);
            scratch
                .shares
                .extend((impulse * scratch.own_inverse_mass[k]).to_array());
        }
        let solved = solve_joint(attachments, body, scratch);
        for (row, &k) in scratch.group.iter().enumerate() {
            let a = &mut attachments[k];
            let impulse = taken(a, k, particles, scratch);
            let r = scratch.arms[row];
            let share = if solved {
                DVec3::from_slice(&scratch.shares[3 * row..3 * row + 3])
            } else {
                // (A singular system: each impulse shared as if its attachment were alone.)
                let own_mass = 1.0 / scratch.own_inverse_mass[k];
                let alone = DMat3::IDENTITY + body.inverse_mass_matrix_at(r) * own_mass;
                alone.inverse() * impulse
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
                a.direction = impulse.normalize();
            }
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
fn solve_joint(attachments: &[Attachment], body: &Body, scratch: &mut AttachmentScratch) -> bool {
    let size = 3 * scratch.group.len();
    scratch.arms.clear();
    let arms = scratch
        .group
        .iter()
        .map(|&k| body.rotation * attachments[k].anchor);
    scratch.arms.extend(arms);
    scratch.system.clear();
    scratch.system.resize(size * size, 0.0);
    for (row, &k) in scratch.group.iter().enumerate() {
        for column in 0..scratch.group.len() {
            let mut block =
                body.inverse_mass_matrix_between(scratch.arms[row], scratch.arms[column]);
            if row == column {
                block += DMat3::from_diagonal(DVec3::splat(scratch.own_inverse_mass[k]));
            }
            for (x, y) in (0..3).flat_map(|x| (0..3).map(move |y| (x, y))) {
                scratch.system[(3 * row + y) * size + 3 * column + x] = block.col(x)[y];
            }
        }
    }
    solve_in_place(size, &mut scratch.system, &mut scratch.shares)
}

/// Solves `A x = b` in place (`A` row-major `n × n`, `b` becomes `x`) by Gaussian elimination
/// with partial pivoting; `false` where `A` is singular or the result not finite.
fn solve_in_place(n: usize, a: &mut [f64], b: &mut [f64]) -> bool {
    for column in 0..n {
        let pivot = (column..n)
            .max_by(|&i, &j| a[i * n + column].abs().total_cmp(&a[j * n + column].abs()))
            .unwrap_or(column);
        if a[pivot * n + column].abs() <= f64::EPSILON {
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
    use super::solve_in_place;
    use crate::solver::{Body, Particles};
    use glam::{DMat3, DQuat, DVec3};

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
