//! The incremental solver: the state it holds (displacement, element dilatations and
//! pressures, the tetrahedra's corner pressures, the modes' amplitudes, the load), its
//! set-up from a [`Model`], and what it reports of a state (positions, cavity volume,
//! stresses, reactions, warm-start state).

use std::sync::Mutex;

use faer::dyn_stack::MemBuffer;
use faer::sparse::linalg::cholesky::SymbolicCholesky;
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use super::assembly::{gather, ElementPart, TetPart, MODE_DOFS};
use super::model::{volume_points, LoadState, Model};
use super::pattern::Pattern;
use crate::fem::contact::contact_terms;
use crate::fem::hex::{element_cauchy_stress, element_response, HexGeometry, Modes};
use crate::fem::membrane::{membrane_response, MembraneGeometry};
use crate::fem::membrane_tri6::{tri6_membrane_response, Tri6Geometry};
use crate::fem::pressure::face_volume;
use crate::fem::pressure_tri6;
use crate::fem::tet10::taylor_hood;
use crate::fem::tet10::Tet10Geometry;
use crate::fem::truss::{truss_response, TRUSS_DOFS};
use crate::fem::FemError;

/// A solver's state ([`Solver::state`]), to warm-start a solve of a nearby model.
#[derive(Debug, Clone)]
pub struct SolverState {
    u: Vec<f64>,
    theta: Vec<f64>,
    pressure: Vec<f64>,
    modes: Vec<Modes>,
    load: LoadState,
}

/// An incremental solver: holds the current displacement and load state of a model.
pub struct Solver<'m> {
    pub(super) model: &'m Model,
    pub(super) geom: Vec<HexGeometry>,
    pub(super) tet_geom: Vec<Tet10Geometry>,
    pub(super) membrane_geom: Vec<MembraneGeometry>,
    /// Reference geometry of each 6-node membrane.
    pub(super) tri_membrane_geom: Vec<Tri6Geometry>,
    pub(super) eq: Vec<Option<usize>>,
    /// Free displacements (equations 0..n_eq).
    pub(super) n_eq: usize,
    /// Each tetrahedron's 4 corner pressures: indices into the corner pressures (the
    /// tail of [`Self::pressure`]; equations n_eq + k). A node of hexahedra only has none.
    pub(super) tet_pressure: Vec<[usize; 4]>,
    /// Corner pressures (Taylor-Hood unknowns), n_p.
    pub(super) n_p: usize,
    /// ∫ L_k dV over the tetrahedra at each corner pressure k: its volume constraint's
    /// residual over it is a volume strain (the convergence test's volume error).
    pub(super) corner_volume: Vec<f64>,
    pub(super) pattern: Pattern,
    /// Node pairs added to the pattern during the solve: slave nodes and the nodes of the
    /// master faces they have met. Coupling every wall node to the facing wall from the
    /// start made the default actuator's ramp 1.7x dearer even with no contact (the
    /// couplings across the gaps turn the comb of chambers into a solid bar for the
    /// fill-reducing ordering); coupled on demand, contact costs nothing until it happens.
    pub(super) extra_couplings: Vec<(usize, usize)>,
    pub(super) symbolic: Option<SymbolicCholesky<usize>>,
    pub(super) factor: Vec<f64>,
    /// Scratch memory of the numeric factorization and solve, kept between Newton
    /// iterations (allocated anew each time it cost ~8% of a ramp in page faults).
    pub(super) scratch: Option<MemBuffer>,
    /// Each element's force, tangent and condensed terms from the last assembly, kept so
    /// that an assembly allocates nothing (a fresh ~55 MB vector per Newton iteration at
    /// the default mesh cost page faults and moves).
    pub(super) parts: Mutex<Vec<Option<ElementPart>>>,
    /// The same for two chunks of tetrahedra ([`super::assembly::TET_CHUNK`]): one
    /// scattered while the next is evaluated.
    pub(super) tet_parts: Mutex<[Vec<Option<TetPart>>; 2]>,
    pub(super) u: Vec<f64>,
    /// Element dilatations θ_e.
    pub(super) theta: Vec<f64>,
    /// Element pressures p_e of the hexahedra, then the tetrahedra's corner pressures,
    /// MPa.
    pub(super) pressure: Vec<f64>,
    /// Amplitudes of each element's incompatible modes (empty for the plain element).
    pub(super) modes: Vec<Modes>,
    pub(super) load: LoadState,
    /// The converged state before the current one and its load: the secant predictor.
    pub(super) previous: Option<(State, LoadState)>,
}

/// A state of the iteration: u, θ_e, p_e (with the corner pressures) and the modes'
/// amplitudes.
pub(super) type State = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<Modes>);

impl<'m> Solver<'m> {
    /// Checks the model and precomputes the reference geometry.
    pub fn new(model: &'m Model) -> Result<Self, FemError> {
        let n = model.nodes.len();
        if model.fixed.len() != 3 * n || model.loads.len() != 3 * n {
            return Err(FemError::Model {
                why: "fixed and loads need 3 entries per node".into(),
            });
        }
        if !model.element_material.is_empty()
            && (model.element_material.len() != model.elements.len()
                || model
                    .element_material
                    .iter()
                    .any(|k| usize::from(*k) > model.extra_materials.len()))
        {
            return Err(FemError::Model {
                why: "element_material needs one valid material index per element".into(),
            });
        }
        if model.incompatible_modes && !model.tets.elements.is_empty() {
            return Err(FemError::Model {
                why: "tetrahedra beside hexahedra with incompatible modes".into(),
            });
        }
        if !model.tets.material.is_empty()
            && (model.tets.material.len() != model.tets.elements.len()
                || model
                    .tets
                    .material
                    .iter()
                    .any(|k| usize::from(*k) > model.extra_materials.len()))
        {
            return Err(FemError::Model {
                why: "the tetrahedra's materials need one valid index per tetrahedron".into(),
            });
        }
        if model
            .contact
            .iter()
            .flat_map(|c| &c.pairs)
            .any(|p| p.slave_nodes.len() != p.slave_areas_mm2.len())
        {
            return Err(FemError::Model {
                why: "a contact pair needs one area per slave node".into(),
            });
        }
        if let Some(bad) = model
            .elements
            .iter()
            .flatten()
            .chain(model.pressure_faces.iter().flatten())
            .chain(model.tets.elements.iter().flatten())
            .chain(model.tets.pressure_faces.iter().flatten())
            .chain(model.membranes.iter().flat_map(|m| &m.nodes))
            .chain(model.tri_membranes.iter().flat_map(|m| &m.nodes))
            .chain(model.plates.iter().flat_map(|t| &t.nodes))
            .chain(
                model
                    .trusses
                    .iter()
                    .flat_map(|t| t.ends.iter().flat_map(|e| &e.nodes)),
            )
            .chain(model.contact.iter().flat_map(|c| {
                c.pairs
                    .iter()
                    .flat_map(|p| p.slave_nodes.iter().chain(p.master_faces.iter().flatten()))
            }))
            .find(|a| **a >= n)
        {
            return Err(FemError::Model {
                why: format!("node index {bad} out of range ({n} nodes)"),
            });
        }
        let mut geom = Vec::with_capacity(model.elements.len());
        for (i, el) in model.elements.iter().enumerate() {
            let x: [Vector3<f64>; 8] = std::array::from_fn(|a| model.nodes[el[a]]);
            geom.push(HexGeometry::new(&x).ok_or(FemError::Model {
                why: format!("element {i} is inverted or degenerate"),
            })?);
        }
        let mut tet_geom = Vec::with_capacity(model.tets.elements.len());
        for (i, t) in model.tets.elements.iter().enumerate() {
            let x: [Vector3<f64>; 10] = std::array::from_fn(|a| model.nodes[t[a]]);
            tet_geom.push(Tet10Geometry::new(&x).ok_or(FemError::Model {
                why: format!("tetrahedron {i} is inverted or degenerate"),
            })?);
        }
        let mut membrane_geom = Vec::with_capacity(model.membranes.len());
        for (i, m) in model.membranes.iter().enumerate() {
            let x: [Vector3<f64>; 4] = std::array::from_fn(|a| model.nodes[m.nodes[a]]);
            membrane_geom.push(MembraneGeometry::new(&x).ok_or(FemError::Model {
                why: format!("membrane {i} is degenerate"),
            })?);
        }
        let mut tri_membrane_geom = Vec::with_capacity(model.tri_membranes.len());
        for (i, m) in model.tri_membranes.iter().enumerate() {
            let x: [Vector3<f64>; 6] = std::array::from_fn(|a| model.nodes[m.nodes[a]]);
            tri_membrane_geom.push(Tri6Geometry::new(&x).ok_or(FemError::Model {
                why: format!("6-node membrane {i} is degenerate"),
            })?);
        }
        let mut eq = vec![None; 3 * n];
        let mut n_eq = 0;
        for (d, fixed) in model.fixed.iter().enumerate() {
            if !fixed {
                eq[d] = Some(n_eq);
                n_eq += 1;
            }
        }
        // The corner pressures, numbered as the tetrahedra first meet them.
        let mut corner = vec![None; n];
        let mut n_p = 0;
        let tet_pressure: Vec<[usize; 4]> = model
            .tets
            .elements
            .iter()
            .map(|t| {
                std::array::from_fn(|i| {
                    *corner[t[i]].get_or_insert_with(|| {
                        n_p += 1;
                        n_p - 1
                    })
                })
            })
            .collect();
        let mut corner_volume = vec![0.0; n_p];
        for (ks, g) in tet_pressure.iter().zip(&tet_geom) {
            for (k, v) in ks.iter().zip(taylor_hood::corner_volumes(g)) {
                corner_volume[*k] += v;
            }
        }
        let pattern = Pattern::new(model, &eq, n_eq, &tet_pressure, n_p, &[])?;
        let points = volume_points(model);
        Ok(Self {
            model,
            geom,
            tet_geom,
            membrane_geom,
            tri_membrane_geom,
            eq,
            n_eq,
            tet_pressure,
            n_p,
            corner_volume,
            pattern,
            extra_couplings: Vec::new(),
            symbolic: None,
            factor: Vec::new(),
            scratch: None,
            parts: Mutex::new(Vec::new()),
            tet_parts: Mutex::new([Vec::new(), Vec::new()]),
            u: vec![0.0; 3 * n],
            theta: vec![1.0; points * model.elements.len()],
            pressure: vec![0.0; points * model.elements.len() + n_p],
            modes: if model.incompatible_modes {
                vec![[0.0; MODE_DOFS]; model.elements.len()]
            } else {
                Vec::new()
            },
            load: LoadState::default(),
            previous: None,
        })
    }

    /// The pattern of this model's tangent with the contact couplings found so far.
    pub(super) fn new_pattern(&self) -> Result<Pattern, FemError> {
        Pattern::new(
            self.model,
            &self.eq,
            self.n_eq,
            &self.tet_pressure,
            self.n_p,
            &self.extra_couplings,
        )
    }

    /// Nodal displacements, mm (3 per node).
    pub fn displacement(&self) -> &[f64] {
        &self.u
    }

    /// The load state of [`Self::displacement`].
    pub fn load(&self) -> LoadState {
        self.load
    }

    /// Degrees of freedom solved for.
    pub fn free_dofs(&self) -> usize {
        self.n_eq
    }

    /// Current position of node `a`.
    pub fn position(&self, a: usize) -> Vector3<f64> {
        self.model.nodes[a] + Vector3::new(self.u[3 * a], self.u[3 * a + 1], self.u[3 * a + 2])
    }

    /// Current volume enclosed by the pressure faces (and the symmetry planes through the
    /// origin), mm³.
    pub fn cavity_volume(&self) -> f64 {
        let w = &self.model.volume_weights;
        let quads: f64 = self
            .model
            .pressure_faces
            .iter()
            .map(|f| {
                let x: [Vector3<f64>; 4] = std::array::from_fn(|k| self.position(f[k]));
                face_volume(&x, w).0
            })
            .sum();
        let triangles: f64 = self
            .model
            .tets
            .pressure_faces
            .iter()
            .map(|f| {
                let x: [Vector3<f64>; 6] = std::array::from_fn(|k| self.position(f[k]));
                pressure_tri6::face_volume(&x, w).0
            })
            .sum();
        quads + triangles
    }

    /// Current volume of each cavity of [`super::Tetrahedra::cavities`], mm³ (with the
    /// symmetry planes, as [`Self::cavity_volume`]).
    pub fn cavity_volumes(&self) -> Vec<f64> {
        let w = &self.model.volume_weights;
        let faces = &self.model.tets.pressure_faces;
        self.model
            .tets
            .cavities
            .iter()
            .map(|c| {
                faces
                    .get(c.faces.clone())
                    .unwrap_or_default()
                    .iter()
                    .map(|f| {
                        let x: [Vector3<f64>; 6] = std::array::from_fn(|k| self.position(f[k]));
                        pressure_tri6::face_volume(&x, w).0
                    })
                    .sum()
            })
            .collect()
    }

    /// The corner pressures of tetrahedron `t`, MPa.
    pub(super) fn corner_pressures(&self, pressure: &[f64], t: usize) -> [f64; 4] {
        let nodal = &pressure[pressure.len() - self.n_p..];
        self.tet_pressure[t].map(|k| nodal[k])
    }

    /// Cauchy stress of every tetrahedron, MPa: the isochoric part and the interpolated
    /// pressure averaged over the element.
    fn tet_stresses(&self) -> Vec<Matrix3<f64>> {
        let model = self.model;
        model
            .tets
            .elements
            .par_iter()
            .zip(&self.tet_geom)
            .enumerate()
            .map(|(t, (el, g))| {
                let material = model.material_of_tet(t);
                let u = gather(&self.u, el);
                let p = self.corner_pressures(&self.pressure, t);
                taylor_hood::element_cauchy_stress(g, material, &u, &p)
                    .unwrap_or_else(|| Matrix3::from_element(f64::NAN))
            })
            .collect()
    }

    /// Cauchy stress of every solid element, MPa: the hexahedra, then the tetrahedra
    /// (NaN entries for an inverted one, which a converged state does not have).
    pub fn element_stresses(&self) -> Vec<Matrix3<f64>> {
        let mut s = self.hex_stresses();
        s.extend(self.tet_stresses());
        s
    }

    fn hex_stresses(&self) -> Vec<Matrix3<f64>> {
        self.model
            .elements
            .par_iter()
            .zip(&self.geom)
            .enumerate()
            .map(|(e, (el, g))| {
                element_cauchy_stress(
                    g,
                    self.model.material_of(e),
                    &gather(&self.u, el),
                    self.modes.get(e),
                )
                .unwrap_or_else(|| Matrix3::from_element(f64::NAN))
            })
            .collect()
    }

    /// Support reactions: internal minus external force at every dof, N (zero up to the
    /// tolerance at free dofs; the force the supports exert at fixed ones).
    pub fn reactions(&self) -> Vec<f64> {
        let mut f = vec![0.0; self.u.len()];
        for (e, (el, g)) in self.model.elements.iter().zip(&self.geom).enumerate() {
            if let Some((_, fe, _)) = element_response(
                g,
                self.model.material_of(e),
                &gather(&self.u, el),
                self.modes.get(e),
            ) {
                for a in 0..24 {
                    f[3 * el[a / 3] + a % 3] += fe[a];
                }
            }
        }
        for (t, (el, g)) in self
            .model
            .tets
            .elements
            .iter()
            .zip(&self.tet_geom)
            .enumerate()
        {
            let p = self.corner_pressures(&self.pressure, t);
            if let Some(r) = taylor_hood::element_response(
                g,
                self.model.material_of_tet(t),
                &gather(&self.u, el),
                &p,
            ) {
                for a in 0..30 {
                    f[3 * el[a / 3] + a % 3] += r.gradient[a];
                }
            }
        }
        for (m, g) in self.model.membranes.iter().zip(&self.membrane_geom) {
            let (_, fm, _) = membrane_response(g, &m.section, &gather(&self.u, &m.nodes));
            for a in 0..12 {
                f[3 * m.nodes[a / 3] + a % 3] += fm[a];
            }
        }
        for (m, g) in self.model.tri_membranes.iter().zip(&self.tri_membrane_geom) {
            let (_, fm, _) = tri6_membrane_response(g, &m.section, &gather(&self.u, &m.nodes));
            for a in 0..18 {
                f[3 * m.nodes[a / 3] + a % 3] += fm[a];
            }
        }
        for t in &self.model.trusses {
            let (_, ft, _) = truss_response(t, &self.model.nodes, &self.u);
            let nodes = t.nodes();
            for a in 0..TRUSS_DOFS {
                f[3 * nodes[a / 3] + a % 3] += ft[a];
            }
        }
        for t in &self.model.plates {
            for (a, fa) in t.force(&self.u).iter().enumerate() {
                f[3 * t.nodes[a / 3] + a % 3] += fa;
            }
        }
        let p = self.load.pressure_mpa;
        for face in &self.model.pressure_faces {
            let x: [Vector3<f64>; 4] = std::array::from_fn(|k| self.position(face[k]));
            let (_, g, _) = face_volume(&x, &self.model.volume_weights);
            for a in 0..12 {
                f[3 * face[a / 3] + a % 3] -= p * g[a];
            }
        }
        for (j, face) in self.model.tets.pressure_faces.iter().enumerate() {
            let x: [Vector3<f64>; 6] = std::array::from_fn(|k| self.position(face[k]));
            let (_, g, _) = pressure_tri6::face_volume(&x, &self.model.volume_weights);
            let pf = p * self.model.tets.pressure_factor(j);
            for a in 0..18 {
                f[3 * face[a / 3] + a % 3] -= pf * g[a];
            }
        }
        if let Some(contact) = &self.model.contact {
            for t in contact_terms(contact, &|a| self.position(a)) {
                for a in 0..15 {
                    f[3 * t.nodes[a / 3] + a % 3] += t.force[a];
                }
            }
        }
        for (fd, l) in f.iter_mut().zip(&self.model.loads) {
            *fd -= self.load.dead * l;
        }
        f
    }

    /// The current state (displacement, element dilatations and pressures, load), to
    /// warm-start another solver of a mesh with the same numbering ([`Self::set_state`]).
    pub fn state(&self) -> SolverState {
        SolverState {
            u: self.u.clone(),
            theta: self.theta.clone(),
            pressure: self.pressure.clone(),
            modes: self.modes.clone(),
            load: self.load,
        }
    }

    /// Restores a state taken by [`Self::state`] (of this mesh or one with the same node
    /// and element counts): the next [`Self::advance`] starts from it. Refused when the
    /// sizes differ.
    pub fn set_state(&mut self, state: &SolverState) -> Result<(), FemError> {
        if state.u.len() != self.u.len()
            || state.theta.len() != self.theta.len()
            || state.pressure.len() != self.pressure.len()
            || state.modes.len() != self.modes.len()
        {
            return Err(FemError::Model {
                why: "a warm-start state of another mesh".into(),
            });
        }
        self.u.clone_from(&state.u);
        self.theta.clone_from(&state.theta);
        self.pressure.clone_from(&state.pressure);
        self.modes.clone_from(&state.modes);
        self.load = state.load;
        // The secant predictor's last state belongs to the old path.
        self.previous = None;
        Ok(())
    }
}
