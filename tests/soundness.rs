//! No safe code can make the solver race: a misbehaving [`Executor`] or a topology changed after
//! `Solver::organize` gives the serial result (or a clear panic), never two threads on one
//! particle.

use bevy_verlet_physics::solver::{Executor, ScopedThreads, Serial, Solver, StepConfig, StickKind};
use glam::DVec3;

/// An `n × n` cloth of rigid sticks (row-major), pinned at its two top corners.
fn cloth(solver: &mut Solver, n: usize) {
    let first = solver.particles.len() as u32;
    for row in 0..n {
        for column in 0..n {
            let p = DVec3::new(column as f64, 0.0, -(row as f64)) * 0.05;
            solver.add_particle(p, 1.0);
        }
    }
    let index = |c: usize, r: usize| first + (r * n + c) as u32;
    for row in 0..n {
        for column in 0..n {
            if column + 1 < n {
                let ends = [index(column, row), index(column + 1, row)];
                solver
                    .sticks
                    .push(ends, 0.05, 0.0, StickKind::Equal, f64::INFINITY, 0);
            }
            if row + 1 < n {
                let ends = [index(column, row), index(column, row + 1)];
                solver
                    .sticks
                    .push(ends, 0.05, 0.0, StickKind::Equal, f64::INFINITY, 0);
            }
        }
    }
    for i in [index(0, 0), index(n - 1, 0)] {
        solver.pin(i, solver.particles.position[i as usize]);
    }
}

/// `ropes` ropes of `links` links, each pinned at its first particle, started horizontally.
fn ropes(solver: &mut Solver, ropes: usize, links: usize) {
    for r in 0..ropes {
        let first = solver.particles.len() as u32;
        for k in 0..=links {
            solver.add_particle(DVec3::new(k as f64 * 0.1, 0.0, r as f64), 1.0);
        }
        for k in 0..links as u32 {
            let ends = [first + k, first + k + 1];
            solver
                .sticks
                .push(ends, 0.1, 0.0, StickKind::AtMost, f64::INFINITY, 0);
        }
        solver.pin(first, solver.particles.position[first as usize]);
    }
}

/// A 72 × 72 cloth (solved on every thread at 4 iterations) and 400 ropes (spread in groups).
fn scene() -> Solver {
    let mut solver = Solver::default();
    cloth(&mut solver, 72);
    ropes(&mut solver, 400, 50);
    solver.organize();
    solver
}

fn config() -> StepConfig {
    StepConfig {
        substeps: 4,
        iterations: 4,
        damping: 0.1,
        ..StepConfig::default()
    }
}

fn bits(solver: &Solver) -> Vec<[u64; 3]> {
    let positions = &solver.particles.position;
    positions
        .iter()
        .map(|p| p.to_array().map(f64::to_bits))
        .collect()
}

/// Runs every job twice, both runs at the same time on their own threads.
struct Twice;

impl Executor for Twice {
    fn threads(&self) -> usize {
        2
    }

    fn run(&self, count: usize, job: &(dyn Fn(usize) + Sync)) {
        std::thread::scope(|scope| {
            for i in 0..count {
                scope.spawn(move || job(i));
                scope.spawn(move || job(i));
            }
        });
    }
}

/// Claims two threads but always passes job index 0, from two threads at once.
struct AlwaysZero;

impl Executor for AlwaysZero {
    fn threads(&self) -> usize {
        2
    }

    fn run(&self, count: usize, job: &(dyn Fn(usize) + Sync)) {
        std::thread::scope(|scope| {
            for _ in 0..count {
                scope.spawn(move || job(0));
            }
        });
    }
}

/// Claims two threads and never runs anything.
struct Lazy;

impl Executor for Lazy {
    fn threads(&self) -> usize {
        2
    }

    fn run(&self, _: usize, _: &(dyn Fn(usize) + Sync)) {}
}

#[test]
fn an_executor_that_runs_jobs_twice_or_with_wrong_indices_gives_the_serial_result() {
    let mut serial = scene();
    let mut twice = serial.clone();
    let mut zero = serial.clone();
    for _ in 0..10 {
        serial.step_with(&config(), &Serial);
        twice.step_with(&config(), &Twice);
        zero.step_with(&config(), &AlwaysZero);
    }
    assert!(serial.particles.all_finite());
    assert_eq!(bits(&serial), bits(&twice));
    assert_eq!(bits(&serial), bits(&zero));
}

#[test]
#[should_panic(expected = "the Executor returned before running its jobs")]
fn an_executor_that_runs_nothing_panics() {
    let mut solver = scene();
    solver.step_with(&config(), &Lazy);
}
