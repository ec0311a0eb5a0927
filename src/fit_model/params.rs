//! The free parameters of a model fit: config fields by name, their bounds, and configs
//! with new values.

use crate::fem::actuator::ActuatorConfig;
use crate::fem::params;

use super::FitModelError;

/// Default bounds of a parameter without explicit ones: its initial value divided and
/// multiplied by this factor.
pub const DEFAULT_BOUND_FACTOR: f64 = 5.0;

/// A config field the fit varies.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FreeParameter {
    /// `section.field`, e.g. `geometry.f`, `material.scale`.
    pub name: String,
    /// Config section.
    pub section: String,
    /// Field in the section.
    pub field: String,
    /// Value in the base config.
    pub initial: f64,
    /// Lower bound.
    pub lower: f64,
    /// Upper bound.
    pub upper: f64,
}

fn bad(name: &str, why: impl Into<String>) -> FitModelError {
    FitModelError::Parameter {
        name: name.to_string(),
        why: why.into(),
    }
}

fn config_table(cfg: &ActuatorConfig) -> Result<toml::Table, FitModelError> {
    toml::Table::try_from(cfg).map_err(|e| bad("config", e.to_string()))
}

/// Parses `NAME[=LO:HI][,NAME[=LO:HI]...]`: NAME is `section.field` (`layer.NAME.field`)
/// or a field name found in exactly one section (`f`, `scale`), as every command names
/// one ([`crate::fem::params`]); bounds default to the initial value / and
/// x [`DEFAULT_BOUND_FACTOR`].
pub fn parse_free(spec: &str, cfg: &ActuatorConfig) -> Result<Vec<FreeParameter>, FitModelError> {
    let doc = config_table(cfg)?;
    let material = cfg
        .material
        .yeoh()
        .map_err(|e| bad("material", e.to_string()))?;
    let mut out: Vec<FreeParameter> = Vec::new();
    for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (name, bounds) = match item.split_once('=') {
            Some((n, b)) => (n.trim(), Some(b.trim())),
            None => (item, None),
        };
        let at = params::resolve(&doc, name).map_err(|e| bad(&e.name, e.why))?;
        let (section, field) = (at.section(), at.field.clone());
        let full = at.name();
        let current = params::value_at(&doc, &at).map_err(|e| bad(&full, e.why))?;
        // Unscaled coefficients: `scale` multiplies them in the material.
        let s = cfg.material.scale;
        let initial = match current {
            Some(toml::Value::Float(v)) => v,
            Some(toml::Value::Integer(_)) => {
                return Err(bad(
                    &full,
                    "a whole number cannot be fitted (it is not continuous)",
                ))
            }
            Some(_) => return Err(bad(&full, "not a number")),
            None if section == "material" && field == "c1" => material.c1 / s,
            None if section == "material" && field == "c2" => material.c2 / s,
            None if section == "material" && field == "c3" => material.c3 / s,
            None if section == "material" && field == "bulk_modulus_mpa" => {
                material.bulk_modulus / s
            }
            None => {
                return Err(bad(
                    &full,
                    format!("no such field in [{section}] (see bendscope simulate --print-config)"),
                ))
            }
        };
        let (lower, upper) = match bounds {
            Some(b) => {
                let (lo, hi) = b
                    .split_once(':')
                    .ok_or_else(|| bad(&full, format!("bounds '{b}': write NAME=LO:HI")))?;
                let num = |v: &str| {
                    v.trim()
                        .parse::<f64>()
                        .ok()
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| bad(&full, format!("bound '{v}' is not a number")))
                };
                (num(lo)?, num(hi)?)
            }
            None if initial > 0.0 => (
                initial / DEFAULT_BOUND_FACTOR,
                initial * DEFAULT_BOUND_FACTOR,
            ),
            None => {
                return Err(bad(
                    &full,
                    format!("initial value {initial}: give bounds, {full}=LO:HI"),
                ))
            }
        };
        if !(lower < upper) {
            return Err(bad(&full, format!("bounds {lower}:{upper}: need LO < HI")));
        }
        if !(initial >= lower && initial <= upper) {
            return Err(bad(
                &full,
                format!("the config's value {initial} is outside the bounds {lower}:{upper}"),
            ));
        }
        if out.iter().any(|p| p.name == full) {
            return Err(bad(&full, "named twice"));
        }
        let param = FreeParameter {
            name: full,
            section,
            field,
            initial,
            lower,
            upper,
        };
        if bounds.is_some() {
            check_bounds_valid(cfg, &param)?;
        }
        out.push(param);
    }
    if out.is_empty() {
        return Err(bad(
            "--free",
            "no parameter named: e.g. --free material.scale,geometry.f",
        ));
    }
    Ok(out)
}

/// Refuses explicit bounds where the parameter leaves its valid range (`material.scale
/// = 0`, a negative size): the fit would search values the model refuses.
fn check_bounds_valid(cfg: &ActuatorConfig, p: &FreeParameter) -> Result<(), FitModelError> {
    for (which, bound) in [("lower", p.lower), ("upper", p.upper)] {
        if let Err(e) = with_values(cfg, std::slice::from_ref(p), &[bound]) {
            // The default bounds as the example, when the model takes them.
            let (lo, hi) = (
                p.initial / DEFAULT_BOUND_FACTOR,
                p.initial * DEFAULT_BOUND_FACTOR,
            );
            let valid = |v: f64| with_values(cfg, std::slice::from_ref(p), &[v]).is_ok();
            let example = if p.initial > 0.0 && valid(lo) && valid(hi) {
                format!(", e.g. {}={lo}:{hi}", p.name)
            } else {
                String::new()
            };
            return Err(bad(
                &p.name,
                format!(
                    "the {which} bound {bound} is outside the parameter's valid range ({e}): give bounds inside it{example}"
                ),
            ));
        }
    }
    Ok(())
}

/// `base` with every parameter set to its value, checked.
pub fn with_values(
    base: &ActuatorConfig,
    params: &[FreeParameter],
    values: &[f64],
) -> Result<ActuatorConfig, FitModelError> {
    let mut cfg = base.clone();
    for (p, v) in params.iter().zip(values) {
        cfg = params::config_with_number(&cfg, &p.name, *v).map_err(|e| bad(&e.name, e.why))?;
    }
    cfg.validate().map_err(FitModelError::Fem)?;
    Ok(cfg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_bounds_and_values() {
        let cfg = ActuatorConfig::default();
        let p = parse_free("material.scale, f=4:8 ,c2", &cfg).unwrap();
        assert_eq!(p[0].name, "material.scale");
        assert_eq!((p[0].initial, p[0].lower, p[0].upper), (1.0, 0.2, 5.0));
        assert_eq!(p[1].name, "geometry.f");
        assert_eq!((p[1].initial, p[1].lower, p[1].upper), (6.0, 4.0, 8.0));
        assert_eq!(p[2].name, "material.c2");
        assert!((p[2].initial - 0.0601).abs() < 1e-12);
        let c = with_values(&cfg, &p, &[0.5, 5.0, 0.03]).unwrap();
        assert_eq!(c.geometry.f, 5.0);
        let y = c.material.yeoh().unwrap();
        // scale multiplies every coefficient, the bulk modulus too.
        assert!((y.c1 - 0.5 * 0.10744).abs() < 1e-12 && (y.c2 - 0.015).abs() < 1e-12);
        assert!((y.bulk_modulus - 0.5 * 2000.0 * 0.10744).abs() < 1e-9);
        for (spec, needle) in [
            ("chambers", "whole number"),
            ("zz", "no such parameter of this config"),
            ("layer.zz", "no section 'layer'"),
            ("f=8:4", "LO < HI"),
            ("f=1:3", "outside the bounds"),
            ("f,geometry.f", "named twice"),
        ] {
            let e = parse_free(spec, &cfg).unwrap_err().to_string();
            assert!(e.contains(needle), "{spec}: {e}");
        }
        // Explicit bounds outside a parameter's valid range are refused by name.
        for (spec, needle) in [
            (
                "material.scale=0:2",
                "--free material.scale: the lower bound 0 is outside the parameter's valid range (",
            ),
            ("scale=-1:2", "the lower bound -1 is outside"),
            (
                "geometry.f=-1:8",
                "--free geometry.f: the lower bound -1 is outside",
            ),
        ] {
            let e = parse_free(spec, &cfg).unwrap_err().to_string();
            assert!(e.contains(needle), "{spec}: {e}");
            assert!(e.contains("give bounds inside it"), "{spec}: {e}");
        }
        let e = parse_free("material.scale=0:2", &cfg)
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with("give bounds inside it, e.g. material.scale=0.2:5"),
            "{e}"
        );
        assert!(parse_free("material.scale=0.01:2", &cfg).is_ok());
        // A value the geometry refuses is an error, not a panic.
        assert!(with_values(&cfg, &p, &[0.5, -1.0, 0.03]).is_err());
    }
}
