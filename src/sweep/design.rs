//! Designs of experiments: the full factorial and the Latin hypercube.
//!
//! Written here: both are a few lines (a Cartesian product; one stratified permutation per
//! factor, McKay, Beckman and Conover 1979), and the crate's own SplitMix64
//! ([`crate::render::rng`]) keeps a seeded hypercube identical on every machine and crate
//! version.

use crate::render::rng::SplitMix64;

/// Largest number of points a plan may have.
pub const MAX_POINTS: usize = 100_000;

/// Decimals a Latin-hypercube value keeps (the config and designs.csv then hold the same
/// number).
const LHS_DECIMALS: i32 = 6;

/// The kind of design.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DesignKind {
    /// Every combination of the factors' levels.
    Factorial,
    /// A Latin hypercube of `n` points.
    Lhs {
        /// Points.
        n: usize,
        /// Seed of the permutations and offsets.
        seed: u64,
    },
}

/// What values a factor takes.
#[derive(Debug, Clone, PartialEq)]
pub enum FactorLevels {
    /// Listed levels (factorial).
    Levels(Vec<toml::Value>),
    /// A range (Latin hypercube); `integer` rounds the values.
    Range {
        /// Low end.
        lo: f64,
        /// High end.
        hi: f64,
        /// The field is an integer.
        integer: bool,
    },
}

/// A factor: a config field and its values.
#[derive(Debug, Clone, PartialEq)]
pub struct Factor {
    /// `section.field`, as in the plan.
    pub name: String,
    /// Its values.
    pub levels: FactorLevels,
}

/// The design's points: one value per factor each, in plan order (factorial: the first
/// factor varies slowest).
pub fn design_points(
    kind: DesignKind,
    factors: &[Factor],
) -> Result<Vec<Vec<toml::Value>>, String> {
    match kind {
        DesignKind::Factorial => {
            let mut points: Vec<Vec<toml::Value>> = vec![Vec::new()];
            for f in factors {
                let FactorLevels::Levels(levels) = &f.levels else {
                    return Err(format!(
                        "factor {}: a factorial design needs levels",
                        f.name
                    ));
                };
                if points.len().saturating_mul(levels.len()) > MAX_POINTS {
                    return Err(format!("the factorial design has more than {MAX_POINTS} points: use fewer levels or a Latin hypercube"));
                }
                points = points
                    .iter()
                    .flat_map(|p| {
                        levels.iter().map(move |l| {
                            let mut q = p.clone();
                            q.push(l.clone());
                            q
                        })
                    })
                    .collect();
            }
            Ok(points)
        }
        DesignKind::Lhs { n, seed } => {
            if n == 0 || n > MAX_POINTS {
                return Err(format!(
                    "a Latin hypercube needs 1..{MAX_POINTS} points, not {n}"
                ));
            }
            let mut rng = SplitMix64::new(seed);
            let mut points = vec![Vec::with_capacity(factors.len()); n];
            let scale = 10f64.powi(LHS_DECIMALS);
            for f in factors {
                let FactorLevels::Range { lo, hi, integer } = f.levels else {
                    return Err(format!(
                        "factor {}: a Latin hypercube needs a range",
                        f.name
                    ));
                };
                let mut strata: Vec<usize> = (0..n).collect();
                for i in (1..n).rev() {
                    let j = (rng.next_u64() % (i as u64 + 1)) as usize;
                    strata.swap(i, j);
                }
                for (p, s) in points.iter_mut().zip(strata) {
                    let u = (s as f64 + rng.uniform()) / n as f64;
                    let v = lo + u * (hi - lo);
                    p.push(if integer {
                        toml::Value::Integer(v.round() as i64)
                    } else {
                        toml::Value::Float((v * scale).round() / scale)
                    });
                }
            }
            Ok(points)
        }
    }
}

/// Point ids `p001`, `p002` ... (at least three digits, as many as the count needs).
pub fn point_ids(count: usize) -> Vec<String> {
    let width = count.to_string().len().max(3);
    (1..=count).map(|i| format!("p{i:0width$}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn range(name: &str, lo: f64, hi: f64, integer: bool) -> Factor {
        Factor {
            name: name.into(),
            levels: FactorLevels::Range { lo, hi, integer },
        }
    }

    #[test]
    fn factorial_is_every_combination_first_factor_slowest() {
        let f = |name: &str, l: &[i64]| Factor {
            name: name.into(),
            levels: FactorLevels::Levels(l.iter().map(|v| toml::Value::Integer(*v)).collect()),
        };
        let p = design_points(
            DesignKind::Factorial,
            &[f("a", &[1, 2]), f("b", &[7, 8, 9])],
        )
        .unwrap();
        let as_int: Vec<Vec<i64>> = p
            .iter()
            .map(|q| q.iter().map(|v| v.as_integer().unwrap()).collect())
            .collect();
        assert_eq!(as_int, [[1, 7], [1, 8], [1, 9], [2, 7], [2, 8], [2, 9]]);
    }

    #[test]
    fn latin_hypercube_puts_one_point_in_every_stratum_of_every_factor() {
        let n = 16;
        let factors = [range("a", 2.0, 8.0, false), range("b", 0.0, 1.0, false)];
        let p = design_points(DesignKind::Lhs { n, seed: 1 }, &factors).unwrap();
        assert_eq!(p.len(), n);
        for (k, f) in factors.iter().enumerate() {
            let FactorLevels::Range { lo, hi, .. } = f.levels else {
                unreachable!()
            };
            let mut strata: Vec<usize> = p
                .iter()
                .map(|q| {
                    let v = q[k].as_float().unwrap();
                    assert!((lo..=hi).contains(&v));
                    (((v - lo) / (hi - lo)) * n as f64)
                        .floor()
                        .min(n as f64 - 1.0) as usize
                })
                .collect();
            strata.sort();
            assert_eq!(strata, (0..n).collect::<Vec<_>>(), "factor {}", f.name);
        }
        // Seeded: the same plan gives the same points; another seed others.
        assert_eq!(
            p,
            design_points(DesignKind::Lhs { n, seed: 1 }, &factors).unwrap()
        );
        assert_ne!(
            p,
            design_points(DesignKind::Lhs { n, seed: 2 }, &factors).unwrap()
        );
        let ints = design_points(
            DesignKind::Lhs { n: 7, seed: 3 },
            &[range("c", 2.0, 8.0, true)],
        )
        .unwrap();
        assert!(ints
            .iter()
            .all(|q| q[0].as_integer().is_some_and(|v| (2..=8).contains(&v))));
    }

    #[test]
    fn ids_are_zero_padded() {
        assert_eq!(point_ids(2), ["p001", "p002"]);
        assert_eq!(point_ids(1000)[999], "p1000");
    }
}
