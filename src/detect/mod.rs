//! Marker detection: HSV colour mask, hole fill, speck removal, connected components and
//! sub-pixel centroids.
//!
//! The chain, per frame: [`mask_from_rgb`] (OpenCV's HSV convention, H in 0..180 with
//! red wrapping around 0/180, S and V in 0..255; the marker colour is a band of it:
//! [`MarkerColour`]'s presets red, green, blue, yellow, dark, or any hue band with
//! saturation and value bounds, [`HsvThresholds`]) -> [`blobs_from_mask`] (8-connected
//! components, holes filled, specks and oversized blobs dropped and counted) -> sub-pixel
//! centroids -> [`order_markers`] from the clamped end to the tip.
//!
//! Labelling is run-based (row runs joined with union-find), written here rather than
//! taken from `imageproc::region_labelling::connected_components` because a frame's mask
//! is almost empty: the run-based pass touches each mask row once and only the few
//! marker pixels after that, while a full-frame labelling allocates and writes a 32-bit
//! label for each of the two million pixels of a 1080p frame. The tests check it against
//! imageproc on random masks.
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
//!
//! One module per operation, each re-exported here: `colour` (the HSV bands and the
//! integer test of a pixel against one), `settings` (`[detect]` and its checked form),
//! `pixels` (frames as pixel sources, the cheap pre-tests of a band), `yuv_source` (the
//! pixel source of decoded YUV video frames), `mask` (the exposure-adjusted band and the
//! marker mask), `labelling` (connected components, hole fill), `centroids` (blobs and
//! their coverage-weighted centroids) and `ordering` (the markers from the clamped end to
//! the tip); [`detect_markers`] runs the chain on a frame. `outline` is the markerless
//! mode (`[detect] mode = "outline"`): the body's mask and its boundary.

mod centroids;
mod colour;
mod labelling;
mod mask;
mod ordering;
mod outline;
mod pixels;
mod settings;
#[cfg(test)]
mod testing;
mod yuv_source;

use image::RgbImage;

pub use centroids::{
    blobs_from_buffer, blobs_from_mask, Blob, Detection, MIN_COVERAGE_CONTRAST, RING_PX,
};
pub use colour::{
    is_marker_colour, HsvThresholds, MarkerColour, DEFAULT_DARK_V_MAX, DEFAULT_S_MIN,
    DEFAULT_V_MIN, HUE_MAX,
};
pub use mask::{
    exposure_adjusted, mask_from_rgb, mask_from_rgb_sparse, mask_from_rgb_sparse_into, MaskBuffer,
    COARSE_MARGIN, EXPOSURE_GRID, MIN_ADJUSTED_V, NOMINAL_WHITE,
};
pub use ordering::{order_marker_indices, order_markers, ChainStart};
pub use outline::{
    body_mask, body_outline, refine_edge, BodyOutline, DetectMode, OutlineError, OutlineSettings,
    DEFAULT_OUTLINE_BAND, DEFAULT_OUTLINE_CLAMP_MM, MAX_BODY_SHARE, MIN_BODY_AREA_PX,
    SECOND_BLOB_SHARE,
};
pub use pixels::{
    coarse_row_hits_exact, MarkerTest, PixelSource, Pretest, COARSE_STEP, PRETEST_DIRECTION,
    PRETEST_SHARE,
};
pub use settings::{
    ClampSide, DetectConfig, DetectSettings, DEFAULT_MAX_AREA_PX, DEFAULT_MIN_AREA_PX,
};

/// The whole chain on one RGB frame: mask, components, filtering, centroids.
pub fn detect_markers(img: &RgbImage, settings: &DetectSettings) -> Detection {
    detect_markers_with(img, settings, &mut MaskBuffer::default())
}

/// [`detect_markers`] with a mask buffer reused from frame to frame.
pub fn detect_markers_with<S: PixelSource>(
    img: &S,
    settings: &DetectSettings,
    mask: &mut MaskBuffer,
) -> Detection {
    let hsv = if settings.auto_exposure {
        exposure_adjusted(img, &settings.hsv)
    } else {
        settings.hsv
    };
    mask_from_rgb_sparse_into(img, &hsv, mask);
    blobs_from_buffer(mask, Some(img), settings)
}

#[cfg(test)]
mod tests {
    use super::testing::disc;
    use super::*;
    use nalgebra::Point2;

    #[test]
    fn subpixel_centroids_of_antialiased_discs() {
        let centres = [(20.3, 15.7, 4.0), (50.55, 18.2, 10.0), (80.9, 40.1, 4.0)];
        let img = disc(100, 60, &centres);
        let d = detect_markers(&img, &DetectSettings::default());
        assert_eq!(d.blobs.len(), 3);
        for (cx, cy, r) in centres {
            let b = d
                .blobs
                .iter()
                .min_by(|a, b| {
                    (a.centroid - Point2::new(cx, cy))
                        .norm()
                        .total_cmp(&(b.centroid - Point2::new(cx, cy)).norm())
                })
                .unwrap();
            let err = (b.centroid - Point2::new(cx, cy)).norm();
            let tol = if r >= 10.0 { 0.05 } else { 0.08 };
            assert!(
                err < tol,
                "disc r {r} at ({cx},{cy}): centroid {} off by {err}",
                b.centroid
            );
        }
    }
}
