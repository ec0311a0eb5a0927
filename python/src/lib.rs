//! `bendscope._native`: the Python extension module, written by hand over the bendscope
//! library with PyO3.
//!
//! Each function calls the library the way the matching `src/cli/*.rs` command does
//! (same settings, same defaults, same one-line error messages) and hands back JSON text
//! that `bendscope/__init__.py` turns into Python objects; the tables stay in the output
//! folder, where the pure-Python part reads them into pandas DataFrames. Nothing here
//! measures or decides anything of its own.
//!
//! The GIL is released while the library works ([`Python::detach`]); progress reaches an
//! optional Python callback `progress(what, done, total)`, the GIL taken again for each
//! call. Errors raise `bendscope.Error` (a `ValueError`) with the CLI's message, without
//! its `error: ` prefix. The library has no cancellation hook, so a Ctrl-C (or any
//! exception the callback raises) is raised when the run returns, not at once.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

use bendscope::calib::corners::{detect_views, DetectSettings};
use bendscope::calib::destination::{check_replaces_same_camera, default_calibration_path};
use bendscope::calib::file::write_calibration;
use bendscope::calib::sources::collect_sources;
use bendscope::calib::{calibrate as calibrate_views, Board, CalibError, CalibrationSettings};
use bendscope::compare::compare_to;
use bendscope::fem::actuator::ActuatorConfig;
use bendscope::fem::output::{simulate_to, SimulateOptions};
use bendscope::material_fit::{fit_material, write_material_fit, MaterialBlock, TensileData};
use bendscope::pipeline::{measure_session, ProcessSettings, Progress, Quiet};
use bendscope::study::{run_study, SampleSpec, StudySpec};
use pyo3::prelude::*;
use serde_json::json;

pyo3::create_exception!(
    bendscope,
    Error,
    pyo3::exceptions::PyValueError,
    "Bad input or a failed run; the message is the CLI's one-line error."
);

/// Frames `calibrate` samples from each video (the CLI's `--frames` default).
const CALIBRATION_FRAMES_PER_VIDEO: u32 = 20;
/// Longest side at which boards are searched (the CLI's `--detect-px` default).
const CALIBRATION_DETECT_PX: u32 = 1280;

/// `bendscope.Error` with `message`.
fn error(message: impl std::fmt::Display) -> PyErr {
    Error::new_err(message.to_string())
}

/// An error and its causes on one line, as the binary's `main` prints them; a cause
/// the message already ends with (an error that shows its source) is not repeated.
fn chain_message(e: &dyn std::error::Error) -> String {
    let mut msg = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let text = c.to_string();
        if !msg.ends_with(&text) {
            msg.push_str(&format!(": {text}"));
        }
        cause = c.source();
    }
    msg
}

/// Calls the Python progress callback with the GIL taken; the first exception it
/// raises (KeyboardInterrupt included) is kept and raised when the run returns.
struct Callback {
    callback: Option<Py<PyAny>>,
    raised: Mutex<Option<PyErr>>,
}

impl Callback {
    fn new(callback: Option<Py<PyAny>>) -> Self {
        Callback {
            callback,
            raised: Mutex::new(None),
        }
    }

    fn call(&self, what: &str, done: u64, total: u64) {
        let Some(cb) = &self.callback else { return };
        let Ok(mut raised) = self.raised.lock() else {
            return;
        };
        if raised.is_some() {
            return;
        }
        if let Err(e) = Python::attach(|py| cb.call1(py, (what, done, total)).map(|_| ())) {
            *raised = Some(e);
        }
    }

    /// The exception the callback raised, if any.
    fn into_raised(self) -> Option<PyErr> {
        self.raised.into_inner().ok().flatten()
    }
}

/// [`Progress`] for `measure_session`: stages and steps to the callback, notes kept by
/// the library in its outcome.
struct StageProgress {
    callback: Callback,
    what: String,
    done: u64,
    total: u64,
}

impl Progress for StageProgress {
    fn start(&mut self, what: &str, total: u64) {
        self.what = what.to_string();
        self.done = 0;
        self.total = total;
        self.callback.call(&self.what, 0, total);
    }
    fn advance(&mut self, n: u64) {
        self.done += n;
        self.callback.call(&self.what, self.done, self.total);
    }
}

/// The callback's exception if it raised one, else `value`.
fn finish<T>(callback: Callback, value: T) -> PyResult<T> {
    match callback.into_raised() {
        Some(e) => Err(e),
        None => Ok(value),
    }
}

/// Measures one session folder into `out` (`bendscope process SESSION -o OUT`); returns
/// JSON: out, measured, failed, notes, scale.
#[pyfunction]
#[pyo3(signature = (session, out=None, calibration=None, config=None, force=false, progress=None))]
fn process(
    py: Python<'_>,
    session: PathBuf,
    out: Option<PathBuf>,
    calibration: Option<PathBuf>,
    config: Option<PathBuf>,
    force: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let out = out.unwrap_or_else(|| session.join("bendscope-out"));
    let settings = ProcessSettings {
        calibration,
        config,
        force,
        error_bars: None,
    };
    let mut stages = StageProgress {
        callback: Callback::new(progress),
        what: String::new(),
        done: 0,
        total: 0,
    };
    let result = py.detach(|| measure_session(&session, &out, &settings, &mut stages));
    let outcome = result.map_err(|e| error(e.for_session(&session)))?;
    let text = json!({
        "out": outcome.out,
        "measured": outcome.measured,
        "failed": outcome.failed,
        "notes": outcome.notes,
        "scale": outcome.provenance.scale.as_ref().map(|s| s.describe()),
    })
    .to_string();
    finish(stages.callback, text)
}

/// Calibrates a camera from checkerboard views (`bendscope calibrate`); writes the YAML
/// file and returns JSON with the intrinsics, the RMS error and the views.
#[pyfunction]
#[pyo3(signature = (paths, cols, rows, square_mm, model, out=None, force=false, progress=None))]
#[allow(clippy::too_many_arguments)]
fn calibrate(
    py: Python<'_>,
    paths: Vec<PathBuf>,
    cols: u32,
    rows: u32,
    square_mm: f64,
    model: &str,
    out: Option<PathBuf>,
    force: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let model = model.parse().map_err(error)?;
    let callback = Callback::new(progress);
    let result = py.detach(|| -> Result<_, CalibError> {
        let board = Board::new(cols, rows, square_mm)?;
        let (sources, skipped) = collect_sources(&paths, CALIBRATION_FRAMES_PER_VIDEO)?;
        if sources.is_empty() {
            return Err(CalibError::NoViews {
                paths: paths
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        let total = sources.len() as u64;
        let done = AtomicU64::new(0);
        let settings = DetectSettings {
            max_detect_px: CALIBRATION_DETECT_PX,
            parallel: true,
        };
        let mut detections = detect_views(&sources, &board, &settings, &|| {
            let n = done.fetch_add(1, Ordering::SeqCst) + 1;
            callback.call("finding corners", n, total);
        });
        detections.rejected.extend(skipped);
        let calib = calibrate_views(
            &detections,
            &CalibrationSettings {
                model,
                board,
                fix_aspect_ratio: false,
            },
        )?;
        let out = match &out {
            Some(path) => path.clone(),
            None => {
                let path = default_calibration_path(&paths[0]);
                if !force {
                    check_replaces_same_camera(&path, &calib)?;
                }
                path
            }
        };
        Ok((calib, out))
    });
    let (calib, out) = result.map_err(|e| error(chain_message(&e)))?;
    write_calibration(&out, &calib)
        .map_err(|e| error(format!("writing {}: {}", out.display(), chain_message(&e))))?;
    let k = &calib.camera_matrix;
    let text = json!({
        "model": calib.model.name(),
        "image_width": calib.image_width,
        "image_height": calib.image_height,
        "camera_matrix": (0..3).map(|r| (0..3).map(|c| k[(r, c)]).collect::<Vec<f64>>()).collect::<Vec<_>>(),
        "distortion": calib.distortion,
        "rms_px": calib.avg_reprojection_error,
        "per_view_rms_px": calib.per_view_errors.iter().map(|v| json!({"name": v.name, "rms_px": v.rms_px})).collect::<Vec<_>>(),
        "views_used": calib.views_used,
        "views_rejected": calib.views_rejected.iter().map(|v| json!({"name": v.name, "reason": v.reason})).collect::<Vec<_>>(),
        "path": out,
    })
    .to_string();
    finish(callback, text)
}

/// The actuator config: `config` is a TOML file path or JSON text (a dict from
/// `default_config`), then the overrides, then validated (`simulate`'s `resolve`).
fn resolve_config(
    config: Option<&str>,
    config_is_json: bool,
    pressures: Option<String>,
    mesh_size_mm: Option<f64>,
) -> Result<ActuatorConfig, String> {
    let mut cfg = match config {
        Some(text) if config_is_json => serde_json::from_str::<ActuatorConfig>(text)
            .map_err(|e| format!("the config dict is not a valid actuator config: {e} (see bendscope.default_config())"))?,
        Some(path) => {
            let path = Path::new(path);
            let text = std::fs::read_to_string(path)
                .map_err(|e| format!("cannot read actuator config {}: {e}", path.display()))?;
            toml::from_str::<ActuatorConfig>(&text).map_err(|e| {
                format!(
                    "{} is not a valid actuator config: {} (see bendscope simulate --print-config)",
                    path.display(),
                    e.message()
                )
            })?
        }
        None => ActuatorConfig::default(),
    };
    if let Some(h) = mesh_size_mm {
        cfg.mesh.size_mm = h;
    }
    if let Some(p) = pressures {
        cfg.load.pressures_kpa = p;
    }
    cfg.validate().map_err(|e| chain_message(&e))?;
    Ok(cfg)
}

/// Simulates the actuator (`bendscope simulate`) into `out`; returns JSON: the summary,
/// warnings and the config's warnings.
#[pyfunction]
#[pyo3(signature = (out, config=None, config_is_json=false, pressures=None, mesh_size=None, blocked=false, vtu=true, progress=None))]
#[allow(clippy::too_many_arguments)]
fn simulate(
    py: Python<'_>,
    out: PathBuf,
    config: Option<String>,
    config_is_json: bool,
    pressures: Option<String>,
    mesh_size: Option<f64>,
    blocked: bool,
    vtu: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let cfg =
        resolve_config(config.as_deref(), config_is_json, pressures, mesh_size).map_err(error)?;
    let total = cfg.pressures_kpa().map_err(error)?.len() as u64;
    let callback = Callback::new(progress);
    let result = py.detach(|| {
        let mut stage_done: (String, u64) = (String::new(), 0);
        simulate_to(
            &out,
            &cfg,
            SimulateOptions { blocked, vtu },
            &mut |stage, _| {
                if stage_done.0 != stage {
                    stage_done = (stage.to_string(), 0);
                }
                stage_done.1 += 1;
                callback.call(stage, stage_done.1, total);
            },
        )
    });
    let sim = result.map_err(|e| error(chain_message(&e)))?;
    let s = &sim.summary;
    // The CLI's line for a ramp that stopped early (exit 1) or did not start (exit 3).
    let failure = s.failure.as_ref().map(|e| {
        format!(
            "{e}; the {} converged step(s) are written in {}",
            sim.steps.len(),
            out.display()
        )
    });
    if let (Some(line), true) = (&failure, sim.steps.is_empty()) {
        return Err(error(line));
    }
    let text = json!({
        "summary": s,
        "config_warnings": cfg.warnings(),
        "failure": failure,
    })
    .to_string();
    finish(callback, text)
}

/// A family's default actuator config (what `bendscope simulate --family NAME
/// --print-config` prints) as JSON text.
#[pyfunction]
fn default_config(family: &str) -> PyResult<String> {
    let family: bendscope::fem::family::Family = family.parse().map_err(error)?;
    serde_json::to_string(&ActuatorConfig::for_family(family)).map_err(error)
}

/// Compares a process output folder with a simulate output folder (`bendscope
/// compare`); returns JSON: summary, notes, warnings, quantities compared.
#[pyfunction]
#[pyo3(signature = (measured, fem, out, force=None))]
fn compare(
    py: Python<'_>,
    measured: PathBuf,
    fem: PathBuf,
    out: PathBuf,
    force: Option<PathBuf>,
) -> PyResult<String> {
    let report = py
        .detach(|| compare_to(&measured, &fem, force.as_deref(), &out))
        .map_err(|e| error(chain_message(&e)))?;
    Ok(json!({
        "summary": report.summary,
        "notes": report.notes,
        "warnings": report.warnings,
        "compared": report.results.len(),
    })
    .to_string())
}

/// Summarizes a study (`bendscope study`) into `out`: `study_toml` a study.toml, or
/// `samples` as (name, sessions) pairs with `fem` folders; returns JSON: summary,
/// warnings, notes.
#[pyfunction]
#[pyo3(signature = (out, study_toml=None, samples=None, fem=None))]
fn study(
    py: Python<'_>,
    out: PathBuf,
    study_toml: Option<PathBuf>,
    samples: Option<Vec<(String, Vec<PathBuf>)>>,
    fem: Option<Vec<PathBuf>>,
) -> PyResult<String> {
    let spec = match (study_toml, samples) {
        (Some(path), None) => StudySpec::read(&path),
        (None, Some(samples)) => {
            let spec = StudySpec {
                samples: samples
                    .into_iter()
                    .map(|(name, sessions)| SampleSpec { name, sessions })
                    .collect(),
                fem: fem.unwrap_or_default(),
                origin: "samples".into(),
                error_bars: Default::default(),
            };
            spec.check().map(|_| spec)
        }
        _ => return Err(error("give a study.toml or the samples, not both")),
    }
    .map_err(|e| error(chain_message(&e)))?;
    let report = py
        .detach(|| run_study(&spec, &out, &mut Quiet))
        .map_err(|e| error(chain_message(&e)))?;
    Ok(json!({
        "summary": report.summary,
        "warnings": report.warnings,
        "notes": report.notes,
    })
    .to_string())
}

/// Fits a hyperelastic model to uniaxial tensile data (`bendscope material fit`) into
/// `out`; returns JSON: the data's warnings and why no material block was written.
/// `data_name` names the data in the outputs instead of `table` (a DataFrame's
/// temporary CSV the user never wrote).
#[pyfunction]
#[pyo3(signature = (table, out, model="yeoh3", nonnegative=false, data_name=None))]
fn material_fit(
    py: Python<'_>,
    table: PathBuf,
    out: PathBuf,
    model: &str,
    nonnegative: bool,
    data_name: Option<String>,
) -> PyResult<String> {
    let kind = model.parse().map_err(error)?;
    let result = py.detach(|| -> Result<_, String> {
        let mut data = TensileData::read(&table).map_err(|e| e.to_string())?;
        if let Some(name) = &data_name {
            let path = table.display().to_string();
            for w in &mut data.warnings {
                *w = w.replace(&path, name);
            }
        }
        let fit = fit_material(&data, kind, nonnegative)
            .map_err(|e| format!("{}: {e}", table.display()))?;
        let named = data_name
            .map(PathBuf::from)
            .unwrap_or_else(|| table.clone());
        let report =
            write_material_fit(&out, &named, &data, &fit).map_err(|e| chain_message(&e))?;
        Ok((data.warnings, report))
    });
    let (warnings, report) = result.map_err(error)?;
    let refused = match &report.material_block {
        MaterialBlock::Yeoh { .. } => None,
        MaterialBlock::Refused(why) => Some(why.clone()),
    };
    Ok(json!({ "warnings": warnings, "refused": refused }).to_string())
}

/// The native part of the `bendscope` Python package.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("Error", m.py().get_type::<Error>())?;
    m.add_function(wrap_pyfunction!(process, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(default_config, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(study, m)?)?;
    m.add_function(wrap_pyfunction!(material_fit, m)?)?;
    Ok(())
}
