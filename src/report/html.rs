//! `report.html`: one self-contained page per session (no external files, no scripts):
//! the per-video table, the power-law fits, the plots (their SVG inlined) and the QA
//! overlays (PNG as data URIs), so it can be mailed or archived alone and opened in any
//! browser.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use base64::Engine as _;

use crate::fit::PowerLawFit;
use crate::io::write_atomic;
use crate::segments::{Segment, SegmentStats};

use super::ReportError;

/// What the report shows, in the report's own terms: the measuring pipeline turns its
/// records, fits and provenance into these, so the report (which the FEM uses too)
/// depends on no measuring module.
pub struct SessionReport<'a> {
    /// Session name (the title).
    pub name: &'a str,
    /// The output folder (plots and overlays are read from it).
    pub out: &'a Path,
    /// Rows of per_video.csv.
    pub videos: &'a [VideoRow],
    /// The fits of fit.json.
    pub fits: &'a Fits,
    /// Plot stems relative to `out` (`plots/radius_vs_pressure`), each with an .svg.
    pub plots: &'a [String],
    /// How the results were made: the scale and calibration are shown.
    pub setup: Option<&'a Setup>,
    /// Segments of a segmented actuator (empty: no per-segment section).
    pub segments: &'a [Segment],
    /// Warnings about the measurement (one-circle check, ...), shown above the tables.
    pub warnings: &'a [String],
    /// Sections of their own (hysteresis, step response), after the fits.
    pub sections: &'a [Section],
}

/// A section of the report beside the standard ones: a title, lines of text, a table
/// and plots (stems relative to the output folder, each with an .svg), all given as
/// plain text (escaped here).
#[derive(Debug, Clone, Default)]
pub struct Section {
    /// Its heading.
    pub title: String,
    /// Lines of text, a list.
    pub lines: Vec<String>,
    /// A table: header and rows.
    pub table: Option<(Vec<String>, Vec<Vec<String>>)>,
    /// Its plots.
    pub plots: Vec<String>,
}

/// How a row of the per-video table is marked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowState {
    /// Measured without problems.
    Ok,
    /// Measured, with problems.
    Partial,
    /// Not measured (failed or skipped).
    Bad,
}

/// A row of the per-video table (a row of per_video.csv).
#[derive(Debug, Clone)]
pub struct VideoRow {
    /// The video (or recording, or pressure bin's item).
    pub file: String,
    /// Its overlay, relative to the output folder.
    pub overlay: String,
    /// Pressure, kPa.
    pub pressure_kpa: f64,
    /// Mean radius, mm.
    pub radius_mm: f64,
    /// Median radius, mm.
    pub radius_mm_median: f64,
    /// Standard deviation of the radius, mm.
    pub radius_mm_std: f64,
    /// Mean curvature, 1/m.
    pub curvature_per_m: f64,
    /// Mean bending angle, degrees.
    pub bending_angle_deg: f64,
    /// Frames measured.
    pub frames_used: usize,
    /// Frames rejected.
    pub frames_rejected: usize,
    /// Its status as per_video.csv writes it.
    pub status: String,
    /// How the row is marked.
    pub state: RowState,
    /// Whether it counts as measured.
    pub measured: bool,
    /// Each segment's statistics (segmented actuators).
    pub segments: Vec<SegmentStats>,
}

/// The power-law fits y = a x^b + c the report lists.
#[derive(Debug, Clone)]
pub struct Fits {
    /// Radius (mm) vs pressure (kPa).
    pub radius_mm_vs_kpa: Option<PowerLawFit>,
    /// Curvature (1/m) vs pressure (kPa).
    pub curvature_per_m_vs_kpa: Option<PowerLawFit>,
    /// Bending angle (deg) vs pressure (kPa).
    pub bending_angle_deg_vs_kpa: Option<PowerLawFit>,
    /// Why a fit is missing, and the rows a fit left out.
    pub notes: Vec<String>,
    /// Segmented actuators: each segment's radius fit.
    pub segments: Vec<SegmentFit>,
}

/// The radius fit of one segment.
#[derive(Debug, Clone)]
pub struct SegmentFit {
    /// Segment number, from 1 at the clamped end.
    pub segment: usize,
    /// Its markers ("1 2 3").
    pub markers: String,
    /// Radius (mm) vs pressure (kPa).
    pub radius_mm_vs_kpa: Option<PowerLawFit>,
}

/// How the results were made, as the report's setup lines say it.
#[derive(Debug, Clone)]
pub struct Setup {
    /// The scale in one line (`0.528208 mm/px from s/scale.jpg (board ...)`).
    pub scale: Option<String>,
    /// The calibration file used.
    pub calibration: Option<CalibrationFile>,
    /// The RGB-D intrinsics (file or recording).
    pub rgbd_intrinsics: Option<PathBuf>,
    /// bendscope's version.
    pub bendscope_version: String,
}

/// A calibration file and the hash of its content.
#[derive(Debug, Clone)]
pub struct CalibrationFile {
    /// The file.
    pub path: PathBuf,
    /// xxh3 of its content.
    pub content_hash: String,
}

/// Escapes text for HTML.
pub fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            _ => o.push(c),
        }
    }
    o
}

/// The start of a bendscope page: doctype, head with the shared style, and `title`
/// (escaped here) as the title and first heading.
pub fn page_start(title: &str) -> String {
    let title = escape(title);
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{title}</title>\n<style>\
body{{font-family:sans-serif;margin:2em;color:#222}}table{{border-collapse:collapse;font-size:0.9em}}\
td,th{{border:1px solid #ccc;padding:3px 8px;text-align:right}}td.l,th.l{{text-align:left}}\
tr.bad td{{background:#fde8e8}}tr.partial td{{background:#fff6dd}}figure{{display:inline-block;margin:1em}}\
figure img,figure svg{{max-width:900px;height:auto}}figure svg{{max-width:640px}}\
td.thumb{{padding:1px;text-align:center}}td.thumb img{{display:block}}</style></head><body>\n<h1>{title}</h1>\n"
    )
}

/// The plot `stem` of `out` (`stem.svg` inlined, links to its PNG, PDF and SVG) as a
/// figure.
pub fn plot_figure(out: &Path, stem: &str) -> String {
    let svg = std::fs::read_to_string(out.join(format!("{stem}.svg"))).unwrap_or_default();
    // The SVG's own XML declaration is not allowed inside HTML.
    let body = svg
        .find("<svg")
        .map(|i| &svg[i..])
        .unwrap_or("<p>(plot missing)</p>");
    format!(
        "<figure data-plot=\"{s}.svg\">{body}<figcaption><a href=\"{s}.png\">{s}</a> (<a href=\"{s}.pdf\">PDF</a>, <a href=\"{s}.svg\">SVG</a>)</figcaption></figure>",
        s = escape(stem)
    )
}

/// A number with `digits` decimals for a table cell: empty for NaN, `inf` for infinities.
pub fn num(v: f64, digits: usize) -> String {
    if v.is_finite() {
        format!("{v:.digits$}")
    } else if v.is_nan() {
        String::new()
    } else {
        "inf".into()
    }
}

/// The overlay of `file` in `out` (at `rel`), as an `<img>` with a data URI, if it exists.
fn overlay_img(out: &Path, file: &str, rel: &str) -> Option<String> {
    let bytes = std::fs::read(out.join(&rel)).ok()?;
    Some(format!(
        "<figure id=\"overlay-{id}\"><img alt=\"overlay of {name}\" data-file=\"{rel_e}\" src=\"data:image/png;base64,{b64}\"><figcaption>{name}</figcaption></figure>",
        id = escape(file),
        name = escape(file),
        rel_e = escape(&rel),
        b64 = base64::engine::general_purpose::STANDARD.encode(bytes)
    ))
}

/// Width of a row's overlay thumbnail, px: small enough that a page of
/// [`MAX_THUMBNAILS`] stays a few MB, large enough to see the markers and the circle.
pub const THUMBNAIL_WIDTH_PX: u32 = 160;

/// Thumbnails in one per-video table at most (a session may list thousands of rows);
/// rows after them link to their overlay by name only.
pub const MAX_THUMBNAILS: usize = 100;

/// A small PNG of the overlay at `rel` in `out` ([`THUMBNAIL_WIDTH_PX`] wide), as an
/// `<img>` with a data URI, if the overlay can be read.
fn thumbnail_img(out: &Path, file: &str, rel: &str) -> Option<String> {
    let img = image::open(out.join(rel)).ok()?;
    let w = THUMBNAIL_WIDTH_PX.min(img.width());
    let h = ((img.height() as u64 * w as u64) / img.width().max(1) as u64).max(1) as u32;
    let small = image::imageops::thumbnail(&img.to_rgb8(), w, h);
    let mut bytes = std::io::Cursor::new(Vec::new());
    small.write_to(&mut bytes, image::ImageFormat::Png).ok()?;
    Some(format!(
        "<img class=\"thumb\" alt=\"overlay of {name}\" width=\"{w}\" height=\"{h}\" src=\"data:image/png;base64,{b64}\">",
        name = escape(file),
        b64 = base64::engine::general_purpose::STANDARD.encode(bytes.get_ref())
    ))
}

/// Whether `rel` is a file in `out`.
fn out_has(out: &Path, rel: &str) -> bool {
    out.join(rel).is_file()
}

/// Renders the report's HTML.
pub fn session_report_html(r: &SessionReport) -> String {
    let mut h = page_start(&format!("bendscope: {}", r.name));
    let measured = r.videos.iter().filter(|v| v.measured).count();
    let _ = writeln!(
        h,
        "<p>{measured} of {} rows measured. Files: per_video.csv, per_frame.csv, markers.csv, fit.json, session.json, plots/, overlays/.</p>",
        r.videos.len()
    );
    if !r.warnings.is_empty() {
        h.push_str("<h2>Warnings</h2>\n<ul class=\"warnings\">\n");
        for w in r.warnings {
            let _ = writeln!(h, "<li>{}</li>", escape(w));
        }
        h.push_str("</ul>\n");
    }
    if let Some(p) = r.setup {
        h.push_str("<h2>Setup</h2>\n<ul>\n");
        if let Some(s) = &p.scale {
            let _ = writeln!(h, "<li>scale: {}</li>", escape(s));
        }
        if let Some(c) = &p.calibration {
            let _ = writeln!(
                h,
                "<li>calibration: {} (xxh3 {})</li>",
                escape(&c.path.display().to_string()),
                escape(&c.content_hash)
            );
        }
        if let Some(i) = &p.rgbd_intrinsics {
            let _ = writeln!(
                h,
                "<li>RGB-D intrinsics: {} (millimetres from the depth)</li>",
                escape(&i.display().to_string())
            );
        }
        let _ = writeln!(
            h,
            "<li>bendscope {}; settings and cache use in session.json</li>\n</ul>",
            escape(&p.bendscope_version)
        );
    }
    h.push_str("<h2>Per video</h2>\n<table><tr><th class=\"l\">file</th><th>pressure (kPa)</th><th>radius (mm)</th><th>median (mm)</th><th>std (mm)</th><th>curvature (1/m)</th><th>angle (deg)</th><th>frames used</th><th>rejected</th><th class=\"l\">status</th><th class=\"l\">overlay</th></tr>\n");
    let mut thumbnails = 0usize;
    let mut capped = false;
    for v in r.videos {
        // Measured rows with an overlay, the first MAX_THUMBNAILS of them.
        let thumb = if v.measured && !v.overlay.is_empty() && out_has(r.out, &v.overlay) {
            if thumbnails < MAX_THUMBNAILS {
                thumbnail_img(r.out, &v.file, &v.overlay).inspect(|_| thumbnails += 1)
            } else {
                capped = true;
                None
            }
        } else {
            None
        };
        let thumb = thumb
            .map(|img| format!("<a href=\"#overlay-{}\">{img}</a>", escape(&v.file)))
            .unwrap_or_default();
        let class = match v.state {
            RowState::Ok => "ok",
            RowState::Partial => "partial",
            RowState::Bad => "bad",
        };
        let _ = writeln!(
            h,
            "<tr class=\"{class}\"><td class=\"l\"><a href=\"#overlay-{id}\">{name}</a></td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"l\">{}</td><td class=\"thumb\">{thumb}</td></tr>",
            num(v.pressure_kpa, 2),
            num(v.radius_mm, 3),
            num(v.radius_mm_median, 3),
            num(v.radius_mm_std, 3),
            num(v.curvature_per_m, 3),
            num(v.bending_angle_deg, 2),
            v.frames_used,
            v.frames_rejected,
            escape(&v.status),
            id = escape(&v.file),
            name = escape(&v.file),
        );
    }
    h.push_str("</table>\n");
    if capped {
        let _ = writeln!(
            h,
            "<p class=\"capped\">Thumbnails for the first {MAX_THUMBNAILS} measured rows only; every overlay is under Overlays below.</p>"
        );
    }
    if !r.segments.is_empty() {
        segment_section(&mut h, r);
    }
    h.push_str("<h2>Fits (y = a x<sup>b</sup> + c, x in kPa)</h2>\n<ul>\n");
    for (what, f) in [
        ("radius (mm)", &r.fits.radius_mm_vs_kpa),
        ("curvature (1/m)", &r.fits.curvature_per_m_vs_kpa),
        ("bending angle (deg)", &r.fits.bending_angle_deg_vs_kpa),
    ] {
        let _ = match f {
            Some(f) => writeln!(
                h,
                "<li>{what}: a = {:.6}, b = {:.4}, c = {:.4}, R² = {:.5}</li>",
                f.a, f.b, f.c, f.r_squared
            ),
            None => writeln!(h, "<li>{what}: no fit</li>"),
        };
    }
    for n in &r.fits.notes {
        let _ = writeln!(h, "<li>{}</li>", escape(n));
    }
    h.push_str("</ul>\n");
    for s in r.sections {
        section(&mut h, r.out, s);
    }
    h.push_str("<h2>Plots</h2>\n");
    for stem in r.plots {
        h.push_str(&plot_figure(r.out, stem));
        h.push('\n');
    }
    h.push_str("<h2>Overlays</h2>\n<p>One measured frame per video, undistorted: mask outline (green), markers from the clamp (yellow) to the tip (blue), fitted circle (magenta).</p>\n");
    // A set: a session may list many thousands of rows (skipped ones included).
    let mut shown: std::collections::HashSet<&str> = std::collections::HashSet::new();
    for v in r.videos {
        if !shown.insert(v.file.as_str()) {
            continue;
        }
        if let Some(img) = overlay_img(r.out, &v.file, &v.overlay) {
            h.push_str(&img);
            h.push('\n');
        }
    }
    h.push_str("</body></html>\n");
    h
}

/// A [`Section`]: heading, lines, table, plots.
fn section(h: &mut String, out: &Path, s: &Section) {
    let _ = writeln!(h, "<h2>{}</h2>", escape(&s.title));
    if !s.lines.is_empty() {
        h.push_str("<ul>\n");
        for l in &s.lines {
            let _ = writeln!(h, "<li>{}</li>", escape(l));
        }
        h.push_str("</ul>\n");
    }
    if let Some((header, rows)) = &s.table {
        h.push_str("<table><tr>");
        for c in header {
            let _ = write!(h, "<th>{}</th>", escape(c));
        }
        h.push_str("</tr>\n");
        for row in rows {
            h.push_str("<tr>");
            for c in row {
                let _ = write!(h, "<td>{}</td>", escape(c));
            }
            h.push_str("</tr>\n");
        }
        h.push_str("</table>\n");
    }
    for stem in &s.plots {
        h.push_str(&plot_figure(out, stem));
        h.push('\n');
    }
}

/// The per-segment table (per_segment.csv) and each segment's fits.
fn segment_section(h: &mut String, r: &SessionReport) {
    h.push_str("<h2>Per segment</h2>\n<p>Each segment's own circle (per_segment.csv), segments numbered from the clamp.</p>\n<table><tr><th class=\"l\">file</th><th>pressure (kPa)</th><th>segment</th><th class=\"l\">markers</th><th>radius (mm)</th><th>std (mm)</th><th>curvature (1/m)</th><th>angle (deg)</th><th>frames used</th></tr>\n");
    for v in r.videos {
        for (k, seg) in r.segments.iter().enumerate() {
            let st = v.segments.get(k);
            let g = |f: fn(&SegmentStats) -> f64| st.map_or(f64::NAN, f);
            let _ = writeln!(
                h,
                "<tr><td class=\"l\">{}</td><td>{}</td><td>{}</td><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                escape(&v.file),
                num(v.pressure_kpa, 2),
                k + 1,
                seg.label(),
                num(g(|s| s.radius_mm), 3),
                num(g(|s| s.radius_mm_std), 3),
                num(g(|s| s.curvature_per_m), 3),
                num(g(|s| s.bending_angle_deg), 2),
                st.map_or(0, |s| s.frames_used),
            );
        }
    }
    h.push_str("</table>\n<ul>\n");
    for f in &r.fits.segments {
        let _ = match &f.radius_mm_vs_kpa {
            Some(p) => writeln!(
                h,
                "<li>segment {} (markers {}), radius (mm) = a x<sup>b</sup> + c: a = {:.6}, b = {:.4}, c = {:.4}, R² = {:.5}</li>",
                f.segment, f.markers, p.a, p.b, p.c, p.r_squared
            ),
            None => writeln!(h, "<li>segment {} (markers {}): no radius fit</li>", f.segment, f.markers),
        };
    }
    h.push_str("</ul>\n");
}

/// Writes `report.html` atomically.
pub fn write_session_report(path: &Path, r: &SessionReport) -> Result<(), ReportError> {
    write_atomic(path, session_report_html(r).as_bytes()).map_err(|source| ReportError::Io {
        path: path.to_path_buf(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(file: &str, measured: bool) -> VideoRow {
        VideoRow {
            file: file.into(),
            overlay: format!("overlays/{file}.png"),
            pressure_kpa: 20.0,
            radius_mm: 100.0,
            radius_mm_median: 100.0,
            radius_mm_std: 0.1,
            curvature_per_m: 10.0,
            bending_angle_deg: 30.0,
            frames_used: 3,
            frames_rejected: 0,
            status: "ok".into(),
            state: if measured {
                RowState::Ok
            } else {
                RowState::Bad
            },
            measured,
            segments: vec![],
        }
    }

    /// A thumbnail beside each measured row with an overlay, THUMBNAIL_WIDTH_PX wide at
    /// the overlay's aspect ratio, linking to its figure; none for a row not measured or
    /// without an overlay file; at most MAX_THUMBNAILS, and the page says so when capped.
    #[test]
    fn thumbnails_sit_beside_measured_rows_and_are_capped() {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir(d.path().join("overlays")).unwrap();
        let n = MAX_THUMBNAILS + 2;
        let mut rows: Vec<VideoRow> = (0..n).map(|i| row(&format!("v{i}"), true)).collect();
        let overlay = image::RgbImage::from_pixel(640, 480, image::Rgb([200, 10, 10]));
        for r in &rows {
            overlay.save(d.path().join(&r.overlay)).unwrap();
        }
        rows.insert(0, row("bad", false));
        overlay.save(d.path().join("overlays/bad.png")).unwrap();
        rows.insert(1, row("no-overlay", true));
        let fits = Fits {
            radius_mm_vs_kpa: None,
            curvature_per_m_vs_kpa: None,
            bending_angle_deg_vs_kpa: None,
            notes: vec![],
            segments: vec![],
        };
        let html = session_report_html(&SessionReport {
            name: "s",
            out: d.path(),
            videos: &rows,
            fits: &fits,
            plots: &[],
            setup: None,
            segments: &[],
            warnings: &[],
            sections: &[],
        });
        let thumbs: Vec<&str> = html.split("<img class=\"thumb\"").skip(1).collect();
        assert_eq!(thumbs.len(), MAX_THUMBNAILS);
        // 640 x 480 -> 160 x 120.
        assert!(thumbs[0].starts_with(" alt=\"overlay of v0\" width=\"160\" height=\"120\""));
        let line = |file: &str| {
            html.lines()
                .find(|l| l.contains(&format!(">{file}</a></td>")))
                .unwrap()
                .to_string()
        };
        assert!(line("v0").contains("<td class=\"thumb\"><a href=\"#overlay-v0\"><img"));
        for none in ["bad", "no-overlay", &format!("v{}", MAX_THUMBNAILS)] {
            assert!(line(none).contains("<td class=\"thumb\"></td>"), "{none}");
        }
        assert!(html.contains(&format!(
            "Thumbnails for the first {MAX_THUMBNAILS} measured rows only"
        )));
        rows.truncate(5);
        let html = session_report_html(&SessionReport {
            videos: &rows,
            name: "s",
            out: d.path(),
            fits: &fits,
            plots: &[],
            setup: None,
            segments: &[],
            warnings: &[],
            sections: &[],
        });
        assert!(!html.contains("Thumbnails for the first"), "not capped");
    }

    #[test]
    fn escapes_markup() {
        assert_eq!(
            escape("<a href='x'>&\"</a>"),
            "&lt;a href=&#39;x&#39;&gt;&amp;&quot;&lt;/a&gt;"
        );
    }
}
