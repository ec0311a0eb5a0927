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
use serde::Deserialize;

use super::config::{bad, number_text};
use super::config_doc::{
    check_layer_tables, merge_over, strip_nulls, type_error, UserValue, RESERVED_PART_NAMES,
};
use super::contact::{Contact, ContactPair};
use super::family::{self, Family};
use super::layer::{LayerConfig, LayerElement};
use super::membrane::MembraneElement;
use super::mesh::{coordinate_line_count, coordinate_lines, gravity_loads};
use super::plate::Mirror;
use super::pressure::CLOSED;
use super::solve::Model;
use super::FemError;

// The config and mesh types, at their old paths.
pub use super::config::{
    ActuatorConfig, Geometry, LoadConfig, MaterialConfig, MeshConfig, SolidElement, SolverConfig,
    DEFAULT_MESH_SIZE_MM, MAX_CHAMBERS, MAX_DENSITY_G_CM3, MAX_ELEMENTS,
};
pub use super::mesh::{ActuatorMesh, BottomWall, Part, GRAVITY_M_S2, MIN_WALL_ELEMENTS};

impl<'de> Deserialize<'de> for ActuatorConfig {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::{DeserializeSeed, Error};
        // The user's document, a non-finite number refused by its key (JSON has no NaN:
        // read as a JSON value it would become null, "not given", and the default).
        let user = UserValue::root().deserialize(d)?;
        let family = match user.get("geometry").and_then(|g| g.get("family")) {
            None => Family::default(),
            Some(v) => Family::deserialize(v)
                .map_err(|e| D::Error::custom(format!("[geometry] family: {e}")))?,
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
        check_layer_tables(&user, &doc, family).map_err(D::Error::custom)?;
        let defaults = doc.clone();
        merge_over(&mut doc, user);
        strip_nulls(&mut doc);
        // `[layer]` (one table) is a list of one layer.
        if let Some(o) = doc.as_object_mut() {
            if let Some(one @ serde_json::Value::Object(_)) = o.get_mut("layer") {
                *one = serde_json::Value::Array(vec![one.take()]);
            }
        }
        let mut track = serde_path_to_error::Track::new();
        let checked =
            ActuatorConfig::deserialize(serde_path_to_error::Deserializer::new(&doc, &mut track));
        checked.map_err(|e| D::Error::custom(type_error(&track.path(), &e, &doc, &defaults)))
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
        toml::from_str(&text).map_err(|e| {
            // A message that names its own --print-config needs no second one.
            let see = if e.message().contains("--print-config") {
                ""
            } else {
                " (see bendscope simulate --print-config)"
            };
            FemError::Input {
                why: format!(
                    "{} is not a valid actuator config: {}{see}",
                    path.display(),
                    e.message()
                ),
            }
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
        if let Some(w) = p.windows(2).find(|w| w[1] <= w[0]) {
            return Err(bad(
                "pressures",
                format!(
                    "{} kPa after {} kPa: pressures must increase (e.g. 20,40 or 10:60:10)",
                    w[1], w[0]
                ),
            ));
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
        self.check_element_count()?;
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

    /// Warnings about values that are valid but suspect: the material's
    /// ([`MaterialConfig::warnings`]) and a key the family ignores, set to other than
    /// its default (the fibre-reinforced tube's shape is its `[tube]`, not `[geometry]`).
    pub fn warnings(&self) -> Vec<String> {
        let mut out = self.material.warnings();
        if self.geometry.family == Family::FibreReinforced {
            let given = serde_json::to_value(&self.geometry).unwrap_or_default();
            let default = serde_json::to_value(Self::for_family(self.geometry.family).geometry)
                .unwrap_or_default();
            if let (Some(given), Some(default)) = (given.as_object(), default.as_object()) {
                for (key, v) in given {
                    if default.get(key) != Some(v) {
                        out.push(format!(
                            "[geometry] {key} = {v} is ignored by the {} family (its shape is [tube]): remove it",
                            self.geometry.family
                        ));
                    }
                }
            }
        }
        out
    }

    /// Refuses a mesh size whose mesh would exceed [`MAX_ELEMENTS`], from the count alone
    /// (nothing allocated), naming the smallest size that fits.
    fn check_element_count(&self) -> Result<(), FemError> {
        let h = self.mesh.size_mm;
        let count = element_estimate(self, h);
        if count <= MAX_ELEMENTS as f64 {
            return Ok(());
        }
        let what = match smallest_mesh_size(self) {
            Some(fit) => format!("use a mesh size of at least {fit} mm"),
            None => "no mesh size fits: make the actuator smaller".into(),
        };
        let about = if count.is_finite() {
            format!("about {count:.1e} elements")
        } else {
            "too many elements to count".to_string()
        };
        // 1e-300 written out would be 300 zeros.
        let size = if (1e-4..1e6).contains(&h) {
            h.to_string()
        } else {
            format!("{h:e}")
        };
        Err(bad(
            "mesh size",
            format!(
                "{size} mm would make {about}, more than the {MAX_ELEMENTS} this solver is sized for: {what}"
            ),
        ))
    }

    /// The family's whole default configuration ([`super::family::defaults`]).
    pub fn for_family(family: Family) -> Self {
        family::defaults(family)
    }

    /// Checks every layer against the base and the others: each fits in the base and the
    /// width; solid layers do not overlap.
    fn validate_layers(&self) -> Result<(), FemError> {
        // A layer's name suffixes its result columns and names it in `layer.NAME.field`.
        for (k, layer) in self.layer.iter().enumerate() {
            let name = layer.name.as_str();
            let which = format!("layer {}", k + 1);
            if name.trim().is_empty() || name.contains(['.', ',', '"']) {
                return Err(bad(
                    &format!("layer.name ({which})"),
                    format!("'{name}': give the layer a name without dots or commas (it suffixes its result columns), e.g. name = \"paper\""),
                ));
            }
            if RESERVED_PART_NAMES.contains(&name) {
                return Err(bad(
                    &format!("layer.name ({which})"),
                    format!(
                        "'{name}' is the name of a part of the model ({}): rename the layer",
                        RESERVED_PART_NAMES.join(", ")
                    ),
                ));
            }
            if let Some(first) = self.layer[..k].iter().position(|l| l.name == name) {
                return Err(bad(
                    &format!("layer.name ({which})"),
                    format!("'{name}' is also layer {}'s name: give every layer its own name (its result columns and layer.NAME.field need it)", first + 1),
                ));
            }
        }
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

    /// Sets one parameter by name to a number, for sweeps: a field of any section (`f`,
    /// `chambers`, `c2`, `bulk_modulus_mpa`, `size_mm`), or a dotted path naming its
    /// section (`geometry.f`, `tube.outer_material.c1`, `layer.paper.thickness_mm`,
    /// `layer.2.youngs_modulus_mpa`).
    pub fn with_parameter(&self, name: &str, value: f64) -> Result<Self, FemError> {
        let mut doc = toml::Table::try_from(self).map_err(|e| FemError::Model {
            why: format!("config: {e}"),
        })?;
        let hit = match name.rsplit_once('.') {
            Some((sections, field)) => {
                let path: Vec<&str> = sections.split('.').collect();
                let table = config_table_at(&mut doc, &path).map_err(|e| bad(name, e))?;
                set_number(table, name, field, value)?
            }
            None => {
                let mut hit = false;
                for (_, section) in doc.iter_mut() {
                    if let Some(table) = section.as_table_mut() {
                        hit |= set_number(table, name, name, value)?;
                    }
                }
                hit
            }
        };
        if !hit {
            return Err(bad(
                name,
                format!(
                    "no such parameter of this config; a layer's is layer.NAME.field ({})",
                    numeric_keys(&doc)
                ),
            ));
        }
        doc.try_into()
            .map_err(|e: toml::de::Error| FemError::Model {
                why: format!("config: {}", e.message()),
            })
    }
}

/// Sets `field` of `table` to `value` (an integer where the field is one) if the table
/// has that number (or is a material, whose coefficients are optional); false if not.
fn set_number(
    table: &mut toml::Table,
    name: &str,
    field: &str,
    value: f64,
) -> Result<bool, FemError> {
    match table.get(field) {
        Some(old) if old.is_integer() || field == "chambers" => {
            if !(value.fract() == 0.0 && value >= 0.0 && value < i64::MAX as f64) {
                return Err(bad(name, format!("{value}: must be a whole number >= 0")));
            }
            table.insert(field.to_string(), toml::Value::Integer(value as i64));
            Ok(true)
        }
        Some(old) if old.is_float() => {
            table.insert(field.to_string(), toml::Value::Float(value));
            Ok(true)
        }
        None if ["c1", "c2", "c3", "bulk_modulus_mpa"].contains(&field)
            && table.contains_key("preset") =>
        {
            table.insert(field.to_string(), toml::Value::Float(value));
            Ok(true)
        }
        _ => Ok(false),
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

/// Along one axis: the coordinates the grid lines go through, and the intervals that are
/// walls.
type AxisFeatures = (Vec<f64>, Vec<(f64, f64)>);

/// Coordinates every line of the PneuNets grid goes through, with the intervals that are
/// walls (at least [`MIN_WALL_ELEMENTS`] across), along x, y and z.
fn grid_features(cfg: &ActuatorConfig) -> [AxisFeatures; 3] {
    let g = &cfg.geometry;
    let blocks = g.blocks();
    let cavities = g.cavities();
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
    let mut fy = vec![0.0, 0.5 * g.p, 0.5 * g.l, 0.5 * g.i];
    for layer in &cfg.layer {
        for (y0, y1) in layer.half_y_ranges(g.i) {
            fy.extend([y0, y1]);
        }
    }
    let y_walls = vec![(0.5 * g.l, 0.5 * g.i), (0.5 * g.p, 0.5 * g.i)];
    let mut fz = vec![0.0, z_channel, z_cavity, z_gap, g.marker_z(), z_top, a];
    for layer in &cfg.layer {
        match layer.element {
            LayerElement::Solid => {
                fz.extend([layer.height_mm, layer.height_mm + layer.thickness_mm])
            }
            LayerElement::Membrane | LayerElement::Plate => fz.push(layer.membrane_height_mm()),
        }
    }
    let z_walls = vec![(0.0, z_channel), (z_cavity, z_gap), (z_top, a)];
    [(fx, x_walls), (fy, y_walls), (fz, z_walls)]
}

/// The number of elements (hexahedra, and the tube's thread segments) a mesh of size `h`
/// mm of `cfg` would have, counted without building it (a float: no overflow).
pub fn element_estimate(cfg: &ActuatorConfig, h: f64) -> f64 {
    match (&cfg.tube, cfg.geometry.family) {
        (Some(t), Family::FibreReinforced) => super::fibre::element_estimate(cfg, t, h),
        _ => grid_features(cfg)
            .iter()
            .map(|(f, w)| coordinate_line_count(f, h, w))
            .product(),
    }
}

/// The smallest mesh size, mm, rounded up to two significant digits, whose mesh of `cfg`
/// has at most [`MAX_ELEMENTS`] elements (None: not even one element per feature fits).
pub fn smallest_mesh_size(cfg: &ActuatorConfig) -> Option<f64> {
    let fits = |h: f64| element_estimate(cfg, h) <= MAX_ELEMENTS as f64;
    let mut hi = 1e4;
    if !fits(hi) {
        return None;
    }
    let mut lo = 1e-6;
    if fits(lo) {
        return Some(lo);
    }
    // The count falls as the size grows (ceil steps aside): bisect in log size.
    for _ in 0..60 {
        let mid = (lo * hi).sqrt();
        if fits(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let exponent = hi.log10().floor() - 1.0;
    let step = 10f64.powf(exponent);
    // Printed with as many decimals as the two digits need (0.45, not 0.45000000000000007).
    let decimals = (-exponent).max(0.0) as usize;
    let round = |v: f64| format!("{v:.decimals$}").parse::<f64>().unwrap_or(v);
    let mut k = (hi / step).ceil();
    while !fits(round(k * step)) && k < 1000.0 {
        k += 1.0;
    }
    Some(round(k * step))
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
    let cavities = g.cavities();
    let (ch0, ch1) = (0.5 * (g.b - g.r), 0.5 * (g.b + g.r));
    let (z_channel, z_cavity) = (g.f, g.f + g.m);
    let (z_gap, z_top, a) = (z_cavity + g.roof, z_cavity + g.n, g.height());

    let [(fx, wx), (fy, wy), (fz, wz)] = grid_features(cfg);
    let xs = coordinate_lines(fx, h, &wx);
    let ys = coordinate_lines(fy, h, &wy);
    let zs = coordinate_lines(fz, h, &wz);
    let (nx, ny, nz) = (xs.len() - 1, ys.len() - 1, zs.len() - 1);
    // validate() bounded the count (element_estimate); this is the count itself.
    if nx.saturating_mul(ny).saturating_mul(nz) > MAX_ELEMENTS {
        return Err(bad(
            "mesh size",
            format!(
                "{h} mm gives {} cells, more than the {MAX_ELEMENTS} this solver is sized for: use a larger mesh size",
                nx.saturating_mul(ny).saturating_mul(nz)
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
    use crate::fem::hex::HexGeometry;

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

    /// The message of reading `text` as a config, or of validating what it reads as.
    fn refusal(text: &str) -> String {
        match toml::from_str::<ActuatorConfig>(text) {
            Err(e) => e.message().to_string(),
            Ok(cfg) => match cfg.validate() {
                Err(e) => e.to_string(),
                Ok(()) => format!("accepted: {text}"),
            },
        }
    }

    /// A NaN or inf is refused by its key when the config is read, never replaced by the
    /// family's default (it was: JSON turned it into null, "not given").
    #[test]
    fn a_nan_or_inf_is_refused_by_its_key_never_replaced_by_the_default() {
        let tube = "[geometry]\nfamily = \"fibre-reinforced\"\n";
        for (text, needle) in [
            ("[geometry]\nb = nan\n".to_string(), "[geometry] b = nan: not a finite number: give a size in mm, or leave the key out"),
            ("[geometry]\nb = inf\n".into(), "[geometry] b = inf: not a finite number"),
            ("[geometry]\nb = -inf\n".into(), "[geometry] b = -inf: not a finite number"),
            ("[material]\nc1 = nan\n".into(), "[material] c1 = nan: not a finite number: give a value in MPa"),
            ("[mesh]\nsize_mm = nan\n".into(), "[mesh] size_mm = nan: not a finite number"),
            ("[load]\ngravity_direction = [nan, 0, 0]\n".into(), "[load] gravity_direction entry 1 = nan: not a finite number"),
            (format!("{tube}[tube]\npitch_mm = nan\n"), "[tube] pitch_mm = nan: not a finite number"),
            (format!("{tube}[tube.outer_material]\nc1 = nan\n"), "[tube.outer_material] c1 = nan"),
            ("[geometry]\nfamily = \"glove\"\n[[layer]]\nname = \"p\"\nthickness_mm = 0.1\nyoungs_modulus_mpa = nan\n".into(), "[layer.1] youngs_modulus_mpa = nan"),
        ] {
            let e = toml::from_str::<ActuatorConfig>(&text).unwrap_err();
            assert!(e.message().contains(needle), "{text}: {}", e.message());
        }
        // JSON has no NaN: its null still means "not given".
        let json: ActuatorConfig = serde_json::from_str(r#"{"material": {"c1": null}}"#).unwrap();
        assert_eq!(json.material.c1, None);
        // A sweep or fit setting a NaN meets the same check.
        let e = ActuatorConfig::default()
            .with_parameter("f", f64::NAN)
            .unwrap_err()
            .to_string();
        assert!(e.contains("[geometry] f = nan: not a finite number"), "{e}");
    }

    /// Every size, modulus and count where a positive value is meant: nan and inf are
    /// refused as the config is read, -1 and 0 as it is validated, each naming its key.
    #[test]
    fn every_key_refuses_nan_inf_negative_and_zero_by_name() {
        let geometry = [
            "b", "i", "f", "m", "p", "r", "c", "g", "d", "e", "l", "n", "top_wall",
        ];
        let material = [
            "c1",
            "bulk_modulus_mpa",
            "density_g_cm3",
            "tensile_strength_mpa",
            "scale",
        ];
        let tube = [
            "inner_radius_mm",
            "inner_wall_mm",
            "outer_wall_mm",
            "length_mm",
            "clamp_mm",
            "end_cap_mm",
            "pitch_mm",
            "fibre_diameter_mm",
            "fibre_modulus_mpa",
            "fibre_strength_mpa",
        ];
        let mut cases: Vec<(String, String, String)> = Vec::new();
        for k in geometry {
            cases.push(("[geometry]\n".into(), k.into(), k.into()));
        }
        for k in material {
            cases.push(("[material]\n".into(), k.into(), k.into()));
        }
        cases.push(("[mesh]\n".into(), "size_mm".into(), "mesh size".into()));
        for k in tube {
            cases.push((
                "[geometry]\nfamily = \"fibre-reinforced\"\n[tube]\n".into(),
                k.into(),
                format!("tube.{k}"),
            ));
        }
        for k in ["thickness_mm", "youngs_modulus_mpa"] {
            cases.push((
                "[geometry]\nfamily = \"glove\"\n[layer]\n".into(),
                k.into(),
                format!("layer.{k}"),
            ));
        }
        for (head, key, name) in &cases {
            for v in ["nan", "inf"] {
                let e = refusal(&format!("{head}{key} = {v}\n"));
                assert!(
                    e.contains(&format!("] {key} = {v}: not a finite number")),
                    "{key} = {v}: {e}"
                );
            }
            for v in ["-1.0", "0.0"] {
                let e = refusal(&format!("{head}{key} = {v}\n"));
                assert!(
                    e.starts_with(&format!("parameter {name}: ")),
                    "{key} = {v}: {e}"
                );
            }
        }
    }

    /// A type error names the key, the value and what is expected, with the family's
    /// value as the example; a list of pressures reads as the comma-separated form.
    #[test]
    fn a_type_error_names_the_key_and_says_what_is_expected() {
        for (text, needle) in [
            ("[geometry]\nchambers = -3\n", "[geometry] chambers = -3: expected a whole number >= 0 (e.g. chambers = 9)"),
            ("[geometry]\nchambers = 9.5\n", "[geometry] chambers = 9.5: expected a whole number >= 0 (e.g. chambers = 9)"),
            ("[load]\ngravity = \"yes\"\n", "[load] gravity = \"yes\": expected true or false (e.g. gravity = true)"),
            ("[load]\npressures_kpa = true\n", "[load] pressures_kpa = true: invalid type: boolean `true`, expected pressures as \"start:stop:step\""),
            ("[geometry]\nfamily = \"strap\"\n[[layer]]\nname = \"a\"\nthickness_mm = 0.1\nyoungs_modulus_mpa = 9\nstrips = \"two\"\n", "[layer.1] strips = \"two\": expected a whole number >= 0"),
        ] {
            let e = refusal(text);
            assert!(e.contains(needle), "{text}: {e}");
        }
        let list: ActuatorConfig = toml::from_str("[load]\npressures_kpa = [20, 40.5]\n").unwrap();
        assert_eq!(list.load.pressures_kpa, "20,40.5");
        assert_eq!(list.pressures_kpa().unwrap(), [20.0, 40.5]);
        let e = refusal("[load]\npressures_kpa = \"40,20\"\n");
        assert!(
            e.contains("20 kPa after 40 kPa: pressures must increase"),
            "{e}"
        );
    }

    /// A single [layer] table updates a family's only layer; on the strap (two layers) it
    /// is refused naming them; on a family with none a new layer must give its thickness
    /// and modulus, as must every [[layer]] table.
    #[test]
    fn a_single_layer_table_updates_only_a_familys_only_layer() {
        let e = refusal("[geometry]\nfamily = \"strap\"\n[layer]\nthickness_mm = 0.2\n");
        assert!(
            e.contains("[layer]: the strap family has 2 layers (pla, fabric)")
                && e.contains("write a [[layer]] table for each")
                && e.contains("layer.pla.thickness_mm"),
            "{e}"
        );
        let e = refusal("[layer]\nthickness_mm = 0.2\n");
        assert!(
            e.contains("[layer] (the pneunets family has no layer of its own) is a new layer and gives no youngs_modulus_mpa")
                && e.contains("give thickness_mm and youngs_modulus_mpa"),
            "{e}"
        );
        let e = refusal(
            "[geometry]\nfamily = \"strap\"\n[[layer]]\nname = \"a\"\nyoungs_modulus_mpa = 9\n",
        );
        assert!(
            e.contains("[[layer]] 1 is a new layer and gives no thickness_mm"),
            "{e}"
        );
        let one: ActuatorConfig =
            toml::from_str("[layer]\nthickness_mm = 0.1\nyoungs_modulus_mpa = 3000\n").unwrap();
        assert_eq!(one.layer.len(), 1);
        assert_eq!(
            (one.layer[0].thickness_mm, one.layer[0].youngs_modulus_mpa),
            (0.1, 3000.0)
        );
        one.validate().unwrap();
    }

    /// Layer names suffix result columns and address layers: empty, duplicate and the
    /// model's own part names are refused before any solve.
    #[test]
    fn layer_names_must_be_given_and_distinct() {
        let strap = ActuatorConfig::for_family(Family::Strap);
        for (name, needle) in [
            (
                "",
                "parameter layer.name (layer 2): '': give the layer a name",
            ),
            (
                "pla",
                "parameter layer.name (layer 2): 'pla' is also layer 1's name",
            ),
            (
                "silicone",
                "parameter layer.name (layer 2): 'silicone' is the name of a part",
            ),
            (
                "a.b",
                "parameter layer.name (layer 2): 'a.b': give the layer a name without dots",
            ),
        ] {
            let mut cfg = strap.clone();
            cfg.layer[1].name = name.into();
            let e = cfg.validate().unwrap_err().to_string();
            assert!(e.starts_with(needle), "{name}: {e}");
        }
    }

    /// A mesh size whose mesh would not fit is refused from its count alone, quickly and
    /// before anything is allocated, for every family, with the smallest size that fits
    /// (which is accepted); the count is the built mesh's.
    #[test]
    fn a_mesh_too_fine_to_fit_is_refused_before_anything_is_built() {
        for family in Family::ALL {
            let base = ActuatorConfig::for_family(family);
            for h in [1e-9, 1e-300, 5e-324, 1e-7, 0.05] {
                let cfg = ActuatorConfig {
                    mesh: MeshConfig {
                        size_mm: h,
                        ..base.mesh.clone()
                    },
                    ..base.clone()
                };
                let start = std::time::Instant::now();
                let e = build_mesh(&cfg).unwrap_err().to_string();
                assert!(
                    start.elapsed().as_secs_f64() < 1.0,
                    "{family} {h}: {:?}",
                    start.elapsed()
                );
                let fit: f64 = e
                    .strip_suffix(" mm")
                    .and_then(|s| s.rsplit_once("use a mesh size of at least "))
                    .and_then(|(_, v)| v.parse().ok())
                    .unwrap_or_else(|| panic!("{family} {h}: {e}"));
                assert!(
                    e.starts_with("parameter mesh size: ") && e.contains("more than the 400000"),
                    "{e}"
                );
                let at = |size_mm| ActuatorConfig {
                    mesh: MeshConfig {
                        size_mm,
                        ..base.mesh.clone()
                    },
                    ..base.clone()
                };
                at(fit)
                    .validate()
                    .unwrap_or_else(|e| panic!("{family}: {fit} mm suggested: {e}"));
                assert!(
                    at(0.9 * fit).validate().is_err(),
                    "{family}: {fit} is not the smallest"
                );
            }
        }
        let e = ActuatorConfig::default()
            .with_parameter("size_mm", 1e-300)
            .unwrap()
            .validate();
        assert!(e
            .unwrap_err()
            .to_string()
            .contains("1e-300 mm would make too many elements to count"));
        for (family, h) in [(Family::Pneunets, 4.0), (Family::FibreReinforced, 4.0)] {
            let cfg = ActuatorConfig {
                mesh: MeshConfig {
                    size_mm: h,
                    ..MeshConfig::default()
                },
                ..ActuatorConfig::for_family(family)
            };
            let mesh = build_mesh(&cfg).unwrap();
            let built = (mesh.model.elements.len()
                + mesh.model.membranes.len()
                + mesh.model.trusses.len()) as f64;
            let estimate = element_estimate(&cfg, h);
            assert!(
                estimate >= built && estimate < 2.5 * built,
                "{family}: {estimate} vs {built}"
            );
        }
    }

    /// A thread pitch below the thread's diameter (overlapping turns) is refused naming
    /// both; the thread's segments count in the mesh bound.
    #[test]
    fn a_pitch_below_the_thread_diameter_is_refused() {
        let tube = "[geometry]\nfamily = \"fibre-reinforced\"\n[tube]\n";
        for pitch in ["0.01", "0.2", "0.29"] {
            for model in ["line", "smeared"] {
                let e = refusal(&format!(
                    "{tube}fibre_model = \"{model}\"\npitch_mm = {pitch}\n"
                ));
                assert!(
                    e.starts_with(&format!("parameter tube.pitch_mm: {pitch} mm is less than the thread's diameter (fibre_diameter_mm = 0.3 mm)")),
                    "{e}"
                );
            }
        }
        let e = refusal(&format!("{tube}pitch_mm = 0\n"));
        assert!(
            e.starts_with("parameter tube.pitch_mm: 0: must be positive"),
            "{e}"
        );
        // A long line-thread tube at a fine pitch: the threads alone exceed the bound.
        let e = refusal(&format!(
            "{tube}fibre_model = \"line\"\npitch_mm = 0.3\nlength_mm = 2000\n"
        ));
        assert!(e.starts_with("parameter mesh size: "), "{e}");
    }

    /// A key the family ignores, set to other than its default, is a warning; the
    /// family's printed config gives none.
    #[test]
    fn a_key_the_family_ignores_is_a_warning() {
        let tube = ActuatorConfig::for_family(Family::FibreReinforced);
        assert_eq!(tube.warnings(), Vec::<String>::new());
        let five: ActuatorConfig =
            toml::from_str("[geometry]\nfamily = \"fibre-reinforced\"\nchambers = 5\n").unwrap();
        assert_eq!(
            five.warnings(),
            ["[geometry] chambers = 5 is ignored by the fibre-reinforced family (its shape is [tube]): remove it"]
        );
        // A layer's parameter is set by its dotted name (simulate --sweep, optimize).
        let glove = ActuatorConfig::for_family(Family::Glove);
        let thick = glove
            .with_parameter("layer.paper.thickness_mm", 0.2)
            .unwrap();
        assert_eq!(thick.layer[0].thickness_mm, 0.2);
        let e = glove
            .with_parameter("layer.card.thickness_mm", 0.2)
            .unwrap_err()
            .to_string();
        assert!(e.contains("no entry 'card' in 'layer'"), "{e}");
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
