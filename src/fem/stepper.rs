//! The actuator solved quasi-statically at one pressure after another, each solve
//! warm-started from the previous equilibrium: the FEM as a plant in a control loop.
//!
//! [`super::simulate::run_ramp`] walks a fixed list of rising pressures; a controller
//! asks for any pressure, up or down, a few kPa from the last. The [`Solver`] keeps its
//! displacement and load between calls, so each request is one (usually one-increment)
//! Newton solve from where the actuator is; the hyperelastic model has no history, so
//! the result does not depend on the path.

use super::actuator::ActuatorMesh;
use super::solve::{LoadState, NewtonSettings, Solver};
use super::FemError;
use crate::fit::{bending_angle_along_markers_deg, fit_circle_pratt};

/// One quasi-static solve of [`QuasiStaticStepper::solve_at`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuasiStaticState {
    /// Pressure, kPa.
    pub pressure_kpa: f64,
    /// Bending angle through the markers, degrees (as `simulate`'s steps.csv).
    pub bending_angle_deg: f64,
    /// Newton iterations this solve took.
    pub newton_iterations: usize,
}

/// The actuator held at a pressure, moved to the next on request.
pub struct QuasiStaticStepper<'m> {
    mesh: &'m ActuatorMesh,
    solver: Solver<'m>,
    newton: NewtonSettings,
    last: Option<QuasiStaticState>,
}

impl<'m> QuasiStaticStepper<'m> {
    /// Loads `mesh` with its dead load (gravity) at zero pressure.
    pub fn new(mesh: &'m ActuatorMesh, newton: NewtonSettings) -> Result<Self, FemError> {
        let mut solver = Solver::new(&mesh.model)?;
        solver.advance(
            LoadState {
                dead: 1.0,
                pressure_mpa: 0.0,
            },
            &NewtonSettings {
                initial_step: 0.25,
                ..newton
            },
        )?;
        Ok(Self {
            mesh,
            solver,
            newton: NewtonSettings {
                initial_step: 1.0,
                ..newton
            },
            last: None,
        })
    }

    /// Solves the actuator at `pressure_kpa` from the current equilibrium. A solve that
    /// does not converge leaves the stepper at the last converged load.
    pub fn solve_at(&mut self, pressure_kpa: f64) -> Result<QuasiStaticState, FemError> {
        if let Some(last) = self.last.filter(|s| s.pressure_kpa == pressure_kpa) {
            return Ok(QuasiStaticState {
                newton_iterations: 0,
                ..last
            });
        }
        let report = self.solver.advance(
            LoadState {
                dead: 1.0,
                pressure_mpa: pressure_kpa * 1e-3,
            },
            &self.newton,
        )?;
        let state = QuasiStaticState {
            pressure_kpa,
            bending_angle_deg: self.bending_angle_deg()?,
            newton_iterations: report.iterations,
        };
        self.last = Some(state);
        Ok(state)
    }

    /// The bending angle of the current state, degrees: the Pratt circle through the
    /// markers and the half-angle convention, as [`super::simulate`] reads a step.
    fn bending_angle_deg(&self) -> Result<f64, FemError> {
        let markers = super::simulate::marker_points(self.mesh, &self.solver);
        let fit_err = |e: crate::fit::FitError| FemError::Model {
            why: format!("marker circle: {e}"),
        };
        let circle = fit_circle_pratt(&markers).map_err(fit_err)?;
        if circle.curvature <= 0.0 {
            return Ok(0.0);
        }
        bending_angle_along_markers_deg(&markers, &circle).map_err(fit_err)
    }
}
