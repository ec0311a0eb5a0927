//! Reading an actuator config document over its family's defaults: the user's document
//! read with every key's path (a NaN or an infinity refused by its key: JSON, the merge's
//! medium, has no NaN and would make it null, "not given"), the `[layer]` rules checked,
//! the two merged, and serde's type errors put in a config file's words.

use std::collections::BTreeMap;

use serde::Deserialize;

use super::config::{Family, MaterialConfig};

/// One step of a key's path in a config document: a table's key or a list's entry.
#[derive(Debug, Clone, PartialEq)]
enum Step {
    Key(String),
    Entry(usize),
}

/// The key at `path` as a config file writes it: `[geometry] b`, `[layer.2] thickness_mm`
/// (list entries numbered from 1), `[load] gravity_direction entry 1`.
fn key_text(path: &[Step]) -> String {
    let Some(k) = path.iter().rposition(|s| matches!(s, Step::Key(_))) else {
        return "the config".into();
    };
    let mut table = String::new();
    for s in &path[..k] {
        match s {
            Step::Key(name) if table.is_empty() => table.push_str(name),
            Step::Key(name) => {
                table.push('.');
                table.push_str(name);
            }
            Step::Entry(i) => table.push_str(&format!(".{}", i + 1)),
        }
    }
    let Step::Key(key) = &path[k] else {
        return "the config".into();
    };
    let mut out = if table.is_empty() {
        key.clone()
    } else {
        format!("[{table}] {key}")
    };
    for s in &path[k + 1..] {
        if let Step::Entry(i) = s {
            out.push_str(&format!(" entry {}", i + 1));
        }
    }
    out
}

/// What a finite value of the key `key` is, for the message refusing a NaN or inf.
fn finite_hint(section: &str, key: &str) -> &'static str {
    if key == "gravity_direction" {
        "give a direction, e.g. [0, 0, -1]"
    } else if section == "cavities" {
        "give the cavity's pressure as a factor of the ramp's (1: the ramp's, 0: not pressurised)"
    } else if key.ends_with("_mm") || section == "geometry" {
        "give a size in mm"
    } else if key.ends_with("_mpa") || ["c1", "c2", "c3"].contains(&key) {
        "give a value in MPa"
    } else if key.ends_with("_kpa") {
        "give a pressure in kPa"
    } else if key.ends_with("_g_cm3") {
        "give a density in g/cm3"
    } else {
        "give a finite number"
    }
}

/// Reads a config document as a JSON value, refusing a NaN or an infinity with its key
/// named (`.0` is the path so far).
pub(super) struct UserValue(Vec<Step>);

impl UserValue {
    /// The reader of a whole document (the path empty).
    pub(super) fn root() -> UserValue {
        UserValue(Vec::new())
    }

    fn with(&self, step: Step) -> UserValue {
        let mut path = self.0.clone();
        path.push(step);
        UserValue(path)
    }
}

impl<'de> serde::de::DeserializeSeed<'de> for UserValue {
    type Value = serde_json::Value;
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de> serde::de::Visitor<'de> for UserValue {
    type Value = serde_json::Value;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("an actuator config value")
    }

    fn visit_bool<E: serde::de::Error>(self, v: bool) -> Result<Self::Value, E> {
        Ok(v.into())
    }

    fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Self::Value, E> {
        Ok(v.into())
    }

    fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Self::Value, E> {
        Ok(v.into())
    }

    fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Self::Value, E> {
        serde_json::Number::from_f64(v)
            .map(serde_json::Value::Number)
            .ok_or_else(|| {
                let key = self.0.iter().rev().find_map(|s| match s {
                    Step::Key(k) => Some(k.as_str()),
                    Step::Entry(_) => None,
                });
                let section = match self.0.first() {
                    Some(Step::Key(s)) => s.as_str(),
                    _ => "",
                };
                let written = if v.is_nan() { "nan".to_string() } else { v.to_string() };
                E::custom(format!(
                    "{} = {written}: not a finite number: {}, or leave the key out for the family's default",
                    key_text(&self.0),
                    finite_hint(section, key.unwrap_or(""))
                ))
            })
    }

    fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Self::Value, E> {
        Ok(v.into())
    }

    fn visit_string<E: serde::de::Error>(self, v: String) -> Result<Self::Value, E> {
        Ok(v.into())
    }

    fn visit_unit<E: serde::de::Error>(self) -> Result<Self::Value, E> {
        Ok(serde_json::Value::Null)
    }

    fn visit_none<E: serde::de::Error>(self) -> Result<Self::Value, E> {
        Ok(serde_json::Value::Null)
    }

    fn visit_some<D: serde::Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_any(self)
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut out = Vec::new();
        while let Some(v) = seq.next_element_seed(self.with(Step::Entry(out.len())))? {
            out.push(v);
        }
        Ok(serde_json::Value::Array(out))
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        let mut out = serde_json::Map::new();
        while let Some(k) = map.next_key::<String>()? {
            let v = map.next_value_seed(self.with(Step::Key(k.clone())))?;
            out.insert(k, v);
        }
        Ok(serde_json::Value::Object(out))
    }
}

/// The value at `path` in a JSON document.
fn value_at<'a>(doc: &'a serde_json::Value, path: &[Step]) -> Option<&'a serde_json::Value> {
    path.iter().try_fold(doc, |v, s| match s {
        Step::Key(k) => v.get(k.as_str()),
        Step::Entry(i) => v.get(*i),
    })
}

/// A type error of the merged config in the user's words: the key, the value given, what
/// is expected with an example (the family's own value where it has one), instead of
/// serde's Rust type names (`expected usize`).
pub(super) fn type_error(
    path: &serde_path_to_error::Path,
    err: &serde_json::Error,
    doc: &serde_json::Value,
    defaults: &serde_json::Value,
) -> String {
    use serde_path_to_error::Segment;
    let steps: Vec<Step> = path
        .iter()
        .filter_map(|s| match s {
            Segment::Map { key } => Some(Step::Key(key.clone())),
            Segment::Seq { index } => Some(Step::Entry(*index)),
            _ => None,
        })
        .collect();
    let message = err.to_string();
    let key = key_text(&steps);
    let field = steps.iter().rev().find_map(|s| match s {
        Step::Key(k) => Some(k.clone()),
        Step::Entry(_) => None,
    });
    let example = field
        .as_ref()
        .zip(value_at(defaults, &steps))
        .map(|(f, v)| format!(" (e.g. {f} = {v})"))
        .unwrap_or_default();
    let given = value_at(doc, &steps)
        .map(|v| format!(" = {v}"))
        .unwrap_or_default();
    let expected = message.rsplit_once(", expected ").map(|(_, e)| e);
    let plain = match expected {
        Some("usize" | "u64" | "u32" | "u16" | "u8") => "expected a whole number >= 0",
        Some("i64" | "i32" | "i16" | "i8" | "isize") => "expected a whole number",
        Some("f64" | "f32") => "expected a number",
        Some("a boolean") => "expected true or false",
        _ => "",
    };
    if steps.is_empty() {
        message
    } else if plain.is_empty() {
        format!("{key}{given}: {message}")
    } else {
        format!("{key}{given}: {plain}{example}")
    }
}

/// Checks the `[layer]` / `[[layer]]` tables of `user` against the family's layers in
/// `doc`. A single `[layer]` table updates a family's only layer; on a family with
/// several it cannot say which, and is refused naming them; on a family with none, and
/// in every `[[layer]]` table (which replace the family's layers), a new layer gives
/// what it has no default for: its thickness and modulus.
pub(super) fn check_layer_tables(
    user: &serde_json::Value,
    doc: &serde_json::Value,
    family: Family,
) -> Result<(), String> {
    use serde_json::Value;
    let family_layers: Vec<&str> = doc
        .get("layer")
        .and_then(Value::as_array)
        .map(|a| {
            a.iter()
                .map(|l| l.get("name").and_then(Value::as_str).unwrap_or("?"))
                .collect()
        })
        .unwrap_or_default();
    let needs = |t: &serde_json::Map<String, Value>, table: &str| -> Result<(), String> {
        let missing: Vec<&str> = NEW_LAYER_KEYS
            .iter()
            .copied()
            .filter(|k| t.get(*k).is_none_or(Value::is_null))
            .collect();
        if missing.is_empty() {
            return Ok(());
        }
        Err(format!(
            "{table} is a new layer and gives no {}: a layer has no default material or size; give {} (e.g. paper: thickness_mm = 0.1, youngs_modulus_mpa = 3000)",
            missing.join(" or "),
            NEW_LAYER_KEYS.join(" and ")
        ))
    };
    match user.get("layer") {
        Some(Value::Object(t)) => match family_layers.as_slice() {
            [_] => Ok(()),
            [] => needs(
                t,
                &format!("[layer] (the {family} family has no layer of its own)"),
            ),
            names => Err(format!(
                "[layer]: the {family} family has {} layers ({}) and a single [layer] table cannot say which one it changes: write a [[layer]] table for each (see bendscope simulate --family {family} --print-config), or name one as layer.NAME.field in a sweep or fit (e.g. layer.{}.thickness_mm)",
                names.len(),
                names.join(", "),
                names[0]
            )),
        },
        Some(Value::Array(items)) => items
            .iter()
            .enumerate()
            .try_for_each(|(k, item)| match item {
                Value::Object(t) => needs(t, &format!("[[layer]] {}", k + 1)),
                _ => Ok(()),
            }),
        _ => Ok(()),
    }
}

/// What a new layer must give: no default thickness or modulus is right for an unnamed
/// sheet.
const NEW_LAYER_KEYS: [&str; 2] = ["thickness_mm", "youngs_modulus_mpa"];

/// Names of the model's own parts, which a layer cannot take (its stress columns would
/// clash with theirs).
pub(super) const RESERVED_PART_NAMES: [&str; 3] = ["silicone", "outer", "fibre"];

/// Merges `user` over `base`: objects key by key, anything else replaces; an object
/// over an array of one object merges into that object (`[layer]` over one layer).
pub(super) fn merge_over(base: &mut serde_json::Value, user: serde_json::Value) {
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

/// Takes the `[material.NAME]` tables (a volume's own material, [`MaterialConfig::named`])
/// out of the document and reads each over the material defaults, an error naming its key
/// (`[material.outer] c1`).
pub(super) fn take_named_materials(
    doc: &mut serde_json::Value,
) -> Result<BTreeMap<String, MaterialConfig>, String> {
    use serde_json::{Map, Value};
    let Some(Value::Object(material)) = doc.get_mut("material") else {
        return Ok(BTreeMap::new());
    };
    let fields = match serde_json::to_value(MaterialConfig::default()) {
        Ok(Value::Object(m)) => m,
        _ => Map::new(),
    };
    let names: Vec<String> = material
        .iter()
        .filter(|(k, v)| v.is_object() && !fields.contains_key(*k))
        .map(|(k, _)| k.clone())
        .collect();
    if names.is_empty() {
        return Ok(BTreeMap::new());
    }
    let mut tables = Map::new();
    let mut defaults = Map::new();
    for name in names {
        if let Some(v) = material.remove(&name) {
            defaults.insert(name.clone(), Value::Object(fields.clone()));
            tables.insert(name, v);
        }
    }
    let wrapped = serde_json::json!({ "material": tables });
    let defaults = serde_json::json!({ "material": defaults });
    let mut track = serde_path_to_error::Track::new();
    let read = BTreeMap::<String, BTreeMap<String, MaterialConfig>>::deserialize(
        serde_path_to_error::Deserializer::new(&wrapped, &mut track),
    );
    match read {
        Ok(mut m) => Ok(m.remove("material").unwrap_or_default()),
        Err(e) => Err(type_error(&track.path(), &e, &wrapped, &defaults)),
    }
}
