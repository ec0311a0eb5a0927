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
pub mod fixtures;
pub mod rng;
pub mod session;

pub use board::{random_board_poses, render_board_photo, BoardPose, PhotoSettings};

/// Errors of the renderers.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The camera model failed (OpenCV).
    #[error("camera model: {0}")]
    Camera(#[from] crate::calib::CalibError),
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
