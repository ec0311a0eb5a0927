//! Test images shared by the detection modules' tests.

use image::RgbImage;

/// A `w` x `h` white frame with red discs (centre x, centre y, radius; px),
/// anti-aliased.
pub(super) fn disc(w: u32, h: u32, discs: &[(f64, f64, f64)]) -> RgbImage {
    // Anti-aliased discs by 8x8 supersampling.
    RgbImage::from_fn(w, h, |x, y| {
        let mut cov = 0.0;
        for sy in 0..8 {
            for sx in 0..8 {
                let (px, py) = (
                    x as f64 - 0.5 + (sx as f64 + 0.5) / 8.0,
                    y as f64 - 0.5 + (sy as f64 + 0.5) / 8.0,
                );
                if discs
                    .iter()
                    .any(|(cx, cy, r)| (px - cx).hypot(py - cy) <= *r)
                {
                    cov += 1.0 / 64.0;
                }
            }
        }
        let mix = |a: f64, b: f64| (a * cov + b * (1.0 - cov)).round() as u8;
        image::Rgb([mix(196.0, 230.0), mix(28.0, 228.0), mix(34.0, 222.0)])
    })
}
