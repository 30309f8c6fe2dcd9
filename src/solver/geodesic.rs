//! The `k` nearest pins of every particle by geodesic distance along the sticks, kept up to date
//! across tears without searching again from scratch.
//!
//! # Search
//! One Dijkstra from every pin at once that keeps, per particle, a list of at most `k` labels
//! `(pin, distance)` with distinct pins, sorted by distance (the k-nearest-facility search). A
//! candidate enters a particle's list only if it is strictly shorter than the list's worst entry
//! (or a shorter path to a pin already listed): a pin that is not among a particle's `k`
//! nearest cannot be among the `k` nearest of the particles beyond it along that path either.
//! Paths do not run through pins (from a pin, its own label at 0 is nearer). Equal and at-most
//! sticks bound the distance; torn sticks, struts and angle constraints do not.
//!
//! # Repair after tears
//! Every label remembers the particle and stick it came through: per pin, the labels form a
//! shortest-path tree. Tearing sticks only lengthens paths, so a label whose path avoids every
//! torn stick is still exact, and still among the particle's `k` nearest. The labels that came
//! along a torn stick are dropped, then, depth first along the sticks, every label that came
//! from a dropped one; the particles that lost labels are offered their neighbours' surviving
//! labels, and the Dijkstra runs again from there. Its cost is that of the region cut off, not
//! of the mesh (Ramalingam and Reps 1996 treat the general dynamic problem), plus one pass over
//! the sticks' kinds to find the torn ones. Any other
//! change since the last search (particles, pins, stick ends, kinds, rest lengths, `k`) searches
//! from scratch.

use super::{Pins, StickKind, Sticks};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// One entry of a particle's nearest-pin list.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Label {
    /// The pinned particle.
    pub pin: u32,
    /// Geodesic distance to it.
    pub distance: f64,
    /// The particle the path came through (`u32::MAX` for a pin's own label).
    via: u32,
    /// The stick it came along (`u32::MAX` for a pin's own label).
    stick: u32,
}

/// An unused slot.
const EMPTY: Label = Label {
    pin: u32::MAX,
    distance: f64::INFINITY,
    via: u32::MAX,
    stick: u32::MAX,
};

/// A stick of the distance graph, seen from one end.
#[derive(Clone, Copy, Debug)]
struct Edge {
    to: u32,
    stick: u32,
    rest: f64,
}

/// What the labels were computed for (anything but tears differing means a new search).
#[derive(Clone, Debug, Default)]
struct Key {
    particles: usize,
    k: usize,
    ends: u64,
    rest: Vec<f64>,
    kind: Vec<StickKind>,
    pins: Vec<u32>,
}

/// The `k` nearest pins of every particle (see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct NearestPins {
    k: usize,
    labels: Vec<Label>,
    heap: BinaryHeap<Item>,
    adjacency_start: Vec<u32>,
    adjacency: Vec<Edge>,
    key: Option<Key>,
    /// Particles that lost labels in a repair.
    affected: Vec<u32>,
    /// Dropped labels (particle, pin) whose descendants are still to drop.
    dropped: Vec<(u32, u32)>,
}

/// A Dijkstra queue entry: distance, particle, the pin it comes from.
#[derive(Clone, Debug, PartialEq)]
struct Item(f64, u32, u32);
impl Eq for Item {}
impl PartialOrd for Item {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Item {
    fn cmp(&self, other: &Self) -> Ordering {
        // Min-heap on distance, ties by particle then pin for determinism.
        other
            .0
            .total_cmp(&self.0)
            .then_with(|| other.1.cmp(&self.1))
            .then_with(|| other.2.cmp(&self.2))
    }
}

impl NearestPins {
    /// Brings the lists up to date for `n` particles and `k` pins each: a repair when only
    /// tears happened since the last call, a search from scratch otherwise. Returns `true` for a
    /// repair.
    pub fn update(&mut self, sticks: &Sticks, pins: &Pins, n: usize, k: usize) -> bool {
        let repair = self.only_tears_since(sticks, pins, n, k);
        if repair {
            self.repair(sticks);
            if let Some(key) = &mut self.key {
                key.kind.clone_from(&sticks.kind); // (all else is as it was)
            }
        } else {
            self.search(sticks, pins, n, k);
            self.remember(sticks, pins, n, k);
        }
        repair
    }

    /// Particle `i`'s nearest pins, nearest first.
    pub fn of(&self, i: usize) -> impl Iterator<Item = &Label> {
        let k = self.k;
        self.labels[i * k..][..k]
            .iter()
            .take_while(|l| l.pin != u32::MAX)
    }

    /// `true` when the last search describes this topology but for sticks torn since.
    fn only_tears_since(&self, sticks: &Sticks, pins: &Pins, n: usize, k: usize) -> bool {
        let Some(key) = &self.key else { return false };
        let kinds_kept = key.kind.len() == sticks.kind.len()
            && key
                .kind
                .iter()
                .zip(&sticks.kind)
                .all(|(&was, &is)| was == is || is == StickKind::Torn);
        key.particles == n
            && key.k == k
            && key.ends == sticks.stamp
            && key.pins == pins.particle
            && key.rest == sticks.rest_length
            && kinds_kept
    }

    fn remember(&mut self, sticks: &Sticks, pins: &Pins, n: usize, k: usize) {
        let key = self.key.get_or_insert_with(Key::default);
        key.particles = n;
        key.k = k;
        key.ends = sticks.stamp;
        key.rest.clone_from(&sticks.rest_length);
        key.kind.clone_from(&sticks.kind);
        key.pins.clone_from(&pins.particle);
    }

    /// A search from scratch.
    fn search(&mut self, sticks: &Sticks, pins: &Pins, n: usize, k: usize) {
        self.k = k;
        self.build_adjacency(sticks, n);
        self.labels.clear();
        self.labels.resize(n * k, EMPTY);
        self.heap.clear();
        for &p in &pins.particle {
            let own = Label {
                pin: p,
                distance: 0.0,
                ..EMPTY
            };
            if (p as usize) < n && offer(self.list_mut(p), own) {
                self.heap.push(Item(0.0, p, p));
            }
        }
        self.run(sticks);
    }

    /// Drops the labels whose path crosses a stick torn since the last update and finds their
    /// replacements.
    fn repair(&mut self, sticks: &Sticks) {
        self.affected.clear();
        self.dropped.clear();
        let before = self.key.as_ref().map_or(&[][..], |key| &key.kind[..]);
        let newly_torn =
            |s: &usize| before[*s] != StickKind::Torn && sticks.kind[*s] == StickKind::Torn;
        let n = self.adjacency_start.len().saturating_sub(1);
        for stick in (0..sticks.len()).filter(newly_torn) {
            // (A stick whose ends are not particles was never in the graph.)
            for end in sticks.ends()[stick]
                .into_iter()
                .filter(|&p| (p as usize) < n)
            {
                for j in 0..self.k {
                    let slot = end as usize * self.k + j;
                    if self.labels[slot].stick == stick as u32
                        && self.labels[slot].distance.is_finite()
                    {
                        self.labels[slot].distance = f64::INFINITY;
                        self.dropped.push((end, self.labels[slot].pin));
                    }
                }
            }
        }
        while let Some((i, pin)) = self.dropped.pop() {
            self.affected.push(i);
            let edges = self.adjacency_start[i as usize] as usize
                ..self.adjacency_start[i as usize + 1] as usize;
            for e in edges {
                let edge = self.adjacency[e];
                let child = self.slot(edge.to, pin).filter(|&c| {
                    let label = &self.labels[c];
                    label.via == i && label.stick == edge.stick && label.distance.is_finite()
                });
                if let Some(c) = child {
                    self.labels[c].distance = f64::INFINITY;
                    self.dropped.push((edge.to, pin));
                }
            }
        }
        self.affected.sort_unstable();
        self.affected.dedup();
        for a in 0..self.affected.len() {
            let list = self.list_mut(self.affected[a]);
            let mut write = 0;
            for read in 0..list.len() {
                if list[read].distance.is_finite() {
                    list[write] = list[read];
                    write += 1;
                }
            }
            list[write..].fill(EMPTY);
        }
        for a in 0..self.affected.len() {
            self.offer_neighbours(self.affected[a], sticks);
        }
        self.run(sticks);
    }

    /// Offers particle `i` every surviving label of its neighbours.
    fn offer_neighbours(&mut self, i: u32, sticks: &Sticks) {
        let edges = self.adjacency_start[i as usize] as usize
            ..self.adjacency_start[i as usize + 1] as usize;
        for e in edges {
            let edge = self.adjacency[e];
            if sticks.kind[edge.stick as usize] == StickKind::Torn {
                continue;
            }
            for j in 0..self.k {
                let from = self.labels[edge.to as usize * self.k + j];
                if from.pin == u32::MAX {
                    break;
                }
                let candidate = Label {
                    pin: from.pin,
                    distance: from.distance + edge.rest,
                    via: edge.to,
                    stick: edge.stick,
                };
                if offer(self.list_mut(i), candidate) {
                    self.heap.push(Item(candidate.distance, i, candidate.pin));
                }
            }
        }
    }

    /// The Dijkstra loop: settles queued labels and offers them on along the sticks.
    fn run(&mut self, sticks: &Sticks) {
        while let Some(Item(d, i, pin)) = self.heap.pop() {
            let node = i as usize;
            let current = self.labels[node * self.k..][..self.k]
                .iter()
                .any(|l| l.pin == pin && l.distance == d);
            if !current {
                continue; // superseded by a shorter path or by nearer pins
            }
            let edges =
                self.adjacency_start[node] as usize..self.adjacency_start[node + 1] as usize;
            for e in edges {
                let edge = self.adjacency[e];
                if sticks.kind[edge.stick as usize] == StickKind::Torn {
                    continue;
                }
                let list = self.list_mut(edge.to);
                if list[0].pin == edge.to && list[0].distance == 0.0 {
                    continue; // a pin: paths through it are no shorter than from it
                }
                let candidate = Label {
                    pin,
                    distance: d + edge.rest,
                    via: i,
                    stick: edge.stick,
                };
                if offer(list, candidate) {
                    self.heap.push(Item(candidate.distance, edge.to, pin));
                }
            }
        }
    }

    /// The compressed adjacency (CSR) of the sticks that bound distance.
    fn build_adjacency(&mut self, sticks: &Sticks, n: usize) {
        self.adjacency_start.clear();
        self.adjacency_start.resize(n + 1, 0);
        let bounds = |i: usize| matches!(sticks.kind[i], StickKind::Equal | StickKind::AtMost);
        let ends = sticks.ends();
        let in_range = |i: usize| ends[i].iter().all(|&p| (p as usize) < n);
        for i in (0..sticks.len()).filter(|&i| bounds(i) && in_range(i)) {
            for p in ends[i] {
                self.adjacency_start[p as usize + 1] += 1;
            }
        }
        for i in 0..n {
            self.adjacency_start[i + 1] += self.adjacency_start[i];
        }
        let unused = Edge {
            to: 0,
            stick: 0,
            rest: 0.0,
        };
        self.adjacency.clear();
        self.adjacency
            .resize(self.adjacency_start[n] as usize, unused);
        let mut fill: Vec<u32> = self.adjacency_start[..n].to_vec();
        for i in (0..sticks.len()).filter(|&i| bounds(i) && in_range(i)) {
            let [a, b] = ends[i];
            let rest = sticks.rest_length[i];
            for (from, to) in [(a, b), (b, a)] {
                let edge = Edge {
                    to,
                    stick: i as u32,
                    rest,
                };
                self.adjacency[fill[from as usize] as usize] = edge;
                fill[from as usize] += 1;
            }
        }
    }

    fn list_mut(&mut self, i: u32) -> &mut [Label] {
        &mut self.labels[i as usize * self.k..][..self.k]
    }

    /// Where particle `i`'s label for `pin` is, if it has one.
    fn slot(&self, i: u32, pin: u32) -> Option<usize> {
        let start = i as usize * self.k;
        self.labels[start..start + self.k]
            .iter()
            .position(|l| l.pin == pin)
            .map(|j| start + j)
    }
}

/// Offers a label to a particle's list (sorted by distance, distinct pins): `true` if it entered
/// (as a new pin or a shorter path to a listed one). Strictly shorter only: of pins at equal
/// distance the one that got there first stays.
fn offer(list: &mut [Label], label: Label) -> bool {
    let before = |l: &Label| label.distance < l.distance;
    let from = match list.iter().position(|l| l.pin == label.pin) {
        Some(i) if list[i].distance <= label.distance => return false,
        Some(i) => i, // the old entry goes; everything after it moves up
        None if !before(&list[list.len() - 1]) => return false,
        None => list.len() - 1, // the worst entry drops out
    };
    let to = list[..from].iter().position(before).unwrap_or(from);
    list.copy_within(to..from, to + 1);
    list[to] = label;
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `side × side` grid with rest lengths that make ties unlikely, pinned at `pins`.
    fn grid(side: usize, pins: &[u32]) -> (Sticks, Pins) {
        let mut sticks = Sticks::default();
        let rest = |i: usize| 1.0 + ((i * 7919) % 101) as f64 * 1e-3 + (i as f64).sqrt() * 1e-7;
        for r in 0..side {
            for c in 0..side {
                let i = (r * side + c) as u32;
                if c + 1 < side {
                    let s = sticks.len();
                    sticks.push([i, i + 1], rest(s), 0.0, StickKind::Equal, 1.0, 0);
                }
                if r + 1 < side {
                    let s = sticks.len();
                    let ends = [i, i + side as u32];
                    sticks.push(ends, rest(s), 0.0, StickKind::Equal, 1.0, 0);
                }
            }
        }
        let mut pin_set = Pins::default();
        for &p in pins {
            pin_set.push(p, glam::DVec3::ZERO);
        }
        (sticks, pin_set)
    }

    fn lists(search: &NearestPins, n: usize) -> Vec<Vec<(u32, f64)>> {
        (0..n)
            .map(|i| search.of(i).map(|l| (l.pin, l.distance)).collect())
            .collect()
    }

    #[test]
    fn repairs_after_tears_match_a_search_from_scratch() {
        let side = 24;
        let n = side * side;
        for k in [1, 2, 3] {
            let (mut sticks, pins) = grid(side, &[0, 23, 300, 575]);
            let mut kept = NearestPins::default();
            assert!(!kept.update(&sticks, &pins, n, k), "first: a search");
            // Rounds of tears: a wall across the middle with a gap, then scattered sticks.
            let rounds: [Vec<usize>; 3] = [
                (0..side - 3).map(|c| 2 * (side * 12 + c) + 1).collect(),
                (0..40).map(|i| (i * 37) % sticks.len()).collect(),
                (0..200).map(|i| (i * 13 + 5) % sticks.len()).collect(),
            ];
            for round in rounds {
                for s in round {
                    sticks.kind[s] = StickKind::Torn;
                }
                assert!(kept.update(&sticks, &pins, n, k), "tears only: a repair");
                let mut fresh = NearestPins::default();
                fresh.update(&sticks, &pins, n, k);
                let (repaired, searched) = (lists(&kept, n), lists(&fresh, n));
                let first_difference = (0..n).find(|&i| repaired[i] != searched[i]);
                assert_eq!(first_difference, None, "k = {k}");
            }
            // Anything else (a rest length) searches again.
            sticks.rest_length[0] *= 2.0;
            assert!(!kept.update(&sticks, &pins, n, k));
        }
    }
}
