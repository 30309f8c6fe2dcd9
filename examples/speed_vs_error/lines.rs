//! The reading of the lines family (direct solve + SHAKE): what it costs to reach 1 % on the
//! chains and the cloth, family by family, and what it does to period and energy.

use crate::Results;
use crate::analysis::{shown, step_cost};
use crate::report::significant;
use crate::sim::{Family, Law, Setting};
use crate::sweep::{Record, SceneResult};
use std::fmt::Write;

/// The families compared: `(label, family, tethers)`.
const FAMILIES: [(&str, Family, bool); 5] = [
    ("1 × N", Family::Iterations, false),
    ("S × 1", Family::Substeps(1), false),
    ("S × 1 + tethers", Family::Substeps(1), true),
    ("S × 1 lines", Family::Lines, false),
    ("S × 1 hierarchy", Family::Hierarchy, false),
];

/// The cheapest record of a family whose plotted error is at most `bound`.
fn cheapest_within(
    result: &SceneResult,
    family: Family,
    tethers: bool,
    bound: f64,
) -> Option<&Record> {
    result
        .series(family, tethers, Law::Xpbd)
        .into_iter()
        .filter(|r| r.error() <= bound)
        .min_by(|a, b| step_cost(a).total_cmp(&step_cost(b)))
}

/// The section.
pub fn section(results: &Results) -> String {
    let mut out = String::from("\n## Lines: direct solve and SHAKE\n\n");
    out.push_str(
        "`Method::Lines` covers an island's sticks with paths and solves each path exactly \
         (tridiagonal, Newton passes until `|C|/L < 10⁻⁹`), correcting along each stick's \
         direction at the start of the substep (SHAKE) so energy is kept. Under \
         `Method::Auto` the solver uses it for chains and trees. Below: the cheapest setting of \
         each family that reaches 1 % on the chains and the cloth (ms of one core per 64 Hz \
         step; `—`: no setting of the family up to 64 reaches it).\n\n",
    );
    out.push_str("| scene |");
    for (label, ..) in FAMILIES {
        let _ = write!(out, " {label} |");
    }
    out.push_str("\n|---|");
    for _ in FAMILIES {
        out.push_str("---|");
    }
    out.push('\n');
    let scenes = [
        &results.heavy_tip,
        &results.swinging[0],
        &results.swinging[1],
        &results.catenary,
        &results.cloth,
    ];
    for result in scenes {
        let _ = write!(out, "| {} |", result.name);
        for (_, family, tethers) in FAMILIES {
            match cheapest_within(result, family, tethers, 0.01) {
                Some(r) => {
                    let _ = write!(
                        out,
                        " {} ms ({}) |",
                        significant(step_cost(r)),
                        r.setting.label()
                    );
                }
                None => out.push_str(" — |"),
            }
        }
        out.push('\n');
    }
    out.push_str(
        "\nAt the default budget, 8 substeps, sweep against lines; and lines at 2 substeps — what \
         `VerletConfig::line_substeps: Some(2)` gives the chains and pendulums while sweeps keep 8 \
         (the cloth keeps 8 there: it is not tree-shaped; its 2 × 1 row is the cloth put on lines \
         at 2 substeps by an `IslandOverride`):\n\n",
    );
    let sweep = Setting::substeps(8, 1);
    let lines = Setting::lines(8);
    let rows: [(&str, &SceneResult); 6] = [
        ("pendulum 120°, period error", &results.pendulum[1]),
        (
            "double pendulum, energy lost in 60 s",
            &results.double_pendulum,
        ),
        ("heavy tip hanging, stretch", &results.heavy_tip),
        ("heavy tip swinging, max link strain", &results.swinging[0]),
        ("200 links swinging, max link strain", &results.swinging[1]),
        ("cloth 50 × 50, max strain", &results.cloth),
    ];
    // (2 × 1 lines: what `line_substeps: Some(2)` gives chains and pendulums, their sweeps at 8;
    // a cloth is not tree-shaped and keeps the step's substeps there, so its row is the cloth
    // put on lines at 2 substeps by an `IslandOverride`.)
    let two = Setting::lines(2);
    out.push_str(
        "| metric | 8 × 1 sweep | 8 × 1 lines | cost ratio | 2 × 1 lines | cost ratio |\n|---|---:|---:|---:|---:|---:|\n",
    );
    for (name, result) in rows {
        let ratio = |setting: &Setting| match (result.get(&sweep), result.get(setting)) {
            (Some(a), Some(b)) => format!("{}×", significant(step_cost(b) / step_cost(a))),
            _ => "n/a".into(),
        };
        let _ = writeln!(
            out,
            "| {name} | {} | {} | {} | {} | {} |",
            shown(result, sweep),
            shown(result, lines),
            ratio(&lines),
            shown(result, two),
            ratio(&two),
        );
    }
    out
}
