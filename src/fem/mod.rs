//! Finite-element model of the PneuNets actuator.
//!
//! So far: [`material`], the Yeoh hyperelastic silicone (neo-Hookean as a special case)
//! with an isochoric/volumetric split, its first Piola stress and consistent tangent,
//! verified against the closed-form uniaxial and equibiaxial stresses of method.md §5
//! and by finite differences. Elements, the pressure load, the Newton solver and the
//! actuator geometry build on it.

pub mod actuator;
pub mod hex;
pub mod material;
pub mod pressure;
pub mod simulate;
pub mod solve;
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
    /// Newton did not converge.
    #[error("FEM solve diverged at {:.1}% of the load: {why}", 100.0 * load_fraction)]
    Diverged {
        /// Load fraction reached.
        load_fraction: f64,
        /// What to try.
        why: String,
    },
}
