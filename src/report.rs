//! Reports: CSV tables (per frame, per video with polars), the power-law fits as JSON,
//! plots (plotters, PNG and SVG) and QA overlays. Every file is written atomically.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use image::RgbImage;
use nalgebra::Point2;
use plotters::prelude::*;
use polars::prelude::*;
use serde::Serialize;

use crate::fit::{fit_power_law, PowerLawFit};
use crate::io::write_atomic;

/// Errors of report writing.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// File system.
    #[error("{path}: {source}")]
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

/// One row of per_frame.csv.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameRow {
    /// Video file.
    pub file: String,
    /// Frame index.
    pub frame: u64,
    /// Time, s.
    pub time_s: f64,
    /// Pressure, kPa.
    pub pressure_kpa: f64,
    /// Markers found.
    pub n_markers: usize,
    /// Radius, undistorted px.
    pub radius_px: f64,
    /// Radius, mm.
    pub radius_mm: f64,
    /// Curvature, 1/m.
    pub curvature_per_m: f64,
    /// Bending angle, degrees.
    pub bending_angle_deg: f64,
    /// Fit RMS, px.
    pub fit_rms_px: f64,
    /// ok, or the reason of rejection.
    pub status: String,
}

/// Formats a number for CSV: empty when NaN (missing), `inf` when infinite.
fn num(v: f64, digits: usize) -> String {
    if v.is_nan() {
        String::new()
    } else if v.is_infinite() {
        if v > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        }
    } else {
        format!("{v:.digits$}")
    }
}

/// Quotes a CSV field when needed.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Writes per_frame.csv.
pub fn write_per_frame_csv(path: &Path, rows: &[FrameRow]) -> Result<(), ReportError> {
    let mut s = String::from(
        "file,frame,time_s,pressure_kpa,n_markers,radius_px,radius_mm,curvature_per_m,bending_angle_deg,fit_rms_px,status\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{}",
            field(&r.file),
            r.frame,
            num(r.time_s, 4),
            num(r.pressure_kpa, 3),
            r.n_markers,
            num(r.radius_px, 3),
            num(r.radius_mm, 4),
            num(r.curvature_per_m, 4),
            num(r.bending_angle_deg, 3),
            num(r.fit_rms_px, 4),
            field(&r.status)
        );
    }
    write_atomic(path, s.as_bytes()).map_err(io(path))
}

/// One row of per_video.csv.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct VideoRow {
    /// Video file.
    pub file: String,
    /// Pressure, kPa.
    pub pressure_kpa: f64,
    /// Pressure in the manifest's unit.
    pub pressure: f64,
    /// Mean radius, mm.
    pub radius_mm: f64,
    /// Median radius, mm.
    pub radius_mm_median: f64,
    /// Standard deviation, mm.
    pub radius_mm_std: f64,
    /// Mean curvature, 1/m.
    pub curvature_per_m: f64,
    /// Mean bending angle, degrees.
    pub bending_angle_deg: f64,
    /// Mean fit RMS, px.
    pub fit_rms_px: f64,
    /// Frames used.
    pub frames_used: usize,
    /// Frames rejected.
    pub frames_rejected: usize,
    /// ok, or what went wrong.
    pub status: String,
}

/// Writes per_video.csv with polars (a `pressure_<unit>` column follows `pressure_kpa`
/// when the manifest used another unit).
pub fn write_per_video_csv(path: &Path, rows: &[VideoRow], unit: &str) -> Result<(), ReportError> {
    let f = |g: fn(&VideoRow) -> f64| -> Vec<Option<f64>> {
        rows.iter()
            .map(|r| Some(g(r)).filter(|v| !v.is_nan()))
            .collect()
    };
    let mut cols = vec![
        Column::new(
            "file".into(),
            rows.iter().map(|r| r.file.clone()).collect::<Vec<_>>(),
        ),
        Column::new("pressure_kpa".into(), f(|r| r.pressure_kpa)),
        Column::new(format!("pressure_{unit}").into(), f(|r| r.pressure)),
        Column::new("radius_mm".into(), f(|r| r.radius_mm)),
        Column::new("radius_mm_median".into(), f(|r| r.radius_mm_median)),
        Column::new("radius_mm_std".into(), f(|r| r.radius_mm_std)),
        Column::new("curvature_per_m".into(), f(|r| r.curvature_per_m)),
        Column::new("bending_angle_deg".into(), f(|r| r.bending_angle_deg)),
        Column::new("fit_rms_px".into(), f(|r| r.fit_rms_px)),
        Column::new(
            "frames_used".into(),
            rows.iter()
                .map(|r| r.frames_used as u64)
                .collect::<Vec<_>>(),
        ),
        Column::new(
            "frames_rejected".into(),
            rows.iter()
                .map(|r| r.frames_rejected as u64)
                .collect::<Vec<_>>(),
        ),
        Column::new(
            "status".into(),
            rows.iter().map(|r| r.status.clone()).collect::<Vec<_>>(),
        ),
    ];
    if unit == "kpa" {
        // pressure_kpa is already there.
        cols.remove(2);
    }
    let render = |e: PolarsError| ReportError::Render {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let mut df = DataFrame::new_infer_height(cols).map_err(render)?;
    let mut buf: Vec<u8> = Vec::new();
    CsvWriter::new(&mut buf)
        .include_header(true)
        .with_float_precision(Some(4))
        .finish(&mut df)
        .map_err(render)?;
    write_atomic(path, &buf).map_err(io(path))
}

/// Power-law fits of a session.
#[derive(Debug, Clone, Serialize)]
pub struct SessionFits {
    /// Model.
    pub model: &'static str,
    /// Radius (mm) vs pressure (kPa).
    pub radius_mm_vs_kpa: Option<PowerLawFit>,
    /// Curvature (1/m) vs pressure (kPa).
    pub curvature_per_m_vs_kpa: Option<PowerLawFit>,
    /// Bending angle (deg) vs pressure (kPa).
    pub bending_angle_deg_vs_kpa: Option<PowerLawFit>,
    /// The manifest's pressure unit.
    pub unit: String,
    /// Radius (mm) vs pressure in the manifest's unit.
    pub radius_mm_vs_unit: Option<PowerLawFit>,
    /// Curvature (1/m) vs pressure in the manifest's unit.
    pub curvature_per_m_vs_unit: Option<PowerLawFit>,
    /// Why a fit is missing.
    pub notes: Vec<String>,
}

/// Fits y = a x^b + c to the measured videos (pressure > 0, finite values).
pub fn fit_session(rows: &[VideoRow], unit: &str) -> SessionFits {
    let mut notes = Vec::new();
    let mut fit =
        |name: &str, x: fn(&VideoRow) -> f64, y: fn(&VideoRow) -> f64| -> Option<PowerLawFit> {
            let pts: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| r.status == "ok")
                .map(|r| (x(r), y(r)))
                .filter(|(a, b)| a.is_finite() && *a > 0.0 && b.is_finite())
                .collect();
            let (xs, ys): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
            match fit_power_law(&xs, &ys) {
                Ok(f) => Some(f),
                Err(e) => {
                    notes.push(format!("{name}: {e}"));
                    None
                }
            }
        };
    SessionFits {
        model: "y = a * x^b + c",
        radius_mm_vs_kpa: fit("radius vs kPa", |r| r.pressure_kpa, |r| r.radius_mm),
        curvature_per_m_vs_kpa: fit(
            "curvature vs kPa",
            |r| r.pressure_kpa,
            |r| r.curvature_per_m,
        ),
        bending_angle_deg_vs_kpa: fit("angle vs kPa", |r| r.pressure_kpa, |r| r.bending_angle_deg),
        unit: unit.to_string(),
        radius_mm_vs_unit: fit("radius vs unit", |r| r.pressure, |r| r.radius_mm),
        curvature_per_m_vs_unit: fit("curvature vs unit", |r| r.pressure, |r| r.curvature_per_m),
        notes,
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
}

/// Draws an x-y plot to `stem.png` and `stem.svg`.
pub fn plot_xy(
    stem: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<(), ReportError> {
    let finite: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    if finite.is_empty() {
        return Ok(());
    }
    let (mut x0, mut x1, mut y0, mut y1) = finite.iter().fold(
        (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ),
        |(a, b, c, d), (x, y)| (a.min(*x), b.max(*x), c.min(*y), d.max(*y)),
    );
    let pad = |lo: &mut f64, hi: &mut f64| {
        let m = ((*hi - *lo) * 0.08).max(1e-9 + 0.05 * hi.abs());
        *lo -= m;
        *hi += m;
    };
    pad(&mut x0, &mut x1);
    pad(&mut y0, &mut y1);
    if let Some(dir) = stem.parent() {
        std::fs::create_dir_all(dir).map_err(io(dir))?;
    }
    let png = stem.with_extension("png");
    let svg = stem.with_extension("svg");
    for (target, is_png) in [(&png, true), (&svg, false)] {
        let tmp = target.with_file_name(format!(
            ".{}.tmp.{}",
            target
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            if is_png { "png" } else { "svg" }
        ));
        let err = |e: String| ReportError::Render {
            path: target.to_path_buf(),
            message: e,
        };
        {
            if is_png {
                draw_chart(
                    BitMapBackend::new(&tmp, (900, 600)).into_drawing_area(),
                    title,
                    x_label,
                    y_label,
                    (x0, x1, y0, y1),
                    series,
                )
                .map_err(err)?;
            } else {
                draw_chart(
                    SVGBackend::new(&tmp, (900, 600)).into_drawing_area(),
                    title,
                    x_label,
                    y_label,
                    (x0, x1, y0, y1),
                    series,
                )
                .map_err(err)?;
            }
        }
        std::fs::rename(&tmp, target).map_err(io(target))?;
    }
    Ok(())
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
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .draw()
        .map_err(|e| e.to_string())?;
    for (i, s) in series.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        if s.line {
            chart
                .draw_series(LineSeries::new(pts, color.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(s.label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
        } else {
            chart
                .draw_series(pts.into_iter().map(|p| Circle::new(p, 4, color.filled())))
                .map_err(|e| e.to_string())?
                .label(s.label)
                .legend(move |(x, y)| Circle::new((x + 8, y), 4, color.filled()));
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())?;
    root.present().map_err(|e| e.to_string())
}

/// Draws the QA overlay on an undistorted frame: mask outline (green), centroids (blue
/// crosses, numbered order by colour from yellow at the clamp to blue at the tip) and
/// the fitted circle (magenta); writes PNG atomically.
pub fn write_overlay(
    path: &Path,
    undistorted: &RgbImage,
    mask: &image::GrayImage,
    markers: &[Point2<f64>],
    center: Point2<f64>,
    radius_px: f64,
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
    if radius_px.is_finite() && center.x.is_finite() && radius_px < 1e6 {
        let steps = ((radius_px * 2.0 * std::f64::consts::PI) as usize).clamp(64, 20_000);
        for i in 0..steps {
            let t = i as f64 / steps as f64 * std::f64::consts::TAU;
            let (x, y) = (
                center.x + radius_px * t.cos(),
                center.y + radius_px * t.sin(),
            );
            if x >= 0.0 && y >= 0.0 && (x as u32) < w && (y as u32) < h {
                img.put_pixel(x as u32, y as u32, image::Rgb([230, 0, 230]));
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

    fn row(file: &str, p: f64, r: f64) -> VideoRow {
        VideoRow {
            file: file.into(),
            pressure_kpa: p,
            pressure: p / 100.0,
            radius_mm: r,
            radius_mm_median: r,
            radius_mm_std: 0.1,
            curvature_per_m: 1000.0 / r,
            bending_angle_deg: 10.0,
            fit_rms_px: 0.05,
            frames_used: 10,
            frames_rejected: 0,
            status: "ok".into(),
        }
    }

    #[test]
    fn per_video_csv_opens_as_a_table() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("per_video.csv");
        let mut rows = vec![row("a.mp4", 20.0, 120.0), row("b, c.mp4", 40.0, 80.0)];
        rows[1].radius_mm_median = f64::NAN;
        write_per_video_csv(&p, &rows, "bar").unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        let mut lines = text.lines();
        assert_eq!(
            lines.next().unwrap(),
            "file,pressure_kpa,pressure_bar,radius_mm,radius_mm_median,radius_mm_std,curvature_per_m,bending_angle_deg,fit_rms_px,frames_used,frames_rejected,status"
        );
        assert_eq!(
            lines.next().unwrap(),
            "a.mp4,20.0000,0.2000,120.0000,120.0000,0.1000,8.3333,10.0000,0.0500,10,0,ok"
        );
        assert!(lines
            .next()
            .unwrap()
            .starts_with("\"b, c.mp4\",40.0000,0.4000,80.0000,,"));
    }

    #[test]
    fn fits_and_plots_are_written() {
        let d = tempfile::tempdir().unwrap();
        let rows: Vec<VideoRow> = (1..=6)
            .map(|i| {
                row(
                    "v",
                    15.0 * i as f64,
                    800.0 * (15.0 * i as f64).powf(-0.8) + 10.0,
                )
            })
            .collect();
        let f = fit_session(&rows, "bar");
        let r = f.radius_mm_vs_kpa.unwrap();
        assert!(
            (r.b + 0.8).abs() < 1e-4 && (r.c - 10.0).abs() < 1e-2,
            "{r:?}"
        );
        let stem = d.path().join("radius_vs_pressure");
        plot_xy(
            &stem,
            "radius",
            "pressure (kPa)",
            "radius (mm)",
            &[Series {
                label: "measured",
                points: rows.iter().map(|r| (r.pressure_kpa, r.radius_mm)).collect(),
                line: false,
            }],
        )
        .unwrap();
        assert!(std::fs::metadata(stem.with_extension("png")).unwrap().len() > 1000);
        assert!(std::fs::read_to_string(stem.with_extension("svg"))
            .unwrap()
            .contains("<svg"));
    }
}
