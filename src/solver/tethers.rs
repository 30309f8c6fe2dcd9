//! Long-range attachments ("tethers", Kim, Chentanez, Müller 2012).
//!
//! Each tethered particle gets a one-sided constraint `|x_i − x_pin| ≤ L` to its nearest pinned
//! particle, where `L` is the geodesic rest distance: the shortest path to the pin along sticks
//! that cannot stretch past their rest length (equal and at-most sticks), summed from their rest
//! lengths. The geodesic distance is an upper bound of any distance the real, inextensible
//! structure can reach, so a tether never pulls a particle the sticks would allow to go there; it
//! only removes the stretch that a budget-limited Gauss–Seidel solve leaves along long chains, at
//! one projection per particle and no extra iterations. Only the free particle moves.
//!
//! Tethers are derived from the topology: they are rebuilt whenever it changes, and after a
//! tear, so that a torn piece is not held across the tear.

use super::islands::next_stamp;
use super::shared::SharedSlice;
use super::{Particles, Pins, StickKind, Sticks};
use glam::DVec3;
use std::cmp::Ordering;
use std::collections::BinaryHeap;
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
#[derive(Clone, Debug, Default)]
pub struct Tethers {
    /// Tethered (free) particle (read with [`Tethers::particle`]).
    pub(crate) particle: Vec<u32>,
    /// Anchor (pinned) particle (read with [`Tethers::anchor`]).
    pub(crate) anchor: Vec<u32>,
    /// Largest allowed distance.
    pub max_length: Vec<f64>,
    // Scratch for the rebuild (kept to avoid reallocating).
    distance: Vec<f64>,
    source: Vec<u32>,
    adjacency_start: Vec<u32>,
    adjacency: Vec<(u32, f64)>,
    /// A stamp that changes with every change of `particle` or `anchor`.
    pub(crate) stamp: u64,
}

#[derive(PartialEq)]
struct Item(f64, u32);
impl Eq for Item {}
impl PartialOrd for Item {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Item {
    fn cmp(&self, other: &Self) -> Ordering {
        // Min-heap on distance, ties by index for determinism.
        other
            .0
            .total_cmp(&self.0)
            .then_with(|| other.1.cmp(&self.1))
    }
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

    /// Recomputes the tethers of every particle with `wanted[i] == true` to its geodesically
    /// nearest pin (multi-source Dijkstra over the non-torn equal and at-most sticks).
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
        // Compressed adjacency (CSR) of the sticks that bound distance.
        self.adjacency_start.clear();
        self.adjacency_start.resize(n + 1, 0);
        let bounds = |i: usize| matches!(sticks.kind[i], StickKind::Equal | StickKind::AtMost);
        for i in 0..sticks.len() {
            if bounds(i) {
                let [a, b] = sticks.ends[i];
                self.adjacency_start[a as usize + 1] += 1;
                self.adjacency_start[b as usize + 1] += 1;
            }
        }
        for i in 0..n {
            self.adjacency_start[i + 1] += self.adjacency_start[i];
        }
        self.adjacency.clear();
        self.adjacency
            .resize(self.adjacency_start[n] as usize, (0, 0.0));
        let mut fill: Vec<u32> = self.adjacency_start[..n].to_vec();
        for i in 0..sticks.len() {
            if bounds(i) {
                let [a, b] = sticks.ends[i];
                let rest = sticks.rest_length[i];
                self.adjacency[fill[a as usize] as usize] = (b, rest);
                fill[a as usize] += 1;
                self.adjacency[fill[b as usize] as usize] = (a, rest);
                fill[b as usize] += 1;
            }
        }
        self.distance.clear();
        self.distance.resize(n, f64::INFINITY);
        self.source.clear();
        self.source.resize(n, u32::MAX);
        let mut heap = BinaryHeap::new();
        for &p in &pins.particle {
            self.distance[p as usize] = 0.0;
            self.source[p as usize] = p;
            heap.push(Item(0.0, p));
        }
        while let Some(Item(d, i)) = heap.pop() {
            if d > self.distance[i as usize] {
                continue;
            }
            let range = self.adjacency_start[i as usize] as usize
                ..self.adjacency_start[i as usize + 1] as usize;
            for &(j, rest) in &self.adjacency[range] {
                let nd = d + rest;
                if nd < self.distance[j as usize] {
                    self.distance[j as usize] = nd;
                    self.source[j as usize] = self.source[i as usize];
                    heap.push(Item(nd, j));
                }
            }
        }
        for (i, &wants) in wanted.iter().enumerate().take(n) {
            let reachable = self.distance[i].is_finite() && self.source[i] != i as u32;
            if wants && reachable && particles.inverse_mass[i] > 0.0 {
                self.particle.push(i as u32);
                self.anchor.push(self.source[i]);
                self.max_length.push(self.distance[i]);
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
    for i in range {
        let (p, a) = (tethers.particle[i] as usize, tethers.anchor[i] as usize);
        if inverse_mass[p] <= 0.0 {
            continue; // grabbed or pinned since the tethers were built
        }
        let max = tethers.max_length[i];
        // SAFETY: this task alone accesses the particle and its anchor (caller).
        unsafe {
            let anchor = position.get(a);
            let delta: DVec3 = position.get(p) - anchor;
            let length_squared = delta.length_squared();
            if length_squared > max * max {
                position.set(p, anchor + delta * (max / length_squared.sqrt()));
            }
        }
    }
}
