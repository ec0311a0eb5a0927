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

/// Tracking metrics of `reference` vs `angle` sampled every `sample_s`.
pub fn tracking_metrics(
    reference_deg: &[f64],
    angle_deg: &[f64],
    sample_s: f64,
) -> TrackingMetrics {
    let e: Vec<f64> = reference_deg
        .iter()
        .zip(angle_deg)
        .map(|(r, y)| r - y)
        .collect();
    let n = e.len().max(1) as f64;
    TrackingMetrics {
        iae_deg_s: e.iter().map(|v| v.abs()).sum::<f64>() * sample_s,
        rmse_deg: (e.iter().map(|v| v * v).sum::<f64>() / n).sqrt(),
        max_abs_error_deg: e.iter().fold(0.0, |m, v| m.max(v.abs())),
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
    let span = target_deg - initial_deg;
    let sign = if span >= 0.0 { 1.0 } else { -1.0 };
    let mag = span.abs().max(1e-12);
    // Progress along the step, 0 at rest, 1 at the target.
    let prog = |y: f64| sign * (y - initial_deg) / mag;
    let cross = |level: f64| -> Option<f64> {
        (0..angle_deg.len())
            .find(|k| prog(angle_deg[*k]) >= level)
            .map(|k| {
                if k == 0 {
                    return time_s[0];
                }
                let (a, b) = (prog(angle_deg[k - 1]), prog(angle_deg[k]));
                time_s[k - 1] + (level - a) / (b - a) * (time_s[k] - time_s[k - 1])
            })
    };
    let rise_time_s = match (cross(0.1), cross(0.9)) {
        (Some(a), Some(b)) => Some(b - a),
        _ => None,
    };
    let peak = angle_deg
        .iter()
        .map(|y| prog(*y))
        .fold(f64::NEG_INFINITY, f64::max);
    let overshoot_pct = (100.0 * (peak - 1.0)).max(0.0);
    let band = SETTLING_BAND * mag;
    let last_out = angle_deg
        .iter()
        .rposition(|y| (y - target_deg).abs() > band);
    let settling_time_s = match last_out {
        None => Some(time_s.first().copied().unwrap_or(0.0)),
        Some(k) if k + 1 < angle_deg.len() => Some(time_s[k + 1]),
        Some(_) => None,
    };
    let tail = ((angle_deg.len() as f64 * STEADY_STATE_SHARE).ceil() as usize).max(1);
    let tail = &angle_deg[angle_deg.len().saturating_sub(tail)..];
    let steady_state_error_deg =
        tail.iter().map(|y| target_deg - y).sum::<f64>() / tail.len().max(1) as f64;
    StepMetrics {
        initial_deg,
        target_deg,
        rise_time_s,
        overshoot_pct,
        settling_time_s,
        steady_state_error_deg,
    }
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
