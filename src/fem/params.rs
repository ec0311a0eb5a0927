//! Config fields by name: the one setter that `simulate --sweep`, `sweep`, `fit-model`,
//! `optimize` and [`ActuatorConfig::with_parameter`] use, and the value ranges they read
//! ([`parse_range`]).
//!
//! Names: `section.field` (`geometry.f`, `mesh.size_mm`), a table inside a section
//! (`tube.outer_material.c1`), an entry of a list of tables by its `name` or its number
//! from 1 (`layer.paper.thickness_mm`, `layer.2.youngs_modulus_mpa`), or a bare field
//! found in exactly one section (`f`, `size_mm`, `c2`); a bare field in several sections
//! is refused (write its section). A cavity's pressure factor is `cavities.NAME`.
//!
//! Values: a count (an integer field) takes a whole number >= 0 and stays an integer; a
//! number field takes any number, an integer included (the config's own checks then
//! refuse NaN, inf and out-of-range values, naming the key); a switch takes true or
//! false, a text a text. A field the config leaves out (a material's c1..c3 and
//! bulk_modulus_mpa beside its preset, a layer's width_mm) may be set too: the value
//! must then be in the config read back, so a misspelt field is refused.

use super::config::ActuatorConfig;
use super::FemError;

/// Material coefficients a material table may leave to its preset (absent until set).
pub const OPTIONAL_MATERIAL_FIELDS: [&str; 4] = ["c1", "c2", "c3", "bulk_modulus_mpa"];

/// A refused name or value: the name as given and what is wrong (each command puts its
/// own context before it: `parameter`, `factor`, `--free`, an optimizer input).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("parameter {name}: {why}")]
pub struct ParamError {
    /// The parameter's name as given.
    pub name: String,
    /// What is wrong and what to do.
    pub why: String,
}

impl From<ParamError> for FemError {
    fn from(e: ParamError) -> Self {
        FemError::Parameter {
            name: e.name,
            why: e.why,
        }
    }
}

fn refuse(name: &str, why: impl Into<String>) -> ParamError {
    ParamError {
        name: name.to_string(),
        why: why.into(),
    }
}

/// Where a name points: the tables to walk (sections, a list entry by name or number)
/// and the field in the last one.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FieldPath {
    /// Section, then tables or list entries inside it: `["layer", "paper"]`.
    pub sections: Vec<String>,
    /// The field in the last table.
    pub field: String,
}

impl FieldPath {
    /// The tables as a dotted path: `layer.paper`.
    pub fn section(&self) -> String {
        self.sections.join(".")
    }

    /// The full dotted name: `layer.paper.thickness_mm`.
    pub fn name(&self) -> String {
        format!("{}.{}", self.section(), self.field)
    }

    fn tables(&self) -> Vec<&str> {
        self.sections.iter().map(String::as_str).collect()
    }
}

/// The config as a TOML document (what the setter edits), with a `[cavities]` table
/// even when the config gives none (empty, it reads back as none), so that
/// `cavities.NAME` can be set on any config.
pub fn config_document(cfg: &ActuatorConfig) -> Result<toml::Table, ParamError> {
    let mut doc =
        toml::Table::try_from(cfg).map_err(|e| refuse("config", format!("config: {e}")))?;
    doc.entry("cavities")
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    Ok(doc)
}

/// Resolves `name` in `doc`: a dotted name as written (its tables are found when the
/// value is set), a bare field to the one section that has it (or the material table
/// whose preset gives it, for [`OPTIONAL_MATERIAL_FIELDS`]).
pub fn resolve(doc: &toml::Table, name: &str) -> Result<FieldPath, ParamError> {
    let parts: Vec<&str> = name.split('.').collect();
    if parts.iter().any(|p| p.trim().is_empty() || *p != p.trim()) {
        return Err(refuse(
            name,
            "not a parameter name: write section.field (geometry.f, material.c1, layer.paper.thickness_mm) or a field of one section (f)",
        ));
    }
    if let Some((field, sections)) = parts.split_last().filter(|(_, s)| !s.is_empty()) {
        return Ok(FieldPath {
            sections: sections.iter().map(|s| s.to_string()).collect(),
            field: field.to_string(),
        });
    }
    let hits: Vec<&String> = doc
        .iter()
        .filter(|(_, v)| {
            v.as_table().is_some_and(|t| {
                t.contains_key(name)
                    || (OPTIONAL_MATERIAL_FIELDS.contains(&name) && t.contains_key("preset"))
            })
        })
        .map(|(s, _)| s)
        .collect();
    match hits.as_slice() {
        [s] => Ok(FieldPath {
            sections: vec![s.to_string()],
            field: name.to_string(),
        }),
        [] => Err(refuse(
            name,
            format!(
                "no such parameter of this config; a layer's is layer.NAME.field ({})",
                numeric_keys(doc)
            ),
        )),
        many => Err(refuse(
            name,
            format!(
                "in several sections ({}): write section.field, e.g. {}.{name}",
                many.iter()
                    .map(|s| s.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
                many[0]
            ),
        )),
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
                    "no section '{here}' (sections: geometry, material, mesh, load, solver, layer, contact, cavities)"
                ))
            }
        };
    }
    Ok(table)
}

/// The value at `path` in `doc` (`None`: the field is absent from its table).
pub fn value_at(doc: &toml::Table, path: &FieldPath) -> Result<Option<toml::Value>, ParamError> {
    let mut doc = doc.clone();
    let table = config_table_at(&mut doc, &path.tables()).map_err(|e| refuse(&path.name(), e))?;
    Ok(table.get(&path.field).cloned())
}

/// What kind of value a TOML value is, in words.
fn kind(v: &toml::Value) -> &'static str {
    match v {
        toml::Value::Integer(_) => "a whole number",
        toml::Value::Float(_) => "a number",
        toml::Value::Boolean(_) => "a switch (true or false)",
        toml::Value::String(_) => "a text",
        toml::Value::Array(_) => "a list",
        toml::Value::Table(_) => "a table",
        toml::Value::Datetime(_) => "a date",
    }
}

/// `value` as the field holding `old` takes it: a count a whole number >= 0 (kept an
/// integer), a number any number, anything else a value of its own kind.
fn typed(
    name: &str,
    old: Option<&toml::Value>,
    value: &toml::Value,
) -> Result<toml::Value, ParamError> {
    use toml::Value::{Float, Integer};
    let whole = |v: f64| {
        if v.fract() == 0.0 && v >= 0.0 && v < i64::MAX as f64 {
            Ok(Integer(v as i64))
        } else {
            Err(refuse(name, format!("{v}: must be a whole number >= 0")))
        }
    };
    match (old, value) {
        (Some(Integer(_)), Integer(i)) => whole(*i as f64),
        (Some(Integer(_)), Float(f)) => whole(*f),
        (Some(Float(_)) | None, Integer(i)) => Ok(Float(*i as f64)),
        (Some(Float(_)) | None, Float(f)) => Ok(Float(*f)),
        (None, v) => Ok(v.clone()),
        (Some(old), v) if std::mem::discriminant(old) == std::mem::discriminant(v) => Ok(v.clone()),
        (Some(old), v) => Err(refuse(
            name,
            format!("{v}: the field takes {}, not {}", kind(old), kind(v)),
        )),
    }
}

/// Sets the field `name` of `doc` to `value` (typed as the field is); the path it set.
pub fn set_value(
    doc: &mut toml::Table,
    name: &str,
    value: &toml::Value,
) -> Result<FieldPath, ParamError> {
    set_in(doc, name, value).map(|(path, _)| path)
}

/// [`set_value`], and whether the field was absent before.
fn set_in(
    doc: &mut toml::Table,
    name: &str,
    value: &toml::Value,
) -> Result<(FieldPath, bool), ParamError> {
    let path = resolve(doc, name)?;
    let table = config_table_at(doc, &path.tables()).map_err(|e| refuse(name, e))?;
    let old = table.get(&path.field);
    let new = typed(name, old, value)?;
    let absent = old.is_none();
    table.insert(path.field.clone(), new);
    Ok((path, absent))
}

/// `cfg` with the field `name` set to `value`, read back through the config's own
/// checks of each key (not yet validated as a whole: [`ActuatorConfig::validate`]).
pub fn config_with(
    cfg: &ActuatorConfig,
    name: &str,
    value: &toml::Value,
) -> Result<ActuatorConfig, ParamError> {
    let mut doc = config_document(cfg)?;
    let (path, absent) = set_in(&mut doc, name, value)?;
    let out: ActuatorConfig = doc
        .try_into()
        .map_err(|e: toml::de::Error| refuse(name, e.message().trim().to_string()))?;
    // A field that was absent must have landed: a misspelt one is dropped (or refused)
    // on the way back.
    if absent && value_at(&config_document(&out)?, &path)?.is_none() {
        let mut back = config_document(&out)?;
        let keys = config_table_at(&mut back, &path.tables())
            .map(|t| t.keys().cloned().collect::<Vec<_>>().join(" "))
            .unwrap_or_default();
        return Err(refuse(
            name,
            format!(
                "no field '{}' in [{}] (its fields: {keys})",
                path.field,
                path.section()
            ),
        ));
    }
    Ok(out)
}

/// [`config_with`] of a number.
pub fn config_with_number(
    cfg: &ActuatorConfig,
    name: &str,
    value: f64,
) -> Result<ActuatorConfig, ParamError> {
    config_with(cfg, name, &toml::Value::Float(value))
}

/// The numbers of a config's sections, as `section: key key ...; ...` (what a bare name
/// can set: each family's own sections are there, e.g. `tube` for the fibre-reinforced
/// family).
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
            for k in OPTIONAL_MATERIAL_FIELDS {
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

fn bad(name: &str, why: String) -> FemError {
    FemError::Parameter {
        name: name.to_string(),
        why,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::family::Family;
    use toml::Value::{Boolean, Float, Integer};

    fn family(f: Family) -> ActuatorConfig {
        ActuatorConfig::for_family(f)
    }

    /// Every path form sets its field, with the field's type: (family, name, value, the
    /// value read back from the config).
    #[test]
    fn every_path_form_sets_its_field() {
        type Get = fn(&ActuatorConfig) -> f64;
        let cases: [(Family, &str, toml::Value, Get, f64); 16] = [
            (
                Family::Pneunets,
                "geometry.f",
                Float(5.0),
                |c| c.geometry.f,
                5.0,
            ),
            (Family::Pneunets, "f", Float(5.5), |c| c.geometry.f, 5.5),
            (
                Family::Pneunets,
                "geometry.f",
                Integer(4),
                |c| c.geometry.f,
                4.0,
            ),
            (
                Family::Pneunets,
                "chambers",
                Float(8.0),
                |c| c.geometry.chambers as f64,
                8.0,
            ),
            (
                Family::Pneunets,
                "geometry.chambers",
                Integer(7),
                |c| c.geometry.chambers as f64,
                7.0,
            ),
            (
                Family::Pneunets,
                "mesh.size_mm",
                Integer(3),
                |c| c.mesh.size_mm,
                3.0,
            ),
            (
                Family::Pneunets,
                "size_mm",
                Float(2.5),
                |c| c.mesh.size_mm,
                2.5,
            ),
            // Absent beside the preset until set: by section or bare.
            (
                Family::Pneunets,
                "material.c1",
                Float(0.2),
                |c| c.material.c1.unwrap_or(0.0),
                0.2,
            ),
            (
                Family::Pneunets,
                "c2",
                Float(0.03),
                |c| c.material.c2.unwrap_or(0.0),
                0.03,
            ),
            (
                Family::Pneunets,
                "solver.max_iterations",
                Float(30.0),
                |c| c.solver.max_iterations as f64,
                30.0,
            ),
            (
                Family::FibreReinforced,
                "pitch_mm",
                Float(3.0),
                |c| c.tube.as_ref().map_or(0.0, |t| t.pitch_mm),
                3.0,
            ),
            (
                Family::FibreReinforced,
                "tube.outer_material.c1",
                Float(0.3),
                |c| {
                    c.tube
                        .as_ref()
                        .and_then(|t| t.outer_material.c1)
                        .unwrap_or(0.0)
                },
                0.3,
            ),
            (
                Family::Glove,
                "layer.paper.thickness_mm",
                Float(0.2),
                |c| c.layer[0].thickness_mm,
                0.2,
            ),
            (
                Family::Glove,
                "layer.1.youngs_modulus_mpa",
                Integer(900),
                |c| c.layer[0].youngs_modulus_mpa,
                900.0,
            ),
            (
                Family::Strap,
                "layer.2.thickness_mm",
                Float(0.3),
                |c| c.layer[1].thickness_mm,
                0.3,
            ),
            (
                Family::Strap,
                "layer.pla.strips",
                Float(3.0),
                |c| c.layer[0].strips as f64,
                3.0,
            ),
        ];
        for (fam, name, value, get, want) in cases {
            let cfg = config_with(&family(fam), name, &value)
                .unwrap_or_else(|e| panic!("{fam:?} {name}: {e}"));
            assert_eq!(get(&cfg), want, "{fam:?} {name}");
        }
        // A count stays an integer in the document; a switch takes a switch.
        let cfg = config_with_number(&ActuatorConfig::default(), "chambers", 8.0).unwrap();
        let doc = config_document(&cfg).unwrap();
        assert_eq!(doc["geometry"]["chambers"], Integer(8));
        let off = config_with(&ActuatorConfig::default(), "load.gravity", &Boolean(false)).unwrap();
        assert!(!off.load.gravity);
        // A layer's optional width, absent until set, lands.
        let wide =
            config_with_number(&family(Family::Glove), "layer.paper.width_mm", 10.0).unwrap();
        assert_eq!(wide.layer[0].width_mm, Some(10.0));
    }

    /// Every refusal names the parameter and says what is wrong: (family, name, value,
    /// the message's text).
    #[test]
    fn every_refusal_says_what_is_wrong() {
        let cases: [(Family, &str, toml::Value, &str); 20] = [
            (Family::Pneunets, "zz", Float(1.0), "parameter zz: no such parameter of this config; a layer's is layer.NAME.field (geometry: "),
            (Family::Pneunets, "", Float(1.0), "not a parameter name: write section.field"),
            (Family::Pneunets, "geometry.", Float(1.0), "not a parameter name"),
            (Family::Pneunets, ".f", Float(1.0), "not a parameter name"),
            (Family::Pneunets, "geometry..f", Float(1.0), "not a parameter name"),
            (Family::Pneunets, "geometry. f", Float(1.0), "not a parameter name"),
            (Family::Pneunets, "nosuch.f", Float(1.0), "no section 'nosuch' (sections: geometry"),
            (Family::Pneunets, "geometry.zz", Float(1.0), "zz"),
            (Family::Pneunets, "material.zz", Float(1.0), "zz"),
            (Family::Glove, "layer.card.thickness_mm", Float(0.2), "no entry 'card' in 'layer' (1 there: number them from 1 or use their name)"),
            (Family::Glove, "layer.0.thickness_mm", Float(0.2), "no entry '0' in 'layer'"),
            (Family::Strap, "layer.thickness_mm", Float(0.2), "'layer' is a list: name one of its entries, e.g. layer.1"),
            (Family::Pneunets, "chambers", Float(8.5), "parameter chambers: 8.5: must be a whole number >= 0"),
            (Family::Pneunets, "chambers", Float(-1.0), "-1: must be a whole number >= 0"),
            (Family::Pneunets, "chambers", Float(f64::NAN), "NaN: must be a whole number >= 0"),
            (Family::Pneunets, "geometry.chambers", Integer(-3), "-3: must be a whole number >= 0"),
            (Family::Pneunets, "f", Float(f64::NAN), "parameter f: [geometry] f = nan: not a finite number"),
            (Family::Pneunets, "load.gravity", Float(1.0), "load.gravity: 1.0: the field takes a switch (true or false), not a number"),
            (Family::Pneunets, "geometry.f", Boolean(true), "true: the field takes a number, not a switch (true or false)"),
            (Family::Pneunets, "chambers", Boolean(true), "true: the field takes a whole number, not a switch"),
        ];
        for (fam, name, value, needle) in cases {
            let e = config_with(&family(fam), name, &value)
                .map(|_| ())
                .unwrap_err()
                .to_string();
            assert!(e.contains(needle), "{fam:?} {name:?}: {e}");
        }
    }

    /// A bare field resolves to its one section; in several it is refused, naming them.
    #[test]
    fn a_bare_field_must_be_in_one_section() {
        let doc: toml::Table = toml::from_str("[a]\nx = 1\ny = 2\n[b]\nx = 3\n").unwrap();
        assert_eq!(resolve(&doc, "y").unwrap().name(), "a.y");
        assert_eq!(resolve(&doc, "b.x").unwrap().name(), "b.x");
        let e = resolve(&doc, "x").unwrap_err().to_string();
        assert_eq!(
            e,
            "parameter x: in several sections (a, b): write section.field, e.g. a.x"
        );
        let path = resolve(&doc, "b.x").unwrap();
        assert_eq!(value_at(&doc, &path).unwrap(), Some(Integer(3)));
        assert_eq!(
            value_at(&doc, &resolve(&doc, "b.z").unwrap()).unwrap(),
            None
        );
    }

    /// Ranges: start:stop:step inclusive, lists, and the refusals.
    #[test]
    fn ranges_and_lists_parse_or_are_refused() {
        assert_eq!(parse_range("10:115:5", "p").unwrap().len(), 22);
        assert_eq!(parse_range("1, 2.5,4", "p").unwrap(), [1.0, 2.5, 4.0]);
        for (text, needle) in [
            ("10:x:5", "'x' is not a number"),
            ("1,inf", "'inf' is not finite"),
            ("5:1:1", "need start <= stop and a positive step"),
            ("1:5:0", "need start <= stop and a positive step"),
            ("0:1e9:1", "values: use a larger step"),
            ("1:2", "expected start:stop:step or a comma-separated list"),
        ] {
            let e = parse_range(text, "p").unwrap_err().to_string();
            assert!(e.contains(needle), "{text}: {e}");
        }
    }
}
