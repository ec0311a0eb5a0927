//! Renders a synthetic session folder:
//! `cargo run --example make_session -- OUT_DIR [WIDTH] [FRAMES] [--distractor]`.
//! Run through `scripts/make-fixtures.sh`.

use std::path::PathBuf;

use bendscope::render::actuator::FrameLook;
use bendscope::render::fixtures::gopro_like_camera;
use bendscope::render::session::{write_session, SessionSpec};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let out = PathBuf::from(
        args.get(1)
            .map(String::as_str)
            .unwrap_or("fixtures/sessions/example"),
    );
    let width: u32 = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(800);
    let frames: usize = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(8);
    let distractor = args.iter().any(|a| a == "--distractor");
    let spec = SessionSpec {
        camera: gopro_like_camera(width, width * 3 / 4),
        distance_mm: 150.0,
        pressures_kpa: vec![20.0, 35.0, 50.0, 65.0, 80.0],
        radius_law: (3000.0, -0.9, 5.0),
        frames,
        calib_views: 16,
        calib_view_reach: 1.0,
        scale_square_mm: 10.0,
        distractor,
        supersample: 3,
        look: FrameLook::default(),
        seed: 7,
        scale_board_offset_mm: Some(0.0),
    };
    let truth = write_session(&out, &spec)?;
    for v in &truth.videos {
        println!(
            "{}  {:5.1} kPa  R = {:7.2} mm  angle = {:5.2} deg",
            v.file, v.pressure_kpa, v.radius_mm, v.bending_angle_deg
        );
    }
    println!(
        "wrote {} (true mm/px {:.6})",
        out.display(),
        truth.mm_per_px
    );
    Ok(())
}
