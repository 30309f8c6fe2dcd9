// The avian integration, shared by `avian2d` and `avian3d`: each of those modules defines the
// dimension adapters (`to_d`, `from_d`, `rotation_d`, `rotation_from_d`, `angular_d`,
// `angular_from_d`, `inverse_inertia_d`) and includes this file. No inner docs here: the
// including module documents the algorithm.

use crate::solver::contacts::overlaps;
use crate::solver::{
    Attachment, Body, ContactShape, External, ExternalCollider, GlobalSubstep, Layers, Pose,
};
use crate::{Composite, Particle, VerletState, VerletSubstepSystems, VerletSubsteps, VerletSystems};
use bevy::ecs::entity::EntityHashMap;
use bevy::prelude::*;
use glam::{DMat3, DQuat, DVec3};

/// Couples the Verlet particles with avian both ways: particles collide with avian colliders and
/// push dynamic bodies; [`BodyAttachment`]s fix particles to bodies and pull on them.
///
/// Add it after avian's `PhysicsPlugins` and [`VerletPlugin`](crate::VerletPlugin). Both step in
/// `FixedPostUpdate`: the particle step runs first (reading the bodies as avian left them at
/// the end of the previous tick, and moving proxies of them through its substeps), hands each
/// body the impulse the particles gave it, then avian steps with that impulse in the bodies'
/// velocities. Bodies lag the particles by at most one tick.
///
/// ```
/// use bevy::prelude::*;
#[doc = concat!("use ", module_name_doc!(), "::prelude::*;")]
#[doc = concat!("use bevy_verlet_physics::", module_name_doc!(), "::VerletAvianPlugin;")]
/// use bevy_verlet_physics::prelude::*;
/// let mut app = App::new();
/// app.add_plugins((MinimalPlugins, bevy::transform::TransformPlugin))
///     .add_plugins((PhysicsPlugins::default(), VerletPlugin::default(), VerletAvianPlugin));
/// app.finish();
/// app.update();
/// ```
#[derive(Debug, Default, Clone, Copy)]
pub struct VerletAvianPlugin;

/// Fixes a particle to a point of an avian rigid body, both ways: a dynamic body drags the
/// particle and the particle's constraints pull the body (with its mass and inertia); a static
/// or kinematic body carries the particle like a moving pin. Put it on the particle's entity.
/// While the body has avian's `RigidBodyDisabled` the attachment holds nothing (avian disables
/// a disabled body's joints).
///
/// ```
/// use bevy::prelude::*;
#[doc = concat!("use bevy_verlet_physics::", module_name_doc!(), "::BodyAttachment;")]
/// let mut world = World::new();
/// let crate_body = world.spawn_empty().id();
/// let attachment = BodyAttachment::new(crate_body, Default::default());
/// assert_eq!(attachment.body, crate_body);
/// ```
#[derive(Component, Reflect, Debug, Clone, Copy, PartialEq)]
#[reflect(Component, Debug, Clone)]
pub struct BodyAttachment {
    /// The rigid body (an entity with avian's `RigidBody`).
    pub body: Entity,
    /// The anchor in the body's local frame (relative to its origin, like avian's joints).
    pub anchor: Anchor,
}

impl BodyAttachment {
    /// Attaches to `body` at `anchor` (body-local).
    pub fn new(body: Entity, anchor: Anchor) -> Self {
        Self { body, anchor }
    }
}

/// Surface response of particles against avian colliders that carry no `Friction` /
/// `Restitution` of their own (with them, those are used: `dynamic_coefficient` and
/// `coefficient`).
///
/// ```
#[doc = concat!("use bevy_verlet_physics::", module_name_doc!(), "::AvianCoupling;")]
/// let coupling = AvianCoupling { friction: 0.3, ..Default::default() };
/// assert_eq!(coupling.restitution, 0.0);
/// ```
#[derive(Resource, Reflect, Debug, Clone, Copy, PartialEq)]
#[reflect(Resource, Debug, Clone)]
pub struct AvianCoupling {
    /// Coulomb friction coefficient (our `VerletCollider` convention).
    pub friction: f32,
    /// Fraction of the normal speed kept after a bounce.
    pub restitution: f32,
}

impl Default for AvianCoupling {
    fn default() -> Self {
        Self {
            friction: 0.5,
            restitution: 0.0,
        }
    }
}

/// What the coupling did in the last fixed step (for tests and overlays).
///
/// ```
#[doc = concat!("use bevy_verlet_physics::", module_name_doc!(), "::AvianCouplingStats;")]
/// assert_eq!(AvianCouplingStats::default().contacts, 0);
/// ```
#[derive(Resource, Reflect, Debug, Clone, Copy, Default, PartialEq)]
#[reflect(Resource, Debug, Clone)]
pub struct AvianCouplingStats {
    /// Bodies taking part (with an attachment or a collider near particles).
    pub bodies: usize,
    /// Colliders near particles (their bounds touch an island's bounds).
    pub colliders: usize,
    /// Attachments.
    pub attachments: usize,
    /// Particle–collider contacts resolved (summed over substeps).
    pub contacts: usize,
    /// Exchanges between bodies and the ropes tied to them beyond the first of each substep
    /// (summed over substeps): where a body holds several ropes solved by lines, they are
    /// solved again from where the body put their ends (see `solver::COUPLING_ROUNDS`).
    pub later_exchanges: usize,
}

/// avian's `Collider`, as the core's [`ContactShape`]; `inside`: what gives a triangle mesh an
/// inside (see `avian/hollow.rs`).
#[derive(Clone)]
struct AvianShape {
    collider: Collider,
    inside: MeshInside,
}

impl ContactShape for AvianShape {
    fn project(&self, pose: Pose, point: DVec3) -> (DVec3, bool) {
        // (Heightfields and oriented meshes: their inside, see `avian/hollow.rs`.)
        if let Some((surface, inside)) = project_with_inside(self, pose, point) {
            return (keep_depth(surface, point), inside);
        }
        let (surface, inside) = self.collider.project_point(
            from_d(pose.translation),
            rotation_from_d(pose.rotation),
            from_d(point),
            false,
        );
        (keep_depth(to_d(surface), point), inside)
    }

    fn cast_ray(
        &self,
        pose: Pose,
        origin: DVec3,
        direction: DVec3,
        max: f64,
    ) -> Option<(f64, DVec3)> {
        let direction = Dir::new(from_d(direction)).ok()?;
        let hit = self.collider.cast_ray(
            from_d(pose.translation),
            rotation_from_d(pose.rotation),
            from_d(origin),
            *direction,
            max as f32,
            true,
        );
        hit.map(|(t, normal)| (f64::from(t), to_d(normal)))
    }

    fn bounds(&self, pose: Pose) -> (DVec3, DVec3) {
        let aabb = self
            .collider
            .aabb(from_d(pose.translation), rotation_from_d(pose.rotation));
        full_depth(to_d(aabb.min), to_d(aabb.max))
    }
}

/// The coupled world of the current step: the core's lists and the entities behind them.
#[derive(Resource, Default)]
struct Coupled {
    external: External<AvianShape>,
    body_entities: Vec<Entity>,
    /// Each body's centre of mass in its own frame (to place its origin).
    body_centres: Vec<DVec3>,
    /// Each body's proxy as the step began (avian's state then).
    body_starts: Vec<Body>,
    body_index: EntityHashMap<u32>,
    island_bounds: Vec<(DVec3, DVec3)>,
    /// avian is paused this step.
    frozen: bool,
    /// The particle entity of each attachment (same order as the core's list).
    attached: Vec<Entity>,
    /// Per gathered collider: spawned, moved or reshaped since the last step (it wakes the
    /// sleeping islands it touches, as a moving body's colliders do).
    placed_anew: Vec<bool>,
    /// What gives each triangle mesh shape an inside (by its `Arc`, a clone kept while anything
    /// else holds it; see `avian/hollow.rs`).
    mesh_insides: MeshInsides,
    /// Per gathered collider: its bounds grown by its body's motion over the step and its margin.
    swept: Vec<(DVec3, DVec3)>,
    /// The pose and bounds of each collider gathered in the last step, and in this one.
    /// (Compared, not change ticks: avian rewrites a child collider's `Position` every step.)
    collider_poses: [EntityHashMap<(Pose, ColliderAabb)>; 2],
    /// Each attached particle's last pull direction, kept across steps (the effective mass).
    pull: EntityHashMap<DVec3>,
}

impl Plugin for VerletAvianPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<BodyAttachment>()
            .register_type::<AvianCoupling>()
            .register_type::<AvianCouplingStats>()
            .init_resource::<AvianCoupling>()
            .init_resource::<AvianCouplingStats>()
            .init_resource::<Coupled>();
        app.configure_sets(
            FixedPostUpdate,
            VerletSystems::Writeback.before(PhysicsSystems::First),
        );
        app.add_systems(
            crate::VerletSchedule,
            (
                gather
                    .after(VerletSystems::Prepare)
                    .before(VerletSystems::Substeps),
                apply_impulses
                    .after(VerletSystems::Substeps)
                    .before(VerletSystems::Writeback),
            ),
        );
        app.add_systems(
            VerletSubsteps,
            (
                before_relax
                    .after(VerletSubstepSystems::Integrate)
                    .before(VerletSubstepSystems::Relax),
                after_relax
                    .after(VerletSubstepSystems::Relax)
                    .before(VerletSubstepSystems::Constrain),
                after_constrain.after(VerletSubstepSystems::Constrain),
            ),
        );
    }
}

/// The components a rigid body contributes.
type BodyData = (
    &'static RigidBody,
    &'static Position,
    &'static Rotation,
    &'static LinearVelocity,
    &'static AngularVelocity,
    &'static ComputedMass,
    &'static ComputedAngularInertia,
    &'static ComputedCenterOfMass,
    Option<&'static GravityScale>,
    Option<&'static LockedAxes>,
);

/// The components a collider contributes.
type ColliderData = (
    Entity,
    Ref<'static, Collider>,
    &'static Position,
    &'static Rotation,
    &'static ColliderAabb,
    Option<&'static ColliderOf>,
    Option<&'static CollisionLayers>,
    Option<&'static Friction>,
    Option<&'static Restitution>,
    Option<&'static CollisionMargin>,
);

/// What a rigid body lends its colliders that have none of their own (as avian does).
type BodySurface = (Option<&'static Friction>, Option<&'static CollisionMargin>);

/// Fills the coupled world for this step: bodies with attachments, colliders whose bounds touch
/// an island's bounds (with their bodies), particle layers and materials.
#[allow(clippy::too_many_arguments)]
fn gather(
    mut coupled: ResMut<Coupled>,
    mut state: ResMut<VerletState>,
    coupling: Res<AvianCoupling>,
    config: Res<crate::VerletConfig>,
    gravity: Res<Gravity>,
    time: Res<Time>,
    physics_time: Res<Time<Physics>>,
    bodies: Query<BodyData>,
    disabled: Query<(), With<RigidBodyDisabled>>,
    surfaces: Query<BodySurface, With<RigidBody>>,
    colliders: Query<ColliderData, (Without<Sensor>, Without<ColliderDisabled>)>,
    attachments: Query<(Entity, &BodyAttachment), With<Particle>>,
    layered: Query<(Entity, &CollisionLayers, Option<&Composite>), Without<Collider>>,
    materials: Query<MaterialData, OwnMaterial>,
) {
    let (coupled, state) = (&mut *coupled, &mut *state);
    coupled.clear();
    // While avian is paused its bodies stand still: particles meet them as static shapes, and
    // no impulse is handed over.
    coupled.frozen = physics_time.is_paused();
    if !colliders.is_empty() || !attachments.is_empty() {
        let world = AvianBodies {
            bodies: &bodies,
            disabled: &disabled,
            surfaces: &surfaces,
            gravity: to_d(gravity.0),
            frozen: coupled.frozen,
        };
        gather_attachments(coupled, state, &world, &attachments);
        let step = time.delta_secs_f64();
        let h = step / f64::from(config.substeps.max(1));
        island_bounds(state, (step, h), &mut coupled.island_bounds);
        gather_colliders(coupled, &world, &colliders, &coupling, step);
        let layers = || layered.iter().map(|(e, l, c)| (e, to_layers(*l), c));
        per_slot(state, layers, Layers::default(), &mut coupled.external.particle_layers);
        let materials = || materials.iter().map(own_material);
        per_slot(state, materials, None, &mut coupled.external.particle_materials);
        wake_touched(state, coupled);
    }
    // With nothing to couple the lists stay empty and no pass runs in the substeps.
    coupled.external.begin_step(&mut state.solver);
}

/// The avian bodies and gravity, as `gather` reads them.
struct AvianBodies<'a, 'w, 's> {
    bodies: &'a Query<'w, 's, BodyData>,
    /// Bodies with avian's `RigidBodyDisabled`: avian gives their contacts and joints no
    /// response, so particles pass through their colliders and their attachments hold nothing.
    disabled: &'a Query<'w, 's, (), With<RigidBodyDisabled>>,
    surfaces: &'a Query<'w, 's, BodySurface, With<RigidBody>>,
    gravity: DVec3,
    /// avian is paused: every body is static.
    frozen: bool,
}

impl Coupled {
    /// Empties the lists (keeping their capacity).
    fn clear(&mut self) {
        self.external.bodies.clear();
        self.external.colliders.clear();
        self.external.attachments.clear();
        self.external.particle_layers.clear();
        self.external.particle_materials.clear();
        self.body_entities.clear();
        self.body_centres.clear();
        self.body_starts.clear();
        self.body_index.clear();
        self.attached.clear();
        self.placed_anew.clear();
        self.swept.clear();
        self.collider_poses.swap(0, 1);
        self.collider_poses[1].clear();
        // (Shapes nothing else holds any more.)
        let alive = |_: &usize, (shape, _): &mut (SharedShape, MeshInside)| {
            std::sync::Arc::strong_count(&shape.0) > 1
        };
        self.mesh_insides.retain(alive);
    }

    /// The index of `entity`'s proxy, adding it if it is an avian rigid body.
    fn add_body(&mut self, world: &AvianBodies, entity: Entity) -> Option<u32> {
        if let Some(&index) = self.body_index.get(&entity) {
            return Some(index);
        }
        let data = world.bodies.get(entity).ok()?;
        let index = self.external.bodies.len() as u32;
        let body = proxy(data, world.gravity);
        let body = if world.frozen {
            Body::kinematic(body.position, body.rotation, DVec3::ZERO, DVec3::ZERO)
        } else {
            body
        };
        self.external.bodies.push(body);
        self.body_starts.push(body);
        self.body_entities.push(entity);
        self.body_centres.push(to_d(data.7.0));
        self.body_index.insert(entity, index);
        Some(index)
    }

    /// A proxy for a collider without a body: static where it is.
    fn add_static(&mut self, pose: Pose) -> u32 {
        let index = self.external.bodies.len() as u32;
        let body = Body::kinematic(pose.translation, pose.rotation, DVec3::ZERO, DVec3::ZERO);
        self.external.bodies.push(body);
        self.body_starts.push(body);
        self.body_entities.push(Entity::PLACEHOLDER);
        self.body_centres.push(DVec3::ZERO);
        index
    }
}

/// Every [`BodyAttachment`] of a simulated, movable particle to an avian rigid body.
fn gather_attachments(
    coupled: &mut Coupled,
    state: &mut VerletState,
    world: &AvianBodies,
    attachments: &Query<(Entity, &BodyAttachment), With<Particle>>,
) {
    use crate::state::Problem;
    for (particle, attachment) in attachments {
        let Some(slot) = state.slot(particle) else {
            continue;
        };
        if world.disabled.contains(attachment.body) {
            continue; // (avian disables a disabled body's joints too)
        }
        if state.solver.particles.inverse_mass[slot as usize] <= 0.0 {
            state.warn(particle, Problem::Attachment, || {
                "BodyAttachment on a pinned or massless particle is ignored".to_string()
            });
            continue;
        }
        let Some(index) = coupled.add_body(world, attachment.body) else {
            state.warn(particle, Problem::Attachment, || {
                format!("BodyAttachment to {}: not an avian rigid body", attachment.body)
            });
            continue;
        };
        let centre = coupled.body_centres[index as usize];
        let anchor = to_d(attachment.anchor) - centre;
        let mut attachment = Attachment::new(slot, index, anchor);
        if let Some(&direction) = coupled.pull.get(&particle) {
            attachment.direction = direction;
        }
        coupled.external.attachments.push(attachment);
        coupled.attached.push(particle);
    }
}

/// Every collider whose bounds, grown by its body's motion over the step, touch an island.
fn gather_colliders(
    coupled: &mut Coupled,
    world: &AvianBodies,
    colliders: &Query<ColliderData, (Without<Sensor>, Without<ColliderDisabled>)>,
    coupling: &AvianCoupling,
    step: f64,
) {
    for (entity, collider, position, rotation, aabb, of, layers, friction, restitution, margin) in
        colliders
    {
        if of.is_some_and(|of| world.disabled.contains(of.body)) {
            continue;
        }
        // Friction and margin fall back to the body's, as in avian's narrow phase.
        let (body_friction, body_margin) = of
            .and_then(|of| world.surfaces.get(of.body).ok())
            .unwrap_or_default();
        let (friction, margin) = (friction.or(body_friction), margin.or(body_margin));
        let margin = f64::from(margin.map_or(0.0, |m| m.0)).max(0.0);
        let body = of.and_then(|of| world.bodies.get(of.body).ok());
        let moving = body.map(|data| proxy(data, world.gravity));
        let (lo, hi) = swept_bounds(aabb, moving.as_ref(), step);
        let (lo, hi) = (lo - margin, hi + margin);
        if !coupled.island_bounds.iter().any(|&island| overlaps((lo, hi), island)) {
            continue;
        }
        let pose = Pose {
            translation: to_d(position.0),
            rotation: rotation_d(rotation),
        };
        let index = of
            .and_then(|of| coupled.add_body(world, of.body))
            .unwrap_or_else(|| coupled.add_static(pose));
        let body_pose = coupled.external.bodies[index as usize].pose();
        // (Found once per triangle mesh shape.)
        let inside = mesh_inside(&mut coupled.mesh_insides, &collider);
        let [last, now] = &mut coupled.collider_poses;
        let placed = (pose, *aabb);
        let same = last.get(&entity).is_some_and(|(p, b)| {
            *p == pose && b.min == aabb.min && b.max == aabb.max
        });
        coupled.placed_anew.push(collider.is_added() || !same);
        coupled.swept.push((lo, hi));
        now.insert(entity, placed);
        coupled.external.colliders.push(ExternalCollider {
            shape: AvianShape {
                collider: Collider::clone(&collider),
                inside,
            },
            body: index,
            local: body_pose.relative(pose),
            restitution: f64::from(restitution.map_or(coupling.restitution, |r| r.coefficient)),
            friction: f64::from(friction.map_or(coupling.friction, |f| f.dynamic_coefficient)),
            layers: layers.map_or_else(Layers::default, |l| to_layers(*l)),
            margin,
        });
    }
}

/// One body's components, as [`BodyData`] yields them.
type BodyItem<'a> = (
    &'a RigidBody,
    &'a Position,
    &'a Rotation,
    &'a LinearVelocity,
    &'a AngularVelocity,
    &'a ComputedMass,
    &'a ComputedAngularInertia,
    &'a ComputedCenterOfMass,
    Option<&'a GravityScale>,
    Option<&'a LockedAxes>,
);

/// A body's proxy: centre-of-mass frame, velocities, mass and world inverse inertia.
fn proxy(
    (kind, position, rotation, linear, angular, mass, inertia, centre, scale, locked): BodyItem,
    gravity: DVec3,
) -> Body {
    let turn = rotation_d(rotation);
    let centre = to_d(position.0) + turn * to_d(centre.0);
    let (velocity, spin) = (to_d(linear.0), angular_d(angular));
    // `LockedAxes`: a body that may not translate freely is immovable for the particles (it
    // still moves by its velocity); one that may not turn gets no inverse inertia.
    let locked = locked.copied().unwrap_or_default();
    let (translation_locked, rotation_locked) = any_locked(&locked);
    if !kind.is_dynamic() || mass.inverse() <= 0.0 || translation_locked {
        // Static bodies do not move; kinematic and locked dynamic ones move by their velocity.
        let (velocity, spin) = if kind.is_static() {
            (DVec3::ZERO, DVec3::ZERO)
        } else {
            (velocity, spin)
        };
        return Body::kinematic(centre, turn, velocity, spin);
    }
    let inverse_inertia = if rotation_locked {
        DMat3::ZERO
    } else {
        inverse_inertia_d(inertia, turn)
    };
    let mut body = Body::dynamic(centre, turn, f64::from(mass.inverse()), inverse_inertia);
    body.velocity = velocity;
    body.angular_velocity = if rotation_locked { DVec3::ZERO } else { spin };
    body.acceleration = gravity * f64::from(scale.map_or(1.0, |s| s.0));
    body
}

/// Bounds of every island's particles, grown by their radii and what they can move in a step
/// (`step` × their velocity). One box for all if the islands are stale.
fn island_bounds(state: &VerletState, (step, h): (f64, f64), out: &mut Vec<(DVec3, DVec3)>) {
    out.clear();
    let solver = &state.solver;
    // (`x − x*` is the velocity times the substep the particle's island's state refers to.)
    let substeps_of = |slot: usize| step / solver.state_substep_of(slot as u32).unwrap_or(h);
    let bounds = |range: std::ops::Range<usize>, one_island: bool| {
        let particles = &solver.particles;
        let island_substeps = substeps_of(range.start);
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for i in range {
            // (Stale islands may each keep their own substep until they are rebuilt.)
            let substeps = if one_island { island_substeps } else { substeps_of(i) };
            let x = particles.position[i];
            let reach = particles.radius[i] + (x - particles.previous[i]).length() * substeps;
            lo = lo.min(x - reach);
            hi = hi.max(x + reach);
        }
        (lo - MARGIN, hi + MARGIN)
    };
    if solver.is_organized() {
        let islands = &solver.islands.list;
        out.extend(islands.iter().map(|island| {
            bounds(island.particles.start as usize..island.particles.end as usize, true)
        }));
    } else {
        out.push(bounds(0..solver.particles.len(), false));
    }
}

/// Slack added to bounds (m).
const MARGIN: f64 = 0.05;

/// A collider's bounds grown by how far its body can carry it in `step` seconds.
fn swept_bounds(aabb: &ColliderAabb, body: Option<&Body>, step: f64) -> (DVec3, DVec3) {
    let (lo, hi) = (to_d(aabb.min), to_d(aabb.max));
    let size = (hi - lo).length();
    let (lo, hi) = full_depth(lo, hi);
    let reach = body.map_or(0.0, |body| {
        (body.velocity.length() + body.angular_velocity.length() * size) * step
    });
    (lo - reach - MARGIN, hi + reach + MARGIN)
}

/// avian's layers as the core's bit masks.
fn to_layers(layers: CollisionLayers) -> Layers {
    Layers {
        memberships: layers.memberships.0,
        filters: layers.filters.0,
    }
}

/// Fills `out` per particle slot from values on particles or on their [`Composite`] root (a
/// particle's own wins); leaves it empty (nobody has one) when `values` yields nothing.
fn per_slot<'a, T: Copy, I>(state: &VerletState, values: impl Fn() -> I, default: T, out: &mut Vec<T>)
where
    I: Iterator<Item = (Entity, T, Option<&'a Composite>)>,
{
    out.clear();
    if values().next().is_none() {
        return;
    }
    out.resize(state.solver.particles.len(), default);
    let mut set = |entity: Entity, value: T| {
        if let Some(slot) = state.slot(entity) {
            out[slot as usize] = value;
        }
    };
    for (_, value, composite) in values() {
        for &particle in composite.map_or(&[][..], |c| &c.particles[..]) {
            set(particle, value);
        }
    }
    for (entity, value, composite) in values() {
        if composite.is_none() {
            set(entity, value);
        }
    }
}

/// A particle's or composite's own `(restitution, friction)`; the one it does not set is NaN
/// (the collider's value is used for it).
fn own_material<'a>(
    (entity, friction, restitution, composite): (
        Entity,
        Option<&Friction>,
        Option<&Restitution>,
        Option<&'a Composite>,
    ),
) -> (Entity, Option<(f64, f64)>, Option<&'a Composite>) {
    let restitution = restitution.map_or(f64::NAN, |r| f64::from(r.coefficient));
    let friction = friction.map_or(f64::NAN, |f| f64::from(f.dynamic_coefficient));
    (entity, Some((restitution, friction)), composite)
}

/// A particle's or composite's own material components.
type MaterialData = (
    Entity,
    Option<&'static Friction>,
    Option<&'static Restitution>,
    Option<&'static Composite>,
);

/// Particles and composites with their own avian `Friction` or `Restitution`.
type OwnMaterial = (
    Or<(With<Particle>, With<Composite>)>,
    Or<(With<Friction>, With<Restitution>)>,
);

/// Wakes sleeping islands that a moving body's collider reaches within the step, and islands
/// with a particle attached to a moving body.
fn wake_touched(state: &mut VerletState, coupled: &Coupled) {
    let external = &coupled.external;
    let moving = |body: &Body| body.velocity != DVec3::ZERO || body.angular_velocity != DVec3::ZERO;
    let islands = state.solver.islands.list.len();
    for index in 0..islands.min(coupled.island_bounds.len()) {
        if !state.solver.islands.list[index].asleep {
            continue;
        }
        let (lo, hi) = coupled.island_bounds[index];
        let range = state.solver.islands.list[index].particles.clone();
        // The cheap test first: only a moving or newly placed collider needs its bounds —
        // swept over the step: one that passes the island within it wakes it.
        let colliders = external.colliders.iter().zip(&coupled.placed_anew);
        let touched = colliders.zip(&coupled.swept).any(|((c, &anew), &swept)| {
            (anew || moving(&external.bodies[c.body as usize])) && overlaps(swept, (lo, hi))
        }) || external.attachments.iter().any(|a| {
            range.contains(&a.particle) && moving(&external.bodies[a.body as usize])
        });
        if touched {
            state.solver.set_asleep(index, false);
        }
    }
}

/// A body's pose, written to place it for avian's step.
type BodyPose = (
    &'static mut Position,
    &'static mut Rotation,
    Option<&'static mut Transform>,
    Has<ChildOf>,
);

/// Hands every dynamic body the impulse the particles gave it during the step, and places it
/// so that avian's step, which moves it by its new velocity, ends where the particle step's
/// proxy ended (their paths within the tick differ by `Δv·Δt/2` otherwise: a light body
/// whipped by a rope would open its attachment by centimetres).
fn apply_impulses(
    mut coupled: ResMut<Coupled>,
    mut stats: ResMut<AvianCouplingStats>,
    time: Res<Time>,
    avian_substeps: Option<Res<SubstepCount>>,
    mut bodies: ParamSet<(Query<Forces>, Query<BodyPose>)>,
) {
    let coupled = &mut *coupled;
    *stats = AvianCouplingStats {
        bodies: coupled.external.bodies.len(),
        colliders: coupled.external.colliders.len(),
        attachments: coupled.external.attachments.len(),
        contacts: coupled.external.contacts,
        later_exchanges: coupled.external.later_exchanges,
    };
    // Keep each attachment's pull direction for the next step.
    coupled.pull.clear();
    for (attachment, &particle) in coupled.external.attachments.iter().zip(&coupled.attached) {
        coupled.pull.insert(particle, attachment.direction);
    }
    let step = time.delta_secs_f64();
    // avian integrates velocity then position per substep: a constant acceleration `a` moves a
    // body by `a·Δt²·(n + 1)/(2n)` in a step of `n` substeps.
    let n = f64::from(avian_substeps.map_or(6, |s| s.0).max(1));
    let fall = step * step * (n + 1.0) / (2.0 * n);
    let moved = coupled.external.bodies.iter_mut().zip(&coupled.body_starts);
    let placed = moved.zip(&coupled.body_entities).zip(&coupled.body_centres);
    for (((body, first), &entity), &centre) in placed {
        let (linear, angular) = body.take_impulse();
        if !body.is_dynamic() || (linear == DVec3::ZERO && angular == DVec3::ZERO) {
            continue;
        }
        let (start, angular) = turned_back(body, first, (angular, step, n));
        // (Placed only with its impulse: the placement assumes the velocities it gives.)
        let mut forces = bodies.p0();
        let Ok(mut forces) = forces.get_mut(entity) else {
            continue;
        };
        forces.apply_linear_impulse(from_d(linear));
        forces.apply_angular_impulse(angular_from_d(angular));
        let mut poses = bodies.p1();
        let Ok((mut position, mut rotation, transform, has_parent)) = poses.get_mut(entity) else {
            continue;
        };
        let velocity_after_impulse = body.velocity - body.acceleration * step;
        let start_centre = body.position - velocity_after_impulse * step - body.acceleration * fall;
        let origin = start_centre - start * centre;
        position.0 = from_d(origin);
        *rotation = rotation_from_d(start.normalize());
        // In a body's first step avian places it from its `Transform` (its `Position` is new):
        // the same placement there, or avian's step starts from where it was spawned.
        if position.is_added()
            && !has_parent
            && let Some(mut transform) = transform
        {
            transform.translation = translation_from_d(origin, transform.translation);
            transform.rotation = start.normalize().as_quat();
        }
    }
}

/// Where avian's step must start `body` turning, and the angular impulse to hand it, so that
/// its step of `n` substeps over `step` ends where the proxy ended (`first`: the proxy as the
/// step began, avian's state then): a body that turns about every axis is turned back through
/// avian's own integration — the rotation by the spin, then the spin by its gyroscopic change
/// ([`Body::gyroscopic_before`]), undone substep by substep — and handed the angular impulse
/// that gives it the spin found there; for others (2D, locked rotation), or where that is not
/// finite, the rotation by the end's spin over the step, and the particles' impulse `angular`
/// as it is. (What else avian does to a spin in its step — `AngularDamping`, torques,
/// `MaxAngularSpeed`, contacts, joints — is not undone; nor does it skip the gyroscopic term
/// for a nearly isotropic body as avian does, where it is next to nothing.)
fn turned_back(body: &Body, first: &Body, (angular, step, n): (DVec3, f64, f64)) -> (DQuat, DVec3) {
    if !body.turns_freely() {
        let start = DQuat::from_scaled_axis(-body.angular_velocity * step) * body.rotation;
        return (start, angular);
    }
    let h = step / n;
    let (mut rotation, mut spin) = (body.rotation, body.angular_velocity);
    for _ in 0..n as u32 {
        rotation = (DQuat::from_scaled_axis(-spin * h) * rotation).normalize();
        spin = body.gyroscopic_before(rotation, spin, h);
    }
    let impulse = first.inverse_inertia().inverse() * (spin - first.angular_velocity);
    if !(impulse.is_finite() && rotation.is_finite()) {
        let start = DQuat::from_scaled_axis(-body.angular_velocity * step) * body.rotation;
        return (start, angular);
    }
    (rotation, impulse)
}

/// The substep the plugin is running (set by the step while the substep schedule runs).
fn current_substep(state: &VerletState) -> Option<GlobalSubstep> {
    state.substep
}

/// Substep hook: bodies predicted, attachments lumped (after integration).
fn before_relax(mut coupled: ResMut<Coupled>, mut state: ResMut<VerletState>) {
    if let Some(substep) = current_substep(&state) {
        coupled.external.before_relax(&mut state.solver, &substep);
    }
}

/// Substep hook: attachments pull their bodies (after the relaxation).
fn after_relax(mut coupled: ResMut<Coupled>, mut state: ResMut<VerletState>) {
    if current_substep(&state).is_some() {
        coupled.external.after_relax(&mut state.solver);
    }
}

/// Substep hook: contacts with avian colliders, body velocities (after the crate's colliders).
fn after_constrain(mut coupled: ResMut<Coupled>, mut state: ResMut<VerletState>) {
    if let Some(substep) = current_substep(&state) {
        coupled.external.after_constrain(&mut state.solver, &substep);
    }
}

#[cfg(test)]
mod tests {
    use super::{MARGIN, island_bounds};
    use crate::solver::{IslandSettings, StepConfig};
    use crate::state::VerletState;
    use glam::DVec3;

    /// Stale islands (a stick added since the last organize) each keep their own substep: the one
    /// box for all reaches as far as each particle moves by its own island's substep.
    #[test]
    fn stale_islands_reach_by_their_own_substeps() {
        let mut state = VerletState::default();
        let solver = &mut state.solver;
        let slow = solver.add_particle(DVec3::ZERO, 1.0);
        let fast = solver.add_particle(DVec3::new(5.0, 0.0, 0.0), 1.0);
        let fine = IslandSettings {
            substeps: 32,
            iterations: 1,
        };
        solver.island_settings.push((fast, fine));
        solver.organize();
        let config = StepConfig {
            gravity: DVec3::ZERO,
            ..StepConfig::default()
        };
        solver.step(&config);
        // 20 m/s along x for the fast particle, in its island's substep (1/64/32 s).
        let h_fast = solver.state_substep_of(fast).unwrap();
        assert!(h_fast < solver.state_substep_of(slow).unwrap());
        let at = solver.particles.position[fast as usize];
        solver.particles.previous[fast as usize] = at - DVec3::X * 20.0 * h_fast;
        let other = solver.add_particle(DVec3::new(0.0, 1.0, 0.0), 1.0);
        solver.sticks.push([slow, other], 1.0, 0.0, crate::solver::StickKind::Equal, f64::INFINITY, 0);
        assert!(!solver.is_organized());
        let (step, h) = (config.timestep, config.timestep / 8.0);
        let mut out = Vec::new();
        island_bounds(&state, (step, h), &mut out);
        let reach = out[0].1.x - MARGIN - at.x;
        // A step at 20 m/s: 0.3125 m (the old code took the first particle's substep: 0.078 m).
        assert!((reach - 20.0 * step).abs() < 1e-9, "reach {reach}");
    }
}
