#![cfg(feature = "avian3d")]
use avian3d::prelude::*;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_verlet_physics::avian3d::{BodyAttachment, VerletAvianPlugin};
use bevy_verlet_physics::prelude::*;

fn app() -> App {
    let gravity = Vec3::new(0.0, -9.81, 0.0);
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        PhysicsPlugins::default(),
        VerletPlugin::default(),
        VerletAvianPlugin,
    ))
    .insert_resource(TimeUpdateStrategy::FixedTimesteps(1))
    .insert_resource(avian3d::prelude::Gravity(gravity))
    .insert_resource(bevy_verlet_physics::Gravity(gravity));
    app.finish();
    app.cleanup();
    app.update();
    app
}
struct Rng(u64);
impl Rng {
    fn r(&mut self, a: f32, b: f32) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        a + (b - a) * ((self.0 >> 11) as f32 / (1u64 << 53) as f32)
    }
}
fn energy(app: &App, plank: Entity, particles: &[Entity]) -> f64 {
    let state = app.world().resource::<VerletState>();
    let (solver, p) = (&state.solver, &state.solver.particles);
    let ropes: f64 = particles
        .iter()
        .filter_map(|&e| state.slot(e))
        .filter(|&s| p.inverse_mass[s as usize] > 0.0)
        .map(|slot| {
            let (i, h) = (slot as usize, solver.state_substep_of(slot).unwrap());
            let (m, v) = (1.0 / p.inverse_mass[i], (p.position[i] - p.previous[i]) / h);
            0.5 * m * v.length_squared() + m * 9.81 * p.position[i].y
        })
        .sum();
    let w = app.world();
    let v = w.get::<LinearVelocity>(plank).unwrap().0;
    let spin = w.get::<AngularVelocity>(plank).unwrap().0;
    let rotation = w.get::<Rotation>(plank).unwrap().0;
    let y = w.get::<Position>(plank).unwrap().0.y;
    let mass = 1.0 / w.get::<ComputedMass>(plank).unwrap().inverse();
    let local = rotation.inverse() * spin;
    let inertia = w.get::<ComputedAngularInertia>(plank).unwrap().value();
    let turning = 0.5 * local.dot(inertia * local);
    ropes + f64::from(0.5 * mass * v.length_squared() + turning + mass * 9.81 * y)
}
#[test]
fn zz_scan3d() {
    let n: usize = std::env::var("ZZ_N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(30);
    let mut rng = Rng(0x1234_5678_9abc_def1);
    let (mut worst, mut worst_strain) = (f64::MIN, 0.0f64);
    for scene in 0..n {
        let mass = rng.r(0.2, 3.2);
        let width = rng.r(0.2, 1.0);
        let ropes = 2 + (rng.r(0.0, 1.0) * 3.0) as usize;
        let knot = rng.r(0.001, 0.3);
        let kick = Vec3::new(rng.r(-7.0, 7.0), rng.r(-7.0, 7.0), rng.r(-3.5, 3.5));
        let spin = Vec3::new(rng.r(-5.0, 5.0), rng.r(-5.0, 5.0), rng.r(-10.0, 10.0));
        let centre = Vec3::new(0.0, -1.0, 0.0);
        let only: Option<usize> = std::env::var("ZZ_ONLY").ok().and_then(|s| s.parse().ok());
        if only.is_some_and(|o| o != scene) {
            for _ in 0..ropes {
                rng.r(0.0, 1.0);
                rng.r(0.0, 1.0);
                rng.r(0.0, 1.0);
            }
            continue;
        }
        let mut app = app();
        let plank = app
            .world_mut()
            .spawn((
                RigidBody::Dynamic,
                Collider::cuboid(width, 0.04, 0.3),
                Mass(mass),
                Transform::from_translation(centre),
            ))
            .id();
        let mut particles = Vec::new();
        for k in 0..ropes {
            let side = width * (k as f32 / (ropes - 1) as f32 - 0.5);
            let depth = 0.15 * if k % 2 == 0 { 1.0 } else { -1.0 };
            let top = Vec3::new(rng.r(-1.0, 1.0), rng.r(-0.2, 0.2), rng.r(-0.5, 0.5));
            let anchor = Vec3::new(side, 0.0, depth);
            let world = app.world_mut();
            let rope = RopeBuilder::new(top, centre + anchor, 8)
                .mass(0.01)
                .pin_start()
                .spawn(&mut world.commands());
            world.flush();
            let last = *rope.particles.last().unwrap();
            let mut e = world.entity_mut(last);
            if std::env::var("ZZ_FREE").is_err() {
                e.insert(BodyAttachment::new(plank, anchor));
            }
            let mut particle = e.get_mut::<Particle>().unwrap();
            *particle = particle.clone().with_mass(knot);
            particles.extend(rope.particles);
        }
        for _ in 0..2 {
            app.update();
        }
        app.world_mut().get_mut::<LinearVelocity>(plank).unwrap().0 = kick;
        app.world_mut().get_mut::<AngularVelocity>(plank).unwrap().0 = spin;
        app.update();
        let after = energy(&app, plank, &particles);
        if only.is_some() {
            println!("mass {mass} width {width} ropes {ropes} knot {knot} kick {kick} spin {spin}");
        }
        let (mut highest, mut strain) = (f64::MIN, 0.0f64);
        for t in 0..256 {
            app.update();
            let e = energy(&app, plank, &particles);
            if only.is_some() && t < 40 {
                println!(
                    "t {t}: energy {:.4} ({:+.3} % of scale), later exchanges {}",
                    e,
                    100.0 * (e - after) / (f64::from(mass) * 9.81 * 2.0),
                    app.world()
                        .resource::<bevy_verlet_physics::avian3d::AvianCouplingStats>()
                        .later_exchanges
                );
            }
            highest = highest.max(e);
            let state = app.world().resource::<VerletState>();
            for i in 0..state.solver.sticks.len() {
                strain = strain.max(state.solver.sticks.strain(i, &state.solver.particles).abs());
            }
        }
        let rise = 100.0 * (highest - after) / (f64::from(mass) * 9.81 * 2.0);
        println!("scene {scene}: rise {rise:.2} % strain {strain:.2e}");
        worst = worst.max(rise);
        worst_strain = worst_strain.max(strain);
    }
    println!("worst rise {worst:.2} % strain {worst_strain:.2e}");
}
