//! Finite-element model of the PneuNets actuator.
//!
//! Written here rather than taken from a crate: no Rust FEM library offers a nearly
//! incompressible finite-strain solid with follower pressure loads; the linear algebra
//! is faer's (sparse LDLᵀ), the small matrices nalgebra's.
//!
//! Data flows: [`material`] (Yeoh silicone, isochoric/volumetric split, stress and
//! tangent) -> [`hex`] (Q1/P0 mean-dilatation hexahedron) and [`pressure`] (cavity
//! faces, follower pressure as −p V) and [`membrane`] (4-node membranes for thin stiff
//! sheets, [`layer`]; [`plate`] their bending stiffness) and [`truss`] (fibre segments embedded in the hexahedra, cables
//! optionally tension-only) and [`contact`] (frictionless node-to-surface
//! penalty contact between the facing chamber walls, optional) -> [`solve`] (Newton on
//! the three-field form, adaptive load steps) -> [`config`] (the config's sections) and [`shapes`] (each actuator shape's presets,
//! checks and [`mesh::ActuatorMesh`]: the PneuNets chambers with the published designs as
//! presets, [`family`]; the fibre-reinforced tube of [`fibre`]) -> [`actuator`] (a config
//! read over its family's defaults and meshed by its shape; [`tube`]: the fibre-wound
//! circular tube) -> [`simulate`] (the pressure ramp and the quantities read off each step),
//! [`vtu`] (ParaView files), [`output`] (every result file of a run or a sweep) and
//! [`inp`] (the model as an Abaqus/CalculiX deck). [`tet10`] (10-node tetrahedra, mixed
//! u-P with a continuous linear pressure, Taylor-Hood) and [`pressure_tri6`] (follower
//! pressure on their 6-node faces) beside the hexahedra.
//!
//! Verified (tests): Yeoh uniaxial and equibiaxial stress against method.md §5; stress,
//! tangent, pressure force and load stiffness against finite differences; the uniaxial
//! block exactly; the plane-strain thick cylinder against the analytic inflation
//! pressure; Cook's membrane against its reference tip displacement; the membrane
//! element's patch test and the composite beam with a sheet or strip; the plate terms
//! on a sheet rolled onto a cylinder, a cantilever strip and the composite beam with a
//! glass strip whose own bending is most of the section's; the fibre segment
//! against finite differences and the Saint Venant-Kirchhoff bar; the fibre-wound tube
//! against the incompressible thick tube (plain: stretch 1.0192 vs 1.0194 at 10 kPa;
//! hoop-wound, outer radius held: 1.0806 vs 1.0808) and a one-way winding's twist
//! (mirror windings opposite to 1e-6, both ways none); the contact
//! tangent against finite differences and the pressed-blocks patch test; the exported
//! deck ([`inp`]) run by CalculiX against bendscope's markers (tests/simulate.rs).

pub mod actuator;
pub mod analytic;
pub mod config;
mod config_doc;
pub mod contact;
pub mod family;
pub mod fibre;
pub mod hex;
pub mod import;
pub mod inp;
pub mod layer;
pub mod material;
pub mod membrane;
pub mod membrane_tri6;
pub mod mesh;
pub mod output;
pub mod params;
pub mod plate;
pub mod plate_tri;
pub mod pressure;
pub mod pressure_tri6;
pub mod shapes;
pub mod simulate;
pub mod solve;
pub mod split;
pub mod stepper;
pub mod tet10;
pub mod truss;
pub mod tube;
pub mod vtu;

/// Errors of the finite-element model.
#[derive(Debug, thiserror::Error)]
pub enum FemError {
    /// A parameter is out of its physical range.
    #[error("parameter {name}: {why}")]
    Parameter {
        /// The parameter (config field name).
        name: String,
        /// What is wrong and what to do.
        why: String,
    },
    /// The model is not usable.
    #[error("FEM model: {why}")]
    Model {
        /// What is wrong.
        why: String,
    },
    /// An input file could not be read or is not what it should be.
    #[error("{why}")]
    Input {
        /// What is wrong with which file, and what to do.
        why: String,
    },
    /// A result file could not be written.
    #[error("cannot write the results: {why}: check the output folder's space and permissions")]
    Output {
        /// What failed.
        why: String,
    },
    /// Newton did not converge.
    #[error("FEM solve diverged at {:.1}% of the load: {why}", 100.0 * load_fraction)]
    Diverged {
        /// Load fraction reached.
        load_fraction: f64,
        /// What to try.
        why: String,
    },
    /// A load, a stiffness or a residual is not a finite number (NaN or infinite): a
    /// divergence with its cause named, never a converged step.
    #[error("FEM solve stopped at {:.1}% of the load: {why}", 100.0 * load_fraction)]
    NotFinite {
        /// Load fraction reached.
        load_fraction: f64,
        /// What is not finite, at which load, and what to check.
        why: String,
    },
}

impl FemError {
    /// The user's input is at fault (a parameter out of range, a model that cannot be
    /// built): a one-line message and exit 2, rather than a failed run.
    pub fn is_bad_input(&self) -> bool {
        matches!(self, FemError::Parameter { .. } | FemError::Model { .. })
    }
}
