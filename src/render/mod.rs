//! Synthetic camera images with known ground truth.
//!
//! Every pixel is traced back through the calibrated lens model (OpenCV's point
//! undistortion gives each sub-pixel sample its viewing ray) into a posed scene, so the
//! images carry the lens distortion exactly as the model defines it. Images are
//! supersampled, blurred and given sensor noise. Random numbers come from a small
//! SplitMix64 generator written here (not the `rand` crate) so fixtures are reproducible
//! byte for byte whatever crate versions are resolved.

pub mod actuator;
pub mod board;
pub mod fem_scene;
pub mod fixtures;
pub mod rng;
pub mod session;

pub use board::{random_board_poses, render_board_photo, BoardPose, PhotoSettings};

impl RenderError {
    /// `e`, met writing into the folder `dir` (or a file in it), as [`RenderError::Write`]:
    /// the path once and what to do ([`crate::io::write_advice`]).
    pub fn write(dir: &std::path::Path, e: &std::io::Error) -> Self {
        let name = dir.display().to_string();
        let text = e.to_string();
        let advice = crate::io::write_advice(dir, e);
        let why = if text.starts_with(&name) {
            text
        } else if advice.contains(&name) {
            advice
        } else {
            format!("{name}: {advice}")
        };
        RenderError::Write { why }
    }
}

/// Errors of the renderers.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The camera model failed (OpenCV).
    #[error("camera model: {0}")]
    Camera(#[from] crate::calib::CalibError),
    /// The simulated actuator does not fit in the view.
    #[error("the actuator ({width_mm:.0} x {height_mm:.0} mm over all steps) does not fit in the camera's view at {distance_mm} mm: use --distance-mm {suggested_mm:.0} or more")]
    DoesNotFit {
        /// Extent along x, mm.
        width_mm: f64,
        /// Extent along y, mm.
        height_mm: f64,
        /// Distance asked for, mm.
        distance_mm: f64,
        /// A distance at which it fits, mm.
        suggested_mm: f64,
    },
    /// A file of the session could not be written.
    #[error("cannot write the session: {why}")]
    Write {
        /// The file or folder and what to do.
        why: String,
    },
    /// The FEM output cannot be rendered.
    #[error("{0}")]
    Fem(String),
    /// The output folder already holds a session that rendering would replace.
    #[error("{dir} already holds a session ({files}): render into a new folder, or give --force to replace its videos, scale photo, pressures.csv and calib/")]
    SessionExists {
        /// The output folder.
        dir: std::path::PathBuf,
        /// The session files found there, listed for the message.
        files: String,
    },
    /// No pose put the board fully inside the frame.
    #[error("could not place the board inside the {width}x{height} frame after {tries} tries: use a smaller board or a wider lens")]
    NoPose {
        /// Frame width.
        width: u32,
        /// Frame height.
        height: u32,
        /// Attempts made.
        tries: usize,
    },
}
