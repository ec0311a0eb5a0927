//! Newton iterations and adaptive load stepping: the settings, the convergence test
//! ([`IterateNorms`]), why an iteration fails ([`NewtonFailure`]), the stepper that cuts
//! a load increment that does not converge, and the secant predictor.

use super::assembly::Assembled;
use super::linear::factor_too_large;
use super::model::{volume_points, LoadState, Model};
use super::solver::{Solver, State};
use crate::fem::hex::{ElementVector, Modes, ENHANCED_DOFS};
use crate::fem::FemError;

/// Newton settings.
#[derive(Debug, Clone, Copy)]
pub struct NewtonSettings {
    /// Relative residual tolerance (to the norm of the external forces).
    pub tolerance: f64,
    /// Absolute residual tolerance, N: tiny loads such as gravity alone cannot be
    /// resolved to a relative 1e-9 (the round-off floor of a stiff model is added on
    /// top, [`Solver`]'s convergence test).
    pub absolute_tolerance: f64,
    /// Iterations per load step before the step is cut.
    pub max_iterations: usize,
    /// First increment, as a fraction of the way to the target load.
    pub initial_step: f64,
    /// Smallest increment (fraction) before giving up.
    pub min_step: f64,
}

impl NewtonSettings {
    /// Checks the settings: tolerances finite and non-negative, steps in (0, 1] (a NaN
    /// smallest step would never end the step cutting).
    pub fn check(&self) -> Result<(), FemError> {
        let bad = |name: &str, v: f64, range: &str| FemError::Parameter {
            name: name.into(),
            why: format!("{v}: must be {range}"),
        };
        for (name, v) in [
            ("tolerance", self.tolerance),
            ("absolute_tolerance", self.absolute_tolerance),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(name, v, "a finite number >= 0"));
            }
        }
        for (name, v) in [
            ("initial_step", self.initial_step),
            ("min_step", self.min_step),
        ] {
            if !(v > 0.0 && v <= 1.0) {
                return Err(bad(name, v, "in (0, 1]"));
            }
        }
        Ok(())
    }
}

impl Default for NewtonSettings {
    fn default() -> Self {
        Self {
            tolerance: 1e-9,
            absolute_tolerance: 1e-10,
            max_iterations: 25,
            initial_step: 0.25,
            min_step: 1e-4,
        }
    }
}

/// The converged solution of [`solve_static`].
#[derive(Debug, Clone)]
pub struct NewtonResult {
    /// Nodal displacements, mm (3 per node).
    pub displacement: Vec<f64>,
    /// Load steps taken.
    pub steps: usize,
    /// Newton iterations in all.
    pub iterations: usize,
    /// Degrees of freedom solved for.
    pub free_dofs: usize,
}

/// What one [`Solver::advance`] took.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepReport {
    /// Converged sub-steps.
    pub substeps: usize,
    /// Newton iterations in all (converged sub-steps only).
    pub iterations: usize,
}

/// One element's Newton update: (Δθ, Δp) of each of its volume points, and the modes'
/// Δa for the element with them.
type ElementUpdate = (Vec<(f64, f64)>, Option<Modes>);

impl<'m> Solver<'m> {
    /// Moves the load from the current state to `target` in adaptive sub-steps, each
    /// solved by Newton; on failure the state is left at the last converged sub-step.
    pub fn advance(
        &mut self,
        target: LoadState,
        s: &NewtonSettings,
    ) -> Result<StepReport, FemError> {
        s.check()?;
        if !(target.dead.is_finite() && target.pressure_mpa.is_finite()) {
            return Err(FemError::NotFinite {
                load_fraction: 0.0,
                why: load_not_finite(target),
            });
        }
        let start = self.load;
        let (mut t, mut step) = (0.0f64, s.initial_step.clamp(s.min_step, 1.0));
        let mut report = StepReport {
            substeps: 0,
            iterations: 0,
        };
        while t < 1.0 {
            let next = (t + step).min(1.0);
            let saved = self.current();
            let saved_couplings = self.extra_couplings.clone();
            let load = start.lerp(&target, next);
            let guess = self.predict(load);
            let outcome = self.newton(load, s, guess);
            if let Err(NewtonFailure::LoadNotFinite) = outcome {
                // Named at the target: a fraction of it overflowing, so does the whole.
                return Err(FemError::NotFinite {
                    load_fraction: t,
                    why: load_not_finite(target),
                });
            }
            if let Err(NewtonFailure::OutOfMemory(bytes)) = outcome {
                return Err(FemError::Model {
                    why: factor_too_large(bytes),
                });
            }
            match outcome {
                Ok(it) => {
                    report.iterations += it;
                    report.substeps += 1;
                    self.previous = Some((saved, self.load));
                    t = next;
                    self.load = start.lerp(&target, t);
                    if it <= 6 {
                        step = (step * 2.0).min(1.0);
                    }
                }
                Err(failure) => {
                    // What was not finite in this failed increment, if anything.
                    let not_finite = match failure {
                        NewtonFailure::NotFinite(what) => Some((what, load)),
                        _ => None,
                    };
                    (self.u, self.theta, self.pressure, self.modes) = saved;
                    if self.extra_couplings != saved_couplings {
                        // Contact met by the iterates of a failed increment (e.g. the
                        // wild first iterates under gravity) would only densify the
                        // matrix from now on.
                        self.extra_couplings = saved_couplings;
                        self.pattern = self.new_pattern()?;
                        self.symbolic = None;
                        self.scratch = None;
                    }
                    step *= 0.5;
                    if step < s.min_step {
                        if let Some((what, at)) = not_finite {
                            return Err(FemError::NotFinite {
                                load_fraction: t,
                                why: format!(
                                    "{what} became NaN or infinite at {} (even with the smallest load increment): a material, layer or load far outside the physical range; check the config's values",
                                    load_text(at)
                                ),
                            });
                        }
                        return Err(FemError::Diverged {
                            load_fraction: t,
                            why: "Newton failed even with the smallest load increment: refine the mesh, lower the pressure or check the supports".into(),
                        });
                    }
                }
            }
        }
        Ok(report)
    }

    /// The secant predictor: the state extrapolated linearly from the last two converged
    /// states to `load` (by the change of pressure, or of the dead-load factor when the
    /// pressure is constant). `None` without a previous state or along another load path.
    /// A step of a smooth ramp then starts close to its solution (one or two Newton
    /// iterations fewer than from the last state).
    fn predict(&self, load: LoadState) -> Option<State> {
        let ((u0, th0, p0, m0), l0) = self.previous.as_ref()?;
        let l1 = self.load;
        let dp = l1.pressure_mpa - l0.pressure_mpa;
        let dd = l1.dead - l0.dead;
        let s = if dp.abs() > 0.0 {
            // Only along a ramp of the pressure with the dead load fixed.
            if (load.dead - l1.dead).abs() > 0.0 || dd.abs() > 0.0 {
                return None;
            }
            (load.pressure_mpa - l1.pressure_mpa) / dp
        } else if dd.abs() > 0.0 {
            if (load.pressure_mpa - l1.pressure_mpa).abs() > 0.0 {
                return None;
            }
            (load.dead - l1.dead) / dd
        } else {
            return None;
        };
        if !(s > 0.0 && s <= MAX_EXTRAPOLATION) {
            return None;
        }
        let ex = |now: &[f64], before: &[f64]| -> Vec<f64> {
            now.iter()
                .zip(before)
                .map(|(a, b)| a + s * (a - b))
                .collect()
        };
        let modes = self
            .modes
            .iter()
            .zip(m0)
            .map(|(a, b)| std::array::from_fn(|i| a[i] + s * (a[i] - b[i])))
            .collect();
        Some((
            ex(&self.u, u0),
            ex(&self.theta, th0),
            ex(&self.pressure, p0),
            modes,
        ))
    }

    /// The current state of the iteration.
    fn current(&self) -> State {
        (
            self.u.clone(),
            self.theta.clone(),
            self.pressure.clone(),
            self.modes.clone(),
        )
    }

    /// Newton iterations at `load` from the current state; the number of linear solves
    /// when converged (the state is then updated). A load, residual or stiffness that
    /// is not finite fails ([`NewtonFailure`]), never passes the convergence test.
    fn newton(
        &mut self,
        load: LoadState,
        s: &NewtonSettings,
        guess: Option<State>,
    ) -> Result<usize, NewtonFailure> {
        let debug = std::env::var_os("BENDSCOPE_DEBUG_NEWTON").is_some();
        // From the predicted state when it is valid (no inverted element), else from the
        // last state.
        let from_last = || -> Option<(State, Assembled)> {
            let st = self.current();
            let a = self.assemble(&st.0, &st.1, &st.2, &st.3, load)?;
            Some((st, a))
        };
        let predicted = guess.and_then(|st| {
            let a = self.assemble(&st.0, &st.1, &st.2, &st.3, load)?;
            Some((st, a))
        });
        let ((mut u, mut theta, mut pressure, mut modes), mut cur) = match predicted {
            Some(p) => p,
            None => from_last().ok_or(NewtonFailure::Cut)?,
        };
        if !cur.external_norm.is_finite() {
            return Err(NewtonFailure::LoadNotFinite);
        }
        let first_norm = cur.equilibrium_norm.max(s.absolute_tolerance);
        for it in 0..=s.max_iterations {
            let norms = IterateNorms {
                equilibrium: cur.equilibrium_norm,
                external: cur.external_norm,
                roundoff: cur.roundoff_norm,
                volume_error: cur.volume_error,
                residual_finite: cur.residual.iter().all(|r| r.is_finite()),
            };
            if debug {
                eprintln!(
                    "newton {it}: |R_u| {:.3e} (tol {:.1e}, round-off floor {:.1e}) volume error {:.2e}",
                    cur.equilibrium_norm,
                    norms.tolerance(s),
                    cur.roundoff_norm,
                    cur.volume_error
                );
            }
            if norms.converged(s).map_err(NewtonFailure::NotFinite)? {
                self.u = u;
                self.theta = theta;
                self.pressure = pressure;
                self.modes = modes;
                return Ok(it);
            }
            if it == s.max_iterations || cur.equilibrium_norm > DIVERGENCE_FACTOR * first_norm {
                return Err(NewtonFailure::Cut);
            }
            if !cur.missing.is_empty() {
                // New contact couplings: extend the pattern (a new symbolic factorization)
                // and assemble the same state into it.
                self.extra_couplings.append(&mut cur.missing);
                self.extra_couplings.sort_unstable();
                self.extra_couplings.dedup();
                if debug {
                    eprintln!(
                        "newton {it}: contact beyond the pattern: {} extra node pairs",
                        self.extra_couplings.len()
                    );
                }
                self.pattern = self.new_pattern().map_err(|_| NewtonFailure::Cut)?;
                self.symbolic = None;
                self.scratch = None;
                cur = self
                    .assemble(&u, &theta, &pressure, &modes, load)
                    .ok_or(NewtonFailure::Cut)?;
            }
            let t0 = std::time::Instant::now();
            let solved = self.factor_and_solve(&cur.values, &cur.residual)?;
            if debug {
                eprintln!(
                    "newton {it}: factor and solve {:.3} s",
                    t0.elapsed().as_secs_f64()
                );
            }
            let Some(du) = solved else {
                if debug {
                    eprintln!("newton {it}: singular tangent: cutting the step");
                }
                return Err(NewtonFailure::Cut);
            };

            let mut du_full = vec![0.0; u.len()];
            for (d, e) in self.eq.iter().enumerate() {
                if let Some(i) = e {
                    du_full[d] = du[*i];
                }
            }
            // Element updates from the condensation: the modes'
            // Δa = −K_aa⁻¹ (r_a + K_au Δu), then Δθ = (Gᵀ Δu + R_p) / V (G over the nodes
            // and the modes, per Gauss point with the modes), Δp = U'' Δθ + R_θ / V.
            let points = volume_points(self.model);
            let updates: Vec<ElementUpdate> = self
                .model
                .elements
                .iter()
                .zip(&cur.condensed)
                .zip(&self.geom)
                .map(|((el, c), g)| {
                    let due = ElementVector::from_fn(|a, _| du_full[3 * el[a / 3] + a % 3]);
                    match &c.modes {
                        None => {
                            // Q1/P0, or an element at rest (every node fixed: G = 0, no
                            // residual, so no update at any of its points).
                            let dth = (c.g.dot(&due) + c.r_volume) / g.volume;
                            let dp = c.ddu * dth + c.r_pressure / g.volume;
                            (vec![(dth, dp); points], None)
                        }
                        Some(m) => {
                            let da = -(m.kaa_inv * (m.ra + m.kau * due));
                            let dx = nalgebra::SVector::<f64, ENHANCED_DOFS>::from_fn(|a, _| {
                                if a < 24 {
                                    due[a]
                                } else {
                                    da[a - 24]
                                }
                            });
                            let pts = (0..8)
                                .map(|q| {
                                    let (r_volume, r_pressure, ddu) = m.points[q];
                                    let vq = g.weights[q];
                                    let dth = (m.g_points[q].dot(&dx) + r_volume) / vq;
                                    (dth, ddu * dth + r_pressure / vq)
                                })
                                .collect();
                            (pts, Some(std::array::from_fn(|i| da[i])))
                        }
                    }
                })
                .collect();
            // The tetrahedra's corner pressures are unknowns of the system (after the
            // displacements), as are the pressures of the hexahedra's state before them.
            let hex_states = points * self.model.elements.len();
            let dp_corners = &du[self.n_eq..];
            // Full step unless it inverts an element; then halve.
            let mut alpha = 1.0;
            let mut accepted = None;
            for _ in 0..12 {
                let tu: Vec<f64> = u.iter().zip(&du_full).map(|(a, b)| a + alpha * b).collect();
                let tt: Vec<f64> = theta
                    .chunks(points)
                    .zip(&updates)
                    .flat_map(|(a, b)| a.iter().zip(&b.0).map(|(x, d)| x + alpha * d.0))
                    .collect();
                let tp: Vec<f64> = pressure[..hex_states]
                    .chunks(points)
                    .zip(&updates)
                    .flat_map(|(a, b)| a.iter().zip(&b.0).map(|(x, d)| x + alpha * d.1))
                    .chain(
                        pressure[hex_states..]
                            .iter()
                            .zip(dp_corners)
                            .map(|(x, d)| x + alpha * d),
                    )
                    .collect();
                let tm: Vec<Modes> = modes
                    .iter()
                    .zip(&updates)
                    .map(|(a, b)| match &b.1 {
                        Some(d) => std::array::from_fn(|i| a[i] + alpha * d[i]),
                        None => *a,
                    })
                    .collect();
                let t0 = std::time::Instant::now();
                let assembled = self.assemble(&tu, &tt, &tp, &tm, load);
                if debug {
                    eprintln!("newton {it}: assembly {:.3} s", t0.elapsed().as_secs_f64());
                }
                if let Some(next) = assembled {
                    accepted = Some((tu, tt, tp, tm, next));
                    break;
                }
                alpha *= 0.5;
            }
            let Some((tu, tt, tp, tm, next)) = accepted else {
                if debug {
                    eprintln!("newton {it}: every step length inverts an element");
                }
                return Err(NewtonFailure::Cut);
            };
            u = tu;
            theta = tt;
            pressure = tp;
            modes = tm;
            cur = next;
        }
        Err(NewtonFailure::Cut)
    }
}

/// Why a Newton solve at one load failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum NewtonFailure {
    /// Not converged (iterations used up, a growing residual, a singular tangent, every
    /// step inverting an element): a smaller load increment may converge.
    Cut,
    /// The external load is not finite (its norm overflows): no increment converges.
    LoadNotFinite,
    /// The named quantity of an iterate is NaN or infinite.
    NotFinite(&'static str),
    /// The sparse factor (bytes) cannot be allocated: no increment fits either.
    OutOfMemory(usize),
}

/// The norms of one Newton iterate that its convergence test reads.
#[derive(Debug, Clone, Copy)]
struct IterateNorms {
    /// |R_u| with the modes' residual.
    equilibrium: f64,
    /// |f_ext|.
    external: f64,
    /// The round-off floor ε ‖ |K| |u| ‖ (not finite when the tangent is not).
    roundoff: f64,
    /// Largest |v / V − θ|.
    volume_error: f64,
    /// Every entry of the condensed residual is finite.
    residual_finite: bool,
}

impl IterateNorms {
    /// The residual tolerance: the largest of the relative one (to the external force),
    /// the absolute one and a multiple of the round-off floor, the last never more than
    /// [`ROUNDOFF_CAP`] of the external force: one degenerate (very thin) element can
    /// inflate the floor past the whole load, which then passed unbalanced.
    fn tolerance(&self, s: &NewtonSettings) -> f64 {
        (s.tolerance * self.external)
            .max(s.absolute_tolerance)
            .max((ROUNDOFF_FACTOR * self.roundoff).min(ROUNDOFF_CAP * self.external))
    }

    /// Whether the iterate has converged; `Err` naming what is NaN or infinite. Every
    /// quantity is checked before it is compared: `NaN <= tol` is false but
    /// `inf <= inf` is true, and `f64::max` drops a NaN, so an overflowed load or
    /// stiffness once made any residual pass.
    fn converged(&self, s: &NewtonSettings) -> Result<bool, &'static str> {
        if !self.external.is_finite() {
            return Err("the external load");
        }
        if !(self.equilibrium.is_finite() && self.residual_finite) {
            return Err("the residual");
        }
        if !self.roundoff.is_finite() {
            return Err("the stiffness");
        }
        if !self.volume_error.is_finite() {
            return Err("the volume error");
        }
        Ok(self.equilibrium <= self.tolerance(s) && self.volume_error <= VOLUME_TOLERANCE)
    }
}

/// A load state in words: `1e200 kPa`, with the dead load (gravity) when on.
fn load_text(load: LoadState) -> String {
    let kpa = 1e3 * load.pressure_mpa;
    let p = if kpa.is_finite() && kpa.abs() < 1e6 {
        format!("{kpa} kPa")
    } else {
        format!("{kpa:e} kPa")
    };
    if load.dead == 0.0 {
        p
    } else if load.dead == 1.0 {
        format!("{p} with gravity")
    } else {
        format!("{p} with {} of gravity", load.dead)
    }
}

/// The message of a load that is not finite.
fn load_not_finite(load: LoadState) -> String {
    format!(
        "the load is not finite at {}: a pressure or a density far beyond any actuator's overflows the arithmetic; check the pressures and density_g_cm3",
        load_text(load)
    )
}

/// Largest ratio of the next load increment to the last one that the secant predictor
/// extrapolates over.
const MAX_EXTRAPOLATION: f64 = 2.0;

/// The residual tolerance is at least this many times the round-off floor
/// ε ‖ |K| |u| ‖ ([`Solver::roundoff_norm`]): the floor bounds the error of rounding u
/// only, the evaluation of the element forces adds its own (measured under gravity on
/// the reference actuator with a 0.1 mm, 3 GPa membrane layer: the last residual is
/// 3.7e-11 N against a floor of 8.7e-11 N: 16 x keeps the test ~40 x above what
/// Newton reaches there).
const ROUNDOFF_FACTOR: f64 = 16.0;

/// The round-off part of the tolerance is at most this fraction of |f_ext|: a residual
/// that large is an unbalanced load, not round-off (a Newton iteration that cannot get
/// below it is cut, then reported as not converged, never passed).
const ROUNDOFF_CAP: f64 = 1e-3;

/// Largest |v_e / V_e − θ_e| of a converged state.
const VOLUME_TOLERANCE: f64 = 1e-10;
/// A Newton iteration whose residual grows beyond this factor of the first is abandoned
/// (the load increment is then cut).
const DIVERGENCE_FACTOR: f64 = 1e8;

/// Solves for static equilibrium under the full dead load (no pressure).
pub fn solve_static(model: &Model, settings: &NewtonSettings) -> Result<NewtonResult, FemError> {
    let mut solver = Solver::new(model)?;
    let report = solver.advance(
        LoadState {
            dead: 1.0,
            pressure_mpa: 0.0,
        },
        settings,
    )?;
    Ok(NewtonResult {
        free_dofs: solver.free_dofs(),
        displacement: solver.u,
        steps: report.substeps,
        iterations: report.iterations,
    })
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;
    use crate::fem::material::Yeoh;
    use crate::fem::solve::assembly::max_or_nan;

    /// One unit cube clamped at x = 0 with a dead load `f` (N) along x on the nodes at
    /// x = 1.
    fn pulled_cube(f: f64, material: Yeoh) -> Model {
        let nodes: Vec<Vector3<f64>> = (0..8)
            .map(|n| Vector3::new((n & 1) as f64, ((n >> 1) & 1) as f64, (n >> 2) as f64))
            .collect();
        let id = |i: usize, j: usize, k: usize| i + 2 * j + 4 * k;
        let mut fixed = vec![false; 24];
        let mut loads = vec![0.0; 24];
        for (a, x) in nodes.iter().enumerate() {
            if x.x == 0.0 {
                fixed[3 * a..3 * a + 3].fill(true);
            } else {
                loads[3 * a] = f / 4.0;
            }
        }
        Model::solid(
            nodes,
            vec![super::super::tests::cell(id, 0, 0, 0)],
            material,
            fixed,
            loads,
        )
    }

    /// A NaN or an infinity in the norms never passes the convergence test: before the
    /// check an overflowed load made the tolerance infinite and `inf <= inf` passed.
    #[test]
    fn the_convergence_test_fails_on_nan_and_inf() {
        let s = NewtonSettings::default();
        let ok = IterateNorms {
            equilibrium: 1e-12,
            external: 1.0,
            roundoff: 1e-14,
            volume_error: 0.0,
            residual_finite: true,
        };
        assert_eq!(ok.converged(&s), Ok(true));
        // A round-off floor inflated past the load (one sliver element ~1e6 times
        // stiffer than the rest) does not pass a residual of a twentieth of the load.
        assert_eq!(
            IterateNorms {
                equilibrium: 1.6,
                external: 30.0,
                roundoff: 7.7,
                ..ok
            }
            .converged(&s),
            Ok(false)
        );
        assert_eq!(
            IterateNorms {
                equilibrium: 1e-3,
                ..ok
            }
            .converged(&s),
            Ok(false)
        );
        let cases: [(IterateNorms, &str); 9] = [
            (
                IterateNorms {
                    external: f64::INFINITY,
                    equilibrium: f64::INFINITY,
                    ..ok
                },
                "the external load",
            ),
            (
                IterateNorms {
                    external: f64::NAN,
                    ..ok
                },
                "the external load",
            ),
            (
                IterateNorms {
                    equilibrium: f64::NAN,
                    ..ok
                },
                "the residual",
            ),
            (
                IterateNorms {
                    equilibrium: f64::INFINITY,
                    ..ok
                },
                "the residual",
            ),
            (
                IterateNorms {
                    residual_finite: false,
                    ..ok
                },
                "the residual",
            ),
            (
                IterateNorms {
                    roundoff: f64::INFINITY,
                    ..ok
                },
                "the stiffness",
            ),
            (
                IterateNorms {
                    roundoff: f64::NAN,
                    ..ok
                },
                "the stiffness",
            ),
            (
                IterateNorms {
                    volume_error: f64::NAN,
                    ..ok
                },
                "the volume error",
            ),
            (
                IterateNorms {
                    volume_error: f64::INFINITY,
                    ..ok
                },
                "the volume error",
            ),
        ];
        for (norms, what) in cases {
            assert_eq!(norms.converged(&s), Err(what), "{norms:?}");
        }
        assert!(max_or_nan(0.0, f64::NAN).is_nan() && max_or_nan(f64::NAN, 1.0).is_nan());
        assert_eq!(max_or_nan(1.0, 2.0), 2.0);
    }

    /// A load whose norm overflows (1e200 N) or that is NaN or infinite is an error that
    /// says the load is not finite, never a converged solve (it was one, in 0 iterations,
    /// at the rest shape); a finite load on the same cube converges.
    #[test]
    fn a_load_that_is_not_finite_is_an_error_never_convergence() {
        let material = crate::fem::material::MaterialPreset::Proposed.yeoh();
        let settings = NewtonSettings::default();
        let r = solve_static(&pulled_cube(0.01, material), &settings).unwrap();
        assert!(r.displacement[3] > 1e-3 && r.displacement[3] < 0.5, "{r:?}");
        for f in [1e200, 1e300, f64::MAX, f64::INFINITY, f64::NAN, -1e200] {
            match solve_static(&pulled_cube(f, material), &settings) {
                Err(FemError::NotFinite { why, .. }) => {
                    assert!(
                        why.starts_with("the load is not finite at 0 kPa"),
                        "{f}: {why}"
                    )
                }
                other => panic!("{f}: {other:?}"),
            }
        }
        // A pressure that is not finite is refused before any iteration.
        let model = pulled_cube(0.0, material);
        let mut solver = Solver::new(&model).unwrap();
        for p in [f64::NAN, f64::INFINITY] {
            let e = solver
                .advance(
                    LoadState {
                        dead: 1.0,
                        pressure_mpa: p,
                    },
                    &settings,
                )
                .unwrap_err();
            assert!(e.to_string().contains("the load is not finite at"), "{e}");
        }
        // A material whose stiffness is NaN diverges (an error), it does not converge.
        let nan = Yeoh {
            c1: f64::NAN,
            ..material
        };
        assert!(solve_static(&pulled_cube(0.01, nan), &settings).is_err());
        // Settings that would never end the step cutting are refused.
        let never = NewtonSettings {
            min_step: f64::NAN,
            ..settings
        };
        assert!(matches!(
            solve_static(&pulled_cube(0.01, material), &never),
            Err(FemError::Parameter { .. })
        ));
    }
}
