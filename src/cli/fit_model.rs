//! `bendscope fit-model`: the actuator model's free parameters fitted to a measurement.

use std::path::PathBuf;

use anyhow::Result;
use bendscope::fem::actuator::ActuatorConfig;
use bendscope::fit_model::{
    fit_model, parse_free, write_fit_model, FitModelError, FitModelSettings, Measured, Quantity,
};
use clap::Args;

use super::{EXIT_BAD_INPUT, EXIT_NOTHING, EXIT_OK, EXIT_PARTIAL};

/// Fit model parameters to measured bending.
#[derive(Debug, Args)]
#[command(
    after_help = "NAME: a config field, section.field (geometry.f, material.c1, material.scale: a factor on every material coefficient) or a field name found in one section; bounds NAME=LO:HI (default: the config's value / and x 5).
Each evaluation simulates the config (its mesh and solver settings) at the measured pressures; a coarse mesh (--mesh-size 3 or 4, or [mesh] size_mm in the config) keeps the fit to minutes.
Outputs in OUT: fitted.toml (the config with the fitted values, for simulate --config), fit_model.json, fit_model.csv, plots/fit_model.png|svg|pdf."
)]
pub struct FitModelArgs {
    /// Output folder of bendscope process (holds per_video.csv), or that CSV.
    #[arg(long, value_name = "OUT")]
    pub measured: PathBuf,
    /// Actuator config (TOML) to start from [default: the reference actuator].
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Parameters to fit: NAME[=LO:HI][,NAME...], e.g. material.scale,geometry.f.
    #[arg(long, value_name = "NAMES")]
    pub free: String,
    /// Quantity fitted (relative deviations at every measured pressure).
    #[arg(long, value_enum, default_value = "radius")]
    pub quantity: Quantity,
    /// Largest element edge of every simulation, mm; overrides the config's [mesh] size_mm
    /// as in simulate [default: the config's].
    #[arg(
        long,
        value_name = "MM",
        visible_alias = "mesh-size-mm",
        allow_hyphen_values = true
    )]
    pub mesh_size: Option<f64>,
    /// Output folder.
    #[arg(short, long, value_name = "DIR", default_value = "fit-model")]
    pub output: PathBuf,
}

/// The config (`path`, else the reference actuator) with `mesh_size` set, checked.
fn read_config(path: &Option<PathBuf>, mesh_size: Option<f64>) -> Result<ActuatorConfig> {
    let mut cfg = match path {
        None => ActuatorConfig::default(),
        Some(path) => ActuatorConfig::read(path)?,
    };
    if let Some(h) = mesh_size {
        cfg.mesh.size_mm = h;
    }
    cfg.validate()?;
    Ok(cfg)
}

/// Runs `bendscope fit-model`.
pub fn run(args: &FitModelArgs) -> Result<u8> {
    let inputs = read_config(&args.config, args.mesh_size).and_then(|cfg| {
        let free = parse_free(&args.free, &cfg)?;
        let measured = Measured::read(&args.measured)?;
        Ok((cfg, free, measured))
    });
    let (cfg, free, measured) = match inputs {
        Ok(x) => x,
        Err(e) => {
            eprintln!("error: {e:#}");
            return Ok(EXIT_BAD_INPUT);
        }
    };
    // One run per output folder, its writability checked before the simulations.
    let _lock = super::lock_output(&args.output)?;
    let bar = super::progress_bar(0, "simulations");
    let result = fit_model(
        &cfg,
        &free,
        &measured,
        &FitModelSettings {
            quantity: args.quantity,
        },
        &mut |p| {
            bar.set_length(p.evaluations as u64);
            bar.set_position(p.evaluations as u64);
            if let Some(r) = p.rms_rel_pct {
                bar.set_message(format!("rms {r:.3}%"));
            }
        },
    );
    bar.finish_and_clear();
    let fit = match result {
        Ok(f) => f,
        Err(e @ (FitModelError::Parameter { .. } | FitModelError::Measured { .. })) => {
            eprintln!("error: {e}");
            return Ok(EXIT_BAD_INPUT);
        }
        Err(e @ FitModelError::Fem(_)) => {
            eprintln!("error: the initial model did not run: {e}");
            return Ok(EXIT_NOTHING);
        }
        Err(e) => return Err(e.into()),
    };
    write_fit_model(&args.output, &fit, &measured)?;
    for ((name, v), (_, se)) in fit.parameters.iter().zip(&fit.std_errors) {
        super::out!("{name} = {v:.6} (+/- {se:.2e})");
    }
    super::out!(
        "{} measured rows at {} pressures: rms deviation {:.3}% (initial {:.2}%), max {:.3}%, radius RMSE {:.3} mm; {} simulations ({} warm-started steps, {} from the previous pressure) in {:.1} s -> {}",
        measured.pressure_kpa.len(),
        fit.pressures_kpa.len(),
        fit.rms_rel_pct,
        fit.initial_rms_rel_pct,
        fit.max_rel_dev_pct,
        fit.rmse_mm,
        fit.stats.evaluations,
        fit.stats.warm_steps,
        fit.stats.cold_steps,
        fit.seconds,
        args.output.join("fitted.toml").display()
    );
    for n in &fit.notes {
        eprintln!("warning: {n}");
    }
    Ok(
        if fit.termination.contains("Converged")
            || fit.termination.contains("Orthogonal")
            || fit.termination.contains("ResidualsZero")
        {
            EXIT_OK
        } else {
            EXIT_PARTIAL
        },
    )
}
