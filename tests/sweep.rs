//! `bendscope sweep` end to end on a coarse mesh: the GNU parallel path for real (jobs.txt
//! run by `parallel` from another folder, then `sweep collect`), the local pool with a
//! failed point and resume, the Slurm script, and `simulate --model analytic`.

mod common;

use std::path::Path;
use std::process::Command;

use common::{col, read_csv, Run};

/// Two factors (a length and a boolean), two points, two kept pressures, a 6 mm mesh: a
/// few seconds per point.
const PLAN: &str = r#"
pressures_kpa = [20, 40]
mesh_size_mm = 6
analytic = true
[design]
kind = "factorial"
[[factor]]
name = "geometry.f"
levels = [5, 6.5]
[[factor]]
name = "load.gravity"
levels = [false]
[cluster]
memory_mb = 1500
time_limit = "00:20:00"
max_concurrent = 2
"#;

const FEM: [&str; 7] = [
    "radius_mm",
    "curvature_per_m",
    "bending_angle_deg",
    "max_principal_stress_mpa",
    "safety_factor",
    "bottom_elongation_pct",
    "cavity_volume_mm3",
];

fn expected_header() -> Vec<String> {
    let mut h: Vec<String> = ["id", "status", "seconds", "geometry.f", "load.gravity"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    for p in ["20", "40"] {
        h.extend(FEM.iter().map(|c| format!("{c}@{p}")));
    }
    for p in ["20", "40"] {
        h.push(format!("bending_angle_deg_analytic@{p}"));
        h.push(format!("radius_mm_analytic@{p}"));
    }
    h.push("height_mm".into());
    h
}

fn write_plan(dir: &Path, text: &str) -> std::path::PathBuf {
    let p = dir.join("plan.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// The steps.csv row of `pressure` (as written) in `run`, cells by column name.
fn steps_row(run: &Path, pressure: &str) -> Vec<(String, String)> {
    let (h, rows) = read_csv(&run.join("steps.csv"));
    let p: f64 = pressure.parse().unwrap();
    let row = rows
        .iter()
        .find(|r| (r[0].parse::<f64>().unwrap() - p).abs() < 1e-9)
        .unwrap_or_else(|| panic!("no {pressure} kPa in {}", run.display()));
    h.into_iter().zip(row.iter().cloned()).collect()
}

#[test]
fn gnu_parallel_runs_the_emitted_jobs_and_collect_gives_simulate_numbers() {
    let tmp = tempfile::tempdir().unwrap();
    let plan = write_plan(tmp.path(), PLAN);
    let out = tmp.path().join("sw");
    let r = Run::new(
        tmp.path(),
        &[
            "sweep",
            plan.to_str().unwrap(),
            "-o",
            "sw",
            "--emit",
            "parallel",
        ],
    );
    assert_eq!(r.code, 0, "{r}");
    let jobs = std::fs::read_to_string(out.join("jobs.txt")).unwrap();
    let lines: Vec<&str> = jobs.lines().collect();
    assert_eq!(lines.len(), 2, "{jobs}");
    let abs_out = out.canonicalize().unwrap();
    assert!(
        lines[0].contains(&format!("'{}'", abs_out.display())) && lines[0].ends_with("'p001'"),
        "{jobs}"
    );
    // Nothing ran: no point has a status yet.
    assert!(!out.join("runs/p001/status.json").exists());
    // GNU parallel from another working directory, 2 at a time.
    let elsewhere = tempfile::tempdir().unwrap();
    let jobs_file = std::fs::File::open(out.join("jobs.txt")).unwrap();
    let p = Command::new("parallel")
        .args(["--will-cite", "-j", "2"])
        .stdin(jobs_file)
        .current_dir(elsewhere.path())
        .output()
        .expect("GNU parallel is installed (scripts/setup.sh installs it)");
    assert!(
        p.status.success(),
        "parallel failed: {}\n{}",
        String::from_utf8_lossy(&p.stdout),
        String::from_utf8_lossy(&p.stderr)
    );
    let r = Run::new(tmp.path(), &["sweep", "collect", "sw"]);
    assert_eq!(r.code, 0, "{r}");
    assert!(r.stdout.contains("2 ok"), "{r}");
    let (h, rows) = read_csv(&out.join("designs.csv"));
    assert_eq!(h, expected_header());
    assert_eq!(rows.len(), 2);
    let ids: Vec<&str> = rows.iter().map(|r| r[0].as_str()).collect();
    assert_eq!(ids, ["p001", "p002"]);
    let f: Vec<&str> = rows
        .iter()
        .map(|r| r[col(&h, "geometry.f")].as_str())
        .collect();
    assert_eq!(f, ["5", "6.5"]);
    let g: Vec<&str> = rows
        .iter()
        .map(|r| r[col(&h, "load.gravity")].as_str())
        .collect();
    assert_eq!(g, ["false", "false"]);
    for r in &rows {
        assert_eq!(r[1], "ok");
        assert!(r[2].parse::<f64>().unwrap() > 0.0);
    }
    // height a = f + m + n + top_wall = f + 2 + 12 + 3.5.
    assert_eq!(rows[1][col(&h, "height_mm")], "24.0000");
    // Every point's numbers are exactly those of `bendscope simulate` on its config.
    let sim = tmp.path().join("sim");
    let cfg = out.join("runs/p002/config.toml");
    let s = Run::new(
        tmp.path(),
        &[
            "simulate",
            "--config",
            cfg.to_str().unwrap(),
            "--no-vtu",
            "-o",
            "sim",
        ],
    );
    assert_eq!(s.code, 0, "{s}");
    for p in ["20", "40"] {
        let cells = steps_row(&sim, p);
        for name in FEM {
            let want = &cells.iter().find(|(c, _)| c == name).unwrap().1;
            let got = &rows[1][col(&h, &format!("{name}@{p}"))];
            assert_eq!(got, want, "{name}@{p}");
        }
    }
    // Bending grows with pressure; the thinner bottom bends more.
    let angle = |r: &Vec<String>, p: &str| -> f64 {
        r[col(&h, &format!("bending_angle_deg@{p}"))]
            .parse()
            .unwrap()
    };
    assert!(rows.iter().all(|r| angle(r, "40") > angle(r, "20")));
    assert!(angle(&rows[0], "40") > angle(&rows[1], "40"), "{rows:?}");
    // The analytic model ignores the bottom layer and gravity: equal for equal chambers.
    let a = |r: &Vec<String>| r[col(&h, "bending_angle_deg_analytic@40")].clone();
    assert!(rows.iter().all(|r| a(r) == a(&rows[0])), "{rows:?}");
}

#[test]
fn the_local_pool_records_a_failed_point_and_resume_skips_finished_points() {
    let tmp = tempfile::tempdir().unwrap();
    // e = 12 mm does not fit the 11.5 mm chambers: that point is invalid, the other runs.
    let text = PLAN.replace("levels = [5, 6.5]", "levels = [6.5]").replace(
        "name = \"load.gravity\"\nlevels = [false]",
        "name = \"geometry.e\"\nlevels = [5, 12]",
    );
    let plan = write_plan(tmp.path(), &text);
    let r = Run::new(
        tmp.path(),
        &["sweep", plan.to_str().unwrap(), "-o", "sw", "--jobs", "2"],
    );
    assert_eq!(r.code, 1, "partial: {r}");
    assert!(
        r.stdout.contains("1 ok") && r.stdout.contains("1 failed"),
        "{r}"
    );
    let out = tmp.path().join("sw");
    let (h, rows) = read_csv(&out.join("designs.csv"));
    assert_eq!(rows[0][1], "ok");
    assert_eq!(rows[1][1], "failed");
    assert_eq!(rows[1][col(&h, "geometry.e")], "12");
    assert_eq!(rows[1][col(&h, "radius_mm@40")], "");
    let radius: f64 = rows[0][col(&h, "radius_mm@40")].parse().unwrap();
    assert!(radius.is_finite() && radius > 0.0);
    let (fh, frows) = read_csv(&out.join("failures.csv"));
    assert_eq!(frows.len(), 1);
    assert_eq!(frows[0][0], "p002");
    assert!(
        frows[0][col(&fh, "reason")].contains("cavity length"),
        "{frows:?}"
    );
    for f in [
        "config.toml",
        "steps.csv",
        "summary.json",
        "log",
        "status.json",
    ] {
        assert!(out.join("runs/p001").join(f).exists(), "{f}");
    }
    // Resume: the finished point is not run again (its files stay as they were).
    let status = out.join("runs/p001/status.json");
    let before = std::fs::metadata(&status).unwrap().modified().unwrap();
    let r = Run::new(tmp.path(), &["sweep", plan.to_str().unwrap(), "-o", "sw"]);
    assert_eq!(r.code, 1, "{r}");
    assert!(
        r.stderr.contains("0 to run, 1 finished earlier, 1 invalid"),
        "{r}"
    );
    assert_eq!(
        std::fs::metadata(&status).unwrap().modified().unwrap(),
        before
    );
    let (_, again) = read_csv(&out.join("designs.csv"));
    assert_eq!(again[0][3..], rows[0][3..], "same numbers after resume");
}

#[test]
fn slurm_script_is_a_job_array_with_the_plans_resources() {
    let tmp = tempfile::tempdir().unwrap();
    let plan = write_plan(tmp.path(), PLAN);
    let r = Run::new(
        tmp.path(),
        &[
            "sweep",
            plan.to_str().unwrap(),
            "-o",
            "sw",
            "--emit",
            "slurm",
        ],
    );
    assert_eq!(r.code, 0, "{r}");
    let s = std::fs::read_to_string(tmp.path().join("sw/sweep.sbatch")).unwrap();
    for line in [
        "#SBATCH --array=0-1%2",
        "#SBATCH --mem=1500M",
        "#SBATCH --time=00:20:00",
        "#SBATCH --cpus-per-task=1",
        "ids=('p001' 'p002')",
    ] {
        assert!(s.lines().any(|l| l == line), "no `{line}` in\n{s}");
    }
    assert!(s.contains("sweep run-point"), "{s}");
    let r = Run::new(tmp.path(), &["sweep", "collect", "sw"]);
    assert_eq!(r.code, 3, "nothing ran yet: {r}");
    assert!(r.stdout.contains("2 not finished"), "{r}");
}

#[test]
fn bad_plans_are_one_line_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let plan = write_plan(tmp.path(), &PLAN.replace("geometry.f", "geometry.foo"));
    Run::new(tmp.path(), &["sweep", plan.to_str().unwrap(), "-o", "sw"])
        .assert_bad_input(&["plan", "foo"]);
    Run::new(tmp.path(), &["sweep", "collect", "nowhere"]).assert_bad_input(&["sweep.json"]);
}

#[test]
fn simulate_model_analytic_writes_the_ramp_instantly() {
    let tmp = tempfile::tempdir().unwrap();
    let r = Run::new(
        tmp.path(),
        &[
            "simulate",
            "--model",
            "analytic",
            "--pressures",
            "0:100:50",
            "-o",
            "an",
        ],
    );
    assert_eq!(r.code, 0, "{r}");
    assert!(r.stdout.contains(" ms"), "{r}");
    let (h, rows) = read_csv(&tmp.path().join("an/steps.csv"));
    assert_eq!(rows.len(), 3);
    let angle: f64 = rows[2][col(&h, "bending_angle_deg")].parse().unwrap();
    // Reference actuator at 100 kPa: sigma = 0.1 * 11 * 12 / (39 * 2) MPa; the stretch
    // inverts the Yeoh uniaxial law; theta = 18 atan(5 eps / 24).
    let eps: f64 = rows[2][col(&h, "axial_strain")].parse().unwrap();
    let theta = (18.0 * (5.0 * eps / 24.0).atan()).to_degrees();
    assert!((angle - theta).abs() < 1e-3, "{angle} vs {theta}");
    let lambda = 1.0 + eps;
    let i1 = lambda * lambda + 2.0 / lambda;
    let (c1, c2, c3) = (0.10744, 0.0601, 0.000302);
    let w1 = c1 + 2.0 * c2 * (i1 - 3.0) + 3.0 * c3 * (i1 - 3.0).powi(2);
    let nominal = 2.0 * (lambda - lambda.powi(-2)) * w1;
    assert!((nominal - 13.2 / 78.0).abs() < 1e-5, "{nominal}");
    assert_eq!(rows[0][col(&h, "bending_angle_deg")], "0.0000");
}

#[test]
fn sigterm_stops_the_running_points_records_them_interrupted_and_the_rerun_completes() {
    let tmp = tempfile::tempdir().unwrap();
    let plan = write_plan(tmp.path(), PLAN);
    let out = tmp.path().join("sw");
    let mut sweep = Command::new(common::exe())
        .args(["sweep", plan.to_str().unwrap(), "-o", "sw", "--jobs", "1"])
        .current_dir(tmp.path())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // The first point's process, once it runs.
    let t = std::time::Instant::now();
    let point = loop {
        let started = std::fs::read_to_string(out.join("runs/p001/status.json"))
            .is_ok_and(|s| s.contains("running"));
        let children = common::children_of(sweep.id());
        if let Some((pid, _)) = children.iter().find(|(_, c)| c.starts_with("bendscope")) {
            if started {
                break *pid;
            }
        }
        assert!(
            t.elapsed() < std::time::Duration::from_secs(30),
            "no point started"
        );
        std::thread::sleep(std::time::Duration::from_millis(5));
    };
    let _guard = common::KillOnDrop(point);
    let kill = Command::new("kill")
        .args(["-TERM", &sweep.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let exit = sweep.wait().unwrap();
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut sweep.stderr.take().unwrap(), &mut stderr).unwrap();
    assert_eq!(exit.code(), Some(130), "{exit}: {stderr}");
    assert!(stderr.contains("run the same command again"), "{stderr}");
    // No point outlives the sweep.
    let t = std::time::Instant::now();
    while common::running(point) {
        assert!(
            t.elapsed() < std::time::Duration::from_secs(2),
            "point process {point} outlived the sweep"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let status = std::fs::read_to_string(out.join("runs/p001/status.json")).unwrap();
    assert!(status.contains("\"interrupted\""), "{status}");
    let (h, rows) = read_csv(&out.join("designs.csv"));
    let s = col(&h, "status");
    assert_eq!(
        rows.iter().map(|r| r[s].as_str()).collect::<Vec<_>>(),
        ["interrupted", "pending"]
    );
    // The rerun runs both points to the end.
    let r = Run::new(
        tmp.path(),
        &["sweep", "plan.toml", "-o", "sw", "--jobs", "1"],
    );
    assert_eq!(r.code, 0, "{r}");
    assert!(r.stderr.contains("2 to run"), "{r}");
    let (h, rows) = read_csv(&out.join("designs.csv"));
    let s = col(&h, "status");
    assert!(rows.iter().all(|r| r[s] == "ok"), "{rows:?}");
}
