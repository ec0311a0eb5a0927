//! One run per output folder: `OUT/.bendscope.lock`.
//!
//! Two runs writing one OUT at once would mix their tables and remove each other's
//! temporaries. A run takes an exclusive `flock` on `OUT/.bendscope.lock`
//! ([`std::fs::File::try_lock`]) before it writes anything and writes its process id
//! into it; a second run finds the lock taken and is refused at once, naming the pid.
//! The kernel releases the lock when its process ends in any way (even `kill -9`), so a
//! file left by a killed run does not block the next one. The file is removed when the
//! run ends; a run that locked a file removed meanwhile (by the run that held it) locks
//! the new one instead, so two runs never both hold a lock.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// Name of the lock file in an output folder.
pub const LOCK_FILE: &str = ".bendscope.lock";

/// Why an output folder could not be locked.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another run holds the lock.
    #[error("{out} is in use by another bendscope run{pid}: wait for it to finish, or give another -o folder", pid = pid.map(|p| format!(" (pid {p})")).unwrap_or_default())]
    Busy {
        /// The output folder.
        out: PathBuf,
        /// The other run's process id, when its lock file names it.
        pid: Option<u32>,
    },
    /// The lock file could not be made or locked.
    #[error("{path}: cannot lock ({source}): check the output folder's space and permissions")]
    Io {
        /// The lock file.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
}

/// The lock of an output folder, held until dropped (then its file is removed).
#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
    /// Keeps the lock: closing the file releases it.
    _file: File,
    /// False when the file system cannot lock (the run goes on unlocked).
    pub locked: bool,
}

impl OutputLock {
    /// Locks `out` (an existing folder) for this process, or says which run holds it.
    pub fn acquire(out: &Path) -> Result<Self, LockError> {
        let path = out.join(LOCK_FILE);
        let io = |source| LockError::Io {
            path: path.clone(),
            source,
        };
        loop {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(io)?;
            let locked = match file.try_lock() {
                Ok(()) => true,
                Err(TryLockError::WouldBlock) => {
                    let mut text = String::new();
                    let _ = file.read_to_string(&mut text);
                    return Err(LockError::Busy {
                        out: out.to_path_buf(),
                        pid: text.trim().parse().ok(),
                    });
                }
                Err(TryLockError::Error(e)) if e.kind() == std::io::ErrorKind::Unsupported => false,
                Err(TryLockError::Error(e)) => return Err(io(e)),
            };
            if locked && !same_file(&file, &path) {
                // The run that held it removed the file between our open and our lock.
                continue;
            }
            file.set_len(0).map_err(io)?;
            writeln!(file, "{}", std::process::id()).map_err(io)?;
            return Ok(Self {
                path,
                _file: file,
                locked,
            });
        }
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        // Removed while still locked; the file is closed (unlocked) afterwards.
        let _ = std::fs::remove_file(&self.path);
    }
}

/// True when `path` still names the file `file` is open on.
#[cfg(unix)]
fn same_file(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

/// True when `path` still names the file `file` is open on (always, off Unix).
#[cfg(not(unix))]
fn same_file(_file: &File, path: &Path) -> bool {
    path.is_file()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_is_refused_with_the_pid_until_the_first_is_dropped() {
        let d = tempfile::tempdir().unwrap();
        let first = OutputLock::acquire(d.path()).unwrap();
        assert!(first.locked);
        let text = std::fs::read_to_string(d.path().join(LOCK_FILE)).unwrap();
        assert_eq!(text.trim(), std::process::id().to_string());
        match OutputLock::acquire(d.path()) {
            Err(LockError::Busy { pid, .. }) => assert_eq!(pid, Some(std::process::id())),
            other => panic!("{other:?}"),
        }
        drop(first);
        assert!(!d.path().join(LOCK_FILE).exists(), "removed when released");
        let again = OutputLock::acquire(d.path()).unwrap();
        assert!(again.locked);
    }
}
