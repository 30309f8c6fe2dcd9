//! Particles against shapes the core does not know (e.g. avian colliders), reached through the
//! small [`ContactShape`] trait, with two-way response on the [`Body`] a shape belongs to.
//!
//! Per due particle and per collider whose bounds overlap the particle's swept box:
//! 1. **Sweep** (no tunnelling): if the particle moved more than half its radius in the substep
//!    *relative to the shape* and started outside, a ray from where its previous position went
//!    with the shape to its current position is cast against the shape; a hit puts the
//!    particle on the hit point, one radius out along the hit normal. A fast shape thus sweeps a
//!    particle standing in its way along, and a fast particle stops at a still shape.
//! 2. **Projection** otherwise: the closest surface point gives the normal and the penetration
//!    (inside points are pushed to the surface, outside points closer than the radius out to it).
//! 3. **Two-way split** (XPBD contact, Müller et al. 2020 §3.5): the penetration `d` is shared by
//!    generalised inverse masses — `Δλ = d / (w_p + w_b)`, the particle moves `w_p·Δλ` along the
//!    normal and the body `−Δλ` at the contact arm ([`Body::correct`]).
//! 4. **Response**, as the crate's own colliders do it ([`Collider`](super::Collider)): the
//!    particle's velocity relative to the surface point is reflected with `restitution` (above
//!    a resting speed) and loses `friction × |normal speed|` tangentially. The change is split
//!    by the same masses; the body's part is an impulse ([`Body::push`]) applied after its
//!    velocity update. Momentum is exchanged exactly: what the particle gains the body loses.
//!
//! The sweep is a straight ray in the shape's pose at the end of the substep: a shape that
//! turns fast is swept along the chord of the particle's relative path, not the arc.

use super::bodies::{Body, Pose};
use glam::{DQuat, DVec3};

/// What the core needs from a shape it does not own. Implemented by the Bevy layer (e.g. for
/// avian's `Collider`); poses are world placements of the shape.
///
/// ```
/// use bevy_verlet_physics::solver::{ContactShape, Pose};
/// use glam::DVec3;
/// /// A ball of radius 1.
/// struct Ball;
/// impl ContactShape for Ball {
///     fn project(&self, pose: Pose, point: DVec3) -> (DVec3, bool) {
///         let d = point - pose.translation;
///         (pose.translation + d.normalize_or(DVec3::Y), d.length() < 1.0)
///     }
///     fn cast_ray(&self, _: Pose, _: DVec3, _: DVec3, _: f64) -> Option<(f64, DVec3)> { None }
///     fn bounds(&self, pose: Pose) -> (DVec3, DVec3) { (pose.translation - 1.0, pose.translation + 1.0) }
/// }
/// assert!(Ball.project(Pose::IDENTITY, DVec3::new(0.5, 0.0, 0.0)).1);
/// ```
pub trait ContactShape: Sync {
    /// The surface point closest to `point` and whether `point` is inside the shape placed at
    /// `pose` (the shape as a hollow surface: inside points project to the boundary).
    fn project(&self, pose: Pose, point: DVec3) -> (DVec3, bool);
    /// The first hit of the ray `origin + t·direction` (`direction` a unit vector),
    /// `0 ≤ t ≤ max`: `t` and the outward unit normal there.
    fn cast_ray(
        &self,
        pose: Pose,
        origin: DVec3,
        direction: DVec3,
        max: f64,
    ) -> Option<(f64, DVec3)>;
    /// Axis-aligned world bounds `(min, max)` of the shape placed at `pose`.
    fn bounds(&self, pose: Pose) -> (DVec3, DVec3);
}

/// Collision layers as bit masks: two sides interact when each one's memberships meet the
/// other's filters (avian's rule).
///
/// ```
/// use bevy_verlet_physics::solver::Layers;
/// let ropes = Layers { memberships: 0b01, filters: 0b11 };
/// let ghosts = Layers { memberships: 0b10, filters: 0b10 };
/// assert!(!ropes.interacts_with(ghosts));
/// assert!(ropes.interacts_with(Layers::default()));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layers {
    /// Layers this side belongs to.
    pub memberships: u32,
    /// Layers this side interacts with.
    pub filters: u32,
}

impl Default for Layers {
    /// Layer 0, interacting with every layer.
    fn default() -> Self {
        Self {
            memberships: 1,
            filters: u32::MAX,
        }
    }
}

impl Layers {
    /// Whether the two sides collide.
    pub fn interacts_with(self, other: Layers) -> bool {
        self.memberships & other.filters != 0 && other.memberships & self.filters != 0
    }
}

/// A shape placed on a body, with its surface response.
#[derive(Clone, Debug)]
pub struct ExternalCollider<S> {
    /// The shape.
    pub shape: S,
    /// Index of the body it is part of (static shapes: an immovable body).
    pub body: u32,
    /// Placement in the body's centre-of-mass frame.
    pub local: Pose,
    /// Fraction of the normal speed kept after a bounce.
    pub restitution: f64,
    /// Coulomb friction coefficient.
    pub friction: f64,
    /// Collision layers.
    pub layers: Layers,
    /// Extra thickness around the shape (avian's `CollisionMargin`): a particle meets the
    /// surface at its radius plus this.
    pub margin: f64,
}

impl<S> ExternalCollider<S> {
    /// The collider's world placement for its body's current pose.
    pub fn pose(&self, bodies: &[Body]) -> Pose {
        bodies[self.body as usize].pose().then(self.local)
    }

    /// The collider's world placement `substeps` of its body's substeps ago — its body's last
    /// substep's motion taken back that many times, turning included (a particle whose island
    /// takes fewer substeps than the bodies spans several of theirs) — or `None` where its body
    /// did not move in its last substep.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{Body, ExternalCollider, Layers, Pose};
    /// use glam::{DQuat, DVec3};
    /// let mut bodies = [Body::kinematic(DVec3::ZERO, DQuat::IDENTITY, DVec3::X, DVec3::ZERO)];
    /// let collider = ExternalCollider {
    ///     shape: (), body: 0, local: Pose::IDENTITY, restitution: 0.0, friction: 0.0,
    ///     layers: Layers::default(), margin: 0.0,
    /// };
    /// bodies[0].begin_substep(0.5); // moves 0.5 m along x
    /// let start = collider.start_pose(&bodies, 2.0).unwrap();
    /// assert!((start.translation - DVec3::new(-0.5, 0.0, 0.0)).length() < 1e-12);
    /// ```
    pub fn start_pose(&self, bodies: &[Body], substeps: f64) -> Option<Pose> {
        let body = &bodies[self.body as usize];
        let (before, now) = (body.previous_pose(), body.pose());
        if before == now {
            return None;
        }
        if substeps == 1.0 {
            return Some(before.then(self.local));
        }
        let turn = now.rotation * before.rotation.inverse();
        let turn = if turn.w < 0.0 { -turn } else { turn }.to_scaled_axis();
        let start = Pose {
            translation: now.translation - (now.translation - before.translation) * substeps,
            rotation: (DQuat::from_scaled_axis(-turn * substeps) * now.rotation).normalize(),
        };
        Some(start.then(self.local))
    }
}

/// Whether two axis-aligned boxes `(min, max)` overlap (touching counts).
///
/// ```
/// use bevy_verlet_physics::solver::contacts::overlaps;
/// use glam::DVec3;
/// assert!(overlaps((DVec3::ZERO, DVec3::ONE), (DVec3::ONE, DVec3::splat(2.0))));
/// assert!(!overlaps((DVec3::ZERO, DVec3::ONE), (DVec3::splat(1.5), DVec3::splat(2.0))));
/// ```
pub fn overlaps((lo, hi): (DVec3, DVec3), (a, b): (DVec3, DVec3)) -> bool {
    lo.cmple(b).all() && hi.cmpge(a).all()
}

/// One particle as the contact pass sees it.
#[derive(Clone, Copy, Debug)]
pub struct ContactParticle<'a> {
    /// Collision layers.
    pub layers: Layers,
    /// Bodies it never collides with: those attached to its island (as avian does not collide
    /// bodies joined by a joint).
    pub connected: &'a [u32],
    /// `|g|·h²` of its substep (for the resting speed).
    pub gravity_step: f64,
    /// The bodies' substep over this particle's, `h_body/h` (1 when its island takes every
    /// substep, less when an `IslandOverride` or `line_substeps` gives it fewer): a body turns a positional
    /// correction into velocity over its own substep, so the particle's penetration is split as
    /// if the body were that much heavier (its velocity impulse is not), and its surface moves
    /// that much farther per particle substep; momentum and energy are kept.
    pub time_ratio: f64,
    /// The particle's own `(restitution, friction)`, if it asks for one: each is averaged with
    /// the collider's (avian's default combine rule); a NaN field leaves the collider's value.
    pub material: Option<(f64, f64)>,
}

/// Resolves the contacts of one particle against `colliders` (whose world poses for this
/// substep, and bounds swept over it — at their start pose, see [`ExternalCollider::start_pose`],
/// and now — are `placed`). Body impulses from the response are added to `impulses` as
/// `(body, arm, impulse)` (mass × displacement per substep), to apply after the bodies' velocity
/// update. Returns whether the particle touched anything.
pub fn collide_particle<S: ContactShape>(
    particle: ContactParticle,
    state: (&mut DVec3, &mut DVec3, f64, f64),
    colliders: &[ExternalCollider<S>],
    placed: &[(Pose, DVec3, DVec3)],
    bodies: &mut [Body],
    impulses: &mut Vec<(u32, DVec3, DVec3)>,
) -> bool {
    let all = 0..colliders.len().min(placed.len());
    let world = (colliders, placed, bodies, impulses);
    collide_particle_with(particle, state, all, world)
}

/// What a particle's contacts read and write: the colliders, their world poses for this
/// substep and bounds swept over it, the bodies, and the body impulses `(body, arm, impulse)` (see
/// [`collide_particle`]).
pub type ContactWorld<'w, S> = (
    &'w [ExternalCollider<S>],
    &'w [(Pose, DVec3, DVec3)],
    &'w mut [Body],
    &'w mut Vec<(u32, DVec3, DVec3)>,
);

/// [`collide_particle`] against the colliders `candidates` (indices into `colliders` and
/// `placed`, in increasing order: the ones near the particle, see
/// [`ColliderGrid`](super::collider_grid::ColliderGrid)).
pub fn collide_particle_with<S: ContactShape>(
    particle: ContactParticle,
    (position, previous, inverse_mass, radius): (&mut DVec3, &mut DVec3, f64, f64),
    candidates: impl IntoIterator<Item = usize>,
    (colliders, placed, bodies, impulses): ContactWorld<'_, S>,
) -> bool {
    if inverse_mass <= 0.0 || !position.is_finite() {
        return false;
    }
    let mut touched = false;
    let particle_radius = radius;
    for i in candidates {
        let (collider, &(pose, lo, hi)) = (&colliders[i], &placed[i]);
        // (A margin thickens the collider: the particle meets it as if that much larger.)
        let radius = particle_radius + collider.margin;
        let (swept_lo, swept_hi) = (position.min(*previous), position.max(*previous));
        if !overlaps((swept_lo - radius, swept_hi + radius), (lo, hi))
            || !particle.layers.interacts_with(collider.layers)
            || particle.connected.contains(&collider.body)
        {
            continue;
        }
        // (Only for a collider whose swept bounds it met.)
        let start = carried(*previous, collider, pose, bodies, particle.time_ratio);
        let Some((normal, depth)) = penetration(&collider.shape, pose, *position, start, radius)
        else {
            continue;
        };
        touched = true;
        let own = (collider.restitution, collider.friction);
        let combine = |mine: f64, theirs: f64| {
            if mine.is_nan() {
                theirs
            } else {
                (mine + theirs) / 2.0
            }
        };
        let material = particle
            .material
            .map_or(own, |(r, f)| (combine(r, own.0), combine(f, own.1)));
        let contact = Contact {
            normal,
            depth,
            collider,
            material,
            gravity_step: particle.gravity_step,
            time_ratio: particle.time_ratio,
        };
        resolve(
            contact,
            (position, previous, inverse_mass, radius),
            bodies,
            impulses,
        );
    }
    touched
}

/// Where a particle that was at `previous` at the start of the substep would be now had it
/// moved with `collider` (now at `pose`): the start of its motion *relative* to the collider,
/// from which a fast one is swept ([`penetration`]). A collider moving fast — a swung bat, a
/// rising platform — thus sweeps a slow particle along instead of passing it (before, only the
/// particle's own motion was swept: a thin moving collider passed particles standing still, and
/// a hollow one, such as a trimesh, left them on its far side). The collider's pose at the start
/// of the particle's substep is [`ExternalCollider::start_pose`], over the bodies' substeps the
/// particle's spans ([`substeps_spanned`]). A collider whose body did not
/// move leaves `previous` exactly as it is.
fn carried<S>(
    previous: DVec3,
    collider: &ExternalCollider<S>,
    pose: Pose,
    bodies: &[Body],
    time_ratio: f64,
) -> DVec3 {
    let Some(start) = collider.start_pose(bodies, substeps_spanned(time_ratio)) else {
        return previous;
    };
    let local = start.rotation.inverse() * (previous - start.translation);
    let carried = pose.translation + pose.rotation * local;
    if carried.is_finite() {
        carried
    } else {
        previous
    }
}

/// How many of the bodies' substeps a particle substep spans at most, for `time_ratio` (the
/// bodies' substep over the particle's, see [`ContactParticle::time_ratio`]): `1/time_ratio`
/// where the counts divide, else the next whole number — an island taking 3 substeps of the
/// bodies' 8 is due after 3, 3 and 2 of theirs.
///
/// ```
/// use bevy_verlet_physics::solver::contacts::substeps_spanned;
/// assert_eq!(substeps_spanned(2.0 / 8.0), 4.0);
/// assert_eq!(substeps_spanned(3.0 / 8.0), 3.0);
/// assert_eq!(substeps_spanned(1.0), 1.0);
/// ```
pub fn substeps_spanned(time_ratio: f64) -> f64 {
    // (A margin for rounding: 8/4 must stay 2.)
    (1.0 / time_ratio - 1e-9).ceil().max(1.0)
}

/// The contact normal and penetration of a particle of `radius` moving from `previous` to
/// `position` (relative to the shape, see [`carried`]) against `shape` at `pose`, or `None`.
fn penetration(
    shape: &impl ContactShape,
    pose: Pose,
    position: DVec3,
    previous: DVec3,
    radius: f64,
) -> Option<(DVec3, f64)> {
    let motion = position - previous;
    let distance = motion.length();
    if distance > 0.5 * radius && distance.is_finite() {
        let direction = motion / distance;
        let (_, started_inside) = shape.project(pose, previous);
        if !started_inside
            && let Some((t, normal)) = shape.cast_ray(pose, previous, direction, distance)
        {
            // Back to the hit point, one radius out: the penetration is measured along the
            // normal from the current position.
            let target = previous + direction * t + normal * radius;
            let depth = (target - position).dot(normal);
            if depth > 0.0 {
                return Some((normal, depth));
            }
        }
    }
    let (surface, inside) = shape.project(pose, position);
    let offset = position - surface;
    let gap = offset.length();
    if inside {
        let normal = (-offset).try_normalize()?;
        Some((normal, gap + radius))
    } else if gap < radius {
        let normal = offset.try_normalize()?;
        Some((normal, radius - gap))
    } else {
        None
    }
}

struct Contact<'a, S> {
    normal: DVec3,
    depth: f64,
    collider: &'a ExternalCollider<S>,
    /// `(restitution, friction)` of the pair.
    material: (f64, f64),
    gravity_step: f64,
    /// See [`ContactParticle::time_ratio`].
    time_ratio: f64,
}

/// Splits the penetration and the velocity response between the particle and the body.
fn resolve<S>(
    contact: Contact<'_, S>,
    (position, previous, w_particle, radius): (&mut DVec3, &mut DVec3, f64, f64),
    bodies: &mut [Body],
    impulses: &mut Vec<(u32, DVec3, DVec3)>,
) {
    let Contact {
        normal,
        depth,
        collider,
        material,
        gravity_step,
        time_ratio,
    } = contact;
    let body = &mut bodies[collider.body as usize];
    // The surface point: one radius minus the penetration behind the particle's centre.
    let arm = *position - normal * (radius - depth) - body.position;
    let w_body = body.inverse_mass_at(arm, normal);
    // The penetration is split as if the body were heavier by the substeps' ratio: it turns
    // its correction into velocity over its own, shorter substep. A velocity impulse it
    // answers at once, whatever its substep: there its own inverse mass.
    let share = w_particle / (w_particle + w_body);
    let lambda = depth / (w_particle + w_body * time_ratio);
    // Velocities (per particle substep) before the projection, relative to the surface point.
    let surface_motion = surface_motion(body, arm) / time_ratio;
    let velocity = *position - *previous;
    let relative = velocity - surface_motion;
    let responded = super::colliders::respond(relative, normal, material, 2.0 * gravity_step);
    let change = responded - relative;
    *position += normal * (w_particle * lambda);
    body.correct(arm, -normal * (lambda * time_ratio));
    *previous = *position - (velocity + change * share);
    if w_body > 0.0 {
        // The body's part of the velocity change, less what its positional correction already
        // puts into its velocity (−λ·n over h), so the exchange is exactly equal and opposite.
        let impulse = -change / (w_particle + w_body) + normal * lambda;
        impulses.push((collider.body, arm, impulse));
    }
}

/// How far the body's material point at `arm` moved in this substep.
fn surface_motion(body: &Body, arm: DVec3) -> DVec3 {
    let before = body.previous_pose();
    let local = body.rotation.inverse() * arm;
    body.position + arm - (before.translation + before.rotation * local)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat3, DQuat};

    /// A ball of radius 1 around the pose's translation.
    struct Ball;

    impl ContactShape for Ball {
        fn project(&self, pose: Pose, point: DVec3) -> (DVec3, bool) {
            let d = point - pose.translation;
            (
                pose.translation + d.normalize_or(DVec3::Y),
                d.length() < 1.0,
            )
        }
        fn cast_ray(&self, pose: Pose, o: DVec3, d: DVec3, max: f64) -> Option<(f64, DVec3)> {
            // |o + t·d − c| = 1, the smaller root.
            let m = o - pose.translation;
            let b = m.dot(d);
            let disc = b * b - (m.length_squared() - 1.0);
            let t = -b - disc.max(0.0).sqrt();
            (disc >= 0.0 && (0.0..=max).contains(&t))
                .then(|| (t, (o + d * t - pose.translation).normalize()))
        }
        fn bounds(&self, pose: Pose) -> (DVec3, DVec3) {
            (pose.translation - 1.0, pose.translation + 1.0)
        }
    }

    fn ball_on(body: u32) -> ExternalCollider<Ball> {
        ExternalCollider {
            shape: Ball,
            body,
            local: Pose::IDENTITY,
            restitution: 0.5,
            friction: 0.2,
            layers: Layers::default(),
            margin: 0.0,
        }
    }

    /// One substep of a particle (mass 2) moving into a ball on `body`.
    fn hit(start: DVec3, velocity: DVec3, body: Body) -> (DVec3, DVec3, Body) {
        let mut bodies = [body];
        let h = 0.01;
        bodies[0].begin_substep(h);
        let (mut x, mut previous) = (start + velocity * h, start);
        let colliders = [ball_on(0)];
        let pose = colliders[0].pose(&bodies);
        // (Bounds swept over the substep, as `External` places them.)
        let start = colliders[0].start_pose(&bodies, 1.0).unwrap_or(pose);
        let (lo, hi) = (
            pose.translation.min(start.translation),
            pose.translation.max(start.translation),
        );
        let placed = [(pose, lo - 1.0, hi + 1.0)];
        let mut impulses = Vec::new();
        let particle = ContactParticle {
            layers: Layers::default(),
            connected: &[],
            gravity_step: 0.0,
            material: None,
            time_ratio: 1.0,
        };
        let state = (&mut x, &mut previous, 0.5, 0.1);
        assert!(collide_particle(
            particle,
            state,
            &colliders,
            &placed,
            &mut bodies,
            &mut impulses
        ));
        bodies[0].end_substep(h);
        for (b, arm, j) in impulses {
            bodies[b as usize].push(arm, j / h);
        }
        ((x - previous) / h, x, bodies[0])
    }

    #[test]
    fn a_hit_exchanges_momentum_exactly() {
        let velocity = DVec3::new(20.0, 0.0, 0.0);
        let free = Body::dynamic(DVec3::ZERO, DQuat::IDENTITY, 1.0, DMat3::IDENTITY);
        let (after, _, body) = hit(DVec3::new(-1.2, 0.3, 0.0), velocity, free);
        let total = after * 2.0 + body.velocity;
        assert!((total - velocity * 2.0).length() < 1e-9, "{total}");
        assert!(body.velocity.x > 0.0 && body.angular_velocity.z != 0.0);
    }

    #[test]
    fn a_fast_particle_is_swept_onto_the_near_side() {
        // 400 m/s: 4 m in the substep, straight through a static 2 m ball without the sweep
        // (the projection alone would push it out of the far side).
        let fixed = Body::kinematic(DVec3::ZERO, DQuat::IDENTITY, DVec3::ZERO, DVec3::ZERO);
        let (_, x, _) = hit(
            DVec3::new(-2.0, 0.0, 0.0),
            DVec3::new(400.0, 0.0, 0.0),
            fixed,
        );
        assert!((x.x + 1.1).abs() < 1e-9, "the particle ended at {x}");
    }

    #[test]
    fn a_fast_collider_sweeps_a_particle_at_rest_along() {
        // A kinematic ball at 400 m/s: 4 m in the substep, from 2 m before a resting particle to
        // 2 m past it. Swept by the particle's motion alone the particle stood still and the ball
        // passed it; relative to the ball it is hit at the ball's front and bounces off it.
        let moving = Body::kinematic(
            DVec3::new(-2.0, 0.0, 0.0),
            DQuat::IDENTITY,
            DVec3::new(400.0, 0.0, 0.0),
            DVec3::ZERO,
        );
        let (velocity, x, _) = hit(DVec3::ZERO, DVec3::ZERO, moving);
        // In front of the ball (centre at 2 m, radius 1 m), one particle radius out.
        assert!((x.x - 3.1).abs() < 1e-9, "the particle ended at {x}");
        // A wall moving at V bounces a particle at rest to V·(1 + e), e = 0.5.
        assert!((velocity.x - 600.0).abs() < 1e-6, "{velocity}");
    }

    #[test]
    fn a_turning_colliders_start_is_taken_back_over_several_substeps() {
        // A collider 1 m off the axis of a body spinning at 2 rad/s: over a particle substep
        // three of the body's long, its start is the body turned back by three of its turns.
        let mut bodies = [Body::kinematic(
            DVec3::ZERO,
            DQuat::IDENTITY,
            DVec3::ZERO,
            DVec3::new(0.0, 0.0, 2.0),
        )];
        let collider = ExternalCollider {
            local: Pose {
                translation: DVec3::X,
                rotation: DQuat::IDENTITY,
            },
            ..ball_on(0)
        };
        assert_eq!(collider.start_pose(&bodies, 3.0), None);
        bodies[0].begin_substep(0.01);
        let start = collider.start_pose(&bodies, 3.0).unwrap();
        let expected = DQuat::from_rotation_z(-0.04);
        assert!(start.rotation.angle_between(expected) < 1e-12);
        assert!((start.translation - expected * DVec3::X).length() < 1e-12);
    }

    #[test]
    fn layers_that_do_not_meet_skip_the_collider() {
        let ghost = Layers {
            memberships: 2,
            filters: 2,
        };
        assert!(!ghost.interacts_with(Layers::default()));
        assert!(Layers::default().interacts_with(Layers::default()));
    }
}
