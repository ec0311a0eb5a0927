//! `OUT/session.json`: how a session's results were made. The bendscope version, the
//! settings, the calibration (file and content hash), the scale (mm/px, which kind and
//! where it came from, the board, whether its square size was given and where its plane
//! lay, or the markers at rest it was measured on, the homography) and which
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
    /// The markers at rest (the 0 kPa item) and `[scale_markers]`.
    Markers,
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
    /// Which scale, in a word or three: `board`, `board offset +3 mm`, `markers`,
    /// `mm_per_px`, `scale file` ([`ScaleUsed::kind_of`]).
    #[serde(default)]
    pub kind: String,
    /// The scale photo's board: its plane's distance from the camera (from its pose) and
    /// how far in front of the marker plane it lay (`[scale_board] offset_mm`), mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub board_plane: Option<BoardPlane>,
    /// The markers at rest it was measured from (`markers`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rest: Option<RestUsed>,
}

/// Where the scale board's plane lay.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BoardPlane {
    /// Distance of the board's plane from the camera along its normal, mm.
    pub distance_mm: f64,
    /// How far it lay in front of the marker plane (negative: behind), mm.
    pub offset_mm: f64,
}

/// The markers at rest a scale was measured from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RestUsed {
    /// Frames whose markers were measured.
    pub frames_used: usize,
    /// The rest spacing given, mm, each consecutive pair from the clamped end.
    pub spacing_mm: Vec<f64>,
    /// Each pair's median distance measured, undistorted px.
    pub spacing_px: Vec<f64>,
    /// Relative standard deviation of the pairs' mm per px.
    pub spread: f64,
}

impl ScaleUsed {
    /// Which scale, in a word or three: `board`, `board offset +3 mm` (the board's plane
    /// 3 mm in front of the markers'), `markers`, `mm_per_px`, `scale file`.
    pub fn kind_of(source: ScaleSource, offset_mm: f64) -> String {
        match source {
            ScaleSource::MmPerPx => "mm_per_px".into(),
            ScaleSource::ScaleFile => "scale file".into(),
            ScaleSource::ScalePhoto if offset_mm == 0.0 => "board".into(),
            ScaleSource::ScalePhoto => format!("board offset {offset_mm:+} mm"),
            ScaleSource::Markers => "markers".into(),
        }
    }

    /// One line for people: `0.528208 mm/px from s/scale.jpg (board 9x6, 10 mm squares)`.
    pub fn describe(&self) -> String {
        let from = match (&self.source, &self.file) {
            (ScaleSource::MmPerPx, _) | (_, None) => "mm_per_px in the settings".to_string(),
            (ScaleSource::ScaleFile, Some(f)) => format!("scale file {}", f.display()),
            (ScaleSource::ScalePhoto, Some(f)) => f.display().to_string(),
            (ScaleSource::Markers, Some(f)) => format!("the markers at rest in {}", f.display()),
        };
        let plane = match &self.board_plane {
            Some(p) if p.offset_mm != 0.0 => format!(
                "; its plane {} mm {} the markers', {:.1} mm from the camera",
                p.offset_mm.abs(),
                if p.offset_mm > 0.0 {
                    "in front of"
                } else {
                    "behind"
                },
                p.distance_mm
            ),
            _ => String::new(),
        };
        let rest = match &self.rest {
            Some(r) => format!(
                " ({} frames, {} marker pairs, {:.1} mm apart in all)",
                r.frames_used,
                r.spacing_mm.len(),
                r.spacing_mm.iter().sum::<f64>()
            ),
            None => String::new(),
        };
        let board = match &self.board {
            Some(b) => format!(
                " (board {}x{}, {} mm squares{}{})",
                b.cols,
                b.rows,
                b.square_mm,
                if b.square_mm_given {
                    ""
                } else {
                    ", assumed: not given"
                },
                plane
            ),
            None => String::new(),
        };
        format!("{:.6} mm/px from {from}{board}{rest}", self.mm_per_px)
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
            kind: "board".into(),
            board_plane: None,
            rest: None,
        };
        assert_eq!(
            s.describe(),
            "0.528208 mm/px from s/scale.jpg (board 9x6, 10 mm squares)"
        );
        s.board_plane = Some(BoardPlane {
            distance_mm: 127.04,
            offset_mm: 3.0,
        });
        assert_eq!(
            s.describe(),
            "0.528208 mm/px from s/scale.jpg (board 9x6, 10 mm squares; its plane 3 mm in front of the markers', 127.0 mm from the camera)"
        );
        s.board_plane = None;
        assert_eq!(
            ScaleUsed::kind_of(ScaleSource::ScalePhoto, 3.0),
            "board offset +3 mm"
        );
        assert_eq!(
            ScaleUsed::kind_of(ScaleSource::ScalePhoto, -2.5),
            "board offset -2.5 mm"
        );
        assert_eq!(ScaleUsed::kind_of(ScaleSource::ScalePhoto, 0.0), "board");
        assert_eq!(ScaleUsed::kind_of(ScaleSource::Markers, 0.0), "markers");
        s.board.as_mut().unwrap().square_mm_given = false;
        assert!(s.describe().ends_with("10 mm squares, assumed: not given)"));
        s.source = ScaleSource::MmPerPx;
        s.board = None;
        assert_eq!(
            s.describe(),
            "0.528208 mm/px from mm_per_px in the settings"
        );
        s.source = ScaleSource::Markers;
        s.file = Some("s/GX010101.MP4".into());
        s.rest = Some(RestUsed {
            frames_used: 5,
            spacing_mm: vec![12.5; 7],
            spacing_px: vec![40.0; 7],
            spread: 0.001,
        });
        assert_eq!(
            s.describe(),
            "0.528208 mm/px from the markers at rest in s/GX010101.MP4 (5 frames, 7 marker pairs, 87.5 mm apart in all)"
        );
    }
}
