//! The parametric PneuNets actuator of method.md §4: configuration, checks and a
//! structured hexahedral mesh of its symmetric half.
//!
//! Coordinates: x along the length (clamped end at x = 0), y across the width, z up;
//! mm. Only the half y ≥ 0 is meshed: y = 0 is a symmetry plane (u_y = 0 there), the
//! cavity volume and the forces of the whole actuator are twice those of the half.
//!
//! Layout (fillets o, h ignored): `chambers` blocks along x, the first and last of
//! profile length c, the others g, separated by gaps d; a remainder of b beyond the
//! blocks is a solid tip. Every block has a centred cavity of length e (x), width l (y)
//! and height n (z) starting at the channel top z = f + m; the channel (height m, width
//! p, length r, centred in x) runs at z ∈ [f, f + m] and joins every cavity. The gaps
//! between blocks are open from the top down to `roof` mm above the channel top (the
//! table leaves the roof of the channel under a gap open; 1 mm by default, a parameter).
//! Total height a = f + m + n + top_wall (23.5 mm for the reference f = 6).
//!
//! The mesh: coordinate lines through every feature (block, gap, cavity and channel
//! boundaries, the marker lines), each interval cut into equal elements no longer than
//! the mesh size; cells inside a cavity or a gap are left out. The cavity faces (solid
//! cells next to cavity cells) carry the pressure. Markers: side face y = i/2, centre of
//! blocks 2..N in x, mid cavity height z = f + m + n/2: mesh nodes by construction.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::contact::{Contact, ContactConfig, ContactPair};
use super::family::{self, Family};
use super::fibre::TubeConfig;
use super::hex::{nodal_volumes, HexGeometry};
use super::layer::{LayerConfig, LayerElement};
use super::material::{MaterialPreset, Yeoh, DEFAULT_BULK_TO_SHEAR};
use super::membrane::MembraneElement;
use super::plate::Mirror;
use super::pressure::CLOSED;
use super::solve::{Model, NewtonSettings};
use super::FemError;

/// Standard gravity, m/s².
pub const GRAVITY_M_S2: f64 = 9.806_65;

/// Geometry of the actuator, mm; field names are those of method.md §4.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Geometry {
    /// The actuator family ([`super::family`]): its defaults fill what a config leaves out.
    pub family: Family,
    /// Number of chambers (blocks along x).
    pub chambers: usize,
    /// Length (x).
    pub b: f64,
    /// Width (y).
    pub i: f64,
    /// Bottom thickness: solid below the channel.
    pub f: f64,
    /// Channel height.
    pub m: f64,
    /// Channel width (y).
    pub p: f64,
    /// Channel length (x), centred.
    pub r: f64,
    /// Profile length of the first and last chamber.
    pub c: f64,
    /// Profile length of the other chambers.
    pub g: f64,
    /// Gap between chambers.
    pub d: f64,
    /// Chamber cavity length (x).
    pub e: f64,
    /// Chamber cavity width (y).
    pub l: f64,
    /// Chamber cavity height (z), from the channel top.
    pub n: f64,
    /// Top wall above the cavities (a = f + m + n + top_wall).
    pub top_wall: f64,
    /// Material between the channel top and the bottom of a gap.
    pub roof: f64,
}

impl Default for Geometry {
    fn default() -> Self {
        Self {
            family: Family::Pneunets,
            chambers: 9,
            b: 116.0,
            i: 15.0,
            f: 6.0,
            m: 2.0,
            p: 7.0,
            r: 105.0,
            c: 13.75,
            g: 11.5,
            d: 1.0,
            e: 5.0,
            l: 11.0,
            n: 12.0,
            top_wall: 3.5,
            roof: 1.0,
        }
    }
}

fn bad(name: &str, why: String) -> FemError {
    FemError::Parameter {
        name: name.to_string(),
        why,
    }
}

impl Geometry {
    /// Total height a.
    pub fn height(&self) -> f64 {
        self.f + self.m + self.n + self.top_wall
    }

    /// Length taken by the chambers and gaps: 2c + (N-2) g + (N-1) d.
    pub fn chambers_length(&self) -> f64 {
        let n = self.chambers as f64;
        2.0 * self.c + (n - 2.0) * self.g + (n - 1.0) * self.d
    }

    /// x extent of every chamber block.
    pub fn blocks(&self) -> Vec<(f64, f64)> {
        let mut x = 0.0;
        (0..self.chambers)
            .map(|k| {
                let len = if k == 0 || k + 1 == self.chambers {
                    self.c
                } else {
                    self.g
                };
                let span = (x, x + len);
                x += len + self.d;
                span
            })
            .collect()
    }

    /// x of the marker lines: centres of chambers 2..N.
    pub fn marker_x(&self) -> Vec<f64> {
        self.blocks()
            .iter()
            .skip(1)
            .map(|(a, b)| 0.5 * (a + b))
            .collect()
    }

    /// z of the markers: mid cavity height.
    pub fn marker_z(&self) -> f64 {
        self.f + self.m + 0.5 * self.n
    }

    /// Checks that the numbers describe a buildable actuator.
    pub fn validate(&self) -> Result<(), FemError> {
        let sizes = [
            ("b", self.b),
            ("i", self.i),
            ("f", self.f),
            ("m", self.m),
            ("p", self.p),
            ("r", self.r),
            ("c", self.c),
            ("g", self.g),
            ("d", self.d),
            ("e", self.e),
            ("l", self.l),
            ("n", self.n),
            ("top_wall", self.top_wall),
        ];
        for (name, v) in sizes {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(name, format!("{v} mm: sizes must be positive")));
            }
        }
        if !(self.roof.is_finite() && self.roof >= 0.0) {
            return Err(bad("roof", format!("{} mm: must be >= 0", self.roof)));
        }
        if self.chambers < 2 {
            return Err(bad(
                "chambers",
                format!("{}: need at least 2 (the first is clamped)", self.chambers),
            ));
        }
        for (name, cavity, body) in [("l", self.l, self.i), ("p", self.p, self.i)] {
            if cavity >= body {
                return Err(bad(
                    name,
                    format!("{cavity} mm is not narrower than the body width i = {body} mm: the side walls would vanish"),
                ));
            }
        }
        let inner = if self.chambers > 2 { self.g } else { self.c };
        if self.e >= inner.min(self.c) {
            return Err(bad(
                "e",
                format!(
                    "cavity length {} mm does not fit in a chamber of {} mm: walls would vanish",
                    self.e,
                    inner.min(self.c)
                ),
            ));
        }
        let needed = self.chambers_length();
        if needed > self.b + 1e-9 {
            return Err(bad(
                "chambers",
                format!(
                    "{} chambers need 2c + (N-2)g + (N-1)d = {needed} mm but the length b is {} mm: lower the count or the sizes, or raise b",
                    self.chambers, self.b
                ),
            ));
        }
        if self.r >= self.b {
            return Err(bad(
                "r",
                format!(
                    "channel length {} mm must be shorter than b = {} mm",
                    self.r, self.b
                ),
            ));
        }
        let x0 = 0.5 * (self.b - self.r);
        let cavity_ends = self.blocks().into_iter().map(|(a, b)| {
            let mid = 0.5 * (a + b);
            (mid - 0.5 * self.e, mid + 0.5 * self.e)
        });
        if let Some((k, _)) = cavity_ends
            .enumerate()
            .find(|(_, (lo, hi))| *hi < x0 || *lo > x0 + self.r)
        {
            return Err(bad(
                "r",
                format!(
                    "the channel ({} mm long, centred) does not reach chamber {}: raise r",
                    self.r,
                    k + 1
                ),
            ));
        }
        if self.roof >= self.n + self.top_wall {
            return Err(bad(
                "roof",
                format!("{} mm leaves no gap between the chambers", self.roof),
            ));
        }
        Ok(())
    }
}

/// Material of the actuator: a preset, optionally with coefficients overridden.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MaterialConfig {
    /// Named Yeoh set of method.md §4.
    pub preset: MaterialPreset,
    /// Overrides C1, MPa.
    pub c1: Option<f64>,
    /// Overrides C2, MPa.
    pub c2: Option<f64>,
    /// Overrides C3, MPa.
    pub c3: Option<f64>,
    /// Bulk modulus, MPa; default 1000 μ0 = 2000 C1.
    pub bulk_modulus_mpa: Option<f64>,
    /// Density, g/cm³ (gravity load).
    pub density_g_cm3: f64,
    /// Tensile strength, MPa (safety factor).
    pub tensile_strength_mpa: f64,
    /// Factor on every coefficient (C1, C2, C3 and the bulk modulus): the whole strain
    /// energy scaled, the stiffness fitted by `bendscope fit-model` (`material.scale`).
    pub scale: f64,
}

impl Default for MaterialConfig {
    fn default() -> Self {
        Self {
            preset: MaterialPreset::Proposed,
            c1: None,
            c2: None,
            c3: None,
            bulk_modulus_mpa: None,
            density_g_cm3: 1.08,
            tensile_strength_mpa: 3.447,
            scale: 1.0,
        }
    }
}

impl MaterialConfig {
    /// Warnings about values that are valid but implausible: a C1 (times `scale`) far
    /// softer or stiffer than every preset ([`super::material::c1_warning`]).
    pub fn warnings(&self) -> Vec<String> {
        let c1 = self.c1.unwrap_or(self.preset.yeoh().c1);
        let given = match self.c1 {
            Some(v) => format!("[material] c1 = {v}"),
            None => format!("[material] preset = \"{}\"", self.preset.name()),
        };
        let what = if self.scale == 1.0 {
            given
        } else {
            format!("{given} with scale = {}", self.scale)
        };
        super::material::c1_warning(self.scale * c1, &what)
            .into_iter()
            .collect()
    }

    /// The Yeoh material (coefficients times `scale`), checked.
    pub fn yeoh(&self) -> Result<Yeoh, FemError> {
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return Err(bad(
                "scale",
                format!("{}: the material scale must be positive", self.scale),
            ));
        }
        let base = self.preset.yeoh();
        let c1 = self.c1.unwrap_or(base.c1);
        let s = self.scale;
        let m = Yeoh {
            c1: s * c1,
            c2: s * self.c2.unwrap_or(base.c2),
            c3: s * self.c3.unwrap_or(base.c3),
            bulk_modulus: s * self
                .bulk_modulus_mpa
                .unwrap_or(DEFAULT_BULK_TO_SHEAR * 2.0 * c1),
        };
        if !(m.c1.is_finite() && m.c1 > 0.0) {
            return Err(bad("c1", format!("{} MPa: must be positive", m.c1)));
        }
        for (name, v) in [("c2", m.c2), ("c3", m.c3)] {
            if !v.is_finite() || v < 0.0 {
                return Err(bad(name, format!("{v} MPa: must be >= 0")));
            }
        }
        if !(m.bulk_modulus.is_finite() && m.bulk_modulus > 0.0) {
            return Err(bad(
                "bulk_modulus_mpa",
                format!(
                    "{} MPa: must be positive (silicone: ~1000 x the shear modulus)",
                    m.bulk_modulus
                ),
            ));
        }
        for (name, v) in [
            ("density_g_cm3", self.density_g_cm3),
            ("tensile_strength_mpa", self.tensile_strength_mpa),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(name, format!("{v}: must be positive")));
            }
        }
        if self.density_g_cm3 > MAX_DENSITY_G_CM3 {
            return Err(bad(
                "density_g_cm3",
                format!(
                    "{}: no material is denser than {MAX_DENSITY_G_CM3} g/cm3 (silicones are 1.0-1.5): give g/cm3",
                    number_text(self.density_g_cm3)
                ),
            ));
        }
        Ok(m)
    }
}

/// Largest density a material may have, g/cm³ (osmium, the densest element, is 22.6).
pub const MAX_DENSITY_G_CM3: f64 = 25.0;

/// Mesh settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MeshConfig {
    /// Largest element edge, mm.
    pub size_mm: f64,
    /// The solid element ([`crate::fem::hex`]).
    pub element: SolidElement,
}

/// The hexahedron the silicone is meshed with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SolidElement {
    /// Trilinear, with the Q1/P0 mean dilatation.
    #[default]
    Q1p0,
    /// The same with three incompatible modes condensed per element (Wilson-Taylor, as
    /// CalculiX's C3D8I): it bends through one element without shear locking.
    IncompatibleModes,
}

impl SolidElement {
    /// Whether the element has incompatible modes.
    pub fn incompatible_modes(self) -> bool {
        self == Self::IncompatibleModes
    }
}

/// Default element size, mm: within 1% of the converged radius over the whole ramp
/// (+0.2..+0.7% against CalculiX C3D20R and bendscope at 1 mm, issue 11's configuration;
/// 2 mm was +3..+5%) in half the CPU time the 2 mm default took before the assembly and
/// element speed-ups (scripts/bench-simulate.sh).
pub const DEFAULT_MESH_SIZE_MM: f64 = 1.5;

/// Largest mesh accepted (elements); a finer one would not fit a workstation's memory.
pub const MAX_ELEMENTS: usize = 400_000;

impl Default for MeshConfig {
    fn default() -> Self {
        Self {
            size_mm: DEFAULT_MESH_SIZE_MM,
            element: SolidElement::default(),
        }
    }
}

/// Newton settings of a simulation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SolverConfig {
    /// Newton iterations per load increment before the increment is halved.
    pub max_iterations: usize,
    /// Residual tolerance relative to the external forces.
    pub tolerance: f64,
}

impl Default for SolverConfig {
    fn default() -> Self {
        let n = NewtonSettings::default();
        Self {
            max_iterations: n.max_iterations,
            tolerance: n.tolerance,
        }
    }
}

impl SolverConfig {
    /// The Newton settings of a pressure step (each step starts with its whole increment).
    pub fn newton(&self) -> NewtonSettings {
        NewtonSettings {
            max_iterations: self.max_iterations,
            tolerance: self.tolerance,
            ..NewtonSettings::default()
        }
    }
}

/// Everything that defines a simulated actuator.
///
/// Read from TOML or JSON over its family's defaults ([`super::family::defaults`] of
/// `geometry.family`): tables merge key by key, other values replace; a single
/// `[layer]` table updates the family's only layer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(remote = "Self")]
#[serde(default, deny_unknown_fields)]
pub struct ActuatorConfig {
    /// Geometry, mm.
    pub geometry: Geometry,
    /// Material.
    pub material: MaterialConfig,
    /// Mesh.
    pub mesh: MeshConfig,
    /// Loads.
    pub load: LoadConfig,
    /// Newton settings.
    pub solver: SolverConfig,
    /// Strain-limiting layers in the base (`[layer]` for one, `[[layer]]` for several;
    /// none in the reference actuator).
    #[serde(
        deserialize_with = "one_or_many",
        skip_serializing_if = "Vec::is_empty"
    )]
    pub layer: Vec<LayerConfig>,
    /// Frictionless contact between the facing walls of neighbouring chambers
    /// (`[contact]`; off by default).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact: Option<ContactConfig>,
    /// The fibre-reinforced tube (`[tube]`; family `fibre-reinforced` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tube: Option<TubeConfig>,
}

impl Serialize for ActuatorConfig {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        ActuatorConfig::serialize(self, s)
    }
}

impl<'de> Deserialize<'de> for ActuatorConfig {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let user = serde_json::Value::deserialize(d)?;
        let family = match user.get("geometry").and_then(|g| g.get("family")) {
            None => Family::default(),
            Some(v) => Family::deserialize(v).map_err(D::Error::custom)?,
        };
        let mut doc = serde_json::to_value(Self::for_family(family)).map_err(D::Error::custom)?;
        // `bottom_strip = false` without layers of the file's own: the family's strip
        // goes; `true`: the fibre-reinforced tube's default strip is the family's layer
        // (a `[layer]` table updates it, `[[layer]]` tables replace it).
        let strip = user
            .get("tube")
            .and_then(|t| t.get("bottom_strip"))
            .and_then(serde_json::Value::as_bool);
        if let Some(o) = doc.as_object_mut() {
            match strip {
                Some(false) if user.get("layer").is_none() => {
                    o.remove("layer");
                }
                Some(true) if family == Family::FibreReinforced => {
                    let layer = serde_json::to_value(vec![family::bottom_strip_layer()])
                        .map_err(D::Error::custom)?;
                    o.insert("layer".into(), layer);
                }
                _ => {}
            }
        }
        merge_over(&mut doc, user);
        strip_nulls(&mut doc);
        ActuatorConfig::deserialize(doc).map_err(D::Error::custom)
    }
}

/// Merges `user` over `base`: objects key by key, anything else replaces; an object
/// over an array of one object merges into that object (`[layer]` over one layer).
fn merge_over(base: &mut serde_json::Value, user: serde_json::Value) {
    use serde_json::Value;
    match (base, user) {
        (Value::Object(b), Value::Object(u)) => {
            for (k, v) in u {
                match b.get_mut(&k) {
                    Some(slot) => merge_over(slot, v),
                    None => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (Value::Array(b), u @ Value::Object(_)) if b.len() == 1 && b[0].is_object() => {
            merge_over(&mut b[0], u)
        }
        (slot, u) => *slot = u,
    }
}

/// Removes null members (JSON's "not given", e.g. an unset `c1`).
fn strip_nulls(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(m) => {
            m.retain(|_, x| !x.is_null());
            m.values_mut().for_each(strip_nulls);
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(strip_nulls),
        _ => {}
    }
}

/// `[layer]` (one table) or `[[layer]]` (an array of tables).
fn one_or_many<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<LayerConfig>, D::Error> {
    use serde::de::Error;
    match serde_json::Value::deserialize(d)? {
        v @ serde_json::Value::Array(_) => serde_json::from_value(v).map_err(D::Error::custom),
        v => Ok(vec![serde_json::from_value(v).map_err(D::Error::custom)?]),
    }
}

/// Loads of a simulation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LoadConfig {
    /// Pressure steps, kPa: "start:stop:step" or a comma-separated list.
    pub pressures_kpa: String,
    /// Gravity on.
    pub gravity: bool,
    /// Direction of gravity in the actuator's frame (x from the clamp to the tip, z up
    /// from the bottom face); [0, 0, -1]: lying bottom down; [1, 0, 0]: hanging from the
    /// clamp.
    pub gravity_direction: [f64; 3],
}

impl Default for LoadConfig {
    fn default() -> Self {
        Self {
            pressures_kpa: "10:115:5".into(),
            gravity: true,
            gravity_direction: [0.0, 0.0, -1.0],
        }
    }
}

/// The table at `path` in a config document: sections by name; in an array of tables
/// (`[[layer]]`) an element by its number from 1 or its `name` (`layer.2`,
/// `layer.fabric`). For sweeps and fits naming `section.field` or `layer.NAME.field`.
pub fn config_table_at<'a>(
    doc: &'a mut toml::Table,
    path: &[&str],
) -> Result<&'a mut toml::Table, String> {
    let mut table = doc;
    for (k, s) in path.iter().enumerate() {
        let here = path[..=k].join(".");
        table = match table.get_mut(*s) {
            Some(toml::Value::Table(t)) => t,
            Some(toml::Value::Array(items)) => {
                let Some(next) = path.get(k + 1) else {
                    return Err(format!("'{here}' is a list: name one of its entries, e.g. {here}.1"));
                };
                let count = items.len();
                let hit = match next.parse::<usize>() {
                    Ok(n) => n.checked_sub(1).and_then(|i| items.get_mut(i)),
                    Err(_) => items
                        .iter_mut()
                        .find(|v| v.get("name").and_then(|n| n.as_str()) == Some(*next)),
                };
                let Some(toml::Value::Table(t)) = hit else {
                    return Err(format!(
                        "no entry '{next}' in '{here}' ({count} there: number them from 1 or use their name)"
                    ));
                };
                // The entry's name or number is consumed with it.
                return config_table_at(t, &path[k + 2..]);
            }
            _ => {
                return Err(format!(
                    "no section '{here}' (sections: geometry, material, mesh, load, solver, layer, contact)"
                ))
            }
        };
    }
    Ok(table)
}

/// Refuses a pressure above [`crate::session::MAX_PLAUSIBLE_PRESSURE_KPA`] in magnitude
/// (where `process` warns): no soft actuator sees it, and the solve would run for long
/// before diverging.
fn check_plausible_pressures(p: &[f64]) -> Result<(), FemError> {
    let max = crate::session::MAX_PLAUSIBLE_PRESSURE_KPA;
    match p.iter().find(|v| v.abs() > max) {
        Some(v) => Err(bad(
            "pressures",
            format!(
                "{} kPa is above {max} kPa (10 MPa), not plausible for a soft actuator: give kPa (e.g. 10:100:10)",
                number_text(*v)
            ),
        )),
        None => Ok(()),
    }
}

/// `v` as a message shows it: `1e300`, not three hundred digits.
fn number_text(v: f64) -> String {
    if v.abs() >= 1e6 {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Parses "start:stop:step" (inclusive) or "a,b,c" into values; `what` names the
/// quantity in messages.
pub fn parse_range(text: &str, what: &str) -> Result<Vec<f64>, FemError> {
    let num = |s: &str| -> Result<f64, FemError> {
        let v: f64 = s.trim().parse().map_err(|_| {
            bad(
                what,
                format!(
                    "'{}' is not a number (expected start:stop:step or a,b,c)",
                    s.trim()
                ),
            )
        })?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(bad(what, format!("'{}' is not finite", s.trim())))
        }
    };
    let parts: Vec<&str> = text.split(':').collect();
    let values = match parts.len() {
        1 => text.split(',').map(num).collect::<Result<Vec<_>, _>>()?,
        3 => {
            let (a, b, s) = (num(parts[0])?, num(parts[1])?, num(parts[2])?);
            if !(s > 0.0) || b < a {
                return Err(bad(
                    what,
                    format!("'{text}': need start <= stop and a positive step"),
                ));
            }
            let count = ((b - a) / s + 1e-9).floor() as usize + 1;
            if count > 10_000 {
                return Err(bad(
                    what,
                    format!("'{text}' gives {count} values: use a larger step"),
                ));
            }
            (0..count).map(|k| a + k as f64 * s).collect()
        }
        _ => {
            return Err(bad(
                what,
                format!("'{text}': expected start:stop:step or a comma-separated list"),
            ))
        }
    };
    if values.is_empty() {
        return Err(bad(what, "no values".into()));
    }
    Ok(values)
}

impl ActuatorConfig {
    /// The config in the TOML file `path` (as `simulate --print-config` prints one), not
    /// yet validated.
    pub fn read(path: &std::path::Path) -> Result<Self, FemError> {
        let text = std::fs::read_to_string(path).map_err(|e| FemError::Input {
            why: format!("cannot read actuator config {}: {e}", path.display()),
        })?;
        toml::from_str(&text).map_err(|e| FemError::Input {
            why: format!(
                "{} is not a valid actuator config: {} (see bendscope simulate --print-config)",
                path.display(),
                e.message()
            ),
        })
    }

    /// The config as TOML, as `simulate --print-config` prints it and config.toml holds
    /// it (arrays on one line: `gravity_direction = [0.0, 0.0, -1.0]`).
    pub fn to_toml(&self) -> Result<String, FemError> {
        toml::to_string(self).map_err(|e| FemError::Output {
            why: format!("the config cannot be written as TOML: {e}"),
        })
    }

    /// The pressure steps, kPa, checked (non-negative, at most 10 MPa, increasing).
    pub fn pressures_kpa(&self) -> Result<Vec<f64>, FemError> {
        let p = parse_range(&self.load.pressures_kpa, "pressures")?;
        check_plausible_pressures(&p)?;
        if let Some(v) = p.iter().find(|v| **v < 0.0) {
            return Err(bad(
                "pressures",
                format!("{v} kPa: pressures must be >= 0 (gauge pressure in the cavities)"),
            ));
        }
        if p.windows(2).any(|w| w[1] <= w[0]) {
            return Err(bad("pressures", "pressures must increase".into()));
        }
        Ok(p)
    }

    /// Checks every parameter.
    pub fn validate(&self) -> Result<(), FemError> {
        self.geometry.validate()?;
        self.material.yeoh()?;
        self.pressures_kpa()?;
        self.validate_layers()?;
        let d = self.load.gravity_direction;
        if !(d.iter().all(|v| v.is_finite()) && d.iter().map(|v| v * v).sum::<f64>() > 1e-12) {
            return Err(bad(
                "gravity_direction",
                format!("{d:?}: give a non-zero direction, e.g. [0, 0, -1] (lying) or [1, 0, 0] (hanging)"),
            ));
        }
        match (&self.tube, self.geometry.family) {
            (Some(t), Family::FibreReinforced) => {
                t.validate()?;
                super::fibre::validate_strips(self, t)?;
                if !t.bottom_strip && !self.layer.is_empty() {
                    return Err(bad(
                        "tube.bottom_strip",
                        "false, but the config has [[layer]]s (the strip): remove them or set bottom_strip = true".into(),
                    ));
                }
            }
            (None, Family::FibreReinforced) => {
                return Err(bad(
                    "tube",
                    "the fibre-reinforced family needs a [tube] section (see bendscope simulate --family fibre-reinforced --print-config)".into(),
                ))
            }
            (Some(_), f) => {
                return Err(bad(
                    "tube",
                    format!("[tube] describes the fibre-reinforced family, and this config is family = \"{f}\": remove [tube] or set family = \"fibre-reinforced\""),
                ))
            }
            (None, _) => {}
        }
        if matches!(self.geometry.family, Family::Glove | Family::Strap) && self.layer.is_empty() {
            return Err(bad(
                "layer",
                format!(
                    "the {} family is a PneuNets with strain-limiting layers, and this config has none: add a [[layer]] (see bendscope simulate --family {} --print-config) or use family = \"pneunets\"",
                    self.geometry.family, self.geometry.family
                ),
            ));
        }
        if let Some(contact) = &self.contact {
            contact.validate()?;
        }
        let h = self.mesh.size_mm;
        if !(h.is_finite() && h > 0.0) {
            return Err(bad("mesh size", format!("{h} mm: must be positive")));
        }
        if self.solver.max_iterations == 0 {
            return Err(bad("max_iterations", "must be at least 1".into()));
        }
        let t = self.solver.tolerance;
        if !(t > 0.0 && t <= 1e-3) {
            return Err(bad(
                "tolerance",
                format!("{t}: use a relative tolerance in (0, 1e-3]"),
            ));
        }
        Ok(())
    }

    /// The family's whole default configuration ([`super::family::defaults`]).
    pub fn for_family(family: Family) -> Self {
        family::defaults(family)
    }

    /// Checks every layer against the base and the others: each fits in the base and the
    /// width; solid layers do not overlap.
    fn validate_layers(&self) -> Result<(), FemError> {
        if self.geometry.family == Family::FibreReinforced {
            // The strip is checked against the tube ([`super::fibre::validate_strips`]).
            return Ok(());
        }
        let g = &self.geometry;
        for (k, layer) in self.layer.iter().enumerate() {
            layer
                .validate(g.f)
                .and_then(|_| layer.validate_width(g.i))
                .map_err(|e| match e {
                    FemError::Parameter { name, why } if self.layer.len() > 1 => {
                        FemError::Parameter {
                            name: format!("{name} (layer {}, '{}')", k + 1, layer.name),
                            why,
                        }
                    }
                    e => e,
                })?;
        }
        let solid: Vec<(usize, &LayerConfig)> = self
            .layer
            .iter()
            .enumerate()
            .filter(|(_, l)| l.element == LayerElement::Solid)
            .collect();
        for (a, (ka, la)) in solid.iter().enumerate() {
            for (kb, lb) in &solid[a + 1..] {
                let z = la.height_mm < lb.height_mm + lb.thickness_mm
                    && lb.height_mm < la.height_mm + la.thickness_mm;
                let y = la.half_y_ranges(g.i).iter().any(|(a0, a1)| {
                    lb.half_y_ranges(g.i)
                        .iter()
                        .any(|(b0, b1)| a0 < b1 && b0 < a1)
                });
                if z && y {
                    return Err(bad(
                        "layer",
                        format!(
                            "solid layers {} and {} overlap: give them different height_mm",
                            ka + 1,
                            kb + 1
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Sets one parameter by name (a field of any section, e.g. `f`, `chambers`, `c2`,
    /// `bulk_modulus_mpa`, `size_mm`) to a number, for sweeps.
    pub fn with_parameter(&self, name: &str, value: f64) -> Result<Self, FemError> {
        let mut doc = toml::Table::try_from(self).map_err(|e| FemError::Model {
            why: format!("config: {e}"),
        })?;
        let mut hit = false;
        for (_, section) in doc.iter_mut() {
            let Some(table) = section.as_table_mut() else {
                continue;
            };
            if let Some(old) = table.get(name).cloned() {
                let new = if old.is_integer() || name == "chambers" {
                    if value.fract() != 0.0 || value < 0.0 {
                        return Err(bad(name, format!("{value}: must be a whole number")));
                    }
                    toml::Value::Integer(value as i64)
                } else {
                    toml::Value::Float(value)
                };
                table.insert(name.to_string(), new);
                hit = true;
            } else if ["c1", "c2", "c3", "bulk_modulus_mpa"].contains(&name)
                && table.contains_key("preset")
            {
                table.insert(name.to_string(), toml::Value::Float(value));
                hit = true;
            }
        }
        if !hit {
            return Err(bad(
                name,
                format!("no such parameter of this config ({})", numeric_keys(&doc)),
            ));
        }
        doc.try_into()
            .map_err(|e: toml::de::Error| FemError::Model {
                why: format!("config: {e}"),
            })
    }
}

/// The numbers of a config's sections, as `section: key key ...; ...` (what
/// [`ActuatorConfig::with_parameter`] can set: each family's own sections are there, e.g.
/// `tube` for the fibre-reinforced family).
fn numeric_keys(doc: &toml::Table) -> String {
    let mut out = Vec::new();
    for (section, value) in doc {
        let Some(table) = value.as_table() else {
            continue;
        };
        let mut keys: Vec<&str> = table
            .iter()
            .filter(|(_, v)| v.is_integer() || v.is_float())
            .map(|(k, _)| k.as_str())
            .collect();
        if table.contains_key("preset") {
            for k in ["c1", "c2", "c3", "bulk_modulus_mpa"] {
                if !keys.contains(&k) {
                    keys.push(k);
                }
            }
        }
        if !keys.is_empty() {
            out.push(format!("{section}: {}", keys.join(" ")));
        }
    }
    out.join("; ")
}

/// The meshed half actuator and the nodes results are read at.
#[derive(Debug, Clone)]
pub struct ActuatorMesh {
    /// The finite-element model (dead loads: gravity).
    pub model: Model,
    /// Marker nodes (side face, centre of chambers 2..N, mid cavity height), from the
    /// clamp towards the tip.
    pub markers: Vec<usize>,
    /// Tip node: bottom edge of the free end on the symmetry plane (x = b, y = 0, z = 0).
    pub tip: usize,
    /// Nodes of the free end's bottom edge (x = b, z = 0): the blocked-force support.
    pub tip_support: Vec<usize>,
    /// Bottom centre line (y = 0, z = 0) beyond the clamp (x >= c), ordered by x.
    pub bottom_line: Vec<usize>,
    /// The side face y = i/2 (the filmed face): quads of nodes, counter-clockwise in x-z.
    pub side_face: Vec<[usize; 4]>,
    /// Clamped length (first chamber), mm.
    pub clamp_mm: f64,
    /// The facing walls across every gap between chambers, paired both ways (each with
    /// half the node areas, [`super::contact`]): where `min_wall_gap_mm` is measured,
    /// and the contact pairs when `[contact]` is on.
    pub wall_pairs: Vec<ContactPair>,
    /// The parts whose stress is reported, the main silicone first.
    pub parts: Vec<Part>,
    /// Two nodes of the free end's face, the first below the second on the actuator's
    /// axis plane: the tip face's twist about the axis is read off them.
    pub twist_pair: (usize, usize),
    /// The model is the half y >= 0 of a mirror-symmetric actuator (forces and volumes
    /// of the whole are twice the model's).
    pub half_model: bool,
    /// Density of each solid material, g/cm³, by material id ([`Model::element_material`]:
    /// 0 the main silicone, k `extra_materials[k - 1]`): the gravity loads' and the
    /// exported deck's.
    pub densities_g_cm3: Vec<f64>,
    /// Where the bottom wall's inflation is read ([`BottomWall`]).
    pub bottom_wall: Option<BottomWall>,
}

/// A bottom wall whose inflation is reported: its centre's distance from the chord of its
/// ends, positive away from the cavity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BottomWall {
    /// The chord's ends, bottom-face nodes. The same node twice on a half model: the chord
    /// from it to its mirror image across the symmetry plane y = 0.
    pub ends: [usize; 2],
    /// The bottom-face node between the ends.
    pub centre: usize,
    /// A node on the cavity's side of the centre (the cavity's floor above it): the
    /// inflation is positive away from it.
    pub inside: usize,
}

impl BottomWall {
    /// The inflation, mm, with the nodes at `position`.
    pub fn inflation_mm(&self, position: impl Fn(usize) -> Vector3<f64>) -> f64 {
        let [a, b] = self.ends.map(&position);
        let b = if self.ends[0] == self.ends[1] {
            Vector3::new(b.x, -b.y, b.z)
        } else {
            b
        };
        let c = position(self.centre);
        let d = (b - a).normalize();
        let w = (c - a) - (c - a).dot(&d) * d;
        w.norm() * w.dot(&(c - position(self.inside))).signum()
    }
}

/// A part of the model (a silicone, a layer, a fibre set) and the elements it is made of.
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    /// Name (silicone, a layer's name, fibre): the stress columns' suffix.
    pub name: String,
    /// Tensile strength, MPa, for its safety factor (None: not reported).
    pub tensile_strength_mpa: Option<f64>,
    /// Solid elements of this material id ([`Model::element_material`]), if any.
    pub solid_material: Option<u8>,
    /// Membrane elements (indices into [`Model::membranes`]).
    pub membranes: Vec<usize>,
    /// The membranes carry the sheet's bending stiffness ([`Model::plates`], a layer
    /// with `element = "plate"`).
    pub plate: bool,
    /// Fibre segments (indices into [`Model::trusses`]).
    pub trusses: Vec<usize>,
}

/// Least number of elements through every wall (side walls beside the chambers and the
/// channel, chamber walls, top wall, bottom, the roof over the channel under the gaps):
/// one trilinear element through a wall in
/// bending is far too stiff (the 2 mm mesh with one element through the 2 mm side walls
/// was +2.5..+4.5% on the radius); two through, at the mesh size along, converge.
pub const MIN_WALL_ELEMENTS: usize = 2;

/// Coordinate lines through `features` (sorted, deduplicated), each interval cut into
/// equal parts no longer than `h`; an interval that is one of `walls` (lo, hi) gets at
/// least `MIN_WALL_ELEMENTS` parts.
pub(crate) fn coordinate_lines(mut features: Vec<f64>, h: f64, walls: &[(f64, f64)]) -> Vec<f64> {
    features.sort_by(f64::total_cmp);
    features.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    let is_wall = |a: f64, b: f64| {
        walls
            .iter()
            .any(|(lo, hi)| (a - lo).abs() < 1e-9 && (b - hi).abs() < 1e-9)
    };
    let mut out = vec![features[0]];
    for w in features.windows(2) {
        let mut parts = ((w[1] - w[0]) / h - 1e-9).ceil().max(1.0) as usize;
        if is_wall(w[0], w[1]) {
            parts = parts.max(MIN_WALL_ELEMENTS);
        }
        for k in 1..=parts {
            out.push(w[0] + (w[1] - w[0]) * k as f64 / parts as f64);
        }
    }
    out
}

fn index_of(lines: &[f64], v: f64) -> usize {
    lines
        .iter()
        .enumerate()
        .min_by(|a, b| (a.1 - v).abs().total_cmp(&(b.1 - v).abs()))
        .map(|(k, _)| k)
        .unwrap_or(0)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Cell {
    Solid,
    Cavity,
    Outside,
}

/// Nodal gravity loads at load factor 1 (zero when `cfg.load.gravity` is off): ρ g ∫ N_a dV
/// along the gravity direction (N per mm³ = g/cm³ · 1e-6 kg/mm³ · g), element e of density
/// `densities_g_cm3[element_material[e]]` (material 0 where `element_material` is empty).
pub(crate) fn gravity_loads(
    cfg: &ActuatorConfig,
    nodes: &[Vector3<f64>],
    elements: &[[usize; 8]],
    element_material: &[u8],
    densities_g_cm3: &[f64],
) -> Result<Vec<f64>, FemError> {
    let density_g_cm3 = |e: usize| {
        let k = element_material.get(e).map_or(0, |&k| usize::from(k));
        densities_g_cm3.get(k).copied().ok_or(FemError::Model {
            why: format!("material {k} has no density (mesh bug)"),
        })
    };
    let mut loads = vec![0.0; 3 * nodes.len()];
    if !cfg.load.gravity {
        return Ok(loads);
    }
    let down = Vector3::from(cfg.load.gravity_direction).normalize();
    for (e, el) in elements.iter().enumerate() {
        let weight_per_mm3 = density_g_cm3(e)? * 1e-6 * GRAVITY_M_S2;
        let x: [Vector3<f64>; 8] = std::array::from_fn(|a| nodes[el[a]]);
        let geom = HexGeometry::new(&x).ok_or(FemError::Model {
            why: "degenerate element (mesh bug)".into(),
        })?;
        for (a, v) in nodal_volumes(&geom).iter().enumerate() {
            for d in 0..3 {
                loads[3 * el[a] + d] += weight_per_mm3 * v * down[d];
            }
        }
    }
    Ok(loads)
}

/// Meshes the half actuator (y ≥ 0) described by `cfg`.
pub fn build_mesh(cfg: &ActuatorConfig) -> Result<ActuatorMesh, FemError> {
    cfg.validate()?;
    if cfg.geometry.family == Family::FibreReinforced {
        return super::fibre::build_mesh(cfg);
    }
    let g = &cfg.geometry;
    let h = cfg.mesh.size_mm;
    let material = cfg.material.yeoh()?;
    let blocks = g.blocks();
    let cavities: Vec<(f64, f64)> = blocks
        .iter()
        .map(|(a, b)| (0.5 * (a + b) - 0.5 * g.e, 0.5 * (a + b) + 0.5 * g.e))
        .collect();
    let (ch0, ch1) = (0.5 * (g.b - g.r), 0.5 * (g.b + g.r));
    let (z_channel, z_cavity) = (g.f, g.f + g.m);
    let (z_gap, z_top, a) = (z_cavity + g.roof, z_cavity + g.n, g.height());

    let mut fx = vec![0.0, g.b, ch0, ch1];
    for ((b0, b1), (c0, c1)) in blocks.iter().zip(&cavities) {
        fx.extend([*b0, *b1, *c0, *c1, 0.5 * (b0 + b1)]);
    }
    let x_walls: Vec<(f64, f64)> = blocks
        .iter()
        .zip(&cavities)
        .flat_map(|((b0, b1), (c0, c1))| [(*b0, *c0), (*c1, *b1)])
        .collect();
    let xs = coordinate_lines(fx, h, &x_walls);
    let mut fy = vec![0.0, 0.5 * g.p, 0.5 * g.l, 0.5 * g.i];
    for layer in &cfg.layer {
        for (y0, y1) in layer.half_y_ranges(g.i) {
            fy.extend([y0, y1]);
        }
    }
    let ys = coordinate_lines(fy, h, &[(0.5 * g.l, 0.5 * g.i), (0.5 * g.p, 0.5 * g.i)]);
    let mut fz = vec![0.0, z_channel, z_cavity, z_gap, g.marker_z(), z_top, a];
    for layer in &cfg.layer {
        match layer.element {
            LayerElement::Solid => {
                fz.extend([layer.height_mm, layer.height_mm + layer.thickness_mm])
            }
            LayerElement::Membrane | LayerElement::Plate => fz.push(layer.membrane_height_mm()),
        }
    }
    let zs = coordinate_lines(fz, h, &[(0.0, z_channel), (z_cavity, z_gap), (z_top, a)]);
    let (nx, ny, nz) = (xs.len() - 1, ys.len() - 1, zs.len() - 1);
    if nx * ny * nz > MAX_ELEMENTS {
        return Err(bad(
            "mesh size",
            format!(
                "{h} mm gives {} cells, more than the {MAX_ELEMENTS} this solver is sized for: use a larger mesh size",
                nx * ny * nz
            ),
        ));
    }

    let inside = |v: f64, lo: f64, hi: f64| v > lo && v < hi;
    let classify = |x: f64, y: f64, z: f64| -> Cell {
        if inside(x, ch0, ch1) && y < 0.5 * g.p && inside(z, z_channel, z_cavity) {
            return Cell::Cavity;
        }
        if y < 0.5 * g.l
            && inside(z, z_cavity, z_top)
            && cavities.iter().any(|(c0, c1)| inside(x, *c0, *c1))
        {
            return Cell::Cavity;
        }
        if z > z_gap && blocks.windows(2).any(|w| inside(x, w[0].1, w[1].0)) {
            return Cell::Outside;
        }
        Cell::Solid
    };
    let cell_id = |i: usize, j: usize, k: usize| (k * ny + j) * nx + i;
    let mut cells = vec![Cell::Solid; nx * ny * nz];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                cells[cell_id(i, j, k)] = classify(
                    0.5 * (xs[i] + xs[i + 1]),
                    0.5 * (ys[j] + ys[j + 1]),
                    0.5 * (zs[k] + zs[k + 1]),
                );
            }
        }
    }

    // Nodes used by solid cells, numbered compactly.
    let grid_id = |i: usize, j: usize, k: usize| (k * (ny + 1) + j) * (nx + 1) + i;
    let mut node_of = vec![usize::MAX; (nx + 1) * (ny + 1) * (nz + 1)];
    let mut nodes = Vec::new();
    let mut node = |i: usize, j: usize, k: usize, nodes: &mut Vec<Vector3<f64>>| -> usize {
        let gi = grid_id(i, j, k);
        if node_of[gi] == usize::MAX {
            node_of[gi] = nodes.len();
            nodes.push(Vector3::new(xs[i], ys[j], zs[k]));
        }
        node_of[gi]
    };
    let mut elements = Vec::new();
    let mut element_material = Vec::new();
    // Material of a cell: 0 silicone, k the k-th solid layer (extra_materials[k - 1]).
    let solid_layers: Vec<(&LayerConfig, Vec<(f64, f64)>)> = cfg
        .layer
        .iter()
        .filter(|l| l.element == LayerElement::Solid)
        .map(|l| (l, l.half_y_ranges(g.i)))
        .collect();
    let in_layer = |j: usize, k: usize| -> u8 {
        let (yc, zc) = (0.5 * (ys[j] + ys[j + 1]), 0.5 * (zs[k] + zs[k + 1]));
        solid_layers
            .iter()
            .position(|(l, ranges)| {
                zc > l.height_mm
                    && zc < l.height_mm + l.thickness_mm
                    && ranges.iter().any(|(y0, y1)| yc > *y0 && yc < *y1)
            })
            .map_or(0, |k| (k + 1) as u8)
    };
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if cells[cell_id(i, j, k)] != Cell::Solid {
                    continue;
                }
                element_material.push(in_layer(j, k));
                let corners = [
                    (i, j, k),
                    (i + 1, j, k),
                    (i + 1, j + 1, k),
                    (i, j + 1, k),
                    (i, j, k + 1),
                    (i + 1, j, k + 1),
                    (i + 1, j + 1, k + 1),
                    (i, j + 1, k + 1),
                ];
                elements.push(corners.map(|(a, b, c)| node(a, b, c, &mut nodes)));
            }
        }
    }

    // Membrane layers: a quad on the layer's plane under (or over) every solid cell
    // within its y ranges (the base is solid through its whole length there).
    let mut membranes = Vec::new();
    // Each layer's membranes (none for a solid layer), in the config's order.
    let mut layer_membranes: Vec<Vec<usize>> = Vec::new();
    for layer in &cfg.layer {
        if !layer.is_sheet() {
            layer_membranes.push(Vec::new());
            continue;
        }
        let km = index_of(&zs, layer.membrane_height_mm());
        let section = layer.section();
        let ranges = layer.half_y_ranges(g.i);
        let mut part = Vec::new();
        for j in 0..ny {
            let yc = 0.5 * (ys[j] + ys[j + 1]);
            if !ranges.iter().any(|(y0, y1)| yc > *y0 && yc < *y1) {
                continue;
            }
            for i in 0..nx {
                let above = km < nz && cells[cell_id(i, j, km)] == Cell::Solid;
                let below = km > 0 && cells[cell_id(i, j, km - 1)] == Cell::Solid;
                if above || below {
                    let corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
                    part.push(membranes.len());
                    membranes.push(MembraneElement {
                        nodes: corners.map(|(a, b)| node_of[grid_id(a, b, km)]),
                        section,
                    });
                }
            }
        }
        layer_membranes.push(part);
    }

    // Cavity faces: between a cavity cell and a solid neighbour, normal into the solid.
    let mut pressure_faces = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if cells[cell_id(i, j, k)] != Cell::Cavity {
                    continue;
                }
                let solid = |di: isize, dj: isize, dk: isize| {
                    let (a, b, c) = (i as isize + di, j as isize + dj, k as isize + dk);
                    a >= 0
                        && b >= 0
                        && c >= 0
                        && (a as usize) < nx
                        && (b as usize) < ny
                        && (c as usize) < nz
                        && cells[cell_id(a as usize, b as usize, c as usize)] == Cell::Solid
                };
                let (i1, j1, k1) = (i + 1, j + 1, k + 1);
                let mut quads: Vec<[(usize, usize, usize); 4]> = Vec::new();
                if solid(1, 0, 0) {
                    quads.push([(i1, j, k), (i1, j1, k), (i1, j1, k1), (i1, j, k1)]);
                }
                if solid(-1, 0, 0) {
                    quads.push([(i, j, k), (i, j, k1), (i, j1, k1), (i, j1, k)]);
                }
                if solid(0, 1, 0) {
                    quads.push([(i, j1, k), (i, j1, k1), (i1, j1, k1), (i1, j1, k)]);
                }
                if solid(0, -1, 0) {
                    quads.push([(i, j, k), (i1, j, k), (i1, j, k1), (i, j, k1)]);
                }
                if solid(0, 0, 1) {
                    quads.push([(i, j, k1), (i1, j, k1), (i1, j1, k1), (i, j1, k1)]);
                }
                if solid(0, 0, -1) {
                    quads.push([(i, j, k), (i, j1, k), (i1, j1, k), (i1, j, k)]);
                }
                for q in quads {
                    pressure_faces.push(q.map(|(a, b, c)| node_of[grid_id(a, b, c)]));
                }
            }
        }
    }
    if pressure_faces.iter().flatten().any(|n| *n == usize::MAX) {
        return Err(FemError::Model {
            why: "a cavity face has a node outside the solid (mesh bug)".into(),
        });
    }

    // Facing walls across each gap: faces between a gap cell and a solid cell beside it
    // in x, normal out of the wall's block into the gap (ξ along y, η along z for the
    // left wall's +x normal; ξ along z, η along y for the right wall's -x).
    let gaps = blocks.len().saturating_sub(1);
    let mut left_walls: Vec<Vec<[usize; 4]>> = vec![Vec::new(); gaps];
    let mut right_walls: Vec<Vec<[usize; 4]>> = vec![Vec::new(); gaps];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if cells[cell_id(i, j, k)] != Cell::Outside {
                    continue;
                }
                let xc = 0.5 * (xs[i] + xs[i + 1]);
                let Some(gap) = blocks.windows(2).position(|w| inside(xc, w[0].1, w[1].0)) else {
                    continue;
                };
                let (j1, k1) = (j + 1, k + 1);
                let node = |a: usize, b: usize, c: usize| node_of[grid_id(a, b, c)];
                if i > 0 && cells[cell_id(i - 1, j, k)] == Cell::Solid {
                    left_walls[gap].push([
                        node(i, j, k),
                        node(i, j1, k),
                        node(i, j1, k1),
                        node(i, j, k1),
                    ]);
                }
                if i + 1 < nx && cells[cell_id(i + 1, j, k)] == Cell::Solid {
                    let i1 = i + 1;
                    right_walls[gap].push([
                        node(i1, j, k),
                        node(i1, j, k1),
                        node(i1, j1, k1),
                        node(i1, j1, k),
                    ]);
                }
            }
        }
    }
    if left_walls
        .iter()
        .chain(&right_walls)
        .flatten()
        .flatten()
        .any(|n| *n == usize::MAX)
    {
        return Err(FemError::Model {
            why: "a chamber wall face has a node outside the solid (mesh bug)".into(),
        });
    }
    let wall_pairs: Vec<ContactPair> = left_walls
        .iter()
        .zip(&right_walls)
        .flat_map(|(l, r)| [slave_against(r, l, &nodes), slave_against(l, r, &nodes)])
        .collect();

    // Supports: the first chamber is clamped; y = 0 is the symmetry plane.
    let n_nodes = nodes.len();
    let mut fixed = vec![false; 3 * n_nodes];
    for (a, x) in nodes.iter().enumerate() {
        if x.x <= g.c + 1e-9 {
            fixed[3 * a] = true;
            fixed[3 * a + 1] = true;
            fixed[3 * a + 2] = true;
        }
        if x.y.abs() < 1e-9 {
            fixed[3 * a + 1] = true;
        }
    }

    // A solid layer is moulded in the silicone's volume: it weighs as the silicone.
    let densities_g_cm3 = vec![cfg.material.density_g_cm3; 1 + solid_layers.len()];
    let loads = gravity_loads(cfg, &nodes, &elements, &element_material, &densities_g_cm3)?;

    let at = |x: f64, y: f64, z: f64| {
        node_of[grid_id(index_of(&xs, x), index_of(&ys, y), index_of(&zs, z))]
    };
    let markers: Vec<usize> = g
        .marker_x()
        .iter()
        .map(|x| at(*x, 0.5 * g.i, g.marker_z()))
        .collect();
    let tip = at(g.b, 0.0, 0.0);
    let side_face: Vec<[usize; 4]> = (0..nz)
        .flat_map(|k| (0..nx).map(move |i| (i, k)))
        .filter(|(i, k)| cells[cell_id(*i, ny - 1, *k)] == Cell::Solid)
        .map(|(i, k)| {
            [(i, k), (i + 1, k), (i + 1, k + 1), (i, k + 1)]
                .map(|(a, c)| node_of[grid_id(a, ny, c)])
        })
        .collect();
    let tip_support: Vec<usize> = (0..=ny).map(|j| node_of[grid_id(nx, j, 0)]).collect();
    let bottom_line: Vec<usize> = (0..=nx)
        .filter(|i| xs[*i] >= g.c - 1e-9)
        .map(|i| node_of[grid_id(i, 0, 0)])
        .collect();
    let mut parts = vec![Part {
        name: "silicone".into(),
        tensile_strength_mpa: Some(cfg.material.tensile_strength_mpa),
        solid_material: Some(0),
        membranes: Vec::new(),
        plate: false,
        trusses: Vec::new(),
    }];
    let mut solid_id = 0u8;
    for (layer, membranes) in cfg.layer.iter().zip(layer_membranes) {
        let solid_material = (layer.element == LayerElement::Solid).then(|| {
            solid_id += 1;
            solid_id
        });
        parts.push(Part {
            name: layer.name.clone(),
            tensile_strength_mpa: layer.tensile_strength_mpa,
            solid_material,
            membranes,
            plate: layer.element == LayerElement::Plate,
            trusses: Vec::new(),
        });
    }
    let twist_pair = (tip, at(g.b, 0.0, a));
    let bottom_wall = {
        let (x0, x1) = blocks[1];
        let xm = 0.5 * (x0 + x1);
        BottomWall {
            ends: [at(x0, 0.0, 0.0), at(x1, 0.0, 0.0)],
            centre: at(xm, 0.0, 0.0),
            inside: at(xm, 0.0, g.f),
        }
    };
    if markers
        .iter()
        .chain(&tip_support)
        .chain(&bottom_wall.ends)
        .chain(&[bottom_wall.centre, bottom_wall.inside])
        .chain(&[twist_pair.1])
        .chain(&bottom_line)
        .chain(std::iter::once(&tip))
        .chain(side_face.iter().flatten())
        .any(|n| *n == usize::MAX)
    {
        return Err(FemError::Model {
            why: "a marker or support point is not on the solid (mesh bug)".into(),
        });
    }
    // The half model's symmetry plane y = 0 mirrors a sheet.
    let mirror = [Mirror { axis: 1, at: 0.0 }];
    let plates = cfg
        .layer
        .iter()
        .zip(&parts[1..])
        .flat_map(|(layer, part)| layer.plate_terms(&nodes, &membranes, &part.membranes, &mirror))
        .collect();
    Ok(ActuatorMesh {
        model: Model {
            nodes,
            elements,
            material,
            fixed,
            loads,
            pressure_faces,
            volume_weights: CLOSED,
            element_material,
            extra_materials: solid_layers.iter().map(|(l, _)| l.material()).collect(),
            membranes,
            trusses: Vec::new(),
            plates,
            contact: cfg.contact.as_ref().filter(|c| c.enabled).map(|c| Contact {
                pairs: wall_pairs.clone(),
                penalty_mpa_per_mm: c.penalty_for(&material, h),
            }),
            incompatible_modes: cfg.mesh.element.incompatible_modes(),
        },
        markers,
        tip,
        tip_support,
        bottom_line,
        side_face,
        clamp_mm: g.c,
        wall_pairs,
        parts,
        twist_pair,
        bottom_wall: Some(bottom_wall),
        densities_g_cm3,
        half_model: true,
    })
}

/// The pair with the nodes of `slave` faces (each with half its share of their areas:
/// the walls are paired both ways) against the `master` faces.
fn slave_against(
    slave: &[[usize; 4]],
    master: &[[usize; 4]],
    nodes: &[Vector3<f64>],
) -> ContactPair {
    let mut area = std::collections::BTreeMap::new();
    for f in slave {
        let x = f.map(|a| nodes[a]);
        // A planar quad's area; each corner takes a quarter (∫ N_a dA of a parallelogram).
        let a = 0.5 * (x[2] - x[0]).cross(&(x[3] - x[1])).norm();
        for n in f {
            *area.entry(*n).or_insert(0.0) += 0.5 * 0.25 * a;
        }
    }
    ContactPair {
        slave_nodes: area.keys().copied().collect(),
        slave_areas_mm2: area.values().copied().collect(),
        master_faces: master.to_vec(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A config file reads back as written; a missing or malformed one is refused with
    /// its path named and what to do.
    #[test]
    fn a_config_file_reads_back_and_a_bad_one_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let cfg = ActuatorConfig::for_family(super::super::family::Family::Strap);
        let path = dir.path().join("strap.toml");
        std::fs::write(&path, cfg.to_toml().unwrap()).unwrap();
        assert_eq!(ActuatorConfig::read(&path).unwrap(), cfg);
        let missing = dir.path().join("none.toml");
        let err = ActuatorConfig::read(&missing).unwrap_err().to_string();
        assert!(
            err.starts_with(&format!(
                "cannot read actuator config {}: ",
                missing.display()
            )),
            "{err}"
        );
        std::fs::write(&path, "[geometry]\nchambers = \"nine\"\n").unwrap();
        let err = ActuatorConfig::read(&path).unwrap_err().to_string();
        assert!(
            err.starts_with(&format!(
                "{} is not a valid actuator config: ",
                path.display()
            )),
            "{err}"
        );
        assert!(
            err.ends_with("(see bendscope simulate --print-config)"),
            "{err}"
        );
    }

    #[test]
    fn reference_layout_matches_the_table() {
        let g = Geometry::default();
        assert!((g.chambers_length() - 116.0).abs() < 1e-12);
        assert!((g.height() - 23.5).abs() < 1e-12);
        let b = g.blocks();
        assert_eq!(b.len(), 9);
        assert!((b[8].1 - 116.0).abs() < 1e-12 && (b[1].0 - 14.75).abs() < 1e-12);
        assert_eq!(g.marker_x().len(), 8);
        assert!((g.marker_x()[0] - 20.5).abs() < 1e-12);
        let with_f2 = Geometry { f: 2.0, ..g };
        assert!((with_f2.height() - 19.5).abs() < 1e-12);
    }

    #[test]
    fn mesh_volume_and_cavity_volume_are_those_of_the_geometry() {
        let cfg = ActuatorConfig {
            mesh: MeshConfig {
                size_mm: 2.0,
                ..Default::default()
            },
            ..Default::default()
        };
        let mesh = build_mesh(&cfg).unwrap();
        let g = &cfg.geometry;
        let volume: f64 = mesh
            .model
            .elements
            .iter()
            .map(|el| {
                let x: [Vector3<f64>; 8] = std::array::from_fn(|a| mesh.model.nodes[el[a]]);
                HexGeometry::new(&x).unwrap().volume
            })
            .sum();
        // Half of: box - gaps - cavities - channel (all exact on the conforming grid).
        let gaps = (g.chambers - 1) as f64 * g.d * g.i * (g.height() - g.f - g.m - g.roof);
        let cavities = g.chambers as f64 * g.e * g.l * g.n;
        let channel = g.r * g.p * g.m;
        let solid = g.b * g.i * g.height() - gaps - cavities - channel;
        assert!(
            (2.0 * volume - solid).abs() < 1e-6 * solid,
            "{} vs {solid}",
            2.0 * volume
        );
        let faces_volume: f64 = mesh
            .model
            .pressure_faces
            .iter()
            .map(|f| {
                let x: [Vector3<f64>; 4] = std::array::from_fn(|k| mesh.model.nodes[f[k]]);
                crate::fem::pressure::face_volume(&x, &CLOSED).0
            })
            .sum();
        // Channel (z ∈ [f, f+m]) and chamber cavities (above) do not overlap.
        let cavity = cavities + channel;
        assert!(
            (2.0 * faces_volume - cavity).abs() < 1e-6 * cavity,
            "{} vs {cavity}",
            2.0 * faces_volume
        );
        // Markers on the side face at mid cavity height, centre of chambers 2..9.
        for (n, x) in mesh.markers.iter().zip(g.marker_x()) {
            let p = mesh.model.nodes[*n];
            assert!((p - Vector3::new(x, 7.5, 14.0)).norm() < 1e-9, "{p}");
        }
    }

    #[test]
    fn nonsense_parameters_are_refused_with_the_parameter_named() {
        let base = ActuatorConfig::default();
        for (name, value, expect) in [
            ("f", -1.0, "positive"),
            ("l", 16.0, "narrower"),
            ("chambers", 12.0, "need"),
            ("bulk_modulus_mpa", 0.0, "positive"),
            ("e", 12.0, "does not fit"),
        ] {
            let cfg = base.with_parameter(name, value).unwrap();
            let err = cfg.validate().unwrap_err().to_string();
            assert!(err.contains(name) && err.contains(expect), "{name}: {err}");
        }
        let err = base.with_parameter("zz", 1.0).unwrap_err().to_string();
        assert!(
            err.contains("no such parameter")
                && err.contains("geometry: ")
                && err.contains(" chambers ")
                && err.contains(" c2 ")
                && err.contains("size_mm")
                && !err.contains("pitch_mm"),
            "{err}"
        );
        // The list is the config's own: the tube's parameters where there is a tube, and
        // each of them sets.
        let tube = ActuatorConfig::for_family(Family::FibreReinforced);
        let err = tube.with_parameter("zz", 1.0).unwrap_err().to_string();
        assert!(err.contains("tube: ") && err.contains("pitch_mm"), "{err}");
        let listed = err.split_once('(').unwrap().1.trim_end_matches(')');
        for key in listed
            .split(';')
            .flat_map(|s| s.split_once(':').unwrap().1.split_whitespace())
        {
            assert!(
                tube.with_parameter(key, 2.0).is_ok(),
                "{key} listed but not set"
            );
        }
        let neg = ActuatorConfig {
            load: LoadConfig {
                pressures_kpa: "-5,10".into(),
                gravity: true,
                ..LoadConfig::default()
            },
            ..Default::default()
        };
        assert!(neg.validate().unwrap_err().to_string().contains(">= 0"));
        assert_eq!(parse_range("10:115:5", "p").unwrap().len(), 22);
        assert!(parse_range("10:x:5", "p").is_err());
    }
}
