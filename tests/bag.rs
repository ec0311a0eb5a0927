//! `bendscope process` on RealSense `.bag` recordings written by an independent writer
//! (the `rosbags` Python package, scripts/make-bag-fixtures.sh) from a rendered PNG
//! RGB-D session (fixtures/bags/png): the bags must measure like the PNG frames they
//! hold, a bag whose depth camera has its own intrinsics and a 15 mm baseline must
//! measure the truth, and broken bags are refused in one line.

mod common;

use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use bendscope::render::session::VideoTruth;
use bendscope::rgbd::bag::BagRecording;
use common::{col, fixture, read_csv, Run};

/// The accuracy tests/process.rs asks of RGB-D sessions against the truth.
const RADIUS_TOLERANCE: f64 = 0.005;
/// A bag of the PNG session's frames must give the PNG session's radii to 0.01%.
const SAME_FRAMES_TOLERANCE: f64 = 1e-4;

fn bags(name: &str) -> PathBuf {
    fixture(&format!("bags/{name}"))
}

/// per_video.csv rows of `session` measured into `dir/out-<tag>`: (pressure, radius).
fn measure(dir: &Path, session: &Path, tag: &str) -> Vec<(f64, f64)> {
    let out = dir.join(format!("out-{tag}"));
    let run = Run::new(
        dir,
        &[
            "process",
            session.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
    );
    assert_eq!(run.code, 0, "{tag}: {run}");
    let (fh, frames) = read_csv(&out.join("per_frame.csv"));
    assert_eq!(frames.len(), 9, "{tag}");
    assert!(
        frames.iter().all(|f| f[col(&fh, "status")] == "ok"),
        "{tag}: {frames:?}"
    );
    let (h, rows) = read_csv(&out.join("per_video.csv"));
    rows.iter()
        .map(|r| {
            assert_eq!(r[col(&h, "frames_used")], "3", "{tag}: {r:?}");
            (
                r[col(&h, "pressure_kpa")].parse().unwrap(),
                r[col(&h, "radius_mm")].parse().unwrap(),
            )
        })
        .collect()
}

fn truth(session: &Path) -> Vec<VideoTruth> {
    serde_json::from_str(&fs::read_to_string(session.join("truth.json")).unwrap()).unwrap()
}

#[test]
fn lz4_and_bz2_bags_measure_like_the_png_frames_they_hold() {
    let dir = tempfile::tempdir().unwrap();
    let png = measure(dir.path(), &bags("png"), "png");
    assert_eq!(png.len(), 3, "{png:?}");
    for tag in ["lz4", "bz2"] {
        let bag = measure(dir.path(), &bags(tag), tag);
        assert_eq!(bag.len(), png.len(), "{tag}: {bag:?} vs {png:?}");
        let mut worst = 0.0f64;
        for ((pb, rb), (pp, rp)) in bag.iter().zip(&png) {
            assert_eq!(pb, pp, "{tag}: pressures");
            worst = worst.max((rb / rp - 1.0).abs());
        }
        eprintln!("{tag} bag vs PNG: worst radius difference {:.2e}", worst);
        assert!(worst < SAME_FRAMES_TOLERANCE, "{tag}: {bag:?} vs {png:?}");
    }
    for ((p, r), t) in png.iter().zip(truth(&bags("png"))) {
        eprintln!("PNG {p} kPa: {r:.3} mm vs truth {:.3} mm", t.radius_mm);
    }
}

#[test]
fn a_bag_with_its_own_depth_camera_is_aligned_and_measures_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let session = bags("baseline");
    let measured = measure(dir.path(), &session, "baseline");
    let truth = truth(&session);
    assert_eq!(measured.len(), truth.len());
    for ((p, r), t) in measured.iter().zip(&truth) {
        assert_eq!(*p, t.pressure_kpa);
        let err = r / t.radius_mm - 1.0;
        eprintln!(
            "baseline bag {p} kPa: {r:.3} mm vs truth {:.3} mm ({:+.3}%)",
            t.radius_mm,
            100.0 * err
        );
        assert!(
            err.abs() < RADIUS_TOLERANCE,
            "{p} kPa: {r} vs {}",
            t.radius_mm
        );
    }
}

#[test]
fn bag_frames_are_the_png_frames_and_read_speed_is_reported() {
    let png = bags("png");
    let mut rec = BagRecording::open(&bags("lz4").join("recording.bag")).unwrap();
    assert_eq!(rec.frames.len(), 9);
    assert_eq!(rec.depth_unit_m, 0.0001);
    assert!((rec.intrinsics.fps - 10.0).abs() < 1e-9);
    for (k, f) in rec.frames.clone().iter().enumerate() {
        assert!((f.time_s - k as f64 / 10.0).abs() < 1e-9, "{}", f.time_s);
        let (rgb, depth) = rec.read_frame(k).unwrap();
        let name = format!("{k:06}.png");
        let color_png = image::open(png.join("color").join(&name))
            .unwrap()
            .into_rgb8();
        assert!(rgb == color_png, "colour frame {k} differs");
        let depth_png = image::open(png.join("depth").join(&name))
            .unwrap()
            .into_luma16();
        assert!(depth == depth_png, "depth frame {k} differs");
    }
    let t = Instant::now();
    for k in 0..rec.frames.len() {
        rec.read_frame(k).unwrap();
    }
    let bag_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    for k in 0..rec.frames.len() {
        let name = format!("{k:06}.png");
        image::open(png.join("color").join(&name)).unwrap();
        image::open(png.join("depth").join(&name)).unwrap();
    }
    let png_s = t.elapsed().as_secs_f64();
    let mut baseline = BagRecording::open(&bags("baseline").join("recording.bag")).unwrap();
    let t = Instant::now();
    for k in 0..baseline.frames.len() {
        baseline.read_frame(k).unwrap();
    }
    let baseline_s = t.elapsed().as_secs_f64();
    eprintln!(
        "read 9 frames (colour + depth, aligned): lz4 bag {:.0} frames/s, baseline bag {:.0} frames/s, PNG folder {:.0} frames/s",
        9.0 / bag_s,
        9.0 / baseline_s,
        9.0 / png_s
    );
}

#[test]
fn a_truncated_bag_is_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("cut");
    common::copy_dir(&bags("lz4"), &s);
    let bag = s.join("recording.bag");
    let bytes = fs::read(&bag).unwrap();
    // Cut halfway between the starts of two middle chunks (each holds about one colour
    // and one depth frame): inside a chunk.
    let mut chunks: Vec<u64> = rosbag::RosBag::new(&bag)
        .unwrap()
        .index_records()
        .filter_map(|r| match r.unwrap() {
            rosbag::IndexRecord::ChunkInfo(c) => Some(c.chunk_pos),
            _ => None,
        })
        .collect();
    chunks.sort_unstable();
    assert!(chunks.len() >= 4, "{chunks:?}");
    let k = chunks.len() / 2;
    let cut = ((chunks[k] + chunks[k + 1]) / 2) as usize;
    fs::write(&bag, &bytes[..cut]).unwrap();
    Run::new(dir.path(), &["process", "cut"]).assert_bad_input(&[
        "recording.bag",
        "truncated",
        "copy the recording again",
    ]);
}

#[test]
fn a_bag_without_depth_is_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    Run::new(
        dir.path(),
        &[
            "process",
            bags("nodepth").to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
    )
    .assert_bad_input(&[
        "recording.bag",
        "no depth stream",
        "record with the depth stream on",
    ]);
}

#[test]
fn a_folder_with_two_recordings_or_a_recording_beside_another_session_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("two");
    common::copy_dir(&bags("nodepth"), &s);
    fs::copy(s.join("recording.bag"), s.join("second.bag")).unwrap();
    Run::new(dir.path(), &["process", "two"])
        .assert_bad_input(&["recording.bag, second.bag", "keep one per session folder"]);
    fs::remove_file(s.join("second.bag")).unwrap();
    fs::write(
        s.join("pressures.csv"),
        "file,pressure_kpa\nGX010001.MP4,20\n",
    )
    .unwrap();
    Run::new(dir.path(), &["process", "two"]).assert_bad_input(&[
        "recording.bag",
        "pressures.csv (step protocol)",
        "keep the one",
    ]);
    fs::remove_file(s.join("pressures.csv")).unwrap();
    fs::create_dir_all(s.join("color")).unwrap();
    fs::create_dir_all(s.join("depth")).unwrap();
    Run::new(dir.path(), &["process", "two"]).assert_bad_input(&[
        "color/ + depth/",
        "recording.bag",
        "keep one",
    ]);
}
