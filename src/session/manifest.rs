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
    // Videos in the folder, by upper-case name.
    let mut videos: BTreeMap<String, String> = BTreeMap::new();
    if let Ok(rd) = std::fs::read_dir(session) {
        for e in rd.flatten() {
            let p = e.path();
            if p.is_file() && has_extension(&p, VIDEO_EXTENSIONS) {
                let name = e.file_name().to_string_lossy().into_owned();
                videos.insert(name.to_ascii_uppercase(), name);
            }
        }
    }
    let mut entries: Vec<ManifestEntry> = Vec::new();
    let mut issues = Vec::new();
    let mut seen: HashSet<String> = HashSet::new();
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
        let pressure: f64 = match raw.parse::<f64>() {
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
        if !seen.insert(file.to_ascii_uppercase()) {
            issues.push(issue("listed twice: the first row is used".into()));
            continue;
        }
        let Some(actual) = videos.get(&file.to_ascii_uppercase()).cloned() else {
            issues.push(issue(
                "no such video in the session folder: check the name".into(),
            ));
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
    let listed: HashSet<String> = entries
        .iter()
        .map(|e| e.file.to_ascii_uppercase())
        .collect();
    let mut claimed: HashSet<String> = HashSet::new();
    for e in entries.iter_mut() {
        if let Some((prefix, 1, rec)) = gopro_parts(&e.file) {
            let mut chapters: Vec<(u32, String)> = videos
                .values()
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
            for (_, c) in &chapters {
                claimed.insert(c.to_ascii_uppercase());
            }
            e.chapters = chapters.into_iter().map(|(_, c)| c).collect();
        }
    }
    for (upper, name) in &videos {
        if !listed.contains(upper) && !claimed.contains(upper) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session::KPA_PER_PSI;

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
}
