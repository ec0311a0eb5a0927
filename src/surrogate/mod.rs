//! Surrogates of a design table: a Gaussian-process (Kriging) model of one output column
//! of `designs.csv` over some input columns, with its predictive standard deviation and
//! its cross-validated accuracy.
//!
//! Data flows: [`designs`] (the table: rows with status `ok`, the named columns) ->
//! [`gp`] (the candidate Kriging models: trend × correlation, fitted by egobox-gp) ->
//! [`validation`] (leave-one-out and k-fold scores: R², explained variance, max error;
//! the coverage of the predictive std) -> [`SurrogateModel`] (the chosen model, its scores and what `predict` needs, saved
//! as JSON).
//!
//! The Gaussian process is egobox-gp's (a port of SMT's Kriging, pure-Rust linear
//! algebra through linfa-linalg): it standardizes the inputs and the output (mean 0,
//! standard deviation 1 per column) and fits the correlation lengths θ by maximum
//! likelihood (multistart COBYLA). Written here: only the choice of the trend and the
//! kernel by leave-one-out R², then of the nugget (the noise variance the model allows
//! for, [`gp::NUGGETS`]) by leave-one-out predictive density, so that the std is honest
//! about held-out errors (FEM outputs carry mesh and Newton-tolerance noise an
//! interpolating model takes for signal: its std at a held-out design was far too small);
//! the coverage (truths within 2 and 3 std held out) is reported; the cross-validation report (egobox's `q2_score` gives R²
//! alone and panics on a failed fold) and the file format.

pub mod designs;
pub mod gp;
pub mod validation;

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

pub use designs::{read_designs, Designs};
pub use gp::{CorrKind, GpKind, MeanKind};
pub use validation::{Scores, Validation};

use crate::report::write_json;

/// Errors of surrogate fitting and prediction.
#[derive(Debug, thiserror::Error)]
pub enum SurrogateError {
    /// The design table could not be read.
    #[error(transparent)]
    Table(#[from] crate::table::TableError),
    /// A named column is not in the table.
    #[error("{path}: no column `{name}` (columns: {available})")]
    NoColumn {
        /// The table.
        path: PathBuf,
        /// The missing column.
        name: String,
        /// The columns there are.
        available: String,
    },
    /// Too few usable rows to fit and validate a model.
    #[error("{path}: {rows} usable row(s) (status ok, every named column a finite number) for `{output}`; need at least {needed}: run more design points")]
    TooFewRows {
        /// The table.
        path: PathBuf,
        /// The output column.
        output: String,
        /// Usable rows.
        rows: usize,
        /// Rows needed.
        needed: usize,
    },
    /// The data cannot define a model (constant output, repeated inputs, ...).
    #[error("{why}")]
    Data {
        /// What is wrong and what to do.
        why: String,
    },
    /// egobox-gp failed to fit or predict.
    #[error("Gaussian process for `{output}`: {why}")]
    Gp {
        /// The output column.
        output: String,
        /// What failed.
        why: String,
    },
    /// A point given on the command line is not valid.
    #[error("point '{text}': {why}")]
    Point {
        /// The text given.
        text: String,
        /// What is wrong and what to do.
        why: String,
    },
    /// A model file cannot be read or written.
    #[error("{path}: {why}")]
    ModelFile {
        /// The file.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
}

/// Version tag of the model file; a file with another tag is refused.
pub const MODEL_FORMAT: &str = "bendscope-surrogate/1";

/// Default number of folds of the k-fold validation.
pub const DEFAULT_FOLDS: usize = 5;

/// Range of an input over the training designs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputRange {
    /// Column name (e.g. `geometry.f`).
    pub name: String,
    /// Smallest value in the designs.
    pub min: f64,
    /// Largest value in the designs.
    pub max: f64,
}

/// Leave-one-out score of one candidate model (how the model was chosen).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// Trend and kernel.
    pub kind: GpKind,
    /// Leave-one-out scores.
    pub loo: Scores,
}

/// Settings of a fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitSettings {
    /// The model to fit; `None`: every trend × kernel, the best leave-one-out R² kept.
    pub kind: Option<GpKind>,
    /// Folds of the k-fold validation (at most the number of points).
    pub folds: usize,
}

impl Default for FitSettings {
    fn default() -> Self {
        Self {
            kind: None,
            folds: DEFAULT_FOLDS,
        }
    }
}

/// A fitted surrogate: the Gaussian process, its inputs and output, how it validated.
/// Saved as `model.json` ([`SurrogateModel::save`]); everything `predict` needs is in it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SurrogateModel {
    /// [`MODEL_FORMAT`].
    pub format: String,
    /// The design table it was fitted on.
    pub designs: String,
    /// Inputs, in the order a point is given, with their range in the designs.
    pub inputs: Vec<InputRange>,
    /// The output column.
    pub output: String,
    /// Training points.
    pub points: usize,
    /// Rows of the table left out (status not ok, or an empty cell).
    pub skipped: usize,
    /// Trend and kernel of the model.
    pub kind: GpKind,
    /// Fitted correlation parameters θ (one per input, on standardized inputs).
    pub theta: Vec<f64>,
    /// The nugget chosen ([`gp::NUGGETS`]; model files before it: [`gp::DEFAULT_NUGGET`]).
    #[serde(default = "default_nugget")]
    pub nugget: f64,
    /// Cross-validation of the chosen model.
    pub validation: Validation,
    /// Leave-one-out scores of every candidate tried.
    pub candidates: Vec<Candidate>,
    /// The fitted Gaussian process (egobox-gp's serialized form).
    pub gp: gp::Gp,
}

fn default_nugget() -> f64 {
    gp::DEFAULT_NUGGET
}

/// A prediction: the Gaussian process mean and standard deviation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Prediction {
    /// Predicted value.
    pub mean: f64,
    /// Predictive standard deviation (same unit).
    pub std: f64,
}

/// Fits a surrogate of column `output` of `designs` (which must hold it) and validates it.
pub fn fit_surrogate(
    designs: &Designs,
    output: &str,
    settings: &FitSettings,
) -> Result<SurrogateModel, SurrogateError> {
    let designs::Training { x, y, ids, skipped } = designs.training(output)?;
    let n_inputs = designs.inputs.len();
    let needed = (n_inputs + 3).max(validation::MIN_POINTS);
    if y.len() < needed {
        return Err(SurrogateError::TooFewRows {
            path: designs.path.clone(),
            output: output.to_string(),
            rows: y.len(),
            needed,
        });
    }
    check_data(designs, output, &x, &y, &ids)?;
    let kinds = match settings.kind {
        Some(k) => vec![k],
        None => GpKind::all(),
    };
    let mut candidates = Vec::new();
    let mut first_error = None;
    for kind in kinds {
        let pred = match validation::cross_predictions(
            kind,
            gp::DEFAULT_NUGGET,
            &x,
            &y,
            y.len(),
            output,
        ) {
            Ok(p) => p,
            // Tried among all: a trend the points cannot carry (a quadratic in four
            // inputs on 16 points) is not a candidate; a model asked for is an error.
            Err(e) if settings.kind.is_none() => {
                first_error.get_or_insert(e);
                continue;
            }
            Err(e) => return Err(e),
        };
        candidates.push(Candidate {
            kind,
            loo: Scores::of(&y, &validation::means(&pred)),
        });
    }
    // The best leave-one-out R²; ties go to the simpler model (listed first).
    let kind = candidates
        .iter()
        .fold(None::<&Candidate>, |best, c| match best {
            Some(b) if b.loo.r2 >= c.loo.r2 || !c.loo.r2.is_finite() => Some(b),
            _ => Some(c),
        })
        .map(|c| c.kind);
    let kind = match (kind, first_error) {
        (Some(k), _) => k,
        (None, Some(e)) => return Err(e),
        (None, None) => {
            return Err(SurrogateError::Data {
                why: "no candidate model".into(),
            })
        }
    };
    // Then the nugget (the noise the model allows for) with the best leave-one-out
    // predictive density: the one whose std is honest about the held-out errors.
    let mut best: Option<(f64, Vec<Prediction>, validation::Coverage)> = None;
    for nugget in gp::NUGGETS {
        let pred = match validation::cross_predictions(kind, nugget, &x, &y, y.len(), output) {
            Ok(p) => p,
            // A nugget egobox cannot fit with is not a candidate (the default always is).
            Err(_) if nugget != gp::DEFAULT_NUGGET => continue,
            Err(e) => return Err(e),
        };
        let c = validation::Coverage::of(&y, &pred);
        if c.nlpd.is_finite() && best.as_ref().is_none_or(|b| c.nlpd < b.2.nlpd) {
            best = Some((nugget, pred, c));
        }
    }
    let (nugget, pred, loo_coverage) = best.ok_or_else(|| SurrogateError::Data {
        why: "no nugget gave finite held-out predictions".into(),
    })?;
    let loo = Scores::of(&y, &validation::means(&pred));
    let folds = settings.folds.clamp(2, y.len());
    let kfold = Scores::of(
        &y,
        &validation::means(&validation::cross_predictions(
            kind, nugget, &x, &y, folds, output,
        )?),
    );
    let gp = gp::fit(kind, nugget, &x, &y, output)?;
    let inputs = designs
        .inputs
        .iter()
        .enumerate()
        .map(|(j, name)| InputRange {
            name: name.clone(),
            min: x.iter().map(|r| r[j]).fold(f64::INFINITY, f64::min),
            max: x.iter().map(|r| r[j]).fold(f64::NEG_INFINITY, f64::max),
        })
        .collect();
    Ok(SurrogateModel {
        format: MODEL_FORMAT.into(),
        designs: designs.path.display().to_string(),
        inputs,
        output: output.to_string(),
        points: y.len(),
        skipped,
        kind,
        theta: gp.theta(),
        nugget,
        validation: Validation {
            loo,
            kfold,
            folds,
            loo_coverage,
        },
        candidates,
        gp,
    })
}

/// Refuses data a Gaussian process cannot interpolate: a constant output, a constant
/// input, two rows with the same inputs.
fn check_data(
    designs: &Designs,
    output: &str,
    x: &[Vec<f64>],
    y: &[f64],
    ids: &[String],
) -> Result<(), SurrogateError> {
    let spread = |v: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
            (a.min(t), b.max(t))
        });
        hi - lo
    };
    if spread(&mut y.iter().copied()) <= 0.0 {
        return Err(SurrogateError::Data {
            why: format!(
                "{}: `{output}` is the same on every usable row: nothing to model",
                designs.path.display()
            ),
        });
    }
    for (j, name) in designs.inputs.iter().enumerate() {
        if spread(&mut x.iter().map(|r| r[j])) <= 0.0 {
            return Err(SurrogateError::Data {
                why: format!(
                    "{}: input `{name}` does not vary over the usable rows: leave it out of --inputs",
                    designs.path.display()
                ),
            });
        }
    }
    for a in 0..x.len() {
        for b in a + 1..x.len() {
            if x[a] == x[b] {
                return Err(SurrogateError::Data {
                    why: format!(
                        "{}: rows {} and {} have the same inputs: a Gaussian process interpolates, keep one of them",
                        designs.path.display(),
                        ids[a],
                        ids[b]
                    ),
                });
            }
        }
    }
    Ok(())
}

impl SurrogateModel {
    /// Input names, in order.
    pub fn input_names(&self) -> Vec<String> {
        self.inputs.iter().map(|i| i.name.clone()).collect()
    }

    /// Mean and standard deviation at `x` (one value per input, in order).
    pub fn predict(&self, x: &[f64]) -> Result<Prediction, SurrogateError> {
        let out = self.predict_many(&[x.to_vec()])?;
        out.into_iter().next().ok_or_else(|| SurrogateError::Gp {
            output: self.output.clone(),
            why: "no prediction".into(),
        })
    }

    /// Means and standard deviations at many points.
    pub fn predict_many(&self, xs: &[Vec<f64>]) -> Result<Vec<Prediction>, SurrogateError> {
        if let Some(x) = xs.iter().find(|x| x.len() != self.inputs.len()) {
            return Err(SurrogateError::Data {
                why: format!(
                    "a point has {} value(s); the model of `{}` has {} input(s)",
                    x.len(),
                    self.output,
                    self.inputs.len()
                ),
            });
        }
        self.gp.predict(xs, &self.output)
    }

    /// Inputs of `x` outside the range of the designs (the model extrapolates there).
    pub fn outside(&self, x: &[f64]) -> Vec<String> {
        self.inputs
            .iter()
            .zip(x)
            .filter(|(r, v)| **v < r.min || **v > r.max)
            .map(|(r, v)| format!("{} = {v} (designs: {} to {})", r.name, r.min, r.max))
            .collect()
    }

    /// Writes the model as JSON.
    pub fn save(&self, path: &Path) -> Result<(), SurrogateError> {
        write_json(path, self).map_err(|e| SurrogateError::ModelFile {
            path: path.to_path_buf(),
            why: e.to_string(),
        })
    }

    /// Reads a model written by [`SurrogateModel::save`].
    pub fn load(path: &Path) -> Result<Self, SurrogateError> {
        let err = |why: String| SurrogateError::ModelFile {
            path: path.to_path_buf(),
            why,
        };
        let text = std::fs::read_to_string(path).map_err(|e| err(format!("cannot read: {e}")))?;
        let head: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
            err(format!(
                "not JSON ({e}): give a model.json written by bendscope surrogate fit"
            ))
        })?;
        match head.get("format").and_then(|f| f.as_str()) {
            Some(MODEL_FORMAT) => {}
            Some(other) => {
                return Err(err(format!(
                    "model format `{other}`, this bendscope reads `{MODEL_FORMAT}`: fit the model again"
                )))
            }
            None => {
                return Err(err(
                    "no `format` field: not a model written by bendscope surrogate fit".into(),
                ))
            }
        }
        serde_json::from_value(head)
            .map_err(|e| err(format!("damaged model ({e}): fit the model again")))
    }
}

/// Parses `name=value,name=value` (every input of the model exactly once, in any order)
/// into values in the model's input order.
pub fn parse_point(text: &str, inputs: &[String]) -> Result<Vec<f64>, SurrogateError> {
    let bad = |why: String| SurrogateError::Point {
        text: text.to_string(),
        why,
    };
    let mut values = vec![None; inputs.len()];
    for part in text.split(',').filter(|p| !p.trim().is_empty()) {
        let (name, value) = part
            .split_once('=')
            .ok_or_else(|| bad(format!("'{part}' is not NAME=VALUE")))?;
        let name = name.trim();
        let j = inputs.iter().position(|i| i == name).ok_or_else(|| {
            bad(format!(
                "`{name}` is not an input (inputs: {})",
                inputs.join(", ")
            ))
        })?;
        let v: f64 = value
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| {
                bad(format!(
                    "`{name}`: '{}' is not a finite number",
                    value.trim()
                ))
            })?;
        if values[j].replace(v).is_some() {
            return Err(bad(format!("`{name}` is given twice")));
        }
    }
    let missing: Vec<&str> = inputs
        .iter()
        .zip(&values)
        .filter(|(_, v)| v.is_none())
        .map(|(n, _)| n.as_str())
        .collect();
    if !missing.is_empty() {
        return Err(bad(format!("missing {}", missing.join(", "))));
    }
    Ok(values.into_iter().flatten().collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A two-level factorial in four inputs (16 points) cannot carry a quadratic trend's
    /// 15 terms in leave-one-out: tried among all, it is skipped and a simpler model
    /// fitted (it failed the whole fit before); asked for, it is the error.
    #[test]
    fn a_trend_the_points_cannot_carry_is_skipped_when_models_are_tried() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("designs.csv");
        let mut text = String::from("id,status,a,b,c,d,y\n");
        for k in 0..16 {
            let v: Vec<f64> = (0..4).map(|j| f64::from((k >> j) & 1)).collect();
            let y = 10.0 + 3.0 * v[0] - 2.0 * v[1] + v[2] + 0.5 * v[3] + v[0] * v[1];
            text += &format!("p{k},ok,{},{},{},{},{y}\n", v[0], v[1], v[2], v[3]);
        }
        std::fs::write(&path, text).unwrap();
        let inputs: Vec<String> = ["a", "b", "c", "d"].map(String::from).to_vec();
        let designs = designs::read_designs(&path, &inputs, &["y".to_string()]).unwrap();
        let model = fit_surrogate(&designs, "y", &FitSettings::default()).unwrap();
        assert_ne!(model.kind.mean, gp::MeanKind::Quadratic);
        let quadratic = FitSettings {
            kind: Some(GpKind {
                mean: gp::MeanKind::Quadratic,
                corr: gp::CorrKind::SquaredExponential,
            }),
            ..FitSettings::default()
        };
        assert!(fit_surrogate(&designs, "y", &quadratic).is_err());
    }

    #[test]
    fn point_parses_in_any_order_and_names_what_is_wrong() {
        let inputs = vec!["geometry.f".to_string(), "geometry.n".to_string()];
        assert_eq!(
            parse_point("geometry.n=11, geometry.f=4.5", &inputs).unwrap(),
            vec![4.5, 11.0]
        );
        for (text, needle) in [
            ("geometry.f=4.5", "missing geometry.n"),
            ("geometry.f=4.5,geometry.f=5,geometry.n=1", "twice"),
            ("geometry.f=x,geometry.n=1", "not a finite number"),
            ("geometry.q=1", "not an input"),
            ("geometry.f", "NAME=VALUE"),
        ] {
            let e = parse_point(text, &inputs).unwrap_err().to_string();
            assert!(e.contains(needle), "{text}: {e}");
        }
    }
}
