//! The study's report.html: warnings and flags, the sessions, the table of means and
//! spreads, repeatability, fits, the FEM comparison and the plots, in the style of the
//! session page ([`crate::report::html`]), self-contained.

use std::fmt::Write as _;
use std::path::Path;

use crate::io::write_atomic;
use crate::report::html::{escape, num, page_start, plot_figure};

use super::analyse::Analysis;
use super::config::{StudyError, FITTED, QUANTITIES};
use super::load::Study;
use super::stats::{BAND_LEVEL, OUTLIER_LEVEL};

fn list(h: &mut String, title: &str, items: &[String]) {
    if items.is_empty() {
        return;
    }
    let _ = writeln!(h, "<h2>{title}</h2>\n<ul>");
    for i in items {
        let _ = writeln!(h, "<li>{}</li>", escape(i));
    }
    h.push_str("</ul>\n");
}

/// A mean ± std cell (the std left out where it is not defined).
fn mean_std(mean: f64, std: f64, digits: usize) -> String {
    if std.is_nan() {
        num(mean, digits)
    } else {
        format!("{} ± {}", num(mean, digits), num(std, digits))
    }
}

/// The report's HTML.
pub fn study_report_html(
    out: &Path,
    study: &Study,
    a: &Analysis,
    plots: &[String],
    notes: &[String],
) -> String {
    let mut h = page_start("bendscope study");
    let _ = writeln!(
        h,
        "<p>{} sample(s), {} session(s). Files: study.csv, repeatability.csv, fits.json{}, plots/.</p>",
        study.samples.len(),
        study.samples.iter().map(|s| s.sessions.len()).sum::<usize>(),
        if study.fem.is_empty() { "" } else { ", fem.csv" }
    );
    list(&mut h, "Warnings", &a.warnings);
    list(&mut h, "Notes", notes);
    h.push_str("<h2>Samples</h2>\n<table><tr><th class=\"l\">sample</th><th class=\"l\">session</th><th>measured rows</th><th>markers</th><th>marker line (mm)</th></tr>\n");
    for s in &study.samples {
        for x in &s.sessions {
            let _ = writeln!(
                h,
                "<tr><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                escape(&s.name),
                escape(&x.label()),
                x.rows.len(),
                x.markers.map_or(String::new(), |m| m.to_string()),
                num(x.length_mm.unwrap_or(f64::NAN), 1)
            );
        }
    }
    h.push_str("</table>\n<h2>Mean ± std over sessions</h2>\n<p>One value per session per pressure (the mean of its videos there); std with n − 1, empty where n = 1.</p>\n<table><tr><th class=\"l\">sample</th><th>pressure (kPa)</th><th>n</th>");
    for (_, label) in &QUANTITIES {
        let _ = write!(h, "<th>{}</th>", escape(label));
    }
    h.push_str("</tr>\n");
    for r in &a.rows {
        let _ = write!(
            h,
            "<tr><td class=\"l\">{}</td><td>{}</td><td>{}</td>",
            escape(&r.sample),
            num(r.pressure_kpa, 2),
            r.n
        );
        for s in &r.stats {
            let _ = write!(h, "<td>{}</td>", mean_std(s.mean, s.std, 3));
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n<h2>Repeatability</h2>\n<p>Coefficient of variation (std / mean, %): <i>runs</i> across the sessions of a sample, <i>samples</i> across the samples' means.</p>\n<table><tr><th class=\"l\">scope</th><th class=\"l\">sample</th><th>pressure (kPa)</th><th>n</th>");
    for (_, label) in &QUANTITIES[..FITTED] {
        let _ = write!(h, "<th>CV {} %</th>", escape(label));
    }
    h.push_str("</tr>\n");
    for r in &a.repeatability {
        let _ = write!(
            h,
            "<tr><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{}</td><td>{}</td>",
            r.scope,
            escape(&r.sample),
            num(r.pressure_kpa, 2),
            r.n
        );
        for v in &r.cv_pct {
            let _ = write!(h, "<td>{}</td>", num(*v, 2));
        }
        h.push_str("</tr>\n");
    }
    let _ = writeln!(
        h,
        "</table>\n<h2>Fits (y = a p<sup>b</sup> + c, p in kPa)</h2>\n<p>Over every session's mean at each pressure; the {:.0} % confidence band of the curve (delta method, Student's t) is in fits.json (its half-width at mid-range below). A session is flagged when one of its values lies outside the {:.0} % prediction interval of the other sessions of its sample (three or more sessions).</p>",
        100.0 * BAND_LEVEL,
        100.0 * OUTLIER_LEVEL
    );
    h.push_str("<table><tr><th class=\"l\">sample</th><th class=\"l\">quantity</th><th>a</th><th>b</th><th>c</th><th>R²</th><th>n</th><th>band half-width at mid-range</th></tr>\n");
    for f in &a.fits {
        let half = f.band.as_ref().map_or(f64::NAN, |b| {
            let k = b.pressure_kpa.len() / 2;
            0.5 * (b.upper[k] - b.lower[k])
        });
        let _ = writeln!(
            h,
            "<tr><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{:.6}</td><td>{:.4}</td><td>{:.4}</td><td>{:.5}</td><td>{}</td><td>{}</td></tr>",
            escape(&f.sample),
            f.quantity,
            f.fit.a,
            f.fit.b,
            f.fit.c,
            f.fit.r_squared,
            f.fit.n,
            num(half, 4)
        );
    }
    h.push_str("</table>\n");
    if !a.fem.is_empty() {
        h.push_str("<h2>FEM against the measurements</h2>\n<p>Fits compared on a common grid; deviation = simulated − measured.</p>\n<table><tr><th class=\"l\">model</th><th class=\"l\">sample</th><th class=\"l\">quantity</th><th>RMSE</th><th>RMSE %</th><th>max |deviation|</th><th>at (kPa)</th></tr>\n");
        for f in &a.fem {
            let _ = writeln!(
                h,
                "<tr><td class=\"l\">{}</td><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                escape(&f.model),
                escape(&f.sample),
                f.quantity,
                num(f.rmse, 4),
                num(f.rmse_pct, 2),
                num(f.max_abs_deviation, 4),
                num(f.max_deviation_at_kpa, 1)
            );
        }
        h.push_str("</table>\n");
    }
    h.push_str("<h2>Plots</h2>\n");
    for stem in plots {
        h.push_str(&plot_figure(out, stem));
        h.push('\n');
    }
    h.push_str("</body></html>\n");
    h
}

/// Writes report.html atomically.
pub fn write_report(
    path: &Path,
    out: &Path,
    study: &Study,
    a: &Analysis,
    plots: &[String],
    notes: &[String],
) -> Result<(), StudyError> {
    write_atomic(
        path,
        study_report_html(out, study, a, plots, notes).as_bytes(),
    )
    .map_err(|e| StudyError::Output {
        why: crate::io::with_path(path, &e),
    })
}
