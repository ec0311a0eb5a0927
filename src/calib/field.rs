//! The valid field of a calibration: the field angles inside which its lens model may be
//! trusted.
//!
//! A fitted distortion polynomial is only constrained where the checkerboard's corners
//! were seen. Beyond, it is extrapolated, and a polynomial of degree 9 (Kannala-Brandt) or
//! 7 (Brown) extrapolated from a narrow range can turn over: the distorted radius stops
//! growing with the field angle, two field angles land on the same pixel, and undistortion
//! there has no answer (OpenCV returns garbage). So a calibration's valid field is the
//! smaller of two limits:
//!
//! - **coverage**: the largest field angle of a detected board corner (known only for
//!   calibrations made by bendscope, see [`super::coverage`]);
//! - **monotonic**: the largest field angle up to which the model's distorted radius is
//!   still increasing, from the coefficients alone:
//!   - fisheye (Kannala & Brandt 2006, OpenCV `cv::fisheye`):
//!     `theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)`, increasing
//!     while `1 + 3 k1 theta^2 + 5 k2 theta^4 + 7 k3 theta^6 + 9 k4 theta^8 > 0`;
//!   - pinhole (Brown-Conrady radial part, OpenCV `cv::calibrateCamera`):
//!     `r_d = r (1 + k1 r^2 + k2 r^4 + k3 r^6)` with `r = tan(theta)` the normalized radius,
//!     increasing while `1 + 3 k1 r^2 + 5 k2 r^4 + 7 k3 r^6 > 0`.
//!
//! No margin is added beyond the coverage: nothing constrains the polynomial there, and
//! the measured failure (issue 10) shows how quickly an extrapolated fit can fold.
//!
//! Field angles are measured from the optical axis, in degrees at the API; 90 degrees
//! means "no limit" (both models describe rays in front of the camera only).

use nalgebra::Point2;

use super::CameraModel;

/// The field angle that means "no limit": rays at 90 degrees or more are outside both
/// models' domain.
pub const NO_LIMIT_DEG: f64 = 90.0;
/// Steps of the scan for the first turning point of the distorted radius.
const MONOTONIC_SCAN_STEPS: usize = 4096;
/// Bisection steps refining the turning point (the interval halves each step).
const MONOTONIC_BISECTION_STEPS: usize = 60;

/// Where a calibration's lens model may be used: field angles from the optical axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidField {
    /// Lens model the angles refer to.
    pub model: CameraModel,
    /// Largest field angle of a detected board corner, degrees; `None` when unknown
    /// (calibration files written without it).
    pub coverage_angle_deg: Option<f64>,
    /// Largest field angle up to which the distorted radius increases, degrees
    /// ([`NO_LIMIT_DEG`] when it increases over the whole domain).
    pub monotonic_angle_deg: f64,
}

impl ValidField {
    /// The field of `model` with `distortion` coefficients, limited by `coverage_angle_deg`
    /// when known: the monotonic limit is computed from the coefficients.
    pub fn new(model: CameraModel, distortion: &[f64], coverage_angle_deg: Option<f64>) -> Self {
        Self {
            model,
            coverage_angle_deg: coverage_angle_deg.filter(|a| a.is_finite() && *a > 0.0),
            monotonic_angle_deg: monotonic_field_angle_deg(model, distortion),
        }
    }

    /// The valid field angle, degrees: the smaller of the coverage and monotonic limits.
    pub fn valid_angle_deg(&self) -> f64 {
        match self.coverage_angle_deg {
            Some(c) => c.min(self.monotonic_angle_deg),
            None => self.monotonic_angle_deg,
        }
    }

    /// True when the field has a limit inside the models' domain (less than 90 degrees).
    pub fn is_limited(&self) -> bool {
        self.valid_angle_deg() < NO_LIMIT_DEG
    }

    /// Largest radius of an undistorted (pinhole) normalized point `(x/z, y/z)` inside the
    /// field: `tan(theta_valid)`; infinite without a limit.
    pub fn undistorted_radius_limit(&self) -> f64 {
        if self.is_limited() {
            self.valid_angle_deg().to_radians().tan()
        } else {
            f64::INFINITY
        }
    }
}

/// `theta_d(theta)` of the Kannala-Brandt model: the distorted normalized radius of a ray
/// at field angle `theta` (radians), `d` = k1..k4.
pub fn fisheye_theta_d(theta: f64, d: &[f64]) -> f64 {
    let t2 = theta * theta;
    let k = |i: usize| d.get(i).copied().unwrap_or(0.0);
    theta * (1.0 + t2 * (k(0) + t2 * (k(1) + t2 * (k(2) + t2 * k(3)))))
}

/// `d theta_d / d theta` of the Kannala-Brandt model:
/// `1 + 3 k1 theta^2 + 5 k2 theta^4 + 7 k3 theta^6 + 9 k4 theta^8`.
pub fn fisheye_theta_d_slope(theta: f64, d: &[f64]) -> f64 {
    let t2 = theta * theta;
    let k = |i: usize| d.get(i).copied().unwrap_or(0.0);
    1.0 + t2 * (3.0 * k(0) + t2 * (5.0 * k(1) + t2 * (7.0 * k(2) + t2 * 9.0 * k(3))))
}

/// `d r_d / d r` of the Brown radial part `r_d = r (1 + k1 r^2 + k2 r^4 + k3 r^6)`,
/// `d` = k1 k2 p1 p2 k3 (OpenCV's order).
pub fn brown_radial_slope(r: f64, d: &[f64]) -> f64 {
    let r2 = r * r;
    let k = |i: usize| d.get(i).copied().unwrap_or(0.0);
    1.0 + r2 * (3.0 * k(0) + r2 * (5.0 * k(1) + r2 * 7.0 * k(4)))
}

/// The largest field angle (degrees) up to which the model's distorted radius increases
/// with the field angle: the first root of the slope (module doc), found by a scan over
/// (0, 90) degrees and bisection; [`NO_LIMIT_DEG`] when the slope stays positive.
pub fn monotonic_field_angle_deg(model: CameraModel, distortion: &[f64]) -> f64 {
    if distortion.iter().any(|v| !v.is_finite()) {
        return 0.0;
    }
    let slope = |angle: f64| match model {
        CameraModel::Fisheye => fisheye_theta_d_slope(angle, distortion),
        CameraModel::Pinhole => brown_radial_slope(angle.tan(), distortion),
    };
    let top = NO_LIMIT_DEG.to_radians();
    let step = top / MONOTONIC_SCAN_STEPS as f64;
    // The last scan point stops short of 90 degrees, where tan() is infinite.
    for i in 1..MONOTONIC_SCAN_STEPS {
        let (mut lo, mut hi) = ((i - 1) as f64 * step, i as f64 * step);
        if slope(hi) > 0.0 {
            continue;
        }
        for _ in 0..MONOTONIC_BISECTION_STEPS {
            let mid = 0.5 * (lo + hi);
            if slope(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        return lo.to_degrees();
    }
    NO_LIMIT_DEG
}

/// The field angle (radians) of the Kannala-Brandt model whose distorted radius is
/// `theta_d`, searched on the increasing part `[0, theta_max]` by bisection; `None` when
/// `theta_d` lies beyond `theta_d(theta_max)`.
pub fn fisheye_theta_from_theta_d(theta_d: f64, d: &[f64], theta_max: f64) -> Option<f64> {
    if !(theta_d.is_finite() && theta_d >= 0.0) || theta_d > fisheye_theta_d(theta_max, d) {
        return None;
    }
    let (mut lo, mut hi) = (0.0, theta_max);
    for _ in 0..MONOTONIC_BISECTION_STEPS {
        let mid = 0.5 * (lo + hi);
        if fisheye_theta_d(mid, d) < theta_d {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// The lens model's forward projection of an undistorted normalized point `(x/z, y/z)`
/// to a distorted normalized point (before the camera matrix), as OpenCV computes it:
///
/// - fisheye: `theta = atan(r)`, `(x, y) * theta_d(theta) / r`;
/// - pinhole: `(x, y) (1 + k1 r^2 + k2 r^4 + k3 r^6)` plus the tangential terms
///   `(2 p1 x y + p2 (r^2 + 2 x^2), p1 (r^2 + 2 y^2) + 2 p2 x y)`.
pub fn distort_normalized(model: CameraModel, d: &[f64], p: Point2<f64>) -> Point2<f64> {
    let k = |i: usize| d.get(i).copied().unwrap_or(0.0);
    let r2 = p.x * p.x + p.y * p.y;
    match model {
        CameraModel::Fisheye => {
            let r = r2.sqrt();
            if r < 1e-12 {
                return p;
            }
            let s = fisheye_theta_d(r.atan(), d) / r;
            Point2::new(p.x * s, p.y * s)
        }
        CameraModel::Pinhole => {
            let (k1, k2, p1, p2, k3) = (k(0), k(1), k(2), k(3), k(4));
            let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
            Point2::new(
                p.x * radial + 2.0 * p1 * p.x * p.y + p2 * (r2 + 2.0 * p.x * p.x),
                p.y * radial + p1 * (r2 + 2.0 * p.y * p.y) + 2.0 * p2 * p.x * p.y,
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The GoPro-like camera of the renderer: its theta_d keeps increasing up to 90 deg.
    const GOPRO: [f64; 4] = [0.045, -0.012, 0.004, -0.0008];
    /// Hand-made: a negative k3 turns theta_d over near 70 deg (slope 0.11 at 1.2 rad,
    /// -0.14 at 1.25 rad).
    const FOLDING: [f64; 4] = [0.02, 0.03, -0.08, 0.01];

    #[test]
    fn a_polynomial_that_keeps_increasing_has_no_limit() {
        assert_eq!(
            monotonic_field_angle_deg(CameraModel::Fisheye, &GOPRO),
            NO_LIMIT_DEG
        );
        assert_eq!(
            monotonic_field_angle_deg(CameraModel::Fisheye, &[0.0; 4]),
            NO_LIMIT_DEG
        );
        // OpenCV's left*.jpg calibration (method.md): barrel, but monotonic throughout.
        let left = [-0.26637, -0.03859, 0.00178, -0.00028, 0.23839];
        assert_eq!(
            monotonic_field_angle_deg(CameraModel::Pinhole, &left),
            NO_LIMIT_DEG
        );
    }

    #[test]
    fn a_folding_polynomial_stops_at_its_turning_point() {
        let limit = monotonic_field_angle_deg(CameraModel::Fisheye, &FOLDING);
        let t = limit.to_radians();
        // The slope vanishes there, is positive just before and negative just after.
        assert!(fisheye_theta_d_slope(t, &FOLDING).abs() < 1e-9, "{limit}");
        assert!(fisheye_theta_d_slope(t - 1e-3, &FOLDING) > 0.0);
        assert!(fisheye_theta_d_slope(t + 1e-3, &FOLDING) < 0.0);
        assert!(limit > 40.0 && limit < 90.0, "{limit}");
        // theta_d is largest there: a point beyond has a twin inside.
        assert!(fisheye_theta_d(t + 0.1, &FOLDING) < fisheye_theta_d(t, &FOLDING));
    }

    #[test]
    fn a_single_coefficient_fold_is_found_exactly() {
        // theta_d = theta (1 - theta^2 / 3): slope 1 - theta^2 = 0 at theta = 1 rad.
        let d = [-1.0 / 3.0, 0.0, 0.0, 0.0];
        let limit = monotonic_field_angle_deg(CameraModel::Fisheye, &d);
        assert!((limit - 1f64.to_degrees()).abs() < 1e-9, "{limit}");
        // Pinhole r_d = r (1 - r^2): slope 1 - 3 r^2 = 0 at r = 1/sqrt(3) (30 deg).
        let b = [-1.0, 0.0, 0.0, 0.0, 0.0];
        let limit = monotonic_field_angle_deg(CameraModel::Pinhole, &b);
        assert!((limit - 30.0).abs() < 1e-9, "{limit}");
        // A folding pinhole through k3 alone: slope 1 - 7 r^6 = 0.
        let c = [0.0, 0.0, 0.0, 0.0, -1.0];
        let limit = monotonic_field_angle_deg(CameraModel::Pinhole, &c);
        let r = (1.0f64 / 7.0).powf(1.0 / 6.0);
        assert!((limit - r.atan().to_degrees()).abs() < 1e-9, "{limit}");
    }

    #[test]
    fn the_valid_field_is_the_smaller_limit() {
        let f = ValidField::new(CameraModel::Fisheye, &FOLDING, Some(42.0));
        assert_eq!(f.valid_angle_deg(), 42.0);
        let f = ValidField::new(CameraModel::Fisheye, &FOLDING, Some(89.0));
        assert_eq!(f.valid_angle_deg(), f.monotonic_angle_deg);
        let f = ValidField::new(CameraModel::Fisheye, &GOPRO, None);
        assert!(!f.is_limited());
        assert_eq!(f.undistorted_radius_limit(), f64::INFINITY);
        let f = ValidField::new(CameraModel::Fisheye, &GOPRO, Some(45.0));
        assert!((f.undistorted_radius_limit() - 1.0).abs() < 1e-12);
        // Nonsense coverage is ignored, nonsense coefficients give an empty field.
        let f = ValidField::new(CameraModel::Fisheye, &GOPRO, Some(f64::NAN));
        assert_eq!(f.coverage_angle_deg, None);
        let f = ValidField::new(CameraModel::Fisheye, &[f64::NAN; 4], None);
        assert_eq!(f.valid_angle_deg(), 0.0);
    }

    #[test]
    fn theta_inverts_theta_d_on_the_increasing_part() {
        let top = monotonic_field_angle_deg(CameraModel::Fisheye, &FOLDING).to_radians();
        for theta in [0.0, 0.3, 0.7, top - 1e-6] {
            let back = fisheye_theta_from_theta_d(fisheye_theta_d(theta, &FOLDING), &FOLDING, top)
                .unwrap();
            assert!((back - theta).abs() < 1e-9, "{theta} -> {back}");
        }
        let beyond = fisheye_theta_d(top, &FOLDING) + 1e-6;
        assert_eq!(fisheye_theta_from_theta_d(beyond, &FOLDING, top), None);
    }
}
