//! A hexahedral actuator mesh turned into 10-node tetrahedra on the same geometry:
//! `[mesh] element = "tet10"`. Each hexahedron is cut into the six tetrahedra of the
//! Kuhn (Freudenthal) triangulation about its diagonal from local corner 0 to 6, a node
//! added at the middle of every edge; each cavity quad becomes the two 6-node triangles
//! its hexahedron's cut makes. The meshes of the shapes are structured grids whose
//! elements all share the local axes' directions, so every face's diagonal runs from
//! its lowest to its highest corner in both neighbours and the cut is conforming
//! (checked: every interior triangle is shared by exactly two tetrahedra).
//!
//! Why: the tetrahedron is checked against the hexahedra on the very geometry they
//! mesh, and a tetrahedral model goes through every downstream path (the ramp, outputs,
//! the CalculiX deck) before imported geometry does.

use std::collections::HashMap;

use nalgebra::Vector3;

use super::config::ActuatorConfig;
use super::mesh::{gravity_loads_tets, ActuatorMesh};
use super::solve::Tetrahedra;
use super::tet10::{EDGES, KUHN_AXIS_ORDERS};
use super::FemError;

/// Local hexahedron corner at parametric (i, j, k) ∈ {0, 1}³ ([`super::hex::CORNERS`]).
const fn corner(i: usize, j: usize, k: usize) -> usize {
    [[[0, 4], [3, 7]], [[1, 5], [2, 6]]][i][j][k]
}

/// The six tetrahedra of the Kuhn cut, as local hexahedron corners: the paths from
/// (0, 0, 0) to (1, 1, 1) one axis at a time.
const KUHN: [[usize; 4]; 6] = {
    const P: [[usize; 3]; 6] = KUHN_AXIS_ORDERS;
    let mut out = [[0; 4]; 6];
    let mut t = 0;
    while t < 6 {
        let mut c = [0usize; 3];
        out[t][0] = corner(0, 0, 0);
        let mut s = 0;
        while s < 3 {
            c[P[t][s]] = 1;
            out[t][s + 1] = corner(c[0], c[1], c[2]);
            s += 1;
        }
        t += 1;
    }
    out
};

/// `mesh` with its hexahedra cut into 10-node tetrahedra (the same nodes first, the
/// mid-edge nodes after them: markers and every other node index keep their meaning).
/// Refused for a model with sheets, fibres or contact, which sit on hexahedra.
pub fn into_tetrahedra(cfg: &ActuatorConfig, mesh: ActuatorMesh) -> Result<ActuatorMesh, FemError> {
    let model = &mesh.model;
    if !model.membranes.is_empty() || !model.trusses.is_empty() || model.contact.is_some() {
        return Err(FemError::Parameter {
            name: "mesh.element".into(),
            why: "\"tet10\" takes solid parts only: a layer meshed as a sheet, fibres and \
                  [contact] need the hexahedra (use \"q1p0\")"
                .into(),
        });
    }
    let mut nodes = model.nodes.clone();
    let mut fixed = model.fixed.clone();
    let mut mid: HashMap<(usize, usize), usize> = HashMap::new();
    let mut mid_node = |a: usize, b: usize, nodes: &mut Vec<Vector3<f64>>| -> usize {
        *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
            nodes.push(0.5 * (nodes[a] + nodes[b]));
            // A mid-node is held in a direction where both ends are (a clamped face,
            // a symmetry plane).
            for d in 0..3 {
                fixed.push(fixed[3 * a + d] && fixed[3 * b + d]);
            }
            nodes.len() - 1
        })
    };
    let mut elements = Vec::with_capacity(6 * model.elements.len());
    let mut material = Vec::with_capacity(6 * model.elements.len());
    for (e, hex) in model.elements.iter().enumerate() {
        for kuhn in KUHN {
            let mut c = kuhn.map(|k| hex[k]);
            let volume = |c: &[usize; 4]| {
                let [a, b, d, f] = c.map(|k| nodes[k]);
                (b - a).cross(&(d - a)).dot(&(f - a))
            };
            if volume(&c) < 0.0 {
                c.swap(1, 2);
            }
            let mut t = [0; 10];
            t[..4].copy_from_slice(&c);
            for (k, [i, j]) in EDGES.iter().enumerate() {
                t[4 + k] = mid_node(c[*i], c[*j], &mut nodes);
            }
            elements.push(t);
            material.push(model.element_material.get(e).copied().unwrap_or(0));
        }
    }
    let faces = face_map(&elements)?;
    let mut pressure_faces = Vec::with_capacity(2 * model.pressure_faces.len());
    for q in &model.pressure_faces {
        let cuts = [
            [[q[0], q[1], q[2]], [q[0], q[2], q[3]]],
            [[q[0], q[1], q[3]], [q[1], q[2], q[3]]],
        ];
        let Some(cut) = cuts
            .iter()
            .find(|cut| cut.iter().all(|tri| faces.contains_key(&sorted(*tri))))
        else {
            return Err(FemError::Model {
                why: "a cavity face is not cut as its element (mesh bug)".into(),
            });
        };
        for tri in cut {
            let m = |a: usize, b: usize| mid[&(a.min(b), a.max(b))];
            pressure_faces.push([
                tri[0],
                tri[1],
                tri[2],
                m(tri[0], tri[1]),
                m(tri[1], tri[2]),
                m(tri[2], tri[0]),
            ]);
        }
    }
    let tets = Tetrahedra {
        elements,
        material,
        pressure_faces,
        cavities: Vec::new(),
    };
    let loads = gravity_loads_tets(cfg, &nodes, &tets, &mesh.densities_g_cm3)?;
    let mut out = mesh;
    out.model.nodes = nodes;
    out.model.fixed = fixed;
    out.model.loads = loads;
    out.model.elements = Vec::new();
    out.model.pressure_faces = Vec::new();
    out.model.element_material = Vec::new();
    out.model.incompatible_modes = false;
    out.model.tets = tets;
    Ok(out)
}

fn sorted(mut t: [usize; 3]) -> [usize; 3] {
    t.sort_unstable();
    t
}

/// How many tetrahedra share each triangle (by its sorted corners); refused when one is
/// shared by more than two.
fn face_map(elements: &[[usize; 10]]) -> Result<HashMap<[usize; 3], u8>, FemError> {
    let mut faces: HashMap<[usize; 3], u8> = HashMap::with_capacity(2 * elements.len());
    for t in elements {
        for [a, b, c] in [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]] {
            let n = faces.entry(sorted([t[a], t[b], t[c]])).or_insert(0);
            *n += 1;
            if *n > 2 {
                return Err(FemError::Model {
                    why: "a triangle of the cut is shared by three tetrahedra (mesh bug)".into(),
                });
            }
        }
    }
    Ok(faces)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::actuator::build_mesh;
    use crate::fem::config::{MeshConfig, SolidElement};
    use crate::fem::hex::HexGeometry;
    use crate::fem::tet10::Tet10Geometry;

    /// The cut of the reference actuator: the tetrahedra fill the hexahedra's volume,
    /// every boundary triangle lies on a hexahedron's boundary quad (no crack inside),
    /// the cavity's enclosed volume is unchanged, and the nodes of the hexahedral mesh
    /// keep their places.
    #[test]
    fn the_cut_is_conforming_and_keeps_volumes() {
        let cfg = ActuatorConfig {
            mesh: MeshConfig {
                size_mm: 3.0,
                element: SolidElement::Q1p0,
            },
            ..Default::default()
        };
        let hexes = build_mesh(&cfg).unwrap();
        let tets = into_tetrahedra(&cfg, hexes.clone()).unwrap();
        let hex_volume: f64 = hexes
            .model
            .elements
            .iter()
            .map(|el| {
                let x = std::array::from_fn(|a| hexes.model.nodes[el[a]]);
                HexGeometry::new(&x).unwrap().volume
            })
            .sum();
        let tet_volume: f64 = tets
            .model
            .tets
            .elements
            .iter()
            .map(|el| {
                let x = std::array::from_fn(|a| tets.model.nodes[el[a]]);
                Tet10Geometry::new(&x).unwrap().volume
            })
            .sum();
        assert!(
            (tet_volume / hex_volume - 1.0).abs() < 1e-12,
            "{tet_volume} vs {hex_volume}"
        );
        // Boundary triangles: twice the boundary quads of the hexahedra.
        let faces = face_map(&tets.model.tets.elements).unwrap();
        let once = faces.values().filter(|n| **n == 1).count();
        let mut quads: HashMap<[usize; 4], u8> = HashMap::new();
        for el in &hexes.model.elements {
            for f in [
                [0, 1, 2, 3],
                [4, 5, 6, 7],
                [0, 1, 5, 4],
                [1, 2, 6, 5],
                [2, 3, 7, 6],
                [3, 0, 4, 7],
            ] {
                let mut q = f.map(|a| el[a]);
                q.sort_unstable();
                *quads.entry(q).or_insert(0) += 1;
            }
        }
        let boundary_quads = quads.values().filter(|n| **n == 1).count();
        assert_eq!(once, 2 * boundary_quads);
        assert_eq!(
            &tets.model.nodes[..hexes.model.nodes.len()],
            &hexes.model.nodes[..]
        );
        assert_eq!(
            tets.model.tets.pressure_faces.len(),
            2 * hexes.model.pressure_faces.len()
        );
        let solver = |m| crate::fem::solve::Solver::new(m).unwrap().cavity_volume();
        let (vh, vt) = (solver(&hexes.model), solver(&tets.model));
        assert!((vt / vh - 1.0).abs() < 1e-12, "cavity {vt} vs {vh}");
        // Gravity: the same total weight.
        let total = |l: &[f64]| l.iter().skip(2).step_by(3).sum::<f64>();
        let (wh, wt) = (total(&hexes.model.loads), total(&tets.model.loads));
        assert!((wt / wh - 1.0).abs() < 1e-12, "weight {wt} vs {wh}");
    }
}
