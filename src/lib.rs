//! bendscope: characterize soft pneumatic bending actuators (PneuNets) from video and
//! check them against a built-in finite-element model.
//!
//! The modules follow the order in which data flows:
//! [`video`] (frame sources) -> [`calib`] (camera models, calibration, undistortion) ->
//! [`scale`] (mm per undistorted pixel) -> [`detect`] (red mask, hole fill, labels,
//! centroids) -> [`fit`] (circle, bending angle, power law) -> [`session`] (batch, manifests,
//! aggregation; [`rgbd`] for colour + depth sessions) -> [`report`] (CSV, plots, overlays). Beside them: [`fem`] (the actuator
//! model and its solver) and [`render`] (synthetic camera images with known ground truth).
//! Every CSV read or written goes through [`table`] (on polars: BOM, CRLF and quoted fields
//! read correctly, errors that name the file, line and column); [`io`] writes files
//! atomically.
//!
//! # Conventions
//!
//! - Image coordinates: x to the right, y down, origin at the centre of the top-left pixel,
//!   in pixels (`_px`). Geometry is `f64` throughout.
//! - Physical lengths in millimetres (`_mm`), pressures in kPa internally (`_kpa`);
//!   other units only at the edges (manifest columns, reports) and always named.
//! - Calibration files are OpenCV `FileStorage` YAML, readable by `cv2.FileStorage` as is.
//! - Library code returns errors (one `thiserror` enum per module family); only the binary
//!   uses `anyhow`.

pub mod calib;
pub mod compare;
pub mod detect;
pub mod fem;
pub mod fit;
pub mod io;
pub mod pipeline;
pub mod render;
pub mod report;
pub mod rgbd;
pub mod scale;
pub mod select;
pub mod session;
pub mod table;
pub mod video;
