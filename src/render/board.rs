//! Synthetic checkerboard photos through a calibrated camera (fisheye or pinhole).
//!
//! Used to make calibration fixtures with known K and D, and scale photos with a known
//! mm per px. Each pixel is supersampled on a jittered `n x n` grid; every sample's ray
//! comes from the camera model, hits the posed board plane (or misses it and sees the
//! background), and the samples are averaged. Then a Gaussian blur (optics) and Gaussian
//! noise (sensor) are applied.

use image::GrayImage;
use nalgebra::{Point2, Rotation3, Vector3};
use rayon::prelude::*;

use super::rng::SplitMix64;
use super::RenderError;
use crate::calib::{Board, Calibration, UndistortSettings, Undistorter};

/// Grey level of a white square.
pub const WHITE: f64 = 225.0;
/// Grey level of a black square.
pub const BLACK: f64 = 25.0;
/// Grey level of the background behind the board.
pub const BACKGROUND: f64 = 110.0;
/// White margin around the squares, in squares.
pub const MARGIN_SQUARES: f64 = 1.0;

/// Board pose: a board point `X_b` (mm, z = 0 on the board) is at `R X_b + t` in the
/// camera frame (x right, y down, z forward).
#[derive(Debug, Clone, PartialEq)]
pub struct BoardPose {
    /// Rotation board -> camera.
    pub rotation: Rotation3<f64>,
    /// Position of the board origin (first inner corner), mm.
    pub translation_mm: Vector3<f64>,
}

/// Image formation settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhotoSettings {
    /// Samples per pixel side (n x n samples per pixel).
    pub supersample: u32,
    /// Gaussian blur sigma, px (0: none).
    pub blur_sigma_px: f32,
    /// Sensor noise sigma, grey levels (0: none).
    pub noise_sigma: f64,
    /// Noise seed.
    pub seed: u64,
}

impl Default for PhotoSettings {
    fn default() -> Self {
        Self {
            supersample: 3,
            blur_sigma_px: 0.7,
            noise_sigma: 2.0,
            seed: 1,
        }
    }
}

/// Grey level of the board at board coordinates (mm), or `None` off the board.
fn board_value(board: &Board, x: f64, y: f64) -> Option<f64> {
    let s = board.square_mm;
    let (x0, y0) = (-s * (1.0 + MARGIN_SQUARES), -s * (1.0 + MARGIN_SQUARES));
    let x1 = s * (board.cols as f64 + MARGIN_SQUARES);
    let y1 = s * (board.rows as f64 + MARGIN_SQUARES);
    if x < x0 || x > x1 || y < y0 || y > y1 {
        return None;
    }
    let (i, j) = ((x / s).floor() as i64 + 1, (y / s).floor() as i64 + 1);
    let inside = i >= 0 && j >= 0 && i <= board.cols as i64 && j <= board.rows as i64;
    if inside && (i + j) % 2 == 0 {
        Some(BLACK)
    } else {
        Some(WHITE)
    }
}

/// Renders one photo of `board` at `pose` through `camera`.
pub fn render_board_photo(
    camera: &Calibration,
    board: &Board,
    pose: &BoardPose,
    settings: &PhotoSettings,
) -> Result<GrayImage, RenderError> {
    let und = Undistorter::new(camera, UndistortSettings::default())?;
    let (w, h) = (camera.image_width, camera.image_height);
    let n = settings.supersample.max(1);
    let normal = pose.rotation * Vector3::z();
    let offset = normal.dot(&pose.translation_mm);
    let inv = pose.rotation.inverse();
    let rows: Vec<Result<Vec<f32>, RenderError>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut acc = vec![0f32; w as usize];
            // Jittered (stratified) samples: one random point in each of the n x n cells
            // of a pixel, so edge aliasing becomes noise instead of a pattern that would
            // bias corner and centroid positions.
            let mut jitter = SplitMix64::new(settings.seed ^ (y as u64).wrapping_mul(0x9E37_79B9));
            for sy in 0..n {
                let pixels: Vec<Point2<f64>> = (0..w * n)
                    .map(|i| {
                        let px = -0.5 + (i as f64 + jitter.uniform()) / n as f64;
                        let py = y as f64 - 0.5 + (sy as f64 + jitter.uniform()) / n as f64;
                        Point2::new(px, py)
                    })
                    .collect();
                let rays = und.rays_from_pixels(&pixels)?;
                for (i, ray) in rays.iter().enumerate() {
                    let denom = normal.dot(ray);
                    let mut v = BACKGROUND * (0.85 + 0.15 * (i as f64 / (w * n) as f64));
                    if denom.abs() > 1e-12 {
                        let s = offset / denom;
                        if s > 0.0 {
                            let b = inv * (ray * s - pose.translation_mm);
                            if let Some(g) = board_value(board, b.x, b.y) {
                                v = g;
                            }
                        }
                    }
                    acc[i / n as usize] += v as f32;
                }
            }
            let k = 1.0 / (n * n) as f32;
            Ok(acc.into_iter().map(|a| a * k).collect())
        })
        .collect();
    let mut img = image::ImageBuffer::<image::Luma<f32>, Vec<f32>>::new(w, h);
    for (y, row) in rows.into_iter().enumerate() {
        for (x, v) in row?.into_iter().enumerate() {
            img.put_pixel(x as u32, y as u32, image::Luma([v]));
        }
    }
    let blurred = if settings.blur_sigma_px > 0.0 {
        imageproc::filter::gaussian_blur_f32(&img, settings.blur_sigma_px)
    } else {
        img
    };
    let mut rng = SplitMix64::new(settings.seed);
    let out = GrayImage::from_fn(w, h, |x, y| {
        let v = blurred.get_pixel(x, y)[0] as f64 + settings.noise_sigma * rng.normal();
        image::Luma([v.round().clamp(0.0, 255.0) as u8])
    });
    Ok(out)
}

/// The board's outer corners (including the white margin), board frame, mm.
fn board_outline(board: &Board) -> [Vector3<f64>; 4] {
    let s = board.square_mm;
    let m = s * (1.0 + MARGIN_SQUARES);
    let (x1, y1) = (
        s * (board.cols as f64 - 1.0) + m,
        s * (board.rows as f64 - 1.0) + m,
    );
    [
        Vector3::new(-m, -m, 0.0),
        Vector3::new(x1, -m, 0.0),
        Vector3::new(x1, y1, 0.0),
        Vector3::new(-m, y1, 0.0),
    ]
}

/// `n` random board poses whose board (with margin) lies fully inside the frame,
/// spread over the frame on a jittered grid so that the views reach its corners, at
/// distances and tilts that keep the board detectable. Deterministic for a seed.
pub fn random_board_poses(
    camera: &Calibration,
    board: &Board,
    n: usize,
    seed: u64,
) -> Result<Vec<BoardPose>, RenderError> {
    random_board_poses_within(camera, board, n, seed, 1.0)
}

/// Like [`random_board_poses`], with every board (with margin) inside the disc of radius
/// `reach` x the frame's half-diagonal around the frame centre, as people hold a board
/// when they rarely bring it into the frame's corners: the target grid is shrunk by
/// `reach` and the boards are made smaller in proportion (farther away). `reach >= 1`
/// gives exactly [`random_board_poses`].
pub fn random_board_poses_within(
    camera: &Calibration,
    board: &Board,
    n: usize,
    seed: u64,
    reach: f64,
) -> Result<Vec<BoardPose>, RenderError> {
    let und = Undistorter::new(camera, UndistortSettings::default())?;
    let (w, h) = (camera.image_width as f64, camera.image_height as f64);
    let mut rng = SplitMix64::new(seed);
    let outline = board_outline(board);
    let centre = Vector3::new(
        board.square_mm * (board.cols as f64 - 1.0) / 2.0,
        board.square_mm * (board.rows as f64 - 1.0) / 2.0,
        0.0,
    );
    let board_size = board.square_mm * (board.cols.max(board.rows) as f64 + 1.0);
    let reach = if reach.is_finite() && reach > 0.0 {
        reach.min(1.0)
    } else {
        1.0
    };
    // Distance at which the board spans about 45% (x reach) of the frame width near the
    // centre.
    let z_ref = camera.fx() * board_size / (0.45 * w) / reach;
    let margin = 0.02 * w.min(h);
    let (fcx, fcy) = (0.5 * (w - 1.0), 0.5 * (h - 1.0));
    let max_radius = reach * fcx.hypot(fcy);
    let tries_per_pose = 400;
    let mut poses = Vec::with_capacity(n);
    let grid = (n as f64).sqrt().ceil() as usize;
    for k in 0..n {
        let (gx, gy) = ((k % grid) as f64, ((k / grid) % grid) as f64);
        let mut placed = None;
        for t in 0..tries_per_pose {
            // Target the board centre at a jittered grid cell, drifting towards the
            // centre of the frame on repeated failures.
            let pull = (t as f64 / tries_per_pose as f64).min(0.8);
            let tx = ((gx + rng.uniform()) / grid as f64 - 0.5) * (1.0 - pull) * reach + 0.5;
            let ty = ((gy + rng.uniform()) / grid as f64 - 0.5) * (1.0 - pull) * reach + 0.5;
            let target = Point2::new(tx * (w - 1.0), ty * (h - 1.0));
            let z = z_ref * rng.range(0.7, 1.2) * (1.0 + 0.5 * pull);
            let rot = Rotation3::from_euler_angles(
                rng.range(-0.6, 0.6),
                rng.range(-0.6, 0.6),
                rng.range(-0.35, 0.35),
            );
            let ray = und.rays_from_pixels(&[target])?[0];
            let t_vec = ray * (z / ray.z) - rot * centre;
            let pts: Vec<Vector3<f64>> = outline.iter().map(|p| rot * p + t_vec).collect();
            if pts.iter().any(|p| p.z <= 0.2 * z_ref) {
                continue;
            }
            // Board normal must face the camera well enough to be seen.
            let facing = (rot * Vector3::z()).dot(&(-t_vec.normalize())).abs();
            if facing < 0.35 {
                continue;
            }
            let px = und.project(&pts)?;
            let inside = px.iter().all(|p| {
                p.x >= margin
                    && p.y >= margin
                    && p.x <= w - 1.0 - margin
                    && p.y <= h - 1.0 - margin
                    && (reach >= 1.0 || (p.x - fcx).hypot(p.y - fcy) <= max_radius)
            });
            if inside {
                placed = Some(BoardPose {
                    rotation: rot,
                    translation_mm: t_vec,
                });
                break;
            }
        }
        match placed {
            Some(p) => poses.push(p),
            None => {
                return Err(RenderError::NoPose {
                    width: camera.image_width,
                    height: camera.image_height,
                    tries: tries_per_pose,
                })
            }
        }
    }
    Ok(poses)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn board_pattern_has_black_first_square_and_white_margin() {
        let b = Board::new(3, 2, 10.0).unwrap();
        // Square touching the first inner corner from the upper left is black.
        assert_eq!(board_value(&b, -5.0, -5.0), Some(BLACK));
        assert_eq!(board_value(&b, 5.0, -5.0), Some(WHITE));
        assert_eq!(board_value(&b, 5.0, 5.0), Some(BLACK));
        // Margin.
        assert_eq!(board_value(&b, -15.0, 0.0), Some(WHITE));
        assert_eq!(board_value(&b, -25.0, 0.0), None);
    }
}
