//! The robustness matrix: `bendscope process` on footage made under the conditions of a
//! real lab, each case with its radius error against the rendered truth and a tolerance.

mod common;

use std::fs;
use std::path::Path;

use common::{col, read_csv, Run};

/// Renders an RGB-D recording of an arc actuator into `dir`: the side face tilted
/// `tilt_deg` about the vertical axis at 230 mm, the white sheet 40 mm behind it, depth
/// in millimetre units with Gaussian noise `noise_mm`; one frame per radius in
/// `radii_mm`, each at its own pressure (1 kPa apart, 10 fps). Returns the radii.
fn render_rgbd(dir: &Path, tilt_deg: f64, noise_mm: f64, radii_mm: &[f64]) {
    use bendscope::calib::{UndistortSettings, Undistorter};
    use bendscope::render::actuator::{ArcScene, FrameLook, PlaneSampler};
    use bendscope::render::board::BoardPose;
    use nalgebra::{Point2, Rotation3, Vector3};
    fs::create_dir_all(dir.join("color")).unwrap();
    fs::create_dir_all(dir.join("depth")).unwrap();
    let camera = bendscope::render::session::rgbd_camera();
    let (w, h) = (camera.image_width, camera.image_height);
    let plane = BoardPose {
        rotation: Rotation3::from_euler_angles(0.0, tilt_deg.to_radians(), 0.0),
        translation_mm: Vector3::new(0.0, 0.0, 230.0),
    };
    let sampler = PlaneSampler::new(&camera, &plane, 4, 4).unwrap();
    let und = Undistorter::new(&camera, UndistortSettings::default()).unwrap();
    let normal = plane.rotation * Vector3::z();
    let offset = normal.dot(&plane.translation_mm);
    let inverse = plane.rotation.inverse();
    let pixels: Vec<Point2<f64>> = (0..h)
        .flat_map(|y| (0..w).map(move |x| Point2::new(x as f64, y as f64)))
        .collect();
    let rays = und.rays_from_pixels(&pixels).unwrap();
    let mut rng = 0x2545_F491_4F6C_DD1Du64;
    let mut gauss = move || {
        let mut u = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            ((rng >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (a, b) = (u(), u());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    };
    let mut log = String::from("time_s,pressure_kpa\n");
    let fps = 10.0;
    for (i, r) in radii_mm.iter().enumerate() {
        let scene = ArcScene::reference_actuator(1.0 / r, Point2::new(-50.0, 20.0));
        sampler
            .render(&scene, [0.0, 0.0], &FrameLook::default(), i as u64)
            .save(dir.join(format!("color/{i:06}.png")))
            .unwrap();
        let depth = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(w, h, |x, y| {
            let ray = rays[(y * w + x) as usize];
            let on_plane = ray * (offset / normal.dot(&ray));
            let q = inverse * (on_plane - plane.translation_mm);
            let z = if scene.on_body(Point2::new(q.x, q.y)) {
                on_plane.z
            } else {
                (ray * ((offset + 40.0) / normal.dot(&ray))).z
            };
            image::Luma([(z + noise_mm * gauss()).round().max(0.0) as u16])
        });
        depth.save(dir.join(format!("depth/{i:06}.png"))).unwrap();
        let t = i as f64 / fps;
        log.push_str(&format!("{t:.3},{}\n", 10.0 + i as f64));
    }
    log.push_str(&format!(
        "{:.3},{}\n",
        radii_mm.len() as f64 / fps,
        10.0 + radii_mm.len() as f64
    ));
    fs::write(
        dir.join("intrinsics.json"),
        format!(
            r#"{{"width": {w}, "height": {h}, "fx": 520.0, "fy": 520.0, "cx": 321.7, "cy": 238.2, "depth_scale_m": 0.001, "fps": {fps}}}"#
        ),
    )
    .unwrap();
    fs::write(dir.join("pressure_log.csv"), log).unwrap();
}

/// Per-frame radius errors (relative) of an RGB-D recording.
fn rgbd_errors(tilt_deg: f64, noise_mm: f64, radii: &[f64]) -> Vec<f64> {
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("rgbd");
    render_rgbd(&s, tilt_deg, noise_mm, radii);
    let run = Run::new(dir.path(), &["process", "rgbd"]);
    assert_eq!(run.code, 0, "{run}");
    let (h, frames) = read_csv(&s.join("bendscope-out/per_frame.csv"));
    assert_eq!(frames.len(), radii.len());
    frames
        .iter()
        .zip(radii)
        .map(|(f, r)| {
            assert_eq!(f[col(&h, "status")], "ok", "{f:?}");
            f[col(&h, "radius_mm")].parse::<f64>().unwrap() / r - 1.0
        })
        .collect()
}

/// RGB-D precision (issue 10 §3): depth noise 0.8 mm in 1 mm units, the actuator's
/// plane tilted 25 and 35 degrees, the sheet 40 mm behind: every frame's radius within
/// 1% from 60 to 400 mm. (Measured: within 0.45%; the same with noise-free depth, so the
/// plane fit has taken depth noise out and what remains is the colour centroids'.)
#[test]
fn rgbd_per_frame_radius_within_one_percent_at_noise_and_tilt() {
    let radii = [60.0, 100.0, 150.0, 250.0, 400.0];
    for tilt in [25.0, 35.0] {
        let e = rgbd_errors(tilt, 0.8, &radii);
        for (r, e) in radii.iter().zip(&e) {
            assert!(
                e.abs() < 0.01,
                "tilt {tilt} deg, R {r} mm: {:+.3}%",
                100.0 * e
            );
        }
    }
}

/// Near straight (R = 1000 mm, sagitta ~1 mm over the markers) a single frame's radius
/// scatters by ~0.6% (1 sigma, up to 1.8%) from the colour centroids alone; the mean of
/// a pressure bin's frames is within 1%.
#[test]
fn rgbd_near_straight_mean_within_one_percent() {
    let radii = [1000.0; 16];
    for tilt in [25.0, 35.0] {
        let e = rgbd_errors(tilt, 0.8, &radii);
        let mean = e.iter().sum::<f64>() / e.len() as f64;
        assert!(mean.abs() < 0.01, "tilt {tilt}: mean {:+.3}%", 100.0 * mean);
    }
}

/// Copies a folder (files and sub-folders).
fn copy_dir(from: &Path, to: &Path) {
    fs::create_dir_all(to).unwrap();
    for e in fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let p = e.path();
        if p.file_name().unwrap() == "bendscope-out" {
            continue;
        }
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            fs::copy(&p, to.join(e.file_name())).unwrap();
        }
    }
}

/// The example session's ground truth.
fn example_truth() -> bendscope::render::session::SessionTruth {
    let text = fs::read_to_string(common::fixture("sessions/example/truth.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

/// Runs `process` on `session` with the example's true camera; returns per_video.csv.
fn process_with_true_camera(dir: &Path, session: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let cal = dir.join("camera.yaml");
    bendscope::calib::file::write_calibration(&cal, &example_truth().camera.to_calibration())
        .unwrap();
    let run = Run::new(
        dir,
        &["process", session, "--calibration", cal.to_str().unwrap()],
    );
    assert_eq!(run.code, 0, "{run}");
    read_csv(&dir.join(session).join("bendscope-out/per_video.csv"))
}

/// Every video's radius within `tolerance` of the example's truth.
fn assert_example_radii(h: &[String], rows: &[Vec<String>], tolerance: f64, case: &str) {
    let t = example_truth();
    assert_eq!(rows.len(), t.videos.len(), "{case}");
    for v in &t.videos {
        let r = rows.iter().find(|r| r[0] == v.file).unwrap();
        assert_eq!(r[col(h, "status")], "ok", "{case}: {r:?}");
        let radius: f64 = r[col(h, "radius_mm")].parse().unwrap();
        let e = radius / v.radius_mm - 1.0;
        assert!(
            e.abs() < tolerance,
            "{case}: {}: {radius} vs {} ({:+.3}%)",
            v.file,
            v.radius_mm,
            100.0 * e
        );
    }
}

/// A GoPro's 10-bit HEVC with an audio track and a timecode data track: decoded at its
/// native depth (no full-frame conversion), measured like the 8-bit original.
#[test]
fn hevc_10bit_with_audio_and_timecode() {
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("hevc10");
    copy_dir(&common::fixture("sessions/example"), &s);
    for v in example_truth().videos {
        let src = s.join(&v.file);
        let tmp = s.join("tmp.mp4");
        let ok = std::process::Command::new("ffmpeg")
            .args(["-v", "error", "-y", "-i"])
            .arg(&src)
            .args([
                "-f", "lavfi", "-i", "sine=d=1", "-map", "0:v", "-map", "1:a",
            ])
            .args(["-c:v", "libx265", "-pix_fmt", "yuv420p10le", "-crf", "12"])
            .args(["-x265-params", "log-level=error", "-c:a", "aac"])
            .args(["-timecode", "01:00:00:00", "-shortest"])
            .arg(&tmp)
            .status()
            .unwrap()
            .success();
        assert!(ok, "ffmpeg re-encodes {}", v.file);
        fs::rename(&tmp, &src).unwrap();
    }
    let (h, rows) = process_with_true_camera(dir.path(), "hevc10");
    assert_example_radii(&h, &rows, 0.005, "10-bit HEVC");
}
