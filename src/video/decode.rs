//! Streaming decode of a video file's best video stream ([`VideoReader`]), frame by frame,
//! as RGB or as the decoder's own YUV frames ([`Pixels`]), with its decode health
//! ([`DecodeStats`]).

use std::path::{Path, PathBuf};

use ffmpeg::format::Pixel;
use ffmpeg::software::scaling;
use ffmpeg_next as ffmpeg;
use image::RgbImage;

use super::container::{init, mp4_truncation};
use super::error::VideoError;
use super::yuv::{Sample, YuvFrame};

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
    /// Packets of the video stream read and sent to the decoder (one per frame in MP4):
    /// what the file holds when the decoder skips frames.
    pub packets_read: u64,
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
    /// The decoder skips all but key frames ([`Self::skip_non_key_frames`]).
    key_frames_only: bool,
    /// Time of the first frame decoded, s: a key frame's index counts from it.
    first_time_s: Option<f64>,
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
            key_frames_only: false,
            first_time_s: None,
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

    /// From now on the decoder returns key frames only: FFmpeg drops the other frames
    /// before decoding them (`skip_frame = AVDISCARD_NONKEY`). Each frame keeps its
    /// index and time in the whole video (the index from its time since the first
    /// frame's, as the skipped frames are never seen); [`DecodeStats::frames_decoded`]
    /// counts the key frames.
    pub fn skip_non_key_frames(&mut self) {
        self.decoder.skip_frame(ffmpeg::Discard::NonKey);
        self.key_frames_only = true;
    }

    /// Decodes up to the next frame; returns its index and time, or `None` at the end.
    /// The frame stays available to [`Self::current_rgb`] until the next call.
    pub fn advance(&mut self) -> Option<(u64, f64)> {
        loop {
            if self.finished {
                return None;
            }
            if self.decoder.receive_frame(&mut self.decoded).is_ok() {
                let mut index = self.next_index;
                self.next_index += 1;
                self.stats.frames_decoded += 1;
                let stamp = self
                    .decoded
                    .timestamp()
                    .filter(|_| self.time_base > 0.0)
                    .map(|ts| ts as f64 * self.time_base);
                if let (true, Some(t)) = (self.key_frames_only, stamp) {
                    let first = *self.first_time_s.get_or_insert(t);
                    if self.info.fps > 0.0 {
                        index = ((t - first) * self.info.fps).round().max(0.0) as u64;
                    }
                }
                let time_s = match stamp {
                    Some(t) => t,
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
                    self.stats.packets_read += 1;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::video::encode::{EncodeSettings, VideoWriter};

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
    fn key_frames_only_returns_the_key_frames_at_their_index_and_time() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("k.mp4");
        let settings = EncodeSettings {
            fps: 25,
            crf: 10,
            keyframe_interval: Some(5),
            ..Default::default()
        };
        let mut w = VideoWriter::create(&p, 96, 64, &settings).unwrap();
        for i in 0..17 {
            w.write(&moving_square(i, 96, 64)).unwrap();
        }
        w.finish().unwrap();
        let mut r = VideoReader::open(&p).unwrap();
        r.skip_non_key_frames();
        let mut got = vec![];
        while let Some(f) = r.next_frame(1).unwrap() {
            assert!(
                (f.time_s - f.index as f64 / 25.0).abs() < 1e-3,
                "t {}",
                f.time_s
            );
            // The picture is that frame's: its square is where frame `index` drew it.
            let sq = f.image.get_pixel(10 + 4 * f.index as u32 + 8, 24);
            assert!(
                sq[0] > 180 && sq[1] < 80 && sq[2] < 80,
                "{}: {sq:?}",
                f.index
            );
            got.push(f.index);
        }
        assert_eq!(got, vec![0, 5, 10, 15]);
        assert_eq!(r.stats().frames_decoded, 4);
        assert_eq!(r.stats().packets_read, 17);
        // Every frame, for comparison: all 17 decoded, as many packets.
        let mut all = VideoReader::open(&p).unwrap();
        while all.next_frame(1).unwrap().is_some() {}
        assert_eq!(
            (all.stats().frames_decoded, all.stats().packets_read),
            (17, 17)
        );
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
