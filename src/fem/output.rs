//! A simulation's outputs: runs a ramp (and the blocked-tip ramp, and sweeps) and writes
//! `steps.csv`, `markers.csv`, `side_face.json`, `vtu/` + `actuator.pvd`, `force.csv`,
//! `plots/`, `config.toml`, `summary.json` and `sweep.csv`. The `simulate` command only
//! parses flags and prints what [`simulate_to`] and [`sweep_to`] return.
//!
//! A run into a folder that holds an earlier run's results first removes them
//! ([`remove_earlier_outputs`]), then writes its `config.toml`, and writes
//! `summary.json` last: whenever it stops (Ctrl-C, a kill, a step that does not
//! converge), the folder holds one run only, its config beside its own (partial)
//! results, never another actuator's. A folder with a `config.toml` and no
//! `summary.json` is a run that was stopped before its end.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use super::actuator::{build_mesh, ActuatorConfig, ActuatorMesh};
use super::simulate::{
    mesh_notes, ramp_warnings, run_ramp, CavityStep, PartStress, Ramp, RampSettings, SideFaceFile,
    StepResult,
};
use super::vtu::{write_pvd, write_vtu};
use super::FemError;
use crate::io::write_atomic;
use crate::report::{plot_xy, write_json, Series};
use crate::table::{write_csv, Column};

/// Largest bottom elongation (magnitude) of an acceptable design, % (the published
/// selection of the bottom thickness f). The bottom face is on the inside of the bend, so
/// its "elongation" is usually a shortening (negative in steps.csv).
pub const BOTTOM_ELONGATION_LIMIT_PCT: f64 = 10.0;

fn output(e: impl std::fmt::Display) -> FemError {
    FemError::Output { why: e.to_string() }
}

/// Files of a run's results in its folder (beside its `config.toml`, which the next run
/// replaces): what [`simulate_to`], [`sweep_to`] and the analytic model write.
pub const RUN_OUTPUT_FILES: [&str; 8] = [
    "summary.json",
    "mesh.msh",
    "steps.csv",
    "markers.csv",
    "side_face.json",
    "force.csv",
    "actuator.pvd",
    "sweep.csv",
];

/// Plots of a run's results in its `plots/` (PNG, SVG and PDF each).
pub const RUN_PLOTS: [&str; 8] = [
    "radius",
    "curvature",
    "bending_angle",
    "safety_factor",
    "force",
    "sweep_radius",
    "sweep_bottom_elongation",
    "sweep_bending_angle",
];

/// Removes the results of an earlier run from `out` ([`RUN_OUTPUT_FILES`], `vtu/`, the
/// plots of [`RUN_PLOTS`]; `summary.json` first, so that a folder without it is never
/// taken for a finished run), leaving other files alone. Call it before writing a new
/// run's `config.toml`.
pub fn remove_earlier_outputs(out: &Path) -> Result<(), FemError> {
    let gone = |r: std::io::Result<()>, what: &Path| match r {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(output(format!(
            "cannot remove the earlier run's {}: {e}",
            what.display()
        ))),
        _ => Ok(()),
    };
    for f in RUN_OUTPUT_FILES {
        let p = out.join(f);
        gone(std::fs::remove_file(&p), &p)?;
    }
    let vtu = out.join("vtu");
    gone(std::fs::remove_dir_all(&vtu), &vtu)?;
    for stem in RUN_PLOTS {
        for ext in crate::report::PLOT_EXTENSIONS {
            let p = out.join("plots").join(format!("{stem}.{ext}"));
            gone(std::fs::remove_file(&p), &p)?;
        }
    }
    // An empty plots/ left behind is no result.
    let _ = std::fs::remove_dir(out.join("plots"));
    Ok(())
}

/// Checks `out` before a run writes into it (and before a solve): it is a folder, or is
/// created as one, and a file can be written in it. A file named `out`, a read-only
/// folder or a full disk then fails in a second with the folder named, not after the
/// solve.
pub fn prepare_output_folder(out: &Path) -> Result<(), FemError> {
    if out.exists() && !out.is_dir() {
        return Err(FemError::Input {
            why: format!(
                "{}: is a file, not a folder: give -o a folder for the results",
                out.display()
            ),
        });
    }
    std::fs::create_dir_all(out).map_err(|e| {
        output(format!(
            "cannot create the output folder {}: {e}",
            out.display()
        ))
    })?;
    // A plain file (not tempfile's): its errors carry no hidden path to show. Named as
    // write_atomic's temporaries, so a run killed here leaves nothing a rerun keeps.
    let path = out.join(format!(
        "{}write-test-{}{}",
        crate::io::TEMP_PREFIX,
        std::process::id(),
        crate::io::TEMP_SUFFIX
    ));
    let probe = || -> std::io::Result<()> {
        use std::io::Write;
        let mut f = std::fs::File::create(&path)?;
        f.write_all(b"bendscope write test\n")?;
        f.sync_all()
    };
    let result = probe();
    let _ = std::fs::remove_file(&path);
    result.map_err(|e| {
        output(format!(
            "the output folder {} is not writable ({e})",
            out.display()
        ))
    })
}

/// Whether `path` is a file that a run into `out` writes or removes: one of
/// [`RUN_OUTPUT_FILES`] or `config.toml` in `out`, anything in `out/vtu/`, a plot of
/// [`RUN_PLOTS`] in `out/plots/`. A file to keep (an exported deck) must not be one.
pub fn is_run_output(out: &Path, path: &Path) -> bool {
    // Existing folders through their links; others lexically from the working folder.
    let folder = |p: &Path| -> PathBuf {
        p.canonicalize()
            .or_else(|_| std::path::absolute(p))
            .unwrap_or_else(|_| p.to_path_buf())
    };
    let Some(name) = path.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        return false;
    };
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let (out, dir) = (folder(out), folder(parent));
    if dir == out {
        return name == "config.toml"
            || name == "vtu"
            || name == "plots"
            || RUN_OUTPUT_FILES.contains(&name.as_str());
    }
    if dir.starts_with(out.join("vtu")) {
        return true;
    }
    dir == out.join("plots")
        && RUN_PLOTS.iter().any(|p| {
            crate::report::PLOT_EXTENSIONS
                .iter()
                .any(|e| name == format!("{p}.{e}"))
        })
}

/// A ramp run by [`ramp_with_outputs`]: its steps, the VTU files written (pressure,
/// name) and the side face; `vtu_error` is the first VTU that could not be written
/// (none is tried after it), so that the small tables are still written.
pub struct RampOutputs {
    /// The converged steps and why the ramp stopped.
    pub ramp: Ramp,
    /// VTU files written, (pressure kPa, name relative to the output folder).
    pub vtu_files: Vec<(f64, String)>,
    /// The filmed face per step.
    pub face: SideFaceFile,
    /// The first VTU write that failed.
    pub vtu_error: Option<String>,
}

/// Runs a ramp, writing a VTU per step into `vtu_dir/vtu/`; `progress` sees each step.
pub fn ramp_with_outputs(
    mesh: &ActuatorMesh,
    pressures: &[f64],
    cfg: &ActuatorConfig,
    blocked: bool,
    vtu_dir: Option<&Path>,
    progress: &mut dyn FnMut(&StepResult),
) -> Result<RampOutputs, FemError> {
    let mut files = Vec::new();
    let mut io_error = None;
    let (mut face, face_nodes) = SideFaceFile::new(mesh);
    let settings = RampSettings {
        blocked,
        newton: cfg.solver.newton(),
    };
    let ramp = run_ramp(mesh, pressures, &settings, |step, fields| {
        face.push(mesh, &face_nodes, step, fields.displacement);
        if let (Some(dir), None) = (vtu_dir, &io_error) {
            let name = format!("vtu/step_{:03}.vtu", files.len() + 1);
            match write_vtu(
                &dir.join(&name),
                &mesh.model.nodes,
                &mesh.model.elements,
                &mesh.model.tets.elements,
                fields.displacement,
                fields.stresses,
            ) {
                Ok(()) => files.push((step.pressure_kpa, name)),
                Err(e) => io_error = Some(e.to_string()),
            }
        }
        progress(step);
    })?;
    Ok(RampOutputs {
        ramp,
        vtu_files: files,
        face,
        vtu_error: io_error,
    })
}

/// A column of step results with `decimals` digits.
fn col(name: &str, decimals: usize, steps: &[StepResult], f: fn(&StepResult) -> f64) -> Column {
    Column::num(name, decimals, steps.iter().map(f))
}

/// `stress_mpa_<part>` and `safety_factor_<part>` for every part beside the main
/// silicone (layers, fibres, a second silicone), the part's name in snake case.
fn part_columns(steps: &[Option<&StepResult>]) -> Vec<Column> {
    named_columns(
        steps,
        |s| &s.parts[..],
        1,
        |p| p.name.as_str(),
        &[
            ("stress_mpa_{}", |p: &PartStress| p.max_principal_stress_mpa),
            ("safety_factor_{}", |p| p.safety_factor),
        ],
    )
}

/// `pressure_<name>_kpa` and `cavity_volume_<name>_mm3` for every named cavity, the
/// name in snake case.
fn cavity_columns(steps: &[Option<&StepResult>]) -> Vec<Column> {
    named_columns(
        steps,
        |s| &s.cavities[..],
        0,
        |c| c.name.as_str(),
        &[
            ("pressure_{}_kpa", |c: &CavityStep| c.pressure_kpa),
            ("cavity_volume_{}_mm3", |c| c.volume_mm3),
        ],
    )
}

/// One column per field of every item the first step given has (after the first
/// `skip`), named by the field's pattern with `{}` the item's name in snake case; NaN
/// where a step lacks the item or is not given (a sweep's failed design).
fn named_columns<T>(
    steps: &[Option<&StepResult>],
    items: fn(&StepResult) -> &[T],
    skip: usize,
    name: fn(&T) -> &str,
    fields: &[(&str, fn(&T) -> f64)],
) -> Vec<Column> {
    let Some(first) = steps.iter().flatten().next() else {
        return Vec::new();
    };
    let mut cols = Vec::new();
    for (k, item) in items(first).iter().enumerate().skip(skip) {
        let snake_name = snake(name(item));
        for (pattern, value) in fields {
            cols.push(Column::num(
                pattern.replace("{}", &snake_name),
                4,
                steps
                    .iter()
                    .map(|s| s.and_then(|s| items(s).get(k)).map_or(f64::NAN, value)),
            ));
        }
    }
    cols
}

/// `name` in lower case, every other character than a letter or digit an underscore.
fn snake(name: &str) -> String {
    name.to_ascii_lowercase()
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

/// Writes `steps.csv` and `markers.csv`.
pub fn write_steps(out: &Path, steps: &[StepResult]) -> Result<(), FemError> {
    let given: Vec<Option<&StepResult>> = steps.iter().map(Some).collect();
    write_csv(
        &out.join("steps.csv"),
        &[
            col("pressure_kpa", 4, steps, |s| s.pressure_kpa),
            col("radius_mm", 4, steps, |s| s.radius_mm),
            col("curvature_per_m", 4, steps, |s| s.curvature_per_m),
            col("bending_angle_deg", 4, steps, |s| s.bending_angle_deg),
            col("tip_x_mm", 4, steps, |s| s.tip_x_mm),
            col("tip_z_mm", 4, steps, |s| s.tip_z_mm),
            col("max_principal_stress_mpa", 4, steps, |s| {
                s.max_principal_stress_mpa
            }),
            col("safety_factor", 4, steps, |s| s.safety_factor),
            col("bottom_elongation_pct", 4, steps, |s| {
                s.bottom_elongation_pct
            }),
            col("twist_angle_deg", 4, steps, |s| s.twist_angle_deg),
            col("extension_pct", 4, steps, |s| s.extension_pct),
            col("bottom_inflation_mm", 5, steps, |s| s.bottom_inflation_mm),
            col("cavity_volume_mm3", 4, steps, |s| s.cavity_volume_mm3),
            col("min_wall_gap_mm", 5, steps, |s| s.min_wall_gap_mm),
            Column::int(
                "newton_iterations",
                steps.iter().map(|s| s.newton_iterations as u64),
            ),
        ]
        .into_iter()
        .chain(part_columns(&given))
        .chain(cavity_columns(&given))
        .collect::<Vec<_>>(),
    )
    .map_err(output)?;
    let n_markers = steps.first().map(|s| s.markers_mm.len()).unwrap_or(0);
    let mut cols = vec![col("pressure_kpa", 5, steps, |s| s.pressure_kpa)];
    for k in 0..n_markers {
        cols.push(Column::num(
            format!("m{}_x_mm", k + 1),
            5,
            steps.iter().map(|s| s.markers_mm[k].0),
        ));
        cols.push(Column::num(
            format!("m{}_z_mm", k + 1),
            5,
            steps.iter().map(|s| s.markers_mm[k].1),
        ));
    }
    write_csv(&out.join("markers.csv"), &cols).map_err(output)?;
    Ok(())
}

/// Writes `force.csv` (blocked tip).
pub fn write_force(out: &Path, steps: &[StepResult]) -> Result<(), FemError> {
    let force = |s: &StepResult| s.blocked_force_n.unwrap_or(f64::NAN);
    write_csv(
        &out.join("force.csv"),
        &[
            col("pressure_kpa", 5, steps, |s| s.pressure_kpa),
            Column::num("force_n", 5, steps.iter().map(force)),
            Column::num(
                "force_gf",
                5,
                steps
                    .iter()
                    .map(|s| force(s) / super::actuator::GRAVITY_M_S2 * 1000.0),
            ),
        ],
    )
    .map_err(output)?;
    Ok(())
}

/// Draws the ramp's plots (and the blocked force's).
pub fn plot_steps(out: &Path, steps: &[StepResult], force: &[StepResult]) -> Result<(), FemError> {
    let plots = out.join("plots");
    let xy = |f: fn(&StepResult) -> f64, s: &[StepResult]| -> Vec<(f64, f64)> {
        s.iter().map(|s| (s.pressure_kpa, f(s))).collect()
    };
    let one = |name: &str, title: &str, y: &str, pts: Vec<(f64, f64)>| {
        plot_xy(
            &plots.join(name),
            title,
            "pressure (kPa)",
            y,
            &[Series {
                label: "FEM",
                points: pts,
                line: true,
                errors: None,
            }],
        )
        .map_err(output)
    };
    one(
        "radius",
        "Radius of curvature vs pressure",
        "radius (mm)",
        xy(|s| s.radius_mm, steps),
    )?;
    one(
        "curvature",
        "Curvature vs pressure",
        "curvature (1/m)",
        xy(|s| s.curvature_per_m, steps),
    )?;
    one(
        "bending_angle",
        "Bending angle vs pressure",
        "bending angle (deg)",
        xy(|s| s.bending_angle_deg, steps),
    )?;
    one(
        "safety_factor",
        "Safety factor vs pressure",
        "tensile strength / max principal stress",
        xy(|s| s.safety_factor, steps),
    )?;
    if !force.is_empty() {
        one(
            "force",
            "Blocked tip force vs pressure",
            "force (N)",
            xy(|s| s.blocked_force_n.unwrap_or(f64::NAN), force),
        )?;
    }
    Ok(())
}

/// What to run besides the ramp.
#[derive(Debug, Clone, Copy, Default)]
pub struct SimulateOptions {
    /// Also the blocked-tip ramp (force.csv).
    pub blocked: bool,
    /// Write VTU files.
    pub vtu: bool,
}

/// `summary.json` and what `simulate` prints.
#[derive(Debug, Clone, Serialize)]
pub struct SimulationSummary {
    /// The actuator family ([`super::family`]).
    pub family: String,
    /// Nodes of the half model.
    pub nodes_half_model: usize,
    /// Hexahedra of the half model.
    pub elements_half_model: usize,
    /// Free degrees of freedom.
    pub free_dofs: usize,
    /// Cavity faces under pressure.
    pub pressure_faces: usize,
    /// Steps that converged.
    pub steps_converged: usize,
    /// Steps asked for.
    pub steps_requested: usize,
    /// Newton iterations over the ramp.
    pub newton_iterations: usize,
    /// Seconds of the ramp.
    pub seconds: f64,
    /// Why the ramp stopped early, if it did.
    pub failure: Option<String>,
    /// Notes on the model (mesh coarser than a wall).
    pub notes: Vec<String>,
    /// Warnings on the results (safety factor below 1, markers past a full turn, chamber
    /// walls interpenetrating).
    pub warnings: Vec<String>,
    /// Smallest signed gap between facing chamber walls over the ramp, mm (negative:
    /// interpenetration).
    pub min_wall_gap_mm: Option<f64>,
    /// Contact penalty stiffness, MPa/mm, when contact between the walls is on.
    pub contact_penalty_mpa_per_mm: Option<f64>,
    /// The last converged step's results (every column of steps.csv, the markers and
    /// the stress and safety factor of each part).
    pub last_step: Option<StepResult>,
}

/// A simulation's results.
#[derive(Debug, Clone)]
pub struct Simulation {
    /// The summary (also in summary.json).
    pub summary: SimulationSummary,
    /// The converged steps.
    pub steps: Vec<StepResult>,
    /// The blocked-tip steps (empty unless asked for).
    pub force_steps: Vec<StepResult>,
}

/// Simulates `cfg` into `out` (every output file, after removing an earlier run's:
/// [`remove_earlier_outputs`]); `progress(stage, step)` sees each converged step. A ramp
/// that stops early is not an error: its converged steps are written and
/// `summary.failure` says why. `summary.json` is written last.
pub fn simulate_to(
    out: &Path,
    cfg: &ActuatorConfig,
    options: SimulateOptions,
    progress: &mut dyn FnMut(&str, &StepResult),
) -> Result<Simulation, FemError> {
    prepare_output_folder(out)?;
    let text = cfg.to_toml()?;
    let pressures = cfg.pressures_kpa()?;
    let notes = mesh_notes(cfg);
    // The mesh before anything is written: what its build refuses (an imported mesh's
    // groups, a table naming none) leaves an earlier run's results and config as they were.
    let mesh = build_mesh(cfg)?;
    remove_earlier_outputs(out)?;
    write_atomic(&out.join("config.toml"), text.as_bytes()).map_err(output)?;
    if let Some(msh) = &mesh.made_mesh {
        write_atomic(&out.join("mesh.msh"), msh).map_err(output)?;
    }
    let started = Instant::now();
    let RampOutputs {
        ramp,
        vtu_files,
        face,
        vtu_error,
    } = ramp_with_outputs(
        &mesh,
        &pressures,
        cfg,
        false,
        options.vtu.then_some(out),
        &mut |s| progress("pressure steps", s),
    )?;
    let seconds = started.elapsed().as_secs_f64();
    // The small tables first: on a full disk they are kept when the VTK files fail.
    write_steps(out, &ramp.steps)?;
    if let Some(e) = vtu_error {
        return Err(output(format!(
            "VTK files: {e} (steps.csv and markers.csv of the {} converged steps are written; --no-vtu leaves the VTK files out)",
            ramp.steps.len()
        )));
    }
    write_json(&out.join("side_face.json"), &face).map_err(output)?;
    if !vtu_files.is_empty() {
        write_pvd(&out.join("actuator.pvd"), &vtu_files).map_err(output)?;
    }
    let mut failure = ramp.failure.as_ref().map(|e| e.to_string());
    let mut force_steps = Vec::new();
    if options.blocked {
        let blocked = ramp_with_outputs(&mesh, &pressures, cfg, true, None, &mut |s| {
            progress("blocked tip", s)
        })?
        .ramp;
        write_force(out, &blocked.steps)?;
        force_steps = blocked.steps;
        if let Some(e) = blocked.failure {
            failure.get_or_insert(format!("blocked tip: {e}"));
        }
    }
    plot_steps(out, &ramp.steps, &force_steps)?;
    let summary = SimulationSummary {
        family: cfg.geometry.family.to_string(),
        last_step: ramp.steps.last().cloned(),
        nodes_half_model: mesh.model.nodes.len(),
        elements_half_model: mesh.model.elements.len() + mesh.model.tets.elements.len(),
        free_dofs: ramp.free_dofs,
        pressure_faces: mesh.model.pressure_faces.len() + mesh.model.tets.pressure_faces.len(),
        steps_converged: ramp.steps.len(),
        steps_requested: pressures.len(),
        newton_iterations: ramp.steps.iter().map(|s| s.newton_iterations).sum(),
        seconds,
        failure,
        notes,
        warnings: ramp_warnings(&ramp.steps, cfg.contact.as_ref().filter(|c| c.enabled)),
        min_wall_gap_mm: ramp
            .steps
            .iter()
            .map(|s| s.min_wall_gap_mm)
            .filter(|g| g.is_finite())
            .min_by(f64::total_cmp),
        contact_penalty_mpa_per_mm: mesh.model.contact.as_ref().map(|c| c.penalty_mpa_per_mm),
    };
    write_json(&out.join("summary.json"), &summary).map_err(output)?;
    Ok(Simulation {
        summary,
        steps: ramp.steps,
        force_steps,
    })
}

/// One design of a sweep.
#[derive(Debug, Clone)]
pub struct SweepRow {
    /// The swept parameter's value.
    pub value: f64,
    /// Results at the last converged pressure.
    pub last: Option<StepResult>,
    /// `ok`, or why the design stopped early or failed.
    pub status: String,
}

/// A sweep's results.
#[derive(Debug, Clone)]
pub struct Sweep {
    /// One row per value.
    pub rows: Vec<SweepRow>,
    /// The top pressure of the ramp, kPa.
    pub top_kpa: f64,
    /// The smallest value whose |bottom elongation| stays within
    /// [`BOTTOM_ELONGATION_LIMIT_PCT`] at the top pressure.
    pub selected: Option<f64>,
}

/// Runs one design per value of parameter `name` (each checked first) and writes
/// `sweep.csv` and its plots into `out` (after removing an earlier run's results:
/// [`remove_earlier_outputs`]); `progress(value)` sees each design as it starts.
pub fn sweep_to(
    out: &Path,
    base: &ActuatorConfig,
    name: &str,
    values: &[f64],
    progress: &mut dyn FnMut(f64),
) -> Result<Sweep, FemError> {
    let mut designs = Vec::new();
    for v in values {
        let c = base.with_parameter(name, *v)?;
        c.validate()?;
        designs.push(c);
    }
    prepare_output_folder(out)?;
    remove_earlier_outputs(out)?;
    // A sweep writes no config of its own: an earlier run's is not its.
    match std::fs::remove_file(out.join("config.toml")) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(output(e)),
        _ => {}
    }
    let pressures = base.pressures_kpa()?;
    let mut rows = Vec::new();
    for (v, cfg) in values.iter().zip(&designs) {
        progress(*v);
        let result = build_mesh(cfg).and_then(|mesh| {
            let settings = RampSettings {
                blocked: false,
                newton: cfg.solver.newton(),
            };
            run_ramp(&mesh, &pressures, &settings, |_, _| {})
        });
        rows.push(match result {
            Ok(ramp) => SweepRow {
                value: *v,
                last: ramp.steps.last().cloned(),
                status: match &ramp.failure {
                    None => "ok".to_string(),
                    Some(e) => format!("stopped early: {e}"),
                },
            },
            Err(e) => SweepRow {
                value: *v,
                last: None,
                status: format!("failed: {e}"),
            },
        });
    }
    let g = |f: fn(&StepResult) -> f64| -> Vec<f64> {
        rows.iter()
            .map(|r| r.last.as_ref().map(f).unwrap_or(f64::NAN))
            .collect()
    };
    let num = |n: &str, v: Vec<f64>| Column::num(n, 4, v);
    let cols = vec![
        num(name, values.to_vec()),
        num("pressure_kpa", g(|s| s.pressure_kpa)),
        num("radius_mm", g(|s| s.radius_mm)),
        num("curvature_per_m", g(|s| s.curvature_per_m)),
        num("bending_angle_deg", g(|s| s.bending_angle_deg)),
        num("tip_x_mm", g(|s| s.tip_x_mm)),
        num("tip_z_mm", g(|s| s.tip_z_mm)),
        num(
            "max_principal_stress_mpa",
            g(|s| s.max_principal_stress_mpa),
        ),
        num("safety_factor", g(|s| s.safety_factor)),
        num("bottom_elongation_pct", g(|s| s.bottom_elongation_pct)),
        num("cavity_volume_mm3", g(|s| s.cavity_volume_mm3)),
    ];
    // Each part's stress and each named cavity's pressure and volume, as in steps.csv.
    let lasts: Vec<Option<&StepResult>> = rows.iter().map(|r| r.last.as_ref()).collect();
    let cols: Vec<Column> = cols
        .into_iter()
        .chain(part_columns(&lasts))
        .chain(cavity_columns(&lasts))
        .chain([Column::text(
            "status",
            rows.iter().map(|r| r.status.clone()),
        )])
        .collect();
    write_csv(&out.join("sweep.csv"), &cols).map_err(output)?;
    let pts = |f: fn(&StepResult) -> f64| -> Vec<(f64, f64)> {
        values.iter().copied().zip(g(f)).collect()
    };
    for (file, title, y, f) in [
        (
            "sweep_radius",
            "Radius at the top pressure",
            "radius (mm)",
            (|s: &StepResult| s.radius_mm) as fn(&StepResult) -> f64,
        ),
        (
            "sweep_bottom_elongation",
            "Bottom elongation at the top pressure",
            "bottom elongation (%)",
            |s: &StepResult| s.bottom_elongation_pct,
        ),
        (
            "sweep_bending_angle",
            "Bending angle at the top pressure",
            "bending angle (deg)",
            |s: &StepResult| s.bending_angle_deg,
        ),
    ] {
        plot_xy(
            &out.join("plots").join(file),
            title,
            name,
            y,
            &[Series {
                label: "FEM",
                points: pts(f),
                line: true,
                errors: None,
            }],
        )
        .map_err(output)?;
    }
    let selected = rows
        .iter()
        .filter(|r| r.status == "ok")
        .find(|r| {
            r.last
                .as_ref()
                .is_some_and(|s| s.bottom_elongation_pct.abs() <= BOTTOM_ELONGATION_LIMIT_PCT)
        })
        .map(|r| r.value);
    Ok(Sweep {
        rows,
        top_kpa: pressures.last().copied().unwrap_or(0.0),
        selected,
    })
}
