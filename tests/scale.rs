//! Islands, colour batches, parallel solving, per-island settings and sleeping — in the solver
//! core (`Solver::organize`, `Solver::step_with`).

use bevy_verlet_physics::solver::{
    IslandSettings, Method, ScopedThreads, Serial, Sleep, Solver, StepConfig, StickKind,
};
use glam::DVec3;
use grid::cloth;
use std::collections::HashSet;

mod grid;

/// Ropes whose particles are interleaved in the arrays (rope `r`'s particle `k` is slot
/// `k·ropes + r`), each pinned at its first particle and started horizontally.
fn interleaved_ropes(solver: &mut Solver, ropes: usize, links: usize) {
    let first = solver.particles.len() as u32;
    for k in 0..=links {
        for r in 0..ropes {
            let p = DVec3::new(k as f64 * 0.1, 0.0, r as f64);
            solver.add_particle(p, 1.0 + r as f64 * 0.5);
        }
    }
    let slot = |k: usize, r: usize| first + (k * ropes + r) as u32;
    for k in 0..links {
        for r in 0..ropes {
            let kind = if r % 2 == 0 {
                StickKind::Equal
            } else {
                StickKind::AtMost
            };
            let ends = [slot(k, r), slot(k + 1, r)];
            solver
                .sticks
                .push(ends, 0.1, 1e-6 * r as f64, kind, f64::INFINITY, 0);
        }
    }
    for r in 0..ropes {
        let i = slot(0, r);
        solver.pin(i, solver.particles.position[i as usize]);
    }
}

fn config(substeps: u32, iterations: u32) -> StepConfig {
    StepConfig {
        substeps,
        iterations,
        damping: 0.1,
        ..StepConfig::default()
    }
}

fn bits(positions: &[DVec3]) -> Vec<[u64; 3]> {
    positions
        .iter()
        .map(|p| p.to_array().map(f64::to_bits))
        .collect()
}

#[test]
fn organize_finds_islands_and_keeps_small_islands_bitwise() {
    let mut plain = Solver::default();
    // (Sweeps: an unorganized solver sweeps, and this compares only the bookkeeping.)
    plain.method = Method::Sweep;
    interleaved_ropes(&mut plain, 5, 30);
    plain.add_particle(DVec3::new(0.0, 5.0, 0.0), 1.0); // a free particle: its own island
    let mut organized = plain.clone();
    let reorder = organized.organize();
    assert_eq!(organized.islands.list.len(), 6);
    for island in &organized.islands.list {
        for stick in island.sticks.clone() {
            for end in organized.sticks.ends()[stick as usize] {
                assert!(island.particles.contains(&end), "stick leaves its island");
            }
        }
        for pin in island.pins.clone() {
            assert!(
                island
                    .particles
                    .contains(&organized.pins.particle[pin as usize])
            );
        }
    }
    // Islands are independent and small ones keep their stick order, so organizing changes
    // nothing but where things are stored.
    let config = config(8, 2);
    for _ in 0..200 {
        plain.step(&config);
        organized.step(&config);
    }
    let expected: Vec<DVec3> = reorder
        .particles
        .iter()
        .map(|&old| plain.particles.position[old as usize])
        .collect();
    assert_eq!(bits(&organized.particles.position), bits(&expected));
}

/// Checks that batches tile each island's sticks and that independent batches share no
/// particle; returns the batch count of the first island and whether any batch is serial.
fn check_batches(solver: &Solver) -> (usize, bool) {
    let islands = &solver.islands;
    let mut seen = vec![false; solver.sticks.len()];
    let mut any_serial = false;
    for island in &islands.list {
        let batches = &islands.batches[island.batches.start as usize..island.batches.end as usize];
        let mut next = island.sticks.start;
        for batch in batches {
            assert_eq!(batch.sticks.start, next, "batches tile the island in order");
            next = batch.sticks.end;
            any_serial |= !batch.independent;
            let mut particles = HashSet::new();
            for stick in batch.sticks.clone() {
                assert!(!std::mem::replace(&mut seen[stick as usize], true));
                for end in solver.sticks.ends()[stick as usize] {
                    assert!(island.particles.contains(&end), "stick leaves its island");
                    if batch.independent {
                        assert!(particles.insert(end), "two sticks of a batch share {end}");
                    }
                }
            }
        }
        assert_eq!(next, island.sticks.end);
    }
    assert!(seen.iter().all(|&s| s), "every stick in exactly one batch");
    let first = islands.list[0].batches.len();
    (first, any_serial)
}

#[test]
fn colour_batches_share_no_particle_and_cover_every_stick_once() {
    let mut grid = Solver::default();
    cloth(&mut grid, 60, 0.1, DVec3::ZERO, &[(0, 0), (59, 0)]);
    grid.organize();
    // A grid (6 960 sticks, so coloured) needs 4 colours: 4 independent batches.
    assert_eq!(check_batches(&grid), (4, false));

    // A hub tied to 100 cloth particles has more sticks than there are colours: the
    // overflow goes to a batch solved serially.
    let mut hub_cloth = Solver::default();
    cloth(&mut hub_cloth, 60, 0.1, DVec3::ZERO, &[(0, 0), (59, 0)]);
    let hub = hub_cloth.add_particle(DVec3::new(3.0, 1.0, 0.0), 1.0);
    for k in 0..100 {
        let rest = 1.0 + k as f64 * 0.01;
        hub_cloth
            .sticks
            .push([hub, k * 7], rest, 0.0, StickKind::Equal, f64::INFINITY, 0);
    }
    hub_cloth.organize();
    let (batches, any_serial) = check_batches(&hub_cloth);
    assert!(any_serial && batches > 64, "{batches} batches");
    // Small islands, and chains of any length, keep their order in one serial batch.
    let mut ropes = Solver::default();
    interleaved_ropes(&mut ropes, 3, 10);
    interleaved_ropes(&mut ropes, 1, 5000);
    ropes.organize();
    assert_eq!(check_batches(&ropes), (1, true));
    assert!(ropes.islands.batches.iter().all(|b| !b.independent));
}

#[test]
fn parallel_solving_is_bitwise_identical_to_serial() {
    let mut serial = Solver::default();
    cloth(&mut serial, 72, 0.05, DVec3::ZERO, &[(0, 0), (71, 0)]);
    let first_rope = serial.particles.len() as u32;
    interleaved_ropes(&mut serial, 400, 50);
    // A 10-link branch from the middle of every fourth rope: 100 trees, solved whole.
    for r in (0..400).step_by(4) {
        let mut from = first_rope + (25 * 400 + r) as u32;
        for _ in 0..10 {
            let at = serial.particles.position[from as usize] + DVec3::new(0.0, 0.1, 0.0);
            let p = serial.add_particle(at, 1.0);
            serial
                .sticks
                .push([from, p], 0.1, 0.0, StickKind::Equal, f64::INFINITY, 0);
            from = p;
        }
    }
    serial.organize();
    let trees = serial
        .islands
        .list
        .iter()
        .filter(|i| !i.trees.is_empty())
        .count();
    assert_eq!(trees, 100);
    let mut threaded = serial.clone();
    let mut four = serial.clone();
    // 4 iterations: the cloth (10 224 sticks × 4) is solved on every thread, the 400 ropes and
    // trees (100 k units of work) are spread in groups.
    let config = config(4, 4);
    for _ in 0..30 {
        serial.step_with(&config, &Serial);
        threaded.step_with(&config, &ScopedThreads(2));
        four.step_with(&config, &ScopedThreads(4));
    }
    assert!(serial.particles.all_finite());
    assert_eq!(
        bits(&serial.particles.position),
        bits(&threaded.particles.position)
    );
    assert_eq!(
        bits(&serial.particles.position),
        bits(&four.particles.position)
    );
}

/// The limitation measured before colour batches: a 100 × 100 cloth pinned at its two top
/// corners, one projection per substep, swept in row-major order, blew up (positions ~1e76 m
/// within 10 s at 8 × 1). Organized (colour order), it hangs.
#[test]
fn taut_two_corner_cloth_stays_bounded_in_colour_order() {
    for (substeps, iterations) in [(8, 1), (16, 1), (4, 1), (1, 8)] {
        let mut solver = Solver::default();
        cloth(&mut solver, 100, 0.02, DVec3::ZERO, &[(0, 0), (99, 0)]);
        solver.organize();
        let config = StepConfig {
            substeps,
            iterations,
            damping: 1.0,
            ..StepConfig::default()
        };
        let mut farthest: f64 = 0.0;
        for _ in 0..640 {
            solver.step(&config);
            let step_max = solver
                .particles
                .position
                .iter()
                .map(|p| p.length())
                .fold(0.0, f64::max);
            farthest = farthest.max(step_max);
        }
        // The cloth is 2 m wide and 2 m long; even stretched it stays within ~10 m of its pins.
        assert!(
            farthest < 10.0,
            "{substeps}x{iterations}: a particle reached {farthest} m"
        );
    }
}

#[test]
fn island_override_matches_a_solo_run_with_those_settings() {
    let mut both = Solver::default();
    // (Sweeps: the solo runs are unorganized, and unorganized solvers sweep.)
    both.method = Method::Sweep;
    interleaved_ropes(&mut both, 2, 20);
    let light = IslandSettings {
        substeps: 2,
        iterations: 3,
    };
    // Rope 1 (slot 1 is its first particle) gets 2 × 3; rope 0 keeps the step's 8 × 1.
    both.island_settings.push((1, light));
    let reorder = both.organize();
    let step_config = config(8, 1);
    let solo = |settings: StepConfig, rope: usize| {
        let mut alone = Solver::default();
        interleaved_ropes(&mut alone, 2, 20);
        // Keep only rope `rope`'s sticks moving by pinning the other rope everywhere.
        for k in 0..=20 {
            let i = (k * 2 + (1 - rope)) as u32;
            alone.pin(i, alone.particles.position[i as usize]);
        }
        for _ in 0..100 {
            alone.step(&settings);
        }
        alone
    };
    for _ in 0..100 {
        both.step(&step_config);
    }
    let fast = solo(step_config, 0);
    let slow = solo(config(2, 3), 1);
    for (new, &old) in reorder.particles.iter().enumerate() {
        let reference = if old % 2 == 0 { &fast } else { &slow };
        assert_eq!(
            both.particles.position[new].to_array().map(f64::to_bits),
            reference.particles.position[old as usize]
                .to_array()
                .map(f64::to_bits),
            "particle {old}"
        );
    }
}

#[test]
fn resting_island_sleeps_and_wakes_when_touched() {
    let mut solver = Solver::default();
    interleaved_ropes(&mut solver, 1, 10);
    cloth(
        &mut solver,
        8,
        0.1,
        DVec3::new(5.0, 0.0, 0.0),
        &[(0, 0), (7, 0)],
    );
    let reorder = solver.organize();
    let new_slot = |old: u32| reorder.particles.iter().position(|&o| o == old).unwrap() as u32;
    let config = StepConfig {
        damping: 2.0,
        sleep: Some(Sleep::for_gravity(9.81)),
        ..StepConfig::default()
    };
    let mut steps = 0;
    while solver.sleeping_islands() < 2 && steps < 64 * 30 {
        solver.step(&config);
        steps += 1;
    }
    assert_eq!(solver.sleeping_islands(), 2, "rope and cloth sleep");
    // Asleep: frozen exactly, at rest.
    let frozen = solver.particles.position.clone();
    for _ in 0..10 {
        solver.step(&config);
    }
    let rope = &solver.islands.list[0];
    for i in rope.particles.clone() {
        let i = i as usize;
        assert_eq!(solver.particles.position[i], frozen[i]);
        assert_eq!(solver.particles.previous[i], frozen[i]);
    }
    // Touched: a moved pin wakes the cloth, `wake` wakes the rope.
    let cloth_pin = solver.islands.list[1].pins.start as usize;
    let target = solver.pins.to[cloth_pin] + DVec3::X * 0.1;
    solver.pins.set_target(cloth_pin, target);
    solver.wake(new_slot(5));
    solver.step(&config);
    assert!(!solver.islands.list[0].asleep && !solver.islands.list[1].asleep);
    // A change of settings wakes everything too.
    while solver.sleeping_islands() < 2 {
        solver.step(&config);
    }
    solver.step(&StepConfig {
        gravity: DVec3::new(1.0, -9.81, 0.0),
        ..config
    });
    assert_eq!(solver.sleeping_islands(), 0);
}
