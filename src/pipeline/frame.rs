//! One frame: detect -> check the markers -> undistort (or lift to 3D with depth) ->
//! order from the clamped end -> fit the circle. The same function serves videos, photos
//! and RGB-D frames; [`Geometry`] says how image points become millimetres. Outline mode
//! (`[detect] mode = "outline"`, no dots: the body's strain-limited edge) is the child
//! module `outline`, reached from [`measure_frame`]'s match on the mode.

mod outline;

pub use outline::strain_limited_edge;

use image::GrayImage;
use nalgebra::{Point2, Point3};

use crate::calib::Undistorter;
use crate::detect::{
    detect_markers_with, order_marker_indices, ChainStart, DetectMode, DetectSettings, MaskBuffer,
    PixelSource,
};
use crate::fit::{bending_angle_along_markers_deg, fit_circle_3d, fit_circle_pratt};
use crate::rgbd::{markers_on_depth_plane, RgbdIntrinsics};
use crate::scale::apply_homography;
use crate::segments::{fit_segments, Segment, SegmentFit};
use crate::select::{chain_continuation, select_markers, select_markers_in_segments, Candidate};
use crate::session::SessionConfig;
use crate::video::Pixels;

use super::records::{FrameStatus, MarkerPoint};

/// A 16-bit depth frame aligned to the colour frame ([`crate::rgbd`] makes them).
pub use crate::rgbd::DepthImage;

/// How image points become lengths.
#[derive(Debug, Clone, Copy)]
pub enum Geometry<'a> {
    /// Markers in a plane parallel to the image plane: centroids undistorted (`None`: the
    /// frame itself was undistorted), radius in px times `mm_per_px`.
    Plane {
        /// The camera, or `None` for frames already undistorted.
        undistorter: Option<&'a Undistorter>,
        /// mm per undistorted px at this frame size.
        mm_per_px: f64,
        /// Undistorted px (this frame size) -> mm in the actuator plane, row-major: the
        /// circle is fitted in mm through it when given (a plane not quite parallel to
        /// the image plane), else in px times `mm_per_px`.
        plane_from_px: Option<[f64; 9]>,
    },
    /// Colour + aligned depth: 3D markers, circle fitted in their plane (mm directly).
    Depth {
        /// The colour camera.
        undistorter: &'a Undistorter,
        /// Its intrinsics and depth scale.
        intrinsics: &'a RgbdIntrinsics,
    },
}

/// What stays from frame to frame of one session: where the marker chain starts (the
/// previous frame's clamped-end marker) and the mask buffer.
#[derive(Debug, Clone)]
pub struct Tracker {
    /// Where the next frame's chain starts.
    pub start: ChainStart,
    /// The last measured frame's markers, ordered (favours the chain that moved least
    /// when a frame has extra red blobs).
    pub previous: Option<Vec<Point2<f64>>>,
    mask: MaskBuffer,
}

impl Tracker {
    /// Starts at `start` (the clamp side, or an earlier video's clamped-end marker).
    pub fn new(start: ChainStart) -> Self {
        Self {
            start,
            previous: None,
            mask: MaskBuffer::default(),
        }
    }

    /// The mask of the last frame measured (for overlays).
    pub fn mask(&self) -> &GrayImage {
        self.mask.mask()
    }
}

/// One frame's measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameMeasurement {
    /// Markers found (the expected count when measured).
    pub n_markers: usize,
    /// Ordered marker points from the clamped end: undistorted px (plane) or raw px
    /// (depth); empty when rejected.
    pub markers_px: Vec<Point2<f64>>,
    /// Red blobs not taken as markers (same space as `markers_px`).
    pub ignored_px: Vec<Point2<f64>>,
    /// Of the ignored blobs, those that continue the marker chain at either end (alike
    /// size, spacing and turn: [`chain_continuation`]); 0 when rejected.
    pub n_continuing: usize,
    /// Circle centre, undistorted px (plane only).
    pub center_px: Point2<f64>,
    /// Radius, undistorted px (plane only; infinite for collinear markers).
    pub radius_px: f64,
    /// Radius, mm.
    pub radius_mm: f64,
    /// Curvature, 1/m.
    pub curvature_per_m: f64,
    /// Bending angle, degrees (tangent at the clamped-end marker vs the chord to the tip,
    /// half-angle convention of method.md §2.9).
    pub bending_angle_deg: f64,
    /// RMS residual of the fit (px for plane, mm for depth).
    pub fit_rms: f64,
    /// Outcome.
    pub status: FrameStatus,
    /// The markers of `markers_px`, in order, with their raw-frame centroid and their
    /// position in mm ([`MarkerPoint`]); empty when rejected. With frames undistorted
    /// before detection (`Geometry::Plane` without an undistorter) the "raw" centroid is
    /// the undistorted frame's: the caller maps it back through the lens model.
    pub markers: Vec<MarkerPoint>,
    /// Segmented actuators: one circle per segment (empty without segments or when
    /// rejected).
    pub segments: Vec<SegmentFit>,
    /// Outline mode: the circle fitted to the body's edge (centre, radius; undistorted
    /// px) before `outline_offset_mm` moved it; `None` otherwise.
    pub edge_circle_px: Option<(Point2<f64>, f64)>,
}

impl FrameMeasurement {
    /// A rejected frame with `n` markers found.
    pub fn rejected(n: usize, status: FrameStatus) -> Self {
        Self {
            n_markers: n,
            markers_px: vec![],
            ignored_px: vec![],
            n_continuing: 0,
            center_px: Point2::new(f64::NAN, f64::NAN),
            radius_px: f64::NAN,
            radius_mm: f64::NAN,
            curvature_per_m: f64::NAN,
            bending_angle_deg: f64::NAN,
            fit_rms: f64::NAN,
            status,
            markers: vec![],
            segments: vec![],
            edge_circle_px: None,
        }
    }
}

/// What a frame's markers are: how many, where they may be, how they are grouped.
#[derive(Debug, Clone, Copy)]
pub struct MarkerLayout<'a> {
    /// Markers per frame (`expected_markers`).
    pub expected: usize,
    /// Region of interest (undistorted px), when set.
    pub roi: Option<&'a [[f64; 2]]>,
    /// Segments of a segmented actuator (empty: one arc).
    pub segments: &'a [Segment],
}

/// Measures one frame. `depth` is required by [`Geometry::Depth`] and ignored otherwise.
/// With more red blobs than markers, the markers are the chain [`select_markers`] finds
/// ([`select_markers_in_segments`] with segments; the others are counted as ignored).
/// On success the tracker's chain start moves to this frame's clamped-end marker and
/// its markers are remembered for the next frame.
pub fn measure_frame<S: PixelSource>(
    pixels: &S,
    depth: Option<&DepthImage>,
    geometry: &Geometry,
    detect: &DetectSettings,
    layout: &MarkerLayout,
    tracker: &mut Tracker,
) -> FrameMeasurement {
    // The detection modes: each turns a frame into a measurement its own way.
    match detect.mode {
        DetectMode::Dots => {}
        DetectMode::Outline => return outline::measure_outline(pixels, geometry, detect, tracker),
    }
    let (expected_markers, roi, segments) = (layout.expected, layout.roi, layout.segments);
    let d = detect_markers_with(pixels, detect, &mut tracker.mask);
    let found = d.blobs.len();
    if found < expected_markers {
        return FrameMeasurement::rejected(
            found,
            FrameStatus::MarkerCount {
                found,
                expected: expected_markers,
                specks: d.specks,
                too_large: d.too_large,
                outside_roi: 0,
            },
        );
    }
    let raw: Vec<Point2<f64>> = d.blobs.iter().map(|b| b.centroid).collect();
    // Candidates where the arc is a circle: undistorted px for a plane, raw px with depth
    // (a nearly distortion-free colour camera; 3D comes later).
    let working = match geometry {
        Geometry::Plane {
            undistorter: Some(u),
            ..
        } => match u.undistort_points(&raw) {
            Ok(p) => p,
            Err(e) => {
                return FrameMeasurement::rejected(
                    found,
                    FrameStatus::FitFailed {
                        why: format!("undistortion failed: {e}"),
                    },
                )
            }
        },
        _ => raw.clone(),
    };
    // Blobs outside the region of interest are never markers.
    let inside: Vec<usize> = (0..found)
        .filter(|&i| roi.is_none_or(|poly| inside_polygon(working[i], poly)))
        .collect();
    if inside.len() < expected_markers {
        return FrameMeasurement::rejected(
            inside.len(),
            FrameStatus::MarkerCount {
                found: inside.len(),
                expected: expected_markers,
                specks: d.specks,
                too_large: d.too_large,
                outside_roi: found - inside.len(),
            },
        );
    }
    let (order, n_continuing): (Vec<usize>, usize) = if inside.len() == expected_markers {
        let pts: Vec<Point2<f64>> = inside.iter().map(|&i| working[i]).collect();
        let order = order_marker_indices(&pts, tracker.start)
            .into_iter()
            .map(|k| inside[k])
            .collect();
        (order, 0)
    } else {
        let candidates: Vec<Candidate> = inside
            .iter()
            .map(|&i| (&d.blobs[i], &working[i]))
            .map(|(b, p)| {
                let (w, h) = (
                    (b.bbox[2] - b.bbox[0] + 1) as f64,
                    (b.bbox[3] - b.bbox[1] + 1) as f64,
                );
                Candidate {
                    point: *p,
                    area_px: b.area_px as f64,
                    elongation: w.max(h) / w.min(h),
                }
            })
            .collect();
        let picked = if segments.is_empty() {
            select_markers(
                &candidates,
                expected_markers,
                tracker.start,
                tracker.previous.as_deref(),
            )
        } else {
            select_markers_in_segments(
                &candidates,
                expected_markers,
                segments,
                tracker.start,
                tracker.previous.as_deref(),
            )
        };
        match picked {
            Ok(order) => {
                let more = chain_continuation(&candidates, &order);
                (order.into_iter().map(|k| inside[k]).collect(), more)
            }
            Err(e) => {
                return FrameMeasurement::rejected(
                    found,
                    FrameStatus::NoMarkerChain { why: e.to_string() },
                )
            }
        }
    };
    let ignored_px: Vec<Point2<f64>> = (0..found)
        .filter(|i| !order.contains(i))
        .map(|i| working[i])
        .collect();
    // The calibration is valid only where its board went: a marker beyond that field
    // would be undistorted by an extrapolated lens model.
    if let Geometry::Plane {
        undistorter: Some(u),
        ..
    } = geometry
    {
        if order.iter().any(|&i| !u.in_valid_field(raw[i])) {
            return FrameMeasurement::rejected(found, FrameStatus::OutsideCalibratedField);
        }
    }
    let chosen: Vec<Point2<f64>> = order.iter().map(|&i| working[i]).collect();
    let (m, mm) = match geometry {
        Geometry::Plane {
            mm_per_px,
            plane_from_px,
            ..
        } => measure_plane(chosen, *mm_per_px, plane_from_px.as_ref(), segments),
        Geometry::Depth {
            undistorter,
            intrinsics,
        } => measure_depth(chosen, depth, undistorter, intrinsics, segments),
    };
    let markers = if m.status.is_ok() {
        order
            .iter()
            .zip(&mm)
            .map(|(&i, p)| MarkerPoint {
                x_px: raw[i].x,
                y_px: raw[i].y,
                x_mm: p.x,
                y_mm: p.y,
                z_mm: p.z,
            })
            .collect()
    } else {
        vec![]
    };
    if m.status.is_ok() {
        if let Some(first) = m.markers_px.first() {
            tracker.start = ChainStart::Near(*first);
        }
        tracker.previous = Some(m.markers_px.clone());
    }
    let n_continuing = if m.status.is_ok() { n_continuing } else { 0 };
    FrameMeasurement {
        n_markers: expected_markers.min(found),
        ignored_px,
        n_continuing,
        markers,
        ..m
    }
}

/// Share of a video's measured frames in which blobs must continue the marker chain for
/// [`chain_continues_warning`] to speak (a red thing passing by in a few frames is not
/// a marker line).
pub const CONTINUING_FRAMES_SHARE: f64 = 0.5;

/// A warning when, in at least [`CONTINUING_FRAMES_SHARE`] of the measured `frames`,
/// marker-like blobs continue the chain of `expected_markers`: more markers are painted
/// than `expected_markers` says, and only part of the chain is measured. Names the
/// count seen most often.
pub fn chain_continues_warning(
    frames: &[super::records::FrameRecord],
    expected_markers: usize,
) -> Option<String> {
    let ok: Vec<usize> = frames
        .iter()
        .filter(|f| f.status.is_ok())
        .map(|f| f.n_continuing)
        .collect();
    let with = ok.iter().filter(|n| **n > 0).count();
    if with == 0 || (with as f64) < CONTINUING_FRAMES_SHARE * ok.len() as f64 {
        return None;
    }
    let mut counts = std::collections::BTreeMap::<usize, usize>::new();
    for n in ok.iter().filter(|n| **n > 0) {
        *counts.entry(*n).or_default() += 1;
    }
    let more = counts
        .iter()
        .max_by_key(|(n, c)| (**c, std::cmp::Reverse(**n)))
        .map(|(n, _)| *n)
        .unwrap_or(0);
    Some(format!(
        "{more} more marker-like blob(s) continue the chain of {expected_markers} markers (alike size and spacing, on its arc) in {with} of {} measured frames: only part of the chain is measured; if the actuator has {} markers, set expected_markers = {} in {}",
        ok.len(),
        expected_markers + more,
        expected_markers + more,
        crate::session::CONFIG
    ))
}

/// The measurement of markers in a plane, and their plane positions (mm, z NaN).
fn measure_plane(
    ordered: Vec<Point2<f64>>,
    mm_per_px: f64,
    plane_from_px: Option<&[f64; 9]>,
    segments: &[Segment],
) -> (FrameMeasurement, Vec<Point3<f64>>) {
    let n = ordered.len();
    let fit_failed = |e: crate::fit::FitError| {
        (
            FrameMeasurement::rejected(n, FrameStatus::FitFailed { why: e.to_string() }),
            vec![],
        )
    };
    // The px circle (overlay, fit RMS in px); the mm one from the plane's homography.
    let circle = match fit_circle_pratt(&ordered) {
        Ok(c) => c,
        Err(e) => return fit_failed(e),
    };
    let mm_points: Vec<Point2<f64>> = match plane_from_px {
        Some(h) => ordered.iter().map(|p| apply_homography(h, *p)).collect(),
        None => ordered
            .iter()
            .map(|p| Point2::from(p.coords * mm_per_px))
            .collect(),
    };
    let circle_mm = match fit_circle_pratt(&mm_points) {
        Ok(c) => c,
        Err(e) => return fit_failed(e),
    };
    let angle = bending_angle_along_markers_deg(&mm_points, &circle_mm).unwrap_or(f64::NAN);
    let segments = fit_segments(Some(&ordered), &mm_points, segments);
    let in_mm = mm_points
        .iter()
        .map(|p| Point3::new(p.x, p.y, f64::NAN))
        .collect();
    (
        FrameMeasurement {
            n_markers: n,
            ignored_px: vec![],
            n_continuing: 0,
            center_px: circle.center,
            radius_px: circle.radius,
            radius_mm: circle_mm.radius,
            curvature_per_m: circle_mm.curvature * 1000.0,
            bending_angle_deg: angle,
            fit_rms: circle.rms,
            markers_px: ordered,
            status: FrameStatus::Ok,
            markers: vec![],
            segments,
            edge_circle_px: None,
        },
        in_mm,
    )
}

/// The measurement of markers lifted to 3D with depth, and their camera-frame
/// positions (mm).
fn measure_depth(
    ordered: Vec<Point2<f64>>,
    depth: Option<&DepthImage>,
    undistorter: &Undistorter,
    intrinsics: &RgbdIntrinsics,
    segments: &[Segment],
) -> (FrameMeasurement, Vec<Point3<f64>>) {
    let n = ordered.len();
    let Some(depth) = depth else {
        return (
            FrameMeasurement::rejected(
                n,
                FrameStatus::BadFrame {
                    why: "no depth frame".into(),
                },
            ),
            vec![],
        );
    };
    let pts = match markers_on_depth_plane(&ordered, depth, intrinsics, undistorter) {
        Ok(p) => p,
        Err(e) => return (FrameMeasurement::rejected(n, e), vec![]),
    };
    let c = match fit_circle_3d(&pts) {
        Ok(c) => c,
        Err(e) => {
            return (
                FrameMeasurement::rejected(n, FrameStatus::FitFailed { why: e.to_string() }),
                vec![],
            )
        }
    };
    let in_plane: Vec<Point2<f64>> = pts.iter().map(|p| c.to_plane(p)).collect();
    let angle = bending_angle_along_markers_deg(&in_plane, &c.circle).unwrap_or(f64::NAN);
    let segments = fit_segments(None, &in_plane, segments);
    (
        FrameMeasurement {
            n_markers: n,
            ignored_px: vec![],
            n_continuing: 0,
            center_px: Point2::new(f64::NAN, f64::NAN),
            radius_px: f64::NAN,
            radius_mm: c.circle.radius,
            curvature_per_m: c.circle.curvature * 1000.0,
            bending_angle_deg: angle,
            fit_rms: c.circle.rms,
            markers_px: ordered,
            status: FrameStatus::Ok,
            markers: vec![],
            segments,
            edge_circle_px: None,
        },
        pts,
    )
}

/// Whether `p` lies inside the polygon `poly` (even-odd rule).
pub fn inside_polygon(p: Point2<f64>, poly: &[[f64; 2]]) -> bool {
    let mut inside = false;
    let n = poly.len();
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + n - 1) % n]);
        if (a[1] > p.y) != (b[1] > p.y) && p.x < (b[0] - a[0]) * (p.y - a[1]) / (b[1] - a[1]) + a[0]
        {
            inside = !inside;
        }
    }
    inside
}

/// [`measure_frame`] on decoded [`Pixels`] (YUV planes or RGB) with the session's
/// detection settings and `segments` (the session's [`SessionConfig::segment_plan`]).
pub fn measure_pixels(
    pixels: &Pixels,
    depth: Option<&DepthImage>,
    geometry: &Geometry,
    config: &SessionConfig,
    segments: &[Segment],
    tracker: &mut Tracker,
) -> FrameMeasurement {
    let layout = MarkerLayout {
        expected: config.expected_markers,
        roi: config.roi.as_deref(),
        segments,
    };
    match pixels {
        Pixels::Yuv(yuv) => measure_frame(yuv, depth, geometry, &config.detect, &layout, tracker),
        Pixels::Yuv10(yuv) => measure_frame(yuv, depth, geometry, &config.detect, &layout, tracker),
        Pixels::Rgb(rgb) => measure_frame(rgb, depth, geometry, &config.detect, &layout, tracker),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polygon_inside_test() {
        let square = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        assert!(inside_polygon(Point2::new(5.0, 5.0), &square));
        assert!(!inside_polygon(Point2::new(15.0, 5.0), &square));
        assert!(!inside_polygon(Point2::new(5.0, -1.0), &square));
        let l_shape = [
            [0.0, 0.0],
            [10.0, 0.0],
            [10.0, 4.0],
            [4.0, 4.0],
            [4.0, 10.0],
            [0.0, 10.0],
        ];
        assert!(inside_polygon(Point2::new(2.0, 8.0), &l_shape));
        assert!(!inside_polygon(Point2::new(8.0, 8.0), &l_shape));
    }
}
