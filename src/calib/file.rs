//! Calibration files: OpenCV `FileStorage` YAML, written and read through OpenCV itself so
//! that `cv2.FileStorage(path, cv2.FILE_STORAGE_READ)` reads them as is.
//!
//! Keys: `model` (fisheye | pinhole), `image_width`, `image_height`, `camera_matrix` (3x3),
//! `distortion_coefficients` (4x1 or 5x1), `avg_reprojection_error` (px, RMS),
//! `per_view_reprojection_errors` (Nx1, px) in the order of `views_used`,
//! `board_width`, `board_height` (inner corners), `square_size_mm`, `views_used`
//! (sequence of names), `views_rejected` (sequence of {name, reason}).

use std::path::Path;

use opencv::core::{FileNode, FileStorage, FileStorage_Mode, Mat, Vector};
use opencv::prelude::*;

use super::cv::{mat_from_column, mat_from_matrix3, matrix3_from_mat, values_from_mat};
use super::{Board, CalibError, Calibration, CameraModel, RejectedView, ViewError};
use crate::io::write_atomic;

/// Writes `calib` to `path` (YAML, atomically).
pub fn write_calibration(path: &Path, calib: &Calibration) -> Result<(), CalibError> {
    let text = calibration_to_yaml(calib).map_err(|e| CalibError::cv("writing YAML", e))?;
    write_atomic(path, text.as_bytes()).map_err(|source| CalibError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The YAML text of a calibration.
pub fn calibration_to_yaml(calib: &Calibration) -> opencv::Result<String> {
    let mut fs = FileStorage::new(
        ".yaml",
        FileStorage_Mode::WRITE as i32 | FileStorage_Mode::MEMORY as i32,
        "",
    )?;
    fs.write_str("model", calib.model.name())?;
    fs.write_i32("image_width", calib.image_width as i32)?;
    fs.write_i32("image_height", calib.image_height as i32)?;
    fs.write_mat("camera_matrix", &mat_from_matrix3(&calib.camera_matrix)?)?;
    fs.write_mat(
        "distortion_coefficients",
        &mat_from_column(&calib.distortion)?,
    )?;
    fs.write_f64("avg_reprojection_error", calib.avg_reprojection_error)?;
    let errors: Vec<f64> = calib.per_view_errors.iter().map(|e| e.rms_px).collect();
    if !errors.is_empty() {
        fs.write_mat("per_view_reprojection_errors", &mat_from_column(&errors)?)?;
    }
    if let Some(b) = calib.board {
        fs.write_i32("board_width", b.cols as i32)?;
        fs.write_i32("board_height", b.rows as i32)?;
        fs.write_f64("square_size_mm", b.square_mm)?;
    }
    let used: Vector<String> = calib.views_used.iter().map(|s| s.as_str()).collect();
    fs.write_str_vec("views_used", &used)?;
    fs.start_write_struct("views_rejected", opencv::core::FileNode_SEQ, "")?;
    for r in &calib.views_rejected {
        fs.start_write_struct("", opencv::core::FileNode_MAP, "")?;
        fs.write_str("name", &r.name)?;
        fs.write_str("reason", &r.reason)?;
        fs.end_write_struct()?;
    }
    fs.end_write_struct()?;
    fs.release_and_get_string()
}

/// Reads a calibration written by [`write_calibration`] (or any OpenCV YAML with the
/// same keys; `model` defaults to pinhole for 5 coefficients and fisheye for 4).
pub fn read_calibration(path: &Path) -> Result<Calibration, CalibError> {
    let not = |why: &str| CalibError::NotACalibration {
        path: path.to_path_buf(),
        why: why.to_string(),
    };
    if !path.is_file() {
        return Err(CalibError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::new(
                std::io::ErrorKind::NotFound,
                "no such file: check the path, or make a calibration with `bendscope calibrate`",
            ),
        });
    }
    // OpenCV's parser reports a malformed file with an exception; some files it simply
    // opens as empty.
    let fs = FileStorage::new(path, FileStorage_Mode::READ as i32, "")
        .map_err(|_| not("not an OpenCV YAML/XML file"))?;
    if !fs.is_opened().unwrap_or(false) {
        return Err(not("not an OpenCV YAML/XML file"));
    }
    let node = |key: &str| -> Result<FileNode, CalibError> {
        let n = fs.get(key).map_err(|_| not(&format!("no `{key}`")))?;
        if n.empty().unwrap_or(true) || n.is_none().unwrap_or(true) {
            return Err(not(&format!("no `{key}`")));
        }
        Ok(n)
    };
    let k_mat: Mat = node("camera_matrix")?
        .mat()
        .map_err(|_| not("`camera_matrix` is not a matrix"))?;
    let camera_matrix = matrix3_from_mat(&k_mat).map_err(|_| not("`camera_matrix` is not 3x3"))?;
    let d_mat: Mat = node("distortion_coefficients")?
        .mat()
        .map_err(|_| not("`distortion_coefficients` is not a matrix"))?;
    let distortion = values_from_mat(&d_mat).map_err(|_| not("bad `distortion_coefficients`"))?;
    let model = match fs.get("model").ok().and_then(|n| n.to_string().ok()) {
        Some(s) if !s.is_empty() => s.parse::<CameraModel>().map_err(|e| not(&e))?,
        _ if distortion.len() == 4 => CameraModel::Fisheye,
        _ => CameraModel::Pinhole,
    };
    if distortion.len() < model.coefficient_count() {
        return Err(not(&format!(
            "{} coefficients for the {} model",
            distortion.len(),
            model.name()
        )));
    }
    let int = |key: &str| -> Result<i32, CalibError> {
        node(key)?
            .to_i32()
            .map_err(|_| not(&format!("`{key}` is not a number")))
    };
    let image_width = int("image_width")?;
    let image_height = int("image_height")?;
    if image_width <= 0 || image_height <= 0 {
        return Err(not("non-positive image size"));
    }
    if !camera_matrix.iter().all(|v| v.is_finite()) || camera_matrix[(0, 0)] <= 0.0 {
        return Err(not("camera matrix is not finite and positive"));
    }
    let avg = fs
        .get("avg_reprojection_error")
        .and_then(|n| n.to_f64())
        .unwrap_or(f64::NAN);
    let names: Vec<String> = match fs.get("views_used") {
        Ok(n) if n.is_seq().unwrap_or(false) => (0..n.size().unwrap_or(0))
            .filter_map(|i| n.at(i as i32).ok().and_then(|e| e.to_string().ok()))
            .collect(),
        _ => vec![],
    };
    let errors: Vec<f64> = match fs.get("per_view_reprojection_errors") {
        Ok(n) if !n.empty().unwrap_or(true) => n
            .mat()
            .and_then(|m| values_from_mat(&m))
            .unwrap_or_default(),
        _ => vec![],
    };
    let per_view_errors = errors
        .iter()
        .enumerate()
        .map(|(i, e)| ViewError {
            name: names.get(i).cloned().unwrap_or_else(|| format!("view {i}")),
            rms_px: *e,
        })
        .collect();
    let mut views_rejected = Vec::new();
    if let Ok(n) = fs.get("views_rejected") {
        if n.is_seq().unwrap_or(false) {
            for i in 0..n.size().unwrap_or(0) {
                if let Ok(e) = n.at(i as i32) {
                    let get = |k: &str| e.get(k).and_then(|v| v.to_string()).unwrap_or_default();
                    views_rejected.push(RejectedView {
                        name: get("name"),
                        reason: get("reason"),
                    });
                }
            }
        }
    }
    let board = match (
        fs.get("board_width").and_then(|n| n.to_i32()),
        fs.get("board_height").and_then(|n| n.to_i32()),
        fs.get("square_size_mm").and_then(|n| n.to_f64()),
    ) {
        (Ok(c), Ok(r), Ok(s)) if c >= 2 && r >= 2 && s > 0.0 => {
            Board::new(c as u32, r as u32, s).ok()
        }
        _ => None,
    };
    Ok(Calibration {
        model,
        image_width: image_width as u32,
        image_height: image_height as u32,
        camera_matrix,
        distortion: distortion[..model.coefficient_count()].to_vec(),
        avg_reprojection_error: avg,
        per_view_errors,
        board,
        views_used: names,
        views_rejected,
    })
}
