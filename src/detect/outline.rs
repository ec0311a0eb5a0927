//! Markerless detection (`[detect] mode = "outline"`): the actuator's body segmented by
//! its colour band, the largest blob taken, and its outer boundary as an ordered loop of
//! sub-pixel points (crack midpoints: halfway between a body pixel and its outside
//! 4-neighbour, where a threshold halfway between body and background puts the edge).
//!
//! The loop is cut into the actuator's edges in the pipeline, after undistortion
//! (`crate::pipeline::outline`): there lengths are in mm and the clamp is known.

use std::collections::HashSet;

use image::{GrayImage, Luma};
use imageproc::contours::{find_contours, BorderType};
use imageproc::region_labelling::{connected_components, Connectivity};
use nalgebra::Point2;
use serde::{Deserialize, Serialize};

use super::colour::{any_case, is_marker_colour, HsvThresholds};
use super::pixels::PixelSource;

/// How a frame becomes points on the actuator (`[detect] mode`, any case).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DetectMode {
    /// Painted dots: their centroids (the default).
    #[default]
    Dots,
    /// No dots: the body's strain-limited edge.
    Outline,
}

impl<'de> Deserialize<'de> for DetectMode {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        any_case(
            d,
            "mode",
            &[("dots", DetectMode::Dots), ("outline", DetectMode::Outline)],
        )
    }
}

/// Default body band: pale, slightly warm silicone (hue 5..40, S >= 16, V >= 60) in
/// front of a white sheet (S below ~10) and a dark or grey clamp.
pub const DEFAULT_OUTLINE_BAND: HsvThresholds = HsvThresholds {
    hue_min: 5,
    hue_max: 40,
    s_min: 16,
    v_min: 60,
    v_max: 255,
};
/// Default length of the body next to the clamp left out of the fit, mm: where the
/// clamp plates press the body and its edge is not free.
pub const DEFAULT_OUTLINE_CLAMP_MM: f64 = 5.0;
/// Smallest body blob, px: below it there is no actuator in the band.
pub const MIN_BODY_AREA_PX: usize = 400;
/// A second blob at least this share of the largest one's area makes the body
/// ambiguous.
pub const SECOND_BLOB_SHARE: f64 = 0.5;
/// Largest share of the frame the body may cover: more is the background in the band.
pub const MAX_BODY_SHARE: f64 = 0.6;

/// The outline mode's settings (`[detect] outline_*` keys).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutlineSettings {
    /// The body's colour band.
    pub band: HsvThresholds,
    /// Signed distance from the fitted edge to the line the radius is reported on, mm,
    /// positive into the body (a dot line's height above the strain-limited face).
    pub offset_mm: f64,
    /// Body length next to the clamp left out of the fit, mm.
    pub clamp_mm: f64,
}

impl Default for OutlineSettings {
    fn default() -> Self {
        Self {
            band: DEFAULT_OUTLINE_BAND,
            offset_mm: 0.0,
            clamp_mm: DEFAULT_OUTLINE_CLAMP_MM,
        }
    }
}

/// Why a frame's body outline could not be taken (one line each, with what to do).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OutlineError {
    /// Nothing large in the band.
    #[error("outline: no body in the outline colour band (largest blob {area_px} px): set [detect] outline_hue_min/outline_hue_max/outline_s_min to the actuator's colour")]
    NoBody {
        /// Area of the largest blob, px.
        area_px: usize,
    },
    /// The band holds the background.
    #[error("outline: the body blob touches every frame border or covers {share_pct:.0}% of the frame: the background is in the outline colour band; narrow outline_s_min/outline_hue_min/outline_hue_max in [detect]")]
    Background {
        /// Share of the frame covered, %.
        share_pct: f64,
    },
    /// Two blobs alike in size.
    #[error("outline: two blobs of the body's colour ({largest} and {second} px): the body is not separated from another object; move it out of view or narrow the outline colour band")]
    TwoBodies {
        /// Largest blob, px.
        largest: usize,
        /// Second largest, px.
        second: usize,
    },
    /// The edge kept is too short to fit.
    #[error("outline: only {found} edge points on the free strain-limited edge ({needed} needed): check outline_clamp_mm and that the whole actuator is in view")]
    TooFewEdgePoints {
        /// Points found.
        found: usize,
        /// Points needed.
        needed: usize,
    },
}

/// The body mask: 255 where a pixel is in `band`, 3x3 median-filtered (single noisy
/// pixels at the edge neither join nor notch the body).
pub fn body_mask<S: PixelSource>(img: &S, band: &HsvThresholds) -> GrayImage {
    let (w, h) = img.dimensions();
    let raw = GrayImage::from_fn(w, h, |x, y| {
        let p = img.rgb(x, y).0;
        Luma([if is_marker_colour(p[0], p[1], p[2], band) {
            255
        } else {
            0
        }])
    });
    imageproc::filter::median_filter(&raw, 1, 1)
}

/// The largest blob's outer boundary: crack midpoints in order around it (px, pixel
/// centres at integers), and its area.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyOutline {
    /// Closed loop of boundary points, raw frame px.
    pub boundary: Vec<Point2<f64>>,
    /// Blob area, px.
    pub area_px: usize,
}

/// The outline of the largest 8-connected blob of `mask`, refused when the blob is too
/// small, is the background, or has a rival of alike size.
pub fn body_outline(mask: &GrayImage) -> Result<BodyOutline, OutlineError> {
    let (w, h) = mask.dimensions();
    let labels = connected_components(mask, Connectivity::Eight, Luma([0u8]));
    let mut area: Vec<usize> = vec![];
    // Which frame borders each label touches (bits: top, bottom, left, right).
    let mut borders: Vec<u8> = vec![];
    for (x, y, l) in labels.enumerate_pixels() {
        let l = l[0] as usize;
        if l == 0 {
            continue;
        }
        if area.len() <= l {
            area.resize(l + 1, 0);
            borders.resize(l + 1, 0);
        }
        area[l] += 1;
        let b = (y == 0) as u8 | ((y + 1 == h) as u8) << 1 | ((x == 0) as u8) << 2;
        borders[l] |= b | ((x + 1 == w) as u8) << 3;
    }
    let mut order: Vec<usize> = (1..area.len()).filter(|&l| area[l] > 0).collect();
    order.sort_by_key(|&l| std::cmp::Reverse(area[l]));
    let Some(&body) = order.first() else {
        return Err(OutlineError::NoBody { area_px: 0 });
    };
    let largest = area[body];
    if largest < MIN_BODY_AREA_PX {
        return Err(OutlineError::NoBody { area_px: largest });
    }
    let share = largest as f64 / (w as f64 * h as f64);
    if borders[body] == 0b1111 || share > MAX_BODY_SHARE {
        return Err(OutlineError::Background {
            share_pct: 100.0 * share,
        });
    }
    if let Some(&second) = order.get(1) {
        if area[second] as f64 >= SECOND_BLOB_SHARE * largest as f64 {
            return Err(OutlineError::TwoBodies {
                largest,
                second: area[second],
            });
        }
    }
    let only = GrayImage::from_fn(w, h, |x, y| {
        Luma([if labels.get_pixel(x, y)[0] as usize == body {
            255
        } else {
            0
        }])
    });
    let inside = |x: i64, y: i64| {
        x >= 0
            && y >= 0
            && x < w as i64
            && y < h as i64
            && only.get_pixel(x as u32, y as u32)[0] != 0
    };
    let mut contour = find_contours::<i64>(&only)
        .into_iter()
        .filter(|c| c.border_type == BorderType::Outer)
        .max_by_key(|c| c.points.len())
        .map(|c| c.points)
        .unwrap_or_default();
    // Walked clockwise on screen (positive shoelace with y down), so a pixel's cracks
    // follow the walk in clockwise order.
    let n = contour.len();
    let area2: i64 = (0..n)
        .map(|i| {
            let (a, b) = (contour[i], contour[(i + 1) % n]);
            a.x * b.y - b.x * a.y
        })
        .sum();
    if area2 < 0 {
        contour.reverse();
    }
    // The 8 neighbours clockwise from up; the cracks are the even ones.
    const AROUND: [(i64, i64); 8] = [
        (0, -1),
        (1, -1),
        (1, 0),
        (1, 1),
        (0, 1),
        (-1, 1),
        (-1, 0),
        (-1, -1),
    ];
    // Each boundary pixel gives the midpoints of its cracks with the outside, once each:
    // clockwise from the neighbour the walk came from.
    let mut seen: HashSet<(i64, i64, usize)> = HashSet::new();
    let mut boundary = Vec::with_capacity(n * 2);
    for i in 0..n {
        let (p, q) = (contour[i], contour[(i + n - 1) % n]);
        let back = AROUND
            .iter()
            .position(|&d| d == (q.x - p.x, q.y - p.y))
            .unwrap_or(7);
        for k in 1..=8 {
            let j = (back + k) % 8;
            let (dx, dy) = AROUND[j];
            if j % 2 == 0 && !inside(p.x + dx, p.y + dy) && seen.insert((p.x, p.y, j)) {
                boundary.push(Point2::new(
                    p.x as f64 + 0.5 * dx as f64,
                    p.y as f64 + 0.5 * dy as f64,
                ));
            }
        }
    }
    Ok(BodyOutline {
        boundary,
        area_px: largest,
    })
}

/// Pixels each side of a crack over which the edge's luma transition is summed
/// ([`refine_edge`]): the crack may be this far, less one, from the true edge.
pub const EDGE_HALF_WINDOW: i64 = 3;
/// Least luma step between body and background for [`refine_edge`] to move a point.
pub const MIN_EDGE_CONTRAST: f64 = 8.0;

/// Luma of a pixel (BT.601 weights: a YUV frame's own Y, full resolution where its
/// chroma has half).
fn luma<S: PixelSource>(img: &S, x: i64, y: i64) -> f64 {
    let p = img.rgb(x as u32, y as u32).0;
    0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64
}

/// Moves each crack point of `boundary` (from [`body_outline`] on `mask`) to the edge's
/// sub-pixel position along the crack's axis, by coverage: across the crack, the
/// pixels from `EDGE_HALF_WINDOW - 1` inside to `EDGE_HALF_WINDOW` outside count by where
/// their luma lies between the body's (two pixels further in) and the background's (two
/// further out), and the edge sits where that much body ends. The colour mask only finds
/// the body; its edge follows the 2x2 chroma blocks of 4:2:0 video, luma does not. A
/// point keeps the crack's position where the window leaves the frame or the luma step
/// is below [`MIN_EDGE_CONTRAST`].
pub fn refine_edge<S: PixelSource>(img: &S, mask: &GrayImage, boundary: &mut [Point2<f64>]) {
    let (w, h) = img.dimensions();
    let m = EDGE_HALF_WINDOW;
    let body = |x: i64, y: i64| mask.get_pixel(x as u32, y as u32)[0] != 0;
    for p in boundary.iter_mut() {
        // A crack between pixels a (body) and a + d.
        let (d, a) = if p.x.fract().abs() > 0.25 {
            let (l, r) = (p.x.floor() as i64, p.x.ceil() as i64);
            let y = p.y.round() as i64;
            if l >= 0 && body(l, y) {
                ((1i64, 0i64), (l, y))
            } else {
                ((-1, 0), (r, y))
            }
        } else {
            let (t, b) = (p.y.floor() as i64, p.y.ceil() as i64);
            let x = p.x.round() as i64;
            if t >= 0 && body(x, t) {
                ((0, 1), (x, t))
            } else {
                ((0, -1), (x, b))
            }
        };
        let at = |k: i64| (a.0 + k * d.0, a.1 + k * d.1);
        let (lo, hi) = (at(-m - 1), at(m + 2));
        let inside = |q: (i64, i64)| q.0 >= 0 && q.1 >= 0 && q.0 < w as i64 && q.1 < h as i64;
        if !inside(lo) || !inside(hi) {
            continue;
        }
        let level = |k: i64| luma(img, at(k).0, at(k).1);
        let l_in = 0.5 * (level(-m) + level(-m - 1));
        let l_out = 0.5 * (level(m + 1) + level(m + 2));
        if (l_out - l_in).abs() < MIN_EDGE_CONTRAST {
            continue;
        }
        // Body coverage of pixels -m+1 ..= m; the crack is at +0.5.
        let covered: f64 = (-m + 1..=m)
            .map(|k| ((l_out - level(k)) / (l_out - l_in)).clamp(0.0, 1.0))
            .sum();
        let e = covered - (m as f64 - 0.5);
        *p = Point2::new(a.0 as f64 + e * d.0 as f64, a.1 as f64 + e * d.1 as f64);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mask_of(w: u32, h: u32, inside: impl Fn(f64, f64) -> bool) -> GrayImage {
        GrayImage::from_fn(w, h, |x, y| {
            Luma([if inside(x as f64, y as f64) { 255 } else { 0 }])
        })
    }

    #[test]
    fn crack_points_of_a_rectangle_lie_on_its_pixel_border() {
        // Pixels 10..=59 x 20..=39: the border is at x = 9.5, 59.5 and y = 19.5, 39.5.
        let m = mask_of(80, 60, |x, y| {
            (10.0..=59.0).contains(&x) && (20.0..=39.0).contains(&y)
        });
        let o = body_outline(&m).unwrap();
        assert_eq!(o.area_px, 50 * 20);
        assert_eq!(o.boundary.len(), 2 * (50 + 20));
        for p in &o.boundary {
            let on_x = (p.x - 9.5).abs() < 1e-12 || (p.x - 59.5).abs() < 1e-12;
            let on_y = (p.y - 19.5).abs() < 1e-12 || (p.y - 39.5).abs() < 1e-12;
            assert!(on_x || on_y, "{p}");
        }
        // In order: successive points are neighbours (at most one pixel apart).
        for w in o.boundary.windows(2) {
            assert!((w[1] - w[0]).norm() <= 1.0 + 1e-9, "{} -> {}", w[0], w[1]);
        }
    }

    #[test]
    fn refined_edge_points_lie_on_an_antialiased_disc() {
        // A pale body disc on a white sheet (the render's colours), 8x8 supersampled
        // and blurred over a pixel (box of the supersamples): the edge is where half of
        // a pixel is covered.
        let (cx, cy, r) = (60.3, 55.7, 37.4);
        let img = image::RgbImage::from_fn(120, 110, |x, y| {
            let mut cov = 0.0;
            for sy in 0..8 {
                for sx in 0..8 {
                    let (px, py) = (
                        x as f64 - 0.5 + (sx as f64 + 0.5) / 8.0,
                        y as f64 - 0.5 + (sy as f64 + 0.5) / 8.0,
                    );
                    if (px - cx).hypot(py - cy) <= r {
                        cov += 1.0 / 64.0;
                    }
                }
            }
            let mix = |a: f64, b: f64| (a * cov + b * (1.0 - cov)).round() as u8;
            image::Rgb([mix(214.0, 236.0), mix(206.0, 236.0), mix(188.0, 230.0)])
        });
        let mask = body_mask(&img, &DEFAULT_OUTLINE_BAND);
        let o = body_outline(&mask).unwrap();
        let mut refined = o.boundary.clone();
        refine_edge(&img, &mask, &mut refined);
        let err = |pts: &[Point2<f64>]| {
            let e: Vec<f64> = pts
                .iter()
                .map(|p| (p - Point2::new(cx, cy)).norm() - r)
                .collect();
            let mean = e.iter().sum::<f64>() / e.len() as f64;
            let worst = e.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            (mean, worst)
        };
        let (mean, worst) = err(&refined);
        assert!(
            mean.abs() < 0.02 && worst < 0.25,
            "refined: mean {mean}, worst {worst}"
        );
        // The cracks of the colour mask alone are off by up to a pixel.
        let (_, crack_worst) = err(&o.boundary);
        assert!(crack_worst > 0.4, "cracks: worst {crack_worst}");
    }

    #[test]
    fn the_background_two_alike_blobs_and_specks_are_refused() {
        let everything = mask_of(60, 40, |_, _| true);
        assert!(matches!(
            body_outline(&everything),
            Err(OutlineError::Background { .. })
        ));
        let two = mask_of(100, 60, |x, y| {
            (10.0..40.0).contains(&x) && (10.0..40.0).contains(&y)
                || (55.0..85.0).contains(&x) && (10.0..40.0).contains(&y)
        });
        assert!(matches!(
            body_outline(&two),
            Err(OutlineError::TwoBodies {
                largest: 900,
                second: 900
            })
        ));
        let speck = mask_of(100, 60, |x, y| {
            (10.0..15.0).contains(&x) && (10.0..15.0).contains(&y)
        });
        assert_eq!(
            body_outline(&speck),
            Err(OutlineError::NoBody { area_px: 25 })
        );
        for e in [
            body_outline(&everything).unwrap_err(),
            body_outline(&two).unwrap_err(),
        ] {
            assert!(!e.to_string().contains('\n') && e.to_string().starts_with("outline: "));
        }
    }
}
