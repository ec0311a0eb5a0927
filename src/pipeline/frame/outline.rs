//! One frame in outline mode (`[detect] mode = "outline"`): the body's boundary
//! ([`crate::detect::body_outline`]) undistorted and taken to mm, the clamp end cut away,
//! the strain-limited edge kept, a circle fitted through it and moved by
//! `outline_offset_mm` to the reported line; the result is a [`FrameMeasurement`] like
//! the dots', with points sampled along the reported line standing for the markers.
//!
//! Cutting the boundary loop: the points within `outline_clamp_mm` (plus
//! [`CORNER_MM`]) of the clamp line, measured along the clamp side's axis from the body's
//! end at the clamp, are the clamp end; the rest is one open chain running from one long
//! edge, round the tip, back along the other. From each end of the chain the edge is
//! followed until it turns a corner (the tip's, or a chamber's gap on the chambered
//! side); the strain-limited edge is the one that is concave as seen from the body (the
//! inside of the bend).

use nalgebra::{Point2, Vector2};

use crate::detect::PixelSource;
use crate::detect::{
    body_mask, body_outline, refine_edge, ChainStart, ClampSide, DetectSettings, OutlineError,
};
use crate::fit::{bending_angle_along_markers_deg, fit_circle_pratt, CircleFit};
use crate::scale::apply_homography;

use super::super::records::{FrameStatus, MarkerPoint};
use super::{FrameMeasurement, Geometry, Tracker};

/// Rounded corners left out at the clamp and at the tip, mm.
pub const CORNER_MM: f64 = 1.0;
/// Half-length of the window over which the edge's turning is measured, mm (at least
/// [`TURN_WINDOW_PX`] px).
pub const TURN_WINDOW_MM: f64 = 2.0;
/// Least half-length of the turning window, px: a colour mask's edge wobbles by a pixel
/// or two (4:2:0 chroma), which a shorter window would take for corners.
pub const TURN_WINDOW_PX: f64 = 8.0;
/// Turning over the window that marks a corner, degrees (a smooth edge of radius R
/// turns by 2 window / R: 11 degrees at R = 20 mm).
pub const CORNER_TURN_DEG: f64 = 45.0;
/// Fewest edge points a fit takes.
pub const MIN_EDGE_POINTS: usize = 20;
/// Points sampled along the reported line (markers.csv, tip pose, bending angle).
pub const OUTLINE_POINTS: usize = 9;

/// Unit vector pointing away from the clamp, in image axes (y down).
fn away_from_clamp(side: ClampSide) -> Vector2<f64> {
    match side {
        ClampSide::Left => Vector2::new(1.0, 0.0),
        ClampSide::Right => Vector2::new(-1.0, 0.0),
        ClampSide::Top => Vector2::new(0.0, 1.0),
        ClampSide::Bottom => Vector2::new(0.0, -1.0),
    }
}

/// Signed angle from `a` to `b`, radians.
fn turn(a: Vector2<f64>, b: Vector2<f64>) -> f64 {
    (a.x * b.y - a.y * b.x).atan2(a.dot(&b))
}

/// Cumulative length along `pts`.
fn arc_lengths(pts: &[Point2<f64>]) -> Vec<f64> {
    let mut s = vec![0.0; pts.len()];
    for i in 1..pts.len() {
        s[i] = s[i - 1] + (pts[i] - pts[i - 1]).norm();
    }
    s
}

/// The smooth start of the open chain `pts` (mm): its points up to the first corner
/// (a turn over [`CORNER_TURN_DEG`] between the directions over `window` mm before and
/// after a point), less [`CORNER_MM`]; and its net turning, radians (the
/// sum of the turns between successive window-long chords).
fn smooth_start(pts: &[Point2<f64>], window: f64) -> (usize, f64) {
    let s = arc_lengths(pts);
    let n = pts.len();
    let limit = CORNER_TURN_DEG.to_radians();
    let (mut back, mut ahead) = (0usize, 0usize);
    let mut end = n;
    for i in 0..n {
        if s[i] < window {
            continue;
        }
        while s[i] - s[back + 1] >= window {
            back += 1;
        }
        ahead = ahead.max(i);
        while ahead + 1 < n && s[ahead] - s[i] < window {
            ahead += 1;
        }
        if s[ahead] - s[i] < window {
            break;
        }
        if turn(pts[i] - pts[back], pts[ahead] - pts[i]).abs() > limit {
            end = i;
            break;
        }
    }
    let stop = s.get(end.min(n - 1)).copied().unwrap_or(0.0) - CORNER_MM;
    let kept = s.iter().take(end).take_while(|&&v| v <= stop).count();
    // Net turning over chords of the window's length.
    let mut knots = vec![0usize];
    for i in 1..kept {
        if s[i] - s[*knots.last().unwrap_or(&0)] >= window {
            knots.push(i);
        }
    }
    let net: f64 = knots
        .windows(3)
        .map(|w| turn(pts[w[1]] - pts[w[0]], pts[w[2]] - pts[w[1]]))
        .sum();
    (kept, net)
}

/// Length ratio over which the longer smooth run is the strain-limited edge: above the
/// ratio of a bend's outer to inner edge unless its inner radius is under half the body's
/// height.
pub const LONGER_RUN: f64 = 3.0;

/// Length of the first `k` points of `pts`.
fn run_length(pts: &[Point2<f64>], k: usize) -> f64 {
    pts[..k.min(pts.len())]
        .windows(2)
        .map(|w| (w[1] - w[0]).norm())
        .sum()
}

/// Twice the signed area of the closed loop `pts` (positive: clockwise on screen, y
/// down).
fn signed_area2(pts: &[Point2<f64>]) -> f64 {
    let n = pts.len();
    (0..n)
        .map(|i| {
            let (a, b) = (pts[i], pts[(i + 1) % n]);
            a.x * b.y - b.x * a.y
        })
        .sum()
}

/// Indices of `loop_mm` on the strain-limited edge, ordered from the clamp to the tip.
/// `away` points away from the clamp, `clamp_at` is the clamp line's coordinate along it
/// and `near` a loop point at the clamp end (its index); `clamp_mm` the length left out;
/// `window` the turning window's half-length, mm.
pub fn strain_limited_edge(
    loop_mm: &[Point2<f64>],
    away: Vector2<f64>,
    clamp_at: f64,
    near: usize,
    clamp_mm: f64,
    window: f64,
) -> Result<Vec<usize>, OutlineError> {
    let n = loop_mm.len();
    let too_few = |found| OutlineError::TooFewEdgePoints {
        found,
        needed: MIN_EDGE_POINTS,
    };
    if n < 2 * MIN_EDGE_POINTS {
        return Err(too_few(0));
    }
    let at_clamp = |i: usize| loop_mm[i % n].coords.dot(&away) - clamp_at < clamp_mm + CORNER_MM;
    // The clamp run around `near`: [start, end] cyclically.
    let (mut lo, mut hi) = (0usize, 0usize);
    while hi < n && at_clamp(near + hi + 1) {
        hi += 1;
    }
    while lo < n && at_clamp(near + n - lo - 1) {
        lo += 1;
    }
    if lo + hi + 1 >= n {
        return Err(too_few(0));
    }
    // The chain from just after the run to just before it.
    let first = near + hi + 1;
    let len = n - (lo + hi + 1);
    let chain: Vec<usize> = (0..len).map(|k| (first + k) % n).collect();
    let pts: Vec<Point2<f64>> = chain.iter().map(|&i| loop_mm[i]).collect();
    let rev: Vec<Point2<f64>> = pts.iter().rev().copied().collect();
    let (ka, ta) = smooth_start(&pts, window);
    let (kb, tb) = smooth_start(&rev, window);
    // Walking the loop with the body on the right (clockwise on screen when the signed
    // area is positive), a convex boundary turns clockwise (positive turns, y down):
    // the concave edge turns the other way. The reversed walk flips the sign.
    let sense = signed_area2(loop_mm).signum();
    let (concave_a, concave_b) = (-sense * ta, sense * tb);
    // The chambered edge stops at its first gap, the strain-limited one runs to the tip:
    // a run [`LONGER_RUN`] times the other's length is the edge whatever the turnings say,
    // since a short run's turning is mostly the onset of the corner that stopped it.
    let (la, lb) = (run_length(&pts, ka), run_length(&rev, kb));
    let take_a = if la >= LONGER_RUN * lb {
        true
    } else if lb >= LONGER_RUN * la {
        false
    } else {
        concave_a >= concave_b
    };
    let edge: Vec<usize> = if take_a {
        chain[..ka].to_vec()
    } else {
        chain.iter().rev().take(kb).copied().collect()
    };
    if edge.len() < MIN_EDGE_POINTS {
        return Err(too_few(edge.len()));
    }
    Ok(edge)
}

/// Measures one frame in outline mode (plane geometry only).
pub(super) fn measure_outline<S: PixelSource>(
    pixels: &S,
    geometry: &Geometry,
    detect: &DetectSettings,
    tracker: &mut Tracker,
) -> FrameMeasurement {
    let failed = |why: String| FrameMeasurement::rejected(0, FrameStatus::FitFailed { why });
    let Geometry::Plane {
        undistorter,
        mm_per_px,
        plane_from_px,
    } = *geometry
    else {
        return failed(
            "outline: [detect] mode = \"outline\" measures plane sessions (videos, photos), not RGB-D: use mode = \"dots\"".into(),
        );
    };
    let settings = &detect.outline;
    let mask = body_mask(pixels, &settings.band);
    let body = match body_outline(&mask) {
        Ok(b) => b,
        Err(e) => return failed(e.to_string()),
    };
    // The cracks keep the loop's order (where the clamp, the corners and the edges
    // are); their refined positions are what is fitted.
    let cracks = body.boundary;
    let mut raw = cracks.clone();
    refine_edge(pixels, &mask, &mut raw);
    let both: Vec<Point2<f64>> = cracks.iter().chain(&raw).copied().collect();
    let mut working = match undistorter {
        Some(u) => match u.undistort_points(&both) {
            Ok(p) => p,
            Err(e) => return failed(format!("undistortion failed: {e}")),
        },
        None => both,
    };
    let refined = working.split_off(cracks.len());
    let to_mm = |p: &Point2<f64>| match plane_from_px {
        Some(h) => apply_homography(&h, *p),
        None => Point2::from(p.coords * mm_per_px),
    };
    let loop_mm: Vec<Point2<f64>> = working.iter().map(to_mm).collect();
    let away = away_from_clamp(detect.clamp_side);
    let nearest = |q: Point2<f64>| {
        (0..loop_mm.len())
            .min_by(|&a, &b| (loop_mm[a] - q).norm().total_cmp(&(loop_mm[b] - q).norm()))
            .unwrap_or(0)
    };
    // The clamp line: from the first frame's body end, then kept where it was.
    let near = match tracker.start {
        ChainStart::Near(p) => nearest(to_mm(&p)),
        ChainStart::Side(_) => (0..loop_mm.len())
            .min_by(|&a, &b| {
                loop_mm[a]
                    .coords
                    .dot(&away)
                    .total_cmp(&loop_mm[b].coords.dot(&away))
            })
            .unwrap_or(0),
    };
    let anchor_px = match tracker.start {
        ChainStart::Near(p) => p,
        ChainStart::Side(_) => working[near],
    };
    let clamp_at = to_mm(&anchor_px).coords.dot(&away);
    let window = TURN_WINDOW_MM.max(TURN_WINDOW_PX * mm_per_px);
    let edge = match strain_limited_edge(&loop_mm, away, clamp_at, near, settings.clamp_mm, window)
    {
        Ok(e) => e,
        Err(e) => return failed(e.to_string()),
    };
    if let Some(u) = undistorter {
        if edge.iter().any(|&i| !u.in_valid_field(raw[i])) {
            return FrameMeasurement::rejected(0, FrameStatus::OutsideCalibratedField);
        }
    }
    let edge_px: Vec<Point2<f64>> = edge.iter().map(|&i| refined[i]).collect();
    let edge_mm: Vec<Point2<f64>> = edge_px.iter().map(to_mm).collect();
    let (circle_mm, circle_px) = match (fit_circle_pratt(&edge_mm), fit_circle_pratt(&edge_px)) {
        (Ok(a), Ok(b)) => (a, b),
        (Err(e), _) | (_, Err(e)) => return failed(e.to_string()),
    };
    // The body's side of the edge: the loop's interior is on the right of its walk
    // when its signed area is positive (y down); the edge runs along the loop or
    // against it.
    let mid = edge.len() / 2;
    let (a, b) = (
        edge[mid.saturating_sub(1)],
        edge[(mid + 1).min(edge.len() - 1)],
    );
    let along = (b + loop_mm.len() - a) % loop_mm.len() <= 2;
    let t = loop_mm[b] - loop_mm[a];
    let right = Vector2::new(-t.y, t.x);
    let sense = signed_area2(&loop_mm).signum() * if along { 1.0 } else { -1.0 };
    let into_body = right * sense;
    // Moving into the body moves away from the centre when the centre is outside it.
    let outward = if circle_mm.center.x.is_finite()
        && (circle_mm.center - edge_mm[mid]).dot(&into_body) > 0.0
    {
        -1.0
    } else {
        1.0
    };
    let offset = settings.offset_mm;
    let radius_mm = circle_mm.radius + outward * offset;
    if !(radius_mm > 0.0) {
        return failed(format!(
            "outline: outline_offset_mm = {offset} moves the line past the centre of the edge's circle (radius {:.1} mm): check its sign (positive is into the body)",
            circle_mm.radius
        ));
    }
    let px_per_mm = circle_px.radius / circle_mm.radius;
    let offset_px = if px_per_mm.is_finite() {
        offset * px_per_mm
    } else {
        offset / mm_per_px
    };
    // Points along the reported line: the edge's points averaged over equal lengths,
    // moved by the offset along the circle's radius (along the body's normal when
    // the edge is straight).
    let moved = |p: Point2<f64>, c: &CircleFit, by: f64| -> Point2<f64> {
        let dir = if c.center.x.is_finite() {
            (p - c.center).normalize() * outward
        } else {
            into_body.normalize()
        };
        p + dir * by
    };
    let s = arc_lengths(&edge_mm);
    let total = s.last().copied().unwrap_or(0.0);
    let mut sums = vec![(Vector2::<f64>::zeros(), Vector2::<f64>::zeros(), 0usize); OUTLINE_POINTS];
    for (k, sk) in s.iter().enumerate() {
        let bin = ((sk / total * OUTLINE_POINTS as f64) as usize).min(OUTLINE_POINTS - 1);
        sums[bin].0 += edge_mm[k].coords;
        sums[bin].1 += edge_px[k].coords;
        sums[bin].2 += 1;
    }
    let samples: Vec<(Point2<f64>, Point2<f64>)> = sums
        .iter()
        .filter(|b| b.2 > 0)
        .map(|(mm, px, k)| {
            let (mm, px) = (Point2::from(mm / *k as f64), Point2::from(px / *k as f64));
            (
                moved(mm, &circle_mm, offset),
                moved(px, &circle_px, offset_px),
            )
        })
        .collect();
    let line_mm: Vec<Point2<f64>> = samples.iter().map(|s| s.0).collect();
    let line_px: Vec<Point2<f64>> = samples.iter().map(|s| s.1).collect();
    let line_raw = match undistorter {
        Some(u) => u
            .distort_points(&line_px)
            .unwrap_or_else(|_| vec![Point2::new(f64::NAN, f64::NAN); line_px.len()]),
        None => line_px.clone(),
    };
    let reported = CircleFit {
        radius: radius_mm,
        curvature: 1.0 / radius_mm,
        ..circle_mm
    };
    let angle = bending_angle_along_markers_deg(&line_mm, &reported).unwrap_or(f64::NAN);
    tracker.start = ChainStart::Near(anchor_px);
    FrameMeasurement {
        n_markers: line_mm.len(),
        markers_px: line_px,
        ignored_px: vec![],
        n_continuing: 0,
        center_px: circle_px.center,
        radius_px: circle_px.radius + outward * offset_px,
        radius_mm,
        curvature_per_m: 1000.0 / radius_mm,
        bending_angle_deg: angle,
        fit_rms: circle_px.rms,
        status: FrameStatus::Ok,
        markers: line_raw
            .iter()
            .zip(&line_mm)
            .map(|(r, m)| MarkerPoint {
                x_px: r.x,
                y_px: r.y,
                x_mm: m.x,
                y_mm: m.y,
                z_mm: f64::NAN,
            })
            .collect(),
        segments: vec![],
        edge_circle_px: Some((circle_px.center, circle_px.radius)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The boundary of a band bent about (0, -r0) (y down, the body bending upward, the
    /// clamp on the left at x = 0): inner edge of radius `r_in`, outer of `r_in + h`,
    /// `angle` of turn; the outer edge notched every `notch` rad when given, each
    /// chamber's top then dented `dent` mm into the body (a half sine between notches).
    /// Points about 0.1 mm apart, walked clockwise on screen.
    fn band(r_in: f64, h: f64, angle: f64, notch: Option<f64>, dent: f64) -> Vec<Point2<f64>> {
        let c = Point2::new(0.0, -r_in);
        let at = |r: f64, a: f64| Point2::new(c.x + r * a.sin(), c.y + r * a.cos());
        let mut pts = vec![];
        let step = |r: f64| 0.1 / r;
        // Inner edge from the clamp to the tip.
        let mut a = 0.0;
        while a < angle {
            pts.push(at(r_in, a));
            a += step(r_in);
        }
        // Tip face.
        let mut r = r_in;
        while r < r_in + h {
            pts.push(at(r, angle));
            r += 0.1;
        }
        // Outer edge back to the clamp, notched 3 mm deep.
        let mut a = angle;
        while a > 0.0 {
            let depth = match notch {
                Some(p) if (a / p).fract() < 0.05 => 3.0,
                Some(p) => dent * (std::f64::consts::PI * (a / p).fract()).sin(),
                None => 0.0,
            };
            pts.push(at(r_in + h - depth, a));
            a -= step(r_in + h);
        }
        // Clamp face.
        let mut r = r_in + h;
        while r > r_in {
            pts.push(at(r, 0.0));
            r -= 0.1;
        }
        pts
    }

    #[test]
    fn the_concave_edge_is_kept_from_past_the_clamp_to_before_the_tip() {
        // The last two: nearly straight, chambers 16 mm long whose dented tops make the
        // short run before the first gap turn more concavely than the whole long edge.
        for (r_in, notch, dent, reversed) in [
            (60.0, None, 0.0, false),
            (60.0, Some(0.15), 0.0, false),
            (30.0, Some(0.3), 0.0, true),
            (200.0, None, 0.0, true),
            (260.0, Some(16.0 / 283.5), 4.0, false),
            (260.0, Some(16.0 / 283.5), 4.0, true),
        ] {
            let (h, angle) = (23.5, 100.0 / r_in);
            let mut pts = band(r_in, h, angle, notch, dent);
            if reversed {
                pts.reverse();
            }
            let away = Vector2::new(1.0, 0.0);
            // The middle of the clamp face (the body's leftmost point is the tip once
            // it curls back past the clamp).
            let face = Point2::new(0.0, 0.5 * h);
            let near = (0..pts.len())
                .min_by(|&a, &b| (pts[a] - face).norm().total_cmp(&(pts[b] - face).norm()))
                .unwrap();
            let clamp_mm = 5.0;
            let edge =
                strain_limited_edge(&pts, away, 0.0, near, clamp_mm, TURN_WINDOW_MM).unwrap();
            let e: Vec<Point2<f64>> = edge.iter().map(|&i| pts[i]).collect();
            let c = fit_circle_pratt(&e).unwrap();
            assert!(
                (c.radius - r_in).abs() < 1e-6,
                "r_in {r_in}: fitted {}",
                c.radius
            );
            // From the clamp: the first point just past clamp_mm + CORNER_MM, the last
            // one before the tip by at least CORNER_MM.
            let first = e[0].x;
            assert!(
                (first - (clamp_mm + CORNER_MM)).abs() < 0.2,
                "r_in {r_in}: starts at x = {first}"
            );
            let last = e.last().unwrap();
            let s_last = r_in
                * last
                    .x
                    .atan2(last.y + r_in)
                    .rem_euclid(std::f64::consts::TAU);
            let to_tip = 100.0 - s_last;
            assert!(
                to_tip > CORNER_MM && to_tip < CORNER_MM + TURN_WINDOW_MM + 0.5,
                "r_in {r_in}: ends {to_tip} mm before the tip"
            );
        }
    }
}
