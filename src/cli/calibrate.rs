//! `bendscope calibrate`: camera intrinsics from checkerboard views.

use std::path::{Path, PathBuf};

use anyhow::Result;
use bendscope::calib::corners::{detect_views, DetectSettings};
use bendscope::calib::destination::{check_replaces_same_camera, default_calibration_path};
use bendscope::calib::field::NO_LIMIT_DEG;
use bendscope::calib::file::write_calibration;
use bendscope::calib::sources::collect_sources;
use bendscope::calib::{
    calibrate, Board, BoardSize, CalibError, Calibration, CalibrationSettings, CameraModel,
};
use clap::Args;

use super::EXIT_OK;

/// Calibrate a camera from checkerboard views.
#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// Images, folders of images, or videos of a checkerboard.
    #[arg(required = true, value_name = "PATH")]
    pub paths: Vec<PathBuf>,
    /// Inner corners of the board, columns x rows (a 10x7-square board has 9x6).
    #[arg(long, default_value = "9x6", value_parser = parse_board_size)]
    pub board: BoardSize,
    /// Side of one square, mm.
    #[arg(long, default_value_t = 25.0, value_parser = parse_positive)]
    pub square_mm: f64,
    /// Lens model: fisheye (GoPro, Kannala-Brandt) or pinhole (RGB-D colour, 5 Brown coefficients).
    #[arg(long, value_enum, default_value_t = CameraModel::Fisheye)]
    pub model: CameraModel,
    /// Pinhole only: keep fx = fy.
    #[arg(long)]
    pub fix_aspect_ratio: bool,
    /// Frames sampled evenly from each video.
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(3..))]
    pub frames: u32,
    /// Output file [default: calibration/<folder-or-camera-name>.yaml; a folder called
    /// calib is named after the folder above it].
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Replace the default output even when it holds another camera's calibration.
    #[arg(long)]
    pub force: bool,
    /// Longest side (px) at which boards are searched; larger views are downscaled first.
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(320..))]
    pub detect_px: u32,
}

fn parse_board_size(s: &str) -> Result<BoardSize, String> {
    s.parse::<BoardSize>().map_err(|e| e.to_string())
}

/// A positive, finite number.
pub fn parse_positive(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("`{s}` is not a positive number")),
    }
}

/// Runs `bendscope calibrate`.
pub fn run(args: &CalibrateArgs) -> Result<u8> {
    if let Some(out) = &args.output {
        super::check_output_file(out)?;
    }
    let board = Board::new(args.board.cols, args.board.rows, args.square_mm)?;
    let (sources, skipped) = collect_sources(&args.paths, args.frames)?;
    if sources.is_empty() {
        return Err(CalibError::NoViews {
            paths: args
                .paths
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
        }
        .into());
    }
    let bar = super::progress_bar(sources.len() as u64, "finding corners");
    let settings = DetectSettings {
        max_detect_px: args.detect_px,
        parallel: true,
    };
    let mut detections = detect_views(&sources, &board, &settings, &|| bar.inc(1));
    bar.finish_and_clear();
    detections.rejected.extend(skipped);
    let calib = calibrate(
        &detections,
        &CalibrationSettings {
            model: args.model,
            board,
            fix_aspect_ratio: args.fix_aspect_ratio,
        },
    )?;
    let out = match &args.output {
        Some(path) => path.clone(),
        None => {
            let path = default_calibration_path(&args.paths[0]);
            if !args.force {
                check_replaces_same_camera(&path, &calib)?;
            }
            path
        }
    };
    // Its error names the file and what to do.
    write_calibration(&out, &calib)?;
    print_summary(&calib, &out);
    Ok(EXIT_OK)
}

fn print_summary(c: &Calibration, out: &Path) {
    let duplicates = c.duplicate_views();
    super::out!(
        "{} calibration of {}x{} from {} view(s){}, {} rejected",
        c.model.name(),
        c.image_width,
        c.image_height,
        c.views_used.len(),
        if duplicates > 0 {
            format!(
                " ({} given, {duplicates} duplicates of another view dropped)",
                c.views_used.len() + duplicates
            )
        } else {
            String::new()
        },
        c.views_rejected.len() - duplicates
    );
    super::out!(
        "  fx = {:.2}  fy = {:.2}  cx = {:.2}  cy = {:.2} px",
        c.fx(),
        c.fy(),
        c.cx(),
        c.cy()
    );
    let d: Vec<String> = c.distortion.iter().map(|v| format!("{v:.5}")).collect();
    super::out!("  distortion = [{}]", d.join(", "));
    super::out!(
        "  RMS reprojection error = {:.4} px",
        c.avg_reprojection_error
    );
    if let Some(worst) = c
        .per_view_errors
        .iter()
        .max_by(|a, b| a.rms_px.total_cmp(&b.rms_px))
    {
        super::out!("  worst view: {} ({:.3} px)", worst.name, worst.rms_px);
    }
    for r in &c.views_rejected {
        super::out!("  rejected {}: {}", r.name, r.reason);
    }
    print_coverage(c);
    super::out!("  written to {}", out.display());
}

/// The board's coverage of the frame and the valid field; a warning on stderr, saying
/// where to hold the board, when the coverage is thin.
fn print_coverage(c: &Calibration) {
    let field = c.valid_field();
    let limit = |deg: f64| {
        if deg >= NO_LIMIT_DEG {
            "no limit".to_string()
        } else {
            format!("{deg:.1}°")
        }
    };
    let Some(cov) = &c.coverage else {
        super::out!(
            "  valid field: {} (distortion monotonic; board coverage unknown)",
            limit(field.valid_angle_deg())
        );
        return;
    };
    let reach = cov
        .half_diagonal_share
        .map(|s| format!("{:.0}% of the frame's half-diagonal, ", 100.0 * s))
        .unwrap_or_default();
    super::out!(
        "  board coverage: corners reached {reach}field angle {:.1}°",
        cov.field_angle_deg
    );
    super::out!(
        "  valid field: up to {} from the optical axis (coverage {:.1}°, distortion monotonic to {})",
        limit(field.valid_angle_deg()),
        cov.field_angle_deg,
        limit(field.monotonic_angle_deg)
    );
    if let Some(grid) = &cov.grid {
        super::out!("  share of each third of the frame the board covered:");
        for row in grid {
            let cells: Vec<String> = row.iter().map(|v| format!("{:>4.0}%", 100.0 * v)).collect();
            super::out!("    {}", cells.join(" "));
        }
    }
    if let Some(advice) = cov.advice() {
        eprintln!(
            "warning: the board covered the frame thinly; the calibration is valid only up to {} from the optical axis, and markers or scale boards beyond cannot be measured: {advice}, then calibrate again",
            limit(field.valid_angle_deg())
        );
    }
}
