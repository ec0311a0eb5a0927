//! Reports: plots (plotters, PNG and SVG rendered in memory), JSON, QA overlays and the
//! session's HTML page ([`html`]). Every file is written atomically. Tables are written
//! by [`crate::table`].

pub mod html;

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
}

/// Plot size, px.
pub const PLOT_SIZE: (u32, u32) = (900, 600);

/// Draws an x-y plot to `stem.png` and `stem.svg`, each rendered in memory and written
/// atomically. Returns `false`, and removes an earlier plot of the same name, when no
/// series has a finite point.
pub fn plot_xy(
    stem: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<bool, ReportError> {
    let png = stem.with_extension("png");
    let svg = stem.with_extension("svg");
    let finite: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    if finite.is_empty() {
        for p in [&png, &svg] {
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
        |(a, b, c, d), (x, y)| (a.min(*x), b.max(*x), c.min(*y), d.max(*y)),
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
            2,
            "no temporaries left"
        );
        let none = vec![(f64::NAN, 1.0)];
        assert!(!plot_xy(&stem, "radius", "p", "r", &[series(none)]).unwrap());
        assert!(!stem.with_extension("png").exists() && !stem.with_extension("svg").exists());
    }
}
