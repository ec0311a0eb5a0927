//! Fits on marker centroids: circles (Pratt, Kasa, geometric), bending angle, and the
//! power law y = a x^b + c of a quantity against pressure.
//!
//! The Pratt fit is the measurement (method.md §2.6): algebraic, no iteration over the
//! points, nearly as accurate as the geometric fit for arcs, and it needs no fixed
//! reference point. Its curvature is computed from the algebraic parameters so that it
//! goes smoothly to 0 when the markers become collinear (nearly straight actuator),
//! where the radius itself blows up.
//!
//! One module per fit, each re-exported here: `circle` (Pratt, Kasa and geometric circles,
//! and circles through 3D points), `angle` (bending angles), `plane` (a robust plane
//! through 3D points), `power_law` (y = a x^b + c), `student` (Student's t quantiles for
//! confidence intervals); `error` holds [`FitError`], which they share.

mod angle;
mod circle;
mod error;
mod plane;
mod power_law;
mod student;

pub use angle::{
    bending_angle_along_markers_deg, bending_angle_deg, bending_angle_from_circle_deg,
};
pub use circle::{
    fit_circle_3d, fit_circle_geometric, fit_circle_kasa, fit_circle_pratt, CircleFit, CircleFit3,
    PRATT_EPS, PRATT_MAX_ITER,
};
pub use error::FitError;
pub use plane::{fit_plane_robust, PlaneFit, PLANE_RANSAC_ITERATIONS};
pub use power_law::{
    distinct_values, fit_power_law, fit_power_law_with_covariance, PowerLawErrors, PowerLawFit,
    DISTINCT_X_REL, POWER_LAW_MIN_DISTINCT_X,
};
pub use student::{t_cdf, t_two_sided};
