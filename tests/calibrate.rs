//! `bendscope calibrate` and `bendscope scale` on real and synthetic photos, with the
//! reference numbers of method.md and the ground truth of the synthetic fixtures.

mod common;

use std::fs;

use bendscope::calib::file::read_calibration;
use bendscope::calib::{UndistortSettings, Undistorter};
use bendscope::render::fixtures::CalibrationSetTruth;
use common::{fixture, Run};

/// OpenCV's published calibration of its left*.jpg samples (method.md §5).
const LEFT_FX: f64 = 535.92;
#[allow(clippy::approx_constant)] // a published RMS in pixels, not pi / 8
const LEFT_RMS: f64 = 0.3926;

fn truth() -> CalibrationSetTruth {
    let text = fs::read_to_string(fixture("fisheye/truth.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn pinhole_on_opencv_samples_matches_the_published_result() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("left.yaml");
    let run = Run::new(
        dir.path(),
        &[
            "calibrate",
            fixture("opencv-left").to_str().unwrap(),
            "--model",
            "pinhole",
            "--fix-aspect-ratio",
            "--board",
            "9x6",
            "--square-mm",
            "25",
            "-o",
            out.to_str().unwrap(),
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    let c = read_calibration(&out).unwrap();
    assert_eq!(c.views_used.len(), 13, "{run}");
    assert!(
        (c.fx() / LEFT_FX - 1.0).abs() < 0.005,
        "fx {} vs {LEFT_FX}",
        c.fx()
    );
    assert_eq!(c.fx(), c.fy(), "aspect ratio fixed");
    assert!(
        (c.avg_reprojection_error - LEFT_RMS).abs() < 0.02,
        "RMS {} vs {LEFT_RMS}",
        c.avg_reprojection_error
    );
    assert!((c.cx() - 342.28).abs() < 2.0 && (c.cy() - 235.57).abs() < 2.0);
    // The non-image files in the folder are listed, not fatal.
    assert!(
        run.stdout.contains("rejected README.md: not an image"),
        "{run}"
    );
}

#[test]
fn fisheye_on_synthetic_gopro_photos_recovers_the_camera() {
    let t = truth();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("gopro.yaml");
    let run = Run::new(
        dir.path(),
        &[
            "calibrate",
            fixture("fisheye/calib").to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    let c = read_calibration(&out).unwrap();
    let k = t.camera.k;
    assert!(c.views_used.len() >= 15, "{run}");
    assert!(
        (c.fx() / k[0][0] - 1.0).abs() < 0.005,
        "fx {} vs {}",
        c.fx(),
        k[0][0]
    );
    assert!(
        (c.fy() / k[1][1] - 1.0).abs() < 0.005,
        "fy {} vs {}",
        c.fy(),
        k[1][1]
    );
    assert!(
        (c.cx() - k[0][2]).abs() < 2.0,
        "cx {} vs {}",
        c.cx(),
        k[0][2]
    );
    assert!(
        (c.cy() - k[1][2]).abs() < 2.0,
        "cy {} vs {}",
        c.cy(),
        k[1][2]
    );
    assert!(
        c.avg_reprojection_error < 0.5,
        "RMS {}",
        c.avg_reprojection_error
    );
    // The file is plain OpenCV YAML.
    let text = fs::read_to_string(&out).unwrap();
    assert!(text.starts_with("%YAML:1.0"));
    assert!(text.contains("model: fisheye"));
    assert!(text.contains("camera_matrix: !!opencv-matrix"));
    // The boards were spread to the frame's corners: the field reaches about 60° (the
    // frame's corners lie at 73°), the true lens is monotonic throughout, and no warning.
    for key in [
        "valid_field_angle_deg:",
        "monotonic_field_angle_deg:",
        "coverage_field_angle_deg:",
        "coverage_grid: !!opencv-matrix",
    ] {
        assert!(text.contains(key), "{key} missing");
    }
    let field = c.valid_field();
    assert_eq!(field.monotonic_angle_deg, 90.0);
    assert!(
        field.valid_angle_deg() > 55.0 && field.valid_angle_deg() < 65.0,
        "{field:?}"
    );
    assert!(
        run.stdout.contains("board coverage: corners reached"),
        "{run}"
    );
    assert!(!run.stderr.contains("warning"), "{run}");
}

#[test]
fn fisheye_from_a_video_of_the_board() {
    use bendscope::video::{EncodeSettings, VideoWriter};
    let t = truth();
    let dir = tempfile::tempdir().unwrap();
    let video = dir.path().join("GX010001.MP4");
    let mut w = VideoWriter::create(
        &video,
        t.camera.width,
        t.camera.height,
        &EncodeSettings {
            fps: 10,
            crf: 12,
            ..Default::default()
        },
    )
    .unwrap();
    let mut names: Vec<_> = fs::read_dir(fixture("fisheye/calib"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    for p in &names {
        let img = image::open(p).unwrap().into_rgb8();
        // Three frames per pose, as a slow sweep would give.
        for _ in 0..3 {
            w.write(&img).unwrap();
        }
    }
    w.finish().unwrap();
    let out = dir.path().join("v.yaml");
    let run = Run::new(
        dir.path(),
        &[
            "calibrate",
            "GX010001.MP4",
            "--frames",
            "20",
            "-o",
            out.to_str().unwrap(),
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    let c = read_calibration(&out).unwrap();
    assert!(c.views_used.len() >= 15, "{run}");
    assert!(
        c.views_used[0].starts_with("GX010001.MP4#frame"),
        "{:?}",
        c.views_used
    );
    let k = t.camera.k;
    assert!(
        (c.fx() / k[0][0] - 1.0).abs() < 0.005,
        "fx {} vs {}",
        c.fx(),
        k[0][0]
    );
    assert!(
        (c.fy() / k[1][1] - 1.0).abs() < 0.005,
        "fy {} vs {}",
        c.fy(),
        k[1][1]
    );
    assert!((c.cx() - k[0][2]).abs() < 2.0 && (c.cy() - k[1][2]).abs() < 2.0);
    // A corrupt video is named with what to do.
    fs::write(dir.path().join("bad.mp4"), b"not a video").unwrap();
    Run::new(dir.path(), &["calibrate", "bad.mp4"])
        .assert_bad_input(&["bad.mp4", "not a video FFmpeg can read"]);
}

#[test]
fn scale_of_an_in_plane_board_is_recovered() {
    let t = truth();
    let dir = tempfile::tempdir().unwrap();
    // With the true camera: the true mm per undistorted px.
    let true_cal = dir.path().join("true.yaml");
    bendscope::calib::file::write_calibration(&true_cal, &t.camera.to_calibration()).unwrap();
    let json = dir.path().join("scale.json");
    let run = Run::new(
        dir.path(),
        &[
            "scale",
            fixture("fisheye/scale.jpg").to_str().unwrap(),
            "--calibration",
            true_cal.to_str().unwrap(),
            "--save",
            json.to_str().unwrap(),
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    let s: bendscope::scale::Scale =
        serde_json::from_str(&fs::read_to_string(&json).unwrap()).unwrap();
    assert!(
        (s.mm_per_px / t.mm_per_px - 1.0).abs() < 0.002,
        "mm/px {} vs {}",
        s.mm_per_px,
        t.mm_per_px
    );
    assert!(!s.looks_tilted(), "spread {}", s.spread);
}

#[test]
fn scale_with_an_estimated_calibration_matches_its_own_undistorted_space() {
    let t = truth();
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("est.yaml");
    let run = Run::new(
        dir.path(),
        &[
            "calibrate",
            fixture("fisheye/calib").to_str().unwrap(),
            "-o",
            cal.to_str().unwrap(),
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    let est = read_calibration(&cal).unwrap();
    let p = Undistorter::new(&est, UndistortSettings::default())
        .unwrap()
        .new_camera_matrix();
    let expected = t.scale_distance_mm / p[(0, 0)];
    let scale = bendscope::scale::scale_from_board_photo(
        &fixture("fisheye/scale.jpg"),
        &est,
        &bendscope::calib::Board::new(9, 6, 25.0).unwrap(),
        UndistortSettings::default(),
    )
    .unwrap();
    assert!(
        (scale.mm_per_px / expected - 1.0).abs() < 0.002,
        "mm/px {} vs {expected}",
        scale.mm_per_px
    );
}

#[test]
fn fov_scale_uses_the_published_formula() {
    let dir = tempfile::tempdir().unwrap();
    let run = Run::new(
        dir.path(),
        &["scale", "--fov-mm", "300", "--width-px", "1920"],
    );
    assert_eq!(run.code, 0, "{run}");
    assert_eq!(run.stdout.trim(), "0.156250 mm/px");
}

// ---- bad input: one clear line naming the file, exit 2, no panic ----

fn copy_left(dir: &std::path::Path, names: &[&str]) {
    for n in names {
        fs::copy(fixture("opencv-left").join(n), dir.join(n)).unwrap();
    }
}

#[test]
fn empty_folder_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty");
    fs::create_dir(&empty).unwrap();
    Run::new(dir.path(), &["calibrate", "empty"])
        .assert_bad_input(&["no calibration images", "empty"]);
}

#[test]
fn missing_path_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    Run::new(dir.path(), &["calibrate", "nowhere"]).assert_bad_input(&["nowhere", "no such file"]);
}

#[test]
fn corrupt_image_is_named_and_the_others_used() {
    let dir = tempfile::tempdir().unwrap();
    let imgs = dir.path().join("imgs");
    fs::create_dir(&imgs).unwrap();
    copy_left(
        &imgs,
        &["left01.jpg", "left02.jpg", "left03.jpg", "left04.jpg"],
    );
    let bytes = fs::read(imgs.join("left04.jpg")).unwrap();
    fs::write(imgs.join("left05.jpg"), &bytes[..bytes.len() / 3]).unwrap();
    fs::write(imgs.join("broken.png"), b"this is not a png").unwrap();
    let run = Run::new(
        dir.path(),
        &["calibrate", "imgs", "--model", "pinhole", "-o", "out.yaml"],
    );
    assert_eq!(run.code, 0, "{run}");
    assert!(
        run.stdout
            .contains("rejected broken.png: not a readable image"),
        "{run}"
    );
    assert!(dir.path().join("out.yaml").is_file());
}

#[test]
fn only_corrupt_images_name_the_files() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("a.jpg"), b"garbage").unwrap();
    Run::new(dir.path(), &["calibrate", "a.jpg"])
        .assert_bad_input(&["a.jpg: not a readable image"]);
}

#[test]
fn no_board_in_any_view_and_wrong_board_size() {
    let dir = tempfile::tempdir().unwrap();
    let run = Run::new(
        dir.path(),
        &[
            "calibrate",
            fixture("opencv-left").to_str().unwrap(),
            "--board",
            "8x5",
            "--model",
            "pinhole",
        ],
    );
    run.assert_bad_input(&[
        "only 0 view(s) with a 8x5 board",
        "check --board",
        "left01.jpg: no 8x5 board found",
    ]);
    let run = Run::new(dir.path(), &["calibrate", "x", "--board", "9"]);
    assert_eq!(run.code, 2, "{run}");
    assert!(run.stderr.contains("COLSxROWS"), "{run}");
}

#[test]
fn too_few_views_for_the_model() {
    let dir = tempfile::tempdir().unwrap();
    copy_left(dir.path(), &["left01.jpg", "left02.jpg"]);
    Run::new(
        dir.path(),
        &[
            "calibrate",
            "left01.jpg",
            "left02.jpg",
            "--model",
            "pinhole",
        ],
    )
    .assert_bad_input(&["only 2 view(s)", "needs at least 3"]);
}

#[test]
fn mixed_resolutions_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let imgs = dir.path().join("imgs");
    fs::create_dir(&imgs).unwrap();
    copy_left(&imgs, &["left01.jpg", "left02.jpg", "left03.jpg"]);
    fs::copy(fixture("fisheye/calib/board01.jpg"), imgs.join("zz.jpg")).unwrap();
    Run::new(dir.path(), &["calibrate", "imgs", "--model", "pinhole"])
        .assert_bad_input(&["zz.jpg: 960x720 differs", "640x480"]);
}

#[test]
fn a_non_image_file_argument_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("notes.txt"), b"hello").unwrap();
    Run::new(dir.path(), &["calibrate", "notes.txt"])
        .assert_bad_input(&["notes.txt", "not an image"]);
}

#[test]
fn a_yaml_that_is_not_a_calibration_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("other.yaml"), "%YAML:1.0\n---\nfoo: 3\n").unwrap();
    fs::write(dir.path().join("text.yaml"), "just: [unbalanced\n").unwrap();
    let scale = fixture("fisheye/scale.jpg");
    for f in ["other.yaml", "text.yaml"] {
        Run::new(
            dir.path(),
            &["scale", scale.to_str().unwrap(), "--calibration", f],
        )
        .assert_bad_input(&[f, "not a bendscope calibration"]);
    }
}

#[test]
fn nonsense_numbers_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for bad in ["--square-mm=-3", "--square-mm=0", "--square-mm=nan"] {
        let run = Run::new(dir.path(), &["calibrate", "x", bad]);
        assert_eq!(run.code, 2, "{run}");
        assert!(run.stderr.contains("not a positive number"), "{run}");
    }
    let run = Run::new(
        dir.path(),
        &["scale", "--fov-mm", "abc", "--width-px", "100"],
    );
    assert_eq!(run.code, 2, "{run}");
}

/// Copies the photos (not the other files) of fixture folder `from` into `to`.
fn copy_photos(from: &str, to: &std::path::Path) {
    fs::create_dir_all(to).unwrap();
    for e in fs::read_dir(fixture(from)).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "jpg" || x == "png") {
            fs::copy(&p, to.join(p.file_name().unwrap())).unwrap();
        }
    }
}

#[test]
fn copies_of_one_photo_count_once_and_give_the_calibration_of_the_distinct_views() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_photos("opencv-left", &d.join("distinct"));
    copy_photos("opencv-left", &d.join("copies"));
    for k in 1..=15 {
        fs::copy(
            fixture("opencv-left/left01.jpg"),
            d.join(format!("copies/left01_copy{k:02}.jpg")),
        )
        .unwrap();
    }
    let calibrate = |folder: &str| {
        let run = Run::new(
            d,
            &[
                "calibrate",
                folder,
                "--model",
                "pinhole",
                "--fix-aspect-ratio",
                "-o",
                &format!("{folder}.yaml"),
            ],
        );
        assert_eq!(run.code, 0, "{run}");
        (
            run,
            read_calibration(&d.join(format!("{folder}.yaml"))).unwrap(),
        )
    };
    let (_, distinct) = calibrate("distinct");
    let (run, copies) = calibrate("copies");
    assert!(
        run.stdout.contains(
            "from 13 view(s) (28 given, 15 duplicates of another view dropped), 0 rejected"
        ),
        "{run}"
    );
    assert!(
        run.stdout
            .contains("rejected left01_copy15.jpg: duplicate of left01.jpg"),
        "{run}"
    );
    assert_eq!(copies.views_used, distinct.views_used);
    let same = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1.0);
    for (a, b) in [
        (copies.fx(), distinct.fx()),
        (copies.fy(), distinct.fy()),
        (copies.cx(), distinct.cx()),
        (copies.cy(), distinct.cy()),
        (
            copies.avg_reprojection_error,
            distinct.avg_reprojection_error,
        ),
    ] {
        assert!(same(a, b), "{a} vs {b} (the distinct views alone)");
    }
    for (a, b) in copies.distortion.iter().zip(&distinct.distortion) {
        assert!(same(*a, *b), "distortion {a} vs {b}");
    }
}

#[test]
fn the_default_output_is_named_after_the_session_and_never_replaces_another_camera() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_photos("opencv-left", &d.join("bench-a/calib"));
    copy_photos("fisheye/calib", &d.join("bench-b/calib"));
    let a = Run::new(d, &["calibrate", "bench-a/calib", "--model", "pinhole"]);
    assert_eq!(a.code, 0, "{a}");
    let b = Run::new(d, &["calibrate", "bench-b/calib"]);
    assert_eq!(b.code, 0, "{b}");
    let (ya, yb) = (
        d.join("calibration/bench-a.yaml"),
        d.join("calibration/bench-b.yaml"),
    );
    assert_eq!(read_calibration(&ya).unwrap().image_width, 640);
    assert!(read_calibration(&yb).unwrap().image_width != 640);
    assert!(!d.join("calibration/calib.yaml").exists());
    // Recalibrating the same camera replaces its file.
    let again = Run::new(d, &["calibrate", "bench-a/calib", "--model", "pinhole"]);
    assert_eq!(again.code, 0, "{again}");
    // Another camera's file at the default name is not replaced without --force.
    fs::copy(&ya, &yb).unwrap();
    let before = fs::read(&yb).unwrap();
    Run::new(d, &["calibrate", "bench-b/calib"]).assert_bad_input(&[
        "calibration/bench-b.yaml",
        "another camera",
        "640x480",
        "-o FILE",
        "--force",
    ]);
    assert_eq!(fs::read(&yb).unwrap(), before);
    let forced = Run::new(d, &["calibrate", "bench-b/calib", "--force"]);
    assert_eq!(forced.code, 0, "{forced}");
    assert!(read_calibration(&yb).unwrap().image_width != 640);
}
