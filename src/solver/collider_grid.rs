//! A uniform grid over the external colliders of a substep, so a particle meets only the
//! colliders near it instead of testing the bounds of every one.
//!
//! Rebuilt every substep from the colliders' placed bounds (they move with their bodies): the
//! cell is the size of the median collider (its largest bounded side), and each collider is
//! listed in every cell its bounds (grown by its margin) overlap. One over four times that size
//! or covering more than [`MAX_CELLS`] cells (a ground, a wall) goes on a list every particle
//! tests; the grid spans the others (a particle away from them meets only the large ones). A particle
//! asks for the cells its swept box — grown by its radius and by what a contact may push it,
//! its radius, its motion and the largest margin — overlaps, and gets each collider once, in
//! the colliders' order: the contacts resolve as without the grid, in the same order, unless a
//! contact pushes a particle farther than that (out of a deep overlap, or by a fast moving
//! collider), when a collider past the box waits for the next substep. An axis the colliders do not
//! bound (2D shapes extend through every depth) is one cell wide; at most a few cells per
//! collider. Below [`MIN_COLLIDERS`] colliders there is no grid. Counting sort into flat arrays:
//! no allocation once they have grown.

use glam::DVec3;

/// Fewer colliders than this are all tested by every particle (no grid).
pub const MIN_COLLIDERS: usize = 8;

/// A collider or a particle query covering more cells than this skips the grid (the collider
/// is tested by every particle; the particle tests every collider).
pub const MAX_CELLS: usize = 27;

/// The grid (see the [module docs](self)).
#[derive(Clone, Debug, Default)]
pub struct ColliderGrid {
    active: bool,
    origin: DVec3,
    inverse_cell: DVec3,
    dims: [usize; 3],
    /// `items[start[c]..start[c + 1]]`: the colliders listed in cell `c`.
    start: Vec<u32>,
    items: Vec<u32>,
    /// Colliders too large for the grid.
    large: Vec<u32>,
    /// Colliders with a larger side are tested by every particle.
    limit: f64,
    /// Axes most colliders leave unbounded (one cell wide).
    free: [bool; 3],
    /// The bounds of the colliders in cells (a box away from them meets only the large ones).
    span: (DVec3, DVec3),
    /// Scratch of the counting sort.
    next: Vec<u32>,
    /// Scratch: each collider's largest bounded side.
    sides: Vec<f64>,
}

impl ColliderGrid {
    /// Rebuilds the grid over `bounds` (each collider's placed bounds, grown by its margin).
    pub fn build(&mut self, bounds: impl Iterator<Item = (DVec3, DVec3)> + Clone) {
        // (Corners in order whatever the input: a negative radius or margin.)
        let bounds = bounds.map(|(lo, hi)| (lo.min(hi), lo.max(hi)));
        let n = bounds.clone().count();
        self.active = n >= MIN_COLLIDERS;
        if !self.active {
            return;
        }
        // Axes most colliders leave unbounded (2D shapes through every depth) are one cell.
        self.free = std::array::from_fn(|k| {
            let unbounded = bounds.clone().filter(|(lo, hi)| !bounded(hi[k] - lo[k]));
            2 * unbounded.count() > n
        });
        // A cell the size of the median collider (its largest side); colliders over four
        // times that (a ground, a wall, a plane) are tested by every particle.
        let free = self.free;
        self.sides.clear();
        self.sides
            .extend(bounds.clone().map(|(lo, hi)| largest_side(free, lo, hi)));
        let middle = n / 2;
        let size = *self.sides.select_nth_unstable_by(middle, f64::total_cmp).1;
        self.limit = 4.0 * size;
        let small = bounds
            .clone()
            .filter(|&(lo, hi)| largest_side(free, lo, hi) <= self.limit);
        let (lo, hi) = small.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), b| {
            (lo.min(b.0), hi.max(b.1))
        });
        let extent = hi - lo;
        let axis = |k: usize, size: f64| -> usize {
            let e = extent[k];
            if !free[k] && bounded(e) && e > 0.0 && size > 0.0 {
                ((e / size).ceil() as usize).clamp(1, 1 << 10)
            } else {
                1
            }
        };
        // No more cells than a few per collider.
        let (mut size, mut dims) = (size, [1; 3]);
        for _ in 0..64 {
            dims = [axis(0, size), axis(1, size), axis(2, size)];
            if dims.iter().product::<usize>() <= 4 * n + 64 {
                break;
            }
            size *= 2.0;
        }
        self.dims = dims;
        self.span = (lo, hi);
        self.origin = lo;
        self.inverse_cell = DVec3::from_array(std::array::from_fn(|k| {
            if dims[k] > 1 {
                dims[k] as f64 / extent[k]
            } else {
                0.0
            }
        }));
        self.fill(bounds);
    }

    /// Counting sort of the colliders into their cells.
    fn fill(&mut self, bounds: impl Iterator<Item = (DVec3, DVec3)> + Clone) {
        let cells = self.dims.iter().product::<usize>();
        self.start.clear();
        self.start.resize(cells + 1, 0);
        self.large.clear();
        for (lo, hi) in bounds.clone() {
            if let Some(range) = self
                .cells(lo, hi)
                .filter(|_| largest_side(self.free, lo, hi) <= self.limit)
            {
                let start = &mut self.start;
                each_cell(self.dims, range, |c| start[c + 1] += 1);
            }
        }
        for c in 0..cells {
            self.start[c + 1] += self.start[c];
        }
        self.items.clear();
        self.items.resize(self.start[cells] as usize, 0);
        self.next.clone_from(&self.start);
        for (i, (lo, hi)) in bounds.enumerate() {
            let range = self.cells(lo, hi);
            match range.filter(|_| largest_side(self.free, lo, hi) <= self.limit) {
                Some(range) => {
                    let (items, next) = (&mut self.items, &mut self.next);
                    each_cell(self.dims, range, |c| {
                        items[next[c] as usize] = i as u32;
                        next[c] += 1;
                    });
                }
                None => self.large.push(i as u32),
            }
        }
    }

    /// Whether a box touches the bounds of the colliders in cells.
    fn reaches(&self, lo: DVec3, hi: DVec3) -> bool {
        let (a, b) = self.span;
        lo.cmple(b).all() && hi.cmpge(a).all()
    }

    /// The cell ranges `[lo, hi]` per axis a box covers, or `None` beyond [`MAX_CELLS`].
    fn cells(&self, lo: DVec3, hi: DVec3) -> Option<[(usize, usize); 3]> {
        let index = |v: f64, k: usize| -> usize {
            let t = (v - self.origin[k]) * self.inverse_cell[k];
            if t.is_nan() || t <= 0.0 {
                0
            } else {
                (t as usize).min(self.dims[k] - 1)
            }
        };
        let range: [(usize, usize); 3] =
            std::array::from_fn(|k| (index(lo[k], k), index(hi[k], k)));
        let count: usize = range.iter().map(|(a, b)| b - a + 1).product();
        (count <= MAX_CELLS).then_some(range)
    }

    /// Whether there is a grid (enough colliders for one).
    pub fn is_active(&self) -> bool {
        self.active
    }

    /// Writes into `out` the colliders a particle with box `(lo, hi)` may meet, each once, in
    /// the colliders' order, and returns how many: no shared scratch, so jobs on several
    /// threads can query at once. `None` when every collider must be tested (no grid, a box
    /// over [`MAX_CELLS`] cells, or more colliders than `out` holds).
    pub fn near_sorted(&self, lo: DVec3, hi: DVec3, out: &mut [u32]) -> Option<usize> {
        if !self.active {
            return None;
        }
        let range = self.cells(lo, hi)?;
        let away = !self.reaches(lo, hi);
        let mut count = 0;
        let mut overflow = false;
        let mut take = |i: u32| match out.get_mut(count) {
            Some(slot) => {
                *slot = i;
                count += 1;
            }
            None => overflow = true,
        };
        self.large.iter().for_each(|&i| take(i));
        let (start, items) = (&self.start, &self.items);
        let range = if away { EMPTY } else { range };
        each_cell(self.dims, range, |c| {
            items[start[c] as usize..start[c + 1] as usize]
                .iter()
                .for_each(|&i| take(i));
        });
        if overflow {
            return None;
        }
        let found = &mut out[..count];
        found.sort_unstable();
        let mut kept = 0;
        for k in 0..count {
            if k == 0 || found[k] != found[kept - 1] {
                found[kept] = found[k];
                kept += 1;
            }
        }
        Some(kept)
    }
}

/// Whether a length is bounded (2D shapes extend through every depth).
fn bounded(length: f64) -> bool {
    length.is_finite() && length < 1e12
}

/// The largest side of a box off the `free` axes (∞ if one is unbounded).
fn largest_side(free: [bool; 3], lo: DVec3, hi: DVec3) -> f64 {
    let sides = (hi - lo).to_array().into_iter().zip(free);
    sides
        .filter(|&(_, free)| !free)
        .map(|(side, _)| if bounded(side) { side } else { f64::INFINITY })
        .fold(0.0, f64::max)
}

/// No cell (for [`each_cell`]).
const EMPTY: [(usize, usize); 3] = [(1, 0); 3];

/// Calls `f` with the index of every cell in `range` (per axis, inclusive).
fn each_cell(dims: [usize; 3], range: [(usize, usize); 3], mut f: impl FnMut(usize)) {
    let [nx, ny, _] = dims;
    for z in range[2].0..=range[2].1 {
        for y in range[1].0..=range[1].1 {
            for x in range[0].0..=range[0].1 {
                f(x + nx * (y + ny * z));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every collider whose bounds touch a query box is returned, each once, in order; far
    /// ones are not; a huge collider is always returned.
    #[test]
    fn a_query_finds_exactly_the_colliders_near_it() {
        let mut boxes: Vec<(DVec3, DVec3)> = (0..40)
            .map(|i| {
                let at = DVec3::new((i % 8) as f64, (i / 8) as f64, 0.0) * 2.0;
                (at, at + DVec3::splat(1.0))
            })
            .collect();
        boxes.push((DVec3::splat(-100.0), DVec3::splat(100.0))); // a ground
        let mut grid = ColliderGrid::default();
        grid.build(boxes.iter().copied());
        let mut out = [0u32; 64];
        for query in [
            (DVec3::new(2.5, 2.5, 0.2), DVec3::new(4.5, 3.0, 0.4)),
            (DVec3::splat(-3.0), DVec3::splat(-2.0)),
        ] {
            let count = grid
                .near_sorted(query.0, query.1, &mut out)
                .expect("small query");
            let out = &out[..count];
            let touching: Vec<u32> = (0..boxes.len() as u32)
                .filter(|&i| {
                    let (a, b) = boxes[i as usize];
                    query.0.cmple(b).all() && query.1.cmpge(a).all()
                })
                .collect();
            assert!(
                touching.iter().all(|i| out.contains(i)),
                "{touching:?} ⊄ {out:?}"
            );
            assert!(out.windows(2).all(|w| w[0] < w[1]), "sorted, once: {out:?}");
            assert!(out.contains(&40), "the ground is always there");
            assert!(out.len() < 10, "only nearby colliders: {out:?}");
        }
    }
}
