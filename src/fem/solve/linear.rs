//! The linear solve of each Newton iteration: faer's sparse LDLᵀ of the condensed
//! tangent, its symbolic analysis kept for the whole solve, the factor and its scratch
//! memory allocated fallibly (a mesh too fine for the machine is refused, not aborted).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::sparse::linalg::cholesky::factorize_symbolic_cholesky;
use faer::{Conj, Mat, Par, Side};

use super::newton::NewtonFailure;
use super::solver::Solver;

impl<'m> Solver<'m> {
    /// Solves K x = −r by a sparse LDLᵀ factorization (the tangent may be indefinite away
    /// from equilibrium, e.g. under the pressure's load stiffness at the start of an
    /// increment); the symbolic analysis (fill-reducing ordering, elimination tree) is
    /// computed on the first call and reused.
    ///
    /// `Ok(None)` is a singular or failed factorization (a smaller increment may do);
    /// the factor or its scratch memory not fitting in memory is an error of its own:
    /// allocated fallibly, so a mesh too fine for the machine is refused, not aborted.
    pub(super) fn factor_and_solve(
        &mut self,
        values: &[f64],
        r: &[f64],
    ) -> Result<Option<Vec<f64>>, NewtonFailure> {
        let k = self.pattern.matrix(values);
        if self.symbolic.is_none() {
            let Ok(sym) = factorize_symbolic_cholesky(
                k.symbolic(),
                Side::Lower,
                Default::default(),
                Default::default(),
            ) else {
                return Ok(None);
            };
            let len = sym.len_val();
            let mut factor = Vec::new();
            if factor.try_reserve_exact(len).is_err() {
                return Err(NewtonFailure::OutOfMemory(
                    len.saturating_mul(std::mem::size_of::<f64>()),
                ));
            }
            factor.resize(len, 0.0);
            self.factor = factor;
            self.symbolic = Some(sym);
        }
        let Some(sym) = self.symbolic.as_ref() else {
            return Ok(None);
        };
        // Sequential: faer's parallel supernodal factorization on 2 cores spent more
        // time in thread hand-offs (sched_yield, futex) than it saved. The elements are
        // assembled in parallel.
        let par = Par::Seq;
        if self.scratch.is_none() {
            let req = sym
                .factorize_numeric_ldlt_scratch::<f64>(par, Default::default())
                .or(sym.solve_in_place_scratch::<f64>(1, par));
            match MemBuffer::try_new(req) {
                Ok(buffer) => self.scratch = Some(buffer),
                Err(_) => return Err(NewtonFailure::OutOfMemory(req.unaligned_bytes_required())),
            }
        }
        let Some(scratch) = self.scratch.as_mut() else {
            return Ok(None);
        };
        let stack = MemStack::new(scratch);
        let Ok(ldlt) = sym.factorize_numeric_ldlt(
            &mut self.factor,
            k,
            Side::Lower,
            LdltRegularization::default(),
            par,
            stack,
            Default::default(),
        ) else {
            return Ok(None);
        };
        let mut rhs = Mat::<f64>::from_fn(r.len(), 1, |i, _| -r[i]);
        ldlt.solve_in_place_with_conj(Conj::No, rhs.as_mut(), par, stack);
        let x: Vec<f64> = (0..r.len()).map(|i| rhs[(i, 0)]).collect();
        Ok(x.iter().all(|v| v.is_finite()).then_some(x))
    }
}

/// The message of a sparse factor that does not fit in memory.
pub(super) fn factor_too_large(bytes: usize) -> String {
    format!(
        "the solver's sparse factor needs {:.1} GB and cannot be allocated on this machine (or under its memory limit): use a coarser mesh ([mesh] size_mm or --mesh-size)",
        bytes as f64 / 1e9
    )
}
