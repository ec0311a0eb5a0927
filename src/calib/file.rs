//! Calibration files: OpenCV `FileStorage` YAML, written and read through OpenCV itself so
//! that `cv2.FileStorage(path, cv2.FILE_STORAGE_READ)` reads them as is.
//!
//! Keys: `model` (fisheye | pinhole), `image_width`, `image_height`, `camera_matrix` (3x3),
//! `distortion_coefficients` (4x1 or 5x1), `avg_reprojection_error` (px, RMS),
//! `per_view_reprojection_errors` (Nx1, px) in the order of `views_used`,
//! `board_width`, `board_height` (inner corners), `square_size_mm`, `views_used`
//! (sequence of names), `views_rejected` (sequence of {name, reason}).
//!
//! OpenCV's parser recurses once per level of nesting with no limit and overflows the
//! stack (aborting the process, not raising an error) on a few thousand levels; files
//! nested deeper than a calibration can be, or larger than one can be, are refused before
//! OpenCV reads them.
//!
//! The valid field ([`super::field`]), in degrees from the optical axis:
//! `valid_field_angle_deg` and `monotonic_field_angle_deg` (always written, for readers of
//! the file; bendscope recomputes both from the coefficients), and, when the calibration
//! knows where its board went ([`super::coverage`]), `coverage_field_angle_deg` (the
//! coverage limit bendscope reads back), `coverage_half_diagonal_share` and
//! `coverage_grid` (3x3, rows top to bottom). A file without `coverage_field_angle_deg`
//! (older files, hand-written ones) gets the monotonic limit only.

use std::path::Path;

use opencv::core::{FileNode, FileStorage, FileStorage_Mode, Mat, Vector};
use opencv::prelude::*;

use super::cv::{mat_from_column, mat_from_matrix3, matrix3_from_mat, values_from_mat};
use super::{Board, CalibError, Calibration, CameraModel, Coverage, RejectedView, ViewError};
use crate::io::write_atomic;

/// Deepest nesting of a file handed to OpenCV's parser. `FileStorage` recurses once per
/// level (flow `[` and `{`, XML elements, indented blocks, `- ` items) with no limit of
/// its own: a few thousand levels overflow the stack, which aborts the whole process
/// instead of raising an error. A calibration file nests 3 levels.
const MAX_NESTING: usize = 64;

/// Largest calibration file read, bytes (one with a thousand views is under 100 kB).
const MAX_CALIBRATION_BYTES: u64 = 16 << 20;

/// An upper bound of how deep `text` nests, for any of OpenCV's formats: per line, the
/// indentation levels enclosing it, its leading `- ` items, and the open `[`/`{` and XML
/// elements (quotes are not taken into account, which can only over-count).
fn nesting_depth(text: &[u8]) -> usize {
    let mut flow = 0usize;
    let mut xml = 0usize;
    let mut indents: Vec<usize> = Vec::new();
    let mut deepest = 0;
    for line in text.split(|b| *b == b'\n' || *b == b'\r') {
        let indent = line
            .iter()
            .take_while(|b| **b == b' ' || **b == b'\t')
            .count();
        let rest = &line[indent..];
        if rest.is_empty() {
            continue;
        }
        while indents.last().is_some_and(|&i| i >= indent) {
            indents.pop();
        }
        indents.push(indent);
        let dashes = rest
            .split(|b| *b == b' ' || *b == b'\t')
            .filter(|w| !w.is_empty())
            .take_while(|w| *w == b"-")
            .count();
        let mut open = flow + xml;
        for (k, &b) in rest.iter().enumerate() {
            match b {
                b'[' | b'{' => flow += 1,
                b']' | b'}' => flow = flow.saturating_sub(1),
                b'<' => match rest.get(k + 1) {
                    Some(b'/') => xml = xml.saturating_sub(1),
                    Some(c) if c.is_ascii_alphabetic() || *c == b'_' => xml += 1,
                    _ => {}
                },
                b'>' if k > 0 && rest[k - 1] == b'/' => xml = xml.saturating_sub(1),
                _ => {}
            }
            open = open.max(flow + xml);
        }
        deepest = deepest.max(indents.len() + dashes + open);
    }
    deepest
}

/// The `[` and `{` of a YAML text that are never closed (outside double and single
/// quotes; 0 for XML, whose elements [`nesting_depth`] bounds). OpenCV 4.6's YAML reader
/// never returns on some files with an unclosed flow collection (`%YAML:1.0`, a line
/// `---h:9`, then `{`: found by the property test below), so such a file, which no
/// calibration is, is turned away before OpenCV sees it.
fn unclosed_flow(text: &[u8]) -> usize {
    if text.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'<') {
        return 0;
    }
    let mut open = 0usize;
    for line in text.split(|b| *b == b'\n' || *b == b'\r') {
        let mut quote = None;
        for &b in line {
            match (quote, b) {
                (None, b'"' | b'\'') => quote = Some(b),
                (Some(q), c) if c == q => quote = None,
                (None, b'[' | b'{') => open += 1,
                (None, b']' | b'}') => open = open.saturating_sub(1),
                _ => {}
            }
        }
    }
    open
}

/// Writes `calib` to `path` (YAML, atomically).
pub fn write_calibration(path: &Path, calib: &Calibration) -> Result<(), CalibError> {
    let text = calibration_to_yaml(calib).map_err(|e| CalibError::cv("writing YAML", e))?;
    write_atomic(path, text.as_bytes()).map_err(|source| CalibError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The YAML text of a calibration.
pub fn calibration_to_yaml(calib: &Calibration) -> opencv::Result<String> {
    let mut fs = FileStorage::new(
        ".yaml",
        FileStorage_Mode::WRITE as i32 | FileStorage_Mode::MEMORY as i32,
        "",
    )?;
    fs.write_str("model", calib.model.name())?;
    fs.write_i32("image_width", calib.image_width as i32)?;
    fs.write_i32("image_height", calib.image_height as i32)?;
    fs.write_mat("camera_matrix", &mat_from_matrix3(&calib.camera_matrix)?)?;
    fs.write_mat(
        "distortion_coefficients",
        &mat_from_column(&calib.distortion)?,
    )?;
    fs.write_f64("avg_reprojection_error", calib.avg_reprojection_error)?;
    let errors: Vec<f64> = calib.per_view_errors.iter().map(|e| e.rms_px).collect();
    if !errors.is_empty() {
        fs.write_mat("per_view_reprojection_errors", &mat_from_column(&errors)?)?;
    }
    if let Some(b) = calib.board {
        fs.write_i32("board_width", b.cols as i32)?;
        fs.write_i32("board_height", b.rows as i32)?;
        fs.write_f64("square_size_mm", b.square_mm)?;
    }
    let field = calib.valid_field();
    fs.write_f64("valid_field_angle_deg", field.valid_angle_deg())?;
    fs.write_f64("monotonic_field_angle_deg", field.monotonic_angle_deg)?;
    if let Some(c) = &calib.coverage {
        fs.write_f64("coverage_field_angle_deg", c.field_angle_deg)?;
        if let Some(share) = c.half_diagonal_share {
            fs.write_f64("coverage_half_diagonal_share", share)?;
        }
        if let Some(grid) = &c.grid {
            fs.write_mat("coverage_grid", &Mat::from_slice_2d(grid)?)?;
        }
    }
    let used: Vector<String> = calib.views_used.iter().map(|s| s.as_str()).collect();
    fs.write_str_vec("views_used", &used)?;
    fs.start_write_struct("views_rejected", opencv::core::FileNode_SEQ, "")?;
    for r in &calib.views_rejected {
        fs.start_write_struct("", opencv::core::FileNode_MAP, "")?;
        fs.write_str("name", &r.name)?;
        fs.write_str("reason", &r.reason)?;
        fs.end_write_struct()?;
    }
    fs.end_write_struct()?;
    fs.release_and_get_string()
}

/// Reads a calibration written by [`write_calibration`] (or any OpenCV YAML with the
/// same keys; `model` defaults to pinhole for 5 coefficients and fisheye for 4).
pub fn read_calibration(path: &Path) -> Result<Calibration, CalibError> {
    let not = |why: &str| CalibError::NotACalibration {
        path: path.to_path_buf(),
        why: why.to_string(),
    };
    if !path.is_file() {
        return Err(CalibError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::new(
                std::io::ErrorKind::NotFound,
                "no such file: check the path, or make a calibration with `bendscope calibrate`",
            ),
        });
    }
    // OpenCV's parser would abort the process on a deeply nested file (see MAX_NESTING):
    // such a file is no calibration, and is turned away before OpenCV sees it.
    let size = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    if size > MAX_CALIBRATION_BYTES {
        return Err(not(&format!(
            "{size} bytes, more than a calibration file holds"
        )));
    }
    let bytes = std::fs::read(path).map_err(|source| CalibError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let depth = nesting_depth(&bytes);
    if depth > MAX_NESTING {
        return Err(not(&format!(
            "nested {depth} levels deep, a calibration file nests 3"
        )));
    }
    let unclosed = unclosed_flow(&bytes);
    if unclosed > 0 {
        return Err(not(&format!(
            "{unclosed} `[` or `{{` never closed (the file is cut short or damaged)"
        )));
    }
    // OpenCV's parser reports a malformed file with an exception; some files it simply
    // opens as empty.
    let fs = FileStorage::new(path, FileStorage_Mode::READ as i32, "")
        .map_err(|_| not("not an OpenCV YAML/XML file"))?;
    if !fs.is_opened().unwrap_or(false) {
        return Err(not("not an OpenCV YAML/XML file"));
    }
    let node = |key: &str| -> Result<FileNode, CalibError> {
        let n = fs.get(key).map_err(|_| not(&format!("no `{key}`")))?;
        if n.empty().unwrap_or(true) || n.is_none().unwrap_or(true) {
            return Err(not(&format!("no `{key}`")));
        }
        Ok(n)
    };
    let k_mat: Mat = node("camera_matrix")?
        .mat()
        .map_err(|_| not("`camera_matrix` is not a matrix"))?;
    let camera_matrix = matrix3_from_mat(&k_mat).map_err(|_| not("`camera_matrix` is not 3x3"))?;
    let d_mat: Mat = node("distortion_coefficients")?
        .mat()
        .map_err(|_| not("`distortion_coefficients` is not a matrix"))?;
    let distortion = values_from_mat(&d_mat).map_err(|_| not("bad `distortion_coefficients`"))?;
    let model = match fs.get("model").ok().and_then(|n| n.to_string().ok()) {
        Some(s) if !s.is_empty() => s.parse::<CameraModel>().map_err(|e| not(&e))?,
        _ if distortion.len() == 4 => CameraModel::Fisheye,
        _ => CameraModel::Pinhole,
    };
    if distortion.len() < model.coefficient_count() {
        return Err(not(&format!(
            "{} coefficients for the {} model",
            distortion.len(),
            model.name()
        )));
    }
    let int = |key: &str| -> Result<i32, CalibError> {
        node(key)?
            .to_i32()
            .map_err(|_| not(&format!("`{key}` is not a number")))
    };
    let image_width = int("image_width")?;
    let image_height = int("image_height")?;
    if image_width <= 0 || image_height <= 0 {
        return Err(not("non-positive image size"));
    }
    if !camera_matrix.iter().all(|v| v.is_finite()) || camera_matrix[(0, 0)] <= 0.0 {
        return Err(not("camera matrix is not finite and positive"));
    }
    let avg = fs
        .get("avg_reprojection_error")
        .and_then(|n| n.to_f64())
        .unwrap_or(f64::NAN);
    let names: Vec<String> = match fs.get("views_used") {
        Ok(n) if n.is_seq().unwrap_or(false) => (0..n.size().unwrap_or(0))
            .filter_map(|i| n.at(i as i32).ok().and_then(|e| e.to_string().ok()))
            .collect(),
        _ => vec![],
    };
    let errors: Vec<f64> = match fs.get("per_view_reprojection_errors") {
        Ok(n) if !n.empty().unwrap_or(true) => n
            .mat()
            .and_then(|m| values_from_mat(&m))
            .unwrap_or_default(),
        _ => vec![],
    };
    let per_view_errors = errors
        .iter()
        .enumerate()
        .map(|(i, e)| ViewError {
            name: names.get(i).cloned().unwrap_or_else(|| format!("view {i}")),
            rms_px: *e,
        })
        .collect();
    let mut views_rejected = Vec::new();
    if let Ok(n) = fs.get("views_rejected") {
        if n.is_seq().unwrap_or(false) {
            for i in 0..n.size().unwrap_or(0) {
                if let Ok(e) = n.at(i as i32) {
                    let get = |k: &str| e.get(k).and_then(|v| v.to_string()).unwrap_or_default();
                    views_rejected.push(RejectedView {
                        name: get("name"),
                        reason: get("reason"),
                    });
                }
            }
        }
    }
    let board = match (
        fs.get("board_width").and_then(|n| n.to_i32()),
        fs.get("board_height").and_then(|n| n.to_i32()),
        fs.get("square_size_mm").and_then(|n| n.to_f64()),
    ) {
        (Ok(c), Ok(r), Ok(s)) if c >= 2 && r >= 2 && s > 0.0 => {
            Board::new(c as u32, r as u32, s).ok()
        }
        _ => None,
    };
    let real = |key: &str| -> Option<f64> {
        fs.get(key)
            .ok()
            .filter(|n| n.is_real().unwrap_or(false) || n.is_int().unwrap_or(false))
            .and_then(|n| n.to_f64().ok())
            .filter(|v| v.is_finite())
    };
    let coverage = real("coverage_field_angle_deg")
        .filter(|a| *a > 0.0)
        .map(|field_angle_deg| Coverage {
            field_angle_deg,
            half_diagonal_share: real("coverage_half_diagonal_share").filter(|s| *s >= 0.0),
            grid: fs
                .get("coverage_grid")
                .ok()
                .filter(|n| !n.empty().unwrap_or(true))
                .and_then(|n| n.mat().ok())
                .filter(|m| m.rows() == 3 && m.cols() == 3)
                .and_then(|m| values_from_mat(&m).ok())
                .and_then(|v| {
                    let cell = |r: usize, c: usize| v.get(r * 3 + c).copied();
                    Some([
                        [cell(0, 0)?, cell(0, 1)?, cell(0, 2)?],
                        [cell(1, 0)?, cell(1, 1)?, cell(1, 2)?],
                        [cell(2, 0)?, cell(2, 1)?, cell(2, 2)?],
                    ])
                }),
        });
    Ok(Calibration {
        model,
        image_width: image_width as u32,
        image_height: image_height as u32,
        camera_matrix,
        distortion: distortion[..model.coefficient_count()].to_vec(),
        avg_reprojection_error: avg,
        per_view_errors,
        board,
        views_used: names,
        views_rejected,
        coverage,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;
    use proptest::prelude::*;

    fn sample() -> Calibration {
        Calibration {
            model: CameraModel::Fisheye,
            image_width: 640,
            image_height: 480,
            camera_matrix: Matrix3::new(300.0, 0.0, 320.0, 0.0, 300.0, 240.0, 0.0, 0.0, 1.0),
            distortion: vec![0.1, -0.02, 0.003, -0.0004],
            avg_reprojection_error: 0.2,
            per_view_errors: vec![],
            board: None,
            views_used: vec!["a.png".into()],
            views_rejected: vec![],
            coverage: None,
        }
    }

    /// Reads `bytes` as a calibration file; the outcome must be a calibration or an error.
    fn read_bytes(bytes: &[u8]) -> Result<Calibration, CalibError> {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("cam.yaml");
        std::fs::write(&p, bytes).unwrap();
        read_calibration(&p)
    }

    #[test]
    fn written_calibrations_read_back_and_garbage_is_an_error() {
        let yaml = calibration_to_yaml(&sample()).unwrap();
        let c = read_bytes(yaml.as_bytes()).unwrap();
        assert_eq!(c.camera_matrix, sample().camera_matrix);
        for bad in [
            &b""[..],
            b"\0\0\0",
            b"%YAML:1.0\n",
            b"camera_matrix: [",
            b"{{{{",
        ] {
            assert!(read_bytes(bad).is_err(), "{bad:?}");
        }
    }

    /// A fisheye calibration whose theta_d folds at 70 degrees (hand-made coefficients).
    fn folding_fisheye(coverage: Option<Coverage>) -> Calibration {
        Calibration {
            model: CameraModel::Fisheye,
            image_width: 1920,
            image_height: 1080,
            camera_matrix: Matrix3::new(860.0, 0.0, 962.6, 0.0, 862.4, 537.6, 0.0, 0.0, 1.0),
            distortion: vec![0.02, 0.03, -0.08, 0.01],
            avg_reprojection_error: 0.08,
            per_view_errors: vec![
                ViewError {
                    name: "a.jpg".into(),
                    rms_px: 0.07,
                },
                ViewError {
                    name: "b.jpg".into(),
                    rms_px: 0.09,
                },
            ],
            board: Some(Board::new(9, 6, 25.0).unwrap()),
            views_used: vec!["a.jpg".into(), "b.jpg".into()],
            views_rejected: vec![RejectedView {
                name: "c.jpg".into(),
                reason: "no 9x6 board found".into(),
            }],
            coverage,
        }
    }

    fn round_trip(c: &Calibration) -> (Calibration, String) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cam.yaml");
        write_calibration(&path, c).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        (read_calibration(&path).unwrap(), text)
    }

    #[test]
    fn the_coverage_survives_a_round_trip() {
        let c = folding_fisheye(Some(Coverage {
            field_angle_deg: 38.7,
            half_diagonal_share: Some(0.54),
            grid: Some([[0.1, 0.5, 0.2], [0.6, 1.0, 0.7], [0.3, 0.4, 0.0]]),
        }));
        let (back, text) = round_trip(&c);
        assert_eq!(back, c);
        assert_eq!(back.valid_field().valid_angle_deg(), 38.7);
        for key in [
            "valid_field_angle_deg: 3.87",
            "monotonic_field_angle_deg: 7.0",
            "coverage_field_angle_deg: 3.87",
            "coverage_half_diagonal_share: 5.4",
            "coverage_grid: !!opencv-matrix",
        ] {
            assert!(text.contains(key), "`{key}` missing in:\n{text}");
        }
    }

    #[test]
    fn deep_nesting_is_an_error_not_a_stack_overflow() {
        // Each of these kinds overflowed OpenCV's parser (and aborted the process) at
        // 10 000 to 20 000 levels on a 2 MB stack.
        let deep =
            |head: &str, open: &str| [head.as_bytes(), &open.repeat(100_000).into_bytes()].concat();
        let lines = |f: fn(usize) -> String| {
            [
                b"%YAML:1.0\na:\n".to_vec(),
                (0..3_000).map(f).collect::<String>().into_bytes(),
            ]
            .concat()
        };
        for bytes in [
            deep("%YAML:1.0\na: ", "["),
            deep("%YAML:1.0\na: ", "{ b: "),
            deep("", "{\"a\":"),
            deep("<?xml version=\"1.0\"?>\n<opencv_storage>", "<a>"),
            deep("%YAML:1.0\na:\n  ", "- "),
            lines(|i| format!("{}-\n", " ".repeat(i + 1))),
        ] {
            let e = read_bytes(&bytes).unwrap_err().to_string();
            assert!(e.contains("levels deep"), "{e}");
        }
        let yaml = calibration_to_yaml(&Calibration {
            views_rejected: vec![RejectedView {
                name: "b[1].png".into(),
                reason: "no board {found}".into(),
            }],
            ..sample()
        })
        .unwrap();
        assert!(nesting_depth(yaml.as_bytes()) <= 4, "{yaml}");
    }

    /// Pieces of OpenCV YAML, to reach its parser's corners.
    fn yamlish() -> impl Strategy<Value = Vec<u8>> {
        let tokens = prop::sample::select(
            [
                "%YAML:1.0\n",
                "---\n",
                "camera_matrix: ",
                "distortion_coefficients: ",
                "!!opencv-matrix\n",
                "   rows: 3\n",
                "   cols: 3\n",
                "   rows: 99999999\n",
                "   dt: d\n",
                "   dt: \"3i\"\n",
                "   data: [ ",
                "1., ",
                "0. ",
                "]\n",
                "[",
                "]",
                "{",
                "}",
                "- ",
                ": ",
                "\n",
                "  ",
                "image_width: 640\n",
                "model: pinhole\n",
                "!!binary |\n",
                "\"",
                "'",
                "1e999",
                "<?xml version=\"1.0\"?>\n",
                "<opencv_storage>",
                "&a ",
                "*a ",
                "...\n",
            ]
            .to_vec(),
        );
        prop::collection::vec(tokens, 0..40).prop_map(|t| t.concat().into_bytes())
    }

    /// Files on which OpenCV 4.6's YAML reader never returns (it spun for over 10
    /// minutes): refused at once, naming what is wrong.
    #[test]
    fn files_that_hang_opencvs_reader_are_refused_at_once() {
        let found = b"%YAML:1.0\n   dt: d\n   rows: 99999999\n'---\n<opencv_storage>image_width: 640\n[\n   rows: 99999999\n<opencv_storage>{\n&a ";
        for bytes in [&b"%YAML:1.\n ---h:9\n{\n"[..], &found[..]] {
            let started = std::time::Instant::now();
            let err = read_bytes(bytes).unwrap_err().to_string();
            assert!(err.contains("never closed"), "{err}");
            assert!(started.elapsed().as_secs_f64() < 1.0);
        }
        // Brackets inside quotes and closed ones are no reason to refuse.
        assert_eq!(unclosed_flow(b"a: \"[\"\nb: '{'\ndata: [ 1., 2. ]\n"), 0);
        assert_eq!(unclosed_flow(b"<?xml version=\"1.0\"?>\n<a>[</a>"), 0);
        assert_eq!(unclosed_flow(b"%YAML:1.0\n{\n[\n]\n"), 1);
        let written = calibration_to_yaml(&sample()).unwrap();
        assert_eq!(unclosed_flow(written.as_bytes()), 0);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        #[test]
        fn arbitrary_files_read_or_fail_without_aborting(
            bytes in prop_oneof![prop::collection::vec(any::<u8>(), 0..200), yamlish()]
        ) {
            let _ = read_bytes(&bytes);
        }

        #[test]
        fn damaged_calibrations_read_or_fail_without_aborting(
            cut in 0usize..2000,
            at in 0usize..2000,
            byte in any::<u8>(),
        ) {
            let mut yaml = calibration_to_yaml(&sample()).unwrap().into_bytes();
            if let Some(b) = yaml.get_mut(at) {
                *b = byte;
            }
            yaml.truncate(cut);
            let _ = read_bytes(&yaml);
        }
    }

    #[test]
    fn a_file_without_the_keys_gets_the_monotonic_limit_only() {
        let c = folding_fisheye(None);
        let (back, text) = round_trip(&c);
        assert_eq!(back, c);
        assert!(!text.contains("coverage"), "{text}");
        let field = back.valid_field();
        assert_eq!(field.coverage_angle_deg, None);
        assert!(field.monotonic_angle_deg > 69.0 && field.monotonic_angle_deg < 71.0);
        assert_eq!(field.valid_angle_deg(), field.monotonic_angle_deg);
    }

    #[test]
    fn hand_written_files_are_read_with_or_without_a_coverage() {
        let dir = tempfile::tempdir().unwrap();
        let base = "%YAML:1.0\n---\nimage_width: 1920\nimage_height: 1080\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 860., 0., 962.6, 0., 862.4, 537.6, 0., 0., 1. ]\ndistortion_coefficients: !!opencv-matrix\n   rows: 4\n   cols: 1\n   dt: d\n   data: [ 0.02, 0.03, -0.08, 0.01 ]\n";
        let old = dir.path().join("old.yaml");
        std::fs::write(&old, base).unwrap();
        let c = read_calibration(&old).unwrap();
        assert_eq!(c.model, CameraModel::Fisheye);
        assert_eq!(c.coverage, None);
        let f = c.valid_field();
        assert_eq!(f.valid_angle_deg(), f.monotonic_angle_deg);
        // Only the coverage angle, typed as an integer: read, the rest unknown.
        let narrowed = dir.path().join("narrowed.yaml");
        std::fs::write(&narrowed, format!("{base}coverage_field_angle_deg: 40\n")).unwrap();
        let c = read_calibration(&narrowed).unwrap();
        assert_eq!(
            c.coverage,
            Some(Coverage {
                field_angle_deg: 40.0,
                half_diagonal_share: None,
                grid: None,
            })
        );
        assert_eq!(c.valid_field().valid_angle_deg(), 40.0);
        // A nonsense coverage is ignored rather than trusted.
        let bad = dir.path().join("bad.yaml");
        std::fs::write(&bad, format!("{base}coverage_field_angle_deg: -3.\n")).unwrap();
        assert_eq!(read_calibration(&bad).unwrap().coverage, None);
    }
}
