//! `StepConfig::line_substeps`: islands solved by lines (chains, ropes, pendulums, trees) take
//! their own substep count while swept islands keep the step's. On the solver core alone, at
//! Bevy's 64 Hz fixed step; the Bevy side (`VerletConfig::line_substeps`) is in
//! `tests/islands.rs`.

use bevy_verlet_physics::solver::{IslandSettings, Method, Solver, StepConfig, StickKind};
use glam::DVec3;

mod chain;

use chain::chain_along;

const G: f64 = 9.81;

/// A chain of `links` rigid links, `length` long, pinned at the origin and laid out along `+X`,
/// its tip `tip_ratio` times as heavy as a link (1 kg). Returns its tip.
fn chain(solver: &mut Solver, links: usize, length: f64, tip_ratio: f64) -> u32 {
    chain_along(solver, (links, length), tip_ratio, DVec3::X)
}

/// A 10 × 10 cloth of 5 cm hung by its top row, 3 m to the side (swept under `Auto`).
fn cloth(solver: &mut Solver) -> u32 {
    let n = 10;
    let first = solver.particles.len() as u32;
    for row in 0..n {
        for column in 0..n {
            let at = DVec3::new(3.0 + 0.05 * column as f64, -0.05 * row as f64, 0.0);
            let p = solver.add_particle(at, if row == 0 { 0.0 } else { 1.0 });
            if row == 0 {
                solver.pin(p, at);
            }
            let index = |c: usize, r: usize| first + (r * n + c) as u32;
            let kind = StickKind::Equal;
            if column > 0 {
                let ends = [index(column - 1, row), p];
                solver.sticks.push(ends, 0.05, 0.0, kind, f64::INFINITY, 0);
            }
            if row > 0 {
                let ends = [index(column, row - 1), p];
                solver.sticks.push(ends, 0.05, 0.0, kind, f64::INFINITY, 0);
            }
        }
    }
    first + (n * n) as u32 - 1
}

fn max_strain(solver: &Solver) -> f64 {
    (0..solver.sticks.len())
        .map(|i| solver.sticks.strain(i, &solver.particles).abs())
        .fold(0.0, f64::max)
}

fn two() -> StepConfig {
    StepConfig {
        line_substeps: Some(2),
        ..StepConfig::default()
    }
}

/// Beside a swept cloth, a chain takes 2 substeps and the cloth 8; with the chain alone the
/// step takes 2 global substeps, with the cloth 8. The chain's positions are the same bits as
/// in a run of its own at 2 × 1: the lockstep with the cloth changes nothing for it.
#[test]
fn lines_take_their_own_substeps_beside_a_swept_cloth() {
    let mut both = Solver::default();
    let tip = chain(&mut both, 20, 1.0, 10.0);
    let corner = cloth(&mut both);
    both.organize();
    let method = |solver: &Solver, slot: u32| {
        let island = solver.islands.of_particle(slot).unwrap();
        solver.islands.list[island].method
    };
    assert_eq!(method(&both, tip), Method::Lines);
    assert_eq!(method(&both, corner), Method::Sweep);
    let mut alone = Solver::default();
    chain(&mut alone, 20, 1.0, 10.0);
    alone.organize();
    let solo = StepConfig {
        substeps: 2,
        ..StepConfig::default()
    };
    assert_eq!(both.begin_step(&two()), 8);
    assert_eq!(alone.begin_step(&two()), 2);
    for _ in 0..64 * 2 {
        both.step(&two());
        alone.step(&solo);
    }
    let step = two().timestep;
    assert_eq!(both.state_substep_of(tip), Some(step / 2.0));
    assert_eq!(both.state_substep_of(corner), Some(step / 8.0));
    let chain_bits = |solver: &Solver, first: usize| {
        solver.particles.position[first..first + 21]
            .iter()
            .flat_map(|p| p.to_array().map(f64::to_bits))
            .collect::<Vec<_>>()
    };
    let first_of_chain = |solver: &Solver| {
        let island = solver.islands.of_particle(tip).unwrap();
        solver.islands.list[island].particles.start as usize
    };
    assert_eq!(
        chain_bits(&both, first_of_chain(&both)),
        chain_bits(&alone, first_of_chain(&alone))
    );
}

/// A fixed step longer than 1/64 s gives lines more substeps, none longer than 1/64 s
/// (`LINE_SUBSTEP_LONGEST`), up to the step's: at 30 Hz a chain beside a swept cloth takes 3
/// of the step's 8 — not a divisor of 8 — the same bits as in a run of its own at 3 × 1; at
/// 16 Hz 4, at 4 Hz the step's 8.
#[test]
fn a_long_fixed_step_gives_lines_more_substeps() {
    for (hz, expected) in [(64.0, 2u32), (30.0, 3), (16.0, 4), (4.0, 8)] {
        let config = StepConfig {
            timestep: 1.0 / hz,
            ..two()
        };
        let mut both = Solver::default();
        let tip = chain(&mut both, 20, 1.0, 10.0);
        cloth(&mut both);
        both.organize();
        let mut alone = Solver::default();
        chain(&mut alone, 20, 1.0, 10.0);
        alone.organize();
        let solo = StepConfig {
            substeps: expected,
            ..config
        };
        for _ in 0..(2.0 * hz) as usize {
            both.step(&config);
            alone.step(&solo);
        }
        let substep = config.timestep / expected as f64;
        assert_eq!(both.state_substep_of(tip), Some(substep), "{hz} Hz");
        assert!(substep <= 1.0 / 64.0 || expected == config.substeps);
        let bits = |solver: &Solver| {
            let island = solver.islands.of_particle(tip).unwrap();
            let first = solver.islands.list[island].particles.start as usize;
            solver.particles.position[first..first + 21]
                .iter()
                .flat_map(|p| p.to_array().map(f64::to_bits))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&both), bits(&alone), "{hz} Hz");
        assert!(max_strain(&alone) < 1e-6, "{hz} Hz: {}", max_strain(&alone));
    }
}

/// An island's own settings win over `line_substeps`.
#[test]
fn an_island_override_wins_over_line_substeps() {
    let mut solver = Solver::default();
    let tip = chain(&mut solver, 10, 1.0, 1.0);
    solver.island_settings.push((
        tip,
        IslandSettings {
            substeps: 4,
            iterations: 1,
        },
    ));
    solver.organize();
    solver.step(&two());
    assert_eq!(solver.state_substep_of(tip), Some(two().timestep / 4.0));
}

/// The report's swinging 1000:1 chain (100 links, 1 m, from horizontal, 5 s) at 2 substeps:
/// within 10⁻⁶ of its lengths throughout, as at 8, in under a third of the Newton passes
/// (measured: 2175 against 7505 at 8; before the SHAKE backoff, `SHAKE_BACKOFF_LIMIT`, 3417
/// against 7628, 0.45×), and never hit hard enough to take 8 in a step.
#[test]
fn a_whipping_chain_at_two_substeps_stays_unstretched_in_fewer_passes() {
    let run = |config: &StepConfig| {
        let mut solver = Solver::default();
        chain(&mut solver, 100, 1.0, 1000.0);
        solver.organize();
        let mut worst: f64 = 0.0;
        for _ in 0..64 * 5 {
            solver.step(config);
            worst = worst.max(max_strain(&solver));
        }
        (worst, solver.line_passes())
    };
    let (at_two, passes_two) = run(&two());
    let (at_eight, passes_eight) = run(&StepConfig::default());
    // (No step of it is a hit: the same passes as 2 substeps throughout.)
    let throughout = StepConfig {
        substeps: 2,
        ..StepConfig::default()
    };
    assert_eq!(run(&throughout).1, passes_two);
    println!(
        "1000:1 chain: 2 substeps {at_two:.2e} in {passes_two} passes, 8: {at_eight:.2e} in {passes_eight}"
    );
    assert!(at_two < 1e-6, "strain {at_two}");
    assert!(at_eight < 1e-6, "strain {at_eight}");
    assert!(
        passes_two * 3 < passes_eight,
        "{passes_two} against {passes_eight}"
    );
}

/// A double pendulum (two 1 m links, 1 kg each, released horizontal, no damping) at 2
/// substeps over 60 s keeps at least 99 % of its energy (SHAKE; the report: 0.2 % lost) and
/// never rises 1 % above it (of `m g L`).
#[test]
fn a_double_pendulum_at_two_substeps_keeps_its_energy() {
    let mut solver = Solver::default();
    chain(&mut solver, 2, 2.0, 1.0);
    solver.organize();
    let config = two();
    let h = config.timestep / 2.0;
    let energy = |solver: &Solver| {
        let p = &solver.particles;
        let potential: f64 = (0..p.len())
            .filter(|&i| p.inverse_mass[i] > 0.0)
            .map(|i| G * 0.5 * (p.position[i].y + p.previous[i].y) / p.inverse_mass[i])
            .sum();
        potential + p.kinetic_energy(h)
    };
    solver.step(&config);
    assert_eq!(solver.state_substep_of(1), Some(h));
    let start = energy(&solver);
    let (mut lowest, mut highest) = (start, start);
    for _ in 0..64 * 60 {
        solver.step(&config);
        let e = energy(&solver);
        (lowest, highest) = (lowest.min(e), highest.max(e));
    }
    // (Released horizontal, it falls 1 + 2 m: its energy scale is m g L summed, 3 g.)
    let scale = 3.0 * G;
    let (lost, rise) = ((start - energy(&solver)) / scale, (highest - start) / scale);
    println!(
        "double pendulum at 2 substeps: lost {lost:.4}, highest rise {rise:.2e}, lowest {:.4}",
        (start - lowest) / scale
    );
    assert!(lost < 0.01, "lost {lost}");
    assert!(rise < 0.01, "rise {rise}");
    assert!(max_strain(&solver) < 1e-6);
}

/// A hit takes the step's substeps for that step only: a pendulum (1 m rod) kicked outwards at
/// 200 m/s (its rod would stretch by 1.56 m in a 1/128 s substep) takes 8 substeps in that step
/// and 2 again in the next, the rod having taken the kick out; a pin jumped 8 m in one step
/// (4 m per substep: the 1 m rod, its bob left behind, would stretch by at least 2 m) as well,
/// and its rod stays on its length.
#[test]
fn a_hit_takes_the_steps_substeps_for_that_step_only() {
    let mut solver = Solver::default();
    let bob = chain(&mut solver, 1, 1.0, 1.0);
    solver.organize();
    let config = two();
    let substeps =
        |solver: &Solver| (config.timestep / solver.state_substep_of(bob).unwrap()).round();
    solver.step(&config);
    assert_eq!(substeps(&solver), 2.0);
    let h = config.timestep / 2.0;
    solver.particles.previous[bob as usize] -= DVec3::X * 200.0 * h;
    solver.step(&config);
    assert_eq!(substeps(&solver), 8.0);
    solver.step(&config);
    assert_eq!(substeps(&solver), 2.0);
    let to = DVec3::new(0.0, 8.0, 0.0);
    solver.pins.set_target(0, to);
    solver.step(&config);
    assert_eq!(substeps(&solver), 8.0);
    for _ in 0..8 {
        solver.step(&config);
    }
    assert_eq!(substeps(&solver), 2.0);
    assert!(max_strain(&solver) < 1e-9, "strain {}", max_strain(&solver));
}

/// A rope carried along by its pin is not hit: its links move with the pin. A 20-link rope of
/// 5 cm, its pin moved at 10 m/s (7.8 cm per 1/128 s substep, beyond a link's length) for 2 s,
/// takes 2 substeps in every step (measured: in no step 8; with pins judged by how far they
/// travel alone, as a first version of the guard did: in every step) and stays on its lengths.
#[test]
fn a_rope_carried_along_by_its_pin_keeps_its_line_substeps() {
    let mut solver = Solver::default();
    let tip = chain_along(&mut solver, (20, 1.0), 1.0, DVec3::NEG_Y);
    solver.organize();
    let config = two();
    let mut full_steps = 0;
    let mut worst: f64 = 0.0;
    for step in 1..=128 {
        let to = DVec3::X * 10.0 * config.timestep * step as f64;
        solver.pins.set_target(0, to);
        solver.step(&config);
        if solver.state_substep_of(tip) != Some(config.timestep / 2.0) {
            full_steps += 1;
        }
        worst = worst.max(max_strain(&solver));
    }
    println!("carried rope: {full_steps} steps at 8 substeps, strain {worst:.2e}");
    assert!(full_steps <= 1, "{full_steps} steps at 8 substeps");
    assert!(worst < 1e-6, "strain {worst}");
}

/// A spring too stiff for the longer substep keeps its island at the step's substeps
/// (`SPRING_STIFFER_THAN`): two 1 kg particles on a spring of 10⁻⁵ m/N have `(ωh)²` = 12 at
/// 1/128 s (Verlet is stable below 4), 0.76 at 1/512 s; one of 10⁻⁴ m/N has 1.2 and takes 2.
#[test]
fn a_stiff_spring_keeps_its_island_at_the_steps_substeps() {
    for (compliance, expected) in [(1e-5, 8.0), (1e-4, 2.0)] {
        let mut solver = Solver::default();
        let pin = solver.add_particle(DVec3::ZERO, 0.0);
        solver.pin(pin, DVec3::ZERO);
        let a = solver.add_particle(DVec3::X * 0.1, 1.0);
        let b = solver.add_particle(DVec3::X * 0.2, 1.0);
        let kind = StickKind::Equal;
        let sticks = &mut solver.sticks;
        sticks.push([pin, a], 0.1, 0.0, kind, f64::INFINITY, 0);
        sticks.push([a, b], 0.1, compliance, kind, f64::INFINITY, 0);
        solver.organize();
        let config = two();
        for _ in 0..64 {
            solver.step(&config);
            let substeps = (config.timestep / solver.state_substep_of(b).unwrap()).round();
            assert_eq!(substeps, expected, "compliance {compliance}");
        }
    }
}
