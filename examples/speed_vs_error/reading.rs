//! The written reading, computed from the results: which preset the data supports, where seed-style
//! iteration loses to substeps and by how much, what tethers and XPBD buy, and how the plot reads.
//! No number in it is typed in: every figure comes from a record of this run.

use crate::Results;
use crate::analysis::{error, exponents, fixed, on_front, pareto, record, shown, step_cost, times};
use crate::report::{format_value, significant};
use crate::sim::{Law, Setting, TIMESTEP};
use crate::sweep::{Record, SceneResult};
use bevy_verlet_physics::solver::Method;
use std::fmt::Write;

/// Cost budget of the game-default rule: the 50 × 50 cloth (4900 sticks) may take this many
/// milliseconds of one core per 64 Hz fixed step (6 % of a 60 fps frame).
pub const GAME_BUDGET_MS_PER_STEP: f64 = 1.0;

/// A pass line an accurate preset must meet (the numerics reference, §6).
struct PassLine<'a> {
    /// Scene measured.
    scene: &'a SceneResult,
    /// Index of the metric.
    metric: usize,
    /// The line: `|value| ≤ limit`, or `value ≥ limit` when `at_least`.
    limit: f64,
    /// Whether the value must reach the limit rather than stay under it.
    at_least: bool,
    /// Description.
    what: &'static str,
}

impl PassLine<'_> {
    fn value(&self, setting: &Setting) -> f64 {
        self.scene
            .get(setting)
            .map_or(f64::NAN, |r| r.values[self.metric])
    }

    fn passes(&self, setting: &Setting) -> bool {
        let v = self.value(setting);
        if self.at_least {
            v >= self.limit
        } else {
            v.abs() <= self.limit
        }
    }
}

/// The scenes the presets are judged on: `(short name, result)`.
fn judged(results: &Results) -> Vec<(&'static str, &SceneResult)> {
    vec![
        ("pendulum 5°", &results.pendulum[0]),
        ("pendulum 120°", &results.pendulum[1]),
        ("double pendulum", &results.double_pendulum),
        ("catenary", &results.catenary),
        ("heavy tip", &results.heavy_tip),
        ("cloth", &results.cloth),
        ("spring 10 Hz", &results.springs[1]),
    ]
}

/// The summary section.
pub fn summary(results: &Results, budgets: &[u32]) -> String {
    let mut out = String::new();
    let default = Setting::substeps(8, 1);
    let accurate = Setting::substeps(32, 1);
    let cloth = &results.cloth;

    // The game-budget rule.
    let affordable: Vec<u32> = budgets
        .iter()
        .copied()
        .filter(|&s| {
            record(cloth, Setting::substeps(s, 1))
                .is_some_and(|r| step_cost(r) <= GAME_BUDGET_MS_PER_STEP)
        })
        .collect();
    let game = affordable.last().map(|&s| Setting::substeps(s, 1));
    // The accuracy rule.
    let lines = [
        PassLine {
            scene: &results.pendulum[1],
            metric: 0,
            limit: 0.02,
            at_least: false,
            what: "pendulum 120° period within 2 %",
        },
        PassLine {
            scene: &results.double_pendulum,
            metric: 1,
            limit: 0.6,
            at_least: true,
            what: "double pendulum keeps ≥ 60 % of its energy for 10 s",
        },
        PassLine {
            scene: &results.catenary,
            metric: 0,
            limit: 0.01,
            at_least: false,
            what: "catenary sag within 1 %",
        },
        PassLine {
            scene: cloth,
            metric: 0,
            limit: 0.01,
            at_least: false,
            what: "untethered cloth max strain ≤ 1 %",
        },
        PassLine {
            scene: &results.springs[1],
            metric: 0,
            limit: 0.01,
            at_least: false,
            what: "10 Hz spring frequency within 1 %",
        },
    ];
    let precise = budgets
        .iter()
        .map(|&s| Setting::substeps(s, 1))
        .find(|s| lines.iter().all(|l| l.passes(s)));

    out.push_str("## Reading\n\n### Presets\n\n");
    let _ = writeln!(
        out,
        "Rule for the default: the most accurate S × 1 setting whose 50 × 50 cloth step (4900 \
         sticks, no tethers) costs at most {GAME_BUDGET_MS_PER_STEP} ms of one core per 64 Hz \
         fixed step on this machine — 6 % of a 60 fps frame — counting the solver thread's CPU \
         time (median), which, unlike wall time, does not grow when other processes load the \
         machine. Rule for the accurate preset: the cheapest S × 1 setting that meets every pass \
         line of the numerics reference (§6): {}.\n",
        lines.iter().map(|l| l.what).collect::<Vec<_>>().join("; ")
    );
    match game {
        Some(g) => {
            let r = record(cloth, g).expect("affordable settings were run");
            let _ = writeln!(
                out,
                "* **Default: the data supports {}** (cloth step {} ms CPU, {} projections per \
                 step). The crate's default is 8 × 1: {}.",
                g.label(),
                significant(step_cost(r)),
                significant(r.projections_per_second * TIMESTEP),
                if g == default {
                    "keep it".to_string()
                } else {
                    format!("the data says change it to {}", g.label())
                }
            );
        }
        None => out.push_str("* **Default:** no S × 1 setting fits the budget on this machine.\n"),
    }
    match precise {
        Some(p) => {
            let _ = writeln!(
                out,
                "* **Accurate: the data supports {}**, the cheapest setting meeting every pass line. \
                 The crate's accurate preset is 32 × 1: {}.",
                p.label(),
                if p == accurate {
                    "keep it".to_string()
                } else {
                    format!("the data says change it to {}", p.label())
                }
            );
        }
        None => out.push_str("* **Accurate:** no swept S × 1 setting meets every pass line.\n"),
    }
    let fronts: Vec<&str> = judged(results)
        .into_iter()
        .filter(|(_, r)| on_front(r, default))
        .map(|(name, _)| name)
        .collect();
    let which = if fronts.is_empty() {
        String::new()
    } else {
        format!(": {}", fronts.join(", "))
    };
    let _ = writeln!(
        out,
        "* 8 × 1 is on the wall-time Pareto front (untethered, all families) of {} of {} scenes{which}.",
        fronts.len(),
        judged(results).len(),
    );
    out.push_str("\nPass lines at the presets and their neighbours (✓ = met):\n\n");
    out.push_str("| pass line |");
    let shown_settings: Vec<Setting> = budgets
        .iter()
        .filter(|&&s| s >= 4)
        .map(|&s| Setting::substeps(s, 1))
        .collect();
    for s in &shown_settings {
        let _ = write!(out, " {} |", s.label());
    }
    out.push_str("\n|---|");
    out.push_str(&"---:|".repeat(shown_settings.len()));
    out.push('\n');
    for line in &lines {
        let _ = write!(out, "| {} |", line.what);
        for s in &shown_settings {
            let unit = line.scene.columns[line.metric].unit;
            let mark = if line.passes(s) { " ✓" } else { "" };
            let _ = write!(out, " {}{mark} |", format_value(line.value(s), unit));
        }
        out.push('\n');
    }
    let _ = write!(out, "| cloth 50 × 50: CPU ms per fixed step |");
    for s in &shown_settings {
        let ms = record(cloth, *s).map_or(f64::NAN, step_cost);
        let _ = write!(out, " {} |", significant(ms));
    }
    let _ = write!(out, "\n| cloth 50 × 50: wall ms per fixed step |");
    for s in &shown_settings {
        let ms = record(cloth, *s).map_or(f64::NAN, |r| r.ms_per_second * TIMESTEP);
        let _ = write!(out, " {} |", significant(ms));
    }
    out.push_str("\n\n");
    out.push_str(&iterations_lose(results, budgets));
    out.push_str(&plot_reading(results, budgets));
    out
}

/// A short reading of the plot.
fn plot_reading(results: &Results, budgets: &[u32]) -> String {
    let mut out = String::new();
    out.push_str("### Reading the plot\n\n");
    let flat: Vec<&str> = judged(results)
        .into_iter()
        .filter(|(_, r)| exponents(r).1.abs() < 0.05)
        .map(|(name, _)| name)
        .collect();
    let chains: Vec<String> = judged(results)
        .into_iter()
        .filter(|(_, r)| exponents(r).1.abs() >= 0.05)
        .map(|(name, r)| {
            let (a, b) = exponents(r);
            format!("{name} a = {}, b = {}", fixed(a), fixed(b))
        })
        .collect();
    // Which settings make up the fronts.
    let max = budgets.iter().copied().max().unwrap_or(64);
    let (mut single, mut split, mut seed, mut one) = (0, 0, 0, 0);
    // For split points on a front: ln(cost ratio), ln(error ratio) against (S·m) × 1.
    let (mut cost_log, mut error_log, mut pairs) = (0.0, 0.0, 0);
    for (_, r) in judged(results) {
        let records: Vec<&Record> = r
            .records
            .iter()
            .filter(|x| {
                !x.setting.tethers
                    && x.setting.law == Law::Xpbd
                    && x.setting.method == Method::Sweep
            })
            .collect();
        let records: Vec<&Record> = records
            .into_iter()
            .filter(|x| x.setting.budget() <= max)
            .collect();
        for i in pareto(&records) {
            match (records[i].setting.substeps, records[i].setting.iterations) {
                (1, 1) => one += 1,
                (_, 1) => single += 1,
                (1, _) => seed += 1,
                (substeps, iterations) => {
                    split += 1;
                    let same_budget = Setting::substeps(substeps * iterations, 1);
                    if let Some(single) = record(r, same_budget) {
                        let point = records[i];
                        cost_log += (point.ms_per_second / single.ms_per_second).ln();
                        error_log += (point.error() / single.error()).ln();
                        pairs += 1;
                    }
                }
            }
        }
    }
    let _ = write!(
        out,
        "Each panel plots one scene's error against wall time per simulated second, both \
         logarithmic; lower left is better. The red 1 × N line (the seeds' style) is flat for {}: \
         there is nothing left to iterate on, and the error that remains is the time step's, \
         which only substeps reduce. Where many constraints are coupled (chains, cloth) \
         iterations do help, but less than substeps (error ∝ S^−a along S × 1, ∝ N^−b along \
         1 × N): {}. \
         On the wall-time Pareto fronts (black dashed line, ringed points) of the {} rigid \
         scenes without tethers, counting only budgets up to {max} that every family covers, \
         {single} points are S × 1, {split} are S × 2 or S × 4, {seed} are 1 × N with N > 1, \
         and {one} are 1 × 1 (the cheapest run of every family).",
        flat.join(", "),
        chains.join("; "),
        judged(results).len(),
    );
    if pairs > 0 {
        let _ = write!(
            out,
            " The S × m points on a front are there because they are slightly cheaper than the \
             S·m × 1 run of the same budget (they skip integration passes), not more accurate: \
             against it they take {} the wall time for {} the error (geometric means).",
            times((cost_log / pairs as f64).exp(), 1.0),
            times((error_log / pairs as f64).exp(), 1.0),
        );
    }
    // Splitting a budget between substeps and iterations.
    let k = budgets.iter().copied().find(|&k| k >= 16).unwrap_or(64);
    let mut ranges = Vec::new();
    for s in [
        Setting::substeps(k / 2, 2),
        Setting::substeps(k / 4, 4),
        Setting::seed(k),
    ] {
        let ratios: Vec<f64> = judged(results)
            .into_iter()
            .map(|(_, r)| error(r, s) / error(r, Setting::substeps(k, 1)))
            .filter(|x| x.is_finite())
            .collect();
        if let (Some(lo), Some(hi)) = (
            ratios.iter().copied().reduce(f64::min),
            ratios.iter().copied().reduce(f64::max),
        ) {
            ranges.push(format!(
                "{} leaves {}–{}× its error",
                s.label(),
                significant(lo),
                significant(hi)
            ));
        }
    }
    if !ranges.is_empty() {
        let _ = write!(
            out,
            " At the same budget as {k} × 1, {} (range over the seven scenes; below 1 means \
             the split did better there).",
            ranges.join(", ")
        );
    }
    out.push_str("\n\n");
    out
}

/// "Where seed-style iteration loses to substeps, by how much."
fn iterations_lose(results: &Results, budgets: &[u32]) -> String {
    let mut out = String::new();
    let low = budgets.iter().copied().find(|&k| k >= 8).unwrap_or(8);
    let high = *budgets.last().unwrap_or(&64);
    out.push_str("### Iterations against substeps\n\n");
    let _ = writeln!(
        out,
        "Same budget (projections per constraint per fixed step), spent as the seeds do (1 × N) \
         or as substeps (S × 1). \"1 × N to match 8 × 1\" is the cheapest swept iteration count \
         whose error is at most the default's, with its wall time relative to 8 × 1. `a` and \
         `b` are log–log slopes from budget 4 (or the first swept above) to {high}: the error \
         falls as `S^−a` along S × 1 and as `N^−b` along 1 × N. Where `error ≈ C·S^−a·N^−b` \
         holds with one `C` — the heavy tip is an example: 8 × 1, 4 × 4 and 1 × 64, all with \
         S²·N = 64, leave {}, {} and {} — moving a fixed budget S·N from iterations to substeps \
         divides the error by `S^(a−b)`.\n",
        shown(&results.heavy_tip, Setting::substeps(8, 1)),
        shown(&results.heavy_tip, Setting::substeps(4, 4)),
        shown(&results.heavy_tip, Setting::seed(64)),
    );
    let _ = writeln!(
        out,
        "| scene (error) | 1×{low} | {low}×1 | 1×{low} / {low}×1 | 1×{high} | {high}×1 | 1×{high} / {high}×1 | 1 × N to match 8 × 1 | a (substeps) | b (iterations) |"
    );
    out.push_str("|---|---:|---:|---:|---:|---:|---:|---|---:|---:|\n");
    for (name, r) in judged(results) {
        let (seed_low, sub_low) = (Setting::seed(low), Setting::substeps(low, 1));
        let (seed_high, sub_high) = (Setting::seed(high), Setting::substeps(high, 1));
        let target = error(r, Setting::substeps(8, 1));
        let matching = budgets
            .iter()
            .map(|&n| Setting::seed(n))
            .find(|s| error(r, *s) <= target);
        let matching = match matching {
            Some(s) => format!(
                "{} ({} the wall time)",
                s.label(),
                times(
                    record(r, s).map_or(f64::NAN, |x| x.ms_per_second),
                    record(r, Setting::substeps(8, 1)).map_or(f64::NAN, |x| x.ms_per_second)
                )
            ),
            None => format!("never up to 1×{high}"),
        };
        let _ = writeln!(
            out,
            "| {name} ({}) | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.columns[0].name,
            shown(r, seed_low),
            shown(r, sub_low),
            times(error(r, seed_low), error(r, sub_low)),
            shown(r, seed_high),
            shown(r, sub_high),
            times(error(r, seed_high), error(r, sub_high)),
            matching,
            fixed(exponents(r).0),
            fixed(exponents(r).1),
        );
    }
    out.push('\n');
    // Splitting a budget between substeps and iterations.
    let k = budgets.iter().copied().find(|&k| k >= 16).unwrap_or(high);
    let splits: Vec<Setting> = [2u32, 4]
        .iter()
        .filter(|&&m| k % m == 0)
        .map(|&m| Setting::substeps(k / m, m))
        .collect();
    if splits.iter().all(|s| record(&results.cloth, *s).is_some()) {
        let _ = writeln!(
            out,
            "Splitting a budget of {k} between substeps and iterations (error relative to {k} × 1):\n"
        );
        let _ = write!(out, "| scene |");
        for s in &splits {
            let _ = write!(out, " {} |", s.label());
        }
        let _ = writeln!(out, " 1×{k} |");
        out.push_str("|---|");
        out.push_str(&"---:|".repeat(splits.len() + 1));
        out.push('\n');
        for (name, r) in judged(results) {
            let base = error(r, Setting::substeps(k, 1));
            let _ = write!(out, "| {name} |");
            for s in splits.iter().chain([&Setting::seed(k)]) {
                let _ = write!(out, " {} |", times(error(r, *s), base));
            }
            out.push('\n');
        }
        out.push('\n');
    }
    out
}
