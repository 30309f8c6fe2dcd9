//! Direct solve of a line of sticks: exact per Newton pass, whatever its length or mass ratio.
//!
//! # Why
//! Gauss–Seidel projects one stick at a time, so a correction travels one or two sticks per sweep:
//! a 100-link chain holding a 1000× heavier tip stretches by hundreds of percent at game budgets.
//! The sticks of a line (see [`lines`](super::lines)) form a *tridiagonal* system, which the
//! Thomas algorithm solves exactly in O(n) (Baraff 1996, "Linear-time dynamics using Lagrange
//! multipliers"; Deul, Kugelstadt, Weiler, Bender 2018, "Direct Position-Based Solver for Stiff
//! Rods", who wrap the same elimination in XPBD).
//!
//! # The system
//! Stick `k` joins line particles `k` and `k + 1` (inverse masses `w_k`, `w_{k+1}`), with
//! `n_k` its unit direction at the current iterate and `C_k = |x_{k+1} − x_k| − L_k`. Each
//! stick moves its ends along a *correction direction* `r_k`:
//!
//! ```text
//! Δx_j = w_j (r_{j−1} Δλ_{j−1} − r_j Δλ_j)
//! (K + α̃) Δλ = −(C + α̃ ∘ λ),   α̃_k = α_k / h²
//! K_kk = (w_k + w_{k+1}) n_k·r_k,  K_k,k+1 = −w_{k+1} n_k·r_{k+1},  K_k,k−1 = −w_k n_k·r_{k−1}
//! ```
//!
//! With `r = n` this is one Newton step of the XPBD projection. With `r` the stick's direction at
//! the **start of the substep** it is **SHAKE** (Ryckaert, Ciccotti, Berendsen 1977): the
//! constraint force acts along the gradient at the start of the step and λ is solved so the
//! constraint holds at its end. Verlet with SHAKE is symplectic and time-reversible, so energy
//! oscillates within O(h²) instead of draining like the projection's implicit (backward-Euler)
//! damping: a 1 m pendulum released at 90° keeps ≈ 100 % of its energy after 10 s instead of 75 %
//! (measured, `tests/direct.rs`). SHAKE needs small turns per substep: a line whose predicted
//! turn exceeds ≈ 8° anywhere ([`SHAKE_MIN_COSINE`]), or whose SHAKE passes do not converge in
//! [`SHAKE_PASSES`] — or whose error a SHAKE pass fails to divide by
//! 1/[`SHAKE_CONTRACTION`], the sign of a substep SHAKE will not solve — is projected along the
//! current directions for that substep instead. A line alone in its island (a chain, a rope)
//! starts a substep that begins projected with one full Newton pass that includes the
//! constraints' curvature (`curvature`): the projection then converges in a few passes where
//! it used to wander (a whipping 1000:1 chain: 28 % fewer passes in all, 12 % less time). Where
//! the projection has still not converged after [`FULL_NEWTON_AFTER`] passes, full Newton
//! passes (the curvature in every pass, the residual measured against the kept prediction) take
//! over: Gauss–Newton alone does not converge on loads 10⁵–10⁶ times a link's mass. A line
//! pinned at both ends takes both too, its last stick closing the loop (`closure`). Such a
//! projection that converged on a far root (a load thrown round its pin), or did not converge
//! while its pins stood still, is tried again from the start of the substep (`second_try`).
//!
//! Each substep starts from the last substep's multipliers (a warm start along the start
//! directions: constraint forces change little between substeps; taken back if it makes the
//! line worse), then Newton passes repeat until the largest XPBD residual `|C + α̃λ|/L` of the
//! line is below [`TOLERANCE`], at most [`MAX_PASSES`] times.
//! A hanging chain needs one pass or none; a heavy chain whipping round needs more in the
//! substeps where its links turn fast (a fixed single pass diverges there: the linearisation
//! error compounds with the mass ratio). A pass is two traversals: forward (evaluate `n`, `C`
//! and eliminate, fused) and backward (substitute and move the particles, fused). A
//! convergence check is one traversal of lengths — or none where the pass it follows is
//! expected not to converge: the next forward traversal measures the residual on its way
//! (`converges_next`). The elimination runs only when a pass follows, so a line its warm
//! start already converged costs the check alone. A line of one rigid stick skips all this
//! where SHAKE applies: its equation is a quadratic, solved in closed form
//! ([`lone_stick`](super::lone_stick)).
//!
//! A projection whose passes run out unconverged (the budget of [`MAX_PASSES`]) and leave a line
//! with a larger error than its prediction had is put back at the prediction and swept once
//! instead (`LineSolve::fall_back`) — for a line that shares particles with others (lines
//! meeting at forks) the prediction is where the lines solved before it left its particles, and
//! this holds in a substep's first round: before it did, trees pinned at three or four
//! particles kicked by up to 30 m/s reached 10⁸ link lengths, 3 of 1033 in a scratch scan, none
//! with it (such trees are now split at their pins and closed more than once, see
//! [`tree`](super::tree); lines still meet at forks in meshes forced onto lines and in trees
//! with a part held by more than nine pins).
//! Gauss–Newton passes far from the constraints can wander off, a sweep cannot — unless the
//! iterate is finite, within `NEARLY_ON` of its rigid sticks' constraints, nearer them than
//! the sweep and not
//! `FARTHER_THAN_A_SWEEP` from the prediction: then it is kept (the error compared first
//! counts a multiplier not yet released, and a review found iterates 4·10⁻⁹–7·10⁻³ off their
//! constraints swept into 46–310 % strain where pins jump each step). An unconverged projection
//! that has thrown its loads — moved the particles (mass-weighted squared distances) more than
//! `THROWN_ABOVE` times as far from the start of the substep as the prediction did, its
//! residual smaller or not — goes to the same fallback, the same exception included:
//! unconverged passes can throw a heavy load across many link lengths (a random rope at one
//! substep kicked by 30 m/s gained 1940 times its scale in one step). Trees use the same rule,
//! and also try the sweep where the iterate is farther from the prediction than
//! [`WARM_START_REACH`] times the start of the substep — not lines, where that changed which
//! energy a rope teleported a kilometre kept. Measured with the random chains and trees of
//! `tests/direct.rs` (loads up to 10⁴× a link): at one substep kicked by 10 m/s (506 scenes)
//! the largest strain went from 2780 % to 255 % and the largest energy gain from 76 % to 0.13 %
//! of a scene's scale; kicked by 30 m/s, from 2.6·10¹⁰ link lengths and 2.9·10¹⁵ times the
//! scale to 7400 and 1900 times (71 of 506 scenes still stretch beyond 1 %; with
//! `THROWN_ABOVE` 934 link lengths and 584 times, the same 71; with the second tries of
//! lines and, beyond `CURVATURE_BELOW`, trees 606 and 2.3 times, 42 of 506; with lines' beyond
//! it too, from a start on its constraints, 25 of 506); at 8 substeps kicked by 100 m/s (2109
//! scenes) the worse of the two that fail went from 6.3·10⁶ to 447 link lengths (28 with the
//! second tries), the other from 89 to 445, their largest energy gain from 3.3 to 18 times the
//! scale; with damping 0.5/s one failure fewer. The report's scenes are unchanged (the same errors; the same Newton passes on the
//! whipping 1000:1 chain, the 200-link chain and the 50 × 50 cloth by lines).
//! A prediction whose error is beyond [`CURVATURE_BELOW`] is measured again before its
//! curvature and full Newton passes are left out: a rope link counted only where it is
//! stretched, a strut only where it is compressed (`violation`), a spring's stretch that its
//! last multiplier balanced left out (`LineSolve::within_reach`; trees alike).
//!
//! One-sided sticks use a primal–dual active set (`in_system_with`): a rope link is in the
//! system while stretched or while its multiplier pulls by more than it is slack, a strut
//! likewise in compression; out of it a multiplier is released (its row reads `Δλ = −λ`);
//! torn sticks and sticks between two immovable particles are never in it (a line splits
//! there). A straight chain pulled taut between two pins makes `K` singular: a line
//! with a rigid segment within 0.1 % of taut between two immovable particles (with a movable
//! particle between them: a stick from pin to pin is out of the system) is swept for that
//! substep instead, and the diagonal carries a relative regularisation of
//! `10⁻⁹`. In an island that is a single line, rigid sticks found violated by more than 0.1 % at
//! the start of a substep (an edited rest length, a spawn) are first corrected on the start
//! positions too, so the correction does not become velocity (a free L-shaped rope whose links
//! are shortened by 10 %: 0 instead of 2.4 m/s, `tests/direct.rs`). Not where lines meet at
//! forks (meshes forced onto lines, trees with a part held by more than nine pins): there the
//! block Gauss–Seidel over lines leaves such violations every substep, and lines correcting one
//! shared particle's start position in turn fed each other's errors (a Y-shaped rope stretched
//! 809 % instead of 22 %).
//! Trees are solved whole instead (see [`tree`](super::tree); three or more pins split them
//! into parts, each closed once per pin besides its root, up to nine pins a part).
//!
//! # Where
//! This file holds the policy (the constants and modes below) and a line's solve from start
//! to end (`LineSolve::solve`); its parts are beside it: `start` (start directions, mode,
//! warm start, stabilised start), `elimination` (the Newton pass and the sweep), `curvature`
//! (full Newton passes), `fallback` (what guards an unconverged solve), `second_try` and
//! `closure` (a line closed between two pins).
//!
//! ```
//! use bevy_verlet_physics::solver::{Method, Solver, StepConfig, StickKind};
//! use glam::DVec3;
//! // A 1000:1 chain: 20 light links and a heavy tip, hanging from a pin.
//! let mut solver = Solver::default();
//! solver.method = Method::Lines;
//! let pin = solver.add_particle(DVec3::ZERO, 0.0);
//! solver.pin(pin, DVec3::ZERO);
//! for i in 1..=20 {
//!     let w = if i == 20 { 0.001 } else { 1.0 };
//!     solver.add_particle(DVec3::new(0.0, -0.05 * i as f64, 0.0), w);
//!     solver.sticks.push([i - 1, i], 0.05, 0.0, StickKind::Equal, f64::INFINITY, 0);
//! }
//! solver.organize();
//! for _ in 0..64 {
//!     solver.step(&StepConfig::default());
//! }
//! assert!(solver.sticks.max_violation(&solver.particles) < 1e-8);
//! ```

use super::Sticks;
use super::shared::SharedSlice;
use super::sticks::{SweepOrder, relax_stick_range, unit_and_length};
use super::{StickKind, lines::Line};
use curvature::Root;

mod closure;
mod curvature;
mod elimination;
mod fallback;
mod passes;
mod second_try;
mod start;
pub(crate) use elimination::line_residual;
use glam::DVec3;
pub(crate) use passes::{NewtonSystem, newton_passes};
use std::sync::atomic::{AtomicU64, Ordering};

/// A line is solved once its largest `|C + α̃λ|/L` is below this.
pub const TOLERANCE: f64 = 1e-9;

/// Newton passes per line and round at most — but for a second try from the start of the
/// substep, which may take as many again (lines: `second_try`; trees alike).
pub const MAX_PASSES: u32 = 32;

/// SHAKE is used for a line only while every stick's predicted turn in a substep has a cosine
/// above this (≈ 8°).
pub const SHAKE_MIN_COSINE: f64 = 0.99;

/// Newton passes SHAKE gets before the line falls back to the projection.
pub const SHAKE_PASSES: u32 = 3;

/// A SHAKE pass must bring a line's (or a tree's) error below this fraction of what it was, or
/// the substep falls back to the projection at once instead of after [`SHAKE_PASSES`]. Newton
/// converges quadratically near a root. Measured on the report's swinging chains at 8 × 1 (5 s,
/// every SHAKE substep's error pass by pass): of the substeps where SHAKE went on to converge,
/// none on the 200-link chain and 18 of 1141 on the 1000:1 chain had a first pass that reduced
/// the error less than 10-fold; the failing ones (a fifth of the substeps on the 200-link chain,
/// half on the 1000:1 chain) spent all three passes before falling back.
pub const SHAKE_CONTRACTION: f64 = 0.1;

/// SHAKE is used for a line pinned at both ends, or a tree, only while every particle's
/// `w Σ μ_k` is below this, summed over its sticks, `μ_k = max(−λ_k, 0)/d_k` from the last
/// substep's multipliers and the sticks' lengths at the start of the substep
/// (`tension_stiffness`). A stick's tension stiffens its ends against turning it (its
/// curvature, see `kkt`), and `2 w Σ μ` bounds `(ωh)²` of the fastest such
/// vibration (Gershgorin; equal for a zigzag along a chain under even tension: `ω² = 4T/(mℓ)`).
/// Verlet, and so SHAKE, is stable only for `ωh < 2`, i.e. `w Σ μ < 2`; the projection,
/// implicit along the sticks, is stable whatever the tension, so a line or tree past the bound
/// is projected for the substep. 1.5 keeps a margin (`ωh < 1.73`): `μ` lags a substep, and a
/// review saw a bound of 2.3 let six neighbouring near-taut scenes gain 65–120 %. (`λ` is zero
/// after a swept substep and after `organize`, so such a substep takes SHAKE whatever the
/// tension; `λ` scales with `h²`, so the bound follows a change of substep.)
///
/// A rope nearly taut between two pins is past it: the energy of a V of 64 links 99.8–99.9 %
/// taut rose by up to 136 % in 5 s under SHAKE (`tests/direct.rs`), locked at `w Σ μ = 2.00` as it did (a period-2
/// Verlet mode, measured by a review). Measured on 512 such scenes (80–99.9 % of its length
/// apart, weights 1–1000× a link, kicks up to 36 m/s, damping 0 and 0.5/s, 8 × 1, 5 s), the
/// scenes whose energy rose above its value after the first step by more than 5 % / 20 % /
/// 50 % of its magnitude: 60 / 31 / 14 without the bound, 32 / 17 / 5 with it (at 1.5) — every one
/// above 20 % left only after a kick had stretched the rope by 90 % or more (a bound of 1
/// removed four more rises of 2–8 % in scenes kicked at 36 m/s, at 7 points more energy lost
/// by a swinging equal-mass Y rope). The heavy loads between two pins of `tests/direct.rs`
/// take 0.2–0.6× the Newton passes they took without it (SHAKE had spent passes there
/// before failing); a 1000× rope link there stretched 1.7·10⁻⁴ without it. Trees (see
/// [`tree`](super::tree)) swinging from horizontal for 5 s: a Y rope with 1000× tips 7088 →
/// 5295 Newton passes (79 → 66 ms, a scratch test in the test profile), 100× tips 6999 → 5413,
/// loads 10⁴–10⁶× 12 903–27 699 → 5603–11 788, equal masses 5926 → 5693; the energy lost to
/// projected substeps 21.8 → 27.2 % of what the fall released (1000× tips), 43.9 → 45.1 %
/// (100×), 61.6 → 65.1 % (equal masses). The report's catenary (50 links between two pins)
/// is past it only at 1 and 2 substeps.
///
/// Not applied to lines with a free end yet, though the instability is the same (the light
/// links next to a heavy load are past the bound). On them (at a bound of 2) it halved the Newton passes of the report's
/// swinging 1000:1 chain (10 143 → 4822 in 5 s at 8 × 1; 37 → 31 ms, a scratch test in the
/// test profile, interleaved with the commit before) and cut the 200-link chain's (5367 →
/// 4024, the same time: projected substeps start with a costly curvature pass, see
/// `curvature`), at a little more energy lost by swinging chains (1000:1 chain 14.6 → 20.1 %
/// of what the fall released, 140 links 40.0 → 44.4 %) — but it changed the trajectory of the
/// rope whose pin is teleported a kilometre (`tests/hard_cases.rs`: three substeps of the yank
/// projected) so that, 4 s later, SHAKE's bounded energy oscillation of a still-whipping rope
/// (±0.15 J around −4.35 J) exceeds that test's 10⁻³·m·g·L bound, which is not to be
/// loosened. Pendulums never reach it.
pub const SHAKE_STIFFNESS_BELOW: f64 = 1.5;

/// `μ = max(−λ, 0)/d` of a stick with multiplier `λ` and length `d` (see
/// [`SHAKE_STIFFNESS_BELOW`]): a pull stiffens its ends against turning it; a push (`λ > 0`)
/// softens them, which cannot make SHAKE unstable this way.
#[inline(always)]
pub(crate) fn tension_stiffness(lambda: f64, length: f64) -> f64 {
    (-lambda).max(0.0) / length.max(1e-12)
}

/// Curvature passes, and the full Newton passes that take over where Gauss–Newton does not
/// converge (see `curvature`), run only where the prediction violates the line or tree by less
/// than this (largest `|C|/L`): ten times a link's length. Beyond it the prediction is a jump
/// rather than motion — the 10-link rope of `tests/hard_cases.rs` whose pin is teleported a
/// kilometre, 125 m per substep — and Gauss–Newton's unconverged passes take most of the jump's
/// energy out; with full Newton passes there too, that rope kept 2600–4600 J whirling at 4 s
/// instead of settling (about −1 J), beyond the hard case's bound on its energy after 4 s.
/// (Trees take full Newton passes beyond it in one place: a second try from the start of the
/// substep, whose result they keep only where it is near enough to be a projection, see
/// `TreeSolve::plausible`; lines too, but only from a start of the
/// substep within `NEARLY_ON` of its constraints, as the second try's argument needs, see
/// `second_try`: from any start they changed how that teleported rope settled, 1.26 J at 4 s
/// and then a rise of 0.22 J, beyond the hard case's bound.)
///
/// Below it, they are what keeps heavy loads hit hard from blowing up: far from the
/// constraints Gauss–Newton wanders, and its active set cycles where rope links snap taut.
/// Measured with `random_heavy_chains_and_trees_hit_hard_stay_unstretched` (`tests/direct.rs`)
/// run wide — 2109 random chains and trees per row, loads up to 10⁴ times a link, one or two
/// pins, kicks up to 2 / 10 / 30 / 100 m/s, 2 s at 8 × 1 — with the bound at 0.1 (the value
/// before, where the report's whipping chains stay): 103 / 270 / 472 / 635 scenes failed
/// (strain beyond 1 % or energy up by 10 % of its scale), some stretched 10⁸⁰ times their
/// length; now 0 / 0 / 0 / 2 (with [`WARM_START_REACH`] and the trees' second try, see
/// `tree`'s `curvature`; loads up to 10⁵ kicked by 10 m/s: 556 → 0). A kicked weight on a V
/// of 64 rope or rigid links between two pins (weights 1–10⁴×, kicks 5–51 m/s, a scratch
/// scan of 150): 38 stretched, up to 4920 %, now none beyond 10⁻⁹. The report's 200-link
/// chain swinging takes 5085 instead of 5367 Newton passes. Without any bound the teleported
/// rope keeps whirling; the hard case is chaotic in this constant (bounds of 7, 10 and 20 pass
/// it, 15 and 30 do not; at 10 its undamped rope has −1.0 J at 4 s, −4.5 J at 0.1).
pub const CURVATURE_BELOW: f64 = 10.0;

/// Relative regularisation of the diagonal (keeps a taut straight chain between pins regular).
const REGULARISATION: f64 = 1e-9;

/// What [`LineSolve::begin`] measured at the prediction.
pub(crate) struct Begun {
    /// The largest `|C|/L` (before the warm start).
    pub predicted: f64,
    /// The largest `|C|/L` of a rigid stick at the start positions.
    pub violated: f64,
}

impl Begun {
    /// A later round of a substep: nothing measured, nothing to take back.
    const LATER_ROUND: Begun = Begun {
        predicted: f64::INFINITY,
        violated: 0.0,
    };
}

/// Whether a stick of `kind` and rest length `rest` stretched by `c` is in the system at a
/// prediction, where its multiplier is still zero (see [`in_system_with`]).
#[inline(always)]
pub(crate) fn in_system(kind: StickKind, c: f64, rest: f64) -> bool {
    in_system_with(kind, c, 0.0, rest)
}

/// Whether a stick of `kind` and rest length `rest` stretched by `c` is in the system, `reach`
/// being how far its multiplier has moved its ends so far (`λ (w_a + w_b)`; negative pulls):
/// a primal–dual active set (Hintermüller, Ito, Kunisch 2002, "The primal-dual active set
/// strategy as a semismooth Newton method"). A rope link is in while stretched *or* pulling by
/// more than it is slack; out of the system its multiplier is released (`Δλ = −λ`), so a rope
/// does not keep a pull it no longer needs, nor push. A link within the solve's tolerance of
/// taut (`TOLERANCE · rest`) counts as taut: a rope the last substep left converged has half its
/// links a rounding short of their length, and they joined one per pass. Measured on 100 rope
/// links from a pin released from horizontal (5 s at 8 × 1, largest stretch; Newton passes),
/// deciding by `c` alone with λ frozen while slack, then reach without, then with the
/// tolerance: tip 1× 0.38 % (12 250), 0.24 % (5357), 10⁻⁹ (4132); 10³× 1.9 % (21 400), 10⁻⁷
/// (11 387), 10⁻⁹ (10 143); 10⁴× 14× (40 055), 10⁻⁹ (18 954), 10⁻⁹ (18 791).
#[inline(always)]
pub(crate) fn in_system_with(kind: StickKind, c: f64, reach: f64, rest: f64) -> bool {
    let taut = TOLERANCE * rest;
    match kind {
        StickKind::Equal => true,
        StickKind::AtMost => c > reach - taut,
        StickKind::AtLeast => c < reach + taut,
        StickKind::Torn => false,
    }
}

/// How far a stick of `kind` stretched by `c` is from what it allows: `|c|` for a rigid stick,
/// the stretch of a rope link, the compression of a strut, nothing for a torn stick. A slack rope
/// link or a stretched strut is on its constraint, however far it has gone: measuring its `|c|`
/// as an error made a tree of ropes and struts (struts stretched 10 links' lengths as its parts
/// flew apart) look too far off for its curvature and full Newton passes
/// ([`CURVATURE_BELOW`]), and Gauss–Newton alone then blew it up.
#[inline(always)]
pub(crate) fn violation(kind: StickKind, c: f64) -> f64 {
    match kind {
        StickKind::Equal => c.abs(),
        StickKind::AtMost => c.max(0.0),
        StickKind::AtLeast => (-c).max(0.0),
        StickKind::Torn => 0.0,
    }
}

/// An unconverged projection whose rigid sticks are off their constraints by less than this
/// (relative) is kept rather than replaced by a sweep from the prediction that does worse
/// (see [`LineSolve::fall_back`]).
pub(crate) const NEARLY_ON: f64 = 0.01;

/// An unconverged projection whose particles moved more than this times as far from the
/// prediction as a sweep from it moves them (mass-weighted squared distances: 100 times the
/// distance) is not kept, however near its constraints (see [`LineSolve::fall_back`]): it may
/// be on another root, a load thrown round its pin. Measured with `tests/direct.rs`'s random
/// scenes: at 16 the nearly converged iterates of
/// `nearly_converged_projections_are_kept_where_pins_jump` were swept (250 % strain); without
/// the bound, the two scenes kicked by 100 m/s that fail at 8 × 1 ended 1420 link lengths
/// apart, gaining 37 times their scale (447 and 18 with it).
pub(crate) const FARTHER_THAN_A_SWEEP: f64 = 1e4;

/// An unconverged projection that moved the particles more than this times as far from the
/// start of the substep as the prediction did (`Σ m|x − x*|²` against `Σ m|x̃ − x*|²` plus
/// `Σ m d²`, `d` the largest move of its pins this substep: [`LineSolve::pins_reach`]) is
/// swept from the prediction instead, as one worse off than its prediction is (see
/// [`LineSolve::fall_back`]): it has thrown its loads. A projection from a prediction whose start
/// satisfies the constraints moves the particles (mass-weighted) no farther from the start
/// than twice the prediction (`2² = 4`; the bound is twice that again, `4² = 16`); unconverged
/// passes far from the constraints can fling a heavy load
/// across many link lengths with the residual still below the prediction's. Measured with the
/// random chains and trees of `tests/direct.rs` at one substep kicked by 30 m/s (506 scenes):
/// the largest energy gain went from 1940 to 584 times a scene's scale, the scenes gaining
/// more than their scale from 12 to 9 (more than ten times it: 5 to 2); at 4 the bound swept
/// projections that were merely far and a scene gained 6.9·10⁴ times its scale, at 8 as 16.
/// For a line sharing particles with others the prediction is where the lines before it left
/// them ([`LineSolve::keep_entry`]), and its start need not satisfy its constraints, so the
/// bound is no longer a theorem there, only a measure: applied to such lines only from a start
/// within [`NEARLY_ON`] of their constraints, random trees pinned at three or four particles
/// (scratch scan, 1033 scenes) blew up in 3, 5 and 3 scenes at 1, 2 and 4 substeps instead of
/// 2, 5 and 0, with as many stretched beyond 100 % at 8 (355).
pub(crate) const THROWN_ABOVE: f64 = 16.0;

/// Where a projection starts from (see [`LineSolve::project`]).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Start {
    /// The warm start applied along the start directions.
    Warmed,
    /// At the prediction, the warm start left out for a curvature pass.
    WarmLeftOut,
    /// At the prediction after SHAKE failed this substep, λ = 0.
    Restarted,
    /// As [`Start::Restarted`], in a line tense enough for a curvature pass to pay (see
    /// [`CURVATURE_AFTER_SHAKE_ABOVE`]).
    RestartedTense,
}

/// After SHAKE failed in a substep, the projection that follows starts with a curvature pass
/// (see `curvature`) where some particle's `w Σ μ` from the last substep's multipliers (as for
/// [`SHAKE_STIFFNESS_BELOW`], with rest lengths; a one-sided stick slack at the prediction
/// counts zero, as it is not warm-started) is at least
/// this: a tension that stiff turns the links under Gauss–Newton's feet, and Gauss–Newton from
/// the prediction wanders (the whipping 1000:1 chain's projections after a failure took 8.6
/// passes each). Elsewhere a curvature pass, about five ordinary ones, costs more than it saves.
/// Measured (scratch tests, 5 s at 8 × 1 from horizontal, no damping; Newton passes for bounds
/// of 4 / 8 / 12 / 16 / never): the report's 1000:1 chain 6950 / 7124 / 7628 / 8099 / 10 143;
/// its 200-link chain (equal masses) 5751 / 5602 / 5367 / 5367 / 5367 — from 12 on, bit for bit
/// as without. At 12, valgrind callgrind over the whole run: 1000:1 chain −13.5 %
/// instructions, a 10⁵× load −55 % (30 758 → 12 464 passes), 200 links +0.3 % (this check
/// after its 199 failures; it never reaches the bound, nor does the rope yanked a kilometre in
/// `tests/hard_cases.rs`: their trajectories are unchanged).
pub const CURVATURE_AFTER_SHAKE_ABOVE: f64 = 12.0;

/// A warm start (the last substep's multipliers, see the [module docs](self)) is taken back
/// before the first pass where it moves the particles of a line alone in its island farther
/// (mass-weighted) than this many times their distance from the prediction back to where the
/// substep started. Where the start positions satisfy the constraints (the last substep
/// converged, the pins stand still, the sticks are rigid) the projection — the nearest point
/// that does — never moves them farther than that distance, so such a warm start is no
/// estimate of this substep's multipliers but the impulse of the last one's: a load caught by
/// a rope, whose catch it repeats. Measured on scene 579 of
/// `random_heavy_chains_and_trees_hit_hard_stay_unstretched` (`tests/direct.rs`): a 2700× load
/// falling at 2.5 m/s was caught by its rope in one substep and thrown back up at 3.2 m/s by
/// the next (SHAKE from that warm start): +4950 J, 19 % of the scene's energy scale; with the
/// warm start taken back its energy never rose. Elsewhere the test is a heuristic (a review
/// saw a soft chain released stretched take back 169 of 709 warm starts: the same energy,
/// 669 → 680 passes). At rest the ratio is 1 (the warm start undoes the substep's fall); the
/// report's swinging chains and cloth by lines never reach 2 (the same Newton passes, to the
/// bit). Checked after a projected substep only (see `begin`). Trees are not checked: in a
/// review's scans of random trees the check fired 0–2 times and no result depended on it.
pub const WARM_START_REACH: f64 = 2.0;

/// Gauss–Newton passes a projection takes before full Newton passes (with the constraints'
/// curvature, see `curvature`) take over, where they can. Gauss–Newton does not converge at
/// all on a chain holding a load 10⁵ times a link's mass released from horizontal: it leaves
/// the links 40–90× their length; full Newton takes 3 passes per projected substep there (the
/// C prototype, `report/prototypes/whip_substep.c`, mode `kkt-warm` at `-DTIP=100000.0`).
pub const FULL_NEWTON_AFTER: u32 = 16;

/// After a SHAKE try fails, a line is projected for the next 1, 2, 4, … substeps — doubling
/// with each failed try in a row, up to `2^(this − 1)` (128) — before SHAKE is tried again; a
/// converged SHAKE starts over at 1. A line whose links turn too far for SHAKE in substep after
/// substep (a chain whipping round) stops paying for tries that fail (up to [`SHAKE_PASSES`]
/// passes each), while one that fails now and then is tried again in the next substep but one,
/// as before. Measured (scratch builds, the solver core's 5 s from horizontal, best of 9, no
/// damping): the 1000:1 chain at 2 substeps 3417 → 2175 Newton passes, 11.5–12.2 → 8.8–8.9 ms
/// (a wait of at most 8 substeps: 10.6 ms; 32: 10.0 ms), at 8 substeps 7628 → 7505 passes,
/// 25.4–25.6 → 25.2–25.4 ms; the 200-link chain 2096 → 2105 and 5085 → 4957 passes, 15.3 ms
/// either way at 2, 32.4–33.8 → 31.8–32.0 ms at 8; the double pendulum's passes and energies
/// unchanged at 1, 2 and 8 substeps. What the projected substeps cost is energy: the whipping
/// chain ends the 5 s at 2 substeps with −5050 J instead of −4456 J (its potential scale is
/// 10.3 kJ), at 8 with −1528 J instead of −1521 J. The wait is counted in substeps: at 2 a
/// chain that stops whipping may stay projected, losing energy, for up to 1 s.
pub const SHAKE_BACKOFF_LIMIT: u8 = 8;

// (A wait of `2^(limit − 1)` substeps must fit a `u8`.)
const _: () = assert!(SHAKE_BACKOFF_LIMIT >= 1 && SHAKE_BACKOFF_LIMIT <= 8);

/// A line's SHAKE backoff (see [`SHAKE_BACKOFF_LIMIT`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct ShakeBackoff {
    /// Substeps left before SHAKE is tried again.
    pub wait: u8,
    /// SHAKE tries that failed in a row (at most [`SHAKE_BACKOFF_LIMIT`]).
    pub failures: u8,
}

impl ShakeBackoff {
    /// After one more failed try.
    fn failed(self) -> Self {
        let failures = (self.failures + 1).min(SHAKE_BACKOFF_LIMIT);
        Self {
            wait: 1 << (failures - 1),
            failures,
        }
    }
}

/// How a line is solved in one substep (decided at its start).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) enum LineMode {
    /// Newton on the XPBD projection (current directions).
    #[default]
    Project,
    /// As [`LineMode::Project`], after SHAKE did not converge in this substep: the next substep
    /// is projected too, without trying SHAKE — links that turned too far for it in one
    /// substep mostly do in the next, and a failed try costs up to [`SHAKE_PASSES`] passes.
    /// (So for trees; a line waits longer after failed tries in a row, see
    /// [`SHAKE_BACKOFF_LIMIT`].)
    /// Measured on the report's swinging chains (8 × 1, 5 s from horizontal, no damping;
    /// instructions by callgrind): 1000:1 chain 16 409 → 14 285 Newton passes, −11.8 %
    /// instructions; 200 links 7461 → 6613 passes, −9.4 %; largest strain below 10⁻⁹ either
    /// way. (Waiting two substeps: −9.5 % / −11.6 %.)
    FellBack,
    /// Newton on SHAKE (start-of-substep directions).
    Shake,
    /// A Gauss–Seidel sweep over its sticks: a rigid segment between two immovable particles
    /// is pulled taut or beyond its length (no solution, or a singular system, for Newton).
    Sweep,
}

/// A rigid segment between two immovable particles counts as taut (and is swept) when the
/// particles are this close to its full length (relative).
pub(crate) const TAUT: f64 = 1e-3;

/// Start-of-substep violations (`|C|/L`) above this are corrected without adding velocity (see
/// [`LineSolve::stabilise_start`]).
pub(crate) const STABILISE_ABOVE: f64 = 1e-3;

/// A count of Newton passes, shared by the jobs of a substep.
#[derive(Debug, Default)]
pub(crate) struct PassCounter(pub(crate) AtomicU64);

impl Clone for PassCounter {
    fn clone(&self) -> Self {
        Self(AtomicU64::new(self.0.load(Ordering::Relaxed)))
    }
}

/// Per line stick scratch, indexed like [`LineSet::sticks`](super::LineSet::sticks).
#[derive(Clone, Debug, Default)]
pub(crate) struct LineScratch {
    /// Unit directions at the start of the substep (SHAKE's `r_k`).
    pub start: Vec<DVec3>,
    /// Correction directions `r_k` of the current pass.
    pub direction: Vec<DVec3>,
    /// Forward-eliminated super-diagonal.
    pub upper: Vec<f64>,
    /// Forward-eliminated right-hand side.
    pub rhs: Vec<f64>,
    /// Each stick's multiplier at the end of the last substep (the warm start of the next).
    pub warm: Vec<f64>,
    /// At a line's first stick: how the line is solved this substep.
    pub mode: Vec<LineMode>,
    /// At a line's first stick: when SHAKE is tried again (see [`SHAKE_BACKOFF_LIMIT`]).
    pub backoff: Vec<ShakeBackoff>,
    /// Per tree node (see [`tree`](super::tree)).
    pub trees: Vec<super::tree::Node>,
    /// Per tree node, for a curvature pass (see [`tree`](super::tree)).
    pub tree_curvature: Vec<super::tree::TreeCurvature>,
    /// Per tree node and extra closing stick (see [`Tree::extra_closings`](super::Tree)).
    pub tree_closings: Vec<super::tree::Closing>,
    /// The elimination of a curvature pass (see [`curvature`]).
    pub curvature: Vec<super::kkt::Reduced>,
    /// A unit load's part of each stick's elimination, for lines pinned at both ends (see
    /// [`closure`]).
    pub loads: Vec<super::kkt::Load>,
    /// Per line *particle* (indexed like [`LineSet::particles`](super::LineSet::particles)):
    /// where the substep's prediction put it — for a line sharing particles with others, where
    /// the lines solved before it left them ([`LineSolve::keep_entry`]) — for the fall back, and
    /// (lines alone in their island) for full Newton passes. Written in a substep's first round.
    pub predicted: Vec<DVec3>,
    /// Per line particle: an iterate's positions, kept while a sweep from the prediction
    /// ([`LineSolve::fall_back`]) or a second try from the start of the substep
    /// ([`second_try`]) is tried instead.
    pub kept: Vec<DVec3>,
    /// Per line stick: that iterate's multipliers.
    pub kept_lambda: Vec<f64>,
}

impl LineScratch {
    pub(crate) fn resize(&mut self, n: usize, particles: usize, trees: &super::TreeSet) {
        let tree_nodes = trees.particle.len();
        self.trees.clear();
        self.trees.resize(tree_nodes, super::tree::Node::default());
        self.tree_closings.clear();
        self.tree_closings
            .resize(trees.closing_records(), super::tree::Closing::default());
        self.tree_curvature.clear();
        self.tree_curvature
            .resize(tree_nodes, super::tree::TreeCurvature::default());
        self.start.resize(n, DVec3::ZERO);
        self.direction.resize(n, DVec3::ZERO);
        self.upper.resize(n, 0.0);
        self.rhs.resize(n, 0.0);
        self.curvature.resize(n, super::kkt::Reduced::default());
        self.loads.resize(n, super::kkt::Load::default());
        self.predicted.resize(particles, DVec3::ZERO);
        self.kept.resize(particles, DVec3::ZERO);
        self.kept_lambda.resize(n, 0.0);
        self.warm.clear();
        self.warm.resize(n, 0.0);
        // (Cleared: a line rebuilt at the offset of one that fell back must not inherit it.)
        self.mode.clear();
        self.mode.resize(n, LineMode::Project);
        self.backoff.clear();
        self.backoff.resize(n, ShakeBackoff::default());
    }
}

/// [`LineScratch`] shared by the jobs of a substep (lines of a group share no stick).
#[derive(Clone, Copy)]
pub(crate) struct LineViews<'a> {
    pub start: SharedSlice<'a, DVec3>,
    pub direction: SharedSlice<'a, DVec3>,
    pub upper: SharedSlice<'a, f64>,
    pub rhs: SharedSlice<'a, f64>,
    pub warm: SharedSlice<'a, f64>,
    pub mode: SharedSlice<'a, LineMode>,
    pub backoff: SharedSlice<'a, ShakeBackoff>,
    pub trees: SharedSlice<'a, super::tree::Node>,
    pub tree_curvature: SharedSlice<'a, super::tree::TreeCurvature>,
    pub tree_closings: SharedSlice<'a, super::tree::Closing>,
    pub curvature: SharedSlice<'a, super::kkt::Reduced>,
    pub loads: SharedSlice<'a, super::kkt::Load>,
    pub predicted: SharedSlice<'a, DVec3>,
    pub kept: SharedSlice<'a, DVec3>,
    pub kept_lambda: SharedSlice<'a, f64>,
}

impl<'a> LineViews<'a> {
    pub(crate) fn new(scratch: &'a mut LineScratch) -> Self {
        Self {
            start: SharedSlice::new(&mut scratch.start),
            direction: SharedSlice::new(&mut scratch.direction),
            upper: SharedSlice::new(&mut scratch.upper),
            rhs: SharedSlice::new(&mut scratch.rhs),
            warm: SharedSlice::new(&mut scratch.warm),
            mode: SharedSlice::new(&mut scratch.mode),
            backoff: SharedSlice::new(&mut scratch.backoff),
            trees: SharedSlice::new(&mut scratch.trees),
            tree_curvature: SharedSlice::new(&mut scratch.tree_curvature),
            tree_closings: SharedSlice::new(&mut scratch.tree_closings),
            curvature: SharedSlice::new(&mut scratch.curvature),
            loads: SharedSlice::new(&mut scratch.loads),
            predicted: SharedSlice::new(&mut scratch.predicted),
            kept: SharedSlice::new(&mut scratch.kept),
            kept_lambda: SharedSlice::new(&mut scratch.kept_lambda),
        }
    }
}

/// Everything one line solve reads and writes.
#[derive(Clone, Copy)]
pub(crate) struct LineSolve<'a, 'v> {
    pub position: SharedSlice<'v, DVec3>,
    pub previous: SharedSlice<'v, DVec3>,
    /// Receives every move made to `position` too (set while stabilising the start positions).
    pub mirror: Option<SharedSlice<'v, DVec3>>,
    pub lambda: SharedSlice<'v, f64>,
    pub inverse_mass: &'a [f64],
    pub sticks: &'a Sticks,
    pub scratch: LineViews<'v>,
    /// `1/h²`.
    pub inv_h2: f64,
    /// Correct along the start-of-substep directions (SHAKE) instead of the current ones.
    pub shake: bool,
    /// First round of the substep: λ starts from the warm start, SHAKE is decided.
    pub first_round: bool,
    /// The line is its island's only one. Then start violations above [`STABILISE_ABOVE`] come
    /// from edits and spawns, not from the solve (it ended the last substep converged), and are
    /// corrected on the start positions (see [`LineSolve::stabilise_start`]); and its
    /// projections may take curvature and full Newton passes (see [`LineSolve::project`]).
    pub alone: bool,
}

/// One line's slices of the [`LineSet`](super::LineSet) and where its sticks start there.
pub(crate) struct LineRef<'a> {
    pub particles: &'a [u32],
    pub sticks: &'a [u32],
    pub offset: usize,
    /// Where its particles start in [`LineSet::particles`](super::LineSet::particles).
    pub particle_offset: usize,
}

impl<'a> LineRef<'a> {
    /// The slices of `line` in `set`.
    pub(crate) fn of(line: &Line, set: &'a super::LineSet) -> Self {
        let r = |r: &std::ops::Range<u32>| r.start as usize..r.end as usize;
        Self {
            particles: &set.particles[r(&line.particles)],
            sticks: &set.sticks[r(&line.sticks)],
            offset: line.sticks.start as usize,
            particle_offset: line.particles.start as usize,
        }
    }
}

impl LineRef<'_> {
    /// Particle `j` of the line (`j ≤` its stick count), without a bounds check.
    ///
    /// # Safety
    /// `j < self.particles.len()`.
    #[inline(always)]
    unsafe fn p(&self, j: usize) -> usize {
        // SAFETY: in bounds (caller).
        unsafe { *self.particles.get_unchecked(j) as usize }
    }

    /// Stick `k` of the line, without a bounds check.
    ///
    /// # Safety
    /// `k < self.sticks.len()`.
    #[inline(always)]
    unsafe fn s(&self, k: usize) -> usize {
        // SAFETY: in bounds (caller).
        unsafe { *self.sticks.get_unchecked(k) as usize }
    }
}

/// Stick `k` of a line as one row of the system sees it.
struct Row {
    normal: DVec3,
    c: f64,
    active: bool,
    /// The stick's multiplier at the iterate (released, `Δλ = −λ`, where it is not active).
    lambda: f64,
    kind: StickKind,
    /// `w_a + w_b`.
    inverse_masses: f64,
}

impl LineSolve<'_, '_> {
    /// Solves one line; returns the Newton passes taken.
    ///
    /// # Safety
    /// No other task accesses the line's particles, its sticks' multipliers or its scratch
    /// (nor, with a mirror, the mirror's entries of its particles) while this runs.
    pub(crate) unsafe fn solve(&self, line: &LineRef) -> u32 {
        if line.sticks.is_empty() {
            return 0;
        }
        // SAFETY: this task alone holds the line (this function's contract).
        if let Some(passes) = unsafe { self.solve_lone_stick(line) } {
            return passes;
        }
        self.check(line);
        // SAFETY: this task alone holds the line (this function's contract), and its indices
        // are in bounds (checked just above): the contract of every function called below.
        unsafe {
            // A line alone in its island may start a projection with the constraints' curvature
            // and be rescued by full Newton passes (see [`LineSolve::project`]).
            let rescuable = self.keeps_prediction();
            let curvable = rescuable && self.shake;
            if self.first_round && !self.alone && self.mirror.is_none() {
                self.keep_entry(line);
            }
            let (begun, root) = if self.first_round {
                self.start(line, curvable)
            } else {
                (Begun::LATER_ROUND, None)
            };
            let passes = match self.scratch.mode.get_unchecked(line.offset) {
                LineMode::Sweep => {
                    self.sweep(line);
                    return 0;
                }
                LineMode::Shake => self.shake_or_project(line, &begun, rescuable),
                _ => {
                    // (A root found already means the warm start was left out for it.)
                    let start = if root.is_some() {
                        Start::WarmLeftOut
                    } else {
                        Start::Warmed
                    };
                    let root = match root {
                        None if rescuable => self.curvature_root(line),
                        root => root,
                    };
                    self.project(line, &begun, root, start)
                }
            };
            for (k, &s) in line.sticks.iter().enumerate() {
                self.scratch
                    .warm
                    .set_unchecked(line.offset + k, self.lambda.get_unchecked(s as usize));
            }
            passes
        }
    }

    /// The start of a substep: [`LineSolve::begin`], and the start positions stabilised where
    /// that applies. Without SHAKE this substep, where a curvature pass may follow (`curvable`
    /// and the line has a root for it), the warm start is left out (the pass starts from the
    /// prediction). Returns what `begin` measured and that root.
    ///
    /// # Safety
    /// As for [`LineSolve::solve`], and `line` passed [`LineSolve::check`].
    unsafe fn start(&self, line: &LineRef, curvable: bool) -> (Begun, Option<Root>) {
        // SAFETY: this task alone holds the line, whose indices are in bounds (this function's
        // contract).
        unsafe {
            // (Not while it waits after failed tries, see [`SHAKE_BACKOFF_LIMIT`].)
            let backoff = self.scratch.backoff.get_unchecked(line.offset);
            if backoff.wait > 0 {
                let wait = backoff.wait - 1;
                let counted = ShakeBackoff { wait, ..backoff };
                self.scratch.backoff.set_unchecked(line.offset, counted);
            }
            let shake = self.shake && backoff.wait == 0;
            let root = (curvable && !shake)
                .then(|| self.curvature_root(line))
                .flatten();
            let warm = root.is_none();
            let mut begun = self.begin(line, shake, warm);
            if self.alone
                && begun.violated > STABILISE_ABOVE
                && self.scratch.mode.get_unchecked(line.offset) != LineMode::Sweep
            {
                self.take_back(line);
                self.stabilise_start(line);
                begun = self.begin(line, shake, warm);
            }
            (begun, root)
        }
    }

    /// SHAKE's Newton passes, and where they do not converge (links turned too far for the start
    /// directions) the projection from the prediction instead — with a curvature pass first only
    /// in a tense line ([`CURVATURE_AFTER_SHAKE_ABOVE`]): elsewhere, after SHAKE's passes, it
    /// cost more than it saved (see [`curvature`]). Returns the passes taken.
    ///
    /// # Safety
    /// As for [`LineSolve::start`], which began this substep in [`LineMode::Shake`].
    unsafe fn shake_or_project(&self, line: &LineRef, begun: &Begun, rescuable: bool) -> u32 {
        // SAFETY: as for `start` (this function's contract).
        unsafe {
            let (passes, converged) = self.newton(
                line,
                SHAKE_PASSES,
                SHAKE_CONTRACTION,
                begun.predicted,
                false,
            );
            let backoff = &self.scratch.backoff;
            if converged {
                backoff.set_unchecked(line.offset, ShakeBackoff::default());
                return passes;
            }
            backoff.set_unchecked(line.offset, backoff.get_unchecked(line.offset).failed());
            self.restart_without_shake(line);
            let root = rescuable.then(|| self.curvature_root(line)).flatten();
            // (Measured only where a curvature pass may run, see `project`.)
            let tense = root.is_some()
                && self.within_reach(line, begun)
                && self.warm_stiffness(line) >= CURVATURE_AFTER_SHAKE_ABOVE;
            let start = if tense {
                Start::RestartedTense
            } else {
                Start::Restarted
            };
            passes + self.project(line, begun, root, start)
        }
    }

    /// The projection's Newton passes. Where `root` is given (the line is alone in its island
    /// and has a root for the curvature elimination, see [`curvature`]) and the prediction is
    /// within [`CURVATURE_BELOW`]: the first pass takes the constraints' curvature where the
    /// substep began projected or SHAKE failed in a tense line (not `Restarted`), and where
    /// Gauss–Newton has not converged after
    /// [`FULL_NEWTON_AFTER`] passes, full Newton passes take over; a result on a far root, or
    /// unconverged while the line's pins stand still, gets a [`second_try`] (beyond
    /// [`CURVATURE_BELOW`] too where the start of the substep is on its constraints). Returns the
    /// passes taken.
    ///
    /// # Safety
    /// As for [`LineSolve::start`].
    unsafe fn project(
        &self,
        line: &LineRef,
        begun: &Begun,
        root: Option<Root>,
        start: Start,
    ) -> u32 {
        // SAFETY: as for `start` (this function's contract).
        unsafe {
            // (Both only where the prediction is within `CURVATURE_BELOW`: beyond, it is a jump,
            // whose energy Gauss–Newton's passes take out — but for a second try from a start on
            // its constraints, below.)
            let rescuable = root;
            let root = root.filter(|_| self.within_reach(line, begun));
            let curving = root.filter(|_| self.shake && start != Start::Restarted);
            let mut passes = 0;
            let mut predicted = begun.predicted;
            match curving {
                Some(root) => {
                    if start == Start::Warmed {
                        self.take_back(line);
                    }
                    self.curvature_pass(line, root);
                    (passes, predicted) = (1, f64::INFINITY);
                }
                // (Left out for a curvature pass that does not apply after all.)
                None if start == Start::WarmLeftOut => _ = self.begin(line, false, true),
                None => {}
            }
            // (After a curvature pass the next pass measures the error on its way: one pass
            // seldom converges.)
            let fused = curving.is_some();
            let budget = if root.is_some() {
                FULL_NEWTON_AFTER
            } else {
                MAX_PASSES
            };
            let (taken, mut converged) =
                self.newton(line, budget - passes, f64::INFINITY, predicted, fused);
            passes += taken;
            if let (false, Some(root)) = (converged, root) {
                let (taken, again) = self.full_newton(line, root, MAX_PASSES - passes);
                (passes, converged) = (passes + taken, again);
            }
            // (On a far root, or unconverged: see [`second_try`]. Beyond `CURVATURE_BELOW` only
            // from a start on its constraints.)
            let retry = root.or_else(|| {
                rescuable.filter(|_| self.violation_at(line, &self.previous) < NEARLY_ON)
            });
            if let Some(root) = retry {
                let (taken, again) = self.second_try(line, root, converged);
                (passes, converged) = (passes + taken, again);
            }
            // (Worse off than the prediction, or its loads thrown: see the module's docs.)
            if !converged
                && self.keeps_entry()
                && (self.residual(line) > begun.predicted || self.thrown(line))
            {
                self.fall_back(line);
            }
            passes
        }
    }

    /// Panics unless every index of `line` is in bounds of the slices this solve reads and
    /// writes. The passes below then access them unchecked: one check per line and solve instead
    /// of one per access (the checks were 17 % of a line solve's instructions).
    fn check(&self, line: &LineRef) {
        let m = line.sticks.len();
        let mirror = self.mirror.map_or(usize::MAX, |mirror| mirror.len());
        let particles = [
            self.position.len(),
            self.previous.len(),
            self.inverse_mass.len(),
        ]
        .into_iter()
        .fold(mirror, usize::min);
        let most = |indices: &[u32]| indices.iter().copied().max().map_or(0, |i| i as usize + 1);
        assert!(
            line.particles.len() == m + 1 && most(line.particles) <= particles,
            "a line's particles are out of bounds"
        );
        let sticks = &self.sticks;
        let stick_count = [
            sticks.rest_length.len(),
            sticks.compliance.len(),
            sticks.kind.len(),
        ]
        .into_iter()
        .fold(self.lambda.len(), usize::min);
        assert!(
            most(line.sticks) <= stick_count,
            "a line's sticks are out of bounds"
        );
        let v = self.scratch;
        let scratch = [
            v.start.len(),
            v.direction.len(),
            v.upper.len(),
            v.rhs.len(),
            v.curvature.len(),
            v.loads.len(),
            v.kept_lambda.len(),
        ]
        .into_iter()
        .fold(v.warm.len().min(v.mode.len()), usize::min)
        .min(v.backoff.len());
        let per_particle = v.predicted.len().min(v.kept.len());
        assert!(
            line.offset + m <= scratch && line.particle_offset + m < per_particle,
            "a line's scratch is out of bounds"
        );
    }

    /// Inverse mass of particle `p`.
    ///
    /// # Safety
    /// `p` is a particle of a line that passed [`LineSolve::check`].
    #[inline(always)]
    unsafe fn w(&self, p: usize) -> f64 {
        // SAFETY: in bounds (caller).
        unsafe { *self.inverse_mass.get_unchecked(p) }
    }

    /// Rest length of stick `s`.
    ///
    /// # Safety
    /// `s` is a stick of a line that passed [`LineSolve::check`].
    #[inline(always)]
    unsafe fn rest(&self, s: usize) -> f64 {
        // SAFETY: in bounds (caller).
        unsafe { *self.sticks.rest_length.get_unchecked(s) }
    }

    /// Compliance of stick `s`.
    ///
    /// # Safety
    /// As for [`LineSolve::rest`].
    #[inline(always)]
    unsafe fn compliance(&self, s: usize) -> f64 {
        // SAFETY: in bounds (caller).
        unsafe { *self.sticks.compliance.get_unchecked(s) }
    }

    /// Kind of stick `s`.
    ///
    /// # Safety
    /// As for [`LineSolve::rest`].
    #[inline(always)]
    unsafe fn kind(&self, s: usize) -> StickKind {
        // SAFETY: in bounds (caller).
        unsafe { *self.sticks.kind.get_unchecked(s) }
    }
}

#[cfg(test)]
mod backoff_tests {
    use super::{SHAKE_BACKOFF_LIMIT, ShakeBackoff};

    /// Failed tries in a row wait 1, 2, 4, … substeps, up to `2^(limit − 1)`; the count starts
    /// over from a reset (a converged SHAKE).
    #[test]
    fn waits_double_up_to_the_limit() {
        let mut backoff = ShakeBackoff::default();
        let mut waits = Vec::new();
        for _ in 0..10 {
            backoff = backoff.failed();
            waits.push(backoff.wait);
        }
        assert_eq!(waits, [1, 2, 4, 8, 16, 32, 64, 128, 128, 128]);
        assert_eq!(backoff.failures, SHAKE_BACKOFF_LIMIT);
        assert_eq!(ShakeBackoff::default().failed().wait, 1);
    }
}
