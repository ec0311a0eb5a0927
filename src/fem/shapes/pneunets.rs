//! The PneuNets shape (method.md §4): chambers in a row on a base with a channel, the
//! strain-limiting layers in the base; its families are presets of it: `pneunets` (the
//! reference, Dragon Skin 30), `glove` (smartphone study: Ecoflex 00-50, a paper sheet
//! at mid-height of the base) and `strap` (strap study: Ecoflex 00-30 chambers, PLA
//! strips under a fabric sheet, hanging). The values chosen where a publication leaves
//! them open are listed in the README ("Actuator families").
//!
//! Layout (fillets o, h ignored): `chambers` blocks along x, the first and last of
//! profile length c, the others g, separated by gaps d; a remainder of b beyond the
//! blocks is a solid tip. Every block has a centred cavity of length e (x), width l (y)
//! and height n (z) starting at the channel top z = f + m; the channel (height m, width
//! p, length r, centred in x) runs at z ∈ [f, f + m] and joins every cavity. The gaps
//! between blocks are open from the top down to `roof` mm above the channel top (the
//! table leaves the roof of the channel under a gap open; 1 mm by default, a parameter).
//! Total height a = f + m + n + top_wall (23.5 mm for the reference f = 6).
//!
//! The mesh: coordinate lines through every feature (block, gap, cavity and channel
//! boundaries, the marker lines, the layers), each interval cut into equal elements no
//! longer than the mesh size; cells inside a cavity or a gap are left out. The cavity
//! faces (solid cells next to cavity cells) carry the pressure. Markers: side face
//! y = i/2, centre of blocks 2..N in x, mid cavity height z = f + m + n/2: mesh nodes by
//! construction. Only the half y >= 0 is meshed (see [`crate::fem::actuator`]).

use nalgebra::Vector3;

use super::Shape;
use crate::fem::config::{
    bad, ActuatorConfig, Family, Geometry, LoadConfig, MaterialConfig, MAX_ELEMENTS,
};
use crate::fem::contact::{Contact, ContactConfig, ContactPair};
use crate::fem::layer::{LayerConfig, LayerElement};
use crate::fem::material::MaterialPreset;
use crate::fem::membrane::MembraneElement;
use crate::fem::mesh::{
    attach_plates, coordinate_line_count, coordinate_lines, gravity_loads, ActuatorMesh,
    BottomWall, Part, MIN_WALL_ELEMENTS,
};
use crate::fem::plate::Mirror;
use crate::fem::pressure::CLOSED;
use crate::fem::solve::Model;
use crate::fem::FemError;

#[allow(non_upper_case_globals)]
impl Family {
    /// The reference PneuNets actuator (method.md §4).
    pub const Pneunets: Family = Family::named("pneunets");
    /// The glove actuator: PneuNets in Ecoflex 00-50 with a paper layer.
    pub const Glove: Family = Family::named("glove");
    /// The soft strap: Ecoflex 00-30 chambers, PLA strips and a fabric sheet, hanging.
    pub const Strap: Family = Family::named("strap");
}

/// The PneuNets chambers on a base ([`build_pneunets`]).
pub struct PneuNets;

impl Shape for PneuNets {
    fn families(&self) -> &'static [Family] {
        &[Family::Pneunets, Family::Glove, Family::Strap]
    }

    fn defaults(&self, family: Family) -> ActuatorConfig {
        let reference = ActuatorConfig::default();
        match family {
            Family::Glove => ActuatorConfig {
                geometry: Geometry {
                    family,
                    ..Geometry::default()
                },
                material: MaterialConfig {
                    preset: MaterialPreset::Ecoflex0050,
                    // Smooth-On Ecoflex 00-50: specific gravity 1.07, tensile strength 315 psi.
                    density_g_cm3: 1.07,
                    tensile_strength_mpa: 2.17,
                    ..MaterialConfig::default()
                },
                load: LoadConfig {
                    pressures_kpa: "1:6:0.5".into(),
                    // The study's rig orientation is not given; lying on its bottom, the
                    // 116 mm Ecoflex 00-50 cantilever would sag past vertical under its weight.
                    gravity: false,
                    ..LoadConfig::default()
                },
                // The chamber walls meet from ~5.5 kPa.
                contact: Some(ContactConfig::default()),
                layer: vec![LayerConfig {
                    name: "paper".into(),
                    thickness_mm: 0.1,
                    youngs_modulus_mpa: 3000.0,
                    poisson_ratio: 0.3,
                    // Between two silicone layers: centred in the 6 mm base.
                    height_mm: 2.95,
                    // A plate: as a bare membrane the compressed paper wrinkles (148 Newton
                    // iterations over the ramp against 77) and its own bending, beside
                    // Ecoflex 00-50's, moves the radius 4%.
                    element: LayerElement::Plate,
                    // Printer paper, in plane: ~30-50 MPa.
                    tensile_strength_mpa: Some(30.0),
                    ..LayerConfig::default()
                }],
                ..reference
            },
            Family::Strap => ActuatorConfig {
                geometry: Geometry {
                    family,
                    ..strap_geometry()
                },
                material: MaterialConfig {
                    preset: MaterialPreset::Ecoflex0030,
                    // Smooth-On Ecoflex 00-30: specific gravity 1.07, tensile strength 200 psi.
                    density_g_cm3: 1.07,
                    tensile_strength_mpa: 1.38,
                    ..MaterialConfig::default()
                },
                load: LoadConfig {
                    pressures_kpa: "3:15:3".into(),
                    gravity: true,
                    // Hanging from its clamp: gravity along the actuator.
                    gravity_direction: [1.0, 0.0, 0.0],
                },
                // No contact: the facing chamber walls overlap by about 1 mm at 15 kPa and
                // contact bends 22% more at 20 times the time (docs/src/validation.md).
                layer: vec![
                    LayerConfig {
                        name: "pla".into(),
                        thickness_mm: 1.0,
                        youngs_modulus_mpa: 4000.0,
                        poisson_ratio: 0.36,
                        height_mm: 0.5,
                        // A plate: the strips lie below the sheet, on the compressed side of
                        // the bend, and as bare membranes they wrinkle (docs/src/howto/fem.md).
                        element: LayerElement::Plate,
                        // 160 x 6 x 1 mm strips; their spacing is not given: centres 7 mm
                        // off the axis, under the cavities' edges.
                        width_mm: Some(6.0),
                        strips: 2,
                        spacing_mm: 14.0,
                        tensile_strength_mpa: Some(50.0),
                    },
                    LayerConfig {
                        name: "fabric".into(),
                        thickness_mm: 0.1,
                        youngs_modulus_mpa: 2500.0,
                        poisson_ratio: 0.3,
                        height_mm: 1.5,
                        element: LayerElement::Membrane,
                        tensile_strength_mpa: Some(100.0),
                        ..LayerConfig::default()
                    },
                ],
                ..reference
            },
            _ => reference,
        }
    }

    fn validate_layers(&self, cfg: &ActuatorConfig) -> Result<(), FemError> {
        let g = &cfg.geometry;
        for (k, layer) in cfg.layer.iter().enumerate() {
            layer
                .validate(g.f)
                .and_then(|_| layer.validate_width(g.i))
                .map_err(|e| match e {
                    FemError::Parameter { name, why } if cfg.layer.len() > 1 => {
                        FemError::Parameter {
                            name: format!("{name} (layer {}, '{}')", k + 1, layer.name),
                            why,
                        }
                    }
                    e => e,
                })?;
        }
        let solid: Vec<(usize, &LayerConfig)> = cfg
            .layer
            .iter()
            .enumerate()
            .filter(|(_, l)| l.element == LayerElement::Solid)
            .collect();
        for (a, (ka, la)) in solid.iter().enumerate() {
            for (kb, lb) in &solid[a + 1..] {
                let z = la.height_mm < lb.height_mm + lb.thickness_mm
                    && lb.height_mm < la.height_mm + la.thickness_mm;
                let y = la.half_y_ranges(g.i).iter().any(|(a0, a1)| {
                    lb.half_y_ranges(g.i)
                        .iter()
                        .any(|(b0, b1)| a0 < b1 && b0 < a1)
                });
                if z && y {
                    return Err(bad(
                        "layer",
                        format!(
                            "solid layers {} and {} overlap: give them different height_mm",
                            ka + 1,
                            kb + 1
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    fn validate(&self, cfg: &ActuatorConfig) -> Result<(), FemError> {
        if matches!(cfg.geometry.family, Family::Glove | Family::Strap) && cfg.layer.is_empty() {
            return Err(bad(
                "layer",
                format!(
                    "the {} family is a PneuNets with strain-limiting layers, and this config has none: add a [[layer]] (see bendscope simulate --family {} --print-config) or use family = \"pneunets\"",
                    cfg.geometry.family, cfg.geometry.family
                ),
            ));
        }
        Ok(())
    }

    fn element_estimate(&self, cfg: &ActuatorConfig, h: f64) -> f64 {
        grid_features(cfg)
            .iter()
            .map(|(f, w)| coordinate_line_count(f, h, w))
            .product()
    }

    fn build(&self, cfg: &ActuatorConfig) -> Result<ActuatorMesh, FemError> {
        build_pneunets(cfg)
    }

    fn height_mm(&self, cfg: &ActuatorConfig) -> f64 {
        cfg.geometry.height()
    }

    /// A note when the mesh is coarser than the thinnest wall (the walls are graded to
    /// [`MIN_WALL_ELEMENTS`] through, but the elements are then much longer than thick).
    fn mesh_notes(&self, cfg: &ActuatorConfig) -> Vec<String> {
        let (t, name) = thinnest_wall_mm(&cfg.geometry);
        let h = cfg.mesh.size_mm;
        if h > t + 1e-9 {
            vec![format!(
                "mesh size {h} mm is coarser than the thinnest wall ({name}, {t} mm): the walls get {} elements through but are long and thin along them and the results are far from converged; use {t} mm or less",
                MIN_WALL_ELEMENTS
            )]
        } else {
            vec![]
        }
    }
}

/// The strap's chambers as the strap study's Table 3 gives them (6 chambers, h = 15,
/// H = 25, w = 18, W = 26, channel height 6, t = 2, 2 mm between chambers, 174 mm); what
/// it leaves open is chosen as in docs/src/validation.md ("The strap as published").
fn strap_geometry() -> Geometry {
    Geometry {
        chambers: 6,
        b: 174.0,
        i: 26.0,
        f: 2.0,
        m: 6.0,
        // The channel's width is not given: square.
        p: 6.0,
        // Not given: 5 mm of solid at each end.
        r: 164.0,
        // 2 x 28 + 4 x 27 + 5 x 2 = 174 in whole millimetres.
        c: 28.0,
        g: 27.0,
        d: 2.0,
        // Not given: 2 mm chamber walls, as the top wall.
        e: 23.0,
        l: 18.0,
        n: 15.0,
        // H - t - channel - h = 25 - 2 - 6 - 15.
        top_wall: 2.0,
        // Not given: 2 mm, as the other walls.
        roof: 2.0,
        ..Geometry::default()
    }
}

/// The thinnest wall of the actuator, mm, with its name: the top wall, the bottom under
/// the channel, the side walls beside the cavities and channel, and the chamber walls.
pub fn thinnest_wall_mm(g: &Geometry) -> (f64, &'static str) {
    let inner = if g.chambers > 2 { g.g } else { g.c };
    [
        (g.top_wall, "top wall"),
        (g.f, "bottom (f)"),
        (
            (g.i - g.l) / 2.0,
            "side wall beside the chambers ((i - l) / 2)",
        ),
        (
            (g.i - g.p) / 2.0,
            "side wall beside the channel ((i - p) / 2)",
        ),
        ((inner - g.e) / 2.0, "chamber wall ((g - e) / 2)"),
    ]
    .into_iter()
    .min_by(|a, b| a.0.total_cmp(&b.0))
    .unwrap_or((f64::NAN, "wall"))
}

/// Along one axis: the coordinates the grid lines go through, and the intervals that are
/// walls.
type AxisFeatures = (Vec<f64>, Vec<(f64, f64)>);

/// Coordinates every line of the PneuNets grid goes through, with the intervals that are
/// walls (at least [`MIN_WALL_ELEMENTS`] across), along x, y and z.
fn grid_features(cfg: &ActuatorConfig) -> [AxisFeatures; 3] {
    let g = &cfg.geometry;
    let blocks = g.blocks();
    let cavities = g.cavities();
    let (ch0, ch1) = (0.5 * (g.b - g.r), 0.5 * (g.b + g.r));
    let (z_channel, z_cavity) = (g.f, g.f + g.m);
    let (z_gap, z_top, a) = (z_cavity + g.roof, z_cavity + g.n, g.height());
    let mut fx = vec![0.0, g.b, ch0, ch1];
    for ((b0, b1), (c0, c1)) in blocks.iter().zip(&cavities) {
        fx.extend([*b0, *b1, *c0, *c1, 0.5 * (b0 + b1)]);
    }
    let x_walls: Vec<(f64, f64)> = blocks
        .iter()
        .zip(&cavities)
        .flat_map(|((b0, b1), (c0, c1))| [(*b0, *c0), (*c1, *b1)])
        .collect();
    let mut fy = vec![0.0, 0.5 * g.p, 0.5 * g.l, 0.5 * g.i];
    for layer in &cfg.layer {
        for (y0, y1) in layer.half_y_ranges(g.i) {
            fy.extend([y0, y1]);
        }
    }
    let y_walls = vec![(0.5 * g.l, 0.5 * g.i), (0.5 * g.p, 0.5 * g.i)];
    let mut fz = vec![0.0, z_channel, z_cavity, z_gap, g.marker_z(), z_top, a];
    for layer in &cfg.layer {
        match layer.element {
            LayerElement::Solid => {
                fz.extend([layer.height_mm, layer.height_mm + layer.thickness_mm])
            }
            LayerElement::Membrane | LayerElement::Plate => fz.push(layer.membrane_height_mm()),
        }
    }
    let z_walls = vec![(0.0, z_channel), (z_cavity, z_gap), (z_top, a)];
    [(fx, x_walls), (fy, y_walls), (fz, z_walls)]
}

fn index_of(lines: &[f64], v: f64) -> usize {
    lines
        .iter()
        .enumerate()
        .min_by(|a, b| (a.1 - v).abs().total_cmp(&(b.1 - v).abs()))
        .map(|(k, _)| k)
        .unwrap_or(0)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Cell {
    Solid,
    Cavity,
    Outside,
}

/// Meshes the half PneuNets actuator (y ≥ 0) described by `cfg`, validated
/// ([`crate::fem::actuator::build_mesh`] checks it, then calls this through the shape).
pub fn build_pneunets(cfg: &ActuatorConfig) -> Result<ActuatorMesh, FemError> {
    let g = &cfg.geometry;
    let h = cfg.mesh.size_mm;
    let material = cfg.material.yeoh()?;
    let blocks = g.blocks();
    let cavities = g.cavities();
    let (ch0, ch1) = (0.5 * (g.b - g.r), 0.5 * (g.b + g.r));
    let (z_channel, z_cavity) = (g.f, g.f + g.m);
    let (z_gap, z_top, a) = (z_cavity + g.roof, z_cavity + g.n, g.height());

    let [(fx, wx), (fy, wy), (fz, wz)] = grid_features(cfg);
    let xs = coordinate_lines(fx, h, &wx);
    let ys = coordinate_lines(fy, h, &wy);
    let zs = coordinate_lines(fz, h, &wz);
    let (nx, ny, nz) = (xs.len() - 1, ys.len() - 1, zs.len() - 1);
    // validate() bounded the count (element_estimate); this is the count itself.
    if nx.saturating_mul(ny).saturating_mul(nz) > MAX_ELEMENTS {
        return Err(bad(
            "mesh size",
            format!(
                "{h} mm gives {} cells, more than the {MAX_ELEMENTS} this solver is sized for: use a larger mesh size",
                nx.saturating_mul(ny).saturating_mul(nz)
            ),
        ));
    }

    let inside = |v: f64, lo: f64, hi: f64| v > lo && v < hi;
    let classify = |x: f64, y: f64, z: f64| -> Cell {
        if inside(x, ch0, ch1) && y < 0.5 * g.p && inside(z, z_channel, z_cavity) {
            return Cell::Cavity;
        }
        if y < 0.5 * g.l
            && inside(z, z_cavity, z_top)
            && cavities.iter().any(|(c0, c1)| inside(x, *c0, *c1))
        {
            return Cell::Cavity;
        }
        if z > z_gap && blocks.windows(2).any(|w| inside(x, w[0].1, w[1].0)) {
            return Cell::Outside;
        }
        Cell::Solid
    };
    let cell_id = |i: usize, j: usize, k: usize| (k * ny + j) * nx + i;
    let mut cells = vec![Cell::Solid; nx * ny * nz];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                cells[cell_id(i, j, k)] = classify(
                    0.5 * (xs[i] + xs[i + 1]),
                    0.5 * (ys[j] + ys[j + 1]),
                    0.5 * (zs[k] + zs[k + 1]),
                );
            }
        }
    }

    // Nodes used by solid cells, numbered compactly.
    let grid_id = |i: usize, j: usize, k: usize| (k * (ny + 1) + j) * (nx + 1) + i;
    let mut node_of = vec![usize::MAX; (nx + 1) * (ny + 1) * (nz + 1)];
    let mut nodes = Vec::new();
    let mut node = |i: usize, j: usize, k: usize, nodes: &mut Vec<Vector3<f64>>| -> usize {
        let gi = grid_id(i, j, k);
        if node_of[gi] == usize::MAX {
            node_of[gi] = nodes.len();
            nodes.push(Vector3::new(xs[i], ys[j], zs[k]));
        }
        node_of[gi]
    };
    let mut elements = Vec::new();
    let mut element_material = Vec::new();
    // Material of a cell: 0 silicone, k the k-th solid layer (extra_materials[k - 1]).
    let solid_layers: Vec<(&LayerConfig, Vec<(f64, f64)>)> = cfg
        .layer
        .iter()
        .filter(|l| l.element == LayerElement::Solid)
        .map(|l| (l, l.half_y_ranges(g.i)))
        .collect();
    let in_layer = |j: usize, k: usize| -> u8 {
        let (yc, zc) = (0.5 * (ys[j] + ys[j + 1]), 0.5 * (zs[k] + zs[k + 1]));
        solid_layers
            .iter()
            .position(|(l, ranges)| {
                zc > l.height_mm
                    && zc < l.height_mm + l.thickness_mm
                    && ranges.iter().any(|(y0, y1)| yc > *y0 && yc < *y1)
            })
            .map_or(0, |k| (k + 1) as u8)
    };
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if cells[cell_id(i, j, k)] != Cell::Solid {
                    continue;
                }
                element_material.push(in_layer(j, k));
                let corners = [
                    (i, j, k),
                    (i + 1, j, k),
                    (i + 1, j + 1, k),
                    (i, j + 1, k),
                    (i, j, k + 1),
                    (i + 1, j, k + 1),
                    (i + 1, j + 1, k + 1),
                    (i, j + 1, k + 1),
                ];
                elements.push(corners.map(|(a, b, c)| node(a, b, c, &mut nodes)));
            }
        }
    }

    // Membrane layers: a quad on the layer's plane under (or over) every solid cell
    // within its y ranges (the base is solid through its whole length there).
    let mut membranes = Vec::new();
    // Each layer's membranes (none for a solid layer), in the config's order.
    let mut layer_membranes: Vec<Vec<usize>> = Vec::new();
    for layer in &cfg.layer {
        if !layer.is_sheet() {
            layer_membranes.push(Vec::new());
            continue;
        }
        let km = index_of(&zs, layer.membrane_height_mm());
        let section = layer.section();
        let ranges = layer.half_y_ranges(g.i);
        let mut part = Vec::new();
        for j in 0..ny {
            let yc = 0.5 * (ys[j] + ys[j + 1]);
            if !ranges.iter().any(|(y0, y1)| yc > *y0 && yc < *y1) {
                continue;
            }
            for i in 0..nx {
                let above = km < nz && cells[cell_id(i, j, km)] == Cell::Solid;
                let below = km > 0 && cells[cell_id(i, j, km - 1)] == Cell::Solid;
                if above || below {
                    let corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
                    part.push(membranes.len());
                    membranes.push(MembraneElement {
                        nodes: corners.map(|(a, b)| node_of[grid_id(a, b, km)]),
                        section,
                    });
                }
            }
        }
        layer_membranes.push(part);
    }

    // Cavity faces: between a cavity cell and a solid neighbour, normal into the solid.
    let mut pressure_faces = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if cells[cell_id(i, j, k)] != Cell::Cavity {
                    continue;
                }
                let solid = |di: isize, dj: isize, dk: isize| {
                    let (a, b, c) = (i as isize + di, j as isize + dj, k as isize + dk);
                    a >= 0
                        && b >= 0
                        && c >= 0
                        && (a as usize) < nx
                        && (b as usize) < ny
                        && (c as usize) < nz
                        && cells[cell_id(a as usize, b as usize, c as usize)] == Cell::Solid
                };
                let (i1, j1, k1) = (i + 1, j + 1, k + 1);
                let mut quads: Vec<[(usize, usize, usize); 4]> = Vec::new();
                if solid(1, 0, 0) {
                    quads.push([(i1, j, k), (i1, j1, k), (i1, j1, k1), (i1, j, k1)]);
                }
                if solid(-1, 0, 0) {
                    quads.push([(i, j, k), (i, j, k1), (i, j1, k1), (i, j1, k)]);
                }
                if solid(0, 1, 0) {
                    quads.push([(i, j1, k), (i, j1, k1), (i1, j1, k1), (i1, j1, k)]);
                }
                if solid(0, -1, 0) {
                    quads.push([(i, j, k), (i1, j, k), (i1, j, k1), (i, j, k1)]);
                }
                if solid(0, 0, 1) {
                    quads.push([(i, j, k1), (i1, j, k1), (i1, j1, k1), (i, j1, k1)]);
                }
                if solid(0, 0, -1) {
                    quads.push([(i, j, k), (i, j1, k), (i1, j1, k), (i1, j, k)]);
                }
                for q in quads {
                    pressure_faces.push(q.map(|(a, b, c)| node_of[grid_id(a, b, c)]));
                }
            }
        }
    }
    if pressure_faces.iter().flatten().any(|n| *n == usize::MAX) {
        return Err(FemError::Model {
            why: "a cavity face has a node outside the solid (mesh bug)".into(),
        });
    }

    // Facing walls across each gap: faces between a gap cell and a solid cell beside it
    // in x, normal out of the wall's block into the gap (ξ along y, η along z for the
    // left wall's +x normal; ξ along z, η along y for the right wall's -x).
    let gaps = blocks.len().saturating_sub(1);
    let mut left_walls: Vec<Vec<[usize; 4]>> = vec![Vec::new(); gaps];
    let mut right_walls: Vec<Vec<[usize; 4]>> = vec![Vec::new(); gaps];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if cells[cell_id(i, j, k)] != Cell::Outside {
                    continue;
                }
                let xc = 0.5 * (xs[i] + xs[i + 1]);
                let Some(gap) = blocks.windows(2).position(|w| inside(xc, w[0].1, w[1].0)) else {
                    continue;
                };
                let (j1, k1) = (j + 1, k + 1);
                let node = |a: usize, b: usize, c: usize| node_of[grid_id(a, b, c)];
                if i > 0 && cells[cell_id(i - 1, j, k)] == Cell::Solid {
                    left_walls[gap].push([
                        node(i, j, k),
                        node(i, j1, k),
                        node(i, j1, k1),
                        node(i, j, k1),
                    ]);
                }
                if i + 1 < nx && cells[cell_id(i + 1, j, k)] == Cell::Solid {
                    let i1 = i + 1;
                    right_walls[gap].push([
                        node(i1, j, k),
                        node(i1, j, k1),
                        node(i1, j1, k1),
                        node(i1, j1, k),
                    ]);
                }
            }
        }
    }
    if left_walls
        .iter()
        .chain(&right_walls)
        .flatten()
        .flatten()
        .any(|n| *n == usize::MAX)
    {
        return Err(FemError::Model {
            why: "a chamber wall face has a node outside the solid (mesh bug)".into(),
        });
    }
    let wall_pairs: Vec<ContactPair> = left_walls
        .iter()
        .zip(&right_walls)
        .flat_map(|(l, r)| [slave_against(r, l, &nodes), slave_against(l, r, &nodes)])
        .collect();

    // Supports: the first chamber is clamped; y = 0 is the symmetry plane.
    let n_nodes = nodes.len();
    let mut fixed = vec![false; 3 * n_nodes];
    for (a, x) in nodes.iter().enumerate() {
        if x.x <= g.c + 1e-9 {
            fixed[3 * a] = true;
            fixed[3 * a + 1] = true;
            fixed[3 * a + 2] = true;
        }
        if x.y.abs() < 1e-9 {
            fixed[3 * a + 1] = true;
        }
    }

    // A solid layer is moulded in the silicone's volume: it weighs as the silicone.
    let densities_g_cm3 = vec![cfg.material.density_g_cm3; 1 + solid_layers.len()];
    let loads = gravity_loads(cfg, &nodes, &elements, &element_material, &densities_g_cm3)?;

    let at = |x: f64, y: f64, z: f64| {
        node_of[grid_id(index_of(&xs, x), index_of(&ys, y), index_of(&zs, z))]
    };
    let markers: Vec<usize> = g
        .marker_x()
        .iter()
        .map(|x| at(*x, 0.5 * g.i, g.marker_z()))
        .collect();
    let tip = at(g.b, 0.0, 0.0);
    let side_face: Vec<[usize; 4]> = (0..nz)
        .flat_map(|k| (0..nx).map(move |i| (i, k)))
        .filter(|(i, k)| cells[cell_id(*i, ny - 1, *k)] == Cell::Solid)
        .map(|(i, k)| {
            [(i, k), (i + 1, k), (i + 1, k + 1), (i, k + 1)]
                .map(|(a, c)| node_of[grid_id(a, ny, c)])
        })
        .collect();
    let tip_support: Vec<usize> = (0..=ny).map(|j| node_of[grid_id(nx, j, 0)]).collect();
    let bottom_line: Vec<usize> = (0..=nx)
        .filter(|i| xs[*i] >= g.c - 1e-9)
        .map(|i| node_of[grid_id(i, 0, 0)])
        .collect();
    let mut parts = vec![Part::solid(
        "silicone",
        cfg.material.tensile_strength_mpa,
        0,
    )];
    let mut solid_id = 0u8;
    for (layer, membranes) in cfg.layer.iter().zip(layer_membranes) {
        let solid_material = (layer.element == LayerElement::Solid).then(|| {
            solid_id += 1;
            solid_id
        });
        parts.push(Part {
            name: layer.name.clone(),
            tensile_strength_mpa: layer.tensile_strength_mpa,
            solid_material,
            membranes,
            plate: None,
            trusses: Vec::new(),
            tri_membranes: Vec::new(),
        });
    }
    let twist_pair = (tip, at(g.b, 0.0, a));
    let bottom_wall = {
        let (x0, x1) = blocks[1];
        let xm = 0.5 * (x0 + x1);
        BottomWall {
            ends: [at(x0, 0.0, 0.0), at(x1, 0.0, 0.0)],
            centre: at(xm, 0.0, 0.0),
            inside: at(xm, 0.0, g.f),
        }
    };
    if markers
        .iter()
        .chain(&tip_support)
        .chain(&bottom_wall.ends)
        .chain(&[bottom_wall.centre, bottom_wall.inside])
        .chain(&[twist_pair.1])
        .chain(&bottom_line)
        .chain(std::iter::once(&tip))
        .chain(side_face.iter().flatten())
        .any(|n| *n == usize::MAX)
    {
        return Err(FemError::Model {
            why: "a marker or support point is not on the solid (mesh bug)".into(),
        });
    }
    // The half model's symmetry plane y = 0 mirrors a sheet.
    let mirror = [Mirror { axis: 1, at: 0.0 }];
    let plates = attach_plates(&cfg.layer, &mut parts[1..], &nodes, &membranes, &mirror);
    Ok(ActuatorMesh {
        model: Model {
            nodes,
            elements,
            material,
            fixed,
            loads,
            pressure_faces,
            volume_weights: CLOSED,
            element_material,
            extra_materials: solid_layers.iter().map(|(l, _)| l.material()).collect(),
            membranes,
            tri_membranes: Vec::new(),
            trusses: Vec::new(),
            plates,
            contact: cfg.contact.as_ref().filter(|c| c.enabled).map(|c| Contact {
                pairs: wall_pairs.clone(),
                penalty_mpa_per_mm: c.penalty_for(&material, h),
            }),
            incompatible_modes: cfg.mesh.element.incompatible_modes(),
            tets: Default::default(),
        },
        markers,
        tip,
        tip_support,
        bottom_line,
        side_face,
        clamp_mm: g.c,
        wall_pairs,
        parts,
        twist_pair,
        bottom_wall: Some(bottom_wall),
        made_mesh: None,
        densities_g_cm3,
        half_model: true,
    })
}

/// The pair with the nodes of `slave` faces (each with half its share of their areas:
/// the walls are paired both ways) against the `master` faces.
fn slave_against(
    slave: &[[usize; 4]],
    master: &[[usize; 4]],
    nodes: &[Vector3<f64>],
) -> ContactPair {
    let mut area = std::collections::BTreeMap::new();
    for f in slave {
        let x = f.map(|a| nodes[a]);
        // A planar quad's area; each corner takes a quarter (∫ N_a dA of a parallelogram).
        let a = 0.5 * (x[2] - x[0]).cross(&(x[3] - x[1])).norm();
        for n in f {
            *area.entry(*n).or_insert(0.0) += 0.5 * 0.25 * a;
        }
    }
    ContactPair {
        slave_nodes: area.keys().copied().collect(),
        slave_areas_mm2: area.values().copied().collect(),
        master_faces: master.to_vec(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::actuator::{build_mesh, MeshConfig};
    use crate::fem::hex::HexGeometry;

    #[test]
    fn reference_layout_matches_the_table() {
        let g = Geometry::default();
        assert!((g.chambers_length() - 116.0).abs() < 1e-12);
        assert!((g.height() - 23.5).abs() < 1e-12);
        let b = g.blocks();
        assert_eq!(b.len(), 9);
        assert!((b[8].1 - 116.0).abs() < 1e-12 && (b[1].0 - 14.75).abs() < 1e-12);
        assert_eq!(g.marker_x().len(), 8);
        assert!((g.marker_x()[0] - 20.5).abs() < 1e-12);
        let with_f2 = Geometry { f: 2.0, ..g };
        assert!((with_f2.height() - 19.5).abs() < 1e-12);
    }

    /// Chambers and gaps typed to six digits (c = g = 27.333333, 2e-6 mm short of b)
    /// mesh without a sliver element at the tip: every x line is at least
    /// `FEATURE_MERGE_FRACTION` of h from the next, and the tip is at b.
    #[test]
    fn lengths_a_hair_short_of_b_mesh_without_a_sliver() {
        let h = 4.0;
        let cfg = ActuatorConfig {
            geometry: Geometry {
                chambers: 6,
                b: 174.0,
                i: 26.0,
                f: 2.0,
                m: 6.0,
                p: 6.0,
                r: 164.0,
                c: 27.333333,
                g: 27.333333,
                d: 2.0,
                e: 23.0,
                l: 18.0,
                n: 15.0,
                top_wall: 2.0,
                roof: 2.0,
                ..Geometry::default()
            },
            mesh: MeshConfig {
                size_mm: h,
                ..Default::default()
            },
            ..Default::default()
        };
        let mesh = build_mesh(&cfg).unwrap();
        let mut xs: Vec<f64> = mesh.model.nodes.iter().map(|x| x.x).collect();
        xs.sort_by(f64::total_cmp);
        xs.dedup();
        let thinnest = xs
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min);
        assert!(
            thinnest >= crate::fem::mesh::FEATURE_MERGE_FRACTION * h,
            "thinnest x interval {thinnest} mm"
        );
        assert_eq!(xs.last().copied(), Some(174.0));
    }

    #[test]
    fn mesh_volume_and_cavity_volume_are_those_of_the_geometry() {
        let cfg = ActuatorConfig {
            mesh: MeshConfig {
                size_mm: 2.0,
                ..Default::default()
            },
            ..Default::default()
        };
        let mesh = build_mesh(&cfg).unwrap();
        let g = &cfg.geometry;
        let volume: f64 = mesh
            .model
            .elements
            .iter()
            .map(|el| {
                let x: [Vector3<f64>; 8] = std::array::from_fn(|a| mesh.model.nodes[el[a]]);
                HexGeometry::new(&x).unwrap().volume
            })
            .sum();
        // Half of: box - gaps - cavities - channel (all exact on the conforming grid).
        let gaps = (g.chambers - 1) as f64 * g.d * g.i * (g.height() - g.f - g.m - g.roof);
        let cavities = g.chambers as f64 * g.e * g.l * g.n;
        let channel = g.r * g.p * g.m;
        let solid = g.b * g.i * g.height() - gaps - cavities - channel;
        assert!(
            (2.0 * volume - solid).abs() < 1e-6 * solid,
            "{} vs {solid}",
            2.0 * volume
        );
        let faces_volume: f64 = mesh
            .model
            .pressure_faces
            .iter()
            .map(|f| {
                let x: [Vector3<f64>; 4] = std::array::from_fn(|k| mesh.model.nodes[f[k]]);
                crate::fem::pressure::face_volume(&x, &CLOSED).0
            })
            .sum();
        // Channel (z ∈ [f, f+m]) and chamber cavities (above) do not overlap.
        let cavity = cavities + channel;
        assert!(
            (2.0 * faces_volume - cavity).abs() < 1e-6 * cavity,
            "{} vs {cavity}",
            2.0 * faces_volume
        );
        // Markers on the side face at mid cavity height, centre of chambers 2..9.
        for (n, x) in mesh.markers.iter().zip(g.marker_x()) {
            let p = mesh.model.nodes[*n];
            assert!((p - Vector3::new(x, 7.5, 14.0)).norm() < 1e-9, "{p}");
        }
    }
}
