//! Blobs of a mask: components filtered by area, with sub-pixel centroids.
//!
//! Centroids are coverage-weighted: over the blob's box grown by [`RING_PX`], each pixel
//! counts by where its luma lies between the background's and the marker's (filled
//! holes count 1), so partly covered edge pixels contribute their fraction. This removes
//! most of the pixel-quantization error of a binary centroid on small (3 mm, ~8 px)
//! markers. Luma rather than redness: video is 4:2:0, its chroma has half the
//! resolution, and redness-weighted centroids of H.264 frames were measured to jump by
//! ~0.2 px with the marker's position on the chroma grid (0.4% radius bias at R = 200
//! mm); redness is the fallback when a marker is not darker or brighter than its
//! surroundings.

use image::GrayImage;
use nalgebra::Point2;
use serde::{Deserialize, Serialize};

use super::labelling::{components, components_in_rows, filled_component, Run};
use super::mask::MaskBuffer;
use super::pixels::PixelSource;
use super::settings::DetectSettings;

/// Smallest difference of the coverage cue (luma or redness, 0..255) between a marker
/// and its surroundings for coverage weighting; below it, binary centroids are used.
pub const MIN_COVERAGE_CONTRAST: f64 = 30.0;

/// A marker candidate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Blob {
    /// Sub-pixel centroid, px.
    pub centroid: Point2<f64>,
    /// Area of the filled blob, px.
    pub area_px: u32,
    /// Bounding box: min x, min y, max x, max y (inclusive), px.
    pub bbox: [u32; 4],
}

/// Blobs of a mask and what was dropped.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Detection {
    /// Kept blobs (not ordered).
    pub blobs: Vec<Blob>,
    /// Blobs smaller than the minimum area.
    pub specks: usize,
    /// Blobs larger than the maximum area.
    pub too_large: usize,
}

/// Redness r - max(g, b) of a pixel (carried by chroma).
#[inline]
fn redness(p: &image::Rgb<u8>) -> f64 {
    p[0] as f64 - (p[1].max(p[2])) as f64
}

/// Chroma max(r, g, b) - min(r, g, b) of a pixel: the fallback cue of markers of other
/// colours than red.
#[inline]
fn chroma(p: &image::Rgb<u8>) -> f64 {
    p[0].max(p[1]).max(p[2]) as f64 - p[0].min(p[1]).min(p[2]) as f64
}

/// Luma (Rec. 601) of a pixel: full resolution in 4:2:0 video, where chroma (and so
/// redness) has half the resolution in both directions.
#[inline]
fn luma(p: &image::Rgb<u8>) -> f64 {
    0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64
}

/// Pixels of the ring around a blob used to weigh edge coverage.
pub const RING_PX: u32 = 2;

/// Levels of a cue (`value` of a pixel) for coverage weighting: the background around a
/// blob (median of the surrounding ring), the fully covered marker (median of the
/// blob's inner half, the pixels farthest from the background level) and the coverage
/// below which a pixel is taken as background noise (2 robust sigmas of the ring, 1.4826
/// x its median absolute deviation, over the contrast); `None` when the levels differ by
/// less than [`MIN_COVERAGE_CONTRAST`].
fn cue_levels<S: PixelSource>(
    img: &S,
    inside: &[bool],
    bbox: (u32, u32, u32, u32),
    value: fn(&image::Rgb<u8>) -> f64,
) -> Option<(f64, f64, f64)> {
    let (x0, y0, x1, y1) = bbox;
    let (w, h) = img.dimensions();
    let bw = (x1 - x0) as usize;
    let mut inner: Vec<f64> = Vec::new();
    let mut ring: Vec<f64> = Vec::new();
    let (ex0, ey0) = (x0.saturating_sub(RING_PX), y0.saturating_sub(RING_PX));
    let (ex1, ey1) = ((x1 + RING_PX).min(w), (y1 + RING_PX).min(h));
    for y in ey0..ey1 {
        for x in ex0..ex1 {
            let in_box = x >= x0 && x < x1 && y >= y0 && y < y1;
            let v = value(&img.rgb(x, y));
            if in_box && inside[(y - y0) as usize * bw + (x - x0) as usize] {
                inner.push(v);
            } else if !in_box {
                ring.push(v);
            }
        }
    }
    if inner.is_empty() || ring.is_empty() {
        return None;
    }
    ring.sort_by(f64::total_cmp);
    let bg = ring[ring.len() / 2];
    inner.sort_by(|a, b| (b - bg).abs().total_cmp(&(a - bg).abs()));
    let core = &inner[..inner.len().div_ceil(2)];
    let full = core[core.len() / 2];
    let mut dev: Vec<f64> = ring.iter().map(|v| (v - bg).abs()).collect();
    dev.sort_by(f64::total_cmp);
    let floor = 2.0 * 1.4826 * dev[dev.len() / 2] / (full - bg).abs().max(1e-9);
    ((full - bg).abs() > MIN_COVERAGE_CONTRAST).then_some((bg, full, floor.min(0.5)))
}

/// Blobs of a red mask, with coverage-weighted centroids from `img` (the frame the mask
/// was made from; pass `None` for plain binary centroids).
pub fn blobs_from_mask<S: PixelSource>(
    mask: &GrayImage,
    img: Option<&S>,
    settings: &DetectSettings,
) -> Detection {
    blobs_from_components(mask, components(mask), img, settings)
}

/// [`blobs_from_mask`] of a [`MaskBuffer`], labelling only the rows its frame set.
pub fn blobs_from_buffer<S: PixelSource>(
    buf: &MaskBuffer,
    img: Option<&S>,
    settings: &DetectSettings,
) -> Detection {
    let comps = components_in_rows(&buf.mask, buf.rows.iter().copied());
    blobs_from_components(&buf.mask, comps, img, settings)
}

fn blobs_from_components<S: PixelSource>(
    mask: &GrayImage,
    comps: Vec<Vec<Run>>,
    img: Option<&S>,
    settings: &DetectSettings,
) -> Detection {
    let mut out = Detection::default();
    let (w, h) = mask.dimensions();
    for runs in comps {
        let raw_area: u32 = runs.iter().map(|r| r.x1 - r.x0).sum();
        if raw_area > settings.max_area_px {
            out.too_large += 1;
            continue;
        }
        let (x0, y0, x1, y1, inside) = filled_component(&runs, settings.fill_holes);
        let bw = (x1 - x0) as usize;
        let area = inside.iter().filter(|v| **v).count() as u32;
        if area < settings.min_area_px {
            out.specks += 1;
            continue;
        }
        let (mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0);
        let mut add = |x: u32, y: u32, c: f64| {
            sw += c;
            sx += c * x as f64;
            sy += c * y as f64;
        };
        // Coverage cue: luma (full resolution even in 4:2:0 video) when the marker
        // stands out from its surroundings in brightness, else redness (chroma for
        // markers of other colours).
        let colour_cue: fn(&image::Rgb<u8>) -> f64 = if settings.hsv.holds_red() {
            redness
        } else {
            chroma
        };
        let cue = img.and_then(|img| {
            let bbox = (x0, y0, x1, y1);
            cue_levels(img, &inside, bbox, luma)
                .map(|l| (img, l, luma as fn(&image::Rgb<u8>) -> f64))
                .or_else(|| {
                    cue_levels(img, &inside, bbox, colour_cue).map(|l| (img, l, colour_cue))
                })
        });
        match cue {
            Some((img, (bg, full, floor), value)) => {
                // Coverage over the blob's box grown by the ring; filled holes count fully.
                let (ex0, ey0) = (x0.saturating_sub(RING_PX), y0.saturating_sub(RING_PX));
                let (ex1, ey1) = ((x1 + RING_PX).min(w), (y1 + RING_PX).min(h));
                for y in ey0..ey1 {
                    for x in ex0..ex1 {
                        let in_box = x >= x0 && x < x1 && y >= y0 && y < y1;
                        let filled = in_box && inside[(y - y0) as usize * bw + (x - x0) as usize];
                        let c = if filled && mask.get_pixel(x, y)[0] == 0 {
                            1.0
                        } else {
                            let c = ((value(&img.rgb(x, y)) - bg) / (full - bg)).clamp(0.0, 1.0);
                            // Background pixels whose noise reads as coverage count 0.
                            if c < floor && !filled {
                                0.0
                            } else {
                                c
                            }
                        };
                        add(x, y, c);
                    }
                }
            }
            _ => {
                for (i, v) in inside.iter().enumerate() {
                    if *v {
                        add((i % bw) as u32 + x0, (i / bw) as u32 + y0, 1.0);
                    }
                }
            }
        }
        out.blobs.push(Blob {
            centroid: Point2::new(sx / sw, sy / sw),
            area_px: area,
            bbox: [x0, y0, x1 - 1, y1 - 1],
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::colour::HsvThresholds;
    use crate::detect::mask::{mask_from_rgb, mask_from_rgb_sparse_into};
    use crate::detect::testing::disc;
    use image::RgbImage;

    #[test]
    fn a_reused_mask_buffer_forgets_the_last_frame() {
        let t = HsvThresholds::default();
        let s = DetectSettings::default();
        let first = disc(120, 90, &[(20.0, 20.0, 6.0), (90.0, 70.0, 5.0)]);
        let second = disc(120, 90, &[(60.0, 45.0, 7.0), (90.0, 72.0, 4.0)]);
        let mut buf = MaskBuffer::default();
        mask_from_rgb_sparse_into(&first, &t, &mut buf);
        assert_eq!(blobs_from_buffer(&buf, Some(&first), &s).blobs.len(), 2);
        mask_from_rgb_sparse_into(&second, &t, &mut buf);
        assert_eq!(buf.mask(), &mask_from_rgb(&second, &t));
        assert_eq!(
            blobs_from_buffer(&buf, Some(&second), &s),
            blobs_from_mask(&mask_from_rgb(&second, &t), Some(&second), &s)
        );
    }

    #[test]
    fn holes_are_filled_and_specks_dropped() {
        let mut m = GrayImage::new(12, 10);
        for y in 2..7 {
            for x in 2..7 {
                m.put_pixel(x, y, image::Luma([255]));
            }
        }
        m.put_pixel(4, 4, image::Luma([0])); // a hole (highlight)
        m.put_pixel(10, 8, image::Luma([255])); // a speck
        let s = DetectSettings {
            min_area_px: 3,
            ..Default::default()
        };
        let d = blobs_from_mask::<RgbImage>(&m, None, &s);
        assert_eq!(d.blobs.len(), 1);
        assert_eq!(d.specks, 1);
        assert_eq!(d.blobs[0].area_px, 25);
        assert_eq!(d.blobs[0].centroid, Point2::new(4.0, 4.0));
        assert_eq!(d.blobs[0].bbox, [2, 2, 6, 6]);
        let no_fill = DetectSettings {
            fill_holes: false,
            ..s
        };
        assert_eq!(
            blobs_from_mask::<RgbImage>(&m, None, &no_fill).blobs[0].area_px,
            24
        );
        let small_max = DetectSettings {
            max_area_px: 10,
            ..s
        };
        assert_eq!(
            blobs_from_mask::<RgbImage>(&m, None, &small_max).too_large,
            1
        );
    }
}
