//! Depth aligned to colour: what `rs2::align` to colour does, from the recorded
//! intrinsics and depth-to-colour extrinsics.
//!
//! Each valid depth pixel `(u, v)` of depth `z` is deprojected with the depth camera's
//! intrinsics at its two corners `(u - 0.5, v - 0.5)` and `(u + 0.5, v + 0.5)` (both at
//! depth `z`), moved into the colour camera's frame (`p_c = R p_d + t`) and projected
//! with the colour intrinsics; every colour pixel whose centre lies in the projected
//! footprint `[x0, x1) x [y0, y1)` gets the colour-frame depth `Z` of the depth pixel's
//! centre, and where footprints overlap (an occluding edge seen from two viewpoints) the
//! nearest depth wins. Two choices differ from librealsense's `align_images`
//! (src/proc/align.cpp): it fills the closed range `round(x0)..=round(x1)`, so a
//! footprint one colour pixel wide covers two and identical cameras smear depth by a
//! pixel; and it stores the depth camera's `z`, not the colour camera's `Z` (the same
//! for a pure baseline, different once the extrinsics rotate). Here identical cameras
//! and identity extrinsics give back the depth image unchanged.

use nalgebra::{Point2, Vector3};

use super::rosmsg::RigidTransform;
use super::DepthImage;

/// Fixed-point iterations of the inverse Brown model (converges to < 1e-12 in
/// normalized coordinates for RealSense-sized coefficients).
pub const UNDISTORT_ITERATIONS: usize = 20;

/// A pinhole camera with optional Brown (OpenCV `plumb_bob`) distortion.
#[derive(Debug, Clone, PartialEq)]
pub struct StreamCamera {
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// Focal length x, px.
    pub fx: f64,
    /// Focal length y, px.
    pub fy: f64,
    /// Principal point x, px.
    pub cx: f64,
    /// Principal point y, px.
    pub cy: f64,
    /// Brown coefficients k1 k2 p1 p2 k3 (all zero: none).
    pub brown: [f64; 5],
}

impl StreamCamera {
    fn has_distortion(&self) -> bool {
        self.brown.iter().any(|c| *c != 0.0)
    }

    /// Normalized image coordinates -> distorted normalized coordinates (Brown).
    fn distort(&self, x: f64, y: f64) -> (f64, f64) {
        let [k1, k2, p1, p2, k3] = self.brown;
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        (
            x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
        )
    }

    /// The point at depth `z` (m) seen at pixel `p`, camera frame, m.
    pub fn deproject(&self, p: Point2<f64>, z: f64) -> Vector3<f64> {
        let (xd, yd) = ((p.x - self.cx) / self.fx, (p.y - self.cy) / self.fy);
        let (mut x, mut y) = (xd, yd);
        if self.has_distortion() {
            for _ in 0..UNDISTORT_ITERATIONS {
                let (dx, dy) = self.distort(x, y);
                x += xd - dx;
                y += yd - dy;
            }
        }
        Vector3::new(x * z, y * z, z)
    }

    /// The pixel where camera-frame point `q` (z > 0) is seen.
    pub fn project(&self, q: &Vector3<f64>) -> Point2<f64> {
        let (mut x, mut y) = (q.x / q.z, q.y / q.z);
        if self.has_distortion() {
            (x, y) = self.distort(x, y);
        }
        Point2::new(self.fx * x + self.cx, self.fy * y + self.cy)
    }
}

/// Depth-to-colour alignment for one pair of cameras: the depth camera's viewing rays
/// (pixel centres and corners, at unit depth) turned into the colour frame once, so a
/// frame costs a scale, an add and two projections per depth pixel (deprojection is
/// linear in depth: `p(u, v, z) = z p(u, v, 1)`).
#[derive(Debug, Clone)]
pub struct DepthAligner {
    depth_cam: StreamCamera,
    color_cam: StreamCamera,
    translation_m: Vector3<f64>,
    /// R * ray of each depth pixel centre, row-major.
    centres: Vec<Vector3<f64>>,
    /// R * ray of each pixel corner (u - 0.5, v - 0.5), (width + 1) x (height + 1).
    corners: Vec<Vector3<f64>>,
}

impl DepthAligner {
    /// Precomputes the rays of `depth_cam` in `color_cam`'s frame.
    pub fn new(
        depth_cam: &StreamCamera,
        color_cam: &StreamCamera,
        depth_to_color: &RigidTransform,
    ) -> Self {
        let r = depth_to_color.rotation;
        let (w, h) = (depth_cam.width as usize, depth_cam.height as usize);
        let ray = |x: f64, y: f64| r * depth_cam.deproject(Point2::new(x, y), 1.0);
        let centres = (0..h)
            .flat_map(|v| (0..w).map(move |u| (u as f64, v as f64)))
            .map(|(u, v)| ray(u, v))
            .collect();
        let corners = (0..=h)
            .flat_map(|v| (0..=w).map(move |u| (u as f64 - 0.5, v as f64 - 0.5)))
            .map(|(u, v)| ray(u, v))
            .collect();
        Self {
            depth_cam: depth_cam.clone(),
            color_cam: color_cam.clone(),
            translation_m: depth_to_color.translation_m,
            centres,
            corners,
        }
    }

    /// Depth (`depth_raw`, row-major `depth_cam.width x depth_cam.height`, units of
    /// `unit_m`) aligned to the colour camera: a colour-sized depth image in the same
    /// units, 0 where no depth pixel lands (see the module doc).
    pub fn align(&self, depth_raw: &[u16], unit_m: f64) -> DepthImage {
        let color_cam = &self.color_cam;
        let (cw, ch) = (color_cam.width, color_cam.height);
        let mut out = DepthImage::new(cw, ch);
        let (dw, dh) = (
            self.depth_cam.width as usize,
            self.depth_cam.height as usize,
        );
        let t = self.translation_m;
        // First pixel centre at or after `a`, and the last before `b`, clamped to `n`.
        let span = |a: f64, b: f64, n: u32| -> Option<(u32, u32)> {
            let (lo, hi) = (a.min(b), a.max(b));
            let first = lo.ceil().max(0.0);
            let last = (hi.ceil() - 1.0).min(n as f64 - 1.0);
            (first.is_finite() && last.is_finite() && first <= last)
                .then_some((first as u32, last as u32))
        };
        for v in 0..dh.min(depth_raw.len() / dw.max(1)) {
            for u in 0..dw {
                let d = depth_raw[v * dw + u];
                if d == 0 {
                    continue;
                }
                let z = d as f64 * unit_m;
                let centre = self.centres[v * dw + u] * z + t;
                let a = self.corners[v * (dw + 1) + u] * z + t;
                let b = self.corners[(v + 1) * (dw + 1) + u + 1] * z + t;
                if centre.z <= 0.0 || a.z <= 0.0 || b.z <= 0.0 {
                    continue;
                }
                let (pa, pb) = (color_cam.project(&a), color_cam.project(&b));
                let (Some((x0, x1)), Some((y0, y1))) = (span(pa.x, pb.x, cw), span(pa.y, pb.y, ch))
                else {
                    continue;
                };
                let value = (centre.z / unit_m).round();
                if !(value >= 1.0 && value <= u16::MAX as f64) {
                    continue;
                }
                let value = value as u16;
                for y in y0..=y1 {
                    for x in x0..=x1 {
                        let px = &mut out.get_pixel_mut(x, y)[0];
                        if *px == 0 || value < *px {
                            *px = value;
                        }
                    }
                }
            }
        }
        out
    }
}

/// [`DepthAligner::align`] for one frame (the rays computed for it alone).
pub fn align_depth_to_color(
    depth_raw: &[u16],
    depth_cam: &StreamCamera,
    color_cam: &StreamCamera,
    depth_to_color: &RigidTransform,
    unit_m: f64,
) -> DepthImage {
    DepthAligner::new(depth_cam, color_cam, depth_to_color).align(depth_raw, unit_m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    fn camera(w: u32, h: u32, f: f64, cx: f64, cy: f64) -> StreamCamera {
        StreamCamera {
            width: w,
            height: h,
            fx: f,
            fy: f,
            cx,
            cy,
            brown: [0.0; 5],
        }
    }

    #[test]
    fn identical_cameras_give_the_depth_back_unchanged() {
        let cam = camera(40, 30, 35.0, 19.6, 14.2);
        let raw: Vec<u16> = (0..40 * 30).map(|i| 2000 + (i * 7 % 500) as u16).collect();
        let out = align_depth_to_color(&raw, &cam, &cam, &RigidTransform::identity(), 1e-4);
        assert_eq!(out.as_raw(), &raw);
    }

    #[test]
    fn a_plane_seen_from_a_baseline_lands_where_the_colour_camera_sees_it() {
        // A fronto-parallel plane at 0.25 m: shifted by f * b / z px, same depth.
        let depth_cam = camera(64, 48, 50.0, 31.5, 23.5);
        let color_cam = camera(80, 60, 62.0, 40.2, 29.7);
        let t = RigidTransform {
            rotation: Matrix3::identity(),
            translation_m: Vector3::new(-0.015, 0.0, 0.0),
        };
        let raw = vec![2500u16; 64 * 48];
        let out = align_depth_to_color(&raw, &depth_cam, &color_cam, &t, 1e-4);
        // Colour pixel x sees the plane point X = (x - cx) z / f; the depth camera sees
        // it at X - 0.015: inside its image for the middle of the colour frame.
        for y in 10..50 {
            for x in 10..70 {
                assert_eq!(out.get_pixel(x, y)[0], 2500, "({x}, {y})");
            }
        }
        // The depth camera's right edge projects to colour x = cx + f (X1 + t) / z:
        // colour pixels right of it get no depth.
        let x_edge: f64 = 40.2 + 62.0 * ((63.5 - 31.5) / 50.0 * 0.25 - 0.015) / 0.25;
        assert_eq!(x_edge.floor(), 76.0);
        assert_eq!(out.get_pixel(75, 30)[0], 2500);
        assert_eq!(out.get_pixel(77, 30)[0], 0);
    }

    #[test]
    fn the_nearest_depth_wins_and_rotation_gives_colour_frame_depth() {
        // Rotated 10 degrees about y: a point on the optical axis at 0.3 m of the depth
        // camera has Z = 0.3 cos(10 deg) in the colour frame.
        let cam = camera(41, 31, 40.0, 20.0, 15.0);
        let r = nalgebra::Rotation3::from_euler_angles(0.0, 10f64.to_radians(), 0.0);
        let t = RigidTransform {
            rotation: *r.matrix(),
            translation_m: Vector3::zeros(),
        };
        let mut raw = vec![0u16; 41 * 31];
        raw[15 * 41 + 20] = 3000;
        let out = align_depth_to_color(&raw, &cam, &cam, &t, 1e-4);
        let z = (0.3 * 10f64.to_radians().cos() / 1e-4).round() as u16;
        assert!(out.as_raw().contains(&z), "{z}");
        assert!(out.as_raw().iter().all(|v| *v == 0 || *v == z));
        // A baseline of 10 mm shifts a pixel by f b / z: 2 px at 0.2 m, 1 px at 0.4 m, so
        // depth pixels 22 (near) and 21 (far) both land on colour pixel 20: the near
        // one is kept.
        let t = RigidTransform {
            rotation: Matrix3::identity(),
            translation_m: Vector3::new(-0.01, 0.0, 0.0),
        };
        let mut raw = vec![0u16; 41 * 31];
        raw[15 * 41 + 22] = 2000;
        raw[15 * 41 + 21] = 4000;
        let out = align_depth_to_color(&raw, &cam, &cam, &t, 1e-4);
        assert_eq!(out.get_pixel(20, 15)[0], 2000);
        assert_eq!(out.get_pixel(19, 15)[0], 0);
    }

    #[test]
    fn brown_deprojection_inverts_projection() {
        let mut cam = camera(640, 480, 600.0, 320.0, 240.0);
        cam.brown = [0.12, -0.25, 0.001, -0.0015, 0.08];
        for (u, v) in [(10.0, 12.0), (320.0, 240.0), (600.5, 470.25)] {
            let q = cam.deproject(Point2::new(u, v), 0.4);
            let p = cam.project(&q);
            assert!((p - Point2::new(u, v)).norm() < 1e-6, "{u} {v} -> {p}");
        }
    }
}
