//! The plant: the actuator's quasi-static map (bending angle vs pressure, from a
//! `simulate` output) behind the pneumatic line that sets its pressure.
//!
//! The pneumatic line is, in the order the command passes: the regulator (range and
//! resolution), a dead time (tubing, valve), a rate limit and a first-order lag (the
//! cavity filling through the valve). The lag's time constant is given, or follows from
//! the cavity volume and a linear valve conductance: for an isothermal ideal gas in a
//! cavity of volume V(p) fed through a valve whose normal-volume flow is K (p_set − p),
//! d(p_abs V)/dt = p_n K (p_set − p), so
//! τ(p) = (V(p) + p_abs dV/dp) / (p_n K), p_n the normal (atmospheric) pressure
//! (e.g. Beater, *Pneumatic Drives*, 2007, ch. 5: a chamber's pressure build-up). The
//! compliance term p_abs dV/dp is the actuator inflating: it is taken from the map's
//! cavity volume, so a softer actuator is slower.
//!
//! Everything is integrated exactly over a sample (the command is held between samples,
//! the lag and the rate limit solved in closed form, a fractional dead time split into
//! its two held values), so a pure first-order-plus-dead-time plant matches its analytic
//! response to round-off.

use std::path::Path;

use serde::Serialize;

use super::ControlError;
use crate::render::rng::SplitMix64;
use crate::table::Table;

/// Normal (atmospheric) pressure, kPa: the reference of a valve's normal-volume flow and
/// the offset from gauge to absolute pressure.
pub const ATMOSPHERIC_KPA: f64 = 101.325;

/// Default valve conductance, L/min (normal) per kPa of pressure difference: a small
/// proportional regulator (about 10 L/min ANR at 100 kPa difference).
pub const DEFAULT_VALVE_CONDUCTANCE_L_MIN_KPA: f64 = 0.1;

/// Default dead time of the line, s (valve response plus a metre of 4 mm tubing).
pub const DEFAULT_DEAD_TIME_S: f64 = 0.03;

/// Longest dead time accepted, s: a line's transport delay is milliseconds (sound
/// crosses 10 m of tubing in 30 ms); the delay line holds one command per sample of it.
pub const MAX_DEAD_TIME_S: f64 = 60.0;

/// Default regulator resolution, kPa (a 12-bit command over 0..~400 kPa).
pub const DEFAULT_RESOLUTION_KPA: f64 = 0.1;

/// Default rate limit of the regulator output, kPa/s.
pub const DEFAULT_RATE_LIMIT_KPA_S: f64 = 500.0;

/// Default sensor noise (standard deviation of the measured angle), degrees.
pub const DEFAULT_NOISE_DEG: f64 = 0.2;

/// Monotone piecewise-cubic Hermite interpolation (PCHIP): the slopes of Fritsch and
/// Carlson (1980) in the weighted-harmonic-mean form of Fritsch and Butland (1984), with
/// SciPy's shape-preserving three-point end slopes. Between data points it never
/// overshoots, so a monotone angle-pressure table stays monotone (an ordinary cubic
/// spline can ripple and make the plant's gain change sign). Written here because it is
/// thirty lines; no maintained crate offers it with derivatives.
#[derive(Debug, Clone, PartialEq)]
pub struct Pchip {
    x: Vec<f64>,
    y: Vec<f64>,
    d: Vec<f64>,
}

impl Pchip {
    /// The interpolant through (x, y); x strictly increasing, at least two points.
    pub fn new(x: &[f64], y: &[f64]) -> Result<Self, ControlError> {
        let bad = |why: &str| ControlError::Map {
            why: format!("interpolation table: {why}"),
        };
        if x.len() != y.len() || x.len() < 2 {
            return Err(bad("needs at least two (x, y) points of equal count"));
        }
        if x.iter().chain(y).any(|v| !v.is_finite()) {
            return Err(bad("non-finite value"));
        }
        if x.windows(2).any(|w| w[1] <= w[0]) {
            return Err(bad("x must increase strictly"));
        }
        let n = x.len();
        let h: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
        let delta: Vec<f64> = (0..n - 1).map(|k| (y[k + 1] - y[k]) / h[k]).collect();
        let mut d = vec![0.0; n];
        if n == 2 {
            d = vec![delta[0]; 2];
        } else {
            for k in 1..n - 1 {
                if delta[k - 1] * delta[k] > 0.0 {
                    let w1 = 2.0 * h[k] + h[k - 1];
                    let w2 = h[k] + 2.0 * h[k - 1];
                    d[k] = (w1 + w2) / (w1 / delta[k - 1] + w2 / delta[k]);
                }
            }
            d[0] = end_slope(h[0], h[1], delta[0], delta[1]);
            d[n - 1] = end_slope(h[n - 2], h[n - 3], delta[n - 2], delta[n - 3]);
        }
        Ok(Self {
            x: x.to_vec(),
            y: y.to_vec(),
            d,
        })
    }

    /// The segment holding `x` (clamped) and the local coordinate t in [0, 1].
    fn locate(&self, x: f64) -> (usize, f64, f64) {
        let n = self.x.len();
        let x = x.clamp(self.x[0], self.x[n - 1]);
        let k = match self.x.partition_point(|v| *v <= x) {
            0 => 0,
            i => (i - 1).min(n - 2),
        };
        let h = self.x[k + 1] - self.x[k];
        (k, (x - self.x[k]) / h, h)
    }

    /// The value at `x`; held at the end values outside the table.
    pub fn eval(&self, x: f64) -> f64 {
        let (k, t, h) = self.locate(x);
        let (t2, t3) = (t * t, t * t * t);
        (2.0 * t3 - 3.0 * t2 + 1.0) * self.y[k]
            + (t3 - 2.0 * t2 + t) * h * self.d[k]
            + (-2.0 * t3 + 3.0 * t2) * self.y[k + 1]
            + (t3 - t2) * h * self.d[k + 1]
    }

    /// The derivative at `x` (zero outside the table, where the value is held).
    pub fn derivative(&self, x: f64) -> f64 {
        if x < self.x[0] || x > self.x[self.x.len() - 1] {
            return 0.0;
        }
        let (k, t, h) = self.locate(x);
        let t2 = t * t;
        ((6.0 * t2 - 6.0 * t) * self.y[k]
            + (3.0 * t2 - 4.0 * t + 1.0) * h * self.d[k]
            + (-6.0 * t2 + 6.0 * t) * self.y[k + 1]
            + (3.0 * t2 - 2.0 * t) * h * self.d[k + 1])
            / h
    }

    /// The first and last x of the table.
    pub fn domain(&self) -> (f64, f64) {
        (self.x[0], self.x[self.x.len() - 1])
    }
}

/// SciPy's end slope: the three-point estimate, zeroed when its sign differs from the
/// first secant's and limited to 3 x that secant when the secants change sign.
fn end_slope(h0: f64, h1: f64, m0: f64, m1: f64) -> f64 {
    let d = ((2.0 * h0 + h1) * m0 - h0 * m1) / (h0 + h1);
    if d.signum() != m0.signum() || m0 == 0.0 {
        0.0
    } else if m0.signum() != m1.signum() && d.abs() > 3.0 * m0.abs() {
        3.0 * m0
    } else {
        d
    }
}

/// The actuator's quasi-static map: bending angle, curvature and cavity volume vs
/// pressure, interpolated monotonically between the steps of a simulation.
#[derive(Debug, Clone)]
pub struct QuasiStaticMap {
    angle_deg: Pchip,
    curvature_per_m: Option<Pchip>,
    volume_mm3: Option<Pchip>,
}

impl QuasiStaticMap {
    /// A map from tables of pressure (kPa, strictly increasing) and bending angle (deg,
    /// non-decreasing), with optional curvature (1/m) and cavity volume (mm³).
    pub fn new(
        pressure_kpa: &[f64],
        angle_deg: &[f64],
        curvature_per_m: Option<&[f64]>,
        volume_mm3: Option<&[f64]>,
    ) -> Result<Self, ControlError> {
        if let Some(w) = angle_deg.windows(2).position(|w| w[1] < w[0]) {
            return Err(ControlError::Map {
                why: format!(
                    "the bending angle falls from {:.2} to {:.2} deg between {} and {} kPa: a controller needs an angle that rises with pressure (check the simulation, or limit the regulator range below {} kPa)",
                    angle_deg[w], angle_deg[w + 1], pressure_kpa[w], pressure_kpa[w + 1], pressure_kpa[w + 1]
                ),
            });
        }
        Ok(Self {
            angle_deg: Pchip::new(pressure_kpa, angle_deg)?,
            curvature_per_m: curvature_per_m
                .map(|c| Pchip::new(pressure_kpa, c))
                .transpose()?,
            volume_mm3: volume_mm3
                .map(|v| Pchip::new(pressure_kpa, v))
                .transpose()?,
        })
    }

    /// Reads `steps.csv` of a `simulate` output folder (pressure_kpa, bending_angle_deg,
    /// and curvature_per_m and cavity_volume_mm3 when present).
    pub fn from_simulation(dir: &Path) -> Result<Self, ControlError> {
        let path = dir.join("steps.csv");
        if !path.is_file() {
            return Err(ControlError::Map {
                why: format!(
                    "{} not found: give the output folder of `bendscope simulate`",
                    path.display()
                ),
            });
        }
        let table = Table::read(&path)?;
        let hint = "steps.csv of `bendscope simulate`";
        let column = |name: &str| -> Result<Vec<f64>, ControlError> {
            let c = table.require(name, hint)?;
            Ok((0..table.len())
                .map(|r| table.f64_at(r, c))
                .collect::<Result<Vec<f64>, _>>()?)
        };
        let optional = |name: &str| -> Result<Option<Vec<f64>>, ControlError> {
            match table.column(name) {
                Some(_) => column(name).map(Some),
                None => Ok(None),
            }
        };
        let p = column("pressure_kpa")?;
        let a = column("bending_angle_deg")?;
        if p.len() < 2 {
            return Err(ControlError::Map {
                why: format!(
                    "{} has {} step(s): simulate at least two pressures (e.g. --pressures 0:115:5)",
                    path.display(),
                    p.len()
                ),
            });
        }
        let k = optional("curvature_per_m")?.filter(|c| c.iter().all(|v| v.is_finite()));
        let v = optional("cavity_volume_mm3")?;
        Self::new(&p, &a, k.as_deref(), v.as_deref()).map_err(|e| match e {
            ControlError::Map { why } => ControlError::Map {
                why: format!("{}: {why}", path.display()),
            },
            e => e,
        })
    }

    /// Bending angle at `pressure_kpa`, degrees (held beyond the table's pressures).
    pub fn angle_deg(&self, pressure_kpa: f64) -> f64 {
        self.angle_deg.eval(pressure_kpa)
    }

    /// Radius of curvature at `pressure_kpa`, mm (NaN without a curvature column,
    /// infinite when straight).
    pub fn radius_mm(&self, pressure_kpa: f64) -> f64 {
        match &self.curvature_per_m {
            Some(k) => 1000.0 / k.eval(pressure_kpa),
            None => f64::NAN,
        }
    }

    /// Cavity volume at `pressure_kpa` and its derivative, mm³ and mm³/kPa.
    pub fn volume_mm3(&self, pressure_kpa: f64) -> Option<(f64, f64)> {
        self.volume_mm3
            .as_ref()
            .map(|v| (v.eval(pressure_kpa), v.derivative(pressure_kpa)))
    }

    /// The simulated pressure range, kPa.
    pub fn pressure_range_kpa(&self) -> (f64, f64) {
        self.angle_deg.domain()
    }

    /// The smallest pressure (within `lo..=hi` kPa) whose angle reaches `angle_deg`
    /// (bisection on the monotone map); `None` when even `hi` does not reach it.
    pub fn pressure_for_angle_kpa(&self, angle_deg: f64, lo: f64, hi: f64) -> Option<f64> {
        if self.angle_deg(hi) < angle_deg {
            return None;
        }
        if self.angle_deg(lo) >= angle_deg {
            return Some(lo);
        }
        let (mut a, mut b) = (lo, hi);
        for _ in 0..60 {
            let m = 0.5 * (a + b);
            if self.angle_deg(m) < angle_deg {
                a = m;
            } else {
                b = m;
            }
        }
        Some(b)
    }
}

/// The first-order lag's time constant.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LagModel {
    /// A fixed time constant, s.
    Fixed {
        /// Time constant, s.
        tau_s: f64,
    },
    /// From the cavity volume and a valve conductance (module doc).
    Valve {
        /// Valve conductance, L/min (normal) per kPa.
        conductance_l_min_kpa: f64,
    },
}

/// The pneumatic line between the controller and the actuator.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PneumaticSettings {
    /// The lag's time constant.
    pub lag: LagModel,
    /// Dead time, s.
    pub dead_time_s: f64,
    /// Lowest regulator output, kPa.
    pub min_kpa: f64,
    /// Highest regulator output, kPa.
    pub max_kpa: f64,
    /// Regulator resolution, kPa (0: continuous).
    pub resolution_kpa: f64,
    /// Largest rate of change of the pressure, kPa/s (infinite: none).
    pub rate_limit_kpa_s: f64,
    /// Sensor noise on the measured angle (standard deviation), degrees.
    pub noise_deg: f64,
    /// Seed of the sensor noise.
    pub seed: u64,
}

impl Default for PneumaticSettings {
    fn default() -> Self {
        Self {
            lag: LagModel::Valve {
                conductance_l_min_kpa: DEFAULT_VALVE_CONDUCTANCE_L_MIN_KPA,
            },
            dead_time_s: DEFAULT_DEAD_TIME_S,
            min_kpa: 0.0,
            max_kpa: 115.0,
            resolution_kpa: DEFAULT_RESOLUTION_KPA,
            rate_limit_kpa_s: DEFAULT_RATE_LIMIT_KPA_S,
            noise_deg: DEFAULT_NOISE_DEG,
            seed: 1,
        }
    }
}

impl PneumaticSettings {
    /// Checks the ranges; the message names the flag.
    pub fn validate(&self) -> Result<(), ControlError> {
        let bad = |name: &str, why: String| {
            Err(ControlError::Setting {
                name: name.into(),
                why,
            })
        };
        match self.lag {
            LagModel::Fixed { tau_s } if !(tau_s.is_finite() && tau_s >= 0.0) => {
                return bad("tau-s", format!("{tau_s} s: give a time constant >= 0"));
            }
            LagModel::Valve {
                conductance_l_min_kpa: k,
            } if !(k.is_finite() && k > 0.0) => {
                return bad(
                    "valve-conductance",
                    format!("{k}: give a conductance > 0 L/min/kPa"),
                );
            }
            _ => {}
        }
        if !(self.dead_time_s.is_finite()
            && self.dead_time_s >= 0.0
            && self.dead_time_s <= MAX_DEAD_TIME_S)
        {
            return bad(
                "dead-time-s",
                format!(
                    "{} s: give a dead time between 0 and {MAX_DEAD_TIME_S} s (a pneumatic line's is tens of milliseconds)",
                    self.dead_time_s
                ),
            );
        }
        if !(self.min_kpa.is_finite() && self.max_kpa.is_finite() && self.min_kpa < self.max_kpa) {
            return bad(
                "regulator-kpa",
                format!(
                    "{}:{} kPa: give MIN:MAX with MIN < MAX",
                    self.min_kpa, self.max_kpa
                ),
            );
        }
        if !(self.resolution_kpa.is_finite() && self.resolution_kpa >= 0.0) {
            return bad(
                "resolution-kpa",
                format!("{}: give a resolution >= 0", self.resolution_kpa),
            );
        }
        if self.rate_limit_kpa_s.is_nan() || self.rate_limit_kpa_s <= 0.0 {
            return bad(
                "rate-limit-kpa-s",
                format!("{}: give a rate > 0 (inf for none)", self.rate_limit_kpa_s),
            );
        }
        if !(self.noise_deg.is_finite() && self.noise_deg >= 0.0) {
            return bad(
                "noise-deg",
                format!("{}: give a standard deviation >= 0", self.noise_deg),
            );
        }
        Ok(())
    }
}

/// What turns a pressure into a bending angle: the map, the FEM in the loop, a test's
/// linear gain.
pub trait AngleModel {
    /// The bending angle at `pressure_kpa`, degrees.
    fn angle_deg(&mut self, pressure_kpa: f64) -> Result<f64, ControlError>;
}

impl AngleModel for QuasiStaticMap {
    fn angle_deg(&mut self, pressure_kpa: f64) -> Result<f64, ControlError> {
        Ok(QuasiStaticMap::angle_deg(self, pressure_kpa))
    }
}

/// The state of the pneumatic line: the pressure, the held commands still in the dead
/// time, the noise generator.
#[derive(Debug, Clone)]
pub struct PneumaticLine {
    settings: PneumaticSettings,
    sample_s: f64,
    /// Regulator set-points of past samples, newest last (enough to cover the delay).
    history: std::collections::VecDeque<f64>,
    pressure_kpa: f64,
    noise: SplitMix64,
}

impl PneumaticLine {
    /// A line at rest at `initial_kpa` (every past command equal to it).
    pub fn new(settings: PneumaticSettings, sample_s: f64, initial_kpa: f64) -> Self {
        let keep = (settings.dead_time_s / sample_s).floor() as usize + 2;
        Self {
            settings,
            sample_s,
            history: std::iter::repeat_n(initial_kpa, keep).collect(),
            pressure_kpa: initial_kpa,
            noise: SplitMix64::new(settings.seed),
        }
    }

    /// The pressure now, kPa.
    pub fn pressure_kpa(&self) -> f64 {
        self.pressure_kpa
    }

    /// The regulator's set-point for a command: clamped to the range, rounded to the
    /// nearest step of the resolution, and a rounded value beyond an end of the range
    /// clamped to that end.
    pub fn setpoint_kpa(&self, command_kpa: f64) -> f64 {
        let s = &self.settings;
        let c = command_kpa.clamp(s.min_kpa, s.max_kpa);
        let q = if s.resolution_kpa > 0.0 {
            (c / s.resolution_kpa).round() * s.resolution_kpa
        } else {
            c
        };
        q.clamp(s.min_kpa, s.max_kpa)
    }

    /// The lag's time constant at `pressure_kpa`, s.
    pub fn tau_s(&self, map: Option<&QuasiStaticMap>, pressure_kpa: f64) -> f64 {
        match self.settings.lag {
            LagModel::Fixed { tau_s } => tau_s,
            LagModel::Valve {
                conductance_l_min_kpa,
            } => {
                let k_mm3_s_kpa = conductance_l_min_kpa * 1e6 / 60.0;
                match map.and_then(|m| m.volume_mm3(pressure_kpa)) {
                    Some((v, dv)) => {
                        (v + (pressure_kpa + ATMOSPHERIC_KPA) * dv.max(0.0))
                            / (ATMOSPHERIC_KPA * k_mm3_s_kpa)
                    }
                    None => 0.0,
                }
            }
        }
    }

    /// Holds `command_kpa` for one sample and returns the pressure at its end, kPa.
    /// `map` gives the cavity volume for a valve-driven lag.
    pub fn step(&mut self, command_kpa: f64, map: Option<&QuasiStaticMap>) -> f64 {
        let sp = self.setpoint_kpa(command_kpa);
        self.history.push_back(sp);
        self.history.pop_front();
        let ts = self.sample_s;
        let delay = self.settings.dead_time_s / ts;
        let whole = delay.floor() as usize;
        let frac = delay - whole as f64;
        let n = self.history.len();
        // Over this sample the line sees the command of `whole` samples ago, preceded
        // for the fraction `frac` of the sample by the one before it.
        let newer = self.history[n - 1 - whole];
        let older = self.history[n - 2 - whole];
        let mut p = self.pressure_kpa;
        for (target, dt) in [(older, frac * ts), (newer, (1.0 - frac) * ts)] {
            if dt > 0.0 {
                let tau = self.tau_s(map, p);
                p = lag_with_rate_limit(p, target, tau, self.settings.rate_limit_kpa_s, dt);
            }
        }
        self.pressure_kpa = p;
        p
    }

    /// A sensor reading of `angle_deg`: plus seeded Gaussian noise.
    pub fn measure(&mut self, angle_deg: f64) -> f64 {
        angle_deg + self.settings.noise_deg * self.noise.normal()
    }
}

/// The first-order lag τ dp/dt = target − p with |dp/dt| ≤ rate, solved exactly over `dt`
/// from `p`: at the rate limit while |target − p| > rate τ, then exponential.
pub fn lag_with_rate_limit(p: f64, target: f64, tau_s: f64, rate_kpa_s: f64, dt: f64) -> f64 {
    let e = target - p;
    let dir = e.signum();
    let band = rate_kpa_s * tau_s;
    let mut p = p;
    let mut dt = dt;
    if e.abs() > band {
        let t_ramp = (e.abs() - band) / rate_kpa_s;
        if t_ramp >= dt {
            return p + dir * rate_kpa_s * dt;
        }
        p += dir * rate_kpa_s * t_ramp;
        dt -= t_ramp;
    }
    if tau_s <= 0.0 {
        return target;
    }
    target + (p - target) * (-dt / tau_s).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pchip_is_exact_on_lines_and_keeps_monotone_data_monotone() {
        let x = [0.0, 1.0, 3.0, 4.0];
        let line = Pchip::new(&x, &[1.0, 3.0, 7.0, 9.0]).unwrap();
        for v in [0.0, 0.3, 2.2, 3.9, 4.0] {
            assert!((line.eval(v) - (1.0 + 2.0 * v)).abs() < 1e-12);
            assert!((line.derivative(v) - 2.0).abs() < 1e-12);
        }
        // A step-like table: a cubic spline overshoots, PCHIP must not.
        let p = Pchip::new(&[0.0, 1.0, 2.0, 3.0, 4.0], &[0.0, 0.0, 1.0, 1.0, 1.0]).unwrap();
        let mut last = f64::NEG_INFINITY;
        for k in 0..=400 {
            let v = p.eval(k as f64 * 0.01);
            assert!(
                v >= last - 1e-15 && (-1e-15..=1.0 + 1e-15).contains(&v),
                "{v}"
            );
            last = v;
        }
        // Data points are hit; values are held beyond the ends.
        assert_eq!(p.eval(2.0), 1.0);
        assert_eq!(p.eval(-5.0), 0.0);
        assert_eq!(p.eval(9.0), 1.0);
    }

    #[test]
    fn pchip_derivative_matches_finite_differences() {
        let x = [0.0, 5.0, 10.0, 20.0, 30.0];
        let y = [0.0, 2.0, 9.0, 30.0, 70.0];
        let p = Pchip::new(&x, &y).unwrap();
        for v in [1.0, 7.3, 12.0, 26.0] {
            let fd = (p.eval(v + 1e-6) - p.eval(v - 1e-6)) / 2e-6;
            assert!((p.derivative(v) - fd).abs() < 1e-6, "{v}");
        }
    }

    #[test]
    fn a_falling_angle_is_refused_with_its_pressures() {
        let e = QuasiStaticMap::new(&[0.0, 10.0, 20.0], &[0.0, 5.0, 4.0], None, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("between 10 and 20 kPa"), "{e}");
    }

    #[test]
    fn lag_and_rate_limit_are_exact() {
        // Pure lag: p = target (1 - e^{-t/τ}).
        let p = lag_with_rate_limit(0.0, 10.0, 0.5, f64::INFINITY, 0.2);
        assert!((p - 10.0 * (1.0 - (-0.4f64).exp())).abs() < 1e-12);
        // Rate-limited: 100 kPa/s, τ = 0.1: ramp until 10 kPa from the target (0.9 s), then
        // exponential; split into pieces, the result is the same.
        let whole = lag_with_rate_limit(0.0, 100.0, 0.1, 100.0, 1.2);
        let mut q = 0.0;
        for _ in 0..12 {
            q = lag_with_rate_limit(q, 100.0, 0.1, 100.0, 0.1);
        }
        assert!((whole - q).abs() < 1e-9, "{whole} {q}");
        assert!((whole - (100.0 - 10.0 * (-3.0f64).exp())).abs() < 1e-9);
    }

    #[test]
    fn dead_time_delays_the_command_by_a_fraction_of_a_sample() {
        let settings = PneumaticSettings {
            lag: LagModel::Fixed { tau_s: 0.2 },
            dead_time_s: 0.025,
            resolution_kpa: 0.0,
            rate_limit_kpa_s: f64::INFINITY,
            noise_deg: 0.0,
            ..Default::default()
        };
        let mut line = PneumaticLine::new(settings, 0.01, 0.0);
        for k in 1..=50 {
            let p = line.step(50.0, None);
            let t: f64 = k as f64 * 0.01 - 0.025;
            let exact = if t > 0.0 {
                50.0 * (1.0 - (-t / 0.2).exp())
            } else {
                0.0
            };
            assert!((p - exact).abs() < 1e-9, "t {t}: {p} vs {exact}");
        }
    }

    #[test]
    fn regulator_clamps_and_rounds() {
        let line = PneumaticLine::new(
            PneumaticSettings {
                resolution_kpa: 0.5,
                max_kpa: 100.2,
                ..Default::default()
            },
            0.01,
            0.0,
        );
        assert_eq!(line.setpoint_kpa(-3.0), 0.0);
        assert_eq!(line.setpoint_kpa(12.26), 12.5);
        // The top of the range is not a multiple of the resolution: the regulator gives
        // the highest step within the range.
        assert_eq!(line.setpoint_kpa(500.0), 100.0);
    }

    #[test]
    fn valve_time_constant_grows_with_volume_and_compliance() {
        let map = QuasiStaticMap::new(
            &[0.0, 100.0],
            &[0.0, 90.0],
            None,
            Some(&[10_000.0, 30_000.0]),
        )
        .unwrap();
        let line = PneumaticLine::new(PneumaticSettings::default(), 0.01, 0.0);
        // K = 0.1 L/min/kPa = 1666.7 mm³/s/kPa; at 0 kPa: (1e4 + 101.325 * 200) / (101.325 * 1666.7).
        let k = 0.1 * 1e6 / 60.0;
        let expect = (10_000.0 + ATMOSPHERIC_KPA * 200.0) / (ATMOSPHERIC_KPA * k);
        assert!((line.tau_s(Some(&map), 0.0) - expect).abs() < 1e-9);
        assert!(line.tau_s(Some(&map), 50.0) > expect);
    }
}
