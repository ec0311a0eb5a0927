//! The manifest of a step session: `pressures.csv`, one row per video.

use std::collections::{BTreeMap, HashSet};
use std::path::Path;

use serde::Serialize;

use super::{
    has_extension, require_pressure_column, PressureUnit, SessionError, MANIFEST, VIDEO_EXTENSIONS,
};
use crate::table::Table;

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

/// Highest pressure a manifest row may give without a warning, kPa (10 MPa: soft
/// pneumatic actuators work below a few hundred kPa; more is a typo or a wrong unit).
pub const MAX_PLAUSIBLE_PRESSURE_KPA: f64 = 10_000.0;

/// The usable rows of `m` whose pressure is above [`MAX_PLAUSIBLE_PRESSURE_KPA`]: a
/// warning each (the row is measured as given), naming the value and its unit.
pub fn implausible_pressures(m: &Manifest) -> Vec<SessionIssue> {
    let show = |v: f64| {
        if v.abs() >= 1e6 {
            format!("{v:e}")
        } else {
            format!("{v}")
        }
    };
    m.entries
        .iter()
        .filter(|e| e.pressure_kpa > MAX_PLAUSIBLE_PRESSURE_KPA)
        .map(|e| {
            let (unit, kpa) = match m.unit {
                PressureUnit::Kpa => ("kPa", String::new()),
                u => (u.name(), format!(" ({} kPa)", show(e.pressure_kpa))),
            };
            SessionIssue {
                file: e.file.clone(),
                line: Some(e.line),
                message: format!(
                    "pressure {} {}{kpa} is above {MAX_PLAUSIBLE_PRESSURE_KPA} kPa (10 MPa), not plausible for a soft actuator: check the value and the unit in the header of {MANIFEST} (measured as given)",
                    show(e.pressure),
                    unit
                ),
            }
        })
        .collect()
}

/// GoPro naming: `GX` or `GH` (or `GL`), two chapter digits, four recording digits
/// (HERO6 and later); or the older naming (HERO5, and HERO6-8 in H.264 on some
/// firmware): `GOPRnnnn` for the first chapter, then `GP01nnnn`, `GP02nnnn`, ... for
/// the second, third, ... Returns (prefix letters, chapter, recording), chapters
/// counted from 1 in both namings (`GOPR0042` is ("GP", 1, "0042"), `GP010042` is
/// ("GP", 2, "0042")).
pub fn gopro_parts(name: &str) -> Option<(String, u32, String)> {
    let stem = Path::new(name)
        .file_stem()?
        .to_string_lossy()
        .to_ascii_uppercase();
    let b = stem.as_bytes();
    if b.len() == 8 && stem.starts_with("GOPR") && b[4..].iter().all(u8::is_ascii_digit) {
        return Some(("GP".into(), 1, stem[4..].to_string()));
    }
    if b.len() == 8 && stem.starts_with("GP") && b[2..].iter().all(u8::is_ascii_digit) {
        let chapter: u32 = stem[2..4].parse().ok()?;
        return Some(("GP".into(), chapter + 1, stem[4..].to_string()));
    }
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

/// The videos of a session folder grouped by upper-case name (names sorted): more than
/// one name in a group means files that differ only in case.
fn videos_by_upper_name(session: &Path) -> BTreeMap<String, Vec<String>> {
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
    videos
}

/// The chapters (02, 03, ...) in `videos` that continue the GoPro recording whose first
/// chapter is `first`, in order; names in `named` are videos of their own, not chapters.
fn chapters_of(
    first: &str,
    videos: &BTreeMap<String, String>,
    named: &HashSet<String>,
) -> Vec<String> {
    let Some((prefix, 1, rec)) = gopro_parts(first) else {
        return vec![];
    };
    let mut chapters: Vec<(u32, String)> = videos
        .iter()
        .filter(|(upper, _)| !named.contains(*upper))
        .filter_map(|(_, v)| match gopro_parts(v) {
            Some((p, ch, r)) if p == prefix && r == rec && ch > 1 => Some((ch, v.clone())),
            _ => None,
        })
        .collect();
    chapters.sort();
    chapters.into_iter().map(|(_, c)| c).collect()
}

/// Reads `SESSION/pressures.csv`, checks every row against the folder, groups GoPro
/// chapters and lists videos that are not in the manifest.
///
/// Every file gives at most one issue: a file named by a row (even a row that cannot be
/// used) is not also reported as missing from the manifest, and files whose names differ
/// only in case are one issue naming all of them (none of them is measured: which one
/// the row means is ambiguous).
pub fn read_manifest(session: &Path) -> Result<Manifest, SessionError> {
    let path = session.join(MANIFEST);
    if !session.is_dir() {
        return Err(SessionError::Folder {
            path: session.to_path_buf(),
            why: "no such session folder".into(),
        });
    }
    let bytes = std::fs::read(&path).map_err(|e| SessionError::Manifest {
        path: path.clone(),
        why: format!("{e}: write a {MANIFEST} with the header `file,pressure_bar` (or pressure_kpa, pressure_psi) and one row per video"),
    })?;
    let table = Table::parse(&bytes, &path)?;
    if table.columns().is_empty() {
        return Err(SessionError::Manifest {
            path,
            why: "empty manifest: add the header `file,pressure_bar` and one row per video".into(),
        });
    }
    let file_col = table.require(
        "file",
        "name the column of video names `file` (header `file,pressure_bar`)",
    )?;
    let (p_col, unit) = require_pressure_column(&table)?;
    let folder = videos_by_upper_name(session);
    let unique: BTreeMap<String, String> = folder
        .iter()
        .filter(|(_, names)| names.len() == 1)
        .map(|(upper, names)| (upper.clone(), names[0].clone()))
        .collect();
    let mut entries: Vec<ManifestEntry> = Vec::new();
    let mut issues = Vec::new();
    let mut seen: HashSet<String> = HashSet::new();
    // Every file a row names, usable or not, and the first row naming each.
    let mut named: BTreeMap<String, (usize, String)> = BTreeMap::new();
    for row in 0..table.len() {
        let lineno = table.line(row);
        let file = table.cell(row, file_col).trim().to_string();
        let raw = table.cell(row, p_col).trim();
        let issue = |message: String| SessionIssue {
            file: file.clone(),
            line: Some(lineno),
            message,
        };
        if file.is_empty() {
            issues.push(issue("no file name in this row".into()));
            continue;
        }
        let upper = file.to_ascii_uppercase();
        named.entry(upper.clone()).or_insert((lineno, file.clone()));
        // A decimal comma reads in a semicolon- or tab-separated manifest.
        let pressure: f64 = match table.number(raw).ok_or(()) {
            Ok(v) if v.is_finite() && v >= 0.0 => v,
            Ok(v) => {
                issues.push(issue(format!(
                    "pressure {v} is negative or not finite: give a pressure >= 0 in {}",
                    unit.name()
                )));
                continue;
            }
            Err(_) if raw.is_empty() => {
                issues.push(issue(format!(
                    "no pressure in this row: give a plain number in {} (the unit is in the header)",
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
        if !seen.insert(upper.clone()) {
            issues.push(issue("listed twice: the first row is used".into()));
            continue;
        }
        if folder.get(&upper).is_some_and(|names| names.len() > 1) {
            // Reported once below, with every name.
            continue;
        }
        let Some(actual) = unique
            .get(&upper)
            .cloned()
            .or_else(|| photo_item(session, &file))
        else {
            issues.push(issue(why_not_an_item(session, &file)));
            continue;
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
    let named_upper: HashSet<String> = named.keys().cloned().collect();
    for e in entries.iter_mut() {
        e.chapters = chapters_of(&e.file, &unique, &named_upper);
    }
    // The chapters of every named recording, usable or not, belong to a row.
    let claimed: HashSet<String> = named
        .values()
        .flat_map(|(_, file)| {
            let first = unique
                .get(&file.to_ascii_uppercase())
                .cloned()
                .unwrap_or_else(|| file.clone());
            chapters_of(&first, &unique, &named_upper)
        })
        .map(|c| c.to_ascii_uppercase())
        .collect();
    for (upper, names) in folder.iter().filter(|(_, names)| names.len() > 1) {
        let (line, file) = match named.get(upper) {
            Some((line, file)) => (Some(*line), file.clone()),
            None => (None, names[0].clone()),
        };
        let count = match names.len() {
            2 => "two".to_string(),
            n => n.to_string(),
        };
        issues.push(SessionIssue {
            file,
            line,
            message: format!(
                "{count} files differ only in case ({}): rename or remove one",
                names.join(", ")
            ),
        });
    }
    for (upper, name) in &unique {
        if !named.contains_key(upper) && !claimed.contains(upper) {
            issues.push(SessionIssue {
                file: name.clone(),
                line: None,
                message: format!("not in {MANIFEST}: not processed (add a row with its pressure)"),
            });
        }
    }
    Ok(Manifest {
        unit,
        entries,
        issues,
    })
}

/// Why the file a manifest row names is neither a video, a photo nor a photo folder of
/// the session: it is missing, or it is there but nested, not a regular file (a pipe, a
/// device) or in a format bendscope does not read.
fn why_not_an_item(session: &Path, file: &str) -> String {
    let path = session.join(file);
    let nested = file.contains(['/', '\\']);
    match std::fs::metadata(&path) {
        Ok(_) if nested => "no such video, photo or photo folder in the session folder itself: nested paths are not supported: put it in the session folder and name it without a folder".into(),
        Ok(m) if !m.is_file() && !m.is_dir() => "not a regular file (a pipe, socket or device): copy the video or photo into the session folder".into(),
        Ok(m) if m.is_file() => {
            let ext = path
                .extension()
                .map(|e| e.to_string_lossy().into_owned())
                .unwrap_or_default();
            let what = if ext.is_empty() {
                "a file without an extension".to_string()
            } else {
                format!("a .{ext} file")
            };
            format!(
                "{what}, a format bendscope does not read: convert it to a photo (.jpg, .png, .tif) or a video (.mp4, .mov, .m4v, .mkv, .avi, .webm)"
            )
        }
        Ok(_) => "a folder bendscope keeps for itself (calib, bendscope-out): not a photo folder: rename it".into(),
        Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied => {
            "permission denied: make it readable (chmod a+r)".into()
        }
        Err(_) => "no such video, photo or photo folder in the session folder: check the name".into(),
    }
}

/// The photo protocol: a row may name a photo (JPEG, PNG, TIFF) or a folder of photos
/// (a burst) in the session folder itself; `Some(name)` when `file` is one.
fn photo_item(session: &Path, file: &str) -> Option<String> {
    if file.contains(['/', '\\']) || file == "." || file == ".." {
        return None;
    }
    let path = session.join(file);
    let is_item = (path.is_file() && super::is_photo(&path))
        || (path.is_dir() && file != "calib" && file != "bendscope-out");
    is_item.then(|| file.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session::{PressureUnit, KPA_PER_PSI};

    fn session(rows: &str, files: &[&str]) -> tempfile::TempDir {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join(MANIFEST), rows).unwrap();
        for f in files {
            std::fs::write(d.path().join(f), b"x").unwrap();
        }
        d
    }

    #[test]
    fn pressures_above_10_mpa_are_warned_with_value_unit_and_line() {
        let d = session(
            "file,pressure_bar\nA.MP4,0.8\nB.MP4,100\nC.MP4,100.5\n",
            &["A.MP4", "B.MP4", "C.MP4"],
        );
        let w = implausible_pressures(&read_manifest(d.path()).unwrap());
        assert_eq!(w.len(), 1, "{w:?}");
        assert_eq!((w[0].file.as_str(), w[0].line), ("C.MP4", Some(4)));
        assert!(
            w[0].message
                .starts_with("pressure 100.5 bar (10050 kPa) is above 10000 kPa"),
            "{}",
            w[0].message
        );
        let d = session("file,pressure_kpa\nA.MP4,1e12\n", &["A.MP4"]);
        let w = implausible_pressures(&read_manifest(d.path()).unwrap());
        assert!(
            w[0].message.starts_with("pressure 1e12 kPa is above"),
            "{w:?}"
        );
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
        assert!(has("GX010004.MP4: no pressure in this row"), "{msgs:?}");
        assert!(has("GX010009.MP4: not in pressures.csv"), "{msgs:?}");
    }

    #[test]
    fn decimal_commas_in_a_comma_separated_manifest_are_an_error_at_the_row() {
        let files = ["GX010101.MP4", "GX010102.MP4"];
        for (rows, line) in [
            // A row with a decimal comma among correct ones: the whole manifest stops.
            ("file,pressure_kpa\nGX010101.MP4,20\nGX010102.MP4,35,5\n", 3),
            (
                "file,pressure_bar\nGX010101.MP4,0,2\nGX010102.MP4,0,35\n",
                2,
            ),
        ] {
            let d = session(rows, &files);
            let e = read_manifest(d.path()).unwrap_err().to_string();
            assert!(
                e.contains(&format!(
                    "pressures.csv: line {line}: this row has 3 fields where the header"
                )),
                "{e}"
            );
            assert!(
                e.contains("decimal comma? use a semicolon separator or a decimal point"),
                "{e}"
            );
        }
        // The same values with a semicolon separator read as decimals.
        let d = session(
            "file;pressure_bar\nGX010101.MP4;0,2\nGX010102.MP4;0,35\n",
            &files,
        );
        let m = read_manifest(d.path()).unwrap();
        let kpa: Vec<f64> = m.entries.iter().map(|e| e.pressure_kpa).collect();
        assert!(
            (kpa[0] - 20.0).abs() < 1e-9 && (kpa[1] - 35.0).abs() < 1e-9,
            "{kpa:?}"
        );
        // A semicolon header over comma rows names the mismatch instead of each row
        // lacking its pressure.
        let d = session(
            "file;pressure_kpa\nGX010101.MP4,20\nGX010102.MP4,35\n",
            &files,
        );
        let e = read_manifest(d.path()).unwrap_err().to_string();
        assert!(
            e.contains("line 2: the header is semicolon-separated but this row is comma-separated"),
            "{e}"
        );
    }

    #[test]
    fn rows_naming_files_that_are_there_but_unusable_say_why() {
        let d = session(
            "file,pressure_kpa\np3.heic,20\nnest/deeper/burst1,30\nGONE.MP4,40\nnoext,50\n",
            &["p3.heic", "noext"],
        );
        std::fs::create_dir_all(d.path().join("nest/deeper/burst1")).unwrap();
        let m = read_manifest(d.path()).unwrap();
        let why = |file: &str| {
            m.issues
                .iter()
                .find(|i| i.file == file)
                .map(|i| i.message.clone())
                .unwrap_or_default()
        };
        assert!(
            why("p3.heic")
                .starts_with("a .heic file, a format bendscope does not read: convert it"),
            "{:?}",
            m.issues
        );
        assert!(
            why("noext").starts_with("a file without an extension"),
            "{:?}",
            m.issues
        );
        assert!(
            why("nest/deeper/burst1").contains("nested paths are not supported"),
            "{:?}",
            m.issues
        );
        assert!(
            why("GONE.MP4").starts_with("no such video"),
            "{:?}",
            m.issues
        );
    }

    #[cfg(unix)]
    #[test]
    fn a_fifo_named_like_a_video_is_not_a_regular_file() {
        let d = session("file,pressure_kpa\nGX010103.MP4,20\n", &[]);
        let fifo = d.path().join("GX010103.MP4");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        assert!(made.is_ok_and(|s| s.success()), "mkfifo failed");
        let m = read_manifest(d.path()).unwrap();
        assert_eq!(m.issues.len(), 1, "{:?}", m.issues);
        assert!(
            m.issues[0]
                .message
                .starts_with("not a regular file (a pipe, socket or device)"),
            "{:?}",
            m.issues
        );
    }

    #[test]
    fn two_pressure_columns_must_agree() {
        let files = ["GX010101.MP4", "GX010102.MP4"];
        let d = session(
            "file,pressure_kpa,pressure_bar\nGX010101.MP4,20,0.2\nGX010102.MP4,35,0.5\n",
            &files,
        );
        let e = read_manifest(d.path()).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{}: line 3: two pressure columns disagree: pressure_kpa is 35 (35 kPa) and pressure_bar is 0.5 (50 kPa): keep one pressure column",
                d.path().join(MANIFEST).display()
            )
        );
        // Columns that agree (to rounding) are fine: the first one is used.
        let d = session(
            "file,pressure_kpa,pressure_psi\nGX010101.MP4,20,2.9\nGX010102.MP4,35,5.08\n",
            &files,
        );
        let m = read_manifest(d.path()).unwrap();
        assert_eq!(
            (m.unit, m.entries[1].pressure_kpa),
            (PressureUnit::Kpa, 35.0)
        );
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
    fn the_older_gopro_naming_continues_gopr_with_gp01_gp02() {
        let d = session(
            "file,pressure_kpa\nGOPR0042.MP4,20\n",
            &["GOPR0042.MP4", "GP020042.MP4", "GP010042.MP4"],
        );
        let m = read_manifest(d.path()).unwrap();
        assert!(m.issues.is_empty(), "{:?}", m.issues);
        assert_eq!(m.entries[0].chapters, vec!["GP010042.MP4", "GP020042.MP4"]);
        assert_eq!(
            gopro_parts("GOPR0042.MP4"),
            Some(("GP".into(), 1, "0042".into()))
        );
        assert_eq!(
            gopro_parts("GP010042.MP4"),
            Some(("GP".into(), 2, "0042".into()))
        );
        assert_eq!(gopro_parts("GOPRO042.MP4"), None);
    }

    #[test]
    fn a_byte_order_mark_and_crlf_are_not_part_of_the_header() {
        let d = session(
            "\u{feff}file,pressure_kpa\r\nGX010001.MP4,20\r\n\"GX010002.MP4\" , 40 \r\n",
            &["GX010001.MP4", "GX010002.MP4"],
        );
        let m = read_manifest(d.path()).unwrap();
        assert!(m.issues.is_empty(), "{:?}", m.issues);
        assert_eq!(m.entries.len(), 2);
        assert_eq!((m.entries[1].line, m.entries[1].pressure_kpa), (3, 40.0));
    }

    #[test]
    fn every_file_is_reported_at_most_once() {
        // Bad rows name files that are in the folder: they are not also "not in the
        // manifest", nor are the chapters of a recording named by a bad row.
        let d = session(
            "file,pressure_bar\nGX010002.MP4,abc\nGX010003.MP4,-1\nGX010004.MP4,\n",
            &[
                "GX010002.MP4",
                "GX010003.MP4",
                "GX010004.MP4",
                "GX020004.MP4",
            ],
        );
        let m = read_manifest(d.path()).unwrap();
        assert!(m.entries.is_empty());
        let files: Vec<&str> = m.issues.iter().map(|i| i.file.as_str()).collect();
        assert_eq!(
            files,
            ["GX010002.MP4", "GX010003.MP4", "GX010004.MP4"],
            "{:?}",
            m.issues
        );
        assert!(m
            .issues
            .iter()
            .all(|i| !i.message.contains("not in pressures.csv")));
        assert_eq!(m.issues[0].line, Some(2));
    }

    #[test]
    fn files_differing_only_in_case_are_one_issue_and_not_measured() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(
            d.path().join(MANIFEST),
            "file,pressure_kpa\nGX010103.MP4,20\nGX010101.MP4,40\n",
        )
        .unwrap();
        for f in [
            "GX010103.MP4",
            "gx010103.mp4",
            "GX010101.MP4",
            "a.mov",
            "A.MOV",
        ] {
            std::fs::write(d.path().join(f), b"x").unwrap();
        }
        let names: Vec<_> = std::fs::read_dir(d.path()).unwrap().collect();
        if names.len() < 6 {
            // A case-insensitive file system: nothing to tell apart.
            return;
        }
        let m = read_manifest(d.path()).unwrap();
        assert_eq!(m.entries.len(), 1);
        assert_eq!(m.entries[0].file, "GX010101.MP4");
        assert_eq!(m.issues.len(), 2, "{:?}", m.issues);
        let listed = &m.issues.iter().find(|i| i.file == "GX010103.MP4").unwrap();
        assert_eq!(listed.line, Some(2));
        assert_eq!(
            listed.message,
            "two files differ only in case (GX010103.MP4, gx010103.mp4): rename or remove one"
        );
        let unlisted = &m.issues.iter().find(|i| i.file == "A.MOV").unwrap();
        assert_eq!(unlisted.line, None);
        assert!(unlisted.message.contains("(A.MOV, a.mov)"), "{unlisted:?}");
    }

    #[test]
    fn header_problems_name_the_file_and_line() {
        let d = session(
            "\nfile_name,pressure_kpa\nGX010001.MP4,1\n",
            &["GX010001.MP4"],
        );
        let e = read_manifest(d.path()).unwrap_err().to_string();
        assert!(
            e.ends_with("pressures.csv: line 2: no `file` column in the header `file_name,pressure_kpa`: name the column of video names `file` (header `file,pressure_bar`)"),
            "{e}"
        );
        let d = session("\n\n", &[]);
        let e = read_manifest(d.path()).unwrap_err().to_string();
        assert!(e.contains("empty manifest"), "{e}");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

        #[test]
        fn arbitrary_manifests_parse_or_fail_without_panicking(
            bytes in proptest::collection::vec(
                proptest::sample::select(b"GX010001.MP4gx2,\",\n\r -1e5x\xff".to_vec()),
                0..160,
            )
        ) {
            let d = tempfile::tempdir().unwrap();
            std::fs::write(d.path().join(MANIFEST), &bytes).unwrap();
            for f in ["GX010001.MP4", "GX020001.MP4", "gx010002.mp4", "GX010002.MP4"] {
                std::fs::write(d.path().join(f), b"x").unwrap();
            }
            let prefix = b"file,pressure_kpa\n";
            if let Ok(m) = read_manifest(d.path()) {
                // At most one issue or entry per row and per file.
                let rows = Table::parse(&bytes, Path::new(MANIFEST)).map(|t| t.len()).unwrap_or(0);
                proptest::prop_assert!(m.entries.len() + m.issues.len() <= rows + 4);
                for e in &m.entries {
                    proptest::prop_assert!(e.pressure_kpa.is_finite() && e.pressure_kpa >= 0.0);
                }
            }
            std::fs::write(d.path().join(MANIFEST), [prefix.as_slice(), &bytes].concat()).unwrap();
            let _ = read_manifest(d.path());
        }
    }
}
