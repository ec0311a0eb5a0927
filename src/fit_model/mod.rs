//! The actuator model fitted to measurements (`bendscope fit-model`): config fields
//! (geometry, material coefficients, `material.scale`) chosen so that the simulated radius
//! (or curvature) matches a `process` output's at the measured pressures.
//!
//! Objective: the relative deviations sim / measured − 1 at every measured row (every
//! pressure weighs the same whatever its radius), minimized by Levenberg-Marquardt (the
//! `levenberg-marquardt` crate) with a forward-difference Jacobian, one simulation per
//! column. Bounds by the sine transform of MINUIT and lmfit (p = lo + (hi − lo)(sin q +
//! 1)/2: LM moves q freely, p stays inside); a simulation that fails (parameters the
//! geometry refuses, Newton not converging) returns a large residual, so LM shortens its
//! step. Standard errors from the Jacobian in the parameters at the optimum,
//! sqrt(diag((JᵀJ)⁻¹) SSE / (m − k)) (relative residuals, so in the parameters' units).
//! Each simulation is warm-started from the previous one ([`evaluate`]).
//!
//! A geometric parameter can change the number of elements through a wall as it moves
//! (the mesh cuts every interval into elements no longer than the mesh size): the
//! objective is then piecewise smooth; the report counts such changes.

pub mod evaluate;
pub mod measured;
pub mod output;
pub mod params;

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::PathBuf;
use std::time::Instant;

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DMatrix, DVector, Dyn, Owned};
use serde::Serialize;

use crate::fem::actuator::ActuatorConfig;
use crate::fem::FemError;

pub use evaluate::{EvaluationStats, Evaluator, ModelCurve};
pub use measured::Measured;
pub use output::write_fit_model;
pub use params::{parse_free, with_values, FreeParameter};

/// Errors of the model fit.
#[derive(Debug, thiserror::Error)]
pub enum FitModelError {
    /// The measurements cannot be read.
    #[error(transparent)]
    Table(#[from] crate::table::TableError),
    /// The measurements are unusable.
    #[error("{path}: {why}")]
    Measured {
        /// The file.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
    /// A free parameter is not usable.
    #[error("--free {name}: {why}")]
    Parameter {
        /// The parameter.
        name: String,
        /// What is wrong and what to do.
        why: String,
    },
    /// The model failed.
    #[error(transparent)]
    Fem(#[from] FemError),
    /// A result file could not be written.
    #[error("cannot write the model fit: {why}: check the output folder's space and permissions")]
    Output {
        /// What failed.
        why: String,
    },
}

/// The measured quantity fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Quantity {
    /// Radius of curvature, mm.
    Radius,
    /// Curvature, 1/m.
    Curvature,
}

/// Residual of a failed simulation at every row (a deviation of 1000%).
pub const FAILED_RESIDUAL: f64 = 10.0;
/// Forward-difference step, relative to the parameter (or to 1e-3 of its range when
/// smaller).
pub const FD_RELATIVE_STEP: f64 = 1e-4;
/// LM stops when a step changes the (transformed) parameters by less than this, relative.
pub const XTOL: f64 = 1e-6;
/// LM stops when a step lowers the sum of squares by less than this, relative.
pub const FTOL: f64 = 1e-10;
/// LM's budget: patience x (parameters + 1) residual evaluations (each Jacobian costs one
/// simulation per parameter on top).
pub const LM_PATIENCE: usize = 12;

/// RMS relative deviation of a fit above which it is reported as poor, %: ten times the
/// radius accuracy of a measurement (0.5%), so the model, not the data, misses.
pub const POOR_FIT_RMS_PCT: f64 = 5.0;

/// The warning for a fit whose RMS relative deviation is above [`POOR_FIT_RMS_PCT`].
pub fn poor_fit_note(rms_rel_pct: f64, max_rel_dev_pct: f64) -> Option<String> {
    (rms_rel_pct.is_nan() || rms_rel_pct > POOR_FIT_RMS_PCT).then(|| {
        format!(
            "poor fit: rms deviation {rms_rel_pct:.1}% (max {max_rel_dev_pct:.1}%) is above {POOR_FIT_RMS_PCT}%: the model does not follow the measurement; check the config (geometry, material, layers) and the measurement, or free other parameters, before using fitted.toml"
        )
    })
}

/// Settings of a fit.
#[derive(Debug, Clone)]
pub struct FitModelSettings {
    /// The quantity fitted.
    pub quantity: Quantity,
}

/// Progress of a fit, after each simulation.
#[derive(Debug, Clone, Copy)]
pub struct FitProgress {
    /// Simulations so far.
    pub evaluations: usize,
    /// RMS relative deviation of this simulation, % (None when it failed).
    pub rms_rel_pct: Option<f64>,
}

/// The result of a fit.
#[derive(Debug, Clone, Serialize)]
pub struct ModelFit {
    /// Fitted values by name.
    pub parameters: Vec<(String, f64)>,
    /// Standard errors by name (NaN without a degree of freedom left).
    pub std_errors: Vec<(String, f64)>,
    /// The free parameters (initial values and bounds).
    pub free: Vec<FreeParameter>,
    /// The fitted config.
    #[serde(skip)]
    pub config: ActuatorConfig,
    /// The quantity fitted.
    pub quantity: Quantity,
    /// Pressures simulated, kPa.
    pub pressures_kpa: Vec<f64>,
    /// The model at the initial values.
    #[serde(skip)]
    pub initial: ModelCurve,
    /// The model at the fitted values.
    #[serde(skip)]
    pub fitted: ModelCurve,
    /// RMS radius deviation over the measured rows, mm.
    pub rmse_mm: f64,
    /// Largest |relative deviation| of the fitted quantity, %.
    pub max_rel_dev_pct: f64,
    /// RMS relative deviation of the fitted quantity at the initial values, %.
    pub initial_rms_rel_pct: f64,
    /// RMS relative deviation of the fitted quantity at the fitted values, %.
    pub rms_rel_pct: f64,
    /// Counters of the simulations.
    pub stats: EvaluationStats,
    /// Wall time, s.
    pub seconds: f64,
    /// How LM stopped.
    pub termination: String,
    /// What a user must know (a parameter at its bound, mesh changes, LM not converged).
    pub notes: Vec<String>,
}

/// Evaluations kept for reuse (LM asks for the residuals and then the Jacobian at the
/// same point).
const CACHE_SIZE: usize = 16;

struct Problem<'a> {
    base: &'a ActuatorConfig,
    free: &'a [FreeParameter],
    measured: &'a Measured,
    quantity: Quantity,
    /// Index into the simulated pressures of every measured row.
    row_index: Vec<usize>,
    evaluator: RefCell<Evaluator>,
    cache: RefCell<HashMap<Vec<u64>, Option<ModelCurve>>>,
    jacobian_p: RefCell<Option<(Vec<f64>, DMatrix<f64>)>>,
    q: DVector<f64>,
    progress: RefCell<&'a mut dyn FnMut(FitProgress)>,
}

/// p from q (sine transform).
fn to_p(f: &FreeParameter, q: f64) -> f64 {
    f.lower + (f.upper - f.lower) * (q.sin() + 1.0) / 2.0
}

/// q from p, a hair inside the bounds (dp/dq vanishes on them).
fn to_q(f: &FreeParameter, p: f64) -> f64 {
    let t = (2.0 * (p - f.lower) / (f.upper - f.lower) - 1.0).clamp(-0.999_999, 0.999_999);
    t.asin()
}

impl Problem<'_> {
    fn values(&self, q: &DVector<f64>) -> Vec<f64> {
        self.free
            .iter()
            .zip(q.iter())
            .map(|(f, q)| to_p(f, *q))
            .collect()
    }

    fn curve(&self, p: &[f64]) -> Option<ModelCurve> {
        let key: Vec<u64> = p.iter().map(|v| v.to_bits()).collect();
        if let Some(c) = self.cache.borrow().get(&key) {
            return c.clone();
        }
        let curve = with_values(self.base, self.free, p)
            .ok()
            .and_then(|cfg| self.evaluator.borrow_mut().simulate(&cfg).ok());
        let res = curve.as_ref().map(|c| self.residuals_of(c));
        let rms = res.map(|r| 100.0 * (r.norm_squared() / r.len() as f64).sqrt());
        let evaluations = self.evaluator.borrow().stats.evaluations;
        (self.progress.borrow_mut())(FitProgress {
            evaluations,
            rms_rel_pct: rms,
        });
        let mut cache = self.cache.borrow_mut();
        if cache.len() >= CACHE_SIZE {
            cache.clear();
        }
        cache.insert(key, curve.clone());
        curve
    }

    fn residuals_of(&self, c: &ModelCurve) -> DVector<f64> {
        DVector::from_iterator(
            self.row_index.len(),
            self.row_index
                .iter()
                .enumerate()
                .map(|(row, k)| match self.quantity {
                    Quantity::Radius => c.radius_mm[*k] / self.measured.radius_mm[row] - 1.0,
                    Quantity::Curvature => {
                        c.curvature_per_m[*k] / self.measured.curvature_per_m[row] - 1.0
                    }
                }),
        )
    }

    fn residuals_at(&self, p: &[f64]) -> Option<DVector<f64>> {
        self.curve(p).map(|c| self.residuals_of(&c))
    }

    /// The Jacobian in the parameters p (forward differences, stepping inwards at a
    /// bound, the other way when a step fails).
    fn jacobian_in_p(&self, p: &[f64]) -> Option<DMatrix<f64>> {
        if let Some((at, j)) = self.jacobian_p.borrow().as_ref() {
            if at == p {
                return Some(j.clone());
            }
        }
        let r0 = self.residuals_at(p)?;
        let mut j = DMatrix::zeros(r0.len(), p.len());
        for (k, f) in self.free.iter().enumerate() {
            let h = FD_RELATIVE_STEP * p[k].abs().max(1e-3 * (f.upper - f.lower));
            let mut column = None;
            for dir in [1.0, -1.0] {
                let step = if p[k] + dir * h > f.upper || p[k] + dir * h < f.lower {
                    continue;
                } else {
                    dir * h
                };
                let mut pk = p.to_vec();
                pk[k] += step;
                if let Some(r) = self.residuals_at(&pk) {
                    column = Some((r - &r0) / step);
                    break;
                }
            }
            j.set_column(k, &column?);
        }
        *self.jacobian_p.borrow_mut() = Some((p.to_vec(), j.clone()));
        Some(j)
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, q: &DVector<f64>) {
        self.q.copy_from(q);
    }
    fn params(&self) -> DVector<f64> {
        self.q.clone()
    }
    fn residuals(&self) -> Option<DVector<f64>> {
        let p = self.values(&self.q);
        Some(
            self.residuals_at(&p)
                .unwrap_or_else(|| DVector::from_element(self.row_index.len(), FAILED_RESIDUAL)),
        )
    }
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let p = self.values(&self.q);
        let mut j = self.jacobian_in_p(&p)?;
        for (k, f) in self.free.iter().enumerate() {
            let dp_dq = (f.upper - f.lower) / 2.0 * self.q[k].cos();
            let mut col = j.column_mut(k);
            col *= dp_dq;
        }
        Some(j)
    }
}

/// Fits the free parameters of `base` to `measured` (see the module doc); `progress`
/// sees every simulation.
pub fn fit_model(
    base: &ActuatorConfig,
    free: &[FreeParameter],
    measured: &Measured,
    settings: &FitModelSettings,
    progress: &mut dyn FnMut(FitProgress),
) -> Result<ModelFit, FitModelError> {
    let started = Instant::now();
    let pressures = measured.pressures();
    let row_index: Vec<usize> = measured
        .pressure_kpa
        .iter()
        .map(|p| {
            pressures
                .iter()
                .position(|q| (q - p).abs() < 1e-9)
                .unwrap_or(0)
        })
        .collect();
    if row_index.len() < free.len() {
        return Err(FitModelError::Measured {
            path: measured.path.clone(),
            why: format!(
                "{} measured row(s) for {} free parameter(s): measure more pressures or free fewer parameters",
                row_index.len(),
                free.len()
            ),
        });
    }
    let initial_values: Vec<f64> = free.iter().map(|f| f.initial).collect();
    // The initial model must run: its failure is the user's to fix, not LM's.
    let initial_cfg = with_values(base, free, &initial_values)?;
    let mut evaluator = Evaluator::new(pressures.clone());
    let initial = evaluator.simulate(&initial_cfg)?;
    progress(FitProgress {
        evaluations: 1,
        rms_rel_pct: None,
    });
    let q0 = DVector::from_iterator(free.len(), free.iter().map(|f| to_q(f, f.initial)));
    let problem = Problem {
        base,
        free,
        measured,
        quantity: settings.quantity,
        row_index,
        evaluator: RefCell::new(evaluator),
        cache: RefCell::new(HashMap::new()),
        jacobian_p: RefCell::new(None),
        q: q0,
        progress: RefCell::new(progress),
    };
    let initial_res = problem.residuals_of(&initial);
    let (problem, report) = LevenbergMarquardt::new()
        .with_xtol(XTOL)
        .with_ftol(FTOL)
        .with_patience(LM_PATIENCE)
        .minimize(problem);
    let p = problem.values(&problem.q);
    let fitted = problem.curve(&p).ok_or_else(|| FemError::Model {
        why: "the model at the fitted values did not run".into(),
    })?;
    let res = problem.residuals_of(&fitted);
    let m = res.len();
    let k = free.len();
    let sse = res.norm_squared();
    let std = problem
        .jacobian_in_p(&p)
        .and_then(|j| (j.transpose() * &j).try_inverse())
        .filter(|_| m > k)
        .map(|cov| {
            (0..k)
                .map(|i| (cov[(i, i)] * sse / (m - k) as f64).sqrt())
                .collect()
        })
        .unwrap_or_else(|| vec![f64::NAN; k]);
    let config = with_values(base, free, &p)?;
    let mut notes = Vec::new();
    if !report.termination.was_successful() {
        notes.push(format!(
            "the fit stopped before converging ({:?}): check the result, or free fewer parameters",
            report.termination
        ));
    }
    for (f, v) in free.iter().zip(&p) {
        if (v - f.lower).abs() < 1e-3 * (f.upper - f.lower)
            || (f.upper - v).abs() < 1e-3 * (f.upper - f.lower)
        {
            notes.push(format!(
                "{} = {v} is at its bound ({}:{}): widen it with --free {}=LO:HI",
                f.name, f.lower, f.upper, f.name
            ));
        }
    }
    let stats = problem.evaluator.borrow().stats;
    if stats.mesh_changes > 0 {
        notes.push(format!(
            "the mesh changed {} time(s) between simulations (a geometric parameter crossed an element boundary): the objective is piecewise smooth; a finer mesh makes the steps smaller",
            stats.mesh_changes
        ));
    }
    let rows = &problem.row_index;
    let rmse_mm = (rows
        .iter()
        .enumerate()
        .map(|(row, k)| (fitted.radius_mm[*k] - measured.radius_mm[row]).powi(2))
        .sum::<f64>()
        / m as f64)
        .sqrt();
    let rms = |r: &DVector<f64>| 100.0 * (r.norm_squared() / r.len() as f64).sqrt();
    let max_rel_dev_pct = 100.0 * res.amax();
    notes.extend(poor_fit_note(rms(&res), max_rel_dev_pct));
    Ok(ModelFit {
        parameters: free
            .iter()
            .map(|f| f.name.clone())
            .zip(p.iter().copied())
            .collect(),
        std_errors: free.iter().map(|f| f.name.clone()).zip(std).collect(),
        free: free.to_vec(),
        config,
        quantity: settings.quantity,
        pressures_kpa: pressures,
        initial,
        fitted,
        rmse_mm,
        max_rel_dev_pct,
        initial_rms_rel_pct: rms(&initial_res),
        rms_rel_pct: rms(&res),
        stats,
        seconds: started.elapsed().as_secs_f64(),
        termination: format!("{:?}", report.termination),
        notes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fit_above_the_threshold_is_called_poor() {
        let note = poor_fit_note(15.7, 28.04).unwrap();
        assert!(
            note.starts_with("poor fit: rms deviation 15.7% (max 28.0%) is above 5%"),
            "{note}"
        );
        assert_eq!(poor_fit_note(POOR_FIT_RMS_PCT, 9.0), None);
        assert_eq!(poor_fit_note(0.3, 0.5), None);
        assert!(poor_fit_note(f64::NAN, f64::NAN).is_some());
    }
}
