//! `bendscope simulate`: the finite-element model of the actuator under a pressure ramp.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Result};
use bendscope::fem::actuator::{build_mesh, parse_range, ActuatorConfig};
use bendscope::fem::analytic::analytic_to;
use bendscope::fem::family::Family;
use bendscope::fem::inp::{caveats, for_calculix, write_inp};
use bendscope::fem::material::MaterialPreset;
use bendscope::fem::output::{
    is_run_output, prepare_output_folder, simulate_to, sweep_to, SimulateOptions,
    BOTTOM_ELONGATION_LIMIT_PCT,
};
use bendscope::fem::FemError;
use clap::Args;

use super::{EXIT_BAD_INPUT, EXIT_NOTHING, EXIT_NO_SPACE, EXIT_OK, EXIT_PARTIAL};

/// Simulate the actuator under a pressure ramp (FEM).
#[derive(Debug, Args)]
#[command(
    after_help = "Outputs in OUT: steps.csv (one row per converged pressure), markers.csv (marker x, z per step), \
side_face.json (the filmed face per step, input of bendscope render), vtu/ + actuator.pvd (deformed mesh, displacement and stress, for ParaView), plots/, config.toml (the resolved \
actuator), summary.json; with --blocked force.csv; with --sweep sweep.csv.
Config sections: [geometry] chambers b i f m p r c g d e l n top_wall roof (mm, method.md §4 names); \
[material] preset c1 c2 c3 bulk_modulus_mpa density_g_cm3 tensile_strength_mpa scale; [mesh] size_mm element (q1p0 or incompatible-modes); \
[load] pressures_kpa gravity gravity_direction; [solver] max_iterations tolerance; [layer] (or several [[layer]]) name thickness_mm \
youngs_modulus_mpa poisson_ratio height_mm element (membrane, plate or solid) width_mm strips spacing_mm tensile_strength_mpa; [contact]; \
[cavities] NAME = factor (a named cavity's pressure over the ramp's: the segmented finger's mcp and pip_dip, a mesh's cavity.NAME groups). \
[geometry] family = pneunets, glove, strap, fibre-reinforced or segmented-finger picks the published design whose values fill what the file leaves out \
([tube] for fibre-reinforced, [finger] height_mm bellows wall_mm foot_mm length_mm cavity_mm cavity_width_mm side_wall_mm gap_mm channel_mm roof_mm sheet_mm sheet_mpa for segmented-finger); family = mesh reads [geometry] file \
(.msh, or .geo/.step/.stp/.iges/.igs/.brep meshed by gmsh) with parameters (a .geo's numbers), clamp (x-min .. z-max) and [geometry.markers] from to count; \
its physical volume NAME takes [material.NAME] (else [material]), its curve thread.NAME is a thread of [threads.NAME] diameter_mm youngs_modulus_mpa tension_only strength_mpa, \
and its surface layer.NAME a sheet of the [[layer]] table name = NAME (thickness_mm youngs_modulus_mpa poisson_ratio tensile_strength_mpa). \
Print a family's whole config with --family NAME --print-config."
)]
pub struct SimulateArgs {
    /// Actuator file (TOML) [default: the family's published design; without --family the
    /// reference PneuNets actuator, Dragon Skin 30]. Its [geometry] family picks the
    /// defaults for what it leaves out.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Actuator family: pneunets, glove, strap, fibre-reinforced, segmented-finger (the published designs, README
    /// "Actuator families"), or mesh (your own gmsh mesh or CAD file: a --config naming its
    /// [geometry] file); with --print-config prints the family's whole config.
    #[arg(long, value_name = "NAME")]
    pub family: Option<Family>,
    /// Output folder.
    #[arg(short, long, value_name = "OUT", default_value = "fem-out")]
    pub output: PathBuf,
    /// Largest element edge, mm [default: 1.5] (every family's).
    #[arg(
        long,
        value_name = "MM",
        visible_alias = "mesh-size-mm",
        allow_hyphen_values = true
    )]
    pub mesh_size: Option<f64>,
    /// Pressure steps, kPa: start:stop:step or a,b,c [default: the family's; pneunets 10:115:5].
    #[arg(
        long,
        value_name = "KPA",
        visible_alias = "pressures-kpa",
        allow_hyphen_values = true
    )]
    pub pressures: Option<String>,
    /// Material preset: proposed, stiffer, softer, ecoflex0030, ecoflex0050, dragonskin10, dragonskin20.
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
    /// Model: fem (finite elements) or analytic (the chamber model: steps.csv in milliseconds).
    #[arg(long, value_name = "MODEL", default_value = "fem")]
    pub model: Model,
    /// Print the resolved actuator config (TOML) and exit.
    #[arg(long)]
    pub print_config: bool,
    /// Also write the model as an Abaqus/CalculiX deck (C3D8I Yeoh solids, M3D4 layers, S4 plates, SPRINGA
    /// threads tied by *EQUATION, [contact] as node-to-surface contact pairs, one step per pressure).
    #[arg(long, value_name = "FILE")]
    pub export_inp: Option<PathBuf>,
    /// With --export-inp: the deck of the model exactly as solved [default: a bulk modulus
    /// above 200 mu0 goes out as 100 mu0, where CalculiX's C3D8I does not lock; noted].
    #[arg(long, requires = "export_inp")]
    pub export_exact: bool,
}

/// The model `simulate` runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Model {
    /// The finite-element model.
    Fem,
    /// The analytic chamber model (docs/src/howto/fem.md: where it departs from the FEM).
    Analytic,
}

/// The resolved configuration: file, then flags.
fn resolve(args: &SimulateArgs) -> Result<ActuatorConfig> {
    let mut cfg = match &args.config {
        Some(path) => ActuatorConfig::read(path)?,
        None => ActuatorConfig::for_family(args.family.unwrap_or_default()),
    };
    if let Some(f) = args.family {
        if f != cfg.geometry.family {
            return Err(anyhow!(
                "--family {f} contradicts the config's [geometry] family = \"{}\": leave out --family or change the config",
                cfg.geometry.family
            ));
        }
    }
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

/// Why `--export-inp` cannot go with the other flags, if it cannot: the runs that write
/// no deck (the analytic model, --print-config, --sweep) and a deck the run's own
/// results would overwrite.
fn export_refused(args: &SimulateArgs) -> Option<String> {
    let path = args.export_inp.as_ref()?;
    let with = if args.model == Model::Analytic {
        "--model analytic (the deck is the finite-element model's)"
    } else if args.print_config {
        "--print-config (it prints the config and exits)"
    } else if args.sweep.is_some() {
        "--sweep (a deck is one design's: export it by a run without --sweep)"
    } else if is_run_output(&args.output, path) {
        return Some(format!(
            "--export-inp {}: the run writes that name in {} (its results would replace the deck): give another name, e.g. {}",
            path.display(),
            args.output.display(),
            args.output.join("deck.inp").display()
        ));
    } else {
        return None;
    };
    Some(format!(
        "--export-inp writes no deck with {with}: drop one of the two"
    ))
}

/// The exit of a run that failed: 4 when the disk is full (as `process`), 2 otherwise.
fn failed(e: FemError) -> Result<u8> {
    if bendscope::io::is_storage_full(&e) {
        eprintln!("error: {e}: free space and rerun");
        return Ok(EXIT_NO_SPACE);
    }
    bad(e)
}

/// Runs `bendscope simulate`.
pub fn run(args: &SimulateArgs) -> Result<u8> {
    if let Some(why) = export_refused(args) {
        return bad(why);
    }
    let cfg = match resolve(args) {
        Ok(c) => c,
        Err(e) => return bad(format!("{e:#}")),
    };
    for w in cfg.warnings() {
        eprintln!("warning: {w}");
    }
    if args.print_config {
        super::out!("{}", cfg.to_toml()?);
        return Ok(EXIT_OK);
    }
    // One run per output folder, its writability checked before the solve.
    let _lock = super::lock_output(&args.output)?;
    if args.model == Model::Analytic {
        return run_analytic(&cfg, &args.output);
    }
    if let Some(sweep) = &args.sweep {
        return run_sweep(&cfg, sweep, &args.output);
    }
    if let Some(path) = &args.export_inp {
        // The output folder first: a bad -o fails before anything is written.
        if let Err(e) = prepare_output_folder(&args.output) {
            return failed(e);
        }
        let (deck_cfg, mut notes) = if args.export_exact {
            (cfg.clone(), Vec::new())
        } else {
            for_calculix(&cfg)
        };
        if args.blocked {
            notes.push("the deck holds the free ramp only: the rigid support under the tip of --blocked (force.csv) has no counterpart in it".into());
        }
        match build_mesh(&deck_cfg).and_then(|mesh| write_inp(path, &mesh, &deck_cfg, &notes)) {
            Ok(deck) => {
                eprintln!("note: {deck} -> {}", path.display());
                caveats(&deck_cfg)
                    .iter()
                    .chain(&notes)
                    .for_each(|c| eprintln!("note: {c}"));
            }
            Err(e) => return failed(e),
        }
    }
    let out = &args.output;
    let total = cfg.pressures_kpa()?.len() as u64;
    let mut bar: Option<(String, indicatif::ProgressBar)> = None;
    let sim = simulate_to(
        out,
        &cfg,
        SimulateOptions {
            blocked: args.blocked,
            vtu: !args.no_vtu,
        },
        &mut |stage, _| {
            if bar.as_ref().is_none_or(|(s, _)| s != stage) {
                if let Some((_, b)) = bar.take() {
                    b.finish_and_clear();
                }
                bar = Some((stage.to_string(), super::progress_bar(total, stage)));
            }
            if let Some((_, b)) = &bar {
                b.inc(1);
            }
        },
    );
    if let Some((_, b)) = bar {
        b.finish_and_clear();
    }
    let sim = match sim {
        Ok(s) => s,
        Err(e) => return failed(e),
    };
    let s = &sim.summary;
    for n in &s.notes {
        eprintln!("note: {n}");
    }
    for w in &s.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(last) = sim.steps.last() {
        super::out!(
            "{} of {} steps in {:.1} s ({} nodes, {} dofs, {} Newton iterations); at {} kPa: radius {:.2} mm, bending angle {:.1} deg, safety factor {:.2}{} -> {}",
            s.steps_converged,
            s.steps_requested,
            s.seconds,
            s.nodes_half_model,
            s.free_dofs,
            s.newton_iterations,
            last.pressure_kpa,
            last.radius_mm,
            last.bending_angle_deg,
            last.safety_factor,
            sim.force_steps
                .last()
                .and_then(|s| s.blocked_force_n)
                .map(|f| format!(", blocked force {f:.3} N"))
                .unwrap_or_default(),
            out.display()
        );
    }
    Ok(match (&s.failure, sim.steps.is_empty()) {
        (None, _) => EXIT_OK,
        (Some(e), empty) => {
            eprintln!(
                "error: {e}; the {} converged step(s) are written in {}",
                sim.steps.len(),
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

/// Bad input: its one line on stderr, exit 2.
fn bad(e: impl std::fmt::Display) -> Result<u8> {
    eprintln!("error: {e}");
    Ok(EXIT_BAD_INPUT)
}

/// `--model analytic`: the chamber model over the ramp, timed.
fn run_analytic(cfg: &ActuatorConfig, out: &Path) -> Result<u8> {
    let started = std::time::Instant::now();
    let steps = match analytic_to(out, cfg) {
        Ok(s) => s,
        Err(e) if e.is_bad_input() => return bad(e),
        Err(e) => return Err(e.into()),
    };
    let ms = 1e3 * started.elapsed().as_secs_f64();
    if let Some(last) = steps.last() {
        super::out!(
            "analytic model: {} steps in {ms:.2} ms; at {} kPa: wall stress {:.4} MPa, strain {:.4}, bending angle {:.1} deg, radius {:.2} mm -> {}",
            steps.len(),
            last.pressure_kpa,
            last.axial_stress_mpa,
            last.axial_strain,
            last.bending_angle_deg,
            last.radius_mm,
            out.display()
        );
    }
    Ok(EXIT_OK)
}

/// `--sweep NAME=RANGE`: one design per value, results at the top pressure.
fn run_sweep(base: &ActuatorConfig, spec: &str, out: &Path) -> Result<u8> {
    let Some((name, range)) = spec.split_once('=') else {
        return bad(format!(
            "--sweep '{spec}': expected NAME=start:stop:step, e.g. f=2:8:1"
        ));
    };
    let name = name.trim();
    let values = match parse_range(range, name) {
        Ok(v) => v,
        Err(e) => return bad(format!("--sweep: {e}")),
    };
    let bar = super::progress_bar(values.len() as u64, &format!("sweep {name}"));
    let result = sweep_to(out, base, name, &values, &mut |v| {
        bar.set_message(format!("{name} = {v}"));
        bar.inc(1);
    });
    bar.finish_and_clear();
    let sweep = match result {
        Ok(s) => s,
        Err(e) if e.is_bad_input() => return bad(format!("--sweep {name}: {e}")),
        Err(e) => return Err(e.into()),
    };
    for r in sweep.rows.iter().filter(|r| r.status != "ok") {
        eprintln!("warning: {name} = {}: {}", r.value, r.status);
    }
    let top = sweep.top_kpa;
    let complete = sweep.rows.iter().filter(|r| r.status == "ok").count();
    super::out!(
        "{complete} of {} designs reached {top} kPa -> {}",
        sweep.rows.len(),
        out.join("sweep.csv").display()
    );
    match sweep.selected {
        Some(v) => super::out!(
            "smallest {name} with |bottom elongation| <= {BOTTOM_ELONGATION_LIMIT_PCT}% at {top} kPa: {v}"
        ),
        None => super::out!("no design keeps |bottom elongation| <= {BOTTOM_ELONGATION_LIMIT_PCT}% at {top} kPa"),
    }
    Ok(if complete == sweep.rows.len() {
        EXIT_OK
    } else if complete == 0 {
        EXIT_NOTHING
    } else {
        EXIT_PARTIAL
    })
}
