//! `bendscope process`: radius of curvature, curvature and bending angle vs pressure
//! from session folders of videos.

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::sync::mpsc::sync_channel;

use anyhow::{anyhow, Context, Result};
use bendscope::calib::corners::{detect_views, DetectSettings as CornerSettings, ViewSource};
use bendscope::calib::file::{calibration_to_yaml, read_calibration, write_calibration};
use bendscope::calib::{
    calibrate, Board, Calibration, CalibrationSettings, UndistortSettings, Undistorter,
};
use bendscope::detect::{mask_from_rgb, ChainStart};
use bendscope::report::{
    fit_session, plot_xy, write_json, write_overlay, write_per_frame_csv, write_per_video_csv,
    FrameRow, Series, VideoRow,
};
use bendscope::scale::scale_from_board_photo;
use bendscope::session::{
    find_scale_image, measure_frame, measure_frame_with, read_manifest, read_pressure_log,
    session_videos, summarize, FrameStatus, Manifest, ManifestEntry, PressureLog, SessionConfig,
    PRESSURE_LOG,
};
use bendscope::video::{Pixels, VideoReader};
use clap::Args;
use opencv::prelude::*;
use serde::{Deserialize, Serialize};

use super::{EXIT_BAD_INPUT, EXIT_NOTHING, EXIT_OK, EXIT_PARTIAL};

/// Measure bending vs pressure from session folders.
#[derive(Debug, Args)]
#[command(
    after_help = "Session folder (step protocol): pressures.csv (header file,pressure_bar | pressure_kpa | pressure_psi), \
one video per pressure (GoPro chapters GX02.. continue GX01..), scale.jpg (a board in the actuator plane), \
calib/ (checkerboard photos) and an optional bendscope.toml.
Ramp protocol: pressure_log.csv (time_s,pressure_<unit>) and one video instead of pressures.csv.
RGB-D: color/, depth/ (16-bit PNG aligned to colour), intrinsics.json and pressure_log.csv.
Outputs in OUT: per_frame.csv, per_video.csv, fit.json, plots/, overlays/."
)]
pub struct ProcessArgs {
    /// Session folders (pressures.csv, videos, scale photo, calib/).
    #[arg(required = true, value_name = "SESSION")]
    pub sessions: Vec<PathBuf>,
    /// Output folder [default: SESSION/bendscope-out; with several sessions OUT/<session>].
    #[arg(short, long, value_name = "OUT")]
    pub output: Option<PathBuf>,
    /// Calibration file (else the session's setting, else calib/ is calibrated and cached in OUT).
    #[arg(long, value_name = "FILE")]
    pub calibration: Option<PathBuf>,
    /// Settings file [default: SESSION/bendscope.toml when present].
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Reprocess videos whose results are current.
    #[arg(long)]
    pub force: bool,
}

/// Cached result of one video.
#[derive(Debug, Serialize, Deserialize)]
struct Cached {
    fingerprint: u64,
    video: VideoRow,
    frames: Vec<CachedFrame>,
    /// The clamped-end marker (px) of the video's last measured frame: where the next
    /// video's marker chain starts (an actuator curled past 180 degrees brings its tip
    /// nearer the clamp side than its clamped end).
    #[serde(default)]
    clamp_marker_px: Option<(f64, f64)>,
}

#[derive(Debug, Serialize, Deserialize)]
struct CachedFrame {
    frame: u64,
    time_s: f64,
    pressure_kpa: f64,
    n_markers: usize,
    radius_px: f64,
    radius_mm: f64,
    curvature_per_m: f64,
    bending_angle_deg: f64,
    fit_rms_px: f64,
    status: String,
}

/// Runs `bendscope process`.
pub fn run(args: &ProcessArgs) -> Result<u8> {
    let several = args.sessions.len() > 1;
    let (mut measured, mut failed, mut bad_input) = (0usize, 0usize, 0usize);
    for session in &args.sessions {
        let name = session
            .canonicalize()
            .ok()
            .and_then(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
            .unwrap_or_else(|| "session".into());
        let out = match (&args.output, several) {
            (Some(o), true) => o.join(&name),
            (Some(o), false) => o.clone(),
            (None, _) => session.join("bendscope-out"),
        };
        match process_session(session, &out, args) {
            Ok(s) => {
                measured += s.measured;
                failed += s.failed;
                super::out!(
                    "{}: {} video(s) measured, {} failed -> {}",
                    session.display(),
                    s.measured,
                    s.failed,
                    out.display()
                );
            }
            Err(e) => {
                eprintln!("error: {}: {e:#}", session.display());
                bad_input += 1;
            }
        }
    }
    Ok(if measured == 0 {
        if bad_input > 0 && failed == 0 {
            EXIT_BAD_INPUT
        } else {
            EXIT_NOTHING
        }
    } else if failed > 0 || bad_input > 0 {
        EXIT_PARTIAL
    } else {
        EXIT_OK
    })
}

struct SessionOutcome {
    measured: usize,
    failed: usize,
}

fn session_calibration(
    session: &Path,
    out: &Path,
    config: &SessionConfig,
    args: &ProcessArgs,
) -> Result<Calibration> {
    if let Some(c) = &args.calibration {
        return Ok(read_calibration(c)?);
    }
    if let Some(c) = &config.calibration {
        return Ok(read_calibration(&session.join(c))?);
    }
    let cached = out.join("calibration.yaml");
    if cached.is_file() && !args.force {
        return Ok(read_calibration(&cached)?);
    }
    let dir = session.join("calib");
    if !dir.is_dir() {
        return Err(anyhow!(
            "no calibration: give --calibration FILE, set `calibration` in bendscope.toml, or put checkerboard photos in {}",
            dir.display()
        ));
    }
    let mut photos: Vec<PathBuf> = std::fs::read_dir(&dir)?
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.extension()
                .map(|e| {
                    bendscope::session::IMAGE_EXTENSIONS
                        .contains(&e.to_string_lossy().to_ascii_lowercase().as_str())
                })
                .unwrap_or(false)
        })
        .collect();
    photos.sort();
    let sources: Vec<ViewSource> = photos.into_iter().map(ViewSource::Image).collect();
    let b = config.calib_board;
    let board = Board::new(b.cols, b.rows, b.square_mm)?;
    let det = detect_views(&sources, &board, &CornerSettings::default(), &|| {});
    let calib = calibrate(
        &det,
        &CalibrationSettings {
            model: config.model,
            board,
            fix_aspect_ratio: false,
        },
    )
    .with_context(|| format!("calibrating {}", dir.display()))?;
    write_calibration(&cached, &calib)?;
    eprintln!(
        "calibrated {} from {} views (RMS {:.3} px) -> {}",
        config.model.name(),
        calib.views_used.len(),
        calib.avg_reprojection_error,
        cached.display()
    );
    Ok(calib)
}

fn process_session(session: &Path, out: &Path, args: &ProcessArgs) -> Result<SessionOutcome> {
    let config = match &args.config {
        Some(p) => SessionConfig::read(p)?,
        None => SessionConfig::for_session(session)?,
    };
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    if bendscope::rgbd::is_rgbd_session(session) {
        return process_rgbd_session(session, out, &config);
    }
    let ramp = if !session.join(bendscope::session::MANIFEST).exists()
        && session.join(PRESSURE_LOG).is_file()
    {
        Some(read_pressure_log(&session.join(PRESSURE_LOG))?)
    } else {
        None
    };
    let manifest = match &ramp {
        Some(log) => {
            let videos = session_videos(session);
            if videos.len() != 1 {
                return Err(anyhow!(
                    "a ramp session ({PRESSURE_LOG}) holds exactly one video, found {}: keep one video per session folder",
                    videos.len()
                ));
            }
            Manifest {
                unit: log.unit,
                entries: vec![ManifestEntry {
                    line: 0,
                    file: videos[0].clone(),
                    chapters: vec![],
                    pressure: f64::NAN,
                    pressure_kpa: f64::NAN,
                }],
                issues: vec![],
            }
        }
        None => read_manifest(session)?,
    };
    if manifest.entries.is_empty() && manifest.issues.is_empty() {
        return Err(anyhow!(
            "{} lists no videos: add one row per video",
            bendscope::session::MANIFEST
        ));
    }
    let calib = session_calibration(session, out, &config, args)?;
    let mm_per_px = match config.mm_per_px {
        Some(m) => m,
        None => {
            let img = find_scale_image(session, &config).ok_or_else(|| {
                anyhow!("no scale photo: put scale.jpg (a board lying in the actuator plane) in the session, or set mm_per_px in bendscope.toml")
            })?;
            let b = config.scale_board;
            let board = Board::new(b.cols, b.rows, b.square_mm)?;
            let s = scale_from_board_photo(&img, &calib, &board, UndistortSettings::default())
                .with_context(|| format!("scale from {}", img.display()))?;
            if s.looks_tilted() {
                eprintln!(
                    "warning: {}: board spacing varies by {:.1}%: not parallel to the image plane?",
                    img.display(),
                    100.0 * s.spread
                );
            }
            s.mm_per_px
        }
    };
    let fingerprint_base = {
        let mut h = DefaultHasher::new();
        toml::to_string(&config).unwrap_or_default().hash(&mut h);
        calibration_to_yaml(&calib).unwrap_or_default().hash(&mut h);
        mm_per_px.to_bits().hash(&mut h);
        std::fs::read(session.join(PRESSURE_LOG))
            .ok()
            .filter(|_| ramp.is_some())
            .hash(&mut h);
        h.finish()
    };
    std::fs::create_dir_all(out.join("cache"))
        .with_context(|| format!("creating {}", out.display()))?;
    let bar = super::progress_bar(manifest.entries.len() as u64, "videos");
    let mut videos: Vec<VideoRow> = Vec::new();
    let mut frames: Vec<FrameRow> = Vec::new();
    let mut per_video_frames: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    let mut chain_start = None;
    for entry in &manifest.entries {
        bar.set_message(entry.file.clone());
        let fp = fingerprint(session, entry, fingerprint_base);
        let cache_path = out.join("cache").join(format!("{}.json", entry.file));
        let cached: Option<Cached> = (!args.force)
            .then(|| std::fs::read_to_string(&cache_path).ok())
            .flatten()
            .and_then(|t| serde_json::from_str(&t).ok())
            .filter(|c: &Cached| c.fingerprint == fp);
        let result = match cached {
            Some(c) => c,
            None => {
                let c = measure_video(
                    session,
                    out,
                    entry,
                    &calib,
                    mm_per_px,
                    &config,
                    ramp.as_ref(),
                    fp,
                    chain_start,
                );
                write_json(&cache_path, &c)?;
                c
            }
        };
        chain_start = result.clamp_marker_px.or(chain_start);
        for f in &result.frames {
            frames.push(FrameRow {
                file: entry.file.clone(),
                frame: f.frame,
                time_s: f.time_s,
                pressure_kpa: f.pressure_kpa,
                n_markers: f.n_markers,
                radius_px: f.radius_px,
                radius_mm: f.radius_mm,
                curvature_per_m: f.curvature_per_m,
                bending_angle_deg: f.bending_angle_deg,
                fit_rms_px: f.fit_rms_px,
                status: f.status.clone(),
            });
        }
        per_video_frames.push((
            entry.file.clone(),
            result
                .frames
                .iter()
                .map(|f| (f.time_s, f.radius_mm))
                .collect(),
        ));
        if result.video.frames_used == 0 {
            bar.suspend(|| eprintln!("warning: {}: {}", entry.file, result.video.status));
        }
        match &ramp {
            // Ramp protocol: the rows are pressure bins of the one video.
            Some(log) if result.video.frames_used > 0 => {
                videos.extend(bin_frames(
                    &entry.file,
                    &result.frames,
                    config.ramp_bin_kpa,
                    log.unit,
                ));
            }
            _ => videos.push(result.video),
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    for issue in &manifest.issues {
        eprintln!(
            "warning: {}{}: {}",
            issue.file,
            issue
                .line
                .map(|l| format!(" (line {l})"))
                .unwrap_or_default(),
            issue.message
        );
        videos.push(VideoRow {
            file: issue.file.clone(),
            pressure_kpa: f64::NAN,
            pressure: f64::NAN,
            radius_mm: f64::NAN,
            radius_mm_median: f64::NAN,
            radius_mm_std: f64::NAN,
            curvature_per_m: f64::NAN,
            bending_angle_deg: f64::NAN,
            fit_rms_px: f64::NAN,
            frames_used: 0,
            frames_rejected: 0,
            status: issue.message.clone(),
        });
    }
    write_outputs(
        out,
        &frames,
        &videos,
        manifest.unit.name(),
        &per_video_frames,
    )
}

/// Writes the tables, fits and plots of a session and counts what was measured.
fn write_outputs(
    out: &Path,
    frames: &[FrameRow],
    videos: &[VideoRow],
    unit: &str,
    per_video_frames: &[(String, Vec<(f64, f64)>)],
) -> Result<SessionOutcome> {
    write_per_frame_csv(&out.join("per_frame.csv"), frames)?;
    write_per_video_csv(&out.join("per_video.csv"), videos, unit)?;
    let fits = fit_session(videos, unit);
    write_json(&out.join("fit.json"), &fits)?;
    write_plots(out, videos, &fits, per_video_frames)?;
    let measured = videos.iter().filter(|v| v.frames_used > 0).count();
    Ok(SessionOutcome {
        measured,
        failed: videos.len() - measured,
    })
}

/// An RGB-D session: colour + aligned depth frames and a pressure log; 3D markers give
/// the radius in mm with no scale photo.
fn process_rgbd_session(
    session: &Path,
    out: &Path,
    config: &SessionConfig,
) -> Result<SessionOutcome> {
    use bendscope::fit::{bending_angle_from_circle_deg, fit_circle_3d};
    use bendscope::rgbd::{list_frames, markers_3d_mm, undistorter};
    let (intr, list) = list_frames(session)?;
    let log_path = session.join(PRESSURE_LOG);
    if !log_path.is_file() {
        return Err(anyhow!(
            "an RGB-D session needs {}: time_s,pressure_<unit> from the regulator",
            log_path.display()
        ));
    }
    let log = read_pressure_log(&log_path)?;
    let und = undistorter(&intr)?;
    let bar = super::progress_bar(list.len() as u64, "RGB-D frames");
    let mut mask = image::GrayImage::new(0, 0);
    let mut start = ChainStart::Side(config.detect.clamp_side);
    let mut cached: Vec<CachedFrame> = Vec::with_capacity(list.len());
    for fr in &list {
        bar.inc(1);
        let pressure_kpa = log
            .pressure_at(fr.time_s + config.ramp_time_offset_s)
            .unwrap_or(f64::NAN);
        let mut row = CachedFrame {
            frame: fr.index,
            time_s: fr.time_s,
            pressure_kpa,
            n_markers: 0,
            radius_px: f64::NAN,
            radius_mm: f64::NAN,
            curvature_per_m: f64::NAN,
            bending_angle_deg: f64::NAN,
            fit_rms_px: f64::NAN,
            status: "ok".into(),
        };
        let measured: Result<(), String> = (|| {
            if pressure_kpa.is_nan() {
                return Err(
                    "outside the pressure log's time span (check ramp_time_offset_s)".into(),
                );
            }
            let color = image::open(&fr.color)
                .map_err(|e| format!("unreadable colour frame: {e}"))?
                .into_rgb8();
            let depth =
                match image::open(&fr.depth).map_err(|e| format!("unreadable depth frame: {e}"))? {
                    image::DynamicImage::ImageLuma16(d) => d,
                    _ => return Err("depth frame is not a 16-bit grey PNG".into()),
                };
            if color.dimensions() != depth.dimensions()
                || color.dimensions() != (intr.width, intr.height)
            {
                return Err(format!(
                    "colour {:?} and depth {:?} differ from the intrinsics' {}x{}: align depth to colour",
                    color.dimensions(),
                    depth.dimensions(),
                    intr.width,
                    intr.height
                ));
            }
            let d = bendscope::detect::detect_markers_with(&color, &config.detect, &mut mask);
            row.n_markers = d.blobs.len();
            if d.blobs.len() != config.expected_markers {
                return Err(format!(
                    "{} markers found, {} expected",
                    d.blobs.len(),
                    config.expected_markers
                ));
            }
            let mut areas: Vec<u32> = d.blobs.iter().map(|b| b.area_px).collect();
            areas.sort_unstable();
            let window = 0.7 * (areas[areas.len() / 2] as f64 / std::f64::consts::PI).sqrt();
            let raw: Vec<nalgebra::Point2<f64>> = d.blobs.iter().map(|b| b.centroid).collect();
            let ordered = bendscope::detect::order_markers(&raw, start);
            let pts = markers_3d_mm(&ordered, window, &depth, &intr, &und)?;
            let c = fit_circle_3d(&pts).map_err(|e| e.to_string())?;
            let flat: Vec<nalgebra::Point2<f64>> = pts.iter().map(|p| c.to_plane(p)).collect();
            row.radius_mm = c.circle.radius;
            row.curvature_per_m = c.circle.curvature * 1000.0;
            row.fit_rms_px = c.circle.rms;
            row.bending_angle_deg =
                bending_angle_from_circle_deg(flat[0], flat[flat.len() - 1], &c.circle)
                    .unwrap_or(f64::NAN);
            start = ChainStart::Near(ordered[0]);
            Ok(())
        })();
        if let Err(why) = measured {
            row.status = why;
        }
        cached.push(row);
    }
    bar.finish_and_clear();
    let frames: Vec<FrameRow> = cached
        .iter()
        .map(|f| FrameRow {
            file: "color".into(),
            frame: f.frame,
            time_s: f.time_s,
            pressure_kpa: f.pressure_kpa,
            n_markers: f.n_markers,
            radius_px: f64::NAN,
            radius_mm: f.radius_mm,
            curvature_per_m: f.curvature_per_m,
            bending_angle_deg: f.bending_angle_deg,
            fit_rms_px: f.fit_rms_px,
            status: f.status.clone(),
        })
        .collect();
    let videos = bin_frames("color", &cached, config.ramp_bin_kpa, log.unit);
    let series = vec![(
        "color".to_string(),
        cached.iter().map(|f| (f.time_s, f.radius_mm)).collect(),
    )];
    let outcome = write_outputs(out, &frames, &videos, log.unit.name(), &series)?;
    Ok(SessionOutcome {
        measured: outcome.measured,
        failed: outcome.failed + usize::from(outcome.measured == 0),
    })
}

fn fingerprint(session: &Path, entry: &ManifestEntry, base: u64) -> u64 {
    let mut h = DefaultHasher::new();
    base.hash(&mut h);
    entry.pressure_kpa.to_bits().hash(&mut h);
    for f in std::iter::once(&entry.file).chain(&entry.chapters) {
        f.hash(&mut h);
        if let Ok(m) = std::fs::metadata(session.join(f)) {
            m.len().hash(&mut h);
            m.modified().ok().hash(&mut h);
        }
    }
    h.finish()
}

/// Measures every frame of one video item (all its chapters), streaming: a decoder
/// thread feeds frames through a bounded channel to the measuring thread.
#[allow(clippy::too_many_arguments)]
fn measure_video(
    session: &Path,
    out: &Path,
    entry: &ManifestEntry,
    calib: &Calibration,
    mm_per_px: f64,
    config: &SessionConfig,
    ramp: Option<&PressureLog>,
    fingerprint: u64,
    chain_start: Option<(f64, f64)>,
) -> Cached {
    let mut rows: Vec<CachedFrame> = Vec::new();
    let mut measurements = Vec::new();
    let mut problems: Vec<String> = Vec::new();
    let mut overlay_done = false;
    let mut start = match chain_start {
        Some((x, y)) => ChainStart::Near(nalgebra::Point2::new(x, y)),
        None => ChainStart::Side(config.detect.clamp_side),
    };
    let mut time_offset = 0.0;
    let mut index_offset = 0u64;
    for file in std::iter::once(&entry.file).chain(&entry.chapters) {
        let path = session.join(file);
        let stride = config.frame_stride;
        // Whole-frame undistortion needs RGB frames: let swscale convert them.
        let want_rgb = config.full_frame_undistort;
        // The reader lives on the decoder thread (FFmpeg contexts are not Send); it sends
        // the stream's size first, then frames, through a bounded channel.
        let (tx, rx) = sync_channel::<Result<Decoded, String>>(2);
        // Frames the measuring thread is done with go back to be decoded into again.
        let (back_tx, back_rx) = sync_channel::<Pixels>(3);
        let decoder = std::thread::spawn(move || {
            let mut reader = match VideoReader::open(&path) {
                Ok(r) => r,
                Err(e) => {
                    let _ = tx.send(Err(e.to_string()));
                    return None;
                }
            };
            let size = (reader.info().width, reader.info().height);
            if tx.send(Ok(Decoded::Size(size.0, size.1))).is_err() {
                return None;
            }
            loop {
                let recycled = back_rx.try_recv().ok();
                let next = if want_rgb {
                    let buf = match recycled {
                        Some(Pixels::Rgb(i)) => Some(i),
                        _ => None,
                    };
                    reader
                        .next_frame_recycling(stride, buf)
                        .map(|f| f.map(|f| (f.index, f.time_s, Pixels::Rgb(f.image))))
                } else {
                    reader.next_pixels(stride, recycled)
                };
                match next {
                    Ok(Some((index, time_s, pixels))) => {
                        let f = DecodedFrame {
                            index,
                            time_s,
                            pixels,
                        };
                        if tx.send(Ok(Decoded::Frame(f))).is_err() {
                            break;
                        }
                    }
                    Ok(None) => break,
                    Err(e) => {
                        let _ = tx.send(Err(e.to_string()));
                        break;
                    }
                }
            }
            Some(reader.stats().clone())
        });
        let (w, h) = match rx.recv() {
            Ok(Ok(Decoded::Size(w, h))) => (w, h),
            Ok(Err(e)) => {
                problems.push(e);
                let _ = decoder.join();
                continue;
            }
            _ => {
                problems.push(format!("{file}: the decoder stopped"));
                let _ = decoder.join();
                continue;
            }
        };
        let setup = calib
            .for_resolution(w, h)
            .and_then(|cal| Undistorter::new(&cal, UndistortSettings::default()));
        let und = match setup {
            Ok(u) => u,
            Err(e) => {
                problems.push(format!("{file}: {e}"));
                drop(rx);
                let _ = decoder.join();
                continue;
            }
        };
        // The scale was measured at the calibration's size: rescale mm/px with it.
        let mm_px = mm_per_px * calib.image_width as f64 / w as f64;
        let maps = if config.full_frame_undistort {
            match und.maps() {
                Ok(m) => Some(m),
                Err(e) => {
                    problems.push(format!("{file}: {e}"));
                    drop(rx);
                    let _ = decoder.join();
                    continue;
                }
            }
        } else {
            None
        };
        let mut last_time = 0.0;
        let mut mask = image::GrayImage::new(0, 0);
        let mut last_index = 0;
        for msg in rx {
            let f = match msg {
                Ok(Decoded::Frame(f)) => f,
                Ok(Decoded::Size(..)) => continue,
                Err(e) => {
                    problems.push(e);
                    break;
                }
            };
            let pressure_kpa = match ramp {
                Some(log) => log
                    .pressure_at(f.time_s + time_offset + config.ramp_time_offset_s)
                    .unwrap_or(f64::NAN),
                None => entry.pressure_kpa,
            };
            let mut m = match &maps {
                Some(maps) => match undistort_pixels(&und, maps, &f.pixels) {
                    Ok(flat) => {
                        measure_frame(&flat, None, &config.detect, config.expected_markers, start)
                    }
                    Err(e) => {
                        problems.push(format!("{file}: {e}"));
                        break;
                    }
                },
                None => match &f.pixels {
                    Pixels::Yuv(yuv) => measure_frame_with(
                        yuv,
                        Some(&und),
                        &config.detect,
                        config.expected_markers,
                        start,
                        &mut mask,
                    ),
                    Pixels::Rgb(rgb) => measure_frame_with(
                        rgb,
                        Some(&und),
                        &config.detect,
                        config.expected_markers,
                        start,
                        &mut mask,
                    ),
                },
            };
            if ramp.is_some() && pressure_kpa.is_nan() {
                m.status = FrameStatus::Rejected(format!(
                    "outside the pressure log's time span (check ramp_time_offset_s in {})",
                    bendscope::session::CONFIG
                ));
            }
            if m.status == FrameStatus::Ok {
                if let Some(first) = m.markers_px.first() {
                    start = ChainStart::Near(*first);
                }
                if !overlay_done {
                    overlay_done = write_video_overlay(
                        out,
                        &entry.file,
                        &f.pixels.to_rgb(),
                        calib,
                        config,
                        &m,
                    )
                    .is_ok();
                }
            }
            rows.push(CachedFrame {
                frame: f.index + index_offset,
                time_s: f.time_s + time_offset,
                pressure_kpa,
                n_markers: m.n_markers,
                radius_px: m.radius_px,
                radius_mm: m.radius_px * mm_px,
                curvature_per_m: m.curvature_per_px / mm_px * 1000.0,
                bending_angle_deg: m.bending_angle_deg,
                fit_rms_px: m.fit_rms_px,
                status: m.status.text(),
            });
            let mut scaled = m.clone();
            // Summaries use one mm/px: fold the chapter's into the radius.
            scaled.radius_px = m.radius_px * mm_px / mm_per_px;
            scaled.curvature_per_px = m.curvature_per_px * mm_per_px / mm_px;
            measurements.push(scaled);
            last_time = f.time_s;
            last_index = f.index;
            let _ = back_tx.try_send(f.pixels);
        }
        match decoder.join() {
            Ok(Some(stats)) if stats.has_errors() => problems.push(format!(
                "{file}: {} corrupt packet(s){}; measured what decoded",
                stats.packets_failed,
                stats
                    .read_error
                    .map(|e| format!(", read error: {e}"))
                    .unwrap_or_default()
            )),
            Ok(_) => {}
            Err(_) => problems.push(format!("{file}: the decoder thread failed")),
        }
        time_offset += last_time + 1.0 / 30.0;
        index_offset += last_index + 1;
    }
    let s = summarize(&measurements, mm_per_px);
    let status = if s.frames_used == 0 {
        let reason = most_common_rejection(&rows).unwrap_or_else(|| "no frames decoded".into());
        if problems.is_empty() {
            format!("no frame measured: {reason}")
        } else {
            format!("no frame measured: {}", problems.join("; "))
        }
    } else if problems.is_empty() {
        "ok".into()
    } else {
        format!("partial: {}", problems.join("; "))
    };
    let clamp_marker_px = match start {
        ChainStart::Near(p) => Some((p.x, p.y)),
        ChainStart::Side(_) => chain_start,
    };
    Cached {
        clamp_marker_px,
        fingerprint,
        video: VideoRow {
            file: entry.file.clone(),
            pressure_kpa: entry.pressure_kpa,
            pressure: entry.pressure,
            radius_mm: s.radius_mm,
            radius_mm_median: s.radius_mm_median,
            radius_mm_std: s.radius_mm_std,
            curvature_per_m: s.curvature_per_m,
            bending_angle_deg: s.bending_angle_deg,
            fit_rms_px: s.fit_rms_px,
            frames_used: s.frames_used,
            frames_rejected: s.frames_rejected,
            status,
        },
        frames: rows,
    }
}

/// Ramp protocol: the measured frames of one video averaged in pressure bins of
/// `bin_kpa` (a low-pass filter of the per-frame results), one row per bin.
fn bin_frames(
    file: &str,
    frames: &[CachedFrame],
    bin_kpa: f64,
    unit: bendscope::session::PressureUnit,
) -> Vec<VideoRow> {
    let mut bins: std::collections::BTreeMap<i64, Vec<&CachedFrame>> =
        std::collections::BTreeMap::new();
    for f in frames
        .iter()
        .filter(|f| f.status == "ok" && f.pressure_kpa.is_finite())
    {
        bins.entry((f.pressure_kpa / bin_kpa).floor() as i64)
            .or_default()
            .push(f);
    }
    bins.into_values()
        .map(|b| {
            let n = b.len() as f64;
            let mean = |g: fn(&CachedFrame) -> f64| b.iter().map(|f| g(f)).sum::<f64>() / n;
            let mut r: Vec<f64> = b.iter().map(|f| f.radius_mm).collect();
            r.sort_by(f64::total_cmp);
            let radius = mean(|f| f.radius_mm);
            let std = if b.len() > 1 && radius.is_finite() {
                (b.iter()
                    .map(|f| (f.radius_mm - radius).powi(2))
                    .sum::<f64>()
                    / (n - 1.0))
                    .sqrt()
            } else {
                0.0
            };
            let p = mean(|f| f.pressure_kpa);
            VideoRow {
                file: file.to_string(),
                pressure_kpa: p,
                pressure: p / unit.to_kpa(),
                radius_mm: radius,
                radius_mm_median: r[r.len() / 2],
                radius_mm_std: std,
                curvature_per_m: mean(|f| f.curvature_per_m),
                bending_angle_deg: mean(|f| f.bending_angle_deg),
                fit_rms_px: mean(|f| f.fit_rms_px),
                frames_used: b.len(),
                frames_rejected: 0,
                status: "ok".into(),
            }
        })
        .collect()
}

/// A decoded frame as the measuring thread receives it.
struct DecodedFrame {
    index: u64,
    time_s: f64,
    pixels: Pixels,
}

/// What the decoder thread sends.
enum Decoded {
    /// Frame size, first.
    Size(u32, u32),
    /// A decoded frame.
    Frame(DecodedFrame),
}

fn most_common_rejection(rows: &[CachedFrame]) -> Option<String> {
    let mut counts: std::collections::BTreeMap<&str, usize> = std::collections::BTreeMap::new();
    for r in rows {
        if r.status != "ok" {
            *counts.entry(r.status.as_str()).or_default() += 1;
        }
    }
    counts
        .into_iter()
        .max_by_key(|(_, n)| *n)
        .map(|(s, n)| format!("{s} (in {n} of {} frames): check the lighting, the HSV thresholds and expected_markers in bendscope.toml", rows.len()))
}

/// Width above which the overlay is drawn at a reduced size (a QA picture needs no
/// more, and full-frame maps of a 4K frame would dominate the memory of a run).
const OVERLAY_MAX_WIDTH: u32 = 1920;

fn write_video_overlay(
    out: &Path,
    file: &str,
    raw: &image::RgbImage,
    calib: &Calibration,
    config: &SessionConfig,
    m: &bendscope::session::FrameMeasurement,
) -> Result<()> {
    let (w, h) = raw.dimensions();
    let k = w.div_ceil(OVERLAY_MAX_WIDTH).max(1);
    let small;
    let (frame, (sw, sh)) = if k > 1 {
        small = image::imageops::resize(raw, w / k, h / k, image::imageops::FilterType::Triangle);
        (&small, (w / k, h / k))
    } else {
        (raw, (w, h))
    };
    // Pixel centres at integers: x' + 0.5 = (x + 0.5) / k.
    let f = |v: f64| (v + 0.5) / k as f64 - 0.5;
    let und = Undistorter::new(&calib.for_resolution(sw, sh)?, UndistortSettings::default())?;
    let maps = und.maps()?;
    let img = undistort_rgb(&und, &maps, frame)?;
    let mask = mask_from_rgb(&img, &config.detect.hsv);
    let markers: Vec<nalgebra::Point2<f64>> = m
        .markers_px
        .iter()
        .map(|p| nalgebra::Point2::new(f(p.x), f(p.y)))
        .collect();
    let center = nalgebra::Point2::new(f(m.center_px.x), f(m.center_px.y));
    write_overlay(
        &out.join("overlays").join(format!("{file}.png")),
        &img,
        &mask,
        &markers,
        center,
        m.radius_px / k as f64,
    )?;
    Ok(())
}

/// Undistorts a whole decoded frame (RGB as decoded, or converted from YUV first).
fn undistort_pixels(
    und: &Undistorter,
    maps: &(opencv::core::Mat, opencv::core::Mat),
    pixels: &Pixels,
) -> Result<image::RgbImage> {
    match pixels {
        Pixels::Rgb(rgb) => undistort_rgb(und, maps, rgb),
        yuv => undistort_rgb(und, maps, &yuv.to_rgb()),
    }
}

/// Undistorts a whole RGB frame (OpenCV remap).
fn undistort_rgb(
    und: &Undistorter,
    maps: &(opencv::core::Mat, opencv::core::Mat),
    raw: &image::RgbImage,
) -> Result<image::RgbImage> {
    let (w, h) = raw.dimensions();
    let flat_src = opencv::core::Mat::from_slice(raw.as_raw())?;
    let mat = flat_src.reshape(3, h as i32)?.clone_pointee();
    let flat = und.undistort_image(maps, &mat)?;
    let bytes = flat.data_bytes()?.to_vec();
    image::RgbImage::from_raw(w, h, bytes).ok_or_else(|| anyhow!("undistorted frame buffer"))
}

fn write_plots(
    out: &Path,
    videos: &[VideoRow],
    fits: &bendscope::report::SessionFits,
    per_frame: &[(String, Vec<(f64, f64)>)],
) -> Result<()> {
    let ok: Vec<&VideoRow> = videos.iter().filter(|v| v.frames_used > 0).collect();
    let pmax = ok.iter().map(|v| v.pressure_kpa).fold(0.0, f64::max);
    let pmin = ok
        .iter()
        .map(|v| v.pressure_kpa)
        .filter(|p| *p > 0.0)
        .fold(f64::INFINITY, f64::min);
    let curve = |f: &Option<bendscope::fit::PowerLawFit>| -> Vec<(f64, f64)> {
        match f {
            Some(f) if pmin.is_finite() => (0..=100)
                .map(|i| {
                    let p = pmin + (pmax - pmin) * i as f64 / 100.0;
                    (p, f.eval(p))
                })
                .collect(),
            _ => vec![],
        }
    };
    let plots = out.join("plots");
    plot_xy(
        &plots.join("radius_vs_pressure"),
        "Radius of curvature vs pressure",
        "pressure (kPa)",
        "radius (mm)",
        &[
            Series {
                label: "measured (mean per video)",
                points: ok.iter().map(|v| (v.pressure_kpa, v.radius_mm)).collect(),
                line: false,
            },
            Series {
                label: "power-law fit",
                points: curve(&fits.radius_mm_vs_kpa),
                line: true,
            },
        ],
    )?;
    plot_xy(
        &plots.join("curvature_vs_pressure"),
        "Curvature vs pressure",
        "pressure (kPa)",
        "curvature (1/m)",
        &[
            Series {
                label: "measured",
                points: ok
                    .iter()
                    .map(|v| (v.pressure_kpa, v.curvature_per_m))
                    .collect(),
                line: false,
            },
            Series {
                label: "power-law fit",
                points: curve(&fits.curvature_per_m_vs_kpa),
                line: true,
            },
        ],
    )?;
    plot_xy(
        &plots.join("angle_vs_pressure"),
        "Bending angle vs pressure",
        "pressure (kPa)",
        "bending angle (deg)",
        &[Series {
            label: "measured",
            points: ok
                .iter()
                .map(|v| (v.pressure_kpa, v.bending_angle_deg))
                .collect(),
            line: false,
        }],
    )?;
    let series: Vec<Series> = per_frame
        .iter()
        .map(|(name, pts)| Series {
            label: name,
            points: pts.clone(),
            line: true,
        })
        .collect();
    plot_xy(
        &plots.join("radius_per_frame"),
        "Radius per frame (stability)",
        "time (s)",
        "radius (mm)",
        &series,
    )?;
    Ok(())
}
