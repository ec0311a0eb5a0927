//! A discrete PID controller with a filtered derivative, output limits and anti-windup
//! by back-calculation, at a fixed sample time.
//!
//! The algorithm is the one of Åström and Hägglund (*Advanced PID Control*, ISA 2006,
//! §3.5 and §13.6; also Åström and Murray, *Feedback Systems*, 2nd ed., §11.5):
//!
//! - P = Kp (b r − y): proportional on a weighted set-point (b = 1: on the error);
//! - D = a D − k (y − y_prev), a = T_f / (T_f + h), k = Kd / (T_f + h): derivative of the
//!   measurement (no kick on set-point steps) through a first-order filter
//!   1 / (T_f s + 1), discretized by the backward difference (stable for any T_f);
//! - v = P + I + D, u = sat(v) within the output limits;
//! - I += Ki h (r − y) + (h / T_t) (u − v): the integral is pulled back while the output
//!   saturates (back-calculation with tracking time T_t), so it does not wind up.
//!
//! Hand-written: it is fifteen lines, and the PID crates on crates.io either lack the
//! derivative filter or the back-calculation.

use serde::Serialize;

use super::ControlError;

/// Default derivative filter: T_f = T_d / N with N = 10 (Åström and Hägglund's range
/// 2..20).
pub const DEFAULT_DERIVATIVE_FILTER_N: f64 = 10.0;

/// Gains of a parallel PID: u = Kp e + Ki ∫e + Kd de/dt; the error in degrees, the
/// output in kPa.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PidGains {
    /// Proportional gain, kPa/deg.
    pub kp_kpa_per_deg: f64,
    /// Integral gain, kPa/(deg s).
    pub ki_kpa_per_deg_s: f64,
    /// Derivative gain, kPa s/deg.
    pub kd_kpa_s_per_deg: f64,
}

/// Settings of the controller besides its gains.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PidSettings {
    /// The gains.
    pub gains: PidGains,
    /// Sample time h, s.
    pub sample_s: f64,
    /// Lowest output, kPa.
    pub min_kpa: f64,
    /// Highest output, kPa.
    pub max_kpa: f64,
    /// Set-point weight b of the proportional term.
    pub setpoint_weight: f64,
    /// Derivative filter divisor N (T_f = Kd / (Kp N)).
    pub derivative_filter_n: f64,
    /// Tracking time of the back-calculation, s (None: sqrt(T_i T_d), or T_i for a PI,
    /// Åström and Hägglund's rule of thumb).
    pub tracking_s: Option<f64>,
}

impl PidSettings {
    /// Checks the settings.
    pub fn validate(&self) -> Result<(), ControlError> {
        let bad = |name: &str, why: String| {
            Err(ControlError::Setting {
                name: name.into(),
                why,
            })
        };
        let g = &self.gains;
        for (name, v) in [
            ("kp", g.kp_kpa_per_deg),
            ("ki", g.ki_kpa_per_deg_s),
            ("kd", g.kd_kpa_s_per_deg),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(
                    name,
                    format!("{v}: give a gain >= 0 (the angle rises with pressure)"),
                );
            }
        }
        if !(self.sample_s.is_finite() && self.sample_s > 0.0) {
            return bad(
                "sample-time-s",
                format!("{} s: give a sample time > 0", self.sample_s),
            );
        }
        if !(self.derivative_filter_n.is_finite() && self.derivative_filter_n > 0.0) {
            return bad(
                "derivative-filter-n",
                format!("{}: give N > 0", self.derivative_filter_n),
            );
        }
        Ok(())
    }

    /// The tracking time T_t, s.
    fn tracking_time_s(&self) -> f64 {
        if let Some(t) = self.tracking_s {
            return t.max(self.sample_s);
        }
        let g = &self.gains;
        let ti = g.kp_kpa_per_deg / g.ki_kpa_per_deg_s;
        let td = g.kd_kpa_s_per_deg / g.kp_kpa_per_deg;
        let t = if td > 0.0 { (ti * td).sqrt() } else { ti };
        if t.is_finite() && t > 0.0 {
            t.max(self.sample_s)
        } else {
            self.sample_s
        }
    }
}

/// The controller's state.
#[derive(Debug, Clone)]
pub struct Pid {
    settings: PidSettings,
    tracking_s: f64,
    integral_kpa: f64,
    derivative_kpa: f64,
    previous_deg: Option<f64>,
}

impl Pid {
    /// A controller at rest whose output starts at `initial_kpa` (bumpless start: the
    /// integral holds it).
    pub fn new(settings: PidSettings, initial_kpa: f64) -> Self {
        Self {
            tracking_s: settings.tracking_time_s(),
            settings,
            integral_kpa: initial_kpa,
            derivative_kpa: 0.0,
            previous_deg: None,
        }
    }

    /// One sample: reference and measured angle, degrees -> the output, kPa (within the
    /// limits). Returns the output and whether it saturated.
    pub fn update(&mut self, reference_deg: f64, measured_deg: f64) -> (f64, bool) {
        let s = &self.settings;
        let g = &s.gains;
        let h = s.sample_s;
        let p = g.kp_kpa_per_deg * (s.setpoint_weight * reference_deg - measured_deg);
        let y_prev = self.previous_deg.unwrap_or(measured_deg);
        if g.kd_kpa_s_per_deg > 0.0 {
            let tf = if g.kp_kpa_per_deg > 0.0 {
                g.kd_kpa_s_per_deg / (g.kp_kpa_per_deg * s.derivative_filter_n)
            } else {
                h
            };
            let a = tf / (tf + h);
            let k = g.kd_kpa_s_per_deg / (tf + h);
            self.derivative_kpa = a * self.derivative_kpa - k * (measured_deg - y_prev);
        }
        self.previous_deg = Some(measured_deg);
        let v = p + self.integral_kpa + self.derivative_kpa;
        let u = v.clamp(s.min_kpa, s.max_kpa);
        // Without integral action there is nothing to wind up: the integral only holds
        // the starting output (bias).
        if g.ki_kpa_per_deg_s > 0.0 {
            self.integral_kpa += g.ki_kpa_per_deg_s * h * (reference_deg - measured_deg)
                + h / self.tracking_s * (u - v);
        }
        (u, u != v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(kp: f64, ki: f64, kd: f64) -> PidSettings {
        PidSettings {
            gains: PidGains {
                kp_kpa_per_deg: kp,
                ki_kpa_per_deg_s: ki,
                kd_kpa_s_per_deg: kd,
            },
            sample_s: 0.01,
            min_kpa: 0.0,
            max_kpa: 100.0,
            setpoint_weight: 1.0,
            derivative_filter_n: 10.0,
            tracking_s: None,
        }
    }

    #[test]
    fn pi_integrates_the_error_each_sample() {
        let mut pid = Pid::new(settings(2.0, 5.0, 0.0), 0.0);
        // e = 1: u_k = Kp e + Ki h e k (the integral is updated after the output).
        for k in 0..10 {
            let (u, sat) = pid.update(1.0, 0.0);
            assert!((u - (2.0 + 5.0 * 0.01 * k as f64)).abs() < 1e-12);
            assert!(!sat);
        }
    }

    #[test]
    fn derivative_of_a_ramp_settles_at_kd_times_its_slope() {
        // y = -t (deg): filtered derivative of the measurement -> Kd * 1 deg/s.
        let mut pid = Pid::new(settings(1.0, 0.0, 0.5), 0.0);
        let mut u = 0.0;
        for k in 0..300 {
            let y = -(k as f64) * 0.01;
            u = pid.update(0.0, y).0 - (0.0 - y);
        }
        assert!((u - 0.5).abs() < 1e-9, "{u}");
    }

    #[test]
    fn back_calculation_stops_windup() {
        // Saturated for 10 s at the top, then the error reverses: with anti-windup the
        // output leaves the limit within a few tracking times, not after unwinding 10 s.
        let mut pid = Pid::new(settings(1.0, 2.0, 0.0), 0.0);
        for _ in 0..1000 {
            let (u, sat) = pid.update(500.0, 0.0);
            assert!(u <= 100.0 && sat);
        }
        let mut left_at = None;
        for k in 0..1000 {
            let (u, _) = pid.update(0.0, 10.0);
            if u < 100.0 {
                left_at = Some(k);
                break;
            }
        }
        let k = left_at.expect("the output leaves the limit");
        assert!(k < 5, "left the limit after {k} samples");
    }
}
