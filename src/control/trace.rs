//! A closed-loop run sample by sample, and what is kept of it: every sample streamed to
//! `control.csv` as the loop runs, figures of merit gathered on the way, and at most
//! [`MAX_PLOT_POINTS`] samples kept for the plots. Memory does not grow with the run's
//! length; the CSV does, so a run is limited to [`MAX_SAMPLES`] samples.

use std::io::Write;

use super::metrics::{StepAccumulator, StepMetrics, TrackingAccumulator, TrackingMetrics};
use super::pid::{Pid, PidSettings};
use super::plant::{AngleModel, PneumaticLine, PneumaticSettings, QuasiStaticMap};
use super::reference::Reference;
use super::ControlError;

/// Most samples of one run: its `control.csv` holds one row per sample, about
/// [`CSV_ROW_BYTES`] each, so at most about 700 MB (100,000 s at the default 0.01 s).
pub const MAX_SAMPLES: usize = 10_000_000;

/// Size of a `control.csv` row, bytes: eight numbers at 4 decimals (about 60-70 bytes
/// measured), for the size a refused run would have written.
pub const CSV_ROW_BYTES: f64 = 70.0;

/// Most samples kept per series for the plots; a longer run keeps every k-th sample
/// (and the last).
pub const MAX_PLOT_POINTS: usize = 100_000;

/// The header of `control.csv` (and `control_map.csv`).
pub const CSV_HEADER: &str = "time_s,reference_deg,angle_deg,measured_angle_deg,pressure_cmd_kpa,pressure_kpa,radius_mm,saturated\n";

/// One sample of a closed-loop run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time, s.
    pub time_s: f64,
    /// Reference, degrees.
    pub reference_deg: f64,
    /// True bending angle, degrees.
    pub angle_deg: f64,
    /// The sensor's reading (with noise), degrees.
    pub measured_deg: f64,
    /// Controller output (regulator command), kPa.
    pub pressure_cmd_kpa: f64,
    /// Pressure in the actuator, kPa.
    pub pressure_kpa: f64,
    /// Whether the controller output was at a limit.
    pub saturated: bool,
}

/// Samples of a run kept for the plots (every `stride`-th, and the last).
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

impl Trace {
    fn push(&mut self, s: &Sample) {
        self.time_s.push(s.time_s);
        self.reference_deg.push(s.reference_deg);
        self.angle_deg.push(s.angle_deg);
        self.measured_deg.push(s.measured_deg);
        self.pressure_cmd_kpa.push(s.pressure_cmd_kpa);
        self.pressure_kpa.push(s.pressure_kpa);
        self.saturated.push(s.saturated);
    }
}

/// Number of samples of a run of `duration_s` at `sample_s` (both ends included).
pub fn sample_count(duration_s: f64, sample_s: f64) -> usize {
    (duration_s / sample_s).round() as usize + 1
}

/// The loop: `plant` turns the line's pressure into the true angle; the line starts at
/// rest at its lowest pressure. Each [`ClosedLoop::next_sample`] advances one sample.
pub struct ClosedLoop<'a> {
    plant: &'a mut dyn AngleModel,
    map: Option<&'a QuasiStaticMap>,
    reference: &'a Reference,
    line: PneumaticLine,
    controller: Pid,
    sample_s: f64,
    /// Samples in the run.
    samples: usize,
    next: usize,
}

impl<'a> ClosedLoop<'a> {
    /// A run of `duration_s` ([`sample_count`] samples); `map` gives the cavity volume
    /// for a valve-driven lag.
    pub fn new(
        plant: &'a mut dyn AngleModel,
        map: Option<&'a QuasiStaticMap>,
        pid: &PidSettings,
        line: &PneumaticSettings,
        reference: &'a Reference,
        duration_s: f64,
    ) -> Self {
        Self {
            plant,
            map,
            reference,
            line: PneumaticLine::new(*line, pid.sample_s, line.min_kpa),
            controller: Pid::new(*pid, line.min_kpa),
            sample_s: pid.sample_s,
            samples: sample_count(duration_s, pid.sample_s),
            next: 0,
        }
    }

    /// Samples in the run.
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// Time between samples, s.
    pub fn sample_s(&self) -> f64 {
        self.sample_s
    }

    /// The next sample (`None` after the last).
    pub fn next_sample(&mut self) -> Option<Result<Sample, ControlError>> {
        if self.next >= self.samples {
            return None;
        }
        let t = self.next as f64 * self.sample_s;
        self.next += 1;
        let p = self.line.pressure_kpa();
        let angle = match self.plant.angle_deg(p) {
            Ok(a) => a,
            Err(e) => return Some(Err(e)),
        };
        let measured = self.line.measure(angle);
        let r = self.reference.at_deg(t);
        let (u, saturated) = self.controller.update(r, measured);
        self.line.step(u, self.map);
        Some(Ok(Sample {
            time_s: t,
            reference_deg: r,
            angle_deg: angle,
            measured_deg: measured,
            pressure_cmd_kpa: u,
            pressure_kpa: p,
            saturated,
        }))
    }
}

/// What is kept of a run while it streams: figures of merit, counts, extremes and the
/// plotted samples.
#[derive(Debug, Clone)]
pub struct Recorder {
    samples: usize,
    stride: usize,
    seen: usize,
    tracking: TrackingAccumulator,
    /// The step's figures (step references), from the first sample's angle.
    step_target_deg: Option<f64>,
    step: Option<StepAccumulator>,
    saturated: usize,
    max_pressure_cmd_kpa: f64,
    max_pressure_kpa: f64,
    trace: Trace,
}

/// A finished run's figures.
#[derive(Debug, Clone)]
pub struct Recorded {
    /// Samples in the run.
    pub samples: usize,
    /// The plotted samples.
    pub trace: Trace,
    /// Tracking figures.
    pub tracking: TrackingMetrics,
    /// Step figures (step references only).
    pub step: Option<StepMetrics>,
    /// Samples whose controller output was at a limit.
    pub saturated: usize,
    /// Highest pressure command, kPa.
    pub max_pressure_cmd_kpa: f64,
    /// Highest pressure in the actuator, kPa.
    pub max_pressure_kpa: f64,
}

impl Recorder {
    /// For a run of `samples` samples `sample_s` apart following `reference`.
    pub fn new(samples: usize, sample_s: f64, reference: &Reference) -> Self {
        Self {
            samples,
            stride: samples.div_ceil(MAX_PLOT_POINTS).max(1),
            seen: 0,
            tracking: TrackingAccumulator::new(sample_s),
            step_target_deg: match reference {
                Reference::Step { angle_deg } => Some(*angle_deg),
                _ => None,
            },
            step: None,
            saturated: 0,
            max_pressure_cmd_kpa: f64::NEG_INFINITY,
            max_pressure_kpa: f64::NEG_INFINITY,
            trace: Trace::default(),
        }
    }

    /// Adds the next sample.
    pub fn push(&mut self, s: &Sample) {
        self.tracking.push(s.reference_deg, s.angle_deg);
        if let Some(target) = self.step_target_deg {
            self.step
                .get_or_insert_with(|| StepAccumulator::new(s.angle_deg, target, self.samples))
                .push(s.time_s, s.angle_deg);
        }
        self.saturated += usize::from(s.saturated);
        self.max_pressure_cmd_kpa = self.max_pressure_cmd_kpa.max(s.pressure_cmd_kpa);
        self.max_pressure_kpa = self.max_pressure_kpa.max(s.pressure_kpa);
        if self.seen % self.stride == 0 || self.seen + 1 == self.samples {
            self.trace.push(s);
        }
        self.seen += 1;
    }

    /// The figures.
    pub fn finish(self) -> Recorded {
        let step = match (self.step, self.step_target_deg) {
            (Some(acc), _) => Some(acc.finish()),
            (None, Some(target)) => Some(StepAccumulator::new(0.0, target, 0).finish()),
            (None, None) => None,
        };
        Recorded {
            samples: self.seen,
            trace: self.trace,
            tracking: self.tracking.finish(),
            step,
            saturated: self.saturated,
            max_pressure_cmd_kpa: self.max_pressure_cmd_kpa,
            max_pressure_kpa: self.max_pressure_kpa,
        }
    }
}

/// A number as `control.csv` writes it (as [`crate::table::write_csv`] writes a
/// numeric column): `decimals` digits, NaN an empty cell, infinities `inf`/`-inf`.
fn write_cell(w: &mut dyn Write, v: f64, decimals: usize) -> std::io::Result<()> {
    if v.is_nan() {
        Ok(())
    } else if v.is_infinite() {
        w.write_all(if v > 0.0 { b"inf" } else { b"-inf" })
    } else {
        write!(w, "{v:.decimals$}")
    }
}

/// Writes one row of `control.csv` (columns of [`CSV_HEADER`]).
pub fn write_row(w: &mut dyn Write, s: &Sample, radius_mm: f64) -> std::io::Result<()> {
    for v in [
        s.time_s,
        s.reference_deg,
        s.angle_deg,
        s.measured_deg,
        s.pressure_cmd_kpa,
        s.pressure_kpa,
    ] {
        write_cell(w, v, 4)?;
        w.write_all(b",")?;
    }
    write_cell(w, radius_mm, 3)?;
    writeln!(w, ",{}", u8::from(s.saturated))
}
