//! A tree held by three or more immovable particles, split at them into independent trees.
//!
//! # Why
//! The elimination of [`tree`](super) closes one loop through the ground (a second immovable
//! particle, see [`closure`](super::closure)); a third one used to take the whole island back
//! to lines meeting at forks, coupled there by block Gauss–Seidel, which carries a load a stick
//! or two per pass: random trees with heavy loads pinned at three or four particles stretched
//! beyond 100 % in about a third of the scenes at 8 × 1 (see `tests/direct.rs`).
//!
//! # The split
//! An immovable particle moves nothing and is moved by nothing: the linearised system has no
//! coupling through it. Removing it from a tree cuts the tree into as many parts as it has
//! sticks, and the parts' systems are independent. So the island's movable particles are split
//! into the parts that their sticks connect without passing through an immovable particle,
//! and each part becomes a tree of its own: rooted at the immovable particle of its first
//! attachment (a stick from the part to an immovable particle), the second attachment's
//! immovable particle its closing node, further ones its extra closing nodes (see
//! [`closings`](super::closings)). Solved one after the other, the parts are solved exactly as
//! the whole would be. An immovable particle appears once per part it holds (a post with a
//! rope on either side roots both). Where a part hangs on more than [`MAX_CLOSINGS`] + 1
//! immovable particles, the island stays on lines.
//!
//! ```
//! use bevy_verlet_physics::solver::{Method, Solver, StepConfig, StickKind};
//! use glam::DVec3;
//! // A rope between two posts with a third post in the middle and a weighted branch on
//! // either side: two trees of two pins each.
//! let mut solver = Solver::default();
//! let mut particle = |x: f64, y: f64, w: f64| {
//!     let p = solver.add_particle(DVec3::new(x, y, 0.0), w);
//!     if w == 0.0 {
//!         solver.pin(p, DVec3::new(x, y, 0.0));
//!     }
//!     p
//! };
//! let ids: Vec<u32> = [
//!     (0.0, 0.0, 0.0), (1.0, -0.2, 1.0), (2.0, 0.0, 0.0), (3.0, -0.2, 1.0), (4.0, 0.0, 0.0),
//!     (1.0, -1.2, 0.01), (3.0, -1.2, 0.01),
//! ]
//! .into_iter()
//! .map(|(x, y, w)| particle(x, y, w))
//! .collect();
//! for [a, b] in [[0, 1], [1, 2], [2, 3], [3, 4], [1, 5], [3, 6]] {
//!     let rest = (solver.particles.position[ids[a] as usize]
//!         - solver.particles.position[ids[b] as usize])
//!         .length();
//!     solver.sticks.push([ids[a], ids[b]], rest, 0.0, StickKind::Equal, f64::INFINITY, 0);
//! }
//! solver.organize();
//! let island = &solver.islands.list[0];
//! assert_eq!(island.method, Method::Lines);
//! assert_eq!(island.trees.len(), 2);
//! for _ in 0..64 {
//!     solver.step(&StepConfig::default());
//! }
//! assert!(solver.sticks.max_violation(&solver.particles) < 1e-8);
//! ```

use super::super::lines::Incidence;
use super::super::{Particles, Sticks};
use super::{MAX_CLOSINGS, NONE, Tree, TreeSet};
use std::ops::Range;

/// Appends one tree per part of a tree-shaped island cut at its immovable particles (see the
/// [module docs](self)); returns the range of the new trees in `set.trees`, empty (and nothing
/// appended) where a part hangs on more than [`MAX_CLOSINGS`] + 1 immovable particles, holds
/// none, or the island is not a tree. `queue` and `seen` as for [`build`](super::build) (`seen`
/// as long as the particles).
pub(super) fn split_at_immovable(
    set: &mut TreeSet,
    (queue, seen): (&mut Vec<u32>, &mut [bool]),
    (particles, sticks): (&Particles, &Sticks),
    island_particles: Range<u32>,
    incidence: &Incidence,
) -> Range<u32> {
    let immovable = |p: u32| particles.inverse_mass[p as usize] <= 0.0;
    let (first_tree, first_node) = (set.trees.len(), set.particle.len());
    let first_extra = set.extra_closing.len();
    queue.clear();
    let mut whole = true;
    'parts: for root in island_particles.clone().filter(|&p| immovable(p)) {
        for &k in incidence.of(root) {
            let [a, b] = sticks.ends[k as usize];
            let first = if a == root { b } else { a };
            if immovable(first) || seen[first as usize] {
                continue;
            }
            if !append_part(
                set,
                (queue, seen),
                (particles, sticks),
                (root, k),
                incidence,
            ) {
                whole = false;
                break 'parts;
            }
        }
    }
    let movable = island_particles.filter(|&p| !immovable(p)).count();
    for &p in queue.iter() {
        seen[p as usize] = false;
    }
    if !whole || queue.len() != movable {
        set.extra_closing.truncate(first_extra);
        set.trees.truncate(first_tree);
        set.particle.truncate(first_node);
        set.stick.truncate(first_node);
        set.parent.truncate(first_node);
        return 0..0;
    }
    first_tree as u32..set.trees.len() as u32
}

/// Appends the part of the tree that stick `k` leads into from immovable particle `root`
/// (breadth-first over movable particles, each marked in `seen` and pushed on `queue`), with
/// `root` as its root, the first further immovable particle it reaches as its closing node and
/// the others as extra closing nodes. `false` where it reaches more than [`MAX_CLOSINGS`], or a
/// particle twice (a loop).
fn append_part(
    set: &mut TreeSet,
    (queue, seen): (&mut Vec<u32>, &mut [bool]),
    (particles, sticks): (&Particles, &Sticks),
    (root, k): (u32, u32),
    incidence: &Incidence,
) -> bool {
    let immovable = |p: u32| particles.inverse_mass[p as usize] <= 0.0;
    let start = set.particle.len();
    push(set, root, NONE, NONE);
    let [a, b] = sticks.ends[k as usize];
    let first = if a == root { b } else { a };
    seen[first as usize] = true;
    queue.push(first);
    push(set, first, k, start as u32);
    let (mut closing, extra) = (None, set.extra_closing.len());
    let mut head = start + 1;
    while head < set.particle.len() {
        let (node, p) = (head, set.particle[head]);
        head += 1;
        if immovable(p) {
            continue; // (the closing node: a leaf)
        }
        for &s in incidence.of(p) {
            if s == set.stick[node] {
                continue;
            }
            let [a, b] = sticks.ends[s as usize];
            let other = if a == p { b } else { a };
            if immovable(other) {
                let node = (set.particle.len() - start) as u32;
                if closing.is_none() {
                    closing = Some(node);
                } else if set.extra_closing.len() - extra + 1 < MAX_CLOSINGS {
                    set.extra_closing.push(node);
                } else {
                    return false;
                }
            } else if seen[other as usize] {
                return false;
            } else {
                seen[other as usize] = true;
                queue.push(other);
            }
            push(set, other, s, node as u32);
        }
    }
    let records = set.closing_records() as u32;
    set.trees.push(Tree {
        nodes: start as u32..set.particle.len() as u32,
        closing,
        extra_closings: extra as u32..set.extra_closing.len() as u32,
        closing_scratch: records,
    });
    true
}

/// Appends a node: its particle, the stick to its parent and the parent node.
fn push(set: &mut TreeSet, particle: u32, stick: u32, parent: u32) {
    set.particle.push(particle);
    set.stick.push(stick);
    set.parent.push(parent);
}
