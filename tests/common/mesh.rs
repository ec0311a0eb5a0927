//! Helpers of the imported-mesh tests (tests/tetrahedra.rs, tests/mesh_parts.rs).

use std::path::Path;

use super::{read_csv, Run};

/// `simulate --config model.toml ARGS` with `config` in `dir` is refused in one line
/// holding `needles` (exit 2) and writes no results.
pub fn assert_refused(dir: &Path, config: &str, args: &[&str], needles: &[&str]) {
    std::fs::write(dir.join("model.toml"), config).unwrap();
    let mut all = vec![
        "simulate",
        "--config",
        "model.toml",
        "-o",
        "out",
        "--no-vtu",
    ];
    all.extend_from_slice(args);
    let run = Run::new(dir, &all);
    run.assert_bad_input(needles);
    assert!(!dir.join("out/steps.csv").exists(), "{config}: {run}");
    assert!(!dir.join("out/config.toml").exists(), "{config}: {run}");
}

/// Rows of a CSV file as numbers by column name: `get(row, name)`.
pub fn table(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let (header, rows) = read_csv(path);
    let rows = rows
        .iter()
        .map(|r| r.iter().map(|c| c.parse().unwrap_or(f64::NAN)).collect())
        .collect();
    (header, rows)
}
