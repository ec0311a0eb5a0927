//! Strain-limiting layer: a thin, stiff sheet (paper, fabric, fibre glass) moulded into
//! the actuator's base, as a thin linear-elastic solid bonded to the silicone.
//!
//! The layer is a slab of hexahedra through the whole base (length and width) at a
//! height in the bottom, one element thick, sharing its nodes with the silicone
//! (bonded). Its material is the compressible neo-Hookean solid with the layer's
//! Young's modulus E and Poisson ratio ν (μ = E / 2(1 + ν), κ = E / 3(1 − 2ν)), which is
//! the linear-elastic solid at the layer's small strains and stays objective under the
//! actuator's large rotations; the Q1/P0 element ([`super::hex`]) takes it as a Yeoh set
//! with C2 = C3 = 0. A sheet works mostly in membrane (stretch), which one element
//! through its thickness carries exactly; its own bending stiffness (E t³/12) is
//! negligible beside the silicone's.
//!
//! Verified against the composite (transformed-section) beam in pure bending
//! ([`composite_beam_curvature`]): a silicone strip with the layer at its bottom.

use serde::{Deserialize, Serialize};

use super::material::Yeoh;
use super::FemError;

/// An optional strain-limiting layer in the base (`[layer]` in the config).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LayerConfig {
    /// Thickness, mm.
    pub thickness_mm: f64,
    /// Young's modulus, MPa.
    pub youngs_modulus_mpa: f64,
    /// Poisson ratio.
    pub poisson_ratio: f64,
    /// Height of the layer's underside above the bottom face, mm (0: on the bottom).
    pub height_mm: f64,
}

/// Default layer: a fabric-like sheet, 0.2 mm, E = 200 MPa, ν = 0.3, 1 mm above the
/// bottom (measured on the reference actuator in the README; a paper-stiff layer,
/// 3 GPa, does not converge yet).
impl Default for LayerConfig {
    fn default() -> Self {
        Self {
            thickness_mm: 0.2,
            youngs_modulus_mpa: 200.0,
            poisson_ratio: 0.3,
            height_mm: 1.0,
        }
    }
}

fn bad(name: &str, why: String) -> FemError {
    FemError::Parameter {
        name: format!("layer.{name}"),
        why,
    }
}

impl LayerConfig {
    /// Checks the numbers against a base of thickness `f_mm`.
    pub fn validate(&self, f_mm: f64) -> Result<(), FemError> {
        for (name, v) in [
            ("thickness_mm", self.thickness_mm),
            ("youngs_modulus_mpa", self.youngs_modulus_mpa),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(name, format!("{v}: must be positive")));
            }
        }
        let nu = self.poisson_ratio;
        if !(nu.is_finite() && nu > -1.0 && nu < 0.5) {
            return Err(bad(
                "poisson_ratio",
                format!("{nu}: must be in (-1, 0.5) (paper and fabric: 0.2..0.4)"),
            ));
        }
        if !(self.height_mm.is_finite() && self.height_mm >= 0.0) {
            return Err(bad(
                "height_mm",
                format!("{}: must be >= 0", self.height_mm),
            ));
        }
        if self.height_mm + self.thickness_mm > f_mm + 1e-9 {
            return Err(bad(
                "height_mm",
                format!(
                    "the layer ({} + {} mm) does not fit in the base (f = {f_mm} mm): lower it or thin it",
                    self.height_mm, self.thickness_mm
                ),
            ));
        }
        Ok(())
    }

    /// The layer's material: compressible neo-Hookean with E and ν.
    pub fn material(&self) -> Yeoh {
        let (e, nu) = (self.youngs_modulus_mpa, self.poisson_ratio);
        let mu = e / (2.0 * (1.0 + nu));
        Yeoh {
            c1: 0.5 * mu,
            c2: 0.0,
            c3: 0.0,
            bulk_modulus: e / (3.0 * (1.0 - 2.0 * nu)),
        }
    }
}

/// One layer of a composite beam section: Young's modulus (MPa), bottom and top (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamLayer {
    /// Young's modulus, MPa.
    pub youngs_modulus_mpa: f64,
    /// Bottom of the layer, mm.
    pub z0_mm: f64,
    /// Top of the layer, mm.
    pub z1_mm: f64,
}

/// Neutral axis (mm) and bending stiffness per unit width (N mm) of a rectangular
/// composite section, by the transformed section (Euler-Bernoulli, layers bonded):
/// z_n = Σ E_i t_i z_i / Σ E_i t_i, D = Σ E_i (t_i³/12 + t_i (z_i − z_n)²).
pub fn composite_section(layers: &[BeamLayer]) -> (f64, f64) {
    let ea: f64 = layers
        .iter()
        .map(|l| l.youngs_modulus_mpa * (l.z1_mm - l.z0_mm))
        .sum();
    let z_n = layers
        .iter()
        .map(|l| l.youngs_modulus_mpa * (l.z1_mm - l.z0_mm) * 0.5 * (l.z0_mm + l.z1_mm))
        .sum::<f64>()
        / ea;
    let d = layers
        .iter()
        .map(|l| {
            let t = l.z1_mm - l.z0_mm;
            let zc = 0.5 * (l.z0_mm + l.z1_mm) - z_n;
            l.youngs_modulus_mpa * (t.powi(3) / 12.0 + t * zc * zc)
        })
        .sum();
    (z_n, d)
}

/// Curvature (1/mm) of a composite strip of width `width_mm` under the bending moment
/// `moment_nmm`: κ = M / (b D) ([`composite_section`]).
pub fn composite_beam_curvature(layers: &[BeamLayer], width_mm: f64, moment_nmm: f64) -> f64 {
    moment_nmm / (width_mm * composite_section(layers).1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::solve::{solve_static, Model, NewtonSettings};
    use nalgebra::Vector3;

    #[test]
    fn composite_section_of_two_equal_halves_is_the_homogeneous_one() {
        let l = [
            BeamLayer {
                youngs_modulus_mpa: 2.0,
                z0_mm: 0.0,
                z1_mm: 1.0,
            },
            BeamLayer {
                youngs_modulus_mpa: 2.0,
                z0_mm: 1.0,
                z1_mm: 3.0,
            },
        ];
        let (z, d) = composite_section(&l);
        assert!((z - 1.5).abs() < 1e-12 && (d - 2.0 * 27.0 / 12.0).abs() < 1e-12);
    }

    /// A silicone strip (4 mm, neo-Hookean μ = 0.2 MPa, κ = 1000 μ) with a 0.2 mm layer
    /// bonded under it (E = 200 MPa, ν = 0.3), length 20 mm, width 2 mm, under a pure
    /// moment: the traction E_i κ (z − z_n) of the exact beam solution on its end x = L,
    /// symmetry plane x = 0; `nx` elements along, `nz` through the silicone, one through
    /// the layer. Returns the FEM curvature, read from the end section's rotation, over
    /// the composite beam's M / (b D), and the all-silicone section's over it.
    fn strip_curvature_ratio(nx: usize, nz_silicone: usize) -> (f64, f64) {
        let silicone = Yeoh {
            c1: 0.1,
            c2: 0.0,
            c3: 0.0,
            bulk_modulus: 200.0,
        };
        let layer = LayerConfig {
            thickness_mm: 0.2,
            youngs_modulus_mpa: 200.0,
            poisson_ratio: 0.3,
            height_mm: 0.0,
        };
        let mu = 2.0 * silicone.c1;
        let e_s = 9.0 * silicone.bulk_modulus * mu / (3.0 * silicone.bulk_modulus + mu);
        let (len, width) = (20.0, 2.0);
        let zs: Vec<f64> = std::iter::once(0.0)
            .chain((0..=nz_silicone).map(|k| 0.2 + 4.0 * k as f64 / nz_silicone as f64))
            .collect();
        let sections = [
            BeamLayer {
                youngs_modulus_mpa: layer.youngs_modulus_mpa,
                z0_mm: 0.0,
                z1_mm: 0.2,
            },
            BeamLayer {
                youngs_modulus_mpa: e_s,
                z0_mm: 0.2,
                z1_mm: 4.2,
            },
        ];
        let (z_n, _) = composite_section(&sections);
        let kappa = 1e-4; // 1/mm: 0.1 degree over the strip, linear range
        let moment = kappa * width * composite_section(&sections).1;
        let nz = zs.len() - 1;
        let id = |i: usize, j: usize, k: usize| (k * 2 + j) * (nx + 1) + i;
        let mut nodes = vec![Vector3::zeros(); (nx + 1) * 2 * (nz + 1)];
        for k in 0..=nz {
            for j in 0..2 {
                for i in 0..=nx {
                    nodes[id(i, j, k)] =
                        Vector3::new(len * i as f64 / nx as f64, width * j as f64, zs[k]);
                }
            }
        }
        let mut elements = Vec::new();
        let mut element_material = Vec::new();
        for k in 0..nz {
            for i in 0..nx {
                elements.push([
                    id(i, 0, k),
                    id(i + 1, 0, k),
                    id(i + 1, 1, k),
                    id(i, 1, k),
                    id(i, 0, k + 1),
                    id(i + 1, 0, k + 1),
                    id(i + 1, 1, k + 1),
                    id(i, 1, k + 1),
                ]);
                element_material.push(u8::from(k == 0));
            }
        }
        let mut fixed = vec![false; 3 * nodes.len()];
        let mut loads = vec![0.0; 3 * nodes.len()];
        for k in 0..=nz {
            for j in 0..2 {
                fixed[3 * id(0, j, k)] = true;
            }
            fixed[3 * id(0, 0, k) + 1] = true;
        }
        fixed[3 * id(0, 0, 0) + 2] = true;
        // End x = L: traction σ(z) = −E_i κ (z − z_n) per element row, consistent nodal
        // forces of a linear load on each edge (b/2 to each of the 2 nodes across).
        for k in 0..nz {
            let e = if k == 0 {
                layer.youngs_modulus_mpa
            } else {
                e_s
            };
            let (za, zb) = (zs[k], zs[k + 1]);
            let (sa, sb) = (e * kappa * (za - z_n), e * kappa * (zb - z_n));
            let dz = zb - za;
            for j in 0..2 {
                loads[3 * id(nx, j, k)] += -0.5 * width * dz * (2.0 * sa + sb) / 6.0;
                loads[3 * id(nx, j, k + 1)] += -0.5 * width * dz * (sa + 2.0 * sb) / 6.0;
            }
        }
        let model = Model {
            nodes,
            elements,
            material: silicone,
            fixed,
            loads,
            pressure_faces: Vec::new(),
            volume_weights: crate::fem::pressure::CLOSED,
            element_material,
            extra_materials: vec![layer.material()],
            contact: None,
        };
        let r = solve_static(&model, &NewtonSettings::default()).unwrap();
        let (top, bottom) = (id(nx, 0, nz), id(nx, 0, 0));
        let fem = -(r.displacement[3 * top] - r.displacement[3 * bottom]) / (len * zs[nz]);
        let exact = composite_beam_curvature(&sections, width, moment);
        assert!((exact / kappa - 1.0).abs() < 1e-12);
        let homogeneous = composite_beam_curvature(
            &[BeamLayer {
                youngs_modulus_mpa: e_s,
                z0_mm: 0.0,
                z1_mm: 4.2,
            }],
            width,
            moment,
        );
        (fem / exact, homogeneous / exact)
    }

    #[test]
    fn bilayer_strip_in_pure_bending_matches_the_composite_beam() {
        let (coarse, homogeneous) = strip_curvature_ratio(40, 8);
        let (fine, _) = strip_curvature_ratio(80, 16);
        eprintln!(
            "bilayer strip, FEM / composite-beam curvature: {coarse:.4} (0.5 mm), {fine:.4} (0.25 mm); all-silicone section {homogeneous:.3}"
        );
        // The layer moves the neutral axis to the bottom: over 2x less curvature than the
        // same section all silicone. Trilinear elements are slightly too stiff in bending
        // (parasitic shear), less so on the finer mesh, which is within 1.5%.
        assert!(homogeneous > 2.0, "{homogeneous}");
        assert!(coarse < fine && fine <= 1.0 + 1e-3, "{coarse} {fine}");
        assert!((fine - 1.0).abs() < 0.015, "{fine}");
    }
}
