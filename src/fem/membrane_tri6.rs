//! 6-node triangular membranes: the sheets (`layer.NAME` surfaces) of an imported mesh,
//! on the faces of its 10-node tetrahedra, so that the sheet deforms with the faces it is
//! bonded to (the same quadratic interpolation) and goes out to CalculiX as its `M3D6`.
//!
//! Why written here: [`super::membrane`]'s element is a 4-node quadrilateral; the
//! material, the plane-stress Saint Venant-Kirchhoff sheet (and threads smeared over it),
//! is the same and shared ([`MembraneSection`]). Geometry: quadratic shape functions over
//! a possibly curved reference triangle; at each of the 3 interior Gauss points (degree
//! 2, exact for the linear element's stiffness on a straight-sided triangle) an
//! orthonormal frame of the reference tangent plane, the shape-function gradients in it
//! and the area weight. Total Lagrangian: F = ∂x/∂X (3x2) along the frame, E = ½ (FᵀF −
//! I₂); force and tangent are the energy's gradient and Hessian (tests check them against
//! finite differences, the patch test and the stress of a uniform stretch).

use nalgebra::{Matrix2, SMatrix, SVector, Vector2, Vector3};

use super::membrane::{gradient_at, green_strain, MembraneSection};

/// Force vector of a 6-node membrane (6 nodes x 3).
pub type Tri6MembraneVector = SVector<f64, 18>;
/// Tangent of a 6-node membrane (18 x 18).
pub type Tri6MembraneMatrix = SMatrix<f64, 18, 18>;

/// One 6-node membrane: corners, then the mid-nodes of edges 01, 12, 20, and its section.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tri6Membrane {
    /// Node indices.
    pub nodes: [usize; 6],
    /// The sheet's section.
    pub section: MembraneSection,
}

/// The interior 3-point rule (area coordinates ξ, η; weight 1/6 each on the unit
/// triangle).
const POINTS: [[f64; 2]; 3] = [
    [1.0 / 6.0, 1.0 / 6.0],
    [2.0 / 3.0, 1.0 / 6.0],
    [1.0 / 6.0, 2.0 / 3.0],
];

/// dN_a/dξ, dN_a/dη of the 6-node triangle at (ξ, η): corners 0 (1 − ξ − η), 1 (ξ),
/// 2 (η), then the mid-nodes of 01, 12, 20.
fn shape_derivatives(xi: f64, eta: f64) -> [Vector2<f64>; 6] {
    let l0 = 1.0 - xi - eta;
    [
        Vector2::new(1.0 - 4.0 * l0, 1.0 - 4.0 * l0),
        Vector2::new(4.0 * xi - 1.0, 0.0),
        Vector2::new(0.0, 4.0 * eta - 1.0),
        Vector2::new(4.0 * (l0 - xi), -4.0 * xi),
        Vector2::new(4.0 * eta, 4.0 * xi),
        Vector2::new(-4.0 * eta, 4.0 * (l0 - eta)),
    ]
}

/// Reference geometry of a 6-node membrane at its Gauss points.
#[derive(Debug, Clone)]
pub struct Tri6Geometry {
    /// Orthonormal frame e₁, e₂ of the reference tangent plane per point.
    frames: [[Vector3<f64>; 2]; 3],
    /// dN_a/dX_α per point, along its frame: `grads[g][a]`.
    grads: [[Vector2<f64>; 6]; 3],
    /// Reference area weight per point, mm².
    weights: [f64; 3],
}

impl Tri6Geometry {
    /// The reference geometry from the 6 node positions; `None` where the triangle is
    /// degenerate or folded (the tangents' area vanishes or turns over at a point).
    pub fn new(x: &[Vector3<f64>; 6]) -> Option<Self> {
        let mut frames = [[Vector3::zeros(); 2]; 3];
        let mut grads = [[Vector2::zeros(); 6]; 3];
        let mut weights = [0.0; 3];
        let mut normal0 = None;
        for (g, p) in POINTS.iter().enumerate() {
            let dn = shape_derivatives(p[0], p[1]);
            let (mut g1, mut g2) = (Vector3::zeros(), Vector3::zeros());
            for (xa, d) in x.iter().zip(&dn) {
                g1 += xa * d[0];
                g2 += xa * d[1];
            }
            let n = g1.cross(&g2);
            let area = n.norm();
            let e1 = g1.try_normalize(1e-12)?;
            let n = n.try_normalize(1e-12 * g1.norm() * g2.norm().max(1e-300))?;
            match normal0 {
                None => normal0 = Some(n),
                Some(n0) if n.dot(&n0) <= 0.0 => return None,
                Some(_) => {}
            }
            let e2 = n.cross(&e1);
            // J maps (ξ, η) derivatives to the frame's: J = [[e1·g1, e1·g2], [e2·g1, e2·g2]].
            let jac = Matrix2::new(e1.dot(&g1), e1.dot(&g2), e2.dot(&g1), e2.dot(&g2));
            let inv_t = jac.try_inverse()?.transpose();
            frames[g] = [e1, e2];
            grads[g] = dn.map(|d| inv_t * d);
            weights[g] = area / 6.0;
        }
        Some(Self {
            frames,
            grads,
            weights,
        })
    }

    /// Reference area, mm² (exact for a straight-sided triangle).
    pub fn area(&self) -> f64 {
        self.weights.iter().sum()
    }
}

/// Energy (N mm), internal force (N) and tangent (N/mm) of a 6-node membrane at nodal
/// displacements `u`.
pub fn tri6_membrane_response(
    geom: &Tri6Geometry,
    section: &MembraneSection,
    u: &[Vector3<f64>; 6],
) -> (f64, Tri6MembraneVector, Tri6MembraneMatrix) {
    let t = section.thickness_mm;
    let mut energy = 0.0;
    let mut force = Tri6MembraneVector::zeros();
    let mut k = Tri6MembraneMatrix::zeros();
    for g in 0..3 {
        let (frame, grads) = (&geom.frames[g], &geom.grads[g]);
        let f = gradient_at(frame, grads, u);
        let strain = green_strain(&f);
        // ∂(E11, E22, 2 E12)/∂u_a (3x3 per node).
        let b: [SMatrix<f64, 3, 3>; 6] = std::array::from_fn(|a| {
            let ga = grads[a];
            SMatrix::<f64, 3, 3>::from_rows(&[
                (f[0] * ga[0]).transpose(),
                (f[1] * ga[1]).transpose(),
                (f[0] * ga[1] + f[1] * ga[0]).transpose(),
            ])
        });
        let d = section.elasticity(frame, &strain);
        let s = d * strain;
        let w = t * geom.weights[g];
        energy += w * 0.5 * strain.dot(&s);
        for a in 0..6 {
            let fa = b[a].transpose() * s;
            for i in 0..3 {
                force[3 * a + i] += w * fa[i];
            }
            let bd = b[a].transpose() * d;
            for c in 0..6 {
                let kac = bd * b[c];
                let (ga, gc) = (grads[a], grads[c]);
                let geo = s[0] * ga[0] * gc[0]
                    + s[1] * ga[1] * gc[1]
                    + s[2] * (ga[0] * gc[1] + ga[1] * gc[0]);
                for i in 0..3 {
                    for j in 0..3 {
                        let delta = if i == j { geo } else { 0.0 };
                        k[(3 * a + i, 3 * c + j)] += w * (kac[(i, j)] + delta);
                    }
                }
            }
        }
    }
    (energy, force, k)
}

/// Second Piola-Kirchhoff membrane stress (S11, S22, S12), MPa, at each Gauss point in
/// its own frame (the frames of a curved or curved-sided triangle differ from point to
/// point; the principal stresses do not depend on them).
pub fn tri6_membrane_stress(
    geom: &Tri6Geometry,
    section: &MembraneSection,
    u: &[Vector3<f64>; 6],
) -> [Vector3<f64>; 3] {
    std::array::from_fn(|g| {
        let f = gradient_at(&geom.frames[g], &geom.grads[g], u);
        let strain = green_strain(&f);
        section.elasticity(&geom.frames[g], &strain) * strain
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paper() -> MembraneSection {
        MembraneSection::isotropic(0.1, 3000.0, 0.3)
    }

    /// A triangle in an inclined plane, its mid-nodes off their edge midpoints in the
    /// plane (a curved-sided triangle), or out of it with `bulge` (a curved sheet).
    fn triangle(bulge: f64) -> [Vector3<f64>; 6] {
        let r = nalgebra::Rotation3::from_euler_angles(0.4, -0.3, 0.7);
        [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(2.0, 0.3, 0.0),
            Vector3::new(0.4, 1.7, 0.0),
            Vector3::new(1.0, 0.05, bulge),
            Vector3::new(1.25, 1.0, bulge),
            Vector3::new(0.2, 0.9, 0.0),
        ]
        .map(|p| r * p + Vector3::new(3.0, -1.0, 2.0))
    }

    #[test]
    fn force_and_tangent_are_derivatives_of_the_energy() {
        for bulge in [0.0, 0.3] {
            let x = triangle(bulge);
            let geom = Tri6Geometry::new(&x).unwrap();
            let section = paper();
            let u: [Vector3<f64>; 6] = std::array::from_fn(|a| {
                let t = a as f64;
                Vector3::new(
                    0.03 * (t * 0.7).sin(),
                    0.05 * (t * 1.3).cos(),
                    -0.04 * (t * 0.4 + 0.2).sin(),
                ) + 0.1 * (x[a] - x[0])
            });
            let (_, f, k) = tri6_membrane_response(&geom, &section, &u);
            assert!(f.norm() > 0.0);
            let h = 1e-6;
            for dof in 0..18 {
                let (mut up, mut um) = (u, u);
                up[dof / 3][dof % 3] += h;
                um[dof / 3][dof % 3] -= h;
                let (ep, fp, _) = tri6_membrane_response(&geom, &section, &up);
                let (em, fm, _) = tri6_membrane_response(&geom, &section, &um);
                let fd = (ep - em) / (2.0 * h);
                assert!(
                    (fd - f[dof]).abs() < 1e-6 * f.norm(),
                    "f[{dof}] {} vs {fd}",
                    f[dof]
                );
                let col = (fp - fm) / (2.0 * h);
                for r in 0..18 {
                    assert!(
                        (col[r] - k[(r, dof)]).abs() < 1e-6 * k.norm(),
                        "K[{r},{dof}] {} vs {}",
                        k[(r, dof)],
                        col[r]
                    );
                }
            }
            assert!((k - k.transpose()).norm() < 1e-9 * k.norm());
        }
    }

    /// Patch test: a flat triangle with curved sides stretched uniformly (x = X + (λ − 1)
    /// (d · X) d along an in-plane direction d, then rotated rigidly) carries the
    /// plane-stress sheet's S = λ' tr E I + 2 μ E everywhere, with E = ½ (λ² − 1) d d
    /// and energy area t (½ λ' (tr E)² + μ E:E); a rigid motion alone carries nothing.
    #[test]
    fn a_uniform_stretch_gives_the_sheets_stress_and_energy() {
        let x = triangle(0.0);
        let geom = Tri6Geometry::new(&x).unwrap();
        let section = paper();
        let d = (x[1] - x[0] + 0.5 * (x[2] - x[0])).normalize();
        let rot = nalgebra::Rotation3::from_axis_angle(&nalgebra::Vector3::z_axis(), 0.6);
        for stretch in [1.0, 1.02, 0.98] {
            let u: [Vector3<f64>; 6] = std::array::from_fn(|a| {
                let y = x[a] + d * ((stretch - 1.0) * d.dot(&x[a]));
                rot * y - x[a]
            });
            let (energy, force, _) = tri6_membrane_response(&geom, &section, &u);
            let s = tri6_membrane_stress(&geom, &section, &u);
            let (e, nu, t) = (3000.0, 0.3, 0.1);
            let (lambda, mu) = (e * nu / (1.0 - nu * nu), e / (2.0 * (1.0 + nu)));
            let edd = 0.5 * (stretch * stretch - 1.0);
            let want_energy = geom.area() * t * (0.5 * lambda * edd * edd + mu * edd * edd);
            assert!(
                (energy - want_energy).abs() <= 1e-9 * want_energy.max(1e-12),
                "{energy} vs {want_energy}"
            );
            // At every point S along d is (λ' + 2 μ) E, and its trace (2 λ' + 2 μ) E.
            for (g, s) in s.iter().enumerate() {
                let a = geom.frames[g];
                let (d1, d2) = (d.dot(&a[0]), d.dot(&a[1]));
                let sdd = s[0] * d1 * d1 + s[1] * d2 * d2 + 2.0 * s[2] * d1 * d2;
                assert!((sdd - (lambda + 2.0 * mu) * edd).abs() < 1e-9 * e, "{s}");
                assert!(
                    (s[0] + s[1] - (2.0 * lambda + 2.0 * mu) * edd).abs() < 1e-9 * e,
                    "{s}"
                );
            }
            // A uniform stress is in equilibrium: the nodal forces sum to zero, and to
            // zero moment about the normal.
            let mut sum = Vector3::zeros();
            for a in 0..6 {
                sum += Vector3::new(force[3 * a], force[3 * a + 1], force[3 * a + 2]);
            }
            assert!(sum.norm() < 1e-9 * (1.0 + force.norm()), "{sum}");
        }
    }

    /// A triangle collapsed onto a line has no geometry.
    #[test]
    fn degenerate_triangles_are_refused() {
        let x = triangle(0.0);
        let line: [Vector3<f64>; 6] =
            std::array::from_fn(|k| x[0] + (x[1] - x[0]) * [0.0, 1.0, 0.4, 0.5, 0.7, 0.2][k]);
        assert!(Tri6Geometry::new(&line).is_none());
        assert!(Tri6Geometry::new(&x).is_some());
    }
}
