//! Reliability suite (issue 9): `bendscope process` on bad inputs and under faults.
//!
//! Every case runs the real binary on a copy of `fixtures/sessions/example` (or of a small
//! rendered RGB-D session) damaged in one way, and checks what a user relies on: no
//! panic, the exit code the README promises (2: the session is refused and nothing is
//! written; 1: some rows or videos failed and the others are kept; 3: nothing measured;
//! 0: all measured, warnings allowed), a stderr line that names the file and says what
//! to do, the other videos still measured within 0.5% of `truth.json`, and no temporary
//! file left in OUT. Faults: a blocked overlay folder, reruns (nothing changed, a video
//! or the calibration photos replaced, an output deleted), two sessions of the same
//! name, a run killed with SIGKILL and rerun (byte-identical outputs).
//!
//! Each case passes `--calibration` with the example camera written once (the truth
//! camera), except the cases about calibration.

mod common;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::{Duration, Instant, SystemTime};

use bendscope::render::session::SessionTruth;
use bendscope::video::{EncodeSettings, VideoWriter};
use common::{col, copy_dir, fixture, read_csv, Run, Tmpfs};

/// Accuracy the issue asks for on every video that is measured.
const RADIUS_TOLERANCE: f64 = 0.005;

// ---------------------------------------------------------------------------------------
// Shared inputs, made once per test run.

fn example() -> PathBuf {
    fixture("sessions/example")
}

fn truth() -> &'static SessionTruth {
    static T: OnceLock<SessionTruth> = OnceLock::new();
    T.get_or_init(|| {
        serde_json::from_str(&fs::read_to_string(example().join("truth.json")).unwrap()).unwrap()
    })
}

/// A folder for inputs shared by the cases of one test run (emptied at its first use).
fn shared() -> &'static Path {
    static D: OnceLock<PathBuf> = OnceLock::new();
    D.get_or_init(|| {
        let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("reliability-shared");
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    })
}

/// The example's camera (from truth.json) as a calibration file.
fn calibration() -> &'static Path {
    static C: OnceLock<PathBuf> = OnceLock::new();
    C.get_or_init(|| {
        let p = shared().join("example-camera.yaml");
        bendscope::calib::file::write_calibration(&p, &truth().camera.to_calibration()).unwrap();
        p
    })
}

/// Every file under `dir` (relative paths, sorted).
fn files_under(dir: &Path) -> Vec<PathBuf> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(rd) = fs::read_dir(dir) else { return };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                out.push(p.strip_prefix(root).unwrap().to_path_buf());
            }
        }
    }
    let mut v = Vec::new();
    walk(dir, dir, &mut v);
    v.sort();
    v
}

fn mtime(p: &Path) -> SystemTime {
    fs::metadata(p)
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
        .modified()
        .unwrap()
}

/// A video of `frames` frames of plain paper colour (no marker), `w` x `h`.
fn blank_video(path: &Path, w: u32, h: u32, frames: usize) {
    let mut wr = VideoWriter::create(path, w, h, &EncodeSettings::default()).unwrap();
    for _ in 0..frames {
        wr.write(&image::RgbImage::from_pixel(
            w,
            h,
            image::Rgb([235, 235, 230]),
        ))
        .unwrap();
    }
    wr.finish().unwrap();
}

/// `src` re-muxed with its index (moov) before the media data, as
/// `ffmpeg -i src -c copy -movflags +faststart dst` does.
fn faststart_copy(src: &Path, dst: &Path) {
    use ffmpeg_next as ffmpeg;
    ffmpeg::init().unwrap();
    ffmpeg::log::set_level(ffmpeg::log::Level::Quiet);
    let mut ictx = ffmpeg::format::input(&src).unwrap();
    let mut octx = ffmpeg::format::output(&dst).unwrap();
    let mut time_bases = Vec::new();
    for ist in ictx.streams() {
        let mut ost = octx
            .add_stream(ffmpeg::encoder::find(ffmpeg::codec::Id::None))
            .unwrap();
        ost.set_parameters(ist.parameters());
        time_bases.push(ist.time_base());
    }
    let mut opts = ffmpeg::Dictionary::new();
    opts.set("movflags", "+faststart");
    octx.write_header_with(opts).unwrap();
    for (stream, mut packet) in ictx.packets() {
        let i = stream.index();
        let otb = octx.stream(i).unwrap().time_base();
        packet.rescale_ts(time_bases[i], otb);
        packet.set_position(-1);
        packet.set_stream(i);
        packet.write_interleaved(&mut octx).unwrap();
    }
    octx.write_trailer().unwrap();
}

/// Top-level MP4 box types in file order.
fn mp4_boxes(bytes: &[u8]) -> Vec<String> {
    let mut out = Vec::new();
    let mut i = 0usize;
    while i + 8 <= bytes.len() {
        let size = u32::from_be_bytes(bytes[i..i + 4].try_into().unwrap()) as usize;
        out.push(String::from_utf8_lossy(&bytes[i + 4..i + 8]).into_owned());
        if size < 8 {
            break;
        }
        i += size;
    }
    out
}

// ---------------------------------------------------------------------------------------
// A case: a damaged copy of a session and the checks every run must pass.

struct Case {
    _dir: tempfile::TempDir,
    /// Working directory of the runs.
    root: PathBuf,
    /// The session folder (`root/s`).
    s: PathBuf,
    /// The output folder (`root/out`).
    out: PathBuf,
}

impl Case {
    /// An empty working directory (no session yet).
    fn bare() -> Case {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().to_path_buf();
        Case {
            s: root.join("s"),
            out: root.join("out"),
            root,
            _dir: dir,
        }
    }

    /// A copy of the example session.
    fn example() -> Case {
        let c = Case::bare();
        copy_dir(&example(), &c.s);
        c
    }

    /// A copy of the rendered RGB-D session.
    fn rgbd() -> Case {
        let c = Case::bare();
        copy_dir(rgbd_session(), &c.s);
        c
    }

    fn path(&self, rel: &str) -> PathBuf {
        self.s.join(rel)
    }

    fn write(&self, rel: &str, bytes: impl AsRef<[u8]>) {
        let p = self.path(rel);
        fs::create_dir_all(p.parent().unwrap()).unwrap();
        fs::write(p, bytes).unwrap();
    }

    fn remove(&self, rel: &str) {
        let p = self.path(rel);
        if p.is_dir() {
            fs::remove_dir_all(p).unwrap();
        } else {
            fs::remove_file(p).unwrap();
        }
    }

    /// Rewrites pressures.csv with the given rows after the header.
    fn manifest(&self, rows: &str) {
        self.write("pressures.csv", format!("file,pressure_kpa\n{rows}"));
    }

    /// `bendscope process s -o out ARGS`, then the checks that hold for every run.
    fn process(&self, args: &[&str]) -> Run {
        let mut all = vec!["process", "s", "-o", "out"];
        all.extend_from_slice(args);
        let run = Run::new(&self.root, &all);
        assert_sane(&run, &self.out);
        run
    }

    /// [`Self::process`] with the example's calibration.
    fn run(&self) -> Run {
        self.process(&["--calibration", calibration().to_str().unwrap()])
    }

    /// Asserts a refused session: exit 2, one stderr line with every needle, and no
    /// file written in OUT.
    fn refused(&self, run: &Run, needles: &[&str]) {
        run.assert_bad_input(needles);
        assert!(
            files_under(&self.out).is_empty(),
            "a refused session wrote {:?}",
            files_under(&self.out)
        );
    }

    fn per_video(&self) -> Table {
        Table::read(&self.out.join("per_video.csv"))
    }

    fn per_frame(&self) -> Table {
        Table::read(&self.out.join("per_frame.csv"))
    }
}

/// No panic, and no temporary file (`.name` or `name.tmp`) anywhere in OUT.
fn assert_sane(run: &Run, out: &Path) {
    assert!(!run.stderr.contains("panicked"), "panic: {run}");
    let temporaries: Vec<PathBuf> = files_under(out)
        .into_iter()
        .filter(|p| {
            let n = p.file_name().unwrap().to_string_lossy();
            n.starts_with('.') || n.ends_with(".tmp")
        })
        .collect();
    assert!(
        temporaries.is_empty(),
        "temporaries left in OUT: {temporaries:?}\n{run}"
    );
}

/// Exactly one stderr line mentions `name`, and it holds every needle.
fn assert_reported_once(run: &Run, name: &str, needles: &[&str]) {
    let lines: Vec<&str> = run.stderr.lines().filter(|l| l.contains(name)).collect();
    assert_eq!(lines.len(), 1, "{name} should be reported once: {run}");
    for n in needles {
        assert!(
            lines[0].contains(n),
            "the line on {name} lacks `{n}`: {run}"
        );
    }
}

/// (measured, failed) from the summary line on stdout.
fn counts(run: &Run) -> (usize, usize) {
    let line = run
        .stdout
        .lines()
        .find(|l| l.contains(" measured, "))
        .unwrap_or_else(|| panic!("no summary line: {run}"));
    let num = |before: &str| -> usize {
        let head = line.split(before).next().unwrap();
        head.rsplit(' ').next().unwrap().parse().unwrap()
    };
    (num(" measured"), num(" failed"))
}

/// A CSV output, by column name.
struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    fn read(p: &Path) -> Table {
        let (header, rows) = read_csv(p);
        Table { header, rows }
    }

    fn rows_of<'a>(&'a self, file: &'a str) -> impl Iterator<Item = &'a Vec<String>> + 'a {
        self.rows.iter().filter(move |r| r[0] == file)
    }

    fn get(&self, row: &[String], column: &str) -> String {
        row[col(&self.header, column)].clone()
    }

    /// The status of the first row of `file` (a duplicate row comes after it).
    fn status(&self, file: &str) -> String {
        let row = self
            .rows_of(file)
            .next()
            .unwrap_or_else(|| panic!("{file} not in {:?}", self.rows));
        self.get(row, "status")
    }

    fn num(&self, row: &[String], column: &str) -> f64 {
        self.get(row, column).parse().unwrap_or(f64::NAN)
    }
}

/// Every example video except `bad` has status ok and its radius within tolerance.
fn assert_others_kept(t: &Table, bad: &[&str]) {
    for v in &truth().videos {
        if bad.contains(&v.file.as_str()) {
            continue;
        }
        assert_eq!(t.status(&v.file), "ok", "{}", v.file);
        assert_radius(t, &v.file, v.radius_mm);
    }
}

fn assert_radius(t: &Table, file: &str, want_mm: f64) {
    let row = t.rows_of(file).next().unwrap();
    let r = t.num(row, "radius_mm");
    assert!(
        (r / want_mm - 1.0).abs() < RADIUS_TOLERANCE,
        "{file}: radius {r} mm vs {want_mm} mm"
    );
}

// ---------------------------------------------------------------------------------------
// Session level: the whole session is refused (exit 2, one line, nothing written).

#[test]
fn a_missing_session_folder_is_refused() {
    let c = Case::bare();
    let run = c.run();
    c.refused(&run, &["s", "no such session folder", "check the path"]);
}

#[test]
fn a_session_path_that_is_a_file_is_refused() {
    let c = Case::bare();
    fs::write(&c.s, b"not a folder").unwrap();
    let run = c.run();
    c.refused(&run, &["s", "is a file", "give the session folder"]);
}

#[test]
fn an_empty_session_folder_is_refused() {
    let c = Case::bare();
    fs::create_dir(&c.s).unwrap();
    let run = c.run();
    c.refused(&run, &["pressures.csv", "write a pressures.csv"]);
}

#[test]
fn an_empty_manifest_is_refused() {
    let c = Case::example();
    c.write("pressures.csv", "");
    let run = c.run();
    c.refused(&run, &["pressures.csv", "empty", "add the header"]);
}

#[test]
fn a_manifest_with_only_its_header_is_refused() {
    let c = Case::example();
    c.manifest("");
    let run = c.run();
    c.refused(
        &run,
        &["pressures.csv", "lists no videos", "add one row per video"],
    );
}

#[test]
fn a_manifest_without_a_file_column_is_refused() {
    let c = Case::example();
    c.write("pressures.csv", "video,pressure_kpa\nGX010101.MP4,20\n");
    let run = c.run();
    c.refused(
        &run,
        &[
            "pressures.csv",
            "no `file` column",
            "name the column of video names `file`",
        ],
    );
}

#[test]
fn a_pressure_column_without_a_unit_is_refused() {
    let c = Case::example();
    c.write("pressures.csv", "file,pressure\nGX010101.MP4,20\n");
    let run = c.run();
    c.refused(
        &run,
        &[
            "pressures.csv",
            "pressure_bar, pressure_kpa or pressure_psi",
        ],
    );
}

#[test]
fn a_binary_garbage_manifest_is_refused() {
    let c = Case::example();
    let garbage: Vec<u8> = (0..4000u32)
        .map(|i| (i * 7919 % 251) as u8 | 0x80)
        .collect();
    c.write("pressures.csv", garbage);
    let run = c.run();
    c.refused(
        &run,
        &["pressures.csv", "not UTF-8", "save the file as CSV UTF-8"],
    );
}

#[test]
fn a_manifest_beside_a_pressure_log_is_refused() {
    let c = Case::example();
    c.write("pressure_log.csv", "time_s,pressure_kpa\n0,0\n1,10\n");
    let run = c.run();
    c.refused(
        &run,
        &[
            "pressures.csv",
            "pressure_log.csv",
            "keep the one that describes",
        ],
    );
}

#[test]
fn a_ramp_session_with_two_videos_is_refused() {
    let c = Case::example();
    c.remove("pressures.csv");
    for v in ["GX010103.MP4", "GX010104.MP4", "GX010105.MP4"] {
        c.remove(v);
    }
    c.write("pressure_log.csv", "time_s,pressure_kpa\n0,0\n1,10\n");
    let run = c.run();
    c.refused(
        &run,
        &["exactly one video, found 2", "one video per session folder"],
    );
}

/// A ramp session (one video) with `log` as its pressure log.
fn ramp_case(log: &[u8]) -> Case {
    let c = Case::example();
    c.remove("pressures.csv");
    for v in [
        "GX010102.MP4",
        "GX010103.MP4",
        "GX010104.MP4",
        "GX010105.MP4",
    ] {
        c.remove(v);
    }
    c.write("pressure_log.csv", log);
    c
}

#[test]
fn a_pressure_log_whose_time_goes_back_is_refused() {
    let c = ramp_case(b"time_s,pressure_kpa\n0,0\n1,10\n0.5,20\n");
    let run = c.run();
    c.refused(
        &run,
        &["pressure_log.csv", "line 4", "does not increase", "sort"],
    );
}

#[test]
fn a_pressure_log_of_one_row_is_refused() {
    let c = ramp_case(b"time_s,pressure_kpa\n0,0\n");
    let run = c.run();
    c.refused(&run, &["pressure_log.csv", "at least two rows"]);
}

#[test]
fn a_garbage_pressure_log_is_refused() {
    let garbage: Vec<u8> = (0..3000u32)
        .map(|i| (i * 104729 % 253) as u8 | 0x80)
        .collect();
    let c = ramp_case(&garbage);
    let run = c.run();
    c.refused(
        &run,
        &[
            "pressure_log.csv",
            "not UTF-8",
            "save the file as CSV UTF-8",
        ],
    );
}

#[test]
fn a_pressure_log_with_text_in_a_row_is_refused() {
    let c = ramp_case(b"time_s,pressure_kpa\n0,0\n0.5,high\n1,10\n");
    let run = c.run();
    c.refused(
        &run,
        &[
            "pressure_log.csv",
            "line 3",
            "pressure_kpa",
            "is not a number",
        ],
    );
}

#[test]
fn a_pressure_log_shorter_than_a_ramp_video_is_warned_with_the_count() {
    // 8 frames at 30 fps; the log ends at 0.12 s, after frame 3.
    let c = ramp_case(b"time_s,pressure_kpa\n0,20\n0.12,26\n");
    let run = c.run();
    assert_eq!(run.code, 0, "measured, with a warning: {run}");
    assert_reported_once(
        &run,
        "GX010101.MP4",
        &[
            "4 of 8 frames",
            "outside the pressure log",
            "ramp_time_offset_s",
        ],
    );
    let f = c.per_frame();
    let ok: Vec<f64> = f
        .rows
        .iter()
        .filter(|r| f.get(r, "status") == "ok")
        .map(|r| f.num(r, "pressure_kpa"))
        .collect();
    assert_eq!(ok.len(), 4);
    assert!(
        (ok[3] - 25.0).abs() < 1e-3,
        "frame 3 at 0.1 s: {} kPa",
        ok[3]
    );
}

/// A copy of the example with `toml` as its bendscope.toml.
fn config_case(toml: &str) -> Case {
    let c = Case::example();
    c.write("bendscope.toml", toml);
    c
}

#[test]
fn an_unknown_config_key_is_refused_with_its_name_and_line() {
    let c = config_case("[scale_board]\nsquare_mm = 10\n\n[detect]\nhue_maxlow = 12\n");
    let run = c.run();
    c.refused(&run, &["bendscope.toml", "hue_maxlow", "line 5"]);
}

#[test]
fn a_config_value_of_the_wrong_type_is_refused_with_its_key() {
    let c = config_case("expected_markers = \"eight\"\n[scale_board]\nsquare_mm = 10\n");
    let run = c.run();
    c.refused(&run, &["bendscope.toml", "expected_markers", "line 1"]);
}

#[test]
fn two_expected_markers_are_refused() {
    let c = config_case("expected_markers = 2\n");
    let run = c.run();
    c.refused(
        &run,
        &["bendscope.toml", "expected_markers = 2", "at least 3"],
    );
}

#[test]
fn a_frame_stride_of_zero_is_refused() {
    let c = config_case("frame_stride = 0\n");
    let run = c.run();
    c.refused(&run, &["bendscope.toml", "frame_stride", "at least 1"]);
}

#[test]
fn bad_segments_are_refused_with_the_key_and_what_is_wrong() {
    for (toml, needles) in [
        (
            "segments = [[1, 2, 3], [4, 5, 9]]\n",
            &["line 1", "segments = ", "marker 9, which does not exist"][..],
        ),
        (
            "segments = [[1, 2], [3, 4, 5, 6, 7, 8]]\n",
            &["segments = ", "segment 1 has 2 marker(s)", "at least 3"][..],
        ),
        (
            "segments = [[1, 2, 3, 4, 5], [3, 4, 5, 6, 7, 8]]\n",
            &["segments = ", "overlapping or out of order"][..],
        ),
        (
            "smooth_s = 0\n",
            &["smooth_s = 0", "positive number of seconds"][..],
        ),
    ] {
        let c = config_case(toml);
        let run = c.run();
        let mut all = vec!["bendscope.toml"];
        all.extend(needles);
        c.refused(&run, &all);
    }
}

#[test]
fn a_negative_mm_per_px_is_refused() {
    let c = config_case("mm_per_px = -1\n");
    let run = c.run();
    c.refused(&run, &["bendscope.toml", "mm_per_px = -1", "positive"]);
}

#[test]
fn a_scale_board_of_zero_square_size_is_refused() {
    let c = config_case("[scale_board]\nsquare_mm = 0\n");
    let run = c.run();
    c.refused(
        &run,
        &[
            "bendscope.toml",
            "scale_board.square_mm",
            "must be a positive number of mm",
        ],
    );
}

#[test]
fn a_garbage_config_file_is_refused() {
    let c = Case::example();
    let garbage: Vec<u8> = (0..2000u32).map(|i| (i * 31 % 256) as u8).collect();
    c.write("bendscope.toml", garbage);
    let run = c.run();
    c.refused(
        &run,
        &["bendscope.toml", "not UTF-8", "save the file as UTF-8"],
    );
}

#[test]
fn a_missing_config_file_given_by_flag_is_refused() {
    let c = Case::example();
    let run = c.process(&[
        "--calibration",
        calibration().to_str().unwrap(),
        "--config",
        "nowhere.toml",
    ]);
    c.refused(&run, &["nowhere.toml", "no such file", "check the path"]);
}

#[test]
fn a_missing_calibration_file_is_refused() {
    let c = Case::example();
    let run = c.process(&["--calibration", "nowhere.yaml"]);
    c.refused(
        &run,
        &["nowhere.yaml", "no such file", "bendscope calibrate"],
    );
}

#[test]
fn a_garbage_calibration_file_is_refused() {
    let c = Case::example();
    let garbage: Vec<u8> = (0..3000u32).map(|i| (i * 7 % 256) as u8).collect();
    fs::write(c.root.join("cam.yaml"), garbage).unwrap();
    let run = c.process(&["--calibration", "cam.yaml"]);
    c.refused(
        &run,
        &[
            "cam.yaml",
            "not a bendscope calibration",
            "bendscope calibrate",
        ],
    );
}

#[test]
fn an_empty_calibration_file_is_refused() {
    let c = Case::example();
    fs::write(c.root.join("cam.yaml"), b"").unwrap();
    let run = c.process(&["--calibration", "cam.yaml"]);
    c.refused(
        &run,
        &[
            "cam.yaml",
            "not a bendscope calibration",
            "bendscope calibrate",
        ],
    );
}

#[test]
fn a_calibration_named_in_the_config_that_is_missing_is_refused() {
    let c = config_case("calibration = \"cam.yaml\"\n[scale_board]\nsquare_mm = 10\n");
    let run = c.process(&[]);
    c.refused(&run, &["cam.yaml", "no such file"]);
}

#[test]
fn no_calib_folder_and_no_calibration_is_refused() {
    let c = Case::example();
    c.remove("calib");
    let run = c.process(&[]);
    c.refused(&run, &["calib", "give --calibration FILE"]);
}

/// A grey 800x600 JPEG (no board).
fn grey_jpeg() -> Vec<u8> {
    let img = image::GrayImage::from_pixel(800, 600, image::Luma([128]));
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, image::ImageFormat::Jpeg).unwrap();
    bytes.into_inner()
}

#[test]
fn calib_photos_without_a_board_are_refused() {
    let c = Case::example();
    c.remove("calib");
    for i in 1..=4 {
        c.write(&format!("calib/photo{i}.jpg"), grey_jpeg());
    }
    let run = c.process(&[]);
    c.refused(&run, &["calib", "calibration failed", "calib_board"]);
}

#[test]
fn a_truncated_calib_photo_is_named_and_the_others_calibrate() {
    let c = Case::example();
    let bytes = fs::read(c.path("calib/board03.jpg")).unwrap();
    c.write("calib/board03.jpg", &bytes[..bytes.len() / 2]);
    let run = c.process(&[]);
    assert_eq!(run.code, 0, "{run}");
    assert_reported_once(
        &run,
        "board03.jpg",
        &["truncated", "copy it again", "not used"],
    );
    assert_reported_once(&run, "calibrated fisheye from 15 views", &[]);
    assert_others_kept(&c.per_video(), &[]);
}

#[test]
fn no_scale_photo_is_refused() {
    let c = Case::example();
    c.remove("scale.jpg");
    let run = c.run();
    c.refused(
        &run,
        &[
            "no scale photo",
            "put scale.jpg",
            "mm_per_px",
            "[scale_markers]",
        ],
    );
}

#[test]
fn a_scale_photo_without_a_board_is_refused() {
    let c = Case::example();
    c.write("scale.jpg", grey_jpeg());
    let run = c.run();
    c.refused(&run, &["scale.jpg", "no 9x6 board", "scale_board"]);
}

#[test]
fn a_scale_photo_of_random_bytes_is_refused() {
    let c = Case::example();
    let garbage: Vec<u8> = (0..5000u32).map(|i| (i * 13 % 256) as u8).collect();
    c.write("scale.jpg", garbage);
    let run = c.run();
    c.refused(
        &run,
        &["scale.jpg", "not a readable image", "give a JPEG/PNG photo"],
    );
}

#[test]
fn a_truncated_scale_photo_is_refused_as_truncated() {
    let c = Case::example();
    let bytes = fs::read(c.path("scale.jpg")).unwrap();
    c.write("scale.jpg", &bytes[..bytes.len() / 2]);
    let run = c.run();
    c.refused(&run, &["scale.jpg", "truncated", "copy it again"]);
}

#[test]
fn an_output_path_that_is_a_file_is_refused() {
    let c = Case::example();
    fs::write(&c.out, b"a file").unwrap();
    let run = c.run();
    run.assert_bad_input(&["out", "is a file", "give -o a folder"]);
    assert_eq!(fs::read(&c.out).unwrap(), b"a file", "the file is kept");
}

#[test]
fn a_refused_session_beside_a_good_one_keeps_the_good_ones_results() {
    let c = Case::example();
    fs::create_dir(c.root.join("empty")).unwrap();
    let cal = calibration().to_str().unwrap();
    let run = Run::new(
        &c.root,
        &["process", "s", "empty", "-o", "out", "--calibration", cal],
    );
    assert_sane(&run, &c.out);
    assert_eq!(
        run.code, 1,
        "one session refused, the other measured: {run}"
    );
    assert_reported_once(&run, "empty", &["pressures.csv"]);
    assert_others_kept(&Table::read(&c.out.join("s/per_video.csv")), &[]);
}

// ---------------------------------------------------------------------------------------
// Rows and videos: the bad one is reported, the others are measured (exit 1).

/// Runs a damaged example with the calibration; asserts exit 1, `file` reported on one
/// stderr line holding `needles`, its per_video.csv status holding them too (but the
/// manifest line, `line N`, which only stderr gives), and the other videos measured.
fn assert_row_fails(c: &Case, file: &str, needles: &[&str]) -> Table {
    let run = c.run();
    assert_eq!(run.code, 1, "{run}");
    assert_reported_once(&run, file, needles);
    let t = c.per_video();
    let status = t
        .rows_of(file)
        .map(|r| t.get(r, "status"))
        .find(|s| s != "ok")
        .unwrap_or_else(|| panic!("{file} has no failed row: {:?}", t.rows));
    for n in needles.iter().filter(|n| !n.starts_with("line ")) {
        assert!(status.contains(n), "status of {file} lacks `{n}`: {status}");
    }
    assert_others_kept(&t, &[file]);
    t
}

const ROWS: &str =
    "GX010101.MP4,20\nGX010102.MP4,35\nGX010103.MP4,50\nGX010104.MP4,65\nGX010105.MP4,80\n";

#[test]
fn a_row_naming_a_missing_video_is_reported_and_the_rest_measured() {
    let c = Case::example();
    c.manifest(&format!("{ROWS}GX019999.MP4,90\n"));
    assert_row_fails(
        &c,
        "GX019999.MP4",
        &["line 7", "no such video", "check the name"],
    );
}

#[test]
fn a_duplicate_row_is_reported_and_the_first_used() {
    let c = Case::example();
    c.manifest(&format!("{ROWS}GX010103.MP4,99\n"));
    let run = c.run();
    assert_eq!(run.code, 1, "{run}");
    assert_reported_once(
        &run,
        "GX010103.MP4",
        &["line 7", "listed twice", "the first row is used"],
    );
    let t = c.per_video();
    let rows: Vec<_> = t.rows_of("GX010103.MP4").collect();
    assert_eq!(rows.len(), 2);
    assert_eq!(
        t.get(rows[0], "pressure_kpa"),
        "50.0000",
        "the first row's pressure"
    );
    assert_others_kept(&t, &[]);
}

/// GX010102.MP4's pressure replaced by `raw`: that row is reported once, the video is
/// not measured, and the failure count stays within the videos.
fn assert_bad_pressure(raw: &str, needles: &[&str]) {
    let c = Case::example();
    c.manifest(&ROWS.replace("GX010102.MP4,35", &format!("GX010102.MP4,{raw}")));
    let t = assert_row_fails(&c, "GX010102.MP4", needles);
    assert_eq!(t.rows.len(), 5, "one row per video: {:?}", t.rows);
}

#[test]
fn a_non_numeric_pressure_is_reported_once() {
    assert_bad_pressure(
        "abc",
        &["line 3", "`abc` is not a number", "give a plain number"],
    );
}

#[test]
fn a_negative_pressure_is_reported_once() {
    assert_bad_pressure("-5", &["line 3", "negative", "give a pressure >= 0"]);
}

#[test]
fn a_nan_pressure_is_reported_once() {
    assert_bad_pressure("NaN", &["line 3", "not finite", "give a pressure >= 0"]);
}

#[test]
fn an_infinite_pressure_is_reported_once() {
    assert_bad_pressure("inf", &["line 3", "not finite", "give a pressure >= 0"]);
}

#[test]
fn an_empty_pressure_is_reported_once() {
    assert_bad_pressure(
        "",
        &["line 3", "no pressure in this row", "give a plain number"],
    );
}

#[test]
fn a_row_without_a_file_name_is_reported_by_line() {
    let c = Case::example();
    c.manifest(&format!("{ROWS},90\n"));
    let run = c.run();
    assert_eq!(run.code, 1, "{run}");
    assert_reported_once(&run, "line 7", &["no file name"]);
    assert_others_kept(&c.per_video(), &[]);
}

#[test]
fn a_row_pointing_outside_the_session_is_not_followed() {
    let c = Case::example();
    fs::copy(c.path("GX010101.MP4"), c.root.join("outside.mp4")).unwrap();
    c.manifest(&format!("{ROWS}../outside.mp4,90\n"));
    assert_row_fails(&c, "../outside.mp4", &["no such video"]);
}

#[test]
fn a_video_not_in_the_manifest_is_reported_once_and_counted_once() {
    let c = Case::example();
    fs::copy(c.path("GX010101.MP4"), c.path("extra.mp4")).unwrap();
    let run = c.run();
    assert_eq!(run.code, 1, "{run}");
    assert_reported_once(&run, "extra.mp4", &["not in pressures.csv", "add a row"]);
    assert_eq!(counts(&run), (5, 1), "{run}");
    let t = c.per_video();
    assert!(t.status("extra.mp4").contains("not in pressures.csv"));
    assert_others_kept(&t, &[]);
}

#[test]
fn bad_rows_of_every_video_do_not_count_more_failures_than_videos() {
    let c = Case::example();
    c.manifest(
        "GX010101.MP4,x\nGX010102.MP4,-1\nGX010103.MP4,NaN\nGX010104.MP4,\nGX010105.MP4,inf\n",
    );
    let run = c.run();
    assert_eq!(run.code, 3, "nothing measured: {run}");
    assert_eq!(counts(&run), (0, 5), "{run}");
    for v in &truth().videos {
        assert_reported_once(&run, &v.file, &["line"]);
    }
    assert_eq!(c.per_video().rows.len(), 5);
}

#[test]
fn a_manifest_name_in_another_letter_case_finds_its_video() {
    let c = Case::example();
    c.manifest(&ROWS.replace("GX010102.MP4", "gx010102.mp4"));
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    assert_others_kept(&c.per_video(), &[]);
}

#[test]
fn two_videos_whose_names_differ_only_in_case_are_reported() {
    let c = Case::example();
    fs::copy(c.path("GX010101.MP4"), c.path("gx010103.mp4")).unwrap();
    let run = c.run();
    assert_eq!(run.code, 1, "{run}");
    // Ambiguous: neither is measured; one line names both.
    assert_reported_once(
        &run,
        "gx010103.mp4",
        &["GX010103.MP4", "differ only in case", "rename"],
    );
    let t = c.per_video();
    assert_others_kept(&t, &["GX010103.MP4"]);
}

/// Pseudo-random bytes (a fixed sequence).
fn noise(n: usize, seed: u64) -> Vec<u8> {
    let mut x = seed | 1;
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x as u8
        })
        .collect()
}

#[test]
fn a_video_of_random_bytes_fails_alone() {
    let c = Case::example();
    c.write("GX010102.MP4", noise(200_000, 1));
    assert_row_fails(
        &c,
        "GX010102.MP4",
        &["no frame measured", "not a video", "re-export"],
    );
}

#[test]
fn an_empty_video_file_fails_alone() {
    let c = Case::example();
    c.write("GX010102.MP4", b"");
    assert_row_fails(
        &c,
        "GX010102.MP4",
        &["no frame measured", "empty", "copy it again"],
    );
}

#[test]
fn a_text_file_named_mp4_fails_alone() {
    let c = Case::example();
    c.write("GX010102.MP4", "these are my notes about the 35 kPa run\n");
    assert_row_fails(&c, "GX010102.MP4", &["no frame measured", "not a video"]);
}

#[test]
fn a_video_truncated_before_its_index_fails_as_truncated() {
    let c = Case::example();
    let bytes = fs::read(c.path("GX010103.MP4")).unwrap();
    assert_eq!(
        mp4_boxes(&bytes).last().unwrap(),
        "moov",
        "index at the end"
    );
    c.write("GX010103.MP4", &bytes[..bytes.len() / 2]);
    assert_row_fails(
        &c,
        "GX010103.MP4",
        &["no frame measured", "truncated", "copy it again"],
    );
}

#[test]
fn a_faststart_video_truncated_is_partial_not_ok() {
    let c = Case::example();
    let fast = shared().join("GX010103-faststart.MP4");
    static ONCE: OnceLock<()> = OnceLock::new();
    ONCE.get_or_init(|| faststart_copy(&c.path("GX010103.MP4"), &fast));
    let bytes = fs::read(&fast).unwrap();
    assert_eq!(mp4_boxes(&bytes)[1], "moov", "index before the data");
    c.write("GX010103.MP4", &bytes[..bytes.len() / 2]);
    let run = c.run();
    assert_eq!(run.code, 0, "measured, with a warning: {run}");
    assert_reported_once(
        &run,
        "GX010103.MP4",
        &["partial", "truncated", "copy it again"],
    );
    let t = c.per_video();
    assert!(
        t.status("GX010103.MP4").starts_with("partial"),
        "{}",
        t.status("GX010103.MP4")
    );
    let row = t.rows_of("GX010103.MP4").next().unwrap();
    let used = t.num(row, "frames_used");
    assert!(used >= 1.0 && used < 8.0, "frames used {used}");
    assert_radius(&t, "GX010103.MP4", truth().videos[2].radius_mm);
    assert_others_kept(&t, &["GX010103.MP4"]);
}

#[test]
fn a_video_without_markers_fails_with_the_marker_count() {
    let c = Case::example();
    blank_video(&c.path("GX010104.MP4"), 800, 600, 4);
    assert_row_fails(
        &c,
        "GX010104.MP4",
        &[
            "0 markers found, 8 expected (in 4 of 4 frames)",
            "expected_markers",
        ],
    );
}

#[test]
fn a_wide_video_in_a_4_3_session_fails_alone() {
    let c = Case::example();
    blank_video(&c.path("GX010102.MP4"), 800, 450, 2);
    assert_row_fails(
        &c,
        "GX010102.MP4",
        &[
            "another aspect ratio",
            "calibrate at the video's resolution",
        ],
    );
}

/// A small 16:9 session rendered once (GoPro-like camera at 640x360, two videos of
/// two frames) with its truth and calibration.
fn wide_session() -> &'static (PathBuf, SessionTruth) {
    use bendscope::render::actuator::FrameLook;
    use bendscope::render::fixtures::gopro_like_camera;
    use bendscope::render::session::{write_session, SessionSpec};
    static S: OnceLock<(PathBuf, SessionTruth)> = OnceLock::new();
    S.get_or_init(|| {
        let s = shared().join("wide");
        let spec = SessionSpec {
            camera: gopro_like_camera(960, 540),
            distance_mm: 150.0,
            pressures_kpa: vec![40.0, 60.0],
            radius_law: (3000.0, -0.9, 5.0),
            frames: 2,
            calib_views: 3,
            calib_view_reach: 1.0,
            scale_square_mm: 8.0,
            scale_board_offset_mm: Some(0.0),
            distractor: false,
            supersample: 2,
            look: FrameLook::default(),
            seed: 11,
        };
        let truth = write_session(&s, &spec).unwrap();
        bendscope::calib::file::write_calibration(
            &s.join("wide.yaml"),
            &truth.camera.to_calibration(),
        )
        .unwrap();
        (s, truth)
    })
}

#[test]
fn a_4_3_video_in_a_wide_session_fails_alone() {
    let (wide, t) = wide_session();
    let c = Case::bare();
    copy_dir(wide, &c.s);
    fs::copy(example().join("GX010103.MP4"), c.path("GX010109.MP4")).unwrap();
    let mut m = fs::read_to_string(c.path("pressures.csv")).unwrap();
    m.push_str("GX010109.MP4,50\n");
    c.write("pressures.csv", m);
    let run = c.process(&["--calibration", "s/wide.yaml"]);
    assert_eq!(run.code, 1, "{run}");
    assert_reported_once(
        &run,
        "GX010109.MP4",
        &[
            "800x600",
            "another aspect ratio",
            "calibrate at the video's resolution",
        ],
    );
    let pv = c.per_video();
    for v in &t.videos {
        assert_eq!(pv.status(&v.file), "ok", "{}", v.file);
        assert_radius(&pv, &v.file, v.radius_mm);
    }
}

#[test]
fn a_254_character_video_name_is_measured_with_bounded_output_names() {
    let c = Case::example();
    let long = format!("{}.mp4", "a".repeat(250));
    assert_eq!(long.len(), 254);
    fs::rename(c.path("GX010102.MP4"), c.path(&long)).unwrap();
    c.manifest(&ROWS.replace("GX010102.MP4", &long));
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    let t = c.per_video();
    assert_eq!(t.status(&long), "ok");
    assert_radius(&t, &long, truth().videos[1].radius_mm);
    assert_others_kept(&t, &["GX010102.MP4"]);
    for dir in ["overlays", "cache"] {
        let names = files_under(&c.out.join(dir));
        assert_eq!(names.len(), 5, "{dir}: {names:?}");
        for n in names {
            assert!(
                n.as_os_str().len() <= 120,
                "{dir}/{}: too long",
                n.display()
            );
        }
    }
}

#[test]
fn a_corrupt_gopro_chapter_makes_its_recording_partial() {
    let c = Case::example();
    c.write("GX020101.MP4", noise(100_000, 7));
    let run = c.run();
    assert_eq!(run.code, 0, "measured with a warning: {run}");
    assert_reported_once(
        &run,
        "GX020101.MP4",
        &["GX010101.MP4", "partial", "not a video"],
    );
    let t = c.per_video();
    assert!(t.status("GX010101.MP4").contains("GX020101.MP4"));
    assert_eq!(t.rows.len(), 5, "the chapter is not a row of its own");
    assert_radius(&t, "GX010101.MP4", truth().videos[0].radius_mm);
    assert_others_kept(&t, &["GX010101.MP4"]);
}

#[test]
fn a_manifest_with_bom_crlf_and_quotes_is_read() {
    let c = Case::example();
    c.write(
        "pressures.csv",
        "\u{feff}\"file\",\"pressure_kpa\"\r\n\"GX010101.MP4\",20\r\nGX010102.MP4,\"35\"\r\n\"GX010103.MP4\",50\r\nGX010104.MP4,65\r\nGX010105.MP4,80\r\n",
    );
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    assert!(run.stderr.trim().is_empty(), "{run}");
    assert_others_kept(&c.per_video(), &[]);
}

#[test]
fn a_pressure_in_bar_is_converted_and_kept_in_its_unit() {
    let c = Case::example();
    c.write(
        "pressures.csv",
        "file,pressure_bar\nGX010101.MP4,0.2\nGX010102.MP4,0.35\nGX010103.MP4,0.5\nGX010104.MP4,0.65\nGX010105.MP4,0.8\n",
    );
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    let t = c.per_video();
    assert_others_kept(&t, &[]);
    let row = t.rows_of("GX010103.MP4").next().unwrap();
    assert_eq!(t.get(row, "pressure_kpa"), "50.0000");
    assert_eq!(t.get(row, "pressure_bar"), "0.5000");
}

// ---------------------------------------------------------------------------------------
// Faults and reruns.

#[test]
fn a_blocked_overlay_folder_is_partial_and_repaired_by_a_rerun() {
    let c = Case::example();
    fs::create_dir_all(&c.out).unwrap();
    fs::write(c.out.join("overlays"), b"a file where the folder goes").unwrap();
    let run = c.run();
    assert_eq!(run.code, 0, "measured, with warnings: {run}");
    let t = c.per_video();
    for v in &truth().videos {
        assert_reported_once(&run, &v.file, &["partial", "overlay not written"]);
        assert!(t.status(&v.file).contains("overlay not written"));
        assert_radius(&t, &v.file, v.radius_mm);
    }
    // The block removed, a rerun makes the overlays (the cached entries are not current
    // without them).
    fs::remove_file(c.out.join("overlays")).unwrap();
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    assert!(run.stderr.trim().is_empty(), "{run}");
    assert_others_kept(&c.per_video(), &[]);
    for v in &truth().videos {
        assert!(c
            .out
            .join("overlays")
            .join(format!("{}.png", v.file))
            .is_file());
    }
}

#[test]
fn a_deleted_overlay_is_repaired_by_a_rerun_alone() {
    let c = Case::example();
    assert_eq!(c.run().code, 0);
    let gone = c.out.join("overlays/GX010103.MP4.png");
    let kept = c.out.join("cache/GX010101.MP4.json");
    let before = fs::read(&gone).unwrap();
    let stamp = mtime(&kept);
    fs::remove_file(&gone).unwrap();
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    assert_eq!(fs::read(&gone).unwrap(), before, "the same overlay again");
    assert_eq!(mtime(&kept), stamp, "the other videos are not redone");
}

/// Contents of every file under `dir` (except `skip`), by relative path.
fn snapshot(dir: &Path, skip: &[&str]) -> Vec<(PathBuf, Vec<u8>)> {
    files_under(dir)
        .into_iter()
        .filter(|p| !skip.iter().any(|s| p.starts_with(s)))
        .map(|p| {
            let bytes = fs::read(dir.join(&p)).unwrap();
            (p, bytes)
        })
        .collect()
}

/// session.json of `a` and `b` agree but for which videos came from the cache.
fn assert_same_provenance(a: &Path, b: &Path) {
    let read = |d: &Path| {
        let mut v: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(d.join("session.json")).unwrap()).unwrap();
        for item in v["videos"].as_array_mut().unwrap() {
            item.as_object_mut().unwrap().remove("from_cache");
        }
        v
    };
    assert_eq!(read(a), read(b));
}

fn assert_same_files(a: &[(PathBuf, Vec<u8>)], b: &[(PathBuf, Vec<u8>)]) {
    let names = |s: &[(PathBuf, Vec<u8>)]| s.iter().map(|(p, _)| p.clone()).collect::<Vec<_>>();
    assert_eq!(names(a), names(b), "the same files");
    for ((p, x), (_, y)) in a.iter().zip(b) {
        assert!(x == y, "{} differs", p.display());
    }
}

#[test]
fn a_rerun_with_nothing_changed_is_identical_and_measures_nothing() {
    let c = Case::example();
    // A video without markers too: its rejected frames (NaN radii) must be cached.
    blank_video(&c.path("GX010104.MP4"), 800, 600, 4);
    assert_eq!(c.run().code, 1);
    let first = snapshot(&c.out, &["session.json"]);
    let first_dir = tempfile::tempdir().unwrap();
    fs::copy(
        c.out.join("session.json"),
        first_dir.path().join("session.json"),
    )
    .unwrap();
    let stamps: Vec<SystemTime> = files_under(&c.out.join("cache"))
        .iter()
        .map(|p| mtime(&c.out.join("cache").join(p)))
        .collect();
    std::thread::sleep(Duration::from_millis(20));
    let run = c.run();
    assert_eq!(run.code, 1, "{run}");
    assert_same_files(&first, &snapshot(&c.out, &["session.json"]));
    assert_same_provenance(first_dir.path(), &c.out);
    let again: Vec<SystemTime> = files_under(&c.out.join("cache"))
        .iter()
        .map(|p| mtime(&c.out.join("cache").join(p)))
        .collect();
    assert_eq!(stamps, again, "no video was measured again");
}

#[test]
fn a_video_replaced_by_one_of_the_same_size_and_time_is_measured_again() {
    let c = Case::example();
    assert_eq!(c.run().code, 0);
    let target = c.path("GX010101.MP4");
    let (size, stamp) = (fs::metadata(&target).unwrap().len(), mtime(&target));
    // GX010105's video padded to the same size with an MP4 `free` box.
    let mut other = fs::read(c.path("GX010105.MP4")).unwrap();
    let pad = size as usize - other.len();
    assert!(pad >= 8);
    other.extend_from_slice(&(pad as u32).to_be_bytes());
    other.extend_from_slice(b"free");
    other.resize(size as usize, 0);
    fs::write(&target, &other).unwrap();
    fs::File::options()
        .write(true)
        .open(&target)
        .unwrap()
        .set_modified(stamp)
        .unwrap();
    assert_eq!(
        (fs::metadata(&target).unwrap().len(), mtime(&target)),
        (size, stamp)
    );
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    assert_radius(&c.per_video(), "GX010101.MP4", truth().videos[4].radius_mm);
}

#[test]
fn replaced_calibration_photos_are_calibrated_again() {
    let c = Case::example();
    let run = c.process(&[]);
    assert_eq!(run.code, 0, "{run}");
    assert!(run.stderr.contains("calibrated fisheye"), "{run}");
    let again = c.process(&[]);
    assert!(!again.stderr.contains("calibrated"), "cached: {again}");
    // The same camera photographed at 960x720 (fixtures/fisheye).
    c.remove("calib");
    copy_dir(&fixture("fisheye/calib"), &c.path("calib"));
    let run = c.process(&[]);
    assert_eq!(run.code, 0, "{run}");
    assert_reported_once(&run, "calibrated fisheye", &["calibration.yaml"]);
    let yaml = fs::read_to_string(c.out.join("calibration.yaml")).unwrap();
    assert!(yaml.contains("image_width: 960"), "{yaml}");
    assert_others_kept(&c.per_video(), &[]);
}

#[test]
fn two_sessions_of_the_same_name_get_their_own_output_folders() {
    let c = Case::bare();
    copy_dir(&example(), &c.root.join("a/x"));
    copy_dir(&example(), &c.root.join("b/x"));
    fs::write(
        c.root.join("b/x/pressures.csv"),
        "file,pressure_kpa\nGX010101.MP4,20\nGX010102.MP4,35\n",
    )
    .unwrap();
    for v in ["GX010103.MP4", "GX010104.MP4", "GX010105.MP4"] {
        fs::remove_file(c.root.join("b/x").join(v)).unwrap();
    }
    let cal = calibration().to_str().unwrap();
    let run = Run::new(
        &c.root,
        &["process", "a/x", "b/x", "-o", "out", "--calibration", cal],
    );
    assert_sane(&run, &c.out);
    assert_eq!(run.code, 0, "{run}");
    assert_reported_once(&run, "x-2", &["b/x", "another session is also named x"]);
    assert_eq!(Table::read(&c.out.join("x/per_video.csv")).rows.len(), 5);
    let second = Table::read(&c.out.join("x-2/per_video.csv"));
    assert_eq!(second.rows.len(), 2, "b/x's results: {:?}", second.rows);
}

#[test]
fn a_temporary_left_by_a_killed_write_is_cleaned_by_the_next_run() {
    let c = Case::example();
    assert_eq!(c.run().code, 0);
    for stale in [
        "cache/.bendscope-Ab12Cd.tmp",
        "overlays/.bendscope-Xy34Zw.tmp",
        ".bendscope-Qq99Rr.tmp",
    ] {
        fs::write(c.out.join(stale), b"half a file").unwrap();
    }
    // c.run() asserts that no temporary is left.
    assert_eq!(c.run().code, 0);
}

#[test]
fn a_corrupt_cache_entry_is_measured_again() {
    let c = Case::example();
    assert_eq!(c.run().code, 0);
    fs::write(c.out.join("cache/GX010102.MP4.json"), b"{\"key\": tru").unwrap();
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    assert_others_kept(&c.per_video(), &[]);
    let text = fs::read_to_string(c.out.join("cache/GX010102.MP4.json")).unwrap();
    assert!(
        text.starts_with('{') && text.ends_with('}'),
        "entry rewritten"
    );
}

/// A session of `n` videos (copies of the example's, pressures 20..80 kPa repeated).
fn many_videos(c: &Case, n: usize) {
    let t = truth();
    let mut rows = String::new();
    for i in 0..n {
        let v = &t.videos[i % t.videos.len()];
        let name = format!("clip{i:03}.mp4");
        fs::copy(c.path(&v.file), c.path(&name)).unwrap();
        rows.push_str(&format!("{name},{}\n", v.pressure_kpa));
    }
    for v in &t.videos {
        c.remove(&v.file);
    }
    c.manifest(&rows);
}

#[test]
fn a_run_killed_with_sigkill_then_rerun_gives_the_outputs_of_an_uninterrupted_run() {
    let c = Case::example();
    many_videos(&c, 40);
    let cal = calibration().to_str().unwrap();
    // Killed once the first video's cache entry exists.
    let mut child = Command::new(env!("CARGO_BIN_EXE_bendscope"))
        .args(["process", "s", "-o", "killed", "--calibration", cal])
        .current_dir(&c.root)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let cache = c.root.join("killed/cache");
    let start = Instant::now();
    while files_under(&cache)
        .iter()
        .all(|p| p.extension().is_none_or(|e| e != "json"))
    {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no cache entry appeared"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before it was killed"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let killed = c.root.join("killed");
    assert!(!killed.join("per_video.csv").exists(), "killed mid-run");
    let first_entry = files_under(&cache)
        .into_iter()
        .find(|p| p.extension().is_some_and(|e| e == "json"))
        .unwrap();
    let stamp = mtime(&cache.join(&first_entry));
    // The rerun completes from the cache; an uninterrupted run into another folder.
    let rerun = Run::new(
        &c.root,
        &["process", "s", "-o", "killed", "--calibration", cal],
    );
    assert_sane(&rerun, &killed);
    assert_eq!(rerun.code, 0, "{rerun}");
    assert_eq!(
        mtime(&cache.join(&first_entry)),
        stamp,
        "the cached video was reused"
    );
    let whole = Run::new(
        &c.root,
        &["process", "s", "-o", "whole", "--calibration", cal],
    );
    assert_sane(&whole, &c.root.join("whole"));
    assert_eq!(whole.code, 0, "{whole}");
    // session.json differs in which videos came from the cache, and only there.
    let (a, b) = (
        snapshot(&killed, &["session.json"]),
        snapshot(&c.root.join("whole"), &["session.json"]),
    );
    assert_same_provenance(&killed, &c.root.join("whole"));
    for kind in ["per_frame.csv", "per_video.csv", "fit.json", "report.html"] {
        assert!(
            a.iter().any(|(p, _)| p == Path::new(kind)),
            "{kind} written"
        );
    }
    assert_eq!(
        a.iter().filter(|(p, _)| p.starts_with("overlays")).count(),
        40
    );
    assert_eq!(
        a.iter()
            .filter(|(p, _)| p.extension().is_some_and(|e| e == "svg"))
            .count(),
        4
    );
    assert_same_files(&a, &b);
    // The report names every video and links every plot.
    let html = fs::read_to_string(killed.join("report.html")).unwrap();
    for i in 0..40 {
        assert!(
            html.contains(&format!("clip{i:03}.mp4")),
            "clip{i:03}.mp4 in the report"
        );
    }
    for p in files_under(&killed.join("plots")) {
        if p.extension().is_some_and(|e| e == "png") {
            let link = format!("href=\"plots/{}\"", p.display());
            assert!(html.contains(&link), "{link} in the report");
        }
    }
}

// ---------------------------------------------------------------------------------------
// RGB-D sessions.

/// Frames per second of the rendered RGB-D session.
const RGBD_FPS: f64 = 10.0;
/// Frames of the rendered RGB-D session.
const RGBD_FRAMES: u64 = 10;
/// Depth units per metre of the rendered session.
const DEPTH_SCALE_M: f64 = 0.0001;

/// Pressure of the rendered ramp at `t` s: 20 kPa + 20 kPa/s.
fn rgbd_pressure(t: f64) -> f64 {
    20.0 + 20.0 * t
}

/// A small RGB-D session rendered once: 10 frames at 10 fps of the reference actuator
/// (640x480 pinhole, the actuator plane 230 mm away), a ramp 20 -> 38 kPa and its log.
fn rgbd_session() -> &'static Path {
    use bendscope::render::actuator::{ArcScene, FrameLook, PlaneSampler};
    use bendscope::render::board::BoardPose;
    use nalgebra::{Point2, Rotation3, Vector3};
    static S: OnceLock<PathBuf> = OnceLock::new();
    S.get_or_init(|| {
        let s = shared().join("rgbd");
        fs::create_dir_all(s.join("color")).unwrap();
        fs::create_dir_all(s.join("depth")).unwrap();
        let camera = bendscope::render::session::rgbd_camera();
        let (w, h) = (camera.image_width, camera.image_height);
        let distance_mm = 230.0;
        let plane = BoardPose {
            rotation: Rotation3::identity(),
            translation_mm: Vector3::new(0.0, 0.0, distance_mm),
        };
        let sampler = PlaneSampler::new(&camera, &plane, 2, 5).unwrap();
        let depth = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_pixel(
            w,
            h,
            image::Luma([(distance_mm / (DEPTH_SCALE_M * 1000.0)).round() as u16]),
        );
        for i in 0..RGBD_FRAMES {
            let p = rgbd_pressure(i as f64 / RGBD_FPS);
            let radius = 3000.0 * p.powf(-0.9) + 5.0;
            let scene = ArcScene::reference_actuator(1.0 / radius, Point2::new(-50.0, 20.0));
            sampler
                .render(&scene, [0.0, 0.0], &FrameLook::default(), i)
                .save(s.join(format!("color/{i:06}.png")))
                .unwrap();
            depth.save(s.join(format!("depth/{i:06}.png"))).unwrap();
        }
        fs::write(
            s.join("intrinsics.json"),
            format!(r#"{{"width": {w}, "height": {h}, "fx": 520.0, "fy": 520.0, "cx": 321.7, "cy": 238.2, "depth_scale_m": {DEPTH_SCALE_M}, "fps": {RGBD_FPS}}}"#),
        )
        .unwrap();
        fs::write(
            s.join("pressure_log.csv"),
            format!("time_s,pressure_kpa\n-0.1,{}\n1.0,{}\n", rgbd_pressure(-0.1), rgbd_pressure(1.0)),
        )
        .unwrap();
        s
    })
}

/// The pressure_kpa of frame `frame` in per_frame.csv.
fn frame_pressure(t: &Table, frame: u64) -> f64 {
    let row = t
        .rows
        .iter()
        .find(|r| t.get(r, "frame") == frame.to_string())
        .unwrap_or_else(|| panic!("no frame {frame}: {:?}", t.rows));
    t.num(row, "pressure_kpa")
}

#[test]
fn an_intact_rgbd_session_is_measured() {
    let c = Case::rgbd();
    let run = c.process(&[]);
    assert_eq!(run.code, 0, "{run}");
    let f = c.per_frame();
    assert_eq!(f.rows.len(), RGBD_FRAMES as usize);
    assert!(
        f.rows.iter().all(|r| f.get(r, "status") == "ok"),
        "{:?}",
        f.rows
    );
}

#[test]
fn a_dropped_rgbd_frame_does_not_shift_the_later_frames_pressures() {
    let c = Case::rgbd();
    c.remove("color/000004.png");
    c.remove("depth/000004.png");
    let run = c.process(&[]);
    assert_eq!(run.code, 0, "{run}");
    let f = c.per_frame();
    assert_eq!(f.rows.len(), RGBD_FRAMES as usize - 1);
    for frame in [3, 5, 6, 9] {
        let want = rgbd_pressure(frame as f64 / RGBD_FPS);
        let got = frame_pressure(&f, frame);
        assert!(
            (got - want).abs() < 1e-3,
            "frame {frame}: {got} kPa vs {want}"
        );
    }
}

#[test]
fn an_orphan_depth_frame_is_warned_by_name() {
    let c = Case::rgbd();
    fs::copy(c.path("depth/000001.png"), c.path("depth/000099.png")).unwrap();
    let run = c.process(&[]);
    assert_eq!(run.code, 0, "{run}");
    assert_reported_once(&run, "depth/000099.png", &["no colour frame", "ignored"]);
    assert_eq!(c.per_frame().rows.len(), RGBD_FRAMES as usize);
}

#[test]
fn an_orphan_colour_frame_is_named_in_its_status() {
    let c = Case::rgbd();
    c.remove("depth/000004.png");
    let run = c.process(&[]);
    assert_eq!(run.code, 0, "{run}");
    assert_reported_once(&run, "color/000004.png", &["no depth frame", "16-bit PNG"]);
    let f = c.per_frame();
    let bad: Vec<_> = f
        .rows
        .iter()
        .filter(|r| f.get(r, "status") != "ok")
        .collect();
    assert_eq!(bad.len(), 1);
    assert_eq!(f.get(bad[0], "frame"), "4");
    assert!(f.get(bad[0], "status").contains("color/000004.png"));
}

#[test]
fn an_unreadable_colour_frame_is_named_and_the_others_measured() {
    let c = Case::rgbd();
    c.write("color/000005.png", noise(3000, 5));
    let run = c.process(&[]);
    assert_eq!(run.code, 0, "{run}");
    assert_reported_once(&run, "color/000005.png", &["unreadable colour frame"]);
    let f = c.per_frame();
    assert_eq!(
        f.rows.iter().filter(|r| f.get(r, "status") == "ok").count(),
        9
    );
}

/// Replaces every depth frame (or only `only`) by `img`.
fn replace_depth(c: &Case, only: Option<u64>, img: &image::DynamicImage) {
    for i in 0..RGBD_FRAMES {
        if only.is_none_or(|o| o == i) {
            img.save(c.path(&format!("depth/{i:06}.png"))).unwrap();
        }
    }
}

/// Every frame's depth replaced by `img`: nothing measured (exit 3), one stderr line
/// naming the frame `name` and saying what to do.
fn assert_all_depth_bad(img: image::DynamicImage, name: &str, needles: &[&str]) {
    let c = Case::rgbd();
    replace_depth(&c, None, &img);
    let run = c.process(&[]);
    assert_eq!(run.code, 3, "{run}");
    assert_reported_once(&run, name, needles);
    let f = c.per_frame();
    assert!(f.rows.iter().all(|r| f.get(r, "status") != "ok"));
}

#[test]
fn eight_bit_depth_frames_measure_nothing_and_say_why() {
    assert_all_depth_bad(
        image::DynamicImage::ImageLuma8(image::GrayImage::from_pixel(640, 480, image::Luma([90]))),
        "depth/000000.png",
        &["not 16-bit grey", "export depth as 16-bit PNG"],
    );
}

#[test]
fn all_zero_depth_frames_measure_nothing_and_say_why() {
    assert_all_depth_bad(
        image::DynamicImage::ImageLuma16(image::ImageBuffer::from_pixel(
            640,
            480,
            image::Luma([0u16]),
        )),
        "depth/000000.png",
        &["all zero", "check the depth stream"],
    );
}

#[test]
fn depth_frames_of_another_size_measure_nothing_and_say_why() {
    assert_all_depth_bad(
        image::DynamicImage::ImageLuma16(image::ImageBuffer::from_pixel(
            320,
            240,
            image::Luma([2300u16]),
        )),
        "color/000000.png",
        &[
            "differ from the intrinsics' 640x480",
            "align depth to colour",
        ],
    );
}

#[test]
fn one_eight_bit_depth_frame_is_named_and_the_others_measured() {
    let c = Case::rgbd();
    let img =
        image::DynamicImage::ImageLuma8(image::GrayImage::from_pixel(640, 480, image::Luma([90])));
    replace_depth(&c, Some(7), &img);
    let run = c.process(&[]);
    assert_eq!(run.code, 0, "{run}");
    assert_reported_once(&run, "depth/000007.png", &["16-bit"]);
    let f = c.per_frame();
    assert_eq!(
        f.rows.iter().filter(|r| f.get(r, "status") == "ok").count(),
        9
    );
}

#[test]
fn missing_intrinsics_are_refused() {
    let c = Case::rgbd();
    c.remove("intrinsics.json");
    let run = c.process(&[]);
    c.refused(&run, &["intrinsics.json", "no such file", "fx"]);
}

#[test]
fn garbage_intrinsics_are_refused() {
    let c = Case::rgbd();
    c.write("intrinsics.json", noise(500, 3));
    let run = c.process(&[]);
    c.refused(&run, &["intrinsics.json", "JSON"]);
}

#[test]
fn intrinsics_with_a_negative_focal_length_are_refused() {
    let c = Case::rgbd();
    let text = fs::read_to_string(c.path("intrinsics.json")).unwrap();
    c.write(
        "intrinsics.json",
        text.replace("\"fx\": 520.0", "\"fx\": -520.0"),
    );
    let run = c.process(&[]);
    c.refused(&run, &["intrinsics.json", "must be positive"]);
}

#[test]
fn intrinsics_with_three_distortion_coefficients_are_refused() {
    let c = Case::rgbd();
    let text = fs::read_to_string(c.path("intrinsics.json")).unwrap();
    c.write(
        "intrinsics.json",
        text.replace("}", ", \"distortion\": [0.1, 0.0, 0.0]}"),
    );
    let run = c.process(&[]);
    c.refused(&run, &["intrinsics.json", "5 Brown coefficients"]);
}

#[test]
fn an_rgbd_session_without_a_pressure_log_is_refused() {
    let c = Case::rgbd();
    c.remove("pressure_log.csv");
    let run = c.process(&[]);
    c.refused(&run, &["pressure_log.csv", "needs a pressure log"]);
}

#[test]
fn a_pressure_log_shorter_than_the_recording_is_warned_with_the_count() {
    let c = Case::rgbd();
    c.write("pressure_log.csv", "time_s,pressure_kpa\n0,20\n0.45,29\n");
    let run = c.process(&[]);
    assert_eq!(run.code, 0, "{run}");
    assert_reported_once(
        &run,
        "color",
        &[
            "5 of 10 frames",
            "outside the pressure log",
            "ramp_time_offset_s",
        ],
    );
    let f = c.per_frame();
    assert_eq!(
        f.rows.iter().filter(|r| f.get(r, "status") == "ok").count(),
        5
    );
}

#[test]
fn frame_times_come_from_frames_csv_when_given() {
    let c = Case::rgbd();
    let mut table = String::from("frame,time_s\n");
    for i in 0..RGBD_FRAMES {
        table.push_str(&format!("{i:06},{}\n", 0.05 * i as f64));
    }
    c.write("frames.csv", table);
    let run = c.process(&[]);
    assert_eq!(run.code, 0, "{run}");
    let f = c.per_frame();
    for i in 0..RGBD_FRAMES {
        let want = rgbd_pressure(0.05 * i as f64);
        assert!((frame_pressure(&f, i) - want).abs() < 1e-3, "frame {i}");
    }
}

#[test]
fn frames_without_numbers_and_without_frames_csv_are_refused() {
    let c = Case::rgbd();
    for (i, name) in ["first", "second", "third"].iter().enumerate() {
        let (from_c, from_d) = (format!("color/{i:06}.png"), format!("depth/{i:06}.png"));
        fs::rename(c.path(&from_c), c.path(&format!("color/{name}.png"))).unwrap();
        fs::rename(c.path(&from_d), c.path(&format!("depth/{name}.png"))).unwrap();
    }
    let run = c.process(&[]);
    c.refused(
        &run,
        &[
            "cannot time",
            "name colour frames by frame number",
            "frames.csv",
        ],
    );
}

#[test]
fn a_frames_csv_missing_a_frame_is_refused_with_the_row_to_add() {
    let c = Case::rgbd();
    c.write("frames.csv", "frame,time_s\n000000,0\n000001,0.1\n");
    let run = c.process(&[]);
    c.refused(
        &run,
        &["frames.csv", "no time for colour frame 000002", "add a row"],
    );
}

// ---------------------------------------------------------------------------------------
// Issue 19, weak answers that mislead: input tables, fits and warnings.

/// The example's manifest with `sep` between the fields and `pressure(kPa)` written by
/// `cell` (a decimal comma, a point, ...).
fn example_manifest(sep: &str, cell: impl Fn(f64) -> String) -> String {
    let mut text = format!("file{sep}pressure_kpa\r\n");
    for v in &truth().videos {
        text.push_str(&format!(
            "{}{sep}{}\r\n",
            v.file,
            cell(v.pressure_kpa + 0.5)
        ));
    }
    text
}

/// (file, pressure_kpa cell, radius_mm cell) of every per_video.csv row.
fn radii(c: &Case) -> Vec<(String, String, String)> {
    let t = c.per_video();
    t.rows
        .iter()
        .map(|r| {
            (
                t.get(r, "file"),
                t.get(r, "pressure_kpa"),
                t.get(r, "radius_mm"),
            )
        })
        .collect()
}

#[test]
fn semicolon_and_tab_manifests_with_decimal_commas_measure_like_the_comma_one() {
    let comma = Case::example();
    comma.write("pressures.csv", example_manifest(",", |p| format!("{p}")));
    let run = comma.run();
    assert_eq!(run.code, 0, "{run}");
    let want = radii(&comma);
    assert_eq!(want.len(), truth().videos.len());
    assert_others_kept(&comma.per_video(), &[]);
    // A European spreadsheet's CSV (semicolons, decimal commas, a BOM) and a tab-separated
    // export: the same videos at the same pressures, the same radii to the last digit.
    for (sep, bom) in [(";", "\u{feff}"), ("\t", "")] {
        let c = Case::example();
        let text = example_manifest(sep, |p| format!("{p}").replace('.', ","));
        assert!(text.contains(&format!("{sep}20,5\r\n")), "{text}");
        c.write("pressures.csv", format!("{bom}{text}"));
        let run = c.run();
        assert_eq!(run.code, 0, "{sep:?}: {run}");
        assert!(!run.stderr.contains("warning"), "{sep:?}: {run}");
        assert_eq!(radii(&c), want, "{sep:?}");
    }
}

#[test]
fn a_manifest_split_by_an_odd_separator_is_refused_naming_it() {
    let c = Case::example();
    c.write("pressures.csv", example_manifest("|", |p| format!("{p}")));
    let run = c.run();
    c.refused(
        &run,
        &[
            "pressures.csv",
            "line 1",
            "separated by `|`",
            "semicolons or tabs",
        ],
    );
    assert!(!run.stderr.contains("no `file` column"), "{run}");
}

fn fit_json(c: &Case) -> serde_json::Value {
    serde_json::from_str(&fs::read_to_string(c.out.join("fit.json")).unwrap()).unwrap()
}

#[test]
fn every_video_at_one_pressure_gives_no_fit_and_says_why() {
    let c = Case::example();
    let rows: String = truth()
        .videos
        .iter()
        .map(|v| format!("{},40\n", v.file))
        .collect();
    c.manifest(&rows);
    let run = c.run();
    assert_eq!(run.code, 0, "videos were measured: {run}");
    assert_eq!(counts(&run), (5, 0), "{run}");
    let f = fit_json(&c);
    for k in [
        "radius_mm_vs_kpa",
        "curvature_per_m_vs_kpa",
        "bending_angle_deg_vs_kpa",
        "radius_mm_vs_unit",
        "curvature_per_m_vs_unit",
    ] {
        assert!(f[k].is_null(), "{k}: {f}");
    }
    let notes: Vec<&str> = f["notes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_str().unwrap())
        .collect();
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].starts_with("no fit of radius vs kPa, curvature vs kPa, angle vs kPa")
            && notes[0].contains("3 or more distinct x values (pressures), got 1 (40)"),
        "{notes:?}"
    );
    let lines: Vec<&str> = run
        .stderr
        .lines()
        .filter(|l| l.contains("fit.json"))
        .collect();
    assert_eq!(lines.len(), 1, "{run}");
    assert!(
        lines[0].starts_with("warning: s: fit.json: no fit of") && lines[0].contains("got 1 (40)"),
        "{run}"
    );
}

#[test]
fn a_zero_kpa_row_is_kept_in_the_tables_and_named_as_left_out_of_the_fits() {
    let c = Case::example();
    let rows: String = truth()
        .videos
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let p = if i == 0 { 0.0 } else { v.pressure_kpa };
            format!("{},{p}\n", v.file)
        })
        .collect();
    c.manifest(&rows);
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    let first = &truth().videos[0].file;
    let t = c.per_video();
    assert_eq!(t.status(first), "ok");
    assert_eq!(t.num(t.rows_of(first).next().unwrap(), "pressure_kpa"), 0.0);
    assert_others_kept(&t, &[]);
    let f = fit_json(&c);
    assert_eq!(f["radius_mm_vs_kpa"]["n"], 4, "{f}");
    let note = format!("{first} (0 kPa)");
    let notes = f["notes"].as_array().unwrap();
    assert_eq!(notes.len(), 1, "{f}");
    assert!(
        notes[0].as_str().unwrap().contains(&note)
            && notes[0].as_str().unwrap().contains("left out of the fits"),
        "{f}"
    );
    assert_reported_once(
        &run,
        &note,
        &["warning: s: fit.json", "left out of the fits"],
    );
}

/// The example with `expected_markers = n` in its bendscope.toml.
fn example_expecting(n: usize) -> Case {
    let c = Case::example();
    let toml = fs::read_to_string(c.path("bendscope.toml")).unwrap();
    c.write("bendscope.toml", format!("expected_markers = {n}\n{toml}"));
    c
}

#[test]
fn fewer_expected_markers_than_painted_is_warned_once_per_video() {
    let c = example_expecting(6);
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    for v in &truth().videos {
        assert_reported_once(
            &run,
            &v.file,
            &[
                "2 more marker-like blob(s) continue the chain of 6 markers",
                "only part of the chain is measured",
                "set expected_markers = 8",
            ],
        );
    }
    // The frames count them among the ignored blobs.
    let f = c.per_frame();
    assert!(
        f.rows
            .iter()
            .all(|r| f.get(r, "status") == "ok" && f.get(r, "n_ignored") == "2"),
        "{:?}",
        f.rows
    );
    // The cache keeps what a warning needs: a rerun from it warns the same.
    let again = c.run();
    assert_eq!(again.code, 0, "{again}");
    assert_eq!(
        again.stderr.matches("marker-like").count(),
        truth().videos.len(),
        "{again}"
    );
    let all = example_expecting(8).run();
    assert_eq!(all.code, 0, "{all}");
    assert!(!all.stderr.contains("marker-like"), "{all}");
}

#[test]
fn an_absurd_acquire_set_point_is_refused_naming_the_value_and_the_key() {
    let c = Case::bare();
    fs::write(
        c.root.join("p.toml"),
        "[steps]\npressures_kpa = [40, 1e9]\nstabilize_s = 1\nrecord_s = 1\n[regulator]\nport = \"/dev/null\"\n[camera]\nkind = \"webcam\"\n",
    )
    .unwrap();
    let run = Run::new(&c.root, &["acquire", "p.toml", "-o", "s", "--dry-run"]);
    run.assert_bad_input(&["p.toml", "1000000000 kPa", "700 kPa", "[regulator] max_kpa"]);
    assert!(!c.s.exists());
}

/// A FEM-shaped steps.csv of y = 300 p^-0.45 + 5 mm at `pressures`.
fn fake_steps(dir: &Path, pressures: &[f64]) {
    let mut s = String::from("pressure_kpa,radius_mm,curvature_per_m,bending_angle_deg\n");
    for p in pressures {
        let r = 300.0 * p.powf(-0.45) + 5.0;
        s.push_str(&format!("{p},{r},{},{}\n", 1000.0 / r, 3.0 * p.powf(0.8)));
    }
    fs::create_dir_all(dir).unwrap();
    fs::write(dir.join("steps.csv"), s).unwrap();
}

#[test]
fn compare_names_degenerate_input_and_the_direction_of_its_deviation() {
    let c = Case::bare();
    fake_steps(&c.root.join("fem"), &[0.0, 10.0, 30.0, 50.0, 70.0, 90.0]);
    let measured = |rows: &[(f64, f64)]| {
        let mut s =
            String::from("file,pressure_kpa,radius_mm,curvature_per_m,bending_angle_deg,status\n");
        for (i, (p, r)) in rows.iter().enumerate() {
            s.push_str(&format!(
                "v{i}.mp4,{p},{r},{},{},ok\n",
                1000.0 / r,
                3.0 * p.powf(0.8)
            ));
        }
        fs::create_dir_all(c.root.join("m")).unwrap();
        fs::write(c.root.join("m/per_video.csv"), s).unwrap();
    };
    // Every video at 40 kPa: no curve, and it says so (not "do not overlap").
    measured(&[(40.0, 61.0), (40.0, 60.5), (40.0, 61.2)]);
    let run = Run::new(
        &c.root,
        &["compare", "--measured", "m", "--fem", "fem", "-o", "r"],
    );
    assert_eq!(run.code, 3, "nothing compared: {run}");
    assert!(!run.stderr.contains("overlap"), "{run}");
    assert_eq!(run.stderr.matches("got 1 (40)").count(), 3, "{run}");
    // A rest row at 0 kPa is left out with a note; measured radii 2 mm below the FEM's
    // give a deviation of +2 mm (simulated - measured), as the summary and help say.
    let law = |p: f64| 300.0 * p.powf(-0.45) + 5.0;
    measured(&[
        (0.0, 900.0),
        (20.0, law(20.0) - 2.0),
        (40.0, law(40.0) - 2.0),
        (60.0, law(60.0) - 2.0),
        (80.0, law(80.0) - 2.0),
    ]);
    let run = Run::new(
        &c.root,
        &["compare", "--measured", "m", "--fem", "fem", "-o", "r"],
    );
    assert_eq!(run.code, 0, "{run}");
    let zero: Vec<&str> = run.stderr.lines().filter(|l| l.contains("0 kPa")).collect();
    assert_eq!(zero.len(), 2, "per_video.csv and steps.csv: {run}");
    assert!(
        zero.iter()
            .all(|l| l.starts_with("note: ") && l.contains("left out of the fits")),
        "{run}"
    );
    let (h, rows) = read_csv(&c.root.join("r/compare.csv"));
    let k = col(&h, "radius_mm_deviation");
    for r in &rows {
        let d: f64 = r[k].parse().unwrap();
        assert!((d - 2.0).abs() < 0.01, "{d}");
    }
    let summary = fs::read_to_string(c.root.join("r/summary.txt")).unwrap();
    assert!(
        summary.contains("deviation = simulated - measured"),
        "{summary}"
    );
    let help = Run::new(&c.root, &["compare", "--help"]);
    assert!(
        help.stdout.contains("Deviation = simulated - measured"),
        "{help}"
    );
}

#[test]
fn simulate_help_print_config_and_readme_agree_on_the_default_mesh() {
    let c = Case::bare();
    let printed = Run::new(&c.root, &["simulate", "--print-config"]);
    assert_eq!(printed.code, 0, "{printed}");
    let cfg: toml::Table = toml::from_str(&printed.stdout).unwrap();
    let size = cfg["mesh"]["size_mm"].as_float().unwrap();
    assert_eq!(size, bendscope::fem::actuator::DEFAULT_MESH_SIZE_MM);
    let help = Run::new(&c.root, &["simulate", "--help"]);
    let line = help
        .stdout
        .lines()
        .skip_while(|l| !l.contains("--mesh-size"))
        .take(3)
        .collect::<Vec<_>>()
        .join(" ");
    assert!(line.contains(&format!("[default: {size}]")), "{help}");
    let readme = fs::read_to_string(common::root().join("README.md")).unwrap();
    assert!(
        readme.contains(&format!("the default mesh size is {size} mm")),
        "README"
    );
    assert!(!readme.contains("default 2 mm mesh"), "README");
}

#[test]
fn a_material_a_thousand_times_stiffer_than_any_preset_is_warned_with_its_value() {
    let c = Case::bare();
    // C1 in kPa where MPa is meant.
    fs::write(c.root.join("a.toml"), "[material]\nc1 = 107.44\n").unwrap();
    let run = Run::new(
        &c.root,
        &["simulate", "--config", "a.toml", "--print-config"],
    );
    assert_eq!(run.code, 0, "{run}");
    let w: Vec<&str> = run
        .stderr
        .lines()
        .filter(|l| l.starts_with("warning: "))
        .collect();
    assert_eq!(w.len(), 1, "{run}");
    assert!(
        w[0].contains("[material] c1 = 107.44")
            && w[0].contains("935x stiffer than the stiffest preset")
            && w[0].contains("in MPa"),
        "{run}"
    );
    fs::write(
        c.root.join("b.toml"),
        "[material]\npreset = \"ecoflex0050\"\nscale = 1e-4\n",
    )
    .unwrap();
    let run = Run::new(
        &c.root,
        &["simulate", "--config", "b.toml", "--print-config"],
    );
    assert!(
        run.stderr
            .contains("preset = \"ecoflex0050\" with scale = 0.0001")
            && run.stderr.contains("softer than the softest preset"),
        "{run}"
    );
    let run = Run::new(
        &c.root,
        &["simulate", "--material", "dragonskin10", "--print-config"],
    );
    assert!(run.stderr.is_empty(), "{run}");
}

// Issue 19: process under faults found by the fault campaign (stale cache, scale
// provenance, scale files, disk full, concurrent runs, absurd pressures).

/// Bytes at each end of a file the cache key once sampled (the rest was not hashed).
const MIB: usize = 1 << 20;

/// Box `kind`'s byte range in an MP4 file (top level).
fn mp4_box(bytes: &[u8], kind: &str) -> std::ops::Range<usize> {
    let mut i = 0usize;
    while i + 8 <= bytes.len() {
        let size = u32::from_be_bytes(bytes[i..i + 4].try_into().unwrap()) as usize;
        if &bytes[i + 4..i + 8] == kind.as_bytes() {
            return i..i + size;
        }
        assert!(size >= 8, "malformed box at {i}");
        i += size;
    }
    panic!("no {kind} box");
}

/// GX010101.MP4 re-encoded losslessly (its media data then spans more than a MiB) and
/// followed by a 1.2 MB `free` box: a video of more than 2 MiB whose frames lie beyond
/// its first MiB and before its last. Made once.
fn big_video() -> &'static Path {
    static V: OnceLock<PathBuf> = OnceLock::new();
    V.get_or_init(|| {
        let p = shared().join("GX010101-lossless.MP4");
        let mut r = bendscope::video::VideoReader::open(&example().join("GX010101.MP4")).unwrap();
        let mut w = None;
        while let Some(f) = r.next_frame(1).unwrap() {
            let (fw, fh) = f.image.dimensions();
            let settings = EncodeSettings {
                crf: 0,
                ..EncodeSettings::default()
            };
            w.get_or_insert_with(|| VideoWriter::create(&p, fw, fh, &settings).unwrap())
                .write(&f.image)
                .unwrap();
        }
        w.unwrap().finish().unwrap();
        let mut bytes = fs::read(&p).unwrap();
        let pad = 1_200_000usize;
        bytes.extend_from_slice(&(pad as u32).to_be_bytes());
        bytes.extend_from_slice(b"free");
        bytes.resize(bytes.len() + pad - 8, 0);
        fs::write(&p, &bytes).unwrap();
        p
    })
}

/// Sets `p`'s modification time to `t` (as `cp -p` keeps it).
fn set_mtime(p: &Path, t: SystemTime) {
    fs::File::options()
        .write(true)
        .open(p)
        .unwrap()
        .set_modified(t)
        .unwrap();
}

#[test]
fn a_video_damaged_in_its_middle_then_restored_with_the_same_size_and_time_is_measured_again() {
    let c = Case::example();
    let target = c.path("GX010101.MP4");
    let good = fs::read(big_video()).unwrap();
    let mdat = mp4_box(&good, "mdat");
    // 32 KiB of the frames, beyond the first MiB and before the last one.
    let damage = MIB + 32 * 1024..MIB + 64 * 1024;
    assert!(
        mdat.start < damage.start && damage.end < mdat.end,
        "{mdat:?}"
    );
    assert!(damage.end < good.len() - MIB);
    let mut bad = good.clone();
    bad[damage.clone()].copy_from_slice(&noise(damage.len(), 19));
    let stamp = SystemTime::UNIX_EPOCH + Duration::from_secs(1_700_000_000);
    fs::write(&target, &bad).unwrap();
    set_mtime(&target, stamp);
    let run = c.run();
    assert_eq!(run.code, 0, "measured with a warning: {run}");
    let status = c.per_video().status("GX010101.MP4");
    assert!(status.starts_with("partial"), "damaged: {status}");
    // Restored from the camera's copy: same size, same time.
    fs::write(&target, &good).unwrap();
    set_mtime(&target, stamp);
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    let t = c.per_video();
    assert_eq!(t.status("GX010101.MP4"), "ok", "restored: {run}");
    assert_radius(&t, "GX010101.MP4", truth().videos[0].radius_mm);
    assert_others_kept(&t, &[]);
}

/// OUT/session.json.
fn session_json(out: &Path) -> serde_json::Value {
    let p = out.join("session.json");
    let text = fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    serde_json::from_str(&text).unwrap()
}

/// `bendscope scale s/scale.jpg` with the example camera and its 9x6 board of 10 mm
/// squares, saved to `save` (relative to the case's root); the saved JSON.
fn saved_scale(c: &Case, save: &str) -> serde_json::Value {
    let cal = calibration().to_str().unwrap();
    let run = Run::new(
        &c.root,
        &[
            "scale",
            "s/scale.jpg",
            "--calibration",
            cal,
            "--board",
            "9x6",
            "--square-mm",
            "10",
            "--save",
            save,
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    serde_json::from_str(&fs::read_to_string(c.root.join(save)).unwrap()).unwrap()
}

#[test]
fn session_json_records_the_version_settings_calibration_scale_and_cache_use() {
    let c = Case::example();
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    let want = saved_scale(&c, "scale.json");
    let s = session_json(&c.out);
    assert_eq!(s["bendscope_version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(s["settings"]["scale_board"]["square_mm"], 10.0);
    assert_eq!(s["settings"]["expected_markers"], 8);
    let cal = calibration();
    assert_eq!(s["calibration"]["path"], cal.to_str().unwrap());
    assert_eq!(s["calibration"]["source"], "given");
    let hash = format!(
        "{:032x}",
        xxhash_rust::xxh3::xxh3_128(&fs::read(cal).unwrap())
    );
    assert_eq!(s["calibration"]["content_hash"], hash.as_str());
    let scale = &s["scale"];
    assert_eq!(scale["source"], "scale_photo");
    assert_eq!(scale["file"], "s/scale.jpg");
    let mm_per_px = scale["mm_per_px"].as_f64().unwrap();
    assert_eq!(mm_per_px, want["mm_per_px"].as_f64().unwrap());
    assert!(
        (mm_per_px / truth().mm_per_px - 1.0).abs() < 0.01,
        "{mm_per_px}"
    );
    assert_eq!(scale["plane_from_px"], want["plane_from_px"]);
    assert_eq!(
        scale["board"],
        serde_json::json!({"cols": 9, "rows": 6, "square_mm": 10.0, "square_mm_given": true})
    );
    let from_cache = |s: &serde_json::Value| -> Vec<(String, bool)> {
        s["videos"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| {
                (
                    v["file"].as_str().unwrap().to_string(),
                    v["from_cache"].as_bool().unwrap(),
                )
            })
            .collect()
    };
    let names: Vec<String> = truth().videos.iter().map(|v| v.file.clone()).collect();
    let first = from_cache(&s);
    assert_eq!(
        first,
        names.iter().map(|n| (n.clone(), false)).collect::<Vec<_>>()
    );
    // The scale is shown on stdout and in the report.
    let shown = format!("{mm_per_px:.6} mm/px");
    assert!(run.stdout.contains(&shown), "{shown} on stdout: {run}");
    assert!(
        run.stdout.contains("9x6") && run.stdout.contains("10 mm"),
        "{run}"
    );
    let html = fs::read_to_string(c.out.join("report.html")).unwrap();
    assert!(html.contains(&shown), "{shown} in report.html");
    // A rerun takes every video from the cache and says so.
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    let again = from_cache(&session_json(&c.out));
    assert_eq!(
        again,
        names.iter().map(|n| (n.clone(), true)).collect::<Vec<_>>()
    );
}

#[test]
fn a_scale_board_square_size_given_nowhere_is_warned_once() {
    let c = Case::example();
    // The example's bendscope.toml gives square_mm = 10: no warning.
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    assert!(!run.stderr.contains("square"), "{run}");
    // Without it, 25 mm is assumed: every radius 2.5 times too large, and said so.
    c.remove("bendscope.toml");
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    assert_reported_once(
        &run,
        "square",
        &["warning", "scale.jpg", "25 mm", "[scale_board] square_mm"],
    );
    let s = session_json(&c.out);
    assert_eq!(s["scale"]["board"]["square_mm"], 25.0);
    assert_eq!(s["scale"]["board"]["square_mm_given"], false);
    // A known mm/px needs no board.
    c.write("bendscope.toml", "mm_per_px = 0.5282\n");
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    assert!(!run.stderr.contains("square"), "{run}");
    assert_eq!(session_json(&c.out)["scale"]["source"], "mm_per_px");
}

#[test]
fn a_calibration_yaml_of_an_earlier_run_does_not_stay_when_another_calibration_is_used() {
    let c = Case::example();
    let run = c.process(&[]);
    assert_eq!(run.code, 0, "{run}");
    let cached = c.out.join("calibration.yaml");
    assert!(cached.is_file(), "calib/ calibrated");
    assert_eq!(session_json(&c.out)["calibration"]["source"], "calibrated");
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    assert!(
        !cached.exists(),
        "calibration.yaml of the earlier run left in OUT"
    );
    let s = session_json(&c.out);
    assert_eq!(s["calibration"]["path"], calibration().to_str().unwrap());
}

#[test]
fn a_scale_file_saved_by_the_scale_command_is_used_by_process() {
    let c = Case::example();
    let want = saved_scale(&c, "s/board-scale.json");
    fs::rename(c.path("scale.jpg"), c.root.join("scale-photo.jpg")).unwrap();
    c.write("bendscope.toml", "scale = \"board-scale.json\"\n");
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    assert!(run.stderr.trim().is_empty(), "no warning: {run}");
    assert_others_kept(&c.per_video(), &[]);
    let scale = &session_json(&c.out)["scale"];
    assert_eq!(scale["source"], "scale_file");
    assert_eq!(scale["file"], "s/board-scale.json");
    assert_eq!(scale["mm_per_px"], want["mm_per_px"]);
    assert_eq!(scale["plane_from_px"], want["plane_from_px"]);
    assert_eq!(scale["board"]["square_mm"], 10.0);
    // A scale file that is not there is refused, naming it.
    c.write("bendscope.toml", "scale = \"nowhere.json\"\n");
    let run = c.run();
    run.assert_bad_input(&["nowhere.json", "bendscope scale", "--save"]);
    // Not both ways of giving the scale.
    c.write(
        "bendscope.toml",
        "scale = \"board-scale.json\"\nmm_per_px = 0.5\n",
    );
    let run = c.run();
    run.assert_bad_input(&["bendscope.toml", "scale", "mm_per_px", "one"]);
    // Saved without --square-mm (25 mm assumed): the scale command and process say so.
    let cal = calibration().to_str().unwrap();
    let run = Run::new(
        &c.root,
        &[
            "scale",
            "scale-photo.jpg",
            "--calibration",
            cal,
            "--save",
            "s/default-square.json",
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    assert_reported_once(&run, "--square-mm", &["warning", "25 mm"]);
    c.write("bendscope.toml", "scale = \"default-square.json\"\n");
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    assert_reported_once(
        &run,
        "square",
        &["warning", "default-square.json", "25 mm", "--square-mm"],
    );
}

/// Bytes `dir`'s files take on a tmpfs (whole 4 KiB pages).
fn pages_under(dir: &Path) -> u64 {
    files_under(dir)
        .iter()
        .map(|p| fs::metadata(dir.join(p)).unwrap().len().div_ceil(4096) * 4096)
        .sum()
}

#[test]
#[ignore = "needs root for a tmpfs mount: cargo test --test reliability -- --ignored, as root"]
fn a_full_disk_exits_4_naming_the_folder_and_a_forced_rerun_leaves_no_stale_report() {
    let c = Case::example();
    // The outputs' size, from a run elsewhere.
    let cal = calibration().to_str().unwrap();
    let probe = Run::new(
        &c.root,
        &["process", "s", "-o", "probe", "--calibration", cal],
    );
    assert_eq!(probe.code, 0, "{probe}");
    let probe_dir = c.root.join("probe");
    let report = fs::metadata(probe_dir.join("report.html")).unwrap().len();
    for p in files_under(&probe_dir) {
        let n = fs::metadata(probe_dir.join(&p)).unwrap().len();
        assert!(
            p == Path::new("report.html") || n < report / 3,
            "{}: {n} bytes",
            p.display()
        );
    }
    // Room for every output once, and for a second copy of any of them but report.html.
    let _mount = Tmpfs::mount(&c.out, pages_under(&probe_dir) + report / 2);
    let run = c.run();
    assert_eq!(run.code, 0, "fits once: {run}");
    assert!(c.out.join("report.html").is_file());
    // A forced rerun: the new report.html does not fit beside the old one.
    let run = c.process(&["--calibration", cal, "--force"]);
    assert_eq!(run.code, 4, "disk full: {run}");
    assert!(!run.stderr.contains("panicked"), "{run}");
    let lines: Vec<&str> = run.stderr.lines().collect();
    assert_eq!(lines.len(), 1, "one line: {run}");
    assert!(
        lines[0].contains(&format!("no space left on {}", c.out.display()))
            || lines[0].contains("no space left on out"),
        "{run}"
    );
    assert!(lines[0].contains("free space and rerun"), "{run}");
    assert!(
        c.out.join("per_video.csv").is_file(),
        "the new table is kept"
    );
    assert!(
        !c.out.join("report.html").exists(),
        "the old report.html stays beside the new table"
    );
}

#[test]
fn a_second_run_into_an_output_folder_in_use_is_refused_naming_the_first() {
    let c = Case::example();
    fs::create_dir_all(&c.out).unwrap();
    let lock_path = c.out.join(".bendscope.lock");
    let pid = std::process::id().to_string();
    {
        use std::io::Write as _;
        let mut lock = fs::File::create(&lock_path).unwrap();
        lock.try_lock().unwrap();
        writeln!(lock, "{pid}").unwrap();
        let cal = calibration().to_str().unwrap();
        let run = Run::new(
            &c.root,
            &["process", "s", "-o", "out", "--calibration", cal],
        );
        run.assert_bad_input(&["out", "another bendscope run", &pid, "wait"]);
        assert_eq!(
            files_under(&c.out),
            [PathBuf::from(".bendscope.lock")],
            "nothing written"
        );
    }
    // The holder gone (its lock released, its file left as by a killed run): the next
    // run proceeds and removes the file when done.
    let run = c.run();
    assert_eq!(run.code, 0, "{run}");
    assert!(!lock_path.exists());
    assert_others_kept(&c.per_video(), &[]);
}

#[test]
fn an_absurd_manifest_pressure_is_warned_with_its_value_and_row() {
    let c = Case::example();
    c.manifest(&ROWS.replace("GX010102.MP4,35", "GX010102.MP4,1e12"));
    let run = c.run();
    assert_eq!(run.code, 0, "a warning, not a refusal: {run}");
    assert_reported_once(
        &run,
        "1e12",
        &[
            "warning",
            "pressures.csv",
            "line 3",
            "GX010102.MP4",
            "10000 kPa",
        ],
    );
    // Besides it only the fits' note: against 1e12 kPa the other pressures are one
    // value, so the power law has too few distinct pressures and says so.
    for line in run.stderr.lines().filter(|l| !l.contains("1e12 kPa")) {
        assert!(
            line.contains("fit.json: no fit") && line.contains("distinct x values"),
            "{run}"
        );
    }
    let t = c.per_video();
    assert_eq!(t.status("GX010102.MP4"), "ok");
    let row = t.rows_of("GX010102.MP4").next().unwrap();
    assert_eq!(t.num(row, "pressure_kpa"), 1e12);
}
