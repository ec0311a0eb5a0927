//! From a mesh file's elements, grouped by physical name, to the checked
//! [`ImportedMesh`]: tetrahedra upgraded to 10 nodes, faces and lines given the
//! tetrahedra's mid-nodes, cavity faces turned out of the cavity, and the checks.

use std::collections::{BTreeMap, BTreeSet, HashMap};

use nalgebra::Vector3;

use super::{dim_word, known_names, part_of, ImportedMesh, Part};
use crate::fem::tet10::{Tet10Geometry, EDGES, FACES};
use crate::fem::FemError;

/// A tetrahedron whose volume is at most this fraction of the mean is refused as flat.
const FLAT_FRACTION: f64 = 1e-6;
/// A symmetry plane's nodes lie within this fraction of the model's size of one plane.
const PLANE_TOLERANCE: f64 = 1e-6;

/// A mesh file's content, format aside.
#[derive(Debug, Clone, Default)]
pub(crate) struct RawMesh {
    /// Every node of the file.
    pub nodes: Vec<Vector3<f64>>,
    /// The file's tag of each node (for messages).
    pub node_tags: Vec<u64>,
    /// The physical groups with their elements.
    pub groups: Vec<RawGroup>,
    /// Tetrahedra of the file in no physical group (for the message when there is no
    /// named volume).
    pub unnamed_tets: usize,
}

/// The elements of one physical group.
#[derive(Debug, Clone)]
pub(crate) struct RawGroup {
    /// 0 points, 1 curves, 2 surfaces, 3 volumes.
    pub dim: usize,
    /// The group's name.
    pub name: String,
    /// Its elements.
    pub elements: Vec<RawElement>,
}

/// One element: its file tag and its nodes (indices into [`RawMesh::nodes`]): 4 or 10
/// for a tetrahedron (10 in C3D10 order), 3 or 6 for a triangle, 2 or 3 for a line
/// (ends, then the mid-node), 1 for a point.
#[derive(Debug, Clone)]
pub(crate) struct RawElement {
    /// The element's tag in the file.
    pub tag: u64,
    /// Its nodes.
    pub nodes: Vec<usize>,
}

fn sorted2(a: usize, b: usize) -> (usize, usize) {
    (a.min(b), a.max(b))
}

fn sorted3(mut f: [usize; 3]) -> [usize; 3] {
    f.sort_unstable();
    f
}

/// The index of `name` in a list of named parts, added if new.
fn entry<T>(list: &mut Vec<(String, Vec<T>)>, name: &str) -> usize {
    match list.iter().position(|(n, _)| n == name) {
        Some(k) => k,
        None => {
            list.push((name.to_string(), Vec::new()));
            list.len() - 1
        }
    }
}

fn fmt_point(x: &Vector3<f64>) -> String {
    format!("({:.3}, {:.3}, {:.3})", x.x, x.y, x.z)
}

/// Builds the checked mesh from a file's groups; `file` names the file in messages.
pub(crate) fn assemble(file: &str, raw: &RawMesh) -> Result<ImportedMesh, FemError> {
    let err = |why: String| FemError::Input {
        why: format!("{file}: {why}"),
    };
    let mut parts = Vec::with_capacity(raw.groups.len());
    for g in &raw.groups {
        let part = part_of(g.dim, &g.name).ok_or_else(|| {
            err(format!(
                "physical {} `{}` has an unknown name: name it {}",
                dim_word(g.dim).to_lowercase(),
                g.name,
                known_names(g.dim)
            ))
        })?;
        parts.push((part, g));
    }

    // Tetrahedra and their materials.
    let mut materials: Vec<String> = Vec::new();
    let mut material_of_tag: HashMap<u64, usize> = HashMap::new();
    let mut raw_tets: Vec<(u64, &[usize], usize)> = Vec::new();
    for (part, g) in &parts {
        let Part::Material(name) = part else { continue };
        let m = match materials.iter().position(|n| n == name) {
            Some(m) => m,
            None => {
                materials.push(name.clone());
                materials.len() - 1
            }
        };
        for e in &g.elements {
            match material_of_tag.insert(e.tag, m) {
                Some(other) if other != m => {
                    return Err(err(format!(
                    "element {} is in two physical volumes, `{}` and `{}`: put each volume in one",
                    e.tag, materials[other], materials[m]
                )))
                }
                Some(_) => continue,
                None => raw_tets.push((e.tag, &e.nodes, m)),
            }
        }
    }
    if raw_tets.is_empty() {
        return Err(err(if raw.unnamed_tets > 0 {
            "the tetrahedra are in no physical volume: name the material's volumes (gmsh: Physical Volume(\"silicone\") = {...})".into()
        } else {
            "no volume elements (tetrahedra): mesh the model in 3D (gmsh -3)".into()
        }));
    }
    if !parts.iter().any(|(p, _)| matches!(p, Part::Cavity(_))) {
        return Err(err("no physical surface named `cavity`: name the cavity's inner surfaces `cavity` (gmsh: Physical Surface(\"cavity\") = {...})".into()));
    }
    let clamp_volume = materials.iter().position(|m| m == "clamp");
    if clamp_volume.is_none() && !parts.iter().any(|(p, _)| *p == Part::Clamp) {
        return Err(err("no physical surface or volume named `clamp`: name the clamped surfaces `clamp` (gmsh: Physical Surface(\"clamp\") = {...}), or clamp a flat face of the solid with [geometry] clamp = \"x-min\"".into()));
    }

    // Nodes of the tetrahedra, in file order; then mid-edge nodes for 4-node ones.
    let mut new_of = vec![usize::MAX; raw.nodes.len()];
    for (_, n, _) in &raw_tets {
        for &a in n.iter() {
            new_of[a] = 0;
        }
    }
    let mut nodes = Vec::new();
    for (a, slot) in new_of.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = nodes.len();
            nodes.push(raw.nodes[a]);
        }
    }
    let mut edge_mid: HashMap<(usize, usize), (usize, u64)> = HashMap::new();
    for (tag, n, _) in raw_tets.iter().filter(|(_, n, _)| n.len() == 10) {
        for (k, &[i, j]) in EDGES.iter().enumerate() {
            let key = sorted2(new_of[n[i]], new_of[n[j]]);
            let mid = new_of[n[4 + k]];
            let (known, other) = *edge_mid.entry(key).or_insert((mid, *tag));
            if known != mid {
                return Err(err(format!(
                    "elements {other} and {tag} have different mid-nodes on their common edge {} - {}: the mesh is not conforming (remesh it in one run)",
                    fmt_point(&nodes[key.0]),
                    fmt_point(&nodes[key.1])
                )));
            }
        }
    }
    let mut tets = Vec::with_capacity(raw_tets.len());
    for (tag, n, _) in &raw_tets {
        let mut t = [0; 10];
        for c in 0..4 {
            t[c] = new_of[n[c]];
        }
        for (k, &[i, j]) in EDGES.iter().enumerate() {
            t[4 + k] = if n.len() == 10 {
                new_of[n[4 + k]]
            } else {
                let key = sorted2(t[i], t[j]);
                let next = nodes.len();
                let (mid, _) = *edge_mid.entry(key).or_insert((next, *tag));
                if mid == next {
                    nodes.push(0.5 * (nodes[t[i]] + nodes[t[j]]));
                }
                mid
            };
        }
        tets.push(t);
    }
    let tet_material: Vec<usize> = raw_tets.iter().map(|(_, _, m)| *m).collect();

    // Orientation, flatness and the Jacobian of curved elements.
    let corner_volume = |t: &[usize; 10]| {
        let [a, b, c, d] = [t[0], t[1], t[2], t[3]].map(|i| nodes[i]);
        (b - a).dot(&(c - a).cross(&(d - a))) / 6.0
    };
    let mean = tets.iter().map(|t| corner_volume(t).abs()).sum::<f64>() / tets.len() as f64;
    for (t, (tag, _, _)) in tets.iter().zip(&raw_tets) {
        let v = corner_volume(t);
        if v < 0.0 && v.abs() > FLAT_FRACTION * mean {
            return Err(err(format!(
                "element {tag} is inverted (volume {v:.3e} mm³): its corners must turn counter-clockwise seen from the 4th; remesh it"
            )));
        }
        // Also catches NaN coordinates.
        if v.partial_cmp(&(FLAT_FRACTION * mean)) != Some(std::cmp::Ordering::Greater) {
            return Err(err(format!(
                "element {tag} is flat (volume {v:.3e} mm³, mean {mean:.3e} mm³): remesh with better quality (gmsh: -optimize_netgen)"
            )));
        }
        if Tet10Geometry::new(&t.map(|i| nodes[i])).is_none() {
            return Err(err(format!(
                "element {tag} is folded by its mid-nodes (its Jacobian is not positive inside): remesh finer where the boundary is curved"
            )));
        }
    }

    // Faces of the tetrahedra: how many tetrahedra hold each, and one of them.
    let mut faces: HashMap<[usize; 3], (u8, usize, usize)> = HashMap::with_capacity(4 * tets.len());
    for (e, t) in tets.iter().enumerate() {
        for (f, face) in FACES.iter().enumerate() {
            let key = sorted3([t[face[0]], t[face[1]], t[face[2]]]);
            faces.entry(key).or_insert((0, e, f)).0 += 1;
        }
    }

    let node_of = |group: &str, e: &RawElement, a: usize| -> Result<usize, FemError> {
        match new_of[a] {
            usize::MAX => Err(err(format!(
                "`{group}`: element {} has node {} at {}, which is no node of the tetrahedra: mesh the surfaces, curves and points with the volume, in one run (points: Point{{...}} In Surface{{...}})",
                e.tag,
                raw.node_tags[a],
                fmt_point(&raw.nodes[a])
            ))),
            n => Ok(n),
        }
    };
    // The mid-node of edge a-b; a file's own mid-node must be the tetrahedra's.
    let mid_of = |group: &str, e: &RawElement, a: usize, b: usize, given: Option<usize>| {
        let mid = edge_mid.get(&sorted2(a, b)).map(|m| m.0).ok_or_else(|| {
            err(format!(
                "`{group}`: element {} runs along {} - {}, which is no edge of the tetrahedra: mesh it with the volume, in one run",
                e.tag,
                fmt_point(&nodes[a]),
                fmt_point(&nodes[b])
            ))
        })?;
        match given {
            Some(g) if node_of(group, e, g)? != mid => Err(err(format!(
                "`{group}`: element {}'s mid-node differs from the tetrahedra's on the edge {} - {}: the mesh is not conforming",
                e.tag,
                fmt_point(&nodes[a]),
                fmt_point(&nodes[b])
            ))),
            _ => Ok(mid),
        }
    };
    let tri6 = |group: &str, e: &RawElement| -> Result<[usize; 6], FemError> {
        if !matches!(e.nodes.len(), 3 | 6) {
            return Err(err(format!(
                "`{group}`: element {} is not a triangle: mesh surfaces with triangles",
                e.tag
            )));
        }
        let c = [0, 1, 2].map(|k| e.nodes[k]);
        let c = [
            node_of(group, e, c[0])?,
            node_of(group, e, c[1])?,
            node_of(group, e, c[2])?,
        ];
        let given = |k: usize| (e.nodes.len() == 6).then(|| e.nodes[3 + k]);
        Ok([
            c[0],
            c[1],
            c[2],
            mid_of(group, e, c[0], c[1], given(0))?,
            mid_of(group, e, c[1], c[2], given(1))?,
            mid_of(group, e, c[2], c[0], given(2))?,
        ])
    };

    let mut cavities: Vec<(String, Vec<[usize; 6]>)> = Vec::new();
    let mut clamp = BTreeSet::new();
    let mut symmetry: BTreeMap<usize, BTreeSet<usize>> = BTreeMap::new();
    let mut layers: Vec<(String, Vec<[usize; 6]>)> = Vec::new();
    let mut threads: Vec<(String, Vec<[usize; 3]>)> = Vec::new();
    let mut markers = BTreeSet::new();
    let mut tip = None;
    if let Some(k) = clamp_volume {
        for (t, m) in tets.iter().zip(&tet_material) {
            if *m == k {
                clamp.extend(t.iter().copied());
            }
        }
    }
    for (part, g) in &parts {
        let name = g.name.as_str();
        match part {
            Part::Material(_) => {}
            Part::Cavity(_) => {
                let k = entry(&mut cavities, name);
                let mut seen = BTreeSet::new();
                for e in &g.elements {
                    let f = tri6(name, e)?;
                    let key = sorted3([f[0], f[1], f[2]]);
                    if !seen.insert(key) {
                        continue;
                    }
                    let (count, t, lf) = *faces.get(&key).ok_or_else(|| {
                        err(format!(
                            "cavity `{name}`: element {} is no face of the tetrahedra: the surface mesh does not match the volume mesh (mesh them in one run)",
                            e.tag
                        ))
                    })?;
                    if count != 1 {
                        return Err(err(format!(
                            "cavity `{name}`: element {} has tetrahedra on both sides: the cavity must be empty (subtract it from the volume: BooleanDifference)",
                            e.tag
                        )));
                    }
                    // The tetrahedron's face turns out of it, into the cavity: reversed,
                    // it turns out of the cavity, into the wall.
                    let [a, b, c, ab, bc, ca] = FACES[lf].map(|i| tets[t][i]);
                    cavities[k].1.push([a, c, b, ca, bc, ab]);
                }
            }
            Part::Clamp | Part::Symmetry(_) => {
                let set = match part {
                    Part::Symmetry(axis) => symmetry.entry(*axis).or_default(),
                    _ => &mut clamp,
                };
                for e in &g.elements {
                    set.extend(tri6(name, e)?);
                }
            }
            Part::Layer(sheet) => {
                let k = entry(&mut layers, sheet);
                // A triangle listed twice (two surfaces of one group) is one sheet.
                let mut seen = BTreeSet::new();
                for e in &g.elements {
                    let f = tri6(name, e)?;
                    if seen.insert(sorted3([f[0], f[1], f[2]])) {
                        layers[k].1.push(f);
                    }
                }
            }
            Part::Thread(fibre) => {
                let k = entry(&mut threads, fibre);
                for e in &g.elements {
                    if !matches!(e.nodes.len(), 2 | 3) {
                        return Err(err(format!(
                            "`{name}`: element {} is not a line: mesh curves with lines",
                            e.tag
                        )));
                    }
                    let (a, b) = (node_of(name, e, e.nodes[0])?, node_of(name, e, e.nodes[1])?);
                    let given = e.nodes.get(2).copied();
                    threads[k].1.push([a, b, mid_of(name, e, a, b, given)?]);
                }
            }
            Part::Tip => {
                let mut nodes = Vec::new();
                for e in &g.elements {
                    for &a in &e.nodes {
                        nodes.push(node_of(name, e, a)?);
                    }
                }
                nodes.dedup();
                match nodes[..] {
                    [one] => tip = Some(one),
                    _ => {
                        return Err(err(format!(
                            "`tip` has {} points: name one point `tip`",
                            nodes.len()
                        )))
                    }
                }
            }
            Part::Markers => {
                for e in &g.elements {
                    for &a in &e.nodes {
                        markers.insert(node_of(name, e, a)?);
                    }
                }
            }
        }
    }

    // Symmetry planes are planes.
    let (lo, hi) = nodes.iter().fold(
        (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), x| (lo.inf(x), hi.sup(x)),
    );
    let size = (hi - lo).norm();
    for (&axis, set) in &symmetry {
        let (min, max) = set
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &n| {
                (a.min(nodes[n][axis]), b.max(nodes[n][axis]))
            });
        if max - min > PLANE_TOLERANCE * size {
            let xyz = ["x", "y", "z"][axis];
            return Err(err(format!(
                "`symmetry.{xyz}` is not a plane {xyz} = const: its nodes' {xyz} runs from {min:.4} to {max:.4} mm: put only the symmetry plane's surfaces in it"
            )));
        }
    }

    // Each cavity is closed: every edge of its surface borders two of its faces, or
    // one where it lies on a symmetry plane.
    let on_plane = |n: usize| symmetry.values().any(|s| s.contains(&n));
    for (name, fs) in &cavities {
        let mut edges: BTreeMap<(usize, usize), usize> = BTreeMap::new();
        for f in fs {
            for (a, b) in [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])] {
                *edges.entry(sorted2(a, b)).or_default() += 1;
            }
        }
        let open = edges
            .iter()
            .find(|(&(a, b), &n)| n != 2 && !(n == 1 && on_plane(a) && on_plane(b)));
        if let Some((&(a, b), &n)) = open {
            return Err(err(format!(
                "cavity `{name}` is open: its edge {} - {} borders {n} of its faces, not 2: put every inner surface of the cavity in `{name}`",
                fmt_point(&nodes[a]),
                fmt_point(&nodes[b])
            )));
        }
    }

    // Markers from the clamp outward.
    let centroid = clamp.iter().map(|&n| nodes[n]).sum::<Vector3<f64>>() / clamp.len() as f64;
    let mut markers: Vec<usize> = markers.into_iter().collect();
    markers.sort_by(|&a, &b| {
        let (da, db) = ((nodes[a] - centroid).norm(), (nodes[b] - centroid).norm());
        da.total_cmp(&db).then(a.cmp(&b))
    });

    Ok(ImportedMesh {
        nodes,
        tets,
        tet_material,
        materials,
        cavities,
        clamp: clamp.into_iter().collect(),
        symmetry: symmetry
            .into_iter()
            .map(|(axis, s)| (axis, s.into_iter().collect()))
            .collect(),
        layers,
        threads,
        markers,
        tip,
    })
}
