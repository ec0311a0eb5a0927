//! The Kriging models a surrogate can be: a polynomial trend (constant, linear or
//! quadratic in the inputs) plus a stationary Gaussian process (squared-exponential or
//! Matérn 5/2 correlation), each fitted by egobox-gp. egobox's model is generic over the
//! trend and the kernel; [`Gp`] holds one of the six, so that a model file can hold any.

use std::panic::{catch_unwind, AssertUnwindSafe};

use egobox_gp::correlation_models::{Matern52Corr, SquaredExponentialCorr};
use egobox_gp::mean_models::{ConstantMean, LinearMean, QuadraticMean};
use egobox_gp::{GaussianProcess, GpParams};
use linfa::prelude::{Dataset, Fit};
use ndarray::{Array1, Array2};
use serde::{Deserialize, Serialize};

use super::{Prediction, SurrogateError};

/// Multistarts of egobox's likelihood maximization (its default).
pub const N_START: usize = egobox_gp::GP_OPTIM_N_START;

/// egobox's nugget (100 ε, relative to the process variance on the correlation
/// matrix's diagonal): numerical regularization only, the model interpolates.
pub const DEFAULT_NUGGET: f64 = 100.0 * f64::EPSILON;

/// Nuggets a fit chooses from by leave-one-out predictive density
/// ([`super::validation::Coverage::nlpd`]): from interpolation to a noise variance of 1%
/// of the process variance (FEM outputs carry mesh and convergence noise of that order).
pub const NUGGETS: [f64; 5] = [DEFAULT_NUGGET, 1e-8, 1e-6, 1e-4, 1e-2];

/// Trend of a Kriging model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MeanKind {
    /// Ordinary Kriging: a constant.
    Constant,
    /// Universal Kriging with a linear trend.
    Linear,
    /// Universal Kriging with a quadratic trend.
    Quadratic,
}

/// Correlation (kernel) of a Kriging model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CorrKind {
    /// exp(-Σ θ d²): very smooth responses.
    SquaredExponential,
    /// Matérn ν = 5/2: twice differentiable, less smooth than the squared exponential.
    Matern52,
}

/// Trend and kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct GpKind {
    /// Trend.
    pub mean: MeanKind,
    /// Kernel.
    pub corr: CorrKind,
}

impl GpKind {
    /// Every combination, simplest first.
    pub fn all() -> Vec<GpKind> {
        let mut v = Vec::new();
        for mean in [MeanKind::Constant, MeanKind::Linear, MeanKind::Quadratic] {
            for corr in [CorrKind::SquaredExponential, CorrKind::Matern52] {
                v.push(GpKind { mean, corr });
            }
        }
        v
    }
}

impl std::fmt::Display for GpKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let m = match self.mean {
            MeanKind::Constant => "constant",
            MeanKind::Linear => "linear",
            MeanKind::Quadratic => "quadratic",
        };
        let c = match self.corr {
            CorrKind::SquaredExponential => "squared_exponential",
            CorrKind::Matern52 => "matern52",
        };
        write!(f, "{m} trend, {c} kernel")
    }
}

impl std::str::FromStr for MeanKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "constant" => Ok(Self::Constant),
            "linear" => Ok(Self::Linear),
            "quadratic" => Ok(Self::Quadratic),
            o => Err(format!("unknown trend '{o}' (constant, linear, quadratic)")),
        }
    }
}

impl std::str::FromStr for CorrKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "squared_exponential" | "squared-exponential" | "se" => Ok(Self::SquaredExponential),
            "matern52" | "matern-5/2" => Ok(Self::Matern52),
            o => Err(format!(
                "unknown kernel '{o}' (squared_exponential, matern52)"
            )),
        }
    }
}

type GpOf<M, C> = GaussianProcess<f64, M, C>;

/// A fitted egobox Gaussian process of one of the [`GpKind`]s.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[allow(clippy::large_enum_variant)]
pub enum Gp {
    /// Constant trend, squared exponential.
    ConstantSquaredExponential(GpOf<ConstantMean, SquaredExponentialCorr>),
    /// Constant trend, Matérn 5/2.
    ConstantMatern52(GpOf<ConstantMean, Matern52Corr>),
    /// Linear trend, squared exponential.
    LinearSquaredExponential(GpOf<LinearMean, SquaredExponentialCorr>),
    /// Linear trend, Matérn 5/2.
    LinearMatern52(GpOf<LinearMean, Matern52Corr>),
    /// Quadratic trend, squared exponential.
    QuadraticSquaredExponential(GpOf<QuadraticMean, SquaredExponentialCorr>),
    /// Quadratic trend, Matérn 5/2.
    QuadraticMatern52(GpOf<QuadraticMean, Matern52Corr>),
}

/// Runs `body` on the inner Gaussian process, whatever its type.
macro_rules! with_gp {
    ($gp:expr, $g:ident => $body:expr) => {
        match $gp {
            Gp::ConstantSquaredExponential($g) => $body,
            Gp::ConstantMatern52($g) => $body,
            Gp::LinearSquaredExponential($g) => $body,
            Gp::LinearMatern52($g) => $body,
            Gp::QuadraticSquaredExponential($g) => $body,
            Gp::QuadraticMatern52($g) => $body,
        }
    };
}

fn gp_error(output: &str, why: impl std::fmt::Display) -> SurrogateError {
    SurrogateError::Gp {
        output: output.to_string(),
        why: why.to_string(),
    }
}

/// Runs egobox under `catch_unwind`: a panic in it (a numerical corner it does not
/// handle) becomes an error, not a crash.
fn guarded<T>(
    output: &str,
    f: impl FnOnce() -> Result<T, SurrogateError>,
) -> Result<T, SurrogateError> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "internal error".into());
            Err(gp_error(output, format!("egobox-gp failed: {msg}")))
        }
    }
}

fn matrix(x: &[Vec<f64>]) -> Array2<f64> {
    let cols = x.first().map(|r| r.len()).unwrap_or(0);
    Array2::from_shape_fn((x.len(), cols), |(i, j)| x[i][j])
}

/// Fits a Gaussian process of `kind` with `nugget` ([`DEFAULT_NUGGET`], [`NUGGETS`]) to
/// `x` (rows of inputs) and `y`; θ by maximum likelihood.
pub fn fit(
    kind: GpKind,
    nugget: f64,
    x: &[Vec<f64>],
    y: &[f64],
    output: &str,
) -> Result<Gp, SurrogateError> {
    let data = Dataset::new(matrix(x), Array1::from(y.to_vec()));
    macro_rules! fit_as {
        ($variant:ident, $mean:expr, $corr:expr) => {
            GpParams::new($mean, $corr)
                .n_start(N_START)
                .nugget(nugget)
                .fit(&data)
                .map(Gp::$variant)
                .map_err(|e| gp_error(output, e))
        };
    }
    guarded(output, || match (kind.mean, kind.corr) {
        (MeanKind::Constant, CorrKind::SquaredExponential) => {
            fit_as!(
                ConstantSquaredExponential,
                ConstantMean(),
                SquaredExponentialCorr()
            )
        }
        (MeanKind::Constant, CorrKind::Matern52) => {
            fit_as!(ConstantMatern52, ConstantMean(), Matern52Corr())
        }
        (MeanKind::Linear, CorrKind::SquaredExponential) => {
            fit_as!(
                LinearSquaredExponential,
                LinearMean(),
                SquaredExponentialCorr()
            )
        }
        (MeanKind::Linear, CorrKind::Matern52) => {
            fit_as!(LinearMatern52, LinearMean(), Matern52Corr())
        }
        (MeanKind::Quadratic, CorrKind::SquaredExponential) => {
            fit_as!(
                QuadraticSquaredExponential,
                QuadraticMean(),
                SquaredExponentialCorr()
            )
        }
        (MeanKind::Quadratic, CorrKind::Matern52) => {
            fit_as!(QuadraticMatern52, QuadraticMean(), Matern52Corr())
        }
    })
}

impl Gp {
    /// Mean and standard deviation at each point of `x`.
    pub fn predict(&self, x: &[Vec<f64>], output: &str) -> Result<Vec<Prediction>, SurrogateError> {
        let xs = matrix(x);
        guarded(output, || {
            let (mean, var) =
                with_gp!(self, g => g.predict_valvar(&xs)).map_err(|e| gp_error(output, e))?;
            Ok(mean
                .iter()
                .zip(var.iter())
                .map(|(m, v)| Prediction {
                    mean: *m,
                    std: v.max(0.0).sqrt(),
                })
                .collect())
        })
    }

    /// Fitted correlation parameters θ.
    pub fn theta(&self) -> Vec<f64> {
        with_gp!(self, g => g.theta().to_vec())
    }
}
