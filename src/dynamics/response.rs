//! A quantity's response to a pressure step, from its time series: 10-90% rise time,
//! the time constant of a first-order response fitted by least squares, overshoot,
//! settling time (2% band) and the 50% crossing (for delays between quantities).

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{storage::Owned, Dyn, OMatrix, OVector, Vector4, U4};
use serde::Serialize;

/// The settling band: within this share of the step of the final value.
pub const SETTLING_BAND: f64 = 0.02;

/// The final value is the median of the samples in this last share of the window after
/// the onset.
pub const FINAL_SHARE: f64 = 0.25;

/// Samples needed before the onset (the initial value is their median).
pub const MIN_SAMPLES_BEFORE: usize = 2;

/// Samples needed after the onset (a first-order fit has 4 parameters; the final value
/// needs samples of its own).
pub const MIN_SAMPLES_AFTER: usize = 8;

/// y(t) = y0 for t < t0, y0 + dy (1 - exp(-(t - t0) / tau)) after: a first-order
/// response with a dead time to a step at t0.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FirstOrderFit {
    /// Value before the step.
    pub y0: f64,
    /// Change to the final value.
    pub dy: f64,
    /// When the response begins, s.
    pub t0_s: f64,
    /// Time constant, s.
    pub tau_s: f64,
    /// RMS residual of the fit, units of y.
    pub rms: f64,
    /// Samples fitted.
    pub n: usize,
}

impl FirstOrderFit {
    /// The fitted response at time `t`.
    pub fn eval(&self, t: f64) -> f64 {
        if t < self.t0_s {
            self.y0
        } else {
            self.y0 + self.dy * (1.0 - (-(t - self.t0_s) / self.tau_s).exp())
        }
    }
}

/// The fit's parameters: y0, dy, t0, ln tau (tau stays positive).
struct FirstOrder<'a> {
    t: &'a [f64],
    y: &'a [f64],
    p: Vector4<f64>,
}

impl FirstOrder<'_> {
    fn model(p: &Vector4<f64>, t: f64) -> f64 {
        let tau = p[3].exp();
        if t < p[2] {
            p[0]
        } else {
            p[0] + p[1] * (1.0 - (-(t - p[2]) / tau).exp())
        }
    }
    fn sse(&self, p: &Vector4<f64>) -> f64 {
        self.t
            .iter()
            .zip(self.y)
            .map(|(t, y)| (Self::model(p, *t) - y).powi(2))
            .sum()
    }
}

impl LeastSquaresProblem<f64, Dyn, U4> for FirstOrder<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, U4>;
    type ParameterStorage = Owned<f64, U4>;

    fn set_params(&mut self, p: &Vector4<f64>) {
        self.p = *p;
    }
    fn params(&self) -> Vector4<f64> {
        self.p
    }
    fn residuals(&self) -> Option<OVector<f64, Dyn>> {
        Some(OVector::<f64, Dyn>::from_iterator(
            self.t.len(),
            self.t
                .iter()
                .zip(self.y)
                .map(|(t, y)| Self::model(&self.p, *t) - y),
        ))
    }
    fn jacobian(&self) -> Option<OMatrix<f64, Dyn, U4>> {
        let (dy, t0, tau) = (self.p[1], self.p[2], self.p[3].exp());
        let mut j = OMatrix::<f64, Dyn, U4>::zeros(self.t.len());
        for (i, &t) in self.t.iter().enumerate() {
            j[(i, 0)] = 1.0;
            if t >= t0 {
                let e = (-(t - t0) / tau).exp();
                j[(i, 1)] = 1.0 - e;
                j[(i, 2)] = -dy * e / tau;
                // d/d(ln tau) = tau d/d(tau).
                j[(i, 3)] = -dy * (t - t0) * e / tau;
            }
        }
        Some(j)
    }
}

/// Least-squares fit of [`FirstOrderFit`]'s response to the samples `(t, y)`
/// (Levenberg-Marquardt from `start`; the start is kept when the fit does not improve
/// on it). `None` with fewer than 5 finite samples or a start with tau <= 0.
pub fn fit_first_order(t: &[f64], y: &[f64], start: &FirstOrderFit) -> Option<FirstOrderFit> {
    let (t, y): (Vec<f64>, Vec<f64>) = t
        .iter()
        .zip(y)
        .filter(|(t, y)| t.is_finite() && y.is_finite())
        .map(|(t, y)| (*t, *y))
        .unzip();
    if t.len() < 5 || start.tau_s.is_nan() || start.tau_s <= 0.0 {
        return None;
    }
    let p0 = Vector4::new(start.y0, start.dy, start.t0_s, start.tau_s.ln());
    let problem = FirstOrder {
        t: &t,
        y: &y,
        p: p0,
    };
    let sse0 = problem.sse(&p0);
    let (solved, _report) = LevenbergMarquardt::new().minimize(problem);
    let sse1 = solved.sse(&solved.p);
    let (p, sse) = if sse1.is_finite() && sse1 <= sse0 && solved.p.iter().all(|v| v.is_finite()) {
        (solved.p, sse1)
    } else {
        (p0, sse0)
    };
    Some(FirstOrderFit {
        y0: p[0],
        dy: p[1],
        t0_s: p[2],
        tau_s: p[3].exp(),
        rms: (sse / t.len() as f64).sqrt(),
        n: t.len(),
    })
}

/// A quantity's response to one step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StepResponse {
    /// Value before the step: median of the samples before the onset.
    pub initial: f64,
    /// Final value: median of the samples in the window's last [`FINAL_SHARE`].
    pub final_value: f64,
    /// First 10% crossing, s (linear between samples).
    pub t10_s: f64,
    /// First 50% crossing, s.
    pub t50_s: f64,
    /// First 90% crossing, s.
    pub t90_s: f64,
    /// t90 - t10, s.
    pub rise_time_s: f64,
    /// Largest excursion beyond the final value, % of the step (0 without one).
    pub overshoot_pct: f64,
    /// From the onset until the samples stay within [`SETTLING_BAND`] of the step around
    /// the final value, s (the band's crossing, linear between samples); NaN when the
    /// last sample is still outside.
    pub settling_time_s: f64,
    /// The first-order response fitted to the window's samples (`None` when it failed).
    pub fit: Option<FirstOrderFit>,
    /// Samples before the onset.
    pub samples_before: usize,
    /// Samples from the onset on.
    pub samples_after: usize,
}

/// Why a response could not be measured.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ResponseError {
    /// Too few samples around the step.
    #[error("{before} sample(s) before the step and {after} after it; {MIN_SAMPLES_BEFORE} and {MIN_SAMPLES_AFTER} needed")]
    TooFewSamples {
        /// Samples before the onset.
        before: usize,
        /// Samples after it.
        after: usize,
    },
    /// The final value equals the initial one.
    #[error("the value does not change across the step")]
    NoChange,
}

/// The first time a sample reaches `level` going the way of `sign`, linear from the
/// sample before it (`samples` in time order; the first one is not a crossing).
fn crossing(samples: &[(f64, f64)], level: f64, sign: f64) -> f64 {
    for w in samples.windows(2) {
        let ((t0, y0), (t1, y1)) = (w[0], w[1]);
        if sign * (y1 - level) >= 0.0 {
            return if sign * (y0 - level) >= 0.0 || y1 == y0 {
                t1
            } else {
                t0 + (t1 - t0) * (level - y0) / (y1 - y0)
            };
        }
    }
    f64::NAN
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The response of the samples `(t, y)` (time order; non-finite ones skipped, those
/// after `end_s` too) to a step at `onset_s`: the samples before the onset give the
/// initial value, the last [`FINAL_SHARE`] of the window after it the final value.
pub fn step_response(
    t: &[f64],
    y: &[f64],
    onset_s: f64,
    end_s: f64,
) -> Result<StepResponse, ResponseError> {
    let samples: Vec<(f64, f64)> = t
        .iter()
        .zip(y)
        .filter(|(t, y)| t.is_finite() && y.is_finite() && **t <= end_s)
        .map(|(t, y)| (*t, *y))
        .collect();
    let split = samples.partition_point(|s| s.0 < onset_s);
    let (before, after) = samples.split_at(split);
    if before.len() < MIN_SAMPLES_BEFORE || after.len() < MIN_SAMPLES_AFTER {
        return Err(ResponseError::TooFewSamples {
            before: before.len(),
            after: after.len(),
        });
    }
    let initial = median(before.iter().map(|s| s.1).collect());
    let last = after[after.len() - 1].0;
    let tail_from = onset_s + (1.0 - FINAL_SHARE) * (last - onset_s);
    let final_value = median(
        after
            .iter()
            .filter(|s| s.0 >= tail_from)
            .map(|s| s.1)
            .collect(),
    );
    let dy = final_value - initial;
    if dy.is_nan() || dy == 0.0 {
        return Err(ResponseError::NoChange);
    }
    let sign = dy.signum();
    // From the last sample before the onset, so a crossing right after it interpolates.
    let from_last_before = &samples[split - 1..];
    let at = |share: f64| crossing(from_last_before, initial + share * dy, sign);
    let (t10, t50, t90) = (at(0.1), at(0.5), at(0.9));
    let peak = after
        .iter()
        .map(|s| sign * (s.1 - final_value))
        .fold(f64::NEG_INFINITY, f64::max);
    let band = SETTLING_BAND * dy.abs();
    let settling_time_s = match after.iter().rposition(|s| (s.1 - final_value).abs() > band) {
        None => 0.0,
        Some(k) if k + 1 == after.len() => f64::NAN,
        Some(k) => {
            let ((t0, y0), (t1, y1)) = (after[k], after[k + 1]);
            let edge = final_value + (y0 - final_value).signum() * band;
            let t = if y1 == y0 {
                t1
            } else {
                t0 + (t1 - t0) * ((edge - y0) / (y1 - y0)).clamp(0.0, 1.0)
            };
            t - onset_s
        }
    };
    let tau0 = if t90 > t10 {
        (t90 - t10) / 9f64.ln()
    } else {
        ((last - onset_s) / 5.0).max(1e-6)
    };
    let t00 = if t10.is_finite() {
        t10 - tau0 * (10.0f64 / 9.0).ln()
    } else {
        onset_s
    };
    let (ts, ys): (Vec<f64>, Vec<f64>) = samples.iter().copied().unzip();
    let fit = fit_first_order(
        &ts,
        &ys,
        &FirstOrderFit {
            y0: initial,
            dy,
            t0_s: t00,
            tau_s: tau0,
            rms: f64::NAN,
            n: 0,
        },
    );
    Ok(StepResponse {
        initial,
        final_value,
        t10_s: t10,
        t50_s: t50,
        t90_s: t90,
        rise_time_s: t90 - t10,
        overshoot_pct: 100.0 * peak.max(0.0) / dy.abs(),
        settling_time_s,
        fit,
        samples_before: before.len(),
        samples_after: after.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Samples at `fps` on 0..`end` s of `y(t)`.
    fn sampled(fps: f64, end: f64, y: impl Fn(f64) -> f64) -> (Vec<f64>, Vec<f64>) {
        let n = (end * fps).round() as usize + 1;
        let t: Vec<f64> = (0..n).map(|i| i as f64 / fps).collect();
        let v = t.iter().map(|t| y(*t)).collect();
        (t, v)
    }

    /// A first-order response of tau 0.2 s starting at t0 = 0.51 s, 30 fps: the fit
    /// recovers tau and t0, the rise time is tau ln 9, the 50% crossing t0 + tau ln 2,
    /// settling t0 + tau ln 50 from the onset, no overshoot (falling steps too).
    #[test]
    fn first_order_response_metrics_are_analytic() {
        let (t0, tau) = (0.51, 0.2);
        for (y0, dy) in [(10.0, 30.0), (80.0, -25.0)] {
            let y = |t: f64| {
                if t < t0 {
                    y0
                } else {
                    y0 + dy * (1.0 - (-(t - t0) / tau).exp())
                }
            };
            let (t, v) = sampled(30.0, 3.0, y);
            let r = step_response(&t, &v, 0.5, 3.0).unwrap();
            let f = r.fit.unwrap();
            assert!(
                (f.tau_s - tau).abs() < 1e-6 && (f.t0_s - t0).abs() < 1e-6,
                "{f:?}"
            );
            assert!(f.rms < 1e-6 && (f.dy - dy).abs() < 1e-6, "{f:?}");
            // The final value is within 2e-4 of y0 + dy after 10 tau or more.
            assert!((r.final_value - (y0 + dy)).abs() < 1e-3 * dy.abs(), "{r:?}");
            // Crossings are linear between frames 1/30 s apart: 1.2 ms of curvature error.
            let frame = 1.0 / 30.0;
            assert!(
                (r.rise_time_s - tau * 9f64.ln()).abs() < 0.05 * frame,
                "{r:?}"
            );
            assert!(
                (r.t50_s - (t0 + tau * 2f64.ln())).abs() < 0.05 * frame,
                "{r:?}"
            );
            assert!(
                (r.settling_time_s - (t0 - 0.5 + tau * 50f64.ln())).abs() < 0.05 * frame,
                "{r:?}"
            );
            // No overshoot: the later samples pass the tail's median (exp(-10.9), 2e-5
            // of the step short of the asymptote) by that much only.
            assert!(r.overshoot_pct < 2e-3, "{r:?}");
        }
    }

    /// An underdamped second-order response (zeta 0.3, omega_n 20 rad/s): overshoot
    /// exp(-pi zeta / sqrt(1 - zeta^2)) = 37.2%, 2% settling about 4 / (zeta omega_n).
    #[test]
    fn second_order_overshoot_and_settling() {
        let (zeta, wn, t0) = (0.3f64, 20.0f64, 0.5);
        let wd = wn * (1.0 - zeta * zeta).sqrt();
        let phi = (1.0 - zeta * zeta).sqrt().atan2(zeta);
        let y = |t: f64| {
            if t < t0 {
                0.0
            } else {
                let s = t - t0;
                40.0 * (1.0
                    - (-zeta * wn * s).exp() * (wd * s + phi).sin() / (1.0 - zeta * zeta).sqrt())
            }
        };
        let (t, v) = sampled(1000.0, 3.0, y);
        let r = step_response(&t, &v, t0, 3.0).unwrap();
        let os = 100.0 * (-std::f64::consts::PI * zeta / (1.0 - zeta * zeta).sqrt()).exp();
        assert!(
            (r.overshoot_pct - os).abs() < 0.05,
            "{} vs {os}",
            r.overshoot_pct
        );
        // The exact 2% settling time: the last time |y - 40| crosses 0.8, found on a
        // fine grid.
        let exact = (0..300_000)
            .map(|i| i as f64 * 1e-5)
            .filter(|s| (y(t0 + s) - 40.0).abs() > 0.8)
            .fold(0.0, f64::max);
        assert!(
            (r.settling_time_s - exact).abs() < 2e-3,
            "{} vs {exact}",
            r.settling_time_s
        );
        assert!(r.rise_time_s > 0.0 && r.rise_time_s < 0.1, "{r:?}");
    }

    #[test]
    fn too_few_samples_and_no_change_are_refused() {
        let (t, v) = sampled(30.0, 1.0, |t| if t < 0.9 { 0.0 } else { 1.0 });
        // The onset at 0.9 s leaves 4 frames after it.
        assert_eq!(
            step_response(&t, &v, 0.9, 1.0),
            Err(ResponseError::TooFewSamples {
                before: 27,
                after: 4
            })
        );
        let (t, v) = sampled(30.0, 1.0, |_| 3.0);
        assert_eq!(
            step_response(&t, &v, 0.5, 1.0),
            Err(ResponseError::NoChange)
        );
        // A settling that never ends in the window.
        let (t, v) = sampled(30.0, 2.0, |t| {
            if t < 0.5 {
                0.0
            } else {
                10.0 + (t * 40.0).sin()
            }
        });
        assert!(step_response(&t, &v, 0.5, 2.0)
            .unwrap()
            .settling_time_s
            .is_nan());
    }
}
