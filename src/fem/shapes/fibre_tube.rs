//! The fibre-reinforced tube shape (`family = "fibre-reinforced"`, DOE study): a D-section
//! tube, Dragon Skin 20 inside Dragon Skin 10, a Kevlar thread wound both ways or one way,
//! a strip in the flat bottom as a `[[layer]]` with `[tube] bottom_strip = true`. Its
//! section is `[tube]` ([`crate::fem::config::tube`]); the mesher is
//! [`crate::fem::fibre`], which this wraps.

use serde_json::{Map, Value};

use super::{PneuNets, Shape};
use crate::fem::config::tube::{bad, FibreModel, TubeConfig};
use crate::fem::config::{ActuatorConfig, Family, Geometry, LoadConfig, MaterialConfig};
use crate::fem::fibre;
use crate::fem::layer::{LayerConfig, LayerElement};
use crate::fem::material::MaterialPreset;
use crate::fem::mesh::ActuatorMesh;
use crate::fem::FemError;

#[allow(non_upper_case_globals)]
impl Family {
    /// The fibre-reinforced tube: D-section, two silicones, wound thread ([`crate::fem::fibre`]).
    pub const FibreReinforced: Family = Family::named("fibre-reinforced");
}

/// The fibre-reinforced tube ([`crate::fem::fibre`]).
pub struct FibreTube;

impl Shape for FibreTube {
    fn own_section(&self) -> Option<&'static str> {
        Some("tube")
    }

    fn families(&self) -> &'static [Family] {
        &[Family::FibreReinforced]
    }

    fn defaults(&self, family: Family) -> ActuatorConfig {
        let reference = ActuatorConfig::default();
        ActuatorConfig {
            geometry: Geometry {
                family,
                ..Geometry::default()
            },
            material: MaterialConfig {
                preset: MaterialPreset::DragonSkin20,
                // Smooth-On Dragon Skin 20: specific gravity 1.08, tensile strength 550 psi.
                density_g_cm3: 1.08,
                tensile_strength_mpa: 3.79,
                ..MaterialConfig::default()
            },
            load: LoadConfig {
                pressures_kpa: FIBRE_PRESSURES.into(),
                ..LoadConfig::default()
            },
            tube: Some(TubeConfig::default()),
            ..reference
        }
    }

    /// `bottom_strip = true`: the tube's default strip is the family's layer (a `[layer]`
    /// table updates it, `[[layer]]` tables replace it).
    fn adjust_defaults(&self, user: &Value, defaults: &mut Map<String, Value>) {
        let strip = user
            .get("tube")
            .and_then(|t| t.get("bottom_strip"))
            .and_then(Value::as_bool);
        if strip == Some(true) {
            if let Ok(layer) = serde_json::to_value(vec![bottom_strip_layer()]) {
                defaults.insert("layer".into(), layer);
            }
        }
    }

    /// The strip is checked against the tube ([`validate_strips`]), in [`Shape::validate`].
    fn validate_layers(&self, _cfg: &ActuatorConfig) -> Result<(), FemError> {
        Ok(())
    }

    fn validate(&self, cfg: &ActuatorConfig) -> Result<(), FemError> {
        let Some(t) = &cfg.tube else {
            return Err(crate::fem::config::bad(
                "tube",
                "the fibre-reinforced family needs a [tube] section (see bendscope simulate --family fibre-reinforced --print-config)".into(),
            ));
        };
        t.validate()?;
        validate_strips(cfg, t)?;
        if !t.bottom_strip && !cfg.layer.is_empty() {
            return Err(crate::fem::config::bad(
                "tube.bottom_strip",
                "false, but the config has [[layer]]s (the strip): remove them or set bottom_strip = true".into(),
            ));
        }
        Ok(())
    }

    /// A key of `[geometry]` set to other than the default: the tube's shape is its `[tube]`.
    fn warnings(&self, cfg: &ActuatorConfig) -> Vec<String> {
        let mut out = Vec::new();
        let given = serde_json::to_value(&cfg.geometry).unwrap_or_default();
        let default =
            serde_json::to_value(self.defaults(cfg.geometry.family).geometry).unwrap_or_default();
        if let (Some(given), Some(default)) = (given.as_object(), default.as_object()) {
            for (key, v) in given {
                if default.get(key) != Some(v) {
                    out.push(format!(
                        "[geometry] {key} = {v} is ignored by the {} family (its shape is [tube]): remove it",
                        cfg.geometry.family
                    ));
                }
            }
        }
        out
    }

    fn element_estimate(&self, cfg: &ActuatorConfig, h: f64) -> f64 {
        match &cfg.tube {
            Some(t) => fibre::element_estimate(cfg, t, h),
            // Refused by validate; counted as the grid it would not be.
            None => PneuNets.element_estimate(cfg, h),
        }
    }

    fn build(&self, cfg: &ActuatorConfig) -> Result<ActuatorMesh, FemError> {
        fibre::build_mesh(cfg)
    }

    /// The D-section's height: the flat bottom's floor and the outer radius above it
    /// (without a `[tube]`, refused by validate, the `[geometry]`'s).
    fn height_mm(&self, cfg: &ActuatorConfig) -> f64 {
        match &cfg.tube {
            Some(t) => t.floor_mm() + t.radii().1,
            None => cfg.geometry.height(),
        }
    }

    fn analytic_refusal(&self) -> Option<&'static str> {
        Some("the analytic model is of PneuNets chambers and the fibre-reinforced tube has none: use --model fem")
    }

    fn silicones<'a>(&self, cfg: &'a ActuatorConfig) -> Vec<(&'static str, &'a MaterialConfig)> {
        std::iter::once(("[material]", &cfg.material))
            .chain(
                cfg.tube
                    .as_ref()
                    .map(|t| ("[tube.outer_material]", &t.outer_material)),
            )
            .collect()
    }

    fn silicones_mut<'a>(
        &self,
        cfg: &'a mut ActuatorConfig,
    ) -> Vec<(&'static str, &'a mut MaterialConfig)> {
        std::iter::once(("[material]", &mut cfg.material))
            .chain(
                cfg.tube
                    .as_mut()
                    .map(|t| ("[tube.outer_material]", &mut t.outer_material)),
            )
            .collect()
    }

    fn deck_caveats(&self, cfg: &ActuatorConfig) -> Vec<String> {
        if cfg
            .tube
            .as_ref()
            .is_some_and(|t| t.fibre_model == FibreModel::Smeared)
        {
            vec!["smeared threads go out as orthotropic M3D4 membranes, on which CalculiX stalls near 10 kPa; [tube] fibre_model = \"line\" exports them as springs it runs to full pressure".into()]
        } else {
            Vec::new()
        }
    }
}

/// The fibre-reinforced bending actuator's strip (`[tube] bottom_strip = true` without
/// `[[layer]]`s of the config's own): a glass-fibre sheet 0.5 mm thick across the flat
/// bottom (the DOE study's strip; its modulus, 6.5 GPa, ν = 0.2, is chosen for a woven
/// glass-fibre sheet, no strength given), centred in the outer silicone under the
/// cavity (0.25..0.75 mm), meshed as a plate: compressed where the tube sags or
/// bends, a membrane alone wrinkles ([`super::plate`]).
pub fn bottom_strip_layer() -> LayerConfig {
    LayerConfig {
        name: "glass".into(),
        thickness_mm: 0.5,
        youngs_modulus_mpa: 6500.0,
        poisson_ratio: 0.2,
        height_mm: 0.25,
        element: LayerElement::Plate,
        tensile_strength_mpa: None,
        ..LayerConfig::default()
    }
}

/// The fibre-reinforced family's default ramp, kPa.
pub const FIBRE_PRESSURES: &str = "10:60:10";

/// Checks the bottom strips against the tube: membranes, inside the bottom wall.
pub fn validate_strips(cfg: &ActuatorConfig, t: &TubeConfig) -> Result<(), FemError> {
    if t.bottom_strip && cfg.layer.is_empty() {
        return Err(bad(
            "bottom_strip",
            "true, but the config's layer list is empty: leave out layer = [] for the family's glass-fibre strip, add a [[layer]] or set bottom_strip = false".into(),
        ));
    }
    for layer in &cfg.layer {
        if !layer.is_sheet() {
            return Err(FemError::Parameter {
                name: "layer.element".into(),
                why: format!("'{}': the fibre-reinforced tube takes sheet strips only: set element = \"plate\" (or \"membrane\")", layer.name),
            });
        }
        layer.validate(t.floor_mm())?;
        layer.validate_width(t.width_mm())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tube's height (sweep's and optimize's `height_mm`) is its D-section's, floor
    /// (inner + outer wall) plus outer radius, not the ignored `[geometry]`'s 23.5 mm.
    #[test]
    fn the_tubes_height_is_its_d_sections() {
        let cfg = ActuatorConfig::for_family(Family::FibreReinforced);
        // Floor 1.5 + 1.0 mm, outer radius 6 + 1.5 + 1.0 mm.
        assert!(
            (cfg.height_mm() - 11.0).abs() < 1e-12,
            "{}",
            cfg.height_mm()
        );
        let mut thicker = cfg.clone();
        if let Some(t) = thicker.tube.as_mut() {
            t.outer_wall_mm = 2.0;
        }
        assert!(
            (thicker.height_mm() - 13.0).abs() < 1e-12,
            "{}",
            thicker.height_mm()
        );
        let reference = ActuatorConfig::default();
        assert!((reference.height_mm() - 23.5).abs() < 1e-12);
    }
}
