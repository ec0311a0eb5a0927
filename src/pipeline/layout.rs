//! What kind of session a folder holds (`Layout`: step, ramp or RGB-D, refused in
//! one line when it is none or two of them), and where each session's results go
//! ([`output_dirs`]).

use std::path::{Path, PathBuf};

use crate::rgbd::{rgbd_frames, RgbdFrames};
use crate::session::{
    read_manifest, read_pressure_log, session_videos, Manifest, PressureLog, MANIFEST, PRESSURE_LOG,
};

use super::error::PipelineError;

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
pub(super) enum Layout {
    /// pressures.csv, one video per pressure.
    Step(Manifest),
    /// pressure_log.csv and one video.
    Ramp(PressureLog, String),
    /// color/ + depth/ + intrinsics.json (or a .bag recording) + pressure_log.csv.
    Rgbd(PressureLog, RgbdFrames),
}

pub(super) fn read_layout(session: &Path) -> Result<Layout, PipelineError> {
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
