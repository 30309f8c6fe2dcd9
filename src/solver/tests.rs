//! Unit tests of the solver core against analytic references.

use super::*;
use glam::DVec3;

fn chain(links: usize, link: f64, compliance: f64) -> Solver {
    let mut solver = Solver::default();
    let mut previous = solver.add_particle(DVec3::ZERO, 0.0);
    solver.pin(previous, DVec3::ZERO);
    for i in 1..=links {
        let p = solver.add_particle(DVec3::new(0.0, -link * i as f64, 0.0), 1.0);
        solver.sticks.push(
            [previous, p],
            link,
            compliance,
            StickKind::Equal,
            f64::INFINITY,
            0,
        );
        previous = p;
    }
    solver
}

fn stretch(solver: &Solver) -> f64 {
    let p = &solver.particles.position;
    let rest: f64 = solver.sticks.rest_length.iter().sum();
    let length: f64 = solver
        .sticks
        .ends
        .iter()
        .map(|[a, b]| (p[*a as usize] - p[*b as usize]).length())
        .sum();
    length / rest - 1.0
}

#[test]
fn free_fall_is_exact_with_a_consistent_start() {
    for substeps in [1, 8, 64] {
        for start in [0.0, 1000.0] {
            let config = StepConfig {
                substeps,
                gravity: DVec3::new(0.0, -980.0, 0.0),
                ..StepConfig::default()
            };
            let h = config.substep();
            let v0 = DVec3::new(30.0, 50.0, 0.0);
            let x0 = DVec3::new(start, start, 0.0);
            let mut solver = Solver::default();
            solver.add_particle(x0, 1.0);
            solver.particles.previous[0] = consistent_previous(x0, v0, config.gravity, h);
            for _ in 0..64 {
                solver.step(&config);
            }
            let exact = x0 + v0 + 0.5 * config.gravity;
            let drop = (exact - x0).length();
            let error = (solver.particles.position[0] - exact).length();
            assert!(
                error / drop < 1e-9,
                "substeps {substeps} start {start}: error {error}"
            );
        }
    }
}

#[test]
fn damping_is_independent_of_substeps() {
    let mut speeds = Vec::new();
    for substeps in [1, 4, 32] {
        let config = StepConfig {
            substeps,
            gravity: DVec3::ZERO,
            damping: 2.0,
            ..StepConfig::default()
        };
        let mut solver = Solver::default();
        solver.add_particle(DVec3::ZERO, 1.0);
        solver.particles.previous[0] = DVec3::new(-config.substep(), 0.0, 0.0); // 1 unit/s
        for _ in 0..64 {
            solver.step(&config);
        }
        speeds.push(solver.particles.velocity(0, config.substep()).x);
    }
    let exact = (-2.0f64).exp();
    for speed in speeds {
        assert!((speed - exact).abs() < 1e-9, "{speed} vs {exact}");
    }
}

#[test]
fn rigid_chain_keeps_length_and_pins_hold() {
    let mut solver = chain(20, 0.05, 0.0);
    // Swing it: start horizontal.
    for (i, p) in solver.particles.position.iter_mut().enumerate() {
        *p = DVec3::new(0.05 * i as f64, 0.0, 0.0);
    }
    solver
        .particles
        .previous
        .clone_from(&solver.particles.position);
    let config = StepConfig {
        substeps: 32,
        iterations: 2,
        ..StepConfig::default()
    };
    for _ in 0..128 {
        solver.step(&config);
        assert_eq!(solver.particles.position[0], DVec3::ZERO);
        assert!(solver.particles.all_finite());
    }
    assert!(solver.sticks.max_violation(&solver.particles) < 0.01);
}

#[test]
fn substeps_beat_iterations_for_the_same_budget() {
    let settle = |substeps, iterations| {
        let mut solver = chain(50, 0.02, 0.0);
        let config = StepConfig {
            substeps,
            iterations,
            damping: 1.0,
            ..StepConfig::default()
        };
        for _ in 0..320 {
            solver.step(&config);
        }
        stretch(&solver)
    };
    let iterations = settle(1, 16);
    let substeps = settle(16, 1);
    assert!(
        substeps * 5.0 < iterations,
        "substeps {substeps} iterations {iterations}"
    );
}

#[test]
fn xpbd_stretch_is_independent_of_iterations_and_matches_the_spring() {
    // One particle hanging on a compliant stick: static stretch = α·m·g.
    let compliance = 1e-3;
    let mut results = Vec::new();
    for (substeps, iterations) in [(8, 1), (8, 4), (32, 1), (2, 16)] {
        let mut solver = chain(1, 1.0, compliance);
        let config = StepConfig {
            substeps,
            iterations,
            damping: 5.0,
            ..StepConfig::default()
        };
        for _ in 0..640 {
            solver.step(&config);
        }
        results.push(stretch(&solver));
    }
    let exact = compliance * 9.81;
    for r in results {
        assert!((r - exact).abs() / exact < 0.01, "{r} vs {exact}");
    }
}

#[test]
fn one_sided_sticks_act_in_one_direction_only() {
    for (kind, start, expect) in [
        (StickKind::AtMost, 0.5, 0.5),
        (StickKind::AtMost, 2.0, 1.0),
        (StickKind::AtLeast, 0.5, 1.0),
        (StickKind::AtLeast, 2.0, 2.0),
        (StickKind::Equal, 0.5, 1.0),
        (StickKind::Equal, 2.0, 1.0),
    ] {
        let mut solver = Solver::default();
        solver.add_particle(DVec3::ZERO, 1.0);
        solver.add_particle(DVec3::X * start, 1.0);
        solver.sticks.push([0, 1], 1.0, 0.0, kind, f64::INFINITY, 0);
        solver.relax(0.01, false);
        let length = (solver.particles.position[1] - solver.particles.position[0]).length();
        assert!(
            (length - expect).abs() < 1e-9,
            "{kind:?} from {start}: {length}"
        );
    }
}

#[test]
fn mass_weighting_moves_the_light_end() {
    let mut solver = Solver::default();
    solver.add_particle(DVec3::ZERO, 1.0 / 1000.0);
    solver.add_particle(DVec3::X * 2.0, 1.0);
    solver
        .sticks
        .push([0, 1], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
    solver.relax(0.01, false);
    let heavy = solver.particles.position[0].x;
    let light = solver.particles.position[1].x;
    assert!((light - heavy - 1.0).abs() < 1e-12);
    // Centre of mass is unchanged.
    let com = (heavy * 1000.0 + light) / 1001.0;
    assert!((com - 2.0 / 1001.0).abs() < 1e-12);
}

#[test]
fn tethers_remove_long_chain_stretch() {
    let run = |tethered: bool| {
        let mut solver = chain(100, 0.01, 0.0);
        if tethered {
            solver.tethered.iter_mut().for_each(|t| *t = true);
            solver.rebuild_tethers();
            assert_eq!(solver.tethers.len(), 100);
        }
        let config = StepConfig {
            substeps: 4,
            iterations: 1,
            damping: 1.0,
            ..StepConfig::default()
        };
        for _ in 0..200 {
            solver.step(&config);
        }
        let bottom = solver.particles.position[100].y;
        -bottom - 1.0
    };
    let without = run(false);
    let with = run(true);
    assert!(without > 0.05, "untethered stretch {without}");
    assert!(with.abs() < 1e-9, "tethered stretch {with}");
}

#[test]
fn tearing_uses_post_solve_strain_and_rebuilds_tethers() {
    let mut solver = chain(10, 0.1, 0.0);
    for i in 0..solver.sticks.len() {
        solver.sticks.tear_strain[i] = 0.5;
    }
    solver.sticks.tearable = (0..10).collect();
    solver.tethered.iter_mut().for_each(|t| *t = true);
    solver.rebuild_tethers();
    let config = StepConfig::default();
    solver.step(&config);
    assert!(
        solver.torn.is_empty(),
        "gravity alone must not tear a rigid chain"
    );
    // Yank the tip far away: the post-solve strain of the last link exceeds 50 %.
    solver.particles.position[10] += DVec3::new(0.0, -10.0, 0.0);
    solver.particles.inverse_mass[10] = 0.0;
    solver.step(&config);
    assert!(!solver.torn.is_empty());
    let torn: Vec<_> = solver.torn.clone();
    for &t in &torn {
        assert_eq!(solver.sticks.kind[t as usize], StickKind::Torn);
    }
    // Every tether still reachable goes through untorn sticks only.
    for (&p, &max) in solver
        .tethers
        .particle
        .iter()
        .zip(&solver.tethers.max_length)
    {
        assert!(
            p as usize
                <= torn
                    .iter()
                    .map(|&t| solver.sticks.ends()[t as usize][0])
                    .min()
                    .unwrap() as usize
        );
        assert!(max <= 1.0 + 1e-9);
    }
    solver.step(&config);
    assert!(solver.torn.is_empty(), "a stick tears once");
}

#[test]
fn moving_pin_is_interpolated_across_substeps() {
    let mut solver = chain(1, 1.0, 0.0);
    solver.pins.set_target(0, DVec3::X);
    let config = StepConfig {
        substeps: 4,
        gravity: DVec3::ZERO,
        ..StepConfig::default()
    };
    solver.step(&config);
    assert_eq!(solver.particles.position[0], DVec3::X);
    // The pinned particle's last substep displacement is a quarter of the move.
    let displacement = solver.particles.position[0] - solver.particles.previous[0];
    assert!((displacement.x - 0.25).abs() < 1e-12);
}

#[test]
fn colliders_bounce_and_rest() {
    let mut solver = Solver::default();
    solver.add_particle(DVec3::new(0.0, 1.0, 0.0), 1.0);
    solver.colliders.push(Collider {
        shape: Shape::Plane {
            point: DVec3::ZERO,
            normal: DVec3::Y,
        },
        restitution: 0.5,
        friction: 0.0,
    });
    let config = StepConfig {
        substeps: 16,
        ..StepConfig::default()
    };
    let mut max_after_bounce: f64 = 0.0;
    let mut bounced = false;
    for _ in 0..64 * 3 {
        solver.step(&config);
        let y = solver.particles.position[0].y;
        assert!(y >= -1e-12);
        if solver.particles.velocity(0, config.substep()).y > 0.0 {
            bounced = true;
        }
        if bounced {
            max_after_bounce = max_after_bounce.max(y);
        }
    }
    assert!(bounced);
    // Restitution 0.5 → rebound height ≈ 0.25 of the drop.
    assert!((max_after_bounce - 0.25).abs() < 0.02, "{max_after_bounce}");
}

#[test]
fn angle_constraint_holds_a_branch() {
    let mut solver = Solver::default();
    let root = solver.add_particle(DVec3::ZERO, 0.0);
    let joint = solver.add_particle(DVec3::Y, 0.0);
    let tip = solver.add_particle(DVec3::new(0.0, 2.0, 0.0), 1.0);
    solver.pin(root, DVec3::ZERO);
    solver.pin(joint, DVec3::Y);
    solver
        .sticks
        .push([joint, tip], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
    solver.angles.push(
        [root, joint, tip],
        std::f64::consts::PI,
        0.0,
        Some(DVec3::Z),
    );
    let config = StepConfig {
        substeps: 8,
        gravity: DVec3::new(-9.81, 0.0, 0.0),
        ..StepConfig::default()
    };
    for _ in 0..64 {
        solver.step(&config);
    }
    // Gravity pulls sideways but the branch stays nearly straight.
    assert!(
        solver.particles.position[2].x.abs() < 0.05,
        "{}",
        solver.particles.position[2]
    );
}

#[test]
fn coincident_ends_are_pushed_apart_and_zero_length_sticks_are_satisfied() {
    let mut p = Particles::default();
    for _ in 0..4 {
        p.push(DVec3::ONE, DVec3::ONE, 1.0, 0.0, 0);
    }
    let mut s = Sticks::default();
    s.push([0, 1], 2.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
    s.push([2, 3], 0.0, 0.0, StickKind::Equal, f64::INFINITY, 1);
    relax_sticks(&mut p, &mut s, 1.0 / 512.0, false);
    assert!(p.all_finite());
    // Stick 0 pushes along +X, to the full rest length (rigid, equal masses: 1 each way).
    assert_eq!(p.position[0], DVec3::new(2.0, 1.0, 1.0));
    assert_eq!(p.position[1], DVec3::new(0.0, 1.0, 1.0));
    // A zero-length stick between coincident particles is satisfied: nothing moves.
    assert_eq!(p.position[2], DVec3::ONE);
    assert_eq!(p.position[3], DVec3::ONE);
    // A rope link (pulls only) has nothing to do when its ends coincide.
    let mut q = Particles::default();
    q.push(DVec3::ZERO, DVec3::ZERO, 1.0, 0.0, 0);
    q.push(DVec3::ZERO, DVec3::ZERO, 1.0, 0.0, 1);
    let mut rope = Sticks::default();
    rope.push([0, 1], 1.0, 0.0, StickKind::AtMost, f64::INFINITY, 0);
    relax_sticks(&mut q, &mut rope, 1.0 / 512.0, false);
    assert_eq!(q.position, vec![DVec3::ZERO; 2]);
    // Another stick index pushes along another direction, still in the XY plane.
    let mut t = Particles::default();
    for _ in 0..2 {
        t.push(DVec3::ZERO, DVec3::ZERO, 1.0, 0.0, 0);
    }
    let mut two = Sticks::default();
    two.push([0, 0], 1.0, 0.0, StickKind::Torn, f64::INFINITY, 0);
    two.push([0, 1], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 1);
    relax_sticks(&mut t, &mut two, 1.0 / 512.0, false);
    let d = t.position[0] - t.position[1];
    assert!(
        (d.length() - 1.0).abs() < 1e-12 && d.z == 0.0 && d.y.abs() > 0.1,
        "{d}"
    );
}

#[test]
fn tethers_across_islands_make_the_layout_stale() {
    // A pinned particle and a free one, joined by a stick torn before `organize`: two islands.
    let mut solver = Solver::default();
    let pivot = solver.add_particle(DVec3::ZERO, 0.0);
    let bob = solver.add_particle(DVec3::X, 1.0);
    solver.pin(pivot, DVec3::ZERO);
    solver
        .sticks
        .push([pivot, bob], 1.0, 0.0, StickKind::Torn, f64::INFINITY, 0);
    solver.tethered[bob as usize] = true;
    solver.organize();
    assert_eq!(solver.islands.list.len(), 2);
    assert!(solver.tethers.is_empty() && solver.is_organized());
    // Made whole again, the stick gives a tether between the two islands: the islands no
    // longer describe the topology (two jobs could otherwise move one particle).
    solver.sticks.kind[0] = StickKind::Equal;
    solver.rebuild_tethers();
    assert_eq!(solver.tethers.len(), 1);
    assert!(!solver.is_organized());
}

#[test]
fn cuts_rebuild_the_tethers_once_before_the_next_step() {
    let mut solver = chain(10, 0.1, 0.0);
    // A free particle beside the tip: the cut-off part must fall just like it.
    let free = solver.add_particle(DVec3::new(1.0, -1.0, 0.0), 1.0);
    for i in 0..solver.sticks.len() {
        solver.sticks.tear_strain[i] = 10.0;
    }
    solver.sticks.tearable = (0..10).collect();
    solver.tethered.iter_mut().for_each(|t| *t = true);
    solver.organize();
    assert_eq!(solver.tethers.len(), 10);
    // Two cuts: particles 5..=10 lose their way to the pin.
    assert!(solver.cut(6) && solver.cut(4));
    assert_eq!(solver.tethers.len(), 10, "rebuilt lazily, not per cut");
    solver.step(&StepConfig::default());
    assert_eq!(
        solver.tethers.len(),
        4,
        "only particles 1..=4 still reach the pin"
    );
    assert!(solver.tethers.particle.iter().all(|&p| p <= 4));
    assert_eq!(
        solver.sticks.tearable.len(),
        8,
        "the cut sticks are dropped by the tear pass"
    );
    let p = &solver.particles.position;
    assert_eq!(
        p[10].y, p[free as usize].y,
        "no tether holds the cut-off part"
    );
}

/// A particle flying in an island of its own with 2 substeps (the step's: 8) keeps its speed
/// when the solver falls back to one island (a particle added without `organize`): the island's
/// states are brought to the solver's convention first (before: ×4 on the fallback step).
#[test]
fn the_one_island_fallback_keeps_every_velocity() {
    let config = StepConfig {
        gravity: DVec3::ZERO,
        sleep: None,
        ..StepConfig::default()
    };
    let mut solver = Solver::default();
    let flyer = solver.add_particle(DVec3::ZERO, 1.0) as usize;
    solver.particles.previous[flyer] = DVec3::new(-config.substep(), 0.0, 0.0); // 1 m/s
    let settings = IslandSettings {
        substeps: 2,
        iterations: 1,
    };
    solver.island_settings.push((flyer as u32, settings));
    let other = solver.add_particle(DVec3::Y * 10.0, 1.0);
    solver.particles.previous[other as usize] = DVec3::new(0.0, 10.0 - config.substep(), 0.0);
    solver.organize();
    solver.step(&config);
    solver.add_particle(DVec3::Y * 20.0, 1.0);
    assert!(!solver.is_organized());
    let before = solver.particles.position[flyer].x;
    solver.step(&config);
    let speed = (solver.particles.position[flyer].x - before) / config.timestep;
    assert!((speed - 1.0).abs() < 1e-9, "{speed} m/s");
}
