//! Uniaxial test data and the least-squares fit of a model to it.
//!
//! The fit minimizes the squared nominal-stress residuals, Σ (P_model(λ_i) − P_i)², by
//! Levenberg-Marquardt (the `levenberg-marquardt` crate, as for the power law in
//! [`crate::fit`]). The uniaxial nominal stress of every offered model is linear in its
//! coefficients, so the optimum is unique and LM reaches it from any start in a couple of
//! iterations; the standard errors come from the Jacobian at the optimum,
//! sqrt(diag((JᵀJ)⁻¹) SSE / (n − k)). With `nonnegative`, every subset of the
//! coefficients beyond C10 is fitted with the others held at zero and the best fit with
//! all coefficients ≥ 0 is kept (the exact non-negative least-squares optimum for up to
//! three coefficients); Yeoh's FEM material needs C2, C3 ≥ 0.

use std::path::Path;

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DMatrix, DVector, Dyn, Owned};
use serde::Serialize;

use super::model::{Hyperelastic, ModelKind, Stability};
use super::MaterialFitError;
use crate::table::Table;

/// Smallest stretch of the stability check.
pub const STABILITY_MIN_STRETCH: f64 = 0.5;
/// The stability check reaches at least this stretch (further when the data do).
pub const STABILITY_MAX_STRETCH_AT_LEAST: f64 = 3.0;

/// Uniaxial test data: stretch and nominal stress.
#[derive(Debug, Clone, PartialEq)]
pub struct TensileData {
    /// Stretch λ = 1 + engineering strain.
    pub stretch: Vec<f64>,
    /// Nominal (engineering) stress, MPa.
    pub stress_mpa: Vec<f64>,
    /// The stress unit of the file (its header's).
    pub stress_unit: StressUnit,
    /// Implausible values, each naming its line (a stretch past where silicones break).
    pub warnings: Vec<String>,
}

/// Largest plausible stretch of a silicone tensile test: Ecoflex 00-30, among the most
/// extensible, breaks near stretch 10 (900% elongation); beyond it the column is likely
/// in another unit (strain in % read as a fraction, a length in mm).
pub const MAX_PLAUSIBLE_STRETCH: f64 = 10.0;

/// A stress unit of a data file's header.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum StressUnit {
    /// MPa (= N/mm²).
    Mpa,
    /// kPa.
    Kpa,
    /// Pa.
    Pa,
    /// psi.
    Psi,
}

/// MPa per psi.
pub const MPA_PER_PSI: f64 = 6.894_757e-3;

impl StressUnit {
    /// MPa per unit.
    pub fn mpa(&self) -> f64 {
        match self {
            StressUnit::Mpa => 1.0,
            StressUnit::Kpa => 1e-3,
            StressUnit::Pa => 1e-6,
            StressUnit::Psi => MPA_PER_PSI,
        }
    }

    /// Name as in a header.
    pub fn name(&self) -> &'static str {
        match self {
            StressUnit::Mpa => "mpa",
            StressUnit::Kpa => "kpa",
            StressUnit::Pa => "pa",
            StressUnit::Psi => "psi",
        }
    }
}

/// What a tensile file's header must look like.
pub const HEADER_HINT: &str = "the header names the stretch (`stretch`) or the strain (`strain` as a fraction, `strain_pct` in %) and the nominal stress with its unit (`stress_mpa`, `stress_kpa`, `stress_pa` or `stress_psi`), e.g. `strain_pct,stress_kpa`";

impl TensileData {
    /// Reads a CSV of stretch or strain vs nominal stress (units in the header, see
    /// [`HEADER_HINT`]); rows whose cells are not numbers are errors naming the line.
    pub fn read(path: &Path) -> Result<TensileData, MaterialFitError> {
        let table = Table::read(path)?;
        let find = |names: &[&str]| names.iter().find_map(|n| table.column(n));
        // The column, stretch from its value, and what a too large stretch likely means.
        type ToStretch = fn(f64) -> f64;
        let (strain_col, to_stretch, unit_hint): (usize, ToStretch, &str) =
            if let Some(c) = find(&["stretch", "lambda", "stretch_ratio"]) {
                (
                    c,
                    |v| v,
                    "if the column is a strain in %, name it `strain_pct`",
                )
            } else if let Some(c) = find(&["strain", "strain_mm_per_mm", "strain_fraction"]) {
                (
                    c,
                    |v| 1.0 + v,
                    "if the strain is in %, name the column `strain_pct`",
                )
            } else if let Some(c) = find(&["strain_pct", "strain_percent"]) {
                (
                    c,
                    |v| 1.0 + v / 100.0,
                    "check the unit of the strain column",
                )
            } else {
                return Err(table
                    .header_error(format!("no stretch or strain column: {HEADER_HINT}"))
                    .into());
            };
        let mut stress = None;
        for (k, name) in table.columns().iter().enumerate() {
            let lower = name.to_lowercase();
            let unit = lower
                .strip_prefix("nominal_stress_")
                .or_else(|| lower.strip_prefix("stress_"));
            if let Some(unit) = unit {
                let unit = match unit {
                    "mpa" | "n_mm2" => StressUnit::Mpa,
                    "kpa" => StressUnit::Kpa,
                    "pa" => StressUnit::Pa,
                    "psi" => StressUnit::Psi,
                    other => {
                        return Err(table
                            .header_error(format!(
                                "stress unit `{other}` of column `{name}` is not known: use mpa, kpa, pa or psi"
                            ))
                            .into())
                    }
                };
                stress = Some((k, unit));
                break;
            }
        }
        let Some((stress_col, unit)) = stress else {
            return Err(table
                .header_error(format!("no stress column: {HEADER_HINT}"))
                .into());
        };
        let mut data = TensileData {
            stretch: Vec::with_capacity(table.len()),
            stress_mpa: Vec::with_capacity(table.len()),
            stress_unit: unit,
            warnings: vec![],
        };
        // (row, value) of the largest implausible stretch, and how many there are.
        let mut too_long: Option<(usize, f64)> = None;
        let mut n_too_long = 0;
        for row in 0..table.len() {
            let s = table.f64_at(row, strain_col)?;
            let p = table.f64_at(row, stress_col)?;
            let lambda = to_stretch(s);
            if !(lambda.is_finite() && lambda > 0.0) {
                return Err(table
                    .error_at(
                        Some(row),
                        Some(strain_col),
                        format!("{s} gives the stretch {lambda}: a stretch must be positive"),
                    )
                    .into());
            }
            if !p.is_finite() {
                return Err(table
                    .error_at(Some(row), Some(stress_col), "the stress must be finite")
                    .into());
            }
            if lambda > MAX_PLAUSIBLE_STRETCH {
                n_too_long += 1;
                if too_long.is_none_or(|(_, l)| lambda > l) {
                    too_long = Some((row, lambda));
                }
            }
            data.stretch.push(lambda);
            data.stress_mpa.push(p * unit.mpa());
        }
        if let Some((row, lambda)) = too_long {
            let others = match n_too_long {
                1 => String::new(),
                n => format!(" ({n} rows beyond {MAX_PLAUSIBLE_STRETCH})"),
            };
            data.warnings.push(
                table
                    .error_at(
                        Some(row),
                        Some(strain_col),
                        format!(
                            "stretch {lambda} is far past where silicones break (below stretch ~{MAX_PLAUSIBLE_STRETCH}){others}: {unit_hint}"
                        ),
                    )
                    .to_string(),
            );
        }
        Ok(data)
    }

    /// The stretch range of the data.
    pub fn stretch_range(&self) -> (f64, f64) {
        self.stretch
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), l| {
                (a.min(*l), b.max(*l))
            })
    }
}

/// A fitted model.
#[derive(Debug, Clone, Serialize)]
pub struct MaterialFit {
    /// The model and its coefficients, MPa.
    pub model: Hyperelastic,
    /// Standard errors of the coefficients, MPa (NaN with no degree of freedom left).
    pub std_errors: Vec<f64>,
    /// Coefficient of determination of the nominal stress.
    pub r_squared: f64,
    /// RMS stress residual, MPa.
    pub rmse_mpa: f64,
    /// Number of points.
    pub points: usize,
    /// Stretch range of the data.
    pub data_stretch: (f64, f64),
    /// Initial shear modulus μ0, MPa.
    pub initial_shear_modulus_mpa: f64,
    /// Whether the coefficients were held non-negative.
    pub nonnegative: bool,
    /// Drucker stability over [`STABILITY_MIN_STRETCH`] ..
    /// max([`STABILITY_MAX_STRETCH_AT_LEAST`], largest stretch of the data).
    pub stability: Stability,
}

/// P(λ) = B c − y with B the basis at every point, for the LM crate.
struct Uniaxial<'a> {
    basis: &'a DMatrix<f64>,
    y: &'a DVector<f64>,
    c: DVector<f64>,
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Uniaxial<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, c: &DVector<f64>) {
        self.c.copy_from(c);
    }
    fn params(&self) -> DVector<f64> {
        self.c.clone()
    }
    fn residuals(&self) -> Option<DVector<f64>> {
        Some(self.basis * &self.c - self.y)
    }
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        Some(self.basis.clone())
    }
}

/// Least squares over the coefficients in `free` (the others zero); returns the full
/// coefficient vector and the SSE.
fn fit_subset(basis: &DMatrix<f64>, y: &DVector<f64>, free: &[usize]) -> (DVector<f64>, f64) {
    let b = basis.select_columns(free);
    // Start: C10 from the mean secant ratio P / basis_0, the others zero.
    let ratios: Vec<f64> = (0..b.nrows())
        .filter(|i| b[(*i, 0)].abs() > 1e-9)
        .map(|i| y[i] / b[(i, 0)])
        .collect();
    let mut start = DVector::zeros(free.len());
    start[0] = if ratios.is_empty() {
        0.1
    } else {
        ratios.iter().sum::<f64>() / ratios.len() as f64
    };
    let (solved, _) = LevenbergMarquardt::new().minimize(Uniaxial {
        basis: &b,
        y,
        c: start,
    });
    let mut full = DVector::zeros(basis.ncols());
    for (k, idx) in free.iter().enumerate() {
        full[*idx] = solved.c[k];
    }
    let sse = (basis * &full - y).norm_squared();
    (full, sse)
}

/// Fits `kind` to `data` (see the module doc).
pub fn fit_material(
    data: &TensileData,
    kind: ModelKind,
    nonnegative: bool,
) -> Result<MaterialFit, MaterialFitError> {
    let n = data.stretch.len();
    let k = kind.len();
    if n < k + 1 {
        return Err(MaterialFitError::Fit {
            why: format!(
                "{n} points for {k} coefficient(s): give at least {} (a whole test curve)",
                k + 1
            ),
        });
    }
    let basis = DMatrix::from_fn(n, k, |i, j| kind.uniaxial_basis(data.stretch[i])[j]);
    let y = DVector::from_column_slice(&data.stress_mpa);
    if (0..k).any(|j| basis.column(j).norm() < 1e-12) {
        return Err(MaterialFitError::Fit {
            why: "every point is at stretch 1 (no strain): give the whole test curve".into(),
        });
    }
    let (c, sse) = if nonnegative {
        // Every subset containing C10.
        (0..(1usize << (k - 1)))
            .map(|mask| {
                let free: Vec<usize> = std::iter::once(0)
                    .chain((1..k).filter(|j| mask & (1 << (j - 1)) != 0))
                    .collect();
                fit_subset(&basis, &y, &free)
            })
            .filter(|(c, _)| c.iter().all(|v| *v >= 0.0) && c[0] > 0.0)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .ok_or_else(|| MaterialFitError::Fit {
                why: "no fit with non-negative coefficients and C10 > 0: is the stress column positive in tension?".into(),
            })?
    } else {
        let all: Vec<usize> = (0..k).collect();
        fit_subset(&basis, &y, &all)
    };
    if !c.iter().all(|v| v.is_finite()) {
        return Err(MaterialFitError::Fit {
            why: "the fit gave non-finite coefficients: check the data".into(),
        });
    }
    let mean = y.mean();
    let sst: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let r_squared = if sst > 0.0 { 1.0 - sse / sst } else { 1.0 };
    let std_errors = (basis.transpose() * &basis)
        .try_inverse()
        .filter(|_| n > k)
        .map(|cov| {
            let s2 = sse / (n - k) as f64;
            (0..k).map(|j| (cov[(j, j)] * s2).sqrt()).collect()
        })
        .unwrap_or_else(|| vec![f64::NAN; k]);
    let model = Hyperelastic {
        kind,
        coefficients: c.iter().copied().collect(),
    };
    let data_stretch = data.stretch_range();
    let stability = model.stability(
        STABILITY_MIN_STRETCH.min(data_stretch.0),
        STABILITY_MAX_STRETCH_AT_LEAST.max(data_stretch.1),
    );
    Ok(MaterialFit {
        initial_shear_modulus_mpa: model.initial_shear_modulus(),
        model,
        std_errors,
        r_squared,
        rmse_mpa: (sse / n as f64).sqrt(),
        points: n,
        data_stretch,
        nonnegative,
        stability,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exact(kind: ModelKind, c: &[f64], lambdas: &[f64]) -> TensileData {
        let m = Hyperelastic {
            kind,
            coefficients: c.to_vec(),
        };
        TensileData {
            stretch: lambdas.to_vec(),
            stress_mpa: lambdas
                .iter()
                .map(|l| m.uniaxial_nominal_stress(*l))
                .collect(),
            stress_unit: StressUnit::Mpa,
            warnings: vec![],
        }
    }

    fn grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64)
            .collect()
    }

    #[test]
    fn exact_data_give_back_their_coefficients_within_1_percent() {
        let l = grid(1.0, 3.0, 30);
        for (kind, c) in [
            (ModelKind::Yeoh3, vec![0.10744, 0.0601, 0.000302]),
            (ModelKind::Yeoh2, vec![0.0127, 4.23e-4]),
            (ModelKind::NeoHookean, vec![0.0425]),
            (ModelKind::MooneyRivlin2, vec![0.05, 0.02]),
        ] {
            for nonneg in [false, true] {
                let fit = fit_material(&exact(kind, &c, &l), kind, nonneg).unwrap();
                for (got, want) in fit.model.coefficients.iter().zip(&c) {
                    assert!((got / want - 1.0).abs() < 0.01, "{kind:?}: {got} vs {want}");
                }
                assert!(fit.r_squared > 1.0 - 1e-9, "{}", fit.r_squared);
                assert!(fit.stability.stable);
            }
        }
    }

    #[test]
    fn the_nonnegative_fit_holds_negative_terms_at_zero() {
        // A softening curve: the free fit wants C20 < 0.
        let d = exact(ModelKind::Yeoh2, &[0.1, -0.004], &grid(1.0, 2.5, 20));
        let free = fit_material(&d, ModelKind::Yeoh2, false).unwrap();
        assert!((free.model.coefficients[1] + 0.004).abs() < 1e-6);
        let held = fit_material(&d, ModelKind::Yeoh2, true).unwrap();
        assert_eq!(held.model.coefficients[1], 0.0);
        assert!(held.model.coefficients[0] > 0.0 && held.r_squared < free.r_squared);
    }

    #[test]
    fn too_few_points_are_refused() {
        let d = exact(ModelKind::Yeoh3, &[0.1, 0.01, 0.001], &[1.2, 1.5, 2.0]);
        let e = fit_material(&d, ModelKind::Yeoh3, false).unwrap_err();
        assert!(e.to_string().contains("at least 4"), "{e}");
    }

    #[test]
    fn a_stretch_past_any_silicone_is_warned_at_its_line() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("t.csv");
        // A strain column in %, named as a fraction: stretches 11, 301, 151.
        std::fs::write(&p, "strain,stress_kpa\n0,0\n10,50\n300,200\n150,120\n").unwrap();
        let data = TensileData::read(&p).unwrap();
        assert_eq!(data.stretch, vec![1.0, 11.0, 301.0, 151.0]);
        assert_eq!(data.warnings.len(), 1, "{:?}", data.warnings);
        let w = &data.warnings[0];
        assert!(
            w.ends_with("t.csv: line 4, column strain: stretch 301 is far past where silicones break (below stretch ~10) (3 rows beyond 10): if the strain is in %, name the column `strain_pct`"),
            "{w}"
        );
        std::fs::write(&p, "strain_pct,stress_kpa\n0,0\n10,50\n300,200\n900,600\n").unwrap();
        assert!(TensileData::read(&p).unwrap().warnings.is_empty());
    }

    #[test]
    fn decimal_commas_in_a_comma_separated_file_are_refused_at_their_line() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("t.csv");
        std::fs::write(&p, "strain_pct,stress_kpa\n0,0\n10,20,5\n50,50,1\n").unwrap();
        let e = TensileData::read(&p).unwrap_err().to_string();
        assert!(
            e.ends_with("t.csv: line 3: this row has 3 fields where the header `strain_pct,stress_kpa` has 2 (`10,20,5`): decimal comma? use a semicolon separator or a decimal point (quote a text field that holds a comma: \"a, b\")"),
            "{e}"
        );
        std::fs::write(&p, "strain_pct;stress_kpa\n0;0\n10;20,5\n").unwrap();
        assert!((TensileData::read(&p).unwrap().stress_mpa[1] - 0.0205).abs() < 1e-12);
    }
}
