//! bendscope: characterize soft pneumatic bending actuators (PneuNets) from video and
//! check them against a built-in finite-element model.
//!
//! The modules follow the order in which data flows:
//! [`video`] (decode, encode) -> [`calib`] (camera models, calibration, valid field,
//! undistortion) -> [`scale`] (mm per undistorted pixel) -> [`detect`] (red mask, hole
//! fill, labels, centroids) -> [`select`] (the markers among red blobs) -> [`fit`]
//! (circle, plane, bending angle, power law) -> [`pipeline`] (a session measured:
//! sources, `measure_frame`, cache, outputs; its records and statistics in [`measure`];
//! hysteresis loops and step responses of the pressure history in [`dynamics`])
//! -> [`report`] (plots,
//! overlays, the HTML page). [`session`] (manifest, pressure log, settings), [`table`]
//! (the one CSV layer), [`rgbd`] (colour + depth: PNG folders, RealSense bags) and
//! [`io`] (atomic writes, content keys) serve them. Beside them: [`fem`] (the actuator model and its solver),
//! [`render`] (synthetic camera images with known ground truth), [`compare`], [`study`]
//! (several samples and runs: means, spreads, fits with bands, the FEM over them),
//! [`material_fit`] (hyperelastic models from tensile tests), [`fit_model`] (model
//! parameters fitted to a measurement) and [`control`] (a PID closing the loop on the
//! model). Design exploration: [`sweep`] (many simulations: local pool, GNU parallel,
//! Slurm) -> [`surrogate`] (Gaussian-process models of a design table) ->
//! [`optimize`] (Bayesian optimization or a Pareto front on them, checked with the FEM).
//! Before them all, [`acquire`] records a session on the bench (pressure regulator on a
//! serial line, GoPro or webcam) into the folder layout [`session`] reads.
//! [`child`] keeps their child processes (a webcam's ffmpeg, a sweep's points) from
//! outliving bendscope.
//!
//! Measuring a session is one call, [`pipeline::measure_session`]; the `bendscope`
//! binary only parses flags, calls it and prints.
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

pub mod acquire;
pub mod calib;
pub mod child;
pub mod compare;
pub mod control;
pub mod detect;
pub mod dynamics;
pub mod fem;
pub mod fit;
pub mod fit_model;
pub mod inspect;
pub mod io;
pub mod lock;
pub mod material_fit;
pub mod measure;
pub mod optimize;
pub mod pipeline;
pub mod render;
pub mod report;
pub mod rgbd;
pub mod scale;
pub mod segments;
pub mod select;
pub mod session;
pub mod study;
pub mod surrogate;
pub mod sweep;
pub mod table;
pub mod video;
