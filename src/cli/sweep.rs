//! `bendscope sweep`: multi-factor design sweeps, run locally or emitted for a cluster.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::{Context, Result};
use bendscope::sweep::collect::collect;
use bendscope::sweep::emit::{write_parallel_jobs, write_slurm};
use bendscope::sweep::plan::Plan;
use bendscope::sweep::run::{
    point_dir, point_memory_mb, pool_size, prepare, read_point_config, run_point, run_pool,
    PointState,
};
use bendscope::sweep::SweepError;
use clap::{Args, Subcommand, ValueEnum};

use super::{EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_NOTHING, EXIT_OK, EXIT_PARTIAL};

/// Run a multi-factor design (factorial or Latin hypercube) of simulations.
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
#[command(
    after_help = "Outputs in DIR: designs.csv (one row per point: id, status, seconds, the factors, radius_mm@P ... cavity_volume_mm3@P per kept pressure P, height_mm), failures.csv, \
runs/<id>/ (config.toml, steps.csv, summary.json, log, status.json), sweep.json. Running again resumes: finished points are skipped.
Ctrl-C or SIGTERM stops the running points (status interrupted), writes designs.csv and exits 130; running again resumes them.
Plan format: see examples/plans/two-factor.toml and docs/src/reference.md (sweep)."
)]
pub struct SweepArgs {
    /// What else to do.
    #[command(subcommand)]
    pub action: Option<SweepAction>,
    /// The plan (TOML).
    #[arg(value_name = "PLAN.toml", required = true)]
    pub plan: Option<PathBuf>,
    /// Output folder.
    #[arg(short, long, value_name = "DIR", default_value = "sweep-out")]
    pub output: PathBuf,
    /// Points run at once [default: the cores, fewer when memory is short].
    #[arg(long, value_name = "N")]
    pub jobs: Option<usize>,
    /// Run nothing: write DIR/jobs.txt (GNU parallel) or DIR/sweep.sbatch (Slurm).
    #[arg(long, value_name = "ENGINE")]
    pub emit: Option<Engine>,
}

/// A cluster engine to emit for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Engine {
    /// GNU parallel: DIR/jobs.txt, one command per point.
    Parallel,
    /// Slurm: DIR/sweep.sbatch, a job array.
    Slurm,
}

/// Sub-actions of `sweep`.
#[derive(Debug, Subcommand)]
pub enum SweepAction {
    /// Merge the finished points of a sweep folder into DIR/designs.csv.
    Collect {
        /// The sweep folder.
        dir: PathBuf,
    },
    /// Run one point of a prepared sweep folder (what the pool, jobs.txt and sweep.sbatch call).
    #[command(hide = true)]
    RunPoint {
        /// The sweep folder.
        dir: PathBuf,
        /// The point's id.
        id: String,
    },
}

fn bad_input(e: &SweepError) -> u8 {
    eprintln!("error: {e}");
    EXIT_BAD_INPUT
}

/// Runs `bendscope sweep`.
pub fn run(args: &SweepArgs) -> Result<u8> {
    match &args.action {
        Some(SweepAction::Collect { dir }) => {
            let _lock = super::lock_output(dir)?;
            return run_collect(dir);
        }
        // Not locked: the sweep that runs the point (or emitted its job) holds DIR's lock,
        // and the point writes only its own runs/<id>/.
        Some(SweepAction::RunPoint { dir, id }) => {
            let s = match run_point(dir, id) {
                Ok(s) => s,
                Err(e @ SweepError::Folder { .. }) => return Ok(bad_input(&e)),
                Err(e) => return Err(e.into()),
            };
            super::out!("{id}: {} in {:.1} s", s.status.as_str(), s.seconds);
            return Ok(match s.status {
                PointState::Ok => EXIT_OK,
                PointState::Stopped => EXIT_PARTIAL,
                _ => EXIT_NOTHING,
            });
        }
        None => {}
    }
    let Some(plan_path) = &args.plan else {
        eprintln!("error: give a plan: bendscope sweep PLAN.toml -o DIR");
        return Ok(EXIT_BAD_INPUT);
    };
    if args.jobs == Some(0) {
        eprintln!("error: --jobs 0: run at least 1 point at a time");
        return Ok(EXIT_BAD_INPUT);
    }
    let plan = match Plan::load(plan_path) {
        Ok(p) => p,
        Err(e) => return Ok(bad_input(&e)),
    };
    // One sweep per folder: a second plan would replace the manifest and the points.
    let _lock = super::lock_output(&args.output)?;
    let prepared = match prepare(&plan, &args.output) {
        Ok(p) => p,
        Err(e @ SweepError::Plan { .. }) => return Ok(bad_input(&e)),
        Err(e) => return Err(e.into()),
    };
    let total = prepared.manifest.points.len();
    let exe = std::env::current_exe().context("cannot locate the bendscope binary")?;
    eprintln!(
        "{total} point(s): {} to run, {} finished earlier, {} invalid",
        prepared.pending.len(),
        prepared.finished,
        prepared.invalid
    );
    if let Some(engine) = args.emit {
        if prepared.pending.is_empty() {
            super::out!(
                "nothing to run: every point is finished; bendscope sweep collect {}",
                prepared.dir.display()
            );
            return Ok(EXIT_OK);
        }
        let (path, how) = match engine {
            Engine::Parallel => (write_parallel_jobs(&prepared, &exe)?, "parallel <"),
            Engine::Slurm => (write_slurm(&prepared, &exe)?, "sbatch"),
        };
        super::out!(
            "{} point(s) -> {}; run: {how} {}; then: bendscope sweep collect {}",
            prepared.pending.len(),
            path.display(),
            path.display(),
            prepared.dir.display()
        );
        return Ok(EXIT_OK);
    }
    if !prepared.pending.is_empty() {
        let point_mb = prepared
            .pending
            .iter()
            .filter_map(|id| read_point_config(&point_dir(&prepared.dir, id)).ok())
            .map(|c| point_memory_mb(&c))
            .fold(0.0, f64::max);
        let jobs = pool_size(args.jobs, prepared.pending.len(), point_mb);
        if args
            .jobs
            .is_some_and(|j| j > jobs && j <= prepared.pending.len())
        {
            eprintln!(
                "note: {jobs} point(s) at a time, not {}: each needs ~{point_mb:.0} MB",
                args.jobs.unwrap_or(0)
            );
        }
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        if let Err(e) = ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst)) {
            eprintln!("warning: Ctrl-C cannot be caught ({e}): a stopped sweep may leave its points running");
        }
        let bar = super::progress_bar(prepared.pending.len() as u64, "sweep");
        run_pool(
            &prepared.dir,
            &prepared.pending,
            jobs,
            &exe,
            &stop,
            &mut |id, s| {
                bar.set_message(format!("{id} {}", s.status.as_str()));
                bar.inc(1);
                if let Some(r) = s.reason.as_deref().filter(|_| s.status != PointState::Ok) {
                    bar.suspend(|| eprintln!("warning: point {id} {}: {r}", s.status.as_str()));
                }
            },
        )?;
        bar.finish_and_clear();
        if stop.load(Ordering::SeqCst) {
            run_collect(&prepared.dir)?;
            eprintln!(
                "interrupted: the running points were stopped (status interrupted); run the same command again to resume"
            );
            return Ok(EXIT_INTERRUPTED);
        }
    }
    run_collect(&prepared.dir)
}

fn run_collect(dir: &std::path::Path) -> Result<u8> {
    let c = match collect(dir) {
        Ok(c) => c,
        Err(e @ SweepError::Folder { .. }) => return Ok(bad_input(&e)),
        Err(e) => return Err(e.into()),
    };
    super::out!(
        "{} point(s): {} ok, {} stopped early, {} failed, {} not finished -> {}",
        c.points,
        c.ok,
        c.stopped,
        c.failed,
        c.unfinished,
        c.designs.display()
    );
    Ok(if c.ok == c.points {
        EXIT_OK
    } else if c.ok + c.stopped == 0 {
        EXIT_NOTHING
    } else {
        EXIT_PARTIAL
    })
}
