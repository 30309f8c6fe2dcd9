//! [`VerletState`]: the solver core plus the bookkeeping that ties it to entities.
//!
//! Each fixed step the plugin *gathers* what users changed on components into the core's arrays
//! and *scatters* positions back once. The table from entities to array slots (and from sticks to
//! particle slots) is built only when the topology changes — particles, sticks, pins, angle
//! constraints or tethers added or removed, a stick torn — so the solver loops never look up an
//! entity. Particle state is carried over a rebuild by entity, in `f64`, so a rebuild never costs
//! accuracy.

use crate::particle::NO_SLOT;
use crate::solver::{GlobalSubstep, Particles, Solver, consistent_previous};
use crate::{Particle, Pin, PinTarget};
use bevy::ecs::entity::{EntityHashMap, EntityHashSet};
use bevy::platform::collections::HashSet;
use bevy::prelude::*;
use bevy::transform::helper::TransformHelper;
use glam::DVec3;

mod rebuild;
pub(crate) use rebuild::{ParticleData, RebuildInputs};

/// What went wrong with a component, for warn-once bookkeeping.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Problem {
    Position,
    Mass,
    Radius,
    Endpoint,
    SelfStick,
    RestLength,
    Compliance,
    TearStrain,
    PinTarget,
    PinWithoutParticle,
    Collider,
    Angle,
    Gravity,
    Damping,
    TetherAnchors,
    SymmetricMassRatio,
    Diverged,
    #[cfg_attr(not(any(feature = "avian2d", feature = "avian3d")), allow(dead_code))]
    Attachment,
}

/// The solver core and its entity bookkeeping (a resource).
///
/// Most games never touch it; it is public for custom constraints (systems in
/// [`VerletSubstepSystems`](crate::VerletSubstepSystems) can read and change
/// [`VerletState::solver`]) and for tools that want the dense arrays.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// fn count(state: Res<VerletState>) {
///     info!("{} particles in the solver", state.solver.particles.len());
/// }
/// # bevy::ecs::system::assert_is_system(count);
/// ```
#[derive(Resource, Default)]
pub struct VerletState {
    /// The solver core.
    pub solver: Solver,
    /// Particle entity of every solver slot.
    pub(crate) particle_entities: Vec<Entity>,
    /// Stick entity of every solver stick.
    pub(crate) stick_entities: Vec<Entity>,
    /// Angle constraint entity of every solver angle constraint.
    pub(crate) angle_entities: Vec<Entity>,
    /// Entity → particle slot (valid between rebuilds).
    pub(crate) slots: EntityHashMap<u32>,
    /// Stick entity → solver stick (valid between rebuilds).
    pub(crate) stick_index: EntityHashMap<u32>,
    /// Angle constraint entity → solver angle constraint (valid between rebuilds).
    pub(crate) angle_index: EntityHashMap<u32>,
    /// Particle entities whose islands wake before the next step (kept by entity, so that a
    /// request survives a topology rebuild in the same step).
    pub(crate) wake_entities: Vec<Entity>,
    /// Force a rebuild before the next step.
    pub(crate) dirty: bool,
    /// Incremented on every rebuild (render caches key on it).
    pub(crate) generation: u64,
    /// Whether the current fixed step runs (not paused, or a requested single step).
    pub(crate) active: bool,
    /// The substep being run.
    pub(crate) substep: Option<GlobalSubstep>,
    /// Particle positions at the start and end of the last fixed step, for interpolation.
    pub(crate) render_previous: Vec<Vec3>,
    pub(crate) render_current: Vec<Vec3>,
    /// Sticks torn (or cut) since the last rebuild: still in the solver's arrays, as torn.
    pub(crate) torn_pending: usize,
    /// Stick entities torn or cut in place whose removal from the world is expected: their
    /// removal is no topology change (the solver already skips them).
    pub(crate) torn_entities: EntityHashSet,
    /// How many `Particle`, `Stick`, `AngleConstraint` and `Tethered` components existed when
    /// topology changes were last checked. A removal the removal buffers no longer hold (they
    /// are cleared every frame, and frames that run no fixed step are common above 64 fps)
    /// still shows up as a changed count.
    pub(crate) component_counts: [usize; 4],
    /// An `IslandOverride` was added, changed or removed since the last step.
    pub(crate) overrides_changed: bool,
    warned: HashSet<(Entity, Problem)>,
    scratch: Particles,
    /// The render arrays of the last topology, read while rebuilding.
    scratch_render: [Vec<Vec3>; 2],
}

impl VerletState {
    /// Particle entity in solver slot `slot`.
    pub fn particle_entity(&self, slot: usize) -> Option<Entity> {
        self.particle_entities.get(slot).copied()
    }

    /// Stick entity of solver stick `index`.
    pub fn stick_entity(&self, index: usize) -> Option<Entity> {
        self.stick_entities.get(index).copied()
    }

    /// The [`StickTorn`](crate::StickTorn) message for solver stick `index` as it is now
    /// (its entity, its particles, its midpoint and its strain), or `None` for an unknown index.
    pub fn stick_torn(&self, index: usize) -> Option<crate::StickTorn> {
        let stick = self.stick_entity(index)?;
        let solver = &self.solver;
        let [a, b] = solver.sticks.ends[index].map(|p| p as usize);
        let midpoint = (solver.particles.position[a] + solver.particles.position[b]) * 0.5;
        Some(crate::StickTorn {
            stick,
            particles: [a, b].map(|p| self.particle_entity(p).unwrap_or(Entity::PLACEHOLDER)),
            position: midpoint.as_vec3(),
            strain: solver.sticks.strain(index, &solver.particles) as f32,
        })
    }

    /// Cuts solver stick `index` in place, as a tear would (no topology rebuild: the stick
    /// stays in the solver's arrays, torn, until the next rebuild), and returns its
    /// [`StickTorn`](crate::StickTorn) message; `None` for an unknown or already torn stick.
    /// The caller takes the stick out of the world (despawns it or removes its `Stick`); that
    /// removal then costs no rebuild either.
    ///
    /// ```
    /// use bevy::prelude::*;
    /// use bevy_verlet_physics::prelude::*;
    /// // Cut every stick whose midpoint is right of x = 0 (a knife).
    /// fn knife(mut state: ResMut<VerletState>, mut commands: Commands) {
    ///     let cut: Vec<usize> = (0..state.solver.sticks.len())
    ///         .filter(|&i| state.stick_torn(i).is_some_and(|m| m.position.x > 0.0))
    ///         .collect();
    ///     for i in cut {
    ///         if let Some(message) = state.cut_stick(i) {
    ///             commands.entity(message.stick).despawn();
    ///         }
    ///     }
    /// }
    /// # bevy::ecs::system::assert_is_system(knife);
    /// ```
    pub fn cut_stick(&mut self, index: usize) -> Option<crate::StickTorn> {
        let message = self.stick_torn(index)?;
        if !self.solver.cut(index) {
            return None;
        }
        self.torn_pending += 1;
        self.release_torn(index);
        Some(message)
    }

    /// Forgets the entity of solver stick `index`, which the solver has torn: its removal from
    /// the world is expected and needs no rebuild.
    pub(crate) fn release_torn(&mut self, index: usize) {
        if let Some(entity) = self.stick_entities.get_mut(index) {
            self.stick_index.remove(entity);
            self.torn_entities.insert(*entity);
            *entity = Entity::PLACEHOLDER;
        }
    }

    /// Solver slot of a particle entity (valid until the next topology change).
    pub fn slot(&self, entity: Entity) -> Option<u32> {
        self.slots.get(&entity).copied()
    }

    /// Interpolated render position of solver slot `slot` (`fraction` as in
    /// `Time::<Fixed>::overstep_fraction`).
    pub fn render_position(&self, slot: usize, fraction: f32) -> Vec3 {
        self.render_previous[slot].lerp(self.render_current[slot], fraction)
    }

    /// Requests a topology rebuild before the next step.
    pub fn mark_dirty(&mut self) {
        self.dirty = true;
    }

    /// Wakes the island of a particle entity before the next step (see
    /// [`Sleeping`](crate::Sleeping)). Editing a `Particle`, a `Stick`, a `Pin` or anything
    /// else the solver reads wakes its island by itself; call this when something the solver
    /// cannot see should disturb a resting island. The request holds across a topology rebuild
    /// in the same step.
    ///
    /// ```
    /// use bevy::prelude::*;
    /// use bevy_verlet_physics::prelude::*;
    /// fn poke(mut state: ResMut<VerletState>, hit: Query<Entity, With<Particle>>) {
    ///     for entity in &hit {
    ///         state.wake(entity);
    ///     }
    /// }
    /// # bevy::ecs::system::assert_is_system(poke);
    /// ```
    pub fn wake(&mut self, entity: Entity) {
        self.wake_entities.push(entity);
    }

    /// Passes the wake requests made by entity to the solver (after any rebuild).
    pub(crate) fn apply_wakes(&mut self) {
        let mut entities = std::mem::take(&mut self.wake_entities);
        for &entity in &entities {
            if let Some(slot) = self.slot(entity) {
                self.solver.wake(slot);
            }
        }
        entities.clear();
        self.wake_entities = entities;
    }

    /// Wakes every island before the next step.
    pub fn wake_all(&mut self) {
        self.solver.wake_all();
    }

    /// `true` when the island of this particle entity sleeps.
    pub fn is_sleeping(&self, entity: Entity) -> bool {
        let Some(slot) = self.slot(entity) else {
            return false;
        };
        let islands = &self.solver.islands;
        islands
            .of_particle(slot)
            .is_some_and(|k| islands.list[k].asleep)
    }

    /// Index of the pin of particle `slot` (pins are kept sorted by particle).
    pub(crate) fn pin_index(&self, slot: u32) -> Option<usize> {
        self.solver.pins.particle.binary_search(&slot).ok()
    }

    /// Warns once per entity and problem.
    pub(crate) fn warn(
        &mut self,
        entity: Entity,
        problem: Problem,
        message: impl FnOnce() -> String,
    ) {
        if self.warned.insert((entity, problem)) {
            warn!("bevy_verlet_physics: {entity}: {}", message());
        }
    }

    /// Validated inverse mass and radius of a particle component (with warnings).
    pub(crate) fn material(&mut self, entity: Entity, particle: &Particle) -> (f64, f64) {
        let w = particle.inverse_mass;
        let inverse_mass = if w.is_finite() && w >= 0.0 {
            w as f64
        } else {
            self.warn(entity, Problem::Mass, || {
                format!("Particle inverse_mass {w} is not finite and ≥ 0 (mass ≤ 0 or NaN?); using mass 1")
            });
            1.0
        };
        let r = particle.radius;
        let radius = if r.is_finite() && r >= 0.0 {
            r as f64
        } else {
            self.warn(entity, Problem::Radius, || {
                format!("Particle radius {r} is not finite and ≥ 0; using 0")
            });
            0.0
        };
        (inverse_mass, radius)
    }

    /// Validated XPBD compliance of a stick or angle constraint (with warnings): NaN or negative
    /// → rigid (`Some(0)`); `+∞` (no stiffness at all) → `None`, the constraint is left out.
    fn compliance(
        &mut self,
        entity: Entity,
        what: &'static str,
        stiffness: crate::Stiffness,
        w: f64,
    ) -> Option<f64> {
        let compliance = stiffness.compliance(w);
        if compliance.is_finite() && compliance >= 0.0 {
            Some(compliance)
        } else if compliance == f64::INFINITY {
            self.warn(entity, Problem::Compliance, || {
                format!("{what} stiffness {stiffness:?} gives an infinite compliance (no stiffness); the constraint is ignored")
            });
            None
        } else {
            self.warn(entity, Problem::Compliance, || {
                format!("{what} stiffness {stiffness:?} gives compliance {compliance} (NaN or negative); using rigid")
            });
            Some(0.0)
        }
    }

    /// The solver state `(x, x*)` a component asks for: its velocity
    /// `(position − previous_position)/dt` taken as the velocity at this instant, started on
    /// the exact constant-acceleration curve. `None` (with a warning) if not finite.
    fn state_from_component(
        &mut self,
        entity: Entity,
        particle: &Particle,
        acceleration: DVec3,
        dt: f64,
        h: f64,
    ) -> Option<(DVec3, DVec3)> {
        if !(particle.position.is_finite() && particle.previous_position.is_finite()) {
            self.warn(entity, Problem::Position, || {
                format!(
                    "Particle position {} / previous {} is not finite; the value is ignored",
                    particle.position, particle.previous_position
                )
            });
            return None;
        }
        let x = particle.position.as_dvec3();
        let velocity = (x - particle.previous_position.as_dvec3()) / dt;
        Some((x, consistent_previous(x, velocity, acceleration, h)))
    }

    /// `true` when a component's `position` or `previous_position` differs from what the
    /// plugin last wrote (or accepted) for it: only such a write moves the particle.
    pub(crate) fn moved(render: [&[Vec3]; 2], slot: usize, particle: &Particle) -> bool {
        particle.previous_position != render[0][slot] || particle.position != render[1][slot]
    }

    /// Applies a user's edit of a particle that is already in the solver: a real change of
    /// `position` / `previous_position` moves it, a mass or radius change applies without
    /// touching its motion, and a write that changes nothing leaves its exact `f64` state (and
    /// its sleep) alone.
    pub(crate) fn gather_edit(
        &mut self,
        entity: Entity,
        particle: &Particle,
        gravity: DVec3,
        dt: f64,
        h: f64,
    ) {
        let slot = particle.slot as usize;
        let (mut w, radius) = self.material(entity, particle);
        if self.is_pinned(slot) {
            w = 0.0;
        }
        let p = &self.solver.particles;
        let material_changed = p.inverse_mass[slot] != w || p.radius[slot] != radius;
        // (A tree solved whole is rooted, closed and split at its immovable particles: it is
        // rebuilt when one changes sides, as when a pin is added.)
        if (p.inverse_mass[slot] <= 0.0) != (w <= 0.0) && self.tree_solved(slot as u32) {
            self.dirty = true;
        }
        let render = [&self.render_previous[..], &self.render_current[..]];
        let moved = Self::moved(render, slot, particle);
        if !moved && !material_changed {
            return;
        }
        let acceleration = if w > 0.0 { gravity } else { DVec3::ZERO };
        // (In the substep its island's state refers to: the step re-expresses it from there.)
        let h = self.solver.state_substep_of(slot as u32).unwrap_or(h);
        if moved
            && let Some((x, previous)) =
                self.state_from_component(entity, particle, acceleration, dt, h)
        {
            self.solver.particles.position[slot] = x;
            self.solver.particles.previous[slot] = previous;
            self.render_previous[slot] = particle.previous_position;
            self.render_current[slot] = particle.position;
        }
        self.solver.particles.inverse_mass[slot] = w;
        self.solver.particles.radius[slot] = radius;
        self.solver.wake(slot as u32);
    }

    fn is_pinned(&self, slot: usize) -> bool {
        self.pin_index(slot as u32).is_some()
    }

    /// `true` when `particle.slot` refers to this entity's solver slot.
    pub(crate) fn owns_slot(&self, entity: Entity, particle: &Particle) -> bool {
        particle.slot != NO_SLOT
            && self.particle_entities.get(particle.slot as usize) == Some(&entity)
    }

    /// Resolves a pin's target, or `None` (warned) if it cannot be: a position, a simulated
    /// particle's position plus the offset, or the offset mapped through an entity's up-to-date
    /// `GlobalTransform` (computed from its `Transform` and its ancestors').
    pub(crate) fn pin_target(
        &mut self,
        entity: Entity,
        pin: &Pin,
        transforms: &TransformHelper,
    ) -> Option<DVec3> {
        let target = match pin.target {
            PinTarget::Position(position) => position.as_dvec3(),
            PinTarget::Entity {
                entity: followed,
                offset,
            } => {
                if let Some(slot) = self.slot(followed) {
                    self.solver.particles.position[slot as usize] + offset.as_dvec3()
                } else {
                    match transforms.compute_global_transform(followed) {
                        Ok(global) => global.transform_point(offset).as_dvec3(),
                        Err(_) => {
                            self.warn(entity, Problem::PinTarget, || {
                                format!("Pin follows {followed}, which has no Transform (or a parent without one); the pin holds still")
                            });
                            return None;
                        }
                    }
                }
            }
        };
        if target.is_finite() {
            Some(target)
        } else {
            self.warn(entity, Problem::PinTarget, || {
                format!("Pin target {target} is not finite; the pin holds still")
            });
            None
        }
    }
}
