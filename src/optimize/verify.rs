//! The best designs simulated with the FEM ([`crate::fem::output::simulate_to`], the
//! plan's base config with the design's inputs set) and compared with what the
//! surrogates predicted.

use std::path::Path;

use serde::Serialize;

use super::{plan::column_pressure, plan::HEIGHT_COLUMN, Evaluation, OptimizeError, Problem};
use crate::fem::output::{simulate_to, SimulateOptions};
use crate::fem::simulate::StepResult;
use crate::surrogate::Prediction;
use crate::table::{write_csv, Column, TableError};

/// Pressures closer than this are the same step, kPa.
const PRESSURE_MATCH_KPA: f64 = 1e-6;

/// A design checked with the FEM.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verified {
    /// Inputs.
    pub x: Vec<f64>,
    /// The surrogates' predictions, per column of [`Problem::columns`].
    pub predicted: Vec<Prediction>,
    /// The FEM's values, per column (NaN when the ramp did not reach the pressure).
    pub fem: Vec<f64>,
    /// Every constraint met by the FEM's values.
    pub feasible_fem: bool,
    /// `ok`, or why the simulation stopped.
    pub status: String,
    /// Folder of the run (relative to the output folder).
    pub run: String,
    /// Inputs outside the designs' range (the surrogates extrapolated there), as
    /// `name = v (designs: lo to hi)`; empty inside.
    pub extrapolated: Vec<String>,
}

/// The value of `column` (`name@P`) in a ramp's steps; NaN when absent.
pub fn fem_value(column: &str, steps: &[StepResult], height_mm: f64) -> f64 {
    if column == HEIGHT_COLUMN {
        return height_mm;
    }
    let Some(p) = column_pressure(column).and_then(|p| p.parse::<f64>().ok()) else {
        return f64::NAN;
    };
    let name = column.split('@').next().unwrap_or("");
    let Some(s) = steps
        .iter()
        .find(|s| (s.pressure_kpa - p).abs() < PRESSURE_MATCH_KPA)
    else {
        return f64::NAN;
    };
    match name {
        "radius_mm" => s.radius_mm,
        "curvature_per_m" => s.curvature_per_m,
        "bending_angle_deg" => s.bending_angle_deg,
        "max_principal_stress_mpa" => s.max_principal_stress_mpa,
        "safety_factor" => s.safety_factor,
        "bottom_elongation_pct" => s.bottom_elongation_pct,
        "cavity_volume_mm3" => s.cavity_volume_mm3,
        "tip_x_mm" => s.tip_x_mm,
        "tip_z_mm" => s.tip_z_mm,
        _ => f64::NAN,
    }
}

/// Simulates each design into `runs/<k>/`; `progress` sees each design and FEM step.
pub fn resimulate(
    problem: &Problem,
    designs: &[Evaluation],
    runs: &Path,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<Verified>, OptimizeError> {
    let mut out = Vec::new();
    for (k, e) in designs.iter().enumerate() {
        let cfg = problem.config(&e.x)?;
        let name = format!("{}", k + 1);
        let dir = runs.join(&name);
        progress(&format!("FEM design {}/{}", k + 1, designs.len()));
        let (steps, status) =
            match simulate_to(&dir, &cfg, SimulateOptions::default(), &mut |_, _| {
                progress("FEM step")
            }) {
                Ok(sim) => (
                    sim.steps,
                    sim.summary.failure.unwrap_or_else(|| "ok".to_string()),
                ),
                Err(err) => (Vec::new(), format!("failed: {err}")),
            };
        let height = cfg.height_mm();
        let fem: Vec<f64> = problem
            .columns
            .iter()
            .map(|c| fem_value(c, &steps, height))
            .collect();
        let feasible_fem = problem.plan.constraints.iter().all(|c| {
            let v = fem[problem.column_index(&c.column)];
            v.is_finite() && c.margin(v) <= 0.0
        });
        out.push(Verified {
            x: e.x.clone(),
            predicted: e.values.clone(),
            fem,
            feasible_fem,
            status,
            run: format!("runs/{name}"),
            extrapolated: problem.outside_designs(&e.x),
        });
    }
    Ok(out)
}

/// Writes `verified.csv`: per design its inputs, then per column the surrogate's mean and
/// std and the FEM's value, then whether the FEM meets the constraints, the status, the
/// run folder and the inputs outside the designs' range (`extrapolated`, empty inside).
pub fn write_verified(path: &Path, problem: &Problem, rows: &[Verified]) -> Result<(), TableError> {
    let mut cols = vec![Column::int(
        "rank",
        (1..=rows.len() as u64).collect::<Vec<_>>(),
    )];
    for (j, i) in problem.plan.inputs.iter().enumerate() {
        cols.push(Column::num(&i.name, 4, rows.iter().map(|r| r.x[j])));
    }
    for (k, c) in problem.columns.iter().enumerate() {
        cols.push(Column::num(
            format!("{c}_surrogate"),
            4,
            rows.iter().map(|r| r.predicted[k].mean),
        ));
        cols.push(Column::num(
            format!("{c}_std"),
            4,
            rows.iter().map(|r| r.predicted[k].std),
        ));
        cols.push(Column::num(
            format!("{c}_fem"),
            4,
            rows.iter().map(|r| r.fem[k]),
        ));
    }
    cols.push(Column::text(
        "feasible_fem",
        rows.iter().map(|r| r.feasible_fem.to_string()),
    ));
    cols.push(Column::text(
        "status",
        rows.iter().map(|r| r.status.clone()),
    ));
    cols.push(Column::text("run", rows.iter().map(|r| r.run.clone())));
    cols.push(Column::text(
        "extrapolated",
        rows.iter().map(|r| r.extrapolated.join("; ")),
    ));
    write_csv(path, &cols)
}
