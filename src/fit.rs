//! Fits on marker centroids: circles (Pratt, Kasa, geometric), bending angle, and the
//! power law y = a x^b + c of a quantity against pressure.
//!
//! The Pratt fit is the measurement (method.md §2.6): algebraic, no iteration over the
//! points, nearly as accurate as the geometric fit for arcs, and it needs no fixed
//! reference point. Its curvature is computed from the algebraic parameters so that it
//! goes smoothly to 0 when the markers become collinear (nearly straight actuator),
//! where the radius itself blows up.

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{storage::Owned, Dyn, Matrix3, OMatrix, OVector, Point2, Vector3, U3};
use serde::{Deserialize, Serialize};

/// Newton iterations of Pratt's characteristic polynomial (Chernov's implementation
/// converges in a handful).
pub const PRATT_MAX_ITER: usize = 100;
/// Relative step at which the Newton iteration stops.
pub const PRATT_EPS: f64 = 1e-12;

/// Errors of the fits.
#[derive(Debug, Clone, thiserror::Error, PartialEq)]
pub enum FitError {
    /// Too few points.
    #[error("{what} needs at least {needed} points, got {got}")]
    TooFewPoints {
        /// The fit.
        what: &'static str,
        /// Minimum.
        needed: usize,
        /// Given.
        got: usize,
    },
    /// Points all at the same place, or non-finite.
    #[error("{what}: points are degenerate ({why})")]
    Degenerate {
        /// The fit.
        what: &'static str,
        /// Why.
        why: &'static str,
    },
    /// The power law needs positive pressures.
    #[error("power law y = a x^b + c needs x > 0 (got {x}): leave out zero or negative pressures")]
    NonPositiveX {
        /// The offending value.
        x: f64,
    },
    /// Too few distinct x values for the power law's three parameters: with one x (every
    /// video at one pressure) or two, any number of curves pass through the points, and
    /// a "fit" would be one of them, with a meaningless R^2.
    #[error("y = a x^b + c has 3 parameters and needs points at {needed} or more distinct x values (pressures), got {distinct} ({values}): measure at more pressures")]
    TooFewDistinctX {
        /// Distinct x values given.
        distinct: usize,
        /// Distinct x values needed.
        needed: usize,
        /// Those values, for the message.
        values: String,
    },
    /// x and y differ in length.
    #[error("x has {x} values and y has {y}")]
    LengthMismatch {
        /// Length of x.
        x: usize,
        /// Length of y.
        y: usize,
    },
}

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

/// Bending angle by the half-angle convention (method.md §2.9): with O the clamped-end
/// marker, O' the tip marker at rest and A the tip marker now,
/// cos(alpha/2) = (OO' . OA) / (|OO'| |OA|); returns alpha in degrees, in [0, 360).
/// On a circular arc starting tangent to OO', alpha is the turning angle of the tangent
/// between O and A.
pub fn bending_angle_deg(
    clamp: Point2<f64>,
    tip_rest: Point2<f64>,
    tip_now: Point2<f64>,
) -> Result<f64, FitError> {
    let u = tip_rest - clamp;
    let v = tip_now - clamp;
    let (nu, nv) = (u.norm(), v.norm());
    if !(nu > 0.0 && nv > 0.0) || !(nu.is_finite() && nv.is_finite()) {
        return Err(FitError::Degenerate {
            what: "bending angle",
            why: "the clamped-end and tip markers coincide",
        });
    }
    let cos_half = (u.dot(&v) / (nu * nv)).clamp(-1.0, 1.0);
    Ok(2.0 * cos_half.acos().to_degrees())
}

/// Bending angle without a rest frame: the rest direction OO' is taken as the fitted
/// circle's tangent at the clamped-end marker, oriented towards the tip (equivalent to
/// [`bending_angle_deg`] when the actuator leaves the clamp tangentially). Collinear
/// markers give 0.
pub fn bending_angle_from_circle_deg(
    clamp: Point2<f64>,
    tip: Point2<f64>,
    circle: &CircleFit,
) -> Result<f64, FitError> {
    if circle.curvature == 0.0 || !circle.center.x.is_finite() {
        return Ok(0.0);
    }
    let r = clamp - circle.center;
    let mut t = nalgebra::Vector2::new(-r.y, r.x);
    if t.dot(&(tip - clamp)) < 0.0 {
        t = -t;
    }
    bending_angle_deg(clamp, clamp + t, tip)
}

/// Bending angle as the turning of the fitted circle's tangent from the clamped-end
/// marker to the tip, following the markers in order: the sum of the signed central
/// angles between successive markers (each well under 180 degrees at any marker
/// spacing), so an actuator curled past 180 degrees reads its whole turn, where the
/// chord-tangent angle of [`bending_angle_from_circle_deg`] folds back (200 degrees read
/// as 160). Below 180 degrees both give the same value. A straight chain gives 0.
pub fn bending_angle_along_markers_deg(
    markers: &[Point2<f64>],
    circle: &CircleFit,
) -> Result<f64, FitError> {
    if markers.len() < 2 {
        return Err(FitError::TooFewPoints {
            what: "bending angle",
            needed: 2,
            got: markers.len(),
        });
    }
    if circle.curvature == 0.0 || !circle.center.x.is_finite() {
        return Ok(0.0);
    }
    let total: f64 = markers
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0] - circle.center, w[1] - circle.center);
            (a.x * b.y - a.y * b.x).atan2(a.dot(&b))
        })
        .sum();
    Ok(total.abs().to_degrees())
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

/// A plane n . x = d (unit normal n).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneFit {
    /// Unit normal.
    pub normal: nalgebra::Vector3<f64>,
    /// Offset: n . x = d for points x on the plane.
    pub offset: f64,
    /// Points used in the final least-squares fit.
    pub inliers: usize,
    /// RMS distance of those points from the plane.
    pub rms: f64,
}

impl PlaneFit {
    /// Signed distance of `p` from the plane.
    pub fn distance(&self, p: &nalgebra::Point3<f64>) -> f64 {
        self.normal.dot(&p.coords) - self.offset
    }

    /// Where the ray t * `dir` (t > 0, from the origin) meets the plane, if it does.
    pub fn intersect_ray(&self, dir: &nalgebra::Vector3<f64>) -> Option<nalgebra::Point3<f64>> {
        let den = self.normal.dot(dir);
        let t = self.offset / den;
        (den.abs() > 1e-12 && t.is_finite() && t > 0.0).then(|| nalgebra::Point3::from(dir * t))
    }
}

/// Least-squares plane of `points` (SVD of the centred points), `None` when degenerate.
fn plane_least_squares(points: &[&nalgebra::Point3<f64>]) -> Option<PlaneFit> {
    if points.len() < 3 {
        return None;
    }
    let n = points.len() as f64;
    let c = points
        .iter()
        .map(|p| p.coords)
        .sum::<nalgebra::Vector3<f64>>()
        / n;
    let mut cov = nalgebra::Matrix3::<f64>::zeros();
    for p in points {
        let d = p.coords - c;
        cov += d * d.transpose();
    }
    let eig = cov.symmetric_eigen();
    let k = (0..3).min_by(|a, b| eig.eigenvalues[*a].total_cmp(&eig.eigenvalues[*b]))?;
    let normal = eig.eigenvectors.column(k).into_owned().normalize();
    if !normal.iter().all(|v| v.is_finite()) {
        return None;
    }
    let offset = normal.dot(&c);
    let rms = (points
        .iter()
        .map(|p| (normal.dot(&p.coords) - offset).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    Some(PlaneFit {
        normal,
        offset,
        inliers: points.len(),
        rms,
    })
}

/// RANSAC iterations of [`fit_plane_robust`].
pub const PLANE_RANSAC_ITERATIONS: usize = 200;

/// A plane through noisy 3D points with outliers (depth pixels of the actuator's side
/// face, with background and flying pixels among them): RANSAC on point triples with
/// the inlier band `band` (same unit as the points; deterministic sampling), then least
/// squares on the inliers, then twice more least squares on the points within 3 robust
/// sigmas (1.4826 x the median absolute residual) of the last plane (Fischler and
/// Bolles 1981 for RANSAC).
pub fn fit_plane_robust(points: &[nalgebra::Point3<f64>], band: f64) -> Result<PlaneFit, FitError> {
    let degenerate = FitError::Degenerate {
        what: "plane fit",
        why: "fewer than 3 points off a line",
    };
    let n = points.len();
    if n < 3 {
        return Err(FitError::TooFewPoints {
            what: "plane fit",
            needed: 3,
            got: n,
        });
    }
    // SplitMix64: a fixed seed keeps results repeatable run to run.
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = |m: usize| -> usize {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) % m as u64) as usize
    };
    let mut best: Option<(usize, nalgebra::Vector3<f64>, f64)> = None;
    for _ in 0..PLANE_RANSAC_ITERATIONS {
        let (a, b, c) = (points[next(n)], points[next(n)], points[next(n)]);
        let normal = (b - a).cross(&(c - a));
        if normal.norm() < 1e-12 {
            continue;
        }
        let normal = normal.normalize();
        let offset = normal.dot(&a.coords);
        let count = points
            .iter()
            .filter(|p| (normal.dot(&p.coords) - offset).abs() <= band)
            .count();
        if best.as_ref().is_none_or(|(k, _, _)| count > *k) {
            best = Some((count, normal, offset));
        }
    }
    let (_, normal, offset) = best.ok_or(degenerate.clone())?;
    let inliers: Vec<&nalgebra::Point3<f64>> = points
        .iter()
        .filter(|p| (normal.dot(&p.coords) - offset).abs() <= band)
        .collect();
    let mut plane = plane_least_squares(&inliers).ok_or(degenerate.clone())?;
    for _ in 0..2 {
        let mut r: Vec<f64> = inliers.iter().map(|p| plane.distance(p).abs()).collect();
        r.sort_by(f64::total_cmp);
        let sigma = 1.4826 * r[r.len() / 2];
        let keep: Vec<&nalgebra::Point3<f64>> = points
            .iter()
            .filter(|p| plane.distance(p).abs() <= (3.0 * sigma).max(1e-9))
            .collect();
        match plane_least_squares(&keep) {
            Some(p) => plane = p,
            None => break,
        }
    }
    Ok(plane)
}

/// Distinct x values (pressures) the power law y = a x^b + c needs: one per parameter.
pub const POWER_LAW_MIN_DISTINCT_X: usize = 3;

/// Neighbouring x values closer than this share of the larger of the two are the same
/// pressure.
pub const DISTINCT_X_REL: f64 = 1e-9;

/// The distinct values of `x` (sorted; neighbours within [`DISTINCT_X_REL`] of the larger
/// |x| of the two are one). The tolerance is relative to each pair, not to the largest
/// value, so that one huge pressure (a typo such as 1e12) does not merge all the others.
pub fn distinct_values(x: &[f64]) -> Vec<f64> {
    let mut v: Vec<f64> = x.to_vec();
    v.sort_by(f64::total_cmp);
    let mut out: Vec<f64> = Vec::with_capacity(v.len());
    for x in v {
        if out
            .last()
            .is_none_or(|l| x - l > DISTINCT_X_REL * x.abs().max(l.abs()))
        {
            out.push(x);
        }
    }
    out
}

/// The fitted power law y = a x^b + c.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PowerLawFit {
    /// Coefficient a.
    pub a: f64,
    /// Exponent b.
    pub b: f64,
    /// Offset c.
    pub c: f64,
    /// Standard errors of a, b, c.
    pub std_errors: PowerLawErrors,
    /// Coefficient of determination.
    pub r_squared: f64,
    /// RMS residual, units of y.
    pub rmse: f64,
    /// Number of points.
    pub n: usize,
}

/// Standard errors of the power-law parameters (from the Jacobian at the optimum:
/// sqrt(diag((JᵀJ)⁻¹) SSE / (n - 3))); NaN with only 3 points.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PowerLawErrors {
    /// Standard error of a.
    pub a: f64,
    /// Standard error of b.
    pub b: f64,
    /// Standard error of c.
    pub c: f64,
}

impl PowerLawFit {
    /// a x^b + c.
    pub fn eval(&self, x: f64) -> f64 {
        self.a * x.powf(self.b) + self.c
    }
}

struct PowerLaw<'a> {
    x: &'a [f64],
    y: &'a [f64],
    p: Vector3<f64>,
}

impl LeastSquaresProblem<f64, Dyn, U3> for PowerLaw<'_> {
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
            self.x.len(),
            self.x
                .iter()
                .zip(self.y)
                .map(|(x, y)| self.p.x * x.powf(self.p.y) + self.p.z - y),
        ))
    }
    fn jacobian(&self) -> Option<OMatrix<f64, Dyn, U3>> {
        let mut j = OMatrix::<f64, Dyn, U3>::zeros(self.x.len());
        for (i, x) in self.x.iter().enumerate() {
            let xb = x.powf(self.p.y);
            j[(i, 0)] = xb;
            j[(i, 1)] = self.p.x * xb * x.ln();
            j[(i, 2)] = 1.0;
        }
        Some(j)
    }
}

/// Levenberg-Marquardt fit of y = a x^b + c (x > 0, at [`POWER_LAW_MIN_DISTINCT_X`] or
/// more distinct x), started from the best of a grid of offsets c with a log-log
/// regression for a and b at each.
pub fn fit_power_law(x: &[f64], y: &[f64]) -> Result<PowerLawFit, FitError> {
    if x.len() != y.len() {
        return Err(FitError::LengthMismatch {
            x: x.len(),
            y: y.len(),
        });
    }
    if x.len() < 3 {
        return Err(FitError::TooFewPoints {
            what: "power law y = a x^b + c",
            needed: 3,
            got: x.len(),
        });
    }
    if let Some(&bad) = x.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
        return Err(FitError::NonPositiveX { x: bad });
    }
    let distinct = distinct_values(x);
    if distinct.len() < POWER_LAW_MIN_DISTINCT_X {
        return Err(FitError::TooFewDistinctX {
            distinct: distinct.len(),
            needed: POWER_LAW_MIN_DISTINCT_X,
            values: distinct
                .iter()
                .map(|v| format!("{v}"))
                .collect::<Vec<_>>()
                .join(", "),
        });
    }
    if y.iter().any(|v| !v.is_finite()) {
        return Err(FitError::Degenerate {
            what: "power law",
            why: "non-finite y values",
        });
    }
    let n = x.len();
    let (ymin, ymax) = y
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    let span = (ymax - ymin).max(f64::MIN_POSITIVE);
    let sse_of = |p: &Vector3<f64>| -> f64 {
        x.iter()
            .zip(y)
            .map(|(xi, yi)| (p.x * xi.powf(p.y) + p.z - yi).powi(2))
            .sum()
    };
    // Start: for each c on a grid below and above the data, y - c has one sign; fit
    // ln|y - c| = ln|a| + b ln x.
    let mut best: Option<(f64, Vector3<f64>)> = None;
    const GRID: usize = 40;
    for k in 0..=GRID {
        let t = k as f64 / GRID as f64;
        for c in [
            ymin - span * (0.001 + 3.0 * t),
            ymax + span * (0.001 + 3.0 * t),
        ] {
            let sign = if ymin > c { 1.0 } else { -1.0 };
            let (mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0);
            for (xi, yi) in x.iter().zip(y) {
                let (lx, ly) = (xi.ln(), (sign * (yi - c)).max(f64::MIN_POSITIVE).ln());
                sx += lx;
                sy += ly;
                sxx += lx * lx;
                sxy += lx * ly;
            }
            let nf = n as f64;
            let den = nf * sxx - sx * sx;
            if den.abs() < 1e-300 {
                continue;
            }
            let b = (nf * sxy - sx * sy) / den;
            let a = sign * ((sy - b * sx) / nf).exp();
            let p = Vector3::new(a, b, c);
            let sse = sse_of(&p);
            if sse.is_finite() && best.as_ref().is_none_or(|(s, _)| sse < *s) {
                best = Some((sse, p));
            }
        }
    }
    let start = best
        .map(|(_, p)| p)
        .unwrap_or_else(|| Vector3::new(1.0, 1.0, 0.0));
    let (solved, _report) = LevenbergMarquardt::new().minimize(PowerLaw { x, y, p: start });
    let p = if sse_of(&solved.p).is_finite() && sse_of(&solved.p) <= sse_of(&start) {
        solved.p
    } else {
        start
    };
    let sse = sse_of(&p);
    let mean = y.iter().sum::<f64>() / n as f64;
    let sst: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let r_squared = if sst > 0.0 { 1.0 - sse / sst } else { 1.0 };
    let problem = PowerLaw { x, y, p };
    let errors = problem
        .jacobian()
        .and_then(|j| {
            let jtj: Matrix3<f64> = j.transpose() * &j;
            jtj.try_inverse()
        })
        .filter(|_| n > 3)
        .map(|cov| {
            let s2 = sse / (n as f64 - 3.0);
            PowerLawErrors {
                a: (cov[(0, 0)] * s2).sqrt(),
                b: (cov[(1, 1)] * s2).sqrt(),
                c: (cov[(2, 2)] * s2).sqrt(),
            }
        })
        .unwrap_or(PowerLawErrors {
            a: f64::NAN,
            b: f64::NAN,
            c: f64::NAN,
        });
    Ok(PowerLawFit {
        a: p.x,
        b: p.y,
        c: p.z,
        std_errors: errors,
        r_squared,
        rmse: (sse / n as f64).sqrt(),
        n,
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
    fn bending_angle_half_angle_convention() {
        let o = Point2::new(0.0, 0.0);
        let rest = Point2::new(100.0, 0.0);
        // Tip rotated by 30° about O: alpha = 60°.
        let a = Point2::new(
            80.0 * 30f64.to_radians().cos(),
            -80.0 * 30f64.to_radians().sin(),
        );
        assert!((bending_angle_deg(o, rest, a).unwrap() - 60.0).abs() < 1e-10);
        assert!((bending_angle_deg(o, rest, rest).unwrap()).abs() < 1e-6);
        assert!(bending_angle_deg(o, o, a).is_err());
        // On an arc leaving O tangentially, the turning angle is recovered.
        let r = 50.0;
        let theta = 1.2f64;
        let on_arc = |t: f64| Point2::new(r * t.sin(), -r * (1.0 - t.cos()));
        let c = fit_circle_pratt(
            &(0..8)
                .map(|i| on_arc(theta * i as f64 / 7.0))
                .collect::<Vec<_>>(),
        )
        .unwrap();
        let alpha = bending_angle_from_circle_deg(on_arc(0.0), on_arc(theta), &c).unwrap();
        assert!((alpha - theta.to_degrees()).abs() < 1e-9, "{alpha}");
        let markers: Vec<_> = (0..8).map(|i| on_arc(theta * i as f64 / 7.0)).collect();
        let along = bending_angle_along_markers_deg(&markers, &c).unwrap();
        assert!((along - alpha).abs() < 1e-9, "{along} vs {alpha}");
        // Curled past 180 degrees: 250 degrees of turn, the chord-tangent angle folds
        // back to 110; following the markers reads 250.
        let theta = 250f64.to_radians();
        let markers: Vec<_> = (0..8).map(|i| on_arc(theta * i as f64 / 7.0)).collect();
        let c = fit_circle_pratt(&markers).unwrap();
        let folded = bending_angle_from_circle_deg(markers[0], markers[7], &c).unwrap();
        assert!((folded - 110.0).abs() < 1e-6, "{folded}");
        let along = bending_angle_along_markers_deg(&markers, &c).unwrap();
        assert!((along - 250.0).abs() < 1e-9, "{along}");
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

    #[test]
    fn power_law_recovers_exact_parameters() {
        let x: Vec<f64> = (0..12).map(|i| 10.0 + 9.5 * i as f64).collect();
        for (a, b, c) in [(2.0, 0.7, 5.0), (800.0, -0.9, 20.0), (0.05, 1.6, -3.0)] {
            let y: Vec<f64> = x.iter().map(|v| a * v.powf(b) + c).collect();
            let f = fit_power_law(&x, &y).unwrap();
            assert!((f.a / a - 1.0).abs() < 1e-5, "{a} {b} {c}: {f:?}");
            assert!((f.b - b).abs() < 1e-6, "{f:?}");
            assert!((f.c - c).abs() < 1e-4 * (1.0 + c.abs()), "{f:?}");
            assert!(f.r_squared > 1.0 - 1e-10);
        }
    }

    #[test]
    fn power_law_standard_errors_cover_the_truth() {
        let x: Vec<f64> = (0..20).map(|i| 10.0 + 5.5 * i as f64).collect();
        let mut rng = crate::render::rng::SplitMix64::new(42);
        let (a, b, c) = (800.0, -0.9, 20.0);
        let y: Vec<f64> = x
            .iter()
            .map(|v| a * v.powf(b) + c + 0.3 * rng.normal())
            .collect();
        let f = fit_power_law(&x, &y).unwrap();
        assert!((f.b - b).abs() < 3.0 * f.std_errors.b, "{f:?}");
        assert!((f.c - c).abs() < 3.0 * f.std_errors.c, "{f:?}");
        assert!(f.std_errors.b > 0.0 && f.std_errors.b < 0.2, "{f:?}");
        assert!(f.rmse > 0.15 && f.rmse < 0.5, "{f:?}");
    }

    #[test]
    fn power_law_bad_input() {
        assert!(matches!(
            fit_power_law(&[1.0, 2.0], &[1.0, 2.0]),
            Err(FitError::TooFewPoints { .. })
        ));
        assert!(matches!(
            fit_power_law(&[0.0, 1.0, 2.0, 3.0], &[1.0, 2.0, 3.0, 4.0]),
            Err(FitError::NonPositiveX { .. })
        ));
        assert!(matches!(
            fit_power_law(&[1.0, 2.0, 3.0], &[1.0, 2.0]),
            Err(FitError::LengthMismatch { .. })
        ));
    }

    #[test]
    fn one_or_two_distinct_pressures_give_no_power_law() {
        // Every video at 40 kPa, radii scattered as real ones: no curve is determined.
        let e = fit_power_law(&[40.0; 5], &[60.1, 59.8, 60.3, 60.0, 59.9]).unwrap_err();
        assert_eq!(
            e,
            FitError::TooFewDistinctX {
                distinct: 1,
                needed: 3,
                values: "40".into()
            }
        );
        assert!(
            e.to_string()
                .contains("got 1 (40): measure at more pressures"),
            "{e}"
        );
        let e = fit_power_law(&[20.0, 20.0, 50.0, 50.0], &[90.0, 91.0, 60.0, 61.0]).unwrap_err();
        assert!(
            matches!(e, FitError::TooFewDistinctX { distinct: 2, .. }),
            "{e}"
        );
        assert!(e.to_string().contains("(20, 50)"), "{e}");
        // Three distinct pressures are enough, repeats included.
        let law = |p: f64| 300.0 * p.powf(-0.45) + 5.0;
        let x = [20.0, 20.0, 50.0, 80.0, 80.0 * (1.0 + 1e-12)];
        assert_eq!(distinct_values(&x), vec![20.0, 50.0, 80.0]);
        let f = fit_power_law(&x, &x.map(law)).unwrap();
        assert!((f.eval(35.0) - law(35.0)).abs() < 1e-6 * law(35.0), "{f:?}");
        // One huge pressure (a typo) does not merge the others into one.
        assert_eq!(
            distinct_values(&[20.0, 35.0, 50.0, 65.0, 1e12]),
            vec![20.0, 35.0, 50.0, 65.0, 1e12]
        );
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

    #[test]
    fn a_robust_plane_ignores_the_background_and_averages_the_noise() {
        use nalgebra::{Point3, Vector3};
        let normal = Vector3::new(0.3, -0.1, 1.0).normalize();
        let offset = 400.0;
        let mut state = 12345u64;
        let mut gauss = || {
            // Box-Muller from a small LCG.
            let mut u = || {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (a, b) = (u(), u());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        let mut pts = Vec::new();
        for i in 0..60 {
            for j in 0..40 {
                let ray = Vector3::new(-0.2 + i as f64 * 0.006, -0.1 + j as f64 * 0.005, 1.0);
                let t = offset / normal.dot(&ray);
                // A quarter of the pixels see the sheet 40 mm behind.
                let extra = if i < 15 { 40.0 } else { 0.0 };
                pts.push(Point3::from(ray * t + normal * (extra + 0.8 * gauss())));
            }
        }
        let p = fit_plane_robust(&pts, 4.0).unwrap();
        let angle = p.normal.dot(&normal).abs().acos().to_degrees();
        assert!(angle < 0.2, "normal off by {angle} deg");
        assert!(
            (p.offset * p.normal.dot(&normal).signum() - offset).abs() < 0.2,
            "{p:?}"
        );
        assert!((p.rms - 0.8).abs() < 0.1, "{p:?}");
        assert!(p.inliers > 1700 && p.inliers < 1820, "{}", p.inliers);
        let hit = p.intersect_ray(&Vector3::new(0.0, 0.0, 1.0)).unwrap();
        assert!(p.distance(&hit).abs() < 1e-9);
    }
}
