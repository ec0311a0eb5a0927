//! One evaluation of the model: the actuator with given parameter values simulated at
//! the measured pressures, warm-started from the previous evaluation.
//!
//! Warm start: a least-squares fit evaluates nearby parameter values over and over (the
//! finite-difference Jacobian moves one parameter by 1e-4), so the converged state of the
//! previous evaluation at each pressure is a far better Newton start than the ramp from
//! the previous pressure. Each pressure first tries one Newton solve from that state (a
//! few iterations); when it fails (a large step of the fit), the step is taken the usual
//! way from this evaluation's previous pressure, with adaptive load increments. Possible
//! when the mesh has the same node and element counts (a geometric parameter may change
//! them: the state of another mesh is never used).

use crate::fem::actuator::{build_mesh, ActuatorConfig};
use crate::fem::solve::{LoadState, NewtonSettings, Solver, SolverState};
use crate::fem::FemError;
use crate::fit::fit_circle_pratt;

use super::FitModelError;

/// Newton iterations a warm-started pressure step may take before it is redone from the
/// previous pressure.
pub const WARM_MAX_ITERATIONS: usize = 12;

/// The simulated curve at the measured pressures.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelCurve {
    /// Pressures, kPa.
    pub pressure_kpa: Vec<f64>,
    /// Pratt radius through the markers, mm.
    pub radius_mm: Vec<f64>,
    /// Curvature, 1/m.
    pub curvature_per_m: Vec<f64>,
}

/// Counters of the evaluations.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct EvaluationStats {
    /// Simulations run.
    pub evaluations: usize,
    /// Simulations that failed (invalid parameters or no convergence).
    pub failed: usize,
    /// Pressure steps solved from the previous evaluation's state.
    pub warm_steps: usize,
    /// Pressure steps solved from the previous pressure.
    pub cold_steps: usize,
    /// Newton iterations in all.
    pub newton_iterations: usize,
    /// Times the mesh's node or element count changed between evaluations.
    pub mesh_changes: usize,
}

/// Runs the simulations of a fit and keeps the warm-start states.
pub struct Evaluator {
    pressures_kpa: Vec<f64>,
    warm: Option<(usize, usize, Vec<SolverState>)>,
    /// Counters.
    pub stats: EvaluationStats,
}

impl Evaluator {
    /// An evaluator at these pressures (kPa, increasing).
    pub fn new(pressures_kpa: Vec<f64>) -> Self {
        Self {
            pressures_kpa,
            warm: None,
            stats: EvaluationStats::default(),
        }
    }

    /// Simulates `cfg` at the pressures (its own pressure list is ignored).
    pub fn simulate(&mut self, cfg: &ActuatorConfig) -> Result<ModelCurve, FitModelError> {
        self.stats.evaluations += 1;
        let result = self.run(cfg);
        if result.is_err() {
            self.stats.failed += 1;
        }
        result
    }

    fn run(&mut self, cfg: &ActuatorConfig) -> Result<ModelCurve, FitModelError> {
        let mesh = build_mesh(cfg)?;
        let model = &mesh.model;
        let shape = (
            model.nodes.len(),
            model.elements.len() + model.tets.elements.len(),
        );
        let warm = match self.warm.take() {
            Some((n, e, states)) if (n, e) == shape => Some(states),
            Some(_) => {
                self.stats.mesh_changes += 1;
                None
            }
            None => None,
        };
        let mut solver = Solver::new(model)?;
        let newton = cfg.solver.newton();
        let mut loaded = false;
        let mut states = Vec::with_capacity(self.pressures_kpa.len());
        let mut curve = ModelCurve {
            pressure_kpa: Vec::new(),
            radius_mm: Vec::new(),
            curvature_per_m: Vec::new(),
        };
        for (k, p) in self.pressures_kpa.iter().enumerate() {
            let target = LoadState {
                dead: 1.0,
                pressure_mpa: p * 1e-3,
            };
            let mut done = false;
            if let Some(state) = warm.as_ref().and_then(|w| w.get(k)) {
                let before = solver.state();
                solver.set_state(state)?;
                let one_solve = NewtonSettings {
                    initial_step: 1.0,
                    min_step: 1.0,
                    max_iterations: WARM_MAX_ITERATIONS,
                    ..newton
                };
                match solver.advance(target, &one_solve) {
                    Ok(r) => {
                        self.stats.warm_steps += 1;
                        self.stats.newton_iterations += r.iterations;
                        done = true;
                    }
                    Err(_) => solver.set_state(&before)?,
                }
            }
            if !done {
                if !loaded {
                    // Gravity first, as simulate does.
                    let first = NewtonSettings {
                        initial_step: 0.25,
                        ..newton
                    };
                    let r = solver.advance(
                        LoadState {
                            dead: 1.0,
                            pressure_mpa: 0.0,
                        },
                        &first,
                    )?;
                    self.stats.newton_iterations += r.iterations;
                }
                let step = NewtonSettings {
                    initial_step: 1.0,
                    ..newton
                };
                let r = solver.advance(target, &step)?;
                self.stats.cold_steps += 1;
                self.stats.newton_iterations += r.iterations;
            }
            loaded = true;
            states.push(solver.state());
            let markers = crate::fem::simulate::marker_points(&mesh, &solver);
            let circle = fit_circle_pratt(&markers).map_err(|e| {
                FitModelError::Fem(FemError::Model {
                    why: format!("marker circle at {p} kPa: {e}"),
                })
            })?;
            curve.pressure_kpa.push(*p);
            curve.radius_mm.push(circle.radius);
            curve.curvature_per_m.push(1000.0 * circle.curvature);
        }
        self.warm = Some((shape.0, shape.1, states));
        Ok(curve)
    }
}
