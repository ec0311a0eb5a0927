//! The threads of an imported mesh (`[threads.NAME]`): the section of each `thread.NAME`
//! curve, a fibre or cable bonded along tetrahedron edges ([`crate::fem::truss`]), and
//! the checks on it.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::fem::truss::TrussSection;
use crate::fem::FemError;

/// Largest thread diameter taken, mm: a thicker "thread" is a part to mesh as a volume.
pub const MAX_THREAD_DIAMETER_MM: f64 = 10.0;
/// Largest Young's modulus taken, MPa (1000 GPa, above carbon fibre's): a larger one is a
/// unit error (Pa for MPa).
pub const MAX_THREAD_MODULUS_MPA: f64 = 1.0e6;

/// One thread's section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThreadConfig {
    /// Diameter, mm.
    pub diameter_mm: f64,
    /// Young's modulus, MPa (Kevlar about 70 000, nylon about 3 000).
    pub youngs_modulus_mpa: f64,
    /// A cable: no force while shorter than at rest (a thread buckles at no load).
    #[serde(default = "yes")]
    pub tension_only: bool,
    /// Tensile strength, MPa, for its safety factor (none: not reported).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strength_mpa: Option<f64>,
}

fn yes() -> bool {
    true
}

/// The sections of `[threads]`, by thread name.
pub type Threads = BTreeMap<String, ThreadConfig>;

impl ThreadConfig {
    /// The truss section.
    pub fn section(&self) -> TrussSection {
        TrussSection {
            area_mm2: 0.25 * std::f64::consts::PI * self.diameter_mm.powi(2),
            youngs_modulus_mpa: self.youngs_modulus_mpa,
            tension_only: self.tension_only,
        }
    }
}

/// Checks each section on its own: a diameter in (0, [`MAX_THREAD_DIAMETER_MM`]], a
/// modulus in (0, [`MAX_THREAD_MODULUS_MPA`]], a positive strength.
pub fn validate(threads: &Threads) -> Result<(), FemError> {
    for (name, t) in threads {
        let bad = |key: &str, v: f64, what: String| {
            super::bad(
                &format!("[threads.{name}] {key}"),
                format!("{}: {what}", super::number_text(v)),
            )
        };
        let d = t.diameter_mm;
        if !(d.is_finite() && d > 0.0 && d <= MAX_THREAD_DIAMETER_MM) {
            return Err(bad(
                "diameter_mm",
                d,
                format!("give the thread's diameter in mm, above 0 and at most {MAX_THREAD_DIAMETER_MM}"),
            ));
        }
        let e = t.youngs_modulus_mpa;
        if !(e.is_finite() && e > 0.0 && e <= MAX_THREAD_MODULUS_MPA) {
            return Err(bad(
                "youngs_modulus_mpa",
                e,
                format!("give the thread's modulus in MPa, above 0 and at most {MAX_THREAD_MODULUS_MPA:e} (Kevlar: about 70000)"),
            ));
        }
        if let Some(s) = t.strength_mpa {
            if !(s.is_finite() && s > 0.0) {
                return Err(bad(
                    "strength_mpa",
                    s,
                    "must be a positive number of MPa".into(),
                ));
            }
        }
    }
    Ok(())
}
