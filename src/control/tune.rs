//! Tuning: a first-order-plus-dead-time (FOPDT) model identified from an open-loop step,
//! and PI gains from Skogestad's SIMC rules.
//!
//! **Identification.** The step response y(t) = y0 + K Δu (1 − e^{−(t−θ)/τ}) for t > θ
//! is fitted to the simulated response by Levenberg-Marquardt (the `levenberg-marquardt`
//! crate, as the power-law fits), started from the two-point method of Smith (1972):
//! with t28 and t63 the times the response covers 28.3% and 63.2% of its change,
//! τ = 1.5 (t63 − t28), θ = t63 − τ.
//!
//! **SIMC** (S. Skogestad, "Simple analytic rules for model reduction and PID controller
//! tuning", *Journal of Process Control* 13 (2003) 291-309, eqs. 21-22): for
//! G(s) = k e^{−θ s} / (τ1 s + 1) and a desired closed-loop time constant τc,
//!
//! - Kc = τ1 / (k (τc + θ)),
//! - τI = min(τ1, 4 (τc + θ)),
//! - no derivative (SIMC adds one, τD = τ2, only for a second-order model),
//!
//! i.e. Kp = Kc, Ki = Kc / τI, Kd = 0. τc = θ is Skogestad's "tight control" (gain
//! margin ~3, phase margin ~61°, 4% set-point overshoot on an exact FOPDT plant); a
//! larger τc gives a slower, smoother loop. The default here is τc = 1.5 θ: on the
//! reference actuator τc = θ overshot a 90-degree step by 10.2%, because the line's rate
//! limit and its lag that grows with pressure (neither in the FOPDT model) add phase lag;
//! 1.5 θ gave 1.9% for a rise time of 0.08 s instead of 0.065 s. The sampling adds half a
//! sample of delay (Skogestad's half rule), so θ is the identified dead time plus h / 2.

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{storage::Owned, Dyn, OMatrix, OVector, Vector3, U3};
use serde::Serialize;

use super::pid::PidGains;
use super::ControlError;

/// A first-order-plus-dead-time model k e^{−θ s} / (τ s + 1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Fopdt {
    /// Static gain, deg/kPa.
    pub gain_deg_per_kpa: f64,
    /// Time constant, s.
    pub tau_s: f64,
    /// Dead time, s.
    pub dead_time_s: f64,
    /// RMS of the fit's residuals, degrees.
    pub rms_deg: f64,
}

impl Fopdt {
    /// The model's response at time `t_s` to a step of `du_kpa` at time 0.
    pub fn step_response_deg(&self, t_s: f64, du_kpa: f64) -> f64 {
        let t = t_s - self.dead_time_s;
        if t <= 0.0 {
            0.0
        } else if self.tau_s <= 0.0 {
            self.gain_deg_per_kpa * du_kpa
        } else {
            self.gain_deg_per_kpa * du_kpa * (1.0 - (-t / self.tau_s).exp())
        }
    }
}

struct StepFit<'a> {
    t: &'a [f64],
    dy: &'a [f64],
    du: f64,
    /// (K, τ, θ).
    p: Vector3<f64>,
}

impl LeastSquaresProblem<f64, Dyn, U3> for StepFit<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, U3>;
    type ParameterStorage = Owned<f64, U3>;

    fn set_params(&mut self, x: &Vector3<f64>) {
        self.p = *x;
    }
    fn params(&self) -> Vector3<f64> {
        self.p
    }
    fn residuals(&self) -> Option<OVector<f64, Dyn>> {
        let m = Fopdt {
            gain_deg_per_kpa: self.p.x,
            tau_s: self.p.y.max(1e-9),
            dead_time_s: self.p.z,
            rms_deg: 0.0,
        };
        Some(OVector::<f64, Dyn>::from_iterator(
            self.t.len(),
            self.t
                .iter()
                .zip(self.dy)
                .map(|(t, y)| m.step_response_deg(*t, self.du) - y),
        ))
    }
    fn jacobian(&self) -> Option<OMatrix<f64, Dyn, U3>> {
        let (k, tau, theta) = (self.p.x, self.p.y.max(1e-9), self.p.z);
        let mut j = OMatrix::<f64, Dyn, U3>::zeros(self.t.len());
        for (i, t) in self.t.iter().enumerate() {
            let s = t - theta;
            if s > 0.0 {
                let e = (-s / tau).exp();
                j[(i, 0)] = self.du * (1.0 - e);
                j[(i, 1)] = -k * self.du * e * s / (tau * tau);
                j[(i, 2)] = -k * self.du * e / tau;
            }
        }
        Some(j)
    }
}

/// The first time the normalized response reaches `level`, linearly interpolated.
fn crossing_s(t: &[f64], dy: &[f64], total: f64, level: f64) -> Option<f64> {
    let f = |k: usize| dy[k] / total;
    (1..t.len()).find(|k| f(*k) >= level).map(|k| {
        let (a, b) = (f(k - 1), f(k));
        if b > a {
            t[k - 1] + (level - a) / (b - a) * (t[k] - t[k - 1])
        } else {
            t[k]
        }
    })
}

/// Identifies an FOPDT model from a step of `du_kpa` at t = 0: times `t_s` and the
/// response's change from its initial value `dy_deg`. The response must have settled by
/// the end (the last tenth is taken as the final value for the start).
pub fn identify_fopdt(t_s: &[f64], dy_deg: &[f64], du_kpa: f64) -> Result<Fopdt, ControlError> {
    let fail = |why: String| ControlError::Tune { why };
    if t_s.len() != dy_deg.len() || t_s.len() < 10 || du_kpa == 0.0 {
        return Err(fail(format!(
            "an open-loop step needs a non-zero pressure step and at least 10 samples ({} given)",
            t_s.len()
        )));
    }
    let tail = &dy_deg[dy_deg.len() - dy_deg.len() / 10..];
    let total = tail.iter().sum::<f64>() / tail.len() as f64;
    if total.is_nan() || total.abs() <= 1e-9 {
        return Err(fail(
            "the open-loop step did not move the angle: check the map and the regulator range"
                .into(),
        ));
    }
    let (Some(t28), Some(t63)) = (
        crossing_s(t_s, dy_deg, total, 0.283),
        crossing_s(t_s, dy_deg, total, 0.632),
    ) else {
        return Err(fail(
            "the open-loop response never reached 63% of its change".into(),
        ));
    };
    let tau0 = (1.5 * (t63 - t28)).max(1e-3);
    let theta0 = (t63 - tau0).max(0.0);
    let problem = StepFit {
        t: t_s,
        dy: dy_deg,
        du: du_kpa,
        p: Vector3::new(total / du_kpa, tau0, theta0),
    };
    let (fitted, report) = LevenbergMarquardt::new().minimize(problem);
    let p = fitted.p;
    let model = if report.termination.was_successful() && p.y > 0.0 && p.z >= 0.0 {
        Fopdt {
            gain_deg_per_kpa: p.x,
            tau_s: p.y,
            dead_time_s: p.z,
            rms_deg: 0.0,
        }
    } else {
        Fopdt {
            gain_deg_per_kpa: total / du_kpa,
            tau_s: tau0,
            dead_time_s: theta0,
            rms_deg: 0.0,
        }
    };
    let sse: f64 = t_s
        .iter()
        .zip(dy_deg)
        .map(|(t, y)| (model.step_response_deg(*t, du_kpa) - y).powi(2))
        .sum();
    Ok(Fopdt {
        rms_deg: (sse / t_s.len() as f64).sqrt(),
        ..model
    })
}

/// Default SIMC closed-loop time constant, in effective dead times (module doc).
pub const DEFAULT_TAU_C_PER_DEAD_TIME: f64 = 1.5;

/// The effective dead time of `model` sampled every `sample_s`: θ + h / 2.
pub fn effective_dead_time_s(model: &Fopdt, sample_s: f64) -> f64 {
    model.dead_time_s + 0.5 * sample_s
}

/// SIMC PI gains for `model` (module doc); `tau_c_s` the desired closed-loop time
/// constant (None: [`DEFAULT_TAU_C_PER_DEAD_TIME`] θ), `sample_s` the controller's sample
/// time (half of it is added to θ).
pub fn simc_gains(model: &Fopdt, tau_c_s: Option<f64>, sample_s: f64) -> PidGains {
    let theta = effective_dead_time_s(model, sample_s);
    let tau_c = tau_c_s.unwrap_or(DEFAULT_TAU_C_PER_DEAD_TIME * theta);
    let kc = model.tau_s / (model.gain_deg_per_kpa * (tau_c + theta));
    let ti = model.tau_s.min(4.0 * (tau_c + theta)).max(sample_s);
    PidGains {
        kp_kpa_per_deg: kc,
        ki_kpa_per_deg_s: kc / ti,
        kd_kpa_s_per_deg: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identifies_an_exact_fopdt_response() {
        let truth = Fopdt {
            gain_deg_per_kpa: 1.3,
            tau_s: 0.4,
            dead_time_s: 0.07,
            rms_deg: 0.0,
        };
        let t: Vec<f64> = (0..400).map(|k| k as f64 * 0.01).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|t| truth.step_response_deg(*t, 20.0))
            .collect();
        let m = identify_fopdt(&t, &y, 20.0).unwrap();
        assert!((m.gain_deg_per_kpa - 1.3).abs() < 1e-4, "{m:?}");
        assert!((m.tau_s - 0.4).abs() < 1e-3, "{m:?}");
        assert!((m.dead_time_s - 0.07).abs() < 1e-3, "{m:?}");
        assert!(m.rms_deg < 1e-3);
    }

    #[test]
    fn simc_rules_as_published() {
        // k = 2, τ1 = 1, θ = 0.1 (h = 0), τc = θ: Kc = 1 / (2 * 0.2) = 2.5,
        // τI = min(1, 0.8) = 0.8.
        let m = Fopdt {
            gain_deg_per_kpa: 2.0,
            tau_s: 1.0,
            dead_time_s: 0.1,
            rms_deg: 0.0,
        };
        let g = simc_gains(&m, Some(0.1), 0.0);
        assert!((g.kp_kpa_per_deg - 2.5).abs() < 1e-12);
        assert!((g.ki_kpa_per_deg_s - 2.5 / 0.8).abs() < 1e-12);
        assert_eq!(g.kd_kpa_s_per_deg, 0.0);
        // A slower loop, τc = 0.5: Kc = 1 / (2 * 0.6), τI = τ1 = 1.
        let g = simc_gains(&m, Some(0.5), 0.0);
        assert!((g.kp_kpa_per_deg - 1.0 / 1.2).abs() < 1e-12);
        assert!((g.ki_kpa_per_deg_s - 1.0 / 1.2).abs() < 1e-12);
        // Default τc = 1.5 θ, h = 0.02 adds 0.01 to θ: θ = 0.11, τc = 0.165,
        // Kc = 1 / (2 * 0.275), τI = min(1, 1.1) = 1.
        let g = simc_gains(&m, None, 0.02);
        assert!((g.kp_kpa_per_deg - 1.0 / 0.55).abs() < 1e-12);
        assert!((g.ki_kpa_per_deg_s - 1.0 / 0.55).abs() < 1e-12);
    }
}
