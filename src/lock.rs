//! One run per output folder: `OUT/.bendscope.lock`.
//!
//! Two runs writing one OUT at once would mix their tables and remove each other's
//! temporaries. Every command that writes a folder calls [`lock_output`] before its
//! work: it refuses a file in the folder's place, creates the folder, locks it and, in
//! writing the lock file, tests that the folder takes a write (read-only, permission,
//! full disk are found before minutes of work, not after). A run takes an exclusive `flock` on `OUT/.bendscope.lock`
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
    /// The output path names a file, not a folder.
    #[error("{out} is a file, not a folder: give -o a folder for the results")]
    NotAFolder {
        /// The output path.
        out: PathBuf,
    },
    /// The folder or its lock file could not be made, written or locked.
    #[error("{}", crate::io::write_advice(out, error))]
    Io {
        /// The output folder.
        out: PathBuf,
        /// Cause (not a `source`: the message says it in words already).
        error: std::io::Error,
    },
}

impl LockError {
    /// True when the folder's disk is full (exit code 4, not 2).
    pub fn is_no_space(&self) -> bool {
        matches!(self, LockError::Io { error, .. } if crate::io::is_storage_full(error))
    }
}

/// Prepares the output folder `out` of a command: refuses a file in its place, creates
/// it, and locks it ([`OutputLock::acquire`], which writes the lock file: the test that
/// the folder takes a write). Hold the lock until the last output is written. A folder
/// made here and still empty when the lock is dropped (the run refused its input) is
/// removed with the lock file.
pub fn lock_output(out: &Path) -> Result<OutputLock, LockError> {
    if out.exists() && !out.is_dir() {
        return Err(LockError::NotAFolder {
            out: out.to_path_buf(),
        });
    }
    let made = !out.exists();
    std::fs::create_dir_all(out).map_err(|error| LockError::Io {
        out: out.to_path_buf(),
        error,
    })?;
    let mut lock = OutputLock::acquire(out)?;
    lock.made = made.then(|| out.to_path_buf());
    Ok(lock)
}

/// The lock of an output folder, held until dropped (then its file is removed).
#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
    /// Keeps the lock: closing the file releases it.
    _file: File,
    /// False when the file system cannot lock (the run goes on unlocked).
    pub locked: bool,
    /// The folder, when [`lock_output`] made it: removed on drop if left empty.
    made: Option<PathBuf>,
}

impl OutputLock {
    /// Locks `out` (an existing folder) for this process, or says which run holds it.
    pub fn acquire(out: &Path) -> Result<Self, LockError> {
        let path = out.join(LOCK_FILE);
        let io = |error| LockError::Io {
            out: out.to_path_buf(),
            error,
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
            // Flushed to the disk: a full disk fails here, before the run's work.
            writeln!(file, "{}", std::process::id()).map_err(io)?;
            file.sync_all().map_err(io)?;
            return Ok(Self {
                path,
                _file: file,
                locked,
                made: None,
            });
        }
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        // Removed while still locked; the file is closed (unlocked) afterwards.
        let _ = std::fs::remove_file(&self.path);
        if let Some(dir) = &self.made {
            // Fails, as it should, when the run wrote anything there.
            let _ = std::fs::remove_dir(dir);
        }
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

    #[test]
    fn lock_output_creates_the_folder_and_refuses_a_file_in_its_place() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("a/b");
        let lock = lock_output(&out).unwrap();
        assert!(out.join(LOCK_FILE).is_file());
        match lock_output(&out) {
            Err(e @ LockError::Busy { .. }) => {
                let text = e.to_string();
                assert!(text.starts_with(&out.display().to_string()), "{text}");
                assert!(
                    text.contains(&format!("(pid {})", std::process::id())),
                    "{text}"
                );
            }
            other => panic!("{other:?}"),
        }
        drop(lock);
        assert!(!out.exists(), "made here and left empty: removed");
        let kept = lock_output(&out).unwrap();
        std::fs::write(out.join("steps.csv"), b"x").unwrap();
        drop(kept);
        assert!(out.join("steps.csv").is_file(), "a folder written to stays");
        assert!(!out.join(LOCK_FILE).exists());
        let file = d.path().join("f");
        std::fs::write(&file, b"x").unwrap();
        let e = lock_output(&file).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "{} is a file, not a folder: give -o a folder for the results",
                file.display()
            )
        );
        assert!(!e.is_no_space());
    }

    #[test]
    fn a_full_or_read_only_folder_says_what_to_do() {
        let out = PathBuf::from("runs/x");
        let e = |error| LockError::Io {
            out: out.clone(),
            error,
        };
        let full = e(std::io::Error::from_raw_os_error(28));
        assert!(full.is_no_space());
        assert_eq!(
            full.to_string(),
            "no space left on the disk of runs/x: free space and rerun"
        );
        let ro = e(std::io::Error::from_raw_os_error(30));
        assert!(!ro.is_no_space());
        assert_eq!(ro.to_string(), "runs/x is read-only: give another -o");
    }
}
