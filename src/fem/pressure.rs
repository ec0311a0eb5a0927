//! Follower pressure on cavity faces, as the potential −p V of the enclosed volume.
//!
//! A uniform pressure p on a closed cavity surface that follows the deformation is a
//! conservative load: its virtual work p ∫ n · δx da is the variation of p V, V being the
//! cavity volume. Each bilinear quad face contributes V_f = 1/3 ∫ x · (x_ξ × x_η) dξ dη
//! (divergence theorem with the field x/3, div = 1); more generally
//! V_f = ∫ (W x) · (x_ξ × x_η) dξ dη with W = diag(w), w_x + w_y + w_z = 1. Summed over
//! a closed surface, or one closed by planes on which (W x) · n = 0 (symmetry planes
//! through the origin; for plane strain, w_z = 0 removes the z = const caps), this is
//! the cavity volume, its gradient is the follower force
//! ∫ N_a n da, and its Hessian is the consistent load stiffness: symmetric, so the
//! tangent of the whole problem stays symmetric and the solver keeps its Cholesky
//! factorization. The integrand is of degree 2 in ξ and η, so 2 x 2 Gauss points
//! integrate it exactly.
//!
//! Face node order: counter-clockwise seen from the side the normal points to; the
//! normal x_ξ × x_η points out of the cavity (into the wall).

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Face stiffness (12 x 12).
pub type FaceMatrix = SMatrix<f64, 12, 12>;
/// Face force (12).
pub type FaceVector = SVector<f64, 12>;

const GP: f64 = 0.577_350_269_189_625_8;
const CORNERS: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Shape functions and their ξ, η derivatives at a Gauss point.
fn shape(xi: f64, eta: f64) -> ([f64; 4], [f64; 4], [f64; 4]) {
    let mut n = [0.0; 4];
    let mut dxi = [0.0; 4];
    let mut deta = [0.0; 4];
    for (a, c) in CORNERS.iter().enumerate() {
        n[a] = 0.25 * (1.0 + c[0] * xi) * (1.0 + c[1] * eta);
        dxi[a] = 0.25 * c[0] * (1.0 + c[1] * eta);
        deta[a] = 0.25 * c[1] * (1.0 + c[0] * xi);
    }
    (n, dxi, deta)
}

/// Weights of the divergence-theorem field of a closed 3D cavity: x / 3.
pub const CLOSED: Vector3<f64> = Vector3::new(1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0);

/// The face's volume share V_f = ∫ (W x) · (x_ξ × x_η), W = diag(w), its gradient ∂V_f/∂x
/// and Hessian ∂²V_f/∂x² with respect to the current positions of its 4 nodes.
pub fn face_volume(x: &[Vector3<f64>; 4], w: &Vector3<f64>) -> (f64, FaceVector, FaceMatrix) {
    let wm = Matrix3::from_diagonal(w);
    let mut v = 0.0;
    let mut grad = FaceVector::zeros();
    let mut hess = FaceMatrix::zeros();
    for c in CORNERS {
        let (n, dxi, deta) = shape(c[0] * GP, c[1] * GP);
        let mut p = Vector3::zeros();
        let mut t1 = Vector3::zeros();
        let mut t2 = Vector3::zeros();
        for a in 0..4 {
            p += n[a] * x[a];
            t1 += dxi[a] * x[a];
            t2 += deta[a] * x[a];
        }
        let normal = t1.cross(&t2);
        let q = wm * p;
        v += q.dot(&normal);
        let (t2xq, qxt1, wn) = (t2.cross(&q), q.cross(&t1), wm * normal);
        let (sq, s1w, s2w) = (skew(&q), skew(&t1) * wm, skew(&t2) * wm);
        for a in 0..4 {
            let g = n[a] * wn + dxi[a] * t2xq + deta[a] * qxt1;
            for i in 0..3 {
                grad[3 * a + i] += g[i];
            }
            for b in 0..4 {
                // Second derivatives of the triple product (W x) · (t1 × t2), trilinear
                // in (x, t1, t2) with coefficients (N, N_ξ, N_η).
                let h = n[a] * dxi[b] * s2w.transpose() + dxi[a] * n[b] * s2w
                    - n[a] * deta[b] * s1w.transpose()
                    - deta[a] * n[b] * s1w
                    + (dxi[a] * deta[b] - deta[a] * dxi[b]) * (-sq);
                for i in 0..3 {
                    for m in 0..3 {
                        hess[(3 * a + i, 3 * b + m)] += h[(i, m)];
                    }
                }
            }
        }
    }
    (v, grad, hess)
}

/// The follower force of a unit pressure on the face, ∫ N_a n da (N per MPa).
pub fn follower_force(x: &[Vector3<f64>; 4]) -> FaceVector {
    let mut f = FaceVector::zeros();
    for c in CORNERS {
        let (n, dxi, deta) = shape(c[0] * GP, c[1] * GP);
        let mut t1 = Vector3::zeros();
        let mut t2 = Vector3::zeros();
        for a in 0..4 {
            t1 += dxi[a] * x[a];
            t2 += deta[a] * x[a];
        }
        let normal = t1.cross(&t2);
        for a in 0..4 {
            for i in 0..3 {
                f[3 * a + i] += n[a] * normal[i];
            }
        }
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 6 faces of a distorted hexahedron, outward normals (node indices into `x`).
    const BOX_FACES: [[usize; 4]; 6] = [
        [0, 3, 2, 1],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [1, 2, 6, 5],
        [2, 3, 7, 6],
        [3, 0, 4, 7],
    ];

    fn distorted_box() -> [Vector3<f64>; 8] {
        [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(2.1, 0.2, -0.1),
            Vector3::new(2.3, 1.8, 0.2),
            Vector3::new(-0.2, 1.5, 0.1),
            Vector3::new(0.1, -0.1, 1.2),
            Vector3::new(1.9, 0.1, 1.5),
            Vector3::new(2.2, 1.7, 1.4),
            Vector3::new(0.2, 1.6, 1.1),
        ]
    }

    fn faces_of(x: &[Vector3<f64>; 8], f: &[usize; 4]) -> [Vector3<f64>; 4] {
        std::array::from_fn(|k| x[f[k]])
    }

    #[test]
    fn closed_surface_volume_is_the_enclosed_volume() {
        // A box of 2 x 1.5 x 1.2 (exact) and the trilinear volume of a distorted hex
        // (same quadrature as the element).
        let b = [0, 1, 2, 3, 4, 5, 6, 7].map(|a: usize| {
            Vector3::new(
                2.0 * ((a == 1 || a == 2 || a == 5 || a == 6) as u8) as f64,
                1.5 * ((a == 2 || a == 3 || a == 6 || a == 7) as u8) as f64,
                1.2 * ((a >= 4) as u8) as f64,
            )
        });
        let v: f64 = BOX_FACES
            .iter()
            .map(|f| face_volume(&faces_of(&b, f), &CLOSED).0)
            .sum();
        assert!((v - 3.6).abs() < 1e-12, "{v}");
        let x = distorted_box();
        let v: f64 = BOX_FACES
            .iter()
            .map(|f| face_volume(&faces_of(&x, f), &CLOSED).0)
            .sum();
        let geom = crate::fem::hex::HexGeometry::new(&x).unwrap();
        assert!((v - geom.volume).abs() < 1e-12, "{v} vs {}", geom.volume);
    }

    #[test]
    fn gradient_of_the_closed_volume_is_the_follower_force() {
        let x = distorted_box();
        let mut grad = [Vector3::<f64>::zeros(); 8];
        let mut follow = [Vector3::<f64>::zeros(); 8];
        for f in &BOX_FACES {
            let (_, g, _) = face_volume(&faces_of(&x, f), &CLOSED);
            let ff = follower_force(&faces_of(&x, f));
            for k in 0..4 {
                for i in 0..3 {
                    grad[f[k]][i] += g[3 * k + i];
                    follow[f[k]][i] += ff[3 * k + i];
                }
            }
        }
        for a in 0..8 {
            assert!(
                (grad[a] - follow[a]).norm() < 1e-12,
                "{a}: {} vs {}",
                grad[a],
                follow[a]
            );
        }
    }

    #[test]
    fn gradient_and_hessian_are_derivatives_of_the_face_volume() {
        let x = faces_of(&distorted_box(), &BOX_FACES[3]);
        let w = Vector3::new(0.5, 0.2, 0.3);
        let (_, g, h) = face_volume(&x, &w);
        let eps = 1e-6;
        for d in 0..12 {
            let mut xp = x;
            let mut xm = x;
            xp[d / 3][d % 3] += eps;
            xm[d / 3][d % 3] -= eps;
            let (vp, gp, _) = face_volume(&xp, &w);
            let (vm, gm, _) = face_volume(&xm, &w);
            assert!(((vp - vm) / (2.0 * eps) - g[d]).abs() < 1e-8, "grad {d}");
            let col = (gp - gm) / (2.0 * eps);
            for r in 0..12 {
                assert!(
                    (col[r] - h[(r, d)]).abs() < 1e-8,
                    "H[{r},{d}] {} vs {}",
                    h[(r, d)],
                    col[r]
                );
            }
        }
        assert!((h - h.transpose()).norm() < 1e-12);
    }
}
