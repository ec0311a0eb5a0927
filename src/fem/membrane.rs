//! Membrane elements for thin stiff sheets (paper, fabric) bonded to the silicone:
//! 4-node bilinear quadrilaterals (2x2 Gauss points) that carry in-plane stress only.
//!
//! Why written here: a sheet 0.1 mm thick and 10³-10⁴ times stiffer than the silicone,
//! meshed as one layer of hexahedra 1.5 mm wide, gives elements of aspect ratio 15 whose
//! through-thickness stiffness (E A / t) dwarfs everything else in the tangent and which
//! lock in bending; the sheet's own bending stiffness (E t³/12) is negligible beside
//! the silicone's, so a membrane on the sheet's mid-plane, sharing the silicone's nodes
//! (bonded), carries what the sheet carries and nothing it does not. A sheet that is
//! compressed, or thick enough for its own bending to count, needs that bending too:
//! [`super::plate`] (`element = "plate"`).
//!
//! Material: the plane-stress Saint Venant-Kirchhoff membrane, energy per reference area
//! t (½ λ' (tr E)² + μ E:E) with the in-plane Green-Lagrange strain E = ½ (FᵀF − I₂)
//! (F = ∂x/∂X, 3x2, over the sheet's reference plane) and λ' = E ν / (1 − ν²),
//! μ = E / 2(1 + ν): the linear-elastic plane-stress sheet at the small strains of a
//! strain-limiting layer, exact under the actuator's large rotations. Threads smeared
//! over a sheet ([`Fibres`]) carry ½ E t E_ff² along their direction a only (E_ff =
//! a · E a; its shear part from the element's centre: `point_strain`), tension-only if
//! asked. Force and tangent
//! are the energy's gradient and Hessian (total Lagrangian; tests check them against
//! finite differences).

use nalgebra::{Matrix2, SMatrix, SVector, Vector2, Vector3};
use serde::Serialize;

/// Membrane element force vector (4 nodes x 3).
pub type MembraneVector = SVector<f64, 12>;
/// Membrane element tangent (12 x 12).
pub type MembraneMatrix = SMatrix<f64, 12, 12>;

/// A sheet's section: thickness and its isotropic linear-elastic constants.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MembraneSection {
    /// Thickness, mm.
    pub thickness_mm: f64,
    /// Young's modulus, MPa.
    pub youngs_modulus_mpa: f64,
    /// Poisson ratio.
    pub poisson_ratio: f64,
    /// `Some`: a family of parallel threads smeared over the sheet, which carries stress
    /// along them only (E the threads' modulus, the thickness their cross-section per unit
    /// width, A / spacing; ν unused); `None`: the isotropic sheet.
    pub fibres: Option<Fibres>,
}

/// Threads smeared over a membrane: the energy per reference area ½ E t E_ff², with
/// E_ff = a · E a the Green-Lagrange strain along their reference direction a (a bar's
/// strain measure, [`super::truss`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Fibres {
    /// Their direction in the reference configuration (in the sheet's plane), unit.
    pub direction: [f64; 3],
    /// They carry no compression (cables).
    pub tension_only: bool,
}

impl MembraneSection {
    /// The isotropic sheet of thickness `t`, modulus `e` and Poisson ratio `nu`.
    pub fn isotropic(t: f64, e: f64, nu: f64) -> Self {
        Self {
            thickness_mm: t,
            youngs_modulus_mpa: e,
            poisson_ratio: nu,
            fibres: None,
        }
    }

    /// Tangent elasticity in Voigt form (E11, E22, 2 E12) -> (S11, S22, S12), MPa, over
    /// the in-plane frame `frame` at the Green strain `strain` (Voigt): the plane-stress
    /// isotropic sheet, or E m mᵀ along the threads, m = (a₁², a₂², a₁ a₂) (zero for
    /// tension-only threads shortened).
    pub(super) fn elasticity(
        &self,
        frame: &[Vector3<f64>; 2],
        strain: &Vector3<f64>,
    ) -> SMatrix<f64, 3, 3> {
        if let Some(f) = &self.fibres {
            let a = Vector3::from(f.direction);
            let a = Vector2::new(a.dot(&frame[0]), a.dot(&frame[1]));
            let a = a / a.norm().max(1e-300);
            let m = Vector3::new(a.x * a.x, a.y * a.y, a.x * a.y);
            if f.tension_only && m.dot(strain) < 0.0 {
                return SMatrix::<f64, 3, 3>::zeros();
            }
            return m * m.transpose() * self.youngs_modulus_mpa;
        }
        let (e, nu) = (self.youngs_modulus_mpa, self.poisson_ratio);
        let c = e / (1.0 - nu * nu);
        SMatrix::<f64, 3, 3>::new(
            c,
            c * nu,
            0.0,
            c * nu,
            c,
            0.0,
            0.0,
            0.0,
            c * 0.5 * (1.0 - nu),
        )
    }
}

/// One membrane element: 4 nodes counter-clockwise (either side) and its section.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MembraneElement {
    /// Node indices.
    pub nodes: [usize; 4],
    /// The sheet's section.
    pub section: MembraneSection,
}

const GP: f64 = 0.577_350_269_189_625_8; // 1/sqrt(3)
const CORNERS: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// Reference geometry of a membrane: an orthonormal in-plane frame, the shape-function
/// gradients in it at each Gauss point and the Gauss weights times the area Jacobian.
#[derive(Debug, Clone)]
pub struct MembraneGeometry {
    /// In-plane unit vectors e₁, e₂ of the reference plane.
    pub frame: [Vector3<f64>; 2],
    /// dN_a/dX_α per Gauss point: `grads[g][a]`.
    pub grads: [[Vector2<f64>; 4]; 4],
    /// Reference area weight per Gauss point, mm².
    pub weights: [f64; 4],
    /// dN_a/dX_α at the centre (the threads' shear strain, [`Fibres`]).
    pub centre: [Vector2<f64>; 4],
}

impl MembraneGeometry {
    /// Precomputes the reference geometry of a (flat) quadrilateral from its 4 node
    /// positions; `None` when it is degenerate or not convex.
    pub fn new(x: &[Vector3<f64>; 4]) -> Option<Self> {
        let normal = (x[2] - x[0]).cross(&(x[3] - x[1]));
        let e1 = (x[1] - x[0] + x[2] - x[3]).try_normalize(1e-12)?;
        let n = normal.try_normalize(1e-12)?;
        let e2 = n.cross(&e1);
        let local: [Vector2<f64>; 4] = std::array::from_fn(|a| {
            let d = x[a] - x[0];
            Vector2::new(d.dot(&e1), d.dot(&e2))
        });
        let mut grads = [[Vector2::zeros(); 4]; 4];
        let mut weights = [0.0; 4];
        let mut centre = [Vector2::zeros(); 4];
        // The 4 Gauss points, then the centre.
        for (g, c) in CORNERS.iter().chain(&[[0.0, 0.0]]).enumerate() {
            let xi = [c[0] * GP, c[1] * GP];
            let dn: [Vector2<f64>; 4] = std::array::from_fn(|a| {
                let n = CORNERS[a];
                Vector2::new(
                    0.25 * n[0] * (1.0 + n[1] * xi[1]),
                    0.25 * n[1] * (1.0 + n[0] * xi[0]),
                )
            });
            let mut jac = Matrix2::zeros();
            for a in 0..4 {
                jac += local[a] * dn[a].transpose();
            }
            let det = jac.determinant();
            if det <= 0.0 {
                return None;
            }
            let inv_t = jac.try_inverse()?.transpose();
            if g == 4 {
                centre = std::array::from_fn(|a| inv_t * dn[a]);
                continue;
            }
            for a in 0..4 {
                grads[g][a] = inv_t * dn[a];
            }
            weights[g] = det;
        }
        Some(Self {
            frame: [e1, e2],
            grads,
            weights,
            centre,
        })
    }

    /// Reference area, mm².
    pub fn area(&self) -> f64 {
        self.weights.iter().sum()
    }
}

/// In-plane deformation gradient F = ∂x/∂X (3x2, columns along e₁, e₂) where the
/// shape functions have gradients `grads`, from the nodal displacements.
pub(super) fn gradient_at<const N: usize>(
    frame: &[Vector3<f64>; 2],
    grads: &[Vector2<f64>; N],
    u: &[Vector3<f64>; N],
) -> [Vector3<f64>; 2] {
    let mut f = *frame;
    for (ua, ga) in u.iter().zip(grads) {
        f[0] += ua * ga[0];
        f[1] += ua * ga[1];
    }
    f
}

/// A membrane's strain at a Gauss point as its energy sees it ([`point_strain`]).
struct PointStrain {
    /// (E11, E22, 2 E12).
    strain: Vector3<f64>,
    /// B_a (3x3 per node): ∂(E11, E22, 2E12)/∂u_a,i.
    b: [SMatrix<f64, 3, 3>; 4],
    /// dN_a/dX at the point (the normal strains' second derivatives).
    grads: [Vector2<f64>; 4],
    /// The gradients of the shear's two parts, each with its weight (point, centre).
    shear: [([Vector2<f64>; 4], f64); 2],
}

/// The share of the threads' shear strain taken at the Gauss point, the rest at the
/// centre ([`point_strain`]): the parasitic shear's energy scales as its square. The
/// tube's default ramp (gravity, 10-60 kPa, h = 1.5 mm): with the whole shear at the
/// centre (0) the sag is 16.831 / 25.686 deg at 10 / 60 kPa, within 0.02% of the mesh
/// 0.75 mm along, but Newton fails 5 increments of the first moves (283 linear solves;
/// with the whole shear at the points, 1, 1 failure and 149 solves); 0.2 gives 16.812 /
/// 25.603 deg (-0.11 / -0.32%), 3 failures, 226 solves; 0.3 -0.27 / -0.72%, 221 solves.
const SHEAR_AT_POINTS: f64 = 0.2;

/// The strain a section's energy is evaluated with at Gauss point `g`, its gradient and
/// the gradients of its second derivative ([`PointStrain`]): the Green-Lagrange strain at
/// the point, except
/// that threads ([`Fibres`]) take their shear 2 E12 mostly from the centre (all but
/// [`SHEAR_AT_POINTS`] of it).
///
/// Why the centre's shear for threads: a bilinear quad bent in its plane (the tube's wall
/// bending as a beam: the axial strain varies around the tube) shows a shear it should
/// not have, proportional to its length, and threads near the hoop direction (84° at the
/// default pitch) turn that shear into stretch of a stiffness 10³ times the silicone's:
/// at 0 kPa the tube's sag under its weight was 15.33 / 15.49 / 15.66 deg with elements
/// 1.0 / 0.75 / 0.5 mm along, and 18.31 / 18.32 / 18.33 with the threads taken out; with
/// the shear at the centre 15.77 / 15.78 / 15.79. The centre's shear is exact for any
/// uniform strain (the patch test holds); the quad's mode that it does not see keeps
/// [`SHEAR_AT_POINTS`] of the point's shear, besides the silicone underneath (with all
/// of it at the centre Newton failed more increments).
fn point_strain(
    geom: &MembraneGeometry,
    section: &MembraneSection,
    g: usize,
    u: &[Vector3<f64>; 4],
) -> PointStrain {
    let grads = &geom.grads[g];
    let f = gradient_at(&geom.frame, grads, u);
    let mut strain = green_strain(&f);
    let mut b: [SMatrix<f64, 3, 3>; 4] = std::array::from_fn(|a| {
        let ga = grads[a];
        SMatrix::<f64, 3, 3>::from_rows(&[
            (f[0] * ga[0]).transpose(),
            (f[1] * ga[1]).transpose(),
            (f[0] * ga[1] + f[1] * ga[0]).transpose(),
        ])
    });
    let beta = if section.fibres.is_some() {
        SHEAR_AT_POINTS
    } else {
        1.0
    };
    let c = &geom.centre;
    if beta < 1.0 {
        let fc = gradient_at(&geom.frame, c, u);
        strain[2] = beta * strain[2] + (1.0 - beta) * fc[0].dot(&fc[1]);
        for (a, ba) in b.iter_mut().enumerate() {
            let row =
                ba.row(2) * beta + (fc[0] * c[a][1] + fc[1] * c[a][0]).transpose() * (1.0 - beta);
            ba.set_row(2, &row);
        }
    }
    let shear = [(*grads, beta), (*c, 1.0 - beta)];
    PointStrain {
        strain,
        b,
        grads: *grads,
        shear,
    }
}

/// Green-Lagrange strain (Voigt: E11, E22, 2 E12) of an in-plane deformation gradient.
pub(super) fn green_strain(f: &[Vector3<f64>; 2]) -> Vector3<f64> {
    Vector3::new(
        0.5 * (f[0].dot(&f[0]) - 1.0),
        0.5 * (f[1].dot(&f[1]) - 1.0),
        f[0].dot(&f[1]),
    )
}

/// Second Piola-Kirchhoff membrane stress (S11, S22, S12), MPa, at nodal displacements
/// `u`, averaged over the Gauss points (uniform in a homogeneous deformation).
pub fn membrane_stress(
    geom: &MembraneGeometry,
    section: &MembraneSection,
    u: &[Vector3<f64>; 4],
) -> Vector3<f64> {
    let mut s = Vector3::zeros();
    for g in 0..4 {
        let strain = point_strain(geom, section, g, u).strain;
        s += section.elasticity(&geom.frame, &strain) * strain * geom.weights[g];
    }
    s / geom.area()
}

/// Energy (N mm), internal force (N) and tangent (N/mm) of a membrane element at nodal
/// displacements `u`.
pub fn membrane_response(
    geom: &MembraneGeometry,
    section: &MembraneSection,
    u: &[Vector3<f64>; 4],
) -> (f64, MembraneVector, MembraneMatrix) {
    let t = section.thickness_mm;
    let mut energy = 0.0;
    let mut force = MembraneVector::zeros();
    let mut k = MembraneMatrix::zeros();
    for g in 0..4 {
        let PointStrain {
            strain,
            b,
            grads,
            shear,
        } = point_strain(geom, section, g, u);
        let d = section.elasticity(&geom.frame, &strain);
        let s = d * strain;
        let w = t * geom.weights[g];
        energy += w * 0.5 * strain.dot(&s);
        for a in 0..4 {
            let fa = b[a].transpose() * s;
            for i in 0..3 {
                force[3 * a + i] += w * fa[i];
            }
            let bd = b[a].transpose() * d;
            for bn in 0..4 {
                let kab = bd * b[bn];
                // S : ∂²E/∂u_a∂u_b, each strain's second derivative at its own point.
                let geo = s[0] * grads[a][0] * grads[bn][0]
                    + s[1] * grads[a][1] * grads[bn][1]
                    + s[2]
                        * shear
                            .iter()
                            .map(|(q, w)| w * (q[a][0] * q[bn][1] + q[a][1] * q[bn][0]))
                            .sum::<f64>();
                for i in 0..3 {
                    for kk in 0..3 {
                        let delta = if i == kk { geo } else { 0.0 };
                        k[(3 * a + i, 3 * bn + kk)] += w * (kab[(i, kk)] + delta);
                    }
                }
            }
        }
    }
    (energy, force, k)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::material::Yeoh;
    use crate::fem::pressure::CLOSED;
    use crate::fem::solve::{solve_static, Model, NewtonSettings};

    fn paper() -> MembraneSection {
        MembraneSection::isotropic(0.1, 3000.0, 0.3)
    }

    /// A skewed quadrilateral in an inclined plane.
    fn quad() -> [Vector3<f64>; 4] {
        let r = nalgebra::Rotation3::from_euler_angles(0.4, -0.3, 0.7);
        [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.6, 0.2, 0.0),
            Vector3::new(1.4, 1.3, 0.0),
            Vector3::new(-0.1, 1.1, 0.0),
        ]
        .map(|p| r * p + Vector3::new(3.0, -1.0, 2.0))
    }

    /// Kevlar threads smeared over the quad of [`quad`], along its first edge turned by 30°.
    fn threads(tension_only: bool) -> MembraneSection {
        let x = quad();
        let (e1, n) = (
            (x[1] - x[0]).normalize(),
            (x[2] - x[0]).cross(&(x[3] - x[1])).normalize(),
        );
        let a = nalgebra::Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(n),
            std::f64::consts::FRAC_PI_6,
        ) * e1;
        MembraneSection {
            fibres: Some(Fibres {
                direction: a.into(),
                tension_only,
            }),
            ..MembraneSection::isotropic(0.0177, 31_067.0, 0.0)
        }
    }

    #[test]
    fn force_and_tangent_are_derivatives_of_the_energy() {
        for section in [paper(), threads(false), threads(true)] {
            derivatives_of_the_energy(section);
        }
    }

    /// Threads stretched along themselves carry E t E_ff along them and nothing across;
    /// stretched across they carry nothing; tension-only threads shortened carry nothing.
    #[test]
    fn smeared_threads_carry_stress_along_themselves_only() {
        let x = quad();
        let geom = MembraneGeometry::new(&x).unwrap();
        let section = threads(false);
        let a = Vector3::from(section.fibres.unwrap().direction);
        let n = geom.frame[0].cross(&geom.frame[1]);
        let across = n.cross(&a);
        for (dir, stretch, tension_only, expect) in [
            (a, 1.01, false, 0.5 * (1.01f64 * 1.01 - 1.0) * 31_067.0),
            (a, 0.99, false, 0.5 * (0.99f64 * 0.99 - 1.0) * 31_067.0),
            (a, 0.99, true, 0.0),
            (across, 1.02, false, 0.0),
        ] {
            // Homogeneous stretch along `dir`: x = X + (λ − 1)(dir · X) dir.
            let u: [Vector3<f64>; 4] =
                std::array::from_fn(|k| dir * ((stretch - 1.0) * dir.dot(&x[k])));
            let section = MembraneSection {
                fibres: Some(Fibres {
                    tension_only,
                    ..section.fibres.unwrap()
                }),
                ..section
            };
            let s = membrane_stress(&geom, &section, &u);
            // S = E E_ff a ⊗ a: its component along a, and the trace (nothing else).
            let al = Vector2::new(a.dot(&geom.frame[0]), a.dot(&geom.frame[1]));
            let sm = Matrix2::new(s[0], s[2], s[2], s[1]);
            let along = al.dot(&(sm * al));
            assert!(
                (along - expect).abs() < 1e-9 * 31_067.0,
                "{along} vs {expect}"
            );
            assert!(
                (sm.trace() - expect).abs() < 1e-9 * 31_067.0,
                "trace {}",
                sm.trace()
            );
        }
    }

    /// In-plane bending of a rectangle 2a x 2b (u_x = κ x y, the bilinear part of pure
    /// bending) under threads at 84° to x (the tube's helix at the default pitch): the
    /// energy is the exact ½ E t ∫ (a_x² κ y)² dA plus SHEAR_AT_POINTS² times the plain
    /// quad's parasitic shear term, which is (a_y a / a_x b)² = 161 times the exact one.
    #[test]
    fn threads_see_a_fraction_of_the_parasitic_shear_of_in_plane_bending() {
        let (a, b, kappa) = (1.0, 0.75, 1e-6);
        let x = [(-a, -b), (a, -b), (a, b), (-a, b)].map(|(p, q)| Vector3::new(p, q, 0.0));
        let geom = MembraneGeometry::new(&x).unwrap();
        let th = 84f64.to_radians();
        let (ax, ay) = (th.cos(), th.sin());
        let section = MembraneSection {
            fibres: Some(Fibres {
                direction: [ax, ay, 0.0],
                tension_only: false,
            }),
            ..MembraneSection::isotropic(0.0177, 31_067.0, 0.0)
        };
        let u = x.map(|p| Vector3::new(kappa * p.x * p.y, 0.0, 0.0));
        let (energy, _, _) = membrane_response(&geom, &section, &u);
        let half_et = 0.5 * 31_067.0 * 0.0177;
        let exact = half_et * kappa * kappa * 4.0 * a * b * ax.powi(4) * b * b / 3.0;
        let parasitic = half_et * kappa * kappa * 4.0 * a * b * (ax * ay).powi(2) * a * a / 3.0;
        assert!(
            (parasitic / exact - 161.0).abs() < 1.0,
            "{}",
            parasitic / exact
        );
        let expect = exact + SHEAR_AT_POINTS.powi(2) * parasitic;
        // Green-Lagrange's quadratic terms are κ² smaller.
        assert!(
            (energy / expect - 1.0).abs() < 1e-5,
            "{energy} vs {expect} (exact {exact}, parasitic {parasitic})"
        );
    }

    fn derivatives_of_the_energy(section: MembraneSection) {
        let x = quad();
        let geom = MembraneGeometry::new(&x).unwrap();
        let u: [Vector3<f64>; 4] = std::array::from_fn(|a| {
            let t = a as f64;
            Vector3::new(
                0.03 * (t * 0.7).sin(),
                0.05 * (t * 1.3).cos(),
                -0.04 * (t * 0.4 + 0.2).sin(),
            ) + 0.1 * (x[a] - x[0])
        });
        let (_, f, k) = membrane_response(&geom, &section, &u);
        assert!(f.norm() > 0.0);
        let h = 1e-6;
        for dof in 0..12 {
            let mut up = u;
            let mut um = u;
            up[dof / 3][dof % 3] += h;
            um[dof / 3][dof % 3] -= h;
            let (ep, fp, _) = membrane_response(&geom, &section, &up);
            let (em, fm, _) = membrane_response(&geom, &section, &um);
            let fd = (ep - em) / (2.0 * h);
            assert!(
                (fd - f[dof]).abs() < 1e-6 * f.norm(),
                "f[{dof}] {} vs {fd}",
                f[dof]
            );
            let col = (fp - fm) / (2.0 * h);
            for r in 0..12 {
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

    #[test]
    fn rigid_motion_is_stress_free() {
        let x = quad();
        let geom = MembraneGeometry::new(&x).unwrap();
        let r = nalgebra::Rotation3::from_euler_angles(1.1, 0.5, -0.8);
        let u: [Vector3<f64>; 4] =
            std::array::from_fn(|a| r * x[a] - x[a] + Vector3::new(1.0, -2.0, 0.5));
        let (e, f, _) = membrane_response(&geom, &paper(), &u);
        assert!(e.abs() < 1e-9 && f.norm() < 1e-9, "{e} {}", f.norm());
    }

    /// Patch test: a 2 x 2 mm sheet meshed by 3 x 3 distorted quadrilaterals, stretched
    /// by a dead uniaxial traction on its edge X = 2 (nominal stress P11 of a finite
    /// uniaxial state, E11 = 5%), held at X = 0 (x), at one node (y) and out of plane.
    /// The exact solution is homogeneous: every node must land on x = F X.
    #[test]
    fn distorted_patch_reproduces_a_finite_uniaxial_stretch() {
        let section = paper();
        let (e, nu) = (section.youngs_modulus_mpa, section.poisson_ratio);
        let e11 = 0.05;
        let s11 = e * e11; // plane-stress uniaxial: S11 = E E11, S22 = 0
        let e22 = -nu * e11;
        let (f11, f22) = ((1.0 + 2.0 * e11).sqrt(), (1.0 + 2.0 * e22).sqrt());
        let p11 = f11 * s11; // nominal traction on X = const
        let n = 3;
        let id = |i: usize, j: usize| j * (n + 1) + i;
        let mut nodes = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (mut x, mut y) = (2.0 * i as f64 / n as f64, 2.0 * j as f64 / n as f64);
                if i > 0 && i < n && j > 0 && j < n {
                    // Interior nodes moved off the grid (a distorted patch).
                    x += 0.17 * (1.3 * (i + 2 * j) as f64).sin();
                    y += 0.15 * (0.9 * (2 * i + j) as f64).cos();
                }
                nodes.push(Vector3::new(x, y, 0.0));
            }
        }
        let mut membranes = Vec::new();
        for j in 0..n {
            for i in 0..n {
                membranes.push(MembraneElement {
                    nodes: [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)],
                    section,
                });
            }
        }
        let mut fixed = vec![false; 3 * nodes.len()];
        let mut loads = vec![0.0; 3 * nodes.len()];
        for j in 0..=n {
            fixed[3 * id(0, j)] = true;
            let (y0, y1) = (
                nodes[id(n, j.saturating_sub(1))].y,
                nodes[id(n, (j + 1).min(n))].y,
            );
            // Half of each adjacent edge segment (length along the edge X = 2).
            loads[3 * id(n, j)] = section.thickness_mm * p11 * 0.5 * (y1 - y0);
        }
        fixed[3 * id(0, 0) + 1] = true;
        for a in 0..nodes.len() {
            fixed[3 * a + 2] = true;
        }
        let model = Model {
            nodes: nodes.clone(),
            elements: Vec::new(),
            material: Yeoh {
                c1: 0.1,
                c2: 0.0,
                c3: 0.0,
                bulk_modulus: 100.0,
            },
            fixed,
            loads,
            pressure_faces: Vec::new(),
            volume_weights: CLOSED,
            element_material: Vec::new(),
            extra_materials: Vec::new(),
            membranes,
            tri_membranes: Vec::new(),
            trusses: Vec::new(),
            plates: Vec::new(),
            incompatible_modes: false,
            tets: Default::default(),
            contact: None,
        };
        let r = solve_static(&model, &NewtonSettings::default()).unwrap();
        let mut worst: f64 = 0.0;
        for (a, x) in nodes.iter().enumerate() {
            let exact = Vector3::new((f11 - 1.0) * x.x, (f22 - 1.0) * x.y, 0.0);
            let got = Vector3::new(
                r.displacement[3 * a],
                r.displacement[3 * a + 1],
                r.displacement[3 * a + 2],
            );
            worst = worst.max((got - exact).norm());
        }
        eprintln!("membrane patch: worst nodal error {worst:.2e} mm (stretch {f11:.6})");
        assert!(worst < 1e-10, "{worst}");
    }
}
