//! Islands through the plugin: sleeping ragdolls, waking on edits, per-island settings.

mod common;
use bevy::prelude::*;
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::scenes;
use common::*;

fn stats(app: &App) -> VerletStats {
    app.world().resource::<VerletStats>().clone()
}

#[test]
fn resting_ragdolls_fall_asleep_and_an_edit_wakes_one() {
    let mut app = app();
    app.insert_resource(Gravity::PIXELS);
    let ragdolls = spawn(&mut app, |c| scenes::ragdolls(c, 6));
    step(&mut app, 64 * 20);
    let asleep = stats(&app);
    assert_eq!(asleep.islands, 6);
    assert_eq!(asleep.sleeping_islands, 6, "all six rest on the floor");
    assert_eq!(asleep.diverged, 0);
    // Asleep means frozen: components do not move.
    let head = ragdolls[2].particles[0];
    let other = ragdolls[0].particles[0];
    let (before, other_before) = (position(&app, head), position(&app, other));
    step(&mut app, 32);
    assert_eq!(position(&app, head), before);

    // Spawning another ragdoll (a topology rebuild) leaves the sleeping ones asleep.
    spawn(&mut app, |c| {
        scenes::spawn_ragdoll(c, Vec3::new(0.0, 200.0, 0.0), false)
    });
    step(&mut app, 1);
    assert_eq!(stats(&app).islands, 7);
    assert_eq!(stats(&app).sleeping_islands, 6);
    // A stick added inside a sleeping ragdoll wakes it.
    let [a, b] = [ragdolls[5].particles[0], ragdolls[5].particles[3]];
    spawn(&mut app, |c| c.spawn(Stick::new(a, b)).id());
    step(&mut app, 1);
    assert!(!app.world().resource::<VerletState>().is_sleeping(a));
    assert_eq!(stats(&app).sleeping_islands, 5);

    // Lifting a particle (at rest) wakes its ragdoll, and only it.
    {
        let mut particle = app.world_mut().get_mut::<Particle>(head).unwrap();
        particle.position += Vec3::Y * 50.0;
        particle.previous_position = particle.position;
    }
    step(&mut app, 1);
    let state = app.world().resource::<VerletState>();
    assert!(!state.is_sleeping(head));
    assert!(state.is_sleeping(ragdolls[0].particles[0]));
    assert_eq!(stats(&app).sleeping_islands, 4);
    let lifted = position(&app, head);
    step(&mut app, 16);
    assert_ne!(position(&app, head), lifted, "it moves again");
    assert_eq!(
        position(&app, other),
        other_before,
        "the others stay asleep, frozen"
    );
}

#[test]
fn sleeping_never_keeps_everything_awake() {
    let mut app = app();
    app.insert_resource(Gravity::PIXELS)
        .insert_resource(VerletConfig {
            sleeping: Sleeping::Never,
            ..default()
        });
    spawn(&mut app, |c| scenes::ragdolls(c, 3));
    step(&mut app, 64 * 20);
    assert_eq!(stats(&app).sleeping_islands, 0);
}

#[test]
fn island_override_changes_only_its_island() {
    // Two identical ropes; one carries an override of 1 substep. With 1 substep and 1
    // iteration a 20-link rope stretches far more than at the default 8 × 1 when swept (lines
    // would hold both exactly).
    let mut app = app();
    app.insert_resource(VerletConfig {
        sleeping: Sleeping::Never,
        method: SolveMethod::Sweep,
        ..default()
    });
    let [plain, light] = [0.0, 3.0].map(|z| {
        spawn(&mut app, |c| {
            RopeBuilder::new(Vec3::new(0.0, 0.0, z), Vec3::new(2.0, 0.0, z), 20)
                .pin_start()
                .spawn(c)
        })
    });
    for &particle in &light.particles {
        app.world_mut()
            .entity_mut(particle)
            .insert(IslandOverride::new(1, 1));
    }
    step(&mut app, 64);
    let stretch = |rope: &Composite| {
        let first = position(&app, rope.particles[0]);
        let last = position(&app, rope.particles[20]);
        (last - first).length() / 2.0 - 1.0
    };
    let (s_plain, s_light) = (stretch(&plain), stretch(&light));
    assert!(s_plain < 0.01, "8 x 1 rope: {s_plain}");
    assert!(
        s_light > 2.0 * s_plain.max(0.001),
        "1 x 1 rope: {s_light} vs {s_plain}"
    );
    assert_eq!(stats(&app).islands, 2);
}

#[test]
fn threaded_plugin_gives_the_same_bits_as_serial() {
    // 130² cloth: 33 540 sticks per substep sweep, enough to be solved on every thread.
    let run = |parallel: bool| {
        let mut app = app();
        app.insert_resource(VerletConfig {
            parallel,
            ..default()
        });
        let cloth = spawn(&mut app, |c| {
            ClothBuilder::new(Vec3::ZERO, 130, 130, 0.02)
                .pin_top_corners()
                .spawn(c)
        });
        step(&mut app, 12);
        cloth
            .particles
            .iter()
            .map(|&p| position(&app, p).to_array().map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    let serial = run(false);
    assert_eq!(serial, run(true));
}

/// `IslandOverride::with_method`: two identical 40 × 40 cloths (2 m, hanging from their top
/// rows, damping 2/s, 3 s); one is solved by lines at 1 substep. Measured: the swept cloth
/// (8 × 1) stretches 5.5 % at its worst stick, the one solved by lines 0 (to rounding). Taking
/// the override off again gives it back to the sweep.
#[test]
fn island_override_picks_the_solve_method() {
    let mut app = app();
    app.insert_resource(VerletConfig {
        damping: 2.0,
        sleeping: Sleeping::Never,
        ..default()
    });
    let [_, exact] = [0.0, 3.0].map(|x| {
        spawn(&mut app, |c| {
            ClothBuilder::new(Vec3::new(x, 0.0, 0.0), 40, 40, 0.05)
                .pin_top_row(1)
                .spawn(c)
        })
    });
    let lines = IslandOverride::new(1, 1).with_method(SolveMethod::Lines);
    app.world_mut().entity_mut(exact.particles[0]).insert(lines);
    step(&mut app, 64 * 3);
    // (Islands are ordered by their first particle: the swept cloth was spawned first.)
    let strain = |app: &App, island: usize| {
        let solver = &app.world().resource::<VerletState>().solver;
        let sticks = solver.islands.list[island].sticks.clone();
        sticks
            .map(|i| solver.sticks.strain(i as usize, &solver.particles))
            .fold(0.0, f64::max)
    };
    let (a, b) = (strain(&app, 0), strain(&app, 1));
    println!("cloth 40 x 40: swept {a:.4}, lines {b:.2e}");
    assert!(a > 0.01, "the swept cloth stretches: {a}");
    assert!(b < 1e-6, "lines: {b}");
    let methods = |app: &App| {
        let islands = &app.world().resource::<VerletState>().solver.islands.list;
        islands.iter().map(|i| i.method).collect::<Vec<_>>()
    };
    use bevy_verlet_physics::solver::Method;
    assert_eq!(methods(&app), [Method::Sweep, Method::Lines]);
    app.world_mut()
        .entity_mut(exact.particles[0])
        .remove::<IslandOverride>();
    step(&mut app, 1);
    assert_eq!(methods(&app), [Method::Sweep, Method::Sweep]);
}

/// `VerletConfig::line_substeps`: ropes (solved by lines) take their own substep count, a
/// cloth beside them (swept) keeps `substeps`, and a rope with an `IslandOverride` keeps its
/// own. The ropes, released horizontal, stay on their lengths at 2 substeps; changing the
/// setting back applies from the next step.
#[test]
fn line_substeps_give_ropes_their_own_substeps() {
    let mut app = app();
    app.insert_resource(VerletConfig {
        line_substeps: Some(2),
        sleeping: Sleeping::Never,
        ..default()
    });
    let [rope, other] = [0.0, 3.0].map(|y| {
        spawn(&mut app, |c| {
            let (start, end) = (Vec3::new(0.0, y, 0.0), Vec3::new(2.0, y, 0.0));
            RopeBuilder::new(start, end, 40).pin_start().spawn(c)
        })
    });
    let own = IslandOverride::new(4, 1);
    app.world_mut().entity_mut(other.particles[0]).insert(own);
    let cloth = spawn(&mut app, |c| {
        ClothBuilder::new(Vec3::new(5.0, 0.0, 0.0), 10, 10, 0.05)
            .pin_top_row(1)
            .spawn(c)
    });
    let mut worst: f64 = 0.0;
    for _ in 0..64 * 2 {
        step(&mut app, 1);
        let state = app.world().resource::<VerletState>();
        let island = state
            .solver
            .islands
            .of_particle(state.slot(rope.particles[1]).unwrap());
        let sticks = state.solver.islands.list[island.unwrap()].sticks.clone();
        let strain = sticks.map(|i| {
            state
                .solver
                .sticks
                .strain(i as usize, &state.solver.particles)
        });
        worst = strain.map(f64::abs).fold(worst, f64::max);
    }
    let substep = |app: &App, entity: Entity| {
        let state = app.world().resource::<VerletState>();
        state
            .solver
            .state_substep_of(state.slot(entity).unwrap())
            .unwrap()
            * 64.0
    };
    let [a, b, c] = [rope.particles[1], other.particles[1], cloth.particles[20]];
    let counts = |app: &App| [a, b, c].map(|e| (1.0 / substep(app, e)).round() as u32);
    println!(
        "line_substeps 2: rope strain {worst:.2e}, substeps {:?}",
        counts(&app)
    );
    assert_eq!(counts(&app), [2, 4, 8]);
    assert!(worst < 1e-6, "rope strain {worst}");
    app.world_mut().resource_mut::<VerletConfig>().line_substeps = None;
    step(&mut app, 1);
    assert_eq!(counts(&app), [8, 4, 8]);
}

/// `IslandOverride::with_method(SolveMethod::Hierarchy)` gives one cloth coarse levels: hung by
/// its two top corners (40 × 40, 5 cm, 3 s) it stretches far less than its swept twin (largest
/// strain measured: 18.9 % against 75.5 %; 21.1 % without the coarse pass after the sweep, 19.4 % while coarse corrections were interpolated); a stick cut in place drops the hierarchy (the
/// island is swept again) until the next rebuild gives the cut cloth a new one.
#[test]
fn island_override_gives_a_cloth_a_hierarchy() {
    use bevy_verlet_physics::solver::Method;
    let mut app = app();
    app.insert_resource(VerletConfig {
        damping: 2.0,
        sleeping: Sleeping::Never,
        method: SolveMethod::Sweep,
        ..default()
    });
    let [_, coarse] = [0.0, 3.0].map(|x| {
        spawn(&mut app, |c| {
            ClothBuilder::new(Vec3::new(x, 0.0, 0.0), 40, 40, 0.05)
                .pin_top_corners()
                .spawn(c)
        })
    });
    let hierarchy = IslandOverride::new(8, 1).with_method(SolveMethod::Hierarchy);
    app.world_mut()
        .entity_mut(coarse.particles[0])
        .insert(hierarchy);
    let mut worst = [0.0f64; 2];
    for _ in 0..64 * 3 {
        step(&mut app, 1);
        let solver = &app.world().resource::<VerletState>().solver;
        for (k, island) in solver.islands.list.iter().enumerate() {
            let sticks = island.sticks.clone();
            let strain = sticks
                .map(|i| solver.sticks.strain(i as usize, &solver.particles))
                .fold(0.0, f64::max);
            worst[k] = worst[k].max(strain);
        }
    }
    println!(
        "cloth 40 x 40 on two corners: swept {:.3}, hierarchy {:.3}",
        worst[0], worst[1]
    );
    assert!(worst[1] < worst[0] / 2.0, "{worst:?}");
    let solver = &app.world().resource::<VerletState>().solver;
    let island = &solver.islands.list[1];
    assert_eq!(island.method, Method::Hierarchy);
    let k = island.hierarchy.expect("the cloth has a hierarchy") as usize;
    assert!(solver.islands.hierarchies().list[k].active);
    // Cut one stick in place: the hierarchy is dropped at the next step.
    let stick = solver.islands.list[1].sticks.start as usize + 100;
    let torn = app
        .world_mut()
        .resource_mut::<VerletState>()
        .cut_stick(stick);
    assert!(torn.is_some());
    step(&mut app, 1);
    let solver = &app.world().resource::<VerletState>().solver;
    assert!(!solver.islands.hierarchies().list[k].active);
    assert!(solver.particles.position.iter().all(|p| p.is_finite()));
}

/// `SolveMethod::Auto` gives a large cloth hung by its two corners a hierarchy (measured on this
/// 40 × 40: 18.9 % largest strain in 3 s against 75.5 % swept, see above), but not the same
/// cloth tethered (tethers bound it already), tearable (a tear would drop the hierarchy), hung
/// by its whole top row (its load runs along the columns), or a 20 × 20 one (760 sticks: too
/// small to colour, and small cloths gain little).
#[test]
fn auto_gives_a_large_cloth_on_few_pins_a_hierarchy() {
    use bevy_verlet_physics::solver::Method;
    // (size, tethers, tearable, hung by the top row, expected a hierarchy)
    let cases = [
        (40, false, false, false, true),
        (40, true, false, false, false),
        (40, false, true, false, false),
        (40, false, false, true, false),
        (20, false, false, false, false),
    ];
    for (n, tethers, tearable, top_row, hierarchy) in cases {
        let mut app = app();
        spawn(&mut app, |c| {
            let builder = ClothBuilder::new(Vec3::ZERO, n, n, 0.05).tethers(tethers);
            let builder = if tearable {
                builder.tear_strain(2.0)
            } else {
                builder
            };
            let builder = if top_row {
                builder.pin_top_row(1)
            } else {
                builder.pin_top_corners()
            };
            builder.spawn(c)
        });
        step(&mut app, 1);
        let solver = &app.world().resource::<VerletState>().solver;
        let method = solver.islands.list[0].method;
        let expected = if hierarchy {
            Method::Hierarchy
        } else {
            Method::Sweep
        };
        let case = format!("{n} × {n}, tethers {tethers}, tearable {tearable}, top row {top_row}");
        assert_eq!(method, expected, "{case}");
    }
}
