//! `bendscope surrogate`: fit a Gaussian-process surrogate of a design table, predict
//! with it.

use std::path::PathBuf;

use anyhow::Result;
use bendscope::surrogate::{
    fit_surrogate, parse_point, read_designs, CorrKind, FitSettings, GpKind, MeanKind, Scores,
    SurrogateError, SurrogateModel, DEFAULT_FOLDS,
};
use clap::{Args, Subcommand};

use super::{EXIT_BAD_INPUT, EXIT_OK};

/// Fit or use a Gaussian-process (Kriging) surrogate of designs.csv.
#[derive(Debug, Args)]
pub struct SurrogateArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: SurrogateCommand,
}

/// Surrogate subcommands.
#[derive(Debug, Subcommand)]
pub enum SurrogateCommand {
    /// Fit a model of one column over some input columns; prints its cross-validation.
    Fit(FitArgs),
    /// Predict the mean and standard deviation at a design.
    Predict(PredictArgs),
}

/// `surrogate fit`.
#[derive(Debug, Args)]
#[command(
    after_help = "Rows whose status is not ok, or with an empty input or output, are left out. \
Without --mean/--kernel every trend (constant, linear, quadratic) x kernel (squared_exponential, matern52) \
is tried and the best leave-one-out R^2 kept. model.json holds the fitted model, its inputs' ranges and its validation."
)]
pub struct FitArgs {
    /// The design table (designs.csv of bendscope sweep).
    #[arg(value_name = "DESIGNS.csv")]
    pub designs: PathBuf,
    /// Input columns, comma-separated (e.g. geometry.f,geometry.n).
    #[arg(long, value_name = "NAMES", value_delimiter = ',', required = true)]
    pub inputs: Vec<String>,
    /// Output column (e.g. radius_mm@100).
    #[arg(long, value_name = "NAME")]
    pub output: String,
    /// Model file to write.
    #[arg(
        short = 'o',
        long = "out",
        value_name = "MODEL.json",
        default_value = "model.json"
    )]
    pub model: PathBuf,
    /// Trend: constant, linear, quadratic [default: chosen by leave-one-out].
    #[arg(long, value_name = "TREND")]
    pub mean: Option<MeanKind>,
    /// Kernel: squared_exponential, matern52 [default: chosen by leave-one-out].
    #[arg(long, value_name = "KERNEL")]
    pub kernel: Option<CorrKind>,
    /// Folds of the k-fold validation.
    #[arg(long, value_name = "K", default_value_t = DEFAULT_FOLDS)]
    pub folds: usize,
}

/// `surrogate predict`.
#[derive(Debug, Args)]
pub struct PredictArgs {
    /// A model written by `surrogate fit`.
    #[arg(value_name = "MODEL.json")]
    pub model: PathBuf,
    /// The design: NAME=VALUE for every input, comma-separated (geometry.f=4.5,geometry.n=11).
    #[arg(value_name = "POINT", allow_hyphen_values = true)]
    pub point: String,
    /// Print {"mean": ..., "std": ...}.
    #[arg(long)]
    pub json: bool,
}

/// Runs `bendscope surrogate`.
pub fn run(args: &SurrogateArgs) -> Result<u8> {
    match &args.command {
        SurrogateCommand::Fit(a) => fit(a),
        SurrogateCommand::Predict(a) => predict(a),
    }
}

fn bad_input(e: &SurrogateError) -> u8 {
    eprintln!("error: {e}");
    EXIT_BAD_INPUT
}

fn line(what: &str, s: &Scores) -> String {
    format!(
        "{what}: R^2 {:.4}, explained variance {:.2}%, max error {:.4}, rmse {:.4}",
        s.r2,
        100.0 * s.explained_variance,
        s.max_error,
        s.rmse
    )
}

fn fit(a: &FitArgs) -> Result<u8> {
    let settings = FitSettings {
        kind: match (a.mean, a.kernel) {
            (None, None) => None,
            (m, k) => Some(GpKind {
                mean: m.unwrap_or(MeanKind::Constant),
                corr: k.unwrap_or(CorrKind::SquaredExponential),
            }),
        },
        folds: a.folds,
    };
    if a.folds < 2 {
        eprintln!("error: --folds {}: use at least 2", a.folds);
        return Ok(EXIT_BAD_INPUT);
    }
    super::check_output_file(&a.model)?;
    let designs = match read_designs(&a.designs, &a.inputs, std::slice::from_ref(&a.output)) {
        Ok(d) => d,
        Err(e) => return Ok(bad_input(&e)),
    };
    let model = match fit_surrogate(&designs, &a.output, &settings) {
        Ok(m) => m,
        Err(e @ (SurrogateError::Gp { .. } | SurrogateError::ModelFile { .. })) => {
            return Err(e.into())
        }
        Err(e) => return Ok(bad_input(&e)),
    };
    model.save(&a.model)?;
    let v = &model.validation;
    super::out!(
        "{} over {} from {} points ({} rows left out): {}, theta [{}]",
        model.output,
        model.input_names().join(", "),
        model.points,
        model.skipped,
        model.kind,
        model
            .theta
            .iter()
            .map(|t| format!("{t:.4}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    super::out!("{}", line("leave-one-out", &v.loo));
    super::out!("{}", line(&format!("{}-fold", v.folds), &v.kfold));
    let c = &v.loo_coverage;
    super::out!(
        "leave-one-out std: truth within 2 std at {} and within 3 std at {} of {} points, z rms {:.2} (nugget {:.0e})",
        c.within_2std,
        c.within_3std,
        c.points,
        c.z_rms,
        model.nugget
    );
    super::out!("-> {}", a.model.display());
    Ok(EXIT_OK)
}

fn predict(a: &PredictArgs) -> Result<u8> {
    let model = match SurrogateModel::load(&a.model) {
        Ok(m) => m,
        Err(e) => return Ok(bad_input(&e)),
    };
    let x = match parse_point(&a.point, &model.input_names()) {
        Ok(x) => x,
        Err(e) => return Ok(bad_input(&e)),
    };
    for o in model.outside(&x) {
        eprintln!("warning: {o}: the model extrapolates there");
    }
    let p = model.predict(&x)?;
    if a.json {
        super::out!("{}", serde_json::to_string(&p)?);
    } else {
        super::out!("{} = {:.4} ± {:.4} (1 std)", model.output, p.mean, p.std);
    }
    Ok(EXIT_OK)
}
