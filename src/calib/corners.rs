//! Checkerboard corner detection.
//!
//! The board is searched with OpenCV's `findChessboardCorners` (normalized image, fast
//! check) and, when that fails, with the sector-based `findChessboardCornersSB`
//! (exhaustive); `cornerSubPix` then refines every corner at full resolution.
//! The adaptive-threshold flag of `findChessboardCorners` is deliberately not used: on
//! some fisheye views its quad linking runs for tens of seconds to minutes (measured:
//! 20 s and 364 s on two 4000x3000 views), while the SB detector has a bounded cost
//! (~0.1 s at 1280 px) and finds those views.
//!
//! Photos larger than [`DetectSettings::max_detect_px`] are searched on a downscaled copy
//! (the search cost grows with the pixel count: ~15 ms at 1280x960 against ~300 ms at
//! 4000x3000 for the classic detector, 0.1 s against 1.3 s for SB) and the corners are
//! then refined on the full image with a window large enough to absorb the downscaling
//! error. Views are processed in parallel (rayon).

use std::path::{Path, PathBuf};

use nalgebra::Point2;
use opencv::core::{Mat, Point2f, Size, TermCriteria, TermCriteria_Type, Vector};
use opencv::prelude::*;
use opencv::{calib3d, imgcodecs, imgproc};
use rayon::prelude::*;

use super::{Board, CalibError, RejectedView};

/// Longest side, px, at which the board is searched; larger views are downscaled first.
pub const DEFAULT_MAX_DETECT_PX: u32 = 1280;
/// Largest half-window of the sub-pixel refinement (OpenCV's calibration sample uses 11).
pub const MAX_SUBPIX_HALF_WINDOW: i32 = 11;
/// Half-window as a fraction of the smallest corner spacing: keeps the window inside
/// one square so neighbouring corners do not pull the estimate.
pub const SUBPIX_WINDOW_FRACTION: f64 = 0.5;
/// Iterations and accuracy of the sub-pixel refinement (as in OpenCV's sample).
pub const SUBPIX_MAX_ITER: i32 = 30;
/// See [`SUBPIX_MAX_ITER`].
pub const SUBPIX_EPS: f64 = 1e-4;

/// How corners are searched.
#[derive(Debug, Clone, Copy)]
pub struct DetectSettings {
    /// Views whose longest side exceeds this are searched on a downscaled copy.
    pub max_detect_px: u32,
    /// Search views in parallel.
    pub parallel: bool,
}

impl Default for DetectSettings {
    fn default() -> Self {
        Self {
            max_detect_px: DEFAULT_MAX_DETECT_PX,
            parallel: true,
        }
    }
}

/// Where a view comes from.
#[derive(Debug, Clone)]
pub enum ViewSource {
    /// An image file, read with OpenCV's `imread`.
    Image(PathBuf),
    /// A frame already in memory (from a video), 8-bit grey.
    Frame {
        /// Name used in reports, e.g. `calib.mp4#frame120`.
        name: String,
        /// The frame.
        gray: image::GrayImage,
    },
}

impl ViewSource {
    /// The name used in reports: the file name, or the frame's name.
    pub fn name(&self) -> String {
        match self {
            ViewSource::Image(p) => display_name(p),
            ViewSource::Frame { name, .. } => name.clone(),
        }
    }
}

/// File name for reports (the whole path when it has none).
pub fn display_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

/// A view with a detected board.
#[derive(Debug, Clone)]
pub struct BoardView {
    /// Name for reports.
    pub name: String,
    /// Frame width, px.
    pub width: u32,
    /// Frame height, px.
    pub height: u32,
    /// Inner corners, row-major as [`Board::object_points_mm`], px.
    pub corners: Vec<Point2<f64>>,
}

/// The outcome of searching all views.
#[derive(Debug, Clone, Default)]
pub struct Detections {
    /// Views with a board, in input order.
    pub views: Vec<BoardView>,
    /// Views without a usable board, with the reason.
    pub rejected: Vec<RejectedView>,
}

/// Searches `board` in every view (in parallel), refining corners to sub-pixel accuracy.
/// A view that cannot be read or shows no board is listed in `rejected`, never an error.
/// `on_done` is called once per view as it finishes (e.g. to advance a progress bar).
pub fn detect_views(
    sources: &[ViewSource],
    board: &Board,
    settings: &DetectSettings,
    on_done: &(dyn Fn() + Sync),
) -> Detections {
    let run = |s: &ViewSource| -> Result<BoardView, RejectedView> {
        let name = s.name();
        let r = detect_view(s, board, settings).map_err(|reason| RejectedView { name, reason });
        on_done();
        r
    };
    let results: Vec<Result<BoardView, RejectedView>> = if settings.parallel {
        sources.par_iter().map(run).collect()
    } else {
        sources.iter().map(run).collect()
    };
    let mut out = Detections::default();
    for r in results {
        match r {
            Ok(v) => out.views.push(v),
            Err(r) => out.rejected.push(r),
        }
    }
    out
}

/// Reads a view as 8-bit grey, or says why it cannot.
fn load_gray(source: &ViewSource) -> Result<Mat, String> {
    match source {
        ViewSource::Image(path) => {
            // Read here rather than by OpenCV's imread, which prints its own warning on
            // stderr for a file it cannot open and reports a permission problem as a
            // missing or corrupt file.
            let bytes = std::fs::read(path).map_err(|e| match e.kind() {
                std::io::ErrorKind::PermissionDenied => {
                    "permission denied: make the file readable (chmod a+r)".to_string()
                }
                std::io::ErrorKind::NotFound => "no such file: check the name".to_string(),
                _ => format!("cannot read the file ({e})"),
            })?;
            if bytes.is_empty() {
                return Err("empty or truncated (copy it again from the camera)".into());
            }
            // A truncated JPEG or PNG: the decoders would print their own warning on
            // stderr and return half a picture (then "no board found").
            if let Some(why) = truncation(&bytes) {
                return Err(format!("truncated ({why}): copy it again from the camera"));
            }
            let m = imgcodecs::imdecode(
                &opencv::core::Vector::<u8>::from_slice(&bytes),
                imgcodecs::IMREAD_GRAYSCALE,
            )
            .map_err(|e| format!("unreadable image ({})", e.message))?;
            if m.empty() {
                return Err("not a readable image (corrupt or not an image file)".to_string());
            }
            Ok(m)
        }
        ViewSource::Frame { gray, .. } => super::cv::mat_from_gray(gray)
            .map_err(|e| format!("frame conversion failed ({})", e.message)),
    }
}

/// Why `bytes`, a JPEG or PNG file, is cut short (it ends before its end marker), or
/// `None` when it is complete or another kind of file.
pub(crate) fn truncation(bytes: &[u8]) -> Option<&'static str> {
    const PNG: &[u8] = b"\x89PNG\r\n\x1a\n";
    if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        jpeg_truncation(bytes)
    } else if let Some(mut rest) = bytes.strip_prefix(PNG) {
        // Chunks: length (4, big-endian), type (4), data, CRC (4); IEND ends the file.
        while rest.len() >= 8 {
            let len = u32::from_be_bytes([rest[0], rest[1], rest[2], rest[3]]) as usize;
            let end = len.checked_add(12)?;
            if rest.len() < end {
                return Some("the file ends inside a PNG chunk");
            }
            if &rest[4..8] == b"IEND" {
                return None;
            }
            rest = &rest[end..];
        }
        Some("the file ends before the PNG end chunk")
    } else {
        None
    }
}

/// [`truncation`] of a JPEG: walks the segments (each with its length) and the
/// entropy-coded scans (where 0xFF is followed by 0x00 or a restart marker) to the end
/// marker (EOI).
fn jpeg_truncation(bytes: &[u8]) -> Option<&'static str> {
    let n = bytes.len();
    let mut i = 2;
    loop {
        // A marker: 0xFF (fill bytes allowed) and its code.
        while i < n && bytes[i] == 0xFF {
            i += 1;
        }
        if i >= n {
            return Some("the file ends before the JPEG end marker");
        }
        let code = bytes[i];
        i += 1;
        match code {
            0xD9 => return None,
            0x01 | 0xD0..=0xD7 => continue,
            _ => {}
        }
        if i + 2 > n {
            return Some("the file ends inside a JPEG segment");
        }
        let len = u16::from_be_bytes([bytes[i], bytes[i + 1]]) as usize;
        if len < 2 || i + len > n {
            return Some("the file ends inside a JPEG segment");
        }
        i += len;
        if code == 0xDA {
            // Entropy-coded data up to the next marker.
            loop {
                if i + 1 >= n {
                    return Some("the file ends inside the JPEG image data");
                }
                if bytes[i] == 0xFF
                    && bytes[i + 1] != 0x00
                    && !(0xD0..=0xD7).contains(&bytes[i + 1])
                {
                    break;
                }
                i += 1;
            }
        }
    }
}

/// Detects the board in one view.
fn detect_view(
    source: &ViewSource,
    board: &Board,
    settings: &DetectSettings,
) -> Result<BoardView, String> {
    let gray = load_gray(source)?;
    let corners = find_corners(&gray, board, settings.max_detect_px)
        .map_err(|e| format!("corner search failed ({})", e.message))?
        .ok_or_else(|| format!("no {board} board found"))?;
    Ok(BoardView {
        name: source.name(),
        width: gray.cols() as u32,
        height: gray.rows() as u32,
        corners,
    })
}

/// Finds and refines the inner corners of `board` in an 8-bit grey image.
/// `Ok(None)` when the board is not (completely) visible.
pub fn find_corners(
    gray: &Mat,
    board: &Board,
    max_detect_px: u32,
) -> opencv::Result<Option<Vec<Point2<f64>>>> {
    let pattern = Size::new(board.cols as i32, board.rows as i32);
    let longest = gray.cols().max(gray.rows()) as f64;
    let scale = if longest > max_detect_px as f64 {
        max_detect_px as f64 / longest
    } else {
        1.0
    };
    let mut corners = Vector::<Point2f>::new();
    let found = if scale < 1.0 {
        let mut small = Mat::default();
        imgproc::resize(
            gray,
            &mut small,
            Size::new(0, 0),
            scale,
            scale,
            imgproc::INTER_AREA,
        )?;
        let found = search_board(&small, pattern, &mut corners)?;
        // Back to full-resolution pixel coordinates (pixel centres at integers).
        let inv = 1.0 / scale;
        let mut full = Vector::<Point2f>::with_capacity(corners.len());
        for p in corners.iter() {
            full.push(Point2f::new(
                ((p.x as f64 + 0.5) * inv - 0.5) as f32,
                ((p.y as f64 + 0.5) * inv - 0.5) as f32,
            ));
        }
        corners = full;
        found
    } else {
        search_board(gray, pattern, &mut corners)?
    };
    if !found || corners.len() != board.corner_count() {
        return Ok(None);
    }
    let spacing = min_corner_spacing(&corners, board);
    let mut half =
        ((SUBPIX_WINDOW_FRACTION * spacing).round() as i32).clamp(2, MAX_SUBPIX_HALF_WINDOW);
    if scale < 1.0 {
        // The downscaled estimate can be off by about one small pixel: the window must
        // reach that far at full resolution.
        let needed = (2.0 / scale).ceil() as i32;
        half = half.max(needed.min((0.45 * spacing) as i32)).max(2);
    }
    let criteria = TermCriteria::new(
        TermCriteria_Type::EPS as i32 + TermCriteria_Type::COUNT as i32,
        SUBPIX_MAX_ITER,
        SUBPIX_EPS,
    )?;
    imgproc::corner_sub_pix(
        gray,
        &mut corners,
        Size::new(half, half),
        Size::new(-1, -1),
        criteria,
    )?;
    Ok(Some(
        corners
            .iter()
            .map(|p| Point2::new(p.x as f64, p.y as f64))
            .collect(),
    ))
}

/// Classic detector first (fast when it works), then the sector-based one.
fn search_board(gray: &Mat, pattern: Size, corners: &mut Vector<Point2f>) -> opencv::Result<bool> {
    let classic = calib3d::CALIB_CB_NORMALIZE_IMAGE | calib3d::CALIB_CB_FAST_CHECK;
    if calib3d::find_chessboard_corners(gray, pattern, corners, classic)? {
        return Ok(true);
    }
    let sb = calib3d::CALIB_CB_NORMALIZE_IMAGE | calib3d::CALIB_CB_EXHAUSTIVE;
    calib3d::find_chessboard_corners_sb(gray, pattern, corners, sb)
}

/// Smallest distance between neighbouring corners along rows and columns, px.
fn min_corner_spacing(corners: &Vector<Point2f>, board: &Board) -> f64 {
    let (cols, rows) = (board.cols as usize, board.rows as usize);
    let at = |r: usize, c: usize| corners.get(r * cols + c).unwrap_or_default();
    let mut best = f64::INFINITY;
    for r in 0..rows {
        for c in 0..cols {
            let p = at(r, c);
            if c + 1 < cols {
                let q = at(r, c + 1);
                best = best.min(((p.x - q.x) as f64).hypot((p.y - q.y) as f64));
            }
            if r + 1 < rows {
                let q = at(r + 1, c);
                best = best.min(((p.x - q.x) as f64).hypot((p.y - q.y) as f64));
            }
        }
    }
    best
}

/// Two views whose corners lie within this RMS distance of each other (same board
/// ordering, or the board's 180-degree ordering) are one view shown twice, px: copies
/// of a photo, or shots that did not move the board. Counting them twice would weigh
/// that pose twice and report a coverage the board never had.
pub const DUPLICATE_VIEW_RMS_PX: f64 = 1.0;

/// Start of the reason [`drop_duplicate_views`] gives a dropped view.
pub const DUPLICATE_REASON: &str = "duplicate of ";

/// RMS distance between the corners of `a` and `b`, the smaller of the same ordering
/// and the reversed one (OpenCV may start a symmetric board at either end); `None` for
/// views of different sizes or corner counts.
pub fn corner_rms_px(a: &BoardView, b: &BoardView) -> Option<f64> {
    if (a.width, a.height) != (b.width, b.height) || a.corners.len() != b.corners.len() {
        return None;
    }
    let n = a.corners.len().max(1) as f64;
    let rms = |pairs: &mut dyn Iterator<Item = (&Point2<f64>, &Point2<f64>)>| {
        (pairs.map(|(p, q)| (p - q).norm_squared()).sum::<f64>() / n).sqrt()
    };
    let same = rms(&mut a.corners.iter().zip(b.corners.iter()));
    let reversed = rms(&mut a.corners.iter().zip(b.corners.iter().rev()));
    Some(same.min(reversed))
}

/// Keeps the first of each set of near-identical views ([`DUPLICATE_VIEW_RMS_PX`]) in
/// input order; the others are returned as rejected, naming the view they repeat.
pub fn drop_duplicate_views(views: &[BoardView]) -> (Vec<BoardView>, Vec<RejectedView>) {
    let mut kept: Vec<BoardView> = Vec::with_capacity(views.len());
    let mut dropped = Vec::new();
    for v in views {
        let twin = kept
            .iter()
            .filter_map(|k| corner_rms_px(k, v).map(|d| (k, d)))
            .filter(|(_, d)| *d < DUPLICATE_VIEW_RMS_PX)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match twin {
            Some((k, d)) => dropped.push(RejectedView {
                name: v.name.clone(),
                reason: format!(
                    "{DUPLICATE_REASON}{} (corners within {d:.2} px RMS): counted once",
                    k.name
                ),
            }),
            None => kept.push(v.clone()),
        }
    }
    (kept, dropped)
}

/// Reads every view's size cheaply and checks they agree; returns (width, height).
pub fn common_size(views: &[BoardView]) -> Result<(u32, u32), CalibError> {
    let first = views.first().ok_or(CalibError::NoViews {
        paths: String::new(),
    })?;
    for v in views {
        if v.width != first.width || v.height != first.height {
            return Err(CalibError::MixedResolution {
                path: v.name.clone(),
                width: v.width,
                height: v.height,
                expected_width: first.width,
                expected_height: first.height,
            });
        }
    }
    Ok((first.width, first.height))
}

/// Loads an image file as 8-bit grey (for the scale photo and similar single views).
pub fn read_gray(path: &Path) -> Result<Mat, CalibError> {
    load_gray(&ViewSource::Image(path.to_path_buf())).map_err(|why| CalibError::Unreadable {
        path: path.to_path_buf(),
        why,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixture(rel: &str) -> Vec<u8> {
        std::fs::read(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("fixtures")
                .join(rel),
        )
        .unwrap()
    }

    fn png() -> Vec<u8> {
        let img = image::GrayImage::from_fn(64, 48, |x, y| image::Luma([(x * y) as u8]));
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        out.into_inner()
    }

    #[test]
    fn a_photo_cut_anywhere_is_truncated_and_a_whole_one_is_not() {
        for bytes in [
            fixture("sessions/example/scale.jpg"),
            fixture("opencv-left/left01.jpg"),
            png(),
        ] {
            assert_eq!(truncation(&bytes), None);
            let n = bytes.len();
            for cut in [10, n / 10, n / 2, n - 100, n - 2, n - 1] {
                assert!(truncation(&bytes[..cut]).is_some(), "cut at {cut} of {n}");
            }
            // Bytes after the end marker (some cameras append data) are not a truncation.
            let mut longer = bytes.clone();
            longer.extend_from_slice(b"trailer");
            assert_eq!(truncation(&longer), None);
        }
        assert_eq!(
            truncation(b"not an image"),
            None,
            "other files are left to the decoder"
        );
    }
}
