//! Scale: millimetres per undistorted pixel.
