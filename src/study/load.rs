//! Loading a study: every session's measured rows (per_video.csv of a process output; a
//! session folder is processed on the way, with its cache), the actuator each session
//! shows (markers per frame, length of the marker line) and the FEM curves. A sample's
//! sessions must show one actuator.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::compare::{read_columns, Curve};
use crate::pipeline::{measure_session, ProcessSettings, Progress};
use crate::table::Table;

use super::config::{StudyError, StudySpec, FITTED, QUANTITIES};

/// A session's marker line may differ in length from its sample's first session by at
/// most this share before the two are called different actuators (the marker line of
/// one actuator changes length by a few % as it bends; a different design or a cut
/// actuator differs by more).
pub const LENGTH_REL_TOL: f64 = 0.10;

/// The folder `bendscope process` writes in a session folder by default.
pub const DEFAULT_OUT: &str = "bendscope-out";

/// One measured row of per_video.csv (status `ok` or `partial`).
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// Pressure, kPa.
    pub pressure_kpa: f64,
    /// The [`QUANTITIES`] in order (NaN where the cell is empty).
    pub values: [f64; 5],
}

/// One session of a sample.
#[derive(Debug, Clone)]
pub struct SessionData {
    /// As listed (study.toml or flags).
    pub listed: PathBuf,
    /// The process output folder read.
    pub out: PathBuf,
    /// Its measured rows.
    pub rows: Vec<Row>,
    /// Markers per measured frame (the most common count), when known.
    pub markers: Option<usize>,
    /// Median length of the marker line (marker 1 to the last, along the markers), mm.
    pub length_mm: Option<f64>,
}

impl SessionData {
    /// A short name: the listed path, without a trailing `bendscope-out`.
    pub fn label(&self) -> String {
        let p = if self.listed.ends_with(DEFAULT_OUT) {
            self.listed.parent().unwrap_or(&self.listed)
        } else {
            &self.listed
        };
        p.display().to_string()
    }
}

/// One sample: name and sessions.
#[derive(Debug, Clone)]
pub struct SampleData {
    /// Name.
    pub name: String,
    /// Sessions, in the order listed.
    pub sessions: Vec<SessionData>,
}

/// One simulation: its name and the curves of the fitted quantities.
#[derive(Debug, Clone)]
pub struct FemModel {
    /// Name (the folder's name).
    pub name: String,
    /// The folder.
    pub dir: PathBuf,
    /// steps.csv's radius, curvature and angle vs pressure (the first [`FITTED`]
    /// quantities).
    pub curves: Vec<Curve>,
}

/// A loaded and checked study.
#[derive(Debug, Clone)]
pub struct Study {
    /// Samples.
    pub samples: Vec<SampleData>,
    /// Simulations.
    pub fem: Vec<FemModel>,
    /// What was done on the way (sessions processed), for stderr and the report.
    pub notes: Vec<String>,
}

/// What a listed session path is.
enum Entry {
    /// A process output (has per_video.csv).
    Output(PathBuf),
    /// A session folder to process into `SESSION/bendscope-out`.
    Session(PathBuf),
}

fn classify(path: &Path, origin: &str) -> Result<Entry, StudyError> {
    if !path.exists() {
        return Err(StudyError::Input {
            path: path.to_path_buf(),
            why: format!("no such folder: check the path in {origin}"),
        });
    }
    if path.join("per_video.csv").is_file() {
        return Ok(Entry::Output(path.to_path_buf()));
    }
    if path.join("pressures.csv").is_file() || path.join("pressure_log.csv").is_file() {
        return Ok(Entry::Session(path.to_path_buf()));
    }
    Err(StudyError::Input {
        path: path.to_path_buf(),
        why: "no per_video.csv (not a `bendscope process` output) and no pressures.csv or pressure_log.csv (not a session folder): give the folder `bendscope process` wrote, e.g. SESSION/bendscope-out".into(),
    })
}

/// The measured rows of `per_video` (status `ok` or `partial ...`, a finite pressure).
fn read_rows(per_video: &Path) -> Result<Vec<Row>, StudyError> {
    let t = Table::read(per_video)?;
    let hint = "give the per_video.csv `bendscope process` wrote";
    let p = t.require("pressure_kpa", hint)?;
    let status = t.require("status", hint)?;
    let mut cols = Vec::new();
    for (k, (name, _)) in QUANTITIES.iter().enumerate() {
        // The fitted quantities are required; the tip's columns are read when present.
        cols.push(if k < FITTED {
            Some(t.require(name, hint)?)
        } else {
            t.column(name)
        });
    }
    let mut rows = Vec::new();
    for r in 0..t.len() {
        let s = t.cell(r, status).trim();
        if !(s == "ok" || s.starts_with("partial")) {
            continue;
        }
        let Some(pressure) = t.number(t.cell(r, p)).filter(|v| v.is_finite()) else {
            continue;
        };
        let mut values = [f64::NAN; 5];
        for (v, c) in values.iter_mut().zip(&cols) {
            *v = c
                .and_then(|c| t.number(t.cell(r, c)))
                .filter(|v| v.is_finite())
                .unwrap_or(f64::NAN);
        }
        rows.push(Row {
            pressure_kpa: pressure,
            values,
        });
    }
    Ok(rows)
}

/// A marker of a frame in markers.csv: its number and its x, y in mm.
type MarkerXy = (usize, f64, f64);

/// The most common value of `v`, the smaller on a tie.
fn mode(v: impl IntoIterator<Item = usize>) -> Option<usize> {
    let mut counts: HashMap<usize, usize> = HashMap::new();
    for x in v {
        *counts.entry(x).or_default() += 1;
    }
    counts
        .into_iter()
        .max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0)))
        .map(|(x, _)| x)
}

/// Markers per frame and the median marker-line length (mm) of a process output, from
/// markers.csv, else (the count only) from per_frame.csv's `n_markers`.
fn actuator_of(out: &Path) -> Result<(Option<usize>, Option<f64>), StudyError> {
    let markers = out.join("markers.csv");
    if markers.is_file() {
        let t = Table::read(&markers)?;
        let (Some(file), Some(frame), Some(marker)) =
            (t.column("file"), t.column("frame"), t.column("marker"))
        else {
            return Ok((None, None));
        };
        let (x, y) = (t.column("x_mm"), t.column("y_mm"));
        // Per frame: its markers (index, x, y) in file order.
        let mut frames: HashMap<(String, String), Vec<MarkerXy>> = HashMap::new();
        for r in 0..t.len() {
            let k = t.number(t.cell(r, marker)).unwrap_or(0.0) as usize;
            let num = |c: Option<usize>| c.and_then(|c| t.number(t.cell(r, c))).unwrap_or(f64::NAN);
            frames
                .entry((t.cell(r, file).to_string(), t.cell(r, frame).to_string()))
                .or_default()
                .push((k, num(x), num(y)));
        }
        let count = mode(frames.values().map(Vec::len));
        let mut lengths: Vec<f64> = frames
            .values_mut()
            .filter_map(|m| {
                m.sort_by_key(|p| p.0);
                let l: f64 = m
                    .windows(2)
                    .map(|w| (w[1].1 - w[0].1).hypot(w[1].2 - w[0].2))
                    .sum();
                (m.len() >= 2 && l.is_finite()).then_some(l)
            })
            .collect();
        lengths.sort_by(f64::total_cmp);
        let median = (!lengths.is_empty()).then(|| lengths[lengths.len() / 2]);
        return Ok((count, median));
    }
    let per_frame = out.join("per_frame.csv");
    if per_frame.is_file() {
        let t = Table::read(&per_frame)?;
        if let Some(c) = t.column("n_markers") {
            let counts = (0..t.len())
                .filter_map(|r| t.number(t.cell(r, c)))
                .filter(|n| *n > 0.0)
                .map(|n| n as usize);
            return Ok((mode(counts), None));
        }
    }
    Ok((None, None))
}

/// Reads one process output folder.
fn read_session(listed: &Path, out: &Path) -> Result<SessionData, StudyError> {
    let per_video = out.join("per_video.csv");
    if !per_video.is_file() {
        return Err(StudyError::Input {
            path: per_video,
            why: "missing: run `bendscope process` on the session first".into(),
        });
    }
    let rows = read_rows(&per_video)?;
    if rows.is_empty() {
        return Err(StudyError::Input {
            path: per_video,
            why: "no measured row (status ok or partial): look at the session's report.html, fix the session and process it again, or leave it out of the study".into(),
        });
    }
    let (markers, length_mm) = actuator_of(out)?;
    Ok(SessionData {
        listed: listed.to_path_buf(),
        out: out.to_path_buf(),
        rows,
        markers,
        length_mm,
    })
}

/// Checks that the sessions of `sample` show one actuator: the same markers per frame,
/// marker lines within [`LENGTH_REL_TOL`] of the first session's.
fn check_one_actuator(sample: &SampleData) -> Result<(), StudyError> {
    let mismatch = |why: String| StudyError::Mismatch {
        sample: sample.name.clone(),
        why,
    };
    let advice = "sessions of one sample must film one actuator: move the session to a sample of its own, or check that it is the right folder";
    if let Some(first) = sample.sessions.iter().find(|s| s.markers.is_some()) {
        for s in &sample.sessions {
            if let (Some(a), Some(b)) = (first.markers, s.markers) {
                if a != b {
                    return Err(mismatch(format!(
                        "{} has {b} markers per frame and {} has {a} (markers.csv): {advice}",
                        s.out.display(),
                        first.out.display()
                    )));
                }
            }
        }
    }
    if let Some(first) = sample.sessions.iter().find(|s| s.length_mm.is_some()) {
        for s in &sample.sessions {
            if let (Some(a), Some(b)) = (first.length_mm, s.length_mm) {
                if (b - a).abs() > LENGTH_REL_TOL * a {
                    return Err(mismatch(format!(
                        "the marker line of {} is {b:.1} mm long and that of {} {a:.1} mm (markers.csv, median over frames; more than {:.0} % apart): {advice}",
                        s.out.display(),
                        first.out.display(),
                        100.0 * LENGTH_REL_TOL
                    )));
                }
            }
        }
    }
    Ok(())
}

/// Reads a simulation's steps.csv.
fn read_fem(dir: &Path) -> Result<FemModel, StudyError> {
    let steps = dir.join("steps.csv");
    if !steps.is_file() {
        return Err(StudyError::Input {
            path: steps,
            why: "missing: give the output folder of `bendscope simulate` as fem".into(),
        });
    }
    let mut curves = Vec::new();
    for (name, _) in &QUANTITIES[..FITTED] {
        let c = read_columns(&steps, &["pressure_kpa", *name]).map_err(|e| StudyError::Input {
            path: steps.clone(),
            why: e.to_string(),
        })?;
        curves.push(Curve {
            pressure_kpa: c[0].clone(),
            value: c[1].clone(),
        });
    }
    let name = dir
        .components()
        .next_back()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .unwrap_or_else(|| dir.display().to_string());
    Ok(FemModel {
        name,
        dir: dir.to_path_buf(),
        curves,
    })
}

/// Loads and checks the study of `spec`: every path first (so a typo is found before
/// any session is processed), then the session folders processed into
/// `SESSION/bendscope-out` (with their cache: a session processed before costs only
/// its check), then every table read and each sample checked for one actuator.
pub fn load_study(spec: &StudySpec, progress: &mut dyn Progress) -> Result<Study, StudyError> {
    spec.check()?;
    let mut entries: Vec<Vec<Entry>> = Vec::new();
    for s in &spec.samples {
        entries.push(
            s.sessions
                .iter()
                .map(|p| classify(p, &spec.origin))
                .collect::<Result<_, _>>()?,
        );
    }
    let fem: Vec<FemModel> = spec
        .fem
        .iter()
        .map(|d| {
            if d.is_dir() {
                read_fem(d)
            } else {
                Err(StudyError::Input {
                    path: d.clone(),
                    why: format!(
                        "no such folder: give the output folder of `bendscope simulate` (check the path in {})",
                        spec.origin
                    ),
                })
            }
        })
        .collect::<Result<_, _>>()?;
    let mut notes = Vec::new();
    let mut samples = Vec::new();
    for (s, entries) in spec.samples.iter().zip(entries) {
        let mut sessions = Vec::new();
        for (listed, e) in s.sessions.iter().zip(entries) {
            let out = match e {
                Entry::Output(out) => out,
                Entry::Session(dir) => {
                    let out = dir.join(DEFAULT_OUT);
                    let outcome =
                        measure_session(&dir, &out, &ProcessSettings::default(), progress)
                            .map_err(|e| StudyError::Process {
                                why: e.for_session(&dir),
                            })?;
                    notes.push(format!(
                        "{}: a session folder, processed on the way ({} measured, {} failed) -> {}",
                        dir.display(),
                        outcome.measured,
                        outcome.failed,
                        out.display()
                    ));
                    out
                }
            };
            sessions.push(read_session(listed, &out)?);
        }
        let sample = SampleData {
            name: s.name.trim().to_string(),
            sessions,
        };
        check_one_actuator(&sample)?;
        samples.push(sample);
    }
    Ok(Study {
        samples,
        fem,
        notes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_keep_measured_ones_and_markers_give_count_and_length() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(
            d.path().join("per_video.csv"),
            "file,pressure_kpa,radius_mm,curvature_per_m,bending_angle_deg,tip_x_mm,status\n\
             a,20,100,10,30,50,ok\nb,40,80,12.5,40,,\"partial: 2 frames rejected\"\nc,60,,,,,no frame measured: x\n",
        )
        .unwrap();
        let rows = read_rows(&d.path().join("per_video.csv")).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[0].values[..4], [100.0, 10.0, 30.0, 50.0]);
        assert!(rows[0].values[4].is_nan() && rows[1].values[3].is_nan());
        // Two frames of three markers on a 3-4-5 polyline, one frame of two.
        std::fs::write(
            d.path().join("markers.csv"),
            "file,frame,marker,x_mm,y_mm\na,0,1,0,0\na,0,2,3,4\na,0,3,3,10\na,1,2,3,4\na,1,1,0,0\na,1,3,3,10\nb,0,1,0,0\nb,0,2,1,0\n",
        )
        .unwrap();
        let (n, len) = actuator_of(d.path()).unwrap();
        assert_eq!(n, Some(3));
        assert_eq!(len, Some(11.0));
    }
}
