//! `bendscope acquire` against device simulators that speak the real protocols: a
//! pressure regulator on a pseudo-terminal pair made by socat (first-order pressure
//! response, the serial line protocol of hardware/regulator/regulator.ino), and a GoPro
//! HTTP server on 127.0.0.1 (the Open GoPro API, or the legacy WiFi API of HERO5-HERO8
//! with its control and media servers on two ports and wake-on-LAN by UDP) that "films"
//! the example session's videos: each recording is the example video whose pressure is
//! nearest the simulated regulator's at the shutter, so `process` on the acquired session
//! must give the example's radii.

mod common;

use std::fs;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream, UdpSocket};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use bendscope::render::session::SessionTruth;
use common::{col, copy_dir, fixture, read_csv, Run};

/// Time constant of the simulated regulator's first-order response, s.
const TAU_S: f64 = 0.02;
/// The example session's pressures, kPa (one video each).
const EXAMPLE_KPA: [f64; 5] = [20.0, 35.0, 50.0, 65.0, 80.0];
/// Accuracy `process` reaches on the example session (tests/process.rs).
const RADIUS_TOLERANCE: f64 = 0.005;

// ---------------------------------------------------------------- regulator simulator

#[derive(Debug, Clone, Copy, PartialEq)]
enum RegMode {
    /// Speaks the protocol.
    Normal,
    /// Answers `ERR over limit` to set points above this, kPa.
    ErrAbove(f64),
    /// Never answers (no sketch, or a dead board).
    Silent,
    /// Answers bytes that are no protocol (what a wrong baud rate gives).
    Garbage,
    /// The PWM valve sketch (hardware/pwm_valve/pwm_valve.ino) and its pneumatics: [`Valve`].
    Valve,
}

// The sketch's constants (hardware/pwm_valve/pwm_valve.ino).
/// PWM period, ms (20 Hz).
const VALVE_PERIOD_MS: u64 = 50;
/// Sensor reading interval, ms.
const VALVE_SAMPLE_MS: u64 = 2;
/// Supply pressure (feed-forward), kPa.
const SUPPLY_KPA: f64 = 200.0;
/// Proportional gain, %/kPa.
const VALVE_KP: f64 = 1.5;
/// Integral gain, %/(kPa s).
const VALVE_KI: f64 = 3.0;
// The simulated bench.
/// Fill time constant with the valve energised (supply -> actuator), s.
const TAU_FILL_S: f64 = 0.3;
/// Exhaust time constant with the valve released (actuator -> exhaust), s.
const TAU_EXHAUST_S: f64 = 0.3;
/// Leak time constant (fittings, the actuator's seal), s.
const TAU_LEAK_S: f64 = 10.0;
/// Standard deviation of one sensor reading, kPa (uniform noise).
const SENSOR_NOISE_KPA: f64 = 0.5;

/// A 3/2 solenoid valve pulsed at 20 Hz on an actuator, simulated in 1 ms steps (forward
/// Euler): energised, dp/dt = (SUPPLY - p) / TAU_FILL; released, dp/dt = -p / TAU_EXHAUST;
/// always a leak -p / TAU_LEAK. The sketch's loop runs on it: sensor readings every 2 ms
/// with noise, their mean over each period is what `GET` answers and what the PI
/// controller with feed-forward (the sketch's gains) acts on at the period's end.
#[derive(Debug)]
struct Valve {
    /// True pressure, kPa.
    p_kpa: f64,
    /// Simulated time, ms since `t0`.
    t_ms: u64,
    t0: Instant,
    set_kpa: f64,
    open_loop: bool,
    duty_pct: f64,
    integral_pct: f64,
    sum_kpa: f64,
    samples: u32,
    /// Mean sensor reading over the last period, kPa.
    period_mean_kpa: f64,
    /// Lowest and highest true pressure of the current period, kPa.
    period_min_kpa: f64,
    period_max_kpa: f64,
    /// Largest true ripple (max - min within a period) seen at a set point, kPa.
    max_ripple_kpa: f64,
    /// xorshift64 state of the sensor noise.
    rng: u64,
}

impl Valve {
    fn new() -> Valve {
        Valve {
            p_kpa: 0.0,
            t_ms: 0,
            t0: Instant::now(),
            set_kpa: 0.0,
            open_loop: false,
            duty_pct: 0.0,
            integral_pct: 0.0,
            sum_kpa: 0.0,
            samples: 0,
            period_mean_kpa: 0.0,
            period_min_kpa: 0.0,
            period_max_kpa: 0.0,
            max_ripple_kpa: 0.0,
            rng: 0x9E37_79B9_7F4A_7C15,
        }
    }

    /// A uniform noise sample with standard deviation SENSOR_NOISE_KPA.
    fn noise_kpa(&mut self) -> f64 {
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 7;
        self.rng ^= self.rng << 17;
        let u = (self.rng >> 11) as f64 / (1u64 << 53) as f64;
        (2.0 * u - 1.0) * SENSOR_NOISE_KPA * 3f64.sqrt()
    }

    /// Runs the bench up to the present.
    fn advance(&mut self) {
        let now_ms = self.t0.elapsed().as_millis() as u64;
        while self.t_ms < now_ms {
            // The share of this millisecond the valve is energised (the sketch's timer
            // PWM switches within a millisecond: 3125 steps a period).
            let phase = (self.t_ms % VALVE_PERIOD_MS) as f64;
            let on_ms = self.duty_pct / 100.0 * VALVE_PERIOD_MS as f64;
            let energised = (on_ms - phase).clamp(0.0, 1.0);
            let p = self.p_kpa;
            let flow =
                energised * (SUPPLY_KPA - p) / TAU_FILL_S - (1.0 - energised) * p / TAU_EXHAUST_S;
            self.p_kpa = p + (flow - p / TAU_LEAK_S) * 1e-3;
            self.period_min_kpa = self.period_min_kpa.min(self.p_kpa);
            self.period_max_kpa = self.period_max_kpa.max(self.p_kpa);
            if self.t_ms.is_multiple_of(VALVE_SAMPLE_MS) {
                let reading = (self.p_kpa + self.noise_kpa()).max(0.0);
                self.sum_kpa += reading;
                self.samples += 1;
            }
            self.t_ms += 1;
            if self.t_ms.is_multiple_of(VALVE_PERIOD_MS) {
                self.end_of_period();
            }
        }
    }

    /// The sketch's `endOfPeriod`: the period's mean, then the new duty.
    fn end_of_period(&mut self) {
        self.period_mean_kpa = self.sum_kpa / f64::from(self.samples.max(1));
        (self.sum_kpa, self.samples) = (0.0, 0);
        if self.set_kpa > 0.0 {
            let ripple = self.period_max_kpa - self.period_min_kpa;
            self.max_ripple_kpa = self.max_ripple_kpa.max(ripple);
        }
        (self.period_min_kpa, self.period_max_kpa) = (self.p_kpa, self.p_kpa);
        if self.open_loop {
            return;
        }
        if self.set_kpa <= 0.0 {
            self.integral_pct = 0.0;
            self.duty_pct = 0.0;
            return;
        }
        let e = self.set_kpa - self.period_mean_kpa;
        let ff_pct = 100.0 * self.set_kpa / SUPPLY_KPA;
        // Conditional integration: not while the duty is pinned and e pushes further.
        let raw = ff_pct + VALVE_KP * e + self.integral_pct;
        if (raw < 100.0 || e < 0.0) && (raw > 0.0 || e > 0.0) {
            self.integral_pct = (self.integral_pct + VALVE_KI * e * VALVE_PERIOD_MS as f64 / 1e3)
                .clamp(-100.0, 100.0);
        }
        self.duty_pct = (ff_pct + VALVE_KP * e + self.integral_pct).clamp(0.0, 100.0);
    }

    /// The sketch's answer to one line.
    fn answer(&mut self, line: &str) -> String {
        self.advance();
        if let Some(v) = line.strip_prefix("SET ") {
            let Ok(v) = v.trim().parse::<f64>() else {
                return "ERR SET needs a number in kPa".into();
            };
            if v == 0.0 {
                (self.set_kpa, self.open_loop) = (0.0, false);
                (self.integral_pct, self.duty_pct) = (0.0, 0.0);
            } else {
                if self.open_loop {
                    self.integral_pct = 0.0;
                }
                (self.set_kpa, self.open_loop) = (v, false);
            }
            format!("OK {v:.2}")
        } else if let Some(d) = line.strip_prefix("DUTY ") {
            match d.trim().parse::<f64>() {
                Ok(d) if (0.0..=100.0).contains(&d) => {
                    (self.open_loop, self.set_kpa, self.integral_pct) = (true, 0.0, 0.0);
                    self.duty_pct = d;
                    format!("OK DUTY {d:.1}")
                }
                _ => "ERR DUTY needs a percentage 0..100".into(),
            }
        } else if line == "GET" {
            format!("P {:.3}", self.period_mean_kpa)
        } else {
            "ERR unknown command (SET <kPa>, GET or DUTY <percent>)".into()
        }
    }
}

/// The simulated pneumatics: p(t) = target + (p0 - target) exp(-(t - t0) / tau).
#[derive(Debug)]
struct RegState {
    target_kpa: f64,
    p0_kpa: f64,
    t0: Instant,
    /// Every `SET` received, in order (refused ones too).
    sets: Vec<f64>,
    mode: RegMode,
    /// The valve bench, in mode Valve.
    valve: Valve,
}

impl RegState {
    fn new(mode: RegMode) -> Arc<Mutex<RegState>> {
        Arc::new(Mutex::new(RegState {
            target_kpa: 0.0,
            p0_kpa: 0.0,
            t0: Instant::now(),
            sets: vec![],
            mode,
            valve: Valve::new(),
        }))
    }
    /// The true pressure now.
    fn pressure_kpa(&mut self) -> f64 {
        if self.mode == RegMode::Valve {
            self.valve.advance();
            return self.valve.p_kpa;
        }
        let t = self.t0.elapsed().as_secs_f64();
        self.target_kpa + (self.p0_kpa - self.target_kpa) * (-t / TAU_S).exp()
    }
    /// The answer to one line.
    fn answer(&mut self, line: &str) -> Option<Vec<u8>> {
        match self.mode {
            RegMode::Silent => return None,
            RegMode::Garbage => return Some(b"\xf0\x8f\xaa\x13x\xfe\n".to_vec()),
            RegMode::Valve => {
                if let Some(v) = line
                    .strip_prefix("SET ")
                    .and_then(|v| v.trim().parse().ok())
                {
                    self.sets.push(v);
                }
                return Some(format!("{}\r\n", self.valve.answer(line)).into_bytes());
            }
            _ => {}
        }
        let text = if let Some(v) = line.strip_prefix("SET ") {
            let v: f64 = v.trim().parse().ok()?;
            self.sets.push(v);
            match self.mode {
                RegMode::ErrAbove(limit) if v > limit => format!("ERR over limit {limit:.2} kPa"),
                _ => {
                    self.p0_kpa = self.pressure_kpa();
                    self.t0 = Instant::now();
                    self.target_kpa = v;
                    format!("OK {v:.2}")
                }
            }
        } else if line == "GET" {
            format!("P {:.3}", self.pressure_kpa())
        } else {
            "ERR unknown command".into()
        };
        Some(format!("{text}\r\n").into_bytes())
    }
}

/// A regulator on one end of a socat pty pair; bendscope opens `port`, the other end.
struct RegSim {
    socat: Child,
    port: PathBuf,
}

impl RegSim {
    fn start(dir: &Path, state: &Arc<Mutex<RegState>>) -> RegSim {
        let (port, sim) = (dir.join("ttyREG"), dir.join("ttySIM"));
        let _ = fs::remove_file(&port);
        let _ = fs::remove_file(&sim);
        let socat = Command::new("socat")
            .arg(format!("pty,rawer,link={}", port.display()))
            .arg(format!("pty,rawer,link={}", sim.display()))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("socat runs (apt-get install socat)");
        let t = Instant::now();
        while !(port.exists() && sim.exists()) {
            assert!(t.elapsed() < Duration::from_secs(5), "socat made no ptys");
            thread::sleep(Duration::from_millis(10));
        }
        let dev = fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&sim)
            .unwrap();
        let mut out = dev.try_clone().unwrap();
        let state = Arc::clone(state);
        thread::spawn(move || {
            for line in BufReader::new(dev).split(b'\n') {
                let Ok(line) = line else { return };
                let line = String::from_utf8_lossy(&line).trim().to_string();
                let answer = state.lock().unwrap().answer(&line);
                if let Some(a) = answer {
                    if out.write_all(&a).is_err() {
                        return;
                    }
                }
            }
        });
        RegSim { socat, port }
    }
}

impl Drop for RegSim {
    fn drop(&mut self) {
        let _ = self.socat.kill();
        let _ = self.socat.wait();
    }
}

// ---------------------------------------------------------------- GoPro simulator

#[derive(Default)]
struct CamState {
    /// The card: (folder, name, bytes).
    media: Vec<(String, String, Arc<Vec<u8>>)>,
    /// Pressure at the shutter of the recording in progress.
    recording_kpa: Option<f64>,
    next_number: u32,
    /// Recording numbers that come as two chapters.
    chapters: Vec<u32>,
    /// Shutter start answers 409.
    busy: bool,
    /// File names whose download is cut halfway.
    cut: Vec<String>,
    /// After this many recordings the camera stops answering.
    lost_after: Option<usize>,
    recordings: usize,
    downloads: usize,
    /// The legacy WiFi API (HERO5-HERO8): GOPRnnnn/GP01nnnn names, `/gp/gpControl`.
    legacy: bool,
    /// Legacy mode: 0 video, 1 photo (a camera starts in photo mode).
    mode: i64,
    /// Legacy status "10": recording.
    encoding: bool,
    /// Asleep until a wake-on-LAN packet for this MAC comes: answers nothing.
    asleep: Option<[u8; 6]>,
    /// Magic packets received for the right MAC.
    wakes: usize,
    /// File names served short once (a consistent Content-Length: a file still written).
    short_once: Vec<String>,
    /// Downloads served short.
    short_served: usize,
    /// Stopped recordings leave no file on the card.
    no_file: bool,
}

/// Which API a listener of the simulator serves.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    /// Open GoPro: control and media on one port.
    OpenGoPro,
    /// Legacy control (`url`, http://10.5.5.9 on a camera).
    LegacyControl,
    /// Legacy media (`media_url`, http://10.5.5.9:8080 on a camera).
    LegacyMedia,
}

struct CamSim {
    url: String,
    /// The legacy media server (the Open GoPro simulator: `url`).
    media_url: String,
    /// UDP port receiving wake-on-LAN packets.
    wake_port: u16,
    state: Arc<Mutex<CamState>>,
}

fn example_videos() -> Vec<(f64, Arc<Vec<u8>>)> {
    let ex = fixture("sessions/example");
    EXAMPLE_KPA
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            let bytes = fs::read(ex.join(format!("GX01010{}.MP4", i + 1))).unwrap();
            (p, Arc::new(bytes))
        })
        .collect()
}

impl CamSim {
    fn start(state: CamState) -> CamSim {
        CamSim::start_with(state, RegState::new(RegMode::Normal))
    }

    fn start_with(mut state: CamState, regulator: Arc<Mutex<RegState>>) -> CamSim {
        state.next_number = 201;
        // An older video on the card: not part of any recording of the run.
        let older = if state.legacy {
            "GOPR0200.MP4"
        } else {
            "GX010200.MP4"
        };
        state
            .media
            .push(("100GOPRO".into(), older.into(), Arc::new(vec![0; 10])));
        let roles = if state.legacy {
            vec![Role::LegacyControl, Role::LegacyMedia]
        } else {
            vec![Role::OpenGoPro]
        };
        let state = Arc::new(Mutex::new(state));
        let videos = example_videos();
        let mut urls = vec![];
        for role in roles {
            let listener = TcpListener::bind("127.0.0.1:0").unwrap();
            urls.push(format!("http://{}", listener.local_addr().unwrap()));
            let (shared, regulator, videos) =
                (Arc::clone(&state), Arc::clone(&regulator), videos.clone());
            thread::spawn(move || {
                for stream in listener.incoming() {
                    let Ok(stream) = stream else { continue };
                    let (state, regulator, videos) =
                        (Arc::clone(&shared), Arc::clone(&regulator), videos.clone());
                    thread::spawn(move || serve(stream, role, &state, &regulator, &videos));
                }
            });
        }
        // Wake-on-LAN: 6 x 0xFF, then the MAC 16 times.
        let udp = UdpSocket::bind("127.0.0.1:0").unwrap();
        let wake_port = udp.local_addr().unwrap().port();
        let shared = Arc::clone(&state);
        thread::spawn(move || {
            let mut buf = [0u8; 512];
            while let Ok(n) = udp.recv(&mut buf) {
                let mut s = shared.lock().unwrap();
                if let Some(mac) = s.asleep {
                    let mut magic = vec![0xFFu8; 6];
                    for _ in 0..16 {
                        magic.extend_from_slice(&mac);
                    }
                    if buf[..n] == magic[..] {
                        s.asleep = None;
                        s.wakes += 1;
                    }
                }
            }
        });
        let media_url = urls.last().unwrap().clone();
        CamSim {
            url: urls[0].clone(),
            media_url,
            wake_port,
            state,
        }
    }

    /// A HERO5-HERO8 on the legacy WiFi API filming `regulator`'s pressure.
    fn wifi(state: CamState, regulator: &Arc<Mutex<RegState>>) -> CamSim {
        CamSim::films(
            CamState {
                legacy: true,
                mode: 1,
                ..state
            },
            regulator,
        )
    }

    /// Attach the regulator whose pressure the camera films.
    fn films(state: CamState, regulator: &Arc<Mutex<RegState>>) -> CamSim {
        CamSim::start_with(state, Arc::clone(regulator))
    }
}

fn respond(stream: &mut TcpStream, status: &str, body: &[u8], cut: bool) {
    let head = format!(
        "HTTP/1.1 {status}\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
        body.len()
    );
    let _ = stream.write_all(head.as_bytes());
    let n = if cut { body.len() / 2 } else { body.len() };
    let _ = stream.write_all(&body[..n]);
    let _ = stream.flush();
}

/// The recording's video(s) nearest `p` on the card: the first chapter, and a second
/// one for numbers in `chapters`, named as the camera's API generation names them.
fn add_recording(s: &mut CamState, p: f64, videos: &[(f64, Arc<Vec<u8>>)]) {
    let (_, bytes) = videos
        .iter()
        .min_by(|a, b| (a.0 - p).abs().total_cmp(&(b.0 - p).abs()))
        .unwrap();
    let n = s.next_number;
    s.next_number += 1;
    s.recordings += 1;
    if s.no_file {
        return;
    }
    let (first, second) = if s.legacy {
        (format!("GOPR{n:04}.MP4"), format!("GP01{n:04}.MP4"))
    } else {
        (format!("GX01{n:04}.MP4"), format!("GX02{n:04}.MP4"))
    };
    s.media.push(("100GOPRO".into(), first, Arc::clone(bytes)));
    if s.chapters.contains(&n) {
        s.media.push(("100GOPRO".into(), second, Arc::clone(bytes)));
    }
}

fn serve(
    mut stream: TcpStream,
    role: Role,
    state: &Mutex<CamState>,
    regulator: &Mutex<RegState>,
    videos: &[(f64, Arc<Vec<u8>>)],
) {
    let mut head = Vec::new();
    let mut byte = [0u8; 1];
    while !head.ends_with(b"\r\n\r\n") {
        match stream.read(&mut byte) {
            Ok(1) => head.push(byte[0]),
            _ => return,
        }
    }
    let head = String::from_utf8_lossy(&head).into_owned();
    let path = head.split_whitespace().nth(1).unwrap_or("").to_string();
    let mut s = state.lock().unwrap();
    if s.lost_after.is_some_and(|n| s.recordings >= n) || s.asleep.is_some() {
        return; // dropped: the camera is gone, or asleep
    }
    let ok = |stream: &mut TcpStream| respond(stream, "200 OK", b"{}", false);
    let legacy_control = path.starts_with("/gp/gpControl");
    let media = path == "/gopro/media/list"
        || path == "/gp/gpMediaList"
        || path.starts_with("/videos/DCIM/");
    let served = match role {
        Role::OpenGoPro => !legacy_control && path != "/gp/gpMediaList",
        Role::LegacyControl => legacy_control,
        Role::LegacyMedia => media && path != "/gopro/media/list",
    };
    if !served {
        return respond(&mut stream, "404 Not Found", b"{}", false);
    }
    match path.as_str() {
        "/gp/gpControl/status" => {
            let body = serde_json::json!({
                "status": {"1": 1, "2": 3, "8": 0, "10": i32::from(s.encoding), "43": s.mode},
                "settings": {"2": 9}
            });
            respond(&mut stream, "200 OK", body.to_string().as_bytes(), false)
        }
        "/gp/gpControl/command/mode?p=0" => {
            s.mode = 0;
            ok(&mut stream)
        }
        "/gp/gpControl/command/shutter?p=1" if s.mode != 0 => {
            // Photo mode: the shutter takes a photo.
            let n = s.next_number;
            s.next_number += 1;
            s.media.push((
                "100GOPRO".into(),
                format!("GOPR{n:04}.JPG"),
                Arc::new(vec![1; 10]),
            ));
            ok(&mut stream)
        }
        "/gp/gpControl/command/shutter?p=1" => {
            s.recording_kpa = Some(regulator.lock().unwrap().pressure_kpa());
            s.encoding = true;
            ok(&mut stream)
        }
        "/gp/gpControl/command/shutter?p=0" => {
            s.encoding = false;
            if let Some(p) = s.recording_kpa.take() {
                add_recording(&mut s, p, videos);
            }
            ok(&mut stream)
        }
        "/gopro/camera/control/wired_usb?p=1" | "/gopro/camera/keep_alive" => ok(&mut stream),
        "/gopro/camera/state" => {
            let recording = i32::from(s.recording_kpa.is_some());
            let body = serde_json::json!({"status": {"8": 0, "10": recording}, "settings": {}});
            respond(&mut stream, "200 OK", body.to_string().as_bytes(), false)
        }
        // Busy, or recording already (a camera starts no second recording).
        "/gopro/camera/shutter/start" if s.busy || s.recording_kpa.is_some() => {
            respond(&mut stream, "409 Conflict", b"{}", false)
        }
        "/gopro/camera/shutter/start" => {
            s.recording_kpa = Some(regulator.lock().unwrap().pressure_kpa());
            ok(&mut stream)
        }
        "/gopro/camera/shutter/stop" => {
            if let Some(p) = s.recording_kpa.take() {
                add_recording(&mut s, p, videos);
            }
            ok(&mut stream)
        }
        "/gopro/media/list" | "/gp/gpMediaList" => {
            let fs: Vec<serde_json::Value> = s
                .media
                .iter()
                .map(|(_, n, b)| serde_json::json!({"n": n, "s": b.len().to_string(), "mod": "1700000000"}))
                .collect();
            let body = serde_json::json!({"id": "1", "media": [{"d": "100GOPRO", "fs": fs}]});
            respond(&mut stream, "200 OK", body.to_string().as_bytes(), false)
        }
        p if p.starts_with("/videos/DCIM/") => {
            let rest = &p["/videos/DCIM/".len()..];
            let found = s
                .media
                .iter()
                .find(|(d, n, _)| format!("{d}/{n}") == rest)
                .map(|(_, n, b)| (n.clone(), Arc::clone(b)));
            match found {
                Some((name, bytes)) => {
                    let cut = s.cut.contains(&name);
                    if let Some(i) = s.short_once.iter().position(|n| *n == name) {
                        s.short_once.remove(i);
                        s.short_served += 1;
                        drop(s);
                        let short = &bytes[..bytes.len() / 2];
                        return respond(&mut stream, "200 OK", short, false);
                    }
                    if !cut {
                        s.downloads += 1;
                    }
                    drop(s);
                    respond(&mut stream, "200 OK", &bytes, cut)
                }
                None => respond(&mut stream, "404 Not Found", b"{}", false),
            }
        }
        _ => respond(&mut stream, "404 Not Found", b"{}", false),
    }
}

// ---------------------------------------------------------------- helpers

struct Bench {
    dir: tempfile::TempDir,
}

impl Bench {
    fn new() -> Bench {
        Bench {
            dir: tempfile::tempdir().unwrap(),
        }
    }
    fn path(&self) -> &Path {
        self.dir.path()
    }
    fn session(&self) -> PathBuf {
        self.path().join("session")
    }
    /// Writes a protocol with `plan` (a [steps] or [ramp] section) and returns its path.
    fn protocol(&self, plan: &str, port: &Path, camera: &str) -> PathBuf {
        let p = self.path().join("protocol.toml");
        fs::write(
            &p,
            format!(
                "{plan}\n[regulator]\nport = \"{}\"\nbaud = 115200\ntimeout_s = 0.1\nretries = 1\nboot_s = 0.3\n[camera]\n{camera}\n",
                port.display()
            ),
        )
        .unwrap();
        p
    }
    fn acquire(&self, protocol: &Path) -> Run {
        Run::new(
            self.path(),
            &[
                "acquire",
                protocol.to_str().unwrap(),
                "-o",
                self.session().to_str().unwrap(),
            ],
        )
    }
}

fn gopro(url: &str) -> String {
    format!("kind = \"gopro\"\nurl = \"{url}\"\ntimeout_s = 0.5")
}

const STEPS: &str = "[steps]\npressures_kpa = [20, 35, 50, 65, 80]\nstabilize_s = 0.15\nrecord_s = 0.2\nsample_hz = 50";

fn sets(reg: &Arc<Mutex<RegState>>) -> Vec<f64> {
    reg.lock().unwrap().sets.clone()
}

/// The manifest's (file, pressure) rows.
fn manifest(session: &Path) -> Vec<(String, f64)> {
    let (h, rows) = read_csv(&session.join("pressures.csv"));
    rows.iter()
        .map(|r| {
            (
                r[col(&h, "file")].clone(),
                r[col(&h, "pressure_kpa")].parse().unwrap(),
            )
        })
        .collect()
}

/// Every manifest row names a video byte-identical to the example's at its pressure.
fn assert_videos_match_the_example(session: &Path) {
    let videos = example_videos();
    for (file, p) in manifest(session) {
        let (_, want) = videos.iter().find(|(q, _)| (q - p).abs() < 1e-9).unwrap();
        assert_eq!(
            &fs::read(session.join(&file)).unwrap(),
            want.as_ref(),
            "{file} at {p} kPa"
        );
    }
}

fn assert_no_temporaries(session: &Path) {
    for e in fs::read_dir(session).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.starts_with(".bendscope-"), "temporary {name} left");
    }
}

// ---------------------------------------------------------------- tests

#[test]
fn an_acquired_session_is_measured_by_process_with_the_known_radii() {
    let b = Bench::new();
    let reg = RegState::new(RegMode::Normal);
    let sim = RegSim::start(b.path(), &reg);
    // The third recording comes as two chapters.
    let cam = CamSim::films(
        CamState {
            chapters: vec![203],
            ..Default::default()
        },
        &reg,
    );
    let protocol = b.protocol(STEPS, &sim.port, &gopro(&cam.url));
    let run = b.acquire(&protocol);
    assert_eq!(run.code, 0, "{run}");
    assert!(run.stdout.contains("5 recorded, 5 of 5"), "{run}");
    // Set points in order, then vented.
    assert_eq!(sets(&reg), [20.0, 35.0, 50.0, 65.0, 80.0, 0.0]);
    let s = b.session();
    assert_eq!(
        manifest(&s),
        (0..5)
            .map(|i| (format!("GX01{:04}.MP4", 201 + i), EXAMPLE_KPA[i]))
            .collect::<Vec<_>>()
    );
    assert!(s.join("GX020203.MP4").is_file(), "the chapter is fetched");
    assert!(
        !s.join("GX010200.MP4").exists(),
        "an older video on the card is not"
    );
    assert_videos_match_the_example(&s);
    assert_eq!(
        fs::read_to_string(s.join("protocol.toml")).unwrap(),
        fs::read_to_string(&protocol).unwrap()
    );
    // The acquisition log: measured mean at the set point (tau = 20 ms, 150 ms to settle),
    // spread of a settled first-order response, ~10 readings per recording.
    let (h, rows) = read_csv(&s.join("acquisition_log.csv"));
    assert_eq!(rows.len(), 5);
    for (r, p) in rows.iter().zip(EXAMPLE_KPA) {
        let mean: f64 = r[col(&h, "measured_mean_kpa")].parse().unwrap();
        let std: f64 = r[col(&h, "measured_std_kpa")].parse().unwrap();
        let n: u32 = r[col(&h, "samples")].parse().unwrap();
        assert!((mean - p).abs() < 0.01, "{p} kPa: mean {mean}");
        assert!(std < 0.01, "{p} kPa: spread {std}");
        assert!((5..=12).contains(&n), "{n} readings in 0.2 s at 50 Hz");
        assert_eq!(r[col(&h, "status")], "ok");
    }
    assert_eq!(rows[2][col(&h, "files")], "GX010203.MP4;GX020203.MP4");
    assert_no_temporaries(&s);
    assert_process_gives_the_example_radii(&b, "GX010203.MP4", "GX010201.MP4");
}

/// `process` measures the acquired session (with the example's scale photo, calibration
/// photos and settings added) with the example's known radii (0.5%), the recording
/// `two_chapters` over both its chapters (16 frames) and `one_chapter` over its 8.
fn assert_process_gives_the_example_radii(b: &Bench, two_chapters: &str, one_chapter: &str) {
    let s = b.session();
    let ex = fixture("sessions/example");
    copy_dir(&ex.join("calib"), &s.join("calib"));
    fs::copy(ex.join("scale.jpg"), s.join("scale.jpg")).unwrap();
    fs::copy(ex.join("bendscope.toml"), s.join("bendscope.toml")).unwrap();
    let out = b.path().join("out");
    let run = Run::new(
        b.path(),
        &["process", s.to_str().unwrap(), "-o", out.to_str().unwrap()],
    );
    assert_eq!(run.code, 0, "{run}");
    let truth: SessionTruth =
        serde_json::from_str(&fs::read_to_string(ex.join("truth.json")).unwrap()).unwrap();
    let (h, rows) = read_csv(&out.join("per_video.csv"));
    assert_eq!(rows.len(), 5);
    for (r, v) in rows.iter().zip(&truth.videos) {
        let radius: f64 = r[col(&h, "radius_mm")].parse().unwrap();
        let p: f64 = r[col(&h, "pressure_kpa")].parse().unwrap();
        assert!((p - v.pressure_kpa).abs() < 1e-9);
        assert!(
            (radius / v.radius_mm - 1.0).abs() < RADIUS_TOLERANCE,
            "{p} kPa: {radius} vs {}",
            v.radius_mm
        );
        assert_eq!(r[col(&h, "status")], "ok");
    }
    // The two-chapter recording is measured over both chapters.
    let (fh, frames) = read_csv(&out.join("per_frame.csv"));
    let n = |f: &str| frames.iter().filter(|r| r[col(&fh, "file")] == f).count();
    assert_eq!((n(two_chapters), n(one_chapter)), (16, 8));
}

/// The `[camera]` section of a HERO5-HERO8 simulator on the legacy WiFi API.
fn gopro_wifi(cam: &CamSim) -> String {
    format!(
        "kind = \"gopro-wifi\"\nurl = \"{}\"\nmedia_url = \"{}\"\nwake_port = {}\ntimeout_s = 0.5",
        cam.url, cam.media_url, cam.wake_port
    )
}

const HERO7_MAC: [u8; 6] = [0xd8, 0x96, 0x85, 0x0a, 0xbc, 0x01];

#[test]
fn a_hero7_over_wifi_is_woken_recorded_and_its_session_measured_with_the_known_radii() {
    let b = Bench::new();
    let reg = RegState::new(RegMode::Normal);
    let sim = RegSim::start(b.path(), &reg);
    // Asleep (answers nothing until the magic packet), in photo mode, the third
    // recording in two chapters (GOPR0203.MP4, GP010203.MP4).
    let cam = CamSim::wifi(
        CamState {
            chapters: vec![203],
            asleep: Some(HERO7_MAC),
            ..Default::default()
        },
        &reg,
    );
    let camera = format!("{}\nwake_mac = \"D8:96:85:0A:BC:01\"", gopro_wifi(&cam));
    let protocol = b.protocol(STEPS, &sim.port, &camera);
    let run = b.acquire(&protocol);
    assert_eq!(run.code, 0, "{run}");
    assert!(run.stdout.contains("5 recorded, 5 of 5"), "{run}");
    assert!(
        cam.state.lock().unwrap().wakes >= 1,
        "woken by the magic packet"
    );
    assert_eq!(cam.state.lock().unwrap().mode, 0, "switched to video mode");
    assert_eq!(sets(&reg), [20.0, 35.0, 50.0, 65.0, 80.0, 0.0]);
    let s = b.session();
    assert_eq!(
        manifest(&s),
        (0..5)
            .map(|i| (format!("GOPR{:04}.MP4", 201 + i), EXAMPLE_KPA[i]))
            .collect::<Vec<_>>()
    );
    assert!(s.join("GP010203.MP4").is_file(), "the chapter is fetched");
    assert!(!s.join("GOPR0200.MP4").exists(), "an older video is not");
    assert_videos_match_the_example(&s);
    let (h, rows) = read_csv(&s.join("acquisition_log.csv"));
    assert_eq!(rows[2][col(&h, "files")], "GOPR0203.MP4;GP010203.MP4");
    assert_no_temporaries(&s);
    assert_process_gives_the_example_radii(&b, "GOPR0203.MP4", "GOPR0201.MP4");
}

#[test]
fn a_short_download_over_wifi_is_tried_again_and_kept_whole() {
    let b = Bench::new();
    let reg = RegState::new(RegMode::Normal);
    let sim = RegSim::start(b.path(), &reg);
    // Served once with half its bytes and a Content-Length saying so (a file the camera
    // still writes): only the media list's size tells it is short.
    let cam = CamSim::wifi(
        CamState {
            short_once: vec!["GOPR0202.MP4".into()],
            ..Default::default()
        },
        &reg,
    );
    let run = b.acquire(&b.protocol(STEPS, &sim.port, &gopro_wifi(&cam)));
    assert_eq!(run.code, 0, "{run}");
    assert_eq!(cam.state.lock().unwrap().short_served, 1);
    assert_eq!(cam.state.lock().unwrap().downloads, 5, "{run}");
    assert_eq!(manifest(&b.session()).len(), 5);
    assert_videos_match_the_example(&b.session());
    assert_no_temporaries(&b.session());
}

#[test]
fn a_wifi_camera_off_its_network_asleep_or_recording_nothing_is_reported_vented() {
    let b = Bench::new();
    let reg = RegState::new(RegMode::Normal);
    let sim = RegSim::start(b.path(), &reg);
    // Not reachable (the host is not on the camera's network).
    let free = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    let camera = format!("kind = \"gopro-wifi\"\nurl = \"http://{free}\"\nmedia_url = \"http://{free}\"\ntimeout_s = 0.5");
    let run = b.acquire(&b.protocol(STEPS, &sim.port, &camera));
    run.assert_bad_input(&[
        "GoPro (WiFi) at http://",
        "join the camera's WiFi network",
        "http://10.5.5.9",
    ]);
    assert_eq!(sets(&reg), [0.0]);
    assert!(!b.session().join("pressures.csv").exists());
    // Asleep, no wake_mac given: the same, naming wake_mac.
    let cam = CamSim::wifi(
        CamState {
            asleep: Some(HERO7_MAC),
            ..Default::default()
        },
        &reg,
    );
    let run = b.acquire(&b.protocol(STEPS, &sim.port, &gopro_wifi(&cam)));
    run.assert_bad_input(&["join the camera's WiFi network", "wake_mac"]);
    assert_eq!(sets(&reg), [0.0, 0.0]);
    // Awake, but the recording never appears in the media list.
    let cam = CamSim::wifi(
        CamState {
            no_file: true,
            ..Default::default()
        },
        &reg,
    );
    let run = b.acquire(&b.protocol(STEPS, &sim.port, &gopro_wifi(&cam)));
    assert_eq!(run.code, 1, "{run}");
    assert!(
        run.stderr.contains("no new video in the media list")
            && run.stderr.contains("vented to 0 kPa; 0 of 5"),
        "{run}"
    );
    assert_eq!(sets(&reg)[2..], [20.0, 0.0]);
    assert_eq!(cam.state.lock().unwrap().recordings, 1);
}

#[test]
fn ctrl_c_vents_keeps_the_recordings_and_a_rerun_resumes_at_the_next_pressure() {
    let b = Bench::new();
    let reg = RegState::new(RegMode::Normal);
    let sim = RegSim::start(b.path(), &reg);
    let cam = CamSim::films(CamState::default(), &reg);
    let protocol = b.protocol(STEPS, &sim.port, &gopro(&cam.url));
    let s = b.session();
    let child = Command::new(common::exe())
        .args([
            "acquire",
            protocol.to_str().unwrap(),
            "-o",
            s.to_str().unwrap(),
        ])
        .stderr(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let t = Instant::now();
    while cam.state.lock().unwrap().downloads < 2 {
        assert!(t.elapsed() < Duration::from_secs(20), "no two recordings");
        thread::sleep(Duration::from_millis(5));
    }
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("interrupted") && stderr.contains("vented to 0 kPa"),
        "{stderr}"
    );
    assert!(stderr.contains("run the same command again"), "{stderr}");
    let first = sets(&reg);
    assert_eq!(first.last(), Some(&0.0), "vented: {first:?}");
    let kept = manifest(&s);
    assert!((2..=3).contains(&kept.len()), "{kept:?}");
    assert_videos_match_the_example(&s);
    // The plan says what is done and what is left, touching no device.
    let dry = Run::new(
        b.path(),
        &[
            "acquire",
            protocol.to_str().unwrap(),
            "-o",
            s.to_str().unwrap(),
            "--dry-run",
        ],
    );
    assert_eq!(dry.code, 0, "{dry}");
    assert_eq!(dry.stdout.matches(" done").count(), kept.len(), "{dry}");
    assert_eq!(
        dry.stdout.matches("to record").count(),
        5 - kept.len(),
        "{dry}"
    );
    assert_eq!(sets(&reg), first, "a dry run sends nothing");
    // Another plan into this session is refused before any device is opened.
    let other = b.path().join("other.toml");
    let text = fs::read_to_string(&protocol).unwrap();
    fs::write(&other, text.replace("[20, 35, 50, 65, 80]", "[20, 40]")).unwrap();
    let run = Run::new(
        b.path(),
        &[
            "acquire",
            other.to_str().unwrap(),
            "-o",
            s.to_str().unwrap(),
        ],
    );
    run.assert_bad_input(&["another plan", "protocol.toml"]);
    assert_eq!(sets(&reg), first);
    // The rerun resumes at the next pressure (a new pty: the port was closed).
    drop(sim);
    let sim = RegSim::start(b.path(), &reg);
    assert_eq!(sim.port, b.path().join("ttyREG"));
    let run = b.acquire(&protocol);
    assert_eq!(run.code, 0, "{run}");
    let second: Vec<f64> = sets(&reg)[first.len()..].to_vec();
    let mut expected: Vec<f64> = EXAMPLE_KPA[kept.len()..].to_vec();
    expected.push(0.0);
    assert_eq!(second, expected);
    assert_eq!(manifest(&s).len(), 5);
    assert_eq!(&manifest(&s)[..kept.len()], &kept[..]);
    assert_videos_match_the_example(&s);
}

#[test]
fn a_regulator_error_vents_and_keeps_what_was_recorded() {
    let b = Bench::new();
    let reg = RegState::new(RegMode::ErrAbove(60.0));
    let sim = RegSim::start(b.path(), &reg);
    let cam = CamSim::films(CamState::default(), &reg);
    let run = b.acquire(&b.protocol(STEPS, &sim.port, &gopro(&cam.url)));
    assert_eq!(run.code, 1, "{run}");
    assert!(
        run.stderr
            .contains("refused `SET 65.00`: ERR over limit 60.00 kPa"),
        "{run}"
    );
    assert!(
        run.stderr.contains("vented to 0 kPa; 3 of 5 recordings"),
        "{run}"
    );
    assert_eq!(sets(&reg), [20.0, 35.0, 50.0, 65.0, 0.0]);
    assert_eq!(manifest(&b.session()).len(), 3);
    assert_videos_match_the_example(&b.session());
}

#[test]
fn a_cut_download_stays_on_the_camera_and_the_rerun_fetches_it_without_recording_again() {
    let b = Bench::new();
    let reg = RegState::new(RegMode::Normal);
    let sim = RegSim::start(b.path(), &reg);
    let cam = CamSim::films(
        CamState {
            cut: vec!["GX010202.MP4".into()],
            ..Default::default()
        },
        &reg,
    );
    let protocol = b.protocol(STEPS, &sim.port, &gopro(&cam.url));
    let run = b.acquire(&protocol);
    assert_eq!(run.code, 1, "{run}");
    assert!(
        run.stderr.contains("download of GX010202.MP4 failed"),
        "{run}"
    );
    assert!(run.stderr.contains("cut after"), "{run}");
    assert!(run.stderr.contains("stays on the camera's card"), "{run}");
    assert_eq!(sets(&reg), [20.0, 35.0, 0.0]);
    let s = b.session();
    assert_eq!(manifest(&s), [("GX010201.MP4".to_string(), 20.0)]);
    assert!(!s.join("GX010202.MP4").exists(), "no partial video");
    assert_no_temporaries(&s);
    let (h, rows) = read_csv(&s.join("acquisition_log.csv"));
    assert!(
        rows[1][col(&h, "status")].starts_with("not downloaded"),
        "{rows:?}"
    );
    // The link is repaired; the rerun fetches step 2 and goes on at step 3.
    cam.state.lock().unwrap().cut.clear();
    drop(sim);
    let _sim = RegSim::start(b.path(), &reg);
    let run = b.acquire(&protocol);
    assert_eq!(run.code, 0, "{run}");
    assert_eq!(sets(&reg)[3..], [50.0, 65.0, 80.0, 0.0]);
    assert_eq!(manifest(&s).len(), 5);
    assert_videos_match_the_example(&s);
}

#[test]
fn a_camera_left_recording_by_a_killed_run_is_stopped_first_and_the_run_completes() {
    for legacy in [false, true] {
        let b = Bench::new();
        let reg = RegState::new(RegMode::Normal);
        let sim = RegSim::start(b.path(), &reg);
        // What a run killed (SIGKILL) during its recording at 50 kPa leaves: the camera
        // recording.
        let left = CamState {
            recording_kpa: Some(50.0),
            encoding: legacy,
            ..Default::default()
        };
        let (cam, camera) = if legacy {
            let cam = CamSim::wifi(left, &reg);
            let camera = gopro_wifi(&cam);
            (cam, camera)
        } else {
            let cam = CamSim::films(left, &reg);
            let camera = gopro(&cam.url);
            (cam, camera)
        };
        let run = b.acquire(&b.protocol(STEPS, &sim.port, &camera));
        assert_eq!(run.code, 0, "legacy {legacy}: {run}");
        assert!(
            run.stderr.contains(
                "was recording (an earlier run killed before it stopped?): stopped that recording"
            ),
            "legacy {legacy}: {run}"
        );
        assert!(
            run.stdout.contains("5 recorded, 5 of 5"),
            "legacy {legacy}: {run}"
        );
        // The left-over recording (number 201) stays on the camera, outside the session.
        let first = if legacy { "GOPR" } else { "GX01" };
        assert_eq!(
            manifest(&b.session()),
            (0..5)
                .map(|i| (format!("{first}{:04}.MP4", 202 + i), EXAMPLE_KPA[i]))
                .collect::<Vec<_>>(),
            "legacy {legacy}"
        );
        assert_videos_match_the_example(&b.session());
        assert_eq!(cam.state.lock().unwrap().recordings, 6, "legacy {legacy}");
    }
}

#[test]
fn missing_or_wrong_devices_are_refused_with_what_to_check() {
    let b = Bench::new();
    let cam = CamSim::start(CamState::default());
    // No device at the port.
    let run = b.acquire(&b.protocol(STEPS, Path::new("/dev/ttyACM-none"), &gopro(&cam.url)));
    run.assert_bad_input(&[
        "regulator on /dev/ttyACM-none",
        "no such serial port",
        "ls /dev/ttyACM*",
    ]);
    // Garbage (a wrong baud rate) and silence.
    for (mode, needle) in [
        (RegMode::Garbage, "baud rate is probably wrong"),
        (RegMode::Silent, "no answer to `GET`"),
    ] {
        let reg = RegState::new(mode);
        let sim = RegSim::start(b.path(), &reg);
        let run = b.acquire(&b.protocol(STEPS, &sim.port, &gopro(&cam.url)));
        run.assert_bad_input(&[needle]);
    }
    // No camera at the url: the regulator is vented before giving up.
    let free = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    let reg = RegState::new(RegMode::Normal);
    let sim = RegSim::start(b.path(), &reg);
    let run = b.acquire(&b.protocol(STEPS, &sim.port, &gopro(&format!("http://{free}"))));
    run.assert_bad_input(&["GoPro at http://", "is the camera on", "USB address"]);
    assert_eq!(sets(&reg), [0.0]);
    assert!(!b.session().join("pressures.csv").exists());
}

#[test]
fn a_regulator_port_another_program_holds_is_said_to_be_in_use() {
    let b = Bench::new();
    let cam = CamSim::start(CamState::default());
    let reg = RegState::new(RegMode::Normal);
    let sim = RegSim::start(b.path(), &reg);
    // Held as another acquire holds it: opened exclusively.
    let _held = serialport::new(sim.port.to_string_lossy(), 115_200)
        .open()
        .expect("the test opens the simulated port");
    let run = b.acquire(&b.protocol(STEPS, &sim.port, &gopro(&cam.url)));
    run.assert_bad_input(&[
        "regulator on ",
        "in use by another program (another acquire?)",
    ]);
    assert!(!run.stderr.contains("no such serial port"), "{run}");
    assert!(sets(&reg).is_empty(), "{run}");
}

#[test]
fn a_busy_or_lost_camera_stops_the_run_vented_with_the_recordings_kept() {
    let b = Bench::new();
    let reg = RegState::new(RegMode::Normal);
    let sim = RegSim::start(b.path(), &reg);
    let cam = CamSim::films(
        CamState {
            busy: true,
            ..Default::default()
        },
        &reg,
    );
    let run = b.acquire(&b.protocol(STEPS, &sim.port, &gopro(&cam.url)));
    assert_eq!(run.code, 1, "{run}");
    assert!(
        run.stderr
            .contains("is busy (HTTP 409 to /gopro/camera/shutter/start)"),
        "{run}"
    );
    assert!(run.stderr.contains("0 of 5"), "{run}");
    assert_eq!(sets(&reg), [20.0, 0.0]);
    drop(sim);
    // Lost after two recordings.
    let b = Bench::new();
    let reg = RegState::new(RegMode::Normal);
    let sim = RegSim::start(b.path(), &reg);
    let cam = CamSim::films(
        CamState {
            lost_after: Some(2),
            ..Default::default()
        },
        &reg,
    );
    let run = b.acquire(&b.protocol(STEPS, &sim.port, &gopro(&cam.url)));
    assert_eq!(run.code, 1, "{run}");
    assert!(
        run.stderr.contains("the camera was lost") || run.stderr.contains("is the camera on"),
        "{run}"
    );
    assert!(run.stderr.contains("vented to 0 kPa; 1 of 5"), "{run}");
    assert_eq!(*sets(&reg).last().unwrap(), 0.0);
    assert_eq!(manifest(&b.session()).len(), 1);
    assert_videos_match_the_example(&b.session());
}

#[test]
fn a_ramp_writes_one_video_and_its_pressure_log() {
    let b = Bench::new();
    let reg = RegState::new(RegMode::Normal);
    let sim = RegSim::start(b.path(), &reg);
    let cam = CamSim::films(CamState::default(), &reg);
    let ramp = "[ramp]\nrate_kpa_s = 40\ntop_kpa = 12\nlog_hz = 50\nstabilize_s = 0.05";
    let run = b.acquire(&b.protocol(ramp, &sim.port, &gopro(&cam.url)));
    assert_eq!(run.code, 0, "{run}");
    let s = b.session();
    assert_eq!(bendscope::session::session_videos(&s), ["GX010201.MP4"]);
    assert!(!s.join("pressures.csv").exists());
    let log = bendscope::session::read_pressure_log(&s.join("pressure_log.csv")).unwrap();
    // 0.3 s of rise at 50 Hz. Read right after each set point step (rate x T), the
    // first-order pressure lags by at most rate T / (1 - exp(-T / tau)) for the longest
    // interval T between readings (1.27 kPa at T = 20 ms), a bound kept by induction.
    let n = log.times_s.len();
    assert!((12..=18).contains(&n), "{n} readings");
    let t_max = log
        .times_s
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(0.0, f64::max);
    let lag_max = 40.0 * t_max / (1.0 - (-t_max / TAU_S).exp()) + 0.01;
    let (_, rows) = read_csv(&s.join("pressure_log.csv"));
    for (r, p) in rows.iter().zip(&log.pressures_kpa) {
        let set: f64 = r[2].parse().unwrap();
        assert!(
            (set - p) > -0.01 && (set - p) < lag_max,
            "set {set}, measured {p}, bound {lag_max}"
        );
    }
    assert!(
        log.pressures_kpa.windows(2).all(|w| w[1] >= w[0] - 1e-3),
        "{:?}",
        log.pressures_kpa
    );
    assert_eq!(*sets(&reg).last().unwrap(), 0.0);
    let top = sets(&reg)[sets(&reg).len() - 2];
    assert_eq!(top, 12.0);
}

#[test]
fn a_pwm_valve_reaches_each_set_point_through_the_sketchs_closed_loop() {
    let b = Bench::new();
    let reg = RegState::new(RegMode::Valve);
    let sim = RegSim::start(b.path(), &reg);
    let cam = CamSim::films(CamState::default(), &reg);
    let plan =
        "[steps]\npressures_kpa = [20, 50, 80]\nstabilize_s = 3.0\nrecord_s = 0.5\nsample_hz = 20";
    let protocol = b.protocol(plan, &sim.port, &gopro(&cam.url));
    let text = fs::read_to_string(&protocol).unwrap();
    fs::write(
        &protocol,
        text.replace("[regulator]\n", "[regulator]\nkind = \"serial\"\n"),
    )
    .unwrap();
    let run = b.acquire(&protocol);
    assert_eq!(run.code, 0, "{run}");
    assert!(!run.stderr.contains("warning"), "{run}");
    assert_eq!(sets(&reg), [20.0, 50.0, 80.0, 0.0]);
    // Settled: averaged over a period the plant is first order (tau 0.3 s, 1.94 kPa per
    // % of duty), the loop gain 2.9; what is left of the rise's overshoot and the leak's
    // offset decays with the integral's time constant, 0.67 s (3.5 s leave 0.035 kPa);
    // after 3 s that, plus the noise of the mean of 10 period means (0.03 kPa), stays
    // well within 0.25 kPa, a quarter of the 1 kPa acquire warns at. The spread of the
    // readings is the noise of one period mean, 0.5 / sqrt(25) = 0.1 kPa.
    let (h, rows) = read_csv(&b.session().join("acquisition_log.csv"));
    assert_eq!(rows.len(), 3);
    for (r, p) in rows.iter().zip([20.0, 50.0, 80.0]) {
        let mean: f64 = r[col(&h, "measured_mean_kpa")].parse().unwrap();
        let std: f64 = r[col(&h, "measured_std_kpa")].parse().unwrap();
        assert!((mean - p).abs() < 0.25, "{p} kPa: mean {mean}");
        assert!(std < 0.25, "{p} kPa: spread {std}");
    }
    // The valve pulses: the true pressure ripples by kPa within a period, which the
    // period means that GET answers do not show.
    let ripple = reg.lock().unwrap().valve.max_ripple_kpa;
    assert!(ripple > 2.0, "ripple {ripple} kPa");
    // Vented at the end: the valve released, the pressure falls.
    thread::sleep(Duration::from_millis(600));
    let p = reg.lock().unwrap().pressure_kpa();
    assert!(p < 20.0, "{p} kPa 0.6 s after the vent");
    assert_eq!(reg.lock().unwrap().valve.duty_pct, 0.0);
}

#[test]
fn a_webcam_is_recorded_through_ffmpeg() {
    let b = Bench::new();
    let reg = RegState::new(RegMode::Normal);
    let sim = RegSim::start(b.path(), &reg);
    let plan = "[steps]\npressures_kpa = [10, 20]\nstabilize_s = 0.05\nrecord_s = 1.0";
    let camera =
        "kind = \"webcam\"\nformat = \"lavfi\"\ndevice = \"testsrc=size=160x120:rate=10,realtime\"";
    let run = b.acquire(&b.protocol(plan, &sim.port, camera));
    assert_eq!(run.code, 0, "{run}");
    let s = b.session();
    assert_eq!(
        manifest(&s),
        [
            ("webcam_001.mp4".to_string(), 10.0),
            ("webcam_002.mp4".to_string(), 20.0)
        ]
    );
    for f in ["webcam_001.mp4", "webcam_002.mp4"] {
        let probe = Command::new("ffprobe")
            .args([
                "-v",
                "error",
                "-count_frames",
                "-select_streams",
                "v:0",
                "-show_entries",
                "stream=nb_read_frames",
                "-of",
                "csv=p=0",
            ])
            .arg(s.join(f))
            .output()
            .unwrap();
        let frames: u32 = String::from_utf8_lossy(&probe.stdout)
            .trim()
            .parse()
            .unwrap();
        // 1 s at 10 fps, give or take ffmpeg's start-up and the stop request.
        assert!((8..=20).contains(&frames), "{f}: {frames} frames");
    }
}

/// Width, height and frame count of a video's first stream (ffprobe), or why not.
fn probe(path: &Path) -> Result<(u32, u32, u32), String> {
    let out = Command::new("ffprobe")
        .args([
            "-v",
            "error",
            "-count_frames",
            "-select_streams",
            "v:0",
            "-show_entries",
            "stream=width,height,nb_read_frames",
            "-of",
            "csv=p=0",
        ])
        .arg(path)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).trim().to_string();
    let v: Vec<u32> = text.split(',').filter_map(|s| s.parse().ok()).collect();
    match v[..] {
        [w, h, n] if n > 0 => Ok((w, h, n)),
        _ => Err(format!(
            "{}: no video stream ({text}; {})",
            path.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        )),
    }
}

const LAVFI: &str =
    "kind = \"webcam\"\nformat = \"lavfi\"\ndevice = \"testsrc=size=160x120:rate=10,realtime\"";

#[test]
fn a_webcam_recorder_dies_with_a_killed_acquire_and_the_rerun_records_every_set_point() {
    let b = Bench::new();
    let reg = RegState::new(RegMode::Normal);
    let sim = RegSim::start(b.path(), &reg);
    let plan = "[steps]\npressures_kpa = [10, 20, 30]\nstabilize_s = 0.05\nrecord_s = 1.5";
    let protocol = b.protocol(plan, &sim.port, LAVFI);
    let s = b.session();
    let mut acquire = Command::new(common::exe())
        .args([
            "acquire",
            protocol.to_str().unwrap(),
            "-o",
            s.to_str().unwrap(),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // The second set point's recorder, a moment into its recording.
    let t = Instant::now();
    let ffmpeg = loop {
        let children = common::children_of(acquire.id());
        let recording = children.iter().find(|(_, c)| c == "ffmpeg");
        if let (true, Some((pid, _))) = (s.join("webcam_001.mp4").exists(), recording) {
            break *pid;
        }
        assert!(t.elapsed() < Duration::from_secs(20), "no second recording");
        thread::sleep(Duration::from_millis(10));
    };
    let _guard = common::KillOnDrop(ffmpeg);
    thread::sleep(Duration::from_millis(500));
    acquire.kill().unwrap();
    acquire.wait().unwrap();
    let t = Instant::now();
    while common::running(ffmpeg) {
        assert!(
            t.elapsed() < Duration::from_secs(2),
            "the webcam's ffmpeg (pid {ffmpeg}) outlived the acquire killed with SIGKILL"
        );
        thread::sleep(Duration::from_millis(20));
    }
    // The rerun records what is left; every set point ends with a playable video.
    drop(sim);
    let _sim = RegSim::start(b.path(), &reg);
    let run = b.acquire(&protocol);
    assert_eq!(run.code, 0, "{run}");
    assert!(run.stdout.contains("3 of 3"), "{run}");
    let files: Vec<(String, f64)> = (1..=3)
        .map(|k| (format!("webcam_00{k}.mp4"), 10.0 * k as f64))
        .collect();
    assert_eq!(manifest(&s), files);
    thread::sleep(Duration::from_millis(500));
    for (f, _) in &files {
        let (w, h, frames) = probe(&s.join(f)).unwrap();
        assert_eq!((w, h), (160, 120), "{f}");
        // 1.5 s at 10 fps, give or take ffmpeg's start-up and the stop request.
        assert!((12..=30).contains(&frames), "{f}: {frames} frames");
    }
    assert!(!s.join(".recorder.pid").exists());
}

#[test]
fn webcam_size_and_fps_apply_to_lavfi_and_an_unplayable_recording_is_recorded_again() {
    let b = Bench::new();
    let reg = RegState::new(RegMode::Normal);
    let sim = RegSim::start(b.path(), &reg);
    let plan = "[steps]\npressures_kpa = [10, 20]\nstabilize_s = 0.05\nrecord_s = 1.0";
    let camera = format!("{LAVFI}\nsize = \"80x60\"\nfps = 5");
    let protocol = b.protocol(plan, &sim.port, &camera);
    let run = b.acquire(&protocol);
    assert_eq!(run.code, 0, "{run}");
    let s = b.session();
    for f in ["webcam_001.mp4", "webcam_002.mp4"] {
        let (w, h, frames) = probe(&s.join(f)).unwrap();
        assert_eq!((w, h), (80, 60), "{f}: size applied");
        // 1 s at 5 fps (the graph's 10 fps resampled).
        assert!((3..=10).contains(&frames), "{f}: {frames} frames");
    }
    // A recording the log calls done but that holds no video (an earlier recorder
    // wrote over it): recorded again by the rerun, the broken file kept aside.
    let len = fs::metadata(s.join("webcam_002.mp4")).unwrap().len() as usize;
    fs::write(s.join("webcam_002.mp4"), vec![0u8; len]).unwrap();
    drop(sim);
    let _sim = RegSim::start(b.path(), &reg);
    let before = sets(&reg).len();
    let run = b.acquire(&protocol);
    assert_eq!(run.code, 0, "{run}");
    assert!(
        run.stderr
            .contains("step 2: webcam_002.mp4 is not a playable recording")
            && run.stderr.contains("recorded again"),
        "{run}"
    );
    assert_eq!(sets(&reg)[before..], [20.0, 0.0]);
    assert!(probe(&s.join("webcam_002.mp4")).is_ok());
    assert!(s.join("webcam_002.mp4.unplayable").is_file());
    assert_eq!(manifest(&s).len(), 2);
}

#[test]
fn stabilize_s_is_required_by_steps_and_its_absence_is_named() {
    let b = Bench::new();
    let help = Run::new(b.path(), &["acquire", "--help"]);
    assert!(help.stdout.contains("stabilize_s (required)"), "{help}");
    let p = b.protocol(
        "[steps]\npressures_kpa = [10]\nrecord_s = 1",
        Path::new("/dev/null"),
        LAVFI,
    );
    let run = Run::new(
        b.path(),
        &[
            "acquire",
            p.to_str().unwrap(),
            "-o",
            b.session().to_str().unwrap(),
            "--dry-run",
        ],
    );
    run.assert_bad_input(&["protocol.toml", "missing field `stabilize_s`"]);
}
