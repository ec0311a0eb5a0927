//! `bendscope control` end to end: the loop on a pure first-order-plus-dead-time plant
//! against its analytic response, a tuned 90-degree step on the reference actuator,
//! saturation, the FEM in the loop against the map, bad input.

mod common;

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use common::{col, Run};

/// The reference actuator simulated once per test run on a coarse mesh (4 mm) from 0 to
/// 100 kPa in 10 kPa steps: the plant of the tests (11 steps, the costliest part of the
/// run).
fn reference_plant() -> &'static Path {
    static D: OnceLock<PathBuf> = OnceLock::new();
    D.get_or_init(|| {
        let root = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("control-shared");
        let _ = fs::remove_dir_all(&root);
        fs::create_dir_all(&root).unwrap();
        let run = Run::new(
            &root,
            &[
                "simulate",
                "--mesh-size",
                "4",
                "--pressures",
                "0:100:10",
                "--no-vtu",
                "-o",
                "fem",
            ],
        );
        assert_eq!(run.code, 0, "{run}");
        root.join("fem")
    })
}

/// A numeric column of a CSV.
fn column(path: &Path, name: &str) -> Vec<f64> {
    let (h, rows) = common::read_csv(path);
    let c = col(&h, name);
    rows.iter().map(|r| r[c].parse::<f64>().unwrap()).collect()
}

/// The plant's resting angle (at its lowest pressure), degrees.
fn resting_deg(plant: &Path) -> f64 {
    column(&plant.join("steps.csv"), "bending_angle_deg")[0]
}

fn metrics(out: &Path) -> serde_json::Value {
    serde_json::from_str(&fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap()
}

/// 1 − y(t) / r of the loop e^{−θ s} / (T s) closed by unit feedback, for a step at
/// t = 0: the delay differential equation T y'(t) = r − y(t − θ) solved by the method
/// of steps, z(t) = Σ_{k ≥ 0, t > kθ} (−1)^k ((t − kθ) / T)^k / k!.
fn analytic_z(t: f64, theta: f64, big_t: f64) -> f64 {
    let mut z = 0.0;
    let mut k = 0;
    let mut fact = 1.0;
    while t > k as f64 * theta || k == 0 {
        if k > 0 {
            fact *= k as f64;
        }
        let s = ((t - k as f64 * theta) / big_t).max(0.0);
        z += (-1f64).powi(k) * s.powi(k) / fact;
        k += 1;
    }
    z
}

#[test]
fn pi_on_a_pure_fopdt_plant_follows_the_analytic_closed_loop() {
    // Plant: angle = 0.8 deg/kPa x pressure behind a lag τ = 0.3 s and a dead time
    // θ = 0.1 s (a linear steps.csv, a fixed lag, no noise, no quantization, no rate
    // limit). PI with τI = τ and Kc = τ / (k T): the loop is e^{−θ s} / (T s) exactly,
    // whose step response is known in closed form (analytic_z).
    let dir = tempfile::tempdir().unwrap();
    let plant = dir.path().join("linear");
    fs::create_dir_all(&plant).unwrap();
    let mut csv = String::from("pressure_kpa,bending_angle_deg\n");
    for p in (0..=200).step_by(20) {
        csv.push_str(&format!("{p},{}\n", 0.8 * p as f64));
    }
    fs::write(plant.join("steps.csv"), csv).unwrap();
    let (k, tau, theta, big_t, h) = (0.8, 0.3, 0.1, 0.2, 0.001);
    let kc = tau / (k * big_t);
    let run = Run::new(
        dir.path(),
        &[
            "control",
            "--plant",
            "linear",
            "--step",
            "50",
            "--kp",
            &kc.to_string(),
            "--ki",
            &(kc / tau).to_string(),
            "--tau-s",
            &tau.to_string(),
            "--dead-time-s",
            &theta.to_string(),
            "--noise-deg",
            "0",
            "--resolution-kpa",
            "0",
            "--rate-limit-kpa-s",
            "inf",
            "--sample-time-s",
            &h.to_string(),
            "--duration-s",
            "2",
            "-o",
            "out",
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    let out = dir.path().join("out");
    let csv = out.join("control.csv");
    let t = column(&csv, "time_s");
    let y = column(&csv, "angle_deg");
    let r = column(&csv, "reference_deg");
    assert!(r.iter().all(|v| *v == 50.0));
    // Sampling adds about half a sample of delay (zero-order hold) and the integral
    // lags one sample: with h = 1 ms against T = 200 ms the responses agree to within
    // 0.5% of the step (measured: 0.12 deg).
    let worst = t
        .iter()
        .zip(&y)
        .map(|(t, y)| (y - 50.0 * (1.0 - analytic_z(*t, theta + 0.5 * h, big_t))).abs())
        .fold(0.0, f64::max);
    assert!(
        worst < 0.25,
        "largest deviation from the analytic response {worst} deg"
    );
    // T = 2θ is SIMC's τc = θ: the analytic overshoot is 4.2%.
    let m = metrics(&out);
    let os = m["step"]["overshoot_pct"].as_f64().unwrap();
    let exact_peak = (0..20000)
        .map(|i| 1.0 - analytic_z(i as f64 * 1e-4, theta + 0.5 * h, big_t))
        .fold(0.0, f64::max);
    assert!(
        (os - 100.0 * (exact_peak - 1.0)).abs() < 0.3,
        "overshoot {os}%"
    );
    assert!(m["step"]["steady_state_error_deg"].as_f64().unwrap().abs() < 0.01);
}

#[test]
fn tuned_step_to_90_degrees_settles_without_much_overshoot() {
    let plant = reference_plant();
    let dir = tempfile::tempdir().unwrap();
    let run = Run::new(
        dir.path(),
        &[
            "control",
            "--plant",
            plant.to_str().unwrap(),
            "--step",
            "90",
            "--tune",
            "-o",
            "out",
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    assert!(run.stdout.contains("tuned: FOPDT"), "{run}");
    let out = dir.path().join("out");
    let m = metrics(&out);
    let step = &m["step"];
    let os = step["overshoot_pct"].as_f64().unwrap();
    let sse = step["steady_state_error_deg"].as_f64().unwrap();
    assert!(os <= 10.0, "overshoot {os}%: {m}");
    assert!(sse.abs() <= 0.5, "steady-state error {sse} deg: {m}");
    let settle = step["settling_time_s"].as_f64().expect("settles");
    assert!(settle < 3.0, "settling {settle} s");
    assert!(m["warnings"].as_array().unwrap().is_empty(), "{m}");
    let csv = out.join("control.csv");
    let (h, _) = common::read_csv(&csv);
    for name in [
        "time_s",
        "reference_deg",
        "angle_deg",
        "pressure_cmd_kpa",
        "pressure_kpa",
    ] {
        col(&h, name);
    }
    let p = column(&csv, "pressure_kpa");
    assert!(p.iter().all(|p| (0.0..=100.0).contains(p)));
    eprintln!("tuned 90-degree step: {m}");
    for plot in ["angle.png", "angle.svg", "pressure.png", "pressure.svg"] {
        assert!(out.join("plots").join(plot).is_file(), "{plot}");
    }
}

#[test]
fn a_target_beyond_reach_warns_and_keeps_the_pressure_bounded() {
    let plant = reference_plant();
    let dir = tempfile::tempdir().unwrap();
    // 300 degrees for 3 s, then back to 20 above rest: the pressure saturates at the
    // regulator's top, and with anti-windup the loop comes back without a long wind-down.
    let low = resting_deg(plant) + 20.0;
    fs::write(
        dir.path().join("ref.csv"),
        format!("time_s,angle_deg\n0,300\n3,300\n3.001,{low}\n6,{low}\n"),
    )
    .unwrap();
    let run = Run::new(
        dir.path(),
        &[
            "control",
            "--plant",
            plant.to_str().unwrap(),
            "--target",
            "ref.csv",
            "--kp",
            "1",
            "--ki",
            "8",
            "-o",
            "out",
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    assert!(
        run.stderr
            .contains("warning: the reference asks for 300.0 deg but the actuator reaches at most"),
        "{run}"
    );
    assert!(run.stderr.contains("at the regulator's limit"), "{run}");
    let out = dir.path().join("out");
    let csv = out.join("control.csv");
    let t = column(&csv, "time_s");
    let cmd = column(&csv, "pressure_cmd_kpa");
    let p = column(&csv, "pressure_kpa");
    let y = column(&csv, "angle_deg");
    assert!(
        cmd.iter().all(|c| (0.0..=100.0).contains(c)),
        "command out of range"
    );
    assert!(p.iter().all(|c| (0.0..=100.0 + 1e-9).contains(c)));
    // Saturated at the top during the first phase.
    let at = |s: f64| t.iter().position(|v| *v >= s).unwrap();
    assert!((cmd[at(2.5)] - 100.0).abs() < 1e-9, "{}", cmd[at(2.5)]);
    // Back within 2 degrees within 1.5 s of the switch.
    assert!(
        y[at(4.5)..].iter().all(|v| (v - low).abs() < 2.0),
        "no recovery: {:?}",
        &y[at(4.5)..at(4.6)]
    );
    let m = metrics(&out);
    assert!(!m["warnings"].as_array().unwrap().is_empty());
}

#[test]
fn fem_in_the_loop_agrees_with_the_map_on_a_slow_ramp() {
    let plant = reference_plant();
    let dir = tempfile::tempdir().unwrap();
    // From 5 to 35 degrees above rest in 1.5 s, sampled at 20 Hz: 37 FEM solves.
    let rest = resting_deg(plant);
    let ramp = format!("{}:{}:1.5", rest + 5.0, rest + 35.0);
    let run = Run::new(
        dir.path(),
        &[
            "control",
            "--plant",
            plant.to_str().unwrap(),
            "--ramp",
            &ramp,
            "--duration-s",
            "1.8",
            "--sample-time-s",
            "0.05",
            "--fem-in-loop",
            "-o",
            "out",
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    let out = dir.path().join("out");
    let m = metrics(&out);
    let fem = &m["fem_in_loop"];
    let diff = fem["max_abs_difference_deg"].as_f64().unwrap();
    assert!(diff < 1.0, "FEM vs map {diff} deg: {m}");
    assert!(fem["solves"].as_u64().unwrap() > 30, "{fem}");
    eprintln!("FEM in the loop: {fem}");
    let a = column(&out.join("control.csv"), "angle_deg");
    let b = column(&out.join("control_map.csv"), "angle_deg");
    assert_eq!(a.len(), b.len());
    let worst = a
        .iter()
        .zip(&b)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1.0, "{worst}");
    // The loop hides plant differences (both runs follow the reference): the FEM's angle
    // must also be the map's at the same pressure, sample by sample.
    let map = bendscope::control::plant::QuasiStaticMap::from_simulation(plant).unwrap();
    let p = column(&out.join("control.csv"), "pressure_kpa");
    let off = p
        .iter()
        .zip(&a)
        .map(|(p, a)| (map.angle_deg(*p) - a).abs())
        .fold(0.0, f64::max);
    assert!(off < 1.0, "FEM vs map at the same pressure: {off} deg");
    // Both follow the ramp.
    assert!(m["tracking"]["rmse_deg"].as_f64().unwrap() < 5.0, "{m}");
}

#[test]
fn bad_input_is_one_line_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    Run::new(
        dir.path(),
        &["control", "--plant", "nowhere", "--step", "90"],
    )
    .assert_bad_input(&["steps.csv not found", "bendscope simulate"]);
    fs::create_dir_all(dir.path().join("p")).unwrap();
    fs::write(
        dir.path().join("p/steps.csv"),
        "pressure_kpa,bending_angle_deg\n0,0\n10,5\n20,4\n",
    )
    .unwrap();
    Run::new(dir.path(), &["control", "--plant", "p", "--step", "3"])
        .assert_bad_input(&["falls", "between 10 and 20 kPa"]);
    Run::new(dir.path(), &["control", "--plant", "p", "--ramp", "0:10"])
        .assert_bad_input(&["--ramp", "FROM_DEG:TO_DEG:SECONDS"]);
}

/// Runs `bendscope args` in `cwd`; its exit code and peak resident memory, kB (the
/// child's own `ru_maxrss`, from wait4).
fn run_with_peak_rss_kb(cwd: &Path, args: &[&str]) -> (i32, i64) {
    let child = std::process::Command::new(common::exe())
        .args(args)
        .current_dir(cwd)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: rusage is plain data; wait4 fills it for the child just started.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let waited = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(waited, pid);
    (libc::WEXITSTATUS(status), usage.ru_maxrss)
}

#[test]
fn a_long_run_streams_with_bounded_memory_and_a_too_long_one_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let plant = dir.path().join("linear");
    fs::create_dir_all(&plant).unwrap();
    let mut csv = String::from("pressure_kpa,bending_angle_deg\n");
    for p in (0..=200).step_by(20) {
        csv.push_str(&format!("{p},{}\n", 0.8 * p as f64));
    }
    fs::write(plant.join("steps.csv"), csv).unwrap();
    let args = |duration: &'static str| {
        vec![
            "control",
            "--plant",
            "linear",
            "--step",
            "50",
            "--kp",
            "1",
            "--ki",
            "5",
            "--tau-s",
            "0.3",
            "--duration-s",
            duration,
            "-o",
            "out",
        ]
    };
    // 1e6 s at 100 Hz: refused before anything runs, with the size it would write.
    let t = std::time::Instant::now();
    Run::new(dir.path(), &args("1e6")).assert_bad_input(&[
        "--duration-s",
        "100000001 samples",
        "7.0 GB",
        "at most 10000000 samples",
        "--sample-time-s",
    ]);
    assert!(t.elapsed() < std::time::Duration::from_secs(5));
    assert!(!dir.path().join("out").exists());
    // The line's delay is held sample by sample: a dead time past a minute, or one of
    // more samples than a run may have, is refused at once too.
    let with = |extra: &[&'static str]| {
        let mut a = args("2");
        a.extend_from_slice(extra);
        a
    };
    Run::new(dir.path(), &with(&["--dead-time-s", "1e9"]))
        .assert_bad_input(&["--dead-time-s", "between 0 and 60 s"]);
    Run::new(
        dir.path(),
        &with(&["--dead-time-s", "50", "--sample-time-s", "1e-6"]),
    )
    .assert_bad_input(&["--sample-time-s", "50000000 delayed samples"]);
    assert!(!dir.path().join("out").exists());
    // 10,000 s at 100 Hz (1,000,001 samples, ~60 MB of CSV): memory stays bounded.
    let (code, peak_kb) = run_with_peak_rss_kb(dir.path(), &args("10000"));
    assert_eq!(code, 0);
    let out = dir.path().join("out");
    let text = fs::read_to_string(out.join("control.csv")).unwrap();
    assert_eq!(text.lines().count(), 1_000_002);
    assert!(text.ends_with("\n"));
    let last = text.lines().last().unwrap();
    assert!(last.starts_with("10000.0000,50.0000,"), "{last}");
    let m = metrics(&out);
    assert!(m["step"]["steady_state_error_deg"].as_f64().unwrap().abs() < 0.05);
    println!("peak RSS of a 1,000,001-sample run: {} MB", peak_kb / 1024);
    assert!(
        peak_kb < 150 * 1024,
        "peak resident memory {} MB for 1,000,001 samples",
        peak_kb / 1024
    );
}
