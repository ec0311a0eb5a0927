//! Actuator families: the published designs the model builds, each a complete default
//! configuration (`[geometry] family = "..."`, `bendscope simulate --family NAME
//! --print-config`).
//!
//! A config file names its family and overrides what it wants: the family's defaults
//! fill the rest ([`super::actuator::ActuatorConfig`]'s deserializer merges the file
//! over [`defaults`]). Each family is a preset of a shape ([`super::shapes`]), which holds
//! its values. Every value a publication leaves open is a parameter; the values
//! chosen here and their sources are listed in the README ("Actuator families").
//!
//! - `pneunets`: the reference actuator of method.md §4 (Dragon Skin 30).
//! - `glove` (smartphone study): the PneuNets layout in Ecoflex 00-50 (Yeoh C1 = 0.0127,
//!   C2 = 4.23e-4 MPa) with a paper sheet (0.1 mm, 3 GPa: the middle of 2-4 GPa)
//!   embedded at mid-height of the base, a plate ([`super::plate`]).
//! - `strap` (strap study): PneuNets chambers in Ecoflex 00-30 on a base holding two PLA
//!   strips (4 GPa) under a 0.1 mm polyester fabric sheet (2.5 GPa), hanging from its
//!   clamp (gravity along the actuator, +x), 0-15 kPa.
//! - `fibre-reinforced` (DOE study): a D-section tube, Dragon Skin 20 inside Dragon Skin
//!   10, a Kevlar thread wound both ways or one way, a strip in the flat bottom as a
//!   `[[layer]]` with `[tube] bottom_strip = true` ([`super::fibre`]).

use super::config::ActuatorConfig;
pub use super::config::Family;
pub use super::shapes::{bottom_strip_layer, FIBRE_PRESSURES};

/// The family's whole default configuration (its shape's preset:
/// [`super::shapes::Shape::defaults`]).
pub fn defaults(family: Family) -> ActuatorConfig {
    family.shape().defaults(family)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::actuator::build_mesh;
    use crate::fem::config::Geometry;
    use crate::fem::layer::LayerElement;
    use crate::fem::material::MaterialPreset;
    use crate::fem::simulate::{run_ramp, RampSettings};

    #[test]
    fn a_config_naming_its_family_gets_the_familys_defaults() {
        let glove: ActuatorConfig = toml::from_str("[geometry]\nfamily = \"glove\"\n").unwrap();
        assert_eq!(glove, defaults(Family::Glove));
        assert_eq!(glove.material.preset, MaterialPreset::Ecoflex0050);
        // One [layer] table updates the family's only layer; other values stay.
        let thicker: ActuatorConfig = toml::from_str(
            "[geometry]\nfamily = \"glove\"\nf = 7.0\n[layer]\nthickness_mm = 0.2\n",
        )
        .unwrap();
        assert_eq!(thicker.layer.len(), 1);
        assert_eq!(thicker.layer[0].name, "paper");
        assert_eq!(
            (
                thicker.layer[0].thickness_mm,
                thicker.layer[0].youngs_modulus_mpa
            ),
            (0.2, 3000.0)
        );
        assert_eq!((thicker.geometry.f, thicker.geometry.b), (7.0, 116.0));
        // [[layer]] replaces the family's layers.
        let one: ActuatorConfig =
            toml::from_str("[geometry]\nfamily = \"strap\"\n[[layer]]\nname = \"paper\"\nthickness_mm = 0.1\nyoungs_modulus_mpa = 3000\nheight_mm = 0.5\n")
                .unwrap();
        assert_eq!(one.layer.len(), 1);
        // A config without a family is the reference actuator, as before families.
        let plain: ActuatorConfig = toml::from_str("[mesh]\nsize_mm = 2.0\n").unwrap();
        assert_eq!(plain.geometry, Geometry::default());
        assert!(plain.layer.is_empty());
        // Every family's printed config reads back as itself, in TOML and in JSON (whose
        // nulls are "not given").
        for f in Family::all() {
            let cfg = defaults(f);
            match cfg.validate() {
                // The mesh family's file is the user's: its defaults name none.
                Err(e) if f == Family::Mesh => {
                    assert!(e.to_string().contains("geometry.file"), "{e}")
                }
                other => other.unwrap(),
            }
            let text = cfg.to_toml().unwrap();
            assert_eq!(toml::from_str::<ActuatorConfig>(&text).unwrap(), cfg, "{f}");
            let json = serde_json::to_string(&cfg).unwrap();
            assert_eq!(
                serde_json::from_str::<ActuatorConfig>(&json).unwrap(),
                cfg,
                "{f}"
            );
        }
        let err = toml::from_str::<ActuatorConfig>("[geometry]\nfamily = \"bellows\"\n")
            .unwrap_err()
            .to_string();
        assert!(err.contains("bellows") && err.contains("glove"), "{err}");
    }

    #[test]
    fn contradictory_layers_are_refused_with_the_key_named() {
        let strap = defaults(Family::Strap);
        let mut wide = strap.clone();
        wide.layer[0].spacing_mm = 21.0;
        let e = wide.validate().unwrap_err().to_string();
        assert!(
            e.contains("spacing_mm") && e.contains("layer 1, 'pla'") && e.contains("27 mm"),
            "{e}"
        );
        let mut thick = strap.clone();
        thick.layer[1].thickness_mm = 1.0;
        let e = thick.validate().unwrap_err().to_string();
        assert!(
            e.contains("height_mm") && e.contains("does not fit in the base"),
            "{e}"
        );
        let mut strips = strap.clone();
        strips.layer[1].strips = 2;
        let e = strips.validate().unwrap_err().to_string();
        assert!(e.contains("strips") && e.contains("width_mm"), "{e}");
        let mut none = defaults(Family::Glove);
        none.layer.clear();
        let e = none.validate().unwrap_err().to_string();
        assert!(
            e.contains("layer") && e.contains("--family glove --print-config"),
            "{e}"
        );
        let mut solid = strap;
        for l in &mut solid.layer {
            l.element = LayerElement::Solid;
            l.height_mm = 0.5;
        }
        solid.layer[1].thickness_mm = 0.1;
        let e = solid.validate().unwrap_err().to_string();
        assert!(e.contains("overlap"), "{e}");
    }

    /// The strips and the sheet land where the config puts them: the membranes' area is
    /// the strips' (two 6 mm strips, half of them in the half model) and the sheet's
    /// over the base's length beyond nothing (the whole length, x from 0 to b).
    #[test]
    fn strap_layers_are_meshed_where_they_are() {
        let cfg = defaults(Family::Strap);
        let mesh = build_mesh(&cfg).unwrap();
        let area = |k: usize| -> f64 {
            mesh.parts[k]
                .membranes
                .iter()
                .map(|m| {
                    let x = mesh.model.membranes[*m].nodes.map(|n| mesh.model.nodes[n]);
                    crate::fem::membrane::MembraneGeometry::new(&x)
                        .unwrap()
                        .area()
                })
                .sum()
        };
        let g = &cfg.geometry;
        assert_eq!(mesh.parts.len(), 3);
        assert!((area(1) - g.b * 6.0).abs() < 1e-6, "{}", area(1));
        assert!((area(2) - g.b * 0.5 * g.i).abs() < 1e-6, "{}", area(2));
        for m in &mesh.parts[1].membranes {
            for n in mesh.model.membranes[*m].nodes {
                let p = mesh.model.nodes[n];
                assert!(p.y >= 4.0 - 1e-9 && p.y <= 10.0 + 1e-9 && (p.z - 1.0).abs() < 1e-9);
            }
        }
    }

    /// Each family's model converges over its published pressure range (a coarse mesh
    /// and three pressures here; the default ramps' figures are in docs/src/howto/fem.md)
    /// and bends as that family does.
    #[test]
    fn every_family_converges_over_its_published_range() {
        for (f, pressures, angle) in [
            (Family::Glove, "1,3,6", (60.0, 110.0)),
            (Family::Strap, "5,10,15", (5.0, 20.0)),
        ] {
            let mut cfg = defaults(f);
            cfg.mesh.size_mm = 2.5;
            cfg.load.pressures_kpa = pressures.into();
            let mesh = build_mesh(&cfg).unwrap();
            let started = std::time::Instant::now();
            let ramp = run_ramp(
                &mesh,
                &cfg.pressures_kpa().unwrap(),
                &RampSettings {
                    newton: cfg.solver.newton(),
                    ..Default::default()
                },
                |_, _| {},
            )
            .unwrap();
            let last = ramp.steps.last().unwrap();
            eprintln!(
                "{f}: {} nodes, {:.1} s, {} steps; at {} kPa radius {:.1} mm, angle {:.1} deg, tip ({:.1}, {:.1}) mm, twist {:.3} deg, extension {:.2}%, bottom inflation {:.3} mm, parts {:?}",
                mesh.model.nodes.len(),
                started.elapsed().as_secs_f64(),
                ramp.steps.len(),
                last.pressure_kpa,
                last.radius_mm,
                last.bending_angle_deg,
                last.tip_x_mm,
                last.tip_z_mm,
                last.twist_angle_deg,
                last.extension_pct,
                last.bottom_inflation_mm,
                last.parts
            );
            assert!(ramp.failure.is_none(), "{f}: {:?}", ramp.failure);
            assert_eq!(ramp.steps.len(), 3);
            let a: Vec<f64> = ramp.steps.iter().map(|s| s.bending_angle_deg).collect();
            assert!(a.windows(2).all(|w| w[1] > w[0]), "{f}: {a:?}");
            assert!(a[2] > angle.0 && a[2] < angle.1, "{f}: {a:?}");
            // A half model: no twist; the marker line stretches as the chambers inflate.
            assert!(ramp.steps.iter().all(|s| s.twist_angle_deg.abs() < 1e-6));
            assert!(ramp
                .steps
                .windows(2)
                .all(|w| w[1].extension_pct > w[0].extension_pct));
            // Every part reports a stress; the stiff layers carry more than the silicone
            // (the plates, the paper and the PLA strips, with their surfaces' bending).
            assert_eq!(last.parts.len(), cfg.layer.len() + 1);
            for p in &last.parts[1..] {
                assert!(
                    p.max_principal_stress_mpa > 2.0 * last.parts[0].max_principal_stress_mpa,
                    "{p:?}"
                );
                assert!(p.safety_factor > 1.0, "{p:?}");
            }
        }
    }
}
