//! Closed-loop control on the model: a PID that bends the simulated actuator to a target
//! angle through a simulated pneumatic line (software in the loop).
//!
//! Data flows: [`reference`] (step, ramp, sine, a `time_s,angle_deg` table) -> [`pid`]
//! (discrete PID, filtered derivative, back-calculation anti-windup) -> [`plant`] (the
//! regulator, dead time, rate limit and lag of the pneumatic line, then the quasi-static
//! angle-pressure map of a `simulate` output, or the FEM solved at every sample through
//! [`crate::fem::stepper`]) -> [`metrics`]. [`tune`] identifies a first-order-plus-dead-
//! time model from a simulated open-loop step and sets PI gains by Skogestad's SIMC rules.
//! [`control_to`] runs it all and writes `control.csv`, `metrics.json` and `plots/`;
//! [`trace`] runs the loop sample by sample, streaming `control.csv` to disk, so memory
//! does not grow with the run (which is limited to [`trace::MAX_SAMPLES`] samples).
//!
//! Conventions: angles in degrees, pressures in kPa (gauge), times in seconds; the
//! controller's output is the regulator's pressure command; the sensor reads the bending
//! angle with seeded Gaussian noise, the metrics use the true angle.

pub mod metrics;
pub mod pid;
pub mod plant;
pub mod reference;
pub mod trace;
pub mod tune;

use std::io::{BufWriter, Write as _};
use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use crate::fem::actuator::{build_mesh, ActuatorConfig};
use crate::fem::stepper::QuasiStaticStepper;
use crate::fem::FemError;
use crate::io::write_atomic_with;
use crate::report::{plot_xy, write_json, Series};
use crate::table::TableError;
use metrics::{StepMetrics, TrackingMetrics};
use pid::{PidGains, PidSettings, DEFAULT_DERIVATIVE_FILTER_N};
use plant::{AngleModel, PneumaticLine, PneumaticSettings, QuasiStaticMap};
use reference::Reference;
use trace::{
    sample_count, write_row, ClosedLoop, Recorded, Recorder, Trace, CSV_HEADER, CSV_ROW_BYTES,
    MAX_SAMPLES,
};
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
    /// The plotted samples of control.csv (the FEM's with --fem-in-loop): all of them
    /// up to [`trace::MAX_PLOT_POINTS`], else every k-th.
    pub trace: Trace,
    /// The plotted samples of the map-in-the-loop run when the FEM was in the loop
    /// (control_map.csv).
    pub map_trace: Option<Trace>,
    /// metrics.json.
    pub report: ControlReport,
}

/// Share of samples at a limit above which a warning is given.
const SATURATION_WARNING_SHARE: f64 = 0.05;

/// Runs the closed loop on the plant of the `simulate` output `fem_dir` and writes
/// `control.csv` (streamed as the loop runs), `metrics.json` and `plots/` (and
/// `control_map.csv` with the FEM in the loop) into `out`. `on_sample(k, n)` sees every
/// sample. A run longer than [`trace::MAX_SAMPLES`] samples is refused at once.
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
    // The line's delay holds one command per sample of its dead time.
    let delay_samples = line.dead_time_s / settings.sample_s;
    if delay_samples > MAX_SAMPLES as f64 {
        return Err(ControlError::Setting {
            name: "sample-time-s".into(),
            why: format!(
                "{} s with a {} s dead time is {delay_samples:.0} delayed samples to hold, more than {MAX_SAMPLES}: lengthen --sample-time-s",
                settings.sample_s, line.dead_time_s
            ),
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
    let samples = sample_count(duration_s, settings.sample_s);
    if samples > MAX_SAMPLES {
        return Err(ControlError::Setting {
            name: "duration-s".into(),
            why: format!(
                "{duration_s} s at {} s per sample is {samples} samples: control.csv would be about {}; at most {MAX_SAMPLES} samples ({} s at this sample time, control.csv about {}): shorten the run or lengthen --sample-time-s",
                settings.sample_s,
                size_text(samples as f64 * CSV_ROW_BYTES),
                (MAX_SAMPLES - 1) as f64 * settings.sample_s,
                size_text(MAX_SAMPLES as f64 * CSV_ROW_BYTES),
            ),
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
    std::fs::create_dir_all(out).map_err(output)?;
    let (run, map_run, fem_report) = match settings.fem_in_loop_mesh_mm {
        None => {
            let mut plant = map.clone();
            let mut lp = ClosedLoop::new(
                &mut plant,
                Some(&map),
                &pid,
                &line,
                &settings.reference,
                duration_s,
            );
            let streamed = stream_loops(out, &map, &mut lp, None, &settings.reference, on_sample)?;
            (streamed.main, None, None)
        }
        Some(mesh_mm) => {
            let (run, map_run, report) = fem_loop(
                out, fem_dir, mesh_mm, &map, &pid, &line, settings, duration_s, on_sample,
            )?;
            (run, Some(map_run), Some(report))
        }
    };
    let saturated_share = run.saturated as f64 / run.samples.max(1) as f64;
    if saturated_share > SATURATION_WARNING_SHARE {
        warnings.push(format!(
            "the pressure command was at the regulator's limit for {:.0}% of the run (highest command {:.1} kPa, bounded by {:.1} kPa)",
            100.0 * saturated_share,
            run.max_pressure_cmd_kpa,
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
        tracking: run.tracking,
        step: run.step,
        saturated_share,
        max_pressure_cmd_kpa: run.max_pressure_cmd_kpa,
        max_pressure_kpa: run.max_pressure_kpa,
        fem_in_loop: fem_report,
        warnings,
    };
    let run = ControlRun {
        trace: run.trace,
        map_trace: map_run.map(|m| m.trace),
        report,
    };
    write_outputs(out, &run)?;
    Ok(run)
}

/// `bytes` for a message: `700 MB`, `7.0 GB`.
fn size_text(bytes: f64) -> String {
    if bytes >= 1e9 {
        format!("{:.1} GB", bytes / 1e9)
    } else {
        format!("{:.0} MB", bytes / 1e6)
    }
}

/// Runs `main` (and `beside`, the map-in-the-loop run compared with it, in step) to
/// their end, streaming every sample to `out/control.csv` (and `out/control_map.csv`),
/// atomically: nothing is written when the loop fails. `on_sample(k, n)` sees each
/// sample. Returns the figures of `main` (and `beside`) and, with `beside`, the largest
/// difference of their angles.
fn stream_loops(
    out: &Path,
    map: &QuasiStaticMap,
    main: &mut ClosedLoop,
    beside: Option<&mut ClosedLoop>,
    reference: &Reference,
    on_sample: &mut dyn FnMut(usize, usize),
) -> Result<Streamed, ControlError> {
    let (n, sample_s) = (main.samples(), main.sample_s());
    let mut state = StreamState {
        main: Recorder::new(n, sample_s, reference),
        beside: Recorder::new(n, sample_s, reference),
        max_difference_deg: 0.0,
        failure: None,
    };
    let written = write_atomic_with(&out.join("control.csv"), |f| {
        let mut main_w = BufWriter::new(f);
        match beside {
            None => state.rows(map, main, &mut main_w, None, on_sample)?,
            Some(lp) => write_atomic_with(&out.join("control_map.csv"), |g| {
                let mut beside_w = BufWriter::new(g);
                state.rows(map, main, &mut main_w, Some((lp, &mut beside_w)), on_sample)?;
                beside_w.flush()
            })?,
        }
        main_w.flush()
    });
    if let Some(e) = state.failure {
        return Err(e);
    }
    written.map_err(output)?;
    Ok(Streamed {
        main: state.main.finish(),
        beside: state.beside.finish(),
        max_difference_deg: state.max_difference_deg,
    })
}

/// The figures [`stream_loops`] gathers while it writes.
struct StreamState {
    main: Recorder,
    beside: Recorder,
    max_difference_deg: f64,
    /// Why the loop stopped (the writes then fail, removing their temporary files).
    failure: Option<ControlError>,
}

impl StreamState {
    fn stop(&mut self, e: ControlError) -> std::io::Error {
        self.failure = Some(e);
        std::io::Error::other("the closed loop failed")
    }

    /// Writes the header and every sample of `main` into `main_w` (and of the loop
    /// beside it into its writer).
    fn rows(
        &mut self,
        map: &QuasiStaticMap,
        main: &mut ClosedLoop,
        main_w: &mut dyn std::io::Write,
        mut beside: Option<(&mut ClosedLoop, &mut dyn std::io::Write)>,
        on_sample: &mut dyn FnMut(usize, usize),
    ) -> std::io::Result<()> {
        let last = main.samples().saturating_sub(1);
        main_w.write_all(CSV_HEADER.as_bytes())?;
        if let Some((_, w)) = &mut beside {
            w.write_all(CSV_HEADER.as_bytes())?;
        }
        let mut k = 0;
        while let Some(sample) = main.next_sample() {
            let s = sample.map_err(|e| self.stop(e))?;
            write_row(main_w, &s, map.radius_mm(s.pressure_kpa))?;
            self.main.push(&s);
            if let Some((lp, w)) = &mut beside {
                if let Some(other) = lp.next_sample() {
                    let o = other.map_err(|e| self.stop(e))?;
                    write_row(*w, &o, map.radius_mm(o.pressure_kpa))?;
                    self.beside.push(&o);
                    self.max_difference_deg = self
                        .max_difference_deg
                        .max((s.angle_deg - o.angle_deg).abs());
                }
            }
            on_sample(k, last);
            k += 1;
        }
        Ok(())
    }
}

/// What [`stream_loops`] kept of its runs.
struct Streamed {
    main: Recorded,
    beside: Recorded,
    max_difference_deg: f64,
}

/// The loop with the FEM solved at every sample, run in step with the map's loop
/// (`control.csv` and `control_map.csv`); the figures of both and the comparison.
#[allow(clippy::too_many_arguments)]
fn fem_loop(
    out: &Path,
    fem_dir: &Path,
    mesh_mm: f64,
    map: &QuasiStaticMap,
    pid: &PidSettings,
    line: &PneumaticSettings,
    settings: &ControlSettings,
    duration_s: f64,
    on_sample: &mut dyn FnMut(usize, usize),
) -> Result<(Recorded, Recorded, FemLoopReport), ControlError> {
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
    let mut map_plant = map.clone();
    let reference = &settings.reference;
    let streamed = {
        let mut fem = ClosedLoop::new(&mut plant, Some(map), pid, line, reference, duration_s);
        let mut beside =
            ClosedLoop::new(&mut map_plant, Some(map), pid, line, reference, duration_s);
        stream_loops(out, map, &mut fem, Some(&mut beside), reference, on_sample)?
    };
    let report = FemLoopReport {
        mesh_size_mm: mesh_mm,
        map_mesh_size_mm,
        solves: plant.solves,
        newton_iterations: plant.newton_iterations,
        fem_seconds: plant.seconds,
        seconds_per_sample: plant.seconds / streamed.main.samples.max(1) as f64,
        max_abs_difference_deg: streamed.max_difference_deg,
        map_tracking: streamed.beside.tracking,
        map_step: streamed.beside.step,
    };
    Ok((streamed.main, streamed.beside, report))
}

/// Writes `metrics.json` and the plots (the CSV files are streamed by the loop).
fn write_outputs(out: &Path, run: &ControlRun) -> Result<(), ControlError> {
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
            errors: None,
        },
        Series {
            label: if fem {
                "angle (FEM in the loop)"
            } else {
                "angle"
            },
            points: xy(t, &t.angle_deg),
            line: true,
            errors: None,
        },
    ];
    let mut pressure = vec![
        Series {
            label: "command",
            points: xy(t, &t.pressure_cmd_kpa),
            line: true,
            errors: None,
        },
        Series {
            label: if fem {
                "pressure (FEM in the loop)"
            } else {
                "pressure"
            },
            points: xy(t, &t.pressure_kpa),
            line: true,
            errors: None,
        },
    ];
    if let Some(m) = &run.map_trace {
        angle.push(Series {
            label: "angle (map in the loop)",
            points: xy(m, &m.angle_deg),
            line: true,
            errors: None,
        });
        pressure.push(Series {
            label: "pressure (map in the loop)",
            points: xy(m, &m.pressure_kpa),
            line: true,
            errors: None,
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
