//! Renders a one-video benchmark session: `cargo run --release --example bench_video --
//! OUT_DIR WIDTH HEIGHT FRAMES MBPS [FPS] [COLOUR]` (FPS default 30; COLOUR `red`, the
//! default, or `green`: the markers' paint). A synthetic actuator (8 markers) through a
//! GoPro-like fisheye camera with sensor noise, H.264 at the given bit rate, plus
//! cam.yaml (the true camera), pressures.csv, bendscope.toml and seed.toml (the same
//! with full-frame undistortion). Used by scripts/bench-process.sh.

use std::path::PathBuf;

use bendscope::calib::file::write_calibration;
use bendscope::calib::{UndistortSettings, Undistorter};
use bendscope::render::actuator::{ArcScene, FrameLook, PlaneSampler};
use bendscope::render::board::BoardPose;
use bendscope::render::fixtures::gopro_like_camera;
use bendscope::render::rng::SplitMix64;
use bendscope::video::{EncodeSettings, VideoWriter};
use nalgebra::{Point2, Rotation3, Vector3};

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().collect();
    let out = PathBuf::from(&a[1]);
    let (w, h): (u32, u32) = (a[2].parse()?, a[3].parse()?);
    let frames: usize = a[4].parse()?;
    let mbps: u64 = a[5].parse()?;
    let fps: u32 = match a.get(6) {
        Some(f) => f.parse()?,
        None => 30,
    };
    let green = match a.get(7).map(String::as_str) {
        None | Some("red") => false,
        Some("green") => true,
        Some(other) => anyhow::bail!("unknown colour {other}: red or green"),
    };
    std::fs::create_dir_all(&out)?;
    let camera = gopro_like_camera(w, h);
    let distance = 260.0;
    let plane = BoardPose {
        rotation: Rotation3::identity(),
        translation_mm: Vector3::new(0.0, 0.0, distance),
    };
    let sampler = PlaneSampler::new(&camera, &plane, 1, 5)?;
    let mut scene = ArcScene::reference_actuator(1.0 / 90.0, Point2::new(-50.0, 22.0));
    if green {
        // Green paint of the same lightness as the red one.
        scene.marker_rgb = [40.0, 150.0, 64.0];
    }
    let look = FrameLook {
        noise_sigma: 6.0,
        ..FrameLook::default()
    };
    let mut writer = VideoWriter::create(
        &out.join("GX010001.MP4"),
        w,
        h,
        &EncodeSettings {
            fps,
            crf: 0,
            bitrate_bps: Some(mbps * 1_000_000),
            ..Default::default()
        },
    )?;
    let mut rng = SplitMix64::new(9);
    for f in 0..frames {
        let img = sampler.render(
            &scene,
            [0.1 * rng.normal(), 0.1 * rng.normal()],
            &look,
            f as u64,
        );
        writer.write(&img)?;
    }
    writer.finish()?;
    write_calibration(&out.join("cam.yaml"), &camera)?;
    let mm_per_px = distance
        / Undistorter::new(&camera, UndistortSettings::default())?.new_camera_matrix()[(0, 0)];
    std::fs::write(
        out.join("pressures.csv"),
        "file,pressure_kpa\nGX010001.MP4,50\n",
    )?;
    let cfg = format!("calibration = \"cam.yaml\"\nmm_per_px = {mm_per_px}\n");
    let detect = if green {
        "[detect]\ncolour = \"green\"\n"
    } else {
        ""
    };
    std::fs::write(out.join("bendscope.toml"), format!("{cfg}{detect}"))?;
    std::fs::write(
        out.join("seed.toml"),
        format!("{cfg}full_frame_undistort = true\n{detect}"),
    )?;
    println!(
        "wrote {} ({w}x{h}, {frames} frames at {fps} fps, {mbps} Mb/s; true radius 90 mm)",
        out.display()
    );
    Ok(())
}
