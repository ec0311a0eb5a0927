//! Marker ordering: the chain of markers from the clamped end to the tip, by the minimum
//! spanning tree of the points.

use nalgebra::Point2;

use super::settings::ClampSide;

/// Where the marker chain starts (the clamped end).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ChainStart {
    /// The end of the chain nearest this image side (first frame of a session).
    Side(ClampSide),
    /// The end of the chain nearest this point: the clamped-end marker of an earlier
    /// frame. Needed once an actuator curls past 180 degrees and its tip comes nearer to
    /// the clamp side than the clamped end.
    Near(Point2<f64>),
}

/// Orders marker points from the clamped end to the tip. The markers form a chain along
/// the actuator; its minimum spanning tree is that chain (a path) and its two ends are
/// the clamped end and the tip; `start` says which is which. When the tree is not a path
/// (irregular spacing), a nearest-neighbour walk from the chosen end is used.
pub fn order_markers(points: &[Point2<f64>], start: ChainStart) -> Vec<Point2<f64>> {
    order_marker_indices(points, start)
        .into_iter()
        .map(|i| points[i])
        .collect()
}

/// [`order_markers`] as indices into `points`.
pub fn order_marker_indices(points: &[Point2<f64>], start: ChainStart) -> Vec<usize> {
    let n = points.len();
    if n < 3 {
        let mut v: Vec<usize> = (0..n).collect();
        v.sort_by(|a, b| chain_key(&points[*a], start).total_cmp(&chain_key(&points[*b], start)));
        return v;
    }
    // Prim's algorithm, O(n²): n is the marker count.
    let d = |i: usize, j: usize| (points[i] - points[j]).norm_squared();
    let mut in_tree = vec![false; n];
    let mut best = vec![f64::INFINITY; n];
    let mut link = vec![0usize; n];
    let mut adj: Vec<Vec<usize>> = vec![vec![]; n];
    in_tree[0] = true;
    for j in 1..n {
        best[j] = d(0, j);
    }
    for _ in 1..n {
        let Some(k) = (0..n)
            .filter(|j| !in_tree[*j])
            .min_by(|a, b| best[*a].total_cmp(&best[*b]))
        else {
            break;
        };
        in_tree[k] = true;
        adj[k].push(link[k]);
        adj[link[k]].push(k);
        for j in 0..n {
            if !in_tree[j] && d(k, j) < best[j] {
                best[j] = d(k, j);
                link[j] = k;
            }
        }
    }
    let ends: Vec<usize> = (0..n).filter(|i| adj[*i].len() == 1).collect();
    let is_path = ends.len() == 2 && adj.iter().all(|a| a.len() <= 2);
    let candidates: Vec<usize> = if is_path { ends } else { (0..n).collect() };
    let first = candidates
        .iter()
        .copied()
        .min_by(|a, b| chain_key(&points[*a], start).total_cmp(&chain_key(&points[*b], start)))
        .unwrap_or(0);
    let mut order = vec![first];
    let mut seen = vec![false; n];
    seen[first] = true;
    while order.len() < n {
        let last = order[order.len() - 1];
        let next = if is_path {
            adj[last].iter().copied().find(|j| !seen[*j])
        } else {
            (0..n)
                .filter(|j| !seen[*j])
                .min_by(|a, b| d(last, *a).total_cmp(&d(last, *b)))
        };
        match next {
            Some(j) => {
                seen[j] = true;
                order.push(j);
            }
            None => break,
        }
    }
    order
}

/// Smaller is nearer the chain's start.
fn chain_key(p: &Point2<f64>, start: ChainStart) -> f64 {
    match start {
        ChainStart::Side(ClampSide::Left) => p.x,
        ChainStart::Side(ClampSide::Right) => -p.x,
        ChainStart::Side(ClampSide::Top) => p.y,
        ChainStart::Side(ClampSide::Bottom) => -p.y,
        ChainStart::Near(q) => (p - q).norm_squared(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ordering_follows_a_curled_actuator() {
        // Markers on a 270° arc leaving the clamp at (50, 100) towards +x and curling up
        // and back: the tip ends left of the clamped end, so only tracking the clamped
        // end (not the clamp side) orders it right.
        let pts: Vec<Point2<f64>> = (0..8)
            .map(|i| {
                let t = 270f64.to_radians() * i as f64 / 7.0;
                Point2::new(50.0 + 50.0 * t.sin(), 50.0 + 50.0 * t.cos())
            })
            .collect();
        let mut shuffled = pts.clone();
        shuffled.reverse();
        shuffled.swap(1, 5);
        assert_eq!(
            order_markers(&shuffled, ChainStart::Near(Point2::new(48.0, 101.0))),
            pts
        );
        // A gentle bend: the clamp side suffices, and sorting would too.
        let gentle: Vec<Point2<f64>> = (0..8)
            .map(|i| {
                let t = 60f64.to_radians() * i as f64 / 7.0;
                Point2::new(50.0 + 100.0 * t.sin(), 100.0 * t.cos())
            })
            .collect();
        let mut s2 = gentle.clone();
        s2.swap(0, 6);
        assert_eq!(
            order_markers(&s2, ChainStart::Side(ClampSide::Left)),
            gentle
        );
    }
}
