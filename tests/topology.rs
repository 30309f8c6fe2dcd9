//! Tearing, despawning, pausing, determinism and bad input.

mod common;
use bevy::prelude::*;
use bevy_verlet_physics::prelude::*;
use common::*;

#[derive(Resource, Default)]
struct Tears(Vec<StickTorn>);

fn record(mut reader: MessageReader<StickTorn>, mut tears: ResMut<Tears>) {
    tears.0.extend(reader.read().copied());
}

#[test]
fn overstretched_stick_tears_once_and_no_particle_is_lost() {
    let mut app = app();
    app.init_resource::<Tears>()
        .add_systems(FixedPostUpdate, record);
    app.insert_resource(Gravity::ZERO);
    let (a, b, stick) = spawn(&mut app, |c| {
        let a = c
            .spawn((Particle::new(Vec3::ZERO), Pin::at(Vec3::ZERO)))
            .id();
        let b = c.spawn((Particle::new(Vec3::X), Pin::at(Vec3::X))).id();
        let s = c.spawn(Stick::new(a, b).with_tear_strain(0.5)).id();
        (a, b, s)
    });
    step(&mut app, 3);
    assert!(
        app.world().resource::<Tears>().0.is_empty(),
        "no tear at rest"
    );
    // Pull the pins apart to twice the length.
    app.world_mut()
        .get_mut::<Pin>(b)
        .unwrap()
        .set_position(Vec3::X * 2.0);
    step(&mut app, 5);
    let tears = &app.world().resource::<Tears>().0;
    assert_eq!(tears.len(), 1, "reported once: {tears:?}");
    assert_eq!(tears[0].stick, stick);
    assert_eq!(tears[0].particles, [a, b]);
    assert!(app.world().get_entity(stick).is_err(), "stick despawned");
    assert_eq!(count::<Particle>(&mut app), 2);
    assert_eq!(app.world().resource::<VerletStats>().torn_total, 1);
}

#[test]
fn cloth_tears_under_a_yank_and_keeps_every_particle() {
    let mut app = app();
    app.init_resource::<Tears>()
        .add_systems(FixedPostUpdate, record);
    let cloth = spawn(&mut app, |c| {
        ClothBuilder::new(Vec3::ZERO, 10, 10, 0.1)
            .pin_top_row(1)
            .tear_strain(0.5)
            .tethers(true)
            .spawn(c)
    });
    step(&mut app, 32);
    assert!(
        app.world().resource::<Tears>().0.is_empty(),
        "gravity alone does not tear it"
    );
    // Grab the bottom row with pins and pull it down hard.
    for column in 0..10 {
        let e = cloth.particles[90 + column];
        let p = position(&app, e);
        app.world_mut()
            .entity_mut(e)
            .insert(Pin::at(p + Vec3::NEG_Y * 3.0));
    }
    step(&mut app, 16);
    let tears = app.world().resource::<Tears>().0.clone();
    assert!(!tears.is_empty());
    let mut sticks: Vec<Entity> = tears.iter().map(|t| t.stick).collect();
    sticks.sort();
    sticks.dedup();
    assert_eq!(sticks.len(), tears.len(), "no stick reported twice");
    assert_eq!(count::<Particle>(&mut app), 100);
    assert_eq!(count::<Stick>(&mut app), 180 - tears.len());
    assert!(all_finite(&mut app));
}

#[test]
fn despawning_a_particle_that_sticks_reference_does_not_panic() {
    let mut app = app();
    let rope = spawn(&mut app, |c| {
        RopeBuilder::new(Vec3::ZERO, Vec3::X, 4)
            .pin_start()
            .spawn(c)
    });
    step(&mut app, 2);
    app.world_mut().despawn(rope.particles[2]);
    step(&mut app, 64);
    assert!(all_finite(&mut app));
    // The part past the despawned particle falls freely: no stick holds it.
    let tail = position(&app, rope.particles[4]);
    assert!(tail.y < -3.0, "the tail fell: {tail}");
    // The part before it still hangs on its stick.
    let first = position(&app, rope.particles[1]);
    assert!((first.length() - 0.25).abs() < 1e-3);
    let state = app.world().resource::<VerletState>();
    assert_eq!(state.solver.sticks.len(), 2);
}

#[test]
fn despawning_a_whole_composite_removes_it_from_the_solver() {
    let mut app = app();
    let cloth = spawn(&mut app, |c| {
        ClothBuilder::new(Vec3::ZERO, 5, 5, 0.1)
            .pin_top_row(1)
            .spawn(c)
    });
    spawn(&mut app, |c| {
        RopeBuilder::new(Vec3::ZERO, Vec3::X, 3).spawn(c)
    });
    step(&mut app, 2);
    app.world_mut().despawn(cloth.root);
    step(&mut app, 2);
    let state = app.world().resource::<VerletState>();
    assert_eq!(state.solver.particles.len(), 4);
    assert_eq!(state.solver.sticks.len(), 3);
}

#[test]
fn pause_and_single_step() {
    let mut app = app();
    let p = spawn(&mut app, |c| c.spawn(Particle::new(Vec3::ZERO)).id());
    step(&mut app, 1);
    app.world_mut().resource_mut::<VerletConfig>().paused = true;
    let before = position(&app, p);
    step(&mut app, 10);
    assert_eq!(position(&app, p), before);
    app.world_mut().resource_mut::<VerletConfig>().step_once();
    step(&mut app, 3);
    assert!(position(&app, p).y < before.y);
    assert_eq!(app.world().resource::<VerletStats>().steps, 2);
}

fn run_scene() -> Vec<Vec3> {
    let mut app = app();
    app.world_mut().spawn(
        VerletCollider::ground(-1.5)
            .with_restitution(0.3)
            .with_friction(0.4),
    );
    let cloth = spawn(&mut app, |c| {
        ClothBuilder::new(Vec3::new(-0.5, 0.0, 0.0), 12, 12, 0.1)
            .pin_top_corners()
            .tear_strain(0.3)
            .spawn(c)
    });
    step(&mut app, 100);
    cloth.particles.iter().map(|&e| position(&app, e)).collect()
}

#[test]
fn the_same_scene_gives_bit_identical_results() {
    let first = run_scene();
    let second = run_scene();
    assert_eq!(first.len(), 144);
    for (a, b) in first.iter().zip(&second) {
        assert_eq!(
            a.to_array().map(f32::to_bits),
            b.to_array().map(f32::to_bits)
        );
    }
}

#[test]
fn bad_input_is_rejected_without_nan_or_panic() {
    let mut app = app();
    let (good, nan_particle, bad_mass) = spawn(&mut app, |c| {
        let good = c
            .spawn((Particle::new(Vec3::ZERO), Pin::at(Vec3::ZERO)))
            .id();
        let nan_particle = c.spawn(Particle::new(Vec3::new(f32::NAN, 0.0, 0.0))).id();
        let bad_mass = c.spawn(Particle::new(Vec3::X).with_mass(-2.0)).id();
        // Sticks to a NaN particle, to itself, to a non-particle, with bad numbers.
        let nothing = c.spawn_empty().id();
        c.spawn(Stick::new(good, nan_particle));
        c.spawn(Stick::new(good, good));
        c.spawn(Stick::new(good, nothing));
        c.spawn(
            Stick::new(good, bad_mass)
                .with_rest_length(f32::NAN)
                .with_compliance(-1.0),
        );
        c.spawn(VerletCollider::sphere(f32::NAN));
        (good, nan_particle, bad_mass)
    });
    step(&mut app, 64);
    assert!(position(&app, good).is_finite());
    let p = particle(&app, bad_mass);
    assert!(p.position.is_finite());
    // Mass −2 was replaced by 1, the NaN rest length by the distance (1): it hangs at 1.
    assert!((p.position.length() - 1.0).abs() < 1e-3, "{}", p.position);
    // The NaN particle was left out and untouched.
    assert!(position(&app, nan_particle).x.is_nan());
    // Fixing it brings it in.
    app.world_mut()
        .get_mut::<Particle>(nan_particle)
        .unwrap()
        .set_position(Vec3::new(0.0, -2.0, 0.0));
    step(&mut app, 4);
    assert!(position(&app, nan_particle).is_finite());
    // Editing a live particle to NaN is rejected: it keeps simulating from its last state.
    app.world_mut()
        .get_mut::<Particle>(bad_mass)
        .unwrap()
        .position = Vec3::splat(f32::INFINITY);
    step(&mut app, 4);
    assert!(position(&app, bad_mass).is_finite());
    assert!(all_finite(&mut app));
}
