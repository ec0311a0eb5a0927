//! Bending stiffness of a flat sheet meshed as triangles (an imported mesh's
//! `layer.NAME` surface with `element = "plate"`): [`super::plate`]'s rotation-free plate
//! energy ½ D [ν |x,₁₁ + x,₂₂|² + (1 − ν)(|x,₁₁|² + |x,₂₂|² + 2 |x,₁₂|²)] on an
//! unstructured triangulation, as the same [`PlateTerm`]s.
//!
//! Why written here: the quadrilateral plate takes second differences along the lines of
//! a structured grid, which a gmsh surface mesh does not have, and a shell element would
//! add rotations to nodes the sheet shares with the tetrahedra. The discretization is the
//! quadrilateral plate's, node by node: each 6-node face is split into its 4 straight
//! sub-triangles; at each node the second derivatives x,αβ are those of the quadratic
//! through the node fitted by weighted least squares to its neighbours (a generalized
//! finite difference), weighted by the node's third of its sub-triangles' area. Every
//! quadratic field, rigid motions among them, is measured exactly, and a spike at one
//! node bends its own fit. Where the neighbours do not pose the fit (a node on a free
//! edge, or with few neighbours) the neighbours' neighbours join it; across a symmetry
//! plane the neighbours' mirror images do (their displacement reflected).
//!
//! A per-triangle patch quadratic (the rotation-free EBST triangle) was tried first: it
//! is exact on quadratics too, but on meshes with vertices of 8 faces it has a soft mode
//! (a simply supported plate 17-22% too flexible, not converging).
//!
//! The reference sheet must be flat (x,αβ of the reference vanishes, which makes the
//! energy exact for a sheet bending without stretching under large rotations, as the
//! quadrilateral plate's): a sheet curved or kinked is refused.

use std::collections::{BTreeMap, BTreeSet};

use nalgebra::{SMatrix, SVector, Vector3};

use super::plate::{Curvature, Mirror, PlateTerm, PLATE_NODES};

/// A neighbourhood's nodes lie within this fraction of its size of the node's plane.
const FLAT: f64 = 1e-6;

/// The fit is posed when the smallest singular value of its scaled, weighted matrix is
/// at least this fraction of the largest.
const WELL_POSED: f64 = 1e-3;

/// Neighbours of one fit at most: a term holds the node and these.
const MOST: usize = PLATE_NODES - 1;

/// One neighbour in a fit: a node of the sheet, its reference position (the mirrored
/// position for a mirror image) and the sign of each displacement component (−1 across
/// a mirror).
#[derive(Debug, Clone, Copy)]
struct Neighbour {
    node: usize,
    at: Vector3<f64>,
    sign: [f64; 3],
}

/// The 4 straight sub-triangles of a 6-node face (corners 0 1 2, then the mid-nodes of
/// 01, 12, 20), each turning as the face.
fn sub_triangles(f: &[usize; 6]) -> [[usize; 3]; 4] {
    [
        [f[0], f[3], f[5]],
        [f[3], f[1], f[4]],
        [f[5], f[4], f[2]],
        [f[3], f[4], f[5]],
    ]
}

/// The bending terms of a flat sheet of rigidity `d` (N mm) and Poisson ratio `nu` on
/// the 6-node triangles `faces` (reference positions `nodes`), cut by the symmetry
/// planes `mirrors`. Err names what makes the sheet no plate (curved or kinked, a
/// degenerate triangle, too few nodes), with a place, for the caller to name the layer.
pub fn tri_plate_terms(
    nodes: &[Vector3<f64>],
    faces: &[[usize; 6]],
    d: f64,
    nu: f64,
    mirrors: &[Mirror],
) -> Result<Vec<PlateTerm>, String> {
    let mut ring: BTreeMap<usize, BTreeSet<usize>> = BTreeMap::new();
    let mut area: BTreeMap<usize, f64> = BTreeMap::new();
    let mut normal: BTreeMap<usize, Vector3<f64>> = BTreeMap::new();
    for tri in faces.iter().flat_map(sub_triangles) {
        let x: [Vector3<f64>; 3] = std::array::from_fn(|a| nodes[tri[a]]);
        let cross = (x[1] - x[0]).cross(&(x[2] - x[0]));
        let a = 0.5 * cross.norm();
        let size = (0..3)
            .map(|k| (x[(k + 1) % 3] - x[k]).norm())
            .fold(0.0, f64::max);
        if !(a > 1e-9 * size * size) {
            return Err(format!("a degenerate triangle at {}", place(&x[0])));
        }
        for k in 0..3 {
            let v = tri[k];
            ring.entry(v)
                .or_default()
                .extend([tri[(k + 1) % 3], tri[(k + 2) % 3]]);
            *area.entry(v).or_default() += a / 3.0;
            // Normals keep the first triangle's side (a sheet's faces may turn either way).
            normal.entry(v).or_insert(cross / (2.0 * a));
        }
    }
    let mut terms = Vec::with_capacity(4 * ring.len());
    for (&v, near) in &ring {
        let n = normal[&v];
        let e1 = any_perpendicular(&n);
        let e2 = n.cross(&e1);
        let mirror_images = |list: &mut Vec<Neighbour>, of: &BTreeSet<usize>| {
            for m in mirrors {
                let scale = near
                    .iter()
                    .map(|&j| (nodes[j] - nodes[v]).norm())
                    .fold(0.0, f64::max);
                if (nodes[v][m.axis] - m.at).abs() > FLAT * scale {
                    continue;
                }
                for &j in of {
                    if (nodes[j][m.axis] - m.at).abs() > FLAT * scale {
                        let mut at = nodes[j];
                        at[m.axis] = 2.0 * m.at - at[m.axis];
                        let mut sign = [1.0; 3];
                        sign[m.axis] = -1.0;
                        list.push(Neighbour { node: j, at, sign });
                    }
                }
            }
        };
        let plain = |j: usize| Neighbour {
            node: j,
            at: nodes[j],
            sign: [1.0; 3],
        };
        let mut list: Vec<Neighbour> = near.iter().map(|&j| plain(j)).collect();
        mirror_images(&mut list, near);
        let mut fit = hessian_fit(&nodes[v], &list, &e1, &e2);
        // Where the neighbours do not pose the fit, the next ring joins (up to the third),
        // nearest first, as many as a term holds.
        let mut wider: BTreeSet<usize> = near.clone();
        for _ in 0..2 {
            if fit.is_some() {
                break;
            }
            let next: Vec<usize> = wider.iter().flat_map(|j| ring[j].iter().copied()).collect();
            wider.extend(next);
            wider.remove(&v);
            let mut list: Vec<Neighbour> = wider.iter().map(|&j| plain(j)).collect();
            mirror_images(&mut list, &wider);
            list.sort_by(|a, b| {
                (a.at - nodes[v])
                    .norm_squared()
                    .total_cmp(&(b.at - nodes[v]).norm_squared())
            });
            fit = (5..=list.len().min(MOST))
                .find_map(|k| hessian_fit(&nodes[v], &list[..k], &e1, &e2));
        }
        let (list, rows) = fit.ok_or_else(|| {
            format!(
                "too few nodes around {} to measure a curvature: mesh the sheet finer",
                place(&nodes[v])
            )
        })?;
        if let Some(p) = list.iter().find(|p| {
            let r = p.at - nodes[v];
            r.dot(&n).abs() > FLAT * r.norm()
        }) {
            return Err(format!(
                "it is not flat at {}: a plate needs a flat sheet (mesh a curved sheet as membranes, or split it into flat surfaces)",
                place(&p.at)
            ));
        }
        push_terms(&mut terms, v, &list, &rows, d * area[&v], nu);
    }
    Ok(terms)
}

/// A neighbour's weight in the fit at scaled offset (y₁, y₂): 1 / |y|⁴, so that the
/// nearest ring decides (weaker weights let farther nodes smooth the fit, which leaves
/// a soft mode on meshes with vertices of 4 and 8 faces).
fn weight(y1: f64, y2: f64) -> f64 {
    (y1 * y1 + y2 * y2).powi(-2)
}

/// A unit vector perpendicular to `n`.
fn any_perpendicular(n: &Vector3<f64>) -> Vector3<f64> {
    let axis = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    (axis - axis.dot(n) * n).normalize()
}

/// The weighted least-squares quadratic through the node at `x0` (value u₀) fitted to
/// `list` (values u_j), in the frame e₁, e₂: q(y) = u₀ + g · y + ½ yᵀ H y, weights
/// [`weight`], coordinates scaled by s, the mean distance. Its second derivatives
/// H₁₁, H₁₂, H₂₂ as rows of coefficients on the u_j (u₀'s is minus their sum), or None
/// when the neighbours do not pose it (fewer than 5, or on a line or a conic through the
/// node). Returns the list it used with the rows.
fn hessian_fit(
    x0: &Vector3<f64>,
    list: &[Neighbour],
    e1: &Vector3<f64>,
    e2: &Vector3<f64>,
) -> Option<(Vec<Neighbour>, [Vec<f64>; 3])> {
    if list.len() < 5 || list.len() > MOST {
        return None;
    }
    let s = list.iter().map(|p| (p.at - x0).norm()).sum::<f64>() / list.len() as f64;
    let m = list.len();
    let mut a = nalgebra::DMatrix::<f64>::zeros(m, 5);
    for (j, p) in list.iter().enumerate() {
        let r = (p.at - x0) / s;
        let (y1, y2) = (r.dot(e1), r.dot(e2));
        let w = weight(y1, y2);
        let row = [y1, y2, 0.5 * y1 * y1, y1 * y2, 0.5 * y2 * y2];
        for (c, v) in row.iter().enumerate() {
            a[(j, c)] = w.sqrt() * v;
        }
    }
    let sv = a.clone().singular_values();
    if sv.min() < WELL_POSED * sv.max() {
        return None;
    }
    let ata = SMatrix::<f64, 5, 5>::from_fn(|i, k| (0..m).map(|j| a[(j, i)] * a[(j, k)]).sum());
    let inv = ata.try_inverse()?;
    // b = (AᵀWA)⁻¹ Aᵀ √W (√W (u − u₀)): the coefficient of u_j is column j of
    // (AᵀWA)⁻¹ (√W A)ᵀ times √w_j.
    let mut rows = [vec![0.0; m], vec![0.0; m], vec![0.0; m]];
    for (j, p) in list.iter().enumerate() {
        let r = (p.at - x0) / s;
        let (y1, y2) = (r.dot(e1), r.dot(e2));
        let sw = weight(y1, y2).sqrt();
        let col = SVector::<f64, 5>::from_fn(|c, _| a[(j, c)]);
        let b = inv * col * sw;
        for (k, row) in rows.iter_mut().enumerate() {
            row[j] = b[2 + k] / (s * s);
        }
    }
    Some((list.to_vec(), rows))
}

/// The plate terms at node `v` of its fit (`list`, Hessian `rows`), over the node's area
/// times the rigidity, `da` = D A.
fn push_terms(
    terms: &mut Vec<PlateTerm>,
    v: usize,
    list: &[Neighbour],
    rows: &[Vec<f64>; 3],
    da: f64,
    nu: f64,
) {
    let stencil = |row: &[f64]| -> Vec<(usize, [f64; 3])> {
        let mut out: Vec<(usize, [f64; 3])> = vec![(v, [-row.iter().sum::<f64>(); 3])];
        for (p, c) in list.iter().zip(row) {
            let w = [c * p.sign[0], c * p.sign[1], c * p.sign[2]];
            match out.iter_mut().find(|(node, _)| *node == p.node) {
                Some((_, have)) => (0..3).for_each(|i| have[i] += w[i]),
                None => out.push((p.node, w)),
            }
        }
        out
    };
    let (xx, xy, yy) = (stencil(&rows[0]), stencil(&rows[1]), stencil(&rows[2]));
    let sum: Vec<(usize, [f64; 3])> = xx
        .iter()
        .zip(&yy)
        .map(|((node, a), (_, b))| (*node, [a[0] + b[0], a[1] + b[1], a[2] + b[2]]))
        .collect();
    if nu != 0.0 {
        terms.push(PlateTerm::new(&sum, nu * da, Curvature::Sum));
    }
    terms.push(PlateTerm::new(&xx, (1.0 - nu) * da, Curvature::Line));
    terms.push(PlateTerm::new(&yy, (1.0 - nu) * da, Curvature::Line));
    terms.push(PlateTerm::new(&xy, 2.0 * (1.0 - nu) * da, Curvature::Twist));
}

fn place(x: &Vector3<f64>) -> String {
    format!("({:.3}, {:.3}, {:.3}) mm", x.x, x.y, x.z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::plate::flexural_rigidity;

    /// A flat a x b sheet in the plane z = 0 as nx x ny squares, each cut into two 6-node
    /// triangles (diagonals alternating when `cross`), the interior nodes shifted by up to
    /// `jitter` of the spacing (a deterministic pattern): nodes and faces.
    fn sheet(
        a: f64,
        b: f64,
        nx: usize,
        ny: usize,
        cross: bool,
        jitter: f64,
    ) -> (Vec<Vector3<f64>>, Vec<[usize; 6]>) {
        let (mx, my) = (2 * nx, 2 * ny);
        let id = |i: usize, j: usize| i + (mx + 1) * j;
        let mut nodes = Vec::new();
        for j in 0..=my {
            for i in 0..=mx {
                let mut p = Vector3::new(a * i as f64 / mx as f64, b * j as f64 / my as f64, 0.0);
                // Shift corner nodes inside; mid-nodes follow below.
                if i % 2 == 0 && j % 2 == 0 && i > 0 && i < mx && j > 0 && j < my {
                    let phase = (7 * i + 13 * j) as f64;
                    p.x += jitter * a / nx as f64 * phase.sin();
                    p.y += jitter * b / ny as f64 * phase.cos();
                }
                nodes.push(p);
            }
        }
        let mut faces = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                let c = |di: usize, dj: usize| id(2 * i + di, 2 * j + dj);
                let flip = cross && (i + j) % 2 == 1;
                if flip {
                    faces.push([c(0, 0), c(2, 0), c(0, 2), c(1, 0), c(1, 1), c(0, 1)]);
                    faces.push([c(2, 0), c(2, 2), c(0, 2), c(2, 1), c(1, 2), c(1, 1)]);
                } else {
                    faces.push([c(0, 0), c(2, 0), c(2, 2), c(1, 0), c(2, 1), c(1, 1)]);
                    faces.push([c(0, 0), c(2, 2), c(0, 2), c(1, 1), c(1, 2), c(0, 1)]);
                }
            }
        }
        // Mid-nodes halfway between their (shifted) corners: straight-sided faces.
        for f in &faces {
            for (m, (p, q)) in [(3, (0, 1)), (4, (1, 2)), (5, (2, 0))] {
                nodes[f[m]] = 0.5 * (nodes[f[p]] + nodes[f[q]]);
            }
        }
        (nodes, faces)
    }

    fn displacement(
        nodes: &[Vector3<f64>],
        field: impl Fn(&Vector3<f64>) -> Vector3<f64>,
    ) -> Vec<f64> {
        nodes
            .iter()
            .flat_map(|x| field(x).iter().copied().collect::<Vec<_>>())
            .collect()
    }

    fn total(terms: &[PlateTerm], u: &[f64]) -> f64 {
        terms.iter().map(|t| t.energy(u)).sum()
    }

    /// Every sub-triangle's terms measure a quadratic field's second derivatives exactly,
    /// on the free edges too, on regular and jittered meshes: a rigid motion (its
    /// linearized displacement, linear in X) costs nothing, and a small deflection
    /// w = ½ (a x² + 2 b x y + c y²) stores the plate energy of its curvatures.
    #[test]
    fn quadratic_fields_are_measured_exactly() {
        let (d, nu) = (flexural_rigidity(0.5, 6500.0, 0.3), 0.3);
        for (cross, jitter) in [(false, 0.0), (true, 0.0), (true, 0.15)] {
            let (nodes, faces) = sheet(12.0, 5.0, 6, 3, cross, jitter);
            let terms = tri_plate_terms(&nodes, &faces, d, nu, &[]).unwrap();
            let linear = displacement(&nodes, |x| {
                Vector3::new(
                    0.3 - 0.02 * x.y,
                    0.1 + 0.02 * x.x + 0.01 * x.z,
                    -0.4 + 0.05 * x.x - 0.07 * x.y,
                )
            });
            assert!(total(&terms, &linear) < 1e-18, "{cross} {jitter}");
            let (a, b, c) = (0.02, -0.005, 0.01);
            let w = displacement(&nodes, |x| {
                Vector3::new(
                    0.0,
                    0.0,
                    0.5 * (a * x.x * x.x + 2.0 * b * x.x * x.y + c * x.y * x.y),
                )
            });
            // Per sub-triangle: x,₁₁ + x,₂₂, x,₁₁, x,₂₂, x,₁₂ (its own frame turns with
            // the sub-triangle, so the sum is checked here; the energy below checks all).
            for four in terms.chunks(4) {
                assert_eq!(four[0].curvature, Curvature::Sum);
                let v = four[0].value(&w).z;
                assert!((v - (a + c)).abs() < 1e-9, "{cross} {jitter}: {v}");
            }
            let exact = 0.5
                * d
                * (nu * (a + c).powi(2) + (1.0 - nu) * (a * a + c * c + 2.0 * b * b))
                * 60.0;
            let e = total(&terms, &w);
            assert!(
                (e / exact - 1.0).abs() < 1e-9,
                "{cross} {jitter}: {e} vs {exact}"
            );
        }
    }

    /// The sheet rolled onto a cylinder of radius R, a large rotation that does not
    /// stretch it, stores ½ D A / R² (within the patches' quadratic approximation of the
    /// circle, which converges as (h / R)²).
    #[test]
    fn a_sheet_rolled_onto_a_cylinder_stores_the_plates_bending_energy() {
        let (d, nu) = (flexural_rigidity(0.5, 6500.0, 0.22), 0.22);
        let (len, width, radius) = (20.0, 4.0, 8.0);
        let mut errors = Vec::new();
        for n in [10, 20] {
            let (nodes, faces) = sheet(len, width, n, n / 5, true, 0.1);
            let terms = tri_plate_terms(&nodes, &faces, d, nu, &[]).unwrap();
            let u = displacement(&nodes, |x| {
                let phi = x.x / radius;
                Vector3::new(radius * phi.sin() - x.x, 0.0, radius * (1.0 - phi.cos()))
            });
            let exact = 0.5 * d * len * width / (radius * radius);
            errors.push((total(&terms, &u) / exact - 1.0).abs());
        }
        eprintln!(
            "rolled sheet: energy off by {:.2e} (h 1 mm), {:.2e} (0.5 mm)",
            errors[0], errors[1]
        );
        assert!(
            errors[0] < 0.01 && errors[1] < errors[0] / 3.0,
            "{errors:?}"
        );
    }

    /// The deflection w (only z) under nodal loads `f` with the nodes `held` at w = 0:
    /// the terms' stiffness is constant, so one dense solve.
    fn deflection(terms: &[PlateTerm], n: usize, f: &[f64], held: &[bool]) -> Vec<f64> {
        let free: Vec<usize> = (0..n).filter(|&i| !held[i]).collect();
        let mut index = vec![usize::MAX; n];
        for (k, &i) in free.iter().enumerate() {
            index[i] = k;
        }
        let m = free.len();
        let mut k = nalgebra::DMatrix::<f64>::zeros(m, m);
        for t in terms {
            for a in 0..PLATE_NODES {
                for b in 0..PLATE_NODES {
                    let (p, q) = (index[t.nodes[a]], index[t.nodes[b]]);
                    if p != usize::MAX && q != usize::MAX {
                        k[(p, q)] += t.tangent(a, 2, b, 2);
                    }
                }
            }
        }
        let rhs = nalgebra::DVector::from_iterator(m, free.iter().map(|&i| f[i]));
        let x = k.cholesky().expect("positive definite").solve(&rhs);
        let mut w = vec![0.0; n];
        for (k, &i) in free.iter().enumerate() {
            w[i] = x[k];
        }
        w
    }

    /// Nodal loads of a uniform pressure q on the sub-triangles (a third of each to its
    /// corners).
    fn uniform_load(nodes: &[Vector3<f64>], faces: &[[usize; 6]], q: f64) -> Vec<f64> {
        let mut f = vec![0.0; nodes.len()];
        for t in faces.iter().flat_map(sub_triangles) {
            let area = 0.5
                * (nodes[t[1]] - nodes[t[0]])
                    .cross(&(nodes[t[2]] - nodes[t[0]]))
                    .norm();
            for a in t {
                f[a] += q * area / 3.0;
            }
        }
        f
    }

    /// The sheet of a gmsh mesh file (`fixtures/mesh/NAME`): nodes and 6-node faces.
    fn gmsh_sheet(name: &str) -> (Vec<Vector3<f64>>, Vec<[usize; 6]>) {
        let path = format!("{}/fixtures/mesh/{name}", env!("CARGO_MANIFEST_DIR"));
        let bytes = std::fs::read(&path).expect("the fixture is shipped");
        let raw = crate::fem::import::msh::parse(name, &bytes).expect("a mesh");
        let group = raw.groups.iter().find(|g| g.dim == 2).expect("a surface");
        let faces = group
            .elements
            .iter()
            .map(|e| std::array::from_fn(|k| e.nodes[k]))
            .collect();
        (raw.nodes, faces)
    }

    /// A simply supported square plate under a uniform pressure (Kirchhoff, ν = 0.3): the
    /// centre deflection is 0.00406235 q a⁴ / D (Navier's series; Timoshenko &
    /// Woinowsky-Krieger, table 8). gmsh's unstructured meshes converge to it, as does a
    /// regular mesh and half of it with a symmetry plane through the centre. A mesh
    /// whose vertices alternate between 4 and 8 faces (diagonals crossing, which gmsh does
    /// not make) stays 1.5% too flexible: the stated limit of the fit.
    #[test]
    fn a_simply_supported_square_plate_deflects_as_navier_says() {
        let (a, q, nu): (f64, f64, f64) = (10.0, 1e-3, 0.3);
        let d = flexural_rigidity(0.5, 200.0, nu);
        let exact = 0.004_062_35 * q * a.powi(4) / d;
        let solve =
            |nodes: &[Vector3<f64>], faces: &[[usize; 6]], mirrors: &[Mirror], right: f64| {
                let terms = tri_plate_terms(nodes, faces, d, nu, mirrors).unwrap();
                let on_sheet: BTreeSet<usize> = faces.iter().flatten().copied().collect();
                let held: Vec<bool> = nodes
                    .iter()
                    .enumerate()
                    .map(|(i, x)| {
                        let edge = x.x.abs() < 1e-9 || x.y.abs() < 1e-9 || (x.y - a).abs() < 1e-9;
                        edge || (mirrors.is_empty() && (x.x - right).abs() < 1e-9)
                            || !on_sheet.contains(&i)
                    })
                    .collect();
                let w = deflection(&terms, nodes.len(), &uniform_load(nodes, faces, q), &held);
                // The deflection at the centre: the nearest node, corrected by the exact
                // shape's ratio there (gmsh puts no node at the centre).
                let centre = Vector3::new(0.5 * a, 0.5 * a, 0.0);
                let i = on_sheet
                    .iter()
                    .copied()
                    .min_by(|&i, &j| {
                        (nodes[i] - centre)
                            .norm()
                            .total_cmp(&(nodes[j] - centre).norm())
                    })
                    .unwrap_or(0);
                let shape = |x: &Vector3<f64>| {
                    (std::f64::consts::PI * x.x / a).sin() * (std::f64::consts::PI * x.y / a).sin()
                };
                w[i] / shape(&nodes[i]) / exact
            };
        let mut report = Vec::new();
        for (mesh, tol) in [("plate-1.6.msh", 0.015), ("plate-0.8.msh", 0.005)] {
            let (nodes, faces) = gmsh_sheet(mesh);
            let ratio = solve(&nodes, &faces, &[], a);
            report.push(format!("{mesh} {ratio:.4}"));
            assert!((ratio - 1.0).abs() < tol, "{report:?}");
        }
        for (n, cross, tol) in [(12, false, 0.005), (24, true, 0.02)] {
            let (nodes, faces) = sheet(a, a, n, n, cross, 0.0);
            let ratio = solve(&nodes, &faces, &[], a);
            report.push(format!("{n}x{n} crossing {cross}: {ratio:.4}"));
            assert!((ratio - 1.0).abs() < tol, "{report:?}");
        }
        // Half the plate (x ≤ a/2), mirrored at x = a/2.
        let (nodes, faces) = sheet(0.5 * a, a, 6, 12, false, 0.0);
        let half = solve(
            &nodes,
            &faces,
            &[Mirror {
                axis: 0,
                at: 0.5 * a,
            }],
            0.5 * a,
        );
        eprintln!("simply supported plate / Navier: {report:?}; half with a mirror {half:.4}");
        assert!((half - 1.0).abs() < 0.005, "{half}");
    }

    /// A curved sheet is no plate: refused, saying where.
    #[test]
    fn a_curved_sheet_is_refused() {
        let (mut nodes, faces) = sheet(10.0, 4.0, 5, 2, true, 0.0);
        for x in &mut nodes {
            x.z = 0.01 * x.x * x.x;
        }
        let err = tri_plate_terms(&nodes, &faces, 1.0, 0.3, &[]).unwrap_err();
        assert!(err.contains("not flat at ("), "{err}");
    }
}
