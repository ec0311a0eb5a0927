//! An independent scene generator for tests: pictures drawn with OpenCV's own camera
//! models (`cv::projectPoints` for the pinhole model with k1 k2 p1 p2 k3,
//! `cv::fisheye::projectPoints` for Kannala-Brandt), anti-aliased polygon fill on a
//! supersampled canvas, area downsampling, Gaussian blur, sensor noise and JPEG through
//! `cv::imencode`. Nothing of bendscope's renderer is used, so the chain is checked on
//! pictures it did not make (other projection code, other pixel conventions, other noise).
#![allow(dead_code)]

use opencv::calib3d;
use opencv::core::{self, Mat, Point, Point2d, Point3d, Scalar, Size, Vector};
use opencv::imgcodecs;
use opencv::imgproc;
use opencv::prelude::*;

/// The lens model and its distortion coefficients.
#[derive(Debug, Clone)]
pub enum Lens {
    /// OpenCV's pinhole model: k1 k2 p1 p2 k3.
    Pinhole([f64; 5]),
    /// OpenCV's fisheye (Kannala-Brandt) model: k1..k4.
    Fisheye([f64; 4]),
}

/// A camera as OpenCV models it.
#[derive(Debug, Clone)]
pub struct CvCamera {
    pub width: i32,
    pub height: i32,
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    pub lens: Lens,
}

/// A plane's pose: plane (x, y, 0) mm -> camera, Rodrigues vector and translation (mm).
#[derive(Debug, Clone, Copy)]
pub struct Pose {
    pub rvec: [f64; 3],
    pub tvec: [f64; 3],
}

impl CvCamera {
    /// Pixel positions of plane points `pts` (mm) seen in pose `pose`.
    pub fn project(&self, pose: &Pose, pts: &[[f64; 2]]) -> Vec<[f64; 2]> {
        let obj: Vector<Point3d> = pts.iter().map(|p| Point3d::new(p[0], p[1], 0.0)).collect();
        let k = Mat::from_slice_2d(&[
            [self.fx, 0.0, self.cx],
            [0.0, self.fy, self.cy],
            [0.0, 0.0, 1.0],
        ])
        .unwrap();
        let rvec = Mat::from_slice(&pose.rvec).unwrap().try_clone().unwrap();
        let tvec = Mat::from_slice(&pose.tvec).unwrap().try_clone().unwrap();
        let mut out: Vector<Point2d> = Vector::new();
        match &self.lens {
            Lens::Pinhole(d) => {
                let d = Mat::from_slice(d).unwrap().try_clone().unwrap();
                calib3d::project_points_def(&obj, &rvec, &tvec, &k, &d, &mut out).unwrap();
            }
            Lens::Fisheye(d) => {
                let d = Mat::from_slice(d).unwrap().try_clone().unwrap();
                calib3d::fisheye_project_points_vec_def(&obj, &mut out, &rvec, &tvec, &k, &d)
                    .unwrap();
            }
        }
        out.iter().map(|p| [p.x, p.y]).collect()
    }
}

/// A deterministic generator (SplitMix64) for poses and noise.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
    pub fn gauss(&mut self) -> f64 {
        let (u, v) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// A picture drawn at `supersample` times the camera's resolution.
pub struct Canvas {
    img: Mat,
    s: f64,
    size: Size,
}

/// Sub-pixel bits of the polygon vertices given to `cv::fillPoly`.
const SHIFT: i32 = 4;

impl Canvas {
    /// A canvas for `cam` filled with `bgr`.
    pub fn new(cam: &CvCamera, supersample: i32, bgr: [f64; 3]) -> Self {
        let img = Mat::new_rows_cols_with_default(
            cam.height * supersample,
            cam.width * supersample,
            core::CV_8UC3,
            Scalar::new(bgr[0], bgr[1], bgr[2], 0.0),
        )
        .unwrap();
        Canvas {
            img,
            s: supersample as f64,
            size: Size::new(cam.width, cam.height),
        }
    }

    /// Fills a polygon given in camera pixels (pixel centres at integers).
    pub fn polygon(&mut self, px: &[[f64; 2]], bgr: [f64; 3]) {
        let k = (1 << SHIFT) as f64;
        // The supersampled pixel grid: camera pixel i covers [i s, (i + 1) s).
        let poly: Vector<Point> = px
            .iter()
            .map(|p| {
                Point::new(
                    (((p[0] + 0.5) * self.s - 0.5) * k).round() as i32,
                    (((p[1] + 0.5) * self.s - 0.5) * k).round() as i32,
                )
            })
            .collect();
        let polys: Vector<Vector<Point>> = std::iter::once(poly).collect();
        imgproc::fill_poly(
            &mut self.img,
            &polys,
            Scalar::new(bgr[0], bgr[1], bgr[2], 0.0),
            imgproc::LINE_AA,
            SHIFT,
            Point::default(),
        )
        .unwrap();
    }

    /// Downsampled (area), blurred (optics, sigma px), with Gaussian sensor noise (sigma
    /// in grey levels), JPEG-encoded at `quality`.
    pub fn jpeg(self, blur_sigma: f64, noise_sigma: f64, seed: u64, quality: i32) -> Vec<u8> {
        let mut small = Mat::default();
        imgproc::resize(
            &self.img,
            &mut small,
            self.size,
            0.0,
            0.0,
            imgproc::INTER_AREA,
        )
        .unwrap();
        let mut blurred = Mat::default();
        imgproc::gaussian_blur_def(&small, &mut blurred, Size::new(0, 0), blur_sigma).unwrap();
        let mut rng = Rng::new(seed);
        for b in blurred.data_bytes_mut().unwrap() {
            *b = (*b as f64 + noise_sigma * rng.gauss())
                .round()
                .clamp(0.0, 255.0) as u8;
        }
        let mut buf: Vector<u8> = Vector::new();
        let params: Vector<i32> = [imgcodecs::IMWRITE_JPEG_QUALITY, quality]
            .into_iter()
            .collect();
        imgcodecs::imencode(".jpg", &blurred, &mut buf, &params).unwrap();
        buf.to_vec()
    }
}

/// Points along the straight segment a -> b (mm), `n` steps, b excluded.
fn segment(a: [f64; 2], b: [f64; 2], n: usize) -> impl Iterator<Item = [f64; 2]> {
    (0..n).map(move |i| {
        let t = i as f64 / n as f64;
        [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
    })
}

/// A quadrilateral in the plane (mm) with subdivided edges, so that its image follows
/// the lens distortion.
fn quad(c: [[f64; 2]; 4], n: usize) -> Vec<[f64; 2]> {
    (0..4)
        .flat_map(|i| segment(c[i], c[(i + 1) % 4], n))
        .collect()
}

/// Draws a chessboard of `cols` x `rows` inner corners with `square_mm` squares, a
/// white margin of one square around it, the first inner corner at the plane origin.
pub fn draw_board(
    canvas: &mut Canvas,
    cam: &CvCamera,
    pose: &Pose,
    cols: usize,
    rows: usize,
    square_mm: f64,
) {
    let s = square_mm;
    let (x0, y0) = (-2.0 * s, -2.0 * s);
    let (x1, y1) = ((cols as f64 + 1.0) * s, (rows as f64 + 1.0) * s);
    let white = quad([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], 40);
    canvas.polygon(&cam.project(pose, &white), [235.0, 235.0, 235.0]);
    for j in 0..=rows {
        for i in 0..=cols {
            if (i + j) % 2 == 1 {
                continue;
            }
            let (a, b) = ((i as f64 - 1.0) * s, (j as f64 - 1.0) * s);
            let sq = quad([[a, b], [a + s, b], [a + s, b + s], [a, b + s]], 6);
            canvas.polygon(&cam.project(pose, &sq), [25.0, 25.0, 25.0]);
        }
    }
}

/// The outer corners of the board drawn by [`draw_board`], plane mm.
pub fn board_outline(cols: usize, rows: usize, square_mm: f64) -> Vec<[f64; 2]> {
    let s = square_mm;
    let (x0, y0, x1, y1) = (
        -2.0 * s,
        -2.0 * s,
        (cols as f64 + 1.0) * s,
        (rows as f64 + 1.0) * s,
    );
    quad([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], 10)
}

/// Whether every point lies inside the frame with `margin` px to spare.
pub fn inside(cam: &CvCamera, px: &[[f64; 2]], margin: f64) -> bool {
    px.iter().all(|p| {
        p[0].is_finite()
            && p[1].is_finite()
            && p[0] >= margin
            && p[1] >= margin
            && p[0] <= cam.width as f64 - 1.0 - margin
            && p[1] <= cam.height as f64 - 1.0 - margin
    })
}

/// The markers' paint (BGR).
pub const MARKER_BGR: [f64; 3] = [40.0, 35.0, 190.0];

/// A bent actuator in the plane: a clamp block, a silicone band along a circular arc of
/// radius `radius_mm` leaving `clamp` (mm) along +x and curving towards +y, and
/// `markers` red discs of `marker_mm` diameter every `spacing_mm` along its centre line
/// from `first_mm`. Returns the markers' centres (mm).
pub struct Actuator {
    pub clamp: [f64; 2],
    pub radius_mm: f64,
    pub length_mm: f64,
    pub width_mm: f64,
    pub markers: usize,
    pub first_mm: f64,
    pub spacing_mm: f64,
    pub marker_mm: f64,
    /// The markers' paint (BGR), [`MARKER_BGR`] (red) unless set.
    pub marker_bgr: [f64; 3],
}

impl Actuator {
    /// The point at arc length `s` and signed offset `d` from the centre line (mm).
    pub fn at(&self, s: f64, d: f64) -> [f64; 2] {
        let r = self.radius_mm;
        let a = s / r;
        // Centre of curvature at clamp + (0, r); d > 0 towards the centre.
        [
            self.clamp[0] + (r - d) * a.sin(),
            self.clamp[1] + r - (r - d) * a.cos(),
        ]
    }

    /// A disc of diameter `diameter_mm` centred at `centre` (plane mm), as a polygon in
    /// plane mm.
    pub fn disc(centre: [f64; 2], diameter_mm: f64) -> Vec<[f64; 2]> {
        (0..48)
            .map(|i| {
                let t = 2.0 * std::f64::consts::PI * i as f64 / 48.0;
                let r = diameter_mm / 2.0;
                [centre[0] + r * t.cos(), centre[1] + r * t.sin()]
            })
            .collect()
    }

    /// Draws it; returns the marker centres (plane mm).
    pub fn draw(&self, canvas: &mut Canvas, cam: &CvCamera, pose: &Pose) -> Vec<[f64; 2]> {
        let (c, w) = (self.clamp, self.width_mm);
        let block = quad(
            [
                [c[0] - 30.0, c[1] - w],
                [c[0], c[1] - w],
                [c[0], c[1] + w],
                [c[0] - 30.0, c[1] + w],
            ],
            10,
        );
        canvas.polygon(&cam.project(pose, &block), [70.0, 70.0, 75.0]);
        let n = 120;
        let mut band: Vec<[f64; 2]> = (0..=n)
            .map(|i| self.at(self.length_mm * i as f64 / n as f64, -w / 2.0))
            .collect();
        band.extend(
            (0..=n)
                .rev()
                .map(|i| self.at(self.length_mm * i as f64 / n as f64, w / 2.0)),
        );
        canvas.polygon(&cam.project(pose, &band), [215.0, 222.0, 225.0]);
        (0..self.markers)
            .map(|k| {
                let centre = self.at(self.first_mm + k as f64 * self.spacing_mm, 0.0);
                let disc = Self::disc(centre, self.marker_mm);
                canvas.polygon(&cam.project(pose, &disc), self.marker_bgr);
                centre
            })
            .collect()
    }
}

/// A segmented actuator in the plane: a clamp block and a band whose centre line leaves
/// `clamp` (mm) along +x as a chain of circular arcs meeting tangentially (segment k of
/// `lengths_mm[k]` with radius `radii_mm[k]`, all curving towards +y), with marker discs
/// at the arc lengths `markers_s_mm`.
pub struct SegmentedActuator {
    pub clamp: [f64; 2],
    pub radii_mm: Vec<f64>,
    pub lengths_mm: Vec<f64>,
    pub width_mm: f64,
    pub markers_s_mm: Vec<f64>,
    pub marker_mm: f64,
    pub marker_bgr: [f64; 3],
}

impl SegmentedActuator {
    /// Total length, mm.
    pub fn length_mm(&self) -> f64 {
        self.lengths_mm.iter().sum()
    }

    /// The point at arc length `s` and signed offset `d` from the centre line (mm;
    /// d > 0 towards the centres of curvature).
    pub fn at(&self, s: f64, d: f64) -> [f64; 2] {
        let (mut p, mut heading, mut s0) = (self.clamp, 0.0f64, 0.0);
        for (k, (&r, &len)) in self.radii_mm.iter().zip(&self.lengths_mm).enumerate() {
            let last = k + 1 == self.radii_mm.len();
            let ds = if last { s - s0 } else { (s - s0).min(len) };
            let h = heading + ds / r;
            let q = [
                p[0] + r * (h.sin() - heading.sin()),
                p[1] - r * (h.cos() - heading.cos()),
            ];
            if last || s <= s0 + len {
                return [q[0] - d * h.sin(), q[1] + d * h.cos()];
            }
            (p, heading, s0) = (q, h, s0 + len);
        }
        p
    }

    /// Draws it; returns the marker centres (plane mm).
    pub fn draw(&self, canvas: &mut Canvas, cam: &CvCamera, pose: &Pose) -> Vec<[f64; 2]> {
        let (c, w) = (self.clamp, self.width_mm);
        let block = quad(
            [
                [c[0] - 30.0, c[1] - w],
                [c[0], c[1] - w],
                [c[0], c[1] + w],
                [c[0] - 30.0, c[1] + w],
            ],
            10,
        );
        canvas.polygon(&cam.project(pose, &block), [70.0, 70.0, 75.0]);
        let n = 240;
        let len = self.length_mm();
        let mut band: Vec<[f64; 2]> = (0..=n)
            .map(|i| self.at(len * i as f64 / n as f64, -w / 2.0))
            .collect();
        band.extend(
            (0..=n)
                .rev()
                .map(|i| self.at(len * i as f64 / n as f64, w / 2.0)),
        );
        canvas.polygon(&cam.project(pose, &band), [215.0, 222.0, 225.0]);
        self.markers_s_mm
            .iter()
            .map(|&s| {
                let centre = self.at(s, 0.0);
                let disc = Actuator::disc(centre, self.marker_mm);
                canvas.polygon(&cam.project(pose, &disc), self.marker_bgr);
                centre
            })
            .collect()
    }
}

/// Rodrigues vector of the rotation Rz(c) Ry(b) Rx(a) (radians).
pub fn rvec_from_angles(a: f64, b: f64, c: f64) -> [f64; 3] {
    let m = nalgebra::Rotation3::from_euler_angles(a, b, c);
    let v = m.scaled_axis();
    [v.x, v.y, v.z]
}

/// `n` calibration views of a board of `cols` x `rows` inner corners (`square_mm`),
/// random poses at `distance_mm` (min, max) whose whole board lies in the frame; each
/// view as JPEG bytes.
pub fn calibration_views(
    cam: &CvCamera,
    n: usize,
    (cols, rows, square_mm): (usize, usize, f64),
    distance_mm: (f64, f64),
    seed: u64,
) -> Vec<Vec<u8>> {
    let mut rng = Rng::new(seed);
    let centre = [
        (cols as f64 - 1.0) * square_mm / 2.0,
        (rows as f64 - 1.0) * square_mm / 2.0,
    ];
    let outline = board_outline(cols, rows, square_mm);
    let mut views = Vec::new();
    let mut tries = 0;
    while views.len() < n {
        tries += 1;
        assert!(tries < 100 * n, "no board pose fits the frame");
        let deg = std::f64::consts::PI / 180.0;
        let rvec = rvec_from_angles(
            rng.range(-35.0, 35.0) * deg,
            rng.range(-35.0, 35.0) * deg,
            rng.range(-20.0, 20.0) * deg,
        );
        let z = rng.range(distance_mm.0, distance_mm.1);
        let (u, v) = (rng.range(-0.45, 0.45), rng.range(-0.35, 0.35));
        let target = [
            u * z * cam.width as f64 / cam.fx,
            v * z * cam.height as f64 / cam.fy,
            z,
        ];
        let r = nalgebra::Rotation3::from_scaled_axis(nalgebra::Vector3::from(rvec));
        let c = r * nalgebra::Vector3::new(centre[0], centre[1], 0.0);
        let pose = Pose {
            rvec,
            tvec: [target[0] - c.x, target[1] - c.y, target[2] - c.z],
        };
        if !inside(cam, &cam.project(&pose, &outline), 4.0) {
            continue;
        }
        let mut canvas = Canvas::new(cam, 3, [110.0, 115.0, 120.0]);
        draw_board(&mut canvas, cam, &pose, cols, rows, square_mm);
        views.push(canvas.jpeg(0.7, 2.0, seed * 1000 + views.len() as u64, 92));
    }
    views
}
