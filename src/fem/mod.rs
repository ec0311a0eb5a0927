//! Finite-element model of the PneuNets actuator.
//!
//! Written here rather than taken from a crate: no Rust FEM library offers a nearly
//! incompressible finite-strain solid with follower pressure loads; the linear algebra
//! is faer's (sparse LDLᵀ), the small matrices nalgebra's.
//!
//! Data flows: [`material`] (Yeoh silicone, isochoric/volumetric split, stress and
//! tangent) -> [`hex`] (Q1/P0 mean-dilatation hexahedron) and [`pressure`] (cavity
//! faces, follower pressure as −p V) and [`membrane`] (4-node membranes for thin stiff
//! sheets, [`layer`]) and [`contact`] (frictionless node-to-surface
//! penalty contact between the facing chamber walls, optional) -> [`solve`] (Newton on
//! the three-field form, adaptive load steps) -> [`actuator`] (the parametric PneuNets geometry and its half
//! mesh) -> [`simulate`] (the pressure ramp and the quantities read off each step),
//! [`vtu`] (ParaView files), [`output`] (every result file of a run or a sweep) and
//! [`inp`] (the model as an Abaqus/CalculiX deck).
//!
//! Verified (tests): Yeoh uniaxial and equibiaxial stress against method.md §5; stress,
//! tangent, pressure force and load stiffness against finite differences; the uniaxial
//! block exactly; the plane-strain thick cylinder against the analytic inflation
//! pressure; Cook's membrane against its reference tip displacement; the membrane
//! element's patch test and the composite beam with a sheet or strip; the contact
//! tangent against finite differences and the pressed-blocks patch test; the exported
//! deck ([`inp`]) run by CalculiX against bendscope's markers (tests/simulate.rs).

pub mod actuator;
pub mod analytic;
pub mod contact;
pub mod hex;
pub mod inp;
pub mod layer;
pub mod material;
pub mod membrane;
pub mod output;
pub mod pressure;
pub mod simulate;
pub mod solve;
pub mod stepper;
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
}
