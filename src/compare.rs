//! Experiment against simulation: both curves of a quantity vs pressure (radius,
//! curvature, bending angle, blocked force) are fitted with the power law
//! y = a p^b + c ([`crate::fit::fit_power_law`]), evaluated on a common pressure grid over
//! the range both cover, and compared: the deviation curve, its RMSE and its largest
//! magnitude. The two need not share pressure points.

use std::path::Path;

use serde::Serialize;

use crate::fit::{fit_power_law, PowerLawFit};
use crate::table::{Table, TableError};

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
}
