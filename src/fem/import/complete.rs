//! The parts a file leaves unnamed, found from its tetrahedra before they are assembled:
//! a file with no `cavity` group gets the closed inner boundaries of its solid as its
//! cavity; `[geometry] clamp = "x-min"` makes the solid's boundary on that face of its
//! bounding box the clamp; `[geometry.markers]` puts the markers on the solid's surface
//! nodes nearest a line's points. Each is added as a physical group of the raw mesh, so
//! the assembly's checks hold for them as for named ones.
//!
//! Written here: no meshing library finds a solid's voids on a tetrahedral mesh (gmsh
//! knows them only as CAD surfaces a user must name).

use std::collections::{BTreeSet, HashMap};

use nalgebra::Vector3;

use super::{part_of, Part, RawElement, RawGroup, RawMesh};
use crate::fem::config::{ClampPlane, MarkerLine};
use crate::fem::tet10::FACES;
use crate::fem::FemError;

/// A clamp plane's nodes lie within this fraction of the solid's size of the plane.
const PLANE_TOLERANCE: f64 = 1e-6;

/// What the config supplies for a file's unnamed parts.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Completion {
    /// The clamp of a file without a `clamp` group.
    pub clamp: Option<ClampPlane>,
    /// The markers of a file without `markers`.
    pub markers: Option<MarkerLine>,
    /// A marker is refused farther than this from the solid's surface, mm (the mesh
    /// size: a surface node lies nearer than that to any surface point).
    pub marker_reach_mm: f64,
}

fn sorted3(mut f: [usize; 3]) -> [usize; 3] {
    f.sort_unstable();
    f
}

/// The boundary of the solid: its faces held by one tetrahedron, corners turned out of
/// the solid, grouped into edge-connected surfaces; the outer one (holding the node of
/// least x) first.
fn boundary_surfaces(raw: &RawMesh) -> Vec<Vec<[usize; 3]>> {
    let tets = raw
        .groups
        .iter()
        .filter(|g| g.dim == 3)
        .flat_map(|g| &g.elements)
        .filter(|e| matches!(e.nodes.len(), 4 | 10));
    let mut count: HashMap<[usize; 3], (u32, [usize; 3])> = HashMap::new();
    let mut seen = BTreeSet::new();
    for e in tets {
        if !seen.insert(e.tag) {
            continue;
        }
        for f in FACES {
            let face = [f[0], f[1], f[2]].map(|k| e.nodes[k]);
            count.entry(sorted3(face)).or_insert((0, face)).0 += 1;
        }
    }
    let mut faces: Vec<[usize; 3]> = count
        .into_values()
        .filter(|(n, _)| *n == 1)
        .map(|(_, f)| f)
        .collect();
    faces.sort_unstable();
    // Connected through shared edges (union-find over the faces).
    let mut parent: Vec<usize> = (0..faces.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let mut by_edge: HashMap<(usize, usize), usize> = HashMap::new();
    for (i, f) in faces.iter().enumerate() {
        for (a, b) in [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])] {
            if let Some(&j) = by_edge.get(&(a.min(b), a.max(b))) {
                let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
                parent[ri] = rj;
            } else {
                by_edge.insert((a.min(b), a.max(b)), i);
            }
        }
    }
    let mut surfaces: HashMap<usize, Vec<[usize; 3]>> = HashMap::new();
    for (i, f) in faces.iter().enumerate() {
        surfaces.entry(root(&mut parent, i)).or_default().push(*f);
    }
    let mut surfaces: Vec<Vec<[usize; 3]>> = surfaces.into_values().collect();
    let least_x = |s: &Vec<[usize; 3]>| {
        s.iter()
            .flatten()
            .map(|&n| raw.nodes[n].x)
            .fold(f64::INFINITY, f64::min)
    };
    surfaces.sort_by(|a, b| least_x(a).total_cmp(&least_x(b)).then(a[0].cmp(&b[0])));
    surfaces
}

fn has_part(raw: &RawMesh, wanted: impl Fn(&Part) -> bool) -> bool {
    raw.groups
        .iter()
        .any(|g| part_of(g.dim, &g.name).is_some_and(|p| wanted(&p)))
}

fn triangles(faces: &[[usize; 3]], first_tag: u64) -> Vec<RawElement> {
    faces
        .iter()
        .zip(first_tag..)
        .map(|(f, tag)| RawElement {
            tag,
            nodes: f.to_vec(),
        })
        .collect()
}

/// Adds to `raw` the groups `completion` and the solid's shape supply: the cavity of a
/// file without one, the clamp plane, the marker line. A part named both in the file
/// and in the config is refused (which one is meant is not clear).
pub(crate) fn complete(
    file: &str,
    raw: &mut RawMesh,
    completion: &Completion,
) -> Result<(), FemError> {
    let err = |why: String| FemError::Input {
        why: format!("{file}: {why}"),
    };
    let has_cavity = has_part(raw, |p| matches!(p, Part::Cavity(_)));
    let has_clamp = has_part(raw, |p| {
        *p == Part::Clamp || *p == Part::Material("clamp".into())
    });
    let has_markers = has_part(raw, |p| *p == Part::Markers);
    if has_cavity && completion.clamp.is_none() && completion.markers.is_none() {
        return Ok(());
    }
    if !raw.groups.iter().any(|g| g.dim == 3) {
        // The assembly says what is missing.
        return Ok(());
    }
    let surfaces = boundary_surfaces(raw);
    let Some(outer) = surfaces.first() else {
        return Ok(());
    };
    // Synthetic elements are numbered past the file's own.
    let mut next_tag = raw
        .groups
        .iter()
        .flat_map(|g| &g.elements)
        .map(|e| e.tag)
        .max()
        .unwrap_or(0)
        + 1;

    if !has_cavity {
        let inner: Vec<[usize; 3]> = surfaces[1..].iter().flatten().copied().collect();
        if inner.is_empty() {
            return Err(err(
                "no cavity: no `cavity` group, and the solid has no closed inner surface: name the cavity's surfaces `cavity` (gmsh: Physical Surface(\"cavity\") = {...}), or close its inlet in the CAD so that the cavity is a void".into(),
            ));
        }
        // The faces turn out of the solid, into the cavity, as a tetrahedron's face
        // into the cavity does: the assembly orients them.
        raw.groups.push(RawGroup {
            dim: 2,
            name: "cavity".into(),
            elements: triangles(&inner, next_tag),
        });
        next_tag += inner.len() as u64;
    }

    let (lo, hi) = outer.iter().flatten().fold(
        (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), &n| (lo.inf(&raw.nodes[n]), hi.sup(&raw.nodes[n])),
    );
    let size = (hi - lo).norm();

    if let Some(plane) = completion.clamp {
        if has_clamp {
            return Err(err(format!(
                "the file names a `clamp` and [geometry] clamp = \"{}\" names another: remove one",
                plane.name()
            )));
        }
        let at = if plane.max { hi } else { lo }[plane.axis];
        let on = |n: usize| (raw.nodes[n][plane.axis] - at).abs() <= PLANE_TOLERANCE * size;
        let faces: Vec<[usize; 3]> = outer
            .iter()
            .filter(|f| f.iter().all(|&n| on(n)))
            .copied()
            .collect();
        if faces.is_empty() {
            return Err(err(format!(
                "[geometry] clamp = \"{}\": the solid has no flat face on its {} side: clamp a flat face, or name the clamp's surfaces `clamp` in the file",
                plane.name(),
                plane.name()
            )));
        }
        raw.groups.push(RawGroup {
            dim: 2,
            name: "clamp".into(),
            elements: triangles(&faces, next_tag),
        });
        next_tag += faces.len() as u64;
    }

    if let Some(line) = &completion.markers {
        if has_markers {
            return Err(err(
                "the file names `markers` and [geometry.markers] puts others: remove one".into(),
            ));
        }
        let surface: BTreeSet<usize> = outer.iter().flatten().copied().collect();
        let mut chosen = Vec::new();
        for (k, p) in line.points().iter().enumerate() {
            let p = Vector3::from(*p);
            let (node, d) = surface
                .iter()
                .map(|&n| (n, (raw.nodes[n] - p).norm()))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap_or((0, f64::INFINITY));
            if d > completion.marker_reach_mm {
                return Err(err(format!(
                    "[geometry.markers]: marker {} at ({:.3}, {:.3}, {:.3}) is {d:.2} mm from the solid's surface, more than the mesh size {} mm: put the line on a face of the actuator",
                    k + 1,
                    p.x,
                    p.y,
                    p.z,
                    completion.marker_reach_mm
                )));
            }
            if chosen.contains(&node) {
                return Err(err(format!(
                    "[geometry.markers]: markers {} and {} fall on the same mesh node: use fewer markers or a finer mesh",
                    k,
                    k + 1
                )));
            }
            chosen.push(node);
        }
        raw.groups.push(RawGroup {
            dim: 0,
            name: "markers".into(),
            elements: chosen
                .iter()
                .zip(next_tag..)
                .map(|(&n, tag)| RawElement {
                    tag,
                    nodes: vec![n],
                })
                .collect(),
        });
    }
    Ok(())
}
