//! The analytic chamber model: an instant baseline beside the finite-element model.
//!
//! After Hao and Onal, as used in the smartphone study of method.md §4: the pressure P on
//! a chamber's end wall (w h) is carried by the walls around the cavity (two side walls of
//! height h and a top wall of width w + 2t, all of thickness t), giving the axial wall
//! stress
//!
//! sigma = P w h / ((2h + w + 2t) t),
//!
//! taken as the uniaxial nominal stress of the material (incompressible Yeoh,
//! P(λ) = 2 (λ - λ⁻²) W1(I1), I1 = λ² + 2/λ), inverted numerically for the stretch λ and
//! the strain eps = λ - 1. Each of the n chambers extends by l eps (l the distance between
//! the chamber's walls) over its height h on an inextensible bottom, which turns it by
//! 2 atan(l eps / (2h)):
//!
//! theta = 2 n atan(l eps / (2h)).
//!
//! Mapping onto the PneuNets geometry of [`super::actuator::Geometry`]: w = l (cavity
//! width), h = n (cavity height), t = (i - l) / 2 (side wall), l = e (cavity length),
//! n = chambers. The radius is the chamber pitch (g + d) over the turn of one chamber.
//! What the model leaves out (length constant, no radial bulging, no gravity, a rigid
//! bottom, the top wall as thin as the side walls) is discussed in the README.

use serde::Serialize;

use super::actuator::Geometry;
use super::material::Yeoh;
use super::FemError;

/// Largest stretch searched when inverting the uniaxial law (a silicone tears long before).
pub const MAX_STRETCH: f64 = 20.0;

/// Relative tolerance of the inverted stretch.
const STRETCH_TOLERANCE: f64 = 1e-12;

/// The chamber dimensions the model uses, mm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ChamberModel {
    /// Chamber (cavity) width w.
    pub width_mm: f64,
    /// Chamber (cavity) height h.
    pub height_mm: f64,
    /// Wall thickness t.
    pub wall_mm: f64,
    /// Distance between the chamber's walls l.
    pub wall_distance_mm: f64,
    /// Number of chambers n.
    pub chambers: usize,
    /// Chamber pitch along the actuator, mm (for the radius).
    pub pitch_mm: f64,
}

impl ChamberModel {
    /// The model's dimensions read off the actuator geometry (see the module doc).
    pub fn from_geometry(g: &Geometry) -> Self {
        Self {
            width_mm: g.l,
            height_mm: g.n,
            wall_mm: 0.5 * (g.i - g.l),
            wall_distance_mm: g.e,
            chambers: g.chambers,
            pitch_mm: g.g + g.d,
        }
    }

    /// Axial wall stress, MPa, at a pressure in kPa.
    pub fn axial_stress_mpa(&self, pressure_kpa: f64) -> f64 {
        let (w, h, t) = (self.width_mm, self.height_mm, self.wall_mm);
        pressure_kpa * 1e-3 * w * h / ((2.0 * h + w + 2.0 * t) * t)
    }
}

/// Incompressible Yeoh uniaxial nominal stress, MPa, at stretch `lambda` (method.md §5).
pub fn uniaxial_nominal_stress_mpa(m: &Yeoh, lambda: f64) -> f64 {
    let i1 = lambda * lambda + 2.0 / lambda;
    2.0 * (lambda - lambda.powi(-2)) * m.w1(i1)
}

/// The uniaxial stretch whose nominal stress is `stress_mpa` (>= 0): bisection on
/// [1, [`MAX_STRETCH`]], where the Yeoh law with C1 > 0 and C2, C3 >= 0 is increasing.
pub fn uniaxial_stretch(m: &Yeoh, stress_mpa: f64) -> Result<f64, FemError> {
    if !(stress_mpa.is_finite() && stress_mpa >= 0.0) {
        return Err(FemError::Model {
            why: format!(
                "analytic model: wall stress {stress_mpa} MPa is not a non-negative number"
            ),
        });
    }
    if stress_mpa == 0.0 {
        return Ok(1.0);
    }
    let (mut lo, mut hi) = (1.0_f64, MAX_STRETCH);
    if uniaxial_nominal_stress_mpa(m, hi) < stress_mpa {
        return Err(FemError::Model {
            why: format!(
                "analytic model: a wall stress of {stress_mpa:.3} MPa needs a stretch beyond {MAX_STRETCH}: lower the pressure"
            ),
        });
    }
    while hi - lo > STRETCH_TOLERANCE * hi {
        let mid = 0.5 * (lo + hi);
        if uniaxial_nominal_stress_mpa(m, mid) < stress_mpa {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(0.5 * (lo + hi))
}

/// One pressure of the analytic ramp.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AnalyticStep {
    /// Cavity pressure, kPa.
    pub pressure_kpa: f64,
    /// Axial wall stress sigma, MPa.
    pub axial_stress_mpa: f64,
    /// Axial wall strain eps (λ - 1).
    pub axial_strain: f64,
    /// Bending angle theta, degrees.
    pub bending_angle_deg: f64,
    /// Chamber pitch over one chamber's turn, mm (infinite when straight).
    pub radius_mm: f64,
    /// 1 / radius, 1/m.
    pub curvature_per_m: f64,
}

/// The analytic model at each pressure.
pub fn analytic_ramp(
    geometry: &Geometry,
    material: &Yeoh,
    pressures_kpa: &[f64],
) -> Result<Vec<AnalyticStep>, FemError> {
    let model = ChamberModel::from_geometry(geometry);
    pressures_kpa
        .iter()
        .map(|&p| {
            let sigma = model.axial_stress_mpa(p);
            let eps = uniaxial_stretch(material, sigma)? - 1.0;
            let turn = 2.0 * (model.wall_distance_mm * eps / (2.0 * model.height_mm)).atan();
            let theta = model.chambers as f64 * turn;
            let curvature_per_mm = turn / model.pitch_mm;
            Ok(AnalyticStep {
                pressure_kpa: p,
                axial_stress_mpa: sigma,
                axial_strain: eps,
                bending_angle_deg: theta.to_degrees(),
                radius_mm: 1.0 / curvature_per_mm,
                curvature_per_m: 1000.0 * curvature_per_mm,
            })
        })
        .collect()
}

/// The analytic model of a config's actuator at each pressure: its `[geometry]`'s chambers
/// in its material. Refused for the fibre-reinforced family: the chamber model is of
/// PneuNets chambers (the glove's and the strap's too, their layers left out), and the
/// tube has none (its `[geometry]` is not read).
pub fn analytic_config(
    cfg: &super::actuator::ActuatorConfig,
    pressures_kpa: &[f64],
) -> Result<Vec<AnalyticStep>, FemError> {
    if let Some(why) = cfg.shape().analytic_refusal() {
        return Err(FemError::Parameter {
            name: "family".into(),
            why: why.into(),
        });
    }
    analytic_ramp(&cfg.geometry, &cfg.material.yeoh()?, pressures_kpa)
}

/// Runs the analytic model over `cfg`'s ramp and writes `config.toml` and `steps.csv`
/// (pressure_kpa, radius_mm, curvature_per_m, bending_angle_deg: the columns of the FEM's
/// steps.csv it can fill; then axial_stress_mpa and axial_strain) into `out`.
pub fn analytic_to(
    out: &std::path::Path,
    cfg: &super::actuator::ActuatorConfig,
) -> Result<Vec<AnalyticStep>, FemError> {
    let output = |e: &dyn std::fmt::Display| FemError::Output { why: e.to_string() };
    let steps = analytic_config(cfg, &cfg.pressures_kpa()?)?;
    super::output::prepare_output_folder(out)?;
    let text = cfg.to_toml()?;
    super::output::remove_earlier_outputs(out)?;
    crate::io::write_atomic(&out.join("config.toml"), text.as_bytes()).map_err(|e| output(&e))?;
    let col = |name: &str, decimals: usize, f: fn(&AnalyticStep) -> f64| {
        crate::table::Column::num(name, decimals, steps.iter().map(f))
    };
    crate::table::write_csv(
        &out.join("steps.csv"),
        &[
            col("pressure_kpa", 4, |s| s.pressure_kpa),
            col("radius_mm", 4, |s| s.radius_mm),
            col("curvature_per_m", 4, |s| s.curvature_per_m),
            col("bending_angle_deg", 4, |s| s.bending_angle_deg),
            col("axial_stress_mpa", 6, |s| s.axial_stress_mpa),
            col("axial_strain", 6, |s| s.axial_strain),
        ],
    )
    .map_err(|e| output(&e))?;
    Ok(steps)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::material::MaterialPreset;

    #[test]
    fn inverted_stretch_gives_back_the_method_md_stresses() {
        let m = MaterialPreset::Proposed.yeoh();
        for (lambda, p) in [(1.1, 0.060635), (1.5, 0.375493), (2.0, 1.230124)] {
            let got = uniaxial_stretch(&m, p).unwrap();
            // The stresses have 6 significant digits: the stretch to ~1e-5.
            assert!(
                (got - lambda).abs() < 2e-5 * lambda,
                "{p} MPa: {got} vs {lambda}"
            );
        }
        assert_eq!(uniaxial_stretch(&m, 0.0).unwrap(), 1.0);
        assert!(uniaxial_stretch(&m, 1e9).is_err());
        assert!(uniaxial_stretch(&m, f64::NAN).is_err());
    }

    #[test]
    fn the_tube_has_no_chamber_model() {
        use crate::fem::{actuator::ActuatorConfig, family::Family};
        let tube = ActuatorConfig::for_family(Family::FibreReinforced);
        let err = analytic_config(&tube, &[10.0]).unwrap_err();
        assert!(err.is_bad_input(), "{err}");
        assert!(err.to_string().contains("family"), "{err}");
        let dir = tempfile::tempdir().unwrap();
        assert!(analytic_to(dir.path(), &tube).is_err());
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "nothing written"
        );
        // The glove's chambers have a model (its paper layer left out).
        let glove = ActuatorConfig::for_family(Family::Glove);
        assert!(analytic_config(&glove, &[10.0]).unwrap()[0].bending_angle_deg > 0.0);
    }

    #[test]
    fn reference_actuator_by_hand() {
        // w = 11, h = 12, t = 2, l = 5, n = 9 at 100 kPa:
        // sigma = 0.1 * 11 * 12 / ((24 + 11 + 4) * 2) = 13.2 / 78 MPa.
        let g = Geometry::default();
        let m = MaterialPreset::Proposed.yeoh();
        let s = analytic_ramp(&g, &m, &[0.0, 100.0]).unwrap();
        assert_eq!(s[0].bending_angle_deg, 0.0);
        assert!(s[0].radius_mm.is_infinite());
        let sigma = 13.2 / 78.0;
        assert!((s[1].axial_stress_mpa - sigma).abs() < 1e-12);
        let lambda = 1.0 + s[1].axial_strain;
        assert!((uniaxial_nominal_stress_mpa(&m, lambda) / sigma - 1.0).abs() < 1e-9);
        let theta = 18.0 * (5.0 * s[1].axial_strain / 24.0).atan();
        assert!((s[1].bending_angle_deg - theta.to_degrees()).abs() < 1e-9);
        // eps is about 0.27 there (P(1.27) ~ 0.17 MPa): about 60 degrees.
        assert!((0.2..0.35).contains(&s[1].axial_strain), "{:?}", s[1]);
        assert!((45.0..75.0).contains(&s[1].bending_angle_deg), "{:?}", s[1]);
    }
}
