//! Reports: plots (plotters, PNG and SVG rendered in memory, PDF from the SVG by
//! [`pdf`]), JSON, QA overlays and the session's HTML page ([`html`]). Every file is
//! written atomically. Tables are written by [`crate::table`].
//!
//! Plots are drawn for one column of a two-column paper: [`PLOT_SIZE`] is 3.5 x 2.6 in
//! at 4 units per point, so at column width tick labels are 7.5 pt, axis labels 8.5 pt,
//! the legend 8 pt and the title 9 pt (journals ask for 7 pt or more), lines 1.5 pt and
//! error bars 1 pt; the PNG keeps the same 1008 x 748 pixels for screens (288 dpi at
//! column width).

pub mod error_bars;
pub mod html;
pub mod pdf;

pub use error_bars::ErrorBars;

use std::path::{Path, PathBuf};

use image::RgbImage;
use nalgebra::Point2;
use plotters::prelude::*;
use serde::Serialize;

use crate::io::write_atomic;

/// Errors of report writing.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// File system.
    #[error("{}", crate::io::with_path(path, source))]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// Table or plot library.
    #[error("{path}: {message}")]
    Render {
        /// File.
        path: PathBuf,
        /// What failed.
        message: String,
    },
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> ReportError + '_ {
    move |source| ReportError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes a JSON value atomically.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), ReportError> {
    let text = serde_json::to_string_pretty(value).map_err(|e| ReportError::Render {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    write_atomic(path, text.as_bytes()).map_err(io(path))
}

/// A data series of a plot.
pub struct Series<'a> {
    /// Legend label.
    pub label: &'a str,
    /// Points.
    pub points: Vec<(f64, f64)>,
    /// Draw as a line (else markers).
    pub line: bool,
    /// Error bars: a half-height per point (e.g. one standard deviation), drawn as a
    /// vertical bar with caps in the series colour; a NaN, negative or zero half-height,
    /// or `None`, draws no bar.
    pub errors: Option<Vec<f64>>,
}

impl Series<'_> {
    /// The finite points with their drawable error half-height (0 when none).
    fn finite_points(&self) -> impl Iterator<Item = ((f64, f64), f64)> + '_ {
        self.points.iter().enumerate().filter_map(|(i, &(x, y))| {
            if !(x.is_finite() && y.is_finite()) {
                return None;
            }
            let e = self
                .errors
                .as_ref()
                .and_then(|e| e.get(i).copied())
                .filter(|e| e.is_finite() && *e > 0.0)
                .unwrap_or(0.0);
            Some(((x, y), e))
        })
    }
}

/// Plot size in plot units (px of the PNG, user units of the SVG; 4 to the point of the
/// PDF): 3.5 x 2.6 in, one paper column ([`pdf::PDF_DPI`]).
pub const PLOT_SIZE: (u32, u32) = (1008, 748);

/// The font family of a plot's text (DejaVu Sans in the PDF, [`pdf::PLOT_FONT`]).
const FONT: &str = "sans-serif";
/// Font sizes, plot units (/4 for points at column width): title, axis labels, tick
/// labels, legend.
const TITLE_FONT: u32 = 36;
const AXIS_LABEL_FONT: u32 = 34;
const TICK_FONT: u32 = 30;
const LEGEND_FONT: u32 = 32;
/// Line widths, plot units: a series' line, an error bar, the axes.
const LINE_WIDTH: u32 = 6;
const BAR_WIDTH: u32 = 4;
const AXIS_WIDTH: u32 = 3;
/// Radius of a marker, plot units.
const MARKER_RADIUS: i32 = 10;
/// Width of an error bar's caps, plot units.
const CAP_PX: i32 = 24;
/// Length of a line's sample in the legend, plot units.
const LEGEND_LINE: i32 = 48;

/// The files of the plot `stem`: PNG, SVG and PDF.
pub fn plot_files(stem: &Path) -> [PathBuf; 3] {
    PLOT_EXTENSIONS.map(|e| stem.with_extension(e))
}

/// Extensions of the files of one plot.
pub const PLOT_EXTENSIONS: [&str; 3] = ["png", "svg", "pdf"];

/// Draws an x-y plot to `stem.png`, `stem.svg` and `stem.pdf`, each rendered in memory
/// and written atomically. Returns `false`, and removes an earlier plot of the same
/// name, when no series has a finite point.
pub fn plot_xy(
    stem: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<bool, ReportError> {
    let [png, svg, pdf] = plot_files(stem);
    let finite: Vec<((f64, f64), f64)> = series.iter().flat_map(|s| s.finite_points()).collect();
    if finite.is_empty() {
        for p in [&png, &svg, &pdf] {
            match std::fs::remove_file(p) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(io(p)(e)),
                _ => {}
            }
        }
        return Ok(false);
    }
    let (mut x0, mut x1, mut y0, mut y1) = finite.iter().fold(
        (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ),
        |(a, b, c, d), ((x, y), e)| (a.min(*x), b.max(*x), c.min(y - e), d.max(y + e)),
    );
    let pad = |lo: &mut f64, hi: &mut f64| {
        let m = ((*hi - *lo) * 0.08).max(1e-9 + 0.05 * hi.abs());
        *lo -= m;
        *hi += m;
    };
    pad(&mut x0, &mut x1);
    pad(&mut y0, &mut y1);
    let range = (x0, x1, y0, y1);
    let (w, h) = PLOT_SIZE;
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    draw_chart(
        BitMapBackend::with_buffer(&mut rgb, PLOT_SIZE).into_drawing_area(),
        title,
        x_label,
        y_label,
        range,
        series,
    )
    .map_err(|message| ReportError::Render {
        path: png.clone(),
        message,
    })?;
    let mut text = String::new();
    draw_chart(
        SVGBackend::with_string(&mut text, PLOT_SIZE).into_drawing_area(),
        title,
        x_label,
        y_label,
        range,
        series,
    )
    .map_err(|message| ReportError::Render {
        path: svg.clone(),
        message,
    })?;
    let pdf_bytes = pdf::pdf_from_svg(&text).map_err(|message| ReportError::Render {
        path: pdf.clone(),
        message,
    })?;
    let image = RgbImage::from_raw(w, h, rgb).ok_or_else(|| ReportError::Render {
        path: png.clone(),
        message: "plot buffer size".into(),
    })?;
    let mut bytes = std::io::Cursor::new(Vec::new());
    image
        .write_to(&mut bytes, image::ImageFormat::Png)
        .map_err(|e| ReportError::Render {
            path: png.clone(),
            message: e.to_string(),
        })?;
    write_atomic(&png, bytes.get_ref()).map_err(io(&png))?;
    write_atomic(&svg, text.as_bytes()).map_err(io(&svg))?;
    write_atomic(&pdf, &pdf_bytes).map_err(io(&pdf))?;
    Ok(true)
}

fn draw_chart<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    x_label: &str,
    y_label: &str,
    (x0, x1, y0, y1): (f64, f64, f64, f64),
    series: &[Series],
) -> Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, (FONT, TITLE_FONT))
        .margin(24)
        .x_label_area_size(100)
        .y_label_area_size(150)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .x_labels(6)
        .y_labels(6)
        .label_style((FONT, TICK_FONT))
        .axis_desc_style((FONT, AXIS_LABEL_FONT))
        .axis_style(BLACK.stroke_width(AXIS_WIDTH))
        .bold_line_style(BLACK.mix(0.15).stroke_width(2))
        .light_line_style(TRANSPARENT)
        .set_all_tick_mark_size(12)
        .draw()
        .map_err(|e| e.to_string())?;
    for (i, s) in series.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let bars: Vec<((f64, f64), f64)> = s.finite_points().filter(|(_, e)| *e > 0.0).collect();
        chart
            .draw_series(bars.iter().map(|&((x, y), e)| {
                PathElement::new(vec![(x, y - e), (x, y + e)], color.stroke_width(BAR_WIDTH))
            }))
            .map_err(|e| e.to_string())?;
        let cap = |&((x, y), _): &((f64, f64), f64)| {
            EmptyElement::at((x, y))
                + PathElement::new(
                    vec![(-CAP_PX / 2, 0), (CAP_PX / 2, 0)],
                    color.stroke_width(BAR_WIDTH),
                )
        };
        for sign in [-1.0, 1.0] {
            chart
                .draw_series(bars.iter().map(|&((x, y), e)| cap(&((x, y + sign * e), e))))
                .map_err(|e| e.to_string())?;
        }
        let pts: Vec<(f64, f64)> = s.finite_points().map(|(p, _)| p).collect();
        if s.line {
            chart
                .draw_series(LineSeries::new(pts, color.stroke_width(LINE_WIDTH)))
                .map_err(|e| e.to_string())?
                .label(s.label)
                .legend(move |(x, y)| {
                    PathElement::new(
                        vec![(x, y), (x + LEGEND_LINE, y)],
                        color.stroke_width(LINE_WIDTH),
                    )
                });
        } else {
            chart
                .draw_series(
                    pts.into_iter()
                        .map(|p| Circle::new(p, MARKER_RADIUS, color.filled())),
                )
                .map_err(|e| e.to_string())?
                .label(s.label)
                .legend(move |(x, y)| {
                    Circle::new((x + LEGEND_LINE / 2, y), MARKER_RADIUS, color.filled())
                });
        }
    }
    chart
        .configure_series_labels()
        .label_font((FONT, LEGEND_FONT))
        .legend_area_size(LEGEND_LINE + 12)
        .margin(16)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())?;
    root.present().map_err(|e| e.to_string())
}

/// Draws the QA overlay on an undistorted frame: mask outline (green), centroids (blue
/// crosses, numbered order by colour from yellow at the clamp to blue at the tip), red
/// blobs that were not taken as markers (cyan hollow squares) and the fitted circles
/// (`circles`: centre, radius px, colour; the one circle in magenta, or one per segment
/// of a segmented actuator); writes PNG atomically.
pub fn write_overlay(
    path: &Path,
    undistorted: &RgbImage,
    mask: &image::GrayImage,
    markers: &[Point2<f64>],
    ignored: &[Point2<f64>],
    circles: &[(Point2<f64>, f64, [u8; 3])],
) -> Result<(), ReportError> {
    let mut img = undistorted.clone();
    let (w, h) = img.dimensions();
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            if mask.get_pixel(x, y)[0] != 0
                && (mask.get_pixel(x - 1, y)[0] == 0
                    || mask.get_pixel(x + 1, y)[0] == 0
                    || mask.get_pixel(x, y - 1)[0] == 0
                    || mask.get_pixel(x, y + 1)[0] == 0)
            {
                img.put_pixel(x, y, image::Rgb([0, 200, 0]));
            }
        }
    }
    for &(center, radius_px, colour) in circles {
        if !(radius_px.is_finite() && center.x.is_finite() && radius_px < 1e6) {
            continue;
        }
        let steps = ((radius_px * 2.0 * std::f64::consts::PI) as usize).clamp(64, 20_000);
        for i in 0..steps {
            let t = i as f64 / steps as f64 * std::f64::consts::TAU;
            let (x, y) = (
                center.x + radius_px * t.cos(),
                center.y + radius_px * t.sin(),
            );
            if x >= 0.0 && y >= 0.0 && (x as u32) < w && (y as u32) < h {
                img.put_pixel(x as u32, y as u32, image::Rgb(colour));
            }
        }
    }
    let n = markers.len().max(2) - 1;
    for (i, m) in markers.iter().enumerate() {
        let t = i as f64 / n as f64;
        let c = image::Rgb([
            (255.0 * (1.0 - t)) as u8,
            (255.0 * (1.0 - t)) as u8,
            (255.0 * t) as u8,
        ]);
        imageproc::drawing::draw_cross_mut(&mut img, c, m.x.round() as i32, m.y.round() as i32);
    }
    for p in ignored {
        let r = imageproc::rect::Rect::at(p.x.round() as i32 - 6, p.y.round() as i32 - 6)
            .of_size(13, 13);
        imageproc::drawing::draw_hollow_rect_mut(&mut img, r, image::Rgb([0, 220, 220]));
    }
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, image::ImageFormat::Png)
        .map_err(|e| ReportError::Render {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    write_atomic(path, bytes.get_ref()).map_err(io(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plots_are_written_and_empty_ones_removed() {
        let d = tempfile::tempdir().unwrap();
        let stem = d.path().join("radius_vs_pressure");
        let series = |points: Vec<(f64, f64)>| Series {
            label: "measured",
            points,
            line: false,
            errors: None,
        };
        let pts: Vec<(f64, f64)> = (1..=6)
            .map(|i| (15.0 * i as f64, 100.0 / i as f64))
            .collect();
        assert!(plot_xy(
            &stem,
            "radius",
            "pressure (kPa)",
            "radius (mm)",
            &[series(pts)]
        )
        .unwrap());
        assert!(std::fs::metadata(stem.with_extension("png")).unwrap().len() > 1000);
        assert!(std::fs::read_to_string(stem.with_extension("svg"))
            .unwrap()
            .contains("<svg"));
        assert_eq!(
            std::fs::read_dir(d.path()).unwrap().count(),
            3,
            "png, svg and pdf, no temporaries left"
        );
        let pdf = std::fs::read(stem.with_extension("pdf")).unwrap();
        let text = String::from_utf8_lossy(&pdf);
        assert!(pdf.starts_with(b"%PDF-"), "a PDF");
        // One paper column: 1008 x 748 units at 288 dpi = 252 x 187 pt (3.5 x 2.6 in).
        assert!(text.contains("/MediaBox [0 0 252 187"), "page size");
        // The text is text, in an embedded subset of the sans-serif font.
        assert!(text.contains("/FontFile2"), "embedded font");
        assert!(text.contains("DejaVuSans"), "DejaVu Sans for sans-serif");
        let none = vec![(f64::NAN, 1.0)];
        assert!(!plot_xy(&stem, "radius", "p", "r", &[series(none)]).unwrap());
        for f in plot_files(&stem) {
            assert!(!f.exists(), "{} removed", f.display());
        }
    }

    /// The value of attribute `name` in an SVG tag.
    fn attr<'t>(tag: &'t str, name: &str) -> Option<&'t str> {
        let start = tag.find(&format!(" {name}=\""))? + name.len() + 3;
        Some(&tag[start..start + tag[start..].find('"')?])
    }

    /// The SVG tags `<kind .../>` whose `colour_attr` is `colour`.
    fn tags<'t>(svg: &'t str, kind: &str, colour_attr: &str, colour: &str) -> Vec<&'t str> {
        svg.split('<')
            .filter(|t| t.starts_with(kind) && attr(t, colour_attr) == Some(colour))
            .collect()
    }

    /// The two end points of a two-point polyline.
    fn segment(tag: &str) -> Option<((f64, f64), (f64, f64))> {
        let p: Vec<(f64, f64)> = attr(tag, "points")?
            .split_whitespace()
            .map(|xy| {
                let (x, y) = xy.split_once(',').unwrap();
                (x.parse().unwrap(), y.parse().unwrap())
            })
            .collect();
        (p.len() == 2).then(|| (p[0], p[1]))
    }

    /// Error bars are drawn at the chart's own mapping of the data: a bar of half-height
    /// e spans e data units either side of its marker's centre, with 8 px caps at both
    /// ends; the y range is widened to hold the bars; a NaN error draws nothing.
    #[test]
    fn error_bars_span_their_half_height_at_the_chart_mapping() {
        let d = tempfile::tempdir().unwrap();
        let stem = d.path().join("bars");
        let (ys, es) = ([10.0, 20.0, 15.0], [1.0, 4.0, f64::NAN]);
        let series = Series {
            label: "measured",
            points: (0..3).map(|i| (1.0 + i as f64, ys[i])).collect(),
            line: false,
            errors: Some(es.to_vec()),
        };
        assert!(plot_xy(&stem, "bars", "x", "y", &[series]).unwrap());
        let svg = std::fs::read_to_string(stem.with_extension("svg")).unwrap();
        let c = Palette99::pick(0).to_rgba().rgb();
        let colour = format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2);
        // Marker centres: the data's in drawing order, then the legend's.
        let centres: Vec<(f64, f64)> = tags(&svg, "circle", "fill", &colour)
            .iter()
            .map(|t| {
                let v = |n| attr(t, n).unwrap().parse::<f64>().unwrap();
                (v("cx"), v("cy"))
            })
            .collect();
        assert_eq!(centres.len(), 4, "three markers and the legend's");
        // Pixels per data unit from the first two markers (y grows downwards).
        let scale = (centres[0].1 - centres[1].1) / (ys[1] - ys[0]);
        let px = |y: f64| centres[0].1 - (y - ys[0]) * scale;
        let tol = 1.5;
        assert!((centres[2].1 - px(ys[2])).abs() <= tol, "linear mapping");
        let lines: Vec<_> = tags(&svg, "polyline", "stroke", &colour)
            .into_iter()
            .filter_map(segment)
            .collect();
        let bars: Vec<_> = lines.iter().filter(|(a, b)| a.0 == b.0).collect();
        let caps: Vec<_> = lines.iter().filter(|(a, b)| a.1 == b.1).collect();
        assert_eq!((bars.len(), caps.len()), (2, 4), "no bar for the NaN error");
        for i in 0..2 {
            let (x, lo, hi) = (centres[i].0, ys[i] - es[i], ys[i] + es[i]);
            let bar = bars
                .iter()
                .find(|(a, _)| (a.0 - x).abs() <= tol)
                .expect("bar at its marker's x");
            let (top, bottom) = (bar.0 .1.min(bar.1 .1), bar.0 .1.max(bar.1 .1));
            assert!(
                (top - px(hi)).abs() <= tol && (bottom - px(lo)).abs() <= tol,
                "bar {i}: {top}..{bottom} px, expected {}..{}",
                px(hi),
                px(lo)
            );
            for y in [top, bottom] {
                let cap = caps
                    .iter()
                    .find(|(a, b)| (a.1 - y).abs() <= tol && (a.0 + b.0) / 2.0 == x)
                    .expect("cap at the bar's end");
                assert_eq!((cap.1 .0 - cap.0 .0).abs(), CAP_PX as f64);
            }
        }
        // The y axis (left edge of the plot area) spans the padded range of the bars,
        // 9..24 widened by 8 % each way: 7.8..25.2.
        let axis = tags(&svg, "polyline", "stroke", "#000000")
            .into_iter()
            .filter_map(segment)
            .filter(|(a, b)| a.0 == b.0 && a.0 < centres[0].0)
            .map(|(a, b)| (a.1.min(b.1), a.1.max(b.1)))
            .max_by(|a, b| (a.1 - a.0).total_cmp(&(b.1 - b.0)))
            .expect("y axis");
        assert!(
            (axis.0 - px(25.2)).abs() <= tol && (axis.1 - px(7.8)).abs() <= tol,
            "y axis {axis:?} px, expected {}..{}",
            px(25.2),
            px(7.8)
        );
    }
}
