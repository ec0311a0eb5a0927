//! The cameras: a GoPro driven through the Open GoPro HTTP API over USB or WiFi, or a UVC
//! (V4L2) webcam recorded by the `ffmpeg` program (a HERO5-HERO8 through the older WiFi
//! API: [`super::gopro_wifi`]). All sit behind [`Camera`]: start a recording, keep the
//! camera awake, stop, then fetch the files of that recording into the session folder.
//!
//! # GoPro (Open GoPro HTTP API 2.0, wired USB or WiFi)
//!
//! Over USB the camera appears as a USB network interface; its API listens on
//! `http://172.2X.1YZ.51:8080`, where X, Y and Z are the last three digits of its serial
//! number. Over WiFi (its access point on, the host on its network) the same API listens
//! on `http://10.5.5.9:8080`; the wired-USB control request is then not sent (it is for
//! USB). Requests used: `GET /gopro/camera/control/wired_usb?p=1` (take control over USB),
//! `/gopro/camera/keep_alive` (every few seconds), `/gopro/camera/shutter/start` and
//! `/stop`, `/gopro/media/list` (`{"media": [{"d": "100GOPRO", "fs": [{"n":
//! "GX010001.MP4", "s": "1234"}]}]}`) and `GET /videos/DCIM/<d>/<n>` to download. The
//! files of a recording are the videos that appear in the media list between before the
//! start and after the stop (a long recording comes as chapters GX01xxxx, GX02xxxx ...,
//! all of them fetched). A camera that answers 409 or 503 is busy (encoding, a menu
//! open): asked again until the request timeout, then refused with what to check. A
//! camera whose state (`GET /gopro/camera/state`, its `status` `"10"`: encoding) says it
//! is recording when a run begins (an earlier run was killed while recording) is stopped
//! first ([`Camera::stop_leftover_recording`]). HTTP
//! is `ureq` (plain http, no TLS: the camera's USB API is not encrypted).
//!
//! # Webcam
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

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use super::protocol::WebcamConfig;
use super::AcquireError;
use crate::session::{gopro_parts, VIDEO_EXTENSIONS};

/// Interval between keep-alive requests while waiting, s.
pub const KEEP_ALIVE_S: f64 = 3.0;
/// Interval between requests to a busy camera, or between media-list polls.
pub(super) const POLL: Duration = Duration::from_millis(200);
/// Wait for the files of a stopped recording to appear in the media list, s.
pub(super) const MEDIA_WAIT_S: f64 = 10.0;
/// Download attempts per file (a cut connection is tried again).
const DOWNLOAD_ATTEMPTS: u32 = 3;
/// Read size of a download, bytes.
const DOWNLOAD_BUFFER_BYTES: usize = 1 << 20;
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

/// A file of a finished recording, still on the camera (or in a temporary file).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CameraFile {
    /// Where the camera keeps it: `100GOPRO/GX010001.MP4`, or a temporary file's path.
    pub source: String,
    /// Its name in the session folder (the camera's name).
    pub name: String,
    /// Size in bytes, when the camera says.
    pub size: Option<u64>,
}

/// A camera that records on command.
pub trait Camera {
    /// What it is, for messages (`GoPro at http://...`).
    fn describe(&self) -> String;
    /// Takes control of the camera and checks it answers.
    fn connect(&mut self) -> Result<(), AcquireError>;
    /// Starts a recording; `name` is the file name to use when the camera names none.
    fn start(&mut self, name: &str) -> Result<(), AcquireError>;
    /// Keeps the camera awake during long waits.
    fn keep_alive(&mut self) -> Result<(), AcquireError>;
    /// Stops the recording; returns its files, in order (chapters in order).
    fn stop(&mut self) -> Result<Vec<CameraFile>, AcquireError>;
    /// Copies one file of a recording to `dest` (atomically); returns its size in bytes.
    fn fetch(&mut self, file: &CameraFile, dest: &Path) -> Result<u64, AcquireError>;
    /// Stops a recording the camera is making before this run starts one (a run killed
    /// before it stopped its own leaves the camera recording); returns whether it did.
    fn stop_leftover_recording(&mut self) -> Result<bool, AcquireError> {
        Ok(false)
    }
    /// Stops a recording after a failure, ignoring errors.
    fn abort(&mut self);
}

/// Key of the `status` object (Open GoPro's camera state and the HERO5-HERO8 status)
/// that says the camera is encoding, i.e. recording.
pub(super) const STATUS_ENCODING: &str = "10";

/// Whether a camera state (`{"status": {"10": 1, ...}}`) says the camera is recording;
/// None when the text says nothing readable about it.
pub fn is_encoding(state: &str) -> Option<bool> {
    let v: serde_json::Value = serde_json::from_str(state).ok()?;
    let encoding = v.get("status")?.get(STATUS_ENCODING)?;
    encoding
        .as_i64()
        .map(|n| n != 0)
        .or_else(|| encoding.as_bool())
}

/// A GoPro on its USB network link.
pub struct GoPro {
    url: String,
    timeout: Duration,
    agent: ureq::Agent,
    download_agent: ureq::Agent,
    before: Option<Vec<CameraFile>>,
}

impl GoPro {
    /// A GoPro at `url` (`http://172.2X.1YZ.51:8080`); `timeout_s` per request.
    pub fn new(url: &str, timeout_s: f64) -> GoPro {
        let timeout = Duration::from_secs_f64(timeout_s);
        let (agent, download_agent) = http_agents(timeout);
        GoPro {
            url: url.trim_end_matches('/').to_string(),
            timeout,
            agent,
            download_agent,
            before: None,
        }
    }

    fn camera_error(&self, why: String) -> AcquireError {
        AcquireError::Camera {
            camera: self.describe(),
            why,
        }
    }

    /// GET `path`; a busy camera (409, 503) is asked again until the timeout.
    fn get(&self, path: &str) -> Result<String, AcquireError> {
        let deadline = Instant::now() + self.timeout;
        loop {
            let mut resp = self
                .agent
                .get(format!("{}{path}", self.url))
                .call()
                .map_err(|e| self.camera_error(transport_error(&e, path)))?;
            let status = resp.status().as_u16();
            let body = resp.body_mut().read_to_string().unwrap_or_default();
            match status {
                200..=299 => return Ok(body),
                409 | 503 if Instant::now() < deadline => std::thread::sleep(POLL),
                409 | 503 => {
                    return Err(AcquireError::CameraBusy {
                        camera: self.describe(),
                        request: path.to_string(),
                        status,
                    })
                }
                _ => {
                    return Err(self.camera_error(format!(
                        "{path} answered HTTP {status} {}: check the camera's mode (video) and firmware (Open GoPro 2.0)",
                        body.trim().chars().take(120).collect::<String>()
                    )))
                }
            }
        }
    }

    /// The videos on the camera's card.
    fn media(&self) -> Result<Vec<CameraFile>, AcquireError> {
        let text = self.get("/gopro/media/list")?;
        parse_media_list(&text).map_err(|why| self.camera_error(why))
    }

    /// Whether the camera state says it is recording; None when the camera does not
    /// tell (no state request, an unreadable answer).
    fn encoding(&self) -> Option<bool> {
        self.get("/gopro/camera/state")
            .ok()
            .and_then(|text| is_encoding(&text))
    }
}

/// True for the address a GoPro has on its own WiFi network (`10.5.5.9`), where the
/// Open GoPro API needs no wired-USB control request.
pub fn is_wifi_address(url: &str) -> bool {
    let rest = url.strip_prefix("http://").unwrap_or(url);
    let authority = rest.split('/').next().unwrap_or(rest);
    authority.split(':').next() == Some(GOPRO_WIFI_HOST)
}

/// The camera's address on its own WiFi network (HERO5 and later).
pub const GOPRO_WIFI_HOST: &str = "10.5.5.9";

/// The HTTP agents of a camera: one for requests (`timeout` in all), one for downloads,
/// which take as long as they take (a stalled one times out per read).
pub(super) fn http_agents(timeout: Duration) -> (ureq::Agent, ureq::Agent) {
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .proxy(None)
        .http_status_as_error(false)
        .timeout_global(Some(timeout))
        .build()
        .into();
    let download_agent: ureq::Agent = ureq::Agent::config_builder()
        .proxy(None)
        .http_status_as_error(false)
        .timeout_connect(Some(timeout))
        .timeout_recv_response(Some(timeout))
        .timeout_per_read(Some(timeout))
        .build()
        .into();
    (agent, download_agent)
}

/// What a transport error means for the user.
fn transport_error(e: &ureq::Error, path: &str) -> String {
    match e {
        ureq::Error::ConnectionFailed | ureq::Error::HostNotFound => format!(
            "no answer to {path} ({e}): is the camera on, connected by USB, and the url its USB address (http://172.2X.1YZ.51:8080)? (over WiFi: join its network, url http://10.5.5.9:8080)"
        ),
        ureq::Error::Io(io) if io.kind() == std::io::ErrorKind::ConnectionRefused => format!(
            "connection refused on {path}: is the camera on, connected by USB, and the url its USB address (http://172.2X.1YZ.51:8080)? (over WiFi: join its network, url http://10.5.5.9:8080)"
        ),
        ureq::Error::Timeout(_) => format!("{path} timed out: the camera stopped answering (battery, cable?)"),
        _ => format!("{path} failed: {e} (the camera was lost: battery, cable?)"),
    }
}

/// The videos of an Open GoPro media list, in list order.
pub fn parse_media_list(text: &str) -> Result<Vec<CameraFile>, String> {
    let v: serde_json::Value = serde_json::from_str(text)
        .map_err(|e| format!("the media list is not JSON ({e}): is the url a GoPro's?"))?;
    let Some(dirs) = v.get("media").and_then(|m| m.as_array()) else {
        return Err("the media list has no \"media\" array: is the url a GoPro's?".into());
    };
    let mut out = Vec::new();
    for dir in dirs {
        let Some(d) = dir.get("d").and_then(|d| d.as_str()) else {
            continue;
        };
        for f in dir
            .get("fs")
            .and_then(|f| f.as_array())
            .into_iter()
            .flatten()
        {
            let Some(n) = f.get("n").and_then(|n| n.as_str()) else {
                continue;
            };
            let is_video = Path::new(n)
                .extension()
                .map(|e| {
                    VIDEO_EXTENSIONS.contains(&e.to_string_lossy().to_ascii_lowercase().as_str())
                })
                .unwrap_or(false);
            if !is_video || n.contains(['/', '\\']) || d.contains(['/', '\\']) {
                continue;
            }
            let size = match f.get("s") {
                Some(serde_json::Value::String(s)) => s.parse().ok(),
                Some(serde_json::Value::Number(n)) => n.as_u64(),
                _ => None,
            };
            out.push(CameraFile {
                source: format!("{d}/{n}"),
                name: n.to_string(),
                size,
            });
        }
    }
    Ok(out)
}

/// The files in `after` that are not in `before`, ordered by recording then chapter.
pub fn new_files(before: &[CameraFile], after: &[CameraFile]) -> Vec<CameraFile> {
    let mut new: Vec<CameraFile> = after
        .iter()
        .filter(|f| !before.iter().any(|b| b.source == f.source))
        .cloned()
        .collect();
    let key = |f: &CameraFile| match gopro_parts(&f.name) {
        Some((prefix, chapter, rec)) => (rec, prefix, chapter, f.name.clone()),
        None => (f.name.clone(), String::new(), 0, f.name.clone()),
    };
    new.sort_by_key(key);
    new
}

impl Camera for GoPro {
    fn describe(&self) -> String {
        format!("GoPro at {}", self.url)
    }

    fn connect(&mut self) -> Result<(), AcquireError> {
        if !is_wifi_address(&self.url) {
            self.get("/gopro/camera/control/wired_usb?p=1")?;
        }
        self.get("/gopro/camera/keep_alive")?;
        self.media()?;
        Ok(())
    }

    fn start(&mut self, _name: &str) -> Result<(), AcquireError> {
        self.before = Some(self.media()?);
        self.get("/gopro/camera/shutter/start")?;
        Ok(())
    }

    fn keep_alive(&mut self) -> Result<(), AcquireError> {
        self.get("/gopro/camera/keep_alive").map(|_| ())
    }

    fn stop(&mut self) -> Result<Vec<CameraFile>, AcquireError> {
        self.get("/gopro/camera/shutter/stop")?;
        let before = self.before.take().unwrap_or_default();
        recording_files(&before, || self.media(), |why| self.camera_error(why))
    }

    fn fetch(&mut self, file: &CameraFile, dest: &Path) -> Result<u64, AcquireError> {
        let file = with_listed_size(file, || self.media());
        fetch_with_retries(
            &self.download_agent,
            &self.url,
            &file,
            dest,
            transport_error,
        )
    }

    fn stop_leftover_recording(&mut self) -> Result<bool, AcquireError> {
        if self.encoding() != Some(true) {
            return Ok(false);
        }
        self.get("/gopro/camera/shutter/stop")?;
        let deadline = Instant::now() + Duration::from_secs_f64(MEDIA_WAIT_S);
        while self.encoding() == Some(true) {
            if Instant::now() >= deadline {
                return Err(self.camera_error(format!(
                    "the camera was recording before this run and kept recording {MEDIA_WAIT_S} s after /gopro/camera/shutter/stop: stop it on the camera"
                )));
            }
            std::thread::sleep(POLL);
        }
        Ok(true)
    }

    fn abort(&mut self) {
        let _ = self.get("/gopro/camera/shutter/stop");
        self.before = None;
    }
}

/// The files of a recording just stopped: the videos of `media()` not in `before`,
/// waited for up to [`MEDIA_WAIT_S`] (a camera lists a file once it is written), with
/// the chapters of a long recording, which may be listed a moment apart.
pub(super) fn recording_files(
    before: &[CameraFile],
    media: impl Fn() -> Result<Vec<CameraFile>, AcquireError>,
    error: impl Fn(String) -> AcquireError,
) -> Result<Vec<CameraFile>, AcquireError> {
    let deadline = Instant::now() + Duration::from_secs_f64(MEDIA_WAIT_S);
    loop {
        let new = new_files(before, &media()?);
        if !new.is_empty() {
            std::thread::sleep(POLL);
            return Ok(new_files(before, &media()?));
        }
        if Instant::now() >= deadline {
            return Err(error(format!(
                "no new video in the media list {MEDIA_WAIT_S} s after the recording stopped: is the camera in video mode with a card in?"
            )));
        }
        std::thread::sleep(POLL);
    }
}

/// `file` with its size as the camera's media list gives it, when `file` has none (a
/// recording named by the acquisition log, which keeps no sizes): what a download's
/// length is checked against. Unchanged when the list cannot be read or lacks it.
pub(super) fn with_listed_size(
    file: &CameraFile,
    media: impl Fn() -> Result<Vec<CameraFile>, AcquireError>,
) -> CameraFile {
    let size = file.size.or_else(|| {
        media()
            .ok()?
            .into_iter()
            .find(|f| f.source == file.source)?
            .size
    });
    CameraFile {
        size,
        ..file.clone()
    }
}

/// Downloads `GET <media_url>/videos/DCIM/<file.source>` into `dest` (atomically),
/// [`DOWNLOAD_ATTEMPTS`] times at most (a cut or short download is tried again);
/// `transport` says what a transport error means for this camera.
pub(super) fn fetch_with_retries(
    agent: &ureq::Agent,
    media_url: &str,
    file: &CameraFile,
    dest: &Path,
    transport: fn(&ureq::Error, &str) -> String,
) -> Result<u64, AcquireError> {
    let path = format!("/videos/DCIM/{}", file.source);
    let mut last = String::new();
    for _ in 0..DOWNLOAD_ATTEMPTS {
        match download_once(agent, media_url, &path, file, dest, transport) {
            Ok(n) => return Ok(n),
            Err(why) => last = why,
        }
    }
    Err(AcquireError::Download {
        file: file.name.clone(),
        why: format!(
            "{last} ({DOWNLOAD_ATTEMPTS} attempts; the recording stays on the camera's card: run acquire again to fetch it)"
        ),
    })
}

/// One download attempt; the reason when it fails (the partial file is removed). The
/// length is checked against the answer's Content-Length and the media list's size: a
/// file served short (the camera still writing it) is no recording.
fn download_once(
    agent: &ureq::Agent,
    media_url: &str,
    path: &str,
    file: &CameraFile,
    dest: &Path,
    transport: fn(&ureq::Error, &str) -> String,
) -> Result<u64, String> {
    let mut resp = agent
        .get(format!("{media_url}{path}"))
        .call()
        .map_err(|e| transport(&e, path))?;
    let status = resp.status().as_u16();
    if !(200..=299).contains(&status) {
        return Err(format!("{path} answered HTTP {status}"));
    }
    let announced: Option<u64> = resp
        .headers()
        .get("content-length")
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse().ok());
    let expected = announced.or(file.size);
    let mut reader = resp.body_mut().with_config().limit(u64::MAX).reader();
    let mut copied = 0u64;
    let of = expected.map(|n| format!(" of {n}")).unwrap_or_default();
    crate::io::write_atomic_with(dest, |f| {
        let mut buf = vec![0u8; DOWNLOAD_BUFFER_BYTES];
        loop {
            let n = match reader.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => {
                    return Err(std::io::Error::new(
                        e.kind(),
                        format!("the download was cut after {copied}{of} bytes ({e})"),
                    ))
                }
            };
            f.write_all(&buf[..n])?;
            copied += n as u64;
        }
        match (expected, file.size) {
            (Some(n), _) if n != copied => Err(std::io::Error::new(
                std::io::ErrorKind::UnexpectedEof,
                format!("the download was cut after {copied}{of} bytes"),
            )),
            (_, Some(n)) if n != copied => Err(std::io::Error::new(
                std::io::ErrorKind::UnexpectedEof,
                format!("{copied} bytes came, the media list says {n}"),
            )),
            _ => Ok(()),
        }
    })
    .map_err(|e| format!("{path}: {e}"))?;
    Ok(copied)
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
    fn the_media_list_diff_finds_a_recording_and_its_chapters_in_order() {
        let before = parse_media_list(
            r#"{"id":"1","media":[{"d":"100GOPRO","fs":[{"n":"GX010041.MP4","s":"10"},{"n":"GOPR0040.JPG","s":"5"}]}]}"#,
        )
        .unwrap();
        let after = parse_media_list(
            r#"{"id":"1","media":[{"d":"100GOPRO","fs":[{"n":"GX010041.MP4","s":"10"},{"n":"GOPR0040.JPG","s":"5"},
              {"n":"GX020042.MP4","s":"7"},{"n":"GX010042.MP4","s":8},{"n":"GL010042.LRV","s":"1"}]}]}"#,
        )
        .unwrap();
        assert_eq!(before.len(), 1, "photos are not videos");
        let new = new_files(&before, &after);
        let names: Vec<&str> = new.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["GX010042.MP4", "GX020042.MP4"]);
        assert_eq!(new[0].source, "100GOPRO/GX010042.MP4");
        assert_eq!((new[0].size, new[1].size), (Some(8), Some(7)));
        assert!(parse_media_list("{}").unwrap_err().contains("media"));
        assert!(parse_media_list("<html>").unwrap_err().contains("not JSON"));
    }

    #[test]
    fn the_camera_state_says_whether_it_records() {
        for (state, expected) in [
            (
                r#"{"status": {"8": 0, "10": 1}, "settings": {}}"#,
                Some(true),
            ),
            (r#"{"status": {"10": 0}}"#, Some(false)),
            (r#"{"status": {"10": true}}"#, Some(true)),
            (r#"{"status": {"8": 1}}"#, None),
            (r#"{}"#, None),
            ("not json", None),
        ] {
            assert_eq!(is_encoding(state), expected, "{state}");
        }
    }

    #[test]
    fn only_the_wifi_address_skips_the_wired_usb_request() {
        assert!(is_wifi_address("http://10.5.5.9:8080"));
        assert!(is_wifi_address("http://10.5.5.9"));
        assert!(!is_wifi_address("http://172.25.123.51:8080"));
        assert!(!is_wifi_address("http://10.5.5.90:8080"));
    }

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
