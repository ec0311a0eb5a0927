//! The cavities pressurised apart (`[cavities]`, issue 39): each named cavity's pressure
//! as a multiple of the ramp's (`mcp = 1.0`, `pip_dip = 0.0`), and the checks on them.
//!
//! A model's named cavities are its `cavity.NAME` surfaces (an imported mesh's groups, the
//! segmented finger's channels `mcp` and `pip_dip`); a cavity the table leaves out takes
//! the ramp's pressure (factor 1), and so does an unnamed `cavity`.

use std::collections::BTreeMap;

use crate::fem::FemError;

/// Largest factor a cavity's pressure may be of the ramp's: a channel a hundred times
/// another's pressure is a typing error, not a design.
pub const MAX_CAVITY_FACTOR: f64 = 100.0;

/// The factors of `[cavities]`, by cavity name.
pub type CavityFactors = BTreeMap<String, f64>;

fn bad(name: &str, why: String) -> FemError {
    super::bad(&format!("cavities.{name}"), why)
}

/// Checks the factors on their own: each a finite number in 0..=[`MAX_CAVITY_FACTOR`],
/// whose pressure at the ramp's top (`top_kpa`) stays plausible.
pub fn validate(factors: &CavityFactors, top_kpa: f64) -> Result<(), FemError> {
    let max_kpa = crate::session::MAX_PLAUSIBLE_PRESSURE_KPA;
    for (name, &f) in factors {
        if !(f.is_finite() && (0.0..=MAX_CAVITY_FACTOR).contains(&f)) {
            return Err(bad(
                name,
                format!(
                    "{}: give the cavity's pressure as a factor of the ramp's from 0 (not pressurised) to {MAX_CAVITY_FACTOR} (1: the ramp's pressure)",
                    super::number_text(f)
                ),
            ));
        }
        if f * top_kpa > max_kpa {
            return Err(bad(
                name,
                format!(
                    "{f} x the ramp's {top_kpa} kPa is above {max_kpa} kPa (10 MPa), not plausible for a soft actuator: lower the factor or the pressures"
                ),
            ));
        }
    }
    Ok(())
}

/// Checks that every factor names one of the model's cavities `named` (its `cavity.NAME`
/// groups, NAME alone); `one_cavity` says what the model is when it names none.
pub fn check_names(
    factors: &CavityFactors,
    named: &[String],
    one_cavity: &str,
) -> Result<(), FemError> {
    let Some((first, _)) = factors.iter().find(|(k, _)| !named.contains(k)) else {
        return Ok(());
    };
    if named.is_empty() {
        return Err(bad(
            first,
            format!("{one_cavity}: remove [cavities] (its factors set named cavities apart)"),
        ));
    }
    Err(bad(
        first,
        format!(
            "the model has no cavity `{first}`: name one of its cavities ({}), or remove the key",
            named.join(", ")
        ),
    ))
}

/// The factor of the cavity named `name` (None: the unnamed `cavity`): its `[cavities]`
/// entry, else 1 (the ramp's pressure).
pub fn factor_of(factors: &CavityFactors, name: Option<&str>) -> f64 {
    name.and_then(|n| factors.get(n)).copied().unwrap_or(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every refusal names its key and says what to do; factors in range pass.
    #[test]
    fn bad_factors_and_names_are_refused_naming_the_key() {
        let named = vec!["mcp".to_string(), "pip_dip".to_string()];
        let one = |k: &str, v: f64| CavityFactors::from([(k.to_string(), v)]);
        let cases: [(CavityFactors, f64, &str); 6] = [
            (one("mcp", f64::NAN), 90.0, "parameter cavities.mcp: NaN: give the cavity's pressure as a factor"),
            (one("mcp", f64::INFINITY), 90.0, "parameter cavities.mcp: inf: give"),
            (one("mcp", -0.5), 90.0, "parameter cavities.mcp: -0.5: give"),
            (one("mcp", 1e9), 90.0, "parameter cavities.mcp: 1e9: give"),
            (one("mcp", 50.0), 9000.0, "parameter cavities.mcp: 50 x the ramp's 9000 kPa is above 10000 kPa"),
            (one("pip", 0.0), 90.0, "parameter cavities.pip: the model has no cavity `pip`: name one of its cavities (mcp, pip_dip)"),
        ];
        for (factors, top, needle) in cases {
            let e = validate(&factors, top)
                .and_then(|()| check_names(&factors, &named, "one cavity"))
                .unwrap_err()
                .to_string();
            assert!(e.starts_with(needle), "{needle}: {e}");
        }
        let e = check_names(&one("a", 1.0), &[], "the pneunets family has one cavity")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "parameter cavities.a: the pneunets family has one cavity: remove [cavities] (its factors set named cavities apart)"
        );
        let fine = CavityFactors::from([("mcp".into(), 0.0), ("pip_dip".into(), 100.0)]);
        validate(&fine, 90.0).unwrap();
        check_names(&fine, &named, "").unwrap();
        assert_eq!(factor_of(&fine, Some("pip_dip")), 100.0);
        assert_eq!(factor_of(&fine, Some("other")), 1.0);
        assert_eq!(factor_of(&fine, None), 1.0);
    }

    /// The one setter of sweeps and fits sets a factor by its dotted or bare name, on the
    /// finger (whose channels are in its config) and on a config without `[cavities]`;
    /// a NaN is refused by its key.
    #[test]
    fn the_setter_sets_a_cavity_factor_by_name() {
        use crate::fem::config::{ActuatorConfig, Family};
        let finger = ActuatorConfig::for_family(Family::SegmentedFinger);
        assert_eq!(finger.cavities.len(), 2);
        let off = finger.with_parameter("cavities.pip_dip", 0.0).unwrap();
        assert_eq!(off.cavities["pip_dip"], 0.0);
        assert_eq!(off.cavities["mcp"], 1.0);
        let half = finger.with_parameter("mcp", 0.5).unwrap();
        assert_eq!(half.cavities["mcp"], 0.5);
        let mesh = ActuatorConfig::for_family(Family::Mesh);
        assert!(mesh.cavities.is_empty());
        let set = mesh.with_parameter("cavities.a", 2.0).unwrap();
        assert_eq!(set.cavities, CavityFactors::from([("a".into(), 2.0)]));
        let e = finger
            .with_parameter("cavities.mcp", f64::NAN)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("[cavities] mcp = nan: not a finite number"),
            "{e}"
        );
        // Printed and read back.
        let back: ActuatorConfig = toml::from_str(&off.to_toml().unwrap()).unwrap();
        assert_eq!(back, off);
    }
}
