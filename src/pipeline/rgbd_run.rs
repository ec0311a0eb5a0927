//! An RGB-D session (colour + depth PNG folders, or a RealSense .bag): its frames
//! measured on the depth plane, each at the pressure the log gives for its time.

use std::path::Path;

use crate::detect::ChainStart;
use crate::rgbd::bag::BagRecording;
use crate::rgbd::{list_frames, RgbdFrames};
use crate::session::{PressureLog, SessionConfig};

use super::error::PipelineError;
use super::frame::{self, Geometry, Tracker};
use super::item::{frame_record, ItemResult};
use super::records::{FrameRecord, FrameStatus};
use super::run::Notes;
use super::source::{BagSource, FrameSource, Next, RgbdSource};

/// An RGB-D session's frames as a source: the PNG folders or the bag recording.
struct RgbdInput {
    /// Item name (`color`, or the bag's file name).
    item: String,
    intrinsics: crate::rgbd::RgbdIntrinsics,
    total: usize,
    timing: String,
    source: Box<dyn FrameSource>,
}

fn open_rgbd(
    session: &Path,
    frames: &RgbdFrames,
    notes: &mut Notes,
) -> Result<RgbdInput, PipelineError> {
    Ok(match frames {
        RgbdFrames::PngFolders => {
            let listing = list_frames(session)?;
            for d in &listing.orphan_depth {
                notes.push(format!(
                    "warning: {d}: no colour frame of the same name: ignored"
                ));
            }
            let intr = listing.intrinsics;
            RgbdInput {
                item: "color".into(),
                total: listing.frames.len(),
                timing: listing.timing,
                source: Box::new(RgbdSource::new(listing.frames, (intr.width, intr.height))),
                intrinsics: intr,
            }
        }
        RgbdFrames::Bag(path) => {
            let rec = BagRecording::open(path)?;
            for n in &rec.notes {
                notes.push(format!("warning: {n}"));
            }
            RgbdInput {
                item: rec.name(),
                intrinsics: rec.intrinsics.clone(),
                total: rec.frames.len(),
                timing: rec.timing.clone(),
                source: Box::new(BagSource::new(rec)),
            }
        }
    })
}

/// Measures the frames of an RGB-D session (one item named `color`, or after the bag).
pub(super) fn measure_rgbd(
    session: &Path,
    frames: &RgbdFrames,
    config: &SessionConfig,
    log: &PressureLog,
    notes: &mut Notes,
) -> Result<ItemResult, PipelineError> {
    let RgbdInput {
        item,
        intrinsics,
        total,
        timing,
        mut source,
    } = open_rgbd(session, frames, notes)?;
    let intr = &intrinsics;
    let undistorter = crate::rgbd::undistorter(intr)?;
    let geometry = Geometry::Depth {
        undistorter: &undistorter,
        intrinsics: intr,
    };
    let mut tracker = Tracker::new(ChainStart::Side(config.detect.clamp_side));
    let segments = config.segment_plan();
    let mut result = ItemResult {
        file: item.clone(),
        pressure_kpa: f64::NAN,
        pressure: f64::NAN,
        frames: Vec::with_capacity(total),
        problems: vec![],
        clamp_marker_px: None,
        outputs: vec![],
        from_cache: false,
        storage_full: false,
    };
    let (mut bad, mut outside_log) = (Vec::new(), 0usize);
    notes.progress.start("RGB-D frames", total as u64);
    loop {
        let next = source.next();
        notes.progress.advance(1);
        let (index, time_s) = match &next {
            Next::Frame(f) => (f.index, f.time_s),
            Next::Bad { index, time_s, .. } => (*index, *time_s),
            Next::End => break,
        };
        let pressure_kpa = log
            .pressure_at(time_s + config.ramp_time_offset_s)
            .unwrap_or(f64::NAN);
        let record =
            |status: FrameStatus| FrameRecord::rejected(&item, index, time_s, pressure_kpa, status);
        let row = match next {
            Next::Bad { why, .. } => {
                bad.push(why.clone());
                record(FrameStatus::BadFrame { why })
            }
            Next::Frame(_) if pressure_kpa.is_nan() => {
                outside_log += 1;
                record(FrameStatus::OutsidePressureLog)
            }
            Next::Frame(f) => {
                let m = frame::measure_pixels(
                    &f.pixels,
                    f.depth.as_ref(),
                    &geometry,
                    config,
                    &segments,
                    &mut tracker,
                );
                frame_record(&item, index, time_s, pressure_kpa, m)
            }
            Next::End => break,
        };
        result.frames.push(row);
    }
    notes.progress.finish();
    if let Some(first) = bad.first() {
        result.problems.push(if bad.len() == 1 {
            first.clone()
        } else {
            format!("{} unusable frames, e.g. {first}", bad.len())
        });
    }
    if outside_log > 0 {
        result.problems.push(format!(
            "{outside_log} of {total} frames fall outside the pressure log's time span ({}): check that the log covers the recording and ramp_time_offset_s",
            timing
        ));
    }
    Ok(result)
}
