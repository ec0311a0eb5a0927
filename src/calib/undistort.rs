//! Undistortion: raw pixel <-> undistorted pixel, full-frame maps and the crop rectangle,
//! all inside the calibration's valid field ([`super::field`]).
//!
//! The undistorted image is a pinhole view with camera matrix
//! P = [s f, 0, cx; 0, s f, cy; 0, 0, 1], f = (fx + fy) / 2: the calibration's principal
//! point kept, square pixels (so a circle in the actuator plane stays a circle and one
//! mm-per-px holds in both directions), and the focal length scaled by `s`. bendscope
//! chooses `s` itself rather than trusting
//! `cv::fisheye::estimateNewCameraMatrixForUndistortRectify`, which is known to return
//! NaN or absurd focal lengths for some calibrations. The "valid part of the raw frame"
//! below is the raw frame inside the valid field (a disc of radius tan(theta_valid) around
//! the principal point in undistorted normalized coordinates):
//!
//! - `balance = 0` (default): the smallest zoom at which the valid part of the raw frame
//!   covers the whole output (its mid-edge points inside the field land on or beyond the
//!   output edges, and the output corners lie inside the field): no black border and no
//!   pixel from outside the field; the raw corners and, when the principal point is
//!   off-centre or the aspect ratio differs from the lens's, a strip of one side are lost;
//! - `balance = 1`: the whole valid part of the raw frame fits in the output (black border
//!   around it);
//! - in between: `s` interpolated linearly.
//!
//! Without a field limit inside the frame this is the framing bendscope always used. The
//! model is never evaluated beyond the field: framing undistorts only raw points inside
//! it, [`Undistorter::crop_rect`] is the largest axis-aligned rectangle of output pixels
//! that lie inside the field and come from inside the raw frame, and the maps of
//! [`Undistorter::maps`] leave pixels outside the field black.
//!
//! Two ways to use it: undistort whole frames with [`Undistorter::undistort_image`]
//! (remap with precomputed maps), or, much cheaper, detect in the raw frame and
//! undistort only the detected points with [`Undistorter::undistort_points`] after
//! checking them with [`Undistorter::in_valid_field`].

use nalgebra::{Matrix3, Point2, Vector3};
use opencv::core::{
    Mat, Point2d, Point3d, Rect, Scalar, Size, TermCriteria, TermCriteria_Type, Vec2s, Vector,
    BORDER_CONSTANT, CV_16SC2,
};
use opencv::prelude::*;
use opencv::{calib3d, imgproc};

use super::cv::{mat_from_column, mat_from_matrix3, points_from_vector, vector_from_points};
use super::field::{distort_normalized, fisheye_theta_d, ValidField};
use super::{CalibError, Calibration, CameraModel};

mod crop;

/// Iteration limit of the iterative point undistortion.
pub const UNDISTORT_MAX_ITER: i32 = 100;
/// Convergence threshold of the point undistortion: OpenCV's pinhole iteration stops when
/// the point's reprojection error is below it in pixels, its fisheye Newton iteration when
/// the step in the incidence angle is (radians, the error then its square). A pinhole
/// threshold near round-off is never met and spends all [`UNDISTORT_MAX_ITER`] iterations.
pub const UNDISTORT_EPS: f64 = 1e-9;
/// Samples per raw-frame edge used to find the scale.
pub const EDGE_SAMPLES: usize = 64;
/// Tolerance, px, with which an output pixel's raw position may sit outside the raw
/// frame and still count as inside (rounding of the forward projection at the edge the
/// framing puts exactly on an output edge).
pub const RAW_EDGE_TOLERANCE_PX: f64 = 1e-6;
/// Relative tolerance on the squared field radius with which an output pixel counts as
/// inside the field (rounding of the framing that puts output corners exactly on it).
pub const FIELD_EDGE_TOLERANCE: f64 = 1e-12;
/// Largest disagreement, px, between a raw point and the forward projection of its
/// undistorted point for the pinhole model's field test: iterative undistortion that did
/// not converge (beyond the model's turning point) misses by far more.
pub const ROUND_TRIP_TOLERANCE_PX: f64 = 1e-3;
/// Map value given to output pixels outside the valid field: far enough outside the raw
/// frame that bilinear remap reads only the border (black).
const OUTSIDE_MAP_VALUE: i16 = -16;

/// How the undistorted view is framed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UndistortSettings {
    /// 0: no black border (raw corners lost); 1: the whole valid raw frame visible.
    pub balance: f64,
}

impl Default for UndistortSettings {
    fn default() -> Self {
        Self { balance: 0.0 }
    }
}

/// Maps between raw and undistorted pixels of one calibrated camera, inside its valid
/// field.
#[derive(Debug)]
pub struct Undistorter {
    model: CameraModel,
    width: u32,
    height: u32,
    k: Mat,
    d: Mat,
    p: Mat,
    camera_matrix: Matrix3<f64>,
    distortion: Vec<f64>,
    field: ValidField,
    /// Fisheye: theta_d at the valid field angle, the largest distorted normalized radius
    /// inside the field.
    distorted_radius_limit: f64,
    new_camera_matrix: Matrix3<f64>,
    crop: Rect,
}

impl Undistorter {
    /// Prepares undistortion for `calib` (frames of the calibration's size; use
    /// [`Calibration::for_resolution`] first for another size), framed by `settings`
    /// inside the calibration's valid field ([`Calibration::valid_field`]).
    pub fn new(calib: &Calibration, settings: UndistortSettings) -> Result<Self, CalibError> {
        let cv = |e| CalibError::cv("undistortion set-up", e);
        let k = mat_from_matrix3(&calib.camera_matrix).map_err(cv)?;
        let d = mat_from_column(&calib.distortion).map_err(cv)?;
        let identity = Matrix3::<f64>::identity();
        let field = calib.valid_field();
        let distorted_radius_limit = match calib.model {
            CameraModel::Fisheye => {
                fisheye_theta_d(field.valid_angle_deg().to_radians(), &calib.distortion)
            }
            CameraModel::Pinhole => f64::INFINITY,
        };
        let mut u = Undistorter {
            model: calib.model,
            width: calib.image_width,
            height: calib.image_height,
            k,
            d,
            p: mat_from_matrix3(&identity).map_err(cv)?,
            camera_matrix: calib.camera_matrix,
            distortion: calib.distortion.clone(),
            field,
            distorted_radius_limit,
            new_camera_matrix: identity,
            crop: Rect::new(0, 0, calib.image_width as i32, calib.image_height as i32),
        };
        let (w, h) = (
            calib.image_width as f64 - 1.0,
            calib.image_height as f64 - 1.0,
        );
        let (cx, cy) = (calib.cx(), calib.cy());
        let f = 0.5 * (calib.fx() + calib.fy());
        let rho = field.undistorted_radius_limit();
        // Normalized coordinates (P = identity) of the raw mid-edge points inside the field.
        let mid_edges = [
            Point2::new(0.0, cy),
            Point2::new(w, cy),
            Point2::new(cx, 0.0),
            Point2::new(cx, h),
        ];
        let n = u.undistort_inside(&mid_edges)?;
        // Smallest scale that puts every mid-edge point inside the field on or beyond its
        // output edge, so the raw frame covers the whole output...
        let room = [cx, w - cx, cy, h - cy];
        let along = |i: usize, q: Point2<f64>| if i < 2 { q.x.abs() } else { q.y.abs() };
        let edges = n
            .iter()
            .enumerate()
            .filter_map(|(i, q)| q.map(|q| room[i] / (f * along(i, q))))
            .filter(|s| s.is_finite() && *s > 0.0)
            .fold(0.0, f64::max);
        // ... and the output corners inside the field.
        let corner_px = [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
            .iter()
            .map(|&(x, y): &(f64, f64)| (x - cx).hypot(y - cy))
            .fold(0.0, f64::max);
        let disc = if rho.is_finite() {
            corner_px / (f * rho)
        } else {
            0.0
        };
        let inner = edges.max(disc);
        let outer = u.outer_scale(f, rho)?;
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
        let p = Matrix3::new(s * f, 0.0, cx, 0.0, s * f, cy, 0.0, 0.0, 1.0);
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

    /// Largest rectangle of the undistorted frame whose pixels all lie inside the valid
    /// field and come from inside the raw frame: (x, y, w, h), px.
    pub fn crop_rect(&self) -> (i32, i32, i32, i32) {
        (self.crop.x, self.crop.y, self.crop.width, self.crop.height)
    }

    /// The calibration's valid field this undistorter works in.
    pub fn valid_field(&self) -> &ValidField {
        &self.field
    }

    /// True when the raw (distorted) pixel `raw_px` sees a ray inside the calibration's
    /// valid field ([`super::field`]): fisheye, its distorted normalized radius is at most
    /// theta_d(theta_valid) (theta_d increases up to there, so this is exactly
    /// theta <= theta_valid); pinhole, its undistorted normalized radius is at most
    /// tan(theta_valid) and the undistortion converged (the forward model gives the raw
    /// point back within [`ROUND_TRIP_TOLERANCE_PX`]).
    pub fn in_valid_field(&self, raw_px: Point2<f64>) -> bool {
        if !(raw_px.x.is_finite() && raw_px.y.is_finite()) {
            return false;
        }
        match self.model {
            CameraModel::Fisheye => {
                self.distorted_normalized(raw_px).coords.norm() <= self.distorted_radius_limit
            }
            CameraModel::Pinhole => {
                if !self.field.is_limited() {
                    return true;
                }
                let Ok(n) = self.normalized_from_raw(&[raw_px]) else {
                    return false;
                };
                let Some(n) = n.first().copied() else {
                    return false;
                };
                n.coords.norm() <= self.field.undistorted_radius_limit()
                    && (self.raw_from_normalized(n) - raw_px).norm() <= ROUND_TRIP_TOLERANCE_PX
            }
        }
    }

    /// Raw (distorted) pixels -> undistorted pixels of [`Self::new_camera_matrix`].
    /// Points outside the valid field are extrapolated with the model, which may be far
    /// off or meaningless there: check them with [`Self::in_valid_field`] first.
    pub fn undistort_points(&self, raw: &[Point2<f64>]) -> Result<Vec<Point2<f64>>, CalibError> {
        self.undistort_with(raw, &self.p)
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
    /// `CV_16SC2` + interpolation table, OpenCV's fastest form). Output pixels outside the
    /// valid field read from outside the raw frame, so they come out black.
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
        if self.field.is_limited() {
            let inside = self.output_mask(true);
            let xy = m1
                .data_typed_mut::<Vec2s>()
                .map_err(|e| CalibError::cv("undistortion maps", e))?;
            for (m, _) in xy.iter_mut().zip(&inside).filter(|(_, v)| !**v) {
                *m = Vec2s::from([OUTSIDE_MAP_VALUE, OUTSIDE_MAP_VALUE]);
            }
        }
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

    /// Raw pixels -> undistorted pixels of the camera matrix `p` (OpenCV's iterative
    /// undistortion of the model).
    fn undistort_with(&self, raw: &[Point2<f64>], p: &Mat) -> Result<Vec<Point2<f64>>, CalibError> {
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
            CameraModel::Fisheye => {
                calib3d::fisheye_undistort_points(&src, &mut dst, &self.k, &self.d, &r, p, criteria)
            }
            CameraModel::Pinhole => {
                calib3d::undistort_points_iter(&src, &mut dst, &self.k, &self.d, &r, p, criteria)
            }
        }
        .map_err(|e| CalibError::cv("undistort points", e))?;
        Ok(points_from_vector(&dst))
    }

    /// Raw pixels -> undistorted normalized coordinates `(x/z, y/z)`.
    fn normalized_from_raw(&self, raw: &[Point2<f64>]) -> Result<Vec<Point2<f64>>, CalibError> {
        let identity = mat_from_matrix3(&Matrix3::identity())
            .map_err(|e| CalibError::cv("undistort points", e))?;
        self.undistort_with(raw, &identity)
    }

    /// Normalized coordinates of the raw points inside the valid field; `None` for the
    /// others (the model is not evaluated there).
    fn undistort_inside(
        &self,
        raw: &[Point2<f64>],
    ) -> Result<Vec<Option<Point2<f64>>>, CalibError> {
        let inside: Vec<bool> = raw.iter().map(|p| self.in_valid_field(*p)).collect();
        let valid: Vec<Point2<f64>> = raw
            .iter()
            .zip(&inside)
            .filter(|(_, v)| **v)
            .map(|(p, _)| *p)
            .collect();
        let mut n = self.normalized_from_raw(&valid)?.into_iter();
        Ok(inside
            .into_iter()
            .map(|v| if v { n.next() } else { None })
            .collect())
    }

    /// Raw pixel -> distorted normalized coordinates: K^-1 applied (skew included).
    fn distorted_normalized(&self, raw: Point2<f64>) -> Point2<f64> {
        let k = &self.camera_matrix;
        let y = (raw.y - k[(1, 2)]) / k[(1, 1)];
        let x = (raw.x - k[(0, 2)] - k[(0, 1)] * y) / k[(0, 0)];
        Point2::new(x, y)
    }

    /// Undistorted normalized coordinates -> raw pixel through the model
    /// ([`distort_normalized`]) and K.
    fn raw_from_normalized(&self, n: Point2<f64>) -> Point2<f64> {
        let q = distort_normalized(self.model, &self.distortion, n);
        let k = &self.camera_matrix;
        Point2::new(
            k[(0, 0)] * q.x + k[(0, 1)] * q.y + k[(0, 2)],
            k[(1, 1)] * q.y + k[(1, 2)],
        )
    }

    /// The largest zoom at which the whole valid part of the raw frame fits in the output
    /// (`balance = 1`): the raw frame's outline, sampled, with the samples outside the
    /// field replaced by the field's edge in the same direction (exact for the radial
    /// fisheye model; the pinhole model's tangential terms, small, are ignored there).
    /// Infinite when nothing bounds it.
    fn outer_scale(&self, f: f64, rho: f64) -> Result<f64, CalibError> {
        let (w, h) = (self.width as f64 - 1.0, self.height as f64 - 1.0);
        let t = |i: usize| i as f64 / (EDGE_SAMPLES - 1) as f64;
        let (cx, cy) = (self.camera_matrix[(0, 2)], self.camera_matrix[(1, 2)]);
        // The mid-edge points (on the axes through the principal point) and samples of
        // every edge.
        let outline: Vec<Point2<f64>> = [
            Point2::new(0.0, cy),
            Point2::new(w, cy),
            Point2::new(cx, 0.0),
            Point2::new(cx, h),
        ]
        .into_iter()
        .chain((0..EDGE_SAMPLES).flat_map(|i| {
            let s = t(i);
            [
                Point2::new(0.0, s * h),
                Point2::new(w, s * h),
                Point2::new(s * w, 0.0),
                Point2::new(s * w, h),
            ]
        }))
        .collect();
        let n = self.undistort_inside(&outline)?;
        let points: Vec<Point2<f64>> = outline
            .iter()
            .zip(n)
            .filter_map(|(raw, n)| match n {
                Some(n) => Some(n),
                None if rho.is_finite() => {
                    let q = self.distorted_normalized(*raw);
                    let r = q.coords.norm();
                    (r > 0.0).then(|| Point2::from(q.coords * (rho / r)))
                }
                None => None,
            })
            .filter(|q| q.x.is_finite() && q.y.is_finite())
            .collect();
        let reach = |g: &dyn Fn(&Point2<f64>) -> f64| points.iter().map(g).fold(0.0, f64::max);
        let sides = [
            (cx, reach(&|q| -q.x)),
            (w - cx, reach(&|q| q.x)),
            (cy, reach(&|q| -q.y)),
            (h - cy, reach(&|q| q.y)),
        ];
        Ok(sides
            .iter()
            .map(|(room, extent)| room / (f * extent))
            .filter(|s| s.is_finite() && *s > 0.0)
            .fold(f64::INFINITY, f64::min))
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

    /// The GoPro-like camera with a recorded coverage of `deg` degrees.
    fn covered_to(width: u32, height: u32, deg: f64) -> Calibration {
        let mut c = gopro_like_camera(width, height);
        c.coverage = Some(crate::calib::Coverage {
            field_angle_deg: deg,
            half_diagonal_share: None,
            grid: None,
        });
        c
    }

    /// Raw pixel of the ray at field angle `deg` towards azimuth `az` (radians).
    fn raw_at(u: &Undistorter, deg: f64, az: f64) -> Point2<f64> {
        let t = deg.to_radians().tan();
        u.project(&[Vector3::new(t * az.cos(), t * az.sin(), 1.0)])
            .unwrap()[0]
    }

    #[test]
    fn the_field_test_follows_the_field_angle() {
        let u =
            Undistorter::new(&covered_to(960, 720, 40.0), UndistortSettings::default()).unwrap();
        for az in [0.0, 0.7, 2.0, 3.5, 5.0] {
            assert!(u.in_valid_field(raw_at(&u, 39.99, az)), "az {az}");
            assert!(!u.in_valid_field(raw_at(&u, 40.01, az)), "az {az}");
        }
        assert!(!u.in_valid_field(Point2::new(f64::NAN, 3.0)));
        // Without a recorded coverage the whole frame is inside (the model is monotonic).
        let u =
            Undistorter::new(&gopro_like_camera(960, 720), UndistortSettings::default()).unwrap();
        assert!(u.in_valid_field(Point2::new(0.0, 0.0)));
        assert!(u.in_valid_field(Point2::new(959.0, 719.0)));
    }

    #[test]
    fn balance_zero_frames_inside_the_field() {
        let u =
            Undistorter::new(&covered_to(960, 720, 40.0), UndistortSettings::default()).unwrap();
        let p = u.new_camera_matrix();
        // Every output corner sees a ray at 40 degrees at most, the farthest one at 40.
        let angle = |x: f64, y: f64| {
            ((x - p[(0, 2)]).hypot(y - p[(1, 2)]) / p[(0, 0)])
                .atan()
                .to_degrees()
        };
        let corners = [(0.0, 0.0), (959.0, 0.0), (0.0, 719.0), (959.0, 719.0)];
        let widest = corners
            .iter()
            .map(|&(x, y)| angle(x, y))
            .fold(0.0, f64::max);
        assert!((widest - 40.0).abs() < 1e-9, "{widest}");
        // So the whole output is usable.
        assert_eq!(u.crop_rect(), (0, 0, 960, 720));
        // A narrower field zooms in: a longer focal length than the unlimited framing.
        let free =
            Undistorter::new(&gopro_like_camera(960, 720), UndistortSettings::default()).unwrap();
        assert!(p[(0, 0)] > free.new_camera_matrix()[(0, 0)]);
    }

    #[test]
    fn balance_one_shows_the_field_and_blanks_what_lies_beyond() {
        let u = Undistorter::new(
            &covered_to(960, 720, 40.0),
            UndistortSettings { balance: 1.0 },
        )
        .unwrap();
        let p = u.new_camera_matrix();
        let (cx, cy, f) = (p[(0, 2)], p[(1, 2)], p[(0, 0)]);
        let rho = 40f64.to_radians().tan();
        // The field's disc fits in the output and touches one of its edges.
        let room = [cx, 959.0 - cx, cy, 719.0 - cy];
        let tight = room.iter().copied().fold(f64::INFINITY, f64::min);
        assert!((f * rho - tight).abs() < 1e-6, "{} vs {tight}", f * rho);
        // The crop lies inside the disc.
        let (x, y, w, h) = u.crop_rect();
        for (px, py) in [
            (x, y),
            (x + w - 1, y),
            (x, y + h - 1),
            (x + w - 1, y + h - 1),
        ] {
            let r = (px as f64 - cx).hypot(py as f64 - cy) / f;
            assert!(r <= rho, "crop corner ({px}, {py}) at radius {r} > {rho}");
        }
        assert!(w > 400 && h > 400, "{:?}", u.crop_rect());
        // Remapping a white frame: white inside the field, black beyond.
        let white =
            Mat::new_rows_cols_with_default(720, 960, opencv::core::CV_8UC1, Scalar::all(255.0))
                .unwrap();
        let flat = u.undistort_image(&u.maps().unwrap(), &white).unwrap();
        let at = |x: i32, y: i32| *flat.at_2d::<u8>(y, x).unwrap();
        assert_eq!(at(cx as i32, cy as i32), 255);
        assert_eq!(at(0, 0), 0);
        assert_eq!(at(959, 719), 0);
        let inside_x = (cx + 0.95 * f * rho) as i32;
        assert_eq!(at(inside_x, cy as i32), 255);
    }

    #[test]
    fn a_fit_that_folds_inside_the_frame_still_frames_and_crops() {
        // theta_d turns over near 70 degrees: the 1920x1080 frame's side edges and corners
        // (60..70 degrees for this focal length) lie beyond what the model can undistort.
        let mut c = gopro_like_camera(1920, 1080);
        c.distortion = vec![0.02, 0.03, -0.08, 0.01];
        let field = c.valid_field();
        assert!(field.is_limited() && field.coverage_angle_deg.is_none());
        let u = Undistorter::new(&c, UndistortSettings::default()).unwrap();
        assert!(!u.in_valid_field(Point2::new(0.0, 0.0)));
        assert!(!u.in_valid_field(Point2::new(1919.0, c.cy())));
        let (x, y, w, h) = u.crop_rect();
        assert!(w > 1000 && h > 500, "{:?}", u.crop_rect());
        let corners = [
            Point2::new(x as f64, y as f64),
            Point2::new((x + w - 1) as f64, (y + h - 1) as f64),
        ];
        for raw in u.distort_points(&corners).unwrap() {
            assert!(u.in_valid_field(raw), "{raw}");
        }
    }

    #[test]
    fn the_pinhole_field_test_stops_at_the_turning_point() {
        // r_d = r (1 - r^2 / 2) turns over at r = sqrt(2/3) (39.2 degrees), where
        // r_d = 0.544; the 640x480 frame's corners sit at r_d = 0.78.
        let mut c = left_camera();
        c.distortion = vec![-0.5, 0.0, 0.0, 0.0, 0.0];
        let u = Undistorter::new(&c, UndistortSettings::default()).unwrap();
        assert!(
            (u.valid_field().valid_angle_deg() - (2.0f64 / 3.0).sqrt().atan().to_degrees()).abs()
                < 1e-9
        );
        assert!(!u.in_valid_field(Point2::new(0.0, 0.0)));
        assert!(u.in_valid_field(Point2::new(342.3, 235.6)));
        assert!(u.in_valid_field(raw_at(&u, 35.0, 0.3)));
        let (_, _, w, h) = u.crop_rect();
        assert!(w > 100 && h > 100, "{:?}", u.crop_rect());
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
