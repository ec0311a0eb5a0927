//! Camera calibration from detected board views (OpenCV).
//!
//! - Fisheye: `cv::fisheye::calibrate` (Kannala-Brandt, 4 coefficients) with
//!   `FIX_SKEW | RECOMPUTE_EXTRINSIC | CHECK_COND`. When OpenCV reports an ill-conditioned
//!   view, that view is dropped, named in the rejected list, and the calibration retried.
//! - Pinhole: `cv::calibrateCamera` (Zhang's method) with 5 Brown coefficients and,
//!   optionally, a fixed aspect ratio.
//!
//! The reported `avg_reprojection_error` is the RMS over all corners of all views used,
//! as in OpenCV's calibration sample; per-view errors are the RMS of each view.

use nalgebra::{Matrix3, Point2, Rotation3, Vector3};
use opencv::calib3d;
use opencv::core::{Mat, Point2f, Point3f, Size, TermCriteria, TermCriteria_Type, Vector};
use opencv::prelude::*;

use super::corners::{common_size, drop_duplicate_views, BoardView, Detections};
use super::coverage::{coverage_grid, half_diagonal_share, Coverage};
use super::cv::{matrix3_from_mat, values_from_mat};
use super::{Board, CalibError, Calibration, CameraModel, RejectedView, ViewError};

/// Fewest views with a board each model accepts.
pub const MIN_VIEWS_FISHEYE: usize = 3;
/// See [`MIN_VIEWS_FISHEYE`].
pub const MIN_VIEWS_PINHOLE: usize = 3;
/// Iteration limit of the calibration optimizer.
pub const MAX_ITERATIONS: i32 = 100;
/// Convergence threshold of the calibration optimizer.
pub const EPSILON: f64 = 1e-10;

/// How to calibrate.
#[derive(Debug, Clone, Copy)]
pub struct CalibrationSettings {
    /// Lens model.
    pub model: CameraModel,
    /// The board shown in the views.
    pub board: Board,
    /// Pinhole only: keep fx/fy at 1 (OpenCV's `CALIB_FIX_ASPECT_RATIO`).
    pub fix_aspect_ratio: bool,
}

/// Calibrates a camera from the views where a board was found. A view that repeats an
/// earlier one (its corners within [`super::corners::DUPLICATE_VIEW_RMS_PX`]) and views
/// OpenCV finds ill-conditioned (fisheye) are dropped and listed; too few usable views is
/// an error.
pub fn calibrate(
    detections: &Detections,
    settings: &CalibrationSettings,
) -> Result<Calibration, CalibError> {
    // One pose shown twice (copies of a photo) counts once.
    let (mut views, duplicates) = drop_duplicate_views(&detections.views);
    let mut rejected: Vec<RejectedView> = detections.rejected.clone();
    rejected.extend(duplicates);
    let needed = match settings.model {
        CameraModel::Fisheye => MIN_VIEWS_FISHEYE,
        CameraModel::Pinhole => MIN_VIEWS_PINHOLE,
    };
    let too_few = |found: usize, rejected: &[RejectedView]| CalibError::TooFewViews {
        found,
        rejected: summarize_rejections(rejected),
        needed,
        board: settings.board.to_string(),
        model: settings.model.name().to_string(),
    };
    if views.len() < needed {
        return Err(too_few(views.len(), &rejected));
    }
    let (width, height) = common_size(&views)?;
    let size = Size::new(width as i32, height as i32);
    let object = settings.board.object_points_mm();
    loop {
        if views.len() < needed {
            return Err(too_few(views.len(), &rejected));
        }
        let object_points: Vector<Vector<Point3f>> = views
            .iter()
            .map(|_| {
                object
                    .iter()
                    .map(|p| Point3f::new(p[0] as f32, p[1] as f32, p[2] as f32))
                    .collect()
            })
            .collect();
        let image_points: Vector<Vector<Point2f>> = views
            .iter()
            .map(|v| {
                v.corners
                    .iter()
                    .map(|p| Point2f::new(p.x as f32, p.y as f32))
                    .collect()
            })
            .collect();
        let attempt = match settings.model {
            CameraModel::Fisheye => run_fisheye(&object_points, &image_points, size),
            CameraModel::Pinhole => run_pinhole(
                &object_points,
                &image_points,
                size,
                settings.fix_aspect_ratio,
            ),
        };
        match attempt {
            Ok(solution) => {
                return finish(solution, &views, rejected, settings, width, height);
            }
            Err(Failure::IllConditioned(index)) if index < views.len() => {
                let v = views.remove(index);
                rejected.push(RejectedView {
                    name: v.name,
                    reason: "ill-conditioned for the fisheye model (board too small, too far or too oblique in this view)".to_string(),
                });
            }
            Err(Failure::IllConditioned(_)) => {
                return Err(CalibError::Diverged {
                    what: "OpenCV reported an ill-conditioned view it did not name".to_string(),
                })
            }
            Err(Failure::Cv(e)) => return Err(CalibError::cv("calibration", e)),
        }
    }
}

/// The first few rejected views and their reasons, for a one-line message.
fn summarize_rejections(rejected: &[RejectedView]) -> String {
    const SHOWN: usize = 4;
    if rejected.is_empty() {
        return String::new();
    }
    let mut parts: Vec<String> = rejected
        .iter()
        .take(SHOWN)
        .map(|r| format!("{}: {}", r.name, r.reason))
        .collect();
    if rejected.len() > SHOWN {
        parts.push(format!("and {} more", rejected.len() - SHOWN));
    }
    format!(" (rejected: {})", parts.join("; "))
}

/// Raw OpenCV result.
struct Solution {
    k: Mat,
    d: Mat,
    rvecs: Vector<Mat>,
    tvecs: Vector<Mat>,
    model: CameraModel,
}

enum Failure {
    /// OpenCV's `CALIB_CHECK_COND` named this view (index into the views passed).
    IllConditioned(usize),
    Cv(opencv::Error),
}

fn criteria() -> opencv::Result<TermCriteria> {
    TermCriteria::new(
        TermCriteria_Type::COUNT as i32 + TermCriteria_Type::EPS as i32,
        MAX_ITERATIONS,
        EPSILON,
    )
}

fn run_fisheye(
    object_points: &Vector<Vector<Point3f>>,
    image_points: &Vector<Vector<Point2f>>,
    size: Size,
) -> Result<Solution, Failure> {
    let mut k = Mat::default();
    let mut d = Mat::default();
    let mut rvecs = Vector::<Mat>::new();
    let mut tvecs = Vector::<Mat>::new();
    let flags = calib3d::Fisheye_CALIB_RECOMPUTE_EXTRINSIC
        | calib3d::Fisheye_CALIB_CHECK_COND
        | calib3d::Fisheye_CALIB_FIX_SKEW;
    let crit = criteria().map_err(Failure::Cv)?;
    match calib3d::calibrate(
        object_points,
        image_points,
        size,
        &mut k,
        &mut d,
        &mut rvecs,
        &mut tvecs,
        flags,
        crit,
    ) {
        Ok(_) => Ok(Solution {
            k,
            d,
            rvecs,
            tvecs,
            model: CameraModel::Fisheye,
        }),
        Err(e) => match ill_conditioned_index(&e.message) {
            Some(i) => Err(Failure::IllConditioned(i)),
            None => Err(Failure::Cv(e)),
        },
    }
}

/// OpenCV's fisheye calibration says "CALIB_CHECK_COND - Ill-conditioned matrix for input
/// array N": the index of the view to drop.
fn ill_conditioned_index(message: &str) -> Option<usize> {
    let at = message.find("Ill-conditioned")?;
    let tail = &message[at..];
    let digits: String = tail
        .chars()
        .skip_while(|c| !c.is_ascii_digit())
        .take_while(|c| c.is_ascii_digit())
        .collect();
    digits.parse().ok()
}

fn run_pinhole(
    object_points: &Vector<Vector<Point3f>>,
    image_points: &Vector<Vector<Point2f>>,
    size: Size,
    fix_aspect_ratio: bool,
) -> Result<Solution, Failure> {
    let mut k = Mat::eye(3, 3, opencv::core::CV_64F)
        .and_then(|m| m.to_mat())
        .map_err(Failure::Cv)?;
    let mut d = Mat::default();
    let mut rvecs = Vector::<Mat>::new();
    let mut tvecs = Vector::<Mat>::new();
    let mut flags = 0;
    if fix_aspect_ratio {
        // The initial K carries the ratio fx/fy = 1 that OpenCV then keeps.
        flags |= calib3d::CALIB_FIX_ASPECT_RATIO;
    }
    let crit = criteria().map_err(Failure::Cv)?;
    calib3d::calibrate_camera(
        object_points,
        image_points,
        size,
        &mut k,
        &mut d,
        &mut rvecs,
        &mut tvecs,
        flags,
        crit,
    )
    .map_err(Failure::Cv)?;
    Ok(Solution {
        k,
        d,
        rvecs,
        tvecs,
        model: CameraModel::Pinhole,
    })
}

/// Per-view reprojection and the final [`Calibration`].
fn finish(
    s: Solution,
    views: &[BoardView],
    rejected: Vec<RejectedView>,
    settings: &CalibrationSettings,
    width: u32,
    height: u32,
) -> Result<Calibration, CalibError> {
    let k: Matrix3<f64> = matrix3_from_mat(&s.k).map_err(|e| CalibError::cv("reading K", e))?;
    let mut d = values_from_mat(&s.d).map_err(|e| CalibError::cv("reading D", e))?;
    d.truncate(s.model.coefficient_count());
    if !k.iter().all(|v| v.is_finite()) || !d.iter().all(|v| v.is_finite()) || k[(0, 0)] <= 0.0 {
        return Err(CalibError::Diverged {
            what: "non-finite or negative camera parameters".to_string(),
        });
    }
    let object: Vector<Point3f> = settings
        .board
        .object_points_mm()
        .iter()
        .map(|p| Point3f::new(p[0] as f32, p[1] as f32, p[2] as f32))
        .collect();
    let board_mm = settings.board.object_points_mm();
    let mut per_view = Vec::with_capacity(views.len());
    let mut total_sq = 0.0;
    let mut total_n = 0usize;
    let mut field_angle_deg = 0.0f64;
    for (i, v) in views.iter().enumerate() {
        let rvec = s.rvecs.get(i).map_err(|e| CalibError::cv("view pose", e))?;
        let tvec = s.tvecs.get(i).map_err(|e| CalibError::cv("view pose", e))?;
        field_angle_deg = field_angle_deg.max(
            largest_field_angle_deg(&board_mm, &rvec, &tvec)
                .map_err(|e| CalibError::cv("view pose", e))?,
        );
        let projected = project(&object, &rvec, &tvec, &s.k, &s.d, s.model)
            .map_err(|e| CalibError::cv("reprojection", e))?;
        let sq: f64 = projected
            .iter()
            .zip(&v.corners)
            .map(|(p, q)| (p - q).norm_squared())
            .sum();
        total_sq += sq;
        total_n += v.corners.len();
        per_view.push(ViewError {
            name: v.name.clone(),
            rms_px: (sq / v.corners.len() as f64).sqrt(),
        });
    }
    if !(field_angle_deg.is_finite() && field_angle_deg > 0.0) {
        return Err(CalibError::Diverged {
            what: "board poses with no finite field angle".to_string(),
        });
    }
    let corners: Vec<&[Point2<f64>]> = views.iter().map(|v| v.corners.as_slice()).collect();
    let coverage = Coverage {
        field_angle_deg,
        half_diagonal_share: Some(half_diagonal_share(&corners, width, height)),
        grid: Some(coverage_grid(&corners, &settings.board, width, height)),
    };
    Ok(Calibration {
        model: s.model,
        image_width: width,
        image_height: height,
        camera_matrix: k,
        distortion: d,
        avg_reprojection_error: (total_sq / total_n.max(1) as f64).sqrt(),
        per_view_errors: per_view,
        board: Some(settings.board),
        views_used: views.iter().map(|v| v.name.clone()).collect(),
        views_rejected: rejected,
        coverage: Some(coverage),
    })
}

/// The largest field angle (degrees from the optical axis) of the board's corners at the
/// calibrated pose: corner X_c = R(rvec) X + t (Rodrigues' rotation of the axis-angle
/// vector), angle atan2(|(x, y)|, z).
fn largest_field_angle_deg(board_mm: &[[f64; 3]], rvec: &Mat, tvec: &Mat) -> opencv::Result<f64> {
    let r = values_from_mat(rvec)?;
    let t = values_from_mat(tvec)?;
    if r.len() != 3 || t.len() != 3 {
        return Err(opencv::Error::new(
            opencv::core::StsBadSize,
            format!("pose vectors of {} and {} values", r.len(), t.len()),
        ));
    }
    let rotation = Rotation3::from_scaled_axis(Vector3::new(r[0], r[1], r[2]));
    let t = Vector3::new(t[0], t[1], t[2]);
    Ok(board_mm
        .iter()
        .map(|p| {
            let c = rotation * Vector3::new(p[0], p[1], p[2]) + t;
            c.x.hypot(c.y).atan2(c.z).to_degrees()
        })
        .fold(0.0, f64::max))
}

/// Projects board points through a posed camera.
fn project(
    object: &Vector<Point3f>,
    rvec: &Mat,
    tvec: &Mat,
    k: &Mat,
    d: &Mat,
    model: CameraModel,
) -> opencv::Result<Vec<Point2<f64>>> {
    let mut out = Vector::<Point2f>::new();
    match model {
        CameraModel::Fisheye => {
            let mut jac = Mat::default();
            calib3d::fisheye_project_points_vec(object, &mut out, rvec, tvec, k, d, 0.0, &mut jac)?
        }
        CameraModel::Pinhole => {
            let mut jac = Mat::default();
            calib3d::project_points(object, rvec, tvec, k, d, &mut out, &mut jac, 0.0)?
        }
    }
    Ok(out
        .iter()
        .map(|p| Point2::new(p.x as f64, p.y as f64))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_ill_conditioned_view_index() {
        let msg = "OpenCV(4.6.0) /build/calib3d/src/fisheye.cpp:1404: error: (-215:Assertion failed) fabs(norm_u1(0)) > 0 ... CALIB_CHECK_COND - Ill-conditioned matrix for input array 7 in function 'CalibrateExtrinsics'";
        assert_eq!(ill_conditioned_index(msg), Some(7));
        assert_eq!(ill_conditioned_index("something else 3"), None);
    }
}
