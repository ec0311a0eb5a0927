//! Where the calibration board went: how much of the frame and of the field its detected
//! corners covered, and where to hold it next when that is thin.
//!
//! Three measures, all from the views a calibration used:
//!
//! - the largest field angle of a detected corner (from the calibrated board poses): the
//!   coverage limit of the valid field ([`super::field`]);
//! - the share of the frame's half-diagonal reached: the distance of the farthest detected
//!   corner from the frame centre over the half-diagonal (1 = a corner of the frame);
//! - a 3x3 grid of the frame (thirds in x and y): the share of each cell inside the
//!   footprint of at least one view (the polygon through the board's outer detected
//!   corners), sampled on [`GRID_SAMPLES`] x [`GRID_SAMPLES`] points per cell.

use nalgebra::Point2;

use super::Board;

/// Sample points per grid cell side.
pub const GRID_SAMPLES: usize = 16;
/// A cell of the 3x3 grid less covered than this share counts as thin: the board went
/// there in too few views for the distortion polynomial to be constrained there. A board
/// held fully inside the frame keeps its outer inner corners about one square plus its
/// white margin from the frame's edges, so no corner cell is ever fully covered: the
/// synthetic set `fixtures/fisheye`, whose boards were spread to the frame's corners,
/// covers 31-45% of each corner cell; OpenCV's left*.jpg samples, which leave the left
/// side bare, cover 2-16% of the left cells.
pub const THIN_CELL_SHARE: f64 = 0.25;
/// Coverage reaching less than this share of the frame's half-diagonal is thin
/// (`fixtures/fisheye` reaches 78%, for the reason above 100% is out of reach).
pub const THIN_HALF_DIAGONAL_SHARE: f64 = 0.7;

/// Names of the 3x3 grid's cells, rows top to bottom, columns left to right.
const CELL_NAMES: [[&str; 3]; 3] = [
    ["top-left", "top", "top-right"],
    ["left", "centre", "right"],
    ["bottom-left", "bottom", "bottom-right"],
];

/// How much of the frame and of the field a calibration's board views covered.
#[derive(Debug, Clone, PartialEq)]
pub struct Coverage {
    /// Largest field angle of a detected board corner, degrees from the optical axis.
    pub field_angle_deg: f64,
    /// Distance of the farthest detected corner from the frame centre over the frame's
    /// half-diagonal; `None` when not recorded (hand-written files).
    pub half_diagonal_share: Option<f64>,
    /// Share of each third of the frame covered by some view's board, rows top to bottom,
    /// columns left to right; `None` when not recorded.
    pub grid: Option<[[f64; 3]; 3]>,
}

impl Coverage {
    /// The outer cells of the grid covered less than [`THIN_CELL_SHARE`], as (row, column).
    pub fn thin_cells(&self) -> Vec<(usize, usize)> {
        let Some(grid) = &self.grid else {
            return vec![];
        };
        (0..3)
            .flat_map(|r| (0..3).map(move |c| (r, c)))
            .filter(|&(r, c)| (r, c) != (1, 1) && grid[r][c] < THIN_CELL_SHARE)
            .collect()
    }

    /// True when the coverage is thin: an outer cell below [`THIN_CELL_SHARE`] or a reach
    /// below [`THIN_HALF_DIAGONAL_SHARE`] of the half-diagonal.
    pub fn is_thin(&self) -> bool {
        !self.thin_cells().is_empty()
            || self
                .half_diagonal_share
                .map(|s| s < THIN_HALF_DIAGONAL_SHARE)
                .unwrap_or(false)
    }

    /// Where to hold the board next, when the coverage is thin: e.g. "hold the board in
    /// the top-right and bottom-left corners and along the left edge".
    pub fn advice(&self) -> Option<String> {
        if !self.is_thin() {
            return None;
        }
        let thin = self.thin_cells();
        let names = |corner: bool| -> Vec<&str> {
            thin.iter()
                .filter(|(r, c)| (*r != 1 && *c != 1) == corner)
                .map(|&(r, c)| CELL_NAMES[r][c])
                .collect()
        };
        let (corners, edges) = (names(true), names(false));
        let mut parts = Vec::new();
        if !corners.is_empty() {
            let noun = if corners.len() == 1 {
                "corner"
            } else {
                "corners"
            };
            parts.push(format!("in the {} {noun}", join_and(&corners)));
        }
        if !edges.is_empty() {
            let noun = if edges.len() == 1 { "edge" } else { "edges" };
            parts.push(format!("along the {} {noun}", join_and(&edges)));
        }
        if parts.is_empty() {
            parts.push("nearer the corners of the frame".to_string());
        }
        Some(format!("hold the board {}", parts.join(" and ")))
    }
}

/// "a", "a and b", "a, b and c".
fn join_and(items: &[&str]) -> String {
    match items {
        [] => String::new(),
        [one] => one.to_string(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    }
}

/// Distance of the farthest corner from the centre of a `width` x `height` frame, over
/// the half-diagonal.
pub fn half_diagonal_share(views: &[&[Point2<f64>]], width: u32, height: u32) -> f64 {
    let (cx, cy) = (0.5 * (width as f64 - 1.0), 0.5 * (height as f64 - 1.0));
    let half = cx.hypot(cy);
    views
        .iter()
        .flat_map(|v| v.iter())
        .map(|p| (p.x - cx).hypot(p.y - cy) / half)
        .filter(|s| s.is_finite())
        .fold(0.0, f64::max)
}

/// The share of each third of the frame inside at least one view's footprint: the
/// polygon through the outer corners of the detected grid (row-major corners of `board`).
pub fn coverage_grid(
    views: &[&[Point2<f64>]],
    board: &Board,
    width: u32,
    height: u32,
) -> [[f64; 3]; 3] {
    let outlines: Vec<Vec<Point2<f64>>> = views
        .iter()
        .filter(|v| v.len() == board.corner_count())
        .map(|v| grid_outline(v, board.cols as usize, board.rows as usize))
        .collect();
    let (w, h) = (width as f64, height as f64);
    let mut grid = [[0.0; 3]; 3];
    let n = GRID_SAMPLES;
    for (r, row) in grid.iter_mut().enumerate() {
        for (c, share) in row.iter_mut().enumerate() {
            let mut hit = 0usize;
            for j in 0..n {
                for i in 0..n {
                    let p = Point2::new(
                        (c as f64 + (i as f64 + 0.5) / n as f64) * w / 3.0 - 0.5,
                        (r as f64 + (j as f64 + 0.5) / n as f64) * h / 3.0 - 0.5,
                    );
                    if outlines.iter().any(|o| inside_polygon(o, p)) {
                        hit += 1;
                    }
                }
            }
            *share = hit as f64 / (n * n) as f64;
        }
    }
    grid
}

/// The border of a `cols` x `rows` grid of row-major points, in order around it.
fn grid_outline(corners: &[Point2<f64>], cols: usize, rows: usize) -> Vec<Point2<f64>> {
    let at = |r: usize, c: usize| corners[r * cols + c];
    let mut out = Vec::with_capacity(2 * (cols + rows));
    out.extend((0..cols).map(|c| at(0, c)));
    out.extend((1..rows).map(|r| at(r, cols - 1)));
    out.extend((0..cols - 1).rev().map(|c| at(rows - 1, c)));
    out.extend((1..rows - 1).rev().map(|r| at(r, 0)));
    out
}

/// Even-odd ray casting.
fn inside_polygon(poly: &[Point2<f64>], p: Point2<f64>) -> bool {
    let mut inside = false;
    let mut j = poly.len().wrapping_sub(1);
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[j]);
        if (a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x {
            inside = !inside;
        }
        j = i;
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Corners of a `cols` x `rows` board, axis-aligned, from (x0, y0) with spacing `s`.
    fn grid(cols: u32, rows: u32, x0: f64, y0: f64, s: f64) -> Vec<Point2<f64>> {
        (0..rows)
            .flat_map(|r| (0..cols).map(move |c| Point2::new(x0 + s * c as f64, y0 + s * r as f64)))
            .collect()
    }

    #[test]
    fn a_board_in_the_centre_covers_only_the_centre_cell() {
        let b = Board::new(4, 4, 10.0).unwrap();
        // Frame 300x300: the centre cell is [100, 200)^2.
        let v = grid(4, 4, 100.0, 100.0, 33.0);
        let g = coverage_grid(&[&v], &b, 300, 300);
        assert!(g[1][1] > 0.9, "{g:?}");
        for (r, c) in [
            (0, 0),
            (0, 1),
            (0, 2),
            (1, 0),
            (1, 2),
            (2, 0),
            (2, 1),
            (2, 2),
        ] {
            assert_eq!(g[r][c], 0.0, "cell {r},{c}: {g:?}");
        }
        let share = half_diagonal_share(&[&v], 300, 300);
        let expected = (100.0f64 - 149.5).hypot(100.0 - 149.5) / 149.5f64.hypot(149.5);
        assert!((share - expected).abs() < 1e-12, "{share}");
        let cov = Coverage {
            field_angle_deg: 20.0,
            half_diagonal_share: Some(share),
            grid: Some(g),
        };
        assert_eq!(cov.thin_cells().len(), 8);
        assert_eq!(
            cov.advice().unwrap(),
            "hold the board in the top-left, top-right, bottom-left and bottom-right corners and along the top, left, right and bottom edges"
        );
    }

    #[test]
    fn boards_in_two_corners_leave_the_other_two_named() {
        let b = Board::new(4, 4, 10.0).unwrap();
        let views = [
            grid(4, 4, 0.0, 0.0, 100.0),
            grid(4, 4, 0.0, 0.0, 60.0),
            grid(4, 4, 120.0, 120.0, 60.0),
            grid(4, 4, 0.0, 120.0, 60.0),
            grid(4, 4, 120.0, 0.0, 60.0),
        ];
        let refs: Vec<&[Point2<f64>]> = views.iter().map(|v| v.as_slice()).collect();
        // The first view spans the whole 300x300 frame: everything covered.
        let g = coverage_grid(&refs, &b, 300, 300);
        assert!(g.iter().flatten().all(|s| *s > 0.99), "{g:?}");
        // Only the views towards the top-left and bottom-right corners.
        let g = coverage_grid(&[&views[1], &views[2]], &b, 300, 300);
        let cov = Coverage {
            field_angle_deg: 60.0,
            half_diagonal_share: Some(0.95),
            grid: Some(g),
        };
        assert!(cov.thin_cells().contains(&(0, 2)) && cov.thin_cells().contains(&(2, 0)));
        assert!(!cov.thin_cells().contains(&(0, 0)) && !cov.thin_cells().contains(&(2, 2)));
        let advice = cov.advice().unwrap();
        assert!(
            advice.starts_with("hold the board in the top-right and bottom-left corners"),
            "{advice}"
        );
    }

    #[test]
    fn full_coverage_gives_no_advice_and_unknown_coverage_none() {
        let full = Coverage {
            field_angle_deg: 70.0,
            half_diagonal_share: Some(0.9),
            grid: Some([[0.8; 3]; 3]),
        };
        assert!(!full.is_thin());
        assert_eq!(full.advice(), None);
        let short = Coverage {
            half_diagonal_share: Some(0.6),
            ..full.clone()
        };
        assert_eq!(
            short.advice().unwrap(),
            "hold the board nearer the corners of the frame"
        );
        let unknown = Coverage {
            field_angle_deg: 40.0,
            half_diagonal_share: None,
            grid: None,
        };
        assert_eq!(unknown.advice(), None);
    }
}
