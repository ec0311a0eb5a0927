//! Measures a session: every frame of every video (or RGB-D frame) to a radius, and the
//! session's tables, fits, plots, overlays and HTML report.
//!
//! ```text
//! measure_session(session, out, &settings, &mut progress)
//!   layout     what kind of session (step: pressures.csv; ramp: pressure_log.csv and
//!              one video; RGB-D: color/ + depth/ + intrinsics.json)   [`layout`]
//!   camera     calibration (given, or calib/ calibrated and cached by content) and
//!              mm per px from the scale photo [`camera`] or the markers at rest
//!              [`rest_scale`]; RGB-D: intrinsics and depth
//!   per item   cache hit (same content key, outputs present) or
//!              source (video chapters / RGB-D frames) -> frame::measure_frame ->
//!              FrameRecord; stats::summarize -> VideoRecord; the overlay
//!              [`video_run`], [`rgbd_run`], [`item`]
//!   dynamics   loading / unloading branches of the pressure history (bins per
//!              branch), the loops, step responses of a recording [`dynamics`]
//!   output     per_frame.csv, markers.csv (in the session's axes, [`markers`]),
//!              per_video.csv, fit.json, session.json, plots/, report.html [`output`];
//!              hysteresis.json, step_response.csv [`dynamics_out`]
//! ```
//!
//! A run holds OUT's lock ([`lock`]) from its first write to its last, so two runs never
//! write one OUT at once; a full disk is [`PipelineError::NoSpace`], whatever was being
//! written.
//!
//! The binary only parses flags, calls [`measure_session`] once per session with the
//! output folders [`output_dirs`] chose, prints and turns [`SessionOutcome`]s into an
//! exit code. Progress and warnings reach the caller through [`Progress`].
//!
//! This file holds the orchestration only; each stage is a module of its own, and the
//! modules import each other without a cycle (tests/modules.rs). The records and their
//! statistics live in [`crate::measure`], re-exported here as [`records`] and [`stats`].

pub mod cache;
pub mod camera;
pub mod dynamics;
pub mod dynamics_out;
pub mod error;
pub mod frame;
pub mod item;
pub mod layout;
/// The output lock ([`crate::lock`]), shared by every command that writes a folder.
pub use crate::lock;
pub mod markers;
pub mod output;
pub mod overlay;
pub mod page;
pub mod profile;
pub mod provenance;
/// What a measurement produces ([`crate::measure::records`]), by its old path.
pub use crate::measure::records;
pub mod rest_scale;
pub mod rgbd_run;
pub mod run;
pub mod smooth;
pub mod source;
/// Statistics of the records ([`crate::measure::stats`]), by its old path.
pub use crate::measure::stats;
pub mod video_run;

pub use error::PipelineError;
pub use layout::output_dirs;
pub use run::{ProcessSettings, Progress, Quiet, SessionOutcome, ISSUE_LINES_PER_KIND};

use std::path::Path;

use crate::rgbd::RgbdFrames;
use crate::session::{implausible_pressures, ManifestEntry, SessionConfig, CONFIG};

use cache::Cache;
use item::ItemResult;
use layout::{read_layout, Layout};
use provenance::{Provenance, VideoUsed};
use records::{FrameRecord, VideoRecord, VideoStatus};
use rgbd_run::measure_rgbd;
use run::{issue_line, issue_lines, Notes};
use video_run::VideoRun;

/// Measures the session folder `session` into `out`, holding `out`'s lock
/// ([`lock::OutputLock`]) while it writes. A full disk anywhere on the way is
/// [`PipelineError::NoSpace`].
pub fn measure_session(
    session: &Path,
    out: &Path,
    settings: &ProcessSettings,
    progress: &mut dyn Progress,
) -> Result<SessionOutcome, PipelineError> {
    measure_session_into(session, out, settings, progress).map_err(|e| {
        if !e.is_no_space() && crate::io::is_storage_full(&e) {
            PipelineError::NoSpace {
                dir: out.to_path_buf(),
            }
        } else {
            e
        }
    })
}

fn measure_session_into(
    session: &Path,
    out: &Path,
    settings: &ProcessSettings,
    progress: &mut dyn Progress,
) -> Result<SessionOutcome, PipelineError> {
    let config_file = match &settings.config {
        Some(p) => Some(p.clone()),
        None => Some(session.join(CONFIG)).filter(|p| p.is_file()),
    };
    let mut config = match &config_file {
        Some(p) => SessionConfig::read(p)?,
        None => SessionConfig::default(),
    };
    if let Some(bars) = settings.error_bars {
        config.error_bars = bars;
    }
    let layout = read_layout(session)?;
    if out.exists() && !out.is_dir() {
        return Err(PipelineError::Layout {
            path: out.to_path_buf(),
            why: "is a file, not a folder: give -o a folder for the results".into(),
        });
    }
    // Made, locked and a write tested; held until the session's outputs are written,
    // then its file is removed.
    let lock = crate::lock::lock_output(out)?;
    // Temporaries of a run killed while writing (no other run is writing here: the lock).
    crate::io::remove_stale_temporaries(&["", "cache", "overlays", "plots"].map(|d| out.join(d)));
    let mut notes = Notes {
        lines: vec![],
        progress,
    };
    if !lock.locked {
        notes.push(format!(
            "warning: {}: this file system cannot lock files: do not run two bendscope process into this folder at once",
            out.display()
        ));
    }
    let mut provenance = Provenance {
        bendscope_version: env!("CARGO_PKG_VERSION").to_string(),
        session: session.to_path_buf(),
        config_file,
        settings: config.clone(),
        force: settings.force,
        calibration: None,
        scale: None,
        rgbd_intrinsics: None,
        videos: vec![],
    };
    let cache = Cache::new(out);
    // A recording's pressure log: its branches (bins per branch) and steps.
    let history = match &layout {
        Layout::Rgbd(log, _) | Layout::Ramp(log, _) => {
            Some(dynamics::LogHistory::of_log(log, config.ramp_time_offset_s))
        }
        Layout::Step(_) => None,
    };
    let branched = history.as_ref().filter(|h| h.has_branches());
    let mut items: Vec<ItemResult> = Vec::new();
    let (unit, skipped, binned) = match &layout {
        Layout::Rgbd(log, frames) => {
            // A recording, as a ramp: every frame's time is needed.
            config
                .frame_selection(true)
                .map_err(|why| PipelineError::Layout {
                    path: session.join(crate::session::CONFIG),
                    why,
                })?;
            provenance.rgbd_intrinsics = Some(match frames {
                RgbdFrames::PngFolders => session.join(crate::rgbd::INTRINSICS),
                RgbdFrames::Bag(bag) => bag.clone(),
            });
            items.push(measure_rgbd(session, frames, &config, log, &mut notes)?);
            (log.unit, vec![], Some(config.ramp_bin_kpa))
        }
        Layout::Step(m) => {
            let run = VideoRun::prepare(
                session,
                out,
                &config,
                settings,
                None,
                Some(&m.entries),
                &mut notes,
            )?;
            for w in implausible_pressures(m) {
                notes.push(issue_line(&w));
            }
            provenance.calibration = Some(run.calibration_used.clone());
            provenance.scale = Some(run.scale_used.clone());
            items.extend(run.measure(&m.entries, &cache, settings.force, &mut notes)?);
            (m.unit, m.issues.clone(), None)
        }
        Layout::Ramp(log, video) => {
            let run =
                VideoRun::prepare(session, out, &config, settings, Some(log), None, &mut notes)?;
            provenance.calibration = Some(run.calibration_used.clone());
            provenance.scale = Some(run.scale_used.clone());
            let entry = ManifestEntry {
                line: 0,
                file: video.clone(),
                chapters: vec![],
                pressure: f64::NAN,
                pressure_kpa: f64::NAN,
            };
            items.extend(run.measure(&[entry], &cache, settings.force, &mut notes)?);
            (log.unit, vec![], Some(config.ramp_bin_kpa))
        }
    };
    provenance.videos = items
        .iter()
        .map(|i| VideoUsed {
            file: i.file.clone(),
            from_cache: i.from_cache,
        })
        .collect();
    // Ramps (video or RGB-D) filtered as labs do: the marker tracks, then the circle.
    let smoothed = match (config.smooth_s, &layout) {
        (Some(s), Layout::Ramp(..) | Layout::Rgbd(..)) => {
            for item in &mut items {
                if let Some(w) = smooth::smooth_window_warning(&item.frames, s) {
                    notes.push(format!("warning: {}: {w}", item.file));
                }
                smooth::smooth_recording(&mut item.frames, s);
            }
            true
        }
        _ => false,
    };
    // The axes of markers.csv span the session; every tip pose is taken in them.
    let axes = markers::SessionAxes::from_frames(items.iter().flat_map(|i| &i.frames));
    if let Some(axes) = &axes {
        markers::set_tip_poses(items.iter_mut().flat_map(|i| &mut i.frames), axes);
    }
    let mut videos: Vec<VideoRecord> = Vec::new();
    // Each row's branch (a ramp whose pressure rises and falls).
    let mut row_branches: Vec<Option<dynamics::RowBranch>> = Vec::new();
    let mut frames: Vec<FrameRecord> = Vec::new();
    let mut report_warnings: Vec<String> = Vec::new();
    if let Some(w) = markers::clamp_end_warning(items.iter().flat_map(|i| &i.frames)) {
        notes.push(format!("warning: {w}"));
        report_warnings.push(w);
    }
    let (mut measured, mut failed) = (0, 0);
    for item in items {
        let record = item.record();
        if record.status.is_measured() {
            measured += 1;
        } else {
            failed += 1;
        }
        match &record.status {
            VideoStatus::Ok => {}
            other => notes.push(format!("warning: {}: {other}", item.file)),
        }
        if let Some(w) = frame::chain_continues_warning(&item.frames, config.expected_markers) {
            notes.push(format!("warning: {}: {w}", item.file));
        }
        // With segments listed, the actuator is known not to be one arc.
        let one_circle = config.segments.is_none();
        if let Some(w) = one_circle
            .then(|| profile::one_circle_warning(&item.frames))
            .flatten()
        {
            let line = format!("{}: {w}", item.file);
            notes.push(format!("warning: {line}"));
            report_warnings.push(line);
        }
        match binned {
            Some(bin_kpa) if record.status.is_measured() => {
                let bins: Vec<(Option<dynamics::RowBranch>, f64, stats::FrameStats)> =
                    match branched {
                        Some(h) => h
                            .bin_by_branch(&item.frames, bin_kpa)
                            .into_iter()
                            .map(|(b, p, s)| (Some(b), p, s))
                            .collect(),
                        None => stats::bin_by_pressure(&item.frames, bin_kpa)
                            .into_iter()
                            .map(|(p, s)| (None, p, s))
                            .collect(),
                    };
                for (branch, p, stats) in bins {
                    videos.push(VideoRecord {
                        file: item.file.clone(),
                        pressure_kpa: p,
                        pressure: p / unit.to_kpa(),
                        stats,
                        status: record.status.clone(),
                    });
                    row_branches.push(branch);
                }
            }
            _ => {
                videos.push(record);
                row_branches.push(None);
            }
        }
        frames.extend(item.frames);
    }
    for line in issue_lines(&skipped) {
        notes.push(line);
    }
    for issue in &skipped {
        videos.push(VideoRecord::skipped(&issue.file, issue.message.clone()));
        row_branches.push(None);
        failed += 1;
    }
    let dynamics = dynamics::session_dynamics(history.as_ref(), &videos, row_branches, &frames);
    for n in &dynamics.notes {
        notes.push(format!("warning: {n}"));
        report_warnings.push(n.clone());
    }
    let name = session
        .canonicalize()
        .ok()
        .and_then(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .unwrap_or_else(|| session.display().to_string());
    let rms = match layout {
        Layout::Rgbd(..) => output::RmsUnit::Mm,
        _ => output::RmsUnit::Px,
    };
    let fits = output::write_session(
        out,
        &output::SessionOutputs {
            name: &name,
            frames: &frames,
            axes: axes.as_ref(),
            segments: &config.segment_plan(),
            warnings: &report_warnings,
            smoothed,
            videos: &videos,
            unit,
            rms,
            provenance: &provenance,
            dynamics: &dynamics,
        },
    )?;
    for n in &fits.notes {
        notes.push(format!("warning: {name}: fit.json: {n}"));
    }
    drop(lock);
    Ok(SessionOutcome {
        out: out.to_path_buf(),
        videos,
        measured,
        failed,
        notes: notes.lines,
        provenance,
    })
}
