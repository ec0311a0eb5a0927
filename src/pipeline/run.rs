//! What a run takes and gives: [`ProcessSettings`] beside the session's own settings,
//! [`Progress`] (where progress bars and notes go), [`SessionOutcome`]; and a session's
//! issues as a few stderr lines however many rows share one.

use std::path::PathBuf;

use super::provenance::Provenance;
use super::records::VideoRecord;

/// How `process` runs, beside what the session's bendscope.toml says.
#[derive(Debug, Clone, Default)]
pub struct ProcessSettings {
    /// Calibration file to use (else the session's `calibration` key, else calib/).
    pub calibration: Option<PathBuf>,
    /// Settings file (else SESSION/bendscope.toml when present).
    pub config: Option<PathBuf>,
    /// Redo videos whose cached results are current.
    pub force: bool,
    /// What the plots' error bars show (else the session's `error_bars`, else std).
    pub error_bars: Option<crate::report::ErrorBars>,
}

/// Where progress and warnings go (the CLI draws bars and prints lines on stderr).
pub trait Progress {
    /// A stage with `total` steps begins.
    fn start(&mut self, _what: &str, _total: u64) {}
    /// The item being worked on.
    fn item(&mut self, _name: &str) {}
    /// `n` steps done.
    fn advance(&mut self, _n: u64) {}
    /// Within the current item (a video): `done` frames measured of about `expected`
    /// (0 when unknown). Called for every frame: a long video shows where it is.
    fn frames(&mut self, _done: u64, _expected: u64) {}
    /// The stage is done.
    fn finish(&mut self) {}
    /// A line for the user (a warning or a note), already naming its file.
    fn note(&mut self, _line: &str) {}
}

/// A [`Progress`] that shows nothing.
#[derive(Debug, Default)]
pub struct Quiet;

impl Progress for Quiet {}

/// What a session gave.
#[derive(Debug, Clone)]
pub struct SessionOutcome {
    /// Where its results are.
    pub out: PathBuf,
    /// Rows of per_video.csv (videos, or pressure bins of a ramp).
    pub videos: Vec<VideoRecord>,
    /// Items measured (videos, or the one ramp/RGB-D recording).
    pub measured: usize,
    /// Items that failed or were skipped.
    pub failed: usize,
    /// Warnings and notes, as given to [`Progress::note`].
    pub notes: Vec<String>,
    /// How the results were made (what `session.json` holds).
    pub provenance: Provenance,
}

/// Collects notes for the outcome and passes them to the caller's progress.
pub(super) struct Notes<'a> {
    pub(super) lines: Vec<String>,
    pub(super) progress: &'a mut dyn Progress,
}

impl Notes<'_> {
    pub(super) fn push(&mut self, line: String) {
        self.progress.note(&line);
        self.lines.push(line);
    }
}

/// Lines printed for one kind of session issue (one message) before the rest are
/// counted in one line.
pub const ISSUE_LINES_PER_KIND: usize = 5;

/// The stderr lines of a session's `issues`: each kind (one message) for its first
/// [`ISSUE_LINES_PER_KIND`] rows, then the rest counted in one line, so that a manifest
/// of thousands of rows naming missing videos gives a few lines, not one per row (every
/// row is still in per_video.csv).
pub(super) fn issue_lines(issues: &[crate::session::SessionIssue]) -> Vec<String> {
    let mut lines = Vec::new();
    let mut kinds: Vec<(&str, usize)> = Vec::new();
    let mut kind_of: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
    for issue in issues {
        let k = *kind_of.entry(issue.message.as_str()).or_insert_with(|| {
            kinds.push((issue.message.as_str(), 0));
            kinds.len() - 1
        });
        kinds[k].1 += 1;
        if kinds[k].1 <= ISSUE_LINES_PER_KIND {
            lines.push(issue_line(issue));
        }
    }
    for (message, n) in kinds.iter().filter(|(_, n)| *n > ISSUE_LINES_PER_KIND) {
        lines.push(format!(
            "warning: {} more rows or files: {message} (all are listed in per_video.csv)",
            n - ISSUE_LINES_PER_KIND
        ));
    }
    lines
}

/// A session issue as a stderr line: `warning: FILE (line N): message`.
pub(super) fn issue_line(issue: &crate::session::SessionIssue) -> String {
    let line = issue
        .line
        .map(|l| format!(" (line {l})"))
        .unwrap_or_default();
    format!("warning: {}{line}: {}", issue.file, issue.message)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session::SessionIssue;

    #[test]
    fn many_rows_with_one_problem_are_summarised_after_the_first_few() {
        let issue = |i: usize, message: &str| SessionIssue {
            file: format!("V{i}.MP4"),
            line: Some(i + 2),
            message: message.into(),
        };
        let mut issues: Vec<SessionIssue> = (0..1000).map(|i| issue(i, "no such video")).collect();
        issues.insert(3, issue(9999, "listed twice"));
        let lines = issue_lines(&issues);
        assert_eq!(lines.len(), ISSUE_LINES_PER_KIND + 2, "{lines:#?}");
        assert_eq!(lines[0], "warning: V0.MP4 (line 2): no such video");
        assert_eq!(lines[3], "warning: V9999.MP4 (line 10001): listed twice");
        assert_eq!(
            lines.last().unwrap(),
            &format!(
                "warning: {} more rows or files: no such video (all are listed in per_video.csv)",
                1000 - ISSUE_LINES_PER_KIND
            )
        );
    }
}
