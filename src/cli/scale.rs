//! `bendscope scale`: mm per undistorted pixel in the actuator plane.

use std::path::PathBuf;

use anyhow::{bail, Result};
use bendscope::calib::file::read_calibration;
use bendscope::calib::{Board, BoardSize, UndistortSettings};
use bendscope::io::write_atomic;
use bendscope::scale::{scale_from_board_photo, scale_from_fov, Scale};
use clap::Args;

use super::calibrate::parse_positive;
use super::EXIT_OK;

/// Square side assumed when --square-mm is not given, mm.
const DEFAULT_SQUARE_MM: f64 = 25.0;

/// Measure mm per undistorted pixel from a board lying in the actuator plane, or from a
/// known field of view.
#[derive(Debug, Args)]
pub struct ScaleArgs {
    /// Photo of a checkerboard lying in the actuator plane (not needed with --fov-mm).
    #[arg(value_name = "IMAGE", required_unless_present = "fov_mm")]
    pub image: Option<PathBuf>,
    /// Calibration file made by `bendscope calibrate`.
    #[arg(long, value_name = "FILE", required_unless_present = "fov_mm")]
    pub calibration: Option<PathBuf>,
    /// Inner corners of the board, columns x rows.
    #[arg(long, default_value = "9x6", value_parser = |s: &str| s.parse::<BoardSize>().map_err(|e| e.to_string()))]
    pub board: BoardSize,
    /// Side of one square, mm [default: 25]; mm/px is proportional to it, so give it.
    #[arg(long, value_parser = parse_positive)]
    pub square_mm: Option<f64>,
    /// Manual method: field of view across the frame width, mm (radius_mm = radius_px x FOV_mm / width_px).
    #[arg(long, value_parser = parse_positive, conflicts_with_all = ["image", "calibration"], requires = "width_px")]
    pub fov_mm: Option<f64>,
    /// Manual method: frame width, px.
    #[arg(long, requires = "fov_mm")]
    pub width_px: Option<u32>,
    /// Manual method: frame height, px.
    #[arg(long, requires = "fov_mm", default_value_t = 0)]
    pub height_px: u32,
    /// Save the result as JSON (with the board); `process` takes it as `scale = "FILE"`
    /// in bendscope.toml.
    #[arg(long, value_name = "FILE")]
    pub save: Option<PathBuf>,
}

/// Runs `bendscope scale`.
pub fn run(args: &ScaleArgs) -> Result<u8> {
    let scale: Scale = match (args.fov_mm, &args.image, &args.calibration) {
        (Some(fov), _, _) => scale_from_fov(fov, args.width_px.unwrap_or(0), args.height_px)?,
        (None, Some(image), Some(cal)) => {
            let calib = read_calibration(cal)?;
            let square_mm = args.square_mm.unwrap_or(DEFAULT_SQUARE_MM);
            let board = Board::new(args.board.cols, args.board.rows, square_mm)?;
            let mut s =
                scale_from_board_photo(image, &calib, &board, UndistortSettings::default())?;
            if let Some(b) = &mut s.board {
                b.square_mm_given = args.square_mm.is_some();
            }
            s
        }
        _ => bail!("give IMAGE and --calibration, or --fov-mm and --width-px"),
    };
    if let Some((w, h)) = scale.calibration_rescaled_from {
        eprintln!(
            "note: the calibration was made at {w}x{h}; its camera matrix was scaled to the photo's {}x{} (same aspect ratio)",
            scale.image_width, scale.image_height
        );
    }
    super::out!("{:.6} mm/px", scale.mm_per_px);
    if scale.board.is_some_and(|b| !b.square_mm_given) {
        eprintln!("warning: --square-mm not given: {DEFAULT_SQUARE_MM} mm squares assumed (mm/px is proportional to it)");
    }
    if scale.looks_tilted() {
        eprintln!(
            "warning: corner spacing varies by {:.1}% across the board: it is probably not parallel to the image plane",
            100.0 * scale.spread
        );
    }
    if let Some(out) = &args.save {
        let json = serde_json::to_string_pretty(&scale)?;
        // Its error names the file and what to do.
        write_atomic(out, json.as_bytes())?;
        eprintln!("saved to {}", out.display());
    }
    Ok(EXIT_OK)
}
