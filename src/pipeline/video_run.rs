//! The videos of a step or ramp session: calibration and scale set up once
//! ([`super::camera`]), each video measured streaming (all its chapters, one clock) or
//! taken from the cache when its content key is current.

use std::path::Path;

use crate::calib::file::calibration_to_yaml;
use crate::calib::{Calibration, UndistortSettings, Undistorter};
use crate::detect::ChainStart;
use crate::io::{content_key, hash_parts};
use crate::session::{ManifestEntry, PressureLog, SessionConfig, PRESSURE_LOG};
use crate::video::FrameSelection;

use super::cache::{Cache, ItemKey};
use super::camera::{session_calibration, session_scale, ScaleItems, SessionScale};
use super::error::{write_err, PipelineError};
use super::frame::{self, measure_frame, Geometry, Tracker};
use super::item::{frame_record, ItemResult};
use super::overlay;
use super::provenance::{CalibrationUsed, ScaleUsed};
use super::records::{FrameRecord, FrameStatus};
use super::run::{Notes, ProcessSettings, Progress};
use super::source::{self, Next};

/// The videos of a step or ramp session with what measuring them needs.
pub(super) struct VideoRun<'a> {
    session: &'a Path,
    out: &'a Path,
    config: &'a SessionConfig,
    calib: Calibration,
    scale: SessionScale,
    /// Where the calibration came from (for session.json).
    pub(super) calibration_used: CalibrationUsed,
    /// Where the scale came from (for session.json).
    pub(super) scale_used: ScaleUsed,
    log: Option<&'a PressureLog>,
    /// Hash of everything session-wide a video's result depends on.
    fingerprint: u128,
    /// Which frames of each video are measured (`[video] frames`, `frame_stride`).
    frames: FrameSelection,
}

impl<'a> VideoRun<'a> {
    /// Calibration, scale and the session's fingerprint. `entries`: a step session's
    /// items (the scale may be measured on its 0 kPa one); `None` for a ramp.
    pub(super) fn prepare(
        session: &'a Path,
        out: &'a Path,
        config: &'a SessionConfig,
        settings: &ProcessSettings,
        log: Option<&'a PressureLog>,
        entries: Option<&[ManifestEntry]>,
        notes: &mut Notes,
    ) -> Result<Self, PipelineError> {
        // Key frames only are refused for a ramp before anything is read.
        let frames =
            config
                .frame_selection(log.is_some())
                .map_err(|why| PipelineError::Layout {
                    path: session.join(crate::session::CONFIG),
                    why,
                })?;
        let (calib, calibration_used) = session_calibration(session, out, config, settings, notes)?;
        let (scale, scale_used) = session_scale(
            session,
            config,
            &calib,
            ScaleItems { entries, frames },
            notes,
        )?;
        let log_bytes = match log {
            Some(_) => std::fs::read(session.join(PRESSURE_LOG)).unwrap_or_default(),
            None => vec![],
        };
        let fingerprint = hash_parts([
            toml::to_string(config).unwrap_or_default().as_bytes(),
            calibration_to_yaml(&calib).unwrap_or_default().as_bytes(),
            &scale.mm_per_px.to_le_bytes(),
            &scale.width.to_le_bytes(),
            &scale
                .plane_from_px
                .iter()
                .flatten()
                .flat_map(|v| v.to_le_bytes())
                .collect::<Vec<u8>>(),
            &log_bytes,
        ]);
        Ok(Self {
            frames,
            session,
            out,
            config,
            calib,
            scale,
            calibration_used,
            scale_used,
            log,
            fingerprint,
        })
    }

    /// Measures `entries` in order (each video's marker chain starts where the previous
    /// one's clamped end was), from the cache when current.
    pub(super) fn measure(
        &self,
        entries: &[ManifestEntry],
        cache: &Cache,
        force: bool,
        notes: &mut Notes,
    ) -> Result<Vec<ItemResult>, PipelineError> {
        let mut items = Vec::with_capacity(entries.len());
        notes.progress.start("videos", entries.len() as u64);
        let mut chain: Option<(f64, f64)> = None;
        for entry in entries {
            notes.progress.item(&entry.file);
            let files: Vec<u128> = std::iter::once(&entry.file)
                .chain(&entry.chapters)
                .map(|f| content_key(&self.session.join(f)).unwrap_or(0))
                .collect();
            let start = chain.map(|(x, y)| nalgebra::Point2::new(x, y));
            // The chain start is an input too: a video measured after another one starts
            // where that one's clamped end was.
            let key = ItemKey::new(
                hash_parts([
                    self.fingerprint.to_le_bytes().as_slice(),
                    format!("{start:?}").as_bytes(),
                ]),
                &files,
                entry.pressure_kpa,
            );
            let cached = (!force).then(|| cache.get(&entry.file, &key)).flatten();
            let result = match cached {
                Some(c) => ItemResult::from_cache(entry, c),
                None => {
                    let r = self.measure_video(entry, start, &mut *notes.progress);
                    if r.storage_full {
                        notes.progress.finish();
                        return Err(PipelineError::NoSpace {
                            dir: self.out.to_path_buf(),
                        });
                    }
                    cache
                        .put(&entry.file, &r.to_cache(key))
                        .map_err(write_err(&self.out.join("cache")))?;
                    r
                }
            };
            chain = result.clamp_marker_px.or(chain);
            items.push(result);
            notes.progress.advance(1);
        }
        notes.progress.finish();
        Ok(items)
    }
}

/// Maps the marker centroids of a frame undistorted before detection back to the raw
/// frame (markers.csv's `x_px`, `y_px`) through the lens model.
fn raw_marker_centroids(undistorter: &Undistorter, m: &mut frame::FrameMeasurement) {
    let flat: Vec<nalgebra::Point2<f64>> = m
        .markers
        .iter()
        .map(|p| nalgebra::Point2::new(p.x_px, p.y_px))
        .collect();
    match undistorter.distort_points(&flat) {
        Ok(raw) => {
            for (p, r) in m.markers.iter_mut().zip(raw) {
                (p.x_px, p.y_px) = (r.x, r.y);
            }
        }
        Err(_) => {
            for p in &mut m.markers {
                (p.x_px, p.y_px) = (f64::NAN, f64::NAN);
            }
        }
    }
}

impl VideoRun<'_> {
    /// Measures one video (all its chapters), streaming: a decoder thread per chapter
    /// feeds frames through a bounded channel. Chapter clocks continue each other: a
    /// chapter starts one frame interval (of its own stream) after the previous
    /// chapter's last frame.
    fn measure_video(
        &self,
        entry: &ManifestEntry,
        start: Option<nalgebra::Point2<f64>>,
        progress: &mut dyn Progress,
    ) -> ItemResult {
        let (session, out, config, log) = (self.session, self.out, self.config, self.log);
        // Frames measured of this item, for progress.
        let mut done = 0u64;
        let mut tracker = Tracker::new(match start {
            Some(p) => ChainStart::Near(p),
            None => ChainStart::Side(config.detect.clamp_side),
        });
        let mut result = ItemResult {
            file: entry.file.clone(),
            pressure_kpa: entry.pressure_kpa,
            pressure: entry.pressure,
            frames: vec![],
            problems: vec![],
            clamp_marker_px: None,
            outputs: vec![],
            from_cache: false,
            storage_full: false,
        };
        let segments = config.segment_plan();
        let mut overlay_pending = true;
        let (mut time_offset, mut index_offset) = (0.0, 0u64);
        let mut outside_log = 0usize;
        for file in std::iter::once(&entry.file).chain(&entry.chapters) {
            let mut source = match source::open_source(
                &session.join(file),
                self.frames,
                config.full_frame_undistort,
            ) {
                Ok(s) => s,
                Err(e) => {
                    result.problems.push(e);
                    continue;
                }
            };
            let (w, h) = source.size();
            // Frames expected: those of the chapters before and this one's.
            let expected = done + source.frames_expected();
            let prepared = self
                .calib
                .for_resolution(w, h)
                .and_then(|c| Undistorter::new(&c, UndistortSettings::default()))
                .and_then(|u| {
                    let maps = if config.full_frame_undistort {
                        Some(u.maps()?)
                    } else {
                        None
                    };
                    Ok((u, maps))
                });
            let (undistorter, maps) = match prepared {
                Ok(p) => p,
                Err(e) => {
                    result.problems.push(format!("{file}: {e}"));
                    let _ = source.finish();
                    continue;
                }
            };
            // mm per px scales with the frame size (same aspect ratio as the scale photo).
            let mm_per_px = self.scale.mm_per_px * self.scale.width as f64 / w as f64;
            let plane_from_px = self
                .scale
                .plane_from_px
                .map(|h| crate::scale::homography_for_width(&h, self.scale.width, w));
            let (mut last_time, mut last_index, mut interval) = (f64::NAN, 0u64, 0.0f64);
            loop {
                let f = match source.next() {
                    Next::Frame(f) => f,
                    Next::Bad { index, time_s, why } => {
                        result.problems.push(why.clone());
                        result.frames.push(FrameRecord::rejected(
                            &entry.file,
                            index + index_offset,
                            time_s + time_offset,
                            entry.pressure_kpa,
                            FrameStatus::BadFrame { why },
                        ));
                        continue;
                    }
                    Next::End => break,
                };
                if last_time.is_finite() && f.time_s > last_time {
                    interval = f.time_s - last_time;
                }
                let (time_s, index) = (f.time_s + time_offset, f.index + index_offset);
                let pressure_kpa = match log {
                    Some(log) => log
                        .pressure_at(time_s + config.ramp_time_offset_s)
                        .unwrap_or(f64::NAN),
                    None => entry.pressure_kpa,
                };
                let mut m = if log.is_some() && pressure_kpa.is_nan() {
                    outside_log += 1;
                    frame::FrameMeasurement::rejected(0, FrameStatus::OutsidePressureLog)
                } else {
                    match &maps {
                        Some(maps) => {
                            match overlay::undistort_pixels(&undistorter, maps, &f.pixels) {
                                Ok(flat) => measure_frame(
                                    &flat,
                                    None,
                                    &Geometry::Plane {
                                        undistorter: None,
                                        mm_per_px,
                                        plane_from_px,
                                    },
                                    &config.detect,
                                    &frame::MarkerLayout {
                                        expected: config.expected_markers,
                                        roi: config.roi.as_deref(),
                                        segments: &segments,
                                    },
                                    &mut tracker,
                                ),
                                Err(e) => {
                                    result.problems.push(format!("{file}: {e}"));
                                    break;
                                }
                            }
                        }
                        None => frame::measure_pixels(
                            &f.pixels,
                            None,
                            &Geometry::Plane {
                                undistorter: Some(&undistorter),
                                mm_per_px,
                                plane_from_px,
                            },
                            config,
                            &segments,
                            &mut tracker,
                        ),
                    }
                };
                if maps.is_some() {
                    raw_marker_centroids(&undistorter, &mut m);
                }
                if m.status.is_ok() && overlay_pending {
                    overlay_pending = false;
                    match overlay::write_video_overlay(
                        out,
                        &entry.file,
                        &f.pixels,
                        &self.calib,
                        config,
                        &m,
                    ) {
                        Ok(rel) => result.outputs.push(rel),
                        Err(e) => {
                            result.storage_full |= crate::io::is_storage_full(&e);
                            result.problems.push(format!(
                                "overlay not written: {e}: check that overlays/ in the output folder is a writable folder (a rerun makes it)"
                            ));
                            // Named all the same: the cache entry stays stale until the
                            // overlay exists, so a rerun makes it.
                            result.outputs.push(overlay::overlay_rel_path(&entry.file));
                        }
                    }
                }
                result
                    .frames
                    .push(frame_record(&entry.file, index, time_s, pressure_kpa, m));
                done += 1;
                progress.frames(done, expected.max(done));
                last_time = f.time_s;
                last_index = f.index;
                source.recycle(f.pixels);
            }
            result.problems.extend(source.finish());
            if last_time.is_finite() {
                time_offset += last_time + interval;
                index_offset += last_index + 1;
            }
        }
        if outside_log > 0 {
            result.problems.push(format!(
            "{outside_log} of {} frames fall outside the pressure log's time span: check that the log covers the recording and ramp_time_offset_s",
            result.frames.len()
        ));
        }
        if let ChainStart::Near(p) = tracker.start {
            result.clamp_marker_px = Some((p.x, p.y));
        }
        result
    }
}
