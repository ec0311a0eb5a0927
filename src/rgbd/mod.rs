//! RGB-D sessions: colour frames with aligned 16-bit depth give 3D marker positions, so
//! the radius comes out in mm with no scale photo (circle fitted in the best-fit plane
//! of the 3D markers, [`crate::fit::fit_circle_3d`]).
//!
//! Two layouts, both with `pressure_log.csv` (`time_s, pressure_<unit>`):
//!
//! ```text
//! SESSION/                 PNG frames
//!   color/             colour frames (PNG/JPG), sorted by name
//!   depth/             16-bit PNG depth frames aligned to the colour frames, same names
//!   intrinsics.json    {"width", "height", "fx", "fy", "cx", "cy", "depth_scale_m",
//!                       "fps", "distortion": [k1, k2, p1, p2, k3] (optional)}
//!   pressure_log.csv   time_s, pressure_<unit>
//!   frames.csv         optional: frame,time_s (else times from the frame names)
//!
//! SESSION/                 a RealSense recording
//!   recording.bag      any one *.bag: ROS1 bag v2.0 from the RealSense Viewer or
//!                      rs-record, colour + depth streams ([`bag`])
//!   pressure_log.csv   time_s, pressure_<unit>; time 0 = the first colour frame
//! ```
//!
//! `depth_scale_m` is metres per depth unit (RealSense convention: 0.001 by default,
//! 0.0001 in high-accuracy presets; a bag records it as the Depth Units option). PNG
//! depth is assumed aligned to the colour image (RealSense `align` to colour); a bag's
//! raw depth is aligned here from its recorded intrinsics and extrinsics ([`align`]).
//! Both yield the same (colour, aligned depth, time) frames to the same measuring code
//! (`pipeline::source::{RgbdSource, BagSource}`): the actuator's side face is a plane
//! fitted to the depth pixels along the marker chain ([`markers_on_depth_plane`]).

pub mod align;
pub mod bag;
pub mod rosmsg;

use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, Point2, Point3};
use serde::Deserialize;

use crate::calib::{Calibration, CameraModel, UndistortSettings, Undistorter};
use crate::measure::records::FrameStatus;

/// Name of the intrinsics file.
pub const INTRINSICS: &str = "intrinsics.json";

/// A 16-bit depth frame aligned to the colour frame.
pub type DepthImage = image::ImageBuffer<image::Luma<u16>, Vec<u16>>;

/// What to do about a missing or unreadable intrinsics file.
const INTRINSICS_HINT: &str = "write the colour camera's intrinsics as JSON: {\"width\", \"height\", \"fx\", \"fy\", \"cx\", \"cy\", \"depth_scale_m\", \"fps\"} (the RealSense SDK prints them)";

/// Errors of RGB-D sessions.
#[derive(Debug, thiserror::Error)]
pub enum RgbdError {
    /// Folder layout or intrinsics problem.
    #[error("{path}: {why}")]
    Layout {
        /// File or folder.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
}

/// Colour camera intrinsics and depth scale.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RgbdIntrinsics {
    /// Frame width, px.
    pub width: u32,
    /// Frame height, px.
    pub height: u32,
    /// Focal length x, px.
    pub fx: f64,
    /// Focal length y, px.
    pub fy: f64,
    /// Principal point x, px.
    pub cx: f64,
    /// Principal point y, px.
    pub cy: f64,
    /// Metres per depth unit.
    pub depth_scale_m: f64,
    /// Frames per second (times frames named by frame number: number / fps).
    #[serde(default = "default_fps")]
    pub fps: f64,
    /// Brown coefficients k1 k2 p1 p2 k3 (empty: none).
    #[serde(default)]
    pub distortion: Vec<f64>,
}

fn default_fps() -> f64 {
    30.0
}

impl RgbdIntrinsics {
    /// Reads and checks `intrinsics.json`.
    pub fn read(path: &Path) -> Result<Self, RgbdError> {
        let bad = |why: String| RgbdError::Layout {
            path: path.to_path_buf(),
            why,
        };
        let text = std::fs::read_to_string(path).map_err(|e| {
            bad(match e.kind() {
                std::io::ErrorKind::NotFound => format!("no such file: {INTRINSICS_HINT}"),
                _ => format!("{e}: {INTRINSICS_HINT}"),
            })
        })?;
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        let i: RgbdIntrinsics = serde_json::from_str(text)
            .map_err(|e| bad(format!("not valid JSON ({e}): {INTRINSICS_HINT}")))?;
        let pos = [i.fx, i.fy, i.depth_scale_m, i.fps];
        if i.width == 0 || i.height == 0 || !pos.iter().all(|v| v.is_finite() && *v > 0.0) {
            return Err(bad(
                "width, height, fx, fy, depth_scale_m and fps must be positive".into(),
            ));
        }
        if !i.distortion.is_empty() && i.distortion.len() != 5 {
            return Err(bad(
                "distortion needs 5 Brown coefficients k1 k2 p1 p2 k3 (or none)".into(),
            ));
        }
        Ok(i)
    }

    /// The colour camera as a pinhole calibration.
    pub fn calibration(&self) -> Calibration {
        let mut d = self.distortion.clone();
        d.resize(5, 0.0);
        Calibration {
            model: CameraModel::Pinhole,
            image_width: self.width,
            image_height: self.height,
            camera_matrix: Matrix3::new(
                self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0,
            ),
            distortion: d,
            avg_reprojection_error: f64::NAN,
            per_view_errors: vec![],
            board: None,
            views_used: vec![],
            views_rejected: vec![],
            coverage: None,
        }
    }
}

/// One colour frame and its depth frame.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbdFrame {
    /// Frame number (from the name, see [`list_frames`]).
    pub index: u64,
    /// Time, s (from the name or `frames.csv`).
    pub time_s: f64,
    /// Colour frame.
    pub color: PathBuf,
    /// Depth frame of the same stem, when there is one.
    pub depth: Option<PathBuf>,
}

/// The frames of an RGB-D folder.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbdListing {
    /// The colour camera.
    pub intrinsics: RgbdIntrinsics,
    /// Colour frames in time order (an orphan colour frame has `depth: None`).
    pub frames: Vec<RgbdFrame>,
    /// Depth frames with no colour frame of the same stem, by name.
    pub orphan_depth: Vec<String>,
    /// How the frames were timed, for the log.
    pub timing: String,
}

/// True when `session` has `color/` and `depth/` folders, or a `.bag` recording.
pub fn is_rgbd_session(session: &Path) -> bool {
    has_png_frames(session) || !bag_files(session).is_empty()
}

fn has_png_frames(session: &Path) -> bool {
    session.join("color").is_dir() && session.join("depth").is_dir()
}

/// The `*.bag` entries of `session` (not hidden), sorted: files, and folders named like
/// one (refused by [`rgbd_frames`] naming them, rather than overlooked).
fn bag_files(session: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(session)
        .map(|rd| {
            rd.flatten()
                .map(|e| e.path())
                .filter(|p| {
                    (p.is_file() || p.is_dir())
                        && !is_hidden(p)
                        && p.extension().is_some_and(|e| e.eq_ignore_ascii_case("bag"))
                })
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Where an RGB-D session's frames are.
#[derive(Debug, Clone, PartialEq)]
pub enum RgbdFrames {
    /// `color/` + `depth/` PNG frames and `intrinsics.json`.
    PngFolders,
    /// A RealSense `.bag` recording.
    Bag(PathBuf),
}

/// Which RGB-D layout `session` has (None: neither); two at once, or two bags, are
/// refused (which one was meant is not known).
pub fn rgbd_frames(session: &Path) -> Result<Option<RgbdFrames>, RgbdError> {
    let bags = bag_files(session);
    if let Some(folder) = bags.iter().find(|p| p.is_dir()) {
        return Err(RgbdError::Layout {
            path: folder.clone(),
            why: "a folder, not a recording: a RealSense recording is one .bag file: put the file itself in the session folder".into(),
        });
    }
    let names = |v: &[PathBuf]| {
        v.iter()
            .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
            .collect::<Vec<_>>()
            .join(", ")
    };
    match (has_png_frames(session), bags.as_slice()) {
        (false, []) => Ok(None),
        (true, []) => Ok(Some(RgbdFrames::PngFolders)),
        (false, [bag]) => Ok(Some(RgbdFrames::Bag(bag.clone()))),
        (true, _) => Err(RgbdError::Layout {
            path: session.to_path_buf(),
            why: format!(
                "both color/ + depth/ frames and a recording ({}): keep one of them in this session folder",
                names(&bags)
            ),
        }),
        (false, _) => Err(RgbdError::Layout {
            path: session.to_path_buf(),
            why: format!(
                "{} .bag recordings ({}): keep one per session folder",
                bags.len(),
                names(&bags)
            ),
        }),
    }
}

/// Name of the optional frame time table of an RGB-D session (`frame,time_s`).
pub const FRAME_TIMES: &str = "frames.csv";

/// The number a frame's name ends with: `000123` -> 123, `color_1700000000123.456` ->
/// 1700000000123.456.
fn trailing_number(stem: &str) -> Option<f64> {
    let start = stem
        .char_indices()
        .rev()
        .take_while(|(_, c)| c.is_ascii_digit() || *c == '.')
        .last()
        .map(|(i, _)| i)?;
    stem[start..].trim_matches('.').parse::<f64>().ok()
}

/// Lists the colour frames with their depth frames (matched by file stem) and times
/// them, never by their position in the list (a dropped frame must not shift the later
/// ones): from `frames.csv` (`frame,time_s`, frame = the colour file's stem) when
/// present, else from the number each name ends with: consecutive integers
/// (`000123.png`) are frame numbers, time = number / fps; other numbers (a RealSense
/// timestamp) are milliseconds, time = (t - t_first) / 1000.
pub fn list_frames(session: &Path) -> Result<RgbdListing, RgbdError> {
    let intrinsics = RgbdIntrinsics::read(&session.join(INTRINSICS))?;
    let list = |dir: &Path| -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
            .map(|rd| {
                rd.flatten()
                    .map(|e| e.path())
                    .filter(|p| p.is_file() && !is_hidden(p))
                    .collect()
            })
            .unwrap_or_default();
        v.sort();
        v
    };
    let stem = |p: &Path| {
        p.file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let colors = list(&session.join("color"));
    if colors.is_empty() {
        return Err(RgbdError::Layout {
            path: session.join("color"),
            why: "no colour frames".into(),
        });
    }
    let mut depth_by_stem: std::collections::BTreeMap<String, PathBuf> =
        list(&session.join("depth"))
            .into_iter()
            .map(|p| (stem(&p), p))
            .collect();
    let times_path = session.join(FRAME_TIMES);
    let (times, timing) = if times_path.is_file() {
        (
            read_frame_times(&times_path, &colors, stem)?,
            format!("times from {FRAME_TIMES}"),
        )
    } else {
        times_from_names(&colors, intrinsics.fps, stem).map_err(|why| RgbdError::Layout {
            path: session.join("color"),
            why,
        })?
    };
    let mut frames: Vec<RgbdFrame> = colors
        .into_iter()
        .zip(times)
        .map(|(color, (index, time_s))| RgbdFrame {
            index,
            time_s,
            depth: depth_by_stem.remove(&stem(&color)),
            color,
        })
        .collect();
    frames.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    let orphan_depth = depth_by_stem
        .into_values()
        .map(|p| {
            format!(
                "depth/{}",
                p.file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default()
            )
        })
        .collect();
    Ok(RgbdListing {
        intrinsics,
        frames,
        orphan_depth,
        timing,
    })
}

fn is_hidden(p: &Path) -> bool {
    p.file_name()
        .map(|n| n.to_string_lossy().starts_with('.'))
        .unwrap_or(false)
}

/// (index, time) of each colour frame from the numbers its name ends with.
fn times_from_names(
    colors: &[PathBuf],
    fps: f64,
    stem: impl Fn(&Path) -> String,
) -> Result<(Vec<(u64, f64)>, String), String> {
    let mut numbers = Vec::with_capacity(colors.len());
    for c in colors {
        match trailing_number(&stem(c)) {
            Some(n) if n.is_finite() && n >= 0.0 => numbers.push(n),
            _ => {
                return Err(format!(
                    "cannot time {}: name colour frames by frame number (000123.png) or timestamp in ms, or give {FRAME_TIMES} (frame,time_s)",
                    c.display()
                ))
            }
        }
    }
    let mut sorted = numbers.clone();
    sorted.sort_by(f64::total_cmp);
    let steps: Vec<f64> = sorted.windows(2).map(|w| w[1] - w[0]).collect();
    if steps.iter().any(|s| *s == 0.0) {
        return Err(format!(
            "two colour frames carry the same number: give {FRAME_TIMES} (frame,time_s)"
        ));
    }
    let integers = numbers.iter().all(|n| n.fract() == 0.0);
    let frame_numbers =
        integers && (steps.is_empty() || crate::measure::stats::median(&steps) <= 1.0);
    Ok(if frame_numbers {
        (
            numbers.iter().map(|n| (*n as u64, n / fps)).collect(),
            format!("frame numbers from the names at {fps} fps"),
        )
    } else {
        let t0 = sorted[0];
        (
            numbers
                .iter()
                .map(|n| (n.round() as u64, (n - t0) / 1000.0))
                .collect(),
            "timestamps in ms from the names".to_string(),
        )
    })
}

/// (index, time) of each colour frame from `frames.csv`: header `frame,time_s`, `frame`
/// the colour file's stem (or its number).
fn read_frame_times(
    path: &Path,
    colors: &[PathBuf],
    stem: impl Fn(&Path) -> String,
) -> Result<Vec<(u64, f64)>, RgbdError> {
    let table = crate::table::Table::read(path).map_err(|e| RgbdError::Layout {
        path: path.to_path_buf(),
        why: e.to_string(),
    })?;
    let bad = |why: String| RgbdError::Layout {
        path: path.to_path_buf(),
        why,
    };
    let hint = "write the header `frame,time_s` and one row per colour frame";
    let fc = table
        .require("frame", hint)
        .map_err(|e| bad(e.to_string()))?;
    let tc = table
        .require("time_s", hint)
        .map_err(|e| bad(e.to_string()))?;
    let mut by_frame = std::collections::HashMap::new();
    for r in 0..table.len() {
        let t = table.f64_at(r, tc).map_err(|e| bad(e.to_string()))?;
        by_frame.insert(table.cell(r, fc).trim().to_string(), t);
    }
    colors
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let s = stem(c);
            let number = trailing_number(&s);
            let t = by_frame
                .get(&s)
                .or_else(|| number.and_then(|n| by_frame.get(&format!("{n}"))))
                .copied()
                .ok_or_else(|| {
                    bad(format!(
                        "no time for colour frame {s}: add a row `{s},TIME_S`"
                    ))
                })?;
            Ok((number.map(|n| n as u64).unwrap_or(i as u64), t))
        })
        .collect()
}

/// Half-width of the band around the marker chain whose depth pixels give the
/// actuator's plane, as a share of the marker spacing (the side face is ~2 spacings tall
/// on the reference actuator, so the band stays on it).
pub const PLANE_BAND_SHARE: f64 = 0.35;
/// Inlier band of the RANSAC plane, mm (3 sigma of a RealSense-class depth noise at
/// 0.3-0.5 m is ~2.5 mm; the background sheet is centimetres behind).
pub const PLANE_INLIER_MM: f64 = 4.0;
/// Fewest valid depth pixels in the band for a plane.
pub const MIN_PLANE_PIXELS: usize = 50;
/// Most depth pixels used for the plane (a regular subsample beyond that).
pub const MAX_PLANE_PIXELS: usize = 20_000;

fn distance_to_segment(p: Point2<f64>, a: Point2<f64>, b: Point2<f64>) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(&ab) / ab.norm_squared().max(1e-12)).clamp(0.0, 1.0);
    (p - (a + ab * t)).norm()
}

/// 3D positions (mm, colour camera frame) of markers at raw pixels `ordered` (chain
/// order): the actuator's side face is a plane fitted robustly
/// ([`crate::fit::fit_plane_robust`]) to every valid depth pixel in a band along the
/// marker chain, and each marker is where its viewing ray meets that plane. Thousands of
/// depth pixels average the sensor noise that a per-marker median keeps (measured: per-
/// frame radius errors of several percent at 0.8 mm noise and 25 degrees of tilt).
pub fn markers_on_depth_plane(
    ordered: &[Point2<f64>],
    depth: &image::ImageBuffer<image::Luma<u16>, Vec<u16>>,
    intr: &RgbdIntrinsics,
    undistorter: &Undistorter,
) -> Result<Vec<Point3<f64>>, FrameStatus> {
    let (w, h) = depth.dimensions();
    let mut spacing: Vec<f64> = ordered.windows(2).map(|p| (p[1] - p[0]).norm()).collect();
    spacing.sort_by(f64::total_cmp);
    let band = PLANE_BAND_SHARE * spacing.get(spacing.len() / 2).copied().unwrap_or(10.0);
    let (mut x0, mut y0, mut x1, mut y1) = (
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    );
    for p in ordered {
        x0 = x0.min(p.x - band);
        y0 = y0.min(p.y - band);
        x1 = x1.max(p.x + band);
        y1 = y1.max(p.y + band);
    }
    let clamp = |v: f64, hi: u32| v.round().clamp(0.0, hi.saturating_sub(1) as f64) as u32;
    let (x0, x1, y0, y1) = (clamp(x0, w), clamp(x1, w), clamp(y0, h), clamp(y1, h));
    let mut pixels = Vec::new();
    let mut depths = Vec::new();
    for y in y0..=y1 {
        for x in x0..=x1 {
            let d = depth.get_pixel(x, y)[0];
            if d == 0 {
                continue;
            }
            let p = Point2::new(x as f64, y as f64);
            let near = ordered
                .windows(2)
                .any(|s| distance_to_segment(p, s[0], s[1]) <= band);
            if near {
                pixels.push(p);
                depths.push(d);
            }
        }
    }
    if pixels.len() < MIN_PLANE_PIXELS {
        return Err(FrameStatus::NoDepth {
            valid_px: pixels.len(),
        });
    }
    let step = pixels.len().div_ceil(MAX_PLANE_PIXELS);
    let (pixels, depths): (Vec<Point2<f64>>, Vec<u16>) =
        pixels.into_iter().zip(depths).step_by(step).unzip();
    let failed = |e: String| FrameStatus::FitFailed { why: e };
    let rays = undistorter
        .rays_from_pixels(&pixels)
        .map_err(|e| failed(format!("undistortion failed: {e}")))?;
    let mm_per_unit = intr.depth_scale_m * 1000.0;
    let cloud: Vec<Point3<f64>> = rays
        .iter()
        .zip(&depths)
        .map(|(r, d)| Point3::from(r * (*d as f64 * mm_per_unit)))
        .collect();
    let plane = crate::fit::fit_plane_robust(&cloud, PLANE_INLIER_MM.max(3.0 * mm_per_unit))
        .map_err(|e| failed(format!("actuator plane: {e}")))?;
    let marker_rays = undistorter
        .rays_from_pixels(ordered)
        .map_err(|e| failed(format!("undistortion failed: {e}")))?;
    marker_rays
        .iter()
        .map(|r| {
            plane
                .intersect_ray(r)
                .ok_or_else(|| failed("a marker's viewing ray misses the actuator plane".into()))
        })
        .collect()
}

/// The colour camera's undistorter (identity framing: rays only are used).
pub fn undistorter(intr: &RgbdIntrinsics) -> Result<Undistorter, crate::calib::CalibError> {
    Undistorter::new(&intr.calibration(), UndistortSettings::default())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_folder_named_like_a_bag_is_refused_naming_it() {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir(d.path().join("x.bag")).unwrap();
        assert!(is_rgbd_session(d.path()));
        let e = rgbd_frames(d.path()).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{}: a folder, not a recording: a RealSense recording is one .bag file: put the file itself in the session folder",
                d.path().join("x.bag").display()
            )
        );
    }

    #[test]
    fn intrinsics_read_and_check() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(INTRINSICS);
        let good = r#"{"width": 640, "height": 480, "fx": 600, "fy": 600, "cx": 320, "cy": 240, "depth_scale_m": 0.001}"#;
        std::fs::write(&p, format!("\u{feff}{good}")).unwrap();
        let i = RgbdIntrinsics::read(&p).unwrap();
        assert_eq!((i.width, i.fps, i.distortion.len()), (640, 30.0, 0));
        for bad in [
            good.replace("600,", "-600,"),
            good.replace("}", r#", "distortion": [0.1]}"#),
            good.replace("}", r#", "extra": 1}"#),
            "{".to_string(),
        ] {
            std::fs::write(&p, &bad).unwrap();
            let e = RgbdIntrinsics::read(&p).unwrap_err().to_string();
            assert!(e.starts_with(&p.display().to_string()), "{e}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        #[test]
        fn arbitrary_intrinsics_read_or_fail_without_panicking(
            bytes in prop_oneof![
                prop::collection::vec(any::<u8>(), 0..120),
                prop::collection::vec(
                    prop::sample::select(
                        [
                            "{", "}", "[", "]", ",", ":", "\"width\"", "\"height\"", "\"fx\"",
                            "\"fy\"", "\"cx\"", "\"cy\"", "\"depth_scale_m\"", "\"fps\"",
                            "\"distortion\"", "0", "1", "-1", "1e400", "0.001", "4294967296",
                            "null", " ",
                        ]
                        .to_vec(),
                    ),
                    0..40,
                )
                .prop_map(|t| t.concat().into_bytes()),
            ]
        ) {
            let d = tempfile::tempdir().unwrap();
            let p = d.path().join(INTRINSICS);
            std::fs::write(&p, &bytes).unwrap();
            if let Ok(i) = RgbdIntrinsics::read(&p) {
                prop_assert!(i.fx > 0.0 && i.fy > 0.0 && i.fps > 0.0 && i.width > 0);
            }
        }
    }
}
