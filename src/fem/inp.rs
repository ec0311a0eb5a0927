//! The model `simulate` solves as an Abaqus/CalculiX input deck (`--export-inp`).
//!
//! Written by hand: the deck is a few keyword cards of plain text, and no crate writes
//! them. The deck is the half actuator of [`super::actuator::build_mesh`] as it is:
//! nodes (mm), hexahedra as `C3D8I` (incompatible modes: CalculiX has no hybrid
//! elements and plain C3D8 locks on nearly incompressible silicone), the Yeoh material
//! (`*HYPERELASTIC, YEOH`: C10 C20 C30 = c1 c2 c3, D1 = 2/K, D2 = D3 = 0) and its
//! density, the clamp and the symmetry plane y = 0 as `*BOUNDARY`, gravity as
//! `*DLOAD GRAV` in a first step of its own when on, then one `*STEP, NLGEOM` per ramp
//! pressure with the cavity pressure as element-face loads `P1..P6` and the marker
//! (`MARKERS`, from the clamp towards the tip) and tip (`TIP`) displacements printed
//! once at its end. Units: mm, N, MPa, t/mm³, s.
//!
//! Face numbers (CalculiX and Abaqus C3D8): P1 = nodes 1-2-3-4 (ζ = −1), P2 = 5-8-7-6
//! (ζ = +1), P3 = 1-5-6-2 (η = −1), P4 = 2-6-7-3 (ξ = +1), P5 = 3-7-8-4 (η = +1),
//! P6 = 4-8-5-1 (ξ = −1), each listed counter-clockwise seen from inside the element;
//! a positive face pressure pushes into the element, as the
//! cavity pressure pushes into the wall. [`super::hex`]'s local node order is
//! CalculiX's (bottom face counter-clockwise seen from +z, then the top face).

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use super::actuator::{build_mesh, ActuatorConfig, ActuatorMesh, GRAVITY_M_S2};
use super::FemError;

/// The faces of a C3D8 element: CalculiX/Abaqus face k + 1 has these local nodes.
pub const C3D8_FACES: [[usize; 4]; 6] = [
    [0, 1, 2, 3],
    [4, 7, 6, 5],
    [0, 4, 5, 1],
    [1, 5, 6, 2],
    [2, 6, 7, 3],
    [3, 7, 4, 0],
];

/// Initial increment of each `*STATIC` step, as a fraction of the step.
pub const INITIAL_INCREMENT: f64 = 0.25;

/// Smallest increment CalculiX may cut a step to, as a fraction of the step.
pub const MIN_INCREMENT: f64 = 1e-5;

/// Most increments in a step (`*STEP, INC=`).
pub const MAX_INCREMENTS: usize = 1000;

/// What an exported deck holds.
#[derive(Debug, Clone, PartialEq)]
pub struct InpSummary {
    /// Nodes of the half model.
    pub nodes: usize,
    /// C3D8I elements.
    pub elements: usize,
    /// Element faces carrying the cavity pressure.
    pub pressure_faces: usize,
    /// `*STEP`s (a gravity step when on, then one per ramp pressure).
    pub steps: usize,
}

impl std::fmt::Display for InpSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "CalculiX deck: {} nodes, {} C3D8I, {} pressure faces, {} steps",
            self.nodes, self.elements, self.pressure_faces, self.steps
        )
    }
}

/// The element and CalculiX face number (1..6) of every cavity face: the solid element
/// the face belongs to.
pub fn pressure_face_loads(mesh: &ActuatorMesh) -> Result<Vec<(usize, usize)>, FemError> {
    let key = |mut q: [usize; 4]| {
        q.sort_unstable();
        q
    };
    let mut faces: HashMap<[usize; 4], (usize, usize)> = HashMap::new();
    for (e, el) in mesh.model.elements.iter().enumerate() {
        for (f, local) in C3D8_FACES.iter().enumerate() {
            faces.insert(key(local.map(|a| el[a])), (e, f + 1));
        }
    }
    mesh.model
        .pressure_faces
        .iter()
        .map(|q| {
            faces.get(&key(*q)).copied().ok_or_else(|| FemError::Model {
                why: "a cavity face belongs to no element (mesh bug)".into(),
            })
        })
        .collect()
}

/// The deck of the model `cfg` describes (see the module doc), and what it holds.
pub fn inp_from_config(cfg: &ActuatorConfig) -> Result<(String, InpSummary), FemError> {
    if !cfg.layer.is_empty() {
        return Err(FemError::Parameter {
            name: "layer".into(),
            why: "--export-inp does not export a [layer] yet: remove the [layer] section or leave out --export-inp".into(),
        });
    }
    if cfg.geometry.family == super::family::Family::FibreReinforced {
        return Err(FemError::Parameter {
            name: "family".into(),
            why: "--export-inp does not export the fibre-reinforced tube's threads yet: leave out --export-inp".into(),
        });
    }
    if cfg.contact.as_ref().is_some_and(|c| c.enabled) {
        return Err(FemError::Parameter {
            name: "contact".into(),
            why: "--export-inp does not export [contact] yet: set enabled = false or leave out --export-inp".into(),
        });
    }
    let pressures_kpa = cfg.pressures_kpa()?;
    let mesh = build_mesh(cfg)?;
    let loads = pressure_face_loads(&mesh)?;
    let m = &mesh.model;
    let mat = &m.material;
    let mut s = String::new();
    // Writing into a String cannot fail: the fmt::Results below are discarded.
    let _ = writeln!(
        s,
        "** bendscope simulate: the half actuator (y >= 0) as solved; mm, N, MPa, t/mm^3, s\n*HEADING\nbendscope half actuator, {} nodes, {} C3D8I, mesh {} mm",
        m.nodes.len(),
        m.elements.len(),
        cfg.mesh.size_mm
    );
    s.push_str("*NODE, NSET=NALL\n");
    for (a, x) in m.nodes.iter().enumerate() {
        let _ = writeln!(s, "{}, {:.9e}, {:.9e}, {:.9e}", a + 1, x.x, x.y, x.z);
    }
    s.push_str("*ELEMENT, TYPE=C3D8I, ELSET=EALL\n");
    for (e, el) in m.elements.iter().enumerate() {
        let ids: Vec<String> = el.iter().map(|n| (n + 1).to_string()).collect();
        let _ = writeln!(s, "{}, {}", e + 1, ids.join(", "));
    }
    let fixed_nodes = |dof: usize| -> Vec<usize> {
        (0..m.nodes.len())
            .filter(|a| m.fixed[3 * a + dof])
            .collect()
    };
    let clamped: Vec<usize> = (0..m.nodes.len())
        .filter(|a| (0..3).all(|d| m.fixed[3 * a + d]))
        .collect();
    let symmetry: Vec<usize> = fixed_nodes(1)
        .into_iter()
        .filter(|a| !clamped.contains(a))
        .collect();
    write_nset(&mut s, "CLAMPED", &clamped);
    write_nset(&mut s, "SYMMETRY", &symmetry);
    write_nset(&mut s, "MARKERS", &mesh.markers);
    write_nset(&mut s, "TIP", &[mesh.tip]);
    let _ = writeln!(
        s,
        "*MATERIAL, NAME=SILICONE\n*HYPERELASTIC, YEOH\n{:.9e}, {:.9e}, {:.9e}, {:.9e}, 0., 0.\n*DENSITY\n{:.9e}",
        mat.c1,
        mat.c2,
        mat.c3,
        2.0 / mat.bulk_modulus,
        cfg.material.density_g_cm3 * 1e-9
    );
    s.push_str("*SOLID SECTION, ELSET=EALL, MATERIAL=SILICONE\n*BOUNDARY\n");
    if !clamped.is_empty() {
        s.push_str("CLAMPED, 1, 3\n");
    }
    if !symmetry.is_empty() {
        s.push_str("SYMMETRY, 2, 2\n");
    }
    let step_head = format!(
        "*STEP, NLGEOM, INC={MAX_INCREMENTS}\n*STATIC\n{INITIAL_INCREMENT}, 1., {MIN_INCREMENT:e}, 1.\n"
    );
    let mut steps = 0;
    if cfg.load.gravity {
        let _ = writeln!(
            s,
            "** gravity first, as bendscope's ramp\n{step_head}*DLOAD\nEALL, GRAV, {:.6}, 0., 0., -1.\n*END STEP",
            GRAVITY_M_S2 * 1e3
        );
        steps += 1;
    }
    for p in &pressures_kpa {
        let _ = write!(s, "** cavity pressure {p} kPa\n{step_head}*DLOAD\n");
        for (e, face) in &loads {
            let _ = writeln!(s, "{}, P{face}, {:.9e}", e + 1, p * 1e-3);
        }
        // FREQUENCY beyond any increment count: printed at the step's end only.
        let every = MAX_INCREMENTS + 1;
        let _ = writeln!(
            s,
            "*NODE PRINT, NSET=MARKERS, FREQUENCY={every}\nU\n*NODE PRINT, NSET=TIP, FREQUENCY={every}\nU\n*END STEP"
        );
        steps += 1;
    }
    let summary = InpSummary {
        nodes: m.nodes.len(),
        elements: m.elements.len(),
        pressure_faces: loads.len(),
        steps,
    };
    Ok((s, summary))
}

/// Writes the deck of `cfg` to `path` atomically ([`crate::io::write_atomic`]).
pub fn write_inp(path: &Path, cfg: &ActuatorConfig) -> Result<InpSummary, FemError> {
    let (text, summary) = inp_from_config(cfg)?;
    crate::io::write_atomic(path, text.as_bytes()).map_err(|e| FemError::Output {
        why: format!("{}: {e}", path.display()),
    })?;
    Ok(summary)
}

/// `*NSET` card with 1-based node ids, at most 16 per line (Abaqus's limit).
fn write_nset(s: &mut String, name: &str, nodes: &[usize]) {
    if nodes.is_empty() {
        return;
    }
    let _ = writeln!(s, "*NSET, NSET={name}");
    for chunk in nodes.chunks(16) {
        let ids: Vec<String> = chunk.iter().map(|n| (n + 1).to_string()).collect();
        let _ = writeln!(s, "{}", ids.join(", "));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::actuator::{LoadConfig, MeshConfig};
    use nalgebra::Vector3;

    /// Normal of a quad (a, b, c, d) by the right-hand rule: (c − a) × (d − b).
    fn normal(x: &[Vector3<f64>], q: [usize; 4]) -> Vector3<f64> {
        (x[q[2]] - x[q[0]]).cross(&(x[q[3]] - x[q[1]]))
    }

    fn coarse() -> ActuatorConfig {
        ActuatorConfig {
            mesh: MeshConfig { size_mm: 4.0 },
            load: LoadConfig {
                pressures_kpa: "5,10".into(),
                gravity: false,
                ..LoadConfig::default()
            },
            ..Default::default()
        }
    }

    #[test]
    fn c3d8_face_numbers_name_calculixs_faces_in_bendscopes_node_order() {
        // The unit cube in the local order of `hex` (bottom counter-clockwise from +z).
        let x: Vec<Vector3<f64>> = [
            (0., 0., 0.),
            (1., 0., 0.),
            (1., 1., 0.),
            (0., 1., 0.),
            (0., 0., 1.),
            (1., 0., 1.),
            (1., 1., 1.),
            (0., 1., 1.),
        ]
        .iter()
        .map(|&(a, b, c)| Vector3::new(a, b, c))
        .collect();
        // CalculiX's faces: P1 z = 0, P2 z = 1, P3 y = 0, P4 x = 1, P5 y = 1, P6 x = 0.
        let outward = [
            Vector3::new(0., 0., -1.),
            Vector3::new(0., 0., 1.),
            Vector3::new(0., -1., 0.),
            Vector3::new(1., 0., 0.),
            Vector3::new(0., 1., 0.),
            Vector3::new(-1., 0., 0.),
        ];
        for (f, out) in C3D8_FACES.iter().zip(&outward) {
            let n = normal(&x, *f);
            // CalculiX lists each face counter-clockwise seen from inside (its
            // right-hand normal points in); the unit cube's diagonals give length 2.
            let want: Vector3<f64> = -2.0 * out;
            assert!((n - want).norm() < 1e-12, "face {f:?}: {n}");
        }
    }

    #[test]
    fn every_cavity_face_is_loaded_on_its_wall_element_pushing_into_it() {
        let mesh = build_mesh(&coarse()).unwrap();
        let loads = pressure_face_loads(&mesh).unwrap();
        let m = &mesh.model;
        assert_eq!(loads.len(), m.pressure_faces.len());
        assert!(loads.len() > 100, "{}", loads.len());
        for (q, (e, face)) in m.pressure_faces.iter().zip(&loads) {
            let el = m.elements[*e];
            let local = C3D8_FACES[face - 1].map(|a| el[a]);
            let mut a = local;
            let mut b = *q;
            a.sort_unstable();
            b.sort_unstable();
            assert_eq!(a, b);
            // bendscope's cavity face normal points into the wall, and so does the
            // listed face's (CalculiX's order: into the element): the same vector.
            let (nb, nc) = (normal(&m.nodes, *q), normal(&m.nodes, local));
            assert!((nb - nc).norm() < 1e-9 * nb.norm(), "{nb} vs {nc}");
        }
    }

    #[test]
    fn the_deck_holds_the_model_once_and_one_print_per_pressure() {
        let cfg = coarse();
        let mesh = build_mesh(&cfg).unwrap();
        let (text, summary) = inp_from_config(&cfg).unwrap();
        assert_eq!(summary.nodes, mesh.model.nodes.len());
        assert_eq!(summary.elements, mesh.model.elements.len());
        assert_eq!(summary.steps, 2);
        assert_eq!(text.matches("*STEP, NLGEOM").count(), 2);
        assert_eq!(text.matches("*NODE PRINT, NSET=MARKERS").count(), 2);
        assert_eq!(text.matches("GRAV").count(), 0);
        let lines: Vec<&str> = text.lines().collect();
        let at = lines
            .iter()
            .position(|l| *l == "*NSET, NSET=MARKERS")
            .unwrap();
        let ids: Vec<usize> = lines[at + 1]
            .split(", ")
            .map(|v| v.parse::<usize>().unwrap() - 1)
            .collect();
        assert_eq!(ids, mesh.markers);
        let d1 = 2.0 / mesh.model.material.bulk_modulus;
        assert!(text.contains(&format!("{d1:.9e}, 0., 0.")));
        let mut with_gravity = cfg.clone();
        with_gravity.load.gravity = true;
        let (text, summary) = inp_from_config(&with_gravity).unwrap();
        assert_eq!(summary.steps, 3);
        assert!(text.contains("EALL, GRAV, 9806.650000, 0., 0., -1."));
        assert_eq!(text.matches("*NODE PRINT, NSET=MARKERS").count(), 2);
    }
}
