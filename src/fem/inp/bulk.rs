//! The silicone's bulk modulus in a deck for CalculiX: its C3D8I locks on nearly
//! incompressible silicone, so the deck warns ([`caveats`]) or softens it
//! ([`for_calculix`]), saying so in a note.

use crate::fem::config::{ActuatorConfig, MaterialConfig};

/// Bulk modulus, as a multiple of the initial shear modulus, above which [`caveats`] warns
/// that CalculiX's C3D8I may lock (it ran the strap's deck at 1000 mu0 but stopped the
/// reference's at 10 kPa; at 100 mu0 the reference's got to 100 kPa).
const CALCULIX_BULK_TO_SHEAR: f64 = 200.0;

/// What to know before running the deck of `cfg` in CalculiX 2.20, one line each (measured
/// in tests/simulate.rs and docs/src/howto/fem.md): its C3D8I may lock on silicone at the
/// default bulk modulus of 1000 mu0, and it stalls on smeared threads' membranes near 10 kPa.
pub fn caveats(cfg: &ActuatorConfig) -> Vec<String> {
    let mut out = Vec::new();
    let shape = cfg.shape();
    let stiff = shape
        .silicones(cfg)
        .into_iter()
        .filter_map(|(_, m)| m.yeoh().ok())
        .any(|y| y.bulk_modulus > CALCULIX_BULK_TO_SHEAR * 2.0 * y.c1);
    if stiff {
        out.push(
            format!("a bulk modulus above {CALCULIX_BULK_TO_SHEAR} mu0, where CalculiX's C3D8I may lock (the reference's default deck, 1000 mu0, stops at 10 kPa in CalculiX; at 100 mu0 it gets to 100 kPa): for CalculiX set about 100 mu0 (--bulk-modulus, or bulk_modulus_mpa in [material] and [tube.outer_material])"),
        );
    }
    out.extend(shape.deck_caveats(cfg));
    out
}

/// Bulk modulus of a deck for CalculiX ([`for_calculix`]), as a multiple of the initial
/// shear modulus: where its C3D8I gets the reference to 100 kPa.
pub const CALCULIX_DECK_BULK_TO_SHEAR: f64 = 100.0;

/// `cfg` as CalculiX's C3D8I takes it without locking: every silicone ([material], and
/// [tube.outer_material]) whose bulk modulus is above [`CALCULIX_BULK_TO_SHEAR`] mu0 (where
/// C3D8I locks) gets [`CALCULIX_DECK_BULK_TO_SHEAR`] mu0; a note per change, for the deck
/// and the output (`simulate --export-exact` writes the model as solved instead).
pub fn for_calculix(cfg: &ActuatorConfig) -> (ActuatorConfig, Vec<String>) {
    let mut deck = cfg.clone();
    let mut notes = Vec::new();
    let soften = |m: &mut MaterialConfig, key: &str, notes: &mut Vec<String>| {
        let Ok(y) = m.yeoh() else { return };
        let mu0 = 2.0 * y.c1;
        if y.bulk_modulus <= CALCULIX_BULK_TO_SHEAR * mu0 {
            return;
        }
        // The coefficients are scaled by `scale` in yeoh(): the ratio to mu0 is not.
        let c1 = m.c1.unwrap_or(m.preset.yeoh().c1);
        m.bulk_modulus_mpa = Some(CALCULIX_DECK_BULK_TO_SHEAR * 2.0 * c1);
        notes.push(format!(
            "the deck's {key} bulk modulus is {:.4} MPa ({CALCULIX_DECK_BULK_TO_SHEAR} mu0), not the {:.4} MPa ({:.0} mu0) solved here: CalculiX's C3D8I locks above {CALCULIX_BULK_TO_SHEAR} mu0 (--export-exact writes the model as solved)",
            CALCULIX_DECK_BULK_TO_SHEAR * mu0,
            y.bulk_modulus,
            y.bulk_modulus / mu0
        ));
    };
    let shape = deck.shape();
    for (key, m) in shape.silicones_mut(&mut deck) {
        soften(m, key, &mut notes);
    }
    (deck, notes)
}
