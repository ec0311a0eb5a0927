//! Assembly: each element's force, tangent and condensed volume terms (Q1/P0, or with
//! incompatible modes condensed per element), the tetrahedra's Taylor-Hood terms (their
//! corner pressures unknowns of the system), then sheets, fibres, plates, follower
//! pressure, contact and dead loads scattered into the condensed residual and the lower
//! triangle of the tangent in the fixed [`super::pattern::Pattern`].

use std::ops::Range;

use nalgebra::Vector3;
use rayon::prelude::*;

use super::model::{volume_points, LoadState, Model};
use super::pattern::SKIP;
use super::solver::Solver;
use crate::fem::contact::contact_terms;
use crate::fem::hex::{
    element_kinematics, enhanced_kinematics, ElementMatrix, ElementVector, HexGeometry, Modes,
    ENHANCED_DOFS, MODES,
};
use crate::fem::material::Yeoh;
use crate::fem::membrane::{membrane_response, MembraneMatrix, MembraneVector};
use crate::fem::membrane_tri6::{tri6_membrane_response, Tri6MembraneMatrix, Tri6MembraneVector};
use crate::fem::plate::PLATE_NODES;
use crate::fem::pressure::{face_volume, FaceMatrix, FaceVector};
use crate::fem::pressure_tri6::{self, Tri6Matrix, Tri6Vector};
use crate::fem::tet10::taylor_hood::{self, ThMatrix, ThVector};
use crate::fem::truss::{truss_response, TrussMatrix, TrussVector, TRUSS_DOFS};

/// An element's force, tangent and condensed terms at the current state.
pub(super) type ElementPart = (ElementVector, ElementMatrix, Condensed);

/// A tetrahedron's Taylor-Hood gradient and Hessian (30 displacements, then its 4
/// corner pressures) at the current state.
pub(super) type TetPart = (ThVector, ThMatrix);

/// Tetrahedra evaluated at once before their terms are scattered: bounds the scratch
/// memory of their 9 kB tangents whatever the mesh size (two chunks are held: one
/// scattered while the next is evaluated).
pub(super) const TET_CHUNK: usize = 2048;

/// Per-element terms of the condensation, kept to update θ_e and p_e after a step.
#[derive(Clone)]
pub(super) struct Condensed {
    /// ∂v_e/∂u.
    pub(super) g: ElementVector,
    /// Volume residual v_e − V_e θ_e.
    pub(super) r_volume: f64,
    /// Constitutive residual V_e (U'(θ_e) − p_e).
    pub(super) r_pressure: f64,
    /// U''(θ_e).
    pub(super) ddu: f64,
    /// The condensation of the incompatible modes, for the element with them.
    pub(super) modes: Option<Box<ModesCondensed>>,
}

/// Number of mode unknowns per element.
pub(super) const MODE_DOFS: usize = 3 * MODES;

/// An element's incompatible modes condensed out of its system
/// [K_uu K_ua; K_au K_aa] [Δu; Δa] = −[r_u; r_a] (θ_e and p_e already condensed):
/// the nodes see K_uu − K_ua K_aa⁻¹ K_au and r_u − K_ua K_aa⁻¹ r_a, and after the
/// solve Δa = −K_aa⁻¹ (r_a + K_au Δu).
#[derive(Clone)]
pub(super) struct ModesCondensed {
    pub(super) kaa_inv: nalgebra::SMatrix<f64, MODE_DOFS, MODE_DOFS>,
    pub(super) kau: nalgebra::SMatrix<f64, MODE_DOFS, 24>,
    /// r_a: the modes' force with the volume terms of the θ, p condensation.
    pub(super) ra: nalgebra::SVector<f64, MODE_DOFS>,
    /// The volume terms of each Gauss point: ∂v_g/∂(u, a), and (R_θ, R_p, U''(θ_g)) as
    /// in [`Condensed`].
    pub(super) g_points: [nalgebra::SVector<f64, ENHANCED_DOFS>; 8],
    pub(super) points: [(f64, f64, f64); 8],
    /// The nodes' condensed residual beyond their force: Σ_g G_g,u w_g − K_ua K_aa⁻¹ r_a.
    pub(super) shift: ElementVector,
    /// |f_a|²: the modes' equilibrium residual (in the convergence test).
    pub(super) residual_sq: f64,
    /// Largest |v_g / V_g − θ_g|.
    pub(super) volume_error: f64,
}

/// The linearized system at a state: condensed residual (free dofs, then the corner
/// pressures' volume constraints), norms for the convergence test, the lower triangle of
/// the condensed tangent, and the element terms.
pub(super) struct Assembled {
    pub(super) residual: Vec<f64>,
    pub(super) equilibrium_norm: f64,
    pub(super) external_norm: f64,
    /// ε ‖ |K| |u| ‖: the round-off floor of the residual ([`Solver::roundoff_norm`]).
    pub(super) roundoff_norm: f64,
    pub(super) volume_error: f64,
    /// Values of the lower triangle in the fixed pattern of [`Pattern`].
    pub(super) values: Vec<f64>,
    pub(super) condensed: Vec<Condensed>,
    /// Node pairs a contact term couples that the pattern lacks (a slave node meeting a
    /// master face for the first time): the pattern is then extended and the state
    /// assembled again.
    pub(super) missing: Vec<(usize, usize)>,
}

pub(super) fn gather<const N: usize>(u: &[f64], nodes: &[usize; N]) -> [Vector3<f64>; N] {
    std::array::from_fn(|a| Vector3::new(u[3 * nodes[a]], u[3 * nodes[a] + 1], u[3 * nodes[a] + 2]))
}

/// The larger of `a` and `b`, NaN when either is (`f64::max` drops a NaN, which would
/// hide it from the convergence test).
pub(super) fn max_or_nan(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// Euclidean norm; infinite when the squares overflow (a load near 1e154 or more), which
/// the convergence test takes as a load that is not finite.
pub(super) fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// One element's force, tangent and condensed terms at displacement `u`, dilatation
/// `th` and pressure `p`; zeros for an element whose nodes are all fixed; `None` when the
/// element is inverted.
#[allow(clippy::too_many_arguments)]
fn element_part(
    model: &Model,
    e: usize,
    el: &[usize; 8],
    g: &HexGeometry,
    th: &[f64],
    p: &[f64],
    modes: Option<&Modes>,
    active: bool,
    u: &[f64],
) -> Option<ElementPart> {
    let material = model.material_of(e);
    if let (Some(m), true) = (modes, active) {
        return enhanced_part(material, el, g, th, p, m, u);
    }
    let (th, p) = (th[0], p[0]);
    if !active {
        // Every node fixed: u = 0, θ = 1, p = 0 stay the exact state; nothing
        // to assemble (the clamped chamber of the actuator).
        return Some((
            ElementVector::zeros(),
            ElementMatrix::zeros(),
            Condensed {
                g: ElementVector::zeros(),
                r_volume: 0.0,
                r_pressure: 0.0,
                ddu: material.ddu(th),
                modes: None,
            },
        ));
    }
    let e = element_kinematics(g, material, &gather(u, el))?;
    if th.is_nan() || th <= 0.0 {
        return None;
    }
    let vol = g.volume;
    let ddu = material.ddu(th);
    let c = Condensed {
        r_volume: e.v - vol * th,
        r_pressure: vol * (material.du(th) - p),
        ddu,
        g: e.g,
        modes: None,
    };
    // Equilibrium with the element's own pressure, and the condensed system.
    let force = e.force_iso + e.g * p;
    let k = e.k_iso + e.h * p + e.g * e.g.transpose() * (ddu / vol);
    Some((force, k, c))
}

/// [`element_part`] of the element with incompatible modes at amplitudes `modes`: the
/// volume constrained at each Gauss point (dilatations `th` and pressures `p`, 8 each,
/// condensed as the element's one pair is for Q1/P0: with the modes' normal strains and
/// one pressure per element, a wall one element thick bends with a free dilatation
/// linear through it, 1.6 x too soft in the thin cantilever test), then the modes
/// condensed ([`ModesCondensed`]). `None` when the element is inverted (or its modes'
/// block singular).
fn enhanced_part(
    material: &Yeoh,
    el: &[usize; 8],
    g: &HexGeometry,
    th: &[f64],
    p: &[f64],
    modes: &Modes,
    u: &[f64],
) -> Option<ElementPart> {
    if th.iter().any(|t| t.is_nan() || *t <= 0.0) {
        return None;
    }
    let e = enhanced_kinematics(
        g,
        material,
        &gather(u, el),
        modes,
        &std::array::from_fn(|q| p[q]),
    )?;
    let mut force = e.force_iso;
    let mut k = e.k_iso + e.h;
    let mut shift = nalgebra::SVector::<f64, ENHANCED_DOFS>::zeros();
    let mut points = [(0.0, 0.0, 0.0); 8];
    let mut volume_error: f64 = 0.0;
    for q in 0..8 {
        let vq = g.weights[q];
        let ddu = material.ddu(th[q]);
        let r_volume = e.v_points[q] - vq * th[q];
        let r_pressure = vq * (material.du(th[q]) - p[q]);
        let gq = &e.g_points[q];
        force += gq * p[q];
        k += gq * gq.transpose() * (ddu / vq);
        shift += gq * ((ddu * r_volume + r_pressure) / vq);
        points[q] = (r_volume, r_pressure, ddu);
        volume_error = max_or_nan(volume_error, (r_volume / vq).abs());
    }
    let kaa_inv = k
        .fixed_view::<MODE_DOFS, MODE_DOFS>(24, 24)
        .into_owned()
        .try_inverse()?;
    let kau = k.fixed_view::<MODE_DOFS, 24>(24, 0).into_owned();
    let fa = force.fixed_rows::<MODE_DOFS>(24).into_owned();
    let ra = fa + shift.fixed_rows::<MODE_DOFS>(24);
    let kua_kaa_inv = kau.transpose() * kaa_inv;
    let k_nodes = k.fixed_view::<24, 24>(0, 0) - kua_kaa_inv * kau;
    let c = Condensed {
        g: ElementVector::zeros(),
        r_volume: 0.0,
        r_pressure: 0.0,
        ddu: 0.0,
        modes: Some(Box::new(ModesCondensed {
            kaa_inv,
            kau,
            ra,
            g_points: e.g_points,
            points,
            shift: shift.fixed_rows::<24>(0) - kua_kaa_inv * ra,
            residual_sq: fa.norm_squared(),
            volume_error,
        })),
    };
    Some((force.fixed_rows::<24>(0).into_owned(), k_nodes, c))
}

impl<'m> Solver<'m> {
    /// ε ‖ |K| |u| ‖ over the free dofs (|K| the entrywise absolute tangent): the size
    /// of the residual that the rounding of the displacements alone (|δu| ≤ ε |u|) makes.
    /// A residual cannot be driven below it: with a sheet 10³-10⁴ times stiffer than the
    /// silicone (a 0.1 mm, 3 GPa layer) it is ~1e-10 N under gravity alone, where the
    /// external force is 3e-4 N and the absolute tolerance 1e-10 N.
    ///
    /// The corner pressures `corners` enter |u| beside the displacements; the norm is
    /// that of the equilibrium rows.
    pub(super) fn roundoff_norm(&self, values: &[f64], u: &[f64], corners: &[f64]) -> f64 {
        let n = self.n_eq + self.n_p;
        let mut u_free = vec![0.0; n];
        for (d, e) in self.eq.iter().enumerate() {
            if let Some(i) = e {
                u_free[*i] = u[d].abs();
            }
        }
        for (k, p) in corners.iter().enumerate() {
            u_free[self.n_eq + k] = p.abs();
        }
        let col_ptr = self.pattern.symbolic.col_ptr();
        let row_idx = self.pattern.symbolic.row_idx();
        let mut y = vec![0.0; n];
        for c in 0..n {
            for (r, v) in row_idx[col_ptr[c]..col_ptr[c + 1]]
                .iter()
                .zip(&values[col_ptr[c]..col_ptr[c + 1]])
            {
                y[*r] += v.abs() * u_free[c];
                if *r != c {
                    y[c] += v.abs() * u_free[*r];
                }
            }
        }
        f64::EPSILON * norm(&y[..self.n_eq])
    }

    /// Adds the tetrahedra's forces and volume constraints to `r` (the constraint of
    /// corner pressure k at n_eq + k) and their Hessians to `values`, a chunk at a time,
    /// at corner pressures `corners`; the largest constraint residual over its corner
    /// volume (a volume strain), or `None` when one is inverted. Every tetrahedron is
    /// evaluated, a clamped one too: its corners' pressures are unknowns. A chunk is
    /// scattered (serially: its entries collide) while the next one is evaluated on the
    /// other threads, so the scatter does not leave them idle.
    fn scatter_tets(
        &self,
        u: &[f64],
        corners: &[f64],
        r: &mut [f64],
        values: &mut [f64],
    ) -> Option<f64> {
        let model = self.model;
        let tets = &model.tets.elements;
        let mut buffers = self.tet_parts.lock().ok()?;
        let [ready, next] = &mut *buffers;
        let mut constraint = vec![0.0; self.n_p];
        let evaluate = |range: Range<usize>, out: &mut Vec<Option<TetPart>>| {
            out.clear();
            out.par_extend(range.into_par_iter().map(|t| {
                let p = self.tet_pressure[t].map(|k| corners[k]);
                let el = gather(u, &tets[t]);
                let th = taylor_hood::element_response(
                    &self.tet_geom[t],
                    model.material_of_tet(t),
                    &el,
                    &p,
                )?;
                Some((th.gradient, th.hessian))
            }));
        };
        let scatter = |range: Range<usize>,
                       parts: &[Option<TetPart>],
                       r: &mut [f64],
                       values: &mut [f64],
                       constraint: &mut [f64]|
         -> Option<()> {
            for (t, part) in range.zip(parts) {
                let (f, k) = part.as_ref()?;
                let el = &tets[t];
                for a in 0..30 {
                    if let Some(i) = self.eq[3 * el[a / 3] + a % 3] {
                        r[i] += f[a];
                    }
                }
                for (i, kp) in self.tet_pressure[t].iter().enumerate() {
                    constraint[*kp] += f[30 + i];
                }
                for (s, v) in self.pattern.tet_slots[t].iter().zip(k.as_slice()) {
                    if *s != SKIP {
                        values[*s as usize] += v;
                    }
                }
            }
            Some(())
        };
        let chunks: Vec<Range<usize>> = (0..tets.len())
            .step_by(TET_CHUNK)
            .map(|start| start..(start + TET_CHUNK).min(tets.len()))
            .collect();
        if let Some(first) = chunks.first() {
            evaluate(first.clone(), ready);
        }
        for (c, range) in chunks.iter().enumerate() {
            let (scattered, ()) = rayon::join(
                || scatter(range.clone(), ready, r, values, &mut constraint),
                || {
                    if let Some(upcoming) = chunks.get(c + 1) {
                        evaluate(upcoming.clone(), next);
                    }
                },
            );
            scattered?;
            std::mem::swap(ready, next);
        }
        let mut volume_error: f64 = 0.0;
        for (k, (c, v)) in constraint.iter().zip(&self.corner_volume).enumerate() {
            r[self.n_eq + k] = *c;
            volume_error = max_or_nan(volume_error, (c / v).abs());
        }
        Some(volume_error)
    }

    pub(super) fn assemble(
        &self,
        u: &[f64],
        theta: &[f64],
        pressure: &[f64],
        modes: &[Modes],
        load: LoadState,
    ) -> Option<Assembled> {
        let model = self.model;
        let points = volume_points(model);
        let mut parts = self.parts.lock().ok()?;
        parts.resize_with(model.elements.len(), || None);
        parts
            .par_iter_mut()
            .zip(&model.elements)
            .zip(&self.geom)
            .zip(
                theta[..points * model.elements.len()]
                    .par_chunks(points)
                    .zip(pressure[..points * model.elements.len()].par_chunks(points)),
            )
            .zip(&self.pattern.active)
            .enumerate()
            .for_each(|(e, ((((slot, el), g), (th, p)), &active))| {
                *slot = element_part(model, e, el, g, th, p, modes.get(e), active, u);
            });
        if parts.iter().any(Option::is_none) {
            return None;
        }
        let faces: Vec<(f64, FaceVector, FaceMatrix)> = model
            .pressure_faces
            .par_iter()
            .map(|f| {
                let du = gather(u, f);
                let x: [Vector3<f64>; 4] = std::array::from_fn(|k| model.nodes[f[k]] + du[k]);
                face_volume(&x, &model.volume_weights)
            })
            .collect();
        let tri6_faces: Vec<(f64, Tri6Vector, Tri6Matrix)> = model
            .tets
            .pressure_faces
            .par_iter()
            .map(|f| {
                let du = gather(u, f);
                let x: [Vector3<f64>; 6] = std::array::from_fn(|k| model.nodes[f[k]] + du[k]);
                pressure_tri6::face_volume(&x, &model.volume_weights)
            })
            .collect();
        let membranes: Vec<(f64, MembraneVector, MembraneMatrix)> = model
            .membranes
            .par_iter()
            .zip(&self.membrane_geom)
            .map(|(m, g)| membrane_response(g, &m.section, &gather(u, &m.nodes)))
            .collect();
        let tri_membranes: Vec<(f64, Tri6MembraneVector, Tri6MembraneMatrix)> = model
            .tri_membranes
            .par_iter()
            .zip(&self.tri_membrane_geom)
            .map(|(m, g)| tri6_membrane_response(g, &m.section, &gather(u, &m.nodes)))
            .collect();
        let trusses: Vec<(f64, TrussVector, TrussMatrix)> = model
            .trusses
            .par_iter()
            .map(|t| truss_response(t, &model.nodes, u))
            .collect();
        let eq = &self.eq;
        // Equilibrium residual R_u, then the corner pressures' volume constraints.
        let mut r = vec![0.0; self.n_eq + self.n_p];
        let mut shift = vec![0.0; self.n_eq]; // G (U'' R_p + R_θ) / V
        let mut ext = vec![0.0; self.n_eq];
        let mut values = vec![0.0; self.pattern.symbolic.row_idx().len()];
        let mut volume_error: f64 = 0.0;
        let mut modes_residual_sq = 0.0;
        for (((el, (f, k, c)), g), slots) in model
            .elements
            .iter()
            .zip(parts.iter().flatten())
            .zip(&self.geom)
            .zip(&self.pattern.element_slots)
        {
            let w = (c.ddu * c.r_volume + c.r_pressure) / g.volume;
            for a in 0..24 {
                if let Some(i) = eq[3 * el[a / 3] + a % 3] {
                    r[i] += f[a];
                    shift[i] += c.g[a] * w;
                    if let Some(m) = &c.modes {
                        shift[i] += m.shift[a];
                    }
                }
            }
            if let Some(m) = &c.modes {
                modes_residual_sq += m.residual_sq;
                volume_error = max_or_nan(volume_error, m.volume_error);
            }
            for (s, v) in slots.iter().zip(k.as_slice()) {
                if *s != SKIP {
                    values[*s as usize] += v;
                }
            }
            volume_error = max_or_nan(volume_error, (c.r_volume / g.volume).abs());
        }
        let corners = &pressure[points * model.elements.len()..];
        if !model.tets.elements.is_empty() {
            let tet_volume_error = self.scatter_tets(u, corners, &mut r, &mut values)?;
            volume_error = max_or_nan(volume_error, tet_volume_error);
        }
        for ((m, (_, f, k)), slots) in model
            .membranes
            .iter()
            .zip(&membranes)
            .zip(&self.pattern.membrane_slots)
        {
            for a in 0..12 {
                if let Some(i) = eq[3 * m.nodes[a / 3] + a % 3] {
                    r[i] += f[a];
                }
            }
            for (s, v) in slots.iter().zip(k.as_slice()) {
                if *s != SKIP {
                    values[*s as usize] += v;
                }
            }
        }
        for ((m, (_, f, k)), slots) in model
            .tri_membranes
            .iter()
            .zip(&tri_membranes)
            .zip(&self.pattern.tri_membrane_slots)
        {
            for a in 0..18 {
                if let Some(i) = eq[3 * m.nodes[a / 3] + a % 3] {
                    r[i] += f[a];
                }
            }
            for (s, v) in slots.iter().zip(k.as_slice()) {
                if *s != SKIP {
                    values[*s as usize] += v;
                }
            }
        }
        for ((t, (_, f, k)), slots) in model
            .trusses
            .iter()
            .zip(&trusses)
            .zip(&self.pattern.truss_slots)
        {
            let nodes = t.nodes();
            for a in 0..TRUSS_DOFS {
                if let Some(i) = eq[3 * nodes[a / 3] + a % 3] {
                    r[i] += f[a];
                }
            }
            for (s, v) in slots.iter().zip(k.as_slice()) {
                if *s != SKIP {
                    values[*s as usize] += v;
                }
            }
        }
        for (t, slots) in model.plates.iter().zip(&self.pattern.plate_slots) {
            for (a, fa) in t.force(u).iter().enumerate() {
                if let Some(i) = eq[3 * t.nodes[a / 3] + a % 3] {
                    r[i] += fa;
                }
            }
            let (n, m) = (3 * PLATE_NODES, 3 * t.used());
            for b in 0..m {
                for a in 0..m {
                    let s = slots[a + n * b];
                    if s != SKIP {
                        values[s as usize] += t.tangent(a / 3, a % 3, b / 3, b % 3);
                    }
                }
            }
        }
        if load.pressure_mpa != 0.0 {
            // Each face at its cavity's pressure (p times the cavity's factor).
            let mut add = |p: f64, nodes: &[usize], g: &[f64], h: &[f64], slots: &[u32]| {
                for (a, ga) in g.iter().enumerate() {
                    if let Some(i) = eq[3 * nodes[a / 3] + a % 3] {
                        ext[i] += p * ga;
                        r[i] -= p * ga;
                    }
                }
                for (s, v) in slots.iter().zip(h) {
                    if *s != SKIP {
                        values[*s as usize] -= p * v;
                    }
                }
            };
            for ((face, (_, g, h)), slots) in model
                .pressure_faces
                .iter()
                .zip(&faces)
                .zip(&self.pattern.face_slots)
            {
                add(load.pressure_mpa, face, g.as_slice(), h.as_slice(), slots);
            }
            for (k, ((face, (_, g, h)), slots)) in model
                .tets
                .pressure_faces
                .iter()
                .zip(&tri6_faces)
                .zip(&self.pattern.tri6_slots)
                .enumerate()
            {
                let p = load.pressure_mpa * model.tets.pressure_factor(k);
                add(p, face, g.as_slice(), h.as_slice(), &slots[..]);
            }
        }
        let mut missing = Vec::new();
        if let Some(contact) = &model.contact {
            let position =
                |a: usize| model.nodes[a] + Vector3::new(u[3 * a], u[3 * a + 1], u[3 * a + 2]);
            for t in contact_terms(contact, &position) {
                let d: [Option<usize>; 15] =
                    std::array::from_fn(|a| eq[3 * t.nodes[a / 3] + a % 3]);
                for a in 0..15 {
                    let Some(i) = d[a] else { continue };
                    r[i] += t.force[a];
                    for (b, db) in d.iter().enumerate() {
                        match db {
                            Some(j) if i >= *j => {
                                let s = self.pattern.slot(i, *j);
                                if s != SKIP {
                                    values[s as usize] += t.stiffness[(a, b)];
                                } else {
                                    missing.push((t.nodes[a / 3], t.nodes[b / 3]));
                                }
                            }
                            _ => {}
                        }
                    }
                }
            }
        }
        for (d, e) in eq.iter().enumerate() {
            if let Some(i) = e {
                let f = load.dead * model.loads[d];
                r[*i] -= f;
                ext[*i] += f;
            }
        }
        let equilibrium_norm = (norm(&r[..self.n_eq]).powi(2) + modes_residual_sq).sqrt();
        let roundoff_norm = self.roundoff_norm(&values, u, corners);
        for (ri, si) in r.iter_mut().zip(&shift) {
            *ri += si;
        }
        Some(Assembled {
            residual: r,
            equilibrium_norm,
            external_norm: norm(&ext),
            roundoff_norm,
            volume_error,
            values,
            condensed: parts.iter().flatten().map(|(_, _, c)| c.clone()).collect(),
            missing,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::actuator::{build_mesh, ActuatorConfig, MeshConfig};
    use crate::fem::config::SolidElement;
    use crate::fem::hex::element_response;

    /// θ_e = v_e / V_e and p_e = U'(θ_e) of the hexahedra: the state the three-field
    /// iteration converges to.
    fn consistent(solver: &Solver, u: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let model = solver.model;
        model
            .elements
            .iter()
            .zip(&solver.geom)
            .enumerate()
            .map(|(e, (el, g))| {
                let m = model.material_of(e);
                let th = element_kinematics(g, m, &gather(u, el)).unwrap().v / g.volume;
                (th, m.du(th))
            })
            .unzip()
    }

    /// The potential energy Π(u) of the displacement-only form for the hexahedra, with
    /// the tetrahedra's Taylor-Hood energy at corner pressures `corners` (a saddle
    /// point in them).
    fn energy(solver: &Solver, u: &[f64], corners: &[f64], load: LoadState) -> f64 {
        let m = solver.model;
        let mut e: f64 = m
            .elements
            .iter()
            .zip(&solver.geom)
            .enumerate()
            .map(|(e, (el, g))| {
                element_response(g, m.material_of(e), &gather(u, el), None)
                    .unwrap()
                    .0
            })
            .sum();
        e += m.plates.iter().map(|t| t.energy(u)).sum::<f64>();
        for (t, (el, g)) in m.tets.elements.iter().zip(&solver.tet_geom).enumerate() {
            let p = solver.tet_pressure[t].map(|k| corners[k]);
            e += taylor_hood::element_response(g, m.material_of_tet(t), &gather(u, el), &p)
                .unwrap()
                .energy;
        }
        for (j, f) in m.tets.pressure_faces.iter().enumerate() {
            let du = gather(u, f);
            let x: [Vector3<f64>; 6] = std::array::from_fn(|k| m.nodes[f[k]] + du[k]);
            let p = load.pressure_mpa * m.tets.pressure_factor(j);
            e -= p * pressure_tri6::face_volume(&x, &m.volume_weights).0;
        }
        for f in &m.pressure_faces {
            let du = gather(u, f);
            let x: [Vector3<f64>; 4] = std::array::from_fn(|k| m.nodes[f[k]] + du[k]);
            e -= load.pressure_mpa * face_volume(&x, &m.volume_weights).0;
        }
        for d in 0..u.len() {
            if !m.fixed[d] {
                e -= load.dead * m.loads[d] * u[d];
            }
        }
        e
    }

    /// At a state consistent in the hexahedra's dilatations and pressures, the residual
    /// is the gradient of the potential energy and the tangent (with the pressure's load
    /// stiffness) its Hessian, on the actuator mesh, of hexahedra and of tetrahedra: for
    /// the tetrahedra in the displacements and the corner pressures together (the
    /// Taylor-Hood system, a saddle point: its pressure block negative definite).
    #[test]
    fn condensed_tangent_and_residual_are_derivatives_of_the_energy() {
        for element in [SolidElement::Q1p0, SolidElement::Tet10] {
            derivatives_of_the_energy(element);
        }
    }

    fn derivatives_of_the_energy(element: SolidElement) {
        let mesh = build_mesh(&ActuatorConfig {
            mesh: MeshConfig {
                size_mm: 4.0,
                element,
            },
            ..Default::default()
        })
        .unwrap();
        let solver = Solver::new(&mesh.model).unwrap();
        let n = mesh.model.nodes.len();
        let u: Vec<f64> = (0..3 * n)
            .map(|d| {
                if mesh.model.fixed[d] {
                    0.0
                } else {
                    0.05 * ((d as f64) * 0.37).sin()
                }
            })
            .collect();
        // Corner pressures of the order of the stresses (MPa), varying over the mesh.
        let corners: Vec<f64> = (0..solver.n_p)
            .map(|k| 0.02 * ((k as f64) * 0.61).cos())
            .collect();
        let load = LoadState {
            dead: 1.0,
            pressure_mpa: 0.05,
        };
        let at = |u: &[f64], corners: &[f64]| {
            let (th, mut p) = consistent(&solver, u);
            p.extend_from_slice(corners);
            solver.assemble(u, &th, &p, &[], load).unwrap()
        };
        let a = at(&u, &corners);
        if element == SolidElement::Q1p0 {
            assert!(a.volume_error < 1e-14);
        } else {
            assert!(solver.n_p > 0 && a.residual.len() == solver.n_eq + solver.n_p);
        }
        // Entry (row, col) of the symmetric tangent from its lower triangle (0 off the
        // pattern).
        let entry = |row: usize, col: usize| match solver.pattern.slot(row.max(col), row.min(col)) {
            SKIP => 0.0,
            s => a.values[s as usize],
        };
        let free: Vec<usize> = (0..3 * n).filter(|d| !mesh.model.fixed[*d]).collect();
        let h = 1e-6;
        let mut worst: f64 = 0.0;
        let scale = a.values.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        // Every entry at once: the tangent times a direction that moves every free dof
        // against the residual's central difference along it.
        let direction: Vec<f64> = (0..a.residual.len())
            .map(|k| ((k as f64) * 0.73 + 0.2).sin())
            .collect();
        let mut product = vec![0.0; direction.len()];
        let col_ptr = solver.pattern.symbolic.col_ptr();
        let row_idx = solver.pattern.symbolic.row_idx();
        for c in 0..direction.len() {
            for s in col_ptr[c]..col_ptr[c + 1] {
                let r = row_idx[s];
                product[r] += a.values[s] * direction[c];
                if r != c {
                    product[c] += a.values[s] * direction[r];
                }
            }
        }
        let along = |sign: f64| {
            let (mut v, mut p) = (u.clone(), corners.clone());
            for (col, d) in direction.iter().enumerate() {
                if col >= solver.n_eq {
                    p[col - solver.n_eq] += sign * h * d;
                } else {
                    v[free[col]] += sign * h * d;
                }
            }
            at(&v, &p).residual
        };
        let (rp, rm) = (along(1.0), along(-1.0));
        let worst_product = (0..product.len())
            .map(|row| ((rp[row] - rm[row]) / (2.0 * h) - product[row]).abs())
            .fold(0.0_f64, f64::max);
        assert!(
            worst_product < 1e-5 * scale,
            "{element:?}: worst |K d - FD| {worst_product} (scale {scale})"
        );
        // Whole columns: about 10 displacement ones spread over the mesh, and about 5
        // pressure ones.
        let columns = free
            .iter()
            .enumerate()
            .step_by(free.len() / 10 + 1)
            .map(|(col, d)| (col, Some(*d)))
            .chain(
                (0..solver.n_p)
                    .step_by(solver.n_p / 5 + 1)
                    .map(|k| (solver.n_eq + k, None)),
            );
        for (col, dof) in columns {
            let (mut up, mut um) = (u.clone(), u.clone());
            let (mut pp, mut pm) = (corners.clone(), corners.clone());
            match dof {
                Some(d) => {
                    up[d] += h;
                    um[d] -= h;
                }
                None => {
                    pp[col - solver.n_eq] += h;
                    pm[col - solver.n_eq] -= h;
                }
            }
            let de =
                (energy(&solver, &up, &pp, load) - energy(&solver, &um, &pm, load)) / (2.0 * h);
            assert!(
                (de - a.residual[col]).abs() < 1e-6 * scale,
                "{element:?}: dE/dx[{col}] {de} vs r {}",
                a.residual[col]
            );
            let (ap, am) = (at(&up, &pp), at(&um, &pm));
            for row in 0..a.residual.len() {
                let fd = (ap.residual[row] - am.residual[row]) / (2.0 * h);
                worst = worst.max((fd - entry(row, col)).abs());
            }
        }
        assert!(
            worst < 1e-5 * scale,
            "{element:?}: worst |K - FD| {worst} (scale {scale})"
        );
    }
}
