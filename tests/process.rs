//! `bendscope process` end to end on synthetic sessions rendered through a fisheye
//! camera with known marker arcs (ground truth in truth.json), and on bad input.

mod common;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use bendscope::render::session::SessionTruth;
use bendscope::video::{EncodeSettings, VideoWriter};
use common::{col, copy_dir, fixture, read_csv, Run};
use plotters::style::{Color, Palette, Palette99};

/// Accuracy the issue asks for on every video.
const RADIUS_TOLERANCE: f64 = 0.005;
const ANGLE_TOLERANCE_DEG: f64 = 0.5;

fn example() -> PathBuf {
    fixture("sessions/example")
}

fn truth() -> SessionTruth {
    serde_json::from_str(&fs::read_to_string(example().join("truth.json")).unwrap()).unwrap()
}

#[test]
fn example_session_matches_the_ground_truth() {
    let t = truth();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let run = Run::new(
        dir.path(),
        &[
            "process",
            example().to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    let (h, rows) = read_csv(&out.join("per_video.csv"));
    assert_eq!(rows.len(), t.videos.len());
    for v in &t.videos {
        let r = rows
            .iter()
            .find(|r| r[0] == v.file)
            .unwrap_or_else(|| panic!("{} missing", v.file));
        assert_eq!(r[col(&h, "status")], "ok");
        let radius: f64 = r[col(&h, "radius_mm")].parse().unwrap();
        let angle: f64 = r[col(&h, "bending_angle_deg")].parse().unwrap();
        let err = radius / v.radius_mm - 1.0;
        assert!(
            err.abs() < RADIUS_TOLERANCE,
            "{}: radius {radius} vs {} ({:+.3}%)",
            v.file,
            v.radius_mm,
            100.0 * err
        );
        assert!(
            (angle - v.bending_angle_deg).abs() < ANGLE_TOLERANCE_DEG,
            "{}: angle {angle} vs {}",
            v.file,
            v.bending_angle_deg
        );
        let curvature: f64 = r[col(&h, "curvature_per_m")].parse().unwrap();
        assert!((curvature * v.radius_mm / 1000.0 - 1.0).abs() < RADIUS_TOLERANCE);
        assert_eq!(r[col(&h, "frames_rejected")], "0");
    }
    // Per frame: every frame of every video, with its pressure.
    let (fh, frames) = read_csv(&out.join("per_frame.csv"));
    assert_eq!(frames.len(), rows.len() * 8);
    assert!(frames.iter().all(|f| f[col(&fh, "status")] == "ok"));
    // Fits, plots, overlays.
    let fit: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("fit.json")).unwrap()).unwrap();
    let r2 = fit["radius_mm_vs_kpa"]["r_squared"].as_f64().unwrap();
    assert!(r2 > 0.999, "R² {r2}");
    // The example's radii follow 3000 p^-0.9 + 5 (mm, kPa).
    let b = fit["radius_mm_vs_kpa"]["b"].as_f64().unwrap();
    assert!((b + 0.9).abs() < 0.1, "exponent {b}");
    for p in [
        "radius_vs_pressure",
        "curvature_vs_pressure",
        "angle_vs_pressure",
        "radius_per_frame",
    ] {
        assert!(
            out.join("plots").join(format!("{p}.png")).is_file(),
            "{p}.png"
        );
        assert!(
            out.join("plots").join(format!("{p}.svg")).is_file(),
            "{p}.svg"
        );
    }
    for v in &t.videos {
        assert!(out
            .join("overlays")
            .join(format!("{}.png", v.file))
            .is_file());
    }
    assert!(
        out.join("calibration.yaml").is_file(),
        "calib/ calibrated and cached"
    );
    for p in ["radius_vs_pressure", "angle_vs_pressure"] {
        let pdf = fs::read(out.join("plots").join(format!("{p}.pdf"))).unwrap();
        assert!(pdf.starts_with(b"%PDF-"), "{p}.pdf");
    }
    let names: Vec<&str> = t.videos.iter().map(|v| v.file.as_str()).collect();
    report_picture_shows_plots_and_thumbnails(&out, &names);
}

/// Chromium's arguments for a reproducible headless page at `width` x `height` CSS px.
fn chromium(profile: &Path, width: u32, height: u32) -> Command {
    let mut c = Command::new(CHROMIUM);
    c.args([
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--hide-scrollbars",
        "--force-device-scale-factor=1",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
    ])
    .arg(format!("--user-data-dir={}", profile.display()))
    .arg(format!("--window-size={width},{height}"));
    c
}

/// Debian's Chromium (scripts/setup.sh installs it).
const CHROMIUM: &str = "/usr/bin/chromium";

/// A box on the page, CSS px (= screenshot px at scale factor 1).
#[derive(Debug, Clone, Copy)]
struct Rect {
    x: u32,
    y: u32,
    w: u32,
    h: u32,
}

/// The page boxes of the elements `report.html` shows, measured by the browser: a copy
/// of the page with a script that writes each box into the DOM (the report itself has
/// no script), laid out at the same window size as the screenshot.
fn page_boxes(out: &Path, profile: &Path, width: u32, height: u32) -> Vec<(String, Rect)> {
    let html = fs::read_to_string(out.join("report.html")).unwrap();
    let script = r#"<script>var o=[];function box(n,e){var r=e.getBoundingClientRect();o.push(n+"|"+[r.left,r.top,r.width,r.height].map(Math.round).join(","));}
document.querySelectorAll("img.thumb").forEach(function(e){box("thumb:"+e.alt,e);});
document.querySelectorAll("figure[data-plot] svg").forEach(function(e){box("plot:"+e.parentNode.getAttribute("data-plot"),e);});
var p=document.createElement("pre");p.id="boxes";p.textContent=o.join("\n");document.body.appendChild(p);</script>"#;
    let probe = out.join("report-probe.html");
    fs::write(&probe, html.replace("</body>", &format!("{script}</body>"))).unwrap();
    let dom = chromium(profile, width, height)
        .arg("--dump-dom")
        .arg(format!("file://{}", probe.display()))
        .output()
        .unwrap();
    fs::remove_file(&probe).unwrap();
    assert!(
        dom.status.success(),
        "{}",
        String::from_utf8_lossy(&dom.stderr)
    );
    let dom = String::from_utf8_lossy(&dom.stdout).into_owned();
    let at = dom.find("<pre id=\"boxes\">").expect("the script ran") + 16;
    dom[at..at + dom[at..].find("</pre>").unwrap()]
        .lines()
        .map(|l| {
            let (name, b) = l.split_once('|').unwrap();
            let v: Vec<u32> = b.split(',').map(|x| x.parse().unwrap()).collect();
            let r = Rect {
                x: v[0],
                y: v[1],
                w: v[2],
                h: v[3],
            };
            (name.replace("&amp;", "&"), r)
        })
        .collect()
}

/// Pixels of `img` in `r` within `tol` of `rgb` on every channel.
fn count_colour(img: &image::RgbImage, r: Rect, rgb: [u8; 3], tol: u8) -> usize {
    (r.y..r.y + r.h)
        .flat_map(|y| (r.x..r.x + r.w).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let p = img.get_pixel(x, y).0;
            (0..3).all(|c| p[c].abs_diff(rgb[c]) <= tol)
        })
        .count()
}

/// Mean absolute difference per channel between `img` in `r` and `other` (r's size).
fn mean_abs_diff(img: &image::RgbImage, r: Rect, other: &image::RgbImage) -> f64 {
    let mut sum = 0u64;
    for y in 0..r.h {
        for x in 0..r.w {
            let (a, b) = (img.get_pixel(r.x + x, r.y + y).0, other.get_pixel(x, y).0);
            sum += (0..3).map(|c| a[c].abs_diff(b[c]) as u64).sum::<u64>();
        }
    }
    sum as f64 / (3 * r.w * r.h) as f64
}

/// Headless Chromium renders the session's report.html and its picture holds what a
/// reader should see: in the radius plot, the measured markers and the fit line in their
/// series colours (plotters' Palette99, as src/report draws them); beside each video's
/// row a thumbnail that is that video's overlay, downscaled (compared with the overlay
/// the test downscales itself, with another filter).
fn report_picture_shows_plots_and_thumbnails(out: &Path, videos: &[&str]) {
    assert!(
        Path::new(CHROMIUM).is_file(),
        "{CHROMIUM} is missing: this test renders report.html in it; install it with scripts/setup.sh (Debian: apt-get install chromium)"
    );
    let started = std::time::Instant::now();
    let profile = tempfile::tempdir().unwrap();
    let (width, height) = (1400, 3000);
    let boxes = page_boxes(out, profile.path(), width, height);
    let shot = out.join("report-shot.png");
    let run = chromium(profile.path(), width, height)
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("file://{}", out.join("report.html").display()))
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let img = image::open(&shot).unwrap().to_rgb8();
    fs::remove_file(&shot).unwrap();
    assert_eq!(img.dimensions(), (width, height));
    let inside = |r: Rect| r.w > 0 && r.x + r.w <= width && r.y + r.h <= height;
    // The plot: markers (series 0) and the power-law line (series 1).
    let plot = boxes
        .iter()
        .find(|(n, _)| n == "plot:plots/radius_vs_pressure.svg")
        .map(|(_, r)| *r)
        .expect("radius plot on the page");
    assert!(inside(plot), "radius plot {plot:?} in the screenshot");
    let colour = |i: usize| {
        let c = Palette99::pick(i).to_rgba().rgb();
        [c.0, c.1, c.2]
    };
    let markers = count_colour(&img, plot, colour(0), 8);
    let line = count_colour(&img, plot, colour(1), 8);
    // Five markers of radius 10 plot units (6.3 CSS px at 640 px wide) are ~600 px;
    // the fit line, 6 units (3.8 px) wide over ~400 px, ~1500 px.
    eprintln!("report picture: radius plot {plot:?}: {markers} marker px, {line} fit-line px");
    assert!(markers > 300, "marker pixels {markers}");
    assert!(line > 500, "fit line pixels {line}");
    // Thumbnails: one per measured video, each its own overlay (nearer to it than to
    // any other video's: the videos differ only in the arc, a small part of the frame).
    let thumbs: Vec<Rect> = videos
        .iter()
        .map(|v| {
            boxes
                .iter()
                .find(|(n, _)| *n == format!("thumb:overlay of {v}"))
                .map(|(_, r)| *r)
                .unwrap_or_else(|| panic!("{v}: no thumbnail"))
        })
        .collect();
    let (w, h) = (thumbs[0].w, thumbs[0].h);
    let smalls: Vec<image::RgbImage> = videos
        .iter()
        .map(|v| {
            let overlay = image::open(out.join("overlays").join(format!("{v}.png")))
                .unwrap()
                .to_rgb8();
            image::imageops::resize(&overlay, w, h, image::imageops::FilterType::Triangle)
        })
        .collect();
    let white = image::RgbImage::from_pixel(w, h, image::Rgb([255, 255, 255]));
    for (i, (v, r)) in videos.iter().zip(&thumbs).enumerate() {
        assert!(inside(*r) && (r.w, r.h) == (160, h), "{v}: thumbnail {r:?}");
        let own = mean_abs_diff(&img, *r, &smalls[i]);
        let blank = mean_abs_diff(&img, *r, &white);
        let other = (0..videos.len())
            .filter(|&j| j != i)
            .map(|j| mean_abs_diff(&img, *r, &smalls[j]))
            .fold(f64::INFINITY, f64::min);
        // Two downscaling filters (the report's and Triangle here) differ by < 1 level.
        assert!(own < 1.0, "{v}: thumbnail {own:.2} levels from its overlay");
        assert!(
            other > 2.0 * own,
            "{v}: as near another video's overlay ({other:.2})"
        );
        assert!(
            blank > 20.0,
            "{v}: thumbnail near blank ({blank:.1} levels from white)"
        );
        eprintln!(
            "report picture: {v}: thumbnail {own:.2} levels from its overlay, {other:.2} from the nearest other, {blank:.1} from white"
        );
    }
    eprintln!("report picture: {:.1} s", started.elapsed().as_secs_f64());
}

/// `[video] frames = "keyframes"` on the example (each video's first frame is its only
/// key frame): one frame measured per video, at its index 0, each radius within the
/// tolerance of the truth; on a ramp it is refused before anything is measured.
#[test]
fn keyframes_measure_only_key_frames_and_are_refused_for_ramps() {
    let t = truth();
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("example");
    copy_dir(&example(), &s);
    let toml = fs::read_to_string(s.join("bendscope.toml")).unwrap();
    fs::write(
        s.join("bendscope.toml"),
        format!("{toml}\n[video]\nframes = \"keyframes\"\n"),
    )
    .unwrap();
    let run = Run::new(dir.path(), &["process", "example"]);
    assert_eq!(run.code, 0, "{run}");
    let out = s.join("bendscope-out");
    let (fh, frames) = read_csv(&out.join("per_frame.csv"));
    assert_eq!(frames.len(), t.videos.len(), "one key frame per video");
    assert!(frames.iter().all(|f| f[col(&fh, "frame")] == "0"));
    let (h, rows) = read_csv(&out.join("per_video.csv"));
    for v in &t.videos {
        let r = rows.iter().find(|r| r[0] == v.file).unwrap();
        assert_eq!(r[col(&h, "status")], "ok", "{run}");
        let radius: f64 = r[col(&h, "radius_mm")].parse().unwrap();
        assert!(
            (radius / v.radius_mm - 1.0).abs() < RADIUS_TOLERANCE,
            "{}: {radius} vs {}",
            v.file,
            v.radius_mm
        );
    }
    assert!(
        !run.stderr.contains("truncated"),
        "skipped frames are not a truncated file: {run}"
    );

    let ramp = write_ramp_session("[video]\nframes = \"keyframes\"\n");
    Run::new(ramp.path(), &["process", "ramp"]).assert_bad_input(&[
        "bendscope.toml",
        "keyframes",
        "ramp needs every frame",
    ]);
    assert!(!ramp
        .path()
        .join("ramp/bendscope-out/per_frame.csv")
        .exists());
}

#[test]
fn rerun_skips_current_videos_unless_forced() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("s");
    copy_dir(&example(), &session);
    let first = Run::new(dir.path(), &["process", "s"]);
    assert_eq!(first.code, 0, "{first}");
    let cache = session.join("bendscope-out/cache/GX010101.MP4.json");
    let stamp = fs::metadata(&cache).unwrap().modified().unwrap();
    let before = fs::read_to_string(session.join("bendscope-out/per_video.csv")).unwrap();
    std::thread::sleep(std::time::Duration::from_millis(20));
    let again = Run::new(dir.path(), &["process", "s"]);
    assert_eq!(again.code, 0, "{again}");
    assert_eq!(
        fs::metadata(&cache).unwrap().modified().unwrap(),
        stamp,
        "current results were reused"
    );
    assert_eq!(
        fs::read_to_string(session.join("bendscope-out/per_video.csv")).unwrap(),
        before
    );
    // The error bars as 95 % confidence intervals: the same cached results, the plots
    // redrawn and saying so, the choice kept in session.json.
    let ci = Run::new(dir.path(), &["process", "s", "--error-bars", "ci95"]);
    assert_eq!(ci.code, 0, "{ci}");
    let out = session.join("bendscope-out");
    let svg = fs::read_to_string(out.join("plots/radius_vs_pressure.svg")).unwrap();
    assert!(
        svg.contains("measured (mean ± 95 % CI per video)"),
        "legend"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&fs::read(out.join("session.json")).unwrap()).unwrap();
    assert_eq!(json["settings"]["error_bars"], "ci95", "{json}");
    let bad = Run::new(dir.path(), &["process", "s", "--error-bars", "sem"]);
    assert_eq!(bad.code, 2, "{bad}");
    assert!(bad.stderr.contains("give std"), "{bad}");
    let forced = Run::new(dir.path(), &["process", "s", "--force"]);
    assert_eq!(forced.code, 0, "{forced}");
    assert_ne!(
        fs::metadata(&cache).unwrap().modified().unwrap(),
        stamp,
        "--force reprocesses"
    );
}

fn blank_video(path: &Path, w: u32, h: u32) {
    let mut wr = VideoWriter::create(path, w, h, &EncodeSettings::default()).unwrap();
    for _ in 0..4 {
        wr.write(&image::RgbImage::from_pixel(
            w,
            h,
            image::Rgb([235, 235, 230]),
        ))
        .unwrap();
    }
    wr.finish().unwrap();
}

#[test]
fn bad_videos_and_manifest_rows_are_reported_and_the_rest_kept() {
    let t = truth();
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("s");
    copy_dir(&example(), &s);
    let (w, h) = (t.camera.width, t.camera.height);
    // Corrupt (not a video), truncated, and a video without red markers.
    fs::write(s.join("GX010102.MP4"), b"definitely not a video").unwrap();
    let bytes = fs::read(s.join("GX010103.MP4")).unwrap();
    fs::write(s.join("GX010103.MP4"), &bytes[..bytes.len() / 2]).unwrap();
    blank_video(&s.join("GX010104.MP4"), w, h);
    // Manifest problems: missing file, duplicate, non-numeric, negative; a video not listed.
    let mut m = fs::read_to_string(s.join("pressures.csv")).unwrap();
    m.push_str("GX019999.MP4,90\nGX010101.MP4,20\nclip_b.mp4,abc\nclip_c.mp4,-5\n");
    fs::write(s.join("pressures.csv"), m).unwrap();
    for f in ["clip_b.mp4", "clip_c.mp4", "extra.mp4"] {
        fs::copy(s.join("GX010101.MP4"), s.join(f)).unwrap();
    }
    let run = Run::new(dir.path(), &["process", "s"]);
    assert_eq!(run.code, 1, "some failed, others kept: {run}");
    assert!(!run.stderr.contains("panicked"), "{run}");
    let (hd, rows) = read_csv(&s.join("bendscope-out/per_video.csv"));
    let status = |f: &str| -> String {
        rows.iter()
            .find(|r| r[0] == f)
            .map(|r| r[col(&hd, "status")].clone())
            .unwrap_or_else(|| panic!("{f} not in per_video.csv: {rows:?}"))
    };
    assert_eq!(status("GX010101.MP4"), "ok");
    assert_eq!(status("GX010105.MP4"), "ok");
    assert!(
        status("GX010102.MP4").contains("not a video FFmpeg can read"),
        "{}",
        status("GX010102.MP4")
    );
    assert!(
        status("GX010103.MP4").contains("GX010103.MP4"),
        "{}",
        status("GX010103.MP4")
    );
    assert!(
        status("GX010103.MP4").starts_with("no frame measured"),
        "{}",
        status("GX010103.MP4")
    );
    assert!(
        status("GX010104.MP4").contains("0 markers found, 8 expected (in 4 of 4 frames)"),
        "{}",
        status("GX010104.MP4")
    );
    assert!(status("GX019999.MP4").contains("no such video"));
    assert!(status("clip_b.mp4").contains("not a number"));
    assert!(status("clip_c.mp4").contains("negative"));
    assert!(status("extra.mp4").contains("not in pressures.csv"));
    // One row per file: a file named by a bad row is not also "not in pressures.csv".
    for f in ["clip_b.mp4", "clip_c.mp4", "GX019999.MP4", "extra.mp4"] {
        assert_eq!(
            rows.iter().filter(|r| r[0] == f).count(),
            1,
            "{f}: {rows:?}"
        );
    }
    assert!(rows
        .iter()
        .any(|r| r[0] == "GX010101.MP4" && r[col(&hd, "status")].contains("listed twice")));
    // The good videos are still measured correctly.
    let r = rows.iter().find(|r| r[0] == "GX010105.MP4").unwrap();
    let radius: f64 = r[col(&hd, "radius_mm")].parse().unwrap();
    assert!((radius / t.videos[4].radius_mm - 1.0).abs() < RADIUS_TOLERANCE);
}

#[test]
fn an_extra_red_object_is_ignored_and_counted() {
    use bendscope::render::actuator::FrameLook;
    use bendscope::render::fixtures::gopro_like_camera;
    use bendscope::render::session::{write_session, SessionSpec};
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("red");
    let spec = SessionSpec {
        camera: gopro_like_camera(640, 480),
        distance_mm: 130.0,
        pressures_kpa: vec![40.0, 60.0],
        radius_law: (3000.0, -0.9, 5.0),
        frames: 3,
        calib_views: 3,
        calib_view_reach: 1.0,
        scale_square_mm: 8.0,
        scale_board_offset_mm: Some(0.0),
        distractor: true,
        supersample: 2,
        look: FrameLook::default(),
        seed: 3,
    };
    let truth = write_session(&s, &spec).unwrap();
    let cal = dir.path().join("cam.yaml");
    bendscope::calib::file::write_calibration(&cal, &truth.camera.to_calibration()).unwrap();
    let run = Run::new(
        dir.path(),
        &["process", "red", "--calibration", cal.to_str().unwrap()],
    );
    assert_eq!(run.code, 0, "{run}");
    let (h, rows) = read_csv(&s.join("bendscope-out/per_video.csv"));
    assert_eq!(rows.len(), truth.videos.len());
    for (r, v) in rows.iter().zip(&truth.videos) {
        assert_eq!(r[col(&h, "status")], "ok");
        assert_eq!(r[col(&h, "frames_used")], "3");
        let radius: f64 = r[col(&h, "radius_mm")].parse().unwrap();
        assert!(
            (radius / v.radius_mm - 1.0).abs() < RADIUS_TOLERANCE,
            "{r:?} vs {}",
            v.radius_mm
        );
    }
    let (fh, frames) = read_csv(&s.join("bendscope-out/per_frame.csv"));
    assert!(
        frames.iter().all(|f| f[col(&fh, "n_ignored")] == "1"),
        "the distractor is listed as ignored in every frame"
    );
    // A region of interest (undistorted px) that holds no marker: nothing is measured,
    // and the reason says so.
    fs::write(
        s.join("bendscope.toml"),
        "roi = [[0, 0], [20, 0], [20, 20], [0, 20]]\n[scale_board]\nsquare_mm = 8\n",
    )
    .unwrap();
    let run = Run::new(
        dir.path(),
        &["process", "red", "--calibration", cal.to_str().unwrap()],
    );
    assert_eq!(run.code, 3, "{run}");
    assert!(run.stderr.contains("0 markers found, 8 expected"), "{run}");
}

#[test]
fn session_level_bad_input_is_one_line_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir(dir.path().join("empty")).unwrap();
    let run = Run::new(dir.path(), &["process", "empty"]);
    assert_eq!(run.code, 2, "{run}");
    assert!(run.stderr.contains("pressures.csv"), "{run}");
    assert_eq!(run.stderr.lines().count(), 1, "{run}");
    let s = dir.path().join("nounit");
    copy_dir(&example(), &s);
    fs::write(s.join("pressures.csv"), "file,pressure\nGX010101.MP4,20\n").unwrap();
    let run = Run::new(dir.path(), &["process", "nounit"]);
    assert_eq!(run.code, 2, "{run}");
    assert!(
        run.stderr
            .contains("pressure_bar, pressure_kpa or pressure_psi"),
        "{run}"
    );
    let run = Run::new(dir.path(), &["process", "nowhere"]);
    assert_eq!(run.code, 2, "{run}");
}

#[test]
fn calibration_of_another_aspect_ratio_is_refused_per_video() {
    let t = truth();
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("s");
    copy_dir(&example(), &s);
    // A 16:9 calibration against 4:3 videos; the scale given directly.
    let mut cam = t.camera.to_calibration();
    cam.image_height = cam.image_width * 9 / 16;
    let cal = dir.path().join("wide.yaml");
    bendscope::calib::file::write_calibration(&cal, &cam).unwrap();
    fs::write(s.join("bendscope.toml"), "mm_per_px = 0.5\n").unwrap();
    let run = Run::new(
        dir.path(),
        &["process", "s", "--calibration", cal.to_str().unwrap()],
    );
    assert_eq!(run.code, 3, "{run}");
    let (h, rows) = read_csv(&s.join("bendscope-out/per_video.csv"));
    for r in &rows {
        assert!(
            r[col(&h, "status")].contains("another aspect ratio"),
            "{r:?}"
        );
    }
}

/// The rendered ramp: 30 frames at 30 fps while the pressure rises 20 -> 50 kPa (radius
/// `ramp_radius_at(p)`), a pressure log, the camera and mm per px; `extra` is appended
/// to its bendscope.toml. Returns the folder holding the session `ramp`.
fn write_ramp_session(extra: &str) -> tempfile::TempDir {
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
    let radius_at = ramp_radius_at;
    // 30 frames at 30 fps while the pressure rises 20 -> 50 kPa; the log runs 0.5 s
    // longer on both sides and the video starts 0.5 s into it.
    let fps = 30.0;
    let mut w = VideoWriter::create(
        &s.join("ramp.mp4"),
        640,
        480,
        &EncodeSettings {
            fps: 30,
            crf: 14,
            ..Default::default()
        },
    )
    .unwrap();
    for i in 0..30 {
        let p = 20.0 + 30.0 * (i as f64 / fps);
        let scene = ArcScene::reference_actuator(1.0 / radius_at(p), Point2::new(-45.0, 18.0));
        w.write(&sampler.render(&scene, [0.0, 0.0], &FrameLook::default(), i as u64))
            .unwrap();
    }
    w.finish().unwrap();
    fs::write(
        s.join("pressure_log.csv"),
        "time_s,pressure_kpa\n0,5\n0.5,20\n1.5,50\n2.0,65\n",
    )
    .unwrap();
    let cal = s.join("cam.yaml");
    bendscope::calib::file::write_calibration(&cal, &camera).unwrap();
    let und = bendscope::calib::Undistorter::new(&camera, Default::default()).unwrap();
    let mm_per_px = distance / und.new_camera_matrix()[(0, 0)];
    fs::write(
        s.join("bendscope.toml"),
        format!("calibration = \"cam.yaml\"\nmm_per_px = {mm_per_px}\nramp_time_offset_s = 0.5\nramp_bin_kpa = 5\n{extra}"),
    )
    .unwrap();
    dir
}

/// Radius drawn at pressure `p` kPa in the rendered ramp, mm.
fn ramp_radius_at(p: f64) -> f64 {
    3000.0 * p.powf(-0.9) + 5.0
}

#[test]
fn ramp_protocol_interpolates_pressure_per_frame() {
    let dir = write_ramp_session("");
    let s = dir.path().join("ramp");
    let radius_at = ramp_radius_at;
    let fps = 30.0;
    let run = Run::new(dir.path(), &["process", "ramp"]);
    assert_eq!(run.code, 0, "{run}");
    let (fh, frames) = read_csv(&s.join("bendscope-out/per_frame.csv"));
    assert_eq!(frames.len(), 30);
    for f in &frames {
        let i: f64 = f[col(&fh, "frame")].parse().unwrap();
        let p: f64 = f[col(&fh, "pressure_kpa")].parse().unwrap();
        assert!(
            (p - (20.0 + 30.0 * i / fps)).abs() < 1e-6,
            "frame {i}: {p} kPa"
        );
        let r: f64 = f[col(&fh, "radius_mm")].parse().unwrap();
        assert!(
            (r / radius_at(p) - 1.0).abs() < 0.01,
            "frame {i} at {p} kPa: {r} vs {}",
            radius_at(p)
        );
    }
    // Bins of 5 kPa: 20..50 kPa gives six, each the mean of its frames.
    let (h, bins) = read_csv(&s.join("bendscope-out/per_video.csv"));
    assert_eq!(bins.len(), 6, "{bins:?}");
    let used: usize = bins
        .iter()
        .map(|b| b[col(&h, "frames_used")].parse::<usize>().unwrap())
        .sum();
    assert_eq!(used, 30);
}

/// `smooth_s = 0.3` on the rendered ramp: per_frame.csv gets `radius_mm_smooth`,
/// `curvature_per_m_smooth` and `bending_angle_deg_smooth` right after their raw columns;
/// every smoothed radius within 1% of the drawn one (as the raw ones), and the smoothed
/// radius errors scatter no more than the raw ones.
#[test]
fn ramp_with_smooth_s_has_smoothed_columns_beside_the_raw_ones() {
    let dir = write_ramp_session("smooth_s = 0.3\n");
    let s = dir.path().join("ramp");
    let run = Run::new(dir.path(), &["process", "ramp"]);
    assert_eq!(run.code, 0, "{run}");
    let (h, frames) = read_csv(&s.join("bendscope-out/per_frame.csv"));
    for raw in ["radius_mm", "curvature_per_m", "bending_angle_deg"] {
        assert_eq!(h[col(&h, raw) + 1], format!("{raw}_smooth"), "{h:?}");
    }
    assert_eq!(frames.len(), 30);
    let err = |f: &Vec<String>, c: &str| -> f64 {
        let p: f64 = f[col(&h, "pressure_kpa")].parse().unwrap();
        f[col(&h, c)].parse::<f64>().unwrap() / ramp_radius_at(p) - 1.0
    };
    let std = |e: &[f64]| {
        let m = e.iter().sum::<f64>() / e.len() as f64;
        (e.iter().map(|v| (v - m).powi(2)).sum::<f64>() / e.len() as f64).sqrt()
    };
    let raw: Vec<f64> = frames.iter().map(|f| err(f, "radius_mm")).collect();
    let smooth: Vec<f64> = frames.iter().map(|f| err(f, "radius_mm_smooth")).collect();
    eprintln!(
        "ramp: radius error sd raw {:.4}%, smoothed {:.4}%; worst smoothed {:.4}%",
        100.0 * std(&raw),
        100.0 * std(&smooth),
        100.0 * smooth.iter().fold(0.0f64, |a, e| a.max(e.abs()))
    );
    assert!(smooth.iter().all(|e| e.abs() < 0.01), "{smooth:?}");
    assert!(std(&smooth) <= std(&raw), "{smooth:?} vs {raw:?}");
}

#[test]
fn rgbd_session_gives_mm_from_depth_without_a_scale_photo() {
    use bendscope::calib::{UndistortSettings, Undistorter};
    use bendscope::render::actuator::{ArcScene, FrameLook, PlaneSampler};
    use bendscope::render::board::BoardPose;
    use bendscope::render::session::reference_marker_positions_mm;
    use nalgebra::{Point2, Rotation3, Vector3};
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("rgbd");
    fs::create_dir_all(s.join("color")).unwrap();
    fs::create_dir_all(s.join("depth")).unwrap();
    // The renderer's RGB-D camera: 640x480 pinhole, fx = fy = 520, (321.7, 238.2).
    let camera = bendscope::render::session::rgbd_camera();
    let (w, h) = (camera.image_width, camera.image_height);
    // The actuator plane is tilted 15° about the vertical axis: depth varies along it.
    let plane = BoardPose {
        rotation: Rotation3::from_euler_angles(0.0, 15f64.to_radians(), 0.0),
        translation_mm: Vector3::new(0.0, 0.0, 230.0),
    };
    // 4x4 samples per pixel: the renderer's jittered sample pattern is the same in every
    // frame, so its sampling noise does not average out over frames; with 2x2 it moved
    // markers by a few hundredths of a pixel, up to 0.7% of radius at R = 165 mm.
    let sampler = PlaneSampler::new(&camera, &plane, 4, 4).unwrap();
    let und = Undistorter::new(&camera, UndistortSettings::default()).unwrap();
    let normal = plane.rotation * Vector3::z();
    let depth_scale_m = 0.0001;
    let depth = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(w, h, |x, y| {
        let ray = und
            .rays_from_pixels(&[Point2::new(x as f64, y as f64)])
            .unwrap()[0];
        let z = normal.dot(&plane.translation_mm) / normal.dot(&ray);
        image::Luma([(z / (depth_scale_m * 1000.0)).round() as u16])
    });
    let radius_at = |p: f64| 3000.0 * p.powf(-0.9) + 5.0;
    // Ten pressure steps of 3 kPa, each held for three frames (10 fps), as a regulator
    // stepping and settling would give; the log holds each step over its frames.
    let fps = 10.0;
    let mut log = String::from("time_s,pressure_kpa\n");
    for k in 0..10 {
        let p = 20.0 + 3.0 * k as f64;
        log.push_str(&format!(
            "{:.3},{p}\n{:.3},{p}\n",
            0.3 * k as f64 - 0.05,
            0.3 * k as f64 + 0.22
        ));
    }
    for i in 0..30 {
        let p = 20.0 + 3.0 * (i / 3) as f64;
        let scene = ArcScene::reference_actuator(1.0 / radius_at(p), Point2::new(-50.0, 20.0));
        sampler
            .render(&scene, [0.0, 0.0], &FrameLook::default(), i)
            .save(s.join(format!("color/{i:06}.png")))
            .unwrap();
        depth.save(s.join(format!("depth/{i:06}.png"))).unwrap();
    }
    fs::write(
        s.join("intrinsics.json"),
        format!(r#"{{"width": {w}, "height": {h}, "fx": 520.0, "fy": 520.0, "cx": 321.7, "cy": 238.2, "depth_scale_m": {depth_scale_m}, "fps": {fps}}}"#),
    )
    .unwrap();
    fs::write(s.join("pressure_log.csv"), log).unwrap();
    let run = Run::new(dir.path(), &["process", "rgbd"]);
    assert_eq!(run.code, 0, "{run}");
    let (fh, frames) = read_csv(&s.join("bendscope-out/per_frame.csv"));
    assert_eq!(frames.len(), 30);
    assert!(
        frames.iter().all(|f| f[col(&fh, "status")] == "ok"),
        "{frames:?}"
    );
    // One row per pressure step (1 kPa bins), the mean of its three frames.
    let (vh, steps) = read_csv(&s.join("bendscope-out/per_video.csv"));
    assert_eq!(steps.len(), 10);
    for f in &steps {
        assert_eq!(f[col(&vh, "frames_used")], "3");
        let p: f64 = f[col(&vh, "pressure_kpa")].parse().unwrap();
        let r: f64 = f[col(&vh, "radius_mm")].parse().unwrap();
        assert!(
            (r / radius_at(p) - 1.0).abs() < RADIUS_TOLERANCE,
            "{p} kPa: {r} mm vs {}",
            radius_at(p)
        );
        let truth_angle = ((reference_marker_positions_mm()[7]
            - reference_marker_positions_mm()[0])
            / radius_at(p))
        .to_degrees();
        let a: f64 = f[col(&vh, "bending_angle_deg")].parse().unwrap();
        assert!(
            (a - truth_angle).abs() < ANGLE_TOLERANCE_DEG,
            "{p} kPa: angle {a} vs {truth_angle}"
        );
    }
    // markers.csv in 3D: a z_mm column, every marker within 0.05 mm of the session's
    // least-squares plane of the markers (the actuator's side face), and marker 1 of the
    // first frame at the origin.
    let (mh, markers) = read_csv(&s.join("bendscope-out/markers.csv"));
    assert_eq!(mh.last().map(String::as_str), Some("z_mm"), "{mh:?}");
    assert_eq!(markers.len(), 30 * 8);
    let z: Vec<f64> = markers
        .iter()
        .map(|m| m[col(&mh, "z_mm")].parse::<f64>().unwrap())
        .collect();
    let worst_z = z.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    eprintln!("rgbd markers.csv: worst |z_mm| {worst_z:.3}");
    assert!(worst_z < 0.05, "{worst_z}");
    for c in ["x_mm", "y_mm", "z_mm"] {
        assert_eq!(markers[0][col(&mh, c)].parse::<f64>().unwrap(), 0.0);
    }
    // A depth frame missing: that frame is named, with what to do; the others are kept.
    fs::remove_file(s.join("depth/000003.png")).unwrap();
    let _ = fps;
    let run = Run::new(dir.path(), &["process", "rgbd"]);
    assert_eq!(run.code, 0, "{run}");
    assert!(
        run.stderr.contains("000003.png") && run.stderr.contains("16-bit PNG"),
        "{run}"
    );
    let (fh, frames) = read_csv(&s.join("bendscope-out/per_frame.csv"));
    let bad: Vec<&Vec<String>> = frames
        .iter()
        .filter(|f| f[col(&fh, "status")] != "ok")
        .collect();
    assert_eq!(bad.len(), 1, "only the frame without depth: {bad:?}");
    assert_eq!(bad[0][col(&fh, "frame")], "3");
}
