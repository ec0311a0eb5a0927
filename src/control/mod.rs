//! Closed-loop control on the model: a PID that bends the simulated actuator to a target
//! angle through a simulated pneumatic line (software in the loop).
//!
//! Data flows: [`reference`] (step, ramp, sine, a `time_s,angle_deg` table) -> [`pid`]
//! (discrete PID, filtered derivative, back-calculation anti-windup) -> [`plant`] (the
//! regulator, dead time, rate limit and lag of the pneumatic line, then the quasi-static
//! angle-pressure map of a `simulate` output, or the FEM solved at every sample through
//! [`crate::fem::stepper`]) -> [`metrics`]. [`tune`] identifies a first-order-plus-dead-
//! time model from a simulated open-loop step and sets PI gains by Skogestad's SIMC rules.
//! [`control_to`] runs it all and writes `control.csv`, `metrics.json` and `plots/`.
//!
//! Conventions: angles in degrees, pressures in kPa (gauge), times in seconds; the
//! controller's output is the regulator's pressure command; the sensor reads the bending
//! angle with seeded Gaussian noise, the metrics use the true angle.

pub mod metrics;
pub mod pid;
pub mod plant;
pub mod reference;
pub mod tune;

use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use crate::fem::actuator::{build_mesh, ActuatorConfig};
use crate::fem::stepper::QuasiStaticStepper;
use crate::fem::FemError;
use crate::report::{plot_xy, write_json, Series};
use crate::table::{write_csv, Column, TableError};
use metrics::{step_metrics, tracking_metrics, StepMetrics, TrackingMetrics};
use pid::{Pid, PidGains, PidSettings, DEFAULT_DERIVATIVE_FILTER_N};
use plant::{AngleModel, PneumaticLine, PneumaticSettings, QuasiStaticMap};
use reference::Reference;
use tune::{effective_dead_time_s, identify_fopdt, simc_gains, Fopdt, DEFAULT_TAU_C_PER_DEAD_TIME};

/// Default sample time of the controller, s (100 Hz, a typical embedded loop).
pub const DEFAULT_SAMPLE_S: f64 = 0.01;

/// Default element size of the FEM in the loop, mm: coarse, so that a sample solves in
/// a fraction of a second.
pub const DEFAULT_FEM_MESH_MM: f64 = 4.0;

/// Length of the simulated open-loop step for tuning, in time constants of the line.
const TUNE_STEP_TAUS: f64 = 12.0;

/// Errors of closed-loop control.
#[derive(Debug, thiserror::Error)]
pub enum ControlError {
    /// The plant map (steps.csv) is not usable.
    #[error("plant: {why}")]
    Map {
        /// What is wrong and what to do.
        why: String,
    },
    /// A setting is out of range.
    #[error("--{name}: {why}")]
    Setting {
        /// The flag.
        name: String,
        /// What is wrong and what to do.
        why: String,
    },
    /// Tuning failed.
    #[error("--tune: {why}")]
    Tune {
        /// What is wrong and what to do.
        why: String,
    },
    /// A table (steps.csv, a reference CSV) is malformed.
    #[error(transparent)]
    Table(#[from] TableError),
    /// The FEM in the loop failed.
    #[error("FEM in the loop: {0}")]
    Fem(#[from] FemError),
    /// A result file could not be written.
    #[error("cannot write the results: {why}: check the output folder's space and permissions")]
    Output {
        /// What failed.
        why: String,
    },
}

fn output(e: impl std::fmt::Display) -> ControlError {
    ControlError::Output { why: e.to_string() }
}

/// Where the gains come from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GainChoice {
    /// Given by the user.
    Given(PidGains),
    /// SIMC on an FOPDT model identified from an open-loop step (closed-loop time
    /// constant τc, None: 1.5 effective dead times, see [`tune`]).
    Tune {
        /// τc, s.
        tau_c_s: Option<f64>,
    },
}

/// Everything a closed-loop run needs besides the plant.
#[derive(Debug, Clone)]
pub struct ControlSettings {
    /// The reference.
    pub reference: Reference,
    /// Length of the run, s (None: the reference's default).
    pub duration_s: Option<f64>,
    /// Controller sample time, s.
    pub sample_s: f64,
    /// The pneumatic line; its regulator range is replaced by the map's pressure range
    /// when `regulator_from_map` is set.
    pub pneumatics: PneumaticSettings,
    /// Take the regulator range from the simulated pressures.
    pub regulator_from_map: bool,
    /// The gains.
    pub gains: GainChoice,
    /// Set-point weight of the proportional term.
    pub setpoint_weight: f64,
    /// Derivative filter divisor N.
    pub derivative_filter_n: f64,
    /// Also run the loop with the FEM solved at every sample, on a mesh of this size, mm.
    pub fem_in_loop_mesh_mm: Option<f64>,
}

impl Default for ControlSettings {
    fn default() -> Self {
        Self {
            reference: Reference::Step { angle_deg: 90.0 },
            duration_s: None,
            sample_s: DEFAULT_SAMPLE_S,
            pneumatics: PneumaticSettings::default(),
            regulator_from_map: true,
            gains: GainChoice::Tune { tau_c_s: None },
            setpoint_weight: 1.0,
            derivative_filter_n: DEFAULT_DERIVATIVE_FILTER_N,
            fem_in_loop_mesh_mm: None,
        }
    }
}

/// One closed-loop run, sample by sample.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trace {
    /// Sample times, s.
    pub time_s: Vec<f64>,
    /// Reference, degrees.
    pub reference_deg: Vec<f64>,
    /// True bending angle, degrees.
    pub angle_deg: Vec<f64>,
    /// The sensor's reading (with noise), degrees.
    pub measured_deg: Vec<f64>,
    /// Controller output (regulator command), kPa.
    pub pressure_cmd_kpa: Vec<f64>,
    /// Pressure in the actuator, kPa.
    pub pressure_kpa: Vec<f64>,
    /// Whether the controller output was at a limit.
    pub saturated: Vec<bool>,
}

/// Runs the loop: `plant` turns the line's pressure into the true angle; the line
/// starts at rest at its lowest pressure. `on_sample(k, n)` sees each sample.
pub fn run_loop(
    plant: &mut dyn AngleModel,
    map: Option<&QuasiStaticMap>,
    pid: &PidSettings,
    line: &PneumaticSettings,
    reference: &Reference,
    duration_s: f64,
    on_sample: &mut dyn FnMut(usize, usize),
) -> Result<Trace, ControlError> {
    let h = pid.sample_s;
    let n = (duration_s / h).round() as usize;
    let mut line_state = PneumaticLine::new(*line, h, line.min_kpa);
    let mut controller = Pid::new(*pid, line.min_kpa);
    let mut trace = Trace::default();
    for k in 0..=n {
        let t = k as f64 * h;
        let p = line_state.pressure_kpa();
        let angle = plant.angle_deg(p)?;
        let measured = line_state.measure(angle);
        let r = reference.at_deg(t);
        let (u, saturated) = controller.update(r, measured);
        trace.time_s.push(t);
        trace.reference_deg.push(r);
        trace.angle_deg.push(angle);
        trace.measured_deg.push(measured);
        trace.pressure_cmd_kpa.push(u);
        trace.pressure_kpa.push(p);
        trace.saturated.push(saturated);
        line_state.step(u, map);
        on_sample(k, n);
    }
    Ok(trace)
}

/// The open-loop step used for tuning and the model identified from it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Tuning {
    /// Pressure before the step, kPa.
    pub from_kpa: f64,
    /// Pressure commanded, kPa.
    pub to_kpa: f64,
    /// The identified model.
    pub model: Fopdt,
    /// τc used by SIMC, s.
    pub tau_c_s: f64,
}

/// Identifies an FOPDT model from an open-loop step of the line (no noise) from its
/// lowest pressure to `to_kpa` on `map`, and returns SIMC gains.
pub fn tune_on_map(
    map: &QuasiStaticMap,
    line: &PneumaticSettings,
    to_kpa: f64,
    tau_c_s: Option<f64>,
    sample_s: f64,
) -> Result<(PidGains, Tuning), ControlError> {
    let quiet = PneumaticSettings {
        noise_deg: 0.0,
        ..*line
    };
    let mut state = PneumaticLine::new(quiet, sample_s, line.min_kpa);
    let to = state.setpoint_kpa(to_kpa);
    let from = line.min_kpa;
    if to - from <= 0.0 {
        return Err(ControlError::Tune {
            why: format!("the operating point ({to_kpa:.1} kPa) is at the regulator's minimum: raise the target"),
        });
    }
    let tau = state.tau_s(Some(map), to).max(state.tau_s(Some(map), from));
    let ramp = (to - from) / line.rate_limit_kpa_s;
    let length = (TUNE_STEP_TAUS * tau + ramp + 2.0 * line.dead_time_s).max(50.0 * sample_s);
    let n = (length / sample_s).ceil() as usize;
    let y0 = map.angle_deg(from);
    let (mut t, mut dy) = (vec![0.0], vec![0.0]);
    for k in 1..=n {
        let p = state.step(to, Some(map));
        t.push(k as f64 * sample_s);
        dy.push(map.angle_deg(p) - y0);
    }
    let model = identify_fopdt(&t, &dy, to - from)?;
    let gains = simc_gains(&model, tau_c_s, sample_s);
    Ok((
        gains,
        Tuning {
            from_kpa: from,
            to_kpa: to,
            model,
            tau_c_s: tau_c_s
                .unwrap_or(DEFAULT_TAU_C_PER_DEAD_TIME * effective_dead_time_s(&model, sample_s)),
        },
    ))
}

/// The FEM in the loop: the stepper and what it cost.
struct FemPlant<'m> {
    stepper: QuasiStaticStepper<'m>,
    solves: usize,
    newton_iterations: usize,
    seconds: f64,
}

impl AngleModel for FemPlant<'_> {
    fn angle_deg(&mut self, pressure_kpa: f64) -> Result<f64, ControlError> {
        let started = Instant::now();
        let s = self.stepper.solve_at(pressure_kpa)?;
        self.seconds += started.elapsed().as_secs_f64();
        if s.newton_iterations > 0 {
            self.solves += 1;
            self.newton_iterations += s.newton_iterations;
        }
        Ok(s.bending_angle_deg)
    }
}

/// What the FEM-in-the-loop run cost and how far it is from the map's.
#[derive(Debug, Clone, Serialize)]
pub struct FemLoopReport {
    /// Element size of the FEM in the loop, mm.
    pub mesh_size_mm: f64,
    /// Element size of the simulation the map comes from, mm.
    pub map_mesh_size_mm: f64,
    /// FEM solves (samples whose pressure changed).
    pub solves: usize,
    /// Newton iterations in all.
    pub newton_iterations: usize,
    /// Seconds in the FEM, in all.
    pub fem_seconds: f64,
    /// Seconds in the FEM per control sample.
    pub seconds_per_sample: f64,
    /// Largest |angle (FEM in the loop) − angle (map in the loop)| over the run, degrees.
    pub max_abs_difference_deg: f64,
    /// The map-in-the-loop run's tracking figures (control_map.csv).
    pub map_tracking: TrackingMetrics,
    /// The map-in-the-loop run's step figures.
    pub map_step: Option<StepMetrics>,
}

/// `metrics.json`: the run's settings, figures and warnings.
#[derive(Debug, Clone, Serialize)]
pub struct ControlReport {
    /// `map` or `fem-in-loop`: the plant of control.csv.
    pub plant: String,
    /// The reference.
    pub reference: Reference,
    /// Length of the run, s.
    pub duration_s: f64,
    /// Controller sample time, s.
    pub sample_time_s: f64,
    /// The gains used.
    pub gains: PidGains,
    /// How they were tuned (with --tune).
    pub tuning: Option<Tuning>,
    /// The pneumatic line.
    pub pneumatics: PneumaticSettings,
    /// The lag's time constant over the regulator range, s (smallest, largest).
    pub lag_tau_s: (f64, f64),
    /// The largest angle the actuator reaches within the regulator range, degrees.
    pub reachable_deg: f64,
    /// Tracking figures.
    pub tracking: TrackingMetrics,
    /// Step figures (step references only).
    pub step: Option<StepMetrics>,
    /// Share of the samples whose controller output was at a limit.
    pub saturated_share: f64,
    /// Highest pressure command and pressure, kPa.
    pub max_pressure_cmd_kpa: f64,
    /// Highest pressure in the actuator, kPa.
    pub max_pressure_kpa: f64,
    /// The FEM-in-the-loop comparison (with --fem-in-loop).
    pub fem_in_loop: Option<FemLoopReport>,
    /// What the user must know (target beyond reach, saturation).
    pub warnings: Vec<String>,
}

/// A finished run: the trace(s) and the report.
#[derive(Debug, Clone)]
pub struct ControlRun {
    /// The trace of control.csv (the FEM's with --fem-in-loop).
    pub trace: Trace,
    /// The map-in-the-loop trace when the FEM was in the loop (control_map.csv).
    pub map_trace: Option<Trace>,
    /// metrics.json.
    pub report: ControlReport,
}

/// Share of samples at a limit above which a warning is given.
const SATURATION_WARNING_SHARE: f64 = 0.05;

/// Runs the closed loop on the plant of the `simulate` output `fem_dir` and writes
/// `control.csv`, `metrics.json` and `plots/` (and `control_map.csv` with the FEM in
/// the loop) into `out`. `on_sample(k, n)` sees every sample of the FEM loop.
pub fn control_to(
    out: &Path,
    fem_dir: &Path,
    settings: &ControlSettings,
    on_sample: &mut dyn FnMut(usize, usize),
) -> Result<ControlRun, ControlError> {
    let map = QuasiStaticMap::from_simulation(fem_dir)?;
    let mut line = settings.pneumatics;
    let (p_lo, p_hi) = map.pressure_range_kpa();
    if settings.regulator_from_map {
        line.min_kpa = p_lo.max(0.0);
        line.max_kpa = p_hi;
    }
    line.validate()?;
    if !(settings.sample_s.is_finite() && settings.sample_s > 0.0) {
        return Err(ControlError::Setting {
            name: "sample-time-s".into(),
            why: format!("{} s: give a sample time > 0", settings.sample_s),
        });
    }
    let duration_s = settings
        .duration_s
        .unwrap_or_else(|| settings.reference.default_duration_s());
    if !(duration_s.is_finite() && duration_s >= settings.sample_s) {
        return Err(ControlError::Setting {
            name: "duration-s".into(),
            why: format!("{duration_s} s: give a run at least one sample long"),
        });
    }
    let mut warnings = Vec::new();
    let top = line.max_kpa.min(p_hi);
    let reachable_deg = map.angle_deg(top);
    let resting_deg = map.angle_deg(line.min_kpa);
    let wanted_max = settings.reference.max_deg(duration_s);
    if wanted_max > reachable_deg {
        let why = if line.max_kpa < p_hi {
            "the regulator's maximum"
        } else {
            "the simulation's top pressure"
        };
        warnings.push(format!(
            "the reference asks for {wanted_max:.1} deg but the actuator reaches at most {reachable_deg:.1} deg at {top:.1} kPa ({why}): the pressure saturates there and the angle stays short; lower the target, or raise --regulator-kpa and simulate higher pressures"
        ));
    }
    let wanted_min = settings.reference.min_deg(duration_s);
    if wanted_min < resting_deg - 1e-9 {
        warnings.push(format!(
            "the reference asks for {wanted_min:.1} deg, below the {resting_deg:.1} deg the actuator rests at with {:.1} kPa: the pressure stays at the regulator's minimum there",
            line.min_kpa
        ));
    }
    if line.max_kpa > p_hi + 1e-9 || line.min_kpa < p_lo - 1e-9 {
        warnings.push(format!(
            "the regulator range {:.1}..{:.1} kPa leaves the simulated {p_lo:.1}..{p_hi:.1} kPa: the angle is held at the end values beyond; simulate the whole range",
            line.min_kpa, line.max_kpa
        ));
    }
    let (gains, tuning) = match settings.gains {
        GainChoice::Given(g) => (g, None),
        GainChoice::Tune { tau_c_s } => {
            let target = wanted_max.min(reachable_deg);
            let to = map
                .pressure_for_angle_kpa(target, line.min_kpa, top)
                .unwrap_or(top);
            let (g, t) = tune_on_map(&map, &line, to, tau_c_s, settings.sample_s)?;
            (g, Some(t))
        }
    };
    let pid = PidSettings {
        gains,
        sample_s: settings.sample_s,
        min_kpa: line.min_kpa,
        max_kpa: line.max_kpa,
        setpoint_weight: settings.setpoint_weight,
        derivative_filter_n: settings.derivative_filter_n,
        tracking_s: None,
    };
    pid.validate()?;
    let mut map_plant = map.clone();
    let map_trace = run_loop(
        &mut map_plant,
        Some(&map),
        &pid,
        &line,
        &settings.reference,
        duration_s,
        &mut |_, _| {},
    )?;
    let (trace, map_trace, fem_report) = match settings.fem_in_loop_mesh_mm {
        None => (map_trace, None, None),
        Some(mesh_mm) => {
            let (trace, report) = fem_loop(
                fem_dir, mesh_mm, &map, &pid, &line, settings, duration_s, &map_trace, on_sample,
            )?;
            (trace, Some(map_trace), Some(report))
        }
    };
    let n = trace.time_s.len().max(1) as f64;
    let saturated_share = trace.saturated.iter().filter(|s| **s).count() as f64 / n;
    if saturated_share > SATURATION_WARNING_SHARE {
        warnings.push(format!(
            "the pressure command was at the regulator's limit for {:.0}% of the run (highest command {:.1} kPa, bounded by {:.1} kPa)",
            100.0 * saturated_share,
            trace.pressure_cmd_kpa.iter().fold(f64::NEG_INFINITY, |a, b| a.max(*b)),
            line.max_kpa
        ));
    }
    let taus: Vec<f64> = (0..=20)
        .map(|k| {
            let p = line.min_kpa + (line.max_kpa - line.min_kpa) * k as f64 / 20.0;
            PneumaticLine::new(line, settings.sample_s, p).tau_s(Some(&map), p)
        })
        .collect();
    let report = ControlReport {
        plant: if fem_report.is_some() {
            "fem-in-loop"
        } else {
            "map"
        }
        .into(),
        reference: settings.reference.clone(),
        duration_s,
        sample_time_s: settings.sample_s,
        gains,
        tuning,
        pneumatics: line,
        lag_tau_s: (
            taus.iter().copied().fold(f64::INFINITY, f64::min),
            taus.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        ),
        reachable_deg,
        tracking: tracking_metrics(&trace.reference_deg, &trace.angle_deg, settings.sample_s),
        step: step_of(&settings.reference, &trace),
        saturated_share,
        max_pressure_cmd_kpa: trace
            .pressure_cmd_kpa
            .iter()
            .fold(f64::NEG_INFINITY, |a, b| a.max(*b)),
        max_pressure_kpa: trace
            .pressure_kpa
            .iter()
            .fold(f64::NEG_INFINITY, |a, b| a.max(*b)),
        fem_in_loop: fem_report,
        warnings,
    };
    let run = ControlRun {
        trace,
        map_trace,
        report,
    };
    write_outputs(out, &run, &map)?;
    Ok(run)
}

/// Step figures when the reference is a step.
fn step_of(reference: &Reference, trace: &Trace) -> Option<StepMetrics> {
    match reference {
        Reference::Step { angle_deg } => Some(step_metrics(
            &trace.time_s,
            &trace.angle_deg,
            trace.angle_deg.first().copied().unwrap_or(0.0),
            *angle_deg,
        )),
        _ => None,
    }
}

/// The loop with the FEM solved at every sample, compared with the map's run.
#[allow(clippy::too_many_arguments)]
fn fem_loop(
    fem_dir: &Path,
    mesh_mm: f64,
    map: &QuasiStaticMap,
    pid: &PidSettings,
    line: &PneumaticSettings,
    settings: &ControlSettings,
    duration_s: f64,
    map_trace: &Trace,
    on_sample: &mut dyn FnMut(usize, usize),
) -> Result<(Trace, FemLoopReport), ControlError> {
    let path = fem_dir.join("config.toml");
    let text = std::fs::read_to_string(&path).map_err(|e| ControlError::Map {
        why: format!(
            "{}: {e}: --fem-in-loop needs the actuator of the simulation (its config.toml)",
            path.display()
        ),
    })?;
    let mut cfg: ActuatorConfig = toml::from_str(&text).map_err(|e| ControlError::Map {
        why: format!(
            "{} is not a valid actuator config: {}",
            path.display(),
            e.message()
        ),
    })?;
    let map_mesh_size_mm = cfg.mesh.size_mm;
    if !(mesh_mm.is_finite() && mesh_mm > 0.0) {
        return Err(ControlError::Setting {
            name: "fem-mesh-mm".into(),
            why: format!("{mesh_mm}: give an element size > 0 mm"),
        });
    }
    cfg.mesh.size_mm = mesh_mm;
    let mesh = build_mesh(&cfg)?;
    let mut plant = FemPlant {
        stepper: QuasiStaticStepper::new(&mesh, cfg.solver.newton())?,
        solves: 0,
        newton_iterations: 0,
        seconds: 0.0,
    };
    let trace = run_loop(
        &mut plant,
        Some(map),
        pid,
        line,
        &settings.reference,
        duration_s,
        on_sample,
    )?;
    let max_abs_difference_deg = trace
        .angle_deg
        .iter()
        .zip(&map_trace.angle_deg)
        .fold(0.0, |m, (a, b)| f64::max(m, (a - b).abs()));
    let report = FemLoopReport {
        mesh_size_mm: mesh_mm,
        map_mesh_size_mm,
        solves: plant.solves,
        newton_iterations: plant.newton_iterations,
        fem_seconds: plant.seconds,
        seconds_per_sample: plant.seconds / trace.time_s.len().max(1) as f64,
        max_abs_difference_deg,
        map_tracking: tracking_metrics(
            &map_trace.reference_deg,
            &map_trace.angle_deg,
            pid.sample_s,
        ),
        map_step: step_of(&settings.reference, map_trace),
    };
    Ok((trace, report))
}

/// Writes a trace as CSV.
fn write_trace(path: &Path, trace: &Trace, map: &QuasiStaticMap) -> Result<(), ControlError> {
    write_csv(
        path,
        &[
            Column::num("time_s", 4, trace.time_s.iter().copied()),
            Column::num("reference_deg", 4, trace.reference_deg.iter().copied()),
            Column::num("angle_deg", 4, trace.angle_deg.iter().copied()),
            Column::num("measured_angle_deg", 4, trace.measured_deg.iter().copied()),
            Column::num(
                "pressure_cmd_kpa",
                4,
                trace.pressure_cmd_kpa.iter().copied(),
            ),
            Column::num("pressure_kpa", 4, trace.pressure_kpa.iter().copied()),
            Column::num(
                "radius_mm",
                3,
                trace.pressure_kpa.iter().map(|p| map.radius_mm(*p)),
            ),
            Column::int("saturated", trace.saturated.iter().map(|s| u64::from(*s))),
        ],
    )
    .map_err(output)
}

fn write_outputs(out: &Path, run: &ControlRun, map: &QuasiStaticMap) -> Result<(), ControlError> {
    std::fs::create_dir_all(out).map_err(output)?;
    write_trace(&out.join("control.csv"), &run.trace, map)?;
    if let Some(m) = &run.map_trace {
        write_trace(&out.join("control_map.csv"), m, map)?;
    }
    write_json(&out.join("metrics.json"), &run.report).map_err(output)?;
    let xy = |t: &Trace, v: &[f64]| -> Vec<(f64, f64)> {
        t.time_s.iter().copied().zip(v.iter().copied()).collect()
    };
    let t = &run.trace;
    let fem = run.map_trace.is_some();
    let mut angle = vec![
        Series {
            label: "reference",
            points: xy(t, &t.reference_deg),
            line: true,
        },
        Series {
            label: if fem {
                "angle (FEM in the loop)"
            } else {
                "angle"
            },
            points: xy(t, &t.angle_deg),
            line: true,
        },
    ];
    let mut pressure = vec![
        Series {
            label: "command",
            points: xy(t, &t.pressure_cmd_kpa),
            line: true,
        },
        Series {
            label: if fem {
                "pressure (FEM in the loop)"
            } else {
                "pressure"
            },
            points: xy(t, &t.pressure_kpa),
            line: true,
        },
    ];
    if let Some(m) = &run.map_trace {
        angle.push(Series {
            label: "angle (map in the loop)",
            points: xy(m, &m.angle_deg),
            line: true,
        });
        pressure.push(Series {
            label: "pressure (map in the loop)",
            points: xy(m, &m.pressure_kpa),
            line: true,
        });
    }
    let plots = out.join("plots");
    plot_xy(
        &plots.join("angle"),
        "Bending angle: reference and response",
        "time (s)",
        "bending angle (deg)",
        &angle,
    )
    .map_err(output)?;
    plot_xy(
        &plots.join("pressure"),
        "Pressure: command and actuator",
        "time (s)",
        "pressure (kPa)",
        &pressure,
    )
    .map_err(output)?;
    Ok(())
}
