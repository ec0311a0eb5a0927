//! The model `simulate` solves as an Abaqus/CalculiX input deck (`--export-inp`).
//!
//! Written by hand: the deck is a few keyword cards of plain text, and no crate writes
//! them. The deck is the model of [`super::actuator::build_mesh`] as it is built, given to
//! [`inp_from_mesh`] (the half
//! actuator of a mirror-symmetric family, the whole of the fibre-reinforced tube):
//! nodes (mm); hexahedra as `C3D8I` (incompatible modes: CalculiX has no hybrid
//! elements and plain C3D8 locks on nearly incompressible silicone), an element set,
//! Yeoh material (`*HYPERELASTIC, YEOH`: C10 C20 C30 = c1 c2 c3, D1 = 2/K, D2 = D3 = 0;
//! a solid layer as Yeoh with C20 = C30 = 0) and density per solid material; thin layers
//! as `M3D4` membranes on the same nodes (an imported mesh's sheets as `M3D6`; `*ELASTIC`
//! E ν, `*MEMBRANE SECTION` thickness),
//! plate layers as `S4` shells there (an imported mesh's as `S6`; `*SHELL SECTION`
//! thickness: CalculiX expands them through the thickness, the mid-plane tied to the
//! silicone's nodes, and on a symmetry plane holds their rotations about its two axes,
//! `SYMMETRY_SHELL` 4 and 6 on y = 0);
//! thread segments as `SPRINGA` between a node per thread point, stiffness E A / L0
//! (bendscope's bar at the thread's small strain; a cable as a `NONLINEAR` spring that
//! carries nothing shortened), each point tied to its host hexahedron by `*EQUATION`s
//! u_p − Σ w_a u_a = 0 (the embedding, exact for trilinear hosts); smeared threads as
//! `M3D4` of an `*ELASTIC, TYPE=ORTHO` material, an `*ORIENTATION` per direction (local 1
//! along the thread; [`SMEARED_ACROSS`] of its modulus across); the clamp and the
//! symmetry planes (a family's y = 0, `SYMMETRY`; an imported mesh's x and z planes too,
//! `SYMMETRY_X`, `SYMMETRY_Z`) as `*BOUNDARY`; `[contact]` as node-to-surface
//! penalty contact (each chamber wall a `*SURFACE` of element faces, a `*CONTACT PAIR`
//! per bendscope pair, the linear pressure-overclosure slope half bendscope's penalty, as
//! bendscope pairs the walls both ways with half a node's area in each); gravity along the config's
//! direction as `*DLOAD GRAV` in a first step of its own when on, then one
//! `*STEP, NLGEOM` per ramp pressure with the cavity pressure as element-face loads
//! `P1..P6` (each named cavity's the ramp's times its `[cavities]` factor, none at 0)
//! and the displacements of the markers (`MARKERS`, from the clamp towards the
//! tip), the tip (`TIP`) and the tip face's twist pair (`TWIST`: on the axis plane, the
//! lower node first; the twist is the angle of the line between them about the axis)
//! printed once at its end. Units: mm, N, MPa, t/mm³, s.
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

use super::config::ActuatorConfig;
use super::membrane::MembraneSection;
use super::mesh::{ActuatorMesh, Part, GRAVITY_M_S2};
use super::truss::EmbeddedPoint;
use super::FemError;

pub use super::hex::C3D8_FACES;

mod bulk;
pub use bulk::{caveats, for_calculix, CALCULIX_DECK_BULK_TO_SHEAR};

/// Initial increment of each `*STATIC` step, as a fraction of the step.
pub const INITIAL_INCREMENT: f64 = 0.25;

/// Smallest increment CalculiX may cut a step to, as a fraction of the step.
pub const MIN_INCREMENT: f64 = 1e-5;

/// Stiffness of smeared threads across themselves in the deck, as a share of theirs.
pub const SMEARED_ACROSS: f64 = 1e-6;

/// Most increments in a step (`*STEP, INC=`).
pub const MAX_INCREMENTS: usize = 1000;

/// What an exported deck holds.
#[derive(Debug, Clone, PartialEq)]
pub struct InpSummary {
    /// Nodes: the mesh's, then one per thread point (embedded in a hexahedron).
    pub nodes: usize,
    /// C3D8I elements.
    pub elements: usize,
    /// C3D10 elements.
    pub tets: usize,
    /// M3D4 membranes (thin layers).
    pub membranes: usize,
    /// M3D6 membranes (an imported mesh's layers, on its 6-node triangles).
    pub membrane_triangles: usize,
    /// S4 shells (thin layers with their bending stiffness: plate layers).
    pub shells: usize,
    /// S6 shells (an imported mesh's plate layers, on its 6-node triangles).
    pub shell_triangles: usize,
    /// SPRINGA thread segments.
    pub springs: usize,
    /// `*EQUATION`s tying the thread points to their host hexahedra (3 per point).
    pub equations: usize,
    /// Element faces carrying the cavity pressure.
    pub pressure_faces: usize,
    /// `*CONTACT PAIR`s (node-to-surface, the facing chamber walls both ways).
    pub contact_pairs: usize,
    /// `*STEP`s (a gravity step when on, then one per ramp pressure).
    pub steps: usize,
}

impl std::fmt::Display for InpSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "CalculiX deck: {} nodes", self.nodes)?;
        if self.elements > 0 {
            write!(f, ", {} C3D8I", self.elements)?;
        }
        if self.tets > 0 {
            write!(f, ", {} C3D10", self.tets)?;
        }
        if self.membranes > 0 {
            write!(f, ", {} M3D4", self.membranes)?;
        }
        if self.membrane_triangles > 0 {
            write!(f, ", {} M3D6", self.membrane_triangles)?;
        }
        if self.shells > 0 {
            write!(f, ", {} S4", self.shells)?;
        }
        if self.shell_triangles > 0 {
            write!(f, ", {} S6", self.shell_triangles)?;
        }
        if self.springs > 0 {
            write!(
                f,
                ", {} SPRINGA tied by {} equations",
                self.springs, self.equations
            )?;
        }
        write!(f, ", {} pressure faces", self.pressure_faces)?;
        if self.contact_pairs > 0 {
            write!(f, ", {} contact pairs", self.contact_pairs)?;
        }
        write!(f, ", {} steps", self.steps)
    }
}

/// Sorted node ids: a face's key whatever its orientation.
fn face_key(mut q: [usize; 4]) -> [usize; 4] {
    q.sort_unstable();
    q
}

/// Every face of the solid elements by [`face_key`]: its element and CalculiX face number
/// (1..6).
fn solid_faces(mesh: &ActuatorMesh) -> HashMap<[usize; 4], (usize, usize)> {
    let mut faces = HashMap::new();
    for (e, el) in mesh.model.elements.iter().enumerate() {
        for (f, local) in C3D8_FACES.iter().enumerate() {
            faces.insert(face_key(local.map(|a| el[a])), (e, f + 1));
        }
    }
    faces
}

/// The element and CalculiX face number of each of `faces` (element faces on the
/// solid's surface: a cavity's or a chamber wall's).
fn element_faces(
    index: &HashMap<[usize; 4], (usize, usize)>,
    faces: &[[usize; 4]],
    what: &str,
) -> Result<Vec<(usize, usize)>, FemError> {
    faces
        .iter()
        .map(|q| {
            index
                .get(&face_key(*q))
                .copied()
                .ok_or_else(|| FemError::Model {
                    why: format!("a {what} face belongs to no element (mesh bug)"),
                })
        })
        .collect()
}

/// Corners of the faces of a C3D10 (0-based local corners), CalculiX's and Abaqus's
/// face numbers 1..4.
pub const C3D10_FACES: [[usize; 3]; 4] = [[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]];

/// The element (numbered after the hexahedra) and C3D10 face number (1..4) of every
/// 6-node cavity face.
fn tet_face_loads(mesh: &ActuatorMesh) -> Result<Vec<(usize, usize)>, FemError> {
    let m = &mesh.model;
    let key = |mut t: [usize; 3]| {
        t.sort_unstable();
        t
    };
    let mut faces = HashMap::new();
    for (t, el) in m.tets.elements.iter().enumerate() {
        for (f, local) in C3D10_FACES.iter().enumerate() {
            faces.insert(key(local.map(|a| el[a])), (m.elements.len() + t, f + 1));
        }
    }
    m.tets
        .pressure_faces
        .iter()
        .map(|f| {
            faces
                .get(&key([f[0], f[1], f[2]]))
                .copied()
                .ok_or_else(|| FemError::Model {
                    why: "a cavity face belongs to no tetrahedron (mesh bug)".into(),
                })
        })
        .collect()
}

/// The element and CalculiX face number of every cavity face: the solid element the face
/// belongs to (hexahedra 1..6, then tetrahedra 1..4).
pub fn pressure_face_loads(mesh: &ActuatorMesh) -> Result<Vec<(usize, usize)>, FemError> {
    let mut loads = element_faces(&solid_faces(mesh), &mesh.model.pressure_faces, "cavity")?;
    loads.extend(tet_face_loads(mesh)?);
    Ok(loads)
}

/// The deck of `mesh`, the model `cfg` describes as built (see the module doc; its
/// loads, ramp and notes are `cfg`'s), and what it holds.
pub fn inp_from_mesh(
    mesh: &ActuatorMesh,
    cfg: &ActuatorConfig,
) -> Result<(String, InpSummary), FemError> {
    let pressures_kpa = cfg.pressures_kpa()?;
    let faces = solid_faces(mesh);
    let loads = pressure_face_loads(mesh)?;
    let m = &mesh.model;
    let names = part_names(mesh);
    let in_parts = |of: fn(&Part) -> usize| mesh.parts.iter().map(of).sum::<usize>();
    if in_parts(|p| p.membranes.len()) != m.membranes.len()
        || in_parts(|p| p.tri_membranes.len()) != m.tri_membranes.len()
        || in_parts(|p| p.trusses.len()) != m.trusses.len()
    {
        return Err(FemError::Model {
            why: "a membrane or thread segment belongs to no part (mesh bug)".into(),
        });
    }
    let mut s = String::new();
    let what = if mesh.half_model {
        "the half actuator (y >= 0)"
    } else {
        "the whole actuator"
    };
    // Writing into a String cannot fail: the fmt::Results below are discarded.
    let _ = writeln!(
        s,
        "** bendscope simulate: {what} as solved; mm, N, MPa, t/mm^3, s"
    );
    // What CalculiX will not do with the deck travels with it, not only on stderr.
    for c in caveats(cfg) {
        let _ = writeln!(s, "{}", comment_line(&format!("note: {c}")));
    }
    for c in &m.tets.cavities {
        if let Some(name) = &c.name {
            let _ = writeln!(
                s,
                "** cavity {name}: {} faces at {} x the ramp's pressure",
                c.faces.len(),
                c.factor
            );
        }
    }
    let _ = writeln!(
        s,
        "*HEADING\nbendscope {what}, {} nodes, {} C3D8I, {} C3D10, mesh {} mm",
        m.nodes.len(),
        m.elements.len(),
        m.tets.elements.len(),
        cfg.mesh.size_mm
    );
    s.push_str("*NODE, NSET=NALL\n");
    for (a, x) in m.nodes.iter().enumerate() {
        let _ = writeln!(s, "{}, {:.9e}, {:.9e}, {:.9e}", a + 1, x.x, x.y, x.z);
    }
    // Thread points: a node each (shared by the segments meeting there).
    let mut points: Vec<EmbeddedPoint> = Vec::new();
    let mut point_id: HashMap<[i64; 3], usize> = HashMap::new();
    let mut spring_ends = Vec::with_capacity(m.trusses.len());
    for t in &m.trusses {
        let ends = t.ends.map(|p| {
            let x = p.position(|a| m.nodes[a]);
            *point_id
                .entry([x.x, x.y, x.z].map(|v| (v * 1e7).round() as i64))
                .or_insert_with(|| {
                    points.push(p);
                    let id = m.nodes.len() + points.len();
                    let _ = writeln!(s, "{id}, {:.9e}, {:.9e}, {:.9e}", x.x, x.y, x.z);
                    id
                })
        });
        spring_ends.push(ends);
    }

    // Solids: a card per kind (ids 1..E as bendscope numbers them: the hexahedra, then
    // the tetrahedra as C3D10, CalculiX having no hybrid element), a set per material.
    if !m.elements.is_empty() {
        s.push_str("*ELEMENT, TYPE=C3D8I, ELSET=EALL\n");
        for (e, el) in m.elements.iter().enumerate() {
            let _ = writeln!(s, "{}, {}", e + 1, join_ids(el.iter().map(|n| n + 1)));
        }
    }
    let solids = m.elements.len() + m.tets.elements.len();
    if !m.tets.elements.is_empty() {
        s.push_str("*ELEMENT, TYPE=C3D10, ELSET=EALL\n");
        for (t, el) in m.tets.elements.iter().enumerate() {
            let id = m.elements.len() + t + 1;
            let _ = writeln!(s, "{id}, {}", join_ids(el.iter().map(|n| n + 1)));
        }
    }
    let n_materials = 1 + m.extra_materials.len();
    for k in 0..n_materials {
        let ids: Vec<usize> = (0..solids)
            .filter(|e| usize::from(m.solid_material_id(*e)) == k)
            .map(|e| e + 1)
            .collect();
        let mat = if k == 0 {
            &m.material
        } else {
            &m.extra_materials[k - 1]
        };
        let density = mesh
            .densities_g_cm3
            .get(k)
            .copied()
            .ok_or(FemError::Model {
                why: format!("material {k} has no density (mesh bug)"),
            })?;
        let name = &names.solids[k];
        write_set(&mut s, "ELSET", name, &ids);
        let _ = writeln!(
            s,
            "*MATERIAL, NAME={name}\n*HYPERELASTIC, YEOH\n{:.9e}, {:.9e}, {:.9e}, {:.9e}, 0., 0.\n*DENSITY\n{:.9e}\n*SOLID SECTION, ELSET={name}, MATERIAL={name}",
            mat.c1,
            mat.c2,
            mat.c3,
            2.0 / mat.bulk_modulus,
            density * 1e-9
        );
    }
    // Sheets on the layer's mid-plane nodes, a set and section per layer: M3D4 membranes,
    // or S4 shells for a plate layer (its bending stiffness; CalculiX expands them to
    // C3D8I through the thickness, tied to the silicone's nodes at their mid-plane).
    let mut next_id = solids;
    let (mut n_membranes, mut n_shells) = (0, 0);
    let (mut n_membrane_triangles, mut n_shell_triangles) = (0, 0);
    let mut shell_nodes = std::collections::BTreeSet::new();
    for (part, name) in mesh.parts.iter().zip(&names.parts) {
        if let Some(&first) = part.tri_membranes.first() {
            // An imported mesh's sheet, on the tetrahedra's 6-node faces: M3D6, or S6
            // shells for a plate layer.
            let section = m.tri_membranes[first].section;
            let (kind, card) = if part.plate.is_some() {
                n_shell_triangles += part.tri_membranes.len();
                ("S6", "SHELL SECTION")
            } else {
                n_membrane_triangles += part.tri_membranes.len();
                ("M3D6", "MEMBRANE SECTION")
            };
            let _ = writeln!(s, "*ELEMENT, TYPE={kind}, ELSET={name}");
            for &i in &part.tri_membranes {
                next_id += 1;
                let nodes = m.tri_membranes[i].nodes;
                if part.plate.is_some() {
                    shell_nodes.extend(nodes);
                }
                let _ = writeln!(s, "{next_id}, {}", join_ids(nodes.iter().map(|n| n + 1)));
            }
            let _ = writeln!(
                s,
                "*MATERIAL, NAME={name}\n*ELASTIC\n{:.9e}, {:.6}\n*{card}, ELSET={name}, MATERIAL={name}\n{:.9e}",
                section.youngs_modulus_mpa, section.poisson_ratio, section.thickness_mm
            );
        }
        let Some(&first) = part.membranes.first() else {
            continue;
        };
        let section = m.membranes[first].section;
        // Smeared threads: a section per direction (a set and an orientation each).
        let mut groups: Vec<(MembraneSection, Vec<usize>)> = Vec::new();
        let bare = |x: MembraneSection| MembraneSection { fibres: None, ..x };
        for &i in &part.membranes {
            let sec = m.membranes[i].section;
            if bare(sec) != bare(section) || sec.fibres.is_some() != section.fibres.is_some() {
                return Err(FemError::Model {
                    why: format!(
                        "layer {} has membranes of two sections (mesh bug)",
                        part.name
                    ),
                });
            }
            match groups.iter_mut().find(|(g, _)| *g == sec) {
                Some((_, ids)) => ids.push(i),
                None => groups.push((sec, vec![i])),
            }
        }
        if section.fibres.is_some_and(|f| f.tension_only) {
            return Err(FemError::Parameter {
                name: "tube.fibre_tension_only".into(),
                why: "smeared tension-only threads have no CalculiX equivalent: export them as a bar (false) or use fibre_model = \"line\"".into(),
            });
        }
        let (kind, card) = if part.plate.is_some() {
            n_shells += part.membranes.len();
            ("S4", "SHELL SECTION")
        } else {
            n_membranes += part.membranes.len();
            ("M3D4", "MEMBRANE SECTION")
        };
        let _ = writeln!(s, "*ELEMENT, TYPE={kind}, ELSET={name}");
        let mut ids = HashMap::new();
        for &i in &part.membranes {
            next_id += 1;
            ids.insert(i, next_id);
            let nodes = m.membranes[i].nodes;
            if part.plate.is_some() {
                shell_nodes.extend(nodes);
            }
            let _ = writeln!(s, "{next_id}, {}", join_ids(nodes.iter().map(|n| n + 1)));
        }
        if section.fibres.is_none() {
            let _ = writeln!(
                s,
                "*MATERIAL, NAME={name}\n*ELASTIC\n{:.9e}, {:.6}\n*{card}, ELSET={name}, MATERIAL={name}\n{:.9e}",
                section.youngs_modulus_mpa, section.poisson_ratio, section.thickness_mm
            );
            continue;
        }
        // Threads along the local 1 axis: D1111 = E; the rest 1e-6 E (CalculiX expands
        // the membrane into a solid, which nothing across the threads would leave
        // singular; with 1e-9 E stock ccx stalls in the first increment; 1e-6 E of Kevlar
        // is 0.03 MPa over the layer's 0.02 mm, 0.1% of the wall's stiffness).
        let e = section.youngs_modulus_mpa;
        let small = SMEARED_ACROSS * e;
        let _ = writeln!(
            s,
            "*MATERIAL, NAME={name}\n*ELASTIC, TYPE=ORTHO\n{e:.9e}, 0., {small:.3e}, 0., 0., {small:.3e}, {small:.3e}, {small:.3e}\n{small:.3e}, 294."
        );
        for (g, (sec, members)) in groups.iter().enumerate() {
            let a = nalgebra::Vector3::from(sec.fibres.map_or([1.0, 0.0, 0.0], |f| f.direction));
            // Local 2: any direction across the thread.
            let b = a
                .cross(&nalgebra::Vector3::x())
                .try_normalize(1e-6)
                .unwrap_or_else(|| a.cross(&nalgebra::Vector3::y()).normalize());
            let set = format!("{name}_{}", g + 1);
            let list: Vec<usize> = members.iter().map(|i| ids[i]).collect();
            write_set(&mut s, "ELSET", &set, &list);
            let _ = writeln!(
                s,
                "*ORIENTATION, NAME={set}, SYSTEM=RECTANGULAR\n{:.12e}, {:.12e}, {:.12e}, {:.12e}, {:.12e}, {:.12e}\n*{card}, ELSET={set}, MATERIAL={name}, ORIENTATION={set}\n{:.9e}",
                a.x, a.y, a.z, b.x, b.y, b.z, section.thickness_mm
            );
        }
    }
    // Threads: a SPRINGA per segment, k = E A / L0 (the bar at small strain), its own set.
    let first_spring = next_id + 1;
    for (part, name) in mesh.parts.iter().zip(&names.parts) {
        if part.trusses.is_empty() {
            continue;
        }
        let _ = writeln!(s, "*ELEMENT, TYPE=SPRINGA, ELSET={name}");
        for &i in &part.trusses {
            let [a, b] = spring_ends[i];
            let _ = writeln!(s, "{}, {a}, {b}", first_spring + i);
        }
    }
    for (i, t) in m.trusses.iter().enumerate() {
        let id = first_spring + i;
        let [p0, p1] = t.ends.map(|p| p.position(|a| m.nodes[a]));
        let l0 = (p1 - p0).norm();
        let k = t.section.youngs_modulus_mpa * t.section.area_mm2 / l0;
        let _ = writeln!(s, "*ELSET, ELSET=F{id}\n{id}");
        if t.section.tension_only {
            // A cable: no force while shorter than at rest (force, elongation pairs).
            let _ = writeln!(
                s,
                "*SPRING, ELSET=F{id}, NONLINEAR\n\n0., {:.9e}\n0., 0.\n{:.9e}, {:.9e}",
                -0.9 * l0,
                k * l0,
                l0
            );
        } else {
            let _ = writeln!(s, "*SPRING, ELSET=F{id}\n\n{k:.9e}");
        }
    }
    // Each thread point moves with its host: u_p = sum w_a u_a, per direction.
    if !points.is_empty() {
        s.push_str("*EQUATION\n");
    }
    for (i, p) in points.iter().enumerate() {
        let id = m.nodes.len() + i + 1;
        let hosts: Vec<(usize, f64)> = p
            .nodes
            .iter()
            .zip(&p.weights)
            .filter(|(_, w)| w.abs() > 1e-12)
            .map(|(a, w)| (a + 1, -w))
            .collect();
        for dof in 1..=3 {
            let terms: Vec<String> = std::iter::once((id, 1.0))
                .chain(hosts.iter().copied())
                .map(|(n, c)| format!("{n}, {dof}, {c:.12e}"))
                .collect();
            let _ = writeln!(s, "{}", terms.len());
            for line in terms.chunks(4) {
                let _ = writeln!(s, "{}", line.join(", "));
            }
        }
    }

    let fixed_nodes = |dof: usize| -> Vec<usize> {
        (0..m.nodes.len())
            .filter(|a| m.fixed[3 * a + dof])
            .collect()
    };
    let clamped: Vec<usize> = (0..m.nodes.len())
        .filter(|a| (0..3).all(|d| m.fixed[3 * a + d]))
        .collect();
    let one_based = |v: &[usize]| -> Vec<usize> { v.iter().map(|a| a + 1).collect() };
    write_set(&mut s, "NSET", "CLAMPED", &one_based(&clamped));
    // Nodes held along one axis alone lie on a symmetry plane (a family's y = 0, an
    // imported mesh's symmetry.x|y|z); a shell there also holds its rotations about the
    // plane's two axes (bendscope's plate takes its mirrored neighbour there).
    let mut held = String::new();
    for (name, axis) in [("SYMMETRY_X", 0), ("SYMMETRY", 1), ("SYMMETRY_Z", 2)] {
        let on_plane: Vec<usize> = fixed_nodes(axis)
            .into_iter()
            .filter(|a| !clamped.contains(a))
            .collect();
        let shells: Vec<usize> = on_plane
            .iter()
            .filter(|a| shell_nodes.contains(*a))
            .map(|a| a + 1)
            .collect();
        write_set(&mut s, "NSET", name, &one_based(&on_plane));
        write_set(&mut s, "NSET", &format!("{name}_SHELL"), &shells);
        if !on_plane.is_empty() {
            let _ = writeln!(held, "{name}, {0}, {0}", axis + 1);
        }
        if !shells.is_empty() {
            for rotation in (4..=6).filter(|r| *r != 4 + axis) {
                let _ = writeln!(held, "{name}_SHELL, {rotation}, {rotation}");
            }
        }
    }
    write_set(&mut s, "NSET", "MARKERS", &one_based(&mesh.markers));
    write_set(&mut s, "NSET", "TIP", &[mesh.tip + 1]);
    let (below, above) = mesh.twist_pair;
    write_set(&mut s, "NSET", "TWIST", &[below + 1, above + 1]);
    s.push_str("*BOUNDARY\n");
    if !clamped.is_empty() {
        s.push_str("CLAMPED, 1, 3\n");
    }
    s.push_str(&held);
    let contact_pairs = write_contact(&mut s, mesh, &faces)?;
    let step_head = format!(
        "*STEP, NLGEOM, INC={MAX_INCREMENTS}\n*STATIC\n{INITIAL_INCREMENT}, 1., {MIN_INCREMENT:e}, 1.\n"
    );
    let mut steps = 0;
    if cfg.load.gravity {
        let down = nalgebra::Vector3::from(cfg.load.gravity_direction).normalize();
        let _ = writeln!(
            s,
            "** gravity first, as bendscope's ramp\n{step_head}*DLOAD\nEALL, GRAV, {:.6}, {:.9}, {:.9}, {:.9}\n*END STEP",
            GRAVITY_M_S2 * 1e3,
            down.x + 0.0,
            down.y + 0.0,
            down.z + 0.0
        );
        steps += 1;
    }
    // Each face at its cavity's pressure: the ramp's times the cavity's factor (the
    // hexahedra's one cavity at 1); a cavity at 0 carries no load.
    let factor = |k: usize| {
        k.checked_sub(m.pressure_faces.len())
            .map_or(1.0, |j| m.tets.pressure_factor(j))
    };
    for p in &pressures_kpa {
        let _ = write!(s, "** cavity pressure {p} kPa\n{step_head}*DLOAD\n");
        for (k, (e, face)) in loads.iter().enumerate() {
            let f = factor(k);
            if f != 0.0 {
                let _ = writeln!(s, "{}, P{face}, {:.9e}", e + 1, p * 1e-3 * f);
            }
        }
        // FREQUENCY beyond any increment count: printed at the step's end only.
        let every = MAX_INCREMENTS + 1;
        let _ = writeln!(
            s,
            "*NODE PRINT, NSET=MARKERS, FREQUENCY={every}\nU\n*NODE PRINT, NSET=TIP, FREQUENCY={every}\nU\n*NODE PRINT, NSET=TWIST, FREQUENCY={every}\nU\n*END STEP"
        );
        steps += 1;
    }
    let summary = InpSummary {
        nodes: m.nodes.len() + points.len(),
        elements: m.elements.len(),
        tets: m.tets.elements.len(),
        membranes: n_membranes,
        membrane_triangles: n_membrane_triangles,
        shells: n_shells,
        shell_triangles: n_shell_triangles,
        springs: m.trusses.len(),
        equations: 3 * points.len(),
        pressure_faces: loads.len(),
        contact_pairs,
        steps,
    };
    Ok((s, summary))
}

/// The model's contact ([`super::contact`]) as CalculiX's node-to-surface penalty contact:
/// each wall's faces a `*SURFACE` (element faces), each pair a `*CONTACT PAIR` of the
/// slave wall's surface against the master's, one `*SURFACE INTERACTION` with the linear
/// pressure-overclosure law. bendscope pairs the walls both ways, each pass with half a
/// slave node's area; CalculiX gives a slave node its whole area in each pass, so the
/// slope is half bendscope's penalty. Returns the number of pairs.
fn write_contact(
    s: &mut String,
    mesh: &ActuatorMesh,
    index: &HashMap<[usize; 4], (usize, usize)>,
) -> Result<usize, FemError> {
    let Some(contact) = &mesh.model.contact else {
        return Ok(0);
    };
    if contact.pairs.is_empty() {
        return Ok(0);
    }
    let masters: Vec<std::collections::BTreeSet<usize>> = contact
        .pairs
        .iter()
        .map(|p| p.master_faces.iter().flatten().copied().collect())
        .collect();
    let _ = writeln!(
        s,
        "** contact between the facing walls of neighbouring chambers, both ways\n*SURFACE INTERACTION, NAME=WALLS\n*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR\n{:.9e}",
        0.5 * contact.penalty_mpa_per_mm
    );
    for (k, pair) in contact.pairs.iter().enumerate() {
        let _ = writeln!(s, "*SURFACE, NAME=WALL{}, TYPE=ELEMENT", k + 1);
        for (e, f) in element_faces(index, &pair.master_faces, "chamber wall")? {
            let _ = writeln!(s, "{}, S{f}", e + 1);
        }
    }
    for (k, pair) in contact.pairs.iter().enumerate() {
        // The slave wall is the master of another pair: its faces are that surface.
        let slave: std::collections::BTreeSet<usize> = pair.slave_nodes.iter().copied().collect();
        let of_slave = masters
            .iter()
            .position(|m| *m == slave)
            .ok_or_else(|| FemError::Model {
                why: format!(
                    "contact pair {} has a slave wall that is no pair's master (mesh bug)",
                    k + 1
                ),
            })?;
        let _ = writeln!(
            s,
            "*CONTACT PAIR, INTERACTION=WALLS, TYPE=NODE TO SURFACE\nWALL{}, WALL{}",
            of_slave + 1,
            k + 1
        );
    }
    Ok(contact.pairs.len())
}

/// Deck names (upper case, `[A-Z0-9_]`, unique) of the solid materials by id and of the
/// parts in order.
struct PartNames {
    solids: Vec<String>,
    parts: Vec<String>,
}

fn part_names(mesh: &ActuatorMesh) -> PartNames {
    let mut used = std::collections::HashSet::new();
    let mut unique = |raw: &str| {
        let base: String = raw
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() {
                    c.to_ascii_uppercase()
                } else {
                    '_'
                }
            })
            .take(60)
            .collect();
        let base = if base.starts_with(|c: char| c.is_ascii_alphabetic()) {
            base
        } else {
            format!("P_{base}")
        };
        let mut name = base.clone();
        let mut k = 2;
        while !used.insert(name.clone()) {
            name = format!("{base}_{k}");
            k += 1;
        }
        name
    };
    let parts: Vec<String> = mesh.parts.iter().map(|p| unique(&p.name)).collect();
    let solids = (0..=mesh.model.extra_materials.len())
        .map(|k| {
            mesh.parts
                .iter()
                .zip(&parts)
                .find(|(p, _)| p.solid_material == Some(k as u8))
                .map_or_else(|| unique(&format!("SOLID{k}")), |(_, n)| n.clone())
        })
        .collect();
    PartNames { solids, parts }
}

fn join_ids(ids: impl Iterator<Item = usize>) -> String {
    ids.map(|n| n.to_string()).collect::<Vec<_>>().join(", ")
}

/// `text` as one `**` comment line of the deck (line breaks folded to spaces).
fn comment_line(text: &str) -> String {
    format!("** {}", text.replace(['\n', '\r'], " "))
}

/// Writes the deck of `mesh` (built from `cfg`) to `path` atomically
/// ([`crate::io::write_atomic`]), with `notes` (what the deck leaves out of the run it was
/// exported from) as `** note:` comment lines under its first line, beside [`caveats`].
pub fn write_inp(
    path: &Path,
    mesh: &ActuatorMesh,
    cfg: &ActuatorConfig,
    notes: &[String],
) -> Result<InpSummary, FemError> {
    let (mut text, summary) = inp_from_mesh(mesh, cfg)?;
    if !notes.is_empty() {
        let at = text.find('\n').map_or(text.len(), |i| i + 1);
        let lines: String = notes
            .iter()
            .map(|n| comment_line(&format!("note: {n}")) + "\n")
            .collect();
        text.insert_str(at, &lines);
    }
    crate::io::write_atomic(path, text.as_bytes()).map_err(|e| FemError::Output {
        why: format!("{}: {e}", path.display()),
    })?;
    Ok(summary)
}

/// `*NSET` or `*ELSET` card of 1-based ids, at most 16 per line (Abaqus's limit).
fn write_set(s: &mut String, kind: &str, name: &str, ids: &[usize]) {
    if ids.is_empty() {
        return;
    }
    let _ = writeln!(s, "*{kind}, {kind}={name}");
    for chunk in ids.chunks(16) {
        let _ = writeln!(s, "{}", join_ids(chunk.iter().copied()));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::actuator::{build_mesh, LoadConfig, MeshConfig};

    /// The deck of the model `cfg` describes, as `simulate --export-inp` writes it.
    fn inp_from_config(cfg: &ActuatorConfig) -> Result<(String, InpSummary), FemError> {
        inp_from_mesh(&build_mesh(cfg)?, cfg)
    }
    use nalgebra::Vector3;

    /// Normal of a quad (a, b, c, d) by the right-hand rule: (c − a) × (d − b).
    /// The nodes (0-based) of the deck's node set `name`, empty when it has none.
    fn node_set(text: &str, name: &str) -> Vec<usize> {
        let lines: Vec<&str> = text.lines().collect();
        let head = format!("*NSET, NSET={name}");
        let Some(at) = lines.iter().position(|l| *l == head) else {
            return Vec::new();
        };
        lines[at + 1..]
            .iter()
            .take_while(|l| !l.starts_with('*'))
            .flat_map(|l| l.split(", ").map(|v| v.parse::<usize>().unwrap() - 1))
            .collect()
    }

    /// The glove at a 4 mm mesh, one pressure, no contact: a small model with a plate.
    fn coarse_glove() -> ActuatorConfig {
        let mut glove = ActuatorConfig::for_family(crate::fem::family::Family::Glove);
        glove.mesh.size_mm = 4.0;
        glove.load.pressures_kpa = "1".into();
        glove.contact = None;
        glove
    }

    fn normal(x: &[Vector3<f64>], q: [usize; 4]) -> Vector3<f64> {
        (x[q[2]] - x[q[0]]).cross(&(x[q[3]] - x[q[1]]))
    }

    /// By default the deck gets the bulk modulus CalculiX converges with (100 mu0 of each
    /// silicone above 200 mu0), with a note each; then no bulk caveat is left, and a
    /// config already at 100 mu0 is unchanged.
    #[test]
    fn the_calculix_deck_softens_the_bulk_modulus_and_says_so() {
        use crate::fem::family::{defaults, Family};
        let reference = defaults(Family::Pneunets);
        let (deck, notes) = for_calculix(&reference);
        let y = deck.material.yeoh().unwrap();
        assert!(
            (y.bulk_modulus / (2.0 * y.c1) - 100.0).abs() < 1e-9,
            "{y:?}"
        );
        assert_eq!(y.c1, reference.material.yeoh().unwrap().c1);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(
            notes[0].starts_with("the deck's [material] bulk modulus is")
                && notes[0].contains("(1000 mu0)")
        );
        assert!(caveats(&deck).is_empty(), "{:?}", caveats(&deck));
        let mut scaled = reference.clone();
        scaled.material.scale = 2.0;
        let y = for_calculix(&scaled).0.material.yeoh().unwrap();
        assert!(
            (y.bulk_modulus / (2.0 * y.c1) - 100.0).abs() < 1e-9,
            "{y:?}"
        );
        let tube = defaults(Family::FibreReinforced);
        let (deck, notes) = for_calculix(&tube);
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(notes[1].contains("[tube.outer_material]"));
        let left = caveats(&deck);
        assert!(left.len() == 1 && left[0].contains("smeared"), "{left:?}");
        let (same, notes) = for_calculix(&deck);
        assert!(notes.is_empty() && same == deck, "{notes:?}");
    }

    /// The export names what CalculiX will not do with a deck: the default bulk modulus
    /// (1000 mu0, C3D8I locks) and smeared threads (it stalls near 10 kPa); a deck at 100
    /// mu0 with threads as lines gets no note.
    #[test]
    fn the_export_notes_what_calculix_stalls_on() {
        use crate::fem::family::{defaults, Family};
        assert_eq!(caveats(&defaults(Family::Pneunets)).len(), 1);
        // In the deck too, as comments under its first line, before *HEADING.
        let mut coarse = defaults(Family::Pneunets);
        coarse.mesh.size_mm = 4.0;
        let (text, _) = inp_from_config(&coarse).unwrap();
        let lines: Vec<&str> = text.lines().take(3).collect();
        assert!(
            lines[1].starts_with("** note: a bulk modulus above 200 mu0") && lines[2] == "*HEADING",
            "{lines:?}"
        );
        let mut tube = defaults(Family::FibreReinforced);
        let notes = caveats(&tube);
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(notes[0].contains("--bulk-modulus") && notes[1].contains("fibre_model"));
        let t = tube.tube.as_mut().unwrap();
        t.fibre_model = crate::fem::fibre::FibreModel::Line;
        t.outer_material.bulk_modulus_mpa = Some(8.5);
        tube.material.bulk_modulus_mpa = Some(6.33);
        assert!(caveats(&tube).is_empty(), "{:?}", caveats(&tube));
    }

    fn coarse() -> ActuatorConfig {
        ActuatorConfig {
            mesh: MeshConfig {
                size_mm: 4.0,
                ..Default::default()
            },
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

    /// The cut mesh's 6-node cavity faces: each loaded on its tetrahedron's face (C3D10
    /// numbering, listed with its normal into the element as CalculiX's faces are), the
    /// same corners and normal as bendscope's face; the deck lists the C3D10 card.
    #[test]
    fn every_tetrahedral_cavity_face_is_loaded_on_its_element_pushing_into_it() {
        let mut cfg = coarse();
        cfg.mesh.element = crate::fem::config::SolidElement::Tet10;
        let mesh = build_mesh(&cfg).unwrap();
        let m = &mesh.model;
        let loads = pressure_face_loads(&mesh).unwrap();
        assert_eq!(loads.len(), m.tets.pressure_faces.len());
        assert!(loads.len() > 200, "{}", loads.len());
        let tri_normal = |c: [usize; 3]| {
            let [a, b, d] = c.map(|k| m.nodes[k]);
            (b - a).cross(&(d - a))
        };
        for (f, (e, face)) in m.tets.pressure_faces.iter().zip(&loads) {
            let el = m.tets.elements[*e - m.elements.len()];
            let local = C3D10_FACES[face - 1].map(|a| el[a]);
            let (mut a, mut b) = (local, [f[0], f[1], f[2]]);
            a.sort_unstable();
            b.sort_unstable();
            assert_eq!(a, b);
            // Into the element: towards its fourth corner.
            let fourth = (0..4).find(|k| !local.contains(&el[*k])).unwrap();
            let inward = m.nodes[el[fourth]] - m.nodes[local[0]];
            assert!(tri_normal(local).dot(&inward) > 0.0);
            let (nb, nc) = (tri_normal([f[0], f[1], f[2]]), tri_normal(local));
            assert!((nb - nc).norm() < 1e-9 * nb.norm(), "{nb} vs {nc}");
        }
        let (text, summary) = inp_from_config(&cfg).unwrap();
        assert_eq!(text.matches("*ELEMENT, TYPE=C3D10, ELSET=EALL").count(), 1);
        assert_eq!(text.matches("TYPE=C3D8I").count(), 0);
        assert_eq!(summary.tets, m.tets.elements.len());
        assert_eq!(summary.pressure_faces, loads.len());
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
        assert_eq!(node_set(&text, "MARKERS"), mesh.markers);
        let d1 = 2.0 / mesh.model.material.bulk_modulus;
        assert!(text.contains(&format!("{d1:.9e}, 0., 0.")));
        let mut with_gravity = cfg.clone();
        with_gravity.load.gravity = true;
        let (text, summary) = inp_from_config(&with_gravity).unwrap();
        assert_eq!(summary.steps, 3);
        assert!(text.contains("EALL, GRAV, 9806.650000, 0.000000000, 0.000000000, -1.000000000"));
        assert_eq!(text.matches("*NODE PRINT, NSET=MARKERS").count(), 2);
    }

    #[test]
    fn layers_go_out_as_membranes_and_threads_as_springs_tied_by_equations() {
        use crate::fem::family::Family;
        // The strap: two layers (PLA strips, fabric sheet), hanging from its clamp.
        let mut strap = ActuatorConfig::for_family(Family::Strap);
        strap.mesh.size_mm = 4.0;
        strap.load.pressures_kpa = "5".into();
        let mesh = build_mesh(&strap).unwrap();
        let (text, summary) = inp_from_config(&strap).unwrap();
        // The fabric as membranes, the PLA strips (plates) as shells.
        assert!(mesh.model.membranes.len() > 50);
        let count = |name: &str| {
            let part = mesh.parts.iter().find(|p| p.name == name).unwrap();
            part.membranes.len()
        };
        assert!(count("pla") > 10 && count("fabric") > 10);
        assert_eq!(summary.membranes, count("fabric"));
        assert_eq!(summary.shells, count("pla"));
        assert_eq!(
            summary.membranes + summary.shells,
            mesh.model.membranes.len()
        );
        assert_eq!(text.matches("*ELEMENT, TYPE=M3D4, ELSET=FABRIC").count(), 1);
        assert_eq!(text.matches("*ELEMENT, TYPE=S4, ELSET=PLA").count(), 1);
        assert_eq!(text.matches("*MEMBRANE SECTION").count(), 1);
        assert!(text.contains("*MEMBRANE SECTION, ELSET=FABRIC, MATERIAL=FABRIC\n1.000000000e-1"));
        assert!(text.contains("*SHELL SECTION, ELSET=PLA, MATERIAL=PLA\n1.000000000e0"));
        assert!(text.contains("EALL, GRAV, 9806.650000, 1.000000000, 0.000000000, 0.000000000"));
        assert!(text.contains("*NSET, NSET=SYMMETRY") && summary.springs == 0);

        // The tube, wound one way, its thread a line of cables: the whole section (wound both ways
        // it is a half model, as the actuator above).
        let mut tube = ActuatorConfig::for_family(Family::FibreReinforced);
        tube.tube.as_mut().unwrap().winding = crate::fem::fibre::Winding::OneWay;
        tube.mesh.size_mm = 3.0;
        tube.load.pressures_kpa = "5,10".into();
        tube.load.gravity = false;
        tube.tube.as_mut().unwrap().fibre_model = crate::fem::fibre::FibreModel::Line;
        tube.tube.as_mut().unwrap().fibre_tension_only = true;
        tube.tube.as_mut().unwrap().length_mm = 40.0;
        let mesh = build_mesh(&tube).unwrap();
        let (text, summary) = inp_from_config(&tube).unwrap();
        let n = mesh.model.trusses.len();
        assert!(n > 100, "{n}");
        assert_eq!(summary.springs, n);
        assert_eq!(text.matches("*SPRING, ELSET=F").count(), n);
        assert_eq!(text.matches(", NONLINEAR").count(), n);
        // One node per thread point: consecutive segments share theirs (so do the two
        // hands where they cross on a segment end: the same point of the same host), at
        // most one more point than segments per thread; three equations each.
        let distinct: std::collections::BTreeSet<[i64; 3]> = mesh
            .model
            .trusses
            .iter()
            .flat_map(|t| t.ends.map(|p| p.position(|a| mesh.model.nodes[a])))
            .map(|x| [x.x, x.y, x.z].map(|v| (v * 1e7).round() as i64))
            .collect();
        let points = summary.nodes - mesh.model.nodes.len();
        assert_eq!(points, distinct.len());
        assert!(
            points <= n + 2 && points > n * 9 / 10,
            "{points} points, {n} segments"
        );
        assert_eq!(summary.equations, 3 * points);
        assert!(!text.contains("NSET=SYMMETRY"));
        assert!(text.contains("*SOLID SECTION, ELSET=OUTER, MATERIAL=OUTER"));
        assert_eq!(text.matches("*DENSITY").count(), 2);
        // Every equation's weights sum to one (the host interpolation).
        let lines: Vec<&str> = text.lines().collect();
        let at = lines.iter().position(|l| *l == "*EQUATION").unwrap() + 1;
        let mut k = at;
        let mut checked = 0;
        while let Ok(terms) = lines[k].trim().parse::<usize>() {
            let rows = terms.div_ceil(4);
            let coeffs: Vec<f64> = lines[k + 1..k + 1 + rows]
                .iter()
                .flat_map(|l| l.split(", ").collect::<Vec<_>>())
                .collect::<Vec<_>>()
                .chunks(3)
                .map(|t| t[2].parse::<f64>().unwrap())
                .collect();
            assert_eq!(coeffs.len(), terms);
            assert!((coeffs.iter().sum::<f64>()).abs() < 1e-9, "{coeffs:?}");
            k += 1 + rows;
            checked += 1;
        }
        assert_eq!(checked, summary.equations);

        // Smeared, the threads are M3D4 membranes of one orthotropic material, a set,
        // an orientation (its local 1 axis the thread) and a section per direction; as
        // cables they have no CalculiX equivalent: refused, naming the key.
        let t = tube.tube.as_mut().unwrap();
        t.fibre_model = crate::fem::fibre::FibreModel::Smeared;
        let err = inp_from_config(&tube).unwrap_err().to_string();
        assert!(err.contains("tube.fibre_tension_only"), "{err}");
        tube.tube.as_mut().unwrap().fibre_tension_only = false;
        let mesh = build_mesh(&tube).unwrap();
        let (text, summary) = inp_from_config(&tube).unwrap();
        assert_eq!(summary.springs, 0);
        assert_eq!(summary.membranes, mesh.model.membranes.len());
        assert_eq!(text.matches("*ELASTIC, TYPE=ORTHO").count(), 1);
        let directions: Vec<[f64; 3]> = mesh.model.membranes.iter().fold(Vec::new(), |mut v, m| {
            let a = m.section.fibres.unwrap().direction;
            if !v.contains(&a) {
                v.push(a);
            }
            v
        });
        assert!(directions.len() > 10, "{}", directions.len());
        assert_eq!(
            text.matches("*ORIENTATION, NAME=FIBRE_").count(),
            directions.len()
        );
        let first = text.find("*ORIENTATION, NAME=FIBRE_1,").unwrap();
        let row: Vec<f64> = text[first..]
            .lines()
            .nth(1)
            .unwrap()
            .split(", ")
            .map(|v| v.parse().unwrap())
            .collect();
        let a = directions[0];
        assert!(
            (0..3).all(|d| (row[d] - a[d]).abs() < 1e-9),
            "{row:?} vs {a:?}"
        );
        assert!(text
            .contains("*MEMBRANE SECTION, ELSET=FIBRE_1, MATERIAL=FIBRE, ORIENTATION=FIBRE_1\n"));
    }

    #[test]
    fn plate_layers_go_out_as_shells_held_at_the_symmetry_plane() {
        // The glove's paper is a plate; the half model holds its rotations about x and z
        // on y = 0.
        let mut glove = coarse_glove();
        let mesh = build_mesh(&glove).unwrap();
        let (text, summary) = inp_from_config(&glove).unwrap();
        assert!(mesh.model.plates.len() > 10);
        assert_eq!(
            (summary.membranes, summary.shells),
            (0, mesh.model.membranes.len())
        );
        assert_eq!(text.matches("*ELEMENT, TYPE=S4, ELSET=PAPER").count(), 1);
        assert!(text.contains("*SHELL SECTION, ELSET=PAPER, MATERIAL=PAPER\n1.000000000e-1"));
        assert!(!text.contains("M3D4") && !text.contains("MEMBRANE SECTION"));
        assert!(text.contains("SYMMETRY_SHELL, 4, 4\nSYMMETRY_SHELL, 6, 6\n"));
        let held = node_set(&text, "SYMMETRY_SHELL");
        let sheet: std::collections::BTreeSet<usize> =
            mesh.model.membranes.iter().flat_map(|m| m.nodes).collect();
        let on_plane: Vec<usize> = sheet
            .iter()
            .copied()
            .filter(|a| mesh.model.nodes[*a].y.abs() < 1e-9 && !mesh.model.fixed[3 * a])
            .collect();
        assert!(!held.is_empty());
        assert_eq!(held, on_plane);
        // As membranes they are M3D4 again, with nothing held but translations.
        glove.layer[0].element = crate::fem::layer::LayerElement::Membrane;
        let (text, summary) = inp_from_config(&glove).unwrap();
        assert_eq!(
            (summary.membranes, summary.shells),
            (mesh.model.membranes.len(), 0)
        );
        assert!(!text.contains("S4") && !text.contains("SYMMETRY_SHELL"));
    }

    /// A node held along x or z alone (an imported mesh's symmetry.x or .z plane) is
    /// held so in the deck as along y, and a shell node there holds its rotations about
    /// the plane's two axes: 5 and 6 on an x plane, 4 and 5 on a z plane.
    #[test]
    fn every_symmetry_plane_goes_out_held_with_its_shells_rotations() {
        let glove = coarse_glove();
        let mut mesh = build_mesh(&glove).unwrap();
        let sheet: std::collections::BTreeSet<usize> =
            mesh.model.membranes.iter().flat_map(|m| m.nodes).collect();
        let free = |m: &ActuatorMesh, a: usize| (0..3).all(|d| !m.model.fixed[3 * a + d]);
        let on_x: Vec<usize> = sheet
            .iter()
            .copied()
            .filter(|&a| free(&mesh, a))
            .take(3)
            .collect();
        let on_z: Vec<usize> = (0..mesh.model.nodes.len())
            .filter(|a| !sheet.contains(a) && free(&mesh, *a))
            .take(2)
            .collect();
        for &a in &on_x {
            mesh.model.fixed[3 * a] = true;
        }
        for &a in &on_z {
            mesh.model.fixed[3 * a + 2] = true;
        }
        let (text, _) = inp_from_mesh(&mesh, &glove).unwrap();
        let set = |name: &str| node_set(&text, name);
        assert_eq!(set("SYMMETRY_X"), on_x);
        assert_eq!(set("SYMMETRY_X_SHELL"), on_x);
        assert_eq!(set("SYMMETRY_Z"), on_z);
        assert!(set("SYMMETRY_Z_SHELL").is_empty());
        assert!(text.contains("SYMMETRY_X, 1, 1\nSYMMETRY_X_SHELL, 5, 5\nSYMMETRY_X_SHELL, 6, 6\n"));
        assert!(text.contains("SYMMETRY_Z, 3, 3\n"));
        // y = 0 as before.
        assert!(text.contains("SYMMETRY, 2, 2\nSYMMETRY_SHELL, 4, 4\nSYMMETRY_SHELL, 6, 6\n"));
    }

    #[test]
    fn contact_goes_out_as_node_to_surface_pairs_both_ways() {
        use crate::fem::family::Family;
        // The glove has [contact] on: its walls paired both ways across every gap.
        let mut glove = ActuatorConfig::for_family(Family::Glove);
        glove.mesh.size_mm = 4.0;
        glove.load.pressures_kpa = "1".into();
        let mesh = build_mesh(&glove).unwrap();
        let contact = mesh.model.contact.as_ref().unwrap();
        let (text, summary) = inp_from_config(&glove).unwrap();
        let n = contact.pairs.len();
        assert!(n >= 2 && n % 2 == 0, "{n}");
        assert_eq!(summary.contact_pairs, n);
        assert_eq!(
            text.matches("*CONTACT PAIR, INTERACTION=WALLS, TYPE=NODE TO SURFACE\n")
                .count(),
            n
        );
        assert_eq!(text.matches("*SURFACE, NAME=WALL").count(), n);
        let slope = format!(
            "PRESSURE-OVERCLOSURE=LINEAR\n{:.9e}\n",
            0.5 * contact.penalty_mpa_per_mm
        );
        assert!(text.contains(&slope), "{slope}");
        // Each wall's surface lists its faces as (element, face) whose nodes are the
        // pair's master faces; a pair's slave surface is the other wall's.
        let lines: Vec<&str> = text.lines().collect();
        let index = solid_faces(&mesh);
        for (k, pair) in contact.pairs.iter().enumerate() {
            let head = format!("*SURFACE, NAME=WALL{}, TYPE=ELEMENT", k + 1);
            let at = lines.iter().position(|l| *l == head).unwrap();
            let listed: Vec<&str> = lines[at + 1..]
                .iter()
                .take_while(|l| !l.starts_with('*'))
                .copied()
                .collect();
            let expected: Vec<String> = pair
                .master_faces
                .iter()
                .map(|f| {
                    let (e, face) = index[&face_key(*f)];
                    format!("{}, S{face}", e + 1)
                })
                .collect();
            assert_eq!(listed, expected);
            let partner = if k % 2 == 0 { k + 2 } else { k };
            assert!(text.contains(&format!("NODE TO SURFACE\nWALL{partner}, WALL{}\n", k + 1)));
        }
    }
}
