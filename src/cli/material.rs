//! `bendscope material`: fit a hyperelastic model to uniaxial test data; list the presets.

use std::path::PathBuf;

use anyhow::Result;
use bendscope::fem::material::MaterialPreset;
use bendscope::material_fit::{
    fit_material, write_material_fit, MaterialBlock, ModelKind, TensileData,
};
use clap::{Args, Subcommand};

use super::{EXIT_BAD_INPUT, EXIT_OK, EXIT_PARTIAL};

/// Material models: fit one to a tensile test, list the presets.
#[derive(Debug, Args)]
pub struct MaterialArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: MaterialCommand,
}

/// `material` subcommands.
#[derive(Debug, Subcommand)]
pub enum MaterialCommand {
    /// Fit a hyperelastic model to uniaxial tensile data (stretch or strain vs nominal stress).
    Fit(FitArgs),
    /// Print the material presets of `simulate` (Yeoh coefficients, MPa).
    Presets,
}

/// `material fit`.
#[derive(Debug, Args)]
#[command(
    after_help = "DATA: CSV with the stretch (`stretch`) or strain (`strain` as a fraction, `strain_pct` in %) and the nominal stress with its unit (`stress_mpa`, `stress_kpa`, `stress_pa`, `stress_psi`).
Outputs in OUT: material.toml (a [material] block for simulate --config; not for mooney-rivlin2 or negative Yeoh terms), material_fit.json, material_fit.csv, plots/material_fit.png|svg|pdf.
Exit codes: 0 fitted and block written, 1 fitted but no block written (the reason on stderr), 2 bad input."
)]
pub struct FitArgs {
    /// Uniaxial test data (CSV).
    pub data: PathBuf,
    /// Model: yeoh3, yeoh2, neo-hookean or mooney-rivlin2.
    #[arg(long, value_name = "MODEL", default_value = "yeoh3")]
    pub model: ModelKind,
    /// Hold every coefficient at zero or above (the FEM's Yeoh needs C2, C3 >= 0).
    #[arg(long)]
    pub nonnegative: bool,
    /// Output folder.
    #[arg(short, long, value_name = "OUT", default_value = "material-fit")]
    pub output: PathBuf,
}

/// Runs `bendscope material`.
pub fn run(args: &MaterialArgs) -> Result<u8> {
    match &args.command {
        MaterialCommand::Fit(a) => run_fit(a),
        MaterialCommand::Presets => {
            super::out!("preset        C1 (MPa)    C2 (MPa)    C3 (MPa)");
            for p in [
                MaterialPreset::Proposed,
                MaterialPreset::Stiffer,
                MaterialPreset::Softer,
                MaterialPreset::Ecoflex0030,
                MaterialPreset::Ecoflex0050,
                MaterialPreset::DragonSkin10,
                MaterialPreset::DragonSkin20,
            ] {
                let y = p.yeoh();
                let name = serde_json::to_value(p)
                    .ok()
                    .and_then(|v| v.as_str().map(String::from))
                    .unwrap_or_default();
                super::out!("{name:<13} {:<11} {:<11} {:<11}", y.c1, y.c2, y.c3);
            }
            Ok(EXIT_OK)
        }
    }
}

fn run_fit(args: &FitArgs) -> Result<u8> {
    let _lock = super::lock_output(&args.output)?;
    let data = match TensileData::read(&args.data) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("error: {e}");
            return Ok(EXIT_BAD_INPUT);
        }
    };
    for w in &data.warnings {
        eprintln!("warning: {w}");
    }
    let fit = match fit_material(&data, args.model, args.nonnegative) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("error: {}: {e}", args.data.display());
            return Ok(EXIT_BAD_INPUT);
        }
    };
    let report = write_material_fit(&args.output, &args.data, &data, &fit)?;
    let names = fit.model.kind.coefficient_names();
    super::out!(
        "{} fit of {} points (stretch {:.3}-{:.3}): R^2 = {:.5}, RMSE {:.4} kPa, mu0 = {:.4} MPa",
        fit.model.kind.name(),
        fit.points,
        fit.data_stretch.0,
        fit.data_stretch.1,
        fit.r_squared,
        fit.rmse_mpa * 1e3,
        fit.initial_shear_modulus_mpa
    );
    for ((n, c), e) in names
        .iter()
        .zip(&fit.model.coefficients)
        .zip(&fit.std_errors)
    {
        super::out!("  {n} = {c:.6e} MPa  (+/- {e:.2e})");
    }
    let s = &fit.stability;
    if s.stable {
        super::out!(
            "  Drucker-stable for stretches {:.2}-{:.2} (uniaxial, equibiaxial, planar)",
            s.min_stretch,
            s.max_stretch
        );
    }
    for u in &s.unstable {
        eprintln!(
            "warning: the fit is unstable (Drucker) in {} {} from stretch {:.3}: a simulation reaching that strain will not be trustworthy; use --nonnegative or a model with fewer terms",
            u.mode.name(),
            u.side,
            u.first_stretch
        );
    }
    match &report.material_block {
        MaterialBlock::Yeoh { .. } => {
            super::out!(
                "-> {} (use with bendscope simulate --config)",
                args.output.join("material.toml").display()
            );
            Ok(EXIT_OK)
        }
        MaterialBlock::Refused(why) => {
            eprintln!("note: {why}");
            super::out!("-> {}", args.output.display());
            Ok(EXIT_PARTIAL)
        }
    }
}
