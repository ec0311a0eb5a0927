//! The webcam: a UVC (V4L2) device recorded by the `ffmpeg` program, behind
//! [`super::camera::Camera`].
//!
//! `ffmpeg -f v4l2 [-input_format F] [-video_size WxH] [-framerate R] -i DEVICE` encodes
//! H.264 (MP4) into a temporary file of the session folder while recording; stopping
//! sends `q` on its standard input (ffmpeg then finishes the file), and fetching renames
//! the file. `format` may name another FFmpeg input (`lavfi` for a test pattern: its
//! `size` and `fps` are applied to the output, since a filter graph takes no input size
//! or rate). A recording ffmpeg finishes without a decodable video stream is an error.
//!
//! ffmpeg dies with bendscope (`PR_SET_PDEATHSIG`, [`crate::child`]), also when
//! bendscope is killed with SIGKILL; and while it records, `SESSION/.recorder.pid` names
//! it (pid, start time, file), so that a later run stops a recorder an earlier one left
//! writing into the session before it records anything ([`stop_earlier_recorder`]).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use super::camera::{Camera, CameraFile, POLL};
use super::protocol::WebcamConfig;
use super::AcquireError;

/// Wait for ffmpeg to finish its file after `q`, s.
const FFMPEG_STOP_WAIT_S: f64 = 10.0;
/// Time ffmpeg is given to fail on a missing device before recording counts as started.
const FFMPEG_START_CHECK: Duration = Duration::from_millis(300);
/// The file in the session folder that names the recorder (ffmpeg) while it records.
pub const RECORDER_PID_FILE: &str = ".recorder.pid";
/// Longest wait for an earlier run's recorder to be gone once killed.
const EARLIER_RECORDER_STOP_WAIT: Duration = Duration::from_secs(2);

/// What `SESSION/.recorder.pid` says: which process records into which file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecorderRecord {
    /// Process id of the recorder.
    pub pid: u32,
    /// Its start time, clock ticks since boot ([`crate::child::process_start_ticks`]).
    pub start_ticks: u64,
    /// The file it writes, as given on its command line.
    pub file: String,
}

impl RecorderRecord {
    /// The file's text: `pid N`, `start_ticks N`, `file PATH`, one a line.
    pub fn to_text(&self) -> String {
        format!(
            "pid {}\nstart_ticks {}\nfile {}\n",
            self.pid, self.start_ticks, self.file
        )
    }

    /// Reads [`RecorderRecord::to_text`]'s text; `None` when it is not one.
    pub fn parse(text: &str) -> Option<RecorderRecord> {
        let value = |key: &str| {
            text.lines()
                .find_map(|l| l.strip_prefix(key)?.strip_prefix(' '))
                .map(str::to_string)
        };
        Some(RecorderRecord {
            pid: value("pid")?.trim().parse().ok()?,
            start_ticks: value("start_ticks")?.trim().parse().ok()?,
            file: value("file")?,
        })
    }

    /// True while that very process (same pid and start time) runs with `file` on its
    /// command line.
    pub fn is_running(&self) -> bool {
        crate::child::process_start_ticks(self.pid) == Some(self.start_ticks)
            && crate::child::process_command_line(self.pid).contains(&self.file)
    }
}

/// Stops a recorder that an earlier run left writing into `session` (an acquire killed
/// while recording, whose ffmpeg lived on): the process named by
/// [`RECORDER_PID_FILE`], when it still runs and writes there, is killed and its
/// unfinished file removed. Returns its pid when there was one. A recorder that cannot
/// be stopped is an error saying which.
pub fn stop_earlier_recorder(session: &Path) -> Result<Option<u32>, AcquireError> {
    let pid_file = session.join(RECORDER_PID_FILE);
    let Ok(text) = std::fs::read_to_string(&pid_file) else {
        return Ok(None);
    };
    let record = RecorderRecord::parse(&text);
    let mut stopped = None;
    if let Some(r) = record.as_ref().filter(|r| r.is_running()) {
        let who = format!(
            "an earlier run's recorder (pid {}) still writes {}",
            r.pid, r.file
        );
        let refuse = |why: String| AcquireError::Session {
            path: session.to_path_buf(),
            why: format!("{who} and {why}: stop it (kill {}) and run again", r.pid),
        };
        crate::child::send_signal(r.pid, libc::SIGKILL)
            .map_err(|e| refuse(format!("cannot be stopped ({e})")))?;
        let deadline = Instant::now() + EARLIER_RECORDER_STOP_WAIT;
        while r.is_running() {
            if Instant::now() >= deadline {
                return Err(refuse("did not stop when killed".into()));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        stopped = Some(r.pid);
    }
    if let Some(r) = &record {
        // Its file is unfinished (no index): never a recording of this session.
        if Path::new(&r.file).starts_with(session) {
            let _ = std::fs::remove_file(&r.file);
        }
    }
    let _ = std::fs::remove_file(&pid_file);
    Ok(stopped)
}

/// A webcam recorded through ffmpeg.
///
/// ffmpeg is spawned from the thread that calls [`Camera::start`] and dies when that
/// thread ends ([`crate::child::die_with_parent`]): record from a thread that lives as
/// long as the recording.
pub struct Webcam {
    cfg: WebcamConfig,
    session: PathBuf,
    child: Option<(Child, CameraFile, tempfile::NamedTempFile)>,
}

impl Webcam {
    /// A webcam whose recordings go to `session`.
    pub fn new(cfg: &WebcamConfig, session: &Path) -> Webcam {
        Webcam {
            cfg: cfg.clone(),
            session: session.to_path_buf(),
            child: None,
        }
    }

    fn error(&self, why: String) -> AcquireError {
        AcquireError::Camera {
            camera: self.describe(),
            why,
        }
    }

    /// The ffmpeg arguments that record into `out`.
    pub fn ffmpeg_args(&self, out: &Path) -> Vec<String> {
        let mut a: Vec<String> = ["-hide_banner", "-loglevel", "error", "-y", "-f"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        a.push(self.cfg.format.clone());
        if let Some(f) = &self.cfg.input_format {
            a.extend(["-input_format".into(), f.clone()]);
        }
        // A filter graph (lavfi) has no input size or rate options: its frames are
        // scaled and resampled on the output instead.
        let graph = self.cfg.format == "lavfi";
        let size = self.cfg.size.as_ref().map(|s| {
            let flag = if graph { "-s" } else { "-video_size" };
            [flag.to_string(), s.clone()]
        });
        let fps = self.cfg.fps.map(|r| {
            let flag = if graph { "-r" } else { "-framerate" };
            [flag.to_string(), format!("{r}")]
        });
        if !graph {
            a.extend(size.iter().chain(&fps).flatten().cloned());
        }
        a.extend(["-i".into(), self.cfg.device.clone()]);
        if graph {
            a.extend(size.iter().chain(&fps).flatten().cloned());
        }
        for s in [
            "-an",
            "-c:v",
            "libx264",
            "-preset",
            "veryfast",
            "-crf",
            "18",
            "-pix_fmt",
            "yuv420p",
            "-movflags",
            "+faststart",
            "-f",
            "mp4",
        ] {
            a.push(s.into());
        }
        a.push(out.to_string_lossy().into_owned());
        a
    }
}

fn last_line(log: &Path) -> String {
    std::fs::read_to_string(log)
        .unwrap_or_default()
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("no message")
        .trim()
        .to_string()
}

impl Camera for Webcam {
    fn describe(&self) -> String {
        format!("webcam {}", self.cfg.device)
    }

    fn connect(&mut self) -> Result<(), AcquireError> {
        let ok = Command::new(&self.cfg.ffmpeg)
            .arg("-version")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        if !ok {
            return Err(self.error(format!(
                "cannot run `{}`: install FFmpeg (apt-get install ffmpeg) or set [camera] ffmpeg",
                self.cfg.ffmpeg
            )));
        }
        if self.cfg.format == "v4l2" && !Path::new(&self.cfg.device).exists() {
            return Err(self.error(
                "no such device: plug the webcam in and check its name (ls /dev/video*)".into(),
            ));
        }
        Ok(())
    }

    fn start(&mut self, name: &str) -> Result<(), AcquireError> {
        let tmp = self.session.join(format!(".{name}.recording"));
        let log = tempfile::NamedTempFile::new()
            .map_err(|e| self.error(format!("cannot make a log file: {e}")))?;
        let stderr = log
            .reopen()
            .map_err(|e| self.error(format!("cannot make a log file: {e}")))?;
        let mut command = Command::new(&self.cfg.ffmpeg);
        command
            .args(self.ffmpeg_args(&tmp))
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(stderr);
        // Killed with bendscope (the spawning thread is acquire's, which waits for it).
        let mut child = crate::child::die_with_parent(&mut command, libc::SIGKILL)
            .spawn()
            .map_err(|e| self.error(format!("cannot run `{}`: {e}", self.cfg.ffmpeg)))?;
        let record = RecorderRecord {
            pid: child.id(),
            start_ticks: crate::child::process_start_ticks(child.id()).unwrap_or(0),
            file: tmp.to_string_lossy().into_owned(),
        };
        let pid_file = self.session.join(RECORDER_PID_FILE);
        if let Err(e) = crate::io::write_atomic(&pid_file, record.to_text().as_bytes()) {
            let _ = child.kill();
            let _ = child.wait();
            return Err(self.error(format!("cannot write {}: {e}", pid_file.display())));
        }
        std::thread::sleep(FFMPEG_START_CHECK);
        if let Ok(Some(status)) = child.try_wait() {
            let _ = std::fs::remove_file(&pid_file);
            return Err(self.error(format!(
                "ffmpeg stopped at once ({status}): {}",
                last_line(log.path())
            )));
        }
        let file = CameraFile {
            source: tmp.to_string_lossy().into_owned(),
            name: name.to_string(),
            size: None,
        };
        self.child = Some((child, file, log));
        Ok(())
    }

    fn keep_alive(&mut self) -> Result<(), AcquireError> {
        if let Some((child, _, log)) = &mut self.child {
            if let Ok(Some(status)) = child.try_wait() {
                let why = format!(
                    "ffmpeg stopped while recording ({status}): {}",
                    last_line(log.path())
                );
                self.child = None;
                self.forget_recorder();
                return Err(self.error(why));
            }
        }
        Ok(())
    }

    fn stop(&mut self) -> Result<Vec<CameraFile>, AcquireError> {
        let Some((mut child, file, log)) = self.child.take() else {
            return Err(self.error("stop without a recording".into()));
        };
        if let Some(mut stdin) = child.stdin.take() {
            let _ = stdin.write_all(b"q");
        }
        let deadline = Instant::now() + Duration::from_secs_f64(FFMPEG_STOP_WAIT_S);
        let status = loop {
            match child.try_wait() {
                Ok(Some(s)) => break Some(s),
                Ok(None) if Instant::now() < deadline => std::thread::sleep(POLL),
                _ => {
                    let _ = child.kill();
                    let _ = child.wait();
                    break None;
                }
            }
        };
        self.forget_recorder();
        let tmp = PathBuf::from(&file.source);
        let size = std::fs::metadata(&tmp).map(|m| m.len()).unwrap_or(0);
        let why = match status {
            Some(s) if s.success() && size > 0 => match super::session::playable_video(&tmp) {
                Ok(()) => {
                    return Ok(vec![CameraFile {
                        size: Some(size),
                        ..file
                    }])
                }
                Err(why) => format!("ffmpeg's recording is not playable: {why}"),
            },
            _ => format!(
                "ffmpeg did not finish the recording: {}",
                last_line(log.path())
            ),
        };
        let _ = std::fs::remove_file(&tmp);
        Err(self.error(why))
    }

    fn fetch(&mut self, file: &CameraFile, dest: &Path) -> Result<u64, AcquireError> {
        let size = std::fs::metadata(&file.source).map(|m| m.len());
        std::fs::rename(&file.source, dest)
            .and(size)
            .map_err(|e| AcquireError::Download {
                file: file.name.clone(),
                why: format!("cannot move the recording into the session: {e}"),
            })
    }

    fn abort(&mut self) {
        if let Some((mut child, file, _)) = self.child.take() {
            let _ = child.kill();
            let _ = child.wait();
            let _ = std::fs::remove_file(&file.source);
            self.forget_recorder();
        }
    }
}

impl Webcam {
    /// Removes [`RECORDER_PID_FILE`] once the recorder is gone.
    fn forget_recorder(&self) {
        let _ = std::fs::remove_file(self.session.join(RECORDER_PID_FILE));
    }
}

impl Drop for Webcam {
    fn drop(&mut self) {
        self.abort();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn webcam_arguments_name_the_device_and_format() {
        let cfg = WebcamConfig {
            device: "/dev/video2".into(),
            format: "v4l2".into(),
            size: Some("1280x720".into()),
            fps: Some(30.0),
            input_format: Some("mjpeg".into()),
            ffmpeg: "ffmpeg".into(),
        };
        let w = Webcam::new(&cfg, Path::new("s"));
        let a = w.ffmpeg_args(Path::new("s/x"));
        let s = a.join(" ");
        assert!(
            s.contains(
                "-f v4l2 -input_format mjpeg -video_size 1280x720 -framerate 30 -i /dev/video2"
            ),
            "{s}"
        );
        assert_eq!(a.last().map(String::as_str), Some("s/x"));
        // A filter graph takes no input size or rate: they go on the output.
        let lavfi = Webcam::new(
            &WebcamConfig {
                device: "testsrc".into(),
                format: "lavfi".into(),
                input_format: None,
                ..cfg
            },
            Path::new("s"),
        );
        let s = lavfi.ffmpeg_args(Path::new("s/x")).join(" ");
        assert!(
            s.contains("-f lavfi -i testsrc -s 1280x720 -r 30 -an"),
            "{s}"
        );
    }

    #[test]
    fn an_earlier_runs_recorder_writing_into_the_session_is_stopped_and_others_left_alone() {
        let d = tempfile::tempdir().unwrap();
        let file = d.path().join(".webcam_002.mp4.recording");
        let mut ffmpeg = Command::new("ffmpeg")
            .args(["-hide_banner", "-loglevel", "error", "-y", "-f", "lavfi"])
            .args(["-i", "testsrc=size=64x48:rate=10,realtime", "-f", "mp4"])
            .arg(&file)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let pid = ffmpeg.id();
        let record = RecorderRecord {
            pid,
            start_ticks: crate::child::process_start_ticks(pid).unwrap(),
            file: file.to_string_lossy().into_owned(),
        };
        let t = Instant::now();
        while !(record.is_running() && file.exists()) {
            assert!(
                t.elapsed() < Duration::from_secs(5),
                "ffmpeg does not record"
            );
            std::thread::sleep(Duration::from_millis(10));
        }
        assert_eq!(
            RecorderRecord::parse(&record.to_text()),
            Some(record.clone())
        );
        let pid_file = d.path().join(RECORDER_PID_FILE);
        std::fs::write(&pid_file, record.to_text()).unwrap();
        assert_eq!(stop_earlier_recorder(d.path()).unwrap(), Some(pid));
        assert!(!ffmpeg.wait().unwrap().success(), "killed");
        assert!(!file.exists() && !pid_file.exists());
        // A pid file whose process is another (a pid reused): not touched.
        let mut other = Command::new("sleep").arg("30").spawn().unwrap();
        let record = RecorderRecord {
            pid: other.id(),
            start_ticks: crate::child::process_start_ticks(other.id()).unwrap(),
            file: file.to_string_lossy().into_owned(),
        };
        std::fs::write(&pid_file, record.to_text()).unwrap();
        assert_eq!(stop_earlier_recorder(d.path()).unwrap(), None);
        assert!(other.try_wait().unwrap().is_none(), "left running");
        assert!(!pid_file.exists());
        let _ = other.kill();
        let _ = other.wait();
    }
}
