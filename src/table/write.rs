//! Writing tables: named columns of text, numbers with a fixed number of decimals or
//! counts, through a polars `DataFrame` and its `CsvWriter`, then atomically
//! ([`crate::io::write_atomic`]).

use std::path::Path;

use polars::prelude::{CsvWriter, DataFrame, NamedFrom, SerWriter, Series};

use super::TableError;
use crate::io::write_atomic;

/// The cells of one written column.
#[derive(Debug, Clone, PartialEq)]
pub enum Cells {
    /// Text; empty strings are empty cells, others are quoted when needed.
    Text(Vec<String>),
    /// Numbers with `decimals` digits after the point; NaN is an empty cell, infinities
    /// are `inf` and `-inf`.
    Num {
        /// Values.
        values: Vec<f64>,
        /// Digits after the decimal point.
        decimals: usize,
    },
    /// Counts.
    Int(Vec<u64>),
}

impl Cells {
    /// Number of cells.
    pub fn len(&self) -> usize {
        match self {
            Cells::Text(v) => v.len(),
            Cells::Num { values, .. } => values.len(),
            Cells::Int(v) => v.len(),
        }
    }

    /// True when there are no cells.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A named column of a table to write.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    /// Header.
    pub name: String,
    /// Cells.
    pub cells: Cells,
}

impl Column {
    /// A text column.
    pub fn text(name: impl Into<String>, values: impl IntoIterator<Item = String>) -> Self {
        Self {
            name: name.into(),
            cells: Cells::Text(values.into_iter().collect()),
        }
    }

    /// A numeric column written with `decimals` digits after the point.
    pub fn num(
        name: impl Into<String>,
        decimals: usize,
        values: impl IntoIterator<Item = f64>,
    ) -> Self {
        Self {
            name: name.into(),
            cells: Cells::Num {
                values: values.into_iter().collect(),
                decimals,
            },
        }
    }

    /// A column of counts.
    pub fn int(name: impl Into<String>, values: impl IntoIterator<Item = u64>) -> Self {
        Self {
            name: name.into(),
            cells: Cells::Int(values.into_iter().collect()),
        }
    }
}

/// A number as a CSV cell: `None` (empty) when NaN, `inf`/`-inf` when infinite, else
/// `decimals` digits after the point.
fn num_cell(v: f64, decimals: usize) -> Option<String> {
    if v.is_nan() {
        None
    } else if v.is_infinite() {
        Some(if v > 0.0 { "inf" } else { "-inf" }.to_string())
    } else {
        Some(format!("{v:.decimals$}"))
    }
}

/// The CSV text of `columns` (header and rows), through a polars `DataFrame`.
fn csv_bytes(columns: &[Column]) -> Result<Vec<u8>, String> {
    let Some(first) = columns.first() else {
        return Ok(Vec::new());
    };
    let height = first.cells.len();
    if let Some(c) = columns.iter().find(|c| c.cells.len() != height) {
        return Err(format!(
            "column `{}` has {} rows and `{}` has {height}: a table needs columns of one length",
            c.name,
            c.cells.len(),
            first.name
        ));
    }
    let series: Vec<polars::prelude::Column> = columns
        .iter()
        .map(|c| {
            let name = c.name.as_str().into();
            let s = match &c.cells {
                Cells::Text(v) => Series::new(
                    name,
                    v.iter()
                        .map(|s| Some(s.as_str()).filter(|s| !s.is_empty()))
                        .collect::<Vec<_>>(),
                ),
                Cells::Num { values, decimals } => Series::new(
                    name,
                    values
                        .iter()
                        .map(|v| num_cell(*v, *decimals))
                        .collect::<Vec<_>>(),
                ),
                Cells::Int(v) => Series::new(name, v.as_slice()),
            };
            s.into()
        })
        .collect();
    let mut df = DataFrame::new(height, series).map_err(|e| e.to_string())?;
    let mut buf = Vec::new();
    CsvWriter::new(&mut buf)
        .include_header(true)
        .finish(&mut df)
        .map_err(|e| e.to_string())?;
    Ok(buf)
}

/// Writes `columns` as a CSV file at `path`, atomically.
pub fn write_csv(path: &Path, columns: &[Column]) -> Result<(), TableError> {
    let bytes = csv_bytes(columns).map_err(|why| TableError::file(path, why))?;
    write_atomic(path, &bytes).map_err(|e| {
        let why = crate::io::without_path(path, &e.to_string());
        TableError::file(path, format!("cannot write: {why}"))
    })
}
