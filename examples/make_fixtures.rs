//! Renders a synthetic fisheye calibration set:
//! `cargo run --example make_fixtures -- OUT_DIR [WIDTH] [VIEWS] [SUPERSAMPLE]`.
//! Run through `scripts/make-fixtures.sh`.

use std::path::PathBuf;

use bendscope::calib::Board;
use bendscope::render::board::PhotoSettings;
use bendscope::render::fixtures::{gopro_like_camera, write_calibration_set, CalibrationSetSpec};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let out = PathBuf::from(
        args.get(1)
            .map(String::as_str)
            .unwrap_or("fixtures/fisheye"),
    );
    let width: u32 = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(960);
    let views: usize = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(20);
    let supersample: u32 = args.get(4).map(|s| s.parse()).transpose()?.unwrap_or(4);
    let camera = gopro_like_camera(width, width * 3 / 4);
    let spec = CalibrationSetSpec {
        camera,
        board: Board::new(9, 6, 25.0)?,
        views,
        view_reach: 1.0,
        scale_distance_mm: 400.0,
        photo: PhotoSettings {
            supersample,
            blur_sigma_px: 0.8 * width as f32 / 960.0,
            noise_sigma: 2.5,
            seed: 11,
        },
        seed: 2024,
    };
    let truth = write_calibration_set(&out, &spec)?;
    println!(
        "wrote {} views, scale.jpg and truth.json to {} (true mm/px {:.6})",
        views,
        out.display(),
        truth.mm_per_px
    );
    Ok(())
}
