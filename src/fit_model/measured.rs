//! The measured curve of a `process` output: `per_video.csv`'s measured rows.

use std::path::{Path, PathBuf};

use crate::table::Table;

use super::FitModelError;

/// Measured points: one per measured row of `per_video.csv` with a positive pressure.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    /// The table read.
    pub path: PathBuf,
    /// Pressure, kPa.
    pub pressure_kpa: Vec<f64>,
    /// Mean radius, mm.
    pub radius_mm: Vec<f64>,
    /// Mean curvature, 1/m.
    pub curvature_per_m: Vec<f64>,
    /// Rows left out (not measured, zero pressure, no radius).
    pub skipped: usize,
}

impl Measured {
    /// Reads `OUT/per_video.csv` (or a CSV path given directly): columns
    /// `pressure_kpa`, `radius_mm`, `curvature_per_m` and, when present, `status` (rows
    /// with `ok` or `partial: ...` are measured).
    pub fn read(out: &Path) -> Result<Measured, FitModelError> {
        let path = if out.is_dir() {
            out.join("per_video.csv")
        } else {
            out.to_path_buf()
        };
        if !path.exists() {
            return Err(FitModelError::Measured {
                path,
                why: "not found: give the output folder of bendscope process (it holds per_video.csv)".into(),
            });
        }
        let table = Table::read(&path)?;
        let hint = "give the per_video.csv of bendscope process";
        let p = table.require("pressure_kpa", hint)?;
        let r = table.require("radius_mm", hint)?;
        let k = table.require("curvature_per_m", hint)?;
        let status = table.column("status");
        let mut m = Measured {
            path: path.clone(),
            pressure_kpa: Vec::new(),
            radius_mm: Vec::new(),
            curvature_per_m: Vec::new(),
            skipped: 0,
        };
        for row in 0..table.len() {
            let measured = status.is_none_or(|c| {
                let s = table.cell(row, c).trim();
                s == "ok" || s.starts_with("partial")
            });
            let num = |c: usize| table.f64_at(row, c).ok().filter(|v| v.is_finite());
            match (measured, num(p), num(r), num(k)) {
                (true, Some(p), Some(r), Some(k)) if p > 0.0 && r > 0.0 && k > 0.0 => {
                    m.pressure_kpa.push(p);
                    m.radius_mm.push(r);
                    m.curvature_per_m.push(k);
                }
                _ => m.skipped += 1,
            }
        }
        if m.pressure_kpa.is_empty() {
            return Err(FitModelError::Measured {
                path,
                why: "no measured row with a positive pressure and radius".into(),
            });
        }
        Ok(m)
    }

    /// The distinct pressures, increasing, kPa.
    pub fn pressures(&self) -> Vec<f64> {
        let mut p = self.pressure_kpa.clone();
        p.sort_by(f64::total_cmp);
        p.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        p
    }
}
