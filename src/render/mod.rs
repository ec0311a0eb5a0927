//! Synthetic camera images with known ground truth.
