//! Reading the fixtures (fixtures/mesh) and small meshes written here, and the
//! refusals; [`meshing`]: meshing CAD with gmsh.

mod meshing;

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::*;
use crate::fem::pressure_tri6::{face_volume, CLOSED};
use crate::fem::tet10::{Tet10Geometry, EDGES};
use crate::fem::FemError;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/mesh")
        .join(name)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

fn mesh_volume(m: &ImportedMesh) -> f64 {
    m.tets
        .iter()
        .map(|t| Tet10Geometry::new(&t.map(|i| m.nodes[i])).unwrap().volume)
        .sum()
}

/// The volume enclosed by a cavity's faces, with weights `w` (see pressure_tri6).
fn cavity_volume(m: &ImportedMesh, faces: &[[usize; 6]], w: &Vector3<f64>) -> f64 {
    faces
        .iter()
        .map(|f| face_volume(&f.map(|i| m.nodes[i]), w).0)
        .sum()
}

/// Every mid-node of every tetrahedron at its edge's midpoint (straight-edged meshes).
fn worst_mid_node_offset(m: &ImportedMesh) -> f64 {
    let mut worst: f64 = 0.0;
    for t in &m.tets {
        for (k, &[i, j]) in EDGES.iter().enumerate() {
            let mid = 0.5 * (m.nodes[t[i]] + m.nodes[t[j]]);
            worst = worst.max((m.nodes[t[4 + k]] - mid).norm());
        }
    }
    worst
}

/// The block of fixtures/mesh/block.geo: 30 x 10 x 8 mm less the 20 x 4 x 4 mm cavity
/// at (5, 3, 2), clamped at x = 0, markers at x = 6, 12, 18, 24 on y = 0, z = 4.
fn check_block(m: &ImportedMesh) {
    assert_eq!(m.materials, ["silicone"]);
    assert!(m.tet_material.iter().all(|&k| k == 0));
    let v = mesh_volume(m);
    assert!(
        rel(v, 30.0 * 10.0 * 8.0 - 20.0 * 4.0 * 4.0) < 1e-9,
        "volume {v}"
    );
    assert_eq!(m.cavities.len(), 1);
    assert_eq!(m.cavities[0].0, "cavity");
    let faces = &m.cavities[0].1;
    let c = cavity_volume(m, faces, &CLOSED);
    assert!(rel(c, 20.0 * 4.0 * 4.0) < 1e-9, "cavity volume {c}");
    // Each face turns out of the cavity: away from its centre.
    let centre = Vector3::new(15.0, 5.0, 4.0);
    for f in faces {
        let x = f.map(|i| m.nodes[i]);
        let n = (x[1] - x[0]).cross(&(x[2] - x[0]));
        let mid = (x[0] + x[1] + x[2]) / 3.0;
        assert!(
            n.dot(&(mid - centre)) > 0.0,
            "face {f:?} turns into the cavity"
        );
    }
    assert!(worst_mid_node_offset(m) < 1e-12);
    assert!(!m.clamp.is_empty() && m.clamp.iter().all(|&n| m.nodes[n].x.abs() < 1e-12));
    let at: Vec<[f64; 3]> = m.markers.iter().map(|&n| m.nodes[n].into()).collect();
    assert_eq!(
        at,
        [
            [6.0, 0.0, 4.0],
            [12.0, 0.0, 4.0],
            [18.0, 0.0, 4.0],
            [24.0, 0.0, 4.0]
        ]
    );
    assert!(m.symmetry.is_empty() && m.layers.is_empty() && m.threads.is_empty());
}

#[test]
fn reads_the_ascii_fixture() {
    let m = msh::read(&fixture("block.msh")).unwrap();
    check_block(&m);
    // gmsh's count: 1722 nodes, 871 10-node tetrahedra.
    assert_eq!((m.nodes.len(), m.tets.len()), (1722, 871));
}

#[test]
fn binary_and_ascii_fixtures_are_the_same_mesh() {
    let a = msh::read(&fixture("block.msh")).unwrap();
    let b = msh::read(&fixture("block-binary.msh")).unwrap();
    check_block(&b);
    // ASCII writes 16 significant digits.
    let worst = a
        .nodes
        .iter()
        .zip(&b.nodes)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    assert!(worst < 1e-12, "node positions differ by {worst}");
    assert_eq!(a.nodes.len(), b.nodes.len());
    assert_eq!(
        (&a.tets, &a.cavities, &a.clamp, &a.markers),
        (&b.tets, &b.cavities, &b.clamp, &b.markers)
    );
}

/// gmsh's 10-node tetrahedron lists edge 23's mid-node before edge 13's: read raw, its
/// node 8 is at the midpoint of corners 2 and 3, node 9 of 1 and 3.
#[test]
fn gmsh_mid_node_order_is_checked_by_geometry() {
    let bytes = std::fs::read(fixture("block.msh")).unwrap();
    let raw = msh::parse("block.msh", &bytes).unwrap();
    let tets = &raw.groups.iter().find(|g| g.dim == 3).unwrap().elements;
    let mut worst = [0.0f64; 2];
    for e in tets {
        // Back to gmsh's order, then its two last mid-nodes against edges 23 and 13.
        let mut g = [0; 10];
        for (k, &p) in msh::GMSH_TET10.iter().enumerate() {
            g[p] = e.nodes[k];
        }
        let x = |a: usize| raw.nodes[g[a]];
        worst[0] = worst[0].max((x(8) - 0.5 * (x(2) + x(3))).norm());
        worst[1] = worst[1].max((x(9) - 0.5 * (x(1) + x(3))).norm());
    }
    assert!(worst[0] < 1e-12 && worst[1] < 1e-12, "{worst:?}");
}

// ---- Small meshes written here -----------------------------------------------------

/// An element block: (dim, entity tag, physical tags, gmsh element type, elements as
/// node indices).
type Block = (i32, i32, Vec<i32>, u8, Vec<Vec<usize>>);

/// A MSH 4.1 ASCII file made of element blocks, one entity each.
#[derive(Clone, Default)]
struct Msh {
    nodes: Vec<Vector3<f64>>,
    blocks: Vec<Block>,
    names: Vec<(i32, i32, String)>,
}

impl Msh {
    fn text(&self) -> String {
        let mut s = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
        s += &format!("$PhysicalNames\n{}\n", self.names.len());
        for (d, t, n) in &self.names {
            s += &format!("{d} {t} \"{n}\"\n");
        }
        s += "$EndPhysicalNames\n";
        let mut entities: BTreeMap<(i32, i32), Vec<i32>> = BTreeMap::new();
        entities.insert((3, 1000), vec![]);
        for (d, e, p, _, _) in &self.blocks {
            entities.insert((*d, *e), p.clone());
        }
        let count = |d: i32| entities.keys().filter(|k| k.0 == d).count();
        s += &format!(
            "$Entities\n{} {} {} {}\n",
            count(0),
            count(1),
            count(2),
            count(3)
        );
        for ((d, e), p) in &entities {
            let phys: String = p.iter().map(|t| format!(" {t}")).collect();
            if *d == 0 {
                s += &format!("{e} 0 0 0 {}{phys}\n", p.len());
            } else {
                s += &format!("{e} 0 0 0 1 1 1 {}{phys} 0\n", p.len());
            }
        }
        s += "$EndEntities\n";
        let n = self.nodes.len();
        s += &format!("$Nodes\n1 {n} 1 {n}\n3 1000 0 {n}\n");
        for k in 1..=n {
            s += &format!("{k}\n");
        }
        for x in &self.nodes {
            s += &format!("{:?} {:?} {:?}\n", x.x, x.y, x.z);
        }
        s += "$EndNodes\n";
        let total: usize = self.blocks.iter().map(|b| b.4.len()).sum();
        s += &format!("$Elements\n{} {total} 1 {total}\n", self.blocks.len());
        let mut tag = 0;
        for (d, e, _, ty, els) in &self.blocks {
            s += &format!("{d} {e} {ty} {}\n", els.len());
            for el in els {
                tag += 1;
                let nodes: String = el.iter().map(|a| format!(" {}", a + 1)).collect();
                s += &format!("{tag}{nodes}\n");
            }
        }
        s + "$EndElements\n"
    }

    fn block_mut(&mut self, name: &str) -> &mut Vec<Vec<usize>> {
        let (_, tag, _) = self.names.iter().find(|n| n.2 == name).unwrap().clone();
        let b = self.blocks.iter_mut().find(|b| b.2.contains(&tag)).unwrap();
        &mut b.4
    }

    fn without(mut self, name: &str) -> Self {
        let (_, tag, _) = self.names.iter().find(|n| n.2 == name).unwrap().clone();
        self.blocks.retain(|b| !b.2.contains(&tag));
        self
    }

    fn renamed(mut self, from: &str, to: &str) -> Self {
        self.names.iter_mut().find(|n| n.2 == from).unwrap().2 = to.into();
        self
    }
}

/// A 3 x 3 x 3 mm cube of 1 mm cells, each split into the 6 tetrahedra of Kuhn, less
/// the cell at `hole` (the cavity); clamp at x = 0; markers at x = 3, 1, 2 on
/// y = 0, z = 0 (listed out of order). With `quadratic`, 10-node tetrahedra and
/// 6-node triangles in gmsh's node order. With the hole on y = 0, the face y = 0 is
/// `symmetry.y` (a half model whose cavity is open on its plane).
fn cube(hole: [usize; 3], quadratic: bool) -> Msh {
    let id = |i: usize, j: usize, k: usize| (k * 4 + j) * 4 + i;
    let mut nodes: Vec<Vector3<f64>> = (0..64)
        .map(|a| Vector3::new((a % 4) as f64, ((a / 4) % 4) as f64, (a / 16) as f64))
        .collect();
    let mut tets = Vec::new();
    for (i, j, k) in (0..27).map(|c| (c % 3, (c / 3) % 3, c / 9)) {
        if [i, j, k] == hole {
            continue;
        }
        for p in crate::fem::tet10::KUHN_AXIS_ORDERS {
            let mut c = [i, j, k];
            let mut t = vec![id(c[0], c[1], c[2])];
            for axis in p {
                c[axis] += 1;
                t.push(id(c[0], c[1], c[2]));
            }
            let x = |a: usize| nodes[t[a]];
            if (x(1) - x(0)).dot(&(x(2) - x(0)).cross(&(x(3) - x(0)))) < 0.0 {
                t.swap(2, 3);
            }
            tets.push(t);
        }
    }
    // Boundary faces (counter-clockwise seen from outside the solid).
    let mut faces: HashMap<[usize; 3], (usize, [usize; 3])> = HashMap::new();
    for t in &tets {
        for f in [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]] {
            let tri = f.map(|a| t[a]);
            let mut key = tri;
            key.sort_unstable();
            faces.entry(key).or_insert((0, tri)).0 += 1;
        }
    }
    let mut boundary: Vec<[usize; 3]> = faces.values().filter(|v| v.0 == 1).map(|v| v.1).collect();
    boundary.sort_unstable();
    let on = |f: &[usize; 3], axis: usize, v: f64| f.iter().all(|&a| nodes[a][axis] == v);
    let lo = hole.map(|h| h as f64);
    let in_hole = |f: &[usize; 3]| {
        f.iter()
            .all(|&a| (0..3).all(|d| nodes[a][d] >= lo[d] && nodes[a][d] <= lo[d] + 1.0))
    };
    let half = hole[1] == 0;
    let cavity: Vec<_> = boundary
        .iter()
        .filter(|f| in_hole(f) && !(half && on(f, 1, 0.0)))
        .copied()
        .collect();
    let clamp: Vec<_> = boundary.iter().filter(|f| on(f, 0, 0.0)).copied().collect();
    let plane: Vec<_> = boundary.iter().filter(|f| on(f, 1, 0.0)).copied().collect();

    let (mut tets, mut tris): (Vec<Vec<usize>>, Vec<Vec<Vec<usize>>>) = (
        tets,
        [cavity, clamp, plane]
            .iter()
            .map(|fs| fs.iter().map(|f| f.to_vec()).collect())
            .collect(),
    );
    let (tet_type, tri_type) = if quadratic {
        let mut mid: HashMap<(usize, usize), usize> = HashMap::new();
        let mut mid_of = |a: usize, b: usize| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                nodes.push(0.5 * (nodes[a] + nodes[b]));
                nodes.len() - 1
            })
        };
        // gmsh's order: edges 01, 12, 20, 03, 23, 13.
        for t in &mut tets {
            let m: Vec<usize> = [(0, 1), (1, 2), (2, 0), (0, 3), (2, 3), (1, 3)]
                .iter()
                .map(|&(i, j)| mid_of(t[i], t[j]))
                .collect();
            t.extend(m);
        }
        for f in tris.iter_mut().flatten() {
            let m: Vec<usize> = [(0, 1), (1, 2), (2, 0)]
                .iter()
                .map(|&(i, j)| mid_of(f[i], f[j]))
                .collect();
            f.extend(m);
        }
        (11, 9)
    } else {
        (4, 2)
    };
    let [cavity, clamp, plane] = [tris[0].clone(), tris[1].clone(), tris[2].clone()];
    let markers = [3, 1, 2].map(|i| vec![id(i, 0, 0)]).to_vec();
    let mut m = Msh {
        nodes,
        blocks: vec![
            (3, 1, vec![1], tet_type, tets),
            (2, 1, vec![2], tri_type, cavity),
            (2, 2, vec![3], tri_type, clamp),
            (0, 1, vec![4], 15, markers),
        ],
        names: vec![
            (3, 1, "silicone".into()),
            (2, 2, "cavity".into()),
            (2, 3, "clamp".into()),
            (0, 4, "markers".into()),
        ],
    };
    if half {
        m.blocks.push((2, 3, vec![5], tri_type, plane));
        m.names.push((2, 5, "symmetry.y".into()));
    }
    m
}

const CENTRE: [usize; 3] = [1, 1, 1];
const ON_PLANE: [usize; 3] = [1, 0, 1];

fn read_text(dir: &Path, name: &str, text: &str) -> Result<ImportedMesh, FemError> {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    msh::read(&path)
}

#[test]
fn four_and_ten_node_cubes_are_the_same_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let linear = read_text(dir.path(), "a.msh", &cube(CENTRE, false).text()).unwrap();
    let quadratic = read_text(dir.path(), "b.msh", &cube(CENTRE, true).text()).unwrap();
    for m in [&linear, &quadratic] {
        assert_eq!(m.tets.len(), 26 * 6);
        assert!(rel(mesh_volume(m), 26.0) < 1e-12);
        assert!(rel(cavity_volume(m, &m.cavities[0].1, &CLOSED), 1.0) < 1e-12);
        assert_eq!(m.cavities[0].1.len(), 12);
        assert!(worst_mid_node_offset(m) < 1e-15);
        let xs: Vec<f64> = m.markers.iter().map(|&n| m.nodes[n].x).collect();
        assert_eq!(xs, [1.0, 2.0, 3.0]);
        // The face x = 0: every point of the doubled 7 x 7 grid.
        assert_eq!(m.clamp.len(), 7 * 7);
    }
    // The same nodes, in another order: compare the node sets and the tetrahedra's
    // positions.
    let sorted = |m: &ImportedMesh| {
        let mut p: Vec<[u64; 3]> = m.nodes.iter().map(|x| x.map(f64::to_bits).into()).collect();
        p.sort_unstable();
        p
    };
    assert_eq!(linear.nodes.len(), quadratic.nodes.len());
    assert_eq!(sorted(&linear), sorted(&quadratic));
}

#[test]
fn a_half_model_cavity_may_be_open_on_its_symmetry_plane() {
    let dir = tempfile::tempdir().unwrap();
    let m = read_text(dir.path(), "half.msh", &cube(ON_PLANE, true).text()).unwrap();
    assert_eq!(m.symmetry.len(), 1);
    let (axis, plane) = &m.symmetry[0];
    assert_eq!(*axis, 1);
    assert!(plane.iter().all(|&n| m.nodes[n].y == 0.0));
    // The doubled 7 x 7 grid less the centre of the hole's square.
    assert_eq!(plane.len(), 7 * 7 - 1);
    // Closed by the plane y = 0, on which the field (x, 0, z) / 2 has no flux.
    let w = Vector3::new(0.5, 0.0, 0.5);
    assert!(rel(cavity_volume(&m, &m.cavities[0].1, &w), 1.0) < 1e-12);
}

/// Each bad file gives its one-line message, naming the file.
/// A file that leaves its cavity, clamp and markers unnamed gets them from the solid's
/// shape and the config: the same mesh as the file that names them.
#[test]
fn unnamed_parts_are_found_as_the_named_ones() {
    use crate::fem::config::{ClampPlane, MarkerLine};
    use crate::fem::import::Completion;
    let dir = tempfile::tempdir().unwrap();
    let named = read_text(dir.path(), "named.msh", &cube(CENTRE, true).text()).unwrap();
    let bare = cube(CENTRE, true)
        .without("cavity")
        .without("clamp")
        .without("markers");
    let path = dir.path().join("bare.msh");
    std::fs::write(&path, bare.text()).unwrap();
    let completion = Completion {
        clamp: Some(ClampPlane {
            axis: 0,
            max: false,
        }),
        markers: Some(MarkerLine {
            from: [1.1, 0.0, 0.1],
            to: [2.9, 0.0, -0.1],
            count: 3,
        }),
        marker_reach_mm: 0.5,
    };
    let found = msh::read_completed(&path, &completion).unwrap();
    assert_eq!(found.nodes, named.nodes);
    assert_eq!(found.clamp, named.clamp);
    assert_eq!(found.markers, named.markers);
    let sorted = |m: &ImportedMesh| {
        let mut f: Vec<[usize; 6]> = m.cavities[0].1.clone();
        f.sort_unstable();
        f
    };
    assert_eq!(found.cavities.len(), 1);
    assert_eq!(sorted(&found), sorted(&named));

    // Named in the file and in the config; a clamp side with no flat face; a marker
    // off the surface; two markers on one node.
    let whole = dir.path().join("whole.msh");
    std::fs::write(&whole, cube(CENTRE, true).text()).unwrap();
    let with = |clamp: Option<ClampPlane>, markers: Option<MarkerLine>| Completion {
        clamp,
        markers,
        marker_reach_mm: 0.5,
    };
    let line = |to: [f64; 3], count| MarkerLine {
        from: [1.0, 0.0, 0.0],
        to,
        count,
    };
    let x_min = Some(ClampPlane {
        axis: 0,
        max: false,
    });
    let shown = |p: &Path| p.display().to_string();
    let cases = [
        (&whole, with(x_min, None), "the file names a `clamp` and [geometry] clamp = \"x-min\" names another: remove one".to_string()),
        (&whole, with(None, Some(line([3.0, 0.0, 0.0], 3))), "the file names `markers` and [geometry.markers] puts others: remove one".into()),
        (&path, with(None, Some(line([3.0, 0.0, -4.0], 3))), "[geometry.markers]: marker 2 at (2.000, 0.000, -2.000) is 2.00 mm from the solid's surface, more than the mesh size 0.5 mm: put the line on a face of the actuator".into()),
        (&path, with(None, Some(line([1.2, 0.0, 0.0], 3))), "[geometry.markers]: markers 1 and 2 fall on the same mesh node: use fewer markers or a finer mesh".into()),
    ];
    for (file, c, why) in cases {
        let e = msh::read_completed(file, &c).unwrap_err().to_string();
        assert_eq!(e, format!("{}: {why}", shown(file)));
    }
}

#[test]
fn bad_meshes_are_refused_with_what_is_wrong() {
    let base = cube(CENTRE, false);
    let half = cube(ON_PLANE, false);
    let text = base.text();
    let mut cases: Vec<(&str, String, String)> = vec![
        (
            "old version",
            "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n".into(),
            "MSH version 2.2, not 4.1: save it as MSH 4.1 (gmsh: -format msh41)".into(),
        ),
        (
            "not a mesh",
            "solid cube\nendsolid\n".into(),
            "not a gmsh mesh: it does not start with $MeshFormat (save it from gmsh as MSH 4.1: -format msh41)".into(),
        ),
        (
            "cut short",
            text[..text.find("$EndNodes").unwrap() - 20].into(),
            "not a readable MSH 4.1 file: line 148, node section > node entity block (1 of 1) > node coordinates > y coordinate: an invalid node definition was encountered".into(),
        ),
        (
            "no cavity",
            half.clone().without("cavity").text(),
            "no cavity: no `cavity` group, and the solid has no closed inner surface: name the cavity's surfaces `cavity` (gmsh: Physical Surface(\"cavity\") = {...}), or close its inlet in the CAD so that the cavity is a void".into(),
        ),
        (
            "no clamp",
            base.clone().without("clamp").text(),
            "no physical surface or volume named `clamp`: name the clamped surfaces `clamp` (gmsh: Physical Surface(\"clamp\") = {...}), or clamp a flat face of the solid with [geometry] clamp = \"x-min\"".into(),
        ),
        (
            "unknown name",
            base.clone().renamed("clamp", "clamped").text(),
            "physical surface `clamped` has an unknown name: name it `cavity`, `cavity.NAME`, `clamp`, `symmetry.x`, `symmetry.y`, `symmetry.z`, `layer.NAME`".into(),
        ),
        (
            "no volume",
            base.clone().without("silicone").text(),
            "no volume elements (tetrahedra): mesh the model in 3D (gmsh -3)".into(),
        ),
        (
            "too many nodes",
            text.replace("$Nodes\n1 64 1 64\n", "$Nodes\n1 1000000000000 1 64\n"),
            "declares 1000000000000 nodes, more than the 2000000 read: mesh coarser".into(),
        ),
        (
            "too many elements",
            text.replace("$Elements\n4 189 1 189\n", "$Elements\n4 99999999 1 189\n"),
            "declares 99999999 elements, more than the 4000000 read: mesh coarser".into(),
        ),
        (
            "half model without its plane",
            half.clone().without("symmetry.y").text(),
            "cavity `cavity` is open: its edge (1.000, 0.000, 1.000) - (2.000, 0.000, 1.000) borders 1 of its faces, not 2: put every inner surface of the cavity in `cavity`".into(),
        ),
    ];
    let mut add = |name: &'static str, m: Msh, why: &str| cases.push((name, m.text(), why.into()));

    let mut open = base.clone();
    open.block_mut("cavity").remove(0);
    add("open cavity", open, "cavity `cavity` is open: its edge (1.000, 1.000, 1.000) - (2.000, 1.000, 1.000) borders 1 of its faces, not 2: put every inner surface of the cavity in `cavity`");

    let mut inverted = base.clone();
    inverted.block_mut("silicone")[0].swap(0, 1);
    add("inverted", inverted, "element 1 is inverted (volume -1.667e-1 mm³): its corners must turn counter-clockwise seen from the 4th; remesh it");

    let mut flat = base.clone();
    flat.block_mut("silicone").push(vec![0, 1, 4, 5]);
    add("flat", flat, "element 157 is flat (volume 0.000e0 mm³, mean 1.656e-1 mm³): remesh with better quality (gmsh: -optimize_netgen)");

    let mut unnamed_volume = base.clone();
    unnamed_volume.blocks[0].2.clear();
    add("unnamed volume", unnamed_volume, "the tetrahedra are in no physical volume: name the material's volumes (gmsh: Physical Volume(\"silicone\") = {...})");

    // The face x = 1 between cells (0, 0, 0) and (1, 0, 0).
    let mut solid_cavity = base.clone();
    solid_cavity.block_mut("cavity").push(vec![1, 5, 21]);
    add("cavity with silicone inside", solid_cavity, "cavity `cavity`: element 169 has tetrahedra on both sides: the cavity must be empty (subtract it from the volume: BooleanDifference)");

    let mut stray = base.clone();
    stray.nodes.push(Vector3::new(5.0, 5.0, 5.0));
    stray.block_mut("markers").push(vec![64]);
    add("marker off the mesh", stray, "`markers`: element 190 has node 65 at (5.000, 5.000, 5.000), which is no node of the tetrahedra: mesh the surfaces, curves and points with the volume, in one run (points: Point{...} In Surface{...})");

    let mut unnamed_group = base.clone();
    unnamed_group
        .blocks
        .push((2, 9, vec![9], 2, vec![vec![0, 1, 5]]));
    add(
        "unnamed group",
        unnamed_group,
        "physical surface 9 has no name: name it (gmsh: Physical Surface(\"NAME\") = {...})",
    );

    let mut quads = base.clone();
    quads
        .blocks
        .push((2, 9, vec![3], 3, vec![vec![0, 1, 5, 4]]));
    add("quadrangles", quads, "physical surface `clamp` holds elements of gmsh type 3 (Qua4): only tetrahedra, triangles, lines and points are read (mesh with gmsh -3, without recombining)");

    let mut bent_plane = half.clone();
    let clamp_face = bent_plane.block_mut("clamp")[0].clone();
    bent_plane.block_mut("symmetry.y").push(clamp_face);
    add("symmetry not a plane", bent_plane, "`symmetry.y` is not a plane y = const: its nodes' y runs from 0.0000 to 1.0000 mm: put only the symmetry plane's surfaces in it");

    let dir = tempfile::tempdir().unwrap();
    let mut failures = Vec::new();
    for (name, text, why) in &cases {
        let path = dir.path().join("bad.msh");
        let got = match read_text(dir.path(), "bad.msh", text) {
            Ok(_) => "read without complaint".to_string(),
            Err(e) => e.to_string(),
        };
        let want = format!("{}: {why}", path.display());
        if got != want {
            failures.push(format!("{name}:\n  got  {got}\n  want {want}"));
        }
        assert!(!got.contains('\n'), "{name}: one line: {got}");
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The linear cube with a sheet `layer.sheet` on the plane z = 1 (inside the solid, the
/// hole's floor left out) and a fibre `thread.fibre` along x on y = z = 0.
fn with_sheet_and_fibre(mut m: Msh) -> Msh {
    let id = |i: usize, j: usize, k: usize| (k * 4 + j) * 4 + i;
    let mut count: HashMap<Vec<usize>, (usize, Vec<usize>)> = HashMap::new();
    for t in &m.blocks[0].4 {
        for f in [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]] {
            let tri: Vec<usize> = f.iter().map(|&a| t[a]).collect();
            let mut key = tri.clone();
            key.sort_unstable();
            count.entry(key).or_insert((0, tri)).0 += 1;
        }
    }
    let mut sheet: Vec<Vec<usize>> = count
        .into_values()
        .filter(|(n, f)| *n == 2 && f.iter().all(|&a| m.nodes[a].z == 1.0))
        .map(|(_, f)| f)
        .collect();
    sheet.sort_unstable();
    let fibre = (0..3).map(|i| vec![id(i, 0, 0), id(i + 1, 0, 0)]).collect();
    m.blocks.push((2, 7, vec![7], 2, sheet));
    m.blocks.push((1, 8, vec![8], 1, fibre));
    m.names.push((2, 7, "layer.sheet".into()));
    m.names.push((1, 8, "thread.fibre".into()));
    m
}

#[test]
fn layers_and_threads_get_the_tetrahedra_mid_nodes() {
    let dir = tempfile::tempdir().unwrap();
    let text = with_sheet_and_fibre(cube(CENTRE, false)).text();
    let m = read_text(dir.path(), "sheet.msh", &text).unwrap();
    assert_eq!(m.layers.len(), 1);
    let (name, sheet) = &m.layers[0];
    assert_eq!(name, "sheet");
    // 9 squares of 2 triangles, less the hole's floor.
    assert_eq!(sheet.len(), 16);
    let area: f64 = sheet
        .iter()
        .map(|f| {
            let x = f.map(|i| m.nodes[i]);
            for (k, (a, b)) in [(0, 1), (1, 2), (2, 0)].into_iter().enumerate() {
                assert!((x[3 + k] - 0.5 * (x[a] + x[b])).norm() < 1e-15);
            }
            assert!(x.iter().all(|p| p.z == 1.0));
            0.5 * (x[1] - x[0]).cross(&(x[2] - x[0])).norm()
        })
        .sum();
    assert!(rel(area, 8.0) < 1e-15);
    assert_eq!(m.threads.len(), 1);
    let (name, lines) = &m.threads[0];
    assert_eq!(name, "fibre");
    let ends: Vec<[f64; 3]> = lines
        .iter()
        .map(|l| [m.nodes[l[0]].x, m.nodes[l[1]].x, m.nodes[l[2]].x])
        .collect();
    assert_eq!(ends, [[0.0, 1.0, 0.5], [1.0, 2.0, 1.5], [2.0, 3.0, 2.5]]);

    // A fibre across a cell's face, off the tetrahedra's edges.
    let mut off = with_sheet_and_fibre(cube(CENTRE, false));
    off.blocks.last_mut().unwrap().4.push(vec![16, 4]);
    let err = read_text(dir.path(), "off.msh", &off.text()).map(|_| "read");
    assert_eq!(
        err.unwrap_err().to_string(),
        format!(
            "{}: `thread.fibre`: element 209 runs along (0.000, 0.000, 1.000) - (0.000, 1.000, 0.000), which is no edge of the tetrahedra: mesh it with the volume, in one run",
            dir.path().join("off.msh").display()
        )
    );
}

/// A binary file's declared node count is read in its own byte order before parsing.
#[test]
fn binary_declared_counts_are_bounded() {
    let mut bytes = std::fs::read(fixture("block-binary.msh")).unwrap();
    let at = bytes.windows(7).position(|w| w == b"\n$Nodes").unwrap() + 8;
    // numEntityBlocks, then numNodes (size_t, little-endian as gmsh wrote it).
    let declared = u64::from_le_bytes(bytes[at + 8..at + 16].try_into().unwrap());
    assert_eq!(declared, 1722);
    bytes[at + 8..at + 16].copy_from_slice(&(1u64 << 40).to_le_bytes());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.msh");
    std::fs::write(&path, &bytes).unwrap();
    assert_eq!(
        msh::read(&path).unwrap_err().to_string(),
        format!(
            "{}: declares 1099511627776 nodes, more than the 2000000 read: mesh coarser",
            path.display()
        )
    );
}
