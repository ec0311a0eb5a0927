//! Scale: millimetres per undistorted pixel in the actuator plane.
//!
//! From a checkerboard lying in the actuator plane: its corners are found in the raw photo,
//! undistorted into the same undistorted pixel space the markers are measured in
//! ([`crate::calib::Undistorter`]), and the mean corner spacing along every row and column
//! (first to last corner, the longest baselines) gives mm per px. The spread between rows
//! and columns tells whether the board was parallel to the image plane.
//!
//! Every corner must lie inside the calibration's valid field
//! ([`crate::calib::field`]): outside, the lens model is extrapolated and the scale would
//! be wrong by an unknown amount, so a corner outside is an error naming how many and
//! where the field ends, not a silent skip (the scale is one number for the whole
//! session; it should come from corners the calibration vouches for).
//!
//! The board also gives the plane's homography (undistorted px -> mm in the plane,
//! `cv::findHomography` over every corner, [`Scale::plane_from_px`]): markers are mapped
//! through it and the circle is fitted in millimetres, so a camera a few degrees off
//! perpendicular to the actuator plane does not bias the radius. Measured on pictures
//! drawn by an independent generator (tests/independent.rs): with the plane tilted 2 and
//! 1.5 degrees at 300 mm, the scalar mm/px was off by up to 0.6% on radius; through the
//! homography the tilted and the perpendicular plane agree (see the README's robustness
//! table).
//!
//! A board parallel to the actuator plane but a few mm in front of it or behind it
//! ([`scale_from_offset_board_photo`]): the board's pose from its homography and the
//! undistorted view's camera matrix gives its plane's distance d, and the scale and
//! homography are carried to the parallel plane at d + offset ([`parallel_plane`]).
//!
//! A scale saved with `bendscope scale --save` ([`read_scale_file`]) can be given to
//! `process` (`scale = "FILE"` in bendscope.toml): its mm/px and homography are used as
//! they are, so it must have been measured with the calibration `process` uses.
//!
//! Or, the published manual method: a field of view of `fov_mm` across the frame width,
//! radius_mm = radius_px x fov_mm / frame_width_px.

use std::path::{Path, PathBuf};

use nalgebra::Point2;
use serde::{Deserialize, Serialize};

use crate::calib::corners::{find_corners, read_gray, DEFAULT_MAX_DETECT_PX};
use crate::calib::{Board, CalibError, Calibration, UndistortSettings, Undistorter};

/// Spread (relative standard deviation of the row/column spacings) above which the scale
/// board is reported as probably tilted.
pub const TILT_WARNING_SPREAD: f64 = 0.01;

/// Errors of the scale measurement.
#[derive(Debug, thiserror::Error)]
pub enum ScaleError {
    /// Calibration or image problem.
    #[error(transparent)]
    Calib(#[from] CalibError),
    /// No board in the scale photo.
    #[error("{path}: no {board} board found: check --board (inner corners, columns x rows) and that the whole board is in the photo")]
    NoBoard {
        /// The photo.
        path: PathBuf,
        /// The board looked for.
        board: String,
    },
    /// Board corners outside the calibration's valid field.
    #[error("{path}: {outside} of {total} board corners lie outside the calibrated field (beyond {field_deg:.1}° from the optical axis, where the calibration photos' board never reached): put the scale board nearer the centre of the frame, or calibrate again with photos that also hold the board where the scale board lies")]
    OutsideField {
        /// The photo.
        path: PathBuf,
        /// Corners outside the field.
        outside: usize,
        /// Corners found.
        total: usize,
        /// The valid field angle, degrees.
        field_deg: f64,
    },
    /// A saved scale file that cannot be used.
    #[error("{path}: {why}: make it with `bendscope scale IMAGE --calibration FILE --board COLSxROWS --square-mm MM --save FILE`")]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        why: String,
    },
    /// A board plane offset that would put the marker plane at or behind the camera.
    #[error("{path}: offset_mm = {offset_mm} but the board lies {distance_mm:.1} mm from the camera: the offset must be smaller than that distance (it is the few mm between the board's plane and the marker plane; + when the board is in front)")]
    Offset {
        /// The photo.
        path: PathBuf,
        /// The offset given, mm.
        offset_mm: f64,
        /// The board plane's distance from the camera, mm.
        distance_mm: f64,
    },
    /// A nonsense number.
    #[error("{what} must be a positive finite number, got {value}")]
    NotPositive {
        /// Which quantity.
        what: &'static str,
        /// The value given.
        value: f64,
    },
}

/// How the scale was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ScaleMethod {
    /// A checkerboard in the actuator plane.
    Board,
    /// A field of view in mm across the frame width.
    FieldOfView,
}

/// Millimetres per undistorted pixel, with its provenance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scale {
    /// mm per undistorted px.
    pub mm_per_px: f64,
    /// How it was measured.
    pub method: ScaleMethod,
    /// Relative standard deviation of the row/column spacings (board method), else 0.
    pub spread: f64,
    /// Frame width the scale applies to, px.
    pub image_width: u32,
    /// Frame height the scale applies to, px.
    pub image_height: u32,
    /// Set when the calibration was made at another size of the same aspect ratio and
    /// its camera matrix was scaled to this photo: the calibration's (width, height).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration_rescaled_from: Option<(u32, u32)>,
    /// Homography from undistorted px (of this photo's size) to mm in the actuator plane,
    /// row-major (board method); `None` for a field of view.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plane_from_px: Option<[f64; 9]>,
    /// The board it was measured from (board method); `None` for a field of view and in
    /// files saved before the board was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub board: Option<ScaleBoard>,
    /// Distance of the board's plane from the camera along its normal, mm, from the
    /// board's pose (board method).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub board_distance_mm: Option<f64>,
    /// How far the board's plane lay in front of the marker plane (negative: behind), mm:
    /// `mm_per_px` and `plane_from_px` are the marker plane's, carried there from the
    /// board's plane.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub offset_mm: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// The board a scale was measured from. mm/px is proportional to `square_mm`, so whether
/// it was given or defaulted is kept: a defaulted square size is a likely error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ScaleBoard {
    /// Inner corners along a row.
    pub cols: u32,
    /// Inner corners along a column.
    pub rows: u32,
    /// Side of one square, mm.
    pub square_mm: f64,
    /// False when `square_mm` is a default nobody gave.
    pub square_mm_given: bool,
}

impl Scale {
    /// True when the board looked tilted (see [`TILT_WARNING_SPREAD`]).
    pub fn looks_tilted(&self) -> bool {
        self.spread > TILT_WARNING_SPREAD
    }
}

/// mm per px from a field of view across the frame width (the published manual method).
pub fn scale_from_fov(fov_mm: f64, width_px: u32, height_px: u32) -> Result<Scale, ScaleError> {
    if !(fov_mm.is_finite() && fov_mm > 0.0) {
        return Err(ScaleError::NotPositive {
            what: "field of view (mm)",
            value: fov_mm,
        });
    }
    if width_px == 0 {
        return Err(ScaleError::NotPositive {
            what: "frame width (px)",
            value: 0.0,
        });
    }
    Ok(Scale {
        mm_per_px: fov_mm / width_px as f64,
        method: ScaleMethod::FieldOfView,
        spread: 0.0,
        image_width: width_px,
        image_height: height_px,
        calibration_rescaled_from: None,
        plane_from_px: None,
        board: None,
        board_distance_mm: None,
        offset_mm: 0.0,
    })
}

/// Reads a scale saved by `bendscope scale --save` (JSON of [`Scale`]); the error says
/// what is wrong and how to make one.
pub fn read_scale_file(path: &Path) -> Result<Scale, ScaleError> {
    let bad = |why: String| ScaleError::File {
        path: path.to_path_buf(),
        why,
    };
    let text = std::fs::read_to_string(path).map_err(|e| {
        bad(match e.kind() {
            std::io::ErrorKind::NotFound => "no such file".into(),
            _ => e.to_string(),
        })
    })?;
    let s: Scale =
        serde_json::from_str(&text).map_err(|e| bad(format!("not a scale file: {e}")))?;
    if !(s.mm_per_px.is_finite() && s.mm_per_px > 0.0) {
        return Err(bad(format!(
            "mm_per_px = {}: not a positive number",
            s.mm_per_px
        )));
    }
    if s.image_width == 0 {
        return Err(bad("image_width = 0: not a frame width".into()));
    }
    if let Some(h) = &s.plane_from_px {
        if !h.iter().all(|v| v.is_finite()) {
            return Err(bad("plane_from_px holds a value that is not finite".into()));
        }
    }
    Ok(s)
}

/// mm per undistorted px from corners of `board` already undistorted (row-major).
pub fn scale_from_corners(
    undistorted: &[Point2<f64>],
    board: &Board,
) -> Result<(f64, f64), ScaleError> {
    let (cols, rows) = (board.cols as usize, board.rows as usize);
    if undistorted.len() != cols * rows {
        return Err(ScaleError::NotPositive {
            what: "corner count",
            value: undistorted.len() as f64,
        });
    }
    let mut spacings = Vec::with_capacity(cols + rows);
    for r in 0..rows {
        let d = (undistorted[r * cols + cols - 1] - undistorted[r * cols]).norm();
        spacings.push(d / (cols - 1) as f64);
    }
    for c in 0..cols {
        let d = (undistorted[(rows - 1) * cols + c] - undistorted[c]).norm();
        spacings.push(d / (rows - 1) as f64);
    }
    let n = spacings.len() as f64;
    let mean = spacings.iter().sum::<f64>() / n;
    let sd = (spacings.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / n).sqrt();
    if !(mean.is_finite() && mean > 0.0) {
        return Err(ScaleError::NotPositive {
            what: "corner spacing (px)",
            value: mean,
        });
    }
    Ok((board.square_mm / mean, sd / mean))
}

/// mm per undistorted px from a photo of `board` lying in the actuator plane; every
/// corner must lie inside the calibration's valid field ([`ScaleError::OutsideField`]).
pub fn scale_from_board_photo(
    path: &Path,
    calib: &Calibration,
    board: &Board,
    undistort: UndistortSettings,
) -> Result<Scale, ScaleError> {
    scale_from_offset_board_photo(path, calib, board, undistort, 0.0)
}

/// [`scale_from_board_photo`] for a board whose plane lies `offset_mm` in front of the
/// marker plane (negative: behind), parallel to it: the scale and homography are carried
/// to the marker plane through the board's pose ([`parallel_plane`]). An offset not
/// smaller than the board's distance from the camera is [`ScaleError::Offset`].
pub fn scale_from_offset_board_photo(
    path: &Path,
    calib: &Calibration,
    board: &Board,
    undistort: UndistortSettings,
    offset_mm: f64,
) -> Result<Scale, ScaleError> {
    if !offset_mm.is_finite() {
        return Err(ScaleError::NotPositive {
            what: "finite board plane offset (mm)",
            value: offset_mm,
        });
    }
    let gray = read_gray(path)?;
    let (w, h) = (
        opencv::prelude::MatTraitConst::cols(&gray) as u32,
        opencv::prelude::MatTraitConst::rows(&gray) as u32,
    );
    let rescaled = calib
        .needs_scaling(w, h)
        .then_some((calib.image_width, calib.image_height));
    let calib = calib.for_resolution(w, h)?;
    let und = Undistorter::new(&calib, undistort)?;
    let corners = find_corners(&gray, board, DEFAULT_MAX_DETECT_PX)
        .map_err(|e| CalibError::cv("corner search", e))?
        .ok_or_else(|| ScaleError::NoBoard {
            path: path.to_path_buf(),
            board: board.to_string(),
        })?;
    let outside = corners.iter().filter(|c| !und.in_valid_field(**c)).count();
    if outside > 0 {
        return Err(ScaleError::OutsideField {
            path: path.to_path_buf(),
            outside,
            total: corners.len(),
            field_deg: und.valid_field().valid_angle_deg(),
        });
    }
    let flat = und.undistort_points(&corners)?;
    let (board_mm_per_px, spread) = scale_from_corners(&flat, board)?;
    let board_plane = plane_homography(&flat, board)?;
    let pose = parallel_plane(&board_plane, &und.new_camera_matrix(), offset_mm);
    let (mm_per_px, plane_from_px, board_distance_mm) = match pose {
        // In the marker plane: the board's own scale and homography, as measured.
        _ if offset_mm == 0.0 => (board_mm_per_px, Some(board_plane), pose.map(|p| p.0)),
        Some((d, h)) if offset_mm.abs() < d => {
            (board_mm_per_px * (d + offset_mm) / d, Some(h), Some(d))
        }
        Some((d, _)) => {
            return Err(ScaleError::Offset {
                path: path.to_path_buf(),
                offset_mm,
                distance_mm: d,
            })
        }
        None => {
            return Err(ScaleError::NotPositive {
                what: "board distance from its pose (mm)",
                value: f64::NAN,
            })
        }
    };
    Ok(Scale {
        mm_per_px,
        method: ScaleMethod::Board,
        spread,
        image_width: w,
        image_height: h,
        calibration_rescaled_from: rescaled,
        plane_from_px,
        board: Some(ScaleBoard {
            cols: board.cols,
            rows: board.rows,
            square_mm: board.square_mm,
            square_mm_given: true,
        }),
        board_distance_mm,
        offset_mm,
    })
}

/// The pose of the plane a board homography `plane_from_px` (undistorted px -> board
/// mm, row-major) sees through the undistorted view's camera matrix `k`: the plane's
/// distance from the camera along its normal, and the homography of the parallel plane
/// `offset_mm` farther from the camera, in the board's axes moved along the normal
/// (both planes' mm agree up to that move). With G = H^-1 = s K [r1 r2 t], the plane
/// moved by o along its normal n is s K [r1 r2 t + o n]. `None` when the homography
/// is degenerate.
pub fn parallel_plane(
    plane_from_px: &[f64; 9],
    k: &nalgebra::Matrix3<f64>,
    offset_mm: f64,
) -> Option<(f64, [f64; 9])> {
    use nalgebra::{Matrix3, Vector3};
    let h = Matrix3::from_row_slice(plane_from_px);
    let m = k.try_inverse()? * h.try_inverse()?;
    let (m1, m2, m3): (Vector3<f64>, Vector3<f64>, Vector3<f64>) =
        (m.column(0).into(), m.column(1).into(), m.column(2).into());
    // The scale s, its sign putting the board's origin in front of the camera.
    let s = 0.5 * (m1.norm() + m2.norm()) * m3.z.signum();
    let (r1, r2, t) = (m1 / s, m2 / s, m3 / s);
    let mut n = r1.cross(&r2).try_normalize(1e-12)?;
    if n.dot(&t) < 0.0 {
        n = -n;
    }
    let d = n.dot(&t);
    if !(d.is_finite() && d > 0.0) {
        return None;
    }
    let moved = Matrix3::from_columns(&[m1, m2, m3 + n * (s * offset_mm)]);
    let out = (k * moved).try_inverse()?;
    let out = out / out[(2, 2)];
    let flat: [f64; 9] = std::array::from_fn(|i| out[(i / 3, i % 3)]);
    flat.iter().all(|v| v.is_finite()).then_some((d, flat))
}

/// Homography from undistorted px to board mm (row-major) from the corners of `board`
/// (row-major, undistorted): least squares over every corner (`cv::findHomography`,
/// method 0, normalized DLT refined by Levenberg-Marquardt).
pub fn plane_homography(
    undistorted: &[Point2<f64>],
    board: &Board,
) -> Result<[f64; 9], ScaleError> {
    use opencv::core::{Mat, Point2d, Vector};
    use opencv::prelude::*;
    let cols = board.cols as usize;
    let src: Vector<Point2d> = undistorted.iter().map(|p| Point2d::new(p.x, p.y)).collect();
    let dst: Vector<Point2d> = (0..undistorted.len())
        .map(|i| {
            Point2d::new(
                (i % cols) as f64 * board.square_mm,
                (i / cols) as f64 * board.square_mm,
            )
        })
        .collect();
    let mut mask = Mat::default();
    let hm = opencv::calib3d::find_homography(&src, &dst, &mut mask, 0, 3.0)
        .map_err(|e| CalibError::cv("findHomography", e))?;
    let mut out = [0.0; 9];
    for (i, v) in out.iter_mut().enumerate() {
        *v = *hm
            .at_2d::<f64>((i / 3) as i32, (i % 3) as i32)
            .map_err(|e| CalibError::cv("findHomography", e))?;
    }
    if !out.iter().all(|v| v.is_finite()) || out.iter().all(|v| *v == 0.0) {
        return Err(ScaleError::NotPositive {
            what: "board homography",
            value: f64::NAN,
        });
    }
    Ok(out)
}

/// A homography (row-major) applied to a point.
pub fn apply_homography(h: &[f64; 9], p: Point2<f64>) -> Point2<f64> {
    let w = h[6] * p.x + h[7] * p.y + h[8];
    Point2::new(
        (h[0] * p.x + h[1] * p.y + h[2]) / w,
        (h[3] * p.x + h[4] * p.y + h[5]) / w,
    )
}

/// `h` (defined on undistorted px of a `from_width`-wide frame) for a frame `to_width`
/// wide of the same aspect ratio (pixel centres at integers: x' + 0.5 = (x + 0.5) k).
pub fn homography_for_width(h: &[f64; 9], from_width: u32, to_width: u32) -> [f64; 9] {
    let k = from_width as f64 / to_width.max(1) as f64;
    let o = 0.5 * k - 0.5;
    // h * [[k, 0, o], [0, k, o], [0, 0, 1]]
    let mut out = [0.0; 9];
    for r in 0..3 {
        out[3 * r] = h[3 * r] * k;
        out[3 * r + 1] = h[3 * r + 1] * k;
        out[3 * r + 2] = h[3 * r] * o + h[3 * r + 1] * o + h[3 * r + 2];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fov_formula() {
        let s = scale_from_fov(300.0, 1920, 1080).unwrap();
        assert!((s.mm_per_px - 0.15625).abs() < 1e-12);
        assert!(scale_from_fov(-1.0, 1920, 1080).is_err());
        assert!(scale_from_fov(f64::NAN, 1920, 1080).is_err());
    }

    #[test]
    fn spacing_of_an_exact_grid() {
        let b = Board::new(4, 3, 25.0).unwrap();
        let pts: Vec<_> = (0..3)
            .flat_map(|r| {
                (0..4).map(move |c| Point2::new(10.0 + 50.0 * c as f64, 7.0 + 50.0 * r as f64))
            })
            .collect();
        let (mm, spread) = scale_from_corners(&pts, &b).unwrap();
        assert!((mm - 0.5).abs() < 1e-12);
        assert!(spread < 1e-12);
    }

    #[test]
    fn a_parallel_plane_is_found_through_the_board_pose() {
        use nalgebra::{Matrix3, Rotation3, Vector3};
        let k = Matrix3::new(800.0, 0.0, 320.5, 0.0, 810.0, 240.2, 0.0, 0.0, 1.0);
        // A board tilted a few degrees, its origin 150 mm away.
        let r = Rotation3::from_euler_angles(0.05, -0.08, 0.3);
        let t = Vector3::new(-30.0, -20.0, 150.0);
        let n = r * Vector3::z();
        let d = n.dot(&t);
        let project = |p: Vector3<f64>| {
            let q = k * p;
            Point2::new(q.x / q.z, q.y / q.z)
        };
        let g = k * Matrix3::from_columns(&[r * Vector3::x(), r * Vector3::y(), t]);
        let h = g.try_inverse().unwrap() * 3.7;
        let h: [f64; 9] = std::array::from_fn(|i| h[(i / 3, i % 3)]);
        for offset in [0.0, 3.0, -3.0, 40.0] {
            let (dist, moved) = parallel_plane(&h, &k, offset).unwrap();
            assert!((dist - d).abs() < 1e-9 * d, "{dist} vs {d}");
            // Points of the parallel plane come back to their plane mm.
            for (u, v) in [(0.0, 0.0), (50.0, 10.0), (-20.0, 35.0)] {
                let x = r * Vector3::new(u, v, 0.0) + t + n * offset;
                let mm = apply_homography(&moved, project(x));
                assert!(
                    (mm.x - u).abs() < 1e-8 && (mm.y - v).abs() < 1e-8,
                    "{offset}: {mm}"
                );
            }
        }
    }

    #[test]
    fn homography_of_a_tilted_board_maps_corners_to_mm() {
        let b = Board::new(9, 6, 10.0).unwrap();
        // A board seen in perspective: x' = (a x + c) / (g x + 1), a known homography.
        let truth = [2.1, 0.05, 300.0, -0.03, 2.05, 200.0, 1.2e-4, -0.8e-4, 1.0];
        let inv = nalgebra::Matrix3::from_row_slice(&truth)
            .try_inverse()
            .unwrap();
        let inv: [f64; 9] = std::array::from_fn(|i| inv[(i / 3, i % 3)]);
        let px: Vec<Point2<f64>> = (0..54)
            .map(|i| {
                apply_homography(
                    &inv,
                    Point2::new((i % 9) as f64 * 10.0, (i / 9) as f64 * 10.0),
                )
            })
            .collect();
        let h = plane_homography(&px, &b).unwrap();
        for (i, p) in px.iter().enumerate() {
            let mm = apply_homography(&h, *p);
            assert!((mm.x - (i % 9) as f64 * 10.0).abs() < 1e-4, "{mm}");
            assert!((mm.y - (i / 9) as f64 * 10.0).abs() < 1e-4, "{mm}");
        }
        // The same plane seen in a frame half as wide.
        let half = homography_for_width(&h, 1920, 960);
        let p = px[20];
        let q = Point2::new((p.x + 0.5) / 2.0 - 0.5, (p.y + 0.5) / 2.0 - 0.5);
        let (a, c) = (apply_homography(&h, p), apply_homography(&half, q));
        assert!((a - c).norm() < 1e-9, "{a} {c}");
    }
}
