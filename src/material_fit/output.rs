//! The outputs of a material fit: `material.toml` (a `[material]` block `simulate
//! --config` reads, when the FEM can use the model), `material_fit.json`,
//! `material_fit.csv` (data and fitted stress) and `plots/material_fit.{png,svg,pdf}`.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::fit::{MaterialFit, TensileData};
use super::model::ModelKind;
use super::MaterialFitError;
use crate::io::write_atomic;
use crate::report::{plot_xy, write_json, Series};
use crate::table::{write_csv, Column};

/// Points of the fitted curve in the plot.
pub const CURVE_POINTS: usize = 200;

/// The `[material]` block of a fit, or why there is none.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum MaterialBlock {
    /// The FEM's Yeoh coefficients c1, c2, c3, MPa.
    Yeoh {
        /// C1.
        c1: f64,
        /// C2.
        c2: f64,
        /// C3.
        c3: f64,
    },
    /// No block: why, and what to do.
    Refused(String),
}

/// The FEM's Yeoh material for a fit (see [`MaterialBlock`]).
pub fn material_block(fit: &MaterialFit) -> MaterialBlock {
    let c = &fit.model.coefficients;
    let at = |k: usize| c.get(k).copied().unwrap_or(0.0);
    let (c1, c2, c3) = match fit.model.kind {
        ModelKind::MooneyRivlin2 => {
            return MaterialBlock::Refused(
                "the FEM material is Yeoh only (no Mooney-Rivlin element): the Mooney-Rivlin fit is reported but no [material] block is written; fit yeoh3, yeoh2 or neo-hookean for simulate".into(),
            )
        }
        ModelKind::Yeoh3 | ModelKind::Yeoh2 | ModelKind::NeoHookean => (at(0), at(1), at(2)),
    };
    if c1 <= 0.0 {
        return MaterialBlock::Refused(format!(
            "C10 = {c1:.4e} MPa is not positive: the data give no usable stiffness; check the stress column and its unit"
        ));
    }
    if let Some((name, v)) = [("C20", c2), ("C30", c3)]
        .into_iter()
        .find(|(_, v)| *v < 0.0)
    {
        return MaterialBlock::Refused(format!(
            "{name} = {v:.4e} MPa is negative, which the FEM's Yeoh material refuses: no [material] block written; refit with --nonnegative"
        ));
    }
    MaterialBlock::Yeoh { c1, c2, c3 }
}

/// `material_fit.json`.
#[derive(Debug, Clone, Serialize)]
pub struct MaterialFitReport {
    /// The data file.
    pub data: PathBuf,
    /// Model name.
    pub model: &'static str,
    /// Coefficients by name, MPa.
    pub parameters: serde_json::Map<String, serde_json::Value>,
    /// Standard errors by name, MPa.
    pub std_errors: serde_json::Map<String, serde_json::Value>,
    /// The whole fit (stability included).
    pub fit: MaterialFit,
    /// The `[material]` block written, or why none was.
    pub material_block: MaterialBlock,
    /// Implausible values of the data (also on stderr).
    pub warnings: Vec<String>,
}

fn output(e: impl std::fmt::Display) -> MaterialFitError {
    MaterialFitError::Output { why: e.to_string() }
}

/// The text of `material.toml` for a Yeoh block.
pub fn material_toml(fit: &MaterialFit, data: &Path, c: (f64, f64, f64)) -> String {
    let mut material = toml::Table::new();
    for (k, v) in [("c1", c.0), ("c2", c.1), ("c3", c.2)] {
        material.insert(k.into(), toml::Value::Float(v));
    }
    let mut doc = toml::Table::new();
    doc.insert("material".into(), toml::Value::Table(material));
    format!(
        "# {} fit of {} by bendscope material fit: R^2 = {:.5}, {} points, stretch {:.3}-{:.3}\n\
         # Use as `bendscope simulate --config` or paste into an actuator config; density_g_cm3\n\
         # and tensile_strength_mpa keep Dragon Skin 30's defaults unless set here.\n{}",
        fit.model.kind.name(),
        data.display(),
        fit.r_squared,
        fit.points,
        fit.data_stretch.0,
        fit.data_stretch.1,
        toml::to_string(&doc).unwrap_or_default()
    )
}

/// Writes every output of a fit into `out`; returns the report (also in
/// `material_fit.json`).
pub fn write_material_fit(
    out: &Path,
    data_path: &Path,
    data: &TensileData,
    fit: &MaterialFit,
) -> Result<MaterialFitReport, MaterialFitError> {
    std::fs::create_dir_all(out.join("plots")).map_err(output)?;
    let block = material_block(fit);
    let toml_path = out.join("material.toml");
    match &block {
        MaterialBlock::Yeoh { c1, c2, c3 } => write_atomic(
            &toml_path,
            material_toml(fit, data_path, (*c1, *c2, *c3)).as_bytes(),
        )
        .map_err(output)?,
        MaterialBlock::Refused(_) => match std::fs::remove_file(&toml_path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(output(e)),
            _ => {}
        },
    }
    let unit = data.stress_unit;
    let fitted: Vec<f64> = data
        .stretch
        .iter()
        .map(|l| fit.model.uniaxial_nominal_stress(*l))
        .collect();
    let in_unit = |v: &[f64]| v.iter().map(|p| p / unit.mpa()).collect::<Vec<f64>>();
    write_csv(
        &out.join("material_fit.csv"),
        &[
            Column::num("stretch", 6, data.stretch.iter().copied()),
            Column::num(
                format!("stress_{}", unit.name()),
                6,
                in_unit(&data.stress_mpa),
            ),
            Column::num(format!("fitted_{}", unit.name()), 6, in_unit(&fitted)),
        ],
    )
    .map_err(output)?;
    let (lo, hi) = fit.data_stretch;
    let lo = lo.min(1.0);
    let curve: Vec<(f64, f64)> = (0..=CURVE_POINTS)
        .map(|k| {
            let l = lo + (hi - lo) * k as f64 / CURVE_POINTS as f64;
            (l, fit.model.uniaxial_nominal_stress(l) / unit.mpa())
        })
        .collect();
    let label = format!("{} fit", fit.model.kind.name());
    plot_xy(
        &out.join("plots").join("material_fit"),
        &format!(
            "Uniaxial nominal stress, {} (R² {:.4})",
            fit.model.kind.name(),
            fit.r_squared
        ),
        "stretch",
        &format!("nominal stress ({})", unit.name()),
        &[
            Series {
                label: "data",
                points: data
                    .stretch
                    .iter()
                    .zip(in_unit(&data.stress_mpa))
                    .map(|(l, p)| (*l, p))
                    .collect(),
                line: false,
                errors: None,
            },
            Series {
                label: &label,
                points: curve,
                line: true,
                errors: None,
            },
        ],
    )
    .map_err(output)?;
    let names = fit.model.kind.coefficient_names();
    let map = |v: &[f64]| {
        names
            .iter()
            .zip(v)
            .map(|(n, x)| (format!("{n}_mpa"), serde_json::json!(x)))
            .collect::<serde_json::Map<_, _>>()
    };
    let report = MaterialFitReport {
        data: data_path.to_path_buf(),
        model: fit.model.kind.name(),
        parameters: map(&fit.model.coefficients),
        std_errors: map(&fit.std_errors),
        fit: fit.clone(),
        material_block: block,
        warnings: data.warnings.clone(),
    };
    write_json(&out.join("material_fit.json"), &report).map_err(output)?;
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::actuator::ActuatorConfig;
    use crate::material_fit::fit::{fit_material, StressUnit};

    #[test]
    fn the_block_is_a_config_simulate_reads_with_the_fitted_coefficients() {
        let l: Vec<f64> = (0..20).map(|k| 1.0 + 0.1 * k as f64).collect();
        let m = crate::material_fit::Hyperelastic {
            kind: ModelKind::Yeoh2,
            coefficients: vec![0.0127, 4.23e-4],
        };
        let data = TensileData {
            stress_mpa: l.iter().map(|x| m.uniaxial_nominal_stress(*x)).collect(),
            stretch: l,
            stress_unit: StressUnit::Kpa,
            warnings: vec![],
        };
        let fit = fit_material(&data, ModelKind::Yeoh2, false).unwrap();
        let MaterialBlock::Yeoh { c1, c2, c3 } = material_block(&fit) else {
            panic!("no block")
        };
        let text = material_toml(&fit, Path::new("t.csv"), (c1, c2, c3));
        let cfg: ActuatorConfig = toml::from_str(&text).unwrap();
        let y = cfg.material.yeoh().unwrap();
        assert!((y.c1 / 0.0127 - 1.0).abs() < 1e-6 && (y.c2 / 4.23e-4 - 1.0).abs() < 1e-6);
        assert_eq!(y.c3, 0.0);
        let mr = fit_material(&data, ModelKind::MooneyRivlin2, false).unwrap();
        assert!(
            matches!(material_block(&mr), MaterialBlock::Refused(w) if w.contains("Yeoh only"))
        );
    }
}
