//! Design optimization on surrogates: objectives and constraints are columns of
//! `designs.csv`, each modelled by a Gaussian process ([`crate::surrogate`]); one
//! objective is optimized by Bayesian optimization ([`ego`], egobox-ego), two by a Pareto
//! front ([`pareto`], NSGA-II); the best designs are then simulated
//! with the FEM ([`verify`]) and reported beside the surrogates' predictions.
//!
//! Data flows: [`plan`] (the TOML plan) -> [`Problem`] (surrogates fitted on the designs;
//! `height_mm` computed exactly from the geometry) -> [`ego`] or [`pareto`] ->
//! [`verify`] -> the outputs of [`optimize_to`] (`pareto.csv` or `evaluations.csv`,
//! `verified.csv`, `plots/`, `models/`, `summary.json`).

pub mod ego;
pub mod pareto;
pub mod plan;
pub mod verify;

use std::path::{Path, PathBuf};

use serde::Serialize;

pub use plan::{load_plan, Goal, LoadedPlan, Op, Plan, PlanConstraint};

use crate::fem::actuator::ActuatorConfig;
use crate::report::{plot_xy, write_json, Series};
use crate::surrogate::{
    fit_surrogate, read_designs, FitSettings, Prediction, SurrogateError, SurrogateModel,
    Validation,
};
use crate::table::{write_csv, Column};

/// Errors of an optimization.
#[derive(Debug, thiserror::Error)]
pub enum OptimizeError {
    /// The plan is not valid.
    #[error("{path}: {why}")]
    Plan {
        /// The plan file.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
    /// A surrogate could not be fitted or evaluated.
    #[error(transparent)]
    Surrogate(#[from] SurrogateError),
    /// A design input could not be set on the actuator config.
    #[error("input {name}: {why}")]
    Input {
        /// The input.
        name: String,
        /// What is wrong and what to do.
        why: String,
    },
    /// The optimizer failed.
    #[error("{which}: {why}")]
    Optimizer {
        /// Which optimizer.
        which: &'static str,
        /// What failed.
        why: String,
    },
    /// An output could not be written.
    #[error("cannot write {path}: {why}")]
    Output {
        /// The file.
        path: PathBuf,
        /// Cause.
        why: String,
    },
}

/// Sets design input `name` of `cfg` to `value`: a config field as every command names
/// one (`geometry.f`, `layer.paper.thickness_mm`, a bare field of one section:
/// [`crate::fem::params`]).
pub fn set_input(
    cfg: &ActuatorConfig,
    name: &str,
    value: f64,
) -> Result<ActuatorConfig, OptimizeError> {
    crate::fem::params::config_with_number(cfg, name, value).map_err(|e| OptimizeError::Input {
        name: e.name,
        why: e.why,
    })
}

/// A design as the surrogates see it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Evaluation {
    /// Inputs, in plan order (integers rounded).
    pub x: Vec<f64>,
    /// Prediction of every column of [`Problem::columns`] (height: exact, std 0).
    pub values: Vec<Prediction>,
    /// Constraint margins (<= 0: met), in plan order.
    pub margins: Vec<f64>,
    /// Every constraint met (on the predicted means).
    pub feasible: bool,
}

impl Evaluation {
    /// Total violation of the constraints (0 when feasible).
    pub fn violation(&self) -> f64 {
        self.margins.iter().map(|m| m.max(0.0)).sum()
    }
}

/// The optimization problem: inputs with bounds, the columns of the objectives and
/// constraints and their surrogates.
#[derive(Debug, Clone)]
pub struct Problem {
    /// The plan.
    pub plan: Plan,
    /// Config the inputs are set on (exact height, re-simulations).
    pub base: ActuatorConfig,
    /// Every column the plan names, each once: objectives first.
    pub columns: Vec<String>,
    /// Surrogate of each column (`None`: `height_mm`, computed from the geometry).
    pub models: Vec<Option<SurrogateModel>>,
    /// (min, max) of each input over the designs (the surrogates extrapolate beyond).
    pub design_ranges: Vec<(f64, f64)>,
}

impl Problem {
    /// Fits a surrogate of every column the plan names (except `height_mm`) on its designs.
    pub fn fit(loaded: &LoadedPlan) -> Result<Problem, OptimizeError> {
        let inputs = loaded.input_names();
        let wanted = loaded.surrogate_columns();
        let designs = read_designs(&loaded.designs, &inputs, &wanted)?;
        let mut columns: Vec<String> = Vec::new();
        let names = loaded
            .plan
            .objectives
            .iter()
            .map(|o| &o.column)
            .chain(loaded.plan.constraints.iter().map(|c| &c.column));
        for c in names {
            if !columns.contains(c) {
                columns.push(c.clone());
            }
        }
        let models = columns
            .iter()
            .map(|c| {
                if c == plan::HEIGHT_COLUMN {
                    Ok(None)
                } else {
                    fit_surrogate(&designs, c, &FitSettings::default()).map(Some)
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        let design_ranges = (0..inputs.len())
            .map(|j| {
                designs
                    .x
                    .iter()
                    .map(|x| x[j])
                    .filter(|v| v.is_finite())
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                        (lo.min(v), hi.max(v))
                    })
            })
            .collect();
        Ok(Problem {
            plan: loaded.plan.clone(),
            base: loaded.base.clone(),
            columns,
            models,
            design_ranges,
        })
    }

    /// The plan's input bounds that reach past the designs' range of that input, each as
    /// a warning: the surrogates extrapolate there.
    pub fn bounds_beyond_designs(&self) -> Vec<String> {
        self.plan
            .inputs
            .iter()
            .zip(&self.design_ranges)
            .filter(|(i, (lo, hi))| i.min < *lo || i.max > *hi)
            .map(|(i, (lo, hi))| {
                format!(
                    "input {}: the bounds {} to {} reach past the designs ({lo} to {hi}): the surrogates extrapolate there, trust the FEM check (verified.csv) over them",
                    i.name, i.min, i.max
                )
            })
            .collect()
    }

    /// Inputs of design `x` outside the designs' range (`name = v (designs: lo to hi)`).
    pub fn outside_designs(&self, x: &[f64]) -> Vec<String> {
        self.plan
            .inputs
            .iter()
            .zip(&self.design_ranges)
            .zip(x)
            .filter(|((_, (lo, hi)), v)| **v < *lo || **v > *hi)
            .map(|((i, (lo, hi)), v)| format!("{} = {v} (designs: {lo} to {hi})", i.name))
            .collect()
    }

    /// Index of `column` in [`Problem::columns`].
    pub fn column_index(&self, column: &str) -> usize {
        self.columns.iter().position(|c| c == column).unwrap_or(0)
    }

    /// `x` clamped to the bounds, integer inputs rounded.
    pub fn snap(&self, x: &[f64]) -> Vec<f64> {
        self.plan
            .inputs
            .iter()
            .zip(x)
            .map(|(i, v)| {
                let v = v.clamp(i.min, i.max);
                if i.integer {
                    v.round().clamp(i.min.ceil(), i.max.floor())
                } else {
                    v
                }
            })
            .collect()
    }

    /// The actuator config of design `x`.
    pub fn config(&self, x: &[f64]) -> Result<ActuatorConfig, OptimizeError> {
        let mut cfg = self.base.clone();
        for (i, v) in self.plan.inputs.iter().zip(x) {
            cfg = set_input(&cfg, &i.name, *v)?;
        }
        Ok(cfg)
    }

    /// Evaluates designs on the surrogates.
    pub fn evaluate(&self, xs: &[Vec<f64>]) -> Result<Vec<Evaluation>, OptimizeError> {
        let xs: Vec<Vec<f64>> = xs.iter().map(|x| self.snap(x)).collect();
        let mut per_column = Vec::new();
        for m in &self.models {
            per_column.push(match m {
                Some(model) => model.predict_many(&xs)?,
                None => xs
                    .iter()
                    .map(|x| {
                        self.config(x).map(|c| Prediction {
                            mean: c.height_mm(),
                            std: 0.0,
                        })
                    })
                    .collect::<Result<Vec<_>, _>>()?,
            });
        }
        Ok(xs
            .into_iter()
            .enumerate()
            .map(|(k, x)| {
                let values: Vec<Prediction> = per_column.iter().map(|c| c[k]).collect();
                let margins: Vec<f64> = self
                    .plan
                    .constraints
                    .iter()
                    .map(|c| c.margin(values[self.column_index(&c.column)].mean))
                    .collect();
                let feasible = margins.iter().all(|m| *m <= 0.0);
                Evaluation {
                    x,
                    values,
                    margins,
                    feasible,
                }
            })
            .collect())
    }

    /// Objective `k` of an evaluation as a quantity to minimize.
    pub fn cost(&self, e: &Evaluation, k: usize) -> f64 {
        let o = &self.plan.objectives[k];
        let v = e.values[self.column_index(&o.column)].mean;
        match o.goal {
            Goal::Minimize => v,
            Goal::Maximize => -v,
        }
    }

    /// Scaled distance between two designs (inputs divided by their range).
    pub fn distance(&self, a: &[f64], b: &[f64]) -> f64 {
        self.plan
            .inputs
            .iter()
            .zip(a.iter().zip(b))
            .map(|(i, (p, q))| ((p - q) / (i.max - i.min)).powi(2))
            .sum::<f64>()
            .sqrt()
    }
}

/// Smallest scaled distance between two designs chosen for re-simulation.
pub const MIN_DISTINCT: f64 = 0.02;

/// Surrogate accuracy of one column (summary).
#[derive(Debug, Clone, Serialize)]
pub struct ColumnSurrogate {
    /// Column.
    pub column: String,
    /// Model kind.
    pub kind: String,
    /// Training points.
    pub points: usize,
    /// Cross-validation.
    pub validation: Validation,
}

/// What [`optimize_to`] found.
#[derive(Debug, Clone, Serialize)]
pub struct OptimizeReport {
    /// `bayesian` (one objective) or `nsga2` (two).
    pub method: String,
    /// Input names.
    pub inputs: Vec<String>,
    /// Columns, objectives first.
    pub columns: Vec<String>,
    /// Surrogate accuracy per column.
    pub surrogates: Vec<ColumnSurrogate>,
    /// Surrogate evaluations made by the optimizer.
    pub evaluations: usize,
    /// One objective: the optimum (first) and the next best distinct designs; two: the
    /// feasible Pareto front, ordered by the first objective.
    pub best: Vec<Evaluation>,
    /// The re-simulated designs.
    pub verified: Vec<verify::Verified>,
    /// Extrapolation past the designs: input bounds beyond them, an optimum outside them.
    pub warnings: Vec<String>,
}

/// Options of a run beside the plan.
#[derive(Debug, Clone, Default)]
pub struct OptimizeOptions {
    /// Overrides the plan's `resimulate`.
    pub resimulate: Option<usize>,
}

/// Runs a plan: fits the surrogates, optimizes, re-simulates the best designs with the
/// FEM into `out/runs/`, writes the tables, plot and summary; `progress(what)` sees each
/// stage and FEM step.
pub fn optimize_to(
    loaded: &LoadedPlan,
    out: &Path,
    options: &OptimizeOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<OptimizeReport, OptimizeError> {
    let io = |path: &Path, e: &dyn std::fmt::Display| OptimizeError::Output {
        path: path.to_path_buf(),
        why: e.to_string(),
    };
    std::fs::create_dir_all(out.join("models")).map_err(|e| io(out, &e))?;
    progress("fitting surrogates");
    let problem = Problem::fit(loaded)?;
    for (c, m) in problem.columns.iter().zip(&problem.models) {
        if let Some(m) = m {
            m.save(
                &out.join("models")
                    .join(crate::io::bounded_file_name(c, "json")),
            )?;
        }
    }
    let mut warnings = problem.bounds_beyond_designs();
    let n_resim = options.resimulate.unwrap_or(loaded.plan.resimulate);
    let (method, evaluated, best) = if problem.plan.objectives.len() == 1 {
        progress("bayesian optimization");
        let all = ego::optimize(&problem, &design_points(&problem, loaded)?)?;
        let best = ego::distinct_best(&problem, &all, n_resim.max(1));
        ("bayesian", all, best)
    } else {
        progress("nsga-ii");
        let front = pareto::front(&problem)?;
        ("nsga2", front.evaluated, front.front)
    };
    let table = out.join(if method == "nsga2" {
        "pareto.csv"
    } else {
        "evaluations.csv"
    });
    let rows = if method == "nsga2" { &best } else { &evaluated };
    write_evaluations(&table, &problem, rows).map_err(|e| io(&table, &e))?;
    let chosen = if method == "nsga2" {
        pareto::spread(&best, n_resim)
    } else {
        best.iter().take(n_resim).cloned().collect()
    };
    if let Some(first) = best.first() {
        let outside = problem.outside_designs(&first.x);
        if !outside.is_empty() {
            warnings.push(format!(
                "the {} lies outside the designs: {}: the surrogates extrapolate; see the FEM check (verified.csv, column extrapolated)",
                if method == "nsga2" { "front's first design" } else { "optimum" },
                outside.join(", ")
            ));
        }
    }
    let verified = verify::resimulate(&problem, &chosen, &out.join("runs"), progress)?;
    verify::write_verified(&out.join("verified.csv"), &problem, &verified)
        .map_err(|e| io(&out.join("verified.csv"), &e))?;
    if method == "nsga2" {
        plot_front(out, &problem, loaded, &best, &verified)?;
    }
    let report = OptimizeReport {
        method: method.into(),
        inputs: problem.plan.inputs.iter().map(|i| i.name.clone()).collect(),
        columns: problem.columns.clone(),
        surrogates: problem
            .columns
            .iter()
            .zip(&problem.models)
            .filter_map(|(c, m)| {
                m.as_ref().map(|m| ColumnSurrogate {
                    column: c.clone(),
                    kind: m.kind.to_string(),
                    points: m.points,
                    validation: m.validation,
                })
            })
            .collect(),
        evaluations: evaluated.len(),
        best,
        verified,
        warnings,
    };
    write_json(&out.join("summary.json"), &report)
        .map_err(|e| io(&out.join("summary.json"), &e))?;
    Ok(report)
}

/// The designs of the table inside the plan's bounds (the optimizer's starting points).
fn design_points(problem: &Problem, loaded: &LoadedPlan) -> Result<Vec<Vec<f64>>, OptimizeError> {
    let d = read_designs(&loaded.designs, &loaded.input_names(), &[])?;
    Ok(d.x
        .into_iter()
        .filter(|x| {
            x.iter()
                .zip(&problem.plan.inputs)
                .all(|(v, i)| v.is_finite() && *v >= i.min && *v <= i.max)
        })
        .collect())
}

/// Writes evaluations: inputs, then each column's mean and std, then `feasible`.
fn write_evaluations(
    path: &Path,
    problem: &Problem,
    rows: &[Evaluation],
) -> Result<(), crate::table::TableError> {
    let mut cols = Vec::new();
    for (j, i) in problem.plan.inputs.iter().enumerate() {
        cols.push(Column::num(&i.name, 4, rows.iter().map(|e| e.x[j])));
    }
    for (k, c) in problem.columns.iter().enumerate() {
        cols.push(Column::num(c, 4, rows.iter().map(|e| e.values[k].mean)));
        cols.push(Column::num(
            format!("{c}_std"),
            4,
            rows.iter().map(|e| e.values[k].std),
        ));
    }
    cols.push(Column::text(
        "feasible",
        rows.iter().map(|e| e.feasible.to_string()),
    ));
    write_csv(path, &cols)
}

/// `plots/pareto`: the surrogate front, the table's designs and the FEM checks in the
/// plane of the two objectives.
fn plot_front(
    out: &Path,
    problem: &Problem,
    loaded: &LoadedPlan,
    front: &[Evaluation],
    verified: &[verify::Verified],
) -> Result<(), OptimizeError> {
    let (a, b) = (
        &problem.plan.objectives[0].column,
        &problem.plan.objectives[1].column,
    );
    let (ia, ib) = (problem.column_index(a), problem.column_index(b));
    let designs = read_designs(
        &loaded.designs,
        &loaded.input_names(),
        &[a.clone(), b.clone()],
    )?;
    let path = out.join("plots").join("pareto");
    plot_xy(
        &path,
        "Pareto front on the surrogates",
        a,
        b,
        &[
            Series {
                label: "surrogate front (feasible)",
                points: front
                    .iter()
                    .map(|e| (e.values[ia].mean, e.values[ib].mean))
                    .collect(),
                line: true,
                errors: None,
            },
            Series {
                label: "designs (FEM)",
                points: designs.y.iter().map(|y| (y[0], y[1])).collect(),
                line: false,
                errors: None,
            },
            Series {
                label: "re-simulated (FEM)",
                points: verified.iter().map(|v| (v.fem[ia], v.fem[ib])).collect(),
                line: false,
                errors: None,
            },
        ],
    )
    .map_err(|e| OptimizeError::Output {
        path,
        why: e.to_string(),
    })?;
    Ok(())
}
