//! Long-range attachments ("tethers", Kim, Chentanez, Müller 2012).
//!
//! Each tethered particle gets one-sided constraints `|x_i − x_pin| ≤ L` to its nearest pinned
//! particles ([`Tethers::anchors`] of them, two by default), where `L` is the geodesic rest
//! distance: the shortest path to the pin along sticks that cannot stretch past their rest
//! length (equal and at-most sticks), summed from their rest lengths. The geodesic distance is an
//! upper bound of any distance the real, inextensible structure can reach, so a tether never
//! pulls a particle the sticks would allow to go there; it only removes the stretch that a budget-limited Gauss–Seidel solve leaves along long chains, at
//! one projection per tether and no extra iterations. Only the free particle moves.
//!
//! Why more than one pin: a tether only bounds the distance to its anchor, so a particle between
//! two pins (a cloth hung by its two top corners) tethered to the nearer one alone may still
//! swing out towards the other side — the far corner's load then stretches the cloth as if there
//! were no tethers. Bounded by both, it sits in the lens where the two spheres meet. Measured
//! (`tests/hard_cases.rs`, 100 × 100 cloth hung by its two top corners, 8 × 1): see the crate
//! README. The nearest `k` pins of every particle come from one Dijkstra (see
//! [`geodesic`](super::geodesic), which also repairs them after tears). A further pin seen
//! within 30° of a nearer anchor (from where the particle is at the rebuild) gets no tether:
//! along a pinned top row the next pin adds almost nothing but cost.
//!
//! Tethers are derived from the topology: they are rebuilt whenever it changes, and after a
//! tear, so that a torn piece is not held across the tear.

use super::geodesic::NearestPins;
use super::islands::next_stamp;
use super::shared::SharedSlice;
use super::{Particles, Pins, Sticks};
use glam::DVec3;
use std::ops::Range;

/// One-sided maximum-distance constraints from particles to pinned anchors.
///
/// ```
/// use bevy_verlet_physics::solver::{Particles, Pins, Sticks, StickKind, Tethers};
/// use glam::DVec3;
/// let mut p = Particles::default();
/// for i in 0..3 { p.push(DVec3::X * i as f64, DVec3::X * i as f64, if i == 0 { 0.0 } else { 1.0 }, 0.0, i); }
/// let mut s = Sticks::default();
/// s.push([0, 1], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
/// s.push([1, 2], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 1);
/// let mut pins = Pins::default();
/// pins.push(0, DVec3::ZERO);
/// let mut tethers = Tethers::default();
/// tethers.rebuild(&p, &s, &pins, &[false, true, true]);
/// assert_eq!(tethers.max_length, vec![1.0, 2.0]);
/// ```
#[derive(Clone, Debug)]
pub struct Tethers {
    /// Tethered (free) particle (read with [`Tethers::particle`]).
    pub(crate) particle: Vec<u32>,
    /// Anchor (pinned) particle (read with [`Tethers::anchor`]).
    pub(crate) anchor: Vec<u32>,
    /// Largest allowed distance.
    pub max_length: Vec<f64>,
    /// How many of its nearest pins each tethered particle is tethered to (clamped to
    /// `1..=`[`MAX_TETHER_ANCHORS`]; applied by the next [`Tethers::rebuild`]). Default 2 (see [`DEFAULT_TETHER_ANCHORS`]).
    pub anchors: usize,
    /// The nearest pins of every particle, kept to repair after tears.
    search: NearestPins,
    /// A stamp that changes with every change of `particle` or `anchor`.
    pub(crate) stamp: u64,
}

impl Default for Tethers {
    fn default() -> Self {
        Self {
            particle: Vec::new(),
            anchor: Vec::new(),
            max_length: Vec::new(),
            anchors: DEFAULT_TETHER_ANCHORS,
            search: NearestPins::default(),
            stamp: 0,
        }
    }
}

/// The most pins a particle is tethered to ([`Tethers::anchors`] is clamped to `1..=` this).
///
/// ```
/// use bevy_verlet_physics::solver::{Tethers, MAX_TETHER_ANCHORS};
/// assert!(Tethers::default().anchors <= MAX_TETHER_ANCHORS);
/// ```
pub const MAX_TETHER_ANCHORS: usize = 8;

/// Pins per tethered particle unless [`Tethers::anchors`] says otherwise.
///
/// ```
/// use bevy_verlet_physics::solver::{Tethers, DEFAULT_TETHER_ANCHORS};
/// assert_eq!(Tethers::default().anchors, DEFAULT_TETHER_ANCHORS);
/// ```
pub const DEFAULT_TETHER_ANCHORS: usize = 2;

/// `true` when pins `a` and `b` are seen from `x` within 30° of each other: a tether to the
/// farther one then adds little to the nearer one's (the next pin along a pinned top row), so it
/// is not made.
fn same_side(x: DVec3, a: DVec3, b: DVec3) -> bool {
    let (to_a, to_b) = (a - x, b - x);
    let dot = to_a.dot(to_b);
    // cos∠ > cos 30°, squared (no square roots): cos² 30° = 3/4.
    dot > 0.0 && dot * dot > 0.75 * to_a.length_squared() * to_b.length_squared()
}

impl Tethers {
    /// Number of tethers.
    pub fn len(&self) -> usize {
        self.particle.len()
    }

    /// `true` when there are no tethers.
    pub fn is_empty(&self) -> bool {
        self.particle.is_empty()
    }

    /// The tethered (free) particle of every tether.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Tethers;
    /// assert!(Tethers::default().particle().is_empty());
    /// ```
    pub fn particle(&self) -> &[u32] {
        &self.particle
    }

    /// The anchor (pinned) particle of every tether.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::Tethers;
    /// assert!(Tethers::default().anchor().is_empty());
    /// ```
    pub fn anchor(&self) -> &[u32] {
        &self.anchor
    }

    /// Removes every tether.
    pub fn clear(&mut self) {
        self.stamp = next_stamp();
        self.particle.clear();
        self.anchor.clear();
        self.max_length.clear();
    }

    /// Recomputes the tethers of every particle with `wanted[i] == true` to its
    /// [`Tethers::anchors`] geodesically nearest pins (Dijkstra over the non-torn equal and
    /// at-most sticks; after tears only, the last search is repaired instead: see
    /// [`geodesic`](super::geodesic)). A particle's tethers are listed together, nearest pin
    /// first.
    pub fn rebuild(
        &mut self,
        particles: &Particles,
        sticks: &Sticks,
        pins: &Pins,
        wanted: &[bool],
    ) {
        self.clear();
        let n = particles.len();
        if pins.is_empty() || !wanted.iter().any(|&w| w) {
            return;
        }
        let k = self.anchors.clamp(1, MAX_TETHER_ANCHORS);
        self.search.update(sticks, pins, n, k);
        let position = &particles.position;
        for (i, &wants) in wanted.iter().enumerate().take(n) {
            if !wants || particles.inverse_mass[i] <= 0.0 {
                continue;
            }
            let first = self.particle.len();
            for label in self.search.of(i) {
                let pin = label.pin;
                let redundant = self.anchor[first..]
                    .iter()
                    .any(|&a| same_side(position[i], position[a as usize], position[pin as usize]));
                if pin != i as u32 && !redundant {
                    self.particle.push(i as u32);
                    self.anchor.push(pin);
                    self.max_length.push(label.distance);
                }
            }
        }
    }
}

/// Projects every tether once: a particle farther than its tether's length from its anchor is
/// moved back onto the sphere around the anchor.
pub fn relax_tethers(particles: &mut Particles, tethers: &Tethers) {
    // SAFETY: the positions are borrowed exclusively here; nothing else can access them.
    unsafe {
        relax_tether_range(
            &SharedSlice::new(&mut particles.position),
            &particles.inverse_mass,
            tethers,
            0..tethers.len(),
        );
    }
}

/// [`relax_tethers`] over the tethers in `range`.
///
/// # Safety
/// No other task accesses the particles or anchors of these tethers while this runs.
pub(crate) unsafe fn relax_tether_range(
    position: &SharedSlice<DVec3>,
    inverse_mass: &[f64],
    tethers: &Tethers,
    range: Range<usize>,
) {
    // The current particle and its first (nearest) tether.
    let (mut current, mut nearest) = (u32::MAX, range.start);
    for i in range {
        if tethers.particle[i] != current {
            (current, nearest) = (tethers.particle[i], i);
        }
        let (p, a) = (current as usize, tethers.anchor[i] as usize);
        if inverse_mass[p] <= 0.0 {
            continue; // grabbed or pinned since the tethers were built
        }
        let max = tethers.max_length[i];
        // SAFETY: this task alone accesses the particle and its anchors (caller).
        unsafe {
            let anchor = position.get(a);
            if nearest != i {
                // A further anchor of the same particle: when the pins have been pulled apart
                // so far that no point is within reach of both it and the nearest, the nearest
                // alone holds (two tethers pulling against each other would spread the pull
                // over the whole cloth instead of letting it tear where it is pulled).
                let nearer = position.get(tethers.anchor[nearest] as usize);
                let reach = max + tethers.max_length[nearest];
                if (anchor - nearer).length_squared() > reach * reach {
                    continue;
                }
            }
            let delta: DVec3 = position.get(p) - anchor;
            let length_squared = delta.length_squared();
            if length_squared > max * max {
                position.set(p, anchor + delta * (max / length_squared.sqrt()));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::StickKind;

    /// A straight chain of `n` particles 1 apart, pinned at the given indices, all tethered.
    fn chain(n: usize, pinned: &[usize], anchors: usize) -> Tethers {
        let mut particles = Particles::default();
        let mut sticks = Sticks::default();
        let mut pins = Pins::default();
        for i in 0..n {
            let x = DVec3::X * i as f64;
            let w = if pinned.contains(&i) { 0.0 } else { 1.0 };
            particles.push(x, x, w, 0.0, i as u64);
            if i > 0 {
                let ends = [i as u32 - 1, i as u32];
                sticks.push(ends, 1.0, 0.0, StickKind::Equal, f64::INFINITY, i as u64);
            }
        }
        for &p in pinned {
            pins.push(p as u32, DVec3::X * p as f64);
        }
        let mut tethers = Tethers {
            anchors,
            ..Tethers::default()
        };
        tethers.rebuild(&particles, &sticks, &pins, &vec![true; n]);
        tethers
    }

    fn listed(t: &Tethers) -> Vec<(u32, u32, f64)> {
        (0..t.len())
            .map(|i| (t.particle[i], t.anchor[i], t.max_length[i]))
            .collect()
    }

    #[test]
    fn every_particle_is_tethered_to_its_nearest_pins_nearest_first() {
        // Pins at 0, 4 and 9: particle 2 is 2 from pin 0, 2 from pin 4 (tie: lower pin
        // first), 7 from pin 9.
        let two = listed(&chain(10, &[0, 4, 9], 2));
        let of = |p: u32| two.iter().filter(|t| t.0 == p).copied().collect::<Vec<_>>();
        assert_eq!(of(2), vec![(2, 0, 2.0), (2, 4, 2.0)]);
        assert_eq!(of(6), vec![(6, 4, 2.0), (6, 9, 3.0)]);
        // Through a pin: particle 1's second-nearest pin is 4, at 3 (past pin 0 is nothing).
        assert_eq!(of(1), vec![(1, 0, 1.0), (1, 4, 3.0)]);
        // Pins get no tethers; every free particle gets two.
        assert_eq!(two.len(), 2 * 7);
        // One anchor: the nearest only.
        let one = listed(&chain(10, &[0, 4, 9], 1));
        assert_eq!(one.len(), 7);
        assert!(one.contains(&(8, 9, 1.0)));
        // Three: pin 9 is reached through pin 4, but from particle 1 it lies beyond pin 4, in
        // the same direction: no tether. Every free particle lies between two pins here.
        let three = listed(&chain(10, &[0, 4, 9], 3));
        assert!(!three.iter().any(|t| t.0 == 1 && t.1 == 9));
        assert_eq!(three, two);
    }

    #[test]
    fn a_single_pin_gives_one_tether_whatever_the_anchor_count() {
        assert_eq!(listed(&chain(4, &[0], 2)), listed(&chain(4, &[0], 1)));
        assert_eq!(chain(4, &[0], 3).len(), 3);
    }

    #[test]
    fn pins_pulled_out_of_reach_leave_the_nearest_tether_alone() {
        let mut particles = Particles::default();
        let mut sticks = Sticks::default();
        let mut pins = Pins::default();
        for i in 0..3 {
            let x = DVec3::X * i as f64;
            particles.push(x, x, if i == 1 { 1.0 } else { 0.0 }, 0.0, i);
        }
        sticks.push([0, 1], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
        sticks.push([1, 2], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 1);
        pins.push(0, DVec3::ZERO);
        pins.push(2, DVec3::X * 2.0);
        let mut tethers = Tethers {
            anchors: 2,
            ..Tethers::default()
        };
        tethers.rebuild(&particles, &sticks, &pins, &[false, true, false]);
        assert_eq!(listed(&tethers), vec![(1, 0, 1.0), (1, 2, 1.0)]);
        // Within reach of both: both act (the far pin's tether, projected last, holds).
        particles.position[1] = DVec3::new(1.0, 3.0, 0.0);
        relax_tethers(&mut particles, &tethers);
        let x = particles.position[1];
        assert!((x - DVec3::X * 2.0).length() <= 1.0 + 1e-12, "{x}");
        assert!(x.x > 1.0, "{x}"); // the nearest tether alone leaves it at x = 0.32
        // The far pin dragged 5 away: the nearest tether alone pulls the particle back.
        particles.position[2] = DVec3::X * 5.0;
        particles.position[1] = DVec3::X * 3.0;
        relax_tethers(&mut particles, &tethers);
        assert_eq!(particles.position[1], DVec3::X);
    }
}
