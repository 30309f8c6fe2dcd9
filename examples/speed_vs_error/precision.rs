//! Units and precision: the same pendulum and projectile in metres at the origin and in pixels
//! around (1000, 1000) px, through the `f64` solver and through an `f32` copy of its loop.

use crate::report::format_value;
use crate::sim::ballistic::{Ballistic, Start};
use crate::sim::pendulum::Pendulum;
use crate::sim::{Scene, Setting, Unit, Units, f32_reference};
use glam::{DVec3, Vec2};
use std::fmt::Write;

/// Substep counts compared.
const SUBSTEPS: [u32; 3] = [1, 8, 64];
/// Amplitudes compared (degrees).
const AMPLITUDES: [f64; 2] = [5.0, 120.0];
/// The projectile's launch velocity in scale units per second (3, 4) m/s or (300, 400) px/s.
const LAUNCH: [f64; 2] = [3.0, 4.0];

/// One row: a quantity at one substep count, `[f64 m, f64 px, f32 m, f32 px]`.
#[derive(Clone, Debug)]
pub struct Row {
    /// What is compared.
    pub what: String,
    /// Substeps (1 iteration each).
    pub substeps: u32,
    /// The four errors.
    pub errors: [f64; 4],
    /// How to print them.
    pub unit: Unit,
}

impl Row {
    /// A row from the `f64` and `f32` errors as functions of the units.
    fn new(
        what: String,
        substeps: u32,
        unit: Unit,
        f64_error: impl Fn(Units) -> f64,
        f32_error: impl Fn(Units) -> f64,
    ) -> Self {
        Self {
            what,
            substeps,
            errors: [
                f64_error(Units::Metres),
                f64_error(Units::Pixels),
                f32_error(Units::Metres),
                f32_error(Units::Pixels),
            ],
            unit,
        }
    }
}

/// Measures every row.
pub fn measure() -> Vec<Row> {
    let mut rows = Vec::new();
    for amplitude_deg in AMPLITUDES {
        for substeps in SUBSTEPS {
            let setting = Setting::substeps(substeps, 1);
            let at = |units| Pendulum {
                amplitude_deg,
                units,
            };
            let f64_error = |units| at(units).measure(&setting)[0];
            let f32_error = |units| f32_reference::pendulum(&at(units), substeps)[0];
            rows.push(Row::new(
                format!("pendulum {amplitude_deg}°: period error"),
                substeps,
                Unit::Percent,
                f64_error,
                f32_error,
            ));
        }
    }
    for (name, velocity) in [("free fall", [0.0, 0.0]), ("projectile", LAUNCH)] {
        for substeps in SUBSTEPS {
            let setting = Setting::substeps(substeps, 1);
            let f64_error = |units| {
                Ballistic {
                    velocity: DVec3::new(velocity[0], velocity[1], 0.0),
                    units,
                    start: Start::Consistent,
                }
                .measure(&setting)[0]
            };
            let f32_error = |units| {
                f32_reference::ballistic(
                    units,
                    Vec2::new(velocity[0] as f32, velocity[1] as f32),
                    substeps,
                )
            };
            rows.push(Row::new(
                format!("{name}: position error after 1 s / distance"),
                substeps,
                Unit::Number,
                f64_error,
                f32_error,
            ));
        }
    }
    rows
}

/// The seeds' start `x₋₁ = x₀ − v₀h` for the projectile, in the `f64` solver, metres.
pub fn seed_start_errors() -> Vec<(u32, f64)> {
    SUBSTEPS
        .iter()
        .map(|&substeps| {
            let scene = Ballistic {
                velocity: DVec3::new(LAUNCH[0], LAUNCH[1], 0.0),
                units: Units::Metres,
                start: Start::Seed,
            };
            (substeps, scene.measure(&Setting::substeps(substeps, 1))[0])
        })
        .collect()
}

/// The markdown table of [`measure`]'s rows.
pub fn table(rows: &[Row]) -> String {
    let mut out = String::new();
    out.push_str(
        "| quantity | S×1 | f64 solver, m at origin | f64 solver, px at (1000, 1000) | f32 loop, m at origin | f32 loop, px at (1000, 1000) |\n",
    );
    out.push_str("|---|---:|---:|---:|---:|---:|\n");
    for row in rows {
        let _ = write!(out, "| {} | {} |", row.what, row.substeps);
        for e in row.errors {
            let _ = write!(out, " {} |", format_value(e, row.unit));
        }
        out.push('\n');
    }
    out
}
