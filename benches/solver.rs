//! Criterion benchmarks, `cargo bench --bench solver`; compare lines within one group (their
//! ratio is measured in the same run):
//!
//! * `relax_sweep`: one sweep of the solver core (`core`: the solver's relax phase, rigid batches
//!   on their fast path; `core_general`: `relax_sticks`, every stick kind and compliance) against a
//!   bare reference loop (the same math on plain arrays, nothing else), on cloth grids of 32²,
//!   128², 512² particles and a 10 000-link rope; plus two variants of the bare loop: `bare_lanes` (four independent sticks at a time,
//!   lane arrays that LLVM vectorises) and `bare_2d` (2D positions).
//! * `lines_step`: a full core step (8 × 1) of a 100-link rope hanging at rest and of a 64 × 64
//!   cloth hanging from its top row, swept (`Method::Sweep`) against solved by lines
//!   (`Method::Lines`, SHAKE) — the cost of exactness at the same substeps.
//! * `parallel_step_10_iterations`: a full core step on one thread and on Bevy's compute pool.
//! * `fixed_step_10_iterations`: a whole `app.update()` with the plugin against the core alone.

use bevy::prelude::*;
use bevy::tasks::ComputeTaskPool;
use bevy::time::TimeUpdateStrategy;
use bevy_verlet_physics::TaskPoolExecutor;
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::solver::{
    GlobalSubstep, Method, Serial, Solver, StepConfig, StickKind, relax_sticks,
};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::{DVec2, DVec3};
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

/// A rope of `links` links pinned at one end, laid along `direction`.
fn rope_along(links: usize, direction: DVec3) -> Solver {
    let mut solver = Solver::default();
    for i in 0..=links {
        solver.add_particle(direction * (i as f64 * 0.01), 1.0);
    }
    for i in 0..links as u32 {
        solver
            .sticks
            .push([i, i + 1], 0.01, 0.0, StickKind::Equal, f64::INFINITY, 0);
    }
    solver.pin(0, DVec3::ZERO);
    solver
}

/// A rope of `links` links pinned at one end, horizontal.
fn rope(links: usize) -> Solver {
    rope_along(links, DVec3::X)
}

/// The bare reference: rigid PBD stick projection on plain arrays.
struct Bare {
    position: Vec<DVec3>,
    position_2d: Vec<DVec2>,
    inverse_mass: Vec<f64>,
    sticks: Vec<(u32, u32, f64)>,
    /// Stick ranges whose sticks share no particle (the solver's colour batches).
    independent: Vec<std::ops::Range<usize>>,
}

impl Bare {
    fn from(solver: &Solver) -> Self {
        Self {
            position: solver.particles.position.clone(),
            position_2d: solver
                .particles
                .position
                .iter()
                .map(|p| p.truncate())
                .collect(),
            inverse_mass: solver.particles.inverse_mass.clone(),
            sticks: (0..solver.sticks.len())
                .map(|i| {
                    let [a, b] = solver.sticks.ends()[i];
                    (a, b, solver.sticks.rest_length[i])
                })
                .collect(),
            independent: solver
                .islands
                .batches
                .iter()
                .filter(|b| b.independent)
                .map(|b| b.sticks.start as usize..b.sticks.end as usize)
                .collect(),
        }
    }

    /// The same sweep with 2D positions (16 bytes instead of 24).
    fn relax_2d(&mut self) {
        let p = &mut self.position_2d;
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

    /// The same sweep over the colour batches, four independent sticks at a time: gather into
    /// lane arrays, compute lane-wise (LLVM vectorises it with the target's SIMD), scatter.
    // (Lane loops index several arrays by lane on purpose: that is what vectorises.)
    #[allow(clippy::needless_range_loop)]
    fn relax_lanes(&mut self) {
        const L: usize = 4;
        let p = &mut self.position;
        let w = &self.inverse_mass;
        for batch in &self.independent {
            let mut i = batch.start;
            while i + L <= batch.end {
                let mut lanes = [[0.0f64; L]; 9]; // dx dy dz wa wb rest ...
                for k in 0..L {
                    let (a, b, rest) = self.sticks[i + k];
                    let (a, b) = (a as usize, b as usize);
                    let d = p[a] - p[b];
                    lanes[0][k] = d.x;
                    lanes[1][k] = d.y;
                    lanes[2][k] = d.z;
                    lanes[3][k] = w[a];
                    lanes[4][k] = w[b];
                    lanes[5][k] = rest;
                }
                let mut scale = [0.0f64; L];
                for k in 0..L {
                    let length = (lanes[0][k] * lanes[0][k]
                        + lanes[1][k] * lanes[1][k]
                        + lanes[2][k] * lanes[2][k])
                        .sqrt();
                    let ws = lanes[3][k] + lanes[4][k];
                    let ok = ws > 0.0 && length >= 1e-12;
                    scale[k] = if ok {
                        (lanes[5][k] - length) / (ws * length)
                    } else {
                        0.0
                    };
                }
                for k in 0..L {
                    let (a, b, _) = self.sticks[i + k];
                    let c = DVec3::new(lanes[0][k], lanes[1][k], lanes[2][k]) * scale[k];
                    p[a as usize] += c * lanes[3][k];
                    p[b as usize] -= c * lanes[4][k];
                }
                i += L;
            }
            for &(a, b, rest) in &self.sticks[i..batch.end] {
                let (a, b) = (a as usize, b as usize);
                let (wa, wb) = (w[a], w[b]);
                let delta = p[a] - p[b];
                let length = delta.length();
                if wa + wb <= 0.0 || length < 1e-12 {
                    continue;
                }
                let correction = delta * ((rest - length) / ((wa + wb) * length));
                p[a] += correction * wa;
                p[b] -= correction * wb;
            }
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
        // Organized as the plugin does (colour batches for the cloths), then sagged a little so
        // the sticks have work to do.
        solver.organize();
        let config = StepConfig::default();
        for _ in 0..4 {
            solver.step(&config);
        }
        let mut bare = Bare::from(&solver);
        group.throughput(Throughput::Elements(solver.sticks.len() as u64));
        // The solver's own sweep: one relax phase of one substep, 1 iteration, one thread.
        let sweep = StepConfig {
            substeps: 1,
            iterations: 1,
            ..StepConfig::default()
        };
        let count = solver.begin_step(&sweep);
        let substep = GlobalSubstep {
            config: sweep,
            index: 1,
            count,
            plain: false,
        };
        group.bench_function(BenchmarkId::new("core", name), |b| {
            b.iter(|| solver.relax_substep(&substep, &Serial))
        });
        group.bench_function(BenchmarkId::new("core_general", name), |b| {
            b.iter(|| relax_sticks(&mut solver.particles, &mut solver.sticks, 1.0 / 64.0, false))
        });
        group.bench_function(BenchmarkId::new("bare", name), |b| b.iter(|| bare.relax()));
        if !bare.independent.is_empty() {
            group.bench_function(BenchmarkId::new("bare_lanes", name), |b| {
                b.iter(|| bare.relax_lanes())
            });
            group.bench_function(BenchmarkId::new("bare_2d", name), |b| {
                b.iter(|| bare.relax_2d())
            });
        }
        black_box((&bare.position, &bare.position_2d));
    }
    group.finish();
}

/// A full fixed step with 10 iterations: the ECS plugin (a whole `app.update()`: Bevy's
/// scheduling, gather, solve, scatter) vs the core, both on Bevy's compute pool.
fn ecs_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("fixed_step_10_iterations");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_millis(500));
    for n in [32, 128, 512] {
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
        let pool = TaskPoolExecutor(ComputeTaskPool::get());
        group.bench_function(BenchmarkId::new("core", format!("cloth_{n}")), |b| {
            b.iter(|| solver.step_with(&config, &pool))
        });
    }
    group.finish();
}

/// A full core step (1 × 10) on one thread and on Bevy's compute pool (all cores): one large
/// cloth (colour batches split across threads) and many small islands (islands spread).
fn parallel(c: &mut Criterion) {
    let mut group = c.benchmark_group("parallel_step_10_iterations");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_millis(500));
    // Bevy's default pools (on 2 cores: one compute worker, plus the calling thread).
    TaskPoolOptions::default().create_default_pools();
    let pool = TaskPoolExecutor(ComputeTaskPool::get());
    let mut ropes = Solver::default();
    for r in 0..400 {
        let start = ropes.particles.len() as u32;
        for i in 0..=100 {
            ropes.add_particle(DVec3::new(i as f64 * 0.01, 0.0, r as f64), 1.0);
        }
        for i in 0..100 {
            ropes.sticks.push(
                [start + i, start + i + 1],
                0.01,
                0.0,
                StickKind::Equal,
                f64::INFINITY,
                0,
            );
        }
        ropes.pin(start, ropes.particles.position[start as usize]);
    }
    let scenes = [
        ("cloth_128", cloth(128)),
        ("cloth_256", cloth(256)),
        ("cloth_512", cloth(512)),
        ("ropes_400x100", ropes),
    ];
    let config = StepConfig {
        substeps: 1,
        iterations: 10,
        ..StepConfig::default()
    };
    for (name, mut solver) in scenes {
        solver.organize();
        group.throughput(Throughput::Elements(solver.sticks.len() as u64 * 10));
        let mut threaded = solver.clone();
        group.bench_function(BenchmarkId::new("serial", name), |b| {
            b.iter(|| solver.step_with(&config, &Serial))
        });
        group.bench_function(BenchmarkId::new("pool", name), |b| {
            b.iter(|| threaded.step_with(&config, &pool))
        });
    }
    group.finish();
}

fn lines_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("lines_step");
    group.measurement_time(Duration::from_secs(3));
    let config = StepConfig::default();
    for name in ["rope_100_hanging", "cloth_64_hanging"] {
        for method in [Method::Sweep, Method::Lines] {
            let mut solver = if name.starts_with("rope") {
                rope_along(100, DVec3::NEG_Y)
            } else {
                cloth(64)
            };
            solver.method = method;
            solver.organize();
            // Settle first, so the measured steps are the steady state.
            for _ in 0..64 {
                solver.step(&config);
            }
            let id = BenchmarkId::new(format!("{method:?}").to_lowercase(), name);
            group.bench_function(id, |b| b.iter(|| solver.step(black_box(&config))));
        }
    }
    group.finish();
}

criterion_group!(benches, relax, lines_step, parallel, ecs_step);
criterion_main!(benches);
