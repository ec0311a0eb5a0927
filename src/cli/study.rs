//! `bendscope study`: several samples, each of several sessions, into the table and
//! figures a paper publishes ([`bendscope::study`]).

use std::path::PathBuf;

use anyhow::Result;
use bendscope::pipeline::Quiet;
use bendscope::study::{analyse, load_study, write_study, StudySpec};
use clap::Args;

use super::EXIT_OK;

/// Summarize a characterization: samples x runs -> means, spreads, fits, FEM.
#[derive(Debug, Args)]
#[command(
    after_help = "STUDY.toml lists the samples: [[sample]] name = \"A\", sessions = [\"A-run1/bendscope-out\", \"A-run2/bendscope-out\"] \
(process output folders with per_video.csv, relative to STUDY.toml; a session folder with pressures.csv or pressure_log.csv \
and no per_video.csv is processed on the way into SESSION/bendscope-out, with its cache), and optionally \
fem = [\"sim/\"] (`bendscope simulate` outputs, each compared with every sample and the pool). \
Or flags: --sample A=OUT,OUT --sample B=OUT --fem SIM.
Rows with status ok or partial count; pressures within 0.5 % or 0.05 kPa are one set point. Each session gives one value per set point \
(the mean of its videos there); study.csv has per sample and pressure (then pooled, sample `all`) n and the mean, std (n - 1; empty where n = 1), \
min and max of those values. Outputs in OUT: study.csv, repeatability.csv (coefficient of variation across runs and across samples), \
fits.json (y = a p^b + c per sample and pooled, 95 % confidence bands), fem.csv, plots/ (PNG + SVG + PDF), report.html.
A session outside the 99 % prediction interval of the other sessions of its sample (3 or more sessions) is flagged on stderr and in the report.
Exit codes: 0 written (warnings on stderr), 2 bad input (nothing written), 4 no space left on OUT's disk."
)]
pub struct StudyArgs {
    /// study.toml (or give the samples with --sample).
    #[arg(
        value_name = "STUDY.toml",
        conflicts_with = "sample",
        required_unless_present = "sample"
    )]
    pub study: Option<PathBuf>,
    /// A sample and its sessions: NAME=OUT,OUT,... (repeat for each sample).
    #[arg(long, value_name = "NAME=OUT,...")]
    pub sample: Vec<String>,
    /// A `bendscope simulate` output folder to compare with (repeatable; with --sample).
    #[arg(long, value_name = "FEM_OUT", requires = "sample")]
    pub fem: Vec<PathBuf>,
    /// Output folder.
    #[arg(short, long, value_name = "OUT", default_value = "study-out")]
    pub output: PathBuf,
    /// What the plots' error bars show: std (of the sessions' values at a set point) or
    /// ci95 (95 % confidence interval of their mean, t with n - 1; no bar where n = 1)
    /// [default: study.toml's error_bars, else std].
    #[arg(long, value_name = "std|ci95")]
    pub error_bars: Option<bendscope::report::ErrorBars>,
}

/// Runs `bendscope study`.
pub fn run(args: &StudyArgs) -> Result<u8> {
    let mut spec = match &args.study {
        Some(path) => StudySpec::read(path)?,
        None => StudySpec::from_flags(&args.sample, &args.fem)?,
    };
    if let Some(bars) = args.error_bars {
        spec.error_bars = bars;
    }
    // Everything is read and checked before OUT is made: bad input leaves nothing.
    let study = load_study(&spec, &mut Quiet)?;
    let analysis = analyse(&study);
    let _lock = super::lock_output(&args.output)?;
    let report = write_study(&study, &analysis, &args.output, spec.error_bars)?;
    for n in &report.notes {
        eprintln!("note: {n}");
    }
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    super::out!("{}\n-> {}", report.summary, args.output.display());
    Ok(EXIT_OK)
}
