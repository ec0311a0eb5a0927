//! Studies: several samples of one design, each inflated in several runs (sessions),
//! turned into the table and figure a paper publishes.
//!
//! A study is read from `study.toml` or flags ([`StudySpec`]), loaded and checked
//! ([`load`]: every session's per_video.csv, session folders processed on the way with
//! the cache, one actuator per sample), analysed ([`analyse`]: per-session means
//! grouped by pressure set point, mean / std / min / max per sample and pooled,
//! repeatability, power-law fits with confidence bands, FEM comparisons, sessions that
//! disagree) and written ([`output`]: study.csv, repeatability.csv, fits.json, fem.csv,
//! plots/, report.html). Nothing is written before the whole study has been read and
//! checked: bad input leaves no half-written output.

pub mod analyse;
pub mod config;
pub mod load;
pub mod output;
mod page;
pub mod stats;

use std::path::Path;

pub use analyse::{analyse, Analysis};
pub use config::{SampleSpec, StudyError, StudySpec, FITTED, POOLED, QUANTITIES};
pub use load::{load_study, Study};
pub use output::{write_study, StudyReport};

/// Loads, analyses and writes the study of `spec` into `out` (nothing is written when
/// the study cannot be read); session folders are processed on the way, with their
/// progress on `progress`.
pub fn run_study(
    spec: &StudySpec,
    out: &Path,
    progress: &mut dyn crate::pipeline::Progress,
) -> Result<StudyReport, StudyError> {
    let study = load_study(spec, progress)?;
    let analysis = analyse(&study);
    write_study(&study, &analysis, out, spec.error_bars)
}
