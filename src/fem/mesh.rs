//! The meshed actuator every shape builds and everything downstream takes (the solve,
//! the outputs, the CalculiX deck): the model, its named parts, markers, clamp and the
//! other nodes results are read at; and the grid helpers the structured meshers share.

use nalgebra::Vector3;

use super::config::ActuatorConfig;
use super::contact::ContactPair;
use super::hex::{nodal_volumes, HexGeometry};
use super::layer::{LayerConfig, LayerElement};
use super::membrane::MembraneElement;
use super::plate::{Mirror, PlateTerm};
use super::solve::{Model, Tetrahedra};
use super::tet10::{self, Tet10Geometry};
use super::FemError;

/// Standard gravity, m/s².
pub const GRAVITY_M_S2: f64 = 9.806_65;

/// The meshed half actuator and the nodes results are read at.
#[derive(Debug, Clone)]
pub struct ActuatorMesh {
    /// The finite-element model (dead loads: gravity).
    pub model: Model,
    /// Marker nodes (side face, centre of chambers 2..N, mid cavity height), from the
    /// clamp towards the tip.
    pub markers: Vec<usize>,
    /// Tip node: bottom edge of the free end on the symmetry plane (x = b, y = 0, z = 0).
    pub tip: usize,
    /// Nodes of the free end's bottom edge (x = b, z = 0): the blocked-force support.
    pub tip_support: Vec<usize>,
    /// Bottom centre line (y = 0, z = 0) beyond the clamp (x >= c), ordered by x.
    pub bottom_line: Vec<usize>,
    /// The side face y = i/2 (the filmed face): quads of nodes, counter-clockwise in x-z.
    pub side_face: Vec<[usize; 4]>,
    /// Clamped length (first chamber), mm.
    pub clamp_mm: f64,
    /// The facing walls across every gap between chambers, paired both ways (each with
    /// half the node areas, [`super::contact`]): where `min_wall_gap_mm` is measured,
    /// and the contact pairs when `[contact]` is on.
    pub wall_pairs: Vec<ContactPair>,
    /// The parts whose stress is reported, the main silicone first.
    pub parts: Vec<Part>,
    /// Two nodes of the free end's face, the first below the second on the actuator's
    /// axis plane: the tip face's twist about the axis is read off them.
    pub twist_pair: (usize, usize),
    /// The model is the half y >= 0 of a mirror-symmetric actuator (forces and volumes
    /// of the whole are twice the model's).
    pub half_model: bool,
    /// Density of each solid material, g/cm³, by material id ([`Model::element_material`]:
    /// 0 the main silicone, k `extra_materials[k - 1]`): the gravity loads' and the
    /// exported deck's.
    pub densities_g_cm3: Vec<f64>,
    /// Where the bottom wall's inflation is read ([`BottomWall`]).
    pub bottom_wall: Option<BottomWall>,
    /// The gmsh mesh (MSH 4.1 bytes) bendscope made of a CAD file, written as `mesh.msh`
    /// beside the results (None: the shape was meshed by bendscope, or read from a mesh).
    pub made_mesh: Option<std::sync::Arc<Vec<u8>>>,
}

/// A bottom wall whose inflation is reported: its centre's distance from the chord of its
/// ends, positive away from the cavity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BottomWall {
    /// The chord's ends, bottom-face nodes. The same node twice on a half model: the chord
    /// from it to its mirror image across the symmetry plane y = 0.
    pub ends: [usize; 2],
    /// The bottom-face node between the ends.
    pub centre: usize,
    /// A node on the cavity's side of the centre (the cavity's floor above it): the
    /// inflation is positive away from it.
    pub inside: usize,
}

impl BottomWall {
    /// The inflation, mm, with the nodes at `position`.
    pub fn inflation_mm(&self, position: impl Fn(usize) -> Vector3<f64>) -> f64 {
        let [a, b] = self.ends.map(&position);
        let b = if self.ends[0] == self.ends[1] {
            Vector3::new(b.x, -b.y, b.z)
        } else {
            b
        };
        let c = position(self.centre);
        let d = (b - a).normalize();
        let w = (c - a) - (c - a).dot(&d) * d;
        w.norm() * w.dot(&(c - position(self.inside))).signum()
    }
}

/// A part of the model (a silicone, a layer, a fibre set) and the elements it is made of.
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    /// Name (silicone, a layer's name, fibre): the stress columns' suffix.
    pub name: String,
    /// Tensile strength, MPa, for its safety factor (None: not reported).
    pub tensile_strength_mpa: Option<f64>,
    /// Solid elements of this material id ([`Model::element_material`]), if any.
    pub solid_material: Option<u8>,
    /// Membrane elements (indices into [`Model::membranes`]).
    pub membranes: Vec<usize>,
    /// The membranes (or 6-node membranes) carry the sheet's bending stiffness
    /// ([`Model::plates`], a layer with `element = "plate"`): its section and its terms
    /// there.
    pub plate: Option<PlateSection>,
    /// Fibre segments (indices into [`Model::trusses`]).
    pub trusses: Vec<usize>,
    /// 6-node membranes (indices into [`Model::tri_membranes`]: an imported mesh's sheet).
    pub tri_membranes: Vec<usize>,
}

impl Part {
    /// A solid part: the elements of material id `material`, no sheets or fibres.
    pub fn solid(name: &str, tensile_strength_mpa: f64, material: u8) -> Self {
        Self {
            name: name.into(),
            tensile_strength_mpa: Some(tensile_strength_mpa),
            solid_material: Some(material),
            membranes: Vec::new(),
            plate: None,
            trusses: Vec::new(),
            tri_membranes: Vec::new(),
        }
    }
}

/// A plate part's section and its bending terms in [`Model::plates`].
#[derive(Debug, Clone, PartialEq)]
pub struct PlateSection {
    /// Thickness, mm.
    pub thickness_mm: f64,
    /// Young's modulus, MPa.
    pub youngs_modulus_mpa: f64,
    /// Poisson's ratio.
    pub poisson_ratio: f64,
    /// Its terms, indices into [`Model::plates`].
    pub terms: std::ops::Range<usize>,
}

/// The bending terms of the sheets `layers` (one per part of `parts`, in order) on the
/// membranes `membranes`, mirrored at `mirrors`: each plate part is told its section and
/// where its terms are.
pub fn attach_plates<'a>(
    layers: impl IntoIterator<Item = &'a LayerConfig>,
    parts: &mut [Part],
    nodes: &[Vector3<f64>],
    membranes: &[MembraneElement],
    mirrors: &[Mirror],
) -> Vec<PlateTerm> {
    let mut plates = Vec::new();
    for (layer, part) in layers.into_iter().zip(parts) {
        let start = plates.len();
        plates.extend(layer.plate_terms(nodes, membranes, &part.membranes, mirrors));
        part.plate = (layer.element == LayerElement::Plate).then(|| PlateSection {
            thickness_mm: layer.thickness_mm,
            youngs_modulus_mpa: layer.youngs_modulus_mpa,
            poisson_ratio: layer.poisson_ratio,
            terms: start..plates.len(),
        });
    }
    plates
}

/// Least number of elements through every wall (side walls beside the chambers and the
/// channel, chamber walls, top wall, bottom, the roof over the channel under the gaps):
/// one trilinear element through a wall in
/// bending is far too stiff (the 2 mm mesh with one element through the 2 mm side walls
/// was +2.5..+4.5% on the radius); two through, at the mesh size along, converge.
pub const MIN_WALL_ELEMENTS: usize = 2;

/// Features closer than this fraction of the mesh size are one coordinate line: a
/// length typed to six digits (27.333333 for a sixth of 164) leaves gaps of a few
/// micrometres between features that meant to coincide, and an element that thin is
/// ~1e6 times stiffer than its neighbours.
pub const FEATURE_MERGE_FRACTION: f64 = 1e-3;

/// The distance below which two features are one line at mesh size `h` (never below
/// 1e-9 mm).
fn feature_tolerance(h: f64) -> f64 {
    (FEATURE_MERGE_FRACTION * h).max(1e-9)
}

/// `features` sorted and deduplicated (closer than [`FEATURE_MERGE_FRACTION`] of `h` is
/// one line), with the number of equal parts no longer than `h`
/// each interval between them is cut into (at least `MIN_WALL_ELEMENTS` for an interval
/// that is one of `walls` (lo, hi)); the counts are floats, which neither overflow nor
/// allocate however small `h` is.
fn interval_parts(features: &[f64], h: f64, walls: &[(f64, f64)]) -> (Vec<f64>, Vec<f64>) {
    let tol = feature_tolerance(h);
    let mut features = features.to_vec();
    features.sort_by(f64::total_cmp);
    let last = features.last().copied();
    features.dedup_by(|a, b| (*a - *b).abs() < tol);
    // The outermost feature (the body's end) stays where it is, not the inner one
    // merged with it.
    if let (Some(end), Some(last)) = (features.last_mut(), last) {
        *end = last;
    }
    let is_wall = |a: f64, b: f64| {
        walls
            .iter()
            .any(|(lo, hi)| (a - lo).abs() < tol && (b - hi).abs() < tol)
    };
    let parts = features
        .windows(2)
        .map(|w| {
            let parts = ((w[1] - w[0]) / h - 1e-9).ceil().max(1.0);
            if is_wall(w[0], w[1]) {
                parts.max(MIN_WALL_ELEMENTS as f64)
            } else {
                parts
            }
        })
        .collect();
    (features, parts)
}

/// Coordinate lines through `features` (sorted, deduplicated), each interval cut into
/// equal parts no longer than `h`; an interval that is one of `walls` (lo, hi) gets at
/// least `MIN_WALL_ELEMENTS` parts. Callers bound the count first
/// ([`coordinate_line_count`]).
pub(crate) fn coordinate_lines(features: Vec<f64>, h: f64, walls: &[(f64, f64)]) -> Vec<f64> {
    let (features, parts) = interval_parts(&features, h, walls);
    let mut out = vec![features[0]];
    for (w, &parts) in features.windows(2).zip(&parts) {
        let parts = parts as usize;
        for k in 1..=parts {
            out.push(w[0] + (w[1] - w[0]) * k as f64 / parts as f64);
        }
    }
    out
}

/// The number of intervals [`coordinate_lines`] cuts, counted without building them
/// (infinite when the count is).
pub(crate) fn coordinate_line_count(features: &[f64], h: f64, walls: &[(f64, f64)]) -> f64 {
    interval_parts(features, h, walls).1.iter().sum()
}

/// Nodal gravity loads at load factor 1 (zero when `cfg.load.gravity` is off): ρ g ∫ N_a dV
/// along the gravity direction (N per mm³ = g/cm³ · 1e-6 kg/mm³ · g), element e of density
/// `densities_g_cm3[element_material[e]]` (material 0 where `element_material` is empty).
pub(crate) fn gravity_loads(
    cfg: &ActuatorConfig,
    nodes: &[Vector3<f64>],
    elements: &[[usize; 8]],
    element_material: &[u8],
    densities_g_cm3: &[f64],
) -> Result<Vec<f64>, FemError> {
    let density_g_cm3 = |e: usize| {
        let k = element_material.get(e).map_or(0, |&k| usize::from(k));
        densities_g_cm3.get(k).copied().ok_or(FemError::Model {
            why: format!("material {k} has no density (mesh bug)"),
        })
    };
    let mut loads = vec![0.0; 3 * nodes.len()];
    if !cfg.load.gravity {
        return Ok(loads);
    }
    let down = Vector3::from(cfg.load.gravity_direction).normalize();
    for (e, el) in elements.iter().enumerate() {
        let weight_per_mm3 = density_g_cm3(e)? * 1e-6 * GRAVITY_M_S2;
        let x: [Vector3<f64>; 8] = std::array::from_fn(|a| nodes[el[a]]);
        let geom = HexGeometry::new(&x).ok_or(FemError::Model {
            why: "degenerate element (mesh bug)".into(),
        })?;
        for (a, v) in nodal_volumes(&geom).iter().enumerate() {
            for d in 0..3 {
                loads[3 * el[a] + d] += weight_per_mm3 * v * down[d];
            }
        }
    }
    Ok(loads)
}

/// [`gravity_loads`] of the tetrahedra `tets`.
pub(crate) fn gravity_loads_tets(
    cfg: &ActuatorConfig,
    nodes: &[Vector3<f64>],
    tets: &Tetrahedra,
    densities_g_cm3: &[f64],
) -> Result<Vec<f64>, FemError> {
    let mut loads = vec![0.0; 3 * nodes.len()];
    if !cfg.load.gravity {
        return Ok(loads);
    }
    let down = Vector3::from(cfg.load.gravity_direction).normalize();
    for (t, el) in tets.elements.iter().enumerate() {
        let k = tets.material.get(t).map_or(0, |&k| usize::from(k));
        let density = densities_g_cm3.get(k).copied().ok_or(FemError::Model {
            why: format!("material {k} has no density (mesh bug)"),
        })?;
        let x: [Vector3<f64>; 10] = std::array::from_fn(|a| nodes[el[a]]);
        let geom = Tet10Geometry::new(&x).ok_or(FemError::Model {
            why: format!("tetrahedron {t} is inverted or degenerate"),
        })?;
        for (a, v) in tet10::nodal_volumes(&geom).iter().enumerate() {
            for d in 0..3 {
                loads[3 * el[a] + d] += density * 1e-6 * GRAVITY_M_S2 * v * down[d];
            }
        }
    }
    Ok(loads)
}

#[cfg(test)]
mod feature_tests {
    use super::*;

    /// Features a few micrometres apart (27.333333 typed for a sixth) are one line: no
    /// interval thinner than `FEATURE_MERGE_FRACTION` of h, and the end stays at b.
    #[test]
    fn features_closer_than_the_merge_tolerance_are_one_line() {
        let cases: [(&[f64], f64, f64); 3] = [
            (&[0.0, 173.999998, 174.0], 4.0, 174.0),
            (&[0.0, 1e-7, 10.0], 0.5, 10.0),
            (&[0.0, 50.0, 49.9999999, 100.0], 1.0, 100.0),
        ];
        for (features, h, end) in cases {
            let lines = coordinate_lines(features.to_vec(), h, &[]);
            let thinnest = lines
                .windows(2)
                .map(|w| w[1] - w[0])
                .fold(f64::INFINITY, f64::min);
            assert!(thinnest >= 0.5 * h, "{features:?} at h = {h}: {lines:?}");
            assert_eq!(lines.last().copied(), Some(end), "{features:?}");
            assert_eq!(lines.first().copied(), Some(0.0), "{features:?}");
        }
        // Features a mesh size apart stay apart.
        let lines = coordinate_lines(vec![0.0, 3.99, 4.0], 4.0, &[]);
        assert_eq!(lines, vec![0.0, 3.99, 4.0]);
    }
}
