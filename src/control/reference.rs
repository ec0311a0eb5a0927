//! References: the bending angle the controller is asked to follow over time.

use std::path::Path;

use serde::Serialize;

use super::ControlError;
use crate::table::Table;

/// Time a step run lasts by default beyond the step, s.
pub const DEFAULT_STEP_DURATION_S: f64 = 5.0;

/// Time added after the end of a ramp or a CSV trajectory by default, s.
pub const DEFAULT_SETTLE_S: f64 = 1.0;

/// A reference trajectory, degrees vs seconds.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Reference {
    /// A step to `angle_deg` at t = 0 (from wherever the actuator rests).
    Step {
        /// Target angle, degrees.
        angle_deg: f64,
    },
    /// A ramp from `from_deg` to `to_deg` over `duration_s`, then held.
    Ramp {
        /// Start angle, degrees.
        from_deg: f64,
        /// End angle, degrees.
        to_deg: f64,
        /// Ramp time, s.
        duration_s: f64,
    },
    /// `mean_deg + amplitude_deg sin(2π t / period_s)`.
    Sine {
        /// Mean, degrees.
        mean_deg: f64,
        /// Amplitude, degrees.
        amplitude_deg: f64,
        /// Period, s.
        period_s: f64,
    },
    /// A table `time_s, angle_deg`, linear between rows, held beyond its ends.
    Table {
        /// Times, s (increasing).
        time_s: Vec<f64>,
        /// Angles, degrees.
        angle_deg: Vec<f64>,
    },
}

fn parse_numbers(text: &str, n: usize, flag: &str, form: &str) -> Result<Vec<f64>, ControlError> {
    let v: Vec<f64> = text
        .split(':')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| ControlError::Setting {
            name: flag.into(),
            why: format!("`{text}`: expected {form}"),
        })?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        return Err(ControlError::Setting {
            name: flag.into(),
            why: format!("`{text}`: expected {form}"),
        });
    }
    Ok(v)
}

impl Reference {
    /// `--ramp FROM:TO:SECONDS`.
    pub fn parse_ramp(text: &str) -> Result<Self, ControlError> {
        let v = parse_numbers(text, 3, "ramp", "FROM_DEG:TO_DEG:SECONDS, e.g. 0:60:10")?;
        if v[2] <= 0.0 {
            return Err(ControlError::Setting {
                name: "ramp".into(),
                why: format!("`{text}`: the ramp time must be > 0 s"),
            });
        }
        Ok(Self::Ramp {
            from_deg: v[0],
            to_deg: v[1],
            duration_s: v[2],
        })
    }

    /// `--sine MEAN:AMPLITUDE:PERIOD`.
    pub fn parse_sine(text: &str) -> Result<Self, ControlError> {
        let v = parse_numbers(
            text,
            3,
            "sine",
            "MEAN_DEG:AMPLITUDE_DEG:PERIOD_S, e.g. 45:30:4",
        )?;
        if v[2] <= 0.0 {
            return Err(ControlError::Setting {
                name: "sine".into(),
                why: format!("`{text}`: the period must be > 0 s"),
            });
        }
        Ok(Self::Sine {
            mean_deg: v[0],
            amplitude_deg: v[1],
            period_s: v[2],
        })
    }

    /// Reads a CSV `time_s,angle_deg` (times increasing from >= 0).
    pub fn from_csv(path: &Path) -> Result<Self, ControlError> {
        let table = Table::read(path)?;
        let hint = "a reference table: time_s,angle_deg";
        let (tc, ac) = (
            table.require("time_s", hint)?,
            table.require("angle_deg", hint)?,
        );
        let mut time_s = Vec::new();
        let mut angle_deg = Vec::new();
        for r in 0..table.len() {
            let (t, a) = (table.f64_at(r, tc)?, table.f64_at(r, ac)?);
            if !(t.is_finite() && a.is_finite()) {
                return Err(table.error_at(Some(r), None, "give finite numbers").into());
            }
            if time_s.last().is_some_and(|p| t <= *p) || t < 0.0 {
                return Err(table
                    .error_at(Some(r), Some(tc), "times must start at >= 0 and increase")
                    .into());
            }
            time_s.push(t);
            angle_deg.push(a);
        }
        if time_s.is_empty() {
            return Err(ControlError::Setting {
                name: "target".into(),
                why: format!("{} has no rows: give time_s,angle_deg rows", path.display()),
            });
        }
        Ok(Self::Table { time_s, angle_deg })
    }

    /// The reference at `t_s`, degrees; `initial_deg` is where the actuator rests (a
    /// step starts from it).
    pub fn at_deg(&self, t_s: f64) -> f64 {
        match self {
            Self::Step { angle_deg } => *angle_deg,
            Self::Ramp {
                from_deg,
                to_deg,
                duration_s,
            } => from_deg + (to_deg - from_deg) * (t_s / duration_s).clamp(0.0, 1.0),
            Self::Sine {
                mean_deg,
                amplitude_deg,
                period_s,
            } => mean_deg + amplitude_deg * (std::f64::consts::TAU * t_s / period_s).sin(),
            Self::Table { time_s, angle_deg } => {
                if time_s.len() == 1 {
                    return angle_deg[0];
                }
                let k = time_s.partition_point(|t| *t <= t_s);
                if k == 0 {
                    angle_deg[0]
                } else if k == time_s.len() {
                    angle_deg[k - 1]
                } else {
                    let w = (t_s - time_s[k - 1]) / (time_s[k] - time_s[k - 1]);
                    angle_deg[k - 1] + w * (angle_deg[k] - angle_deg[k - 1])
                }
            }
        }
    }

    /// The run's default length, s.
    pub fn default_duration_s(&self) -> f64 {
        match self {
            Self::Step { .. } => DEFAULT_STEP_DURATION_S,
            Self::Ramp { duration_s, .. } => duration_s + DEFAULT_SETTLE_S,
            Self::Sine { period_s, .. } => 2.0 * period_s,
            Self::Table { time_s, .. } => time_s.last().copied().unwrap_or(0.0) + DEFAULT_SETTLE_S,
        }
    }

    /// The largest angle asked for within `duration_s`.
    pub fn max_deg(&self, duration_s: f64) -> f64 {
        match self {
            Self::Step { angle_deg } => *angle_deg,
            Self::Ramp {
                from_deg, to_deg, ..
            } => from_deg.max(*to_deg),
            Self::Sine {
                mean_deg,
                amplitude_deg,
                ..
            } => mean_deg + amplitude_deg.abs(),
            Self::Table { time_s, angle_deg } => time_s
                .iter()
                .zip(angle_deg)
                .filter(|(t, _)| **t <= duration_s)
                .map(|(_, a)| *a)
                .fold(angle_deg[0], f64::max),
        }
    }

    /// The smallest angle asked for within `duration_s`.
    pub fn min_deg(&self, duration_s: f64) -> f64 {
        match self {
            Self::Step { angle_deg } => *angle_deg,
            Self::Ramp {
                from_deg, to_deg, ..
            } => from_deg.min(*to_deg),
            Self::Sine {
                mean_deg,
                amplitude_deg,
                ..
            } => mean_deg - amplitude_deg.abs(),
            Self::Table { time_s, angle_deg } => time_s
                .iter()
                .zip(angle_deg)
                .filter(|(t, _)| **t <= duration_s)
                .map(|(_, a)| *a)
                .fold(angle_deg[0], f64::min),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn references_at_times() {
        let r = Reference::parse_ramp("10:70:3").unwrap();
        assert_eq!(r.at_deg(-1.0), 10.0);
        assert!((r.at_deg(1.5) - 40.0).abs() < 1e-12);
        assert_eq!(r.at_deg(9.0), 70.0);
        let s = Reference::parse_sine("45:30:4").unwrap();
        assert!((s.at_deg(1.0) - 75.0).abs() < 1e-12);
        let t = Reference::Table {
            time_s: vec![0.0, 2.0, 5.0],
            angle_deg: vec![0.0, 60.0, 60.0],
        };
        assert!((t.at_deg(1.0) - 30.0).abs() < 1e-12);
        assert_eq!(t.at_deg(7.0), 60.0);
        assert_eq!(t.max_deg(10.0), 60.0);
        assert!(Reference::parse_ramp("10:70").is_err());
        assert!(Reference::parse_sine("1:2:0").is_err());
    }
}
