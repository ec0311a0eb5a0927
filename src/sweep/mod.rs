//! Multi-factor design sweeps: a plan (TOML) -> its design points -> one `bendscope`
//! process per point -> `designs.csv`.
//!
//! Data flows: [`plan`] (the plan file, checked, and a point's actuator config) ->
//! [`design`] (full factorial or Latin hypercube) -> [`run`] (the sweep folder: manifest,
//! one folder per point, resume, a local pool of child processes, and the point itself)
//! or [`emit`] (GNU parallel jobs.txt, Slurm job array) -> [`collect`] (the finished
//! points into `designs.csv`).
//!
//! Layout of a sweep folder DIR: `sweep.json` (the manifest: factors, kept pressures,
//! points), `runs/<id>/` per point (`config.toml`, `steps.csv`, `summary.json`, `log`,
//! `status.json` ...), `designs.csv`, `failures.csv`, and `jobs.txt` or `sweep.sbatch`
//! when emitted. Every point is the complete `bendscope simulate` of its `config.toml`,
//! so its numbers are those `bendscope simulate --config DIR/runs/<id>/config.toml` gives.

pub mod collect;
pub mod design;
pub mod emit;
pub mod plan;
pub mod run;

use std::path::PathBuf;

/// Errors of sweeps.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The plan file is not usable.
    #[error("plan {path}: {why}")]
    Plan {
        /// The plan file.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
    /// The sweep folder is not usable (no manifest, unknown point ...).
    #[error("sweep folder {dir}: {why}")]
    Folder {
        /// The folder.
        dir: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
    /// A file could not be read or written.
    #[error("{path}: {why}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What failed.
        why: String,
    },
}

impl SweepError {
    /// An I/O error on `path` (its text not naming `path` a second time).
    pub fn io(path: &std::path::Path, e: impl std::fmt::Display) -> Self {
        Self::Io {
            path: path.to_path_buf(),
            why: crate::io::without_path(path, &e.to_string()),
        }
    }
}
