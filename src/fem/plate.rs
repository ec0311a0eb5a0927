//! Bending stiffness of a thin stiff sheet meshed as membranes: the quadratic bending
//! energy of a nearly inextensible plate on the membranes' nodes, with no rotations.
//!
//! Why written here: a membrane ([`super::membrane`]) has no bending stiffness, and in
//! compression a sheet without it, bonded to silicone 10⁴ times softer, wrinkles at the
//! mesh's own wavelength (the foundation holds it only to a critical force ~ G h,
//! a compressive strain of ~10⁻⁵ in a 6.5 GPa glass-fibre strip): the solution then
//! depends on the mesh and Newton stalls. A 0.5 mm strip has a bending stiffness
//! D = E t³ / 12 (1 − ν²) comparable with the whole silicone section's, so it also
//! matters for the bend itself. Shell elements would add rotations to every node the
//! sheet shares with the silicone; instead the energy is written in the second
//! derivatives of the position over the flat reference grid (a rotation-free plate):
//! ½ D [ν |x,₁₁ + x,₂₂|² + (1 − ν)(|x,₁₁|² + |x,₂₂|² + 2 |x,₁₂|²)]. For a small deflection
//! it is Kirchhoff's plate energy; for a sheet that bends without stretching (the
//! membranes keep it from stretching) x,αβ = II_αβ n (the curvature tensor times the
//! normal), so it is exact under large rotations, as the quadratic bending model of
//! Bergou et al. (2006, "A quadratic bending model for inextensible surfaces"), whose
//! |Δx|² alone lets a free edge curl into a saddle at no cost; and it is quadratic in the
//! displacement: a constant stiffness matrix.
//!
//! Discretization ([`plate_terms`]): x,αα by three-point second differences along each
//! grid line through a node that has a neighbour on both sides (weights of an uneven
//! grid, so the flat grid's own second differences vanish and rigid motions cost
//! nothing), weighted by the node's tributary area; x,₁₂ by the bilinear twist of each
//! (rectangular) quad; a node on a symmetry plane takes its mirrored neighbour. A
//! clamped sheet is clamped by holding two rows of nodes; a free edge is free (natural).

use nalgebra::Vector3;
use serde::Serialize;

use super::membrane::{MembraneElement, MembraneGeometry};

/// Nodes of one bending term: a node and its neighbours on up to two grid lines (5), or
/// a node and the neighbours of its fit on triangles ([`super::plate_tri`], up to 11).
pub const PLATE_NODES: usize = 12;

/// What a bending term's second derivative is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Curvature {
    /// x,αα along one grid line through a node.
    Line,
    /// x,₁₁ + x,₂₂ at a node.
    Sum,
    /// x,₁₂ of a quad.
    Twist,
}

/// One bending term: energy ½ k |Σ_j w_j ⊙ u_j|² (u the nodal displacements, w_j a
/// weight per displacement component: a mirrored neighbour's normal component drops).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PlateTerm {
    /// The nodes (unused entries repeat the first, with weight 0).
    pub nodes: [usize; PLATE_NODES],
    /// Finite-difference weights per node and component, 1/mm².
    pub weights: [[f64; 3]; PLATE_NODES],
    /// D times the term's area (and its factor ν, 1 − ν or 2 (1 − ν)), N mm³.
    pub stiffness: f64,
    /// The second derivative it measures.
    pub curvature: Curvature,
}

impl PlateTerm {
    /// The second derivative this term measures, mm⁻¹.
    pub fn value(&self, u: &[f64]) -> Vector3<f64> {
        let mut l = Vector3::zeros();
        for (n, w) in self.nodes.iter().zip(&self.weights) {
            for i in 0..3 {
                l[i] += w[i] * u[3 * n + i];
            }
        }
        l
    }

    /// Energy (N mm) at displacements `u` (3 per node of the model).
    pub fn energy(&self, u: &[f64]) -> f64 {
        0.5 * self.stiffness * self.value(u).norm_squared()
    }

    /// Internal force on the term's nodes (3 per node, node-major), N.
    pub fn force(&self, u: &[f64]) -> [f64; 3 * PLATE_NODES] {
        let l = self.value(u) * self.stiffness;
        let mut f = [0.0; 3 * PLATE_NODES];
        for (a, w) in self.weights.iter().enumerate() {
            for i in 0..3 {
                f[3 * a + i] = w[i] * l[i];
            }
        }
        f
    }

    /// How many of the node entries are the term's (the rest are padding: the first
    /// node again, weight 0).
    pub fn used(&self) -> usize {
        (1..PLATE_NODES)
            .rev()
            .find(|&k| self.nodes[k] != self.nodes[0] || self.weights[k] != [0.0; 3])
            .map_or(1, |k| k + 1)
    }

    /// Tangent entry between dof (a, i) and (b, k) of the term's nodes, N/mm.
    pub fn tangent(&self, a: usize, i: usize, b: usize, k: usize) -> f64 {
        if i == k {
            self.stiffness * self.weights[a][i] * self.weights[b][i]
        } else {
            0.0
        }
    }

    pub(crate) fn new(stencil: &[(usize, [f64; 3])], stiffness: f64, curvature: Curvature) -> Self {
        let mut term = Self {
            nodes: [stencil[0].0; PLATE_NODES],
            weights: [[0.0; 3]; PLATE_NODES],
            stiffness,
            curvature,
        };
        for (k, (node, w)) in stencil.iter().take(PLATE_NODES).enumerate() {
            term.nodes[k] = *node;
            term.weights[k] = *w;
        }
        term
    }
}

/// The largest surface bending stress of a plate's `terms` at displacements `u`, MPa:
/// E t / (2 (1 − ν²)) times the largest curvature along a grid line plus the largest
/// twist, an upper estimate of the principal bending stress (exact for a cylindrical
/// bend along a grid line).
pub fn surface_bending_stress(
    terms: &[PlateTerm],
    u: &[f64],
    thickness_mm: f64,
    youngs_modulus_mpa: f64,
    poisson_ratio: f64,
) -> f64 {
    let largest = |kind: Curvature| {
        terms
            .iter()
            .filter(|t| t.curvature == kind)
            .map(|t| t.value(u).norm())
            .fold(0.0, f64::max)
    };
    let kappa = largest(Curvature::Line) + largest(Curvature::Twist);
    youngs_modulus_mpa * thickness_mm / (2.0 * (1.0 - poisson_ratio * poisson_ratio)) * kappa
}

/// Bending stiffness per unit width of a plate, N mm.
pub fn flexural_rigidity(thickness_mm: f64, youngs_modulus_mpa: f64, poisson_ratio: f64) -> f64 {
    youngs_modulus_mpa * thickness_mm.powi(3) / (12.0 * (1.0 - poisson_ratio * poisson_ratio))
}

/// A symmetry plane of the mesh, `X[axis] = at`: a sheet's node on it has a mirrored
/// neighbour (its displacement reflected) across it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mirror {
    /// The plane's normal axis (0 x, 1 y, 2 z).
    pub axis: usize,
    /// Its coordinate, mm.
    pub at: f64,
}

/// The bending terms of a sheet of rigidity `d` (N mm) and Poisson ratio `nu`, meshed
/// as the structured rectangular grid of `membranes` (indices into `all`), reference
/// positions `nodes`, cut by the symmetry planes `mirrors`.
///
/// The plate energy density ½ D [ν |x,₁₁ + x,₂₂|² + (1 − ν)(|x,₁₁|² + |x,₂₂|² + 2 |x,₁₂|²)]
/// (Kirchhoff's ½ D [(w,₁₁ + w,₂₂)² − 2 (1 − ν)(w,₁₁ w,₂₂ − w,₁₂²)] for a small deflection
/// w; for an isometry x,αβ = II_αβ n, the curvature tensor): x,αα by three-point
/// differences along the grid lines at each node (tributary area), x,₁₂ by the
/// bilinear twist of each quad (its area).
pub fn plate_terms(
    nodes: &[Vector3<f64>],
    all: &[MembraneElement],
    membranes: &[usize],
    d: f64,
    nu: f64,
    mirrors: &[Mirror],
) -> Vec<PlateTerm> {
    use std::collections::BTreeMap;
    let mut terms = Vec::new();
    let mut area: BTreeMap<usize, f64> = BTreeMap::new();
    let mut neighbours: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for &m in membranes {
        let q = all[m].nodes;
        let x: [Vector3<f64>; 4] = std::array::from_fn(|a| nodes[q[a]]);
        let (l1, l2) = ((x[1] - x[0]).norm(), (x[3] - x[0]).norm());
        let a = MembraneGeometry::new(&x).map_or(0.0, |g| g.area());
        // Twist of the bilinear quad: x,₁₂ = (x₀ − x₁ + x₂ − x₃) / (l₁ l₂).
        let w = 1.0 / (l1 * l2);
        let twist: Vec<(usize, [f64; 3])> = q
            .iter()
            .zip([w, -w, w, -w])
            .map(|(n, s)| (*n, [s; 3]))
            .collect();
        terms.push(PlateTerm::new(
            &twist,
            2.0 * (1.0 - nu) * d * a,
            Curvature::Twist,
        ));
        for k in 0..4 {
            *area.entry(q[k]).or_default() += 0.25 * a;
            for other in [q[(k + 1) % 4], q[(k + 3) % 4]] {
                let list = neighbours.entry(q[k]).or_default();
                if !list.contains(&other) {
                    list.push(other);
                }
            }
        }
    }
    for (&n, list) in &neighbours {
        // Each grid line through n: its three-point second difference, [(node, weights)].
        let mut lines: Vec<Vec<(usize, [f64; 3])>> = Vec::new();
        let mut used = vec![false; list.len()];
        for p in 0..list.len() {
            if used[p] {
                continue;
            }
            let dp = nodes[list[p]] - nodes[n];
            let opposite = (p + 1..list.len()).find(|&q| {
                let dq = nodes[list[q]] - nodes[n];
                !used[q] && dp.dot(&dq) < -0.999 * dp.norm() * dq.norm()
            });
            if let Some(q) = opposite {
                used[p] = true;
                used[q] = true;
                let (d1, d2) = (dp.norm(), (nodes[list[q]] - nodes[n]).norm());
                lines.push(vec![
                    (n, [-2.0 / (d1 * d2); 3]),
                    (list[p], [2.0 / (d1 * (d1 + d2)); 3]),
                    (list[q], [2.0 / (d2 * (d1 + d2)); 3]),
                ]);
            } else if let Some(m) = mirrors.iter().find(|m| {
                (nodes[n][m.axis] - m.at).abs() < 1e-9 && dp[m.axis].abs() > 0.999 * dp.norm()
            }) {
                // The mirrored neighbour's displacement is p's reflected: its normal
                // component cancels p's, the others add.
                used[p] = true;
                let h2 = dp.norm_squared();
                let mut wp = [2.0 / h2; 3];
                wp[m.axis] = 0.0;
                lines.push(vec![(n, [-2.0 / h2; 3]), (list[p], wp)]);
            }
        }
        let a = area[&n];
        match lines.as_slice() {
            [] => {}
            [one] => terms.push(PlateTerm::new(one, d * a, Curvature::Line)),
            [first, second, ..] => {
                let mut both = first.clone();
                for (node, w) in second {
                    if *node == n {
                        for (b, wi) in both[0].1.iter_mut().zip(w) {
                            *b += wi;
                        }
                    } else {
                        both.push((*node, *w));
                    }
                }
                terms.push(PlateTerm::new(&both, nu * d * a, Curvature::Sum));
                terms.push(PlateTerm::new(first, (1.0 - nu) * d * a, Curvature::Line));
                terms.push(PlateTerm::new(second, (1.0 - nu) * d * a, Curvature::Line));
            }
        }
    }
    terms
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::membrane::MembraneSection;

    /// A flat nx x ny grid of membranes in the xy plane, spacing hx, hy; node (i, j)
    /// is i + (nx + 1) j.
    fn grid(nx: usize, ny: usize, hx: f64, hy: f64) -> (Vec<Vector3<f64>>, Vec<MembraneElement>) {
        let section = MembraneSection::isotropic(0.5, 6500.0, 0.22);
        let id = |i: usize, j: usize| i + (nx + 1) * j;
        let nodes = (0..=ny)
            .flat_map(|j| (0..=nx).map(move |i| Vector3::new(i as f64 * hx, j as f64 * hy, 0.0)))
            .collect();
        let membranes = (0..ny)
            .flat_map(|j| {
                (0..nx).map(move |i| MembraneElement {
                    nodes: [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)],
                    section,
                })
            })
            .collect();
        (nodes, membranes)
    }

    fn total(terms: &[PlateTerm], u: &[f64]) -> f64 {
        terms.iter().map(|t| t.energy(u)).sum()
    }

    /// Rigid motions cost nothing; the grid rolled onto a cylinder of radius R (an
    /// isometry) stores ½ D A / R² (the interior nodes' share of the area).
    #[test]
    fn a_sheet_rolled_onto_a_cylinder_stores_the_plates_bending_energy() {
        let (nx, ny, h) = (40, 6, 1.0);
        let (nodes, membranes) = grid(nx, ny, h, h);
        let all: Vec<usize> = (0..membranes.len()).collect();
        let d = flexural_rigidity(0.5, 6500.0, 0.22);
        let terms = plate_terms(&nodes, &membranes, &all, d, 0.22, &[]);
        let rot = nalgebra::Rotation3::from_euler_angles(0.3, -0.7, 1.1);
        let shift = Vector3::new(3.0, -2.0, 5.0);
        let u: Vec<f64> = nodes
            .iter()
            .flat_map(|x| (rot * x + shift - x).iter().copied().collect::<Vec<_>>())
            .collect();
        let e_rigid = total(&terms, &u);
        assert!(e_rigid < 1e-18 * d, "rigid motion: {e_rigid}");
        let r = 15.0;
        let u: Vec<f64> = nodes
            .iter()
            .flat_map(|x| {
                let th = x.x / r;
                let y = Vector3::new(r * th.sin(), x.y, r * (1.0 - th.cos()));
                (y - x).iter().copied().collect::<Vec<_>>()
            })
            .collect();
        let e = total(&terms, &u);
        // The nodes with a line along x: all but the two end columns (x = 0, x = L).
        let area = (nx as f64 - 1.0) * h * ny as f64 * h;
        let expect = 0.5 * d * area / (r * r);
        assert!(
            (e / expect - 1.0).abs() < 0.002,
            "energy {e} against {expect} ({:+.3}%)",
            100.0 * (e / expect - 1.0)
        );
        // Its surfaces: E t / (2 (1 - nu^2)) / R, the chord's second difference within
        // (h / R)^2 / 12 of 1 / R; rigid motion none.
        let sigma = surface_bending_stress(&terms, &u, 0.5, 6500.0, 0.22);
        let want = 6500.0 * 0.5 / (2.0 * (1.0 - 0.22 * 0.22)) / r;
        assert!(
            (sigma / want - 1.0).abs() < 1e-3,
            "bending stress {sigma} against {want}"
        );
        assert!(surface_bending_stress(&terms, &vec![0.0; u.len()], 0.5, 6500.0, 0.22) == 0.0);
    }

    /// Force and tangent are the energy's gradient and Hessian (central differences).
    #[test]
    fn force_and_tangent_are_derivatives_of_the_energy() {
        let (nodes, membranes) = grid(3, 2, 1.0, 1.5);
        let all: Vec<usize> = (0..membranes.len()).collect();
        let terms = plate_terms(&nodes, &membranes, &all, 2.0, 0.3, &[]);
        let u: Vec<f64> = (0..3 * nodes.len())
            .map(|k| 0.1 * ((k * 7 % 11) as f64 - 5.0))
            .collect();
        let h = 1e-6;
        for t in &terms {
            let f = t.force(&u);
            for a in 0..3 * PLATE_NODES {
                let dof = 3 * t.nodes[a / 3] + a % 3;
                let shifted = |s: f64| {
                    let mut v = u.clone();
                    v[dof] += s;
                    v
                };
                let de = (t.energy(&shifted(h)) - t.energy(&shifted(-h))) / (2.0 * h);
                // A node repeated in the stencil (weight 0) gets its share once.
                let first = t.nodes.iter().position(|n| *n == t.nodes[a / 3]).unwrap();
                if first == a / 3 {
                    let fsum: f64 = (0..PLATE_NODES)
                        .filter(|b| t.nodes[*b] == t.nodes[a / 3])
                        .map(|b| f[3 * b + a % 3])
                        .sum();
                    assert!((de - fsum).abs() < 1e-6 * (1.0 + de.abs()), "{de} {fsum}");
                }
                let (fp, fm) = (t.force(&shifted(h)), t.force(&shifted(-h)));
                for b in 0..3 * PLATE_NODES {
                    let dk = (fp[b] - fm[b]) / (2.0 * h);
                    let k: f64 = (0..PLATE_NODES)
                        .filter(|c| t.nodes[*c] == t.nodes[a / 3])
                        .map(|c| t.tangent(b / 3, b % 3, c, a % 3))
                        .sum();
                    assert!((dk - k).abs() < 1e-6 * (1.0 + k.abs()), "{dk} {k}");
                }
            }
        }
    }

    /// The plate strip as a cantilever under a tip force: the terms' stiffness alone
    /// (small deflection, the membranes carry no bending) gives the beam's deflection
    /// P L³ / 3 D b within 2% (clamped by holding the first two rows of nodes); without
    /// the twist and the (1 − ν) terms the free edges would let it curl into a saddle
    /// at no cost (3.6 times the deflection, measured).
    #[test]
    fn a_clamped_strip_deflects_as_the_euler_bernoulli_cantilever() {
        let (nx, ny, h) = (60, 4, 0.5);
        let (nodes, membranes) = grid(nx, ny, h, h);
        let all: Vec<usize> = (0..membranes.len()).collect();
        // ν = 0: the narrow strip's beam and plate rigidities agree.
        let d = flexural_rigidity(0.5, 6500.0, 0.0);
        let terms = plate_terms(&nodes, &membranes, &all, d, 0.0, &[]);
        // Unknowns: w at the nodes with i >= 2 (z only: the bending decouples).
        let free: Vec<usize> = (0..nodes.len()).filter(|n| n % (nx + 1) >= 2).collect();
        let index = |n: usize| free.iter().position(|f| *f == n);
        let m = free.len();
        let mut k = nalgebra::DMatrix::<f64>::zeros(m, m);
        for t in &terms {
            for a in 0..PLATE_NODES {
                for b in 0..PLATE_NODES {
                    if let (Some(ia), Some(ib)) = (index(t.nodes[a]), index(t.nodes[b])) {
                        k[(ia, ib)] += t.tangent(a, 2, b, 2);
                    }
                }
            }
        }
        let p = 0.01; // N, spread over the tip column
        let mut f = nalgebra::DVector::<f64>::zeros(m);
        for j in 0..=ny {
            let share = if j == 0 || j == ny { 0.5 } else { 1.0 } / ny as f64;
            f[index(nx + (nx + 1) * j).unwrap()] = p * share;
        }
        let w = k.lu().solve(&f).unwrap();
        let tip = w[index(nx + (nx + 1) * (ny / 2)).unwrap()];
        // The first two rows held: clamped at half a spacing, the beam is L - h/2 long.
        let (l, b) = (nx as f64 * h - 0.5 * h, ny as f64 * h);
        let expect = p * l.powi(3) / (3.0 * d * b);
        assert!(
            (tip / expect - 1.0).abs() < 0.02,
            "tip {tip} against {expect} ({:+.2}%)",
            100.0 * (tip / expect - 1.0)
        );
    }
}
