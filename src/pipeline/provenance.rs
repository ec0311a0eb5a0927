//! `OUT/session.json`: how a session's results were made. The bendscope version, the
//! settings, the calibration (file and content hash), the scale (mm/px, where it came
//! from, the board and whether its square size was given, the homography) and which
//! videos came from the cache: what a reader of the tables needs to trust (or doubt)
//! their millimetres.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::scale::ScaleBoard;
use crate::session::SessionConfig;

/// Name of the provenance file in OUT.
pub const SESSION_JSON: &str = "session.json";

/// Everything `session.json` holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// Version of bendscope that made the results.
    pub bendscope_version: String,
    /// The session folder, as given.
    pub session: PathBuf,
    /// The settings file read (`None`: the defaults).
    pub config_file: Option<PathBuf>,
    /// The settings used (the file's, with every default filled in).
    pub settings: SessionConfig,
    /// Whether cached results were ignored (`--force`).
    pub force: bool,
    /// The calibration used (video sessions).
    pub calibration: Option<CalibrationUsed>,
    /// The scale used (video sessions).
    pub scale: Option<ScaleUsed>,
    /// The intrinsics file (RGB-D sessions: the depth gives millimetres).
    pub rgbd_intrinsics: Option<PathBuf>,
    /// Every measured item, in order, and whether its result came from the cache.
    pub videos: Vec<VideoUsed>,
}

/// Where a calibration came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CalibrationSource {
    /// `--calibration FILE`.
    Given,
    /// `calibration = "FILE"` in bendscope.toml.
    Config,
    /// calib/ calibrated by this run or an earlier one (cached in OUT).
    Calibrated,
}

/// The calibration a session was measured with.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct CalibrationUsed {
    /// Where it came from.
    pub source: CalibrationSource,
    /// The file read (for `calibrated`: OUT/calibration.yaml).
    pub path: PathBuf,
    /// xxh3-128 of the file's bytes, 32 hex digits.
    pub content_hash: String,
}

impl CalibrationUsed {
    /// The calibration read from `path` (its bytes hashed).
    pub fn of_file(source: CalibrationSource, path: &Path) -> std::io::Result<Self> {
        let bytes = std::fs::read(path)?;
        Ok(Self {
            source,
            path: path.to_path_buf(),
            content_hash: format!("{:032x}", xxhash_rust::xxh3::xxh3_128(&bytes)),
        })
    }
}

/// Where a scale came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ScaleSource {
    /// `mm_per_px` in bendscope.toml.
    MmPerPx,
    /// `scale = "FILE"` in bendscope.toml (saved by `bendscope scale --save`).
    ScaleFile,
    /// The session's scale photo and `[scale_board]`.
    ScalePhoto,
}

/// The scale a session was measured with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScaleUsed {
    /// Where it came from.
    pub source: ScaleSource,
    /// The scale photo or scale file (`None` for `mm_per_px`).
    pub file: Option<PathBuf>,
    /// mm per undistorted px at `image_width`.
    pub mm_per_px: f64,
    /// Frame width the scale applies to, px (other widths are scaled in proportion).
    pub image_width: u32,
    /// The board it was measured from, when known.
    pub board: Option<ScaleBoard>,
    /// Undistorted px -> plane mm (row-major), when measured from a board.
    pub plane_from_px: Option<[f64; 9]>,
}

impl ScaleUsed {
    /// One line for people: `0.528208 mm/px from s/scale.jpg (board 9x6, 10 mm squares)`.
    pub fn describe(&self) -> String {
        let from = match (&self.source, &self.file) {
            (ScaleSource::MmPerPx, _) | (_, None) => "mm_per_px in the settings".to_string(),
            (ScaleSource::ScaleFile, Some(f)) => format!("scale file {}", f.display()),
            (ScaleSource::ScalePhoto, Some(f)) => f.display().to_string(),
        };
        let board = match &self.board {
            Some(b) => format!(
                " (board {}x{}, {} mm squares{})",
                b.cols,
                b.rows,
                b.square_mm,
                if b.square_mm_given {
                    ""
                } else {
                    ", assumed: not given"
                }
            ),
            None => String::new(),
        };
        format!("{:.6} mm/px from {from}{board}", self.mm_per_px)
    }
}

/// An item of the session and whether its result came from the cache.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct VideoUsed {
    /// The video (or `color` for an RGB-D recording).
    pub file: String,
    /// True when its cached result was current and used.
    pub from_cache: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scale_line_names_value_source_and_board() {
        let mut s = ScaleUsed {
            source: ScaleSource::ScalePhoto,
            file: Some("s/scale.jpg".into()),
            mm_per_px: 0.528_208_1,
            image_width: 800,
            board: Some(ScaleBoard {
                cols: 9,
                rows: 6,
                square_mm: 10.0,
                square_mm_given: true,
            }),
            plane_from_px: None,
        };
        assert_eq!(
            s.describe(),
            "0.528208 mm/px from s/scale.jpg (board 9x6, 10 mm squares)"
        );
        s.board.as_mut().unwrap().square_mm_given = false;
        assert!(s.describe().ends_with("10 mm squares, assumed: not given)"));
        s.source = ScaleSource::MmPerPx;
        s.board = None;
        assert_eq!(
            s.describe(),
            "0.528208 mm/px from mm_per_px in the settings"
        );
    }
}
