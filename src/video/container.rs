//! The container side of reading a video: FFmpeg's one-time set-up, and why an MP4/MOV
//! file is cut short.
//!
//! The top-level boxes are walked by hand (a few header reads, no MP4 crate) only to
//! name the cause when FFmpeg refuses a file, so the message can say what to do (copy the
//! file again) instead of FFmpeg's generic error.

use std::path::Path;
use std::sync::Once;

use ffmpeg_next as ffmpeg;

/// Why an MP4/MOV file is cut short, or `None` when its top-level boxes are whole (or
/// it is not an ISO media file): an empty file, a box that runs past the end of the file
/// (the index, `moov`, is written last unless the file was made with faststart), or no
/// index at all.
pub fn mp4_truncation(path: &Path) -> Option<String> {
    use std::io::{Read, Seek, SeekFrom};
    /// Box types that may come first in an MP4 or QuickTime file.
    const FIRST: [&[u8; 4]; 6] = [b"ftyp", b"wide", b"free", b"skip", b"mdat", b"moov"];
    let mut f = std::fs::File::open(path).ok()?;
    let len = f.metadata().ok()?.len();
    if len == 0 {
        return Some("the file is empty (0 bytes)".into());
    }
    let (mut pos, mut first, mut index) = (0u64, true, false);
    while pos < len {
        let mut head = [0u8; 16];
        f.seek(SeekFrom::Start(pos)).ok()?;
        let got = f.read(&mut head).ok()?;
        if got < 8 {
            break;
        }
        let kind: [u8; 4] = head[4..8].try_into().ok()?;
        if first && !FIRST.contains(&&kind) {
            return None;
        }
        first = false;
        index |= &kind == b"moov";
        let size = match u32::from_be_bytes(head[..4].try_into().ok()?) as u64 {
            0 => len - pos,
            1 if got >= 16 => u64::from_be_bytes(head[8..16].try_into().ok()?),
            1 => break,
            s => s,
        };
        if size < 8 {
            return None;
        }
        if pos + size > len {
            let name = String::from_utf8_lossy(&kind).into_owned();
            return Some(if index {
                format!("truncated: the file ends inside its '{name}' box")
            } else {
                format!("truncated: the file ends inside its '{name}' box, before its index (moov)")
            });
        }
        pos += size;
    }
    (!first && !index).then(|| "truncated: the file has no index (moov box)".to_string())
}

static INIT: Once = Once::new();

/// Initializes FFmpeg once and keeps its own logging quiet (bendscope reports decode
/// problems itself, one line per video).
pub(super) fn init() {
    INIT.call_once(|| {
        let _ = ffmpeg::init();
        ffmpeg::util::log::set_level(ffmpeg::util::log::Level::Quiet);
    });
}
