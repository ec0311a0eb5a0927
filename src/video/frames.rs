//! Which frames of a video are decoded and measured (`[video] frames` in bendscope.toml):
//! every frame, every N-th frame, or key frames only.
//!
//! Key frames only is FFmpeg's own frame skipping (the decoder's `skip_frame` set to
//! `AVDISCARD_NONKEY` through ffmpeg-next): the decoder drops the other frames before
//! decoding them, which no stride can do, since an inter frame needs the frames before it.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// Largest N of `"every:N"`: one frame in a hundred thousand (an hour at 30 fps is
/// 108 000 frames); a larger N is a slip.
pub const MAX_EVERY: u64 = 100_000;

/// Which frames of a video are measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub enum FrameSelection {
    /// Every frame (`"all"`, the default).
    #[default]
    All,
    /// Key frames only (`"keyframes"`): the decoder skips the others, so a steady hold
    /// is measured on a few frames per second at a fraction of the decode time. Frames
    /// keep their index and time in the whole video.
    Keyframes,
    /// Every N-th frame (`"every:N"`, N >= 1): every frame is decoded (inter frames
    /// need their predecessors), every N-th is measured, as `frame_stride = N`.
    Every(u64),
}

impl FrameSelection {
    /// The stride of frame indices to measure: N for `"every:N"`, else 1.
    pub fn stride(self) -> u64 {
        match self {
            FrameSelection::Every(n) => n,
            _ => 1,
        }
    }
}

impl fmt::Display for FrameSelection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameSelection::All => f.write_str("all"),
            FrameSelection::Keyframes => f.write_str("keyframes"),
            FrameSelection::Every(n) => write!(f, "every:{n}"),
        }
    }
}

impl FromStr for FrameSelection {
    type Err = String;

    /// `"all"`, `"keyframes"` or `"every:N"` (any case, spaces around ignored).
    fn from_str(s: &str) -> Result<Self, String> {
        let text = s.trim().to_ascii_lowercase();
        let form = "use \"all\", \"keyframes\" or \"every:N\" (N a whole number of frames, \
                    e.g. \"every:5\")";
        match text.as_str() {
            "all" => return Ok(FrameSelection::All),
            "keyframes" => return Ok(FrameSelection::Keyframes),
            _ => {}
        }
        let Some(n) = text.strip_prefix("every:") else {
            return Err(format!("unknown frames `{s}`: {form}"));
        };
        match n.trim().parse::<u64>() {
            Ok(0) => Err(format!(
                "`{s}`: N must be at least 1 (every:1 is every frame)"
            )),
            Ok(n) if n > MAX_EVERY => Err(format!(
                "`{s}`: N must be at most {MAX_EVERY} frames, e.g. \"every:5\""
            )),
            Ok(n) => Ok(FrameSelection::Every(n)),
            Err(_) => Err(format!("`{s}`: N is not a whole number: {form}")),
        }
    }
}

impl TryFrom<String> for FrameSelection {
    type Error = String;

    fn try_from(s: String) -> Result<Self, String> {
        s.parse()
    }
}

impl From<FrameSelection> for String {
    fn from(f: FrameSelection) -> String {
        f.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_selections_parse_and_bad_ones_say_the_form() {
        for (text, want) in [
            ("all", FrameSelection::All),
            ("keyframes", FrameSelection::Keyframes),
            (" KeyFrames ", FrameSelection::Keyframes),
            ("every:1", FrameSelection::Every(1)),
            ("every:15", FrameSelection::Every(15)),
            ("every: 7", FrameSelection::Every(7)),
            ("every:100000", FrameSelection::Every(MAX_EVERY)),
        ] {
            assert_eq!(text.parse::<FrameSelection>(), Ok(want), "{text:?}");
            // Written back, read again: the same.
            assert_eq!(want.to_string().parse::<FrameSelection>(), Ok(want));
        }
        for (text, needle) in [
            (
                "keyframe",
                "unknown frames `keyframe`: use \"all\", \"keyframes\" or \"every:N\"",
            ),
            ("", "unknown frames ``"),
            ("every:0", "`every:0`: N must be at least 1"),
            ("every:-2", "`every:-2`: N is not a whole number"),
            ("every:2.5", "`every:2.5`: N is not a whole number"),
            ("every:", "`every:`: N is not a whole number"),
            ("every:100001", "N must be at most 100000 frames"),
        ] {
            let e = text.parse::<FrameSelection>().unwrap_err();
            assert!(e.contains(needle), "{text:?}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
        assert_eq!(FrameSelection::Every(4).stride(), 4);
        assert_eq!(FrameSelection::Keyframes.stride(), 1);
        assert_eq!(FrameSelection::default(), FrameSelection::All);
    }
}
