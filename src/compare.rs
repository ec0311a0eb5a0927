//! Experiment against simulation: both curves of a quantity vs pressure (radius,
//! curvature, bending angle, blocked force) are fitted with the power law
//! y = a p^b + c ([`crate::fit::fit_power_law`]), evaluated on a common pressure grid over
//! the range both cover, and compared: the deviation curve, its RMSE and its largest
//! magnitude. The two need not share pressure points.

use std::path::Path;

use polars::prelude::*;
use serde::Serialize;

use crate::fit::{fit_power_law, PowerLawFit};

/// Points of the common pressure grid.
pub const GRID_POINTS: usize = 41;

/// Errors of the comparison.
#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    /// A results table cannot be read.
    #[error("cannot read {path}: {why}")]
    Read {
        /// The file.
        path: std::path::PathBuf,
        /// What went wrong.
        why: String,
    },
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
    /// A curve could not be fitted.
    #[error("{what}: {why}")]
    Fit {
        /// The curve.
        what: String,
        /// Why.
        why: String,
    },
}

/// Reads the named columns of a CSV as f64 (polars); rows with an empty or non-numeric
/// cell in any of them are dropped.
pub fn read_columns(path: &Path, names: &[&str]) -> Result<Vec<Vec<f64>>, CompareError> {
    let err = |why: String| CompareError::Read {
        path: path.to_path_buf(),
        why,
    };
    let df = CsvReadOptions::default()
        .with_has_header(true)
        .try_into_reader_with_file_path(Some(path.to_path_buf()))
        .and_then(|r| r.finish())
        .map_err(|e| err(e.to_string()))?;
    let mut cols = Vec::new();
    for name in names {
        let c = df
            .column(name)
            .map_err(|_| err(format!("no column '{name}'")))?
            .cast(&DataType::Float64)
            .map_err(|e| err(e.to_string()))?;
        let v: Vec<f64> = c
            .f64()
            .map_err(|e| err(e.to_string()))?
            .iter()
            .map(|x| x.unwrap_or(f64::NAN))
            .collect();
        cols.push(v);
    }
    let n = cols.first().map(|c| c.len()).unwrap_or(0);
    let keep: Vec<usize> = (0..n)
        .filter(|i| cols.iter().all(|c| c[*i].is_finite()))
        .collect();
    Ok(cols
        .into_iter()
        .map(|c| keep.iter().map(|i| c[*i]).collect())
        .collect())
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
    /// RMS of (simulated − measured) on the grid.
    pub rmse: f64,
    /// Largest |simulated − measured| on the grid.
    pub max_abs_deviation: f64,
    /// Pressure of that largest deviation, kPa.
    pub max_deviation_at_kpa: f64,
    /// RMSE relative to the RMS of the measured values, %.
    pub rmse_pct: f64,
}

fn range(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        })
}

/// Fits both curves and compares them on the overlap of their pressure ranges.
pub fn compare_quantity(
    name: &str,
    measured: &Curve,
    fem: &Curve,
) -> Result<QuantityComparison, CompareError> {
    let (m0, m1) = range(&measured.pressure_kpa);
    let (f0, f1) = range(&fem.pressure_kpa);
    let (lo, hi) = (m0.max(f0), m1.min(f1));
    if !(hi > lo) {
        return Err(CompareError::NoOverlap { m0, m1, f0, f1 });
    }
    let fit = |c: &Curve, what: &str| {
        fit_power_law(&c.pressure_kpa, &c.value).map_err(|e| CompareError::Fit {
            what: format!("{what} {name}"),
            why: e.to_string(),
        })
    };
    let mf = fit(measured, "measured")?;
    let ff = fit(fem, "simulated")?;
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
