//! Another engine's rigid bodies and colliders inside the particle step: the proxies
//! ([`Body`]), the particles attached to them ([`Attachment`]) and the colliders particles meet
//! ([`ExternalCollider`]), run at three points of every substep:
//!
//! ```text
//! integrate → before_relax (bodies predicted, attachments lumped)
//!           → relax × N
//!           → after_relax (attachments hand their pull to the bodies)
//!           → constrain (the crate's colliders)
//!           → after_constrain (contacts with external colliders, body velocities, impulses)
//! ```
//!
//! After the step, [`Body::take_impulse`] on each body gives what the particles did to it; the
//! other engine applies that impulse and steps its bodies (see the avian integration).
//! A scene without bodies pays nothing: every pass returns at once when its list is empty.

use super::attachments::{AttachmentScratch, lump, release, relump, settle_pulls};
use super::bodies::{Body, Pose};
use super::collider_grid::ColliderGrid;
use super::contacts::{
    ContactParticle, ContactShape, ExternalCollider, Layers, collide_particle_with,
    substeps_spanned,
};
use super::{Attachment, Executor, GlobalSubstep, Method, Solver, StepConfig, Substep};
use glam::DVec3;
use std::ops::Range;

/// The most exchanges between bodies and the ropes attached to them in a substep (see
/// [`External::after_relax`]): each one after the first solves the attached ropes again
/// from where the bodies put their ends.
///
/// ```
/// assert_eq!(bevy_verlet_physics::solver::COUPLING_ROUNDS, 4);
/// ```
pub const COUPLING_ROUNDS: u32 = 4;

/// The exchanges between bodies and their ropes in a substep stop once no attached particle
/// is farther from its anchor than this fraction of the largest move the first exchange's
/// constraints gave one (see [`External::after_relax`]).
///
/// ```
/// assert_eq!(bevy_verlet_physics::solver::COUPLING_TOLERANCE, 0.01);
/// ```
pub const COUPLING_TOLERANCE: f64 = 0.01;

/// The exchanges between bodies and their ropes in a substep go on only while each cuts the
/// gap between the attached particles and their anchors to this fraction of the last or less
/// (see [`External::after_relax`]). Where they converge slowly — a body snapped taut on ropes
/// that hold it from several sides — each further exchange pulled the body on by about as much
/// again: in scratch scans of 140 kicked bodies on 2–4 ropes, going on while the gap merely
/// shrank left a body's energy up to 2.6 % of `m·g·2 m` above its value after the kick, and
/// this fraction 0.96 % (see `report/limitations.md`).
///
/// ```
/// assert_eq!(bevy_verlet_physics::solver::COUPLING_CONTRACTION, 0.3);
/// ```
pub const COUPLING_CONTRACTION: f64 = 0.3;

/// Bodies, attachments and colliders of another engine for one fixed step (see the
/// [module docs](self)). The Bevy layer fills the public lists before the step.
///
/// ```
/// use bevy_verlet_physics::solver::*;
/// use glam::{DMat3, DQuat, DVec3};
/// # struct NoShape;
/// # impl ContactShape for NoShape {
/// #     fn project(&self, _: Pose, p: DVec3) -> (DVec3, bool) { (p, false) }
/// #     fn cast_ray(&self, _: Pose, _: DVec3, _: DVec3, _: f64) -> Option<(f64, DVec3)> { None }
/// #     fn bounds(&self, _: Pose) -> (DVec3, DVec3) { (DVec3::ZERO, DVec3::ZERO) }
/// # }
/// // A 1 kg body hangs from a 0.1 kg particle, held by a 1 m stick from a pinned one.
/// let mut solver = Solver::default();
/// let top = solver.add_particle(DVec3::ZERO, 0.0);
/// let end = solver.add_particle(DVec3::new(0.0, -1.0, 0.0), 10.0);
/// solver.sticks.push([top, end], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
/// solver.organize();
/// let mut external = External::<NoShape>::default();
/// let mut body = Body::dynamic(DVec3::new(0.0, -1.0, 0.0), DQuat::IDENTITY, 1.0, DMat3::IDENTITY);
/// body.acceleration = DVec3::new(0.0, -9.81, 0.0);
/// external.bodies.push(body);
/// external.attachments.push(Attachment::new(end, 0, DVec3::ZERO));
/// let config = StepConfig::default();
/// for _ in 0..60 {
///     external.step(&mut solver, &config, &Serial); // the phases above, in order
///     // The rope held the body: an impulse of about m·g·Δt upwards per step.
///     let (impulse, _) = external.bodies[0].take_impulse();
///     assert!((impulse.y - 9.81 / 60.0).abs() < 0.02, "{impulse}");
/// }
/// ```
#[derive(Clone, Debug)]
pub struct External<S> {
    /// Body proxies; colliders and attachments refer to them by index.
    pub bodies: Vec<Body>,
    /// Colliders particles meet.
    pub colliders: Vec<ExternalCollider<S>>,
    /// Particles fixed to bodies.
    pub attachments: Vec<Attachment>,
    /// Collision layers per particle slot; empty means [`Layers::default`] for all.
    pub particle_layers: Vec<Layers>,
    /// `(restitution, friction)` per particle slot for particles that ask for their own
    /// (averaged with the collider's); empty means none does.
    pub particle_materials: Vec<Option<(f64, f64)>>,
    /// Contacts resolved in the last step.
    pub contacts: usize,
    /// Exchanges between bodies and their ropes after the first of each substep, in the last
    /// step (see [`External::after_relax`]).
    pub later_exchanges: usize,
    /// The bodies attached to each island (no contacts with them): island indices, sorted,
    /// and beside each the body (`connected_body`), without repeats.
    connected_island: Vec<u32>,
    connected_body: Vec<u32>,
    /// Scratch of [`External::begin_step`].
    connected_pairs: Vec<(u32, u32)>,
    scratch: AttachmentScratch,
    placed: Vec<(Pose, DVec3, DVec3)>,
    impulses: Vec<(u32, DVec3, DVec3)>,
    due: Vec<(Range<usize>, Substep)>,
    h: f64,
    /// The largest particle radius (this step).
    max_radius: f64,
    /// Bounds of every placed collider, grown by `max_radius` (this substep).
    reach: (DVec3, DVec3),
    /// The placed colliders by place (this substep), and a particle's query.
    grid: ColliderGrid,
    /// The largest collider margin (this substep).
    largest_margin: f64,
    near: Vec<u32>,
    /// The global substep being run (set before the relaxation).
    substep: Option<GlobalSubstep>,
    /// The attached particles that later exchanges solve again, sorted (this step).
    attached: Vec<u32>,
    /// Attachments per body (this step).
    held: Vec<u32>,
}

impl<S> Default for External<S> {
    fn default() -> Self {
        Self {
            bodies: Vec::new(),
            colliders: Vec::new(),
            attachments: Vec::new(),
            particle_layers: Vec::new(),
            particle_materials: Vec::new(),
            contacts: 0,
            later_exchanges: 0,
            connected_island: Vec::new(),
            connected_body: Vec::new(),
            connected_pairs: Vec::new(),
            scratch: AttachmentScratch::default(),
            placed: Vec::new(),
            impulses: Vec::new(),
            due: Vec::new(),
            h: 0.0,
            max_radius: 0.0,
            reach: (DVec3::ZERO, DVec3::ZERO),
            grid: ColliderGrid::default(),
            largest_margin: 0.0,
            near: Vec::new(),
            substep: None,
            attached: Vec::new(),
            held: Vec::new(),
        }
    }
}

impl<S: ContactShape> External<S> {
    /// One fixed step of `solver` with these bodies, the lists filled: [`External::begin_step`],
    /// then per substep the solver's phases with this one's between them (see the
    /// [module docs](self)), and [`Solver::finish_step`]. Returns how many sticks tore. (The
    /// Bevy layer runs the same phases as systems.) See [`External`] for an example.
    pub fn step(
        &mut self,
        solver: &mut Solver,
        config: &StepConfig,
        executor: &dyn Executor,
    ) -> usize {
        self.begin_step(solver);
        let count = solver.begin_step(config);
        for index in 1..=count {
            let config = *config;
            let substep = GlobalSubstep {
                config,
                index,
                count,
                plain: false,
            };
            solver.integrate_substep(&substep, executor);
            self.before_relax(solver, &substep);
            solver.relax_substep(&substep, executor);
            self.after_relax(solver);
            solver.constrain_substep(&substep, executor);
            self.after_constrain(solver, &substep);
        }
        solver.finish_step()
    }

    /// Whether there is nothing to couple (every pass is skipped).
    pub fn is_empty(&self) -> bool {
        self.bodies.is_empty()
    }

    /// Starts a step after the lists were filled: notes, for every island with an attachment,
    /// the bodies attached to it (particles never collide with a body attached to their
    /// island, as avian's joints disable collisions between the bodies they join; any number
    /// of bodies per island), and the attached particles in [`Solver::attached`] (their islands
    /// step with the bodies). Call it before [`Solver::begin_step`].
    pub fn begin_step(&mut self, solver: &mut Solver) {
        solver.attached.clear();
        solver
            .attached
            .extend(self.attachments.iter().map(|a| a.particle));
        // (Those on bodies that hold several, in islands solved by lines: the ones a later
        // exchange solves again.)
        self.held.clear();
        self.held.resize(self.bodies.len(), 0);
        for a in &self.attachments {
            if let Some(held) = self.held.get_mut(a.body as usize) {
                *held += 1;
            }
        }
        let by_lines = |p: u32| {
            let island = solver.is_organized().then(|| solver.islands.of_particle(p));
            island
                .flatten()
                .is_some_and(|k| solver.islands.list[k].method == Method::Lines)
        };
        self.attached.clear();
        for a in &self.attachments {
            if self.held.get(a.body as usize) > Some(&1) && by_lines(a.particle) {
                self.attached.push(a.particle);
            }
        }
        self.attached.sort_unstable();
        self.contacts = 0;
        self.later_exchanges = 0;
        self.max_radius = if self.colliders.is_empty() {
            0.0
        } else {
            solver.particles.radius.iter().copied().fold(0.0, f64::max)
        };
        let pairs = &mut self.connected_pairs;
        pairs.clear();
        for a in &self.attachments {
            pairs.push((island_key(solver, a.particle), a.body));
        }
        pairs.sort_unstable();
        pairs.dedup();
        self.connected_island.clear();
        self.connected_body.clear();
        for &(island, body) in pairs.iter() {
            self.connected_island.push(island);
            self.connected_body.push(body);
        }
    }

    /// Where the bodies attached to the island of particle `slot` are in `connected_body`.
    fn connected_to(&self, solver: &Solver, slot: u32) -> Range<usize> {
        if self.connected_island.is_empty() {
            return 0..0;
        }
        let island = island_key(solver, slot);
        let start = self.connected_island.partition_point(|&k| k < island);
        let end = self.connected_island.partition_point(|&k| k <= island);
        start..end
    }

    /// After integration: predicts the bodies' poses for the substep and lumps attachments.
    pub fn before_relax(&mut self, solver: &mut Solver, global: &GlobalSubstep) {
        if self.is_empty() {
            return;
        }
        self.h = global.config.timestep / f64::from(global.count.max(1));
        self.substep = Some(*global);
        for body in &mut self.bodies {
            body.begin_substep(self.h);
        }
        solver.due_ranges(global, &mut self.due);
        if self.attachments.is_empty() {
            return;
        }
        let (due, h) = (&self.due, self.h);
        let is_due = |p: usize| {
            let (_, substep) = due.iter().find(|(range, _)| range.contains(&p))?;
            Some(h / substep.h)
        };
        lump(
            &self.attachments,
            &mut self.bodies,
            &mut solver.particles,
            &mut self.scratch,
            is_due,
        );
    }

    /// After the relaxation: attachments move their bodies. Where a body holds several
    /// attachments, that leaves its particles away from where their ropes' solves put them (each
    /// solve saw the body through an effective mass, the body answered every pull at once: see
    /// [`AttachmentScratch::mismatch`]); the ropes solved by lines then take the bodies' moves
    /// and pull again ([`Solver::relax_lines_again`]) — up to [`COUPLING_ROUNDS`] exchanges in
    /// all, while the gap is above [`COUPLING_TOLERANCE`] of the first exchange's largest move
    /// and each exchange cut it to [`COUPLING_CONTRACTION`] of the last or less.
    pub fn after_relax(&mut self, solver: &mut Solver) {
        if self.attachments.is_empty() || self.bodies.is_empty() {
            return;
        }
        release(
            &mut self.attachments,
            &mut self.bodies,
            &mut solver.particles,
            &mut self.scratch,
        );
        let Some(global) = self.substep.filter(|_| !self.attached.is_empty()) else {
            return;
        };
        let (first_move, mut last_gap) = (self.scratch.mismatch().1, f64::INFINITY);
        let mut exchanges = 1;
        while exchanges < COUPLING_ROUNDS {
            let gap = self.scratch.mismatch().0;
            if gap <= COUPLING_TOLERANCE * first_move || gap > COUPLING_CONTRACTION * last_gap {
                break;
            }
            last_gap = gap;
            if !self.exchange_again(solver, &global) {
                break;
            }
            exchanges += 1;
            self.later_exchanges += 1;
        }
        if exchanges > 1 {
            settle_pulls(&mut self.attachments, &self.scratch);
        }
    }

    /// One more exchange between the bodies and the ropes solved by lines attached to several
    /// on one body (see [`External::after_relax`]). Returns whether there was one (none of
    /// those ropes may take this substep).
    fn exchange_again(&mut self, solver: &mut Solver, global: &GlobalSubstep) -> bool {
        if !solver.has_lines_again(global, &self.attached) {
            return false;
        }
        let (bodies, scratch) = (&mut self.bodies, &mut self.scratch);
        relump(&self.attachments, bodies, &mut solver.particles, scratch);
        solver.relax_lines_again(global, &self.attached);
        release(
            &mut self.attachments,
            bodies,
            &mut solver.particles,
            scratch,
        );
        true
    }

    /// After the crate's colliders: contacts with the external colliders, then the bodies'
    /// velocities and the contacts' velocity impulses.
    pub fn after_constrain(&mut self, solver: &mut Solver, _global: &GlobalSubstep) {
        if self.is_empty() {
            return;
        }
        // (The longest particle substep due, in the bodies' substeps.)
        let spanned = |substep: &Substep| substeps_spanned(self.h / substep.h);
        let substeps = self.due.iter().map(|(_, substep)| spanned(substep));
        self.place_colliders(substeps.fold(1.0, f64::max));
        self.impulses.clear();
        for k in 0..self.due.len() {
            let (range, substep) = self.due[k].clone();
            self.collide_range(solver, range, &substep);
        }
        for body in &mut self.bodies {
            body.end_substep(self.h);
        }
        for &(body, arm, impulse) in &self.impulses {
            self.bodies[body as usize].push(arm, impulse);
        }
        for &(body, arm, slower) in &self.scratch.velocity_corrections {
            self.bodies[body as usize].push(arm, slower / self.h);
        }
        self.scratch.velocity_corrections.clear();
    }

    /// Each collider's pose and bounds for this substep, and the bounds of them all (grown by
    /// their margins and the largest particle radius) for the particles' first, cheap test.
    /// The bounds are swept over the longest particle substep due (`substeps` of the bodies'):
    /// a collider that passed a particle standing still is still offered to it, to be swept
    /// relative to it (see [`collide_particle_with`]).
    fn place_colliders(&mut self, substeps: f64) {
        self.placed.clear();
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for collider in &self.colliders {
            let pose = collider.pose(&self.bodies);
            let (mut a, mut b) = collider.shape.bounds(pose);
            if let Some(start) = collider.start_pose(&self.bodies, substeps) {
                let (c, d) = collider.shape.bounds(start);
                (a, b) = (a.min(c), b.max(d));
            }
            self.placed.push((pose, a, b));
            let margin = collider.margin;
            (lo, hi) = (lo.min(a - margin), hi.max(b + margin));
        }
        self.reach = (lo - self.max_radius, hi + self.max_radius);
        let margins = self.colliders.iter().map(|c| c.margin);
        self.largest_margin = margins.clone().fold(0.0, f64::max);
        // (A query's buffer: more than it holds and the particle tests every collider.)
        self.near.resize((4 * self.colliders.len()).max(64), 0);
        let bounds = self.placed.iter().zip(margins);
        let bounds = bounds.map(|(&(_, a, b), margin)| (a - margin, b + margin));
        self.grid.build(bounds);
    }

    fn collide_range(&mut self, solver: &mut Solver, range: Range<usize>, substep: &Substep) {
        if self.colliders.is_empty() {
            return;
        }
        let gravity_step = substep.gravity.length() * substep.h * substep.h;
        // (A due range is one island's.)
        let connected = match range.clone().next() {
            Some(first) => self.connected_to(solver, first as u32),
            None => 0..0,
        };
        let connected = &self.connected_body[connected];
        let particles = &mut solver.particles;
        let start = self.impulses.len();
        let (lo, hi) = self.reach;
        for slot in range {
            let (x, before) = (particles.position[slot], particles.previous[slot]);
            if x.min(before).cmpgt(hi).any() || x.max(before).cmplt(lo).any() {
                continue; // its swept box is far from every collider
            }
            let particle = ContactParticle {
                layers: self.particle_layers.get(slot).copied().unwrap_or_default(),
                connected,
                gravity_step,
                material: self.particle_materials.get(slot).copied().flatten(),
                time_ratio: self.h / substep.h,
            };
            // The colliders it may meet: its swept box grown by its radius and by what a
            // contact may push it (its radius and its motion again).
            let radius = particles.radius[slot];
            let reach = radius * 2.0 + (x - before).length() + self.largest_margin;
            let (box_lo, box_hi) = (x.min(before) - reach, x.max(before) + reach);
            let near = self.grid.near_sorted(box_lo, box_hi, &mut self.near);
            let (position, previous) =
                (&mut particles.position[slot], &mut particles.previous[slot]);
            let state = (position, previous, particles.inverse_mass[slot], radius);
            let world = (
                &self.colliders[..],
                &self.placed[..],
                &mut self.bodies[..],
                &mut self.impulses,
            );
            let touched = match near {
                Some(count) => {
                    let candidates = self.near[..count].iter().map(|&i| i as usize);
                    collide_particle_with(particle, state, candidates, world)
                }
                None => collide_particle_with(particle, state, 0..self.colliders.len(), world),
            };
            self.contacts += usize::from(touched);
        }
        // Impulses were in mass × displacement per substep: per second for the bodies.
        for impulse in &mut self.impulses[start..] {
            impulse.2 /= substep.h;
        }
    }
}

/// The island of particle `slot` as a sort key (one for all in an unorganized solver).
fn island_key(solver: &Solver, slot: u32) -> u32 {
    if solver.is_organized() {
        solver
            .islands
            .of_particle(slot)
            .map_or(u32::MAX, |k| k as u32)
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::{Body, Serial, StickKind};
    use glam::{DMat3, DQuat};

    /// No collider: attachments only.
    struct NoShape;

    impl ContactShape for NoShape {
        fn project(&self, _: Pose, p: DVec3) -> (DVec3, bool) {
            (p, false)
        }
        fn cast_ray(&self, _: Pose, _: DVec3, _: DVec3, _: f64) -> Option<(f64, DVec3)> {
            None
        }
        fn bounds(&self, _: Pose) -> (DVec3, DVec3) {
            (DVec3::ZERO, DVec3::ZERO)
        }
    }

    /// A 0.59 kg, 96 cm plank (2D: it turns about Z) 1 m below two pins, tied by its ends to
    /// two ropes of 8 links (10 g, knots 35 g), kicked sideways and spun: the worst scene of
    /// the scan behind [`COUPLING_ROUNDS`], on the core alone, for 2 s. With one exchange per
    /// substep its ropes stretched up to 4.9·10⁻³ (and 0.7 % in the avian run, where the next
    /// step gave the plank 0.2 J); the exchanges repeated keep them within 2·10⁻³ (measured
    /// 1.1·10⁻³).
    #[test]
    fn repeated_exchanges_keep_a_kicked_plank_on_its_ropes() {
        let (mass, width, centre) = (0.59, 0.96, DVec3::new(0.0, -1.0, 0.0));
        let tops = [
            (DVec3::new(0.449, -0.112, 0.0), -0.48),
            (DVec3::new(0.241, -0.026, 0.0), 0.48),
        ];
        let mut solver = Solver::default();
        let mut attachments = Vec::new();
        for (top, side) in tops {
            let end = centre + DVec3::X * side;
            let mut previous = solver.add_particle(top, 0.0);
            solver.pin(previous, top);
            for i in 1..=8 {
                let w = if i == 8 { 1.0 / 0.035 } else { 100.0 };
                let p = solver.add_particle(top + (end - top) * (i as f64 / 8.0), w);
                let (rest, rigid) = ((end - top).length() / 8.0, StickKind::Equal);
                solver
                    .sticks
                    .push([previous, p], rest, 0.0, rigid, f64::INFINITY, 0);
                previous = p;
            }
            attachments.push(Attachment::new(previous, 0, DVec3::X * side));
        }
        solver.organize();
        let inertia = mass * (width * width + 0.04 * 0.04) / 12.0;
        let inverse = DMat3::from_diagonal(DVec3::new(0.0, 0.0, 1.0 / inertia));
        let mut body = Body::dynamic(centre, DQuat::IDENTITY, 1.0 / mass, inverse);
        body.acceleration = DVec3::new(0.0, -9.81, 0.0);
        body.velocity = DVec3::new(-5.5, 0.34, 0.0);
        body.angular_velocity = DVec3::new(0.0, 0.0, -2.5);
        let mut external = External::<NoShape>::default();
        external.bodies.push(body);
        external.attachments = attachments;
        let (config, mut strain) = (StepConfig::default(), 0.0f64);
        for _ in 0..128 {
            external.step(&mut solver, &config, &Serial);
            external.bodies[0].take_impulse();
            let sticks = &solver.sticks;
            for i in 0..sticks.len() {
                strain = strain.max(sticks.strain(i, &solver.particles).abs());
            }
        }
        assert!(strain < 2e-3, "strain {strain}");
    }
}
