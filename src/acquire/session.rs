//! The session folder an acquisition writes, in the layout `bendscope process` reads
//! ([`crate::session`]):
//!
//! ```text
//! SESSION/
//!   GX010101.MP4 ...       the videos under their camera names (chapters GX02.. too)
//!   pressures.csv          `file,pressure_kpa`: the set point of each recording (steps)
//!   pressure_log.csv       `time_s,pressure_kpa,set_kpa` from the recording's start (ramp)
//!   protocol.toml          a copy of the protocol
//!   acquisition_log.csv    one row per recording: set point, measured mean, spread, status
//! ```
//!
//! Every file is rewritten (atomically) after each recording, so a run stopped at any
//! point leaves a session that `process` measures, and the acquisition log tells a rerun
//! where to resume: steps with a row are done (`ok`), or recorded but still on the camera
//! (`not downloaded: ...`, fetched first by the rerun).

use std::path::Path;

use super::protocol::{Plan, Protocol};
use super::{AcquireError, ACQUISITION_LOG, PROTOCOL_COPY};
use crate::session::{MANIFEST, PRESSURE_LOG};
use crate::table::{write_csv, Column, Table};

/// Status text of a recording whose files are in the session.
pub const STATUS_OK: &str = "ok";
/// Status prefix of a recording whose files are still on the camera.
pub const STATUS_NOT_DOWNLOADED: &str = "not downloaded";
/// Separator of file names in one cell of the acquisition log.
const FILE_SEPARATOR: &str = ";";

/// Mean and spread of the pressure measured during one recording, kPa.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PressureStats {
    /// Number of readings.
    pub samples: u64,
    /// Mean, kPa (NaN without readings).
    pub mean_kpa: f64,
    /// Sample standard deviation, kPa (NaN with fewer than two readings).
    pub std_kpa: f64,
    /// Smallest reading, kPa.
    pub min_kpa: f64,
    /// Largest reading, kPa.
    pub max_kpa: f64,
}

impl PressureStats {
    /// The statistics of `readings_kpa`.
    pub fn from_readings(readings_kpa: &[f64]) -> PressureStats {
        let n = readings_kpa.len();
        let mean = readings_kpa.iter().sum::<f64>() / n as f64;
        let std = if n > 1 {
            (readings_kpa.iter().map(|p| (p - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            f64::NAN
        };
        let fold = |init: f64, f: fn(f64, f64) -> f64| {
            if n == 0 {
                f64::NAN
            } else {
                readings_kpa.iter().copied().fold(init, f)
            }
        };
        PressureStats {
            samples: n as u64,
            mean_kpa: mean,
            std_kpa: std,
            min_kpa: fold(f64::INFINITY, f64::min),
            max_kpa: fold(f64::NEG_INFINITY, f64::max),
        }
    }
}

/// One recording in the acquisition log.
#[derive(Debug, Clone, PartialEq)]
pub struct LogRow {
    /// 1-based position in the run.
    pub step: u32,
    /// 1-based pass over the set points.
    pub repeat: u32,
    /// Set point, kPa (the ramp's top for a ramp).
    pub set_kpa: f64,
    /// File names in the session, first chapter first.
    pub files: Vec<String>,
    /// Where the camera keeps them (`100GOPRO/GX010101.MP4`).
    pub camera_files: Vec<String>,
    /// Pressure measured while recording.
    pub measured: PressureStats,
    /// Length of the recording, s (from the start request to the stop request).
    pub record_s: f64,
    /// [`STATUS_OK`] or `not downloaded: why`.
    pub status: String,
    /// A remark (set point not reached, ramp interrupted), may be empty.
    pub note: String,
}

impl LogRow {
    /// True when the files are in the session.
    pub fn is_ok(&self) -> bool {
        self.status == STATUS_OK
    }
}

/// Checks `session` for an acquisition with `protocol` (text `text`): a new or empty
/// folder, or one this protocol's earlier run left (resumed). Writes the protocol copy
/// and returns the acquisition log so far.
pub fn prepare(
    session: &Path,
    protocol: &Protocol,
    text: &str,
) -> Result<Vec<LogRow>, AcquireError> {
    let bad = |why: String| AcquireError::Session {
        path: session.to_path_buf(),
        why,
    };
    if session.exists() && !session.is_dir() {
        return Err(bad("is a file: give a folder for the session".into()));
    }
    let copy = session.join(PROTOCOL_COPY);
    let log = session.join(ACQUISITION_LOG);
    if session.is_dir() {
        if !log.exists() && (session.join(MANIFEST).exists() || session.join(PRESSURE_LOG).exists())
        {
            return Err(bad(format!(
                "holds a {MANIFEST} or {PRESSURE_LOG} that acquire did not write: choose a new folder"
            )));
        }
        // A changed plan is refused only once something was recorded with the old one.
        if copy.exists() && log.exists() {
            let earlier = Protocol::read(&copy)?;
            if earlier.plan != protocol.plan {
                return Err(bad(format!(
                    "was acquired with another plan ({PROTOCOL_COPY}): resume with that protocol, or choose a new folder"
                )));
            }
        }
    }
    let rows = if log.exists() {
        read_log(&log)?
    } else {
        vec![]
    };
    crate::io::write_atomic(&copy, text.as_bytes())
        .map_err(|e| bad(format!("cannot write {PROTOCOL_COPY}: {e}")))?;
    crate::io::remove_stale_temporaries(&[session.to_path_buf()]);
    Ok(rows)
}

/// Ok when `path` is a video with a decodable frame of a video stream (through
/// [`crate::video::VideoReader`]); else why not. A recording its recorder left unfinished
/// (killed, or overwritten by another) fails this.
pub fn playable_video(path: &Path) -> Result<(), String> {
    let mut reader = crate::video::VideoReader::open(path).map_err(|e| e.to_string())?;
    match reader.advance() {
        Some(_) => Ok(()),
        None => Err(format!("{}: no frame could be decoded", path.display())),
    }
}

/// Name a recording that is not playable is moved aside to (kept for inspection; no
/// session reader takes it for a video).
pub fn unplayable_name(file: &str) -> String {
    format!("{file}.unplayable")
}

/// Reads an acquisition log written by [`write_log`].
pub fn read_log(path: &Path) -> Result<Vec<LogRow>, AcquireError> {
    let t = Table::read(path)?;
    let col = |name: &str| t.require(name, "this acquisition log was not written by acquire");
    let (c_step, c_repeat, c_set) = (col("step")?, col("repeat")?, col("set_kpa")?);
    let (c_files, c_cam, c_status) = (col("files")?, col("camera_files")?, col("status")?);
    let (c_mean, c_std, c_min, c_max, c_n, c_rec) = (
        col("measured_mean_kpa")?,
        col("measured_std_kpa")?,
        col("measured_min_kpa")?,
        col("measured_max_kpa")?,
        col("samples")?,
        col("record_s")?,
    );
    let c_note = t.column("note");
    let num = |row: usize, c: usize| -> Result<f64, AcquireError> {
        let cell = t.cell(row, c).trim();
        if cell.is_empty() {
            Ok(f64::NAN)
        } else {
            Ok(t.f64_at(row, c)?)
        }
    };
    let split = |s: &str| -> Vec<String> {
        s.split(FILE_SEPARATOR)
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect()
    };
    let mut rows = Vec::new();
    for r in 0..t.len() {
        rows.push(LogRow {
            step: num(r, c_step)? as u32,
            repeat: num(r, c_repeat)? as u32,
            set_kpa: num(r, c_set)?,
            files: split(t.cell(r, c_files)),
            camera_files: split(t.cell(r, c_cam)),
            measured: PressureStats {
                samples: num(r, c_n)?.max(0.0) as u64,
                mean_kpa: num(r, c_mean)?,
                std_kpa: num(r, c_std)?,
                min_kpa: num(r, c_min)?,
                max_kpa: num(r, c_max)?,
            },
            record_s: num(r, c_rec)?,
            status: t.cell(r, c_status).trim().to_string(),
            note: c_note
                .map(|c| t.cell(r, c).trim().to_string())
                .unwrap_or_default(),
        });
    }
    Ok(rows)
}

/// Writes the acquisition log and the manifest (steps) of `rows`.
pub fn write_log(session: &Path, rows: &[LogRow], plan: &Plan) -> Result<(), AcquireError> {
    let text = |f: fn(&LogRow) -> String| rows.iter().map(f).collect::<Vec<_>>();
    let num = |f: fn(&LogRow) -> f64| rows.iter().map(f).collect::<Vec<_>>();
    write_csv(
        &session.join(ACQUISITION_LOG),
        &[
            Column::int("step", rows.iter().map(|r| r.step as u64)),
            Column::int("repeat", rows.iter().map(|r| r.repeat as u64)),
            Column::num("set_kpa", 3, num(|r| r.set_kpa)),
            Column::text("files", text(|r| r.files.join(FILE_SEPARATOR))),
            Column::text(
                "camera_files",
                text(|r| r.camera_files.join(FILE_SEPARATOR)),
            ),
            Column::num("measured_mean_kpa", 3, num(|r| r.measured.mean_kpa)),
            Column::num("measured_std_kpa", 3, num(|r| r.measured.std_kpa)),
            Column::num("measured_min_kpa", 3, num(|r| r.measured.min_kpa)),
            Column::num("measured_max_kpa", 3, num(|r| r.measured.max_kpa)),
            Column::int("samples", rows.iter().map(|r| r.measured.samples)),
            Column::num("record_s", 3, num(|r| r.record_s)),
            Column::text("status", text(|r| r.status.clone())),
            Column::text("note", text(|r| r.note.clone())),
        ],
    )?;
    if let Plan::Steps(_) = plan {
        let ok: Vec<&LogRow> = rows
            .iter()
            .filter(|r| r.is_ok() && !r.files.is_empty())
            .collect();
        write_csv(
            &session.join(MANIFEST),
            &[
                Column::text("file", ok.iter().map(|r| r.files[0].clone())),
                Column::num("pressure_kpa", 3, ok.iter().map(|r| r.set_kpa)),
            ],
        )?;
    }
    Ok(())
}

/// One reading of a ramp's pressure log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RampSample {
    /// Time from the recording's start, s.
    pub time_s: f64,
    /// Measured pressure, kPa.
    pub pressure_kpa: f64,
    /// Set point at that time, kPa.
    pub set_kpa: f64,
}

/// Writes a ramp's `pressure_log.csv` (`time_s,pressure_kpa,set_kpa`).
pub fn write_pressure_log(session: &Path, samples: &[RampSample]) -> Result<(), AcquireError> {
    write_csv(
        &session.join(PRESSURE_LOG),
        &[
            Column::num("time_s", 4, samples.iter().map(|s| s.time_s)),
            Column::num("pressure_kpa", 3, samples.iter().map(|s| s.pressure_kpa)),
            Column::num("set_kpa", 3, samples.iter().map(|s| s.set_kpa)),
        ],
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acquire::protocol::StepPlan;

    #[test]
    fn the_log_reads_back_and_the_manifest_lists_the_fetched_recordings() {
        let d = tempfile::tempdir().unwrap();
        let stats = PressureStats::from_readings(&[39.0, 40.0, 41.0]);
        assert_eq!(
            (stats.mean_kpa, stats.std_kpa, stats.min_kpa, stats.max_kpa),
            (40.0, 1.0, 39.0, 41.0)
        );
        let rows = vec![
            LogRow {
                step: 1,
                repeat: 1,
                set_kpa: 40.0,
                files: vec!["GX010101.MP4".into(), "GX020101.MP4".into()],
                camera_files: vec![
                    "100GOPRO/GX010101.MP4".into(),
                    "100GOPRO/GX020101.MP4".into(),
                ],
                measured: stats,
                record_s: 5.0,
                status: STATUS_OK.into(),
                note: String::new(),
            },
            LogRow {
                step: 2,
                repeat: 1,
                set_kpa: 55.0,
                files: vec!["GX010102.MP4".into()],
                camera_files: vec!["100GOPRO/GX010102.MP4".into()],
                measured: PressureStats::from_readings(&[]),
                record_s: 5.0,
                status: format!("{STATUS_NOT_DOWNLOADED}: cut, say \"why\""),
                note: "a, b".into(),
            },
        ];
        let plan = Plan::Steps(StepPlan {
            pressures_kpa: vec![40.0, 55.0],
            stabilize_s: 0.0,
            record_s: 5.0,
            repeats: 1,
            vent_at_end: true,
            sample_hz: 10.0,
        });
        write_log(d.path(), &rows, &plan).unwrap();
        let back = read_log(&d.path().join(ACQUISITION_LOG)).unwrap();
        assert_eq!(back[0], rows[0]);
        assert_eq!(back[1].status, rows[1].status);
        assert_eq!(back[1].note, rows[1].note);
        assert!(back[1].measured.mean_kpa.is_nan());
        let m = crate::session::read_manifest(d.path()).unwrap();
        // Only the fetched recording; its chapter is not a row of its own.
        assert_eq!(
            m.entries.len(),
            0,
            "the videos are not in the folder: {m:?}"
        );
        assert_eq!(
            std::fs::read_to_string(d.path().join(MANIFEST)).unwrap(),
            "file,pressure_kpa\nGX010101.MP4,40.000\n"
        );
    }
}
