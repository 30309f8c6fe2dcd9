//! Distance constraints ("sticks") solved with XPBD (Macklin, Müller, Chentanez 2016).
//!
//! For a stick between particles `a` and `b` with rest length `L`, the constraint is
//! `C = |x_a − x_b| − L`. One projection computes, with `W = w_a + w_b` and `α̃ = α/h²`,
//!
//! ```text
//! Δλ = (−C − α̃·λ) / (W + α̃),   x_a += w_a·n·Δλ,   x_b −= w_b·n·Δλ,   λ += Δλ
//! ```
//!
//! where `n` is the unit vector from `b` to `a`. With compliance `α = 0` this is Jakobsen's
//! mass-weighted stick (full projection); with `α > 0` the stick is a spring of stiffness `1/α`
//! whose stiffness does not change with the iteration count or the timestep. One-sided sticks
//! (ropes that only pull, struts that only push) clamp the accumulated `λ` to one sign.
//! Sticks whose ends are both immovable are skipped. Coincident ends (`|x_a − x_b| ≈ 0`) have no
//! direction: rather than divide by zero, a stick with a positive rest length pushes them apart
//! along a fixed direction in the XY plane that depends only on the stick's index (the golden
//! angle times the index, starting at `+X`): the solver stays deterministic, 2D scenes stay in
//! their plane, and different sticks of a heap of coincident particles push different ways. A
//! zero rest length with coincident ends is satisfied.

use super::Particles;
use super::islands::next_stamp;
use super::shared::SharedSlice;
use glam::DVec3;
use std::ops::Range;

/// Which way a stick acts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum StickKind {
    /// Holds its length both ways (a rod).
    #[default]
    Equal,
    /// Only pulls: active when longer than its rest length (a rope or chain link).
    AtMost,
    /// Only pushes: active when shorter than its rest length (a strut; the Tuts+ ragdoll's
    /// joint-angle limits).
    AtLeast,
    /// Torn: ignored until the topology is rebuilt without it.
    Torn,
}

/// Struct-of-arrays storage for distance constraints.
///
/// ```
/// use bevy_verlet_physics::solver::{Sticks, StickKind};
/// let mut sticks = Sticks::default();
/// sticks.push([0, 1], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 7);
/// assert_eq!(sticks.len(), 1);
/// ```
#[derive(Clone, Debug, Default)]
pub struct Sticks {
    /// Particle indices of the two ends (read with [`Sticks::ends`], change with
    /// [`Sticks::set_ends`]: the solver's islands and colour batches are built from them).
    pub(crate) ends: Vec<[u32; 2]>,
    /// Rest lengths.
    pub rest_length: Vec<f64>,
    /// XPBD compliances (inverse stiffness; `0` = rigid).
    pub compliance: Vec<f64>,
    /// Direction of action.
    pub kind: Vec<StickKind>,
    /// Strain (`length / rest − 1`) past which the stick tears; `INFINITY` = never.
    pub tear_strain: Vec<f64>,
    /// Accumulated XPBD multipliers of the current substep.
    pub lambda: Vec<f64>,
    /// An opaque handle per stick (the Bevy layer stores `Entity::to_bits`).
    pub handle: Vec<u64>,
    /// Indices of the sticks with a finite tear strain (so that a scene without tearing pays
    /// nothing for the tear pass). Sticks cut in place ([`Solver::cut`](super::Solver::cut))
    /// stay listed until the next tear pass drops them.
    pub tearable: Vec<u32>,
    /// A stamp that changes with every change of `ends` (see [`next_stamp`]).
    pub(crate) stamp: u64,
}

impl Sticks {
    /// Number of sticks (torn ones included until the next rebuild).
    pub fn len(&self) -> usize {
        self.ends.len()
    }

    /// `true` when there are no sticks.
    pub fn is_empty(&self) -> bool {
        self.ends.is_empty()
    }

    /// Particle indices of the two ends of every stick.
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{Sticks, StickKind};
    /// let mut sticks = Sticks::default();
    /// sticks.push([0, 1], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
    /// assert_eq!(sticks.ends(), &[[0, 1]]);
    /// ```
    pub fn ends(&self) -> &[[u32; 2]] {
        &self.ends
    }

    /// Makes stick `i` join `ends` instead. This changes the topology: the solver's islands
    /// no longer describe it, so [`Solver::step`](super::Solver::step) treats everything as
    /// one island until the next [`Solver::organize`](super::Solver::organize).
    ///
    /// ```
    /// use bevy_verlet_physics::solver::{Sticks, StickKind};
    /// let mut sticks = Sticks::default();
    /// sticks.push([0, 1], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
    /// sticks.set_ends(0, [1, 2]);
    /// assert_eq!(sticks.ends()[0], [1, 2]);
    /// ```
    pub fn set_ends(&mut self, i: usize, ends: [u32; 2]) {
        self.ends[i] = ends;
        self.stamp = next_stamp();
    }

    /// Removes every stick, keeping the allocations.
    pub fn clear(&mut self) {
        self.stamp = next_stamp();
        self.ends.clear();
        self.rest_length.clear();
        self.compliance.clear();
        self.kind.clear();
        self.tear_strain.clear();
        self.lambda.clear();
        self.handle.clear();
        self.tearable.clear();
    }

    /// Adds a stick and returns its index.
    pub fn push(
        &mut self,
        ends: [u32; 2],
        rest_length: f64,
        compliance: f64,
        kind: StickKind,
        tear_strain: f64,
        handle: u64,
    ) -> u32 {
        let index = self.ends.len() as u32;
        self.stamp = next_stamp();
        self.ends.push(ends);
        self.rest_length.push(rest_length);
        self.compliance.push(compliance);
        self.kind.push(kind);
        self.tear_strain.push(tear_strain);
        self.lambda.push(0.0);
        self.handle.push(handle);
        if tear_strain.is_finite() {
            self.tearable.push(index);
        }
        index
    }

    /// Current strain `|x_a − x_b| / L − 1` of stick `i` (`0` for a zero rest length).
    pub fn strain(&self, i: usize, particles: &Particles) -> f64 {
        let [a, b] = self.ends[i];
        let length = (particles.position[a as usize] - particles.position[b as usize]).length();
        let rest = self.rest_length[i];
        if rest > 0.0 { length / rest - 1.0 } else { 0.0 }
    }

    /// Largest `|strain|` over the sticks that are active (an at-most stick that is slack and an
    /// at-least stick that is stretched count as satisfied).
    pub fn max_violation(&self, particles: &Particles) -> f64 {
        let mut worst: f64 = 0.0;
        for i in 0..self.len() {
            let strain = self.strain(i, particles);
            let violation = match self.kind[i] {
                StickKind::Equal => strain.abs(),
                StickKind::AtMost => strain.max(0.0),
                StickKind::AtLeast => (-strain).max(0.0),
                StickKind::Torn => 0.0,
            };
            worst = worst.max(violation);
        }
        worst
    }
}

/// Below this length a stick has no usable direction (its ends count as coincident).
const MIN_LENGTH: f64 = 1e-12;

/// The direction along which stick `i` pushes coincident ends apart: the golden angle
/// (≈ 137.5°) times `i` in the XY plane (`+X` for stick 0).
pub(crate) fn coincident_direction(i: usize) -> DVec3 {
    const GOLDEN_ANGLE: f64 = 2.399_963_229_728_653;
    let (sin, cos) = (GOLDEN_ANGLE * i as f64).sin_cos();
    DVec3::new(cos, sin, 0.0)
}

/// The unit vector along `d` (stick `i`'s, from one end to the other) and its length; for
/// (nearly) coincident ends, stick `i`'s fixed push-apart direction ([`coincident_direction`]).
/// Shared by the line and tree solves.
#[inline(always)]
pub(crate) fn unit_and_length(d: DVec3, i: usize) -> (DVec3, f64) {
    let length = d.length();
    if length > MIN_LENGTH {
        (d / length, length)
    } else {
        (coincident_direction(i), length)
    }
}

/// A stick's two ends as the sweeps need them.
struct End {
    a: usize,
    b: usize,
    wa: f64,
    wb: f64,
    xa: DVec3,
    xb: DVec3,
}

impl End {
    /// Reads both ends without bounds checks.
    ///
    /// # Safety
    /// Both indices are below `position.len()` and `inverse_mass.len()`, and no other task
    /// writes those particles while this runs.
    #[inline(always)]
    unsafe fn load(position: &SharedSlice<DVec3>, inverse_mass: &[f64], [a, b]: [u32; 2]) -> Self {
        let (a, b) = (a as usize, b as usize);
        // SAFETY: in bounds (caller).
        unsafe {
            Self {
                a,
                b,
                wa: *inverse_mass.get_unchecked(a),
                wb: *inverse_mass.get_unchecked(b),
                xa: position.get_unchecked(a),
                xb: position.get_unchecked(b),
            }
        }
    }

    /// Moves end `a` by `correction·w_a` and end `b` by `−correction·w_b`.
    ///
    /// # Safety
    /// As for [`End::load`] (no other task reads or writes those particles).
    #[inline(always)]
    unsafe fn apply(&self, position: &SharedSlice<DVec3>, correction: DVec3) {
        // SAFETY: in bounds (caller).
        unsafe {
            position.set_unchecked(self.a, self.xa + correction * self.wa);
            position.set_unchecked(self.b, self.xb - correction * self.wb);
        }
    }
}

/// Projects every stick once (one Gauss–Seidel sweep), for a substep of length `h`.
///
/// `accumulate` selects full XPBD with the multipliers in [`Sticks::lambda`] (needed when a
/// substep runs more than one iteration and compliances are non-zero); with one iteration the
/// multipliers start at zero and are not needed.
///
/// ```
/// use bevy_verlet_physics::solver::{relax_sticks, Particles, Sticks, StickKind};
/// use glam::DVec3;
/// let mut p = Particles::default();
/// p.push(DVec3::ZERO, DVec3::ZERO, 1.0, 0.0, 0);
/// p.push(DVec3::X * 2.0, DVec3::X * 2.0, 1.0, 0.0, 1);
/// let mut s = Sticks::default();
/// s.push([0, 1], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
/// relax_sticks(&mut p, &mut s, 1.0 / 60.0, false);
/// assert!((p.position[1].x - p.position[0].x - 1.0).abs() < 1e-12);
/// ```
pub fn relax_sticks(particles: &mut Particles, sticks: &mut Sticks, h: f64, accumulate: bool) {
    let mut lambda = std::mem::take(&mut sticks.lambda);
    // SAFETY: both slices are borrowed exclusively here; nothing else can access them.
    unsafe {
        relax_stick_range(
            &SharedSlice::new(&mut particles.position),
            &particles.inverse_mass,
            sticks,
            &SharedSlice::new(&mut lambda),
            0..sticks.len(),
            1.0 / (h * h),
            accumulate,
            false,
            SweepOrder::Forward,
        );
    }
    sticks.lambda = lambda;
}

/// The order in which a sweep visits its sticks: a forward sweep followed by a backward one
/// is a symmetric Gauss–Seidel sweep (see [`symmetric`](super::symmetric)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SweepOrder {
    /// First stick to last.
    Forward,
    /// Last stick to first (the adjoint of the forward sweep).
    Backward,
}

/// `for pattern in items { body }` with `items` visited in `order` (a loop per direction, the
/// body in each: a closure here was not always inlined into the sweep).
macro_rules! in_order {
    ($order:expr, $items:expr, |$pattern:pat_param| $body:block) => {
        match $order {
            SweepOrder::Forward => {
                for $pattern in $items $body
            }
            SweepOrder::Backward => {
                for $pattern in $items.rev() $body
            }
        }
    };
}

/// [`relax_sticks`] over the sticks in `range`, visited in `order`, with positions and
/// multipliers that other tasks may be writing at other indices (the sticks' particles are this
/// task's alone). `rigid` says every stick of the range is a two-sided stick of compliance 0
/// (see [`Batch::rigid`](super::Batch::rigid)): then only ends and rest lengths are read, and no
/// multiplier is kept (with `α = 0` it changes nothing).
#[allow(clippy::too_many_arguments)]
///
/// # Safety
/// No other task accesses the particles of the sticks in `range`, or their multipliers, while
/// this runs.
pub(crate) unsafe fn relax_stick_range(
    position: &SharedSlice<DVec3>,
    inverse_mass: &[f64],
    sticks: &Sticks,
    lambda: &SharedSlice<f64>,
    range: Range<usize>,
    inv_h2: f64,
    accumulate: bool,
    rigid: bool,
    order: SweepOrder,
) {
    let ends = &sticks.ends[range.clone()];
    let kinds = &sticks.kind[range.clone()];
    let rests = &sticks.rest_length[range.clone()];
    let compliances = &sticks.compliance[range.clone()];
    // Every index the loop uses, checked once (the loop then reads without bounds checks).
    let n = position.len().min(inverse_mass.len());
    let largest = ends.iter().fold(0, |m: u32, &[a, b]| m.max(a).max(b));
    assert!(
        ends.is_empty() || (largest as usize) < n,
        "a stick refers to a particle that does not exist"
    );
    assert!(!accumulate || range.end <= lambda.len());
    if rigid {
        in_order!(order, ends.iter().zip(rests).enumerate(), |(
            k,
            (&pair, &rest),
        )| {
            // SAFETY: both ends `< n` (checked above); this task alone accesses them (caller).
            let end = unsafe { End::load(position, inverse_mass, pair) };
            let w = end.wa + end.wb;
            if w <= 0.0 {
                continue;
            }
            let delta = end.xa - end.xb;
            let length = delta.length();
            let correction = if length >= MIN_LENGTH {
                delta * ((rest - length) / (w * length))
            } else if rest >= MIN_LENGTH {
                coincident_direction(range.start + k) * ((rest - length) / w)
            } else {
                continue;
            };
            // SAFETY: as above.
            unsafe { end.apply(position, correction) };
        });
        return;
    }
    let all = ends.iter().zip(kinds).zip(rests).zip(compliances);
    in_order!(order, all.enumerate(), |(
        k,
        (((&pair, &kind), &rest), &compliance),
    )| {
        if kind == StickKind::Torn {
            continue;
        }
        let i = range.start + k;
        // SAFETY: both ends `< n` (checked above); this task alone accesses them (caller).
        let end = unsafe { End::load(position, inverse_mass, pair) };
        let w = end.wa + end.wb;
        if w <= 0.0 {
            continue;
        }
        let delta = end.xa - end.xb;
        let length = delta.length();
        let coincident = length < MIN_LENGTH;
        if coincident && rest < MIN_LENGTH {
            continue; // a zero-length stick with coincident ends is satisfied
        }
        let c = length - rest;
        let alpha = compliance * inv_h2;
        if kind == StickKind::Equal && !accumulate && !coincident {
            // The common case in one division: Δλ/|d| = −C / ((W + α̃)·|d|).
            let correction = delta * (-c / ((w + alpha) * length));
            // SAFETY: as above.
            unsafe { end.apply(position, correction) };
            continue;
        }
        // SAFETY: this task alone accesses the multipliers of these sticks (caller).
        let lambda_i = if accumulate {
            unsafe { lambda.get(i) }
        } else {
            0.0
        };
        let mut d_lambda = (-c - alpha * lambda_i) / (w + alpha);
        // One-sided sticks: the total multiplier may only pull (≤ 0) or only push (≥ 0).
        match kind {
            StickKind::AtMost => d_lambda = d_lambda.min(-lambda_i),
            StickKind::AtLeast => d_lambda = d_lambda.max(-lambda_i),
            _ => {}
        }
        if accumulate {
            // SAFETY: as above.
            unsafe { lambda.set(i, lambda_i + d_lambda) };
        }
        let correction: DVec3 = if coincident {
            coincident_direction(i) * d_lambda
        } else {
            delta * (d_lambda / length)
        };
        // SAFETY: as above.
        unsafe { end.apply(position, correction) };
    });
}
