//! Command-line interface: flags parsed once into checked settings, then dispatched to the
//! library. Data goes to files and stdout; logs and progress bars go to stderr.

/// Prints a line to stdout, ignoring a closed pipe (`bendscope ... | head` must not
/// panic; the results are already written when summaries are printed).
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}
pub(crate) use out;

pub mod acquire;
pub mod calibrate;
pub mod compare;
pub mod control;
pub mod demo;
pub mod fit_model;
pub mod inspect;
pub mod material;
pub mod optimize;
pub mod process;
pub mod render;
pub mod scale;
pub mod simulate;
pub mod study;
pub mod surrogate;
pub mod sweep;

use std::path::Path;

use bendscope::lock::OutputLock;
use clap::{Parser, Subcommand};

/// Exit code: everything asked for was done.
pub const EXIT_OK: u8 = 0;
/// Exit code: some items failed, the others' results were written.
pub const EXIT_PARTIAL: u8 = 1;
/// Exit code: bad input or usage; nothing was done.
pub const EXIT_BAD_INPUT: u8 = 2;
/// Exit code: nothing could be measured.
pub const EXIT_NOTHING: u8 = 3;
/// Exit code of a run stopped by SIGINT (Ctrl-C) or SIGTERM that kept what it had
/// done (`sweep`): 128 + SIGINT, what a shell reports for a command Ctrl-C stopped.
pub const EXIT_INTERRUPTED: u8 = 130;
/// Exit code: the output folder's disk is full (free space and rerun).
pub const EXIT_NO_SPACE: u8 = 4;

/// Measure soft pneumatic bending actuators from video and compare them with a
/// finite-element model.
#[derive(Debug, Parser)]
#[command(name = "bendscope", version, about, long_about = None)]
#[command(
    after_help = "Exit codes: 0 all done, 1 some items failed (others kept), 2 bad input or usage (also: the output folder in use by another run, or not writable), 3 nothing could be measured, 4 no space left on the output folder's disk."
)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Calibrate a camera from checkerboard photos, folders of photos or videos.
    Calibrate(calibrate::CalibrateArgs),
    /// Measure mm per undistorted pixel from a board lying in the actuator plane.
    Scale(scale::ScaleArgs),
    /// Measure radius of curvature, curvature and bending angle vs pressure from session folders.
    Process(process::ProcessArgs),
    /// Simulate the actuator under a pressure ramp with the finite-element model.
    Simulate(simulate::SimulateArgs),
    /// Render the simulated actuator through a calibrated camera as a session of videos.
    Render(render::RenderArgs),
    /// Compare measured bending (process output) with the simulation (simulate output).
    Compare(compare::CompareArgs),
    /// Summarize samples x runs (process outputs): means, spreads, fits, the FEM over them.
    Study(study::StudyArgs),
    /// Drive the pressure regulator and the camera through a protocol: record a session.
    Acquire(acquire::AcquireArgs),
    /// Close the loop: a PID bends the simulated actuator to a reference angle.
    Control(control::ControlArgs),
    /// Run the whole chain on a simulated actuator: simulate, render, calibrate, process, compare.
    Demo(demo::DemoArgs),
    /// Run a multi-factor design of simulations (local pool, GNU parallel or Slurm) into designs.csv.
    Sweep(sweep::SweepArgs),
    /// Fit a Gaussian-process surrogate of designs.csv, or predict with one.
    Surrogate(surrogate::SurrogateArgs),
    /// Optimize a design on surrogates of designs.csv; re-simulate the best with the FEM.
    Optimize(optimize::OptimizeArgs),
    /// Fit a hyperelastic model to uniaxial tensile data; list the material presets.
    Material(material::MaterialArgs),
    /// Fit model parameters (geometry, material) to a measurement (process output).
    FitModel(fit_model::FitModelArgs),
    /// Show a frame's marker mask in a page with colour sliders; suggest a [detect] setting.
    Inspect(inspect::InspectArgs),
}

/// A progress bar on stderr (drawn only when stderr is a terminal).
pub fn progress_bar(len: u64, what: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{msg:>16} [{bar:30}] {pos}/{len} {elapsed_precise} eta {eta}",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(what.to_string());
    bar
}

/// Takes the output folder `out` before a command's work ([`bendscope::lock::lock_output`]:
/// made, locked, a write tested): a second run into it, a read-only folder or a full
/// disk is refused at once (exit 2, or 4 for a full disk, in `main`). Hold the lock
/// until the last output is written.
pub fn lock_output(out: &Path) -> anyhow::Result<OutputLock> {
    let lock = bendscope::lock::lock_output(out)?;
    if !lock.locked {
        eprintln!(
            "warning: {}: this file system cannot lock files: do not run two bendscope commands into this folder at once",
            out.display()
        );
    }
    Ok(lock)
}

/// Checks before a command's work that the file `path` can be written
/// ([`bendscope::io::check_file_writable`]).
pub fn check_output_file(path: &Path) -> anyhow::Result<()> {
    bendscope::io::check_file_writable(path)?;
    Ok(())
}
