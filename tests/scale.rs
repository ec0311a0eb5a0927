//! `bendscope process` with the scale off the marker plane or without a board (issue 40
//! item 3), on sessions rendered through a fisheye camera with known marker arcs: a
//! scale board 3 mm in front of or behind the marker plane (`[scale_board] offset_mm`),
//! and no board at all (`[scale_markers] spacing_mm`, the markers of the 0 kPa video).

mod common;

use std::fs;
use std::path::Path;

use bendscope::render::actuator::FrameLook;
use bendscope::render::fixtures::gopro_like_camera;
use bendscope::render::session::{write_session, SessionSpec, SessionTruth};
use common::{col, read_csv, Run};

/// Accuracy asked of the radius with the board's offset given.
const OFFSET_RADIUS_TOLERANCE: f64 = 0.002;
/// Accuracy asked of the radius with the scale from the markers at rest.
const MARKERS_RADIUS_TOLERANCE: f64 = 0.003;
/// Distance of the actuator plane, mm.
const DISTANCE_MM: f64 = 130.0;

/// A small session: 960x720 fisheye, four frames per video, the scale board `offset` mm
/// in front of the marker plane (`None`: no board), its calibration written beside it.
fn render(dir: &Path, name: &str, pressures: &[f64], offset: Option<f64>) -> SessionTruth {
    let spec = SessionSpec {
        camera: gopro_like_camera(960, 720),
        distance_mm: DISTANCE_MM,
        pressures_kpa: pressures.to_vec(),
        radius_law: (3000.0, -0.9, 5.0),
        frames: 4,
        calib_views: 3,
        calib_view_reach: 1.0,
        scale_square_mm: 8.0,
        scale_board_offset_mm: offset,
        distractor: false,
        supersample: 2,
        look: FrameLook::default(),
        seed: 21,
    };
    let truth = write_session(&dir.join(name), &spec).unwrap();
    bendscope::calib::file::write_calibration(
        &dir.join(format!("{name}.yaml")),
        &truth.camera.to_calibration(),
    )
    .unwrap();
    truth
}

/// `process NAME --calibration NAME.yaml --force` in `dir`.
fn process(dir: &Path, name: &str) -> Run {
    let cal = format!("{name}.yaml");
    Run::new(dir, &["process", name, "--calibration", &cal, "--force"])
}

/// Each video's radius relative error (measured / truth - 1), for the videos at a
/// pressure above 0.
fn radius_errors(dir: &Path, name: &str, truth: &SessionTruth) -> Vec<f64> {
    let (h, rows) = read_csv(&dir.join(name).join("bendscope-out/per_video.csv"));
    truth
        .videos
        .iter()
        .filter(|v| v.pressure_kpa > 0.0)
        .map(|v| {
            let r = rows.iter().find(|r| r[0] == v.file).unwrap();
            assert_eq!(r[col(&h, "status")], "ok", "{r:?}");
            r[col(&h, "radius_mm")].parse::<f64>().unwrap() / v.radius_mm - 1.0
        })
        .collect()
}

/// session.json's scale.
fn scale_json(dir: &Path, name: &str) -> serde_json::Value {
    let text = fs::read_to_string(dir.join(name).join("bendscope-out/session.json")).unwrap();
    serde_json::from_str::<serde_json::Value>(&text).unwrap()["scale"].clone()
}

/// A board 3 mm in front of and 3 mm behind the marker plane: with `offset_mm` given,
/// every radius within 0.2% of the truth; without it, off by the ratio of the planes'
/// distances (d / (d + offset) - 1 = -offset / distance), about 2.3% either way.
#[test]
fn a_board_off_the_marker_plane_is_carried_to_it_by_offset_mm() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (name, offset) in [("front", 3.0), ("behind", -3.0)] {
        let truth = render(d, name, &[40.0, 60.0], Some(offset));
        let toml = fs::read_to_string(d.join(name).join("bendscope.toml")).unwrap();
        assert!(toml.contains(&format!("offset_mm = {offset}")), "{toml}");
        let run = process(d, name);
        assert_eq!(run.code, 0, "{run}");
        let with = radius_errors(d, name, &truth);
        let s = scale_json(d, name);
        assert_eq!(s["kind"], format!("board offset {offset:+} mm"), "{s}");
        let plane = &s["board_plane"];
        let board_distance = plane["distance_mm"].as_f64().unwrap();
        assert!(
            (board_distance - (DISTANCE_MM - offset)).abs() < 1.0,
            "{name}: board at {board_distance} mm, rendered at {}",
            DISTANCE_MM - offset
        );
        assert_eq!(plane["offset_mm"].as_f64(), Some(offset));
        let mm_per_px = s["mm_per_px"].as_f64().unwrap();
        eprintln!(
            "{name} ({offset:+} mm): board {board_distance:.2} mm away, {mm_per_px} mm/px in the marker plane, truth {} ({:+.3}%)",
            truth.mm_per_px,
            100.0 * (mm_per_px / truth.mm_per_px - 1.0)
        );
        let report = fs::read_to_string(d.join(name).join("bendscope-out/report.html")).unwrap();
        let side = if offset > 0.0 {
            "in front of"
        } else {
            "behind"
        };
        assert!(
            report.contains(&format!("its plane 3 mm {side} the markers")),
            "the report names the offset"
        );

        // The same session read as if the board lay in the marker plane.
        fs::write(
            d.join(name).join("bendscope.toml"),
            toml.replace(&format!("offset_mm = {offset}\n"), ""),
        )
        .unwrap();
        let run = process(d, name);
        assert_eq!(run.code, 0, "{run}");
        let without = radius_errors(d, name, &truth);
        assert_eq!(scale_json(d, name)["kind"], "board");
        let expected = -offset / DISTANCE_MM;
        for (w, wo) in with.iter().zip(&without) {
            eprintln!(
                "{name} ({offset:+} mm): radius error {:+.3}% with offset_mm, {:+.3}% without (expected {:+.3}%)",
                100.0 * w,
                100.0 * wo,
                100.0 * expected
            );
            assert!(w.abs() < OFFSET_RADIUS_TOLERANCE, "{name}: {w}");
            // The correction alone: the same markers, the scale moved from the board's
            // plane (d = distance - offset) to the markers' (d + offset).
            let moved = (1.0 + w) / (1.0 + wo);
            let want = DISTANCE_MM / (DISTANCE_MM - offset);
            assert!(
                (moved / want - 1.0).abs() < 1e-4,
                "{name}: {moved} vs {want}"
            );
            assert!(
                (wo - expected).abs() < OFFSET_RADIUS_TOLERANCE,
                "{name}: without offset_mm {wo}, expected about {expected}"
            );
        }

        // An offset as far as the board from the camera: refused, naming the key.
        fs::write(
            d.join(name).join("bendscope.toml"),
            toml.replace(&format!("offset_mm = {offset}"), "offset_mm = 140"),
        )
        .unwrap();
        process(d, name).assert_bad_input(&["scale.jpg", "[scale_board] offset_mm", "140"]);
    }
}

/// No board: `[scale_markers] spacing_mm` with the 0 kPa video gives every radius within
/// 0.3% of the truth; a scale photo beside it is not used and a warning says so; a ramp,
/// or a session without a 0 kPa video, is refused in one line.
#[test]
fn the_markers_at_rest_give_the_scale_without_a_board() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = render(d, "rest", &[0.0, 40.0, 60.0], None);
    let s = d.join("rest");
    assert!(!s.join("scale.jpg").exists());
    let toml = fs::read_to_string(s.join("bendscope.toml")).unwrap();
    assert!(
        toml.contains("[scale_markers]\nspacing_mm = [12.500000, "),
        "{toml}"
    );
    let run = process(d, "rest");
    assert_eq!(run.code, 0, "{run}");
    assert!(
        run.stdout
            .contains("from the markers at rest in rest/GX010101.MP4 (4 frames, 7 marker pairs, 87.5 mm apart in all)"),
        "{run}"
    );
    for e in radius_errors(d, "rest", &truth) {
        eprintln!("markers at rest: radius error {:+.3}%", 100.0 * e);
        assert!(e.abs() < MARKERS_RADIUS_TOLERANCE, "{e}");
    }
    let scale = scale_json(d, "rest");
    assert_eq!(scale["kind"], "markers", "{scale}");
    assert_eq!(scale["source"], "markers");
    assert!(scale["file"].as_str().unwrap().ends_with("GX010101.MP4"));
    assert_eq!(scale["rest"]["frames_used"], 4);
    assert_eq!(scale["rest"]["spacing_px"].as_array().unwrap().len(), 7);
    let mm_per_px = scale["mm_per_px"].as_f64().unwrap();
    eprintln!(
        "markers at rest: {mm_per_px} mm/px, truth {} ({:+.3}%)",
        truth.mm_per_px,
        100.0 * (mm_per_px / truth.mm_per_px - 1.0)
    );
    assert!((mm_per_px / truth.mm_per_px - 1.0).abs() < MARKERS_RADIUS_TOLERANCE);

    // A scale photo beside [scale_markers]: the markers win (the photo is not even
    // read), and a warning says so.
    fs::write(s.join("scale.jpg"), b"not read").unwrap();
    let run = process(d, "rest");
    assert!(
        run.stderr.lines().any(|l| l.contains("warning")
            && l.contains("scale.jpg")
            && l.contains("not used: [scale_markers]")),
        "{run}"
    );
    assert_eq!(scale_json(d, "rest")["kind"], "markers");
    fs::remove_file(s.join("scale.jpg")).unwrap();

    // A ramp (one video, a pressure log) has no 0 kPa item: refused in one line.
    let ramp = d.join("ramp");
    fs::create_dir(&ramp).unwrap();
    fs::copy(s.join("GX010102.MP4"), ramp.join("ramp.mp4")).unwrap();
    fs::write(
        ramp.join("pressure_log.csv"),
        "time_s,pressure_kpa\n0,0\n1,50\n",
    )
    .unwrap();
    fs::copy(d.join("rest.yaml"), d.join("ramp.yaml")).unwrap();
    fs::write(
        ramp.join("bendscope.toml"),
        "[scale_markers]\nspacing_mm = 12.5\n",
    )
    .unwrap();
    process(d, "ramp").assert_bad_input(&["[scale_markers]", "a ramp has none", "scale board"]);

    // No 0 kPa video: refused before anything is measured.
    let manifest = fs::read_to_string(s.join("pressures.csv")).unwrap();
    let without_rest: String = manifest
        .lines()
        .filter(|l| !l.starts_with("GX010101.MP4"))
        .map(|l| format!("{l}\n"))
        .collect();
    fs::write(s.join("pressures.csv"), without_rest).unwrap();
    process(d, "rest").assert_bad_input(&["[scale_markers]", "0 kPa", "scale board"]);
}
