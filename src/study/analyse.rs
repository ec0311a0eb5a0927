//! The analysis of a loaded study: each session's mean at each pressure set point, the
//! summaries per sample and pooled, repeatability, power-law fits with confidence bands,
//! the FEM against each sample and the pool, and the sessions that disagree with the
//! others of their sample.

use serde::Serialize;

use crate::compare::{compare_quantity, Curve, GRID_POINTS};
use crate::fit::{fit_power_law_with_covariance, PowerLawFit};

use super::config::{FITTED, POOLED, QUANTITIES};
use super::load::{SampleData, Study};
use super::stats::{
    confidence_band, outlier_check, set_point_of, set_points, Band, Summary, OUTLIER_LEVEL,
};

/// One session's values at one set point: the means of its measured rows there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SessionPoint {
    /// Mean pressure of those rows, kPa.
    pub pressure_kpa: f64,
    /// Mean of each of [`QUANTITIES`] over the rows (finite cells only; NaN when none).
    pub values: [f64; 5],
}

/// A row of study.csv: one sample (or the pool) at one set point.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyRow {
    /// Sample name, or [`POOLED`].
    pub sample: String,
    /// Mean pressure of the sessions' points, kPa.
    pub pressure_kpa: f64,
    /// Sessions with a measured row here.
    pub n: usize,
    /// Summary of the per-session values of each of [`QUANTITIES`].
    pub stats: [Summary; 5],
}

/// A row of repeatability.csv.
#[derive(Debug, Clone, PartialEq)]
pub struct RepeatRow {
    /// `runs` (across the sessions of one sample) or `samples` (across the samples'
    /// means).
    pub scope: &'static str,
    /// The sample (or [`POOLED`] for scope `samples`).
    pub sample: String,
    /// Pressure, kPa.
    pub pressure_kpa: f64,
    /// Values the coefficient of variation is over.
    pub n: usize,
    /// Coefficient of variation, %, of the fitted quantities (NaN when n < 2).
    pub cv_pct: [f64; FITTED],
}

/// A power law of one quantity of one sample (or the pool), over its per-session values.
#[derive(Debug, Clone, Serialize)]
pub struct FitResult {
    /// Sample, or [`POOLED`].
    pub sample: String,
    /// Quantity (per_video.csv column).
    pub quantity: &'static str,
    /// The fit y = a p^b + c (p in kPa).
    pub fit: PowerLawFit,
    /// Covariance of (a, b, c); absent with 3 points.
    pub covariance: Option<[[f64; 3]; 3]>,
    /// Confidence band of the curve over the fitted pressures; absent without covariance.
    pub band: Option<Band>,
}

/// One simulation against one sample's (or the pool's) means for one quantity.
#[derive(Debug, Clone, Serialize)]
pub struct FemResult {
    /// The simulation's name.
    pub model: String,
    /// Sample, or [`POOLED`].
    pub sample: String,
    /// Quantity.
    pub quantity: &'static str,
    /// RMS of simulated − measured fit on the common grid (quantity's unit).
    pub rmse: f64,
    /// RMSE relative to the RMS of the measured fit, %.
    pub rmse_pct: f64,
    /// Largest |simulated − measured| on the grid.
    pub max_abs_deviation: f64,
    /// Where it is, kPa.
    pub max_deviation_at_kpa: f64,
    /// The grid's range, kPa.
    pub from_kpa: f64,
    /// The grid's range, kPa.
    pub to_kpa: f64,
}

/// Everything the outputs show.
#[derive(Debug, Clone)]
pub struct Analysis {
    /// Pressure set points, kPa, ascending.
    pub set_points: Vec<f64>,
    /// Per sample, per session, per set point: the session's point there, if measured.
    pub points: Vec<Vec<Vec<Option<SessionPoint>>>>,
    /// study.csv: samples in order, each by set point, then the pooled rows.
    pub rows: Vec<StudyRow>,
    /// repeatability.csv.
    pub repeatability: Vec<RepeatRow>,
    /// Fits, per sample then pooled, radius / curvature / angle each.
    pub fits: Vec<FitResult>,
    /// FEM comparisons.
    pub fem: Vec<FemResult>,
    /// Sessions that disagree, samples with one session, FEM comparisons that failed.
    pub warnings: Vec<String>,
    /// Rows without spread, missing set points, fits that could not be made.
    pub notes: Vec<String>,
}

/// The points of one session at each set point.
fn session_points(rows: &[super::load::Row], set_points: &[f64]) -> Vec<Option<SessionPoint>> {
    let mut groups: Vec<Vec<&super::load::Row>> = vec![Vec::new(); set_points.len()];
    for r in rows {
        if let Some(k) = set_point_of(set_points, r.pressure_kpa) {
            groups[k].push(r);
        }
    }
    groups
        .into_iter()
        .map(|g| {
            (!g.is_empty()).then(|| {
                let mut values = [f64::NAN; 5];
                for (q, v) in values.iter_mut().enumerate() {
                    *v = Summary::of(&g.iter().map(|r| r.values[q]).collect::<Vec<_>>()).mean;
                }
                SessionPoint {
                    pressure_kpa: g.iter().map(|r| r.pressure_kpa).sum::<f64>() / g.len() as f64,
                    values,
                }
            })
        })
        .collect()
}

/// The study row of `points` (the sessions' points at one set point), if any.
fn row_of(sample: &str, points: &[SessionPoint]) -> Option<StudyRow> {
    if points.is_empty() {
        return None;
    }
    let mut stats = [Summary::of(&[]); 5];
    for (q, s) in stats.iter_mut().enumerate() {
        *s = Summary::of(&points.iter().map(|p| p.values[q]).collect::<Vec<_>>());
    }
    Some(StudyRow {
        sample: sample.to_string(),
        pressure_kpa: points.iter().map(|p| p.pressure_kpa).sum::<f64>() / points.len() as f64,
        n: points.len(),
        stats,
    })
}

/// A pressure for messages.
fn kpa(p: f64) -> String {
    format!("{} kPa", (p * 100.0).round() / 100.0)
}

/// The power laws of the fitted quantities over `points` (pressure > 0, finite value).
fn fit_points(sample: &str, points: &[SessionPoint], notes: &mut Vec<String>) -> Vec<FitResult> {
    let mut out = Vec::new();
    for (q, (name, _)) in QUANTITIES[..FITTED].iter().enumerate() {
        let (x, y): (Vec<f64>, Vec<f64>) = points
            .iter()
            .filter(|p| p.pressure_kpa > 0.0 && p.values[q].is_finite())
            .map(|p| (p.pressure_kpa, p.values[q]))
            .unzip();
        match fit_power_law_with_covariance(&x, &y) {
            Ok((fit, cov)) => {
                let range = x
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                        (a.min(*v), b.max(*v))
                    });
                out.push(FitResult {
                    sample: sample.to_string(),
                    quantity: name,
                    fit,
                    covariance: cov.map(|c| {
                        [
                            [c[(0, 0)], c[(0, 1)], c[(0, 2)]],
                            [c[(1, 0)], c[(1, 1)], c[(1, 2)]],
                            [c[(2, 0)], c[(2, 1)], c[(2, 2)]],
                        ]
                    }),
                    band: cov.map(|c| confidence_band(&fit, &c, range, GRID_POINTS)),
                });
            }
            Err(e) => notes.push(format!("{sample} {name}: no power law: {e}")),
        }
    }
    out
}

/// Sessions of `sample` (three or more) with a value outside the [`OUTLIER_LEVEL`]
/// prediction interval of the other sessions ([`outlier_check`]) for radius, curvature
/// or angle at a set point above 0 kPa: one warning per such session, naming its worst
/// case.
fn disagreeing_sessions(
    sample: &SampleData,
    points: &[Vec<Option<SessionPoint>>],
    set_points: &[f64],
) -> Vec<String> {
    let mut out = Vec::new();
    for (i, session) in sample.sessions.iter().enumerate() {
        // (t / limit, message) of each finding.
        let mut found: Vec<(f64, String)> = Vec::new();
        for (q, (name, _)) in QUANTITIES[..FITTED].iter().enumerate() {
            let value = |p: &Option<SessionPoint>| {
                p.filter(|p| p.pressure_kpa > 0.0)
                    .map_or(f64::NAN, |p| p.values[q])
            };
            let own: Vec<f64> = points[i].iter().map(value).collect();
            let others: Vec<Vec<f64>> = (0..set_points.len())
                .map(|k| {
                    points
                        .iter()
                        .enumerate()
                        .filter(|(j, _)| *j != i)
                        .map(|(_, s)| value(&s[k]))
                        .filter(|v| v.is_finite())
                        .collect()
                })
                .collect();
            let Some(check) = outlier_check(&own, &others) else {
                continue;
            };
            for (k, t) in check.t.iter().enumerate() {
                let Some(t) = t.filter(|t| *t > check.limit) else {
                    continue;
                };
                let o = Summary::of(&others[k]);
                found.push((
                    t / check.limit,
                    format!(
                        "{name} {:.4} at {} where the other {} sessions give {:.4} ± {:.4}; t = {:.1} > {:.2}",
                        own[k],
                        kpa(set_points[k]),
                        others[k].len(),
                        o.mean,
                        o.std,
                        t,
                        check.limit
                    ),
                ));
            }
        }
        if let Some((_, worst)) = found.iter().max_by(|a, b| a.0.total_cmp(&b.0)) {
            out.push(format!(
                "sample {}: session {} disagrees with the other sessions beyond their spread ({} value(s) outside the {:.1} % prediction interval of the others; worst: {worst}): check it (another actuator, a leak, a moved camera) or leave it out",
                sample.name,
                session.label(),
                found.len(),
                100.0 * OUTLIER_LEVEL
            ));
        }
    }
    out
}

/// Analyses a loaded study.
pub fn analyse(study: &Study) -> Analysis {
    let all_pressures: Vec<f64> = study
        .samples
        .iter()
        .flat_map(|s| &s.sessions)
        .flat_map(|s| s.rows.iter().map(|r| r.pressure_kpa))
        .collect();
    let sp = set_points(&all_pressures);
    let points: Vec<Vec<Vec<Option<SessionPoint>>>> = study
        .samples
        .iter()
        .map(|s| {
            s.sessions
                .iter()
                .map(|x| session_points(&x.rows, &sp))
                .collect()
        })
        .collect();
    let (mut warnings, mut notes) = (Vec::new(), Vec::new());
    let mut rows = Vec::new();
    let mut repeatability = Vec::new();
    let mut fits = Vec::new();
    // Per sample.
    for (s, sample) in study.samples.iter().enumerate() {
        if sample.sessions.len() == 1 {
            warnings.push(format!(
                "sample {} has one session ({}): its spread is not defined (std and CV left empty); add repeat runs to measure it",
                sample.name,
                sample.sessions[0].label()
            ));
        }
        for k in 0..sp.len() {
            let here: Vec<SessionPoint> = points[s].iter().filter_map(|x| x[k]).collect();
            if !here.is_empty() && here.len() < sample.sessions.len() {
                let missing: Vec<String> = sample
                    .sessions
                    .iter()
                    .zip(&points[s])
                    .filter(|(_, x)| x[k].is_none())
                    .map(|(x, _)| x.label())
                    .collect();
                notes.push(format!(
                    "sample {} at {}: no measured row in {} (n = {} of {})",
                    sample.name,
                    kpa(sp[k]),
                    missing.join(", "),
                    here.len(),
                    sample.sessions.len()
                ));
            }
            if let Some(r) = row_of(&sample.name, &here) {
                repeatability.push(RepeatRow {
                    scope: "runs",
                    sample: sample.name.clone(),
                    pressure_kpa: r.pressure_kpa,
                    n: r.n,
                    cv_pct: std::array::from_fn(|q| r.stats[q].cv_pct()),
                });
                rows.push(r);
            }
        }
        let flat: Vec<SessionPoint> = points[s].iter().flatten().flatten().copied().collect();
        fits.extend(fit_points(&sample.name, &flat, &mut notes));
        if sample.sessions.len() >= 3 {
            warnings.extend(disagreeing_sessions(sample, &points[s], &sp));
        }
    }
    // Pooled, and across the samples' means.
    for k in 0..sp.len() {
        let here: Vec<SessionPoint> = points.iter().flatten().filter_map(|x| x[k]).collect();
        if let Some(r) = row_of(POOLED, &here) {
            rows.push(r);
        }
        // Each sample's (pressure, means) here.
        let means: Vec<(f64, [f64; 5])> = points
            .iter()
            .filter_map(|sessions| {
                let here: Vec<SessionPoint> = sessions.iter().filter_map(|x| x[k]).collect();
                row_of("", &here).map(|r| (r.pressure_kpa, r.stats.map(|s| s.mean)))
            })
            .collect();
        if !means.is_empty() {
            repeatability.push(RepeatRow {
                scope: "samples",
                sample: POOLED.to_string(),
                pressure_kpa: means.iter().map(|m| m.0).sum::<f64>() / means.len() as f64,
                n: means.len(),
                cv_pct: std::array::from_fn(|q| {
                    Summary::of(&means.iter().map(|m| m.1[q]).collect::<Vec<_>>()).cv_pct()
                }),
            });
        }
    }
    let pooled: Vec<SessionPoint> = points
        .iter()
        .flatten()
        .flatten()
        .flatten()
        .copied()
        .collect();
    fits.extend(fit_points(POOLED, &pooled, &mut notes));
    let single: Vec<String> = rows
        .iter()
        .filter(|r| r.n == 1)
        .map(|r| format!("{} {}", r.sample, kpa(r.pressure_kpa)))
        .collect();
    if !single.is_empty() {
        notes.push(format!(
            "n = 1 (one session) at {} row(s): the spread is not defined there, so std and CV are left empty ({})",
            single.len(),
            single.join(", ")
        ));
    }
    let samples_with_two: Vec<&str> = study
        .samples
        .iter()
        .filter(|s| s.sessions.len() == 2)
        .map(|s| s.name.as_str())
        .collect();
    if !samples_with_two.is_empty() {
        notes.push(format!(
            "sessions that disagree are looked for among 3 or more sessions of a sample; sample(s) {} have 2",
            samples_with_two.join(", ")
        ));
    }
    let fem = compare_fem(study, &rows, &mut warnings);
    Analysis {
        set_points: sp,
        points,
        rows,
        repeatability,
        fits,
        fem,
        warnings,
        notes,
    }
}

/// Each simulation against each sample's means and the pool's ([`compare_quantity`]).
fn compare_fem(study: &Study, rows: &[StudyRow], warnings: &mut Vec<String>) -> Vec<FemResult> {
    let mut names: Vec<&str> = study.samples.iter().map(|s| s.name.as_str()).collect();
    names.push(POOLED);
    let mut out = Vec::new();
    for model in &study.fem {
        for sample in &names {
            for (q, (name, _)) in QUANTITIES[..FITTED].iter().enumerate() {
                let (pressure_kpa, value) = rows
                    .iter()
                    .filter(|r| r.sample == *sample && r.stats[q].mean.is_finite())
                    .map(|r| (r.pressure_kpa, r.stats[q].mean))
                    .unzip();
                let measured = Curve {
                    pressure_kpa,
                    value,
                };
                match compare_quantity(name, &measured, &model.curves[q]) {
                    Ok(c) => out.push(FemResult {
                        model: model.name.clone(),
                        sample: sample.to_string(),
                        quantity: name,
                        rmse: c.rmse,
                        rmse_pct: c.rmse_pct,
                        max_abs_deviation: c.max_abs_deviation,
                        max_deviation_at_kpa: c.max_deviation_at_kpa,
                        from_kpa: c.grid_kpa[0],
                        to_kpa: c.grid_kpa[c.grid_kpa.len() - 1],
                    }),
                    Err(e) => warnings.push(format!(
                        "FEM {} vs sample {sample}, {name}: not compared: {e}",
                        model.name
                    )),
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::load::{Row, SessionData};

    fn session(name: &str, rows: &[(f64, f64)]) -> SessionData {
        SessionData {
            listed: name.into(),
            out: name.into(),
            rows: rows
                .iter()
                .map(|&(p, r)| Row {
                    pressure_kpa: p,
                    values: [r, 1000.0 / r, 3000.0 / r, f64::NAN, p],
                })
                .collect(),
            markers: Some(8),
            length_mm: Some(100.0),
        }
    }

    /// Two samples: A of three sessions (the third far off at 40 kPa), B of one. Rows,
    /// pooled rows and the flag are checked against hand values.
    #[test]
    fn rows_pool_and_flag_by_hand() {
        let study = Study {
            samples: vec![
                SampleData {
                    name: "A".into(),
                    sessions: vec![
                        // Two videos at 20 kPa in the first session: their mean counts.
                        session("a1", &[(20.0, 100.0), (20.05, 102.0), (40.0, 60.0)]),
                        session("a2", &[(20.0, 103.0), (40.1, 60.5)]),
                        session("a3", &[(19.98, 99.0), (40.0, 80.0)]),
                    ],
                },
                SampleData {
                    name: "B".into(),
                    sessions: vec![session("b1", &[(20.0, 150.0), (40.0, 80.0)])],
                },
            ],
            fem: vec![],
            notes: vec![],
        };
        let a = analyse(&study);
        assert_eq!(a.set_points.len(), 2);
        let row = |s: &str, k: usize| a.rows.iter().filter(|r| r.sample == s).nth(k).unwrap();
        let r = row("A", 0);
        assert_eq!(r.n, 3);
        let s = Summary::of(&[101.0, 103.0, 99.0]);
        assert_eq!(r.stats[0], s);
        assert!((r.pressure_kpa - (20.025 + 20.0 + 19.98) / 3.0).abs() < 1e-12);
        // The curvature: each session's mean of its videos' curvatures, then the mean.
        let a1 = (1000.0 / 100.0 + 1000.0 / 102.0) / 2.0;
        let expected = (a1 + 1000.0 / 103.0 + 1000.0 / 99.0) / 3.0;
        assert!(
            (r.stats[1].mean - expected).abs() < 1e-12,
            "{:?}",
            r.stats[1]
        );
        assert!(r.stats[3].mean.is_nan() && r.stats[3].n == 0);
        let b = row("B", 1);
        assert_eq!((b.n, b.stats[0].mean), (1, 80.0));
        assert!(b.stats[0].std.is_nan());
        let pooled = row(POOLED, 1);
        assert_eq!(pooled.n, 4);
        assert_eq!(pooled.stats[0], Summary::of(&[60.0, 60.5, 80.0, 80.0]));
        // Across samples: the CV of the two samples' means.
        let across = a
            .repeatability
            .iter()
            .find(|r| r.scope == "samples")
            .unwrap();
        assert_eq!(across.n, 2);
        assert_eq!(across.cv_pct[0], Summary::of(&[101.0, 150.0]).cv_pct());
        // a3: 80 at 40 kPa against 60 and 60.5 is far off, but with the others'
        // relative spread (101 vs 103, 60 vs 60.5: 1.07 %, 2 dof) t = 25.1 stays under
        // the limit 31.6. B's one session is a warning; the n = 1 note is one line.
        assert!(a
            .warnings
            .iter()
            .any(|w| w.starts_with("sample B has one session (b1)")));
        assert_eq!(a.notes.iter().filter(|n| n.starts_with("n = 1")).count(), 1);
        assert!(
            !a.warnings.iter().any(|w| w.contains("disagrees")),
            "{:?}",
            a.warnings
        );
    }

    #[test]
    fn a_session_far_from_three_close_others_is_flagged() {
        let mk = |n: &str, r: f64| session(n, &[(20.0, r), (40.0, r / 2.0), (60.0, r / 3.0)]);
        let study = Study {
            samples: vec![SampleData {
                name: "A".into(),
                sessions: vec![
                    mk("a1", 100.0),
                    mk("a2", 100.4),
                    mk("a3", 99.8),
                    mk("a4", 130.0),
                ],
            }],
            fem: vec![],
            notes: vec![],
        };
        let a = analyse(&study);
        let flags: Vec<&String> = a
            .warnings
            .iter()
            .filter(|w| w.contains("disagrees"))
            .collect();
        assert_eq!(flags.len(), 1, "{flags:?}");
        assert!(
            flags[0].starts_with("sample A: session a4 disagrees"),
            "{}",
            flags[0]
        );
        // Fits: three distinct pressures, 12 points each for A and the pool.
        assert_eq!(a.fits.len(), 6);
        assert!(a.fits.iter().all(|f| f.fit.n == 12 && f.band.is_some()));
    }
}
