//! Verlet particle physics for Bevy.
pub mod solver;
