//! Graph colouring of the sticks, for Gauss–Seidel by colour.
//!
//! Sticks that share no particle can be projected in any order — or at the same time — with the
//! same result. A greedy edge colouring gives every stick the lowest colour not yet used at
//! either of its ends; the sticks of one colour form a *batch* of independent projections.
//! Solving batch after batch is still Gauss–Seidel (each batch sees the previous batches'
//! corrections), and the outcome does not depend on how a batch is split across threads.
//!
//! The order matters for more than parallelism: on a grid, a sweep in row-major order can
//! diverge when a taut pinned edge carries the cloth with one projection per substep (measured:
//! a 100 × 100 cloth pinned at two corners blew up within 10 s at 8 substeps × 1), while the
//! colour order — a red–black ordering on a grid, four batches — stays bounded at every setting
//! tried (see `tests/hard_cases.rs`).
//!
//! A particle with more than [`MAX_COLOURS`] sticks (a wheel hub with 100 spokes) cannot be
//! coloured with a bitmask; its remaining sticks go into a last batch solved serially.

use std::ops::Range;

/// Colours tracked per particle (a `u64` bitmask).
pub const MAX_COLOURS: u32 = 64;

/// A run of consecutive sticks solved together.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Batch {
    /// Stick indices.
    pub sticks: Range<u32>,
    /// `true` when no two sticks of the batch share a particle (it may be split across threads).
    pub independent: bool,
    /// `true` when every stick of the batch is two-sided, rigid (compliance 0) and cannot tear:
    /// the sweep then reads only ends and rest lengths. [`Solver::organize`](super::Solver::organize)
    /// sets it and a tear clears it; set it to `false` if you change kinds or compliances of
    /// organized sticks by hand.
    pub rigid: bool,
}

/// Greedy edge colouring: `colour[i]` for every stick `order[i]`, visiting sticks in `order`.
/// Sticks that found no free colour get [`MAX_COLOURS`]. `used` is scratch (one mask per
/// particle, indexed by particle).
pub(crate) fn colour_sticks(
    ends: &[[u32; 2]],
    order: &[u32],
    used: &mut [u64],
    colour: &mut Vec<u32>,
) {
    colour.clear();
    for &stick in order {
        let [a, b] = ends[stick as usize].map(|p| p as usize);
        let taken = used[a] | used[b];
        let c = (!taken).trailing_zeros();
        if c < MAX_COLOURS {
            used[a] |= 1 << c;
            used[b] |= 1 << c;
        }
        colour.push(c.min(MAX_COLOURS));
    }
}
