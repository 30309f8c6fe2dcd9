//! Particles attached to rigid bodies ([`Body`]) at a body-local anchor, coupled both ways.
//!
//! An attached particle is rigidly fixed to its anchor, so for the constraints around it the
//! particle and the body move as one: before the relaxation ([`lump`]) the particle is placed
//! on its anchor and takes the body's effective mass (along the direction it was last pulled,
//! `1/((r × n)·I⁻¹(r × n) + 1/M)`; with other attachments on the body, see below), so a rope
//! solve sees a
//! heavy crate at its end and not a light particle that the crate catches up with a substep
//! later (a Gauss–Seidel pass between a rope and a 100× heavier body would carry ~1 % of the
//! correction per substep). After the relaxation ([`release`]) the particle's displacement is
//! handed to the body as a positional correction at the anchor, the particle is put back on the
//! anchor, and its own mass is restored. The correction keeps momentum: the rope's impulse on
//! the lumped particle, `J = Δx / w_lumped`, is shared between the body and the particle riding
//! its anchor, `p + m·W(r) p = J` with `W(r)` the body's inverse mass matrix at the anchor
//! (along the pull direction this moves the anchor by `Δx`) — for a body with several
//! attachments all at once (below). Static and kinematic bodies make the particle immovable: it
//! follows the body like a pin.
//!
//! Before that, where the particle's motion over the substep differs from its anchor's by less
//! than half the anchor's (riding a turning body: the anchor's path curves, the particle's does
//! not) the two are met half way, as a zero-length joint: the body and the particle are moved
//! by their masses, so what the particle's turn takes, the body gives (a 0.1 kg particle on a
//! 1 kg box spun 2 rad in a second: momentum kept to 2·10⁻⁶ instead of losing 11 %; for a
//! body with several attachments all at once, below). An offset from before the substep (a
//! particle spawned off its anchor, a body moved by its own engine between steps) is closed by
//! putting the particle on the anchor.
//!
//! **Several attachments on one body.** A correction at one anchor moves the body's other
//! anchors too — `W(r_k, r_j)` ([`Body::inverse_mass_matrix_between`]) — so for a body with
//! more than one attachment taking the substep both exchanges are solved for all of them at
//! once, in one system of `3K` unknowns (solved through the body's six degrees of freedom, in
//! time linear in `K`): the half-way meeting,
//! `Σ_j W(r_k, r_j) q_j + w_k q_k = g_k` for the gaps `g`, and the sharing of the impulses,
//! `w_k p_k + Σ_j W(r_k, r_j) p_j = w_k J_k`. Momentum is then kept whatever the number of
//! attachments (to first order in the body's turn per substep); one at a time, each correction
//! moved the other anchors unaccounted (a free box with a rope on each side lost 0.28–82 % of
//! its momentum in 2 s with knots of 1 g to 1 kg; now below 3·10⁻⁷, `tests/avian2d.rs`). The
//! effective inverse mass each rope's solve sees at its end is how far that anchor can move
//! per unit of its pull while the others pull as hard, each the way that moves it most,
//! `Σ_j |d_k·W(r_k, r_j)·d_j|` — never heavier than any pattern of such pulls makes it (up to
//! [`EXACT_SHARING_UP_TO`] attachments on a body; beyond, the cheaper rule below). The
//! body's inverse mass at the anchor times the number of attachments, used before, made the
//! ends far lighter than the part of the body each carries: a platform swung on four parallel
//! ropes swung 4.6 % fast (now 0.09 % slow, `tests/avian3d.rs`) and a plank hung in a V from
//! one pin gained 12 % of m·g·L (now 7·10⁻⁶ of it).
//!
//! Each rope's solve still sees its body through one effective mass while the body answers
//! every pull at once, so after [`release`] a particle put back on its anchor can be as far
//! from where its rope left it as the rope moved it ([`AttachmentScratch::mismatch`]): a
//! stretch the next substep takes back, pumping energy into the body as a rope snaps taut.
//! [`External::after_relax`](super::External::after_relax) therefore repeats the exchange
//! within the substep for bodies holding several attachments: [`relump`], the ropes solved
//! by lines solved again from where the body put their ends, [`release`] — the direction each
//! end is pulled in between exchanges being the last exchange's, and for the next substep that
//! of all of them together ([`settle_pulls`]).
//!
//! An island that takes fewer substeps than the bodies (its own `IslandOverride`, raised to a
//! count that divides the bodies' so that each of its substeps ends with one of theirs:
//! [`substeps_aligned_with`](super::substeps_aligned_with); under `line_substeps`, and beside
//! an island that takes more, an attached island steps with the bodies:
//! [`Island::steps_with_bodies`](super::Island::steps_with_bodies)) compares the anchor's
//! motion over the body's substep with its particle's velocity over that time (its motion ×
//! `h_body/h`) and moves the body's anchor the same way; the velocity that correction gives
//! over the body's shorter substep is brought back to what the constraints solved for
//! (`Δx / h`, momentum `J / h`) by a velocity impulse after the body's substep
//! (`AttachmentScratch::velocity_corrections`). (Until 2026-11-26 a particle from a longer
//! substep was put on its anchor instead: a 0.1 kg knot on a spinning 1 kg box lost 12 % of
//! the momentum at 2 of the box's 8 substeps; now 3·10⁻⁵, `tests/avian2d.rs`.)
//!
//! This is the lumped-mass form of a zero-length XPBD joint between a particle and a rigid body
//! (Müller et al. 2020, "Detailed Rigid Body Simulation with Extended Position Based Dynamics",
//! §3.3), solved inside the particle solve instead of after it.

use super::Particles;
use super::bodies::Body;
use glam::{DMat3, DVec3};

mod shared;
pub use shared::EXACT_SHARING_UP_TO;

/// A particle fixed to a point of a body.
///
/// ```
/// use bevy_verlet_physics::solver::{Attachment, Body};
/// use glam::{DQuat, DVec3};
/// let attachment = Attachment::new(0, 0, DVec3::new(0.0, 0.5, 0.0));
/// let body = Body::kinematic(DVec3::ZERO, DQuat::IDENTITY, DVec3::ZERO, DVec3::ZERO);
/// assert_eq!(attachment.world_anchor(&body), DVec3::new(0.0, 0.5, 0.0));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Attachment {
    /// Particle slot.
    pub particle: u32,
    /// Index of the body in the body list.
    pub body: u32,
    /// Anchor in the body's centre-of-mass frame.
    pub anchor: DVec3,
    /// The direction the particle was last pulled in (for the effective mass).
    pub direction: DVec3,
}

impl Attachment {
    /// Attaches `particle` to `body` at `anchor` (in the body's centre-of-mass frame).
    pub fn new(particle: u32, body: u32, anchor: DVec3) -> Self {
        let direction = anchor.try_normalize().unwrap_or(DVec3::Y);
        Self {
            particle,
            body,
            anchor,
            direction,
        }
    }

    /// The anchor in the world, for the body's current pose.
    pub fn world_anchor(&self, body: &Body) -> DVec3 {
        body.position + body.rotation * self.anchor
    }

    fn previous_anchor(&self, body: &Body) -> DVec3 {
        let pose = body.previous_pose();
        pose.translation + pose.rotation * self.anchor
    }
}

/// Per-attachment state kept between [`lump`] and [`release`] (reused, no allocation once
/// grown).
#[derive(Clone, Debug, Default)]
pub struct AttachmentScratch {
    /// The particle's own inverse mass, restored by [`release`].
    own_inverse_mass: Vec<f64>,
    /// The body's effective inverse mass at the anchor along the pull direction (with other
    /// attachments on the body: [`shared`]'s).
    body_inverse_mass: Vec<f64>,
    /// Per attachment on a shared body: its pull, `I⁻¹ (r × d)` and `r × d`.
    pulls: Vec<[DVec3; 3]>,
    /// The bodies' substep over the particle's, `h_body/h` (1 when it takes every substep).
    time_ratio: Vec<f64>,
    /// Velocity impulses `(body, arm, impulse × h_body)` to apply after the bodies' substep
    /// ends ([`Body::end_substep`]): what makes a correction from a longer substep the velocity
    /// the constraints solved for (see [`release`]).
    pub velocity_corrections: Vec<(u32, DVec3, DVec3)>,
    /// Where the particle was placed before the relaxation.
    placed: Vec<DVec3>,
    /// Attachments per body that take this substep.
    per_body: Vec<u32>,
    /// Those attachments by body: body `b`'s are `order[starts[b]..starts[b + 1]]`.
    starts: Vec<u32>,
    order: Vec<usize>,
    /// A body's attachments that take this substep, and their shared system (see [`shared`]).
    group: Vec<usize>,
    shares: Vec<f64>,
    arms: Vec<DVec3>,
    /// The impulse each particle took from its constraints over this substep's exchanges (its
    /// pull direction is kept for the next substep).
    pulled: Vec<DVec3>,

    /// The last [`release`]'s largest gap between where the constraints left a lumped particle
    /// and its anchor after the body moved, and its largest move by the constraints (m).
    mismatch: (f64, f64),
}

impl AttachmentScratch {
    /// What the last [`release`] left: the largest gap between where the constraints had put
    /// a lumped particle and its anchor once the bodies moved (each particle is then put on
    /// its anchor, so the gap is left in its constraints), and the largest distance the
    /// constraints had moved one (m). One body holding one attachment leaves no gap along its
    /// pull; several leave gaps of the size of their moves, as each rope's solve saw the body
    /// through an effective mass while the body answered every pull at once.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::AttachmentScratch;
    /// assert_eq!(AttachmentScratch::default().mismatch(), (0.0, 0.0));
    /// ```
    pub fn mismatch(&self) -> (f64, f64) {
        self.mismatch
    }

    /// Where body `b`'s attachments that take this substep are in `order`.
    fn bucket(&self, b: usize) -> std::ops::Range<usize> {
        self.starts[b] as usize..self.starts[b + 1] as usize
    }
}

/// Before the relaxation: puts every due attachment's particle on its anchor (previous position
/// on the anchor's previous position, a substep of its own back) and gives it the body's share
/// of effective mass. `due`
/// gives, for a particle that takes this substep, the bodies' substep over its own (`h_body/h`:
/// 1 when its island takes every substep), and `None` for one that does not.
pub fn lump(
    attachments: &[Attachment],
    bodies: &mut [Body],
    particles: &mut Particles,
    scratch: &mut AttachmentScratch,
    due: impl Fn(usize) -> Option<f64>,
) {
    let n = attachments.len();
    scratch.own_inverse_mass.resize(n, 0.0);
    scratch.body_inverse_mass.resize(n, 0.0);
    scratch.time_ratio.resize(n, 1.0);
    scratch.placed.resize(n, DVec3::ZERO);
    scratch.pulled.clear();
    scratch.pulled.resize(n, DVec3::ZERO);
    scratch.velocity_corrections.clear();
    scratch.per_body.clear();
    scratch.per_body.resize(bodies.len(), 0);
    for (k, a) in attachments.iter().enumerate() {
        // (NaN: its particle does not take this substep.)
        scratch.time_ratio[k] = due(a.particle as usize).unwrap_or(f64::NAN);
        if !scratch.time_ratio[k].is_nan() {
            scratch.per_body[a.body as usize] += 1;
        }
        scratch.own_inverse_mass[k] = particles.inverse_mass[a.particle as usize];
    }
    sort_by_body(attachments, scratch);
    for (k, a) in attachments.iter().enumerate() {
        let body = &mut bodies[a.body as usize];
        let ratio = scratch.time_ratio[k];
        if ratio.is_nan() || scratch.per_body[a.body as usize] > 1 {
            continue;
        }
        if let Some(gap) = riding_gap(a, body, particles, ratio) {
            let r = body.rotation * a.anchor;
            let w_own = particles.inverse_mass[a.particle as usize];
            let pull = meeting_alone(body, r, w_own, gap);
            if pull.is_finite() {
                body.correct(r, -pull);
            }
        }
    }
    shared::meet_half_way(attachments, bodies, particles, scratch);
    place(attachments, bodies, particles, scratch, true);
}

/// [`lump`] for a later exchange of the same substep, after [`release`] (see
/// [`External::after_relax`](super::External::after_relax)): the particles, which `release`
/// put on their anchors, are lumped again with the body's effective mass along their last
/// exchange's pull. What `lump` did once per substep is not done again: the particles' start
/// of the substep (their previous positions) stays, riding particles are not met half way
/// again, and the velocity corrections of the earlier exchanges are kept.
pub fn relump(
    attachments: &[Attachment],
    bodies: &[Body],
    particles: &mut Particles,
    scratch: &mut AttachmentScratch,
) {
    place(attachments, bodies, particles, scratch, false);
}

/// Puts every due attachment's particle on its anchor with its lumped inverse mass (and, at
/// the `start` of the substep, its previous position on the anchor's, a substep of its own
/// back).
fn place(
    attachments: &[Attachment],
    bodies: &[Body],
    particles: &mut Particles,
    scratch: &mut AttachmentScratch,
    start: bool,
) {
    shared::prepare_pulls(attachments, bodies, scratch);
    for (k, a) in attachments.iter().enumerate() {
        let p = a.particle as usize;
        let body = &bodies[a.body as usize];
        let ratio = scratch.time_ratio[k];
        if ratio.is_nan() {
            scratch.body_inverse_mass[k] = f64::NAN; // not lumped
            continue;
        }
        let w_own = scratch.own_inverse_mass[k];
        let r = body.rotation * a.anchor;
        let w_body = if scratch.per_body[a.body as usize] > 1 {
            shared::inverse_mass(attachments, k, body, scratch)
        } else {
            body.inverse_mass_at(r, a.direction)
        };
        scratch.body_inverse_mass[k] = w_body;
        let anchor = a.world_anchor(body);
        particles.position[p] = anchor;
        if start {
            // (Its Verlet state in its own substep: the anchor's motion over the body's, scaled.)
            particles.previous[p] = anchor - (anchor - a.previous_anchor(body)) / ratio;
        }
        scratch.placed[k] = anchor;
        particles.inverse_mass[p] = if w_body > 0.0 && w_own > 0.0 {
            1.0 / (1.0 / w_own + 1.0 / w_body)
        } else {
            0.0
        };
    }
}

/// The correction `q` that meets a particle of inverse mass `w_own`, riding the anchor at arm
/// `r`, half way across `gap`: `(W(r) + w_own·I) q = gap` (the body moves by `−W(r) q`, the
/// particle by `w_own q`).
fn meeting_alone(body: &Body, r: DVec3, w_own: f64, gap: DVec3) -> DVec3 {
    let joint = body.inverse_mass_matrix_at(r) + DMat3::from_diagonal(DVec3::splat(w_own));
    joint.inverse() * gap
}

/// The body's part `p` of the impulse `J` taken at the anchor at arm `r` by a particle of mass
/// `own_mass` riding it: `p + m·W(r) p = J`.
fn share_alone(body: &Body, r: DVec3, own_mass: f64, impulse: DVec3) -> DVec3 {
    let share = DMat3::IDENTITY + body.inverse_mass_matrix_at(r) * own_mass;
    share.inverse() * impulse
}

/// Lists the attachments that take this substep by body (`scratch.starts`, `scratch.order`),
/// from the counts in `scratch.per_body`.
fn sort_by_body(attachments: &[Attachment], scratch: &mut AttachmentScratch) {
    scratch.starts.clear();
    scratch.starts.push(0);
    let mut total = 0;
    for &count in &scratch.per_body {
        total += count;
        scratch.starts.push(total);
    }
    scratch.order.clear();
    scratch.order.resize(total as usize, 0);
    // (Each body's next free place; `starts` shifted back once filled.)
    for (k, a) in attachments.iter().enumerate() {
        if !scratch.time_ratio[k].is_nan() {
            let next = &mut scratch.starts[a.body as usize];
            scratch.order[*next as usize] = k;
            *next += 1;
        }
    }
    for b in (1..scratch.starts.len()).rev() {
        scratch.starts[b] = scratch.starts[b - 1];
    }
    scratch.starts[0] = 0;
}

/// The gap between the motion of attachment `a`'s anchor over the body's substep and its
/// particle's over that time, where the two are to meet half way, as a zero-length joint: over
/// this substep the particle moved on its own path, the anchor on its body's. An offset from
/// before — a body moved by its own engine between steps — is closed by putting the particle
/// on the anchor instead, as is a particle spawned off it (meeting half way would kick the
/// body): only a gap well within the anchor's own motion (a turning path) is met, and only for
/// a movable particle on a dynamic body. From a longer substep than the body's (`ratio` =
/// `h_body/h` < 1) the particle's motion over the body's substep is its velocity's: its own
/// motion × `ratio`.
fn riding_gap(a: &Attachment, body: &Body, particles: &Particles, ratio: f64) -> Option<DVec3> {
    let p = a.particle as usize;
    let anchor_motion = a.world_anchor(body) - a.previous_anchor(body);
    let own_motion = (particles.position[p] - particles.previous[p]) * ratio;
    let gap = anchor_motion - own_motion;
    let riding = gap != DVec3::ZERO && gap.length() <= 0.5 * anchor_motion.length();
    (particles.inverse_mass[p] > 0.0 && body.is_dynamic() && riding).then_some(gap)
}

/// After the relaxation: moves each body by the impulse its attached particles took (the body
/// and the particle on its anchor share it, momentum kept), puts the particles back on the
/// anchors, and restores their masses.
pub fn release(
    attachments: &mut [Attachment],
    bodies: &mut [Body],
    particles: &mut Particles,
    scratch: &mut AttachmentScratch,
) {
    shared::release(attachments, bodies, particles, scratch);
    for (k, a) in attachments.iter_mut().enumerate() {
        let w_body = scratch.body_inverse_mass[k];
        if w_body.is_nan() || scratch.per_body[a.body as usize] > 1 {
            continue;
        }
        let p = a.particle as usize;
        let moved = particles.position[p] - scratch.placed[k];
        let w_lumped = particles.inverse_mass[p];
        if w_body > 0.0 && w_lumped > 0.0 && moved != DVec3::ZERO {
            let body = &mut bodies[a.body as usize];
            let r = body.rotation * a.anchor;
            // The impulse J the constraints gave the lumped particle, shared between the body
            // (p) and the particle riding its anchor: p + m·W p = J.
            let impulse = moved / w_lumped;
            let own_mass = 1.0 / scratch.own_inverse_mass[k];
            let p = share_alone(body, r, own_mass, impulse);
            if p.is_finite() {
                body.correct(r, p);
                // Over the body's shorter substep that correction is too fast a velocity:
                // the rest is taken back after it (`h_body/h − 1` of it).
                let ratio = scratch.time_ratio[k];
                if ratio != 1.0 {
                    let slower = (a.body, r, p * (ratio - 1.0));
                    scratch.velocity_corrections.push(slower);
                }
            }
            scratch.pulled[k] += impulse;
            a.direction = moved.normalize();
        }
    }
    let (mut gap, mut moved) = (0.0f64, 0.0f64);
    for (k, a) in attachments.iter().enumerate() {
        let p = a.particle as usize;
        particles.inverse_mass[p] = scratch.own_inverse_mass[k];
        if !scratch.body_inverse_mass[k].is_nan() {
            let anchor = a.world_anchor(&bodies[a.body as usize]);
            if scratch.per_body[a.body as usize] > 1 {
                gap = gap.max((anchor - particles.position[p]).length());
                moved = moved.max((particles.position[p] - scratch.placed[k]).length());
            }
            particles.position[p] = anchor;
        }
    }
    scratch.mismatch = (gap, moved);
}

/// After the last exchange of a substep: each attachment keeps, as the direction its particle
/// is pulled in (its effective mass in the next substep), that of everything its particle took
/// over the substep's exchanges. (Between exchanges it is the last exchange's: a later one
/// corrects what the earlier left, so its effective mass is taken along that correction.)
pub fn settle_pulls(attachments: &mut [Attachment], scratch: &AttachmentScratch) {
    for (a, pulled) in attachments.iter_mut().zip(&scratch.pulled) {
        if let Some(direction) = pulled.try_normalize() {
            a.direction = direction;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat3, DQuat};

    /// [`lump`] for an island that takes every substep.
    fn lump_every_substep(
        attachments: &[Attachment],
        bodies: &mut [Body],
        particles: &mut Particles,
        scratch: &mut AttachmentScratch,
    ) {
        lump(attachments, bodies, particles, scratch, |_| Some(1.0));
    }

    #[test]
    fn a_pull_on_the_particle_moves_the_body_anchor_with_it() {
        let mut bodies = [Body::dynamic(
            DVec3::ZERO,
            DQuat::IDENTITY,
            0.5,
            DMat3::IDENTITY * 0.1,
        )];
        let mut particles = Particles::default();
        particles.push(DVec3::ZERO, DVec3::ZERO, 10.0, 0.0, 0);
        let mut attachments = [Attachment::new(0, 0, DVec3::new(0.0, 1.0, 0.0))];
        let mut scratch = AttachmentScratch::default();
        bodies[0].begin_substep(0.1);
        lump_every_substep(&attachments, &mut bodies, &mut particles, &mut scratch);
        assert_eq!(particles.position[0], DVec3::Y);
        // Lumped: 0.1 kg particle + 2 kg body along Y (the arm is along Y: no turning).
        assert!((1.0 / particles.inverse_mass[0] - 2.1).abs() < 1e-12);
        particles.position[0].y += 0.3; // a rope pulled it up
        release(&mut attachments, &mut bodies, &mut particles, &mut scratch);
        assert!((bodies[0].position.y - 0.3).abs() < 1e-12);
        assert!((particles.position[0].y - 1.3).abs() < 1e-12);
        assert_eq!(particles.inverse_mass[0], 10.0);
    }

    #[test]
    fn a_static_body_holds_its_particle_like_a_pin() {
        let mut bodies = [Body::kinematic(
            DVec3::ZERO,
            DQuat::IDENTITY,
            DVec3::X,
            DVec3::ZERO,
        )];
        let mut particles = Particles::default();
        particles.push(DVec3::ZERO, DVec3::ZERO, 1.0, 0.0, 0);
        let mut attachments = [Attachment::new(0, 0, DVec3::ZERO)];
        let mut scratch = AttachmentScratch::default();
        bodies[0].begin_substep(0.5);
        lump_every_substep(&attachments, &mut bodies, &mut particles, &mut scratch);
        assert_eq!(particles.inverse_mass[0], 0.0);
        assert_eq!(particles.position[0], DVec3::new(0.5, 0.0, 0.0));
        assert_eq!(particles.previous[0], DVec3::ZERO);
        release(&mut attachments, &mut bodies, &mut particles, &mut scratch);
        assert_eq!(particles.inverse_mass[0], 1.0);
        assert_eq!(bodies[0].position, DVec3::new(0.5, 0.0, 0.0));
    }
}
