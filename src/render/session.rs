//! Synthetic session folders: a GoPro-like fisheye camera films an actuator whose marker
//! line is a circular arc of known radius at each pressure; with calibration photos, a
//! scale photo in the actuator plane, `pressures.csv` and `truth.json`.

use std::path::Path;

use nalgebra::{Point2, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use super::actuator::{ArcScene, FrameLook, PlaneSampler};
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
    /// Square size of the scale board (9x6 inner corners) lying in the actuator plane, mm.
    pub scale_square_mm: f64,
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

/// Renders a whole session into `dir`.
pub fn write_session(dir: &Path, spec: &SessionSpec) -> Result<SessionTruth, RenderError> {
    let err = |e: std::io::Error| {
        RenderError::Camera(crate::calib::CalibError::Io {
            path: dir.to_path_buf(),
            source: e,
        })
    };
    std::fs::create_dir_all(dir).map_err(err)?;
    // Calibration photos (9x6, 25 mm) in calib/.
    write_calibration_set(
        dir,
        &CalibrationSetSpec {
            camera: spec.camera.clone(),
            board: Board::new(9, 6, 25.0).map_err(RenderError::Camera)?,
            views: spec.calib_views,
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
    // Scale photo: a small board lying in the actuator plane.
    let sb = Board::new(9, 6, spec.scale_square_mm).map_err(RenderError::Camera)?;
    let centre = Vector3::new(sb.square_mm * 4.0, sb.square_mm * 2.5, 0.0);
    let pose = BoardPose {
        rotation: Rotation3::identity(),
        translation_mm: Vector3::new(0.0, 0.0, spec.distance_mm) - centre,
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
    let und = Undistorter::new(&spec.camera, UndistortSettings::default())?;
    let mm_per_px = spec.distance_mm / und.new_camera_matrix()[(0, 0)];
    // Videos.
    let plane = BoardPose {
        rotation: Rotation3::identity(),
        translation_mm: Vector3::new(0.0, 0.0, spec.distance_mm),
    };
    let sampler = PlaneSampler::new(&spec.camera, &plane, spec.supersample, spec.seed)?;
    let mut rng = SplitMix64::new(spec.seed ^ 0xACE);
    let mut videos = Vec::new();
    let mut manifest = String::from("file,pressure_kpa\n");
    for (i, &p) in spec.pressures_kpa.iter().enumerate() {
        let (a, b, c) = spec.radius_law;
        let radius = a * p.powf(b) + c;
        let scene = ArcScene {
            distractor: spec.distractor.then(|| (Point2::new(75.0, 55.0), 8.0)),
            ..ArcScene::reference_actuator(1.0 / radius, Point2::new(-50.0, 22.0))
        };
        let file = format!("GX01{:04}.MP4", 101 + i);
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
        manifest.push_str(&format!("{file},{p}\n"));
        videos.push(VideoTruth {
            file,
            pressure_kpa: p,
            radius_mm: radius,
            bending_angle_deg: scene.bending_angle_deg(),
            markers_mm: scene.markers_mm().iter().map(|m| [m.x, m.y]).collect(),
        });
    }
    write_atomic(&dir.join("pressures.csv"), manifest.as_bytes()).map_err(err)?;
    let config = format!(
        "# Settings of this session (see `bendscope process --help`).\n[scale_board]\ncols = 9\nrows = 6\nsquare_mm = {}\n",
        spec.scale_square_mm
    );
    write_atomic(&dir.join("bendscope.toml"), config.as_bytes()).map_err(err)?;
    let truth = SessionTruth {
        camera: CameraTruth::from_calibration(&spec.camera),
        distance_mm: spec.distance_mm,
        mm_per_px,
        videos,
    };
    let json = serde_json::to_string_pretty(&truth).map_err(|e| err(e.into()))?;
    write_atomic(&dir.join("truth.json"), json.as_bytes()).map_err(err)?;
    Ok(truth)
}
