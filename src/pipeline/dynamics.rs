//! Hysteresis and step response of a session: [`crate::dynamics`] applied to its
//! records. A ramp (or RGB-D) recording's pressure log is split into loading and
//! unloading branches and searched for steps; a step session's pressures, in manifest
//! order, are split into branches. The output stage writes what this finds
//! ([`super::dynamics_out`]).

use serde::Serialize;

use crate::dynamics::branches::{self, Branch, Direction};
use crate::dynamics::hysteresis::{loop_metrics, LoopMetrics};
use crate::dynamics::noise_sd;
use crate::dynamics::response::{step_response, FirstOrderFit, ResponseError, StepResponse};
use crate::dynamics::steps::{
    find_steps, PressureStep, StepSearch, HOLD_BAND_NOISE, STEP_BAND_FACTOR, STEP_MIN_KPA,
};
use crate::fit::{fit_power_law, PowerLawFit};
use crate::session::PressureLog;

use super::records::{FrameRecord, VideoRecord};
use super::stats::{self, FrameStats};

/// The branch of a row of per_video.csv (or of a frame of per_frame.csv).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowBranch {
    /// Branch number, from 1.
    pub branch: usize,
    /// Loading or unloading.
    pub direction: Direction,
    /// Cycle number, from 1.
    pub cycle: usize,
}

impl RowBranch {
    fn of(b: &Branch) -> Self {
        Self {
            branch: b.branch,
            direction: b.direction,
            cycle: b.cycle,
        }
    }
}

/// A recording's pressure log in the frames' clock (per_frame.csv's time_s: the log's
/// time less `ramp_time_offset_s`), with its branches and steps.
#[derive(Debug, Clone)]
pub struct LogHistory {
    /// Log times in the frames' clock, s.
    pub times_s: Vec<f64>,
    /// Logged pressures, kPa.
    pub pressures_kpa: Vec<f64>,
    /// The reversal that makes a turning point, kPa
    /// ([`branches::reversal_threshold_kpa`] of the log's noise).
    pub reversal_kpa: f64,
    /// Loading and unloading branches (one when the pressure only rises).
    pub branches: Vec<Branch>,
    /// Holds and steps of the log.
    pub steps: StepSearch,
}

impl LogHistory {
    /// The log's branches and steps, its times moved into the frames' clock.
    pub fn of_log(log: &PressureLog, time_offset_s: f64) -> Self {
        let times_s: Vec<f64> = log.times_s.iter().map(|t| t - time_offset_s).collect();
        let p = &log.pressures_kpa;
        let reversal_kpa = branches::reversal_threshold_kpa(noise_sd(&times_s, p));
        Self {
            branches: branches::branches(&times_s, p, reversal_kpa),
            steps: find_steps(&times_s, p),
            reversal_kpa,
            pressures_kpa: p.clone(),
            times_s,
        }
    }

    /// Whether the pressure goes up and down (more than one branch).
    pub fn has_branches(&self) -> bool {
        self.branches.len() > 1
    }

    /// The branch of a frame at time `t` (frames' clock).
    pub fn branch_at(&self, t: f64) -> Option<RowBranch> {
        branches::branch_at(&self.branches, t).map(|k| RowBranch::of(&self.branches[k]))
    }

    /// The measured frames binned by pressure within each branch: one row per bin, the
    /// branches in time order, a loading branch's bins by rising pressure and an
    /// unloading branch's by falling pressure (the order they were recorded).
    pub fn bin_by_branch(
        &self,
        frames: &[FrameRecord],
        bin_kpa: f64,
    ) -> Vec<(RowBranch, f64, FrameStats)> {
        let mut out = Vec::new();
        for (k, b) in self.branches.iter().enumerate() {
            let mine: Vec<FrameRecord> = frames
                .iter()
                .filter(|f| branches::branch_at(&self.branches, f.time_s) == Some(k))
                .cloned()
                .collect();
            let mut bins = stats::bin_by_pressure(&mine, bin_kpa);
            if b.direction == Direction::Unloading {
                bins.reverse();
            }
            out.extend(bins.into_iter().map(|(p, s)| (RowBranch::of(b), p, s)));
        }
        out
    }
}

/// Videos a step session's branch needs of its own (besides the turning video it
/// starts from) for the session to be split: a manifest that repeats its pressures in
/// order (20..80, 20..80, ...) or lists them shuffled is not an up-and-down protocol.
pub const MIN_ROWS_PER_BRANCH: usize = 2;

/// The branches of a step session's rows (videos in manifest order, by their
/// pressures: setpoints, so any reversal turns) and each row's branch; rows without a
/// pressure have none. `None` when the pressures never reverse, or when a branch has
/// fewer than [`MIN_ROWS_PER_BRANCH`] videos.
pub fn manifest_branches(videos: &[VideoRecord]) -> Option<(Vec<Branch>, Vec<Option<RowBranch>>)> {
    let with_p: Vec<usize> = (0..videos.len())
        .filter(|&i| videos[i].pressure_kpa.is_finite())
        .collect();
    let pos: Vec<f64> = (0..with_p.len()).map(|k| k as f64).collect();
    let p: Vec<f64> = with_p.iter().map(|&i| videos[i].pressure_kpa).collect();
    let bs = branches::branches(&pos, &p, 0.0);
    if bs.len() < 2 {
        return None;
    }
    let mut rows = vec![None; videos.len()];
    let mut own = vec![0usize; bs.len()];
    for (k, &i) in with_p.iter().enumerate() {
        let b = branches::branch_at(&bs, k as f64);
        if let Some(b) = b {
            own[b] += 1;
        }
        rows[i] = b.map(|b| RowBranch::of(&bs[b]));
    }
    if own.iter().any(|n| *n < MIN_ROWS_PER_BRANCH) {
        return None;
    }
    Some((bs, rows))
}

/// Power-law fits of one branch's rows.
#[derive(Debug, Clone, Serialize)]
pub struct BranchFits {
    /// Branch number.
    pub branch: usize,
    /// Loading or unloading.
    pub direction: Direction,
    /// Cycle number.
    pub cycle: usize,
    /// Radius (mm) vs pressure (kPa).
    pub radius_mm_vs_kpa: Option<PowerLawFit>,
    /// Curvature (1/m) vs pressure (kPa).
    pub curvature_per_m_vs_kpa: Option<PowerLawFit>,
    /// Bending angle (deg) vs pressure (kPa).
    pub bending_angle_deg_vs_kpa: Option<PowerLawFit>,
}

/// A branch as hysteresis.json lists it.
#[derive(Debug, Clone, Serialize)]
pub struct BranchSummary {
    /// Branch number.
    pub branch: usize,
    /// Loading or unloading.
    pub direction: Direction,
    /// Cycle number.
    pub cycle: usize,
    /// Pressure at its start, kPa.
    pub from_kpa: f64,
    /// Pressure at its end, kPa.
    pub to_kpa: f64,
    /// Start in the frames' clock, s (recordings only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub start_s: Option<f64>,
    /// End, s (recordings only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub end_s: Option<f64>,
    /// Measured rows of per_video.csv on it.
    pub rows: usize,
}

/// The loop of one cycle: its loading branch against its unloading branch.
#[derive(Debug, Clone, Serialize)]
pub struct CycleLoop {
    /// Cycle number.
    pub cycle: usize,
    /// Its loading branch's number.
    pub loading_branch: usize,
    /// Its unloading branch's number.
    pub unloading_branch: usize,
    /// Bending angle: area in deg kPa, differences in deg.
    pub bending_angle_deg: Option<LoopMetrics>,
    /// Radius: area in mm kPa, differences in mm.
    pub radius_mm: Option<LoopMetrics>,
    /// Curvature: area in kPa/m, differences in 1/m.
    pub curvature_per_m: Option<LoopMetrics>,
}

/// What hysteresis.json holds.
#[derive(Debug, Clone, Serialize)]
pub struct Hysteresis {
    /// How the branches were found.
    pub method: String,
    /// The reversal that makes a turning point, kPa (0 for a step session's setpoints).
    pub reversal_kpa: f64,
    /// The branches in time order.
    pub branches: Vec<BranchSummary>,
    /// One loop per cycle that has both branches.
    pub loops: Vec<CycleLoop>,
}

/// The session's dynamics: what the output stage writes beside the tables.
#[derive(Debug, Clone, Default)]
pub struct SessionDynamics {
    /// Each per_video.csv row's branch (empty: one branch, no branch columns).
    pub rows: Vec<Option<RowBranch>>,
    /// Each per_frame.csv row's branch (empty: no branch columns).
    pub frames: Vec<Option<RowBranch>>,
    /// The loops (`None`: one branch).
    pub hysteresis: Option<Hysteresis>,
    /// Each branch's fits (fit.json's `branches`).
    pub branch_fits: Vec<BranchFits>,
    /// Step responses (`None`: no step in the log).
    pub steps: Option<StepResults>,
    /// Warnings for stderr and the report.
    pub notes: Vec<String>,
}

/// The (pressure, value) points of the measured rows of one branch.
fn branch_points(
    videos: &[VideoRecord],
    rows: &[Option<RowBranch>],
    branch: usize,
    y: fn(&VideoRecord) -> f64,
) -> Vec<(f64, f64)> {
    videos
        .iter()
        .zip(rows)
        .filter(|(v, r)| v.status.is_measured() && r.is_some_and(|r| r.branch == branch))
        .map(|(v, _)| (v.pressure_kpa, y(v)))
        .filter(|(p, y)| p.is_finite() && y.is_finite())
        .collect()
}

/// Branches a note names before it counts the rest.
const NAMED_BRANCHES: usize = 5;

/// The loops and per-branch fits of rows labelled `rows` (aligned with `videos`);
/// `times` says whether the branches' times are a recording's (else row positions).
pub fn hysteresis(
    videos: &[VideoRecord],
    rows: &[Option<RowBranch>],
    bs: &[Branch],
    reversal_kpa: f64,
    times: bool,
    notes: &mut Vec<String>,
) -> (Hysteresis, Vec<BranchFits>) {
    // A step session's turning video is the top (or bottom) of both branches: the
    // branch after it starts there.
    let points = |b: &Branch, y: fn(&VideoRecord) -> f64| -> Vec<(f64, f64)> {
        let mut pts = branch_points(videos, rows, b.branch, y);
        if !times && b.branch > 1 {
            pts.extend(
                branch_points(videos, rows, b.branch - 1, y)
                    .into_iter()
                    .filter(|(p, _)| *p == b.from_kpa),
            );
        }
        pts
    };
    let angle = |v: &VideoRecord| v.stats.bending_angle_deg;
    let radius = |v: &VideoRecord| v.stats.radius_mm;
    let curvature = |v: &VideoRecord| v.stats.curvature_per_m;
    let mut fits = Vec::new();
    let mut failed: Vec<String> = Vec::new();
    for b in bs {
        let fit = |y: fn(&VideoRecord) -> f64| -> Option<PowerLawFit> {
            let (x, y): (Vec<f64>, Vec<f64>) =
                points(b, y).into_iter().filter(|(p, _)| *p > 0.0).unzip();
            fit_power_law(&x, &y).ok()
        };
        let f = BranchFits {
            branch: b.branch,
            direction: b.direction,
            cycle: b.cycle,
            radius_mm_vs_kpa: fit(radius),
            curvature_per_m_vs_kpa: fit(curvature),
            bending_angle_deg_vs_kpa: fit(angle),
        };
        if f.bending_angle_deg_vs_kpa.is_none() {
            failed.push(format!("{} ({}, cycle {})", b.branch, b.direction, b.cycle));
        }
        fits.push(f);
    }
    if !failed.is_empty() {
        let more = failed.len().saturating_sub(NAMED_BRANCHES);
        failed.truncate(NAMED_BRANCHES);
        let more = if more > 0 {
            format!(" and {more} more")
        } else {
            String::new()
        };
        notes.push(format!(
            "no power-law fit of branch {}{more}: fewer than 3 measured pressures above 0 kPa on it",
            failed.join(", ")
        ));
    }
    let summaries = bs
        .iter()
        .map(|b| BranchSummary {
            branch: b.branch,
            direction: b.direction,
            cycle: b.cycle,
            from_kpa: b.from_kpa,
            to_kpa: b.to_kpa,
            start_s: times.then_some(b.start_s),
            end_s: times.then_some(b.end_s),
            rows: branch_points(videos, rows, b.branch, |v| v.pressure_kpa).len(),
        })
        .collect();
    let mut loops = Vec::new();
    for l in bs.iter().filter(|b| b.direction == Direction::Loading) {
        let Some(u) = bs
            .iter()
            .find(|u| u.cycle == l.cycle && u.direction == Direction::Unloading)
        else {
            continue;
        };
        let m = |y: fn(&VideoRecord) -> f64| loop_metrics(&points(l, y), &points(u, y));
        loops.push(CycleLoop {
            cycle: l.cycle,
            loading_branch: l.branch,
            unloading_branch: u.branch,
            bending_angle_deg: m(angle),
            radius_mm: m(radius),
            curvature_per_m: m(curvature),
        });
    }
    let method = if times {
        "turning points of pressure_log.csv where the pressure reverses by more than reversal_kpa; rows are pressure bins within each branch; loops by trapezoids on the binned means over the pressure range both branches cover"
    } else {
        "turning points of the manifest's pressures in manifest order; rows are videos; loops by trapezoids on the videos' means over the pressure range both branches cover"
    };
    (
        Hysteresis {
            method: method.into(),
            reversal_kpa,
            branches: summaries,
            loops,
        },
        fits,
    )
}

/// A per_frame.csv column and how to read it from a frame.
pub type FrameQuantity = (&'static str, fn(&FrameRecord) -> f64);

/// The quantities a step response is measured for, with their per_frame.csv names.
pub const STEP_QUANTITIES: [FrameQuantity; 3] = [
    ("bending_angle_deg", |f| f.bending_angle_deg),
    ("radius_mm", |f| f.radius_mm),
    ("curvature_per_m", |f| f.curvature_per_m),
];

/// The logged pressure's name in step_response.csv.
pub const PRESSURE_QUANTITY: &str = "pressure_kpa";

/// One row of step_response.csv: a quantity's response to one step.
#[derive(Debug, Clone)]
pub struct StepRow {
    /// The step.
    pub step: PressureStep,
    /// `pressure_kpa` (the log) or a per_frame.csv column.
    pub quantity: &'static str,
    /// Its response.
    pub response: StepResponse,
    /// Its 50% crossing after the logged pressure's, s.
    pub delay_s: f64,
    /// The logged pressure's 10-90% rise time, s.
    pub pressure_rise_time_s: f64,
}

/// The step responses of a recording, and what the plots draw.
#[derive(Debug, Clone)]
pub struct StepResults {
    /// Rows of step_response.csv, by step then quantity.
    pub rows: Vec<StepRow>,
    /// The measured (time, bending angle) of the frames.
    pub angle_series: Vec<(f64, f64)>,
    /// Each step's window (from, to) in the frames' clock, s.
    pub windows: Vec<(f64, f64)>,
    /// (step, quantity, time since onset, normalised value 0 -> 1) of every sample in
    /// a step's window.
    pub normalised: Vec<(&'static str, Vec<(f64, f64)>)>,
}

impl StepRow {
    /// The fitted response, if any.
    pub fn fit(&self) -> Option<&FirstOrderFit> {
        self.response.fit.as_ref()
    }
}

/// The logged pressure's own response to `step` (from the log's samples in its window;
/// with too few log samples, the crossings of the two holds' levels alone).
fn pressure_response(h: &LogHistory, step: &PressureStep) -> StepResponse {
    let (from, to) = (step.before.first, step.after.last);
    let t = &h.times_s[from..=to];
    let p = &h.pressures_kpa[from..=to];
    step_response(t, p, step.onset_s, step.after.end_s).unwrap_or_else(|_| {
        let (a, b) = (step.from_kpa(), step.to_kpa());
        let cross = |share: f64| {
            let level = a + share * (b - a);
            let s = (b - a).signum();
            t.windows(2)
                .zip(p.windows(2))
                .find(|(_, w)| s * (w[1] - level) >= 0.0 && s * (w[0] - level) < 0.0)
                .map(|(tw, w)| tw[0] + (tw[1] - tw[0]) * (level - w[0]) / (w[1] - w[0]))
                .unwrap_or(f64::NAN)
        };
        let (t10, t50, t90) = (cross(0.1), cross(0.5), cross(0.9));
        StepResponse {
            initial: a,
            final_value: b,
            t10_s: t10,
            t50_s: t50,
            t90_s: t90,
            rise_time_s: t90 - t10,
            overshoot_pct: f64::NAN,
            settling_time_s: f64::NAN,
            fit: None,
            samples_before: 0,
            samples_after: 0,
        }
    })
}

/// The step responses of a recording's frames to the steps of its log; a step the
/// frames do not cover well enough (too few measured frames before or after it) is
/// named in one note and keeps its pressure row. `None` without steps.
pub fn step_results(
    h: &LogHistory,
    frames: &[FrameRecord],
    file: &str,
    notes: &mut Vec<String>,
) -> Option<StepResults> {
    if h.steps.steps.is_empty() {
        return None;
    }
    let ok: Vec<&FrameRecord> = frames
        .iter()
        .filter(|f| f.status.is_ok() && f.time_s.is_finite())
        .collect();
    let mut rows = Vec::new();
    let mut windows = Vec::new();
    let mut normalised: Vec<(&'static str, Vec<(f64, f64)>)> = vec![(PRESSURE_QUANTITY, vec![])];
    normalised.extend(STEP_QUANTITIES.iter().map(|(q, _)| (*q, vec![])));
    let mut add_normalised = |q: &str, r: &StepResponse, t: &[f64], y: &[f64], onset: f64| {
        let dy = r.final_value - r.initial;
        if let Some((_, pts)) = normalised.iter_mut().find(|(n, _)| *n == q) {
            pts.extend(
                t.iter()
                    .zip(y)
                    .map(|(t, y)| (t - onset, (y - r.initial) / dy))
                    .filter(|(a, b)| a.is_finite() && b.is_finite()),
            );
        }
    };
    // Steps the frames do not cover: said in one line.
    let mut uncovered: Vec<String> = Vec::new();
    for step in &h.steps.steps {
        let (start, end) = (step.before.start_s, step.after.end_s);
        windows.push((start, end));
        let pressure = pressure_response(h, step);
        let (lt, lp) = (
            &h.times_s[step.before.first..=step.after.last],
            &h.pressures_kpa[step.before.first..=step.after.last],
        );
        add_normalised(PRESSURE_QUANTITY, &pressure, lt, lp, step.onset_s);
        let (p_t50, p_rise) = (pressure.t50_s, pressure.rise_time_s);
        let row = |quantity, response: StepResponse| StepRow {
            step: *step,
            quantity,
            delay_s: response.t50_s - p_t50,
            pressure_rise_time_s: p_rise,
            response,
        };
        rows.push(row(PRESSURE_QUANTITY, pressure));
        let window: Vec<&FrameRecord> = ok
            .iter()
            .copied()
            .filter(|f| f.time_s >= start && f.time_s <= end)
            .collect();
        let t: Vec<f64> = window.iter().map(|f| f.time_s).collect();
        let describe = format!(
            "step {} ({:.1} -> {:.1} kPa at {:.2} s)",
            step.step,
            step.from_kpa(),
            step.to_kpa(),
            step.onset_s
        );
        for (quantity, get) in STEP_QUANTITIES {
            let y: Vec<f64> = window.iter().map(|f| get(f)).collect();
            match step_response(&t, &y, step.onset_s, end) {
                Ok(r) => {
                    add_normalised(quantity, &r, &t, &y, step.onset_s);
                    rows.push(row(quantity, r));
                }
                Err(e @ ResponseError::TooFewSamples { .. }) => {
                    uncovered.push(format!("{describe}: measured frames: {e}"));
                    break;
                }
                Err(e) => notes.push(format!("{file}: {describe}: {quantity}: {e}")),
            }
        }
    }
    match uncovered.len() {
        0 => {}
        1 => notes.push(format!(
            "{file}: {}: no step response for it (the other outputs are kept)",
            uncovered[0]
        )),
        n => notes.push(format!(
            "{file}: {n} steps without enough measured frames around them, no step response for them (the other outputs are kept); the first: {}",
            uncovered[0]
        )),
    }
    Some(StepResults {
        rows,
        angle_series: ok.iter().map(|f| (f.time_s, f.bending_angle_deg)).collect(),
        windows,
        normalised,
    })
}

/// The session's branches, loops and step responses: a recording's from its pressure
/// log (`history`), a step session's from its rows' pressures in manifest order.
pub fn session_dynamics(
    history: Option<&LogHistory>,
    videos: &[VideoRecord],
    row_branches: Vec<Option<RowBranch>>,
    frames: &[FrameRecord],
) -> SessionDynamics {
    let mut d = SessionDynamics::default();
    match history {
        Some(h) => {
            if h.has_branches() {
                d.frames = frames.iter().map(|f| h.branch_at(f.time_s)).collect();
                let (hy, fits) = hysteresis(
                    videos,
                    &row_branches,
                    &h.branches,
                    h.reversal_kpa,
                    true,
                    &mut d.notes,
                );
                d.rows = row_branches;
                d.hysteresis = Some(hy);
                d.branch_fits = fits;
            }
            let file = frames.first().map_or("", |f| f.file.as_str());
            d.steps = step_results(h, frames, file, &mut d.notes);
            if let Some(c) = h.steps.small_change {
                d.notes.push(format!(
                    "{}: the pressure changes by {:.2} kPa at {:.2} s, less than the {:.2} kPa a step needs here ({STEP_MIN_KPA} kPa, and {STEP_BAND_FACTOR} times the holds' band of {HOLD_BAND_NOISE} noise sds; noise sd {:.3} kPa): no step response measured",
                    crate::session::PRESSURE_LOG,
                    c.change_kpa,
                    c.at_s,
                    h.steps.threshold_kpa,
                    h.steps.noise_sd_kpa
                ));
            }
        }
        None => {
            if let Some((bs, rows)) = manifest_branches(videos) {
                let of_file: std::collections::HashMap<&str, RowBranch> = videos
                    .iter()
                    .zip(&rows)
                    .filter_map(|(v, r)| r.map(|r| (v.file.as_str(), r)))
                    .collect();
                d.frames = frames
                    .iter()
                    .map(|f| of_file.get(f.file.as_str()).copied())
                    .collect();
                let (hy, fits) = hysteresis(videos, &rows, &bs, 0.0, false, &mut d.notes);
                d.rows = rows;
                d.hysteresis = Some(hy);
                d.branch_fits = fits;
            }
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::records::FrameStatus;
    use crate::session::PressureUnit;

    fn frame(t: f64, p: f64, angle: f64) -> FrameRecord {
        let mut f =
            FrameRecord::rejected("v.mp4", (t * 30.0).round() as u64, t, p, FrameStatus::Ok);
        f.bending_angle_deg = angle;
        f.radius_mm = 87.5 / angle.to_radians();
        f.curvature_per_m = 1000.0 / f.radius_mm;
        f.fit_rms = 0.0;
        f
    }

    /// An up-and-down log 20 -> 50 -> 20 kPa: two branches; frames binned per branch,
    /// the unloading bins in falling order; the loop of angle = p (loading) and
    /// p + 5 sin (unloading) has the trapezoids' area of the binned means.
    #[test]
    fn up_and_down_log_bins_per_branch_and_measures_its_loop() {
        let log = PressureLog {
            unit: PressureUnit::Kpa,
            times_s: (0..=40).map(|i| i as f64 * 0.05).collect(),
            pressures_kpa: (0..=40)
                .map(|i| 50.0 - 1.5 * (i as f64 - 20.0).abs())
                .collect(),
        };
        let h = LogHistory::of_log(&log, 0.0);
        assert_eq!(h.branches.len(), 2);
        assert!(h.steps.steps.is_empty());
        let angle = |t: f64, p: f64| {
            if t <= 1.0 {
                p
            } else {
                p + 5.0 * (std::f64::consts::PI * (p - 20.0) / 30.0).sin()
            }
        };
        let frames: Vec<FrameRecord> = (0..=60)
            .map(|i| {
                let t = i as f64 / 30.0;
                let p = log_pressure(&log, t);
                frame(t, p, angle(t, p))
            })
            .collect();
        let bins = h.bin_by_branch(&frames, 5.0);
        let used: usize = bins.iter().map(|b| b.2.frames_used).sum();
        assert_eq!(used, 61);
        let unloading: Vec<f64> = bins
            .iter()
            .filter(|b| b.0.direction == Direction::Unloading)
            .map(|b| b.1)
            .collect();
        assert!(unloading.windows(2).all(|w| w[1] < w[0]), "{unloading:?}");
        let videos: Vec<VideoRecord> = bins
            .iter()
            .map(|(_, p, s)| VideoRecord {
                file: "v.mp4".into(),
                pressure_kpa: *p,
                pressure: *p,
                stats: s.clone(),
                status: crate::measure::records::VideoStatus::Ok,
            })
            .collect();
        let rows: Vec<Option<RowBranch>> = bins.iter().map(|b| Some(b.0)).collect();
        let mut notes = vec![];
        let (hy, fits) = hysteresis(
            &videos,
            &rows,
            &h.branches,
            h.reversal_kpa,
            true,
            &mut notes,
        );
        assert!(notes.is_empty(), "{notes:?}");
        assert_eq!(fits.len(), 2);
        let l = hy.loops[0].bending_angle_deg.unwrap();
        // 60 h / pi for h = 5, less the trapezoids' and the bins' smoothing (a few %).
        let truth = 300.0 / std::f64::consts::PI;
        assert!((l.area / truth - 1.0).abs() < 0.08, "{l:?} vs {truth}");
        assert!(l.signed_area > 0.0);
    }

    fn log_pressure(log: &PressureLog, t: f64) -> f64 {
        log.pressure_at(t).unwrap()
    }

    /// Pressures 0, 20, 40, 60, 40, 20 in manifest order: loading then unloading; the
    /// top video ends the loading branch; a skipped row has no branch.
    #[test]
    fn step_session_rows_split_at_the_top() {
        let mk = |p: f64| VideoRecord {
            file: format!("{p}.mp4"),
            pressure_kpa: p,
            pressure: p,
            stats: FrameStats::empty(0),
            status: crate::measure::records::VideoStatus::Ok,
        };
        let mut videos: Vec<VideoRecord> = [0.0, 20.0, 40.0, 60.0, 40.0, 20.0].map(mk).to_vec();
        videos.push(VideoRecord::skipped("x.mp4", "no such video".into()));
        let (bs, rows) = manifest_branches(&videos).unwrap();
        assert_eq!(bs.len(), 2);
        let labels: Vec<Option<(usize, Direction)>> = rows
            .iter()
            .map(|r| r.map(|r| (r.branch, r.direction)))
            .collect();
        use Direction::*;
        assert_eq!(
            labels,
            [
                Some((1, Loading)),
                Some((1, Loading)),
                Some((1, Loading)),
                Some((1, Loading)),
                Some((2, Unloading)),
                Some((2, Unloading)),
                None
            ]
        );
        assert!(manifest_branches(&videos[..4]).is_none(), "rising only");
        // Pressures repeated in order: the drops have one video each, no protocol.
        let repeated: Vec<VideoRecord> = [20.0, 35.0, 50.0, 20.0, 35.0, 50.0, 20.0, 35.0]
            .map(mk)
            .to_vec();
        assert!(manifest_branches(&repeated).is_none());
    }
}
