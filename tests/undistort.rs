//! Full-frame undistortion (remap maps) and point undistortion agree: corners found in
//! the undistorted frame sit where the raw corners' undistorted points say.

mod common;

use bendscope::calib::corners::{find_corners, read_gray};
use bendscope::calib::{Board, UndistortSettings, Undistorter};
use bendscope::render::fixtures::CalibrationSetTruth;
use common::fixture;

#[test]
fn frame_and_point_undistortion_agree_on_the_scale_photo() {
    let truth: CalibrationSetTruth =
        serde_json::from_str(&std::fs::read_to_string(fixture("fisheye/truth.json")).unwrap())
            .unwrap();
    let camera = truth.camera.to_calibration();
    let board = Board::new(9, 6, 25.0).unwrap();
    let und = Undistorter::new(&camera, UndistortSettings::default()).unwrap();
    let raw = read_gray(&fixture("fisheye/scale.jpg")).unwrap();
    let raw_corners = find_corners(&raw, &board, 4000)
        .unwrap()
        .expect("board in the raw photo");
    let expected = und.undistort_points(&raw_corners).unwrap();
    let maps = und.maps().unwrap();
    let flat = und.undistort_image(&maps, &raw).unwrap();
    let found = find_corners(&flat, &board, 4000)
        .unwrap()
        .expect("board in the undistorted photo");
    let worst = expected
        .iter()
        .zip(&found)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    // Bilinear remap of a blurred, noisy JPEG: corner positions agree to a small
    // fraction of a pixel.
    assert!(worst < 0.15, "largest disagreement {worst} px");
    // The board is parallel to the image plane: in the undistorted view its rows are
    // straight lines (lens distortion removed); in the raw photo the outer rows bend by
    // about a pixel.
    // The tolerance covers corner localization on a supersampled, blurred, noisy JPEG
    // (about 0.15 px at worst on this fixture).
    let bend = |pts: &[nalgebra::Point2<f64>], r: usize| {
        let row = &pts[r * 9..r * 9 + 9];
        let (a, b) = (row[0], row[8]);
        let dir = (b - a).normalize();
        row.iter()
            .map(|p| (p - a).perp(&dir).abs())
            .fold(0.0, f64::max)
    };
    for r in [0, 5] {
        let b = bend(&raw_corners, r);
        assert!(b > 0.8, "raw row {r} should bend visibly, bends {b} px");
    }
    for r in 0..6 {
        let b = bend(&expected, r);
        assert!(b < 0.3, "undistorted row {r} bends by {b} px");
    }
}
