//! The statistics of a study: a summary (mean, sample standard deviation with n - 1,
//! min, max) of per-session values, pressure set points grouped within a tolerance, the
//! coefficient of variation, Student's t quantiles, the leave-one-out check of a
//! session against the others and the delta-method confidence band of a power law.

use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

use crate::fit::PowerLawFit;
pub use crate::fit::{t_cdf, t_two_sided};

/// Two pressures are one set point when they differ by at most this share of the larger
/// one ...
pub const SAME_PRESSURE_REL: f64 = 0.005;
/// ... or by at most this many kPa (set points near 0 kPa).
pub const SAME_PRESSURE_KPA: f64 = 0.05;

/// Two-sided level of the confidence band of a fit.
pub const BAND_LEVEL: f64 = 0.95;

/// Two-sided level of the prediction interval a session must stay in
/// ([`outlier_check`]): high, because each session is checked at every pressure for
/// three quantities (a fine study of three sessions at four pressures makes 36 checks).
pub const OUTLIER_LEVEL: f64 = 0.999;

/// Mean, spread and range of the per-session values at one pressure.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Summary {
    /// Number of values.
    pub n: usize,
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (n - 1); NaN when n < 2 (no spread defined).
    pub std: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
}

impl Summary {
    /// The summary of the finite values of `v` (NaN everywhere when there is none).
    pub fn of(v: &[f64]) -> Summary {
        let v: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
        let n = v.len();
        if n == 0 {
            return Summary {
                n,
                mean: f64::NAN,
                std: f64::NAN,
                min: f64::NAN,
                max: f64::NAN,
            };
        }
        let mean = v.iter().sum::<f64>() / n as f64;
        let std = if n < 2 {
            f64::NAN
        } else {
            (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        };
        Summary {
            n,
            mean,
            std,
            min: v.iter().copied().fold(f64::INFINITY, f64::min),
            max: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }

    /// Coefficient of variation std / |mean|, in %; NaN when n < 2 or the mean is 0.
    pub fn cv_pct(&self) -> f64 {
        if self.n < 2 || self.mean == 0.0 {
            f64::NAN
        } else {
            100.0 * self.std / self.mean.abs()
        }
    }
}

/// True when `a` and `b` are one pressure set point ([`SAME_PRESSURE_REL`],
/// [`SAME_PRESSURE_KPA`]).
pub fn same_pressure(a: f64, b: f64) -> bool {
    (a - b).abs() <= SAME_PRESSURE_KPA.max(SAME_PRESSURE_REL * a.abs().max(b.abs()))
}

/// The set points of `pressures` (any order): sorted, each group opened by its lowest
/// pressure and holding the pressures that are [`same_pressure`] as that one (a chain
/// of close values does not merge far ones); each set point is its group's mean.
pub fn set_points(pressures: &[f64]) -> Vec<f64> {
    let mut p: Vec<f64> = pressures
        .iter()
        .copied()
        .filter(|p| p.is_finite())
        .collect();
    p.sort_by(f64::total_cmp);
    let mut groups: Vec<(f64, Vec<f64>)> = Vec::new();
    for x in p {
        match groups.last_mut() {
            Some((first, members)) if same_pressure(*first, x) => members.push(x),
            _ => groups.push((x, vec![x])),
        }
    }
    groups
        .into_iter()
        .map(|(_, m)| m.iter().sum::<f64>() / m.len() as f64)
        .collect()
}

/// The index of the set point of `points` that `p` belongs to (the nearest one within
/// the tolerance), if any.
pub fn set_point_of(points: &[f64], p: f64) -> Option<usize> {
    points
        .iter()
        .enumerate()
        .filter(|(_, s)| same_pressure(**s, p))
        .min_by(|a, b| (a.1 - p).abs().total_cmp(&(b.1 - p).abs()))
        .map(|(k, _)| k)
}

/// A session checked against the other sessions of its sample ([`outlier_check`]).
#[derive(Debug, Clone, PartialEq)]
pub struct OutlierCheck {
    /// Degrees of freedom of the others' pooled spread.
    pub dof: usize,
    /// The limit: Student's t at [`OUTLIER_LEVEL`] (two-sided) with `dof`.
    pub limit: f64,
    /// Per set point, the session's t (`None` where it or two others are missing).
    pub t: Vec<Option<f64>>,
}

/// Checks one session against the others of its sample over all set points at once.
/// At set point k the others (m_k >= 2 values) have mean μ_k; their relative residuals
/// x/μ_k − 1, pooled over the set points, give the run-to-run spread s with
/// Σ (m_k − 1) degrees of freedom (run-to-run changes scale with the value, so one
/// relative spread serves every pressure). The session's t at k is
/// |own_k/μ_k − 1| / (s sqrt(1 + 1/m_k)), the statistic of the prediction interval of
/// one new run; it is outside when t exceeds Student's t at [`OUTLIER_LEVEL`].
/// `own[k]` is NaN where the session has no value; `others[k]` holds the finite values
/// of the other sessions. `None` when no set point has two others.
pub fn outlier_check(own: &[f64], others: &[Vec<f64>]) -> Option<OutlierCheck> {
    let usable = |o: &Vec<f64>| -> Option<f64> {
        let mean = Summary::of(o).mean;
        (o.len() >= 2 && mean.is_finite() && mean != 0.0).then_some(mean)
    };
    let (mut sum, mut dof) = (0.0, 0usize);
    for o in others {
        if let Some(mean) = usable(o) {
            sum += o.iter().map(|x| (x / mean - 1.0).powi(2)).sum::<f64>();
            dof += o.len() - 1;
        }
    }
    if dof == 0 {
        return None;
    }
    let s = (sum / dof as f64).sqrt();
    let t = own
        .iter()
        .zip(others)
        .map(|(x, o)| {
            let mean = usable(o)?;
            if !x.is_finite() {
                return None;
            }
            let d = (x / mean - 1.0).abs();
            Some(if s > 0.0 {
                d / (s * (1.0 + 1.0 / o.len() as f64).sqrt())
            } else if d > 1e-12 {
                f64::INFINITY
            } else {
                0.0
            })
        })
        .collect();
    Some(OutlierCheck {
        dof,
        limit: t_two_sided(OUTLIER_LEVEL, dof),
        t,
    })
}

/// A power law's confidence band on a pressure grid.
#[derive(Debug, Clone, Serialize)]
pub struct Band {
    /// Confidence level (two-sided).
    pub level: f64,
    /// Student's t quantile used (n - 3 degrees of freedom).
    pub t: f64,
    /// Pressures, kPa.
    pub pressure_kpa: Vec<f64>,
    /// The fitted curve.
    pub value: Vec<f64>,
    /// Lower edge.
    pub lower: Vec<f64>,
    /// Upper edge.
    pub upper: Vec<f64>,
}

/// Standard error of the fitted curve a p^b + c at `p` by the delta method:
/// sqrt(gᵀ Σ g), g = (p^b, a p^b ln p, 1) the gradient in (a, b, c) and Σ the
/// parameters' covariance.
pub fn curve_std_error(fit: &PowerLawFit, covariance: &Matrix3<f64>, p: f64) -> f64 {
    let pb = p.powf(fit.b);
    let g = Vector3::new(pb, fit.a * pb * p.ln(), 1.0);
    (g.transpose() * covariance * g)[(0, 0)].max(0.0).sqrt()
}

/// The [`BAND_LEVEL`] confidence band of the mean curve of `fit` on `points` pressures
/// evenly spread over [p0, p1]: value ± t_{n-3} × [`curve_std_error`].
pub fn confidence_band(
    fit: &PowerLawFit,
    covariance: &Matrix3<f64>,
    (p0, p1): (f64, f64),
    points: usize,
) -> Band {
    let t = t_two_sided(BAND_LEVEL, fit.n.saturating_sub(3));
    let grid: Vec<f64> = (0..points)
        .map(|k| p0 + (p1 - p0) * k as f64 / (points.max(2) - 1) as f64)
        .collect();
    let value: Vec<f64> = grid.iter().map(|p| fit.eval(*p)).collect();
    let half: Vec<f64> = grid
        .iter()
        .map(|p| t * curve_std_error(fit, covariance, *p))
        .collect();
    Band {
        level: BAND_LEVEL,
        t,
        lower: value.iter().zip(&half).map(|(v, h)| v - h).collect(),
        upper: value.iter().zip(&half).map(|(v, h)| v + h).collect(),
        pressure_kpa: grid,
        value,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::fit_power_law_with_covariance;

    #[test]
    fn summary_of_hand_values() {
        // 2, 4, 4, 4, 5, 5, 7, 9: mean 5, sum of squares 32, std sqrt(32/7).
        let s = Summary::of(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0, f64::NAN]);
        assert_eq!((s.n, s.mean, s.min, s.max), (8, 5.0, 2.0, 9.0));
        assert!((s.std - (32.0f64 / 7.0).sqrt()).abs() < 1e-15);
        assert!((s.cv_pct() - 100.0 * (32.0f64 / 7.0).sqrt() / 5.0).abs() < 1e-12);
        // One value: no spread, and no CV; none: all NaN.
        let one = Summary::of(&[3.5]);
        assert_eq!((one.n, one.mean, one.min, one.max), (1, 3.5, 3.5, 3.5));
        assert!(one.std.is_nan() && one.cv_pct().is_nan());
        assert!(Summary::of(&[]).mean.is_nan());
    }

    #[test]
    fn set_points_group_within_the_tolerance() {
        // 40 and 40.15 (0.375 %) are one; 0 and 0.04 kPa are one; 60 and 60.4 (0.66 %)
        // are two.
        let p = set_points(&[40.15, 0.0, 60.0, 40.0, 0.04, 60.4, 20.0]);
        assert_eq!(p.len(), 5, "{p:?}");
        assert!((p[0] - 0.02).abs() < 1e-12 && (p[2] - 40.075).abs() < 1e-12);
        assert_eq!((p[1], p[3], p[4]), (20.0, 60.0, 60.4));
        assert_eq!(set_point_of(&p, 40.1), Some(2));
        assert_eq!(set_point_of(&p, 30.0), None);
        // A chain 100, 100.4, 100.8, 101.2: opened at 100, so 100.8 starts a new group.
        assert_eq!(set_points(&[100.0, 100.4, 100.8, 101.2]).len(), 2);
    }

    #[test]
    fn a_session_outside_the_others_prediction_interval_is_found() {
        // Others at two set points: (100, 102) and (50, 49): relative residuals ±1/101
        // and ±0.5/49.5, 2 degrees of freedom; the limit is t_2 at 99.9 % = 31.599.
        let others = vec![vec![100.0, 102.0], vec![50.0, 49.0], vec![7.0]];
        let s = ((2.0 / (101.0f64 * 101.0) + 2.0 * (0.5f64 / 49.5).powi(2)) / 2.0).sqrt();
        let c = outlier_check(&[200.0, 49.5, 7.0], &others).unwrap();
        assert_eq!(c.dof, 2);
        assert!((c.limit - 31.599).abs() < 1e-3, "{}", c.limit);
        let t0 = (200.0 / 101.0 - 1.0) / (s * 1.5f64.sqrt());
        assert!((c.t[0].unwrap() - t0).abs() < 1e-9 && t0 > c.limit);
        assert_eq!(c.t[1], Some(0.0));
        assert_eq!(c.t[2], None, "one other value: no check there");
        let c = outlier_check(&[103.0, 50.0, f64::NAN], &others).unwrap();
        assert!(c.t[0].unwrap() < c.limit && c.t[2].is_none());
        assert!(outlier_check(&[1.0], &[vec![1.0]]).is_none());
        // Identical others: any other value is outside.
        let c = outlier_check(&[5.1, 5.0], &[vec![5.0, 5.0], vec![5.0, 5.0]]).unwrap();
        assert_eq!((c.t[0], c.t[1]), (Some(f64::INFINITY), Some(0.0)));
    }

    /// The 95 % band covers the true curve in about 95 % of noisy data sets (the delta
    /// method is exact for a, c and close for b at this noise): 400 data sets, each 5
    /// pressures x 2 runs, checked at three pressures.
    #[test]
    fn the_band_covers_the_truth_at_its_level() {
        let law = |p: f64| 3000.0 * p.powf(-0.9) + 5.0;
        let x: Vec<f64> = [20.0, 30.0, 45.0, 60.0, 80.0]
            .iter()
            .flat_map(|p| [*p, *p])
            .collect();
        let mut rng = crate::render::rng::SplitMix64::new(7);
        let (mut inside, mut total) = (0, 0);
        for _ in 0..400 {
            let y: Vec<f64> = x
                .iter()
                .map(|p| law(*p) * (1.0 + 0.01 * rng.normal()))
                .collect();
            let (fit, cov) = fit_power_law_with_covariance(&x, &y).unwrap();
            let band = confidence_band(&fit, &cov.unwrap(), (25.0, 70.0), 3);
            assert!((band.t - t_two_sided(0.95, 7)).abs() < 1e-12);
            for (k, p) in band.pressure_kpa.iter().enumerate() {
                total += 1;
                inside += usize::from(band.lower[k] <= law(*p) && law(*p) <= band.upper[k]);
            }
        }
        let coverage = inside as f64 / total as f64;
        eprintln!("band coverage: {coverage:.4} of {total}");
        // 1200 checks (not independent within a data set): 0.95 within ±0.03.
        assert!((coverage - 0.95).abs() < 0.03, "coverage {coverage}");
    }
}
