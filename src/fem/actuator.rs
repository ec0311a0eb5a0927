//! The actuator a config describes: the document read over its family's defaults,
//! the checks across its sections, and its mesh built by its shape ([`super::shapes`]).
//! The config types ([`super::config`]) and the mesh types ([`super::mesh`]) are
//! re-exported here at their old paths.
//!
//! Coordinates (every shape): x along the length (clamped end at x = 0), y across the
//! width, z up; mm. A mirror-symmetric actuator is meshed as its half y ≥ 0: y = 0 is a
//! symmetry plane (u_y = 0 there), the cavity volume and the forces of the whole actuator
//! are twice those of the half.

use serde::Deserialize;

use super::config::Family;
use super::config::{bad, number_text, strip_nulls};
use super::config_doc::{
    check_layer_tables, merge_over, take_named_materials, type_error, UserValue,
    RESERVED_PART_NAMES,
};
use super::FemError;

// The config and mesh types, at their old paths.
pub use super::config::{
    ActuatorConfig, Geometry, LoadConfig, MaterialConfig, MeshConfig, SolidElement, SolverConfig,
    DEFAULT_MESH_SIZE_MM, MAX_CHAMBERS, MAX_DENSITY_G_CM3, MAX_ELEMENTS,
};
pub use super::mesh::{ActuatorMesh, BottomWall, Part, GRAVITY_M_S2, MIN_WALL_ELEMENTS};
pub use super::params::{config_table_at, parse_range};

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
        // goes; the shape adjusts the rest (the tube's `true`: its default strip).
        let strip = user
            .get("tube")
            .and_then(|t| t.get("bottom_strip"))
            .and_then(serde_json::Value::as_bool);
        if let Some(o) = doc.as_object_mut() {
            match strip {
                Some(false) if user.get("layer").is_none() => {
                    o.remove("layer");
                }
                _ => family.shape().adjust_defaults(&user, o),
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
        let named = take_named_materials(&mut doc).map_err(D::Error::custom)?;
        let mut track = serde_path_to_error::Track::new();
        let checked =
            ActuatorConfig::deserialize(serde_path_to_error::Deserializer::new(&doc, &mut track));
        let mut cfg = checked
            .map_err(|e| D::Error::custom(type_error(&track.path(), &e, &doc, &defaults)))?;
        cfg.material.named = named;
        Ok(cfg)
    }
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

impl ActuatorConfig {
    /// The config in the TOML file `path` (as `simulate --print-config` prints one), not
    /// yet validated.
    pub fn read(path: &std::path::Path) -> Result<Self, FemError> {
        let text = std::fs::read_to_string(path).map_err(|e| FemError::Input {
            why: format!("cannot read actuator config {}: {e}", path.display()),
        })?;
        let mut cfg: Self = toml::from_str(&text).map_err(|e| {
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
        })?;
        // A geometry file is relative to the config that names it.
        if let Some(file) = cfg.geometry.file.as_mut() {
            if file.is_relative() {
                *file = path
                    .parent()
                    .unwrap_or(std::path::Path::new(""))
                    .join(&*file);
            }
        }
        Ok(cfg)
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
        self.validate_named_materials()?;
        self.validate_threads()?;
        self.pressures_kpa()?;
        self.validate_layers()?;
        let d = self.load.gravity_direction;
        if !(d.iter().all(|v| v.is_finite()) && d.iter().map(|v| v * v).sum::<f64>() > 1e-12) {
            return Err(bad(
                "gravity_direction",
                format!("{d:?}: give a non-zero direction, e.g. [0, 0, -1] (lying) or [1, 0, 0] (hanging)"),
            ));
        }
        if !self.shape().reads_file() {
            self.refuse_file_keys()?;
        }
        self.refuse_foreign_sections()?;
        self.shape().validate(self)?;
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
        // Last: an imported mesh is meshed for its cavities' names.
        self.validate_cavities()
    }

    /// Checks each `[material.NAME]` table, and that this shape's mesh has named volumes
    /// for it (whether it has one of that name is the mesh's to say, when it is built).
    fn validate_named_materials(&self) -> Result<(), FemError> {
        let Some(name) = self.material.named.keys().next() else {
            return Ok(());
        };
        self.refuse_without_named_groups(
            &format!("[material.{name}]"),
            "a named volume's material",
        )?;
        if self.material.named.len() > usize::from(u8::MAX) {
            return Err(bad(
                "material",
                format!(
                    "{} named materials: at most {} are taken",
                    self.material.named.len(),
                    u8::MAX
                ),
            ));
        }
        for (name, m) in &self.material.named {
            let key = format!("[material.{name}]");
            if name == "silicone" || name == "clamp" {
                return Err(bad(
                    &key,
                    format!("the `{name}` volume takes [material] itself: put these keys there"),
                ));
            }
            m.yeoh().map_err(|e| match e {
                FemError::Parameter { name, why } => FemError::Parameter {
                    name: format!("{key} {name}"),
                    why,
                },
                other => other,
            })?;
        }
        Ok(())
    }

    /// Checks each `[threads.NAME]` section, and that this shape's mesh has named groups
    /// for it (whether it has a `thread.NAME` curve is the mesh's to say).
    fn validate_threads(&self) -> Result<(), FemError> {
        let Some(name) = self.threads.keys().next() else {
            return Ok(());
        };
        self.refuse_without_named_groups(&format!("[threads.{name}]"), "a thread's section")?;
        super::config::threads::validate(&self.threads)
    }

    /// Refuses `table` (what it holds: `what`) on a shape whose mesh has no named groups.
    fn refuse_without_named_groups(&self, table: &str, what: &str) -> Result<(), FemError> {
        if self.shape().named_groups() {
            return Ok(());
        }
        Err(bad(
            table,
            format!(
                "{what} is for an imported mesh's named groups (family = \"mesh\"), and the {} family's mesh has none: remove the table",
                self.geometry.family
            ),
        ))
    }

    /// Checks `[cavities]`: its factors, and that each names a cavity of the model (an
    /// imported mesh is read for its names: meshed once, [`super::shapes`] keeps it).
    fn validate_cavities(&self) -> Result<(), FemError> {
        if self.cavities.is_empty() {
            return Ok(());
        }
        let top = self.pressures_kpa()?.last().copied().unwrap_or(0.0);
        super::config::cavities::validate(&self.cavities, top)?;
        let shape = self.shape();
        super::config::cavities::check_names(
            &self.cavities,
            &shape.cavity_names(self)?,
            &shape.one_cavity(self),
        )
    }

    /// Refuses `[geometry]`'s keys of a geometry file for a shape that reads none.
    fn refuse_file_keys(&self) -> Result<(), FemError> {
        let g = &self.geometry;
        let given = [
            ("file", g.file.is_some()),
            ("parameters", !g.parameters.is_empty()),
            ("clamp", g.clamp.is_some()),
            ("markers", g.markers.is_some()),
        ];
        match given.iter().find(|(_, set)| *set) {
            Some((key, _)) => Err(bad(
                &format!("geometry.{key}"),
                format!(
                    "the {} family is built from its numbers, not from a file: remove `{key}`, or set family = \"mesh\" to simulate a geometry file",
                    g.family
                ),
            )),
            None => Ok(()),
        }
    }

    /// Warnings about values that are valid but suspect: the material's
    /// ([`MaterialConfig::warnings`]) and a key the family ignores, set to other than
    /// its default (the fibre-reinforced tube's shape is its `[tube]`, not `[geometry]`).
    pub fn warnings(&self) -> Vec<String> {
        let mut out = self.material.warnings();
        out.extend(self.shape().warnings(self));
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

    /// The family's whole default configuration ([`super::shapes::Shape::defaults`]).
    pub fn for_family(family: Family) -> Self {
        family.shape().defaults(family)
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
        self.shape().validate_layers(self)
    }

    /// Sets one parameter by name to a number, for sweeps: a field of one section (`f`,
    /// `chambers`, `c2`, `bulk_modulus_mpa`, `size_mm`), or a dotted path naming its
    /// section (`geometry.f`, `tube.outer_material.c1`, `layer.paper.thickness_mm`,
    /// `layer.2.youngs_modulus_mpa`); the rules of [`super::params::config_with`].
    pub fn with_parameter(&self, name: &str, value: f64) -> Result<Self, FemError> {
        Ok(super::params::config_with_number(self, name, value)?)
    }
}

/// The number of elements (hexahedra, and the tube's thread segments) a mesh of size `h`
/// mm of `cfg` would have, counted without building it (a float: no overflow).
pub fn element_estimate(cfg: &ActuatorConfig, h: f64) -> f64 {
    let hexes = cfg.shape().element_estimate(cfg, h);
    if cfg.mesh.element == super::config::SolidElement::Tet10 {
        // Six tetrahedra per hexahedron.
        6.0 * hexes
    } else {
        hexes
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

/// Meshes the actuator `cfg` describes (its shape's mesh: [`super::shapes`]), validated
/// first.
pub fn build_mesh(cfg: &ActuatorConfig) -> Result<ActuatorMesh, FemError> {
    cfg.validate()?;
    let mesh = cfg.shape().build(cfg)?;
    if cfg.mesh.element == super::config::SolidElement::Tet10 && !mesh.model.elements.is_empty() {
        return super::split::into_tetrahedra(cfg, mesh);
    }
    Ok(mesh)
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
    /// (which is accepted); the count is the built mesh's. An imported mesh is bounded
    /// by its reader instead (`fem::import`'s node and element limits).
    #[test]
    fn a_mesh_too_fine_to_fit_is_refused_before_anything_is_built() {
        for family in Family::all().into_iter().filter(|f| *f != Family::Mesh) {
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
