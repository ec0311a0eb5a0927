//! Camera models, checkerboard calibration and undistortion.
//!
//! - [`corners`]: find the checkerboard's inner corners in a view (large photos are
//!   searched on a downscaled copy, then refined at full resolution), views in parallel.
//! - [`solve`]: run OpenCV's calibration: Kannala-Brandt fisheye (`cv::fisheye::calibrate`)
//!   or pinhole + 5 Brown coefficients (`cv::calibrateCamera`, Zhang's method).
//! - [`coverage`]: where the board went (field angle, share of the frame, 3x3 grid) and
//!   where to hold it next.
//! - [`field`]: the valid field of a calibration, the smaller of the field the board
//!   covered and the field over which the distortion polynomial is monotonic.
//! - [`file`]: read and write calibration files (OpenCV `FileStorage` YAML).
//! - [`destination`]: where `calibrate` writes by default, and not over another
//!   camera's file.
//! - [`sources`]: the views given as images, folders or videos.
//! - [`undistort`]: raw pixel <-> undistorted pixel for points, full-frame maps and the
//!   crop rectangle free of the black border, inside the valid field.

pub mod corners;
pub mod coverage;
pub mod destination;
pub mod field;
pub mod file;
pub mod solve;
pub mod sources;
pub mod undistort;

mod cv;

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

pub use corners::{detect_views, BoardView, DetectSettings as CornerSettings, ViewSource};
pub use coverage::Coverage;
pub use field::ValidField;
pub use solve::{calibrate, CalibrationSettings};
pub use undistort::{UndistortSettings, Undistorter};

/// Errors of camera calibration, calibration files and undistortion.
#[derive(Debug, thiserror::Error)]
pub enum CalibError {
    /// The board specification could not be parsed.
    #[error("board `{spec}` is not COLSxROWS of inner corners (e.g. 9x6, both at least 2)")]
    BadBoard {
        /// What the user gave.
        spec: String,
    },
    /// No input view at all.
    #[error(
        "no calibration images found in {paths}: give image files, folders of images or videos"
    )]
    NoViews {
        /// The paths given, joined.
        paths: String,
    },
    /// A path given on the command line is neither an image, a folder nor a video.
    #[error("{path}: not an image, a folder or a video bendscope can read; give checkerboard photos (jpg, png, ...) or a video")]
    NotAnInput {
        /// The offending path.
        path: PathBuf,
    },
    /// An image file that cannot be decoded.
    #[error("{path}: {why}; give a JPEG/PNG photo")]
    Unreadable {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        why: String,
    },
    /// Too few views with a detected board.
    #[error("only {found} view(s) with a {board} board were found, the {model} model needs at least {needed}: check --board (inner corners, columns x rows) and add more photos{rejected}")]
    TooFewViews {
        /// Views with a board.
        found: usize,
        /// The rejected views and why, formatted for the message (empty when none).
        rejected: String,
        /// Minimum needed.
        needed: usize,
        /// Board, e.g. `9x6`.
        board: String,
        /// Camera model name.
        model: String,
    },
    /// Views of different sizes.
    #[error("{path}: {width}x{height} differs from the other views' {expected_width}x{expected_height}: calibrate one camera setting at a time")]
    MixedResolution {
        /// The first view with another size.
        path: String,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
        /// The size of the first view.
        expected_width: u32,
        /// The size of the first view.
        expected_height: u32,
    },
    /// OpenCV failed in a way bendscope could not recover from.
    #[error("OpenCV {context}: {message}")]
    OpenCv {
        /// What bendscope was doing.
        context: String,
        /// OpenCV's message.
        message: String,
    },
    /// The calibration did not converge to finite values.
    #[error("calibration diverged ({what}): add views that fill the frame, especially its corners, and check --model")]
    Diverged {
        /// What was not finite.
        what: String,
    },
    /// A file that should be a calibration is not one.
    #[error("{path}: not a bendscope calibration ({why}); make one with `bendscope calibrate`")]
    NotACalibration {
        /// The file.
        path: PathBuf,
        /// What is missing or wrong.
        why: String,
    },
    /// Reading or writing a file failed.
    #[error("{}", crate::io::with_path(path, source))]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The output file holds another camera's calibration.
    #[error("{path} holds {why}: give -o FILE for this camera, or --force to replace it")]
    OtherCamera {
        /// The file.
        path: PathBuf,
        /// What it holds and how it differs.
        why: String,
    },
    /// Video and calibration frame sizes cannot be reconciled.
    #[error("video is {width}x{height} but the calibration was made at {calib_width}x{calib_height} (another aspect ratio): calibrate at the video's resolution")]
    ResolutionMismatch {
        /// Video width.
        width: u32,
        /// Video height.
        height: u32,
        /// Calibration width.
        calib_width: u32,
        /// Calibration height.
        calib_height: u32,
    },
    /// A decoded video could not provide frames for calibration.
    #[error("{message}")]
    Video {
        /// The video.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

impl CalibError {
    pub(crate) fn cv(context: impl Into<String>, e: opencv::Error) -> Self {
        CalibError::OpenCv {
            context: context.into(),
            message: e.message,
        }
    }
}

/// A checkerboard: inner corners per row (`cols`) and per column (`rows`), square size.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Board {
    /// Inner corners along a row (x).
    pub cols: u32,
    /// Inner corners along a column (y).
    pub rows: u32,
    /// Side of one square, mm.
    pub square_mm: f64,
}

impl Board {
    /// A board of `cols` x `rows` inner corners with squares of `square_mm`.
    pub fn new(cols: u32, rows: u32, square_mm: f64) -> Result<Self, CalibError> {
        if cols < 2 || rows < 2 || !(square_mm.is_finite() && square_mm > 0.0) {
            return Err(CalibError::BadBoard {
                spec: format!("{cols}x{rows} / {square_mm} mm"),
            });
        }
        Ok(Self {
            cols,
            rows,
            square_mm,
        })
    }

    /// Parses `COLSxROWS` (inner corners) with the given square size.
    pub fn parse(spec: &str, square_mm: f64) -> Result<Self, CalibError> {
        let size: BoardSize = spec.parse()?;
        Self::new(size.cols, size.rows, square_mm)
    }

    /// Number of inner corners.
    pub fn corner_count(&self) -> usize {
        (self.cols * self.rows) as usize
    }

    /// Inner-corner positions on the board plane (z = 0), mm, row-major as OpenCV
    /// returns them (x along a row).
    pub fn object_points_mm(&self) -> Vec<[f64; 3]> {
        let mut pts = Vec::with_capacity(self.corner_count());
        for r in 0..self.rows {
            for c in 0..self.cols {
                pts.push([c as f64 * self.square_mm, r as f64 * self.square_mm, 0.0]);
            }
        }
        pts
    }
}

impl fmt::Display for Board {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.cols, self.rows)
    }
}

/// `COLSxROWS` as typed on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoardSize {
    /// Inner corners along a row.
    pub cols: u32,
    /// Inner corners along a column.
    pub rows: u32,
}

impl FromStr for BoardSize {
    type Err = CalibError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || CalibError::BadBoard {
            spec: s.to_string(),
        };
        let (c, r) = s.trim().split_once(['x', 'X', '*']).ok_or_else(bad)?;
        let cols: u32 = c.trim().parse().map_err(|_| bad())?;
        let rows: u32 = r.trim().parse().map_err(|_| bad())?;
        if cols < 2 || rows < 2 {
            return Err(bad());
        }
        Ok(Self { cols, rows })
    }
}

impl fmt::Display for BoardSize {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.cols, self.rows)
    }
}

/// The lens model of a calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum CameraModel {
    /// Kannala-Brandt fisheye, 4 coefficients (OpenCV `cv::fisheye`): GoPro and other
    /// wide-angle lenses.
    Fisheye,
    /// Pinhole with 5 Brown-Conrady coefficients k1 k2 p1 p2 k3 (OpenCV
    /// `cv::calibrateCamera`): RGB-D colour cameras, ordinary lenses.
    Pinhole,
}

impl CameraModel {
    /// The name used in files and messages.
    pub fn name(&self) -> &'static str {
        match self {
            CameraModel::Fisheye => "fisheye",
            CameraModel::Pinhole => "pinhole",
        }
    }

    /// Number of distortion coefficients.
    pub fn coefficient_count(&self) -> usize {
        match self {
            CameraModel::Fisheye => 4,
            CameraModel::Pinhole => 5,
        }
    }
}

impl FromStr for CameraModel {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "fisheye" => Ok(CameraModel::Fisheye),
            "pinhole" => Ok(CameraModel::Pinhole),
            other => Err(format!(
                "unknown camera model `{other}` (fisheye or pinhole)"
            )),
        }
    }
}

/// A view that did not contribute to the calibration, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RejectedView {
    /// File name (and frame, for video frames).
    pub name: String,
    /// Why it was left out.
    pub reason: String,
}

/// Reprojection error of one view.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ViewError {
    /// File name (and frame, for video frames).
    pub name: String,
    /// RMS reprojection error over the view's corners, px.
    pub rms_px: f64,
}

/// Camera intrinsics and how they were obtained.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// Lens model.
    pub model: CameraModel,
    /// Width of the calibrated frames, px.
    pub image_width: u32,
    /// Height of the calibrated frames, px.
    pub image_height: u32,
    /// K = [fx 0 cx; 0 fy cy; 0 0 1], px.
    pub camera_matrix: Matrix3<f64>,
    /// Fisheye: k1..k4; pinhole: k1 k2 p1 p2 k3.
    pub distortion: Vec<f64>,
    /// RMS reprojection error over all corners of all views used, px.
    pub avg_reprojection_error: f64,
    /// Per-view RMS reprojection error.
    pub per_view_errors: Vec<ViewError>,
    /// The board used.
    pub board: Option<Board>,
    /// Views that were used.
    pub views_used: Vec<String>,
    /// Views left out, with the reason.
    pub views_rejected: Vec<RejectedView>,
    /// Where the board's detected corners went; `None` when unknown (cameras described
    /// by hand, calibration files written before bendscope recorded it).
    pub coverage: Option<Coverage>,
}

impl Calibration {
    /// fx, px.
    pub fn fx(&self) -> f64 {
        self.camera_matrix[(0, 0)]
    }
    /// fy, px.
    pub fn fy(&self) -> f64 {
        self.camera_matrix[(1, 1)]
    }
    /// cx, px.
    pub fn cx(&self) -> f64 {
        self.camera_matrix[(0, 2)]
    }
    /// cy, px.
    pub fn cy(&self) -> f64 {
        self.camera_matrix[(1, 2)]
    }

    /// The same camera at another frame size: equal size returns a copy; the same aspect
    /// ratio (within 0.5%) scales K (the distortion acts on normalized coordinates and is
    /// unchanged); another aspect ratio is an error.
    pub fn for_resolution(&self, width: u32, height: u32) -> Result<Calibration, CalibError> {
        if width == self.image_width && height == self.image_height {
            return Ok(self.clone());
        }
        let sx = width as f64 / self.image_width as f64;
        let sy = height as f64 / self.image_height as f64;
        if (sx / sy - 1.0).abs() > ASPECT_TOLERANCE {
            return Err(CalibError::ResolutionMismatch {
                width,
                height,
                calib_width: self.image_width,
                calib_height: self.image_height,
            });
        }
        let mut out = self.clone();
        let k = &mut out.camera_matrix;
        // Pixel centres at integer coordinates: x' + 0.5 = (x + 0.5) * s.
        k[(0, 0)] *= sx;
        k[(0, 1)] *= sx;
        k[(0, 2)] = (k[(0, 2)] + 0.5) * sx - 0.5;
        k[(1, 1)] *= sy;
        k[(1, 2)] = (k[(1, 2)] + 0.5) * sy - 0.5;
        out.image_width = width;
        out.image_height = height;
        out.avg_reprojection_error *= sx;
        Ok(out)
    }

    /// Where the lens model may be used ([`field`]): field angles up to the smaller of the
    /// largest angle the board's corners covered (when known) and the largest angle up to
    /// which the distortion polynomial is monotonic (Kannala-Brandt theta_d(theta), or
    /// the Brown radial r (1 + k1 r^2 + k2 r^4 + k3 r^6)). Angles do not depend on the
    /// frame size, so this holds for [`Calibration::for_resolution`]'s result too.
    pub fn valid_field(&self) -> ValidField {
        ValidField::new(
            self.model,
            &self.distortion,
            self.coverage.as_ref().map(|c| c.field_angle_deg),
        )
    }

    /// Views left out because they repeated another view
    /// ([`corners::drop_duplicate_views`]).
    pub fn duplicate_views(&self) -> usize {
        self.views_rejected
            .iter()
            .filter(|r| r.reason.starts_with(corners::DUPLICATE_REASON))
            .count()
    }

    /// True when [`Calibration::for_resolution`] would scale (not copy) for this size.
    pub fn needs_scaling(&self, width: u32, height: u32) -> bool {
        width != self.image_width || height != self.image_height
    }
}

/// Relative aspect-ratio difference accepted between a video and its calibration.
pub const ASPECT_TOLERANCE: f64 = 0.005;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn board_size_parses_and_rejects() {
        assert_eq!(
            "9x6".parse::<BoardSize>().unwrap(),
            BoardSize { cols: 9, rows: 6 }
        );
        assert!("9".parse::<BoardSize>().is_err());
        assert!("1x6".parse::<BoardSize>().is_err());
        assert!("ax6".parse::<BoardSize>().is_err());
        assert!(Board::parse("9x6", -1.0).is_err());
    }

    #[test]
    fn object_points_are_row_major() {
        let b = Board::new(3, 2, 10.0).unwrap();
        let p = b.object_points_mm();
        assert_eq!(p.len(), 6);
        assert_eq!(p[1], [10.0, 0.0, 0.0]);
        assert_eq!(p[3], [0.0, 10.0, 0.0]);
    }

    #[test]
    fn resolution_scaling_keeps_the_field_of_view() {
        let c = Calibration {
            model: CameraModel::Fisheye,
            image_width: 4000,
            image_height: 3000,
            camera_matrix: Matrix3::new(1800.0, 0.0, 1999.5, 0.0, 1800.0, 1499.5, 0.0, 0.0, 1.0),
            distortion: vec![0.05, 0.01, 0.0, 0.0],
            avg_reprojection_error: 0.4,
            per_view_errors: vec![],
            board: None,
            views_used: vec![],
            views_rejected: vec![],
            coverage: None,
        };
        let s = c.for_resolution(1920, 1440).unwrap();
        assert!((s.fx() - 864.0).abs() < 1e-9);
        assert!((s.cx() - 959.5).abs() < 1e-9);
        assert!((s.cy() - 719.5).abs() < 1e-9);
        assert!(matches!(
            c.for_resolution(1920, 1080),
            Err(CalibError::ResolutionMismatch { .. })
        ));
        assert_eq!(c.for_resolution(4000, 3000).unwrap(), c);
    }
}
