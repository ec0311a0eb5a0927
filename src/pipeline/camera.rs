//! The camera of a video session: its calibration (given, or calib/ calibrated and
//! cached by content) and its scale (mm per undistorted px: from the settings, a scale
//! file, the markers at rest or the scale photo), each with where it came from for
//! session.json.

use std::path::{Path, PathBuf};

use crate::calib::corners::{detect_views, DetectSettings as CornerSettings, ViewSource};
use crate::calib::file::{read_calibration, write_calibration};
use crate::calib::{calibrate, Board, Calibration, CalibrationSettings, UndistortSettings};
use crate::io::{content_key, hash_parts, write_atomic};
use crate::scale::{read_scale_file, scale_from_offset_board_photo, ScaleBoard, ScaleError};
use crate::session::{find_scale_image, ManifestEntry, SessionConfig, CONFIG, IMAGE_EXTENSIONS};
use crate::video::FrameSelection;

use super::error::{write_err, PipelineError};
use super::provenance::{
    BoardPlane, CalibrationSource, CalibrationUsed, RestUsed, ScaleSource, ScaleUsed,
};
use super::rest_scale::{rest_entry, scale_from_rest};
use super::run::{Notes, ProcessSettings};

/// Removes `path` when it exists.
fn remove_if_present(path: &Path) -> Result<(), PipelineError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(write_err(path)(e)),
        _ => Ok(()),
    }
}

/// [`CalibrationUsed::of_file`], its read error naming the file.
fn calibration_used(
    source: CalibrationSource,
    path: &Path,
) -> Result<CalibrationUsed, PipelineError> {
    CalibrationUsed::of_file(source, path).map_err(|e| PipelineError::Layout {
        path: path.to_path_buf(),
        why: format!("cannot read it again ({e}): check the file"),
    })
}

/// The session's calibration and where it came from: `--calibration`, else the config's
/// `calibration`, else calib/ calibrated and cached in OUT under a key of its photos'
/// content, board and model (replacing a photo redoes it). OUT's calibration.yaml is the
/// calibration of calib/ only while it is used: with a calibration from elsewhere, one
/// left by an earlier run is removed.
pub(super) fn session_calibration(
    session: &Path,
    out: &Path,
    config: &SessionConfig,
    settings: &ProcessSettings,
    notes: &mut Notes,
) -> Result<(Calibration, CalibrationUsed), PipelineError> {
    let cached = out.join("calibration.yaml");
    let key_path = out.join("cache").join("calibration.key");
    let elsewhere = match (&settings.calibration, &config.calibration) {
        (Some(c), _) => Some((CalibrationSource::Given, c.clone())),
        (None, Some(c)) => Some((CalibrationSource::Config, session.join(c))),
        (None, None) => None,
    };
    if let Some((source, path)) = elsewhere {
        let calib = read_calibration(&path)?;
        let used = calibration_used(source, &path)?;
        let is_cached = match (path.canonicalize(), cached.canonicalize()) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        };
        if !is_cached {
            remove_if_present(&cached)?;
            remove_if_present(&key_path)?;
        }
        return Ok((calib, used));
    }
    let dir = session.join("calib");
    if !dir.is_dir() {
        return Err(PipelineError::Layout {
            path: dir,
            why: "no calibration: give --calibration FILE, set `calibration` in bendscope.toml, or put checkerboard photos in this folder".into(),
        });
    }
    let mut photos: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(|e| PipelineError::Layout {
            path: dir.clone(),
            why: e.to_string(),
        })?
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.extension()
                .map(|e| {
                    IMAGE_EXTENSIONS.contains(&e.to_string_lossy().to_ascii_lowercase().as_str())
                })
                .unwrap_or(false)
        })
        .collect();
    photos.sort();
    let b = config.calib_board;
    let mut parts: Vec<Vec<u8>> = vec![
        format!(
            "{}x{}@{}:{}",
            b.cols,
            b.rows,
            b.square_mm,
            config.model.name()
        )
        .into_bytes(),
        env!("CARGO_PKG_VERSION").as_bytes().to_vec(),
    ];
    for p in &photos {
        parts.push(
            p.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
                .into_bytes(),
        );
        parts.push(content_key(p).unwrap_or(0).to_le_bytes().to_vec());
    }
    let key = format!("{:032x}", hash_parts(parts.iter().map(|p| p.as_slice())));
    let current = std::fs::read_to_string(&key_path)
        .map(|k| k.trim() == key)
        .unwrap_or(false);
    if current && !settings.force {
        if let Ok(c) = read_calibration(&cached) {
            return Ok((c, calibration_used(CalibrationSource::Calibrated, &cached)?));
        }
    }
    let sources: Vec<ViewSource> = photos.into_iter().map(ViewSource::Image).collect();
    let board = Board::new(b.cols, b.rows, b.square_mm)?;
    notes.progress.start("calibrating", 1);
    let det = detect_views(&sources, &board, &CornerSettings::default(), &|| {});
    let calib = calibrate(
        &det,
        &CalibrationSettings {
            model: config.model,
            board,
            fix_aspect_ratio: false,
        },
    );
    notes.progress.finish();
    // The calibrate command's advice names its --board flag; process reads the board
    // from the settings.
    let calib = calib.map_err(|e| PipelineError::Layout {
        path: dir.clone(),
        why: format!("calibration failed: {e}")
            .replace("--board", &format!("[calib_board] in {CONFIG}")),
    })?;
    write_calibration(&cached, &calib)?;
    write_atomic(&key_path, key.as_bytes()).map_err(write_err(&key_path))?;
    for r in &calib.views_rejected {
        notes.push(format!(
            "warning: {}: {}: not used for the calibration",
            dir.join(&r.name).display(),
            r.reason
        ));
    }
    notes.push(format!(
        "calibrated {} from {} views (RMS {:.3} px) -> {}",
        config.model.name(),
        calib.views_used.len(),
        calib.avg_reprojection_error,
        cached.display()
    ));
    let used = calibration_used(CalibrationSource::Calibrated, &cached)?;
    Ok((calib, used))
}

/// mm per undistorted px and the frame width it applies to.
#[derive(Debug, Clone, Copy)]
pub(super) struct SessionScale {
    pub(super) mm_per_px: f64,
    pub(super) width: u32,
    pub(super) plane_from_px: Option<[f64; 9]>,
}

/// The items of a session the scale may be measured on: a step session's manifest
/// entries (`None`: a ramp) and the frames measured of each.
pub(super) struct ScaleItems<'a> {
    pub(super) entries: Option<&'a [ManifestEntry]>,
    pub(super) frames: FrameSelection,
}

/// The session's scale and where it came from: `mm_per_px` in the settings, else a
/// scale file (`scale`), else the markers at rest (`[scale_markers]`, which wins over a
/// scale photo, with a warning), else the scale photo measured with `[scale_board]`
/// (carried to the marker plane when `offset_mm` is set). Warns when the board's square
/// size was never given (mm/px is proportional to it).
pub(super) fn session_scale(
    session: &Path,
    config: &SessionConfig,
    calib: &Calibration,
    items: ScaleItems,
    notes: &mut Notes,
) -> Result<(SessionScale, ScaleUsed), PipelineError> {
    if let Some(m) = config.mm_per_px {
        let used = ScaleUsed {
            source: ScaleSource::MmPerPx,
            file: None,
            mm_per_px: m,
            image_width: calib.image_width,
            board: None,
            plane_from_px: None,
            kind: ScaleUsed::kind_of(ScaleSource::MmPerPx, 0.0),
            board_plane: None,
            rest: None,
        };
        let scale = SessionScale {
            mm_per_px: m,
            width: calib.image_width,
            plane_from_px: None,
        };
        return Ok((scale, used));
    }
    if let Some(f) = &config.scale {
        let path = session.join(f);
        let s = read_scale_file(&path).map_err(|e| PipelineError::Layout {
            path: path.clone(),
            why: e
                .to_string()
                .replace(&format!("{}: ", path.display()), "")
                .replace(": make it", &format!(" (`scale` in {CONFIG}): make it")),
        })?;
        if let Some(b) = s.board.filter(|b| !b.square_mm_given) {
            notes.push(format!(
                "warning: {}: measured with `bendscope scale`'s default square size ({} mm, --square-mm not given), and every radius scales with it: measure it again with --square-mm",
                path.display(),
                b.square_mm
            ));
        }
        let scale = SessionScale {
            mm_per_px: s.mm_per_px,
            width: s.image_width,
            plane_from_px: s.plane_from_px,
        };
        let used = ScaleUsed {
            source: ScaleSource::ScaleFile,
            file: Some(path),
            mm_per_px: s.mm_per_px,
            image_width: s.image_width,
            board: s.board,
            plane_from_px: s.plane_from_px,
            kind: ScaleUsed::kind_of(ScaleSource::ScaleFile, 0.0),
            board_plane: None,
            rest: None,
        };
        return Ok((scale, used));
    }
    if config.scale_markers.is_some() {
        return markers_scale(session, config, calib, items, notes);
    }
    let img = find_scale_image(session, config).ok_or_else(|| PipelineError::Layout {
        path: session.to_path_buf(),
        why: "no scale photo: put scale.jpg (a board lying in the actuator plane) in the session, or set mm_per_px (or scale, a file saved by `bendscope scale --save`, or [scale_markers] spacing_mm, the markers' rest spacing measured in a 0 kPa video) in bendscope.toml".into(),
    })?;
    let b = config.scale_board;
    let board = Board::new(b.cols, b.rows, b.square_mm)?;
    let s = scale_from_offset_board_photo(
        &img,
        calib,
        &board,
        UndistortSettings::default(),
        b.offset_mm,
    )
    .map_err(|source| {
        // Refusals fixed in the settings: the scale command's advice names its flags,
        // process the keys in bendscope.toml.
        let (flag, key) = match source {
            ScaleError::NoBoard { .. } => ("--board", format!("[scale_board] in {CONFIG}")),
            ScaleError::Offset { .. } => {
                ("offset_mm", format!("[scale_board] offset_mm in {CONFIG}"))
            }
            source => {
                return PipelineError::Scale {
                    path: img.clone(),
                    source,
                }
            }
        };
        PipelineError::Layout {
            path: img.clone(),
            why: source
                .to_string()
                .replace(&format!("{}: ", img.display()), "")
                .replace(flag, &key),
        }
    })?;
    if !config.scale_square_mm_given {
        notes.push(format!(
            "warning: {}: the scale board's square size is given nowhere: {} mm assumed, and every radius scales with it: set [scale_board] square_mm in {CONFIG}",
            img.display(),
            b.square_mm
        ));
    }
    if s.looks_tilted() {
        notes.push(format!(
            "warning: {}: board spacing varies by {:.1}%: not parallel to the image plane?",
            img.display(),
            100.0 * s.spread
        ));
    }
    let scale = SessionScale {
        mm_per_px: s.mm_per_px,
        width: s.image_width,
        plane_from_px: s.plane_from_px,
    };
    let used = ScaleUsed {
        source: ScaleSource::ScalePhoto,
        file: Some(img),
        mm_per_px: s.mm_per_px,
        image_width: s.image_width,
        board: Some(ScaleBoard {
            cols: b.cols,
            rows: b.rows,
            square_mm: b.square_mm,
            square_mm_given: config.scale_square_mm_given,
        }),
        plane_from_px: s.plane_from_px,
        kind: ScaleUsed::kind_of(ScaleSource::ScalePhoto, b.offset_mm),
        board_plane: s.board_distance_mm.map(|d| BoardPlane {
            distance_mm: d,
            offset_mm: b.offset_mm,
        }),
        rest: None,
    };
    Ok((scale, used))
}

/// The scale from the markers at rest (`[scale_markers]`): the session's first 0 kPa
/// item; a scale photo also present is not used, and a warning says so.
fn markers_scale(
    session: &Path,
    config: &SessionConfig,
    calib: &Calibration,
    items: ScaleItems,
    notes: &mut Notes,
) -> Result<(SessionScale, ScaleUsed), PipelineError> {
    let Some(entries) = items.entries else {
        return Err(PipelineError::Layout {
            path: session.join(CONFIG),
            why: "[scale_markers] measures the scale on a step session's 0 kPa item, and a ramp has none: use a scale board (scale.jpg) instead".into(),
        });
    };
    let entry = rest_entry(session, entries)?;
    let r = scale_from_rest(session, entry, config, calib, items.frames)?;
    if let Some(img) = find_scale_image(session, config) {
        notes.push(format!(
            "warning: {}: not used: [scale_markers] in {CONFIG} gives the scale (from the markers at rest in {}); remove one of them",
            img.display(),
            entry.file
        ));
    }
    if r.spread > crate::scale::TILT_WARNING_SPREAD {
        notes.push(format!(
            "warning: {}: the markers' spacing at rest differs from [scale_markers] spacing_mm by {:.1}% between pairs: is the actuator straight, and the spacing right?",
            r.file.display(),
            100.0 * r.spread
        ));
    }
    let spacing = config
        .scale_markers
        .as_ref()
        .map(|m| m.spacing_mm.distances(config.expected_markers))
        .unwrap_or_default();
    let scale = SessionScale {
        mm_per_px: r.mm_per_px,
        width: r.width,
        plane_from_px: None,
    };
    let used = ScaleUsed {
        source: ScaleSource::Markers,
        file: Some(r.file),
        mm_per_px: r.mm_per_px,
        image_width: r.width,
        board: None,
        plane_from_px: None,
        kind: ScaleUsed::kind_of(ScaleSource::Markers, 0.0),
        board_plane: None,
        rest: Some(RestUsed {
            frames_used: r.frames_used,
            spacing_mm: spacing,
            spacing_px: r.spacing_px,
            spread: r.spread,
        }),
    };
    Ok((scale, used))
}
