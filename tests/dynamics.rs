//! `bendscope process` on rendered ramp recordings whose pressure goes up and down (the
//! hysteresis loop) or steps (the step response), against the laws they were rendered
//! from; and the bad inputs: a log of one level, a step smaller than the noise, too few
//! frames after a step. (In a file of its own: tests/process.rs is near the size where a
//! file holds two rooms.)

mod common;

use std::f64::consts::PI;
use std::fs;
use std::path::Path;

use bendscope::video::{EncodeSettings, VideoWriter};
use common::{col, read_csv, Run};

/// Arc length between the first and last marker of the reference actuator, mm
/// (`ArcScene::reference_actuator`: 8 markers 12.5 mm apart): bending angle = this / R.
const MARKER_SPAN_MM: f64 = 87.5;

/// Renders a ramp session `ramp` in a new folder: `n` frames at `fps` of the reference
/// actuator with curvature `curvature_at(t)` (1/mm, t in the video's clock), 640x480
/// through the GoPro-like camera 120 mm from the plane, the pressure log `log` (log
/// clock = video clock + 0.5 s: `ramp_time_offset_s = 0.5`), mm per px, `ramp_bin_kpa`.
fn render_recording(
    n: usize,
    fps: u32,
    curvature_at: impl Fn(f64) -> f64,
    log: &str,
    bin_kpa: f64,
) -> tempfile::TempDir {
    use bendscope::render::actuator::{ArcScene, FrameLook, PlaneSampler};
    use bendscope::render::board::BoardPose;
    use bendscope::render::fixtures::gopro_like_camera;
    use nalgebra::{Point2, Rotation3, Vector3};
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("ramp");
    fs::create_dir_all(&s).unwrap();
    let camera = gopro_like_camera(640, 480);
    let distance = 120.0;
    let plane = BoardPose {
        rotation: Rotation3::identity(),
        translation_mm: Vector3::new(0.0, 0.0, distance),
    };
    let sampler = PlaneSampler::new(&camera, &plane, 2, 1).unwrap();
    let mut w = VideoWriter::create(
        &s.join("ramp.mp4"),
        640,
        480,
        &EncodeSettings {
            fps,
            crf: 14,
            ..Default::default()
        },
    )
    .unwrap();
    for i in 0..n {
        let t = i as f64 / fps as f64;
        let scene = ArcScene::reference_actuator(curvature_at(t), Point2::new(-45.0, 18.0));
        w.write(&sampler.render(&scene, [0.0, 0.0], &FrameLook::default(), i as u64))
            .unwrap();
    }
    w.finish().unwrap();
    fs::write(s.join("pressure_log.csv"), log).unwrap();
    bendscope::calib::file::write_calibration(&s.join("cam.yaml"), &camera).unwrap();
    let und = bendscope::calib::Undistorter::new(&camera, Default::default()).unwrap();
    let mm_per_px = distance / und.new_camera_matrix()[(0, 0)];
    fs::write(
        s.join("bendscope.toml"),
        format!("calibration = \"cam.yaml\"\nmm_per_px = {mm_per_px}\nramp_time_offset_s = 0.5\nramp_bin_kpa = {bin_kpa}\n"),
    )
    .unwrap();
    dir
}

/// A pressure log sampled every `dt` s on 0..`end` s (log clock) of `p(t)`, plus a
/// deterministic dither of amplitude `noise` kPa.
fn log_csv(end: f64, dt: f64, noise: f64, p: impl Fn(f64) -> f64) -> String {
    let mut s = String::from("time_s,pressure_kpa\n");
    let n = (end / dt).round() as usize;
    for i in 0..=n {
        let t = i as f64 * dt;
        let d = noise * [1.0, -1.0, 0.5, -0.5, 0.0, 0.8, -0.3][i % 7];
        s.push_str(&format!("{t:.4},{:.4}\n", p(t) + d));
    }
    s
}

/// The loading branch's radius (mm) at `p` kPa, and the unloading branch's (a second
/// "simulation": the same at 20 and 50 kPa, up to 15% smaller between).
fn loading_radius(p: f64) -> f64 {
    3000.0 * p.powf(-0.9) + 5.0
}
fn unloading_radius(p: f64) -> f64 {
    loading_radius(p) * (1.0 - 0.15 * (PI * (p - 20.0) / 30.0).sin())
}
fn angle_deg(radius_mm: f64) -> f64 {
    (MARKER_SPAN_MM / radius_mm).to_degrees()
}

/// The pressure of the up-and-down ramp at video time `t`: 20 -> 50 kPa in 1 s and
/// back in 1 s, 20 kPa outside.
fn triangle_kpa(t: f64) -> f64 {
    20.0 + 30.0 * (1.0 - (t - 1.0).abs()).max(0.0)
}

/// A ramp up and down rendered with a different radius law per branch: the loop's area
/// in the pressure-angle plane within 2% of the laws' (Simpson on 3000 intervals), its
/// largest angle difference within 0.25 deg, at a pressure within 3 kPa (the
/// difference is within 0.35 deg of its peak over +-3 kPa, where frame noise can move
/// the binned maximum); branch columns, per-branch fits, plots and the report section.
#[test]
fn up_and_down_ramp_gives_the_rendered_loop() {
    let start = std::time::Instant::now();
    let fps = 30;
    let dir = render_recording(
        61,
        fps,
        |t| {
            let p = triangle_kpa(t);
            1.0 / if t <= 1.0 {
                loading_radius(p)
            } else {
                unloading_radius(p)
            }
        },
        // Regulator dither +-0.05 kPa: below the 1 kPa reversal a turning point needs.
        &log_csv(3.0, 0.02, 0.05, |t| triangle_kpa(t - 0.5)),
        // Bins of 1 kPa: a frame each (1 kPa apart); the loop's common range is then
        // 20..49 kPa, 0.4% of the area short of the laws' 20..50.
        1.0,
    );
    let s = dir.path().join("ramp");
    let run = Run::new(dir.path(), &["process", "ramp"]);
    assert_eq!(run.code, 0, "{run}");
    assert!(!run.stderr.contains("warning"), "{run}");
    let out = s.join("bendscope-out");

    // The truth: the area between the laws' angles over 20..50 kPa, and their largest
    // difference.
    let diff = |p: f64| angle_deg(unloading_radius(p)) - angle_deg(loading_radius(p));
    let n = 3000;
    let h = 30.0 / n as f64;
    let area: f64 = (0..=n)
        .map(|i| {
            let w = if i == 0 || i == n {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            w * diff(20.0 + h * i as f64).abs()
        })
        .sum::<f64>()
        * h
        / 3.0;
    let (peak_p, peak) = (0..=n)
        .map(|i| 20.0 + h * i as f64)
        .map(|p| (p, diff(p)))
        .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a });

    let hy: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("hysteresis.json")).unwrap()).unwrap();
    let branches = hy["branches"].as_array().unwrap();
    assert_eq!(branches.len(), 2, "{hy}");
    assert_eq!(branches[0]["direction"], "loading");
    assert_eq!(branches[1]["direction"], "unloading");
    // The turning point at the top, 1 s into the video (log samples 20 ms apart).
    let turn = branches[0]["end_s"].as_f64().unwrap();
    assert!((turn - 1.0).abs() <= 0.021, "turning point at {turn} s");
    let angle = &hy["loops"][0]["bending_angle_deg"];
    let measured = angle["area"].as_f64().unwrap();
    eprintln!(
        "loop area {measured:.2} vs {area:.2} deg kPa ({:+.2}%); largest difference {:.3} deg at {:.1} kPa vs {peak:.3} at {peak_p:.1}",
        100.0 * (measured / area - 1.0),
        angle["max_difference"].as_f64().unwrap(),
        angle["at_kpa"].as_f64().unwrap(),
    );
    assert!(
        (measured / area - 1.0).abs() < 0.02,
        "area {measured} vs {area}"
    );
    let max = angle["max_difference"].as_f64().unwrap();
    assert!(
        (max - peak).abs() < 0.25,
        "largest difference {max} vs {peak}"
    );
    let at = angle["at_kpa"].as_f64().unwrap();
    assert!((at - peak_p).abs() <= 3.0, "at {at} kPa vs {peak_p}");
    assert!(hy["loops"][0]["radius_mm"]["area"].as_f64().unwrap() > 0.0);

    // per_video.csv: a branch and a cycle column; loading bins rising, then unloading
    // bins falling; per_frame.csv labels every frame.
    let (vh, rows) = read_csv(&out.join("per_video.csv"));
    assert_eq!(&vh[1..4], ["pressure_kpa", "branch", "cycle"], "{vh:?}");
    let labels: Vec<&str> = rows
        .iter()
        .map(|r| r[col(&vh, "branch")].as_str())
        .collect();
    let first_unloading = labels.iter().position(|l| *l == "unloading").unwrap();
    assert!(
        labels[..first_unloading].iter().all(|l| *l == "loading"),
        "{labels:?}"
    );
    assert!(
        labels[first_unloading..].iter().all(|l| *l == "unloading"),
        "{labels:?}"
    );
    assert!(rows.iter().all(|r| r[col(&vh, "cycle")] == "1"));
    let p = |r: &Vec<String>| r[col(&vh, "pressure_kpa")].parse::<f64>().unwrap();
    assert!(rows[..first_unloading]
        .windows(2)
        .all(|w| p(&w[1]) > p(&w[0])));
    assert!(rows[first_unloading..]
        .windows(2)
        .all(|w| p(&w[1]) < p(&w[0])));
    let (fh, frames) = read_csv(&out.join("per_frame.csv"));
    assert_eq!(frames.len(), 61);
    for f in &frames {
        let t: f64 = f[col(&fh, "time_s")].parse().unwrap();
        let want = if t <= turn { "loading" } else { "unloading" };
        assert_eq!(f[col(&fh, "branch")], want, "frame at {t} s");
    }
    // Each branch fitted on its own rows: its power law against the one fitted to the
    // law's own angles at the branch's pressures (within 0.3 deg on 22..48 kPa: the
    // frames' scatter; the unloading law is no power law, so both fits miss it alike).
    let fit: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("fit.json")).unwrap()).unwrap();
    let fb = fit["branches"].as_array().unwrap();
    assert_eq!(fb.len(), 2);
    let eval = |f: &serde_json::Value, p: f64| {
        let g = |k: &str| f["bending_angle_deg_vs_kpa"][k].as_f64().unwrap();
        g("a") * p.powf(g("b")) + g("c")
    };
    for (f, branch, law) in [
        (&fb[0], "loading", loading_radius as fn(f64) -> f64),
        (&fb[1], "unloading", unloading_radius),
    ] {
        let ps: Vec<f64> = rows
            .iter()
            .filter(|r| r[col(&vh, "branch")] == branch)
            .map(p)
            .collect();
        assert_eq!(
            f["bending_angle_deg_vs_kpa"]["n"].as_u64().unwrap() as usize,
            ps.len()
        );
        let truth: Vec<f64> = ps.iter().map(|p| angle_deg(law(*p))).collect();
        let want = bendscope::fit::fit_power_law(&ps, &truth).unwrap();
        for q in [22.0, 30.0, 40.0, 48.0] {
            assert!(
                (eval(f, q) - want.eval(q)).abs() < 0.3,
                "{branch} at {q} kPa: {f}"
            );
        }
    }
    for stem in ["hysteresis_angle", "hysteresis_radius"] {
        assert!(out.join(format!("plots/{stem}.png")).is_file(), "{stem}");
    }
    let html = fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("<h2>Hysteresis</h2>") && html.contains("hysteresis_angle.svg"));
    assert!(
        !out.join("step_response.csv").exists(),
        "no step in this log"
    );
    if let Some(d) = std::env::var_os("BENDSCOPE_DOCS_IMAGES") {
        fs::copy(
            out.join("plots/hysteresis_angle.png"),
            Path::new(&d).join("hysteresis-loop.png"),
        )
        .unwrap();
    }
    eprintln!(
        "up_and_down_ramp_gives_the_rendered_loop: {:.1} s",
        start.elapsed().as_secs_f64()
    );
}

/// The actuator's pressure after the log's step (log 20 -> 50 kPa in 50 ms from 1.0 s
/// of the log clock, 0.5 s of the video's): p(t) = 20 + 30 (1 - exp(-(t - 0.5)/0.2)).
const STEP_T0: f64 = 0.5;
const STEP_TAU: f64 = 0.2;
fn actuator_kpa(t: f64) -> f64 {
    if t < STEP_T0 {
        20.0
    } else {
        20.0 + 30.0 * (1.0 - (-(t - STEP_T0) / STEP_TAU).exp())
    }
}

/// A rendered step: curvature linear in the actuator's pressure, so the bending angle is
/// itself a first-order response of tau 0.2 s starting at 0.5 s. Asserted: the angle's
/// fitted time constant within one frame period (1/30 s) of 0.2 s, its onset within one
/// frame of 0.5 s, the logged pressure's 10-90% rise 40 ms (0.8 x 50 ms, 1 ms), the
/// delay of the angle's 50% crossing after the log's (0.2 ln 2 - 0.025 s) within one
/// frame; no overshoot beyond the frames' scatter (1%).
#[test]
fn rendered_step_gives_the_first_order_time_constant() {
    let start = std::time::Instant::now();
    let fps = 30;
    // 1/mm: R 208 mm at 20 kPa to 94 mm at 50 kPa (the ramp test's range).
    let curvature = |p: f64| 1.0 / 208.0 + (p - 20.0) * (1.0 / 94.0 - 1.0 / 208.0) / 30.0;
    let dir = render_recording(
        60,
        fps,
        |t| curvature(actuator_kpa(t)),
        &log_csv(3.0, 0.01, 0.0, |t| {
            20.0 + 30.0 * ((t - 1.0) / 0.05).clamp(0.0, 1.0)
        }),
        5.0,
    );
    let s = dir.path().join("ramp");
    let run = Run::new(dir.path(), &["process", "ramp"]);
    assert_eq!(run.code, 0, "{run}");
    let out = s.join("bendscope-out");
    let (h, rows) = read_csv(&out.join("step_response.csv"));
    let row = |q: &str| -> &Vec<String> {
        rows.iter()
            .find(|r| r[col(&h, "quantity")] == q)
            .unwrap_or_else(|| panic!("no {q} row: {rows:?}"))
    };
    let v = |q: &str, c: &str| -> f64 { row(q)[col(&h, c)].parse().unwrap() };
    let frame = 1.0 / fps as f64;
    assert_eq!(
        rows.len(),
        4,
        "pressure, angle, radius, curvature: {rows:?}"
    );
    let tau = v("bending_angle_deg", "tau_s");
    let t0 = v("bending_angle_deg", "t0_s");
    let delay = v("bending_angle_deg", "delay_s");
    let true_delay = STEP_TAU * 2f64.ln() - 0.025;
    eprintln!(
        "angle tau {tau:.4} s (true {STEP_TAU}), t0 {t0:.4} s (true {STEP_T0}), rise {:.4} s (true {:.4}), delay {delay:.4} s (true {true_delay:.4}), overshoot {:.2}%, settling {:.3} s (true {:.3}); pressure rise {:.4} s; curvature tau {:.4} s",
        v("bending_angle_deg", "rise_time_s"),
        STEP_TAU * 9f64.ln(),
        v("bending_angle_deg", "overshoot_pct"),
        v("bending_angle_deg", "settling_time_s"),
        STEP_T0 - 0.5 + STEP_TAU * 50f64.ln(),
        v("pressure_kpa", "rise_time_s"),
        v("curvature_per_m", "tau_s"),
    );
    assert!((tau - STEP_TAU).abs() < frame, "tau {tau}");
    assert!((t0 - STEP_T0).abs() < frame, "t0 {t0}");
    assert!((v("pressure_kpa", "rise_time_s") - 0.04).abs() < 1e-3);
    assert!((v("bending_angle_deg", "pressure_rise_time_s") - 0.04).abs() < 1e-3);
    assert!(
        (delay - true_delay).abs() < frame,
        "delay {delay} vs {true_delay}"
    );
    assert!(v("bending_angle_deg", "overshoot_pct") < 1.0);
    // The angle's step: 87.5 mm x the curvature's change.
    let dy = v("bending_angle_deg", "final") - v("bending_angle_deg", "initial");
    let true_dy = angle_deg(1.0 / curvature(50.0)) - angle_deg(1.0 / curvature(20.0));
    assert!((dy / true_dy - 1.0).abs() < 0.01, "{dy} vs {true_dy}");
    assert!(out.join("plots/step_response_angle.png").is_file());
    assert!(out.join("plots/step_response_normalised.png").is_file());
    let html = fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("<h2>Step response</h2>"));
    assert!(
        !out.join("hysteresis.json").exists(),
        "the pressure only rises"
    );
    if let Some(d) = std::env::var_os("BENDSCOPE_DOCS_IMAGES") {
        fs::copy(
            out.join("plots/step_response_angle.png"),
            Path::new(&d).join("step-response.png"),
        )
        .unwrap();
    }
    eprintln!(
        "rendered_step_gives_the_first_order_time_constant: {:.1} s",
        start.elapsed().as_secs_f64()
    );
}

/// Bad input on one rendered hold (20 frames, R 120 mm) with three logs: one level
/// with regulator noise (no step, no branches: no step_response.csv, hysteresis.json
/// or branch column, and nothing said); a 1.5 kPa step within noise of +-0.5 kPa (said
/// once, not measured); a step 0.1 s before the video ends (too few frames after it:
/// said once, the pressure's row and the other outputs kept).
#[test]
fn one_level_small_steps_and_late_steps_are_said_once() {
    let start = std::time::Instant::now();
    let dir = render_recording(20, 30, |_| 1.0 / 120.0, "", 2.0);
    let video = dir.path().join("ramp/ramp.mp4");
    let cases: [(&str, String, Option<&str>); 3] = [
        ("level", log_csv(2.0, 0.01, 0.3, |_| 30.0), None),
        (
            "small",
            log_csv(2.0, 0.01, 0.5, |t| if t < 0.8 { 30.0 } else { 31.5 }),
            Some("less than the"),
        ),
        (
            "late",
            log_csv(2.0, 0.01, 0.0, |t| if t < 1.05 { 20.0 } else { 40.0 }),
            Some("no step response for it"),
        ),
    ];
    for (name, log, said) in cases {
        let s = dir.path().join(name);
        fs::create_dir_all(&s).unwrap();
        for f in ["ramp.mp4", "cam.yaml", "bendscope.toml"] {
            fs::copy(video.with_file_name(f), s.join(f)).unwrap();
        }
        fs::write(s.join("pressure_log.csv"), log).unwrap();
        let run = Run::new(dir.path(), &["process", name]);
        assert!(run.code == 0, "{name}: {run}");
        let out = s.join("bendscope-out");
        let lines: Vec<&str> = run
            .stderr
            .lines()
            .filter(|l| l.contains("step") || l.contains("branch") || l.contains("hysteresis"))
            .collect();
        match said {
            None => assert!(lines.is_empty(), "{name}: {run}"),
            Some(n) => {
                assert_eq!(lines.len(), 1, "{name}: {run}");
                assert!(lines[0].contains(n), "{name}: {run}");
            }
        }
        assert!(!out.join("hysteresis.json").exists(), "{name}");
        let (vh, _) = read_csv(&out.join("per_video.csv"));
        assert!(!vh.iter().any(|c| c == "branch"), "{name}: {vh:?}");
        assert!(out.join("report.html").is_file() && out.join("fit.json").is_file());
        if name == "late" {
            let (h, rows) = read_csv(&out.join("step_response.csv"));
            assert_eq!(rows.len(), 1, "the pressure's row only: {rows:?}");
            assert_eq!(rows[0][col(&h, "quantity")], "pressure_kpa");
        } else {
            assert!(!out.join("step_response.csv").exists(), "{name}");
        }
    }
    eprintln!(
        "one_level_small_steps_and_late_steps_are_said_once: {:.1} s",
        start.elapsed().as_secs_f64()
    );
}

/// A step session whose manifest goes 20 -> 80 kPa and back down through copies of the
/// 65, 35 and 20 kPa videos: rows split into a loading and an unloading branch (the
/// 80 kPa video ends the first and starts the loop's second), and the loop is the one
/// between the per_video.csv means: the unloading branch has no 50 kPa video, so the
/// two polylines differ only by d = (a35 + a65)/2 - a50 at 50 kPa, a triangle of area
/// 15 |d| deg kPa on 35..65 kPa.
#[test]
fn step_session_up_and_down_splits_its_videos() {
    let start = std::time::Instant::now();
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("s");
    common::copy_dir(&common::fixture("sessions/example"), &s);
    for (copy, of) in [
        ("down65.MP4", "GX010104.MP4"),
        ("down35.MP4", "GX010102.MP4"),
        ("down20.MP4", "GX010101.MP4"),
    ] {
        fs::copy(s.join(of), s.join(copy)).unwrap();
    }
    fs::write(
        s.join("pressures.csv"),
        "file,pressure_kpa\nGX010101.MP4,20\nGX010102.MP4,35\nGX010103.MP4,50\nGX010104.MP4,65\nGX010105.MP4,80\ndown65.MP4,65\ndown35.MP4,35\ndown20.MP4,20\n",
    )
    .unwrap();
    let run = Run::new(dir.path(), &["process", "s"]);
    assert_eq!(run.code, 0, "{run}");
    let out = s.join("bendscope-out");
    let (h, rows) = read_csv(&out.join("per_video.csv"));
    let labels: Vec<&str> = rows.iter().map(|r| r[col(&h, "branch")].as_str()).collect();
    assert_eq!(
        labels,
        [
            "loading",
            "loading",
            "loading",
            "loading",
            "loading",
            "unloading",
            "unloading",
            "unloading"
        ]
    );
    let angle = |f: &str| -> f64 {
        rows.iter().find(|r| r[0] == f).unwrap()[col(&h, "bending_angle_deg")]
            .parse()
            .unwrap()
    };
    let d = (angle("GX010102.MP4") + angle("GX010104.MP4")) / 2.0 - angle("GX010103.MP4");
    let hy: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("hysteresis.json")).unwrap()).unwrap();
    let l = &hy["loops"][0]["bending_angle_deg"];
    assert_eq!(l["from_kpa"].as_f64(), Some(20.0), "{hy}");
    assert_eq!(
        l["to_kpa"].as_f64(),
        Some(80.0),
        "the top is on both branches: {hy}"
    );
    // per_video.csv's 4 decimals: 1e-4 deg on each mean.
    assert!(
        (l["area"].as_f64().unwrap() - 15.0 * d.abs()).abs() < 15.0 * 2e-4,
        "{l} vs d {d}"
    );
    assert!(
        (l["max_difference"].as_f64().unwrap() - d).abs() < 2e-4,
        "{l} vs {d}"
    );
    assert_eq!(l["at_kpa"].as_f64(), Some(50.0));
    let (fh, frames) = read_csv(&out.join("per_frame.csv"));
    assert!(frames
        .iter()
        .all(|f| (f[0].starts_with("down")) == (f[col(&fh, "branch")] == "unloading")));
    eprintln!(
        "step_session_up_and_down_splits_its_videos: {:.1} s",
        start.elapsed().as_secs_f64()
    );
}
