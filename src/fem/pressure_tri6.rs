//! Follower pressure on 6-node triangle faces (the faces of [`super::tet10`]), as the
//! potential −p V of the enclosed volume, with its consistent load stiffness.
//!
//! As for the quad faces of [`super::pressure`]: each face contributes
//! V_f = ∫ (W x) · (x_ξ × x_η) dξ dη, W = diag(w), w_x + w_y + w_z = 1; summed over a
//! closed surface (or one closed by planes on which (W x) · n = 0) this is the enclosed
//! volume, its gradient the follower force ∫ N_a n da and its Hessian the load
//! stiffness, symmetric. With quadratic shape functions x is of degree 2 and x_ξ, x_η of
//! degree 1, so the integrand is of degree 4: the 6-point rule of Dunavant (1985,
//! degree 4, positive weights) integrates it exactly.
//!
//! Node order: corners 0, 1, 2 counter-clockwise seen from the side the normal points
//! to, then the mid-nodes of edges 01, 12, 20; volume coordinates L0 = 1 − ξ − η,
//! L1 = ξ, L2 = η. The normal x_ξ × x_η points out of the cavity (into the wall).

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Face stiffness (18 x 18).
pub type Tri6Matrix = SMatrix<f64, 18, 18>;
/// Face force (18).
pub type Tri6Vector = SVector<f64, 18>;

/// Dunavant's degree-4 rule on the reference triangle: (L0, L1, L2, weight), the
/// weights summing to its area 1/2.
const RULE: [(f64, f64, f64, f64); 6] = {
    const A1: f64 = 0.445_948_490_915_965;
    const B1: f64 = 0.108_103_018_168_070;
    const W1: f64 = 0.5 * 0.223_381_589_678_011;
    const A2: f64 = 0.091_576_213_509_771;
    const B2: f64 = 0.816_847_572_980_459;
    const W2: f64 = 0.5 * 0.109_951_743_655_322;
    [
        (B1, A1, A1, W1),
        (A1, B1, A1, W1),
        (A1, A1, B1, W1),
        (B2, A2, A2, W2),
        (A2, B2, A2, W2),
        (A2, A2, B2, W2),
    ]
};

const EDGES: [[usize; 2]; 3] = [[0, 1], [1, 2], [2, 0]];

/// Shape functions and their ξ, η derivatives at volume coordinates `l`.
fn shape(l: [f64; 3]) -> ([f64; 6], [f64; 6], [f64; 6]) {
    let mut n = [0.0; 6];
    let mut dl = [[0.0; 3]; 6];
    for a in 0..3 {
        n[a] = l[a] * (2.0 * l[a] - 1.0);
        dl[a][a] = 4.0 * l[a] - 1.0;
    }
    for (k, &[i, j]) in EDGES.iter().enumerate() {
        n[3 + k] = 4.0 * l[i] * l[j];
        dl[3 + k][i] = 4.0 * l[j];
        dl[3 + k][j] = 4.0 * l[i];
    }
    (n, dl.map(|d| d[1] - d[0]), dl.map(|d| d[2] - d[0]))
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Weights of the divergence-theorem field of a closed 3D cavity: x / 3.
pub const CLOSED: Vector3<f64> = super::pressure::CLOSED;

/// The face's volume share V_f = ∫ (W x) · (x_ξ × x_η), W = diag(w), its gradient and
/// Hessian with respect to the current positions of its 6 nodes: −p times them are the
/// follower force's potential, the force and the load stiffness.
pub fn face_volume(x: &[Vector3<f64>; 6], w: &Vector3<f64>) -> (f64, Tri6Vector, Tri6Matrix) {
    let wm = Matrix3::from_diagonal(w);
    let mut v = 0.0;
    let mut grad = Tri6Vector::zeros();
    let mut hess = Tri6Matrix::zeros();
    for (l0, l1, l2, wt) in RULE {
        let (n, dxi, deta) = shape([l0, l1, l2]);
        let (mut p, mut t1, mut t2) = (Vector3::zeros(), Vector3::zeros(), Vector3::zeros());
        for a in 0..6 {
            p += n[a] * x[a];
            t1 += dxi[a] * x[a];
            t2 += deta[a] * x[a];
        }
        let normal = t1.cross(&t2);
        let q = wm * p;
        v += wt * q.dot(&normal);
        let (t2xq, qxt1, wn) = (t2.cross(&q), q.cross(&t1), wm * normal);
        let (sq, s1w, s2w) = (skew(&q), skew(&t1) * wm, skew(&t2) * wm);
        for a in 0..6 {
            let g = n[a] * wn + dxi[a] * t2xq + deta[a] * qxt1;
            for i in 0..3 {
                grad[3 * a + i] += wt * g[i];
            }
            for b in 0..6 {
                // The triple product (W x) · (t1 × t2) is trilinear in (x, t1, t2),
                // whose coefficients are (N, N_ξ, N_η).
                let h = n[a] * dxi[b] * s2w.transpose() + dxi[a] * n[b] * s2w
                    - n[a] * deta[b] * s1w.transpose()
                    - deta[a] * n[b] * s1w
                    + (dxi[a] * deta[b] - deta[a] * dxi[b]) * (-sq);
                for i in 0..3 {
                    for m in 0..3 {
                        hess[(3 * a + i, 3 * b + m)] += wt * h[(i, m)];
                    }
                }
            }
        }
    }
    (v, grad, hess)
}

/// The follower force of a unit pressure on the face, ∫ N_a n da (N per MPa), along
/// x_ξ × x_η.
pub fn follower_force(x: &[Vector3<f64>; 6]) -> Tri6Vector {
    let mut f = Tri6Vector::zeros();
    for (l0, l1, l2, wt) in RULE {
        let (n, dxi, deta) = shape([l0, l1, l2]);
        let (mut t1, mut t2) = (Vector3::zeros(), Vector3::zeros());
        for a in 0..6 {
            t1 += dxi[a] * x[a];
            t2 += deta[a] * x[a];
        }
        let normal = t1.cross(&t2) * wt;
        for a in 0..6 {
            for i in 0..3 {
                f[3 * a + i] += n[a] * normal[i];
            }
        }
    }
    f
}

/// ∫ N_a da of each node (mm²): the nodal shares of a uniform dead traction.
pub fn nodal_areas(x: &[Vector3<f64>; 6]) -> [f64; 6] {
    let mut out = [0.0; 6];
    for (l0, l1, l2, wt) in RULE {
        let (n, dxi, deta) = shape([l0, l1, l2]);
        let (mut t1, mut t2) = (Vector3::zeros(), Vector3::zeros());
        for a in 0..6 {
            t1 += dxi[a] * x[a];
            t2 += deta[a] * x[a];
        }
        let da = t1.cross(&t2).norm() * wt;
        for a in 0..6 {
            out[a] += n[a] * da;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::tet10::{Tet10Geometry, EDGES as TET_EDGES, FACES};

    /// A tetrahedron with curved edges.
    fn curved_tet() -> [Vector3<f64>; 10] {
        let c = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(2.0, 0.1, -0.1),
            Vector3::new(0.3, 1.8, 0.2),
            Vector3::new(0.2, 0.4, 1.5),
        ];
        std::array::from_fn(|a| {
            if a < 4 {
                c[a]
            } else {
                let [i, j] = TET_EDGES[a - 4];
                let t = a as f64;
                0.5 * (c[i] + c[j]) + 0.08 * Vector3::new(t.sin(), (1.7 * t).cos(), (0.6 * t).sin())
            }
        })
    }

    fn face(x: &[Vector3<f64>; 10], f: &[usize; 6]) -> [Vector3<f64>; 6] {
        std::array::from_fn(|k| x[f[k]])
    }

    #[test]
    fn closed_surface_encloses_the_volume_and_carries_no_net_force() {
        // Straight edges: the enclosed volume is the tetrahedron's exactly.
        let mut x = curved_tet();
        for (k, &[i, j]) in TET_EDGES.iter().enumerate() {
            x[4 + k] = 0.5 * (x[i] + x[j]);
        }
        let v: f64 = FACES
            .iter()
            .map(|f| face_volume(&face(&x, f), &CLOSED).0)
            .sum();
        let geom = Tet10Geometry::new(&x).unwrap();
        assert!(
            (v - geom.volume).abs() < 1e-13 * v,
            "{v} vs {}",
            geom.volume
        );
        // Curved edges: uniform pressure on the closed surface has zero resultant, and
        // the volume's gradient assembled is the assembled follower force.
        let x = curved_tet();
        let mut total = Vector3::<f64>::zeros();
        let mut grad = [Vector3::<f64>::zeros(); 10];
        let mut follow = [Vector3::<f64>::zeros(); 10];
        for f in &FACES {
            let (_, g, _) = face_volume(&face(&x, f), &CLOSED);
            let ff = follower_force(&face(&x, f));
            for k in 0..6 {
                for i in 0..3 {
                    grad[f[k]][i] += g[3 * k + i];
                    follow[f[k]][i] += ff[3 * k + i];
                    total[i] += ff[3 * k + i];
                }
            }
        }
        assert!(total.norm() < 1e-14, "net force {total}");
        for a in 0..10 {
            assert!(
                (grad[a] - follow[a]).norm() < 1e-13,
                "{a}: {} vs {}",
                grad[a],
                follow[a]
            );
        }
    }

    #[test]
    fn flat_face_force_is_pressure_times_area_along_the_normal() {
        // A tilted flat triangle with straight edges: the resultant is A n, carried by
        // the mid-nodes alone, A/3 each (the corners' shares of a quadratic triangle
        // under a uniform load are zero).
        let c = [
            Vector3::new(0.2, -0.1, 0.3),
            Vector3::new(3.0, 0.4, 1.1),
            Vector3::new(0.9, 2.5, -0.4),
        ];
        let x: [Vector3<f64>; 6] = std::array::from_fn(|a| {
            if a < 3 {
                c[a]
            } else {
                let [i, j] = EDGES[a - 3];
                0.5 * (c[i] + c[j])
            }
        });
        let an = 0.5 * (c[1] - c[0]).cross(&(c[2] - c[0]));
        let area = an.norm();
        let f = follower_force(&x);
        let total: Vector3<f64> = (0..6).map(|a| f.fixed_rows::<3>(3 * a).into_owned()).sum();
        assert!((total - an).norm() < 1e-13 * area, "{total} vs {an}");
        for a in 0..6 {
            let want = if a < 3 { 0.0 } else { area / 3.0 };
            let got = f.fixed_rows::<3>(3 * a).into_owned();
            assert!(
                (got - an.normalize() * want).norm() < 1e-13 * area,
                "node {a}: {got}"
            );
        }
        let shares = nodal_areas(&x);
        assert!((shares.iter().sum::<f64>() - area).abs() < 1e-13 * area);
        assert!((shares[4] - area / 3.0).abs() < 1e-13 * area && shares[1].abs() < 1e-13);
    }

    #[test]
    fn gradient_and_hessian_are_derivatives_of_the_face_volume() {
        let x = face(&curved_tet(), &FACES[2]);
        let w = Vector3::new(0.5, 0.2, 0.3);
        let (_, g, h) = face_volume(&x, &w);
        let eps = 1e-6;
        for d in 0..18 {
            let (mut xp, mut xm) = (x, x);
            xp[d / 3][d % 3] += eps;
            xm[d / 3][d % 3] -= eps;
            let (vp, gp, _) = face_volume(&xp, &w);
            let (vm, gm, _) = face_volume(&xm, &w);
            // Central differences of a cubic in each coordinate: exact to round-off.
            assert!(((vp - vm) / (2.0 * eps) - g[d]).abs() < 1e-8, "grad {d}");
            let col = (gp - gm) / (2.0 * eps);
            for r in 0..18 {
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
