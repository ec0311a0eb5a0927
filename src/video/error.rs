//! The errors of video decoding and encoding, one enum for both.

use std::path::PathBuf;

/// Errors of video decoding and encoding.
#[derive(Debug, thiserror::Error)]
pub enum VideoError {
    /// The file does not exist.
    #[error("{path}: no such file")]
    Missing {
        /// The file.
        path: PathBuf,
    },
    /// FFmpeg cannot read the file as a video.
    #[error(
        "{path}: not a video FFmpeg can read ({reason}): check the file, or re-export it as MP4"
    )]
    NotAVideo {
        /// The file.
        path: PathBuf,
        /// FFmpeg's reason.
        reason: String,
    },
    /// The file is cut short (an interrupted copy or recording).
    #[error("{path}: {why}: copy it again from the camera")]
    Truncated {
        /// The file.
        path: PathBuf,
        /// What is missing.
        why: String,
    },
    /// Encoding failed.
    #[error("{path}: cannot encode video ({reason})")]
    Encode {
        /// The output file.
        path: PathBuf,
        /// What failed.
        reason: String,
    },
    /// An RGB frame of the wrong size was given to the writer.
    #[error("{path}: frame is {got_width}x{got_height}, the video is {width}x{height}")]
    FrameSize {
        /// The output file.
        path: PathBuf,
        /// Frame width.
        got_width: u32,
        /// Frame height.
        got_height: u32,
        /// Video width.
        width: u32,
        /// Video height.
        height: u32,
    },
}
