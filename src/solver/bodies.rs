//! Rigid bodies of another engine (e.g. avian), as the particle solver sees them during one
//! fixed step: a *proxy* per body that moves through the solver's substeps and takes the
//! corrections particles push on it, so that a rope holding a crate feels the crate's mass
//! within the step, not one step later.
//!
//! A proxy is an XPBD rigid body (Müller, Macklin, Chentanez, Jeschke, Kim 2020, "Detailed
//! Rigid Body Simulation with Extended Position Based Dynamics", §3.2–3.5): per substep its pose
//! is predicted from its velocity (and gravity), positional corrections `p` (mass × length)
//! applied at an arm `r` from the centre of mass move it by `w·p` and turn it by `I⁻¹(r × p)`,
//! and its velocity is then the pose change over `h`. Velocity-level impulses (restitution,
//! friction) are added after that. Every correction is also summed as an impulse, which the
//! other engine applies to its body after the particle step ([`Body::impulse`]): that engine
//! then moves the body by its own step, with the particles' pull in its velocity.
//!
//! Static and kinematic bodies have zero inverse mass: they move by their velocity only.
//! In 2D the inverse inertia has only its `zz` entry, so proxies turn about `Z` only. A body
//! that turns about every axis changes its angular velocity as it turns, keeping its angular
//! momentum (the gyroscopic term, integrated per substep as avian does it,
//! [`Body::gyroscopic_at`]), and its world inverse inertia turns with it: the proxy of a box
//! spun about a slanted axis moves as avian then moves the body.

use glam::{DMat3, DQuat, DVec3};

/// A rigid placement: translation and rotation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Translation.
    pub translation: DVec3,
    /// Rotation (a unit quaternion).
    pub rotation: DQuat,
}

impl Pose {
    /// The identity placement.
    pub const IDENTITY: Self = Self {
        translation: DVec3::ZERO,
        rotation: DQuat::IDENTITY,
    };

    /// `self ∘ local`: `local` expressed in the frame `self` places.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Pose;
    /// use glam::{DQuat, DVec3};
    /// let body = Pose { translation: DVec3::X, rotation: DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2) };
    /// let local = Pose { translation: DVec3::X, rotation: DQuat::IDENTITY };
    /// assert!((body.then(local).translation - DVec3::new(1.0, 1.0, 0.0)).length() < 1e-12);
    /// ```
    pub fn then(self, local: Pose) -> Pose {
        Pose {
            translation: self.translation + self.rotation * local.translation,
            rotation: (self.rotation * local.rotation).normalize(),
        }
    }

    /// `self⁻¹ ∘ world`: where `world` is in the frame `self` places.
    pub fn relative(self, world: Pose) -> Pose {
        let inverse = self.rotation.inverse();
        Pose {
            translation: inverse * (world.translation - self.translation),
            rotation: (inverse * world.rotation).normalize(),
        }
    }
}

/// A rigid body proxy for one fixed step (see the [module docs](self)).
///
/// ```
/// use bevy_verlet_physics::solver::Body;
/// use glam::{DMat3, DQuat, DVec3};
/// // A 2 kg body falling under gravity for one 0.1 s substep, then pushed up at its centre.
/// let mut body = Body::dynamic(DVec3::ZERO, DQuat::IDENTITY, 0.5, DMat3::IDENTITY);
/// body.acceleration = DVec3::new(0.0, -10.0, 0.0);
/// body.begin_substep(0.1);
/// assert!((body.pose().translation.y + 0.1).abs() < 1e-12);
/// body.correct(DVec3::ZERO, DVec3::new(0.0, 0.2, 0.0)); // 0.2 kg·m: moves 0.1 m up
/// body.end_substep(0.1);
/// assert!(body.velocity.length() < 1e-12);
/// assert!((body.impulse().0.y - 2.0).abs() < 1e-12); // 2 kg·m/s held it up
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Body {
    /// Centre of mass (world).
    pub position: DVec3,
    /// Orientation.
    pub rotation: DQuat,
    /// Linear velocity (m/s).
    pub velocity: DVec3,
    /// Angular velocity (rad/s, world axis).
    pub angular_velocity: DVec3,
    /// `1 / mass`; 0 for static and kinematic bodies.
    pub inverse_mass: f64,
    /// World inverse inertia about the centre of mass at the current orientation (turned with
    /// the body by [`Body::begin_substep`]); zero if immovable. See [`Body::inverse_inertia`].
    inverse_inertia: DMat3,
    /// Acceleration applied every substep (gravity × gravity scale for dynamic bodies).
    pub acceleration: DVec3,
    previous: Pose,
    /// Inverse inertia and inertia in the body's own frame (the inertia where it is invertible:
    /// a body that turns about every axis, for the gyroscopic term).
    local_inertia: (DMat3, Option<DMat3>),
    /// Positional corrections of the current substep (mass × length; linear, angular).
    pending: (DVec3, DVec3),
    linear_impulse: DVec3,
    angular_impulse: DVec3,
}

impl Body {
    /// A body that moves only by the given velocities (static: zero; kinematic).
    pub fn kinematic(position: DVec3, rotation: DQuat, velocity: DVec3, spin: DVec3) -> Self {
        Self {
            position,
            rotation,
            velocity,
            angular_velocity: spin,
            inverse_mass: 0.0,
            inverse_inertia: DMat3::ZERO,
            acceleration: DVec3::ZERO,
            previous: Pose {
                translation: position,
                rotation,
            },
            local_inertia: (DMat3::ZERO, None),
            pending: (DVec3::ZERO, DVec3::ZERO),
            linear_impulse: DVec3::ZERO,
            angular_impulse: DVec3::ZERO,
        }
    }

    /// A dynamic body at rest with the given inverse mass and world inverse inertia (at
    /// `rotation`).
    pub fn dynamic(position: DVec3, rotation: DQuat, inverse_mass: f64, inverse: DMat3) -> Self {
        let turn = DMat3::from_quat(rotation);
        let local = turn.transpose() * inverse * turn;
        // (The inertia only where it is finite: a nearly singular inverse would overflow it.)
        let inertia = (local.determinant() != 0.0).then(|| local.inverse());
        let inertia = inertia.filter(|inertia| inertia.is_finite() && local.is_finite());
        Self {
            inverse_mass,
            inverse_inertia: inverse,
            local_inertia: (local, inertia),
            ..Self::kinematic(position, rotation, DVec3::ZERO, DVec3::ZERO)
        }
    }

    /// Whether particles can move this body.
    pub fn is_dynamic(&self) -> bool {
        self.inverse_mass > 0.0
    }

    /// World inverse inertia about the centre of mass at the current orientation: the one given
    /// to [`Body::dynamic`] (in the world frame at its rotation), turned with the body each
    /// substep; zero if immovable.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Body;
    /// use glam::{DMat3, DQuat, DVec3};
    /// let inverse = DMat3::from_diagonal(DVec3::new(1.0, 2.0, 3.0));
    /// let mut body = Body::dynamic(DVec3::ZERO, DQuat::IDENTITY, 1.0, inverse);
    /// assert_eq!(body.inverse_inertia(), inverse);
    /// // A quarter turn about z swaps its x and y axes.
    /// body.angular_velocity = DVec3::Z * std::f64::consts::FRAC_PI_2;
    /// body.begin_substep(1.0);
    /// let turned = body.inverse_inertia();
    /// assert!((turned.x_axis.x - 2.0).abs() < 1e-12 && (turned.y_axis.y - 1.0).abs() < 1e-12);
    /// ```
    pub fn inverse_inertia(&self) -> DMat3 {
        self.inverse_inertia
    }

    /// The centre-of-mass frame.
    pub fn pose(&self) -> Pose {
        Pose {
            translation: self.position,
            rotation: self.rotation,
        }
    }

    /// The centre-of-mass frame at the start of the current substep.
    pub fn previous_pose(&self) -> Pose {
        self.previous
    }

    /// Generalised inverse mass for a correction along unit `n` at arm `r` (world, from the
    /// centre of mass): `w + (r × n)·I⁻¹(r × n)`.
    pub fn inverse_mass_at(&self, r: DVec3, n: DVec3) -> f64 {
        if !self.is_dynamic() {
            return 0.0;
        }
        let arm = r.cross(n);
        self.inverse_mass + arm.dot(self.inverse_inertia * arm)
    }

    /// Generalised inverse mass matrix at arm `r` (world, from the centre of mass): a
    /// correction `p` applied there moves that point by `W p` (to first order), with
    /// `W = w·I + [r]ₓᵀ I⁻¹ [r]ₓ`. Zero for immovable bodies.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Body;
    /// use glam::{DMat3, DQuat, DVec3};
    /// let body = Body::dynamic(DVec3::ZERO, DQuat::IDENTITY, 0.5, DMat3::IDENTITY * 2.0);
    /// let w = body.inverse_mass_matrix_at(DVec3::X);
    /// // Along the arm only the mass answers; across it the inertia too.
    /// assert!((w * DVec3::X - DVec3::X * 0.5).length() < 1e-12);
    /// assert!((w * DVec3::Y - DVec3::Y * 2.5).length() < 1e-12);
    /// ```
    pub fn inverse_mass_matrix_at(&self, r: DVec3) -> DMat3 {
        if !self.is_dynamic() {
            return DMat3::ZERO;
        }
        let cross = DMat3::from_cols(r.cross(DVec3::X), r.cross(DVec3::Y), r.cross(DVec3::Z));
        DMat3::from_diagonal(DVec3::splat(self.inverse_mass)) - cross * self.inverse_inertia * cross
    }

    /// How a correction `p` applied at arm `b` moves the body's point at arm `a` (to first
    /// order): `W(a, b) p` with `W(a, b) = w·I + [a]ₓᵀ I⁻¹ [b]ₓ`, so that
    /// [`Body::inverse_mass_matrix_at`] is `W(r, r)` and `W(b, a) = W(a, b)ᵀ`. Zero for
    /// immovable bodies.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Body;
    /// use glam::{DMat3, DQuat, DVec3};
    /// let body = Body::dynamic(DVec3::ZERO, DQuat::IDENTITY, 0.5, DMat3::IDENTITY * 2.0);
    /// let (a, b) = (DVec3::X, -DVec3::X);
    /// // A push along Y at one end of a rod turns it: the other end moves the other way.
    /// let w = body.inverse_mass_matrix_between(a, b);
    /// assert!((w * DVec3::Y - DVec3::Y * (0.5 - 2.0)).length() < 1e-12);
    /// assert!((w.transpose() - body.inverse_mass_matrix_between(b, a)).abs_diff_eq(DMat3::ZERO, 1e-12));
    /// ```
    pub fn inverse_mass_matrix_between(&self, a: DVec3, b: DVec3) -> DMat3 {
        if !self.is_dynamic() {
            return DMat3::ZERO;
        }
        let cross =
            |r: DVec3| DMat3::from_cols(r.cross(DVec3::X), r.cross(DVec3::Y), r.cross(DVec3::Z));
        DMat3::from_diagonal(DVec3::splat(self.inverse_mass))
            - cross(a) * self.inverse_inertia * cross(b)
    }

    /// Velocity of the body's material point at arm `r`.
    pub fn point_velocity(&self, r: DVec3) -> DVec3 {
        self.velocity + self.angular_velocity.cross(r)
    }

    /// Predicts the pose of a substep of length `h` (XPBD integration, Müller et al. 2020,
    /// Algorithm 2: the angular velocity takes the gyroscopic term, then the pose moves), and
    /// turns the world inverse inertia with the body.
    pub fn begin_substep(&mut self, h: f64) {
        self.previous = self.pose();
        self.velocity += self.acceleration * h;
        if self.is_dynamic() {
            self.gyroscopic(h);
        }
        self.position += self.velocity * h;
        self.rotation = turned(self.rotation, self.angular_velocity * h);
        if self.is_dynamic() {
            let turn = DMat3::from_quat(self.rotation);
            self.inverse_inertia = turn * self.local_inertia.0 * turn.transpose();
        }
    }

    /// Applies [`Body::gyroscopic_at`] at its own rotation.
    fn gyroscopic(&mut self, h: f64) {
        self.angular_velocity = self.gyroscopic_at(self.rotation, self.angular_velocity, h);
    }

    /// The angular velocity `spin` of this body at `rotation` after the torque-free change of
    /// a step `h`, `L' = L − h·ω × L` in its own frame, as avian integrates it (semi-implicit,
    /// `|L|` kept so that it adds no energy; Catto 2015, Jolt): an asymmetric body spinning
    /// keeps its angular momentum, not its angular velocity. `spin` as it is for a body that does
    /// not turn about every axis (2D, locked rotation): there the term is zero.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Body;
    /// use glam::{DMat3, DQuat, DVec3};
    /// let inverse = DMat3::from_diagonal(DVec3::new(1.0, 0.5, 0.25));
    /// let body = Body::dynamic(DVec3::ZERO, DQuat::IDENTITY, 1.0, inverse);
    /// let spin = DVec3::new(1.0, 2.0, 0.0);
    /// let turned = body.gyroscopic_at(DQuat::IDENTITY, spin, 0.01);
    /// // The angular momentum keeps its length.
    /// let momentum = |w: DVec3| inverse.inverse() * w;
    /// assert!((momentum(turned).length() - momentum(spin).length()).abs() < 1e-12);
    /// assert!(turned != spin);
    /// ```
    pub fn gyroscopic_at(&self, rotation: DQuat, spin: DVec3, h: f64) -> DVec3 {
        let Some(inertia) = self.local_inertia.1 else {
            return spin;
        };
        let local = rotation.inverse() * spin;
        let momentum = inertia * local;
        let turned = momentum - local.cross(momentum) * h;
        let length = turned.length_squared();
        if length == 0.0 || !length.is_finite() {
            return spin;
        }
        let kept = turned * (momentum.length_squared() / length).sqrt();
        rotation * (self.local_inertia.0 * kept)
    }

    /// The angular velocity before [`Body::gyroscopic_at`] gave `spin` at `rotation` over `h`:
    /// its step undone, by fixed-point iteration on `L = c·L' + h·ω(L) × L` (`c > 0` keeping
    /// the length), which gains a factor of about `h·|ω|` per pass, until it settles (at most
    /// [`GYROSCOPIC_PASSES`]).
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Body;
    /// use glam::{DMat3, DQuat, DVec3};
    /// let inverse = DMat3::from_diagonal(DVec3::new(1.0, 0.5, 0.25));
    /// let body = Body::dynamic(DVec3::ZERO, DQuat::IDENTITY, 1.0, inverse);
    /// let (spin, turn) = (DVec3::new(4.0, 2.0, -3.0), DQuat::from_rotation_x(0.3));
    /// let after = body.gyroscopic_at(turn, spin, 0.01);
    /// assert!((body.gyroscopic_before(turn, after, 0.01) - spin).length() < 1e-12);
    /// ```
    pub fn gyroscopic_before(&self, rotation: DQuat, spin: DVec3, h: f64) -> DVec3 {
        let Some(inertia) = self.local_inertia.1 else {
            return spin;
        };
        let after = inertia * (rotation.inverse() * spin);
        let squared = after.length_squared();
        let mut before = after;
        for _ in 0..GYROSCOPIC_PASSES {
            // The step took `L − h·ω × L` along `L'` and scaled it to `|L|`, which it kept:
            // `L = c·L' + v`, `v = h·ω × L`, with `c > 0` where `|c·L' + v| = |L'|`.
            let v = (self.local_inertia.0 * before).cross(before) * h;
            let along = after.dot(v);
            let root = along * along - squared * (v.length_squared() - squared);
            let next = after * ((root.sqrt() - along) / squared) + v;
            if !next.is_finite() {
                return spin;
            }
            let settled = (next - before).length_squared() <= 1e-30 * squared;
            before = next;
            if settled {
                break;
            }
        }
        rotation * (self.local_inertia.0 * before)
    }

    /// Whether the body turns about every axis (a dynamic 3D body without locked rotation):
    /// where [`Body::gyroscopic_at`] changes its spin.
    pub fn turns_freely(&self) -> bool {
        self.is_dynamic() && self.local_inertia.1.is_some()
    }

    /// Applies the positional correction `p` (mass × length) at arm `r`: the body moves by
    /// `w·p` and turns by `I⁻¹(r × p)`. Immovable bodies ignore it.
    pub fn correct(&mut self, r: DVec3, p: DVec3) {
        if !self.is_dynamic() {
            return;
        }
        self.position += p * self.inverse_mass;
        self.rotation = turned(self.rotation, self.inverse_inertia * r.cross(p));
        self.pending.0 += p;
        self.pending.1 += r.cross(p);
    }

    /// Applies the impulse `j` (mass × velocity) at arm `r` to the velocities (after
    /// [`Body::end_substep`]). Immovable bodies ignore it.
    pub fn push(&mut self, r: DVec3, j: DVec3) {
        if !self.is_dynamic() {
            return;
        }
        self.velocity += j * self.inverse_mass;
        self.angular_velocity += self.inverse_inertia * r.cross(j);
        self.linear_impulse += j;
        self.angular_impulse += r.cross(j);
    }

    /// The impulse particles gave the body since [`Body::take_impulse`] was last called:
    /// linear (N·s) and angular about the centre of mass (N·m·s, world axis).
    pub fn impulse(&self) -> (DVec3, DVec3) {
        (self.linear_impulse, self.angular_impulse)
    }

    /// [`Body::impulse`], resetting it.
    pub fn take_impulse(&mut self) -> (DVec3, DVec3) {
        let impulse = self.impulse();
        self.linear_impulse = DVec3::ZERO;
        self.angular_impulse = DVec3::ZERO;
        impulse
    }

    /// Ends a substep of length `h`: the velocities become the pose change over `h`.
    pub fn end_substep(&mut self, h: f64) {
        if !self.is_dynamic() || h <= 0.0 {
            return;
        }
        self.velocity = (self.position - self.previous.translation) / h;
        let turn = self.rotation * self.previous.rotation.inverse();
        let turn = if turn.w < 0.0 { -turn } else { turn };
        self.angular_velocity = turn.to_scaled_axis() / h;
        // The corrections of this substep are in the velocity now: count them as impulses.
        self.linear_impulse += self.pending.0 / h;
        self.angular_impulse += self.pending.1 / h;
        self.pending = (DVec3::ZERO, DVec3::ZERO);
    }
}

/// The most passes of [`Body::gyroscopic_before`]'s iteration, which stops where a pass
/// moves the momentum by less than 10⁻¹⁵ of itself: each gains a factor of about `h·|ω|`
/// (1/40 for a box spinning at 9 rad/s over avian's substep at 64 Hz × 6; a backward Euler
/// step instead left the knot of a rope on such a box 3.5·10⁻⁵ m off its corner after avian's
/// step, 1.7·10⁻⁷ m with this, `tests/avian3d.rs`).
pub const GYROSCOPIC_PASSES: usize = 16;

/// `rotation` turned by the rotation vector `angle` (exact exponential map, so that
/// [`Body::end_substep`] recovers the same angular velocity).
fn turned(rotation: DQuat, angle: DVec3) -> DQuat {
    if angle == DVec3::ZERO {
        return rotation;
    }
    (DQuat::from_scaled_axis(angle) * rotation).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_push_off_centre_turns_the_body() {
        let mut body = Body::dynamic(DVec3::ZERO, DQuat::IDENTITY, 1.0, DMat3::IDENTITY);
        body.push(DVec3::X, DVec3::Y);
        assert_eq!(body.velocity, DVec3::Y);
        assert_eq!(body.angular_velocity, DVec3::Z);
        assert_eq!(body.impulse(), (DVec3::Y, DVec3::Z));
        assert_eq!(body.take_impulse().0, DVec3::Y);
        assert_eq!(body.impulse().0, DVec3::ZERO);
    }

    #[test]
    fn a_spinning_body_keeps_its_spin_through_substeps() {
        let mut body = Body::dynamic(DVec3::ZERO, DQuat::IDENTITY, 1.0, DMat3::IDENTITY);
        body.angular_velocity = DVec3::new(0.0, 0.0, 2.0);
        for _ in 0..100 {
            body.begin_substep(0.01);
            body.end_substep(0.01);
        }
        assert!((body.angular_velocity.z - 2.0).abs() < 1e-9);
        let (axis, angle) = body.rotation.to_axis_angle();
        assert!((axis.z * angle - 2.0).abs() < 1e-3, "{angle}");
    }

    #[test]
    fn static_bodies_ignore_corrections() {
        let mut body = Body::kinematic(DVec3::ZERO, DQuat::IDENTITY, DVec3::ZERO, DVec3::ZERO);
        body.correct(DVec3::X, DVec3::Y);
        body.push(DVec3::X, DVec3::Y);
        body.end_substep(0.1);
        assert_eq!(body.pose(), Pose::IDENTITY);
        assert_eq!(body.impulse(), (DVec3::ZERO, DVec3::ZERO));
        assert_eq!(body.inverse_mass_at(DVec3::X, DVec3::Y), 0.0);
    }
}
