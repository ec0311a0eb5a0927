//! Outline mode (`[detect] mode = "outline"`) end to end: one rendered actuator filmed
//! with dots and without, the dots measured in dots mode and the bare body in outline
//! mode with `outline_offset_mm` = the dot line's height above the strain-limited face.
//!
//! What the render can check: its body is a band of constant thickness around the dot
//! line (no chambers), so its strain-limited edge is exactly concentric with the dot
//! line, 14 mm below it, and its outer edge is smooth. The test checks the edge's
//! segmentation, the cut at the clamp and the tip, the choice of the concave edge, the
//! undistortion and the offset against the dots, not the chambers' bumps (those are
//! checked on a notched band in the unit tests of `pipeline::frame::outline`).

mod common;

use std::fs;
use std::path::Path;

use bendscope::render::actuator::FrameLook;
use bendscope::render::fixtures::gopro_like_camera;
use bendscope::render::session::{write_session, write_session_without_dots, SessionSpec};
use common::{col, read_csv, Run};

/// The render's dot line lies this far above the body's strain-limited face, mm
/// (`ArcScene::reference_actuator`'s `below_mm`).
const DOT_LINE_HEIGHT_MM: f64 = 14.0;
/// Outline radius against the dots' at every pressure (the 1%).
const OUTLINE_VS_DOTS: f64 = 0.01;

fn spec() -> SessionSpec {
    SessionSpec {
        camera: gopro_like_camera(640, 480),
        distance_mm: 130.0,
        pressures_kpa: vec![20.0, 40.0, 60.0, 80.0],
        radius_law: (3000.0, -0.9, 5.0),
        frames: 3,
        calib_views: 3,
        calib_view_reach: 1.0,
        scale_square_mm: 8.0,
        distractor: false,
        supersample: 2,
        look: FrameLook::default(),
        seed: 11,
        scale_board_offset_mm: Some(0.0),
    }
}

/// Processes `name` under `dir` with the camera `cal`; the per-video radii by file.
fn radii(dir: &Path, name: &str, cal: &Path) -> Vec<(String, f64)> {
    let run = Run::new(
        dir,
        &["process", name, "--calibration", cal.to_str().unwrap()],
    );
    assert_eq!(run.code, 0, "{run}");
    let (h, rows) = read_csv(&dir.join(name).join("bendscope-out/per_video.csv"));
    rows.iter()
        .map(|r| {
            assert_eq!(r[col(&h, "status")], "ok", "{name}: {r:?}");
            assert_eq!(r[col(&h, "frames_rejected")], "0", "{name}: {r:?}");
            (r[0].clone(), r[col(&h, "radius_mm")].parse().unwrap())
        })
        .collect()
}

#[test]
fn outline_radii_match_the_dots_of_the_same_actuator() {
    let dir = tempfile::tempdir().unwrap();
    let truth = write_session(&dir.path().join("dots"), &spec()).unwrap();
    write_session_without_dots(&dir.path().join("bare"), &spec()).unwrap();
    let cal = dir.path().join("cam.yaml");
    bendscope::calib::file::write_calibration(&cal, &truth.camera.to_calibration()).unwrap();
    let bare = dir.path().join("bare");
    fs::write(
        bare.join("bendscope.toml"),
        format!(
            "[scale_board]\ncols = 9\nrows = 6\nsquare_mm = 8\n[detect]\nmode = \"outline\"\noutline_offset_mm = {DOT_LINE_HEIGHT_MM}\n"
        ),
    )
    .unwrap();
    // Without dots, dots mode finds none.
    let dots = radii(dir.path(), "dots", &cal);
    let outline = radii(dir.path(), "bare", &cal);
    assert_eq!(dots.len(), truth.videos.len());
    for ((file, d), ((_, o), v)) in dots.iter().zip(outline.iter().zip(&truth.videos)) {
        let vs_dots = o / d - 1.0;
        eprintln!(
            "{file}: truth {:.2} dots {d:.2} outline {o:.2} mm: {:+.3}% vs dots, {:+.3}% vs truth",
            v.radius_mm,
            100.0 * vs_dots,
            100.0 * (o / v.radius_mm - 1.0)
        );
        assert!(
            vs_dots.abs() < OUTLINE_VS_DOTS,
            "{file}: outline {o} vs dots {d} ({:+.3}%)",
            100.0 * vs_dots
        );
        assert!(
            (o / v.radius_mm - 1.0).abs() < OUTLINE_VS_DOTS,
            "{file}: outline {o} vs truth {}",
            v.radius_mm
        );
    }
    // The overlay shows the body's outline and the reported line.
    assert!(bare
        .join("bendscope-out/overlays")
        .join(format!("{}.png", truth.videos[0].file))
        .is_file());
    // The background in the body's band: every video fails with the reason, nothing is
    // measured (exit 3).
    fs::write(
        bare.join("bendscope.toml"),
        "[scale_board]\nsquare_mm = 8\n[detect]\nmode = \"outline\"\noutline_s_min = 0\n",
    )
    .unwrap();
    let run = Run::new(
        dir.path(),
        &["process", "bare", "--calibration", cal.to_str().unwrap()],
    );
    assert_eq!(run.code, 3, "{run}");
    assert!(
        run.stderr
            .contains("the background is in the outline colour band"),
        "{run}"
    );
    // Bad values of the outline keys: one line, exit 2.
    for (text, needle) in [
        (
            "mode = \"outline\"\noutline_offset_mm = nan",
            "`outline_offset_mm` = NaN: must be a finite",
        ),
        (
            "mode = \"outline\"\noutline_clamp_mm = -2",
            "`outline_clamp_mm` = -2: must be a length",
        ),
        (
            "mode = \"sideways\"",
            "unknown mode `sideways`: use one of dots, outline",
        ),
        ("outline_hue_max = 200", "200 is outside 0..180"),
    ] {
        fs::write(
            bare.join("bendscope.toml"),
            format!("[scale_board]\nsquare_mm = 8\n[detect]\n{text}\n"),
        )
        .unwrap();
        let run = Run::new(
            dir.path(),
            &["process", "bare", "--calibration", cal.to_str().unwrap()],
        );
        run.assert_bad_input(&[needle]);
    }
    // Segments need dots.
    fs::write(
        bare.join("bendscope.toml"),
        "segments = [[1, 2, 3, 4], [4, 5, 6, 7, 8]]\n[scale_board]\nsquare_mm = 8\n[detect]\nmode = \"outline\"\n",
    )
    .unwrap();
    let run = Run::new(
        dir.path(),
        &["process", "bare", "--calibration", cal.to_str().unwrap()],
    );
    run.assert_bad_input(&["segments need dots"]);
}
