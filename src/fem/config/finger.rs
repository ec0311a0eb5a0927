//! The segmented finger's section (`[finger]`, finger-design study): the study's design
//! parameters H, N, TSB, TOF and length, with the values it leaves open beside them, and
//! the checks on them alone (the shape is [`crate::fem::shapes::finger`]).

use serde::{Deserialize, Serialize};

use crate::fem::FemError;

/// Most bellows a finger may have.
pub const MAX_BELLOWS: usize = 200;

/// The segmented finger (`[finger]`): N semicircular bellows on a foot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FingerConfig {
    /// Bellow height H above the foot, mm.
    pub height_mm: f64,
    /// Number of bellows N.
    pub bellows: usize,
    /// Bellow wall thickness TSB, mm.
    pub wall_mm: f64,
    /// Foot thickness TOF, mm.
    pub foot_mm: f64,
    /// Length, mm.
    pub length_mm: f64,
    /// Width, mm (not given by the study); the bellow's top is a half cylinder across it.
    pub width_mm: f64,
    /// Gap between bellows, mm (not given by the study).
    pub gap_mm: f64,
}

/// The study's first design (H 10 mm, N 12, TSB 1 mm, TOF 1.25 mm, 130 mm) and the
/// values chosen where it is silent (docs/src/validation.md, "The segmented finger").
impl Default for FingerConfig {
    fn default() -> Self {
        Self {
            height_mm: 10.0,
            bellows: 12,
            wall_mm: 1.0,
            foot_mm: 1.25,
            length_mm: 130.0,
            width_mm: 20.0,
            gap_mm: 1.5,
        }
    }
}

fn bad(name: &str, why: String) -> FemError {
    FemError::Parameter {
        name: format!("finger.{name}"),
        why,
    }
}

impl FingerConfig {
    /// The .geo's numbers (`examples/geo/segmented_finger.geo`'s DefineConstants; NMCP
    /// the MCP segment's bellows, the first channel's).
    pub fn geo_numbers(&self) -> Vec<(String, f64)> {
        [
            ("H", self.height_mm),
            ("N", self.bellows as f64),
            ("TSB", self.wall_mm),
            ("TOF", self.foot_mm),
            ("L", self.length_mm),
            ("W", self.width_mm),
            ("gap", self.gap_mm),
            ("NMCP", self.segments()[0] as f64),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect()
    }

    /// The drawn solid's volume (the half model's), mm³: the foot, and each bellow's
    /// half-cylinder top and straight sides less its cavity.
    pub fn solid_volume_mm3(&self) -> f64 {
        let n = self.bellows as f64;
        let r = 0.5 * self.width_mm;
        let ri = r - self.wall_mm;
        let sides = self.height_mm - r;
        let tb = self.length_mm / n - self.gap_mm;
        let section = |radius: f64| std::f64::consts::FRAC_PI_4 * radius * radius + radius * sides;
        self.length_mm * r * self.foot_mm
            + n * (tb * section(r) - (tb - 2.0 * self.wall_mm) * section(ri))
    }

    /// Bellows per segment (MCP, PIP, DIP): MCP and PIP ceil(N / 3) each, DIP the rest
    /// (the study's "one fewer in DIP" where N allows it; its N = 12 and 18 do not).
    pub fn segments(&self) -> [usize; 3] {
        let m = self.bellows.div_ceil(3);
        [m, m, self.bellows.saturating_sub(2 * m)]
    }

    /// Checks that the numbers describe a finger the .geo can draw.
    pub fn validate(&self) -> Result<(), FemError> {
        for (name, v) in [
            ("height_mm", self.height_mm),
            ("wall_mm", self.wall_mm),
            ("foot_mm", self.foot_mm),
            ("length_mm", self.length_mm),
            ("width_mm", self.width_mm),
            ("gap_mm", self.gap_mm),
        ] {
            if !(v.is_finite() && v > 0.0 && v < 1e4) {
                return Err(bad(
                    name,
                    format!("{v} mm: give a positive size below 10 m"),
                ));
            }
        }
        if !(3..=MAX_BELLOWS).contains(&self.bellows) {
            return Err(bad(
                "bellows",
                format!("{}: give 3 to {MAX_BELLOWS} bellows", self.bellows),
            ));
        }
        let radius = 0.5 * self.width_mm;
        if self.height_mm < radius {
            return Err(bad(
                "height_mm",
                format!(
                    "{} mm is lower than the half-cylinder top's radius (width_mm / 2 = {radius} mm): raise it or narrow the finger",
                    self.height_mm
                ),
            ));
        }
        if self.wall_mm >= radius {
            return Err(bad(
                "wall_mm",
                format!(
                    "{} mm leaves no cavity in a bellow {} mm wide",
                    self.wall_mm, self.width_mm
                ),
            ));
        }
        let pitch = self.length_mm / self.bellows as f64;
        let cavity = pitch - self.gap_mm - 2.0 * self.wall_mm;
        if cavity <= 0.0 {
            return Err(bad(
                "bellows",
                format!(
                    "{} bellows of {pitch:.2} mm with {} mm gaps and {} mm walls leave no cavity: fewer bellows, thinner walls or smaller gaps",
                    self.bellows, self.gap_mm, self.wall_mm
                ),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_split_the_bellows_as_stated() {
        let split = |n| {
            FingerConfig {
                bellows: n,
                ..FingerConfig::default()
            }
            .segments()
        };
        assert_eq!(split(12), [4, 4, 4]);
        assert_eq!(split(14), [5, 5, 4]);
        assert_eq!(split(16), [6, 6, 4]);
        assert_eq!(split(20), [7, 7, 6]);
    }

    #[test]
    fn undrawable_fingers_are_refused_naming_the_key() {
        let cases: [(FingerConfig, &str); 5] = [
            (
                FingerConfig {
                    wall_mm: f64::NAN,
                    ..Default::default()
                },
                "finger.wall_mm",
            ),
            (
                FingerConfig {
                    bellows: 2,
                    ..Default::default()
                },
                "finger.bellows",
            ),
            (
                FingerConfig {
                    height_mm: 8.0,
                    ..Default::default()
                },
                "finger.height_mm",
            ),
            (
                FingerConfig {
                    wall_mm: 10.0,
                    ..Default::default()
                },
                "finger.wall_mm",
            ),
            (
                FingerConfig {
                    bellows: 60,
                    ..Default::default()
                },
                "finger.bellows",
            ),
        ];
        for (cfg, key) in cases {
            let e = cfg.validate().unwrap_err().to_string();
            assert!(e.contains(key), "{key}: {e}");
        }
        FingerConfig::default().validate().unwrap();
    }
}
