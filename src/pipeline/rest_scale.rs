//! The scale from the markers themselves (`[scale_markers]`): in the session's 0 kPa
//! item the actuator is at rest, so the distance between consecutive markers in
//! undistorted px (each pair's median over the measured frames) against their known rest
//! spacing gives mm per px, with no board.

use std::path::{Path, PathBuf};

use crate::calib::{Calibration, UndistortSettings, Undistorter};
use crate::detect::ChainStart;
use crate::session::{ManifestEntry, SessionConfig, CONFIG};
use crate::video::FrameSelection;

use super::error::PipelineError;
use super::frame::{measure_pixels, Geometry, Tracker};
use super::source::{open_source, Next};

/// The rest item's scale and how it was measured.
#[derive(Debug, Clone, PartialEq)]
pub struct RestScale {
    /// mm per undistorted px at `width`.
    pub mm_per_px: f64,
    /// Frame width of the rest item, px.
    pub width: u32,
    /// The rest item (video or photo).
    pub file: PathBuf,
    /// Frames whose markers were measured.
    pub frames_used: usize,
    /// Each consecutive pair's median distance, undistorted px.
    pub spacing_px: Vec<f64>,
    /// Relative standard deviation of the pairs' mm per px (markers not evenly in one
    /// plane, a spacing mistyped, an actuator not straight).
    pub spread: f64,
}

/// The session's rest item: its first 0 kPa entry; the error says to add one or use a
/// board.
pub fn rest_entry<'a>(
    session: &Path,
    entries: &'a [ManifestEntry],
) -> Result<&'a ManifestEntry, PipelineError> {
    entries
        .iter()
        .find(|e| e.pressure_kpa == 0.0)
        .ok_or_else(|| PipelineError::Layout {
            path: session.join(crate::session::MANIFEST),
            why: format!(
                "[scale_markers] in {CONFIG} measures the scale on the markers at rest, and no item is at 0 kPa: add a video (or photo) of the actuator at 0 pressure, or use a scale board (scale.jpg) instead"
            ),
        })
}

/// Median of `v` (not empty).
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// mm per px from the markers of `entry` (all its chapters; the frames `frames` picks)
/// and the spacing of `[scale_markers]`.
pub fn scale_from_rest(
    session: &Path,
    entry: &ManifestEntry,
    config: &SessionConfig,
    calib: &Calibration,
    frames: FrameSelection,
) -> Result<RestScale, PipelineError> {
    let Some(markers) = &config.scale_markers else {
        return Err(PipelineError::Layout {
            path: session.join(CONFIG),
            why: "no [scale_markers] spacing_mm: set it, or use a scale board".into(),
        });
    };
    let spacing = markers.spacing_mm.distances(config.expected_markers);
    let path = session.join(&entry.file);
    let bad = |why: String| PipelineError::Layout {
        path: path.clone(),
        why,
    };
    let segments = config.segment_plan();
    let mut tracker = Tracker::new(ChainStart::Side(config.detect.clamp_side));
    let mut pairs: Vec<Vec<f64>> = vec![vec![]; spacing.len()];
    let (mut seen, mut width) = (0usize, 0u32);
    for file in std::iter::once(&entry.file).chain(&entry.chapters) {
        let mut source = open_source(&session.join(file), frames, false).map_err(&bad)?;
        let (w, h) = source.size();
        if width != 0 && w != width {
            return Err(bad(format!(
                "its chapters are {width} and {w} px wide: the rest item's frames must be of one size"
            )));
        }
        width = w;
        let und = calib
            .for_resolution(w, h)
            .and_then(|c| Undistorter::new(&c, UndistortSettings::default()))?;
        let geometry = Geometry::Plane {
            undistorter: Some(&und),
            mm_per_px: 1.0,
            plane_from_px: None,
        };
        loop {
            let f = match source.next() {
                Next::Frame(f) => f,
                Next::Bad { .. } => {
                    seen += 1;
                    continue;
                }
                Next::End => break,
            };
            seen += 1;
            let m = measure_pixels(&f.pixels, None, &geometry, config, &segments, &mut tracker);
            if m.status.is_ok() && m.markers_px.len() == spacing.len() + 1 {
                for (k, w) in m.markers_px.windows(2).enumerate() {
                    pairs[k].push((w[1] - w[0]).norm());
                }
            }
            source.recycle(f.pixels);
        }
        let _ = source.finish();
    }
    let frames_used = pairs.first().map_or(0, Vec::len);
    if frames_used == 0 {
        return Err(bad(format!(
            "the scale from the markers at rest ([scale_markers]): none of its {seen} frames shows the {} markers: check the detection settings, or use a scale board",
            config.expected_markers
        )));
    }
    let spacing_px: Vec<f64> = pairs.into_iter().map(median).collect();
    let mm_per_px = spacing.iter().sum::<f64>() / spacing_px.iter().sum::<f64>();
    let ratios: Vec<f64> = spacing
        .iter()
        .zip(&spacing_px)
        .map(|(mm, px)| mm / px / mm_per_px)
        .collect();
    let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
    let spread =
        (ratios.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / ratios.len() as f64).sqrt();
    if !(mm_per_px.is_finite() && mm_per_px > 0.0) {
        return Err(bad(
            "the markers at rest give no finite scale: check the frames and [scale_markers]".into(),
        ));
    }
    Ok(RestScale {
        mm_per_px,
        width,
        file: path.clone(),
        frames_used,
        spacing_px,
        spread,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rest_item_is_the_first_at_zero_and_its_absence_is_one_line() {
        let entry = |file: &str, p: f64| ManifestEntry {
            line: 0,
            file: file.into(),
            chapters: vec![],
            pressure: p,
            pressure_kpa: p,
        };
        let s = Path::new("s");
        let e = [
            entry("a.MP4", 20.0),
            entry("b.MP4", 0.0),
            entry("c.MP4", 0.0),
        ];
        assert_eq!(rest_entry(s, &e).unwrap().file, "b.MP4");
        let msg = rest_entry(s, &e[..1]).unwrap_err().to_string();
        assert!(
            msg.starts_with("s/pressures.csv: [scale_markers] in bendscope.toml measures the scale on the markers at rest, and no item is at 0 kPa: add a video"),
            "{msg}"
        );
        assert!(!msg.contains('\n'));
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
    }
}
