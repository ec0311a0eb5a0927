//! Marker colours as bands of OpenCV's HSV (H in 0..180 with red wrapping around 0/180,
//! S and V in 0..255): the presets ([`MarkerColour`]), the band ([`HsvThresholds`]) and
//! the test of an RGB pixel against it in integer arithmetic ([`is_marker_colour`],
//! checked against OpenCV's floating-point conversion), with the HSV and chroma
//! conversions the pre-tests are derived from.

use serde::{Deserialize, Serialize};

/// Default minimum saturation (0..255) of a coloured marker: pale silicone and the white
/// sheet stay out.
pub const DEFAULT_S_MIN: u8 = 100;
/// Default minimum value (0..255) of a coloured marker: shadows stay out.
pub const DEFAULT_V_MIN: u8 = 60;
/// Default largest value (0..255) of a dark marker (black dots on a light actuator).
pub const DEFAULT_DARK_V_MAX: u8 = 80;
/// Largest hue on OpenCV's scale (degrees / 2).
pub const HUE_MAX: u8 = 180;

/// The marker colours with a preset band (`[detect] colour = ...`, any case: `"Green"`
/// is green, as `--family` takes any case).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MarkerColour {
    /// Hue 170..10 (wrapping at 0/180), S >= 100, V >= 60.
    #[default]
    Red,
    /// Hue 35..85, S >= 100, V >= 60.
    Green,
    /// Hue 95..130, S >= 100, V >= 60.
    Blue,
    /// Hue 20..34, S >= 100, V >= 80.
    Yellow,
    /// Any hue, V <= 80: black or dark dots on a light actuator.
    Dark,
}

/// Reads one of `names` (lowercase) in any case as `T`: a `[detect]` name written
/// `"Green"` or `"LEFT"` is accepted, an unknown one is refused listing the names.
pub(super) fn any_case<'de, D, T: Copy>(
    d: D,
    what: &str,
    names: &[(&str, T)],
) -> Result<T, D::Error>
where
    D: serde::Deserializer<'de>,
{
    let s = String::deserialize(d)?;
    let lower = s.trim().to_ascii_lowercase();
    names
        .iter()
        .find(|(n, _)| *n == lower)
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            let list: Vec<&str> = names.iter().map(|(n, _)| *n).collect();
            serde::de::Error::custom(format!(
                "unknown {what} `{s}`: use one of {}",
                list.join(", ")
            ))
        })
}

impl<'de> Deserialize<'de> for MarkerColour {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use MarkerColour::*;
        any_case(
            d,
            "colour",
            &[
                ("red", Red),
                ("green", Green),
                ("blue", Blue),
                ("yellow", Yellow),
                ("dark", Dark),
            ],
        )
    }
}

impl MarkerColour {
    /// The preset band of this colour.
    pub fn thresholds(self) -> HsvThresholds {
        let band = |hue_min, hue_max, s_min, v_min| HsvThresholds {
            hue_min,
            hue_max,
            s_min,
            v_min,
            v_max: 255,
        };
        match self {
            MarkerColour::Red => band(170, 10, DEFAULT_S_MIN, DEFAULT_V_MIN),
            MarkerColour::Green => band(35, 85, DEFAULT_S_MIN, DEFAULT_V_MIN),
            MarkerColour::Blue => band(95, 130, DEFAULT_S_MIN, DEFAULT_V_MIN),
            MarkerColour::Yellow => band(20, 34, 100, 80),
            MarkerColour::Dark => HsvThresholds {
                hue_min: 0,
                hue_max: HUE_MAX,
                s_min: 0,
                v_min: 0,
                v_max: DEFAULT_DARK_V_MAX,
            },
        }
    }
}

/// The marker colour as a band of OpenCV's HSV (H in 0..180, S and V in 0..255): hue in
/// `hue_min..=hue_max` (wrapping through 0/180 when `hue_min > hue_max`, as red does;
/// `0..=180` is every hue), S >= `s_min`, `v_min` <= V <= `v_max`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HsvThresholds {
    /// Lowest hue of the band.
    pub hue_min: u8,
    /// Highest hue of the band (below `hue_min`: the band wraps through 0).
    pub hue_max: u8,
    /// Minimum saturation.
    pub s_min: u8,
    /// Minimum value.
    pub v_min: u8,
    /// Maximum value (255 for coloured markers; dark markers set it).
    pub v_max: u8,
}

impl Default for HsvThresholds {
    fn default() -> Self {
        MarkerColour::Red.thresholds()
    }
}

impl HsvThresholds {
    /// True when every hue passes (dark markers).
    pub fn every_hue(&self) -> bool {
        self.hue_min == 0 && self.hue_max >= HUE_MAX
    }

    /// True when the band holds hue 0 (red): the centroid's fallback cue is redness.
    pub fn holds_red(&self) -> bool {
        self.hue_min > self.hue_max || self.hue_min == 0
    }

    /// True when the band holds hue `h` (OpenCV scale) given as `num / den` (den > 0).
    #[inline]
    fn holds_hue(&self, num: i32, den: i32) -> bool {
        let (lo, hi) = (self.hue_min as i32 * den, self.hue_max as i32 * den);
        if self.hue_min <= self.hue_max {
            lo <= num && num <= hi
        } else {
            num >= lo || num <= hi
        }
    }
}

/// Whether an RGB pixel lies in the colour band `t` (OpenCV's HSV, integer arithmetic).
///
/// V = max(r, g, b), S = 255 (V - min) / V, and H (OpenCV's degrees / 2) from the largest
/// channel, in OpenCV's order (r, then g, then b on ties): 30 (g - b) / delta (plus 180
/// when negative), 60 + 30 (b - r) / delta, 120 + 30 (r - g) / delta. The comparisons are
/// cross-multiplied, without division. A grey pixel (delta 0) has no hue: it passes only
/// a band of every hue.
#[inline]
pub fn is_marker_colour(r: u8, g: u8, b: u8, t: &HsvThresholds) -> bool {
    let v = r.max(g).max(b);
    if v < t.v_min || v > t.v_max {
        return false;
    }
    let (r, g, b, v) = (r as i32, g as i32, b as i32, v as i32);
    let delta = v - r.min(g).min(b);
    if 255 * delta < t.s_min as i32 * v {
        return false;
    }
    if t.every_hue() {
        return true;
    }
    if delta == 0 {
        return false;
    }
    let num = if v == r {
        let n = 30 * (g - b);
        if n < 0 {
            n + 180 * delta
        } else {
            n
        }
    } else if v == g {
        60 * delta + 30 * (b - r)
    } else {
        120 * delta + 30 * (r - g)
    };
    t.holds_hue(num, delta)
}

/// RGB (0..255) of OpenCV hue `h` (0..180), saturation and value (0..1 and 0..255).
pub(crate) fn rgb_of_hsv(h: f64, s: f64, v: f64) -> [f64; 3] {
    let h6 = (h / 30.0).rem_euclid(6.0);
    let c = v * s;
    let x = c * (1.0 - (h6 % 2.0 - 1.0).abs());
    let m = v - c;
    let (r, g, b) = match h6 as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    [r + m, g + m, b + m]
}

/// BT.601 limited-range chroma (Cb - 128, Cr - 128) of an RGB colour (0..255); the
/// full-range chroma is this times 255/224, so a positive bound on it holds for both.
pub(super) fn chroma_of_rgb(p: [f64; 3]) -> [f64; 2] {
    let [r, g, b] = p;
    [
        (-37.797 * r - 74.203 * g + 112.0 * b) / 255.0,
        (112.0 * r - 93.786 * g - 18.214 * b) / 255.0,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// OpenCV's RGB -> HSV for 8-bit images, in floating point (the reference).
    fn hsv_reference(r: u8, g: u8, b: u8) -> (f64, f64, f64) {
        let (r, g, b) = (r as f64, g as f64, b as f64);
        let v = r.max(g).max(b);
        let min = r.min(g).min(b);
        let s = if v > 0.0 { 255.0 * (v - min) / v } else { 0.0 };
        let d = v - min;
        let mut h = if d == 0.0 {
            0.0
        } else if v == r {
            60.0 * (g - b) / d
        } else if v == g {
            120.0 + 60.0 * (b - r) / d
        } else {
            240.0 + 60.0 * (r - g) / d
        };
        if h < 0.0 {
            h += 360.0;
        }
        (h / 2.0, s, v)
    }

    /// The band test on OpenCV's floating-point HSV (a grey pixel has no hue: it passes
    /// only a band of every hue).
    fn band_reference(r: u8, g: u8, b: u8, t: &HsvThresholds) -> bool {
        let (h, s, v) = hsv_reference(r, g, b);
        let (lo, hi) = (t.hue_min as f64, t.hue_max as f64);
        let hue_ok = t.every_hue()
            || (s > 0.0
                && if lo <= hi {
                    lo <= h && h <= hi
                } else {
                    h >= lo || h <= hi
                });
        hue_ok && s >= t.s_min as f64 && v >= t.v_min as f64 && v <= t.v_max as f64
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        #[test]
        fn integer_red_test_matches_opencv_hsv(r: u8, g: u8, b: u8) {
            let t = HsvThresholds::default();
            prop_assert_eq!(is_marker_colour(r, g, b, &t), band_reference(r, g, b, &t), "rgb {} {} {}", r, g, b);
        }

        #[test]
        fn integer_band_test_matches_opencv_hsv(r: u8, g: u8, b: u8, lo in 0u8..=180, hi in 0u8..=180, s_min: u8, v_min: u8, v_max: u8) {
            let t = HsvThresholds { hue_min: lo, hue_max: hi, s_min, v_min, v_max };
            prop_assert_eq!(is_marker_colour(r, g, b, &t), band_reference(r, g, b, &t), "rgb {} {} {} in {:?}", r, g, b, t);
        }
    }

    #[test]
    fn every_preset_passes_its_own_colour_and_not_the_others() {
        // Saturated paint of each colour as a camera sees it, and a red tube, a white
        // sheet and a grey shadow.
        let paint = [
            (MarkerColour::Red, [196, 28, 34]),
            (MarkerColour::Green, [40, 160, 70]),
            (MarkerColour::Blue, [30, 60, 180]),
            (MarkerColour::Yellow, [220, 190, 30]),
            (MarkerColour::Dark, [35, 32, 30]),
        ];
        for (colour, _) in paint {
            let t = colour.thresholds();
            for (other, [r, g, b]) in paint {
                assert_eq!(
                    is_marker_colour(r, g, b, &t),
                    colour == other,
                    "{colour:?} on {other:?}"
                );
            }
            for [r, g, b] in [[230, 228, 222], [120, 118, 115]] {
                assert!(
                    !is_marker_colour(r, g, b, &t),
                    "{colour:?} on grey {r} {g} {b}"
                );
            }
        }
    }

    #[test]
    fn hue_wraps_around_zero() {
        let t = HsvThresholds::default();
        // Hue ~2 (slightly orange) and ~178 (slightly magenta) are both red.
        assert!(is_marker_colour(200, 20, 10, &t));
        assert!(is_marker_colour(200, 10, 20, &t));
        // Orange (hue ~15) and pink-purple are not; nor pale or dark red.
        assert!(!is_marker_colour(200, 110, 10, &t));
        assert!(!is_marker_colour(200, 10, 120, &t));
        assert!(!is_marker_colour(214, 206, 188, &t));
        assert!(!is_marker_colour(40, 5, 5, &t));
    }
}
