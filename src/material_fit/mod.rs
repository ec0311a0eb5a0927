//! Hyperelastic models fitted to uniaxial tensile data (`bendscope material fit`): the
//! models and their Drucker stability ([`model`]), the data and the least-squares fit
//! ([`fit`]), and the outputs, among them a `[material]` block that `simulate --config`
//! reads ([`output`]).
//!
//! The finite-element material is Yeoh (neo-Hookean is Yeoh with C2 = C3 = 0); a
//! Mooney-Rivlin fit is reported but gives no block (the FEM element has no Mooney-Rivlin
//! material), and a Yeoh fit with a negative C2 or C3 gives none either (the FEM refuses
//! them): `--nonnegative` fits with every coefficient held at zero or above.

pub mod fit;
pub mod model;
pub mod output;

pub use fit::{fit_material, MaterialFit, TensileData};
pub use model::{Hyperelastic, ModelKind};
pub use output::{material_block, write_material_fit, MaterialBlock, MaterialFitReport};

/// Errors of the material fit.
#[derive(Debug, thiserror::Error)]
pub enum MaterialFitError {
    /// The data file cannot be read, lacks a column or has a bad cell.
    #[error(transparent)]
    Table(#[from] crate::table::TableError),
    /// The data cannot be fitted.
    #[error("material fit: {why}")]
    Fit {
        /// What is wrong and what to do.
        why: String,
    },
    /// A result file could not be written.
    #[error(
        "cannot write the material fit: {why}: check the output folder's space and permissions"
    )]
    Output {
        /// What failed.
        why: String,
    },
}
