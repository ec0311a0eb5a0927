//! The incompressible hyperelastic models `material fit` offers, their uniaxial nominal
//! stress and their Drucker stability.
//!
//! Every model is a strain energy W(I1, I2) of the invariants of an incompressible
//! deformation (J = 1), with coefficients in MPa:
//!
//! - Yeoh (1993): W = Σ C_i0 (I1 − 3)^i, three terms (`yeoh3`) or two (`yeoh2`);
//! - neo-Hookean: W = C10 (I1 − 3), μ0 = 2 C10;
//! - Mooney-Rivlin, two terms: W = C10 (I1 − 3) + C01 (I2 − 3), μ0 = 2 (C10 + C01).
//!
//! Uniaxial tension (λ1 = λ, λ2 = λ3 = λ^−1/2), nominal (first Piola) stress:
//! P = 2 (λ − λ^−2) (W1 + W2 / λ), I1 = λ² + 2/λ (Treloar; e.g. Ogden, Non-linear Elastic
//! Deformations, §7.2). P is linear in the coefficients.
//!
//! Drucker stability (as in Abaqus' material evaluation, Analysis User's Guide §22.5.1):
//! dτ : dε > 0 for every increment of logarithmic strain. For an incompressible material
//! under plane stress with fixed principal axes, τ_i − τ_3 = ∂Ŵ/∂ε_i with
//! Ŵ(ε1, ε2) = W(λ1 = e^ε1, λ2 = e^ε2, λ3 = e^(−ε1−ε2)), so dτ : dε = dεᵀ H dε with H the
//! Hessian of Ŵ: the material is stable at a deformation when H is positive definite. It is
//! checked along uniaxial, equibiaxial and planar (pure shear) paths, in tension and
//! compression, as Abaqus does.

use serde::Serialize;

/// A hyperelastic model family offered by `material fit`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ModelKind {
    /// Yeoh, C10 C20 C30.
    Yeoh3,
    /// Yeoh, C10 C20.
    Yeoh2,
    /// Neo-Hookean, C10.
    NeoHookean,
    /// Mooney-Rivlin, C10 C01.
    MooneyRivlin2,
}

impl std::str::FromStr for ModelKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "yeoh3" | "yeoh" => Ok(Self::Yeoh3),
            "yeoh2" => Ok(Self::Yeoh2),
            "neo-hookean" | "neohookean" | "neo-hooke" => Ok(Self::NeoHookean),
            "mooney-rivlin2" | "mooney-rivlin" | "mooneyrivlin2" => Ok(Self::MooneyRivlin2),
            other => Err(format!(
                "unknown model '{other}': use yeoh3, yeoh2, neo-hookean or mooney-rivlin2"
            )),
        }
    }
}

impl ModelKind {
    /// The model's name on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            ModelKind::Yeoh3 => "yeoh3",
            ModelKind::Yeoh2 => "yeoh2",
            ModelKind::NeoHookean => "neo-hookean",
            ModelKind::MooneyRivlin2 => "mooney-rivlin2",
        }
    }

    /// Names of the coefficients, in order.
    pub fn coefficient_names(&self) -> &'static [&'static str] {
        match self {
            ModelKind::Yeoh3 => &["C10", "C20", "C30"],
            ModelKind::Yeoh2 => &["C10", "C20"],
            ModelKind::NeoHookean => &["C10"],
            ModelKind::MooneyRivlin2 => &["C10", "C01"],
        }
    }

    /// Number of coefficients.
    pub fn len(&self) -> usize {
        self.coefficient_names().len()
    }

    /// Whether the model has no coefficient (never).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// ∂P/∂c_k of the uniaxial nominal stress at stretch λ, for every coefficient
    /// (P = Σ c_k basis_k, linear in the coefficients).
    pub fn uniaxial_basis(&self, lambda: f64) -> Vec<f64> {
        let g = 2.0 * (lambda - lambda.powi(-2));
        let x = lambda * lambda + 2.0 / lambda - 3.0;
        match self {
            ModelKind::Yeoh3 => vec![g, 2.0 * g * x, 3.0 * g * x * x],
            ModelKind::Yeoh2 => vec![g, 2.0 * g * x],
            ModelKind::NeoHookean => vec![g],
            ModelKind::MooneyRivlin2 => vec![g, g / lambda],
        }
    }
}

/// A model with its coefficients, MPa.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Hyperelastic {
    /// The family.
    pub kind: ModelKind,
    /// Coefficients in the order of [`ModelKind::coefficient_names`], MPa.
    pub coefficients: Vec<f64>,
}

/// Derivatives of W(I1, I2) that the models have (W12 = W22 = 0 for all of them).
struct Derivatives {
    w1: f64,
    w2: f64,
    w11: f64,
}

impl Hyperelastic {
    fn c(&self, k: usize) -> f64 {
        self.coefficients.get(k).copied().unwrap_or(0.0)
    }

    /// Strain energy W(I1, I2), MPa.
    pub fn energy(&self, i1: f64, i2: f64) -> f64 {
        let x = i1 - 3.0;
        match self.kind {
            ModelKind::Yeoh3 | ModelKind::Yeoh2 | ModelKind::NeoHookean => {
                self.c(0) * x + self.c(1) * x * x + self.c(2) * x * x * x
            }
            ModelKind::MooneyRivlin2 => self.c(0) * x + self.c(1) * (i2 - 3.0),
        }
    }

    fn derivatives(&self, i1: f64) -> Derivatives {
        let x = i1 - 3.0;
        match self.kind {
            ModelKind::Yeoh3 | ModelKind::Yeoh2 | ModelKind::NeoHookean => Derivatives {
                w1: self.c(0) + 2.0 * self.c(1) * x + 3.0 * self.c(2) * x * x,
                w2: 0.0,
                w11: 2.0 * self.c(1) + 6.0 * self.c(2) * x,
            },
            ModelKind::MooneyRivlin2 => Derivatives {
                w1: self.c(0),
                w2: self.c(1),
                w11: 0.0,
            },
        }
    }

    /// Uniaxial nominal stress at stretch λ, MPa.
    pub fn uniaxial_nominal_stress(&self, lambda: f64) -> f64 {
        self.kind
            .uniaxial_basis(lambda)
            .iter()
            .zip(&self.coefficients)
            .map(|(b, c)| b * c)
            .sum()
    }

    /// Initial shear modulus μ0, MPa.
    pub fn initial_shear_modulus(&self) -> f64 {
        match self.kind {
            ModelKind::MooneyRivlin2 => 2.0 * (self.c(0) + self.c(1)),
            _ => 2.0 * self.c(0),
        }
    }

    /// The Hessian of Ŵ(ε1, ε2) at principal stretches (λ1, λ2), λ3 = 1/(λ1 λ2): the
    /// Drucker tangent of the plane-stress state.
    pub fn drucker_tangent(&self, l1: f64, l2: f64) -> [[f64; 2]; 2] {
        let l3 = 1.0 / (l1 * l2);
        let (a1, a2, a3) = (l1 * l1, l2 * l2, l3 * l3);
        let i1 = a1 + a2 + a3;
        let d = self.derivatives(i1);
        // ∂I1/∂ε_i = 2 (λ_i² − λ3²); ∂²I1 = 4 [[λ1² + λ3², λ3²], [λ3², λ2² + λ3²]];
        // I2 = λ1⁻² + λ2⁻² + λ3⁻²: ∂²I2 = 4 [[λ1⁻² + λ3⁻², λ3⁻²], [λ3⁻², λ2⁻² + λ3⁻²]].
        let g1 = [2.0 * (a1 - a3), 2.0 * (a2 - a3)];
        let h1 = [[4.0 * (a1 + a3), 4.0 * a3], [4.0 * a3, 4.0 * (a2 + a3)]];
        let (b1, b2, b3) = (1.0 / a1, 1.0 / a2, 1.0 / a3);
        let h2 = [[4.0 * (b1 + b3), 4.0 * b3], [4.0 * b3, 4.0 * (b2 + b3)]];
        let mut h = [[0.0; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                h[i][j] = d.w1 * h1[i][j] + d.w2 * h2[i][j] + d.w11 * g1[i] * g1[j];
            }
        }
        h
    }

    /// Whether the material is Drucker-stable at principal stretches (λ1, λ2) (plane
    /// stress): the tangent is positive definite.
    pub fn is_drucker_stable(&self, l1: f64, l2: f64) -> bool {
        let h = self.drucker_tangent(l1, l2);
        let det = h[0][0] * h[1][1] - h[0][1] * h[1][0];
        h[0][0] + h[1][1] > 0.0 && det > 0.0
    }

    /// Checks Drucker stability along the uniaxial, equibiaxial and planar paths for
    /// stretches `lo..=hi` (compression below 1, tension above), sampled at
    /// [`STABILITY_SAMPLES`] stretches each side of 1.
    pub fn stability(&self, lo: f64, hi: f64) -> Stability {
        let mut unstable = Vec::new();
        for mode in [Mode::Uniaxial, Mode::Equibiaxial, Mode::Planar] {
            for (side, end) in [("tension", hi), ("compression", lo)] {
                // From λ = 1 outwards: the first stretch that fails.
                let first = (1..=STABILITY_SAMPLES)
                    .map(|k| 1.0 + (end - 1.0) * k as f64 / STABILITY_SAMPLES as f64)
                    .find(|l| {
                        let (l1, l2) = mode.stretches(*l);
                        !self.is_drucker_stable(l1, l2)
                    });
                if let Some(stretch) = first {
                    unstable.push(Instability {
                        mode,
                        side,
                        first_stretch: stretch,
                    });
                }
            }
        }
        Stability {
            min_stretch: lo,
            max_stretch: hi,
            stable: unstable.is_empty(),
            unstable,
        }
    }
}

/// Stretches checked on each side of λ = 1 per deformation mode.
pub const STABILITY_SAMPLES: usize = 400;

/// A homogeneous deformation mode of the stability check.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// λ1 = λ, λ2 = λ3 = λ^−1/2.
    Uniaxial,
    /// λ1 = λ2 = λ, λ3 = λ^−2.
    Equibiaxial,
    /// Pure shear: λ1 = λ, λ2 = 1, λ3 = 1/λ.
    Planar,
}

impl Mode {
    /// (λ1, λ2) at stretch λ.
    pub fn stretches(&self, lambda: f64) -> (f64, f64) {
        match self {
            Mode::Uniaxial => (lambda, lambda.powf(-0.5)),
            Mode::Equibiaxial => (lambda, lambda),
            Mode::Planar => (lambda, 1.0),
        }
    }

    /// Name.
    pub fn name(&self) -> &'static str {
        match self {
            Mode::Uniaxial => "uniaxial",
            Mode::Equibiaxial => "equibiaxial",
            Mode::Planar => "planar",
        }
    }
}

/// Where a model loses Drucker stability.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Instability {
    /// The deformation mode.
    pub mode: Mode,
    /// `tension` (λ > 1) or `compression` (λ < 1).
    pub side: &'static str,
    /// The first stretch from λ = 1 where the tangent is not positive definite.
    pub first_stretch: f64,
}

/// The stability check of a model over a stretch range.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stability {
    /// Smallest stretch checked.
    pub min_stretch: f64,
    /// Largest stretch checked.
    pub max_stretch: f64,
    /// Stable over the whole range in every mode.
    pub stable: bool,
    /// Where it is not.
    pub unstable: Vec<Instability>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn invariants(l1: f64, l2: f64) -> (f64, f64) {
        let l3 = 1.0 / (l1 * l2);
        (
            l1 * l1 + l2 * l2 + l3 * l3,
            l1.powi(-2) + l2.powi(-2) + l3.powi(-2),
        )
    }

    fn models() -> Vec<Hyperelastic> {
        vec![
            Hyperelastic {
                kind: ModelKind::Yeoh3,
                coefficients: vec![0.10744, 0.0601, 0.000302],
            },
            Hyperelastic {
                kind: ModelKind::Yeoh3,
                coefficients: vec![0.1, -0.02, 0.001],
            },
            Hyperelastic {
                kind: ModelKind::MooneyRivlin2,
                coefficients: vec![0.08, -0.03],
            },
            Hyperelastic {
                kind: ModelKind::NeoHookean,
                coefficients: vec![0.0425],
            },
        ]
    }

    #[test]
    fn yeoh_uniaxial_matches_method_md_and_the_fem_material() {
        let m = &models()[0];
        for (lambda, p) in [(1.1, 0.060635), (1.5, 0.375493), (2.0, 1.230124)] {
            let got = m.uniaxial_nominal_stress(lambda);
            assert!((got / p - 1.0).abs() < 1e-5, "λ {lambda}: {got} vs {p}");
        }
    }

    #[test]
    fn uniaxial_stress_is_the_derivative_of_the_energy_along_the_path() {
        for m in models() {
            for lambda in [0.6, 0.9, 1.3, 2.0, 3.5] {
                let w = |l: f64| {
                    let (i1, i2) = invariants(l, l.powf(-0.5));
                    m.energy(i1, i2)
                };
                let h = 1e-6;
                let fd = (w(lambda + h) - w(lambda - h)) / (2.0 * h);
                let got = m.uniaxial_nominal_stress(lambda);
                assert!(
                    (got - fd).abs() < 1e-7 * got.abs().max(1e-3),
                    "{m:?} λ {lambda}: {got} vs fd {fd}"
                );
            }
        }
    }

    #[test]
    fn drucker_tangent_is_the_hessian_of_the_energy_in_log_strains() {
        for m in models() {
            for (l1, l2) in [
                (1.0f64, 1.0f64),
                (1.7, 0.8),
                (0.6, 1.4),
                (2.5, 2.5),
                (3.0, 1.0),
            ] {
                let w = |e1: f64, e2: f64| {
                    let (i1, i2) = invariants(e1.exp(), e2.exp());
                    m.energy(i1, i2)
                };
                let (e1, e2, h) = (l1.ln(), l2.ln(), 1e-4);
                let fd11 = (w(e1 + h, e2) - 2.0 * w(e1, e2) + w(e1 - h, e2)) / (h * h);
                let fd22 = (w(e1, e2 + h) - 2.0 * w(e1, e2) + w(e1, e2 - h)) / (h * h);
                let fd12 = (w(e1 + h, e2 + h) - w(e1 + h, e2 - h) - w(e1 - h, e2 + h)
                    + w(e1 - h, e2 - h))
                    / (4.0 * h * h);
                let t = m.drucker_tangent(l1, l2);
                let scale = t[0][0].abs() + t[1][1].abs();
                // Second differences, h = 1e-4: truncation ~h² relative, round-off ~1e-8.
                for (got, fd) in [(t[0][0], fd11), (t[1][1], fd22), (t[0][1], fd12)] {
                    assert!(
                        (got - fd).abs() < 1e-5 * scale,
                        "{m:?} ({l1}, {l2}): {got} vs fd {fd}"
                    );
                }
            }
        }
    }

    #[test]
    fn stability_finds_the_known_limits() {
        // Neo-Hookean and Yeoh with non-negative coefficients: stable everywhere.
        for k in [0, 3] {
            let s = models()[k].stability(0.1, 10.0);
            assert!(s.stable, "{s:?}");
        }
        // Yeoh with C20 < 0: W1 = 0.1 - 0.04 x + 0.003 x² is negative for 3.33 < x < 10
        // (uniaxial λ from 2.35), so the uniaxial stress turns over before λ = 2.35.
        let s = models()[1].stability(0.5, 3.0);
        assert!(!s.stable);
        let uni = s
            .unstable
            .iter()
            .find(|u| u.mode == Mode::Uniaxial && u.side == "tension")
            .expect("uniaxial tension unstable");
        // Along the uniaxial path dτ : dε = dε1² d(λP)/d(ln λ) (true stress τ = λP), so
        // Drucker fails there or earlier: where the true stress stops rising with the log
        // strain (not the nominal stress with the stretch: that turns first).
        let p = |l: f64| models()[1].uniaxial_nominal_stress(l);
        let tau = |l: f64| l * p(l);
        let turn = (1..1000)
            .map(|k| 1.0 + 2.0 * k as f64 / 1000.0)
            .find(|l| tau(l * 1.0001) <= tau(*l))
            .unwrap_or(3.0);
        assert!(turn < 2.35, "{turn}");
        assert!(uni.first_stretch <= turn + 0.01, "{uni:?} vs turn {turn}");
        // Mooney-Rivlin with C01 < 0 (C10 + C01 > 0): unstable in some mode within 0.5-3.
        let s = models()[2].stability(0.5, 3.0);
        assert!(!s.stable, "{s:?}");
    }
}
