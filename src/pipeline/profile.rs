//! Beyond one circle: the curvature profile along the markers (the circle through each
//! three successive markers) and the "one circle holds" check (the single fit's
//! residual against the residual of local four-marker circles).
//!
//! Written by hand: two short formulas on the markers' mm positions (the circumcircle
//! curvature 4 area / (a b c), and a Pratt fit on sliding windows), kept apart from the
//! frame measurement because they read only the recorded markers, so cached videos get
//! them too.

use nalgebra::{Point2, Vector3};

use crate::fit::fit_circle_pratt;

use super::records::{FrameRecord, MarkerPoint};

/// Markers per window of the local fits that estimate the markers' scatter.
pub const LOCAL_WINDOW_MARKERS: usize = 4;
/// The single fit's RMS residual must exceed this many times the local fits' (median)
/// RMS for the actuator to count as visibly not one arc.
pub const ONE_CIRCLE_FACTOR: f64 = 4.0;
/// ... and this many mm (below it, the residual is at the markers' noise whatever the
/// ratio: noise-free footage has local residuals near 0).
pub const ONE_CIRCLE_FLOOR_MM: f64 = 0.1;
/// Share of a video's measured frames that must fail the check for the warning.
pub const ONE_CIRCLE_FRAMES_SHARE: f64 = 0.5;

fn position(p: &MarkerPoint) -> Vector3<f64> {
    let z = if p.z_mm.is_finite() { p.z_mm } else { 0.0 };
    Vector3::new(p.x_mm, p.y_mm, z)
}

/// Curvature (1/m) of the circle through each three successive markers, at markers 2 to
/// n-1 (n-2 values; 0 for three collinear markers): kappa = 4 A / (a b c) with A the
/// triangle's area and a, b, c its sides.
pub fn curvature_profile_per_m(markers: &[MarkerPoint]) -> Vec<f64> {
    markers
        .windows(3)
        .map(|w| {
            let (a, b, c) = (position(&w[0]), position(&w[1]), position(&w[2]));
            let twice_area = (b - a).cross(&(c - a)).norm();
            let sides = (b - a).norm() * (c - b).norm() * (c - a).norm();
            if sides > 0.0 {
                2.0 * twice_area / sides * 1000.0
            } else {
                f64::NAN
            }
        })
        .collect()
}

/// The markers in their own plane, mm (plane sessions: as recorded; RGB-D: projected on
/// the plane of the chain's first, middle and last marker's spread).
fn in_plane(markers: &[MarkerPoint]) -> Vec<Point2<f64>> {
    if markers.iter().all(|p| !p.z_mm.is_finite()) {
        return markers
            .iter()
            .map(|p| Point2::new(p.x_mm, p.y_mm))
            .collect();
    }
    let pts: Vec<Vector3<f64>> = markers.iter().map(position).collect();
    let mean = pts.iter().sum::<Vector3<f64>>() / pts.len().max(1) as f64;
    let scatter: nalgebra::Matrix3<f64> = pts
        .iter()
        .map(|p| (p - mean) * (p - mean).transpose())
        .sum();
    let eig = scatter.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let (u, v) = (
        eig.eigenvectors.column(order[0]).into_owned(),
        eig.eigenvectors.column(order[1]).into_owned(),
    );
    pts.iter()
        .map(|p| Point2::new((p - mean).dot(&u), (p - mean).dot(&v)))
        .collect()
}

/// A frame's one-circle check: the single Pratt fit's RMS residual and the median RMS of
/// Pratt fits on every [`LOCAL_WINDOW_MARKERS`] successive markers (mm); `None` with
/// fewer than [`LOCAL_WINDOW_MARKERS`] + 1 markers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OneCircle {
    /// RMS residual of the circle through all markers, mm.
    pub single_rms_mm: f64,
    /// Median RMS residual of the local circles, mm (the markers' scatter).
    pub local_rms_mm: f64,
}

impl OneCircle {
    /// Whether the actuator is visibly not one arc in this frame.
    pub fn fails(&self) -> bool {
        self.single_rms_mm > ONE_CIRCLE_FLOOR_MM
            && self.single_rms_mm > ONE_CIRCLE_FACTOR * self.local_rms_mm
    }
}

/// The check of one frame's markers.
pub fn one_circle_check(markers: &[MarkerPoint]) -> Option<OneCircle> {
    if markers.len() <= LOCAL_WINDOW_MARKERS {
        return None;
    }
    let pts = in_plane(markers);
    let single = fit_circle_pratt(&pts).ok()?.rms;
    let mut local: Vec<f64> = pts
        .windows(LOCAL_WINDOW_MARKERS)
        .filter_map(|w| fit_circle_pratt(w).ok().map(|c| c.rms))
        .collect();
    if local.is_empty() {
        return None;
    }
    local.sort_by(f64::total_cmp);
    Some(OneCircle {
        single_rms_mm: single,
        local_rms_mm: local[local.len() / 2],
    })
}

/// A warning when, in at least [`ONE_CIRCLE_FRAMES_SHARE`] of the measured `frames`, the
/// single circle's residual is much larger than the markers' scatter: the actuator is
/// visibly not one arc (segments bending differently), and its one radius describes
/// none of them.
pub fn one_circle_warning(frames: &[FrameRecord]) -> Option<String> {
    let checks: Vec<OneCircle> = frames
        .iter()
        .filter(|f| f.status.is_ok())
        .filter_map(|f| one_circle_check(&f.markers))
        .collect();
    let failing: Vec<&OneCircle> = checks.iter().filter(|c| c.fails()).collect();
    if failing.is_empty() || (failing.len() as f64) < ONE_CIRCLE_FRAMES_SHARE * checks.len() as f64
    {
        return None;
    }
    let mut single: Vec<f64> = failing.iter().map(|c| c.single_rms_mm).collect();
    let mut local: Vec<f64> = failing.iter().map(|c| c.local_rms_mm).collect();
    single.sort_by(f64::total_cmp);
    local.sort_by(f64::total_cmp);
    Some(format!(
        "the markers are visibly not on one circle in {} of {} measured frames (single-circle residual {:.3} mm against {:.3} mm for circles through {LOCAL_WINDOW_MARKERS} successive markers, medians): the one radius describes no part of the actuator; if it has segments, list them (segments = [[1, 2, 3], ...] in {}) and read per_segment.csv, or see the curvature profile in per_frame.csv",
        failing.len(),
        checks.len(),
        single[single.len() / 2],
        local[local.len() / 2],
        crate::session::CONFIG
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn markers(pts: &[(f64, f64)]) -> Vec<MarkerPoint> {
        pts.iter()
            .map(|&(x, y)| MarkerPoint {
                x_px: 0.0,
                y_px: 0.0,
                x_mm: x,
                y_mm: y,
                z_mm: f64::NAN,
            })
            .collect()
    }

    fn arc(r: f64, n: usize, ds: f64) -> Vec<(f64, f64)> {
        (0..n)
            .map(|k| {
                let t = k as f64 * ds / r;
                (r * t.sin(), r * (1.0 - t.cos()))
            })
            .collect()
    }

    #[test]
    fn the_profile_of_a_circle_is_its_curvature() {
        let m = markers(&arc(80.0, 6, 15.0));
        let k = curvature_profile_per_m(&m);
        assert_eq!(k.len(), 4);
        for v in k {
            assert!((v - 12.5).abs() < 1e-9, "{v}");
        }
        let line = markers(&[(0.0, 0.0), (10.0, 0.0), (20.0, 0.0)]);
        assert_eq!(curvature_profile_per_m(&line), [0.0]);
    }

    #[test]
    fn one_circle_holds_for_an_arc_and_fails_for_two() {
        // An arc with 0.02 mm of deterministic scatter.
        let noisy: Vec<(f64, f64)> = arc(90.0, 8, 14.0)
            .into_iter()
            .enumerate()
            .map(|(k, (x, y))| (x, y + 0.02 * if k % 2 == 0 { 1.0 } else { -1.0 }))
            .collect();
        let c = one_circle_check(&markers(&noisy)).unwrap();
        assert!(!c.fails(), "{c:?}");
        // Two arcs meeting tangentially, R 150 then R 40: not one circle.
        let mut two = arc(150.0, 5, 14.0);
        let (p, a) = (two[4], 56.0f64 / 150.0);
        let centre = (p.0 - 40.0 * a.sin(), p.1 + 40.0 * a.cos());
        for k in 1..5 {
            let t = a + 14.0 * k as f64 / 40.0;
            two.push((centre.0 + 40.0 * t.sin(), centre.1 - 40.0 * t.cos()));
        }
        let c = one_circle_check(&markers(&two)).unwrap();
        assert!(c.fails(), "{c:?}");
        assert!(c.single_rms_mm > 0.5, "{c:?}");
    }
}
