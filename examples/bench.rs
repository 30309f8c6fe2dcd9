//! Whole-step timing, headless, for comparing with other crates:
//!
//! ```text
//! cargo run --release --example bench -- cloth --cols 100 --rows 100 --steps 300 --iterations 6 --substeps 1
//! cargo run --release --example bench -- rope --links 10000 --steps 300
//! cargo run --release --example bench -- ragdolls --count 100 --steps 300
//! cargo run --release --example bench -- ropes --count 1000 --links 1 --steps 300 --threads 1
//! cargo run --release --example bench -- sleeping --count 100 --steps 120
//! cargo run --release --example bench -- torn --substeps 8 --iterations 1 --steps 400
//! ```
//!
//! The full plugin runs under `MinimalPlugins`, one 1/64 s fixed step per update (cloth: top
//! row pinned, spacing 0.1 m, g = 9.81 m/s², structural sticks only). It prints one line:
//! particles, sticks, steps, µs per full step (gather + solve + scatter), µs per step of the
//! solver core alone on the same scene (measured in the same run), and the max stretch.
//! The line ends with Bevy's own cost against the plugin's, measured in the same run in three
//! interleaved rounds of `--steps` updates (the fastest round of each counts): an app with
//! `MinimalPlugins` alone, the same with `VerletPlugin` and no particles (the idle plugin's
//! cost), and the scene (whose update minus the bare app's should be close to gather + solve +
//! scatter).
//! `avian` (needs `--features avian2d`) times a cloth draped over an avian ball with the
//! coupling against the same cloth over the crate's own sphere collider, both with avian
//! running, and prints the coupling's extra cost per step; `--pebbles N` adds N small static
//! colliders in a row under the cloth (many colliders near one cloth).
//! `torn` cuts the cloth example's curtain into 100 patches in place and compares its solve
//! with the intact curtain's, before and after the next topology rebuild (sleeping off).
//! `--method sweep|lines|hierarchy` forces a [`SolveMethod`]; `--corners 1` hangs the cloth by its
//! two top corners instead of its top row.
//! `--line-substeps N` sets `VerletConfig::line_substeps` (ropes and chains, solved by lines,
//! take N substeps; cloth keeps `--substeps`).
//! `--threads N` runs the solver on N threads (`1`: serial; default: every core);
//! `--tether-anchors N` sets `VerletConfig::tether_anchors` (scenes with tethers). `sleeping` lets
//! `--count` ragdolls fall asleep, drops one more among them and compares its cost with that
//! ragdoll dropped alone. `ropes` hangs `--count` ropes of `--links` links of 1 cm side by side,
//! each from a pin, released at 45° (many small islands: `--links 1` makes pendulums).

use bevy::prelude::*;
use bevy::tasks::ComputeTaskPool;
use bevy::time::TimeUpdateStrategy;
use bevy_verlet_physics::TaskPoolExecutor;
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::scenes;
use bevy_verlet_physics::solver::{Executor, Serial, StepConfig};
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
    /// `VerletConfig::line_substeps` (0: `None`).
    line_substeps: u32,
    threads: Option<usize>,
    tether_anchors: u32,
    method: SolveMethod,
    corners: bool,
    pebbles: usize,
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
        line_substeps: 0,
        threads: None,
        tether_anchors: VerletConfig::default().tether_anchors,
        method: SolveMethod::default(),
        corners: false,
        pebbles: 0,
    };
    while let Some(flag) = args.next() {
        let value = args.next().ok_or(format!("{flag} needs a value"))?;
        if flag == "--method" {
            o.method = match value.as_str() {
                "auto" => SolveMethod::Auto,
                "sweep" => SolveMethod::Sweep,
                "lines" => SolveMethod::Lines,
                "hierarchy" => SolveMethod::Hierarchy,
                _ => {
                    return Err(format!(
                        "--method: auto, sweep, lines or hierarchy, not {value}"
                    ));
                }
            };
            continue;
        }
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
            "--line-substeps" => o.line_substeps = number as u32,
            "--threads" => o.threads = Some(number),
            "--tether-anchors" => o.tether_anchors = number as u32,
            "--corners" => o.corners = number != 0,
            "--pebbles" => o.pebbles = number,
            _ => return Err(format!("unknown option {flag}")),
        }
    }
    Ok(o)
}

/// A headless app without the plugin (`MinimalPlugins` only), one fixed step per update,
/// `threads` as asked.
fn bare_app(options: &Options) -> App {
    let mut task_pools = TaskPoolOptions::default();
    if let Some(threads) = options.threads.filter(|&n| n > 1) {
        // The thread running the schedule helps the compute pool, so N threads = N − 1 workers.
        task_pools.compute.min_threads = threads - 1;
        task_pools.compute.max_threads = threads - 1;
    }
    let mut app = App::new();
    app.add_plugins(MinimalPlugins.set(TaskPoolPlugin {
        task_pool_options: task_pools,
    }))
    .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
    app
}

/// [`bare_app`] with the plugin.
fn new_app(options: &Options) -> App {
    let mut app = bare_app(options);
    app.add_plugins(VerletPlugin::default())
        .insert_resource(VerletConfig {
            substeps: options.substeps,
            iterations: options.iterations,
            parallel: options.threads != Some(1),
            tether_anchors: options.tether_anchors,
            method: options.method,
            line_substeps: (options.line_substeps > 0).then_some(options.line_substeps),
            ..VerletConfig::default()
        });
    app
}

/// Runs `steps` updates and returns the mean µs per update.
fn time_steps(app: &mut App, steps: usize) -> f64 {
    let started = Instant::now();
    for _ in 0..steps {
        app.update();
    }
    started.elapsed().as_secs_f64() * 1e6 / steps as f64
}

/// Mean µs per update, and of the plugin's gather, solve and scatter ([`VerletStats`]).
struct Timing {
    update: f64,
    gather: f64,
    solve: f64,
    scatter: f64,
}

/// Runs `steps` updates and times them.
fn time_steps_and_plugin(app: &mut App, steps: usize) -> Timing {
    let mut sums = [0.0; 3];
    let started = Instant::now();
    for _ in 0..steps {
        app.update();
        let stats = app.world().resource::<VerletStats>();
        let parts = [
            stats.gather_micros,
            stats.solve_micros,
            stats.scatter_micros,
        ];
        for (sum, part) in sums.iter_mut().zip(parts) {
            *sum += part as f64;
        }
    }
    let steps = steps as f64;
    Timing {
        update: started.elapsed().as_secs_f64() * 1e6 / steps,
        gather: sums[0] / steps,
        solve: sums[1] / steps,
        scatter: sums[2] / steps,
    }
}

/// Spawns with commands and applies them.
fn spawn<T>(app: &mut App, f: impl FnOnce(&mut Commands) -> T) -> T {
    let world = app.world_mut();
    let out = f(&mut world.commands());
    world.flush();
    out
}

/// Where the moving ragdoll of the `sleeping` scene is dropped from.
const DROP: Vec3 = Vec3::new(0.0, 200.0, 0.0);

/// `count` ragdolls left to fall asleep, then one more dropped among them, against that one
/// ragdoll dropped alone: sleeping islands should cost close to nothing.
fn sleeping(options: &Options) {
    let mut crowd = new_app(options);
    crowd.insert_resource(Gravity::PIXELS);
    spawn(&mut crowd, |c| scenes::ragdolls(c, options.count));
    let mut settle = 0;
    crowd.update();
    while crowd.world().resource::<VerletStats>().sleeping_islands < options.count
        && settle < 64 * 60
    {
        crowd.update();
        settle += 1;
    }
    let asleep = crowd.world().resource::<VerletStats>().sleeping_islands;
    spawn(&mut crowd, |c| scenes::spawn_ragdoll(c, DROP, false));
    crowd.update();
    let with_crowd = time_steps_and_plugin(&mut crowd, options.steps);

    let mut alone = new_app(options);
    alone.insert_resource(Gravity::PIXELS);
    spawn(&mut alone, |c| {
        c.spawn(scenes::window_bounds(0.0, 0.6));
        scenes::spawn_ragdoll(c, DROP, false)
    });
    alone.update();
    alone.update();
    let single = time_steps_and_plugin(&mut alone, options.steps);
    let plugin = |t: &Timing| t.gather + t.solve + t.scatter;
    println!(
        "{} ragdolls ({asleep} asleep after {:.1} s, 1 dropped): {:.1} µs/step, of which the plugin {:.1} µs; the dropped ragdoll alone: {:.1} µs/step, of which the plugin {:.1} µs; ratio {:.2}× (plugin {:.2}×)",
        options.count + 1,
        settle as f64 / 64.0,
        with_crowd.update,
        plugin(&with_crowd),
        single.update,
        plugin(&single),
        with_crowd.update / single.update,
        plugin(&with_crowd) / plugin(&single),
    );
}

/// The cloth example's curtain (100 × 60, tethers, tear strain 1.5) with one bottom particle
/// pinned and dragged 10 px down per step: the cost of the steps in which sticks tore against
/// the quiet ones.
fn tearing(options: &Options) {
    let mut app = new_app(options);
    app.insert_resource(Gravity::PIXELS);
    let curtain = spawn(&mut app, scenes::curtain);
    app.update();
    app.update();
    let (columns, rows, _) = scenes::CURTAIN;
    let grip = curtain.particles[(rows - 1) * columns + columns / 2];
    let start = app
        .world()
        .get::<Particle>(grip)
        .expect("a particle")
        .position;
    app.world_mut().entity_mut(grip).insert(Pin::at(start));
    app.update();
    let rebuilds = app.world().resource::<VerletStats>().rebuilds;
    let (mut quiet, mut tearing) = (Vec::new(), Vec::new());
    for n in 1..=options.steps {
        let target = start - Vec3::Y * 10.0 * n as f32;
        app.world_mut()
            .get_mut::<Pin>(grip)
            .expect("a pin")
            .set_position(target);
        let torn = app.world().resource::<VerletStats>().torn_total;
        let started = Instant::now();
        app.update();
        let micros = started.elapsed().as_secs_f64() * 1e6;
        let tore = app.world().resource::<VerletStats>().torn_total > torn;
        if tore { &mut tearing } else { &mut quiet }.push(micros);
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    let stats = app.world().resource::<VerletStats>();
    println!(
        "tearing curtain, {} steps: {} quiet steps {:.0} µs (max {:.0}); {} steps with tears {:.0} µs (max {:.0}), ratio {:.2}×; {} sticks torn, {} rebuilds",
        options.steps,
        quiet.len(),
        mean(&quiet),
        max(&quiet),
        tearing.len(),
        mean(&tearing),
        max(&tearing),
        mean(&tearing) / mean(&quiet),
        stats.torn_total,
        stats.rebuilds - rebuilds,
    );
}

/// Mean solve µs per step over `steps` updates.
fn mean_solve(app: &mut App, steps: usize) -> f64 {
    time_steps_and_plugin(app, steps).solve
}

/// The cloth example's curtain cut into 10 × 10 patches (every 10th column and 6th row of sticks
/// cut in place, as a knife does): the solve per step intact, torn before the next topology
/// rebuild, and torn after it (where the patches are islands of their own).
fn torn(options: &Options) {
    let mut app = new_app(options);
    app.insert_resource(Gravity::PIXELS);
    // Awake throughout, so the three phases do the same work per stick.
    app.world_mut().resource_mut::<VerletConfig>().sleeping = Sleeping::Never;
    let curtain = spawn(&mut app, scenes::curtain);
    for _ in 0..32 {
        app.update();
    }
    let intact = mean_solve(&mut app, options.steps);
    let (columns, _, _) = scenes::CURTAIN;
    let grid: std::collections::HashMap<Entity, usize> = curtain
        .particles
        .iter()
        .enumerate()
        .map(|(i, &e)| (e, i))
        .collect();
    let world = app.world_mut();
    let mut cut = Vec::new();
    {
        let state = world.resource::<VerletState>();
        for (i, ends) in state.solver.sticks.ends().iter().enumerate() {
            let [a, b] = ends.map(|p| state.particle_entity(p as usize).and_then(|e| grid.get(&e)));
            let (Some(&a), Some(&b)) = (a, b) else {
                continue;
            };
            let (low, high) = (a.min(b), a.max(b));
            let (row, column) = (low / columns, low % columns);
            let across = high == low + 1 && column % 10 == 9;
            let down = high == low + columns && row % 6 == 5;
            if across || down {
                cut.push(i);
            }
        }
    }
    let mut torn_sticks = 0;
    let started = Instant::now();
    for i in cut {
        let message = world.resource_mut::<VerletState>().cut_stick(i);
        if let Some(message) = message {
            world.entity_mut(message.stick).despawn();
            torn_sticks += 1;
        }
    }
    app.update();
    let cut_micros = started.elapsed().as_secs_f64() * 1e6;
    let rebuilds = app.world().resource::<VerletStats>().rebuilds;
    let before_rebuild = mean_solve(&mut app, options.steps);
    assert_eq!(
        rebuilds,
        app.world().resource::<VerletStats>().rebuilds,
        "no rebuild yet"
    );
    app.world_mut().resource_mut::<VerletState>().mark_dirty();
    app.update();
    let islands = app
        .world()
        .resource::<VerletState>()
        .solver
        .islands
        .list
        .len();
    let after_rebuild = mean_solve(&mut app, options.steps);
    println!(
        "torn curtain, {} × {}: solve intact {intact:.0} µs/step; {torn_sticks} sticks cut (with the next update: {:.1} ms): {before_rebuild:.0} µs before a rebuild ({:.2}×), {after_rebuild:.0} µs after it ({islands} islands, {:.2}×)",
        options.substeps,
        options.iterations,
        cut_micros / 1e3,
        before_rebuild / intact,
        after_rebuild / intact,
    );
}

fn main() {
    let options = match parse() {
        Ok(options) => options,
        Err(message) => {
            eprintln!(
                "{message}\nusage: bench [cloth|rope|ropes|ragdolls|sleeping|tearing|torn|avian] [--cols N --rows N | --links N | --count N | --pebbles N] \
                 [--steps N] [--iterations N] [--substeps N] [--line-substeps N] [--threads N] [--method auto|sweep|lines|hierarchy] [--corners 1]"
            );
            std::process::exit(2);
        }
    };
    if options.scene == "sleeping" {
        sleeping(&options);
        return;
    }
    if options.scene == "tearing" {
        tearing(&options);
        return;
    }
    if options.scene == "torn" {
        torn(&options);
        return;
    }
    if options.scene == "avian" {
        #[cfg(feature = "avian2d")]
        avian::compare(&options);
        #[cfg(not(feature = "avian2d"))]
        eprintln!("the avian scene needs --features avian2d");
        return;
    }
    let mut app = new_app(&options);
    match options.scene.as_str() {
        "cloth" => {
            spawn(&mut app, |c| {
                let cloth = ClothBuilder::new(Vec3::ZERO, options.cols, options.rows, 0.1);
                match options.corners {
                    true => cloth.pin_top_corners().spawn(c),
                    false => cloth.pin_top_row(1).spawn(c),
                }
            });
        }
        "rope" => {
            let length = options.links as f32 * 0.01;
            spawn(&mut app, |c| {
                RopeBuilder::new(Vec3::ZERO, Vec3::new(length, 0.0, 0.0), options.links)
                    .pin_start()
                    .spawn(c)
            });
        }
        "ragdolls" => {
            app.insert_resource(Gravity::PIXELS);
            spawn(&mut app, |c| scenes::ragdolls(c, options.count));
        }
        "ropes" => {
            let length = options.links as f32 * 0.01;
            spawn(&mut app, |c| {
                for k in 0..options.count {
                    let start = Vec3::new(k as f32 * 2.0 * length, 0.0, 0.0);
                    let end = start + Vec3::new(1.0, -1.0, 0.0) * (length / 2f32.sqrt());
                    RopeBuilder::new(start, end, options.links)
                        .pin_start()
                        .spawn(c);
                }
            });
        }
        other => {
            eprintln!("unknown scene {other}: cloth, rope, ropes, ragdolls or sleeping");
            std::process::exit(2);
        }
    }
    // The first update starts the clock; the second gathers the scene (topology build).
    app.update();
    app.update();
    // Bevy alone, Bevy + the idle plugin, and the scene, interleaved; the fastest round counts.
    let mut bare = bare_app(&options);
    let mut idle = new_app(&options);
    bare.update();
    idle.update();
    let mut best = [f64::INFINITY; 2];
    let mut t = None::<Timing>;
    for _ in 0..3 {
        best[0] = best[0].min(time_steps(&mut bare, options.steps));
        best[1] = best[1].min(time_steps(&mut idle, options.steps));
        let round = time_steps_and_plugin(&mut app, options.steps);
        if t.as_ref().is_none_or(|t| round.update < t.update) {
            t = Some(round);
        }
    }
    let (t, [bevy, idle]) = (t.expect("three rounds"), best);

    // The solver core alone on the same scene, in the same run, on the same threads.
    let world = app.world();
    let mut solver = world.resource::<VerletState>().solver.clone();
    let config = StepConfig {
        timestep: world.resource::<Time<Fixed>>().timestep().as_secs_f64(),
        substeps: options.substeps,
        iterations: options.iterations,
        gravity: world.resource::<Gravity>().0.as_dvec3(),
        damping: 0.0,
        sleep: None,
        shake: true,
        symmetric_mass_ratio: world.resource::<VerletConfig>().symmetric_mass_ratio as f64,
        line_substeps: world.resource::<VerletConfig>().line_substeps,
    };
    let pool = ComputeTaskPool::get();
    let executor: &dyn Executor = if options.threads == Some(1) {
        &Serial
    } else {
        &TaskPoolExecutor(pool)
    };
    let started = Instant::now();
    for _ in 0..options.steps {
        solver.step_with(&config, executor);
    }
    let core = started.elapsed().as_secs_f64() * 1e6 / options.steps as f64;

    let state = app.world().resource::<VerletState>();
    let sticks = &state.solver.sticks;
    let max_stretch = (0..sticks.len())
        .map(|i| sticks.strain(i, &state.solver.particles))
        .fold(0.0, f64::max);
    let plugin = t.gather + t.solve + t.scatter;
    println!(
        "{} particles {} sticks {} steps {:.1} µs/step: gather {:.1} + solve {:.1} + scatter {:.1} µs (ECS overhead {:.2}×; core alone {:.1} µs/step) max stretch {:.3} % threads {} | Bevy alone {bevy:.1} µs/update; + VerletPlugin, no particles: {idle:.1} µs (+{:.1}); + the scene: {:.1} µs (+{:.1} = gather + solve + scatter {:+.1} %)",
        state.solver.particles.len(),
        sticks.len(),
        options.steps,
        t.update,
        t.gather,
        t.solve,
        t.scatter,
        plugin / t.solve,
        core,
        max_stretch * 100.0,
        executor.threads(),
        idle - bevy,
        t.update,
        t.update - bevy,
        ((t.update - bevy) / plugin - 1.0) * 100.0,
    );
}

/// The `avian` scene: the coupling's cost against the crate's own collider.
#[cfg(feature = "avian2d")]
mod avian {
    use super::{Options, new_app, spawn, time_steps};
    use avian2d::prelude::*;
    use bevy::prelude::*;
    use bevy_verlet_physics::avian2d::{AvianCouplingStats, VerletAvianPlugin};
    use bevy_verlet_physics::prelude::*;

    /// The cloth (top row pinned, 0.1 m cells) above a 1 m ball, with avian running; the ball is
    /// an avian collider (`coupled`) or a `VerletCollider` sphere.
    fn app(options: &Options, coupled: bool) -> App {
        let mut app = new_app(options);
        app.add_plugins((TransformPlugin, PhysicsPlugins::default()));
        if coupled {
            app.add_plugins(VerletAvianPlugin);
        }
        app.finish();
        app.cleanup();
        let width = options.cols as f32 * 0.1;
        let centre = Vec3::new(width / 2.0, -1.5, 0.0);
        spawn(&mut app, |c| {
            let pebbles = (0..options.pebbles).map(|i| {
                let x = width * (i as f32 + 0.5) / options.pebbles as f32;
                (Vec3::new(x, -0.4, 0.0), 0.04)
            });
            for (at, radius) in std::iter::once((centre, 1.0)).chain(pebbles) {
                let place = Transform::from_translation(at);
                if coupled {
                    c.spawn((RigidBody::Static, Collider::circle(radius), place));
                } else {
                    c.spawn((VerletCollider::sphere(radius), place));
                }
            }
            ClothBuilder::new(Vec3::ZERO, options.cols, options.rows, 0.1)
                .pin_top_row(1)
                .spawn(c)
        });
        app.update();
        app.update();
        app
    }

    /// Prints µs per update of both apps (fastest of three interleaved rounds).
    pub fn compare(options: &Options) {
        let mut own = app(options, false);
        let mut coupled = app(options, true);
        let mut best = [f64::INFINITY; 2];
        for _ in 0..3 {
            best[0] = best[0].min(time_steps(&mut own, options.steps));
            best[1] = best[1].min(time_steps(&mut coupled, options.steps));
        }
        let stats = *coupled.world().resource::<AvianCouplingStats>();
        let particles = coupled
            .world()
            .resource::<VerletState>()
            .solver
            .particles
            .len();
        println!(
            "{particles} particles, avian running in both: own sphere collider {:.1} µs/update; avian ball coupled {:.1} µs/update (+{:.1} µs, {} contacts in the last step, {} colliders gathered)",
            best[0],
            best[1],
            best[1] - best[0],
            stats.contacts,
            stats.colliders,
        );
    }
}
