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

use std::path::Path;

use opencv::core::{FileNode, FileStorage, FileStorage_Mode, Mat, Vector};
use opencv::prelude::*;

use super::cv::{mat_from_column, mat_from_matrix3, matrix3_from_mat, values_from_mat};
use super::{Board, CalibError, Calibration, CameraModel, RejectedView, ViewError};
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
}
