//! `bendscope acquire`: drive the pressure regulator and the camera through a protocol and
//! write a session folder for `process`.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::Result;
use bendscope::acquire::protocol::{CameraConfig, Plan};
use bendscope::acquire::{acquire, dry_run, AcquireError, NoteKind};
use clap::Args;

use super::{EXIT_BAD_INPUT, EXIT_OK, EXIT_PARTIAL};

/// Record a session: set each pressure, wait, record a video, fetch it.
#[derive(Debug, Args)]
#[command(
    after_help = "PROTOCOL.toml: [steps] pressures_kpa = [40, 55, 70] (or pressures = \"40:115:15\", unit = \"kPa\"|\"bar\"|\"psi\"), \
stabilize_s (required), record_s (required), repeats (1), vent_at_end (true), sample_hz (10); or [ramp] rate_kpa_s, top_kpa, start_kpa (0), log_hz, stabilize_s (0); \
[regulator] port, baud (115200), timeout_s, retries, boot_s, max_kpa; [camera] kind = \"gopro\" (HERO9+) with url = \"http://172.2X.1YZ.51:8080\" (USB) or \"http://10.5.5.9:8080\" (WiFi), \
or kind = \"gopro-wifi\" (HERO5-8 on the camera's WiFi) with url (http://10.5.5.9), media_url (http://10.5.5.9:8080), wake_mac, wake_port (9), \
or kind = \"webcam\" with device, size, fps, input_format (format = \"lavfi\": size and fps scale and resample the graph's output). \
SESSION gets the videos, pressures.csv (or pressure_log.csv), protocol.toml and acquisition_log.csv. \
Ctrl-C (or SIGTERM), a lost camera or a regulator error vents to 0 kPa and keeps what was recorded; the same command resumes. \
Exit codes: 0 done, 1 stopped early (recordings kept, rerun to resume), 2 bad protocol or a device unreachable (nothing recorded)."
)]
pub struct AcquireArgs {
    /// The protocol (TOML).
    #[arg(value_name = "PROTOCOL.toml")]
    pub protocol: PathBuf,
    /// The session folder to write (created; a folder of an earlier run is resumed).
    #[arg(short, long, value_name = "SESSION")]
    pub output: PathBuf,
    /// Print the plan and what is already recorded; touch no device.
    #[arg(long)]
    pub dry_run: bool,
}

/// Runs `bendscope acquire`.
pub fn run(args: &AcquireArgs) -> Result<u8> {
    if args.dry_run {
        return print_plan(args);
    }
    // One recording per session folder (a second would fight over the camera and port).
    let _lock = super::lock_output(&args.output)?;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    if let Err(e) = ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst)) {
        eprintln!("warning: Ctrl-C cannot be caught ({e}): stop with care, the regulator is vented only by a normal end");
    }
    let tty = std::io::stderr().is_terminal();
    let mut note = |kind: NoteKind, line: &str| match kind {
        NoteKind::Progress if tty => eprintln!("{line}"),
        NoteKind::Progress => {}
        NoteKind::Warning => eprintln!("warning: {line}"),
    };
    let outcome = match acquire(&args.protocol, &args.output, &stop, &mut note) {
        Ok(o) => o,
        Err(e @ (AcquireError::Protocol { .. } | AcquireError::Session { .. })) => {
            eprintln!("error: {e}");
            return Ok(EXIT_BAD_INPUT);
        }
        Err(e) => {
            eprintln!("error: {e} (nothing recorded; the regulator was vented if it answered)");
            return Ok(EXIT_BAD_INPUT);
        }
    };
    let session = args.output.display();
    if let Some(v) = &outcome.vent_failed {
        eprintln!("DANGER: the regulator could not be vented ({v}): release the pressure by hand");
    }
    if let Some(e) = &outcome.stopped {
        eprintln!(
            "error: {e}; {}{} of {} recordings are in {session}: run the same command again to resume",
            if outcome.vented { "vented to 0 kPa; " } else { "" },
            outcome.in_session,
            outcome.planned
        );
        return Ok(EXIT_PARTIAL);
    }
    super::out!(
        "{} recorded, {} of {} in {session}{}; measure it with: bendscope process {session} (with scale.jpg and calib/ or --calibration)",
        outcome.recorded,
        outcome.in_session,
        outcome.planned,
        if outcome.vented { ", vented to 0 kPa" } else { "" }
    );
    Ok(EXIT_OK)
}

fn print_plan(args: &AcquireArgs) -> Result<u8> {
    let plan = match dry_run(&args.protocol, &args.output) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: {e}");
            return Ok(EXIT_BAD_INPUT);
        }
    };
    let p = &plan.protocol;
    match &p.plan {
        Plan::Steps(s) => super::out!(
            "steps: {} set points x {} repeats, stabilize {} s, record {} s, pressure read at {} Hz{}",
            s.pressures_kpa.len(),
            s.repeats,
            s.stabilize_s,
            s.record_s,
            s.sample_hz,
            if s.vent_at_end { ", vent at end" } else { "" }
        ),
        Plan::Ramp(r) => super::out!(
            "ramp: {} -> {} kPa at {} kPa/s ({:.1} s), logged at {} Hz",
            r.start_kpa,
            r.top_kpa,
            r.rate_kpa_s,
            r.duration_s(),
            r.log_hz
        ),
    }
    super::out!(
        "regulator: {} at {} baud; camera: {}",
        p.regulator.port,
        p.regulator.baud,
        match &p.camera {
            CameraConfig::GoPro { url, .. } => format!("GoPro at {url}"),
            CameraConfig::GoProWifi(w) => format!("GoPro (WiFi) at {}", w.url),
            CameraConfig::Webcam(w) => format!("webcam {} ({})", w.device, w.format),
        }
    );
    for r in &plan.recordings {
        super::out!("  {:>4}  {:>9.3} kPa  {}", r.step, r.pressure_kpa, r.state);
    }
    super::out!(
        "about {:.0} s left -> {} (dry run: no device touched)",
        plan.estimate_s,
        args.output.display()
    );
    Ok(EXIT_OK)
}
