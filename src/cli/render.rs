//! `bendscope render`: a session folder of synthetic videos of the simulated actuator,
//! seen through a calibrated camera: ground truth for the whole image chain.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{anyhow, Context, Result};
use bendscope::calib::file::read_calibration;
use bendscope::render::session::{
    check_render_target, read_side_face, render_fem_session, FemRenderSettings,
};
use clap::Args;

use super::EXIT_OK;

/// Render the simulated actuator as a session of videos (ground truth for `process`).
#[derive(Debug, Args)]
#[command(
    after_help = "Writes into SESSION: one H.264 video per FEM pressure step (GX01xxxx.MP4), pressures.csv, \
scale.jpg (a 9x6 board of 10 mm squares in the actuator plane), calib/ (board photos through the same camera), \
bendscope.toml and truth.json (camera, and per video the radius and bending angle of the rendered marker centres).
A SESSION that already holds a session (videos, pressures.csv, scale.jpg, calib/ ...) is refused unless --force, \
or unless it is the unfinished session of a render that was stopped (marked .bendscope-render-unfinished).
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
    /// Leave the marker dots unpainted (the bare body, for `[detect] mode = "outline"`);
    /// truth.json still lists where they would be.
    #[arg(long)]
    pub no_dots: bool,
    /// Also write an RGB-D recording of the same actuator into SESSION/rgbd/ (640x480
    /// pinhole colour + aligned 16-bit depth, plane tilted 15 degrees, 3 frames per step,
    /// pressure_log.csv, intrinsics.json): bendscope process SESSION/rgbd.
    #[arg(long)]
    pub rgbd: bool,
    /// Random seed (noise, jitter, board poses).
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Render into SESSION even when it already holds a session (its videos, scale photo,
    /// pressures.csv and calib/ are replaced).
    #[arg(long)]
    pub force: bool,
}

impl RenderArgs {
    /// The library's settings from the flags.
    pub fn settings(&self) -> FemRenderSettings {
        FemRenderSettings {
            distance_mm: self.distance_mm,
            frames: self.frames,
            marker_diameter_mm: self.marker_diameter_mm,
            calib_views: self.calib_views,
            supersample: self.supersample,
            distractor: self.distractor,
            clean: self.clean,
            rgbd: self.rgbd,
            dots: !self.no_dots,
            seed: self.seed,
        }
    }
}

/// Runs `bendscope render`.
pub fn run(args: &RenderArgs) -> Result<u8> {
    check_render_target(&args.output, args.force)?;
    let _lock = super::lock_output(&args.output)?;
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
    let face = read_side_face(&args.fem)?;
    let bar = super::progress_bar(face.steps.len() as u64, "rendering");
    let truth = render_fem_session(&face, &camera, &args.output, &args.settings(), &|_| {
        bar.inc(1)
    })?;
    bar.finish_and_clear();
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
