//! The smaller findings, each with its numbers from this run: what tethers buy, XPBD compliance
//! against plain per-pass stiffness, whether the scenes at rest had settled, and units and
//! precision (metres against pixels, `f64` against an `f32` loop).

use crate::Results;
use crate::analysis::{record, shown, times};
use crate::report::{format_value, significant};
use crate::sim::{Law, Setting, Unit};
use std::fmt::Write;

/// Tethers, laws, settling and precision: short readings with their numbers.
pub fn extras(results: &Results) -> String {
    let mut out = String::new();
    let default = Setting::substeps(8, 1);
    out.push_str("### Tethers\n\n");
    for (name, r) in [
        ("cloth", &results.cloth),
        ("heavy tip", &results.heavy_tip),
        ("catenary", &results.catenary),
    ] {
        let (plain, tethered) = (record(r, default), record(r, default.with_tethers()));
        if let (Some(a), Some(b)) = (plain, tethered) {
            let unit = r.columns[0].unit;
            let _ = writeln!(
                out,
                "* {name} at 8 × 1: {} {} without tethers, {} with (wall time {}).",
                r.columns[0].name,
                format_value(a.values[0], unit),
                format_value(b.values[0], unit),
                times(b.ms_per_second, a.ms_per_second)
            );
        }
    }
    out.push_str(
        "\nTethers bound each particle's distance to its two nearest pins. For a chain or cloth \
         hanging from pins along one edge that bound is the whole stretch, so it vanishes at \
         any budget; between two pins (the catenary, a slack rope) it removes only part of the \
         shape error; it does nothing for swinging dynamics.\n\n",
    );

    out.push_str("### XPBD compliance against plain per-pass stiffness\n\n");
    out.push_str(
        "Seed materials converted with `Stiffness::Seed` (XPBD) or applied as the seeds do, \
         `k` per projection (plain). The error column is relative to the intended material \
         (the stretch or frequency the conversion promises).\n\n",
    );
    let shown_settings = [
        Setting::seed(1),
        Setting::seed(4),
        Setting::seed(16),
        Setting::substeps(8, 1),
        Setting::substeps(8, 4),
        Setting::substeps(32, 1),
        Setting::substeps(32, 4),
    ];
    out.push_str("| scene | law |");
    for s in &shown_settings {
        let _ = write!(out, " {} |", s.label());
    }
    out.push_str("\n|---|---|");
    out.push_str(&"---:|".repeat(shown_settings.len()));
    out.push('\n');
    for r in results.loaded.iter().chain([&results.springs[2]]) {
        for law in [Law::Xpbd, Law::Plain] {
            let _ = write!(out, "| {} ({}) | {law:?} |", r.name, r.columns[0].name);
            for s in &shown_settings {
                let _ = write!(out, " {} |", shown(r, s.with_law(law)));
            }
            out.push('\n');
        }
    }
    out.push('\n');
    for r in &results.loaded {
        let stretch = |s: Setting| record(r, s).map_or(f64::NAN, |x| x.values[1]);
        let change = |law| {
            times(
                stretch(Setting::substeps(8, 1).with_law(law)),
                stretch(Setting::substeps(8, 4).with_law(law)),
            )
        };
        let _ = writeln!(
            out,
            "* {}: at 8 substeps, going from 1 to 4 iterations divides the stretch by {} \
             under XPBD and by {} under plain stiffness.",
            r.name,
            change(Law::Xpbd),
            change(Law::Plain)
        );
    }
    out.push_str(
        "\nUnder XPBD the material converges to what was intended once the solve converges; \
         under plain stiffness it gets stiffer with every extra pass and every extra substep, \
         so the same `k` is a different material at every budget. At 1 substep both are \
         dominated by under-convergence.\n\n",
    );

    out.push_str("### Settling\n\n");
    out.push_str(&crate::settle::table(&results.settling));
    let largest = results
        .settling
        .iter()
        .map(|row| (row.values[1] / row.values[0] - 1.0).abs())
        .fold(0.0, f64::max);
    let _ = writeln!(
        out,
        "\nThe largest change from doubling the run is {}: the errors reported for the scenes \
         at rest are the solver's steady state, not a transient.\n",
        format_value(largest, Unit::Percent)
    );
    out.push_str("### Units and precision\n\n");
    out.push_str(&crate::precision::table(&results.precision));
    // Largest f64 error of the consistent start over the ballistic rows.
    let consistent = results
        .precision
        .iter()
        .filter(|row| row.unit == Unit::Number)
        .flat_map(|row| row.errors[..2].iter().copied())
        .fold(0.0, f64::max);
    let seed: Vec<String> = results
        .seed_start
        .iter()
        .map(|(s, e)| format!("{s}×1: {}", format_value(*e, Unit::Number)))
        .collect();
    let _ = writeln!(
        out,
        "\nThe f64 solver gives the same relative errors in metres at the origin and in pixels \
         around 1000 px (the pendulums differ in the fourth digit because 100 px / 980 px/s² and \
         1 m / 9.81 m/s² differ by 0.1 %; the pixel run's exact zeros come from g, v₀ and h all \
         being dyadic there). The f32 loop is the same algorithm with f32 state; the table shows \
         where it departs from the f64 solver: as substeps shrink `x − x*` towards the rounding \
         step of `x`, and much sooner far from the origin (\"n/a\": the pendulum never swung). \
         Starting Verlet the seeds' way (`x₋₁ = x₀ − v₀h`, f64) leaves a projectile error \
         (relative to the distance travelled) of {} after 1 s — `½·g·h·t` — against at most {} \
         from the consistent start.\n",
        seed.join(", "),
        significant(consistent)
    );
    out
}
