//! Quadratic tetrahedra (10 nodes) with a mixed displacement-pressure formulation for
//! nearly incompressible silicone: the element class of Abaqus C3D10H and ANSYS
//! SOLID187 in mixed u-P, here the P2/P0 pair.
//!
//! Geometry: isoparametric, volume coordinates L0 = 1 − ξ − η − ζ, L1 = ξ, L2 = η,
//! L3 = ζ; corner nodes N = L(2L − 1), mid-edge nodes N = 4 L_i L_j; node order that of
//! Abaqus/CalculiX C3D10 (corners 0-3, then the mid-nodes of edges 01, 12, 20, 03, 13,
//! 23, [`EDGES`]). Stiffness by the 4-point Gauss rule (degree 2, positive weights):
//! on a straight-edged tetrahedron the shape-function gradients are linear, so it
//! integrates the small-strain stiffness exactly, and it is the rule of C3D10; the
//! 5-point rule (degree 3) has a negative weight, which can make the tangent of a
//! stiffening hyperelastic material indefinite, for no gain in the element's order. On
//! a curved tetrahedron (mid-nodes off the chords) ∫ ∇N dV is of degree 3 and the patch
//! test holds only to the quadrature error: mid-nodes inside the body belong at the
//! edges' midpoints.
//!
//! Formulation: the three-field form of Simo, Taylor & Pister (1985) with the
//! dilatation θ and the pressure p constant per element (P0), condensed at the element:
//! Π_e = Σ_gp w W_iso(F) + V_e U(v_e / V_e), v_e = ∫ J dV the current volume. The
//! condensed pressure is p_e = U'(v_e / V_e), the mixed u-P solution with a discontinuous
//! constant pressure; the global system stays displacement-only, as with the Q1/P0
//! hexahedron of [`super::hex`], and the tangent is the Hessian of Π_e: symmetric.
//!
//! Why P0 and not a discontinuous linear pressure (P1, 4 per element): by Hughes'
//! constraint count (The Finite Element Method, 1987, ch. 4), a large tetrahedral mesh has about
//! 6 tetrahedra and 8 nodes (vertices and edges) per vertex, 24 displacement equations
//! against 6 constraints with P0 (ratio 4, above the ideal 3 of 3D: no locking) and 24
//! with P1 (ratio 1: locks). P2/P1-discontinuous is also not inf-sup stable without the
//! cubic bubbles of the Crouzeix-Raviart element, so its pressures oscillate, while
//! P2/P0 is inf-sup stable (Boffi, Brezzi & Fortin, Mixed Finite Element Methods and
//! Applications, 2013, ch. 8): no checkerboard mode. The price is a pressure of first order only, constant per element. One
//! element alone has, beside its rigid motions, the 3 zero-energy modes of the special
//! conformal fields 2 (a·x) x − |x|² a, whose strain is a pure dilatation of zero mean;
//! neighbours and supports remove them (the trace-free Korn inequality of the continuum).
//!
//! [`taylor_hood`] is the element with a continuous linear pressure (P2/P1), the one the
//! solver uses: P0 leaves the dilatation free to jump between elements, and a wall one
//! element thick bends too easily (`verify`'s cantilever wall).
//!
//! [`Formulation::Displacement`] is the plain element (U(J) at every Gauss point), kept
//! to show the locking the mixed one avoids (tests in `verify`).

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::material::{HyperelasticMaterial, Yeoh};

/// Element stiffness (30 x 30).
pub type Tet10Matrix = SMatrix<f64, 30, 30>;
/// Element force vector (30).
pub type Tet10Vector = SVector<f64, 30>;

/// The corners of each edge; edge k's mid-node is local node 4 + k.
pub const EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]];

/// The 4 faces as 6-node triangles (corners, then the mid-nodes of edges c0c1, c1c2,
/// c2c0), counter-clockwise seen from outside: the order of
/// [`super::pressure_tri6`], normal out of the element.
pub const FACES: [[usize; 6]; 4] = [
    [0, 2, 1, 6, 5, 4],
    [0, 1, 3, 4, 8, 7],
    [1, 2, 3, 5, 9, 8],
    [2, 0, 3, 6, 7, 9],
];

const GA: f64 = 0.585_410_196_624_968_5; // (5 + 3√5) / 20
const GB: f64 = 0.138_196_601_125_010_5; // (5 − √5) / 20
/// Gauss points in volume coordinates (L0..L3); each weight is 1/24 of the reference
/// tetrahedron's volume 1/6.
const GAUSS: [[f64; 4]; 4] = [
    [GA, GB, GB, GB],
    [GB, GA, GB, GB],
    [GB, GB, GA, GB],
    [GB, GB, GB, GA],
];
const GAUSS_WEIGHT: f64 = 1.0 / 24.0;

/// The orders in which a path from a cube's corner (0, 0, 0) to (1, 1, 1) takes the
/// axes: each is one of the six tetrahedra of the cube's Kuhn (Freudenthal) cut.
pub const KUHN_AXIS_ORDERS: [[usize; 3]; 6] = [
    [0, 1, 2],
    [0, 2, 1],
    [1, 0, 2],
    [1, 2, 0],
    [2, 0, 1],
    [2, 1, 0],
];

/// Shape functions and their derivatives with respect to (ξ, η, ζ) at volume
/// coordinates `l`.
pub fn shape(l: &[f64; 4]) -> ([f64; 10], [Vector3<f64>; 10]) {
    let mut n = [0.0; 10];
    // dN/dL_i, then dN/dξ_k = dN/dL_{k+1} − dN/dL_0.
    let mut dl = [[0.0; 4]; 10];
    for a in 0..4 {
        n[a] = l[a] * (2.0 * l[a] - 1.0);
        dl[a][a] = 4.0 * l[a] - 1.0;
    }
    for (k, &[i, j]) in EDGES.iter().enumerate() {
        n[4 + k] = 4.0 * l[i] * l[j];
        dl[4 + k][i] = 4.0 * l[j];
        dl[4 + k][j] = 4.0 * l[i];
    }
    let dn = dl.map(|d| Vector3::new(d[1] - d[0], d[2] - d[0], d[3] - d[0]));
    (n, dn)
}

/// Reference geometry of a 10-node tetrahedron: shape-function gradients and weights at
/// the Gauss points.
#[derive(Debug, Clone)]
pub struct Tet10Geometry {
    /// dN_a/dX_J per Gauss point: `grads[g][a]`.
    pub grads: [[Vector3<f64>; 10]; 4],
    /// Reference volume weight per Gauss point (Gauss weight times det ∂X/∂ξ).
    pub weights: [f64; 4],
    /// Reference volume V_e (to the rule: exact for straight edges).
    pub volume: f64,
}

impl Tet10Geometry {
    /// Precomputes the geometry from the 10 node positions (local order above). `None`
    /// when the element is inverted or degenerate at a Gauss point.
    pub fn new(x: &[Vector3<f64>; 10]) -> Option<Self> {
        let mut grads = [[Vector3::zeros(); 10]; 4];
        let mut weights = [0.0; 4];
        for (g, l) in GAUSS.iter().enumerate() {
            let (_, dn) = shape(l);
            let mut jac = Matrix3::zeros();
            for a in 0..10 {
                jac += x[a] * dn[a].transpose();
            }
            let det = jac.determinant();
            if !(det > 0.0) {
                return None;
            }
            let inv_t = jac.try_inverse()?.transpose();
            for a in 0..10 {
                grads[g][a] = inv_t * dn[a];
            }
            weights[g] = GAUSS_WEIGHT * det;
        }
        Some(Self {
            grads,
            weights,
            volume: weights.iter().sum(),
        })
    }

    /// Deformation gradient at Gauss point `g` from the nodal displacements.
    pub fn deformation_gradient(&self, g: usize, u: &[Vector3<f64>; 10]) -> Matrix3<f64> {
        let mut f = Matrix3::identity();
        for a in 0..10 {
            f += u[a] * self.grads[g][a].transpose();
        }
        f
    }
}

/// How the volumetric energy is integrated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Formulation {
    /// Mixed u-P with one pressure per element (P2/P0), condensed: V_e U(v_e / V_e).
    MixedP0,
    /// Displacement only: Σ_gp w U(J) (locks when ν → 0.5).
    Displacement,
}

/// The element's condensed pressure p_e = U'(v_e / V_e), MPa (the mixed form's
/// pressure, positive in tension). `None` for an inverted element.
pub fn element_pressure(
    geom: &Tet10Geometry,
    material: &Yeoh,
    u: &[Vector3<f64>; 10],
) -> Option<f64> {
    let mut v = 0.0;
    for g in 0..4 {
        let j = geom.deformation_gradient(g, u).determinant();
        if !(j > 0.0) {
            return None;
        }
        v += geom.weights[g] * j;
    }
    Some(material.du(v / geom.volume))
}

/// ∫ N_a dV of each node over the reference element (a consistent body load's weights:
/// negative at the corners, as for every quadratic tetrahedron).
pub fn nodal_volumes(geom: &Tet10Geometry) -> [f64; 10] {
    let mut v = [0.0; 10];
    for (l, w) in GAUSS.iter().zip(geom.weights) {
        let (n, _) = shape(l);
        for a in 0..10 {
            v[a] += w * n[a];
        }
    }
    v
}

/// The element's Cauchy stress, MPa: the isochoric part averaged over the current
/// volume plus the condensed pressure (as the hexahedron's). `None` when inverted.
pub fn element_cauchy_stress(
    geom: &Tet10Geometry,
    material: &Yeoh,
    u: &[Vector3<f64>; 10],
) -> Option<Matrix3<f64>> {
    let iso = material.isochoric();
    let mut sum = Matrix3::zeros();
    let mut v = 0.0;
    for g in 0..4 {
        let f = geom.deformation_gradient(g, u);
        let j = f.determinant();
        if !(j > 0.0) {
            return None;
        }
        // σ_iso J w = P_iso Fᵀ w: volume-weighted average over the current element.
        sum += iso.first_piola(&f) * f.transpose() * geom.weights[g];
        v += j * geom.weights[g];
    }
    Some(sum / v + Matrix3::identity() * material.du(v / geom.volume))
}

/// The displacement-dependent parts of an element at nodal displacements `u`: isochoric
/// energy, force and tangent, the current volume v = ∫ J dV, its gradient G = ∂v/∂u and
/// Hessian H = ∂²v/∂u² (what the solver's three-field iteration combines with the
/// element's dilatation and pressure, as for the hexahedron). `None` when a Gauss point
/// is inverted (J <= 0).
pub struct Kinematics {
    /// Isochoric energy.
    pub energy_iso: f64,
    /// Isochoric internal force.
    pub force_iso: Tet10Vector,
    /// Isochoric tangent.
    pub k_iso: Tet10Matrix,
    /// Current volume.
    pub v: f64,
    /// ∂v/∂u.
    pub g: Tet10Vector,
    /// ∂²v/∂u².
    pub h: Tet10Matrix,
    /// J at each Gauss point.
    pub js: [f64; 4],
}

/// [`Kinematics`] of one element; with `point_volumes` the volume's gradient and Hessian
/// of each Gauss point are also handed to it (`g`, `h` of that point, J).
pub fn kinematics(
    geom: &Tet10Geometry,
    material: &Yeoh,
    u: &[Vector3<f64>; 10],
    mut point_volumes: Option<&mut dyn FnMut(&Tet10Vector, &Tet10Matrix, f64)>,
) -> Option<Kinematics> {
    let fs: [Matrix3<f64>; 4] = std::array::from_fn(|g| geom.deformation_gradient(g, u));
    let js = fs.map(|f| f.determinant());
    if js.iter().any(|j| !(*j > 0.0)) {
        return None;
    }
    let iso = material.isochoric();
    let mut k = Kinematics {
        energy_iso: 0.0,
        force_iso: Tet10Vector::zeros(),
        k_iso: Tet10Matrix::zeros(),
        v: 0.0,
        g: Tet10Vector::zeros(),
        h: Tet10Matrix::zeros(),
        js,
    };
    for g in 0..4 {
        let (f, j, w) = (fs[g], js[g], geom.weights[g]);
        let grads = &geom.grads[g];
        let fit = f.try_inverse()?.transpose();
        let p = iso.first_piola(&f);
        let a = iso.tangent(&f);
        k.energy_iso += w * iso.energy(&f);
        k.v += w * j;
        // q_a = F⁻ᵀ ∇N_a: ∂J/∂u_a = J q_a, and
        // ∂²J/∂u_a,i∂u_b,k = J (q_a,i q_b,k − q_b,i q_a,k).
        let q: [Vector3<f64>; 10] = std::array::from_fn(|an| fit * grads[an]);
        let mut gp = Tet10Vector::zeros();
        let mut hp = Tet10Matrix::zeros();
        for an in 0..10 {
            let pa = p * grads[an];
            for i in 0..3 {
                k.force_iso[3 * an + i] += w * pa[i];
                gp[3 * an + i] = w * j * q[an][i];
            }
        }
        // The tangent's block (a, b) is ∇N_a · A · ∇N_b: A contracted with ∇N_a once per
        // node (ca[a][(i, 3 k + l)] = Σ_j ∇N_a,j A_ij,kl), then with ∇N_b per pair. Both
        // blocks are symmetric in (a, i) <-> (b, k) (A has major symmetry), so each pair
        // a < b is computed once and mirrored.
        let ca: [[f64; 27]; 10] = std::array::from_fn(|an| {
            let ga = grads[an];
            std::array::from_fn(|m| {
                let (i, col) = (m / 9, m % 9);
                ga[0] * a[(3 * i, col)] + ga[1] * a[(3 * i + 1, col)] + ga[2] * a[(3 * i + 2, col)]
            })
        });
        for an in 0..10 {
            for bn in an..10 {
                let gb = grads[bn];
                for i in 0..3 {
                    for kk in 0..3 {
                        let c = &ca[an][9 * i + 3 * kk..9 * i + 3 * kk + 3];
                        let s = w * (c[0] * gb[0] + c[1] * gb[1] + c[2] * gb[2]);
                        let h = w * j * (q[an][i] * q[bn][kk] - q[bn][i] * q[an][kk]);
                        let (r, col) = (3 * an + i, 3 * bn + kk);
                        k.k_iso[(r, col)] += s;
                        hp[(r, col)] = h;
                        if bn != an {
                            k.k_iso[(col, r)] += s;
                            hp[(col, r)] = h;
                        }
                    }
                }
            }
        }
        k.g += gp;
        k.h += hp;
        if let Some(each) = point_volumes.as_mut() {
            each(&gp, &hp, j);
        }
    }
    Some(k)
}

/// Energy, internal force and consistent tangent of one element at nodal displacements
/// `u`, its pressure condensed exactly (`MixedP0`: p = U'(v / V)) or the plain
/// displacement element. `None` when a Gauss point is inverted (J <= 0).
pub fn element_response(
    geom: &Tet10Geometry,
    material: &Yeoh,
    u: &[Vector3<f64>; 10],
    formulation: Formulation,
) -> Option<(f64, Tet10Vector, Tet10Matrix)> {
    match formulation {
        Formulation::MixedP0 => {
            let k = kinematics(geom, material, u, None)?;
            let jbar = k.v / geom.volume;
            let (du, ddu) = (material.du(jbar), material.ddu(jbar));
            Some((
                k.energy_iso + geom.volume * material.u(jbar),
                k.force_iso + k.g * du,
                k.k_iso + k.h * du + k.g * k.g.transpose() * (ddu / geom.volume),
            ))
        }
        Formulation::Displacement => {
            // U(J) at every Gauss point: Σ w U(J_g), its gradient U'(J_g) G_g and Hessian
            // U'(J_g) H_g + U''(J_g) G_g G_gᵀ / w_g.
            let mut energy = 0.0;
            let mut force = Tet10Vector::zeros();
            let mut tangent = Tet10Matrix::zeros();
            let mut point = 0;
            let mut each = |gp: &Tet10Vector, hp: &Tet10Matrix, j: f64| {
                let w = geom.weights[point];
                point += 1;
                energy += w * material.u(j);
                force += gp * material.du(j);
                tangent += hp * material.du(j) + gp * gp.transpose() * (material.ddu(j) / w);
            };
            let k = kinematics(geom, material, u, Some(&mut each))?;
            Some((
                k.energy_iso + energy,
                k.force_iso + force,
                k.k_iso + tangent,
            ))
        }
    }
}

pub mod taylor_hood;

#[cfg(test)]
mod verify;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::material::MaterialPreset;

    /// A tetrahedron with curved edges (mid-nodes moved off the chords).
    pub(super) fn curved() -> [Vector3<f64>; 10] {
        let c = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(2.0, 0.1, -0.1),
            Vector3::new(0.3, 1.8, 0.2),
            Vector3::new(0.2, 0.4, 1.5),
        ];
        let bumps = [
            Vector3::new(0.05, -0.1, 0.02),
            Vector3::new(0.1, 0.08, -0.03),
            Vector3::new(-0.06, 0.02, 0.05),
            Vector3::new(0.04, -0.05, 0.0),
            Vector3::new(0.0, 0.07, 0.06),
            Vector3::new(-0.03, 0.0, -0.08),
        ];
        std::array::from_fn(|a| {
            if a < 4 {
                c[a]
            } else {
                let [i, j] = EDGES[a - 4];
                0.5 * (c[i] + c[j]) + bumps[a - 4]
            }
        })
    }

    fn sample_u() -> [Vector3<f64>; 10] {
        std::array::from_fn(|a| {
            let t = a as f64;
            Vector3::new(
                0.06 * (t * 0.7).sin(),
                0.08 * (t * 1.3).cos() - 0.05,
                -0.04 * (t * 0.4).sin(),
            )
        })
    }

    #[test]
    fn shape_functions_are_a_partition_of_unity_and_nodal() {
        let nodes: [[f64; 4]; 10] = std::array::from_fn(|a| {
            let mut l = [0.0; 4];
            if a < 4 {
                l[a] = 1.0;
            } else {
                let [i, j] = EDGES[a - 4];
                l[i] = 0.5;
                l[j] = 0.5;
            }
            l
        });
        for (b, l) in nodes.iter().enumerate() {
            let (n, dn) = shape(l);
            for a in 0..10 {
                let want = if a == b { 1.0 } else { 0.0 };
                assert!((n[a] - want).abs() < 1e-15, "N_{a} at node {b}: {}", n[a]);
            }
            assert!(dn.iter().sum::<Vector3<f64>>().norm() < 1e-14);
        }
        // The derivatives against central differences in (ξ, η, ζ).
        let l = [0.2, 0.3, 0.1, 0.4];
        let (_, dn) = shape(&l);
        let h = 1e-6;
        for k in 0..3 {
            let (mut lp, mut lm) = (l, l);
            lp[k + 1] += h;
            lp[0] -= h;
            lm[k + 1] -= h;
            lm[0] += h;
            let (np, nm) = (shape(&lp).0, shape(&lm).0);
            for a in 0..10 {
                let fd = (np[a] - nm[a]) / (2.0 * h);
                assert!((fd - dn[a][k]).abs() < 1e-9, "dN_{a}/dξ_{k}");
            }
        }
    }

    #[test]
    fn straight_tetrahedron_volume_is_exact() {
        let mut x = curved();
        for (k, &[i, j]) in EDGES.iter().enumerate() {
            x[4 + k] = 0.5 * (x[i] + x[j]);
        }
        let exact = (x[1] - x[0]).cross(&(x[2] - x[0])).dot(&(x[3] - x[0])) / 6.0;
        let geom = Tet10Geometry::new(&x).unwrap();
        assert!(
            (geom.volume - exact).abs() < 1e-14 * exact,
            "{}",
            geom.volume
        );
        // Inverted: mirrored.
        for p in x.iter_mut() {
            p.z = -p.z;
        }
        assert!(Tet10Geometry::new(&x).is_none());
    }

    /// The force is the central difference of the energy, the tangent that of the
    /// force (30 columns), and the tangent symmetric: both formulations, κ = 100 μ and
    /// the default 1000 μ.
    #[test]
    fn force_and_tangent_are_derivatives_of_the_energy() {
        let geom = Tet10Geometry::new(&curved()).unwrap();
        let base = MaterialPreset::Proposed.yeoh();
        let soft = Yeoh {
            bulk_modulus: 100.0 * 2.0 * base.c1,
            ..base
        };
        let u0 = sample_u();
        for (m, form) in [
            (soft, Formulation::MixedP0),
            (base, Formulation::MixedP0),
            (soft, Formulation::Displacement),
        ] {
            let response = |d: usize, s: f64| {
                let mut u = u0;
                u[d / 3][d % 3] += s;
                element_response(&geom, &m, &u, form).unwrap()
            };
            let (_, f, k) = response(0, 0.0);
            let h = 1e-6;
            for d in 0..30 {
                let ((ep, fp, _), (em, fm, _)) = (response(d, h), response(d, -h));
                let fd = (ep - em) / (2.0 * h);
                // Central differences: truncation ~h² times the third derivative.
                assert!(
                    (fd - f[d]).abs() < 1e-6 * f.norm(),
                    "{form:?}: f[{d}] {} vs {fd}",
                    f[d]
                );
                let col = (fp - fm) / (2.0 * h);
                for r in 0..30 {
                    assert!(
                        (col[r] - k[(r, d)]).abs() < 1e-6 * k.norm(),
                        "{form:?}: K[{r},{d}] {} vs {}",
                        k[(r, d)],
                        col[r]
                    );
                }
            }
            assert!((k - k.transpose()).norm() < 1e-12 * k.norm(), "symmetric");
        }
    }

    #[test]
    fn rigid_motion_is_stress_free() {
        let x = curved();
        let geom = Tet10Geometry::new(&x).unwrap();
        let m = MaterialPreset::Proposed.yeoh();
        let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.5);
        let u: [Vector3<f64>; 10] =
            std::array::from_fn(|a| r * x[a] - x[a] + Vector3::new(1.0, 2.0, 3.0));
        for form in [Formulation::MixedP0, Formulation::Displacement] {
            let (e, f, _) = element_response(&geom, &m, &u, form).unwrap();
            assert!(e.abs() < 1e-12 && f.norm() < 1e-10, "{e} {}", f.norm());
        }
        assert!(element_pressure(&geom, &m, &u).unwrap().abs() < 1e-12);
    }

    /// At rest the plain element's zero-energy modes are the 6 rigid motions; the mixed
    /// element's also the 3 special conformal fields u = 2 (a·x) x − |x|² a (x from the
    /// centroid), whose strain (a·x) I is a pure dilatation of zero mean: the kernel of
    /// the trace-free strain, which neighbouring elements and supports remove (the
    /// trace-free Korn inequality), as for the continuum.
    #[test]
    fn zero_energy_modes_are_the_rigid_and_conformal_ones() {
        let mut x = curved();
        for (k, &[i, j]) in EDGES.iter().enumerate() {
            x[4 + k] = 0.5 * (x[i] + x[j]);
        }
        let geom = Tet10Geometry::new(&x).unwrap();
        let m = MaterialPreset::Proposed.yeoh();
        let zero = [Vector3::zeros(); 10];
        for (form, modes) in [(Formulation::Displacement, 6), (Formulation::MixedP0, 9)] {
            let (_, _, k) = element_response(&geom, &m, &zero, form).unwrap();
            let eig = k.symmetric_eigenvalues();
            let count = eig.iter().filter(|l| l.abs() < 1e-10 * k.norm()).count();
            assert_eq!(count, modes, "{form:?}: {eig}");
        }
        let c: Vector3<f64> = x.iter().take(4).sum::<Vector3<f64>>() / 4.0;
        let a = Vector3::new(0.3, -0.2, 0.5);
        let mode: Tet10Vector = Tet10Vector::from_iterator(x.iter().flat_map(|p| {
            let y = p - c;
            let v = 2.0 * a.dot(&y) * y - y.norm_squared() * a;
            [v.x, v.y, v.z]
        }));
        let (_, _, k) = element_response(&geom, &m, &zero, Formulation::MixedP0).unwrap();
        assert!((k * mode).norm() < 1e-12 * k.norm() * mode.norm());
    }
}
