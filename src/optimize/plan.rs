//! The optimization plan (TOML): where the designs are, the inputs and their bounds, the
//! objectives and constraints (columns of `designs.csv`), how the best points are checked
//! with the FEM.
//!
//! ```toml
//! designs = "designs.csv"          # relative to the plan file
//! base = "actuator.toml"           # optional: config of the re-simulations (default: reference)
//! mesh_size_mm = 3.0               # optional override of the base's mesh
//! pressures_kpa = "10:100:10"      # optional override of the base's ramp
//! resimulate = 3                   # best points checked with the FEM (0: none)
//! [[input]]
//! name = "geometry.f"
//! min = 3.0
//! max = 7.5
//! [[objective]]
//! column = "bending_angle_deg@100"
//! goal = "maximize"
//! [[constraint]]
//! column = "bottom_elongation_pct@100"
//! abs = true                       # |value| op bound
//! op = "<="
//! value = 10.0
//! ```

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::OptimizeError;
use crate::fem::actuator::ActuatorConfig;

/// Default number of designs re-simulated with the FEM.
pub const DEFAULT_RESIMULATE: usize = 3;
/// Default iterations of the Bayesian optimization (one objective).
pub const DEFAULT_ITERATIONS: usize = 20;
/// Default NSGA-II population (two objectives).
pub const DEFAULT_POPULATION: usize = 40;
/// Default NSGA-II generations.
pub const DEFAULT_GENERATIONS: usize = 60;
/// Default random seed.
pub const DEFAULT_SEED: u64 = 1;
/// The column computed exactly from the geometry, not from a surrogate.
pub const HEIGHT_COLUMN: &str = "height_mm";

/// A design input and its bounds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanInput {
    /// Column of designs.csv and config field (`geometry.f`).
    pub name: String,
    /// Lower bound.
    pub min: f64,
    /// Upper bound.
    pub max: f64,
    /// Whole numbers only (e.g. `geometry.chambers`): values are rounded.
    #[serde(default)]
    pub integer: bool,
}

/// Direction of an objective.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Goal {
    /// Smaller is better.
    Minimize,
    /// Larger is better.
    Maximize,
}

/// An objective: a column to minimize or maximize.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanObjective {
    /// Column of designs.csv (`bending_angle_deg@100`).
    pub column: String,
    /// Direction.
    pub goal: Goal,
}

/// Comparison of a constraint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Op {
    /// value <= bound.
    #[serde(rename = "<=")]
    AtMost,
    /// value >= bound.
    #[serde(rename = ">=")]
    AtLeast,
}

/// A constraint on a column: `[|]column[|] op value`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanConstraint {
    /// Column of designs.csv, or `height_mm` (computed from the geometry).
    pub column: String,
    /// Compare the magnitude of the value.
    #[serde(default)]
    pub abs: bool,
    /// Comparison.
    pub op: Op,
    /// Bound.
    pub value: f64,
}

impl PlanConstraint {
    /// Violation of the constraint by `v`: <= 0 when met, else how far it is missed.
    pub fn margin(&self, v: f64) -> f64 {
        let lhs = if self.abs { v.abs() } else { v };
        match self.op {
            Op::AtMost => lhs - self.value,
            Op::AtLeast => self.value - lhs,
        }
    }
}

impl std::fmt::Display for PlanConstraint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let op = match self.op {
            Op::AtMost => "<=",
            Op::AtLeast => ">=",
        };
        if self.abs {
            write!(f, "|{}| {op} {}", self.column, self.value)
        } else {
            write!(f, "{} {op} {}", self.column, self.value)
        }
    }
}

/// An optimization plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plan {
    /// The design table (relative paths are relative to the plan file).
    pub designs: PathBuf,
    /// Actuator config of the re-simulations (default: the reference actuator).
    pub base: Option<PathBuf>,
    /// Mesh size of the re-simulations, mm (default: the base's).
    pub mesh_size_mm: Option<f64>,
    /// Ramp of the re-simulations (default: the base's); must reach every pressure named
    /// in a column.
    pub pressures_kpa: Option<String>,
    /// Best points re-simulated with the FEM.
    #[serde(default = "default_resimulate")]
    pub resimulate: usize,
    /// Random seed (optimizers).
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Bayesian-optimization iterations (one objective).
    #[serde(default = "default_iterations")]
    pub iterations: usize,
    /// NSGA-II population (two objectives).
    #[serde(default = "default_population")]
    pub population: usize,
    /// NSGA-II generations.
    #[serde(default = "default_generations")]
    pub generations: usize,
    /// Inputs.
    #[serde(rename = "input")]
    pub inputs: Vec<PlanInput>,
    /// Objectives (one or two).
    #[serde(rename = "objective")]
    pub objectives: Vec<PlanObjective>,
    /// Constraints.
    #[serde(rename = "constraint", default)]
    pub constraints: Vec<PlanConstraint>,
}

fn default_resimulate() -> usize {
    DEFAULT_RESIMULATE
}
fn default_seed() -> u64 {
    DEFAULT_SEED
}
fn default_iterations() -> usize {
    DEFAULT_ITERATIONS
}
fn default_population() -> usize {
    DEFAULT_POPULATION
}
fn default_generations() -> usize {
    DEFAULT_GENERATIONS
}

/// A plan read from its file, paths resolved, the re-simulation config built.
#[derive(Debug, Clone)]
pub struct LoadedPlan {
    /// The plan.
    pub plan: Plan,
    /// The plan file.
    pub path: PathBuf,
    /// designs resolved against the plan's folder.
    pub designs: PathBuf,
    /// Config of the re-simulations (inputs not yet set).
    pub base: ActuatorConfig,
}

impl LoadedPlan {
    /// Columns that need a surrogate (objectives and constraints, except `height_mm`),
    /// each once, in order.
    pub fn surrogate_columns(&self) -> Vec<String> {
        let mut cols: Vec<String> = Vec::new();
        let all = self
            .plan
            .objectives
            .iter()
            .map(|o| &o.column)
            .chain(self.plan.constraints.iter().map(|c| &c.column));
        for c in all {
            if c != HEIGHT_COLUMN && !cols.contains(c) {
                cols.push(c.clone());
            }
        }
        cols
    }

    /// Input names in order.
    pub fn input_names(&self) -> Vec<String> {
        self.plan.inputs.iter().map(|i| i.name.clone()).collect()
    }
}

fn bad(path: &Path, why: impl Into<String>) -> OptimizeError {
    OptimizeError::Plan {
        path: path.to_path_buf(),
        why: why.into(),
    }
}

/// The pressure a column is read at (`radius_mm@100` -> 100), if it names one.
pub fn column_pressure(column: &str) -> Option<&str> {
    column.split_once('@').map(|(_, p)| p)
}

/// Reads and checks a plan.
pub fn load_plan(path: &Path) -> Result<LoadedPlan, OptimizeError> {
    let text = std::fs::read_to_string(path).map_err(|e| bad(path, format!("cannot read: {e}")))?;
    let plan: Plan = toml::from_str(&text).map_err(|e| {
        bad(
            path,
            format!(
                "not a valid plan: {} (see examples/plans/optimize.toml)",
                e.message().trim()
            ),
        )
    })?;
    let dir = path.parent().unwrap_or(Path::new(""));
    let resolve = |p: &Path| {
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            dir.join(p)
        }
    };
    if plan.inputs.is_empty() {
        return Err(bad(path, "no [[input]]: name at least one design input"));
    }
    for i in &plan.inputs {
        if !(i.min.is_finite() && i.max.is_finite() && i.min < i.max) {
            return Err(bad(
                path,
                format!(
                    "input {}: need finite min < max, got {} and {}",
                    i.name, i.min, i.max
                ),
            ));
        }
    }
    if plan.objectives.is_empty() || plan.objectives.len() > 2 {
        return Err(bad(
            path,
            format!(
                "{} [[objective]]: give one (Bayesian optimization) or two (Pareto front)",
                plan.objectives.len()
            ),
        ));
    }
    if plan.objectives.iter().any(|o| o.column == HEIGHT_COLUMN) {
        return Err(bad(path, "height_mm is a constraint, not an objective"));
    }
    if plan.population < 4 || plan.generations == 0 || plan.iterations == 0 {
        return Err(bad(
            path,
            "population must be >= 4, generations and iterations >= 1",
        ));
    }
    let mut base = match &plan.base {
        Some(b) => {
            let b = resolve(b);
            let t = std::fs::read_to_string(&b)
                .map_err(|e| bad(path, format!("base {}: cannot read: {e}", b.display())))?;
            toml::from_str::<ActuatorConfig>(&t).map_err(|e| {
                bad(
                    path,
                    format!(
                        "base {}: not an actuator config: {}",
                        b.display(),
                        e.message()
                    ),
                )
            })?
        }
        None => ActuatorConfig::default(),
    };
    if let Some(h) = plan.mesh_size_mm {
        base.mesh.size_mm = h;
    }
    if let Some(p) = &plan.pressures_kpa {
        base.load.pressures_kpa = p.clone();
    }
    base.validate()
        .map_err(|e| bad(path, format!("re-simulation config: {e}")))?;
    let ramp = base.pressures_kpa().map_err(|e| bad(path, e.to_string()))?;
    let columns = plan
        .objectives
        .iter()
        .map(|o| &o.column)
        .chain(plan.constraints.iter().map(|c| &c.column));
    for c in columns {
        if let Some(p) = column_pressure(c) {
            let kpa: f64 = p
                .parse()
                .map_err(|_| bad(path, format!("column {c}: '{p}' is not a pressure in kPa")))?;
            if plan.resimulate > 0 && !ramp.iter().any(|r| (r - kpa).abs() < 1e-9) {
                return Err(bad(
                    path,
                    format!(
                        "column {c}: the re-simulation ramp '{}' does not reach {kpa} kPa: set pressures_kpa",
                        base.load.pressures_kpa
                    ),
                ));
            }
        }
    }
    for i in &plan.inputs {
        crate::optimize::set_input(&base, &i.name, i.min).map_err(|e| bad(path, e.to_string()))?;
    }
    Ok(LoadedPlan {
        designs: resolve(&plan.designs),
        path: path.to_path_buf(),
        plan,
        base,
    })
}
