//! Experiment against simulation: both curves of a quantity vs pressure (radius,
//! curvature, bending angle, blocked force) are fitted with the power law
//! y = a p^b + c ([`crate::fit::fit_power_law`]), evaluated on a common pressure grid over
//! the range both cover, and compared: the deviation curve (simulated − measured, in the
//! quantity's unit), its RMSE (also in % of the measured fit's RMS) and its largest
//! magnitude. The two need not share pressure points. Points at or below 0 kPa cannot
//! enter the power law (p^b at 0); they are left out of the fits, with a note.

use std::path::Path;

use std::fmt::Write as _;

use serde::Serialize;

use crate::fit::{fit_power_law, PowerLawFit};
use crate::io::write_atomic;
use crate::report::{plot_xy, write_json, Series};
use crate::table::{write_csv, Column, Table, TableError};

/// grams-force to newtons.
pub const N_PER_GF: f64 = 9.806_65e-3;

fn output(e: impl std::fmt::Display) -> CompareError {
    CompareError::Output { why: e.to_string() }
}

/// Points of the common pressure grid.
pub const GRID_POINTS: usize = 41;

/// Errors of the comparison.
#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    /// A results table cannot be read or lacks a column.
    #[error(transparent)]
    Table(#[from] TableError),
    /// The two pressure ranges do not overlap.
    #[error("the measured pressures ({m0:.1}-{m1:.1} kPa) and the simulated ones ({f0:.1}-{f1:.1} kPa) do not overlap: simulate the measured range (bendscope simulate --pressures {m0}:{m1}:5)")]
    NoOverlap {
        /// Measured range.
        m0: f64,
        /// Measured range.
        m1: f64,
        /// Simulated range.
        f0: f64,
        /// Simulated range.
        f1: f64,
    },
    /// An input table is missing.
    #[error("{path} is missing: {why}")]
    Missing {
        /// The file.
        path: std::path::PathBuf,
        /// What to do.
        why: String,
    },
    /// A result file could not be written.
    #[error("cannot write the comparison: {why}")]
    Output {
        /// What failed.
        why: String,
    },
    /// A curve could not be fitted.
    #[error("{what}: {why}")]
    Fit {
        /// The curve.
        what: String,
        /// Why.
        why: String,
    },
}

/// Reads the named columns of a CSV as numbers ([`Table`]); rows with an empty,
/// non-numeric or non-finite cell in any of them are dropped.
pub fn read_columns(path: &Path, names: &[&str]) -> Result<Vec<Vec<f64>>, CompareError> {
    let table = Table::read(path)?;
    let wanted = names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ");
    let hint = format!("give a table with the columns {wanted}");
    let cols = names
        .iter()
        .map(|n| table.require(n, &hint))
        .collect::<Result<Vec<usize>, TableError>>()?;
    let mut out = vec![Vec::with_capacity(table.len()); cols.len()];
    for row in 0..table.len() {
        let values: Option<Vec<f64>> = cols
            .iter()
            .map(|c| table.f64_at(row, *c).ok().filter(|v| v.is_finite()))
            .collect();
        if let Some(values) = values {
            for (o, v) in out.iter_mut().zip(values) {
                o.push(v);
            }
        }
    }
    Ok(out)
}

/// Measured or simulated points of one quantity.
#[derive(Debug, Clone, Default)]
pub struct Curve {
    /// Pressures, kPa.
    pub pressure_kpa: Vec<f64>,
    /// Values.
    pub value: Vec<f64>,
}

/// The comparison of one quantity.
#[derive(Debug, Clone, Serialize)]
pub struct QuantityComparison {
    /// Quantity name (column name, e.g. `radius_mm`).
    pub name: String,
    /// Power-law fit of the measurement.
    pub measured_fit: PowerLawFit,
    /// Power-law fit of the simulation.
    pub fem_fit: PowerLawFit,
    /// Common pressure grid, kPa.
    pub grid_kpa: Vec<f64>,
    /// Measured fit on the grid.
    pub measured: Vec<f64>,
    /// Simulated fit on the grid.
    pub fem: Vec<f64>,
    /// RMS of the deviation, simulated − measured, on the grid (unit of the quantity).
    pub rmse: f64,
    /// Largest |simulated − measured| on the grid.
    pub max_abs_deviation: f64,
    /// Pressure of that largest deviation, kPa.
    pub max_deviation_at_kpa: f64,
    /// RMSE relative to the RMS of the measured values, %.
    pub rmse_pct: f64,
}

/// The text of the deviation's direction (help, summary.txt).
pub const DEVIATION_MEANING: &str = "deviation = simulated - measured (FEM fit minus measured fit, in the quantity's unit; RMSE % relative to the RMS of the measured fit)";

/// The points of `c` at a positive pressure (the power law's x^b needs x > 0).
fn positive_part(c: &Curve) -> Curve {
    let (pressure_kpa, value) = c
        .pressure_kpa
        .iter()
        .zip(&c.value)
        .filter(|(p, _)| **p > 0.0)
        .map(|(p, v)| (*p, *v))
        .unzip();
    Curve {
        pressure_kpa,
        value,
    }
}

fn range(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        })
}

/// Fits both curves (their points at a positive pressure) and compares them on the
/// overlap of their pressure ranges. Disjoint ranges are an error first; a curve that
/// cannot be fitted (too few distinct pressures) is one before a range of a single
/// point is called "no overlap".
pub fn compare_quantity(
    name: &str,
    measured: &Curve,
    fem: &Curve,
) -> Result<QuantityComparison, CompareError> {
    let (measured, fem) = (positive_part(measured), positive_part(fem));
    let (m0, m1) = range(&measured.pressure_kpa);
    let (f0, f1) = range(&fem.pressure_kpa);
    let no_overlap = CompareError::NoOverlap { m0, m1, f0, f1 };
    if m1 < f0 || f1 < m0 {
        return Err(no_overlap);
    }
    let fit = |c: &Curve, what: &str| {
        fit_power_law(&c.pressure_kpa, &c.value).map_err(|e| CompareError::Fit {
            what: format!("{what} {name}"),
            why: e.to_string(),
        })
    };
    let mf = fit(&measured, "measured")?;
    let ff = fit(&fem, "simulated")?;
    let (lo, hi) = (m0.max(f0), m1.min(f1));
    if !(hi > lo) {
        return Err(no_overlap);
    }
    let grid: Vec<f64> = (0..GRID_POINTS)
        .map(|k| lo + (hi - lo) * k as f64 / (GRID_POINTS - 1) as f64)
        .collect();
    let mv: Vec<f64> = grid.iter().map(|p| mf.eval(*p)).collect();
    let fv: Vec<f64> = grid.iter().map(|p| ff.eval(*p)).collect();
    let dev: Vec<f64> = fv.iter().zip(&mv).map(|(f, m)| f - m).collect();
    let rmse = (dev.iter().map(|d| d * d).sum::<f64>() / dev.len() as f64).sqrt();
    let (k, max) = dev
        .iter()
        .enumerate()
        .map(|(k, d)| (k, d.abs()))
        .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    let scale = (mv.iter().map(|m| m * m).sum::<f64>() / mv.len() as f64).sqrt();
    Ok(QuantityComparison {
        name: name.to_string(),
        measured_fit: mf,
        fem_fit: ff,
        grid_kpa: grid.clone(),
        measured: mv,
        fem: fv,
        rmse,
        max_abs_deviation: max,
        max_deviation_at_kpa: grid[k],
        rmse_pct: 100.0 * rmse / scale.max(1e-300),
    })
}

fn curve(path: &Path, value: &str, scale: f64) -> Result<Curve, CompareError> {
    let cols = read_columns(path, &["pressure_kpa", value])?;
    Ok(Curve {
        pressure_kpa: cols[0].clone(),
        value: cols[1].iter().map(|v| v * scale).collect(),
    })
}

const QUANTITIES: [(&str, &str, &str); 3] = [
    ("radius_mm", "Radius of curvature", "radius (mm)"),
    ("curvature_per_m", "Curvature", "curvature (1/m)"),
    ("bending_angle_deg", "Bending angle", "bending angle (deg)"),
];

/// What [`compare_to`] found.
#[derive(Debug, Clone)]
pub struct CompareReport {
    /// The text of summary.txt.
    pub summary: String,
    /// One comparison per quantity that could be fitted.
    pub results: Vec<QuantityComparison>,
    /// Quantities that could not be compared, with why.
    pub warnings: Vec<String>,
    /// Points left out of the fits (at or below 0 kPa), by table.
    pub notes: Vec<String>,
}

/// A note naming the rows of `table` at or below 0 kPa (left out of the fits), if any.
fn zero_pressure_note(table: &Path) -> Result<Option<String>, CompareError> {
    let p = &read_columns(table, &["pressure_kpa"])?[0];
    let zero: Vec<String> = p
        .iter()
        .filter(|p| **p <= 0.0)
        .map(|p| format!("{p}"))
        .collect();
    Ok((!zero.is_empty()).then(|| {
        format!(
            "{}: {} row(s) at or below 0 kPa ({} kPa) left out of the fits (y = a p^b + c needs p > 0)",
            table.display(),
            zero.len(),
            zero.join(", ")
        )
    }))
}

/// Compares `measured` (a `process` output folder) with `fem` (a `simulate` output
/// folder), with the measured blocked force (`pressure_kpa,force_g`) when given, and
/// writes compare.csv, compare.json, summary.txt and plots/ into `out`.
pub fn compare_to(
    measured: &Path,
    fem: &Path,
    force: Option<&Path>,
    out: &Path,
) -> Result<CompareReport, CompareError> {
    let per_video = measured.join("per_video.csv");
    let steps = fem.join("steps.csv");
    for (p, what) in [
        (&per_video, "bendscope process"),
        (&steps, "bendscope simulate"),
    ] {
        if !p.is_file() {
            return Err(CompareError::Missing {
                path: p.to_path_buf(),
                why: format!("give the output folder of `{what}`"),
            });
        }
    }
    let mut pairs: Vec<(String, String, String, Curve, Curve)> = Vec::new();
    for (name, title, axis) in QUANTITIES {
        pairs.push((
            name.into(),
            title.into(),
            axis.into(),
            curve(&per_video, name, 1.0)?,
            curve(&steps, name, 1.0)?,
        ));
    }
    if let Some(force) = &force {
        let measured = curve(force, "force_g", N_PER_GF)?;
        let fem_force = fem.join("force.csv");
        if !fem_force.is_file() {
            return Err(CompareError::Missing {
                path: fem_force,
                why: "run bendscope simulate with --blocked to compare forces".into(),
            });
        }
        pairs.push((
            "force_n".into(),
            "Blocked tip force".into(),
            "force (N)".into(),
            measured,
            curve(&fem_force, "force_n", 1.0)?,
        ));
    }
    std::fs::create_dir_all(out).map_err(output)?;
    let mut results: Vec<QuantityComparison> = Vec::new();
    let mut notes = Vec::new();
    for table in [&per_video, &steps] {
        notes.extend(zero_pressure_note(table)?);
    }
    let mut summary = format!(
        "bendscope compare: measured {} vs simulated {}\nfits y = a p^b + c, compared on a common pressure grid; {DEVIATION_MEANING}\n",
        measured.display(),
        fem.display()
    );
    for n in &notes {
        let _ = writeln!(summary, "note: {n}");
    }
    summary.push('\n');
    let mut warnings = Vec::new();
    for (name, title, axis, m, f) in &pairs {
        let c = match compare_quantity(name, m, f) {
            Ok(c) => c,
            Err(e @ CompareError::NoOverlap { .. }) => return Err(e),
            Err(e) => {
                warnings.push(e.to_string());
                continue;
            }
        };
        let _ = writeln!(
            summary,
            "{name:>18}: RMSE {:.4} ({:.2}% of the measured RMS), max |deviation| {:.4} at {:.1} kPa over {:.1}-{:.1} kPa",
            c.rmse,
            c.rmse_pct,
            c.max_abs_deviation,
            c.max_deviation_at_kpa,
            c.grid_kpa[0],
            c.grid_kpa[c.grid_kpa.len() - 1]
        );
        let stem = out.join("plots").join(
            name.trim_end_matches("_mm")
                .trim_end_matches("_per_m")
                .trim_end_matches("_deg")
                .trim_end_matches("_n"),
        );
        plot_xy(
            &stem,
            &format!("{title}: measured vs FEM"),
            "pressure (kPa)",
            axis,
            &[
                Series {
                    label: "measured",
                    points: m
                        .pressure_kpa
                        .iter()
                        .copied()
                        .zip(m.value.iter().copied())
                        .collect(),
                    line: false,
                    errors: None,
                },
                Series {
                    label: "measured fit",
                    points: c
                        .grid_kpa
                        .iter()
                        .copied()
                        .zip(c.measured.iter().copied())
                        .collect(),
                    line: true,
                    errors: None,
                },
                Series {
                    label: "FEM",
                    points: f
                        .pressure_kpa
                        .iter()
                        .copied()
                        .zip(f.value.iter().copied())
                        .collect(),
                    line: false,
                    errors: None,
                },
                Series {
                    label: "FEM fit",
                    points: c
                        .grid_kpa
                        .iter()
                        .copied()
                        .zip(c.fem.iter().copied())
                        .collect(),
                    line: true,
                    errors: None,
                },
            ],
        )
        .map_err(output)?;
        results.push(c);
    }
    if let Some(first) = results.first() {
        let mut cols = vec![Column::num(
            "pressure_kpa",
            5,
            first.grid_kpa.iter().copied(),
        )];
        for c in &results {
            cols.push(Column::num(
                format!("{}_measured", c.name),
                5,
                c.measured.iter().copied(),
            ));
            cols.push(Column::num(
                format!("{}_fem", c.name),
                5,
                c.fem.iter().copied(),
            ));
            cols.push(Column::num(
                format!("{}_deviation", c.name),
                5,
                c.fem.iter().zip(&c.measured).map(|(f, m)| f - m),
            ));
        }
        // Quantities share the grid only when their ranges agree; radius, curvature and
        // angle come from the same two tables, so they do; force may not.
        if !results.iter().all(|c| c.grid_kpa == first.grid_kpa) {
            cols.truncate(1 + 3 * 3);
        }
        write_csv(&out.join("compare.csv"), &cols)?;
    }
    write_json(&out.join("compare.json"), &results).map_err(output)?;
    write_atomic(&out.join("summary.txt"), summary.as_bytes()).map_err(output)?;
    Ok(CompareReport {
        summary,
        results,
        warnings,
        notes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn read_columns_keeps_complete_rows_and_names_a_missing_column() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("per_video.csv");
        std::fs::write(
            &p,
            "\u{feff}file,pressure_kpa,radius_mm,status\r\na,20,100.5,ok\r\n\"b, c\",40,,\"no frame, measured\"\r\nd,60,inf,x\r\ne,80,50,ok\r\n",
        )
        .unwrap();
        let c = read_columns(&p, &["pressure_kpa", "radius_mm"]).unwrap();
        assert_eq!(c, vec![vec![20.0, 80.0], vec![100.5, 50.0]]);
        let e = read_columns(&p, &["pressure_kpa", "force_n"])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("per_video.csv: line 1: no `force_n` column in the header `file,pressure_kpa,radius_mm,status`"),
            "{e}"
        );
    }

    #[test]
    fn identical_laws_on_different_points_agree_and_offsets_show() {
        let law = |p: f64| 300.0 * p.powf(-0.45) + 5.0;
        let measured = Curve {
            pressure_kpa: vec![12.0, 27.0, 41.0, 66.0, 80.0, 97.0],
            value: vec![12.0, 27.0, 41.0, 66.0, 80.0, 97.0]
                .iter()
                .map(|p| law(*p))
                .collect(),
        };
        let fem = Curve {
            pressure_kpa: (2..=23).map(|k| 5.0 * k as f64).collect(),
            value: (2..=23).map(|k| law(5.0 * k as f64)).collect(),
        };
        let c = compare_quantity("radius_mm", &measured, &fem).unwrap();
        assert!(
            c.rmse < 1e-4 && c.max_abs_deviation < 1e-4,
            "{} {}",
            c.rmse,
            c.max_abs_deviation
        );
        assert!(
            (c.grid_kpa[0] - 12.0).abs() < 1e-12
                && (c.grid_kpa[GRID_POINTS - 1] - 97.0).abs() < 1e-12
        );
        // A simulated curve 2 mm above: RMSE and max deviation 2 mm.
        let shifted = Curve {
            value: fem.value.iter().map(|v| v + 2.0).collect(),
            ..fem.clone()
        };
        let c = compare_quantity("radius_mm", &measured, &shifted).unwrap();
        assert!((c.rmse - 2.0).abs() < 1e-3 && (c.max_abs_deviation - 2.0).abs() < 1e-3);
        let apart = Curve {
            pressure_kpa: vec![150.0, 160.0, 170.0, 180.0],
            value: vec![1.0, 2.0, 3.0, 4.0],
        };
        let e = compare_quantity("radius_mm", &measured, &apart)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("do not overlap") && e.contains("12.0-97.0"),
            "{e}"
        );
    }

    #[test]
    fn one_measured_pressure_is_no_fit_and_zero_kpa_points_are_left_out() {
        let law = |p: f64| 300.0 * p.powf(-0.45) + 5.0;
        let fem = Curve {
            pressure_kpa: (0..=23).map(|k| 5.0 * k as f64).collect(),
            value: (0..=23).map(|k| law(5.0 * k as f64).min(1e6)).collect(),
        };
        let one = Curve {
            pressure_kpa: vec![40.0; 4],
            value: vec![60.0, 60.2, 59.9, 60.1],
        };
        let e = compare_quantity("radius_mm", &one, &fem)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("measured radius_mm: ") && e.contains("got 1 (40)"),
            "{e}"
        );
        // A rest row at 0 kPa (radius huge) and the FEM's 0 kPa step: left out, so the
        // identical laws agree.
        let measured = Curve {
            pressure_kpa: vec![0.0, 12.0, 41.0, 66.0, 97.0],
            value: vec![5000.0, law(12.0), law(41.0), law(66.0), law(97.0)],
        };
        let c = compare_quantity("radius_mm", &measured, &fem).unwrap();
        assert!(c.rmse < 1e-3, "{}", c.rmse);
        assert_eq!(
            (c.grid_kpa[0], c.measured_fit.n, c.fem_fit.n),
            (12.0, 4, 23)
        );
    }
}
