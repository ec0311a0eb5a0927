//! Output folders of every command (issue 38): one run per folder at a time (the lock
//! `OUT/.bendscope.lock`), and a folder that is in use, read-only or on a full disk
//! refused before any work, in one line that names it and says what to do.

mod common;

use std::fs;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use bendscope::lock::{OutputLock, LOCK_FILE};
use common::{fixture, root, Run, Tmpfs};

/// A refusal comes before any work: the binary's start-up and a few file operations
/// (loose, for a loaded machine; the work refused takes seconds to minutes).
const REFUSED_WITHIN: Duration = Duration::from_secs(3);

/// Every command that writes a folder, with inputs that bring it to its lock, writing
/// into `out` (relative to the test folder `d`, where the inputs are made).
fn folder_commands(d: &Path, out: &str) -> Vec<(&'static str, Vec<String>)> {
    // A process-shaped measurement for fit-model: three pressures.
    fs::create_dir_all(d.join("measured")).unwrap();
    fs::write(
        d.join("measured/per_video.csv"),
        "file,pressure_kpa,radius_mm,curvature_per_m,frames_used,status\n\
         GX010001.MP4,20,300,3.3,30,ok\nGX010002.MP4,45,120,8.3,30,ok\nGX010003.MP4,70,60,16.7,30,ok\n",
    )
    .unwrap();
    let plans = root().join("examples/plans");
    let path = |p: PathBuf| p.to_string_lossy().into_owned();
    let table: [(&str, Vec<String>); 13] = [
        (
            "simulate",
            strings(&["simulate", "--mesh-size", "4", "--pressures", "10"]),
        ),
        (
            "simulate --model analytic",
            strings(&["simulate", "--model", "analytic"]),
        ),
        (
            "sweep",
            vec!["sweep".into(), path(plans.join("two-factor.toml"))],
        ),
        ("sweep collect", strings(&["sweep", "collect", out])),
        (
            "fit-model",
            strings(&[
                "fit-model",
                "--measured",
                "measured",
                "--free",
                "material.scale",
                "--mesh-size",
                "4",
            ]),
        ),
        (
            "optimize",
            vec![
                "optimize".into(),
                path(plans.join("optimize-curvature.toml")),
            ],
        ),
        (
            "render",
            strings(&["render", "--fem", "nowhere", "--gopro-like", "640x480"]),
        ),
        ("demo", strings(&["demo"])),
        (
            "control",
            strings(&[
                "control", "--plant", "linear", "--step", "50", "--kp", "1", "--ki", "0.1",
            ]),
        ),
        (
            "compare",
            strings(&["compare", "--measured", "nowhere", "--fem", "nowhere"]),
        ),
        ("material fit", strings(&["material", "fit", "tensile.csv"])),
        ("acquire", strings(&["acquire", "protocol.toml"])),
        (
            "process",
            vec!["process".into(), path(fixture("sessions/example"))],
        ),
    ];
    table
        .into_iter()
        .map(|(name, mut args)| {
            if name != "sweep collect" {
                args.extend(["-o".to_string(), out.to_string()]);
            }
            (name, args)
        })
        .collect()
}

fn strings(a: &[&str]) -> Vec<String> {
    a.iter().map(|s| s.to_string()).collect()
}

fn run(d: &Path, args: &[String]) -> (Run, Duration) {
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let started = Instant::now();
    let run = Run::new(d, &args);
    (run, started.elapsed())
}

fn names_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn every_command_that_writes_a_folder_is_refused_at_once_while_another_run_holds_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("out");
    fs::create_dir_all(&out).unwrap();
    // This test process plays the other run.
    let held = OutputLock::acquire(&out).unwrap();
    assert!(held.locked, "the file system locks");
    let pid = format!("(pid {})", std::process::id());
    for (name, args) in folder_commands(d, "out") {
        let (run, took) = run(d, &args);
        assert_eq!(run.code, 2, "{name}: {run}");
        let lines: Vec<&str> = run
            .stderr
            .lines()
            .filter(|l| !l.trim().is_empty())
            .collect();
        assert_eq!(lines.len(), 1, "{name}: one line: {run}");
        assert!(
            lines[0].contains("out is in use by another bendscope run")
                && lines[0].contains(&pid)
                && lines[0].contains("give another -o folder"),
            "{name}: {run}"
        );
        assert!(took < REFUSED_WITHIN, "{name}: refused after {took:?}");
        assert_eq!(names_in(&out), [LOCK_FILE], "{name}: nothing written");
    }
    drop(held);
    // Released: a quick command runs and removes its lock file at its end.
    let (run, _) = run(
        d,
        &strings(&["simulate", "--model", "analytic", "-o", "out"]),
    );
    assert_eq!(run.code, 0, "{run}");
    assert!(out.join("steps.csv").is_file());
    assert!(!out.join(LOCK_FILE).exists());
}

/// Every command that writes, with `-o` under `parent` (a folder for the folder
/// commands; a file for those that write one file).
fn writing_commands(d: &Path, parent: &str) -> Vec<(&'static str, Vec<String>)> {
    let folder = format!("{parent}/x");
    let mut v = folder_commands(d, &folder);
    let file = |f: &str| format!("{parent}/{f}");
    v.push((
        "calibrate",
        strings(&["calibrate", "nowhere", "-o", &file("cal.yaml")]),
    ));
    v.push((
        "inspect",
        strings(&["inspect", "nowhere", "-o", &file("inspect.html")]),
    ));
    v.push((
        "surrogate fit",
        strings(&[
            "surrogate",
            "fit",
            "nowhere.csv",
            "--inputs",
            "geometry.f",
            "--output",
            "radius_mm@100",
            "-o",
            &file("model.json"),
        ]),
    ));
    v
}

#[test]
#[ignore = "needs root for a tmpfs mount: cargo test --test outputs -- --ignored, as root"]
fn a_read_only_output_is_refused_before_the_work_naming_the_folder_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let _ro = Tmpfs::mount_read_only(&d.join("ro"));
    for (name, args) in writing_commands(d, "ro") {
        let (run, took) = run(d, &args);
        assert_eq!(run.code, 2, "{name}: {run}");
        let lines: Vec<&str> = run
            .stderr
            .lines()
            .filter(|l| !l.trim().is_empty())
            .collect();
        assert_eq!(lines.len(), 1, "{name}: one line: {run}");
        let line = lines[0];
        assert!(
            line.contains("is read-only: give another -o"),
            "{name}: {run}"
        );
        assert_eq!(
            line.matches("read-only").count(),
            1,
            "{name}: said once: {run}"
        );
        for refused in [".bendscope-", "camera model", "os error", "at path"] {
            assert!(!line.contains(refused), "{name}: `{refused}`: {run}");
        }
        assert!(took < REFUSED_WITHIN, "{name}: refused after {took:?}");
    }
}

#[test]
#[ignore = "needs root for a tmpfs mount: cargo test --test outputs -- --ignored, as root"]
fn a_full_disk_is_found_before_the_work_and_exits_4() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let full = d.join("full");
    let _mount = Tmpfs::mount(&full, 64 * 1024);
    // Fill it: write until the disk says no.
    let mut filler = fs::File::create(full.join("filler")).unwrap();
    let block = vec![0u8; 4096];
    loop {
        use std::io::Write as _;
        if filler
            .write_all(&block)
            .and_then(|()| filler.sync_all())
            .is_err()
        {
            break;
        }
    }
    for (name, args) in writing_commands(d, "full") {
        let (run, took) = run(d, &args);
        assert_eq!(run.code, 4, "{name}: {run}");
        let lines: Vec<&str> = run
            .stderr
            .lines()
            .filter(|l| !l.trim().is_empty())
            .collect();
        assert_eq!(lines.len(), 1, "{name}: one line: {run}");
        // process words it its own way: `no space left on full/x: free space and rerun`.
        assert!(
            (lines[0].contains("no space left on the disk of full")
                || lines[0].contains("no space left on full/x"))
                && lines[0].contains("free space and rerun"),
            "{name}: {run}"
        );
        assert!(!lines[0].contains(".bendscope-"), "{name}: {run}");
        assert!(took < REFUSED_WITHIN, "{name}: refused after {took:?}");
    }
}
