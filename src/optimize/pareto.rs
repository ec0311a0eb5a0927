//! Two objectives: a Pareto front by NSGA-II (Deb, Pratap, Agarwal, Meyarivan 2002, IEEE
//! TEC 6(2)) on the surrogates: constrained domination (a feasible design beats an
//! infeasible one, two infeasible ones compare by total violation), fast non-dominated
//! sorting, crowding distance, binary tournaments, simulated binary crossover and
//! polynomial mutation (Deb & Agrawal 1995), seeded.
//!
//! Written here: the maintained crate (nsga_rs 1.4.1) does not build with either release
//! of its macro crate (nsga-rs-macros 1.2.1 lacks `as_algorithm`, 1.1.1 the thread pool),
//! and it would add a third nalgebra, bindgen and a C hypervolume library to the build;
//! the algorithm is a hundred lines over the surrogates' evaluations.

use super::{Evaluation, OptimizeError, Problem};

/// Crossover probability per pair.
const CROSSOVER_PROBABILITY: f64 = 0.9;
/// Distribution index of the simulated binary crossover.
const ETA_CROSSOVER: f64 = 15.0;
/// Distribution index of the polynomial mutation.
const ETA_MUTATION: f64 = 20.0;

/// SplitMix64 (Steele, Lea, Flood 2014): a small seeded generator, enough for the
/// genetic operators.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// The result of NSGA-II.
#[derive(Debug, Clone)]
pub struct Front {
    /// Every design evaluated (initial population and offspring).
    pub evaluated: Vec<Evaluation>,
    /// The final population's feasible non-dominated designs, ordered by the first
    /// objective.
    pub front: Vec<Evaluation>,
}

/// `a` beats `b` under constrained domination (costs minimized).
fn dominates(a: &(Vec<f64>, f64), b: &(Vec<f64>, f64)) -> bool {
    match (a.1 <= 0.0, b.1 <= 0.0) {
        (true, false) => true,
        (false, true) => false,
        (false, false) => a.1 < b.1,
        (true, true) => {
            a.0.iter().zip(&b.0).all(|(p, q)| p <= q) && a.0.iter().zip(&b.0).any(|(p, q)| p < q)
        }
    }
}

/// Fronts of `pts` (indices), best first (fast non-dominated sort).
fn sort_fronts(pts: &[(Vec<f64>, f64)]) -> Vec<Vec<usize>> {
    let n = pts.len();
    let mut beaten_by = vec![0usize; n];
    let mut beats: Vec<Vec<usize>> = vec![Vec::new(); n];
    for i in 0..n {
        for j in 0..n {
            if i != j && dominates(&pts[i], &pts[j]) {
                beats[i].push(j);
            } else if i != j && dominates(&pts[j], &pts[i]) {
                beaten_by[i] += 1;
            }
        }
    }
    let mut fronts = Vec::new();
    let mut current: Vec<usize> = (0..n).filter(|i| beaten_by[*i] == 0).collect();
    while !current.is_empty() {
        let mut next = Vec::new();
        for &i in &current {
            for &j in &beats[i] {
                beaten_by[j] -= 1;
                if beaten_by[j] == 0 {
                    next.push(j);
                }
            }
        }
        fronts.push(current);
        current = next;
    }
    fronts
}

/// Crowding distance of each member of `front` (same order).
fn crowding(pts: &[(Vec<f64>, f64)], front: &[usize]) -> Vec<f64> {
    let mut d = vec![0.0; front.len()];
    let n_obj = pts.first().map(|p| p.0.len()).unwrap_or(0);
    for k in 0..n_obj {
        let mut order: Vec<usize> = (0..front.len()).collect();
        order.sort_by(|a, b| pts[front[*a]].0[k].total_cmp(&pts[front[*b]].0[k]));
        let (lo, hi) = (
            pts[front[order[0]]].0[k],
            pts[front[order[order.len() - 1]]].0[k],
        );
        d[order[0]] = f64::INFINITY;
        d[order[order.len() - 1]] = f64::INFINITY;
        if hi > lo {
            for w in 1..order.len().saturating_sub(1) {
                d[order[w]] +=
                    (pts[front[order[w + 1]]].0[k] - pts[front[order[w - 1]]].0[k]) / (hi - lo);
            }
        }
    }
    d
}

/// Simulated binary crossover of one variable in [lo, hi].
fn sbx(rng: &mut Rng, a: f64, b: f64, lo: f64, hi: f64) -> (f64, f64) {
    let u = rng.uniform();
    let beta = if u <= 0.5 {
        (2.0 * u).powf(1.0 / (ETA_CROSSOVER + 1.0))
    } else {
        (1.0 / (2.0 * (1.0 - u))).powf(1.0 / (ETA_CROSSOVER + 1.0))
    };
    let c1 = 0.5 * ((1.0 + beta) * a + (1.0 - beta) * b);
    let c2 = 0.5 * ((1.0 - beta) * a + (1.0 + beta) * b);
    (c1.clamp(lo, hi), c2.clamp(lo, hi))
}

/// Polynomial mutation of one variable in [lo, hi].
fn mutate(rng: &mut Rng, v: f64, lo: f64, hi: f64) -> f64 {
    let u = rng.uniform();
    let delta = if u < 0.5 {
        (2.0 * u).powf(1.0 / (ETA_MUTATION + 1.0)) - 1.0
    } else {
        1.0 - (2.0 * (1.0 - u)).powf(1.0 / (ETA_MUTATION + 1.0))
    };
    (v + delta * (hi - lo)).clamp(lo, hi)
}

/// Runs NSGA-II with the plan's population, generations and seed.
pub fn front(problem: &Problem) -> Result<Front, OptimizeError> {
    let inputs = &problem.plan.inputs;
    let n_obj = problem.plan.objectives.len();
    let size = problem.plan.population + problem.plan.population % 2;
    let mut rng = Rng(problem.plan.seed);
    let key = |e: &Evaluation| -> (Vec<f64>, f64) {
        (
            (0..n_obj).map(|k| problem.cost(e, k)).collect(),
            e.violation(),
        )
    };
    let init: Vec<Vec<f64>> = (0..size)
        .map(|_| {
            inputs
                .iter()
                .map(|i| i.min + rng.uniform() * (i.max - i.min))
                .collect()
        })
        .collect();
    let mut pop = problem.evaluate(&init)?;
    let mut evaluated = pop.clone();
    // Rank and crowding of the current population, for the tournaments.
    let mut rank = vec![0usize; pop.len()];
    let mut crowd = vec![0.0; pop.len()];
    let rank_pop = |pop: &[Evaluation], rank: &mut Vec<usize>, crowd: &mut Vec<f64>| {
        let pts: Vec<_> = pop.iter().map(key).collect();
        for (r, f) in sort_fronts(&pts).iter().enumerate() {
            for (i, c) in f.iter().zip(crowding(&pts, f)) {
                rank[*i] = r;
                crowd[*i] = c;
            }
        }
    };
    rank_pop(&pop, &mut rank, &mut crowd);
    for _ in 0..problem.plan.generations {
        let pick = |rng: &mut Rng| {
            let (a, b) = (rng.below(pop.len()), rng.below(pop.len()));
            if rank[a] < rank[b] || (rank[a] == rank[b] && crowd[a] > crowd[b]) {
                a
            } else {
                b
            }
        };
        let mut children: Vec<Vec<f64>> = Vec::with_capacity(size);
        while children.len() < size {
            let (p, q) = (pick(&mut rng), pick(&mut rng));
            let (mut c1, mut c2) = (pop[p].x.clone(), pop[q].x.clone());
            if rng.uniform() < CROSSOVER_PROBABILITY {
                for (j, i) in inputs.iter().enumerate() {
                    if rng.uniform() < 0.5 {
                        let (a, b) = sbx(&mut rng, c1[j], c2[j], i.min, i.max);
                        c1[j] = a;
                        c2[j] = b;
                    }
                }
            }
            for c in [&mut c1, &mut c2] {
                for (j, i) in inputs.iter().enumerate() {
                    if rng.uniform() < 1.0 / inputs.len() as f64 {
                        c[j] = mutate(&mut rng, c[j], i.min, i.max);
                    }
                }
            }
            children.push(c1);
            children.push(c2);
        }
        let offspring = problem.evaluate(&children)?;
        evaluated.extend(offspring.iter().cloned());
        let mut all = pop;
        all.extend(offspring);
        let pts: Vec<_> = all.iter().map(key).collect();
        let mut next: Vec<usize> = Vec::with_capacity(size);
        for f in sort_fronts(&pts) {
            if next.len() + f.len() <= size {
                next.extend(&f);
            } else {
                let d = crowding(&pts, &f);
                let mut order: Vec<usize> = (0..f.len()).collect();
                order.sort_by(|a, b| d[*b].total_cmp(&d[*a]));
                next.extend(order.iter().take(size - next.len()).map(|k| f[*k]));
                break;
            }
        }
        pop = next.into_iter().map(|i| all[i].clone()).collect();
        rank_pop(&pop, &mut rank, &mut crowd);
    }
    let front = non_dominated(problem, &pop);
    Ok(Front { evaluated, front })
}

/// The feasible designs no other feasible design dominates (duplicates dropped), ordered
/// by the first objective.
pub fn non_dominated(problem: &Problem, evals: &[Evaluation]) -> Vec<Evaluation> {
    let n_obj = problem.plan.objectives.len();
    let costs: Vec<Vec<f64>> = evals
        .iter()
        .map(|e| (0..n_obj).map(|k| problem.cost(e, k)).collect())
        .collect();
    let better = |a: &[f64], b: &[f64]| {
        a.iter().zip(b).all(|(p, q)| p <= q) && a.iter().zip(b).any(|(p, q)| p < q)
    };
    let mut front: Vec<(Vec<f64>, Evaluation)> = Vec::new();
    for (i, e) in evals.iter().enumerate() {
        if !e.feasible {
            continue;
        }
        let dominated = evals
            .iter()
            .enumerate()
            .any(|(j, o)| o.feasible && better(&costs[j], &costs[i]));
        let duplicate = front.iter().any(|(c, _)| c == &costs[i]);
        if !dominated && !duplicate {
            front.push((costs[i].clone(), e.clone()));
        }
    }
    front.sort_by(|a, b| a.0[0].total_cmp(&b.0[0]));
    front.into_iter().map(|(_, e)| e).collect()
}

/// `n` designs spread along a front: both ends and evenly between them.
pub fn spread(front: &[Evaluation], n: usize) -> Vec<Evaluation> {
    if n == 0 || front.is_empty() {
        return Vec::new();
    }
    if n >= front.len() {
        return front.to_vec();
    }
    if n == 1 {
        return vec![front[front.len() / 2].clone()];
    }
    let mut idx: Vec<usize> = (0..n)
        .map(|k| ((k as f64) * (front.len() - 1) as f64 / (n - 1) as f64).round() as usize)
        .collect();
    idx.dedup();
    idx.into_iter().map(|i| front[i].clone()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sorting_puts_feasible_non_dominated_first_and_crowding_keeps_the_ends() {
        let pts = vec![
            (vec![1.0, 3.0], 0.0),
            (vec![2.0, 2.0], 0.0),
            (vec![3.0, 1.0], 0.0),
            (vec![3.0, 3.0], 0.0),
            (vec![0.0, 0.0], 1.0), // best costs, infeasible
        ];
        let f = sort_fronts(&pts);
        assert_eq!(f[0], vec![0, 1, 2]);
        assert_eq!(f[1], vec![3]);
        assert_eq!(f[2], vec![4]);
        let d = crowding(&pts, &f[0]);
        assert!(d[0].is_infinite() && d[2].is_infinite());
        assert!((d[1] - 2.0).abs() < 1e-12, "{d:?}");
    }
}
