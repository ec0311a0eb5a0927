//! Whole-frame undistortion (the original method, and the QA overlay): a decoded frame
//! remapped through the calibration, and the overlay of one measured frame per video.

use std::path::Path;

use opencv::core::Mat;
use opencv::prelude::*;

use crate::calib::{CalibError, Calibration, UndistortSettings, Undistorter};
use crate::detect::{body_mask, exposure_adjusted, mask_from_rgb, DetectMode};
use crate::io::bounded_file_name;
use crate::report::{write_overlay, ReportError};
use crate::session::SessionConfig;
use crate::video::Pixels;

use super::frame::FrameMeasurement;

/// Width above which the overlay is drawn at a reduced size (a QA picture needs no
/// more, and full-frame maps of a 4K frame would dominate the memory of a run).
pub const OVERLAY_MAX_WIDTH: u32 = 1920;

/// Colour of the one fitted circle (magenta).
pub const CIRCLE_RGB: [u8; 3] = [230, 0, 230];
/// Colour of outline mode's circle fitted to the body's edge (orange), beside the
/// reported circle.
pub const EDGE_CIRCLE_RGB: [u8; 3] = [255, 140, 0];
/// Colours of the segments' circles of a segmented actuator, from the clamp.
pub const SEGMENT_CIRCLE_RGB: [[u8; 3]; 4] =
    [[230, 0, 230], [255, 140, 0], [0, 150, 255], [120, 60, 0]];

/// Why an overlay was not written.
#[derive(Debug, thiserror::Error)]
pub enum OverlayError {
    /// Undistorting the frame.
    #[error(transparent)]
    Calib(#[from] CalibError),
    /// Drawing or writing the picture (a full disk among others).
    #[error(transparent)]
    Report(#[from] ReportError),
}

/// Where the overlay of video `file` goes, relative to OUT (name bounded).
pub fn overlay_rel_path(file: &str) -> String {
    format!("overlays/{}", bounded_file_name(file, ".png"))
}

/// Undistorts a whole decoded frame (RGB as decoded, or converted from YUV first).
pub fn undistort_pixels(
    und: &Undistorter,
    maps: &(Mat, Mat),
    pixels: &Pixels,
) -> Result<image::RgbImage, CalibError> {
    match pixels {
        Pixels::Rgb(rgb) => undistort_rgb(und, maps, rgb),
        yuv => undistort_rgb(und, maps, &yuv.to_rgb()),
    }
}

/// Undistorts a whole RGB frame (OpenCV remap).
pub fn undistort_rgb(
    und: &Undistorter,
    maps: &(Mat, Mat),
    raw: &image::RgbImage,
) -> Result<image::RgbImage, CalibError> {
    let cv = |e: opencv::Error| CalibError::cv("whole-frame undistortion", e);
    let (w, h) = raw.dimensions();
    let flat_src = Mat::from_slice(raw.as_raw()).map_err(cv)?;
    let mat = flat_src.reshape(3, h as i32).map_err(cv)?.clone_pointee();
    let flat = und.undistort_image(maps, &mat)?;
    let bytes = flat.data_bytes().map_err(cv)?.to_vec();
    image::RgbImage::from_raw(w, h, bytes).ok_or_else(|| {
        CalibError::cv(
            "whole-frame undistortion",
            opencv::Error::new(0, "unexpected buffer size".to_string()),
        )
    })
}

/// Writes the QA overlay of `file` (undistorted frame, mask outline, ordered markers,
/// circle) to `OUT/overlays/<file>.png` (name bounded) and returns its path relative to
/// OUT. The frame is drawn at most [`OVERLAY_MAX_WIDTH`] wide.
pub fn write_video_overlay(
    out: &Path,
    file: &str,
    pixels: &Pixels,
    calib: &Calibration,
    config: &SessionConfig,
    m: &FrameMeasurement,
) -> Result<String, OverlayError> {
    let raw = pixels.to_rgb();
    let (w, h) = raw.dimensions();
    let k = w.div_ceil(OVERLAY_MAX_WIDTH).max(1);
    let small;
    let (frame, (sw, sh)) = if k > 1 {
        small = image::imageops::resize(&raw, w / k, h / k, image::imageops::FilterType::Triangle);
        (&small, (w / k, h / k))
    } else {
        (&raw, (w, h))
    };
    // Pixel centres at integers: x' + 0.5 = (x + 0.5) / k.
    let f = |v: f64| (v + 0.5) / k as f64 - 0.5;
    let und = calib
        .for_resolution(sw, sh)
        .and_then(|c| Undistorter::new(&c, UndistortSettings::default()))?;
    let maps = und.maps()?;
    let img = undistort_rgb(&und, &maps, frame)?;
    let mask = match config.detect.mode {
        DetectMode::Dots => {
            let hsv = if config.detect.auto_exposure {
                exposure_adjusted(&img, &config.detect.hsv)
            } else {
                config.detect.hsv
            };
            mask_from_rgb(&img, &hsv)
        }
        DetectMode::Outline => body_mask(&img, &config.detect.outline.band),
    };
    let markers: Vec<nalgebra::Point2<f64>> = m
        .markers_px
        .iter()
        .map(|p| nalgebra::Point2::new(f(p.x), f(p.y)))
        .collect();
    let ignored: Vec<nalgebra::Point2<f64>> = m
        .ignored_px
        .iter()
        .map(|p| nalgebra::Point2::new(f(p.x), f(p.y)))
        .collect();
    let scaled = |c: nalgebra::Point2<f64>, r: f64, colour| {
        (nalgebra::Point2::new(f(c.x), f(c.y)), r / k as f64, colour)
    };
    // One circle, or one per segment (colours in turn).
    let circles: Vec<_> = if m.segments.is_empty() {
        vec![scaled(m.center_px, m.radius_px, CIRCLE_RGB)]
    } else {
        m.segments
            .iter()
            .enumerate()
            .map(|(i, s)| {
                scaled(
                    s.center_px,
                    s.radius_px,
                    SEGMENT_CIRCLE_RGB[i % SEGMENT_CIRCLE_RGB.len()],
                )
            })
            .collect()
    };
    let mut circles = circles;
    if let Some((c, r)) = m.edge_circle_px {
        circles.push(scaled(c, r, EDGE_CIRCLE_RGB));
    }
    let rel = overlay_rel_path(file);
    write_overlay(&out.join(&rel), &img, &mask, &markers, &ignored, &circles)?;
    Ok(rel)
}
