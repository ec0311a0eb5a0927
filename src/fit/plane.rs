//! A plane through noisy 3D points with outliers (RGB-D depth of the actuator's side
//! face): RANSAC on point triples, then least squares on the inliers.
//!
//! Written here rather than taken from a crate: the sampling is a fixed-seed SplitMix64,
//! so a session measures the same run to run, and the least-squares step is the
//! smallest eigenvector of a 3x3 covariance (nalgebra).

use super::error::FitError;

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

#[cfg(test)]
mod tests {
    use super::*;

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
