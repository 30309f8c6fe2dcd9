//! The solver core allocates nothing in a steady-state step: a counting global allocator
//! watches 200 fixed steps of a scene that uses every feature (sticks of every kind, tearable
//! sticks, angle constraints, tethers, a moving pin, colliders, substeps and iterations), a
//! cloth with a hierarchy, ropes, chains and trees solved by lines, and rigid bodies of another
//! engine held by ropes and a cloth, as the avian layer couples them.

use bevy_verlet_physics::solver::{
    Attachment, Body, Collider, ContactShape, EXACT_SHARING_UP_TO, External, ExternalCollider,
    Layers, Pose, Serial, Shape, Sleep, Solver, StepConfig, StickKind,
};
use glam::{DMat3, DQuat, DVec3};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

mod chain;

/// Counts allocations made by threads that opted in.
struct Counting;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    // (Per thread: tests run side by side, each counting its own.)
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn note() {
    if COUNTING.with(Cell::get) {
        ALLOCATIONS.with(|count| count.set(count.get() + 1));
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made by `f` on this thread.
fn allocations_in(f: impl FnOnce()) -> usize {
    let before = ALLOCATIONS.with(Cell::get);
    COUNTING.with(|c| c.set(true));
    f();
    COUNTING.with(|c| c.set(false));
    ALLOCATIONS.with(Cell::get) - before
}

/// A 30 × 30 cloth with every feature switched on.
fn scene() -> Solver {
    let mut solver = Solver::default();
    let n = 34; // 2244 sticks: large enough to be coloured
    for row in 0..n {
        for column in 0..n {
            let p = DVec3::new(column as f64 * 0.05, -(row as f64) * 0.05, 0.0);
            let i = solver.add_particle(p, 1.0);
            solver.tethered[i as usize] = true;
        }
    }
    let index = |c: usize, r: usize| (r * n + c) as u32;
    for row in 0..n {
        for column in 0..n {
            let kinds = [StickKind::Equal, StickKind::AtMost, StickKind::AtLeast];
            let kind = kinds[(row + column) % 3];
            if column + 1 < n {
                // Tearable, but far from tearing: a tear rebuilds the tethers (that allocates).
                let ends = [index(column, row), index(column + 1, row)];
                solver
                    .sticks
                    .push(ends, 0.05, 1e-6, StickKind::Equal, 2.0, 0);
            }
            if row + 1 < n {
                let ends = [index(column, row), index(column, row + 1)];
                solver.sticks.push(ends, 0.05, 0.0, kind, f64::INFINITY, 0);
            }
            if row + 2 < n {
                let ends = [
                    index(column, row),
                    index(column, row + 1),
                    index(column, row + 2),
                ];
                solver.angles.push(ends, std::f64::consts::PI, 1e-3, None);
            }
        }
    }
    for column in [0, n - 1] {
        let i = index(column, 0);
        solver.pin(i, solver.particles.position[i as usize]);
    }
    solver.rebuild_tethers();
    solver.colliders.push(Collider {
        shape: Shape::Sphere {
            center: DVec3::new(0.7, -1.2, 0.2),
            radius: 0.4,
        },
        restitution: 0.2,
        friction: 0.5,
    });
    solver.colliders.push(Collider {
        shape: Shape::Plane {
            point: DVec3::new(0.0, -1.6, 0.0),
            normal: DVec3::Y,
        },
        restitution: 0.0,
        friction: 0.8,
    });
    solver
}

#[test]
fn a_steady_state_step_allocates_nothing() {
    let mut solver = scene();
    // Organized as the plugin does (islands; the cloth is coloured), with sleeping enabled.
    solver.organize();
    assert!(solver.islands.batches.iter().any(|b| b.independent));
    let config = StepConfig {
        substeps: 4,
        iterations: 2,
        damping: 0.5,
        sleep: Some(Sleep::for_gravity(9.81)),
        ..StepConfig::default()
    };
    // Warm up: the first steps may size scratch buffers.
    for _ in 0..10 {
        solver.step(&config);
    }
    let mut torn = 0;
    let allocations = allocations_in(|| {
        for step in 0..200 {
            // Move a pin every step, as a dragged cloth does.
            let target = DVec3::new(0.0, 0.1 * (step as f64 * 0.05).sin(), 0.0);
            solver.pins.set_target(0, target);
            solver.step(&config);
            torn += solver.torn.len();
        }
    });
    assert_eq!(torn, 0, "the scene tore: not a steady state");
    assert!(
        solver.particles.position.iter().all(|p| p.is_finite()),
        "the scene blew up"
    );
    assert_eq!(allocations, 0, "allocations in 200 steady-state steps");
    // The counter works: an allocation on this thread is seen.
    assert_eq!(allocations_in(|| drop(vec![1u8; 64])), 1);
}

/// The same for a cloth solved with a hierarchy (coarse levels before each sweep): the levels'
/// masses and lengths are re-read every step without allocating.
#[test]
fn a_steady_state_step_with_a_hierarchy_allocates_nothing() {
    use bevy_verlet_physics::solver::Method;
    let mut solver = Solver::default();
    let n = 40;
    for row in 0..n {
        for column in 0..n {
            let p = DVec3::new(column as f64 * 0.05, -(row as f64) * 0.05, 0.0);
            let i = solver.add_particle(p, 1.0);
            if row == 0 && (column == 0 || column == n - 1) {
                solver.pin(i, p);
            }
        }
    }
    let index = |c: usize, r: usize| (r * n + c) as u32;
    for row in 0..n {
        for column in 0..n {
            let mut rigid = |a: u32, b: u32| {
                let kind = StickKind::Equal;
                solver
                    .sticks
                    .push([a, b], 0.05, 0.0, kind, f64::INFINITY, 0);
            };
            if column + 1 < n {
                rigid(index(column, row), index(column + 1, row));
            }
            if row + 1 < n {
                rigid(index(column, row), index(column, row + 1));
            }
        }
    }
    solver.method = Method::Hierarchy;
    solver.organize();
    assert!(solver.islands.list[0].hierarchy.is_some());
    let config = StepConfig::default();
    for _ in 0..10 {
        solver.step(&config);
    }
    let allocations = allocations_in(|| {
        for _ in 0..100 {
            solver.step(&config);
        }
    });
    assert!(solver.particles.position.iter().all(|p| p.is_finite()));
    assert!(solver.islands.hierarchies().list[0].active);
    assert_eq!(allocations, 0, "allocations in 100 steady-state steps");
}

/// Ropes, chains and trees solved by lines allocate nothing in a steady step either — under
/// `line_substeps` at a count that does not divide the step's (a 30 Hz step: 3 of its 8,
/// `line_substep_count`), beside a swept cloth, with a 1000:1 chain whipping round from
/// horizontal (SHAKE failing, projections starting with curvature passes), a forked tree and a
/// rope between two pins.
#[test]
fn a_steady_state_step_of_lines_allocates_nothing() {
    use bevy_verlet_physics::solver::Method;
    use chain::chain_along;
    let mut solver = Solver::default();
    let tip = chain_along(&mut solver, (100, 1.0), 1000.0, DVec3::X);
    let hanging = chain_along(&mut solver, (20, 1.0), 1.0, DVec3::NEG_Y);
    // A branch of 10 links from the middle of the hanging chain: a tree with a fork.
    let mut previous = hanging - 10;
    for i in 1..=10 {
        let at = solver.particles.position[(hanging - 10) as usize] + DVec3::X * 0.05 * i as f64;
        let p = solver.add_particle(at, 1.0);
        let ends = [previous, p];
        solver
            .sticks
            .push(ends, 0.05, 0.0, StickKind::Equal, f64::INFINITY, 0);
        previous = p;
    }
    // A rope of 30 links between two pins 1.2 m apart (1.5 m long): it sags and swings.
    let left = solver.add_particle(DVec3::new(3.0, 0.0, 0.0), 0.0);
    solver.pin(left, DVec3::new(3.0, 0.0, 0.0));
    let mut previous = left;
    for i in 1..=30 {
        let at = DVec3::new(3.0 + 0.04 * i as f64, 0.0, 0.0);
        let w = if i == 30 { 0.0 } else { 1.0 };
        let p = solver.add_particle(at, w);
        if i == 30 {
            solver.pin(p, at);
        }
        solver.sticks.push(
            [previous, p],
            0.05,
            0.0,
            StickKind::AtMost,
            f64::INFINITY,
            0,
        );
        previous = p;
    }
    let cloth = scene();
    let offset = solver.particles.len() as u32;
    for i in 0..cloth.particles.len() {
        let p = cloth.particles.position[i] + DVec3::new(-3.0, 0.0, 0.0);
        solver.add_particle(p, 1.0);
    }
    for i in 0..cloth.sticks.len() {
        let [a, b] = cloth.sticks.ends()[i];
        let ends = [a + offset, b + offset];
        let rest = cloth.sticks.rest_length[i];
        solver
            .sticks
            .push(ends, rest, 0.0, StickKind::Equal, f64::INFINITY, 0);
    }
    for top in offset..offset + 34 {
        solver.pin(top, solver.particles.position[top as usize]);
    }
    solver.organize();
    let method = |slot: u32| solver.islands.list[solver.islands.of_particle(slot).unwrap()].method;
    assert_eq!(method(tip), Method::Lines);
    assert_eq!(method(hanging), Method::Lines);
    assert_eq!(method(previous), Method::Lines);
    assert_eq!(method(offset), Method::Sweep);
    let config = StepConfig {
        timestep: 1.0 / 30.0,
        line_substeps: Some(2),
        ..StepConfig::default()
    };
    for _ in 0..10 {
        solver.step(&config);
    }
    let passes = solver.line_passes();
    let allocations = allocations_in(|| {
        for _ in 0..150 {
            solver.step(&config);
        }
    });
    assert!(solver.particles.position.iter().all(|p| p.is_finite()));
    assert_eq!(solver.state_substep_of(tip), Some(config.timestep / 3.0));
    assert!(
        solver.line_passes() > passes + 150 * 3,
        "the lines were solved"
    );
    assert_eq!(allocations, 0, "allocations in 150 steady-state steps");
}

/// A ball of `radius` around its pose's translation (what the avian layer's shapes answer).
struct Ball(f64);

impl ContactShape for Ball {
    fn project(&self, pose: Pose, point: DVec3) -> (DVec3, bool) {
        let d = point - pose.translation;
        let surface = pose.translation + d.normalize_or(DVec3::Y) * self.0;
        (surface, d.length() < self.0)
    }
    fn cast_ray(&self, pose: Pose, o: DVec3, d: DVec3, max: f64) -> Option<(f64, DVec3)> {
        let m = o - pose.translation;
        let b = m.dot(d);
        let disc = b * b - (m.length_squared() - self.0 * self.0);
        let t = -b - disc.max(0.0).sqrt();
        (disc >= 0.0 && (0.0..=max).contains(&t))
            .then(|| (t, (o + d * t - pose.translation).normalize()))
    }
    fn bounds(&self, pose: Pose) -> (DVec3, DVec3) {
        (pose.translation - self.0, pose.translation + self.0)
    }
}

/// A rope of `links` 5 cm links from a pin at `top` straight down; returns its last particle.
fn rope_from(solver: &mut Solver, top: DVec3, links: usize) -> u32 {
    let pin = solver.add_particle(top, 0.0);
    solver.pin(pin, top);
    let mut previous = pin;
    for i in 1..=links {
        let p = solver.add_particle(top - DVec3::Y * (0.05 * i as f64), 10.0);
        let ends = [previous, p];
        solver
            .sticks
            .push(ends, 0.05, 0.0, StickKind::Equal, f64::INFINITY, 0);
        previous = p;
    }
    previous
}

/// A `width × rows` cloth of 5 cm cells hung by its top row from `corner`; returns the
/// particles of its bottom row.
fn cloth_from(solver: &mut Solver, corner: DVec3, (width, rows): (usize, usize)) -> Vec<u32> {
    let first = solver.particles.len() as u32;
    let at = |c: usize, r: usize| corner + DVec3::new(0.05 * c as f64, -0.05 * r as f64, 0.0);
    for r in 0..rows {
        for c in 0..width {
            let i = solver.add_particle(at(c, r), 10.0);
            if r == 0 {
                solver.pin(i, at(c, r));
            }
        }
    }
    let index = |c: usize, r: usize| first + (r * width + c) as u32;
    let mut stick = |a: u32, b: u32| {
        let kind = StickKind::Equal;
        solver
            .sticks
            .push([a, b], 0.05, 0.0, kind, f64::INFINITY, 0);
    };
    for r in 0..rows {
        for c in 0..width {
            if c + 1 < width {
                stick(index(c, r), index(c + 1, r));
            }
            if r + 1 < rows {
                stick(index(c, r), index(c, r + 1));
            }
        }
    }
    (0..width).map(|c| index(c, rows - 1)).collect()
}

/// What the avian layer hands the core every step, kept between steps as the plugin keeps it.
struct Coupling {
    external: External<Ball>,
    bodies: Vec<Body>,
    attachments: Vec<Attachment>,
    layers: Vec<Layers>,
    materials: Vec<Option<(f64, f64)>>,
    contacts: usize,
}

impl Coupling {
    /// A dynamic body falling under gravity, `1 / inverse_mass` kg.
    fn falling(position: DVec3, inverse_mass: f64) -> Body {
        let inertia = DMat3::from_diagonal(DVec3::splat(inverse_mass * 12.0));
        let mut body = Body::dynamic(position, DQuat::IDENTITY, inverse_mass, inertia);
        body.acceleration = DVec3::new(0.0, -9.81, 0.0);
        body
    }

    /// Attaches each of `particles` to `body` where it is now.
    fn attach(&mut self, solver: &Solver, particles: &[u32], body: u32) {
        let centre = self.bodies[body as usize].position;
        for &p in particles {
            let anchor = solver.particles.position[p as usize] - centre;
            self.attachments.push(Attachment::new(p, body, anchor));
        }
    }

    /// One fixed step: the lists refilled (their capacity kept), the substeps run with the
    /// bodies, and the bodies carried on from where the particles left them (the other
    /// engine's step, here nothing but their own motion).
    fn step(&mut self, solver: &mut Solver, config: &StepConfig) {
        let external = &mut self.external;
        external.bodies.clone_from(&self.bodies);
        external.attachments.clone_from(&self.attachments);
        external.colliders.clear();
        external.colliders.extend([ball(0, 0.15), ball(3, 0.5)]);
        external.particle_layers.clone_from(&self.layers);
        external.particle_materials.clone_from(&self.materials);
        external.step(solver, config, &Serial);
        self.contacts += external.contacts;
        for (kept, body) in self.bodies.iter_mut().zip(&mut external.bodies) {
            body.take_impulse();
            *kept = *body;
        }
        for (kept, used) in self.attachments.iter_mut().zip(&external.attachments) {
            kept.direction = used.direction;
        }
    }
}

/// A ball collider of `radius` at `body`'s centre.
fn ball(body: u32, radius: f64) -> ExternalCollider<Ball> {
    ExternalCollider {
        shape: Ball(radius),
        body,
        local: Pose::IDENTITY,
        restitution: 0.3,
        friction: 0.4,
        layers: Layers::default(),
        margin: 0.01,
    }
}

/// Rigid bodies held by particles, coupled as the avian layer couples them: a box kicked on
/// one rope (solved by lines), a plank on three ropes (their pulls shared exactly), a bar
/// carrying the bottom edge of a 40-wide cloth (above `EXACT_SHARING_UP_TO` attachments: the
/// count rule), a ball collider on the box and a static ball the cloth rests on, with particle
/// layers and materials. At a 30 Hz step with `line_substeps` the attached islands take the
/// bodies' substep count.
fn coupled_scene() -> (Solver, Coupling) {
    let mut solver = Solver::default();
    let box_end = rope_from(&mut solver, DVec3::new(-2.0, 0.0, 0.0), 20);
    let plank_ends = [-0.4, 0.0, 0.4].map(|x| rope_from(&mut solver, DVec3::new(x, 0.0, 0.0), 10));
    let hem = cloth_from(&mut solver, DVec3::new(2.0, 0.0, 0.0), (40, 12));
    solver.organize();
    let stand = DQuat::IDENTITY;
    let mut coupling = Coupling {
        external: External::default(),
        bodies: vec![
            Coupling::falling(DVec3::new(-1.9, -1.1, 0.0), 0.5),
            Coupling::falling(DVec3::new(0.0, -0.55, 0.0), 0.2),
            Coupling::falling(DVec3::new(2.975, -0.6, 0.0), 0.25),
            Body::kinematic(DVec3::new(3.0, -0.3, 0.45), stand, DVec3::ZERO, DVec3::ZERO),
        ],
        attachments: Vec::new(),
        layers: (0..solver.particles.len())
            .map(|i| Layers {
                memberships: 1 + (i % 2) as u32,
                filters: u32::MAX,
            })
            .collect(),
        materials: (0..solver.particles.len())
            .map(|i| (i % 3 == 0).then_some((0.1, 0.9)))
            .collect(),
        contacts: 0,
    };
    coupling.bodies[0].velocity = DVec3::new(1.0, 0.0, 0.5);
    coupling.attach(&solver, &[box_end], 0);
    coupling.attach(&solver, &plank_ends, 1);
    coupling.attach(&solver, &hem, 2);
    assert!(hem.len() > EXACT_SHARING_UP_TO as usize);
    (solver, coupling)
}

#[test]
fn a_steady_state_step_with_rigid_bodies_allocates_nothing() {
    let (mut solver, mut coupling) = coupled_scene();
    let config = StepConfig {
        timestep: 1.0 / 30.0,
        line_substeps: Some(2),
        ..StepConfig::default()
    };
    for _ in 0..10 {
        coupling.step(&mut solver, &config);
    }
    let start = (
        coupling.contacts,
        coupling.bodies[0].position,
        solver.line_passes(),
    );
    let allocations = allocations_in(|| {
        for _ in 0..150 {
            coupling.step(&mut solver, &config);
        }
    });
    assert!(solver.particles.position.iter().all(|p| p.is_finite()));
    let body_finite = |b: &Body| b.position.is_finite() && b.velocity.is_finite();
    assert!(coupling.bodies.iter().all(body_finite));
    assert!(coupling.contacts > start.0, "particles met the balls");
    let swing = (coupling.bodies[0].position - start.1).length();
    assert!(swing > 0.05, "the box swung: {swing}");
    assert!(
        solver.line_passes() > start.2,
        "the ropes were solved by lines"
    );
    assert_eq!(allocations, 0, "allocations in 150 steady-state steps");
}
