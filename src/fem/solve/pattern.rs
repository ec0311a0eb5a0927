//! The sparsity pattern of the condensed tangent, computed once from the mesh (and
//! extended when contact couples new node pairs), and where every element, face, sheet
//! and fibre matrix entry goes in its value array. The tetrahedra's corner pressures
//! (Taylor-Hood, [`crate::fem::tet10::taylor_hood`]) are unknowns of their own, numbered
//! after the free displacements.

use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};

use super::model::Model;
use crate::fem::plate::PLATE_NODES;
use crate::fem::tet10::taylor_hood::TH_DOFS;
use crate::fem::truss::TRUSS_DOFS;
use crate::fem::FemError;

/// Marks an entry of an element or face matrix that is not assembled (a fixed dof, or
/// the upper triangle).
pub(super) const SKIP: u32 = u32::MAX;

/// The sparsity pattern of the condensed tangent's lower triangle (free dofs), fixed by
/// the mesh, and where every element and face matrix entry goes in its value array.
///
/// Why: building the matrix from triplets sorted ~1.2 M entries per Newton iteration
/// (a quarter of the run time); with the pattern computed once, assembly is a scatter
/// of each element matrix into its precomputed slots, and faer's symbolic factorization
/// (computed once for the same pattern) is reused for every numeric factorization.
pub(super) struct Pattern {
    pub(super) symbolic: SymbolicSparseColMat<usize>,
    /// `element_slots[e][a + 24 b]`: value index of entry (a, b) of element e (column
    /// major, nalgebra's storage order), or SKIP.
    pub(super) element_slots: Vec<[u32; 576]>,
    /// Elements with a free dof (the others stay at rest and are not evaluated).
    pub(super) active: Vec<bool>,
    /// `face_slots[f][a + 12 b]`: value index of entry (a, b) of pressure face f, or SKIP.
    pub(super) face_slots: Vec<[u32; 144]>,
    /// `membrane_slots[m][a + 12 b]`: value index of entry (a, b) of membrane m, or SKIP.
    pub(super) membrane_slots: Vec<[u32; 144]>,
    /// `tri_membrane_slots[m][a + 18 b]`: the same for 6-node membrane m.
    pub(super) tri_membrane_slots: Vec<Box<[u32; 324]>>,
    /// `truss_slots[t][a + 48 b]`: value index of entry (a, b) of fibre segment t, or SKIP.
    pub(super) truss_slots: Vec<Box<[u32; TRUSS_DOFS * TRUSS_DOFS]>>,
    /// `plate_slots[t][a + 3 PLATE_NODES b]`: value index of entry (a, b) of bending term t, or SKIP.
    pub(super) plate_slots: Vec<[u32; 9 * PLATE_NODES * PLATE_NODES]>,
    /// `tet_slots[t][a + 34 b]`: value index of entry (a, b) of tetrahedron t (30
    /// displacements, then its 4 corner pressures), or SKIP.
    pub(super) tet_slots: Vec<Box<[u32; TH_DOFS * TH_DOFS]>>,
    /// `tri6_slots[f][a + 18 b]`: value index of entry (a, b) of 6-node pressure face f,
    /// or SKIP.
    pub(super) tri6_slots: Vec<Box<[u32; 324]>>,
}

impl Pattern {
    /// The pattern of `n_eq` free displacements (`eq`: each dof's equation) and the
    /// pressures `tet_pressure` (each tetrahedron's 4 corner pressures, 0..n_p, their
    /// equations n_eq + k), with the node pairs `extra` that contact couples.
    pub(super) fn new(
        model: &Model,
        eq: &[Option<usize>],
        n_eq: usize,
        tet_pressure: &[[usize; 4]],
        n_p: usize,
        extra: &[(usize, usize)],
    ) -> Result<Self, FemError> {
        let dofs = |nodes: &[usize]| -> Vec<Option<usize>> {
            (0..3 * nodes.len())
                .map(|a| eq[3 * nodes[a / 3] + a % 3])
                .collect()
        };
        // A bending term's padding (its unused node entries) takes no slot.
        let plate_dofs = |t: &crate::fem::plate::PlateTerm| -> Vec<Option<usize>> {
            (0..3 * PLATE_NODES)
                .map(|a| {
                    (a / 3 < t.used())
                        .then(|| eq[3 * t.nodes[a / 3] + a % 3])
                        .flatten()
                })
                .collect()
        };
        let tet_dofs = |t: usize| -> Vec<Option<usize>> {
            let mut d = dofs(&model.tets.elements[t]);
            d.extend(tet_pressure[t].iter().map(|k| Some(n_eq + k)));
            d
        };
        let n = n_eq + n_p;
        let mut columns: Vec<Vec<usize>> = vec![Vec::new(); n];
        let mut add = |d: &[Option<usize>]| {
            for ra in d.iter().flatten() {
                for cb in d.iter().flatten() {
                    if ra >= cb {
                        columns[*cb].push(*ra);
                    }
                }
            }
        };
        for el in &model.elements {
            add(&dofs(el));
        }
        for f in &model.pressure_faces {
            add(&dofs(f));
        }
        for m in &model.membranes {
            add(&dofs(&m.nodes));
        }
        for m in &model.tri_membranes {
            add(&dofs(&m.nodes));
        }
        for t in &model.trusses {
            add(&dofs(&t.nodes()));
        }
        for t in &model.plates {
            add(&plate_dofs(t));
        }
        for t in 0..model.tets.elements.len() {
            add(&tet_dofs(t));
        }
        for f in &model.tets.pressure_faces {
            add(&dofs(f));
        }
        // Contact: the node pairs contact has coupled so far (`extra`, found during the
        // solve); the master faces' own couplings are those of their elements.
        for (a, b) in extra {
            for ra in dofs(&[*a]).iter().flatten() {
                for cb in dofs(&[*b]).iter().flatten() {
                    let (hi, lo) = if ra >= cb { (*ra, *cb) } else { (*cb, *ra) };
                    columns[lo].push(hi);
                }
            }
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for c in columns.iter_mut() {
            c.sort_unstable();
            c.dedup();
            row_idx.extend_from_slice(c);
            col_ptr.push(row_idx.len());
        }
        if row_idx.len() >= SKIP as usize {
            return Err(FemError::Model {
                why: "the stiffness matrix has too many entries: use a larger mesh size".into(),
            });
        }
        let slot = |r: usize, c: usize| -> u32 {
            let rows = &row_idx[col_ptr[c]..col_ptr[c + 1]];
            match rows.binary_search(&r) {
                Ok(k) => (col_ptr[c] + k) as u32,
                Err(_) => SKIP,
            }
        };
        let slots = |d: &[Option<usize>], out: &mut [u32]| {
            let n = d.len();
            for a in 0..n {
                for b in 0..n {
                    out[a + n * b] = match (d[a], d[b]) {
                        (Some(r), Some(c)) if r >= c => slot(r, c),
                        _ => SKIP,
                    };
                }
            }
        };
        let element_slots = model
            .elements
            .iter()
            .map(|el| {
                let mut s = [SKIP; 576];
                slots(&dofs(el), &mut s);
                s
            })
            .collect();
        let active = model
            .elements
            .iter()
            .map(|el| dofs(el).iter().any(Option::is_some))
            .collect();
        let face_slots = model
            .pressure_faces
            .iter()
            .map(|f| {
                let mut s = [SKIP; 144];
                slots(&dofs(f), &mut s);
                s
            })
            .collect();
        let membrane_slots = model
            .membranes
            .iter()
            .map(|m| {
                let mut s = [SKIP; 144];
                slots(&dofs(&m.nodes), &mut s);
                s
            })
            .collect();
        let tri_membrane_slots = model
            .tri_membranes
            .iter()
            .map(|m| {
                let mut s = Box::new([SKIP; 324]);
                slots(&dofs(&m.nodes), &mut s[..]);
                s
            })
            .collect();
        let truss_slots = model
            .trusses
            .iter()
            .map(|t| {
                let mut s = Box::new([SKIP; TRUSS_DOFS * TRUSS_DOFS]);
                slots(&dofs(&t.nodes()), &mut s[..]);
                s
            })
            .collect();
        let plate_slots = model
            .plates
            .iter()
            .map(|t| {
                let mut s = [SKIP; 9 * PLATE_NODES * PLATE_NODES];
                slots(&plate_dofs(t), &mut s);
                s
            })
            .collect();
        let tet_slots = (0..model.tets.elements.len())
            .map(|t| {
                let mut s = Box::new([SKIP; TH_DOFS * TH_DOFS]);
                slots(&tet_dofs(t), &mut s[..]);
                s
            })
            .collect();
        let tri6_slots = model
            .tets
            .pressure_faces
            .iter()
            .map(|f| {
                let mut s = Box::new([SKIP; 324]);
                slots(&dofs(f), &mut s[..]);
                s
            })
            .collect();
        let symbolic = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        Ok(Self {
            symbolic,
            element_slots,
            active,
            face_slots,
            membrane_slots,
            tri_membrane_slots,
            truss_slots,
            plate_slots,
            tet_slots,
            tri6_slots,
        })
    }

    /// The value index of lower-triangle entry (r, c), r >= c, or SKIP when it is not in
    /// the pattern.
    pub(super) fn slot(&self, r: usize, c: usize) -> u32 {
        let col_ptr = self.symbolic.col_ptr();
        let rows = &self.symbolic.row_idx()[col_ptr[c]..col_ptr[c + 1]];
        match rows.binary_search(&r) {
            Ok(k) => (col_ptr[c] + k) as u32,
            Err(_) => SKIP,
        }
    }

    pub(super) fn matrix<'a>(&'a self, values: &'a [f64]) -> SparseColMatRef<'a, usize, f64> {
        SparseColMatRef::new(self.symbolic.as_ref(), values)
    }
}
