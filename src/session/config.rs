//! Settings of a session: `bendscope.toml`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{SessionError, CONFIG};
use crate::detect::DetectSettings;

/// The scale board (a board lying in the actuator plane).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoardConfig {
    /// Inner corners along a row.
    pub cols: u32,
    /// Inner corners along a column.
    pub rows: u32,
    /// Square side, mm.
    pub square_mm: f64,
}

impl Default for BoardConfig {
    fn default() -> Self {
        Self {
            cols: 9,
            rows: 6,
            square_mm: 25.0,
        }
    }
}

/// Settings of a session (`bendscope.toml`); every field has a default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SessionConfig {
    /// Calibration file (relative to the session); else `calib/` is calibrated.
    pub calibration: Option<PathBuf>,
    /// Lens model used when calibrating `calib/`.
    pub model: crate::calib::CameraModel,
    /// Board of the `calib/` photos.
    pub calib_board: BoardConfig,
    /// Board of the scale photo.
    pub scale_board: BoardConfig,
    /// Scale photo (relative to the session); default: the first `scale.*` image.
    pub scale_image: Option<PathBuf>,
    /// Known mm per undistorted px (skips the scale photo).
    pub mm_per_px: Option<f64>,
    /// Expected number of markers per frame.
    pub expected_markers: usize,
    /// Process every n-th frame.
    pub frame_stride: u64,
    /// Ramp protocol: width of the pressure bins frames are averaged in, kPa (the
    /// low-pass filter of the per-frame results).
    pub ramp_bin_kpa: f64,
    /// Ramp protocol: time of the video's first frame on the pressure log's clock, s.
    pub ramp_time_offset_s: f64,
    /// Undistort every whole frame before detection (the original method; slower, for
    /// comparison) instead of undistorting only the detected centroids.
    pub full_frame_undistort: bool,
    /// Marker detection.
    pub detect: DetectSettings,
}

impl Default for SessionConfig {
    fn default() -> Self {
        Self {
            calibration: None,
            model: crate::calib::CameraModel::Fisheye,
            calib_board: BoardConfig::default(),
            scale_board: BoardConfig::default(),
            scale_image: None,
            mm_per_px: None,
            expected_markers: 8,
            frame_stride: 1,
            ramp_bin_kpa: 1.0,
            ramp_time_offset_s: 0.0,
            full_frame_undistort: false,
            detect: DetectSettings::default(),
        }
    }
}

impl SessionConfig {
    /// Reads `path` (TOML); missing fields take their defaults.
    pub fn read(path: &Path) -> Result<Self, SessionError> {
        let text = std::fs::read_to_string(path).map_err(|e| SessionError::Config {
            path: path.to_path_buf(),
            why: e.to_string(),
        })?;
        let c: SessionConfig = toml::from_str(&text).map_err(|e| SessionError::Config {
            path: path.to_path_buf(),
            why: e.message().to_string(),
        })?;
        c.check(path)?;
        Ok(c)
    }

    /// Reads `SESSION/bendscope.toml` when present, else the defaults.
    pub fn for_session(session: &Path) -> Result<Self, SessionError> {
        let p = session.join(CONFIG);
        if p.is_file() {
            Self::read(&p)
        } else {
            Ok(Self::default())
        }
    }

    fn check(&self, path: &Path) -> Result<(), SessionError> {
        let bad = |why: String| {
            Err(SessionError::Config {
                path: path.to_path_buf(),
                why,
            })
        };
        if self.expected_markers < 3 {
            return bad(format!(
                "expected_markers = {}: a circle needs at least 3 markers",
                self.expected_markers
            ));
        }
        if !(self.ramp_bin_kpa.is_finite() && self.ramp_bin_kpa > 0.0)
            || !self.ramp_time_offset_s.is_finite()
        {
            return bad(
                "ramp_bin_kpa must be a positive number and ramp_time_offset_s a number".into(),
            );
        }
        if self.frame_stride == 0 {
            return bad("frame_stride must be at least 1".into());
        }
        if let Some(m) = self.mm_per_px {
            if !(m.is_finite() && m > 0.0) {
                return bad(format!("mm_per_px = {m} must be a positive number"));
            }
        }
        for (name, b) in [
            ("calib_board", &self.calib_board),
            ("scale_board", &self.scale_board),
        ] {
            if b.cols < 2 || b.rows < 2 || !(b.square_mm.is_finite() && b.square_mm > 0.0) {
                return bad(format!(
                    "{name}: cols and rows must be >= 2 and square_mm > 0"
                ));
            }
        }
        if self.detect.min_area_px > self.detect.max_area_px {
            return bad("detect: min_area_px is larger than max_area_px".into());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_defaults_and_bad_values() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(CONFIG);
        std::fs::write(
            &p,
            "expected_markers = 6\n[scale_board]\nsquare_mm = 10\n[detect]\ns_min = 90\n",
        )
        .unwrap();
        let c = SessionConfig::read(&p).unwrap();
        assert_eq!(c.expected_markers, 6);
        assert_eq!(c.scale_board.square_mm, 10.0);
        assert_eq!(c.scale_board.cols, 9);
        assert_eq!(c.detect.hsv.s_min, 90);
        std::fs::write(&p, "frame_stride = 0\n").unwrap();
        assert!(SessionConfig::read(&p)
            .unwrap_err()
            .to_string()
            .contains("frame_stride"));
        std::fs::write(&p, "nonsense = 1\n").unwrap();
        assert!(SessionConfig::read(&p).is_err());
    }
}
