//! Finite-element model of the PneuNets actuator.
//!
//! So far: [`material`], the Yeoh hyperelastic silicone (neo-Hookean as a special case)
//! with an isochoric/volumetric split, its first Piola stress and consistent tangent,
//! verified against the closed-form uniaxial and equibiaxial stresses of method.md §5
//! and by finite differences. Elements, the pressure load, the Newton solver and the
//! actuator geometry build on it.

pub mod hex;
pub mod material;
