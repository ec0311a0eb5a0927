//! RGB-D sessions: colour frames with aligned 16-bit depth give 3D marker positions, so
//! the radius comes out in mm with no scale photo (circle fitted in the best-fit plane
//! of the 3D markers, [`crate::fit::fit_circle_3d`]).
//!
//! ```text
//! SESSION/
//!   color/             colour frames (PNG/JPG), sorted by name
//!   depth/             16-bit PNG depth frames aligned to the colour frames, same names
//!   intrinsics.json    {"width", "height", "fx", "fy", "cx", "cy", "depth_scale_m",
//!                       "fps", "distortion": [k1, k2, p1, p2, k3] (optional)}
//!   pressure_log.csv   time_s, pressure_<unit> (frame i is at i / fps)
//! ```
//!
//! `depth_scale_m` is metres per depth unit (RealSense convention: 0.001 by default,
//! 0.0001 in high-accuracy presets). Depth is assumed aligned to the colour image
//! (RealSense `align` to colour): the depth of a marker is the median of the valid depth
//! pixels around its raw centroid.

use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, Point2, Point3};
use serde::Deserialize;

use crate::calib::{Calibration, CameraModel, UndistortSettings, Undistorter};

/// Name of the intrinsics file.
pub const INTRINSICS: &str = "intrinsics.json";

/// Errors of RGB-D sessions.
#[derive(Debug, thiserror::Error)]
pub enum RgbdError {
    /// Folder layout or intrinsics problem.
    #[error("{path}: {why}")]
    Layout {
        /// File or folder.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
}

/// Colour camera intrinsics and depth scale.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RgbdIntrinsics {
    /// Frame width, px.
    pub width: u32,
    /// Frame height, px.
    pub height: u32,
    /// Focal length x, px.
    pub fx: f64,
    /// Focal length y, px.
    pub fy: f64,
    /// Principal point x, px.
    pub cx: f64,
    /// Principal point y, px.
    pub cy: f64,
    /// Metres per depth unit.
    pub depth_scale_m: f64,
    /// Frames per second (frame i is at i / fps).
    #[serde(default = "default_fps")]
    pub fps: f64,
    /// Brown coefficients k1 k2 p1 p2 k3 (empty: none).
    #[serde(default)]
    pub distortion: Vec<f64>,
}

fn default_fps() -> f64 {
    30.0
}

impl RgbdIntrinsics {
    /// Reads and checks `intrinsics.json`.
    pub fn read(path: &Path) -> Result<Self, RgbdError> {
        let bad = |why: String| RgbdError::Layout {
            path: path.to_path_buf(),
            why,
        };
        let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
        let i: RgbdIntrinsics = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
        let pos = [i.fx, i.fy, i.depth_scale_m, i.fps];
        if i.width == 0 || i.height == 0 || !pos.iter().all(|v| v.is_finite() && *v > 0.0) {
            return Err(bad(
                "width, height, fx, fy, depth_scale_m and fps must be positive".into(),
            ));
        }
        if !i.distortion.is_empty() && i.distortion.len() != 5 {
            return Err(bad(
                "distortion needs 5 Brown coefficients k1 k2 p1 p2 k3 (or none)".into(),
            ));
        }
        Ok(i)
    }

    /// The colour camera as a pinhole calibration.
    pub fn calibration(&self) -> Calibration {
        let mut d = self.distortion.clone();
        d.resize(5, 0.0);
        Calibration {
            model: CameraModel::Pinhole,
            image_width: self.width,
            image_height: self.height,
            camera_matrix: Matrix3::new(
                self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0,
            ),
            distortion: d,
            avg_reprojection_error: f64::NAN,
            per_view_errors: vec![],
            board: None,
            views_used: vec![],
            views_rejected: vec![],
            coverage: None,
        }
    }
}

/// One colour + depth frame pair.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbdFrame {
    /// 0-based index in name order.
    pub index: u64,
    /// Time, s (index / fps).
    pub time_s: f64,
    /// Colour frame.
    pub color: PathBuf,
    /// Depth frame.
    pub depth: PathBuf,
}

/// True when `session` has `color/` and `depth/` folders.
pub fn is_rgbd_session(session: &Path) -> bool {
    session.join("color").is_dir() && session.join("depth").is_dir()
}

/// Lists the frame pairs (matched by file stem) and reads the intrinsics.
pub fn list_frames(session: &Path) -> Result<(RgbdIntrinsics, Vec<RgbdFrame>), RgbdError> {
    let intr = RgbdIntrinsics::read(&session.join(INTRINSICS))?;
    let list = |dir: &Path| -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
            .map(|rd| {
                rd.flatten()
                    .map(|e| e.path())
                    .filter(|p| p.is_file())
                    .collect()
            })
            .unwrap_or_default();
        v.sort();
        v
    };
    let depth_dir = session.join("depth");
    let mut frames = Vec::new();
    for color in list(&session.join("color")) {
        let stem = color
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let depth = depth_dir.join(format!("{stem}.png"));
        if !depth.is_file() {
            return Err(RgbdError::Layout {
                path: depth,
                why: format!(
                    "no depth frame for {}: depth/ needs a 16-bit PNG of the same name",
                    color.display()
                ),
            });
        }
        let index = frames.len() as u64;
        frames.push(RgbdFrame {
            index,
            time_s: index as f64 / intr.fps,
            color,
            depth,
        });
    }
    if frames.is_empty() {
        return Err(RgbdError::Layout {
            path: session.join("color"),
            why: "no colour frames".into(),
        });
    }
    Ok((intr, frames))
}

/// 3D positions (mm, colour camera frame) of markers at raw pixel `centroids`, with
/// radius `radius_px` of the depth window, from an aligned depth frame. A marker with no
/// valid depth around it is an error naming it.
pub fn markers_3d_mm(
    centroids: &[Point2<f64>],
    window_px: f64,
    depth: &image::ImageBuffer<image::Luma<u16>, Vec<u16>>,
    intr: &RgbdIntrinsics,
    undistorter: &Undistorter,
) -> Result<Vec<Point3<f64>>, String> {
    let (w, h) = depth.dimensions();
    let rays = undistorter
        .rays_from_pixels(centroids)
        .map_err(|e| e.to_string())?;
    let r = window_px.max(1.0);
    let mut out = Vec::with_capacity(centroids.len());
    for (i, (c, ray)) in centroids.iter().zip(&rays).enumerate() {
        let mut vals: Vec<u16> = Vec::new();
        let (x0, x1) = (
            (c.x - r).floor().max(0.0) as u32,
            ((c.x + r).ceil() as u32).min(w.saturating_sub(1)),
        );
        let (y0, y1) = (
            (c.y - r).floor().max(0.0) as u32,
            ((c.y + r).ceil() as u32).min(h.saturating_sub(1)),
        );
        for y in y0..=y1 {
            for x in x0..=x1 {
                let d = depth.get_pixel(x, y)[0];
                if d > 0 && (x as f64 - c.x).hypot(y as f64 - c.y) <= r {
                    vals.push(d);
                }
            }
        }
        if vals.is_empty() {
            return Err(format!(
                "no depth at marker {} ({:.0}, {:.0})",
                i + 1,
                c.x,
                c.y
            ));
        }
        vals.sort_unstable();
        let z_mm = vals[vals.len() / 2] as f64 * intr.depth_scale_m * 1000.0;
        out.push(Point3::new(ray.x * z_mm, ray.y * z_mm, z_mm));
    }
    Ok(out)
}

/// The colour camera's undistorter (identity framing: rays only are used).
pub fn undistorter(intr: &RgbdIntrinsics) -> Result<Undistorter, crate::calib::CalibError> {
    Undistorter::new(&intr.calibration(), UndistortSettings::default())
}
