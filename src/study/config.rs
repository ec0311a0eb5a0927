//! What a study holds ([`StudySpec`]: samples and their sessions, simulations), read
//! from study.toml or flags and checked before any file is read; the study's errors and
//! its quantities.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::table::TableError;

/// The name of the pooled rows (all sessions of all samples); no sample may take it.
pub const POOLED: &str = "all";

/// The quantities of study.csv: per_video.csv column and axis label.
pub const QUANTITIES: [(&str, &str); 5] = [
    ("radius_mm", "radius (mm)"),
    ("curvature_per_m", "curvature (1/m)"),
    ("bending_angle_deg", "bending angle (deg)"),
    ("tip_x_mm", "tip x (mm)"),
    ("tip_y_mm", "tip y (mm)"),
];

/// How many of [`QUANTITIES`] (the first ones) are fitted, compared with the FEM, checked
/// for repeatability and plotted: radius, curvature and bending angle. The tip's
/// coordinates depend on where the axes' origin is, so their coefficient of variation
/// and a power law in them mean little.
pub const FITTED: usize = 3;

/// Errors of a study. Each is one line naming the file, key or sample and what to do.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// study.toml or the flags are wrong.
    #[error("{file}: {why}")]
    Config {
        /// study.toml, or the flag.
        file: String,
        /// What is wrong and what to do.
        why: String,
    },
    /// A listed folder or file is missing or not what it should be.
    #[error("{}: {why}", path.display())]
    Input {
        /// The folder or file.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
    /// The sessions of one sample are not of one actuator.
    #[error("sample {sample}: {why}")]
    Mismatch {
        /// The sample.
        sample: String,
        /// What differs and what to do.
        why: String,
    },
    /// A table cannot be read or lacks a column.
    #[error(transparent)]
    Table(#[from] TableError),
    /// A session folder could not be processed on the way.
    #[error("{why}")]
    Process {
        /// The message of `bendscope process`, naming the session.
        why: String,
    },
    /// An output could not be written.
    #[error("cannot write the study: {why}")]
    Output {
        /// What failed.
        why: String,
    },
}

/// One sample: its name and its sessions (process output folders, or session folders).
#[derive(Debug, Clone, PartialEq)]
pub struct SampleSpec {
    /// Name (a row label of study.csv).
    pub name: String,
    /// Its sessions, as paths to read.
    pub sessions: Vec<PathBuf>,
}

/// What a study holds: the samples and the simulations to compare them with.
#[derive(Debug, Clone, PartialEq)]
pub struct StudySpec {
    /// Samples, in the order given.
    pub samples: Vec<SampleSpec>,
    /// `bendscope simulate` output folders (each compared with every sample and the pool).
    pub fem: Vec<PathBuf>,
    /// Where the spec was written (study.toml, or `--sample` for flags), for messages.
    pub origin: String,
    /// What the plots' error bars show (`error_bars` in study.toml, `--error-bars`).
    pub error_bars: crate::report::ErrorBars,
}

/// One path or several.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum OneOrMany {
    One(String),
    Many(Vec<String>),
}

impl OneOrMany {
    fn into_vec(self) -> Vec<String> {
        match self {
            OneOrMany::One(s) => vec![s],
            OneOrMany::Many(v) => v,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct StudyFile {
    #[serde(default)]
    fem: Option<OneOrMany>,
    #[serde(default)]
    error_bars: crate::report::ErrorBars,
    #[serde(default)]
    sample: Vec<SampleFile>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SampleFile {
    name: String,
    sessions: Vec<String>,
    /// TOML puts a `fem` written after a `[[sample]]` into that sample: taken as the
    /// study's.
    #[serde(default)]
    fem: Option<OneOrMany>,
}

/// The 1-based line of byte `offset` in `text`.
fn line_of(text: &str, offset: usize) -> usize {
    1 + text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|b| **b == b'\n')
        .count()
}

/// A TOML error on one line: `line L: message` (toml's own text spans several lines).
fn toml_error_line(text: &str, e: &toml::de::Error) -> String {
    let msg = e
        .message()
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(" ");
    let Some(span) = e.span() else {
        return msg.replace("unknown field", "unknown key");
    };
    let mut line = line_of(text, span.start);
    // An unknown key may be reported at its table: find the key's own line in it.
    if let Some(key) = msg
        .strip_prefix("unknown field `")
        .and_then(|r| r.split_once('`'))
        .map(|(k, _)| k)
    {
        let is_key = |l: &str| {
            l.trim_start()
                .strip_prefix(key)
                .is_some_and(|r| r.trim_start().starts_with('='))
        };
        if let Some(k) = text.lines().skip(line - 1).position(is_key) {
            line += k;
        }
    }
    format!(
        "line {line}: {}",
        msg.replace("unknown field", "unknown key")
    )
}

impl StudySpec {
    /// Reads `path` (study.toml); session and FEM paths are relative to its folder.
    pub fn read(path: &Path) -> Result<StudySpec, StudyError> {
        let file = path.display().to_string();
        let bad = |why: String| StudyError::Config {
            file: file.clone(),
            why,
        };
        let bytes = std::fs::read(path).map_err(|e| {
            bad(match e.kind() {
                std::io::ErrorKind::NotFound => "no such file: check the path".into(),
                _ => crate::io::without_path(path, &e.to_string()),
            })
        })?;
        let text = String::from_utf8(bytes)
            .map_err(|_| bad("not UTF-8 text: save the file as UTF-8".into()))?;
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        let parsed: StudyFile = toml::from_str(text).map_err(|e| {
            bad(format!(
                "{}: a study lists [[sample]] tables with `name` and `sessions`, and optionally `fem` and `error_bars` (std or ci95) (see `bendscope study --help`)",
                toml_error_line(text, &e)
            ))
        })?;
        let base = path.parent().unwrap_or(Path::new(""));
        let rel = |s: &str| base.join(s);
        let mut fem: Vec<PathBuf> = parsed
            .fem
            .map(OneOrMany::into_vec)
            .unwrap_or_default()
            .iter()
            .map(|s| rel(s.as_str()))
            .collect();
        let mut samples = Vec::new();
        for s in parsed.sample {
            for f in s.fem.map(OneOrMany::into_vec).unwrap_or_default() {
                let f = rel(f.as_str());
                if !fem.contains(&f) {
                    fem.push(f);
                }
            }
            samples.push(SampleSpec {
                name: s.name,
                sessions: s.sessions.iter().map(|p| rel(p.as_str())).collect(),
            });
        }
        let spec = StudySpec {
            samples,
            fem,
            origin: file,
            error_bars: parsed.error_bars,
        };
        spec.check()?;
        Ok(spec)
    }

    /// The study of the flags: each `sample` is `NAME=PATH,PATH,...`; paths as given.
    pub fn from_flags(samples: &[String], fem: &[PathBuf]) -> Result<StudySpec, StudyError> {
        let origin = "--sample".to_string();
        let mut out = Vec::new();
        for s in samples {
            let Some((name, paths)) = s.split_once('=') else {
                return Err(StudyError::Config {
                    file: origin,
                    why: format!(
                        "`{s}`: give a sample as NAME=OUT,OUT,... (process output folders), e.g. --sample A=A-run1/bendscope-out,A-run2/bendscope-out"
                    ),
                });
            };
            out.push(SampleSpec {
                name: name.trim().to_string(),
                sessions: paths
                    .split(',')
                    .map(str::trim)
                    .filter(|p| !p.is_empty())
                    .map(PathBuf::from)
                    .collect(),
            });
        }
        let spec = StudySpec {
            samples: out,
            fem: fem.to_vec(),
            origin,
            error_bars: crate::report::ErrorBars::default(),
        };
        spec.check()?;
        Ok(spec)
    }

    /// Checks what needs no file: at least one sample, names given, unique and not
    /// [`POOLED`], every sample with sessions, no session listed twice.
    pub fn check(&self) -> Result<(), StudyError> {
        let bad = |why: String| StudyError::Config {
            file: self.origin.clone(),
            why,
        };
        if self.samples.is_empty() {
            return Err(bad(
                "no sample: list each sample as [[sample]] name = \"A\", sessions = [\"A-run1/bendscope-out\", ...]".into(),
            ));
        }
        let mut seen: Vec<&str> = Vec::new();
        for s in &self.samples {
            let name = s.name.trim();
            if name.is_empty() {
                return Err(bad(
                    "a sample has an empty name: give each sample a name".into()
                ));
            }
            if name.eq_ignore_ascii_case(POOLED) {
                return Err(bad(format!(
                    "sample name `{}` is taken by the pooled rows: rename the sample",
                    s.name
                )));
            }
            if seen.contains(&name) {
                return Err(bad(format!(
                    "sample `{name}` is listed twice: give each sample one entry with all its sessions"
                )));
            }
            seen.push(name);
            if s.sessions.is_empty() {
                return Err(bad(format!(
                    "sample `{name}` has no session: list its process output folders in `sessions`, or remove the sample"
                )));
            }
        }
        let all: Vec<&PathBuf> = self.samples.iter().flat_map(|s| &s.sessions).collect();
        let key = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
        let keys: Vec<PathBuf> = all.iter().map(|p| key(p.as_path())).collect();
        for (i, p) in all.iter().enumerate() {
            if keys[..i].contains(&keys[i]) {
                return Err(bad(format!(
                    "session {} is listed twice: a session belongs to one sample, once",
                    p.display()
                )));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<StudySpec, String> {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("study.toml");
        std::fs::write(&p, text).unwrap();
        StudySpec::read(&p).map_err(|e| {
            e.to_string()
                .replace(&d.path().display().to_string(), "DIR")
        })
    }

    #[test]
    fn study_toml_is_read_relative_to_its_folder() {
        let s = read(
            "fem = \"sim\"\n[[sample]]\nname = \"A\"\nsessions = [\"a1\", \"a2\"]\n[[sample]]\nname = \"B\"\nsessions = [\"b1\"]\nfem = [\"sim\", \"sim2/\"]\n",
        )
        .unwrap();
        assert_eq!(s.samples.len(), 2);
        assert_eq!(s.samples[0].sessions.len(), 2);
        assert!(s.samples[0].sessions[0].ends_with("a1"));
        assert!(s.samples[0].sessions[0].is_absolute());
        // `fem` inside the last sample (where TOML puts it) joins the study's, once.
        assert_eq!(s.fem.len(), 2, "{:?}", s.fem);
    }

    #[test]
    fn bad_study_toml_is_one_line_naming_the_key() {
        for (text, needle) in [
            ("[[sample]]\nname = \"A\"\nsessions = [\"a\"]\nrepeats = 3\n", "line 4: unknown key `repeats`"),
            ("[[sample]]\nname = \"A\"\nsessions = []\n", "sample `A` has no session"),
            ("[[sample]]\nname = \"A\"\nsessions = [\"a\"]\n[[sample]]\nname = \"A\"\nsessions = [\"b\"]\n", "sample `A` is listed twice"),
            ("[[sample]]\nname = \"all\"\nsessions = [\"a\"]\n", "taken by the pooled rows"),
            ("fem = \"sim\"\n", "no sample"),
            ("[[sample]]\nname = \"A\"\nsessions = [\"a\", \"a\"]\n", "listed twice"),
            ("[[sample]]\nname = \"A\"\n", "missing field `sessions`"),
        ] {
            let e = read(text).unwrap_err();
            assert!(e.starts_with("DIR/study.toml: "), "{e}");
            assert!(e.contains(needle), "{text}: {e}");
            assert!(!e.contains('\n'), "one line: {e}");
        }
    }

    #[test]
    fn flags_name_their_samples() {
        let s = StudySpec::from_flags(&["A=x/1,x/2".into(), "B=y".into()], &[]).unwrap();
        assert_eq!(
            s.samples[0].sessions,
            vec![PathBuf::from("x/1"), "x/2".into()]
        );
        let e = StudySpec::from_flags(&["A".into()], &[])
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("--sample: `A`: give a sample as NAME=OUT"),
            "{e}"
        );
        let e = StudySpec::from_flags(&["A=".into()], &[])
            .unwrap_err()
            .to_string();
        assert!(e.contains("sample `A` has no session"), "{e}");
    }
}
