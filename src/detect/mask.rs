//! The marker mask of a frame: the band adjusted to the frame's exposure, then the mask,
//! over the whole frame or only around the hits of a coarse pass, into a buffer reused
//! from frame to frame.

use image::{GrayImage, RgbImage};
use rayon::prelude::*;

use super::colour::{is_marker_colour, HsvThresholds};
use super::pixels::{MarkerTest, PixelSource, COARSE_STEP};

/// White level of a normally exposed frame (the sheet behind the actuator), 8-bit.
pub const NOMINAL_WHITE: f64 = 230.0;
/// Lowest `v_min` the exposure adjustment goes to (below it sensor noise passes for
/// colour).
pub const MIN_ADJUSTED_V: u8 = 20;
/// Samples per side of the grid the white level is read on.
pub const EXPOSURE_GRID: u32 = 48;

/// The thresholds for this frame: `v_min` (and a dark marker's `v_max`) scaled by the
/// frame's white level (the 90th percentile of max(R, G, B) on a coarse grid) over
/// [`NOMINAL_WHITE`] when the frame is darker than that, `v_min` never below
/// [`MIN_ADJUSTED_V`]. A coloured marker in a dim frame keeps its hue and saturation but
/// loses value, and a dark marker's value falls with the light too; the white sheet tells
/// how much light there is.
pub fn exposure_adjusted<S: PixelSource>(img: &S, t: &HsvThresholds) -> HsvThresholds {
    let (w, h) = img.dimensions();
    if w == 0 || h == 0 {
        return *t;
    }
    let mut levels: Vec<u8> = Vec::with_capacity((EXPOSURE_GRID * EXPOSURE_GRID) as usize);
    for j in 0..EXPOSURE_GRID {
        for i in 0..EXPOSURE_GRID {
            let (x, y) = (
                ((2 * i + 1) * w / (2 * EXPOSURE_GRID)).min(w - 1),
                ((2 * j + 1) * h / (2 * EXPOSURE_GRID)).min(h - 1),
            );
            let p = img.rgb(x, y);
            levels.push(p[0].max(p[1]).max(p[2]));
        }
    }
    levels.sort_unstable();
    let white = levels[levels.len() * 9 / 10] as f64;
    if white >= NOMINAL_WHITE {
        return *t;
    }
    let scaled = |v: u8| (v as f64 * white / NOMINAL_WHITE).round() as u8;
    HsvThresholds {
        v_min: scaled(t.v_min).max(MIN_ADJUSTED_V).min(t.v_min),
        v_max: if t.v_max == 255 { 255 } else { scaled(t.v_max) },
        ..*t
    }
}

/// Marker mask (255 in the band, 0 not) of an RGB frame, rows in parallel.
pub fn mask_from_rgb(img: &RgbImage, t: &HsvThresholds) -> GrayImage {
    let (w, h) = img.dimensions();
    let mut mask = GrayImage::new(w, h);
    let src = img.as_raw();
    mask.as_mut()
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(y, row)| {
            let s = &src[y * w as usize * 3..(y + 1) * w as usize * 3];
            for (x, m) in row.iter_mut().enumerate() {
                let p = &s[x * 3..x * 3 + 3];
                *m = if is_marker_colour(p[0], p[1], p[2], t) {
                    255
                } else {
                    0
                };
            }
        });
    mask
}

/// Margin added around coarse hits before the full-resolution pass, px.
pub const COARSE_MARGIN: u32 = 3;

/// The same mask as [`mask_from_rgb`], computed only where it can be non-zero: a coarse
/// pass tests every second pixel of every second row, and the full test runs only in
/// boxes around the coarse hits (grown by [`COARSE_MARGIN`]). A red region containing a
/// 2x2 block of red pixels is always found; smaller ones (isolated specks, which the
/// minimum area drops anyway) may be missed. On a 1080p frame with 8 markers this tests
/// about a quarter of the pixels.
pub fn mask_from_rgb_sparse<S: PixelSource>(img: &S, t: &HsvThresholds) -> GrayImage {
    let mut buf = MaskBuffer::default();
    mask_from_rgb_sparse_into(img, t, &mut buf);
    buf.mask
}

/// A red mask reused from frame to frame, with the rows its last frame may have set: the
/// next frame clears, and labelling scans, only those rows instead of the whole frame
/// (on a 4K frame a full clear and scan cost ~5% of the decode time).
#[derive(Debug, Clone)]
pub struct MaskBuffer {
    pub(super) mask: GrayImage,
    /// Rows that may hold set pixels, ascending.
    pub(super) rows: Vec<u32>,
}

impl Default for MaskBuffer {
    fn default() -> Self {
        Self {
            mask: GrayImage::new(0, 0),
            rows: Vec::new(),
        }
    }
}

impl MaskBuffer {
    /// The mask of the last frame (255 red, 0 not).
    pub fn mask(&self) -> &GrayImage {
        &self.mask
    }
}

/// [`mask_from_rgb_sparse`] into a reused mask buffer (resized, or cleared where the last
/// frame set it).
pub fn mask_from_rgb_sparse_into<S: PixelSource>(img: &S, t: &HsvThresholds, buf: &mut MaskBuffer) {
    let (w, h) = img.dimensions();
    if buf.mask.dimensions() != (w, h) {
        buf.mask = GrayImage::new(w, h);
    } else {
        for &y in &buf.rows {
            let i = (y * w) as usize;
            buf.mask.as_mut()[i..i + w as usize].fill(0);
        }
    }
    buf.rows.clear();
    let t = &MarkerTest::new(t);
    let mask = &mut buf.mask;
    // Coarse rows in parallel: x ranges of hits, as (row, x0, x1) in full-res px.
    let rows: Vec<(u32, Vec<(u32, u32)>)> = (0..h.div_ceil(COARSE_STEP))
        .into_par_iter()
        .filter_map(|cy| {
            let y = cy * COARSE_STEP;
            let mut hits = Vec::new();
            img.coarse_row_hits(y, t, &mut hits);
            let mut spans: Vec<(u32, u32)> = Vec::new();
            for x in hits {
                let x0 = x.saturating_sub(COARSE_MARGIN);
                let x1 = (x + COARSE_MARGIN + 1).min(w);
                match spans.last_mut() {
                    Some(last) if last.1 >= x0 => last.1 = x1,
                    _ => spans.push((x0, x1)),
                }
            }
            (!spans.is_empty()).then_some((y, spans))
        })
        .collect();
    let mut touched = vec![false; h as usize];
    for (y, spans) in rows {
        let ya = y.saturating_sub(COARSE_MARGIN);
        let yb = (y + COARSE_MARGIN + 1).min(h);
        for yy in ya..yb {
            touched[yy as usize] = true;
            for &(x0, x1) in &spans {
                for x in x0..x1 {
                    if img.is_marker_at(x, yy, t) {
                        mask.put_pixel(x, yy, image::Luma([255]));
                    }
                }
            }
        }
    }
    buf.rows.extend((0..h).filter(|&y| touched[y as usize]));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::testing::disc;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        /// Discs of radius >= 2.5 px always hold a 2x2 block of fully red pixels, which
        /// the coarse grid cannot miss (smaller regions may be missed, as documented).
        #[test]
        fn sparse_mask_equals_full_mask_for_discs(seed: u64) {
            let mut rng = crate::render::rng::SplitMix64::new(seed);
            let discs: Vec<(f64, f64, f64)> = (0..6)
                .map(|_| (rng.range(0.0, 120.0), rng.range(0.0, 90.0), rng.range(2.5, 9.0)))
                .collect();
            let img = disc(120, 90, &discs);
            let t = HsvThresholds::default();
            prop_assert_eq!(mask_from_rgb_sparse(&img, &t), mask_from_rgb(&img, &t));
        }
    }
}
