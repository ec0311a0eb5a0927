//! H.264 (or HEVC) encoding of RGB frames into an MP4 file ([`VideoWriter`]), written
//! under a temporary name and renamed when finished.

use std::path::{Path, PathBuf};

use ffmpeg::format::Pixel;
use ffmpeg::software::scaling;
use ffmpeg_next as ffmpeg;
use image::RgbImage;

use super::container::init;
use super::error::VideoError;

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
    /// Frames from one key frame to the next (the GOP length), with no extra key frames
    /// at scene cuts; `None`: the encoder's default (x264: up to 250, and at cuts).
    pub keyframe_interval: Option<u32>,
}

impl Default for EncodeSettings {
    fn default() -> Self {
        Self {
            fps: 30,
            crf: 18,
            bitrate_bps: None,
            preset: "veryfast",
            encoder: "libx264",
            keyframe_interval: None,
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
        if let Some(g) = settings.keyframe_interval {
            let g = g.max(1);
            enc.set_gop(g);
            opts.set("keyint_min", &g.to_string());
            opts.set("sc_threshold", "0");
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
