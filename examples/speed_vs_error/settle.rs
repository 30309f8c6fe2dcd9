//! Settling check: the scenes measured "at rest" are run for their usual duration and for twice
//! it; a small change means the reported error is the solver's steady state, not a transient.

use crate::report::format_value;
use crate::sim::catenary::Catenary;
use crate::sim::cloth::Cloth;
use crate::sim::heavy_tip::HeavyTip;
use crate::sim::{Scene, Setting};
use std::fmt::Write;

/// One scene and setting at two durations.
#[derive(Clone, Debug)]
pub struct Row {
    /// Scene name, metric name.
    pub what: String,
    /// The setting.
    pub setting: Setting,
    /// Duration used in the report (s).
    pub seconds: f64,
    /// Primary metric at that duration and at twice it.
    pub values: [f64; 2],
    /// How to print them.
    pub unit: crate::sim::Unit,
}

/// Measures `scene` (whose duration is `seconds`) and `longer` (the same at twice it).
fn row(scene: &dyn Scene, longer: &dyn Scene, seconds: f64, setting: Setting) -> Row {
    let column = scene.columns()[0];
    Row {
        what: format!("{}: {}", scene.name(), column.name),
        setting,
        seconds,
        values: [scene.measure(&setting)[0], longer.measure(&setting)[0]],
        unit: column.unit,
    }
}

/// Runs the check at the default (8 × 1) and the seeds' 1 × 64.
pub fn check() -> Vec<Row> {
    let mut rows = Vec::new();
    for setting in [Setting::substeps(8, 1), Setting::seed(64)] {
        let catenary = Catenary::default();
        let long_catenary = Catenary {
            seconds: 2.0 * catenary.seconds,
            ..catenary
        };
        rows.push(row(&catenary, &long_catenary, catenary.seconds, setting));
        let heavy = HeavyTip::default();
        let long_heavy = HeavyTip {
            seconds: 2.0 * heavy.seconds,
            ..heavy
        };
        rows.push(row(&heavy, &long_heavy, heavy.seconds, setting));
        let cloth = Cloth::default();
        let long_cloth = Cloth {
            seconds: 2.0 * cloth.seconds,
            ..cloth
        };
        rows.push(row(&cloth, &long_cloth, cloth.seconds, setting));
    }
    rows
}

/// The markdown table.
pub fn table(rows: &[Row]) -> String {
    let mut out = String::from(
        "| scene: metric | setting | at the report's duration | at twice it | relative change |\n\
         |---|---|---:|---:|---:|\n",
    );
    for row in rows {
        let [a, b] = row.values;
        let _ = writeln!(
            out,
            "| {} | {} | {} ({} s) | {} | {} |",
            row.what,
            row.setting.label(),
            format_value(a, row.unit),
            row.seconds,
            format_value(b, row.unit),
            format_value(b / a - 1.0, crate::sim::Unit::Percent)
        );
    }
    out
}
