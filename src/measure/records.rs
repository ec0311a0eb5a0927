//! What a measurement produces: one [`FrameRecord`] per frame, one [`VideoRecord`] per
//! video (or per pressure bin of a ramp), each with a typed status whose `Display` is
//! the text written to the CSVs.

use std::fmt;

use serde::{Deserialize, Serialize};

/// Why a frame was not measured (or that it was).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum FrameStatus {
    /// Measured.
    Ok,
    /// Not the expected number of markers.
    MarkerCount {
        /// Red blobs kept after the size filter.
        found: usize,
        /// Markers expected (`expected_markers`).
        expected: usize,
        /// Blobs dropped as specks.
        specks: usize,
        /// Blobs dropped as too large.
        too_large: usize,
        /// Blobs of the marker colour left out because they lie outside the `roi`.
        #[serde(default)]
        outside_roi: usize,
    },
    /// More red blobs than markers, and no subset looks like the actuator's marker line.
    NoMarkerChain {
        /// Why (from the selection).
        why: String,
    },
    /// A marker lies outside the field where the calibration is valid.
    OutsideCalibratedField,
    /// The frame's time is outside the pressure log.
    OutsidePressureLog,
    /// Too few valid depth pixels on the actuator around the markers (RGB-D).
    NoDepth {
        /// Valid depth pixels found in the band along the marker chain.
        valid_px: usize,
    },
    /// The frame (or its depth frame) could not be used as read.
    BadFrame {
        /// What is wrong and what to do.
        why: String,
    },
    /// Undistortion or the circle fit failed.
    FitFailed {
        /// The cause.
        why: String,
    },
}

impl FrameStatus {
    /// True when the frame was measured.
    pub fn is_ok(&self) -> bool {
        matches!(self, FrameStatus::Ok)
    }
}

impl fmt::Display for FrameStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameStatus::Ok => write!(f, "ok"),
            FrameStatus::MarkerCount {
                found,
                expected,
                specks,
                too_large,
                outside_roi,
            } => {
                write!(f, "{found} markers found, {expected} expected")?;
                if specks + too_large > 0 {
                    write!(f, " ({specks} specks, {too_large} too large dropped)")?;
                }
                if *outside_roi > 0 {
                    write!(f, " ({outside_roi} outside the roi)")?;
                }
                Ok(())
            }
            FrameStatus::OutsideCalibratedField => write!(f, "outside calibrated field"),
            FrameStatus::OutsidePressureLog => write!(
                f,
                "outside the pressure log's time span (check ramp_time_offset_s in {})",
                crate::session::CONFIG
            ),
            FrameStatus::NoDepth { valid_px } => write!(
                f,
                "too few depth pixels on the actuator ({valid_px}): check the depth stream and its alignment to colour"
            ),
            FrameStatus::BadFrame { why }
            | FrameStatus::FitFailed { why }
            | FrameStatus::NoMarkerChain { why } => write!(f, "{why}"),
        }
    }
}

/// The serde helper for non-finite `f64`s, where it was first written ([`crate::io`]
/// holds it now, below every module that serialises records).
pub(crate) use crate::io::non_finite;

/// One measured marker of a frame, as the frame's measurement placed it (before the
/// session's axes of `markers.csv`, [`crate::pipeline::markers`], are applied).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MarkerPoint {
    /// Centroid in the raw (distorted) frame, px.
    pub x_px: f64,
    /// Centroid in the raw frame, px (y down).
    pub y_px: f64,
    /// Position in the actuator plane, mm: the scale board's plane (homography, or
    /// undistorted px times mm per px); RGB-D: the camera's X, mm.
    pub x_mm: f64,
    /// Second plane coordinate, mm (RGB-D: the camera's Y).
    pub y_mm: f64,
    /// RGB-D: the camera's Z (depth along the optical axis), mm; NaN for a plane.
    #[serde(with = "non_finite")]
    pub z_mm: f64,
}

/// One row of `per_frame.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameRecord {
    /// Video (or RGB-D colour frame) the frame belongs to.
    pub file: String,
    /// Frame index (continuous over a GoPro recording's chapters; the number in an
    /// RGB-D frame's name).
    pub frame: u64,
    /// Time, s (stream timestamps; chapters continue the previous chapter's clock).
    #[serde(with = "non_finite")]
    pub time_s: f64,
    /// Pressure, kPa.
    #[serde(with = "non_finite")]
    pub pressure_kpa: f64,
    /// Markers used (or red blobs found, when too few).
    pub n_markers: usize,
    /// Red blobs found besides the markers (not used).
    pub n_ignored: usize,
    /// Of those, the ones that continue the marker chain like more markers (not in
    /// per_frame.csv; kept in the cache so that a cached video warns too).
    #[serde(default)]
    pub n_continuing: usize,
    /// Radius, undistorted px (NaN for RGB-D, where the circle is fitted in mm).
    #[serde(with = "non_finite")]
    pub radius_px: f64,
    /// Radius, mm.
    #[serde(with = "non_finite")]
    pub radius_mm: f64,
    /// Curvature, 1/m.
    #[serde(with = "non_finite")]
    pub curvature_per_m: f64,
    /// Bending angle, degrees (half-angle convention).
    #[serde(with = "non_finite")]
    pub bending_angle_deg: f64,
    /// RMS residual of the circle fit (px, or mm for RGB-D).
    #[serde(with = "non_finite")]
    pub fit_rms: f64,
    /// Outcome.
    pub status: FrameStatus,
    /// The measured markers from the clamped end (empty when rejected): the rows of
    /// `markers.csv`.
    #[serde(default)]
    pub markers: Vec<MarkerPoint>,
    /// Segmented actuators: each segment's circle (empty without segments or when
    /// rejected).
    #[serde(default)]
    pub segments: Vec<crate::segments::SegmentFit>,
    /// Tip marker's x in the session's axes of markers.csv, mm (NaN until the session's
    /// axes are known: set after every item is measured, never cached).
    #[serde(skip, default = "nan")]
    pub tip_x_mm: f64,
    /// Tip marker's y in the session's axes, mm.
    #[serde(skip, default = "nan")]
    pub tip_y_mm: f64,
    /// Tip angle in the session's axes, degrees ([`crate::pipeline::markers`]).
    #[serde(skip, default = "nan")]
    pub tip_angle_deg: f64,
    /// With `smooth_s` (ramp and RGB-D): the radius of the smoothed marker tracks, mm
    /// ([`crate::pipeline::smooth`]; set after the recording is measured, never cached).
    #[serde(skip, default = "nan")]
    pub radius_mm_smooth: f64,
    /// With `smooth_s`: curvature of the smoothed tracks, 1/m.
    #[serde(skip, default = "nan")]
    pub curvature_per_m_smooth: f64,
    /// With `smooth_s`: bending angle of the smoothed tracks, degrees.
    #[serde(skip, default = "nan")]
    pub bending_angle_deg_smooth: f64,
}

/// NaN, the default of values not in the cache.
fn nan() -> f64 {
    f64::NAN
}

impl FrameRecord {
    /// A frame that was not measured.
    pub fn rejected(
        file: &str,
        frame: u64,
        time_s: f64,
        pressure_kpa: f64,
        status: FrameStatus,
    ) -> Self {
        Self {
            file: file.to_string(),
            frame,
            time_s,
            pressure_kpa,
            n_markers: 0,
            n_ignored: 0,
            n_continuing: 0,
            radius_px: f64::NAN,
            radius_mm: f64::NAN,
            curvature_per_m: f64::NAN,
            bending_angle_deg: f64::NAN,
            fit_rms: f64::NAN,
            status,
            markers: vec![],
            segments: vec![],
            tip_x_mm: f64::NAN,
            tip_y_mm: f64::NAN,
            tip_angle_deg: f64::NAN,
            radius_mm_smooth: f64::NAN,
            curvature_per_m_smooth: f64::NAN,
            bending_angle_deg_smooth: f64::NAN,
        }
    }
}

/// Outcome of a video (or of a manifest row that could not be used).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum VideoStatus {
    /// Every decoded frame was read without trouble (some may be rejected).
    Ok,
    /// Measured, with problems worth knowing (corrupt packets, truncation, an overlay
    /// that could not be written).
    Partial {
        /// The problems, each naming its file.
        problems: Vec<String>,
    },
    /// Nothing measured.
    Failed {
        /// Why, and what to do.
        why: String,
    },
    /// A manifest row or file that was not processed.
    Skipped {
        /// Why, and what to do.
        why: String,
    },
}

impl VideoStatus {
    /// True when the video has measured frames (ok or partial).
    pub fn is_measured(&self) -> bool {
        matches!(self, VideoStatus::Ok | VideoStatus::Partial { .. })
    }
}

impl fmt::Display for VideoStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            VideoStatus::Ok => write!(f, "ok"),
            VideoStatus::Partial { problems } => write!(f, "partial: {}", problems.join("; ")),
            VideoStatus::Failed { why } => write!(f, "no frame measured: {why}"),
            VideoStatus::Skipped { why } => write!(f, "{why}"),
        }
    }
}

/// One row of `per_video.csv`: a video of the step protocol, or a pressure bin of a ramp.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VideoRecord {
    /// Video file (the first chapter's name for a GoPro recording).
    pub file: String,
    /// Pressure, kPa (the bin's mean for a ramp).
    pub pressure_kpa: f64,
    /// Pressure in the manifest's (or log's) unit.
    pub pressure: f64,
    /// Statistics of the measured frames.
    pub stats: super::stats::FrameStats,
    /// Outcome.
    pub status: VideoStatus,
}

impl VideoRecord {
    /// A manifest row or file that was not processed.
    pub fn skipped(file: &str, why: String) -> Self {
        Self {
            file: file.to_string(),
            pressure_kpa: f64::NAN,
            pressure: f64::NAN,
            stats: super::stats::FrameStats::empty(0),
            status: VideoStatus::Skipped { why },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_text_is_what_the_csv_shows() {
        let s = FrameStatus::MarkerCount {
            found: 9,
            expected: 8,
            specks: 0,
            too_large: 0,
            outside_roi: 0,
        };
        assert_eq!(s.to_string(), "9 markers found, 8 expected");
        let s = FrameStatus::MarkerCount {
            found: 7,
            expected: 8,
            specks: 2,
            too_large: 1,
            outside_roi: 0,
        };
        assert_eq!(
            s.to_string(),
            "7 markers found, 8 expected (2 specks, 1 too large dropped)"
        );
        let s = FrameStatus::MarkerCount {
            found: 0,
            expected: 8,
            specks: 0,
            too_large: 0,
            outside_roi: 8,
        };
        assert_eq!(
            s.to_string(),
            "0 markers found, 8 expected (8 outside the roi)"
        );
        assert_eq!(FrameStatus::Ok.to_string(), "ok");
        assert_eq!(
            VideoStatus::Partial {
                problems: vec!["a".into(), "b".into()]
            }
            .to_string(),
            "partial: a; b"
        );
        assert_eq!(
            VideoStatus::Failed { why: "x".into() }.to_string(),
            "no frame measured: x"
        );
    }

    #[test]
    fn statuses_survive_the_cache() {
        for s in [
            FrameStatus::Ok,
            FrameStatus::NoDepth { valid_px: 3 },
            FrameStatus::BadFrame { why: "w".into() },
        ] {
            let j = serde_json::to_string(&s).unwrap();
            assert_eq!(serde_json::from_str::<FrameStatus>(&j).unwrap(), s);
        }
    }

    #[test]
    fn a_rejected_frame_survives_the_cache() {
        let mut r = FrameRecord::rejected("a.mp4", 3, 0.1, 20.0, FrameStatus::OutsidePressureLog);
        r.radius_px = f64::INFINITY;
        r.curvature_per_m = f64::NEG_INFINITY;
        let j = serde_json::to_string(&r).unwrap();
        let back: FrameRecord = serde_json::from_str(&j).unwrap();
        let bits = |r: &FrameRecord| {
            [
                r.time_s,
                r.pressure_kpa,
                r.radius_px,
                r.radius_mm,
                r.curvature_per_m,
                r.bending_angle_deg,
                r.fit_rms,
            ]
            .map(|v| if v.is_nan() { u64::MAX } else { v.to_bits() })
        };
        assert_eq!(bits(&back), bits(&r), "{j}");
        assert_eq!(back.status, r.status);
    }
}
