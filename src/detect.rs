//! Marker detection: HSV colour mask, hole fill, speck removal, connected components and
//! sub-pixel centroids.
//!
//! The chain, per frame: [`mask_from_rgb`] (OpenCV's HSV convention, H in 0..180 with
//! red wrapping around 0/180, S and V in 0..255; the marker colour is a band of it:
//! [`MarkerColour`]'s presets red, green, blue, yellow, dark, or any hue band with
//! saturation and value bounds, [`HsvThresholds`]) -> [`blobs_from_mask`] (8-connected
//! components, holes filled, specks and oversized blobs dropped and counted) -> sub-pixel
//! centroids -> [`order_markers`] from the clamped end to the tip.
//!
//! Labelling is run-based (row runs joined with union-find), written here rather than
//! taken from `imageproc::region_labelling::connected_components` because a frame's mask
//! is almost empty: the run-based pass touches each mask row once and only the few
//! marker pixels after that, while a full-frame labelling allocates and writes a 32-bit
//! label for each of the two million pixels of a 1080p frame. The tests check it against
//! imageproc on random masks.
//!
//! Centroids are coverage-weighted: over the blob's box grown by [`RING_PX`], each pixel
//! counts by where its luma lies between the background's and the marker's (filled
//! holes count 1), so partly covered edge pixels contribute their fraction. This removes
//! most of the pixel-quantization error of a binary centroid on small (3 mm, ~8 px)
//! markers. Luma rather than redness: video is 4:2:0, its chroma has half the
//! resolution, and redness-weighted centroids of H.264 frames were measured to jump by
//! ~0.2 px with the marker's position on the chroma grid (0.4% radius bias at R = 200
//! mm); redness is the fallback when a marker is not darker or brighter than its
//! surroundings.

use image::{GrayImage, RgbImage};
use nalgebra::Point2;
use rayon::prelude::*;
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
/// Default smallest blob kept, px (smaller are specks: noise, reflections).
pub const DEFAULT_MIN_AREA_PX: u32 = 6;
/// Default largest blob kept, px (larger are other red objects).
pub const DEFAULT_MAX_AREA_PX: u32 = 20_000;
/// Smallest difference of the coverage cue (luma or redness, 0..255) between a marker
/// and its surroundings for coverage weighting; below it, binary centroids are used.
pub const MIN_COVERAGE_CONTRAST: f64 = 30.0;

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
fn any_case<'de, D, T: Copy>(d: D, what: &str, names: &[(&str, T)]) -> Result<T, D::Error>
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

impl<'de> Deserialize<'de> for ClampSide {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use ClampSide::*;
        any_case(
            d,
            "clamp_side",
            &[
                ("left", Left),
                ("right", Right),
                ("top", Top),
                ("bottom", Bottom),
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

/// `[detect]` as written in bendscope.toml: a preset `colour` and the keys that override
/// its band. Checked and resolved into [`DetectSettings`].
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DetectConfig {
    /// Preset colour (default red).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub colour: Option<MarkerColour>,
    /// Lowest hue of the band, 0..180.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hue_min: Option<i64>,
    /// Highest hue of the band, 0..180 (below `hue_min`: wraps through 0).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hue_max: Option<i64>,
    /// Red's two-band form: hue in [0, hue_max_low] (= `hue_max`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hue_max_low: Option<i64>,
    /// Red's two-band form: hue in [hue_min_high, 180] (= `hue_min`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hue_min_high: Option<i64>,
    /// Minimum saturation, 0..255.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub s_min: Option<i64>,
    /// Minimum value, 0..255.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v_min: Option<i64>,
    /// Maximum value, 0..255.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v_max: Option<i64>,
    /// Smallest blob kept, px.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_area_px: Option<u32>,
    /// Largest blob kept, px.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_area_px: Option<u32>,
    /// Fill holes inside blobs.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fill_holes: Option<bool>,
    /// Where the clamped end is in the first frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub clamp_side: Option<ClampSide>,
    /// Lower `v_min` (and `v_max`) in proportion when the frame is dim.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto_exposure: Option<bool>,
}

impl TryFrom<DetectConfig> for DetectSettings {
    type Error = String;

    fn try_from(c: DetectConfig) -> Result<Self, String> {
        let colour = c.colour.unwrap_or_default();
        let mut t = colour.thresholds();
        let level = |v: Option<i64>, max: i64| -> Result<Option<u8>, String> {
            match v {
                Some(v) if !(0..=max).contains(&v) => Err(format!(
                    "{v} is outside 0..{max}{}",
                    if max == HUE_MAX as i64 {
                        " (OpenCV's hue scale: degrees / 2)"
                    } else {
                        ""
                    }
                )),
                v => Ok(v.map(|v| v as u8)),
            }
        };
        let hue = HUE_MAX as i64;
        let (lo, hi) = (level(c.hue_min, hue)?, level(c.hue_max, hue)?);
        let (low, high) = (level(c.hue_max_low, hue)?, level(c.hue_min_high, hue)?);
        if (low.is_some() || high.is_some()) && (lo.is_some() || hi.is_some()) {
            return Err(
                "`hue_max_low`/`hue_min_high` (red's two bands) and `hue_min`/`hue_max` \
                 both given: keep one form"
                    .into(),
            );
        }
        if (low.is_some() || high.is_some()) && colour != MarkerColour::Red {
            return Err(format!(
                "`hue_max_low`/`hue_min_high` are red's bands, but colour = \"{}\": use `hue_min`/`hue_max`",
                serde_json::to_value(colour).ok().and_then(|v| v.as_str().map(String::from)).unwrap_or_default()
            ));
        }
        if let Some(h) = high.or(lo) {
            t.hue_min = h;
        }
        if let Some(h) = low.or(hi) {
            t.hue_max = h;
        }
        if let Some(s) = level(c.s_min, 255)? {
            t.s_min = s;
        }
        if let Some(v) = level(c.v_min, 255)? {
            t.v_min = v;
        }
        if let Some(v) = level(c.v_max, 255)? {
            t.v_max = v;
        }
        if t.v_min > t.v_max {
            return Err(format!(
                "`v_min` = {} is above `v_max` = {}: no pixel can pass",
                t.v_min, t.v_max
            ));
        }
        let d = DetectSettings::default();
        Ok(DetectSettings {
            hsv: t,
            min_area_px: c.min_area_px.unwrap_or(d.min_area_px),
            max_area_px: c.max_area_px.unwrap_or(d.max_area_px),
            fill_holes: c.fill_holes.unwrap_or(d.fill_holes),
            clamp_side: c.clamp_side.unwrap_or(d.clamp_side),
            auto_exposure: c.auto_exposure.unwrap_or(d.auto_exposure),
        })
    }
}

impl From<DetectSettings> for DetectConfig {
    fn from(s: DetectSettings) -> Self {
        let t = s.hsv;
        DetectConfig {
            colour: None,
            hue_min: Some(t.hue_min as i64),
            hue_max: Some(t.hue_max as i64),
            hue_max_low: None,
            hue_min_high: None,
            s_min: Some(t.s_min as i64),
            v_min: Some(t.v_min as i64),
            v_max: Some(t.v_max as i64),
            min_area_px: Some(s.min_area_px),
            max_area_px: Some(s.max_area_px),
            fill_holes: Some(s.fill_holes),
            clamp_side: Some(s.clamp_side),
            auto_exposure: Some(s.auto_exposure),
        }
    }
}

/// Which image side the clamped end of the actuator is nearest to (any case in
/// `[detect] clamp_side`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ClampSide {
    /// Clamp at the left of the frame.
    #[default]
    Left,
    /// Clamp at the right.
    Right,
    /// Clamp at the top.
    Top,
    /// Clamp at the bottom.
    Bottom,
}

/// Marker detection settings (read from `[detect]` through [`DetectConfig`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "DetectConfig", into = "DetectConfig")]
pub struct DetectSettings {
    /// The markers' colour band.
    pub hsv: HsvThresholds,
    /// Smallest blob kept, px.
    pub min_area_px: u32,
    /// Largest blob kept, px.
    pub max_area_px: u32,
    /// Fill holes (specular highlights) inside blobs before taking centroids.
    pub fill_holes: bool,
    /// Where the clamped end is, to order markers.
    pub clamp_side: ClampSide,
    /// Lower `v_min` in proportion when the frame is darker than a normally exposed
    /// white sheet (see [`exposure_adjusted`]).
    pub auto_exposure: bool,
}

/// White level of a normally exposed frame (the sheet behind the actuator), 8-bit.
pub const NOMINAL_WHITE: f64 = 230.0;
/// Lowest `v_min` the exposure adjustment goes to (below it sensor noise passes for
/// colour).
pub const MIN_ADJUSTED_V: u8 = 20;
/// Samples per side of the grid the white level is read on.
pub const EXPOSURE_GRID: u32 = 48;

/// The thresholds for this frame: `v_min` (and a dark marker's `v_max`) scaled by the
/// frame's white level (the 90th percentile of max(R, G, B) on a coarse grid) over
/// [`NOMINAL_WHITE`] when the frame is darker than that, `v_min` never below
/// [`MIN_ADJUSTED_V`]. A coloured marker in a dim frame keeps its hue and saturation but
/// loses value, and a dark marker's value falls with the light too; the white sheet tells
/// how much light there is.
pub fn exposure_adjusted<S: PixelSource>(img: &S, t: &HsvThresholds) -> HsvThresholds {
    let (w, h) = img.dimensions();
    if w == 0 || h == 0 {
        return *t;
    }
    let mut levels: Vec<u8> = Vec::with_capacity((EXPOSURE_GRID * EXPOSURE_GRID) as usize);
    for j in 0..EXPOSURE_GRID {
        for i in 0..EXPOSURE_GRID {
            let (x, y) = (
                ((2 * i + 1) * w / (2 * EXPOSURE_GRID)).min(w - 1),
                ((2 * j + 1) * h / (2 * EXPOSURE_GRID)).min(h - 1),
            );
            let p = img.rgb(x, y);
            levels.push(p[0].max(p[1]).max(p[2]));
        }
    }
    levels.sort_unstable();
    let white = levels[levels.len() * 9 / 10] as f64;
    if white >= NOMINAL_WHITE {
        return *t;
    }
    let scaled = |v: u8| (v as f64 * white / NOMINAL_WHITE).round() as u8;
    HsvThresholds {
        v_min: scaled(t.v_min).max(MIN_ADJUSTED_V).min(t.v_min),
        v_max: if t.v_max == 255 { 255 } else { scaled(t.v_max) },
        ..*t
    }
}

impl Default for DetectSettings {
    fn default() -> Self {
        Self {
            hsv: HsvThresholds::default(),
            min_area_px: DEFAULT_MIN_AREA_PX,
            max_area_px: DEFAULT_MAX_AREA_PX,
            fill_holes: true,
            clamp_side: ClampSide::Left,
            auto_exposure: true,
        }
    }
}

/// Random access to a frame's RGB pixels: an RGB image, or a decoded YUV 4:2:0 frame
/// converted pixel by pixel only where detection looks ([`crate::video::YuvFrame`]).
pub trait PixelSource: Sync {
    /// (width, height), px.
    fn dimensions(&self) -> (u32, u32);
    /// The RGB value at (x, y).
    fn rgb(&self, x: u32, y: u32) -> image::Rgb<u8>;
    /// Whether (x, y) has the marker colour of `t`; sources may reject cheaply first
    /// (see [`crate::video::YuvFrame`]).
    #[inline]
    fn is_marker_at(&self, x: u32, y: u32, t: &MarkerTest) -> bool {
        let p = self.rgb(x, y);
        t.matches(p[0], p[1], p[2])
    }
    /// Appends to `out` the x of every [`COARSE_STEP`]-th pixel of row `y` that has the
    /// marker colour of `t` (the coarse pass of [`mask_from_rgb_sparse`]); sources may
    /// skip runs of pixels that cannot pass (a YUV frame scans a chroma or luma row first).
    fn coarse_row_hits(&self, y: u32, t: &MarkerTest, out: &mut Vec<u32>) {
        coarse_row_hits_exact(self, y, t, out);
    }
}

/// [`PixelSource::coarse_row_hits`] by the exact test on every [`COARSE_STEP`]-th pixel.
pub fn coarse_row_hits_exact<S: PixelSource + ?Sized>(
    img: &S,
    y: u32,
    t: &MarkerTest,
    out: &mut Vec<u32>,
) {
    let (w, _) = img.dimensions();
    out.extend(
        (0..w)
            .step_by(COARSE_STEP as usize)
            .filter(|&x| img.is_marker_at(x, y, t)),
    );
}

impl PixelSource for RgbImage {
    fn dimensions(&self) -> (u32, u32) {
        image::GenericImageView::dimensions(self)
    }
    #[inline]
    fn rgb(&self, x: u32, y: u32) -> image::Rgb<u8> {
        *self.get_pixel(x, y)
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

/// Share of the smallest chroma excess of a band's pixels that the pre-test demands
/// ([`MarkerTest::pretest`]): the rest is room for the rounding and clamping of a YUV
/// sample's conversion to RGB. 3/7 keeps the red pre-test of a Cr excess of 3 at the
/// default thresholds (whose smallest excess is 7).
pub const PRETEST_SHARE: f64 = 3.0 / 7.0;
/// Length of the chroma direction of a [`Pretest::Chroma`] (integer components).
pub const PRETEST_DIRECTION: f64 = 64.0;

/// A necessary condition on a YUV sample (BT.601, 8-bit units; a 10-bit sample compares
/// with the bounds shifted by 2 bits) for its pixel to pass a colour band: what lets a
/// YUV frame skip most pixels without converting them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pretest {
    /// No cheap test applies: every pixel gets the exact test.
    None,
    /// Only samples with a (Cb - 128) + b (Cr - 128) >= k can pass.
    Chroma {
        /// Weight of Cb - 128.
        a: i32,
        /// Weight of Cr - 128.
        b: i32,
        /// Bound.
        k: i32,
    },
    /// Only samples with Y <= the bound can pass (dark markers).
    Luma {
        /// Bound for limited-range (16..235) luma.
        limited: i32,
        /// Bound for full-range luma.
        full: i32,
    },
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
fn chroma_of_rgb(p: [f64; 3]) -> [f64; 2] {
    let [r, g, b] = p;
    [
        (-37.797 * r - 74.203 * g + 112.0 * b) / 255.0,
        (112.0 * r - 93.786 * g - 18.214 * b) / 255.0,
    ]
}

impl Pretest {
    /// The strongest pre-test of band `t`. The chroma of a colour is linear in its RGB,
    /// and RGB is linear in S and V for a fixed hue and piecewise linear in the hue (its
    /// pieces meet at multiples of 30), so the smallest projection of the band's chroma
    /// on a direction is met at the band's edges or a multiple of 30 inside it, at
    /// S = s_min or 1 and V = v_min: those few colours give it exactly. Of the four
    /// chroma axes (one plane to scan) and the band's centre direction, the axis with the
    /// largest smallest projection is taken unless the centre's is over 1.4 times larger.
    pub fn of_band(t: &HsvThresholds) -> Pretest {
        if t.every_hue() {
            if t.s_min == 0 && t.v_max < 255 {
                // Y is a weighted mean of R, G, B, so never above V.
                let v = t.v_max as i32;
                return Pretest::Luma {
                    limited: 16 + (219 * v + 254) / 255 + 1,
                    full: v + 1,
                };
            }
            return Pretest::None;
        }
        if t.v_min == 0 {
            return Pretest::None;
        }
        let (lo, hi) = (t.hue_min as f64, t.hue_max as f64);
        let hi = if t.hue_min > t.hue_max {
            hi + 180.0
        } else {
            hi
        };
        let mut hues = vec![lo, hi];
        let mut m = (lo / 30.0).ceil() * 30.0;
        while m < hi {
            hues.push(m);
            m += 30.0;
        }
        let v = t.v_min as f64;
        let colours: Vec<[f64; 2]> = hues
            .iter()
            .flat_map(|&h| {
                [t.s_min as f64 / 255.0, 1.0].map(|s| chroma_of_rgb(rgb_of_hsv(h, s, v)))
            })
            .collect();
        let floor = |a: f64, b: f64| {
            colours
                .iter()
                .map(|c| a * c[0] + b * c[1])
                .fold(f64::INFINITY, f64::min)
        };
        let n = PRETEST_DIRECTION;
        let centre = chroma_of_rgb(rgb_of_hsv((lo + hi) / 2.0, 1.0, 255.0));
        let len = centre[0].hypot(centre[1]).max(1e-9);
        let (ca, cb) = ((n * centre[0] / len).round(), (n * centre[1] / len).round());
        let axes = [(0.0, n), (0.0, -n), (n, 0.0), (-n, 0.0)];
        let (aa, ab, af) = axes.iter().map(|&(a, b)| (a, b, floor(a, b))).fold(
            (0.0, 0.0, f64::NEG_INFINITY),
            |best, c| if c.2 > best.2 { c } else { best },
        );
        let cf = floor(ca, cb) * n / ca.hypot(cb).max(1e-9);
        let (a, b, f) = if cf > 1.4 * af {
            (ca, cb, floor(ca, cb))
        } else {
            (aa, ab, af)
        };
        let k = (f * PRETEST_SHARE).floor();
        if k <= 0.0 {
            return Pretest::None;
        }
        Pretest::Chroma {
            a: a as i32,
            b: b as i32,
            k: k as i32,
        }
    }
}

/// A colour band with its pre-test, made once per frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerTest {
    /// The band.
    pub band: HsvThresholds,
    /// The cheap necessary condition for YUV samples.
    pub pretest: Pretest,
}

impl MarkerTest {
    /// The test of band `t`.
    pub fn new(t: &HsvThresholds) -> Self {
        Self {
            band: *t,
            pretest: Pretest::of_band(t),
        }
    }

    /// Whether an RGB pixel passes.
    #[inline]
    pub fn matches(&self, r: u8, g: u8, b: u8) -> bool {
        is_marker_colour(r, g, b, &self.band)
    }
}

/// Marker mask (255 in the band, 0 not) of an RGB frame, rows in parallel.
pub fn mask_from_rgb(img: &RgbImage, t: &HsvThresholds) -> GrayImage {
    let (w, h) = img.dimensions();
    let mut mask = GrayImage::new(w, h);
    let src = img.as_raw();
    mask.as_mut()
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(y, row)| {
            let s = &src[y * w as usize * 3..(y + 1) * w as usize * 3];
            for (x, m) in row.iter_mut().enumerate() {
                let p = &s[x * 3..x * 3 + 3];
                *m = if is_marker_colour(p[0], p[1], p[2], t) {
                    255
                } else {
                    0
                };
            }
        });
    mask
}

/// Grid step of the coarse pass of [`mask_from_rgb_sparse`], px.
pub const COARSE_STEP: u32 = 2;
/// Margin added around coarse hits before the full-resolution pass, px.
pub const COARSE_MARGIN: u32 = 3;

/// The same mask as [`mask_from_rgb`], computed only where it can be non-zero: a coarse
/// pass tests every second pixel of every second row, and the full test runs only in
/// boxes around the coarse hits (grown by [`COARSE_MARGIN`]). A red region containing a
/// 2x2 block of red pixels is always found; smaller ones (isolated specks, which the
/// minimum area drops anyway) may be missed. On a 1080p frame with 8 markers this tests
/// about a quarter of the pixels.
pub fn mask_from_rgb_sparse<S: PixelSource>(img: &S, t: &HsvThresholds) -> GrayImage {
    let mut buf = MaskBuffer::default();
    mask_from_rgb_sparse_into(img, t, &mut buf);
    buf.mask
}

/// A red mask reused from frame to frame, with the rows its last frame may have set: the
/// next frame clears, and labelling scans, only those rows instead of the whole frame
/// (on a 4K frame a full clear and scan cost ~5% of the decode time).
#[derive(Debug, Clone)]
pub struct MaskBuffer {
    mask: GrayImage,
    /// Rows that may hold set pixels, ascending.
    rows: Vec<u32>,
}

impl Default for MaskBuffer {
    fn default() -> Self {
        Self {
            mask: GrayImage::new(0, 0),
            rows: Vec::new(),
        }
    }
}

impl MaskBuffer {
    /// The mask of the last frame (255 red, 0 not).
    pub fn mask(&self) -> &GrayImage {
        &self.mask
    }
}

/// [`mask_from_rgb_sparse`] into a reused mask buffer (resized, or cleared where the last
/// frame set it).
pub fn mask_from_rgb_sparse_into<S: PixelSource>(img: &S, t: &HsvThresholds, buf: &mut MaskBuffer) {
    let (w, h) = img.dimensions();
    if buf.mask.dimensions() != (w, h) {
        buf.mask = GrayImage::new(w, h);
    } else {
        for &y in &buf.rows {
            let i = (y * w) as usize;
            buf.mask.as_mut()[i..i + w as usize].fill(0);
        }
    }
    buf.rows.clear();
    let t = &MarkerTest::new(t);
    let mask = &mut buf.mask;
    // Coarse rows in parallel: x ranges of hits, as (row, x0, x1) in full-res px.
    let rows: Vec<(u32, Vec<(u32, u32)>)> = (0..h.div_ceil(COARSE_STEP))
        .into_par_iter()
        .filter_map(|cy| {
            let y = cy * COARSE_STEP;
            let mut hits = Vec::new();
            img.coarse_row_hits(y, t, &mut hits);
            let mut spans: Vec<(u32, u32)> = Vec::new();
            for x in hits {
                let x0 = x.saturating_sub(COARSE_MARGIN);
                let x1 = (x + COARSE_MARGIN + 1).min(w);
                match spans.last_mut() {
                    Some(last) if last.1 >= x0 => last.1 = x1,
                    _ => spans.push((x0, x1)),
                }
            }
            (!spans.is_empty()).then_some((y, spans))
        })
        .collect();
    let mut touched = vec![false; h as usize];
    for (y, spans) in rows {
        let ya = y.saturating_sub(COARSE_MARGIN);
        let yb = (y + COARSE_MARGIN + 1).min(h);
        for yy in ya..yb {
            touched[yy as usize] = true;
            for &(x0, x1) in &spans {
                for x in x0..x1 {
                    if img.is_marker_at(x, yy, t) {
                        mask.put_pixel(x, yy, image::Luma([255]));
                    }
                }
            }
        }
    }
    buf.rows.extend((0..h).filter(|&y| touched[y as usize]));
}

/// A marker candidate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Blob {
    /// Sub-pixel centroid, px.
    pub centroid: Point2<f64>,
    /// Area of the filled blob, px.
    pub area_px: u32,
    /// Bounding box: min x, min y, max x, max y (inclusive), px.
    pub bbox: [u32; 4],
}

/// Blobs of a mask and what was dropped.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Detection {
    /// Kept blobs (not ordered).
    pub blobs: Vec<Blob>,
    /// Blobs smaller than the minimum area.
    pub specks: usize,
    /// Blobs larger than the maximum area.
    pub too_large: usize,
}

/// A horizontal run of mask pixels.
#[derive(Debug, Clone, Copy)]
struct Run {
    y: u32,
    x0: u32,
    x1: u32, // exclusive
    label: usize,
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Runs of each row, labelled into 8-connected components; returns runs grouped by
/// component.
fn components(mask: &GrayImage) -> Vec<Vec<Run>> {
    components_in_rows(mask, 0..mask.height())
}

/// [`components`] of the mask restricted to `rows` (ascending; the other rows must be
/// empty).
fn components_in_rows(mask: &GrayImage, rows: impl IntoIterator<Item = u32>) -> Vec<Vec<Run>> {
    let w = mask.width();
    let raw = mask.as_raw();
    let mut runs: Vec<Run> = Vec::new();
    let mut parent: Vec<usize> = Vec::new();
    let mut prev: std::ops::Range<usize> = 0..0;
    let mut last_row: Option<u32> = None;
    for y in rows {
        if last_row.is_none_or(|l| l + 1 != y) {
            prev = 0..0;
        }
        last_row = Some(y);
        let row = &raw[(y * w) as usize..((y + 1) * w) as usize];
        let start = runs.len();
        let mut x = 0usize;
        while x < row.len() {
            match row[x..].iter().position(|&v| v != 0) {
                None => break,
                Some(off) => {
                    let x0 = x + off;
                    let len = row[x0..]
                        .iter()
                        .position(|&v| v == 0)
                        .unwrap_or(row.len() - x0);
                    let label = parent.len();
                    parent.push(label);
                    runs.push(Run {
                        y,
                        x0: x0 as u32,
                        x1: (x0 + len) as u32,
                        label,
                    });
                    x = x0 + len;
                }
            }
        }
        // Join with overlapping runs of the previous row (8-connectivity: touching
        // diagonally counts).
        let cur = start..runs.len();
        let mut j = prev.start;
        for i in cur.clone() {
            let (a0, a1) = (runs[i].x0, runs[i].x1);
            while j < prev.end && runs[j].x1 < a0 {
                j += 1;
            }
            let mut k = j;
            while k < prev.end && runs[k].x0 <= a1 {
                let (ra, rb) = (
                    find(&mut parent, runs[i].label),
                    find(&mut parent, runs[k].label),
                );
                if ra != rb {
                    parent[ra.max(rb)] = ra.min(rb);
                }
                k += 1;
            }
        }
        prev = cur;
    }
    let mut groups: std::collections::BTreeMap<usize, Vec<Run>> = std::collections::BTreeMap::new();
    for r in &runs {
        let root = find(&mut parent, r.label);
        groups.entry(root).or_default().push(*r);
    }
    groups.into_values().collect()
}

/// Filled pixel mask of one component in its bounding box (holes filled when asked).
fn filled_component(runs: &[Run], fill: bool) -> (u32, u32, u32, u32, Vec<bool>) {
    let x0 = runs.iter().map(|r| r.x0).min().unwrap_or(0);
    let x1 = runs.iter().map(|r| r.x1).max().unwrap_or(0);
    let y0 = runs.iter().map(|r| r.y).min().unwrap_or(0);
    let y1 = runs.iter().map(|r| r.y).max().unwrap_or(0) + 1;
    let (bw, bh) = ((x1 - x0) as usize, (y1 - y0) as usize);
    let mut inside = vec![false; bw * bh];
    for r in runs {
        let row = (r.y - y0) as usize * bw;
        for x in r.x0..r.x1 {
            inside[row + (x - x0) as usize] = true;
        }
    }
    if fill {
        // Background reachable from the box border stays background; the rest are holes
        // (4-connected background, the complement of 8-connected foreground).
        let mut outside = vec![false; bw * bh];
        let mut stack: Vec<(usize, usize)> = Vec::new();
        for x in 0..bw {
            stack.push((x, 0));
            stack.push((x, bh - 1));
        }
        for y in 0..bh {
            stack.push((0, y));
            stack.push((bw - 1, y));
        }
        while let Some((x, y)) = stack.pop() {
            let i = y * bw + x;
            if inside[i] || outside[i] {
                continue;
            }
            outside[i] = true;
            if x > 0 {
                stack.push((x - 1, y));
            }
            if x + 1 < bw {
                stack.push((x + 1, y));
            }
            if y > 0 {
                stack.push((x, y - 1));
            }
            if y + 1 < bh {
                stack.push((x, y + 1));
            }
        }
        for (v, o) in inside.iter_mut().zip(&outside) {
            *v = !*o;
        }
    }
    (x0, y0, x1, y1, inside)
}

/// Redness r - max(g, b) of a pixel (carried by chroma).
#[inline]
fn redness(p: &image::Rgb<u8>) -> f64 {
    p[0] as f64 - (p[1].max(p[2])) as f64
}

/// Chroma max(r, g, b) - min(r, g, b) of a pixel: the fallback cue of markers of other
/// colours than red.
#[inline]
fn chroma(p: &image::Rgb<u8>) -> f64 {
    p[0].max(p[1]).max(p[2]) as f64 - p[0].min(p[1]).min(p[2]) as f64
}

/// Luma (Rec. 601) of a pixel: full resolution in 4:2:0 video, where chroma (and so
/// redness) has half the resolution in both directions.
#[inline]
fn luma(p: &image::Rgb<u8>) -> f64 {
    0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64
}

/// Pixels of the ring around a blob used to weigh edge coverage.
pub const RING_PX: u32 = 2;

/// Levels of a cue (`value` of a pixel) for coverage weighting: the background around a
/// blob (median of the surrounding ring), the fully covered marker (median of the
/// blob's inner half, the pixels farthest from the background level) and the coverage
/// below which a pixel is taken as background noise (2 robust sigmas of the ring, 1.4826
/// x its median absolute deviation, over the contrast); `None` when the levels differ by
/// less than [`MIN_COVERAGE_CONTRAST`].
fn cue_levels<S: PixelSource>(
    img: &S,
    inside: &[bool],
    bbox: (u32, u32, u32, u32),
    value: fn(&image::Rgb<u8>) -> f64,
) -> Option<(f64, f64, f64)> {
    let (x0, y0, x1, y1) = bbox;
    let (w, h) = img.dimensions();
    let bw = (x1 - x0) as usize;
    let mut inner: Vec<f64> = Vec::new();
    let mut ring: Vec<f64> = Vec::new();
    let (ex0, ey0) = (x0.saturating_sub(RING_PX), y0.saturating_sub(RING_PX));
    let (ex1, ey1) = ((x1 + RING_PX).min(w), (y1 + RING_PX).min(h));
    for y in ey0..ey1 {
        for x in ex0..ex1 {
            let in_box = x >= x0 && x < x1 && y >= y0 && y < y1;
            let v = value(&img.rgb(x, y));
            if in_box && inside[(y - y0) as usize * bw + (x - x0) as usize] {
                inner.push(v);
            } else if !in_box {
                ring.push(v);
            }
        }
    }
    if inner.is_empty() || ring.is_empty() {
        return None;
    }
    ring.sort_by(f64::total_cmp);
    let bg = ring[ring.len() / 2];
    inner.sort_by(|a, b| (b - bg).abs().total_cmp(&(a - bg).abs()));
    let core = &inner[..inner.len().div_ceil(2)];
    let full = core[core.len() / 2];
    let mut dev: Vec<f64> = ring.iter().map(|v| (v - bg).abs()).collect();
    dev.sort_by(f64::total_cmp);
    let floor = 2.0 * 1.4826 * dev[dev.len() / 2] / (full - bg).abs().max(1e-9);
    ((full - bg).abs() > MIN_COVERAGE_CONTRAST).then_some((bg, full, floor.min(0.5)))
}

/// Blobs of a red mask, with coverage-weighted centroids from `img` (the frame the mask
/// was made from; pass `None` for plain binary centroids).
pub fn blobs_from_mask<S: PixelSource>(
    mask: &GrayImage,
    img: Option<&S>,
    settings: &DetectSettings,
) -> Detection {
    blobs_from_components(mask, components(mask), img, settings)
}

/// [`blobs_from_mask`] of a [`MaskBuffer`], labelling only the rows its frame set.
pub fn blobs_from_buffer<S: PixelSource>(
    buf: &MaskBuffer,
    img: Option<&S>,
    settings: &DetectSettings,
) -> Detection {
    let comps = components_in_rows(&buf.mask, buf.rows.iter().copied());
    blobs_from_components(&buf.mask, comps, img, settings)
}

fn blobs_from_components<S: PixelSource>(
    mask: &GrayImage,
    comps: Vec<Vec<Run>>,
    img: Option<&S>,
    settings: &DetectSettings,
) -> Detection {
    let mut out = Detection::default();
    let (w, h) = mask.dimensions();
    for runs in comps {
        let raw_area: u32 = runs.iter().map(|r| r.x1 - r.x0).sum();
        if raw_area > settings.max_area_px {
            out.too_large += 1;
            continue;
        }
        let (x0, y0, x1, y1, inside) = filled_component(&runs, settings.fill_holes);
        let bw = (x1 - x0) as usize;
        let area = inside.iter().filter(|v| **v).count() as u32;
        if area < settings.min_area_px {
            out.specks += 1;
            continue;
        }
        let (mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0);
        let mut add = |x: u32, y: u32, c: f64| {
            sw += c;
            sx += c * x as f64;
            sy += c * y as f64;
        };
        // Coverage cue: luma (full resolution even in 4:2:0 video) when the marker
        // stands out from its surroundings in brightness, else redness (chroma for
        // markers of other colours).
        let colour_cue: fn(&image::Rgb<u8>) -> f64 = if settings.hsv.holds_red() {
            redness
        } else {
            chroma
        };
        let cue = img.and_then(|img| {
            let bbox = (x0, y0, x1, y1);
            cue_levels(img, &inside, bbox, luma)
                .map(|l| (img, l, luma as fn(&image::Rgb<u8>) -> f64))
                .or_else(|| {
                    cue_levels(img, &inside, bbox, colour_cue).map(|l| (img, l, colour_cue))
                })
        });
        match cue {
            Some((img, (bg, full, floor), value)) => {
                // Coverage over the blob's box grown by the ring; filled holes count fully.
                let (ex0, ey0) = (x0.saturating_sub(RING_PX), y0.saturating_sub(RING_PX));
                let (ex1, ey1) = ((x1 + RING_PX).min(w), (y1 + RING_PX).min(h));
                for y in ey0..ey1 {
                    for x in ex0..ex1 {
                        let in_box = x >= x0 && x < x1 && y >= y0 && y < y1;
                        let filled = in_box && inside[(y - y0) as usize * bw + (x - x0) as usize];
                        let c = if filled && mask.get_pixel(x, y)[0] == 0 {
                            1.0
                        } else {
                            let c = ((value(&img.rgb(x, y)) - bg) / (full - bg)).clamp(0.0, 1.0);
                            // Background pixels whose noise reads as coverage count 0.
                            if c < floor && !filled {
                                0.0
                            } else {
                                c
                            }
                        };
                        add(x, y, c);
                    }
                }
            }
            _ => {
                for (i, v) in inside.iter().enumerate() {
                    if *v {
                        add((i % bw) as u32 + x0, (i / bw) as u32 + y0, 1.0);
                    }
                }
            }
        }
        out.blobs.push(Blob {
            centroid: Point2::new(sx / sw, sy / sw),
            area_px: area,
            bbox: [x0, y0, x1 - 1, y1 - 1],
        });
    }
    out
}

/// The whole chain on one RGB frame: mask, components, filtering, centroids.
pub fn detect_markers(img: &RgbImage, settings: &DetectSettings) -> Detection {
    detect_markers_with(img, settings, &mut MaskBuffer::default())
}

/// [`detect_markers`] with a mask buffer reused from frame to frame.
pub fn detect_markers_with<S: PixelSource>(
    img: &S,
    settings: &DetectSettings,
    mask: &mut MaskBuffer,
) -> Detection {
    let hsv = if settings.auto_exposure {
        exposure_adjusted(img, &settings.hsv)
    } else {
        settings.hsv
    };
    mask_from_rgb_sparse_into(img, &hsv, mask);
    blobs_from_buffer(mask, Some(img), settings)
}

/// Where the marker chain starts (the clamped end).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ChainStart {
    /// The end of the chain nearest this image side (first frame of a session).
    Side(ClampSide),
    /// The end of the chain nearest this point: the clamped-end marker of an earlier
    /// frame. Needed once an actuator curls past 180 degrees and its tip comes nearer to
    /// the clamp side than the clamped end.
    Near(Point2<f64>),
}

/// Orders marker points from the clamped end to the tip. The markers form a chain along
/// the actuator; its minimum spanning tree is that chain (a path) and its two ends are
/// the clamped end and the tip; `start` says which is which. When the tree is not a path
/// (irregular spacing), a nearest-neighbour walk from the chosen end is used.
pub fn order_markers(points: &[Point2<f64>], start: ChainStart) -> Vec<Point2<f64>> {
    order_marker_indices(points, start)
        .into_iter()
        .map(|i| points[i])
        .collect()
}

/// [`order_markers`] as indices into `points`.
pub fn order_marker_indices(points: &[Point2<f64>], start: ChainStart) -> Vec<usize> {
    let n = points.len();
    if n < 3 {
        let mut v: Vec<usize> = (0..n).collect();
        v.sort_by(|a, b| chain_key(&points[*a], start).total_cmp(&chain_key(&points[*b], start)));
        return v;
    }
    // Prim's algorithm, O(n²): n is the marker count.
    let d = |i: usize, j: usize| (points[i] - points[j]).norm_squared();
    let mut in_tree = vec![false; n];
    let mut best = vec![f64::INFINITY; n];
    let mut link = vec![0usize; n];
    let mut adj: Vec<Vec<usize>> = vec![vec![]; n];
    in_tree[0] = true;
    for j in 1..n {
        best[j] = d(0, j);
    }
    for _ in 1..n {
        let Some(k) = (0..n)
            .filter(|j| !in_tree[*j])
            .min_by(|a, b| best[*a].total_cmp(&best[*b]))
        else {
            break;
        };
        in_tree[k] = true;
        adj[k].push(link[k]);
        adj[link[k]].push(k);
        for j in 0..n {
            if !in_tree[j] && d(k, j) < best[j] {
                best[j] = d(k, j);
                link[j] = k;
            }
        }
    }
    let ends: Vec<usize> = (0..n).filter(|i| adj[*i].len() == 1).collect();
    let is_path = ends.len() == 2 && adj.iter().all(|a| a.len() <= 2);
    let candidates: Vec<usize> = if is_path { ends } else { (0..n).collect() };
    let first = candidates
        .iter()
        .copied()
        .min_by(|a, b| chain_key(&points[*a], start).total_cmp(&chain_key(&points[*b], start)))
        .unwrap_or(0);
    let mut order = vec![first];
    let mut seen = vec![false; n];
    seen[first] = true;
    while order.len() < n {
        let last = order[order.len() - 1];
        let next = if is_path {
            adj[last].iter().copied().find(|j| !seen[*j])
        } else {
            (0..n)
                .filter(|j| !seen[*j])
                .min_by(|a, b| d(last, *a).total_cmp(&d(last, *b)))
        };
        match next {
            Some(j) => {
                seen[j] = true;
                order.push(j);
            }
            None => break,
        }
    }
    order
}

/// Smaller is nearer the chain's start.
fn chain_key(p: &Point2<f64>, start: ChainStart) -> f64 {
    match start {
        ChainStart::Side(ClampSide::Left) => p.x,
        ChainStart::Side(ClampSide::Right) => -p.x,
        ChainStart::Side(ClampSide::Top) => p.y,
        ChainStart::Side(ClampSide::Bottom) => -p.y,
        ChainStart::Near(q) => (p - q).norm_squared(),
    }
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
    fn detect_config_resolves_presets_and_names_bad_keys() {
        let read = |text: &str| -> Result<DetectSettings, String> {
            toml::from_str::<DetectSettings>(text).map_err(|e| e.message().to_string())
        };
        assert_eq!(read("").unwrap(), DetectSettings::default());
        let green = read("colour = \"green\"\ns_min = 60\n").unwrap();
        assert_eq!(
            (green.hsv.hue_min, green.hsv.hue_max, green.hsv.s_min),
            (35, 85, 60)
        );
        // Red's two-band form is the wrapping band.
        let red = read("hue_max_low = 8\nhue_min_high = 172\n").unwrap();
        assert_eq!((red.hsv.hue_min, red.hsv.hue_max), (172, 8));
        // Any case, as `--family` takes it.
        for text in [
            "colour = \"Green\"\ns_min = 60\n",
            "colour = \"GREEN\"\ns_min = 60\n",
        ] {
            assert_eq!(read(text).unwrap(), green, "{text}");
        }
        assert_eq!(
            read("clamp_side = \"Right\"\n").unwrap().clamp_side,
            ClampSide::Right
        );
        let dark = read("colour = \"dark\"\nv_max = 70\n").unwrap();
        assert!(dark.hsv.every_hue() && dark.hsv.v_max == 70);
        for (text, needle) in [
            ("hue_min = 200\nhue_max = 10\n", "200 is outside 0..180"),
            (
                "colour = \"purple\"\n",
                "unknown colour `purple`: use one of red, green, blue, yellow, dark",
            ),
            (
                "clamp_side = \"middle\"\n",
                "unknown clamp_side `middle`: use one of left, right, top, bottom",
            ),
            ("hue_max_low = 8\nhue_max = 9\n", "keep one form"),
            (
                "colour = \"blue\"\nhue_max_low = 8\n",
                "use `hue_min`/`hue_max`",
            ),
            ("v_min = 90\nv_max = 80\n", "no pixel can pass"),
        ] {
            let e = read(text).unwrap_err();
            assert!(e.contains(needle), "{text:?}: {e}");
        }
        // Written back and read again: the same settings.
        let text = toml::to_string(&green).unwrap();
        assert_eq!(read(&text).unwrap(), green);
    }

    /// The pre-test never rejects a pixel of the band: checked on every colour of the
    /// band's edges and centre at random S and V (the smallest projection is met at the
    /// extremal colours, see [`Pretest::of_band`]), 8-bit limited range.
    #[test]
    fn pretest_floors_hold_for_every_preset() {
        for colour in [
            MarkerColour::Red,
            MarkerColour::Green,
            MarkerColour::Blue,
            MarkerColour::Yellow,
        ] {
            let t = colour.thresholds();
            let Pretest::Chroma { a, b, k } = Pretest::of_band(&t) else {
                panic!("{colour:?}: no chroma pre-test");
            };
            let mut worst = f64::INFINITY;
            for r in 0..=255u8 {
                for g in (0..=255u8).step_by(3) {
                    for bl in (0..=255u8).step_by(3) {
                        if is_marker_colour(r, g, bl, &t) {
                            let c = chroma_of_rgb([r as f64, g as f64, bl as f64]);
                            worst = worst.min(a as f64 * c[0] + b as f64 * c[1]);
                        }
                    }
                }
            }
            assert!(
                worst >= k as f64 / PRETEST_SHARE - 1e-6,
                "{colour:?}: {worst} below {}",
                k as f64 / PRETEST_SHARE
            );
        }
        // Red keeps a one-plane Cr pre-test at least as strong as its former Cr - 128 >= 3.
        let red = Pretest::of_band(&HsvThresholds::default());
        assert!(
            matches!(red, Pretest::Chroma { a: 0, b: 64, k } if k >= 3 * 64),
            "{red:?}"
        );
        assert!(matches!(
            Pretest::of_band(&MarkerColour::Dark.thresholds()),
            Pretest::Luma { .. }
        ));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        /// Discs of radius >= 2.5 px always hold a 2x2 block of fully red pixels, which
        /// the coarse grid cannot miss (smaller regions may be missed, as documented).
        #[test]
        fn sparse_mask_equals_full_mask_for_discs(seed: u64) {
            let mut rng = crate::render::rng::SplitMix64::new(seed);
            let discs: Vec<(f64, f64, f64)> = (0..6)
                .map(|_| (rng.range(0.0, 120.0), rng.range(0.0, 90.0), rng.range(2.5, 9.0)))
                .collect();
            let img = disc(120, 90, &discs);
            let t = HsvThresholds::default();
            prop_assert_eq!(mask_from_rgb_sparse(&img, &t), mask_from_rgb(&img, &t));
        }
    }

    #[test]
    fn a_reused_mask_buffer_forgets_the_last_frame() {
        let t = HsvThresholds::default();
        let s = DetectSettings::default();
        let first = disc(120, 90, &[(20.0, 20.0, 6.0), (90.0, 70.0, 5.0)]);
        let second = disc(120, 90, &[(60.0, 45.0, 7.0), (90.0, 72.0, 4.0)]);
        let mut buf = MaskBuffer::default();
        mask_from_rgb_sparse_into(&first, &t, &mut buf);
        assert_eq!(blobs_from_buffer(&buf, Some(&first), &s).blobs.len(), 2);
        mask_from_rgb_sparse_into(&second, &t, &mut buf);
        assert_eq!(buf.mask(), &mask_from_rgb(&second, &t));
        assert_eq!(
            blobs_from_buffer(&buf, Some(&second), &s),
            blobs_from_mask(&mask_from_rgb(&second, &t), Some(&second), &s)
        );
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

    fn disc(w: u32, h: u32, discs: &[(f64, f64, f64)]) -> RgbImage {
        // Anti-aliased discs by 8x8 supersampling.
        RgbImage::from_fn(w, h, |x, y| {
            let mut cov = 0.0;
            for sy in 0..8 {
                for sx in 0..8 {
                    let (px, py) = (
                        x as f64 - 0.5 + (sx as f64 + 0.5) / 8.0,
                        y as f64 - 0.5 + (sy as f64 + 0.5) / 8.0,
                    );
                    if discs
                        .iter()
                        .any(|(cx, cy, r)| (px - cx).hypot(py - cy) <= *r)
                    {
                        cov += 1.0 / 64.0;
                    }
                }
            }
            let mix = |a: f64, b: f64| (a * cov + b * (1.0 - cov)).round() as u8;
            image::Rgb([mix(196.0, 230.0), mix(28.0, 228.0), mix(34.0, 222.0)])
        })
    }

    #[test]
    fn subpixel_centroids_of_antialiased_discs() {
        let centres = [(20.3, 15.7, 4.0), (50.55, 18.2, 10.0), (80.9, 40.1, 4.0)];
        let img = disc(100, 60, &centres);
        let d = detect_markers(&img, &DetectSettings::default());
        assert_eq!(d.blobs.len(), 3);
        for (cx, cy, r) in centres {
            let b = d
                .blobs
                .iter()
                .min_by(|a, b| {
                    (a.centroid - Point2::new(cx, cy))
                        .norm()
                        .total_cmp(&(b.centroid - Point2::new(cx, cy)).norm())
                })
                .unwrap();
            let err = (b.centroid - Point2::new(cx, cy)).norm();
            let tol = if r >= 10.0 { 0.05 } else { 0.08 };
            assert!(
                err < tol,
                "disc r {r} at ({cx},{cy}): centroid {} off by {err}",
                b.centroid
            );
        }
    }

    #[test]
    fn holes_are_filled_and_specks_dropped() {
        let mut m = GrayImage::new(12, 10);
        for y in 2..7 {
            for x in 2..7 {
                m.put_pixel(x, y, image::Luma([255]));
            }
        }
        m.put_pixel(4, 4, image::Luma([0])); // a hole (highlight)
        m.put_pixel(10, 8, image::Luma([255])); // a speck
        let s = DetectSettings {
            min_area_px: 3,
            ..Default::default()
        };
        let d = blobs_from_mask::<RgbImage>(&m, None, &s);
        assert_eq!(d.blobs.len(), 1);
        assert_eq!(d.specks, 1);
        assert_eq!(d.blobs[0].area_px, 25);
        assert_eq!(d.blobs[0].centroid, Point2::new(4.0, 4.0));
        assert_eq!(d.blobs[0].bbox, [2, 2, 6, 6]);
        let no_fill = DetectSettings {
            fill_holes: false,
            ..s
        };
        assert_eq!(
            blobs_from_mask::<RgbImage>(&m, None, &no_fill).blobs[0].area_px,
            24
        );
        let small_max = DetectSettings {
            max_area_px: 10,
            ..s
        };
        assert_eq!(
            blobs_from_mask::<RgbImage>(&m, None, &small_max).too_large,
            1
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn run_labelling_matches_imageproc(seed: u64, density in 0.05f64..0.6) {
            let mut rng = crate::render::rng::SplitMix64::new(seed);
            let m = GrayImage::from_fn(40, 30, |_, _| image::Luma([if rng.uniform() < density { 255 } else { 0 }]));
            let ours = components(&m);
            let labels = imageproc::region_labelling::connected_components(&m, imageproc::region_labelling::Connectivity::Eight, image::Luma([0u8]));
            let n_ref = labels.pixels().map(|p| p[0]).max().unwrap_or(0) as usize;
            prop_assert_eq!(ours.len(), n_ref);
            // Every component of ours has one imageproc label, and sizes agree.
            let mut sizes_ours: Vec<u32> = ours.iter().map(|c| c.iter().map(|r| r.x1 - r.x0).sum()).collect();
            let mut sizes_ref = vec![0u32; n_ref + 1];
            for p in labels.pixels() { sizes_ref[p[0] as usize] += 1; }
            let mut sizes_ref: Vec<u32> = sizes_ref[1..].to_vec();
            sizes_ours.sort();
            sizes_ref.sort();
            prop_assert_eq!(sizes_ours, sizes_ref);
        }
    }

    #[test]
    fn ordering_follows_a_curled_actuator() {
        // Markers on a 270° arc leaving the clamp at (50, 100) towards +x and curling up
        // and back: the tip ends left of the clamped end, so only tracking the clamped
        // end (not the clamp side) orders it right.
        let pts: Vec<Point2<f64>> = (0..8)
            .map(|i| {
                let t = 270f64.to_radians() * i as f64 / 7.0;
                Point2::new(50.0 + 50.0 * t.sin(), 50.0 + 50.0 * t.cos())
            })
            .collect();
        let mut shuffled = pts.clone();
        shuffled.reverse();
        shuffled.swap(1, 5);
        assert_eq!(
            order_markers(&shuffled, ChainStart::Near(Point2::new(48.0, 101.0))),
            pts
        );
        // A gentle bend: the clamp side suffices, and sorting would too.
        let gentle: Vec<Point2<f64>> = (0..8)
            .map(|i| {
                let t = 60f64.to_radians() * i as f64 / 7.0;
                Point2::new(50.0 + 100.0 * t.sin(), 100.0 * t.cos())
            })
            .collect();
        let mut s2 = gentle.clone();
        s2.swap(0, 6);
        assert_eq!(
            order_markers(&s2, ChainStart::Side(ClampSide::Left)),
            gentle
        );
    }
}
