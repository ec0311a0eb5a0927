//! The power law y = a x^b + c of a quantity against pressure: Levenberg-Marquardt (the
//! `levenberg_marquardt` crate) from a log-log start, with standard errors from the
//! Jacobian, refused with fewer than three distinct pressures.

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{storage::Owned, Dyn, Matrix3, OMatrix, OVector, Vector3, U3};
use serde::{Deserialize, Serialize};

use super::error::FitError;

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
    fit_power_law_with_covariance(x, y).map(|(fit, _)| fit)
}

/// [`fit_power_law`] with the covariance of (a, b, c): (JᵀJ)⁻¹ SSE / (n - 3) at the
/// optimum (the matrix whose diagonal gives [`PowerLawErrors`]); `None` with only 3
/// points or a singular JᵀJ. A confidence band of the curve follows from it by the
/// delta method.
pub fn fit_power_law_with_covariance(
    x: &[f64],
    y: &[f64],
) -> Result<(PowerLawFit, Option<Matrix3<f64>>), FitError> {
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
    let covariance = problem
        .jacobian()
        .and_then(|j| {
            let jtj: Matrix3<f64> = j.transpose() * &j;
            jtj.try_inverse()
        })
        .filter(|_| n > 3)
        .map(|inv| inv * (sse / (n as f64 - 3.0)));
    let errors = covariance
        .map(|cov| PowerLawErrors {
            a: cov[(0, 0)].sqrt(),
            b: cov[(1, 1)].sqrt(),
            c: cov[(2, 2)].sqrt(),
        })
        .unwrap_or(PowerLawErrors {
            a: f64::NAN,
            b: f64::NAN,
            c: f64::NAN,
        });
    let fit = PowerLawFit {
        a: p.x,
        b: p.y,
        c: p.z,
        std_errors: errors,
        r_squared,
        rmse: (sse / n as f64).sqrt(),
        n,
    };
    Ok((fit, covariance))
}

#[cfg(test)]
mod tests {
    use super::*;

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
        // The covariance's diagonal is the squared standard errors; it is symmetric.
        let (g, cov) = fit_power_law_with_covariance(&x, &y).unwrap();
        let cov = cov.unwrap();
        assert_eq!(g, f);
        for (k, e) in [f.std_errors.a, f.std_errors.b, f.std_errors.c]
            .iter()
            .enumerate()
        {
            assert!((cov[(k, k)].sqrt() / e - 1.0).abs() < 1e-12, "{cov}");
        }
        assert!((cov - cov.transpose()).abs().max() <= 1e-12 * cov.abs().max());
        // Three points: no covariance.
        let (_, none) = fit_power_law_with_covariance(&x[..3], &y[..3]).unwrap();
        assert!(none.is_none());
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
}
