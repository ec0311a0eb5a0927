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
}

impl HexGeometry {
    /// Precomputes the reference geometry of a hexahedron from its 8 node positions
    /// (local order above). `None` when the element is inverted or degenerate.
    pub fn new(x: &[Vector3<f64>; 8]) -> Option<Self> {
        let mut grads = [[Vector3::zeros(); 8]; 8];
        let mut weights = [0.0; 8];
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
        }
        Some(Self {
            grads,
            weights,
            volume: weights.iter().sum(),
        })
    }

    /// Deformation gradient at Gauss point `g` from nodal displacements.
    pub fn deformation_gradient(&self, g: usize, u: &[Vector3<f64>; 8]) -> Matrix3<f64> {
        let mut f = Matrix3::identity();
        for a in 0..8 {
            f += u[a] * self.grads[g][a].transpose();
        }
        f
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
) -> Option<Matrix3<f64>> {
    let iso = material.isochoric();
    let mut sum = Matrix3::zeros();
    let mut v = 0.0;
    for g in 0..8 {
        let f = geom.deformation_gradient(g, u);
        let j = f.determinant();
        if j <= 0.0 {
            return None;
        }
        // σ_iso J w = P_iso Fᵀ w: volume-weighted average over the current element.
        sum += iso.first_piola(&f) * f.transpose() * geom.weights[g];
        v += j * geom.weights[g];
    }
    let jbar = v / geom.volume;
    Some(sum / v + Matrix3::identity() * material.du(jbar))
}

/// The displacement-dependent parts of an element: isochoric energy, force and tangent
/// (Gauss points), the current volume v_e = ∫ J dV, its gradient G = ∂v/∂u and Hessian
/// H = ∂²v/∂u². `None` when an inverted Gauss point (J <= 0) is met.
pub struct ElementKinematics {
    /// Isochoric energy.
    pub energy_iso: f64,
    /// Isochoric internal force.
    pub force_iso: ElementVector,
    /// Isochoric tangent.
    pub k_iso: ElementMatrix,
    /// Current volume.
    pub v: f64,
    /// ∂v/∂u.
    pub g: ElementVector,
    /// ∂²v/∂u².
    pub h: ElementMatrix,
}

/// Evaluates [`ElementKinematics`] at nodal displacements `u`.
pub fn element_kinematics(
    geom: &HexGeometry,
    material: &Yeoh,
    u: &[Vector3<f64>; 8],
) -> Option<ElementKinematics> {
    let iso = material.isochoric();
    let mut energy = 0.0;
    let mut force = ElementVector::zeros();
    let mut k = ElementMatrix::zeros();
    let mut v = 0.0;
    let mut dv = ElementVector::zeros(); // ∂v/∂u
    let mut hv = ElementMatrix::zeros(); // ∂²v/∂u²
    for g in 0..8 {
        let f = geom.deformation_gradient(g, u);
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
        let grads = &geom.grads[g];
        // Per node: P ∇N_a (force), q_a = F⁻ᵀ ∇N_a (∂J/∂u_a = J q_a), and
        // m_a[i][3k + l] = Σ_J ∇N_a,J A_iJkL: the tangent's blocks are then
        // K_ab,ik = Σ_L m_a[i][3k + l] ∇N_b,L and the volume Hessian's
        // H_ab,ik = J (q_a,i q_b,k − q_b,i q_a,k) (from ∂²J/∂F_iJ∂F_kL =
        // J (F⁻ᵀ_iJ F⁻ᵀ_kL − F⁻ᵀ_iL F⁻ᵀ_kJ)): O(8·81 + 64·27) per Gauss point instead of
        // O(576·9).
        let mut q = [Vector3::zeros(); 8];
        let mut m = [[[0.0; 9]; 3]; 8];
        for (an, ga) in grads.iter().enumerate() {
            let pa = p * ga;
            q[an] = fit * ga;
            for i in 0..3 {
                force[3 * an + i] += w * pa[i];
                dv[3 * an + i] += w * j * q[an][i];
                for (kl, mv) in m[an][i].iter_mut().enumerate() {
                    *mv = ga[0] * a[(3 * i, kl)]
                        + ga[1] * a[(3 * i + 1, kl)]
                        + ga[2] * a[(3 * i + 2, kl)];
                }
            }
        }
        for an in 0..8 {
            for (bn, gb) in grads.iter().enumerate().skip(an) {
                for i in 0..3 {
                    let mi = &m[an][i];
                    for kk in 0..3 {
                        let s =
                            mi[3 * kk] * gb[0] + mi[3 * kk + 1] * gb[1] + mi[3 * kk + 2] * gb[2];
                        let h = j * (q[an][i] * q[bn][kk] - q[bn][i] * q[an][kk]);
                        k[(3 * an + i, 3 * bn + kk)] += w * s;
                        hv[(3 * an + i, 3 * bn + kk)] += w * h;
                    }
                }
            }
        }
    }
    // Mirror the upper block triangle (b > a) into the lower one: both are symmetric.
    for an in 0..8 {
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
    Some(ElementKinematics {
        energy_iso: energy,
        force_iso: force,
        k_iso: k,
        v,
        g: dv,
        h: hv,
    })
}

/// Energy, internal force and tangent of one element in the displacement-only form
/// (pressure slaved to the mean dilatation, p = U'(v_e / V_e)). `None` when an
/// inverted Gauss point (J <= 0) is met.
pub fn element_response(
    geom: &HexGeometry,
    material: &Yeoh,
    u: &[Vector3<f64>; 8],
) -> Option<(f64, ElementVector, ElementMatrix)> {
    let e = element_kinematics(geom, material, u)?;
    let jbar = e.v / geom.volume;
    if jbar <= 0.0 {
        return None;
    }
    let du = material.du(jbar);
    let ddu = material.ddu(jbar);
    let energy = e.energy_iso + geom.volume * material.u(jbar);
    let force = e.force_iso + e.g * du;
    let k = e.k_iso + e.g * e.g.transpose() * (ddu / geom.volume) + e.h * du;
    Some((energy, force, k))
}

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
        let (_, f, k) = element_response(&geom, &m, &u).unwrap();
        let h = 1e-6;
        for d in 0..24 {
            let mut up = u;
            let mut um = u;
            up[d / 3][d % 3] += h;
            um[d / 3][d % 3] -= h;
            let (ep, fp, _) = element_response(&geom, &m, &up).unwrap();
            let (em, fm, _) = element_response(&geom, &m, &um).unwrap();
            let fd = (ep - em) / (2.0 * h);
            assert!(
                (fd - f[d]).abs() < 1e-6 * f.norm().max(1.0),
                "f[{d}] {} vs {fd}",
                f[d]
            );
            let col = (fp - fm) / (2.0 * h);
            for r in 0..24 {
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
    fn rigid_motion_is_stress_free() {
        let x = unit_cube();
        let geom = HexGeometry::new(&x).unwrap();
        let m = MaterialPreset::Proposed.yeoh();
        let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.5);
        let u: [Vector3<f64>; 8] =
            std::array::from_fn(|a| r * x[a] - x[a] + Vector3::new(1.0, 2.0, 3.0));
        let (e, f, _) = element_response(&geom, &m, &u).unwrap();
        assert!(e.abs() < 1e-12 && f.norm() < 1e-10, "{e} {}", f.norm());
    }
}
