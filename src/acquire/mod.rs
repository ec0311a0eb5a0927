//! Acquisition: drive the pressure regulator and the camera through a protocol and write
//! a session folder that `bendscope process` measures.
//!
//! For each set point of the step protocol: `SET` the pressure, wait `stabilize_s`, record
//! `record_s` while reading the pressure (`GET`) `sample_hz` times a second, stop, fetch
//! the recording's files, and rewrite the session's tables ([`session`]). The ramp
//! protocol records once while the set point rises at `rate_kpa_s`, logging the pressure.
//!
//! Anything that stops a run early (Ctrl-C through the caller's stop flag, a lost camera,
//! a regulator error) vents the regulator to 0 kPa first, stops the camera, keeps every
//! recording fetched so far, and leaves the acquisition log from which a rerun resumes
//! at the next set point (fetching first a recording whose download failed). A rerun
//! also records again every set point whose recording the log calls done but that is
//! missing or not a playable video (a recorder left running by a killed run wrote over
//! it), and stops such a recorder first ([`webcam::stop_earlier_recorder`]); a GoPro
//! still recording for a killed run is stopped first too
//! ([`camera::Camera::stop_leftover_recording`]).
//!
//! Modules: [`protocol`] (the TOML), [`regulator`] (the serial line protocol), [`camera`]
//! (the camera trait, GoPro over the Open GoPro HTTP API), [`webcam`] (a UVC webcam
//! through ffmpeg), [`gopro_wifi`] (HERO5-HERO8 through the legacy WiFi API), [`session`]
//! (the files written).

pub mod camera;
pub mod gopro_wifi;
pub mod protocol;
pub mod regulator;
pub mod session;
pub mod webcam;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use camera::{Camera, CameraFile, GoPro};
use gopro_wifi::GoProWifi;
use protocol::{CameraConfig, Plan, Protocol, RampPlan, SetPoint, StepPlan};
use regulator::SerialRegulator;
use session::{LogRow, PressureStats, RampSample, STATUS_NOT_DOWNLOADED, STATUS_OK};
use webcam::Webcam;

use crate::table::TableError;

/// Name of the protocol's copy in the session folder.
pub const PROTOCOL_COPY: &str = "protocol.toml";
/// Name of the acquisition log in the session folder.
pub const ACQUISITION_LOG: &str = "acquisition_log.csv";
/// Longest sleep between checks of the stop flag.
const WAIT_SLICE: Duration = Duration::from_millis(20);
/// A measured mean further than this from its set point gets a note, kPa...
const SET_POINT_WARN_KPA: f64 = 1.0;
/// ... or this share of the set point, whichever is larger.
const SET_POINT_WARN_SHARE: f64 = 0.05;
/// Longest silence towards the regulator during waits, s: the sketch vents when the
/// host stays silent for two minutes (a crashed host must not leave the actuator
/// pressurised), so waits read the pressure now and then.
const REGULATOR_KEEP_ALIVE_S: f64 = 1.0;
/// Time per recording spent on requests and downloads, for the dry run's estimate, s.
const OVERHEAD_ESTIMATE_S: f64 = 3.0;

/// Errors of an acquisition.
#[derive(Debug, thiserror::Error)]
pub enum AcquireError {
    /// The protocol file is wrong.
    #[error("{path}: {why}")]
    Protocol {
        /// The protocol file.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
    /// The session folder cannot take this acquisition.
    #[error("{path}: {why}")]
    Session {
        /// The session folder.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
    /// The regulator cannot be reached or does not speak the protocol.
    #[error("regulator on {port}: {why}")]
    Regulator {
        /// Serial port.
        port: String,
        /// What is wrong and what to do.
        why: String,
    },
    /// The regulator answered `ERR`.
    #[error("regulator on {port} refused `{command}`: ERR {text} (check the supply pressure, the sensor and the set point range)")]
    RegulatorRefused {
        /// Serial port.
        port: String,
        /// The command refused.
        command: String,
        /// The device's reason.
        text: String,
    },
    /// The camera cannot be reached or failed.
    #[error("{camera}: {why}")]
    Camera {
        /// Which camera.
        camera: String,
        /// What is wrong and what to do.
        why: String,
    },
    /// The camera stayed busy.
    #[error("{camera} is busy (HTTP {status} to {request}): close its menus, let it finish encoding, check that a card is in and not full")]
    CameraBusy {
        /// Which camera.
        camera: String,
        /// The request refused.
        request: String,
        /// HTTP status.
        status: u16,
    },
    /// A recording could not be copied into the session.
    #[error("download of {file} failed: {why}")]
    Download {
        /// The file.
        file: String,
        /// What happened.
        why: String,
    },
    /// A camera file would replace a recording of this session.
    #[error("the camera's {file} has the name of a recording already in the session: move the session's {file} away (the camera's numbering restarted?)")]
    NameTaken {
        /// The file name.
        file: String,
    },
    /// Stopped by the user.
    #[error("interrupted")]
    Interrupted,
    /// A table could not be read or written.
    #[error(transparent)]
    Table(#[from] TableError),
}

/// What an acquisition did.
#[derive(Debug)]
pub struct AcquireOutcome {
    /// Recordings fetched by this run.
    pub recorded: usize,
    /// Recordings in the session now (all runs).
    pub in_session: usize,
    /// Recordings the protocol asks for.
    pub planned: usize,
    /// Why the run stopped early, if it did (what was recorded is kept).
    pub stopped: Option<AcquireError>,
    /// The regulator was vented to 0 kPa at the end (vent_at_end, or after a stop).
    pub vented: bool,
    /// When venting after a stop failed: why (vent by hand!).
    pub vent_failed: Option<AcquireError>,
}

/// One line of a dry run's plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedRecording {
    /// 1-based position in the run.
    pub step: u32,
    /// Set point, kPa (a ramp: its top).
    pub pressure_kpa: f64,
    /// `to record`, `done`, or `to fetch from the camera`.
    pub state: &'static str,
}

/// A dry run: what acquire would do, without touching a device.
#[derive(Debug, Clone, PartialEq)]
pub struct DryRun {
    /// The protocol.
    pub protocol: Protocol,
    /// Every recording and its state.
    pub recordings: Vec<PlannedRecording>,
    /// Estimated time for what is left, s.
    pub estimate_s: f64,
}

/// Reads the protocol and the session folder and says what a run would do.
pub fn dry_run(protocol_path: &Path, session: &Path) -> Result<DryRun, AcquireError> {
    let protocol = Protocol::read(protocol_path)?;
    let log = session.join(ACQUISITION_LOG);
    let rows = if log.exists() {
        session::read_log(&log)?
    } else {
        vec![]
    };
    let state = |step: u32| match rows.iter().find(|r| r.step == step) {
        Some(r) if r.is_ok() => "done",
        Some(_) => "to fetch from the camera",
        None => "to record",
    };
    let (recordings, per_s): (Vec<PlannedRecording>, f64) = match &protocol.plan {
        Plan::Steps(s) => (
            s.set_points()
                .iter()
                .map(|sp| PlannedRecording {
                    step: sp.step,
                    pressure_kpa: sp.pressure_kpa,
                    state: state(sp.step),
                })
                .collect(),
            s.stabilize_s + s.record_s + OVERHEAD_ESTIMATE_S,
        ),
        Plan::Ramp(r) => (
            vec![PlannedRecording {
                step: 1,
                pressure_kpa: r.top_kpa,
                state: state(1),
            }],
            r.stabilize_s + r.duration_s() + OVERHEAD_ESTIMATE_S,
        ),
    };
    let left = recordings.iter().filter(|r| r.state == "to record").count();
    Ok(DryRun {
        protocol,
        recordings,
        estimate_s: left as f64 * per_s,
    })
}

/// What a progress line is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoteKind {
    /// Where the run is (for a terminal).
    Progress,
    /// Something the user should know (also in the acquisition log's note column).
    Warning,
}

/// Runs the protocol at `protocol_path` into the session folder `session`; `stop` is
/// polled (set it from a Ctrl-C handler), `note` receives progress lines and warnings.
///
/// Errors before anything was recorded (bad protocol, no regulator, no camera) are
/// returned as `Err` after venting; a run stopped later returns `Ok` with
/// [`AcquireOutcome::stopped`] set.
pub fn acquire(
    protocol_path: &Path,
    session: &Path,
    stop: &AtomicBool,
    note: &mut dyn FnMut(NoteKind, &str),
) -> Result<AcquireOutcome, AcquireError> {
    let protocol = Protocol::read(protocol_path)?;
    let text = std::fs::read_to_string(protocol_path).map_err(|e| AcquireError::Protocol {
        path: protocol_path.to_path_buf(),
        why: format!("cannot read: {e}"),
    })?;
    std::fs::create_dir_all(session).map_err(|e| AcquireError::Session {
        path: session.to_path_buf(),
        why: format!("cannot create the folder: {e}"),
    })?;
    let rows = session::prepare(session, &protocol, &text)?;
    // Before any device: a recorder an earlier, killed run left running must not write
    // into the session beside this run's.
    if let CameraConfig::Webcam(_) = &protocol.camera {
        if let Some(pid) = webcam::stop_earlier_recorder(session)? {
            note(
                NoteKind::Warning,
                &format!("an earlier run's recorder (ffmpeg, pid {pid}) was still writing into the session: stopped it; its unfinished recording is recorded again"),
            );
        }
    }
    let mut regulator = SerialRegulator::open(&protocol.regulator)?;
    note(
        NoteKind::Progress,
        &format!(
            "regulator on {}: {:.2} kPa",
            protocol.regulator.port,
            regulator.get_kpa()?
        ),
    );
    let mut camera: Box<dyn Camera> = match &protocol.camera {
        CameraConfig::GoPro { url, timeout_s } => Box::new(GoPro::new(url, *timeout_s)),
        CameraConfig::GoProWifi(w) => Box::new(GoProWifi::new(w)),
        CameraConfig::Webcam(w) => Box::new(Webcam::new(w, session)),
    };
    // A run killed while recording leaves the camera recording: stop that recording
    // before this run's first, which the camera would refuse as busy.
    match camera.connect().and_then(|()| camera.stop_leftover_recording()) {
        Ok(true) => note(
            NoteKind::Warning,
            &format!(
                "{} was recording (an earlier run killed before it stopped?): stopped that recording; it stays on the camera, outside the session",
                camera.describe()
            ),
        ),
        Ok(false) => {}
        Err(e) => {
            let _ = regulator.set_kpa(0.0);
            return Err(e);
        }
    }
    note(
        NoteKind::Progress,
        &format!("camera: {}", camera.describe()),
    );
    let mut run = Run {
        session,
        plan: &protocol.plan,
        regulator: &mut regulator,
        camera: camera.as_mut(),
        stop,
        note,
        rows,
        recorded: 0,
        last_keep_alive: Instant::now(),
        last_regulator: Instant::now(),
    };
    let result = match &protocol.plan {
        Plan::Steps(s) => run.steps(s),
        Plan::Ramp(r) => run.ramp(r),
    };
    let vent_at_end = match &protocol.plan {
        Plan::Steps(s) => s.vent_at_end,
        Plan::Ramp(r) => r.vent_at_end,
    };
    let (stopped, vented, vent_failed) = match result {
        Ok(()) if !vent_at_end => (None, false, None),
        Ok(()) => match run.regulator.set_kpa(0.0) {
            Ok(_) => (None, true, None),
            Err(e) => (Some(e), false, None),
        },
        Err(e) => {
            // Vent first: the actuator must not stay pressurised.
            let vent = run.regulator.set_kpa(0.0);
            run.camera.abort();
            match vent {
                Ok(_) => (Some(e), true, None),
                Err(v) => (Some(e), false, Some(v)),
            }
        }
    };
    let in_session = run.rows.iter().filter(|r| r.is_ok()).count();
    let planned = match &protocol.plan {
        Plan::Steps(s) => s.set_points().len(),
        Plan::Ramp(_) => 1,
    };
    Ok(AcquireOutcome {
        recorded: run.recorded,
        in_session,
        planned,
        stopped,
        vented,
        vent_failed,
    })
}

/// The state of one run.
struct Run<'a> {
    session: &'a Path,
    plan: &'a Plan,
    regulator: &'a mut SerialRegulator,
    camera: &'a mut dyn Camera,
    stop: &'a AtomicBool,
    note: &'a mut dyn FnMut(NoteKind, &str),
    rows: Vec<LogRow>,
    recorded: usize,
    last_keep_alive: Instant,
    last_regulator: Instant,
}

impl Run<'_> {
    fn check_stop(&self) -> Result<(), AcquireError> {
        if self.stop.load(Ordering::SeqCst) {
            Err(AcquireError::Interrupted)
        } else {
            Ok(())
        }
    }

    /// Keeps the camera awake every [`camera::KEEP_ALIVE_S`].
    fn keep_alive(&mut self) -> Result<(), AcquireError> {
        if self.last_keep_alive.elapsed().as_secs_f64() >= camera::KEEP_ALIVE_S {
            self.camera.keep_alive()?;
            self.last_keep_alive = Instant::now();
        }
        if self.last_regulator.elapsed().as_secs_f64() >= REGULATOR_KEEP_ALIVE_S {
            self.regulator.get_kpa()?;
            self.last_regulator = Instant::now();
        }
        Ok(())
    }

    /// Sleeps until `until`, watching the stop flag and keeping the camera awake.
    fn wait_until(&mut self, until: Instant) -> Result<(), AcquireError> {
        loop {
            self.check_stop()?;
            self.keep_alive()?;
            let now = Instant::now();
            if now >= until {
                return Ok(());
            }
            std::thread::sleep((until - now).min(WAIT_SLICE));
        }
    }

    fn save(&mut self) -> Result<(), AcquireError> {
        session::write_log(self.session, &self.rows, self.plan)
    }

    /// Fetches the files of `row` (index into rows) into the session; the row's status
    /// tells the outcome, which is saved either way.
    fn fetch(&mut self, index: usize) -> Result<(), AcquireError> {
        let row = self.rows[index].clone();
        let taken: Vec<&String> = self
            .rows
            .iter()
            .enumerate()
            .filter(|(i, r)| *i != index && r.is_ok())
            .flat_map(|(_, r)| r.files.iter())
            .collect();
        let mut result = Ok(());
        for (name, source) in row.files.iter().zip(&row.camera_files) {
            if taken.iter().any(|t| t.eq_ignore_ascii_case(name)) {
                result = Err(AcquireError::NameTaken { file: name.clone() });
                break;
            }
            let file = CameraFile {
                source: source.clone(),
                name: name.clone(),
                size: None,
            };
            (self.note)(NoteKind::Progress, &format!("fetching {name}"));
            if let Err(e) = self.camera.fetch(&file, &self.session.join(name)) {
                result = Err(e);
                break;
            }
        }
        self.rows[index].status = match &result {
            Ok(()) => STATUS_OK.to_string(),
            Err(e) => format!("{STATUS_NOT_DOWNLOADED}: {e}"),
        };
        if result.is_ok() {
            self.recorded += 1;
        }
        self.save()?;
        result
    }

    /// Recordings the log calls done whose files are missing or not playable (a
    /// recorder an earlier run left writing over them): their rows are dropped, so their
    /// set points are recorded again, and an unplayable file is moved aside
    /// ([`session::unplayable_name`]).
    fn drop_unplayable(&mut self) -> Result<(), AcquireError> {
        let mut dropped = false;
        let mut i = 0;
        while i < self.rows.len() {
            let row = &self.rows[i];
            let bad = if row.is_ok() {
                row.files.iter().find_map(|f| {
                    let path = self.session.join(f);
                    session::playable_video(&path)
                        .err()
                        .map(|why| (f.clone(), path, why))
                })
            } else {
                None
            };
            let Some((file, path, why)) = bad else {
                i += 1;
                continue;
            };
            let step = row.step;
            let aside = session::unplayable_name(&file);
            let kept = if !path.exists() {
                "missing".to_string()
            } else if std::fs::rename(&path, self.session.join(&aside)).is_ok() {
                format!("moved aside as {aside}")
            } else {
                "left in place".to_string()
            };
            (self.note)(
                NoteKind::Warning,
                &format!(
                    "step {step}: {file} is not a playable recording ({why}): {kept}; the set point is recorded again"
                ),
            );
            self.rows.remove(i);
            dropped = true;
        }
        if dropped {
            self.save()?;
        }
        Ok(())
    }

    /// Fetches recordings an earlier run left on the camera.
    fn fetch_pending(&mut self) -> Result<(), AcquireError> {
        for i in 0..self.rows.len() {
            if !self.rows[i].is_ok() {
                (self.note)(
                    NoteKind::Progress,
                    &format!(
                        "step {}: fetching the recording an earlier run left on the camera",
                        self.rows[i].step
                    ),
                );
                self.fetch(i)?;
            }
        }
        Ok(())
    }

    fn steps(&mut self, plan: &StepPlan) -> Result<(), AcquireError> {
        self.drop_unplayable()?;
        self.fetch_pending()?;
        let todo: Vec<SetPoint> = plan
            .set_points()
            .into_iter()
            .filter(|sp| !self.rows.iter().any(|r| r.step == sp.step))
            .collect();
        let total = plan.set_points().len();
        if todo.len() < total {
            (self.note)(
                NoteKind::Progress,
                &format!(
                    "resuming: {} of {total} recordings already in the session",
                    total - todo.len()
                ),
            );
        }
        for sp in todo {
            self.check_stop()?;
            (self.note)(
                NoteKind::Progress,
                &format!("step {}/{total}: {:.2} kPa", sp.step, sp.pressure_kpa),
            );
            self.regulator.set_kpa(sp.pressure_kpa)?;
            let settle = Instant::now() + Duration::from_secs_f64(plan.stabilize_s);
            self.wait_until(settle)?;
            let name = format!("webcam_{:03}.mp4", sp.step);
            self.camera.start(&name)?;
            let started = Instant::now();
            let period = Duration::from_secs_f64(1.0 / plan.sample_hz);
            let end = started + Duration::from_secs_f64(plan.record_s);
            let mut readings = Vec::new();
            let mut next = started;
            while Instant::now() < end {
                readings.push(self.regulator.get_kpa()?);
                next += period;
                self.wait_until(next.min(end))?;
            }
            let files = self.camera.stop()?;
            let record_s = started.elapsed().as_secs_f64();
            let measured = PressureStats::from_readings(&readings);
            let off = (measured.mean_kpa - sp.pressure_kpa).abs();
            let note = if off > SET_POINT_WARN_KPA.max(SET_POINT_WARN_SHARE * sp.pressure_kpa) {
                let n = format!(
                    "measured {:.2} kPa, {off:.2} kPa from the set point: a longer stabilize_s, or check the supply",
                    measured.mean_kpa
                );
                (self.note)(NoteKind::Warning, &format!("step {}: {n}", sp.step));
                n
            } else {
                String::new()
            };
            // In step order (a set point recorded again comes back to its place).
            let index = self.rows.partition_point(|r| r.step < sp.step);
            self.rows.insert(
                index,
                LogRow {
                    step: sp.step,
                    repeat: sp.repeat,
                    set_kpa: sp.pressure_kpa,
                    files: files.iter().map(|f| f.name.clone()).collect(),
                    camera_files: files.iter().map(|f| f.source.clone()).collect(),
                    measured,
                    record_s,
                    status: format!("{STATUS_NOT_DOWNLOADED}: not fetched yet"),
                    note,
                },
            );
            self.fetch(index)?;
        }
        Ok(())
    }

    fn ramp(&mut self, plan: &RampPlan) -> Result<(), AcquireError> {
        self.drop_unplayable()?;
        if let Some(row) = self.rows.first() {
            if row.is_ok() {
                (self.note)(NoteKind::Progress, "the ramp is already recorded: nothing to do (acquire into a new folder for another)");
                return Ok(());
            }
            return self.fetch_pending();
        }
        (self.note)(
            NoteKind::Progress,
            &format!(
                "ramp {:.2} -> {:.2} kPa at {} kPa/s",
                plan.start_kpa, plan.top_kpa, plan.rate_kpa_s
            ),
        );
        self.regulator.set_kpa(plan.start_kpa)?;
        self.wait_until(Instant::now() + Duration::from_secs_f64(plan.stabilize_s))?;
        self.camera.start("webcam_ramp.mp4")?;
        let started = Instant::now();
        let period = Duration::from_secs_f64(1.0 / plan.log_hz);
        let mut samples: Vec<RampSample> = Vec::new();
        let mut next = started;
        let interrupted = loop {
            let t = started.elapsed().as_secs_f64();
            let set = (plan.start_kpa + plan.rate_kpa_s * t).min(plan.top_kpa);
            let step = self
                .regulator
                .set_kpa(set)
                .and_then(|_| self.regulator.get_kpa());
            let p = match step {
                Ok(p) => p,
                Err(e) => break Some(e),
            };
            samples.push(RampSample {
                time_s: started.elapsed().as_secs_f64(),
                pressure_kpa: p,
                set_kpa: set,
            });
            if set >= plan.top_kpa {
                break None;
            }
            next += period;
            if let Err(e) = self.wait_until(next) {
                break Some(e);
            }
        };
        // What was recorded is kept, also when the ramp was cut short: vent, then stop.
        if interrupted.is_some() {
            let _ = self.regulator.set_kpa(0.0);
        }
        let files = self.camera.stop()?;
        let measured = PressureStats::from_readings(
            &samples.iter().map(|s| s.pressure_kpa).collect::<Vec<_>>(),
        );
        session::write_pressure_log(self.session, &samples)?;
        let top = samples.last().map(|s| s.set_kpa).unwrap_or(plan.start_kpa);
        self.rows.push(LogRow {
            step: 1,
            repeat: 1,
            set_kpa: plan.top_kpa,
            files: files.iter().map(|f| f.name.clone()).collect(),
            camera_files: files.iter().map(|f| f.source.clone()).collect(),
            measured,
            record_s: started.elapsed().as_secs_f64(),
            status: format!("{STATUS_NOT_DOWNLOADED}: not fetched yet"),
            note: match &interrupted {
                Some(e) => format!("ramp stopped at {top:.2} kPa: {e}"),
                None => String::new(),
            },
        });
        self.fetch(0)?;
        match interrupted {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}
