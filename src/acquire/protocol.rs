//! The acquisition protocol: a TOML file naming the set points (or a ramp), the
//! regulator's serial port and the camera. Parsed once into a checked [`Protocol`].
//!
//! ```toml
//! [steps]                        # or [ramp] rate_kpa_s = 0.25, top_kpa = 15, log_hz = 20
//! pressures_kpa = [40, 55, 70]   # or pressures = "40:115:15" with unit = "kPa" | "bar" | "psi"
//! stabilize_s = 2.0              # wait after each set point before recording
//! record_s = 5.0
//! repeats = 1
//! vent_at_end = true
//! [regulator]
//! port = "/dev/ttyACM0"
//! baud = 115200
//! [camera]
//! kind = "gopro"                 # or "gopro-wifi" (HERO5-8), or "webcam" with device = "/dev/video0", size, fps
//! url = "http://172.2X.1YZ.51:8080"
//! ```

use std::path::Path;

use serde::Deserialize;

use super::AcquireError;
use crate::fem::params::parse_range;
use crate::session::{KPA_PER_BAR, KPA_PER_PSI};

/// The one `[regulator] kind` (the default): a device speaking the serial line protocol
/// (hardware/regulator/regulator.ino or hardware/pwm_valve/pwm_valve.ino).
pub const REGULATOR_KIND_SERIAL: &str = "serial";
/// The regulator sketch's baud rate (hardware/regulator/regulator.ino).
pub const DEFAULT_BAUD: u32 = 115_200;
/// Default wait for one answer of the regulator, s.
pub const DEFAULT_REGULATOR_TIMEOUT_S: f64 = 0.5;
/// Default number of times a command is sent again when no answer came.
pub const DEFAULT_RETRIES: u32 = 2;
/// Default wait for the regulator after opening its port, s: opening the port resets an
/// Arduino, whose boot loader takes about 1.5 s before the sketch answers.
pub const DEFAULT_BOOT_S: f64 = 3.0;
/// Default pressure sampling rate while recording (steps), Hz.
pub const DEFAULT_SAMPLE_HZ: f64 = 10.0;
/// Default pressure log rate of a ramp, Hz.
pub const DEFAULT_LOG_HZ: f64 = 20.0;
/// Default wait for one camera HTTP request, s.
pub const DEFAULT_CAMERA_TIMEOUT_S: f64 = 5.0;
/// Control API of a HERO5-HERO8 on its own WiFi network (the camera is the access point).
pub const DEFAULT_GOPRO_WIFI_URL: &str = "http://10.5.5.9";
/// Media server of a HERO5-HERO8 on its WiFi network (media list and downloads).
pub const DEFAULT_GOPRO_WIFI_MEDIA_URL: &str = "http://10.5.5.9:8080";
/// Port of a HERO5-HERO8's media server, on the host of its control API.
pub const GOPRO_WIFI_MEDIA_PORT: u16 = 8080;
/// UDP port of the wake-on-LAN magic packet (the discard port, as the cameras expect).
pub const DEFAULT_WAKE_PORT: u16 = 9;
/// Highest sampling or logging rate accepted, Hz (the serial line answers one `GET` in
/// about a millisecond; faster logging only repeats readings).
pub const MAX_RATE_HZ: f64 = 200.0;
/// Most set points a protocol may hold.
pub const MAX_SET_POINTS: usize = 10_000;
/// Highest set point without `[regulator] max_kpa`, kPa: the range of the pressure sensor
/// in the README's wiring (MPX5700DP, 0..700 kPa). A set point above it is refused as a
/// typo (a unit or a digit); give `max_kpa` for a bench that goes further.
pub const DEFAULT_MAX_KPA: f64 = 700.0;

/// A checked acquisition protocol.
#[derive(Debug, Clone, PartialEq)]
pub struct Protocol {
    /// What is recorded: steps or a ramp.
    pub plan: Plan,
    /// The pressure regulator.
    pub regulator: RegulatorConfig,
    /// The camera.
    pub camera: CameraConfig,
}

/// Steps (one video per set point) or a ramp (one video while the pressure rises).
#[derive(Debug, Clone, PartialEq)]
pub enum Plan {
    /// One video per set point: `pressures.csv`.
    Steps(StepPlan),
    /// One video while the pressure rises: `pressure_log.csv`.
    Ramp(RampPlan),
}

/// The step protocol.
#[derive(Debug, Clone, PartialEq)]
pub struct StepPlan {
    /// Set points of one pass, kPa, in order.
    pub pressures_kpa: Vec<f64>,
    /// Wait after each set point before recording, s.
    pub stabilize_s: f64,
    /// Length of each recording, s.
    pub record_s: f64,
    /// Passes over the set points (cycles: 40, 55, 70, 40, 55, 70 for two).
    pub repeats: u32,
    /// Vent to 0 kPa after the last recording.
    pub vent_at_end: bool,
    /// Pressure sampling rate while recording, Hz.
    pub sample_hz: f64,
}

/// One recording of the step protocol.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SetPoint {
    /// 1-based position in the whole run (what a rerun resumes from).
    pub step: u32,
    /// 1-based pass.
    pub repeat: u32,
    /// Set point, kPa.
    pub pressure_kpa: f64,
}

impl StepPlan {
    /// Every recording of the run, in order.
    pub fn set_points(&self) -> Vec<SetPoint> {
        let mut out = Vec::new();
        for repeat in 1..=self.repeats {
            for &p in &self.pressures_kpa {
                out.push(SetPoint {
                    step: out.len() as u32 + 1,
                    repeat,
                    pressure_kpa: p,
                });
            }
        }
        out
    }
}

/// The ramp protocol: from `start_kpa` to `top_kpa` at `rate_kpa_s`, the set point
/// updated and the pressure logged `log_hz` times a second while one video records.
#[derive(Debug, Clone, PartialEq)]
pub struct RampPlan {
    /// First set point, kPa.
    pub start_kpa: f64,
    /// Last set point, kPa.
    pub top_kpa: f64,
    /// Rate of rise, kPa/s.
    pub rate_kpa_s: f64,
    /// Set point updates and pressure readings per second.
    pub log_hz: f64,
    /// Wait at the start pressure before recording, s.
    pub stabilize_s: f64,
    /// Vent to 0 kPa after the recording.
    pub vent_at_end: bool,
}

impl RampPlan {
    /// Duration of the rise, s.
    pub fn duration_s(&self) -> f64 {
        (self.top_kpa - self.start_kpa) / self.rate_kpa_s
    }
}

/// The regulator's serial line.
#[derive(Debug, Clone, PartialEq)]
pub struct RegulatorConfig {
    /// Serial port (`/dev/ttyACM0`).
    pub port: String,
    /// Baud rate (the sketch: 115200, 8N1).
    pub baud: u32,
    /// Wait for one answer, s.
    pub timeout_s: f64,
    /// Times a command is sent again when no answer came.
    pub retries: u32,
    /// Wait for the first answer after opening the port, s.
    pub boot_s: f64,
    /// Highest set point allowed, kPa (a protocol asking more is refused), if given;
    /// else [`DEFAULT_MAX_KPA`] holds.
    pub max_kpa: Option<f64>,
}

/// The camera.
#[derive(Debug, Clone, PartialEq)]
pub enum CameraConfig {
    /// A GoPro through the Open GoPro HTTP API over USB.
    GoPro {
        /// Base URL, `http://172.2X.1YZ.51:8080`.
        url: String,
        /// Wait for one HTTP request, s.
        timeout_s: f64,
    },
    /// A GoPro HERO5-HERO8 through its legacy WiFi API (`/gp/gpControl/...`).
    GoProWifi(GoProWifiConfig),
    /// A UVC (V4L2) webcam recorded through the `ffmpeg` program.
    Webcam(WebcamConfig),
}

/// A HERO5-HERO8 on its own WiFi network, driven through the legacy HTTP API.
#[derive(Debug, Clone, PartialEq)]
pub struct GoProWifiConfig {
    /// Control API base URL ([`DEFAULT_GOPRO_WIFI_URL`]).
    pub url: String,
    /// Media server base URL ([`DEFAULT_GOPRO_WIFI_MEDIA_URL`]).
    pub media_url: String,
    /// Wait for one HTTP request, s.
    pub timeout_s: f64,
    /// The camera's MAC address, for the wake-on-LAN packet a sleeping camera needs.
    pub wake_mac: Option<[u8; 6]>,
    /// UDP port of the wake-on-LAN packet, sent to the host of `url`.
    pub wake_port: u16,
}

/// A webcam recorded by running `ffmpeg`.
#[derive(Debug, Clone, PartialEq)]
pub struct WebcamConfig {
    /// Input device (`/dev/video0`), or any input of `format`.
    pub device: String,
    /// FFmpeg input format (demuxer): `v4l2`.
    pub format: String,
    /// Frame size `WIDTHxHEIGHT`, if forced.
    pub size: Option<String>,
    /// Frame rate, if forced.
    pub fps: Option<f64>,
    /// Pixel format asked from the camera (`mjpeg`, `yuyv422`), if forced.
    pub input_format: Option<String>,
    /// The ffmpeg program.
    pub ffmpeg: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawProtocol {
    steps: Option<RawSteps>,
    ramp: Option<RawRamp>,
    regulator: RawRegulator,
    camera: RawCamera,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum RawPressures {
    Text(String),
    List(Vec<f64>),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSteps {
    pressures_kpa: Option<Vec<f64>>,
    pressures: Option<RawPressures>,
    unit: Option<String>,
    stabilize_s: f64,
    record_s: f64,
    #[serde(default = "one")]
    repeats: u32,
    #[serde(default = "yes")]
    vent_at_end: bool,
    sample_hz: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRamp {
    rate_kpa_s: f64,
    top_kpa: f64,
    #[serde(default)]
    start_kpa: f64,
    log_hz: Option<f64>,
    #[serde(default)]
    stabilize_s: f64,
    #[serde(default = "yes")]
    vent_at_end: bool,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRegulator {
    kind: Option<String>,
    port: String,
    baud: Option<u32>,
    timeout_s: Option<f64>,
    retries: Option<u32>,
    boot_s: Option<f64>,
    max_kpa: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    kind: String,
    url: Option<String>,
    media_url: Option<String>,
    wake_mac: Option<String>,
    wake_port: Option<u16>,
    timeout_s: Option<f64>,
    device: Option<String>,
    format: Option<String>,
    size: Option<String>,
    fps: Option<f64>,
    input_format: Option<String>,
    ffmpeg: Option<String>,
}

fn one() -> u32 {
    1
}
fn yes() -> bool {
    true
}

impl Protocol {
    /// Reads and checks a protocol file.
    pub fn read(path: &Path) -> Result<Protocol, AcquireError> {
        let text = std::fs::read_to_string(path).map_err(|e| AcquireError::Protocol {
            path: path.to_path_buf(),
            why: format!("cannot read: {e}"),
        })?;
        Protocol::parse(&text, path)
    }

    /// Parses and checks protocol text (`path` names it in messages).
    pub fn parse(text: &str, path: &Path) -> Result<Protocol, AcquireError> {
        let bad = |why: String| AcquireError::Protocol {
            path: path.to_path_buf(),
            why,
        };
        let raw: RawProtocol = toml::from_str(text).map_err(|e| {
            let at = e
                .span()
                .map(|s| {
                    format!(
                        " (line {})",
                        text[..s.start.min(text.len())].lines().count().max(1)
                    )
                })
                .unwrap_or_default();
            bad(format!("{}{at}", e.message().trim()))
        })?;
        let plan = match (raw.steps, raw.ramp) {
            (Some(s), None) => Plan::Steps(steps_plan(s).map_err(bad)?),
            (None, Some(r)) => Plan::Ramp(ramp_plan(r).map_err(bad)?),
            (Some(_), Some(_)) => {
                return Err(bad(
                    "both [steps] and [ramp]: keep the one this session records".into(),
                ))
            }
            (None, None) => return Err(bad(
                "no [steps] or [ramp] section: say what to record (see bendscope acquire --help)"
                    .into(),
            )),
        };
        let regulator = regulator_config(raw.regulator).map_err(bad)?;
        let camera = camera_config(raw.camera).map_err(bad)?;
        let top = match &plan {
            Plan::Steps(s) => s.pressures_kpa.iter().copied().fold(0.0, f64::max),
            Plan::Ramp(r) => r.top_kpa,
        };
        match regulator.max_kpa {
            Some(max) if top > max => {
                return Err(bad(format!(
                    "a set point of {top} kPa exceeds the regulator's max_kpa = {max}: lower the pressures"
                )));
            }
            None if top > DEFAULT_MAX_KPA => {
                return Err(bad(format!(
                    "a set point of {top} kPa exceeds {DEFAULT_MAX_KPA} kPa, the limit without [regulator] max_kpa (the sensor range of the wiring in docs/src/howto/rigs.md): lower the pressures (check their unit), or set [regulator] max_kpa to your bench's range"
                )));
            }
            _ => {}
        }
        Ok(Protocol {
            plan,
            regulator,
            camera,
        })
    }
}

fn positive(v: f64, what: &str) -> Result<f64, String> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{what} = {v}: give a positive number"))
    }
}

fn non_negative(v: f64, what: &str) -> Result<f64, String> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("{what} = {v}: give a number >= 0"))
    }
}

fn rate(v: Option<f64>, default: f64, what: &str) -> Result<f64, String> {
    let v = positive(v.unwrap_or(default), what)?;
    if v > MAX_RATE_HZ {
        return Err(format!("{what} = {v}: at most {MAX_RATE_HZ} Hz"));
    }
    Ok(v)
}

fn steps_plan(s: RawSteps) -> Result<StepPlan, String> {
    let pressures_kpa = match (s.pressures_kpa, s.pressures) {
        (Some(p), None) => {
            if s.unit.is_some() {
                return Err("unit goes with `pressures`; `pressures_kpa` is in kPa already".into());
            }
            p
        }
        (None, Some(p)) => {
            let to_kpa = match s.unit.as_deref().map(str::to_ascii_lowercase).as_deref() {
                None | Some("kpa") => 1.0,
                Some("bar") => KPA_PER_BAR,
                Some("psi") => KPA_PER_PSI,
                Some(u) => return Err(format!("unit = \"{u}\": use \"kPa\", \"bar\" or \"psi\"")),
            };
            let values = match p {
                RawPressures::List(v) => v,
                RawPressures::Text(t) => parse_range(&t, "pressures").map_err(|e| e.to_string())?,
            };
            values.into_iter().map(|v| v * to_kpa).collect()
        }
        (Some(_), Some(_)) => {
            return Err("both pressures_kpa and pressures: keep one".into());
        }
        (None, None) => {
            return Err(
                "[steps] needs pressures_kpa = [..] or pressures = \"start:stop:step\"".into(),
            )
        }
    };
    if pressures_kpa.is_empty() {
        return Err("no pressures: list at least one set point".into());
    }
    for &p in &pressures_kpa {
        non_negative(p, "a pressure (kPa)")?;
    }
    if s.repeats == 0 {
        return Err("repeats = 0: give at least 1".into());
    }
    if pressures_kpa.len() * s.repeats as usize > MAX_SET_POINTS {
        return Err(format!(
            "{} recordings: at most {MAX_SET_POINTS}",
            pressures_kpa.len() * s.repeats as usize
        ));
    }
    Ok(StepPlan {
        pressures_kpa,
        stabilize_s: non_negative(s.stabilize_s, "stabilize_s")?,
        record_s: positive(s.record_s, "record_s")?,
        repeats: s.repeats,
        vent_at_end: s.vent_at_end,
        sample_hz: rate(s.sample_hz, DEFAULT_SAMPLE_HZ, "sample_hz")?,
    })
}

fn ramp_plan(r: RawRamp) -> Result<RampPlan, String> {
    let plan = RampPlan {
        start_kpa: non_negative(r.start_kpa, "start_kpa")?,
        top_kpa: positive(r.top_kpa, "top_kpa")?,
        rate_kpa_s: positive(r.rate_kpa_s, "rate_kpa_s")?,
        log_hz: rate(r.log_hz, DEFAULT_LOG_HZ, "log_hz")?,
        stabilize_s: non_negative(r.stabilize_s, "stabilize_s")?,
        vent_at_end: r.vent_at_end,
    };
    if plan.top_kpa <= plan.start_kpa {
        return Err(format!(
            "top_kpa = {} is not above start_kpa = {}",
            plan.top_kpa, plan.start_kpa
        ));
    }
    Ok(plan)
}

fn regulator_config(r: RawRegulator) -> Result<RegulatorConfig, String> {
    // One kind: the serial line protocol, which both sketches speak (the proportional
    // regulator's, hardware/regulator, and the PWM valve's, hardware/pwm_valve).
    if let Some(kind) = r.kind.as_deref() {
        if !kind.eq_ignore_ascii_case(REGULATOR_KIND_SERIAL) {
            return Err(format!(
                "[regulator] kind = \"{kind}\": use \"serial\" (the SET/GET line protocol of hardware/regulator and hardware/pwm_valve, for a proportional regulator or a PWM solenoid valve alike)"
            ));
        }
    }
    if r.port.trim().is_empty() {
        return Err(
            "[regulator] port is empty: give the serial port, e.g. \"/dev/ttyACM0\"".into(),
        );
    }
    let baud = r.baud.unwrap_or(DEFAULT_BAUD);
    if baud == 0 {
        return Err("[regulator] baud = 0: the sketch uses 115200".into());
    }
    Ok(RegulatorConfig {
        port: r.port,
        baud,
        timeout_s: positive(
            r.timeout_s.unwrap_or(DEFAULT_REGULATOR_TIMEOUT_S),
            "[regulator] timeout_s",
        )?,
        retries: r.retries.unwrap_or(DEFAULT_RETRIES),
        boot_s: non_negative(r.boot_s.unwrap_or(DEFAULT_BOOT_S), "[regulator] boot_s")?,
        max_kpa: r
            .max_kpa
            .map(|m| positive(m, "[regulator] max_kpa"))
            .transpose()?,
    })
}

/// A MAC address `AA:BB:CC:DD:EE:FF` (or with `-`, or 12 hex digits).
pub fn parse_mac(text: &str) -> Result<[u8; 6], String> {
    let hex: String = text
        .trim()
        .chars()
        .filter(|c| !matches!(c, ':' | '-'))
        .collect();
    let bad = || {
        format!(
            "[camera] wake_mac = \"{text}\": give the camera's MAC address as AA:BB:CC:DD:EE:FF (the GoPro app or the camera's Connections menu shows it)"
        )
    };
    if hex.len() != 12 || !hex.chars().all(|c| c.is_ascii_hexdigit()) {
        return Err(bad());
    }
    let mut mac = [0u8; 6];
    for (i, byte) in mac.iter_mut().enumerate() {
        *byte = u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).map_err(|_| bad())?;
    }
    Ok(mac)
}

/// A plain `http://` URL without its trailing `/`.
fn http_url(url: &str, key: &str, example: &str) -> Result<String, String> {
    let url = url.trim_end_matches('/').to_string();
    if !url.starts_with("http://") {
        return Err(format!(
            "[camera] {key} = \"{url}\": the GoPro's API is plain http://, e.g. {example}"
        ));
    }
    Ok(url)
}

/// The media server beside the control API at `url` (an `http://` URL): the same host
/// on [`GOPRO_WIFI_MEDIA_PORT`], so that a `url` pointing elsewhere than the camera's
/// default address takes the media requests with it.
fn media_url_of(url: &str) -> String {
    let rest = url.strip_prefix("http://").unwrap_or(url);
    let authority = rest.split('/').next().unwrap_or(rest);
    let host = match authority.rfind([':', ']']) {
        // `host:port` (an IPv6 host is bracketed: `[::1]:80`).
        Some(i) if authority.as_bytes()[i] == b':' => &authority[..i],
        _ => authority,
    };
    format!("http://{host}:{GOPRO_WIFI_MEDIA_PORT}")
}

/// Refuses the webcam's keys in a GoPro's section.
fn no_webcam_keys(c: &RawCamera) -> Result<(), String> {
    for (key, set) in [
        ("device", c.device.is_some()),
        ("size", c.size.is_some()),
        ("fps", c.fps.is_some()),
        ("format", c.format.is_some()),
        ("input_format", c.input_format.is_some()),
        ("ffmpeg", c.ffmpeg.is_some()),
    ] {
        if set {
            return Err(format!(
                "[camera] {key} is for kind = \"webcam\", not a GoPro"
            ));
        }
    }
    Ok(())
}

fn camera_config(c: RawCamera) -> Result<CameraConfig, String> {
    let kind = c.kind.to_ascii_lowercase();
    if kind != "gopro-wifi" {
        for (key, set) in [
            ("media_url", c.media_url.is_some()),
            ("wake_mac", c.wake_mac.is_some()),
            ("wake_port", c.wake_port.is_some()),
        ] {
            if set {
                return Err(format!(
                    "[camera] {key} is for kind = \"gopro-wifi\" (HERO5-HERO8 over WiFi)"
                ));
            }
        }
    }
    match kind.as_str() {
        "gopro-wifi" => {
            no_webcam_keys(&c)?;
            let url = http_url(
                c.url.as_deref().unwrap_or(DEFAULT_GOPRO_WIFI_URL),
                "url",
                DEFAULT_GOPRO_WIFI_URL,
            )?;
            let media_url = match c.media_url.as_deref() {
                Some(m) => http_url(m, "media_url", DEFAULT_GOPRO_WIFI_MEDIA_URL)?,
                None => media_url_of(&url),
            };
            let wake_port = c.wake_port.unwrap_or(DEFAULT_WAKE_PORT);
            if wake_port == 0 {
                return Err(format!(
                    "[camera] wake_port = 0: give a UDP port (the cameras listen on {DEFAULT_WAKE_PORT})"
                ));
            }
            Ok(CameraConfig::GoProWifi(GoProWifiConfig {
                url,
                media_url,
                timeout_s: positive(
                    c.timeout_s.unwrap_or(DEFAULT_CAMERA_TIMEOUT_S),
                    "[camera] timeout_s",
                )?,
                wake_mac: c.wake_mac.as_deref().map(parse_mac).transpose()?,
                wake_port,
            }))
        }
        "gopro" => {
            no_webcam_keys(&c)?;
            let Some(url) = c.url else {
                return Err("[camera] kind = \"gopro\" needs url = \"http://172.2X.1YZ.51:8080\" over USB (X, Y, Z: the last three digits of the camera's serial number), or \"http://10.5.5.9:8080\" on the camera's WiFi network".into());
            };
            let url = http_url(&url, "url", "http://172.2X.1YZ.51:8080 (USB) or http://10.5.5.9:8080 (WiFi)")?;
            Ok(CameraConfig::GoPro {
                url,
                timeout_s: positive(
                    c.timeout_s.unwrap_or(DEFAULT_CAMERA_TIMEOUT_S),
                    "[camera] timeout_s",
                )?,
            })
        }
        "webcam" => {
            if c.url.is_some() {
                return Err(
                    "[camera] url is for kind = \"gopro\"; a webcam has device = \"/dev/video0\""
                        .into(),
                );
            }
            if let Some(size) = &c.size {
                let ok = size
                    .split_once('x')
                    .map(|(w, h)| w.parse::<u32>().is_ok() && h.parse::<u32>().is_ok())
                    .unwrap_or(false);
                if !ok {
                    return Err(format!(
                        "[camera] size = \"{size}\": give WIDTHxHEIGHT, e.g. \"1280x720\""
                    ));
                }
            }
            Ok(CameraConfig::Webcam(WebcamConfig {
                device: c.device.unwrap_or_else(|| "/dev/video0".into()),
                format: c.format.unwrap_or_else(|| "v4l2".into()),
                size: c.size,
                fps: c.fps.map(|f| positive(f, "[camera] fps")).transpose()?,
                input_format: c.input_format,
                ffmpeg: c.ffmpeg.unwrap_or_else(|| "ffmpeg".into()),
            }))
        }
        other => Err(format!(
            "[camera] kind = \"{other}\": use \"gopro\" (HERO9 and later, USB or WiFi), \"gopro-wifi\" (HERO5-HERO8 over WiFi) or \"webcam\""
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BASE: &str = "[regulator]\nport = \"/dev/ttyACM0\"\n[camera]\nkind = \"gopro\"\nurl = \"http://127.0.0.1:8080/\"\n";

    fn parse(steps: &str) -> Result<Protocol, AcquireError> {
        Protocol::parse(&format!("{steps}\n{BASE}"), Path::new("p.toml"))
    }

    #[test]
    fn ranges_units_and_repeats_become_set_points_in_kpa() {
        let p = parse("[steps]\npressures = \"0.4:0.7:0.15\"\nunit = \"bar\"\nstabilize_s = 0.5\nrecord_s = 1\nrepeats = 2").unwrap();
        let Plan::Steps(s) = &p.plan else { panic!() };
        let sp = s.set_points();
        let kpa: Vec<f64> = sp.iter().map(|s| s.pressure_kpa).collect();
        assert_eq!(sp.len(), 6);
        for (a, b) in kpa.iter().zip([40.0, 55.0, 70.0, 40.0, 55.0, 70.0]) {
            assert!((a - b).abs() < 1e-9, "{kpa:?}");
        }
        assert_eq!((sp[4].step, sp[4].repeat), (5, 2));
        assert_eq!(p.regulator.baud, DEFAULT_BAUD);
        assert_eq!(
            p.camera,
            CameraConfig::GoPro {
                url: "http://127.0.0.1:8080".into(),
                timeout_s: DEFAULT_CAMERA_TIMEOUT_S
            }
        );
        let psi =
            parse("[steps]\npressures = [1, 2]\nunit = \"psi\"\nstabilize_s = 0\nrecord_s = 1")
                .unwrap();
        let Plan::Steps(s) = &psi.plan else { panic!() };
        assert!((s.pressures_kpa[1] - 2.0 * KPA_PER_PSI).abs() < 1e-12);
    }

    #[test]
    fn bad_protocols_say_what_to_fix() {
        let cases = [
            (
                "[steps]\npressures_kpa = [40]\nstabilize_s = 1\nrecord_s = 0",
                "record_s = 0",
            ),
            (
                "[steps]\npressures_kpa = [-5]\nstabilize_s = 1\nrecord_s = 1",
                ">= 0",
            ),
            (
                "[steps]\npressures = \"40:10:5\"\nstabilize_s = 1\nrecord_s = 1",
                "start <= stop",
            ),
            (
                "[steps]\npressures = [1]\nunit = \"mmHg\"\nstabilize_s = 1\nrecord_s = 1",
                "\"kPa\", \"bar\" or \"psi\"",
            ),
            ("[steps]\nstabilize_s = 1\nrecord_s = 1", "pressures_kpa"),
            ("[ramp]\nrate_kpa_s = 0.5\ntop_kpa = 0", "top_kpa"),
            ("", "no [steps] or [ramp]"),
            (
                "[steps]\npressures_kpa = [40]\nstabilize_s = 1\nrecord_s = 1\nrecrod_s = 2",
                "recrod_s",
            ),
        ];
        for (text, needle) in cases {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.contains(needle), "{text}: {e}");
            assert!(e.starts_with("p.toml"), "{e}");
        }
        let no_url = Protocol::parse(
            "[ramp]\nrate_kpa_s = 1\ntop_kpa = 10\n[regulator]\nport = \"x\"\n[camera]\nkind = \"gopro\"",
            Path::new("p.toml"),
        )
        .unwrap_err()
        .to_string();
        assert!(no_url.contains("172.2X.1YZ.51"), "{no_url}");
        let too_high = Protocol::parse(
            "[ramp]\nrate_kpa_s = 1\ntop_kpa = 100\n[regulator]\nport = \"x\"\nmax_kpa = 80\n[camera]\nkind = \"webcam\"",
            Path::new("p.toml"),
        )
        .unwrap_err()
        .to_string();
        assert!(too_high.contains("max_kpa"), "{too_high}");
        // Without max_kpa, the default limit holds: 1e9 kPa is a typo, 700 kPa is not.
        let absurd = parse("[steps]\npressures_kpa = [40, 1e9]\nstabilize_s = 1\nrecord_s = 1")
            .unwrap_err()
            .to_string();
        assert!(
            absurd.contains("1000000000 kPa exceeds 700 kPa")
                && absurd.contains("[regulator] max_kpa"),
            "{absurd}"
        );
        assert!(parse("[steps]\npressures_kpa = [700]\nstabilize_s = 1\nrecord_s = 1").is_ok());
        let bar = parse("[steps]\npressures = [8]\nunit = \"bar\"\nstabilize_s = 1\nrecord_s = 1")
            .unwrap_err()
            .to_string();
        assert!(bar.contains("800 kPa exceeds 700 kPa"), "{bar}");
        let allowed = Protocol::parse(
            "[steps]\npressures_kpa = [900]\nstabilize_s = 1\nrecord_s = 1\n[regulator]\nport = \"x\"\nmax_kpa = 1000\n[camera]\nkind = \"webcam\"",
            Path::new("p.toml"),
        );
        assert!(allowed.is_ok(), "{allowed:?}");
    }

    #[test]
    fn a_gopro_wifi_media_url_follows_the_url_unless_given() {
        let media_url = |camera: &str| {
            let p = Protocol::parse(
                &format!("[ramp]\nrate_kpa_s = 1\ntop_kpa = 10\n[regulator]\nport = \"x\"\n[camera]\nkind = \"gopro-wifi\"\n{camera}"),
                Path::new("p.toml"),
            )
            .unwrap();
            let CameraConfig::GoProWifi(w) = p.camera else {
                panic!("{camera}: not gopro-wifi")
            };
            w.media_url
        };
        for (camera, expected) in [
            ("url = \"http://127.0.0.1:18432\"", "http://127.0.0.1:8080"),
            ("url = \"http://192.168.4.7/\"", "http://192.168.4.7:8080"),
            ("url = \"http://[::1]:18432\"", "http://[::1]:8080"),
            ("url = \"http://[::1]\"", "http://[::1]:8080"),
            ("", "http://10.5.5.9:8080"),
            (
                "url = \"http://127.0.0.1:18432\"\nmedia_url = \"http://127.0.0.1:9000\"",
                "http://127.0.0.1:9000",
            ),
        ] {
            assert_eq!(media_url(camera), expected, "{camera}");
        }
    }

    #[test]
    fn a_gopro_wifi_camera_has_the_legacy_addresses_and_a_checked_wake_mac() {
        let wifi = |camera: &str| {
            Protocol::parse(
                &format!("[ramp]\nrate_kpa_s = 1\ntop_kpa = 10\n[regulator]\nport = \"x\"\n[camera]\nkind = \"gopro-wifi\"\n{camera}"),
                Path::new("p.toml"),
            )
        };
        assert_eq!(
            wifi("").unwrap().camera,
            CameraConfig::GoProWifi(GoProWifiConfig {
                url: "http://10.5.5.9".into(),
                media_url: "http://10.5.5.9:8080".into(),
                timeout_s: DEFAULT_CAMERA_TIMEOUT_S,
                wake_mac: None,
                wake_port: 9,
            })
        );
        let p = wifi("url = \"http://127.0.0.1:1/\"\nmedia_url = \"http://127.0.0.1:2\"\nwake_mac = \"d8:96:85:0A:bc:01\"\nwake_port = 4000").unwrap();
        let CameraConfig::GoProWifi(w) = &p.camera else {
            panic!()
        };
        assert_eq!(
            (w.url.as_str(), w.media_url.as_str(), w.wake_port),
            ("http://127.0.0.1:1", "http://127.0.0.1:2", 4000)
        );
        assert_eq!(w.wake_mac, Some([0xd8, 0x96, 0x85, 0x0a, 0xbc, 0x01]));
        assert_eq!(
            parse_mac("D8-96-85-0A-BC-01"),
            Ok([0xd8, 0x96, 0x85, 0x0a, 0xbc, 0x01])
        );
        for (camera, needle) in [
            ("wake_mac = \"d8:96:85\"", "AA:BB:CC:DD:EE:FF"),
            ("wake_mac = \"zz:96:85:0a:bc:01\"", "wake_mac"),
            ("media_url = \"https://10.5.5.9\"", "plain http://"),
            ("device = \"/dev/video0\"", "not a GoPro"),
            ("wake_port = 0", "wake_port = 0"),
        ] {
            let e = wifi(camera).unwrap_err().to_string();
            assert!(e.contains(needle), "{camera}: {e}");
        }
        let e = Protocol::parse(
            "[ramp]\nrate_kpa_s = 1\ntop_kpa = 10\n[regulator]\nport = \"x\"\n[camera]\nkind = \"gopro\"\nurl = \"http://10.5.5.9:8080\"\nwake_mac = \"d8:96:85:0a:bc:01\"",
            Path::new("p.toml"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("wake_mac is for kind = \"gopro-wifi\""), "{e}");
        let e = Protocol::parse(
            "[ramp]\nrate_kpa_s = 1\ntop_kpa = 10\n[regulator]\nport = \"x\"\n[camera]\nkind = \"hero7\"",
            Path::new("p.toml"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("\"gopro-wifi\" (HERO5-HERO8 over WiFi)"), "{e}");
    }

    #[test]
    fn the_regulator_kind_is_serial_for_both_sketches() {
        let with_kind = |kind: &str| {
            Protocol::parse(
                &format!("[ramp]\nrate_kpa_s = 1\ntop_kpa = 10\n[regulator]\nkind = \"{kind}\"\nport = \"x\"\n[camera]\nkind = \"webcam\""),
                Path::new("p.toml"),
            )
        };
        assert!(with_kind("serial").is_ok());
        assert!(with_kind("Serial").is_ok());
        let e = with_kind("pwm").unwrap_err().to_string();
        assert!(
            e.contains("kind = \"pwm\"") && e.contains("hardware/pwm_valve"),
            "{e}"
        );
    }

    #[test]
    fn a_ramp_has_its_duration() {
        let p = Protocol::parse(
            "[ramp]\nrate_kpa_s = 0.25\ntop_kpa = 15\nlog_hz = 20\n[regulator]\nport = \"x\"\n[camera]\nkind = \"webcam\"\nsize = \"640x480\"\nfps = 30",
            Path::new("p.toml"),
        )
        .unwrap();
        let Plan::Ramp(r) = &p.plan else { panic!() };
        assert!((r.duration_s() - 60.0).abs() < 1e-12);
        let CameraConfig::Webcam(w) = &p.camera else {
            panic!()
        };
        assert_eq!(
            (w.device.as_str(), w.format.as_str()),
            ("/dev/video0", "v4l2")
        );
    }
}
