//! Attach sprites and meshes to the simulation: copy interpolated particle and stick poses into
//! `Transform`s every frame.
//!
//! A particle entity that has a `Transform` gets its translation written every frame,
//! interpolated between fixed steps (as avian writes its bodies' `Transform`s), so
//! `(Particle, Sprite)` or `(Particle, Mesh3d)` — both require a `Transform` — just works.
//! Particles without a `Transform` cost nothing here: the query matches none of them.

use crate::{Particle, VerletConfig};
use bevy::prelude::*;

/// Makes an entity's `Transform` follow a particle (interpolated between fixed steps).
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut world = World::new();
/// let particle = world.spawn(Particle::new(Vec3::ZERO)).id();
/// world.spawn((FollowParticle(particle), Transform::default()));
/// ```
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Debug)]
pub struct FollowParticle(pub Entity);

/// Makes an entity's `Transform` follow a stick: translation at the stick's midpoint, local
/// +X along the stick from `a` to `b` (so a sprite drawn along X becomes a limb), and, if
/// `stretch` is set, X scaled by the stick's current length.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut world = World::new();
/// let a = world.spawn(Particle::new(Vec3::ZERO)).id();
/// let b = world.spawn(Particle::new(Vec3::X)).id();
/// world.spawn((FollowStick { a, b, stretch: false }, Transform::default()));
/// ```
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Debug)]
pub struct FollowStick {
    /// First particle.
    pub a: Entity,
    /// Second particle.
    pub b: Entity,
    /// Scale local X by the current length.
    pub stretch: bool,
}

/// Adds the `Transform` following for [`FollowParticle`] and [`FollowStick`] (part of
/// [`VerletPlugin`](crate::VerletPlugin)).
pub(crate) fn plugin(app: &mut App) {
    app.register_type::<FollowParticle>()
        .register_type::<FollowStick>()
        .add_systems(
            RunFixedMainLoop,
            follow.in_set(RunFixedMainLoopSystems::AfterFixedMainLoop),
        );
}

/// Particles whose `Transform` is synced: not followers themselves.
type NotFollowing = (Without<FollowParticle>, Without<FollowStick>);

fn follow(
    time: Res<Time<Fixed>>,
    config: Res<VerletConfig>,
    particles: Query<&Particle>,
    mut synced: Query<(&Particle, &mut Transform), NotFollowing>,
    mut followers: Query<(&FollowParticle, &mut Transform), Without<FollowStick>>,
    mut sticks: Query<(&FollowStick, &mut Transform), Without<FollowParticle>>,
) {
    let fraction = config.render_fraction(&time);
    for (particle, mut transform) in &mut synced {
        // (Written only when it changes: a resting particle does not re-propagate.)
        let translation = particle.interpolated(fraction);
        if transform.translation != translation {
            transform.translation = translation;
        }
    }
    for (follow, mut transform) in &mut followers {
        if let Ok(particle) = particles.get(follow.0) {
            transform.translation = particle.interpolated(fraction);
        }
    }
    for (follow, mut transform) in &mut sticks {
        let (Ok(a), Ok(b)) = (particles.get(follow.a), particles.get(follow.b)) else {
            continue;
        };
        let (a, b) = (a.interpolated(fraction), b.interpolated(fraction));
        let along = b - a;
        let Some(direction) = along.try_normalize() else {
            continue;
        };
        transform.translation = (a + b) * 0.5;
        transform.rotation = Quat::from_rotation_arc(Vec3::X, direction);
        if follow.stretch {
            transform.scale.x = along.length();
        }
    }
}
