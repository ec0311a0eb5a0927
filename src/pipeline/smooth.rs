//! `smooth_s`: the low-pass filter labs apply to ramp recordings, here on the marker
//! tracks before the circle is fitted again.
//!
//! Each marker's track (x, y and, for RGB-D, z in mm, over the measured frames of one
//! recording in time order) is replaced by a Savitzky-Golay estimate: the least-squares
//! quadratic in time through the samples within `smooth_s / 2` seconds of the frame,
//! evaluated at the frame's time (Savitzky and Golay 1964, written for uneven sampling
//! so that rejected frames leave gaps, not shifts; near the ends the window is one-sided).
//! A quadratic keeps a ramp's trend and curvature unbiased while the scatter of the
//! centroids averages out. Then the circle is fitted to the smoothed markers as to the
//! raw ones: `radius_mm_smooth`, `curvature_per_m_smooth`, `bending_angle_deg_smooth`.
//! Written by hand: a few lines of local regression on uneven samples, which the
//! filters of signal-processing crates (uniform sampling) do not cover.

use nalgebra::{Matrix3, Point2, Point3, Vector3};

use crate::fit::{bending_angle_along_markers_deg, fit_circle_3d, fit_circle_pratt};

use super::records::{FrameRecord, MarkerPoint};

/// The local quadratic at `t0` through the samples (`t`, `v`) with |t - t0| <= `half_s`;
/// the mean of the window when fewer than 4 samples (or a degenerate spread) make the
/// quadratic unsafe.
fn local_quadratic(ts: &[f64], vs: &[f64], t0: f64, half_s: f64) -> f64 {
    let (mut m, mut b) = (Matrix3::<f64>::zeros(), Vector3::<f64>::zeros());
    let (mut sum, mut n) = (0.0, 0usize);
    for (&t, &v) in ts.iter().zip(vs) {
        let dt = t - t0;
        if dt.abs() > half_s {
            continue;
        }
        let basis = Vector3::new(1.0, dt, dt * dt);
        m += basis * basis.transpose();
        b += basis * v;
        sum += v;
        n += 1;
    }
    if n == 0 {
        return f64::NAN;
    }
    if n >= 4 {
        if let Some(c) = m.lu().solve(&b) {
            if c[0].is_finite() {
                return c[0];
            }
        }
    }
    sum / n as f64
}

/// Smooths the marker tracks of one recording's `frames` over `smooth_s` seconds and
/// sets every measured frame's `*_smooth` values (the others keep NaN). Frames whose
/// marker count differs from the recording's first measured frame are left out.
pub fn smooth_recording(frames: &mut [FrameRecord], smooth_s: f64) {
    let idx: Vec<usize> = (0..frames.len())
        .filter(|&i| frames[i].status.is_ok() && frames[i].time_s.is_finite())
        .collect();
    let Some(&first) = idx.first() else {
        return;
    };
    let n = frames[first].markers.len();
    let idx: Vec<usize> = idx
        .into_iter()
        .filter(|&i| frames[i].markers.len() == n)
        .collect();
    let ts: Vec<f64> = idx.iter().map(|&i| frames[i].time_s).collect();
    let depth = frames[first].markers.iter().all(|p| p.z_mm.is_finite());
    let half = 0.5 * smooth_s;
    let track = |k: usize, g: fn(&MarkerPoint) -> f64| -> Vec<f64> {
        idx.iter().map(|&i| g(&frames[i].markers[k])).collect()
    };
    let tracks: Vec<[Vec<f64>; 3]> = (0..n)
        .map(|k| {
            [
                track(k, |p| p.x_mm),
                track(k, |p| p.y_mm),
                track(k, |p| p.z_mm),
            ]
        })
        .collect();
    for (j, &i) in idx.iter().enumerate() {
        let at = |v: &[f64]| local_quadratic(&ts, v, ts[j], half);
        let smooth: Vec<[f64; 3]> = tracks
            .iter()
            .map(|[x, y, z]| [at(x), at(y), if depth { at(z) } else { f64::NAN }])
            .collect();
        let (r, k, a) = fit_smoothed(&smooth, depth);
        let f = &mut frames[i];
        (
            f.radius_mm_smooth,
            f.curvature_per_m_smooth,
            f.bending_angle_deg_smooth,
        ) = (r, k, a);
    }
}

/// A warning when `smooth_s` is longer than the time the measured `frames` of one
/// recording span: the window then holds the whole recording, and the `*_smooth`
/// columns are one blend of every pressure rather than a filtered track.
pub fn smooth_window_warning(frames: &[FrameRecord], smooth_s: f64) -> Option<String> {
    let times = frames
        .iter()
        .filter(|f| f.status.is_ok() && f.time_s.is_finite())
        .map(|f| f.time_s);
    let (lo, hi) = times.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
        (lo.min(t), hi.max(t))
    });
    let span = hi - lo;
    (span.is_finite() && smooth_s > span).then(|| {
        format!(
            "smooth_s = {smooth_s} s is longer than the {span:.2} s the measured frames span: the *_smooth columns blend the whole recording; give a window well below it (e.g. smooth_s = {:.2})",
            span / 10.0
        )
    })
}

/// Radius (mm), curvature (1/m) and bending angle (deg) of smoothed markers: a Pratt
/// circle in the plane, or the 3D circle for RGB-D, as for the raw markers.
fn fit_smoothed(points: &[[f64; 3]], depth: bool) -> (f64, f64, f64) {
    let nan = (f64::NAN, f64::NAN, f64::NAN);
    if depth {
        let pts: Vec<Point3<f64>> = points
            .iter()
            .map(|p| Point3::new(p[0], p[1], p[2]))
            .collect();
        let Ok(c) = fit_circle_3d(&pts) else {
            return nan;
        };
        let flat: Vec<Point2<f64>> = pts.iter().map(|p| c.to_plane(p)).collect();
        let angle = bending_angle_along_markers_deg(&flat, &c.circle).unwrap_or(f64::NAN);
        (c.circle.radius, c.circle.curvature * 1000.0, angle)
    } else {
        let pts: Vec<Point2<f64>> = points.iter().map(|p| Point2::new(p[0], p[1])).collect();
        let Ok(c) = fit_circle_pratt(&pts) else {
            return nan;
        };
        let angle = bending_angle_along_markers_deg(&pts, &c).unwrap_or(f64::NAN);
        (c.radius, c.curvature * 1000.0, angle)
    }
}

#[cfg(test)]
mod tests {
    use super::super::records::FrameStatus;
    use super::*;

    #[test]
    fn a_window_longer_than_the_recording_is_warned() {
        let frames: Vec<FrameRecord> = (0..40)
            .map(|i| FrameRecord::rejected("v", i, i as f64 / 30.0, 0.0, FrameStatus::Ok))
            .collect();
        assert_eq!(smooth_window_warning(&frames, 1.0), None);
        let w = smooth_window_warning(&frames, 1e9).unwrap();
        assert!(
            w.starts_with(
                "smooth_s = 1000000000 s is longer than the 1.30 s the measured frames span"
            ),
            "{w}"
        );
        assert!(w.ends_with("(e.g. smooth_s = 0.13)"), "{w}");
    }

    #[test]
    fn a_quadratic_is_kept_and_noise_averaged() {
        let ts: Vec<f64> = (0..50).map(|i| i as f64 * 0.1).collect();
        let vs: Vec<f64> = ts.iter().map(|t| 3.0 + 2.0 * t - 0.5 * t * t).collect();
        for &t0 in &[0.0, 1.23, 4.9] {
            let v = local_quadratic(&ts, &vs, t0, 0.8);
            assert!(
                (v - (3.0 + 2.0 * t0 - 0.5 * t0 * t0)).abs() < 1e-9,
                "{t0}: {v}"
            );
        }
    }

    /// A noisy ramp: 8 markers on an arc whose curvature rises linearly from 4 to 16 1/m
    /// over 30 s at 30 frames/s, each centroid with 0.08 mm of Gaussian-like scatter
    /// (deterministic). With smooth_s = 1 s the radius scatter about the truth drops
    /// by more than 3 times and its mean error stays below 0.1%.
    #[test]
    fn a_noisy_ramp_is_smoothed_without_bias() {
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut gauss = || {
            // Sum of 12 uniforms minus 6: unit variance.
            (0..12)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    (state >> 11) as f64 / (1u64 << 53) as f64
                })
                .sum::<f64>()
                - 6.0
        };
        let truth_r = |t: f64| 1000.0 / (4.0 + 12.0 * t / 30.0);
        let mut frames: Vec<FrameRecord> = (0..900)
            .map(|i| {
                let t = i as f64 / 30.0;
                let r = truth_r(t);
                let mut f = FrameRecord::rejected("color", i, t, 0.0, FrameStatus::Ok);
                f.markers = (0..8)
                    .map(|k| {
                        let a = (6.0 + 14.0 * k as f64) / r;
                        MarkerPoint {
                            x_px: 0.0,
                            y_px: 0.0,
                            x_mm: r * a.sin() + 0.08 * gauss(),
                            y_mm: r * (1.0 - a.cos()) + 0.08 * gauss(),
                            z_mm: f64::NAN,
                        }
                    })
                    .collect();
                let pts: Vec<Point2<f64>> = f
                    .markers
                    .iter()
                    .map(|p| Point2::new(p.x_mm, p.y_mm))
                    .collect();
                f.radius_mm = fit_circle_pratt(&pts).unwrap().radius;
                f
            })
            .collect();
        smooth_recording(&mut frames, 1.0);
        let stats = |g: fn(&FrameRecord) -> f64| {
            let e: Vec<f64> = frames
                .iter()
                .map(|f| g(f) / truth_r(f.time_s) - 1.0)
                .collect();
            let mean = e.iter().sum::<f64>() / e.len() as f64;
            let std = (e.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / e.len() as f64).sqrt();
            (mean, std)
        };
        let (raw_mean, raw_std) = stats(|f| f.radius_mm);
        let (mean, std) = stats(|f| f.radius_mm_smooth);
        eprintln!(
            "raw: mean {:+.4}% std {:.4}%; smoothed: mean {:+.4}% std {:.4}%",
            100.0 * raw_mean,
            100.0 * raw_std,
            100.0 * mean,
            100.0 * std
        );
        assert!(std < raw_std / 3.0, "scatter {std} vs raw {raw_std}");
        assert!(mean.abs() < 1e-3, "bias {mean}");
        assert!(frames.iter().all(|f| f.curvature_per_m_smooth.is_finite()));
    }
}
