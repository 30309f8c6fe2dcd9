//! Whole-step timing, headless, for comparing with other crates:
//!
//! ```text
//! cargo run --release --example bench -- cloth --cols 100 --rows 100 --steps 300 --iterations 6 --substeps 1
//! cargo run --release --example bench -- rope --links 10000 --steps 300
//! cargo run --release --example bench -- ragdolls --count 100 --steps 300
//! ```
//!
//! The full plugin runs under `MinimalPlugins`, one 1/64 s fixed step per update (cloth: top
//! row pinned, spacing 0.1 m, g = 9.81 m/s², structural sticks only). It prints one line:
//! particles, sticks, steps, µs per full step (gather + solve + scatter), µs per step of the
//! solver core alone on the same scene (measured in the same run), and the max stretch.
//! `--threads N` sizes Bevy's task pools; the solver itself is single-threaded today.

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::scenes;
use bevy_verlet_physics::solver::StepConfig;
use std::time::Instant;

/// Command-line options.
struct Options {
    scene: String,
    cols: usize,
    rows: usize,
    links: usize,
    count: usize,
    steps: usize,
    iterations: u32,
    substeps: u32,
    threads: Option<usize>,
}

fn parse() -> Result<Options, String> {
    let mut args = std::env::args().skip(1);
    let mut o = Options {
        scene: args.next().unwrap_or_else(|| "cloth".into()),
        cols: 100,
        rows: 100,
        links: 10_000,
        count: 100,
        steps: 300,
        iterations: 6,
        substeps: 1,
        threads: None,
    };
    while let Some(flag) = args.next() {
        let value = args.next().ok_or(format!("{flag} needs a value"))?;
        let number = value
            .parse::<usize>()
            .map_err(|_| format!("{flag}: not a number: {value}"))?;
        match flag.as_str() {
            "--cols" => o.cols = number,
            "--rows" => o.rows = number,
            "--links" => o.links = number,
            "--count" => o.count = number,
            "--steps" => o.steps = number,
            "--iterations" => o.iterations = number as u32,
            "--substeps" => o.substeps = number as u32,
            "--threads" => o.threads = Some(number),
            _ => return Err(format!("unknown option {flag}")),
        }
    }
    Ok(o)
}

fn main() {
    let options = match parse() {
        Ok(options) => options,
        Err(message) => {
            eprintln!(
                "{message}\nusage: bench [cloth|rope|ragdolls] [--cols N --rows N | --links N | --count N] \
                 [--steps N] [--iterations N] [--substeps N] [--threads N]"
            );
            std::process::exit(2);
        }
    };
    let mut app = App::new();
    let task_pool = options
        .threads
        .map_or_else(TaskPoolOptions::default, TaskPoolOptions::with_num_threads);
    app.add_plugins((
        MinimalPlugins.set(TaskPoolPlugin {
            task_pool_options: task_pool,
        }),
        VerletPlugin::default(),
    ))
    .insert_resource(TimeUpdateStrategy::FixedTimesteps(1))
    .insert_resource(VerletConfig {
        substeps: options.substeps,
        iterations: options.iterations,
        ..VerletConfig::default()
    });
    let world = app.world_mut();
    let mut commands = world.commands();
    match options.scene.as_str() {
        "cloth" => {
            ClothBuilder::new(Vec3::ZERO, options.cols, options.rows, 0.1)
                .pin_top_row(1)
                .spawn(&mut commands);
        }
        "rope" => {
            let length = options.links as f32 * 0.01;
            RopeBuilder::new(Vec3::ZERO, Vec3::new(length, 0.0, 0.0), options.links)
                .pin_start()
                .spawn(&mut commands);
        }
        "ragdolls" => {
            app.insert_resource(Gravity::PIXELS);
            let mut commands = app.world_mut().commands();
            scenes::ragdolls(&mut commands, options.count);
        }
        other => {
            eprintln!("unknown scene {other}: cloth, rope or ragdolls");
            std::process::exit(2);
        }
    }
    app.world_mut().flush();
    // The first update starts the clock; the second gathers the scene (topology build).
    app.update();
    app.update();
    let started = Instant::now();
    for _ in 0..options.steps {
        app.update();
    }
    let full = started.elapsed().as_secs_f64() * 1e6 / options.steps as f64;

    // The solver core alone on the same scene, in the same run.
    let world = app.world();
    let mut solver = world.resource::<VerletState>().solver.clone();
    let config = StepConfig {
        timestep: world.resource::<Time<Fixed>>().timestep().as_secs_f64(),
        substeps: options.substeps,
        iterations: options.iterations,
        gravity: world.resource::<Gravity>().0.as_dvec3(),
        damping: 0.0,
        sleep: None,
    };
    let started = Instant::now();
    for _ in 0..options.steps {
        solver.step(&config);
    }
    let core = started.elapsed().as_secs_f64() * 1e6 / options.steps as f64;

    let state = app.world().resource::<VerletState>();
    let sticks = &state.solver.sticks;
    let max_stretch = (0..sticks.len())
        .map(|i| sticks.strain(i, &state.solver.particles))
        .fold(0.0, f64::max);
    println!(
        "{} particles {} sticks {} steps {:.1} µs/step (core {:.1} µs/step, ECS overhead {:.2}×) max stretch {:.3} %",
        state.solver.particles.len(),
        sticks.len(),
        options.steps,
        full,
        core,
        full / core,
        max_stretch * 100.0,
    );
}
