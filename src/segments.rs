//! Segmented actuators: `segments = [[1, 2, 3], [4, 5, 6], [7, 8, 9]]` in
//! bendscope.toml, marker numbers from the clamped end. Each segment is fitted with its
//! own circle (the single fit averages segments that bend differently into a number that
//! describes none); the marker pick follows the segments ([`crate::select`]).
//!
//! Written here because it is a domain rule (how a segmented PneuNets marker line is
//! numbered and checked), not a generic algorithm.

use nalgebra::Point2;
use serde::{Deserialize, Serialize};

use crate::fit::{bending_angle_along_markers_deg, fit_circle_pratt};

/// Markers a segment needs at least (a circle needs 3 points).
pub const MIN_SEGMENT_MARKERS: usize = 3;

/// One segment of the marker chain: 0-based indices of its first and last marker
/// (inclusive; markers `first..=last`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Segment {
    /// Index of its first marker in the chain from the clamped end.
    pub first: usize,
    /// Index of its last marker.
    pub last: usize,
}

impl Segment {
    /// Its markers as written in bendscope.toml and per_segment.csv: 1-based numbers
    /// joined by spaces ("4 5 6").
    pub fn label(&self) -> String {
        (self.first + 1..=self.last + 1)
            .map(|k| k.to_string())
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// The segments of `spec` (marker numbers from 1 at the clamped end) for a chain of
/// `expected_markers`, or what is wrong with them: each segment lists consecutive
/// markers in increasing order, at least [`MIN_SEGMENT_MARKERS`]; the next segment starts
/// at the previous one's last marker (shared) or right after it; together they cover
/// markers 1 to `expected_markers`.
pub fn segments_from_spec(
    spec: &[Vec<usize>],
    expected_markers: usize,
) -> Result<Vec<Segment>, String> {
    if spec.is_empty() {
        return Err("[]: give at least one segment, e.g. [[1, 2, 3], [4, 5, 6]]".into());
    }
    let mut out: Vec<Segment> = Vec::with_capacity(spec.len());
    for (k, s) in spec.iter().enumerate() {
        let n = k + 1;
        if s.len() < MIN_SEGMENT_MARKERS {
            return Err(format!(
                "segment {n} has {} marker(s): each needs at least {MIN_SEGMENT_MARKERS} for its circle",
                s.len()
            ));
        }
        if let Some(m) = s.iter().find(|m| **m == 0 || **m > expected_markers) {
            return Err(format!(
                "segment {n} names marker {m}, which does not exist: markers are numbered 1 to expected_markers = {expected_markers} from the clamped end"
            ));
        }
        if s.windows(2).any(|w| w[1] != w[0] + 1) {
            return Err(format!(
                "segment {n} ({s:?}) is not a run of consecutive markers in increasing order"
            ));
        }
        let seg = Segment {
            first: s[0] - 1,
            last: s[s.len() - 1] - 1,
        };
        match out.last() {
            None if seg.first != 0 => {
                return Err(format!(
                    "segment 1 starts at marker {}: the segments must start at marker 1 (the clamped end)",
                    s[0]
                ))
            }
            Some(prev) if seg.first != prev.last && seg.first != prev.last + 1 => {
                return Err(format!(
                    "segment {n} starts at marker {} but segment {k} ends at marker {}: segments go in order from the clamp, each starting at the previous one's last marker or the next one (overlapping or out of order)",
                    s[0],
                    prev.last + 1
                ))
            }
            _ => {}
        }
        out.push(seg);
    }
    if let Some(last) = out.last() {
        if last.last + 1 != expected_markers {
            return Err(format!(
                "the last segment ends at marker {} but expected_markers = {expected_markers}: the segments must cover every marker",
                last.last + 1
            ));
        }
    }
    Ok(out)
}

/// One segment's circle in one frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SegmentFit {
    /// Radius, mm (infinite for collinear markers).
    #[serde(with = "crate::io::non_finite")]
    pub radius_mm: f64,
    /// Curvature, 1/m.
    #[serde(with = "crate::io::non_finite")]
    pub curvature_per_m: f64,
    /// Bending angle over the segment, degrees (half-angle convention, tangent at the
    /// segment's first marker vs the chord to its last).
    #[serde(with = "crate::io::non_finite")]
    pub bending_angle_deg: f64,
    /// RMS residual of the fit (px in the undistorted frame, or mm for RGB-D).
    #[serde(with = "crate::io::non_finite")]
    pub fit_rms: f64,
    /// Circle centre, undistorted px (plane sessions; for the overlay, not cached).
    #[serde(skip, default = "nan_point")]
    pub center_px: Point2<f64>,
    /// Radius, undistorted px (plane sessions; for the overlay, not cached).
    #[serde(skip, default = "nan")]
    pub radius_px: f64,
}

fn nan() -> f64 {
    f64::NAN
}

fn nan_point() -> Point2<f64> {
    Point2::new(f64::NAN, f64::NAN)
}

/// Fits each segment: its markers' circle in mm (`mm`, plane coordinates) for the
/// radius, curvature and angle, and in `px` (undistorted px; `None` for RGB-D, where the
/// RMS is taken in mm) for the overlay and the RMS. A segment whose fit fails gets NaN.
pub fn fit_segments(
    px: Option<&[Point2<f64>]>,
    mm: &[Point2<f64>],
    segments: &[Segment],
) -> Vec<SegmentFit> {
    segments
        .iter()
        .map(|s| {
            let range = s.first..s.last + 1;
            let nan_fit = SegmentFit {
                radius_mm: f64::NAN,
                curvature_per_m: f64::NAN,
                bending_angle_deg: f64::NAN,
                fit_rms: f64::NAN,
                center_px: nan_point(),
                radius_px: f64::NAN,
            };
            let Some(part_mm) = mm.get(range.clone()) else {
                return nan_fit;
            };
            let Ok(c) = fit_circle_pratt(part_mm) else {
                return nan_fit;
            };
            let px_fit = px
                .and_then(|p| p.get(range))
                .and_then(|p| fit_circle_pratt(p).ok());
            SegmentFit {
                radius_mm: c.radius,
                curvature_per_m: c.curvature * 1000.0,
                bending_angle_deg: bending_angle_along_markers_deg(part_mm, &c).unwrap_or(f64::NAN),
                fit_rms: px_fit.as_ref().map_or(c.rms, |f| f.rms),
                center_px: px_fit.as_ref().map_or(nan_point(), |f| f.center),
                radius_px: px_fit.as_ref().map_or(f64::NAN, |f| f.radius),
            }
        })
        .collect()
}

/// One segment's statistics over a group of frames (a video or a pressure bin).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SegmentStats {
    /// Mean radius, mm.
    pub radius_mm: f64,
    /// Sample standard deviation of the radius, mm (0 for one frame).
    pub radius_mm_std: f64,
    /// Mean curvature, 1/m.
    pub curvature_per_m: f64,
    /// Mean bending angle, degrees.
    pub bending_angle_deg: f64,
    /// Mean fit RMS (px, or mm for RGB-D).
    pub fit_rms: f64,
    /// Frames whose fit of this segment succeeded.
    pub frames_used: usize,
}

/// Per-segment statistics of the measured frames `fits` (each frame's segment fits, in
/// segment order); NaN and 0 frames for a segment never fitted.
pub fn summarize_segments(fits: &[&[SegmentFit]], n_segments: usize) -> Vec<SegmentStats> {
    (0..n_segments)
        .map(|k| {
            let used: Vec<&SegmentFit> = fits
                .iter()
                .filter_map(|f| f.get(k))
                .filter(|f| f.radius_mm.is_finite() || f.curvature_per_m == 0.0)
                .collect();
            let n = used.len();
            let mean = |g: fn(&SegmentFit) -> f64| -> f64 {
                if n == 0 {
                    f64::NAN
                } else {
                    used.iter().map(|f| g(f)).sum::<f64>() / n as f64
                }
            };
            let radius_mm = mean(|f| f.radius_mm);
            let radius_mm_std = if n > 1 && radius_mm.is_finite() {
                (used
                    .iter()
                    .map(|f| (f.radius_mm - radius_mm).powi(2))
                    .sum::<f64>()
                    / (n - 1) as f64)
                    .sqrt()
            } else if n == 1 {
                0.0
            } else {
                f64::NAN
            };
            SegmentStats {
                radius_mm,
                radius_mm_std,
                curvature_per_m: mean(|f| f.curvature_per_m),
                bending_angle_deg: mean(|f| f.bending_angle_deg),
                fit_rms: mean(|f| f.fit_rms),
                frames_used: n,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_are_read_from_marker_numbers() {
        let s = segments_from_spec(&[vec![1, 2, 3], vec![3, 4, 5, 6], vec![7, 8, 9]], 9).unwrap();
        assert_eq!(
            s,
            [
                Segment { first: 0, last: 2 },
                Segment { first: 2, last: 5 },
                Segment { first: 6, last: 8 }
            ]
        );
        assert_eq!(s[1].label(), "3 4 5 6");
    }

    #[test]
    fn bad_segments_say_what_is_wrong() {
        let e = |spec: &[Vec<usize>], n| segments_from_spec(spec, n).unwrap_err();
        assert!(e(&[vec![1, 2]], 2).contains("at least 3"));
        assert!(e(&[vec![1, 2, 3], vec![3, 4, 10]], 9).contains("marker 10, which does not exist"));
        assert!(e(&[vec![1, 2, 3], vec![2, 3, 4]], 4).contains("overlapping or out of order"));
        assert!(e(&[vec![1, 3, 2]], 3).contains("consecutive"));
        assert!(e(&[vec![2, 3, 4]], 4).contains("start at marker 1"));
        assert!(e(&[vec![1, 2, 3]], 5).contains("cover every marker"));
        assert!(e(&[], 5).contains("at least one segment"));
    }

    #[test]
    fn each_segment_gets_its_own_circle() {
        // Two arcs meeting tangentially at marker 3 (shared): R 100 then R 40 mm.
        let mut pts = vec![];
        for k in 0..3 {
            let t = 20.0 * k as f64 / 100.0;
            pts.push(Point2::new(100.0 * t.sin(), 100.0 * (1.0 - t.cos())));
        }
        let (p, a) = (pts[2], 40.0f64 / 100.0);
        let centre = Point2::new(p.x - 40.0 * a.sin(), p.y + 40.0 * a.cos());
        for k in 1..3 {
            let t = a + 10.0 * k as f64 / 40.0;
            pts.push(Point2::new(
                centre.x + 40.0 * t.sin(),
                centre.y - 40.0 * t.cos(),
            ));
        }
        let segs = segments_from_spec(&[vec![1, 2, 3], vec![3, 4, 5]], 5).unwrap();
        let f = fit_segments(None, &pts, &segs);
        assert!((f[0].radius_mm - 100.0).abs() < 1e-9, "{f:?}");
        assert!((f[1].radius_mm - 40.0).abs() < 1e-9, "{f:?}");
        assert!((f[1].curvature_per_m - 25.0).abs() < 1e-9);
    }
}
