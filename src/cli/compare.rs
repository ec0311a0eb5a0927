//! `bendscope compare`: measured (process output) against simulated (simulate output).

use std::path::PathBuf;

use anyhow::Result;
use bendscope::compare::compare_to;
use clap::Args;

use super::{EXIT_OK, EXIT_PARTIAL};

/// Compare measured bending with the simulation.
#[derive(Debug, Args)]
#[command(
    after_help = "Reads MEASURED/per_video.csv (bendscope process) and FEM/steps.csv (+ force.csv) \
(bendscope simulate). Each curve is fitted with y = a p^b + c and the fits are compared on a common pressure grid \
over the range both cover. Writes in REPORT: compare.csv (the curves and their deviation), summary.txt, \
compare.json and plots/ (PNG + SVG)."
)]
pub struct CompareArgs {
    /// Output folder of `bendscope process` (per_video.csv).
    #[arg(long, value_name = "OUT")]
    pub measured: PathBuf,
    /// Output folder of `bendscope simulate` (steps.csv, force.csv).
    #[arg(long, value_name = "FEM_OUT")]
    pub fem: PathBuf,
    /// Measured blocked force: CSV with pressure_kpa and force_g (grams) columns.
    #[arg(long, value_name = "CSV")]
    pub force: Option<PathBuf>,
    /// Report folder.
    #[arg(short, long, value_name = "REPORT", default_value = "compare-out")]
    pub output: PathBuf,
}

/// Runs `bendscope compare`.
pub fn run(args: &CompareArgs) -> Result<u8> {
    let report = compare_to(
        &args.measured,
        &args.fem,
        args.force.as_deref(),
        &args.output,
    )?;
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    super::out!("{}-> {}", report.summary, args.output.display());
    Ok(if report.warnings.is_empty() {
        EXIT_OK
    } else {
        EXIT_PARTIAL
    })
}
