//! A GoPro HERO5-HERO8 through its legacy WiFi HTTP API, the one the published protocol's
//! HERO7 Silver spoke (through the Python `goprocam` library). The camera is the access
//! point: the host joins its WiFi network and finds it at `10.5.5.9`.
//!
//! # Requests (written by hand: GoPro never published this API; these are the requests
//! # of the community documentation `KonradIT/goprowifihack` that goprocam sends)
//!
//! - control, at `url` (default `http://10.5.5.9`): `GET /gp/gpControl/status` (keys of
//!   its `status` object: `"8"` busy, `"10"` encoding, i.e. recording, `"43"` mode, 0
//!   for video), `/gp/gpControl/command/mode?p=0` (video mode),
//!   `/gp/gpControl/command/shutter?p=1` (record) and `?p=0` (stop);
//! - media, at `media_url` (default `http://10.5.5.9:8080`): `GET /gp/gpMediaList` (the
//!   JSON of Open GoPro's media list, [`super::camera::parse_media_list`]) and
//!   `GET /videos/DCIM/<d>/<n>` to download (length checked, tried again).
//!
//! The files of a recording are the videos that appear in the media list between before
//! the shutter and after the recording stopped encoding: `GOPRnnnn.MP4` (then chapters
//! `GP01nnnn.MP4`, ...), or `GXccnnnn.MP4` (HEVC) / `GHccnnnn.MP4` on HERO6-8.
//!
//! A camera asleep answers nothing; given `wake_mac`, the wake-on-LAN magic packet (6
//! bytes 0xFF, then the MAC 16 times, by UDP to port `wake_port`, 9, of the camera's
//! address: what goprocam's `power_on` sends) is sent once a second until the camera
//! answers. The keep-alive is a status request (any request keeps the camera awake).

use std::net::{ToSocketAddrs, UdpSocket};
use std::path::Path;
use std::time::{Duration, Instant};

use super::camera::{
    fetch_with_retries, http_agents, parse_media_list, recording_files, with_listed_size, Camera,
    CameraFile, MEDIA_WAIT_S, POLL, STATUS_ENCODING,
};
use super::protocol::GoProWifiConfig;
use super::AcquireError;

/// Longest wait for a camera to answer after the first wake-on-LAN packet, s.
pub const WAKE_WAIT_S: f64 = 15.0;
/// Interval between wake-on-LAN packets while the camera sleeps.
const WAKE_RESEND: Duration = Duration::from_secs(1);
/// `status` key: the camera is busy (a menu, processing).
const STATUS_BUSY: &str = "8";
/// `status` key: the camera's mode (0 video, 1 photo, 2 multishot).
const STATUS_MODE: &str = "43";
/// What to do when the camera does not answer at all.
const JOIN_THE_NETWORK: &str = "join the camera's WiFi network (turn WiFi on in the camera's Connections menu; the network is named after the camera, e.g. GP25xxxxxx or \"HERO7 Silver\", its password under Camera Info) and check url (http://10.5.5.9); a camera asleep needs [camera] wake_mac";

/// What the camera's `status` object says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LegacyStatus {
    /// Busy (a menu open, processing).
    pub busy: bool,
    /// Encoding, i.e. recording.
    pub encoding: bool,
    /// The mode (0 video), when the camera says.
    pub mode: Option<i64>,
}

/// Reads the answer of `GET /gp/gpControl/status`.
pub fn parse_status(text: &str) -> Result<LegacyStatus, String> {
    let v: serde_json::Value = serde_json::from_str(text)
        .map_err(|e| format!("the status is not JSON ({e}): is the url a HERO5-HERO8's?"))?;
    let Some(status) = v.get("status").and_then(|s| s.as_object()) else {
        return Err(
            "the status has no \"status\" object: is the url a HERO5-HERO8's (a HERO9 or later: kind = \"gopro\")?"
                .into(),
        );
    };
    let int = |key: &str| status.get(key).and_then(serde_json::Value::as_i64);
    Ok(LegacyStatus {
        busy: int(STATUS_BUSY).unwrap_or(0) != 0,
        encoding: int(STATUS_ENCODING).unwrap_or(0) != 0,
        mode: int(STATUS_MODE),
    })
}

/// The wake-on-LAN magic packet of `mac`: 6 bytes 0xFF, then the MAC 16 times.
pub fn magic_packet(mac: [u8; 6]) -> [u8; 102] {
    let mut packet = [0xFFu8; 102];
    for chunk in packet[6..].chunks_exact_mut(6) {
        chunk.copy_from_slice(&mac);
    }
    packet
}

/// The host part of an `http://host[:port][/...]` URL.
fn url_host(url: &str) -> &str {
    let rest = url.strip_prefix("http://").unwrap_or(url);
    let authority = rest.split('/').next().unwrap_or(rest);
    match authority.rsplit_once(':') {
        Some((host, port)) if port.chars().all(|c| c.is_ascii_digit()) => host,
        _ => authority,
    }
}

/// What a transport error means for a camera on WiFi.
fn wifi_transport_error(e: &ureq::Error, path: &str) -> String {
    match e {
        ureq::Error::ConnectionFailed | ureq::Error::HostNotFound => {
            format!("no answer to {path} ({e}): {JOIN_THE_NETWORK}")
        }
        ureq::Error::Io(io) if io.kind() == std::io::ErrorKind::ConnectionRefused => {
            format!("connection refused on {path}: {JOIN_THE_NETWORK}")
        }
        ureq::Error::Timeout(_) => format!(
            "{path} timed out: the camera stopped answering (out of WiFi range, asleep, battery?)"
        ),
        _ => {
            format!("{path} failed: {e} (the camera was lost: out of WiFi range, asleep, battery?)")
        }
    }
}

/// A GoPro HERO5-HERO8 on its own WiFi network.
pub struct GoProWifi {
    cfg: GoProWifiConfig,
    timeout: Duration,
    agent: ureq::Agent,
    download_agent: ureq::Agent,
    before: Option<Vec<CameraFile>>,
    /// The camera answered once: until then every transport error means "not on its
    /// network" (or asleep).
    answered: bool,
}

impl GoProWifi {
    /// A camera at `cfg.url` (control) and `cfg.media_url` (media).
    pub fn new(cfg: &GoProWifiConfig) -> GoProWifi {
        let timeout = Duration::from_secs_f64(cfg.timeout_s);
        let (agent, download_agent) = http_agents(timeout);
        GoProWifi {
            cfg: cfg.clone(),
            timeout,
            agent,
            download_agent,
            before: None,
            answered: false,
        }
    }

    fn error(&self, why: String) -> AcquireError {
        AcquireError::Camera {
            camera: self.describe(),
            why,
        }
    }

    /// GET `base` + `path`; a busy camera (409, 503) is asked again until the timeout.
    fn get_at(&self, base: &str, path: &str) -> Result<String, AcquireError> {
        let deadline = Instant::now() + self.timeout;
        loop {
            let mut resp = self
                .agent
                .get(format!("{base}{path}"))
                .call()
                .map_err(|e| {
                    self.error(if self.answered {
                        wifi_transport_error(&e, path)
                    } else {
                        format!("no answer to {path} ({e}): {JOIN_THE_NETWORK}")
                    })
                })?;
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
                    return Err(self.error(format!(
                        "{path} answered HTTP {status} {}: is it a HERO5-HERO8 (a HERO9 or later: kind = \"gopro\")?",
                        body.trim().chars().take(120).collect::<String>()
                    )))
                }
            }
        }
    }

    /// A control request.
    fn get(&self, path: &str) -> Result<String, AcquireError> {
        self.get_at(&self.cfg.url, path)
    }

    /// The camera's status.
    fn status(&self) -> Result<LegacyStatus, AcquireError> {
        let text = self.get("/gp/gpControl/status")?;
        parse_status(&text).map_err(|why| self.error(why))
    }

    /// Polls the status until `ok` holds, for `wait`; `what` says what did not happen.
    fn wait_for(
        &self,
        wait: Duration,
        what: &str,
        ok: impl Fn(&LegacyStatus) -> bool,
    ) -> Result<LegacyStatus, AcquireError> {
        let deadline = Instant::now() + wait;
        loop {
            let s = self.status()?;
            if ok(&s) {
                return Ok(s);
            }
            if Instant::now() >= deadline {
                return Err(self.error(format!("{what} within {:.1} s", wait.as_secs_f64())));
            }
            std::thread::sleep(POLL);
        }
    }

    /// The videos on the camera's card.
    fn media(&self) -> Result<Vec<CameraFile>, AcquireError> {
        let text = self.get_at(&self.cfg.media_url, "/gp/gpMediaList")?;
        parse_media_list(&text).map_err(|why| self.error(why))
    }

    /// Sends the magic packet once a second until the camera answers a status request.
    fn wake(&self, mac: [u8; 6]) -> Result<(), AcquireError> {
        let host = url_host(&self.cfg.url);
        let mac_text = mac.map(|b| format!("{b:02X}")).join(":");
        let target = (host, self.cfg.wake_port)
            .to_socket_addrs()
            .ok()
            .and_then(|mut a| a.find(|a| a.is_ipv4()))
            .ok_or_else(|| {
                self.error(format!(
                    "cannot resolve {host} to send the wake-on-LAN packet: check url"
                ))
            })?;
        let socket = UdpSocket::bind("0.0.0.0:0")
            .and_then(|s| s.set_broadcast(true).map(|()| s))
            .map_err(|e| self.error(format!("cannot open a UDP socket for wake-on-LAN: {e}")))?;
        let packet = magic_packet(mac);
        let deadline = Instant::now() + Duration::from_secs_f64(WAKE_WAIT_S);
        let mut sent: Option<Instant> = None;
        loop {
            if sent.is_none_or(|t| t.elapsed() >= WAKE_RESEND) {
                socket.send_to(&packet, target).map_err(|e| {
                    self.error(format!(
                        "cannot send the wake-on-LAN packet to {target}: {e}: {JOIN_THE_NETWORK}"
                    ))
                })?;
                sent = Some(Instant::now());
            }
            if self.status().is_ok() {
                return Ok(());
            }
            if Instant::now() >= deadline {
                return Err(self.error(format!(
                    "no answer to /gp/gpControl/status {WAKE_WAIT_S} s after wake-on-LAN packets for {mac_text} to {target}: {JOIN_THE_NETWORK} (check wake_mac)"
                )));
            }
            std::thread::sleep(POLL);
        }
    }
}

impl Camera for GoProWifi {
    fn describe(&self) -> String {
        format!("GoPro (WiFi) at {}", self.cfg.url)
    }

    fn connect(&mut self) -> Result<(), AcquireError> {
        if let Some(mac) = self.cfg.wake_mac {
            self.wake(mac)?;
        }
        self.status()?;
        self.answered = true;
        self.get("/gp/gpControl/command/mode?p=0")?;
        self.wait_for(
            self.timeout,
            "the camera did not switch to video mode (mode?p=0)",
            |s| s.mode.is_none_or(|m| m == 0),
        )?;
        self.media()?;
        Ok(())
    }

    fn start(&mut self, _name: &str) -> Result<(), AcquireError> {
        self.before = Some(self.media()?);
        self.get("/gp/gpControl/command/shutter?p=1")?;
        self.wait_for(
            self.timeout,
            "the shutter started no recording (check that a card is in and not full, and the camera in video mode)",
            |s| s.encoding,
        )?;
        Ok(())
    }

    fn keep_alive(&mut self) -> Result<(), AcquireError> {
        self.status().map(|_| ())
    }

    fn stop(&mut self) -> Result<Vec<CameraFile>, AcquireError> {
        self.get("/gp/gpControl/command/shutter?p=0")?;
        self.wait_for(
            Duration::from_secs_f64(MEDIA_WAIT_S),
            "the camera did not finish the recording (still encoding or busy)",
            |s| !s.encoding && !s.busy,
        )?;
        let before = self.before.take().unwrap_or_default();
        recording_files(&before, || self.media(), |why| self.error(why))
    }

    fn fetch(&mut self, file: &CameraFile, dest: &Path) -> Result<u64, AcquireError> {
        let file = with_listed_size(file, || self.media());
        fetch_with_retries(
            &self.download_agent,
            &self.cfg.media_url,
            &file,
            dest,
            wifi_transport_error,
        )
    }

    fn stop_leftover_recording(&mut self) -> Result<bool, AcquireError> {
        if !self.status()?.encoding {
            return Ok(false);
        }
        self.get("/gp/gpControl/command/shutter?p=0")?;
        self.wait_for(
            Duration::from_secs_f64(MEDIA_WAIT_S),
            "the camera was recording before this run and did not stop (still encoding or busy): stop it on the camera",
            |s| !s.encoding && !s.busy,
        )?;
        Ok(true)
    }

    fn abort(&mut self) {
        let _ = self.get("/gp/gpControl/command/shutter?p=0");
        self.before = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_status_object_gives_busy_encoding_and_mode() {
        let s =
            parse_status(r#"{"status":{"1":1,"8":0,"10":1,"43":0},"settings":{"2":9}}"#).unwrap();
        assert_eq!(
            s,
            LegacyStatus {
                busy: false,
                encoding: true,
                mode: Some(0)
            }
        );
        let s = parse_status(r#"{"status":{"8":1}}"#).unwrap();
        assert!(s.busy && !s.encoding && s.mode.is_none());
        assert!(parse_status("{}").unwrap_err().contains("kind = \"gopro\""));
        assert!(parse_status("<html>").unwrap_err().contains("not JSON"));
    }

    #[test]
    fn the_magic_packet_is_six_ff_then_the_mac_sixteen_times() {
        let mac = [0xd8, 0x96, 0x85, 0x0a, 0xbc, 0x01];
        let p = magic_packet(mac);
        assert_eq!(&p[..6], &[0xFF; 6]);
        for k in 0..16 {
            assert_eq!(&p[6 + 6 * k..12 + 6 * k], &mac, "repetition {k}");
        }
        assert_eq!(url_host("http://10.5.5.9"), "10.5.5.9");
        assert_eq!(url_host("http://127.0.0.1:8080/x"), "127.0.0.1");
    }
}
