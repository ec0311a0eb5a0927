//! The whole image chain on ground truth from the FEM: simulate -> render through a
//! fisheye camera (noise, blur, vignetting, light gradient, jitter) -> process
//! (calibrating from the rendered board photos) -> radius and angle against truth.json;
//! and the RGB-D recording of the same steps.

mod common;

use std::path::Path;

use bendscope::compare::read_columns;
use bendscope::render::session::SessionTruth;
use common::Run;

fn camera() -> String {
    common::root()
        .join("calibration/gopro-synthetic-960x720.yaml")
        .to_string_lossy()
        .into_owned()
}

#[test]
fn rendered_fem_session_is_measured_within_half_a_percent() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sim = Run::new(
        d,
        &[
            "simulate",
            "--mesh-size",
            "3",
            "--pressures",
            "30:110:40",
            "--no-vtu",
            "-o",
            "fem",
        ],
    );
    assert_eq!(sim.code, 0, "{sim}");
    let cam = camera();
    let render = Run::new(
        d,
        &[
            "render",
            "--fem",
            "fem",
            "--calibration",
            &cam,
            "--distance-mm",
            "200",
            "--frames",
            "3",
            "--rgbd",
            "-o",
            "session",
        ],
    );
    assert_eq!(render.code, 0, "{render}");
    let process = Run::new(d, &["process", "session", "-o", "measured"]);
    assert_eq!(process.code, 0, "{process}");
    let truth: SessionTruth =
        serde_json::from_str(&std::fs::read_to_string(d.join("session/truth.json")).unwrap())
            .unwrap();
    assert_eq!(truth.videos.len(), 3);
    let cols = read_columns(
        &d.join("measured/per_video.csv"),
        &["pressure_kpa", "radius_mm", "bending_angle_deg"],
    )
    .unwrap();
    assert_eq!(cols[0].len(), 3, "every video measured");
    // The truth is the FEM's own marker circle: rendering keeps its radius exactly (it
    // rounds to steps.csv's value, printed with 4 decimals).
    let steps = read_columns(&d.join("fem/steps.csv"), &["pressure_kpa", "radius_mm"]).unwrap();
    for (k, v) in truth.videos.iter().enumerate() {
        assert!(
            format!("{:.4}", v.radius_mm) == format!("{:.4}", steps[1][k]),
            "{} vs {}",
            v.radius_mm,
            steps[1][k]
        );
        let err = cols[1][k] / v.radius_mm - 1.0;
        let angle = cols[2][k] - v.bending_angle_deg;
        eprintln!(
            "{} kPa: radius {:.3} vs {:.3} mm ({:+.3}%), angle {:.2} vs {:.2} deg",
            v.pressure_kpa,
            cols[1][k],
            v.radius_mm,
            100.0 * err,
            cols[2][k],
            v.bending_angle_deg
        );
        assert!(err.abs() < 0.005, "radius at {} kPa: {err}", v.pressure_kpa);
        assert!(
            angle.abs() < 0.5,
            "angle at {} kPa: {angle}",
            v.pressure_kpa
        );
    }
    // The RGB-D recording of the same steps (plane tilted 15 degrees, mm from depth).
    let rgbd = Run::new(d, &["process", "session/rgbd", "-o", "measured-rgbd"]);
    assert_eq!(rgbd.code, 0, "{rgbd}");
    let rows = read_columns(
        &d.join("measured-rgbd/per_video.csv"),
        &["pressure_kpa", "radius_mm", "bending_angle_deg"],
    )
    .unwrap();
    assert_eq!(rows[0].len(), 3, "one row per pressure step");
    for (k, v) in truth.videos.iter().enumerate() {
        assert!((rows[0][k] - v.pressure_kpa).abs() < 1e-6);
        let err = rows[1][k] / v.radius_mm - 1.0;
        eprintln!(
            "RGB-D {} kPa: radius {:+.3}%, angle {:+.2} deg",
            v.pressure_kpa,
            100.0 * err,
            rows[2][k] - v.bending_angle_deg
        );
        assert!(
            err.abs() < 0.005,
            "RGB-D radius at {} kPa: {err}",
            v.pressure_kpa
        );
        assert!(
            (rows[2][k] - v.bending_angle_deg).abs() < 0.5,
            "RGB-D angle at {} kPa",
            v.pressure_kpa
        );
    }
    // compare: the measured curves against the simulated ones.
    let cmp = Run::new(
        d,
        &[
            "compare",
            "--measured",
            "measured",
            "--fem",
            "fem",
            "-o",
            "report",
        ],
    );
    assert_eq!(cmp.code, 0, "{cmp}");
    let c = read_columns(&d.join("report/compare.csv"), &["radius_mm_deviation"]).unwrap();
    assert!(c[0].iter().all(|dev| dev.abs() < 0.5), "{:?}", c[0]);
    assert!(d.join("report/plots/radius.png").is_file());
}

#[test]
fn render_and_compare_refuse_bad_input_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("empty")).unwrap();
    let cam = camera();
    Run::new(d, &["render", "--fem", "empty", "--calibration", &cam])
        .assert_bad_input(&["side_face.json", "simulate"]);
    let sim = Run::new(
        d,
        &[
            "simulate",
            "--mesh-size",
            "4",
            "--pressures",
            "20",
            "--no-vtu",
            "-o",
            "fem",
        ],
    );
    assert_eq!(sim.code, 0, "{sim}");
    Run::new(
        d,
        &[
            "render",
            "--fem",
            "fem",
            "--calibration",
            &cam,
            "--distance-mm",
            "40",
        ],
    )
    .assert_bad_input(&["does not fit", "--distance-mm"]);
    Run::new(
        d,
        &["render", "--fem", "fem", "--calibration", "fem/steps.csv"],
    )
    .assert_bad_input(&["steps.csv"]);
    write(d, "measured/per_video.csv", "file,pressure_kpa,radius_mm,curvature_per_m,bending_angle_deg\na,150,40,25,100\nb,160,38,26,105\nc,170,36,27,110\nd,180,35,28,112\n");
    Run::new(d, &["compare", "--measured", "measured", "--fem", "fem"])
        .assert_bad_input(&["do not overlap", "--pressures"]);
    Run::new(d, &["compare", "--measured", "fem", "--fem", "fem"])
        .assert_bad_input(&["per_video.csv", "process"]);
}

fn write(dir: &Path, rel: &str, text: &str) {
    let p = dir.join(rel);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    std::fs::write(p, text).unwrap();
}

/// Every file under `dir` with its bytes, sorted by path.
fn snapshot(dir: &Path) -> Vec<(std::path::PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(snapshot(&p));
        } else {
            let bytes = std::fs::read(&p).unwrap();
            out.push((p, bytes));
        }
    }
    out.sort();
    out
}

#[test]
fn render_refuses_a_folder_that_holds_a_session_unless_forced() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A recorded session: videos, manifest, scale photo, calibration photos.
    common::copy_dir(&common::fixture("sessions/example"), &d.join("recorded"));
    let before = snapshot(&d.join("recorded"));
    let sim = Run::new(
        d,
        &[
            "simulate",
            "--mesh-size",
            "4",
            "--pressures",
            "20",
            "--no-vtu",
            "-o",
            "fem",
        ],
    );
    assert_eq!(sim.code, 0, "{sim}");
    let render = |extra: &[&str]| {
        let mut args = vec![
            "render",
            "--fem",
            "fem",
            "--gopro-like",
            "320x240",
            "--frames",
            "1",
            "--calib-views",
            "0",
            "--supersample",
            "1",
            "-o",
            "recorded",
        ];
        args.extend_from_slice(extra);
        Run::new(d, &args)
    };
    render(&[]).assert_bad_input(&[
        "already holds a session",
        "GX010101.MP4",
        "calib/",
        "pressures.csv",
        "--force",
    ]);
    assert!(
        snapshot(&d.join("recorded")) == before,
        "the recorded session was changed"
    );
    // --force renders over it: its manifest is the rendered one.
    let forced = render(&["--force"]);
    assert_eq!(forced.code, 0, "{forced}");
    let manifest = std::fs::read_to_string(d.join("recorded/pressures.csv")).unwrap();
    assert_eq!(manifest, "file,pressure_kpa\nGX010101.MP4,20\n");
}

/// Simulates a family (`family`, its pressures in kPa, a 3 mm mesh), renders it through
/// the synthetic GoPro calibration (`extra` render arguments) and processes the session:
/// the rendered truth and the measured Pratt radius per video, checked within 0.5%.
fn render_and_measure_family(family: &str, pressures: &str, extra: &[&str]) -> SessionTruth {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sim = Run::new(
        d,
        &[
            "simulate",
            "--family",
            family,
            "--mesh-size",
            "3",
            "--pressures",
            pressures,
            "--no-vtu",
            "-o",
            "fem",
        ],
    );
    assert_eq!(sim.code, 0, "{sim}");
    let cam = camera();
    let mut args = vec!["render", "--fem", "fem", "--frames", "3", "-o", "session"];
    // The synthetic GoPro calibration unless `extra` names a camera of its own.
    if !extra.contains(&"--gopro-like") {
        args.extend_from_slice(&["--calibration", &cam]);
    }
    args.extend_from_slice(extra);
    let render = Run::new(d, &args);
    assert_eq!(render.code, 0, "{render}");
    let process = Run::new(d, &["process", "session", "-o", "measured"]);
    assert_eq!(process.code, 0, "{process}");
    let truth: SessionTruth =
        serde_json::from_str(&std::fs::read_to_string(d.join("session/truth.json")).unwrap())
            .unwrap();
    let cols = read_columns(&d.join("measured/per_video.csv"), &["radius_mm"]).unwrap();
    let n = pressures.split(',').count();
    assert_eq!((truth.videos.len(), cols[0].len()), (n, n));
    for (k, v) in truth.videos.iter().enumerate() {
        let err = cols[0][k] / v.radius_mm - 1.0;
        eprintln!(
            "{family} {} kPa: radius {:.2} vs {:.2} mm ({:+.3}%)",
            v.pressure_kpa,
            cols[0][k],
            v.radius_mm,
            100.0 * err
        );
        assert!(err.abs() < 0.005, "radius at {} kPa: {err}", v.pressure_kpa);
    }
    truth
}

/// A family renders like the reference: the glove (Ecoflex 00-50, paper layer) filmed
/// through the synthetic GoPro calibration and measured by the image chain gives the FEM's radius.
#[test]
fn a_family_renders_and_measures_like_the_reference() {
    render_and_measure_family("glove", "2,3", &["--distance-mm", "200"]);
}

/// The fibre-reinforced tube (its half model, markers evenly spaced on its side edge)
/// renders and measures like the PneuNets families: wound both ways, 20 and 60 kPa,
/// sagging under its weight (gravity -z), its markers are on no one circle (the chain
/// warns), and the measured Pratt radius is the one of the rendered marker centres.
/// The camera 220 mm from the actuator plane (260 by default) and 1920x1080 (the GoPro-like
/// fisheye): the sagging tube's marker line is a shallow arc (about 20-26 deg; its sagitta
/// ~4 mm over the 90 mm line), whose radius the centroids' sub-pixel error moves as
/// R^2 / L^2. Measured with the threads' shear of 2026-12-05 (radius 258 / 238 mm): +0.10%
/// and -0.08%, and within 0.31% at 10, 15, 20, 30, 40, 50, 60 kPa; through the synthetic
/// 960x720 calibration the same scenes gave +0.9% at 20 kPa at 220 mm and up to 0.66% at
/// 170 mm (the 0.5% asked is ~0.07 px of sagitta there). Earlier: +0.075% / -0.24% at
/// 960x720 (the mesh rule of 2026-12-05, radius 292 / 312 mm); -0.18%, +0.29%, -0.14% at
/// 20, 40, 60 kPa through `--gopro-like 800x600` calibrated from its rendered board photos.
#[test]
fn the_fibre_reinforced_tube_renders_and_measures_like_the_reference() {
    let truth = render_and_measure_family(
        "fibre-reinforced",
        "20,60",
        &["--distance-mm", "220", "--gopro-like", "1920x1080"],
    );
    for v in &truth.videos {
        // Bent: the 90 mm marker line turns by more than 12 deg (its radius under 430 mm).
        assert!(v.radius_mm < 430.0, "the tube bends: {}", v.radius_mm);
    }
}
