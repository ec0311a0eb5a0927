//! `bendscope control`: a PID closing the loop around the simulated actuator.

use std::path::PathBuf;

use anyhow::Result;
use bendscope::control::pid::{PidGains, DEFAULT_DERIVATIVE_FILTER_N};
use bendscope::control::plant::{
    LagModel, PneumaticSettings, DEFAULT_DEAD_TIME_S, DEFAULT_NOISE_DEG, DEFAULT_RATE_LIMIT_KPA_S,
    DEFAULT_RESOLUTION_KPA, DEFAULT_VALVE_CONDUCTANCE_L_MIN_KPA,
};
use bendscope::control::reference::Reference;
use bendscope::control::{
    control_to, ControlError, ControlSettings, GainChoice, DEFAULT_FEM_MESH_MM, DEFAULT_SAMPLE_S,
};
use clap::{ArgGroup, Args};

use super::{EXIT_BAD_INPUT, EXIT_OK};

/// Close the loop: a PID drives the pressure of the simulated actuator to a reference
/// bending angle.
#[derive(Debug, Args)]
#[command(group(ArgGroup::new("reference").required(true).args(["step", "ramp", "sine", "target"])))]
#[command(
    after_help = "The plant: the bending angle vs pressure of a `bendscope simulate` output (steps.csv, monotone PCHIP interpolation) \
behind a pneumatic line: regulator range and resolution, dead time, rate limit, first-order lag (τ given, or from the cavity volume \
and the valve conductance), seeded sensor noise. Without --kp/--ki/--kd the gains are tuned (--tune: SIMC on an FOPDT model of a simulated open-loop step).
Outputs in OUT: control.csv (time_s, reference_deg, angle_deg, measured_angle_deg, pressure_cmd_kpa, pressure_kpa, radius_mm, saturated), \
metrics.json (rise time, overshoot, settling time 2%, steady-state error, IAE, RMSE, gains, warnings), plots/angle and plots/pressure; \
with --fem-in-loop also control_map.csv (the same loop on the map)."
)]
pub struct ControlArgs {
    /// Output folder of `bendscope simulate` (steps.csv; config.toml for --fem-in-loop).
    #[arg(long, value_name = "FEM_OUT")]
    pub plant: PathBuf,
    /// Output folder.
    #[arg(short, long, value_name = "OUT", default_value = "control-out")]
    pub output: PathBuf,
    /// Reference: a step to DEG at t = 0.
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub step: Option<f64>,
    /// Reference: a ramp FROM_DEG:TO_DEG:SECONDS, then held.
    #[arg(long, value_name = "FROM:TO:S", allow_hyphen_values = true)]
    pub ramp: Option<String>,
    /// Reference: a sinusoid MEAN_DEG:AMPLITUDE_DEG:PERIOD_S.
    #[arg(long, value_name = "MEAN:AMP:PERIOD", allow_hyphen_values = true)]
    pub sine: Option<String>,
    /// Reference: a CSV time_s,angle_deg (e.g. an exercise: flex, hold, extend), linear
    /// between rows.
    #[arg(long, value_name = "REF.csv")]
    pub target: Option<PathBuf>,
    /// Proportional gain, kPa/deg.
    #[arg(long, value_name = "KPA_PER_DEG", conflicts_with = "tune")]
    pub kp: Option<f64>,
    /// Integral gain, kPa/(deg s) [default with --kp: 0].
    #[arg(
        long,
        value_name = "KPA_PER_DEG_S",
        conflicts_with = "tune",
        requires = "kp"
    )]
    pub ki: Option<f64>,
    /// Derivative gain, kPa s/deg [default with --kp: 0].
    #[arg(
        long,
        value_name = "KPA_S_PER_DEG",
        conflicts_with = "tune",
        requires = "kp"
    )]
    pub kd: Option<f64>,
    /// Tune the gains (the default without --kp): SIMC on an identified FOPDT model.
    #[arg(long)]
    pub tune: bool,
    /// SIMC closed-loop time constant τc, s [default: 1.5 x the identified dead time + half a sample].
    #[arg(long, value_name = "S", conflicts_with = "kp")]
    pub tau_c_s: Option<f64>,
    /// Length of the run, s [default: step 5, ramp and CSV their length + 1, sine 2 periods].
    #[arg(long, value_name = "S")]
    pub duration_s: Option<f64>,
    /// Controller sample time, s.
    #[arg(long, value_name = "S", default_value_t = DEFAULT_SAMPLE_S)]
    pub sample_time_s: f64,
    /// Time constant of the pneumatic lag, s [default: from the cavity volume and --valve-conductance].
    #[arg(long, value_name = "S")]
    pub tau_s: Option<f64>,
    /// Valve conductance, L/min (normal) per kPa, for the lag from the cavity volume.
    #[arg(long, value_name = "L_MIN_KPA", default_value_t = DEFAULT_VALVE_CONDUCTANCE_L_MIN_KPA, conflicts_with = "tau_s")]
    pub valve_conductance: f64,
    /// Dead time of the line, s (0 to 60).
    #[arg(long, value_name = "S", default_value_t = DEFAULT_DEAD_TIME_S)]
    pub dead_time_s: f64,
    /// Regulator range MIN:MAX, kPa [default: the simulated pressures].
    #[arg(long, value_name = "MIN:MAX")]
    pub regulator_kpa: Option<String>,
    /// Regulator resolution, kPa (0: continuous).
    #[arg(long, value_name = "KPA", default_value_t = DEFAULT_RESOLUTION_KPA)]
    pub resolution_kpa: f64,
    /// Largest rate of change of the pressure, kPa/s (inf: none).
    #[arg(long, value_name = "KPA_S", default_value_t = DEFAULT_RATE_LIMIT_KPA_S)]
    pub rate_limit_kpa_s: f64,
    /// Sensor noise on the angle (standard deviation), degrees.
    #[arg(long, value_name = "DEG", default_value_t = DEFAULT_NOISE_DEG)]
    pub noise_deg: f64,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Set-point weight b of the proportional term (P = Kp (b r − y)).
    #[arg(long, value_name = "B", default_value_t = 1.0)]
    pub setpoint_weight: f64,
    /// Derivative filter divisor N (T_f = Kd / (Kp N)).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_DERIVATIVE_FILTER_N)]
    pub derivative_filter_n: f64,
    /// Solve the FEM at every control sample (warm-started) and compare with the map.
    #[arg(long)]
    pub fem_in_loop: bool,
    /// Element size of the FEM in the loop, mm.
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_FEM_MESH_MM, requires = "fem_in_loop")]
    pub fem_mesh_mm: f64,
}

/// Flags -> settings.
fn settings(args: &ControlArgs) -> Result<ControlSettings, ControlError> {
    let reference = match (&args.step, &args.ramp, &args.sine, &args.target) {
        (Some(a), ..) => Reference::Step { angle_deg: *a },
        (_, Some(r), ..) => Reference::parse_ramp(r)?,
        (_, _, Some(s), _) => Reference::parse_sine(s)?,
        (.., Some(path)) => Reference::from_csv(path)?,
        _ => {
            return Err(ControlError::Setting {
                name: "step".into(),
                why: "give a reference: --step, --ramp, --sine or --target".into(),
            })
        }
    };
    let mut pneumatics = PneumaticSettings {
        lag: match args.tau_s {
            Some(tau_s) => LagModel::Fixed { tau_s },
            None => LagModel::Valve {
                conductance_l_min_kpa: args.valve_conductance,
            },
        },
        dead_time_s: args.dead_time_s,
        resolution_kpa: args.resolution_kpa,
        rate_limit_kpa_s: args.rate_limit_kpa_s,
        noise_deg: args.noise_deg,
        seed: args.seed,
        ..Default::default()
    };
    if let Some(r) = &args.regulator_kpa {
        let parsed = r.split_once(':').and_then(|(a, b)| {
            Some((a.trim().parse::<f64>().ok()?, b.trim().parse::<f64>().ok()?))
        });
        let Some((lo, hi)) = parsed else {
            return Err(ControlError::Setting {
                name: "regulator-kpa".into(),
                why: format!("`{r}`: expected MIN:MAX in kPa, e.g. 0:115"),
            });
        };
        pneumatics.min_kpa = lo;
        pneumatics.max_kpa = hi;
    }
    let gains = match args.kp {
        Some(kp) => GainChoice::Given(PidGains {
            kp_kpa_per_deg: kp,
            ki_kpa_per_deg_s: args.ki.unwrap_or(0.0),
            kd_kpa_s_per_deg: args.kd.unwrap_or(0.0),
        }),
        None => GainChoice::Tune {
            tau_c_s: args.tau_c_s,
        },
    };
    Ok(ControlSettings {
        reference,
        duration_s: args.duration_s,
        sample_s: args.sample_time_s,
        pneumatics,
        regulator_from_map: args.regulator_kpa.is_none(),
        gains,
        setpoint_weight: args.setpoint_weight,
        derivative_filter_n: args.derivative_filter_n,
        fem_in_loop_mesh_mm: args.fem_in_loop.then_some(args.fem_mesh_mm),
    })
}

fn opt_s(v: Option<f64>) -> String {
    v.map(|v| format!("{v:.3} s"))
        .unwrap_or_else(|| "never".into())
}

/// Runs `bendscope control`.
pub fn run(args: &ControlArgs) -> Result<u8> {
    let settings = match settings(args) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return Ok(EXIT_BAD_INPUT);
        }
    };
    let _lock = super::lock_output(&args.output)?;
    let bar = args
        .fem_in_loop
        .then(|| super::progress_bar(0, "FEM in the loop"));
    let result = control_to(&args.output, &args.plant, &settings, &mut |k, n| {
        if let Some(b) = &bar {
            b.set_length(n as u64 + 1);
            b.set_position(k as u64 + 1);
        }
    });
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let run = match result {
        Ok(r) => r,
        Err(e @ ControlError::Output { .. }) => return Err(e.into()),
        Err(e) => {
            eprintln!("error: {e}");
            return Ok(EXIT_BAD_INPUT);
        }
    };
    let r = &run.report;
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(t) = &r.tuning {
        super::out!(
            "tuned: FOPDT from a {:.1} -> {:.1} kPa open-loop step: gain {:.4} deg/kPa, tau {:.3} s, dead time {:.3} s (fit RMS {:.2} deg); SIMC tau_c {:.3} s",
            t.from_kpa, t.to_kpa, t.model.gain_deg_per_kpa, t.model.tau_s, t.model.dead_time_s, t.model.rms_deg, t.tau_c_s
        );
    }
    let g = &r.gains;
    super::out!(
        "gains: kp {:.4} kPa/deg, ki {:.4} kPa/(deg s), kd {:.4} kPa s/deg; lag tau {:.3}..{:.3} s, dead time {:.3} s, sample {:.3} s",
        g.kp_kpa_per_deg, g.ki_kpa_per_deg_s, g.kd_kpa_s_per_deg, r.lag_tau_s.0, r.lag_tau_s.1, r.pneumatics.dead_time_s, r.sample_time_s
    );
    if let Some(s) = &r.step {
        super::out!(
            "step {:.1} -> {:.1} deg: rise {}, overshoot {:.2}%, settling (2%) {}, steady-state error {:.3} deg",
            s.initial_deg,
            s.target_deg,
            opt_s(s.rise_time_s),
            s.overshoot_pct,
            opt_s(s.settling_time_s),
            s.steady_state_error_deg
        );
    }
    let t = &r.tracking;
    super::out!(
        "{}: IAE {:.3} deg s, RMSE {:.3} deg, max error {:.2} deg, highest pressure {:.1} kPa -> {}",
        r.plant,
        t.iae_deg_s,
        t.rmse_deg,
        t.max_abs_error_deg,
        r.max_pressure_kpa,
        args.output.display()
    );
    if let Some(f) = &r.fem_in_loop {
        super::out!(
            "map in the loop: IAE {:.3} deg s, RMSE {:.3} deg; FEM vs map: largest difference {:.3} deg; FEM ({} mm mesh): {} solves, {} Newton iterations, {:.3} s per sample",
            f.map_tracking.iae_deg_s,
            f.map_tracking.rmse_deg,
            f.max_abs_difference_deg,
            f.mesh_size_mm,
            f.solves,
            f.newton_iterations,
            f.seconds_per_sample
        );
        if (f.mesh_size_mm - f.map_mesh_size_mm).abs() > 1e-9 {
            eprintln!(
                "note: the map comes from a {} mm mesh, the FEM in the loop uses {} mm: part of the difference is mesh error (--fem-mesh-mm {} compares like with like)",
                f.map_mesh_size_mm, f.mesh_size_mm, f.map_mesh_size_mm
            );
        }
    }
    Ok(EXIT_OK)
}
