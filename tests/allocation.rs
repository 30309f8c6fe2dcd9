//! The solver core allocates nothing in a steady-state step: a counting global allocator
//! watches 200 fixed steps of a scene that uses every feature (sticks of every kind, tearable
//! sticks, angle constraints, tethers, a moving pin, colliders, substeps and iterations).

use bevy_verlet_physics::solver::{Collider, Shape, Sleep, Solver, StepConfig, StickKind};
use glam::DVec3;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Counts allocations made by threads that opted in.
struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

fn note() {
    if COUNTING.with(Cell::get) {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
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
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    COUNTING.with(|c| c.set(true));
    f();
    COUNTING.with(|c| c.set(false));
    ALLOCATIONS.load(Ordering::Relaxed) - before
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
