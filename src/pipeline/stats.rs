//! One summary of measured frames, used for a video and for a pressure bin alike: mean
//! (the published method), median (mean of the two middle values for an even count),
//! sample standard deviation, and the frames used and rejected.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::records::FrameRecord;

/// Statistics of a group of frames.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameStats {
    /// Mean radius over the measured frames, mm.
    pub radius_mm: f64,
    /// Median radius, mm.
    pub radius_mm_median: f64,
    /// Sample standard deviation of the radius, mm (0 for one frame).
    pub radius_mm_std: f64,
    /// Mean curvature, 1/m.
    pub curvature_per_m: f64,
    /// Mean bending angle, degrees.
    pub bending_angle_deg: f64,
    /// Mean fit RMS (px, or mm for RGB-D).
    pub fit_rms: f64,
    /// Frames measured.
    pub frames_used: usize,
    /// Frames rejected.
    pub frames_rejected: usize,
}

impl FrameStats {
    /// No frame measured, `rejected` rejected.
    pub fn empty(rejected: usize) -> Self {
        Self {
            radius_mm: f64::NAN,
            radius_mm_median: f64::NAN,
            radius_mm_std: f64::NAN,
            curvature_per_m: f64::NAN,
            bending_angle_deg: f64::NAN,
            fit_rms: f64::NAN,
            frames_used: 0,
            frames_rejected: rejected,
        }
    }
}

/// Mean of a non-empty slice.
fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Median: the middle value, or the mean of the two middle values.
pub fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => v[n / 2],
        _ => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Summarizes `frames`: the measured ones give the statistics, the others are counted
/// as rejected.
pub fn summarize<'a>(frames: impl IntoIterator<Item = &'a FrameRecord>) -> FrameStats {
    let (mut used, mut rejected) = (Vec::new(), 0usize);
    for f in frames {
        if f.status.is_ok() {
            used.push(f);
        } else {
            rejected += 1;
        }
    }
    if used.is_empty() {
        return FrameStats::empty(rejected);
    }
    let n = used.len();
    let col = |g: fn(&FrameRecord) -> f64| -> Vec<f64> { used.iter().map(|f| g(f)).collect() };
    let r = col(|f| f.radius_mm);
    let radius_mm = mean(&r);
    let radius_mm_std = if n > 1 && radius_mm.is_finite() {
        (r.iter().map(|v| (v - radius_mm).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
    } else {
        0.0
    };
    FrameStats {
        radius_mm,
        radius_mm_median: median(&r),
        radius_mm_std,
        curvature_per_m: mean(&col(|f| f.curvature_per_m)),
        bending_angle_deg: mean(&col(|f| f.bending_angle_deg)),
        fit_rms: mean(&col(|f| f.fit_rms)),
        frames_used: n,
        frames_rejected: rejected,
    }
}

/// Ramp protocol: the measured frames grouped in pressure bins of `bin_kpa` (bin k holds
/// [k bin, (k+1) bin)), each with its mean pressure (kPa) and statistics, in pressure
/// order. Rejected frames and frames without a pressure are left out.
pub fn bin_by_pressure(frames: &[FrameRecord], bin_kpa: f64) -> Vec<(f64, FrameStats)> {
    let mut bins: BTreeMap<i64, Vec<&FrameRecord>> = BTreeMap::new();
    for f in frames
        .iter()
        .filter(|f| f.status.is_ok() && f.pressure_kpa.is_finite())
    {
        bins.entry((f.pressure_kpa / bin_kpa).floor() as i64)
            .or_default()
            .push(f);
    }
    bins.into_values()
        .map(|b| {
            let p = b.iter().map(|f| f.pressure_kpa).sum::<f64>() / b.len() as f64;
            (p, summarize(b))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::records::FrameStatus;
    use super::*;

    fn frame(p: f64, r: f64, ok: bool) -> FrameRecord {
        let mut f = FrameRecord::rejected(
            "v",
            0,
            0.0,
            p,
            if ok {
                FrameStatus::Ok
            } else {
                FrameStatus::OutsidePressureLog
            },
        );
        if ok {
            f.radius_mm = r;
            f.curvature_per_m = 1000.0 / r;
            f.bending_angle_deg = 10.0;
            f.fit_rms = 0.1;
        }
        f
    }

    #[test]
    fn median_of_even_count_is_the_mean_of_the_middle_two() {
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert!(median(&[]).is_nan());
    }

    #[test]
    fn summary_counts_and_spreads() {
        let f = [
            frame(1.0, 10.0, true),
            frame(1.0, 12.0, true),
            frame(1.0, 0.0, false),
        ];
        let s = summarize(&f);
        assert_eq!((s.frames_used, s.frames_rejected), (2, 1));
        assert_eq!(s.radius_mm, 11.0);
        assert_eq!(s.radius_mm_median, 11.0);
        assert!((s.radius_mm_std - 2f64.sqrt()).abs() < 1e-12);
        let none = summarize(&f[2..]);
        assert_eq!((none.frames_used, none.frames_rejected), (0, 1));
        assert!(none.radius_mm.is_nan());
    }

    #[test]
    fn bins_use_the_same_statistics() {
        let f = [
            frame(0.2, 10.0, true),
            frame(0.7, 14.0, true),
            frame(1.1, 20.0, true),
            frame(1.9, 22.0, true),
            frame(f64::NAN, 1.0, true),
            frame(1.5, 0.0, false),
        ];
        let b = bin_by_pressure(&f, 1.0);
        assert_eq!(b.len(), 2);
        assert!((b[0].0 - 0.45).abs() < 1e-12);
        assert_eq!(b[0].1.radius_mm_median, 12.0);
        assert_eq!(b[1].1.radius_mm, 21.0);
        assert_eq!(b[1].1, summarize(&f[2..4]));
    }
}
