//! A circular silicone tube with helical fibre windings: the cross-section of the
//! fibre-reinforced actuators' analytic models (Bishop-Moser & Kota 2015; Connolly,
//! Walsh & Bertoldi 2017), and the check of [`super::truss`] against them.
//!
//! Mesh: structured hexahedra in (r, θ, z) (ξ₁ radial, ξ₂ around, ξ₃ along the axis),
//! the whole circle. Supports: the base z = 0 is a symmetry plane (u_z = 0 on every base
//! node, u_y = 0 on the base nodes at θ = 0 and π, u_x = 0 at θ = ±π/2: rigid motions
//! removed, radial growth and twist about the axis left free), so the tube stands for
//! one of twice its length closed at both ends. The far end is closed by the
//! divergence-theorem weights w = (½, ½, 0) of [`super::pressure`]: the pressurized inner
//! wall then encloses V = π r² l between the planes z = 0 and z = l, and the end cap's
//! force p π r² acts on the end ring of the inner wall (Saint-Venant: the same resultant
//! as a cap, a tube length away from the ends).
//!
//! Windings ([`helix`]): a thread at radius r_f (inside the wall: embedded in the
//! hexahedra), pitch s per turn, right- or left-handed; a ring (pitch 0) is a hoop.

use nalgebra::Vector3;

use super::material::Yeoh;
use super::solve::Model;
use super::truss::{embed_fibre, TrussElement, TrussSection};
use super::FemError;

/// The tube's dimensions and mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TubeSpec {
    /// Inner radius, mm.
    pub inner_radius_mm: f64,
    /// Outer radius, mm.
    pub outer_radius_mm: f64,
    /// Length, mm.
    pub length_mm: f64,
    /// Elements through the wall.
    pub radial: usize,
    /// Elements around the circle.
    pub around: usize,
    /// Elements along the axis.
    pub axial: usize,
}

/// The tube's model and the node sets its results are read from.
#[derive(Debug, Clone)]
pub struct TubeMesh {
    /// The model: silicone, supports, pressure on the inner wall, no fibres yet.
    pub model: Model,
    /// The spec it was built from.
    pub spec: TubeSpec,
    /// Node index strides: around (nodes per radial line) and axial (nodes per ring).
    pub stride: (usize, usize),
}

impl TubeMesh {
    /// Node index of radial layer `i` (0 inner), angle index `j` (mod around), ring `k`.
    pub fn node(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.stride.0 * (j % self.spec.around) + self.stride.1 * k
    }
}

/// Builds the tube ([`TubeSpec`]) of `material`.
pub fn tube_mesh(spec: TubeSpec, material: Yeoh) -> Result<TubeMesh, FemError> {
    let TubeSpec {
        inner_radius_mm: ri,
        outer_radius_mm: ro,
        length_mm: l,
        radial: nr,
        around: nt,
        axial: nz,
    } = spec;
    if !(ri > 0.0 && ro > ri && l > 0.0 && nr >= 1 && nt >= 8 && nt % 4 == 0 && nz >= 1) {
        return Err(FemError::Model {
            why: format!("tube {spec:?}: needs 0 < inner < outer radius, length > 0, around a multiple of 4 (>= 8)"),
        });
    }
    let stride = (nr + 1, (nr + 1) * nt);
    let mut nodes = Vec::with_capacity(stride.1 * (nz + 1));
    for k in 0..=nz {
        for j in 0..nt {
            let t = std::f64::consts::TAU * j as f64 / nt as f64;
            for i in 0..=nr {
                let r = ri + (ro - ri) * i as f64 / nr as f64;
                nodes.push(Vector3::new(
                    r * t.cos(),
                    r * t.sin(),
                    l * k as f64 / nz as f64,
                ));
            }
        }
    }
    let id = |i: usize, j: usize, k: usize| i + stride.0 * (j % nt) + stride.1 * k;
    let mut elements = Vec::with_capacity(nr * nt * nz);
    let mut pressure_faces = Vec::with_capacity(nt * nz);
    for k in 0..nz {
        for j in 0..nt {
            for i in 0..nr {
                elements.push([
                    id(i, j, k),
                    id(i + 1, j, k),
                    id(i + 1, j + 1, k),
                    id(i, j + 1, k),
                    id(i, j, k + 1),
                    id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1),
                    id(i, j + 1, k + 1),
                ]);
            }
            // Normal +e_r (out of the cavity): e_θ x e_z.
            pressure_faces.push([
                id(0, j, k),
                id(0, j + 1, k),
                id(0, j + 1, k + 1),
                id(0, j, k + 1),
            ]);
        }
    }
    let mut fixed = vec![false; 3 * nodes.len()];
    for j in 0..nt {
        for i in 0..=nr {
            let a = id(i, j, 0);
            fixed[3 * a + 2] = true;
            if j == 0 || j == nt / 2 {
                fixed[3 * a + 1] = true;
            }
            if j == nt / 4 || j == 3 * nt / 4 {
                fixed[3 * a] = true;
            }
        }
    }
    let loads = vec![0.0; 3 * nodes.len()];
    Ok(TubeMesh {
        model: Model {
            nodes,
            elements,
            material,
            fixed,
            loads,
            pressure_faces,
            volume_weights: Vector3::new(0.5, 0.5, 0.0),
            element_material: Vec::new(),
            extra_materials: Vec::new(),
            membranes: Vec::new(),
            tri_membranes: Vec::new(),
            trusses: Vec::new(),
            plates: Vec::new(),
            incompatible_modes: false,
            contact: None,
            tets: Default::default(),
        },
        spec,
        stride,
    })
}

/// Sense of a helical winding about the tube axis (+z).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Handedness {
    /// θ grows with z.
    Right,
    /// θ falls with z.
    Left,
}

/// The polyline of a helix of radius `radius_mm` and `pitch_mm` per turn over the length
/// `length_mm`, starting at angle `start_rad`, `per_turn` points a turn.
pub fn helix(
    radius_mm: f64,
    pitch_mm: f64,
    handedness: Handedness,
    length_mm: f64,
    start_rad: f64,
    per_turn: usize,
) -> Vec<Vector3<f64>> {
    let turns = length_mm / pitch_mm;
    let n = (turns * per_turn as f64).ceil().max(1.0) as usize;
    let sign = if handedness == Handedness::Right {
        1.0
    } else {
        -1.0
    };
    (0..=n)
        .map(|k| {
            let s = k as f64 / n as f64;
            let t = start_rad + sign * std::f64::consts::TAU * turns * s;
            Vector3::new(radius_mm * t.cos(), radius_mm * t.sin(), length_mm * s)
        })
        .collect()
}

/// Embeds the polyline `path` in the tube's mesh as fibre segments of `section`.
pub fn embed_winding(
    mesh: &TubeMesh,
    path: &[Vector3<f64>],
    section: TrussSection,
) -> Result<Vec<TrussElement>, FemError> {
    let h = (mesh.spec.length_mm / mesh.spec.axial as f64)
        .min(std::f64::consts::TAU * mesh.spec.inner_radius_mm / mesh.spec.around as f64);
    embed_fibre(&mesh.model.nodes, &mesh.model.elements, path, 0.5 * h, section).map_err(|i| {
        FemError::Parameter {
            name: "fibre".into(),
            why: format!("point {i} of the fibre path ({:.3?}) is outside the body: put the fibre radius between the wall's inner and outer radius", path[i]),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::solve::{LoadState, NewtonSettings, Solver};
    use crate::fem::truss::{truss_strain_stress, EmbeddedPoint};

    /// Ecoflex-like silicone: μ0 = 2 C1 = 0.05 MPa, K = 1000 μ0.
    fn silicone() -> Yeoh {
        Yeoh {
            c1: 0.025,
            c2: 0.0005,
            c3: 0.0,
            bulk_modulus: 50.0,
        }
    }

    fn w_incompressible(m: &Yeoh, i1: f64) -> f64 {
        let x = i1 - 3.0;
        m.c1 * x + m.c2 * x * x + m.c3 * x * x * x
    }

    /// The incompressible thick tube under internal pressure p with closed ends, in the
    /// deformation r² = a² + (R² − Rᵢ²)/λ, z = λ Z (a: deformed inner radius): its
    /// energy per reference length minus the pressure's work, p π a² λ (the volume of
    /// the closed cavity per reference length).
    fn tube_potential(m: &Yeoh, ri: f64, ro: f64, p: f64, a: f64, lambda: f64) -> f64 {
        let n = 400;
        let mut e = 0.0;
        for k in 0..n {
            // Gauss-Legendre 2 points per interval.
            for g in [-0.577_350_269_189_625_8, 0.577_350_269_189_625_8] {
                let big_r = ri + (ro - ri) * (k as f64 + 0.5 + 0.5 * g) / n as f64;
                let r = (a * a + (big_r * big_r - ri * ri) / lambda).sqrt();
                let lt = r / big_r;
                let lr = 1.0 / (lt * lambda);
                let i1 = lr * lr + lt * lt + lambda * lambda;
                e += 0.5 * (ro - ri) / n as f64
                    * w_incompressible(m, i1)
                    * std::f64::consts::TAU
                    * big_r;
            }
        }
        e - p * std::f64::consts::PI * a * a * lambda
    }

    fn golden(mut lo: f64, mut hi: f64, f: impl Fn(f64) -> f64) -> f64 {
        let g = 0.5 * (5f64.sqrt() - 1.0);
        for _ in 0..100 {
            let (x1, x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
            if f(x1) < f(x2) {
                hi = x2;
            } else {
                lo = x1;
            }
        }
        0.5 * (lo + hi)
    }

    /// Axial stretch, deformed inner and outer radius of the analytic tube; with
    /// `outer_held` the outer radius stays Ro (inextensible hoop fibres on it).
    fn analytic(m: &Yeoh, ri: f64, ro: f64, p: f64, outer_held: bool) -> (f64, f64, f64) {
        let inner_for = |lambda: f64| (ro * ro - (ro * ro - ri * ri) / lambda).sqrt();
        let lambda = if outer_held {
            golden(1.0, 3.0, |l| tube_potential(m, ri, ro, p, inner_for(l), l))
        } else {
            golden(0.5, 3.0, |l| {
                let a = golden(ri, 3.0 * ro, |a| tube_potential(m, ri, ro, p, a, l));
                tube_potential(m, ri, ro, p, a, l)
            })
        };
        let a = if outer_held {
            inner_for(lambda)
        } else {
            golden(ri, 3.0 * ro, |a| tube_potential(m, ri, ro, p, a, lambda))
        };
        (lambda, a, (a * a + (ro * ro - ri * ri) / lambda).sqrt())
    }

    struct Measured {
        stretch: f64,
        inner: f64,
        outer: f64,
        twist_deg: f64,
    }

    /// Stretch between rings at a quarter and three quarters of the length, radii at the
    /// middle, twist of the three-quarter ring relative to the quarter ring.
    fn measure(mesh: &TubeMesh, solver: &Solver) -> Measured {
        let s = mesh.spec;
        let (k1, k2, km) = (s.axial / 4, 3 * s.axial / 4, s.axial / 2);
        let z = |a: usize| solver.position(a).z;
        let mean = |f: &dyn Fn(usize) -> f64| (0..s.around).map(f).sum::<f64>() / s.around as f64;
        let dz = mean(&|j| z(mesh.node(s.radial, j, k2)) - z(mesh.node(s.radial, j, k1)));
        let dz0 = s.length_mm * (k2 - k1) as f64 / s.axial as f64;
        let radius = |i: usize| mean(&|j| solver.position(mesh.node(i, j, km)).xy().norm());
        let angle = |a: usize| {
            let p = solver.position(a);
            p.y.atan2(p.x)
        };
        let twist = mean(&|j| {
            let d = angle(mesh.node(s.radial, j, k2)) - angle(mesh.node(s.radial, j, k1));
            (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
        });
        Measured {
            stretch: dz / dz0,
            inner: radius(0),
            outer: radius(s.radial),
            twist_deg: twist.to_degrees(),
        }
    }

    fn solve(model: &Model, p_mpa: f64) -> Solver<'_> {
        let mut solver = Solver::new(model).unwrap();
        solver
            .advance(
                LoadState {
                    dead: 0.0,
                    pressure_mpa: p_mpa,
                },
                &NewtonSettings::default(),
            )
            .unwrap();
        solver
    }

    const SPEC: TubeSpec = TubeSpec {
        inner_radius_mm: 4.0,
        outer_radius_mm: 6.0,
        length_mm: 48.0,
        radial: 3,
        around: 24,
        axial: 32,
    };

    #[test]
    fn the_plain_tube_inflates_as_the_analytic_thick_tube() {
        let mesh = tube_mesh(SPEC, silicone()).unwrap();
        let p = 0.01; // 10 kPa
        let solver = solve(&mesh.model, p);
        let got = measure(&mesh, &solver);
        let (lambda, a, b) = analytic(&silicone(), 4.0, 6.0, p, false);
        eprintln!(
            "plain tube at 10 kPa: stretch {:.4} (analytic {lambda:.4}), inner {:.4} ({a:.4}), outer {:.4} ({b:.4}) mm",
            got.stretch, got.inner, got.outer
        );
        assert!(
            (got.stretch - lambda).abs() < 0.02 * (lambda - 1.0),
            "stretch"
        );
        assert!((got.inner / a - 1.0).abs() < 0.005, "inner radius");
        assert!((got.outer / b - 1.0).abs() < 0.005, "outer radius");
    }

    fn kevlar() -> TrussSection {
        // A 0.25 mm Kevlar thread: A = 0.049 mm², E = 70 GPa.
        TrussSection {
            area_mm2: 0.049,
            youngs_modulus_mpa: 7.0e4,
            tension_only: true,
        }
    }

    #[test]
    fn hoop_fibres_hold_the_radius_and_the_tube_extends_as_the_constrained_analytic_tube() {
        let mut mesh = tube_mesh(SPEC, silicone()).unwrap();
        // A hoop ring through the outer nodes of every node ring.
        for k in 0..=SPEC.axial {
            let ring: Vec<usize> = (0..=SPEC.around)
                .map(|j| mesh.node(SPEC.radial, j, k))
                .collect();
            for w in ring.windows(2) {
                mesh.model.trusses.push(TrussElement {
                    ends: [EmbeddedPoint::at_node(w[0]), EmbeddedPoint::at_node(w[1])],
                    section: kevlar(),
                });
            }
        }
        let p = 0.01;
        let solver = solve(&mesh.model, p);
        let got = measure(&mesh, &solver);
        let (lambda, a, _) = analytic(&silicone(), 4.0, 6.0, p, true);
        let (free, _, free_outer) = analytic(&silicone(), 4.0, 6.0, p, false);
        eprintln!(
            "hoop-reinforced tube at 10 kPa: stretch {:.4} (analytic {lambda:.4}; unreinforced {free:.4}), inner {:.4} ({a:.4}), outer {:.4} mm (6; unreinforced {free_outer:.4})",
            got.stretch, got.inner, got.outer
        );
        // No radial growth: the outer radius within 0.2% of its rest value (it grows by
        // several percent without fibres), the stretch within 3% of the analytic
        // extension λ − 1 (the rings hold the radius at the nodes only; between them the
        // wall bulges by a little).
        assert!(
            free_outer / 6.0 - 1.0 > 0.02,
            "unreinforced outer {free_outer}"
        );
        assert_holds_the_constrained_tube(&got, lambda, a, 0.03);
    }

    /// The outer radius held within 0.2% of 6 mm, the stretch within `share` of the
    /// analytic extension λ − 1, the inner radius within 0.5% of the analytic `a`, no twist.
    fn assert_holds_the_constrained_tube(got: &Measured, lambda: f64, a: f64, share: f64) {
        assert!((got.outer / 6.0 - 1.0).abs() < 0.002, "outer {}", got.outer);
        assert!(
            (got.stretch - lambda).abs() < share * (lambda - 1.0),
            "stretch {} vs {lambda}",
            got.stretch
        );
        assert!(
            (got.inner / a - 1.0).abs() < 0.005,
            "inner {} vs {a}",
            got.inner
        );
        assert!(got.twist_deg.abs() < 1e-6, "twist {}", got.twist_deg);
    }

    /// The same hoop threads smeared ([`crate::fem::membrane::Fibres`]): a membrane on
    /// each facet of the outer surface carrying stress around the tube only, thickness
    /// A / spacing (one thread per 1.5 mm ring). The surface is held everywhere, not at
    /// the rings only, so the stretch is the analytic one within 1% of λ − 1.
    #[test]
    fn smeared_hoop_threads_hold_the_radius_as_the_constrained_analytic_tube() {
        use crate::fem::membrane::{Fibres, MembraneElement, MembraneSection};
        let mut mesh = tube_mesh(SPEC, silicone()).unwrap();
        let spacing = SPEC.length_mm / SPEC.axial as f64;
        let k = kevlar();
        for j in 0..SPEC.around {
            for ring in 0..SPEC.axial {
                let q = [
                    mesh.node(SPEC.radial, j, ring),
                    mesh.node(SPEC.radial, j + 1, ring),
                    mesh.node(SPEC.radial, j + 1, ring + 1),
                    mesh.node(SPEC.radial, j, ring + 1),
                ];
                let hoop = (mesh.model.nodes[q[1]] - mesh.model.nodes[q[0]]).normalize();
                mesh.model.membranes.push(MembraneElement {
                    nodes: q,
                    section: MembraneSection {
                        fibres: Some(Fibres {
                            direction: hoop.into(),
                            tension_only: k.tension_only,
                        }),
                        ..MembraneSection::isotropic(
                            k.area_mm2 / spacing,
                            k.youngs_modulus_mpa,
                            0.0,
                        )
                    },
                });
            }
        }
        let p = 0.01;
        let solver = solve(&mesh.model, p);
        let got = measure(&mesh, &solver);
        let (lambda, a, _) = analytic(&silicone(), 4.0, 6.0, p, true);
        eprintln!(
            "smeared hoop threads at 10 kPa: stretch {:.4} (analytic {lambda:.4}), inner {:.4} ({a:.4}), outer {:.4} mm (6)",
            got.stretch, got.inner, got.outer
        );
        assert_holds_the_constrained_tube(&got, lambda, a, 0.01);
    }

    fn wound(windings: &[(Handedness, f64)]) -> TubeMesh {
        let mut mesh = tube_mesh(SPEC, silicone()).unwrap();
        for (hand, start) in windings {
            let path = helix(5.0, 12.0, *hand, SPEC.length_mm, *start, 48);
            let t = embed_winding(&mesh, &path, kevlar()).unwrap();
            mesh.model.trusses.extend(t);
        }
        mesh
    }

    #[test]
    fn a_one_way_winding_twists_the_tube_and_both_ways_do_not() {
        // 4 kPa: two threads 12 mm a turn leave the wall between them free to bulge; at
        // 10 kPa Newton stalls at 86% of the load (the hoop-wound tube converges there).
        let p = 0.004;
        let right = wound(&[
            (Handedness::Right, 0.0),
            (Handedness::Right, std::f64::consts::PI),
        ]);
        let left = wound(&[
            (Handedness::Left, 0.0),
            (Handedness::Left, std::f64::consts::PI),
        ]);
        let both = wound(&[(Handedness::Right, 0.0), (Handedness::Left, 0.0)]);
        let (sr, sl, sb) = (
            solve(&right.model, p),
            solve(&left.model, p),
            solve(&both.model, p),
        );
        let (mr, ml, mb) = (
            measure(&right, &sr),
            measure(&left, &sl),
            measure(&both, &sb),
        );
        eprintln!(
            "one-way right: twist {:.3} deg over half the tube, stretch {:.4}; left: twist {:.3}; both ways: twist {:.2e}, stretch {:.4}",
            mr.twist_deg, mr.stretch, ml.twist_deg, mb.twist_deg, mb.stretch
        );
        // A right-handed thread of fixed length unwinds as the tube grows: the far ring
        // turns against the winding. Mirror images twist by opposite angles.
        assert!(mr.twist_deg < -1.0, "{}", mr.twist_deg);
        assert!(
            (mr.twist_deg + ml.twist_deg).abs() < 1e-6 * mr.twist_deg.abs(),
            "{} vs {}",
            mr.twist_deg,
            ml.twist_deg
        );
        assert!(
            mb.twist_deg.abs() < 0.02 * mr.twist_deg.abs(),
            "{}",
            mb.twist_deg
        );
        let worst = right
            .model
            .trusses
            .iter()
            .map(|t| truss_strain_stress(t, &right.model.nodes, sr.displacement()).0)
            .fold(0.0f64, f64::max);
        // The thread barely stretches while the wall it lies in grows: its strain is a
        // small part of the plain tube's hoop strain at the thread's radius.
        let plain = tube_mesh(SPEC, silicone()).unwrap();
        let sp = solve(&plain.model, p);
        let hoop = measure(&plain, &sp).inner / SPEC.inner_radius_mm - 1.0;
        eprintln!("one-way thread: worst strain {worst:.2e}; plain tube hoop strain at the inner wall {hoop:.3}");
        assert!(worst < 0.02 * hoop, "thread strain {worst} vs hoop {hoop}");
    }
}
