//! `markers.csv`: every measured marker of every frame in one session-wide frame of
//! axes, and the tip pose (position and angle) per frame that `per_video.csv` summarizes.
//!
//! # Axes (written by hand: a convention, documented in the README)
//!
//! - Origin: marker 1 (the clamped end) of the session's first measured frame (manifest
//!   order; the rest frame when the session starts at 0 kPa).
//! - x: from that marker toward the tip marker of the same frame (the actuator's chord;
//!   at rest, its length direction).
//! - y: perpendicular to x in the actuator plane, toward the side the actuator bends to
//!   (the sign that makes the mean tip y over the measured frames >= 0), so the axes may
//!   be mirrored with respect to the image.
//! - Plane sessions: positions in the actuator plane from the scale board's homography
//!   (or undistorted px times mm per px), then moved and turned into these axes.
//! - RGB-D: the actuator plane is the least-squares plane of every measured marker of
//!   the session (the smallest principal axis of their 3D cloud is its normal; the
//!   camera's optical axis when the markers never leave a line); x, y as above in that
//!   plane, `z_mm` the distance out of it toward the camera.
//!
//! Tip angle: the direction of the chord from the second-to-last marker to the tip
//! marker, measured from +x toward +y, in degrees, unwrapped along the chain (the turns
//! between successive chords are added up), so an actuator curled past 180 degrees
//! reads above 180 rather than wrapping to negative values.

use std::path::Path;

use nalgebra::{Matrix3, Vector3};

use crate::table::{write_csv, Column};

use super::error::PipelineError;
use super::records::{FrameRecord, MarkerPoint};

/// Below this share of the largest principal variance, the second one means the RGB-D
/// markers lie on a line (a straight actuator throughout) and define no plane.
const LINE_VARIANCE_SHARE: f64 = 1e-6;

/// The session's axes of `markers.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionAxes {
    /// Origin (marker 1 of the first measured frame), in the markers' mm space.
    pub origin: Vector3<f64>,
    /// Unit x axis.
    pub x: Vector3<f64>,
    /// Unit y axis (toward the bending side).
    pub y: Vector3<f64>,
    /// Unit normal of the actuator plane (toward the camera for RGB-D).
    pub z: Vector3<f64>,
    /// Whether the markers are 3D (RGB-D) and `z_mm` is written.
    pub depth: bool,
}

/// A marker's mm position as a 3D vector (z = 0 for a plane session).
fn position(p: &MarkerPoint) -> Vector3<f64> {
    let z = if p.z_mm.is_finite() { p.z_mm } else { 0.0 };
    Vector3::new(p.x_mm, p.y_mm, z)
}

/// The markers of the measured frames with at least two markers.
fn measured<'a>(
    frames: impl IntoIterator<Item = &'a FrameRecord>,
) -> impl Iterator<Item = &'a FrameRecord> {
    frames
        .into_iter()
        .filter(|f| f.status.is_ok() && f.markers.len() >= 2)
}

impl SessionAxes {
    /// The axes of a session's `frames` (every item's, in order); `None` when no frame
    /// was measured.
    pub fn from_frames<'a>(
        frames: impl IntoIterator<Item = &'a FrameRecord> + Clone,
    ) -> Option<Self> {
        let first = measured(frames.clone()).next()?;
        let depth = first.markers.iter().all(|p| p.z_mm.is_finite());
        let z = if depth {
            plane_normal(measured(frames.clone()).flat_map(|f| f.markers.iter().map(position)))
        } else {
            Vector3::z()
        };
        let origin = position(&first.markers[0]);
        let chord = position(first.markers.last()?) - origin;
        let x = (chord - z * chord.dot(&z)).try_normalize(f64::EPSILON)?;
        let y = z.cross(&x);
        let tip_y: f64 = measured(frames)
            .filter_map(|f| f.markers.last())
            .map(|p| (position(p) - origin).dot(&y))
            .sum();
        let y = if tip_y < 0.0 { -y } else { y };
        Some(Self {
            origin,
            x,
            y,
            z,
            depth,
        })
    }

    /// `p` in these axes: (x, y, z) mm.
    pub fn place(&self, p: &MarkerPoint) -> [f64; 3] {
        let d = position(p) - self.origin;
        [d.dot(&self.x), d.dot(&self.y), d.dot(&self.z)]
    }

    /// The tip pose of a frame's ordered markers: tip position (mm) and tip angle
    /// (degrees, unwrapped along the chain); `None` for fewer than two markers.
    pub fn tip_pose(&self, markers: &[MarkerPoint]) -> Option<TipPose> {
        let tip = self.place(markers.last()?);
        let pts: Vec<[f64; 3]> = markers.iter().map(|p| self.place(p)).collect();
        let dirs: Vec<(f64, f64)> = pts
            .windows(2)
            .map(|w| (w[1][0] - w[0][0], w[1][1] - w[0][1]))
            .collect();
        let (dx, dy) = *dirs.first()?;
        let mut angle = dy.atan2(dx);
        for w in dirs.windows(2) {
            let ((ax, ay), (bx, by)) = (w[0], w[1]);
            angle += (ax * by - ay * bx).atan2(ax * bx + ay * by);
        }
        Some(TipPose {
            x_mm: tip[0],
            y_mm: tip[1],
            angle_deg: angle.to_degrees(),
        })
    }
}

/// Where a frame's tip marker is, in the session's axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipPose {
    /// Tip x, mm.
    pub x_mm: f64,
    /// Tip y, mm.
    pub y_mm: f64,
    /// Tip angle, degrees (see the module doc).
    pub angle_deg: f64,
}

/// Unit normal of the least-squares plane of `points` (the eigenvector of the smallest
/// eigenvalue of their scatter matrix), turned toward the camera (negative camera z);
/// the optical axis toward the camera when the points lie on a line or are too few.
fn plane_normal(points: impl Iterator<Item = Vector3<f64>>) -> Vector3<f64> {
    let toward_camera = -Vector3::z();
    let pts: Vec<Vector3<f64>> = points.filter(|p| p.iter().all(|v| v.is_finite())).collect();
    if pts.len() < 3 {
        return toward_camera;
    }
    let mean = pts.iter().sum::<Vector3<f64>>() / pts.len() as f64;
    let scatter: Matrix3<f64> = pts
        .iter()
        .map(|p| (p - mean) * (p - mean).transpose())
        .sum();
    let eig = scatter.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let (middle, largest) = (eig.eigenvalues[order[1]], eig.eigenvalues[order[2]]);
    if middle.is_nan() || largest.is_nan() || middle <= LINE_VARIANCE_SHARE * largest {
        return toward_camera;
    }
    let n: Vector3<f64> = eig.eigenvectors.column(order[0]).into_owned();
    if n.dot(&toward_camera) < 0.0 {
        -n
    } else {
        n
    }
}

/// Sets every measured frame's tip pose (`tip_x_mm`, `tip_y_mm`, `tip_angle_deg`) in
/// `axes`; the others keep NaN.
pub fn set_tip_poses<'a>(
    frames: impl IntoIterator<Item = &'a mut FrameRecord>,
    axes: &SessionAxes,
) {
    for f in frames {
        if !f.status.is_ok() {
            continue;
        }
        if let Some(t) = axes.tip_pose(&f.markers) {
            (f.tip_x_mm, f.tip_y_mm, f.tip_angle_deg) = (t.x_mm, t.y_mm, t.angle_deg);
        }
    }
}

/// Writes `markers.csv`: `file,frame,time_s,pressure_kpa,marker,x_px,y_px,x_mm,y_mm`
/// (plus `z_mm` for RGB-D), one row per marker of each measured frame, marker 1 the
/// clamped end. Only the header when no frame was measured.
pub fn write_markers_csv(
    path: &Path,
    frames: &[FrameRecord],
    axes: Option<&SessionAxes>,
) -> Result<(), PipelineError> {
    let rows: Vec<(&FrameRecord, usize, &MarkerPoint)> = match axes {
        Some(_) => frames
            .iter()
            .filter(|f| f.status.is_ok())
            .flat_map(|f| {
                f.markers
                    .iter()
                    .enumerate()
                    .map(move |(k, p)| (f, k + 1, p))
            })
            .collect(),
        None => vec![],
    };
    let placed: Vec<[f64; 3]> = rows
        .iter()
        .map(|(_, _, p)| axes.map_or([f64::NAN; 3], |a| a.place(p)))
        .collect();
    let num = |i: usize| placed.iter().map(move |p| p[i]);
    let mut cols = vec![
        Column::text("file", rows.iter().map(|r| r.0.file.clone())),
        Column::int("frame", rows.iter().map(|r| r.0.frame)),
        Column::num("time_s", 4, rows.iter().map(|r| r.0.time_s)),
        Column::num("pressure_kpa", 3, rows.iter().map(|r| r.0.pressure_kpa)),
        Column::int("marker", rows.iter().map(|r| r.1 as u64)),
        Column::num("x_px", 3, rows.iter().map(|r| r.2.x_px)),
        Column::num("y_px", 3, rows.iter().map(|r| r.2.y_px)),
        Column::num("x_mm", 4, num(0)),
        Column::num("y_mm", 4, num(1)),
    ];
    if axes.is_some_and(|a| a.depth) {
        cols.push(Column::num("z_mm", 4, num(2)));
    }
    write_csv(path, &cols)?;
    Ok(())
}

/// Least motion of marker 1 over the measured frames, mm (RMS distance from its mean
/// position), before [`clamp_end_warning`] speaks: below it the clamp's marker is still.
pub const CLAMP_MOTION_MIN_MM: f64 = 1.0;
/// How many times more marker 1 must move than the last marker for
/// [`clamp_end_warning`] to speak.
pub const CLAMP_MOTION_RATIO: f64 = 2.0;

/// RMS distance, mm, of marker `k` of `frames` from its mean position.
fn marker_motion_mm(frames: &[&FrameRecord], k: usize) -> f64 {
    let points: Vec<Vector3<f64>> = frames.iter().map(|f| position(&f.markers[k])).collect();
    let mean = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    (points
        .iter()
        .map(|p| (p - mean).norm_squared())
        .sum::<f64>()
        / points.len() as f64)
        .sqrt()
}

/// A warning when marker 1, taken as the clamped end, moves over the measured `frames`
/// (across pressures) while the last marker, taken as the tip, stays put: the actuator
/// is clamped at the other end than `clamp_side` says, and every tip value describes
/// the clamp. Frames of the most common marker count are compared.
pub fn clamp_end_warning<'a>(frames: impl IntoIterator<Item = &'a FrameRecord>) -> Option<String> {
    let frames: Vec<&FrameRecord> = frames
        .into_iter()
        .filter(|f| f.status.is_ok() && f.markers.len() >= 2)
        .filter(|f| {
            f.markers
                .iter()
                .all(|p| p.x_mm.is_finite() && p.y_mm.is_finite())
        })
        .collect();
    let n = frames.first()?.markers.len();
    let frames: Vec<&FrameRecord> = frames
        .into_iter()
        .filter(|f| f.markers.len() == n)
        .collect();
    if frames.len() < 2 {
        return None;
    }
    let (first, last) = (
        marker_motion_mm(&frames, 0),
        marker_motion_mm(&frames, n - 1),
    );
    (first > CLAMP_MOTION_MIN_MM && first > CLAMP_MOTION_RATIO * last).then(|| {
        format!(
            "marker 1 (taken as the clamped end) moves {first:.1} mm (rms) over the measured frames while marker {n} (taken as the tip) moves {last:.1} mm: the actuator looks clamped at the other end, so the tip values describe the clamp: set [detect] clamp_side in bendscope.toml to the side the clamp is on (left, right, top, bottom)"
        )
    })
}

#[cfg(test)]
mod tests {
    use super::super::records::FrameStatus;
    use super::*;

    fn frame(points: &[(f64, f64)], z: Option<f64>) -> FrameRecord {
        let mut f = FrameRecord::rejected("v", 0, 0.0, 0.0, FrameStatus::Ok);
        f.markers = points
            .iter()
            .map(|&(x, y)| MarkerPoint {
                x_px: 0.0,
                y_px: 0.0,
                x_mm: x,
                y_mm: y,
                z_mm: z.unwrap_or(f64::NAN),
            })
            .collect();
        f
    }

    /// Points of an arc of radius `r` leaving (ox, oy) along direction `a0` (rad),
    /// turning clockwise in the image (y down: toward -y), `n` markers `ds` apart.
    fn arc(o: (f64, f64), a0: f64, r: f64, n: usize, ds: f64) -> Vec<(f64, f64)> {
        (0..n)
            .map(|k| {
                let t = k as f64 * ds / r;
                // Centre to the left of the direction (toward -y when a0 = 0).
                let (nx, ny) = (a0.sin(), -a0.cos());
                let (cx, cy) = (o.0 + r * nx, o.1 + r * ny);
                let phi = (o.1 - cy).atan2(o.0 - cx) - t;
                (cx + r * phi.cos(), cy + r * phi.sin())
            })
            .collect()
    }

    /// `n` points `ds` apart on a straight line from `o` along direction `a0` (rad).
    fn line(o: (f64, f64), a0: f64, n: usize, ds: f64) -> Vec<(f64, f64)> {
        (0..n)
            .map(|k| {
                let s = k as f64 * ds;
                (o.0 + s * a0.cos(), o.1 + s * a0.sin())
            })
            .collect()
    }

    #[test]
    fn axes_start_at_the_clamp_and_point_to_the_tip_and_the_bending_side() {
        let a0 = 0.3;
        let rest = frame(&line((10.0, 20.0), a0, 5, 20.0), None);
        let bent = frame(&arc((10.0, 20.0), a0, 50.0, 5, 20.0), None);
        let axes = SessionAxes::from_frames([&rest, &bent]).unwrap();
        assert!(!axes.depth);
        let m1 = axes.place(&bent.markers[0]);
        assert!(m1[0].abs() < 1e-6 && m1[1].abs() < 1e-6, "{m1:?}");
        let rest_tip = axes.place(&rest.markers[4]);
        assert!((rest_tip[0] - 80.0).abs() < 1e-6 && rest_tip[1].abs() < 1e-6);
        // Exact tip of an arc of 80 mm at R = 50 from the origin along +x, bending to +y.
        let t = axes.tip_pose(&bent.markers).unwrap();
        let phi = 80.0f64 / 50.0;
        assert!((t.x_mm - 50.0 * phi.sin()).abs() < 1e-6, "{t:?}");
        assert!((t.y_mm - 50.0 * (1.0 - phi.cos())).abs() < 1e-6, "{t:?}");
        // The last chord's direction: the tangent at its midpoint, s = 70 mm.
        assert!(
            (t.angle_deg - (70.0f64 / 50.0).to_degrees()).abs() < 1e-6,
            "{t:?}"
        );
    }

    #[test]
    fn a_moving_first_marker_and_a_still_tip_are_warned_as_the_wrong_clamp_end() {
        // Clamped at (0, 0) on the left, bending more with each pressure.
        let frames: Vec<FrameRecord> = [1e9, 400.0, 200.0, 120.0]
            .iter()
            .map(|&r| frame(&arc((0.0, 0.0), 0.0, r, 6, 15.0), None))
            .collect();
        assert_eq!(clamp_end_warning(&frames), None);
        // The same frames numbered from the tip: marker 1 moves, marker 6 does not.
        let reversed: Vec<FrameRecord> = frames
            .iter()
            .map(|f| {
                let mut f = f.clone();
                f.markers.reverse();
                f
            })
            .collect();
        let w = clamp_end_warning(&reversed).unwrap();
        assert!(
            w.starts_with("marker 1 (taken as the clamped end) moves "),
            "{w}"
        );
        assert!(
            w.contains("while marker 6 (taken as the tip) moves 0.0 mm"),
            "{w}"
        );
        assert!(w.contains("set [detect] clamp_side"), "{w}");
        // One pressure only: nothing to compare.
        assert_eq!(clamp_end_warning(&reversed[..1]), None);
    }

    #[test]
    fn tip_angle_is_unwrapped_past_180_degrees() {
        let bent = frame(&arc((0.0, 0.0), 0.0, 20.0, 9, 10.0), None);
        let axes =
            SessionAxes::from_frames([&frame(&[(0.0, 0.0), (80.0, 0.0)], None), &bent]).unwrap();
        let t = axes.tip_pose(&bent.markers).unwrap();
        // Last chord from s = 70 to 80 mm: tangent at s = 75, 75/20 rad = 214.9 degrees.
        assert!(
            (t.angle_deg - (75.0f64 / 20.0).to_degrees()).abs() < 1e-6,
            "{t:?}"
        );
    }

    #[test]
    fn depth_axes_lie_in_the_markers_plane() {
        // Markers in the plane z = 500 + 0.2 x (tilted about the camera's y axis).
        let lift = |pts: Vec<(f64, f64)>| -> FrameRecord {
            let mut f = frame(&pts, Some(0.0));
            for p in &mut f.markers {
                p.z_mm = 500.0 + 0.2 * p.x_mm;
            }
            f
        };
        let rest = lift(line((0.0, 0.0), 0.0, 6, 15.0));
        let bent = lift(arc((0.0, 0.0), 0.0, 60.0, 6, 15.0));
        let axes = SessionAxes::from_frames([&rest, &bent]).unwrap();
        assert!(axes.depth);
        let n = Vector3::new(0.2, 0.0, -1.0).normalize();
        assert!((axes.z.dot(&n) - 1.0).abs() < 1e-9, "{:?}", axes.z);
        for p in bent.markers.iter().chain(&rest.markers) {
            assert!(axes.place(p)[2].abs() < 1e-9);
        }
        // Distances are kept in the plane: the rest tip is 75 mm in x and 15 mm in z
        // from marker 1.
        let tip = axes.place(&rest.markers[5]);
        let chord = (75.0f64.powi(2) + 15.0f64.powi(2)).sqrt();
        assert!(
            (tip[0] - chord).abs() < 1e-6 && tip[1].abs() < 1e-6,
            "{tip:?}"
        );
    }
}
