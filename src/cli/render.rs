//! `bendscope render`: a session folder of synthetic videos of the simulated actuator,
//! seen through a calibrated camera: ground truth for the whole image chain.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, Context, Result};
use bendscope::calib::file::read_calibration;
use bendscope::calib::Calibration;
use bendscope::fem::simulate::SideFaceFile;
use bendscope::render::actuator::FrameLook;
use bendscope::render::session::{
    fem_videos, place_fem_actuator, render_session, write_fem_rgbd, RgbdSpec, SessionSpec,
    SessionTruth,
};
use clap::Args;

use super::EXIT_OK;

/// Render the simulated actuator as a session of videos (ground truth for `process`).
#[derive(Debug, Args)]
#[command(
    after_help = "Writes into SESSION: one H.264 video per FEM pressure step (GX01xxxx.MP4), pressures.csv, \
scale.jpg (a 9x6 board of 10 mm squares in the actuator plane), calib/ (board photos through the same camera), \
bendscope.toml and truth.json (camera, and per video the radius and bending angle of the rendered marker centres).
Then: bendscope process SESSION."
)]
pub struct RenderArgs {
    /// Output folder of `bendscope simulate` (side_face.json).
    #[arg(long, value_name = "FEM_OUT")]
    pub fem: PathBuf,
    /// Camera calibration (YAML from `bendscope calibrate`).
    #[arg(long, value_name = "CAL.yaml", required_unless_present = "gopro_like")]
    pub calibration: Option<PathBuf>,
    /// Instead of a calibration: the built-in GoPro-like fisheye at this size, e.g. 1920x1080.
    #[arg(long, value_name = "WxH", conflicts_with = "calibration")]
    pub gopro_like: Option<String>,
    /// Distance of the actuator plane from the camera, mm.
    #[arg(
        long,
        value_name = "MM",
        default_value_t = 260.0,
        allow_hyphen_values = true
    )]
    pub distance_mm: f64,
    /// Output session folder.
    #[arg(
        short,
        long,
        value_name = "SESSION",
        default_value = "rendered-session"
    )]
    pub output: PathBuf,
    /// Frames per video.
    #[arg(long, default_value_t = 5)]
    pub frames: usize,
    /// Marker disc diameter, mm.
    #[arg(
        long,
        value_name = "MM",
        default_value_t = 3.0,
        allow_hyphen_values = true
    )]
    pub marker_diameter_mm: f64,
    /// Calibration photos to render into calib/.
    #[arg(long, default_value_t = 14)]
    pub calib_views: usize,
    /// Samples per pixel side (supersampling).
    #[arg(long, default_value_t = 3)]
    pub supersample: u32,
    /// Put a red disc that is not a marker beside the actuator.
    #[arg(long)]
    pub distractor: bool,
    /// No blur, noise, vignetting or light gradient.
    #[arg(long)]
    pub clean: bool,
    /// Also write an RGB-D recording of the same actuator into SESSION/rgbd/ (640x480
    /// pinhole colour + aligned 16-bit depth, plane tilted 15 degrees, 3 frames per step,
    /// pressure_log.csv, intrinsics.json): bendscope process SESSION/rgbd.
    #[arg(long)]
    pub rgbd: bool,
    /// Random seed (noise, jitter, board poses).
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
}

/// Reads `FEM_OUT/side_face.json`.
pub fn read_side_face(fem: &Path) -> Result<SideFaceFile> {
    let path = fem.join("side_face.json");
    let text = std::fs::read_to_string(&path).map_err(|_| {
        anyhow!(
            "{} has no side_face.json: give the output folder of `bendscope simulate -o FEM_OUT`",
            fem.display()
        )
    })?;
    serde_json::from_str(&text)
        .map_err(|e| anyhow!("{} is not a bendscope side face file: {e}", path.display()))
}

/// Renders `face` through `camera` into `out`, with a progress bar.
pub fn render_fem_session(
    face: &SideFaceFile,
    camera: &Calibration,
    out: &Path,
    args: &RenderArgs,
) -> Result<SessionTruth> {
    if !(args.distance_mm.is_finite() && args.distance_mm > 0.0) {
        return Err(anyhow!(
            "--distance-mm {}: must be a positive distance",
            args.distance_mm
        ));
    }
    if !(args.marker_diameter_mm.is_finite()
        && args.marker_diameter_mm > 0.0
        && args.marker_diameter_mm < 12.0)
    {
        return Err(anyhow!(
            "--marker-diameter-mm {}: use a diameter between 0 and 12 mm",
            args.marker_diameter_mm
        ));
    }
    if args.frames == 0 || args.supersample == 0 {
        return Err(anyhow!("--frames and --supersample must be at least 1"));
    }
    let origin = place_fem_actuator(face, camera, args.distance_mm)?;
    let videos = fem_videos(face, origin, args.marker_diameter_mm, args.distractor)?;
    let spec = SessionSpec {
        camera: camera.clone(),
        distance_mm: args.distance_mm,
        pressures_kpa: videos.iter().map(|(_, t)| t.pressure_kpa).collect(),
        radius_law: (0.0, 0.0, 0.0),
        frames: args.frames,
        calib_views: args.calib_views,
        calib_view_reach: 1.0,
        scale_square_mm: 10.0,
        distractor: args.distractor,
        supersample: args.supersample,
        look: if args.clean {
            FrameLook {
                blur_sigma_px: 0.0,
                noise_sigma: 0.0,
                gradient: 0.0,
                vignetting: 0.0,
            }
        } else {
            FrameLook::default()
        },
        seed: args.seed,
    };
    let bar = super::progress_bar(videos.len() as u64, "rendering");
    let truth = render_session(out, &spec, videos, &|_| bar.inc(1))?;
    bar.finish_and_clear();
    if args.rgbd {
        write_fem_rgbd(
            &out.join("rgbd"),
            face,
            &RgbdSpec {
                distance_mm: args.distance_mm,
                tilt_deg: 15.0,
                frames_per_step: 3,
                fps: 10.0,
                supersample: args.supersample.max(4),
                marker_diameter_mm: args.marker_diameter_mm,
                look: spec.look,
                seed: args.seed,
            },
        )?;
    }
    Ok(truth)
}

/// Runs `bendscope render`.
pub fn run(args: &RenderArgs) -> Result<u8> {
    let face = read_side_face(&args.fem)?;
    let camera = match (&args.calibration, &args.gopro_like) {
        (Some(path), _) => read_calibration(path)
            .with_context(|| format!("cannot use {} as the camera", path.display()))?,
        (None, Some(size)) => {
            let parsed = size
                .split_once(['x', 'X'])
                .and_then(|(w, h)| {
                    Some((w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?))
                })
                .filter(|(w, h)| (64..=8192).contains(w) && (64..=8192).contains(h));
            let Some((w, h)) = parsed else {
                return Err(anyhow!(
                    "--gopro-like '{size}': expected WIDTHxHEIGHT, e.g. 1920x1080"
                ));
            };
            bendscope::render::fixtures::gopro_like_camera(w, h)
        }
        (None, None) => return Err(anyhow!("give --calibration CAL.yaml or --gopro-like WxH")),
    };
    let started = Instant::now();
    let truth = render_fem_session(&face, &camera, &args.output, args)?;
    let frames = truth.videos.len() * args.frames;
    super::out!(
        "{} videos ({} frames of {}x{}) in {:.1} s -> {}; next: bendscope process {}",
        truth.videos.len(),
        frames,
        camera.image_width,
        camera.image_height,
        started.elapsed().as_secs_f64(),
        args.output.display(),
        args.output.display()
    );
    Ok(EXIT_OK)
}
