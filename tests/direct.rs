//! The direct line solve and SHAKE (issue "Solver 2"), on the solver core alone, at the default
//! budget (1/64 s steps, 8 substeps × 1 round): stiff chains whatever the mass ratio, and
//! pendulums that keep their energy. Before (Gauss–Seidel sweeps, position projection) figures
//! are in each test's doc comment; each test also runs the sweep to show the difference is real.

use bevy_verlet_physics::solver::{Method, Solver, StepConfig, StickKind};
use glam::DVec3;

mod chain;
mod grid;
mod random;

use chain::chain_along;
use random::Scan;

const G: f64 = 9.81;

/// A chain of `links` rigid sticks from a pin at the origin, along `direction`, `length` long;
/// the last particle has `tip_ratio` × the mass of the others (1 kg).
fn chain(links: usize, length: f64, direction: DVec3, tip_ratio: f64, method: Method) -> Solver {
    let mut solver = Solver::default();
    solver.method = method;
    chain_along(&mut solver, (links, length), tip_ratio, direction);
    solver.organize();
    solver
}

fn config(damping: f64, shake: bool) -> StepConfig {
    StepConfig {
        damping,
        shake,
        ..StepConfig::default()
    }
}

/// `solver` with every stick made a rope link (`AtMost`), reorganised.
fn as_rope(mut solver: Solver) -> Solver {
    solver.sticks.kind.fill(StickKind::AtMost);
    solver.organize();
    solver
}

/// Largest link stretch `length/rest − 1` (a rope link may go slack).
fn max_stretch(solver: &Solver) -> f64 {
    (0..solver.sticks.len())
        .map(|i| solver.sticks.strain(i, &solver.particles))
        .fold(0.0, f64::max)
}

/// Largest link strain `|length/rest − 1|`.
fn max_strain(solver: &Solver) -> f64 {
    (0..solver.sticks.len())
        .map(|i| solver.sticks.strain(i, &solver.particles).abs())
        .fold(0.0, f64::max)
}

/// Steps `solver` `steps` times; the largest link strain after any step.
fn largest_strain_over(solver: &mut Solver, config: &StepConfig, steps: usize) -> f64 {
    largest_over(solver, config, steps, max_strain)
}

/// Steps `solver` `steps` times; the largest `measure` after any step.
fn largest_over(
    solver: &mut Solver,
    config: &StepConfig,
    steps: usize,
    measure: fn(&Solver) -> f64,
) -> f64 {
    (0..steps)
        .map(|_| {
            solver.step(config);
            measure(solver)
        })
        .fold(0.0, f64::max)
}

/// Total length over total rest length, minus 1.
fn total_stretch(solver: &Solver) -> f64 {
    let (mut length, mut rest) = (0.0, 0.0);
    for i in 0..solver.sticks.len() {
        let [a, b] = solver.sticks.ends()[i].map(|p| p as usize);
        length += (solver.particles.position[a] - solver.particles.position[b]).length();
        rest += solver.sticks.rest_length[i];
    }
    length / rest - 1.0
}

/// Mechanical energy at the middle of the last substep `h`: kinetic from `(x − x*)/h`,
/// potential at `(x + x*)/2` (both second-order accurate there).
fn energy(solver: &Solver, h: f64) -> f64 {
    let p = &solver.particles;
    (0..p.len())
        .filter(|&i| p.inverse_mass[i] > 0.0)
        .map(|i| {
            let m = 1.0 / p.inverse_mass[i];
            let v = (p.position[i] - p.previous[i]) / h;
            let y = 0.5 * (p.position[i].y + p.previous[i].y);
            m * (0.5 * v.length_squared() + G * y)
        })
        .sum()
}

/// Heavy tip, hanging: 100 links of 1 cm, tip 1000× a link, damping 2/s, 10 s. Total stretch
/// (mean over the last 0.5 s). Measured: sweeps at 8 × 1 196 % (forward and back, as islands
/// whose masses differ more than 8× are swept: `solver::symmetric`; 389 % forward alone); lines
/// below 10⁻⁶ % (goal: below 0.1 %).
#[test]
fn heavy_tip_chain_hangs_unstretched() {
    let mut result = Vec::new();
    for method in [Method::Sweep, Method::Lines] {
        let mut solver = chain(100, 1.0, DVec3::NEG_Y, 1000.0, method);
        let config = config(2.0, true);
        let mut sum = 0.0;
        for n in 0..640 {
            solver.step(&config);
            if n >= 608 {
                sum += total_stretch(&solver) / 32.0;
            }
        }
        println!("{method:?}: hanging total stretch {:.4} %", sum * 100.0);
        result.push(sum);
    }
    assert!(result[0] > 0.1, "the sweep stretches: {}", result[0]);
    assert!(result[1] < 1e-3, "lines: {}", result[1]);
}

/// Heavy tip released from horizontal, no damping, 5 s: largest link strain at any step.
/// Measured: sweeps at 8 × 1 970 % (forward and back; 908 % forward alone); lines below 10⁻⁶ %
/// (goal: below 1 %). Also the cost, in
/// Newton passes (a count, not a time): 7628 (3.0 per substep, a curvature or full Newton pass
/// counted as one) since a projection after a failed SHAKE in a tense line starts with a
/// curvature pass too (`solver::direct::CURVATURE_AFTER_SHAKE_ABOVE`); 10 143 (4.0 per
/// substep; 10 331 before the full Newton rescue)
/// since a substep that begins projected starts with the constraints' curvature
/// (`solver::direct`, module `curvature`); 14 285 (5.6 per substep) since a substep after a
/// SHAKE fallback is projected without trying SHAKE (`LineMode::FellBack`); 16 409 before, when
/// SHAKE was tried every substep but gave up at a pass that did not divide the error by 10;
/// 18 876 when it always spent its three passes.
#[test]
fn heavy_tip_chain_swings_unstretched() {
    let mut result = Vec::new();
    let mut passes = 0;
    for method in [Method::Sweep, Method::Lines] {
        let mut solver = chain(100, 1.0, DVec3::X, 1000.0, method);
        let config = config(0.0, true);
        let worst = largest_strain_over(&mut solver, &config, 320);
        println!(
            "{method:?}: swinging max link strain {:.4} %, {} Newton passes",
            worst * 100.0,
            solver.line_passes()
        );
        result.push(worst);
        passes = solver.line_passes();
    }
    assert!(result[0] > 0.5, "the sweep stretches: {}", result[0]);
    assert!(result[1] < 1e-6, "lines: {}", result[1]);
    assert!(passes < 9_000, "{passes} Newton passes");
}

/// The report's swinging chains (a 100-link chain with a 1000:1 tip, 200 links of equal mass,
/// released from horizontal, no damping, 5 s) at one substep per 1/64 s step: largest link
/// strain below 10⁻⁶ (measured below 10⁻⁹, at 1.16× and 0.97× the time of the 8 × 1 sweep in
/// the report; 2657 and 1724 Newton passes). Before curvature and full Newton passes ran for
/// predictions up to ten link lengths off (`CURVATURE_BELOW` 0.1 instead of 10), the 1000:1
/// chain stretched 7900 % here (the report's 1 × 1 rows: 9773 % and 844 %).
#[test]
fn swinging_chains_stay_unstretched_at_one_substep() {
    let config = StepConfig {
        substeps: 1,
        ..config(0.0, true)
    };
    for (links, length, tip) in [(100, 1.0, 1000.0), (200, 2.0, 1.0)] {
        let mut solver = chain(links, length, DVec3::X, tip, Method::Auto);
        let worst = largest_strain_over(&mut solver, &config, 320);
        println!(
            "{links} links, tip {tip}×, 1 × 1: swinging max link strain {:.2e} %, {} Newton passes",
            worst * 100.0,
            solver.line_passes()
        );
        assert!(worst < 1e-6, "{links} links: {worst}");
    }
}

/// Loads 10⁴, 10⁵ and 10⁶ times a link's mass on a 100-link chain (1 m) and on the three tips
/// of a Y rope, released from horizontal, no damping, 5 s: largest link strain below 10⁻⁶
/// (measured below 10⁻⁹). Gauss–Newton alone does not converge on these: the chain kept up to
/// 40–1000× its links' lengths (10⁵, 10⁶), the Y rope 360–860×; full Newton passes take over
/// where it has not converged after `FULL_NEWTON_AFTER` passes (`solver::direct`).
#[test]
fn extreme_loads_swing_unstretched() {
    for tip in [1e4, 1e5, 1e6] {
        let chain = chain(100, 1.0, DVec3::X, tip, Method::Auto);
        let forked = y_rope(tip, DVec3::X, Method::Auto);
        for (name, mut solver) in [("chain", chain), ("Y rope", forked)] {
            let config = config(0.0, true);
            let worst = largest_strain_over(&mut solver, &config, 320);
            println!(
                "{name} with {tip:e}× loads swinging: max strain {:.2e} %, {} Newton passes",
                worst * 100.0,
                solver.line_passes()
            );
            assert!(solver.particles.all_finite());
            assert!(worst < 1e-6, "{name}, {tip:e}×: max strain {worst}");
        }
    }
}

/// What [`random_heavy_scene`] builds its sticks of besides rigid and rope links, and how
/// many more pins it draws.
#[derive(Clone, Copy)]
struct Mix {
    /// The share of sticks made struts (`AtLeast`).
    struts: f64,
    /// The compliance (m/N) given to half the sticks, 0 for none.
    springs: f64,
    /// Particles pinned where they are besides the first two (drawn at random; one already
    /// pinned is left as it is).
    pins: usize,
}

impl Mix {
    /// Rigid and rope links only.
    const LINKS: Mix = Mix {
        struts: 0.0,
        springs: 0.0,
        pins: 0,
    };
}

/// Scene `seed` of [`random_heavy_chains_and_trees_hit_hard_stay_unstretched`]: 4–43
/// particles joined by 5 cm sticks into a random chain or tree (each particle hung off a random
/// earlier one, in a random direction), 15 % of them `10¹–10^heaviest` times heavier, rigid
/// or (30 %) rope links, pinned at the first particle and (80 %) at a second one whose path to
/// the first is not taut (and at `mix.pins` more where they are); in half the scenes every movable particle is kicked by up to `kick`
/// m/s (`substep` the first step's substep length). `mix` makes some sticks struts or springs
/// (drawing more random numbers only where it does). Returns the solver (organized) and the
/// energy scale `m·g·L` (total mass, total length).
fn random_heavy_scene(
    seed: u64,
    (heaviest, kick): (f64, f64),
    mix: Mix,
    substep: f64,
) -> Option<(Solver, f64)> {
    const LINK: f64 = 0.05;
    let mut r = Scan::of_scene(seed, 12345);
    let n = 4 + r.below(40);
    let chain = r.next() < 0.5;
    let links = if r.next() < 0.3 {
        StickKind::AtMost
    } else {
        StickKind::Equal
    };
    let mut solver = Solver::default();
    let mut depth = vec![0usize];
    solver.add_particle(DVec3::ZERO, 0.0);
    solver.pin(0, DVec3::ZERO);
    for i in 1..n {
        let parent = if chain { i - 1 } else { r.below(i) };
        let at = solver.particles.position[parent] + r.unit() * LINK;
        let heavy = r.next() < 0.15;
        let w = if heavy {
            10f64.powf(-(1.0 + (heaviest - 1.0) * r.next()))
        } else {
            1.0
        };
        solver.add_particle(at, w);
        depth.push(depth[parent] + 1);
        let ends = [parent as u32, i as u32];
        let strut = mix.struts > 0.0 && r.next() < mix.struts;
        let kind = if strut { StickKind::AtLeast } else { links };
        let spring = mix.springs > 0.0 && r.next() < 0.5;
        let compliance = if spring { mix.springs } else { 0.0 };
        solver
            .sticks
            .push(ends, LINK, compliance, kind, f64::INFINITY, 0);
    }
    if r.next() < 0.8 {
        let second = 1 + r.below(n - 1);
        let at = solver.particles.position[second];
        if at.length() > 0.95 * depth[second] as f64 * LINK {
            return None;
        }
        solver.particles.inverse_mass[second] = 0.0;
        solver.pin(second as u32, at);
    }
    for _ in 0..mix.pins {
        let k = 1 + r.below(n - 1);
        if solver.particles.inverse_mass[k] > 0.0 {
            solver.pin(k as u32, solver.particles.position[k]);
        }
    }
    solver.organize();
    if r.next() < 0.5 {
        for i in 0..n {
            if solver.particles.inverse_mass[i] > 0.0 {
                let v = r.unit() * (kick * r.next());
                solver.particles.previous[i] = solver.particles.position[i] - v * substep;
            }
        }
    }
    let p = &solver.particles;
    let mass: f64 = (0..n)
        .filter(|&i| p.inverse_mass[i] > 0.0)
        .map(|i| 1.0 / p.inverse_mass[i])
        .sum();
    Some((solver, mass * G * LINK * (n - 1) as f64))
}

/// The largest violation of a rigid stick's constraint: the stretch of a rope link, the
/// compression of a strut, the strain of any other (a spring's stretch is its own).
fn max_stretch_or_strain(solver: &Solver) -> f64 {
    (0..solver.sticks.len())
        .filter(|&i| solver.sticks.compliance[i] == 0.0)
        .map(|i| {
            let strain = solver.sticks.strain(i, &solver.particles);
            match solver.sticks.kind[i] {
                StickKind::AtMost => strain.max(0.0),
                StickKind::AtLeast => (-strain).max(0.0),
                _ => strain.abs(),
            }
        })
        .fold(0.0, f64::max)
}

/// [`energy`] plus the springs' `½ C²/α`, their lengths at the middle of the last substep
/// (one-sided springs count only where they act).
fn energy_with_springs(solver: &Solver, h: f64) -> f64 {
    let (p, s) = (&solver.particles, &solver.sticks);
    let middle = |i: u32| 0.5 * (p.position[i as usize] + p.previous[i as usize]);
    let elastic: f64 = (0..s.len())
        .filter(|&i| s.compliance[i] > 0.0)
        .map(|i| {
            let [a, b] = s.ends()[i];
            let c = (middle(b) - middle(a)).length() - s.rest_length[i];
            let c = match s.kind[i] {
                StickKind::AtMost => c.max(0.0),
                StickKind::AtLeast => c.min(0.0),
                _ => c,
            };
            0.5 * c * c / s.compliance[i]
        })
        .sum();
    energy(solver, h) + elastic
}

/// Runs [`random_heavy_scene`] for seeds `1..=scenes` for 2 s without damping at `substeps`
/// × 1 (8 unless given): asserts every scene finite, its largest [`max_stretch_or_strain`]
/// below `strain_bound` (1 % unless given) and its energy ([`energy_with_springs`]) never more
/// than 10 % of its scale (`m·g·L` plus the kick's kinetic energy) above its value after the
/// first step. Prints the scenes built, the largest strain and the largest rise.
fn scan_random_heavy_scenes(
    name: &str,
    scenes: u64,
    (kick, heaviest): (f64, f64),
    mix: Mix,
    (substeps, strain_bound): (Option<u32>, Option<f64>),
) {
    let config = StepConfig {
        substeps: substeps.unwrap_or(8),
        ..config(0.0, true)
    };
    scan_random_heavy_scenes_with(
        name,
        (1..=scenes, scenes),
        (kick, heaviest),
        mix,
        &config,
        strain_bound,
    );
}

/// [`scan_random_heavy_scenes`] over `seeds` (of which `expected` should build at least
/// half) under `config`. Returns the steps in which scenes took the step's own substeps, the
/// steps run, and the scenes with at least one such step (see [`run_random_heavy_scene`]).
fn scan_random_heavy_scenes_with(
    name: &str,
    (seeds, expected): (impl IntoIterator<Item = u64>, u64),
    (kick, heaviest): (f64, f64),
    mix: Mix,
    config: &StepConfig,
    strain_bound: Option<f64>,
) -> (u32, u32, usize) {
    let strain_bound = strain_bound.unwrap_or(0.01);
    let (mut built, mut worst, mut worst_rise) = (0, 0.0f64, f64::MIN);
    let (mut full_steps, mut scenes_with_full) = (0, 0);
    let mut failed = Vec::new();
    for seed in seeds {
        let Some((strain, rise, finite, full)) =
            run_random_heavy_scene(seed, (heaviest, kick), mix, config)
        else {
            continue;
        };
        full_steps += full;
        scenes_with_full += usize::from(full > 0);
        if !finite || strain >= strain_bound || rise >= 0.1 {
            failed.push(format!(
                "{seed}: strain {strain:.2e}, rise {rise:.2e}, finite {finite}"
            ));
        }
        (built, worst, worst_rise) = (built + 1, worst.max(strain), worst_rise.max(rise));
    }
    println!(
        "{name}: {built} scenes, max strain {:.2e} %, energy at most {:+.2} % of its scale above its start; {} failed",
        worst * 100.0,
        worst_rise * 100.0,
        failed.len()
    );
    assert!(failed.is_empty(), "{name}, failed scenes: {failed:#?}");
    assert!(
        built >= expected as usize / 2,
        "{name}: only {built} scenes built"
    );
    (full_steps, 128 * built as u32, scenes_with_full)
}

/// Runs scene `seed` of [`random_heavy_scene`] for 2 s under `config`: its largest
/// [`max_stretch_or_strain`], its largest energy ([`energy_with_springs`]) above its value after
/// the first step relative to its scale (`m·g·L` plus the kick's kinetic energy), whether it
/// stayed finite, and in how many of its 128 steps it took the step's own substeps (all but
/// where `line_substeps` applied); `None` where the scene is not built.
fn run_random_heavy_scene(
    seed: u64,
    (heaviest, kick): (f64, f64),
    mix: Mix,
    config: &StepConfig,
) -> Option<(f64, f64, bool, u32)> {
    let h = config.substep();
    let (mut solver, scale) = random_heavy_scene(seed, (heaviest, kick), mix, h)?;
    // (The scene is one island; under `line_substeps` its substep may not be the step's.)
    let h_of = |solver: &Solver| solver.state_substep_of(0).unwrap_or(h);
    solver.step(config);
    let full = |solver: &Solver| u32::from(h_of(solver) == h);
    let mut full_steps = full(&solver);
    let start = energy_with_springs(&solver, h_of(&solver));
    let scale = scale + solver.particles.kinetic_energy(h_of(&solver));
    let (mut strain, mut highest) = (0.0f64, f64::MIN);
    for _ in 1..128 {
        solver.step(config);
        full_steps += full(&solver);
        strain = strain.max(max_stretch_or_strain(&solver));
        highest = highest.max(energy_with_springs(&solver, h_of(&solver)));
    }
    let rise = (highest - start) / scale;
    Some((strain, rise, solver.particles.all_finite(), full_steps))
}

/// A number from the environment variable `name`, else `default`.
fn env_or(name: &str, default: f64) -> f64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Random chains and trees with loads up to 10⁴ times a link's mass, one or two pins, rigid or
/// rope links, kicked by up to 30 m/s (see [`random_heavy_scene`], [`scan_random_heavy_scenes`]
/// for what is asserted). Measured (600 seeds, 506 scenes built): largest strain 1.6·10⁻⁵,
/// energy at most 0.5 % above. Before curvature and full Newton passes ran up to a prediction
/// ten links' lengths off (`CURVATURE_BELOW` 0.1 instead of 10, `solver::direct`), 115 of these
/// scenes failed, some stretched 10³⁰ times their length; before a warm start that reaches too
/// far was taken back (`WARM_START_REACH`), scene 579 gained 19 % (a caught load thrown back
/// up). `SCAN_SCENES`, `SCAN_KICK` (m/s) and `SCAN_HEAVIEST` (the exponent) widen it; with
/// kicks of 100 m/s a few scenes in a thousand still fail (see `CURVATURE_BELOW`).
#[test]
fn random_heavy_chains_and_trees_hit_hard_stay_unstretched() {
    let scenes = env_or("SCAN_SCENES", 600.0) as u64;
    let hits = (env_or("SCAN_KICK", 30.0), env_or("SCAN_HEAVIEST", 4.0));
    let name = "random heavy chains and trees";
    scan_random_heavy_scenes(name, scenes, hits, Mix::LINKS, (None, None));
}

/// The scenes of [`random_heavy_chains_and_trees_hit_hard_stay_unstretched`] with ropes and
/// chains at 2 substeps (`StepConfig::line_substeps`) in a step of 8: in a step where a stick
/// would stretch beyond its length within one of those substeps (a hit,
/// `solver::line_substeps::HIT_ABOVE`) a scene takes 8. Seeds 193, 249, 259, 301, 436, 646
/// and 823 are the ones of 1200 that ended beyond 1 % strain at 2 substeps throughout (a
/// scratch scan: 2.8 to 1100 times a link's length, one gaining 54 times its energy scale).
/// Measured with the guard (1200 seeds, 1033 scenes): none failed, largest strain 1.7·10⁻⁴
/// (1.2·10⁻⁴ since the SHAKE backoff, `solver::direct::SHAKE_BACKOFF_LIMIT`),
/// energy at most 0.28 % of its scale above its start, 909 of 132 224 steps (in 486 scenes)
/// at 8 substeps; without it (`HIT_ABOVE` infinite, a scratch build) four of those seeds fail
/// here (249, 301, 436, 823: up to 302 times a link's length). Asserted too: fewer than a tenth
/// of the steps at 8 (so the scenes do run at 2). `SCAN_SCENES` widens it.
#[test]
fn random_heavy_chains_and_trees_hit_hard_at_two_line_substeps_stay_unstretched() {
    let scenes = env_or("SCAN_SCENES", 240.0) as u64;
    let config = StepConfig {
        line_substeps: Some(2),
        ..config(0.0, true)
    };
    let failed_without_the_guard = [193, 249, 259, 301, 436, 646, 823];
    let later = failed_without_the_guard.into_iter().filter(|&s| s > scenes);
    let seeds = (1..=scenes).chain(later);
    let name = "random heavy chains and trees, ropes at 2 of 8 substeps";
    let hits = (30.0, 4.0);
    let (full, steps, scenes_hit) =
        scan_random_heavy_scenes_with(name, (seeds, scenes), hits, Mix::LINKS, &config, None);
    println!("{full} of {steps} steps at 8 substeps (hits), in {scenes_hit} scenes");
    assert!(full * 10 < steps, "{full} of {steps} steps at 8 substeps");
}

/// The scenes of [`random_heavy_chains_and_trees_hit_hard_stay_unstretched`] with 30 % of
/// their sticks struts (`AtLeast`), then with half their sticks springs (compliance 10⁻⁶ m/N:
/// a 10⁴ kg load stretches one by two links' lengths), asserted alike (a strut's compression,
/// a rigid stick's strain; the springs' energy counted). Measured (600 seeds, 530 scenes each):
/// struts largest strain 10⁻⁹, energy at most 0.27 % above; springs 10⁻⁹ and 1.7 %. Before
/// a prediction too far off for curvature and full Newton passes (`CURVATURE_BELOW`) was
/// measured again with slack rope links and stretched struts counted as on their constraints
/// (`solver::direct`'s `violation`) the struts failed in 50 scenes: struts stretched ten links'
/// lengths as a tree's parts flew apart left Gauss–Newton alone, and it blew the tree up
/// (strain 10⁵², energy 10¹⁰³ times its scale); before a spring's stretch that its last
/// multiplier balanced was left out of that measure, the springs failed in 13 scenes (a rigid
/// stick stretched 1180 %, energy up 45 %). `SCAN_SCENES` and `SCAN_KICK` widen it.
#[test]
fn random_trees_of_struts_and_springs_hit_hard_stay_on_their_constraints() {
    let scenes = env_or("SCAN_SCENES", 600.0) as u64;
    let hits = (env_or("SCAN_KICK", 30.0), 4.0);
    let struts = Mix {
        struts: 0.3,
        ..Mix::LINKS
    };
    scan_random_heavy_scenes(
        "random trees with struts",
        scenes,
        hits,
        struts,
        (None, None),
    );
    let springs = Mix {
        springs: 1e-6,
        ..Mix::LINKS
    };
    scan_random_heavy_scenes(
        "random trees with springs",
        scenes,
        hits,
        springs,
        (None, None),
    );
}

/// The scenes of [`random_heavy_chains_and_trees_hit_hard_stay_unstretched`] at one substep
/// per step, kicked by up to 10 m/s (a link's length in a substep's eighth): every scene
/// finite, its energy never more than 10 % of its scale above its start, its largest strain
/// below 500 % — at one substep the heaviest loads hit hardest do stretch their links
/// (measured, 600 seeds, 506 scenes: 4 scenes beyond 1 %, largest strain 255 %, energy at most
/// 0.13 % above). Before a projection whose passes did not converge and left the line or tree
/// worse off than its prediction was swept from the prediction instead (`solver::direct`'s
/// `LineSolve::project`, `solver::tree`), scene 384 stretched a link 2780 % and gained 76 % of
/// its scale. `SCAN_SCENES` and `SCAN_KICK` widen it.
#[test]
fn random_heavy_chains_and_trees_at_one_substep_never_blow_up() {
    let scenes = env_or("SCAN_SCENES", 600.0) as u64;
    let hits = (env_or("SCAN_KICK", 10.0), 4.0);
    let name = "random heavy chains and trees at 1 substep";
    scan_random_heavy_scenes(name, scenes, hits, Mix::LINKS, (Some(1), Some(5.0)));
}

/// Scene `seed` of [`random_heavy_scene`] run for 2 s under `config`
/// ([`run_random_heavy_scene`]): its largest strain and its largest energy rise, printed with
/// `how` the scene was run. Asserts it built and stayed finite.
fn printed_scene(
    seed: u64,
    hits: (f64, f64),
    mix: Mix,
    config: &StepConfig,
    how: &str,
) -> (f64, f64) {
    let (strain, rise, finite, _) = run_random_heavy_scene(seed, hits, mix, config).unwrap();
    println!(
        "scene {seed}, {how}: largest strain {:.3e} %, energy at most {:+.2} % of its scale above its start",
        strain * 100.0,
        rise * 100.0
    );
    assert!(finite, "scene {seed}");
    (strain, rise)
}

/// [`printed_scene`] kicked by up to 30 m/s at one substep per step.
fn kicked_at_one_substep(seed: u64) -> (f64, f64) {
    let config = StepConfig {
        substeps: 1,
        ..config(0.0, true)
    };
    let how = "kicked at one substep";
    printed_scene(seed, (4.0, 30.0), Mix::LINKS, &config, how)
}

/// Scenes of [`random_heavy_scene`] at one substep per step kicked by up to 30 m/s (nine link
/// lengths a substep) where unconverged passes threw a heavy load: they now end swept from the
/// prediction (`THROWN_ABOVE` in `solver::direct`) — scene 160 now solved before that, by a
/// line's second try. Asserted over 2 s: energy never more than 10 % of the scene's scale above
/// its value after the first step, scene 160 below 1 % strain (measured: scenes 42, 160 and
/// 311 never above it — at most −0.5 %, −32 %, −14 %; before, 1940, 1670 and 167 times the
/// scale above, each in one step). Scenes 42 and 311 still stretch — 156 and 314 link lengths
/// at most (7440 and 664 before): at one substep these kicks are beyond what the passes solve
/// (see the README's known limitations); scene 160 (2640 before) is on its constraints since
/// lines try again from a start on its constraints beyond `CURVATURE_BELOW` too. Without the
/// `THROWN_ABOVE` rule scene 42 still gains 1940 times its scale.
#[test]
fn unconverged_projections_that_throw_their_loads_are_swept() {
    for seed in [42, 160, 311] {
        let (strain, rise) = kicked_at_one_substep(seed);
        assert!(rise < 0.1, "scene {seed}: energy {rise} of its scale above");
        assert!(seed != 160 || strain < 0.01, "scene 160: strain {strain}");
    }
}

/// Trees of [`random_heavy_scene`] at one substep per step kicked by up to 30 m/s whose
/// predictions were too far off for curvature passes (`CURVATURE_BELOW`) and whose
/// Gauss–Newton passes converged on far roots or not at all: they now get the second try from
/// the start of the substep that nearer ones get, its result kept only where it is near enough
/// to be a projection (`TreeSolve::plausible` in `solver::tree`). Asserted over 2 s: scenes
/// 346 and 542 on their constraints (largest strain below 1 %; measured 6·10⁻⁸ % and
/// 7·10⁻⁸ %), scene 571 below 500 % (measured 109 %), energy never 10 % of the scale above its
/// start (measured at most −28 %, −34 %, −55 %). Before: 739, 934 and 275 link lengths, 138,
/// 6.8 and 584 times the scale above.
#[test]
fn trees_far_off_their_constraints_try_again_from_the_start() {
    for (seed, bound) in [(346, 0.01), (542, 0.01), (571, 5.0)] {
        let (strain, rise) = kicked_at_one_substep(seed);
        assert!(strain < bound, "scene {seed}: largest strain {strain}");
        assert!(rise < 0.1, "scene {seed}: energy {rise} of its scale above");
    }
}

/// Lines of [`random_heavy_scene`] at four substeps per step kicked by up to 60 m/s (three link
/// lengths a substep) whose passes ran out unconverged while their pins stood still: they now
/// get a second try from the start of the substep, kept where it converged near enough to be
/// a projection (`solver::direct`'s `second_try`). Asserted over 2 s: on their constraints
/// (largest strain below 1 %; measured 10⁻⁹) and energy never 10 % of the scale above its
/// start (measured at most −31 %, −78 %, −25 %). Without the second try of unconverged lines:
/// 92, 192 and 42 link lengths, scenes 651 and 955 gaining 6.6 and 8.2 times their scale.
#[test]
fn unconverged_lines_with_still_pins_try_again_from_the_start() {
    let config = StepConfig {
        substeps: 4,
        ..config(0.0, true)
    };
    for seed in [384, 651, 955] {
        let how = "kicked at four substeps";
        let (strain, rise) = printed_scene(seed, (4.0, 60.0), Mix::LINKS, &config, how);
        assert!(strain < 0.01, "scene {seed}: largest strain {strain}");
        assert!(rise < 0.1, "scene {seed}: energy {rise} of its scale above");
    }
}

/// A 1000:1 chain of 40 links pinned at its first two particles (so its first link holds the
/// rest out sideways, as a lamp's arm), released from horizontal, 8 × 1, 5 s:
/// solved by lines, it stays on its constraints (largest strain below 10⁻⁶; measured 10⁻⁹).
/// Before, the stick between the two neighbouring pins counted as a segment pulled taut
/// between immovable particles, and the whole line was swept in every substep (measured 212 %
/// largest strain).
#[test]
fn a_chain_pinned_at_neighbouring_particles_is_solved_not_swept() {
    let mut solver = chain(40, 2.0, DVec3::X, 1000.0, Method::Auto);
    solver.pin(1, solver.particles.position[1]);
    solver.organize();
    let config = config(0.0, true);
    let mut strain: f64 = 0.0;
    for _ in 0..320 {
        solver.step(&config);
        strain = strain.max(max_stretch_or_strain(&solver));
    }
    println!("chain pinned at neighbouring particles: largest strain {strain:.2e}");
    assert!(solver.line_passes() > 0, "solved by lines, not swept");
    assert!(strain < 1e-6, "largest strain {strain}");
}

/// Scenes 364, 481 and 1046 of [`random_heavy_scene`] pinned at two more particles (trees with
/// four pins), kicked by up to 30 m/s, 8 × 1, 2 s: as lines meeting at forks (block
/// Gauss–Seidel over lines, how trees with three or more pins were solved before they were split
/// at their pins and closed more than once, `solver::tree`) they stretched 3.8·10⁷–7.7·10⁸ link
/// lengths; with a fall back for lines sharing particles (`solver::direct`'s `fall_back`, which
/// stays for lines that still meet at forks: meshes forced onto lines, parts of trees held by
/// more than nine pins) 32, 11 and 2 link lengths. Now trees: asserted below 1 % strain
/// (measured 10⁻⁹) and energy never 10 % of the scale above its value after the first step
/// (measured −19 %, −19 %, 0 %).
#[test]
fn trees_that_blew_up_as_lines_meeting_at_forks_stay_unstretched() {
    let config = config(0.0, true);
    let mix = Mix {
        pins: 2,
        ..Mix::LINKS
    };
    for seed in [364, 481, 1046] {
        let how = "pinned at four particles";
        let (strain, rise) = printed_scene(seed, (4.0, 30.0), mix, &config, how);
        assert!(strain < 0.01, "scene {seed}: largest strain {strain}");
        assert!(rise < 0.1, "scene {seed}: energy {rise} of its scale above");
    }
}

/// Random chains and trees of [`random_heavy_scene`] pinned at up to two more particles
/// (`Mix::pins`: three or four pins), 8 × 1, loads up to 10⁴×, half kicked by up to 30 m/s:
/// every scene stays below 1 % strain and never rises 10 % of its scale above its start, as
/// with one or two pins. Trees are split at their pins into parts held by at most two
/// (`solver::tree`'s `split`) and parts held by three to nine are closed more than once
/// (`closings`); chains are lines pinned inside. Measured (a scratch scan of 1033 such
/// scenes, largest strain beyond 100 % before → now): split trees 120 of 221 → 0, trees
/// closed more than once 145 of 241 → 0 (both were lines meeting at forks), chains 88 of 533
/// → 0 (a stick between two neighbouring pins counted as a taut segment had the line swept in
/// every substep); in all 355 → 0, largest strain 9·10⁻⁶.
#[test]
fn trees_and_chains_held_by_three_or_four_pins_stay_unstretched() {
    let scenes = env_or("SCAN_SCENES", 240.0) as u64;
    let config = config(0.0, true);
    let mix = Mix {
        pins: 2,
        ..Mix::LINKS
    };
    let hits = (4.0, 30.0);
    let mut counts = [0; 3]; // (split, closed more than once, chains)
    let (mut worst, mut worst_rise) = (0.0f64, f64::MIN);
    for seed in 1..=scenes {
        let Some((solver, _)) = random_heavy_scene(seed, hits, mix, config.substep()) else {
            continue;
        };
        let held = (0..solver.particles.len())
            .filter(|&p| solver.particles.inverse_mass[p] == 0.0)
            .count();
        if held < 3 || held == solver.particles.len() {
            continue; // (fewer pins, or nothing left to move)
        }
        let island = &solver.islands.list[0];
        let trees = &solver.islands.lines().trees.trees;
        let trees = &trees[island.trees.start as usize..island.trees.end as usize];
        let kind = match trees.len() {
            0 => 2,
            _ if trees.iter().any(|t| !t.extra_closings.is_empty()) => 1,
            _ => 0,
        };
        counts[kind] += 1;
        let (strain, rise, finite, _) = run_random_heavy_scene(seed, hits, mix, &config).unwrap();
        assert!(finite, "scene {seed}: not finite");
        assert!(strain < 0.01, "scene {seed}: largest strain {strain}");
        assert!(rise < 0.1, "scene {seed}: energy {rise} of its scale above");
        (worst, worst_rise) = (worst.max(strain), worst_rise.max(rise));
    }
    let [split, closed, chains] = counts;
    println!(
        "split trees {split}, trees closed more than once {closed}, chains pinned inside {chains}: largest strain {:.2e} %, energy at most {:+.2} % of its scale above its start",
        worst * 100.0,
        worst_rise * 100.0
    );
    assert!(
        split >= 20 && closed >= 20 && chains >= 40,
        "only {split} split trees, {closed} closed more than once, {chains} chains"
    );
}

/// Scene 969 of [`random_heavy_scene`] (a rope of seven links, loads 1300 times a link on its
/// far part, pinned at its first and third particles) with its pins waving 5 cm sideways out of
/// phase (0.3 m/s), 8 × 1: the segment between the pins is pulled tight and slack by turns, and a
/// projection converged on a far root — the heavy part thrown round its pin — and each such root
/// led to the next. Now a line's projection that ends farther from its prediction than the start
/// of the substep allows is tried again from that start (`solver::direct`'s `second_try`).
/// Asserted over 2 s: finite, largest strain below 500 % (measured 271 %: the pins pull the
/// segment between them beyond its length) and energy at the end no more than 10 % of the
/// scene's scale above its value after the first step (measured 0.99 of the scale below it;
/// the peak is not asserted: a one-step spike of 235 times the scale remains, where the second
/// try converges on the same root, given back the next step). Before: 1.2·10⁶ link
/// lengths and 3.6·10¹⁰ times the scale (1.2·10⁹ and 8·10¹⁶ before `THROWN_ABOVE`).
#[test]
fn a_rope_between_waving_pins_never_blows_up() {
    let config = config(0.0, true);
    let h = config.substep();
    let (mut solver, scale) = random_heavy_scene(969, (4.0, 30.0), Mix::LINKS, h).unwrap();
    solver.step(&config);
    let start = energy_with_springs(&solver, h);
    let scale = scale + solver.particles.kinetic_energy(h);
    let base = solver.pins.to.clone();
    let mut strain: f64 = 0.0;
    for step in 1..128 {
        let t = step as f64 / 64.0;
        for (i, at) in base.iter().enumerate() {
            solver.pins.to[i] = *at + DVec3::X * 0.05 * (6.0 * t + i as f64).sin();
        }
        solver.step(&config);
        strain = strain.max(max_stretch_or_strain(&solver));
    }
    let end = (energy_with_springs(&solver, h) - start) / scale;
    println!(
        "rope between waving pins: largest strain {:.1} %, energy at the end {end:+.3} of its scale from its start",
        strain * 100.0
    );
    assert!(solver.particles.all_finite());
    assert!(strain < 5.0, "largest strain {strain}");
    assert!(end < 0.1, "energy {end} of its scale above its start");
}

/// Scenes of [`random_heavy_scene`] at one substep per step whose pins jump 5 cm back and
/// forth every two steps (3.2 m/s): where the passes of a substep ran out short of converging
/// but within 1 % of the constraints, the iterate is kept rather than replaced by a sweep from
/// the prediction (`NEARLY_ON` in `solver::direct`; a review saw such iterates
/// 4·10⁻⁹–7·10⁻³ off). Measured over 2 s: largest strain 0.06–0.47 % (rigid sticks and rope
/// stretch; 0.12–0.64 % before a line's far root got a second try); with every unconverged
/// projection worse off than its prediction swept (the rule before), 250–495 %, the sweep
/// leaving what the passes had nearly solved.
#[test]
fn nearly_converged_projections_are_kept_where_pins_jump() {
    let config = StepConfig {
        substeps: 1,
        ..config(0.0, true)
    };
    for seed in [173, 456, 706, 839] {
        let (mut solver, _) =
            random_heavy_scene(seed, (4.0, 30.0), Mix::LINKS, config.substep()).unwrap();
        solver.step(&config);
        let base = solver.pins.to.clone();
        let mut strain: f64 = 0.0;
        for step in 1..128 {
            let sign = if (step / 2) % 2 == 0 { 1.0 } else { -1.0 };
            for (i, at) in base.iter().enumerate() {
                let jump = DVec3::new((i as f64 + 1.0).sqrt(), 0.0, 0.5) * 0.05 * sign;
                solver.pins.to[i] = *at + jump;
            }
            solver.step(&config);
            strain = strain.max(max_stretch_or_strain(&solver));
        }
        println!(
            "scene {seed}, pins jumping: largest strain {:.3} %",
            strain * 100.0
        );
        assert!(solver.particles.all_finite());
        assert!(strain < 0.01, "scene {seed}: largest strain {strain}");
    }
}

/// A weight `weight` × a link hung from two pins 0.8 m apart by a V of 64 links of 2 cm and
/// kind `kind` (straight, the weight 0.5 m below the pins): one line pinned at both ends.
fn sling(weight: f64, kind: StickKind) -> Solver {
    sling_spanning(0.8, weight, kind)
}

/// As [`sling`], the pins `span` apart (at most the V's 1.28 m).
fn sling_spanning(span: f64, weight: f64, kind: StickKind) -> Solver {
    let mut solver = Solver::default();
    let half = span / 2.0;
    let at = [-half, half].map(|x| DVec3::new(x, 0.0, 0.0));
    let bottom = DVec3::new(0.0, -(0.64f64 * 0.64 - half * half).max(0.0).sqrt(), 0.0);
    let first = solver.add_particle(at[0], 0.0);
    solver.pin(first, at[0]);
    push_v(&mut solver, first, [at[0], bottom, at[1]], weight, kind);
    solver.organize();
    solver
}

/// Appends a V of 64 links of 2 cm and kind `kind` from particle `from` (at `corners[0]`)
/// down to `corners[1]` and up to a new pin at `corners[2]`, straight, with a weight
/// `weight` × a link at the bottom; returns the new pin.
fn push_v(
    solver: &mut Solver,
    from: u32,
    corners: [DVec3; 3],
    weight: f64,
    kind: StickKind,
) -> u32 {
    let [top, bottom, end] = corners;
    let mut previous = from;
    for i in 1..=64 {
        let (a, b, f) = if i <= 32 {
            (top, bottom, i as f64 / 32.0)
        } else {
            (bottom, end, (i - 32) as f64 / 32.0)
        };
        let w = match i {
            32 => 1.0 / weight,
            64 => 0.0,
            _ => 1.0,
        };
        let p = solver.add_particle(a + (b - a) * f, w);
        if i == 64 {
            solver.pin(p, b);
        }
        solver
            .sticks
            .push([previous, p], 0.02, 0.0, kind, f64::INFINITY, 0);
        previous = p;
    }
    previous
}

/// Heavy loads between two pins, the weight kicked sideways (`kick` m in the first substep of
/// 1/512 s: 5.1 m/s for 0.01), no damping, 10 s: largest link strain after any step below 10⁻⁶
/// (measured below 10⁻⁹). A line pinned at both ends takes curvature and full Newton passes,
/// the stick to the second pin closing the loop through a Schur complement
/// (`solver::direct::closure`); before, it took Gauss–Newton passes only, which do not converge
/// under such loads: rigid links 10⁻⁹, 296 %, 2880 %, 2740 % and 28 300 % for the cases below
/// in order, rope links 0.82 % and 330 %.
#[test]
fn heavy_loads_between_two_pins_swing_unstretched() {
    let cases = [
        (StickKind::Equal, 1e3, 0.01),
        (StickKind::Equal, 1e4, 0.01),
        (StickKind::Equal, 1e5, 0.0),
        (StickKind::Equal, 1e5, 0.01),
        (StickKind::Equal, 1e6, 0.0),
        (StickKind::AtMost, 1e3, 0.01),
        (StickKind::AtMost, 1e4, 0.01),
    ];
    for (kind, weight, kick) in cases {
        let mut solver = sling(weight, kind);
        solver.particles.previous[32] -= DVec3::Z * kick;
        let worst = largest_strain_over(&mut solver, &config(0.0, true), 640);
        println!(
            "sling of {kind:?} links, weight {weight:e}×, kick {kick} m: max strain {:.2e} %, {} Newton passes",
            worst * 100.0,
            solver.line_passes()
        );
        assert!(solver.particles.all_finite());
        assert!(
            worst < 1e-6,
            "{kind:?}, {weight:e}×, kick {kick}: max strain {worst}"
        );
    }
}

/// A clothesline: three V's of 64 links of 2 cm between four posts 0.8 m apart (one line,
/// pinned at both ends and at two particles inside), weights `weight` × a link at the bottoms,
/// links of kind `kind`.
fn clothesline(weight: f64, kind: StickKind) -> Solver {
    let mut solver = Solver::default();
    let mut previous = solver.add_particle(DVec3::ZERO, 0.0);
    solver.pin(previous, DVec3::ZERO);
    for span in 0..3 {
        let x0 = 0.8 * span as f64;
        let corners = [
            DVec3::new(x0, 0.0, 0.0),
            DVec3::new(x0 + 0.4, -0.5, 0.0),
            DVec3::new(x0 + 0.8, 0.0, 0.0),
        ];
        previous = push_v(&mut solver, previous, corners, weight, kind);
    }
    solver.organize();
    solver
}

/// Heavy loads on a line pinned inside (the clothesline), the weights kicked sideways at
/// 5.1 m/s or at rest, no damping, 10 s: largest link stretch after any step below 10⁻⁶
/// (measured below 10⁻⁹). Each stretch between two pins takes its own curvature and full
/// Newton passes (`Root::Segments` in `solver::direct`'s `curvature` module); before, a line
/// pinned inside took Gauss–Newton passes only: rigid links 372 % and 39 400 %, rope links
/// 411 % and 4420 % for the cases below in order (measured on 3f5698f).
#[test]
fn heavy_loads_on_a_line_pinned_inside_swing_unstretched() {
    for (kind, weight, kick) in [
        (StickKind::Equal, 1e4, 0.01),
        (StickKind::Equal, 1e6, 0.0),
        (StickKind::AtMost, 1e4, 0.01),
        (StickKind::AtMost, 1e5, 0.0),
    ] {
        let mut solver = clothesline(weight, kind);
        for bottom in [32, 96, 160] {
            solver.particles.previous[bottom] -= DVec3::Z * kick;
        }
        let worst = largest_over(&mut solver, &config(0.0, true), 640, max_stretch);
        println!(
            "clothesline of {kind:?} links, weights {weight:e}×, kick {kick} m: max stretch {:.2e} %, {} Newton passes",
            worst * 100.0,
            solver.line_passes()
        );
        assert!(solver.particles.all_finite());
        assert!(worst < 1e-6, "{kind:?}, {weight:e}×: max stretch {worst}");
    }
}

/// A V of 64 links (1 kg each) between two pins 99.8–99.9 % of its length apart (not within
/// the 0.1 % where a taut line is swept), nearly taut, kicked at up to 2.9 m/s, no damping,
/// 5 s: the energy never rises above its value after the first step by more than 1 % of its
/// magnitude (measured: its highest 3.8–8.8 % below it; 15–17 % lost after 5 s). The tension
/// makes the links' sideways vibration too fast for SHAKE, which is stable only below `ωh = 2`;
/// such substeps are projected (`SHAKE_STIFFNESS_BELOW` in `solver::direct`). Without that
/// (the constant made infinite), these rose by 47 %, 76 %, 136 % and 88 %; of 30 such scenes
/// (spans 0.998–0.99899, kicks up to 2.9 m/s, rigid and rope links) 16 rose, by 3–136 %, and
/// none does with it (a scratch scan).
#[test]
fn a_rope_nearly_taut_between_pins_keeps_its_energy() {
    let config = config(0.0, true);
    let h = config.timestep / f64::from(config.substeps);
    for (kind, span, kick) in [
        (StickKind::Equal, 0.9985, 0.0),
        (StickKind::Equal, 0.99899, 0.0),
        (StickKind::Equal, 0.998, 0.004),
        (StickKind::AtMost, 0.99899, 0.002),
    ] {
        let mut solver = sling_spanning(1.28 * span, 1.0, kind);
        solver.particles.previous[32] -= DVec3::new(kick, 0.0, kick);
        solver.step(&config);
        let start = energy(&solver, h);
        let highest = (0..320)
            .map(|_| {
                solver.step(&config);
                energy(&solver, h)
            })
            .fold(f64::MIN, f64::max);
        let rise = (highest - start) / start.abs();
        let end = (energy(&solver, h) - start) / start.abs();
        println!(
            "{kind:?} links, span {span}, kick {kick} m: energy at most {:+.2} %, after 5 s {:+.2} %",
            rise * 100.0,
            end * 100.0
        );
        assert!(solver.particles.all_finite());
        assert!(
            rise < 0.01,
            "{kind:?}, span {span}, kick {kick}: rose by {rise}"
        );
    }
}

/// A rope of 50 one-sided links (`AtMost`, 2 cm) between two pins 70 % of its length apart,
/// released straight (every link slack), SHAKE on, no damping, 5 s: the energy never rises above
/// its start. Measured: at most 0.07 J below it, −93 J after 5 s (the old code: up to +1079 J —
/// a slack link was warm-started with the tension of a substep when it was taut, a pull no pass
/// took back).
#[test]
fn a_slack_rope_between_pins_never_gains_energy() {
    let mut solver = slack_rope(0.7);
    let config = config(0.0, true);
    let h = config.timestep / config.substeps as f64;
    let start = energy(&solver, h);
    let mut highest = f64::MIN;
    for _ in 0..320 {
        solver.step(&config);
        highest = highest.max(energy(&solver, h));
    }
    println!("slack rope: energy start {start:.3} J, highest {highest:.3} J");
    assert!(
        highest <= start + 0.01,
        "energy rose to {highest} from {start}"
    );
}

/// A rope of 50 one-sided links (`AtMost`, 2 cm) between two pins `span` × its length apart,
/// straight (every link slack).
fn slack_rope(span: f64) -> Solver {
    let mut solver = Solver::default();
    let (links, link) = (50, 0.02);
    let mut previous = None;
    for i in 0..=links {
        let at = DVec3::new(span * link * i as f64, 0.0, 0.0);
        let pinned = i == 0 || i == links;
        let p = solver.add_particle(at, if pinned { 0.0 } else { 1.0 });
        if pinned {
            solver.pin(p, at);
        }
        if let Some(q) = previous {
            solver
                .sticks
                .push([q, p], link, 0.0, StickKind::AtMost, f64::INFINITY, 0);
        }
        previous = Some(p);
    }
    solver.organize();
    solver
}

/// How far rope links break complementarity after a step, relative to their rest lengths: the
/// largest pull of a slack link (the smaller of its slack and its multiplier's reach
/// `|λ| (w_a + w_b)`) and the largest push (a rope link's multiplier may only pull, `λ ≤ 0`).
fn rope_complementarity(solver: &Solver) -> (f64, f64) {
    let p = &solver.particles;
    let (mut slack_pull, mut push): (f64, f64) = (0.0, 0.0);
    for i in 0..solver.sticks.len() {
        let [a, b] = solver.sticks.ends()[i].map(|p| p as usize);
        let reach = solver.sticks.lambda[i] * (p.inverse_mass[a] + p.inverse_mass[b])
            / solver.sticks.rest_length[i];
        let strain = solver.sticks.strain(i, p);
        push = push.max(reach);
        if strain < 0.0 {
            slack_pull = slack_pull.max((-reach).min(-strain));
        }
    }
    (slack_pull, push)
}

/// Rope links pull only while taut, and never push: after every step of 5 s (8 × 1, no
/// damping) of the slack ropes between pins (spans 70 % and 95 %) and the chain and the Y rope
/// of rope links released from horizontal (tips 1× and 10⁴×), no slack link pulls and no
/// link pushes by more than 10⁻⁸ of its length (measured at most 10⁻⁹ and 0). Before the
/// primal–dual active set: slack links pulled up to 10 % (slack rope, 70 %) and 95 % (the chain,
/// tip 1×), links pushed up to 10 % and 55 % (the chain, tips 1× and 10⁴×) and 20× their
/// length (the Y rope, 10⁴×; measured by a review on the commit before); with the rule but a
/// link out of the system keeping its multiplier (no release) the 70 % slack rope pushed 3·10⁻⁵.
#[test]
fn rope_links_pull_only_while_taut() {
    let config = config(0.0, true);
    let scenes: [(&str, Solver); 6] = [
        ("slack rope 70 %", slack_rope(0.7)),
        ("slack rope 95 %", slack_rope(0.95)),
        (
            "chain, tip 1×",
            as_rope(chain(100, 1.0, DVec3::X, 1.0, Method::Lines)),
        ),
        (
            "chain, tip 1e4×",
            as_rope(chain(100, 1.0, DVec3::X, 1e4, Method::Lines)),
        ),
        (
            "Y rope, tip 1×",
            as_rope(y_rope(1.0, DVec3::X, Method::Auto)),
        ),
        (
            "Y rope, tip 1e4×",
            as_rope(y_rope(1e4, DVec3::X, Method::Auto)),
        ),
    ];
    for (name, mut solver) in scenes {
        let (mut slack_pull, mut push): (f64, f64) = (0.0, 0.0);
        for _ in 0..320 {
            solver.step(&config);
            let (pull, pushed) = rope_complementarity(&solver);
            (slack_pull, push) = (slack_pull.max(pull), push.max(pushed));
        }
        println!("{name}: slack pull {slack_pull:.1e}, push {push:.1e}");
        assert!(slack_pull < 1e-8, "{name}: a slack link pulls {slack_pull}");
        assert!(push < 1e-8, "{name}: a link pushes {push}");
    }
}

/// Rope links push nothing: 10 rope links (`AtMost`, 10 cm) hang from a pin under gravity for
/// 2 s (their links in tension, warm-started), then the tip is tossed up at 0.4 m/s. Its link
/// goes slack, so after one step the tip flies on at 0.4 m/s less gravity's share, damped by 2/s
/// for 1/64 s: `(0.4 − 9.81/64)·e^(−2/64)` = 0.239 m/s. (A rope link held in the system while
/// it went slack, tried on 2026-11-26 and not kept, stopped it: a rope pushed.)
#[test]
fn a_tossed_rope_end_flies_freely() {
    let mut solver = Solver::default();
    let pin = solver.add_particle(DVec3::ZERO, 0.0);
    solver.pin(pin, DVec3::ZERO);
    let mut previous = pin;
    for i in 1..=10 {
        let p = solver.add_particle(DVec3::NEG_Y * (0.1 * i as f64), 1.0);
        let kind = StickKind::AtMost;
        solver
            .sticks
            .push([previous, p], 0.1, 0.0, kind, f64::INFINITY, 0);
        previous = p;
    }
    solver.organize();
    let config = config(2.0, true);
    for _ in 0..128 {
        solver.step(&config);
    }
    let tip = previous as usize;
    let h = config.timestep / config.substeps as f64;
    let x = solver.particles.position[tip];
    solver.particles.previous[tip] = x - DVec3::Y * (0.4 * h);
    solver.step(&config);
    let speed = (solver.particles.position[tip] - solver.particles.previous[tip]).y / h;
    println!("tossed rope end: {speed:.3} m/s after one step");
    assert!((speed - 0.239).abs() < 0.01, "the tip flies at {speed} m/s");
}

/// Rope links (`AtMost`) under loads 1–10⁵ times a link: the 100-link chain (1 m) and the Y
/// rope, released from horizontal, no damping, 5 s: largest stretch below 10⁻⁶ (measured below
/// 10⁻⁹ everywhere), in at most 1.1× the Newton passes the same ropes with rigid links take
/// (measured 0.86–1.003×). Before a rope link was in the system by the primal–dual rule
/// (`solver::direct`, `in_system_with`) — in while stretched, its multiplier frozen while slack
/// — the chain stretched 0.38 %, 0.35 %, 1.9 %, 14× and 137× with tips 1, 10², 10³, 10⁴, 10⁵
/// times a link, in 2.8×, 1.9×, 2.1×, 2.1×, 2.6× the rigid chain's passes; the Y rope 1.2 %,
/// 1.4 %, 15 %, 38×, 338× (3.4×, 3.3×, 6.7×, 6.3×, 2.9×).
#[test]
fn rope_links_under_heavy_loads_swing_unstretched() {
    let config = config(0.0, true);
    for tip in [1.0, 100.0, 1000.0, 1e4, 1e5] {
        for (name, build) in [
            (
                "chain",
                (|tip| chain(100, 1.0, DVec3::X, tip, Method::Lines)) as fn(f64) -> Solver,
            ),
            ("Y rope", |tip| y_rope(tip, DVec3::X, Method::Auto)),
        ] {
            let mut rigid = build(tip);
            largest_strain_over(&mut rigid, &config, 320);
            let mut rope = as_rope(build(tip));
            let worst = largest_over(&mut rope, &config, 320, max_stretch);
            let (passes, rigid_passes) = (rope.line_passes(), rigid.line_passes());
            println!(
                "{name} of rope links, tip {tip:e}×: max stretch {:.2e} %, {passes} Newton passes (rigid links: {rigid_passes})",
                worst * 100.0
            );
            assert!(worst < 1e-6, "{name}, tip {tip}: stretch {worst}");
            assert!(
                passes as f64 <= 1.1 * rigid_passes as f64,
                "{name}, tip {tip}: {passes} passes, rigid {rigid_passes}"
            );
        }
    }
}

/// 200 links of 1 cm from one pin, released horizontal, damping 0.5/s, 20 s: largest link
/// strain while swinging (first 10 s) and at rest (last step). Sweeps at 8 × 1: 185 % / 75 %
/// (`tests/hard_cases.rs`); lines: below 10⁻⁶ % both (goal: below 2 % / 1 %).
#[test]
fn two_hundred_link_chain_swings_and_hangs_unstretched() {
    let mut solver = chain(200, 2.0, DVec3::X, 1.0, Method::Auto);
    assert_eq!(solver.islands.list[0].method, Method::Lines);
    let config = config(0.5, true);
    let mut swing: f64 = 0.0;
    for n in 0..1280 {
        solver.step(&config);
        if n < 640 {
            swing = swing.max(max_strain(&solver));
        }
    }
    let rest = max_strain(&solver);
    println!(
        "200 links: swinging {:.4} %, at rest {:.4} %",
        swing * 100.0,
        rest * 100.0
    );
    assert!(swing < 1e-6, "swinging {swing}");
    assert!(rest < 1e-6, "at rest {rest}");
}

/// A Y-shaped rope: a 50-link trunk (1 cm links) from a pin along `down`, then three 30-link
/// branches from its end (37° to either side in the XY plane, and straight on), the branch tips
/// `tip_ratio` × a link.
fn y_rope(tip_ratio: f64, down: DVec3, method: Method) -> Solver {
    let mut solver = Solver::default();
    solver.method = method;
    let pin = solver.add_particle(DVec3::ZERO, 0.0);
    solver.pin(pin, DVec3::ZERO);
    let mut branch = |from: u32, direction: DVec3, links: usize, tip: f64| {
        let start = solver.particles.position[from as usize];
        let mut previous = from;
        for i in 1..=links {
            let w = if i == links { 1.0 / tip } else { 1.0 };
            let p = solver.add_particle(start + direction * (0.01 * i as f64), w);
            solver
                .sticks
                .push([previous, p], 0.01, 0.0, StickKind::Equal, f64::INFINITY, 0);
            previous = p;
        }
        previous
    };
    let fork = branch(pin, down, 50, 1.0);
    let side = DVec3::Z.cross(down);
    for direction in [0.8 * down - 0.6 * side, down, 0.8 * down + 0.6 * side] {
        branch(fork, direction, 30, tip_ratio);
    }
    solver.organize();
    solver
}

/// Y-shaped ropes hanging, damping 2/s, 10 s: largest link strain over the last 5 s. The tree
/// is solved whole, leaves to root. Measured at 8 × 1: equal masses, sweeps 52 %, lines meeting
/// at the fork (block Gauss–Seidel) 22 % — and 809 % while the lines re-stabilised the fork's
/// start position against each other —, the tree 0 %; 1000× heavier tips: sweeps 1175 %
/// (forward and back; 1183 % forward alone), lines 935 %, the tree below 10⁻⁷ %.
#[test]
fn a_forked_rope_hangs_unstretched() {
    let run = |tip: f64, method: Method| {
        let mut solver = y_rope(tip, DVec3::NEG_Y, method);
        let config = config(2.0, true);
        let mut worst: f64 = 0.0;
        for n in 0..640 {
            solver.step(&config);
            if n >= 320 {
                worst = worst.max(max_strain(&solver));
            }
        }
        worst
    };
    for tip in [1.0, 1000.0] {
        let (sweep, tree) = (run(tip, Method::Sweep), run(tip, Method::Auto));
        println!(
            "Y rope, tips {tip}×: sweep {:.1} %, tree {:.2e} %",
            sweep * 100.0,
            tree * 100.0
        );
        assert!(sweep > 0.3, "the sweep stretches: {sweep}");
        assert!(tree < 1e-6, "tree: {tree}");
    }
}

/// A Y rope with heavy tips (100× and 1000× a link) settled for 10 s (damping 2/s), its tips
/// then kicked sideways at 0.05 m/s, no damping, 10 s: the energy never rises above its value
/// after the kick by more than 1 % of what the kick added (measured: never above it). The
/// tension next to the tips makes SHAKE unstable there (`SHAKE_STIFFNESS_BELOW` in
/// `solver::direct`); without the bound the kicked ropes gained 26 % (100×) and 15 % (1000×, a
/// review's figure) of the kick's energy.
#[test]
fn a_kicked_forked_rope_with_heavy_tips_keeps_its_energy() {
    let config = config(0.0, true);
    let h = config.timestep / f64::from(config.substeps);
    for tip in [100.0, 1000.0] {
        let mut solver = y_rope(tip, DVec3::NEG_Y, Method::Auto);
        for _ in 0..640 {
            solver.step(&self::config(2.0, true));
        }
        let settled = energy(&solver, h);
        let n = solver.particles.len();
        for tip_particle in [n - 1, n - 31, n - 61] {
            solver.particles.previous[tip_particle] -= DVec3::Z * (0.05 * h);
        }
        solver.step(&config);
        let start = energy(&solver, h);
        let highest = (1..640)
            .map(|_| {
                solver.step(&config);
                energy(&solver, h)
            })
            .fold(f64::MIN, f64::max);
        let rise = (highest - start) / (start - settled);
        println!(
            "Y rope, tips {tip}× kicked: energy at most {:+.2} % of the kick's",
            rise * 100.0
        );
        assert!(solver.particles.all_finite());
        assert!(
            rise < 0.01,
            "tips {tip}×: rose by {rise} of the kick's energy"
        );
    }
}

/// Y-shaped ropes released from horizontal, no damping, 5 s: largest link strain, with equal
/// masses and with 100× and 1000× heavier tips. Measured: below 10⁻⁷ % all (the tree solve
/// converges to 10⁻⁹ every substep). Energy is not asserted: as on a plain chain released from
/// horizontal, the whipping free ends turn too far per substep for SHAKE, the projection takes
/// over there and damps, as do substeps whose tension makes SHAKE unstable
/// (`SHAKE_STIFFNESS_BELOW` in `solver::direct`; equal masses: 60–65 % of the energy released by
/// the fall is lost over 5 s, a scratch measure). Also the cost, in Newton passes (a count, not
/// a time): 5693 / 5413 / 5295 since those substeps are projected, 5926 / 7001 / 7112 before,
/// since a projected substep starts with a curvature pass (`solver::tree`'s `curvature`),
/// 6446 / 10 839 / 28 707 before that.
#[test]
fn a_forked_rope_swings_unstretched() {
    for (tip, most_passes) in [(1.0, 6_500), (100.0, 8_000), (1000.0, 8_000)] {
        let mut solver = y_rope(tip, DVec3::X, Method::Auto);
        assert!(!solver.islands.list[0].trees.is_empty(), "solved as a tree");
        let config = config(0.0, true);
        let worst = largest_strain_over(&mut solver, &config, 320);
        let passes = solver.line_passes();
        println!(
            "Y rope swinging, tips {tip}×: max strain {:.2e} %, {passes} Newton passes",
            worst * 100.0
        );
        assert!(worst < 1e-6, "max strain {worst}");
        assert!(passes < most_passes, "{passes} Newton passes");
    }
}

/// A string of lanterns: a rope of 40 links of 2.5 cm between two posts `span` m apart (a V
/// at rest), three strings of 10 links hanging from its 10th, 20th and 30th particles with
/// weights `weight` × a link at their ends — a tree held by two pins.
fn lantern_line(span: f64, weight: f64) -> Solver {
    let mut solver = Solver::default();
    let link = 0.025;
    let depth = (0.25 - span * span / 4.0).max(0.0).sqrt();
    let mut rope = Vec::new();
    for i in 0..=40 {
        let t = i as f64 / 40.0;
        let at = DVec3::new(span * t, -depth * (1.0 - (2.0 * t - 1.0).abs()), 0.0);
        let pinned = i == 0 || i == 40;
        let p = solver.add_particle(at, if pinned { 0.0 } else { 1.0 });
        if pinned {
            solver.pin(p, at);
        }
        if let Some(&before) = rope.last() {
            solver
                .sticks
                .push([before, p], link, 0.0, StickKind::Equal, f64::INFINITY, 0);
        }
        rope.push(p);
    }
    for i in [10, 20, 30] {
        let mut above = rope[i];
        let top = solver.particles.position[above as usize];
        for j in 1..=10 {
            let w = if j == 10 { 1.0 / weight } else { 1.0 };
            let p = solver.add_particle(top - DVec3::Y * (link * j as f64), w);
            solver
                .sticks
                .push([above, p], link, 0.0, StickKind::Equal, f64::INFINITY, 0);
            above = p;
        }
    }
    solver.organize();
    solver
}

/// A tree held by two pins is solved whole, the stick to the second pin closing the loop
/// (`solver::tree`'s `closure`): a string of lanterns swinging from rest, no damping, 10 s,
/// weights 1×, 10× and 100× a link: largest link strain after any step below 10⁻⁶ (measured
/// below 10⁻⁹), and its energy (at the middle of the substep) never more than 10⁻³·m·g·1 m
/// above its value after the first step (measured 3·10⁻⁶–1·10⁻⁴: SHAKE's oscillation).
/// Before, covered by lines meeting at forks: 4.0 %, 5.6 % and 30 % over 5 s (a review's run of
/// the same scene; swept: 18 %, 26 %, 101 %). Pulled straight between its posts (a rigid path within 0.1 % of taut:
/// singular) it is swept for those substeps, as a line between two pins is, and stays finite
/// (measured 23 % and 114 % strain under 1× and 100× weights over 5 s).
#[test]
fn a_tree_between_two_pins_swings_unstretched() {
    let config = config(0.0, true);
    let h = config.substep();
    for weight in [1.0, 10.0, 100.0] {
        let mut solver = lantern_line(0.9, weight);
        assert!(!solver.islands.list[0].trees.is_empty(), "solved as a tree");
        solver.step(&config);
        let start = energy(&solver, h);
        let mut highest = f64::MIN;
        let mut worst: f64 = 0.0;
        for _ in 1..64 * 10 {
            solver.step(&config);
            highest = highest.max(energy(&solver, h));
            worst = worst.max(max_strain(&solver));
        }
        let p = &solver.particles;
        let mass: f64 = (0..p.len())
            .filter(|&i| p.inverse_mass[i] > 0.0)
            .map(|i| 1.0 / p.inverse_mass[i])
            .sum();
        let rise = (highest - start) / (mass * G);
        println!(
            "lanterns {weight}×: max strain {:.2e} %, energy at most {rise:+.1e} m·g·L above its start, {} Newton passes",
            worst * 100.0,
            solver.line_passes()
        );
        assert!(worst < 1e-6, "{weight}×: max strain {worst}");
        assert!(rise < 1e-3, "{weight}×: energy rose by {rise} m·g·L");
    }
    for weight in [1.0, 100.0] {
        let mut solver = lantern_line(1.0, weight);
        let worst = largest_strain_over(&mut solver, &config, 320);
        println!(
            "lanterns {weight}× pulled straight: max strain {:.0} %",
            worst * 100.0
        );
        assert!(solver.particles.all_finite());
        assert!(worst < 3.0, "{weight}× pulled straight: max strain {worst}");
    }
}

/// Two posts joined by a beam (a stick between two pins, out of the system) with ropes of 20
/// links hanging from both, two from the first (a fork): a tree whose closing stick runs from
/// its root, which closes no loop through a movable particle — solved, not swept as a taut
/// path between the pins (a review found it swept whole: 6.2 % and 42 % strain; this scene
/// swept: 6.0 % with 1× weights). Weights 1× and 100× a link, swinging from a sideways start,
/// 5 s, no damping: below 10⁻⁶ (measured below 10⁻⁹).
#[test]
fn ropes_hanging_from_two_joined_posts_swing_unstretched() {
    for weight in [1.0, 100.0] {
        let mut solver = Solver::default();
        let posts = [DVec3::ZERO, DVec3::X * 0.5].map(|at| {
            let p = solver.add_particle(at, 0.0);
            solver.pin(p, at);
            p
        });
        solver
            .sticks
            .push(posts, 0.5, 0.0, StickKind::Equal, f64::INFINITY, 0);
        for (post, side) in [(posts[0], -1.0), (posts[0], 1.0), (posts[1], 1.0)] {
            let top = solver.particles.position[post as usize];
            let mut above = post;
            for j in 1..=20 {
                let w = if j == 20 { 1.0 / weight } else { 1.0 };
                let at = top + DVec3::new(0.7 * side, -0.7, 0.1) * (0.02 * j as f64);
                let p = solver.add_particle(at, w);
                let rest = 0.02 * DVec3::new(0.7, 0.7, 0.1).length();
                solver
                    .sticks
                    .push([above, p], rest, 0.0, StickKind::Equal, f64::INFINITY, 0);
                above = p;
            }
        }
        solver.organize();
        assert!(!solver.islands.list[0].trees.is_empty(), "solved as a tree");
        let worst = largest_strain_over(&mut solver, &config(0.0, true), 320);
        println!(
            "ropes from two joined posts, {weight}×: max strain {:.2e} %",
            worst * 100.0
        );
        assert!(worst < 1e-6, "{weight}×: max strain {worst}");
    }
}

/// A lamp hung from two pins 0.8 m apart by a V of ropes (32 links of 2 cm each, straight, to
/// a ring 0.5 m below), then 30 links (0.6 m) down to the lamp, `lamp` × a link.
fn bridle(lamp: f64, method: Method) -> Solver {
    let mut solver = Solver::default();
    solver.method = method;
    let ring = DVec3::new(0.0, -0.5, 0.0);
    let rope = |solver: &mut Solver, from: u32, to: DVec3, links: usize, w_last: f64| {
        let start = solver.particles.position[from as usize];
        let mut previous = from;
        for i in 1..=links {
            let w = if i == links { w_last } else { 1.0 };
            let p = solver.add_particle(start + (to - start) * (i as f64 / links as f64), w);
            solver
                .sticks
                .push([previous, p], 0.02, 0.0, StickKind::Equal, f64::INFINITY, 0);
            previous = p;
        }
        previous
    };
    let [left, right] = [-0.4, 0.4].map(|x| {
        let at = DVec3::new(x, 0.0, 0.0);
        let pin = solver.add_particle(at, 0.0);
        solver.pin(pin, at);
        pin
    });
    let ring = rope(&mut solver, left, ring, 32, 1.0);
    let towards_ring = ring_at(&solver, ring, right);
    let last = rope(&mut solver, right, towards_ring, 31, 1.0);
    solver
        .sticks
        .push([last, ring], 0.02, 0.0, StickKind::Equal, f64::INFINITY, 0);
    let below = solver.particles.position[ring as usize] - DVec3::Y * 0.6;
    rope(&mut solver, ring, below, 30, 1.0 / lamp);
    solver.organize();
    solver
}

/// Where the 31st of 32 equal links from `pin` to `ring` ends.
fn ring_at(solver: &Solver, ring: u32, pin: u32) -> DVec3 {
    let [ring, pin] = [ring, pin].map(|p| solver.particles.position[p as usize]);
    pin + (ring - pin) * (31.0 / 32.0)
}

/// The lamp on its bridle (a tree with two pins, its second pin closing a loop through the
/// first: `solver::tree`'s `closure`), kicked sideways (2 cm in the first step), damping
/// 0.5/s, 10 s: largest link strain after the first second below 10⁻⁶ (measured below 10⁻⁹),
/// lamp 1× and 100× a link; swept 13 % and 70 % (forward and back; 85 % forward alone).
/// Before, as lines meeting at the ring: 6.9 %
/// and 186 %, in 16 339 and 25 074 Newton passes instead of 9573 and 11 133. (A tree with pins
/// below its root was built once before, the stick to a pin eliminated with its movable end,
/// and taken out: unstable where that stick runs straight into its parent, as the bridle's
/// straight ropes do at the start; the loop closure keeps every pivot of the elimination from
/// one pin.)
#[test]
fn a_lamp_on_a_bridle_swings_unstretched() {
    let config = config(0.5, true);
    for lamp in [1.0, 100.0] {
        let mut strain = [0.0; 2];
        for (i, method) in [Method::Sweep, Method::Auto].into_iter().enumerate() {
            let mut solver = bridle(lamp, method);
            let last = solver.particles.len() - 1;
            solver.particles.previous[last] -= DVec3::Z * 0.02;
            strain[i] = (0..640)
                .map(|n| {
                    solver.step(&config);
                    if n < 64 { 0.0 } else { max_strain(&solver) }
                })
                .fold(0.0, f64::max);
            if method == Method::Auto {
                assert!(!solver.islands.list[0].trees.is_empty(), "solved as a tree");
            }
        }
        println!(
            "bridle, lamp {lamp}×: swept {:.2} %, tree {:.2e} %",
            strain[0] * 100.0,
            strain[1] * 100.0
        );
        assert!(strain[0] > 0.01, "the sweep stretches: {}", strain[0]);
        assert!(strain[1] < 1e-6, "the tree: {}", strain[1]);
    }
}

/// The bridle's right pin pulled 1.6 m further out over 16 steps (the ropes between the pins
/// would have to stretch to twice their length), damping 0.5/s: the tree is swept whole while
/// its path between the pins is taut (no solution holds both ends), and nothing explodes: every
/// particle stays finite and within 5 m of the left pin, and the energy over the next 5 s
/// stays within 1.5× its value after the pull. Measured: 21 262 J after the pull, at most
/// 28 906 J (1.36×), farthest particle 4.23 m — the swept lamp rope stretches under the 100×
/// lamp. Before, as lines meeting at the ring (the lamp's line solved exactly, the taut lines
/// swept): 10 030 J, then up to 14 283 J (1.42×), farthest 2.43 m.
#[test]
fn a_bridle_pulled_apart_stays_bounded() {
    let config = config(0.5, true);
    let h = config.timestep / config.substeps as f64;
    let mut solver = bridle(100.0, Method::Auto);
    for _ in 0..64 {
        solver.step(&config);
    }
    let right = solver.pins.particle[1];
    for i in 1..=16 {
        solver
            .pins
            .set_target(1, DVec3::new(0.4 + 0.1 * i as f64, 0.0, 0.0));
        solver.step(&config);
    }
    let after = energy(&solver, h);
    let mut highest = f64::MIN;
    let mut farthest: f64 = 0.0;
    for _ in 0..320 {
        solver.step(&config);
        highest = highest.max(energy(&solver, h));
        let left = solver.particles.position[solver.pins.particle[0] as usize];
        farthest = solver
            .particles
            .position
            .iter()
            .map(|x| (*x - left).length())
            .fold(farthest, f64::max);
    }
    println!(
        "pulled bridle: energy after {after:.0} J, highest {highest:.0} J, farthest {farthest:.2} m"
    );
    assert!(solver.particles.all_finite());
    assert_eq!(
        solver.particles.position[right as usize],
        DVec3::new(2.0, 0.0, 0.0)
    );
    assert!(farthest < 5.0, "a particle flew {farthest} m");
    assert!(
        highest <= 1.5 * after,
        "the energy rose to {highest} from {after}"
    );
}

/// A Y-shaped rope solved as a tree, then a branch tip made immovable in place (no rebuild;
/// the Bevy layer rebuilds when it pins, this is the core on its own): the tree is swept for
/// those substeps instead of eliminated with a singular row. Largest link strain over 1 s:
/// measured 75 %, as swept (sweeps leave 52 % on this rope hanging from one pin); eliminating
/// regardless left the pinned tip's stick uncorrected: 804 %.
#[test]
fn a_tree_pinned_twice_in_place_is_swept() {
    let mut solver = y_rope(1.0, DVec3::NEG_Y, Method::Auto);
    assert!(!solver.islands.list[0].trees.is_empty());
    let config = config(2.0, true);
    for _ in 0..64 {
        solver.step(&config);
    }
    let tip = solver.particles.len() - 1;
    solver.particles.inverse_mass[tip] = 0.0;
    let worst = largest_strain_over(&mut solver, &config, 64);
    println!(
        "tree pinned twice in place: max strain {:.3} %",
        worst * 100.0
    );
    assert!(solver.particles.all_finite());
    assert!(worst < 1.0, "max strain {worst}");
}

/// A free rope bent into an L (20 + 19 links of 1 cm), without and with a third arm from the
/// corner (a tree), no gravity, at rest; then every rest length shortened by 10 % in place. The
/// exact solve corrects the start positions too, so the correction does not become velocity.
/// Largest particle speed after one step: 0 for both; without the start correction 2.4 m/s
/// (L) and 2.2 m/s (tree).
#[test]
fn shortened_sticks_do_not_launch_a_chain_or_a_tree() {
    for arm in [false, true] {
        let mut solver = Solver::default();
        let mut add = |from: Option<u32>, at: DVec3| {
            let p = solver.add_particle(at, 1.0);
            if let Some(from) = from {
                let rest = (solver.particles.position[from as usize] - at).length();
                solver
                    .sticks
                    .push([from, p], rest, 0.0, StickKind::Equal, f64::INFINITY, 0);
            }
            p
        };
        let mut last = add(None, DVec3::ZERO);
        for i in 1..20 {
            last = add(Some(last), DVec3::X * (0.01 * i as f64));
        }
        let corner = last;
        for i in 1..20 {
            last = add(Some(last), DVec3::new(0.19, 0.01 * i as f64, 0.0));
        }
        if arm {
            let mut last = corner;
            for i in 1..10 {
                last = add(Some(last), DVec3::new(0.19, 0.0, 0.01 * i as f64));
            }
        }
        solver.organize();
        assert_eq!(!solver.islands.list[0].trees.is_empty(), arm);
        for rest in &mut solver.sticks.rest_length {
            *rest *= 0.9;
        }
        let config = StepConfig {
            gravity: DVec3::ZERO,
            ..StepConfig::default()
        };
        solver.step(&config);
        let p = &solver.particles;
        let fastest = (0..p.len())
            .map(|i| (p.position[i] - p.previous[i]).length() / config.substep())
            .fold(0.0, f64::max);
        println!("L rope, third arm {arm}: fastest particle {fastest:.2e} m/s");
        assert!(fastest < 1e-6, "arm {arm}: {fastest} m/s");
        assert!(max_strain(&solver) < 1e-6, "arm {arm}: not shortened");
    }
}

/// Exact period of a pendulum of length `l` released at `amplitude` radians.
fn exact_period(l: f64, amplitude: f64) -> f64 {
    let (mut a, mut b) = (1.0, (amplitude / 2.0).cos());
    for _ in 0..30 {
        (a, b) = ((a + b) / 2.0, (a * b).sqrt());
    }
    2.0 * std::f64::consts::PI * (l / G).sqrt() / a
}

/// Period error and energy left after 10 s of a 1 m pendulum released at `degrees`.
fn pendulum(degrees: f64, shake: bool) -> (f64, f64) {
    let amplitude = degrees.to_radians();
    let start = DVec3::new(amplitude.sin(), -amplitude.cos(), 0.0);
    let mut solver = chain(1, 1.0, start, 1.0, Method::Auto);
    let config = config(0.0, shake);
    let h = config.substep();
    let start_energy = -G * amplitude.cos();
    // Zero crossings of x (through the vertical), interpolated within a step.
    let mut crossings = Vec::new();
    let mut last_x = solver.particles.position[1].x;
    let mut energies = Vec::new();
    for n in 1..=640 {
        solver.step(&config);
        let x = solver.particles.position[1].x;
        if (x < 0.0) != (last_x < 0.0) {
            crossings.push((n as f64 - 1.0 + last_x / (last_x - x)) * config.timestep);
        }
        last_x = x;
        if n > 640 - 64 * 3 {
            energies.push(energy(&solver, h));
        }
    }
    // Mean over the last 3 s (several periods): the sampled energy oscillates within a period.
    let mean = energies.iter().sum::<f64>() / energies.len() as f64;
    let energy_left = (mean + G) / (start_energy + G); // relative to the lowest point
    let periods = (crossings.len() - 1) / 2;
    let period = (crossings[2 * periods] - crossings[0]) / periods as f64;
    (period / exact_period(1.0, amplitude) - 1.0, energy_left)
}

/// A 1 m pendulum at 90° and 120°, 8 × 1, 10 s. Measured: projection 74 % / 70 % of the energy
/// left, period −3.5 % / −8.2 %; SHAKE 100.00 % of the energy, period within 0.0005 % (goal:
/// within 0.1 % and ≥ 99 %).
#[test]
fn pendulum_keeps_its_period_and_energy() {
    for degrees in [90.0, 120.0] {
        let (period_projection, energy_projection) = pendulum(degrees, false);
        let (period, energy) = pendulum(degrees, true);
        println!(
            "{degrees}°: projection period {:+.4} % energy {:.4}; SHAKE period {:+.4} % energy {:.4}",
            period_projection * 100.0,
            energy_projection,
            period * 100.0,
            energy
        );
        assert!(energy_projection < 0.9, "the projection damps");
        assert!(period.abs() < 1e-3, "period error {period}");
        assert!((0.99..=1.01).contains(&energy), "energy {energy}");
    }
}

/// Double pendulum, two 1 m links, 1 kg each, released horizontal, 8 × 1, 60 s: energy (at the
/// middle of each substep) relative to its start. Measured: projection 22 % left; SHAKE 100.00 %
/// left, at most 0.03 % above the start (goal: ≥ 95 % and never more than 1 % above).
#[test]
fn double_pendulum_keeps_its_energy() {
    for shake in [false, true] {
        let mut solver = chain(2, 2.0, DVec3::X, 1.0, Method::Auto);
        let config = config(0.0, shake);
        let h = config.substep();
        let start = energy(&solver, h);
        // Relative to the lowest possible energy (both links hanging).
        let floor = -G * (1.0 + 2.0) - 1e-9;
        let mut highest: f64 = 0.0;
        for _ in 0..64 * 60 {
            solver.step(&config);
            highest = highest.max((energy(&solver, h) - floor) / (start - floor));
        }
        let left = (energy(&solver, h) - floor) / (start - floor);
        println!("SHAKE {shake}: energy left {left:.4}, highest {highest:.4}");
        if shake {
            assert!(left >= 0.95, "energy left {left}");
            assert!(highest <= 1.01, "energy rose to {highest}");
        } else {
            assert!(left < 0.5, "the projection damps: {left}");
        }
    }
}

/// A lone rigid stick is solved by SHAKE in closed form (`solver::lone_stick`); a compliance of
/// 10⁻³⁰⁰ m/N (no physical difference) sends the same stick through the general Newton solve.
/// Both must follow one trajectory: a pendulum released at 120° and a free dumbbell (masses
/// 1 and 3 kg) thrown spinning, 8 × 1, 5 s. Measured: 8·10⁻¹² m apart (pendulum) and 1.0·10⁻⁸ m
/// (dumbbell, 112 m travelled: Newton stops within 10⁻⁹ of the length, often after its warm
/// start alone, where the closed form is exact), lengths exact to 10⁻¹⁴; the dumbbell's centre
/// of mass within 5·10⁻¹⁰ m of its parabola (rounding over 112 m). A sign or root error in the
/// closed form puts them metres apart.
#[test]
fn a_lone_stick_in_closed_form_follows_the_newton_solve() {
    let run = |compliance: f64, pinned: bool| {
        let mut solver = Solver::default();
        solver.method = Method::Lines;
        let a = solver.add_particle(DVec3::ZERO, if pinned { 0.0 } else { 1.0 });
        if pinned {
            solver.pin(a, DVec3::ZERO);
        }
        let angle = 120f64.to_radians();
        let b = solver.add_particle(DVec3::new(angle.sin(), -angle.cos(), 0.0), 1.0 / 3.0);
        solver
            .sticks
            .push([a, b], 1.0, compliance, StickKind::Equal, f64::INFINITY, 0);
        solver.organize();
        if !pinned {
            // Thrown upwards at 3 m/s, spinning at about 1.3 turns per second.
            let (h, p) = (config(0.0, true).substep(), &mut solver.particles);
            p.previous[0] = p.position[0] - DVec3::new(0.0, 3.0, 1.0) * h;
            p.previous[1] = p.position[1] - DVec3::new(-8.0, 3.0, 0.0) * h;
        }
        let centre = |p: &bevy_verlet_physics::solver::Particles| {
            (p.position[0] + 3.0 * p.position[1]) / 4.0
        };
        let (start, velocity) = (centre(&solver.particles), DVec3::new(-6.0, 3.0, 0.25));
        let h = config(0.0, true).substep();
        let (mut path, mut off_parabola) = (Vec::new(), 0.0f64);
        for n in 1..=64 * 5 {
            solver.step(&config(0.0, true));
            path.push([solver.particles.position[0], solver.particles.position[1]]);
            let t = n as f64 / 64.0;
            // (Verlet from `x − x* = v h`: the drop after k substeps is g h² k(k+1)/2.)
            let parabola = start + velocity * t - DVec3::Y * (0.5 * G * t * (t + h));
            let off = (centre(&solver.particles) - parabola).length();
            off_parabola = off_parabola.max(off);
        }
        if !pinned {
            println!("centre of mass at most {off_parabola:.1e} m off its parabola");
            assert!(
                off_parabola < 1e-9,
                "centre of mass {off_parabola} m off its parabola"
            );
        }
        (path, max_strain(&solver), solver.line_passes())
    };
    for pinned in [true, false] {
        let (closed, strain, closed_passes) = run(0.0, pinned);
        let (newton, newton_strain, newton_passes) = run(1e-300, pinned);
        let apart = closed
            .iter()
            .zip(&newton)
            .flat_map(|(c, n)| [(c[0] - n[0]).length(), (c[1] - n[1]).length()])
            .fold(0.0, f64::max);
        let travelled = (closed[0][1] - closed.last().unwrap()[1]).length();
        println!(
            "pinned {pinned}: apart {apart:.2e} m, strains {strain:.1e} / {newton_strain:.1e}, travelled {travelled:.2} m, passes {closed_passes} / {newton_passes}"
        );
        assert!(travelled > 0.5, "the stick moved: {travelled}");
        assert!(apart < 1e-6, "closed form and Newton {apart} m apart");
        assert!(
            strain < 1e-12 && newton_strain < 1e-9,
            "{strain} {newton_strain}"
        );
    }
}

/// A one-stick line among others (a corner diagonal of a small sheared cloth forced onto lines,
/// one corner pinned, swinging) at 8 × 2: the second round solves it by the general SHAKE along
/// the direction the closed form used. Measured over 5 s: largest strain 0.86 % (as before the
/// closed form), the energy never above its start; with the start direction left stale (a bug
/// the review found), 11 % and up to 114 J above it.
#[test]
fn a_lone_stick_among_lines_holds_in_later_rounds() {
    let (n, spacing) = (3, 0.1);
    let mut solver = Solver::default();
    solver.method = Method::Lines;
    grid::cloth(&mut solver, n, spacing, DVec3::ZERO, &[(0, 0)]);
    // Shear diagonals: the two at the free corners are lines of one stick.
    let index = |column: usize, row: usize| (row * n + column) as u32;
    for row in 1..n {
        for column in 1..n {
            let diagonal = spacing * 2f64.sqrt();
            for ends in [
                [index(column - 1, row - 1), index(column, row)],
                [index(column, row - 1), index(column - 1, row)],
            ] {
                let kind = StickKind::Equal;
                solver
                    .sticks
                    .push(ends, diagonal, 0.0, kind, f64::INFINITY, 0);
            }
        }
    }
    solver.organize();
    let config = StepConfig {
        iterations: 2,
        ..config(0.0, true)
    };
    let h = config.substep();
    let start = energy(&solver, h);
    let (mut strain, mut highest): (f64, f64) = (0.0, f64::NEG_INFINITY);
    for _ in 0..64 * 5 {
        solver.step(&config);
        strain = strain.max(max_strain(&solver));
        highest = highest.max(energy(&solver, h) - start);
    }
    println!("largest strain {strain:.4}, energy at most {highest:+.3} J from its start");
    assert!(strain < 0.02, "strain {strain}");
    assert!(highest < 0.05, "energy rose by {highest} J");
}

/// One-sided and compliant sticks in a line. A slack rope (`AtMost`) does not hold its end: the
/// end falls freely until the rope is taut; a strut (`AtLeast`) lets a hanging bob fall;
/// a compliant stick (α = 0.01 m/N) under a 1 kg bob hangs stretched by α·m·g = 9.81 cm, the
/// static XPBD answer, to 10⁻⁶.
#[test]
fn one_sided_and_compliant_sticks_in_lines() {
    let config = config(0.0, true);
    let hang = |kind: StickKind, compliance: f64, bob: DVec3| {
        let mut solver = Solver::default();
        let pin = solver.add_particle(DVec3::ZERO, 0.0);
        solver.pin(pin, DVec3::ZERO);
        let b = solver.add_particle(bob, 1.0);
        solver
            .sticks
            .push([pin, b], 1.0, compliance, kind, f64::INFINITY, 0);
        solver.organize();
        assert_eq!(solver.islands.list[0].method, Method::Lines);
        solver
    };
    // Slack rope: the end starts 0.1 m below the pin and falls freely for 0.25 s (0.31 m; from
    // rest, Verlet falls g·h²·n(n+1)/2 in n substeps).
    let mut rope = hang(StickKind::AtMost, 0.0, DVec3::new(0.0, -0.1, 0.0));
    for _ in 0..16 {
        rope.step(&config);
    }
    let fall = -0.1 - rope.particles.position[1].y;
    let (h, n) = (config.substep(), 128.0);
    assert!(
        (fall - G * h * h * n * (n + 1.0) / 2.0).abs() < 1e-9,
        "fell {fall}"
    );
    // Strut: the bob hanging 1 m below falls through.
    let mut strut = hang(StickKind::AtLeast, 0.0, DVec3::NEG_Y);
    for _ in 0..32 {
        strut.step(&config);
    }
    assert!(
        strut.particles.position[1].y < -1.5,
        "the strut held its bob"
    );
    // Compliant stick, damped to rest.
    let mut soft = hang(StickKind::Equal, 0.01, DVec3::NEG_Y);
    let damped = StepConfig {
        damping: 5.0,
        ..config
    };
    for _ in 0..64 * 10 {
        soft.step(&damped);
    }
    let stretch = soft.particles.position[1].length() - 1.0;
    assert!((stretch - 0.01 * G).abs() < 1e-6, "stretch {stretch}");
}

/// `organize` leaves nothing of the last substeps behind: a whipping 1000:1 chain stepped,
/// re-organized and stepped again matches, bit for bit, a fresh solver built from the same state.
/// (Found by review: a line rebuilt where one had just fallen back from SHAKE inherited the
/// fallback and skipped SHAKE for a substep — 32 of 200 steps differed.)
#[test]
fn organize_forgets_the_last_substeps() {
    let config = StepConfig::default();
    let mut solver = chain(40, 2.0, DVec3::X, 1000.0, Method::Lines);
    let bits = |s: &Solver| -> Vec<[u64; 3]> {
        let position = &s.particles.position;
        position
            .iter()
            .map(|p| p.to_array().map(f64::to_bits))
            .collect()
    };
    for _ in 0..200 {
        solver.step(&config);
        let mut stepped = solver.clone();
        stepped.organize();
        let mut fresh = Solver::default();
        fresh.particles = solver.particles.clone();
        fresh.sticks = solver.sticks.clone();
        fresh.pins = solver.pins.clone();
        fresh.tethered = solver.tethered.clone();
        fresh.method = solver.method;
        fresh.organize();
        stepped.step(&config);
        fresh.step(&config);
        assert_eq!(bits(&stepped), bits(&fresh));
    }
}
