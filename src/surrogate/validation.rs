//! Cross-validation of a surrogate: leave-one-out and k-fold predictions (the model is
//! refitted, hyperparameters included, without the held-out points) and their scores.

use serde::{Deserialize, Serialize};

use super::gp::{fit, GpKind};
use super::SurrogateError;

/// Fewest points a surrogate is fitted on (leave-one-out on fewer says little).
pub const MIN_POINTS: usize = 5;

/// Accuracy of predictions against the true values.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Scores {
    /// Coefficient of determination 1 − Σ(y − ŷ)² / Σ(y − ȳ)² (Q² when ŷ is
    /// cross-validated).
    pub r2: f64,
    /// Explained variance 1 − Var(y − ŷ) / Var(y) (as scikit-learn's
    /// `explained_variance_score`: a constant bias is not counted).
    pub explained_variance: f64,
    /// Largest |y − ŷ|, in the output's unit.
    pub max_error: f64,
    /// Root mean square of y − ŷ, in the output's unit.
    pub rmse: f64,
}

fn variance(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n
}

impl Scores {
    /// Scores of `pred` against `y` (same length, at least 2).
    pub fn of(y: &[f64], pred: &[f64]) -> Scores {
        let res: Vec<f64> = y.iter().zip(pred).map(|(a, b)| a - b).collect();
        let var_y = variance(y);
        let ss_res = res.iter().map(|r| r * r).sum::<f64>() / y.len() as f64;
        Scores {
            r2: 1.0 - ss_res / var_y,
            explained_variance: 1.0 - variance(&res) / var_y,
            max_error: res.iter().fold(0.0, |m, r| m.max(r.abs())),
            rmse: ss_res.sqrt(),
        }
    }
}

/// Cross-validation of the chosen model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Validation {
    /// Leave-one-out.
    pub loo: Scores,
    /// k-fold.
    pub kfold: Scores,
    /// k of the k-fold.
    pub folds: usize,
}

/// Predictions of each point by a model of `kind` fitted without its fold. Point i is in
/// fold i mod `folds` (deterministic; `folds` = number of points is leave-one-out).
pub fn cross_predictions(
    kind: GpKind,
    x: &[Vec<f64>],
    y: &[f64],
    folds: usize,
    output: &str,
) -> Result<Vec<f64>, SurrogateError> {
    let mut pred = vec![f64::NAN; y.len()];
    for k in 0..folds {
        let (mut xt, mut yt, mut xv, mut iv) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for i in 0..y.len() {
            if i % folds == k {
                xv.push(x[i].clone());
                iv.push(i);
            } else {
                xt.push(x[i].clone());
                yt.push(y[i]);
            }
        }
        if xv.is_empty() {
            continue;
        }
        let gp = fit(kind, &xt, &yt, output)?;
        for (i, p) in iv.into_iter().zip(gp.predict(&xv, output)?) {
            pred[i] = p.mean;
        }
    }
    Ok(pred)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scores_of_exact_biased_and_noisy_predictions() {
        let y = [1.0, 2.0, 3.0, 4.0];
        let s = Scores::of(&y, &y);
        assert_eq!((s.r2, s.explained_variance, s.max_error), (1.0, 1.0, 0.0));
        // A constant bias of 0.5: explained variance 1, R² = 1 − 0.25/1.25.
        let s = Scores::of(&y, &[1.5, 2.5, 3.5, 4.5]);
        assert!((s.explained_variance - 1.0).abs() < 1e-12);
        assert!((s.r2 - 0.8).abs() < 1e-12);
        assert!((s.max_error - 0.5).abs() < 1e-12);
    }

    #[test]
    fn leave_one_out_of_a_smooth_function_is_accurate() {
        // y = x0² + sin(x1) on a 4 × 4 grid: LOO R² of a quadratic-trend Kriging > 0.95.
        let mut x = Vec::new();
        for i in 0..4 {
            for j in 0..4 {
                x.push(vec![i as f64, j as f64]);
            }
        }
        let y: Vec<f64> = x.iter().map(|p| p[0] * p[0] + p[1].sin()).collect();
        let kind = GpKind {
            mean: super::super::MeanKind::Quadratic,
            corr: super::super::CorrKind::SquaredExponential,
        };
        let pred = cross_predictions(kind, &x, &y, y.len(), "y").unwrap();
        let s = Scores::of(&y, &pred);
        assert!(s.r2 > 0.95, "{s:?}");
    }
}
