//! The hysteresis loop between a loading and an unloading branch of one quantity
//! against pressure: the area between them and their largest difference at equal
//! pressure, over the pressure range both branches cover.

use serde::Serialize;

/// The loop between two branches of a quantity y(p).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LoopMetrics {
    /// Lower end of the pressure range both branches cover, kPa.
    pub from_kpa: f64,
    /// Upper end, kPa.
    pub to_kpa: f64,
    /// Area between the branches, integral of |unloading - loading| dp (units of y
    /// times kPa).
    pub area: f64,
    /// Integral of (unloading - loading) dp: positive when the unloading branch lies above.
    pub signed_area: f64,
    /// The difference unloading - loading of the largest magnitude at one pressure.
    pub max_difference: f64,
    /// The pressure where it is, kPa.
    pub at_kpa: f64,
}

/// The branch's points sorted by pressure, points at one pressure averaged, non-finite
/// ones left out.
fn polyline(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out: Vec<(f64, f64, usize)> = Vec::new();
    for (x, y) in p {
        match out.last_mut() {
            Some(last) if last.0 == x => {
                last.1 += y;
                last.2 += 1;
            }
            _ => out.push((x, y, 1)),
        }
    }
    out.into_iter().map(|(x, s, n)| (x, s / n as f64)).collect()
}

/// The loop between `loading` and `unloading`, each (pressure kPa, value) points (binned
/// means, in any order): both are joined by straight lines between their points, and the
/// difference unloading - loading is integrated by trapezoids on the union of their
/// pressures over the range both cover (exact for the two polylines; a segment where the
/// difference changes sign contributes the two triangles' areas). `None` when a branch
/// has fewer than two distinct pressures or the ranges do not overlap.
pub fn loop_metrics(loading: &[(f64, f64)], unloading: &[(f64, f64)]) -> Option<LoopMetrics> {
    let (l, u) = (polyline(loading), polyline(unloading));
    if l.len() < 2 || u.len() < 2 {
        return None;
    }
    let from = l[0].0.max(u[0].0);
    let to = l[l.len() - 1].0.min(u[u.len() - 1].0);
    if to <= from {
        return None;
    }
    let mut grid: Vec<f64> = l
        .iter()
        .chain(&u)
        .map(|p| p.0)
        .filter(|p| *p > from && *p < to)
        .collect();
    grid.push(from);
    grid.push(to);
    grid.sort_by(f64::total_cmp);
    grid.dedup();
    let diff: Vec<(f64, f64)> = grid
        .iter()
        .map(|&p| {
            let d = super::interpolate(&u, p).unwrap_or(f64::NAN)
                - super::interpolate(&l, p).unwrap_or(f64::NAN);
            (p, d)
        })
        .collect();
    let (mut area, mut signed) = (0.0, 0.0);
    for w in diff.windows(2) {
        let ((p0, d0), (p1, d1)) = (w[0], w[1]);
        let h = p1 - p0;
        signed += 0.5 * h * (d0 + d1);
        area += if d0 * d1 < 0.0 {
            0.5 * h * (d0 * d0 + d1 * d1) / (d0.abs() + d1.abs())
        } else {
            0.5 * h * (d0.abs() + d1.abs())
        };
    }
    let (at, max) = diff
        .iter()
        .copied()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
    Some(LoopMetrics {
        from_kpa: from,
        to_kpa: to,
        area,
        signed_area: signed,
        max_difference: max,
        at_kpa: at,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// An analytic loop: loading y = p, unloading y = p + h sin(pi (p - 20) / 30) on
    /// 20..50 kPa, area 60 h / pi, largest difference h at 35 kPa. Sampled every `dp`
    /// (the unloading branch from the top, on a grid shifted by half a step), the
    /// trapezoids converge as dp^2.
    #[test]
    fn analytic_loop_area_and_largest_difference() {
        let h = 6.0;
        let truth = 60.0 * h / PI;
        for (dp, rel_tol) in [(1.0, 0.002), (0.25, 0.0002)] {
            let n = (30.0 / dp) as usize;
            let load: Vec<(f64, f64)> = (0..=n)
                .map(|i| 20.0 + dp * i as f64)
                .map(|p| (p, p))
                .collect();
            let mut unload: Vec<(f64, f64)> = (0..=n + 1)
                .map(|i| (20.0 + dp * (i as f64 - 0.5)).clamp(20.0, 50.0))
                .map(|p| (p, p + h * (PI * (p - 20.0) / 30.0).sin()))
                .collect();
            unload.reverse();
            let m = loop_metrics(&load, &unload).unwrap();
            assert_eq!((m.from_kpa, m.to_kpa), (20.0, 50.0));
            assert!(
                (m.area / truth - 1.0).abs() < rel_tol,
                "dp {dp}: {} vs {truth}",
                m.area
            );
            assert!((m.signed_area - m.area).abs() < 1e-12);
            assert!((m.max_difference - h).abs() < h * rel_tol * 2.0, "{m:?}");
            assert!((m.at_kpa - 35.0).abs() <= dp, "{m:?}");
        }
    }

    #[test]
    fn crossing_branches_and_partial_overlap() {
        // Unloading = loading + (p - 30) on 20..40: the difference changes sign at 30;
        // |area| = 2 * 10^2 / 2 = 100, signed 0; largest |difference| 10 at either end.
        let load = [(20.0, 0.0), (40.0, 0.0)];
        let unload = [(40.0, 10.0), (20.0, -10.0)];
        let m = loop_metrics(&load, &unload).unwrap();
        assert!(
            (m.area - 100.0).abs() < 1e-9 && m.signed_area.abs() < 1e-9,
            "{m:?}"
        );
        assert_eq!(m.max_difference.abs(), 10.0);
        // Only the common range counts: loading 10..40, unloading 25..60, difference 1.
        let load = [(10.0, 0.0), (40.0, 0.0)];
        let unload = [(25.0, 1.0), (60.0, 1.0)];
        let m = loop_metrics(&load, &unload).unwrap();
        assert_eq!((m.from_kpa, m.to_kpa), (25.0, 40.0));
        assert!((m.area - 15.0).abs() < 1e-9);
        // Points at one pressure are averaged; too few or disjoint branches give none.
        let m = loop_metrics(
            &[(0.0, 0.0), (10.0, 0.0)],
            &[(0.0, 1.0), (0.0, 3.0), (10.0, 2.0)],
        )
        .unwrap();
        assert!((m.area - 20.0).abs() < 1e-9);
        assert!(loop_metrics(&[(1.0, 1.0)], &unload).is_none());
        assert!(loop_metrics(&[(0.0, 0.0), (5.0, 0.0)], &[(6.0, 0.0), (9.0, 1.0)]).is_none());
        assert!(loop_metrics(&[(0.0, f64::NAN), (5.0, 0.0)], &unload).is_none());
    }
}
