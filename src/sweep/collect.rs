//! Merges the points of a sweep folder into `designs.csv` (one row per point) and
//! `failures.csv` (the points without a complete result, with the reason).
//!
//! Columns of designs.csv: `id`, `status` (ok, stopped, failed, running, interrupted,
//! pending),
//! `seconds`, one column per factor named as in the plan, then for each kept pressure P
//! (as written in the plan) `radius_mm@P`, `curvature_per_m@P`, `bending_angle_deg@P`,
//! `max_principal_stress_mpa@P`, `safety_factor@P`, `bottom_elongation_pct@P`,
//! `cavity_volume_mm3@P`, with `blocked = true` also `blocked_force_n@P`, with
//! `analytic = true` also `bending_angle_deg_analytic@P` and `radius_mm_analytic@P`, and
//! last `height_mm`. The FEM cells are copied as text from the point's `steps.csv` (and
//! `force.csv`): exactly what `bendscope simulate` writes for the same config. A pressure
//! the point did not reach is an empty cell.

use std::path::{Path, PathBuf};

use super::run::{point_dir, read_manifest, read_point_config, read_status, PointState};
use super::SweepError;
use crate::fem::analytic::analytic_config;
use crate::table::{write_csv, Column, Table};

/// The FEM results kept per pressure: the steps.csv columns.
pub const RESULT_COLUMNS: [&str; 7] = [
    "radius_mm",
    "curvature_per_m",
    "bending_angle_deg",
    "max_principal_stress_mpa",
    "safety_factor",
    "bottom_elongation_pct",
    "cavity_volume_mm3",
];

/// Tolerance on a pressure when finding it in steps.csv, kPa (written with 4 decimals).
const PRESSURE_MATCH_KPA: f64 = 1e-3;

/// Counts of a collection.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Collected {
    /// Points.
    pub points: usize,
    /// Complete.
    pub ok: usize,
    /// Stopped early (partial rows).
    pub stopped: usize,
    /// Failed.
    pub failed: usize,
    /// Not started or not finished.
    pub unfinished: usize,
    /// designs.csv.
    pub designs: PathBuf,
}

/// The cells of `columns` in the row of `pressure_kpa`, as text (`None`: not there).
fn cells_at(table: &Table, columns: &[&str], pressure_kpa: f64) -> Option<Vec<String>> {
    let p = table.column("pressure_kpa")?;
    let row = (0..table.len()).find(|r| {
        table
            .f64_at(*r, p)
            .is_ok_and(|v| (v - pressure_kpa).abs() < PRESSURE_MATCH_KPA)
    })?;
    columns
        .iter()
        .map(|c| table.column(c).map(|k| table.cell(row, k).to_string()))
        .collect()
}

/// Collects the sweep folder `dir` into `dir/designs.csv` and `dir/failures.csv`.
pub fn collect(dir: &Path) -> Result<Collected, SweepError> {
    let m = read_manifest(dir)?;
    let n = m.points.len();
    let mut status = Vec::with_capacity(n);
    let mut seconds = Vec::with_capacity(n);
    let mut height = Vec::with_capacity(n);
    let mut failures: Vec<[String; 3]> = Vec::new();
    // Per pressure, per result column, the cells.
    let mut fem = vec![vec![Vec::with_capacity(n); RESULT_COLUMNS.len() + 1]; m.pressures.len()];
    let mut analytic = vec![vec![Vec::with_capacity(n); 2]; m.pressures.len()];
    let mut counts = Collected {
        points: n,
        designs: dir.join("designs.csv"),
        ..Default::default()
    };
    let kpa: Vec<f64> = m.pressures.iter().map(|p| p.kpa).collect();
    for p in &m.points {
        let point = point_dir(dir, &p.id);
        let st = read_status(&point);
        let state = st.as_ref().map_or(PointState::Pending, |s| s.status);
        match state {
            PointState::Ok => counts.ok += 1,
            PointState::Stopped => counts.stopped += 1,
            PointState::Failed => counts.failed += 1,
            PointState::Running | PointState::Interrupted | PointState::Pending => {
                counts.unfinished += 1
            }
        }
        if state != PointState::Ok {
            let reason = st
                .as_ref()
                .and_then(|s| s.reason.clone())
                .unwrap_or_else(|| {
                    if state == PointState::Running {
                        "started, not finished: still running, or killed (see its log)".into()
                    } else {
                        "not run yet".into()
                    }
                });
            failures.push([p.id.clone(), state.as_str().into(), reason]);
        }
        status.push(state.as_str().to_string());
        seconds.push(
            st.as_ref()
                .filter(|s| s.status.finished() || s.status == PointState::Failed)
                .map_or(f64::NAN, |s| s.seconds),
        );
        let cfg = read_point_config(&point).ok();
        height.push(cfg.as_ref().map_or(f64::NAN, |c| c.height_mm()));
        let steps = state
            .finished()
            .then(|| Table::read(&point.join("steps.csv")).ok())
            .flatten();
        let force = (state.finished() && m.blocked)
            .then(|| Table::read(&point.join("force.csv")).ok())
            .flatten();
        for (k, p_kpa) in kpa.iter().enumerate() {
            let row = steps
                .as_ref()
                .and_then(|t| cells_at(t, &RESULT_COLUMNS, *p_kpa));
            for (c, cells) in fem[k].iter_mut().take(RESULT_COLUMNS.len()).enumerate() {
                cells.push(row.as_ref().map(|r| r[c].clone()).unwrap_or_default());
            }
            let f = force
                .as_ref()
                .and_then(|t| cells_at(t, &["force_n"], *p_kpa));
            fem[k][RESULT_COLUMNS.len()].push(f.map(|mut r| r.remove(0)).unwrap_or_default());
        }
        let model = cfg
            .as_ref()
            .filter(|_| m.analytic)
            .and_then(|c| analytic_config(c, &kpa).ok());
        for (k, cells) in analytic.iter_mut().enumerate() {
            let s = model.as_ref().map(|v| v[k]);
            cells[0].push(s.map_or(f64::NAN, |s| s.bending_angle_deg));
            cells[1].push(s.map_or(f64::NAN, |s| s.radius_mm));
        }
    }
    let mut cols = vec![
        Column::text("id", m.points.iter().map(|p| p.id.clone())),
        Column::text("status", status),
        Column::num("seconds", 3, seconds),
    ];
    for (j, f) in m.factors.iter().enumerate() {
        cols.push(Column::text(
            f,
            m.points.iter().map(|p| p.values[j].clone()),
        ));
    }
    for (k, p) in m.pressures.iter().enumerate() {
        let mut cells = std::mem::take(&mut fem[k]);
        let force = cells.pop().unwrap_or_default();
        for (name, c) in RESULT_COLUMNS.iter().zip(cells) {
            cols.push(Column::text(format!("{name}@{}", p.label), c));
        }
        if m.blocked {
            cols.push(Column::text(format!("blocked_force_n@{}", p.label), force));
        }
    }
    if m.analytic {
        for (k, p) in m.pressures.iter().enumerate() {
            let [angle, radius]: [Vec<f64>; 2] = std::mem::take(&mut analytic[k])
                .try_into()
                .unwrap_or_default();
            cols.push(Column::num(
                format!("bending_angle_deg_analytic@{}", p.label),
                4,
                angle,
            ));
            cols.push(Column::num(
                format!("radius_mm_analytic@{}", p.label),
                4,
                radius,
            ));
        }
    }
    cols.push(Column::num("height_mm", 4, height));
    write_csv(&counts.designs, &cols).map_err(|e| SweepError::io(&counts.designs, e))?;
    let path = dir.join("failures.csv");
    write_csv(
        &path,
        &[
            Column::text("id", failures.iter().map(|f| f[0].clone())),
            Column::text("status", failures.iter().map(|f| f[1].clone())),
            Column::text("reason", failures.iter().map(|f| f[2].clone())),
        ],
    )
    .map_err(|e| SweepError::io(&path, e))?;
    Ok(counts)
}
