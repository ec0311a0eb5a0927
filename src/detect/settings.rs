//! `[detect]` as written in bendscope.toml ([`DetectConfig`]) and as checked
//! ([`DetectSettings`]): the colour band, the blob size limits, hole filling, the clamp
//! side and the exposure adjustment.

use serde::{Deserialize, Serialize};

use super::colour::{any_case, HsvThresholds, MarkerColour, HUE_MAX};
use super::outline::{DetectMode, OutlineSettings};

/// Default smallest blob kept, px (smaller are specks: noise, reflections).
pub const DEFAULT_MIN_AREA_PX: u32 = 6;
/// Default largest blob kept, px (larger are other red objects).
pub const DEFAULT_MAX_AREA_PX: u32 = 20_000;

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
    /// What is detected: "dots" (default) or "outline" (the body's edge, no dots).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mode: Option<DetectMode>,
    /// Outline mode: signed distance from the fitted edge to the reported line, mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outline_offset_mm: Option<f64>,
    /// Outline mode: body length next to the clamp left out, mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outline_clamp_mm: Option<f64>,
    /// Outline mode: lowest hue of the body's band, 0..180.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outline_hue_min: Option<i64>,
    /// Outline mode: highest hue of the body's band, 0..180.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outline_hue_max: Option<i64>,
    /// Outline mode: minimum saturation of the body, 0..255.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outline_s_min: Option<i64>,
    /// Outline mode: minimum value of the body, 0..255.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outline_v_min: Option<i64>,
    /// Outline mode: maximum value of the body, 0..255.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outline_v_max: Option<i64>,
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
        let outline = resolve_outline(&c, &level)?;
        Ok(DetectSettings {
            mode: c.mode.unwrap_or_default(),
            outline,
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
            ..outline_written(s.mode, &s.outline)
        }
    }
}

/// The outline settings of a `[detect]` table (defaults for the keys left out); `level`
/// checks a colour level against its largest value. A NaN, infinite or (for the clamp
/// length) negative length is refused.
fn resolve_outline(
    c: &DetectConfig,
    level: &impl Fn(Option<i64>, i64) -> Result<Option<u8>, String>,
) -> Result<OutlineSettings, String> {
    let d = OutlineSettings::default();
    let mut band = d.band;
    let hue = HUE_MAX as i64;
    if let Some(v) = level(c.outline_hue_min, hue)? {
        band.hue_min = v;
    }
    if let Some(v) = level(c.outline_hue_max, hue)? {
        band.hue_max = v;
    }
    if let Some(v) = level(c.outline_s_min, 255)? {
        band.s_min = v;
    }
    if let Some(v) = level(c.outline_v_min, 255)? {
        band.v_min = v;
    }
    if let Some(v) = level(c.outline_v_max, 255)? {
        band.v_max = v;
    }
    if band.v_min > band.v_max {
        return Err(format!(
            "`outline_v_min` = {} is above `outline_v_max` = {}: no pixel can pass",
            band.v_min, band.v_max
        ));
    }
    let offset_mm = c.outline_offset_mm.unwrap_or(d.offset_mm);
    if !offset_mm.is_finite() {
        return Err(format!(
            "`outline_offset_mm` = {offset_mm}: must be a finite number of mm (0: the edge itself)"
        ));
    }
    let clamp_mm = c.outline_clamp_mm.unwrap_or(d.clamp_mm);
    if !(clamp_mm.is_finite() && clamp_mm >= 0.0) {
        return Err(format!(
            "`outline_clamp_mm` = {clamp_mm}: must be a length of 0 mm or more"
        ));
    }
    Ok(OutlineSettings {
        band,
        offset_mm,
        clamp_mm,
    })
}

/// The `[detect]` keys of the outline mode as written back: none in dots mode (a dots
/// session's config reads as before), all of them in outline mode.
fn outline_written(mode: DetectMode, o: &OutlineSettings) -> DetectConfig {
    if mode == DetectMode::Dots {
        return Default::default();
    }
    DetectConfig {
        mode: Some(mode),
        outline_offset_mm: Some(o.offset_mm),
        outline_clamp_mm: Some(o.clamp_mm),
        outline_hue_min: Some(o.band.hue_min as i64),
        outline_hue_max: Some(o.band.hue_max as i64),
        outline_s_min: Some(o.band.s_min as i64),
        outline_v_min: Some(o.band.v_min as i64),
        outline_v_max: Some(o.band.v_max as i64),
        ..Default::default()
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
    /// white sheet (see [`exposure_adjusted`](super::exposure_adjusted)).
    pub auto_exposure: bool,
    /// Dots or the body's outline.
    pub mode: DetectMode,
    /// The outline mode's band, offset and clamp length.
    pub outline: OutlineSettings,
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
            mode: DetectMode::Dots,
            outline: OutlineSettings::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        // Dots mode writes no outline key; outline mode writes them all back.
        assert!(
            !text.contains("outline") && !text.contains("mode"),
            "{text}"
        );
        let outline =
            read("mode = \"Outline\"\noutline_offset_mm = -3.5\noutline_s_min = 30\n").unwrap();
        assert_eq!(outline.mode, DetectMode::Outline);
        assert_eq!(
            (outline.outline.offset_mm, outline.outline.band.s_min),
            (-3.5, 30)
        );
        let text = toml::to_string(&outline).unwrap();
        assert_eq!(read(&text).unwrap(), outline);
    }
}
