//! The model the solver takes (mesh, materials, supports, dead loads, pressurized faces,
//! sheets, fibres, contact) and the load state it is solved at.

use nalgebra::Vector3;

use crate::fem::contact::Contact;
use crate::fem::material::Yeoh;
use crate::fem::membrane::MembraneElement;
use crate::fem::membrane_tri6::Tri6Membrane;
use crate::fem::plate::PlateTerm;
use crate::fem::truss::TrussElement;

/// A hexahedral model: mesh, material, supports, dead loads and pressurized faces.
#[derive(Debug, Clone)]
pub struct Model {
    /// Node positions, mm.
    pub nodes: Vec<Vector3<f64>>,
    /// Elements: 8 node indices each (local order of [`crate::fem::hex`]).
    pub elements: Vec<[usize; 8]>,
    /// Material.
    pub material: Yeoh,
    /// Fixed degrees of freedom (3 per node: x, y, z), zero displacement.
    pub fixed: Vec<bool>,
    /// Nodal dead loads at load factor 1, N (3 per node).
    pub loads: Vec<f64>,
    /// Cavity faces carrying the follower pressure: 4 node indices, counter-clockwise
    /// seen from the wall (normal out of the cavity), see [`crate::fem::pressure`].
    pub pressure_faces: Vec<[usize; 4]>,
    /// Weights of the divergence-theorem field for the cavity volume
    /// ([`crate::fem::pressure::CLOSED`] for a cavity closed in 3D or by symmetry planes
    /// through the origin; w_z = 0 for a plane-strain slab).
    pub volume_weights: Vector3<f64>,
    /// Material of each element: 0 is [`Self::material`], k is `extra_materials[k - 1]`
    /// (e.g. a strain-limiting layer, [`crate::fem::layer`]); empty: every element is 0.
    pub element_material: Vec<u8>,
    /// The materials beside [`Self::material`].
    pub extra_materials: Vec<Yeoh>,
    /// Membrane elements (thin stiff sheets bonded to the solid, [`crate::fem::membrane`]).
    pub membranes: Vec<MembraneElement>,
    /// 6-node membranes on tetrahedra's faces ([`crate::fem::membrane_tri6`]).
    pub tri_membranes: Vec<Tri6Membrane>,
    /// Fibre segments embedded in the hexahedra ([`crate::fem::truss`]).
    pub trusses: Vec<TrussElement>,
    /// Bending terms of sheets meshed as membranes with their bending stiffness
    /// ([`crate::fem::plate`] on quadrilaterals, [`crate::fem::plate_tri`] on
    /// triangles): a constant stiffness.
    pub plates: Vec<PlateTerm>,
    /// Frictionless contact between surfaces ([`crate::fem::contact`]); `None`: no contact.
    pub contact: Option<Contact>,
    /// The hexahedra with incompatible modes ([`crate::fem::hex`]'s enhanced element, the
    /// modes condensed per element) instead of the plain Q1/P0 element.
    pub incompatible_modes: bool,
    /// Quadratic tetrahedra beside (or instead of) the hexahedra, and their pressurized
    /// faces.
    pub tets: Tetrahedra,
}

/// The 10-node tetrahedra of a model ([`crate::fem::tet10::taylor_hood`], mixed u-P with
/// a continuous linear pressure: the solver adds a pressure unknown at every corner
/// node) and their 6-node cavity faces ([`crate::fem::pressure_tri6`]).
#[derive(Debug, Clone, Default)]
pub struct Tetrahedra {
    /// Elements: 10 node indices each (C3D10 order, [`crate::fem::tet10::EDGES`]).
    pub elements: Vec<[usize; 10]>,
    /// Material of each tetrahedron as [`Model::element_material`] (0 the main material,
    /// k `extra_materials[k - 1]`); empty: every one is 0.
    pub material: Vec<u8>,
    /// Cavity faces carrying the follower pressure: 6 node indices, the normal out of the
    /// cavity ([`crate::fem::pressure_tri6`]'s order).
    pub pressure_faces: Vec<[usize; 6]>,
    /// The cavities the faces make, each a run of them (an imported mesh's `cavity` and
    /// `cavity.NAME` groups); empty: one cavity, at the ramp's pressure.
    pub cavities: Vec<Cavity>,
}

/// One cavity of [`Tetrahedra`]: its faces and its pressure as a factor of the ramp's
/// (`[cavities]`, [`crate::fem::config::cavities`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Cavity {
    /// NAME of its `cavity.NAME` group (None: the unnamed `cavity`).
    pub name: Option<String>,
    /// Its faces, indices into [`Tetrahedra::pressure_faces`].
    pub faces: std::ops::Range<usize>,
    /// Its pressure over the ramp's (1: the ramp's, 0: not pressurised).
    pub factor: f64,
}

impl Tetrahedra {
    /// The pressure factor of face `face`: its cavity's, 1 outside every cavity.
    pub fn pressure_factor(&self, face: usize) -> f64 {
        self.cavities
            .iter()
            .find(|c| c.faces.contains(&face))
            .map_or(1.0, |c| c.factor)
    }
}

impl Model {
    /// A model of hexahedra alone (Q1/P0, one material, no pressure, sheets, fibres or
    /// contact).
    pub fn solid(
        nodes: Vec<Vector3<f64>>,
        elements: Vec<[usize; 8]>,
        material: Yeoh,
        fixed: Vec<bool>,
        loads: Vec<f64>,
    ) -> Self {
        Self {
            nodes,
            elements,
            material,
            fixed,
            loads,
            pressure_faces: Vec::new(),
            volume_weights: crate::fem::pressure::CLOSED,
            element_material: Vec::new(),
            extra_materials: Vec::new(),
            membranes: Vec::new(),
            tri_membranes: Vec::new(),
            trusses: Vec::new(),
            plates: Vec::new(),
            contact: None,
            incompatible_modes: false,
            tets: Tetrahedra::default(),
        }
    }

    /// The material of element `e`.
    pub fn material_of(&self, e: usize) -> &Yeoh {
        self.material_by_id(self.element_material.get(e).copied())
    }

    /// The material id of solid element `e`, counting the hexahedra first and the
    /// tetrahedra after them (the order of [`super::Solver::element_stresses`]).
    pub fn solid_material_id(&self, e: usize) -> u8 {
        let hexes = self.elements.len();
        if e < hexes {
            self.element_material.get(e).copied().unwrap_or(0)
        } else {
            self.tets.material.get(e - hexes).copied().unwrap_or(0)
        }
    }

    /// The material of tetrahedron `t`.
    pub fn material_of_tet(&self, t: usize) -> &Yeoh {
        self.material_by_id(self.tets.material.get(t).copied())
    }

    fn material_by_id(&self, id: Option<u8>) -> &Yeoh {
        match id {
            Some(k) if k > 0 => self
                .extra_materials
                .get(usize::from(k) - 1)
                .unwrap_or(&self.material),
            _ => &self.material,
        }
    }
}

/// A load state: dead-load factor and cavity pressure.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LoadState {
    /// Factor on [`Model::loads`].
    pub dead: f64,
    /// Cavity pressure, MPa.
    pub pressure_mpa: f64,
}

impl LoadState {
    pub(super) fn lerp(&self, to: &LoadState, t: f64) -> LoadState {
        LoadState {
            dead: self.dead + t * (to.dead - self.dead),
            pressure_mpa: self.pressure_mpa + t * (to.pressure_mpa - self.pressure_mpa),
        }
    }
}

/// Dilatations and pressures per element: one (Q1/P0), or one per Gauss point for the
/// element with incompatible modes.
pub(super) fn volume_points(model: &Model) -> usize {
    if model.incompatible_modes {
        8
    } else {
        1
    }
}
