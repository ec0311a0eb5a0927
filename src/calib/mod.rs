//! Camera models, checkerboard calibration and undistortion.
