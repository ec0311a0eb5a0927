//! The fibre-reinforced tube's section (`[tube]`): its dimensions, thread and outer
//! silicone, and the checks on them alone (the mesher is [`crate::fem::fibre`]).

use serde::{Deserialize, Serialize};

use super::MaterialConfig;
use crate::fem::material::MaterialPreset;
use crate::fem::FemError;

/// How the thread is wound (`[tube] winding`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Winding {
    /// A right- and a left-handed helix (bending with a bottom strip, extending without).
    #[default]
    Both,
    /// A right-handed helix only (twisting).
    OneWay,
}

/// How the thread is modelled (`[tube] fibre_model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum FibreModel {
    /// Each thread a line of bars embedded in the hexahedra (the thread as it lies, but
    /// of zero diameter: the tube softens without a limit as the mesh is refined).
    Line,
    /// Each hand's turns smeared over the interface: membranes that carry stress along
    /// the thread only, of the thread's modulus and thickness A / spacing (a continuum:
    /// the mesh converges).
    #[default]
    Smeared,
}

/// The fibre-reinforced tube (`[tube]`): dimensions, outer silicone, thread, mesh.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TubeConfig {
    /// Radius of the semicircular cavity, mm.
    pub inner_radius_mm: f64,
    /// Inner silicone layer's thickness ([material]), around the arc and under the cavity, mm.
    pub inner_wall_mm: f64,
    /// Outer silicone layer's thickness ([tube.outer_material]), mm.
    pub outer_wall_mm: f64,
    /// Length, mm.
    pub length_mm: f64,
    /// Clamped length from x = 0, mm.
    pub clamp_mm: f64,
    /// Solid end caps closing the cavity at both ends, mm.
    pub end_cap_mm: f64,
    /// `"both"` or `"one-way"`.
    pub winding: Winding,
    /// Advance along the tube per turn of a thread, mm.
    pub pitch_mm: f64,
    /// Thread diameter, mm.
    pub fibre_diameter_mm: f64,
    /// Thread's Young's modulus, MPa.
    pub fibre_modulus_mpa: f64,
    /// Thread's tensile strength, MPa.
    pub fibre_strength_mpa: f64,
    /// `"smeared"` (default) or `"line"`.
    pub fibre_model: FibreModel,
    /// The thread carries no compression (a cable); false (default): a bar, which
    /// converges in fewer Newton iterations (the threads stay in tension under pressure).
    pub fibre_tension_only: bool,
    /// A strain-limiting strip in the flat bottom: the config's `[[layer]]`s (sheets;
    /// without any, the family's glass-fibre plate, [`crate::fem::family::bottom_strip_layer`]).
    pub bottom_strip: bool,
    /// Markers along the side, evenly spaced from the clamp to the tip.
    pub markers: usize,
    /// The outer silicone layer.
    pub outer_material: MaterialConfig,
}

/// The DOE study's actuator as far as it is given (chosen values in docs/src/howto/fem.md),
/// wound both ways without a strip (extending): the strip's variant is a [[layer]] away.
impl Default for TubeConfig {
    fn default() -> Self {
        Self {
            inner_radius_mm: 6.0,
            inner_wall_mm: 1.5,
            outer_wall_mm: 1.0,
            length_mm: 100.0,
            clamp_mm: 10.0,
            end_cap_mm: 3.0,
            winding: Winding::Both,
            pitch_mm: 4.0,
            fibre_diameter_mm: 0.3,
            // Kevlar thread as modelled by Polygerinos et al. 2015.
            fibre_modulus_mpa: 31_067.0,
            fibre_strength_mpa: 3000.0,
            fibre_model: FibreModel::Smeared,
            fibre_tension_only: false,
            bottom_strip: false,
            markers: 8,
            outer_material: MaterialConfig {
                preset: MaterialPreset::DragonSkin10,
                // Smooth-On Dragon Skin 10: specific gravity 1.07, tensile strength 475 psi.
                density_g_cm3: 1.07,
                tensile_strength_mpa: 3.28,
                ..MaterialConfig::default()
            },
        }
    }
}

pub(crate) fn bad(name: &str, why: String) -> FemError {
    FemError::Parameter {
        name: format!("tube.{name}"),
        why,
    }
}

impl TubeConfig {
    /// Interface radius R1 and outer radius R2, mm.
    pub fn radii(&self) -> (f64, f64) {
        let r1 = self.inner_radius_mm + self.inner_wall_mm;
        (r1, r1 + self.outer_wall_mm)
    }

    /// Height of the cavity's flat floor (the bottom wall's thickness), mm.
    pub fn floor_mm(&self) -> f64 {
        self.inner_wall_mm + self.outer_wall_mm
    }

    /// Width of the flat bottom, mm.
    pub fn width_mm(&self) -> f64 {
        2.0 * self.radii().1
    }

    /// Checks every dimension.
    pub fn validate(&self) -> Result<(), FemError> {
        for (name, v) in [
            ("inner_radius_mm", self.inner_radius_mm),
            ("inner_wall_mm", self.inner_wall_mm),
            ("outer_wall_mm", self.outer_wall_mm),
            ("length_mm", self.length_mm),
            ("clamp_mm", self.clamp_mm),
            ("end_cap_mm", self.end_cap_mm),
            ("pitch_mm", self.pitch_mm),
            ("fibre_diameter_mm", self.fibre_diameter_mm),
            ("fibre_modulus_mpa", self.fibre_modulus_mpa),
            ("fibre_strength_mpa", self.fibre_strength_mpa),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(name, format!("{v}: must be positive")));
            }
        }
        if self.pitch_mm < self.fibre_diameter_mm {
            return Err(bad(
                "pitch_mm",
                format!(
                    "{} mm is less than the thread's diameter (fibre_diameter_mm = {} mm): neighbouring turns would overlap; use a pitch of at least {} mm",
                    self.pitch_mm, self.fibre_diameter_mm, self.fibre_diameter_mm
                ),
            ));
        }
        if self.clamp_mm < self.end_cap_mm {
            return Err(bad(
                "clamp_mm",
                format!(
                    "{} mm is shorter than the end cap ({} mm): clamp at least the cap",
                    self.clamp_mm, self.end_cap_mm
                ),
            ));
        }
        if self.clamp_mm + 2.0 * self.end_cap_mm >= self.length_mm {
            return Err(bad(
                "length_mm",
                format!(
                    "{} mm leaves no free cavity beyond the clamp ({} mm) and the tip cap ({} mm): make it longer",
                    self.length_mm, self.clamp_mm, self.end_cap_mm
                ),
            ));
        }
        if self.fibre_diameter_mm > self.inner_wall_mm.min(self.outer_wall_mm) {
            return Err(bad(
                "fibre_diameter_mm",
                format!(
                    "{} mm is thicker than a silicone layer it lies between: use a thinner thread or thicker walls",
                    self.fibre_diameter_mm
                ),
            ));
        }
        if !(3..=100).contains(&self.markers) {
            return Err(bad(
                "markers",
                format!("{}: use 3 to 100 (a circle needs three)", self.markers),
            ));
        }
        self.outer_material.yeoh().map(|_| ())
    }
}
