//! Tables: the one CSV layer. Every CSV bendscope reads (manifests, pressure logs, its own
//! results) and every numeric or text table it writes goes through here, on polars.
//!
//! Reading ([`Table::read`], [`Table::parse`]) is forgiving about how the file was saved
//! and precise about what is wrong in it:
//!
//! - a UTF-8 byte order mark (spreadsheets write one) is dropped;
//! - the separator is found in the header line: a comma, a semicolon or a tab, whichever
//!   it has most of outside quotes (a European spreadsheet's default is `;` with decimal
//!   commas); with a semicolon or a tab, numbers may have a decimal comma (`40,5`). A
//!   header split by another character ([`ODD_SEPARATORS`]: `|`, `:`, ...) is refused,
//!   naming it, rather than read as one column;
//! - line ends may be LF, CRLF or CR; blank lines are skipped;
//! - fields may be quoted (`"a, b"`, `"say ""hi"""`), also across lines, with spaces
//!   around the quotes; quoting is otherwise checked as RFC 4180 has it: a `"` in an
//!   unquoted field, text after a closing quote or a quote never closed is an error at
//!   its line (not rows silently merged);
//! - every cell is read as text (no type inference): the caller asks for a number with
//!   [`Table::f64_at`], whose error names the file, the line and the column;
//! - header names are trimmed and looked up case-insensitively;
//! - rows shorter than the header read as empty cells; a row with more (non-blank)
//!   fields than the header is an error at its line (in a comma-separated file most
//!   often a decimal comma: `GX010101.MP4,20,5`), as is a row split by another separator
//!   than the header's.
//!
//! polars splits records on line ends outside quotes, counting every `"` (a quote inside
//! an unquoted field flips the state too). [`Table::parse`] does the same small scan
//! first, to drop blank lines, check the quoting and remember the line each row starts
//! on, which polars does not report; polars then reads the cleaned records.
//!
//! Writing ([`write_csv`]): named columns of text, numbers with a fixed number of decimals
//! (NaN: empty cell; infinities: `inf`, `-inf`) or counts, built as a polars `DataFrame`,
//! written with its `CsvWriter` (fields quoted when needed) and then atomically
//! ([`crate::io::write_atomic`]).

use std::io::Cursor;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use polars::prelude::{CsvReadOptions, DataFrame, SerReader};

mod write;
pub use write::{write_csv, Cells, Column};

/// The UTF-8 byte order mark.
const UTF8_BOM: &[u8] = b"\xEF\xBB\xBF";

/// Characters that separate a header's columns in files bendscope does not read (a header
/// with one of them and no comma, semicolon or tab is refused naming it).
pub const ODD_SEPARATORS: [char; 5] = ['|', ':', '^', '~', '!'];

/// The separator of a table file's fields, found in its header line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Separator {
    /// `,` (numbers with a decimal point only).
    #[default]
    Comma,
    /// `;` (a European spreadsheet's CSV: numbers may have a decimal comma).
    Semicolon,
    /// A tab (numbers may have a decimal comma).
    Tab,
}

impl Separator {
    /// The byte between fields.
    pub fn byte(self) -> u8 {
        match self {
            Separator::Comma => b',',
            Separator::Semicolon => b';',
            Separator::Tab => b'\t',
        }
    }

    /// Its name, for messages.
    pub fn name(self) -> &'static str {
        match self {
            Separator::Comma => "comma",
            Separator::Semicolon => "semicolon",
            Separator::Tab => "tab",
        }
    }

    /// The separator of a file whose header record is `header`: the one of comma,
    /// semicolon and tab found most often outside quotes (a tie goes to the comma, then
    /// the semicolon); a comma when there is none of them (one column). An error is an
    /// odd separator ([`ODD_SEPARATORS`]) found instead.
    pub fn of_header(header: &str) -> Result<Separator, char> {
        let mut counts = [0usize; 3];
        let mut odd = None;
        let mut quoted = false;
        for c in header.chars() {
            match c {
                '"' => quoted = !quoted,
                _ if quoted => {}
                ',' => counts[0] += 1,
                ';' => counts[1] += 1,
                '\t' => counts[2] += 1,
                c if ODD_SEPARATORS.contains(&c) => {
                    odd.get_or_insert(c);
                }
                _ => {}
            }
        }
        let all = [Separator::Comma, Separator::Semicolon, Separator::Tab];
        let best = (0..3).fold(0, |b, k| if counts[k] > counts[b] { k } else { b });
        match (counts[best], odd) {
            (0, Some(c)) => Err(c),
            _ => Ok(all[best]),
        }
    }
}

/// `raw` as a number, with a decimal comma (`40,5`, one comma and no point) read as a
/// decimal point when `decimal_comma` holds.
fn parse_number(raw: &str, decimal_comma: bool) -> Option<f64> {
    if let Ok(v) = raw.parse::<f64>() {
        return Some(v);
    }
    let one_comma = raw.bytes().filter(|b| *b == b',').count() == 1 && !raw.contains('.');
    if decimal_comma && one_comma {
        raw.replace(',', ".").parse::<f64>().ok()
    } else {
        None
    }
}

/// A problem with a table file: where it is (file, and line and column when known) and
/// what to do.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{path}{}{}: {why}", line_part(.line), column_part(.line, .column))]
pub struct TableError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line in the file, when the problem is on one line.
    pub line: Option<usize>,
    /// Column name, when the problem is in one column.
    pub column: Option<String>,
    /// What is wrong and what to do.
    pub why: String,
}

fn line_part(line: &Option<usize>) -> String {
    line.map(|l| format!(": line {l}")).unwrap_or_default()
}

fn column_part(line: &Option<usize>, column: &Option<String>) -> String {
    match (line, column) {
        (Some(_), Some(c)) => format!(", column {c}"),
        (None, Some(c)) => format!(": column {c}"),
        (_, None) => String::new(),
    }
}

impl TableError {
    /// An error about the whole file.
    pub fn file(path: &Path, why: impl Into<String>) -> Self {
        Self {
            path: path.to_path_buf(),
            line: None,
            column: None,
            why: why.into(),
        }
    }
}

/// A CSV file read as text cells: a header and rows, each row with its line in the file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    path: PathBuf,
    separator: Separator,
    header_line: usize,
    columns: Vec<String>,
    /// Cells by column, then row.
    cells: Vec<Vec<String>>,
    /// 1-based line each row starts on.
    lines: Vec<usize>,
}

/// One record of the file as found by [`records`]: its text (line end removed) and the
/// 1-based line it starts on.
struct Record<'a> {
    text: &'a str,
    line: usize,
}

/// Splits `text` into records the way polars does (a line end ends a record unless an odd
/// number of `"` came before it in the record), with CRLF, LF or CR as line ends; blank
/// records are dropped.
fn records(text: &str) -> Vec<Record<'_>> {
    fn keep<'a>(out: &mut Vec<Record<'a>>, text: &'a str, line: usize) {
        if !text.trim().is_empty() {
            out.push(Record { text, line });
        }
    }
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let (mut line, mut start, mut start_line) = (1, 0, 1);
    let mut quoted = false;
    let mut i = 0;
    while i < bytes.len() {
        let b = bytes[i];
        if b == b'"' {
            quoted = !quoted;
        }
        let eol_len = match b {
            b'\r' if bytes.get(i + 1) == Some(&b'\n') => 2,
            b'\r' | b'\n' => 1,
            _ => 0,
        };
        if eol_len == 0 {
            i += 1;
            continue;
        }
        line += 1;
        if !quoted {
            keep(&mut out, &text[start..i], start_line);
            start = i + eol_len;
            start_line = line;
        }
        i += eol_len;
    }
    keep(&mut out, &text[start..], start_line);
    out
}

/// 1-based line of byte `offset` in `bytes` (CRLF, LF or CR line ends).
fn line_of_offset(bytes: &[u8], offset: usize) -> usize {
    let head = &bytes[..offset.min(bytes.len())];
    let crlf = head.windows(2).filter(|w| w == b"\r\n").count();
    let breaks = head.iter().filter(|b| **b == b'\n' || **b == b'\r').count();
    1 + breaks - crlf
}

/// One record as [`normalize_quotes`] returns it.
struct Normalized {
    /// The record as polars should read it.
    text: String,
    /// Number of fields.
    fields: usize,
    /// 1-based number of the last field that is not blank (0 when all are).
    filled: usize,
}

/// Checks the quoting of one record (RFC 4180) with fields separated by `sep` and returns
/// it as polars should read it: a field is either unquoted and free of `"`, or quoted
/// (inner quotes doubled), with optional spaces (or tabs, when tabs do not separate the
/// fields) around the quotes, which are dropped. An error is the byte
/// offset of the first problem and what it is.
///
/// polars accepts a `"` inside an unquoted field as text, but its record splitting (like
/// [`records`]) still counts it, so one stray quote silently merges the lines after it;
/// and it rejects text after a closing quote with a message about data types. Both are
/// reported here instead, at their line.
fn normalize_quotes(rec: &str, sep: u8) -> Result<Normalized, (usize, &'static str)> {
    let b = rec.as_bytes();
    let blank = |c: &u8| *c == b' ' || (*c == b'\t' && sep != b'\t');
    let mut out = String::with_capacity(rec.len());
    let (mut fields, mut filled) = (0, 0);
    let mut i = 0;
    loop {
        fields += 1;
        let start = i;
        while b.get(i).is_some_and(blank) {
            i += 1;
        }
        if b.get(i) == Some(&b'"') {
            let open = i;
            i += 1;
            loop {
                match b.get(i) {
                    None => {
                        return Err((
                            open,
                            "a quoted field is not closed: add the closing `\"` (a `\"` inside a field is written `\"\"`)",
                        ))
                    }
                    Some(b'"') if b.get(i + 1) == Some(&b'"') => i += 2,
                    Some(b'"') => {
                        i += 1;
                        break;
                    }
                    Some(_) => i += 1,
                }
            }
            out.push_str(&rec[open..i]);
            if i - open > 2 {
                filled = fields;
            }
            while b.get(i).is_some_and(blank) {
                i += 1;
            }
            match b.get(i) {
                None => return Ok(Normalized { text: out, fields, filled }),
                Some(c) if *c == sep => {
                    out.push(char::from(sep));
                    i += 1;
                }
                Some(_) => {
                    return Err((
                        i,
                        "text after the closing `\"` of a quoted field: quote the whole field and write a `\"` inside it as `\"\"`",
                    ))
                }
            }
        } else {
            while let Some(&c) = b.get(i) {
                match c {
                    c if c == sep => break,
                    b'"' => {
                        return Err((
                            i,
                            "a `\"` inside a field that does not start with one: quote the whole field and write the `\"` as `\"\"`",
                        ))
                    }
                    _ => i += 1,
                }
            }
            out.push_str(&rec[start..i]);
            if !rec[start..i].trim().is_empty() {
                filled = fields;
            }
            if i >= b.len() {
                return Ok(Normalized {
                    text: out,
                    fields,
                    filled,
                });
            }
            out.push(char::from(sep));
            i += 1;
        }
    }
}

/// Longest excerpt of a record quoted in a message.
const MAX_QUOTED_RECORD: usize = 60;

/// `text` trimmed, cut to [`MAX_QUOTED_RECORD`] characters (with `...`), for a message.
fn excerpt(text: &str) -> String {
    let text = text.trim();
    match text.char_indices().nth(MAX_QUOTED_RECORD) {
        Some((end, _)) => format!("{}...", &text[..end]),
        None => text.to_string(),
    }
}

/// Number of `byte`s in `text` outside double quotes.
fn count_unquoted(text: &str, byte: u8) -> usize {
    let mut quoted = false;
    text.bytes()
        .filter(|b| {
            if *b == b'"' {
                quoted = !quoted;
            }
            !quoted && *b == byte
        })
        .count()
}

/// What is wrong with the shape of data record `raw` (normalized: `rec`) under a header
/// `header` of `header_fields` fields separated by `sep`, if anything:
///
/// - more non-blank fields than the header: an error rather than cells dropped, since in
///   a comma-separated file it is most often a decimal comma (`GX010101.MP4,20,5` is
///   20.5 kPa, not 20); trailing blank cells (`a,b,` as some spreadsheets save rows) are
///   fine;
/// - one field only where the header has several and the row holds another separator
///   (a semicolon header over comma rows): the file mixes separators.
fn row_shape_problem(
    sep: Separator,
    header: &str,
    header_fields: usize,
    raw: &str,
    rec: &Normalized,
) -> Option<String> {
    if rec.filled > header_fields {
        let what = format!(
            "this row has {} fields where the header `{}` has {header_fields} (`{}`)",
            rec.filled,
            excerpt(header),
            excerpt(raw)
        );
        return Some(match sep {
            Separator::Comma => format!(
                "{what}: decimal comma? use a semicolon separator or a decimal point (quote a text field that holds a comma: \"a, b\")"
            ),
            _ => format!("{what}: remove the extra cells or name their column in the header"),
        });
    }
    if rec.fields == 1 && header_fields > 1 {
        let other = [Separator::Comma, Separator::Semicolon, Separator::Tab]
            .into_iter()
            .find(|s| *s != sep && count_unquoted(raw, s.byte()) > 0)?;
        return Some(format!(
            "the header is {}-separated but this row is {}-separated (`{}`): use one separator in the whole file",
            sep.name(),
            other.name(),
            excerpt(raw)
        ));
    }
    None
}

/// Reads `text` (records already cleaned: one per line, LF, fields separated by `sep`)
/// with polars as text cells, row-major, without a header. polars is called under `catch_unwind`: it is a large
/// parser fed with user files, and a panic in it must become an error, not a crash.
fn polars_rows(text: String, sep: u8) -> Result<Vec<Vec<String>>, String> {
    let read = || -> Result<DataFrame, String> {
        CsvReadOptions::default()
            .with_has_header(false)
            .with_infer_schema_length(Some(0))
            .with_raise_if_empty(false)
            .with_n_threads(Some(1))
            .map_parse_options(|o| o.with_truncate_ragged_lines(true).with_separator(sep))
            .into_reader_with_file_handle(Cursor::new(text.into_bytes()))
            .finish()
            .map_err(|e| e.to_string())
    };
    let df = match catch_unwind(AssertUnwindSafe(read)) {
        Ok(r) => r?,
        Err(_) => return Err("the CSV reader failed on this file".into()),
    };
    let mut rows = vec![Vec::with_capacity(df.width()); df.height()];
    for c in df.columns() {
        let s = c
            .cast(&polars::prelude::DataType::String)
            .map_err(|e| e.to_string())?;
        let s = s.str().map_err(|e| e.to_string())?;
        for (row, v) in rows.iter_mut().zip(s.iter()) {
            row.push(v.unwrap_or_default().to_string());
        }
    }
    Ok(rows)
}

impl Table {
    /// Reads and parses the CSV file at `path` ([`Table::parse`]).
    pub fn read(path: &Path) -> Result<Table, TableError> {
        let bytes = std::fs::read(path).map_err(|e| TableError::file(path, e.to_string()))?;
        Table::parse(&bytes, path)
    }

    /// Parses CSV `bytes`; `path` is the file they came from (named in errors). An empty
    /// file (or one of blank lines) gives a table with no columns and no rows.
    pub fn parse(bytes: &[u8], path: &Path) -> Result<Table, TableError> {
        let bom = if bytes.starts_with(UTF8_BOM) {
            UTF8_BOM.len()
        } else {
            0
        };
        let text = std::str::from_utf8(&bytes[bom..]).map_err(|e| TableError {
            path: path.to_path_buf(),
            line: Some(line_of_offset(&bytes[bom..], e.valid_up_to())),
            column: None,
            why: "not UTF-8 text: save the file as CSV UTF-8".into(),
        })?;
        let recs = records(text);
        let Some(first) = recs.first() else {
            return Ok(Table {
                path: path.to_path_buf(),
                ..Table::default()
            });
        };
        let separator = Separator::of_header(first.text).map_err(|c| TableError {
            path: path.to_path_buf(),
            line: Some(first.line),
            column: None,
            why: format!(
                "the header's columns are separated by `{c}`: bendscope reads commas, semicolons or tabs; save the file as CSV (comma- or semicolon-separated)"
            ),
        })?;
        let sep = separator.byte();
        let mut cleaned = String::with_capacity(text.len() + recs.len());
        let mut header_fields = 0;
        for (k, r) in recs.iter().enumerate() {
            let rec = normalize_quotes(r.text, sep).map_err(|(offset, why)| TableError {
                path: path.to_path_buf(),
                line: Some(r.line + line_of_offset(r.text.as_bytes(), offset) - 1),
                column: None,
                why: why.into(),
            })?;
            if k == 0 {
                header_fields = rec.fields;
            } else if let Some(why) =
                row_shape_problem(separator, first.text, header_fields, r.text, &rec)
            {
                return Err(TableError {
                    path: path.to_path_buf(),
                    line: Some(r.line),
                    column: None,
                    why,
                });
            }
            cleaned.push_str(&rec.text);
            cleaned.push('\n');
        }
        let rows = polars_rows(cleaned, sep).map_err(|e| {
            // polars' messages run over several lines, with hints for its Python API.
            let first = e.lines().next().unwrap_or_default();
            TableError::file(
                path,
                format!("not a readable CSV file ({first}): check the quotes and separators"),
            )
        })?;
        if rows.len() != recs.len() {
            return Err(TableError::file(
                path,
                format!(
                    "{} records found where {} lines were expected: check for an unclosed quote (\")",
                    rows.len(),
                    recs.len()
                ),
            ));
        }
        let mut rows = rows.into_iter();
        let columns: Vec<String> = rows
            .next()
            .unwrap_or_default()
            .iter()
            .map(|c| c.trim().to_string())
            .collect();
        let mut cells = vec![Vec::with_capacity(recs.len() - 1); columns.len()];
        for row in rows {
            let mut row = row.into_iter();
            for col in cells.iter_mut() {
                col.push(row.next().unwrap_or_default());
            }
        }
        Ok(Table {
            path: path.to_path_buf(),
            separator,
            header_line: first.line,
            columns,
            cells,
            lines: recs[1..].iter().map(|r| r.line).collect(),
        })
    }

    /// The file the table came from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The separator found in the header line (a comma for an empty file).
    pub fn separator(&self) -> Separator {
        self.separator
    }

    /// `raw` (a cell's text, trimmed) as a number: a decimal comma (`40,5`) reads as
    /// 40.5 when the file is semicolon- or tab-separated. `None` when it is not one.
    pub fn number(&self, raw: &str) -> Option<f64> {
        parse_number(raw, self.separator != Separator::Comma)
    }

    /// Header names, trimmed, in file order (empty for an empty file).
    pub fn columns(&self) -> &[String] {
        &self.columns
    }

    /// The header as written back (names joined by commas), for messages.
    pub fn header_text(&self) -> String {
        self.columns.join(",")
    }

    /// 1-based line of the header (0 for an empty file).
    pub fn header_line(&self) -> usize {
        self.header_line
    }

    /// Index of the first column named `name` (case-insensitive).
    pub fn column(&self, name: &str) -> Option<usize> {
        let name = name.to_lowercase();
        self.columns.iter().position(|c| c.to_lowercase() == name)
    }

    /// Index of column `name`, or an error naming the file, the header it has and
    /// `hint` (what the header should look like).
    pub fn require(&self, name: &str, hint: &str) -> Result<usize, TableError> {
        self.column(name).ok_or_else(|| {
            if self.columns.is_empty() {
                self.header_error(format!("empty file, no `{name}` column: {hint}"))
            } else {
                self.header_error(format!(
                    "no `{name}` column in the header `{}`: {hint}",
                    self.header_text()
                ))
            }
        })
    }

    /// An error about the header (at its line; about the file when it is empty).
    pub fn header_error(&self, why: impl Into<String>) -> TableError {
        TableError {
            path: self.path.clone(),
            line: Some(self.header_line).filter(|l| *l > 0),
            column: None,
            why: why.into(),
        }
    }

    /// Number of data rows (the header is not a row).
    pub fn len(&self) -> usize {
        self.lines.len()
    }

    /// True when there are no data rows.
    pub fn is_empty(&self) -> bool {
        self.lines.is_empty()
    }

    /// The cell at `row`, `col` as written (unquoted); empty when missing.
    pub fn cell(&self, row: usize, col: usize) -> &str {
        self.cells
            .get(col)
            .and_then(|c| c.get(row))
            .map(String::as_str)
            .unwrap_or("")
    }

    /// 1-based line of the file `row` starts on (0 when there is no such row).
    pub fn line(&self, row: usize) -> usize {
        self.lines.get(row).copied().unwrap_or(0)
    }

    /// An error at `row` (its line) and `col` (its name), either optional.
    pub fn error_at(
        &self,
        row: Option<usize>,
        col: Option<usize>,
        why: impl Into<String>,
    ) -> TableError {
        TableError {
            path: self.path.clone(),
            line: row.map(|r| self.line(r)),
            column: col.map(|c| {
                self.columns
                    .get(c)
                    .cloned()
                    .unwrap_or_else(|| format!("#{}", c + 1))
            }),
            why: why.into(),
        }
    }

    /// The cell at `row`, `col` as a number (surrounding spaces ignored; `inf` and `nan`
    /// are numbers too: check finiteness where it matters; a decimal comma as
    /// [`Table::number`] reads it). The error names the file, the line and the column.
    pub fn f64_at(&self, row: usize, col: usize) -> Result<f64, TableError> {
        let raw = self.cell(row, col).trim();
        self.number(raw).ok_or_else(|| {
            let why = if raw.is_empty() {
                "empty cell: give a number".to_string()
            } else if self.separator == Separator::Comma && parse_number(raw, true).is_some() {
                format!("`{raw}` is not a number: a decimal comma needs a semicolon- or tab-separated file (write a decimal point here)")
            } else {
                format!("`{raw}` is not a number")
            };
            self.error_at(Some(row), Some(col), why)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn parse(text: &str) -> Table {
        Table::parse(text.as_bytes(), Path::new("pressures.csv")).unwrap()
    }

    #[test]
    fn bom_crlf_quotes_and_blank_lines_read_correctly() {
        let t = parse(
            "\u{feff} File , Pressure_KPA ,note\r\n\r\nGX010001.MP4,20,\"a, b\"\r\n  \r\nGX010002.MP4,40,\"say \"\"hi\"\"\"\r\n",
        );
        assert_eq!(t.columns(), ["File", "Pressure_KPA", "note"]);
        assert_eq!(t.column("file"), Some(0));
        assert_eq!(t.column("pressure_kpa"), Some(1));
        assert_eq!(t.column("missing"), None);
        assert_eq!(t.len(), 2);
        assert_eq!(t.cell(0, 0), "GX010001.MP4");
        assert_eq!(t.cell(0, 2), "a, b");
        assert_eq!(t.cell(1, 2), "say \"hi\"");
        assert_eq!((t.line(0), t.line(1)), (3, 5));
        assert_eq!(t.header_line(), 1);
        assert_eq!(t.f64_at(1, 1).unwrap(), 40.0);
    }

    #[test]
    fn lines_count_quoted_line_breaks_and_old_mac_line_ends() {
        let t = parse("a,b\n\"two\nlines\",1\n\n3,4\n");
        assert_eq!(t.len(), 2);
        assert_eq!(t.cell(0, 0), "two\nlines");
        assert_eq!((t.line(0), t.line(1)), (2, 5));
        let t = parse("a,b\r1,2\r\r3,4");
        assert_eq!(t.len(), 2);
        assert_eq!((t.line(0), t.line(1)), (2, 4));
        assert_eq!(t.cell(1, 1), "4");
    }

    #[test]
    fn bad_quoting_is_an_error_at_its_line() {
        let t = parse("a,b\n \"x, y\"\t, \"1\" \n");
        assert_eq!((t.cell(0, 0), t.cell(0, 1)), ("x, y", "1"));
        for (text, line, what) in [
            ("a,b\n\n\"x\" y,1\n", 3, "text after the closing"),
            ("a,b\nab\"c,1\nd\",2\n", 2, "does not start with one"),
            ("a,b\n1,2\r\n\"multi\nline,1\n", 3, "not closed"),
            ("a,\"b\nc\"d\n", 2, "text after the closing"),
        ] {
            let e = Table::parse(text.as_bytes(), Path::new("x.csv")).unwrap_err();
            assert_eq!(e.line, Some(line), "{text:?}: {e}");
            assert!(e.why.contains(what), "{text:?}: {e}");
            assert!(!e.to_string().contains('\n'), "{e}");
        }
    }

    #[test]
    fn semicolons_and_tabs_separate_fields_and_allow_decimal_commas() {
        let t = parse("\u{feff}file;pressure_kpa;note\r\nGX010001.MP4;40,5;\"a; b, c\"\r\nGX010002.MP4; 55.25 ;x\r\n");
        assert_eq!(t.separator(), Separator::Semicolon);
        assert_eq!(t.columns(), ["file", "pressure_kpa", "note"]);
        assert_eq!(t.len(), 2);
        assert_eq!(t.cell(0, 2), "a; b, c");
        assert_eq!(t.f64_at(0, 1).unwrap(), 40.5);
        assert_eq!(t.f64_at(1, 1).unwrap(), 55.25);
        let e = parse("a;b\n1,2,3;4\n").f64_at(0, 0).unwrap_err();
        assert!(e.to_string().contains("`1,2,3` is not a number"), "{e}");
        let t = parse("time_s\tpressure_kpa\n0,5\t\"12,75\"\n1\t-3,5e1\n");
        assert_eq!(t.separator(), Separator::Tab);
        assert_eq!(t.columns(), ["time_s", "pressure_kpa"]);
        assert_eq!(
            (t.f64_at(0, 0).unwrap(), t.f64_at(0, 1).unwrap()),
            (0.5, 12.75)
        );
        assert_eq!(t.f64_at(1, 1).unwrap(), -35.0);
        // Commas outnumber the semicolons (quoted ones do not count): a comma file, where
        // a decimal comma is an error that says why.
        let t = parse("\"a;b;c\",x;y,z\n\"40,5\",1,2\n");
        assert_eq!(t.separator(), Separator::Comma);
        assert_eq!(t.columns(), ["a;b;c", "x;y", "z"]);
        let e = t.f64_at(0, 0).unwrap_err().to_string();
        assert!(
            e.contains("`40,5` is not a number: a decimal comma needs a semicolon"),
            "{e}"
        );
        // One column: no separator needed.
        assert_eq!(parse("time_s\n1.5\n").f64_at(0, 0).unwrap(), 1.5);
    }

    #[test]
    fn a_header_split_by_another_character_is_refused_naming_it() {
        for (text, c) in [
            ("file|pressure_kpa\nGX010001.MP4|40\n", '|'),
            ("\n\nstrain_pct:stress_kpa\n1:2\n", ':'),
        ] {
            let e = Table::parse(text.as_bytes(), Path::new("x.csv")).unwrap_err();
            assert_eq!(e.line, Some(if c == '|' { 1 } else { 3 }), "{e}");
            let msg = e.to_string();
            assert!(msg.contains(&format!("separated by `{c}`")), "{msg}");
            assert!(msg.contains("commas, semicolons or tabs"), "{msg}");
        }
        // Inside quotes it is text.
        assert_eq!(parse("\"a|b\"\n1\n").columns(), ["a|b"]);
    }

    #[test]
    fn short_rows_read_empty_and_trailing_blank_cells_are_ignored() {
        let t = parse("a,b,c\n1\n1,2,3,, \n4,5,6,\"\"\n");
        assert_eq!(t.len(), 3);
        assert_eq!((t.cell(0, 0), t.cell(0, 1), t.cell(0, 2)), ("1", "", ""));
        assert_eq!(t.cell(1, 2), "3");
        assert_eq!(t.cell(2, 2), "6");
        assert_eq!(t.cell(9, 9), "");
        assert_eq!(t.line(9), 0);
    }

    #[test]
    fn rows_with_more_fields_than_the_header_are_errors_at_their_line() {
        // A decimal comma in a comma-separated file (`20,5` is 20.5, not 20 and a stray 5).
        for (text, line, fields, header) in [
            (
                "video,pressure_kpa\nGX010101.MP4,20.5\n\nGX010102.MP4,35,5\n",
                4,
                3,
                2,
            ),
            ("file,pressure_bar\nA.MP4,0,2\n", 2, 3, 2),
            ("strain_pct,stress_kpa\n0,0\n10,20,5\n", 3, 3, 2),
            ("a,b\n1,2,,x\n", 2, 4, 2),
        ] {
            let e = Table::parse(text.as_bytes(), Path::new("pressures.csv")).unwrap_err();
            assert_eq!(e.line, Some(line), "{text:?}: {e}");
            let msg = e.to_string();
            assert!(
                msg.starts_with(&format!(
                    "pressures.csv: line {line}: this row has {fields} fields where the header"
                )),
                "{msg}"
            );
            assert!(msg.contains(&format!("has {header} (`")), "{msg}");
            assert!(
                msg.contains("decimal comma? use a semicolon separator or a decimal point"),
                "{msg}"
            );
            assert!(!msg.contains('\n'), "{msg}");
        }
        // In a semicolon file the extra cells are named, without the decimal-comma hint.
        let e = Table::parse(b"a;b\n1;2;3\n", Path::new("x.csv")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "x.csv: line 2: this row has 3 fields where the header `a;b` has 2 (`1;2;3`): remove the extra cells or name their column in the header"
        );
        // A quoted comma is text, not a field.
        assert_eq!(parse("a,b\n\"1,5\",2\n").cell(0, 0), "1,5");
    }

    #[test]
    fn rows_split_by_another_separator_than_the_header_are_errors() {
        for (text, what) in [
            ("video;pressure_kpa\nGX010101.MP4,20\n", "the header is semicolon-separated but this row is comma-separated (`GX010101.MP4,20`)"),
            ("video,pressure_kpa\nGX010101.MP4;20\n", "the header is comma-separated but this row is semicolon-separated"),
            ("a\tb\n1;5\n", "the header is tab-separated but this row is semicolon-separated"),
        ] {
            let e = Table::parse(text.as_bytes(), Path::new("x.csv")).unwrap_err();
            assert_eq!(e.line, Some(2), "{e}");
            assert!(e.to_string().contains(what), "{e}");
            assert!(e.to_string().ends_with("use one separator in the whole file"), "{e}");
        }
        // A one-column row of a several-column table is fine without another separator.
        assert_eq!(parse("a;b\nx\n").cell(0, 0), "x");
    }

    #[test]
    fn errors_name_the_file_line_and_column() {
        let t = parse("file,pressure_kpa\na,1\n\nb,2\nc,abc\nd,\n");
        let e = t.f64_at(2, 1).unwrap_err();
        assert_eq!(
            e.to_string(),
            "pressures.csv: line 5, column pressure_kpa: `abc` is not a number"
        );
        assert_eq!(e.line, Some(5));
        assert_eq!(e.column.as_deref(), Some("pressure_kpa"));
        assert!(t
            .f64_at(3, 1)
            .unwrap_err()
            .to_string()
            .contains("line 6, column pressure_kpa: empty cell"));
        let e = t
            .require("time_s", "the header is `time_s,pressure_kpa`")
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "pressures.csv: line 1: no `time_s` column in the header `file,pressure_kpa`: the header is `time_s,pressure_kpa`"
        );
        assert_eq!(
            TableError::file(Path::new("x.csv"), "gone").to_string(),
            "x.csv: gone"
        );
        let e = t.error_at(None, Some(0), "bad");
        assert_eq!(e.to_string(), "pressures.csv: column file: bad");
    }

    #[test]
    fn empty_files_have_no_columns_and_bad_bytes_are_errors() {
        for text in ["", "\n\n", "\u{feff}", "  \r\n"] {
            let t = parse(text);
            assert!(t.columns().is_empty() && t.is_empty(), "{text:?}");
            assert!(t
                .require("file", "hint")
                .unwrap_err()
                .to_string()
                .contains("empty file"));
        }
        let e = Table::parse(b"a,b\n1,2\n\xff\xfe,3\n", Path::new("x.csv")).unwrap_err();
        assert_eq!(e.line, Some(3), "{e}");
        assert!(e.to_string().contains("not UTF-8"), "{e}");
        let e = Table::read(Path::new("/nonexistent/x.csv")).unwrap_err();
        assert!(e.to_string().starts_with("/nonexistent/x.csv: "), "{e}");
    }

    #[test]
    fn written_tables_read_back() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("t.csv");
        write_csv(
            &p,
            &[
                Column::text(
                    "file",
                    ["a.mp4", "b, \"c\".mp4", "", "x\ny"].map(String::from),
                ),
                Column::num("radius_mm", 3, [1.0 / 3.0, f64::NAN, f64::INFINITY, -2.0]),
                Column::int("frames", [1, 2, 3, u64::MAX]),
            ],
        )
        .unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(
            text.starts_with(
                "file,radius_mm,frames\na.mp4,0.333,1\n\"b, \"\"c\"\".mp4\",,2\n,inf,3\n"
            ),
            "{text}"
        );
        let t = Table::read(&p).unwrap();
        assert_eq!(t.len(), 4);
        assert_eq!(t.cell(1, 0), "b, \"c\".mp4");
        assert_eq!(t.cell(3, 0), "x\ny");
        assert_eq!(t.cell(3, 1), "-2.000");
        assert_eq!(t.cell(3, 2), u64::MAX.to_string());
        assert_eq!(t.f64_at(2, 1).unwrap(), f64::INFINITY);
        let e = write_csv(&p, &[Column::int("a", [1, 2]), Column::int("b", [1])]).unwrap_err();
        assert!(
            e.to_string().contains("`b` has 1 rows and `a` has 2"),
            "{e}"
        );
    }

    /// Bytes that look like CSV often enough to reach the parser's corners: quotes,
    /// separators, every line end, a BOM, invalid UTF-8.
    fn csvish_bytes() -> impl Strategy<Value = Vec<u8>> {
        prop_oneof![
            prop::collection::vec(any::<u8>(), 0..200),
            prop::collection::vec(
                prop::sample::select(vec![
                    b'a', b'1', b'.', b',', b',', b'"', b'"', b'\n', b'\r', b' ', b'\t', 0xEF,
                    0xBB, 0xBF, 0xFF, 0,
                ]),
                0..200
            ),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        #[test]
        fn arbitrary_bytes_parse_or_fail_without_panicking(bytes in csvish_bytes()) {
            let lines = 1 + bytes.iter().filter(|b| **b == b'\n' || **b == b'\r').count();
            if let Ok(t) = Table::parse(&bytes, Path::new("x.csv")) {
                let mut last = t.header_line();
                for row in 0..t.len() {
                    prop_assert!(t.line(row) > last && t.line(row) <= lines);
                    last = t.line(row);
                    for col in 0..t.columns().len() {
                        let _ = t.cell(row, col);
                        let _ = t.f64_at(row, col);
                    }
                }
            }
        }

        #[test]
        fn text_and_numbers_survive_a_round_trip(
            rows in prop::collection::vec(
                ("[a-z ,\"\n]{0,8}", -1e6f64..1e6),
                0..12,
            )
        ) {
            let d = tempfile::tempdir().unwrap();
            let p = d.path().join("t.csv");
            write_csv(&p, &[
                Column::text("text", rows.iter().map(|r| r.0.clone())),
                Column::num("value", 6, rows.iter().map(|r| r.1)),
            ]).unwrap();
            let t = Table::read(&p).unwrap();
            prop_assert_eq!(t.len(), rows.len());
            for (i, (text, value)) in rows.iter().enumerate() {
                prop_assert_eq!(t.cell(i, 0), text.as_str());
                prop_assert!((t.f64_at(i, 1).unwrap() - value).abs() < 1e-6);
            }
        }
    }
}
