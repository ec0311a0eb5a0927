//! The pressure regulator on a serial line (an Arduino driving a proportional regulator,
//! hardware/regulator/regulator.ino), 115200 baud 8N1 by default.
//!
//! # Line protocol
//!
//! ASCII lines ending in `\n` (a `\r` before it is ignored), one answer per command:
//!
//! | host sends | device answers | meaning |
//! |---|---|---|
//! | `SET <kPa>` | `OK <kPa>` | new set point, echoed |
//! | `GET` | `P <kPa>` | the measured pressure |
//! | anything wrong | `ERR <text>` | refused (out of range, sensor fault, unknown command) |
//!
//! Numbers are decimal kPa (`SET 40.00`). Lines that are none of these (a boot banner)
//! are skipped; a command that gets no answer within the timeout is sent again
//! (`retries` times); `ERR` is final. The serial port comes from the `serialport` crate
//! (built without libudev: ports are named, not enumerated); the protocol itself is a
//! dozen lines no crate provides.

use std::io::{ErrorKind, Read, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use super::protocol::RegulatorConfig;
use super::AcquireError;

/// How long one read of the port blocks before the deadline is checked again.
const READ_SLICE: Duration = Duration::from_millis(20);
/// Interval between `GET`s while waiting for a freshly opened device to boot.
const BOOT_POLL: Duration = Duration::from_millis(250);
/// Longest answer line accepted, bytes (a longer one is garbage from a wrong baud rate).
const MAX_LINE_BYTES: usize = 256;
/// An `OK` echo may differ from the set point by this much (rounding in the sketch), kPa.
const ECHO_TOLERANCE_KPA: f64 = 0.01;

/// One answer of the device.
#[derive(Debug, Clone, PartialEq)]
pub enum Answer {
    /// `OK <kPa>`: a set point accepted.
    Ok(f64),
    /// `P <kPa>`: the measured pressure.
    Pressure(f64),
    /// `ERR <text>`: refused.
    Err(String),
}

/// Parses one answer line; `None` for lines that are not the protocol.
pub fn parse_answer(line: &str) -> Option<Answer> {
    let line = line.trim();
    if let Some(text) = line.strip_prefix("ERR") {
        if text.is_empty() || text.starts_with(' ') {
            return Some(Answer::Err(text.trim().to_string()));
        }
    }
    let (word, value) = line.split_once(' ')?;
    let v: f64 = value.trim().parse().ok().filter(|v: &f64| v.is_finite())?;
    match word {
        "OK" => Some(Answer::Ok(v)),
        "P" => Some(Answer::Pressure(v)),
        _ => None,
    }
}

/// The regulator: a line protocol over any byte stream (a serial port, or a test double).
pub struct Regulator<P: Read + Write> {
    port: P,
    name: String,
    baud: u32,
    timeout: Duration,
    retries: u32,
    pending: Vec<u8>,
    /// The last line that was not the protocol (for messages).
    garbage: Option<String>,
}

/// The regulator on a real serial port.
pub type SerialRegulator = Regulator<Box<dyn serialport::SerialPort>>;

impl SerialRegulator {
    /// Opens the serial port (8N1, no flow control) and waits up to `boot_s` for the device
    /// to answer `GET`.
    pub fn open(cfg: &RegulatorConfig) -> Result<SerialRegulator, AcquireError> {
        let port = serialport::new(&cfg.port, cfg.baud)
            .data_bits(serialport::DataBits::Eight)
            .parity(serialport::Parity::None)
            .stop_bits(serialport::StopBits::One)
            .flow_control(serialport::FlowControl::None)
            .timeout(READ_SLICE)
            .open()
            .map_err(|e| AcquireError::Regulator {
                port: cfg.port.clone(),
                why: open_error(&e, Path::new(&cfg.port).exists()),
            })?;
        let mut reg = Regulator::new(port, cfg);
        reg.wait_ready(Duration::from_secs_f64(cfg.boot_s))?;
        Ok(reg)
    }
}

/// What a failure to open the serial port means for the user; `exists`: the port's
/// device file exists.
fn open_error(e: &serialport::Error, exists: bool) -> String {
    use serialport::ErrorKind as K;
    match e.kind() {
        // serialport reports a port another process holds (its TIOCEXCL or flock) as
        // NoDevice: the device file is there, and busy.
        K::NoDevice if exists => format!(
            "in use by another program (another acquire?) ({e}): let it finish or close it, or set [regulator] port to another device"
        ),
        K::NoDevice | K::Io(ErrorKind::NotFound) => format!(
            "no such serial port ({e}): plug the regulator in, check the port name (ls /dev/ttyACM* /dev/ttyUSB*) and set [regulator] port"
        ),
        K::Io(ErrorKind::PermissionDenied) => format!(
            "permission denied ({e}): add yourself to the dialout group (sudo adduser $USER dialout, then log in again)"
        ),
        _ => format!("cannot open the serial port: {e} (is another program using it?)"),
    }
}

impl<P: Read + Write> Regulator<P> {
    /// A regulator on an open byte stream whose reads time out after a short while.
    pub fn new(port: P, cfg: &RegulatorConfig) -> Regulator<P> {
        Regulator {
            port,
            name: cfg.port.clone(),
            baud: cfg.baud,
            timeout: Duration::from_secs_f64(cfg.timeout_s),
            retries: cfg.retries,
            pending: Vec::new(),
            garbage: None,
        }
    }

    /// Sends `GET` until the device answers or `boot` has passed (an Arduino resets when
    /// its port is opened). Other lines (a boot banner) are skipped.
    pub fn wait_ready(&mut self, boot: Duration) -> Result<f64, AcquireError> {
        let deadline = Instant::now() + boot.max(self.timeout);
        loop {
            self.send("GET")?;
            let slice = BOOT_POLL.min(self.timeout).max(READ_SLICE);
            match self.read_answer(Instant::now() + slice)? {
                Some(Answer::Pressure(p)) => return Ok(p),
                Some(Answer::Err(text)) => return Err(self.refused("GET", &text)),
                Some(Answer::Ok(_)) | None => {}
            }
            if Instant::now() >= deadline {
                return Err(self.no_answer("GET", boot.max(self.timeout).as_secs_f64()));
            }
        }
    }

    /// Sets the pressure, kPa; returns the echoed set point.
    pub fn set_kpa(&mut self, kpa: f64) -> Result<f64, AcquireError> {
        let command = format!("SET {kpa:.2}");
        match self.ask(&command, |a| matches!(a, Answer::Ok(_)))? {
            Answer::Ok(v) if (v - kpa).abs() <= ECHO_TOLERANCE_KPA => Ok(v),
            Answer::Ok(v) => Err(AcquireError::Regulator {
                port: self.name.clone(),
                why: format!("`{command}` was acknowledged as {v} kPa: check the sketch's range"),
            }),
            other => Err(self.unexpected(&command, &other)),
        }
    }

    /// The measured pressure, kPa.
    pub fn get_kpa(&mut self) -> Result<f64, AcquireError> {
        match self.ask("GET", |a| matches!(a, Answer::Pressure(_)))? {
            Answer::Pressure(p) => Ok(p),
            other => Err(self.unexpected("GET", &other)),
        }
    }

    /// Sends `command` and waits for an answer `wanted` accepts (or `ERR`), sending it
    /// again when none came within the timeout.
    fn ask(
        &mut self,
        command: &str,
        wanted: impl Fn(&Answer) -> bool,
    ) -> Result<Answer, AcquireError> {
        for _ in 0..=self.retries {
            self.send(command)?;
            let deadline = Instant::now() + self.timeout;
            while let Some(answer) = self.read_answer(deadline)? {
                match answer {
                    Answer::Err(text) => return Err(self.refused(command, &text)),
                    a if wanted(&a) => return Ok(a),
                    // A late answer to an earlier command: skip it.
                    _ => {}
                }
            }
        }
        Err(self.no_answer(command, self.timeout.as_secs_f64()))
    }

    fn send(&mut self, command: &str) -> Result<(), AcquireError> {
        let line = format!("{command}\n");
        self.port
            .write_all(line.as_bytes())
            .and_then(|_| self.port.flush())
            .map_err(|e| AcquireError::Regulator {
                port: self.name.clone(),
                why: format!("cannot send `{command}`: {e} (was the cable pulled?)"),
            })
    }

    /// The next protocol answer before `deadline`, or `None` when the time is up.
    fn read_answer(&mut self, deadline: Instant) -> Result<Option<Answer>, AcquireError> {
        loop {
            while let Some(end) = self.pending.iter().position(|&b| b == b'\n') {
                let raw: Vec<u8> = self.pending.drain(..=end).collect();
                let line = String::from_utf8_lossy(&raw).trim().to_string();
                if line.is_empty() {
                    continue;
                }
                match parse_answer(&line) {
                    Some(a) => return Ok(Some(a)),
                    None => self.garbage = Some(line),
                }
            }
            if self.pending.len() > MAX_LINE_BYTES {
                self.garbage = Some(String::from_utf8_lossy(&self.pending).into_owned());
                self.pending.clear();
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
            let mut buf = [0u8; 256];
            match self.port.read(&mut buf) {
                Ok(0) => std::thread::sleep(READ_SLICE),
                Ok(n) => self.pending.extend_from_slice(&buf[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
                    ) => {}
                Err(e) => {
                    return Err(AcquireError::Regulator {
                        port: self.name.clone(),
                        why: format!("the serial line failed: {e} (was the cable pulled?)"),
                    })
                }
            }
        }
    }

    fn refused(&self, command: &str, text: &str) -> AcquireError {
        AcquireError::RegulatorRefused {
            port: self.name.clone(),
            command: command.to_string(),
            text: text.to_string(),
        }
    }

    fn unexpected(&self, command: &str, answer: &Answer) -> AcquireError {
        AcquireError::Regulator {
            port: self.name.clone(),
            why: format!("unexpected answer {answer:?} to `{command}`"),
        }
    }

    fn no_answer(&self, command: &str, waited_s: f64) -> AcquireError {
        let why = match &self.garbage {
            Some(g) => format!(
                "no valid answer to `{command}`, only `{}`: the baud rate is probably wrong (the sketch uses {}; the protocol says {}), or the device runs another sketch",
                g.escape_debug(),
                super::protocol::DEFAULT_BAUD,
                self.baud
            ),
            None => format!(
                "no answer to `{command}` within {waited_s} s ({} tries): check that the regulator sketch is loaded, the baud rate ({}) and the port",
                self.retries + 1,
                self.baud
            ),
        };
        AcquireError::Regulator {
            port: self.name.clone(),
            why,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::VecDeque;

    #[test]
    fn a_port_held_by_another_program_is_in_use_not_missing() {
        let held = serialport::Error::new(
            serialport::ErrorKind::NoDevice,
            "Unable to acquire exclusive lock on serial port",
        );
        let e = open_error(&held, true);
        assert!(
            e.starts_with("in use by another program (another acquire?) (Unable to acquire exclusive lock on serial port)"),
            "{e}"
        );
        assert!(open_error(&held, false).starts_with("no such serial port"));
    }

    #[test]
    fn answers_parse() {
        assert_eq!(parse_answer("OK 40.00\r"), Some(Answer::Ok(40.0)));
        assert_eq!(parse_answer("P 39.87"), Some(Answer::Pressure(39.87)));
        assert_eq!(
            parse_answer("ERR over limit"),
            Some(Answer::Err("over limit".into()))
        );
        assert_eq!(parse_answer("ERR"), Some(Answer::Err(String::new())));
        assert_eq!(parse_answer("READY regulator 1"), None);
        assert_eq!(parse_answer("P nan"), None);
        assert_eq!(parse_answer("ERRx"), None);
    }

    /// A device double: answers scripted lines, one per command written.
    struct Script {
        answers: VecDeque<&'static str>,
        out: Vec<u8>,
        sent: Vec<String>,
    }

    impl Read for Script {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            if self.out.is_empty() {
                return Err(ErrorKind::TimedOut.into());
            }
            let n = buf.len().min(self.out.len());
            buf[..n].copy_from_slice(&self.out[..n]);
            self.out.drain(..n);
            Ok(n)
        }
    }

    impl Write for Script {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.sent
                .push(String::from_utf8_lossy(buf).trim().to_string());
            if let Some(a) = self.answers.pop_front() {
                self.out.extend_from_slice(a.as_bytes());
            }
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    fn regulator(answers: &[&'static str]) -> Regulator<Script> {
        let cfg = RegulatorConfig {
            port: "test".into(),
            baud: 115_200,
            timeout_s: 0.05,
            retries: 2,
            boot_s: 0.0,
            max_kpa: None,
        };
        Regulator::new(
            Script {
                answers: answers.iter().copied().collect(),
                out: vec![],
                sent: vec![],
            },
            &cfg,
        )
    }

    #[test]
    fn a_lost_answer_is_asked_again_and_err_is_final() {
        // First SET unanswered, second answered after a banner line.
        let mut r = regulator(&[
            "",
            "READY\r\nOK 40.00\r\n",
            "P 39.5\n",
            "ERR sensor fault\n",
        ]);
        assert_eq!(r.set_kpa(40.0).unwrap(), 40.0);
        assert_eq!(r.port.sent, ["SET 40.00", "SET 40.00"]);
        assert_eq!(r.get_kpa().unwrap(), 39.5);
        let e = r.get_kpa().unwrap_err().to_string();
        assert!(e.contains("sensor fault") && e.contains("GET"), "{e}");
        assert_eq!(r.port.sent.len(), 4, "ERR is not retried");
    }

    #[test]
    fn silence_and_garbage_are_told_apart() {
        let mut r = regulator(&[]);
        let e = r.set_kpa(10.0).unwrap_err().to_string();
        assert!(e.contains("no answer") && e.contains("3 tries"), "{e}");
        let mut r = regulator(&["\u{fe}\u{7f}x\u{3}\n", "\u{fe}\n", "\u{fe}\n"]);
        let e = r.get_kpa().unwrap_err().to_string();
        assert!(e.contains("baud rate is probably wrong"), "{e}");
    }
}
