//! The design table (`designs.csv` of `bendscope sweep`): one row per design point, a
//! `status` column (`ok` when the point's ramp finished), one column per factor
//! (`geometry.f`) and the results (`radius_mm@100`, `height_mm`, ...). Read through
//! [`crate::table::Table`].

use std::path::{Path, PathBuf};

use super::SurrogateError;
use crate::table::Table;

/// Status of a design point whose simulation finished.
pub const STATUS_OK: &str = "ok";

/// Columns of a design table: inputs and outputs of the rows whose status is `ok`.
#[derive(Debug, Clone, PartialEq)]
pub struct Designs {
    /// The file.
    pub path: PathBuf,
    /// Input column names.
    pub inputs: Vec<String>,
    /// Output column names.
    pub outputs: Vec<String>,
    /// `id` of each kept row (the 1-based row number when the table has no `id`).
    pub ids: Vec<String>,
    /// Inputs of each kept row (NaN for an empty cell).
    pub x: Vec<Vec<f64>>,
    /// Outputs of each kept row, in the order of `outputs` (NaN for an empty cell).
    pub y: Vec<Vec<f64>>,
    /// Rows left out because their status is not `ok`.
    pub not_ok: usize,
}

/// The points a model of one output is fitted on.
#[derive(Debug, Clone, PartialEq)]
pub struct Training {
    /// Inputs per point.
    pub x: Vec<Vec<f64>>,
    /// The output per point.
    pub y: Vec<f64>,
    /// Row id per point.
    pub ids: Vec<String>,
    /// Rows left out (status not ok, or a non-finite input or output).
    pub skipped: usize,
}

/// A cell as a number: empty is NaN, `inf`/`-inf` are infinities.
fn number(table: &Table, row: usize, col: usize) -> Result<f64, SurrogateError> {
    if table.cell(row, col).trim().is_empty() {
        return Ok(f64::NAN);
    }
    Ok(table.f64_at(row, col)?)
}

/// Reads the rows of `path` whose status is `ok` (every row when there is no `status`
/// column), with the columns `inputs` and `outputs`.
pub fn read_designs(
    path: &Path,
    inputs: &[String],
    outputs: &[String],
) -> Result<Designs, SurrogateError> {
    let table = Table::read(path)?;
    let find = |name: &String| {
        table.column(name).ok_or_else(|| SurrogateError::NoColumn {
            path: path.to_path_buf(),
            name: name.clone(),
            available: table.columns().join(", "),
        })
    };
    let in_cols = inputs.iter().map(find).collect::<Result<Vec<_>, _>>()?;
    let out_cols = outputs.iter().map(find).collect::<Result<Vec<_>, _>>()?;
    let status = table.column("status");
    let id = table.column("id");
    let mut d = Designs {
        path: path.to_path_buf(),
        inputs: inputs.to_vec(),
        outputs: outputs.to_vec(),
        ids: Vec::new(),
        x: Vec::new(),
        y: Vec::new(),
        not_ok: 0,
    };
    for row in 0..table.len() {
        if status.is_some_and(|c| table.cell(row, c).trim() != STATUS_OK) {
            d.not_ok += 1;
            continue;
        }
        d.ids.push(match id {
            Some(c) => table.cell(row, c).trim().to_string(),
            None => (row + 1).to_string(),
        });
        d.x.push(
            in_cols
                .iter()
                .map(|c| number(&table, row, *c))
                .collect::<Result<_, _>>()?,
        );
        d.y.push(
            out_cols
                .iter()
                .map(|c| number(&table, row, *c))
                .collect::<Result<_, _>>()?,
        );
    }
    Ok(d)
}

impl Designs {
    /// The points with finite inputs and a finite value of `output`.
    pub fn training(&self, output: &str) -> Result<Training, SurrogateError> {
        let k = self
            .outputs
            .iter()
            .position(|o| o == output)
            .ok_or_else(|| SurrogateError::NoColumn {
                path: self.path.clone(),
                name: output.to_string(),
                available: self.outputs.join(", "),
            })?;
        let mut t = Training {
            x: Vec::new(),
            y: Vec::new(),
            ids: Vec::new(),
            skipped: self.not_ok,
        };
        for ((x, y), id) in self.x.iter().zip(&self.y).zip(&self.ids) {
            if x.iter().all(|v| v.is_finite()) && y[k].is_finite() {
                t.x.push(x.clone());
                t.y.push(y[k]);
                t.ids.push(id.clone());
            } else {
                t.skipped += 1;
            }
        }
        Ok(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_not_ok_and_empty_cells_are_left_out() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("designs.csv");
        std::fs::write(
            &path,
            "id,status,geometry.f,radius_mm@100\n1,ok,3,50.5\n2,failed: diverged,4,\n3,ok,5,\n4,ok,6,70\n",
        )
        .unwrap();
        let d = read_designs(&path, &["geometry.f".into()], &["radius_mm@100".into()]).unwrap();
        assert_eq!(d.not_ok, 1);
        let t = d.training("radius_mm@100").unwrap();
        assert_eq!(t.x, vec![vec![3.0], vec![6.0]]);
        assert_eq!(t.y, vec![50.5, 70.0]);
        assert_eq!(t.ids, vec!["1", "4"]);
        assert_eq!(t.skipped, 2);
        let e = read_designs(&path, &["geometry.q".into()], &[]).unwrap_err();
        assert!(e.to_string().contains("no column `geometry.q`"), "{e}");
    }
}
