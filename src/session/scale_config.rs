//! The scale's settings in `bendscope.toml`: `[scale_board]` (the board of the scale
//! photo, and how far its plane lies from the marker plane) and `[scale_markers]` (the
//! markers' own rest spacing, no board needed).

use serde::{Deserialize, Serialize};

/// `[scale_board]`: the board of the scale photo.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScaleBoardConfig {
    /// Inner corners along a row.
    pub cols: u32,
    /// Inner corners along a column.
    pub rows: u32,
    /// Square side, mm.
    pub square_mm: f64,
    /// How far the board's plane lies in front of the marker plane (nearer the camera;
    /// negative: behind it), mm along the board's normal. The scale is carried from the
    /// board's plane to the marker plane through the board's pose.
    #[serde(skip_serializing_if = "is_zero")]
    pub offset_mm: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Default for ScaleBoardConfig {
    fn default() -> Self {
        let b = super::BoardConfig::default();
        Self {
            cols: b.cols,
            rows: b.rows,
            square_mm: b.square_mm,
            offset_mm: 0.0,
        }
    }
}

impl ScaleBoardConfig {
    /// The board itself (corners and square size).
    pub fn board(&self) -> super::BoardConfig {
        super::BoardConfig {
            cols: self.cols,
            rows: self.rows,
            square_mm: self.square_mm,
        }
    }
}

/// The markers' rest spacing: one pitch for every pair, or each consecutive pair's
/// distance from the clamped end (markers - 1 values), mm.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum MarkerSpacing {
    /// The same distance between every two consecutive markers.
    Pitch(f64),
    /// The distance of each consecutive pair, from the clamped end.
    List(Vec<f64>),
}

impl MarkerSpacing {
    /// The distance of each of the `markers - 1` consecutive pairs, mm.
    pub fn distances(&self, markers: usize) -> Vec<f64> {
        match self {
            Self::Pitch(p) => vec![*p; markers.saturating_sub(1)],
            Self::List(l) => l.clone(),
        }
    }

    /// Checks the values against `markers` per frame; the error says what is wrong.
    pub fn check(&self, markers: usize) -> Result<(), String> {
        let values = match self {
            Self::Pitch(p) => vec![*p],
            Self::List(l) => l.clone(),
        };
        if let Some(v) = values.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
            return Err(format!(
                "{v}: every distance must be a positive number of mm"
            ));
        }
        if let Self::List(l) = self {
            if l.len() + 1 != markers {
                return Err(format!(
                    "{} distances for {markers} markers: give one per pair of consecutive markers ({}), or one number for an even pitch",
                    l.len(),
                    markers.saturating_sub(1)
                ));
            }
        }
        Ok(())
    }
}

impl<'de> Deserialize<'de> for MarkerSpacing {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = MarkerSpacing;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number of mm or a list of numbers")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Self::Value, E> {
                Ok(MarkerSpacing::Pitch(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Self::Value, E> {
                Ok(MarkerSpacing::Pitch(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Self::Value, E> {
                Ok(MarkerSpacing::Pitch(v as f64))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> Result<Self::Value, A::Error> {
                let mut l = Vec::new();
                while let Some(v) = seq.next_element::<f64>()? {
                    l.push(v);
                }
                Ok(MarkerSpacing::List(l))
            }
        }
        d.deserialize_any(V)
    }
}

/// `[scale_markers]`: the scale from the markers themselves, at rest (the session's
/// 0 kPa video or photo), against their known spacing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScaleMarkersConfig {
    /// Rest distance between consecutive markers, mm: one pitch or a list.
    pub spacing_mm: MarkerSpacing,
}

/// Where the session's scale comes from besides these tables: `mm_per_px` and a scale
/// file (`scale`) in the settings.
pub(super) struct OtherScale {
    pub(super) mm_per_px: bool,
    pub(super) file: bool,
}

/// Checks the scale tables: a finite offset, spacings for `markers` per frame, and one
/// explicit way to the scale. The error is the table, the key and what is wrong.
pub(super) fn check_scale(
    board: &ScaleBoardConfig,
    markers: Option<&ScaleMarkersConfig>,
    expected_markers: usize,
    other: OtherScale,
) -> Result<(), (&'static str, &'static str, String)> {
    let o = board.offset_mm;
    let elsewhere = match (other.mm_per_px, other.file) {
        (true, _) => Some("mm_per_px"),
        (_, true) => Some("scale"),
        _ => None,
    };
    if !o.is_finite() {
        return Err((
            "scale_board",
            "offset_mm",
            format!("{o}: must be a finite number of mm (+ board in front of the marker plane, - behind)"),
        ));
    }
    if let (Some(e), true) = (elsewhere, o != 0.0) {
        return Err((
            "scale_board",
            "offset_mm",
            format!("{o} with {e} set: the scale photo is not used; remove offset_mm or {e}"),
        ));
    }
    let Some(m) = markers else {
        return Ok(());
    };
    m.spacing_mm
        .check(expected_markers)
        .map_err(|why| ("scale_markers", "spacing_mm", why))?;
    if let Some(e) = elsewhere {
        return Err((
            "scale_markers",
            "spacing_mm",
            format!("set with {e} as well: give the scale one way (keep one of them)"),
        ));
    }
    if o != 0.0 {
        return Err((
            "scale_markers",
            "spacing_mm",
            format!(
                "set with [scale_board] offset_mm = {o}: give the scale one way (markers or board)"
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The message of reading `text` as bendscope.toml, without the path.
    fn error_of(text: &str) -> String {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(crate::session::CONFIG);
        std::fs::write(&p, text).unwrap();
        let e = crate::session::SessionConfig::read(&p)
            .unwrap_err()
            .to_string();
        let prefix = format!("{}: ", p.display());
        e.strip_prefix(&prefix).unwrap_or(&e).to_string()
    }

    #[test]
    fn scale_tables_are_read_and_bad_values_refused_naming_the_key() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(crate::session::CONFIG);
        std::fs::write(&p, "[scale_board]\nsquare_mm = 10\noffset_mm = -3.5\n").unwrap();
        let c = crate::session::SessionConfig::read(&p).unwrap();
        assert_eq!(c.scale_board.offset_mm, -3.5);
        assert!(c.scale_markers.is_none());
        std::fs::write(
            &p,
            "expected_markers = 4\n[scale_markers]\nspacing_mm = [10, 11, 12]\n",
        )
        .unwrap();
        let c = crate::session::SessionConfig::read(&p).unwrap();
        let m = c.scale_markers.unwrap();
        assert_eq!(m.spacing_mm.distances(4), vec![10.0, 11.0, 12.0]);
        for (text, want) in [
            (
                "[scale_board]\noffset_mm = nan\n",
                "line 2: scale_board.offset_mm = NaN: must be a finite number of mm",
            ),
            (
                "[scale_board]\n\noffset_mm = inf\n",
                "line 3: scale_board.offset_mm = inf: must be a finite number of mm",
            ),
            (
                "mm_per_px = 0.2\n[scale_board]\noffset_mm = 3\n",
                "line 3: scale_board.offset_mm = 3 with mm_per_px set: the scale photo is not used",
            ),
            (
                "[scale_markers]\nspacing_mm = -12.5\n",
                "line 2: scale_markers.spacing_mm = -12.5: every distance must be a positive number of mm",
            ),
            (
                "[scale_markers]\nspacing_mm = [12.5, 12.5]\n",
                "line 2: scale_markers.spacing_mm = 2 distances for 8 markers",
            ),
            (
                "scale = \"s.json\"\n[scale_markers]\nspacing_mm = 12.5\n",
                "line 3: scale_markers.spacing_mm = set with scale as well: give the scale one way",
            ),
            (
                "[scale_board]\noffset_mm = 2\n[scale_markers]\nspacing_mm = 12.5\n",
                "line 4: scale_markers.spacing_mm = set with [scale_board] offset_mm = 2",
            ),
            (
                "[scale_markers]\nspacing_mm = \"12.5\"\n",
                "line 2: `scale_markers.spacing_mm`: got the text \"12.5\", expected a number of mm or a list of numbers: mm, one pitch",
            ),
            (
                "[scale_markers]\npitch = 12.5\n",
                "line 2: unknown key `pitch` in [scale_markers]",
            ),
            (
                "[scale_board]\noffset_mm = \"3\"\n",
                "line 2: `scale_board.offset_mm`: got the text \"3\", expected a number: mm, + in front",
            ),
        ] {
            let e = error_of(text);
            assert!(e.starts_with(want), "{text:?}:\n{e}\n{want}");
            assert!(!e.contains('\n'), "{e}");
        }
    }

    #[test]
    fn spacing_reads_a_pitch_or_a_list_and_checks_both() {
        for (text, want) in [
            ("spacing_mm = 12.5", MarkerSpacing::Pitch(12.5)),
            ("spacing_mm = 12", MarkerSpacing::Pitch(12.0)),
            (
                "spacing_mm = [12.5, 12, 13.0]",
                MarkerSpacing::List(vec![12.5, 12.0, 13.0]),
            ),
        ] {
            let c: ScaleMarkersConfig = toml::from_str(text).unwrap();
            assert_eq!(c.spacing_mm, want, "{text}");
            // Written and read back: the same.
            let again: ScaleMarkersConfig = toml::from_str(&toml::to_string(&c).unwrap()).unwrap();
            assert_eq!(again, c);
        }
        assert_eq!(MarkerSpacing::Pitch(12.5).distances(4), vec![12.5; 3]);
        assert!(MarkerSpacing::Pitch(12.5).check(8).is_ok());
        assert!(MarkerSpacing::List(vec![1.0, 2.0]).check(3).is_ok());
        for (s, markers, want) in [
            (
                MarkerSpacing::Pitch(0.0),
                8,
                "0: every distance must be a positive",
            ),
            (MarkerSpacing::Pitch(f64::NAN), 8, "NaN: every distance"),
            (
                MarkerSpacing::List(vec![12.5, f64::INFINITY]),
                3,
                "inf: every distance",
            ),
            (
                MarkerSpacing::List(vec![12.5, 12.5]),
                8,
                "2 distances for 8 markers: give one per pair of consecutive markers (7)",
            ),
        ] {
            let e = s.check(markers).unwrap_err();
            assert!(e.starts_with(want), "{e}");
        }
    }
}
