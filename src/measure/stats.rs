//! One summary of measured frames, used for a video and for a pressure bin alike: mean
//! (the published method), median (mean of the two middle values for an even count),
//! sample standard deviation, and the frames used and rejected.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::records::FrameRecord;

/// Statistics of a group of frames (equal when every value is, NaN matching NaN: a
/// statistic that cannot be taken is the same missing value).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FrameStats {
    /// Mean radius over the measured frames, mm.
    pub radius_mm: f64,
    /// Median radius, mm.
    pub radius_mm_median: f64,
    /// Sample standard deviation of the radius, mm (0 for one frame).
    pub radius_mm_std: f64,
    /// Mean curvature, 1/m.
    pub curvature_per_m: f64,
    /// Sample standard deviation of the curvature, 1/m.
    pub curvature_per_m_std: f64,
    /// Mean bending angle, degrees.
    pub bending_angle_deg: f64,
    /// Sample standard deviation of the bending angle, degrees.
    pub bending_angle_deg_std: f64,
    /// Mean fit RMS (px, or mm for RGB-D).
    pub fit_rms: f64,
    /// Mean tip x in the session's axes of markers.csv, mm.
    pub tip_x_mm: f64,
    /// Sample standard deviation of the tip x, mm.
    pub tip_x_mm_std: f64,
    /// Mean tip y, mm.
    pub tip_y_mm: f64,
    /// Sample standard deviation of the tip y, mm.
    pub tip_y_mm_std: f64,
    /// Mean tip angle, degrees.
    pub tip_angle_deg: f64,
    /// Sample standard deviation of the tip angle, degrees.
    pub tip_angle_deg_std: f64,
    /// Segmented actuators: each segment's statistics (empty without segments).
    #[serde(default)]
    pub segments: Vec<crate::segments::SegmentStats>,
    /// Frames measured.
    pub frames_used: usize,
    /// Frames rejected.
    pub frames_rejected: usize,
}

impl PartialEq for FrameStats {
    fn eq(&self, o: &Self) -> bool {
        let same = |a: f64, b: f64| a == b || (a.is_nan() && b.is_nan());
        [
            (self.radius_mm, o.radius_mm),
            (self.radius_mm_median, o.radius_mm_median),
            (self.radius_mm_std, o.radius_mm_std),
            (self.curvature_per_m, o.curvature_per_m),
            (self.curvature_per_m_std, o.curvature_per_m_std),
            (self.bending_angle_deg, o.bending_angle_deg),
            (self.bending_angle_deg_std, o.bending_angle_deg_std),
            (self.fit_rms, o.fit_rms),
            (self.tip_x_mm, o.tip_x_mm),
            (self.tip_x_mm_std, o.tip_x_mm_std),
            (self.tip_y_mm, o.tip_y_mm),
            (self.tip_y_mm_std, o.tip_y_mm_std),
            (self.tip_angle_deg, o.tip_angle_deg),
            (self.tip_angle_deg_std, o.tip_angle_deg_std),
        ]
        .iter()
        .all(|&(a, b)| same(a, b))
            && self.segments == o.segments
            && self.frames_used == o.frames_used
            && self.frames_rejected == o.frames_rejected
    }
}

impl FrameStats {
    /// No frame measured, `rejected` rejected.
    pub fn empty(rejected: usize) -> Self {
        Self {
            radius_mm: f64::NAN,
            radius_mm_median: f64::NAN,
            radius_mm_std: f64::NAN,
            curvature_per_m: f64::NAN,
            curvature_per_m_std: f64::NAN,
            bending_angle_deg: f64::NAN,
            bending_angle_deg_std: f64::NAN,
            fit_rms: f64::NAN,
            tip_x_mm: f64::NAN,
            tip_x_mm_std: f64::NAN,
            tip_y_mm: f64::NAN,
            tip_y_mm_std: f64::NAN,
            tip_angle_deg: f64::NAN,
            tip_angle_deg_std: f64::NAN,
            segments: vec![],
            frames_used: 0,
            frames_rejected: rejected,
        }
    }
}

/// Mean of a non-empty slice.
fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Sample standard deviation (0 for one value; NaN when the mean is not finite).
fn sample_std(v: &[f64], mean: f64) -> f64 {
    if v.len() > 1 && mean.is_finite() {
        (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
    } else if mean.is_finite() {
        0.0
    } else {
        f64::NAN
    }
}

/// Mean and sample standard deviation.
fn mean_std(v: &[f64]) -> (f64, f64) {
    let m = mean(v);
    (m, sample_std(v, m))
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
    let (curvature_per_m, curvature_per_m_std) = mean_std(&col(|f| f.curvature_per_m));
    let (bending_angle_deg, bending_angle_deg_std) = mean_std(&col(|f| f.bending_angle_deg));
    let (tip_x_mm, tip_x_mm_std) = mean_std(&col(|f| f.tip_x_mm));
    let (tip_y_mm, tip_y_mm_std) = mean_std(&col(|f| f.tip_y_mm));
    let (tip_angle_deg, tip_angle_deg_std) = mean_std(&col(|f| f.tip_angle_deg));
    FrameStats {
        radius_mm,
        radius_mm_median: median(&r),
        radius_mm_std,
        curvature_per_m,
        curvature_per_m_std,
        bending_angle_deg,
        bending_angle_deg_std,
        fit_rms: mean(&col(|f| f.fit_rms)),
        tip_x_mm,
        tip_x_mm_std,
        tip_y_mm,
        tip_y_mm_std,
        tip_angle_deg,
        tip_angle_deg_std,
        segments: {
            let fits: Vec<&[crate::segments::SegmentFit]> =
                used.iter().map(|f| f.segments.as_slice()).collect();
            let n_segments = used.iter().map(|f| f.segments.len()).max().unwrap_or(0);
            crate::segments::summarize_segments(&fits, n_segments)
        },
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
        // Curvatures 100 and 1000/12 1/m: std |100 - 83.33| / sqrt 2; equal angles: 0.
        let k_std = (100.0 - 1000.0 / 12.0) / 2f64.sqrt();
        assert!((s.curvature_per_m_std - k_std).abs() < 1e-12);
        assert_eq!(s.bending_angle_deg_std, 0.0);
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
