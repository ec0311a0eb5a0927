//! Synthetic session folders: a GoPro-like fisheye camera films an actuator whose marker
//! line is a circular arc of known radius at each pressure; with calibration photos, a
//! scale photo in the actuator plane, `pressures.csv` and `truth.json`.

use std::path::Path;

use nalgebra::{Point2, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use super::actuator::{ArcScene, FrameLook, PlaneSampler, Shade, BODY_RGB, MARKER_RGB};
use super::board::{render_board_photo, BoardPose, PhotoSettings};
use super::fixtures::{write_calibration_set, write_jpeg, CalibrationSetSpec, CameraTruth};
use super::rng::SplitMix64;
use super::RenderError;
use crate::calib::{Board, Calibration, UndistortSettings, Undistorter};
use crate::io::write_atomic;
use crate::video::{EncodeSettings, VideoWriter};

/// What to render.
#[derive(Debug, Clone)]
pub struct SessionSpec {
    /// Camera.
    pub camera: Calibration,
    /// Distance of the actuator plane, mm (fronto-parallel).
    pub distance_mm: f64,
    /// Pressures, kPa.
    pub pressures_kpa: Vec<f64>,
    /// Radius of the marker arc at pressure p: a p^b + c (mm, kPa).
    pub radius_law: (f64, f64, f64),
    /// Frames per video.
    pub frames: usize,
    /// Calibration photos.
    pub calib_views: usize,
    /// The calibration boards stay inside the disc of this share of the frame's
    /// half-diagonal around the frame centre (1: anywhere in the frame).
    pub calib_view_reach: f64,
    /// Square size of the scale board (9x6 inner corners), mm.
    pub scale_square_mm: f64,
    /// Where the scale board lies: `Some(o)`, parallel to the actuator plane and `o` mm in
    /// front of it (nearer the camera; negative: behind), written to bendscope.toml as
    /// `[scale_board] offset_mm` (0: in the plane, the usual board); `None`, no scale
    /// photo, and bendscope.toml gets `[scale_markers]` with the rest spacing of the
    /// first 0 kPa video's markers.
    pub scale_board_offset_mm: Option<f64>,
    /// A red object that is not a marker, in every frame.
    pub distractor: bool,
    /// Samples per pixel side.
    pub supersample: u32,
    /// Look of the frames.
    pub look: FrameLook,
    /// Seed.
    pub seed: u64,
}

/// One video's truth.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct VideoTruth {
    /// File name.
    pub file: String,
    /// Pressure, kPa.
    pub pressure_kpa: f64,
    /// Radius of the circle through the marker centres, mm.
    pub radius_mm: f64,
    /// Turning angle between the first and last marker, degrees.
    pub bending_angle_deg: f64,
    /// Marker centres in the actuator plane, mm.
    pub markers_mm: Vec<[f64; 2]>,
}

/// `truth.json` of a synthetic session.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SessionTruth {
    /// The camera.
    pub camera: CameraTruth,
    /// Distance of the actuator plane, mm.
    pub distance_mm: f64,
    /// True mm per undistorted px in the actuator plane.
    pub mm_per_px: f64,
    /// Videos.
    pub videos: Vec<VideoTruth>,
}

/// Arc-length positions of the 8 markers from the clamp edge: centres of chambers 2..9 of
/// the reference actuator (first chamber 13.75 mm, clamped; 1 mm gaps; 11.5 mm chambers).
pub fn reference_marker_positions_mm() -> Vec<f64> {
    ArcScene::reference_actuator(0.0, Point2::origin()).marker_s_mm
}

/// Renders a whole session into `dir`: a circular-arc actuator whose radius follows
/// `spec.radius_law`.
pub fn write_session(dir: &Path, spec: &SessionSpec) -> Result<SessionTruth, RenderError> {
    write_arc_session(dir, spec, MARKER_RGB)
}

/// [`write_session`] without dots: the same actuator, its dots painted in the body's
/// colour ([`BODY_RGB`]), for outline mode. truth.json still lists where the dots would
/// be (their line's radius and bending angle).
pub fn write_session_without_dots(
    dir: &Path,
    spec: &SessionSpec,
) -> Result<SessionTruth, RenderError> {
    write_arc_session(dir, spec, BODY_RGB)
}

fn write_arc_session(
    dir: &Path,
    spec: &SessionSpec,
    marker_rgb: [f64; 3],
) -> Result<SessionTruth, RenderError> {
    let videos = spec
        .pressures_kpa
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            let (a, b, c) = spec.radius_law;
            let radius = a * p.powf(b) + c;
            let scene = ArcScene {
                distractor: spec.distractor.then(|| (Point2::new(75.0, 55.0), 8.0)),
                marker_rgb,
                ..ArcScene::reference_actuator(1.0 / radius, Point2::new(-50.0, 22.0))
            };
            let truth = VideoTruth {
                file: video_name(i),
                pressure_kpa: p,
                radius_mm: radius,
                bending_angle_deg: scene.bending_angle_deg(),
                markers_mm: scene.markers_mm().iter().map(|m| [m.x, m.y]).collect(),
            };
            (scene, truth)
        })
        .collect();
    render_session(dir, spec, videos, &|_| {})
}

/// Writes a table of preformatted cells through [`crate::table::write_csv`] (the
/// numbers keep the exact text the renderer gives them).
fn write_text_table<const N: usize>(
    path: &Path,
    columns: [(&str, Vec<String>); N],
) -> Result<(), RenderError> {
    let cols: Vec<crate::table::Column> = columns
        .into_iter()
        .map(|(name, cells)| crate::table::Column::text(name, cells))
        .collect();
    crate::table::write_csv(path, &cols).map_err(|e| RenderError::Fem(e.to_string()))
}

/// GoPro-like name of the i-th video of a session.
pub fn video_name(i: usize) -> String {
    format!("GX01{:04}.MP4", 101 + i)
}

/// Renders `videos` (a scene and its truth each) with the rig of `spec` (camera,
/// distance, frames, calibration photos, scale photo, look, seed; `pressures_kpa`,
/// `radius_law` and `distractor` are not used) into `dir`; `progress` sees the index of
/// each finished video.
pub fn render_session<S: Shade + Sync>(
    dir: &Path,
    spec: &SessionSpec,
    videos: Vec<(S, VideoTruth)>,
    progress: &dyn Fn(usize),
) -> Result<SessionTruth, RenderError> {
    let err = |e: std::io::Error| RenderError::write(dir, &e);
    std::fs::create_dir_all(dir).map_err(err)?;
    // Calibration photos (9x6, 25 mm) in calib/.
    write_calibration_set(
        dir,
        &CalibrationSetSpec {
            camera: spec.camera.clone(),
            board: Board::new(9, 6, 25.0).map_err(RenderError::Camera)?,
            views: spec.calib_views,
            view_reach: spec.calib_view_reach,
            scale_distance_mm: 400.0,
            photo: PhotoSettings {
                supersample: spec.supersample,
                blur_sigma_px: 0.7,
                noise_sigma: 2.0,
                seed: spec.seed,
            },
            seed: spec.seed,
        },
    )?;
    let _ = std::fs::remove_file(dir.join("truth.json"));
    // Scale photo: a small board in the actuator plane, or parallel to it.
    let _ = std::fs::remove_file(dir.join("scale.jpg"));
    if let Some(offset) = spec.scale_board_offset_mm {
        let sb = Board::new(9, 6, spec.scale_square_mm).map_err(RenderError::Camera)?;
        let centre = Vector3::new(sb.square_mm * 4.0, sb.square_mm * 2.5, 0.0);
        let pose = BoardPose {
            rotation: Rotation3::identity(),
            translation_mm: Vector3::new(0.0, 0.0, spec.distance_mm - offset) - centre,
        };
        let photo = PhotoSettings {
            supersample: spec.supersample,
            blur_sigma_px: 0.7,
            noise_sigma: 2.0,
            seed: spec.seed ^ 77,
        };
        write_jpeg(
            &dir.join("scale.jpg"),
            &render_board_photo(&spec.camera, &sb, &pose, &photo)?,
        )?;
    }
    let und = Undistorter::new(&spec.camera, UndistortSettings::default())?;
    let mm_per_px = spec.distance_mm / und.new_camera_matrix()[(0, 0)];
    // Videos.
    let plane = BoardPose {
        rotation: Rotation3::identity(),
        translation_mm: Vector3::new(0.0, 0.0, spec.distance_mm),
    };
    let sampler = PlaneSampler::new(&spec.camera, &plane, spec.supersample, spec.seed)?;
    let mut rng = SplitMix64::new(spec.seed ^ 0xACE);
    let mut truths = Vec::new();
    let mut manifest: (Vec<String>, Vec<String>) = (vec![], vec![]);
    for (i, (scene, truth)) in videos.into_iter().enumerate() {
        let file = truth.file.clone();
        let (w, h) = (spec.camera.image_width, spec.camera.image_height);
        let mut writer = VideoWriter::create(
            &dir.join(&file),
            w,
            h,
            &EncodeSettings {
                fps: 30,
                crf: 16,
                ..Default::default()
            },
        )
        .map_err(|e| err(std::io::Error::other(e.to_string())))?;
        for f in 0..spec.frames {
            let shift = [0.15 * rng.normal(), 0.15 * rng.normal()];
            let img = sampler.render(
                &scene,
                shift,
                &spec.look,
                spec.seed.wrapping_add((i * 1000 + f) as u64),
            );
            writer
                .write(&img)
                .map_err(|e| err(std::io::Error::other(e.to_string())))?;
        }
        writer
            .finish()
            .map_err(|e| err(std::io::Error::other(e.to_string())))?;
        manifest.0.push(file.clone());
        manifest.1.push(format!("{}", truth.pressure_kpa));
        truths.push(truth);
        progress(i);
    }
    write_text_table(
        &dir.join("pressures.csv"),
        [("file", manifest.0), ("pressure_kpa", manifest.1)],
    )?;
    let head = "# Settings of this session (see `bendscope process --help`).\n";
    let config = match spec.scale_board_offset_mm {
        Some(o) => format!(
            "{head}[scale_board]\ncols = 9\nrows = 6\nsquare_mm = {}\n{}",
            spec.scale_square_mm,
            if o == 0.0 {
                String::new()
            } else {
                format!("offset_mm = {o}\n")
            }
        ),
        None => match truths.iter().find(|t| t.pressure_kpa == 0.0) {
            Some(rest) => format!(
                "{head}[scale_markers]\nspacing_mm = [{}]\n",
                rest.markers_mm
                    .windows(2)
                    .map(|w| format!("{:.6}", (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            None => head.to_string(),
        },
    };
    write_atomic(&dir.join("bendscope.toml"), config.as_bytes()).map_err(err)?;
    let truth = SessionTruth {
        camera: CameraTruth::from_calibration(&spec.camera),
        distance_mm: spec.distance_mm,
        mm_per_px,
        videos: truths,
    };
    let json = serde_json::to_string_pretty(&truth).map_err(|e| err(e.into()))?;
    write_atomic(&dir.join("truth.json"), json.as_bytes()).map_err(err)?;
    Ok(truth)
}

/// Room kept right of the actuator for the distracting disc, mm.
const DISTRACTOR_ROOM_MM: f64 = 16.0;

/// Margin kept between the actuator and the frame border, as a fraction of the frame.
const VIEW_MARGIN: f64 = 0.04;

fn fits(
    und: &Undistorter,
    w: u32,
    h: u32,
    corners: &[Point2<f64>],
    distance_mm: f64,
) -> Result<bool, RenderError> {
    let pts: Vec<Vector3<f64>> = corners
        .iter()
        .map(|c| Vector3::new(c.x, c.y, distance_mm))
        .collect();
    let px = und.project(&pts)?;
    let (mx, my) = (VIEW_MARGIN * w as f64, VIEW_MARGIN * h as f64);
    Ok(px.iter().all(|p| {
        p.x.is_finite()
            && p.y.is_finite()
            && p.x >= mx
            && p.x <= w as f64 - mx
            && p.y >= my
            && p.y <= h as f64 - my
    }))
}

/// Places the simulated actuator in the plane so that the bounding box of all its steps
/// (and the clamp) is centred on the optical axis; checks that it fits the view at
/// `distance_mm` (fronto-parallel plane). Returns the plane position of the FEM origin.
pub fn place_fem_actuator(
    face: &crate::fem::simulate::SideFaceFile,
    camera: &Calibration,
    distance_mm: f64,
) -> Result<Point2<f64>, RenderError> {
    use super::fem_scene::scene_bounds;
    if face.steps.is_empty() || face.quads.is_empty() {
        return Err(RenderError::Fem(
            "the FEM output has no converged step to render".into(),
        ));
    }
    let (lo, mut hi) = scene_bounds(face, Point2::origin());
    // Room on the right for the optional distracting red disc.
    hi.x += DISTRACTOR_ROOM_MM;
    let centre = Point2::new(0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y));
    let origin = Point2::new(-centre.x, -centre.y);
    let (hw, hh) = (0.5 * (hi.x - lo.x), 0.5 * (hi.y - lo.y));
    let corners = [
        Point2::new(-hw, -hh),
        Point2::new(hw, -hh),
        Point2::new(hw, hh),
        Point2::new(-hw, hh),
        Point2::new(0.0, -hh),
        Point2::new(0.0, hh),
        Point2::new(-hw, 0.0),
        Point2::new(hw, 0.0),
    ];
    let und = Undistorter::new(camera, UndistortSettings::default())?;
    let (w, h) = (camera.image_width, camera.image_height);
    if fits(&und, w, h, &corners, distance_mm)? {
        return Ok(origin);
    }
    let mut d = distance_mm.max(10.0);
    for _ in 0..60 {
        d *= 1.1;
        if fits(&und, w, h, &corners, d)? {
            break;
        }
    }
    Err(RenderError::DoesNotFit {
        width_mm: 2.0 * hw,
        height_mm: 2.0 * hh,
        distance_mm,
        suggested_mm: (d / 10.0).ceil() * 10.0,
    })
}

/// One scene and its truth per FEM step: marker discs of `marker_diameter_mm` on the
/// FEM marker points; radius and bending angle of the rendered marker centres computed
/// by the image chain's own functions, in the plane.
pub fn fem_videos(
    face: &crate::fem::simulate::SideFaceFile,
    origin: Point2<f64>,
    marker_diameter_mm: f64,
    distractor: bool,
) -> Result<Vec<(super::fem_scene::FemScene, VideoTruth)>, RenderError> {
    use super::fem_scene::{scene_bounds, FemScene};
    use crate::fit::{bending_angle_along_markers_deg, fit_circle_pratt};
    let (lo, hi) = scene_bounds(face, origin);
    face.steps
        .iter()
        .enumerate()
        .map(|(i, step)| {
            let mut scene = FemScene::new(face, step, origin, marker_diameter_mm);
            if distractor {
                scene.distractor = Some((
                    Point2::new(hi.x + 0.5 * DISTRACTOR_ROOM_MM, 0.5 * (lo.y + hi.y)),
                    8.0,
                ));
            }
            let m = scene.markers_mm().to_vec();
            if m.len() < 3 {
                return Err(RenderError::Fem(format!(
                    "step {} has {} markers; need 3 or more",
                    i + 1,
                    m.len()
                )));
            }
            let circle = fit_circle_pratt(&m).map_err(|e| RenderError::Fem(e.to_string()))?;
            let angle = bending_angle_along_markers_deg(&m, &circle)
                .map_err(|e| RenderError::Fem(e.to_string()))?;
            let truth = VideoTruth {
                file: video_name(i),
                pressure_kpa: step.pressure_kpa,
                radius_mm: circle.radius,
                bending_angle_deg: angle,
                markers_mm: m.iter().map(|p| [p.x, p.y]).collect(),
            };
            Ok((scene, truth))
        })
        .collect()
}

/// An RGB-D recording of the simulated actuator: what to render.
#[derive(Debug, Clone)]
pub struct RgbdSpec {
    /// Distance of the actuator plane on the optical axis, mm.
    pub distance_mm: f64,
    /// Tilt of the actuator plane about the vertical axis, degrees (depth varies along it).
    pub tilt_deg: f64,
    /// Frames per pressure step.
    pub frames_per_step: usize,
    /// Frame rate of the recording (times in pressure_log.csv).
    pub fps: f64,
    /// Samples per pixel side.
    pub supersample: u32,
    /// Marker disc diameter, mm.
    pub marker_diameter_mm: f64,
    /// Look of the colour frames.
    pub look: FrameLook,
    /// Depth sensor noise, standard deviation, mm (Gaussian, independent per pixel and
    /// frame).
    pub depth_noise_mm: f64,
    /// Depth unit, m per level of the 16-bit frames (RealSense: 0.001; 0.0001 in
    /// high-accuracy presets).
    pub depth_scale_m: f64,
    /// Distance of the white sheet behind the actuator's side face, mm (0: in its
    /// plane).
    pub sheet_offset_mm: f64,
    /// Seed.
    pub seed: u64,
}

/// Depth unit of the RGB-D renders unless a spec says otherwise, m (a fine unit, so
/// the depth quantization does not hide other errors).
pub const DEPTH_SCALE_M: f64 = 0.0001;

/// The RGB-D camera of [`write_fem_rgbd`]: a 640x480 pinhole colour camera, depth
/// aligned to it.
pub fn rgbd_camera() -> Calibration {
    Calibration {
        model: crate::calib::CameraModel::Pinhole,
        image_width: 640,
        image_height: 480,
        camera_matrix: nalgebra::Matrix3::new(520.0, 0.0, 321.7, 0.0, 520.0, 238.2, 0.0, 0.0, 1.0),
        distortion: vec![0.0; 5],
        avg_reprojection_error: 0.0,
        per_view_errors: vec![],
        board: None,
        views_used: vec![],
        views_rejected: vec![],
        coverage: None,
    }
}

/// Writes an RGB-D session of the simulated actuator into `dir`: `color/` and 16-bit
/// `depth/` PNG frames (each pressure step held for `frames_per_step` frames),
/// `intrinsics.json`, `pressure_log.csv` and `truth.json` (the truths of the steps).
pub fn write_fem_rgbd(
    dir: &Path,
    face: &crate::fem::simulate::SideFaceFile,
    spec: &RgbdSpec,
) -> Result<Vec<VideoTruth>, RenderError> {
    let err = |e: std::io::Error| RenderError::write(dir, &e);
    let camera = rgbd_camera();
    let origin = place_fem_actuator(face, &camera, spec.distance_mm)?;
    let videos = fem_videos(face, origin, spec.marker_diameter_mm, false)?;
    for sub in ["color", "depth"] {
        std::fs::create_dir_all(dir.join(sub)).map_err(err)?;
    }
    let plane = BoardPose {
        rotation: Rotation3::from_euler_angles(0.0, spec.tilt_deg.to_radians(), 0.0),
        translation_mm: Vector3::new(0.0, 0.0, spec.distance_mm),
    };
    let sampler = PlaneSampler::new(&camera, &plane, spec.supersample, spec.seed)?;
    let und = Undistorter::new(&camera, UndistortSettings::default())?;
    let normal = plane.rotation * Vector3::z();
    let offset = normal.dot(&plane.translation_mm);
    let (w, h) = (camera.image_width, camera.image_height);
    let pixels: Vec<Point2<f64>> = (0..h)
        .flat_map(|y| (0..w).map(move |x| Point2::new(x as f64, y as f64)))
        .collect();
    let rays = und.rays_from_pixels(&pixels)?;
    // Each pixel centre's point on the actuator plane (plane coordinates, mm) and its
    // depth there and on the sheet behind.
    let inverse = plane.rotation.inverse();
    let hits: Vec<(Point2<f64>, f64, f64)> = rays
        .iter()
        .map(|ray| {
            let x = ray * (offset / normal.dot(ray));
            let q = inverse * (x - plane.translation_mm);
            let behind = ray * ((offset + spec.sheet_offset_mm) / normal.dot(ray));
            (Point2::new(q.x, q.y), x.z, behind.z)
        })
        .collect();
    let unit_mm = spec.depth_scale_m * 1000.0;
    let depth_png =
        |scene: &super::fem_scene::FemScene, frame_seed: u64| -> Result<Vec<u8>, RenderError> {
            let mut rng = SplitMix64::new(frame_seed ^ 0xD3E7);
            let depth = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(w, h, |x, y| {
                let (p, on_plane, behind) = hits[(y * w + x) as usize];
                let z = if scene.on_body(p) { on_plane } else { behind };
                let noisy = z + spec.depth_noise_mm * rng.normal();
                image::Luma([(noisy / unit_mm).round().clamp(0.0, 65535.0) as u16])
            });
            let mut png = Vec::new();
            depth
                .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
                .map_err(|e| err(std::io::Error::other(e.to_string())))?;
            Ok(png)
        };
    let mut log: (Vec<String>, Vec<String>) = (vec![], vec![]);
    let mut frame = 0usize;
    let mut truths = Vec::new();
    for (i, (scene, mut truth)) in videos.into_iter().enumerate() {
        let t0 = frame as f64 / spec.fps;
        for _ in 0..spec.frames_per_step {
            let img = sampler.render(
                &scene,
                [0.0, 0.0],
                &spec.look,
                spec.seed.wrapping_add(frame as u64),
            );
            let mut png = Vec::new();
            img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
                .map_err(|e| err(std::io::Error::other(e.to_string())))?;
            write_atomic(&dir.join(format!("color/{frame:06}.png")), &png).map_err(err)?;
            let depth = depth_png(&scene, spec.seed.wrapping_add(frame as u64))?;
            write_atomic(&dir.join(format!("depth/{frame:06}.png")), &depth).map_err(err)?;
            frame += 1;
        }
        let t1 = (frame - 1) as f64 / spec.fps;
        let p = truth.pressure_kpa;
        for t in [t0 - 0.3 / spec.fps, t1 + 0.3 / spec.fps] {
            log.0.push(format!("{t:.4}"));
            log.1.push(format!("{p}"));
        }
        truth.file = format!("step {}", i + 1);
        truths.push(truth);
    }
    write_text_table(
        &dir.join("pressure_log.csv"),
        [("time_s", log.0), ("pressure_kpa", log.1)],
    )?;
    let k = camera.camera_matrix;
    let intrinsics = format!(
        "{{\"width\": {w}, \"height\": {h}, \"fx\": {}, \"fy\": {}, \"cx\": {}, \"cy\": {}, \"depth_scale_m\": {}, \"fps\": {}}}\n",
        k[(0, 0)],
        k[(1, 1)],
        k[(0, 2)],
        k[(1, 2)],
        spec.depth_scale_m,
        spec.fps
    );
    write_atomic(&dir.join(crate::rgbd::INTRINSICS), intrinsics.as_bytes()).map_err(err)?;
    let json = serde_json::to_string_pretty(&truths).map_err(|e| err(e.into()))?;
    write_atomic(&dir.join("truth.json"), json.as_bytes()).map_err(err)?;
    Ok(truths)
}

/// Names of what makes a folder a session (`process` reads them): the manifest, a ramp's
/// pressure log, the acquisition log, `scale.*`, `calib/`, `truth.json` and videos.
/// Sorted; empty when `dir` holds none (or does not exist).
pub fn session_files_in(dir: &Path) -> Vec<String> {
    const TABLES: [&str; 4] = [
        crate::session::MANIFEST,
        crate::session::PRESSURE_LOG,
        crate::acquire::ACQUISITION_LOG,
        "truth.json",
    ];
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut found: Vec<String> = entries
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let path = e.path();
            let ext = path
                .extension()
                .map(|x| x.to_string_lossy().to_ascii_lowercase())
                .unwrap_or_default();
            let stem = path
                .file_stem()
                .map(|x| x.to_string_lossy().into_owned())
                .unwrap_or_default();
            let is_session_file = if path.is_dir() {
                name == "calib"
            } else {
                TABLES.contains(&name.as_str())
                    || crate::session::VIDEO_EXTENSIONS.contains(&ext.as_str())
                    || (stem == "scale" && crate::session::IMAGE_EXTENSIONS.contains(&ext.as_str()))
            };
            is_session_file.then(|| {
                if path.is_dir() {
                    format!("{name}/")
                } else {
                    name
                }
            })
        })
        .collect();
    found.sort();
    found
}

/// Marks a folder [`render_fem_session`] is writing; removed when the session is
/// complete. A render stopped on the way (killed, disk full) leaves it, and the rerun
/// recognises the partial session as its own.
pub const UNFINISHED_RENDER: &str = ".bendscope-render-unfinished";

/// Refuses to render into `dir` when it already holds a session ([`session_files_in`]):
/// the rendered videos, `scale.jpg`, `pressures.csv` and `calib/` would replace or mix
/// with a recorded session's. `force` renders over it anyway, and so does a render into
/// the unfinished session of an earlier render ([`UNFINISHED_RENDER`]).
pub fn check_render_target(dir: &Path, force: bool) -> Result<(), RenderError> {
    let files = session_files_in(dir);
    if force || files.is_empty() || dir.join(UNFINISHED_RENDER).is_file() {
        return Ok(());
    }
    const SHOWN: usize = 6;
    let mut list = files
        .iter()
        .take(SHOWN)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    if files.len() > SHOWN {
        list.push_str(&format!(" and {} more", files.len() - SHOWN));
    }
    Err(RenderError::SessionExists {
        dir: dir.to_path_buf(),
        files: list,
    })
}

/// How [`render_fem_session`] films a simulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FemRenderSettings {
    /// Distance of the actuator plane from the camera, mm.
    pub distance_mm: f64,
    /// Frames per video.
    pub frames: usize,
    /// Marker disc diameter, mm.
    pub marker_diameter_mm: f64,
    /// Calibration photos to render into calib/.
    pub calib_views: usize,
    /// Samples per pixel side.
    pub supersample: u32,
    /// A red disc that is not a marker beside the actuator.
    pub distractor: bool,
    /// No blur, noise, vignetting or light gradient.
    pub clean: bool,
    /// Also an RGB-D recording in `out/rgbd/`.
    pub rgbd: bool,
    /// Paint the marker dots (false: the bare body, for outline mode; truth.json still
    /// lists where the dots would be).
    pub dots: bool,
    /// Random seed.
    pub seed: u64,
}

impl Default for FemRenderSettings {
    fn default() -> Self {
        Self {
            distance_mm: 260.0,
            frames: 5,
            marker_diameter_mm: 3.0,
            calib_views: 14,
            supersample: 3,
            distractor: false,
            clean: false,
            rgbd: false,
            dots: true,
            seed: 7,
        }
    }
}

/// Reads `FEM_OUT/side_face.json` (written by `bendscope simulate`).
pub fn read_side_face(fem: &Path) -> Result<crate::fem::simulate::SideFaceFile, RenderError> {
    let path = fem.join("side_face.json");
    let text = std::fs::read_to_string(&path).map_err(|_| {
        RenderError::Fem(format!(
            "{} has no side_face.json: give the output folder of `bendscope simulate -o FEM_OUT`",
            fem.display()
        ))
    })?;
    serde_json::from_str(&text).map_err(|e| {
        RenderError::Fem(format!(
            "{} is not a bendscope side face file: {e}",
            path.display()
        ))
    })
}

/// Films every step of a simulation (`face`) through `camera` into the session folder
/// `out` (videos, pressures.csv, scale.jpg, calib/, truth.json; RGB-D in `out/rgbd/`
/// when asked). `on_video` is called after each video.
pub fn render_fem_session(
    face: &crate::fem::simulate::SideFaceFile,
    camera: &Calibration,
    out: &Path,
    settings: &FemRenderSettings,
    on_video: &(dyn Fn(usize) + Sync),
) -> Result<SessionTruth, RenderError> {
    let s = settings;
    if !(s.distance_mm.is_finite() && s.distance_mm > 0.0) {
        return Err(RenderError::Fem(format!(
            "distance {} mm: must be a positive distance",
            s.distance_mm
        )));
    }
    if !(s.marker_diameter_mm.is_finite()
        && s.marker_diameter_mm > 0.0
        && s.marker_diameter_mm < 12.0)
    {
        return Err(RenderError::Fem(format!(
            "marker diameter {} mm: use a diameter between 0 and 12 mm",
            s.marker_diameter_mm
        )));
    }
    if s.frames == 0 || s.supersample == 0 {
        return Err(RenderError::Fem(
            "frames and supersampling must be at least 1".into(),
        ));
    }
    let origin = place_fem_actuator(face, camera, s.distance_mm)?;
    let mut videos = fem_videos(face, origin, s.marker_diameter_mm, s.distractor)?;
    if !s.dots {
        for (scene, _) in &mut videos {
            scene.marker_rgb = BODY_RGB;
        }
    }
    let look = if s.clean {
        FrameLook {
            blur_sigma_px: 0.0,
            noise_sigma: 0.0,
            gradient: 0.0,
            vignetting: 0.0,
        }
    } else {
        FrameLook::default()
    };
    let spec = SessionSpec {
        camera: camera.clone(),
        distance_mm: s.distance_mm,
        pressures_kpa: videos.iter().map(|(_, t)| t.pressure_kpa).collect(),
        radius_law: (0.0, 0.0, 0.0),
        frames: s.frames,
        calib_views: s.calib_views,
        calib_view_reach: 1.0,
        scale_square_mm: 10.0,
        scale_board_offset_mm: Some(0.0),
        distractor: s.distractor,
        supersample: s.supersample,
        look,
        seed: s.seed,
    };
    let unfinished = out.join(UNFINISHED_RENDER);
    write_atomic(
        &unfinished,
        b"a render is writing this session, or was stopped before its end\n",
    )
    .map_err(|e| RenderError::write(out, &e))?;
    let truth = render_session(out, &spec, videos, on_video)?;
    if s.rgbd {
        write_fem_rgbd(
            &out.join("rgbd"),
            face,
            &RgbdSpec {
                distance_mm: s.distance_mm,
                tilt_deg: 15.0,
                frames_per_step: 3,
                fps: 10.0,
                supersample: s.supersample.max(4),
                marker_diameter_mm: s.marker_diameter_mm,
                look,
                depth_noise_mm: 0.0,
                depth_scale_m: DEPTH_SCALE_M,
                sheet_offset_mm: 0.0,
                seed: s.seed,
            },
        )?;
    }
    std::fs::remove_file(&unfinished).map_err(|e| RenderError::write(&unfinished, &e))?;
    Ok(truth)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_partial_render_is_rendered_over_and_a_recorded_session_refused() {
        let d = tempfile::tempdir().unwrap();
        let dir = d.path();
        assert!(check_render_target(dir, false).is_ok(), "empty");
        // What a render stopped on the way leaves: calib/ and scale.jpg.
        std::fs::create_dir(dir.join("calib")).unwrap();
        std::fs::write(dir.join("scale.jpg"), b"x").unwrap();
        match check_render_target(dir, false) {
            Err(RenderError::SessionExists { files, .. }) => {
                assert_eq!(files, "calib/, scale.jpg")
            }
            other => panic!("a session without the mark is refused: {other:?}"),
        }
        assert!(check_render_target(dir, true).is_ok(), "--force");
        std::fs::write(dir.join(UNFINISHED_RENDER), b"").unwrap();
        assert!(
            check_render_target(dir, false).is_ok(),
            "its own partial render"
        );
    }
}
