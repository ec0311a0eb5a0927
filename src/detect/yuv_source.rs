//! Decoded YUV 4:2:0 video frames ([`YuvFrame`]) as a [`PixelSource`]: a pixel is
//! converted to RGB only after its chroma (or, for dark markers, its luma) sample passes
//! the band's pre-test, and the coarse pass scans a frame's chroma rows in chunks, so
//! most of a frame is never converted.

use super::pixels::{coarse_row_hits_exact, MarkerTest, PixelSource, Pretest, COARSE_STEP};
use crate::video::{Sample, YuvFrame};

/// Cr samples scanned together by [`YuvFrame`]'s coarse pass: the largest of a chunk is
/// compared first (a vectorized max), and a chunk below the pre-test is skipped whole.
const CR_CHUNK: usize = 32;

impl<T: Sample> PixelSource for YuvFrame<T> {
    fn dimensions(&self) -> (u32, u32) {
        (self.width, self.height)
    }
    #[inline]
    fn rgb(&self, x: u32, y: u32) -> image::Rgb<u8> {
        image::Rgb(self.rgb_at(x, y))
    }
    #[inline]
    fn is_marker_at(&self, x: u32, y: u32, t: &MarkerTest) -> bool {
        let k = T::EXTRA_BITS;
        let (cy, cx) = (y as usize / 2, x as usize / 2);
        let cb = self.plane(1)[cy * self.strides[1] + cx];
        let cr = self.plane(2)[cy * self.strides[2] + cx];
        let luma = || self.plane(0)[y as usize * self.strides[0] + x as usize];
        let pass = match t.pretest {
            Pretest::None => true,
            Pretest::Chroma { a, b, k: bound } => {
                a * (cb.value() - (128 << k)) + b * (cr.value() - (128 << k)) >= bound << k
            }
            Pretest::Luma { limited, full } => {
                let bound = if self.full_range { full } else { limited };
                luma().value() <= bound << k
            }
        };
        if !pass {
            return false;
        }
        let [r, g, b] = self.rgb_of(luma(), cb, cr);
        t.matches(r, g, b)
    }
    /// The coarse pass on the chroma row under row `y` (or the luma row for dark
    /// markers): the coarse grid (every second pixel of every second row) is the chroma
    /// grid, so each coarse pixel has its own chroma sample; chunks of samples that fail
    /// the pre-test are skipped without converting a pixel.
    fn coarse_row_hits(&self, y: u32, t: &MarkerTest, out: &mut Vec<u32>) {
        const { assert!(COARSE_STEP == 2) };
        let k = T::EXTRA_BITS;
        let cw = self.width.div_ceil(2) as usize;
        let cy = y as usize / 2;
        let chroma_row = |i: usize| -> Option<&[T]> {
            let start = cy * self.strides[i];
            self.plane(i).get(start..start + cw)
        };
        if t.pretest == Pretest::None {
            coarse_row_hits_exact(self, y, t, out);
            return;
        }
        let (Some(cb), Some(cr)) = (chroma_row(1), chroma_row(2)) else {
            return;
        };
        let luma_start = y as usize * self.strides[0];
        let Some(luma) = self
            .plane(0)
            .get(luma_start..luma_start + self.width as usize)
        else {
            return;
        };
        // A sample that passed the pre-test gets the band's exact test, converted from
        // the rows held here.
        let mut hit = |i: usize| {
            let x = 2 * i;
            if x < luma.len() {
                let [r, g, b] = self.rgb_of(luma[x], cb[i], cr[i]);
                if t.matches(r, g, b) {
                    out.push(x as u32);
                }
            }
        };
        match t.pretest {
            Pretest::None => {}
            Pretest::Chroma { a, b, k: bound } => {
                let (mid, bound) = (128 << k, bound << k);
                match (a, b) {
                    // One plane: the bound as a sample value, chunks by their max or min.
                    (0, w) | (w, 0) => {
                        let plane = if a == 0 { cr } else { cb };
                        // w (s - mid) >= bound: s at least (or, w < 0, at most) mid
                        // +- ceil(bound / |w|) (bound > 0).
                        let q = (bound + w.abs() - 1).div_euclid(w.abs());
                        if w > 0 {
                            let thr = T::saturated(mid + q);
                            scan_chunks(
                                cw,
                                |r| plane[r].iter().fold(T::default(), |m, &s| m.max(s)) < thr,
                                |i| plane[i] >= thr,
                                &mut hit,
                            );
                        } else {
                            let thr = T::saturated(mid - q);
                            let top = T::saturated(i32::MAX);
                            scan_chunks(
                                cw,
                                |r| plane[r].iter().fold(top, |m, &s| m.min(s)) > thr,
                                |i| plane[i] <= thr,
                                &mut hit,
                            );
                        }
                    }
                    (a, b) => {
                        let score =
                            |i: usize| a * (cb[i].value() - mid) + b * (cr[i].value() - mid);
                        // A chunk's best score is at most the sum of each plane's best
                        // term, met at the plane's extreme sample in its weight's
                        // direction: two min/max folds over the samples (which the
                        // compiler vectorizes, unlike the weighted sum) skip a chunk.
                        let top = T::saturated(i32::MAX);
                        let best = |plane: &[T], w: i32, r: std::ops::Range<usize>| {
                            let s = &plane[r];
                            let v = if w > 0 {
                                s.iter().fold(T::default(), |m, &x| m.max(x))
                            } else {
                                s.iter().fold(top, |m, &x| m.min(x))
                            };
                            w * (v.value() - mid)
                        };
                        scan_chunks(
                            cw,
                            |r| best(cb, a, r.clone()) + best(cr, b, r) < bound,
                            |i| score(i) >= bound,
                            &mut hit,
                        );
                    }
                }
            }
            Pretest::Luma { limited, full } => {
                let bound = T::saturated((if self.full_range { full } else { limited }) << k);
                let row = luma;
                scan_chunks(
                    cw,
                    |r| {
                        row[2 * r.start..(2 * r.end).min(row.len())]
                            .iter()
                            .step_by(2)
                            .fold(T::saturated(i32::MAX), |m, &s| m.min(s))
                            > bound
                    },
                    |i| row[2 * i] <= bound,
                    &mut hit,
                );
            }
        }
    }
}

/// The coarse samples `0..n` in chunks of [`CR_CHUNK`]: a chunk that `fails` (no sample
/// can pass the pre-test) is skipped, else `hit` gets each sample that `passes`.
#[inline]
fn scan_chunks(
    n: usize,
    fails: impl Fn(std::ops::Range<usize>) -> bool,
    passes: impl Fn(usize) -> bool,
    hit: &mut impl FnMut(usize),
) {
    for c0 in (0..n).step_by(CR_CHUNK) {
        let c1 = (c0 + CR_CHUNK).min(n);
        if fails(c0..c1) {
            continue;
        }
        for i in c0..c1 {
            if passes(i) {
                hit(i);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::colour::{is_marker_colour, rgb_of_hsv, HsvThresholds};

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(20_000))]
        /// Red's Cr pre-test agrees with the exact test on every YUV sample, in gamut or not.
        #[test]
        fn cr_pretest_never_rejects_a_red_pixel(y: u8, u: u8, v: u8, full: bool, v_min in 1u8..=80) {
            let f = YuvFrame::from_planes(2, 2, vec![y; 4], vec![u], vec![v], full).unwrap();
            let t = HsvThresholds { v_min, ..Default::default() };
            let test = MarkerTest::new(&t);
            let p = f.rgb_at(0, 0);
            let exact = is_marker_colour(p[0], p[1], p[2], &t);
            proptest::prop_assert_eq!(PixelSource::is_marker_at(&f, 0, 0, &test), exact, "yuv {} {} {} -> {:?}", y, u, v, p);
        }

        /// Every preset's pre-test agrees with the exact test on YUV samples of RGB
        /// colours (as a decoder makes them) with up to 6 levels of chroma noise.
        #[test]
        fn every_preset_pretest_keeps_its_pixels(r: u8, g: u8, b: u8, du in -6i32..=6, dv in -6i32..=6, full: bool, preset in 0usize..5, v_scale in 0.3f64..1.5) {
            use crate::detect::colour::MarkerColour::*;
            let colour = [Red, Green, Blue, Yellow, Dark][preset];
            let mut t = colour.thresholds();
            t.v_min = (t.v_min as f64 * v_scale).round().clamp(1.0, 255.0) as u8;
            if t.v_max < 255 {
                t.v_max = (t.v_max as f64 * v_scale).round().clamp(1.0, 254.0) as u8;
            }
            let (rf, gf, bf) = (r as f64, g as f64, b as f64);
            let (yy, cb, cr) = if full {
                (0.299 * rf + 0.587 * gf + 0.114 * bf, 128.0 - 0.168736 * rf - 0.331264 * gf + 0.5 * bf, 128.0 + 0.5 * rf - 0.418688 * gf - 0.081312 * bf)
            } else {
                (16.0 + (65.481 * rf + 128.553 * gf + 24.966 * bf) / 255.0, 128.0 + (-37.797 * rf - 74.203 * gf + 112.0 * bf) / 255.0, 128.0 + (112.0 * rf - 93.786 * gf - 18.214 * bf) / 255.0)
            };
            let q = |v: f64| v.round().clamp(0.0, 255.0) as u8;
            let (u, v) = (q(cb + du as f64), q(cr + dv as f64));
            let f = YuvFrame::from_planes(2, 2, vec![q(yy); 4], vec![u], vec![v], full).unwrap();
            let test = MarkerTest::new(&t);
            let p = f.rgb_at(0, 0);
            let exact = is_marker_colour(p[0], p[1], p[2], &t);
            proptest::prop_assert_eq!(PixelSource::is_marker_at(&f, 0, 0, &test), exact, "{:?} yuv {} {} {} -> {:?}, {:?}", colour, q(yy), u, v, p, test.pretest);
        }
    }

    /// The pre-tests at their tightest: colours on the edges of each preset's band (its
    /// hue bounds, S = s_min, V = v_min, and a little inside), through both YUV ranges,
    /// are never rejected by the pre-test when their converted RGB passes.
    #[test]
    fn pretests_keep_the_edges_of_every_band() {
        use crate::detect::colour::MarkerColour::*;
        let mut checked = 0;
        for colour in [Red, Green, Blue, Yellow, Dark] {
            let t = colour.thresholds();
            let test = MarkerTest::new(&t);
            let hi = if t.hue_min > t.hue_max {
                t.hue_max as f64 + 180.0
            } else {
                t.hue_max as f64
            };
            for i in 0..=40 {
                let h = t.hue_min as f64 + (hi - t.hue_min as f64) * i as f64 / 40.0;
                for ds in [0.0, 2.0, 6.0, 40.0, 255.0] {
                    for dv in [0.0, 1.0, 3.0, 10.0, 60.0] {
                        let s = ((t.s_min as f64 + ds) / 255.0).min(1.0);
                        let v = if t.v_max < 255 {
                            t.v_max as f64 - dv
                        } else {
                            t.v_min as f64 + dv
                        };
                        let [r, g, b] = rgb_of_hsv(h % 180.0, s, v.clamp(0.0, 255.0));
                        for full in [false, true] {
                            let (yy, cb, cr) = if full {
                                (
                                    0.299 * r + 0.587 * g + 0.114 * b,
                                    128.0 - 0.168736 * r - 0.331264 * g + 0.5 * b,
                                    128.0 + 0.5 * r - 0.418688 * g - 0.081312 * b,
                                )
                            } else {
                                (
                                    16.0 + (65.481 * r + 128.553 * g + 24.966 * b) / 255.0,
                                    128.0 + (-37.797 * r - 74.203 * g + 112.0 * b) / 255.0,
                                    128.0 + (112.0 * r - 93.786 * g - 18.214 * b) / 255.0,
                                )
                            };
                            let q = |v: f64| v.round().clamp(0.0, 255.0) as u8;
                            let f = YuvFrame::from_planes(
                                2,
                                2,
                                vec![q(yy); 4],
                                vec![q(cb)],
                                vec![q(cr)],
                                full,
                            )
                            .unwrap();
                            let p = f.rgb_at(0, 0);
                            if test.matches(p[0], p[1], p[2]) {
                                checked += 1;
                                assert!(PixelSource::is_marker_at(&f, 0, 0, &test), "{colour:?}: hsv {h} {s} {v} -> yuv {} {} {} (full {full}) rejected by {:?}", q(yy), q(cb), q(cr), test.pretest);
                            }
                        }
                    }
                }
            }
        }
        assert!(
            checked > 1500,
            "only {checked} edge colours passed their band"
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// The chroma- and luma-row scans find exactly the coarse pixels the exact test
        /// finds, for every preset, at both depths, odd sizes included.
        #[test]
        fn row_scans_match_the_exact_coarse_pass(seed: u64, w in 1u32..150, h in 1u32..9, ten_bit: bool, preset in 0usize..5) {
            use crate::detect::colour::MarkerColour::*;
            let mut rng = crate::render::rng::SplitMix64::new(seed);
            let (cw, ch) = (w.div_ceil(2) as usize, h.div_ceil(2) as usize);
            let mut sample = |lo: f64, hi: f64| rng.range(lo, hi) as u16;
            let y: Vec<u16> = (0..w as usize * h as usize).map(|i| if i % 23 < 4 { sample(16.0, 60.0) } else { sample(16.0, 236.0) }).collect();
            // Mostly neutral chroma with coloured patches.
            let u: Vec<u16> = (0..cw * ch).map(|i| if i % 29 < 5 { sample(16.0, 240.0) } else { sample(110.0, 146.0) }).collect();
            let v: Vec<u16> = (0..cw * ch).map(|i| if i % 37 < 5 { sample(16.0, 240.0) } else { sample(100.0, 134.0) }).collect();
            let t = MarkerTest::new(&[Red, Green, Blue, Yellow, Dark][preset].thresholds());
            let check = |f: &dyn Fn(u32, &mut Vec<u32>, &mut Vec<u32>)| -> Result<(), proptest::test_runner::TestCaseError> {
                for row in (0..h).step_by(2) {
                    let (mut fast, mut exact) = (Vec::new(), Vec::new());
                    f(row, &mut fast, &mut exact);
                    proptest::prop_assert_eq!(fast, exact, "row {}", row);
                }
                Ok(())
            };
            if ten_bit {
                let up = |p: &[u16]| p.iter().map(|&s| s << 2).collect::<Vec<u16>>();
                let f = YuvFrame::from_planes(w, h, up(&y), up(&u), up(&v), false).unwrap();
                check(&|row, a, b| {
                    PixelSource::coarse_row_hits(&f, row, &t, a);
                    coarse_row_hits_exact(&f, row, &t, b);
                })?;
            } else {
                let down = |p: &[u16]| p.iter().map(|&s| s as u8).collect::<Vec<u8>>();
                let f = YuvFrame::from_planes(w, h, down(&y), down(&u), down(&v), false).unwrap();
                check(&|row, a, b| {
                    PixelSource::coarse_row_hits(&f, row, &t, a);
                    coarse_row_hits_exact(&f, row, &t, b);
                })?;
            }
        }
    }
}
