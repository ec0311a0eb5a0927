//! `bendscope compare`: measured (process output) against simulated (simulate output).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, Result};
use bendscope::compare::{compare_quantity, read_columns, Curve, QuantityComparison};
use bendscope::io::write_atomic;
use bendscope::report::{plot_xy, write_json, Series};
use bendscope::table::{write_csv, Column};
use clap::Args;

use super::{EXIT_OK, EXIT_PARTIAL};

/// grams-force to newtons.
const N_PER_GF: f64 = 9.806_65e-3;

/// Compare measured bending with the simulation.
#[derive(Debug, Args)]
#[command(
    after_help = "Reads MEASURED/per_video.csv (bendscope process) and FEM/steps.csv (+ force.csv) \
(bendscope simulate). Each curve is fitted with y = a p^b + c and the fits are compared on a common pressure grid \
over the range both cover. Writes in REPORT: compare.csv (the curves and their deviation), summary.txt, \
compare.json and plots/ (PNG + SVG)."
)]
pub struct CompareArgs {
    /// Output folder of `bendscope process` (per_video.csv).
    #[arg(long, value_name = "OUT")]
    pub measured: PathBuf,
    /// Output folder of `bendscope simulate` (steps.csv, force.csv).
    #[arg(long, value_name = "FEM_OUT")]
    pub fem: PathBuf,
    /// Measured blocked force: CSV with pressure_kpa and force_g (grams) columns.
    #[arg(long, value_name = "CSV")]
    pub force: Option<PathBuf>,
    /// Report folder.
    #[arg(short, long, value_name = "REPORT", default_value = "compare-out")]
    pub output: PathBuf,
}

fn curve(path: &Path, value: &str, scale: f64) -> Result<Curve> {
    let cols = read_columns(path, &["pressure_kpa", value])?;
    Ok(Curve {
        pressure_kpa: cols[0].clone(),
        value: cols[1].iter().map(|v| v * scale).collect(),
    })
}

const QUANTITIES: [(&str, &str, &str); 3] = [
    ("radius_mm", "Radius of curvature", "radius (mm)"),
    ("curvature_per_m", "Curvature", "curvature (1/m)"),
    ("bending_angle_deg", "Bending angle", "bending angle (deg)"),
];

/// Runs `bendscope compare`.
pub fn run(args: &CompareArgs) -> Result<u8> {
    let per_video = args.measured.join("per_video.csv");
    let steps = args.fem.join("steps.csv");
    for (p, what) in [
        (&per_video, "bendscope process"),
        (&steps, "bendscope simulate"),
    ] {
        if !p.is_file() {
            return Err(anyhow!(
                "{} is missing: give the output folder of `{what}`",
                p.display()
            ));
        }
    }
    let mut pairs: Vec<(String, String, String, Curve, Curve)> = Vec::new();
    for (name, title, axis) in QUANTITIES {
        pairs.push((
            name.into(),
            title.into(),
            axis.into(),
            curve(&per_video, name, 1.0)?,
            curve(&steps, name, 1.0)?,
        ));
    }
    if let Some(force) = &args.force {
        let measured = curve(force, "force_g", N_PER_GF)?;
        let fem_force = args.fem.join("force.csv");
        if !fem_force.is_file() {
            return Err(anyhow!(
                "{} is missing: run bendscope simulate with --blocked to compare forces",
                fem_force.display()
            ));
        }
        pairs.push((
            "force_n".into(),
            "Blocked tip force".into(),
            "force (N)".into(),
            measured,
            curve(&fem_force, "force_n", 1.0)?,
        ));
    }
    std::fs::create_dir_all(&args.output)?;
    let mut results: Vec<QuantityComparison> = Vec::new();
    let mut summary = format!(
        "bendscope compare: measured {} vs simulated {}\nfits y = a p^b + c, compared on a common pressure grid\n\n",
        args.measured.display(),
        args.fem.display()
    );
    let mut failed = 0;
    for (name, title, axis, m, f) in &pairs {
        let c = match compare_quantity(name, m, f) {
            Ok(c) => c,
            Err(e @ bendscope::compare::CompareError::NoOverlap { .. }) => return Err(e.into()),
            Err(e) => {
                eprintln!("warning: {e}");
                failed += 1;
                continue;
            }
        };
        let _ = writeln!(
            summary,
            "{name:>18}: RMSE {:.4} ({:.2}% of the measured RMS), max |deviation| {:.4} at {:.1} kPa over {:.1}-{:.1} kPa",
            c.rmse,
            c.rmse_pct,
            c.max_abs_deviation,
            c.max_deviation_at_kpa,
            c.grid_kpa[0],
            c.grid_kpa[c.grid_kpa.len() - 1]
        );
        let stem = args.output.join("plots").join(
            name.trim_end_matches("_mm")
                .trim_end_matches("_per_m")
                .trim_end_matches("_deg")
                .trim_end_matches("_n"),
        );
        plot_xy(
            &stem,
            &format!("{title}: measured vs FEM"),
            "pressure (kPa)",
            axis,
            &[
                Series {
                    label: "measured",
                    points: m
                        .pressure_kpa
                        .iter()
                        .copied()
                        .zip(m.value.iter().copied())
                        .collect(),
                    line: false,
                },
                Series {
                    label: "measured fit",
                    points: c
                        .grid_kpa
                        .iter()
                        .copied()
                        .zip(c.measured.iter().copied())
                        .collect(),
                    line: true,
                },
                Series {
                    label: "FEM",
                    points: f
                        .pressure_kpa
                        .iter()
                        .copied()
                        .zip(f.value.iter().copied())
                        .collect(),
                    line: false,
                },
                Series {
                    label: "FEM fit",
                    points: c
                        .grid_kpa
                        .iter()
                        .copied()
                        .zip(c.fem.iter().copied())
                        .collect(),
                    line: true,
                },
            ],
        )?;
        results.push(c);
    }
    if let Some(first) = results.first() {
        let mut cols = vec![Column::num(
            "pressure_kpa",
            5,
            first.grid_kpa.iter().copied(),
        )];
        for c in &results {
            cols.push(Column::num(
                format!("{}_measured", c.name),
                5,
                c.measured.iter().copied(),
            ));
            cols.push(Column::num(
                format!("{}_fem", c.name),
                5,
                c.fem.iter().copied(),
            ));
            cols.push(Column::num(
                format!("{}_deviation", c.name),
                5,
                c.fem.iter().zip(&c.measured).map(|(f, m)| f - m),
            ));
        }
        // Quantities share the grid only when their ranges agree; radius, curvature and
        // angle come from the same two tables, so they do; force may not.
        if !results.iter().all(|c| c.grid_kpa == first.grid_kpa) {
            cols.truncate(1 + 3 * 3);
        }
        write_csv(&args.output.join("compare.csv"), &cols)?;
    }
    write_json(&args.output.join("compare.json"), &results)?;
    write_atomic(&args.output.join("summary.txt"), summary.as_bytes())?;
    super::out!("{summary}-> {}", args.output.display());
    Ok(if failed == 0 { EXIT_OK } else { EXIT_PARTIAL })
}
