//! Picking the actuator's markers among the red blobs of a frame.
//!
//! Real footage has red things besides the markers (the air tube running into the clamp,
//! a label, a regulator's LED). When a frame has more candidates than markers, the
//! markers are the subset that looks like an actuator: a chain of `n` blobs of alike
//! size and round shape, with near-uniform spacing along a smooth arc (constant turning
//! between successive chords, as on a circle), starting at the clamped end and close to
//! the previous frame's markers. [`select_markers`] searches such chains with a beam
//! search (each candidate a possible first marker, each step extending the best partial
//! chains by a neighbour whose spacing and turn agree with the chain so far) and keeps
//! the cheapest complete one. Written here because no library offers it: it is a
//! domain rule (what a PneuNets marker line looks like), not a generic algorithm.

use nalgebra::Point2;

use crate::detect::{ChainStart, ClampSide};
use crate::segments::Segment;

/// A red blob that may be a marker.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Centroid, px (undistorted when the camera is known).
    pub point: Point2<f64>,
    /// Area, px.
    pub area_px: f64,
    /// Bounding-box elongation: longer side / shorter side (1 for a disc).
    pub elongation: f64,
}

/// Longest bounding-box side over the shortest a marker may have (a disc is 1; motion
/// blur stretches it a little, a tube is much longer).
pub const MAX_ELONGATION: f64 = 2.5;
/// A chain's spacings must lie within these shares of the chain's mean spacing.
pub const SPACING_RANGE: (f64, f64) = (0.6, 1.5);
/// Largest turn between successive chords, degrees (8 markers over 180 degrees turn
/// ~26 degrees per chord).
pub const MAX_TURN_DEG: f64 = 50.0;
/// Largest difference between a turn and the chain's mean turn so far, degrees.
pub const MAX_TURN_CHANGE_DEG: f64 = 20.0;
/// Marker areas within this factor of the chain's median area.
pub const AREA_FACTOR: f64 = 3.0;
/// Partial chains kept at each step of the search.
pub const BEAM_WIDTH: usize = 48;
/// Neighbours tried as the second marker of a chain.
pub const FIRST_STEP_NEIGHBOURS: usize = 6;

/// Why no marker chain was found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SelectError {
    /// Fewer round, alike blobs than markers.
    #[error("{found} marker-like blobs, {expected} expected")]
    TooFew {
        /// Candidates that passed the shape test.
        found: usize,
        /// Markers expected.
        expected: usize,
    },
    /// No subset forms a smooth, evenly spaced chain.
    #[error("no chain of {expected} evenly spaced markers among {found} red blobs")]
    NoChain {
        /// Candidates.
        found: usize,
        /// Markers expected.
        expected: usize,
    },
}

#[derive(Debug, Clone)]
struct Partial {
    chain: Vec<usize>,
    cost: f64,
}

fn wrap(a: f64) -> f64 {
    let mut d = a;
    while d > std::f64::consts::PI {
        d -= std::f64::consts::TAU;
    }
    while d < -std::f64::consts::PI {
        d += std::f64::consts::TAU;
    }
    d
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

fn std_dev(v: &[f64]) -> f64 {
    if v.len() < 2 {
        return 0.0;
    }
    let m = mean(v);
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
}

/// Spacings and turns (radians) along a chain.
fn geometry(c: &[Candidate], chain: &[usize]) -> (Vec<f64>, Vec<f64>) {
    let pts: Vec<Point2<f64>> = chain.iter().map(|&i| c[i].point).collect();
    let d: Vec<f64> = pts.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
    let dirs: Vec<f64> = pts
        .windows(2)
        .map(|w| (w[1].y - w[0].y).atan2(w[1].x - w[0].x))
        .collect();
    let t: Vec<f64> = dirs.windows(2).map(|w| wrap(w[1] - w[0])).collect();
    (d, t)
}

/// Shape cost of a (partial) chain: spacing variation, turn variation, area variation;
/// `None` when it breaks a gate.
fn shape_cost(c: &[Candidate], chain: &[usize]) -> Option<f64> {
    let (d, t) = geometry(c, chain);
    let md = mean(&d);
    if d.iter()
        .any(|x| *x < SPACING_RANGE.0 * md || *x > SPACING_RANGE.1 * md)
    {
        return None;
    }
    let mt = mean(&t);
    if t.iter().any(|x| {
        x.abs() > MAX_TURN_DEG.to_radians() || (x - mt).abs() > MAX_TURN_CHANGE_DEG.to_radians()
    }) {
        return None;
    }
    let mut areas: Vec<f64> = chain.iter().map(|&i| c[i].area_px).collect();
    areas.sort_by(f64::total_cmp);
    let med = areas[areas.len() / 2];
    if areas
        .iter()
        .any(|a| *a > AREA_FACTOR * med || *a * AREA_FACTOR < med)
    {
        return None;
    }
    let log_areas: Vec<f64> = areas.iter().map(|a| a.max(1.0).ln()).collect();
    Some(3.0 * std_dev(&d) / md.max(1e-9) + 3.0 * std_dev(&t) + std_dev(&log_areas))
}

/// Where the chain's first marker is expected: cost of `first` as the clamped end,
/// in units of the chain's spacing.
fn start_cost(c: &[Candidate], chain: &[usize], start: ChainStart, spacing: f64) -> f64 {
    let p = c[chain[0]].point;
    match start {
        ChainStart::Near(q) => (p - q).norm() / spacing,
        ChainStart::Side(side) => {
            // How far the first marker is from the chain's end nearest that side.
            let key = |q: Point2<f64>| match side {
                ClampSide::Left => q.x,
                ClampSide::Right => -q.x,
                ClampSide::Top => q.y,
                ClampSide::Bottom => -q.y,
            };
            let best = chain
                .iter()
                .map(|&i| key(c[i].point))
                .fold(f64::INFINITY, f64::min);
            (key(p) - best) / spacing
        }
    }
}

/// Picks `n` markers among `candidates`: indices in chain order from the clamped end.
/// `previous` (the last frame's ordered markers, same count) favours the chain that
/// moved least.
pub fn select_markers(
    candidates: &[Candidate],
    n: usize,
    start: ChainStart,
    previous: Option<&[Point2<f64>]>,
) -> Result<Vec<usize>, SelectError> {
    beam_select(candidates, n, start, previous, &|chain| {
        shape_cost(candidates, chain)
    })
}

/// [`select_markers`] for a segmented actuator: the chain follows `segments` (which
/// cover markers 0..n in order, [`Segment`]): even spacing and a constant turn within
/// each segment, tangent continuity across each joint ([`segmented_shape_cost`]).
pub fn select_markers_in_segments(
    candidates: &[Candidate],
    n: usize,
    segments: &[Segment],
    start: ChainStart,
    previous: Option<&[Point2<f64>]>,
) -> Result<Vec<usize>, SelectError> {
    beam_select(candidates, n, start, previous, &|chain| {
        segmented_shape_cost(candidates, chain, segments)
    })
}

/// Gates and cost of one segment's (partial) sub-chain: spacing and turn variation.
fn segment_part_cost(d: &[f64], t: &[f64]) -> Option<f64> {
    let md = mean(d);
    if d.iter()
        .any(|x| *x < SPACING_RANGE.0 * md || *x > SPACING_RANGE.1 * md)
    {
        return None;
    }
    let mt = mean(t);
    if t.iter().any(|x| {
        x.abs() > MAX_TURN_DEG.to_radians() || (x - mt).abs() > MAX_TURN_CHANGE_DEG.to_radians()
    }) {
        return None;
    }
    Some(3.0 * std_dev(d) / md.max(1e-9) + 3.0 * std_dev(t))
}

/// Distance of `x` from the interval spanned by `a` and `b`.
fn outside(x: f64, a: f64, b: f64) -> f64 {
    (a.min(b) - x).max(x - a.max(b)).max(0.0)
}

/// Shape cost of a (partial) chain of a segmented actuator; `None` when it breaks a
/// gate. Within each segment the gates of an evenly spaced arc apply to its own
/// spacing and turn. At a joint the tangent is continuous: where a marker is shared, the
/// turn there is half of each segment's turn per chord (tA / 2 + tB / 2, chords of
/// circles meeting tangentially); where the segments abut, the joint chord (which may
/// be shorter) turns by its length times a curvature between the two segments', and each
/// of its two turns is half of that plus half of the neighbouring segment's turn. Areas
/// alike over the whole chain.
pub fn segmented_shape_cost(c: &[Candidate], chain: &[usize], segments: &[Segment]) -> Option<f64> {
    let (d, t) = geometry(c, chain);
    let len = chain.len();
    let change = MAX_TURN_CHANGE_DEG.to_radians();
    let mut cost = 0.0;
    // Per segment: mean spacing and mean turn per chord (None until known).
    let mut parts: Vec<(Option<f64>, Option<f64>)> = Vec::with_capacity(segments.len());
    for s in segments {
        if s.first + 1 >= len {
            parts.push((None, None));
            continue;
        }
        let last = s.last.min(len - 1);
        let ds = &d[s.first..last];
        let ts = if last >= s.first + 2 {
            &t[s.first..last - 1]
        } else {
            &[][..]
        };
        cost += segment_part_cost(ds, ts)?;
        parts.push((Some(mean(ds)), (!ts.is_empty()).then(|| mean(ts))));
    }
    for (k, w) in segments.windows(2).enumerate() {
        let (a, b) = (w[0], w[1]);
        let ((da, ta), (db, tb)) = (parts[k], parts[k + 1]);
        if b.first == a.last {
            // Shared marker j: the turn between chords j-1 -> j and j -> j+1.
            let j = a.last;
            if j + 1 >= len {
                continue;
            }
            let turn = t[j - 1];
            if turn.abs() > MAX_TURN_DEG.to_radians() {
                return None;
            }
            if let (Some(ta), Some(tb)) = (ta, tb) {
                let e = (turn - 0.5 * (ta + tb)).abs();
                if e > change {
                    return None;
                }
                cost += 3.0 * e;
            }
        } else {
            // Joint chord j -> j+1 between the segments.
            let j = a.last;
            if j + 1 >= len {
                continue;
            }
            let joint = d[j];
            let (Some(da), Some(ta)) = (da, ta) else {
                continue;
            };
            let db_or = db.unwrap_or(da);
            if joint < 0.3 * da.min(db_or) || joint > SPACING_RANGE.1 * da.max(db_or) {
                return None;
            }
            let turn_in = t[j - 1];
            if turn_in.abs() > MAX_TURN_DEG.to_radians() {
                return None;
            }
            let ka = ta / da.max(1e-9);
            let kb = match (db, tb) {
                (Some(db), Some(tb)) => tb / db.max(1e-9),
                _ => ka,
            };
            let e_in = outside(
                turn_in,
                0.5 * ta + 0.5 * joint * ka,
                0.5 * ta + 0.5 * joint * kb,
            );
            if e_in > change {
                return None;
            }
            cost += 3.0 * e_in;
            if let (Some(tb), true) = (tb, j + 2 < len) {
                let turn_out = t[j];
                if turn_out.abs() > MAX_TURN_DEG.to_radians() {
                    return None;
                }
                let e_out = outside(
                    turn_out,
                    0.5 * tb + 0.5 * joint * ka,
                    0.5 * tb + 0.5 * joint * kb,
                );
                if e_out > change {
                    return None;
                }
                cost += 3.0 * e_out;
            }
        }
    }
    let mut areas: Vec<f64> = chain.iter().map(|&i| c[i].area_px).collect();
    areas.sort_by(f64::total_cmp);
    let med = areas[areas.len() / 2];
    if areas
        .iter()
        .any(|a| *a > AREA_FACTOR * med || *a * AREA_FACTOR < med)
    {
        return None;
    }
    let log_areas: Vec<f64> = areas.iter().map(|a| a.max(1.0).ln()).collect();
    Some(cost + std_dev(&log_areas))
}

/// The beam search of [`select_markers`] with the chain shape cost `cost`.
fn beam_select(
    candidates: &[Candidate],
    n: usize,
    start: ChainStart,
    previous: Option<&[Point2<f64>]>,
    cost: &dyn Fn(&[usize]) -> Option<f64>,
) -> Result<Vec<usize>, SelectError> {
    let round: Vec<usize> = (0..candidates.len())
        .filter(|&i| candidates[i].elongation <= MAX_ELONGATION)
        .collect();
    if round.len() < n || n < 3 {
        return Err(SelectError::TooFew {
            found: round.len(),
            expected: n,
        });
    }
    let mut beam: Vec<Partial> = round
        .iter()
        .map(|&i| Partial {
            chain: vec![i],
            cost: 0.0,
        })
        .collect();
    for _ in 1..n {
        let mut next: Vec<Partial> = Vec::new();
        for p in &beam {
            let last = candidates[p.chain[p.chain.len() - 1]].point;
            let mut options: Vec<usize> = round
                .iter()
                .copied()
                .filter(|j| !p.chain.contains(j))
                .collect();
            options.sort_by(|a, b| {
                (candidates[*a].point - last)
                    .norm()
                    .total_cmp(&(candidates[*b].point - last).norm())
            });
            if p.chain.len() == 1 {
                options.truncate(FIRST_STEP_NEIGHBOURS);
            }
            for j in options {
                let mut chain = p.chain.clone();
                chain.push(j);
                if let Some(cost) = cost(&chain) {
                    next.push(Partial { chain, cost });
                }
            }
        }
        next.sort_by(|a, b| a.cost.total_cmp(&b.cost));
        next.truncate(BEAM_WIDTH * 4);
        beam = next;
        if beam.is_empty() {
            return Err(SelectError::NoChain {
                found: candidates.len(),
                expected: n,
            });
        }
    }
    let total = |p: &Partial| -> f64 {
        let (d, _) = geometry(candidates, &p.chain);
        let spacing = mean(&d).max(1e-9);
        let mut cost = p.cost + 0.5 * start_cost(candidates, &p.chain, start, spacing);
        if let Some(prev) = previous.filter(|v| v.len() == p.chain.len()) {
            let moved: Vec<f64> = p
                .chain
                .iter()
                .zip(prev)
                .map(|(&i, q)| (candidates[i].point - q).norm())
                .collect();
            cost += 0.5 * mean(&moved) / spacing;
        }
        cost
    };
    beam.iter()
        .map(|p| (total(p), p))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, p)| p.chain.clone())
        .ok_or(SelectError::NoChain {
            found: candidates.len(),
            expected: n,
        })
}

/// Round candidates outside `chain` that continue it at either end, one after the other:
/// each the nearest unused candidate (of [`FIRST_STEP_NEIGHBOURS`]) whose addition keeps
/// every gate of a marker chain (alike size, the chain's spacing, its turn on the arc).
/// More than 0 after a pick of `n` markers means more markers are painted than `n`
/// (or a marker-like dot lies exactly where the next marker would be): only part of the
/// actuator is measured.
pub fn chain_continuation(candidates: &[Candidate], chain: &[usize]) -> usize {
    let mut count = 0;
    let mut chain = chain.to_vec();
    for _end in 0..2 {
        while chain.len() >= 2 {
            let last = candidates[chain[chain.len() - 1]].point;
            let mut options: Vec<usize> = (0..candidates.len())
                .filter(|j| candidates[*j].elongation <= MAX_ELONGATION && !chain.contains(j))
                .collect();
            options.sort_by(|a, b| {
                (candidates[*a].point - last)
                    .norm()
                    .total_cmp(&(candidates[*b].point - last).norm())
            });
            let next = options.into_iter().take(FIRST_STEP_NEIGHBOURS).find(|&j| {
                let mut longer = chain.clone();
                longer.push(j);
                shape_cost(candidates, &longer).is_some()
            });
            match next {
                Some(j) => {
                    chain.push(j);
                    count += 1;
                }
                None => break,
            }
        }
        // The other end: the chain reversed.
        chain.reverse();
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` markers on an arc of radius `r` from the clamp at the left, spacing `s`.
    fn arc(n: usize, r: f64, s: f64) -> Vec<Point2<f64>> {
        (0..n)
            .map(|k| {
                let t = s * (k as f64 + 0.5) / r;
                Point2::new(100.0 + r * t.sin(), 300.0 - r * (1.0 - t.cos()))
            })
            .collect()
    }

    fn disc(p: Point2<f64>) -> Candidate {
        Candidate {
            point: p,
            area_px: 50.0,
            elongation: 1.1,
        }
    }

    fn pick(cands: &[Candidate], start: ChainStart) -> Vec<Point2<f64>> {
        select_markers(cands, 8, start, None)
            .unwrap()
            .into_iter()
            .map(|i| cands[i].point)
            .collect()
    }

    #[test]
    fn the_markers_are_found_among_distractors_of_every_kind() {
        let m = arc(8, 200.0, 50.0);
        let left = ChainStart::Side(ClampSide::Left);
        let s = 50.0;
        let tip = m[7];
        let dir = (m[7] - m[6]).normalize();
        let normal = nalgebra::Vector2::new(-dir.y, dir.x);
        let cases: Vec<(&str, Vec<Candidate>)> = vec![
            (
                "a tube entering the clamp",
                vec![Candidate {
                    point: Point2::new(60.0, 320.0),
                    area_px: 900.0,
                    elongation: 8.0,
                }],
            ),
            ("a blob near the tip", vec![disc(tip + normal * 0.4 * s)]),
            (
                "a blob on the arc's extension",
                vec![disc(arc(9, 200.0, 50.0)[8])],
            ),
            (
                "a marker-sized dot 2 spacings away",
                vec![disc(tip + dir * 2.0 * s)],
            ),
            (
                "an LED and a label",
                vec![
                    disc(Point2::new(500.0, 50.0)),
                    Candidate {
                        point: Point2::new(300.0, 500.0),
                        area_px: 400.0,
                        elongation: 1.5,
                    },
                ],
            ),
        ];
        for (what, extra) in cases {
            let mut cands: Vec<Candidate> = m.iter().copied().map(disc).collect();
            cands.extend(extra);
            // Shuffle the order deterministically.
            cands.reverse();
            cands.rotate_left(3);
            assert_eq!(pick(&cands, left), m, "{what}");
        }
    }

    #[test]
    fn the_clamped_end_decides_between_two_equal_chains() {
        let m = arc(9, 200.0, 50.0);
        let cands: Vec<Candidate> = m.iter().copied().map(disc).collect();
        assert_eq!(pick(&cands, ChainStart::Side(ClampSide::Left)), m[..8]);
        assert_eq!(
            pick(&cands, ChainStart::Near(m[1])),
            m[1..].to_vec(),
            "near the previous clamped end"
        );
    }

    #[test]
    fn blobs_continuing_a_short_pick_are_counted_at_both_ends() {
        let m = arc(8, 200.0, 50.0);
        let mut cands: Vec<Candidate> = m.iter().copied().map(disc).collect();
        // Distractors that do not continue the chain: a tube, a blob beside the tip, a
        // dot two spacings beyond it, a far LED.
        let dir = (m[7] - m[6]).normalize();
        cands.push(Candidate {
            point: Point2::new(60.0, 320.0),
            area_px: 900.0,
            elongation: 8.0,
        });
        cands.push(disc(m[7] + nalgebra::Vector2::new(-dir.y, dir.x) * 20.0));
        cands.push(disc(m[7] + dir * 100.0));
        cands.push(disc(Point2::new(500.0, 50.0)));
        let left = ChainStart::Side(ClampSide::Left);
        for (n, more) in [(8, 0), (6, 2), (5, 3), (3, 5)] {
            let pick = select_markers(&cands, n, left, None).unwrap();
            assert_eq!(chain_continuation(&cands, &pick), more, "{n} of 8");
        }
        // Markers 2..7 picked: one continues at each end.
        assert_eq!(chain_continuation(&cands, &[1, 2, 3, 4, 5, 6]), 2);
        // A blob of ten times a marker's area is not alike (AREA_FACTOR): it ends the chain.
        let mut plain: Vec<Candidate> = m.iter().copied().map(disc).collect();
        plain[7].area_px = 500.0;
        assert_eq!(chain_continuation(&plain, &[0, 1, 2, 3, 4, 5]), 1);
    }

    /// Points at arc lengths `s` along arcs of `radii` (each `len` long) meeting
    /// tangentially, from (100, 300) heading right and turning up the image.
    fn segmented(radii: &[f64], len: f64, s: &[f64]) -> Vec<Point2<f64>> {
        s.iter()
            .map(|&s| {
                let (mut p, mut heading, mut s0) = (Point2::new(100.0, 300.0), 0.0f64, 0.0);
                for (k, &r) in radii.iter().enumerate() {
                    let ds = if k + 1 == radii.len() {
                        s - s0
                    } else {
                        (s - s0).min(len)
                    };
                    let h = heading + ds / r;
                    let q = Point2::new(
                        p.x + r * (h.sin() - heading.sin()),
                        p.y + r * (h.cos() - heading.cos()),
                    );
                    if k + 1 == radii.len() || s <= s0 + len {
                        return q;
                    }
                    (p, heading, s0) = (q, h, s0 + len);
                }
                p
            })
            .collect()
    }

    #[test]
    fn a_segmented_chain_is_picked_by_its_segments() {
        // Three segments of 200 px, radii 500, 250, 140 px; markers 80 px apart within a
        // segment, 40 px across a joint; a marker-sized dot off the chain, a tube.
        let s: Vec<f64> = (0..3)
            .flat_map(|k| [20.0, 100.0, 180.0].map(|v| 200.0 * k as f64 + v))
            .collect();
        let m = segmented(&[500.0, 250.0, 140.0], 200.0, &s);
        let mut cands: Vec<Candidate> = m.iter().copied().map(disc).collect();
        cands.push(disc(Point2::new(420.0, 80.0)));
        cands.push(disc(m[8] + nalgebra::Vector2::new(60.0, 10.0)));
        cands.push(Candidate {
            point: Point2::new(60.0, 300.0),
            area_px: 900.0,
            elongation: 8.0,
        });
        cands.rotate_left(4);
        let left = ChainStart::Side(ClampSide::Left);
        // One evenly spaced arc does not describe it (the "no chain of 9").
        assert!(select_markers(&cands, 9, left, None).is_err());
        let segs = [
            Segment { first: 0, last: 2 },
            Segment { first: 3, last: 5 },
            Segment { first: 6, last: 8 },
        ];
        let pick: Vec<Point2<f64>> = select_markers_in_segments(&cands, 9, &segs, left, None)
            .unwrap()
            .into_iter()
            .map(|i| cands[i].point)
            .collect();
        assert_eq!(pick, m);
        // Shared joint markers: segments [1..4], [4..7], [7..9] of evenly spaced markers.
        let s: Vec<f64> = (0..9).map(|k| 70.0 * k as f64).collect();
        let m = segmented(&[600.0, 260.0, 150.0], 210.0, &s);
        let mut cands: Vec<Candidate> = m.iter().copied().map(disc).collect();
        cands.push(disc(m[8] + nalgebra::Vector2::new(40.0, 30.0)));
        let segs = [
            Segment { first: 0, last: 3 },
            Segment { first: 3, last: 6 },
            Segment { first: 6, last: 8 },
        ];
        let pick = select_markers_in_segments(&cands, 9, &segs, left, None).unwrap();
        assert_eq!(pick, (0..9).collect::<Vec<_>>());
    }

    #[test]
    fn no_chain_is_an_error_not_a_guess() {
        let cands: Vec<Candidate> = (0..10)
            .map(|k| {
                disc(Point2::new(
                    (k * 37 % 11) as f64 * 40.0,
                    (k * 53 % 7) as f64 * 60.0,
                ))
            })
            .collect();
        assert!(select_markers(&cands, 8, ChainStart::Side(ClampSide::Left), None).is_err());
        let few: Vec<Candidate> = arc(5, 200.0, 50.0).into_iter().map(disc).collect();
        assert_eq!(
            select_markers(&few, 8, ChainStart::Side(ClampSide::Left), None),
            Err(SelectError::TooFew {
                found: 5,
                expected: 8
            })
        );
    }
}
