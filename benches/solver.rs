//! Criterion benchmarks: the solver core against a bare reference loop (the same math on plain
//! arrays, nothing else) and the full ECS fixed step against the core alone, on cloth grids of
//! 32², 128² and 512² particles and a 10 000-link rope.
//!
//! `cargo bench --bench solver` — compare the `core` and `bare` lines of one group: their ratio
//! is the core's overhead, measured in the same run.

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::solver::{Solver, StepConfig, StickKind, relax_sticks};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use std::hint::black_box;
use std::time::Duration;

/// A `n × n` cloth (structural sticks, spacing 0.1, top row pinned) in the solver core.
fn cloth(n: usize) -> Solver {
    let mut solver = Solver::default();
    for row in 0..n {
        for column in 0..n {
            let p = DVec3::new(column as f64 * 0.1, -(row as f64) * 0.1, 0.0);
            solver.add_particle(p, 1.0);
        }
    }
    let index = |c: usize, r: usize| (r * n + c) as u32;
    for row in 0..n {
        for column in 0..n {
            if column + 1 < n {
                let ends = [index(column, row), index(column + 1, row)];
                solver
                    .sticks
                    .push(ends, 0.1, 0.0, StickKind::Equal, f64::INFINITY, 0);
            }
            if row + 1 < n {
                let ends = [index(column, row), index(column, row + 1)];
                solver
                    .sticks
                    .push(ends, 0.1, 0.0, StickKind::Equal, f64::INFINITY, 0);
            }
        }
    }
    for column in 0..n {
        let i = index(column, 0);
        solver.pin(i, solver.particles.position[i as usize]);
    }
    solver
}

/// A rope of `links` links pinned at one end.
fn rope(links: usize) -> Solver {
    let mut solver = Solver::default();
    for i in 0..=links {
        solver.add_particle(DVec3::new(i as f64 * 0.01, 0.0, 0.0), 1.0);
    }
    for i in 0..links as u32 {
        solver
            .sticks
            .push([i, i + 1], 0.01, 0.0, StickKind::Equal, f64::INFINITY, 0);
    }
    solver.pin(0, DVec3::ZERO);
    solver
}

/// The bare reference: rigid PBD stick projection on plain arrays.
struct Bare {
    position: Vec<DVec3>,
    inverse_mass: Vec<f64>,
    sticks: Vec<(u32, u32, f64)>,
}

impl Bare {
    fn from(solver: &Solver) -> Self {
        Self {
            position: solver.particles.position.clone(),
            inverse_mass: solver.particles.inverse_mass.clone(),
            sticks: (0..solver.sticks.len())
                .map(|i| {
                    let [a, b] = solver.sticks.ends[i];
                    (a, b, solver.sticks.rest_length[i])
                })
                .collect(),
        }
    }

    fn relax(&mut self) {
        let p = &mut self.position;
        for &(a, b, rest) in &self.sticks {
            let (a, b) = (a as usize, b as usize);
            let (wa, wb) = (self.inverse_mass[a], self.inverse_mass[b]);
            let w = wa + wb;
            let delta = p[a] - p[b];
            let length = delta.length();
            if w <= 0.0 || length < 1e-12 {
                continue;
            }
            let correction = delta * ((rest - length) / (w * length));
            p[a] += correction * wa;
            p[b] -= correction * wb;
        }
    }
}

/// One relaxation sweep: core vs bare loop, per stick.
fn relax(c: &mut Criterion) {
    let mut group = c.benchmark_group("relax_sweep");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));
    let scenes = [
        ("cloth_32", cloth(32)),
        ("cloth_128", cloth(128)),
        ("cloth_512", cloth(512)),
        ("rope_10k", rope(10_000)),
    ];
    for (name, mut solver) in scenes {
        // Sag a little first so the sticks have work to do.
        let config = StepConfig::default();
        for _ in 0..4 {
            solver.step(&config);
        }
        let mut bare = Bare::from(&solver);
        group.throughput(Throughput::Elements(solver.sticks.len() as u64));
        group.bench_function(BenchmarkId::new("core", name), |b| {
            b.iter(|| relax_sticks(&mut solver.particles, &mut solver.sticks, 1.0 / 64.0, false))
        });
        group.bench_function(BenchmarkId::new("bare", name), |b| b.iter(|| bare.relax()));
        black_box(&bare.position);
    }
    group.finish();
}

/// A full fixed step with 10 iterations: the ECS plugin (gather, solve, scatter) vs the core.
fn ecs_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("fixed_step_10_iterations");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_millis(500));
    for n in [32, 128] {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, VerletPlugin::default()))
            .insert_resource(TimeUpdateStrategy::FixedTimesteps(1))
            .insert_resource(VerletConfig {
                substeps: 1,
                iterations: 10,
                ..VerletConfig::default()
            });
        ClothBuilder::new(Vec3::ZERO, n, n, 0.1)
            .pin_top_row(1)
            .spawn(&mut app.world_mut().commands());
        app.world_mut().flush();
        app.update();
        app.update();
        let particles = (n * n) as u64;
        group.throughput(Throughput::Elements(particles));
        group.bench_function(BenchmarkId::new("ecs", format!("cloth_{n}")), |b| {
            b.iter(|| app.update())
        });
        let mut solver = app.world().resource::<VerletState>().solver.clone();
        let config = StepConfig {
            substeps: 1,
            iterations: 10,
            timestep: 1.0 / 64.0,
            ..StepConfig::default()
        };
        group.bench_function(BenchmarkId::new("core", format!("cloth_{n}")), |b| {
            b.iter(|| solver.step(&config))
        });
        // The same cloth built directly in the core (row-major particles and sticks): shows
        // what the ECS's slot and stick order costs.
        let mut direct = cloth(n);
        group.bench_function(BenchmarkId::new("core_direct", format!("cloth_{n}")), |b| {
            b.iter(|| direct.step(&config))
        });
    }
    group.finish();
}

criterion_group!(benches, relax, ecs_step);
criterion_main!(benches);
