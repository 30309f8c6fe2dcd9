//! Small computations on the results that the reading quotes: look-ups, ratios, log–log slopes,
//! Pareto fronts.

use crate::report::{format_value, significant};
use crate::sim::{Family, Law, Setting, TIMESTEP};
use crate::sweep::{Record, SceneResult};

/// Milliseconds of one core per 64 Hz fixed step: the solver thread's CPU time, or the wall
/// time where the platform does not report CPU time.
pub fn step_cost(record: &Record) -> f64 {
    let per_second = if record.cpu_ms_per_second.is_finite() {
        record.cpu_ms_per_second
    } else {
        record.ms_per_second
    };
    per_second * TIMESTEP
}

/// Two decimals (`n/a` for `NaN`).
pub fn fixed(value: f64) -> String {
    if value.is_finite() {
        format!("{value:.2}")
    } else {
        "n/a".into()
    }
}

/// The record of `setting` in `result`.
pub fn record(result: &SceneResult, setting: Setting) -> Option<&Record> {
    result.get(&setting)
}

/// The plotted (absolute primary) error of `setting`, `NaN` if not run.
pub fn error(result: &SceneResult, setting: Setting) -> f64 {
    record(result, setting).map_or(f64::NAN, Record::error)
}

/// The primary metric of `setting`, formatted.
pub fn shown(result: &SceneResult, setting: Setting) -> String {
    record(result, setting).map_or("n/a".into(), |r| {
        format_value(r.values[0], result.columns[0].unit)
    })
}

/// `a / b` formatted as `12×`, or `n/a`.
pub fn times(a: f64, b: f64) -> String {
    let ratio = a / b;
    if ratio.is_finite() && ratio > 0.0 {
        format!("{}×", significant(ratio))
    } else {
        "n/a".into()
    }
}

/// Log–log slope `−Δln(error)/Δln(budget)` of one family (untethered, XPBD) between its first
/// run with budget ≥ 4 and its last: `a` for S × 1, `b` for 1 × N.
pub fn slope(result: &SceneResult, family: Family) -> f64 {
    let points: Vec<(f64, f64)> = result
        .series(family, false, Law::Xpbd)
        .iter()
        .filter(|r| r.setting.budget() >= 4 && r.error() > 0.0 && r.error().is_finite())
        .map(|r| (r.setting.budget() as f64, r.error()))
        .collect();
    match (points.first(), points.last()) {
        (Some(p), Some(q)) if q.0 > p.0 => -(q.1 / p.1).ln() / (q.0 / p.0).ln(),
        _ => f64::NAN,
    }
}

/// `(a, b)`: the error falls as `S^−a` along S × 1 and as `N^−b` along 1 × N.
pub fn exponents(result: &SceneResult) -> (f64, f64) {
    (
        slope(result, Family::Substeps(1)),
        slope(result, Family::Iterations),
    )
}

/// Indices of the Pareto-optimal records (no other record is both cheaper and more accurate),
/// over the records with a positive finite error, cost = wall time.
pub fn pareto(records: &[&Record]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..records.len())
        .filter(|&i| records[i].error().is_finite() && records[i].error() > 0.0)
        .collect();
    order.sort_by(|&a, &b| {
        records[a]
            .ms_per_second
            .total_cmp(&records[b].ms_per_second)
            .then(records[a].error().total_cmp(&records[b].error()))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in order {
        if records[i].error() < best {
            best = records[i].error();
            front.push(i);
        }
    }
    front
}

/// Whether `setting` is on the Pareto front of the rigid, tether-free records of `result`.
pub fn on_front(result: &SceneResult, setting: Setting) -> bool {
    let records: Vec<&Record> = result
        .records
        .iter()
        .filter(|r| !r.setting.tethers && r.setting.law == Law::Xpbd)
        .collect();
    pareto(&records).iter().any(|&i| {
        records[i].setting.substeps == setting.substeps
            && records[i].setting.iterations == setting.iterations
            && records[i].setting.method == setting.method
    })
}
