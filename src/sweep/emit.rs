//! Scripts for a cluster's own engine, written and never run: `jobs.txt` for GNU parallel
//! (`parallel < DIR/jobs.txt`, `--sshloginfile` to spread it over hosts) and
//! `sweep.sbatch` for Slurm (`sbatch DIR/sweep.sbatch`: a job array, one task per point).
//! Every command names the `bendscope` binary and the sweep folder by absolute path, so
//! it runs from any working directory (on other hosts: the same paths on a shared file
//! system). `bendscope sweep collect DIR` then merges the finished points.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::run::Prepared;
use super::SweepError;
use crate::io::write_atomic;

/// `s` quoted for a POSIX shell (single quotes; a quote inside as `'\''`).
pub fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// The command that runs one point.
pub fn point_command(exe: &Path, dir: &Path, id: &str) -> String {
    format!(
        "{} sweep run-point {} {}",
        shell_quote(&exe.to_string_lossy()),
        shell_quote(&dir.to_string_lossy()),
        shell_quote(id)
    )
}

/// Writes `DIR/jobs.txt`: one command per point still to run.
pub fn write_parallel_jobs(prepared: &Prepared, exe: &Path) -> Result<PathBuf, SweepError> {
    let path = prepared.dir.join("jobs.txt");
    let text: String = prepared
        .pending
        .iter()
        .map(|id| point_command(exe, &prepared.dir, id) + "\n")
        .collect();
    write_atomic(&path, text.as_bytes()).map_err(|e| SweepError::io(&path, e))?;
    Ok(path)
}

/// Writes `DIR/sweep.sbatch`: a Slurm job array over the points still to run, with the
/// plan's `[cluster]` resources; each task's output goes to `DIR/slurm/`.
pub fn write_slurm(prepared: &Prepared, exe: &Path) -> Result<PathBuf, SweepError> {
    let dir = &prepared.dir;
    let c = &prepared.manifest.cluster;
    let path = dir.join("sweep.sbatch");
    let logs = dir.join("slurm");
    std::fs::create_dir_all(&logs).map_err(|e| SweepError::io(&logs, e))?;
    let n = prepared.pending.len();
    let mut s = String::from("#!/bin/bash\n");
    let _ = writeln!(s, "# bendscope sweep: {n} point(s) of {}", dir.display());
    let _ = writeln!(s, "#SBATCH --job-name={}", c.job_name);
    let throttle = c
        .max_concurrent
        .map(|m| format!("%{m}"))
        .unwrap_or_default();
    let _ = writeln!(s, "#SBATCH --array=0-{}{throttle}", n.saturating_sub(1));
    let _ = writeln!(s, "#SBATCH --ntasks=1");
    let _ = writeln!(s, "#SBATCH --cpus-per-task={}", c.cpus_per_task);
    let _ = writeln!(s, "#SBATCH --mem={}M", c.memory_mb);
    let _ = writeln!(s, "#SBATCH --time={}", c.time_limit);
    if let Some(p) = &c.partition {
        let _ = writeln!(s, "#SBATCH --partition={p}");
    }
    if let Some(a) = &c.account {
        let _ = writeln!(s, "#SBATCH --account={a}");
    }
    let _ = writeln!(s, "#SBATCH --output={}/%A_%a.out", logs.display());
    let _ = writeln!(s, "set -eu");
    let ids: Vec<String> = prepared.pending.iter().map(|i| shell_quote(i)).collect();
    let _ = writeln!(s, "ids=({})", ids.join(" "));
    let _ = writeln!(
        s,
        "export RAYON_NUM_THREADS=\"${{SLURM_CPUS_PER_TASK:-1}}\""
    );
    let _ = writeln!(
        s,
        "exec {} sweep run-point {} \"${{ids[$SLURM_ARRAY_TASK_ID]}}\"",
        shell_quote(&exe.to_string_lossy()),
        shell_quote(&dir.to_string_lossy())
    );
    write_atomic(&path, s.as_bytes()).map_err(|e| SweepError::io(&path, e))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quoting_survives_spaces_and_quotes() {
        assert_eq!(shell_quote("a b"), "'a b'");
        assert_eq!(shell_quote("it's"), r"'it'\''s'");
        assert_eq!(
            point_command(Path::new("/x/bendscope"), Path::new("/d ir"), "p001"),
            "'/x/bendscope' sweep run-point '/d ir' 'p001'"
        );
    }
}
