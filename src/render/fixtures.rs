//! Synthetic calibration sets: checkerboard photos from random poses plus a scale photo
//! (board parallel to the image plane at a known distance), with a `truth.json` holding
//! the camera and the true mm per undistorted px. Used by `scripts/make-fixtures.sh`,
//! the tests and the calibration benchmark.

use std::path::Path;

use nalgebra::{Matrix3, Rotation3, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::board::{random_board_poses_within, render_board_photo, BoardPose, PhotoSettings};
use super::RenderError;
use crate::calib::{Board, Calibration, CameraModel, UndistortSettings, Undistorter};
use crate::io::write_atomic;

/// JPEG quality of synthetic photos.
pub const JPEG_QUALITY: u8 = 92;

/// What to render.
#[derive(Debug, Clone)]
pub struct CalibrationSetSpec {
    /// The true camera.
    pub camera: Calibration,
    /// The board.
    pub board: Board,
    /// Number of calibration photos.
    pub views: usize,
    /// The boards stay inside the disc of this share of the frame's half-diagonal around
    /// the frame centre (1: anywhere in the frame; see
    /// [`super::board::random_board_poses_within`]).
    pub view_reach: f64,
    /// Distance of the scale board from the camera, mm.
    pub scale_distance_mm: f64,
    /// Image formation.
    pub photo: PhotoSettings,
    /// Pose seed.
    pub seed: u64,
}

/// Ground truth written beside the photos.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CameraTruth {
    /// fisheye or pinhole.
    pub model: CameraModel,
    /// Frame width, px.
    pub width: u32,
    /// Frame height, px.
    pub height: u32,
    /// K, row-major.
    pub k: [[f64; 3]; 3],
    /// Distortion coefficients.
    pub d: Vec<f64>,
}

impl CameraTruth {
    /// From a calibration.
    pub fn from_calibration(c: &Calibration) -> Self {
        let m = &c.camera_matrix;
        Self {
            model: c.model,
            width: c.image_width,
            height: c.image_height,
            k: [
                [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
                [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
                [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
            ],
            d: c.distortion.clone(),
        }
    }

    /// As a calibration (no views, zero error).
    pub fn to_calibration(&self) -> Calibration {
        let k = &self.k;
        Calibration {
            model: self.model,
            image_width: self.width,
            image_height: self.height,
            camera_matrix: Matrix3::new(
                k[0][0], k[0][1], k[0][2], k[1][0], k[1][1], k[1][2], k[2][0], k[2][1], k[2][2],
            ),
            distortion: self.d.clone(),
            avg_reprojection_error: 0.0,
            per_view_errors: vec![],
            board: None,
            views_used: vec![],
            views_rejected: vec![],
            coverage: None,
        }
    }
}

/// `truth.json` of a synthetic calibration set.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CalibrationSetTruth {
    /// The camera that took the photos.
    pub camera: CameraTruth,
    /// Inner corners along a row.
    pub board_cols: u32,
    /// Inner corners along a column.
    pub board_rows: u32,
    /// Square side, mm.
    pub square_mm: f64,
    /// Scale photo file name.
    pub scale_file: String,
    /// Distance of the scale board, mm.
    pub scale_distance_mm: f64,
    /// True mm per undistorted px of the scale board (with the true camera).
    pub mm_per_px: f64,
}

/// A GoPro-like fisheye camera at `width` x `height` (4:3): wide field of view (about
/// 150 degrees across the diagonal), Kannala-Brandt coefficients of the size GoPro lenses
/// show, principal point slightly off centre.
pub fn gopro_like_camera(width: u32, height: u32) -> Calibration {
    let s = width as f64 / 960.0;
    CameraTruth {
        model: CameraModel::Fisheye,
        width,
        height,
        k: [
            [430.0 * s, 0.0, 481.3 * s],
            [
                0.0,
                431.2 * s,
                358.4 * s * (height as f64 / (0.75 * width as f64)),
            ],
            [0.0, 0.0, 1.0],
        ],
        d: vec![0.045, -0.012, 0.004, -0.0008],
    }
    .to_calibration()
}

/// Renders the photos, the scale photo and `truth.json` into `dir` (photos in
/// `dir/calib/`).
pub fn write_calibration_set(
    dir: &Path,
    spec: &CalibrationSetSpec,
) -> Result<CalibrationSetTruth, RenderError> {
    let poses = random_board_poses_within(
        &spec.camera,
        &spec.board,
        spec.views,
        spec.seed,
        spec.view_reach,
    )?;
    let calib_dir = dir.join("calib");
    poses
        .par_iter()
        .enumerate()
        .try_for_each(|(i, pose)| -> Result<(), RenderError> {
            let settings = PhotoSettings {
                seed: spec.photo.seed.wrapping_add(i as u64 * 7919),
                ..spec.photo
            };
            let img = render_board_photo(&spec.camera, &spec.board, pose, &settings)?;
            write_jpeg(&calib_dir.join(format!("board{:02}.jpg", i + 1)), &img)
        })?;
    // Scale photo: board parallel to the image plane, centred on the optical axis.
    let b = &spec.board;
    let centre = Vector3::new(
        b.square_mm * (b.cols as f64 - 1.0) / 2.0,
        b.square_mm * (b.rows as f64 - 1.0) / 2.0,
        0.0,
    );
    let pose = BoardPose {
        rotation: Rotation3::identity(),
        translation_mm: Vector3::new(0.0, 0.0, spec.scale_distance_mm) - centre,
    };
    let img = render_board_photo(&spec.camera, b, &pose, &spec.photo)?;
    write_jpeg(&dir.join("scale.jpg"), &img)?;
    let und = Undistorter::new(&spec.camera, UndistortSettings::default())?;
    let truth = CalibrationSetTruth {
        camera: CameraTruth::from_calibration(&spec.camera),
        board_cols: b.cols,
        board_rows: b.rows,
        square_mm: b.square_mm,
        scale_file: "scale.jpg".to_string(),
        scale_distance_mm: spec.scale_distance_mm,
        mm_per_px: spec.scale_distance_mm / und.new_camera_matrix()[(0, 0)],
    };
    let json = serde_json::to_string_pretty(&truth).map_err(|e| io_error(dir, e.into()))?;
    write_atomic(&dir.join("truth.json"), json.as_bytes()).map_err(|e| io_error(dir, e))?;
    Ok(truth)
}

fn io_error(path: &Path, source: std::io::Error) -> RenderError {
    RenderError::write(path, &source)
}

/// Encodes a grey image as JPEG and writes it atomically.
pub fn write_jpeg(path: &Path, img: &image::GrayImage) -> Result<(), RenderError> {
    let mut bytes = Vec::new();
    let enc = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, JPEG_QUALITY);
    img.write_with_encoder(enc)
        .map_err(|e| io_error(path, std::io::Error::other(e)))?;
    write_atomic(path, &bytes).map_err(|e| io_error(path, e))
}
