//! Messages the plugin sends.

use bevy::prelude::*;

/// Sent once for every stick that tears.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// fn report(mut torn: MessageReader<StickTorn>) {
///     for tear in torn.read() {
///         info!("stick {} tore at {}", tear.stick, tear.position);
///     }
/// }
/// # bevy::ecs::system::assert_is_system(report);
/// ```
#[derive(Message, Clone, Copy, Debug, PartialEq)]
pub struct StickTorn {
    /// The stick entity (despawned, or stripped of its `Stick`, by the time you read this).
    pub stick: Entity,
    /// Its two particles.
    pub particles: [Entity; 2],
    /// Midpoint of the stick when it tore.
    pub position: Vec3,
    /// Its strain when it tore.
    pub strain: f32,
}
