//! The cameras: a GoPro driven through the Open GoPro HTTP API over USB or WiFi (a
//! HERO5-HERO8 through the older WiFi API: [`super::gopro_wifi`]), or a UVC (V4L2) webcam
//! recorded by the `ffmpeg` program ([`super::webcam`]). All sit behind [`Camera`]: start
//! a recording, keep the camera awake, stop, then fetch the files of that recording into
//! the session folder.
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

use std::io::{Read, Write};
use std::path::Path;
use std::time::{Duration, Instant};

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
}
