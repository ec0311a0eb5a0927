//! The sweep folder and its points: preparing it from a plan (manifest, one config per
//! point, resume), running one point (the hidden `bendscope sweep run-point`), and a
//! local pool of child processes that runs the points not yet finished.
//!
//! Each point runs in its own process (`bendscope sweep run-point DIR ID`) whichever way
//! it is launched (local pool, GNU parallel, Slurm): a point that runs out of memory or
//! crashes takes only itself down, and the numbers are the same on every launcher.

use std::collections::VecDeque;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Mutex};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use super::design::{design_points, point_ids};
use super::plan::{value_text, ClusterSettings, KeptPressure, Plan};
use super::SweepError;
use crate::fem::actuator::{build_mesh, ActuatorConfig};
use crate::fem::output::{simulate_to, SimulateOptions};
use crate::io::write_atomic;
use crate::report::write_json;

/// The manifest file of a sweep folder.
pub const MANIFEST: &str = "sweep.json";
/// A point's status file.
pub const STATUS: &str = "status.json";
/// A point's log.
pub const LOG: &str = "log";

/// Peak memory of a point's process besides its mesh, MB. Measured (peak RSS of
/// one-pressure ramps, test profile): 6, 4 and 3 mm meshes, 1263, 1943 and 3425 nodes,
/// 102, 118 and 163 MB: about 67 MB + 0.028 MB per node.
pub const POINT_BASE_MB: f64 = 70.0;
/// Peak memory per node of the half mesh, MB: the measured 0.028 (see [`POINT_BASE_MB`])
/// with margin, since the sparse factor grows faster than the node count on fine meshes.
pub const POINT_MB_PER_NODE: f64 = 0.05;
/// Share of the available memory the local pool may plan for.
const MEMORY_SHARE: f64 = 0.8;
/// How often the pool looks at its children and the stop flag.
const POLL: Duration = Duration::from_millis(50);
/// Wait for a point's process to end after the forwarded signal, before SIGKILL.
const INTERRUPT_WAIT: Duration = Duration::from_secs(5);

/// One point of the manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointEntry {
    /// Its id (`p001`), also its folder under `runs/`.
    pub id: String,
    /// Factor values, as text, in the manifest's factor order.
    pub values: Vec<String>,
}

/// `sweep.json`: what `collect`, `run-point` and the emitted scripts need of the plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// The plan file it came from.
    pub plan: PathBuf,
    /// Factor names (designs.csv column names).
    pub factors: Vec<String>,
    /// Kept pressures.
    pub pressures: Vec<KeptPressure>,
    /// Blocked-tip force too.
    pub blocked: bool,
    /// Analytic columns too.
    pub analytic: bool,
    /// Cluster resources.
    pub cluster: ClusterSettings,
    /// The points.
    pub points: Vec<PointEntry>,
}

/// State of a point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PointState {
    /// Every pressure converged.
    Ok,
    /// The ramp stopped early; the converged pressures are kept.
    Stopped,
    /// No result: invalid config, error, crash.
    Failed,
    /// Started and not finished (running, or killed without a word).
    Running,
    /// Stopped by a signal to the sweep (SIGINT, SIGTERM) or to the point: run again on
    /// resume.
    Interrupted,
    /// Not started.
    Pending,
}

impl PointState {
    /// The word written in designs.csv.
    pub fn as_str(&self) -> &'static str {
        match self {
            PointState::Ok => "ok",
            PointState::Stopped => "stopped",
            PointState::Failed => "failed",
            PointState::Running => "running",
            PointState::Interrupted => "interrupted",
            PointState::Pending => "pending",
        }
    }

    /// Finished points are not run again on resume (a failed point is).
    pub fn finished(&self) -> bool {
        matches!(self, PointState::Ok | PointState::Stopped)
    }
}

/// `runs/<id>/status.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointStatus {
    /// State.
    pub status: PointState,
    /// Wall seconds of the point (0 until it ends).
    pub seconds: f64,
    /// Why it stopped or failed.
    pub reason: Option<String>,
}

/// A prepared sweep folder.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// The folder, absolute.
    pub dir: PathBuf,
    /// Its manifest.
    pub manifest: Manifest,
    /// Points still to run.
    pub pending: Vec<String>,
    /// Points finished earlier (resume).
    pub finished: usize,
    /// Points whose config is invalid (recorded as failed, not run).
    pub invalid: usize,
}

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> SweepError + '_ {
    move |e| SweepError::io(path, e)
}

/// The folder of point `id`.
pub fn point_dir(dir: &Path, id: &str) -> PathBuf {
    dir.join("runs").join(id)
}

/// Reads a sweep folder's manifest.
pub fn read_manifest(dir: &Path) -> Result<Manifest, SweepError> {
    let path = dir.join(MANIFEST);
    let text = std::fs::read_to_string(&path).map_err(|e| SweepError::Folder {
        dir: dir.to_path_buf(),
        why: format!("cannot read {MANIFEST} ({e}): is it the -o folder of a bendscope sweep?"),
    })?;
    serde_json::from_str(&text).map_err(|e| SweepError::Folder {
        dir: dir.to_path_buf(),
        why: format!("{MANIFEST} is damaged ({e}): run bendscope sweep PLAN -o DIR again"),
    })
}

/// Reads a point's status (`None` when it has none: not started).
pub fn read_status(point: &Path) -> Option<PointStatus> {
    let text = std::fs::read_to_string(point.join(STATUS)).ok()?;
    serde_json::from_str(&text).ok()
}

fn write_status(point: &Path, s: &PointStatus) -> Result<(), SweepError> {
    let path = point.join(STATUS);
    write_json(&path, s).map_err(|e| SweepError::io(&path, e))
}

/// Reads a point's config.
pub fn read_point_config(point: &Path) -> Result<ActuatorConfig, SweepError> {
    let path = point.join("config.toml");
    let text = std::fs::read_to_string(&path).map_err(io_err(&path))?;
    toml::from_str(&text).map_err(|e| SweepError::io(&path, e.message()))
}

/// Files of an earlier run of a point that no longer belong to it.
const STALE: [&str; 5] = [STATUS, "steps.csv", "force.csv", "summary.json", LOG];

/// Prepares `dir` for `plan`: writes the manifest and every point's `config.toml`, keeps
/// the points already finished with the same config (resume), records points whose
/// config is invalid as failed.
pub fn prepare(plan: &Plan, dir: &Path) -> Result<Prepared, SweepError> {
    std::fs::create_dir_all(dir.join("runs")).map_err(io_err(dir))?;
    let dir = dir.canonicalize().map_err(io_err(dir))?;
    let values = design_points(plan.design, &plan.factors).map_err(|why| SweepError::Plan {
        path: plan.path.clone(),
        why,
    })?;
    let ids = point_ids(values.len());
    let mut prepared = Prepared {
        dir: dir.clone(),
        manifest: Manifest {
            plan: plan
                .path
                .canonicalize()
                .unwrap_or_else(|_| plan.path.clone()),
            factors: plan.factors.iter().map(|f| f.name.clone()).collect(),
            pressures: plan.pressures.clone(),
            blocked: plan.blocked,
            analytic: plan.analytic,
            cluster: plan.cluster.clone(),
            points: Vec::new(),
        },
        pending: Vec::new(),
        finished: 0,
        invalid: 0,
    };
    for (id, v) in ids.iter().zip(&values) {
        let point = point_dir(&dir, id);
        std::fs::create_dir_all(&point).map_err(io_err(&point))?;
        prepared.manifest.points.push(PointEntry {
            id: id.clone(),
            values: v.iter().map(value_text).collect(),
        });
        let cfg = match plan.point_config(v) {
            Ok(c) => c,
            Err(why) => {
                for f in STALE.iter().chain(["config.toml"].iter()) {
                    let _ = std::fs::remove_file(point.join(f));
                }
                write_status(
                    &point,
                    &PointStatus {
                        status: PointState::Failed,
                        seconds: 0.0,
                        reason: Some(format!("invalid design: {why}")),
                    },
                )?;
                prepared.invalid += 1;
                continue;
            }
        };
        let done = read_status(&point).is_some_and(|s| s.status.finished())
            && read_point_config(&point).is_ok_and(|old| old == cfg);
        if done {
            prepared.finished += 1;
            continue;
        }
        for f in STALE {
            let _ = std::fs::remove_file(point.join(f));
        }
        let text = cfg.to_toml().map_err(|e| SweepError::io(&point, e))?;
        let path = point.join("config.toml");
        write_atomic(&path, text.as_bytes()).map_err(io_err(&path))?;
        prepared.pending.push(id.clone());
    }
    write_json(&dir.join(MANIFEST), &prepared.manifest)
        .map_err(|e| SweepError::io(&dir.join(MANIFEST), e))?;
    Ok(prepared)
}

/// Runs point `id` of the sweep in `dir` in this process (what `bendscope sweep run-point`
/// does): the whole `simulate` of its config into its folder (no VTK files), its log
/// and its status.
pub fn run_point(dir: &Path, id: &str) -> Result<PointStatus, SweepError> {
    let manifest = read_manifest(dir)?;
    if !manifest.points.iter().any(|p| p.id == id) {
        return Err(SweepError::Folder {
            dir: dir.to_path_buf(),
            why: format!("no point '{id}' in {MANIFEST}"),
        });
    }
    let point = point_dir(dir, id);
    let log_path = point.join(LOG);
    let mut log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .map_err(io_err(&log_path))?;
    let started = Instant::now();
    let _ = writeln!(log, "point {id}: started (pid {})", std::process::id());
    write_status(
        &point,
        &PointStatus {
            status: PointState::Running,
            seconds: 0.0,
            reason: None,
        },
    )?;
    let result = read_point_config(&point).and_then(|cfg| {
        let options = SimulateOptions {
            blocked: manifest.blocked,
            vtu: false,
        };
        simulate_to(&point, &cfg, options, &mut |stage, s| {
            let _ = writeln!(
                log,
                "{stage}: {} kPa converged in {} Newton iterations, radius {:.3} mm, bending angle {:.2} deg",
                s.pressure_kpa, s.newton_iterations, s.radius_mm, s.bending_angle_deg
            );
        })
        .map_err(|e| SweepError::io(&point, e))
    });
    let seconds = started.elapsed().as_secs_f64();
    let status = match result {
        Ok(sim) => match sim.summary.failure {
            None => PointStatus {
                status: PointState::Ok,
                seconds,
                reason: None,
            },
            Some(why) if !sim.steps.is_empty() => PointStatus {
                status: PointState::Stopped,
                seconds,
                reason: Some(why),
            },
            Some(why) => PointStatus {
                status: PointState::Failed,
                seconds,
                reason: Some(why),
            },
        },
        Err(e) => PointStatus {
            status: PointState::Failed,
            seconds,
            reason: Some(e.to_string()),
        },
    };
    let _ = writeln!(
        log,
        "point {id}: {} in {seconds:.1} s{}",
        status.status.as_str(),
        status
            .reason
            .as_deref()
            .map(|r| format!(": {r}"))
            .unwrap_or_default()
    );
    write_status(&point, &status)?;
    Ok(status)
}

/// Estimated peak memory of one point, MB, from its mesh.
pub fn point_memory_mb(cfg: &ActuatorConfig) -> f64 {
    let nodes = build_mesh(cfg).map(|m| m.model.nodes.len()).unwrap_or(0);
    POINT_BASE_MB + POINT_MB_PER_NODE * nodes as f64
}

/// Memory available to new processes, MB (`MemAvailable` of /proc/meminfo; `None`
/// where there is no such file).
pub fn available_memory_mb() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// How many points to run at once: `asked`, else the cores; never more than the memory
/// holds (each point `point_mb`) nor than there are points; at least 1.
pub fn pool_size(asked: Option<usize>, points: usize, point_mb: f64) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let by_memory = available_memory_mb()
        .map(|m| (MEMORY_SHARE * m / point_mb.max(1.0)).floor() as usize)
        .unwrap_or(usize::MAX);
    asked.unwrap_or(cores).min(by_memory).min(points).max(1)
}

/// Runs `ids` of the prepared sweep `dir`, `jobs` at a time, each as
/// `exe sweep run-point DIR ID` (its stdout and stderr appended to its log, its solver
/// threads the cores shared out; killed if this process dies: [`crate::child`]);
/// `on_done` sees each point as it ends. A process that ends without writing its
/// result is recorded as failed (crashed, out of memory), or interrupted when a signal
/// (SIGINT, SIGTERM, SIGHUP) ended it. Once `stop` is set (a signal to the sweep), no
/// point starts, SIGTERM is forwarded to the running ones, which are waited for and
/// recorded as interrupted.
pub fn run_pool(
    dir: &Path,
    ids: &[String],
    jobs: usize,
    exe: &Path,
    stop: &AtomicBool,
    on_done: &mut dyn FnMut(&str, &PointStatus),
) -> Result<(), SweepError> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = (cores / jobs.max(1)).max(1);
    let queue = Mutex::new(ids.iter().cloned().collect::<VecDeque<String>>());
    let (tx, rx) = mpsc::channel::<Result<(String, PointStatus), SweepError>>();
    std::thread::scope(|scope| {
        for _ in 0..jobs.max(1) {
            let tx = tx.clone();
            let queue = &queue;
            scope.spawn(move || loop {
                if stop.load(Ordering::SeqCst) {
                    break;
                }
                let Some(id) = queue.lock().ok().and_then(|mut q| q.pop_front()) else {
                    break;
                };
                let r = run_child(dir, &id, exe, threads, stop).map(|s| (id, s));
                if tx.send(r).is_err() {
                    break;
                }
            });
        }
        drop(tx);
        let mut first_error = None;
        for r in rx {
            match r {
                Ok((id, s)) => on_done(&id, &s),
                Err(e) => {
                    first_error.get_or_insert(e);
                }
            }
        }
        first_error.map_or(Ok(()), Err)
    })
}

fn run_child(
    dir: &Path,
    id: &str,
    exe: &Path,
    threads: usize,
    stop: &AtomicBool,
) -> Result<PointStatus, SweepError> {
    let point = point_dir(dir, id);
    let log_path = point.join(LOG);
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .map_err(io_err(&log_path))?;
    let log2 = log.try_clone().map_err(io_err(&log_path))?;
    let started = Instant::now();
    let mut command = Command::new(exe);
    command
        .arg("sweep")
        .arg("run-point")
        .arg(dir)
        .arg(id)
        .env("RAYON_NUM_THREADS", threads.to_string())
        .stdin(Stdio::null())
        .stdout(log)
        .stderr(log2);
    // This thread waits for the child, so the child dies with the sweep.
    let mut child = crate::child::die_with_parent(&mut command, libc::SIGKILL)
        .spawn()
        .map_err(|e| SweepError::io(exe, format!("cannot start a point's process: {e}")))?;
    let mut forwarded: Option<Instant> = None;
    let exit = loop {
        match child.try_wait() {
            Ok(Some(exit)) => break exit,
            Ok(None) => {}
            Err(e) => return Err(SweepError::io(exe, format!("cannot wait for a point: {e}"))),
        }
        if stop.load(Ordering::SeqCst) {
            match forwarded {
                None => {
                    let _ = crate::child::send_signal(child.id(), libc::SIGTERM);
                    forwarded = Some(Instant::now());
                }
                Some(t) if t.elapsed() > INTERRUPT_WAIT => {
                    let _ = child.kill();
                }
                Some(_) => {}
            }
        }
        std::thread::sleep(POLL);
    };
    let by_signal = {
        use std::os::unix::process::ExitStatusExt;
        exit.signal()
            .filter(|s| [libc::SIGINT, libc::SIGTERM, libc::SIGHUP].contains(s))
    };
    match read_status(&point) {
        Some(s) if s.status != PointState::Running => Ok(s),
        _ if forwarded.is_some() || by_signal.is_some() => {
            let s = PointStatus {
                status: PointState::Interrupted,
                seconds: started.elapsed().as_secs_f64(),
                reason: Some(format!(
                    "interrupted ({exit}) after {:.1} s: run the sweep again to run it",
                    started.elapsed().as_secs_f64()
                )),
            };
            write_status(&point, &s)?;
            Ok(s)
        }
        other => {
            let s = PointStatus {
                status: PointState::Failed,
                seconds: other.map_or(0.0, |s| s.seconds),
                reason: Some(format!(
                    "the point's process ended ({exit}) without a result (out of memory? see {})",
                    log_path.display()
                )),
            };
            write_status(&point, &s)?;
            Ok(s)
        }
    }
}
