//! Static equilibrium by total Lagrangian Newton-Raphson with adaptive load stepping.
//!
//! The equilibrium is the stationary point of
//! Π(u) = Σ_e Π_e(u) − λ f_dead · u − p V_cavity(u): internal energy of the elements,
//! dead loads (gravity, point loads) scaled by λ, and the follower pressure as −p V
//! ([`super::pressure`]). Newton iterates on the three-field form of the Q1/P0 element
//! (u, element dilatation θ_e, element pressure p_e; see [`super::hex`]) with θ and p
//! condensed per element: the condensed tangent K_iso + p_e H + U''(θ_e)/V_e G Gᵀ minus
//! the pressure's load stiffness is symmetric (for a closed cavity). The 10-node
//! tetrahedra's corner pressures (Taylor-Hood, [`super::tet10::taylor_hood`]) are
//! unknowns of the system after the displacements, their block −∫ L_i L_j / U'' dV
//! negative definite: the system is a saddle point, quasi-definite near the rest state.
//! faer's sparse LDLᵀ (no pivoting) factorizes it (it may be indefinite away from
//! equilibrium); its symbolic analysis is computed once and reused for every
//! Newton iteration and load step; element and face terms are computed in parallel
//! (rayon). A step that inverts an element is halved (a line search on validity only:
//! the three-field system is a saddle point, not a minimum, so there is no energy to
//! descend; an energy line search on the displacement-only form crawled, ~100
//! iterations per 5 kPa step, against ~6 now); a load increment that does not converge
//! is cut in half and retried. An iteration has converged when the residual is below
//! the largest of the relative tolerance (to the external force), the absolute one, and
//! a multiple of the round-off floor ε ‖ |K| |u| ‖: with a sheet thousands of times
//! stiffer than the silicone the floor is above the absolute tolerance under gravity
//! alone, and Newton, converged to round-off, used to stall there and cut the step
//! until it gave up. `BENDSCOPE_DEBUG_NEWTON=1` prints every iteration's residual and
//! the seconds of its assembly and linear solve to stderr.
//!
//! The rooms: `model` (the model and its load state), `pattern` (the sparsity
//! pattern of the tangent), `assembly` (element, sheet, fibre, face and contact terms
//! into the condensed residual and tangent), `linear` (the sparse LDLᵀ factor, allocated
//! fallibly), `solver` (the incremental solver's state and what it reports) and
//! `newton` (Newton iterations, their convergence test and the adaptive load stepping).

mod assembly;
mod linear;
mod model;
mod newton;
mod pattern;
mod solver;
#[cfg(test)]
pub(crate) mod tests;

pub use model::{Cavity, LoadState, Model, Tetrahedra};
pub use newton::{solve_static, NewtonResult, NewtonSettings, StepReport};
pub use solver::{Solver, SolverState};
