//! `bendscope demo`: the whole tool on a simulated actuator, offline, in about ten
//! seconds (release build): simulate -> render through a GoPro-like fisheye -> calibrate
//! from the rendered board photos and measure (process) -> compare with the simulation.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{anyhow, Result};
use bendscope::calib::file::write_calibration;
use bendscope::pipeline::{measure_session, ProcessSettings, Quiet};
use bendscope::render::fixtures::gopro_like_camera;
use bendscope::render::session::{read_side_face, render_fem_session, FemRenderSettings};
use clap::Args;

use super::{compare, simulate, EXIT_OK};

/// Run the whole chain on a simulated actuator (no input needed).
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Output folder (fem/, camera.yaml, session/, measured/, compare/).
    #[arg(short, long, value_name = "DIR", default_value = "bendscope-demo")]
    pub output: PathBuf,
}

fn stage(name: &str, code: u8) -> Result<()> {
    if code == EXIT_OK {
        Ok(())
    } else {
        Err(anyhow!(
            "the demo's {name} stage ended with exit code {code}"
        ))
    }
}

/// Runs `bendscope demo`.
pub fn run(args: &DemoArgs) -> Result<u8> {
    let dir = &args.output;
    // Its stages lock their own subfolders.
    let _lock = super::lock_output(dir)?;
    let started = Instant::now();
    let mut times = Vec::new();
    let mut lap = |what: &str, t: &mut Instant| {
        times.push((what.to_string(), t.elapsed().as_secs_f64()));
        *t = Instant::now();
    };
    let mut t = Instant::now();
    eprintln!("1/4 simulate: the reference actuator on a 3 mm mesh, 20-100 kPa");
    stage(
        "simulate",
        simulate::run(&simulate::SimulateArgs {
            family: None,
            config: None,
            output: dir.join("fem"),
            mesh_size: Some(3.0),
            pressures: Some("20:100:20".into()),
            material: None,
            bulk_modulus: None,
            no_gravity: false,
            blocked: false,
            sweep: None,
            no_vtu: false,
            model: simulate::Model::Fem,
            export_inp: None,
            export_exact: false,
            print_config: false,
        })?,
    )?;
    lap("simulate", &mut t);
    eprintln!(
        "2/4 render: a GoPro-like 960x720 fisheye at 200 mm, 3 frames per pressure, board photos"
    );
    let camera = gopro_like_camera(960, 720);
    let camera_path = dir.join("camera.yaml");
    write_calibration(&camera_path, &camera)?;
    let face = read_side_face(&dir.join("fem"))?;
    let truth = render_fem_session(
        &face,
        &camera,
        &dir.join("session"),
        &FemRenderSettings {
            distance_mm: 200.0,
            frames: 3,
            ..FemRenderSettings::default()
        },
        &|_| {},
    )?;
    lap("render", &mut t);
    eprintln!("3/4 process: calibrate from session/calib, measure every video");
    let measured = measure_session(
        &dir.join("session"),
        &dir.join("measured"),
        &ProcessSettings {
            force: true,
            ..ProcessSettings::default()
        },
        &mut Quiet,
    )?;
    if measured.failed > 0 {
        return Err(anyhow!(
            "the demo's process stage failed on {} video(s): {}",
            measured.failed,
            measured.notes.join("; ")
        ));
    }
    lap("calibrate + process", &mut t);
    eprintln!("4/4 compare: measured vs simulated");
    stage(
        "compare",
        compare::run(&compare::CompareArgs {
            measured: dir.join("measured"),
            fem: dir.join("fem"),
            force: None,
            output: dir.join("compare"),
        })?,
    )?;
    lap("compare", &mut t);

    // The measured radii against the rendered truth.

    super::out!(
        "\npressure_kpa  true_radius_mm  measured_mm  error_%  true_angle_deg  measured_deg"
    );
    for v in &truth.videos {
        if let Some(m) = measured
            .videos
            .iter()
            .find(|m| (m.pressure_kpa - v.pressure_kpa).abs() < 1e-6)
        {
            super::out!(
                "{:>12.1}  {:>14.3}  {:>11.3}  {:>+7.3}  {:>14.2}  {:>12.2}",
                v.pressure_kpa,
                v.radius_mm,
                m.stats.radius_mm,
                100.0 * (m.stats.radius_mm / v.radius_mm - 1.0),
                v.bending_angle_deg,
                m.stats.bending_angle_deg
            );
        }
    }
    super::out!(
        "\ndemo done in {:.0} s ({}):\n  {}/fem        simulation (steps.csv, markers.csv, vtu/, plots/)\n  {}/session    rendered videos, calib/, scale.jpg, truth.json\n  {}/measured   process results (per_video.csv, fit.json, plots/, overlays/)\n  {}/compare    measured vs FEM (summary.txt, compare.csv, plots/)",
        started.elapsed().as_secs_f64(),
        times
            .iter()
            .map(|(w, s)| format!("{w} {s:.0} s"))
            .collect::<Vec<_>>()
            .join(", "),
        dir.display(),
        dir.display(),
        dir.display(),
        dir.display()
    );
    Ok(EXIT_OK)
}
