//! The `avian_2d` example's scene, as a library function (pixels, origin at the centre of a
//! 1280 × 720 window, Y up; gravity −980 px/s² for both engines), so a headless test steps
//! exactly what the example shows.

use super::BodyAttachment;
use crate::builders::{ClothBuilder, Composite, RopeBuilder};
use crate::scenes::spawn_ragdoll;
use ::avian2d::prelude::*;
use bevy::prelude::*;

/// Gravity of the scene for both engines (px/s², down).
pub const GRAVITY: f32 = -980.0;

/// What [`spawn`] made.
#[derive(Clone, Debug)]
pub struct AvianScene {
    /// Static avian colliders: ground, walls, two ramps, the capsule.
    pub statics: Vec<Entity>,
    /// The 40 kg avian wrecking ball.
    pub ball: Entity,
    /// Its Verlet rope (pinned at the top, last particle attached to the ball).
    pub rope: Composite,
    /// The avian boxes of the stack.
    pub boxes: Vec<Entity>,
    /// The cloth strip dropped over the capsule.
    pub cloth: Composite,
    /// The capsule.
    pub capsule: Entity,
    /// Two ragdolls above the ramps.
    pub ragdolls: Vec<Composite>,
}

impl AvianScene {
    /// Every avian entity of the scene (for despawning on reset).
    pub fn avian_entities(&self) -> impl Iterator<Item = Entity> + '_ {
        self.statics
            .iter()
            .chain(&self.boxes)
            .copied()
            .chain([self.ball])
    }
}

/// Spawns the scene: static ground, walls and ramps, a wrecking ball on a rope swinging into a
/// stack of boxes, a cloth strip over a capsule, two ragdolls above the ramps.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::avian2d::scene;
/// let mut world = World::new();
/// let s = scene::spawn(&mut world.commands());
/// world.flush();
/// assert_eq!(s.boxes.len(), 15);
/// ```
pub fn spawn(commands: &mut Commands) -> AvianScene {
    let mut statics = Vec::new();
    let mut wall = |commands: &mut Commands, at: Vec2, size: Vec2, turn: f32| {
        let transform =
            Transform::from_translation(at.extend(0.0)).with_rotation(Quat::from_rotation_z(turn));
        let body = (
            RigidBody::Static,
            Collider::rectangle(size.x, size.y),
            transform,
        );
        statics.push(commands.spawn(body).id());
    };
    wall(
        commands,
        Vec2::new(0.0, -340.0),
        Vec2::new(1280.0, 40.0),
        0.0,
    );
    wall(
        commands,
        Vec2::new(-630.0, 0.0),
        Vec2::new(20.0, 720.0),
        0.0,
    );
    wall(commands, Vec2::new(630.0, 0.0), Vec2::new(20.0, 720.0), 0.0);
    wall(
        commands,
        Vec2::new(-420.0, 60.0),
        Vec2::new(300.0, 16.0),
        -0.35,
    );
    wall(
        commands,
        Vec2::new(-200.0, -120.0),
        Vec2::new(260.0, 16.0),
        0.35,
    );
    let (ball, rope) = wrecking_ball(commands);
    let boxes = box_stack(commands, Vec2::new(380.0, -295.0));
    let (capsule, cloth) = draped_cloth(commands, Vec2::new(60.0, -230.0));
    statics.push(capsule);
    let ragdolls = vec![
        spawn_ragdoll(commands, Vec3::new(-470.0, 140.0, 0.0), false),
        spawn_ragdoll(commands, Vec3::new(-380.0, 220.0, 0.0), true),
    ];
    AvianScene {
        statics,
        ball,
        rope,
        boxes,
        cloth,
        capsule,
        ragdolls,
    }
}

/// A 40 kg ball on a 20-link Verlet rope from a pin, pulled back to the left. The rope's last
/// particle is fixed to the ball's centre: the ball swings on the rope, the rope feels 40 kg.
fn wrecking_ball(commands: &mut Commands) -> (Entity, Composite) {
    let pin = Vec3::new(400.0, 250.0, 0.0);
    let start = Vec3::new(60.0, 150.0, 0.0);
    let ball = commands
        .spawn((
            RigidBody::Dynamic,
            Collider::circle(40.0),
            Mass(40.0),
            Transform::from_translation(start),
        ))
        .id();
    let rope = RopeBuilder::new(pin, start, 20)
        .mass(0.2)
        .radius(3.0)
        .pin_start()
        .spawn(commands);
    let end = *rope.particles.last().expect("a rope has particles");
    commands
        .entity(end)
        .insert(BodyAttachment::new(ball, Vec2::ZERO));
    (ball, rope)
}

/// Five rows of three 50 px, 2 kg avian boxes standing on the ground.
fn box_stack(commands: &mut Commands, base: Vec2) -> Vec<Entity> {
    let mut boxes = Vec::new();
    for row in 0..5 {
        for column in 0..3 {
            let at = base + Vec2::new(column as f32 * 52.0, row as f32 * 52.0 + 26.0);
            // 2 kg each (avian's default density would make a 50 px box 2500 "kg").
            let body = (
                RigidBody::Dynamic,
                Collider::rectangle(50.0, 50.0),
                Mass(2.0),
                Transform::from_translation(at.extend(0.0)),
            );
            boxes.push(commands.spawn(body).id());
        }
    }
    boxes
}

/// A capsule lying on the ground and a 24 × 4 cloth strip dropped over it.
fn draped_cloth(commands: &mut Commands, capsule: Vec2) -> (Entity, Composite) {
    let turn = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
    let body = (
        RigidBody::Static,
        Collider::capsule(40.0, 120.0),
        Transform::from_translation(capsule.extend(0.0)).with_rotation(turn),
    );
    let capsule_entity = commands.spawn(body).id();
    let cloth = ClothBuilder::new(
        capsule.extend(0.0) + Vec3::new(-120.0, 150.0, 0.0),
        24,
        4,
        10.0,
    )
    .radius(3.0)
    .spawn(commands);
    (capsule_entity, cloth)
}
