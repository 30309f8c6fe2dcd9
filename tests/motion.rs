//! Motion against analytic references: free fall, pendulum, damping.

mod common;
use bevy::prelude::*;
use bevy_verlet_physics::prelude::*;
use common::*;

#[test]
fn free_fall_matches_the_exact_parabola_at_every_substep_count_and_far_from_the_origin() {
    for substeps in [1, 8, 64] {
        for start in [Vec3::ZERO, Vec3::new(1000.0, 1000.0, 0.0)] {
            let mut app = app();
            app.insert_resource(Gravity::PIXELS);
            app.insert_resource(VerletConfig {
                substeps,
                ..VerletConfig::default()
            });
            let v0 = Vec3::new(120.0, 300.0, 0.0);
            let ball = spawn(&mut app, |c| {
                c.spawn(Particle::new(start).with_velocity(v0, DT)).id()
            });
            step(&mut app, 64);
            let t = 1.0f64;
            let g = -980.0f64;
            let exact_y = start.y as f64 + v0.y as f64 * t + 0.5 * g * t * t;
            let exact_x = start.x as f64 + v0.x as f64 * t;
            let p = position(&app, ball);
            let displacement =
                ((exact_x - start.x as f64).powi(2) + (exact_y - start.y as f64).powi(2)).sqrt();
            let error = ((p.x as f64 - exact_x).powi(2) + (p.y as f64 - exact_y).powi(2)).sqrt();
            assert!(
                error / displacement < 1e-3,
                "substeps {substeps}, start {start}: at {p}, exact ({exact_x}, {exact_y}), error {error}"
            );
        }
    }
}

/// Times of upward zero crossings of `x` (linear interpolation between samples).
fn crossings(samples: &[(f64, f64)]) -> Vec<f64> {
    samples
        .windows(2)
        .filter(|w| w[0].1 < 0.0 && w[1].1 >= 0.0)
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * (-w[0].1 / (w[1].1 - w[0].1)))
        .collect()
}

#[test]
fn pendulum_keeps_its_length_and_swings_with_the_right_period() {
    let mut app = app();
    let length = 1.0f32;
    let amplitude = 5f32.to_radians();
    let bob_start = Vec3::new(length * amplitude.sin(), -length * amplitude.cos(), 0.0);
    let (pivot, bob) = spawn(&mut app, |c| {
        let pivot = c
            .spawn((Particle::new(Vec3::ZERO), Pin::at(Vec3::ZERO)))
            .id();
        let bob = c.spawn(Particle::new(bob_start)).id();
        c.spawn(Stick::new(pivot, bob));
        (pivot, bob)
    });
    let mut samples = Vec::new();
    for i in 1..=640 {
        step(&mut app, 1);
        let p = position(&app, bob);
        let l = (p - position(&app, pivot)).length();
        assert!((l - length).abs() / length < 1e-3, "length {l} at step {i}");
        samples.push((i as f64 * DT as f64, p.x as f64));
    }
    assert_eq!(position(&app, pivot), Vec3::ZERO);
    let times = crossings(&samples);
    assert!(times.len() >= 4, "{} crossings", times.len());
    let period = (times[times.len() - 1] - times[0]) / (times.len() - 1) as f64;
    // Exact small-amplitude period with the 5° correction (T/T0 = 1 + θ²/16).
    let t0 = 2.0 * std::f64::consts::PI * (1.0 / 9.81f64).sqrt();
    let exact = t0 * (1.0 + (amplitude as f64).powi(2) / 16.0);
    assert!(
        (period - exact).abs() / exact < 0.01,
        "period {period}, exact {exact}"
    );
}

#[test]
fn damping_decays_velocity_exponentially_at_any_substep_count() {
    for substeps in [1, 16] {
        let mut app = app();
        app.insert_resource(Gravity::ZERO);
        app.insert_resource(VerletConfig {
            substeps,
            damping: 1.0,
            ..VerletConfig::default()
        });
        let p = spawn(&mut app, |c| {
            c.spawn(Particle::new(Vec3::ZERO).with_velocity(Vec3::X, DT))
                .id()
        });
        step(&mut app, 64);
        let v = particle(&app, p).velocity(DT).x;
        // Average velocity over the last step: exp(−t) sampled mid-step.
        let exact = (-(1.0f32 - DT / 2.0)).exp();
        // One substep samples the decay at the end of the step, not mid-step: ≤ DT/2 apart.
        assert!(
            (v - exact).abs() / exact < 0.01,
            "substeps {substeps}: {v} vs {exact}"
        );
    }
}
