//! Figures of merit of a closed-loop run, on the true (noise-free) bending angle.

use serde::Serialize;

/// Band of the settling time, share of the step (2%).
pub const SETTLING_BAND: f64 = 0.02;

/// Share of the run at its end over which the steady-state error is averaged.
pub const STEADY_STATE_SHARE: f64 = 0.1;

/// Tracking figures of any run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrackingMetrics {
    /// Integral of |reference − angle| over the run, deg s.
    pub iae_deg_s: f64,
    /// RMS of reference − angle, degrees.
    pub rmse_deg: f64,
    /// Largest |reference − angle|, degrees.
    pub max_abs_error_deg: f64,
}

/// Figures of a step response (from the resting angle y0 to the target r).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StepMetrics {
    /// Resting angle before the step, degrees.
    pub initial_deg: f64,
    /// Target, degrees.
    pub target_deg: f64,
    /// Time from 10% to 90% of the step, s (None: never reached 90%).
    pub rise_time_s: Option<f64>,
    /// Largest excursion beyond the target, % of the step (0 when none).
    pub overshoot_pct: f64,
    /// Time after which the angle stays within 2% of the step around the target, s
    /// (None: not settled by the end).
    pub settling_time_s: Option<f64>,
    /// Mean of target − angle over the last tenth of the run, degrees.
    pub steady_state_error_deg: f64,
}

/// [`TrackingMetrics`] gathered one sample at a time (a run too long to keep).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackingAccumulator {
    sample_s: f64,
    samples: usize,
    sum_abs_deg: f64,
    sum_sq_deg2: f64,
    max_abs_deg: f64,
}

impl TrackingAccumulator {
    /// Nothing seen yet; samples `sample_s` apart.
    pub fn new(sample_s: f64) -> Self {
        Self {
            sample_s,
            samples: 0,
            sum_abs_deg: 0.0,
            sum_sq_deg2: 0.0,
            max_abs_deg: 0.0,
        }
    }

    /// Adds one sample.
    pub fn push(&mut self, reference_deg: f64, angle_deg: f64) {
        let e = reference_deg - angle_deg;
        self.samples += 1;
        self.sum_abs_deg += e.abs();
        self.sum_sq_deg2 += e * e;
        self.max_abs_deg = self.max_abs_deg.max(e.abs());
    }

    /// The figures of the samples seen.
    pub fn finish(&self) -> TrackingMetrics {
        TrackingMetrics {
            iae_deg_s: self.sum_abs_deg * self.sample_s,
            rmse_deg: (self.sum_sq_deg2 / self.samples.max(1) as f64).sqrt(),
            max_abs_error_deg: self.max_abs_deg,
        }
    }
}

/// Tracking metrics of `reference` vs `angle` sampled every `sample_s`.
pub fn tracking_metrics(
    reference_deg: &[f64],
    angle_deg: &[f64],
    sample_s: f64,
) -> TrackingMetrics {
    let mut acc = TrackingAccumulator::new(sample_s);
    for (r, y) in reference_deg.iter().zip(angle_deg) {
        acc.push(*r, *y);
    }
    acc.finish()
}

/// [`StepMetrics`] gathered one sample at a time, for a run of a known number of
/// samples (the steady-state error averages its last tenth); the step is at the first
/// sample's time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepAccumulator {
    initial_deg: f64,
    target_deg: f64,
    /// Index of the first sample of the steady-state tail.
    tail_start: usize,
    tail_len: usize,
    seen: usize,
    first_time_s: f64,
    /// The previous sample: time and progress along the step.
    previous: Option<(f64, f64)>,
    cross_10: Option<f64>,
    cross_90: Option<f64>,
    peak_progress: f64,
    /// The last sample was outside the settling band.
    outside: bool,
    /// Time of the first sample after the latest one outside the band.
    settled_from_s: Option<f64>,
    tail_sum_deg: f64,
}

impl StepAccumulator {
    /// A step from `initial_deg` to `target_deg` seen over `samples` samples.
    pub fn new(initial_deg: f64, target_deg: f64, samples: usize) -> Self {
        let tail_len = ((samples as f64 * STEADY_STATE_SHARE).ceil() as usize).max(1);
        Self {
            initial_deg,
            target_deg,
            tail_start: samples.saturating_sub(tail_len),
            tail_len: tail_len.min(samples).max(1),
            seen: 0,
            first_time_s: 0.0,
            previous: None,
            cross_10: None,
            cross_90: None,
            peak_progress: f64::NEG_INFINITY,
            outside: false,
            settled_from_s: None,
            tail_sum_deg: 0.0,
        }
    }

    /// Progress along the step: 0 at rest, 1 at the target.
    fn progress(&self, angle_deg: f64) -> f64 {
        let span = self.target_deg - self.initial_deg;
        let sign = if span >= 0.0 { 1.0 } else { -1.0 };
        sign * (angle_deg - self.initial_deg) / span.abs().max(1e-12)
    }

    /// Adds the sample at `time_s`.
    pub fn push(&mut self, time_s: f64, angle_deg: f64) {
        let prog = self.progress(angle_deg);
        if self.seen == 0 {
            self.first_time_s = time_s;
        }
        let previous = self.previous;
        let cross = |level: f64| match previous {
            _ if prog < level => None,
            None => Some(time_s),
            Some((t0, a)) => Some(t0 + (level - a) / (prog - a) * (time_s - t0)),
        };
        if self.cross_10.is_none() {
            self.cross_10 = cross(0.1);
        }
        if self.cross_90.is_none() {
            self.cross_90 = cross(0.9);
        }
        self.peak_progress = self.peak_progress.max(prog);
        if self.outside {
            self.settled_from_s = Some(time_s);
        }
        let band = SETTLING_BAND * (self.target_deg - self.initial_deg).abs().max(1e-12);
        self.outside = (angle_deg - self.target_deg).abs() > band;
        if self.seen >= self.tail_start {
            self.tail_sum_deg += self.target_deg - angle_deg;
        }
        self.previous = Some((time_s, prog));
        self.seen += 1;
    }

    /// The figures of the samples seen.
    pub fn finish(&self) -> StepMetrics {
        let rise_time_s = match (self.cross_10, self.cross_90) {
            (Some(a), Some(b)) => Some(b - a),
            _ => None,
        };
        let settling_time_s = if self.outside {
            None
        } else {
            Some(self.settled_from_s.unwrap_or(self.first_time_s))
        };
        StepMetrics {
            initial_deg: self.initial_deg,
            target_deg: self.target_deg,
            rise_time_s,
            overshoot_pct: (100.0 * (self.peak_progress - 1.0)).max(0.0),
            settling_time_s,
            steady_state_error_deg: self.tail_sum_deg / self.tail_len as f64,
        }
    }
}

/// Step metrics of `angle` (sampled at `time_s`, the step at t = 0) from `initial_deg`
/// to `target_deg`.
pub fn step_metrics(
    time_s: &[f64],
    angle_deg: &[f64],
    initial_deg: f64,
    target_deg: f64,
) -> StepMetrics {
    let mut acc = StepAccumulator::new(initial_deg, target_deg, angle_deg.len());
    for (t, y) in time_s.iter().zip(angle_deg) {
        acc.push(*t, *y);
    }
    acc.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_order_step_has_its_textbook_figures() {
        // y = 90 (1 - e^{-t/τ}), τ = 0.5: rise 10-90% = τ ln 9, no overshoot, 2% settling
        // at τ ln 50.
        let tau = 0.5;
        let t: Vec<f64> = (0..=5000).map(|k| k as f64 * 1e-3).collect();
        let y: Vec<f64> = t.iter().map(|t| 90.0 * (1.0 - (-t / tau).exp())).collect();
        let m = step_metrics(&t, &y, 0.0, 90.0);
        assert!(
            (m.rise_time_s.unwrap() - tau * 9f64.ln()).abs() < 1e-4,
            "{m:?}"
        );
        assert_eq!(m.overshoot_pct, 0.0);
        assert!(
            (m.settling_time_s.unwrap() - tau * 50f64.ln()).abs() < 2e-3,
            "{m:?}"
        );
        assert!(m.steady_state_error_deg.abs() < 0.01);
        let r = vec![90.0; t.len()];
        let tr = tracking_metrics(&r, &y, 1e-3);
        // IAE = 90 τ (1 - e^{-10}).
        assert!((tr.iae_deg_s - 45.0).abs() < 0.05, "{tr:?}");
        assert!((tr.max_abs_error_deg - 90.0).abs() < 1e-9);
    }

    #[test]
    fn overshoot_is_a_share_of_the_step() {
        let t = [0.0, 1.0, 2.0, 3.0];
        let y = [10.0, 60.0, 55.0, 50.0];
        let m = step_metrics(&t, &y, 10.0, 50.0);
        assert!((m.overshoot_pct - 25.0).abs() < 1e-12);
    }
}
