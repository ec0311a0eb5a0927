//! Sessions: a folder of videos with a pressure manifest, measured video by video and
//! aggregated.
//!
//! ```text
//! SESSION/
//!   pressures.csv   header `file,pressure_bar` (or pressure_kpa / pressure_psi)
//!   *.MP4 ...       one video per pressure (GoPro chapters GX02xxxx continue GX01xxxx)
//!   scale.jpg       a board lying in the actuator plane (any image format)
//!   calib/          checkerboard photos, used when no calibration is given
//!   bendscope.toml  optional settings ([`SessionConfig`])
//! ```
//!
//! Per frame ([`measure_frame`]; any [`crate::detect::PixelSource`]: RGB images, or
//! decoded YUV frames read without a full-frame colour conversion): red markers are
//! detected in the raw frame, their
//! centroids undistorted (detecting in the raw frame and undistorting 8 points is far
//! cheaper than undistorting every frame, and gives the same points: see the
//! `undistort` tests), ordered from the clamped end, and fitted with a Pratt circle.
//! Frames with another marker count than expected are rejected with the reason.

use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

use nalgebra::Point2;
use serde::{Deserialize, Serialize};

use crate::calib::{CalibError, Undistorter};
use crate::detect::{detect_markers_with, order_markers, ChainStart, DetectSettings};
use crate::fit::{bending_angle_from_circle_deg, fit_circle_pratt};

/// Name of the manifest file in a session folder.
pub const MANIFEST: &str = "pressures.csv";
/// Name of the pressure log of a ramp session (instead of the manifest).
pub const PRESSURE_LOG: &str = "pressure_log.csv";
/// Name of the optional settings file in a session folder.
pub const CONFIG: &str = "bendscope.toml";
/// Video file extensions (case-insensitive).
pub const VIDEO_EXTENSIONS: &[&str] = &["mp4", "mov", "m4v", "mkv", "avi", "webm"];
/// Image extensions accepted for the scale photo.
pub const IMAGE_EXTENSIONS: &[&str] = &["jpg", "jpeg", "png", "bmp", "tif", "tiff"];
/// kPa per bar.
pub const KPA_PER_BAR: f64 = 100.0;
/// kPa per psi.
pub const KPA_PER_PSI: f64 = 6.894_757;

/// Errors that stop a whole session.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The session folder is missing or empty.
    #[error("{path}: {why}")]
    Folder {
        /// The folder.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
    /// The manifest cannot be used at all.
    #[error("{path}: {why}")]
    Manifest {
        /// The manifest.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
    /// The settings file is wrong.
    #[error("{path}: {why}")]
    Config {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        why: String,
    },
    /// Calibration problem.
    #[error(transparent)]
    Calib(#[from] CalibError),
}

/// Pressure unit of a manifest column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PressureUnit {
    /// bar.
    Bar,
    /// kPa.
    Kpa,
    /// psi.
    Psi,
}

impl PressureUnit {
    /// kPa per unit.
    pub fn to_kpa(&self) -> f64 {
        match self {
            PressureUnit::Bar => KPA_PER_BAR,
            PressureUnit::Kpa => 1.0,
            PressureUnit::Psi => KPA_PER_PSI,
        }
    }
    /// Name as in the header.
    pub fn name(&self) -> &'static str {
        match self {
            PressureUnit::Bar => "bar",
            PressureUnit::Kpa => "kpa",
            PressureUnit::Psi => "psi",
        }
    }
}

/// One usable manifest row.
#[derive(Debug, Clone, PartialEq)]
pub struct ManifestEntry {
    /// 1-based line number in the manifest.
    pub line: usize,
    /// Video file name, relative to the session.
    pub file: String,
    /// Further chapter files of the same GoPro recording, in order.
    pub chapters: Vec<String>,
    /// Pressure in the manifest's unit.
    pub pressure: f64,
    /// Pressure, kPa.
    pub pressure_kpa: f64,
}

/// A problem with one row or file of a session (the rest goes on).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SessionIssue {
    /// File concerned.
    pub file: String,
    /// Manifest line, when it comes from one.
    pub line: Option<usize>,
    /// What is wrong and what to do.
    pub message: String,
}

/// A parsed manifest.
#[derive(Debug, Clone, PartialEq)]
pub struct Manifest {
    /// Unit of the pressure column.
    pub unit: PressureUnit,
    /// Usable rows, in manifest order.
    pub entries: Vec<ManifestEntry>,
    /// Rows and files that cannot be used.
    pub issues: Vec<SessionIssue>,
}

fn has_extension(path: &Path, exts: &[&str]) -> bool {
    path.extension()
        .map(|e| exts.contains(&e.to_string_lossy().to_ascii_lowercase().as_str()))
        .unwrap_or(false)
}

/// GoPro naming: `GX` or `GH` (or `GL`), two chapter digits, four recording digits.
/// Returns (prefix letters, chapter, recording).
pub fn gopro_parts(name: &str) -> Option<(String, u32, String)> {
    let stem = Path::new(name)
        .file_stem()?
        .to_string_lossy()
        .to_ascii_uppercase();
    let b = stem.as_bytes();
    if b.len() != 8
        || b[0] != b'G'
        || !b[1].is_ascii_alphabetic()
        || !b[2..].iter().all(u8::is_ascii_digit)
    {
        return None;
    }
    let chapter: u32 = stem[2..4].parse().ok()?;
    Some((stem[..2].to_string(), chapter, stem[4..].to_string()))
}

/// Reads `SESSION/pressures.csv`, checks every row against the folder, groups GoPro
/// chapters and lists videos that are not in the manifest.
pub fn read_manifest(session: &Path) -> Result<Manifest, SessionError> {
    let path = session.join(MANIFEST);
    if !session.is_dir() {
        return Err(SessionError::Folder {
            path: session.to_path_buf(),
            why: "no such session folder".into(),
        });
    }
    let text = std::fs::read_to_string(&path).map_err(|e| SessionError::Manifest {
        path: path.clone(),
        why: format!("{e}: write a {MANIFEST} with the header `file,pressure_bar` (or pressure_kpa, pressure_psi) and one row per video"),
    })?;
    let mut lines = without_bom(&text)
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or_else(|| SessionError::Manifest {
        path: path.clone(),
        why: "empty manifest: add the header `file,pressure_bar` and one row per video".into(),
    })?;
    let cols: Vec<String> = split_csv(header)
        .iter()
        .map(|c| c.to_ascii_lowercase())
        .collect();
    let file_col = cols
        .iter()
        .position(|c| c == "file")
        .ok_or_else(|| SessionError::Manifest {
            path: path.clone(),
            why: format!("no `file` column in the header `{header}`: name the video column `file` (header `file,pressure_bar`)"),
        })?;
    let (p_col, unit) = pressure_column(&cols)
        .ok_or_else(|| SessionError::Manifest {
            path: path.clone(),
            why: format!(
                "no pressure column with a unit in the header `{header}`: name it pressure_bar, pressure_kpa or pressure_psi"
            ),
        })?;
    // Videos in the folder, by upper-case name (names that differ only in letter case,
    // possible on case-sensitive file systems, share a key).
    let mut videos: BTreeMap<String, Vec<String>> = BTreeMap::new();
    if let Ok(rd) = std::fs::read_dir(session) {
        for e in rd.flatten() {
            let p = e.path();
            if p.is_file() && has_extension(&p, VIDEO_EXTENSIONS) {
                let name = e.file_name().to_string_lossy().into_owned();
                videos
                    .entry(name.to_ascii_uppercase())
                    .or_default()
                    .push(name);
            }
        }
    }
    for names in videos.values_mut() {
        names.sort();
    }
    // Upper-case names given by a row, usable or not (its problem is reported there).
    let mut named: HashSet<String> = HashSet::new();
    let mut entries: Vec<ManifestEntry> = Vec::new();
    let mut issues = Vec::new();
    let mut seen: HashSet<String> = HashSet::new();
    for (i, line) in lines {
        let lineno = i + 1;
        let cells = split_csv(line);
        let file = cells.get(file_col).cloned().unwrap_or_default();
        let raw = cells.get(p_col).cloned().unwrap_or_default();
        let issue = |message: String| SessionIssue {
            file: file.clone(),
            line: Some(lineno),
            message,
        };
        if file.is_empty() {
            issues.push(issue("no file name in this row".into()));
            continue;
        }
        named.insert(file.to_ascii_uppercase());
        let pressure: f64 = match raw.parse::<f64>() {
            Ok(v) if v.is_finite() && v >= 0.0 => v,
            Ok(v) => {
                issues.push(issue(format!(
                    "pressure {v} is negative or not finite: give a pressure >= 0 in {}",
                    unit.name()
                )));
                continue;
            }
            Err(_) => {
                issues.push(issue(format!(
                    "pressure `{raw}` is not a number: give a plain number in {} (the unit is in the header)",
                    unit.name()
                )));
                continue;
            }
        };
        if !seen.insert(file.to_ascii_uppercase()) {
            issues.push(issue("listed twice: the first row is used".into()));
            continue;
        }
        let actual = match videos.get(&file.to_ascii_uppercase()).map(Vec::as_slice) {
            None | Some([]) => {
                issues.push(issue(
                    "no such video in the session folder: check the name".into(),
                ));
                continue;
            }
            Some([one]) => one.clone(),
            Some(several) => match several.iter().find(|n| **n == file) {
                Some(exact) => exact.clone(),
                None => {
                    issues.push(issue(format!(
                        "matches {}, which differ only in letter case: write the name exactly as on disk, or rename one of them",
                        several.join(" and ")
                    )));
                    continue;
                }
            },
        };
        entries.push(ManifestEntry {
            line: lineno,
            file: actual,
            chapters: vec![],
            pressure,
            pressure_kpa: pressure * unit.to_kpa(),
        });
    }
    // GoPro chapters continue the recording of chapter 01 listed in the manifest.
    let listed: HashSet<String> = entries
        .iter()
        .map(|e| e.file.to_ascii_uppercase())
        .collect();
    for e in entries.iter_mut() {
        if let Some((prefix, 1, rec)) = gopro_parts(&e.file) {
            let mut chapters: Vec<(u32, String)> = videos
                .values()
                .flatten()
                .filter_map(|v| match gopro_parts(v) {
                    Some((p, ch, r))
                        if p == prefix
                            && r == rec
                            && ch > 1
                            && !listed.contains(&v.to_ascii_uppercase()) =>
                    {
                        Some((ch, v.clone()))
                    }
                    _ => None,
                })
                .collect();
            chapters.sort();
            // One file per chapter (a name in another letter case is reported below).
            chapters.dedup_by_key(|(ch, _)| *ch);
            e.chapters = chapters.into_iter().map(|(_, c)| c).collect();
        }
    }
    let used: HashSet<&str> = entries
        .iter()
        .flat_map(|e| std::iter::once(&e.file).chain(&e.chapters))
        .map(String::as_str)
        .collect();
    for (upper, names) in &videos {
        for name in names.iter().filter(|n| !used.contains(n.as_str())) {
            let message = match names.iter().find(|n| used.contains(n.as_str())) {
                Some(twin) => format!(
                    "differs only in letter case from {twin}, which is measured: not processed (rename or remove one of them)"
                ),
                // Its row is reported.
                None if named.contains(upper) => continue,
                None => format!("not in {MANIFEST}: not processed (add a row with its pressure)"),
            };
            issues.push(SessionIssue {
                file: name.clone(),
                line: None,
                message,
            });
        }
    }
    Ok(Manifest {
        unit,
        entries,
        issues,
    })
}

/// A regulator's pressure log for the ramp protocol: (time, pressure) rows, one video.
#[derive(Debug, Clone, PartialEq)]
pub struct PressureLog {
    /// Unit of the pressure column.
    pub unit: PressureUnit,
    /// Times, s, increasing.
    pub times_s: Vec<f64>,
    /// Pressures, kPa.
    pub pressures_kpa: Vec<f64>,
}

impl PressureLog {
    /// Pressure at `t` by linear interpolation; `None` outside the logged time span.
    pub fn pressure_at(&self, t: f64) -> Option<f64> {
        let (first, last) = (*self.times_s.first()?, *self.times_s.last()?);
        if !(t >= first && t <= last) {
            return None;
        }
        let i = self
            .times_s
            .partition_point(|&x| x <= t)
            .clamp(1, self.times_s.len() - 1);
        let (t0, t1) = (self.times_s[i - 1], self.times_s[i]);
        let (p0, p1) = (self.pressures_kpa[i - 1], self.pressures_kpa[i]);
        Some(if t1 > t0 {
            p0 + (p1 - p0) * (t - t0) / (t1 - t0)
        } else {
            p1
        })
    }
}

/// Reads a pressure log: header `time_s,pressure_<unit>` (bar, kpa or psi), times
/// strictly increasing, pressures >= 0, at least two rows.
pub fn read_pressure_log(path: &Path) -> Result<PressureLog, SessionError> {
    let bad = |why: String| SessionError::Manifest {
        path: path.to_path_buf(),
        why,
    };
    let text = std::fs::read_to_string(path).map_err(|e| {
        bad(format!(
            "{e}: a pressure log is a CSV text file, `time_s,pressure_kpa` (or _bar, _psi) and one row per sample"
        ))
    })?;
    let mut lines = without_bom(&text)
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or_else(|| {
        bad("empty pressure log: write `time_s,pressure_kpa` and one row per sample".into())
    })?;
    let cols: Vec<String> = split_csv(header)
        .iter()
        .map(|c| c.to_ascii_lowercase())
        .collect();
    let t_col = cols
        .iter()
        .position(|c| c == "time_s")
        .ok_or_else(|| bad(format!("no `time_s` column in `{header}`")))?;
    let (p_col, unit) = pressure_column(&cols)
        .ok_or_else(|| bad(format!("no pressure column with a unit in `{header}`: name it pressure_bar, pressure_kpa or pressure_psi")))?;
    let mut log = PressureLog {
        unit,
        times_s: vec![],
        pressures_kpa: vec![],
    };
    for (i, line) in lines {
        let cells = split_csv(line);
        let num = |c: usize| {
            cells
                .get(c)
                .and_then(|v| v.parse::<f64>().ok())
                .filter(|v| v.is_finite())
        };
        let (Some(t), Some(p)) = (num(t_col), num(p_col)) else {
            return Err(bad(format!("line {}: `{line}` is not two numbers", i + 1)));
        };
        if p < 0.0 {
            return Err(bad(format!("line {}: negative pressure {p}", i + 1)));
        }
        if log.times_s.last().is_some_and(|&last| t <= last) {
            return Err(bad(format!(
                "line {}: time {t} s does not increase: sort the rows by time and drop repeated samples",
                i + 1
            )));
        }
        log.times_s.push(t);
        log.pressures_kpa.push(p * unit.to_kpa());
    }
    if log.times_s.len() < 2 {
        return Err(bad("a pressure log needs at least two rows".into()));
    }
    Ok(log)
}

/// The videos of a session folder, sorted by name.
pub fn session_videos(session: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(session)
        .map(|rd| {
            rd.flatten()
                .filter(|e| e.path().is_file() && has_extension(&e.path(), VIDEO_EXTENSIONS))
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// The pressure column of a header and its unit: `pressure_bar`, `pressure_kpa` or
/// `pressure_psi` (lower-cased column names).
fn pressure_column(cols: &[String]) -> Option<(usize, PressureUnit)> {
    cols.iter().enumerate().find_map(|(i, c)| match c.as_str() {
        "pressure_bar" => Some((i, PressureUnit::Bar)),
        "pressure_kpa" => Some((i, PressureUnit::Kpa)),
        "pressure_psi" => Some((i, PressureUnit::Psi)),
        _ => None,
    })
}

/// `text` without the UTF-8 byte order mark spreadsheet programs put first.
fn without_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// Splits one CSV line (commas; double quotes around a field are removed).
fn split_csv(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    for ch in line.chars() {
        match ch {
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(std::mem::take(&mut cur).trim().to_string()),
            c => cur.push(c),
        }
    }
    out.push(cur.trim().to_string());
    out
}

/// The scale board (a board lying in the actuator plane).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoardConfig {
    /// Inner corners along a row.
    pub cols: u32,
    /// Inner corners along a column.
    pub rows: u32,
    /// Square side, mm.
    pub square_mm: f64,
}

impl Default for BoardConfig {
    fn default() -> Self {
        Self {
            cols: 9,
            rows: 6,
            square_mm: 25.0,
        }
    }
}

/// Settings of a session (`bendscope.toml`); every field has a default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SessionConfig {
    /// Calibration file (relative to the session); else `calib/` is calibrated.
    pub calibration: Option<PathBuf>,
    /// Lens model used when calibrating `calib/`.
    pub model: crate::calib::CameraModel,
    /// Board of the `calib/` photos.
    pub calib_board: BoardConfig,
    /// Board of the scale photo.
    pub scale_board: BoardConfig,
    /// Scale photo (relative to the session); default: the first `scale.*` image.
    pub scale_image: Option<PathBuf>,
    /// Known mm per undistorted px (skips the scale photo).
    pub mm_per_px: Option<f64>,
    /// Expected number of markers per frame.
    pub expected_markers: usize,
    /// Process every n-th frame.
    pub frame_stride: u64,
    /// Ramp protocol: width of the pressure bins frames are averaged in, kPa (the
    /// low-pass filter of the per-frame results).
    pub ramp_bin_kpa: f64,
    /// Ramp protocol: time of the video's first frame on the pressure log's clock, s.
    pub ramp_time_offset_s: f64,
    /// Undistort every whole frame before detection (the original method; slower, for
    /// comparison) instead of undistorting only the detected centroids.
    pub full_frame_undistort: bool,
    /// Marker detection.
    pub detect: DetectSettings,
}

impl Default for SessionConfig {
    fn default() -> Self {
        Self {
            calibration: None,
            model: crate::calib::CameraModel::Fisheye,
            calib_board: BoardConfig::default(),
            scale_board: BoardConfig::default(),
            scale_image: None,
            mm_per_px: None,
            expected_markers: 8,
            frame_stride: 1,
            ramp_bin_kpa: 1.0,
            ramp_time_offset_s: 0.0,
            full_frame_undistort: false,
            detect: DetectSettings::default(),
        }
    }
}

impl SessionConfig {
    /// Reads `path` (TOML); missing fields take their defaults.
    pub fn read(path: &Path) -> Result<Self, SessionError> {
        let bad = |why: String| SessionError::Config {
            path: path.to_path_buf(),
            why,
        };
        let text = std::fs::read_to_string(path).map_err(|e| {
            bad(match e.kind() {
                std::io::ErrorKind::NotFound => "no such file: check the path".to_string(),
                std::io::ErrorKind::InvalidData => format!(
                    "not a text file: {CONFIG} holds TOML settings (`key = value` lines, see the README)"
                ),
                _ => e.to_string(),
            })
        })?;
        let c: SessionConfig =
            toml::from_str(&text).map_err(|e| bad(toml_error_line(&text, &e)))?;
        c.check(path)?;
        Ok(c)
    }

    /// Reads `SESSION/bendscope.toml` when present, else the defaults.
    pub fn for_session(session: &Path) -> Result<Self, SessionError> {
        let p = session.join(CONFIG);
        if p.is_file() {
            Self::read(&p)
        } else {
            Ok(Self::default())
        }
    }

    fn check(&self, path: &Path) -> Result<(), SessionError> {
        let bad = |why: String| {
            Err(SessionError::Config {
                path: path.to_path_buf(),
                why,
            })
        };
        if self.expected_markers < 3 {
            return bad(format!(
                "expected_markers = {}: a circle needs at least 3 markers",
                self.expected_markers
            ));
        }
        if !(self.ramp_bin_kpa.is_finite() && self.ramp_bin_kpa > 0.0)
            || !self.ramp_time_offset_s.is_finite()
        {
            return bad(
                "ramp_bin_kpa must be a positive number and ramp_time_offset_s a number".into(),
            );
        }
        if self.frame_stride == 0 {
            return bad("frame_stride must be at least 1".into());
        }
        if let Some(m) = self.mm_per_px {
            if !(m.is_finite() && m > 0.0) {
                return bad(format!("mm_per_px = {m} must be a positive number"));
            }
        }
        for (name, b) in [
            ("calib_board", &self.calib_board),
            ("scale_board", &self.scale_board),
        ] {
            if b.cols < 2 || b.rows < 2 || !(b.square_mm.is_finite() && b.square_mm > 0.0) {
                return bad(format!(
                    "{name}: cols and rows must be >= 2 and square_mm > 0"
                ));
            }
        }
        if self.detect.min_area_px > self.detect.max_area_px {
            return bad("detect: min_area_px is larger than max_area_px".into());
        }
        Ok(())
    }
}

/// A TOML error as one line naming where it is: `line N (`the line`): message`.
fn toml_error_line(text: &str, e: &toml::de::Error) -> String {
    let mut message = e.message().trim().replace('\n', " ");
    let Some(span) = e.span() else {
        return message;
    };
    let mut n = text[..span.start.min(text.len())].matches('\n').count();
    // An unknown key's error spans its whole table: point at the key itself.
    let unknown = message
        .strip_prefix("unknown field `")
        .and_then(|rest| rest.split('`').next())
        .map(str::to_string);
    if let Some(key) = unknown {
        let is_key = |l: &str| {
            l.trim_start()
                .strip_prefix(key.as_str())
                .is_some_and(|rest| rest.trim_start().starts_with('='))
        };
        if let Some(k) = text.lines().skip(n).position(is_key) {
            n += k;
        }
        message.push_str(": check its spelling (the keys are listed in the README)");
    }
    let line = text.lines().nth(n).unwrap_or("").trim();
    format!("line {} (`{line}`): {message}", n + 1)
}

/// The scale photo of a session: the configured one, or the first `scale.*` image.
pub fn find_scale_image(session: &Path, config: &SessionConfig) -> Option<PathBuf> {
    if let Some(p) = &config.scale_image {
        return Some(session.join(p));
    }
    let mut found: Vec<PathBuf> = std::fs::read_dir(session)
        .ok()?
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.is_file()
                && has_extension(p, IMAGE_EXTENSIONS)
                && p.file_stem()
                    .map(|s| s.to_string_lossy().eq_ignore_ascii_case("scale"))
                    .unwrap_or(false)
        })
        .collect();
    found.sort();
    found.into_iter().next()
}

/// Status of a frame.
#[derive(Debug, Clone, PartialEq)]
pub enum FrameStatus {
    /// Measured.
    Ok,
    /// Rejected, with the reason.
    Rejected(String),
}

impl FrameStatus {
    /// Text for the CSV.
    pub fn text(&self) -> String {
        match self {
            FrameStatus::Ok => "ok".into(),
            FrameStatus::Rejected(r) => r.clone(),
        }
    }
}

/// One frame's measurement (lengths in undistorted px; mm via the scale).
#[derive(Debug, Clone, PartialEq)]
pub struct FrameMeasurement {
    /// Markers found.
    pub n_markers: usize,
    /// Undistorted, ordered marker centroids (empty when rejected).
    pub markers_px: Vec<Point2<f64>>,
    /// Pratt radius, px (infinite for collinear markers; NaN when rejected).
    pub radius_px: f64,
    /// 1 / radius, 1/px.
    pub curvature_per_px: f64,
    /// Bending angle, degrees (tangent at the clamped-end marker to the tip chord,
    /// half-angle convention).
    pub bending_angle_deg: f64,
    /// RMS residual of the circle fit, px.
    pub fit_rms_px: f64,
    /// Centre of the fitted circle, undistorted px.
    pub center_px: Point2<f64>,
    /// Outcome.
    pub status: FrameStatus,
}

impl FrameMeasurement {
    fn rejected(n: usize, why: String) -> Self {
        Self {
            n_markers: n,
            markers_px: vec![],
            radius_px: f64::NAN,
            curvature_per_px: f64::NAN,
            bending_angle_deg: f64::NAN,
            fit_rms_px: f64::NAN,
            center_px: Point2::new(f64::NAN, f64::NAN),
            status: FrameStatus::Rejected(why),
        }
    }
}

/// Measures one RGB frame: detect, check the count, undistort the centroids, order,
/// fit. `undistorter` is `None` when the frame itself was already undistorted.
pub fn measure_frame(
    frame: &image::RgbImage,
    undistorter: Option<&Undistorter>,
    detect: &DetectSettings,
    expected_markers: usize,
    start: ChainStart,
) -> FrameMeasurement {
    measure_frame_with(
        frame,
        undistorter,
        detect,
        expected_markers,
        start,
        &mut image::GrayImage::new(0, 0),
    )
}

/// [`measure_frame`] with a mask buffer reused from frame to frame.
pub fn measure_frame_with<S: crate::detect::PixelSource>(
    frame: &S,
    undistorter: Option<&Undistorter>,
    detect: &DetectSettings,
    expected_markers: usize,
    start: ChainStart,
    mask: &mut image::GrayImage,
) -> FrameMeasurement {
    let d = detect_markers_with(frame, detect, mask);
    let n = d.blobs.len();
    if n != expected_markers {
        let mut why = format!("{n} markers found, {expected_markers} expected");
        if d.specks + d.too_large > 0 {
            why.push_str(&format!(
                " ({} specks, {} too large dropped)",
                d.specks, d.too_large
            ));
        }
        return FrameMeasurement::rejected(n, why);
    }
    let raw: Vec<Point2<f64>> = d.blobs.iter().map(|b| b.centroid).collect();
    let flat = match undistorter.map(|u| u.undistort_points(&raw)) {
        Some(Ok(p)) => p,
        Some(Err(e)) => return FrameMeasurement::rejected(n, format!("undistortion failed: {e}")),
        None => raw,
    };
    // Track the clamped end in undistorted space when given as a point.
    let ordered = order_markers(&flat, start);
    let circle = match fit_circle_pratt(&ordered) {
        Ok(c) => c,
        Err(e) => return FrameMeasurement::rejected(n, e.to_string()),
    };
    let angle = match (ordered.first(), ordered.last()) {
        (Some(o), Some(a)) => bending_angle_from_circle_deg(*o, *a, &circle).unwrap_or(f64::NAN),
        _ => f64::NAN,
    };
    FrameMeasurement {
        n_markers: n,
        markers_px: ordered,
        radius_px: circle.radius,
        curvature_per_px: circle.curvature,
        bending_angle_deg: angle,
        fit_rms_px: circle.rms,
        center_px: circle.center,
        status: FrameStatus::Ok,
    }
}

/// Summary of a video's frames.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct VideoSummary {
    /// Mean radius over used frames, mm (the published method).
    pub radius_mm: f64,
    /// Median radius, mm.
    pub radius_mm_median: f64,
    /// Standard deviation of the radius, mm.
    pub radius_mm_std: f64,
    /// Mean curvature, 1/m.
    pub curvature_per_m: f64,
    /// Mean bending angle, degrees.
    pub bending_angle_deg: f64,
    /// Mean fit RMS, px.
    pub fit_rms_px: f64,
    /// Frames measured.
    pub frames_used: usize,
    /// Frames rejected.
    pub frames_rejected: usize,
}

/// Aggregates frame measurements (radius px -> mm with `mm_per_px`).
pub fn summarize(frames: &[FrameMeasurement], mm_per_px: f64) -> VideoSummary {
    let used: Vec<&FrameMeasurement> = frames
        .iter()
        .filter(|f| f.status == FrameStatus::Ok)
        .collect();
    let n = used.len();
    let mut s = VideoSummary {
        frames_used: n,
        frames_rejected: frames.len() - n,
        radius_mm: f64::NAN,
        radius_mm_median: f64::NAN,
        radius_mm_std: f64::NAN,
        curvature_per_m: f64::NAN,
        bending_angle_deg: f64::NAN,
        fit_rms_px: f64::NAN,
    };
    if n == 0 {
        return s;
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let mut r: Vec<f64> = used.iter().map(|f| f.radius_px * mm_per_px).collect();
    s.radius_mm = mean(&r);
    s.radius_mm_std = if n > 1 && s.radius_mm.is_finite() {
        (r.iter().map(|v| (v - s.radius_mm).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
    } else {
        0.0
    };
    r.sort_by(f64::total_cmp);
    s.radius_mm_median = if n % 2 == 1 {
        r[n / 2]
    } else {
        0.5 * (r[n / 2 - 1] + r[n / 2])
    };
    let k: Vec<f64> = used
        .iter()
        .map(|f| f.curvature_per_px / mm_per_px * 1000.0)
        .collect();
    s.curvature_per_m = mean(&k);
    let a: Vec<f64> = used.iter().map(|f| f.bending_angle_deg).collect();
    s.bending_angle_deg = mean(&a);
    let q: Vec<f64> = used.iter().map(|f| f.fit_rms_px).collect();
    s.fit_rms_px = mean(&q);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn session(rows: &str, files: &[&str]) -> tempfile::TempDir {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join(MANIFEST), rows).unwrap();
        for f in files {
            std::fs::write(d.path().join(f), b"x").unwrap();
        }
        d
    }

    #[test]
    fn units_come_from_the_header() {
        for (h, k) in [
            ("pressure_bar", 100.0),
            ("pressure_kpa", 1.0),
            ("pressure_psi", KPA_PER_PSI),
        ] {
            let d = session(&format!("file,{h}\nGX010001.MP4,0.5\n"), &["GX010001.MP4"]);
            let m = read_manifest(d.path()).unwrap();
            assert_eq!(m.entries.len(), 1);
            assert!((m.entries[0].pressure_kpa - 0.5 * k).abs() < 1e-12);
        }
        let d = session("file,pressure\nGX010001.MP4,0.5\n", &["GX010001.MP4"]);
        let e = read_manifest(d.path()).unwrap_err().to_string();
        assert!(
            e.contains("pressure_bar, pressure_kpa or pressure_psi"),
            "{e}"
        );
    }

    #[test]
    fn a_spreadsheet_export_with_bom_crlf_and_quotes_is_read() {
        let d = session(
            "\u{feff}\"file\",\"pressure_kpa\"\r\n\"GX010001.MP4\",20\r\nGX010002.MP4,\"35\"\r\n",
            &["GX010001.MP4", "GX010002.MP4"],
        );
        let m = read_manifest(d.path()).unwrap();
        assert!(m.issues.is_empty(), "{:?}", m.issues);
        assert_eq!(m.entries.len(), 2);
        assert_eq!(m.entries[1].pressure_kpa, 35.0);
        let p = d.path().join(PRESSURE_LOG);
        std::fs::write(&p, "\u{feff}time_s,pressure_kpa\r\n0,1\r\n1,2\r\n").unwrap();
        assert_eq!(read_pressure_log(&p).unwrap().pressure_at(0.5), Some(1.5));
    }

    #[test]
    fn row_problems_are_listed_not_fatal() {
        let d = session(
            "file,pressure_bar\nGX010001.MP4,0.1\nGX010002.MP4,abc\nGX010003.MP4,-0.2\nGX010001.MP4,0.3\nMISSING.MP4,0.4\nGX010004.MP4,\n",
            &["GX010001.MP4", "GX010002.MP4", "GX010003.MP4", "GX010004.MP4", "GX010009.MP4"],
        );
        let m = read_manifest(d.path()).unwrap();
        assert_eq!(m.entries.len(), 1);
        let msgs: Vec<String> = m
            .issues
            .iter()
            .map(|i| format!("{}: {}", i.file, i.message))
            .collect();
        let has = |s: &str| msgs.iter().any(|m| m.contains(s));
        assert!(
            has("GX010002.MP4: pressure `abc` is not a number"),
            "{msgs:?}"
        );
        assert!(has("GX010003.MP4: pressure -0.2 is negative"), "{msgs:?}");
        assert!(has("GX010001.MP4: listed twice"), "{msgs:?}");
        assert!(has("MISSING.MP4: no such video"), "{msgs:?}");
        assert!(has("GX010004.MP4: pressure `` is not a number"), "{msgs:?}");
        assert!(has("GX010009.MP4: not in pressures.csv"), "{msgs:?}");
    }

    #[test]
    fn a_bad_row_is_its_videos_only_report() {
        let d = session(
            "file,pressure_kpa\nGX010001.MP4,abc\nGX010002.MP4,-1\nGX010003.MP4,7\nGX010003.MP4,8\n",
            &["GX010001.MP4", "GX010002.MP4", "GX010003.MP4"],
        );
        let m = read_manifest(d.path()).unwrap();
        assert_eq!(m.entries.len(), 1);
        let files: Vec<&str> = m.issues.iter().map(|i| i.file.as_str()).collect();
        assert_eq!(
            files,
            ["GX010001.MP4", "GX010002.MP4", "GX010003.MP4"],
            "{:?}",
            m.issues
        );
        assert!(m.issues.iter().all(|i| i.line.is_some()), "{:?}", m.issues);
    }

    #[test]
    fn names_that_differ_only_in_case_are_not_confused() {
        let d = session(
            "file,pressure_kpa\nGX010003.MP4,50\n",
            &["GX010003.MP4", "gx010003.mp4"],
        );
        let m = read_manifest(d.path()).unwrap();
        assert_eq!(m.entries.len(), 1);
        assert_eq!(m.entries[0].file, "GX010003.MP4", "the exact name");
        assert_eq!(m.issues.len(), 1, "{:?}", m.issues);
        assert_eq!(m.issues[0].file, "gx010003.mp4");
        assert!(m.issues[0]
            .message
            .contains("differs only in letter case from GX010003.MP4"));
        // A row matching both only case-insensitively is refused, both files kept out.
        let d = session(
            "file,pressure_kpa\nGx010003.Mp4,50\n",
            &["GX010003.MP4", "gx010003.mp4"],
        );
        let m = read_manifest(d.path()).unwrap();
        assert!(m.entries.is_empty());
        assert_eq!(m.issues.len(), 1, "{:?}", m.issues);
        assert!(m.issues[0]
            .message
            .contains("GX010003.MP4 and gx010003.mp4"));
    }

    #[test]
    fn gopro_chapters_follow_their_first_chapter() {
        let d = session(
            "file,pressure_kpa\nGX010123.MP4,50\n",
            &[
                "GX010123.MP4",
                "GX030123.MP4",
                "GX020123.MP4",
                "GH010124.MP4",
            ],
        );
        let m = read_manifest(d.path()).unwrap();
        assert_eq!(m.entries[0].chapters, vec!["GX020123.MP4", "GX030123.MP4"]);
        assert_eq!(m.issues.len(), 1, "{:?}", m.issues);
        assert!(m.issues[0].file == "GH010124.MP4");
        assert_eq!(
            gopro_parts("GX020123.MP4"),
            Some(("GX".into(), 2, "0123".into()))
        );
        assert_eq!(gopro_parts("clip.mp4"), None);
    }

    #[test]
    fn pressure_log_interpolates_and_checks() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(PRESSURE_LOG);
        std::fs::write(&p, "time_s,pressure_kpa\n0,0\n10,2.5\n20,5\n").unwrap();
        let log = read_pressure_log(&p).unwrap();
        assert_eq!(log.pressure_at(5.0), Some(1.25));
        assert_eq!(log.pressure_at(20.0), Some(5.0));
        assert_eq!(log.pressure_at(20.5), None);
        std::fs::write(&p, "time_s,pressure_bar\n0,0\n1,0.1\n").unwrap();
        assert_eq!(read_pressure_log(&p).unwrap().pressure_at(1.0), Some(10.0));
        for bad in [
            "time_s,pressure\n0,1\n1,2\n",
            "time_s,pressure_kpa\n1,1\n0,2\n",
            "time_s,pressure_kpa\n0,x\n",
            "time_s,pressure_kpa\n0,1\n",
        ] {
            std::fs::write(&p, bad).unwrap();
            assert!(read_pressure_log(&p).is_err(), "{bad}");
        }
    }

    #[test]
    fn config_defaults_and_bad_values() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(CONFIG);
        std::fs::write(
            &p,
            "expected_markers = 6\n[scale_board]\nsquare_mm = 10\n[detect]\ns_min = 90\n",
        )
        .unwrap();
        let c = SessionConfig::read(&p).unwrap();
        assert_eq!(c.expected_markers, 6);
        assert_eq!(c.scale_board.square_mm, 10.0);
        assert_eq!(c.scale_board.cols, 9);
        assert_eq!(c.detect.hsv.s_min, 90);
        std::fs::write(&p, "frame_stride = 0\n").unwrap();
        assert!(SessionConfig::read(&p)
            .unwrap_err()
            .to_string()
            .contains("frame_stride"));
        std::fs::write(&p, "nonsense = 1\n").unwrap();
        assert!(SessionConfig::read(&p).is_err());
        std::fs::write(
            &p,
            "expected_markers = 8\n\n[detect]\ns_min = 90\nhue_maxlow = 3\n",
        )
        .unwrap();
        let e = SessionConfig::read(&p).unwrap_err().to_string();
        assert!(e.contains("line 5 (`hue_maxlow = 3`)"), "{e}");
        std::fs::write(&p, "frame_stride = 1\nexpected_markers = \"eight\"\n").unwrap();
        let e = SessionConfig::read(&p).unwrap_err().to_string();
        assert!(e.contains("line 2 (`expected_markers = \"eight\"`)"), "{e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}
