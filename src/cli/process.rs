//! `bendscope process`: parses the flags, measures each session through
//! [`bendscope::pipeline::measure_session`], prints and picks the exit code.

use std::path::PathBuf;

use anyhow::Result;
use bendscope::pipeline::{measure_session, output_dirs, ProcessSettings, Progress};
use clap::Args;

use super::{EXIT_BAD_INPUT, EXIT_NOTHING, EXIT_NO_SPACE, EXIT_OK, EXIT_PARTIAL};

/// Measure bending vs pressure from session folders.
#[derive(Debug, Args)]
#[command(
    after_help = "Session folder (step protocol): pressures.csv (header file,pressure_bar | pressure_kpa | pressure_psi), \
one video per pressure (GoPro chapters GX02.. continue GX01..), scale.jpg (a board in the actuator plane), \
calib/ (checkerboard photos) and an optional bendscope.toml.
Ramp protocol: pressure_log.csv (time_s,pressure_<unit>) and one video instead of pressures.csv.
RGB-D: color/, depth/ (16-bit PNG aligned to colour), intrinsics.json, pressure_log.csv and optionally frames.csv (frame,time_s); \
or one RealSense recording (*.bag from the RealSense Viewer / rs-record: colour + depth, aligned here) and pressure_log.csv (time 0 = the first colour frame).
Outputs in OUT: per_frame.csv, per_video.csv, fit.json, session.json (version, settings, calibration, scale, cache use), plots/, overlays/, report.html, cache/.
Settings: scale = \"FILE\" in bendscope.toml takes a scale saved by `bendscope scale --save` instead of the scale photo.
One run at a time per OUT (OUT/.bendscope.lock); a killed run (Ctrl-C, kill) is simply run again.
Exit codes: 0 all measured, 1 some videos or sessions failed (the others' results are written), 2 bad input (or OUT in use), 3 nothing measured, 4 no space left on OUT's disk (free space and rerun)."
)]
pub struct ProcessArgs {
    /// Session folders (pressures.csv, videos, scale photo, calib/; or RGB-D frames or a .bag).
    #[arg(required = true, value_name = "SESSION")]
    pub sessions: Vec<PathBuf>,
    /// Output folder [default: SESSION/bendscope-out; with several sessions OUT/<session>,
    /// OUT/<session>-2 for a second session of the same name].
    #[arg(short, long, value_name = "OUT")]
    pub output: Option<PathBuf>,
    /// Calibration file (else the session's setting, else calib/ is calibrated and cached in OUT).
    #[arg(long, value_name = "FILE")]
    pub calibration: Option<PathBuf>,
    /// Settings file [default: SESSION/bendscope.toml when present].
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Reprocess videos whose results are current.
    #[arg(long)]
    pub force: bool,
    /// What the plots' error bars show: std (one standard deviation of a video's frames)
    /// or ci95 (95 % confidence interval of the mean, t with n - 1 over the frames used)
    /// [default: the session's error_bars, else std].
    #[arg(long, value_name = "std|ci95")]
    pub error_bars: Option<bendscope::report::ErrorBars>,
}

/// Seconds between progress lines when stderr is not a terminal (a log file, a pipe):
/// the bar is hidden there, and a long video would otherwise show nothing for minutes.
const PROGRESS_LINE_EVERY_S: u64 = 10;

/// Progress bars and warning lines on stderr.
struct Bars {
    bar: Option<indicatif::ProgressBar>,
    /// The item being measured.
    item: String,
    /// When a progress line was last printed (stderr not a terminal).
    last_line: std::time::Instant,
    /// Whether stderr is a terminal (where the bar shows).
    tty: bool,
}

impl Bars {
    fn new() -> Self {
        Self {
            bar: None,
            item: String::new(),
            last_line: std::time::Instant::now(),
            tty: std::io::IsTerminal::is_terminal(&std::io::stderr()),
        }
    }
}

impl Progress for Bars {
    fn start(&mut self, what: &str, total: u64) {
        self.bar = Some(super::progress_bar(total, what));
    }
    fn item(&mut self, name: &str) {
        self.item = name.to_string();
        if let Some(b) = &self.bar {
            b.set_message(name.to_string());
        }
    }
    fn frames(&mut self, done: u64, expected: u64) {
        let of = if expected > 0 {
            format!(" of ~{expected}")
        } else {
            String::new()
        };
        if self.tty {
            if let Some(b) = &self.bar {
                b.set_message(format!("{} frame {done}{of}", self.item));
            }
        } else if self.last_line.elapsed().as_secs() >= PROGRESS_LINE_EVERY_S {
            self.last_line = std::time::Instant::now();
            eprintln!("progress: {}: frame {done}{of}", self.item);
        }
    }
    fn advance(&mut self, n: u64) {
        if let Some(b) = &self.bar {
            b.inc(n);
        }
    }
    fn finish(&mut self) {
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
        }
    }
    fn note(&mut self, line: &str) {
        match &self.bar {
            Some(b) => b.suspend(|| eprintln!("{line}")),
            None => eprintln!("{line}"),
        }
    }
}

/// Runs `bendscope process`.
pub fn run(args: &ProcessArgs) -> Result<u8> {
    let settings = ProcessSettings {
        calibration: args.calibration.clone(),
        config: args.config.clone(),
        force: args.force,
        error_bars: args.error_bars,
    };
    let (mut measured, mut failed, mut bad_input, mut no_space) = (0usize, 0usize, 0usize, 0usize);
    let dirs = output_dirs(&args.sessions, args.output.as_deref());
    for (session, (out, note)) in args.sessions.iter().zip(dirs) {
        if let Some(n) = note {
            eprintln!("note: {n}");
        }
        match measure_session(session, &out, &settings, &mut Bars::new()) {
            Ok(s) => {
                measured += s.measured;
                failed += s.failed;
                if let Some(scale) = &s.provenance.scale {
                    super::out!("{}: scale {}", session.display(), scale.describe());
                }
                super::out!(
                    "{}: {} measured, {} failed -> {}",
                    session.display(),
                    s.measured,
                    s.failed,
                    out.display()
                );
            }
            Err(e) => {
                eprintln!("error: {}", e.for_session(session));
                if e.is_no_space() {
                    no_space += 1;
                } else {
                    bad_input += 1;
                }
            }
        }
    }
    Ok(if no_space > 0 {
        EXIT_NO_SPACE
    } else if measured == 0 {
        if bad_input > 0 && failed == 0 {
            EXIT_BAD_INPUT
        } else {
            EXIT_NOTHING
        }
    } else if failed > 0 || bad_input > 0 {
        EXIT_PARTIAL
    } else {
        EXIT_OK
    })
}
