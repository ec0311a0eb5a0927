//! Key frames only against every frame, measured in the same run: `cargo run --release
//! --example bench_keyframes -- OUT_DIR [WIDTH HEIGHT FRAMES GOP MBPS]` (defaults 1920
//! 1080 300 15 40). Renders a steady hold (the reference actuator, R 90 mm, through a
//! GoPro-like fisheye, sensor noise, H.264 with a key frame every GOP frames) unless
//! OUT_DIR holds it already, then decodes and measures it every frame and key frames
//! only (detection, marker order and a Pratt circle per frame), best of 3 each, and
//! prints the video frames covered per second of each, their ratio, the two median radii
//! and the scatter expected of a median of that many frames. Used by
//! scripts/bench-keyframes.sh.

use std::path::Path;
use std::time::Instant;

use bendscope::detect::{
    detect_markers_with, order_markers, ChainStart, ClampSide, DetectSettings, MaskBuffer,
};
use bendscope::fit::fit_circle_pratt;
use bendscope::render::actuator::{ArcScene, FrameLook, PlaneSampler};
use bendscope::render::board::BoardPose;
use bendscope::render::fixtures::gopro_like_camera;
use bendscope::render::rng::SplitMix64;
use bendscope::video::{EncodeSettings, Pixels, VideoReader, VideoWriter};
use nalgebra::{Point2, Rotation3, Vector3};

fn arg<T: std::str::FromStr>(a: &[String], i: usize, default: T) -> anyhow::Result<T> {
    match a.get(i) {
        Some(s) => s
            .parse()
            .map_err(|_| anyhow::anyhow!("argument {i} `{s}` is not a number")),
        None => Ok(default),
    }
}

/// One pass over a video: seconds, frames measured, median radius (px) and the robust
/// sd of the frames' radii (1.4826 x their median absolute deviation, px).
type Pass = (f64, usize, f64, f64);

/// One pass over `video`, every frame or key frames only.
fn measure(video: &Path, key_frames_only: bool) -> anyhow::Result<Pass> {
    let start = Instant::now();
    let mut reader = VideoReader::open(video)?;
    if key_frames_only {
        reader.skip_non_key_frames();
    }
    let settings = DetectSettings::default();
    let mut buf = MaskBuffer::default();
    let mut radii = Vec::new();
    let mut measured = 0;
    let mut recycled = None;
    while let Some((_, _, pixels)) = reader.next_pixels(1, recycled.take())? {
        let found = match &pixels {
            Pixels::Yuv(f) => detect_markers_with(f, &settings, &mut buf),
            Pixels::Yuv10(f) => detect_markers_with(f, &settings, &mut buf),
            Pixels::Rgb(i) => detect_markers_with(i, &settings, &mut buf),
        };
        let points: Vec<Point2<f64>> = found.blobs.iter().map(|b| b.centroid).collect();
        let ordered = order_markers(&points, ChainStart::Side(ClampSide::Left));
        if let Ok(c) = fit_circle_pratt(&ordered) {
            radii.push(c.radius);
        }
        measured += 1;
        recycled = Some(pixels);
    }
    let seconds = start.elapsed().as_secs_f64();
    radii.sort_by(f64::total_cmp);
    let n = radii.len();
    anyhow::ensure!(n > 0, "{}: no frame measured", video.display());
    let median_of = |v: &[f64]| {
        let n = v.len();
        if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        }
    };
    let median = median_of(&radii);
    let mut dev: Vec<f64> = radii.iter().map(|r| (r - median).abs()).collect();
    dev.sort_by(f64::total_cmp);
    Ok((seconds, measured, median, 1.4826 * median_of(&dev)))
}

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().collect();
    let out = Path::new(a.get(1).ok_or_else(|| {
        anyhow::anyhow!("usage: bench_keyframes OUT_DIR [WIDTH HEIGHT FRAMES GOP MBPS]")
    })?);
    let (w, h): (u32, u32) = (arg(&a, 2, 1920)?, arg(&a, 3, 1080)?);
    let frames: u32 = arg(&a, 4, 300)?;
    let gop: u32 = arg(&a, 5, 15)?;
    let mbps: u64 = arg(&a, 6, 40)?;
    let video = out.join(format!("hold-{w}x{h}-{frames}-gop{gop}-{mbps}.mp4"));
    if !video.is_file() {
        std::fs::create_dir_all(out)?;
        let camera = gopro_like_camera(w, h);
        let plane = BoardPose {
            rotation: Rotation3::identity(),
            translation_mm: Vector3::new(0.0, 0.0, 260.0),
        };
        let sampler = PlaneSampler::new(&camera, &plane, 1, 5)?;
        let scene = ArcScene::reference_actuator(1.0 / 90.0, Point2::new(-50.0, 22.0));
        let look = FrameLook {
            noise_sigma: 6.0,
            ..FrameLook::default()
        };
        let settings = EncodeSettings {
            fps: 30,
            crf: 0,
            bitrate_bps: Some(mbps * 1_000_000),
            keyframe_interval: Some(gop),
            ..Default::default()
        };
        let mut writer = VideoWriter::create(&video, w, h, &settings)?;
        let mut rng = SplitMix64::new(9);
        for f in 0..frames {
            let shift = [0.05 * rng.normal(), 0.05 * rng.normal()];
            writer.write(&sampler.render(&scene, shift, &look, f as u64))?;
        }
        writer.finish()?;
    }
    let best = |key: bool| -> anyhow::Result<Pass> {
        let mut best = measure(&video, key)?;
        for _ in 0..2 {
            let run = measure(&video, key)?;
            if run.0 < best.0 {
                best = run;
            }
        }
        Ok(best)
    };
    let (t_all, n_all, m_all, sd) = best(false)?;
    let (t_key, n_key, m_key, _) = best(true)?;
    let f = frames as f64;
    println!("{w}x{h}, {frames} frames at 30 fps, ~{mbps} Mb/s H.264, a key frame every {gop}");
    println!(
        "  every frame : {n_all:4} measured, {:7.1} video frames/s ({t_all:.2} s), median radius {m_all:.3} px",
        f / t_all
    );
    println!(
        "  key frames  : {n_key:4} measured, {:7.1} video frames/s ({t_key:.2} s), median radius {m_key:.3} px",
        f / t_key
    );
    // A median of n frames scatters by about 1.2533 sd / sqrt(n) (normal radii).
    println!(
        "  throughput ratio {:.2} x; medians differ by {:+.4}% (per-frame radius sd {:.4}%, \
         a median of {n_key} frames scatters by ~{:.4}%)",
        t_all / t_key,
        100.0 * (m_key / m_all - 1.0),
        100.0 * sd / m_all,
        100.0 * 1.2533 * sd / m_all / (n_key as f64).sqrt()
    );
    Ok(())
}
