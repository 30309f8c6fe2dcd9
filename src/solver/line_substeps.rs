//! [`StepConfig::line_substeps`](super::StepConfig::line_substeps): tree-shaped islands solved
//! by lines — chains, ropes, pendulums, trees, what [`Method::Auto`](super::Method::Auto) puts on
//! lines — may take fewer substeps than the step. Their solve is exact at any substep count
//! (see [`direct`](super::direct)), so fewer substeps cost them no stretch, only accuracy in
//! time, and SHAKE keeps their energy at 2 substeps (the crate README, "Configuration"). That
//! accuracy depends on the substep's length, not on the count: a fixed step longer than
//! [`LINE_SUBSTEP_LONGEST`] (1/64 s) gives them more substeps ([`line_substep_count`]).
//!
//! What fewer substeps do cost is robustness under hits: a load kicked hard moves many link
//! lengths in one long substep, and the Newton passes then start far from the constraints. So
//! an island takes the shorter count only in steps where no rigid stick of it, its ends moving
//! on at their velocities — a pinned end towards its pin's target — for one such substep, would
//! stretch by more than [`HIT_ABOVE`] times its length or have its ends cross (`hit_hard`); otherwise it
//! takes the step's count, with its Verlet state re-expressed for it
//! ([`resubstep`](super::resubstep), velocities kept). A rope carried along by its pin moves
//! with it and is not hit; a pin jerked away from its rope is. An island with a spring too
//! stiff for the longer substep ([`SPRING_STIFFER_THAN`]) keeps the step's count in every step,
//! and so does one attached to another engine's body
//! ([`Solver::attached`](super::Solver::attached); more where the bodies take more,
//! [`Island::steps_with_bodies`](super::Island::steps_with_bodies)): it steps with the body, whose coupling
//! keeps momentum best substep by substep (a 0.1 kg knot of a rope riding a spinning 1 kg
//! avian box: 2·10⁻⁶ of the momentum lost at the box's 8 substeps, 3·10⁻⁵ with 2 of its own
//! from an `IslandOverride` — 12 % before a knot was met half way from a longer substep too;
//! `tests/avian2d.rs`).
//!
//! ```
//! use bevy_verlet_physics::solver::{Solver, StepConfig, StickKind};
//! use glam::DVec3;
//! let mut solver = Solver::default();
//! let pin = solver.add_particle(DVec3::ZERO, 0.0);
//! solver.pin(pin, DVec3::ZERO);
//! let bob = solver.add_particle(DVec3::X, 1.0);
//! solver.sticks.push([pin, bob], 1.0, 0.0, StickKind::Equal, f64::INFINITY, 0);
//! solver.organize();
//! let config = StepConfig { line_substeps: Some(2), ..StepConfig::default() };
//! solver.step(&config);
//! assert_eq!(solver.state_substep_of(bob), Some(config.timestep / 2.0));
//! // Hit hard: 200 m/s away from the pin would stretch the 1 m stick by 1.56 m in 1/128 s.
//! let h = config.timestep / 2.0;
//! solver.particles.previous[bob as usize] -= DVec3::X * 200.0 * h;
//! solver.step(&config);
//! assert_eq!(solver.state_substep_of(bob), Some(config.timestep / 8.0));
//! ```

use super::step::range;
use super::{Island, Particles, Pins, StepConfig, StickKind, Sticks};
use glam::DVec3;
use std::ops::Range;

/// The largest relative stretch a rigid stick may reach in one substep of
/// [`StepConfig::line_substeps`](super::StepConfig::line_substeps), its ends moving on at their
/// velocities, for its island to take that count in a step — and (rigid sticks and struts) the
/// largest shrink, 1 being its ends crossing (see the [module docs](self)): beyond, the step is
/// a hit rather than motion, and the island takes the step's substeps. Swinging under gravity
/// stays far below it (a stick turning by `θ` per substep stretches by about `θ²/2`: 0.14 at
/// 30°). Measured with the generator of `random_heavy_scene` (`tests/direct.rs`: chains and
/// trees, loads up to 10⁴ times a link, one or two pins, kicked by up to 30 m/s on half of
/// them, 1200 seeds → 1033 scenes, 2 s), a scratch scan: at 2 substeps and no guard, 7 scenes
/// ended beyond 1 % strain (up to 1100 times a link's length) — they had reached a stretch of
/// 2.3–13 in the step of the kick, where all but 3 of the others (4.1–6.3) stayed below 2.0.
/// With the step at 8 substeps and `line_substeps` 2 guarded at 1.0 none fails: largest strain
/// 1.7·10⁻⁴ (8 substeps throughout: 1.6·10⁻⁵), energy never more than 0.28 % of its scale above
/// its start; 909 of the 132 224 steps, in 486 scenes (the kicked ones), take 8 substeps
/// (`random_heavy_chains_and_trees_hit_hard_at_two_line_substeps_stay_unstretched` with
/// `SCAN_SCENES=1200`).
pub const HIT_ABOVE: f64 = 1.0;

/// A spring (a stick with compliance `α > 0`) whose `(ωh)² = (w_a + w_b)·h²/α` over a substep
/// `h` of [`StepConfig::line_substeps`](super::StepConfig::line_substeps) exceeds this keeps its
/// island at the step's substeps. Verlet is stable only for `ωh < 2`; this keeps the margin of
/// [`SHAKE_STIFFNESS_BELOW`](super::direct::SHAKE_STIFFNESS_BELOW) (`2 w Σ μ < 3`). Measured
/// (scratch scans of the generator of `random_heavy_scene`, half the sticks springs of
/// 10⁻⁵ m/N, 1200 seeds → 1041 scenes): at 2 substeps without it 3 scenes gained 0.24–0.46 of
/// their energy scale (chains of 1 kg links on such springs: `(ωh)²` = 12); at 8 substeps at
/// most 0.009.
pub const SPRING_STIFFER_THAN: f64 = 3.0;

/// The longest substep (s) of [`StepConfig::line_substeps`](super::StepConfig::line_substeps),
/// unless that takes more than the step's own substeps: Bevy's default fixed step, 1/64 s. A
/// longer fixed step gives its lines more substeps, up to the step's own
/// ([`line_substep_count`]): their solve is exact at any substep, but their motion is not — a
/// 1 m pendulum's period at 2 Hz with 2 line substeps of 0.25 s was 2.7 % short, 0.098 % at
/// the step's 8 (`very_small_and_very_large_fixed_timesteps`, `tests/hard_cases.rs`).
pub const LINE_SUBSTEP_LONGEST: f64 = 1.0 / 64.0;

/// [`Island::keeps_step_substeps`] for this step: whether `island`, which could take
/// [`StepConfig::line_substeps`] (fewer than the step's substeps, no override of its own), holds
/// a particle attached to another engine's body (`attached`, see
/// [`Solver::attached`](super::Solver::attached)), or is hit hard or holds a spring too stiff
/// for them ([`hit_hard`]); `false` where it could not take them. `unset`: the substep of a
/// Verlet state not yet set per island
/// ([`Solver::verlet_substep`](super::Solver::verlet_substep), or the step's).
pub(crate) fn keeps_step_substeps(
    island: &Island,
    arrays: (&Particles, &Sticks, &Pins),
    attached: bool,
    config: &StepConfig,
    unset: f64,
) -> bool {
    let Some(n) = line_substep_count(config) else {
        return false;
    };
    if n >= config.substeps || island.settings.is_some() || !island.takes_line_substeps() {
        return false;
    }
    if attached {
        return true;
    }
    let h_state = island.state_substep_or(unset);
    let h_line = config.timestep / n as f64;
    let ranges = (range(&island.sticks), range(&island.pins));
    hit_hard(arrays, ranges, (h_state, h_line, config.timestep))
}

/// The substeps a step of `config` gives an island that takes
/// [`StepConfig::line_substeps`](super::StepConfig::line_substeps) `Some(n)`: `n` (at least 1),
/// more where a substep would be longer than [`LINE_SUBSTEP_LONGEST`], never more than
/// `config.substeps`; `None` without `line_substeps`.
///
/// ```
/// use bevy_verlet_physics::solver::{line_substeps::line_substep_count, StepConfig};
/// let at_64_hz = StepConfig { line_substeps: Some(2), ..StepConfig::default() };
/// assert_eq!(line_substep_count(&at_64_hz), Some(2));
/// // A 2 Hz step: substeps of 1/64 s at most, no more than the step's 8.
/// let at_2_hz = StepConfig { timestep: 0.5, ..at_64_hz };
/// assert_eq!(line_substep_count(&at_2_hz), Some(8));
/// let at_16_hz = StepConfig { timestep: 1.0 / 16.0, ..at_64_hz };
/// assert_eq!(line_substep_count(&at_16_hz), Some(4));
/// ```
pub fn line_substep_count(config: &StepConfig) -> Option<u32> {
    let n = config.line_substeps?.max(1);
    if n >= config.substeps {
        return Some(n);
    }
    // (The margin keeps a step of exactly that length at one substep.)
    let fitting = (config.timestep / LINE_SUBSTEP_LONGEST * (1.0 - 1e-9)).ceil();
    let needed = if fitting >= 1.0 {
        fitting.min(u32::MAX as f64) as u32
    } else {
        1
    };
    Some(n.max(needed).min(config.substeps))
}

/// Whether one of the sorted `slots` is in `particles`.
pub(crate) fn holds_any(particles: &Range<u32>, slots: &[u32]) -> bool {
    let first = slots.partition_point(|&slot| slot < particles.start);
    slots.get(first).is_some_and(|&slot| slot < particles.end)
}

/// Whether a rigid stick in `sticks` would stretch by more than [`HIT_ABOVE`] times its
/// length in a substep of `h_line`, or (rigid sticks and struts) have its ends cross, its ends
/// moving on at their velocities `(x − x*)/h_state` — an immovable end held by one of `pins`
/// towards its target, which it reaches over the step of length `step` (rope links only by
/// stretching; springs, torn sticks and sticks of length 0 left out).
pub(crate) fn hit_hard(
    (particles, sticks, pins): (&Particles, &Sticks, &Pins),
    (stick_range, pin_range): (Range<usize>, Range<usize>),
    (h_state, h_line, step): (f64, f64, f64),
) -> bool {
    let ahead = h_line / h_state;
    let (x, previous) = (&particles.position, &particles.previous);
    // Pins are sorted by particle (`Solver::organize`); a particle pinned twice follows its last.
    let held = &pins.particle[pin_range.clone()];
    let moved = |p: usize| {
        if particles.inverse_mass[p] > 0.0 {
            return x[p] - previous[p];
        }
        let end = held.partition_point(|&q| q as usize <= p);
        match end.checked_sub(1) {
            Some(k) if held[k] as usize == p => {
                (pins.to[pin_range.start + k] - x[p]) * (h_state / step)
            }
            _ => DVec3::ZERO,
        }
    };
    stick_range.into_iter().any(|i| {
        let (kind, rest) = (sticks.kind[i], sticks.rest_length[i]);
        let [a, b] = sticks.ends()[i].map(|p| p as usize);
        let compliance = sticks.compliance[i];
        if compliance > 0.0 && kind != StickKind::Torn {
            let w = particles.inverse_mass[a] + particles.inverse_mass[b];
            return w * h_line * h_line / compliance > SPRING_STIFFER_THAN;
        }
        // (A stick of length 0 has no strain to measure, as in `Sticks::strain`.)
        if compliance != 0.0 || kind == StickKind::Torn || rest == 0.0 {
            return false;
        }
        let (now, ahead) = (x[b] - x[a], (moved(b) - moved(a)) * ahead);
        let stretch = (now + ahead).length() / rest - 1.0;
        // Along the stick's present direction: below 0 where its ends would cross.
        let along = now.normalize_or_zero().dot(now + ahead) / rest;
        let violation = match kind {
            StickKind::AtMost => stretch,
            StickKind::AtLeast => 1.0 - along,
            _ => stretch.max(1.0 - along),
        };
        // (A NaN counts as a hit: the step's own count, as without `line_substeps`.)
        violation > HIT_ABOVE || violation.is_nan()
    })
}
