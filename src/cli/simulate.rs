//! `bendscope simulate`: the finite-element model of the actuator under a pressure ramp.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, Context, Result};
use bendscope::fem::actuator::{build_mesh, parse_range, ActuatorConfig, ActuatorMesh};
use bendscope::fem::material::MaterialPreset;
use bendscope::fem::simulate::{run_ramp, Ramp, RampSettings, SideFaceFile, StepResult};
use bendscope::fem::vtu::{write_pvd, write_vtu};
use bendscope::io::write_atomic;
use bendscope::report::{plot_xy, write_json, Series};
use bendscope::table::{write_csv, Column};
use clap::Args;
use serde::Serialize;

use super::{EXIT_BAD_INPUT, EXIT_NOTHING, EXIT_OK, EXIT_PARTIAL};

/// Largest bottom elongation (magnitude) of an acceptable design, % (the published
/// selection of the bottom thickness f). The bottom face is on the inside of the bend, so
/// its "elongation" is usually a shortening (negative in steps.csv).
pub const BOTTOM_ELONGATION_LIMIT_PCT: f64 = 10.0;

/// Simulate the actuator under a pressure ramp (FEM).
#[derive(Debug, Args)]
#[command(
    after_help = "Outputs in OUT: steps.csv (one row per converged pressure), markers.csv (marker x, z per step), \
side_face.json (the filmed face per step, input of bendscope render), vtu/ + actuator.pvd (deformed mesh, displacement and stress, for ParaView), plots/, config.toml (the resolved \
actuator), summary.json; with --blocked force.csv; with --sweep sweep.csv.
Config sections: [geometry] chambers b i f m p r c g d e l n top_wall roof (mm, method.md §4 names); \
[material] preset c1 c2 c3 bulk_modulus_mpa density_g_cm3 tensile_strength_mpa; [mesh] size_mm; \
[load] pressures_kpa gravity; [solver] max_iterations tolerance. Print the defaults with --print-config."
)]
pub struct SimulateArgs {
    /// Actuator file (TOML) [default: the reference actuator, Dragon Skin 30].
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Output folder.
    #[arg(short, long, value_name = "OUT", default_value = "fem-out")]
    pub output: PathBuf,
    /// Largest element edge, mm [default: 2].
    #[arg(
        long,
        value_name = "MM",
        visible_alias = "mesh-size-mm",
        allow_hyphen_values = true
    )]
    pub mesh_size: Option<f64>,
    /// Pressure steps, kPa: start:stop:step or a,b,c [default: 10:115:5].
    #[arg(
        long,
        value_name = "KPA",
        visible_alias = "pressures-kpa",
        allow_hyphen_values = true
    )]
    pub pressures: Option<String>,
    /// Material preset: proposed, stiffer, softer, ecoflex0030.
    #[arg(long, value_name = "NAME")]
    pub material: Option<MaterialPreset>,
    /// Bulk modulus, MPa [default: 1000 x the initial shear modulus].
    #[arg(long, value_name = "MPA", allow_hyphen_values = true)]
    pub bulk_modulus: Option<f64>,
    /// Leave gravity out.
    #[arg(long)]
    pub no_gravity: bool,
    /// Also run the blocked-tip analysis (tip on a flat rigid support): force.csv.
    #[arg(long)]
    pub blocked: bool,
    /// Sweep one parameter, NAME=start:stop:step or NAME=a,b,c (e.g. f=2:8:1): one row per
    /// design with its results at the top pressure (sweep.csv).
    #[arg(long, value_name = "NAME=RANGE")]
    pub sweep: Option<String>,
    /// Skip the VTK files.
    #[arg(long)]
    pub no_vtu: bool,
    /// Print the resolved actuator config (TOML) and exit.
    #[arg(long)]
    pub print_config: bool,
}

/// The resolved configuration: file, then flags.
fn resolve(args: &SimulateArgs) -> Result<ActuatorConfig> {
    let mut cfg = match &args.config {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read actuator config {}", path.display()))?;
            toml::from_str::<ActuatorConfig>(&text).map_err(|e| {
                anyhow!(
                    "{} is not a valid actuator config: {} (see bendscope simulate --print-config)",
                    path.display(),
                    e.message()
                )
            })?
        }
        None => ActuatorConfig::default(),
    };
    if let Some(h) = args.mesh_size {
        cfg.mesh.size_mm = h;
    }
    if let Some(p) = &args.pressures {
        cfg.load.pressures_kpa = p.clone();
    }
    if let Some(m) = args.material {
        cfg.material.preset = m;
    }
    if let Some(k) = args.bulk_modulus {
        cfg.material.bulk_modulus_mpa = Some(k);
    }
    if args.no_gravity {
        cfg.load.gravity = false;
    }
    cfg.validate()?;
    Ok(cfg)
}

#[derive(Serialize)]
struct Summary {
    nodes_half_model: usize,
    elements_half_model: usize,
    free_dofs: usize,
    pressure_faces: usize,
    steps_converged: usize,
    steps_requested: usize,
    newton_iterations: usize,
    seconds: f64,
    failure: Option<String>,
}

/// Runs `bendscope simulate`.
pub fn run(args: &SimulateArgs) -> Result<u8> {
    let cfg = match resolve(args) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e:#}");
            return Ok(EXIT_BAD_INPUT);
        }
    };
    if args.print_config {
        super::out!("{}", toml::to_string_pretty(&cfg)?);
        return Ok(EXIT_OK);
    }
    if let Some(sweep) = &args.sweep {
        return run_sweep(&cfg, sweep, &args.output);
    }
    let out = &args.output;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    write_atomic(
        &out.join("config.toml"),
        toml::to_string_pretty(&cfg)?.as_bytes(),
    )?;
    let pressures = cfg.pressures_kpa()?;
    for n in bendscope::fem::simulate::mesh_notes(&cfg) {
        eprintln!("note: {n}");
    }
    let mesh = build_mesh(&cfg)?;
    eprintln!(
        "mesh: {} nodes, {} hexahedra (half model, {} mm), {} cavity faces",
        mesh.model.nodes.len(),
        mesh.model.elements.len(),
        cfg.mesh.size_mm,
        mesh.model.pressure_faces.len()
    );
    let started = Instant::now();
    let (ramp, vtu_files, face) = ramp_with_outputs(
        &mesh,
        &pressures,
        &cfg,
        false,
        (!args.no_vtu).then_some(out.as_path()),
    )?;
    write_json(&out.join("side_face.json"), &face)?;
    let seconds = started.elapsed().as_secs_f64();
    write_steps(out, &ramp.steps)?;
    for w in bendscope::fem::simulate::ramp_warnings(&ramp.steps) {
        eprintln!("warning: {w}");
    }
    if !vtu_files.is_empty() {
        write_pvd(&out.join("actuator.pvd"), &vtu_files)?;
    }
    let mut failure = ramp.failure.as_ref().map(|e| e.to_string());
    let mut force_steps = Vec::new();
    if args.blocked {
        let blocked = ramp_with_outputs(&mesh, &pressures, &cfg, true, None)?.0;
        write_force(out, &blocked.steps)?;
        force_steps = blocked.steps;
        if let Some(e) = blocked.failure {
            failure.get_or_insert(format!("blocked tip: {e}"));
        }
    }
    plot_steps(out, &ramp.steps, &force_steps)?;
    let summary = Summary {
        nodes_half_model: mesh.model.nodes.len(),
        elements_half_model: mesh.model.elements.len(),
        free_dofs: ramp.free_dofs,
        pressure_faces: mesh.model.pressure_faces.len(),
        steps_converged: ramp.steps.len(),
        steps_requested: pressures.len(),
        newton_iterations: ramp.steps.iter().map(|s| s.newton_iterations).sum(),
        seconds,
        failure: failure.clone(),
    };
    write_json(&out.join("summary.json"), &summary)?;
    if let Some(last) = ramp.steps.last() {
        super::out!(
            "{} of {} steps in {:.1} s ({} dofs, {} Newton iterations); at {} kPa: radius {:.2} mm, bending angle {:.1} deg, safety factor {:.2}{} -> {}",
            ramp.steps.len(),
            pressures.len(),
            seconds,
            ramp.free_dofs,
            summary.newton_iterations,
            last.pressure_kpa,
            last.radius_mm,
            last.bending_angle_deg,
            last.safety_factor,
            force_steps
                .last()
                .and_then(|s| s.blocked_force_n)
                .map(|f| format!(", blocked force {f:.3} N"))
                .unwrap_or_default(),
            out.display()
        );
    }
    Ok(match (&failure, ramp.steps.is_empty()) {
        (None, _) => EXIT_OK,
        (Some(e), empty) => {
            eprintln!(
                "error: {e}; the {} converged step(s) are written in {}",
                ramp.steps.len(),
                out.display()
            );
            if empty {
                EXIT_NOTHING
            } else {
                EXIT_PARTIAL
            }
        }
    })
}

/// Runs a ramp with a progress bar, writing a VTU per step into `vtu_dir/vtu/`.
fn ramp_with_outputs(
    mesh: &ActuatorMesh,
    pressures: &[f64],
    cfg: &ActuatorConfig,
    blocked: bool,
    vtu_dir: Option<&Path>,
) -> Result<(Ramp, Vec<(f64, String)>, SideFaceFile)> {
    let bar = super::progress_bar(
        pressures.len() as u64,
        if blocked {
            "blocked tip"
        } else {
            "pressure steps"
        },
    );
    let mut files = Vec::new();
    let mut io_error = None;
    let (mut face, face_nodes) = SideFaceFile::new(mesh);
    let settings = RampSettings {
        blocked,
        newton: cfg.solver.newton(),
    };
    let ramp = run_ramp(mesh, pressures, &settings, |step, fields| {
        face.push(mesh, &face_nodes, step, fields.displacement);
        if let Some(dir) = vtu_dir {
            let name = format!("vtu/step_{:03}.vtu", files.len() + 1);
            match write_vtu(
                &dir.join(&name),
                &mesh.model.nodes,
                &mesh.model.elements,
                fields.displacement,
                fields.stresses,
            ) {
                Ok(()) => files.push((step.pressure_kpa, name)),
                Err(e) => {
                    io_error.get_or_insert(e);
                }
            }
        }
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    if let Some(e) = io_error {
        return Err(anyhow!("cannot write the VTK files: {e}"));
    }
    Ok((ramp, files, face))
}

/// A column of step results with `decimals` digits.
fn col(name: &str, decimals: usize, steps: &[StepResult], f: fn(&StepResult) -> f64) -> Column {
    Column::num(name, decimals, steps.iter().map(f))
}

fn write_steps(out: &Path, steps: &[StepResult]) -> Result<()> {
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
            col("cavity_volume_mm3", 4, steps, |s| s.cavity_volume_mm3),
            Column::int(
                "newton_iterations",
                steps.iter().map(|s| s.newton_iterations as u64),
            ),
        ],
    )?;
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
    write_csv(&out.join("markers.csv"), &cols)?;
    Ok(())
}

fn write_force(out: &Path, steps: &[StepResult]) -> Result<()> {
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
                    .map(|s| force(s) / bendscope::fem::actuator::GRAVITY_M_S2 * 1000.0),
            ),
        ],
    )?;
    Ok(())
}

fn plot_steps(out: &Path, steps: &[StepResult], force: &[StepResult]) -> Result<()> {
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
            }],
        )
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

/// `--sweep NAME=RANGE`: one design per value, results at the top pressure.
fn run_sweep(base: &ActuatorConfig, spec: &str, out: &Path) -> Result<u8> {
    let Some((name, range)) = spec.split_once('=') else {
        eprintln!("error: --sweep '{spec}': expected NAME=start:stop:step, e.g. f=2:8:1");
        return Ok(EXIT_BAD_INPUT);
    };
    let name = name.trim();
    let values = match parse_range(range, name) {
        Ok(v) => v,
        Err(e) => {
            eprintln!("error: --sweep: {e}");
            return Ok(EXIT_BAD_INPUT);
        }
    };
    let mut designs = Vec::new();
    for v in &values {
        match base
            .with_parameter(name, *v)
            .and_then(|c| c.validate().map(|_| c))
        {
            Ok(c) => designs.push(c),
            Err(e) => {
                eprintln!("error: --sweep {name} = {v}: {e}");
                return Ok(EXIT_BAD_INPUT);
            }
        }
    }
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let pressures = base.pressures_kpa()?;
    let bar = super::progress_bar(values.len() as u64, &format!("sweep {name}"));
    let mut rows: Vec<(f64, Option<StepResult>, String)> = Vec::new();
    for (v, cfg) in values.iter().zip(&designs) {
        bar.set_message(format!("{name} = {v}"));
        let result = build_mesh(cfg).and_then(|mesh| {
            let settings = RampSettings {
                blocked: false,
                newton: cfg.solver.newton(),
            };
            run_ramp(&mesh, &pressures, &settings, |_, _| {})
        });
        let row = match result {
            Ok(ramp) => {
                let status = match &ramp.failure {
                    None => "ok".to_string(),
                    Some(e) => format!("stopped early: {e}"),
                };
                (*v, ramp.steps.last().cloned(), status)
            }
            Err(e) => (*v, None, format!("failed: {e}")),
        };
        if row.2 != "ok" {
            bar.suspend(|| eprintln!("warning: {name} = {v}: {}", row.2));
        }
        rows.push(row);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let g = |f: fn(&StepResult) -> f64| -> Vec<f64> {
        rows.iter()
            .map(|(_, s, _)| s.as_ref().map(f).unwrap_or(f64::NAN))
            .collect()
    };
    let cols = [
        Column::num(name, 4, values.iter().copied()),
        Column::num("pressure_kpa", 4, g(|s| s.pressure_kpa)),
        Column::num("radius_mm", 4, g(|s| s.radius_mm)),
        Column::num("curvature_per_m", 4, g(|s| s.curvature_per_m)),
        Column::num("bending_angle_deg", 4, g(|s| s.bending_angle_deg)),
        Column::num("tip_x_mm", 4, g(|s| s.tip_x_mm)),
        Column::num("tip_z_mm", 4, g(|s| s.tip_z_mm)),
        Column::num(
            "max_principal_stress_mpa",
            4,
            g(|s| s.max_principal_stress_mpa),
        ),
        Column::num("safety_factor", 4, g(|s| s.safety_factor)),
        Column::num("bottom_elongation_pct", 4, g(|s| s.bottom_elongation_pct)),
        Column::num("cavity_volume_mm3", 4, g(|s| s.cavity_volume_mm3)),
    ];
    write_csv(&out.join("sweep.csv"), &cols)?;
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
            }],
        )?;
    }
    let top = pressures.last().copied().unwrap_or(0.0);
    let complete: Vec<&(f64, Option<StepResult>, String)> = rows
        .iter()
        .filter(|(_, s, st)| st == "ok" && s.is_some())
        .collect();
    super::out!(
        "{} of {} designs reached {top} kPa -> {}",
        complete.len(),
        rows.len(),
        out.join("sweep.csv").display()
    );
    let selected = complete.iter().find(|(_, s, _)| {
        s.as_ref()
            .is_some_and(|s| s.bottom_elongation_pct.abs() <= BOTTOM_ELONGATION_LIMIT_PCT)
    });
    match selected {
        Some((v, _, _)) => super::out!(
            "smallest {name} with |bottom elongation| <= {BOTTOM_ELONGATION_LIMIT_PCT}% at {top} kPa: {v}"
        ),
        None => super::out!("no design keeps |bottom elongation| <= {BOTTOM_ELONGATION_LIMIT_PCT}% at {top} kPa"),
    }
    Ok(if complete.len() == rows.len() {
        EXIT_OK
    } else if complete.is_empty() {
        EXIT_NOTHING
    } else {
        EXIT_PARTIAL
    })
}
