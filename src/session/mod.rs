//! Sessions: a folder of videos with a pressure manifest, measured video by video and
//! aggregated.
//!
//! ```text
//! SESSION/
//!   pressures.csv   header `file,pressure_bar` (or pressure_kpa / pressure_psi)
//!   *.MP4 ...       one video per pressure (GoPro chapters GX02xxxx continue GX01xxxx)
//!   scale.jpg       a board in (or parallel to) the actuator plane (any image format)
//!   calib/          checkerboard photos, used when no calibration is given
//!   bendscope.toml  optional settings ([`SessionConfig`])
//! ```
//!
//! The measurement itself is [`crate::pipeline`]'s.
//!
//! The session's files are read in submodules, the CSVs through [`crate::table`] (a
//! spreadsheet's BOM and CRLF are fine; errors name the file, line and column): the
//! manifest ([`read_manifest`]), the ramp protocol's pressure log ([`read_pressure_log`])
//! and `bendscope.toml` ([`SessionConfig`]).

mod config;
mod manifest;
mod pressure_log;
mod scale_config;

pub use config::{BoardConfig, SessionConfig};
pub use manifest::{
    gopro_parts, implausible_pressures, read_manifest, Manifest, ManifestEntry, SessionIssue,
    MAX_PLAUSIBLE_PRESSURE_KPA,
};
pub use pressure_log::{read_pressure_log, PressureLog};
pub use scale_config::{MarkerSpacing, ScaleBoardConfig, ScaleMarkersConfig};

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::calib::CalibError;
use crate::table::{Table, TableError};

/// Name of the manifest file in a session folder.
pub const MANIFEST: &str = "pressures.csv";
/// Name of the pressure log of a ramp session (instead of the manifest).
pub const PRESSURE_LOG: &str = "pressure_log.csv";
/// Name of the optional settings file in a session folder.
pub const CONFIG: &str = "bendscope.toml";
/// Video file extensions (case-insensitive).
pub const VIDEO_EXTENSIONS: &[&str] = &["mp4", "mov", "m4v", "mkv", "avi", "webm"];
/// Image extensions accepted for the scale photo.
pub const IMAGE_EXTENSIONS: &[&str] = &["jpg", "jpeg", "png", "bmp", "tif", "tiff"];
/// Photo extensions a manifest row may name (case-insensitive): the photo protocol.
pub const PHOTO_EXTENSIONS: &[&str] = &["jpg", "jpeg", "png", "tif", "tiff"];

/// True when `path` has a photo extension.
pub fn is_photo(path: &Path) -> bool {
    has_extension(path, PHOTO_EXTENSIONS)
}

/// kPa per bar.
pub const KPA_PER_BAR: f64 = 100.0;
/// kPa per psi.
pub const KPA_PER_PSI: f64 = 6.894_757;

/// Errors that stop a whole session.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The session folder is missing or empty.
    #[error("{path}: {why}")]
    Folder {
        /// The folder.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
    /// The manifest cannot be used at all.
    #[error("{path}: {why}")]
    Manifest {
        /// The manifest.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
    /// The settings file is wrong.
    #[error("{path}: {why}")]
    Config {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        why: String,
    },
    /// A table (manifest, pressure log) is malformed, at a known line and column.
    #[error(transparent)]
    Table(#[from] TableError),
    /// Calibration problem.
    #[error(transparent)]
    Calib(#[from] CalibError),
}

/// Pressure unit of a manifest column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PressureUnit {
    /// bar.
    Bar,
    /// kPa.
    Kpa,
    /// psi.
    Psi,
}

impl PressureUnit {
    /// kPa per unit.
    pub fn to_kpa(&self) -> f64 {
        match self {
            PressureUnit::Bar => KPA_PER_BAR,
            PressureUnit::Kpa => 1.0,
            PressureUnit::Psi => KPA_PER_PSI,
        }
    }
    /// Name as in the header.
    pub fn name(&self) -> &'static str {
        match self {
            PressureUnit::Bar => "bar",
            PressureUnit::Kpa => "kpa",
            PressureUnit::Psi => "psi",
        }
    }
}

fn has_extension(path: &Path, exts: &[&str]) -> bool {
    path.extension()
        .map(|e| exts.contains(&e.to_string_lossy().to_ascii_lowercase().as_str()))
        .unwrap_or(false)
}

/// The videos of a session folder, sorted by name.
pub fn session_videos(session: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(session)
        .map(|rd| {
            rd.flatten()
                .filter(|e| e.path().is_file() && has_extension(&e.path(), VIDEO_EXTENSIONS))
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Two pressure columns of one row agree when they differ by less than this share of the
/// larger (a value converted by hand and rounded to a few digits still agrees).
const PRESSURE_COLUMNS_AGREE_REL: f64 = 0.01;

/// The pressure column of a table and its unit: the first column named `pressure_bar`,
/// `pressure_kpa` or `pressure_psi` (any case), else an error naming the header.
///
/// A table may hold more than one of them only when they agree in every row: where two
/// give different pressures (`pressure_kpa` 20 beside `pressure_bar` 0.5), which one is
/// meant is unknown, and the error names both and the line.
fn require_pressure_column(table: &Table) -> Result<(usize, PressureUnit), TableError> {
    let mut found = table.columns().iter().enumerate().filter_map(|(i, c)| {
        match c.to_ascii_lowercase().as_str() {
            "pressure_bar" => Some((i, PressureUnit::Bar)),
            "pressure_kpa" => Some((i, PressureUnit::Kpa)),
            "pressure_psi" => Some((i, PressureUnit::Psi)),
            _ => None,
        }
    });
    let first = found.next().ok_or_else(|| {
        table.header_error(format!(
            "no pressure column with a unit in the header `{}`: name it pressure_bar, pressure_kpa or pressure_psi",
            table.header_text()
        ))
    })?;
    for other in found {
        for row in 0..table.len() {
            let kpa = |(col, unit): (usize, PressureUnit)| {
                table
                    .number(table.cell(row, col).trim())
                    .filter(|v| v.is_finite())
                    .map(|v| (v, v * unit.to_kpa()))
            };
            let (Some((a, a_kpa)), Some((b, b_kpa))) = (kpa(first), kpa(other)) else {
                continue;
            };
            if (a_kpa - b_kpa).abs() > PRESSURE_COLUMNS_AGREE_REL * a_kpa.abs().max(b_kpa.abs()) {
                let name = |(col, _): (usize, PressureUnit)| table.columns()[col].clone();
                // Rounded for the message: 0.35 bar shows as 35 kPa, not 35.00000000000001.
                let (a_kpa, b_kpa) = ((a_kpa * 1e6).round() / 1e6, (b_kpa * 1e6).round() / 1e6);
                return Err(table.error_at(
                    Some(row),
                    None,
                    format!(
                        "two pressure columns disagree: {} is {a} ({a_kpa} kPa) and {} is {b} ({b_kpa} kPa): keep one pressure column",
                        name(first),
                        name(other)
                    ),
                ));
            }
        }
    }
    Ok(first)
}

/// The scale photo of a session: the configured one, or the first `scale.*` image.
pub fn find_scale_image(session: &Path, config: &SessionConfig) -> Option<PathBuf> {
    if let Some(p) = &config.scale_image {
        return Some(session.join(p));
    }
    let mut found: Vec<PathBuf> = std::fs::read_dir(session)
        .ok()?
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.is_file()
                && has_extension(p, IMAGE_EXTENSIONS)
                && p.file_stem()
                    .map(|s| s.to_string_lossy().eq_ignore_ascii_case("scale"))
                    .unwrap_or(false)
        })
        .collect();
    found.sort();
    found.into_iter().next()
}
