//! One objective: Bayesian optimization (EGO) with egobox-ego on the surrogates.
//!
//! egobox-ego minimizes a function returning `[objective, constraints...]` per point,
//! constraints met when <= 0: here the surrogates' mean of the objective (negated when
//! maximized) and each constraint's margin. It starts from the table's designs (inside
//! the bounds) and adds `iterations` infill points chosen by its own Gaussian-process
//! mixture and the WB2 criterion with constraint handling; every evaluated point is
//! kept, so the next best distinct designs can be re-simulated too.

use ndarray::{Array2, ArrayView2};

use super::{Evaluation, OptimizeError, Problem, MIN_DISTINCT};
use egobox_ego::EgorBuilder;

fn ego_error(e: impl std::fmt::Display) -> OptimizeError {
    OptimizeError::Optimizer {
        which: "Bayesian optimization (egobox-ego)",
        why: e.to_string(),
    }
}

/// Runs the Bayesian optimization from `start` (designs inside the bounds); returns
/// every point it evaluated, best first (feasible by objective, then the others by
/// violation).
pub fn optimize(problem: &Problem, start: &[Vec<f64>]) -> Result<Vec<Evaluation>, OptimizeError> {
    let inputs = &problem.plan.inputs;
    let n_cstr = problem.plan.constraints.len();
    let f = |x: &ArrayView2<f64>| -> Result<Array2<f64>, String> {
        let xs: Vec<Vec<f64>> = x.rows().into_iter().map(|r| r.to_vec()).collect();
        let evals = problem.evaluate(&xs).map_err(|e| e.to_string())?;
        let mut y = Array2::zeros((evals.len(), 1 + n_cstr));
        for (i, e) in evals.iter().enumerate() {
            y[[i, 0]] = problem.cost(e, 0);
            for (j, m) in e.margins.iter().enumerate() {
                y[[i, 1 + j]] = *m;
            }
        }
        Ok(y)
    };
    let xlimits = Array2::from_shape_fn((inputs.len(), 2), |(j, k)| {
        if k == 0 {
            inputs[j].min
        } else {
            inputs[j].max
        }
    });
    let iterations = problem.plan.iterations;
    let seed = problem.plan.seed;
    let doe = (start.len() > inputs.len())
        .then(|| Array2::from_shape_fn((start.len(), inputs.len()), |(i, j)| start[i][j]));
    let result = EgorBuilder::optimize(f)
        .configure(|c| {
            let c = c.n_cstr(n_cstr).max_iters(iterations).seed(seed);
            match &doe {
                Some(d) => c.doe(d),
                None => c,
            }
        })
        .min_within(&xlimits)
        .map_err(ego_error)?
        .run()
        .map_err(ego_error)?;
    let xs: Vec<Vec<f64>> = result
        .x_doe
        .rows()
        .into_iter()
        .map(|r| r.to_vec())
        .collect();
    let mut evals = problem.evaluate(&xs)?;
    evals.sort_by(|a, b| match (a.feasible, b.feasible) {
        (true, false) => std::cmp::Ordering::Less,
        (false, true) => std::cmp::Ordering::Greater,
        (true, true) => problem.cost(a, 0).total_cmp(&problem.cost(b, 0)),
        (false, false) => a.violation().total_cmp(&b.violation()),
    });
    Ok(evals)
}

/// The first `n` designs of `sorted` that are at least [`MIN_DISTINCT`] apart.
pub fn distinct_best(problem: &Problem, sorted: &[Evaluation], n: usize) -> Vec<Evaluation> {
    let mut out: Vec<Evaluation> = Vec::new();
    for e in sorted {
        if out.len() == n {
            break;
        }
        if out
            .iter()
            .all(|o| problem.distance(&o.x, &e.x) >= MIN_DISTINCT)
        {
            out.push(e.clone());
        }
    }
    out
}
