//! Sticks, pins, tethers and colliders through the plugin.

mod common;
use bevy::prelude::*;
use bevy_verlet_physics::prelude::*;
use common::*;

#[test]
fn rope_sticks_stay_at_rest_length() {
    let mut app = app();
    let rope = spawn(&mut app, |c| {
        RopeBuilder::new(Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), 20)
            .pin_start()
            .spawn(c)
    });
    let mut lowest = f32::INFINITY;
    for _ in 0..64 * 3 {
        step(&mut app, 1);
        lowest = lowest.min(position(&app, rope.particles[20]).y);
    }
    assert!(all_finite(&mut app));
    let strain = max_strain(&mut app);
    assert!(strain < 0.01, "max strain {strain}");
    assert_eq!(position(&app, rope.particles[0]), Vec3::ZERO);
    // It swung down (its end passes well below the pin).
    assert!(lowest < -1.5, "lowest {lowest}");
}

#[test]
fn cloth_pinned_row_never_moves_and_tethers_remove_stretch() {
    let run = |tethers: bool| {
        let mut app = app();
        let builder = ClothBuilder::new(Vec3::new(-1.0, 0.0, 0.0), 21, 41, 0.05)
            .pin_top_row(1)
            .tethers(tethers);
        let cloth = spawn(&mut app, |c| builder.spawn(c));
        let top: Vec<(Entity, Vec3)> = (0..21)
            .map(|i| (cloth.particles[i], position(&app, cloth.particles[i])))
            .collect();
        app.insert_resource(VerletConfig {
            substeps: 2,
            damping: 1.0,
            ..VerletConfig::default()
        });
        for _ in 0..128 {
            step(&mut app, 1);
            for &(e, p) in &top {
                assert_eq!(position(&app, e), p);
            }
        }
        assert!(all_finite(&mut app));
        let bottom = position(&app, cloth.particles[40 * 21 + 10]).y;
        -bottom - 2.0 // stretch of the 2 m drop
    };
    let loose = run(false);
    let tethered = run(true);
    assert!(loose > 0.01, "untethered stretch {loose}");
    assert!(tethered < 1e-4, "tethered stretch {tethered}");
}

#[test]
fn one_sided_sticks_only_act_in_their_direction() {
    // (kind, start length, expected length range after one step). A violated constraint is
    // resolved by moving the free end, and Verlet keeps that motion as velocity, so a pushed or
    // pulled end keeps going: only the direction is asserted.
    for (kind, start, range) in [
        (StickKind::AtMost, 0.5, 0.5..=0.5), // rope: slack stays slack
        (StickKind::AtLeast, 0.5, 1.0..=f32::MAX), // strut: pushes apart
        (StickKind::AtMost, 2.0, 0.0..=1.0), // rope: pulls in
        (StickKind::AtLeast, 2.0, 2.0..=2.0), // strut: does not pull
    ] {
        let mut app = app();
        app.insert_resource(Gravity::ZERO);
        let (a, b) = spawn(&mut app, |c| {
            let a = c
                .spawn((Particle::new(Vec3::ZERO), Pin::at(Vec3::ZERO)))
                .id();
            let b = c.spawn(Particle::new(Vec3::X * start)).id();
            c.spawn(Stick::new(a, b).with_rest_length(1.0).with_kind(kind));
            (a, b)
        });
        step(&mut app, 1);
        let length = (position(&app, b) - position(&app, a)).length();
        let within = range.contains(&length)
            || (length - range.start()).abs() < 1e-5
            || (length - range.end()).abs() < 1e-5;
        assert!(
            within,
            "{kind:?} from {start}: {length}, expected {range:?}"
        );
    }
}

#[test]
fn moving_pin_drags_the_rope_smoothly() {
    let mut app = app();
    app.insert_resource(Gravity::ZERO);
    let rope = spawn(&mut app, |c| {
        RopeBuilder::new(Vec3::ZERO, Vec3::X, 10)
            .pin_start()
            .spawn(c)
    });
    let hand = rope.particles[0];
    for i in 1..=64 {
        let target = Vec3::new(0.0, i as f32 * 0.02, 0.0);
        app.world_mut()
            .get_mut::<Pin>(hand)
            .unwrap()
            .set_position(target);
        step(&mut app, 1);
        let hand_particle = particle(&app, hand);
        assert!((hand_particle.position - target).length() < 1e-6);
        // The hand moved exactly the pin's step, at the pin's velocity.
        let moved = hand_particle.position - hand_particle.previous_position;
        assert!(
            (moved - Vec3::new(0.0, 0.02, 0.0)).length() < 1e-6,
            "{moved}"
        );
        // Dragging never stretches the rope.
        let strain = max_strain(&mut app);
        assert!(strain < 0.01, "strain {strain} at step {i}");
    }
    let tip = position(&app, rope.particles[10]);
    assert!(tip.y > 0.5, "the rope followed the hand: {tip}");
}

#[test]
fn pin_follows_an_entity_transform() {
    let mut app = app();
    let (hook, p) = spawn(&mut app, |c| {
        let hook = c.spawn(Transform::from_xyz(1.0, 2.0, 0.0)).id();
        let p = c
            .spawn((Particle::new(Vec3::ZERO), Pin::follow(hook, Vec3::Y)))
            .id();
        (hook, p)
    });
    step(&mut app, 2);
    assert!((position(&app, p) - Vec3::new(1.0, 3.0, 0.0)).length() < 1e-6);
    app.world_mut()
        .get_mut::<Transform>(hook)
        .unwrap()
        .translation = Vec3::new(5.0, 2.0, 0.0);
    step(&mut app, 1);
    assert!((position(&app, p) - Vec3::new(5.0, 3.0, 0.0)).length() < 1e-6);
}

#[test]
fn ground_and_sphere_colliders_stop_particles() {
    let mut app = app();
    let (on_ground, on_sphere) = spawn(&mut app, |c| {
        c.spawn(VerletCollider::ground(0.0).with_friction(0.5));
        c.spawn((
            VerletCollider::sphere(1.0),
            Transform::from_xyz(5.0, 1.0, 0.0),
        ));
        let a = c
            .spawn(Particle::new(Vec3::new(0.0, 2.0, 0.0)).with_radius(0.1))
            .id();
        let b = c.spawn(Particle::new(Vec3::new(5.0, 4.0, 0.0))).id();
        (a, b)
    });
    step(&mut app, 64 * 2);
    let a = position(&app, on_ground);
    assert!(
        (a.y - 0.1).abs() < 1e-3,
        "resting on the ground with its radius: {a}"
    );
    let b = position(&app, on_sphere);
    assert!(
        (b - Vec3::new(5.0, 1.0, 0.0)).length() >= 1.0 - 1e-4,
        "outside the sphere: {b}"
    );
}

#[test]
fn angle_constraint_holds_a_bent_joint() {
    let mut app = app();
    let (a, b, c) = spawn(&mut app, |cmd| {
        let a = cmd
            .spawn((Particle::new(Vec3::ZERO), Pin::at(Vec3::ZERO)))
            .id();
        let b = cmd.spawn((Particle::new(Vec3::X), Pin::at(Vec3::X))).id();
        let c = cmd.spawn(Particle::new(Vec3::new(1.0, 1.0, 0.0))).id();
        cmd.spawn(Stick::new(b, c));
        cmd.spawn(AngleConstraint::new(a, b, c));
        (a, b, c)
    });
    step(&mut app, 64);
    let u = position(&app, a) - position(&app, b);
    let v = position(&app, c) - position(&app, b);
    let angle = u.angle_between(v);
    assert!(
        (angle - std::f32::consts::FRAC_PI_2).abs() < 0.05,
        "angle {angle}"
    );
}
