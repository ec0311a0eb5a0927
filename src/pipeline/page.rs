//! The report page's inputs from a session's records: per_video.csv's rows and
//! session.json's provenance in the terms of [`crate::report::html`], which knows
//! nothing of the pipeline (fit.json's fits: [`super::output`]).

use crate::report::html::{CalibrationFile, RowState, Setup, VideoRow};

use super::overlay::overlay_rel_path;
use super::provenance::Provenance;
use super::records::{VideoRecord, VideoStatus};

/// The rows of the per-video table.
pub fn video_rows(videos: &[VideoRecord]) -> Vec<VideoRow> {
    videos
        .iter()
        .map(|v| VideoRow {
            file: v.file.clone(),
            overlay: overlay_rel_path(&v.file),
            pressure_kpa: v.pressure_kpa,
            radius_mm: v.stats.radius_mm,
            radius_mm_median: v.stats.radius_mm_median,
            radius_mm_std: v.stats.radius_mm_std,
            curvature_per_m: v.stats.curvature_per_m,
            bending_angle_deg: v.stats.bending_angle_deg,
            frames_used: v.stats.frames_used,
            frames_rejected: v.stats.frames_rejected,
            status: v.status.to_string(),
            state: match &v.status {
                VideoStatus::Ok => RowState::Ok,
                VideoStatus::Partial { .. } => RowState::Partial,
                _ => RowState::Bad,
            },
            measured: v.status.is_measured(),
            segments: v.stats.segments.clone(),
        })
        .collect()
}

/// The page's setup lines from the session's provenance.
pub fn setup(p: &Provenance) -> Setup {
    Setup {
        scale: p.scale.as_ref().map(|s| s.describe()),
        calibration: p.calibration.as_ref().map(|c| CalibrationFile {
            path: c.path.clone(),
            content_hash: c.content_hash.clone(),
        }),
        rgbd_intrinsics: p.rgbd_intrinsics.clone(),
        bendscope_version: p.bendscope_version.clone(),
    }
}
