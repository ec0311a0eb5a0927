//! Strain-limiting layer: a thin, stiff sheet (paper, fabric, fibre glass) or strip
//! (PLA) moulded into the actuator's base, bonded to the silicone.
//!
//! Two ways to mesh it (`[layer] element`). `membrane` (default): membrane elements
//! ([`super::membrane`]) on the layer's mid-plane, sharing the silicone's nodes there;
//! the silicone mesh runs through the layer's volume (its own stiffness there, E_s t,
//! is 10⁻³-10⁻⁴ of the sheet's). A sheet works in membrane (stretch); its own bending
//! stiffness E t³/12 is left out (about 1-2% of the section's bending stiffness for a
//! 0.1-0.2 mm sheet on a 4 mm strip, less under the actuator's taller base). `solid`: a
//! slab of hexahedra through the layer's thickness, a compressible neo-Hookean solid
//! with the layer's E and ν (μ = E / 2(1 + ν), κ = E / 3(1 − 2ν): linear elastic at its
//! small strains, objective under large rotations; the Q1/P0 element ([`super::hex`])
//! takes it as a Yeoh set with C2 = C3 = 0), for a strip whose own bending stiffness
//! counts; trilinear hexahedra lock in bending when much longer than thick, so a solid
//! layer needs elements along it not much longer than its thickness.
//!
//! Verified against the composite (transformed-section) beam in pure bending
//! ([`composite_beam_curvature`]): a silicone strip with a fabric or paper sheet
//! (membrane) or a PLA strip (solid) at its bottom.

use serde::{Deserialize, Serialize};

use super::material::Yeoh;
use super::membrane::MembraneSection;
use super::FemError;

/// How a strain-limiting layer is meshed (`[layer] element`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum LayerElement {
    /// Membrane elements on the layer's mid-plane ([`super::membrane`]): for sheets
    /// (paper, fabric, fibre glass) whose own bending stiffness is negligible.
    #[default]
    Membrane,
    /// One slab of hexahedra through the layer's thickness: for strips whose own
    /// bending stiffness counts (a 1 mm PLA strip), meshed finely enough along.
    Solid,
    /// Membranes with the sheet's bending stiffness D = E t³ / 12 (1 − ν²) on their
    /// nodes ([`super::plate`]): for a stiff sheet that is compressed (a glass-fibre
    /// strip under a sagging or bending actuator), where a membrane alone wrinkles at
    /// the mesh's wavelength.
    Plate,
}

/// Thickest sheet taken as membranes on a tetrahedral mesh's faces (an imported mesh's
/// `layer.NAME`, the segmented finger's sheet), mm: a membrane carries a sheet's stretch,
/// not the bending of a slab.
pub const MAX_SHEET_MM: f64 = 5.0;

/// A strain-limiting layer in the base (`[layer]` in the config, or several as
/// `[[layer]]`): a sheet across the whole width, or one or two strips along the length.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LayerConfig {
    /// What the layer is (paper, fabric, PLA strips...): names its stress columns.
    pub name: String,
    /// Thickness, mm.
    pub thickness_mm: f64,
    /// Young's modulus, MPa.
    pub youngs_modulus_mpa: f64,
    /// Poisson ratio.
    pub poisson_ratio: f64,
    /// Height of the layer's underside above the bottom face, mm (0: on the bottom).
    pub height_mm: f64,
    /// How the layer is meshed: `"membrane"` (default), `"plate"` (membranes with the
    /// sheet's bending stiffness) or `"solid"`.
    pub element: LayerElement,
    /// Width of each strip, mm; absent: a sheet across the whole width.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub width_mm: Option<f64>,
    /// Strips (with `width_mm`): 1, centred, or 2, symmetric about the centre line.
    pub strips: usize,
    /// Centre-to-centre distance of two strips, mm.
    pub spacing_mm: f64,
    /// Tensile strength, MPa (its safety factor; absent: none reported).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tensile_strength_mpa: Option<f64>,
}

/// Default layer: a fabric-like sheet, 0.2 mm, E = 200 MPa, ν = 0.3, 1 mm above the
/// bottom, as membranes (measured on the reference actuator in the README).
impl Default for LayerConfig {
    fn default() -> Self {
        Self {
            name: "layer".into(),
            thickness_mm: 0.2,
            youngs_modulus_mpa: 200.0,
            poisson_ratio: 0.3,
            height_mm: 1.0,
            element: LayerElement::Membrane,
            width_mm: None,
            strips: 1,
            spacing_mm: 0.0,
            tensile_strength_mpa: None,
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
    /// The y ranges the layer covers in the half model (y >= 0) of an actuator of width
    /// `width_mm`.
    pub fn half_y_ranges(&self, width_mm: f64) -> Vec<(f64, f64)> {
        match (self.width_mm, self.strips) {
            (None, _) => vec![(0.0, 0.5 * width_mm)],
            (Some(w), 1) => vec![(0.0, 0.5 * w)],
            (Some(w), _) => vec![(0.5 * (self.spacing_mm - w), 0.5 * (self.spacing_mm + w))],
        }
    }

    /// Checks the strips' layout against an actuator of width `width_mm`.
    pub fn validate_width(&self, width_mm: f64) -> Result<(), FemError> {
        let Some(w) = self.width_mm else {
            if self.strips != 1 {
                return Err(bad(
                    "strips",
                    format!("{} strips need a width_mm (without it the layer is one sheet across the whole width)", self.strips),
                ));
            }
            return Ok(());
        };
        if !(w.is_finite() && w > 0.0) {
            return Err(bad("width_mm", format!("{w}: must be positive")));
        }
        match self.strips {
            1 if w > width_mm + 1e-9 => Err(bad(
                "width_mm",
                format!("a {w} mm strip is wider than the actuator (i = {width_mm} mm): narrow it or leave width_mm out for a sheet"),
            )),
            1 => Ok(()),
            2 => {
                let s = self.spacing_mm;
                if !(s.is_finite() && s >= w) {
                    Err(bad(
                        "spacing_mm",
                        format!("{s}: two {w} mm strips need a centre-to-centre spacing of at least their width"),
                    ))
                } else if s + w > width_mm + 1e-9 {
                    Err(bad(
                        "spacing_mm",
                        format!("two {w} mm strips {s} mm apart span {} mm, more than the width i = {width_mm} mm", s + w),
                    ))
                } else {
                    Ok(())
                }
            }
            n => Err(bad("strips", format!("{n}: use 1 (centred) or 2 (symmetric)"))),
        }
    }

    /// Checks the numbers against a base of thickness `f_mm`.
    pub fn validate(&self, f_mm: f64) -> Result<(), FemError> {
        if let Some(v) = self.tensile_strength_mpa {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(
                    "tensile_strength_mpa",
                    format!("{v}: must be positive"),
                ));
            }
        }
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

    /// The layer as a membrane section (thickness, E, ν).
    pub fn section(&self) -> MembraneSection {
        MembraneSection::isotropic(
            self.thickness_mm,
            self.youngs_modulus_mpa,
            self.poisson_ratio,
        )
    }

    /// Meshed as membranes (with or without bending stiffness), not as hexahedra.
    pub fn is_sheet(&self) -> bool {
        self.element != LayerElement::Solid
    }

    /// The sheet's flexural rigidity D, N mm, when it is a plate (`None` otherwise).
    pub fn plate_rigidity(&self) -> Option<f64> {
        (self.element == LayerElement::Plate).then(|| {
            super::plate::flexural_rigidity(
                self.thickness_mm,
                self.youngs_modulus_mpa,
                self.poisson_ratio,
            )
        })
    }

    /// The bending terms of this layer's membranes `part` (indices into `membranes`) on
    /// `nodes`, mirrored at `mirrors` ([`super::plate`]); none unless it is a plate.
    pub fn plate_terms(
        &self,
        nodes: &[nalgebra::Vector3<f64>],
        membranes: &[super::membrane::MembraneElement],
        part: &[usize],
        mirrors: &[super::plate::Mirror],
    ) -> Vec<super::plate::PlateTerm> {
        self.plate_rigidity().map_or_else(Vec::new, |d| {
            super::plate::plate_terms(nodes, membranes, part, d, self.poisson_ratio, mirrors)
        })
    }

    /// Height of the membrane's plane above the bottom face, mm: the layer's mid-plane.
    pub fn membrane_height_mm(&self) -> f64 {
        self.height_mm + 0.5 * self.thickness_mm
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
    use crate::fem::membrane::MembraneElement;
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

    /// A silicone strip (4 mm, neo-Hookean μ = 0.2 MPa, κ = 1000 μ) with `layer` bonded
    /// under it (0 to t), length 20 mm, width 2 mm, under a pure moment: the traction
    /// E_i κ (z − z_n) of the exact beam solution on its end x = L, symmetry plane x = 0;
    /// `nx` elements along, `nz` through the silicone. A solid layer gets `nz_layer`
    /// hexahedra through its thickness; a membrane layer lies on its mid-plane z = t/2
    /// with silicone (one element) between it and the bottom face, as in the actuator.
    /// Returns the FEM curvature, read from the end section's rotation, over the
    /// composite beam's M / (b D), and the all-silicone section's over it.
    fn strip_curvature_ratio(
        layer: &LayerConfig,
        nx: usize,
        nz_silicone: usize,
        nz_layer: usize,
    ) -> (f64, f64) {
        let silicone = Yeoh {
            c1: 0.1,
            c2: 0.0,
            c3: 0.0,
            bulk_modulus: 200.0,
        };
        let t = layer.thickness_mm;
        let mu = 2.0 * silicone.c1;
        let e_s = 9.0 * silicone.bulk_modulus * mu / (3.0 * silicone.bulk_modulus + mu);
        let (len, width) = (20.0, 2.0);
        let solid = layer.element == LayerElement::Solid;
        let bottom: Vec<f64> = if solid {
            (0..nz_layer)
                .map(|k| t * k as f64 / nz_layer as f64)
                .collect()
        } else {
            vec![0.0, 0.5 * t]
        };
        let zs: Vec<f64> = bottom
            .into_iter()
            .chain((0..=nz_silicone).map(|k| t + 4.0 * k as f64 / nz_silicone as f64))
            .collect();
        let sections = [
            BeamLayer {
                youngs_modulus_mpa: layer.youngs_modulus_mpa,
                z0_mm: 0.0,
                z1_mm: t,
            },
            BeamLayer {
                youngs_modulus_mpa: e_s,
                z0_mm: t,
                z1_mm: t + 4.0,
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
        let in_layer = |k: usize| solid && zs[k + 1] <= t + 1e-12;
        let mut elements = Vec::new();
        let mut element_material = Vec::new();
        let mut membranes = Vec::new();
        for i in 0..nx {
            for k in 0..nz {
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
                element_material.push(u8::from(in_layer(k)));
            }
            if !solid {
                membranes.push(MembraneElement {
                    nodes: [id(i, 0, 1), id(i + 1, 0, 1), id(i + 1, 1, 1), id(i, 1, 1)],
                    section: layer.section(),
                });
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
        // End x = L: traction σ(z) = −E_i κ (z − z_n) of the exact solution, consistent
        // nodal forces of a linear load on each edge (b/2 to each of the 2 nodes across);
        // a membrane's share, E κ (z_m − z_n) t b, goes to its two end nodes.
        for k in 0..nz {
            let e = if in_layer(k) {
                layer.youngs_modulus_mpa
            } else if zs[k] >= t - 1e-12 {
                e_s
            } else {
                continue; // the silicone under a membrane: in the layer's volume
            };
            let (za, zb) = (zs[k], zs[k + 1]);
            let (sa, sb) = (e * kappa * (za - z_n), e * kappa * (zb - z_n));
            let dz = zb - za;
            for j in 0..2 {
                loads[3 * id(nx, j, k)] += -0.5 * width * dz * (2.0 * sa + sb) / 6.0;
                loads[3 * id(nx, j, k + 1)] += -0.5 * width * dz * (sa + 2.0 * sb) / 6.0;
            }
        }
        if !solid {
            let s = layer.youngs_modulus_mpa * kappa * (0.5 * t - z_n);
            for j in 0..2 {
                loads[3 * id(nx, j, 1)] += -0.5 * width * t * s;
            }
        }
        // A plate also carries its own couple −E κ b t³/12 (the linear stress through its
        // thickness about its mid-plane): a pair of z forces on the last two columns.
        let all: Vec<usize> = (0..membranes.len()).collect();
        // x = 0 is a symmetry plane of the pure bending: the sheet is mirrored there.
        let mirror = [crate::fem::plate::Mirror { axis: 0, at: 0.0 }];
        let plates = layer.plate_terms(&nodes, &membranes, &all, &mirror);
        if layer.plate_rigidity().is_some() {
            let dx = len / nx as f64;
            let f = layer.youngs_modulus_mpa * kappa * width * t.powi(3) / (12.0 * dx);
            for j in 0..2 {
                loads[3 * id(nx, j, 1) + 2] += 0.5 * f;
                loads[3 * id(nx - 1, j, 1) + 2] -= 0.5 * f;
            }
        }
        let model = Model {
            tri_membranes: Vec::new(),
            nodes,
            elements,
            material: silicone,
            fixed,
            loads,
            pressure_faces: Vec::new(),
            volume_weights: crate::fem::pressure::CLOSED,
            element_material,
            extra_materials: vec![layer.material()],
            membranes,
            trusses: Vec::new(),
            plates,
            contact: None,
            incompatible_modes: false,
            tets: Default::default(),
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
                z1_mm: t + 4.0,
            }],
            width,
            moment,
        );
        (fem / exact, homogeneous / exact)
    }

    fn fabric(element: LayerElement) -> LayerConfig {
        LayerConfig {
            thickness_mm: 0.2,
            youngs_modulus_mpa: 200.0,
            poisson_ratio: 0.3,
            height_mm: 0.0,
            element,
            ..LayerConfig::default()
        }
    }

    #[test]
    fn bilayer_strip_in_pure_bending_matches_the_composite_beam() {
        let layer = fabric(LayerElement::Solid);
        let (coarse, homogeneous) = strip_curvature_ratio(&layer, 40, 8, 1);
        let (fine, _) = strip_curvature_ratio(&layer, 80, 16, 1);
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

    /// The same strip with the sheet as membranes on its mid-plane: a fabric sheet
    /// (0.2 mm, 200 MPa) and a paper sheet (0.1 mm, 3 GPa, 5000 x the silicone). The
    /// membrane lacks the sheet's own bending stiffness E t³/12 (0.9% and 1.7% of the
    /// section's D here) and the exact beam counts it, so the FEM curves slightly more.
    #[test]
    fn membrane_sheet_in_pure_bending_matches_the_composite_beam() {
        for layer in [
            fabric(LayerElement::Membrane),
            LayerConfig {
                thickness_mm: 0.1,
                youngs_modulus_mpa: 3000.0,
                ..fabric(LayerElement::Membrane)
            },
        ] {
            let (coarse, homogeneous) = strip_curvature_ratio(&layer, 40, 8, 1);
            let (fine, _) = strip_curvature_ratio(&layer, 80, 16, 1);
            eprintln!(
                "membrane {} mm, {} MPa: FEM / composite-beam curvature {coarse:.4} (0.5 mm), {fine:.4} (0.25 mm); all-silicone {homogeneous:.3}",
                layer.thickness_mm, layer.youngs_modulus_mpa
            );
            assert!(homogeneous > 2.0, "{homogeneous}");
            assert!((coarse - 1.0).abs() < 0.015, "{coarse}");
            assert!((fine - 1.0).abs() < 0.015, "{fine}");
        }
    }

    /// A glass-fibre strip (0.5 mm, 6.5 GPa) whose own bending stiffness E t³/12 is
    /// most of the section's (ν = 0: beam and plate agree): as a plate (membranes with
    /// [`crate::fem::plate`]'s bending terms) it matches the composite beam; without
    /// them it would curve several times more (the strip's own share of D is ~80%).
    #[test]
    fn plate_strip_in_pure_bending_matches_the_composite_beam() {
        let glass = LayerConfig {
            thickness_mm: 0.5,
            youngs_modulus_mpa: 6500.0,
            poisson_ratio: 0.0,
            height_mm: 0.0,
            element: LayerElement::Plate,
            ..LayerConfig::default()
        };
        let (coarse, homogeneous) = strip_curvature_ratio(&glass, 40, 8, 1);
        let (fine, _) = strip_curvature_ratio(&glass, 80, 16, 1);
        // The strip's own share of the section's bending stiffness (silicone E = 0.6 MPa).
        let sections = [
            BeamLayer {
                youngs_modulus_mpa: 6500.0,
                z0_mm: 0.0,
                z1_mm: 0.5,
            },
            BeamLayer {
                youngs_modulus_mpa: 0.6 * 200.0 / (200.0 + 0.2 / 3.0),
                z0_mm: 0.5,
                z1_mm: 4.5,
            },
        ];
        let own = 6500.0 * 0.5f64.powi(3) / 12.0 / composite_section(&sections).1;
        eprintln!(
            "glass plate: FEM / composite-beam curvature {coarse:.4} (0.5 mm), {fine:.4} (0.25 mm); the strip's own share of D {own:.3}; all-silicone {homogeneous:.3}"
        );
        assert!(own > 0.7, "{own}");
        assert!((coarse - 1.0).abs() < 0.015, "{coarse}");
        assert!((fine - 1.0).abs() < 0.015, "{fine}");
    }

    /// A PLA strip (1 mm, 4 GPa) as a solid layer, 4 hexahedra through it: its own
    /// bending stiffness dominates the section (56 x the all-silicone one). Beam theory
    /// leaves the strip free to curve anticlastically across its width; one element
    /// across the 2 mm width cannot (it is linear in y), so with ν = 0.35 the strip sits
    /// between the beam and the plate (D / (1 − ν²), curvature ratio 0.8775); with ν = 0
    /// there is no anticlastic curvature and the beam must be met.
    #[test]
    fn pla_strip_in_pure_bending_matches_the_composite_beam() {
        let pla = LayerConfig {
            thickness_mm: 1.0,
            youngs_modulus_mpa: 4000.0,
            poisson_ratio: 0.35,
            height_mm: 0.0,
            element: LayerElement::Solid,
            ..LayerConfig::default()
        };
        let no_poisson = LayerConfig {
            poisson_ratio: 0.0,
            ..pla.clone()
        };
        let (coarse, homogeneous) = strip_curvature_ratio(&no_poisson, 40, 8, 4);
        let (fine, _) = strip_curvature_ratio(&no_poisson, 80, 16, 4);
        let (with_poisson, _) = strip_curvature_ratio(&pla, 80, 16, 4);
        eprintln!(
            "PLA strip: FEM / composite-beam curvature, nu = 0: {coarse:.4} (0.5 mm), {fine:.4} (0.25 mm); nu = 0.35: {with_poisson:.4}; all-silicone {homogeneous:.1}"
        );
        assert!(homogeneous > 50.0, "{homogeneous}");
        assert!(coarse < fine && fine <= 1.0 + 1e-3, "{coarse} {fine}");
        assert!((fine - 1.0).abs() < 0.015, "{fine}");
        let plate = 1.0 - pla.poisson_ratio * pla.poisson_ratio;
        assert!(
            with_poisson > plate && with_poisson < fine,
            "{with_poisson}"
        );
    }
}
