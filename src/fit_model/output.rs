//! A model fit's files: `fitted.toml` (the config with the fitted values, for
//! `simulate --config`), `fit_model.json`, `fit_model.csv` (measured, initial and fitted
//! per measured row) and `plots/fit_model.{png,svg}` (the overlay).

use std::path::Path;

use serde_json::{json, Map, Value};

use super::{FitModelError, Measured, ModelFit, Quantity};
use crate::io::write_atomic;
use crate::report::{plot_xy, write_json, Series};
use crate::table::{write_csv, Column};

fn output(e: impl std::fmt::Display) -> FitModelError {
    FitModelError::Output { why: e.to_string() }
}

/// The JSON report (`fit_model.json`).
pub fn report_json(fit: &ModelFit, measured: &Measured) -> Value {
    let map = |v: &[(String, f64)]| -> Map<String, Value> {
        v.iter().map(|(n, x)| (n.clone(), json!(x))).collect()
    };
    json!({
        "parameters": map(&fit.parameters),
        "std_errors": map(&fit.std_errors),
        "rmse_mm": fit.rmse_mm,
        "max_rel_dev_pct": fit.max_rel_dev_pct,
        "evaluations": fit.stats.evaluations,
        "seconds": fit.seconds,
        "quantity": fit.quantity,
        "rms_rel_pct": fit.rms_rel_pct,
        "initial_rms_rel_pct": fit.initial_rms_rel_pct,
        "initial": fit.free.iter().map(|f| (f.name.clone(), json!(f.initial))).collect::<Map<_, _>>(),
        "bounds": fit.free.iter().map(|f| (f.name.clone(), json!([f.lower, f.upper]))).collect::<Map<_, _>>(),
        "pressures_kpa": fit.pressures_kpa,
        "measured": measured.path,
        "measured_rows": measured.pressure_kpa.len(),
        "simulations": fit.stats,
        "termination": fit.termination,
        "notes": fit.notes,
    })
}

/// The comment lines `fitted.toml` begins with: what was fitted to what, and every
/// warning of the fit (a poor fit, a parameter at its bound), so that the file says them
/// wherever it goes.
pub fn fitted_toml_header(
    measured: &Path,
    parameters: &[(String, f64)],
    notes: &[String],
) -> String {
    let mut header = format!(
        "# Fitted by bendscope fit-model to {}: {}\n",
        measured.display(),
        parameters
            .iter()
            .map(|(n, v)| format!("{n} = {v:.6}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    for n in notes {
        header.push_str(&format!("# warning: {n}\n"));
    }
    header
}

/// Writes every output of a fit into `out`.
pub fn write_fit_model(
    out: &Path,
    fit: &ModelFit,
    measured: &Measured,
) -> Result<(), FitModelError> {
    std::fs::create_dir_all(out.join("plots")).map_err(output)?;
    let text = fit.config.to_toml().map_err(output)?;
    let header = fitted_toml_header(&measured.path, &fit.parameters, &fit.notes);
    write_atomic(
        &out.join("fitted.toml"),
        format!("{header}{text}").as_bytes(),
    )
    .map_err(output)?;
    write_json(&out.join("fit_model.json"), &report_json(fit, measured)).map_err(output)?;
    let at = |c: &super::ModelCurve, q: Quantity, p: f64| -> f64 {
        let k = c
            .pressure_kpa
            .iter()
            .position(|x| (x - p).abs() < 1e-9)
            .unwrap_or(0);
        match q {
            Quantity::Radius => c.radius_mm[k],
            Quantity::Curvature => c.curvature_per_m[k],
        }
    };
    let rows = &measured.pressure_kpa;
    let r = |c: &super::ModelCurve| {
        rows.iter()
            .map(|p| at(c, Quantity::Radius, *p))
            .collect::<Vec<_>>()
    };
    let fitted_r = r(&fit.fitted);
    write_csv(
        &out.join("fit_model.csv"),
        &[
            Column::num("pressure_kpa", 4, rows.iter().copied()),
            Column::num("measured_radius_mm", 4, measured.radius_mm.iter().copied()),
            Column::num("initial_radius_mm", 4, r(&fit.initial)),
            Column::num("fitted_radius_mm", 4, fitted_r.iter().copied()),
            Column::num(
                "radius_dev_pct",
                4,
                fitted_r
                    .iter()
                    .zip(&measured.radius_mm)
                    .map(|(f, m)| 100.0 * (f / m - 1.0)),
            ),
            Column::num(
                "measured_curvature_per_m",
                4,
                measured.curvature_per_m.iter().copied(),
            ),
            Column::num(
                "fitted_curvature_per_m",
                4,
                rows.iter()
                    .map(|p| at(&fit.fitted, Quantity::Curvature, *p)),
            ),
        ],
    )
    .map_err(output)?;
    let (y_label, title, meas): (&str, &str, &[f64]) = match fit.quantity {
        Quantity::Radius => (
            "radius (mm)",
            "Radius vs pressure: measured and model",
            &measured.radius_mm,
        ),
        Quantity::Curvature => (
            "curvature (1/m)",
            "Curvature vs pressure: measured and model",
            &measured.curvature_per_m,
        ),
    };
    let line = |c: &super::ModelCurve| -> Vec<(f64, f64)> {
        c.pressure_kpa
            .iter()
            .map(|p| (*p, at(c, fit.quantity, *p)))
            .collect()
    };
    plot_xy(
        &out.join("plots").join("fit_model"),
        title,
        "pressure (kPa)",
        y_label,
        &[
            Series {
                label: "measured",
                points: rows.iter().copied().zip(meas.iter().copied()).collect(),
                line: false,
                errors: None,
            },
            Series {
                label: "model, initial",
                points: line(&fit.initial),
                line: true,
                errors: None,
            },
            Series {
                label: "model, fitted",
                points: line(&fit.fitted),
                line: true,
                errors: None,
            },
        ],
    )
    .map_err(output)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fitted_toml_carries_the_fits_warnings_as_comments() {
        let note = super::super::poor_fit_note(15.7, 28.0).unwrap();
        let header = fitted_toml_header(
            Path::new("out"),
            &[("material.scale".into(), 0.5)],
            std::slice::from_ref(&note),
        );
        assert_eq!(
            header,
            format!("# Fitted by bendscope fit-model to out: material.scale = 0.500000\n# warning: {note}\n")
        );
        // Still a valid TOML document.
        assert!(toml::from_str::<toml::Table>(&header).is_ok());
        assert_eq!(
            fitted_toml_header(Path::new("out"), &[], &[])
                .lines()
                .count(),
            1
        );
    }
}
