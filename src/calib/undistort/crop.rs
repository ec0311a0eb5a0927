//! The crop rectangle of the undistorted view: which output pixels lie inside the valid
//! field and come from inside the raw frame, and the largest axis-aligned rectangle of
//! them (the view [`Undistorter::crop_rect`] reports).
//!
//! Why written here: OpenCV's `getOptimalNewCameraMatrix` returns a valid-pixel ROI for
//! the pinhole model only, and knows nothing of the calibration's valid field.

use nalgebra::Point2;
use opencv::core::Rect;
use rayon::prelude::*;

use super::{Undistorter, FIELD_EDGE_TOLERANCE, RAW_EDGE_TOLERANCE_PX};
use crate::calib::CalibError;

impl Undistorter {
    /// Whether the output pixel (x, y) lies inside the valid field (undistorted
    /// normalized radius at most tan(theta_valid)) and, unless `only_field`, its raw
    /// position from the forward model lies inside the raw frame.
    pub(super) fn output_pixel_inside(&self, x: f64, y: f64, only_field: bool) -> bool {
        let p = &self.new_camera_matrix;
        let n = Point2::new((x - p[(0, 2)]) / p[(0, 0)], (y - p[(1, 2)]) / p[(1, 1)]);
        let rho = self.field.undistorted_radius_limit();
        if n.x * n.x + n.y * n.y > rho * rho * (1.0 + FIELD_EDGE_TOLERANCE) {
            return false;
        }
        if only_field {
            return true;
        }
        let raw = self.raw_from_normalized(n);
        raw.x >= -RAW_EDGE_TOLERANCE_PX
            && raw.y >= -RAW_EDGE_TOLERANCE_PX
            && raw.x <= self.width as f64 - 1.0 + RAW_EDGE_TOLERANCE_PX
            && raw.y <= self.height as f64 - 1.0 + RAW_EDGE_TOLERANCE_PX
    }

    /// [`Self::output_pixel_inside`] for every output pixel, row-major.
    pub(super) fn output_mask(&self, only_field: bool) -> Vec<bool> {
        let w = self.width as usize;
        let mut mask = vec![false; w * self.height as usize];
        mask.par_chunks_mut(w.max(1))
            .enumerate()
            .for_each(|(y, row)| {
                for (x, v) in row.iter_mut().enumerate() {
                    *v = self.output_pixel_inside(x as f64, y as f64, only_field);
                }
            });
        mask
    }

    /// The largest axis-aligned rectangle of output pixels inside the valid field that
    /// come from inside the raw frame ([`Self::output_pixel_inside`]). That region is
    /// star-shaped about the principal point (a disc intersected with the image of the raw
    /// frame under a radial model increasing inside the field), so when every pixel of the
    /// output's border is inside, the whole output is: the common case is settled by the
    /// border alone, the others by the full mask.
    pub(super) fn compute_crop(&self) -> Result<Rect, CalibError> {
        let (w, h) = (self.width as usize, self.height as usize);
        let border = (0..w)
            .flat_map(|x| [(x, 0), (x, h.saturating_sub(1))])
            .chain((0..h).flat_map(|y| [(0, y), (w.saturating_sub(1), y)]));
        let (cx, cy) = (
            self.new_camera_matrix[(0, 2)],
            self.new_camera_matrix[(1, 2)],
        );
        let centre_inside = cx >= 0.0 && cy >= 0.0 && cx <= w as f64 - 1.0 && cy <= h as f64 - 1.0;
        if centre_inside
            && border
                .into_iter()
                .all(|(x, y)| self.output_pixel_inside(x as f64, y as f64, false))
        {
            return Ok(Rect::new(0, 0, w as i32, h as i32));
        }
        let mask = self.output_mask(false);
        largest_rectangle(&mask, w, h).ok_or_else(|| CalibError::Diverged {
            what: "no pixel of the undistorted view lies inside the calibrated field".to_string(),
        })
    }
}

/// The largest-area axis-aligned rectangle of `true` cells in a row-major `w` x `h` mask
/// (the classic histogram-and-stack method, O(w h)); `None` when no cell is set.
fn largest_rectangle(mask: &[bool], w: usize, h: usize) -> Option<Rect> {
    let mut heights = vec![0usize; w];
    let mut best: Option<(usize, Rect)> = None;
    let mut stack: Vec<usize> = Vec::with_capacity(w + 1);
    for y in 0..h {
        for x in 0..w {
            heights[x] = if mask[y * w + x] { heights[x] + 1 } else { 0 };
        }
        stack.clear();
        for x in 0..=w {
            let current = if x < w { heights[x] } else { 0 };
            while let Some(&top) = stack.last() {
                if heights[top] < current {
                    break;
                }
                stack.pop();
                let height = heights[top];
                let left = stack.last().map(|&l| l + 1).unwrap_or(0);
                let width = x - left;
                let area = height * width;
                if height > 0 && best.as_ref().map(|(a, _)| area > *a).unwrap_or(true) {
                    best = Some((
                        area,
                        Rect::new(
                            left as i32,
                            (y + 1 - height) as i32,
                            width as i32,
                            height as i32,
                        ),
                    ));
                }
            }
            stack.push(x);
        }
    }
    best.map(|(_, r)| r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_largest_rectangle_of_a_mask() {
        #[rustfmt::skip]
        let mask = [
            0, 1, 1, 0, 0,
            1, 1, 1, 1, 0,
            1, 1, 1, 1, 1,
            0, 1, 1, 1, 0,
        ].map(|v| v == 1);
        let r = largest_rectangle(&mask, 5, 4).unwrap();
        assert_eq!((r.x, r.y, r.width, r.height), (1, 1, 3, 3));
        assert!(largest_rectangle(&[false; 6], 3, 2).is_none());
        assert_eq!(
            largest_rectangle(&[true; 6], 3, 2).unwrap(),
            Rect::new(0, 0, 3, 2)
        );
    }
}
