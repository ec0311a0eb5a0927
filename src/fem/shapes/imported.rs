//! An actuator of the user's own geometry (`[geometry] family = "mesh"`, `file = ...`):
//! a gmsh mesh read by [`crate::fem::import`], or a CAD or .geo file gmsh meshes first at
//! `[mesh] size_mm` (second order). Its physical groups name the parts: volumes the
//! materials (a volume takes `[material.NAME]` where the config has a table of its name,
//! else `[material]`; a volume named `clamp` is a clamped block), `cavity` surfaces (at the ramp's pressure), `clamp` surfaces,
//! `symmetry.x|y|z` planes, `markers` points (read from the clamp outward), and
//! optionally a `tip` point (else the last marker); `cavity.NAME` surfaces are cavities
//! pressurised apart (`[cavities] NAME = factor`). A file may leave its cavity (then
//! its closed inner surfaces), its clamp (`[geometry] clamp = "x-min"`) and its markers
//! (`[geometry.markers]`) unnamed ([`crate::fem::import::Completion`]); a .geo takes
//! `[geometry.parameters]` as gmsh numbers. As the built-in families, the
//! actuator lies along +x from its clamp and bends in the x-z plane: the radius is fitted
//! to the markers' x and z.
//!
//! `thread.NAME` curves are threads bonded along the tetrahedra's edges, their section
//! from `[threads.NAME]`; `layer.NAME` surfaces are sheets bonded to the tetrahedra's
//! faces (the sheet's mid-surface) as 6-node membranes ([`crate::fem::membrane_tri6`]),
//! their section from the `[[layer]]` table named NAME; a flat one with
//! `element = "plate"` also bends ([`crate::fem::plate_tri`]).

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::SystemTime;

use super::Shape;
use crate::fem::config::{ActuatorConfig, Family, Geometry, MaterialConfig};
use crate::fem::import::{gmsh, msh, Completion, ImportedMesh};
use crate::fem::layer::{LayerConfig, LayerElement, MAX_SHEET_MM};
use crate::fem::material::Yeoh;
use crate::fem::membrane_tri6::Tri6Membrane;
use crate::fem::mesh::{gravity_loads_tets, ActuatorMesh, Part, PlateSection};
use crate::fem::plate::{Mirror, PlateTerm};
use crate::fem::plate_tri::tri_plate_terms;
use crate::fem::pressure::CLOSED;
use crate::fem::solve::{Cavity, Model, Tetrahedra};
use crate::fem::truss::{EmbeddedPoint, TrussElement};
use crate::fem::FemError;

#[allow(non_upper_case_globals)]
impl Family {
    /// An imported mesh or CAD file ([`Imported`]).
    pub const Mesh: Family = Family::named("mesh");
}

/// The user's own geometry, from a file.
pub struct Imported;

/// Stiffest sheet, MPa (ten times steel's modulus: a value in Pa is refused).
const MAX_SHEET_MPA: f64 = 1e6;

/// Extensions gmsh meshes (CAD and its own .geo).
const CAD: [&str; 6] = ["geo", "step", "stp", "iges", "igs", "brep"];

fn bad(why: String) -> FemError {
    crate::fem::config::bad("geometry.file", why)
}

/// The configured file, checked to be there and of a kind this reads.
fn source(cfg: &ActuatorConfig) -> Result<&Path, FemError> {
    let Some(file) = cfg.geometry.file.as_deref() else {
        return Err(bad(
            "the mesh family needs a file: set [geometry] file = \"actuator.msh\" (a gmsh mesh, or .geo/.step/.stp/.iges/.igs/.brep for gmsh to mesh)".into(),
        ));
    };
    let ext = file
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    if ext != "msh" && !CAD.contains(&ext.as_str()) {
        return Err(bad(format!(
            "{}: not a gmsh mesh (.msh) or a file gmsh meshes (.geo, .step, .stp, .iges, .igs, .brep)",
            file.display()
        )));
    }
    if !file.is_file() {
        return Err(bad(format!(
            "{} does not exist (a relative path is relative to the config file)",
            file.display()
        )));
    }
    Ok(file)
}

/// An imported mesh, and the gmsh mesh file bendscope made for it (None: the config
/// named a mesh file).
pub(super) struct Made {
    pub mesh: ImportedMesh,
    pub msh: Option<Arc<Vec<u8>>>,
}

/// What a mesh depends on: the file (path, length, time), the mesh size, the .geo's
/// numbers and the supplied parts.
type Key = (
    PathBuf,
    u64,
    Option<SystemTime>,
    u64,
    Vec<(String, u64)>,
    String,
);

/// The meshes made last, newest first: a run reads its height, builds and writes its
/// mesh from one meshing, and a sweep's steps over the same geometry share it.
static MADE: Mutex<Vec<(Key, Arc<Made>)>> = Mutex::new(Vec::new());
/// How many meshes [`MADE`] keeps.
const MADE_KEPT: usize = 2;

fn completion(cfg: &ActuatorConfig) -> Completion {
    Completion {
        clamp: cfg.geometry.clamp,
        markers: cfg.geometry.markers.clone(),
        marker_reach_mm: cfg.mesh.size_mm,
    }
}

/// Refuses `[geometry] parameters` a file cannot take: a mesh or CAD file has none, and
/// a .geo only those names it holds (gmsh would ignore the others).
fn check_parameters(cfg: &ActuatorConfig, file: &Path, ext: &str) -> Result<(), FemError> {
    let Some((name, _)) = cfg.geometry.parameters.iter().next() else {
        return Ok(());
    };
    if ext != "geo" {
        return Err(crate::fem::config::bad(
            &format!("geometry.parameters.{name}"),
            format!(
                "{} is no .geo file: only a gmsh script has parameters (its DefineConstant numbers): remove [geometry] parameters",
                file.display()
            ),
        ));
    }
    let text = std::fs::read_to_string(file)
        .map_err(|e| bad(format!("{}: cannot read it: {e}", file.display())))?;
    let words: std::collections::BTreeSet<&str> = text
        .split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .collect();
    for name in cfg.geometry.parameters.keys() {
        if !words.contains(name.as_str()) {
            return Err(crate::fem::config::bad(
                &format!("geometry.parameters.{name}"),
                format!(
                    "{} has no `{name}`: name one of its DefineConstant numbers",
                    file.display()
                ),
            ));
        }
    }
    Ok(())
}

/// The mesh of the configured file ([`made`]).
fn read(cfg: &ActuatorConfig) -> Result<Arc<Made>, FemError> {
    let file = source(cfg)?;
    let ext = file
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    check_parameters(cfg, file, &ext)?;
    let numbers: Vec<(String, f64)> = cfg
        .geometry
        .parameters
        .iter()
        .map(|(k, v)| (k.clone(), *v))
        .collect();
    made(file, &numbers, cfg.mesh.size_mm, &completion(cfg))
}

/// The mesh of `file`: read (a .msh), or made by gmsh at `size_mm` with a .geo's
/// `numbers` into a temporary folder; the same file, size and settings mesh once
/// ([`MADE`]).
pub(super) fn made(
    file: &Path,
    numbers: &[(String, f64)],
    size_mm: f64,
    completion: &Completion,
) -> Result<Arc<Made>, FemError> {
    let meta = std::fs::metadata(file)
        .map_err(|e| bad(format!("{}: cannot read it: {e}", file.display())))?;
    let key: Key = (
        file.to_path_buf(),
        meta.len(),
        meta.modified().ok(),
        size_mm.to_bits(),
        numbers
            .iter()
            .map(|(k, v)| (k.clone(), v.to_bits()))
            .collect(),
        format!("{completion:?}"),
    );
    let mut kept = MADE.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, m)) = kept.iter().find(|(k, _)| *k == key) {
        return Ok(m.clone());
    }
    let is_msh = file
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("msh"));
    let m = Arc::new(if is_msh {
        Made {
            mesh: msh::read_completed(file, completion)?,
            msh: None,
        }
    } else {
        let dir = tempfile::tempdir().map_err(|e| FemError::Output {
            why: format!("cannot make a temporary folder for gmsh's mesh: {e}"),
        })?;
        let out: PathBuf = dir.path().join("mesh.msh");
        gmsh::mesh(file, size_mm, numbers, &out)?;
        let bytes = std::fs::read(&out).map_err(|e| FemError::Output {
            why: format!("{}: cannot read gmsh's mesh: {e}", out.display()),
        })?;
        Made {
            mesh: msh::read_bytes(&file.display().to_string(), &bytes, completion)?,
            msh: Some(Arc::new(bytes)),
        }
    });
    kept.insert(0, (key, m.clone()));
    kept.truncate(MADE_KEPT);
    Ok(m)
}

/// The solver's model of a made mesh, with the mesh file gmsh made.
pub(super) fn model_of(cfg: &ActuatorConfig, made: &Made) -> Result<ActuatorMesh, FemError> {
    let mut mesh = from_imported(cfg, made.mesh.clone())?;
    mesh.made_mesh = made.msh.clone();
    Ok(mesh)
}

impl Shape for Imported {
    fn families(&self) -> &'static [Family] {
        &[Family::Mesh]
    }

    fn reads_file(&self) -> bool {
        true
    }

    fn named_groups(&self) -> bool {
        true
    }

    fn defaults(&self, family: Family) -> ActuatorConfig {
        ActuatorConfig {
            geometry: Geometry {
                family,
                ..Geometry::default()
            },
            ..ActuatorConfig::default()
        }
    }

    /// A layer lies where its `layer.NAME` surface is, as membranes (a plate: also its
    /// bending): the keys that place a built-in family's layer, and a solid layer, are
    /// refused.
    fn validate_layers(&self, cfg: &ActuatorConfig) -> Result<(), FemError> {
        let placed = LayerConfig::default();
        for layer in &cfg.layer {
            let given = [
                ("height_mm", layer.height_mm != placed.height_mm),
                ("width_mm", layer.width_mm.is_some()),
                ("strips", layer.strips != placed.strips),
                ("spacing_mm", layer.spacing_mm != placed.spacing_mm),
            ];
            if let Some((key, _)) = given.iter().find(|(_, g)| *g) {
                return Err(crate::fem::config::bad(
                    &format!("layer.{}.{key}", layer.name),
                    format!("an imported mesh's layer lies where its surface `layer.{}` is: remove {key}", layer.name),
                ));
            }
            // The sheet's numbers (no base to fit in: the surface is where it is).
            layer.validate(f64::INFINITY)?;
            let at = |key: &str| format!("layer.{}.{key}", layer.name);
            if layer.thickness_mm > MAX_SHEET_MM {
                return Err(crate::fem::config::bad(
                    &at("thickness_mm"),
                    format!("{}: a sheet is at most {MAX_SHEET_MM} mm thick here: draw a thicker layer as a volume with its own [material.NAME]", layer.thickness_mm),
                ));
            }
            if layer.youngs_modulus_mpa > MAX_SHEET_MPA {
                return Err(crate::fem::config::bad(
                    &at("youngs_modulus_mpa"),
                    format!("{}: above {MAX_SHEET_MPA} MPa (steel is 2e5): the modulus is in MPa, not Pa", layer.youngs_modulus_mpa),
                ));
            }
            if layer.element == LayerElement::Solid {
                return Err(crate::fem::config::bad(
                    &format!("layer.{}.element", layer.name),
                    "an imported mesh's layer is a surface: membrane or plate (its bending too); draw a solid strip as a volume with its own [material.NAME]".into(),
                ));
            }
        }
        Ok(())
    }

    fn validate(&self, cfg: &ActuatorConfig) -> Result<(), FemError> {
        source(cfg).map(|_| ())
    }

    fn cavity_names(&self, cfg: &ActuatorConfig) -> Result<Vec<String>, FemError> {
        Ok(named_cavities(&read(cfg)?.mesh))
    }

    fn one_cavity(&self, cfg: &ActuatorConfig) -> String {
        let file = cfg
            .geometry
            .file
            .as_deref()
            .map_or_else(String::new, |f| format!("{}: ", f.display()));
        one_cavity(&file)
    }

    /// The file decides: the reader bounds what it allocates itself.
    fn element_estimate(&self, _cfg: &ActuatorConfig, _h: f64) -> f64 {
        0.0
    }

    fn build(&self, cfg: &ActuatorConfig) -> Result<ActuatorMesh, FemError> {
        let made = read(cfg)?;
        model_of(cfg, &made)
    }

    fn height_mm(&self, cfg: &ActuatorConfig) -> f64 {
        read(cfg).map_or(f64::NAN, |m| {
            let z = m.mesh.nodes.iter().map(|x| x.z);
            z.clone().fold(f64::NEG_INFINITY, f64::max) - z.fold(f64::INFINITY, f64::min)
        })
    }

    fn analytic_refusal(&self) -> Option<&'static str> {
        Some("an imported mesh has no chamber model: use --model fem")
    }
}

/// The NAMEs of a mesh's `cavity.NAME` groups, in its order.
fn named_cavities(m: &ImportedMesh) -> Vec<String> {
    m.cavities
        .iter()
        .filter_map(|(g, _)| g.strip_prefix("cavity.").map(str::to_string))
        .collect()
}

/// What a mesh naming no cavity is (`file` its "path: " prefix), refusing `[cavities]`.
fn one_cavity(file: &str) -> String {
    format!(
        "{file}the mesh has one unnamed cavity (`cavity`, or its voids): name its surfaces `cavity.NAME` in the file (a group per cavity) to pressurise them apart"
    )
}

/// The solver's model of an imported mesh: its tetrahedra, cavities, clamp, symmetry
/// planes, markers and tip.
pub fn from_imported(cfg: &ActuatorConfig, m: ImportedMesh) -> Result<ActuatorMesh, FemError> {
    let name = cfg
        .geometry
        .file
        .as_deref()
        .map_or_else(String::new, |f| format!("{}: ", f.display()));
    let refuse = |why: String| FemError::Input {
        why: format!("{name}{why}"),
    };
    if m.markers.len() < 3 {
        return Err(refuse(format!(
            "{} `markers` point(s): the radius is fitted to at least 3 (Physical Point(\"markers\") = {{...}}, or a line of them: [geometry.markers] from = [x, y, z], to = [x, y, z], count = 8)",
            m.markers.len()
        )));
    }
    let n = m.nodes.len();
    let mut fixed = vec![false; 3 * n];
    for &a in &m.clamp {
        fixed[3 * a..3 * a + 3].fill(true);
    }
    for (axis, nodes) in &m.symmetry {
        for &a in nodes {
            fixed[3 * a + axis] = true;
        }
    }
    let names = named_cavities(&m);
    crate::fem::config::cavities::check_names(&cfg.cavities, &names, &one_cavity(&name))?;
    let materials = volume_materials(cfg, &m, &refuse)?;
    let mut parts = materials.parts;
    let trusses = threads_of(cfg, &m, &mut parts, &refuse)?;
    // Each symmetry plane at its nodes' mean coordinate (a plate's mirror there).
    let mirrors: Vec<Mirror> = m
        .symmetry
        .iter()
        .filter(|(_, nodes)| !nodes.is_empty())
        .map(|(axis, nodes)| Mirror {
            axis: *axis,
            at: nodes.iter().map(|&a| m.nodes[a][*axis]).sum::<f64>() / nodes.len() as f64,
        })
        .collect();
    let (tri_membranes, plates) = layers_of(cfg, &m, &mirrors, &mut parts, &refuse)?;
    let mut pressure_faces = Vec::new();
    let mut cavities = Vec::new();
    for (group, faces) in m.cavities {
        let name = group.strip_prefix("cavity.").map(str::to_string);
        let start = pressure_faces.len();
        pressure_faces.extend(faces);
        cavities.push(Cavity {
            factor: crate::fem::config::cavities::factor_of(&cfg.cavities, name.as_deref()),
            name,
            faces: start..pressure_faces.len(),
        });
    }
    let tets = Tetrahedra {
        elements: m.tets,
        material: materials.of_tet,
        pressure_faces,
        cavities,
    };
    let densities_g_cm3 = materials.densities_g_cm3;
    let loads = gravity_loads_tets(cfg, &m.nodes, &tets, &densities_g_cm3)?;
    // The cavity volume's field W x with no component across a symmetry plane: a cavity
    // the plane closes, wherever the plane lies.
    let mut weights = CLOSED;
    for (axis, _) in &m.symmetry {
        weights[*axis] = 0.0;
    }
    let sum = weights.sum();
    if sum <= 0.0 {
        return Err(refuse(
            "symmetry planes across all three axes: a model needs one axis without".into(),
        ));
    }
    weights /= sum;
    let tip = m.tip.unwrap_or(m.markers[m.markers.len() - 1]);
    let mut model = Model::solid(m.nodes, Vec::new(), cfg.material.yeoh()?, fixed, loads);
    model.volume_weights = weights;
    model.tets = tets;
    model.extra_materials = materials.extra;
    model.trusses = trusses;
    model.tri_membranes = tri_membranes;
    model.plates = plates;
    Ok(ActuatorMesh {
        model,
        markers: m.markers,
        tip,
        tip_support: vec![tip],
        bottom_line: Vec::new(),
        side_face: Vec::new(),
        clamp_mm: 0.0,
        wall_pairs: Vec::new(),
        parts,
        twist_pair: (tip, tip),
        half_model: !m.symmetry.is_empty(),
        densities_g_cm3,
        bottom_wall: None,
        made_mesh: None,
    })
}

/// The materials of an imported mesh's volumes ([`volume_materials`]).
struct VolumeMaterials {
    /// Each tetrahedron's material id (empty: all `[material]`).
    of_tet: Vec<u8>,
    /// The `[material.NAME]` tables' materials, ids 1, 2, ...
    extra: Vec<Yeoh>,
    /// A solid part per material used.
    parts: Vec<Part>,
    /// Density per material id, g/cm³.
    densities_g_cm3: Vec<f64>,
}

/// Each volume's material: id 0 (`[material]`, the part `silicone`) for a volume without
/// a table of its own, id k for the k-th `[material.NAME]` (the part NAME); a table
/// naming no volume of the mesh is refused.
fn volume_materials(
    cfg: &ActuatorConfig,
    m: &ImportedMesh,
    refuse: &dyn Fn(String) -> FemError,
) -> Result<VolumeMaterials, FemError> {
    let named: Vec<(&String, &MaterialConfig)> = cfg.material.named.iter().collect();
    if let Some((n, _)) = named.iter().find(|(n, _)| !m.materials.contains(n)) {
        return Err(refuse(format!(
            "[material.{n}]: the mesh has no volume `{n}` (its physical volumes: {}): name the table after one",
            m.materials.join(", ")
        )));
    }
    // The k-th table's material id, k + 1.
    let ids = (1..=named.len())
        .map(u8::try_from)
        .collect::<Result<Vec<u8>, _>>()
        .map_err(|_| refuse(format!("at most {} named materials", u8::MAX)))?;
    let id_of: Vec<u8> = m
        .materials
        .iter()
        .map(|volume| {
            named
                .iter()
                .position(|(n, _)| *n == volume)
                .map_or(0, |k| ids[k])
        })
        .collect();
    let of_tet: Vec<u8> = if named.is_empty() {
        Vec::new()
    } else {
        m.tet_material.iter().map(|&v| id_of[v]).collect()
    };
    let mut parts = Vec::new();
    if of_tet.is_empty() || of_tet.contains(&0) {
        parts.push(Part::solid(
            "silicone",
            cfg.material.tensile_strength_mpa,
            0,
        ));
    }
    let mut extra = Vec::with_capacity(named.len());
    let mut densities_g_cm3 = vec![cfg.material.density_g_cm3];
    for ((n, c), &id) in named.iter().zip(&ids) {
        extra.push(c.yeoh()?);
        densities_g_cm3.push(c.density_g_cm3);
        parts.push(Part::solid(n, c.tensile_strength_mpa, id));
    }
    Ok(VolumeMaterials {
        of_tet,
        extra,
        parts,
        densities_g_cm3,
    })
}

/// The trusses of the mesh's `thread.NAME` curves, each line cut at its mid-node into two
/// bars on the tetrahedra's nodes, with the section of `[threads.NAME]`; a part per thread
/// joins `parts`. A curve without its section, a section without its curve and a thread
/// named as a material are refused.
fn threads_of(
    cfg: &ActuatorConfig,
    m: &ImportedMesh,
    parts: &mut Vec<Part>,
    refuse: &dyn Fn(String) -> FemError,
) -> Result<Vec<TrussElement>, FemError> {
    let names: Vec<&str> = m.threads.iter().map(|(n, _)| n.as_str()).collect();
    if let Some(n) = cfg.threads.keys().find(|n| !names.contains(&n.as_str())) {
        let have = if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        };
        return Err(refuse(format!(
            "[threads.{n}]: the mesh has no curve `thread.{n}` (its threads: {have}): name the table after one"
        )));
    }
    let mut trusses = Vec::new();
    for (name, lines) in &m.threads {
        let t = cfg.threads.get(name).ok_or_else(|| {
            refuse(format!(
                "thread `{name}` has no section: give it, e.g. [threads.{name}] diameter_mm = 0.3, youngs_modulus_mpa = 70000 (Kevlar)"
            ))
        })?;
        if parts.iter().any(|p| p.name == *name) {
            return Err(refuse(format!(
                "thread `{name}` is named as a material: rename one of the groups"
            )));
        }
        let section = t.section();
        let start = trusses.len();
        for &[a, b, mid] in lines {
            for (p, q) in [(a, mid), (mid, b)] {
                trusses.push(TrussElement {
                    ends: [EmbeddedPoint::at_node(p), EmbeddedPoint::at_node(q)],
                    section,
                });
            }
        }
        parts.push(Part {
            name: name.clone(),
            tensile_strength_mpa: t.strength_mpa,
            solid_material: None,
            membranes: Vec::new(),
            plate: None,
            trusses: (start..trusses.len()).collect(),
            tri_membranes: Vec::new(),
        });
    }
    Ok(trusses)
}

/// The membranes of the mesh's `layer.NAME` surfaces, a 6-node membrane on each of their
/// triangles, with the section of the `[[layer]]` table named NAME, and a plate layer's
/// bending terms ([`crate::fem::plate_tri`], mirrored at `mirrors`); a part per layer
/// joins `parts`. A surface without its table, a table without its surface, a layer
/// named as another part and a plate that is not flat are refused.
fn layers_of(
    cfg: &ActuatorConfig,
    m: &ImportedMesh,
    mirrors: &[Mirror],
    parts: &mut Vec<Part>,
    refuse: &dyn Fn(String) -> FemError,
) -> Result<(Vec<Tri6Membrane>, Vec<PlateTerm>), FemError> {
    let names: Vec<&str> = m.layers.iter().map(|(n, _)| n.as_str()).collect();
    if let Some(l) = cfg.layer.iter().find(|l| !names.contains(&l.name.as_str())) {
        let have = if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        };
        return Err(refuse(format!(
            "[[layer]] `{}`: the mesh has no surface `layer.{}` (its layers: {have}): name the table after one",
            l.name, l.name
        )));
    }
    let mut membranes = Vec::new();
    let mut plates = Vec::new();
    for (name, faces) in &m.layers {
        let layer = cfg.layer.iter().find(|l| l.name == *name).ok_or_else(|| {
            refuse(format!(
                "layer `{name}` has no section: give it, e.g. [[layer]] name = \"{name}\", thickness_mm = 0.1, youngs_modulus_mpa = 3000 (paper)"
            ))
        })?;
        if parts.iter().any(|p| p.name == *name) {
            return Err(refuse(format!(
                "layer `{name}` is named as a material or a thread: rename one of the groups"
            )));
        }
        let section = layer.section();
        let start = membranes.len();
        membranes.extend(faces.iter().map(|&nodes| Tri6Membrane { nodes, section }));
        let plate = match layer.plate_rigidity() {
            Some(d) => {
                let first = plates.len();
                let terms = tri_plate_terms(&m.nodes, faces, d, layer.poisson_ratio, mirrors)
                    .map_err(|why| refuse(format!("layer `{name}` cannot be a plate: {why}")))?;
                plates.extend(terms);
                Some(PlateSection {
                    thickness_mm: layer.thickness_mm,
                    youngs_modulus_mpa: layer.youngs_modulus_mpa,
                    poisson_ratio: layer.poisson_ratio,
                    terms: first..plates.len(),
                })
            }
            None => None,
        };
        parts.push(Part {
            name: name.clone(),
            tensile_strength_mpa: layer.tensile_strength_mpa,
            solid_material: None,
            membranes: Vec::new(),
            plate,
            trusses: Vec::new(),
            tri_membranes: (start..membranes.len()).collect(),
        });
    }
    Ok((membranes, plates))
}
