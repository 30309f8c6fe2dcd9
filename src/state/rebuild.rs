//! [`VerletState::rebuild`], one function per table, and the edits that apply in place without
//! a rebuild (stick and angle parameters, pins, island overrides).

use super::{Problem, VerletState};
use crate::particle::NO_SLOT;
use crate::solver::islands::permute;
use crate::solver::{IslandSettings, Islands, StickKind};
use crate::{AngleConstraint, IslandOverride, Particle, Pin, Stick};
use bevy::ecs::entity::{Entities, EntityHashMap};
use bevy::prelude::*;
use glam::DVec3;

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

/// A stick's validated solver parameters.
struct StickParams {
    rest: f64,
    compliance: f64,
    kind: StickKind,
    tear: f64,
}

/// The solver's island settings of an override (counts below 1 count as 1).
fn island_settings(island: &IslandOverride) -> IslandSettings {
    IslandSettings {
        substeps: island.substeps.max(1),
        iterations: island.iterations.max(1),
    }
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
        entities: &Entities,
    ) {
        let (old_slots, old_islands) = self.begin_rebuild();
        self.rebuild_particles(inputs, particles, &old_slots);
        self.rebuild_sticks(sticks);
        self.rebuild_angles(angles);
        self.organize(particles);
        // Unchanged islands sleep on; an edited particle wakes its island (`wake_entities`).
        self.solver
            .keep_sleep_state(&old_islands, &self.scratch.handle);
        self.forget_despawned(entities);
        self.generation += 1;
        self.dirty = false;
    }

    /// Moves the old tables aside (the particle state and render arrays into scratch) and
    /// empties the solver, keeping its colliders. Returns the old slots and islands.
    fn begin_rebuild(&mut self) -> (EntityHashMap<u32>, Islands) {
        // (States carried over meet in new islands: in one convention, velocities kept.)
        self.solver.states_to_verlet_substep();
        let old_slots = std::mem::take(&mut self.slots);
        std::mem::swap(&mut self.scratch, &mut self.solver.particles);
        std::mem::swap(&mut self.scratch_render[0], &mut self.render_previous);
        std::mem::swap(&mut self.scratch_render[1], &mut self.render_current);
        let old_islands = std::mem::take(&mut self.solver.islands);
        let colliders = std::mem::take(&mut self.solver.colliders);
        self.solver.clear();
        self.solver.colliders = colliders;
        self.particle_entities.clear();
        self.stick_entities.clear();
        self.angle_entities.clear();
        self.stick_index.clear();
        self.angle_index.clear();
        self.render_previous.clear();
        self.render_current.clear();
        self.torn_pending = 0;
        // (The rebuild reads the world as it is: removals still expected are no longer special.)
        self.torn_entities.clear();
        (old_slots, old_islands)
    }

    /// The particle table (with pins, tether flags and island overrides).
    fn rebuild_particles(
        &mut self,
        inputs: &RebuildInputs,
        particles: &mut Query<ParticleData>,
        old_slots: &EntityHashMap<u32>,
    ) {
        for (entity, mut particle, pin, tethered, island) in particles.iter_mut() {
            let (mut w, radius) = self.material(entity, &particle);
            if pin.is_some() {
                w = 0.0;
            }
            let old = old_slots.get(&entity).map(|&slot| slot as usize);
            let Some((x, previous, edited)) =
                self.carried_state(entity, &particle, old, (w, radius), inputs)
            else {
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
                let settings = island_settings(island);
                self.solver.island_settings.push((slot, settings));
                if let Some(method) = island.method {
                    self.solver.island_methods.push((slot, method.core()));
                }
            }
            if pin.is_some() {
                // Starts from where the particle is; `prepare` then sets the target, so a new
                // pin drags it there smoothly.
                self.solver.pins.push(slot, x);
            }
            if edited {
                self.wake_entities.push(entity);
            }
        }
    }

    /// The state `(x, x*)` a particle enters the new topology with, and whether it was edited:
    /// its exact old state unless its component really moved (an invalid move is ignored, as
    /// without a rebuild); a new particle's state from its component (`None` if invalid).
    fn carried_state(
        &mut self,
        entity: Entity,
        particle: &Particle,
        old: Option<usize>,
        (w, radius): (f64, f64),
        inputs: &RebuildInputs,
    ) -> Option<(DVec3, DVec3, bool)> {
        let acceleration = if w > 0.0 { inputs.gravity } else { DVec3::ZERO };
        let Some(old) = old else {
            let (x, previous) =
                self.state_from_component(entity, particle, acceleration, inputs.dt, inputs.h)?;
            return Some((x, previous, true));
        };
        let kept = (self.scratch.position[old], self.scratch.previous[old]);
        let render = [&self.scratch_render[0][..], &self.scratch_render[1][..]];
        if !Self::moved(render, old, particle) {
            let material_changed =
                self.scratch.inverse_mass[old] != w || self.scratch.radius[old] != radius;
            return Some((kept.0, kept.1, material_changed));
        }
        let (x, previous) = self
            .state_from_component(entity, particle, acceleration, inputs.dt, inputs.h)
            .unwrap_or(kept);
        Some((x, previous, true))
    }

    /// The stick table.
    fn rebuild_sticks(&mut self, sticks: &mut Query<(Entity, &mut Stick)>) {
        for (entity, mut stick) in sticks.iter_mut() {
            let stick = stick.bypass_change_detection();
            let Some(ends) = self.stick_ends(entity, stick) else {
                continue;
            };
            let Some(p) = self.stick_params(entity, stick, ends) else {
                continue;
            };
            self.solver
                .sticks
                .push(ends, p.rest, p.compliance, p.kind, p.tear, entity.to_bits());
            self.stick_entities.push(entity);
        }
    }

    /// The solver slots of a stick's ends, or `None` (warned) if it cannot be simulated.
    fn stick_ends(&mut self, entity: Entity, stick: &Stick) -> Option<[u32; 2]> {
        let (Some(a), Some(b)) = (self.slot(stick.a), self.slot(stick.b)) else {
            let (sa, sb) = (stick.a, stick.b);
            self.warn(entity, Problem::Endpoint, || {
                format!("Stick endpoint {sa} or {sb} is not a simulated particle (despawned, never a Particle, or invalid); the stick is ignored")
            });
            return None;
        };
        if a == b {
            self.warn(entity, Problem::SelfStick, || {
                "Stick connects a particle to itself; ignored".to_string()
            });
            return None;
        }
        Some([a, b])
    }

    /// A stick's validated parameters (with warnings; a missing rest length is measured and
    /// written back), or `None` when it has no stiffness at all.
    fn stick_params(
        &mut self,
        entity: Entity,
        stick: &mut Stick,
        [a, b]: [u32; 2],
    ) -> Option<StickParams> {
        let p = &self.solver.particles;
        let distance = (p.position[a as usize] - p.position[b as usize]).length();
        let w = p.inverse_mass[a as usize] + p.inverse_mass[b as usize];
        let rest = match stick.rest_length {
            Some(rest) if rest.is_finite() && rest >= 0.0 => rest as f64,
            None => {
                // (Clamped: ends farther apart than f32's range would write back ∞.)
                stick.rest_length = Some((distance as f32).min(f32::MAX));
                distance
            }
            Some(rest) => {
                self.warn(entity, Problem::RestLength, || {
                    format!("Stick rest length {rest} is negative or not finite; using the current distance {distance}")
                });
                distance
            }
        };
        let compliance = self.compliance(entity, "Stick", stick.stiffness, w)?;
        let tear = match stick.tear_strain {
            None => f64::INFINITY,
            Some(s) if s.is_finite() && s >= 0.0 => s as f64,
            Some(s) => {
                self.warn(entity, Problem::TearStrain, || {
                    format!(
                        "Stick tear strain {s} is negative or not finite; the stick will not tear"
                    )
                });
                f64::INFINITY
            }
        };
        Some(StickParams {
            rest,
            compliance,
            kind: stick.kind,
            tear,
        })
    }

    /// The angle constraint table.
    fn rebuild_angles(&mut self, angles: &mut Query<(Entity, &mut AngleConstraint)>) {
        for (entity, mut angle) in angles.iter_mut() {
            let angle = angle.bypass_change_detection();
            let Some(ends) = self.angle_ends(entity, angle) else {
                continue;
            };
            let Some((compliance, axis)) = self.angle_params(entity, angle, ends) else {
                continue;
            };
            let index = self.solver.angles.push(ends, 0.0, compliance, axis);
            self.set_rest_angle(entity, angle, index);
            self.angle_entities.push(entity);
        }
    }

    /// The solver slots of an angle constraint's particles, or `None` (warned).
    fn angle_ends(&mut self, entity: Entity, angle: &AngleConstraint) -> Option<[u32; 3]> {
        let found = [angle.a, angle.b, angle.c].map(|e| self.slot(e));
        let [Some(a), Some(b), Some(c)] = found else {
            self.warn(entity, Problem::Endpoint, || {
                "AngleConstraint refers to an entity that is not a simulated particle; ignored"
                    .to_string()
            });
            return None;
        };
        if a == b || b == c {
            self.warn(entity, Problem::SelfStick, || {
                "AngleConstraint's vertex is also an arm; ignored".to_string()
            });
            return None;
        }
        Some([a, b, c])
    }

    /// An angle constraint's compliance and axis (with warnings), or `None` without stiffness.
    fn angle_params(
        &mut self,
        entity: Entity,
        angle: &AngleConstraint,
        [a, b, c]: [u32; 3],
    ) -> Option<(f64, Option<DVec3>)> {
        let p = &self.solver.particles;
        let w =
            p.inverse_mass[a as usize] + p.inverse_mass[b as usize] + p.inverse_mass[c as usize];
        let compliance = self.compliance(entity, "AngleConstraint", angle.stiffness, w)?;
        let axis = angle.axis.map(|k| k.as_dvec3());
        if let Some(k) = axis.filter(|k| k.try_normalize().is_none()) {
            self.warn(entity, Problem::Angle, || {
                format!("AngleConstraint axis {k} is zero or not finite; using the unsigned angle")
            });
        }
        Some((compliance, axis))
    }

    /// Sets solver angle `index`'s rest angle from the component (a missing one is measured and
    /// written back).
    fn set_rest_angle(&mut self, entity: Entity, angle: &mut AngleConstraint, index: usize) {
        let current = self.solver.angles.angle(index, &self.solver.particles);
        let rest = match angle.rest_angle {
            Some(rest) if rest.is_finite() => rest as f64,
            None => {
                angle.rest_angle = Some(current as f32);
                current
            }
            Some(rest) => {
                self.warn(entity, Problem::Angle, || {
                    format!(
                        "AngleConstraint rest angle {rest} is not finite; using the current angle"
                    )
                });
                current
            }
        };
        self.solver.angles.rest_angle[index] = rest;
    }

    /// Lets the solver find islands and reorder its arrays, then follows the new order in the
    /// entity tables and the `Particle::slot` fields (also rebuilds the tethers).
    fn organize(&mut self, particles: &mut Query<ParticleData>) {
        let angles_before = self.solver.angles.particles.clone();
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
        for (index, &entity) in self.stick_entities.iter().enumerate() {
            self.stick_index.insert(entity, index as u32);
        }
        // The solver sorts angle constraints stably by the island of their vertex: the same
        // sort of the entities follows it.
        let mut new_slot = vec![0u32; reorder.particles.len()];
        for (new, &old) in reorder.particles.iter().enumerate() {
            new_slot[old as usize] = new as u32;
        }
        let islands = &self.solver.islands;
        let mut order: Vec<u32> = (0..angles_before.len() as u32).collect();
        order
            .sort_by_key(|&i| islands.of_particle(new_slot[angles_before[i as usize][1] as usize]));
        permute(&mut self.angle_entities, &order);
        for (index, &entity) in self.angle_entities.iter().enumerate() {
            debug_assert_eq!(
                self.solver.angles.particles[index],
                angles_before[order[index] as usize].map(|s| new_slot[s as usize])
            );
            self.angle_index.insert(entity, index as u32);
        }
    }

    /// Drops the warn-once entries of entities that no longer exist.
    fn forget_despawned(&mut self, entities: &Entities) {
        self.warned
            .retain(|&(entity, _)| entity == Entity::PLACEHOLDER || entities.contains(entity));
    }

    /// Applies a changed `Stick` in place (rest length, stiffness, kind, tear strain). Returns
    /// `false` when that takes a rebuild: a stick the solver does not have, new endpoints, a
    /// kind to or from `Torn`, or no stiffness at all.
    pub(crate) fn edit_stick(&mut self, entity: Entity, stick: &mut Stick) -> bool {
        let Some(&index) = self.stick_index.get(&entity) else {
            return false;
        };
        let i = index as usize;
        let ends = self.solver.sticks.ends[i];
        if [self.slot(stick.a), self.slot(stick.b)] != ends.map(Some)
            || self.solver.sticks.kind[i] == StickKind::Torn
            || stick.kind == StickKind::Torn
        {
            return false;
        }
        let Some(p) = self.stick_params(entity, stick, ends) else {
            return false;
        };
        let s = &mut self.solver.sticks;
        let flags_changed = s.kind[i] != p.kind
            || s.compliance[i] != p.compliance
            || s.tear_strain[i].is_finite() != p.tear.is_finite();
        s.rest_length[i] = p.rest;
        s.compliance[i] = p.compliance;
        s.kind[i] = p.kind;
        s.tear_strain[i] = p.tear;
        if flags_changed {
            self.refresh_stick_flags(index);
        }
        true
    }

    /// After stick `index` changed kind, compliance or tearability: the tearable list and the
    /// `rigid` flag of its colour batch.
    fn refresh_stick_flags(&mut self, index: u32) {
        let s = &mut self.solver.sticks;
        s.tearable.clear();
        for k in 0..s.len() {
            if s.tear_strain[k].is_finite() && s.kind[k] != StickKind::Torn {
                s.tearable.push(k as u32);
            }
        }
        let s = &self.solver.sticks;
        for batch in &mut self.solver.islands.batches.0 {
            if batch.sticks.contains(&index) {
                batch.rigid = batch.sticks.clone().all(|k| {
                    let k = k as usize;
                    s.kind[k] == StickKind::Equal
                        && s.compliance[k] == 0.0
                        && !s.tear_strain[k].is_finite()
                });
            }
        }
    }

    /// Applies a changed `AngleConstraint` in place (rest angle, stiffness, axis); `false` when
    /// that takes a rebuild (one the solver does not have, new particles, no stiffness).
    pub(crate) fn edit_angle(&mut self, entity: Entity, angle: &mut AngleConstraint) -> bool {
        let Some(&index) = self.angle_index.get(&entity) else {
            return false;
        };
        let i = index as usize;
        let ends = self.solver.angles.particles[i];
        if [angle.a, angle.b, angle.c].map(|e| self.slot(e)) != ends.map(Some) {
            return false;
        }
        let Some((compliance, axis)) = self.angle_params(entity, angle, ends) else {
            return false;
        };
        self.solver.angles.compliance[i] = compliance;
        self.solver.angles.axis[i] = axis;
        self.set_rest_angle(entity, angle, i);
        true
    }

    /// Pins simulated particle `slot` in place (it starts where it is; `prepare` sets the
    /// target). `false` when that takes a rebuild (tethers hang on pins).
    pub(crate) fn add_pin(&mut self, slot: u32) -> bool {
        if self.solver.tethered.contains(&true) {
            return false;
        }
        // A tree solved whole is rooted at its pin, its other pins close loops or split it (see
        // `solver::tree`): another pin changes how.
        if self.tree_solved(slot) {
            return false;
        }
        let organized = self.solver.is_organized();
        let x = self.solver.particles.position[slot as usize];
        let pins = &mut self.solver.pins;
        let index = pins.particle.partition_point(|&p| p < slot);
        pins.particle.insert(index, slot);
        pins.from.insert(index, x);
        pins.to.insert(index, x);
        self.solver.particles.inverse_mass[slot as usize] = 0.0;
        self.shift_pin_ranges(slot, organized, true);
        self.solver.wake(slot);
        true
    }

    /// Unpins solver pin `index` in place, giving its particle inverse mass `w` back (it keeps
    /// the pin's last velocity). `false` when that takes a rebuild (tethers; a tree-solved
    /// island held by three or more immovable particles, [`VerletState::tree_held_thrice`]:
    /// split at them, the parts would move the particle one by one).
    pub(crate) fn remove_pin(&mut self, index: usize, w: f64) -> bool {
        if self.solver.tethered.contains(&true) {
            return false;
        }
        let split = self
            .solver
            .pins
            .particle
            .get(index)
            .is_some_and(|&slot| self.tree_held_thrice(slot));
        if split {
            return false;
        }
        let organized = self.solver.is_organized();
        let pins = &mut self.solver.pins;
        let slot = pins.particle.remove(index);
        pins.from.remove(index);
        pins.to.remove(index);
        self.solver.particles.inverse_mass[slot as usize] = w;
        self.shift_pin_ranges(slot, organized, false);
        self.solver.wake(slot);
        true
    }

    /// `true` when particle `slot`'s island is solved as trees (see `solver::tree`).
    pub(crate) fn tree_solved(&self, slot: u32) -> bool {
        let islands = &self.solver.islands;
        islands
            .of_particle(slot)
            .is_some_and(|k| !islands.list[k].trees.is_empty())
    }

    /// `true` when particle `slot`'s island is solved as trees and holds three or more
    /// immovable particles (pins or weightless particles): it is split at them (see
    /// `solver::tree`), so taking a pin away takes a rebuild.
    pub(crate) fn tree_held_thrice(&self, slot: u32) -> bool {
        let islands = &self.solver.islands;
        let w = &self.solver.particles.inverse_mass;
        self.tree_solved(slot)
            && islands.of_particle(slot).is_some_and(|k| {
                let held = islands.list[k].particles.clone();
                held.filter(|&p| w[p as usize] <= 0.0).count() >= 3
            })
    }

    /// Follows a pin added to (`grow`) or removed from particle `slot` in the islands' pin
    /// ranges (pins are sorted by particle, islands by slot).
    fn shift_pin_ranges(&mut self, slot: u32, organized: bool, grow: bool) {
        if !organized {
            return; // the solver treats everything as one island until the next rebuild
        }
        let shift = |x: &mut u32| {
            if grow {
                *x += 1;
            } else {
                *x -= 1;
            }
        };
        for island in &mut self.solver.islands.list.0 {
            if island.particles.start > slot {
                shift(&mut island.pins.start);
                shift(&mut island.pins.end);
            } else if island.particles.contains(&slot) {
                shift(&mut island.pins.end);
            }
        }
        self.solver.islands.signature = self.solver.signature();
    }

    /// Reads every `IslandOverride` again (one was added, changed or removed) and resolves the
    /// islands' settings, as a rebuild does.
    pub(crate) fn refresh_island_settings<'a>(
        &mut self,
        overrides: impl Iterator<Item = (Entity, &'a IslandOverride)>,
    ) {
        self.solver.island_settings.clear();
        for (entity, island) in overrides {
            if let Some(slot) = self.slot(entity) {
                let settings = island_settings(island);
                self.solver.island_settings.push((slot, settings));
            }
        }
        let islands = &mut self.solver.islands;
        for island in &mut islands.list.0 {
            island.settings = None;
        }
        for &(slot, settings) in &self.solver.island_settings {
            if let Some(k) = islands.of_particle(slot) {
                let island = &mut islands.list.0[k];
                island.settings = Some(island.settings.map_or(settings, |s| s.max(settings)));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::prelude::*;
    use bevy::prelude::*;
    use bevy::time::TimeUpdateStrategy;

    /// Warn-once entries of despawned entities are dropped at the next rebuild (before: 50
    /// sticks with a missing endpoint left 50 entries behind forever).
    #[test]
    fn warnings_of_despawned_entities_are_forgotten() {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, VerletPlugin::default()))
            .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
        app.update();
        let world = app.world_mut();
        let a = world.spawn(Particle::new(Vec3::ZERO)).id();
        let sticks: Vec<Entity> = (0..50)
            .map(|_| world.spawn(Stick::new(a, Entity::PLACEHOLDER)).id())
            .collect();
        app.update();
        let warned = |app: &App| app.world().resource::<VerletState>().warned.len();
        assert_eq!(warned(&app), 50);
        for stick in sticks {
            app.world_mut().despawn(stick);
        }
        app.update();
        assert_eq!(warned(&app), 0);
    }
}
