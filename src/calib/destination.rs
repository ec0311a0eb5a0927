//! Where `bendscope calibrate` writes without `-o`: `calibration/<name>.yaml`, named
//! after the camera's folder, and never over another camera's file unasked.
//!
//! Calibration photos usually sit in a session's `calib/` folder, so a folder called
//! `calib` (or `calibration`) names the file after the folder above it: `a/calib` and
//! `b/calib` become `calibration/a.yaml` and `calibration/b.yaml`, not one `calib.yaml`
//! the second camera would silently replace. An existing default file of another camera
//! (another model, frame size, focal length or principal point) is not replaced without
//! `--force`.

use std::path::{Path, PathBuf};

use super::file::read_calibration;
use super::{CalibError, Calibration};

/// Folder names that say "calibration photos", not which camera (compared ignoring case).
pub const GENERIC_FOLDER_NAMES: [&str; 2] = ["calib", "calibration"];

/// Two calibrations whose focal lengths differ by more than this share, or whose
/// principal points differ by more than this share of the frame size, are of different
/// cameras (a recalibration of one camera moves them by about 1%).
pub const SAME_CAMERA_SHARE: f64 = 0.05;

fn is_video(path: &Path) -> bool {
    path.extension()
        .map(|e| {
            super::sources::VIDEO_EXTENSIONS
                .contains(&e.to_string_lossy().to_ascii_lowercase().as_str())
        })
        .unwrap_or(false)
}

/// The name of `dir`, or of the folder above it when `dir` is a generic calibration
/// folder ([`GENERIC_FOLDER_NAMES`]).
fn camera_folder_name(dir: &Path) -> Option<String> {
    let dir = std::fs::canonicalize(dir).ok()?;
    let name = dir.file_name()?.to_string_lossy().into_owned();
    if GENERIC_FOLDER_NAMES
        .iter()
        .any(|g| g.eq_ignore_ascii_case(&name))
    {
        if let Some(above) = dir.parent().and_then(|p| p.file_name()) {
            return Some(above.to_string_lossy().into_owned());
        }
    }
    Some(name)
}

/// The default output for calibrating `first` (the first input path):
/// `calibration/<name>.yaml`, `name` the folder's name (a generic `calib/` folder: the
/// folder above it), a video's stem, or a photo's folder name (likewise).
pub fn default_calibration_path(first: &Path) -> PathBuf {
    let name = if first.is_dir() {
        camera_folder_name(first)
    } else if is_video(first) {
        first.file_stem().map(|n| n.to_string_lossy().into_owned())
    } else {
        std::fs::canonicalize(first)
            .ok()
            .and_then(|p| p.parent().and_then(camera_folder_name))
    };
    PathBuf::from("calibration").join(format!("{}.yaml", name.unwrap_or_else(|| "camera".into())))
}

/// A short description of a calibration's camera for messages.
fn describe(c: &Calibration) -> String {
    format!(
        "{} {}x{}, fx {:.1} px",
        c.model.name(),
        c.image_width,
        c.image_height,
        c.fx()
    )
}

/// Why `a` and `b` are calibrations of different cameras, `None` when they may be one.
pub fn other_camera(a: &Calibration, b: &Calibration) -> Option<String> {
    let rel = |x: f64, y: f64| (x / y - 1.0).abs();
    if a.model != b.model {
        return Some("another lens model".into());
    }
    if (a.image_width, a.image_height) != (b.image_width, b.image_height) {
        return Some("another frame size".into());
    }
    if rel(a.fx(), b.fx()) > SAME_CAMERA_SHARE || rel(a.fy(), b.fy()) > SAME_CAMERA_SHARE {
        return Some("another focal length".into());
    }
    let (w, h) = (a.image_width as f64, a.image_height as f64);
    if (a.cx() - b.cx()).abs() > SAME_CAMERA_SHARE * w
        || (a.cy() - b.cy()).abs() > SAME_CAMERA_SHARE * h
    {
        return Some("another principal point".into());
    }
    None
}

/// Refuses to write `calib` over `path` when `path` holds another camera's calibration
/// ([`other_camera`]) or a file that is no calibration; a missing file, or a
/// recalibration of the same camera, is fine.
pub fn check_replaces_same_camera(path: &Path, calib: &Calibration) -> Result<(), CalibError> {
    if !path.exists() {
        return Ok(());
    }
    let refuse = |why: String| CalibError::OtherCamera {
        path: path.to_path_buf(),
        why,
    };
    match read_calibration(path) {
        Ok(old) => match other_camera(&old, calib) {
            Some(what) => Err(refuse(format!(
                "another camera's calibration ({what}: {}; this one: {})",
                describe(&old),
                describe(calib)
            ))),
            None => Ok(()),
        },
        Err(_) => Err(refuse("a file that is not a calibration".into())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_calib_folder_is_named_after_the_folder_above_it() {
        let d = tempfile::tempdir().unwrap();
        for sub in ["bench-a/calib", "bench-b/Calibration", "gopro"] {
            std::fs::create_dir_all(d.path().join(sub)).unwrap();
        }
        std::fs::write(d.path().join("bench-a/calib/one.jpg"), b"x").unwrap();
        let name = |p: &str| default_calibration_path(&d.path().join(p));
        assert_eq!(name("bench-a/calib"), Path::new("calibration/bench-a.yaml"));
        assert_eq!(
            name("bench-a/calib/one.jpg"),
            Path::new("calibration/bench-a.yaml")
        );
        assert_eq!(
            name("bench-b/Calibration"),
            Path::new("calibration/bench-b.yaml")
        );
        assert_eq!(name("gopro"), Path::new("calibration/gopro.yaml"));
        assert_eq!(name("GX010001.MP4"), Path::new("calibration/GX010001.yaml"));
    }
}
