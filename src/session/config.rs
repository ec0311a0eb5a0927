//! Settings of a session: `bendscope.toml`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::scale_config::{ScaleBoardConfig, ScaleMarkersConfig};
use super::{SessionError, CONFIG};
use crate::detect::DetectSettings;
use crate::video::FrameSelection;

/// A checkerboard: inner corners and square size.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoardConfig {
    /// Inner corners along a row.
    pub cols: u32,
    /// Inner corners along a column.
    pub rows: u32,
    /// Square side, mm.
    pub square_mm: f64,
}

impl Default for BoardConfig {
    fn default() -> Self {
        Self {
            cols: 9,
            rows: 6,
            square_mm: 25.0,
        }
    }
}

/// `[video]`: which frames of each video are measured.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VideoConfig {
    /// `"all"` (the default), `"keyframes"` (step sessions only) or `"every:N"`.
    pub frames: FrameSelection,
}

impl VideoConfig {
    /// True for the defaults (left out when the settings are written).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// Settings of a session (`bendscope.toml`); every field has a default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SessionConfig {
    /// Calibration file (relative to the session); else `calib/` is calibrated.
    pub calibration: Option<PathBuf>,
    /// Lens model used when calibrating `calib/`.
    pub model: crate::calib::CameraModel,
    /// Board of the `calib/` photos.
    pub calib_board: BoardConfig,
    /// Board of the scale photo, and where its plane lies from the marker plane.
    pub scale_board: ScaleBoardConfig,
    /// The scale from the markers' rest spacing (the 0 kPa item) instead of a board.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scale_markers: Option<ScaleMarkersConfig>,
    /// Scale photo (relative to the session); default: the first `scale.*` image.
    pub scale_image: Option<PathBuf>,
    /// Known mm per undistorted px (skips the scale photo).
    pub mm_per_px: Option<f64>,
    /// A scale saved by `bendscope scale --save` (relative to the session): its mm/px and
    /// homography are used instead of measuring the scale photo.
    pub scale: Option<PathBuf>,
    /// Whether the file sets `[scale_board] square_mm` (not a setting: read from the
    /// file, so that a scale from a defaulted square size can be warned about).
    #[serde(skip)]
    pub scale_square_mm_given: bool,
    /// Expected number of markers per frame.
    pub expected_markers: usize,
    /// Process every n-th frame.
    pub frame_stride: u64,
    /// Ramp protocol: width of the pressure bins frames are averaged in, kPa (the
    /// low-pass filter of the per-frame results).
    pub ramp_bin_kpa: f64,
    /// Ramp protocol: time of the video's first frame on the pressure log's clock, s.
    pub ramp_time_offset_s: f64,
    /// Undistort every whole frame before detection (the original method; slower, for
    /// comparison) instead of undistorting only the detected centroids.
    pub full_frame_undistort: bool,
    /// Segmented actuator: the markers of each segment, numbered from 1 at the clamped
    /// end (`[[1, 2, 3], [3, 4, 5]]`; a marker may end one segment and start the next).
    /// Each segment gets its own circle; the marker pick follows the segments.
    pub segments: Option<Vec<Vec<usize>>>,
    /// Ramp and RGB-D sessions: smooth the marker tracks over this many seconds
    /// (Savitzky-Golay, quadratic) before fitting again; per_frame.csv gets
    /// `radius_mm_smooth`, `curvature_per_m_smooth`, `bending_angle_deg_smooth`.
    pub smooth_s: Option<f64>,
    /// Region of interest: a polygon of undistorted pixels `[[x, y], ...]` (at least 3
    /// vertices); red blobs outside it are never markers (counted as ignored).
    pub roi: Option<Vec<[f64; 2]>>,
    /// Marker detection.
    pub detect: DetectSettings,
    /// Which frames of each video are measured.
    #[serde(skip_serializing_if = "VideoConfig::is_default")]
    pub video: VideoConfig,
    /// What the plots' error bars show: `std` (one standard deviation of the frames) or
    /// `ci95` (95 % confidence interval of the mean); `--error-bars` overrides it.
    #[serde(skip_serializing_if = "crate::report::ErrorBars::is_default")]
    pub error_bars: crate::report::ErrorBars,
}

impl Default for SessionConfig {
    fn default() -> Self {
        Self {
            calibration: None,
            model: crate::calib::CameraModel::Fisheye,
            calib_board: BoardConfig::default(),
            scale_board: ScaleBoardConfig::default(),
            scale_markers: None,
            scale_image: None,
            mm_per_px: None,
            scale: None,
            scale_square_mm_given: false,
            expected_markers: 8,
            frame_stride: 1,
            ramp_bin_kpa: 1.0,
            ramp_time_offset_s: 0.0,
            full_frame_undistort: false,
            segments: None,
            smooth_s: None,
            roi: None,
            detect: DetectSettings::default(),
            video: VideoConfig::default(),
            error_bars: crate::report::ErrorBars::default(),
        }
    }
}

/// A value out of its range: its table (`None`: top level), its key and what is wrong.
struct BadValue {
    table: Option<&'static str>,
    key: &'static str,
    why: String,
}

impl BadValue {
    fn new(table: Option<&'static str>, key: &'static str, why: String) -> Self {
        Self { table, key, why }
    }
}

/// 1-based line of byte `offset` in `text`.
fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    1 + text.as_bytes()[..end]
        .iter()
        .filter(|b| **b == b'\n')
        .count()
}

/// 1-based line where `key` is set (in `[table]` when given), when the text parses.
fn key_line(text: &str, table: Option<&str>, key: &str) -> Option<usize> {
    use toml::de::{DeTable, DeValue};
    let doc = DeTable::parse(text).ok()?;
    let mut t = doc.get_ref();
    if let Some(name) = table {
        match t.iter().find(|(k, _)| k.get_ref() == name)?.1.get_ref() {
            DeValue::Table(inner) => t = inner,
            _ => return None,
        }
    }
    let (k, _) = t.iter().find(|(k, _)| k.get_ref() == key)?;
    Some(line_of(text, k.span().start))
}

/// The line at byte `offset` of `text`: where it starts and its text.
fn line_at(text: &str, offset: usize) -> (usize, &str) {
    let end = offset.min(text.len());
    let start = text
        .get(..end)
        .and_then(|head| head.rfind('\n'))
        .map(|i| i + 1)
        .unwrap_or(0);
    let line = text
        .get(start..)
        .and_then(|rest| rest.lines().next())
        .unwrap_or("");
    (start, line)
}

/// The table name of a `[table]` (or `[[table]]`) header line.
fn header_name(line: &str) -> Option<String> {
    line.trim()
        .strip_prefix('[')
        .and_then(|r| r.strip_suffix(']'))
        .map(|name| name.trim_matches(['[', ']', ' ']).to_string())
}

/// The `[table]` the line at `offset` belongs to (`None`: top level).
fn table_at(text: &str, offset: usize) -> Option<String> {
    let (start, _) = line_at(text, offset);
    text.get(..start)?.lines().rev().find_map(header_name)
}

/// The key set on the line at `offset` (`key = value`), when there is one.
fn key_at(text: &str, offset: usize) -> Option<String> {
    let (key, _) = line_at(text, offset).1.split_once('=')?;
    let key = key.trim();
    (!key.is_empty() && !key.starts_with(['[', '#'])).then(|| key.to_string())
}

/// The name of the `[table]` header on the line at `offset`, when that line is one.
fn header_at(text: &str, offset: usize) -> Option<String> {
    header_name(line_at(text, offset).1)
}

/// The first key of the `[detect]` table whose value alone does not deserialize, and its
/// line. [`DetectSettings`] flattens its colour thresholds, and through a flattened
/// struct toml reports errors at the table, not at the key.
fn failing_detect_key(text: &str) -> Option<(String, usize)> {
    let doc: toml::Table = toml::from_str(text).ok()?;
    let detect = doc.get("detect")?.as_table()?;
    detect.iter().find_map(|(key, value)| {
        let mut single = toml::Table::new();
        single.insert(key.clone(), value.clone());
        toml::Value::Table(single)
            .try_into::<DetectSettings>()
            .is_err()
            .then(|| {
                (
                    key.clone(),
                    key_line(text, Some("detect"), key).unwrap_or(0),
                )
            })
    })
}

/// What a serde type name means to a user writing TOML.
fn plain_expected(expected: &str) -> String {
    let e = expected.trim();
    match e {
        "i8" | "i16" | "i32" | "i64" => "a whole number".into(),
        "u8" | "u16" | "u32" | "u64" | "usize" => "a whole number >= 0".into(),
        "f32" | "f64" => "a number".into(),
        "a sequence" => "a list `[...]`".into(),
        "a boolean" => "true or false".into(),
        "a string" | "a borrowed string" => "text in quotes".into(),
        _ => e.to_string(),
    }
}

/// What a serde description of a value (`floating point `35.5``, `string "1"`,
/// `integer `-1``, `sequence`) means to a user writing TOML.
fn plain_value(value: &str) -> String {
    let v = value.trim();
    let inner = |prefix: &str| {
        v.strip_prefix(prefix)
            .map(|r| r.trim().trim_matches('`').to_string())
    };
    if let Some(x) = inner("floating point") {
        format!("the decimal number {x}")
    } else if let Some(x) = inner("integer") {
        if x.starts_with('-') {
            format!("the negative number {x}")
        } else {
            format!("the whole number {x}")
        }
    } else if let Some(x) = inner("string") {
        format!("the text {x}")
    } else if let Some(x) = inner("boolean") {
        format!("{x}")
    } else {
        match v {
            "sequence" => "a list".into(),
            "map" => "a table".into(),
            _ => v.to_string(),
        }
    }
}

/// An example of a valid value of the session key `key` (its last dotted part), for
/// messages about a value of the wrong type.
fn key_example(key: &str) -> Option<&'static str> {
    Some(match key.rsplit('.').next().unwrap_or(key) {
        "hue_min" | "hue_max" | "hue_max_low" | "hue_min_high" => {
            "0..180 (OpenCV's hue: degrees / 2), e.g. hue_min = 35"
        }
        "s_min" | "v_min" | "v_max" => "0..255, e.g. s_min = 100",
        "min_area_px" | "max_area_px" => "pixels, e.g. min_area_px = 6",
        "segments" => {
            "the marker numbers of each segment, from 1 at the clamped end, e.g. segments = [[1, 2, 3], [3, 4, 5]]"
        }
        "roi" => "undistorted pixel corners [x, y], e.g. roi = [[100, 50], [1800, 50], [1800, 1000]]",
        "expected_markers" => "e.g. expected_markers = 8",
        "frame_stride" => "e.g. frame_stride = 2",
        "cols" | "rows" => "inner corners, e.g. cols = 9",
        "colour" => "red, green, blue, yellow or dark, e.g. colour = \"green\"",
        "clamp_side" => "left, right, top or bottom, e.g. clamp_side = \"right\"",
        "smooth_s" => "seconds, e.g. smooth_s = 0.2",
        "error_bars" => "std or ci95, e.g. error_bars = \"ci95\"",
        "frames" => "\"all\", \"keyframes\" or \"every:N\", e.g. frames = \"keyframes\"",
        "spacing_mm" => "mm, one pitch or one per pair of markers, e.g. spacing_mm = 12.5",
        "offset_mm" => "mm, + in front of the marker plane, e.g. offset_mm = 3",
        _ => return None,
    })
}

/// A serde type error (`invalid type: floating point `35.5`, expected i64`) in a user's
/// words, with an example of the key's form when one is known; other messages unchanged.
fn plain_type_error(msg: &str, key: &str) -> String {
    let rest = msg
        .strip_prefix("invalid type: ")
        .or_else(|| msg.strip_prefix("invalid value: "));
    let Some((value, expected)) = rest.and_then(|r| r.rsplit_once(", expected ")) else {
        return msg.to_string();
    };
    let example = key_example(key)
        .map(|e| format!(": {e}"))
        .unwrap_or_default();
    format!(
        "got {}, expected {}{example}",
        plain_value(value),
        plain_expected(expected)
    )
}

/// A TOML or serde error as `line L: what`, naming the key: an unknown key by name (and
/// its `[table]`), a value of the wrong type by the key it is set to.
fn describe_toml_error(text: &str, e: &toml::de::Error) -> String {
    let msg = e.message().trim();
    let Some(span) = e.span() else {
        return msg.to_string();
    };
    let mut line = line_of(text, span.start);
    let header = header_at(text, span.start);
    let what = if let Some(rest) = msg.strip_prefix("unknown field ") {
        let (key, expected) = rest.split_once(", ").unwrap_or((rest, ""));
        let table = header.clone().or_else(|| table_at(text, span.start));
        if let Some(t) = &header {
            // Reported at the table: find the key in it.
            let name = key.trim_matches('`');
            line = key_line(text, Some(t), name).unwrap_or(line);
        }
        let table = table.map(|t| format!(" in [{t}]")).unwrap_or_default();
        let expected = if expected.is_empty() {
            String::new()
        } else {
            format!(": {expected}")
        };
        format!("unknown key {key}{table}{expected}")
    } else if header.as_deref() == Some("detect") {
        match failing_detect_key(text) {
            Some((key, key_line)) if key_line > 0 => {
                line = key_line;
                format!("`detect.{key}`: {}", plain_type_error(msg, &key))
            }
            _ => format!("[detect]: {msg}"),
        }
    } else {
        let table = table_at(text, span.start)
            .map(|t| format!("{t}."))
            .unwrap_or_default();
        match key_at(text, span.start) {
            Some(key) => format!("`{table}{key}`: {}", plain_type_error(msg, &key)),
            None => msg.to_string(),
        }
    };
    format!("line {line}: {what}")
}

impl SessionConfig {
    /// Reads `path` (TOML); missing fields take their defaults. Errors name the line and
    /// the key: syntax errors, unknown keys, values of the wrong type or out of range.
    pub fn read(path: &Path) -> Result<Self, SessionError> {
        let bad = |why: String| SessionError::Config {
            path: path.to_path_buf(),
            why,
        };
        let bytes = std::fs::read(path).map_err(|e| {
            bad(match e.kind() {
                std::io::ErrorKind::NotFound => "no such file: check the path".to_string(),
                _ => e.to_string(),
            })
        })?;
        let text = String::from_utf8(bytes).map_err(|e| {
            let line = 1 + e.as_bytes()[..e.utf8_error().valid_up_to()]
                .iter()
                .filter(|b| **b == b'\n')
                .count();
            bad(format!(
                "line {line}: not UTF-8 text: save the file as UTF-8"
            ))
        })?;
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        let mut c: SessionConfig =
            toml::from_str(text).map_err(|e| bad(describe_toml_error(text, &e)))?;
        c.scale_square_mm_given = toml::from_str::<toml::Table>(text).is_ok_and(|t| {
            t.get("scale_board")
                .and_then(|b| b.as_table())
                .is_some_and(|b| b.contains_key("square_mm"))
        });
        c.check().map_err(|b| {
            let key = match b.table {
                Some(t) => format!("{t}.{}", b.key),
                None => b.key.to_string(),
            };
            let at = key_line(text, b.table, b.key)
                .map(|l| format!("line {l}: "))
                .unwrap_or_default();
            bad(format!("{at}{key} = {}", b.why))
        })?;
        Ok(c)
    }

    /// The checked segments of a segmented actuator (empty without `segments`).
    pub fn segment_plan(&self) -> Vec<crate::segments::Segment> {
        self.segments
            .as_deref()
            .and_then(|s| crate::segments::segments_from_spec(s, self.expected_markers).ok())
            .unwrap_or_default()
    }

    /// The frames to measure of each video: `[video] frames`, or `"every:N"` for
    /// `frame_stride = N`. Key frames only is refused for a ramp (`ramp`), which reads
    /// the pressure at every frame's time.
    pub fn frame_selection(&self, ramp: bool) -> Result<FrameSelection, String> {
        match self.video.frames {
            FrameSelection::Keyframes if ramp => Err(
                "[video] frames = \"keyframes\" is for step sessions: a ramp needs every \
                 frame's time to read its pressure from pressure_log.csv; use \"all\" or \
                 \"every:N\""
                    .into(),
            ),
            FrameSelection::All if self.frame_stride > 1 => {
                Ok(FrameSelection::Every(self.frame_stride))
            }
            f => Ok(f),
        }
    }

    /// Reads `SESSION/bendscope.toml` when present, else the defaults.
    pub fn for_session(session: &Path) -> Result<Self, SessionError> {
        let p = session.join(CONFIG);
        if p.is_file() {
            Self::read(&p)
        } else {
            Ok(Self::default())
        }
    }

    /// The scale tables' checks ([`super::scale_config::check_scale`]).
    fn check_scale(&self) -> Result<(), BadValue> {
        super::scale_config::check_scale(
            &self.scale_board,
            self.scale_markers.as_ref(),
            self.expected_markers,
            super::scale_config::OtherScale {
                mm_per_px: self.mm_per_px.is_some(),
                file: self.scale.is_some(),
            },
        )
        .map_err(|(table, key, why)| BadValue::new(Some(table), key, why))
    }

    /// Checks the values' ranges; the error names the first key out of range.
    fn check(&self) -> Result<(), BadValue> {
        let top = |key, why| Err(BadValue::new(None, key, why));
        if self.expected_markers < 3 {
            return top(
                "expected_markers",
                format!(
                    "{}: a circle needs at least 3 markers",
                    self.expected_markers
                ),
            );
        }
        if !(self.ramp_bin_kpa.is_finite() && self.ramp_bin_kpa > 0.0) {
            return top(
                "ramp_bin_kpa",
                format!("{}: must be a positive number of kPa", self.ramp_bin_kpa),
            );
        }
        if !self.ramp_time_offset_s.is_finite() {
            return top(
                "ramp_time_offset_s",
                format!(
                    "{}: must be a finite number of seconds",
                    self.ramp_time_offset_s
                ),
            );
        }
        if let Some(s) = self.smooth_s {
            if !(s.is_finite() && s > 0.0) {
                return top(
                    "smooth_s",
                    format!("{s}: must be a positive number of seconds (the filter's window)"),
                );
            }
        }
        if self.segments.is_some() && self.detect.mode == crate::detect::DetectMode::Outline {
            return top(
                "segments",
                "segments need dots: outline mode ([detect] mode = \"outline\") fits one circle to the body's edge; remove segments or use mode = \"dots\"".into(),
            );
        }
        if let Some(spec) = &self.segments {
            if let Err(why) = crate::segments::segments_from_spec(spec, self.expected_markers) {
                return top("segments", format!("{spec:?}: {why}"));
            }
        }
        if self.frame_stride == 0 {
            return top("frame_stride", "0: must be at least 1".into());
        }
        if self.video.frames != FrameSelection::All && self.frame_stride != 1 {
            return Err(BadValue::new(
                Some("video"),
                "frames",
                format!(
                    "\"{}\" with frame_stride = {}: choose the frames one way (frame_stride = N \
                     is frames = \"every:N\")",
                    self.video.frames, self.frame_stride
                ),
            ));
        }
        if let Some(roi) = &self.roi {
            if roi.len() < 3 || roi.iter().flatten().any(|v| !v.is_finite()) {
                return top(
                    "roi",
                    "needs at least 3 vertices [x, y] of finite undistorted pixel coordinates"
                        .into(),
                );
            }
        }
        if let Some(m) = self.mm_per_px {
            if !(m.is_finite() && m > 0.0) {
                return top("mm_per_px", format!("{m}: must be a positive number"));
            }
            if self.scale.is_some() {
                return top(
                    "mm_per_px",
                    format!(
                        "{m} and scale are both set: give the scale one way (keep one of them)"
                    ),
                );
            }
        }
        self.check_scale()?;
        for (name, b) in [
            ("calib_board", &self.calib_board),
            ("scale_board", &self.scale_board.board()),
        ] {
            let bad = |key, why| Err(BadValue::new(Some(name), key, why));
            if b.cols < 2 {
                return bad("cols", format!("{}: must be >= 2 inner corners", b.cols));
            }
            if b.rows < 2 {
                return bad("rows", format!("{}: must be >= 2 inner corners", b.rows));
            }
            if !(b.square_mm.is_finite() && b.square_mm > 0.0) {
                return bad(
                    "square_mm",
                    format!("{}: must be a positive number of mm", b.square_mm),
                );
            }
        }
        if self.detect.min_area_px > self.detect.max_area_px {
            return Err(BadValue::new(
                Some("detect"),
                "min_area_px",
                format!(
                    "{}: larger than max_area_px = {}: lower min_area_px or raise max_area_px",
                    self.detect.min_area_px, self.detect.max_area_px
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
    fn config_defaults_and_bad_values() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(CONFIG);
        std::fs::write(
            &p,
            "expected_markers = 6\n[scale_board]\nsquare_mm = 10\n[detect]\ns_min = 90\n",
        )
        .unwrap();
        let c = SessionConfig::read(&p).unwrap();
        assert_eq!(c.expected_markers, 6);
        assert_eq!(c.scale_board.square_mm, 10.0);
        assert_eq!(c.scale_board.cols, 9);
        assert!(c.scale_square_mm_given);
        std::fs::write(&p, "scale_board.square_mm = 12\n").unwrap();
        assert!(SessionConfig::read(&p).unwrap().scale_square_mm_given);
        std::fs::write(&p, "[scale_board]\ncols = 7\n").unwrap();
        assert!(!SessionConfig::read(&p).unwrap().scale_square_mm_given);
        assert_eq!(c.detect.hsv.s_min, 90);
        std::fs::write(&p, "frame_stride = 0\n").unwrap();
        assert!(SessionConfig::read(&p)
            .unwrap_err()
            .to_string()
            .contains("frame_stride"));
        std::fs::write(&p, "nonsense = 1\n").unwrap();
        assert!(SessionConfig::read(&p).is_err());
    }

    fn error_of(text: impl AsRef<[u8]>) -> String {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(CONFIG);
        std::fs::write(&p, text).unwrap();
        let e = SessionConfig::read(&p).unwrap_err().to_string();
        let prefix = format!("{}: ", p.display());
        e.strip_prefix(&prefix).unwrap_or(&e).to_string()
    }

    #[test]
    fn errors_name_the_key_and_line() {
        let e = error_of("# settings\nexpected_markers = 8\nnonsense = 1\n");
        assert!(
            e.starts_with("line 3: unknown key `nonsense`: expected one of"),
            "{e}"
        );
        let e = error_of("expected_markers = 8\n[scale_board]\ncols = 9\nsquares = 3\n");
        assert!(
            e.starts_with("line 4: unknown key `squares` in [scale_board]"),
            "{e}"
        );
        let e = error_of("[detect]\ns_min = 90\n\nfoo = 1\n");
        assert!(
            e.starts_with("line 4: unknown key `foo` in [detect]"),
            "{e}"
        );
        let e = error_of("[detect]\ns_min = 90\nhue_max_low = 300\n");
        assert!(
            e.starts_with("line 3: `detect.hue_max_low`: 300 is outside 0..180"),
            "{e}"
        );
        let e = error_of("mm_per_px = 0.2\nexpected_markers = \"eight\"\n");
        assert!(
            e.starts_with("line 2: `expected_markers`: got the text \"eight\", expected a whole number >= 0: e.g. expected_markers = 8"),
            "{e}"
        );
        let e = error_of("frame_stride = 1\nmodel = fisheye\n");
        assert!(e.starts_with("line 2: "), "{e}");
        // Values of the wrong type in a user's words, with the form the key takes.
        for (text, want) in [
            (
                "[detect]\nhue_min = 35.5\n",
                "line 2: `detect.hue_min`: got the decimal number 35.5, expected a whole number: 0..180 (OpenCV's hue: degrees / 2), e.g. hue_min = 35",
            ),
            (
                "[detect]\ns_min = 90\nhue_min = \"35\"\n",
                "line 3: `detect.hue_min`: got the text \"35\", expected a whole number: 0..180",
            ),
            (
                "segments = [[\"1\", \"2\", \"3\"], [3, 4, 5]]\n",
                "line 1: `segments`: got the text \"1\", expected a whole number >= 0: the marker numbers of each segment, from 1 at the clamped end, e.g. segments = [[1, 2, 3], [3, 4, 5]]",
            ),
            (
                "segments = [[1.0, 2.0, 3.0], [3, 4, 5]]\n",
                "line 1: `segments`: got the decimal number 1.0, expected a whole number >= 0: the marker",
            ),
            (
                "segments = [[-1, 2, 3], [3, 4, 5]]\n",
                "line 1: `segments`: got the negative number -1, expected a whole number >= 0: the marker",
            ),
            (
                "segments = [1, 2, 3, 4, 5]\n",
                "line 1: `segments`: got the whole number 1, expected a list `[...]`: the marker numbers of each segment, from 1 at the clamped end, e.g. segments = [[1, 2, 3], [3, 4, 5]]",
            ),
        ] {
            let e = error_of(text);
            assert!(e.starts_with(want), "{text:?}:\n{e}\n{want}");
            assert!(!e.contains("i64") && !e.contains("usize"), "{e}");
        }
        assert!(e.starts_with("line 2: "), "{e}");
        assert_eq!(
            error_of("\n\nframe_stride = 0\n"),
            "line 3: frame_stride = 0: must be at least 1"
        );
        assert_eq!(
            error_of("[calib_board]\nrows = 6\ncols = 1\n"),
            "line 3: calib_board.cols = 1: must be >= 2 inner corners"
        );
        assert_eq!(
            error_of("scale_board.square_mm = -2.5\n"),
            "line 1: scale_board.square_mm = -2.5: must be a positive number of mm"
        );
        assert_eq!(
            error_of("ramp_bin_kpa = nan\n"),
            "line 1: ramp_bin_kpa = NaN: must be a positive number of kPa"
        );
        assert!(error_of("[detect]\nmax_area_px = 5\nmin_area_px = 10\n")
            .starts_with("line 3: detect.min_area_px = 10: larger than max_area_px = 5"),);
        assert!(error_of(b"a = \xff\n").starts_with("line 1: not UTF-8"));
        // A byte order mark is not an error.
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(CONFIG);
        std::fs::write(&p, "\u{feff}expected_markers = 6\n").unwrap();
        assert_eq!(SessionConfig::read(&p).unwrap().expected_markers, 6);
    }

    #[test]
    fn video_frames_are_read_checked_and_refused_for_ramps() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(CONFIG);
        for (text, want, ramp) in [
            ("", FrameSelection::All, Ok(FrameSelection::All)),
            ("frame_stride = 3\n", FrameSelection::All, Ok(FrameSelection::Every(3))),
            (
                "[video]\nframes = \"keyframes\"\n",
                FrameSelection::Keyframes,
                Err("[video] frames = \"keyframes\" is for step sessions: a ramp needs every frame's time"),
            ),
            (
                "[video]\nframes = \"every:4\"\n",
                FrameSelection::Every(4),
                Ok(FrameSelection::Every(4)),
            ),
        ] {
            std::fs::write(&p, text).unwrap();
            let c = SessionConfig::read(&p).unwrap();
            assert_eq!(c.video.frames, want, "{text:?}");
            assert_eq!(c.frame_selection(false), Ok(ramp.unwrap_or(want)), "{text:?}");
            match (c.frame_selection(true), ramp) {
                (Ok(got), Ok(w)) => assert_eq!(got, w, "{text:?}"),
                (Err(e), Err(needle)) => {
                    assert!(e.starts_with(needle) && !e.contains('\n'), "{e}")
                }
                (got, w) => panic!("{text:?}: {got:?}, wanted {w:?}"),
            }
            // Written and read back: the same; the default is left out.
            let written = toml::to_string(&c).unwrap();
            assert_eq!(written.contains("[video]"), want != FrameSelection::All, "{written}");
            assert_eq!(toml::from_str::<SessionConfig>(&written).unwrap().video, c.video);
        }
        for (text, want) in [
            (
                "[video]\nframes = \"keyframe\"\n",
                "line 2: `video.frames`: unknown frames `keyframe`: use \"all\", \"keyframes\" or \"every:N\" (N a whole number of frames, e.g. \"every:5\")",
            ),
            (
                "[video]\nframes = \"every:0\"\n",
                "line 2: `video.frames`: `every:0`: N must be at least 1",
            ),
            (
                "[video]\n\nframes = 4\n",
                "line 3: `video.frames`: got the whole number 4, expected text in quotes: \"all\", \"keyframes\" or \"every:N\", e.g. frames = \"keyframes\"",
            ),
            (
                "frame_stride = 2\n[video]\nframes = \"every:3\"\n",
                "line 3: video.frames = \"every:3\" with frame_stride = 2: choose the frames one way",
            ),
            ("[video]\nframe = \"all\"\n", "line 2: unknown key `frame` in [video]"),
        ] {
            let e = error_of(text);
            assert!(e.starts_with(want), "{text:?}:\n{e}\n{want}");
            assert!(!e.contains('\n'), "{e}");
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(128))]

        #[test]
        fn arbitrary_configs_read_or_fail_without_panicking(
            bytes in proptest::prop_oneof![
                proptest::collection::vec(proptest::prelude::any::<u8>(), 0..120),
                proptest::collection::vec(
                    proptest::sample::select(b"[]=\"'\n#.,{}0123 aemodl_xpk-".to_vec()),
                    0..120,
                ),
            ]
        ) {
            let d = tempfile::tempdir().unwrap();
            let p = d.path().join(CONFIG);
            std::fs::write(&p, &bytes).unwrap();
            if let Ok(c) = SessionConfig::read(&p) {
                proptest::prop_assert!(c.expected_markers >= 3 && c.frame_stride >= 1);
            }
        }
    }
}
