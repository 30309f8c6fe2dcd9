//! The PNG: one log–log panel per scene, wall time per simulated second against error, one series
//! per setting family, the Pareto front dashed and ringed, the presets labelled.

use crate::Results;
use crate::analysis::pareto;
use crate::sim::{Family, Law};
use crate::sweep::{Record, SceneResult};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::error::Error;

/// Fira Mono (ASCII subset, SIL Open Font License 1.1, see `assets/fonts/`).
static FONT: &[u8] = include_bytes!("../../assets/fonts/FiraMono-subset.ttf");
/// The family name the font is registered under.
const FAMILY: &str = "sans-serif";

/// One series of a panel.
struct Series {
    label: &'static str,
    family: Family,
    tethers: bool,
    law: Law,
    color: RGBColor,
}

/// Every series any panel may show (a panel draws those it has records for).
const SERIES: [Series; 11] = [
    Series {
        label: "1xN (seed style)",
        family: Family::Iterations,
        tethers: false,
        law: Law::Xpbd,
        color: RGBColor(220, 30, 30),
    },
    Series {
        label: "Sx1",
        family: Family::Substeps(1),
        tethers: false,
        law: Law::Xpbd,
        color: RGBColor(30, 80, 220),
    },
    Series {
        label: "Sx2",
        family: Family::Substeps(2),
        tethers: false,
        law: Law::Xpbd,
        color: RGBColor(20, 150, 40),
    },
    Series {
        label: "Sx4",
        family: Family::Substeps(4),
        tethers: false,
        law: Law::Xpbd,
        color: RGBColor(150, 40, 200),
    },
    Series {
        label: "Sx1 lines",
        family: Family::Lines,
        tethers: false,
        law: Law::Xpbd,
        color: RGBColor(0, 0, 0),
    },
    Series {
        label: "Sx1 hierarchy",
        family: Family::Hierarchy,
        tethers: false,
        law: Law::Xpbd,
        color: RGBColor(120, 120, 120),
    },
    Series {
        label: "1xN + tethers",
        family: Family::Iterations,
        tethers: true,
        law: Law::Xpbd,
        color: RGBColor(250, 150, 40),
    },
    Series {
        label: "Sx1 + tethers",
        family: Family::Substeps(1),
        tethers: true,
        law: Law::Xpbd,
        color: RGBColor(40, 190, 230),
    },
    Series {
        label: "1xN plain k",
        family: Family::Iterations,
        tethers: false,
        law: Law::Plain,
        color: RGBColor(130, 0, 0),
    },
    Series {
        label: "Sx1 plain k",
        family: Family::Substeps(1),
        tethers: false,
        law: Law::Plain,
        color: RGBColor(0, 140, 140),
    },
    Series {
        label: "Sx4 plain k",
        family: Family::Substeps(4),
        tethers: false,
        law: Law::Plain,
        color: RGBColor(170, 110, 0),
    },
];

/// One panel: a scene and what its error axis means.
struct Panel<'a> {
    title: String,
    result: &'a SceneResult,
    y: &'static str,
}

/// Draws the figure to `path`.
pub fn draw(results: &Results, path: &str) -> Result<(), Box<dyn Error>> {
    plotters::style::register_font(FAMILY, FontStyle::Normal, FONT)
        .map_err(|_| "the bundled font is not a valid TrueType font")?;
    let panels = [
        Panel {
            title: "(1) Pendulum 5 deg".into(),
            result: &results.pendulum[0],
            y: "|period error|",
        },
        Panel {
            title: "(1) Pendulum 120 deg".into(),
            result: &results.pendulum[1],
            y: "|period error|",
        },
        Panel {
            title: "(7) Double pendulum, 60 s".into(),
            result: &results.double_pendulum,
            y: "energy lost in 60 s",
        },
        Panel {
            title: "(2) Catenary, 50 links".into(),
            result: &results.catenary,
            y: "|sag error|",
        },
        Panel {
            title: "(3) Heavy tip 1000:1, 100 links".into(),
            result: &results.heavy_tip,
            y: "stretch",
        },
        Panel {
            title: "(8) Heavy tip swinging from horizontal".into(),
            result: &results.swinging[0],
            y: "max link strain",
        },
        Panel {
            title: "(8) 200 links swinging from horizontal".into(),
            result: &results.swinging[1],
            y: "max link strain",
        },
        Panel {
            title: "(4) Cloth 50x50".into(),
            result: &results.cloth,
            y: "max strain",
        },
        Panel {
            title: "(5) Spring 10 Hz".into(),
            result: &results.springs[1],
            y: "|frequency error|",
        },
        Panel {
            title: "(5) Seed spring (Tuts+ k=0.02): XPBD vs plain k".into(),
            result: &results.springs[2],
            y: "|frequency error|",
        },
        Panel {
            title: "(3b) Soft chain (verlet-js k=0.9): XPBD vs plain k".into(),
            result: &results.loaded[results.loaded.len() - 1],
            y: "|stretch / intended - 1|",
        },
    ];
    let root = BitMapBackend::new(path, (2100, 2480)).into_drawing_area();
    root.fill(&WHITE)?;
    let (header, body) = root.split_vertically(120);
    draw_header(&header)?;
    for (area, panel) in body.split_evenly((4, 3)).iter().zip(&panels) {
        draw_panel(area, panel)?;
    }
    root.present()?;
    Ok(())
}

/// Title and the shared legend.
fn draw_header(area: &DrawingArea<BitMapBackend, Shift>) -> Result<(), Box<dyn Error>> {
    area.draw_text(
        "Speed against error: wall time per simulated second (x) vs error (y), log-log; \
         lower left is better",
        &(FAMILY, 26).into_font().color(&BLACK),
        (20, 12),
    )?;
    let font = (FAMILY, 19).into_font().color(&BLACK);
    // Nine entries per row; the Pareto entry follows the last series.
    let (x0, y0, width, height, per_row) = (20, 56, 228, 32, 9);
    let slot = |i: usize| {
        (
            x0 + (i % per_row) as i32 * width,
            y0 + (i / per_row) as i32 * height,
        )
    };
    for (i, series) in SERIES.iter().enumerate() {
        let (x, y) = slot(i);
        area.draw(&PathElement::new(
            vec![(x, y + 10), (x + 36, y + 10)],
            series.color.stroke_width(3),
        ))?;
        area.draw(&Circle::new((x + 18, y + 10), 5, series.color.filled()))?;
        area.draw_text(series.label, &font, (x + 44, y))?;
    }
    let (x, y) = slot(SERIES.len().max(per_row));
    area.draw(&PathElement::new(
        vec![(x, y + 10), (x + 36, y + 10)],
        BLACK.stroke_width(2),
    ))?;
    area.draw(&Circle::new((x + 18, y + 10), 9, BLACK.stroke_width(2)))?;
    area.draw_text(
        "Pareto front (dashed, ringed points). Labels: default 8x1, accurate 32x1. \
         Errors below 1e-10 (rounding; heavy tip with tethers: exactly 0) are not drawn.",
        &font,
        (x + 44, y),
    )?;
    Ok(())
}

/// Formats a log-axis tick: plain between 0.01 and 1000, else `2e-5` style.
fn tick(value: &f64) -> String {
    let v = *value;
    if (0.01..1000.0).contains(&v.abs()) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

/// Errors below this are rounding, not method error, and are not drawn.
const FLOOR: f64 = 1e-10;

/// A drawable point: `(cost, error)` with a finite error above [`FLOOR`].
fn point(record: &Record) -> Option<(f64, f64)> {
    let e = record.error();
    (e.is_finite() && e > FLOOR && record.ms_per_second > 0.0).then_some((record.ms_per_second, e))
}

/// Tick positions for a log axis from `low` to `high`: 1, 1.5, 2, 2.5, 3 … 9 × 10ⁿ within half a
/// decade, 1, 2, 3, 5, 7 × 10ⁿ within about a decade, 1, 2, 5 × 10ⁿ up to three decades, every
/// decade up to eight, every other decade beyond.
fn ticks(low: f64, high: f64) -> Vec<f64> {
    let decades = (high / low).log10();
    let (mantissas, stride): (&[f64], i32) = if decades <= 0.6 {
        (&[1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0], 1)
    } else if decades <= 1.3 {
        (&[1.0, 2.0, 3.0, 5.0, 7.0], 1)
    } else if decades <= 3.5 {
        (&[1.0, 2.0, 5.0], 1)
    } else if decades <= 8.0 {
        (&[1.0], 1)
    } else {
        (&[1.0], 2)
    };
    let mut points = Vec::new();
    let mut exponent = low.log10().floor() as i32;
    while 10f64.powi(exponent) <= high {
        if exponent.rem_euclid(stride) == 0 {
            for m in mantissas {
                let v = m * 10f64.powi(exponent);
                if v >= low && v <= high {
                    points.push(v);
                }
            }
        }
        exponent += 1;
    }
    points
}

/// Log-axis padding: a small factor for narrow ranges, up to 3× for wide ones.
fn pad(low: f64, high: f64) -> f64 {
    (high / low).powf(0.08).clamp(1.15, 3.0)
}

/// One scene's panel.
fn draw_panel(
    area: &DrawingArea<BitMapBackend, Shift>,
    panel: &Panel,
) -> Result<(), Box<dyn Error>> {
    let records: Vec<&Record> = panel
        .result
        .records
        .iter()
        .filter(|r| point(r).is_some())
        .collect();
    let points: Vec<(f64, f64)> = records.iter().filter_map(|r| point(r)).collect();
    if points.is_empty() {
        return Ok(());
    }
    let (x_min, x_max) = points.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let (y_min, y_max) = points.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.1), b.max(p.1))
    });
    let (px, py) = (pad(x_min, x_max), pad(y_min, y_max));
    let (x_range, y_range) = ((x_min / px, x_max * px), (y_min / py, y_max * py));
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, (FAMILY, 24))
        .margin(14)
        .x_label_area_size(50)
        .y_label_area_size(90)
        .build_cartesian_2d(
            (x_range.0..x_range.1)
                .log_scale()
                .with_key_points(ticks(x_range.0, x_range.1)),
            (y_range.0..y_range.1)
                .log_scale()
                .with_key_points(ticks(y_range.0, y_range.1)),
        )?;
    chart
        .configure_mesh()
        .x_desc("wall ms per simulated s")
        .y_desc(panel.y)
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .label_style((FAMILY, 17))
        .axis_desc_style((FAMILY, 19))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()?;
    for series in &SERIES {
        let line: Vec<(f64, f64)> = panel
            .result
            .series(series.family, series.tethers, series.law)
            .iter()
            .filter_map(|r| point(r))
            .collect();
        if line.is_empty() {
            continue;
        }
        let style = series.color.stroke_width(2);
        if series.law == Law::Plain {
            chart.draw_series(DashedLineSeries::new(line.clone(), 8, 5, style))?;
        } else {
            chart.draw_series(LineSeries::new(line.clone(), style))?;
        }
        chart.draw_series(
            line.iter()
                .map(|&p| Circle::new(p, 4, series.color.filled())),
        )?;
    }
    // Pareto front over everything drawn.
    let mut front: Vec<(f64, f64)> = pareto(&records)
        .into_iter()
        .filter_map(|i| point(records[i]))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    chart.draw_series(DashedLineSeries::new(
        front.clone(),
        6,
        4,
        BLACK.stroke_width(2),
    ))?;
    chart.draw_series(
        front
            .iter()
            .map(|&p| Circle::new(p, 9, BLACK.stroke_width(2))),
    )?;
    // Preset labels.
    for (substeps, label) in [(8, "default 8x1"), (32, "accurate 32x1")] {
        let preset = panel.result.records.iter().find(|r| {
            r.setting.family == Family::Substeps(1)
                && r.setting.substeps == substeps
                && !r.setting.tethers
                && r.setting.law == Law::Xpbd
        });
        if let Some(p) = preset.and_then(point) {
            chart.draw_series(std::iter::once(
                EmptyElement::at(p) + Text::new(label, (8, 6), (FAMILY, 16).into_font()),
            ))?;
        }
    }
    Ok(())
}
