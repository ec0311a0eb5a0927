//! Synthetic frames of a bending actuator whose marker line is a circular arc of known
//! radius, seen through a calibrated camera (fisheye included).
//!
//! The actuator's side face lies in a plane (the actuator plane) at a known pose. Every
//! sub-pixel sample's viewing ray is intersected with that plane once
//! ([`PlaneSampler`]); each frame then only shades plane points: a white sheet, the
//! clamp, the pale silicone body around the marker arc, red marker discs, optionally a
//! distracting red object; then lighting gradient, vignetting, blur and sensor noise.
//! Because the sampling is done in the plane, a marker disc is exactly a disc there, and
//! the circle through the marker centres has exactly the scene's radius.

use image::RgbImage;
use nalgebra::{Point2, Vector3};
use rayon::prelude::*;

use super::board::BoardPose;
use super::rng::SplitMix64;
use super::RenderError;
use crate::calib::{Calibration, UndistortSettings, Undistorter};

/// Sheet colour (RGB), before lighting.
pub const SHEET_RGB: [f64; 3] = [236.0, 236.0, 230.0];
/// Silicone body colour.
pub const BODY_RGB: [f64; 3] = [214.0, 206.0, 188.0];
/// Marker colour.
pub const MARKER_RGB: [f64; 3] = [196.0, 28.0, 34.0];
/// Clamp colour.
pub const CLAMP_RGB: [f64; 3] = [62.0, 62.0, 68.0];
/// Distracting object colour.
pub const DISTRACTOR_RGB: [f64; 3] = [205.0, 22.0, 26.0];

/// A scene in the actuator plane: the colour of a plane point (mm) before lighting.
pub trait Shade {
    /// RGB of plane point `p`.
    fn shade(&self, p: Point2<f64>) -> [f64; 3];
}

impl Shade for ArcScene {
    fn shade(&self, p: Point2<f64>) -> [f64; 3] {
        ArcScene::shade(self, p)
    }
}

/// The scene in actuator-plane coordinates (mm; x along the rest actuator from the clamp,
/// y down in the image, bending towards -y).
#[derive(Debug, Clone, PartialEq)]
pub struct ArcScene {
    /// Curvature of the marker line, 1/mm (0: straight).
    pub curvature_per_mm: f64,
    /// Start of the marker line (the clamp's edge), plane mm.
    pub origin_mm: Point2<f64>,
    /// Arc-length positions of the markers along the marker line, mm.
    pub marker_s_mm: Vec<f64>,
    /// Marker disc diameter, mm.
    pub marker_diameter_mm: f64,
    /// Body length beyond the clamp, mm.
    pub length_mm: f64,
    /// Body on the inside of the bend (towards -y at rest: the strain-limiting bottom), mm.
    pub below_mm: f64,
    /// Body on the outside of the bend (towards +y at rest: the chambers), mm.
    pub above_mm: f64,
    /// Clamp length along x (behind the origin), mm.
    pub clamp_mm: f64,
    /// A red disc that is not a marker: centre and diameter, mm.
    pub distractor: Option<(Point2<f64>, f64)>,
    /// Marker paint (RGB before lighting; default [`MARKER_RGB`], red).
    pub marker_rgb: [f64; 3],
}

impl ArcScene {
    /// The reference actuator of method.md §4 seen from the side: 8 markers (3 mm) at
    /// the centres of chambers 2..9, 102.25 mm beyond the clamp (116 - 13.75), 14 mm of
    /// body below the marker line (bottom layer and channel up to mid cavity height)
    /// and 9.5 mm above, a 15 mm clamp, no distractor.
    pub fn reference_actuator(curvature_per_mm: f64, origin_mm: Point2<f64>) -> Self {
        Self {
            curvature_per_mm,
            origin_mm,
            marker_s_mm: (0..8).map(|i| 1.0 + 5.75 + 12.5 * i as f64).collect(),
            marker_diameter_mm: 3.0,
            length_mm: 102.25,
            below_mm: 14.0,
            above_mm: 9.5,
            clamp_mm: 15.0,
            distractor: None,
            marker_rgb: MARKER_RGB,
        }
    }

    /// Marker centres in the plane, mm.
    pub fn markers_mm(&self) -> Vec<Point2<f64>> {
        self.marker_s_mm
            .iter()
            .map(|&s| self.point_at(s, 0.0))
            .collect()
    }

    /// The point at arc length `s` and signed normal offset `n` (towards +y at rest; for a
    /// positive curvature, away from the centre of curvature, the outside of the bend).
    pub fn point_at(&self, s: f64, n: f64) -> Point2<f64> {
        let k = self.curvature_per_mm;
        let (t, nrm) = if k.abs() < 1e-12 {
            (Vector3::new(s, 0.0, 0.0), Vector3::new(0.0, 1.0, 0.0))
        } else {
            let a = k * s;
            (
                Vector3::new(a.sin() / k, -(1.0 - a.cos()) / k, 0.0),
                Vector3::new(a.sin(), a.cos(), 0.0),
            )
        };
        Point2::new(
            self.origin_mm.x + t.x + n * nrm.x,
            self.origin_mm.y + t.y + n * nrm.y,
        )
    }

    /// Arc length and normal offset of a plane point (inverse of [`Self::point_at`]).
    fn arc_coordinates(&self, p: Point2<f64>) -> (f64, f64) {
        let k = self.curvature_per_mm;
        let d = p - self.origin_mm;
        if k.abs() < 1e-12 {
            return (d.x, d.y);
        }
        // Centre of curvature at origin + (0, -1/k); p - centre = rho (sin a, cos a) with
        // rho = 1/k + n and a = k s.
        let r = 1.0 / k;
        let (vx, vy) = (d.x, d.y + r);
        let dist = vx.hypot(vy);
        let (ang, rho) = if k > 0.0 {
            (vx.atan2(vy), dist)
        } else {
            ((-vx).atan2(-vy), -dist)
        };
        let s = ang / k;
        let n = rho - r;
        (s, n)
    }

    /// True bending angle between the first and the last marker, degrees: the turning of
    /// the tangent, which the half-angle convention recovers on a circular arc.
    pub fn bending_angle_deg(&self) -> f64 {
        match (self.marker_s_mm.first(), self.marker_s_mm.last()) {
            (Some(a), Some(b)) => ((b - a) * self.curvature_per_mm).to_degrees(),
            _ => 0.0,
        }
    }

    /// True when plane point `p` (mm) lies on the actuator's side face.
    pub fn on_body(&self, p: Point2<f64>) -> bool {
        let (s, n) = self.arc_coordinates(p);
        s >= 0.0 && s <= self.length_mm && n >= -self.below_mm && n <= self.above_mm
    }

    /// Colour of a plane point before lighting.
    fn shade(&self, p: Point2<f64>) -> [f64; 3] {
        let r_marker = 0.5 * self.marker_diameter_mm;
        if let Some((c, d)) = self.distractor {
            if (p - c).norm() <= 0.5 * d {
                return DISTRACTOR_RGB;
            }
        }
        let d = p - self.origin_mm;
        if d.x <= 0.0
            && d.x >= -self.clamp_mm
            && d.y >= -self.below_mm - 4.0
            && d.y <= self.above_mm + 4.0
        {
            return CLAMP_RGB;
        }
        if self.on_body(p) {
            let (s, _) = self.arc_coordinates(p);
            for &m in &self.marker_s_mm {
                if (s - m).abs() <= 2.0 * r_marker && (p - self.point_at(m, 0.0)).norm() <= r_marker
                {
                    return self.marker_rgb;
                }
            }
            return BODY_RGB;
        }
        SHEET_RGB
    }
}

/// Lighting, optics and sensor settings of a synthetic frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameLook {
    /// Gaussian blur sigma, px.
    pub blur_sigma_px: f32,
    /// Sensor noise sigma, levels (per channel).
    pub noise_sigma: f64,
    /// Relative brightness drop from the left to the right edge.
    pub gradient: f64,
    /// Relative brightness drop at the frame corners (cos^4-like vignetting).
    pub vignetting: f64,
}

impl Default for FrameLook {
    fn default() -> Self {
        Self {
            blur_sigma_px: 0.7,
            noise_sigma: 3.0,
            gradient: 0.12,
            vignetting: 0.25,
        }
    }
}

/// Plane coordinates of every sub-pixel sample, computed once per camera and plane.
pub struct PlaneSampler {
    width: u32,
    height: u32,
    supersample: u32,
    /// Plane point (mm) of each sample, row-major by pixel then sample; NaN off the plane.
    samples: Vec<[f32; 2]>,
}

impl PlaneSampler {
    /// Intersects every sample ray of `camera` with the plane z = 0 of `plane` (a plane
    /// point (x, y, 0) is at `R p + t` in the camera frame).
    pub fn new(
        camera: &Calibration,
        plane: &BoardPose,
        supersample: u32,
        seed: u64,
    ) -> Result<Self, RenderError> {
        let und = Undistorter::new(camera, UndistortSettings::default())?;
        let (w, h) = (camera.image_width, camera.image_height);
        let n = supersample.max(1);
        let normal = plane.rotation * Vector3::z();
        let offset = normal.dot(&plane.translation_mm);
        let inv = plane.rotation.inverse();
        let rows: Vec<Result<Vec<[f32; 2]>, RenderError>> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut jitter = SplitMix64::new(seed ^ (y as u64).wrapping_mul(0x9E37_79B9));
                let mut pixels = Vec::with_capacity((w * n * n) as usize);
                for x in 0..w {
                    for sy in 0..n {
                        for sx in 0..n {
                            pixels.push(Point2::new(
                                x as f64 - 0.5 + (sx as f64 + jitter.uniform()) / n as f64,
                                y as f64 - 0.5 + (sy as f64 + jitter.uniform()) / n as f64,
                            ));
                        }
                    }
                }
                let rays = und.rays_from_pixels(&pixels)?;
                Ok(rays
                    .iter()
                    .map(|ray| {
                        let denom = normal.dot(ray);
                        let s = offset / denom;
                        if denom.abs() < 1e-12 || s <= 0.0 {
                            return [f32::NAN, f32::NAN];
                        }
                        let p = inv * (ray * s - plane.translation_mm);
                        [p.x as f32, p.y as f32]
                    })
                    .collect())
            })
            .collect();
        let mut samples = Vec::with_capacity((w * h * n * n) as usize);
        for r in rows {
            samples.extend(r?);
        }
        Ok(Self {
            width: w,
            height: h,
            supersample: n,
            samples,
        })
    }

    /// Renders one frame of `scene`, shifted in the plane by `shift_mm` (per-frame jitter).
    pub fn render<S: Shade + Sync>(
        &self,
        scene: &S,
        shift_mm: [f64; 2],
        look: &FrameLook,
        seed: u64,
    ) -> RgbImage {
        let (w, h) = (self.width, self.height);
        let nn = (self.supersample * self.supersample) as usize;
        let (cx, cy) = (0.5 * (w as f64 - 1.0), 0.5 * (h as f64 - 1.0));
        let rmax2 = cx * cx + cy * cy;
        let mut buf = vec![0f32; (w * h * 3) as usize];
        buf.par_chunks_mut((w * 3) as usize)
            .enumerate()
            .for_each(|(y, row)| {
                for x in 0..w as usize {
                    let base = (y * w as usize + x) * nn;
                    let mut acc = [0.0f64; 3];
                    for s in &self.samples[base..base + nn] {
                        let c = if s[0].is_nan() {
                            SHEET_RGB
                        } else {
                            scene.shade(Point2::new(
                                s[0] as f64 - shift_mm[0],
                                s[1] as f64 - shift_mm[1],
                            ))
                        };
                        for k in 0..3 {
                            acc[k] += c[k];
                        }
                    }
                    let (dx, dy) = (x as f64 - cx, y as f64 - cy);
                    let light = (1.0 - look.gradient * x as f64 / w as f64)
                        * (1.0 - look.vignetting * (dx * dx + dy * dy) / rmax2);
                    for k in 0..3 {
                        row[x * 3 + k] = (acc[k] / nn as f64 * light) as f32;
                    }
                }
            });
        let img = image::ImageBuffer::<image::Rgb<f32>, Vec<f32>>::from_raw(w, h, buf)
            .unwrap_or_else(|| image::ImageBuffer::new(w, h));
        let blurred = if look.blur_sigma_px > 0.0 {
            imageproc::filter::gaussian_blur_f32(&img, look.blur_sigma_px)
        } else {
            img
        };
        let mut rng = SplitMix64::new(seed);
        RgbImage::from_fn(w, h, |x, y| {
            let p = blurred.get_pixel(x, y);
            let mut out = [0u8; 3];
            for k in 0..3 {
                out[k] = (p[k] as f64 + look.noise_sigma * rng.normal())
                    .round()
                    .clamp(0.0, 255.0) as u8;
            }
            image::Rgb(out)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(k: f64) -> ArcScene {
        ArcScene {
            curvature_per_mm: k,
            origin_mm: Point2::new(-50.0, 10.0),
            marker_s_mm: (0..8).map(|i| 19.0 + 12.5 * i as f64).collect(),
            marker_diameter_mm: 3.0,
            length_mm: 116.0,
            below_mm: 14.0,
            above_mm: 9.5,
            clamp_mm: 15.0,
            distractor: None,
            marker_rgb: MARKER_RGB,
        }
    }

    #[test]
    fn markers_lie_on_a_circle_of_the_scene_radius() {
        let s = scene(1.0 / 60.0);
        let c = Point2::new(-50.0, 10.0 - 60.0);
        for m in s.markers_mm() {
            assert!(((m - c).norm() - 60.0).abs() < 1e-9);
        }
        let straight = scene(0.0);
        for m in straight.markers_mm() {
            assert!((m.y - 10.0).abs() < 1e-12);
        }
        // Turning angle between the first and last marker.
        assert!((s.bending_angle_deg() - (87.5f64 / 60.0).to_degrees()).abs() < 1e-9);
    }

    #[test]
    fn arc_coordinates_invert_point_at() {
        for k in [0.0, 1.0 / 40.0, -1.0 / 80.0] {
            let s = scene(k);
            for (a, n) in [(10.0, 0.0), (50.0, 5.0), (90.0, -9.0)] {
                let (a2, n2) = s.arc_coordinates(s.point_at(a, n));
                assert!(
                    (a - a2).abs() < 1e-9 && (n - n2).abs() < 1e-9,
                    "k {k}: {a},{n} -> {a2},{n2}"
                );
            }
        }
    }
}
