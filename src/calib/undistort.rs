//! Undistortion: raw pixel <-> undistorted pixel, full-frame maps and the crop rectangle.
//!
//! The undistorted image is a pinhole view with camera matrix
//! P = [s f, 0, cx; 0, s f, cy; 0, 0, 1], f = (fx + fy) / 2: the calibration's principal
//! point kept, square pixels (so a circle in the actuator plane stays a circle and one
//! mm-per-px holds in both directions), and the focal length scaled by `s`. bendscope chooses `s` itself rather than trusting
//! `cv::fisheye::estimateNewCameraMatrixForUndistortRectify`, which is known to return
//! NaN or absurd focal lengths for some calibrations:
//!
//! - `balance = 0` (default): the smallest zoom at which the raw frame covers the whole
//!   output (its four mid-edge points land on or beyond the output edges): no black
//!   border; the raw corners and, when the principal point is off-centre or the aspect
//!   ratio differs from the lens's, a strip of one side are lost;
//! - `balance = 1`: the whole raw frame fits in the output (black border around it);
//! - in between: `s` interpolated linearly.
//!
//! [`Undistorter::crop_rect`] is the largest axis-aligned rectangle of the output whose
//! pixels all come from inside the raw frame.
//!
//! Two ways to use it: undistort whole frames with [`Undistorter::undistort_image`]
//! (remap with precomputed maps), or, much cheaper, detect in the raw frame and
//! undistort only the detected points with [`Undistorter::undistort_points`].

use nalgebra::{Matrix3, Point2, Vector3};
use opencv::core::{
    Mat, Point2d, Point3d, Rect, Scalar, Size, TermCriteria, TermCriteria_Type, Vector,
    BORDER_CONSTANT, CV_16SC2,
};
use opencv::{calib3d, imgproc};

use super::cv::{mat_from_column, mat_from_matrix3, points_from_vector, vector_from_points};
use super::{CalibError, Calibration, CameraModel};

/// Iteration limit of the iterative point undistortion.
pub const UNDISTORT_MAX_ITER: i32 = 100;
/// Convergence threshold (normalized coordinates) of the point undistortion: far below
/// 1e-6 px for any focal length up to 10^5 px.
pub const UNDISTORT_EPS: f64 = 1e-14;
/// Samples per raw-frame edge used to find the scale and the crop rectangle.
pub const EDGE_SAMPLES: usize = 64;

/// How the undistorted view is framed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UndistortSettings {
    /// 0: no black border (raw corners lost); 1: the whole raw frame visible.
    pub balance: f64,
}

impl Default for UndistortSettings {
    fn default() -> Self {
        Self { balance: 0.0 }
    }
}

/// Maps between raw and undistorted pixels of one calibrated camera.
#[derive(Debug)]
pub struct Undistorter {
    model: CameraModel,
    width: u32,
    height: u32,
    k: Mat,
    d: Mat,
    p: Mat,
    new_camera_matrix: Matrix3<f64>,
    crop: Rect,
}

impl Undistorter {
    /// Prepares undistortion for `calib` (frames of the calibration's size; use
    /// [`Calibration::for_resolution`] first for another size).
    pub fn new(calib: &Calibration, settings: UndistortSettings) -> Result<Self, CalibError> {
        let cv = |e| CalibError::cv("undistortion set-up", e);
        let k = mat_from_matrix3(&calib.camera_matrix).map_err(cv)?;
        let d = mat_from_column(&calib.distortion).map_err(cv)?;
        let identity = Matrix3::<f64>::identity();
        let mut u = Undistorter {
            model: calib.model,
            width: calib.image_width,
            height: calib.image_height,
            k,
            d,
            p: mat_from_matrix3(&identity).map_err(cv)?,
            new_camera_matrix: identity,
            crop: Rect::new(0, 0, calib.image_width as i32, calib.image_height as i32),
        };
        // Normalized coordinates of the raw frame's edges and corners (P = identity).
        let (w, h) = (
            calib.image_width as f64 - 1.0,
            calib.image_height as f64 - 1.0,
        );
        let (cx, cy) = (calib.cx(), calib.cy());
        let f = 0.5 * (calib.fx() + calib.fy());
        let (fx, fy) = (f, f);
        let probe = [
            Point2::new(0.0, cy),
            Point2::new(w, cy),
            Point2::new(cx, 0.0),
            Point2::new(cx, h),
            Point2::new(0.0, 0.0),
            Point2::new(w, 0.0),
            Point2::new(0.0, h),
            Point2::new(w, h),
        ];
        let n = u.undistort_points(&probe)?;
        // Smallest scale that puts every mid-edge point on or beyond its output edge, so
        // the raw frame covers the whole output.
        let inner = [
            cx / (fx * n[0].x.abs()),
            (w - cx) / (fx * n[1].x.abs()),
            cy / (fy * n[2].y.abs()),
            (h - cy) / (fy * n[3].y.abs()),
        ]
        .into_iter()
        .filter(|s| s.is_finite() && *s > 0.0)
        .fold(0.0, f64::max);
        // Scale that keeps every raw corner inside the output.
        let outer = n[4..]
            .iter()
            .map(|q| {
                let sx = if q.x < 0.0 {
                    cx / (fx * -q.x)
                } else {
                    (w - cx) / (fx * q.x)
                };
                let sy = if q.y < 0.0 {
                    cy / (fy * -q.y)
                } else {
                    (h - cy) / (fy * q.y)
                };
                sx.min(sy)
            })
            .filter(|s| s.is_finite() && *s > 0.0)
            .fold(f64::INFINITY, f64::min);
        let b = settings.balance.clamp(0.0, 1.0);
        let s = if outer.is_finite() {
            inner * (1.0 - b) + outer.min(inner) * b
        } else {
            inner
        };
        if !(s.is_finite() && s > 0.0) || inner == 0.0 {
            return Err(CalibError::Diverged {
                what: "no finite undistortion scale: the calibration is degenerate".to_string(),
            });
        }
        let p = Matrix3::new(s * fx, 0.0, cx, 0.0, s * fy, cy, 0.0, 0.0, 1.0);
        u.p = mat_from_matrix3(&p).map_err(cv)?;
        u.new_camera_matrix = p;
        u.crop = u.compute_crop()?;
        Ok(u)
    }

    /// The camera matrix of the undistorted view.
    pub fn new_camera_matrix(&self) -> Matrix3<f64> {
        self.new_camera_matrix
    }

    /// Output (and input) frame size, px.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Largest rectangle of the undistorted frame without black border: (x, y, w, h), px.
    pub fn crop_rect(&self) -> (i32, i32, i32, i32) {
        (self.crop.x, self.crop.y, self.crop.width, self.crop.height)
    }

    /// Raw (distorted) pixels -> undistorted pixels of [`Self::new_camera_matrix`].
    pub fn undistort_points(&self, raw: &[Point2<f64>]) -> Result<Vec<Point2<f64>>, CalibError> {
        if raw.is_empty() {
            return Ok(vec![]);
        }
        let src = vector_from_points(raw);
        let mut dst = Vector::<Point2d>::new();
        let r = Mat::default();
        let criteria = TermCriteria::new(
            TermCriteria_Type::COUNT as i32 + TermCriteria_Type::EPS as i32,
            UNDISTORT_MAX_ITER,
            UNDISTORT_EPS,
        )
        .map_err(|e| CalibError::cv("undistort points", e))?;
        match self.model {
            CameraModel::Fisheye => calib3d::fisheye_undistort_points(
                &src, &mut dst, &self.k, &self.d, &r, &self.p, criteria,
            ),
            CameraModel::Pinhole => calib3d::undistort_points_iter(
                &src, &mut dst, &self.k, &self.d, &r, &self.p, criteria,
            ),
        }
        .map_err(|e| CalibError::cv("undistort points", e))?;
        Ok(points_from_vector(&dst))
    }

    /// Raw pixels -> viewing rays (x, y, 1) in the camera frame (normalized coordinates).
    pub fn rays_from_pixels(&self, raw: &[Point2<f64>]) -> Result<Vec<Vector3<f64>>, CalibError> {
        let p = &self.new_camera_matrix;
        Ok(self
            .undistort_points(raw)?
            .into_iter()
            .map(|q| {
                Vector3::new(
                    (q.x - p[(0, 2)]) / p[(0, 0)],
                    (q.y - p[(1, 2)]) / p[(1, 1)],
                    1.0,
                )
            })
            .collect())
    }

    /// Camera-frame points (mm, z forward) -> raw pixels through the lens model.
    pub fn project(&self, points: &[Vector3<f64>]) -> Result<Vec<Point2<f64>>, CalibError> {
        if points.is_empty() {
            return Ok(vec![]);
        }
        let rays: Vector<Point3d> = points.iter().map(|q| Point3d::new(q.x, q.y, q.z)).collect();
        project_rays(&rays, &self.k, &self.d, self.model)
            .map_err(|e| CalibError::cv("project points", e))
    }

    /// Undistorted pixels -> raw (distorted) pixels: the camera model's forward projection.
    pub fn distort_points(
        &self,
        undistorted: &[Point2<f64>],
    ) -> Result<Vec<Point2<f64>>, CalibError> {
        if undistorted.is_empty() {
            return Ok(vec![]);
        }
        let p = &self.new_camera_matrix;
        let rays: Vector<Point3d> = undistorted
            .iter()
            .map(|q| {
                Point3d::new(
                    (q.x - p[(0, 2)]) / p[(0, 0)],
                    (q.y - p[(1, 2)]) / p[(1, 1)],
                    1.0,
                )
            })
            .collect();
        project_rays(&rays, &self.k, &self.d, self.model)
            .map_err(|e| CalibError::cv("distort points", e))
    }

    /// Maps for `cv::remap` from the raw frame to the undistorted frame (fixed-point
    /// `CV_16SC2` + interpolation table, OpenCV's fastest form).
    pub fn maps(&self) -> Result<(Mat, Mat), CalibError> {
        let mut m1 = Mat::default();
        let mut m2 = Mat::default();
        let size = Size::new(self.width as i32, self.height as i32);
        let r = Mat::default();
        match self.model {
            CameraModel::Fisheye => calib3d::fisheye_init_undistort_rectify_map(
                &self.k, &self.d, &r, &self.p, size, CV_16SC2, &mut m1, &mut m2,
            ),
            CameraModel::Pinhole => calib3d::init_undistort_rectify_map(
                &self.k, &self.d, &r, &self.p, size, CV_16SC2, &mut m1, &mut m2,
            ),
        }
        .map_err(|e| CalibError::cv("undistortion maps", e))?;
        Ok((m1, m2))
    }

    /// Undistorts a whole frame with maps from [`Self::maps`] (bilinear).
    pub fn undistort_image(&self, maps: &(Mat, Mat), raw: &Mat) -> Result<Mat, CalibError> {
        let mut out = Mat::default();
        imgproc::remap(
            raw,
            &mut out,
            &maps.0,
            &maps.1,
            imgproc::INTER_LINEAR,
            BORDER_CONSTANT,
            Scalar::all(0.0),
        )
        .map_err(|e| CalibError::cv("remap", e))?;
        Ok(out)
    }

    /// The raw frame's outline in the undistorted frame, reduced to the largest inner
    /// axis-aligned rectangle.
    fn compute_crop(&self) -> Result<Rect, CalibError> {
        let (w, h) = (self.width as f64 - 1.0, self.height as f64 - 1.0);
        let t = |i: usize| i as f64 / (EDGE_SAMPLES - 1) as f64;
        let edge = |f: &dyn Fn(f64) -> Point2<f64>| -> Vec<Point2<f64>> {
            (0..EDGE_SAMPLES).map(|i| f(t(i))).collect()
        };
        let left = self.undistort_points(&edge(&|s| Point2::new(0.0, s * h)))?;
        let right = self.undistort_points(&edge(&|s| Point2::new(w, s * h)))?;
        let top = self.undistort_points(&edge(&|s| Point2::new(s * w, 0.0)))?;
        let bottom = self.undistort_points(&edge(&|s| Point2::new(s * w, h)))?;
        let x0 = left.iter().map(|p| p.x).fold(0.0, f64::max).ceil();
        let x1 = right.iter().map(|p| p.x).fold(w, f64::min).floor();
        let y0 = top.iter().map(|p| p.y).fold(0.0, f64::max).ceil();
        let y1 = bottom.iter().map(|p| p.y).fold(h, f64::min).floor();
        if !(x1 > x0 && y1 > y0) {
            return Err(CalibError::Diverged {
                what: "empty crop rectangle after undistortion".to_string(),
            });
        }
        Ok(Rect::new(
            x0 as i32,
            y0 as i32,
            (x1 - x0) as i32 + 1,
            (y1 - y0) as i32 + 1,
        ))
    }
}

/// Projects camera-frame rays (x, y, z) through the lens model to raw pixels.
pub(crate) fn project_rays(
    rays: &Vector<Point3d>,
    k: &Mat,
    d: &Mat,
    model: CameraModel,
) -> opencv::Result<Vec<Point2<f64>>> {
    let zero = mat_from_column(&[0.0, 0.0, 0.0])?;
    let mut out = Vector::<Point2d>::new();
    let mut jac = Mat::default();
    match model {
        CameraModel::Fisheye => {
            calib3d::fisheye_project_points_vec(rays, &mut out, &zero, &zero, k, d, 0.0, &mut jac)?
        }
        CameraModel::Pinhole => {
            calib3d::project_points(rays, &zero, &zero, k, d, &mut out, &mut jac, 0.0)?
        }
    }
    Ok(points_from_vector(&out))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::fixtures::gopro_like_camera;
    use proptest::prelude::*;

    fn left_camera() -> Calibration {
        let mut c = gopro_like_camera(640, 480);
        c.model = CameraModel::Pinhole;
        c.camera_matrix = Matrix3::new(535.9, 0.0, 342.3, 0.0, 535.9, 235.6, 0.0, 0.0, 1.0);
        c.distortion = vec![-0.26637, -0.03859, 0.00178, -0.00028, 0.23839];
        c
    }

    #[test]
    fn balance_zero_leaves_no_black_border() {
        let u =
            Undistorter::new(&gopro_like_camera(960, 720), UndistortSettings::default()).unwrap();
        let (x, y, w, h) = u.crop_rect();
        assert!(
            x <= 1 && y <= 1 && w >= 958 && h >= 718,
            "{:?}",
            u.crop_rect()
        );
        // Square pixels, principal point kept.
        let p = u.new_camera_matrix();
        assert_eq!(p[(0, 0)], p[(1, 1)]);
        assert_eq!(p[(0, 2)], 481.3);
    }

    #[test]
    fn balance_one_shows_the_whole_frame_inside_a_border() {
        let cam = gopro_like_camera(960, 720);
        let u = Undistorter::new(&cam, UndistortSettings { balance: 1.0 }).unwrap();
        let corners = [
            Point2::new(0.0, 0.0),
            Point2::new(959.0, 0.0),
            Point2::new(0.0, 719.0),
            Point2::new(959.0, 719.0),
        ];
        for q in u.undistort_points(&corners).unwrap() {
            assert!(
                q.x > -0.5 && q.x < 959.5 && q.y > -0.5 && q.y < 719.5,
                "{q}"
            );
        }
        let (_, _, w, h) = u.crop_rect();
        assert!(
            w < 959 && h < 719,
            "a border remains to crop: {:?}",
            u.crop_rect()
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn fisheye_round_trip_is_exact(x in 0.0f64..959.0, y in 0.0f64..719.0) {
            let u = Undistorter::new(&gopro_like_camera(960, 720), UndistortSettings::default()).unwrap();
            let p = Point2::new(x, y);
            let back = u.undistort_points(&u.distort_points(&[p]).unwrap()).unwrap()[0];
            prop_assert!((back - p).norm() < 1e-6, "{} -> {}", p, back);
            let raw_back = u.distort_points(&u.undistort_points(&[p]).unwrap()).unwrap()[0];
            prop_assert!((raw_back - p).norm() < 1e-6, "{} -> {}", p, raw_back);
        }

        #[test]
        fn pinhole_round_trip_is_exact(x in 0.0f64..639.0, y in 0.0f64..479.0) {
            let u = Undistorter::new(&left_camera(), UndistortSettings::default()).unwrap();
            let p = Point2::new(x, y);
            let back = u.undistort_points(&u.distort_points(&[p]).unwrap()).unwrap()[0];
            prop_assert!((back - p).norm() < 1e-6, "{} -> {}", p, back);
        }
    }
}
