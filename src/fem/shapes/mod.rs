//! Actuator shapes: the seam between a config and the mesh the solver takes.
//!
//! A shape is one kind of actuator (the PneuNets chambers, the fibre-reinforced tube): it
//! supplies its families' default configurations (the published designs, presets of the
//! shape), checks its own sections and how the layers fit it, counts and builds its
//! [`ActuatorMesh`] (nodes, elements, named parts with materials, layers, threads,
//! cavity faces, clamp, markers), and answers what other modules ask of an actuator
//! (its height, whether the analytic chamber model stands for it, what the CalculiX
//! deck should know). Nothing outside this folder asks which family a config is.
//!
//! Adding a shape is a new file here implementing [`Shape`] and one line in
//! [`REGISTRY`] (docs: "Developer notes: adding an actuator shape").

mod fibre_tube;
pub mod finger;
mod imported;
mod pneunets;

use std::sync::OnceLock;

use serde::de::{
    Deserialize, DeserializeSeed, Deserializer, EnumAccess, Error, VariantAccess, Visitor,
};
use serde_json::{Map, Value};

use super::config::{ActuatorConfig, Family, MaterialConfig};
use super::mesh::ActuatorMesh;
use super::FemError;

pub use fibre_tube::{bottom_strip_layer, validate_strips, FibreTube, FIBRE_PRESSURES};
pub use imported::{from_imported, Imported};
pub use pneunets::{build_pneunets, thinnest_wall_mm, PneuNets};

/// Every shape the model builds, in the order of the docs (its families in that order
/// make `Family::all()` and the list an unknown family's message gives).
pub static REGISTRY: &[&dyn Shape] = &[&PneuNets, &FibreTube, &finger::Finger, &Imported];

/// One kind of actuator: its presets, its checks, its mesh.
pub trait Shape: Sync {
    /// The families (`[geometry] family`) that are presets of this shape, the default one
    /// first.
    fn families(&self) -> &'static [Family];

    /// The whole default configuration of `family` (one of [`Shape::families`]).
    fn defaults(&self, family: Family) -> ActuatorConfig;

    /// Adjusts the defaults `user`'s document is merged over (as JSON), for a key of the
    /// user's that changes which defaults apply (the tube's `bottom_strip`).
    fn adjust_defaults(&self, _user: &Value, _defaults: &mut Map<String, Value>) {}

    /// Checks the layers against the shape: where each goes, whether it fits.
    fn validate_layers(&self, cfg: &ActuatorConfig) -> Result<(), FemError>;

    /// Whether the shape is read from `[geometry] file` (and takes its `parameters`,
    /// `clamp` and `markers`); the others refuse those keys.
    fn reads_file(&self) -> bool {
        false
    }

    /// Whether the shape's mesh has named groups: volumes, each of which may take its own
    /// material (`[material.NAME]`), and `thread.NAME` curves (`[threads.NAME]`); the
    /// others refuse those tables.
    fn named_groups(&self) -> bool {
        false
    }

    /// Checks the shape's own sections and what it needs of the others.
    fn validate(&self, cfg: &ActuatorConfig) -> Result<(), FemError>;

    /// The model's named cavities (its `cavity.NAME` surfaces, NAME alone), whose
    /// pressures `[cavities]` sets apart; none: one cavity at the ramp's pressure.
    fn cavity_names(&self, _cfg: &ActuatorConfig) -> Result<Vec<String>, FemError> {
        Ok(Vec::new())
    }

    /// What the model is when it names no cavity, for the message refusing `[cavities]`.
    fn one_cavity(&self, cfg: &ActuatorConfig) -> String {
        format!(
            "the {} family has one cavity, at the ramp's pressure (separate pressures: the segmented finger's channels, or an imported mesh's `cavity.NAME` surfaces)",
            cfg.geometry.family
        )
    }

    /// Valid but suspect values: keys the shape ignores, set to other than the default.
    fn warnings(&self, _cfg: &ActuatorConfig) -> Vec<String> {
        Vec::new()
    }

    /// The number of elements a mesh of size `h` mm would have, counted without building
    /// it (a float: no overflow).
    fn element_estimate(&self, cfg: &ActuatorConfig, h: f64) -> f64;

    /// Meshes the actuator of `cfg`, validated.
    fn build(&self, cfg: &ActuatorConfig) -> Result<ActuatorMesh, FemError>;

    /// The actuator's height, mm (`height_mm` of sweeps and the optimizer).
    fn height_mm(&self, cfg: &ActuatorConfig) -> f64;

    /// Notes on the mesh before a run (a mesh coarser than the thinnest wall).
    fn mesh_notes(&self, _cfg: &ActuatorConfig) -> Vec<String> {
        Vec::new()
    }

    /// Why the analytic chamber model cannot stand for this shape (None: it can).
    fn analytic_refusal(&self) -> Option<&'static str> {
        None
    }

    /// The silicones of the config, each with the key that sets it (`[material]`).
    fn silicones<'a>(&self, cfg: &'a ActuatorConfig) -> Vec<(&'static str, &'a MaterialConfig)> {
        vec![("[material]", &cfg.material)]
    }

    /// [`Shape::silicones`], to change.
    fn silicones_mut<'a>(
        &self,
        cfg: &'a mut ActuatorConfig,
    ) -> Vec<(&'static str, &'a mut MaterialConfig)> {
        vec![("[material]", &mut cfg.material)]
    }

    /// What CalculiX will not do with this shape's deck, beyond the silicones' bulk
    /// modulus, one line each.
    fn deck_caveats(&self, _cfg: &ActuatorConfig) -> Vec<String> {
        Vec::new()
    }

    /// The config section only this shape reads (`tube`, `finger`), if any: the others
    /// refuse it rather than ignore it.
    fn own_section(&self) -> Option<&'static str> {
        None
    }
}

impl Family {
    /// Every family of every shape, in the registry's order.
    pub fn all() -> Vec<Family> {
        REGISTRY
            .iter()
            .flat_map(|s| s.families().iter().copied())
            .collect()
    }

    /// The shape this family is a preset of.
    pub fn shape(self) -> &'static dyn Shape {
        // A family is made only from the registry's names (its presets, FromStr,
        // deserializing): the first shape is never reached but for a bug.
        REGISTRY
            .iter()
            .copied()
            .find(|s| s.families().contains(&self))
            .unwrap_or(REGISTRY[0])
    }
}

impl ActuatorConfig {
    /// The shape of this config's family.
    pub fn shape(&self) -> &'static dyn Shape {
        self.geometry.family.shape()
    }

    /// Refuses a shape's own section ([`Shape::own_section`]) on another family's
    /// config, where nothing would read it.
    pub fn refuse_foreign_sections(&self) -> Result<(), FemError> {
        let family = self.geometry.family;
        for (section, given) in [
            ("tube", self.tube.is_some()),
            ("finger", self.finger.is_some()),
        ] {
            if !given || self.shape().own_section() == Some(section) {
                continue;
            }
            let owner = REGISTRY
                .iter()
                .find(|s| s.own_section() == Some(section))
                .map_or("another", |s| s.families()[0].name());
            return Err(super::config::bad(
                section,
                format!("[{section}] describes the {owner} family, and this config is family = \"{family}\": remove [{section}] or set family = \"{owner}\""),
            ));
        }
        Ok(())
    }

    /// The actuator's height, mm ([`Shape::height_mm`]).
    pub fn height_mm(&self) -> f64 {
        self.shape().height_mm(self)
    }
}

/// Refuses `[[layer]]` tables on a shape that takes none, saying `why`.
fn no_layers(cfg: &ActuatorConfig, why: &str) -> Result<(), FemError> {
    if cfg.layer.is_empty() {
        Ok(())
    } else {
        Err(super::config::bad("layer", why.into()))
    }
}

/// The families' names, in the registry's order.
fn family_names() -> &'static [&'static str] {
    static NAMES: OnceLock<Vec<&'static str>> = OnceLock::new();
    NAMES.get_or_init(|| Family::all().into_iter().map(Family::name).collect())
}

fn family_named(name: &str) -> Option<Family> {
    Family::all().into_iter().find(|f| f.name() == name)
}

impl std::str::FromStr for Family {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        family_named(&s.to_ascii_lowercase()).ok_or_else(|| {
            format!(
                "unknown actuator family '{s}': use {}",
                family_names().join(", ")
            )
        })
    }
}

/// As serde derives it for a unit enum: a name, refused with the names it could be.
impl<'de> Deserialize<'de> for Family {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Name;
        impl<'de> Visitor<'de> for Name {
            type Value = Family;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("variant identifier")
            }
            fn visit_str<E: Error>(self, v: &str) -> Result<Family, E> {
                family_named(v).ok_or_else(|| E::unknown_variant(v, family_names()))
            }
        }
        impl<'de> DeserializeSeed<'de> for Name {
            type Value = Family;
            fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Family, D::Error> {
                d.deserialize_identifier(self)
            }
        }
        struct Variant;
        impl<'de> Visitor<'de> for Variant {
            type Value = Family;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("enum Family")
            }
            fn visit_enum<A: EnumAccess<'de>>(self, data: A) -> Result<Family, A::Error> {
                let (family, variant) = data.variant_seed(Name)?;
                variant.unit_variant()?;
                Ok(family)
            }
        }
        d.deserialize_enum("Family", family_names(), Variant)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `[tube]` and `[finger]` on a family that does not read them are refused naming
    /// the section and the family that does; on their own family they pass.
    #[test]
    fn a_section_of_another_family_is_refused() {
        let tube = Family::FibreReinforced;
        let finger = Family::SegmentedFinger;
        for (family, donor, section, owner) in [
            (Family::default(), finger, "finger", "segmented-finger"),
            (tube, finger, "finger", "segmented-finger"),
            (finger, tube, "tube", "fibre-reinforced"),
            (Family::default(), tube, "tube", "fibre-reinforced"),
        ] {
            let mut cfg = ActuatorConfig::for_family(family);
            let given = ActuatorConfig::for_family(donor);
            cfg.tube = cfg.tube.or(given.tube);
            cfg.finger = cfg.finger.or(given.finger);
            let e = cfg.refuse_foreign_sections().unwrap_err().to_string();
            assert!(
                e.contains(&format!("[{section}]")) && e.contains(&format!("family = \"{owner}\"")),
                "{family}: {e}"
            );
        }
        for family in [tube, finger] {
            ActuatorConfig::for_family(family)
                .refuse_foreign_sections()
                .unwrap();
        }
    }

    /// Every family belongs to exactly one shape, names are distinct, and the default
    /// family is the reference PneuNets.
    #[test]
    fn every_family_has_one_shape_and_its_own_name() {
        let all = Family::all();
        assert_eq!(
            family_names(),
            [
                "pneunets",
                "glove",
                "strap",
                "fibre-reinforced",
                "segmented-finger",
                "mesh"
            ]
        );
        for f in &all {
            let owners = REGISTRY.iter().filter(|s| s.families().contains(f)).count();
            assert_eq!(owners, 1, "{f}");
            assert_eq!(f.shape().defaults(*f).geometry.family, *f);
            assert_eq!(f.name().parse::<Family>(), Ok(*f));
        }
        assert_eq!(Family::default(), Family::Pneunets);
        assert_eq!(Family::default(), REGISTRY[0].families()[0]);
        let err = "bellows".parse::<Family>().unwrap_err();
        assert_eq!(
            err,
            "unknown actuator family 'bellows': use pneunets, glove, strap, fibre-reinforced, segmented-finger, mesh"
        );
    }
}
