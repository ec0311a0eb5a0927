//! Truss (cable) elements for fibre reinforcement, embedded in the hexahedral host mesh.
//!
//! Why written here: the fibre-reinforced actuators wind a thread (Kevlar) as a helix in
//! the silicone wall; the thread carries axial force only, and its path does not follow
//! the host mesh's nodes. Each fibre is cut into straight segments; each segment end is
//! a point of a host hexahedron, its position the host's trilinear interpolation
//! x = Σ N_a(ξ) x_a of the host nodes (the embedded-element technique of Abaqus'
//! `*EMBEDDED ELEMENT`): the fibre moves with the silicone, bonded, with no extra unknowns.
//!
//! Material: the Saint Venant-Kirchhoff bar, energy A L₀ ½ E_f ε² with the Green strain
//! ε = (l² − L₀²) / 2 L₀² (l, L₀ the current and reference segment lengths): linear
//! elastic at the small strains of a stiff thread, exact under large rotations. A cable
//! (`tension_only`) carries nothing while shorter than at rest (a thread buckles at no
//! load). Force and tangent are the energy's gradient and Hessian (total Lagrangian,
//! checked against finite differences below); with end weights w the 48 nodal entries
//! are f_a = w_a f_end and K_ab = w_a w_b K_end.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use serde::Serialize;

use super::hex::CORNERS;

/// Nodes each segment end is interpolated from (the 8 of its host hexahedron).
pub const END_NODES: usize = 8;
/// Degrees of freedom of a segment: 2 ends x 8 host nodes x 3.
pub const TRUSS_DOFS: usize = 2 * END_NODES * 3;

/// Truss force vector (16 host nodes x 3).
pub type TrussVector = SVector<f64, TRUSS_DOFS>;
/// Truss tangent (48 x 48).
pub type TrussMatrix = SMatrix<f64, TRUSS_DOFS, TRUSS_DOFS>;

/// A thread's section: cross-section area and Young's modulus.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrussSection {
    /// Cross-section area, mm².
    pub area_mm2: f64,
    /// Young's modulus, MPa.
    pub youngs_modulus_mpa: f64,
    /// A cable: no force while compressed.
    pub tension_only: bool,
}

/// A point of the host mesh: weights on up to 8 nodes (zero weights pad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmbeddedPoint {
    /// Host node indices.
    pub nodes: [usize; END_NODES],
    /// Interpolation weights (sum 1).
    pub weights: [f64; END_NODES],
}

impl EmbeddedPoint {
    /// A point on one node.
    pub fn at_node(a: usize) -> Self {
        let mut weights = [0.0; END_NODES];
        weights[0] = 1.0;
        Self {
            nodes: [a; END_NODES],
            weights,
        }
    }

    /// Its position given node positions (reference or current).
    pub fn position(&self, x: impl Fn(usize) -> Vector3<f64>) -> Vector3<f64> {
        self.nodes
            .iter()
            .zip(&self.weights)
            .filter(|(_, w)| **w != 0.0)
            .map(|(a, w)| x(*a) * *w)
            .sum()
    }
}

/// One straight fibre segment between two embedded points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrussElement {
    /// The segment's ends.
    pub ends: [EmbeddedPoint; 2],
    /// The thread's section.
    pub section: TrussSection,
}

impl TrussElement {
    /// The 16 host nodes in dof order (end 0's 8, then end 1's 8).
    pub fn nodes(&self) -> [usize; 2 * END_NODES] {
        std::array::from_fn(|k| self.ends[k / END_NODES].nodes[k % END_NODES])
    }

    fn weight(&self, k: usize) -> f64 {
        self.ends[k / END_NODES].weights[k % END_NODES]
    }
}

/// Axial strain state of a segment: Green strain and second Piola-Kirchhoff stress (MPa).
pub fn truss_strain_stress(t: &TrussElement, nodes: &[Vector3<f64>], u: &[f64]) -> (f64, f64) {
    let (_, _, strain, stress) = kinematics(t, nodes, u);
    (strain, stress)
}

/// Current end-to-end vector, reference length (mm), Green strain and stress (MPa).
fn kinematics(
    t: &TrussElement,
    nodes: &[Vector3<f64>],
    u: &[f64],
) -> (Vector3<f64>, f64, f64, f64) {
    let current = |a: usize| nodes[a] + Vector3::new(u[3 * a], u[3 * a + 1], u[3 * a + 2]);
    let d0 = t.ends[1].position(|a| nodes[a]) - t.ends[0].position(|a| nodes[a]);
    let d = t.ends[1].position(current) - t.ends[0].position(current);
    let l0sq = d0.norm_squared();
    let strain = 0.5 * (d.norm_squared() - l0sq) / l0sq;
    let stress = if t.section.tension_only && strain < 0.0 {
        0.0
    } else {
        t.section.youngs_modulus_mpa * strain
    };
    (d, l0sq.sqrt(), strain, stress)
}

/// Energy (N mm), force (N) and tangent (N/mm) of a segment at displacement `u` (3 per
/// node of the whole mesh).
pub fn truss_response(
    t: &TrussElement,
    nodes: &[Vector3<f64>],
    u: &[f64],
) -> (f64, TrussVector, TrussMatrix) {
    let (d, l0, strain, stress) = kinematics(t, nodes, u);
    let a = t.section.area_mm2;
    let slack = t.section.tension_only && strain < 0.0;
    let energy = if slack {
        0.0
    } else {
        0.5 * a * l0 * t.section.youngs_modulus_mpa * strain * strain
    };
    // dΠ/dx_end1 = A L₀ S dε/dd = A S d / L₀; the other end the opposite.
    let f_end = d * (a * stress / l0);
    let k_end = if slack {
        Matrix3::zeros()
    } else {
        (Matrix3::identity() * stress
            + d * d.transpose() * (t.section.youngs_modulus_mpa / (l0 * l0)))
            * (a / l0)
    };
    let mut f = TrussVector::zeros();
    let mut k = TrussMatrix::zeros();
    let sign = |i: usize| if i < END_NODES { -1.0 } else { 1.0 };
    for i in 0..2 * END_NODES {
        let wi = t.weight(i) * sign(i);
        if wi == 0.0 {
            continue;
        }
        for c in 0..3 {
            f[3 * i + c] = wi * f_end[c];
        }
        for j in 0..2 * END_NODES {
            let wj = t.weight(j) * sign(j);
            if wj == 0.0 {
                continue;
            }
            k.fixed_view_mut::<3, 3>(3 * i, 3 * j)
                .copy_from(&(k_end * (wi * wj)));
        }
    }
    (energy, f, k)
}

/// Trilinear shape functions of the hexahedron at local coordinates ξ (local node order
/// of [`super::hex`]).
pub fn hex_shape(xi: [f64; 3]) -> [f64; 8] {
    std::array::from_fn(|a| {
        let n = CORNERS[a];
        0.125 * (1.0 + n[0] * xi[0]) * (1.0 + n[1] * xi[1]) * (1.0 + n[2] * xi[2])
    })
}

/// Local coordinates of point `p` in the hexahedron with corners `x` (Newton on the
/// trilinear map), `None` when `p` lies outside it (beyond `slack` in ξ).
pub fn locate_in_hex(x: &[Vector3<f64>; 8], p: &Vector3<f64>, slack: f64) -> Option<[f64; 3]> {
    let mut xi = [0.0; 3];
    for _ in 0..30 {
        let n = hex_shape(xi);
        let mut r = -p;
        for a in 0..8 {
            r += x[a] * n[a];
        }
        // Jacobian ∂x/∂ξ by central differences of the (exactly trilinear) map.
        let mut jac = Matrix3::zeros();
        for i in 0..3 {
            let (mut lo, mut hi) = (xi, xi);
            lo[i] -= 0.5;
            hi[i] += 0.5;
            let (nl, nh) = (hex_shape(lo), hex_shape(hi));
            let col: Vector3<f64> = (0..8).map(|a| x[a] * (nh[a] - nl[a])).sum();
            jac.set_column(i, &col);
        }
        let step = jac.try_inverse()? * r;
        for i in 0..3 {
            xi[i] -= step[i];
        }
        if step.norm() < 1e-13 {
            break;
        }
    }
    xi.iter().all(|v| v.abs() <= 1.0 + slack).then_some(xi)
}

/// Embeds point `p` in the first of `elements` that holds it; `None` when none does.
pub fn embed_point(
    nodes: &[Vector3<f64>],
    elements: &[[usize; 8]],
    p: &Vector3<f64>,
) -> Option<EmbeddedPoint> {
    const SLACK: f64 = 1e-9;
    for el in elements {
        let x: [Vector3<f64>; 8] = std::array::from_fn(|a| nodes[el[a]]);
        let (lo, hi) = x.iter().fold(
            (
                Vector3::repeat(f64::INFINITY),
                Vector3::repeat(f64::NEG_INFINITY),
            ),
            |(lo, hi), v| (lo.inf(v), hi.sup(v)),
        );
        let pad = 1e-9 * (hi - lo).norm();
        if (0..3).any(|i| p[i] < lo[i] - pad || p[i] > hi[i] + pad) {
            continue;
        }
        if let Some(xi) = locate_in_hex(&x, p, SLACK) {
            let xi = xi.map(|v| v.clamp(-1.0, 1.0));
            return Some(EmbeddedPoint {
                nodes: *el,
                weights: hex_shape(xi),
            });
        }
    }
    None
}

/// Cuts the polyline `path` into segments no longer than `max_segment_mm` and embeds
/// them. Err with the index of the first path point outside the mesh.
pub fn embed_fibre(
    nodes: &[Vector3<f64>],
    elements: &[[usize; 8]],
    path: &[Vector3<f64>],
    max_segment_mm: f64,
    section: TrussSection,
) -> Result<Vec<TrussElement>, usize> {
    let mut points = Vec::new();
    for (i, w) in path.windows(2).enumerate() {
        let n = ((w[1] - w[0]).norm() / max_segment_mm).ceil().max(1.0) as usize;
        for k in 0..n {
            points.push((i, w[0] + (w[1] - w[0]) * (k as f64 / n as f64)));
        }
    }
    if let Some(last) = path.last() {
        points.push((path.len() - 1, *last));
    }
    let embedded = points
        .iter()
        .map(|(i, p)| embed_point(nodes, elements, p).ok_or(*i))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(embedded
        .windows(2)
        .map(|e| TrussElement {
            ends: [e[0], e[1]],
            section,
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_cube() -> (Vec<Vector3<f64>>, [usize; 8]) {
        let c = [
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 1.5, 0.0],
            [0.0, 1.5, 0.0],
            [0.0, 0.0, 1.0],
            [2.0, 0.0, 1.0],
            [2.0, 1.5, 1.0],
            [0.0, 1.5, 1.0],
        ];
        (
            c.iter().map(|v| Vector3::new(v[0], v[1], v[2])).collect(),
            std::array::from_fn(|a| a),
        )
    }

    fn segment(nodes: &[Vector3<f64>], el: [usize; 8], tension_only: bool) -> TrussElement {
        let embed = |p: Vector3<f64>| embed_point(nodes, &[el], &p).unwrap();
        TrussElement {
            ends: [
                embed(Vector3::new(0.3, 0.4, 0.2)),
                embed(Vector3::new(1.7, 1.1, 0.9)),
            ],
            section: TrussSection {
                area_mm2: 0.05,
                youngs_modulus_mpa: 7e4,
                tension_only,
            },
        }
    }

    #[test]
    fn an_embedded_point_is_where_the_trilinear_map_puts_it() {
        let (mut nodes, el) = unit_cube();
        nodes[6] += Vector3::new(0.3, -0.2, 0.25); // a distorted hexahedron
        let p = Vector3::new(1.1, 0.7, 0.6);
        let e = embed_point(&nodes, &[el], &p).unwrap();
        let back = e.position(|a| nodes[a]);
        assert!((back - p).norm() < 1e-12, "{back} vs {p}");
        assert!((e.weights.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        assert!(embed_point(&nodes, &[el], &Vector3::new(2.5, 0.7, 0.6)).is_none());
    }

    #[test]
    fn force_and_tangent_are_the_energys_derivatives() {
        let (nodes, el) = unit_cube();
        let t = segment(&nodes, el, false);
        // A stretch with a rotation: every node moved.
        let u: Vec<f64> = (0..24)
            .map(|k| {
                0.05 * ((k as f64) * 0.7).sin() + if k % 3 == 0 { 0.01 * k as f64 } else { 0.0 }
            })
            .collect();
        let (_, f, k) = truss_response(&t, &nodes, &u);
        let dofs = t.nodes();
        let h = 1e-6;
        let mut worst_f: f64 = 0.0;
        let mut worst_k: f64 = 0.0;
        for i in 0..TRUSS_DOFS {
            let d = 3 * dofs[i / 3] + i % 3;
            // Entries of repeated nodes sum: compare per mesh dof, first occurrence only.
            if (0..i).any(|j| 3 * dofs[j / 3] + j % 3 == d) {
                continue;
            }
            let (mut up, mut dn) = (u.clone(), u.clone());
            up[d] += h;
            dn[d] -= h;
            let (eu, fu, _) = truss_response(&t, &nodes, &up);
            let (ed, fd, _) = truss_response(&t, &nodes, &dn);
            let fi: f64 = (0..TRUSS_DOFS)
                .filter(|j| 3 * dofs[j / 3] + j % 3 == d)
                .map(|j| f[j])
                .sum();
            worst_f = worst_f.max(((eu - ed) / (2.0 * h) - fi).abs());
            for j in 0..TRUSS_DOFS {
                let kij: f64 = (0..TRUSS_DOFS)
                    .filter(|m| 3 * dofs[m / 3] + m % 3 == d)
                    .map(|m| k[(m, j)])
                    .sum();
                worst_k = worst_k.max(((fu[j] - fd[j]) / (2.0 * h) - kij).abs());
            }
        }
        let scale = f.amax().max(1e-12);
        assert!(worst_f < 1e-6 * scale, "force {worst_f} vs {scale}");
        assert!(
            worst_k < 1e-5 * k.amax(),
            "tangent {worst_k} vs {}",
            k.amax()
        );
    }

    #[test]
    fn a_bar_carries_the_saint_venant_kirchhoff_force_and_a_cable_none_in_compression() {
        let (nodes, el) = unit_cube();
        let section = TrussSection {
            area_mm2: 0.2,
            youngs_modulus_mpa: 1000.0,
            tension_only: true,
        };
        // A bar from node 0 to node 1 (length 2) stretched by 10% along x.
        let t = TrussElement {
            ends: [EmbeddedPoint::at_node(0), EmbeddedPoint::at_node(1)],
            section,
        };
        let _ = el;
        let mut u = vec![0.0; 24];
        u[3] = 0.2;
        let (_, f, _) = truss_response(&t, &nodes, &u);
        // Green strain (1.1² − 1)/2 = 0.105; S = 105 MPa; axial force A S λ = 0.2 * 105 * 1.1.
        let exact = 0.2 * 105.0 * 1.1;
        assert!((f[24] - exact).abs() < 1e-9 * exact, "{} vs {exact}", f[24]);
        assert!((f[0] + exact).abs() < 1e-9 * exact);
        u[3] = -0.2;
        let (e, f, k) = truss_response(&t, &nodes, &u);
        assert_eq!((e, f.amax(), k.amax()), (0.0, 0.0, 0.0));
    }
}
