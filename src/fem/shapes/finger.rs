//! The segmented finger of the finger-design study (`family = "segmented-finger"`):
//! N semicircular bellows of height H and wall TSB on a foot TOF thick, 130 mm long,
//! drawn by the project's parametric gmsh script (`examples/geo/segmented_finger.geo`,
//! built into the program) from `[finger]` ([`crate::fem::config::finger`]) and meshed
//! in 10-node tetrahedra as an imported geometry ([`super::imported`]). Its cavities are
//! the study's two channels, `mcp` (the MCP segment's bellows) and `pip_dip` (the PIP
//! and DIP segments' bellows, [`FingerConfig::segments`]), both at the ramp's pressure
//! by default (the study's 90 kPa on every segment); `[cavities]` sets them apart.

use std::path::PathBuf;

use super::imported::{made, model_of};
use super::Shape;
use crate::fem::config::finger::{FingerConfig, SHEET_POISSON};
use crate::fem::config::{
    ActuatorConfig, Family, Geometry, LoadConfig, MaterialConfig, MeshConfig,
};
use crate::fem::import::Completion;
use crate::fem::layer::LayerConfig;
use crate::fem::material::MaterialPreset;
use crate::fem::mesh::ActuatorMesh;
use crate::fem::FemError;

#[allow(non_upper_case_globals)]
impl Family {
    /// The finger-design study's segmented finger ([`Finger`]).
    pub const SegmentedFinger: Family = Family::named("segmented-finger");
}

/// The segmented finger.
pub struct Finger;

/// The finger's cavities, the study's channels (the .geo's `cavity.NAME` groups): the
/// MCP segment's bellows, and the PIP and DIP segments' together.
pub const CHANNELS: [&str; 2] = ["mcp", "pip_dip"];

/// The finger's gmsh script.
const GEO: &str = include_str!("../../../examples/geo/segmented_finger.geo");

/// The script as a file gmsh can read: written once per content into the temporary
/// folder (its name holds the content's hash, so a changed script is a new file).
fn geo_file() -> Result<PathBuf, FemError> {
    let hash = xxhash_rust::xxh3::xxh3_64(GEO.as_bytes());
    let dir = std::env::temp_dir().join(format!("bendscope-geo-{hash:016x}"));
    let path = dir.join("segmented_finger.geo");
    if path.is_file() {
        return Ok(path);
    }
    let fail = |e: std::io::Error| FemError::Output {
        why: format!(
            "{}: cannot write the finger's gmsh script: {e}",
            path.display()
        ),
    };
    std::fs::create_dir_all(&dir).map_err(fail)?;
    crate::io::write_atomic(&path, GEO.as_bytes()).map_err(fail)?;
    Ok(path)
}

fn finger(cfg: &ActuatorConfig) -> Result<&FingerConfig, FemError> {
    cfg.finger.as_ref().ok_or_else(|| {
        crate::fem::config::bad(
            "finger",
            "the segmented-finger family needs a [finger] section (see bendscope simulate --family segmented-finger --print-config)".into(),
        )
    })
}

impl Shape for Finger {
    fn own_section(&self) -> Option<&'static str> {
        Some("finger")
    }

    fn named_groups(&self) -> bool {
        true
    }

    fn families(&self) -> &'static [Family] {
        &[Family::SegmentedFinger]
    }

    fn defaults(&self, family: Family) -> ActuatorConfig {
        let reference = ActuatorConfig::default();
        ActuatorConfig {
            geometry: Geometry {
                family,
                ..Geometry::default()
            },
            // The study's Yeoh set; density and strength are not given (a silicone's
            // 1.1 g/cm³; strength 5 MPa, a safety factor's scale only).
            material: MaterialConfig {
                preset: MaterialPreset::Proposed,
                c1: Some(3.061),
                c2: Some(-0.637651),
                c3: Some(0.098623),
                density_g_cm3: 1.1,
                tensile_strength_mpa: 5.0,
                ..MaterialConfig::default()
            },
            // The study's 2 mm base size.
            mesh: MeshConfig {
                size_mm: 2.0,
                ..reference.mesh.clone()
            },
            load: LoadConfig {
                pressures_kpa: "15:90:15".into(),
                gravity: false,
                ..LoadConfig::default()
            },
            finger: Some(FingerConfig::default()),
            cavities: CHANNELS.iter().map(|c| (c.to_string(), 1.0)).collect(),
            ..reference
        }
    }

    fn validate_layers(&self, cfg: &ActuatorConfig) -> Result<(), FemError> {
        super::no_layers(
            cfg,
            "the segmented finger takes no [[layer]] tables: remove them",
        )
    }

    fn validate(&self, cfg: &ActuatorConfig) -> Result<(), FemError> {
        finger(cfg)?.validate()
    }

    fn cavity_names(&self, _cfg: &ActuatorConfig) -> Result<Vec<String>, FemError> {
        Ok(CHANNELS.map(str::to_string).to_vec())
    }

    /// Tetrahedra of gmsh's mesh at size h: the solid's volume over a regular
    /// tetrahedron's (h³ / 6√2), more where the walls are thinner than h, with a margin
    /// (the default's 2 and 2.5 mm meshes have about half of it).
    fn element_estimate(&self, cfg: &ActuatorConfig, h: f64) -> f64 {
        cfg.finger.as_ref().map_or(0.0, |f| {
            let thinnest = f.wall_mm.min(f.foot_mm).min(f.side_wall());
            1.5 * f.solid_volume_mm3() * 6.0 * std::f64::consts::SQRT_2 / h.powi(3)
                * (h / thinnest).max(1.0)
        })
    }

    fn build(&self, cfg: &ActuatorConfig) -> Result<ActuatorMesh, FemError> {
        let f = finger(cfg)?;
        let m = made(
            &geo_file()?,
            &f.geo_numbers(),
            cfg.mesh.size_mm,
            &Completion::default(),
        )?;
        // The bottom sheet is the .geo's `layer.sheet` surface, as a membrane.
        let mut with_sheet = cfg.clone();
        if f.sheet_mpa > 0.0 {
            with_sheet.layer = vec![LayerConfig {
                name: "sheet".into(),
                thickness_mm: f.sheet_mm,
                youngs_modulus_mpa: f.sheet_mpa,
                poisson_ratio: SHEET_POISSON,
                ..LayerConfig::default()
            }];
        }
        model_of(&with_sheet, &m)
    }

    fn height_mm(&self, cfg: &ActuatorConfig) -> f64 {
        cfg.finger
            .as_ref()
            .map_or(f64::NAN, |f| f.foot_mm + f.height_mm)
    }

    fn analytic_refusal(&self) -> Option<&'static str> {
        Some("the analytic model is of PneuNets chambers: use --model fem for the segmented finger")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::pressure_tri6::face_volume;

    /// The default finger meshed by gmsh: its cavities' volume is the drawn one
    /// ([`FingerConfig::cavity_volume_mm3`]: N bellows' box and half-cylinder top, the
    /// channels between them) to the 2 mm quadratic mesh's 0.2%; its sheet covers the
    /// bottom face (130 x 10 mm in the half model); its height is the foot and the bellow.
    #[test]
    fn the_default_finger_has_its_drawn_cavities_and_sheet() {
        let cfg = ActuatorConfig::for_family(Family::SegmentedFinger);
        cfg.validate().unwrap();
        let mesh = Finger.build(&cfg).unwrap();
        let nodes = &mesh.model.nodes;
        let w = mesh.model.volume_weights;
        let volume: f64 = mesh
            .model
            .tets
            .pressure_faces
            .iter()
            .map(|f| face_volume(&f.map(|i| nodes[i]), &w).0)
            .sum();
        let f = cfg.finger.as_ref().unwrap();
        let drawn = f.cavity_volume_mm3();
        assert!((volume / drawn - 1.0).abs() < 2e-3, "{volume} vs {drawn}");
        let sheet: f64 = mesh
            .model
            .tri_membranes
            .iter()
            .map(|m| {
                let [a, b, c] = [0, 1, 2].map(|k| nodes[m.nodes[k]]);
                0.5 * (b - a).cross(&(c - a)).norm()
            })
            .sum();
        let bottom = f.length_mm * 0.5 * f.width_mm();
        assert!((sheet / bottom - 1.0).abs() < 1e-9, "{sheet} vs {bottom}");
        assert_eq!(mesh.markers.len(), f.bellows + 1);
        assert!(mesh.half_model);
        assert_eq!(Finger.height_mm(&cfg), 11.25);
    }
}
