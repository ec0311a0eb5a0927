//! Sessions: a folder of videos with a pressure manifest, measured video by video and
//! aggregated.
//!
//! ```text
//! SESSION/
//!   pressures.csv   header `file,pressure_bar` (or pressure_kpa / pressure_psi)
//!   *.MP4 ...       one video per pressure (GoPro chapters GX02xxxx continue GX01xxxx)
//!   scale.jpg       a board lying in the actuator plane (any image format)
//!   calib/          checkerboard photos, used when no calibration is given
//!   bendscope.toml  optional settings ([`SessionConfig`])
//! ```
//!
//! Per frame ([`measure_frame`]; any [`crate::detect::PixelSource`]: RGB images, or
//! decoded YUV frames read without a full-frame colour conversion): red markers are
//! detected in the raw frame, their
//! centroids undistorted (detecting in the raw frame and undistorting 8 points is far
//! cheaper than undistorting every frame, and gives the same points: see the
//! `undistort` tests), ordered from the clamped end, and fitted with a Pratt circle.
//! Frames with another marker count than expected are rejected with the reason.
//!
//! The session's files are read in submodules, the CSVs through [`crate::table`] (a
//! spreadsheet's BOM and CRLF are fine; errors name the file, line and column): the
//! manifest ([`read_manifest`]), the ramp protocol's pressure log ([`read_pressure_log`])
//! and `bendscope.toml` ([`SessionConfig`]).

mod config;
mod manifest;
mod pressure_log;

pub use config::{BoardConfig, SessionConfig};
pub use manifest::{gopro_parts, read_manifest, Manifest, ManifestEntry, SessionIssue};
pub use pressure_log::{read_pressure_log, PressureLog};

use std::path::{Path, PathBuf};

use nalgebra::Point2;
use serde::{Deserialize, Serialize};

use crate::calib::{CalibError, Undistorter};
use crate::detect::{detect_markers_with, order_markers, ChainStart, DetectSettings};
use crate::fit::{bending_angle_from_circle_deg, fit_circle_pratt};
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

/// The pressure column of a table and its unit: the first column named `pressure_bar`,
/// `pressure_kpa` or `pressure_psi` (any case), else an error naming the header.
fn require_pressure_column(table: &Table) -> Result<(usize, PressureUnit), TableError> {
    table
        .columns()
        .iter()
        .enumerate()
        .find_map(|(i, c)| match c.to_ascii_lowercase().as_str() {
            "pressure_bar" => Some((i, PressureUnit::Bar)),
            "pressure_kpa" => Some((i, PressureUnit::Kpa)),
            "pressure_psi" => Some((i, PressureUnit::Psi)),
            _ => None,
        })
        .ok_or_else(|| {
            table.header_error(format!(
                "no pressure column with a unit in the header `{}`: name it pressure_bar, pressure_kpa or pressure_psi",
                table.header_text()
            ))
        })
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

/// Status of a frame.
#[derive(Debug, Clone, PartialEq)]
pub enum FrameStatus {
    /// Measured.
    Ok,
    /// Rejected, with the reason.
    Rejected(String),
}

impl FrameStatus {
    /// Text for the CSV.
    pub fn text(&self) -> String {
        match self {
            FrameStatus::Ok => "ok".into(),
            FrameStatus::Rejected(r) => r.clone(),
        }
    }
}

/// One frame's measurement (lengths in undistorted px; mm via the scale).
#[derive(Debug, Clone, PartialEq)]
pub struct FrameMeasurement {
    /// Markers found.
    pub n_markers: usize,
    /// Undistorted, ordered marker centroids (empty when rejected).
    pub markers_px: Vec<Point2<f64>>,
    /// Pratt radius, px (infinite for collinear markers; NaN when rejected).
    pub radius_px: f64,
    /// 1 / radius, 1/px.
    pub curvature_per_px: f64,
    /// Bending angle, degrees (tangent at the clamped-end marker to the tip chord,
    /// half-angle convention).
    pub bending_angle_deg: f64,
    /// RMS residual of the circle fit, px.
    pub fit_rms_px: f64,
    /// Centre of the fitted circle, undistorted px.
    pub center_px: Point2<f64>,
    /// Outcome.
    pub status: FrameStatus,
}

impl FrameMeasurement {
    fn rejected(n: usize, why: String) -> Self {
        Self {
            n_markers: n,
            markers_px: vec![],
            radius_px: f64::NAN,
            curvature_per_px: f64::NAN,
            bending_angle_deg: f64::NAN,
            fit_rms_px: f64::NAN,
            center_px: Point2::new(f64::NAN, f64::NAN),
            status: FrameStatus::Rejected(why),
        }
    }
}

/// Measures one RGB frame: detect, check the count, undistort the centroids, order,
/// fit. `undistorter` is `None` when the frame itself was already undistorted.
pub fn measure_frame(
    frame: &image::RgbImage,
    undistorter: Option<&Undistorter>,
    detect: &DetectSettings,
    expected_markers: usize,
    start: ChainStart,
) -> FrameMeasurement {
    measure_frame_with(
        frame,
        undistorter,
        detect,
        expected_markers,
        start,
        &mut image::GrayImage::new(0, 0),
    )
}

/// [`measure_frame`] with a mask buffer reused from frame to frame.
pub fn measure_frame_with<S: crate::detect::PixelSource>(
    frame: &S,
    undistorter: Option<&Undistorter>,
    detect: &DetectSettings,
    expected_markers: usize,
    start: ChainStart,
    mask: &mut image::GrayImage,
) -> FrameMeasurement {
    let d = detect_markers_with(frame, detect, mask);
    let n = d.blobs.len();
    if n != expected_markers {
        let mut why = format!("{n} markers found, {expected_markers} expected");
        if d.specks + d.too_large > 0 {
            why.push_str(&format!(
                " ({} specks, {} too large dropped)",
                d.specks, d.too_large
            ));
        }
        return FrameMeasurement::rejected(n, why);
    }
    let raw: Vec<Point2<f64>> = d.blobs.iter().map(|b| b.centroid).collect();
    let flat = match undistorter.map(|u| u.undistort_points(&raw)) {
        Some(Ok(p)) => p,
        Some(Err(e)) => return FrameMeasurement::rejected(n, format!("undistortion failed: {e}")),
        None => raw,
    };
    // Track the clamped end in undistorted space when given as a point.
    let ordered = order_markers(&flat, start);
    let circle = match fit_circle_pratt(&ordered) {
        Ok(c) => c,
        Err(e) => return FrameMeasurement::rejected(n, e.to_string()),
    };
    let angle = match (ordered.first(), ordered.last()) {
        (Some(o), Some(a)) => bending_angle_from_circle_deg(*o, *a, &circle).unwrap_or(f64::NAN),
        _ => f64::NAN,
    };
    FrameMeasurement {
        n_markers: n,
        markers_px: ordered,
        radius_px: circle.radius,
        curvature_per_px: circle.curvature,
        bending_angle_deg: angle,
        fit_rms_px: circle.rms,
        center_px: circle.center,
        status: FrameStatus::Ok,
    }
}

/// Summary of a video's frames.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct VideoSummary {
    /// Mean radius over used frames, mm (the published method).
    pub radius_mm: f64,
    /// Median radius, mm.
    pub radius_mm_median: f64,
    /// Standard deviation of the radius, mm.
    pub radius_mm_std: f64,
    /// Mean curvature, 1/m.
    pub curvature_per_m: f64,
    /// Mean bending angle, degrees.
    pub bending_angle_deg: f64,
    /// Mean fit RMS, px.
    pub fit_rms_px: f64,
    /// Frames measured.
    pub frames_used: usize,
    /// Frames rejected.
    pub frames_rejected: usize,
}

/// Aggregates frame measurements (radius px -> mm with `mm_per_px`).
pub fn summarize(frames: &[FrameMeasurement], mm_per_px: f64) -> VideoSummary {
    let used: Vec<&FrameMeasurement> = frames
        .iter()
        .filter(|f| f.status == FrameStatus::Ok)
        .collect();
    let n = used.len();
    let mut s = VideoSummary {
        frames_used: n,
        frames_rejected: frames.len() - n,
        radius_mm: f64::NAN,
        radius_mm_median: f64::NAN,
        radius_mm_std: f64::NAN,
        curvature_per_m: f64::NAN,
        bending_angle_deg: f64::NAN,
        fit_rms_px: f64::NAN,
    };
    if n == 0 {
        return s;
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let mut r: Vec<f64> = used.iter().map(|f| f.radius_px * mm_per_px).collect();
    s.radius_mm = mean(&r);
    s.radius_mm_std = if n > 1 && s.radius_mm.is_finite() {
        (r.iter().map(|v| (v - s.radius_mm).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
    } else {
        0.0
    };
    r.sort_by(f64::total_cmp);
    s.radius_mm_median = if n % 2 == 1 {
        r[n / 2]
    } else {
        0.5 * (r[n / 2 - 1] + r[n / 2])
    };
    let k: Vec<f64> = used
        .iter()
        .map(|f| f.curvature_per_px / mm_per_px * 1000.0)
        .collect();
    s.curvature_per_m = mean(&k);
    let a: Vec<f64> = used.iter().map(|f| f.bending_angle_deg).collect();
    s.bending_angle_deg = mean(&a);
    let q: Vec<f64> = used.iter().map(|f| f.fit_rms_px).collect();
    s.fit_rms_px = mean(&q);
    s
}
