//! `bendscope compare`: measured (process output) against simulated (simulate output).

use std::path::PathBuf;

use anyhow::Result;
use bendscope::compare::compare_to;
use clap::Args;

use super::{EXIT_NOTHING, EXIT_OK, EXIT_PARTIAL};

/// Compare measured bending with the simulation.
#[derive(Debug, Args)]
#[command(
    after_help = "Reads MEASURED/per_video.csv (bendscope process) and FEM/steps.csv (+ force.csv) \
(bendscope simulate). Each curve is fitted with y = a p^b + c and the fits are compared on a common pressure grid \
over the range both cover (rows at 0 kPa are left out of the fits, with a note). \
Deviation = simulated - measured (FEM fit minus measured fit, in the quantity's unit: a positive radius deviation is a simulated \
radius larger than measured); RMSE % is relative to the RMS of the measured fit. \
Writes in REPORT: compare.csv (per quantity: NAME_measured, NAME_fem, NAME_deviation on the grid), summary.txt, \
compare.json and plots/ (PNG + SVG + PDF).
Exit codes: 0 every quantity compared, 1 some could not be (why on stderr), 2 bad input, 3 none could be compared."
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
    let _lock = super::lock_output(&args.output)?;
    let report = compare_to(
        &args.measured,
        &args.fem,
        args.force.as_deref(),
        &args.output,
    )?;
    for n in &report.notes {
        eprintln!("note: {n}");
    }
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    super::out!("{}-> {}", report.summary, args.output.display());
    Ok(if report.results.is_empty() {
        EXIT_NOTHING
    } else if report.warnings.is_empty() {
        EXIT_OK
    } else {
        EXIT_PARTIAL
    })
}
