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

use std::path::{Path, PathBuf};
use std::sync::{Arc, Once};

use ffmpeg::format::Pixel;
use ffmpeg::software::scaling;
use ffmpeg_next as ffmpeg;
use image::RgbImage;

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

static INIT: Once = Once::new();

/// Initializes FFmpeg once and keeps its own logging quiet (bendscope reports decode
/// problems itself, one line per video).
fn init() {
    INIT.call_once(|| {
        let _ = ffmpeg::init();
        ffmpeg::util::log::set_level(ffmpeg::util::log::Level::Quiet);
    });
}

/// What a video holds.
#[derive(Debug, Clone, PartialEq)]
pub struct VideoInfo {
    /// Frame width, px.
    pub width: u32,
    /// Frame height, px.
    pub height: u32,
    /// Frames per second (average).
    pub fps: f64,
    /// Duration, s (0 when unknown).
    pub duration_s: f64,
    /// Frame count from the container, or duration x fps.
    pub frame_count_estimate: u64,
    /// Frame count the container states (MP4 `nb_frames`), 0 when it states none: a
    /// file that decodes to fewer frames is truncated or corrupt.
    pub container_frames: u64,
    /// Codec name, e.g. `h264`, `hevc`.
    pub codec: String,
}

/// One decoded frame.
#[derive(Debug, Clone)]
pub struct Frame {
    /// 0-based index in decode (display) order.
    pub index: u64,
    /// Presentation time from the stream's timestamps, s (index / fps when missing).
    pub time_s: f64,
    /// The frame, RGB.
    pub image: RgbImage,
}

mod sealed {
    /// Only the sample types below: [`super::YuvFrame`] reads decoder buffers as them.
    pub trait Sealed {}
    impl Sealed for u8 {}
    impl Sealed for u16 {}
}

/// A sample of a YUV plane: 8-bit, or 10-bit in 16 bits (HEVC Main 10, as recent
/// GoPros record). Conversions work at the sample's own depth. Sealed: implemented for
/// `u8` and `u16` only, types for which every bit pattern is a value.
pub trait Sample:
    sealed::Sealed + Copy + Default + Ord + Send + Sync + std::fmt::Debug + 'static
{
    /// Bits beyond 8 (0 for 8-bit samples, 2 for 10-bit ones).
    const EXTRA_BITS: u32;
    /// The sample's value.
    fn value(self) -> i32;
    /// The sample of value `v`, saturated to the type's range.
    fn saturated(v: i32) -> Self;
}

impl Sample for u8 {
    const EXTRA_BITS: u32 = 0;
    #[inline]
    fn value(self) -> i32 {
        self as i32
    }
    fn saturated(v: i32) -> Self {
        v.clamp(0, u8::MAX as i32) as u8
    }
}

impl Sample for u16 {
    const EXTRA_BITS: u32 = 2;
    #[inline]
    fn value(self) -> i32 {
        self as i32
    }
    fn saturated(v: i32) -> Self {
        v.clamp(0, u16::MAX as i32) as u16
    }
}

/// Cr samples scanned together by [`YuvFrame`]'s coarse pass: the largest of a chunk is
/// compared first (a vectorized max), and a chunk below the pre-test is skipped whole.
const CR_CHUNK: usize = 32;

/// Where a [`YuvFrame`]'s samples live.
#[derive(Clone)]
enum Planes<T> {
    /// Y, Cb, Cr copied into vectors.
    Owned([Vec<T>; 3]),
    /// The decoder's own frame: its buffers are reference-counted and go back to
    /// FFmpeg's pool when the last holder drops it, so a 4K frame is never copied (a
    /// 10-bit 4K frame is 25 MB; copying it cost ~3% of the run and a buffer per frame
    /// in flight).
    Decoded(Arc<ffmpeg::frame::Video>),
}

/// A decoded 4:2:0 frame kept in YUV at its native depth: detection reads the
/// quarter-size Cr plane first and converts to RGB only the pixels that may be red,
/// instead of converting whole frames. BT.601, limited or full range. `T` is `u8` for
/// 8-bit streams, `u16` for 10-bit ones. The planes are the decoder's buffers (no copy)
/// or owned vectors ([`YuvFrame::from_planes`]).
#[derive(Clone)]
pub struct YuvFrame<T: Sample = u8> {
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// Full-range (JPEG) levels instead of limited (16..235).
    pub full_range: bool,
    planes: Planes<T>,
    /// Row strides of Y, Cb, Cr, samples.
    strides: [usize; 3],
}

impl<T: Sample> Default for YuvFrame<T> {
    fn default() -> Self {
        Self {
            width: 0,
            height: 0,
            full_range: false,
            planes: Planes::Owned([vec![], vec![], vec![]]),
            strides: [0; 3],
        }
    }
}

impl<T: Sample> std::fmt::Debug for YuvFrame<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("YuvFrame")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("full_range", &self.full_range)
            .field("zero_copy", &matches!(self.planes, Planes::Decoded(_)))
            .finish()
    }
}

impl<T: Sample> YuvFrame<T> {
    /// A frame from packed planes: `y` is `width` x `height`, `u` and `v` are
    /// ceil(width/2) x ceil(height/2); `None` when a plane is too short.
    pub fn from_planes(
        width: u32,
        height: u32,
        y: Vec<T>,
        u: Vec<T>,
        v: Vec<T>,
        full_range: bool,
    ) -> Option<Self> {
        let (w, h) = (width as usize, height as usize);
        let (cw, ch) = (w.div_ceil(2), h.div_ceil(2));
        (y.len() >= w * h && u.len() >= cw * ch && v.len() >= cw * ch).then(|| Self {
            width,
            height,
            full_range,
            planes: Planes::Owned([y, u, v]),
            strides: [w, cw, cw],
        })
    }

    /// The decoder's frame itself when its three planes can be read as `T` samples in
    /// place (aligned, whole-sample strides, little-endian for 16-bit samples), else
    /// `None`.
    fn from_decoded(frame: ffmpeg::frame::Video, full_range: bool) -> Option<Self> {
        let bytes = std::mem::size_of::<T>();
        if frame.planes() < 3 || (bytes > 1 && cfg!(target_endian = "big")) {
            return None;
        }
        let (w, h) = (frame.width() as usize, frame.height() as usize);
        let (cw, ch) = (w.div_ceil(2), h.div_ceil(2));
        let mut strides = [0; 3];
        for (i, (row, rows)) in [(w, h), (cw, ch), (cw, ch)].into_iter().enumerate() {
            let data = frame.data(i);
            let stride = frame.stride(i);
            let aligned = (data.as_ptr() as usize).is_multiple_of(std::mem::align_of::<T>());
            if !aligned || !stride.is_multiple_of(bytes) || stride < row * bytes {
                return None;
            }
            if data.len() < (rows.max(1) - 1) * stride + row * bytes {
                return None;
            }
            strides[i] = stride / bytes;
        }
        Some(Self {
            width: frame.width(),
            height: frame.height(),
            full_range,
            planes: Planes::Decoded(Arc::new(frame)),
            strides,
        })
    }

    /// Plane `i` (0 Y, 1 Cb, 2 Cr) as samples, rows [`Self::strides`] apart.
    #[inline]
    fn plane(&self, i: usize) -> &[T] {
        match &self.planes {
            Planes::Owned(p) => &p[i],
            Planes::Decoded(f) => {
                let data = f.data(i);
                // SAFETY: `T` is u8 or u16 (Sample is sealed), for which every bit
                // pattern is a valid value; `from_decoded` checked that the plane is
                // aligned for `T`; the length stays within `data`.
                unsafe {
                    std::slice::from_raw_parts(
                        data.as_ptr() as *const T,
                        data.len() / std::mem::size_of::<T>(),
                    )
                }
            }
        }
    }

    /// RGB at (x, y): BT.601, chroma of the 2x2 block the pixel belongs to; integer
    /// arithmetic at the samples' depth, rounded once to 8 bits.
    #[inline]
    pub fn rgb_at(&self, x: u32, y: u32) -> [u8; 3] {
        let (cy, cx) = (y as usize / 2, x as usize / 2);
        self.rgb_of(
            self.plane(0)[y as usize * self.strides[0] + x as usize],
            self.plane(1)[cy * self.strides[1] + cx],
            self.plane(2)[cy * self.strides[2] + cx],
        )
    }

    /// RGB of one luma and its chroma samples (the conversion of [`Self::rgb_at`], for
    /// callers that hold the planes' rows: a plane lookup asks FFmpeg for the pixel
    /// format's descriptor).
    #[inline]
    fn rgb_of(&self, luma: T, cb: T, cr: T) -> [u8; 3] {
        let k = T::EXTRA_BITS;
        let yy = luma.value();
        let (d, e) = (cb.value() - (128 << k), cr.value() - (128 << k));
        let (r, g, b) = if self.full_range {
            let c = yy << 8;
            (c + 359 * e, c - 88 * d - 183 * e, c + 454 * d)
        } else {
            let c = 298 * (yy - (16 << k));
            (c + 409 * e, c - 100 * d - 208 * e, c + 516 * d)
        };
        let q = |v: i32| ((v + (128 << k)) >> (8 + k)).clamp(0, 255) as u8;
        [q(r), q(g), q(b)]
    }

    /// The whole frame in RGB (for overlays and full-frame undistortion).
    pub fn to_rgb(&self) -> RgbImage {
        RgbImage::from_fn(self.width, self.height, |x, y| {
            image::Rgb(self.rgb_at(x, y))
        })
    }
}

impl<T: Sample> crate::detect::PixelSource for YuvFrame<T> {
    fn dimensions(&self) -> (u32, u32) {
        (self.width, self.height)
    }
    #[inline]
    fn rgb(&self, x: u32, y: u32) -> image::Rgb<u8> {
        image::Rgb(self.rgb_at(x, y))
    }
    #[inline]
    fn is_marker_at(&self, x: u32, y: u32, t: &crate::detect::MarkerTest) -> bool {
        use crate::detect::Pretest;
        let k = T::EXTRA_BITS;
        let (cy, cx) = (y as usize / 2, x as usize / 2);
        let cb = self.plane(1)[cy * self.strides[1] + cx];
        let cr = self.plane(2)[cy * self.strides[2] + cx];
        let luma = || self.plane(0)[y as usize * self.strides[0] + x as usize];
        let pass = match t.pretest {
            Pretest::None => true,
            Pretest::Chroma { a, b, k: bound } => {
                a * (cb.value() - (128 << k)) + b * (cr.value() - (128 << k)) >= bound << k
            }
            Pretest::Luma { limited, full } => {
                let bound = if self.full_range { full } else { limited };
                luma().value() <= bound << k
            }
        };
        if !pass {
            return false;
        }
        let [r, g, b] = self.rgb_of(luma(), cb, cr);
        t.matches(r, g, b)
    }
    /// The coarse pass on the chroma row under row `y` (or the luma row for dark
    /// markers): the coarse grid (every second pixel of every second row) is the chroma
    /// grid, so each coarse pixel has its own chroma sample; chunks of samples that fail
    /// the pre-test are skipped without converting a pixel.
    fn coarse_row_hits(&self, y: u32, t: &crate::detect::MarkerTest, out: &mut Vec<u32>) {
        use crate::detect::Pretest;
        const { assert!(crate::detect::COARSE_STEP == 2) };
        let k = T::EXTRA_BITS;
        let cw = self.width.div_ceil(2) as usize;
        let cy = y as usize / 2;
        let chroma_row = |i: usize| -> Option<&[T]> {
            let start = cy * self.strides[i];
            self.plane(i).get(start..start + cw)
        };
        if t.pretest == Pretest::None {
            crate::detect::coarse_row_hits_exact(self, y, t, out);
            return;
        }
        let (Some(cb), Some(cr)) = (chroma_row(1), chroma_row(2)) else {
            return;
        };
        let luma_start = y as usize * self.strides[0];
        let Some(luma) = self
            .plane(0)
            .get(luma_start..luma_start + self.width as usize)
        else {
            return;
        };
        // A sample that passed the pre-test gets the band's exact test, converted from
        // the rows held here.
        let mut hit = |i: usize| {
            let x = 2 * i;
            if x < luma.len() {
                let [r, g, b] = self.rgb_of(luma[x], cb[i], cr[i]);
                if t.matches(r, g, b) {
                    out.push(x as u32);
                }
            }
        };
        match t.pretest {
            Pretest::None => {}
            Pretest::Chroma { a, b, k: bound } => {
                let (mid, bound) = (128 << k, bound << k);
                match (a, b) {
                    // One plane: the bound as a sample value, chunks by their max or min.
                    (0, w) | (w, 0) => {
                        let plane = if a == 0 { cr } else { cb };
                        // w (s - mid) >= bound: s at least (or, w < 0, at most) mid
                        // +- ceil(bound / |w|) (bound > 0).
                        let q = (bound + w.abs() - 1).div_euclid(w.abs());
                        if w > 0 {
                            let thr = T::saturated(mid + q);
                            scan_chunks(
                                cw,
                                |r| plane[r].iter().fold(T::default(), |m, &s| m.max(s)) < thr,
                                |i| plane[i] >= thr,
                                &mut hit,
                            );
                        } else {
                            let thr = T::saturated(mid - q);
                            let top = T::saturated(i32::MAX);
                            scan_chunks(
                                cw,
                                |r| plane[r].iter().fold(top, |m, &s| m.min(s)) > thr,
                                |i| plane[i] <= thr,
                                &mut hit,
                            );
                        }
                    }
                    (a, b) => {
                        let score =
                            |i: usize| a * (cb[i].value() - mid) + b * (cr[i].value() - mid);
                        // A chunk's best score is at most the sum of each plane's best
                        // term, met at the plane's extreme sample in its weight's
                        // direction: two min/max folds over the samples (which the
                        // compiler vectorizes, unlike the weighted sum) skip a chunk.
                        let top = T::saturated(i32::MAX);
                        let best = |plane: &[T], w: i32, r: std::ops::Range<usize>| {
                            let s = &plane[r];
                            let v = if w > 0 {
                                s.iter().fold(T::default(), |m, &x| m.max(x))
                            } else {
                                s.iter().fold(top, |m, &x| m.min(x))
                            };
                            w * (v.value() - mid)
                        };
                        scan_chunks(
                            cw,
                            |r| best(cb, a, r.clone()) + best(cr, b, r) < bound,
                            |i| score(i) >= bound,
                            &mut hit,
                        );
                    }
                }
            }
            Pretest::Luma { limited, full } => {
                let bound = T::saturated((if self.full_range { full } else { limited }) << k);
                let row = luma;
                scan_chunks(
                    cw,
                    |r| {
                        row[2 * r.start..(2 * r.end).min(row.len())]
                            .iter()
                            .step_by(2)
                            .fold(T::saturated(i32::MAX), |m, &s| m.min(s))
                            > bound
                    },
                    |i| row[2 * i] <= bound,
                    &mut hit,
                );
            }
        }
    }
}

/// The coarse samples `0..n` in chunks of [`CR_CHUNK`]: a chunk that `fails` (no sample
/// can pass the pre-test) is skipped, else `hit` gets each sample that `passes`.
#[inline]
fn scan_chunks(
    n: usize,
    fails: impl Fn(std::ops::Range<usize>) -> bool,
    passes: impl Fn(usize) -> bool,
    hit: &mut impl FnMut(usize),
) {
    for c0 in (0..n).step_by(CR_CHUNK) {
        let c1 = (c0 + CR_CHUNK).min(n);
        if fails(c0..c1) {
            continue;
        }
        for i in c0..c1 {
            if passes(i) {
                hit(i);
            }
        }
    }
}

/// A decoded frame's pixels: kept in YUV when the stream is 8- or 10-bit 4:2:0, else
/// RGB.
#[derive(Debug, Clone)]
pub enum Pixels {
    /// 8-bit 4:2:0 planes.
    Yuv(YuvFrame<u8>),
    /// 10-bit 4:2:0 planes.
    Yuv10(YuvFrame<u16>),
    /// RGB (other pixel formats, converted by swscale).
    Rgb(RgbImage),
}

impl Pixels {
    /// The frame in RGB.
    pub fn to_rgb(&self) -> RgbImage {
        match self {
            Pixels::Yuv(f) => f.to_rgb(),
            Pixels::Yuv10(f) => f.to_rgb(),
            Pixels::Rgb(i) => i.clone(),
        }
    }
}

/// Decode health of a video.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DecodeStats {
    /// Frames decoded.
    pub frames_decoded: u64,
    /// Packets the decoder refused (corrupt data).
    pub packets_failed: u64,
    /// The demuxer stopped with an error before the end of the file (truncated file).
    pub read_error: Option<String>,
}

impl DecodeStats {
    /// True when anything went wrong.
    pub fn has_errors(&self) -> bool {
        self.packets_failed > 0 || self.read_error.is_some()
    }
}

/// Streaming decoder of a video file's best video stream.
pub struct VideoReader {
    path: PathBuf,
    input: ffmpeg::format::context::Input,
    stream_index: usize,
    decoder: ffmpeg::decoder::Video,
    scaler: Option<scaling::Context>,
    time_base: f64,
    info: VideoInfo,
    stats: DecodeStats,
    next_index: u64,
    eof_sent: bool,
    finished: bool,
    decoded: ffmpeg::frame::Video,
}

impl VideoReader {
    /// Opens `path` and prepares a threaded decoder for its best video stream.
    pub fn open(path: &Path) -> Result<Self, VideoError> {
        init();
        if !path.is_file() {
            return Err(VideoError::Missing {
                path: path.to_path_buf(),
            });
        }
        let not_video = |reason: String| VideoError::NotAVideo {
            path: path.to_path_buf(),
            reason,
        };
        let input = ffmpeg::format::input(&path).map_err(|e| {
            // Why FFmpeg cannot open it, when the file is cut short.
            match mp4_truncation(path) {
                Some(why) => VideoError::Truncated {
                    path: path.to_path_buf(),
                    why,
                },
                None => not_video(e.to_string()),
            }
        })?;
        let stream = input
            .streams()
            .best(ffmpeg::media::Type::Video)
            .ok_or_else(|| not_video("no video stream".to_string()))?;
        let stream_index = stream.index();
        let tb = stream.time_base();
        let time_base = if tb.denominator() != 0 {
            tb.numerator() as f64 / tb.denominator() as f64
        } else {
            0.0
        };
        let rate = stream.avg_frame_rate();
        let mut fps = if rate.denominator() != 0 {
            rate.numerator() as f64 / rate.denominator() as f64
        } else {
            0.0
        };
        let mut ctx = ffmpeg::codec::context::Context::from_parameters(stream.parameters())
            .map_err(|e| not_video(e.to_string()))?;
        ctx.set_threading(ffmpeg::codec::threading::Config {
            kind: ffmpeg::codec::threading::Type::Frame,
            count: 0,
            ..Default::default()
        });
        let decoder = ctx
            .decoder()
            .video()
            .map_err(|e| not_video(format!("no decoder: {e}")))?;
        if !(fps.is_finite() && fps > 0.0) {
            let r = decoder.frame_rate().unwrap_or(ffmpeg::Rational(0, 1));
            fps = if r.denominator() != 0 {
                r.numerator() as f64 / r.denominator() as f64
            } else {
                0.0
            };
        }
        let duration_s = if stream.duration() > 0 {
            stream.duration() as f64 * time_base
        } else if input.duration() > 0 {
            input.duration() as f64 / ffmpeg::ffi::AV_TIME_BASE as f64
        } else {
            0.0
        };
        let frame_count_estimate = if stream.frames() > 0 {
            stream.frames() as u64
        } else {
            (duration_s * fps).round().max(0.0) as u64
        };
        let codec = decoder
            .codec()
            .map(|c| c.name().to_string())
            .unwrap_or_else(|| format!("{:?}", decoder.id()).to_lowercase());
        if decoder.width() == 0 || decoder.height() == 0 {
            return Err(not_video("zero frame size".to_string()));
        }
        let info = VideoInfo {
            width: decoder.width(),
            height: decoder.height(),
            fps,
            duration_s,
            frame_count_estimate,
            container_frames: stream.frames().max(0) as u64,
            codec,
        };
        Ok(Self {
            path: path.to_path_buf(),
            input,
            stream_index,
            decoder,
            scaler: None,
            time_base,
            info,
            stats: DecodeStats::default(),
            next_index: 0,
            eof_sent: false,
            finished: false,
            decoded: ffmpeg::frame::Video::empty(),
        })
    }

    /// The stream's properties.
    pub fn info(&self) -> &VideoInfo {
        &self.info
    }

    /// Decode health so far.
    pub fn stats(&self) -> &DecodeStats {
        &self.stats
    }

    /// The file being read.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Decodes up to the next frame; returns its index and time, or `None` at the end.
    /// The frame stays available to [`Self::current_rgb`] until the next call.
    pub fn advance(&mut self) -> Option<(u64, f64)> {
        loop {
            if self.finished {
                return None;
            }
            if self.decoder.receive_frame(&mut self.decoded).is_ok() {
                let index = self.next_index;
                self.next_index += 1;
                self.stats.frames_decoded += 1;
                let time_s = match self.decoded.timestamp() {
                    Some(ts) if self.time_base > 0.0 => ts as f64 * self.time_base,
                    _ if self.info.fps > 0.0 => index as f64 / self.info.fps,
                    _ => 0.0,
                };
                return Some((index, time_s));
            }
            if self.eof_sent {
                self.finished = true;
                return None;
            }
            self.feed();
        }
    }

    /// Sends the next packet of the video stream to the decoder (or end of stream).
    fn feed(&mut self) {
        let mut packet = ffmpeg::Packet::empty();
        loop {
            match packet.read(&mut self.input) {
                Ok(()) => {
                    if packet.stream() != self.stream_index {
                        continue;
                    }
                    if self.decoder.send_packet(&packet).is_err() {
                        self.stats.packets_failed += 1;
                    }
                    return;
                }
                Err(ffmpeg::Error::Eof) => break,
                Err(ffmpeg::Error::Other { errno }) if errno == ffmpeg::util::error::EAGAIN => {
                    continue
                }
                Err(e) => {
                    self.stats.read_error = Some(e.to_string());
                    break;
                }
            }
        }
        let _ = self.decoder.send_eof();
        self.eof_sent = true;
    }

    /// The frame last returned by [`Self::advance`], converted to RGB.
    pub fn current_rgb(&mut self) -> Result<RgbImage, VideoError> {
        self.current_rgb_into(Vec::new())
    }

    /// Like [`Self::current_rgb`], converting into `buf`'s allocation when it is large
    /// enough (a caller recycling its frames avoids a fresh multi-megabyte allocation,
    /// and its page faults, per frame).
    pub fn current_rgb_into(&mut self, mut buf: Vec<u8>) -> Result<RgbImage, VideoError> {
        let (w, h) = (self.decoded.width(), self.decoded.height());
        let fmt = self.decoded.format();
        let rebuild = match &self.scaler {
            Some(s) => s.input().width != w || s.input().height != h || s.input().format != fmt,
            None => true,
        };
        let err = |e: ffmpeg::Error| VideoError::NotAVideo {
            path: self.path.clone(),
            reason: format!("colour conversion: {e}"),
        };
        if rebuild {
            self.scaler = Some(
                scaling::Context::get(fmt, w, h, Pixel::RGB24, w, h, scaling::Flags::FAST_BILINEAR)
                    .map_err(err)?,
            );
        }
        let scaler = self.scaler.as_mut().ok_or_else(|| VideoError::NotAVideo {
            path: self.path.clone(),
            reason: "colour conversion unavailable".to_string(),
        })?;
        // Convert straight into the image's buffer: one pass over the frame instead of a
        // conversion into an FFmpeg frame plus a copy (measured: ~1 ms per 1080p frame).
        let row = (w * 3) as usize;
        let len = row * h as usize;
        buf.clear();
        buf.reserve(len);
        let dst = [
            buf.as_mut_ptr(),
            std::ptr::null_mut(),
            std::ptr::null_mut(),
            std::ptr::null_mut(),
        ];
        let dst_stride = [row as i32, 0, 0, 0];
        // SAFETY: the scaler was built for exactly this input size and format and RGB24
        // output of the same size; `buf` has capacity for h rows of `row` bytes, which
        // sws_scale writes completely (it returns the number of rows written, checked
        // before the length is set).
        let written = unsafe {
            let src = self.decoded.as_ptr();
            ffmpeg::ffi::sws_scale(
                scaler.as_mut_ptr(),
                (*src).data.as_ptr() as *const *const u8,
                (*src).linesize.as_ptr(),
                0,
                h as i32,
                dst.as_ptr(),
                dst_stride.as_ptr(),
            )
        };
        if written != h as i32 {
            return Err(VideoError::NotAVideo {
                path: self.path.clone(),
                reason: format!("colour conversion wrote {written} of {h} rows"),
            });
        }
        // SAFETY: all `len` bytes were written by sws_scale above.
        unsafe { buf.set_len(len) };
        RgbImage::from_raw(w, h, buf).ok_or_else(|| VideoError::NotAVideo {
            path: self.path.clone(),
            reason: "frame buffer size".to_string(),
        })
    }

    /// Takes the frame last returned by [`Self::advance`] as [`Pixels`]: for 8- and
    /// 10-bit 4:2:0 streams the decoder's frame itself (no copy; its buffers go back to
    /// FFmpeg's pool when the pixels are dropped), else RGB (converted into `recycled`'s
    /// buffer when given). The frame is gone from the reader afterwards.
    pub fn take_pixels(&mut self, recycled: Option<Pixels>) -> Result<Pixels, VideoError> {
        match self.decoded.format() {
            Pixel::YUV420P | Pixel::YUVJ420P => return self.take_yuv().map(Pixels::Yuv),
            Pixel::YUV420P10LE => return self.take_yuv().map(Pixels::Yuv10),
            _ => {}
        }
        let buf = match recycled {
            Some(Pixels::Rgb(i)) => i.into_raw(),
            _ => Vec::new(),
        };
        Ok(Pixels::Rgb(self.current_rgb_into(buf)?))
    }

    /// Takes the decoded 4:2:0 frame as a [`YuvFrame`] of `T` samples, read in place.
    fn take_yuv<T: Sample>(&mut self) -> Result<YuvFrame<T>, VideoError> {
        let full_range = self.decoded.format() == Pixel::YUVJ420P
            || self.decoded.color_range() == ffmpeg::util::color::Range::JPEG;
        let frame = std::mem::replace(&mut self.decoded, ffmpeg::frame::Video::empty());
        YuvFrame::from_decoded(frame, full_range).ok_or_else(|| VideoError::NotAVideo {
            path: self.path.clone(),
            reason: "decoded frame with an unexpected plane layout (misaligned or short planes): report the file's codec".to_string(),
        })
    }

    /// The next frame whose index is a multiple of `stride`, as [`Pixels`].
    pub fn next_pixels(
        &mut self,
        stride: u64,
        recycled: Option<Pixels>,
    ) -> Result<Option<(u64, f64, Pixels)>, VideoError> {
        let stride = stride.max(1);
        while let Some((index, time_s)) = self.advance() {
            if index % stride == 0 {
                return Ok(Some((index, time_s, self.take_pixels(recycled)?)));
            }
        }
        Ok(None)
    }

    /// The next frame whose index is a multiple of `stride` (1: every frame), in RGB.
    /// Skipped frames are decoded (H.264 needs them) but not converted.
    pub fn next_frame(&mut self, stride: u64) -> Result<Option<Frame>, VideoError> {
        self.next_frame_recycling(stride, None)
    }

    /// [`Self::next_frame`], reusing the buffer of a frame the caller is done with.
    pub fn next_frame_recycling(
        &mut self,
        stride: u64,
        recycled: Option<RgbImage>,
    ) -> Result<Option<Frame>, VideoError> {
        let stride = stride.max(1);
        let buf = recycled.map(|i| i.into_raw()).unwrap_or_default();
        while let Some((index, time_s)) = self.advance() {
            if index % stride == 0 {
                let image = self.current_rgb_into(buf)?;
                return Ok(Some(Frame {
                    index,
                    time_s,
                    image,
                }));
            }
        }
        Ok(None)
    }
}

/// `n` frames spread evenly over a video (for calibration from a video of a board).
pub fn sample_evenly(path: &Path, n: usize) -> Result<Vec<Frame>, VideoError> {
    let mut reader = VideoReader::open(path)?;
    let total = reader.info().frame_count_estimate.max(1);
    let n = n.max(1) as u64;
    let mut wanted: Vec<u64> = (0..n).map(|i| (i * total) / n + total / (2 * n)).collect();
    wanted.dedup();
    let mut out = Vec::with_capacity(wanted.len());
    let mut next = 0;
    while next < wanted.len() {
        match reader.advance() {
            Some((index, time_s)) => {
                if index == wanted[next] {
                    out.push(Frame {
                        index,
                        time_s,
                        image: reader.current_rgb()?,
                    });
                    next += 1;
                }
            }
            None => break,
        }
    }
    Ok(out)
}

/// H.264 encoding settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EncodeSettings {
    /// Frames per second.
    pub fps: u32,
    /// Constant rate factor (0 lossless .. 51 worst); ignored when `bitrate_bps` is set.
    pub crf: u32,
    /// Target bit rate, bit/s.
    pub bitrate_bps: Option<u64>,
    /// Encoder preset (x264/x265).
    pub preset: &'static str,
    /// Encoder: `libx264` (H.264) or `libx265` (HEVC, as recent GoPros record).
    pub encoder: &'static str,
}

impl Default for EncodeSettings {
    fn default() -> Self {
        Self {
            fps: 30,
            crf: 18,
            bitrate_bps: None,
            preset: "veryfast",
            encoder: "libx264",
        }
    }
}

/// Streaming H.264 writer.
pub struct VideoWriter {
    path: PathBuf,
    tmp: PathBuf,
    output: ffmpeg::format::context::Output,
    encoder: ffmpeg::encoder::Video,
    scaler: scaling::Context,
    width: u32,
    height: u32,
    frame_index: i64,
    encoder_time_base: ffmpeg::Rational,
    stream_time_base: ffmpeg::Rational,
    yuv: ffmpeg::frame::Video,
    rgb: ffmpeg::frame::Video,
    finished: bool,
}

impl VideoWriter {
    /// Creates `path` (MP4, H.264, yuv420p) for `width` x `height` frames (even sizes).
    pub fn create(
        path: &Path,
        width: u32,
        height: u32,
        settings: &EncodeSettings,
    ) -> Result<Self, VideoError> {
        init();
        let fail = |reason: String| VideoError::Encode {
            path: path.to_path_buf(),
            reason,
        };
        if !width.is_multiple_of(2) || !height.is_multiple_of(2) || width == 0 || height == 0 {
            return Err(fail(format!(
                "{width}x{height}: H.264 yuv420p needs even, non-zero sizes"
            )));
        }
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| fail(e.to_string()))?;
        }
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "video.mp4".into());
        let tmp = path.with_file_name(format!(".{name}.partial.mp4"));
        let mut output = ffmpeg::format::output_as(&tmp, "mp4").map_err(|e| fail(e.to_string()))?;
        let codec = ffmpeg::encoder::find_by_name(settings.encoder).ok_or_else(|| {
            fail(format!(
                "no {} encoder in this FFmpeg build",
                settings.encoder
            ))
        })?;
        let global_header = output
            .format()
            .flags()
            .contains(ffmpeg::format::Flags::GLOBAL_HEADER);
        let mut stream = output.add_stream(codec).map_err(|e| fail(e.to_string()))?;
        let mut enc = ffmpeg::codec::context::Context::new_with_codec(codec)
            .encoder()
            .video()
            .map_err(|e| fail(e.to_string()))?;
        let time_base = ffmpeg::Rational(1, settings.fps.max(1) as i32);
        enc.set_width(width);
        enc.set_height(height);
        enc.set_format(Pixel::YUV420P);
        enc.set_time_base(time_base);
        enc.set_frame_rate(Some(ffmpeg::Rational(settings.fps.max(1) as i32, 1)));
        if global_header {
            enc.set_flags(ffmpeg::codec::Flags::GLOBAL_HEADER);
        }
        let mut opts = ffmpeg::Dictionary::new();
        opts.set("preset", settings.preset);
        if settings.encoder == "libx265" {
            // Quiet x265's banner on stderr; tag the stream hvc1 as GoPro files are.
            opts.set("x265-params", "log-level=error");
        }
        match settings.bitrate_bps {
            Some(b) => {
                enc.set_bit_rate(b as usize);
                enc.set_max_bit_rate(b as usize);
            }
            None => opts.set("crf", &settings.crf.to_string()),
        }
        let encoder = enc.open_with(opts).map_err(|e| fail(e.to_string()))?;
        stream.set_parameters(&encoder);
        stream.set_time_base(time_base);
        output.write_header().map_err(|e| fail(e.to_string()))?;
        let stream_time_base = output.stream(0).map(|s| s.time_base()).unwrap_or(time_base);
        let scaler = scaling::Context::get(
            Pixel::RGB24,
            width,
            height,
            Pixel::YUV420P,
            width,
            height,
            scaling::Flags::BILINEAR,
        )
        .map_err(|e| fail(e.to_string()))?;
        Ok(Self {
            path: path.to_path_buf(),
            tmp,
            output,
            encoder,
            scaler,
            width,
            height,
            frame_index: 0,
            encoder_time_base: time_base,
            stream_time_base,
            yuv: ffmpeg::frame::Video::empty(),
            rgb: ffmpeg::frame::Video::new(Pixel::RGB24, width, height),
            finished: false,
        })
    }

    /// Encodes one frame.
    pub fn write(&mut self, frame: &RgbImage) -> Result<(), VideoError> {
        if frame.width() != self.width || frame.height() != self.height {
            return Err(VideoError::FrameSize {
                path: self.path.clone(),
                got_width: frame.width(),
                got_height: frame.height(),
                width: self.width,
                height: self.height,
            });
        }
        let stride = self.rgb.stride(0);
        let row = (self.width * 3) as usize;
        let src = frame.as_raw();
        let dst = self.rgb.data_mut(0);
        for y in 0..self.height as usize {
            dst[y * stride..y * stride + row].copy_from_slice(&src[y * row..(y + 1) * row]);
        }
        let path = self.path.clone();
        let fail = move |e: ffmpeg::Error| VideoError::Encode {
            path: path.clone(),
            reason: e.to_string(),
        };
        self.scaler.run(&self.rgb, &mut self.yuv).map_err(&fail)?;
        self.yuv.set_pts(Some(self.frame_index));
        self.frame_index += 1;
        self.encoder.send_frame(&self.yuv).map_err(&fail)?;
        self.drain()
    }

    fn drain(&mut self) -> Result<(), VideoError> {
        let mut packet = ffmpeg::Packet::empty();
        while self.encoder.receive_packet(&mut packet).is_ok() {
            packet.set_stream(0);
            // One frame interval each, so the container's duration and average frame
            // rate come out exact.
            packet.set_duration(1);
            packet.rescale_ts(self.encoder_time_base, self.stream_time_base);
            packet
                .write_interleaved(&mut self.output)
                .map_err(|e| VideoError::Encode {
                    path: self.path.clone(),
                    reason: e.to_string(),
                })?;
        }
        Ok(())
    }

    /// Flushes the encoder, writes the trailer and moves the file to its final name.
    pub fn finish(mut self) -> Result<PathBuf, VideoError> {
        let path = self.path.clone();
        let fail = |e: String| VideoError::Encode {
            path: path.clone(),
            reason: e,
        };
        self.encoder.send_eof().map_err(|e| fail(e.to_string()))?;
        self.drain()?;
        self.output
            .write_trailer()
            .map_err(|e| fail(e.to_string()))?;
        std::fs::rename(&self.tmp, &self.path).map_err(|e| fail(e.to_string()))?;
        self.finished = true;
        Ok(self.path.clone())
    }
}

impl Drop for VideoWriter {
    /// A writer dropped before [`VideoWriter::finish`] (an error, a panic upstream)
    /// removes its partial file: no `.NAME.partial.mp4` is left behind.
    fn drop(&mut self) {
        if !self.finished {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn moving_square(i: u32, w: u32, h: u32) -> RgbImage {
        RgbImage::from_fn(w, h, |x, y| {
            let sx = 10 + 4 * i;
            if x >= sx && x < sx + 16 && (16..32).contains(&y) {
                image::Rgb([220, 30, 30])
            } else {
                image::Rgb([40, 120, 200])
            }
        })
    }

    fn write_test_video(path: &Path, frames: u32) {
        let mut w = VideoWriter::create(
            path,
            96,
            64,
            &EncodeSettings {
                fps: 25,
                crf: 10,
                ..Default::default()
            },
        )
        .unwrap();
        for i in 0..frames {
            w.write(&moving_square(i, 96, 64)).unwrap();
        }
        w.finish().unwrap();
    }

    #[test]
    fn round_trip_frames_times_and_colours() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.mp4");
        write_test_video(&p, 10);
        assert!(!dir.path().join(".a.mp4.partial.mp4").exists());
        let mut r = VideoReader::open(&p).unwrap();
        assert_eq!((r.info().width, r.info().height), (96, 64));
        assert!((r.info().fps - 25.0).abs() < 1e-6);
        assert_eq!(r.info().codec, "h264");
        let mut n = 0;
        while let Some(f) = r.next_frame(1).unwrap() {
            assert!(
                (f.time_s - f.index as f64 / 25.0).abs() < 1e-3,
                "t {}",
                f.time_s
            );
            // Centre of the square and the background, within compression error.
            let sq = f.image.get_pixel(10 + 4 * f.index as u32 + 8, 24);
            assert!(sq[0] > 180 && sq[1] < 80 && sq[2] < 80, "{sq:?}");
            let bg = f.image.get_pixel(90, 60);
            assert!((bg[2] as i32 - 200).abs() < 20, "{bg:?}");
            n += 1;
        }
        assert_eq!(n, 10);
        assert!(!r.stats().has_errors());
    }

    #[test]
    fn stride_and_even_sampling() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("b.mp4");
        write_test_video(&p, 12);
        let mut r = VideoReader::open(&p).unwrap();
        let mut idx = vec![];
        while let Some(f) = r.next_frame(3).unwrap() {
            idx.push(f.index);
        }
        assert_eq!(idx, vec![0, 3, 6, 9]);
        let s = sample_evenly(&p, 4).unwrap();
        let idx: Vec<u64> = s.iter().map(|f| f.index).collect();
        assert_eq!(idx, vec![1, 4, 7, 10]);
    }

    #[test]
    fn truncated_and_corrupt_videos_do_not_panic() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.mp4");
        write_test_video(&p, 30);
        let bytes = std::fs::read(&p).unwrap();
        // MP4 writes its index (moov) at the end: a truncated recording cannot be opened
        // and must say so.
        let cut = dir.path().join("cut.mp4");
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        match VideoReader::open(&cut) {
            Err(VideoError::Truncated { why, .. }) => {
                assert!(why.contains("before its index (moov)"), "{why}")
            }
            other => panic!("{:?}", other.map(|r| r.info().clone())),
        }
        std::fs::write(&cut, b"").unwrap();
        assert!(matches!(
            VideoReader::open(&cut),
            Err(VideoError::Truncated { .. })
        ));
        // Garbage inside the frame data: the video opens and decodes what it can.
        let mut bad = bytes.clone();
        let (a, b) = (bad.len() / 3, bad.len() / 2);
        for (i, x) in bad[a..b].iter_mut().enumerate() {
            *x = (i * 7919 % 251) as u8;
        }
        let corrupt = dir.path().join("corrupt.mp4");
        std::fs::write(&corrupt, &bad).unwrap();
        let mut r = VideoReader::open(&corrupt).unwrap();
        let mut n = 0;
        while r.next_frame(1).unwrap().is_some() {
            n += 1;
        }
        assert!(n >= 1 && n <= 30, "decoded {n}");
        assert_eq!(r.stats().frames_decoded, n);
    }

    #[test]
    fn yuv_pixels_match_swscale_rgb() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("y.mp4");
        write_test_video(&p, 3);
        let mut a = VideoReader::open(&p).unwrap();
        let mut b = VideoReader::open(&p).unwrap();
        let rgb = a.next_frame(1).unwrap().unwrap().image;
        let (_, _, px) = b.next_pixels(1, None).unwrap().unwrap();
        let Pixels::Yuv(yuv) = px else {
            panic!("H.264 yuv420p should stay YUV")
        };
        let mut worst = 0;
        for y in 0..64 {
            for x in 0..96 {
                // Away from colour edges (chroma interpolation differs there).
                if (8..44).contains(&x) && (12..36).contains(&y) {
                    continue;
                }
                let (p, q) = (rgb.get_pixel(x, y), yuv.rgb_at(x, y));
                for k in 0..3 {
                    worst = worst.max((p[k] as i32 - q[k] as i32).abs());
                }
            }
        }
        assert!(worst <= 3, "largest channel difference {worst}");
    }

    #[test]
    fn ten_bit_hevc_stays_yuv_at_native_depth_and_converts_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let src = dir.path().join("y.mp4");
        write_test_video(&src, 3);
        let p = dir.path().join("y10.mp4");
        let ok = std::process::Command::new("ffmpeg")
            .args(["-v", "error", "-y", "-i"])
            .arg(&src)
            .args(["-c:v", "libx265", "-pix_fmt", "yuv420p10le", "-crf", "4"])
            .args(["-x265-params", "log-level=error"])
            .arg(&p)
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        assert!(ok, "ffmpeg with libx265 makes a 10-bit test video");
        let mut a = VideoReader::open(&p).unwrap();
        let mut b = VideoReader::open(&p).unwrap();
        let rgb = a.next_frame(1).unwrap().unwrap().image;
        let (_, _, px) = b.next_pixels(1, None).unwrap().unwrap();
        let Pixels::Yuv10(yuv) = px else {
            panic!("HEVC yuv420p10le should stay 10-bit YUV")
        };
        assert!(yuv.plane(0).iter().any(|v| *v > 255), "10-bit levels kept");
        // Against BT.601 limited range in floating point on the 10-bit samples: off by
        // at most the final rounding (swscale's own 10 -> 8-bit path dithers, so it is
        // only a loose second check).
        let (mut exact, mut loose) = (0.0f64, 0);
        let [ys, cs, _] = yuv.strides;
        for y in 0..64u32 {
            for x in 0..96u32 {
                let yy = yuv.plane(0)[y as usize * ys + x as usize] as f64 / 4.0 - 16.0;
                let ci = (y as usize / 2) * cs + x as usize / 2;
                let (d, e) = (
                    yuv.plane(1)[ci] as f64 / 4.0 - 128.0,
                    yuv.plane(2)[ci] as f64 / 4.0 - 128.0,
                );
                let f = [
                    1.164 * yy + 1.596 * e,
                    1.164 * yy - 0.391 * d - 0.813 * e,
                    1.164 * yy + 2.018 * d,
                ];
                let q = yuv.rgb_at(x, y);
                for k in 0..3 {
                    exact = exact.max((f[k].clamp(0.0, 255.0) - q[k] as f64).abs());
                }
                if !((8..44).contains(&x) && (12..36).contains(&y)) {
                    let p = rgb.get_pixel(x, y);
                    for k in 0..3 {
                        loose = loose.max((p[k] as i32 - q[k] as i32).abs());
                    }
                }
            }
        }
        assert!(
            exact <= 1.0,
            "largest difference from the exact conversion {exact}"
        );
        assert!(
            loose <= 4,
            "largest channel difference from swscale {loose}"
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(20_000))]
        /// Red's Cr pre-test agrees with the exact test on every YUV sample, in gamut or not.
        #[test]
        fn cr_pretest_never_rejects_a_red_pixel(y: u8, u: u8, v: u8, full: bool, v_min in 1u8..=80) {
            let f = YuvFrame::from_planes(2, 2, vec![y; 4], vec![u], vec![v], full).unwrap();
            let t = crate::detect::HsvThresholds { v_min, ..Default::default() };
            let test = crate::detect::MarkerTest::new(&t);
            let p = f.rgb_at(0, 0);
            let exact = crate::detect::is_marker_colour(p[0], p[1], p[2], &t);
            proptest::prop_assert_eq!(crate::detect::PixelSource::is_marker_at(&f, 0, 0, &test), exact, "yuv {} {} {} -> {:?}", y, u, v, p);
        }

        /// Every preset's pre-test agrees with the exact test on YUV samples of RGB
        /// colours (as a decoder makes them) with up to 6 levels of chroma noise.
        #[test]
        fn every_preset_pretest_keeps_its_pixels(r: u8, g: u8, b: u8, du in -6i32..=6, dv in -6i32..=6, full: bool, preset in 0usize..5, v_scale in 0.3f64..1.5) {
            use crate::detect::MarkerColour::*;
            let colour = [Red, Green, Blue, Yellow, Dark][preset];
            let mut t = colour.thresholds();
            t.v_min = (t.v_min as f64 * v_scale).round().clamp(1.0, 255.0) as u8;
            if t.v_max < 255 {
                t.v_max = (t.v_max as f64 * v_scale).round().clamp(1.0, 254.0) as u8;
            }
            let (rf, gf, bf) = (r as f64, g as f64, b as f64);
            let (yy, cb, cr) = if full {
                (0.299 * rf + 0.587 * gf + 0.114 * bf, 128.0 - 0.168736 * rf - 0.331264 * gf + 0.5 * bf, 128.0 + 0.5 * rf - 0.418688 * gf - 0.081312 * bf)
            } else {
                (16.0 + (65.481 * rf + 128.553 * gf + 24.966 * bf) / 255.0, 128.0 + (-37.797 * rf - 74.203 * gf + 112.0 * bf) / 255.0, 128.0 + (112.0 * rf - 93.786 * gf - 18.214 * bf) / 255.0)
            };
            let q = |v: f64| v.round().clamp(0.0, 255.0) as u8;
            let (u, v) = (q(cb + du as f64), q(cr + dv as f64));
            let f = YuvFrame::from_planes(2, 2, vec![q(yy); 4], vec![u], vec![v], full).unwrap();
            let test = crate::detect::MarkerTest::new(&t);
            let p = f.rgb_at(0, 0);
            let exact = crate::detect::is_marker_colour(p[0], p[1], p[2], &t);
            proptest::prop_assert_eq!(crate::detect::PixelSource::is_marker_at(&f, 0, 0, &test), exact, "{:?} yuv {} {} {} -> {:?}, {:?}", colour, q(yy), u, v, p, test.pretest);
        }
    }

    /// The pre-tests at their tightest: colours on the edges of each preset's band (its
    /// hue bounds, S = s_min, V = v_min, and a little inside), through both YUV ranges,
    /// are never rejected by the pre-test when their converted RGB passes.
    #[test]
    fn pretests_keep_the_edges_of_every_band() {
        use crate::detect::MarkerColour::*;
        let mut checked = 0;
        for colour in [Red, Green, Blue, Yellow, Dark] {
            let t = colour.thresholds();
            let test = crate::detect::MarkerTest::new(&t);
            let hi = if t.hue_min > t.hue_max {
                t.hue_max as f64 + 180.0
            } else {
                t.hue_max as f64
            };
            for i in 0..=40 {
                let h = t.hue_min as f64 + (hi - t.hue_min as f64) * i as f64 / 40.0;
                for ds in [0.0, 2.0, 6.0, 40.0, 255.0] {
                    for dv in [0.0, 1.0, 3.0, 10.0, 60.0] {
                        let s = ((t.s_min as f64 + ds) / 255.0).min(1.0);
                        let v = if t.v_max < 255 {
                            t.v_max as f64 - dv
                        } else {
                            t.v_min as f64 + dv
                        };
                        let [r, g, b] =
                            crate::detect::rgb_of_hsv(h % 180.0, s, v.clamp(0.0, 255.0));
                        for full in [false, true] {
                            let (yy, cb, cr) = if full {
                                (
                                    0.299 * r + 0.587 * g + 0.114 * b,
                                    128.0 - 0.168736 * r - 0.331264 * g + 0.5 * b,
                                    128.0 + 0.5 * r - 0.418688 * g - 0.081312 * b,
                                )
                            } else {
                                (
                                    16.0 + (65.481 * r + 128.553 * g + 24.966 * b) / 255.0,
                                    128.0 + (-37.797 * r - 74.203 * g + 112.0 * b) / 255.0,
                                    128.0 + (112.0 * r - 93.786 * g - 18.214 * b) / 255.0,
                                )
                            };
                            let q = |v: f64| v.round().clamp(0.0, 255.0) as u8;
                            let f = YuvFrame::from_planes(
                                2,
                                2,
                                vec![q(yy); 4],
                                vec![q(cb)],
                                vec![q(cr)],
                                full,
                            )
                            .unwrap();
                            let p = f.rgb_at(0, 0);
                            if test.matches(p[0], p[1], p[2]) {
                                checked += 1;
                                assert!(crate::detect::PixelSource::is_marker_at(&f, 0, 0, &test), "{colour:?}: hsv {h} {s} {v} -> yuv {} {} {} (full {full}) rejected by {:?}", q(yy), q(cb), q(cr), test.pretest);
                            }
                        }
                    }
                }
            }
        }
        assert!(
            checked > 1500,
            "only {checked} edge colours passed their band"
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// The chroma- and luma-row scans find exactly the coarse pixels the exact test
        /// finds, for every preset, at both depths, odd sizes included.
        #[test]
        fn row_scans_match_the_exact_coarse_pass(seed: u64, w in 1u32..150, h in 1u32..9, ten_bit: bool, preset in 0usize..5) {
            use crate::detect::MarkerColour::*;
            let mut rng = crate::render::rng::SplitMix64::new(seed);
            let (cw, ch) = (w.div_ceil(2) as usize, h.div_ceil(2) as usize);
            let mut sample = |lo: f64, hi: f64| rng.range(lo, hi) as u16;
            let y: Vec<u16> = (0..w as usize * h as usize).map(|i| if i % 23 < 4 { sample(16.0, 60.0) } else { sample(16.0, 236.0) }).collect();
            // Mostly neutral chroma with coloured patches.
            let u: Vec<u16> = (0..cw * ch).map(|i| if i % 29 < 5 { sample(16.0, 240.0) } else { sample(110.0, 146.0) }).collect();
            let v: Vec<u16> = (0..cw * ch).map(|i| if i % 37 < 5 { sample(16.0, 240.0) } else { sample(100.0, 134.0) }).collect();
            let t = crate::detect::MarkerTest::new(&[Red, Green, Blue, Yellow, Dark][preset].thresholds());
            let check = |f: &dyn Fn(u32, &mut Vec<u32>, &mut Vec<u32>)| -> Result<(), proptest::test_runner::TestCaseError> {
                for row in (0..h).step_by(2) {
                    let (mut fast, mut exact) = (Vec::new(), Vec::new());
                    f(row, &mut fast, &mut exact);
                    proptest::prop_assert_eq!(fast, exact, "row {}", row);
                }
                Ok(())
            };
            if ten_bit {
                let up = |p: &[u16]| p.iter().map(|&s| s << 2).collect::<Vec<u16>>();
                let f = YuvFrame::from_planes(w, h, up(&y), up(&u), up(&v), false).unwrap();
                check(&|row, a, b| {
                    crate::detect::PixelSource::coarse_row_hits(&f, row, &t, a);
                    crate::detect::coarse_row_hits_exact(&f, row, &t, b);
                })?;
            } else {
                let down = |p: &[u16]| p.iter().map(|&s| s as u8).collect::<Vec<u8>>();
                let f = YuvFrame::from_planes(w, h, down(&y), down(&u), down(&v), false).unwrap();
                check(&|row, a, b| {
                    crate::detect::PixelSource::coarse_row_hits(&f, row, &t, a);
                    crate::detect::coarse_row_hits_exact(&f, row, &t, b);
                })?;
            }
        }
    }

    #[test]
    fn hevc_decodes_like_h264() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("GX010042.MP4");
        let settings = EncodeSettings {
            fps: 25,
            crf: 10,
            encoder: "libx265",
            ..Default::default()
        };
        let mut w = VideoWriter::create(&p, 96, 64, &settings).unwrap();
        for i in 0..6 {
            w.write(&moving_square(i, 96, 64)).unwrap();
        }
        w.finish().unwrap();
        let mut r = VideoReader::open(&p).unwrap();
        assert_eq!(r.info().codec, "hevc");
        let mut n = 0;
        while let Some(f) = r.next_frame(1).unwrap() {
            let sq = f.image.get_pixel(10 + 4 * f.index as u32 + 8, 24);
            assert!(sq[0] > 170 && sq[1] < 90, "{sq:?}");
            n += 1;
        }
        assert_eq!(n, 6);
    }

    #[test]
    fn text_file_is_not_a_video_and_missing_is_missing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.mp4");
        std::fs::write(&p, "hello, not a video").unwrap();
        assert!(matches!(
            VideoReader::open(&p),
            Err(VideoError::NotAVideo { .. })
        ));
        assert!(matches!(
            VideoReader::open(&dir.path().join("none.mp4")),
            Err(VideoError::Missing { .. })
        ));
    }
}
