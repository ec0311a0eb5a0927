//! Pixel tests: frames as random-access pixel sources ([`PixelSource`], implemented for RGB
//! images here and for decoded YUV frames in `yuv_source`), and a colour band with the
//! cheap necessary condition on a YUV sample ([`Pretest`]) that lets a YUV frame skip
//! most pixels without converting them ([`MarkerTest`]).

use image::RgbImage;

use super::colour::{chroma_of_rgb, is_marker_colour, rgb_of_hsv, HsvThresholds};

/// Share of the smallest chroma excess of a band's pixels that the pre-test demands
/// ([`MarkerTest::pretest`]): the rest is room for the rounding and clamping of a YUV
/// sample's conversion to RGB. 3/7 keeps the red pre-test of a Cr excess of 3 at the
/// default thresholds (whose smallest excess is 7).
pub const PRETEST_SHARE: f64 = 3.0 / 7.0;
/// Length of the chroma direction of a [`Pretest::Chroma`] (integer components).
pub const PRETEST_DIRECTION: f64 = 64.0;

/// A necessary condition on a YUV sample (BT.601, 8-bit units; a 10-bit sample compares
/// with the bounds shifted by 2 bits) for its pixel to pass a colour band: what lets a
/// YUV frame skip most pixels without converting them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pretest {
    /// No cheap test applies: every pixel gets the exact test.
    None,
    /// Only samples with a (Cb - 128) + b (Cr - 128) >= k can pass.
    Chroma {
        /// Weight of Cb - 128.
        a: i32,
        /// Weight of Cr - 128.
        b: i32,
        /// Bound.
        k: i32,
    },
    /// Only samples with Y <= the bound can pass (dark markers).
    Luma {
        /// Bound for limited-range (16..235) luma.
        limited: i32,
        /// Bound for full-range luma.
        full: i32,
    },
}

impl Pretest {
    /// The strongest pre-test of band `t`. The chroma of a colour is linear in its RGB,
    /// and RGB is linear in S and V for a fixed hue and piecewise linear in the hue (its
    /// pieces meet at multiples of 30), so the smallest projection of the band's chroma
    /// on a direction is met at the band's edges or a multiple of 30 inside it, at
    /// S = s_min or 1 and V = v_min: those few colours give it exactly. Of the four
    /// chroma axes (one plane to scan) and the band's centre direction, the axis with the
    /// largest smallest projection is taken unless the centre's is over 1.4 times larger.
    pub fn of_band(t: &HsvThresholds) -> Pretest {
        if t.every_hue() {
            if t.s_min == 0 && t.v_max < 255 {
                // Y is a weighted mean of R, G, B, so never above V.
                let v = t.v_max as i32;
                return Pretest::Luma {
                    limited: 16 + (219 * v + 254) / 255 + 1,
                    full: v + 1,
                };
            }
            return Pretest::None;
        }
        if t.v_min == 0 {
            return Pretest::None;
        }
        let (lo, hi) = (t.hue_min as f64, t.hue_max as f64);
        let hi = if t.hue_min > t.hue_max {
            hi + 180.0
        } else {
            hi
        };
        let mut hues = vec![lo, hi];
        let mut m = (lo / 30.0).ceil() * 30.0;
        while m < hi {
            hues.push(m);
            m += 30.0;
        }
        let v = t.v_min as f64;
        let colours: Vec<[f64; 2]> = hues
            .iter()
            .flat_map(|&h| {
                [t.s_min as f64 / 255.0, 1.0].map(|s| chroma_of_rgb(rgb_of_hsv(h, s, v)))
            })
            .collect();
        let floor = |a: f64, b: f64| {
            colours
                .iter()
                .map(|c| a * c[0] + b * c[1])
                .fold(f64::INFINITY, f64::min)
        };
        let n = PRETEST_DIRECTION;
        let centre = chroma_of_rgb(rgb_of_hsv((lo + hi) / 2.0, 1.0, 255.0));
        let len = centre[0].hypot(centre[1]).max(1e-9);
        let (ca, cb) = ((n * centre[0] / len).round(), (n * centre[1] / len).round());
        let axes = [(0.0, n), (0.0, -n), (n, 0.0), (-n, 0.0)];
        let (aa, ab, af) = axes.iter().map(|&(a, b)| (a, b, floor(a, b))).fold(
            (0.0, 0.0, f64::NEG_INFINITY),
            |best, c| if c.2 > best.2 { c } else { best },
        );
        let cf = floor(ca, cb) * n / ca.hypot(cb).max(1e-9);
        let (a, b, f) = if cf > 1.4 * af {
            (ca, cb, floor(ca, cb))
        } else {
            (aa, ab, af)
        };
        let k = (f * PRETEST_SHARE).floor();
        if k <= 0.0 {
            return Pretest::None;
        }
        Pretest::Chroma {
            a: a as i32,
            b: b as i32,
            k: k as i32,
        }
    }
}

/// A colour band with its pre-test, made once per frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerTest {
    /// The band.
    pub band: HsvThresholds,
    /// The cheap necessary condition for YUV samples.
    pub pretest: Pretest,
}

impl MarkerTest {
    /// The test of band `t`.
    pub fn new(t: &HsvThresholds) -> Self {
        Self {
            band: *t,
            pretest: Pretest::of_band(t),
        }
    }

    /// Whether an RGB pixel passes.
    #[inline]
    pub fn matches(&self, r: u8, g: u8, b: u8) -> bool {
        is_marker_colour(r, g, b, &self.band)
    }
}

/// Grid step of the coarse pass of [`mask_from_rgb_sparse`](super::mask_from_rgb_sparse), px.
pub const COARSE_STEP: u32 = 2;

/// Random access to a frame's RGB pixels: an RGB image, or a decoded YUV 4:2:0 frame
/// converted pixel by pixel only where detection looks ([`crate::video::YuvFrame`]).
pub trait PixelSource: Sync {
    /// (width, height), px.
    fn dimensions(&self) -> (u32, u32);
    /// The RGB value at (x, y).
    fn rgb(&self, x: u32, y: u32) -> image::Rgb<u8>;
    /// Whether (x, y) has the marker colour of `t`; sources may reject cheaply first
    /// (see [`crate::video::YuvFrame`]).
    #[inline]
    fn is_marker_at(&self, x: u32, y: u32, t: &MarkerTest) -> bool {
        let p = self.rgb(x, y);
        t.matches(p[0], p[1], p[2])
    }
    /// Appends to `out` the x of every [`COARSE_STEP`]-th pixel of row `y` that has the
    /// marker colour of `t` (the coarse pass of [`mask_from_rgb_sparse`](super::mask_from_rgb_sparse)); sources may
    /// skip runs of pixels that cannot pass (a YUV frame scans a chroma or luma row first).
    fn coarse_row_hits(&self, y: u32, t: &MarkerTest, out: &mut Vec<u32>) {
        coarse_row_hits_exact(self, y, t, out);
    }
}

/// [`PixelSource::coarse_row_hits`] by the exact test on every [`COARSE_STEP`]-th pixel.
pub fn coarse_row_hits_exact<S: PixelSource + ?Sized>(
    img: &S,
    y: u32,
    t: &MarkerTest,
    out: &mut Vec<u32>,
) {
    let (w, _) = img.dimensions();
    out.extend(
        (0..w)
            .step_by(COARSE_STEP as usize)
            .filter(|&x| img.is_marker_at(x, y, t)),
    );
}

impl PixelSource for RgbImage {
    fn dimensions(&self) -> (u32, u32) {
        image::GenericImageView::dimensions(self)
    }
    #[inline]
    fn rgb(&self, x: u32, y: u32) -> image::Rgb<u8> {
        *self.get_pixel(x, y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::colour::MarkerColour;

    /// The pre-test never rejects a pixel of the band: checked on every colour of the
    /// band's edges and centre at random S and V (the smallest projection is met at the
    /// extremal colours, see [`Pretest::of_band`]), 8-bit limited range.
    #[test]
    fn pretest_floors_hold_for_every_preset() {
        for colour in [
            MarkerColour::Red,
            MarkerColour::Green,
            MarkerColour::Blue,
            MarkerColour::Yellow,
        ] {
            let t = colour.thresholds();
            let Pretest::Chroma { a, b, k } = Pretest::of_band(&t) else {
                panic!("{colour:?}: no chroma pre-test");
            };
            let mut worst = f64::INFINITY;
            for r in 0..=255u8 {
                for g in (0..=255u8).step_by(3) {
                    for bl in (0..=255u8).step_by(3) {
                        if is_marker_colour(r, g, bl, &t) {
                            let c = chroma_of_rgb([r as f64, g as f64, bl as f64]);
                            worst = worst.min(a as f64 * c[0] + b as f64 * c[1]);
                        }
                    }
                }
            }
            assert!(
                worst >= k as f64 / PRETEST_SHARE - 1e-6,
                "{colour:?}: {worst} below {}",
                k as f64 / PRETEST_SHARE
            );
        }
        // Red keeps a one-plane Cr pre-test at least as strong as its former Cr - 128 >= 3.
        let red = Pretest::of_band(&HsvThresholds::default());
        assert!(
            matches!(red, Pretest::Chroma { a: 0, b: 64, k } if k >= 3 * 64),
            "{red:?}"
        );
        assert!(matches!(
            Pretest::of_band(&MarkerColour::Dark.thresholds()),
            Pretest::Luma { .. }
        ));
    }
}
