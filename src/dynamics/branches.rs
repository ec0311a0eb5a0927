//! Loading and unloading branches of a pressure history: turning points where the
//! pressure reverses by more than a threshold (a zigzag filter, so regulator noise
//! smaller than the threshold never makes a turning point), the stretches between them
//! labelled by direction and numbered in cycles.

use serde::Serialize;

/// Turning points need the pressure to reverse by at least this much, kPa (and by
/// [`TURN_NOISE_FACTOR`] noise standard deviations).
pub const TURN_MIN_KPA: f64 = 1.0;

/// A turning point needs a reversal of this many noise standard deviations of the log
/// ([`super::noise_sd`]): the range of thousands of normal samples stays below it.
pub const TURN_NOISE_FACTOR: f64 = 8.0;

/// The reversal that makes a turning point in a log of noise sd `noise_sd_kpa`.
pub fn reversal_threshold_kpa(noise_sd_kpa: f64) -> f64 {
    TURN_MIN_KPA.max(TURN_NOISE_FACTOR * noise_sd_kpa)
}

/// Which way the pressure goes along a branch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// Rising pressure.
    Loading,
    /// Falling pressure.
    Unloading,
}

impl std::fmt::Display for Direction {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Direction::Loading => "loading",
            Direction::Unloading => "unloading",
        })
    }
}

/// A monotone stretch of a pressure history, between two turning points (or an end).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Branch {
    /// Branch number, from 1 in time order.
    pub branch: usize,
    /// Rising or falling.
    pub direction: Direction,
    /// Cycle number, from 1: a cycle is a loading branch and the unloading branch after
    /// it (a history that starts by falling has that unloading branch alone in cycle 1).
    pub cycle: usize,
    /// Time (or position) where it starts: the previous turning point, or the first sample.
    pub start_s: f64,
    /// Time where it ends: its turning point, or the last sample.
    pub end_s: f64,
    /// Pressure at its start, kPa.
    pub from_kpa: f64,
    /// Pressure at its end, kPa.
    pub to_kpa: f64,
}

/// Indices of the turning points of `values`: a sample is one when it is the extreme
/// (largest while rising, smallest while falling) since the last turning point and the
/// values after it reverse by more than `reversal` before exceeding it. The direction
/// at the start is the first move by more than `reversal`.
pub fn turning_points(values: &[f64], reversal: f64) -> Vec<usize> {
    #[derive(PartialEq)]
    enum Dir {
        Unknown,
        Up,
        Down,
    }
    let mut turns = Vec::new();
    let Some(&first) = values.first() else {
        return turns;
    };
    let (mut dir, mut ext) = (Dir::Unknown, 0usize);
    let (mut lo, mut hi) = (first, first);
    for (i, &v) in values.iter().enumerate().skip(1) {
        if !v.is_finite() {
            continue;
        }
        match dir {
            Dir::Unknown => {
                lo = lo.min(v);
                hi = hi.max(v);
                if v - lo > reversal {
                    (dir, ext) = (Dir::Up, i);
                } else if hi - v > reversal {
                    (dir, ext) = (Dir::Down, i);
                }
            }
            Dir::Up => {
                if v > values[ext] {
                    ext = i;
                } else if values[ext] - v > reversal {
                    turns.push(ext);
                    (dir, ext) = (Dir::Down, i);
                }
            }
            Dir::Down => {
                if v < values[ext] {
                    ext = i;
                } else if v - values[ext] > reversal {
                    turns.push(ext);
                    (dir, ext) = (Dir::Up, i);
                }
            }
        }
    }
    turns
}

/// The branches of the history `(times[i], values[i])` split at its [`turning_points`]
/// for `reversal`. A history that never moves by more than `reversal` is one loading
/// branch. Empty input gives no branch.
pub fn branches(times: &[f64], values: &[f64], reversal: f64) -> Vec<Branch> {
    let n = times.len().min(values.len());
    if n == 0 {
        return vec![];
    }
    let mut bounds = vec![0];
    bounds.extend(turning_points(&values[..n], reversal));
    bounds.push(n - 1);
    let mut out: Vec<Branch> = Vec::new();
    for w in bounds.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b == a && !out.is_empty() {
            continue;
        }
        let direction = if values[b] < values[a] {
            Direction::Unloading
        } else {
            Direction::Loading
        };
        let cycle = match out.last() {
            None => 1,
            Some(prev) if direction == Direction::Loading => prev.cycle + 1,
            Some(prev) => prev.cycle,
        };
        out.push(Branch {
            branch: out.len() + 1,
            direction,
            cycle,
            start_s: times[a],
            end_s: times[b],
            from_kpa: values[a],
            to_kpa: values[b],
        });
    }
    out
}

/// The index (into `branches`) of the branch that holds time `t`: a turning point's time
/// belongs to the branch it ends. `None` outside the history.
pub fn branch_at(branches: &[Branch], t: f64) -> Option<usize> {
    let first = branches.first()?;
    if t.is_nan() || t < first.start_s {
        return None;
    }
    branches.iter().position(|b| t <= b.end_s)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Branch directions and cycles as a compact string: `L1 U1 L2 U2`.
    fn labels(b: &[Branch]) -> String {
        b.iter()
            .map(|b| {
                let d = match b.direction {
                    Direction::Loading => 'L',
                    Direction::Unloading => 'U',
                };
                format!("{d}{}", b.cycle)
            })
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// A triangle wave between 20 and 50 kPa, `cycles` up-and-down cycles of 2 s
    /// sampled at 100 Hz, with a +-`noise` kPa saw-tooth dither on top.
    fn triangle(cycles: usize, noise: f64) -> (Vec<f64>, Vec<f64>) {
        let n = cycles * 200 + 1;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let p = t
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let phase = t % 2.0;
                let tri = if phase <= 1.0 { phase } else { 2.0 - phase };
                20.0 + 30.0 * tri + noise * [1.0, -1.0, 0.5, -0.5, 0.0][i % 5]
            })
            .collect();
        (t, p)
    }

    #[test]
    fn cycles_split_at_the_turning_points_despite_noise() {
        // (cycles, noise kPa, reversal kPa, expected labels)
        for (cycles, noise, reversal, want) in [
            (1, 0.0, 1.0, "L1 U1"),
            (1, 0.4, 1.0, "L1 U1"),
            (3, 0.4, 1.0, "L1 U1 L2 U2 L3 U3"),
            (2, 0.0, 1.0, "L1 U1 L2 U2"),
        ] {
            let (t, p) = triangle(cycles, noise);
            let b = branches(&t, &p, reversal);
            assert_eq!(labels(&b), want, "{cycles} cycles, noise {noise}");
            // Turning points within the dither's reach of the true ones (1 s, 2 s, ...).
            for (k, br) in b.iter().enumerate().take(b.len() - 1) {
                let true_turn = (k + 1) as f64;
                assert!(
                    (br.end_s - true_turn).abs() <= 0.03,
                    "turn {k}: {} s",
                    br.end_s
                );
            }
            assert_eq!(b.last().unwrap().end_s, *t.last().unwrap());
        }
    }

    #[test]
    fn dither_below_the_threshold_is_not_a_turning_point() {
        // Noise of +-0.4 kPa alone with a reversal threshold of 1 kPa: one branch; with
        // a threshold below the dither every reversal would count.
        let t: Vec<f64> = (0..500).map(|i| i as f64 * 0.01).collect();
        let p: Vec<f64> = (0..500)
            .map(|i| 30.0 + 0.4 * [1.0, -1.0, 0.5, -0.5, 0.0][i % 5])
            .collect();
        assert_eq!(branches(&t, &p, 1.0).len(), 1);
        assert!(branches(&t, &p, 0.5).len() > 100);
    }

    #[test]
    fn a_ramp_that_only_rises_is_one_loading_branch() {
        let t: Vec<f64> = (0..100).map(|i| i as f64 * 0.1).collect();
        let p: Vec<f64> = t.iter().map(|t| 5.0 + 2.5 * t).collect();
        let b = branches(&t, &p, 1.0);
        assert_eq!(labels(&b), "L1");
        assert_eq!((b[0].from_kpa, b[0].to_kpa), (5.0, p[99]));
        assert_eq!(branch_at(&b, 3.0), Some(0));
        assert_eq!(branch_at(&b, -1.0), None);
        assert_eq!(branch_at(&b, 100.0), None);
        // A history that starts by falling: its unloading branch is cycle 1 alone.
        let p: Vec<f64> = [50.0, 40.0, 30.0, 40.0, 50.0, 40.0].to_vec();
        let t: Vec<f64> = (0..6).map(|i| i as f64).collect();
        let b = branches(&t, &p, 0.0);
        assert_eq!(labels(&b), "U1 L2 U2");
        assert_eq!(
            branch_at(&b, 2.0),
            Some(0),
            "a turning point ends its branch"
        );
        assert_eq!(branch_at(&b, 2.5), Some(1));
    }

    #[test]
    fn threshold_follows_the_noise() {
        assert_eq!(reversal_threshold_kpa(0.0), TURN_MIN_KPA);
        assert_eq!(reversal_threshold_kpa(0.5), 4.0);
    }
}
