//! A session's outputs from its records: `per_frame.csv`, `markers.csv`, `per_video.csv`,
//! `fit.json` (power laws), `session.json` (how they were made), `plots/` and
//! `report.html`. Every
//! file is written atomically; the outputs depend only on the records (session.json
//! also on which came from the cache), so a rerun writes identical files. When one
//! cannot be written (a full disk), it and the ones after it are removed, so no output
//! of an earlier run stays beside this run's as if it were current.

use std::path::Path;

use serde::Serialize;

use crate::fit::{fit_power_law, PowerLawFit};
use crate::report::{html, plot_xy, write_json, ErrorBars, Series};
use crate::session::PressureUnit;
use crate::table::{write_csv, Column};

use crate::segments::{Segment, SegmentStats};

use super::dynamics::{BranchFits, SessionDynamics};
use super::dynamics_out::{self, DYNAMICS_PLOT_STEMS, HYSTERESIS_JSON, STEP_RESPONSE_CSV};
use super::error::PipelineError;
use super::markers::{write_markers_csv, SessionAxes};
use super::page;
use super::profile;
use super::provenance::{Provenance, SESSION_JSON};
use super::records::{FrameRecord, VideoRecord};

/// The marker positions of every measured frame ([`super::markers`]).
pub const MARKERS_CSV: &str = "markers.csv";

/// The per-segment table of a segmented actuator ([`crate::segments`]).
pub const PER_SEGMENT_CSV: &str = "per_segment.csv";

/// Stems (in plots/) of the per-segment plots of a segmented actuator.
pub const SEGMENT_PLOT_STEMS: [&str; 2] = [
    "segment_radius_vs_pressure",
    "segment_curvature_vs_pressure",
];

/// Stems (in plots/) of the session's plots; each has a .png, an .svg and a .pdf.
pub const PLOT_STEMS: [&str; 4] = [
    "radius_vs_pressure",
    "curvature_vs_pressure",
    "angle_vs_pressure",
    "radius_per_frame",
];

/// The session's outputs in the order they are written (relative to OUT; the plots
/// stage holds every plot file).
fn output_stages() -> Vec<Vec<String>> {
    let plots = PLOT_STEMS
        .iter()
        .chain(&SEGMENT_PLOT_STEMS)
        .chain(&DYNAMICS_PLOT_STEMS)
        .flat_map(|s| crate::report::PLOT_EXTENSIONS.map(|e| format!("plots/{s}.{e}")))
        .collect();
    vec![
        vec!["per_frame.csv".into()],
        vec![MARKERS_CSV.into()],
        vec!["per_video.csv".into()],
        vec![PER_SEGMENT_CSV.into()],
        vec!["fit.json".into()],
        vec![HYSTERESIS_JSON.into()],
        vec![STEP_RESPONSE_CSV.into()],
        vec![SESSION_JSON.into()],
        plots,
        vec!["report.html".into()],
    ]
}

/// Power-law fits y = a x^b + c of a session.
#[derive(Debug, Clone, Serialize)]
pub struct SessionFits {
    /// Model.
    pub model: &'static str,
    /// Radius (mm) vs pressure (kPa).
    pub radius_mm_vs_kpa: Option<PowerLawFit>,
    /// Curvature (1/m) vs pressure (kPa).
    pub curvature_per_m_vs_kpa: Option<PowerLawFit>,
    /// Bending angle (deg) vs pressure (kPa).
    pub bending_angle_deg_vs_kpa: Option<PowerLawFit>,
    /// The manifest's pressure unit.
    pub unit: String,
    /// Radius (mm) vs pressure in the manifest's unit.
    pub radius_mm_vs_unit: Option<PowerLawFit>,
    /// Curvature (1/m) vs pressure in the manifest's unit.
    pub curvature_per_m_vs_unit: Option<PowerLawFit>,
    /// Why a fit is missing, and the measured rows a fit had to leave out (each note
    /// is also a warning on stderr).
    pub notes: Vec<String>,
    /// Segmented actuators: each segment's fits (absent without segments).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub segments: Vec<SegmentFits>,
    /// A session whose pressure rises and falls: each loading and unloading branch's
    /// fits (absent with one branch).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub branches: Vec<BranchFits>,
}

/// Power-law fits of one segment of a segmented actuator (`null` when there are too few
/// distinct pressures, as for the whole actuator).
#[derive(Debug, Clone, Serialize)]
pub struct SegmentFits {
    /// Segment number, from 1 at the clamped end.
    pub segment: usize,
    /// Its markers ("1 2 3").
    pub markers: String,
    /// Radius (mm) vs pressure (kPa).
    pub radius_mm_vs_kpa: Option<PowerLawFit>,
    /// Curvature (1/m) vs pressure (kPa).
    pub curvature_per_m_vs_kpa: Option<PowerLawFit>,
    /// Bending angle over the segment (deg) vs pressure (kPa).
    pub bending_angle_deg_vs_kpa: Option<PowerLawFit>,
}

/// Each segment's power laws over the measured rows (pressure > 0, finite values).
pub fn fit_segment_records(rows: &[VideoRecord], segments: &[Segment]) -> Vec<SegmentFits> {
    segments
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let fit = |g: fn(&SegmentStats) -> f64| -> Option<PowerLawFit> {
                let (xs, ys): (Vec<f64>, Vec<f64>) = rows
                    .iter()
                    .filter(|r| r.status.is_measured())
                    .filter_map(|r| r.stats.segments.get(k).map(|st| (r.pressure_kpa, g(st))))
                    .filter(|(x, y)| x.is_finite() && *x > 0.0 && y.is_finite())
                    .unzip();
                fit_power_law(&xs, &ys).ok()
            };
            SegmentFits {
                segment: k + 1,
                markers: s.label(),
                radius_mm_vs_kpa: fit(|st| st.radius_mm),
                curvature_per_m_vs_kpa: fit(|st| st.curvature_per_m),
                bending_angle_deg_vs_kpa: fit(|st| st.bending_angle_deg),
            }
        })
        .collect()
}

/// Writes `per_segment.csv`: one row per segment of each row of per_video.csv
/// (`file,pressure_kpa,segment,markers,radius_mm,radius_mm_std,curvature_per_m,
/// bending_angle_deg,fit_rms_px,frames_used,status`; RGB-D: `fit_rms_mm`).
pub fn write_per_segment_csv(
    path: &Path,
    rows: &[VideoRecord],
    segments: &[Segment],
    rms: RmsUnit,
) -> Result<(), PipelineError> {
    let cells: Vec<(&VideoRecord, usize, Option<&SegmentStats>)> = rows
        .iter()
        .flat_map(|r| (0..segments.len()).map(move |k| (r, k, r.stats.segments.get(k))))
        .collect();
    let f = |g: fn(&SegmentStats) -> f64| -> Vec<f64> {
        cells
            .iter()
            .map(|(_, _, st)| st.map_or(f64::NAN, g))
            .collect()
    };
    write_csv(
        path,
        &[
            Column::text("file", cells.iter().map(|c| c.0.file.clone())),
            Column::num("pressure_kpa", 4, cells.iter().map(|c| c.0.pressure_kpa)),
            Column::int("segment", cells.iter().map(|c| c.1 as u64 + 1)),
            Column::text("markers", cells.iter().map(|c| segments[c.1].label())),
            Column::num("radius_mm", 4, f(|s| s.radius_mm)),
            Column::num("radius_mm_std", 4, f(|s| s.radius_mm_std)),
            Column::num("curvature_per_m", 4, f(|s| s.curvature_per_m)),
            Column::num("bending_angle_deg", 4, f(|s| s.bending_angle_deg)),
            Column::num(rms.column(), 4, f(|s| s.fit_rms)),
            Column::int(
                "frames_used",
                cells
                    .iter()
                    .map(|c| c.2.map_or(0, |s| s.frames_used) as u64),
            ),
            Column::text("status", cells.iter().map(|c| c.0.status.to_string())),
        ],
    )?;
    Ok(())
}

/// Fits the measured rows (pressure > 0, finite values). Rows at or below 0 kPa stay in
/// the tables but cannot enter y = a x^b + c (x^b at x = 0): a note names them. Fits
/// that fail for the same reason (too few distinct pressures) share one note.
pub fn fit_records(rows: &[VideoRecord], unit: PressureUnit) -> SessionFits {
    let measured = || rows.iter().filter(|r| r.status.is_measured());
    let mut notes = Vec::new();
    let at_zero: Vec<String> = measured()
        .filter(|r| r.pressure_kpa.is_finite() && r.pressure_kpa <= 0.0)
        .map(|r| format!("{} ({} kPa)", r.file, r.pressure_kpa))
        .collect();
    if !at_zero.is_empty() {
        notes.push(format!(
            "{} measured row(s) at or below 0 kPa are kept in the tables and left out of the fits (y = a x^b + c needs x > 0): {}",
            at_zero.len(),
            at_zero.join(", ")
        ));
    }
    // (fit names, reason) of the fits that failed, grouped by reason.
    let mut failed: Vec<(Vec<String>, String)> = Vec::new();
    let mut fit = |name: &str,
                   x: fn(&VideoRecord) -> f64,
                   y: fn(&VideoRecord) -> f64|
     -> Option<PowerLawFit> {
        let (xs, ys): (Vec<f64>, Vec<f64>) = measured()
            .map(|r| (x(r), y(r)))
            .filter(|(a, b)| a.is_finite() && *a > 0.0 && b.is_finite())
            .unzip();
        match fit_power_law(&xs, &ys) {
            Ok(f) => Some(f),
            Err(e) => {
                let why = e.to_string();
                match failed.iter_mut().find(|(_, w)| *w == why) {
                    Some((names, _)) => names.push(name.to_string()),
                    None => failed.push((vec![name.to_string()], why)),
                }
                None
            }
        }
    };
    let mut fits = SessionFits {
        model: "y = a * x^b + c",
        radius_mm_vs_kpa: fit("radius vs kPa", |r| r.pressure_kpa, |r| r.stats.radius_mm),
        curvature_per_m_vs_kpa: fit(
            "curvature vs kPa",
            |r| r.pressure_kpa,
            |r| r.stats.curvature_per_m,
        ),
        bending_angle_deg_vs_kpa: fit(
            "angle vs kPa",
            |r| r.pressure_kpa,
            |r| r.stats.bending_angle_deg,
        ),
        unit: unit.name().to_string(),
        radius_mm_vs_unit: fit("radius vs unit", |r| r.pressure, |r| r.stats.radius_mm),
        curvature_per_m_vs_unit: fit(
            "curvature vs unit",
            |r| r.pressure,
            |r| r.stats.curvature_per_m,
        ),
        notes,
        segments: vec![],
        branches: vec![],
    };
    for (names, why) in failed {
        fits.notes
            .push(format!("no fit of {}: {why}", names.join(", ")));
    }
    fits
}

/// The unit of the fit RMS column: px for video sessions, mm for RGB-D.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RmsUnit {
    /// Undistorted pixels.
    Px,
    /// Millimetres (circle fitted in 3D).
    Mm,
}

impl RmsUnit {
    fn column(self) -> &'static str {
        match self {
            RmsUnit::Px => "fit_rms_px",
            RmsUnit::Mm => "fit_rms_mm",
        }
    }
}

/// Writes `per_frame.csv`; after the fit RMS, the curvature profile: one column
/// `curvature_m<k>_per_m` per inner marker k = 2 .. n-1 of the longest marker chain
/// (the circle through markers k-1, k, k+1, [`profile::curvature_profile_per_m`]).
/// With `smoothed`, `radius_mm_smooth`, `curvature_per_m_smooth` and
/// `bending_angle_deg_smooth` follow their raw columns ([`super::smooth`]). `branch`
/// columns (a session whose pressure rises and falls) follow `pressure_kpa`.
pub fn write_per_frame_csv(
    path: &Path,
    rows: &[FrameRecord],
    rms: RmsUnit,
    smoothed: bool,
    branch: Vec<Column>,
) -> Result<(), PipelineError> {
    let f = |g: fn(&FrameRecord) -> f64| rows.iter().map(g).collect::<Vec<f64>>();
    let profiles: Vec<Vec<f64>> = rows
        .iter()
        .map(|r| profile::curvature_profile_per_m(&r.markers))
        .collect();
    let inner = profiles.iter().map(Vec::len).max().unwrap_or(0);
    let mut cols = vec![
        Column::text("file", rows.iter().map(|r| r.file.clone())),
        Column::int("frame", rows.iter().map(|r| r.frame)),
        Column::num("time_s", 4, f(|r| r.time_s)),
        Column::num("pressure_kpa", 3, f(|r| r.pressure_kpa)),
    ];
    cols.extend(branch);
    cols.extend([
        Column::int("n_markers", rows.iter().map(|r| r.n_markers as u64)),
        Column::int("n_ignored", rows.iter().map(|r| r.n_ignored as u64)),
        Column::num("radius_px", 3, f(|r| r.radius_px)),
        Column::num("radius_mm", 4, f(|r| r.radius_mm)),
    ]);
    if smoothed {
        cols.push(Column::num(
            "radius_mm_smooth",
            4,
            f(|r| r.radius_mm_smooth),
        ));
    }
    cols.push(Column::num("curvature_per_m", 4, f(|r| r.curvature_per_m)));
    if smoothed {
        cols.push(Column::num(
            "curvature_per_m_smooth",
            4,
            f(|r| r.curvature_per_m_smooth),
        ));
    }
    cols.push(Column::num(
        "bending_angle_deg",
        3,
        f(|r| r.bending_angle_deg),
    ));
    if smoothed {
        cols.push(Column::num(
            "bending_angle_deg_smooth",
            3,
            f(|r| r.bending_angle_deg_smooth),
        ));
    }
    cols.push(Column::num(rms.column(), 4, f(|r| r.fit_rms)));
    for k in 0..inner {
        cols.push(Column::num(
            format!("curvature_m{}_per_m", k + 2),
            4,
            profiles
                .iter()
                .map(|p| p.get(k).copied().unwrap_or(f64::NAN))
                .collect::<Vec<f64>>(),
        ));
    }
    cols.push(Column::text(
        "status",
        rows.iter().map(|r| r.status.to_string()),
    ));
    write_csv(path, &cols)?;
    Ok(())
}

/// Writes `per_video.csv` (a `pressure_<unit>` column follows `pressure_kpa` when the
/// manifest used another unit; then the `branch` columns, when given).
pub fn write_per_video_csv(
    path: &Path,
    rows: &[VideoRecord],
    unit: PressureUnit,
    rms: RmsUnit,
    branch: Vec<Column>,
) -> Result<(), PipelineError> {
    let f = |g: fn(&VideoRecord) -> f64| rows.iter().map(g).collect::<Vec<f64>>();
    let mut cols = vec![
        Column::text("file", rows.iter().map(|r| r.file.clone())),
        Column::num("pressure_kpa", 4, f(|r| r.pressure_kpa)),
    ];
    if unit != PressureUnit::Kpa {
        cols.push(Column::num(
            format!("pressure_{}", unit.name()),
            4,
            f(|r| r.pressure),
        ));
    }
    cols.extend(branch);
    cols.extend([
        Column::num("radius_mm", 4, f(|r| r.stats.radius_mm)),
        Column::num("radius_mm_median", 4, f(|r| r.stats.radius_mm_median)),
        Column::num("radius_mm_std", 4, f(|r| r.stats.radius_mm_std)),
        Column::num("curvature_per_m", 4, f(|r| r.stats.curvature_per_m)),
        Column::num("curvature_per_m_std", 4, f(|r| r.stats.curvature_per_m_std)),
        Column::num("bending_angle_deg", 4, f(|r| r.stats.bending_angle_deg)),
        Column::num(
            "bending_angle_deg_std",
            4,
            f(|r| r.stats.bending_angle_deg_std),
        ),
        Column::num(rms.column(), 4, f(|r| r.stats.fit_rms)),
        Column::num("tip_x_mm", 4, f(|r| r.stats.tip_x_mm)),
        Column::num("tip_x_mm_std", 4, f(|r| r.stats.tip_x_mm_std)),
        Column::num("tip_y_mm", 4, f(|r| r.stats.tip_y_mm)),
        Column::num("tip_y_mm_std", 4, f(|r| r.stats.tip_y_mm_std)),
        Column::num("tip_angle_deg", 4, f(|r| r.stats.tip_angle_deg)),
        Column::num("tip_angle_deg_std", 4, f(|r| r.stats.tip_angle_deg_std)),
        Column::int(
            "frames_used",
            rows.iter().map(|r| r.stats.frames_used as u64),
        ),
        Column::int(
            "frames_rejected",
            rows.iter().map(|r| r.stats.frames_rejected as u64),
        ),
        Column::text("status", rows.iter().map(|r| r.status.to_string())),
    ]);
    write_csv(path, &cols)?;
    Ok(())
}

/// What [`write_session`] writes from.
pub struct SessionOutputs<'a> {
    /// Session name (the report's title).
    pub name: &'a str,
    /// Rows of per_frame.csv (their markers: the rows of markers.csv).
    pub frames: &'a [FrameRecord],
    /// The session's axes of markers.csv (`None` when no frame was measured).
    pub axes: Option<&'a SessionAxes>,
    /// Segments of a segmented actuator (empty: one arc, no per_segment.csv).
    pub segments: &'a [Segment],
    /// Warnings about the measurement the report shows (also on stderr).
    pub warnings: &'a [String],
    /// Whether the frames carry smoothed values (`smooth_s` on a ramp): per_frame.csv
    /// gets the `*_smooth` columns.
    pub smoothed: bool,
    /// Rows of per_video.csv.
    pub videos: &'a [VideoRecord],
    /// The manifest's pressure unit.
    pub unit: PressureUnit,
    /// Unit of the fit RMS column.
    pub rms: RmsUnit,
    /// How the results were made (session.json, and the report's setup lines).
    pub provenance: &'a Provenance,
    /// Branches, loops and step responses ([`super::dynamics`]).
    pub dynamics: &'a SessionDynamics,
}

/// Writes every output of a session into `out`; returns its fits (their notes are for
/// the user). When one output fails, it and every output after it are removed (an
/// earlier run's file must not stay beside this run's tables) and the error is returned.
pub fn write_session(out: &Path, s: &SessionOutputs) -> Result<SessionFits, PipelineError> {
    let mut done = 0usize;
    let result = write_stages(out, s, &mut done);
    if result.is_err() {
        for rel in output_stages().iter().skip(done).flatten() {
            let _ = std::fs::remove_file(out.join(rel));
        }
    }
    result
}

/// Writes the outputs in [`output_stages`] order, counting the stages done.
fn write_stages(
    out: &Path,
    s: &SessionOutputs,
    done: &mut usize,
) -> Result<SessionFits, PipelineError> {
    write_per_frame_csv(
        &out.join("per_frame.csv"),
        s.frames,
        s.rms,
        s.smoothed,
        dynamics_out::branch_columns(&s.dynamics.frames),
    )?;
    *done += 1;
    write_markers_csv(&out.join(MARKERS_CSV), s.frames, s.axes)?;
    *done += 1;
    write_per_video_csv(
        &out.join("per_video.csv"),
        s.videos,
        s.unit,
        s.rms,
        dynamics_out::branch_columns(&s.dynamics.rows),
    )?;
    *done += 1;
    if s.segments.is_empty() {
        // An earlier run's table must not stand for this run's.
        remove_stale(&out.join(PER_SEGMENT_CSV))?;
    } else {
        write_per_segment_csv(&out.join(PER_SEGMENT_CSV), s.videos, s.segments, s.rms)?;
    }
    *done += 1;
    let mut fits = fit_records(s.videos, s.unit);
    fits.segments = fit_segment_records(s.videos, s.segments);
    fits.branches = s.dynamics.branch_fits.clone();
    write_json(&out.join("fit.json"), &fits)?;
    *done += 1;
    dynamics_out::write_hysteresis_json(out, s.dynamics)?;
    *done += 1;
    dynamics_out::write_step_response_csv(out, s.dynamics)?;
    *done += 1;
    write_json(&out.join(SESSION_JSON), s.provenance)?;
    *done += 1;
    let bars = s.provenance.settings.error_bars;
    let mut plots = write_plots(out, s.videos, &fits, s.frames, bars)?;
    plots.extend(write_segment_plots(out, s.videos, s.segments, bars)?);
    let dynamic_plots = dynamics_out::write_dynamics_plots(out, s.videos, s.dynamics, bars)?;
    *done += 1;
    html::write_session_report(
        &out.join("report.html"),
        &html::SessionReport {
            name: s.name,
            out,
            videos: &page::video_rows(s.videos),
            fits: &report_fits(&fits),
            plots: &plots,
            setup: Some(&page::setup(s.provenance)),
            segments: s.segments,
            warnings: s.warnings,
            sections: &dynamics_out::report_sections(s.dynamics, &dynamic_plots),
        },
    )?;
    *done += 1;
    Ok(fits)
}

/// The fits the report page lists.
fn report_fits(f: &SessionFits) -> html::Fits {
    html::Fits {
        radius_mm_vs_kpa: f.radius_mm_vs_kpa,
        curvature_per_m_vs_kpa: f.curvature_per_m_vs_kpa,
        bending_angle_deg_vs_kpa: f.bending_angle_deg_vs_kpa,
        notes: f.notes.clone(),
        segments: f
            .segments
            .iter()
            .map(|s| html::SegmentFit {
                segment: s.segment,
                markers: s.markers.clone(),
                radius_mm_vs_kpa: s.radius_mm_vs_kpa,
            })
            .collect(),
    }
}

/// Removes `path` when it exists.
fn remove_stale(path: &Path) -> Result<(), PipelineError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(PipelineError::Write {
            path: path.to_path_buf(),
            source: e,
        }),
        _ => Ok(()),
    }
}

/// Draws radius and curvature vs pressure with one series per segment (nothing without
/// segments; a segmented run's plots of an earlier run are removed); returns their stems.
fn write_segment_plots(
    out: &Path,
    videos: &[VideoRecord],
    segments: &[Segment],
    bars: ErrorBars,
) -> Result<Vec<String>, PipelineError> {
    if segments.is_empty() {
        for stem in SEGMENT_PLOT_STEMS {
            for ext in crate::report::PLOT_EXTENSIONS {
                remove_stale(&out.join("plots").join(format!("{stem}.{ext}")))?;
            }
        }
        return Ok(vec![]);
    }
    let labels = |bar: &str| -> Vec<String> {
        segments
            .iter()
            .enumerate()
            .map(|(k, s)| format!("segment {} (markers {}){bar}", k + 1, s.label()))
            .collect()
    };
    let (with_bars, without) = (labels(&format!(" ± {}", bars.label())), labels(""));
    // `e`: each point's standard deviation (NaN: no bar).
    // `bars_shown`: the labels that name the error bars.
    let series = |bars_shown: bool,
                  g: fn(&SegmentStats) -> f64,
                  e: fn(&SegmentStats) -> f64|
     -> Vec<Series> {
        let labels = if bars_shown { &with_bars } else { &without };
        labels
            .iter()
            .enumerate()
            .map(|(k, label)| {
                let (points, errors): (Vec<(f64, f64)>, Vec<f64>) = videos
                    .iter()
                    .filter(|v| v.status.is_measured())
                    .filter_map(|v| {
                        v.stats.segments.get(k).map(|s| {
                            (
                                (v.pressure_kpa, g(s)),
                                bars.half_height(e(s), s.frames_used),
                            )
                        })
                    })
                    .filter(|((x, y), _)| x.is_finite() && y.is_finite())
                    .unzip();
                Series {
                    label,
                    points,
                    line: true,
                    errors: Some(errors),
                }
            })
            .collect()
    };
    let mut written = Vec::new();
    for (stem, title, y_label, s) in [
        (
            SEGMENT_PLOT_STEMS[0],
            "Radius of curvature per segment vs pressure",
            "radius (mm)",
            series(true, |s| s.radius_mm, |s| s.radius_mm_std),
        ),
        (
            SEGMENT_PLOT_STEMS[1],
            "Curvature per segment vs pressure",
            "curvature (1/m)",
            series(false, |s| s.curvature_per_m, |_| f64::NAN),
        ),
    ] {
        if plot_xy(
            &out.join("plots").join(stem),
            title,
            "pressure (kPa)",
            y_label,
            &s,
        )? {
            written.push(format!("plots/{stem}"));
        }
    }
    Ok(written)
}

/// Draws the session's plots; returns their stems relative to OUT (each has a .png,
/// an .svg and a .pdf).
fn write_plots(
    out: &Path,
    videos: &[VideoRecord],
    fits: &SessionFits,
    frames: &[FrameRecord],
    bars: ErrorBars,
) -> Result<Vec<String>, PipelineError> {
    let ok: Vec<&VideoRecord> = videos.iter().filter(|v| v.status.is_measured()).collect();
    let pmax = ok.iter().map(|v| v.pressure_kpa).fold(0.0, f64::max);
    let pmin = ok
        .iter()
        .map(|v| v.pressure_kpa)
        .filter(|p| *p > 0.0)
        .fold(f64::INFINITY, f64::min);
    let curve = |f: &Option<PowerLawFit>| -> Vec<(f64, f64)> {
        match f {
            Some(f) if pmin.is_finite() => (0..=100)
                .map(|i| {
                    let p = pmin + (pmax - pmin) * i as f64 / 100.0;
                    (p, f.eval(p))
                })
                .collect(),
            _ => vec![],
        }
    };
    let points = |g: fn(&VideoRecord) -> f64| -> Vec<(f64, f64)> {
        ok.iter().map(|v| (v.pressure_kpa, g(v))).collect()
    };
    // Each video's bar: its frames' spread, or the confidence interval of their mean.
    let errors = |std: fn(&VideoRecord) -> f64| -> Option<Vec<f64>> {
        Some(
            ok.iter()
                .map(|v| bars.half_height(std(v), v.stats.frames_used))
                .collect(),
        )
    };
    let measured = format!("measured (mean ± {} per video)", bars.label());
    let mut per_file: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for f in frames {
        match per_file.last_mut() {
            Some((name, pts)) if *name == f.file => pts.push((f.time_s, f.radius_mm)),
            _ => per_file.push((f.file.clone(), vec![(f.time_s, f.radius_mm)])),
        }
    }
    let plots = [
        (
            PLOT_STEMS[0],
            "Radius of curvature vs pressure",
            "radius (mm)",
            vec![
                Series {
                    label: &measured,
                    points: points(|v| v.stats.radius_mm),
                    line: false,
                    errors: errors(|v| v.stats.radius_mm_std),
                },
                Series {
                    label: "power-law fit",
                    points: curve(&fits.radius_mm_vs_kpa),
                    line: true,
                    errors: None,
                },
            ],
        ),
        (
            PLOT_STEMS[1],
            "Curvature vs pressure",
            "curvature (1/m)",
            vec![
                Series {
                    label: &measured,
                    points: points(|v| v.stats.curvature_per_m),
                    line: false,
                    errors: errors(|v| v.stats.curvature_per_m_std),
                },
                Series {
                    label: "power-law fit",
                    points: curve(&fits.curvature_per_m_vs_kpa),
                    line: true,
                    errors: None,
                },
            ],
        ),
        (
            PLOT_STEMS[2],
            "Bending angle vs pressure",
            "bending angle (deg)",
            vec![
                Series {
                    label: &measured,
                    points: points(|v| v.stats.bending_angle_deg),
                    line: false,
                    errors: errors(|v| v.stats.bending_angle_deg_std),
                },
                Series {
                    label: "power-law fit",
                    points: curve(&fits.bending_angle_deg_vs_kpa),
                    line: true,
                    errors: None,
                },
            ],
        ),
    ];
    let mut written = Vec::new();
    for (stem, title, y_label, series) in plots {
        if plot_xy(
            &out.join("plots").join(stem),
            title,
            "pressure (kPa)",
            y_label,
            &series,
        )? {
            written.push(format!("plots/{stem}"));
        }
    }
    let series: Vec<Series> = per_file
        .iter()
        .map(|(name, pts)| Series {
            label: name,
            points: pts.clone(),
            line: true,
            errors: None,
        })
        .collect();
    if plot_xy(
        &out.join("plots").join(PLOT_STEMS[3]),
        "Radius per frame (stability)",
        "time (s)",
        "radius (mm)",
        &series,
    )? {
        written.push(format!("plots/{}", PLOT_STEMS[3]));
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::super::records::VideoStatus;
    use super::super::stats::FrameStats;
    use super::*;
    use plotters::prelude::{Color, Palette, Palette99};

    fn row(file: &str, p: f64, r: f64) -> VideoRecord {
        VideoRecord {
            file: file.into(),
            pressure_kpa: p,
            pressure: p / 100.0,
            stats: FrameStats {
                radius_mm: r,
                radius_mm_median: r,
                radius_mm_std: 0.1,
                curvature_per_m: 1000.0 / r,
                curvature_per_m_std: 0.3,
                bending_angle_deg: 10.0,
                bending_angle_deg_std: 0.4,
                fit_rms: 0.05,
                tip_x_mm: 90.0,
                tip_x_mm_std: 0.2,
                tip_y_mm: 30.0,
                tip_y_mm_std: 0.1,
                tip_angle_deg: 40.0,
                tip_angle_deg_std: 0.5,
                segments: vec![],
                frames_used: 10,
                frames_rejected: 0,
            },
            status: VideoStatus::Ok,
        }
    }

    #[test]
    fn per_video_csv_opens_as_a_table() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("per_video.csv");
        let mut rows = vec![row("a.mp4", 20.0, 120.0), row("b, c.mp4", 40.0, 80.0)];
        rows[1].stats.radius_mm_median = f64::NAN;
        rows.push(VideoRecord::skipped("x.mp4", "listed twice".into()));
        write_per_video_csv(&p, &rows, PressureUnit::Bar, RmsUnit::Px, vec![]).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        let mut lines = text.lines();
        assert_eq!(
            lines.next().unwrap(),
            "file,pressure_kpa,pressure_bar,radius_mm,radius_mm_median,radius_mm_std,curvature_per_m,curvature_per_m_std,bending_angle_deg,bending_angle_deg_std,fit_rms_px,tip_x_mm,tip_x_mm_std,tip_y_mm,tip_y_mm_std,tip_angle_deg,tip_angle_deg_std,frames_used,frames_rejected,status"
        );
        assert_eq!(
            lines.next().unwrap(),
            "a.mp4,20.0000,0.2000,120.0000,120.0000,0.1000,8.3333,0.3000,10.0000,0.4000,0.0500,90.0000,0.2000,30.0000,0.1000,40.0000,0.5000,10,0,ok"
        );
        assert!(lines
            .next()
            .unwrap()
            .starts_with("\"b, c.mp4\",40.0000,0.4000,80.0000,,"));
        assert_eq!(
            lines.next().unwrap(),
            "x.mp4,,,,,,,,,,,,,,,,,0,0,listed twice"
        );
    }

    #[test]
    fn fits_recover_a_power_law_and_skip_unmeasured_rows() {
        let mut rows: Vec<VideoRecord> = (1..=6)
            .map(|i| {
                let p = 15.0 * i as f64;
                row("v", p, 800.0 * p.powf(-0.8) + 10.0)
            })
            .collect();
        rows.push(VideoRecord::skipped("bad.mp4", "not a number".into()));
        let f = fit_records(&rows, PressureUnit::Bar);
        let r = f.radius_mm_vs_kpa.unwrap();
        assert!(
            (r.b + 0.8).abs() < 1e-4 && (r.c - 10.0).abs() < 1e-2,
            "{r:?}"
        );
        assert_eq!(r.n, 6);
    }

    #[test]
    fn one_pressure_gives_no_fit_and_zero_kpa_rows_are_named() {
        let rows: Vec<VideoRecord> = (0..5)
            .map(|i| row(&format!("v{i}.mp4"), 40.0, 60.0 + 0.1 * i as f64))
            .collect();
        let f = fit_records(&rows, PressureUnit::Bar);
        assert!(f.radius_mm_vs_kpa.is_none() && f.curvature_per_m_vs_kpa.is_none());
        assert!(f.bending_angle_deg_vs_kpa.is_none() && f.radius_mm_vs_unit.is_none());
        // One note per reason: the kPa fits' and the bar fits' (other values).
        assert_eq!(f.notes.len(), 2, "{:?}", f.notes);
        assert!(
            f.notes[0].starts_with("no fit of radius vs kPa, curvature vs kPa, angle vs kPa: ")
                && f.notes[0].contains("got 1 (40)"),
            "{:?}",
            f.notes
        );
        assert!(
            f.notes[1].starts_with("no fit of radius vs unit, curvature vs unit: ")
                && f.notes[1].contains("got 1 (0.4)"),
            "{:?}",
            f.notes
        );
        let json = serde_json::to_string(&f).unwrap();
        assert!(json.contains("\"radius_mm_vs_kpa\":null"), "{json}");
        // A 0 kPa row is kept out of the fits, by name; the others are fitted.
        let mut rows: Vec<VideoRecord> = (1..=5)
            .map(|i| {
                let p = 15.0 * i as f64;
                row("v", p, 800.0 * p.powf(-0.8) + 10.0)
            })
            .collect();
        rows.insert(0, row("rest.mp4", 0.0, 500.0));
        let f = fit_records(&rows, PressureUnit::Kpa);
        assert_eq!(f.radius_mm_vs_kpa.unwrap().n, 5);
        assert_eq!(f.notes.len(), 1, "{:?}", f.notes);
        assert!(
            f.notes[0].contains("1 measured row(s) at or below 0 kPa")
                && f.notes[0].contains("left out of the fits")
                && f.notes[0].contains("rest.mp4 (0 kPa)"),
            "{:?}",
            f.notes
        );
    }

    /// The `points` of the SVG polylines of colour `colour`, each as pixel pairs.
    fn polylines(svg: &str, colour: &str) -> Vec<Vec<(f64, f64)>> {
        let attr = |t: &str, n: &str| -> Option<String> {
            let start = t.find(&format!(" {n}=\""))? + n.len() + 3;
            Some(t[start..start + t[start..].find('"')?].to_string())
        };
        svg.split('<')
            .filter(|t| t.starts_with("polyline") && attr(t, "stroke").as_deref() == Some(colour))
            .map(|t| {
                attr(t, "points")
                    .unwrap()
                    .split_whitespace()
                    .map(|xy| {
                        let (x, y) = xy.split_once(',').unwrap();
                        (x.parse().unwrap(), y.parse().unwrap())
                    })
                    .collect()
            })
            .collect()
    }

    /// The angle plot draws fit.json's power law through its points and each video's
    /// angle std as a bar: pixel positions from the plot's own mapping, 1.5 px.
    #[test]
    fn angle_plot_draws_its_fit_and_std_bars() {
        let d = tempfile::tempdir().unwrap();
        let angle = |p: f64| 3.0 * p.powf(0.7) + 2.0;
        let rows: Vec<VideoRecord> = (1..=6)
            .map(|i| {
                let p = 15.0 * i as f64;
                let mut r = row("v", p, 800.0 * p.powf(-0.8) + 10.0);
                r.stats.bending_angle_deg = angle(p);
                r
            })
            .collect();
        let fits = fit_records(&rows, PressureUnit::Kpa);
        assert!(fits.bending_angle_deg_vs_kpa.is_some(), "{:?}", fits.notes);
        write_plots(d.path(), &rows, &fits, &[], ErrorBars::Std).unwrap();
        let svg = std::fs::read_to_string(d.path().join("plots/angle_vs_pressure.svg")).unwrap();
        let hex = |i: usize| {
            let c = Palette99::pick(i).to_rgba().rgb();
            format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)
        };
        let bars: Vec<Vec<(f64, f64)>> = polylines(&svg, &hex(0))
            .into_iter()
            .filter(|l| l.len() == 2 && l[0].0 == l[1].0)
            .collect();
        assert_eq!(bars.len(), 6, "one bar per video");
        // Pixels per degree and the pixel row of 0 deg from the first and last bars' centres.
        let mid = |b: &Vec<(f64, f64)>| (b[0].1 + b[1].1) / 2.0;
        let (a0, a5) = (angle(15.0), angle(90.0));
        let scale = (mid(&bars[0]) - mid(&bars[5])) / (a5 - a0);
        let px = |deg: f64| mid(&bars[0]) - (deg - a0) * scale;
        for (b, r) in bars.iter().zip(&rows) {
            let len = (b[0].1 - b[1].1).abs();
            assert!((len - 2.0 * 0.4 * scale).abs() <= 1.5, "bar {len} px");
            assert!((mid(b) - px(r.stats.bending_angle_deg)).abs() <= 1.5);
        }
        let curves: Vec<Vec<(f64, f64)>> = polylines(&svg, &hex(1))
            .into_iter()
            .filter(|l| l.len() > 50)
            .collect();
        assert_eq!(curves.len(), 1, "the fit line");
        let f = fits.bending_angle_deg_vs_kpa.unwrap();
        for (end, p) in [(curves[0][0], 15.0), (*curves[0].last().unwrap(), 90.0)] {
            assert!((end.0 - bars[if p == 15.0 { 0 } else { 5 }][0].0).abs() <= 1.5);
            assert!(
                (end.1 - px(f.eval(p))).abs() <= 1.5,
                "{end:?} vs {}",
                px(f.eval(p))
            );
        }
    }
}
