//! A measured item (a video with its chapters, or an RGB-D recording): its frames'
//! records, its problems and its row of per_video.csv, to and from the cache.

use crate::session::ManifestEntry;

use super::cache::{CacheEntry, ItemKey};
use super::frame;
use super::records::{FrameRecord, VideoRecord, VideoStatus};
use super::stats;

/// A measured item (a video with its chapters, or an RGB-D recording).
pub(super) struct ItemResult {
    pub(super) file: String,
    pub(super) pressure_kpa: f64,
    pub(super) pressure: f64,
    pub(super) frames: Vec<FrameRecord>,
    pub(super) problems: Vec<String>,
    pub(super) clamp_marker_px: Option<(f64, f64)>,
    pub(super) outputs: Vec<String>,
    /// Its result came from the cache.
    pub(super) from_cache: bool,
    /// An output could not be written for lack of space: the run stops.
    pub(super) storage_full: bool,
}

impl ItemResult {
    pub(super) fn from_cache(entry: &ManifestEntry, c: CacheEntry) -> Self {
        Self {
            file: entry.file.clone(),
            pressure_kpa: entry.pressure_kpa,
            pressure: entry.pressure,
            frames: c.frames,
            problems: c.problems,
            clamp_marker_px: c.clamp_marker_px,
            outputs: c.outputs,
            from_cache: true,
            storage_full: false,
        }
    }

    pub(super) fn to_cache(&self, key: ItemKey) -> CacheEntry {
        CacheEntry {
            key,
            frames: self.frames.clone(),
            problems: self.problems.clone(),
            clamp_marker_px: self.clamp_marker_px,
            outputs: self.outputs.clone(),
        }
    }

    /// The item's row: statistics of its frames and its status.
    pub(super) fn record(&self) -> VideoRecord {
        let stats = stats::summarize(&self.frames);
        let status = if stats.frames_used == 0 {
            let why = if self.problems.is_empty() {
                most_common_rejection(&self.frames).unwrap_or_else(|| "no frames decoded".into())
            } else {
                self.problems.join("; ")
            };
            VideoStatus::Failed { why }
        } else if self.problems.is_empty() {
            VideoStatus::Ok
        } else {
            VideoStatus::Partial {
                problems: self.problems.clone(),
            }
        };
        VideoRecord {
            file: self.file.clone(),
            pressure_kpa: self.pressure_kpa,
            pressure: self.pressure,
            stats,
            status,
        }
    }
}

/// The record of a measured frame of `file`.
pub(super) fn frame_record(
    file: &str,
    frame: u64,
    time_s: f64,
    pressure_kpa: f64,
    m: frame::FrameMeasurement,
) -> FrameRecord {
    FrameRecord {
        file: file.to_string(),
        frame,
        time_s,
        pressure_kpa,
        n_markers: m.n_markers,
        n_ignored: m.ignored_px.len(),
        n_continuing: m.n_continuing,
        radius_px: m.radius_px,
        radius_mm: m.radius_mm,
        curvature_per_m: m.curvature_per_m,
        bending_angle_deg: m.bending_angle_deg,
        fit_rms: m.fit_rms,
        status: m.status,
        markers: m.markers,
        segments: m.segments,
        tip_x_mm: f64::NAN,
        tip_y_mm: f64::NAN,
        tip_angle_deg: f64::NAN,
        radius_mm_smooth: f64::NAN,
        curvature_per_m_smooth: f64::NAN,
        bending_angle_deg_smooth: f64::NAN,
    }
}

/// The most frequent rejection of `frames`, with a hint.
fn most_common_rejection(frames: &[FrameRecord]) -> Option<String> {
    let mut counts: std::collections::BTreeMap<String, usize> = std::collections::BTreeMap::new();
    for f in frames.iter().filter(|f| !f.status.is_ok()) {
        *counts.entry(f.status.to_string()).or_default() += 1;
    }
    let hint = |s: &str| {
        if s.contains("outside the roi") {
            "check the roi in bendscope.toml (undistorted pixels; `bendscope inspect` shows the markers' positions)"
        } else if s.starts_with("0 markers found") {
            "no blob of the marker colour: set [detect] colour in bendscope.toml (red, green, blue, yellow or dark; default red), check the lighting and expected_markers; `bendscope inspect` shows what passes the thresholds"
        } else if s.contains("markers found") {
            "check the lighting, the HSV thresholds ([detect] colour, hue_min, ...; `bendscope inspect` shows what passes) and expected_markers in bendscope.toml"
        } else if s.contains("pressure log") {
            "check that the log covers the recording"
        } else if s.contains("depth") {
            "check the depth frames"
        } else {
            "see per_frame.csv"
        }
    };
    counts
        .into_iter()
        .max_by_key(|(_, n)| *n)
        .map(|(s, n)| format!("{s} (in {n} of {} frames): {}", frames.len(), hint(&s)))
}
