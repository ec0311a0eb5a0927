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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::actuator::{build_mesh, ActuatorConfig, LoadConfig, MeshConfig};

    /// A pressure that is not finite, or whose load overflows, is an error saying so,
    /// never a converged state at the rest shape (1e200 kPa was one, in 0 iterations);
    /// the stepper stays at its last equilibrium and goes on from it.
    #[test]
    fn a_pressure_that_is_not_finite_is_an_error_and_the_stepper_stays() {
        let mesh = build_mesh(&ActuatorConfig {
            mesh: MeshConfig {
                size_mm: 4.0,
                ..Default::default()
            },
            load: LoadConfig {
                gravity: false,
                ..Default::default()
            },
            ..Default::default()
        })
        .unwrap();
        let mut stepper = QuasiStaticStepper::new(&mesh, NewtonSettings::default()).unwrap();
        let at10 = stepper.solve_at(10.0).unwrap();
        assert!(at10.bending_angle_deg > 0.0, "{at10:?}");
        for p in [f64::NAN, f64::INFINITY, 1e200, 1e300] {
            match stepper.solve_at(p) {
                Err(FemError::NotFinite { why, .. }) => {
                    assert!(why.starts_with("the load is not finite at"), "{p}: {why}")
                }
                other => panic!("{p} kPa: {other:?}"),
            }
        }
        let at20 = stepper.solve_at(20.0).unwrap();
        assert!(
            at20.bending_angle_deg > at10.bending_angle_deg && at20.newton_iterations > 0,
            "{at20:?} after {at10:?}"
        );
    }
}
