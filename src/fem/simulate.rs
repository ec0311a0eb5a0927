//! A pressure ramp on the meshed actuator and the quantities read off each converged
//! step: marker positions, Pratt radius, bending angle, tip, stress, bottom elongation,
//! cavity volume and, with the tip blocked, the support force.
//!
//! The radius and the bending angle come from the same functions as the image chain
//! ([`crate::fit::fit_circle_pratt`], [`crate::fit::bending_angle_along_markers_deg`] on
//! the 8 marker points in the x-z plane), so simulated and measured numbers share their
//! definitions.

use nalgebra::{Matrix3, Point2, Vector3};
use serde::{Deserialize, Serialize};

use super::actuator::ActuatorMesh;
use super::contact::{min_gap_mm, ContactConfig};
use super::membrane::{membrane_stress, MembraneGeometry};
use super::membrane_tri6::{tri6_membrane_stress, Tri6Geometry};
use super::plate::surface_bending_stress;
use super::solve::{LoadState, NewtonSettings, Solver};
use super::truss::truss_strain_stress;
use super::FemError;
use crate::fit::{bending_angle_along_markers_deg, fit_circle_pratt};

/// Results of one converged pressure step (whole actuator).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StepResult {
    /// Cavity pressure, kPa.
    pub pressure_kpa: f64,
    /// Radius of the Pratt circle through the markers, mm (infinite when straight).
    pub radius_mm: f64,
    /// 1 / radius, 1/m.
    pub curvature_per_m: f64,
    /// Bending angle, degrees (half-angle convention of the image chain).
    pub bending_angle_deg: f64,
    /// Tip (bottom edge of the free end, symmetry plane), x, mm.
    pub tip_x_mm: f64,
    /// Tip z, mm.
    pub tip_z_mm: f64,
    /// Largest first principal Cauchy stress over the elements, MPa.
    pub max_principal_stress_mpa: f64,
    /// Tensile strength / that stress.
    pub safety_factor: f64,
    /// Elongation of the bottom face's centre line beyond the clamp, % (negative: the
    /// bottom is on the inside of the bend and usually shortens).
    pub bottom_elongation_pct: f64,
    /// Rotation of the free end's face about the actuator's axis, degrees, right-handed
    /// about +x (0 by symmetry on a half model); over a ramp, carried on past ±180.
    pub twist_angle_deg: f64,
    /// Length change of the polyline through the markers, % (axial extension).
    pub extension_pct: f64,
    /// Inflation of the first free chamber's bottom wall, mm: its centre's distance from
    /// the chord of its ends, positive outward (NaN when the model has no such wall).
    pub bottom_inflation_mm: f64,
    /// Largest first principal stress and safety factor of every part (silicone first,
    /// then each layer and fibre set).
    pub parts: Vec<PartStress>,
    /// Volume of the cavities (chambers + channel), mm³.
    pub cavity_volume_mm3: f64,
    /// Each named cavity's pressure and volume (an imported mesh's `cavity.NAME`
    /// groups, the segmented finger's channels; empty without them).
    pub cavities: Vec<CavityStep>,
    /// Smallest signed gap between the facing walls of neighbouring chambers, mm
    /// (negative: the walls interpenetrate; NaN when no wall node faces the other wall).
    pub min_wall_gap_mm: f64,
    /// Newton iterations this step took.
    pub newton_iterations: usize,
    /// Force of the tip on its support, N (blocked-tip runs only).
    pub blocked_force_n: Option<f64>,
    /// Marker positions (x, z), mm, from the clamp to the tip.
    pub markers_mm: Vec<(f64, f64)>,
}

/// A named cavity at a step ([`crate::fem::solve::Cavity`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CavityStep {
    /// NAME of its `cavity.NAME` group.
    pub name: String,
    /// Its pressure, kPa: the ramp's times its factor.
    pub pressure_kpa: f64,
    /// Its volume, mm³ (the whole actuator's, as `cavity_volume_mm3`).
    pub volume_mm3: f64,
}

/// The stress of one part of the model at a step.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PartStress {
    /// The part ([`super::actuator::Part`]).
    pub name: String,
    /// Largest first principal stress, MPa (Cauchy for solids; the membranes' and
    /// fibres' second Piola-Kirchhoff stress, equal at their small strains; a plate's
    /// with its surface bending stress added).
    pub max_principal_stress_mpa: f64,
    /// Tensile strength / that stress (NaN without a strength).
    pub safety_factor: f64,
}

/// `side_face.json`: the filmed side face (y = i/2) of the actuator at every converged
/// step, in the x-z plane; the input of `bendscope render`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SideFaceFile {
    /// Quads, indices into every step's `points_mm`, counter-clockwise in x-z.
    pub quads: Vec<[usize; 4]>,
    /// Clamped length from x = 0, mm.
    pub clamp_mm: f64,
    /// The steps.
    pub steps: Vec<SideFaceStep>,
}

/// One step of [`SideFaceFile`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SideFaceStep {
    /// Pressure, kPa.
    pub pressure_kpa: f64,
    /// Face points (x, z), mm.
    pub points_mm: Vec<[f64; 2]>,
    /// Marker points (x, z), mm, from the clamp to the tip.
    pub markers_mm: Vec<[f64; 2]>,
    /// Pratt radius through the markers, mm.
    pub radius_mm: f64,
    /// Bending angle, degrees.
    pub bending_angle_deg: f64,
}

impl SideFaceFile {
    /// The face of `mesh`, no steps yet; returns it with the mesh nodes it lists.
    pub fn new(mesh: &ActuatorMesh) -> (Self, Vec<usize>) {
        let mut index = std::collections::HashMap::new();
        let mut nodes = Vec::new();
        let quads = mesh
            .side_face
            .iter()
            .map(|q| {
                q.map(|n| {
                    *index.entry(n).or_insert_with(|| {
                        nodes.push(n);
                        nodes.len() - 1
                    })
                })
            })
            .collect();
        (
            Self {
                quads,
                clamp_mm: mesh.clamp_mm,
                steps: Vec::new(),
            },
            nodes,
        )
    }

    /// Appends a converged step (`nodes` from [`Self::new`]).
    pub fn push(
        &mut self,
        mesh: &ActuatorMesh,
        nodes: &[usize],
        step: &StepResult,
        displacement: &[f64],
    ) {
        let at = |n: usize| {
            let x = mesh.model.nodes[n];
            [x.x + displacement[3 * n], x.z + displacement[3 * n + 2]]
        };
        self.steps.push(SideFaceStep {
            pressure_kpa: step.pressure_kpa,
            points_mm: nodes.iter().map(|n| at(*n)).collect(),
            markers_mm: step.markers_mm.iter().map(|(x, z)| [*x, *z]).collect(),
            radius_mm: step.radius_mm,
            bending_angle_deg: step.bending_angle_deg,
        });
    }
}

/// State of a converged step, for field output.
pub struct StepFields<'a> {
    /// Nodal displacements, mm (3 per node).
    pub displacement: &'a [f64],
    /// Element Cauchy stresses, MPa.
    pub stresses: &'a [Matrix3<f64>],
}

/// Settings of a ramp.
#[derive(Debug, Clone, Copy, Default)]
pub struct RampSettings {
    /// Fix the tip's bottom edge in z (a flat rigid support) and report its force.
    pub blocked: bool,
    /// Newton settings.
    pub newton: NewtonSettings,
}

/// The outcome of a ramp: the converged steps, and the failure that ended it early.
#[derive(Debug)]
pub struct Ramp {
    /// Converged steps, in pressure order.
    pub steps: Vec<StepResult>,
    /// Why the ramp stopped before its last pressure.
    pub failure: Option<FemError>,
    /// Free degrees of freedom.
    pub free_dofs: usize,
}

/// The largest eigenvalue of a symmetric 3x3 matrix.
pub fn max_principal(s: &Matrix3<f64>) -> f64 {
    let sym = 0.5 * (s + s.transpose());
    sym.symmetric_eigenvalues().max()
}

/// Runs the pressure ramp: gravity (the mesh's dead load) first, then each pressure in
/// turn; `on_step` sees every converged step. A step that does not converge ends the
/// ramp; the steps before it are kept.
pub fn run_ramp(
    mesh: &ActuatorMesh,
    pressures_kpa: &[f64],
    settings: &RampSettings,
    mut on_step: impl FnMut(&StepResult, &StepFields),
) -> Result<Ramp, FemError> {
    let mut model = mesh.model.clone();
    if settings.blocked {
        for n in &mesh.tip_support {
            model.fixed[3 * n + 2] = true;
        }
    }
    let mut solver = Solver::new(&model)?;
    let mut ramp = Ramp {
        steps: Vec::new(),
        failure: None,
        free_dofs: solver.free_dofs(),
    };
    let first = NewtonSettings {
        initial_step: 0.25,
        ..settings.newton
    };
    if let Err(e) = solver.advance(
        LoadState {
            dead: 1.0,
            pressure_mpa: 0.0,
        },
        &first,
    ) {
        ramp.failure = Some(e);
        return Ok(ramp);
    }
    for &p in pressures_kpa {
        let step = NewtonSettings {
            initial_step: 1.0,
            ..settings.newton
        };
        match solver.advance(
            LoadState {
                dead: 1.0,
                pressure_mpa: p * 1e-3,
            },
            &step,
        ) {
            Ok(report) => {
                let stresses = solver.element_stresses();
                let mut result = step_result(
                    mesh,
                    &solver,
                    &stresses,
                    p,
                    report.iterations,
                    settings.blocked,
                )?;
                // The twist continues from the last step's past ±180 deg (steps turn the end
                // by far less than 180 deg each).
                if let Some(last) = ramp.steps.last() {
                    result.twist_angle_deg =
                        continued_twist(last.twist_angle_deg, result.twist_angle_deg);
                }
                on_step(
                    &result,
                    &StepFields {
                        displacement: solver.displacement(),
                        stresses: &stresses,
                    },
                );
                ramp.steps.push(result);
            }
            Err(FemError::Diverged { load_fraction, .. }) => {
                let from = ramp.steps.last().map(|s| s.pressure_kpa).unwrap_or(0.0);
                ramp.failure = Some(FemError::Diverged {
                    load_fraction,
                    why: format!(
                        "the step from {from} to {p} kPa did not converge (stopped at {:.2} kPa): the actuator may be unstable there; try a finer --mesh-size, smaller pressure steps or a stiffer material",
                        from + load_fraction * (p - from)
                    ),
                });
                break;
            }
            // Its cause (which load is not finite) is the message: the steps before it
            // are kept.
            Err(e @ FemError::NotFinite { .. }) => {
                ramp.failure = Some(e);
                break;
            }
            Err(e) => return Err(e),
        }
    }
    Ok(ramp)
}

/// Rotation of the free end's face about the actuator's axis, degrees, in (-180, 180]:
/// the face's vertical (`twist_pair`, bottom to top) read off the bending plane, its
/// sideways part (-y) against its part in the x-z plane, whose sign says whether the face
/// has turned past 90 deg: that part points up (along the axis at the end, from the bottom
/// line's last segment, turned by 90 deg towards +z) or down. Past 90 deg the reading
/// without the sign (earlier) folded back (46.6 / -1.5 deg at 50 / 60 kPa for the twisting
/// tube, turned ~133 / ~181 deg); [`run_ramp`] carries it on past 180 deg.
fn twist_angle_deg(mesh: &ActuatorMesh, solver: &Solver) -> f64 {
    let v = solver.position(mesh.twist_pair.1) - solver.position(mesh.twist_pair.0);
    let line = &mesh.bottom_line;
    let axis = match line.len() {
        n if n >= 2 => solver.position(line[n - 1]) - solver.position(line[n - 2]),
        _ => Vector3::x(),
    };
    twist_of(&v, &axis)
}

/// [`twist_angle_deg`] of the end face's vertical `v` at the end's axis `axis`.
fn twist_of(v: &Vector3<f64>, axis: &Vector3<f64>) -> f64 {
    let up = Vector3::new(-axis.z, 0.0, axis.x);
    let side = if v.dot(&up) < 0.0 { -1.0 } else { 1.0 };
    (-v.y).atan2(side * v.x.hypot(v.z)).to_degrees()
}

/// A twist read in (-180, 180] carried on from the step before (whole turns added).
fn continued_twist(last_deg: f64, now_deg: f64) -> f64 {
    now_deg + 360.0 * ((last_deg - now_deg) / 360.0).round()
}

/// The markers' current positions in the filmed side plane (x, z), mm: what a step's
/// circle, radius and bending angle are read from.
pub fn marker_points(mesh: &ActuatorMesh, solver: &Solver) -> Vec<Point2<f64>> {
    mesh.markers
        .iter()
        .map(|n| {
            let x = solver.position(*n);
            Point2::new(x.x, x.z)
        })
        .collect()
}

fn step_result(
    mesh: &ActuatorMesh,
    solver: &Solver,
    stresses: &[Matrix3<f64>],
    pressure_kpa: f64,
    newton_iterations: usize,
    blocked: bool,
) -> Result<StepResult, FemError> {
    let markers = marker_points(mesh, solver);
    let fit_err = |e: crate::fit::FitError| FemError::Model {
        why: format!("marker circle at {pressure_kpa} kPa: {e}"),
    };
    let circle = fit_circle_pratt(&markers).map_err(fit_err)?;
    let angle = if circle.curvature > 0.0 {
        bending_angle_along_markers_deg(&markers, &circle).map_err(fit_err)?
    } else {
        0.0
    };
    let tip = solver.position(mesh.tip);
    let whole = if mesh.half_model { 2.0 } else { 1.0 };
    let length = |pts: &mut dyn Iterator<Item = Vector3<f64>>| {
        let v: Vec<Vector3<f64>> = pts.collect();
        v.windows(2).map(|w| (w[1] - w[0]).norm()).sum::<f64>()
    };
    let l0 = length(&mut mesh.bottom_line.iter().map(|n| mesh.model.nodes[*n]));
    let l1 = length(&mut mesh.bottom_line.iter().map(|n| solver.position(*n)));
    let m0 = length(&mut mesh.markers.iter().map(|n| mesh.model.nodes[*n]));
    let m1 = length(&mut mesh.markers.iter().map(|n| solver.position(*n)));
    let parts = part_stresses(mesh, solver, stresses);
    // The main silicone is the mesh's first part (a strain-limiting layer is far stiffer
    // and stronger: reported as its own part).
    let silicone = &parts[0];
    let twist_angle_deg = twist_angle_deg(mesh, solver);
    let bottom_inflation_mm = mesh
        .bottom_wall
        .map_or(f64::NAN, |w| w.inflation_mm(|n| solver.position(n)));
    let blocked_force_n = blocked.then(|| {
        let r = solver.reactions();
        // Support force on the model (+z), doubled on a half model: the tip's push.
        whole * mesh.tip_support.iter().map(|n| r[3 * n + 2]).sum::<f64>()
    });
    Ok(StepResult {
        pressure_kpa,
        radius_mm: circle.radius,
        curvature_per_m: 1000.0 * circle.curvature,
        bending_angle_deg: angle,
        tip_x_mm: tip.x,
        tip_z_mm: tip.z,
        max_principal_stress_mpa: silicone.max_principal_stress_mpa,
        safety_factor: silicone.safety_factor,
        bottom_elongation_pct: 100.0 * (l1 / l0 - 1.0),
        twist_angle_deg,
        extension_pct: 100.0 * (m1 / m0 - 1.0),
        bottom_inflation_mm,
        parts,
        cavity_volume_mm3: whole * solver.cavity_volume(),
        cavities: mesh
            .model
            .tets
            .cavities
            .iter()
            .zip(solver.cavity_volumes())
            .filter_map(|(c, v)| {
                Some(CavityStep {
                    name: c.name.clone()?,
                    pressure_kpa: pressure_kpa * c.factor,
                    volume_mm3: whole * v,
                })
            })
            .collect(),
        min_wall_gap_mm: min_gap_mm(&mesh.wall_pairs, &|a| solver.position(a)).unwrap_or(f64::NAN),
        newton_iterations,
        blocked_force_n,
        markers_mm: markers.iter().map(|p| (p.x, p.y)).collect(),
    })
}

/// Largest eigenvalue of a membrane stress [[s11, s12], [s12, s22]] (Voigt s11, s22, s12).
fn largest_in_plane(s: &Vector3<f64>) -> f64 {
    0.5 * (s[0] + s[1]) + (0.25 * (s[0] - s[1]).powi(2) + s[2] * s[2]).sqrt()
}

/// The largest first principal stress of every part of `mesh` and its safety factor.
pub fn part_stresses(
    mesh: &ActuatorMesh,
    solver: &Solver,
    stresses: &[Matrix3<f64>],
) -> Vec<PartStress> {
    let model = &mesh.model;
    let u = solver.displacement();
    let at = |n: usize| Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
    mesh.parts
        .iter()
        .map(|part| {
            let mut max = f64::NEG_INFINITY;
            if let Some(id) = part.solid_material {
                for (e, s) in stresses.iter().enumerate() {
                    let v = max_principal(s);
                    if model.solid_material_id(e) == id && v.is_finite() {
                        max = max.max(v);
                    }
                }
            }
            for &k in &part.membranes {
                let el = &model.membranes[k];
                let x = el.nodes.map(|n| model.nodes[n]);
                if let Some(geom) = MembraneGeometry::new(&x) {
                    let s = membrane_stress(&geom, &el.section, &el.nodes.map(at));
                    max = max.max(largest_in_plane(&s));
                }
            }
            for &k in &part.tri_membranes {
                let el = &model.tri_membranes[k];
                let x = el.nodes.map(|n| model.nodes[n]);
                if let Some(geom) = Tri6Geometry::new(&x) {
                    for s in tri6_membrane_stress(&geom, &el.section, &el.nodes.map(at)) {
                        max = max.max(largest_in_plane(&s));
                    }
                }
            }
            // A plate's surfaces carry its bending stress beside the membrane stress (an
            // upper estimate: the largest of each, added).
            if let Some(p) = &part.plate {
                let bending = surface_bending_stress(
                    &model.plates[p.terms.clone()],
                    u,
                    p.thickness_mm,
                    p.youngs_modulus_mpa,
                    p.poisson_ratio,
                );
                if max.is_finite() {
                    max += bending;
                }
            }
            for &k in &part.trusses {
                let (_, stress) = truss_strain_stress(&model.trusses[k], &model.nodes, u);
                max = max.max(stress);
            }
            let max = if max.is_finite() { max } else { f64::NAN };
            PartStress {
                name: part.name.clone(),
                max_principal_stress_mpa: max,
                safety_factor: part
                    .tensile_strength_mpa
                    .map_or(f64::NAN, |t| t / max.max(1e-300)),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The end face's vertical turned by φ about the end's axis, the actuator bent by 50 deg
    /// (the axis down the x-z plane) and straight: φ read back over (-180, 180], the same
    /// as the reading without the sign below 90 deg, and carried on past ±180.
    #[test]
    fn the_twist_is_read_past_90_degrees_and_carried_past_180() {
        for bend in [0.0f64, -50.0] {
            let b = bend.to_radians();
            let axis = Vector3::new(b.cos(), 0.0, b.sin());
            let up = Vector3::new(-b.sin(), 0.0, b.cos());
            for phi in [0.0f64, 30.0, -60.0, 89.0, 120.0, -150.0, 179.0] {
                let p = phi.to_radians();
                // Rotation by φ about the axis takes up to cos φ up − sin φ y (right-handed).
                let v = (up * p.cos() - Vector3::y() * p.sin()) * 11.0 + axis * 0.3;
                let got = twist_of(&v, &axis);
                assert!((got - phi).abs() < 2.0, "bend {bend}, {phi}: {got}");
                if phi.abs() < 90.0 {
                    let before = (-v.y).atan2(v.x.hypot(v.z)).to_degrees();
                    assert_eq!(got, before);
                }
            }
        }
        assert_eq!(continued_twist(170.0, -175.0), 185.0);
        assert_eq!(continued_twist(-170.0, 175.0), -185.0);
        assert_eq!(continued_twist(400.0, 50.0), 410.0);
        assert_eq!(continued_twist(15.0, 35.0), 35.0);
    }
    use crate::fem::actuator::{build_mesh, ActuatorConfig, LoadConfig, MeshConfig};

    fn coarse(gravity: bool) -> ActuatorMesh {
        build_mesh(&ActuatorConfig {
            mesh: MeshConfig {
                size_mm: 2.5,
                ..Default::default()
            },
            load: LoadConfig {
                gravity,
                ..Default::default()
            },
            ..Default::default()
        })
        .unwrap()
    }

    #[test]
    fn zero_pressure_without_gravity_leaves_the_actuator_straight() {
        let mesh = coarse(false);
        let ramp = run_ramp(&mesh, &[0.0], &RampSettings::default(), |_, _| {}).unwrap();
        assert!(ramp.failure.is_none());
        let s = &ramp.steps[0];
        assert!(s.curvature_per_m < 1e-9, "{s:?}");
        assert!(s.bending_angle_deg.abs() < 1e-9 && s.tip_z_mm.abs() < 1e-9);
        assert!(s.bottom_elongation_pct.abs() < 1e-9);
    }

    /// A step whose load is not finite ends the ramp as a failure naming the load, the
    /// steps before it kept (it was a step "converged" in 0 iterations at the rest shape),
    /// and so does a density whose gravity load overflows, before any step.
    #[test]
    fn a_load_that_is_not_finite_ends_the_ramp_naming_it() {
        let mesh = coarse(false);
        let ramp = run_ramp(
            &mesh,
            &[10.0, 1e200, 20.0],
            &RampSettings::default(),
            |_, _| {},
        )
        .unwrap();
        assert_eq!(ramp.steps.len(), 1);
        let why = ramp.failure.map(|e| e.to_string()).unwrap_or_default();
        assert!(why.contains("the load is not finite at 1e200 kPa"), "{why}");
        let mut heavy = coarse(true);
        for l in &mut heavy.model.loads {
            *l *= 1e300;
        }
        let ramp = run_ramp(&heavy, &[10.0], &RampSettings::default(), |_, _| {}).unwrap();
        assert!(ramp.steps.is_empty());
        let why = ramp.failure.map(|e| e.to_string()).unwrap_or_default();
        assert!(
            why.contains("the load is not finite at 0 kPa with gravity"),
            "{why}"
        );
    }

    #[test]
    fn radius_falls_and_blocked_force_rises_with_pressure() {
        let mesh = coarse(true);
        let p = [0.0, 20.0, 40.0, 60.0];
        let free = run_ramp(&mesh, &p, &RampSettings::default(), |_, _| {}).unwrap();
        assert!(free.failure.is_none(), "{:?}", free.failure);
        let r: Vec<f64> = free.steps.iter().map(|s| s.radius_mm).collect();
        // Gravity alone sags the soft cantilever a lot (the free length carries ~0.3 N on
        // a bending stiffness of a few thousand N mm²: tens of mm); pressure bends it on.
        assert!(free.steps[0].tip_z_mm < -10.0, "{:?}", free.steps[0]);
        assert!(r.windows(2).all(|w| w[1] < w[0]), "radius must fall: {r:?}");
        let angles: Vec<f64> = free.steps.iter().map(|s| s.bending_angle_deg).collect();
        assert!(angles.windows(2).all(|w| w[1] > w[0]), "{angles:?}");
        assert!(
            free.steps.iter().all(|s| s.tip_z_mm < 0.0),
            "bends towards -z"
        );
        let v: Vec<f64> = free.steps.iter().map(|s| s.cavity_volume_mm3).collect();
        assert!(v.windows(2).all(|w| w[1] > w[0]), "cavity inflates: {v:?}");
        let blocked = run_ramp(
            &mesh,
            &p,
            &RampSettings {
                blocked: true,
                ..Default::default()
            },
            |_, _| {},
        )
        .unwrap();
        let f: Vec<f64> = blocked
            .steps
            .iter()
            .map(|s| s.blocked_force_n.unwrap())
            .collect();
        assert!(f.windows(2).all(|w| w[1] > w[0]) && f[3] > 0.0, "{f:?}");
        // At zero pressure the support carries a share of the weight only: the body is
        // about 3.2e4 mm³ of 1.08 g/cm³ silicone, 0.34 N in all (3/8 of the free part
        // for a propped cantilever).
        assert!(f[0] > 0.0 && f[0] < 0.3, "{f:?}");
    }
}

#[cfg(test)]
mod layer_tests {
    use super::*;
    use crate::fem::actuator::{build_mesh, ActuatorConfig, LoadConfig, MeshConfig};
    use crate::fem::layer::{LayerConfig, LayerElement};

    /// The reference actuator (2.5 mm mesh, gravity on) with a paper layer (0.1 mm,
    /// 3 GPa, 1 mm above the bottom) meshed as `element`.
    fn paper(element: LayerElement) -> (ActuatorMesh, Ramp) {
        let cfg = ActuatorConfig {
            mesh: MeshConfig {
                size_mm: 2.5,
                ..Default::default()
            },
            load: LoadConfig {
                gravity: true,
                ..Default::default()
            },
            layer: vec![LayerConfig {
                thickness_mm: 0.1,
                youngs_modulus_mpa: 3000.0,
                element,
                ..Default::default()
            }],
            ..Default::default()
        };
        let mesh = build_mesh(&cfg).unwrap();
        let started = std::time::Instant::now();
        let ramp = run_ramp(
            &mesh,
            &[10.0, 60.0, 115.0],
            &RampSettings::default(),
            |_, _| {},
        )
        .unwrap();
        eprintln!(
            "paper layer ({element:?}): {:.1} s, {:?}",
            started.elapsed().as_secs_f64(),
            ramp.steps
                .iter()
                .map(|s| (
                    s.pressure_kpa,
                    s.radius_mm,
                    s.bottom_elongation_pct,
                    s.newton_iterations
                ))
                .collect::<Vec<_>>()
        );
        (mesh, ramp)
    }

    #[test]
    fn paper_layer_converges_under_gravity_over_the_ramp() {
        for element in [LayerElement::Membrane, LayerElement::Solid] {
            let (_, ramp) = paper(element);
            assert!(ramp.failure.is_none(), "{element:?}: {:?}", ramp.failure);
            assert_eq!(ramp.steps.len(), 3);
        }
    }
}

#[cfg(test)]
mod contact_tests {
    use super::*;
    use crate::fem::actuator::{build_mesh, ActuatorConfig, Geometry, LoadConfig, MeshConfig};
    use crate::fem::contact::ContactConfig;

    /// The reference actuator with 0.5 mm gaps between its chambers, coarse (3 mm).
    fn narrow_gaps(contact: Option<ContactConfig>) -> ActuatorConfig {
        ActuatorConfig {
            geometry: Geometry {
                d: 0.5,
                ..Geometry::default()
            },
            mesh: MeshConfig {
                size_mm: 3.0,
                ..Default::default()
            },
            load: LoadConfig {
                pressures_kpa: "10,25,40".into(),
                gravity: true,
                ..LoadConfig::default()
            },
            contact,
            ..Default::default()
        }
    }

    /// The chambers bulge into the 0.5 mm gaps: by 25 kPa the facing walls would pass
    /// through each other; with contact they stay apart to a penetration of hundredths of
    /// a millimetre, Newton converges as without, and the walls pushing on each other
    /// bend the actuator more.
    #[test]
    fn walls_driven_into_each_other_stay_apart_with_contact() {
        let run = |cfg: &ActuatorConfig| {
            let mesh = build_mesh(cfg).unwrap();
            let started = std::time::Instant::now();
            let ramp = run_ramp(
                &mesh,
                &cfg.pressures_kpa().unwrap(),
                &RampSettings {
                    newton: cfg.solver.newton(),
                    ..Default::default()
                },
                |_, _| {},
            )
            .unwrap();
            (ramp, started.elapsed().as_secs_f64())
        };
        let (free, t_free) = run(&narrow_gaps(None));
        let contact = ContactConfig::default();
        let (held, t_held) = run(&narrow_gaps(Some(contact.clone())));
        for (a, b) in free.steps.iter().zip(&held.steps) {
            eprintln!(
                "{:4.0} kPa: min wall gap {:8.4} mm without contact, {:8.4} mm with; radius {:7.3} / {:7.3} mm ({:+.2}%); Newton iterations {} / {}",
                a.pressure_kpa,
                a.min_wall_gap_mm,
                b.min_wall_gap_mm,
                a.radius_mm,
                b.radius_mm,
                100.0 * (b.radius_mm / a.radius_mm - 1.0),
                a.newton_iterations,
                b.newton_iterations
            );
        }
        eprintln!(
            "ramp {t_free:.2} s without contact, {t_held:.2} s with ({:.2}x)",
            t_held / t_free
        );
        assert!(free.failure.is_none() && held.failure.is_none());
        assert_eq!((free.steps.len(), held.steps.len()), (3, 3));
        let gap = |r: &Ramp| -> Vec<f64> { r.steps.iter().map(|s| s.min_wall_gap_mm).collect() };
        let (g_free, g_held) = (gap(&free), gap(&held));
        // Open at 10 kPa (0.5 mm less the bulges: measured 0.281 mm), the same with and
        // without contact; without, the walls overlap by 0.1 mm and more from 25 kPa.
        assert!((g_free[0] - 0.281).abs() < 0.01 && (g_held[0] - g_free[0]).abs() < 1e-12);
        assert!(g_free[1] < -0.1 && g_free[2] < g_free[1], "{g_free:?}");
        let warnings = ramp_warnings(&free.steps, None);
        assert!(
            warnings
                .iter()
                .any(|w| w.contains("from 25 kPa the facing walls")),
            "{warnings:?}"
        );
        // With contact: in contact, penetration within the tolerance (measured 0.012 mm
        // at 40 kPa), no warning.
        for g in &g_held[1..] {
            assert!(*g < 0.0 && *g > -contact.tolerance_mm, "{g_held:?}");
        }
        assert!(ramp_warnings(&held.steps, Some(&contact)).is_empty());
        // Smaller radius with contact at 25 and 40 kPa (measured -1.7% at 40 kPa).
        let ratio = held.steps[2].radius_mm / free.steps[2].radius_mm;
        assert!(ratio < 0.99 && ratio > 0.95, "{ratio}");
        assert!(held.steps[1].radius_mm < free.steps[1].radius_mm);
    }
}

pub use super::shapes::thinnest_wall_mm;

/// Notes on the mesh of `cfg` before a run ([`super::shapes::Shape::mesh_notes`]: a mesh
/// coarser than the thinnest wall).
pub fn mesh_notes(cfg: &super::actuator::ActuatorConfig) -> Vec<String> {
    cfg.shape().mesh_notes(cfg)
}

/// Total turning of the marker chain from the clamp to the tip, degrees: the turns
/// between successive chords plus half a chord turn at each end (the tangent at an end
/// marker is half a turn from its chord on a circular arc). More than 360 degrees means
/// the actuator has curled past a full turn, where the half-angle bending angle wraps.
pub fn marker_turning_deg(markers: &[(f64, f64)]) -> f64 {
    let chords: Vec<f64> = markers
        .windows(2)
        .map(|w| (w[1].1 - w[0].1).atan2(w[1].0 - w[0].0))
        .collect();
    let turns: Vec<f64> = chords
        .windows(2)
        .map(|c| {
            let mut d = c[1] - c[0];
            while d > std::f64::consts::PI {
                d -= std::f64::consts::TAU;
            }
            while d < -std::f64::consts::PI {
                d += std::f64::consts::TAU;
            }
            d
        })
        .collect();
    if turns.is_empty() {
        return 0.0;
    }
    let sum: f64 = turns.iter().sum();
    let mean = sum / turns.len() as f64;
    (sum + mean).abs().to_degrees()
}

/// What a user must know about a ramp's results: the first step where the safety
/// factor drops below 1 (the silicone would tear), the first step where the markers
/// curl past a full turn (the bending angle wraps and is no longer the total bend), and
/// the first step where the facing chamber walls interpenetrate: at all without
/// `contact` (the ramp's model has no contact), beyond its tolerance with it.
pub fn ramp_warnings(steps: &[StepResult], contact: Option<&ContactConfig>) -> Vec<String> {
    let mut w = Vec::new();
    let allowed = contact.map_or(0.0, |c| c.tolerance_mm);
    if let Some(s) = steps.iter().find(|s| s.min_wall_gap_mm < -allowed) {
        w.push(match contact {
            None => format!(
                "from {} kPa the facing walls of neighbouring chambers interpenetrate (smallest gap {:.3} mm): the model has no contact between them, so the steps from there on are not physical; add a [contact] table to the config",
                s.pressure_kpa, s.min_wall_gap_mm
            ),
            Some(c) => format!(
                "from {} kPa the facing chamber walls interpenetrate by {:.3} mm, more than contact.tolerance_mm = {} mm: raise contact.penalty_mpa_per_mm",
                s.pressure_kpa, -s.min_wall_gap_mm, c.tolerance_mm
            ),
        });
    }
    if let Some(s) = steps.iter().find(|s| s.safety_factor < 1.0) {
        w.push(format!(
            "safety factor {:.2} < 1 from {} kPa: the max principal stress ({:.2} MPa) exceeds the tensile strength; the silicone would tear there",
            s.safety_factor, s.pressure_kpa, s.max_principal_stress_mpa
        ));
    }
    let parts = steps.first().map_or(0, |s| s.parts.len());
    for k in 1..parts {
        if let Some(s) = steps
            .iter()
            .find(|s| s.parts.get(k).is_some_and(|p| p.safety_factor < 1.0))
        {
            let p = &s.parts[k];
            w.push(format!(
                "{}: safety factor {:.2} < 1 from {} kPa (stress {:.1} MPa beyond its tensile strength): it would tear there",
                p.name, p.safety_factor, s.pressure_kpa, p.max_principal_stress_mpa
            ));
        }
    }
    if let Some(s) = steps
        .iter()
        .find(|s| marker_turning_deg(&s.markers_mm) > 360.0)
    {
        w.push(format!(
            "from {} kPa the markers curl past a full turn ({:.0} deg): the bending angle ({:.0} deg) wraps and no longer measures the total bend",
            s.pressure_kpa,
            marker_turning_deg(&s.markers_mm),
            s.bending_angle_deg
        ));
    }
    w
}

#[cfg(test)]
mod warning_tests {
    use super::*;

    fn arc(turn_deg: f64, n: usize) -> Vec<(f64, f64)> {
        // n markers evenly on an arc turning `turn_deg` from the first to the last
        // (plus half a step at each end, as for chamber centres).
        let step = turn_deg.to_radians() / n as f64;
        (0..n)
            .map(|k| {
                let t = step * (k as f64 + 0.5);
                (50.0 * t.sin(), 50.0 * (1.0 - t.cos()))
            })
            .collect()
    }

    #[test]
    fn turning_is_the_angle_between_the_end_markers_tangents() {
        // Markers at t_k = s (k + 1/2): the tangents at the first and last marker are
        // s (n - 1) apart, 7/8 of the arc for 8 markers.
        for turn in [30.0, 170.0, 300.0, 440.0] {
            let t = marker_turning_deg(&arc(turn, 8));
            assert!((t - turn * 7.0 / 8.0).abs() < 1e-6, "{turn}: {t}");
        }
    }

    #[test]
    fn warnings_name_the_first_step() {
        let step = |p: f64, sf: f64, turn: f64| StepResult {
            pressure_kpa: p,
            radius_mm: 40.0,
            curvature_per_m: 25.0,
            bending_angle_deg: 10.0,
            tip_x_mm: 0.0,
            tip_z_mm: 0.0,
            max_principal_stress_mpa: 3.447 / sf,
            safety_factor: sf,
            bottom_elongation_pct: 0.0,
            twist_angle_deg: 0.0,
            extension_pct: 0.0,
            bottom_inflation_mm: 0.0,
            parts: Vec::new(),
            cavity_volume_mm3: 0.0,
            cavities: Vec::new(),
            min_wall_gap_mm: 1.0 - p / 250.0,
            newton_iterations: 3,
            blocked_force_n: None,
            markers_mm: arc(turn, 8),
        };
        assert!(ramp_warnings(&[step(100.0, 2.0, 200.0)], None).is_empty());
        // Gaps 0.6, -0.2, -0.6 mm.
        let steps = [
            step(100.0, 2.0, 200.0),
            step(300.0, 0.8, 380.0),
            step(400.0, 0.5, 420.0),
        ];
        let w = ramp_warnings(&steps, None);
        assert_eq!(w.len(), 3, "{w:?}");
        assert!(
            w[0].contains("from 300 kPa the facing walls of neighbouring chambers interpenetrate (smallest gap -0.200 mm)"),
            "{}",
            w[0]
        );
        assert!(
            w[1].contains("safety factor 0.80 < 1 from 300 kPa"),
            "{}",
            w[1]
        );
        assert!(
            w[2].contains("from 400 kPa the markers curl past a full turn"),
            "{}",
            w[2]
        );
        // With contact, only a penetration beyond its tolerance is worth a warning.
        let contact = ContactConfig {
            tolerance_mm: 0.3,
            ..ContactConfig::default()
        };
        let w = ramp_warnings(&steps, Some(&contact));
        assert_eq!(w.len(), 3, "{w:?}");
        assert!(
            w[0].contains("from 400 kPa the facing chamber walls interpenetrate by 0.600 mm"),
            "{}",
            w[0]
        );
    }
}
