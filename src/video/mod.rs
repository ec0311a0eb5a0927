//! Frame sources: streaming video decode and H.264 encode (FFmpeg through ffmpeg-next).
//!
//! [`VideoReader`] decodes the best video stream of a file (GoPro telemetry and audio
//! streams are ignored) one frame at a time, with FFmpeg's frame threading switched on
//! explicitly (without it ffmpeg-next decodes on one thread), and converts only the
//! frames the caller asks for to RGB. A whole video is never held in memory. Packets
//! that fail to decode (corrupt or truncated files) are counted in [`DecodeStats`]
//! instead of aborting: what decodes is measured, the rest reported.
//!
//! [`VideoWriter`] encodes RGB frames to H.264 (libx264, yuv420p) in an MP4 container,
//! written under a temporary name and renamed on [`VideoWriter::finish`].
//!
//! One module per part, each re-exported here: `container` (FFmpeg's set-up and why an
//! MP4 file is cut short), `yuv` (decoded 4:2:0 frames kept in YUV at their native
//! depth), `decode` ([`VideoReader`]), `encode` ([`VideoWriter`]), `frames` (which frames
//! are measured, [`FrameSelection`]); `error` holds
//! [`VideoError`], which they share. Detection reads a [`YuvFrame`] through
//! `crate::detect::PixelSource`, implemented in `detect`.

mod container;
mod decode;
mod encode;
mod error;
mod frames;
mod yuv;

pub use container::mp4_truncation;
pub use decode::{sample_evenly, DecodeStats, Frame, Pixels, VideoInfo, VideoReader};
pub use encode::{EncodeSettings, VideoWriter};
pub use error::VideoError;
pub use frames::{FrameSelection, MAX_EVERY};
pub use yuv::{Sample, YuvFrame};
