//! `bendscope study` on rendered sessions of two simulated samples (two radius laws, two
//! runs each with their own seeds and a small run-to-run change), processed by the
//! binary: study.csv against the statistics computed here from the per_video.csv files,
//! the samples' means against the rendered truth, a simulation of one sample, a session
//! that disagrees, a sample of one session, and bad input.

mod common;

use std::collections::BTreeMap;
use std::fs;
use std::path::Path;

use bendscope::render::actuator::FrameLook;
use bendscope::render::fixtures::gopro_like_camera;
use bendscope::render::session::{write_session, SessionSpec};
use common::{col, read_csv, Run};

/// Pressures of every run, kPa.
const PRESSURES: [f64; 4] = [20.0, 30.0, 45.0, 60.0];

/// The two samples' radius laws (a, b, c): radius = a p^b + c (mm, kPa); B is stiffer.
const LAWS: [(&str, (f64, f64, f64)); 2] =
    [("A", (3000.0, -0.9, 5.0)), ("B", (3600.0, -0.85, 5.0))];

/// Each run scales its sample's law by this factor (a run-to-run change), with its seed.
const RUNS: [(f64, u64); 2] = [(1.003, 11), (0.997, 12)];

/// Agreement of study.csv with the statistics computed here (both from the same cells).
const SAME: f64 = 1e-9;

/// Agreement of a sample's mean radius with its rendered law (each video is measured
/// within 0.5 %, tests/process.rs; the run factors cancel in the mean).
const TRUTH_TOLERANCE: f64 = 0.01;

fn law(l: (f64, f64, f64), p: f64) -> f64 {
    l.0 * p.powf(l.1) + l.2
}

/// Renders run `run` of sample `s` into `dir` with the camera's calibration and the true
/// mm per px in its bendscope.toml (no calibration or scale photo to measure).
fn render_run(dir: &Path, s: usize, run: usize) {
    let (factor, seed) = RUNS[run];
    let (a, b, c) = LAWS[s].1;
    let spec = SessionSpec {
        camera: gopro_like_camera(640, 480),
        distance_mm: 130.0,
        pressures_kpa: PRESSURES.to_vec(),
        radius_law: (a * factor, b, c * factor),
        frames: 3,
        calib_views: 0,
        calib_view_reach: 1.0,
        scale_square_mm: 8.0,
        scale_board_offset_mm: None,
        distractor: false,
        supersample: 2,
        look: FrameLook::default(),
        seed: seed + 10 * s as u64,
    };
    let truth = write_session(dir, &spec).unwrap();
    bendscope::calib::file::write_calibration(
        &dir.join("cam.yaml"),
        &truth.camera.to_calibration(),
    )
    .unwrap();
    fs::write(
        dir.join("bendscope.toml"),
        format!(
            "calibration = \"cam.yaml\"\nmm_per_px = {}\n",
            truth.mm_per_px
        ),
    )
    .unwrap();
}

/// A number cell of study.csv (empty: NaN).
fn cell(v: &str) -> f64 {
    if v.is_empty() {
        f64::NAN
    } else {
        v.parse().unwrap_or_else(|_| panic!("not a number: {v}"))
    }
}

/// The per-session values of a process output: per pressure cell text, each quantity's
/// mean over the measured rows there.
fn session_means(out: &Path, quantities: &[&str]) -> BTreeMap<String, Vec<f64>> {
    let (h, rows) = read_csv(&out.join("per_video.csv"));
    let mut by_p: BTreeMap<String, Vec<Vec<f64>>> = BTreeMap::new();
    for r in rows {
        let status = &r[col(&h, "status")];
        if status != "ok" && !status.starts_with("partial") {
            continue;
        }
        let values = quantities
            .iter()
            .map(|q| r[col(&h, q)].parse::<f64>().unwrap())
            .collect();
        by_p.entry(r[col(&h, "pressure_kpa")].clone())
            .or_default()
            .push(values);
    }
    by_p.into_iter()
        .map(|(p, rows)| {
            let means = (0..quantities.len())
                .map(|q| rows.iter().map(|r| r[q]).sum::<f64>() / rows.len() as f64)
                .collect();
            (p, means)
        })
        .collect()
}

/// mean, std (n - 1; NaN for one value), min, max.
fn stats(v: &[f64]) -> [f64; 4] {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let std = if v.len() < 2 {
        f64::NAN
    } else {
        (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    };
    let min = v.iter().copied().fold(f64::INFINITY, f64::min);
    let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    [mean, std, min, max]
}

fn close(got: f64, want: f64, what: &str) {
    if want.is_nan() {
        assert!(got.is_nan(), "{what}: {got}, expected an empty cell");
    } else {
        assert!(
            (got - want).abs() <= SAME * want.abs().max(1e-300),
            "{what}: {got} vs {want}"
        );
    }
}

/// Checks every row of OUT/study.csv against the statistics of `samples` (name, process
/// outputs) computed here; returns the rows as maps of column -> cell.
fn check_study_csv(
    out: &Path,
    samples: &[(&str, Vec<std::path::PathBuf>)],
) -> Vec<BTreeMap<String, String>> {
    let quantities = [
        "radius_mm",
        "curvature_per_m",
        "bending_angle_deg",
        "tip_x_mm",
        "tip_y_mm",
    ];
    let (h, rows) = read_csv(&out.join("study.csv"));
    let mut expected_header = vec!["sample".to_string(), "pressure_kpa".into(), "n".into()];
    for q in quantities {
        for s in ["mean", "std", "min", "max"] {
            expected_header.push(format!("{q}_{s}"));
        }
    }
    assert_eq!(h, expected_header);
    let mut pooled: BTreeMap<String, Vec<Vec<f64>>> = BTreeMap::new();
    let mut expected: Vec<(String, String, Vec<Vec<f64>>)> = Vec::new();
    for (name, outs) in samples {
        let mut by_p: BTreeMap<String, Vec<Vec<f64>>> = BTreeMap::new();
        for o in outs {
            for (p, m) in session_means(o, &quantities) {
                by_p.entry(p.clone()).or_default().push(m.clone());
                pooled.entry(p).or_default().push(m);
            }
        }
        for (p, v) in by_p {
            expected.push((name.to_string(), p, v));
        }
    }
    for (p, v) in pooled {
        expected.push(("all".into(), p, v));
    }
    // Rows are in pressure order within a sample; the cells here are sorted as text,
    // so match by (sample, pressure).
    assert_eq!(rows.len(), expected.len(), "rows of study.csv");
    let maps: Vec<BTreeMap<String, String>> = rows
        .iter()
        .map(|r| h.iter().cloned().zip(r.iter().cloned()).collect())
        .collect();
    for (sample, p, values) in &expected {
        let row = maps
            .iter()
            .find(|r| r["sample"] == *sample && (cell(&r["pressure_kpa"]) - cell(p)).abs() < 1e-9)
            .unwrap_or_else(|| panic!("no row {sample} {p} kPa"));
        assert_eq!(row["n"], values.len().to_string(), "{sample} {p}");
        for (q, name) in quantities.iter().enumerate() {
            let v: Vec<f64> = values.iter().map(|m| m[q]).collect();
            let s = stats(&v);
            for (k, what) in ["mean", "std", "min", "max"].iter().enumerate() {
                let key = format!("{name}_{what}");
                close(cell(&row[&key]), s[k], &format!("{sample} {p} kPa {key}"));
            }
        }
    }
    maps
}

/// Rewrites `per_video.csv` of `out` with the radius scaled by `k` and the curvature and
/// bending angle by 1/k (a session of a softer actuator: the same marker line on a
/// circle k times larger).
fn scale_radius(out: &Path, k: f64) {
    let path = out.join("per_video.csv");
    let text = fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (r, c, a) = (
        column("radius_mm"),
        column("curvature_per_m"),
        column("bending_angle_deg"),
    );
    let mut out_text = header.join(",") + "\n";
    for l in lines {
        assert!(!l.contains('"'), "a plain row: {l}");
        let mut cells: Vec<String> = l.split(',').map(String::from).collect();
        for (i, f) in [(r, k), (c, 1.0 / k), (a, 1.0 / k)] {
            if let Ok(v) = cells[i].parse::<f64>() {
                cells[i] = format!("{:.4}", v * f);
            }
        }
        out_text += &(cells.join(",") + "\n");
    }
    fs::write(&path, out_text).unwrap();
}

#[test]
fn two_samples_of_two_runs_give_the_statistics_of_their_tables_and_the_truth() {
    let started = std::time::Instant::now();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (s, (name, _)) in LAWS.iter().enumerate() {
        for run in 0..RUNS.len() {
            render_run(&d.join(format!("{name}-run{}", run + 1)), s, run);
        }
    }
    // Three runs processed by `process`; B-run2 is left to `study` (a session folder).
    let run = Run::new(d, &["process", "A-run1", "A-run2", "B-run1"]);
    assert_eq!(run.code, 0, "{run}");
    // A simulation that is sample B's law, 10..70 kPa.
    fs::create_dir(d.join("sim-b")).unwrap();
    let mut steps = "pressure_kpa,radius_mm,curvature_per_m,bending_angle_deg\n".to_string();
    for k in 2..=14 {
        let p = 5.0 * k as f64;
        let r = law(LAWS[1].1, p);
        // The bending angle of an arc of the marker line's length (about 98 mm).
        steps += &format!("{p},{r},{},{}\n", 1000.0 / r, (98.0 / r).to_degrees());
    }
    fs::write(d.join("sim-b/steps.csv"), steps).unwrap();
    fs::write(
        d.join("study.toml"),
        "fem = \"sim-b\"\n[[sample]]\nname = \"A\"\nsessions = [\"A-run1/bendscope-out\", \"A-run2/bendscope-out\"]\n[[sample]]\nname = \"B\"\nsessions = [\"B-run1/bendscope-out\", \"B-run2\"]\n",
    )
    .unwrap();
    let run = Run::new(d, &["study", "study.toml", "-o", "out"]);
    assert_eq!(run.code, 0, "{run}");
    assert!(
        run.stderr
            .contains("B-run2: a session folder, processed on the way (4 measured, 0 failed)"),
        "{run}"
    );
    assert!(!run.stderr.contains("disagrees"), "{run}");
    let out = d.join("out");
    let outs = |s: &str| {
        (1..=2)
            .map(|r| d.join(format!("{s}-run{r}/bendscope-out")))
            .collect::<Vec<_>>()
    };
    let rows = check_study_csv(&out, &[("A", outs("A")), ("B", outs("B"))]);
    // Each sample's mean radius within 1 % of its rendered law; two sessions per row.
    let mut worst = 0.0f64;
    for (name, l) in LAWS {
        for p in PRESSURES {
            let row = rows
                .iter()
                .find(|r| r["sample"] == name && cell(&r["pressure_kpa"]) == p)
                .unwrap();
            assert_eq!(row["n"], "2");
            let (mean, truth) = (cell(&row["radius_mm_mean"]), law(l, p));
            worst = worst.max((mean / truth - 1.0).abs());
            assert!(
                (mean / truth - 1.0).abs() < TRUTH_TOLERANCE,
                "{name} at {p} kPa: {mean} mm vs {truth} mm"
            );
            let k = cell(&row["curvature_per_m_mean"]);
            assert!(
                (k * truth / 1000.0 - 1.0).abs() < TRUTH_TOLERANCE,
                "{name} {p}: {k}"
            );
            assert!(cell(&row["radius_mm_std"]) > 0.0);
        }
    }
    // The simulation is B's law: it agrees with B (within the 1 % of the measurement)
    // and not with A.
    let (fh, fem) = read_csv(&out.join("fem.csv"));
    let rmse_pct = |sample: &str| -> f64 {
        let r = fem
            .iter()
            .find(|r| r[col(&fh, "sample")] == sample && r[col(&fh, "quantity")] == "radius_mm")
            .unwrap();
        assert_eq!(r[col(&fh, "model")], "sim-b");
        cell(&r[col(&fh, "rmse_pct")])
    };
    eprintln!(
        "study test: worst sample mean radius vs truth {:.3} %; sim-b RMSE {:.3} % of B, {:.1} % of A",
        100.0 * worst,
        rmse_pct("B"),
        rmse_pct("A")
    );
    assert!(rmse_pct("B") < 1.0, "{}", rmse_pct("B"));
    assert!(rmse_pct("A") > 10.0, "{}", rmse_pct("A"));
    // Fits with bands that hold the truth of their sample at mid-range.
    let fits: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("fits.json")).unwrap()).unwrap();
    let fit_list = fits["fits"].as_array().unwrap();
    assert_eq!(fit_list.len(), 9, "3 quantities x (A, B, all)");
    for (name, l) in LAWS {
        let f = fit_list
            .iter()
            .find(|f| f["sample"] == name && f["quantity"] == "radius_mm")
            .unwrap();
        assert_eq!(f["fit"]["n"], 8);
        let band = &f["band"];
        let k = 20;
        let p = band["pressure_kpa"][k].as_f64().unwrap();
        let (lo, hi) = (
            band["lower"][k].as_f64().unwrap(),
            band["upper"][k].as_f64().unwrap(),
        );
        assert!(
            lo < hi && (hi - lo) < 0.05 * law(l, p),
            "{name}: {lo}..{hi} at {p}"
        );
        assert!(
            lo < law(l, p) * (1.0 + TRUTH_TOLERANCE) && hi > law(l, p) * (1.0 - TRUTH_TOLERANCE),
            "{name}: band {lo}..{hi} at {p} kPa, truth {}",
            law(l, p)
        );
    }
    for stem in [
        "radius_vs_pressure",
        "curvature_vs_pressure",
        "angle_vs_pressure",
    ] {
        for ext in ["png", "svg", "pdf"] {
            let p = out.join("plots").join(format!("{stem}.{ext}"));
            assert!(
                fs::metadata(&p).map(|m| m.len() > 1000).unwrap_or(false),
                "{}",
                p.display()
            );
        }
    }
    let svg = fs::read_to_string(out.join("plots/radius_vs_pressure.svg")).unwrap();
    for label in [
        "sample A (mean ± std)",
        "sample B (mean ± std)",
        "pooled fit",
        "FEM sim-b",
    ] {
        assert!(svg.contains(label), "legend lacks {label}");
    }
    let html = fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("<svg") && html.contains("Repeatability") && html.contains("sim-b"));
    if let Some(keep) = std::env::var_os("BENDSCOPE_STUDY_FIGURE") {
        fs::copy(out.join("plots/radius_vs_pressure.png"), keep).unwrap();
    }

    // A third run of A from a softer actuator (radius +30 %), and B of one session, by
    // flags: the third run is flagged, B's std is empty and said so once.
    fs::create_dir(d.join("A-run3")).unwrap();
    for f in ["per_video.csv", "markers.csv"] {
        fs::copy(
            d.join("A-run1/bendscope-out").join(f),
            d.join("A-run3").join(f),
        )
        .unwrap();
    }
    scale_radius(&d.join("A-run3"), 1.3);
    let run = Run::new(
        d,
        &[
            "study",
            "--sample",
            "A=A-run1/bendscope-out,A-run2/bendscope-out,A-run3",
            "--sample",
            "B=B-run1/bendscope-out",
            "-o",
            "out2",
            "--error-bars",
            "ci95",
        ],
    );
    assert_eq!(run.code, 0, "{run}");
    let flags: Vec<&str> = run
        .stderr
        .lines()
        .filter(|l| l.contains("disagrees"))
        .collect();
    assert_eq!(flags.len(), 1, "{run}");
    eprintln!("study test: {}", flags[0]);
    assert!(
        flags[0].starts_with("warning: sample A: session A-run3 disagrees"),
        "{run}"
    );
    assert_eq!(
        run.stderr.matches("sample B has one session").count(),
        1,
        "{run}"
    );
    assert_eq!(
        run.stderr
            .lines()
            .filter(|l| l.starts_with("note: n = 1"))
            .count(),
        1,
        "{run}"
    );
    let rows = check_study_csv(
        &d.join("out2"),
        &[
            (
                "A",
                vec![outs("A")[0].clone(), outs("A")[1].clone(), d.join("A-run3")],
            ),
            ("B", vec![outs("B")[0].clone()]),
        ],
    );
    for r in rows.iter().filter(|r| r["sample"] == "B") {
        assert_eq!(
            (r["n"].as_str(), r["radius_mm_std"].as_str()),
            ("1", ""),
            "{r:?}"
        );
        assert!(!r["radius_mm_mean"].is_empty());
    }
    let html = fs::read_to_string(d.join("out2/report.html")).unwrap();
    assert!(html.contains("session A-run3 disagrees"));
    ci95_bars_are_drawn_at_their_half_height(&d.join("out2"), &rows);
    eprintln!("study test: {:.1} s", started.elapsed().as_secs_f64());
}

/// The value of attribute `name` in an SVG tag.
fn attr<'t>(tag: &'t str, name: &str) -> Option<&'t str> {
    let start = tag.find(&format!(" {name}=\""))? + name.len() + 3;
    Some(&tag[start..start + tag[start..].find('"')?])
}

/// With `--error-bars ci95`, each of sample A's bars (3 sessions a set point) spans
/// t_{0.975, 2} std / sqrt(3) = 4.3027 std / sqrt(3) either side of its marker, the std
/// from study.csv, at the plot's own px per mm (from A's first and last markers); B
/// (one session) has none; the legend says which bars these are.
fn ci95_bars_are_drawn_at_their_half_height(out: &Path, rows: &[BTreeMap<String, String>]) {
    use plotters::style::{Color, Palette, Palette99};
    let svg = fs::read_to_string(out.join("plots/radius_vs_pressure.svg")).unwrap();
    assert!(svg.contains("sample A (mean ± 95 % CI)"), "legend");
    let colour = |i: usize| {
        let c = Palette99::pick(i).to_rgba().rgb();
        format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)
    };
    let tags = |kind: &str, key: &str, c: &str| -> Vec<String> {
        svg.split('<')
            .filter(|t| t.starts_with(kind) && attr(t, key) == Some(c))
            .map(str::to_string)
            .collect()
    };
    let num = |t: &str, n: &str| attr(t, n).unwrap().parse::<f64>().unwrap();
    // Vertical two-point polylines: (x, top, bottom).
    let bars = |c: &str| -> Vec<(f64, f64, f64)> {
        tags("polyline", "stroke", c)
            .iter()
            .filter_map(|t| {
                let p: Vec<(f64, f64)> = attr(t, "points")?
                    .split_whitespace()
                    .map(|xy| {
                        let (x, y) = xy.split_once(',').unwrap();
                        (x.parse().unwrap(), y.parse().unwrap())
                    })
                    .collect();
                (p.len() == 2 && p[0].0 == p[1].0)
                    .then(|| (p[0].0, p[0].1.min(p[1].1), p[0].1.max(p[1].1)))
            })
            .collect()
    };
    assert!(bars(&colour(1)).is_empty(), "no bar for B's one session");
    let value = |r: &BTreeMap<String, String>, k: &str| r[k].parse::<f64>().unwrap();
    let mut a: Vec<&BTreeMap<String, String>> =
        rows.iter().filter(|r| r["sample"] == "A").collect();
    a.sort_by(|p, q| value(p, "pressure_kpa").total_cmp(&value(q, "pressure_kpa")));
    let mut markers: Vec<(f64, f64)> = tags("circle", "fill", &colour(0))
        .iter()
        .map(|t| (num(t, "cx"), num(t, "cy")))
        .collect();
    markers.sort_by(|p, q| p.0.total_cmp(&q.0));
    let a_bars = bars(&colour(0));
    assert_eq!(a_bars.len(), a.len(), "one bar per set point of A");
    // The markers with a bar, left to right = the set points by pressure.
    let with_bar: Vec<(f64, f64)> = markers
        .into_iter()
        .filter(|m| a_bars.iter().any(|b| (b.0 - m.0).abs() <= 1.5))
        .collect();
    assert_eq!(with_bar.len(), a.len());
    let (first, last) = (a[0], a[a.len() - 1]);
    let px_per_mm = (with_bar[0].1 - with_bar[a.len() - 1].1)
        / (value(last, "radius_mm_mean") - value(first, "radius_mm_mean"));
    for (r, m) in a.iter().zip(&with_bar) {
        assert_eq!(r["n"], "3");
        let std = value(r, "radius_mm_std");
        let expected = 4.3027 * std / 3f64.sqrt() * px_per_mm.abs();
        let b = a_bars.iter().find(|b| (b.0 - m.0).abs() <= 1.5).unwrap();
        let half = 0.5 * (b.2 - b.1);
        // SVG coordinates are whole px: 1.5 px for the rounding of both ends.
        assert!(
            (half - expected).abs() <= 1.5,
            "{} kPa: bar half-length {half} px, expected {expected:.1} px",
            r["pressure_kpa"]
        );
        assert!(
            (half - std * px_per_mm.abs()).abs() > 3.0,
            "a ci95 bar differs from a std bar"
        );
        assert!(
            (0.5 * (b.1 + b.2) - m.1).abs() <= 1.5,
            "centred on its marker"
        );
    }
}

/// A hand-made process output: per_video.csv at [`PRESSURES`] (radius law A times
/// `k`), markers.csv with `markers` markers per frame on a straight line `length_mm`
/// long.
fn fake_output(dir: &Path, k: f64, markers: usize, length_mm: f64, status: &str) {
    fs::create_dir_all(dir).unwrap();
    let mut pv =
        "file,pressure_kpa,radius_mm,curvature_per_m,bending_angle_deg,tip_x_mm,tip_y_mm,status\n"
            .to_string();
    let mut mk = "file,frame,time_s,pressure_kpa,marker,x_px,y_px,x_mm,y_mm\n".to_string();
    for (i, p) in PRESSURES.iter().enumerate() {
        let r = k * law(LAWS[0].1, *p);
        pv += &format!(
            "v{i}.mp4,{p},{r},{},{},{},{},{status}\n",
            1000.0 / r,
            98.0 / r * 57.3,
            90.0,
            20.0
        );
        for m in 0..markers {
            let x = length_mm * m as f64 / (markers - 1) as f64;
            mk += &format!("v{i}.mp4,0,0,{p},{},0,0,{x},0\n", m + 1);
        }
    }
    fs::write(dir.join("per_video.csv"), pv).unwrap();
    fs::write(dir.join("markers.csv"), mk).unwrap();
}

#[test]
fn bad_studies_are_one_line_exit_2_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fake_output(&d.join("a1"), 1.0, 8, 98.0, "ok");
    fake_output(&d.join("a2"), 1.01, 8, 98.5, "ok");
    fake_output(&d.join("seven"), 1.0, 7, 98.0, "ok");
    fake_output(&d.join("long"), 1.0, 8, 140.0, "ok");
    fake_output(&d.join("failed"), 1.0, 8, 98.0, "no frame measured: blur");
    fs::create_dir(d.join("empty")).unwrap();
    let sample = |sessions: &str| format!("[[sample]]\nname = \"A\"\nsessions = [{sessions}]\n");
    let cases: Vec<(String, Vec<&str>)> = vec![
        (
            sample("\"a1\", \"a2\"") + "colour = \"red\"\n",
            vec!["study.toml: line 4: unknown key `colour`"],
        ),
        (sample(""), vec!["study.toml", "sample `A` has no session"]),
        (
            sample("\"a1\"") + &sample("\"a2\""),
            vec!["study.toml", "sample `A` is listed twice"],
        ),
        (
            sample("\"a1\", \"nowhere\""),
            vec!["nowhere: no such folder"],
        ),
        (
            sample("\"a1\", \"empty\""),
            vec!["empty: no per_video.csv", "bendscope process"],
        ),
        (
            sample("\"a1\", \"seven\""),
            vec!["sample A:", "has 7 markers per frame", "has 8"],
        ),
        (
            sample("\"a1\", \"long\""),
            vec!["sample A:", "marker line", "140.0 mm", "98.0 mm"],
        ),
        (
            sample("\"a1\", \"failed\""),
            vec!["failed/per_video.csv: no measured row"],
        ),
        (sample("\"a1\", \"a1/\""), vec!["session", "listed twice"]),
        (
            "fem = \"nosim\"\n".to_string() + &sample("\"a1\", \"a2\""),
            vec!["nosim: no such folder", "bendscope simulate"],
        ),
        (
            "[[sample]]\nname = \"all\"\nsessions = [\"a1\"]\n".into(),
            vec!["taken by the pooled rows"],
        ),
        (
            "[sample]\nname = \"A\"\n".into(),
            vec!["study.toml: line 1:"],
        ),
    ];
    for (k, (toml, needles)) in cases.iter().enumerate() {
        let file = format!("study{k}.toml");
        fs::write(d.join(&file), toml.replace("study.toml", &file)).unwrap();
        let needles: Vec<String> = needles
            .iter()
            .map(|n| n.replace("study.toml", &file))
            .collect();
        let needles: Vec<&str> = needles.iter().map(String::as_str).collect();
        let run = Run::new(d, &["study", &file, "-o", "out"]);
        run.assert_bad_input(&needles);
        assert!(!d.join("out").exists(), "case {k}: nothing written: {run}");
    }
    for (args, needles) in [
        (
            vec!["study", "--sample", "A", "-o", "out"],
            vec!["--sample: `A`: give a sample as NAME=OUT"],
        ),
        (
            vec!["study", "--sample", "A=a1,seven", "-o", "out"],
            vec!["sample A:", "7 markers"],
        ),
    ] {
        let run = Run::new(d, &args);
        run.assert_bad_input(&needles);
        assert!(!d.join("out").exists(), "{args:?}: nothing written");
    }
    // The good pair is a study: a warning-free run of hand-made outputs.
    let run = Run::new(d, &["study", "--sample", "A=a1,a2", "-o", "out"]);
    assert_eq!(run.code, 0, "{run}");
    check_study_csv(&d.join("out"), &[("A", vec![d.join("a1"), d.join("a2")])]);
}
