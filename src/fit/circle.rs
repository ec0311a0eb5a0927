//! Circle fits: Pratt's algebraic fit (the measurement), Kasa's (for comparison), the
//! geometric fit by Levenberg-Marquardt, and a circle through 3D points in their
//! best-fit plane.
//!
//! The algebraic fits are written here, a few dozen lines on the points' centred moments:
//! Pratt's curvature comes straight from the algebraic parameters, so it goes smoothly to
//! 0 for collinear markers (a nearly straight actuator), where the radius blows up. The
//! geometric fit uses the `levenberg_marquardt` crate.

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{storage::Owned, Dyn, OMatrix, OVector, Point2, Vector3, U3};
use serde::{Deserialize, Serialize};

use super::error::FitError;

/// Newton iterations of Pratt's characteristic polynomial (Chernov's implementation
/// converges in a handful).
pub const PRATT_MAX_ITER: usize = 100;
/// Relative step at which the Newton iteration stops.
pub const PRATT_EPS: f64 = 1e-12;

/// A fitted circle (units of the input points).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CircleFit {
    /// Centre; not finite when `curvature` is 0 (collinear points).
    pub center: Point2<f64>,
    /// Radius; `f64::INFINITY` for collinear points.
    pub radius: f64,
    /// 1 / radius, always finite and >= 0.
    pub curvature: f64,
    /// RMS of the geometric residuals |distance to centre - radius| (for collinear
    /// points: distance to the fitted line).
    pub rms: f64,
}

/// Centred moments of a point set.
struct Moments {
    mean: Point2<f64>,
    mxx: f64,
    myy: f64,
    mxy: f64,
    mxz: f64,
    myz: f64,
    mzz: f64,
}

fn moments(points: &[Point2<f64>], what: &'static str) -> Result<Moments, FitError> {
    if points.len() < 3 {
        return Err(FitError::TooFewPoints {
            what,
            needed: 3,
            got: points.len(),
        });
    }
    if points.iter().any(|p| !(p.x.is_finite() && p.y.is_finite())) {
        return Err(FitError::Degenerate {
            what,
            why: "non-finite coordinates",
        });
    }
    let n = points.len() as f64;
    let mean = Point2::new(
        points.iter().map(|p| p.x).sum::<f64>() / n,
        points.iter().map(|p| p.y).sum::<f64>() / n,
    );
    let mut m = Moments {
        mean,
        mxx: 0.0,
        myy: 0.0,
        mxy: 0.0,
        mxz: 0.0,
        myz: 0.0,
        mzz: 0.0,
    };
    for p in points {
        let (x, y) = (p.x - mean.x, p.y - mean.y);
        let z = x * x + y * y;
        m.mxx += x * x;
        m.myy += y * y;
        m.mxy += x * y;
        m.mxz += x * z;
        m.myz += y * z;
        m.mzz += z * z;
    }
    for v in [
        &mut m.mxx, &mut m.myy, &mut m.mxy, &mut m.mxz, &mut m.myz, &mut m.mzz,
    ] {
        *v /= n;
    }
    if m.mxx + m.myy <= f64::EPSILON * (mean.coords.norm_squared() + 1.0) {
        return Err(FitError::Degenerate {
            what,
            why: "all points coincide",
        });
    }
    Ok(m)
}

/// Circle from algebraic parameters A(x²+y²) + Bx + Cy + D = 0 in centred coordinates.
fn circle_from_algebraic(
    a: f64,
    b: f64,
    c: f64,
    d: f64,
    points: &[Point2<f64>],
    mean: Point2<f64>,
) -> CircleFit {
    let disc = (b * b + c * c - 4.0 * a * d).max(0.0);
    let curvature = if disc > 0.0 {
        2.0 * a.abs() / disc.sqrt()
    } else {
        0.0
    };
    if curvature > 0.0 && a != 0.0 {
        let center = Point2::new(mean.x - b / (2.0 * a), mean.y - c / (2.0 * a));
        let radius = 1.0 / curvature;
        let rms = (points
            .iter()
            .map(|p| ((p - center).norm() - radius).powi(2))
            .sum::<f64>()
            / points.len() as f64)
            .sqrt();
        CircleFit {
            center,
            radius,
            curvature,
            rms,
        }
    } else {
        // A line Bx + Cy + D = 0: residuals are distances to it.
        let norm = (b * b + c * c).sqrt().max(f64::MIN_POSITIVE);
        let rms = (points
            .iter()
            .map(|p| ((b * (p.x - mean.x) + c * (p.y - mean.y) + d) / norm).powi(2))
            .sum::<f64>()
            / points.len() as f64)
            .sqrt();
        CircleFit {
            center: Point2::new(f64::INFINITY, f64::INFINITY),
            radius: f64::INFINITY,
            curvature: 0.0,
            rms,
        }
    }
}

/// Pratt's algebraic circle fit (V. Pratt, "Direct least-squares fitting of algebraic
/// surfaces", SIGGRAPH 1987), in N. Chernov's Newton formulation on centred data.
pub fn fit_circle_pratt(points: &[Point2<f64>]) -> Result<CircleFit, FitError> {
    let m = moments(points, "Pratt circle fit")?;
    let mz = m.mxx + m.myy;
    let cov_xy = m.mxx * m.myy - m.mxy * m.mxy;
    let (mxz2, myz2) = (m.mxz * m.mxz, m.myz * m.myz);
    let a2 = 4.0 * cov_xy - 3.0 * mz * mz - m.mzz;
    let a1 = m.mzz * mz + 4.0 * cov_xy * mz - mxz2 - myz2 - mz * mz * mz;
    let a0 = mxz2 * m.myy + myz2 * m.mxx - m.mzz * cov_xy - 2.0 * m.mxz * m.myz * m.mxy
        + mz * mz * cov_xy;
    let a22 = a2 + a2;
    let mut x = 0.0f64;
    let mut y = f64::INFINITY;
    for _ in 0..PRATT_MAX_ITER {
        let y_old = y;
        y = a0 + x * (a1 + x * (a2 + 4.0 * x * x));
        if y.abs() > y_old.abs() {
            x = 0.0;
            break;
        }
        let dy = a1 + x * (a22 + 16.0 * x * x);
        if dy == 0.0 {
            break;
        }
        let x_old = x;
        x = x_old - y / dy;
        if x != 0.0 && ((x - x_old) / x).abs() < PRATT_EPS {
            break;
        }
        if x < 0.0 {
            x = 0.0;
            break;
        }
    }
    let det = x * x - x * mz + cov_xy;
    // Centre = (-B/2A, -C/2A) with A = det; D follows from R² = |c|² + Mz + 2x.
    let a = det;
    let b = -(m.mxz * (m.myy - x) - m.myz * m.mxy);
    let c = -(m.myz * (m.mxx - x) - m.mxz * m.mxy);
    let d = -a * (mz + 2.0 * x);
    Ok(circle_from_algebraic(a, b, c, d, points, m.mean))
}

/// Kasa's algebraic fit (least squares on x²+y² + Bx + Cy + D), biased towards small
/// circles on short arcs; kept for comparison.
pub fn fit_circle_kasa(points: &[Point2<f64>]) -> Result<CircleFit, FitError> {
    let m = moments(points, "Kasa circle fit")?;
    // Normal equations for B, C in centred coordinates (D = -Mz).
    let det = m.mxx * m.myy - m.mxy * m.mxy;
    let mz = m.mxx + m.myy;
    if det.abs() <= f64::EPSILON * mz * mz {
        // Collinear: a line through the centroid along the principal direction.
        let ang = 0.5 * (2.0 * m.mxy).atan2(m.mxx - m.myy);
        return Ok(circle_from_algebraic(
            0.0,
            -ang.sin(),
            ang.cos(),
            0.0,
            points,
            m.mean,
        ));
    }
    let b = -(m.mxz * m.myy - m.myz * m.mxy) / det;
    let c = -(m.myz * m.mxx - m.mxz * m.mxy) / det;
    Ok(circle_from_algebraic(1.0, b, c, -mz, points, m.mean))
}

struct GeometricCircle<'a> {
    points: &'a [Point2<f64>],
    p: Vector3<f64>,
}

impl LeastSquaresProblem<f64, Dyn, U3> for GeometricCircle<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, U3>;
    type ParameterStorage = Owned<f64, U3>;

    fn set_params(&mut self, x: &Vector3<f64>) {
        self.p = *x;
    }
    fn params(&self) -> Vector3<f64> {
        self.p
    }
    fn residuals(&self) -> Option<OVector<f64, Dyn>> {
        Some(OVector::<f64, Dyn>::from_iterator(
            self.points.len(),
            self.points
                .iter()
                .map(|q| (q.x - self.p.x).hypot(q.y - self.p.y) - self.p.z),
        ))
    }
    fn jacobian(&self) -> Option<OMatrix<f64, Dyn, U3>> {
        let mut j = OMatrix::<f64, Dyn, U3>::zeros(self.points.len());
        for (i, q) in self.points.iter().enumerate() {
            let r = (q.x - self.p.x)
                .hypot(q.y - self.p.y)
                .max(f64::MIN_POSITIVE);
            j[(i, 0)] = -(q.x - self.p.x) / r;
            j[(i, 1)] = -(q.y - self.p.y) / r;
            j[(i, 2)] = -1.0;
        }
        Some(j)
    }
}

/// Geometric (orthogonal-distance) circle fit by Levenberg-Marquardt from the Pratt
/// estimate; the reference the algebraic fits approximate.
pub fn fit_circle_geometric(points: &[Point2<f64>]) -> Result<CircleFit, FitError> {
    let start = fit_circle_pratt(points)?;
    if start.curvature == 0.0 {
        return Ok(start);
    }
    let problem = GeometricCircle {
        points,
        p: Vector3::new(start.center.x, start.center.y, start.radius),
    };
    let (solved, report) = LevenbergMarquardt::new().minimize(problem);
    let p = solved.p;
    if !report.termination.was_successful() || !p.iter().all(|v| v.is_finite()) || p.z <= 0.0 {
        return Ok(start);
    }
    let center = Point2::new(p.x, p.y);
    let rms = (points
        .iter()
        .map(|q| ((q - center).norm() - p.z).powi(2))
        .sum::<f64>()
        / points.len() as f64)
        .sqrt();
    Ok(CircleFit {
        center,
        radius: p.z,
        curvature: 1.0 / p.z,
        rms,
    })
}

/// A circle fitted to 3D points: Pratt's fit in their best-fit plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CircleFit3 {
    /// The circle in plane coordinates (origin at the points' centroid, axes `u`, `v`).
    pub circle: CircleFit,
    /// Unit normal of the best-fit plane.
    pub normal: nalgebra::Vector3<f64>,
    /// First in-plane axis.
    pub u: nalgebra::Vector3<f64>,
    /// Second in-plane axis.
    pub v: nalgebra::Vector3<f64>,
    /// Centroid of the points.
    pub origin: nalgebra::Point3<f64>,
    /// RMS distance of the points from the plane.
    pub plane_rms: f64,
}

impl CircleFit3 {
    /// In-plane coordinates of a 3D point.
    pub fn to_plane(&self, p: &nalgebra::Point3<f64>) -> Point2<f64> {
        let d = p - self.origin;
        Point2::new(d.dot(&self.u), d.dot(&self.v))
    }
}

/// Best-fit plane of 3D points (SVD of the centred points: the normal is the direction
/// of least spread), then [`fit_circle_pratt`] on the points expressed in that plane.
/// Used for RGB-D markers, whose 3D positions give the radius in mm directly.
pub fn fit_circle_3d(points: &[nalgebra::Point3<f64>]) -> Result<CircleFit3, FitError> {
    if points.len() < 3 {
        return Err(FitError::TooFewPoints {
            what: "3D circle fit",
            needed: 3,
            got: points.len(),
        });
    }
    let n = points.len() as f64;
    let origin = nalgebra::Point3::from(
        points
            .iter()
            .map(|p| p.coords)
            .sum::<nalgebra::Vector3<f64>>()
            / n,
    );
    let mut m = nalgebra::DMatrix::<f64>::zeros(points.len(), 3);
    for (i, p) in points.iter().enumerate() {
        let d = p - origin;
        m[(i, 0)] = d.x;
        m[(i, 1)] = d.y;
        m[(i, 2)] = d.z;
    }
    let svd = m.svd(false, true);
    let vt = svd.v_t.ok_or(FitError::Degenerate {
        what: "3D circle fit",
        why: "no plane (SVD failed)",
    })?;
    // Singular values are sorted in decreasing order: rows 0, 1 span the plane.
    let u = nalgebra::Vector3::new(vt[(0, 0)], vt[(0, 1)], vt[(0, 2)]);
    let v = nalgebra::Vector3::new(vt[(1, 0)], vt[(1, 1)], vt[(1, 2)]);
    let normal = u.cross(&v).normalize();
    let plane_rms = (points
        .iter()
        .map(|p| (p - origin).dot(&normal).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let flat: Vec<Point2<f64>> = points
        .iter()
        .map(|p| {
            let d = p - origin;
            Point2::new(d.dot(&u), d.dot(&v))
        })
        .collect();
    let circle = fit_circle_pratt(&flat)?;
    Ok(CircleFit3 {
        circle,
        normal,
        u,
        v,
        origin,
        plane_rms,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn pts(x: &[f64], y: &[f64]) -> Vec<Point2<f64>> {
        x.iter().zip(y).map(|(a, b)| Point2::new(*a, *b)).collect()
    }

    fn gander() -> Vec<Point2<f64>> {
        pts(
            &[1.0, 2.0, 5.0, 7.0, 9.0, 3.0],
            &[7.0, 6.0, 8.0, 7.0, 5.0, 7.0],
        )
    }

    #[test]
    fn pratt_on_gander_golub_strebel_points() {
        let c = fit_circle_pratt(&gander()).unwrap();
        assert!((c.center.x - 4.61548).abs() < 5e-5, "{c:?}");
        assert!((c.center.y - 2.80735).abs() < 5e-5, "{c:?}");
        assert!((c.radius - 4.91130).abs() < 5e-5, "{c:?}");
        assert!((c.curvature * c.radius - 1.0).abs() < 1e-12);
    }

    #[test]
    fn kasa_and_geometric_on_gander_golub_strebel_points() {
        let k = fit_circle_kasa(&gander()).unwrap();
        assert!((k.radius - 4.10876).abs() < 5e-5, "{k:?}");
        let g = fit_circle_geometric(&gander()).unwrap();
        assert!((g.center.x - 4.7398).abs() < 5e-4, "{g:?}");
        assert!((g.center.y - 2.9835).abs() < 5e-4, "{g:?}");
        assert!((g.radius - 4.7142).abs() < 5e-4, "{g:?}");
    }

    #[test]
    fn pratt_and_geometric_on_the_second_reference_set() {
        let p = pts(
            &[9.0, 35.0, -13.0, 10.0, 23.0, 0.0],
            &[34.0, 10.0, 6.0, -14.0, 27.0, -10.0],
        );
        let c = fit_circle_pratt(&p).unwrap();
        assert!((c.center.x - 10.550298).abs() < 5e-7, "{c:?}");
        assert!((c.center.y - 9.709954).abs() < 5e-7, "{c:?}");
        assert!((c.radius - 23.415414).abs() < 5e-7, "{c:?}");
        let g = fit_circle_geometric(&p).unwrap();
        assert!((g.radius - 23.333528).abs() < 5e-6, "{g:?}");
    }

    #[test]
    fn collinear_points_give_zero_curvature_and_no_nan() {
        let p: Vec<_> = (0..8)
            .map(|i| Point2::new(3.0 * i as f64, 1.0 + 0.5 * i as f64))
            .collect();
        let c = fit_circle_pratt(&p).unwrap();
        assert_eq!(c.curvature, 0.0);
        assert!(c.radius.is_infinite());
        assert!(c.rms < 1e-9, "{c:?}");
        assert!(!c.curvature.is_nan() && !c.rms.is_nan());
        // Nearly collinear: tiny, finite curvature, no NaN.
        let q: Vec<_> = (0..8)
            .map(|i| {
                let x = i as f64 * 12.5;
                Point2::new(x, 1e-9 * x * x)
            })
            .collect();
        let c = fit_circle_pratt(&q).unwrap();
        assert!(c.curvature.is_finite() && c.curvature < 1e-6, "{c:?}");
    }

    #[test]
    fn degenerate_inputs_are_errors() {
        assert!(matches!(
            fit_circle_pratt(&gander()[..2]),
            Err(FitError::TooFewPoints { .. })
        ));
        let same = vec![Point2::new(1.0, 1.0); 5];
        assert!(matches!(
            fit_circle_pratt(&same),
            Err(FitError::Degenerate { .. })
        ));
        let nan = vec![
            Point2::new(1.0, f64::NAN),
            Point2::new(0.0, 0.0),
            Point2::new(2.0, 0.0),
        ];
        assert!(fit_circle_pratt(&nan).is_err());
    }

    #[test]
    fn circle_in_a_tilted_plane() {
        let rot = nalgebra::Rotation3::from_euler_angles(0.4, -0.3, 0.2);
        let pts: Vec<nalgebra::Point3<f64>> = (0..8)
            .map(|i| {
                let t = 1.4 * i as f64 / 7.0;
                nalgebra::Point3::from(
                    rot * nalgebra::Vector3::new(70.0 * t.cos(), 70.0 * t.sin(), 0.0)
                        + nalgebra::Vector3::new(5.0, -3.0, 150.0),
                )
            })
            .collect();
        let c = fit_circle_3d(&pts).unwrap();
        assert!((c.circle.radius - 70.0).abs() < 1e-9, "{c:?}");
        assert!(c.plane_rms < 1e-9);
        assert!((c.normal.dot(&(rot * nalgebra::Vector3::z())).abs() - 1.0).abs() < 1e-9);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        #[test]
        fn pratt_recovers_points_on_an_arc(
            cx in -500.0f64..500.0, cy in -500.0f64..500.0, r in 10.0f64..5000.0,
            start in 0.0f64..std::f64::consts::TAU, span_deg in 20.0f64..300.0, n in 3usize..20,
        ) {
            let span = span_deg.to_radians();
            let p: Vec<_> = (0..n)
                .map(|i| {
                    let t = start + span * i as f64 / (n - 1) as f64;
                    Point2::new(cx + r * t.cos(), cy + r * t.sin())
                })
                .collect();
            let c = fit_circle_pratt(&p).unwrap();
            prop_assert!((c.radius / r - 1.0).abs() < 1e-6, "r {} vs {}", c.radius, r);
            prop_assert!((c.center - Point2::new(cx, cy)).norm() < 1e-6 * r);
        }

        #[test]
        fn pratt_is_invariant_to_rotation_and_translation(
            ang in 0.0f64..std::f64::consts::TAU, tx in -1000.0f64..1000.0, ty in -1000.0f64..1000.0,
        ) {
            let base = gander();
            let (s, co) = ang.sin_cos();
            let moved: Vec<_> = base.iter().map(|p| Point2::new(co * p.x - s * p.y + tx, s * p.x + co * p.y + ty)).collect();
            let a = fit_circle_pratt(&base).unwrap();
            let b = fit_circle_pratt(&moved).unwrap();
            prop_assert!((a.radius - b.radius).abs() < 1e-8);
        }
    }
}
