//! The 10-node tetrahedron with a continuous linear pressure: the Taylor-Hood pair P2/P1
//! (the pressure field of Abaqus C3D10H and ANSYS SOLID187 in mixed u-P).
//!
//! Unknowns: the displacements of the 10 nodes and the pressures p_i of the 4 corners,
//! p_h = Σ L_i p_i, continuous across elements (the solver shares a corner's pressure
//! between the tetrahedra that meet there). Perturbed-Lagrangian energy with the
//! material's own volumetric energy U(J) = κ/4 (J² − 1 − 2 ln J):
//! Π_e = ∫ [W_iso(F) + p_h J − U*(p_h)] dV, U* the convex conjugate of U (Ĵ(p) solves
//! U'(Ĵ) = p, U*(p) = p Ĵ − U(Ĵ), U*' = Ĵ, U*'' = 1 / U''(Ĵ)). Stationarity in p gives
//! J = Ĵ(p_h) weakly, i.e. p = U'(J) in the mean over each corner's patch; stationarity
//! in u is equilibrium with the pressure p_h. The 34 x 34 Hessian is symmetric and
//! indefinite (a saddle point): K_uu = K_iso + Σ p_h ∂²J/∂u², K_up = ∫ L_i ∂J/∂u dV,
//! K_pp = −∫ L_i L_j / U''(Ĵ) dV.
//!
//! Quadrature: the element's 4-point rule (degree 2). On a straight-edged tetrahedron
//! L_i L_j (the pressure block at small strain) and L_i ∂J/∂u (degree 1 times 1) are of
//! degree 2: integrated exactly. Taylor-Hood is inf-sup stable on tetrahedra with every
//! element having an interior vertex or edge (Boffi, Brezzi & Fortin 2013, ch. 8), and
//! unlike P2/P0 its dilatation cannot jump from element to element: a wall one element
//! thick no longer bends with a free dilatation through it.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::{kinematics, Tet10Geometry, GAUSS};
use crate::fem::material::{HyperelasticMaterial, Yeoh};

/// Unknowns of one element: 30 displacements, then the 4 corner pressures.
pub const TH_DOFS: usize = 34;
/// Element Hessian (34 x 34, displacements first).
pub type ThMatrix = SMatrix<f64, TH_DOFS, TH_DOFS>;
/// Element gradient (34).
pub type ThVector = SVector<f64, TH_DOFS>;

/// Ĵ(p): the dilatation at which the volumetric energy's derivative is p, U'(Ĵ) = p,
/// the positive root of Ĵ² − 2 (p/κ) Ĵ − 1 = 0 (written without cancellation for
/// either sign of p).
pub fn dilatation_at(material: &Yeoh, p: f64) -> f64 {
    let s = p / material.bulk_modulus;
    let root = (s * s + 1.0).sqrt();
    if s >= 0.0 {
        s + root
    } else {
        1.0 / (root - s)
    }
}

/// U*(p) = p Ĵ − U(Ĵ), the convex conjugate of the volumetric energy.
pub fn conjugate_energy(material: &Yeoh, p: f64) -> f64 {
    let j = dilatation_at(material, p);
    p * j - material.u(j)
}

/// The pressure at volume coordinates `l` from the corner pressures.
pub fn pressure_at(l: &[f64; 4], p: &[f64; 4]) -> f64 {
    (0..4).map(|i| l[i] * p[i]).sum()
}

/// ∫ L_i dV of each corner over the reference element (a quarter of its volume when
/// the edges are straight): the weight of its pressure's volume constraint.
pub fn corner_volumes(geom: &Tet10Geometry) -> [f64; 4] {
    std::array::from_fn(|i| (0..4).map(|g| geom.weights[g] * GAUSS[g][i]).sum())
}

/// What one element gives at (u, p): the energy Π_e, its gradient (r_u: internal force
/// with the pressure p_h; r_p: ∫ L_i (J − Ĵ(p_h)) dV, the volume constraint) and its
/// Hessian.
pub struct ThResponse {
    /// Π_e.
    pub energy: f64,
    /// ∂Π_e/∂(u, p).
    pub gradient: ThVector,
    /// ∂²Π_e/∂(u, p)².
    pub hessian: ThMatrix,
}

/// The element's energy, gradient and Hessian at nodal displacements `u` and corner
/// pressures `p` (MPa, positive in tension). `None` when a Gauss point is inverted.
pub fn element_response(
    geom: &Tet10Geometry,
    material: &Yeoh,
    u: &[Vector3<f64>; 10],
    p: &[f64; 4],
) -> Option<ThResponse> {
    let mut volumetric = 0.0;
    let mut force = SVector::<f64, 30>::zeros();
    let mut kuu = SMatrix::<f64, 30, 30>::zeros();
    let mut kup = SMatrix::<f64, 30, 4>::zeros();
    let mut rp = SVector::<f64, 4>::zeros();
    let mut kpp = SMatrix::<f64, 4, 4>::zeros();
    let mut point = 0;
    let mut each = |gp: &SVector<f64, 30>, hp: &SMatrix<f64, 30, 30>, j: f64| {
        let (l, w) = (&GAUSS[point], geom.weights[point]);
        point += 1;
        let ph = pressure_at(l, p);
        let jh = dilatation_at(material, ph);
        let compliance = 1.0 / material.ddu(jh);
        volumetric += w * (ph * j - (ph * jh - material.u(jh)));
        force += gp * ph;
        kuu += hp * ph;
        for i in 0..4 {
            kup.set_column(i, &(kup.column(i) + gp * l[i]));
            rp[i] += w * l[i] * (j - jh);
            for k in 0..4 {
                kpp[(i, k)] -= w * l[i] * l[k] * compliance;
            }
        }
    };
    let k = kinematics(geom, material, u, Some(&mut each))?;
    let mut gradient = ThVector::zeros();
    gradient
        .fixed_rows_mut::<30>(0)
        .copy_from(&(k.force_iso + force));
    gradient.fixed_rows_mut::<4>(30).copy_from(&rp);
    let mut hessian = ThMatrix::zeros();
    hessian
        .fixed_view_mut::<30, 30>(0, 0)
        .copy_from(&(k.k_iso + kuu));
    hessian.fixed_view_mut::<30, 4>(0, 30).copy_from(&kup);
    hessian
        .fixed_view_mut::<4, 30>(30, 0)
        .copy_from(&kup.transpose());
    hessian.fixed_view_mut::<4, 4>(30, 30).copy_from(&kpp);
    Some(ThResponse {
        energy: k.energy_iso + volumetric,
        gradient,
        hessian,
    })
}

/// The element's Cauchy stress, MPa: the current-volume average of the isochoric part
/// plus the interpolated pressure p_h, ∫ (σ_iso + p_h I) dv / v. `None` when inverted.
pub fn element_cauchy_stress(
    geom: &Tet10Geometry,
    material: &Yeoh,
    u: &[Vector3<f64>; 10],
    p: &[f64; 4],
) -> Option<Matrix3<f64>> {
    let iso = material.isochoric();
    let mut sum = Matrix3::zeros();
    let mut v = 0.0;
    for (g, l) in GAUSS.iter().enumerate() {
        let f = geom.deformation_gradient(g, u);
        let j = f.determinant();
        if !(j > 0.0) {
            return None;
        }
        // σ J w = (P_iso Fᵀ + p_h J I) w.
        let w = geom.weights[g];
        sum += (iso.first_piola(&f) * f.transpose()
            + Matrix3::identity() * (pressure_at(l, p) * j))
            * w;
        v += j * w;
    }
    Some(sum / v)
}

#[cfg(test)]
mod tests {
    use super::super::tests::curved;
    use super::super::EDGES;
    use super::*;
    use crate::fem::material::MaterialPreset;

    fn sample(x: &[Vector3<f64>; 10]) -> ([Vector3<f64>; 10], [f64; 4]) {
        let u = std::array::from_fn(|a| {
            let t = a as f64;
            0.05 * Vector3::new((0.7 * t).sin(), (1.3 * t).cos() - 0.4, -(0.4 * t).sin())
                + 0.02 * x[a]
        });
        (u, [0.3, -0.1, 0.25, 0.05])
    }

    #[test]
    fn the_conjugate_inverts_the_volumetric_derivative() {
        let m = MaterialPreset::Proposed.yeoh();
        for p in [-50.0, -0.3, 0.0, 1e-9, 0.2, 40.0] {
            let j = dilatation_at(&m, p);
            assert!((m.du(j) - p).abs() < 1e-12 * m.bulk_modulus, "{p}: {j}");
            let h = 1e-5;
            let d = (conjugate_energy(&m, p + h) - conjugate_energy(&m, p - h)) / (2.0 * h);
            assert!((d - j).abs() < 1e-8, "U*' {d} vs Ĵ {j}");
        }
        assert_eq!(dilatation_at(&m, 0.0), 1.0);
        assert_eq!(conjugate_energy(&m, 0.0), 0.0);
    }

    /// The gradient is the central difference of the energy and the Hessian that of the
    /// gradient (34 columns, displacements and pressures), symmetric; κ = 100 μ and the
    /// default 1000 μ.
    #[test]
    fn gradient_and_hessian_are_derivatives_of_the_energy() {
        let x = curved();
        let geom = Tet10Geometry::new(&x).unwrap();
        let base = MaterialPreset::Proposed.yeoh();
        let soft = Yeoh {
            bulk_modulus: 100.0 * 2.0 * base.c1,
            ..base
        };
        let (u0, p0) = sample(&x);
        for m in [soft, base] {
            let at = |d: usize, s: f64| {
                let (mut u, mut p) = (u0, p0);
                if d < 30 {
                    u[d / 3][d % 3] += s;
                } else {
                    p[d - 30] += s;
                }
                element_response(&geom, &m, &u, &p).unwrap()
            };
            let r = at(0, 0.0);
            let h = 1e-6;
            for d in 0..TH_DOFS {
                let (a, b) = (at(d, h), at(d, -h));
                let fd = (a.energy - b.energy) / (2.0 * h);
                assert!(
                    (fd - r.gradient[d]).abs() < 1e-7 * r.gradient.norm(),
                    "g[{d}] {} vs {fd}",
                    r.gradient[d]
                );
                let col = (a.gradient - b.gradient) / (2.0 * h);
                for row in 0..TH_DOFS {
                    assert!(
                        (col[row] - r.hessian[(row, d)]).abs() < 1e-7 * r.hessian.norm(),
                        "K[{row},{d}] {} vs {}",
                        r.hessian[(row, d)],
                        col[row]
                    );
                }
            }
            let k = &r.hessian;
            assert!((k - k.transpose()).norm() < 1e-12 * k.norm(), "symmetric");
        }
    }

    /// A rigid motion at zero pressure: no energy, no force, no volume residual; and a
    /// uniform F with the corner pressures at U'(det F) balances the constraint exactly.
    #[test]
    fn rigid_motion_is_stress_free_and_a_uniform_dilatation_is_consistent() {
        let mut x = curved();
        let geom = Tet10Geometry::new(&x).unwrap();
        let m = MaterialPreset::Proposed.yeoh();
        let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.5);
        let u: [Vector3<f64>; 10] =
            std::array::from_fn(|a| r * x[a] - x[a] + Vector3::new(1.0, 2.0, 3.0));
        let th = element_response(&geom, &m, &u, &[0.0; 4]).unwrap();
        assert!(th.energy.abs() < 1e-12 && th.gradient.norm() < 1e-10);
        let s = element_cauchy_stress(&geom, &m, &u, &[0.0; 4]).unwrap();
        assert!(s.norm() < 1e-12, "{s}");
        for (k, &[i, j]) in EDGES.iter().enumerate() {
            x[4 + k] = 0.5 * (x[i] + x[j]);
        }
        let geom = Tet10Geometry::new(&x).unwrap();
        let f = Matrix3::new(1.05, 0.02, 0.0, -0.01, 0.97, 0.03, 0.0, 0.01, 1.01);
        let u: [Vector3<f64>; 10] = std::array::from_fn(|a| (f - Matrix3::identity()) * x[a]);
        let p = m.du(f.determinant());
        let th = element_response(&geom, &m, &u, &[p; 4]).unwrap();
        let rp = th.gradient.fixed_rows::<4>(30);
        assert!(rp.norm() < 1e-12 * geom.volume, "{rp}");
        let s = element_cauchy_stress(&geom, &m, &u, &[p; 4]).unwrap();
        let exact = m.first_piola(&f) * f.transpose() / f.determinant();
        assert!((s - exact).norm() < 1e-10 * exact.norm(), "{s} vs {exact}");
    }
}
