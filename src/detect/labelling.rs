//! Connected components of a mask (8-connected) and the hole fill of one component.
//!
//! Labelling is run-based (row runs joined with union-find), written here rather than
//! taken from `imageproc::region_labelling::connected_components` because a frame's mask
//! is almost empty: the run-based pass touches each mask row once and only the few
//! marker pixels after that, while a full-frame labelling allocates and writes a 32-bit
//! label for each of the two million pixels of a 1080p frame. The tests check it against
//! imageproc on random masks.

use image::GrayImage;

/// A horizontal run of mask pixels.
#[derive(Debug, Clone, Copy)]
pub(super) struct Run {
    pub(super) y: u32,
    pub(super) x0: u32,
    pub(super) x1: u32, // exclusive
    pub(super) label: usize,
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Runs of each row, labelled into 8-connected components; returns runs grouped by
/// component.
pub(super) fn components(mask: &GrayImage) -> Vec<Vec<Run>> {
    components_in_rows(mask, 0..mask.height())
}

/// [`components`] of the mask restricted to `rows` (ascending; the other rows must be
/// empty).
pub(super) fn components_in_rows(
    mask: &GrayImage,
    rows: impl IntoIterator<Item = u32>,
) -> Vec<Vec<Run>> {
    let w = mask.width();
    let raw = mask.as_raw();
    let mut runs: Vec<Run> = Vec::new();
    let mut parent: Vec<usize> = Vec::new();
    let mut prev: std::ops::Range<usize> = 0..0;
    let mut last_row: Option<u32> = None;
    for y in rows {
        if last_row.is_none_or(|l| l + 1 != y) {
            prev = 0..0;
        }
        last_row = Some(y);
        let row = &raw[(y * w) as usize..((y + 1) * w) as usize];
        let start = runs.len();
        let mut x = 0usize;
        while x < row.len() {
            match row[x..].iter().position(|&v| v != 0) {
                None => break,
                Some(off) => {
                    let x0 = x + off;
                    let len = row[x0..]
                        .iter()
                        .position(|&v| v == 0)
                        .unwrap_or(row.len() - x0);
                    let label = parent.len();
                    parent.push(label);
                    runs.push(Run {
                        y,
                        x0: x0 as u32,
                        x1: (x0 + len) as u32,
                        label,
                    });
                    x = x0 + len;
                }
            }
        }
        // Join with overlapping runs of the previous row (8-connectivity: touching
        // diagonally counts).
        let cur = start..runs.len();
        let mut j = prev.start;
        for i in cur.clone() {
            let (a0, a1) = (runs[i].x0, runs[i].x1);
            while j < prev.end && runs[j].x1 < a0 {
                j += 1;
            }
            let mut k = j;
            while k < prev.end && runs[k].x0 <= a1 {
                let (ra, rb) = (
                    find(&mut parent, runs[i].label),
                    find(&mut parent, runs[k].label),
                );
                if ra != rb {
                    parent[ra.max(rb)] = ra.min(rb);
                }
                k += 1;
            }
        }
        prev = cur;
    }
    let mut groups: std::collections::BTreeMap<usize, Vec<Run>> = std::collections::BTreeMap::new();
    for r in &runs {
        let root = find(&mut parent, r.label);
        groups.entry(root).or_default().push(*r);
    }
    groups.into_values().collect()
}

/// Filled pixel mask of one component in its bounding box (holes filled when asked).
pub(super) fn filled_component(runs: &[Run], fill: bool) -> (u32, u32, u32, u32, Vec<bool>) {
    let x0 = runs.iter().map(|r| r.x0).min().unwrap_or(0);
    let x1 = runs.iter().map(|r| r.x1).max().unwrap_or(0);
    let y0 = runs.iter().map(|r| r.y).min().unwrap_or(0);
    let y1 = runs.iter().map(|r| r.y).max().unwrap_or(0) + 1;
    let (bw, bh) = ((x1 - x0) as usize, (y1 - y0) as usize);
    let mut inside = vec![false; bw * bh];
    for r in runs {
        let row = (r.y - y0) as usize * bw;
        for x in r.x0..r.x1 {
            inside[row + (x - x0) as usize] = true;
        }
    }
    if fill {
        // Background reachable from the box border stays background; the rest are holes
        // (4-connected background, the complement of 8-connected foreground).
        let mut outside = vec![false; bw * bh];
        let mut stack: Vec<(usize, usize)> = Vec::new();
        for x in 0..bw {
            stack.push((x, 0));
            stack.push((x, bh - 1));
        }
        for y in 0..bh {
            stack.push((0, y));
            stack.push((bw - 1, y));
        }
        while let Some((x, y)) = stack.pop() {
            let i = y * bw + x;
            if inside[i] || outside[i] {
                continue;
            }
            outside[i] = true;
            if x > 0 {
                stack.push((x - 1, y));
            }
            if x + 1 < bw {
                stack.push((x + 1, y));
            }
            if y > 0 {
                stack.push((x, y - 1));
            }
            if y + 1 < bh {
                stack.push((x, y + 1));
            }
        }
        for (v, o) in inside.iter_mut().zip(&outside) {
            *v = !*o;
        }
    }
    (x0, y0, x1, y1, inside)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn run_labelling_matches_imageproc(seed: u64, density in 0.05f64..0.6) {
            let mut rng = crate::render::rng::SplitMix64::new(seed);
            let m = GrayImage::from_fn(40, 30, |_, _| image::Luma([if rng.uniform() < density { 255 } else { 0 }]));
            let ours = components(&m);
            let labels = imageproc::region_labelling::connected_components(&m, imageproc::region_labelling::Connectivity::Eight, image::Luma([0u8]));
            let n_ref = labels.pixels().map(|p| p[0]).max().unwrap_or(0) as usize;
            prop_assert_eq!(ours.len(), n_ref);
            // Every component of ours has one imageproc label, and sizes agree.
            let mut sizes_ours: Vec<u32> = ours.iter().map(|c| c.iter().map(|r| r.x1 - r.x0).sum()).collect();
            let mut sizes_ref = vec![0u32; n_ref + 1];
            for p in labels.pixels() { sizes_ref[p[0] as usize] += 1; }
            let mut sizes_ref: Vec<u32> = sizes_ref[1..].to_vec();
            sizes_ours.sort();
            sizes_ref.sort();
            prop_assert_eq!(sizes_ours, sizes_ref);
        }
    }
}
