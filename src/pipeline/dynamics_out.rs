//! Writes what [`super::dynamics`] found: the branch columns of per_video.csv and
//! per_frame.csv, hysteresis.json, step_response.csv, the loop and step plots, and the
//! report's sections. A session without branches or steps has none of these, and an
//! earlier run's files of that kind are removed.

use std::path::Path;

use crate::report::html::Section;
use crate::report::{plot_xy, write_json, ErrorBars, Series};
use crate::table::{write_csv, Column};

use super::dynamics::{RowBranch, SessionDynamics, StepResults, PRESSURE_QUANTITY};
use super::error::PipelineError;
use super::records::VideoRecord;

/// The loops of a session whose pressure rises and falls.
pub const HYSTERESIS_JSON: &str = "hysteresis.json";

/// The step responses of a recording whose pressure log steps.
pub const STEP_RESPONSE_CSV: &str = "step_response.csv";

/// Stems (in plots/) of the dynamics plots; each has a .png, an .svg and a .pdf.
pub const DYNAMICS_PLOT_STEMS: [&str; 4] = [
    "hysteresis_angle",
    "hysteresis_radius",
    "step_response_angle",
    "step_response_normalised",
];

/// The `branch` (loading / unloading) and `cycle` columns for rows labelled `labels`;
/// none when `labels` is empty (one branch).
pub fn branch_columns(labels: &[Option<RowBranch>]) -> Vec<Column> {
    if labels.is_empty() {
        return vec![];
    }
    vec![
        Column::text(
            "branch",
            labels
                .iter()
                .map(|l| l.map(|l| l.direction.to_string()).unwrap_or_default()),
        ),
        Column::num(
            "cycle",
            0,
            labels
                .iter()
                .map(|l| l.map_or(f64::NAN, |l| l.cycle as f64)),
        ),
    ]
}

/// Removes `path` when it exists.
fn remove_stale(path: &Path) -> Result<(), PipelineError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(PipelineError::Write {
            path: path.to_path_buf(),
            source: e,
        }),
        _ => Ok(()),
    }
}

/// Writes hysteresis.json (or removes an earlier one).
pub fn write_hysteresis_json(out: &Path, d: &SessionDynamics) -> Result<(), PipelineError> {
    let path = out.join(HYSTERESIS_JSON);
    match &d.hysteresis {
        Some(h) => Ok(write_json(&path, h)?),
        None => remove_stale(&path),
    }
}

/// Writes step_response.csv (or removes an earlier one): one row per step and quantity.
pub fn write_step_response_csv(out: &Path, d: &SessionDynamics) -> Result<(), PipelineError> {
    let path = out.join(STEP_RESPONSE_CSV);
    let Some(s) = &d.steps else {
        return remove_stale(&path);
    };
    let rows = &s.rows;
    let f = |g: &dyn Fn(&super::dynamics::StepRow) -> f64| rows.iter().map(g).collect::<Vec<f64>>();
    write_csv(
        &path,
        &[
            Column::int("step", rows.iter().map(|r| r.step.step as u64)),
            Column::text("quantity", rows.iter().map(|r| r.quantity.to_string())),
            Column::num("onset_s", 4, f(&|r| r.step.onset_s)),
            Column::num("from_kpa", 3, f(&|r| r.step.from_kpa())),
            Column::num("to_kpa", 3, f(&|r| r.step.to_kpa())),
            Column::num("initial", 4, f(&|r| r.response.initial)),
            Column::num("final", 4, f(&|r| r.response.final_value)),
            Column::num("rise_time_s", 4, f(&|r| r.response.rise_time_s)),
            Column::num("t10_s", 4, f(&|r| r.response.t10_s)),
            Column::num("t50_s", 4, f(&|r| r.response.t50_s)),
            Column::num("t90_s", 4, f(&|r| r.response.t90_s)),
            Column::num("delay_s", 4, f(&|r| r.delay_s)),
            Column::num("tau_s", 4, f(&|r| r.fit().map_or(f64::NAN, |f| f.tau_s))),
            Column::num("t0_s", 4, f(&|r| r.fit().map_or(f64::NAN, |f| f.t0_s))),
            Column::num("fit_rms", 4, f(&|r| r.fit().map_or(f64::NAN, |f| f.rms))),
            Column::num("overshoot_pct", 2, f(&|r| r.response.overshoot_pct)),
            Column::num("settling_time_s", 4, f(&|r| r.response.settling_time_s)),
            Column::num("pressure_rise_time_s", 4, f(&|r| r.pressure_rise_time_s)),
            Column::int(
                "samples",
                rows.iter()
                    .map(|r| (r.response.samples_before + r.response.samples_after) as u64),
            ),
        ],
    )?;
    Ok(())
}

/// Draws the loop (angle and radius against pressure, a series per branch) and the step
/// responses; removes the plots of kinds this session does not have. Returns the stems
/// drawn, relative to OUT.
pub fn write_dynamics_plots(
    out: &Path,
    videos: &[VideoRecord],
    d: &SessionDynamics,
    bars: ErrorBars,
) -> Result<Vec<String>, PipelineError> {
    let plots = out.join("plots");
    let mut drawn = Vec::new();
    let mut draw =
        |stem: &str, title: &str, x: &str, y: &str, s: &[Series]| -> Result<(), PipelineError> {
            if plot_xy(&plots.join(stem), title, x, y, s)? {
                drawn.push(format!("plots/{stem}"));
            }
            Ok(())
        };
    if d.hysteresis.is_some() {
        let mut branches: Vec<RowBranch> = d.rows.iter().flatten().copied().collect();
        branches.dedup_by_key(|b| b.branch);
        let labels: Vec<String> = branches
            .iter()
            .map(|b| format!("cycle {} {} ± {}", b.cycle, b.direction, bars.label()))
            .collect();
        let series = |y: fn(&VideoRecord) -> f64, e: fn(&VideoRecord) -> f64| -> Vec<Series> {
            branches
                .iter()
                .zip(&labels)
                .map(|(b, label)| {
                    let (points, errors): (Vec<(f64, f64)>, Vec<f64>) = videos
                        .iter()
                        .zip(&d.rows)
                        .filter(|(v, r)| {
                            v.status.is_measured() && r.is_some_and(|r| r.branch == b.branch)
                        })
                        .map(|(v, _)| {
                            let bar = bars.half_height(e(v), v.stats.frames_used);
                            ((v.pressure_kpa, y(v)), bar)
                        })
                        .unzip();
                    Series {
                        label,
                        points,
                        line: true,
                        errors: Some(errors),
                    }
                })
                .collect()
        };
        draw(
            DYNAMICS_PLOT_STEMS[0],
            "Bending angle vs pressure: loading and unloading",
            "pressure (kPa)",
            "bending angle (deg)",
            &series(
                |v| v.stats.bending_angle_deg,
                |v| v.stats.bending_angle_deg_std,
            ),
        )?;
        draw(
            DYNAMICS_PLOT_STEMS[1],
            "Radius vs pressure: loading and unloading",
            "pressure (kPa)",
            "radius (mm)",
            &series(|v| v.stats.radius_mm, |v| v.stats.radius_mm_std),
        )?;
    }
    if let Some(s) = &d.steps {
        draw_steps(s, &mut draw)?;
    }
    for stem in DYNAMICS_PLOT_STEMS {
        if !drawn.iter().any(|d| d.ends_with(stem)) {
            for ext in crate::report::PLOT_EXTENSIONS {
                remove_stale(&plots.join(format!("{stem}.{ext}")))?;
            }
        }
    }
    Ok(drawn)
}

type Draw<'a> = dyn FnMut(&str, &str, &str, &str, &[Series]) -> Result<(), PipelineError> + 'a;

/// The bending angle over time with each step's fitted first-order response, and every
/// quantity normalised (0 before the step, 1 after) against the time since the onset.
fn draw_steps(s: &StepResults, draw: &mut Draw) -> Result<(), PipelineError> {
    let mut fitted: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for r in s.rows.iter().filter(|r| r.quantity == "bending_angle_deg") {
        if let Some(f) = r.fit() {
            // Over the step's window where there are frames.
            let (w0, w1) = s.windows[r.step.step - 1];
            let inside = || {
                s.angle_series
                    .iter()
                    .map(|p| p.0)
                    .filter(|t| *t >= w0 && *t <= w1)
            };
            let a = inside().fold(f64::INFINITY, f64::min);
            let b = inside().fold(f64::NEG_INFINITY, f64::max);
            if b <= a {
                continue;
            }
            let curve = (0..=200)
                .map(|i| a + (b - a) * i as f64 / 200.0)
                .map(|t| (t, f.eval(t)))
                .collect();
            fitted.push((format!("first-order fit, step {}", r.step.step), curve));
        }
    }
    let mut series = vec![Series {
        label: "measured",
        points: s.angle_series.clone(),
        line: false,
        errors: None,
    }];
    series.extend(fitted.iter().map(|(label, pts)| Series {
        label,
        points: pts.clone(),
        line: true,
        errors: None,
    }));
    draw(
        DYNAMICS_PLOT_STEMS[2],
        "Bending angle over time and the fitted step responses",
        "time (s)",
        "bending angle (deg)",
        &series,
    )?;
    let labels: Vec<String> = s
        .normalised
        .iter()
        .map(|(q, _)| match *q {
            PRESSURE_QUANTITY => "pressure (log)".to_string(),
            q => q.replace('_', " "),
        })
        .collect();
    let series: Vec<Series> = s
        .normalised
        .iter()
        .zip(&labels)
        .map(|((q, pts), label)| {
            let mut pts = pts.clone();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            Series {
                label,
                points: pts,
                line: *q == PRESSURE_QUANTITY,
                errors: None,
            }
        })
        .collect();
    draw(
        DYNAMICS_PLOT_STEMS[3],
        "Step responses, normalised (0 before the step, 1 after)",
        "time since the step's onset (s)",
        "normalised response",
        &series,
    )
}

fn num(v: f64, digits: usize) -> String {
    if v.is_finite() {
        format!("{v:.digits$}")
    } else {
        String::new()
    }
}

/// The report's sections: the loops and the step responses, each with its plots.
pub fn report_sections(d: &SessionDynamics, plots: &[String]) -> Vec<Section> {
    let mine = |prefix: &str| -> Vec<String> {
        plots
            .iter()
            .filter(|p| p.starts_with(&format!("plots/{prefix}")))
            .cloned()
            .collect()
    };
    let mut out = Vec::new();
    if let Some(h) = &d.hysteresis {
        let mut lines = vec![format!(
            "{} branches (turning points where the pressure reverses by more than {:.2} kPa); hysteresis.json, and per-branch fits in fit.json.",
            h.branches.len(),
            h.reversal_kpa
        )];
        for f in &d.branch_fits {
            lines.push(match &f.bending_angle_deg_vs_kpa {
                Some(p) => format!(
                    "cycle {} {}: bending angle (deg) = {:.6} p^{:.4} + {:.4}, R² {:.5}",
                    f.cycle, f.direction, p.a, p.b, p.c, p.r_squared
                ),
                None => format!("cycle {} {}: no angle fit", f.cycle, f.direction),
            });
        }
        let rows = h
            .loops
            .iter()
            .map(|l| {
                let a = l.bending_angle_deg;
                let r = l.radius_mm;
                vec![
                    l.cycle.to_string(),
                    a.map_or(String::new(), |m| {
                        format!("{}..{}", num(m.from_kpa, 1), num(m.to_kpa, 1))
                    }),
                    a.map_or(String::new(), |m| num(m.area, 1)),
                    a.map_or(String::new(), |m| num(m.max_difference, 2)),
                    a.map_or(String::new(), |m| num(m.at_kpa, 1)),
                    r.map_or(String::new(), |m| num(m.area, 1)),
                    r.map_or(String::new(), |m| num(m.max_difference, 2)),
                ]
            })
            .collect();
        out.push(Section {
            title: "Hysteresis".into(),
            lines,
            table: Some((
                [
                    "cycle",
                    "common range (kPa)",
                    "angle loop area (deg kPa)",
                    "largest angle difference (deg)",
                    "at (kPa)",
                    "radius loop area (mm kPa)",
                    "largest radius difference (mm)",
                ]
                .map(String::from)
                .to_vec(),
                rows,
            )),
            plots: mine("hysteresis_"),
        });
    }
    if let Some(s) = &d.steps {
        let rows = s
            .rows
            .iter()
            .map(|r| {
                vec![
                    r.step.step.to_string(),
                    r.quantity.to_string(),
                    format!("{}..{}", num(r.step.from_kpa(), 1), num(r.step.to_kpa(), 1)),
                    num(r.response.rise_time_s, 3),
                    num(r.fit().map_or(f64::NAN, |f| f.tau_s), 3),
                    num(r.response.overshoot_pct, 1),
                    num(r.response.settling_time_s, 3),
                    num(r.delay_s, 3),
                ]
            })
            .collect();
        out.push(Section {
            title: "Step response".into(),
            lines: vec![
                "Per step and quantity (step_response.csv): 10-90% rise time, time constant of the first-order response y0 + dy (1 - exp(-(t - t0)/tau)) fitted by least squares, overshoot, 2% settling time from the onset (the logged pressure's 10% crossing), and the delay of the 50% crossing after the logged pressure's.".into(),
            ],
            table: Some((
                [
                    "step",
                    "quantity",
                    "kPa",
                    "rise 10-90% (s)",
                    "tau (s)",
                    "overshoot (%)",
                    "settling (s)",
                    "delay (s)",
                ]
                .map(String::from)
                .to_vec(),
                rows,
            )),
            plots: mine("step_response"),
        });
    }
    out
}
