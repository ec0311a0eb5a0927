//! Trilinear hexahedra (8 nodes, 2x2x2 Gauss points) with the Q1/P0 mean-dilatation
//! treatment of the volumetric energy (Simo, Taylor & Pister 1985).
//!
//! Why this element: nearly incompressible silicone locks plain linear elements. With an
//! energy split W = W_iso(F) + U(J), Q1/P0 evaluates the isochoric part at every Gauss
//! point and the volumetric part once per element with the element's mean dilatation
//! J̄ = v_e / V_e (current over reference volume). The element energy
//! Π_e = Σ_gp w W_iso(F) + V_e U(v_e / V_e) is a function of the nodal positions only, so
//! the internal force is its gradient and the tangent its Hessian: symmetric, which
//! lets the solver use a sparse Cholesky factorization. Structured hex meshes of the
//! actuator's box-shaped walls and cavities suit it.
//!
//! The solver ([`super::solve`]) iterates on the three-field form of the same element
//! (displacement u, element dilatation θ_e and pressure p_e, Simo-Taylor-Pister), with θ
//! and p condensed per element: at convergence θ_e = v_e / V_e and p_e = U'(θ_e), the
//! solution of the energy above, but a Newton step no longer turns the second-order
//! volume error of a linearized rotation into a large pressure (κ θ² with κ ~ 1000 μ),
//! which made the displacement-only iteration crawl on the bending actuator.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::material::{HyperelasticMaterial, Yeoh};

/// Element stiffness (24 x 24).
pub type ElementMatrix = SMatrix<f64, 24, 24>;
/// Element force vector (24).
pub type ElementVector = SVector<f64, 24>;

const GP: f64 = 0.577_350_269_189_625_8; // 1/sqrt(3)

/// Incompatible modes of the enhanced element, 1 − ξ_i² for i = 1..3, each with a
/// vector amplitude.
pub const MODES: usize = 3;
/// Unknowns of the element with incompatible modes: 24 nodal, then 9 of the modes.
pub const ENHANCED_DOFS: usize = 24 + 3 * MODES;
/// The amplitudes of an element's incompatible modes (3 per mode).
pub type Modes = [f64; 3 * MODES];

/// Local node order: (-1,-1,-1), (1,-1,-1), (1,1,-1), (-1,1,-1), then the same at +1.
pub(crate) const CORNERS: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];

/// Shape-function derivatives with respect to the reference coordinates at each Gauss
/// point, and the Gauss weights times det(∂X/∂ξ).
#[derive(Debug, Clone)]
pub struct HexGeometry {
    /// dN_a/dX_J per Gauss point: `grads[g][a]`.
    pub grads: [[Vector3<f64>; 8]; 8],
    /// Reference volume weight per Gauss point.
    pub weights: [f64; 8],
    /// Reference volume V_e.
    pub volume: f64,
    /// Gradients of the incompatible modes 1 − ξ_i² at each Gauss point, in the
    /// patch-test-passing form G̃_i = (det J₀ / det J) J₀⁻ᵀ ∂(1 − ξ_i²)/∂ξ (J₀ the
    /// Jacobian at the centre): `enhanced[g][i]`.
    pub enhanced: [[Vector3<f64>; MODES]; 8],
}

impl HexGeometry {
    /// Precomputes the reference geometry of a hexahedron from its 8 node positions
    /// (local order above). `None` when the element is inverted or degenerate.
    pub fn new(x: &[Vector3<f64>; 8]) -> Option<Self> {
        let mut grads = [[Vector3::zeros(); 8]; 8];
        let mut weights = [0.0; 8];
        // The Jacobian at the centre, where dN_a/dξ = n_a / 8.
        let mut jac0 = Matrix3::zeros();
        for (a, n) in CORNERS.iter().enumerate() {
            jac0 += x[a] * Vector3::new(n[0], n[1], n[2]).transpose() * 0.125;
        }
        let det0 = jac0.determinant();
        let inv0t = jac0.try_inverse()?.transpose();
        let mut enhanced = [[Vector3::zeros(); MODES]; 8];
        for (g, c) in CORNERS.iter().enumerate() {
            let xi = [c[0] * GP, c[1] * GP, c[2] * GP];
            let mut dn = [Vector3::zeros(); 8];
            for (a, n) in CORNERS.iter().enumerate() {
                let f = |i: usize| 1.0 + n[i] * xi[i];
                dn[a] = Vector3::new(
                    0.125 * n[0] * f(1) * f(2),
                    0.125 * n[1] * f(0) * f(2),
                    0.125 * n[2] * f(0) * f(1),
                );
            }
            let mut jac = Matrix3::zeros();
            for a in 0..8 {
                jac += x[a] * dn[a].transpose();
            }
            let det = jac.determinant();
            let inv = jac.try_inverse()?;
            if det <= 0.0 {
                return None;
            }
            for a in 0..8 {
                grads[g][a] = inv.transpose() * dn[a];
            }
            weights[g] = det;
            for (i, m) in enhanced[g].iter_mut().enumerate() {
                let mut dm = Vector3::zeros();
                dm[i] = -2.0 * xi[i];
                *m = inv0t * dm * (det0 / det);
            }
        }
        if det0 <= 0.0 {
            return None;
        }
        Some(Self {
            grads,
            weights,
            volume: weights.iter().sum(),
            enhanced,
        })
    }

    /// Deformation gradient at Gauss point `g` from nodal displacements and, for the
    /// element with incompatible modes, the modes' amplitudes.
    pub fn deformation_gradient(
        &self,
        g: usize,
        u: &[Vector3<f64>; 8],
        modes: Option<&Modes>,
    ) -> Matrix3<f64> {
        let mut f = Matrix3::identity();
        for a in 0..8 {
            f += u[a] * self.grads[g][a].transpose();
        }
        if let Some(m) = modes {
            for i in 0..MODES {
                let ai = Vector3::new(m[3 * i], m[3 * i + 1], m[3 * i + 2]);
                f += ai * self.enhanced[g][i].transpose();
            }
        }
        f
    }

    /// The gradients of the 8 nodes and the 3 incompatible modes at Gauss point `g`.
    fn enhanced_grads(&self, g: usize) -> [Vector3<f64>; 8 + MODES] {
        std::array::from_fn(|a| {
            if a < 8 {
                self.grads[g][a]
            } else {
                self.enhanced[g][a - 8]
            }
        })
    }
}

/// ∫ N_a dV of each node (the nodal shares of a uniform body force).
pub fn nodal_volumes(geom: &HexGeometry) -> [f64; 8] {
    let mut out = [0.0; 8];
    for (g, c) in CORNERS.iter().enumerate() {
        for (a, n) in CORNERS.iter().enumerate() {
            let shape = 0.125
                * (1.0 + n[0] * c[0] * GP)
                * (1.0 + n[1] * c[1] * GP)
                * (1.0 + n[2] * c[2] * GP);
            out[a] += shape * geom.weights[g];
        }
    }
    out
}

/// Cauchy stress of an element, MPa: the isochoric part averaged over the Gauss points
/// (by current volume) plus the element's mean-dilatation pressure U'(J̄) I. `None` for
/// an inverted element.
pub fn element_cauchy_stress(
    geom: &HexGeometry,
    material: &Yeoh,
    u: &[Vector3<f64>; 8],
    modes: Option<&Modes>,
) -> Option<Matrix3<f64>> {
    let iso = material.isochoric();
    let mut sum = Matrix3::zeros();
    let mut v = 0.0;
    let mut pv = 0.0;
    for g in 0..8 {
        let f = geom.deformation_gradient(g, u, modes);
        let j = f.determinant();
        if j <= 0.0 {
            return None;
        }
        // σ_iso J w = P_iso Fᵀ w: volume-weighted average over the current element.
        sum += iso.first_piola(&f) * f.transpose() * geom.weights[g];
        v += j * geom.weights[g];
        pv += material.du(j) * j * geom.weights[g];
    }
    // The pressure: the element's mean dilatation's, or with the modes (a volume
    // constraint per Gauss point) the points' average over the current volume.
    let p = match modes {
        None => material.du(v / geom.volume),
        Some(_) => pv / v,
    };
    Some(sum / v + Matrix3::identity() * p)
}

/// The displacement-dependent parts of an element with `D = 3 N` unknowns (8 nodes, or 8
/// nodes and the 3 incompatible modes): isochoric energy, force and tangent (Gauss
/// points), the current volume v_e = ∫ J dV, its gradient G = ∂v/∂u and Hessian
/// H = ∂²v/∂u². `None` when an inverted Gauss point (J <= 0) is met.
pub struct Kinematics<const D: usize> {
    /// Isochoric energy.
    pub energy_iso: f64,
    /// Isochoric internal force.
    pub force_iso: SVector<f64, D>,
    /// Isochoric tangent.
    pub k_iso: SMatrix<f64, D, D>,
    /// Current volume.
    pub v: f64,
    /// ∂v/∂u.
    pub g: SVector<f64, D>,
    /// Σ_g c_g ∂²v_g/∂u², the Gauss points' volume Hessians weighted by the `c` given
    /// (all 1: ∂²v/∂u²; the points' pressures: the pressure term of the element with a
    /// volume constraint per point).
    pub h: SMatrix<f64, D, D>,
    /// Current volume of each Gauss point's share, v_g = w_g J_g.
    pub v_points: [f64; 8],
    /// ∂v_g/∂u of each Gauss point.
    pub g_points: [SVector<f64, D>; 8],
}

/// The kinematics of the plain element (8 nodes, 24 unknowns).
pub type ElementKinematics = Kinematics<24>;

/// Evaluates [`ElementKinematics`] at nodal displacements `u`.
pub fn element_kinematics(
    geom: &HexGeometry,
    material: &Yeoh,
    u: &[Vector3<f64>; 8],
) -> Option<ElementKinematics> {
    kinematics::<8, 24>(geom, material, u, |g| geom.grads[g], &[1.0; 8])
}

/// Evaluates the kinematics of the element with incompatible modes: unknowns the 24
/// nodal displacements `u`, then the 9 mode amplitudes `modes` (3 per mode); the volume
/// Hessian is Σ_g c_g ∂²v_g/∂u² with the weights `c` (the Gauss points' pressures).
pub fn enhanced_kinematics(
    geom: &HexGeometry,
    material: &Yeoh,
    u: &[Vector3<f64>; 8],
    modes: &Modes,
    c: &[f64; 8],
) -> Option<Kinematics<ENHANCED_DOFS>> {
    let d: [Vector3<f64>; 8 + MODES] = std::array::from_fn(|a| {
        if a < 8 {
            u[a]
        } else {
            let i = a - 8;
            Vector3::new(modes[3 * i], modes[3 * i + 1], modes[3 * i + 2])
        }
    });
    kinematics::<{ 8 + MODES }, ENHANCED_DOFS>(geom, material, &d, |g| geom.enhanced_grads(g), c)
}

fn kinematics<const N: usize, const D: usize>(
    geom: &HexGeometry,
    material: &Yeoh,
    u: &[Vector3<f64>; N],
    grads_at: impl Fn(usize) -> [Vector3<f64>; N],
    c: &[f64; 8],
) -> Option<Kinematics<D>> {
    debug_assert_eq!(D, 3 * N);
    let iso = material.isochoric();
    let mut energy = 0.0;
    let mut force = SVector::<f64, D>::zeros();
    let mut k = SMatrix::<f64, D, D>::zeros();
    let mut v = 0.0;
    let mut dv = SVector::<f64, D>::zeros(); // ∂v/∂u
    let mut hv = SMatrix::<f64, D, D>::zeros(); // Σ c_g ∂²v_g/∂u²
    let mut v_points = [0.0; 8];
    let mut g_points = [SVector::<f64, D>::zeros(); 8];
    for g in 0..8 {
        let grads = grads_at(g);
        let mut f = Matrix3::identity();
        for a in 0..N {
            f += u[a] * grads[a].transpose();
        }
        let j = f.determinant();
        if j <= 0.0 {
            return None;
        }
        let w = geom.weights[g];
        let fit = f.try_inverse()?.transpose();
        let p = iso.first_piola(&f);
        let a = iso.tangent(&f);
        energy += w * iso.energy(&f);
        v += w * j;
        v_points[g] = w * j;
        let wh = w * c[g];
        // Per node: P ∇N_a (force), q_a = F⁻ᵀ ∇N_a (∂J/∂u_a = J q_a), and
        // m_a[i][3k + l] = Σ_J ∇N_a,J A_iJkL: the tangent's blocks are then
        // K_ab,ik = Σ_L m_a[i][3k + l] ∇N_b,L and the volume Hessian's
        // H_ab,ik = J (q_a,i q_b,k − q_b,i q_a,k) (from ∂²J/∂F_iJ∂F_kL =
        // J (F⁻ᵀ_iJ F⁻ᵀ_kL − F⁻ᵀ_iL F⁻ᵀ_kJ)): O(8·81 + 64·27) per Gauss point instead of
        // O(576·9).
        let mut q = [Vector3::zeros(); N];
        let mut m = [[[0.0; 9]; 3]; N];
        for (an, ga) in grads.iter().enumerate() {
            let pa = p * ga;
            q[an] = fit * ga;
            for i in 0..3 {
                force[3 * an + i] += w * pa[i];
                g_points[g][3 * an + i] = w * j * q[an][i];
                for (kl, mv) in m[an][i].iter_mut().enumerate() {
                    *mv = ga[0] * a[(3 * i, kl)]
                        + ga[1] * a[(3 * i + 1, kl)]
                        + ga[2] * a[(3 * i + 2, kl)];
                }
            }
        }
        for an in 0..N {
            for (bn, gb) in grads.iter().enumerate().skip(an) {
                for i in 0..3 {
                    let mi = &m[an][i];
                    for kk in 0..3 {
                        let s =
                            mi[3 * kk] * gb[0] + mi[3 * kk + 1] * gb[1] + mi[3 * kk + 2] * gb[2];
                        let h = j * (q[an][i] * q[bn][kk] - q[bn][i] * q[an][kk]);
                        k[(3 * an + i, 3 * bn + kk)] += w * s;
                        hv[(3 * an + i, 3 * bn + kk)] += wh * h;
                    }
                }
            }
        }
        dv += g_points[g];
    }
    // Mirror the upper block triangle (b > a) into the lower one: both are symmetric.
    for an in 0..N {
        for bn in 0..an {
            for i in 0..3 {
                for kk in 0..3 {
                    let (r, c) = (3 * an + i, 3 * bn + kk);
                    k[(r, c)] = k[(c, r)];
                    hv[(r, c)] = hv[(c, r)];
                }
            }
        }
    }
    Some(Kinematics {
        energy_iso: energy,
        force_iso: force,
        k_iso: k,
        v,
        g: dv,
        h: hv,
        v_points,
        g_points,
    })
}

/// Energy, internal force and tangent of one element in the displacement-only form
/// (pressure slaved to the mean dilatation, p = U'(v_e / V_e)); with `modes`, the
/// element with incompatible modes at those amplitudes (force and tangent of the nodal
/// unknowns, the modes held). `None` when an inverted Gauss point (J <= 0) is met.
pub fn element_response(
    geom: &HexGeometry,
    material: &Yeoh,
    u: &[Vector3<f64>; 8],
    modes: Option<&Modes>,
) -> Option<(f64, ElementVector, ElementMatrix)> {
    if let Some(m) = modes {
        let (energy, force, k) = enhanced_response(geom, material, u, m)?;
        return Some((
            energy,
            force.fixed_rows::<24>(0).into_owned(),
            k.fixed_view::<24, 24>(0, 0).into_owned(),
        ));
    }
    let e = element_kinematics(geom, material, u)?;
    let (energy_iso, force_iso, k_iso, v, g, h) =
        (e.energy_iso, e.force_iso, e.k_iso, e.v, e.g, e.h);
    let jbar = v / geom.volume;
    if jbar <= 0.0 {
        return None;
    }
    let du = material.du(jbar);
    let ddu = material.ddu(jbar);
    let energy = energy_iso + geom.volume * material.u(jbar);
    let force = force_iso + g * du;
    let k = k_iso + g * g.transpose() * (ddu / geom.volume) + h * du;
    Some((energy, force, k))
}

/// Energy, force and tangent of the element with incompatible modes over all its 33
/// unknowns (nodes, then modes) in the displacement-only form: the volumetric energy
/// Σ_g w_g U(J_g) per Gauss point. `None` when an inverted Gauss point is met.
pub fn enhanced_response(
    geom: &HexGeometry,
    material: &Yeoh,
    u: &[Vector3<f64>; 8],
    modes: &Modes,
) -> Option<(
    f64,
    SVector<f64, ENHANCED_DOFS>,
    SMatrix<f64, ENHANCED_DOFS, ENHANCED_DOFS>,
)> {
    // The volume Hessians are weighted by the points' pressures U'(J_g).
    let c = std::array::from_fn(|g| {
        material.du(geom.deformation_gradient(g, u, Some(modes)).determinant())
    });
    let e = enhanced_kinematics(geom, material, u, modes, &c)?;
    let (mut energy, mut force, mut k) = (e.energy_iso, e.force_iso, e.k_iso + e.h);
    for g in 0..8 {
        let (w, j) = (geom.weights[g], e.v_points[g] / geom.weights[g]);
        energy += w * material.u(j);
        force += e.g_points[g] * material.du(j);
        k += e.g_points[g] * e.g_points[g].transpose() * (material.ddu(j) / w);
    }
    Some((energy, force, k))
}

/// The faces of a C3D8 element: CalculiX/Abaqus face k + 1 has these local nodes.
pub const C3D8_FACES: [[usize; 4]; 6] = [
    [0, 1, 2, 3],
    [4, 7, 6, 5],
    [0, 4, 5, 1],
    [1, 5, 6, 2],
    [2, 6, 7, 3],
    [3, 7, 4, 0],
];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::material::MaterialPreset;

    fn unit_cube() -> [Vector3<f64>; 8] {
        CORNERS.map(|c| {
            Vector3::new(
                0.5 * (c[0] + 1.0) * 2.0,
                0.5 * (c[1] + 1.0) * 1.5,
                0.5 * (c[2] + 1.0) * 1.2,
            )
        })
    }

    /// Asserts that a response's force and tangent are the central differences of its
    /// energy and force, and the tangent symmetric; `response(d, s)`: the response with
    /// unknown d moved by s.
    fn assert_derivatives<const D: usize>(
        response: impl Fn(usize, f64) -> (f64, SVector<f64, D>, SMatrix<f64, D, D>),
    ) {
        let (_, f, k) = response(0, 0.0);
        let h = 1e-6;
        for d in 0..D {
            let ((ep, fp, _), (em, fm, _)) = (response(d, h), response(d, -h));
            let fd = (ep - em) / (2.0 * h);
            assert!(
                (fd - f[d]).abs() < 1e-6 * f.norm().max(1.0),
                "f[{d}] {} vs {fd}",
                f[d]
            );
            let col = (fp - fm) / (2.0 * h);
            for r in 0..D {
                assert!(
                    (col[r] - k[(r, d)]).abs() < 1e-5 * k.norm(),
                    "K[{r},{d}] {} vs {}",
                    k[(r, d)],
                    col[r]
                );
            }
        }
        assert!(
            (k - k.transpose()).norm() < 1e-9 * k.norm(),
            "symmetric tangent"
        );
    }

    #[test]
    fn force_and_tangent_are_derivatives_of_the_energy() {
        let x = unit_cube();
        let geom = HexGeometry::new(&x).unwrap();
        assert!((geom.volume - 3.6).abs() < 1e-12);
        let m = MaterialPreset::Proposed.yeoh();
        let m = Yeoh {
            bulk_modulus: 20.0,
            ..m
        };
        let u: [Vector3<f64>; 8] = std::array::from_fn(|a| {
            let t = a as f64;
            Vector3::new(
                0.05 * (t * 0.7).sin(),
                0.08 * (t * 1.3).cos(),
                -0.04 * (t * 0.4).sin(),
            )
        });
        assert_derivatives::<24>(|d, s| {
            let mut uu = u;
            uu[d / 3][d % 3] += s;
            element_response(&geom, &m, &uu, None).unwrap()
        });
    }

    #[test]
    fn rigid_motion_is_stress_free() {
        let x = unit_cube();
        let geom = HexGeometry::new(&x).unwrap();
        let m = MaterialPreset::Proposed.yeoh();
        let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.5);
        let u: [Vector3<f64>; 8] =
            std::array::from_fn(|a| r * x[a] - x[a] + Vector3::new(1.0, 2.0, 3.0));
        let (e, f, _) = element_response(&geom, &m, &u, None).unwrap();
        assert!(e.abs() < 1e-12 && f.norm() < 1e-10, "{e} {}", f.norm());
    }

    /// A hexahedron distorted out of a box, so that the patch test means something.
    fn distorted() -> [Vector3<f64>; 8] {
        let mut x = unit_cube();
        x[2] += Vector3::new(0.3, -0.1, 0.2);
        x[4] += Vector3::new(-0.2, 0.15, 0.1);
        x[7] += Vector3::new(0.1, 0.2, -0.15);
        x
    }

    #[test]
    fn incompatible_modes_force_and_tangent_are_derivatives_of_the_energy() {
        let x = distorted();
        let geom = HexGeometry::new(&x).unwrap();
        let m = Yeoh {
            bulk_modulus: 20.0,
            ..MaterialPreset::Proposed.yeoh()
        };
        let u: [Vector3<f64>; 8] = std::array::from_fn(|a| {
            let t = a as f64;
            Vector3::new(
                0.05 * (t * 0.7).sin(),
                0.08 * (t * 1.3).cos(),
                -0.04 * (t * 0.4).sin(),
            )
        });
        let modes: Modes = std::array::from_fn(|i| 0.03 * ((i as f64) * 0.9).cos());
        assert_derivatives::<ENHANCED_DOFS>(|d, s| {
            let (mut uu, mut mm) = (u, modes);
            if d < 24 {
                uu[d / 3][d % 3] += s;
            } else {
                mm[d - 24] += s;
            }
            enhanced_response(&geom, &m, &uu, &mm).unwrap()
        });
    }

    #[test]
    fn incompatible_modes_pass_the_patch_test() {
        // A homogeneous deformation of a distorted element: the modes' forces vanish
        // (∫ G̃ dV = 0), so the modes stay at rest and the element's response is the
        // plain one's.
        let x = distorted();
        let geom = HexGeometry::new(&x).unwrap();
        let m = MaterialPreset::Proposed.yeoh();
        let f = Matrix3::new(1.2, 0.1, -0.05, 0.03, 0.9, 0.08, -0.1, 0.02, 1.05);
        let u: [Vector3<f64>; 8] = std::array::from_fn(|a| (f - Matrix3::identity()) * x[a]);
        let zero = [0.0; 3 * MODES];
        let (_, fe, _) = enhanced_response(&geom, &m, &u, &zero).unwrap();
        let (_, fp, _) = element_response(&geom, &m, &u, None).unwrap();
        let (_, fr, _) = element_response(&geom, &m, &u, Some(&zero)).unwrap();
        assert!((fr - fp).norm() < 1e-12 * fp.norm());
        let modes_force = fe.fixed_rows::<9>(24).norm();
        assert!(
            modes_force < 1e-12 * fp.norm(),
            "{modes_force} against {}",
            fp.norm()
        );
        assert!((fe.fixed_rows::<24>(0) - fp).norm() < 1e-12 * fp.norm());
        for i in 0..MODES {
            let mean: Vector3<f64> = (0..8).map(|g| geom.enhanced[g][i] * geom.weights[g]).sum();
            assert!(mean.norm() < 1e-14, "mode {i}: {mean}");
        }
    }
}
