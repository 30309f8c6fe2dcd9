//! Tearing on post-solve strain.
//!
//! After all substeps of a fixed step, a stick whose strain `length / rest − 1` exceeds its tear
//! strain is marked torn. The seeds test the length *before* the correction instead, which makes
//! tearing measure the solver's budget (a 10 % threshold tears a whole curtain on its first step
//! at 60 Hz, because gravity alone predicts 13.6 % stretch) rather than the material.

use super::{Particles, StickKind, Sticks};

/// Marks every tearable stick strained past its threshold as [`StickKind::Torn`], appends its
/// index to `torn` and drops it from [`Sticks::tearable`]. Returns how many tore.
///
/// ```
/// use bevy_verlet_physics::solver::{tear, Particles, Sticks, StickKind};
/// use glam::DVec3;
/// let mut p = Particles::default();
/// p.push(DVec3::ZERO, DVec3::ZERO, 1.0, 0.0, 0);
/// p.push(DVec3::X * 3.0, DVec3::X * 3.0, 1.0, 0.0, 1);
/// let mut s = Sticks::default();
/// s.push([0, 1], 1.0, 0.0, StickKind::Equal, 1.5, 0); // tears past 2.5× its length
/// let mut torn = Vec::new();
/// assert_eq!(tear(&p, &mut s, &mut torn), 1);
/// assert_eq!(s.kind[0], StickKind::Torn);
/// ```
pub fn tear(particles: &Particles, sticks: &mut Sticks, torn: &mut Vec<u32>) -> usize {
    let before = torn.len();
    let Sticks {
        ends,
        rest_length,
        tearable,
        kind,
        tear_strain,
        ..
    } = sticks;
    let mut i = 0;
    while i < tearable.len() {
        let s = tearable[i] as usize;
        let [a, b] = ends[s];
        let rest = rest_length[s];
        let length = (particles.position[a as usize] - particles.position[b as usize]).length();
        // A zero rest length has no strain: such sticks never tear.
        let strain = if rest > 0.0 { length / rest - 1.0 } else { 0.0 };
        // A NaN strain never tears (it is not greater than anything); inputs are sanitised upstream.
        if kind[s] == StickKind::Torn {
            // Cut since the last pass (`Solver::cut`).
            tearable.swap_remove(i);
        } else if strain > tear_strain[s] {
            kind[s] = StickKind::Torn;
            torn.push(s as u32);
            tearable.swap_remove(i);
        } else {
            i += 1;
        }
    }
    torn.len() - before
}

impl super::Solver {
    /// Cuts stick `i` in place, as a tear would: it becomes [`StickKind::Torn`] (skipped by every
    /// sweep and line), its island wakes, and tethers, if there are any, are rebuilt when the
    /// next step begins (once for all the cuts before it) — no topology rebuild. Returns
    /// `false` for an unknown or already torn stick.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{Solver, StickKind};
    /// use glam::DVec3;
    /// let mut solver = Solver::default();
    /// solver.add_particle(DVec3::ZERO, 1.0);
    /// solver.add_particle(DVec3::X, 1.0);
    /// solver.sticks.push([0, 1], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
    /// assert!(solver.cut(0));
    /// assert_eq!(solver.sticks.kind[0], StickKind::Torn);
    /// assert!(!solver.cut(0));
    /// ```
    pub fn cut(&mut self, i: usize) -> bool {
        if self
            .sticks
            .kind
            .get(i)
            .is_none_or(|&k| k == StickKind::Torn)
        {
            return false;
        }
        // (`tearable` keeps it until the next tear pass drops it: no O(sticks) search per cut.)
        self.sticks.kind[i] = StickKind::Torn;
        // Torn sticks must be skipped: no batch is known all-rigid any more.
        for batch in &mut self.islands.batches.0 {
            batch.rigid = false;
        }
        self.wake_requests.push(self.sticks.ends[i][0]);
        // Once before the next step, however many sticks are cut before it.
        self.tethers_stale |= !self.tethers.is_empty();
        true
    }
}
