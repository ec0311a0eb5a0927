//! `bendscope optimize`: optimize a design on surrogates of designs.csv, then check the
//! best designs with the FEM.

use std::path::PathBuf;

use anyhow::Result;
use bendscope::optimize::{load_plan, optimize_to, OptimizeError, OptimizeOptions};
use clap::Args;

use super::{EXIT_BAD_INPUT, EXIT_OK, EXIT_PARTIAL};

/// Optimize a design on Gaussian-process surrogates; re-simulate the best with the FEM.
#[derive(Debug, Args)]
#[command(
    after_help = "One [[objective]]: Bayesian optimization (egobox-ego) -> evaluations.csv; two: NSGA-II Pareto front -> pareto.csv, plots/pareto.png. \
Both: verified.csv (surrogate mean, std and FEM value per column of the re-simulated designs; extrapolated: their inputs outside the designs' range), runs/<k>/ (their FEM outputs), models/ (one surrogate per column), summary.json. \
Input bounds or an optimum beyond the designs' range are warned about (the surrogates extrapolate there). \
See examples/plans/optimize.toml for the plan format."
)]
pub struct OptimizeArgs {
    /// The plan (TOML).
    #[arg(value_name = "PLAN.toml")]
    pub plan: PathBuf,
    /// Output folder.
    #[arg(short, long, value_name = "OUT", default_value = "optimize-out")]
    pub output: PathBuf,
    /// Designs to re-simulate with the FEM [default: the plan's resimulate].
    #[arg(long, value_name = "N")]
    pub resimulate: Option<usize>,
    /// Mesh size of the re-simulations, mm [default: the plan's].
    #[arg(long, value_name = "MM")]
    pub mesh_size: Option<f64>,
}

/// Runs `bendscope optimize`.
pub fn run(args: &OptimizeArgs) -> Result<u8> {
    let mut loaded = match load_plan(&args.plan) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: {e}");
            return Ok(EXIT_BAD_INPUT);
        }
    };
    if let Some(h) = args.mesh_size {
        loaded.base.mesh.size_mm = h;
        if let Err(e) = loaded.base.validate() {
            eprintln!("error: --mesh-size: {e}");
            return Ok(EXIT_BAD_INPUT);
        }
    }
    let _lock = super::lock_output(&args.output)?;
    let bar = super::progress_bar(0, "optimize");
    let result = optimize_to(
        &loaded,
        &args.output,
        &OptimizeOptions {
            resimulate: args.resimulate,
        },
        &mut |what| {
            if what != "FEM step" {
                bar.set_message(what.to_string());
            }
            bar.tick();
        },
    );
    bar.finish_and_clear();
    let report = match result {
        Ok(r) => r,
        Err(e @ (OptimizeError::Surrogate(_) | OptimizeError::Input { .. })) => {
            eprintln!("error: {e}");
            return Ok(EXIT_BAD_INPUT);
        }
        Err(e) => return Err(e.into()),
    };
    for s in &report.surrogates {
        super::out!(
            "surrogate {}: {} points, {}, leave-one-out R^2 {:.4} (explained variance {:.2}%, max error {:.4})",
            s.column,
            s.points,
            s.kind,
            s.validation.loo.r2,
            100.0 * s.validation.loo.explained_variance,
            s.validation.loo.max_error
        );
    }
    let fmt_x = |x: &[f64]| {
        report
            .inputs
            .iter()
            .zip(x)
            .map(|(n, v)| format!("{n}={v:.4}"))
            .collect::<Vec<_>>()
            .join(",")
    };
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    if report.best.is_empty() || !report.best[0].feasible {
        eprintln!("warning: no design meets every constraint on the surrogates");
    }
    match report.method.as_str() {
        "nsga2" => super::out!(
            "Pareto front: {} feasible designs ({} evaluated) -> {}",
            report.best.len(),
            report.evaluations,
            args.output.join("pareto.csv").display()
        ),
        _ => {
            if let Some(b) = report.best.first() {
                super::out!(
                    "optimum on the surrogates ({} evaluations): {} -> {} = {:.4} ± {:.4}",
                    report.evaluations,
                    fmt_x(&b.x),
                    report.columns[0],
                    b.values[0].mean,
                    b.values[0].std
                );
            }
        }
    }
    let mut failed = 0;
    for (k, v) in report.verified.iter().enumerate() {
        let cols = report
            .columns
            .iter()
            .enumerate()
            .map(|(c, name)| {
                format!(
                    "{name} {:.3} ± {:.3} vs FEM {:.3}",
                    v.predicted[c].mean, v.predicted[c].std, v.fem[c]
                )
            })
            .collect::<Vec<_>>()
            .join("; ");
        let beyond = if v.extrapolated.is_empty() {
            String::new()
        } else {
            format!("; extrapolated: {}", v.extrapolated.join(", "))
        };
        super::out!(
            "FEM check {}: {}: {cols}; constraints {} ({}){beyond}",
            k + 1,
            fmt_x(&v.x),
            if v.feasible_fem { "met" } else { "NOT met" },
            v.status
        );
        if v.status != "ok" {
            failed += 1;
        }
    }
    super::out!("-> {}", args.output.join("summary.json").display());
    Ok(if failed == 0 { EXIT_OK } else { EXIT_PARTIAL })
}
