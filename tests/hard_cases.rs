//! Hard cases and bad input: every case has a bounded outcome that is checked.
//!
//! The bounds are measured values with a margin; each test's comment says what was measured
//! (dev profile, default 8 substeps × 1 iteration at 64 Hz unless stated). Energies are
//! `Σ ½mv² + m·(−g)·x` over the movable particles, with velocities over the last substep.

mod common;
use bevy::ecs::schedule::SingleThreadedExecutor;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_verlet_physics::prelude::*;
use bevy_verlet_physics::solver::{Solver, StepConfig};
use common::*;
use glam::DVec3;
use std::time::Duration;

/// Runs `steps` fixed steps; returns (largest energy, largest stick stretch) seen, checking
/// that the solver stays finite after every step.
fn run_and_watch(app: &mut App, steps: usize) -> (f64, f64) {
    let mut max_energy = f64::MIN;
    let mut max_stretch: f64 = 0.0;
    for i in 0..steps {
        step(app, 1);
        assert!(solver_finite(app), "non-finite state at step {i}");
        max_energy = max_energy.max(energy(app));
        max_stretch = max_stretch.max(solver_max_stretch(app));
    }
    (max_energy, max_stretch)
}

/// `Σ m·|g|·extent`: the energy scale of a scene, for relative tolerances.
fn energy_scale(app: &App, extent: f64) -> f64 {
    let state = app.world().resource::<VerletState>();
    let g = app.world().resource::<Gravity>().0.length() as f64;
    let p = &state.solver.particles;
    let mass: f64 = (0..p.len())
        .filter(|&i| p.inverse_mass[i] > 0.0)
        .map(|i| 1.0 / p.inverse_mass[i])
        .sum();
    mass * g * extent
}

// ---------------------------------------------------------------------------------------------
// Mass ratio, long chains, big cloth
// ---------------------------------------------------------------------------------------------

/// A 1 kg weight on a 1 m chain of ten 1 g links (1000:1), released horizontally, damping
/// 0.5/s, 20 s.
///
/// Measured: energy never above its start (peak −1.4·10⁻³ J below it). Swept, Gauss–Seidel
/// moves the light end of the weight's link almost alone, so at 8 substeps the link holding the
/// weight stretches 98 % at the bottom of the swing and 38 % at rest (≈ (1 + w_light/w_heavy)·
/// g·h²/L); at 64 substeps 1.6 % / 0.6 %; with tethers 1.0 % / 0.003 % (swept forward and
/// back, as islands whose masses differ more than 8× are, `solver::symmetric`; forward alone
/// 95 % / 37 %, 1.5 % / 0.6 %, 1.7 % / 0.004 %). Solved by lines (the default for a chain):
/// below 10⁻⁸ at 8 substeps, swinging and at rest.
#[test]
fn heavy_weight_on_a_light_chain_settles_with_bounded_stretch() {
    for (method, substeps, tethers, bound_swing, bound_rest) in [
        (SolveMethod::Sweep, 8, false, 1.2, 0.45),
        (SolveMethod::Sweep, 64, false, 0.025, 0.01),
        (SolveMethod::Sweep, 8, true, 0.03, 1e-3),
        (SolveMethod::Auto, 8, false, 1e-6, 1e-6),
    ] {
        let mut app = app();
        app.insert_resource(VerletConfig {
            substeps,
            damping: 0.5,
            method,
            ..default()
        });
        let rope = spawn(&mut app, |c| {
            RopeBuilder::new(Vec3::ZERO, Vec3::X, 10)
                .pin_start()
                .mass(0.001)
                .tethers(tethers)
                .spawn(c)
        });
        let weight = rope.particles[10];
        app.world_mut()
            .get_mut::<Particle>(weight)
            .unwrap()
            .inverse_mass = 1.0;
        step(&mut app, 1);
        let start = energy(&app);
        let scale = energy_scale(&app, 1.0);
        let (max_energy, max_stretch) = run_and_watch(&mut app, 64 * 20);
        let rest_stretch = solver_max_stretch(&app);
        let ke = kinetic_energy(&app);
        println!(
            "1000:1, {method:?}, {substeps} substeps, tethers {tethers}: energy rise {:.2e} J, stretch {max_stretch:.4} swing / {rest_stretch:.5} rest, KE {ke:.1e} J",
            max_energy - start
        );
        assert!(max_energy <= start + 1e-6 * scale, "energy grew");
        assert!(max_stretch < bound_swing, "stretch {max_stretch}");
        assert!(rest_stretch < bound_rest, "stretch at rest {rest_stretch}");
        // Settled: hanging straight down, nearly still.
        assert!(ke < 1e-3 * scale, "still moving: {ke} J");
        let p = solver_position(&app, weight).unwrap();
        assert!(p.x.abs() < 0.01 && p.y < -0.99, "weight at {p}");
    }
}

/// A 2 m chain of 200 links (1 kg each) pinned at one end, released horizontally, damping
/// 0.5/s, 20 s.
///
/// Measured: energy never above its start. Swept: largest link stretch 185 % while swinging
/// and 75 % at rest at 8 substeps (the top links carry 200 links' weight with one projection per
/// substep); 19 % / 4.7 % at 32 substeps, 42 % / 0.2 % with tethers. Solved by lines (the
/// default for a chain): below 10⁻⁸ at 8 substeps, swinging and at rest.
#[test]
fn two_hundred_link_chain_settles_with_bounded_stretch() {
    for (method, substeps, tethers, bound_swing, bound_rest) in [
        (SolveMethod::Sweep, 8, false, 2.2, 0.9),
        (SolveMethod::Sweep, 32, false, 0.25, 0.06),
        (SolveMethod::Sweep, 8, true, 0.5, 0.005),
        (SolveMethod::Auto, 8, false, 1e-6, 1e-6),
    ] {
        let mut app = app();
        app.insert_resource(VerletConfig {
            substeps,
            damping: 0.5,
            method,
            ..default()
        });
        let rope = spawn(&mut app, |c| {
            RopeBuilder::new(Vec3::ZERO, Vec3::X * 2.0, 200)
                .pin_start()
                .tethers(tethers)
                .spawn(c)
        });
        step(&mut app, 1);
        let start = energy(&app);
        let scale = energy_scale(&app, 2.0);
        let (max_energy, max_stretch) = run_and_watch(&mut app, 64 * 20);
        let rest_stretch = solver_max_stretch(&app);
        let ke = kinetic_energy(&app);
        println!(
            "200 links, {method:?}, {substeps} substeps, tethers {tethers}: energy rise {:.2e} J, stretch {max_stretch:.3} swing / {rest_stretch:.4} rest, KE {ke:.1e} J",
            max_energy - start
        );
        assert!(max_energy <= start + 1e-6 * scale, "energy grew");
        assert!(max_stretch < bound_swing, "stretch {max_stretch}");
        assert!(rest_stretch < bound_rest, "stretch at rest {rest_stretch}");
        assert!(ke < 1e-3 * scale, "still moving: {ke} J");
        let tip = solver_position(&app, rope.particles[200]).unwrap();
        assert!(tip.x.abs() < 0.05, "hanging down: {tip}");
    }
}

/// A 100 × 100 cloth (2 m, 1 kg particles, 19 800 rigid sticks) pinned at its two top corners,
/// damping 1/s, 10 s.
///
/// Swept (`SolveMethod::Sweep`; `Auto` gives this cloth a hierarchy since it hangs untethered
/// from two pins — the last row below), this is past what 8 substeps × 1 iteration can hold:
/// every path to a pin is ~100 links long and the two corner links carry 10 t. Measured in colour order (the plugin's order for a
/// cloth this size): energy never above its start; largest link stretch 9.6× while falling and
/// 5.2× hanging; a small residual flutter (KE up to 6 J in the last 2 s, 0.17 % of the fall's
/// peak of 34 kJ). (In the builder's row order, before colour batches: 14.9× / 7–9×, flutter
/// 15 % of the peak.) It stays bounded, finite and pinned; it needs far more substeps to hang
/// unstretched.
///
/// Tethers to both corners (the default `tether_anchors: 2`): 81 % / 41 %, KE ≤ 0.5 J in the
/// last 2 s. To the nearer corner only (`tether_anchors: 1`, as before there was a choice):
/// 4.9× / 4.1× — a particle bound to one corner can still swing out towards the other. The
/// stretch left is where the tethers leave room: the top row is exactly as long as the span
/// between the corners, so only stretch lets it sag, and a tether bounds only the distance to
/// its pin. Untethered under `SolveMethod::Hierarchy` (coarse levels of long-range sticks
/// before and after each sweep, the smaller levels projected more often): 29 % / 20 %, KE ≤
/// 0.3 J in the last 2 s (0.003 % of the peak; every level projected once: 55 % / 31 %, bounds
/// 1.0 / 0.4; before the sweep only: 88 % / 47 %). The first version also interpolated each
/// coarse correction to the particles between the coarse ones (Müller 2008): 73 % / 31 % here with KE ≤ 15 J (0.13 %),
/// bounds 1.0 / 0.4 / 0.005 — but it put energy in: cloths of 10 × 10 to 30 × 30 on two corners
/// and this one on its top row never settled (up to 100 % and 6.9 % of the peak). The flutter
/// bound is 10⁻⁴ of the peak now (was 5·10⁻³). (Not asserted: with rigid shear sticks too, `.shear(0.0)`, 26 % / 17 % with two
/// anchors but a flutter of up to 3 % of the fall's peak KE; with one anchor 1.6× / 1.4×.)
#[test]
fn hundred_by_hundred_cloth_on_two_corners_stays_bounded() {
    for (method, tethers, anchors, bound_fall, bound_hang, bound_ke) in [
        (SolveMethod::Sweep, false, 2, 12.0, 7.0, 0.01),
        (SolveMethod::Auto, true, 1, 6.0, 5.0, 0.001),
        (SolveMethod::Auto, true, 2, 1.0, 0.5, 0.001),
        (SolveMethod::Hierarchy, false, 2, 0.4, 0.3, 1e-4),
    ] {
        let mut app = app();
        app.insert_resource(VerletConfig {
            damping: 1.0,
            tether_anchors: anchors,
            method,
            ..default()
        });
        let cloth = spawn(&mut app, |c| {
            ClothBuilder::new(Vec3::ZERO, 100, 100, 0.02)
                .pin_top_corners()
                .tethers(tethers)
                .spawn(c)
        });
        let corners = [cloth.particles[0], cloth.particles[99]].map(|e| (e, position(&app, e)));
        step(&mut app, 1);
        let start = energy(&app);
        let scale = energy_scale(&app, 2.0);
        let mut peak_ke: f64 = 0.0;
        let mut max_energy = f64::MIN;
        let mut max_stretch: f64 = 0.0;
        let mut late_ke: f64 = 0.0;
        let steps = 64 * 10;
        for i in 0..steps {
            step(&mut app, 1);
            let ke = kinetic_energy(&app);
            peak_ke = peak_ke.max(ke);
            if i >= steps - 64 * 2 {
                late_ke = late_ke.max(ke);
            }
            max_energy = max_energy.max(energy(&app));
            max_stretch = max_stretch.max(solver_max_stretch(&app));
        }
        assert!(solver_finite(&app));
        assert!(all_finite(&mut app));
        let hang_stretch = solver_max_stretch(&app);
        println!(
            "100×100 cloth, {method:?}, tethers {tethers} ({anchors} anchors): energy rise {:.2e} J, stretch {max_stretch:.2} falling / {hang_stretch:.2} hanging, KE peak {peak_ke:.3e} J, last 2 s max {late_ke:.3e} J",
            max_energy - start
        );
        assert!(max_energy <= start + 1e-6 * scale, "energy grew");
        assert!(max_stretch < bound_fall, "stretch {max_stretch}");
        assert!(hang_stretch < bound_hang, "hanging stretch {hang_stretch}");
        assert!(
            late_ke < bound_ke * peak_ke,
            "KE {late_ke} vs peak {peak_ke}"
        );
        for (corner, start) in corners {
            assert_eq!(position(&app, corner), start, "pinned corner moved");
        }
    }
}

/// A weighted hammock: a 10 × 10 cloth of 5 cm sticks (1 kg particles) hung by its two top
/// corners, every seventh particle a 1000 kg weight, swung sideways at 5 or 30 m/s, 10 s.
///
/// Measured: swept forward alone (`symmetric_mass_ratio: f32::INFINITY`, how every swept island
/// was solved before), a mode of the sweep itself grows every substep: the energy went from
/// 1.4·10⁵ J to 3.7·10¹² J (5 m/s) and from 5.8·10⁶ J to 1.7·10¹⁷ J (30 m/s; 100 kg weights:
/// 5.1·10²⁹ J). Swept forward and back (the default: its masses differ 1000×, more than the
/// ratio of 8): never above its first step's energy. See `solver::symmetric`.
#[test]
fn a_weighted_hammock_swung_hard_never_blows_up() {
    for (speed, symmetric_mass_ratio) in [(5.0, 8.0), (30.0, 8.0), (5.0, f32::INFINITY)] {
        let mut app = app();
        app.insert_resource(VerletConfig {
            symmetric_mass_ratio,
            ..default()
        });
        let cloth = spawn(&mut app, |c| {
            ClothBuilder::new(Vec3::ZERO, 10, 10, 0.05)
                .pin_top_corners()
                .spawn(c)
        });
        for (k, &e) in cloth.particles.iter().enumerate() {
            let mut particle = app.world_mut().get_mut::<Particle>(e).unwrap();
            if k % 7 == 3 {
                particle.inverse_mass = 1e-3;
            }
            particle.set_velocity(Vec3::X * speed, DT);
        }
        step(&mut app, 1);
        let (start, scale) = (energy(&app), energy_scale(&app, 0.5));
        let (highest, _) = run_and_watch(&mut app, 640);
        let symmetric = app.world().resource::<VerletState>().solver.islands.list[0].symmetric;
        let counted = app.world().resource::<VerletStats>().symmetric_islands;
        assert_eq!(
            counted,
            usize::from(symmetric),
            "VerletStats::symmetric_islands"
        );
        println!(
            "hammock at {speed} m/s, ratio {symmetric_mass_ratio}: energy {start:.3e} J → at most {highest:.3e} J (scale {scale:.3e} J), symmetric {symmetric}"
        );
        if symmetric_mass_ratio.is_finite() {
            assert!(symmetric);
            assert!(highest <= start + 1e-6 * scale, "energy grew to {highest}");
        } else {
            assert!(!symmetric);
            assert!(highest > start + 1e6 * scale, "forward alone: {highest}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Over-constrained and violent events
// ---------------------------------------------------------------------------------------------

/// Pins pulled apart: a rigid stick between two pins, and a 10-link rigid chain between two
/// pins, pulled to twice their length. The pins win (infinite mass); the chain's links cannot
/// all hold, but nothing explodes: every particle stays between the pins and the energy after
/// the pull never rises. Measured: chain energy falls by 8 % in the 5 s after the pull.
#[test]
fn pins_pulling_rigid_sticks_apart_stay_bounded() {
    let mut app = app();
    let (a, b, stick) = spawn(&mut app, |c| {
        let a = c
            .spawn((Particle::new(Vec3::ZERO), Pin::at(Vec3::ZERO)))
            .id();
        let b = c.spawn((Particle::new(Vec3::X), Pin::at(Vec3::X))).id();
        let s = c.spawn(Stick::new(a, b)).id();
        (a, b, s)
    });
    let chain = spawn(&mut app, |c| {
        RopeBuilder::new(Vec3::new(0.0, 2.0, 0.0), Vec3::new(1.0, 2.0, 0.0), 10)
            .pin_start()
            .pin_end()
            .spawn(c)
    });
    step(&mut app, 8);
    app.world_mut()
        .get_mut::<Pin>(b)
        .unwrap()
        .set_position(Vec3::X * 2.0);
    let end = chain.particles[10];
    app.world_mut()
        .get_mut::<Pin>(end)
        .unwrap()
        .set_position(Vec3::new(2.0, 2.0, 0.0));
    step(&mut app, 2);
    let after = energy(&app);
    let scale = energy_scale(&app, 2.0);
    let (max_energy, _) = run_and_watch(&mut app, 64 * 5);
    let last = energy(&app);
    println!("pulled chain: energy after {after:.4} J, max {max_energy:.4}, last {last:.4}");
    assert!(
        max_energy <= after + 1e-6 * scale,
        "energy grew after the pull"
    );
    assert_eq!(position(&app, a), Vec3::ZERO);
    assert_eq!(position(&app, b), Vec3::X * 2.0);
    assert!(app.world().get::<Stick>(stick).is_some());
    for &p in &chain.particles {
        let x = solver_position(&app, p).unwrap();
        assert!(
            (-1e-9..=2.0 + 1e-9).contains(&x.x) && (0.0..=2.0 + 1e-9).contains(&x.y),
            "chain particle left the span: {x}"
        );
    }
}

/// A hanging 1 m rope whose pin is teleported 1 km in one step: the pin moves along the
/// straight line over the step's substeps (125 m per substep) and yanks the rope to ~64 km/s.
/// While its links are far from their length, projecting them back turns position corrections
/// into velocity, so the energy is not monotonic; it never exceeds 1.05 × its value right after
/// the teleport (measured: 1.02 ×, one step later). Once the rope is back to its length (by 4 s)
/// the undamped swing's energy only oscillates at the integrator's O(h²) level: it never rises
/// more than 10⁻³ × m·g·L above its 4-s value. With damping the rope then hangs from the new
/// place exactly as before. Measured on 2026-11-26, no damping: 2.03·10¹⁰ J after the
/// teleport, 1227 J at 4 s (the rope whirls on); its largest energy later is 10⁻⁴ m·g·L below
/// that (it drops to 1215.7–1218.5 J in the last second). That bound holds here by chance,
/// the 4-s value lying at the top of the band the whirl's energy oscillates in: teleported
/// 100 m, 500 m, 998–1003 m or 2 km instead (a scratch copy of this test), 8 of 10 distances
/// exceed their 4-s value by more (up to 1.7·10⁻² m·g·L; at 500 m 2310–2313 J each second for
/// 10 s, m·g·L = 98 J), none drifting up (the crate README, "Configuration", `line_substeps`).
#[test]
fn pin_teleported_a_kilometre_away() {
    for damping in [0.0, 2.0] {
        let mut app = app();
        app.insert_resource(VerletConfig {
            damping,
            ..default()
        });
        let rope = spawn(&mut app, |c| {
            RopeBuilder::new(Vec3::ZERO, Vec3::new(0.0, -1.0, 0.0), 10)
                .pin_start()
                .spawn(c)
        });
        step(&mut app, 64 * 4);
        let hanging = solver_position(&app, rope.particles[10]).unwrap();
        let rest_stretch = solver_max_stretch(&app);
        let far = Vec3::new(1000.0, 0.0, 0.0);
        app.world_mut()
            .get_mut::<Pin>(rope.particles[0])
            .unwrap()
            .set_position(far);
        step(&mut app, 1);
        let after = energy(&app);
        let (yank_max, yank_stretch) = run_and_watch(&mut app, 64 * 4 - 1);
        let caught_up = energy(&app);
        let stretch_at_4s = solver_max_stretch(&app);
        let (later_max, _) = run_and_watch(&mut app, 64 * 4);
        println!(
            "pin teleport, damping {damping}: energy {after:.4e} J after, max {yank_max:.4e} while yanked (stretch up to {yank_stretch:.0}), {caught_up:.3} at 4 s (stretch {stretch_at_4s:.1e}), max {later_max:.3} later"
        );
        assert!(yank_max <= 1.05 * after, "energy grew while yanked");
        assert!(
            stretch_at_4s < 0.01,
            "rope not back to its length: {stretch_at_4s}"
        );
        let scale = energy_scale(&app, 1.0);
        assert!(later_max <= caught_up + 1e-3 * scale, "energy grew");
        assert_eq!(position(&app, rope.particles[0]), far);
        if damping > 0.0 {
            let tip = solver_position(&app, rope.particles[10]).unwrap();
            let moved = tip - far.as_dvec3();
            assert!(
                (moved - hanging).length() < 1e-3,
                "tip {moved} vs {hanging} before"
            );
            assert!((solver_max_stretch(&app) - rest_stretch).abs() < 1e-4);
        }
    }
}

/// A hanging rope's free end kicked to 10⁶ m/s (5·10¹¹ J): the stick projections absorb most of
/// it at once (measured on 2026-11-26: 6.2·10⁴ J left after the kick's step), the energy after
/// that step is never exceeded, and with damping the rope comes back to hang where an unkicked
/// one does, its resting stretch included, within 1 mm: sleeping freezes its last swing
/// (measured 0.36 mm off; 0.09–0.36 mm for kicks of 10⁵–2·10⁶ m/s, within 2.5·10⁻⁵ m without
/// sleeping, a scratch copy of this test). A lone particle kicked the
/// same way flies on ballistically.
#[test]
fn huge_velocity_is_absorbed_without_explosion() {
    let mut app = app();
    app.insert_resource(VerletConfig {
        damping: 2.0,
        ..default()
    });
    let rope = spawn(&mut app, |c| {
        RopeBuilder::new(Vec3::ZERO, Vec3::new(0.0, -1.0, 0.0), 10)
            .pin_start()
            .spawn(c)
    });
    step(&mut app, 64 * 8);
    let tip = rope.particles[10];
    let hanging = solver_position(&app, tip).unwrap();
    let rest_stretch = solver_max_stretch(&app);
    app.world_mut()
        .get_mut::<Particle>(tip)
        .unwrap()
        .set_velocity(Vec3::X * 1e6, DT);
    step(&mut app, 1);
    let after = energy(&app);
    let (max_energy, _) = run_and_watch(&mut app, 64 * 12);
    println!("10⁶ m/s kick: energy after its step {after:.4e} J, max later {max_energy:.4e}");
    assert!(after < 5e11, "the kick's energy did not drop");
    assert!(max_energy <= after, "energy grew");
    let p = solver_position(&app, tip).unwrap();
    assert!(
        (p - hanging).length() < 1e-3,
        "tip at {p}, hung at {hanging}"
    );
    assert!((solver_max_stretch(&app) - rest_stretch).abs() < 1e-4);
    assert!(all_finite(&mut app));

    let mut app = common::app();
    app.insert_resource(Gravity::ZERO)
        .insert_resource(VerletConfig {
            damping: 2.0,
            ..default()
        });
    let lone = spawn(&mut app, |c| {
        c.spawn(Particle::new(Vec3::ZERO).with_velocity(Vec3::X * 1e6, DT))
            .id()
    });
    step(&mut app, 64 * 4);
    // x(t) = v₀·(1 − e^{−ct})/c; the per-substep damping factor applied at the end of each
    // substep travels short by ≈ c·h/2 = 0.2 % (measured 0.195 %).
    let x = solver_position(&app, lone).unwrap().x;
    let exact = 1e6 * (1.0 - (-8.0f64).exp()) / 2.0;
    assert!(
        (x / exact - 1.0).abs() < 4e-3,
        "lone particle at x = {x}, exact {exact}"
    );
}

// ---------------------------------------------------------------------------------------------
// Degenerate geometry
// ---------------------------------------------------------------------------------------------

/// A stick between coincident particles gets rest length 0 (a weld): the free particle stays on
/// the pinned one. A stick from a particle to itself is ignored (with a warning) and the
/// particle falls freely.
#[test]
fn zero_length_and_self_sticks() {
    let mut app = app();
    let (anchor, welded, lone, weld_stick) = spawn(&mut app, |c| {
        let anchor = c.spawn((Particle::new(Vec3::ONE), Pin::at(Vec3::ONE))).id();
        let welded = c.spawn(Particle::new(Vec3::ONE)).id();
        let weld = c.spawn(Stick::new(anchor, welded)).id();
        let lone = c.spawn(Particle::new(Vec3::ZERO)).id();
        c.spawn(Stick::new(lone, lone));
        (anchor, welded, lone, weld)
    });
    step(&mut app, 64);
    assert_eq!(
        app.world().get::<Stick>(weld_stick).unwrap().rest_length,
        Some(0.0)
    );
    let gap = (position(&app, welded) - position(&app, anchor)).length();
    // One substep of gravity (g·h² = 3.7·10⁻⁵ m) is undone by the projection in the same substep.
    assert!(gap < 1e-9, "weld gap {gap}");
    assert_eq!(app.world().resource::<VerletState>().solver.sticks.len(), 1);
    // Free fall for 1 s: −g/2.
    let y = solver_position(&app, lone).unwrap().y;
    assert!((y + 9.81 / 2.0).abs() < 1e-6, "lone particle at y = {y}");
}

/// Several particles at one point, in zero gravity: a chain of three coincident particles with
/// 0.5 m links pinned at the first unfolds to its lengths in one step (coincident ends are
/// pushed apart along a fixed per-stick direction in the XY plane). A triangle of three
/// coincident particles with 1 m sides first lands on a line (only its first stick sees
/// coincident ends); that compressed straight triangle is an unstable equilibrium, and it tips
/// over into a proper triangle within a second, staying in its plane. Five unlinked particles
/// at one point under gravity fall together.
#[test]
fn particles_at_one_point() {
    let mut app = app();
    app.insert_resource(Gravity::ZERO);
    let (chain, triangle) = spawn(&mut app, |c| {
        let chain: Vec<Entity> = (0..3)
            .map(|_| c.spawn(Particle::new(Vec3::ZERO)).id())
            .collect();
        c.entity(chain[0]).insert(Pin::at(Vec3::ZERO));
        c.spawn(Stick::new(chain[0], chain[1]).with_rest_length(0.5));
        c.spawn(Stick::new(chain[1], chain[2]).with_rest_length(0.5));
        let triangle: Vec<Entity> = (0..3)
            .map(|_| c.spawn(Particle::new(Vec3::splat(5.0))).id())
            .collect();
        for (a, b) in [(0, 1), (1, 2), (2, 0)] {
            c.spawn(Stick::new(triangle[a], triangle[b]).with_rest_length(1.0));
        }
        (chain, triangle)
    });
    step(&mut app, 1);
    assert!(solver_finite(&app));
    let [a, b, c] = [0, 1, 2].map(|i| solver_position(&app, chain[i]).unwrap());
    assert_eq!(a, DVec3::ZERO);
    assert!(((b - a).length() - 0.5).abs() < 1e-9 && ((c - b).length() - 0.5).abs() < 1e-9);
    step(&mut app, 64);
    assert!(solver_finite(&app));
    let [a, b, c] = [0, 1, 2].map(|i| solver_position(&app, triangle[i]).unwrap());
    for (side, length) in [(b - a), (c - b), (a - c)].iter().map(|d| (d, d.length())) {
        assert!(
            (length - 1.0).abs() < 1e-3,
            "triangle side {side}: {length}"
        );
    }
    assert!([a, b, c].iter().all(|p| p.z == 5.0), "stayed in its plane");

    let mut app = common::app();
    let heap: Vec<Entity> = spawn(&mut app, |c| {
        (0..5)
            .map(|_| c.spawn(Particle::new(Vec3::ONE)).id())
            .collect()
    });
    step(&mut app, 64);
    let first = position(&app, heap[0]);
    assert!(first.y < 0.0);
    for &e in &heap {
        assert_eq!(position(&app, e), first, "fell together");
    }
}

/// A particle exactly on a ground plane, exactly on a sphere's top, and exactly on a box's floor
/// stays there; particles exactly at a sphere's centre (zero gravity, so that they stay exactly
/// there until the collision pass) are pushed out to its top (the fixed choice +Y) without a
/// velocity kick, and rest there.
#[test]
fn particles_exactly_on_collider_surfaces_or_centres() {
    let colliders = [
        VerletCollider::ground(0.0),
        VerletCollider::sphere(1.0),
        VerletCollider::bounds(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0)),
    ];
    // (start, where it must be after 1 s)
    let cases = [
        (Vec3::ZERO, Vec3::ZERO),
        (Vec3::Y, Vec3::Y),
        (Vec3::ZERO, Vec3::ZERO),
    ];
    for (collider, (start, end)) in colliders.into_iter().zip(cases) {
        let mut app = app();
        let p = spawn(&mut app, |c| {
            c.spawn(collider);
            c.spawn(Particle::new(start)).id()
        });
        step(&mut app, 64);
        assert_eq!(position(&app, p), end, "{collider:?}");
    }
    let mut app = app();
    app.insert_resource(Gravity::ZERO);
    let centre = Vec3::new(3.0, 2.0, 0.0);
    let at_centre: Vec<Entity> = spawn(&mut app, |c| {
        c.spawn((
            VerletCollider::sphere(1.0),
            Transform::from_translation(centre),
        ));
        (0..3)
            .map(|_| c.spawn(Particle::new(centre).with_radius(0.1)).id())
            .collect()
    });
    step(&mut app, 1);
    assert!(solver_finite(&app));
    step(&mut app, 63);
    let top = centre.as_dvec3() + DVec3::Y * (1.0 + 0.1f32 as f64);
    for &e in &at_centre {
        let p = solver_position(&app, e).unwrap();
        assert!((p - top).length() < 1e-9, "on the sphere's top: {p}");
    }
    assert_eq!(kinetic_energy(&app), 0.0, "no kick");
}

// ---------------------------------------------------------------------------------------------
// Time
// ---------------------------------------------------------------------------------------------

fn steps_run(app: &App) -> u64 {
    app.world().resource::<VerletStats>().steps
}

/// A 1 s frame hitch runs 16 fixed steps, not 64: `Time<Virtual>` caps a frame's delta at its
/// `max_delta` (250 ms by default) and the rest of the hitch is dropped, so the simulation runs
/// slow for that frame instead of spiralling. Repeated hitches never build a backlog.
#[test]
fn a_one_second_hitch_runs_at_most_sixteen_steps() {
    let frame = Duration::from_secs_f64(1.0 / 64.0);
    let mut app = app_with_time(TimeUpdateStrategy::ManualDuration(frame));
    assert_eq!(
        app.world().resource::<Time<Virtual>>().max_delta(),
        Duration::from_millis(250)
    );
    spawn(&mut app, |c| {
        ClothBuilder::new(Vec3::ZERO, 10, 10, 0.1)
            .pin_top_row(1)
            .spawn(c)
    });
    for _ in 0..4 {
        let before = steps_run(&app);
        app.update();
        assert_eq!(steps_run(&app) - before, 1);
    }
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs(1)));
    for _ in 0..3 {
        let before = steps_run(&app);
        app.update();
        assert_eq!(steps_run(&app) - before, 16, "250 ms / 15.625 ms");
    }
    app.insert_resource(TimeUpdateStrategy::ManualDuration(frame));
    let before = steps_run(&app);
    app.update();
    assert_eq!(steps_run(&app) - before, 1, "no backlog after the hitch");
    assert!(all_finite(&mut app));
    assert!(max_strain(&mut app) < 0.05);
}

/// Period of a 1 m pendulum started at 5° (from upward zero crossings of x) and the largest
/// length error, in the app's current timing.
fn pendulum(app: &mut App, seconds: f64) -> (f64, f64) {
    let amplitude = 5f32.to_radians();
    let (pivot, bob) = spawn(app, |c| {
        let pivot = c
            .spawn((Particle::new(Vec3::ZERO), Pin::at(Vec3::ZERO)))
            .id();
        let bob = c
            .spawn(Particle::new(Vec3::new(
                amplitude.sin(),
                -amplitude.cos(),
                0.0,
            )))
            .id();
        c.spawn(Stick::new(pivot, bob));
        (pivot, bob)
    });
    let dt = app
        .world()
        .resource::<Time<Fixed>>()
        .timestep()
        .as_secs_f64();
    let steps = (seconds / dt).round() as usize;
    let mut samples = Vec::with_capacity(steps);
    let mut worst: f64 = 0.0;
    for i in 1..=steps {
        step(app, 1);
        let (p, o) = (
            solver_position(app, bob).unwrap(),
            solver_position(app, pivot).unwrap(),
        );
        worst = worst.max(((p - o).length() - 1.0).abs());
        samples.push((i as f64 * dt, p.x - o.x));
    }
    let times: Vec<f64> = samples
        .windows(2)
        .filter(|w| w[0].1 < 0.0 && w[1].1 >= 0.0)
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * (-w[0].1 / (w[1].1 - w[0].1)))
        .collect();
    assert!(times.len() >= 2, "{} crossings", times.len());
    let period = (times[times.len() - 1] - times[0]) / (times.len() - 1) as f64;
    (period, worst)
}

/// Exact period of the 5° pendulum of [`pendulum`] (small-angle period × (1 + θ²/16)).
fn exact_period(g: f64) -> f64 {
    2.0 * std::f64::consts::PI * (1.0 / g).sqrt() * (1.0 + 5f64.to_radians().powi(2) / 16.0)
}

/// Fixed steps of 0.1 ms (10 kHz) and 0.5 s (2 Hz, with `max_delta` raised to 1 s so that each
/// update runs one step) both keep a pendulum's length and period, with its rod at the step's
/// substeps and under `VerletConfig::line_substeps: Some(2)` — whose substeps are never longer
/// than 1/64 s (`solver::line_substeps::LINE_SUBSTEP_LONGEST`), so at 2 Hz it takes the step's
/// 8 of 62.5 ms (ωh ≈ 0.2). Measured period errors: 2·10⁻⁷ at 10 kHz (both), 9.8·10⁻⁴ (short)
/// at 2 Hz (both; 2.7 % with 2 substeps of 0.25 s, before the cap); length error 2·10⁻⁸ (the
/// f32 start position).
#[test]
fn very_small_and_very_large_fixed_timesteps() {
    for line_substeps in [None, Some(2)] {
        for (hz, seconds, bound) in [(10_000.0, 4.5, 1e-5), (2.0, 30.0, 0.015)] {
            let mut app = app();
            app.insert_resource(Time::<Fixed>::from_hz(hz))
                .insert_resource(VerletConfig {
                    line_substeps,
                    ..default()
                });
            app.world_mut()
                .resource_mut::<Time<Virtual>>()
                .set_max_delta(Duration::from_secs(1));
            let (period, length_error) = pendulum(&mut app, seconds);
            let exact = exact_period(9.81);
            let error = (period - exact).abs() / exact;
            println!(
                "{hz} Hz, line substeps {line_substeps:?}: period {period:.5} s vs {exact:.5} ({error:.2e}), length error {length_error:.1e}"
            );
            assert!(error < bound, "{hz} Hz: period {period} vs {exact}");
            assert!(length_error < 1e-6, "{hz} Hz: length error {length_error}");
            assert!(all_finite(&mut app));
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Topology under way
// ---------------------------------------------------------------------------------------------

/// What [`despawn_planned`] despawns on its next run.
#[derive(Resource, Default)]
struct DespawnPlan(Vec<Entity>);

fn despawn_planned(mut plan: ResMut<DespawnPlan>, mut commands: Commands) {
    for entity in plan.0.drain(..) {
        commands.entity(entity).despawn();
    }
}

/// Where in the fixed step the despawning system runs.
#[derive(Clone, Copy, Debug)]
enum When {
    BeforePrepare,
    BeforeSubsteps,
    BeforeTear,
    BeforeWriteback,
    AfterWriteback,
}

fn app_despawning(when: When) -> App {
    let mut app = app();
    app.init_resource::<DespawnPlan>();
    let system = despawn_planned;
    match when {
        When::BeforePrepare => {
            app.add_systems(VerletSchedule, system.before(VerletSystems::Prepare));
        }
        When::BeforeSubsteps => {
            app.add_systems(
                VerletSchedule,
                system
                    .after(VerletSystems::Prepare)
                    .before(VerletSystems::Substeps),
            );
        }
        When::BeforeTear => {
            app.add_systems(
                VerletSchedule,
                system
                    .after(VerletSystems::Substeps)
                    .before(VerletSystems::Tear),
            );
        }
        When::BeforeWriteback => {
            app.add_systems(
                VerletSchedule,
                system
                    .after(VerletSystems::Tear)
                    .before(VerletSystems::Writeback),
            );
        }
        When::AfterWriteback => {
            app.add_systems(VerletSchedule, system.after(VerletSystems::Writeback));
        }
    }
    app
}

/// Despawning a rope particle, a stick, or a whole cloth from a `VerletSchedule` system at every
/// point of the fixed step: no panic, no NaN, and from the next step on the solver's tables
/// match the components exactly.
#[test]
fn despawning_during_the_fixed_step() {
    for when in [
        When::BeforePrepare,
        When::BeforeSubsteps,
        When::BeforeTear,
        When::BeforeWriteback,
        When::AfterWriteback,
    ] {
        let mut app = app_despawning(when);
        let rope = spawn(&mut app, |c| {
            RopeBuilder::new(Vec3::ZERO, Vec3::X, 10)
                .pin_start()
                .tear_strain(5.0)
                .spawn(c)
        });
        let cloth = spawn(&mut app, |c| {
            ClothBuilder::new(Vec3::new(5.0, 0.0, 0.0), 8, 8, 0.1)
                .pin_top_row(1)
                .spawn(c)
        });
        step(&mut app, 8);
        app.world_mut().resource_mut::<DespawnPlan>().0 =
            vec![rope.particles[5], rope.sticks[2], cloth.root];
        step(&mut app, 1);
        assert!(solver_finite(&app), "{when:?}");
        step(&mut app, 1);
        check_consistency(&mut app).unwrap_or_else(|e| panic!("{when:?}: {e}"));
        let state = app.world().resource::<VerletState>();
        assert_eq!(state.solver.particles.len(), 10, "{when:?}");
        // Sticks 0, 1 and 5..9 of the rope remain (2 is despawned, 3 and 4 lost particle 5).
        assert_eq!(state.solver.sticks.len(), 7, "{when:?}");
        step(&mut app, 64);
        assert!(all_finite(&mut app));
        // The piece past the gap falls away; the piece on the pin still hangs there.
        assert!(position(&app, rope.particles[10]).y < -3.0, "{when:?}");
        assert!((position(&app, rope.particles[1]).length() - 0.1).abs() < 1e-3);
    }
}

/// Despawns made in `Update` at 200 fps, where most frames run no fixed step: Bevy keeps a
/// removal for two frames only, so the solver notices it by the changed component count, not
/// the removal buffer. Without that, a stick cut between fixed steps kept acting.
#[test]
fn despawns_between_fixed_steps_at_a_high_frame_rate_are_not_missed() {
    let mut app = app_with_time(TimeUpdateStrategy::ManualDuration(Duration::from_millis(5)));
    app.init_resource::<DespawnPlan>()
        .add_systems(Update, despawn_planned);
    let rope = spawn(&mut app, |c| {
        RopeBuilder::new(Vec3::ZERO, Vec3::X, 10)
            .pin_start()
            .spawn(c)
    });
    let mut despawned = 0;
    for frame in 0..400 {
        let before = steps_run(&app);
        app.update();
        // Right after a frame that ran a step, cut the next stick (the following frames run none).
        if steps_run(&app) > before && frame > 20 && despawned < 6 {
            app.world_mut()
                .resource_mut::<DespawnPlan>()
                .0
                .push(rope.sticks[despawned]);
            despawned += 1;
        }
    }
    assert_eq!(despawned, 6);
    check_consistency(&mut app).unwrap();
    let state = app.world().resource::<VerletState>();
    assert_eq!(state.solver.sticks.len(), 4);
    // Everything below the first cut fell.
    assert!(position(&app, rope.particles[10]).y < -5.0);
}

#[derive(Resource, Default)]
struct Tears(Vec<StickTorn>);

fn record_tears(mut reader: MessageReader<StickTorn>, mut tears: ResMut<Tears>) {
    tears.0.extend(reader.read().copied());
}

/// A hanging 40 × 40 cloth with tearable sticks, then gravity × 40: tears cascade down from the
/// pinned row until the cloth falls off. Every particle remains, every tear is reported exactly
/// once, no stick tears twice, and the solver matches the components after every step.
#[test]
fn tearing_cascade_keeps_every_particle_and_reports_each_tear_once() {
    let mut app = app();
    app.init_resource::<Tears>()
        .add_systems(FixedPostUpdate, record_tears);
    let cloth = spawn(&mut app, |c| {
        ClothBuilder::new(Vec3::ZERO, 40, 40, 0.05)
            .pin_top_row(1)
            .tear_strain(0.5)
            .spawn(c)
    });
    let sticks = cloth.sticks.len();
    step(&mut app, 64);
    assert!(app.world().resource::<Tears>().0.is_empty());
    app.insert_resource(Gravity(Vec3::new(0.0, -400.0, 0.0)));
    let mut torn_so_far = 0;
    for _ in 0..64 * 3 {
        step(&mut app, 1);
        check_consistency(&mut app).unwrap();
        let tears = app.world().resource::<Tears>().0.len();
        assert!(tears >= torn_so_far);
        torn_so_far = tears;
    }
    let tears = app.world().resource::<Tears>().0.clone();
    let mut torn: Vec<Entity> = tears.iter().map(|t| t.stick).collect();
    torn.sort();
    torn.dedup();
    println!("cascade: {} of {sticks} sticks torn", tears.len());
    assert_eq!(torn.len(), tears.len(), "a stick was reported twice");
    assert!(
        tears.len() >= 40,
        "the cloth tore off: {} tears",
        tears.len()
    );
    assert_eq!(
        app.world().resource::<VerletStats>().torn_total,
        tears.len() as u64
    );
    assert_eq!(count::<Stick>(&mut app), sticks - tears.len());
    assert_eq!(count::<Particle>(&mut app), 1600);
    assert_eq!(
        app.world().resource::<VerletState>().solver.particles.len(),
        1600
    );
    for t in &tears {
        assert!(
            app.world().get_entity(t.stick).is_err(),
            "torn stick despawned"
        );
        assert!(
            t.particles
                .iter()
                .all(|&p| app.world().get::<Particle>(p).is_some())
        );
    }
    assert!(all_finite(&mut app));
    // The torn-off part fell far below the pinned row.
    assert!(position(&app, cloth.particles[1599]).y < -20.0);
}

// ---------------------------------------------------------------------------------------------
// Far from the origin
// ---------------------------------------------------------------------------------------------

/// Sag of a 10 × 10 pixel cloth (8 px spacing, top corners pinned, settled with damping) and the
/// period of a 100 px pendulum, at 64 substeps, at the origin and 10⁶ px away (every start
/// position exactly representable in f32 there, so both scenes are the same). Measured
/// differences (read from the solver's f64 state): sag 2·10⁻⁸ px of 74 px, period 2·10⁻⁸ s of
/// 2.017 s; both periods within 0.2 % of the exact one.
#[test]
fn far_from_the_origin_behaves_like_at_the_origin() {
    let measure = |origin: Vec3| {
        let mut app = app();
        app.insert_resource(Gravity::PIXELS)
            .insert_resource(VerletConfig {
                substeps: 64,
                damping: 2.0,
                ..default()
            });
        let cloth = spawn(&mut app, |c| {
            ClothBuilder::new(origin, 10, 10, 8.0)
                .pin_top_corners()
                .spawn(c)
        });
        step(&mut app, 64 * 6);
        let sag = origin.y as f64 - solver_position(&app, cloth.particles[95]).unwrap().y;
        // A pendulum of 100 px released at (28, −96) px from its pivot (16.3°), undamped.
        let mut app = app_pendulum(origin);
        let (period, stretch) = app_period(&mut app, origin);
        (sag, period, stretch)
    };
    let (sag0, period0, stretch0) = measure(Vec3::ZERO);
    let (sag1, period1, stretch1) = measure(Vec3::new(1e6, 1e6, 0.0));
    println!(
        "origin: sag {sag0} px, period {period0} s; 10⁶ px: sag {sag1} px, period {period1} s (stretch {stretch0:.1e} / {stretch1:.1e})"
    );
    assert!(sag0 > 50.0);
    assert!((sag1 - sag0).abs() < 1e-5, "sag {sag0} vs {sag1}");
    assert!(
        (period1 - period0).abs() < 1e-6,
        "period {period0} vs {period1}"
    );
    // T = T₀·(1 + θ²/16 + 11θ⁴/3072 + …) at θ = asin(0.28).
    let theta = 0.28f64.asin();
    let exact = 2.0
        * std::f64::consts::PI
        * (100.0f64 / 980.0).sqrt()
        * (1.0 + theta.powi(2) / 16.0 + 11.0 * theta.powi(4) / 3072.0);
    assert!(
        (period0 - exact).abs() / exact < 0.002,
        "period {period0} vs {exact}"
    );
    assert!(stretch0 < 1e-6 && stretch1 < 1e-6);
}

fn app_pendulum(origin: Vec3) -> App {
    let mut app = app();
    app.insert_resource(Gravity::PIXELS)
        .insert_resource(VerletConfig {
            substeps: 64,
            ..default()
        });
    spawn(&mut app, |c| {
        let pivot = c.spawn((Particle::new(origin), Pin::at(origin))).id();
        let bob = c
            .spawn(Particle::new(origin + Vec3::new(28.0, -96.0, 0.0)))
            .id();
        c.spawn(Stick::new(pivot, bob).with_rest_length(100.0));
    });
    app
}

/// Period and largest relative length error of the pendulum of [`app_pendulum`] over 6 s.
fn app_period(app: &mut App, origin: Vec3) -> (f64, f64) {
    let o = origin.as_dvec3();
    let mut samples = Vec::new();
    let mut worst: f64 = 0.0;
    for i in 1..=64 * 6 {
        step(app, 1);
        let state = app.world().resource::<VerletState>();
        let p = state.solver.particles.position[1];
        worst = worst.max(((p - o).length() / 100.0 - 1.0).abs());
        samples.push((i as f64 / 64.0, p.x - o.x));
    }
    let times: Vec<f64> = samples
        .windows(2)
        .filter(|w| w[0].1 < 0.0 && w[1].1 >= 0.0)
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * (-w[0].1 / (w[1].1 - w[0].1)))
        .collect();
    assert!(times.len() >= 2);
    (
        (times[times.len() - 1] - times[0]) / (times.len() - 1) as f64,
        worst,
    )
}

// ---------------------------------------------------------------------------------------------
// A long run
// ---------------------------------------------------------------------------------------------

/// 10⁵ fixed steps (26 min of simulated time) of a braced square swinging from one corner and a
/// 10-link chain swinging from a pin, no damping, in the solver core: no NaN, the energy never
/// rises above its start and never falls below the resting pose, the sticks hold. Measured:
/// the swing decays by PBD's numerical dissipation (see the printed energies) until both hang
/// still; max stretch 7·10⁻³ (the chain's links at 8 substeps).
#[test]
fn a_hundred_thousand_steps_stay_finite_and_bounded() {
    let mut solver = Solver::default();
    use bevy_verlet_physics::solver::StickKind::Equal;
    // Braced square of side 1 hanging from corner 0, tilted by 30°.
    let corners = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(1.0, -1.0, 0.0),
        DVec3::new(0.0, -1.0, 0.0),
    ];
    let tilt = glam::DQuat::from_rotation_z(0.5);
    let square: Vec<u32> = corners
        .iter()
        .map(|&c| solver.add_particle(tilt * c, 1.0))
        .collect();
    solver.pin(square[0], DVec3::ZERO);
    for (a, b) in [(0, 1), (1, 2), (2, 3), (3, 0), (0, 2), (1, 3)] {
        let rest = (corners[a] - corners[b]).length();
        solver
            .sticks
            .push([square[a], square[b]], rest, 0.0, Equal, f64::INFINITY, 0);
    }
    // A horizontal chain from (5, 0).
    let mut previous = solver.add_particle(DVec3::new(5.0, 0.0, 0.0), 0.0);
    solver.pin(previous, DVec3::new(5.0, 0.0, 0.0));
    for i in 1..=10 {
        let p = solver.add_particle(DVec3::new(5.0 + 0.1 * i as f64, 0.0, 0.0), 1.0);
        solver
            .sticks
            .push([previous, p], 0.1, 0.0, Equal, f64::INFINITY, 0);
        previous = p;
    }
    let config = StepConfig::default();
    let h = config.substep();
    let energy = |s: &Solver| {
        let p = &s.particles;
        let potential: f64 = (0..p.len())
            .filter(|&i| p.inverse_mass[i] > 0.0)
            .map(|i| 9.81 * p.position[i].y / p.inverse_mass[i])
            .sum();
        p.kinetic_energy(h) + potential
    };
    solver.step(&config);
    let start = energy(&solver);
    let scale = 13.0 * 9.81 * 2.0;
    // Both hanging still: the square's diagonal vertical (corners at −√½, −√½, −√2), the chain
    // straight down (−0.1 … −1).
    let rest = -9.81 * (2.0 * 0.5f64.sqrt() + 2f64.sqrt() + 0.1 * 55.0);
    let mut max_energy = f64::MIN;
    let mut max_stretch: f64 = 0.0;
    let mut after_1000 = 0.0;
    for i in 0..100_000 {
        solver.step(&config);
        if i == 999 {
            after_1000 = energy(&solver);
        }
        if i % 100 == 0 {
            assert!(solver.particles.all_finite(), "NaN at step {i}");
            max_energy = max_energy.max(energy(&solver));
            max_stretch = max_stretch.max(solver.sticks.max_violation(&solver.particles));
        }
    }
    let end = energy(&solver);
    println!(
        "10⁵ steps: energy {start:.4} → {after_1000:.4} (10³ steps) → {end:.4} J (10⁵; max {max_energy:.4}, rest {rest:.4}), max stretch {max_stretch:.1e}"
    );
    assert!(solver.particles.all_finite());
    assert!(max_energy <= start + 1e-6 * scale, "energy grew");
    // Bounded below by the resting pose (less a little stretch): it cannot fall through it.
    assert!(
        end > rest - 0.01 * scale,
        "below the resting pose: {end} < {rest}"
    );
    assert!(max_stretch < 1e-2, "stretch {max_stretch}");
}

// ---------------------------------------------------------------------------------------------
// Bad input
// ---------------------------------------------------------------------------------------------

/// Warning capture: a subscriber on the test thread (the fixed-step schedule is made
/// single-threaded, so the plugin's systems run there).
mod warnings {
    use bevy::log::tracing::field::{Field, Visit};
    use bevy::log::tracing::{self, Event, Subscriber};
    use bevy::log::tracing_subscriber::layer::{Context, Layer, SubscriberExt};
    use bevy::log::tracing_subscriber::registry;
    use std::sync::{Arc, Mutex};

    struct Capture(Arc<Mutex<Vec<String>>>);

    struct Message(String);
    impl Visit for Message {
        fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
            if field.name() == "message" {
                self.0 = format!("{value:?}");
            }
        }
    }

    impl<S: Subscriber> Layer<S> for Capture {
        fn on_event(&self, event: &Event<'_>, _: Context<'_, S>) {
            if *event.metadata().level() == tracing::Level::WARN {
                let mut message = Message(String::new());
                event.record(&mut message);
                self.0.lock().unwrap().push(message.0);
            }
        }
    }

    /// Runs `f` with warnings captured; returns them.
    pub fn capture(f: impl FnOnce()) -> Vec<String> {
        let log = Arc::new(Mutex::new(Vec::new()));
        let subscriber = registry().with(Capture(log.clone()));
        tracing::subscriber::with_default(subscriber, f);
        log.lock().unwrap().clone()
    }
}

/// A particle at `position` whose previous position is `previous`.
fn with_previous(position: Vec3, previous: Vec3) -> Particle {
    let mut particle = Particle::new(position);
    particle.previous_position = previous;
    particle
}

/// Every kind of bad input at once: each is warned about exactly once (over 64 steps), nothing
/// panics, no NaN reaches a simulated particle, and the good parts of the scene simulate normally.
///
/// | input | what happens |
/// |---|---|
/// | NaN/∞ position at spawn | particle left out (component untouched); its sticks and pin ignored |
/// | NaN/∞ position edit | edit ignored; the particle keeps its last state |
/// | NaN, ∞ (mass 0) or negative inverse mass | mass 1 |
/// | NaN/negative radius | 0 |
/// | NaN or negative compliance | rigid |
/// | +∞ compliance | no stiffness: the stick is ignored |
/// | rest length NaN/∞/negative | the current distance |
/// | tear strain NaN/negative | never tears |
/// | endpoint not a particle, despawned, or left out | stick ignored |
/// | stick from a particle to itself | ignored |
/// | pin target NaN, or following an entity without `Transform` | the pin holds still |
/// | `Pin` on an entity without `Particle` | ignored |
/// | NaN gravity / NaN or negative damping | zero / none |
/// | `tether_anchors` 0 or above 8 | 1 / 8 |
/// | empty or NaN collider | ignored |
#[test]
fn bad_input_warns_once_and_never_spreads_nan() {
    let mut app = app();
    app.edit_schedule(FixedPostUpdate, |schedule| {
        schedule.set_executor(SingleThreadedExecutor::new());
    });
    let nan = f32::NAN;
    let mut ids = Vec::new();
    let log = warnings::capture(|| {
        let e = spawn(&mut app, |c| {
            let anchor = c
                .spawn((Particle::new(Vec3::ZERO), Pin::at(Vec3::ZERO)))
                .id();
            let free =
                |c: &mut Commands, x: f32| c.spawn(Particle::new(Vec3::new(x, 0.0, 0.0))).id();
            let a = free(c, 1.0);
            let b = free(c, 2.0);
            let d = free(c, 3.0);
            let f = free(c, 4.0);
            let g = free(c, 5.0);
            c.spawn(Stick::new(anchor, a));
            c.spawn(Stick::new(a, b).with_compliance(-0.25));
            c.spawn(Stick::new(b, d).with_compliance(nan));
            c.spawn(Stick::new(d, f).with_compliance(f32::INFINITY));
            c.spawn(
                Stick::new(d, g)
                    .with_rest_length(-3.5)
                    .with_tear_strain(-0.75),
            );
            c.spawn(Stick::new(f, g).with_rest_length(nan).with_tear_strain(nan));
            let nan_position = c
                .spawn(with_previous(Vec3::new(nan, 0.0, 0.0), Vec3::splat(31.5)))
                .id();
            let inf_position = c.spawn(Particle::new(Vec3::splat(f32::INFINITY))).id();
            let negative_mass = c
                .spawn(Particle::new(Vec3::new(0.0, 5.0, 0.0)).with_mass(-2.0))
                .id();
            let zero_mass = c
                .spawn(Particle::new(Vec3::new(1.0, 5.0, 0.0)).with_mass(0.0))
                .id();
            let nan_mass = c
                .spawn(
                    Particle::new(Vec3::new(2.0, 5.0, 0.0))
                        .with_inverse_mass(nan)
                        .with_radius(-1.5),
                )
                .id();
            let nothing = c.spawn_empty().id();
            let gone = c.spawn(Particle::new(Vec3::new(3.0, 5.0, 0.0))).id();
            c.spawn(Stick::new(anchor, nan_position));
            c.spawn(Stick::new(anchor, nothing));
            c.spawn(Stick::new(anchor, gone));
            c.spawn(Stick::new(anchor, anchor));
            c.spawn(AngleConstraint::new(a, b, d).with_compliance(nan));
            c.spawn(AngleConstraint::new(b, d, f).with_rest_angle(nan));
            c.spawn((
                Particle::new(Vec3::new(6.0, 0.0, 0.0)),
                Pin::at(Vec3::new(nan, 1.25, 0.0)),
            ));
            let follower = c
                .spawn((
                    Particle::new(Vec3::new(7.0, 0.0, 0.0)),
                    Pin::follow(nothing, Vec3::ZERO),
                ))
                .id();
            let pin_only = c.spawn(Pin::at(Vec3::ZERO)).id();
            c.spawn(VerletCollider::sphere(nan));
            c.spawn(VerletCollider::bounds(Vec3::splat(1.0), Vec3::splat(-1.0)));
            c.spawn(VerletCollider::new(ColliderShape::Plane {
                point: Vec3::ZERO,
                normal: Vec3::ZERO,
            }));
            [
                anchor,
                a,
                b,
                d,
                f,
                g,
                nan_position,
                inf_position,
                negative_mass,
                zero_mass,
                nan_mass,
                gone,
                follower,
                pin_only,
            ]
        });
        ids.extend(e);
        step(&mut app, 1);
        app.world_mut().despawn(e[11]);
        app.insert_resource(Gravity(Vec3::new(0.0, nan, 0.0)));
        app.insert_resource(VerletConfig {
            damping: -1.0,
            tether_anchors: 1_000_000,
            symmetric_mass_ratio: nan,
            ..default()
        });
        for _ in 0..8 {
            step(&mut app, 1);
            assert!(solver_finite(&app));
        }
        app.insert_resource(Gravity::default());
        app.insert_resource(VerletConfig::default());
        step(&mut app, 64);
        // A live particle edited to NaN, with and without a rebuild in the same step.
        for rebuild in [false, true] {
            app.world_mut().get_mut::<Particle>(e[8]).unwrap().position = Vec3::new(nan, 0.0, 0.0);
            if rebuild {
                app.world_mut()
                    .spawn(Particle::new(Vec3::new(50.0, 0.0, 0.0)));
            }
            step(&mut app, 4);
        }
    });
    let count = |needle: &str| log.iter().filter(|m| m.contains(needle)).count();
    for m in &log {
        println!("warning: {m}");
    }
    // Each problem once, with the bad value in the message.
    for needle in [
        "compliance -0.25",
        "Stick stiffness Compliance(NaN)",
        "infinite compliance",
        "rest length -3.5",
        "rest length NaN",
        "tear strain -0.75",
        "tear strain NaN",
        "previous [31.5, 31.5, 31.5]",
        "position [inf, inf, inf]",
        "inverse_mass -0.5",
        "inverse_mass inf",
        "inverse_mass NaN",
        "radius -1.5",
        "connects a particle to itself",
        "AngleConstraint stiffness Compliance(NaN)",
        "rest angle NaN",
        "Pin target [NaN, 1.25, 0]",
        "which has no Transform",
        "Pin on an entity without a Particle",
        "Gravity [0, NaN, 0]",
        "damping -1",
        "tether_anchors 1000000 is outside 1..=8; using 8",
        "symmetric_mass_ratio is NaN; using 8",
        "sphere with a non-finite centre",
        "min > max",
        "zero or non-finite normal",
    ] {
        assert_eq!(
            count(needle),
            1,
            "{needle:?} warned {} times",
            count(needle)
        );
    }
    // Endpoints: the NaN particle, the non-particle and the despawned one (each stick once).
    assert_eq!(count("is not a simulated particle"), 3, "{log:#?}");
    // The live particle edited to NaN twice: ignored, warned once.
    assert_eq!(count("position [NaN, 0, 0] / previous [0,"), 1);

    assert!(solver_finite(&app));
    let world = app.world_mut();
    let mut query = world.query::<(Entity, &Particle)>();
    let state = world.resource::<VerletState>();
    for (entity, particle) in query.iter(world) {
        if state.slot(entity).is_some() {
            assert!(particle.position.is_finite() && particle.previous_position.is_finite());
        }
    }
    assert!(state.slot(ids[6]).is_none() && state.slot(ids[7]).is_none());
    assert!(
        state.slot(ids[8]).is_some(),
        "the NaN edit did not drop the particle"
    );
    // The good chain hangs from the anchor.
    assert!((position(&app, ids[1]).length() - 1.0).abs() < 1e-3);
    // Negative, zero and NaN masses became mass 1 (they fall); the edited one kept falling.
    for &e in &ids[8..11] {
        assert!(position(&app, e).y < 0.0, "fell");
    }
    check_consistency(&mut app).unwrap();
}

/// A constraint set the solver cannot handle — an angle constraint whose arms no stick holds,
/// with a light vertex between a pinned and a heavy end, started folded — diverges (measured:
/// beyond 10³⁰ m within 2 s in the solver core, NaN soon after). The plugin puts every
/// diverging particle back at its last position, at rest, and counts it: nothing non-finite
/// ever reaches a component or the next step.
#[test]
fn diverging_particles_are_put_back_without_nan() {
    let mut app = app();
    let ends = spawn(&mut app, |c| {
        let a = c
            .spawn((Particle::new(Vec3::ZERO), Pin::at(Vec3::ZERO)))
            .id();
        let b = c
            .spawn(Particle::new(Vec3::ZERO).with_inverse_mass(0.1))
            .id();
        let d = c
            .spawn(Particle::new(Vec3::new(3.9449944, 0.0, 0.0)).with_inverse_mass(0.001))
            .id();
        c.spawn(AngleConstraint::new(a, b, d).with_rest_angle(1.0));
        [a, b, d]
    });
    let mut worst: f32 = 0.0;
    for _ in 0..64 * 5 {
        step(&mut app, 1);
        assert!(all_finite(&mut app));
        assert!(solver_finite(&app));
        for &e in &ends {
            worst = worst.max(position(&app, e).abs().max_element());
        }
        check_consistency(&mut app).unwrap();
    }
    let diverged = app.world().resource::<VerletStats>().diverged;
    println!("free-armed angle: {diverged} particle resets, farthest {worst:.2e} m");
    assert!(
        diverged > 0,
        "it did not diverge (the case no longer shows the limitation)"
    );
}

/// A pinned particle next to one whose state turned NaN — written into the solver here; wild
/// input the fuzzer built reached it the same way — ends the step at its pin's new target, not
/// where it was: a swept stick moves its pinned end by `0 · NaN`, and a diverged particle is
/// put back at rest, a pinned one now at its pin (`FUZZ_SEED=33` of `tests/fuzz.rs` failed so:
/// the pinned particle stayed at its old target).
#[test]
fn a_diverged_pinned_particle_is_put_back_at_its_pin() {
    let mut app = app();
    app.insert_resource(VerletConfig {
        method: SolveMethod::Sweep,
        ..default()
    });
    let (pinned, other) = spawn(&mut app, |c| {
        let pinned = c
            .spawn((Particle::new(Vec3::ZERO), Pin::at(Vec3::ZERO)))
            .id();
        let other = c.spawn(Particle::new(Vec3::X)).id();
        c.spawn(Stick::new(pinned, other));
        (pinned, other)
    });
    step(&mut app, 2);
    let target = Vec3::new(0.0, 1.0, 0.0);
    app.world_mut()
        .get_mut::<Pin>(pinned)
        .unwrap()
        .set_position(target);
    let mut state = app.world_mut().resource_mut::<VerletState>();
    let slot = state.slot(other).unwrap() as usize;
    state.solver.particles.position[slot] = DVec3::NAN;
    state.solver.particles.previous[slot] = DVec3::NAN;
    step(&mut app, 1);
    assert!(app.world().resource::<VerletStats>().diverged >= 1);
    assert_eq!(position(&app, pinned), target);
    assert_eq!(solver_position(&app, pinned), Some(target.as_dvec3()));
    assert!(solver_finite(&app));
}

/// A particle pushed past f32's range (3·10³⁸ m at 6.4·10³⁹ m/s) is put back at its last
/// position, at rest, with a warning, instead of writing ±∞ into its component.
#[test]
fn particles_beyond_the_f32_range_are_stopped() {
    let mut app = app();
    app.insert_resource(Gravity::ZERO);
    let p = spawn(&mut app, |c| {
        c.spawn(with_previous(
            Vec3::new(3.0e38, 0.0, 0.0),
            Vec3::new(2.0e38, 0.0, 0.0),
        ))
        .id()
    });
    step(&mut app, 4);
    let particle = particle(&app, p);
    assert_eq!(particle.position, Vec3::new(3.0e38, 0.0, 0.0));
    assert_eq!(particle.previous_position, particle.position, "at rest");
    assert!(solver_finite(&app));
    assert_eq!(app.world().resource::<VerletStats>().diverged, 1);
}
