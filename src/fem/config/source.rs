//! What `[geometry]` says about an imported geometry file beside `file`: the gmsh
//! parameters of a .geo (`parameters`), the clamp plane of a file without a `clamp`
//! group (`clamp = "x-min"`) and the marker line of one without `markers`
//! (`[geometry.markers]`), and the checks on them alone.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::fem::FemError;

/// Most markers a marker line may put.
pub const MAX_LINE_MARKERS: usize = 1000;

/// A boundary plane of the solid's bounding box: where a file without a `clamp` group is
/// clamped (`[geometry] clamp = "x-min"`, `"x-max"`, `"y-min"`, ... `"z-max"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClampPlane {
    /// 0, 1, 2 for x, y, z.
    pub axis: usize,
    /// The largest coordinate's plane (else the smallest's).
    pub max: bool,
}

impl ClampPlane {
    /// The plane's name in configs: `x-min`.
    pub fn name(self) -> String {
        format!(
            "{}-{}",
            ["x", "y", "z"][self.axis],
            if self.max { "max" } else { "min" }
        )
    }
}

impl std::str::FromStr for ClampPlane {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let (axis, end) = s.split_once('-').unwrap_or((s, ""));
        let axis = ["x", "y", "z"].iter().position(|a| *a == axis);
        let max = match end {
            "min" => Some(false),
            "max" => Some(true),
            _ => None,
        };
        match (axis, max) {
            (Some(axis), Some(max)) => Ok(ClampPlane { axis, max }),
            _ => Err(format!(
                "`{s}` is no clamp plane: give one of x-min, x-max, y-min, y-max, z-min, z-max (the solid's face on that side)"
            )),
        }
    }
}

impl Serialize for ClampPlane {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.name())
    }
}

impl<'de> Deserialize<'de> for ClampPlane {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

/// Markers on a line (`[geometry.markers]`): `count` points evenly from `from` to `to`
/// (mm), each taken as the solid's nearest surface node.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MarkerLine {
    /// The first point, mm (nearest the clamp).
    pub from: [f64; 3],
    /// The last point, mm.
    pub to: [f64; 3],
    /// How many markers, at least 3.
    pub count: usize,
}

impl MarkerLine {
    /// The points, from `from` to `to`.
    pub fn points(&self) -> Vec<[f64; 3]> {
        let n = self.count.max(2);
        (0..n)
            .map(|k| {
                let t = k as f64 / (n - 1) as f64;
                std::array::from_fn(|i| self.from[i] + t * (self.to[i] - self.from[i]))
            })
            .collect()
    }
}

fn bad(name: &str, why: String) -> FemError {
    super::bad(name, why)
}

/// Checks the geometry file's settings on their own: finite marker points, 3 to
/// [`MAX_LINE_MARKERS`] markers on a line of some length, parameter names a .geo can
/// hold and finite values.
pub fn validate(
    parameters: &BTreeMap<String, f64>,
    markers: Option<&MarkerLine>,
) -> Result<(), FemError> {
    for (name, value) in parameters {
        let plain = name.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !plain {
            return Err(bad(
                &format!("geometry.parameters.{name}"),
                "a parameter's name is a .geo DefineConstant's: letters, digits and _, starting with a letter".into(),
            ));
        }
        if !value.is_finite() {
            return Err(bad(
                &format!("geometry.parameters.{name}"),
                format!("{value}: give a finite number"),
            ));
        }
    }
    if let Some(line) = markers {
        if !(3..=MAX_LINE_MARKERS).contains(&line.count) {
            return Err(bad(
                "geometry.markers.count",
                format!(
                    "{}: give 3 to {MAX_LINE_MARKERS} markers (the radius is fitted to at least 3)",
                    line.count
                ),
            ));
        }
        for (key, p) in [("from", line.from), ("to", line.to)] {
            if !p.iter().all(|v| v.is_finite()) {
                return Err(bad(
                    &format!("geometry.markers.{key}"),
                    format!("{p:?}: give three finite coordinates, mm"),
                ));
            }
        }
        let length = (0..3)
            .map(|i| (line.to[i] - line.from[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        if length <= 0.0 {
            return Err(bad(
                "geometry.markers",
                "`from` and `to` are one point: give the line's two ends".into(),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clamp_planes_read_and_write_by_name() {
        for (text, axis, max) in [("x-min", 0, false), ("y-max", 1, true), ("z-min", 2, false)] {
            let p: ClampPlane = text.parse().unwrap();
            assert_eq!(p, ClampPlane { axis, max });
            assert_eq!(p.name(), text);
        }
        for text in ["x", "xmin", "w-min", "x-middle", ""] {
            let e = text.parse::<ClampPlane>().unwrap_err();
            assert!(e.contains("x-min, x-max"), "{e}");
        }
    }

    #[test]
    fn a_marker_line_spaces_its_points_evenly() {
        let line = MarkerLine {
            from: [0.0, 1.0, 2.0],
            to: [30.0, 1.0, 2.0],
            count: 4,
        };
        let xs: Vec<f64> = line.points().iter().map(|p| p[0]).collect();
        assert_eq!(xs, vec![0.0, 10.0, 20.0, 30.0]);
    }

    #[test]
    fn bad_settings_are_refused_naming_the_key() {
        let line = |from: [f64; 3], count| MarkerLine {
            from,
            to: [1.0, 0.0, 0.0],
            count,
        };
        let none = BTreeMap::new();
        let cases: [(BTreeMap<String, f64>, Option<MarkerLine>, &str); 6] = [
            (
                BTreeMap::from([("H".into(), f64::NAN)]),
                None,
                "geometry.parameters.H",
            ),
            (
                BTreeMap::from([("2H".into(), 1.0)]),
                None,
                "geometry.parameters.2H",
            ),
            (
                none.clone(),
                Some(line([0.0; 3], 2)),
                "geometry.markers.count",
            ),
            (
                none.clone(),
                Some(line([0.0; 3], 5000)),
                "geometry.markers.count",
            ),
            (
                none.clone(),
                Some(line([f64::INFINITY, 0.0, 0.0], 3)),
                "geometry.markers.from",
            ),
            (none, Some(line([1.0, 0.0, 0.0], 3)), "geometry.markers"),
        ];
        for (params, markers, key) in cases {
            let e = validate(&params, markers.as_ref()).unwrap_err().to_string();
            assert!(e.contains(key), "{key}: {e}");
        }
        validate(
            &BTreeMap::from([("H".into(), 15.0)]),
            Some(&line([0.0; 3], 3)),
        )
        .unwrap();
    }
}
