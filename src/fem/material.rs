//! Hyperelastic materials: strain energy, first Piola-Kirchhoff stress and its tangent.
//!
//! Yeoh (1993) with the usual isochoric/volumetric split:
//! W(F) = sum_{i=1..3} C_i (Ī1 - 3)^i + U(J),  Ī1 = J^(-2/3) tr(FᵀF),  J = det F,
//! U(J) = κ/4 (J² - 1 - 2 ln J) (the volumetric energy of method.md's Cook's membrane
//! case; U'(J) = κ/2 (J - 1/J), U''(J) = κ/2 (1 + 1/J²)). Neo-Hookean is C2 = C3 = 0
//! with μ = 2 C1. Units: MPa (= N/mm²).
//!
//! Stress: P = W1 ∂Ī1/∂F + U'(J) J F⁻ᵀ with W1 = dW/dĪ1 and
//! ∂Ī1/∂F = J^(-2/3) (2F - 2/3 I1 F⁻ᵀ). The tangent A = ∂P/∂F is derived from the same
//! expressions (index form in [`Yeoh::tangent`]) and checked by finite differences.

use nalgebra::{Matrix3, SMatrix};
use serde::{Deserialize, Serialize};

/// dP/dF as a 9x9 matrix, row 3i+J and column 3k+L for ∂P_iJ/∂F_kL.
pub type Tangent = SMatrix<f64, 9, 9>;

/// A hyperelastic material.
pub trait HyperelasticMaterial {
    /// Strain energy density W(F), MPa.
    fn energy(&self, f: &Matrix3<f64>) -> f64;
    /// First Piola-Kirchhoff stress ∂W/∂F, MPa.
    fn first_piola(&self, f: &Matrix3<f64>) -> Matrix3<f64>;
    /// Tangent ∂P/∂F.
    fn tangent(&self, f: &Matrix3<f64>) -> Tangent;
}

/// Yeoh coefficients (MPa) and bulk modulus κ (MPa).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Yeoh {
    /// C1, MPa (μ0 = 2 C1).
    pub c1: f64,
    /// C2, MPa.
    pub c2: f64,
    /// C3, MPa.
    pub c3: f64,
    /// Bulk modulus κ, MPa.
    pub bulk_modulus: f64,
}

/// Default bulk modulus as a multiple of the initial shear modulus μ0 = 2 C1 (ν ≈ 0.4995):
/// silicone is nearly incompressible; results should be reported with their sensitivity.
pub const DEFAULT_BULK_TO_SHEAR: f64 = 1000.0;

/// How far C1 may lie below the softest preset's or above the stiffest preset's before
/// [`c1_warning`] speaks: silicones span about 10x (Ecoflex 00-10 to Sylgard 184); 100x
/// is a unit slip (kPa or Pa written for MPa) or a digit too many.
pub const IMPLAUSIBLE_C1_FACTOR: f64 = 100.0;

/// A warning naming `c1_mpa` when it is more than [`IMPLAUSIBLE_C1_FACTOR`] softer than
/// the softest preset or stiffer than the stiffest; `what` names the value (`[material]
/// c1 = 107 MPa`).
pub fn c1_warning(c1_mpa: f64, what: &str) -> Option<String> {
    let c1 = |p: &MaterialPreset| p.yeoh().c1;
    let soft = MaterialPreset::ALL
        .iter()
        .min_by(|a, b| c1(a).total_cmp(&c1(b)))?;
    let stiff = MaterialPreset::ALL
        .iter()
        .max_by(|a, b| c1(a).total_cmp(&c1(b)))?;
    let (lo, hi) = (c1(soft), c1(stiff));
    if c1_mpa * IMPLAUSIBLE_C1_FACTOR < lo {
        Some(format!(
            "{what}: C1 = {c1_mpa} MPa is {:.0}x softer than the softest preset ({}, C1 = {lo} MPa): the coefficients are in MPa; check the value and its unit",
            lo / c1_mpa,
            soft.name()
        ))
    } else if c1_mpa > IMPLAUSIBLE_C1_FACTOR * hi {
        Some(format!(
            "{what}: C1 = {c1_mpa} MPa is {:.0}x stiffer than the stiffest preset ({}, C1 = {hi} MPa): the coefficients are in MPa (was it given in kPa?); check the value and its unit",
            c1_mpa / hi,
            stiff.name()
        ))
    } else {
        None
    }
}

/// Named material presets of method.md §4.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MaterialPreset {
    /// Dragon Skin 30, proposed set (default).
    Proposed,
    /// Stiffer literature set.
    Stiffer,
    /// Softer literature set.
    Softer,
    /// Ecoflex 00-30 (strap study).
    Ecoflex0030,
    /// Ecoflex 00-50, Yeoh C1 = 0.0127, C2 = 4.23e-4 MPa (smartphone study, from the Soft
    /// Robotics Toolkit).
    Ecoflex0050,
    /// Dragon Skin 10, neo-Hookean C1 = 0.0425 MPa (DOE study).
    #[serde(rename = "dragonskin10")]
    DragonSkin10,
    /// Dragon Skin 20, neo-Hookean C1 = 0.031648 MPa (DOE study).
    #[serde(rename = "dragonskin20")]
    DragonSkin20,
}

impl std::str::FromStr for MaterialPreset {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "proposed" => Ok(Self::Proposed),
            "stiffer" => Ok(Self::Stiffer),
            "softer" => Ok(Self::Softer),
            "ecoflex0030" | "ecoflex-00-30" | "ecoflex" => Ok(Self::Ecoflex0030),
            "ecoflex0050" | "ecoflex-00-50" => Ok(Self::Ecoflex0050),
            "dragonskin10" | "dragon-skin-10" => Ok(Self::DragonSkin10),
            "dragonskin20" | "dragon-skin-20" => Ok(Self::DragonSkin20),
            other => Err(format!(
                "unknown material '{other}': use {}",
                MaterialPreset::NAMES
            )),
        }
    }
}

impl MaterialPreset {
    /// Every preset's name, for messages.
    pub const NAMES: &'static str =
        "proposed, stiffer, softer, ecoflex0030, ecoflex0050, dragonskin10 or dragonskin20";

    /// Every preset.
    pub const ALL: [MaterialPreset; 7] = [
        MaterialPreset::Proposed,
        MaterialPreset::Stiffer,
        MaterialPreset::Softer,
        MaterialPreset::Ecoflex0030,
        MaterialPreset::Ecoflex0050,
        MaterialPreset::DragonSkin10,
        MaterialPreset::DragonSkin20,
    ];

    /// Its name in a config (`preset = "..."`).
    pub fn name(&self) -> &'static str {
        match self {
            MaterialPreset::Proposed => "proposed",
            MaterialPreset::Stiffer => "stiffer",
            MaterialPreset::Softer => "softer",
            MaterialPreset::Ecoflex0030 => "ecoflex0030",
            MaterialPreset::Ecoflex0050 => "ecoflex0050",
            MaterialPreset::DragonSkin10 => "dragonskin10",
            MaterialPreset::DragonSkin20 => "dragonskin20",
        }
    }

    /// The Yeoh coefficients with the default bulk modulus.
    pub fn yeoh(&self) -> Yeoh {
        let (c1, c2, c3) = match self {
            MaterialPreset::Proposed => (0.10744, 0.0601, 0.000302),
            MaterialPreset::Stiffer => (0.1, 0.119, 0.000604),
            MaterialPreset::Softer => (0.11488, 0.001262, 0.0),
            MaterialPreset::Ecoflex0030 => (0.1, 0.012, 4.96e-5),
            MaterialPreset::Ecoflex0050 => (0.0127, 4.23e-4, 0.0),
            MaterialPreset::DragonSkin10 => (0.0425, 0.0, 0.0),
            MaterialPreset::DragonSkin20 => (0.031648, 0.0, 0.0),
        };
        Yeoh {
            c1,
            c2,
            c3,
            bulk_modulus: DEFAULT_BULK_TO_SHEAR * 2.0 * c1,
        }
    }
}

impl Yeoh {
    /// dW/dĪ1 at Ī1.
    pub fn w1(&self, i1_bar: f64) -> f64 {
        let x = i1_bar - 3.0;
        self.c1 + 2.0 * self.c2 * x + 3.0 * self.c3 * x * x
    }

    /// d²W/dĪ1².
    fn w11(&self, i1_bar: f64) -> f64 {
        2.0 * self.c2 + 6.0 * self.c3 * (i1_bar - 3.0)
    }

    /// Isochoric energy, stress and tangent only (the volumetric part is handled by the
    /// element with its mean dilatation).
    pub fn isochoric(&self) -> Yeoh {
        Yeoh {
            bulk_modulus: 0.0,
            ..*self
        }
    }

    /// Volumetric energy U(J).
    pub fn u(&self, j: f64) -> f64 {
        0.25 * self.bulk_modulus * (j * j - 1.0 - 2.0 * j.ln())
    }
    /// U'(J).
    pub fn du(&self, j: f64) -> f64 {
        0.5 * self.bulk_modulus * (j - 1.0 / j)
    }
    /// U''(J).
    pub fn ddu(&self, j: f64) -> f64 {
        0.5 * self.bulk_modulus * (1.0 + 1.0 / (j * j))
    }
}

/// J, F⁻ᵀ, I1 and Ī1 of a deformation gradient (J must be positive).
fn kinematics(f: &Matrix3<f64>) -> (f64, Matrix3<f64>, f64, f64) {
    let j = f.determinant();
    let f_inv_t = f.try_inverse().unwrap_or_else(Matrix3::zeros).transpose();
    let i1 = f.norm_squared();
    (j, f_inv_t, i1, j.powf(-2.0 / 3.0) * i1)
}

impl HyperelasticMaterial for Yeoh {
    fn energy(&self, f: &Matrix3<f64>) -> f64 {
        let (j, _, _, i1b) = kinematics(f);
        let x = i1b - 3.0;
        self.c1 * x + self.c2 * x * x + self.c3 * x * x * x + self.u(j)
    }

    fn first_piola(&self, f: &Matrix3<f64>) -> Matrix3<f64> {
        let (j, fit, i1, i1b) = kinematics(f);
        let g = (f * 2.0 - fit * (2.0 / 3.0 * i1)) * j.powf(-2.0 / 3.0);
        g * self.w1(i1b) + fit * (self.du(j) * j)
    }

    fn tangent(&self, f: &Matrix3<f64>) -> Tangent {
        let (j, fit, i1, i1b) = kinematics(f);
        let jm = j.powf(-2.0 / 3.0);
        let g = (f * 2.0 - fit * (2.0 / 3.0 * i1)) * jm;
        let (w1, w11) = (self.w1(i1b), self.w11(i1b));
        let (du, ddu) = (self.du(j), self.ddu(j));
        let mut a = Tangent::zeros();
        for i in 0..3 {
            for jj in 0..3 {
                for k in 0..3 {
                    for l in 0..3 {
                        let d = |a: usize, b: usize| if a == b { 1.0 } else { 0.0 };
                        // ∂g_iJ/∂F_kL
                        let dg = -2.0 / 3.0 * fit[(k, l)] * g[(i, jj)]
                            + jm * (2.0 * d(i, k) * d(jj, l)
                                - 2.0 / 3.0
                                    * (2.0 * f[(k, l)] * fit[(i, jj)]
                                        - i1 * fit[(i, l)] * fit[(k, jj)]));
                        let iso = w11 * g[(i, jj)] * g[(k, l)] + w1 * dg;
                        let vol = (ddu * j + du) * j * fit[(k, l)] * fit[(i, jj)]
                            - du * j * fit[(i, l)] * fit[(k, jj)];
                        a[(3 * i + jj, 3 * k + l)] = iso + vol;
                    }
                }
            }
        }
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_c1_far_beyond_every_preset_is_warned_with_its_value() {
        let w = c1_warning(107.44, "[material] c1 = 107.44").unwrap();
        assert!(
            w.starts_with("[material] c1 = 107.44: C1 = 107.44 MPa is 935x stiffer than the stiffest preset (softer, C1 = 0.11488 MPa)"),
            "{w}"
        );
        let w = c1_warning(1e-5, "x").unwrap();
        assert!(
            w.contains("1270x softer than the softest preset (ecoflex0050"),
            "{w}"
        );
        for plausible in [0.0127, 0.005, 0.5, 0.10744] {
            assert_eq!(c1_warning(plausible, "x"), None, "{plausible}");
        }
    }

    fn proposed() -> Yeoh {
        MaterialPreset::Proposed.yeoh()
    }

    /// Incompressible uniaxial nominal stress from an isochoric stretch: the lateral
    /// faces are traction-free, so the hydrostatic part cancels in (σ11 - σ22) / λ.
    fn uniaxial(m: &Yeoh, lambda: f64) -> f64 {
        let f = Matrix3::from_diagonal(&nalgebra::Vector3::new(
            lambda,
            lambda.powf(-0.5),
            lambda.powf(-0.5),
        ));
        let sigma = m.first_piola(&f) * f.transpose() / f.determinant();
        (sigma[(0, 0)] - sigma[(1, 1)]) / lambda
    }

    fn equibiaxial(m: &Yeoh, lambda: f64) -> f64 {
        let f = Matrix3::from_diagonal(&nalgebra::Vector3::new(lambda, lambda, lambda.powi(-2)));
        let sigma = m.first_piola(&f) * f.transpose() / f.determinant();
        (sigma[(0, 0)] - sigma[(2, 2)]) / lambda
    }

    #[test]
    fn uniaxial_and_equibiaxial_match_method_md() {
        let m = proposed();
        for (lambda, p) in [(1.1, 0.060635), (1.5, 0.375493), (2.0, 1.230124)] {
            let got = uniaxial(&m, lambda);
            // The reference values have 6 significant digits.
            assert!((got / p - 1.0).abs() < 1e-5, "λ {lambda}: {got} vs {p}");
            // And the closed form itself to 1e-6 relative.
            let i1 = lambda * lambda + 2.0 / lambda;
            let exact = 2.0 * (lambda - lambda.powi(-2)) * m.w1(i1);
            assert!(
                (got / exact - 1.0).abs() < 1e-6,
                "λ {lambda}: {got} vs {exact}"
            );
        }
        let got = equibiaxial(&m, 2.0);
        assert!((got / 2.910491 - 1.0).abs() < 1e-6, "{got}");
    }

    fn sample_f() -> Vec<Matrix3<f64>> {
        vec![
            Matrix3::new(1.2, 0.1, -0.05, 0.03, 0.9, 0.2, -0.1, 0.05, 1.05),
            Matrix3::new(1.6, -0.3, 0.0, 0.2, 0.7, 0.1, 0.0, -0.2, 1.1),
            Matrix3::identity(),
        ]
    }

    #[test]
    fn stress_is_the_derivative_of_the_energy() {
        for m in [
            proposed(),
            MaterialPreset::Softer.yeoh(),
            Yeoh {
                bulk_modulus: 5.0,
                ..proposed()
            },
        ] {
            for f in sample_f() {
                let p = m.first_piola(&f);
                for i in 0..3 {
                    for j in 0..3 {
                        let h = 1e-6;
                        let mut fp = f;
                        fp[(i, j)] += h;
                        let mut fm = f;
                        fm[(i, j)] -= h;
                        let fd = (m.energy(&fp) - m.energy(&fm)) / (2.0 * h);
                        // Central differences, h = 1e-6: truncation ~h², round-off ~1e-10.
                        assert!(
                            (fd - p[(i, j)]).abs() < 1e-6 * p.norm().max(1.0),
                            "P[{i}{j}] {} vs fd {fd}",
                            p[(i, j)]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn tangent_is_the_derivative_of_the_stress() {
        for m in [proposed(), MaterialPreset::Stiffer.yeoh()] {
            for f in sample_f() {
                let a = m.tangent(&f);
                let scale = a.norm();
                for k in 0..3 {
                    for l in 0..3 {
                        let h = 1e-6;
                        let mut fp = f;
                        fp[(k, l)] += h;
                        let mut fm = f;
                        fm[(k, l)] -= h;
                        let fd = (m.first_piola(&fp) - m.first_piola(&fm)) / (2.0 * h);
                        for i in 0..3 {
                            for j in 0..3 {
                                let got = a[(3 * i + j, 3 * k + l)];
                                assert!(
                                    (got - fd[(i, j)]).abs() < 1e-6 * scale,
                                    "A[{i}{j},{k}{l}] {got} vs fd {}",
                                    fd[(i, j)]
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn reference_state_is_stress_free_and_linearizes_to_hooke() {
        let m = proposed();
        assert!(m.first_piola(&Matrix3::identity()).norm() < 1e-12);
        // Small simple shear: P12 = μ γ with μ = 2 C1.
        let g = 1e-6;
        let f = Matrix3::new(1.0, g, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        let p12 = m.first_piola(&f)[(0, 1)];
        assert!((p12 / (2.0 * m.c1 * g) - 1.0).abs() < 1e-5, "{p12}");
    }
}
