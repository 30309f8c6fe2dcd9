//! [`VerletState`]: the solver core plus the bookkeeping that ties it to entities.
//!
//! Each fixed step the plugin *gathers* what users changed on components into the core's arrays
//! and *scatters* positions back once. The table from entities to array slots (and from sticks to
//! particle slots) is built only when the topology changes — particles, sticks, pins, angle
//! constraints or tethers added or removed, a stick torn — so the solver loops never look up an
//! entity. Particle state is carried over a rebuild by entity, in `f64`, so a rebuild never costs
//! accuracy.

use crate::particle::NO_SLOT;
use crate::solver::islands::permute;
use crate::solver::{GlobalSubstep, IslandSettings, Particles, Solver, consistent_previous};
use crate::{AngleConstraint, IslandOverride, Particle, Pin, PinTarget, Stick};
use bevy::ecs::entity::EntityHashMap;
use bevy::platform::collections::HashSet;
use bevy::prelude::*;
use glam::DVec3;

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
    Diverged,
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
    /// Entity → particle slot (valid between rebuilds).
    pub(crate) slots: EntityHashMap<u32>,
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
    /// Sticks torn in the last step that the ECS has not removed yet.
    pub(crate) torn_pending: usize,
    /// How many `Particle`, `Stick`, `AngleConstraint`, `Pin` and `Tethered` components existed
    /// when topology changes were last checked. A removal the removal buffers no longer hold
    /// (they are cleared every frame, and frames that run no fixed step are common above 64 fps)
    /// still shows up as a changed count.
    pub(crate) component_counts: [usize; 5],
    warned: HashSet<(Entity, Problem)>,
    scratch: Particles,
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
    /// [`Sleeping`](crate::Sleeping)). Editing a `Particle` wakes its island by itself; call
    /// this when something the solver cannot see should disturb a resting island.
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
        if let Some(slot) = self.slot(entity) {
            self.solver.wake(slot);
        }
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
    fn material(&mut self, entity: Entity, particle: &Particle) -> (f64, f64) {
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

    /// Applies a user's edit of a particle that is already in the solver.
    pub(crate) fn gather_edit(
        &mut self,
        entity: Entity,
        particle: &Particle,
        gravity: DVec3,
        dt: f64,
        h: f64,
    ) {
        let slot = particle.slot as usize;
        let pinned = self.solver.particles.inverse_mass[slot] == 0.0 && self.is_pinned(slot);
        let (mut w, radius) = self.material(entity, particle);
        if pinned {
            w = 0.0;
        }
        let acceleration = if w > 0.0 { gravity } else { DVec3::ZERO };
        if let Some((x, previous)) =
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

    /// Resolves a pin's target, or `None` (warned) if it cannot be.
    pub(crate) fn pin_target(
        &mut self,
        entity: Entity,
        pin: &Pin,
        transforms: &Query<&Transform>,
    ) -> Option<DVec3> {
        let target = match pin.target {
            PinTarget::Position(position) => position,
            PinTarget::Entity {
                entity: followed,
                offset,
            } => {
                match transforms.get(followed) {
                    Ok(transform) => transform.translation + offset,
                    Err(_) => {
                        self.warn(entity, Problem::PinTarget, || {
                        format!("Pin follows {followed}, which has no Transform; the pin holds still")
                    });
                        return None;
                    }
                }
            }
        };
        if target.is_finite() {
            Some(target.as_dvec3())
        } else {
            self.warn(entity, Problem::PinTarget, || {
                format!("Pin target {target} is not finite; the pin holds still")
            });
            None
        }
    }
}

/// What the rebuild reads of a particle entity.
pub(crate) type ParticleData = (
    Entity,
    &'static mut Particle,
    Option<&'static Pin>,
    Has<crate::Tethered>,
    Option<&'static IslandOverride>,
);

/// Inputs of a topology rebuild.
pub(crate) struct RebuildInputs {
    pub gravity: DVec3,
    pub dt: f64,
    pub h: f64,
}

impl VerletState {
    /// Rebuilds the solver's topology from the components, carrying particle state over by
    /// entity.
    pub(crate) fn rebuild(
        &mut self,
        inputs: &RebuildInputs,
        particles: &mut Query<ParticleData>,
        sticks: &mut Query<(Entity, &mut Stick)>,
        angles: &mut Query<(Entity, &mut AngleConstraint)>,
        transforms: &Query<&Transform>,
    ) {
        let old_slots = std::mem::take(&mut self.slots);
        std::mem::swap(&mut self.scratch, &mut self.solver.particles);
        let old_islands = std::mem::take(&mut self.solver.islands);
        let mut edited = Vec::new();
        let colliders = std::mem::take(&mut self.solver.colliders);
        self.solver.clear();
        self.solver.colliders = colliders;
        self.particle_entities.clear();
        self.stick_entities.clear();
        self.render_previous.clear();
        self.render_current.clear();
        self.torn_pending = 0;

        for (entity, mut particle, pin, tethered, island) in particles.iter_mut() {
            let (mut w, radius) = self.material(entity, &particle);
            let target = pin.and_then(|pin| self.pin_target(entity, pin, transforms));
            if pin.is_some() {
                w = 0.0;
            }
            let acceleration = if w > 0.0 { inputs.gravity } else { DVec3::ZERO };
            let old_state = old_slots.get(&entity).map(|&old| {
                (
                    self.scratch.position[old as usize],
                    self.scratch.previous[old as usize],
                )
            });
            if particle.is_changed() {
                edited.push(entity);
            }
            let state = match old_state {
                Some(state) if !particle.is_changed() => Some(state),
                // An edit is gathered; an invalid edit is ignored, as without a rebuild
                // (`gather_edit`): the particle keeps its last state.
                _ => self
                    .state_from_component(entity, &particle, acceleration, inputs.dt, inputs.h)
                    .or(old_state),
            };
            let Some((x, previous)) = state else {
                particle.bypass_change_detection().slot = NO_SLOT;
                continue;
            };
            let slot = self
                .solver
                .particles
                .push(x, previous, w, radius, entity.to_bits());
            self.solver.tethered.push(tethered);
            self.particle_entities.push(entity);
            // (A rejected edit leaves non-finite values in the component: show the state kept.)
            let shown = if particle.position.is_finite() && particle.previous_position.is_finite() {
                [particle.previous_position, particle.position]
            } else {
                [x.as_vec3(); 2]
            };
            self.render_previous.push(shown[0]);
            self.render_current.push(shown[1]);
            self.slots.insert(entity, slot);
            particle.bypass_change_detection().slot = slot;
            if let Some(island) = island {
                let settings = IslandSettings {
                    substeps: island.substeps.max(1),
                    iterations: island.iterations.max(1),
                };
                self.solver.island_settings.push((slot, settings));
            }
            if pin.is_some() {
                let pin_index = self.solver.pins.push(slot, target.unwrap_or(x));
                // Start from where the particle is, so a new pin drags it there smoothly.
                self.solver.pins.from[pin_index] = x;
            }
        }

        for (entity, mut stick) in sticks.iter_mut() {
            let (Some(&a), Some(&b)) = (self.slots.get(&stick.a), self.slots.get(&stick.b)) else {
                let (sa, sb) = (stick.a, stick.b);
                self.warn(entity, Problem::Endpoint, || {
                    format!("Stick endpoint {sa} or {sb} is not a simulated particle (despawned, never a Particle, or invalid); the stick is ignored")
                });
                continue;
            };
            if a == b {
                self.warn(entity, Problem::SelfStick, || {
                    "Stick connects a particle to itself; ignored".to_string()
                });
                continue;
            }
            let p = &self.solver.particles;
            let distance = (p.position[a as usize] - p.position[b as usize]).length();
            let w = p.inverse_mass[a as usize] + p.inverse_mass[b as usize];
            let rest = match stick.rest_length {
                Some(rest) if rest.is_finite() && rest >= 0.0 => rest as f64,
                None => {
                    // (Clamped: ends farther apart than f32's range would write back ∞.)
                    stick.bypass_change_detection().rest_length =
                        Some((distance as f32).min(f32::MAX));
                    distance
                }
                Some(rest) => {
                    self.warn(entity, Problem::RestLength, || {
                        format!("Stick rest length {rest} is negative or not finite; using the current distance {distance}")
                    });
                    distance
                }
            };
            let stiffness = stick.stiffness;
            let Some(compliance) = self.compliance(entity, "Stick", stiffness, w) else {
                continue;
            };
            let tear = match stick.tear_strain {
                None => f64::INFINITY,
                Some(s) if s.is_finite() && s >= 0.0 => s as f64,
                Some(s) => {
                    self.warn(entity, Problem::TearStrain, || {
                        format!("Stick tear strain {s} is negative or not finite; the stick will not tear")
                    });
                    f64::INFINITY
                }
            };
            self.solver
                .sticks
                .push([a, b], rest, compliance, stick.kind, tear, entity.to_bits());
            self.stick_entities.push(entity);
        }

        for (entity, mut angle) in angles.iter_mut() {
            let found = [angle.a, angle.b, angle.c].map(|e| self.slots.get(&e).copied());
            let [Some(a), Some(b), Some(c)] = found else {
                self.warn(entity, Problem::Endpoint, || {
                    "AngleConstraint refers to an entity that is not a simulated particle; ignored"
                        .to_string()
                });
                continue;
            };
            if a == b || b == c {
                self.warn(entity, Problem::SelfStick, || {
                    "AngleConstraint's vertex is also an arm; ignored".to_string()
                });
                continue;
            }
            let p = &self.solver.particles;
            let w = p.inverse_mass[a as usize]
                + p.inverse_mass[b as usize]
                + p.inverse_mass[c as usize];
            let stiffness = angle.stiffness;
            let Some(compliance) = self.compliance(entity, "AngleConstraint", stiffness, w) else {
                continue;
            };
            let axis = angle.axis.map(|k| k.as_dvec3());
            if let Some(k) = axis.filter(|k| k.try_normalize().is_none()) {
                self.warn(entity, Problem::Angle, || {
                    format!(
                        "AngleConstraint axis {k} is zero or not finite; using the unsigned angle"
                    )
                });
            }
            let index = self.solver.angles.push([a, b, c], 0.0, compliance, axis);
            let current = self.solver.angles.angle(index, &self.solver.particles);
            let rest = match angle.rest_angle {
                Some(rest) if rest.is_finite() => rest as f64,
                None => {
                    angle.bypass_change_detection().rest_angle = Some(current as f32);
                    current
                }
                Some(rest) => {
                    self.warn(entity, Problem::Angle, || {
                        format!("AngleConstraint rest angle {rest} is not finite; using the current angle")
                    });
                    current
                }
            };
            self.solver.angles.rest_angle[index] = rest;
        }

        self.organize(particles);
        // Unchanged islands sleep on; an edited particle wakes its island.
        self.solver
            .keep_sleep_state(&old_islands, &self.scratch.handle);
        for entity in edited {
            self.wake(entity);
        }
        self.generation += 1;
        self.dirty = false;
    }

    /// Lets the solver find islands and reorder its arrays, then follows the new order in the
    /// entity tables and the `Particle::slot` fields (also rebuilds the tethers).
    fn organize(&mut self, particles: &mut Query<ParticleData>) {
        let reorder = self.solver.organize();
        permute(&mut self.particle_entities, &reorder.particles);
        permute(&mut self.render_previous, &reorder.particles);
        permute(&mut self.render_current, &reorder.particles);
        permute(&mut self.stick_entities, &reorder.sticks);
        for (slot, &entity) in self.particle_entities.iter().enumerate() {
            self.slots.insert(entity, slot as u32);
            if let Ok((_, mut particle, ..)) = particles.get_mut(entity) {
                particle.bypass_change_detection().slot = slot as u32;
            }
        }
    }
}
