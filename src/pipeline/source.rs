//! Frame sources behind one trait: a video file (decoded on its own thread, streamed
//! through a bounded channel, buffers recycled), an RGB-D folder (colour + aligned
//! depth frames, timed by their names or `frames.csv`) and a RealSense `.bag`
//! recording (colour + depth aligned here, timed by the header stamps): both RGB-D
//! sources yield the same (colour, aligned depth, time) frames.

use std::path::{Path, PathBuf};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::thread::JoinHandle;

use crate::rgbd::bag::BagRecording;
use crate::rgbd::RgbdFrame;
use crate::video::{DecodeStats, FrameSelection, Pixels, VideoInfo, VideoReader};

use super::frame::DepthImage;

/// A frame as a source delivers it.
#[derive(Debug)]
pub struct SourceFrame {
    /// Index (continuous within the source).
    pub index: u64,
    /// Time, s, on the source's clock.
    pub time_s: f64,
    /// Colour pixels as decoded.
    pub pixels: Pixels,
    /// Aligned depth (RGB-D sources only).
    pub depth: Option<DepthImage>,
}

/// What [`FrameSource::next`] returns.
#[derive(Debug)]
pub enum Next {
    /// A frame.
    Frame(SourceFrame),
    /// A frame that exists but cannot be used (unreadable file, wrong depth format).
    Bad {
        /// Index.
        index: u64,
        /// Time, s.
        time_s: f64,
        /// What is wrong and what to do.
        why: String,
    },
    /// No more frames.
    End,
}

/// A stream of frames of one measured item.
pub trait FrameSource {
    /// Frame size, px, known before the first frame.
    fn size(&self) -> (u32, u32);
    /// Frames it is expected to deliver (from the container; 0 when unknown), for
    /// progress.
    fn frames_expected(&self) -> u64 {
        0
    }
    /// The next frame.
    fn next(&mut self) -> Next;
    /// Gives back pixels the caller is done with, to be decoded into again.
    fn recycle(&mut self, _pixels: Pixels) {}
    /// Ends the source: the problems seen on the way (corrupt packets, a truncated
    /// file), each naming its file.
    fn finish(self: Box<Self>) -> Vec<String>;
}

/// Share of the frames a container states that must decode before a video counts as
/// complete (a few frames may be lost at the end of an edit list).
pub const TRUNCATION_SHARE: f64 = 0.98;

/// Decoded frames waiting for the measuring thread beside the one it works on and the
/// one the decoder offers. Each is a whole frame (25 MB at 4K 10-bit); FFmpeg's frame
/// threads already decode several frames ahead, so a deeper queue only costs memory.
pub const FRAMES_AHEAD: usize = 0;

/// What the decoder thread sends.
enum Decoded {
    Frame(u64, f64, Pixels),
    Failed(String),
}

/// A video file decoded on its own thread (FFmpeg contexts are not `Send`, so the reader
/// lives there), frames streamed through a bounded channel.
pub struct VideoSource {
    name: String,
    size: (u32, u32),
    frames_expected: u64,
    rx: Receiver<Decoded>,
    back: SyncSender<Pixels>,
    problems: Vec<String>,
    thread: Option<JoinHandle<(VideoInfo, DecodeStats)>>,
    /// Key frames only: the truncation check counts packets read, not frames decoded.
    keyframes: bool,
}

impl VideoSource {
    /// Opens `path`; the frames `frames` selects are delivered (every N-th, or the key
    /// frames only), as RGB when `want_rgb` (for whole-frame undistortion), else as
    /// decoded (YUV planes for 8-bit 4:2:0).
    pub fn open(path: &Path, frames: FrameSelection, want_rgb: bool) -> Result<Self, String> {
        let stride = frames.stride();
        let keyframes = frames == FrameSelection::Keyframes;
        let name = file_name(path);
        let (info_tx, info_rx) = sync_channel::<Result<(u32, u32, u64), String>>(1);
        let (tx, rx) = sync_channel::<Decoded>(FRAMES_AHEAD);
        let (back, back_rx) = sync_channel::<Pixels>(3);
        let path = path.to_path_buf();
        let thread = std::thread::spawn(move || {
            decode(&path, stride, keyframes, want_rgb, info_tx, tx, back_rx)
        });
        match info_rx.recv() {
            Ok(Ok((w, h, frames))) => Ok(Self {
                name,
                size: (w, h),
                frames_expected: frames.div_ceil(stride.max(1)),
                rx,
                back,
                problems: vec![],
                thread: Some(thread),
                keyframes,
            }),
            Ok(Err(e)) => {
                let _ = thread.join();
                Err(e)
            }
            Err(_) => {
                let _ = thread.join();
                Err(format!("{name}: the decoder stopped"))
            }
        }
    }
}

/// The decoder thread: opens the file, sends the size, then frames until the end or
/// until the receiver hangs up; returns the stream's info and decode health.
fn decode(
    path: &Path,
    stride: u64,
    keyframes: bool,
    want_rgb: bool,
    info_tx: SyncSender<Result<(u32, u32, u64), String>>,
    tx: SyncSender<Decoded>,
    back_rx: Receiver<Pixels>,
) -> (VideoInfo, DecodeStats) {
    let mut reader = match VideoReader::open(path) {
        Ok(r) => r,
        Err(e) => {
            let _ = info_tx.send(Err(e.to_string()));
            return (empty_info(), DecodeStats::default());
        }
    };
    if keyframes {
        reader.skip_non_key_frames();
    }
    let info = reader.info();
    let _ = info_tx.send(Ok((info.width, info.height, info.frame_count_estimate)));
    loop {
        let recycled = back_rx.try_recv().ok();
        let next = if want_rgb {
            let buf = match recycled {
                Some(Pixels::Rgb(i)) => Some(i),
                _ => None,
            };
            reader
                .next_frame_recycling(stride, buf)
                .map(|f| f.map(|f| (f.index, f.time_s, Pixels::Rgb(f.image))))
        } else {
            reader.next_pixels(stride, recycled)
        };
        let msg = match next {
            Ok(Some((index, time_s, pixels))) => Decoded::Frame(index, time_s, pixels),
            Ok(None) => break,
            Err(e) => Decoded::Failed(e.to_string()),
        };
        let failed = matches!(msg, Decoded::Failed(_));
        if tx.send(msg).is_err() || failed {
            break;
        }
    }
    (reader.info().clone(), reader.stats().clone())
}

fn empty_info() -> VideoInfo {
    VideoInfo {
        width: 0,
        height: 0,
        fps: 0.0,
        duration_s: 0.0,
        frame_count_estimate: 0,
        container_frames: 0,
        codec: String::new(),
    }
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

impl FrameSource for VideoSource {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn frames_expected(&self) -> u64 {
        self.frames_expected
    }

    fn next(&mut self) -> Next {
        match self.rx.recv() {
            Ok(Decoded::Frame(index, time_s, pixels)) => Next::Frame(SourceFrame {
                index,
                time_s,
                pixels,
                depth: None,
            }),
            Ok(Decoded::Failed(e)) => {
                self.problems.push(e);
                Next::End
            }
            Err(_) => Next::End,
        }
    }

    /// RGB buffers go back to the decoder thread to be converted into again; YUV
    /// frames are the decoder's own buffers, returned to its pool by dropping them here.
    fn recycle(&mut self, pixels: Pixels) {
        if matches!(pixels, Pixels::Rgb(_)) {
            let _ = self.back.try_send(pixels);
        }
    }

    fn finish(mut self: Box<Self>) -> Vec<String> {
        let mut problems = std::mem::take(&mut self.problems);
        let name = self.name.clone();
        // Hang up first so a decoder still running stops at its next frame.
        let Self {
            rx,
            back,
            thread,
            keyframes: self_keyframes,
            ..
        } = *self;
        drop(rx);
        drop(back);
        match thread.map(|t| t.join()) {
            Some(Ok((info, stats))) => {
                if stats.has_errors() {
                    problems.push(format!(
                        "{name}: {} corrupt packet(s){}; measured what decoded",
                        stats.packets_failed,
                        stats
                            .read_error
                            .map(|e| format!(", read error: {e}"))
                            .unwrap_or_default()
                    ));
                }
                // Key frames only: every packet is still read, the others are skipped.
                let seen = if self_keyframes {
                    stats.packets_read
                } else {
                    stats.frames_decoded
                };
                let stated = info.container_frames;
                if stated > 0 && (seen as f64) < TRUNCATION_SHARE * stated as f64 {
                    problems.push(format!(
                        "{name}: {seen} of the {stated} frames the container lists decoded: the file is truncated or corrupt (copy it again from the camera)"
                    ));
                }
            }
            Some(Err(_)) => problems.push(format!("{name}: the decoder thread failed")),
            None => {}
        }
        problems
    }
}

/// The frames of an RGB-D folder, read one at a time.
pub struct RgbdSource {
    frames: std::vec::IntoIter<RgbdFrame>,
    size: (u32, u32),
}

impl RgbdSource {
    /// The listed frames, expected at `size` (the intrinsics' frame size).
    pub fn new(frames: Vec<RgbdFrame>, size: (u32, u32)) -> Self {
        Self {
            frames: frames.into_iter(),
            size,
        }
    }
}

/// Reads one colour + depth pair, checking what a measurement needs.
fn read_pair(
    color: &Path,
    depth: Option<&PathBuf>,
    size: (u32, u32),
) -> Result<(Pixels, DepthImage), String> {
    let name = |p: &Path| {
        let parent = p
            .parent()
            .and_then(|d| d.file_name())
            .map(|d| d.to_string_lossy().into_owned())
            .unwrap_or_default();
        format!("{parent}/{}", file_name(p))
    };
    let depth_path = depth.ok_or_else(|| {
        format!(
            "no depth frame for {}: depth/ needs a 16-bit PNG of the same name",
            name(color)
        )
    })?;
    let rgb = image::open(color)
        .map_err(|e| format!("{}: unreadable colour frame ({e})", name(color)))?
        .into_rgb8();
    let depth = match image::open(depth_path)
        .map_err(|e| format!("{}: unreadable depth frame ({e})", name(depth_path)))?
    {
        image::DynamicImage::ImageLuma16(d) => d,
        other => {
            return Err(format!(
                "{}: depth frame is {:?}, not 16-bit grey: export depth as 16-bit PNG (z16)",
                name(depth_path),
                other.color()
            ))
        }
    };
    if rgb.dimensions() != size || depth.dimensions() != size {
        return Err(format!(
            "{}: colour {}x{} and depth {}x{} differ from the intrinsics' {}x{}: align depth to colour at the intrinsics' size",
            name(color),
            rgb.width(),
            rgb.height(),
            depth.width(),
            depth.height(),
            size.0,
            size.1
        ));
    }
    if depth.as_raw().iter().all(|&d| d == 0) {
        return Err(format!(
            "{}: depth frame has no valid pixel (all zero): check the depth stream",
            name(depth_path)
        ));
    }
    Ok((Pixels::Rgb(rgb), depth))
}

impl FrameSource for RgbdSource {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn next(&mut self) -> Next {
        let Some(f) = self.frames.next() else {
            return Next::End;
        };
        match read_pair(&f.color, f.depth.as_ref(), self.size) {
            Ok((pixels, depth)) => Next::Frame(SourceFrame {
                index: f.index,
                time_s: f.time_s,
                pixels,
                depth: Some(depth),
            }),
            Err(why) => Next::Bad {
                index: f.index,
                time_s: f.time_s,
                why,
            },
        }
    }

    fn finish(self: Box<Self>) -> Vec<String> {
        vec![]
    }
}

/// The frames of a RealSense `.bag` recording, read one at a time (colour decoded,
/// depth aligned to colour, see [`crate::rgbd::bag`]).
pub struct BagSource {
    recording: BagRecording,
    next: usize,
}

impl BagSource {
    /// Reads `recording`'s frames in time order.
    pub fn new(recording: BagRecording) -> Self {
        Self { recording, next: 0 }
    }
}

impl FrameSource for BagSource {
    fn size(&self) -> (u32, u32) {
        (
            self.recording.intrinsics.width,
            self.recording.intrinsics.height,
        )
    }

    fn next(&mut self) -> Next {
        let k = self.next;
        let Some((index, time_s)) = self.recording.frames.get(k).map(|f| (f.index, f.time_s))
        else {
            return Next::End;
        };
        self.next += 1;
        match self.recording.read_frame(k) {
            Ok((rgb, depth)) => Next::Frame(SourceFrame {
                index,
                time_s,
                pixels: Pixels::Rgb(rgb),
                depth: Some(depth),
            }),
            Err(why) => Next::Bad { index, time_s, why },
        }
    }

    fn finish(self: Box<Self>) -> Vec<String> {
        vec![]
    }
}

/// Reads a photo with its EXIF orientation applied (a phone stores portrait photos
/// landscape with a rotation tag).
///
/// A file that is empty, or a JPEG or PNG cut short before its end marker, is refused as
/// truncated: the JPEG decoder would fill the missing part with grey and the photo be
/// measured (or its markers missed) without a word. Errors are one line.
pub fn read_photo(path: &Path) -> Result<image::RgbImage, String> {
    use image::ImageDecoder as _;
    let name = file_name(path);
    let fail = |e: image::ImageError| {
        let e = e
            .to_string()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        format!("{name}: not a photo bendscope can read ({e}): use JPEG, PNG or TIFF")
    };
    let bytes = std::fs::read(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::PermissionDenied => {
            format!("{name}: permission denied: make the file readable (chmod a+r)")
        }
        _ => format!("{name}: cannot read ({e})"),
    })?;
    if bytes.is_empty() {
        return Err(format!(
            "{name}: empty or truncated (copy it again from the camera)"
        ));
    }
    if let Some(why) = crate::calib::corners::truncation(&bytes) {
        return Err(format!(
            "{name}: truncated ({why}): copy it again from the camera"
        ));
    }
    let reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| format!("{name}: cannot read ({e})"))?;
    let mut decoder = reader.into_decoder().map_err(fail)?;
    let orientation = decoder.orientation().map_err(fail)?;
    let mut img = image::DynamicImage::from_decoder(decoder).map_err(fail)?;
    img.apply_orientation(orientation);
    Ok(img.into_rgb8())
}

/// Photos as frames: one photo, or every photo of a folder (a burst at one pressure),
/// in name order; frame i is at time i s. All must have the size of the first.
pub struct PhotoSource {
    photos: std::vec::IntoIter<PathBuf>,
    first: Option<image::RgbImage>,
    size: (u32, u32),
    index: u64,
}

impl PhotoSource {
    /// `path`: a photo, or a folder of photos.
    pub fn open(path: &Path) -> Result<Self, String> {
        let mut photos: Vec<PathBuf> = if path.is_dir() {
            std::fs::read_dir(path)
                .map_err(|e| format!("{}: {e}", path.display()))?
                .flatten()
                .map(|e| e.path())
                .filter(|p| p.is_file() && crate::session::is_photo(p))
                .collect()
        } else {
            vec![path.to_path_buf()]
        };
        photos.sort();
        let mut photos = photos.into_iter();
        let first_path = photos.next().ok_or_else(|| {
            format!(
                "{}: no photos (JPEG, PNG or TIFF) in this folder",
                path.display()
            )
        })?;
        let first = read_photo(&first_path)?;
        Ok(Self {
            size: first.dimensions(),
            first: Some(first),
            photos,
            index: 0,
        })
    }
}

impl FrameSource for PhotoSource {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn next(&mut self) -> Next {
        let index = self.index;
        let image = match self.first.take() {
            Some(img) => Ok(img),
            None => match self.photos.next() {
                Some(p) => read_photo(&p).and_then(|img| {
                    if img.dimensions() == self.size {
                        Ok(img)
                    } else {
                        Err(format!(
                            "{}: {}x{} differs from the first photo's {}x{}: keep one camera mode per burst",
                            file_name(&p),
                            img.width(),
                            img.height(),
                            self.size.0,
                            self.size.1
                        ))
                    }
                }),
                None => return Next::End,
            },
        };
        self.index += 1;
        match image {
            Ok(img) => Next::Frame(SourceFrame {
                index,
                time_s: index as f64,
                pixels: Pixels::Rgb(img),
                depth: None,
            }),
            Err(why) => Next::Bad {
                index,
                time_s: index as f64,
                why,
            },
        }
    }

    fn finish(self: Box<Self>) -> Vec<String> {
        vec![]
    }
}

/// Opens a manifest item's file: a video, a photo, or a folder of photos.
pub fn open_source(
    path: &Path,
    frames: FrameSelection,
    want_rgb: bool,
) -> Result<Box<dyn FrameSource>, String> {
    if path.is_dir() || crate::session::is_photo(path) {
        Ok(Box::new(PhotoSource::open(path)?))
    } else {
        Ok(Box::new(VideoSource::open(path, frames, want_rgb)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 64x48 JPEG of a gradient (big enough that its scan holds most of the file).
    fn jpeg_bytes() -> Vec<u8> {
        let img = image::RgbImage::from_fn(64, 48, |x, y| {
            image::Rgb([(x * 4) as u8, (y * 5) as u8, ((x + y) * 2) as u8])
        });
        let mut buf = std::io::Cursor::new(Vec::new());
        img.write_to(&mut buf, image::ImageFormat::Jpeg).unwrap();
        buf.into_inner()
    }

    #[test]
    fn empty_and_truncated_photos_are_refused_in_one_line() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("p1.jpg");
        let full = jpeg_bytes();
        std::fs::write(&p, &full).unwrap();
        assert_eq!(read_photo(&p).unwrap().dimensions(), (64, 48));
        std::fs::write(&p, b"").unwrap();
        assert_eq!(
            read_photo(&p).unwrap_err(),
            "p1.jpg: empty or truncated (copy it again from the camera)"
        );
        // Cut to 82% and 49%: the decoder would return a grey-filled picture.
        for share in [0.82, 0.49] {
            let cut = (full.len() as f64 * share) as usize;
            std::fs::write(&p, &full[..cut]).unwrap();
            let e = read_photo(&p).unwrap_err();
            assert!(
                e.starts_with("p1.jpg: truncated (")
                    && e.ends_with("): copy it again from the camera"),
                "{share}: {e}"
            );
        }
        // Not an image at all: one line, however the decoder words it.
        std::fs::write(
            &p,
            b"\xFF\xD8\xFF\xE0\x00\x10JFIF\x00\x01\x01\x00\x00\x01\x00\x01\x00\x00\xFF\xD9",
        )
        .unwrap();
        let e = read_photo(&p).unwrap_err();
        assert!(
            e.starts_with("p1.jpg: not a photo bendscope can read"),
            "{e}"
        );
        assert!(!e.contains('\n'), "{e}");
    }
}
