//! A study's outputs: study.csv, repeatability.csv, fits.json, fem.csv (with
//! simulations), plots/ (PNG + SVG + PDF) and report.html, each written atomically.

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use crate::compare::GRID_POINTS;
use crate::report::{plot_xy, write_json, ErrorBars, Series};
use crate::table::{write_csv, Column};

use super::analyse::{Analysis, FemResult, FitResult};
use super::config::{StudyError, FITTED, POOLED, QUANTITIES};
use super::load::Study;
use super::stats::{Summary, BAND_LEVEL, OUTLIER_LEVEL, SAME_PRESSURE_KPA, SAME_PRESSURE_REL};

/// Stems (in plots/) of the study's plots, one per fitted quantity, with their titles.
pub const PLOT_STEMS: [(&str, &str); FITTED] = [
    ("radius_vs_pressure", "Radius of curvature"),
    ("curvature_vs_pressure", "Curvature"),
    ("angle_vs_pressure", "Bending angle"),
];

/// What [`write_study`] wrote and said.
#[derive(Debug, Clone)]
pub struct StudyReport {
    /// A few lines for stdout.
    pub summary: String,
    /// Warnings (also in the report).
    pub warnings: Vec<String>,
    /// Notes (also in the report).
    pub notes: Vec<String>,
}

fn output(e: impl std::fmt::Display) -> StudyError {
    StudyError::Output { why: e.to_string() }
}

/// A number as its shortest exact text (it reads back to the same f64); NaN empty.
fn exact(v: f64) -> String {
    if v.is_nan() {
        String::new()
    } else {
        format!("{v}")
    }
}

/// study.csv: `sample, pressure_kpa, n`, then `<q>_mean, <q>_std, <q>_min, <q>_max`.
fn write_study_csv(path: &Path, a: &Analysis) -> Result<(), StudyError> {
    let rows = &a.rows;
    let mut cols = vec![
        Column::text("sample", rows.iter().map(|r| r.sample.clone())),
        Column::text("pressure_kpa", rows.iter().map(|r| exact(r.pressure_kpa))),
        Column::int("n", rows.iter().map(|r| r.n as u64)),
    ];
    for (q, (name, _)) in QUANTITIES.iter().enumerate() {
        for (what, f) in [
            ("mean", (|s: &Summary| s.mean) as fn(&Summary) -> f64),
            ("std", |s: &Summary| s.std),
            ("min", |s: &Summary| s.min),
            ("max", |s: &Summary| s.max),
        ] {
            cols.push(Column::text(
                format!("{name}_{what}"),
                rows.iter().map(|r| exact(f(&r.stats[q]))),
            ));
        }
    }
    write_csv(path, &cols)?;
    Ok(())
}

/// repeatability.csv: `scope, sample, pressure_kpa, n, <q>_cv_pct` for the fitted
/// quantities.
fn write_repeatability_csv(path: &Path, a: &Analysis) -> Result<(), StudyError> {
    let r = &a.repeatability;
    let mut cols = vec![
        Column::text("scope", r.iter().map(|r| r.scope.to_string())),
        Column::text("sample", r.iter().map(|r| r.sample.clone())),
        Column::num("pressure_kpa", 4, r.iter().map(|r| r.pressure_kpa)),
        Column::int("n", r.iter().map(|r| r.n as u64)),
    ];
    for (q, (name, _)) in QUANTITIES[..FITTED].iter().enumerate() {
        cols.push(Column::num(
            format!("{name}_cv_pct"),
            4,
            r.iter().map(|r| r.cv_pct[q]),
        ));
    }
    write_csv(path, &cols)?;
    Ok(())
}

/// fem.csv: one row per simulation, sample (or pool) and quantity.
fn write_fem_csv(path: &Path, fem: &[FemResult]) -> Result<(), StudyError> {
    write_csv(
        path,
        &[
            Column::text("model", fem.iter().map(|f| f.model.clone())),
            Column::text("sample", fem.iter().map(|f| f.sample.clone())),
            Column::text("quantity", fem.iter().map(|f| f.quantity.to_string())),
            Column::num("rmse", 5, fem.iter().map(|f| f.rmse)),
            Column::num("rmse_pct", 3, fem.iter().map(|f| f.rmse_pct)),
            Column::num(
                "max_abs_deviation",
                5,
                fem.iter().map(|f| f.max_abs_deviation),
            ),
            Column::num(
                "max_deviation_at_kpa",
                3,
                fem.iter().map(|f| f.max_deviation_at_kpa),
            ),
            Column::num("from_kpa", 3, fem.iter().map(|f| f.from_kpa)),
            Column::num("to_kpa", 3, fem.iter().map(|f| f.to_kpa)),
        ],
    )?;
    Ok(())
}

/// fits.json.
#[derive(Serialize)]
struct FitsJson<'a> {
    model: &'static str,
    points: &'static str,
    band: String,
    pressure_tolerance: String,
    fits: &'a [FitResult],
    fem: &'a [FemResult],
    warnings: &'a [String],
    notes: &'a [String],
}

/// The FEM points of `q` within the measured range widened by a tenth each way (a
/// simulation to 120 kPa would squash measurements to 60 kPa into a corner).
fn fem_points(curve: &crate::compare::Curve, (lo, hi): (f64, f64)) -> Vec<(f64, f64)> {
    let m = 0.1 * (hi - lo);
    curve
        .pressure_kpa
        .iter()
        .zip(&curve.value)
        .filter(|(p, _)| **p > 0.0 && **p >= lo - m && **p <= hi + m)
        .map(|(p, v)| (*p, *v))
        .collect()
}

/// Draws the plot of quantity `q`: each sample's means with std error bars, the pooled
/// fit and each simulation.
fn plot_quantity(
    out: &Path,
    study: &Study,
    a: &Analysis,
    q: usize,
    bars: ErrorBars,
) -> Result<bool, StudyError> {
    let (stem, title) = PLOT_STEMS[q];
    let (name, axis) = QUANTITIES[q];
    let range = a
        .rows
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
            (lo.min(r.pressure_kpa), hi.max(r.pressure_kpa))
        });
    let labels: Vec<String> = study
        .samples
        .iter()
        .map(|s| format!("sample {} (mean ± {})", s.name, bars.label()))
        .chain(study.fem.iter().map(|m| format!("FEM {}", m.name)))
        .collect();
    let mut series: Vec<Series> = Vec::new();
    for (s, sample) in study.samples.iter().enumerate() {
        let rows: Vec<_> = a.rows.iter().filter(|r| r.sample == sample.name).collect();
        series.push(Series {
            label: &labels[s],
            points: rows
                .iter()
                .map(|r| (r.pressure_kpa, r.stats[q].mean))
                .collect(),
            line: false,
            errors: Some(
                rows.iter()
                    .map(|r| bars.half_height(r.stats[q].std, r.stats[q].n))
                    .collect(),
            ),
        });
    }
    let pooled = a
        .fits
        .iter()
        .find(|f| f.sample == POOLED && f.quantity == name);
    // The band stays in fits.json and the report: drawn here, its two edges (each a
    // series of its own colour) would read as two more curves.
    if let Some(f) = pooled {
        series.push(Series {
            label: "pooled fit a p^b + c",
            points: (0..GRID_POINTS)
                .map(|k| range.0 + (range.1 - range.0) * k as f64 / (GRID_POINTS - 1) as f64)
                .map(|p| (p, f.fit.eval(p)))
                .collect(),
            line: true,
            errors: None,
        });
    }
    for (m, model) in study.fem.iter().enumerate() {
        series.push(Series {
            label: &labels[study.samples.len() + m],
            points: fem_points(&model.curves[q], range),
            line: true,
            errors: None,
        });
    }
    plot_xy(
        &out.join("plots").join(stem),
        &format!("{title}: study"),
        "pressure (kPa)",
        axis,
        &series,
    )
    .map_err(output)
}

/// Writes every output of the study into `out` (made if needed); the plots' error bars
/// show `bars` of the per-session values at each set point.
pub fn write_study(
    study: &Study,
    a: &Analysis,
    out: &Path,
    bars: ErrorBars,
) -> Result<StudyReport, StudyError> {
    std::fs::create_dir_all(out.join("plots")).map_err(|e| StudyError::Output {
        why: crate::io::with_path(&out.join("plots"), &e),
    })?;
    write_study_csv(&out.join("study.csv"), a)?;
    write_repeatability_csv(&out.join("repeatability.csv"), a)?;
    if !study.fem.is_empty() {
        write_fem_csv(&out.join("fem.csv"), &a.fem)?;
    }
    let mut notes = study.notes.clone();
    notes.extend(a.notes.iter().cloned());
    write_json(
        &out.join("fits.json"),
        &FitsJson {
            model: "y = a p^b + c (p in kPa)",
            points: "each session's mean at each pressure set point (pressure > 0)",
            band: format!(
                "{:.0} % confidence band of the fitted curve: delta method on the covariance of (a, b, c), Student's t with n - 3 degrees of freedom",
                100.0 * BAND_LEVEL
            ),
            pressure_tolerance: format!(
                "pressures within {} % or {} kPa are one set point",
                100.0 * SAME_PRESSURE_REL,
                SAME_PRESSURE_KPA
            ),
            fits: &a.fits,
            fem: &a.fem,
            warnings: &a.warnings,
            notes: &notes,
        },
    )
    .map_err(output)?;
    let mut plots = Vec::new();
    for (q, (stem, _)) in PLOT_STEMS.iter().enumerate() {
        if plot_quantity(out, study, a, q, bars)? {
            plots.push(format!("plots/{stem}"));
        }
    }
    super::page::write_report(&out.join("report.html"), out, study, a, &plots, &notes)?;
    let sessions: usize = study.samples.iter().map(|s| s.sessions.len()).sum();
    let mut summary = format!(
        "{} sample(s), {sessions} session(s), {} pressure set point(s)\n",
        study.samples.len(),
        a.set_points.len()
    );
    for f in a.fits.iter().filter(|f| f.quantity == "radius_mm") {
        let _ = writeln!(
            summary,
            "{:>10} radius_mm = {:.4} p^{:.4} + {:.4} (R² {:.5}, n {})",
            f.sample, f.fit.a, f.fit.b, f.fit.c, f.fit.r_squared, f.fit.n
        );
    }
    for f in a.fem.iter().filter(|f| f.sample == POOLED) {
        let _ = writeln!(
            summary,
            "FEM {} vs {}: {} RMSE {:.4} ({:.2} %), max |deviation| {:.4} at {:.1} kPa",
            f.model,
            POOLED,
            f.quantity,
            f.rmse,
            f.rmse_pct,
            f.max_abs_deviation,
            f.max_deviation_at_kpa
        );
    }
    let _ = write!(
        summary,
        "flags: {}",
        if a.warnings.iter().any(|w| w.contains("disagrees")) {
            format!(
                "sessions outside the {:.1} % prediction interval of their sample (see warnings)",
                100.0 * OUTLIER_LEVEL
            )
        } else {
            "none".into()
        }
    );
    Ok(StudyReport {
        summary,
        warnings: a.warnings.clone(),
        notes,
    })
}
