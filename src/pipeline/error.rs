//! The error that stops a whole session ([`PipelineError`]), and how a write error
//! names its file.

use std::path::{Path, PathBuf};

use crate::calib::CalibError;
use crate::lock::LockError;
use crate::rgbd::RgbdError;
use crate::scale::ScaleError;
use crate::session::SessionError;

/// Errors that stop a whole session (the other sessions of a run go on).
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// Layout, manifest, pressure log or settings.
    #[error(transparent)]
    Session(#[from] SessionError),
    /// RGB-D layout or intrinsics.
    #[error(transparent)]
    Rgbd(#[from] RgbdError),
    /// Calibration.
    #[error(transparent)]
    Calib(#[from] CalibError),
    /// Scale photo.
    #[error("scale from {path}: {source}")]
    Scale {
        /// The photo.
        path: PathBuf,
        /// Cause.
        source: ScaleError,
    },
    /// What the session folder holds cannot be measured as it is.
    #[error("{path}: {why}")]
    Layout {
        /// File or folder.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
    /// The output folder is in use by another run, or cannot be locked.
    #[error(transparent)]
    Lock(#[from] LockError),
    /// The output folder's file system is full.
    #[error("no space left on {}: free space and rerun", dir.display())]
    NoSpace {
        /// The output folder.
        dir: PathBuf,
    },
    /// An output could not be written.
    #[error("{}: cannot write ({}): check the output folder's space and permissions", path.display(), crate::io::without_path(path, &source.to_string()))]
    Write {
        /// The file.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// Plots, JSON or the HTML report.
    #[error(transparent)]
    Report(#[from] crate::report::ReportError),
    /// A table.
    #[error(transparent)]
    Table(#[from] crate::table::TableError),
}

impl PipelineError {
    /// The one-line message for a session that failed with this error: the session's
    /// path first, once (most errors already start with it or a file inside it).
    pub fn for_session(&self, session: &Path) -> String {
        let msg = self.to_string();
        let path = session.display().to_string();
        if msg.starts_with(&path) {
            msg
        } else {
            format!("{path}: {msg}")
        }
    }

    /// True for [`PipelineError::NoSpace`]: the run stopped because the disk is full (the
    /// binary gives it its own exit code).
    pub fn is_no_space(&self) -> bool {
        matches!(self, PipelineError::NoSpace { .. })
    }
}

pub(super) fn write_err(path: &Path) -> impl Fn(std::io::Error) -> PipelineError + '_ {
    move |source| PipelineError::Write {
        path: path.to_path_buf(),
        source,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_write_error_names_its_file_once() {
        let path = Path::new("out/overlays/a.png");
        let os = std::io::Error::from_raw_os_error(21);
        let e = PipelineError::Write {
            path: path.to_path_buf(),
            source: crate::io::write_error(path, Path::new("out/overlays"), &os),
        };
        assert_eq!(
            e.to_string(),
            "out/overlays/a.png: cannot write (Is a directory (os error 21)): check the output folder's space and permissions"
        );
    }
}
