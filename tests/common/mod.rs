//! Shared helpers for integration tests: run the real binary, read its outputs.
#![allow(dead_code)]

pub mod calculix;
pub mod cvscene;
pub mod mesh;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A fixture path.
pub fn fixture(rel: &str) -> PathBuf {
    root().join("fixtures").join(rel)
}

/// The `bendscope` binary under test: `$BENDSCOPE_BIN` when set (several worktrees
/// sharing one target dir overwrite each other's `target/debug/bendscope`; point it at
/// this tree's `target/debug/deps/bendscope-<hash>`), else cargo's.
pub fn exe() -> PathBuf {
    std::env::var_os("BENDSCOPE_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_bendscope")))
}

/// Runs `bendscope` with `args` in `cwd`.
pub fn bendscope(cwd: &Path, args: &[&str]) -> Output {
    Command::new(exe())
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the bendscope binary runs")
}

/// Output with a readable dump for assertion messages.
pub struct Run {
    /// Exit code (-1 when killed).
    pub code: i32,
    /// Standard output.
    pub stdout: String,
    /// Standard error.
    pub stderr: String,
}

impl Run {
    /// Runs `bendscope` with `args` in `cwd`.
    pub fn new(cwd: &Path, args: &[&str]) -> Run {
        let o = bendscope(cwd, args);
        Run {
            code: o.status.code().unwrap_or(-1),
            stdout: String::from_utf8_lossy(&o.stdout).into_owned(),
            stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
        }
    }

    /// Asserts a bad-input failure: exit code 2, exactly one line on stderr that
    /// contains every `needle`, no panic.
    pub fn assert_bad_input(&self, needles: &[&str]) {
        assert_eq!(self.code, 2, "expected exit 2: {self}");
        assert!(!self.stderr.contains("panicked"), "panic: {self}");
        let lines: Vec<&str> = self
            .stderr
            .lines()
            .filter(|l| !l.trim().is_empty())
            .collect();
        assert_eq!(lines.len(), 1, "expected one line on stderr: {self}");
        for n in needles {
            assert!(self.stderr.contains(n), "stderr lacks `{n}`: {self}");
        }
    }
}

impl std::fmt::Display for Run {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "exit {}\n--- stdout\n{}--- stderr\n{}",
            self.code, self.stdout, self.stderr
        )
    }
}

/// A CSV as (header, rows of cells), read through the library's table layer
/// ([`bendscope::table::Table`]: quoted fields kept whole, blank lines skipped).
pub fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let table = bendscope::table::Table::read(path).unwrap_or_else(|e| panic!("{e}"));
    let header = table.columns().to_vec();
    let rows = (0..table.len())
        .map(|r| {
            (0..header.len())
                .map(|c| table.cell(r, c).to_string())
                .collect()
        })
        .collect();
    (header, rows)
}

/// Index of column `name`.
pub fn col(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
}

/// Copies a folder (files and sub-folders), leaving out `bendscope-out`.
pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let p = e.path();
        if p.file_name().unwrap() == "bendscope-out" {
            continue;
        }
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).unwrap();
        }
    }
}

/// The fields of `/proc/PID/stat` after the command name (state first), or `None`
/// when there is no such process.
fn proc_stat(pid: u32) -> Option<(String, Vec<String>)> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let (open, close) = (stat.find('(')?, stat.rfind(')')?);
    let comm = stat[open + 1..close].to_string();
    let fields = stat[close + 1..]
        .split_whitespace()
        .map(String::from)
        .collect();
    Some((comm, fields))
}

/// The processes whose parent is `parent`, with their command names (from /proc).
pub fn children_of(parent: u32) -> Vec<(u32, String)> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return out;
    };
    for e in entries.flatten() {
        let Ok(pid) = e.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        if let Some((comm, fields)) = proc_stat(pid) {
            if fields.get(1).is_some_and(|p| *p == parent.to_string()) {
                out.push((pid, comm));
            }
        }
    }
    out
}

/// True while process `pid` runs (a zombie, exited but not reaped, does not).
pub fn running(pid: u32) -> bool {
    proc_stat(pid).is_some_and(|(_, f)| f.first().is_some_and(|s| s != "Z" && s != "X"))
}

/// Kills process `pid` when dropped (a test's stray child must not outlive it).
pub struct KillOnDrop(pub u32);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        if running(self.0) {
            let _ = Command::new("kill")
                .args(["-KILL", &self.0.to_string()])
                .status();
        }
    }
}

/// A tmpfs mounted on `dir` (created), unmounted when dropped. Mounting needs root: a
/// test that uses it is `#[ignore]`d with that reason, and a mount that fails panics (a
/// test that cannot set itself up must not pass).
pub struct Tmpfs(PathBuf);

impl Tmpfs {
    /// A writable tmpfs of `bytes`.
    pub fn mount(dir: &Path, bytes: u64) -> Tmpfs {
        Self::mount_with(dir, &format!("size={bytes}"))
    }

    /// A read-only (empty) tmpfs.
    pub fn mount_read_only(dir: &Path) -> Tmpfs {
        Self::mount_with(dir, "ro,size=65536")
    }

    fn mount_with(dir: &Path, options: &str) -> Tmpfs {
        std::fs::create_dir_all(dir).unwrap();
        let status = Command::new("mount")
            .args(["-t", "tmpfs", "-o", options, "tmpfs"])
            .arg(dir)
            .status();
        assert!(
            status.as_ref().is_ok_and(|s| s.success()),
            "mount -t tmpfs -o {options} on {} failed ({status:?}): this test needs root",
            dir.display()
        );
        Tmpfs(dir.to_path_buf())
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg("-l").arg(&self.0).status();
    }
}
