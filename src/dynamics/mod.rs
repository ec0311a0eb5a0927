//! Dynamics of a recording: hysteresis and step response, as pure maths on time series
//! and binned means (the pipeline applies them to a session: `pipeline::dynamics`).
//!
//! ```text
//! pressure history (log samples, or a step session's pressures in manifest order)
//!   branches    turning points where the pressure reverses by more than a threshold:
//!               loading / unloading branches numbered in cycles   [`branches`]
//!   hysteresis  the loop between a cycle's two branches: area by trapezoids over the
//!               common pressure range, largest difference at equal pressure [`hysteresis`]
//!   steps       holds of the log and the steps between them        [`steps`]
//!   response    per step and quantity: 10-90% rise, first-order time constant (least
//!               squares), overshoot, 2% settling, 50% crossing       [`response`]
//! ```

pub mod branches;
pub mod hysteresis;
pub mod response;
pub mod steps;

/// A robust standard deviation of the white noise on a smooth signal sampled at `times`:
/// each sample's residual from the straight line through its two neighbours (for white
/// noise of sd s on evenly spaced samples, sd s sqrt(3/2)), scaled from its median
/// absolute value (1.4826 MAD). A ramp, a hold or a line gives 0; a jump or a turning
/// point moves a few residuals only, which the median ignores.
pub fn noise_sd(times: &[f64], values: &[f64]) -> f64 {
    let n = times.len().min(values.len());
    if n < 3 {
        return 0.0;
    }
    let mut r: Vec<f64> = (1..n - 1)
        .filter_map(|i| {
            let (t0, t1, t2) = (times[i - 1], times[i], times[i + 1]);
            (t2 > t0).then(|| {
                let line = values[i - 1] + (values[i + 1] - values[i - 1]) * (t1 - t0) / (t2 - t0);
                (values[i] - line).abs()
            })
        })
        .filter(|v| v.is_finite())
        .collect();
    if r.is_empty() {
        return 0.0;
    }
    r.sort_by(f64::total_cmp);
    let m = r.len();
    let median = if m % 2 == 1 {
        r[m / 2]
    } else {
        0.5 * (r[m / 2 - 1] + r[m / 2])
    };
    1.4826 * median / 1.5f64.sqrt()
}

/// Linear interpolation of the polyline `(x, y)` (x increasing) at `x0`; `None` outside.
pub(crate) fn interpolate(points: &[(f64, f64)], x0: f64) -> Option<f64> {
    let (first, last) = (points.first()?, points.last()?);
    if !(x0 >= first.0 && x0 <= last.0) {
        return None;
    }
    let i = points
        .partition_point(|p| p.0 <= x0)
        .clamp(1, points.len().max(2) - 1);
    if points.len() == 1 {
        return Some(first.1);
    }
    let (a, b) = (points[i - 1], points[i]);
    Some(if b.0 > a.0 {
        a.1 + (b.1 - a.1) * (x0 - a.0) / (b.0 - a.0)
    } else {
        b.1
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_sd_of_white_noise_on_a_ramp_and_of_clean_signals() {
        // A deterministic pseudo-random normal sequence (Box-Muller on an LCG).
        let mut state = 12345u64;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let t: Vec<f64> = (0..4000).map(|i| i as f64 * 0.01).collect();
        let p: Vec<f64> = t
            .iter()
            .map(|t| {
                let g = (-2.0 * uniform().ln()).sqrt() * (std::f64::consts::TAU * uniform()).cos();
                5.0 + 3.0 * t + 0.2 * g
            })
            .collect();
        let s = noise_sd(&t, &p);
        assert!((s / 0.2 - 1.0).abs() < 0.06, "{s}");
        // A clean ramp up and down and a clean step: no noise.
        let tri: Vec<f64> = t.iter().map(|t| 20.0 - (t - 20.0).abs()).collect();
        assert!(noise_sd(&t, &tri) < 1e-9);
        let step: Vec<f64> = t
            .iter()
            .map(|t| if *t < 3.0 { 20.0 } else { 50.0 })
            .collect();
        assert_eq!(noise_sd(&t, &step), 0.0);
    }

    #[test]
    fn interpolation_inside_and_outside() {
        let pts = [(0.0, 0.0), (1.0, 10.0), (3.0, 30.0)];
        assert_eq!(interpolate(&pts, 0.5), Some(5.0));
        assert_eq!(interpolate(&pts, 2.0), Some(20.0));
        assert_eq!(interpolate(&pts, 3.0), Some(30.0));
        assert_eq!(interpolate(&pts, 3.5), None);
        assert_eq!(interpolate(&[(1.0, 4.0)], 1.0), Some(4.0));
    }
}
