//! Measures a session: every frame of every video (or RGB-D frame) to a radius, and the
//! session's tables, fits, plots, overlays and HTML report.
//!
//! ```text
//! measure_session(session, out, &settings, &mut progress)
//!   layout     what kind of session (step: pressures.csv; ramp: pressure_log.csv and
//!              one video; RGB-D: color/ + depth/ + intrinsics.json)
//!   camera     calibration (given, or calib/ calibrated and cached by content) and
//!              mm per px from the scale photo; RGB-D: intrinsics and depth
//!   per item   cache hit (same content key, outputs present) or
//!              source (video chapters / RGB-D frames) -> frame::measure_frame ->
//!              FrameRecord; stats::summarize -> VideoRecord; the overlay
//!   output     per_frame.csv, markers.csv (in the session's axes, [`markers`]),
//!              per_video.csv, fit.json, session.json, plots/, report.html
//! ```
//!
//! A run holds OUT's lock ([`lock`]) from its first write to its last, so two runs never
//! write one OUT at once; a full disk is [`PipelineError::NoSpace`], whatever was being
//! written.
//!
//! The binary only parses flags, calls [`measure_session`] once per session with the
//! output folders [`output_dirs`] chose, prints and turns [`SessionOutcome`]s into an
//! exit code. Progress and warnings reach the caller through [`Progress`].

pub mod cache;
pub mod frame;
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
pub mod smooth;
pub mod source;
/// Statistics of the records ([`crate::measure::stats`]), by its old path.
pub use crate::measure::stats;

use std::path::{Path, PathBuf};

use crate::calib::corners::{detect_views, DetectSettings as CornerSettings, ViewSource};
use crate::calib::file::{calibration_to_yaml, read_calibration, write_calibration};
use crate::calib::{
    calibrate, Board, CalibError, Calibration, CalibrationSettings, UndistortSettings, Undistorter,
};
use crate::detect::ChainStart;
use crate::io::{content_key, hash_parts, write_atomic};
use crate::rgbd::bag::BagRecording;
use crate::rgbd::{list_frames, rgbd_frames, RgbdError, RgbdFrames};
use crate::scale::{read_scale_file, scale_from_board_photo, ScaleBoard, ScaleError};
use crate::session::{
    find_scale_image, implausible_pressures, read_manifest, read_pressure_log, session_videos,
    Manifest, ManifestEntry, PressureLog, SessionConfig, SessionError, CONFIG, IMAGE_EXTENSIONS,
    MANIFEST, PRESSURE_LOG,
};

use crate::lock::LockError;
use cache::{Cache, CacheEntry, ItemKey};
use frame::{measure_frame, Geometry, Tracker};
use provenance::{
    CalibrationSource, CalibrationUsed, Provenance, ScaleSource, ScaleUsed, VideoUsed,
};
use records::{FrameRecord, FrameStatus, VideoRecord, VideoStatus};
use source::{BagSource, FrameSource, Next, RgbdSource};

/// Errors that stop a whole session (the other sessions of a run go on).
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// Layout, manifest, pressure log or settings.
    #[error(transparent)]
    Session(#[from] SessionError),
    /// RGB-D layout or intrinsics.
    #[error(transparent)]
    Rgbd(#[from] RgbdError),
    /// Calibration.
    #[error(transparent)]
    Calib(#[from] CalibError),
    /// Scale photo.
    #[error("scale from {path}: {source}")]
    Scale {
        /// The photo.
        path: PathBuf,
        /// Cause.
        source: ScaleError,
    },
    /// What the session folder holds cannot be measured as it is.
    #[error("{path}: {why}")]
    Layout {
        /// File or folder.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
    /// The output folder is in use by another run, or cannot be locked.
    #[error(transparent)]
    Lock(#[from] LockError),
    /// The output folder's file system is full.
    #[error("no space left on {}: free space and rerun", dir.display())]
    NoSpace {
        /// The output folder.
        dir: PathBuf,
    },
    /// An output could not be written.
    #[error("{}: cannot write ({}): check the output folder's space and permissions", path.display(), crate::io::without_path(path, &source.to_string()))]
    Write {
        /// The file.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// Plots, JSON or the HTML report.
    #[error(transparent)]
    Report(#[from] crate::report::ReportError),
    /// A table.
    #[error(transparent)]
    Table(#[from] crate::table::TableError),
}

impl PipelineError {
    /// The one-line message for a session that failed with this error: the session's
    /// path first, once (most errors already start with it or a file inside it).
    pub fn for_session(&self, session: &Path) -> String {
        let msg = self.to_string();
        let path = session.display().to_string();
        if msg.starts_with(&path) {
            msg
        } else {
            format!("{path}: {msg}")
        }
    }

    /// True for [`PipelineError::NoSpace`]: the run stopped because the disk is full (the
    /// binary gives it its own exit code).
    pub fn is_no_space(&self) -> bool {
        matches!(self, PipelineError::NoSpace { .. })
    }
}

fn write_err(path: &Path) -> impl Fn(std::io::Error) -> PipelineError + '_ {
    move |source| PipelineError::Write {
        path: path.to_path_buf(),
        source,
    }
}

/// How `process` runs, beside what the session's bendscope.toml says.
#[derive(Debug, Clone, Default)]
pub struct ProcessSettings {
    /// Calibration file to use (else the session's `calibration` key, else calib/).
    pub calibration: Option<PathBuf>,
    /// Settings file (else SESSION/bendscope.toml when present).
    pub config: Option<PathBuf>,
    /// Redo videos whose cached results are current.
    pub force: bool,
}

/// Where progress and warnings go (the CLI draws bars and prints lines on stderr).
pub trait Progress {
    /// A stage with `total` steps begins.
    fn start(&mut self, _what: &str, _total: u64) {}
    /// The item being worked on.
    fn item(&mut self, _name: &str) {}
    /// `n` steps done.
    fn advance(&mut self, _n: u64) {}
    /// Within the current item (a video): `done` frames measured of about `expected`
    /// (0 when unknown). Called for every frame: a long video shows where it is.
    fn frames(&mut self, _done: u64, _expected: u64) {}
    /// The stage is done.
    fn finish(&mut self) {}
    /// A line for the user (a warning or a note), already naming its file.
    fn note(&mut self, _line: &str) {}
}

/// A [`Progress`] that shows nothing.
#[derive(Debug, Default)]
pub struct Quiet;

impl Progress for Quiet {}

/// What a session gave.
#[derive(Debug, Clone)]
pub struct SessionOutcome {
    /// Where its results are.
    pub out: PathBuf,
    /// Rows of per_video.csv (videos, or pressure bins of a ramp).
    pub videos: Vec<VideoRecord>,
    /// Items measured (videos, or the one ramp/RGB-D recording).
    pub measured: usize,
    /// Items that failed or were skipped.
    pub failed: usize,
    /// Warnings and notes, as given to [`Progress::note`].
    pub notes: Vec<String>,
    /// How the results were made (what `session.json` holds).
    pub provenance: Provenance,
}

/// Output folders for `sessions`: `SESSION/bendscope-out` without `output`; `output`
/// itself for one session; `output/<session name>` for several, with `-2`, `-3`, ...
/// appended when two sessions have the same folder name (a note says so). Decided before
/// any work, so no session's results replace another's.
pub fn output_dirs(sessions: &[PathBuf], output: Option<&Path>) -> Vec<(PathBuf, Option<String>)> {
    let several = sessions.len() > 1;
    let mut taken: Vec<String> = Vec::new();
    sessions
        .iter()
        .map(|s| match (output, several) {
            (None, _) => (s.join("bendscope-out"), None),
            (Some(o), false) => (o.to_path_buf(), None),
            (Some(o), true) => {
                let name = s
                    .canonicalize()
                    .ok()
                    .and_then(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
                    .unwrap_or_else(|| "session".into());
                let mut unique = name.clone();
                let mut k = 1;
                while taken.contains(&unique) {
                    k += 1;
                    unique = format!("{name}-{k}");
                }
                taken.push(unique.clone());
                let note = (unique != name).then(|| {
                    format!(
                        "{}: another session is also named {name}: its results go to {}",
                        s.display(),
                        o.join(&unique).display()
                    )
                });
                (o.join(unique), note)
            }
        })
        .collect()
}

/// The kind of a session folder.
enum Layout {
    /// pressures.csv, one video per pressure.
    Step(Manifest),
    /// pressure_log.csv and one video.
    Ramp(PressureLog, String),
    /// color/ + depth/ + intrinsics.json (or a .bag recording) + pressure_log.csv.
    Rgbd(PressureLog, RgbdFrames),
}

fn read_layout(session: &Path) -> Result<Layout, PipelineError> {
    if !session.is_dir() {
        return Err(PipelineError::Layout {
            path: session.to_path_buf(),
            why: if session.exists() {
                "is a file, not a folder: give the session folder (the one holding pressures.csv and the videos)".into()
            } else {
                "no such session folder: check the path".into()
            },
        });
    }
    let manifest = session.join(MANIFEST);
    let log = session.join(PRESSURE_LOG);
    if let Some(frames) = rgbd_frames(session)? {
        if let RgbdFrames::Bag(bag) = &frames {
            let videos = session_videos(session);
            if manifest.exists() || !videos.is_empty() {
                return Err(PipelineError::Layout {
                    path: session.to_path_buf(),
                    why: format!(
                        "both a RealSense recording ({}) and {}: keep the one that describes this session",
                        bag.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
                        if manifest.exists() { format!("{MANIFEST} (step protocol)") } else { format!("videos ({})", videos.join(", ")) }
                    ),
                });
            }
        }
        if !log.is_file() {
            return Err(PipelineError::Layout {
                path: log,
                why: "an RGB-D session needs a pressure log: time_s,pressure_<unit> from the regulator".into(),
            });
        }
        return Ok(Layout::Rgbd(read_pressure_log(&log)?, frames));
    }
    match (manifest.exists(), log.is_file()) {
        (true, true) => Err(PipelineError::Layout {
            path: session.to_path_buf(),
            why: format!(
                "both {MANIFEST} (step protocol) and {PRESSURE_LOG} (ramp protocol): keep the one that describes this session"
            ),
        }),
        (false, true) => {
            let log = read_pressure_log(&log)?;
            let videos = session_videos(session);
            if videos.len() != 1 {
                return Err(PipelineError::Layout {
                    path: session.to_path_buf(),
                    why: format!(
                        "a ramp session ({PRESSURE_LOG}) holds exactly one video, found {}: keep one video per session folder",
                        videos.len()
                    ),
                });
            }
            Ok(Layout::Ramp(log, videos[0].clone()))
        }
        _ => {
            let m = read_manifest(session)?;
            // No row at all (issues without a line are videos the manifest lacks).
            if m.entries.is_empty() && m.issues.iter().all(|i| i.line.is_none()) {
                return Err(PipelineError::Layout {
                    path: session.join(MANIFEST),
                    why: "lists no videos: add one row per video".into(),
                });
            }
            Ok(Layout::Step(m))
        }
    }
}

/// Collects notes for the outcome and passes them to the caller's progress.
struct Notes<'a> {
    lines: Vec<String>,
    progress: &'a mut dyn Progress,
}

impl Notes<'_> {
    fn push(&mut self, line: String) {
        self.progress.note(&line);
        self.lines.push(line);
    }
}

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

/// Lines printed for one kind of session issue (one message) before the rest are
/// counted in one line.
pub const ISSUE_LINES_PER_KIND: usize = 5;

/// The stderr lines of a session's `issues`: each kind (one message) for its first
/// [`ISSUE_LINES_PER_KIND`] rows, then the rest counted in one line, so that a manifest
/// of thousands of rows naming missing videos gives a few lines, not one per row (every
/// row is still in per_video.csv).
fn issue_lines(issues: &[crate::session::SessionIssue]) -> Vec<String> {
    let mut lines = Vec::new();
    let mut kinds: Vec<(&str, usize)> = Vec::new();
    let mut kind_of: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
    for issue in issues {
        let k = *kind_of.entry(issue.message.as_str()).or_insert_with(|| {
            kinds.push((issue.message.as_str(), 0));
            kinds.len() - 1
        });
        kinds[k].1 += 1;
        if kinds[k].1 <= ISSUE_LINES_PER_KIND {
            lines.push(issue_line(issue));
        }
    }
    for (message, n) in kinds.iter().filter(|(_, n)| *n > ISSUE_LINES_PER_KIND) {
        lines.push(format!(
            "warning: {} more rows or files: {message} (all are listed in per_video.csv)",
            n - ISSUE_LINES_PER_KIND
        ));
    }
    lines
}

/// A session issue as a stderr line: `warning: FILE (line N): message`.
fn issue_line(issue: &crate::session::SessionIssue) -> String {
    let line = issue
        .line
        .map(|l| format!(" (line {l})"))
        .unwrap_or_default();
    format!("warning: {}{line}: {}", issue.file, issue.message)
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
    let config = match &config_file {
        Some(p) => SessionConfig::read(p)?,
        None => SessionConfig::default(),
    };
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
    let mut items: Vec<ItemResult> = Vec::new();
    let (unit, skipped, binned) = match &layout {
        Layout::Rgbd(log, frames) => {
            provenance.rgbd_intrinsics = Some(match frames {
                RgbdFrames::PngFolders => session.join(crate::rgbd::INTRINSICS),
                RgbdFrames::Bag(bag) => bag.clone(),
            });
            items.push(measure_rgbd(session, frames, &config, log, &mut notes)?);
            (log.unit, vec![], Some(config.ramp_bin_kpa))
        }
        Layout::Step(m) => {
            let run = VideoRun::prepare(session, out, &config, settings, None, &mut notes)?;
            for w in implausible_pressures(m) {
                notes.push(issue_line(&w));
            }
            provenance.calibration = Some(run.calibration_used.clone());
            provenance.scale = Some(run.scale_used.clone());
            items.extend(run.measure(&m.entries, &cache, settings.force, &mut notes)?);
            (m.unit, m.issues.clone(), None)
        }
        Layout::Ramp(log, video) => {
            let run = VideoRun::prepare(session, out, &config, settings, Some(log), &mut notes)?;
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
                for (p, stats) in stats::bin_by_pressure(&item.frames, bin_kpa) {
                    videos.push(VideoRecord {
                        file: item.file.clone(),
                        pressure_kpa: p,
                        pressure: p / unit.to_kpa(),
                        stats,
                        status: record.status.clone(),
                    });
                }
            }
            _ => videos.push(record),
        }
        frames.extend(item.frames);
    }
    for line in issue_lines(&skipped) {
        notes.push(line);
    }
    for issue in &skipped {
        videos.push(VideoRecord::skipped(&issue.file, issue.message.clone()));
        failed += 1;
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

/// The videos of a step or ramp session with what measuring them needs.
struct VideoRun<'a> {
    session: &'a Path,
    out: &'a Path,
    config: &'a SessionConfig,
    calib: Calibration,
    scale: SessionScale,
    /// Where the calibration came from (for session.json).
    calibration_used: CalibrationUsed,
    /// Where the scale came from (for session.json).
    scale_used: ScaleUsed,
    log: Option<&'a PressureLog>,
    /// Hash of everything session-wide a video's result depends on.
    fingerprint: u128,
}

impl<'a> VideoRun<'a> {
    /// Calibration, scale and the session's fingerprint.
    fn prepare(
        session: &'a Path,
        out: &'a Path,
        config: &'a SessionConfig,
        settings: &ProcessSettings,
        log: Option<&'a PressureLog>,
        notes: &mut Notes,
    ) -> Result<Self, PipelineError> {
        let (calib, calibration_used) = session_calibration(session, out, config, settings, notes)?;
        let (scale, scale_used) = session_scale(session, config, &calib, notes)?;
        let log_bytes = match log {
            Some(_) => std::fs::read(session.join(PRESSURE_LOG)).unwrap_or_default(),
            None => vec![],
        };
        let fingerprint = hash_parts([
            toml::to_string(config).unwrap_or_default().as_bytes(),
            calibration_to_yaml(&calib).unwrap_or_default().as_bytes(),
            &scale.mm_per_px.to_le_bytes(),
            &scale.width.to_le_bytes(),
            &scale
                .plane_from_px
                .iter()
                .flatten()
                .flat_map(|v| v.to_le_bytes())
                .collect::<Vec<u8>>(),
            &log_bytes,
        ]);
        Ok(Self {
            session,
            out,
            config,
            calib,
            scale,
            calibration_used,
            scale_used,
            log,
            fingerprint,
        })
    }

    /// Measures `entries` in order (each video's marker chain starts where the previous
    /// one's clamped end was), from the cache when current.
    fn measure(
        &self,
        entries: &[ManifestEntry],
        cache: &Cache,
        force: bool,
        notes: &mut Notes,
    ) -> Result<Vec<ItemResult>, PipelineError> {
        let mut items = Vec::with_capacity(entries.len());
        notes.progress.start("videos", entries.len() as u64);
        let mut chain: Option<(f64, f64)> = None;
        for entry in entries {
            notes.progress.item(&entry.file);
            let files: Vec<u128> = std::iter::once(&entry.file)
                .chain(&entry.chapters)
                .map(|f| content_key(&self.session.join(f)).unwrap_or(0))
                .collect();
            let start = chain.map(|(x, y)| nalgebra::Point2::new(x, y));
            // The chain start is an input too: a video measured after another one starts
            // where that one's clamped end was.
            let key = ItemKey::new(
                hash_parts([
                    self.fingerprint.to_le_bytes().as_slice(),
                    format!("{start:?}").as_bytes(),
                ]),
                &files,
                entry.pressure_kpa,
            );
            let cached = (!force).then(|| cache.get(&entry.file, &key)).flatten();
            let result = match cached {
                Some(c) => ItemResult::from_cache(entry, c),
                None => {
                    let r = self.measure_video(entry, start, &mut *notes.progress);
                    if r.storage_full {
                        notes.progress.finish();
                        return Err(PipelineError::NoSpace {
                            dir: self.out.to_path_buf(),
                        });
                    }
                    cache
                        .put(&entry.file, &r.to_cache(key))
                        .map_err(write_err(&self.out.join("cache")))?;
                    r
                }
            };
            chain = result.clamp_marker_px.or(chain);
            items.push(result);
            notes.progress.advance(1);
        }
        notes.progress.finish();
        Ok(items)
    }
}

/// Removes `path` when it exists.
fn remove_if_present(path: &Path) -> Result<(), PipelineError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(write_err(path)(e)),
        _ => Ok(()),
    }
}

/// [`CalibrationUsed::of_file`], its read error naming the file.
fn calibration_used(
    source: CalibrationSource,
    path: &Path,
) -> Result<CalibrationUsed, PipelineError> {
    CalibrationUsed::of_file(source, path).map_err(|e| PipelineError::Layout {
        path: path.to_path_buf(),
        why: format!("cannot read it again ({e}): check the file"),
    })
}

/// The session's calibration and where it came from: `--calibration`, else the config's
/// `calibration`, else calib/ calibrated and cached in OUT under a key of its photos'
/// content, board and model (replacing a photo redoes it). OUT's calibration.yaml is the
/// calibration of calib/ only while it is used: with a calibration from elsewhere, one
/// left by an earlier run is removed.
fn session_calibration(
    session: &Path,
    out: &Path,
    config: &SessionConfig,
    settings: &ProcessSettings,
    notes: &mut Notes,
) -> Result<(Calibration, CalibrationUsed), PipelineError> {
    let cached = out.join("calibration.yaml");
    let key_path = out.join("cache").join("calibration.key");
    let elsewhere = match (&settings.calibration, &config.calibration) {
        (Some(c), _) => Some((CalibrationSource::Given, c.clone())),
        (None, Some(c)) => Some((CalibrationSource::Config, session.join(c))),
        (None, None) => None,
    };
    if let Some((source, path)) = elsewhere {
        let calib = read_calibration(&path)?;
        let used = calibration_used(source, &path)?;
        let is_cached = match (path.canonicalize(), cached.canonicalize()) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        };
        if !is_cached {
            remove_if_present(&cached)?;
            remove_if_present(&key_path)?;
        }
        return Ok((calib, used));
    }
    let dir = session.join("calib");
    if !dir.is_dir() {
        return Err(PipelineError::Layout {
            path: dir,
            why: "no calibration: give --calibration FILE, set `calibration` in bendscope.toml, or put checkerboard photos in this folder".into(),
        });
    }
    let mut photos: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(|e| PipelineError::Layout {
            path: dir.clone(),
            why: e.to_string(),
        })?
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.extension()
                .map(|e| {
                    IMAGE_EXTENSIONS.contains(&e.to_string_lossy().to_ascii_lowercase().as_str())
                })
                .unwrap_or(false)
        })
        .collect();
    photos.sort();
    let b = config.calib_board;
    let mut parts: Vec<Vec<u8>> = vec![
        format!(
            "{}x{}@{}:{}",
            b.cols,
            b.rows,
            b.square_mm,
            config.model.name()
        )
        .into_bytes(),
        env!("CARGO_PKG_VERSION").as_bytes().to_vec(),
    ];
    for p in &photos {
        parts.push(
            p.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
                .into_bytes(),
        );
        parts.push(content_key(p).unwrap_or(0).to_le_bytes().to_vec());
    }
    let key = format!("{:032x}", hash_parts(parts.iter().map(|p| p.as_slice())));
    let current = std::fs::read_to_string(&key_path)
        .map(|k| k.trim() == key)
        .unwrap_or(false);
    if current && !settings.force {
        if let Ok(c) = read_calibration(&cached) {
            return Ok((c, calibration_used(CalibrationSource::Calibrated, &cached)?));
        }
    }
    let sources: Vec<ViewSource> = photos.into_iter().map(ViewSource::Image).collect();
    let board = Board::new(b.cols, b.rows, b.square_mm)?;
    notes.progress.start("calibrating", 1);
    let det = detect_views(&sources, &board, &CornerSettings::default(), &|| {});
    let calib = calibrate(
        &det,
        &CalibrationSettings {
            model: config.model,
            board,
            fix_aspect_ratio: false,
        },
    );
    notes.progress.finish();
    // The calibrate command's advice names its --board flag; process reads the board
    // from the settings.
    let calib = calib.map_err(|e| PipelineError::Layout {
        path: dir.clone(),
        why: format!("calibration failed: {e}")
            .replace("--board", &format!("[calib_board] in {CONFIG}")),
    })?;
    write_calibration(&cached, &calib)?;
    write_atomic(&key_path, key.as_bytes()).map_err(write_err(&key_path))?;
    for r in &calib.views_rejected {
        notes.push(format!(
            "warning: {}: {}: not used for the calibration",
            dir.join(&r.name).display(),
            r.reason
        ));
    }
    notes.push(format!(
        "calibrated {} from {} views (RMS {:.3} px) -> {}",
        config.model.name(),
        calib.views_used.len(),
        calib.avg_reprojection_error,
        cached.display()
    ));
    let used = calibration_used(CalibrationSource::Calibrated, &cached)?;
    Ok((calib, used))
}

/// mm per undistorted px and the frame width it applies to.
#[derive(Debug, Clone, Copy)]
struct SessionScale {
    mm_per_px: f64,
    width: u32,
    plane_from_px: Option<[f64; 9]>,
}

/// The session's scale and where it came from: `mm_per_px` in the settings, else a
/// scale file (`scale`), else the scale photo measured with `[scale_board]`. Warns when
/// the board's square size was never given (mm/px is proportional to it).
fn session_scale(
    session: &Path,
    config: &SessionConfig,
    calib: &Calibration,
    notes: &mut Notes,
) -> Result<(SessionScale, ScaleUsed), PipelineError> {
    if let Some(m) = config.mm_per_px {
        let used = ScaleUsed {
            source: ScaleSource::MmPerPx,
            file: None,
            mm_per_px: m,
            image_width: calib.image_width,
            board: None,
            plane_from_px: None,
        };
        let scale = SessionScale {
            mm_per_px: m,
            width: calib.image_width,
            plane_from_px: None,
        };
        return Ok((scale, used));
    }
    if let Some(f) = &config.scale {
        let path = session.join(f);
        let s = read_scale_file(&path).map_err(|e| PipelineError::Layout {
            path: path.clone(),
            why: e
                .to_string()
                .replace(&format!("{}: ", path.display()), "")
                .replace(": make it", &format!(" (`scale` in {CONFIG}): make it")),
        })?;
        if let Some(b) = s.board.filter(|b| !b.square_mm_given) {
            notes.push(format!(
                "warning: {}: measured with `bendscope scale`'s default square size ({} mm, --square-mm not given), and every radius scales with it: measure it again with --square-mm",
                path.display(),
                b.square_mm
            ));
        }
        let scale = SessionScale {
            mm_per_px: s.mm_per_px,
            width: s.image_width,
            plane_from_px: s.plane_from_px,
        };
        let used = ScaleUsed {
            source: ScaleSource::ScaleFile,
            file: Some(path),
            mm_per_px: s.mm_per_px,
            image_width: s.image_width,
            board: s.board,
            plane_from_px: s.plane_from_px,
        };
        return Ok((scale, used));
    }
    let img = find_scale_image(session, config).ok_or_else(|| PipelineError::Layout {
        path: session.to_path_buf(),
        why: "no scale photo: put scale.jpg (a board lying in the actuator plane) in the session, or set mm_per_px (or scale, a file saved by `bendscope scale --save`) in bendscope.toml".into(),
    })?;
    let b = config.scale_board;
    let board = Board::new(b.cols, b.rows, b.square_mm)?;
    let s = scale_from_board_photo(&img, calib, &board, UndistortSettings::default()).map_err(
        |source| match source {
            // The scale command's advice names its --board flag; process reads the
            // board from the settings.
            ScaleError::NoBoard { .. } => PipelineError::Layout {
                path: img.clone(),
                why: source
                    .to_string()
                    .replace(&format!("{}: ", img.display()), "")
                    .replace("--board", &format!("[scale_board] in {CONFIG}")),
            },
            source => PipelineError::Scale {
                path: img.clone(),
                source,
            },
        },
    )?;
    if !config.scale_square_mm_given {
        notes.push(format!(
            "warning: {}: the scale board's square size is given nowhere: {} mm assumed, and every radius scales with it: set [scale_board] square_mm in {CONFIG}",
            img.display(),
            b.square_mm
        ));
    }
    if s.looks_tilted() {
        notes.push(format!(
            "warning: {}: board spacing varies by {:.1}%: not parallel to the image plane?",
            img.display(),
            100.0 * s.spread
        ));
    }
    let scale = SessionScale {
        mm_per_px: s.mm_per_px,
        width: s.image_width,
        plane_from_px: s.plane_from_px,
    };
    let used = ScaleUsed {
        source: ScaleSource::ScalePhoto,
        file: Some(img),
        mm_per_px: s.mm_per_px,
        image_width: s.image_width,
        board: Some(ScaleBoard {
            cols: b.cols,
            rows: b.rows,
            square_mm: b.square_mm,
            square_mm_given: config.scale_square_mm_given,
        }),
        plane_from_px: s.plane_from_px,
    };
    Ok((scale, used))
}

/// A measured item (a video with its chapters, or an RGB-D recording).
struct ItemResult {
    file: String,
    pressure_kpa: f64,
    pressure: f64,
    frames: Vec<FrameRecord>,
    problems: Vec<String>,
    clamp_marker_px: Option<(f64, f64)>,
    outputs: Vec<String>,
    /// Its result came from the cache.
    from_cache: bool,
    /// An output could not be written for lack of space: the run stops.
    storage_full: bool,
}

impl ItemResult {
    fn from_cache(entry: &ManifestEntry, c: CacheEntry) -> Self {
        Self {
            file: entry.file.clone(),
            pressure_kpa: entry.pressure_kpa,
            pressure: entry.pressure,
            frames: c.frames,
            problems: c.problems,
            clamp_marker_px: c.clamp_marker_px,
            outputs: c.outputs,
            from_cache: true,
            storage_full: false,
        }
    }

    fn to_cache(&self, key: ItemKey) -> CacheEntry {
        CacheEntry {
            key,
            frames: self.frames.clone(),
            problems: self.problems.clone(),
            clamp_marker_px: self.clamp_marker_px,
            outputs: self.outputs.clone(),
        }
    }

    /// The item's row: statistics of its frames and its status.
    fn record(&self) -> VideoRecord {
        let stats = stats::summarize(&self.frames);
        let status = if stats.frames_used == 0 {
            let why = if self.problems.is_empty() {
                most_common_rejection(&self.frames).unwrap_or_else(|| "no frames decoded".into())
            } else {
                self.problems.join("; ")
            };
            VideoStatus::Failed { why }
        } else if self.problems.is_empty() {
            VideoStatus::Ok
        } else {
            VideoStatus::Partial {
                problems: self.problems.clone(),
            }
        };
        VideoRecord {
            file: self.file.clone(),
            pressure_kpa: self.pressure_kpa,
            pressure: self.pressure,
            stats,
            status,
        }
    }
}

/// The record of a measured frame of `file`.
fn frame_record(
    file: &str,
    frame: u64,
    time_s: f64,
    pressure_kpa: f64,
    m: frame::FrameMeasurement,
) -> FrameRecord {
    FrameRecord {
        file: file.to_string(),
        frame,
        time_s,
        pressure_kpa,
        n_markers: m.n_markers,
        n_ignored: m.ignored_px.len(),
        n_continuing: m.n_continuing,
        radius_px: m.radius_px,
        radius_mm: m.radius_mm,
        curvature_per_m: m.curvature_per_m,
        bending_angle_deg: m.bending_angle_deg,
        fit_rms: m.fit_rms,
        status: m.status,
        markers: m.markers,
        segments: m.segments,
        tip_x_mm: f64::NAN,
        tip_y_mm: f64::NAN,
        tip_angle_deg: f64::NAN,
        radius_mm_smooth: f64::NAN,
        curvature_per_m_smooth: f64::NAN,
        bending_angle_deg_smooth: f64::NAN,
    }
}

/// Maps the marker centroids of a frame undistorted before detection back to the raw
/// frame (markers.csv's `x_px`, `y_px`) through the lens model.
fn raw_marker_centroids(undistorter: &Undistorter, m: &mut frame::FrameMeasurement) {
    let flat: Vec<nalgebra::Point2<f64>> = m
        .markers
        .iter()
        .map(|p| nalgebra::Point2::new(p.x_px, p.y_px))
        .collect();
    match undistorter.distort_points(&flat) {
        Ok(raw) => {
            for (p, r) in m.markers.iter_mut().zip(raw) {
                (p.x_px, p.y_px) = (r.x, r.y);
            }
        }
        Err(_) => {
            for p in &mut m.markers {
                (p.x_px, p.y_px) = (f64::NAN, f64::NAN);
            }
        }
    }
}

/// The most frequent rejection of `frames`, with a hint.
fn most_common_rejection(frames: &[FrameRecord]) -> Option<String> {
    let mut counts: std::collections::BTreeMap<String, usize> = std::collections::BTreeMap::new();
    for f in frames.iter().filter(|f| !f.status.is_ok()) {
        *counts.entry(f.status.to_string()).or_default() += 1;
    }
    let hint = |s: &str| {
        if s.contains("outside the roi") {
            "check the roi in bendscope.toml (undistorted pixels; `bendscope inspect` shows the markers' positions)"
        } else if s.starts_with("0 markers found") {
            "no blob of the marker colour: set [detect] colour in bendscope.toml (red, green, blue, yellow or dark; default red), check the lighting and expected_markers; `bendscope inspect` shows what passes the thresholds"
        } else if s.contains("markers found") {
            "check the lighting, the HSV thresholds ([detect] colour, hue_min, ...; `bendscope inspect` shows what passes) and expected_markers in bendscope.toml"
        } else if s.contains("pressure log") {
            "check that the log covers the recording"
        } else if s.contains("depth") {
            "check the depth frames"
        } else {
            "see per_frame.csv"
        }
    };
    counts
        .into_iter()
        .max_by_key(|(_, n)| *n)
        .map(|(s, n)| format!("{s} (in {n} of {} frames): {}", frames.len(), hint(&s)))
}

impl VideoRun<'_> {
    /// Measures one video (all its chapters), streaming: a decoder thread per chapter
    /// feeds frames through a bounded channel. Chapter clocks continue each other: a
    /// chapter starts one frame interval (of its own stream) after the previous
    /// chapter's last frame.
    fn measure_video(
        &self,
        entry: &ManifestEntry,
        start: Option<nalgebra::Point2<f64>>,
        progress: &mut dyn Progress,
    ) -> ItemResult {
        let (session, out, config, log) = (self.session, self.out, self.config, self.log);
        // Frames measured of this item, for progress.
        let mut done = 0u64;
        let mut tracker = Tracker::new(match start {
            Some(p) => ChainStart::Near(p),
            None => ChainStart::Side(config.detect.clamp_side),
        });
        let mut result = ItemResult {
            file: entry.file.clone(),
            pressure_kpa: entry.pressure_kpa,
            pressure: entry.pressure,
            frames: vec![],
            problems: vec![],
            clamp_marker_px: None,
            outputs: vec![],
            from_cache: false,
            storage_full: false,
        };
        let segments = config.segment_plan();
        let mut overlay_pending = true;
        let (mut time_offset, mut index_offset) = (0.0, 0u64);
        let mut outside_log = 0usize;
        for file in std::iter::once(&entry.file).chain(&entry.chapters) {
            let mut source = match source::open_source(
                &session.join(file),
                config.frame_stride,
                config.full_frame_undistort,
            ) {
                Ok(s) => s,
                Err(e) => {
                    result.problems.push(e);
                    continue;
                }
            };
            let (w, h) = source.size();
            // Frames expected: those of the chapters before and this one's.
            let expected = done + source.frames_expected();
            let prepared = self
                .calib
                .for_resolution(w, h)
                .and_then(|c| Undistorter::new(&c, UndistortSettings::default()))
                .and_then(|u| {
                    let maps = if config.full_frame_undistort {
                        Some(u.maps()?)
                    } else {
                        None
                    };
                    Ok((u, maps))
                });
            let (undistorter, maps) = match prepared {
                Ok(p) => p,
                Err(e) => {
                    result.problems.push(format!("{file}: {e}"));
                    let _ = source.finish();
                    continue;
                }
            };
            // mm per px scales with the frame size (same aspect ratio as the scale photo).
            let mm_per_px = self.scale.mm_per_px * self.scale.width as f64 / w as f64;
            let plane_from_px = self
                .scale
                .plane_from_px
                .map(|h| crate::scale::homography_for_width(&h, self.scale.width, w));
            let (mut last_time, mut last_index, mut interval) = (f64::NAN, 0u64, 0.0f64);
            loop {
                let f = match source.next() {
                    Next::Frame(f) => f,
                    Next::Bad { index, time_s, why } => {
                        result.problems.push(why.clone());
                        result.frames.push(FrameRecord::rejected(
                            &entry.file,
                            index + index_offset,
                            time_s + time_offset,
                            entry.pressure_kpa,
                            FrameStatus::BadFrame { why },
                        ));
                        continue;
                    }
                    Next::End => break,
                };
                if last_time.is_finite() && f.time_s > last_time {
                    interval = f.time_s - last_time;
                }
                let (time_s, index) = (f.time_s + time_offset, f.index + index_offset);
                let pressure_kpa = match log {
                    Some(log) => log
                        .pressure_at(time_s + config.ramp_time_offset_s)
                        .unwrap_or(f64::NAN),
                    None => entry.pressure_kpa,
                };
                let mut m = if log.is_some() && pressure_kpa.is_nan() {
                    outside_log += 1;
                    frame::FrameMeasurement::rejected(0, FrameStatus::OutsidePressureLog)
                } else {
                    match &maps {
                        Some(maps) => {
                            match overlay::undistort_pixels(&undistorter, maps, &f.pixels) {
                                Ok(flat) => measure_frame(
                                    &flat,
                                    None,
                                    &Geometry::Plane {
                                        undistorter: None,
                                        mm_per_px,
                                        plane_from_px,
                                    },
                                    &config.detect,
                                    &frame::MarkerLayout {
                                        expected: config.expected_markers,
                                        roi: config.roi.as_deref(),
                                        segments: &segments,
                                    },
                                    &mut tracker,
                                ),
                                Err(e) => {
                                    result.problems.push(format!("{file}: {e}"));
                                    break;
                                }
                            }
                        }
                        None => frame::measure_pixels(
                            &f.pixels,
                            None,
                            &Geometry::Plane {
                                undistorter: Some(&undistorter),
                                mm_per_px,
                                plane_from_px,
                            },
                            config,
                            &segments,
                            &mut tracker,
                        ),
                    }
                };
                if maps.is_some() {
                    raw_marker_centroids(&undistorter, &mut m);
                }
                if m.status.is_ok() && overlay_pending {
                    overlay_pending = false;
                    match overlay::write_video_overlay(
                        out,
                        &entry.file,
                        &f.pixels,
                        &self.calib,
                        config,
                        &m,
                    ) {
                        Ok(rel) => result.outputs.push(rel),
                        Err(e) => {
                            result.storage_full |= crate::io::is_storage_full(&e);
                            result.problems.push(format!(
                                "overlay not written: {e}: check that overlays/ in the output folder is a writable folder (a rerun makes it)"
                            ));
                            // Named all the same: the cache entry stays stale until the
                            // overlay exists, so a rerun makes it.
                            result.outputs.push(overlay::overlay_rel_path(&entry.file));
                        }
                    }
                }
                result
                    .frames
                    .push(frame_record(&entry.file, index, time_s, pressure_kpa, m));
                done += 1;
                progress.frames(done, expected.max(done));
                last_time = f.time_s;
                last_index = f.index;
                source.recycle(f.pixels);
            }
            result.problems.extend(source.finish());
            if last_time.is_finite() {
                time_offset += last_time + interval;
                index_offset += last_index + 1;
            }
        }
        if outside_log > 0 {
            result.problems.push(format!(
            "{outside_log} of {} frames fall outside the pressure log's time span: check that the log covers the recording and ramp_time_offset_s",
            result.frames.len()
        ));
        }
        if let ChainStart::Near(p) = tracker.start {
            result.clamp_marker_px = Some((p.x, p.y));
        }
        result
    }
}

/// An RGB-D session's frames as a source: the PNG folders or the bag recording.
struct RgbdInput {
    /// Item name (`color`, or the bag's file name).
    item: String,
    intrinsics: crate::rgbd::RgbdIntrinsics,
    total: usize,
    timing: String,
    source: Box<dyn FrameSource>,
}

fn open_rgbd(
    session: &Path,
    frames: &RgbdFrames,
    notes: &mut Notes,
) -> Result<RgbdInput, PipelineError> {
    Ok(match frames {
        RgbdFrames::PngFolders => {
            let listing = list_frames(session)?;
            for d in &listing.orphan_depth {
                notes.push(format!(
                    "warning: {d}: no colour frame of the same name: ignored"
                ));
            }
            let intr = listing.intrinsics;
            RgbdInput {
                item: "color".into(),
                total: listing.frames.len(),
                timing: listing.timing,
                source: Box::new(RgbdSource::new(listing.frames, (intr.width, intr.height))),
                intrinsics: intr,
            }
        }
        RgbdFrames::Bag(path) => {
            let rec = BagRecording::open(path)?;
            for n in &rec.notes {
                notes.push(format!("warning: {n}"));
            }
            RgbdInput {
                item: rec.name(),
                intrinsics: rec.intrinsics.clone(),
                total: rec.frames.len(),
                timing: rec.timing.clone(),
                source: Box::new(BagSource::new(rec)),
            }
        }
    })
}

/// Measures the frames of an RGB-D session (one item named `color`, or after the bag).
fn measure_rgbd(
    session: &Path,
    frames: &RgbdFrames,
    config: &SessionConfig,
    log: &PressureLog,
    notes: &mut Notes,
) -> Result<ItemResult, PipelineError> {
    let RgbdInput {
        item,
        intrinsics,
        total,
        timing,
        mut source,
    } = open_rgbd(session, frames, notes)?;
    let intr = &intrinsics;
    let undistorter = crate::rgbd::undistorter(intr)?;
    let geometry = Geometry::Depth {
        undistorter: &undistorter,
        intrinsics: intr,
    };
    let mut tracker = Tracker::new(ChainStart::Side(config.detect.clamp_side));
    let segments = config.segment_plan();
    let mut result = ItemResult {
        file: item.clone(),
        pressure_kpa: f64::NAN,
        pressure: f64::NAN,
        frames: Vec::with_capacity(total),
        problems: vec![],
        clamp_marker_px: None,
        outputs: vec![],
        from_cache: false,
        storage_full: false,
    };
    let (mut bad, mut outside_log) = (Vec::new(), 0usize);
    notes.progress.start("RGB-D frames", total as u64);
    loop {
        let next = source.next();
        notes.progress.advance(1);
        let (index, time_s) = match &next {
            Next::Frame(f) => (f.index, f.time_s),
            Next::Bad { index, time_s, .. } => (*index, *time_s),
            Next::End => break,
        };
        let pressure_kpa = log
            .pressure_at(time_s + config.ramp_time_offset_s)
            .unwrap_or(f64::NAN);
        let record =
            |status: FrameStatus| FrameRecord::rejected(&item, index, time_s, pressure_kpa, status);
        let row = match next {
            Next::Bad { why, .. } => {
                bad.push(why.clone());
                record(FrameStatus::BadFrame { why })
            }
            Next::Frame(_) if pressure_kpa.is_nan() => {
                outside_log += 1;
                record(FrameStatus::OutsidePressureLog)
            }
            Next::Frame(f) => {
                let m = frame::measure_pixels(
                    &f.pixels,
                    f.depth.as_ref(),
                    &geometry,
                    config,
                    &segments,
                    &mut tracker,
                );
                frame_record(&item, index, time_s, pressure_kpa, m)
            }
            Next::End => break,
        };
        result.frames.push(row);
    }
    notes.progress.finish();
    if let Some(first) = bad.first() {
        result.problems.push(if bad.len() == 1 {
            first.clone()
        } else {
            format!("{} unusable frames, e.g. {first}", bad.len())
        });
    }
    if outside_log > 0 {
        result.problems.push(format!(
            "{outside_log} of {total} frames fall outside the pressure log's time span ({}): check that the log covers the recording and ramp_time_offset_s",
            timing
        ));
    }
    Ok(result)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session::SessionIssue;

    #[test]
    fn many_rows_with_one_problem_are_summarised_after_the_first_few() {
        let issue = |i: usize, message: &str| SessionIssue {
            file: format!("V{i}.MP4"),
            line: Some(i + 2),
            message: message.into(),
        };
        let mut issues: Vec<SessionIssue> = (0..1000).map(|i| issue(i, "no such video")).collect();
        issues.insert(3, issue(9999, "listed twice"));
        let lines = issue_lines(&issues);
        assert_eq!(lines.len(), ISSUE_LINES_PER_KIND + 2, "{lines:#?}");
        assert_eq!(lines[0], "warning: V0.MP4 (line 2): no such video");
        assert_eq!(lines[3], "warning: V9999.MP4 (line 10001): listed twice");
        assert_eq!(
            lines.last().unwrap(),
            &format!(
                "warning: {} more rows or files: no such video (all are listed in per_video.csv)",
                1000 - ISSUE_LINES_PER_KIND
            )
        );
    }

    #[test]
    fn a_write_error_names_its_file_once() {
        let path = Path::new("out/overlays/a.png");
        let os = std::io::Error::from_raw_os_error(21);
        let e = PipelineError::Write {
            path: path.to_path_buf(),
            source: crate::io::write_error(path, Path::new("out/overlays"), &os),
        };
        assert_eq!(
            e.to_string(),
            "out/overlays/a.png: cannot write (Is a directory (os error 21)): check the output folder's space and permissions"
        );
    }
}
