//! The simulated actuator as a plane scene: the deformed side face of one FEM step
//! (`side_face.json` of `bendscope simulate`) in pale silicone, red marker discs centred
//! on the FEM marker points, the clamp over the first chamber, a white sheet behind.
//!
//! Plane coordinates (mm, x right, y down in the image): plane = origin + (x, −z) of the
//! FEM's x-z plane, so the circle through the rendered marker centres has the FEM's
//! radius exactly (a reflection keeps distances).

use nalgebra::Point2;

use super::actuator::{Shade, BODY_RGB, CLAMP_RGB, DISTRACTOR_RGB, MARKER_RGB, SHEET_RGB};
use crate::fem::simulate::{SideFaceFile, SideFaceStep};

/// Side of the cells of the quad lookup grid, mm.
const CELL_MM: f64 = 2.0;

/// One FEM step as a scene.
#[derive(Debug, Clone)]
pub struct FemScene {
    quads: Vec<[Point2<f64>; 4]>,
    /// Quads overlapping each grid cell.
    grid: Vec<Vec<u32>>,
    grid_origin: Point2<f64>,
    grid_size: (usize, usize),
    markers: Vec<Point2<f64>>,
    marker_radius_mm: f64,
    clamp: (Point2<f64>, Point2<f64>),
    /// A red disc that is not a marker: centre and diameter, plane mm.
    pub distractor: Option<(Point2<f64>, f64)>,
    /// Marker paint (RGB before lighting; [`MARKER_RGB`] unless set: [`BODY_RGB`] hides
    /// the dots).
    pub marker_rgb: [f64; 3],
}

/// Maps FEM (x, z) to plane coordinates.
pub fn to_plane(origin: Point2<f64>, p: [f64; 2]) -> Point2<f64> {
    Point2::new(origin.x + p[0], origin.y - p[1])
}

/// Bounding box (min, max) of every step's face in plane coordinates, with the clamp.
pub fn scene_bounds(face: &SideFaceFile, origin: Point2<f64>) -> (Point2<f64>, Point2<f64>) {
    let mut lo = Point2::new(f64::INFINITY, f64::INFINITY);
    let mut hi = Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
    for s in &face.steps {
        for p in &s.points_mm {
            let q = to_plane(origin, *p);
            lo = lo.inf(&q);
            hi = hi.sup(&q);
        }
    }
    let (c0, c1) = clamp_rect(face, origin);
    (lo.inf(&c0), hi.sup(&c1))
}

/// The clamp: plates over the first chamber, 4 mm beyond the body's top and bottom.
fn clamp_rect(face: &SideFaceFile, origin: Point2<f64>) -> (Point2<f64>, Point2<f64>) {
    let (mut zmin, mut zmax) = (f64::INFINITY, f64::NEG_INFINITY);
    if let Some(s) = face.steps.first() {
        for p in &s.points_mm {
            if p[0] <= face.clamp_mm + 1e-9 {
                zmin = zmin.min(p[1]);
                zmax = zmax.max(p[1]);
            }
        }
    }
    if !zmin.is_finite() {
        (zmin, zmax) = (0.0, 0.0);
    }
    (
        to_plane(origin, [-6.0, zmax + 4.0]),
        to_plane(origin, [face.clamp_mm, zmin - 4.0]),
    )
}

fn inside_quad(q: &[Point2<f64>; 4], p: Point2<f64>) -> bool {
    // Crossing number: the quads of a deformed structured mesh are simple polygons.
    let mut inside = false;
    for k in 0..4 {
        let (a, b) = (q[k], q[(k + 1) % 4]);
        if (a.y > p.y) != (b.y > p.y) {
            let x = a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y);
            if p.x < x {
                inside = !inside;
            }
        }
    }
    inside
}

impl FemScene {
    /// The scene of `step` of `face`, the FEM origin at `origin` (plane mm).
    pub fn new(
        face: &SideFaceFile,
        step: &SideFaceStep,
        origin: Point2<f64>,
        marker_diameter_mm: f64,
    ) -> Self {
        let quads: Vec<[Point2<f64>; 4]> = face
            .quads
            .iter()
            .filter(|q| q.iter().all(|i| *i < step.points_mm.len()))
            .map(|q| q.map(|i| to_plane(origin, step.points_mm[i])))
            .collect();
        let mut lo = Point2::new(f64::INFINITY, f64::INFINITY);
        let mut hi = Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
        for q in &quads {
            for p in q {
                lo = lo.inf(p);
                hi = hi.sup(p);
            }
        }
        if quads.is_empty() {
            (lo, hi) = (Point2::origin(), Point2::origin());
        }
        let nx = ((hi.x - lo.x) / CELL_MM).ceil().max(1.0) as usize;
        let ny = ((hi.y - lo.y) / CELL_MM).ceil().max(1.0) as usize;
        let mut grid = vec![Vec::new(); nx * ny];
        for (k, q) in quads.iter().enumerate() {
            let (mut a, mut b) = (q[0], q[0]);
            for p in q {
                a = a.inf(p);
                b = b.sup(p);
            }
            let cx = |v: f64| (((v - lo.x) / CELL_MM).floor().max(0.0) as usize).min(nx - 1);
            let cy = |v: f64| (((v - lo.y) / CELL_MM).floor().max(0.0) as usize).min(ny - 1);
            for j in cy(a.y)..=cy(b.y) {
                for i in cx(a.x)..=cx(b.x) {
                    grid[j * nx + i].push(k as u32);
                }
            }
        }
        Self {
            quads,
            grid,
            grid_origin: lo,
            grid_size: (nx, ny),
            markers: step
                .markers_mm
                .iter()
                .map(|m| to_plane(origin, *m))
                .collect(),
            marker_radius_mm: 0.5 * marker_diameter_mm,
            clamp: clamp_rect(face, origin),
            distractor: None,
            marker_rgb: MARKER_RGB,
        }
    }

    /// Marker centres, plane mm.
    pub fn markers_mm(&self) -> &[Point2<f64>] {
        &self.markers
    }

    /// True when plane point `p` (mm) lies on the actuator's side face.
    pub fn on_body(&self, p: Point2<f64>) -> bool {
        let (nx, ny) = self.grid_size;
        let (fx, fy) = (
            (p.x - self.grid_origin.x) / CELL_MM,
            (p.y - self.grid_origin.y) / CELL_MM,
        );
        if fx < 0.0 || fy < 0.0 || fx >= nx as f64 || fy >= ny as f64 {
            return false;
        }
        self.grid[fy as usize * nx + fx as usize]
            .iter()
            .any(|k| inside_quad(&self.quads[*k as usize], p))
    }
}

impl Shade for FemScene {
    fn shade(&self, p: Point2<f64>) -> [f64; 3] {
        if let Some((c, d)) = self.distractor {
            if (p - c).norm() <= 0.5 * d {
                return DISTRACTOR_RGB;
            }
        }
        let (c0, c1) = self.clamp;
        if p.x >= c0.x && p.x <= c1.x && p.y >= c0.y && p.y <= c1.y {
            return CLAMP_RGB;
        }
        if self.on_body(p) {
            if self
                .markers
                .iter()
                .any(|m| (p - m).norm() <= self.marker_radius_mm)
            {
                return self.marker_rgb;
            }
            return BODY_RGB;
        }
        SHEET_RGB
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn face() -> SideFaceFile {
        // Two quads side by side: x 0..20, z 0..10, clamp over x <= 5.
        SideFaceFile {
            quads: vec![[0, 1, 4, 3], [1, 2, 5, 4]],
            clamp_mm: 5.0,
            steps: vec![SideFaceStep {
                pressure_kpa: 10.0,
                points_mm: vec![
                    [0.0, 0.0],
                    [10.0, 0.0],
                    [20.0, 0.0],
                    [0.0, 10.0],
                    [10.0, 10.0],
                    [20.0, 10.0],
                ],
                markers_mm: vec![[15.0, 5.0]],
                radius_mm: f64::INFINITY,
                bending_angle_deg: 0.0,
            }],
        }
    }

    #[test]
    fn shades_body_markers_clamp_and_sheet_where_they_are() {
        let f = face();
        let origin = Point2::new(100.0, 50.0);
        let s = FemScene::new(&f, &f.steps[0], origin, 3.0);
        // FEM (15, 5) is plane (115, 45): a marker; (15, 8) body; (2, 5) clamp; (30, 5) sheet.
        assert_eq!(s.shade(Point2::new(115.0, 45.0)), MARKER_RGB);
        assert_eq!(s.shade(Point2::new(115.0, 42.0)), BODY_RGB);
        assert_eq!(s.shade(Point2::new(102.0, 45.0)), CLAMP_RGB);
        assert_eq!(s.shade(Point2::new(130.0, 45.0)), SHEET_RGB);
        assert_eq!(
            s.shade(Point2::new(115.0, 39.0)),
            SHEET_RGB,
            "above the body (z > 10)"
        );
        // Without dots (`render --no-dots`) the marker is body.
        let bare = FemScene {
            marker_rgb: BODY_RGB,
            ..s.clone()
        };
        assert_eq!(bare.shade(Point2::new(115.0, 45.0)), BODY_RGB);
        let (lo, hi) = scene_bounds(&f, origin);
        assert!(
            lo.x <= 94.0 && hi.x >= 120.0 && lo.y <= 36.0 && hi.y >= 54.0,
            "{lo} {hi}"
        );
    }
}
