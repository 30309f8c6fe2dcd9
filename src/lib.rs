//! Verlet particle physics for Bevy: particles, sticks (distance constraints) and pins for
//! ropes, tearable cloth, ragdolls and stick structures.
//!
//! Add [`VerletPlugin`], spawn [`Particle`]s, [`Stick`]s between them and [`Pin`]s — or a whole
//! rope or cloth with one call from [`builders`] — and add [`VerletDebugPlugin`] (feature
//! `gizmos`, on by default) to see them drawn with gizmo lines.
//!
//! ```
//! use bevy::prelude::*;
//! use bevy_verlet_physics::prelude::*;
//!
//! let mut app = App::new();
//! app.add_plugins((MinimalPlugins, VerletPlugin::default()));
//! // A 20-link rope from (0, 2) to (2, 2), pinned at its first end.
//! let rope = RopeBuilder::new(Vec3::new(0.0, 2.0, 0.0), Vec3::new(2.0, 2.0, 0.0), 20)
//!     .pin_start()
//!     .spawn(&mut app.world_mut().commands());
//! app.world_mut().flush();
//! for _ in 0..10 {
//!     app.update();
//! }
//! ```
//!
//! The crate is two layers: [`solver`], a Bevy-free core of dense `f64` arrays and plain
//! functions (integrate, relax, constrain, tear), and the Bevy layer — components, the plugin,
//! rendering and builders — which gathers component changes into the core each fixed step and
//! scatters positions back once.
//!
//! With the features `avian2d` / `avian3d` (off by default), the modules `avian2d` / `avian3d`
//! couple the particles with the avian physics engine both ways: particles collide with avian
//! colliders and push dynamic bodies, and particles attached to bodies pull on them.
#![warn(missing_docs)]

#[cfg(feature = "avian2d")]
pub mod avian2d;
#[cfg(feature = "avian3d")]
pub mod avian3d;
pub mod builders;
#[cfg(feature = "gizmos")]
mod cloth_mesh;
mod collider;
mod config;
#[cfg(feature = "gizmos")]
mod debug_render;
mod executor;
#[cfg(feature = "gizmos")]
pub mod interaction;
mod island;
mod messages;
mod particle;
mod pin;
mod plugin;
pub mod scenes;
pub mod solver;
mod state;
mod stick;
mod systems;
mod transform_sync;

pub use builders::{
    ClothBuilder, Composite, HiddenStick, RagdollBuilder, RopeBuilder, StructureBuilder,
};
#[cfg(feature = "gizmos")]
pub use cloth_mesh::ClothMesh;
pub use collider::{ColliderShape, VerletCollider};
pub use config::{Gravity, Sleeping, SolveMethod, VerletConfig, VerletStats};
#[cfg(feature = "gizmos")]
pub use debug_render::{DebugColor, VerletDebugConfig, VerletDebugPlugin, VerletGizmos};
pub use executor::TaskPoolExecutor;
#[cfg(feature = "gizmos")]
pub use interaction::{ResetRequested, VerletInteraction, VerletInteractionPlugin};
pub use island::IslandOverride;
pub use messages::StickTorn;
pub use particle::{Particle, Tethered};
pub use pin::{Pin, PinTarget};
pub use plugin::{
    VerletPlugin, VerletSchedule, VerletSubstepSystems, VerletSubsteps, VerletSystems,
};
pub use solver::StickKind;
pub use state::VerletState;
pub use stick::{AngleConstraint, Stick, Stiffness};
pub use transform_sync::{FollowParticle, FollowStick};

/// Everything a game usually needs.
pub mod prelude {
    pub use crate::builders::{
        ClothBuilder, Composite, HiddenStick, RagdollBuilder, RopeBuilder, StructureBuilder,
    };
    pub use crate::{
        AngleConstraint, ColliderShape, FollowParticle, FollowStick, Gravity, IslandOverride,
        Particle, Pin, PinTarget, Sleeping, SolveMethod, Stick, StickKind, StickTorn, Stiffness,
        Tethered, VerletCollider, VerletConfig, VerletPlugin, VerletSchedule, VerletState,
        VerletStats, VerletSubstepSystems, VerletSubsteps, VerletSystems,
    };
    #[cfg(feature = "gizmos")]
    pub use crate::{
        ClothMesh, DebugColor, ResetRequested, VerletDebugConfig, VerletDebugPlugin, VerletGizmos,
        VerletInteraction, VerletInteractionPlugin,
    };
}

/// The README's code blocks, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
