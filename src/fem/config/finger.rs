//! The segmented finger's section (`[finger]`, finger-design study): the study's design
//! parameters H, N, TSB, TOF and length, with the values it leaves open beside them, and
//! the checks on them alone (the shape is [`crate::fem::shapes::finger`]).

use serde::{Deserialize, Serialize};

use crate::fem::layer::MAX_SHEET_MM;
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
    /// Bellow wall thickness TSB (end walls and the top), mm.
    pub wall_mm: f64,
    /// Foot thickness TOF, mm.
    pub foot_mm: f64,
    /// Length, mm.
    pub length_mm: f64,
    /// Each bellow's cavity along the finger, mm (not given by the study).
    pub cavity_mm: f64,
    /// The cavities' width across the finger, mm (not given by the study).
    pub cavity_width_mm: f64,
    /// The bellows' flat side walls, mm (not given by the study); absent:
    /// [`FingerConfig::side_wall`]'s rule.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub side_wall_mm: Option<f64>,
    /// Gap between bellows, mm (not given by the study).
    pub gap_mm: f64,
    /// Height of the channel joining a segment's bellows, mm (not given by the study).
    pub channel_mm: f64,
    /// The channel's roof between bellows, mm (not given by the study).
    pub roof_mm: f64,
    /// The strain-limiting sheet on the bottom face: thickness, mm.
    pub sheet_mm: f64,
    /// The sheet's Young's modulus, MPa (the study's second, stiffer material, not given);
    /// 0: no sheet.
    pub sheet_mpa: f64,
}

/// The side walls' thickness at TSB = 1 mm, and the share of TSB beyond 1 mm they take
/// ([`FingerConfig::side_wall`]).
pub const SIDE_WALL_BASE_MM: f64 = 1.0;
/// See [`SIDE_WALL_BASE_MM`].
pub const SIDE_WALL_SHARE: f64 = 0.5;

/// The sheet's Poisson's ratio (a paper or fabric sheet's order).
pub const SHEET_POISSON: f64 = 0.45;

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
            cavity_mm: 3.0,
            cavity_width_mm: 18.0,
            side_wall_mm: None,
            gap_mm: 1.5,
            channel_mm: 2.0,
            roof_mm: 1.0,
            sheet_mm: 0.5,
            sheet_mpa: 20.0,
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
    /// The flat side walls' thickness, mm: `side_wall_mm`, or 1 mm at TSB = 1 mm and half of
    /// TSB's growth beyond it (chosen so that the TSB series falls as the study's).
    pub fn side_wall(&self) -> f64 {
        self.side_wall_mm
            .unwrap_or(SIDE_WALL_BASE_MM + SIDE_WALL_SHARE * (self.wall_mm - SIDE_WALL_BASE_MM))
    }

    /// Each bellow's length along the finger, mm: its cavity and two end walls.
    pub fn bellow_mm(&self) -> f64 {
        self.cavity_mm + 2.0 * self.wall_mm
    }

    /// The gap drawn between bellows, mm: `gap_mm`, or less where N bellows that far
    /// apart would overrun the finger (the last one then ends at the tip; 0: they touch).
    pub fn drawn_gap_mm(&self) -> f64 {
        let n = self.bellows as f64;
        let room = (self.length_mm - n * self.bellow_mm()) / (n - 1.0).max(1.0);
        self.gap_mm.min(room).max(0.0)
    }

    /// The bellows' pitch from the clamp on, mm.
    pub fn pitch_mm(&self) -> f64 {
        self.bellow_mm() + self.drawn_gap_mm()
    }

    /// The finger's width, mm: the cavities' and two side walls.
    pub fn width_mm(&self) -> f64 {
        self.cavity_width_mm + 2.0 * self.side_wall()
    }

    /// How far the channel and its roof raise the foot between bellows, mm.
    fn raised_mm(&self) -> f64 {
        if self.channel_mm > 0.0 {
            self.channel_mm + self.roof_mm
        } else {
            0.0
        }
    }

    /// The .geo's numbers (`examples/geo/segmented_finger.geo`'s DefineConstants; NMCP
    /// the MCP segment's bellows, the first channel's).
    pub fn geo_numbers(&self) -> Vec<(String, f64)> {
        [
            ("H", self.height_mm),
            ("N", self.bellows as f64),
            ("TSB", self.wall_mm),
            ("TOF", self.foot_mm),
            ("L", self.length_mm),
            ("NMCP", self.segments()[0] as f64),
            ("CAVITY", self.cavity_mm),
            ("CAVITY_W", self.cavity_width_mm),
            ("SIDEWALL", self.side_wall()),
            ("GAP", self.drawn_gap_mm()),
            ("CHANNEL", self.channel_mm),
            ("ROOF", self.roof_mm),
            ("SIDE", 1.0),
            ("SHEET", if self.sheet_mpa > 0.0 { 3.0 } else { 0.0 }),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect()
    }

    /// The half model's cavity volume, mm³: per bellow a box CAVITY long, half the
    /// cavities' width across, up to the half cylinder of radius CAVITY / 2 under the top,
    /// and the two channels where they run between bellows.
    pub fn cavity_volume_mm3(&self) -> f64 {
        let n = self.bellows as f64;
        let half = 0.5 * self.cavity_width_mm;
        let c = self.cavity_mm;
        let rs = 0.5 * self.bellow_mm();
        let bellow = half * (c * (self.height_mm - rs) + std::f64::consts::PI * c * c / 8.0);
        // Both channels together run from the first bellow's cavity to the last's but
        // across the MCP segment's last gap.
        let channels = (n - 2.0) * self.pitch_mm() + 2.0 * c;
        n * bellow + half * self.channel_mm * (channels - n * c)
    }

    /// The drawn solid's volume (the half model's), mm³: the foot (under the channels'
    /// roof along the bellows), each bellow's outline, less the cavities.
    pub fn solid_volume_mm3(&self) -> f64 {
        let n = self.bellows as f64;
        let r = 0.5 * self.width_mm();
        let b = self.bellow_mm();
        let rs = 0.5 * b;
        let base = self.foot_mm + self.raised_mm();
        let bellow = r * (b * (self.height_mm - rs) + std::f64::consts::PI * rs * rs / 2.0);
        let outline = self.length_mm * r * base + n * (bellow - r * b * (base - self.foot_mm));
        outline - self.cavity_volume_mm3()
    }

    /// Bellows per segment (MCP, PIP, DIP): MCP and PIP ceil(N / 3) each, DIP the rest
    /// (the study's "one fewer in DIP" where N allows it; its N = 12 and 18 do not).
    pub fn segments(&self) -> [usize; 3] {
        let m = self.bellows.div_ceil(3);
        [m, m, self.bellows.saturating_sub(2 * m)]
    }

    /// Checks that the numbers describe a finger the .geo can draw.
    pub fn validate(&self) -> Result<(), FemError> {
        let sizes = [
            ("height_mm", self.height_mm),
            ("wall_mm", self.wall_mm),
            ("foot_mm", self.foot_mm),
            ("length_mm", self.length_mm),
            ("cavity_mm", self.cavity_mm),
            ("cavity_width_mm", self.cavity_width_mm),
            ("gap_mm", self.gap_mm),
            ("roof_mm", self.roof_mm),
            ("sheet_mm", self.sheet_mm),
        ];
        let side = self.side_wall_mm.map(|v| ("side_wall_mm", v));
        for (name, v) in sizes.into_iter().chain(side) {
            if !(v.is_finite() && v > 0.0 && v < 1e4) {
                return Err(bad(
                    name,
                    format!("{v} mm: give a positive size below 10 m"),
                ));
            }
        }
        if self.sheet_mm > MAX_SHEET_MM {
            return Err(bad(
                "sheet_mm",
                format!(
                    "{} mm: the sheet is a membrane, at most {MAX_SHEET_MM} mm thick",
                    self.sheet_mm
                ),
            ));
        }
        if !(self.channel_mm.is_finite() && (0.0..1e4).contains(&self.channel_mm)) {
            return Err(bad(
                "channel_mm",
                format!(
                    "{} mm: give 0 (no channel) or a size below 10 m",
                    self.channel_mm
                ),
            ));
        }
        if !(self.sheet_mpa.is_finite() && (0.0..=2e5).contains(&self.sheet_mpa)) {
            return Err(bad(
                "sheet_mpa",
                format!(
                    "{} MPa: give 0 (no sheet) or a modulus up to 2e5 MPa (steel's)",
                    self.sheet_mpa
                ),
            ));
        }
        if !(3..=MAX_BELLOWS).contains(&self.bellows) {
            return Err(bad(
                "bellows",
                format!("{}: give 3 to {MAX_BELLOWS} bellows", self.bellows),
            ));
        }
        let rs = 0.5 * self.bellow_mm();
        let base = self.raised_mm();
        if self.height_mm <= (rs + base).max(2.0 * rs) {
            return Err(bad(
                "height_mm",
                format!(
                    "{} mm leaves no straight wall under the bellow's top (radius {rs} mm) above the channel and roof ({base} mm): raise it or shorten the cavities",
                    self.height_mm
                ),
            ));
        }
        let used = self.bellows as f64 * self.bellow_mm();
        if used > self.length_mm + 1e-9 {
            return Err(bad(
                "bellows",
                format!(
                    "{} bellows {:.2} mm long need {used:.2} mm, more than the {} mm finger: fewer bellows, shorter cavities or thinner walls",
                    self.bellows,
                    self.bellow_mm(),
                    self.length_mm
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
        let d = FingerConfig::default;
        let cases: [(FingerConfig, &str); 10] = [
            (
                FingerConfig {
                    sheet_mm: 6.0,
                    ..d()
                },
                "finger.sheet_mm",
            ),
            (
                FingerConfig {
                    wall_mm: f64::NAN,
                    ..d()
                },
                "finger.wall_mm",
            ),
            (
                FingerConfig {
                    side_wall_mm: Some(f64::NAN),
                    ..d()
                },
                "finger.side_wall_mm",
            ),
            (
                FingerConfig {
                    cavity_mm: -3.0,
                    ..d()
                },
                "finger.cavity_mm",
            ),
            (
                FingerConfig {
                    channel_mm: f64::INFINITY,
                    ..d()
                },
                "finger.channel_mm",
            ),
            (
                FingerConfig {
                    sheet_mpa: -20.0,
                    ..d()
                },
                "finger.sheet_mpa",
            ),
            (FingerConfig { bellows: 2, ..d() }, "finger.bellows"),
            // The top's radius 2.5 mm on a 2 mm channel under a 1 mm roof.
            (
                FingerConfig {
                    height_mm: 5.5,
                    ..d()
                },
                "finger.height_mm",
            ),
            (
                FingerConfig {
                    wall_mm: 10.0,
                    ..d()
                },
                "finger.height_mm",
            ),
            // 27 bellows 5 mm long need 135 mm.
            (FingerConfig { bellows: 27, ..d() }, "finger.bellows"),
        ];
        for (cfg, key) in cases {
            let e = cfg.validate().unwrap_err().to_string();
            assert!(e.contains(key), "{key}: {e}");
        }
        d().validate().unwrap();
    }

    /// The bellows keep their pitch (cavity, two walls, gap) from the clamp while they
    /// fit, and the gaps close where they would not: 20 bellows of TSB 1.75 mm fill the
    /// finger.
    #[test]
    fn gaps_close_only_where_the_bellows_would_overrun() {
        let at = |bellows, wall_mm| FingerConfig {
            bellows,
            wall_mm,
            ..FingerConfig::default()
        };
        let cases = [
            (12, 1.0, 1.5, 6.5),
            (20, 1.0, 1.5, 6.5),
            (14, 1.75, 1.5, 8.0),
            (20, 1.5, 10.0 / 19.0, 6.0 + 10.0 / 19.0),
            (20, 1.75, 0.0, 6.5),
        ];
        for (n, tsb, gap, pitch) in cases {
            let f = at(n, tsb);
            f.validate().unwrap();
            assert!(
                (f.drawn_gap_mm() - gap).abs() < 1e-12,
                "N {n} TSB {tsb}: gap {}",
                f.drawn_gap_mm()
            );
            assert!(
                (f.pitch_mm() - pitch).abs() < 1e-12,
                "N {n} TSB {tsb}: pitch {}",
                f.pitch_mm()
            );
        }
        // The side walls: 1 mm at TSB 1 mm, half of TSB's growth beyond.
        assert_eq!(at(14, 1.75).side_wall(), 1.375);
        assert_eq!(at(14, 1.75).width_mm(), 20.75);
    }
}
