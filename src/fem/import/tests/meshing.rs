//! Meshing the fixtures and the reference actuator with gmsh (installed by
//! scripts/setup.sh), and gmsh's failures.

use std::path::Path;

use nalgebra::Vector3;

use super::{cavity_volume, check_block, fixture, mesh_volume, rel};
use crate::fem::import::{gmsh, msh, ImportedMesh};

/// A tetrahedron's corners, bit for bit.
type Corners = Vec<[u64; 3]>;

fn gmsh_mesh(cad: &Path, size: f64, numbers: &[(String, f64)], out: &Path) {
    if let Err(e) = gmsh::mesh(cad, size, numbers, out) {
        panic!(
            "meshing {} with gmsh (scripts/setup.sh installs it): {e}",
            cad.display()
        );
    }
}

#[test]
fn gmsh_meshes_the_block_geo_and_its_step() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("block.msh");
    gmsh_mesh(&fixture("block.geo"), 4.0, &[], &out);
    let coarse = msh::read(&out).unwrap();
    check_block(&coarse);
    // A .geo's DefineConstant set from the command line.
    gmsh_mesh(&fixture("block.geo"), 4.0, &[("h".into(), 2.5)], &out);
    let fine = msh::read(&out).unwrap();
    check_block(&fine);
    assert!(
        fine.tets.len() > coarse.tets.len(),
        "{} tets",
        fine.tets.len()
    );

    // The CAD with the parts named by a .geo, and the bare STEP (no parts).
    gmsh_mesh(&fixture("block-step.geo"), 4.0, &[], &out);
    check_block(&msh::read(&out).unwrap());
    gmsh_mesh(&fixture("block.step"), 4.0, &[], &out);
    check_bare_block(&out);
    // Nothing left behind but the mesh.
    let files: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(files, ["block.msh"]);
}

/// The bare STEP (no groups): one silicone, its void the cavity, its face x = 0 the
/// clamp, markers on the side face y = 0 from the config; without a clamp, refused.
fn check_bare_block(out: &Path) {
    use crate::fem::config::{ClampPlane, MarkerLine};
    use crate::fem::import::Completion;
    let err = msh::read(out).unwrap_err().to_string();
    assert_eq!(err, format!("{}: no physical surface or volume named `clamp`: name the clamped surfaces `clamp` (gmsh: Physical Surface(\"clamp\") = {{...}}), or clamp a flat face of the solid with [geometry] clamp = \"x-min\"", out.display()));
    let completion = Completion {
        clamp: Some(ClampPlane {
            axis: 0,
            max: false,
        }),
        markers: Some(MarkerLine {
            from: [6.0, 0.0, 4.0],
            to: [24.0, 0.0, 4.0],
            count: 4,
        }),
        marker_reach_mm: 4.0,
    };
    let m = msh::read_completed(out, &completion).unwrap();
    assert_eq!(m.materials, ["silicone"]);
    let v = mesh_volume(&m);
    assert!(
        rel(v, 30.0 * 10.0 * 8.0 - 20.0 * 4.0 * 4.0) < 1e-9,
        "volume {v}"
    );
    assert_eq!(m.cavities.len(), 1);
    let c = cavity_volume(&m, &m.cavities[0].1, &crate::fem::pressure::CLOSED);
    assert!(rel(c, 20.0 * 4.0 * 4.0) < 1e-9, "cavity volume {c}");
    let clamp_area = m.clamp.len();
    assert!(clamp_area > 4 && m.clamp.iter().all(|&n| m.nodes[n].x.abs() < 1e-9));
    assert_eq!(m.markers.len(), 4);
    for (k, &n) in m.markers.iter().enumerate() {
        let want = Vector3::new(6.0 + 6.0 * k as f64, 0.0, 4.0);
        let x = m.nodes[n];
        assert!(
            x.y.abs() < 1e-9 && (x - want).norm() <= 4.0,
            "marker {k} at {x:?}"
        );
    }
}

#[test]
fn gmsh_failures_are_one_line_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.msh");
    let bad = dir.path().join("bad.geo");
    std::fs::write(
        &bad,
        "SetFactory(\"OpenCASCADE\");\nBox(1) = {0, 0, 0, 1, 1, 1};\nFoo(2) = {1};\n",
    )
    .unwrap();
    let block = fixture("block.geo");
    let stl = dir.path().join("part.stl");
    std::fs::write(&stl, "solid\n").unwrap();
    type Case<'a> = (&'a str, &'a str, &'a Path, f64, Vec<(String, f64)>, String);
    let cases: Vec<Case> = vec![
        ("syntax error", "gmsh", &bad, 1.0, vec![], format!("{0}: gmsh failed: '{0}', line 3: syntax error ({{)", bad.display())),
        ("no gmsh", "gmsh-is-not-here", &block, 1.0, vec![], format!("{}: cannot mesh it: gmsh is not installed (or not on PATH): run scripts/setup.sh", block.display())),
        ("stl", "gmsh", &stl, 1.0, vec![], format!("{}: gmsh meshes .geo, .step, .stp, .iges, .igs and .brep files, not `.stl`: export the CAD as STEP", stl.display())),
        ("size", "gmsh", &block, f64::NAN, vec![], "parameter mesh size: NaN mm: give a positive size in mm".into()),
        ("number", "gmsh", &block, 1.0, vec![("h; rm".into(), 1.0)], "parameter gmsh number `h; rm`: 1: give a name of letters, digits and _ (a DefineConstant of the .geo) and a finite value".into()),
    ];
    for (name, program, cad, size, numbers, want) in cases {
        let got = gmsh::mesh_with(program, cad, size, &numbers, &out)
            .unwrap_err()
            .to_string();
        assert_eq!(got, want, "{name}");
        assert!(!out.exists(), "{name}: nothing written");
    }
    let mut left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    left.sort();
    assert_eq!(left, ["bad.geo", "part.stl"]);
}

/// examples/geo/pneunets_reference.geo against the geometry of the built-in mesh
/// (src/fem/shapes/pneunets.rs): the half volume, the half cavity volume, the markers.
#[test]
fn the_reference_actuator_geo_meshes_to_its_geometry() {
    let cfg = crate::fem::config::ActuatorConfig::default();
    let g = &cfg.geometry;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pneunets.msh");
    let geo = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/geo/pneunets_reference.geo");
    gmsh_mesh(&geo, 3.0, &[], &out);
    let m = msh::read(&out).unwrap();
    let a = g.height();
    let gaps = (g.chambers - 1) as f64 * g.d * g.i * (a - g.f - g.m - g.roof);
    let cavities = g.chambers as f64 * g.e * g.l * g.n;
    let channel = g.r * g.p * g.m;
    let solid = 0.5 * (g.b * g.i * a - gaps - cavities - channel);
    assert!(
        rel(mesh_volume(&m), solid) < 1e-9,
        "{} vs {solid}",
        mesh_volume(&m)
    );
    assert_eq!(m.symmetry.len(), 1);
    assert_eq!(m.cavities.len(), 1);
    // Closed by the plane y = 0, on which (x, 0, z) / 2 has no flux.
    let w = Vector3::new(0.5, 0.0, 0.5);
    let inside = cavity_volume(&m, &m.cavities[0].1, &w);
    assert!(rel(inside, 0.5 * (cavities + channel)) < 1e-9, "{inside}");
    assert!(m.clamp.iter().all(|&n| m.nodes[n].x <= g.c + 1e-9));
    let at: Vec<[f64; 3]> = m.markers.iter().map(|&n| m.nodes[n].into()).collect();
    let want: Vec<[f64; 3]> = g
        .marker_x()
        .iter()
        .map(|&x| [x, 0.5 * g.i, g.marker_z()])
        .collect();
    assert_eq!(at.len(), want.len());
    for (p, q) in at.iter().zip(&want) {
        assert!(
            (Vector3::from(*p) - Vector3::from(*q)).norm() < 1e-9,
            "{p:?} vs {q:?}"
        );
    }
}

/// gmsh's first-order mesh of the block, upgraded here, is its second-order mesh: the
/// same tetrahedra with the same mid-edge nodes.
#[test]
fn four_node_gmsh_mesh_upgrades_to_gmsh_s_ten_node_one() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = |order: &str| {
        let out = dir.path().join(format!("order{order}.msh"));
        let ok = std::process::Command::new("gmsh")
            .arg(fixture("block.geo"))
            .args(["-3", "-order", order, "-format", "msh41", "-o"])
            .arg(&out)
            .stdout(std::process::Stdio::null())
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        assert!(ok, "gmsh meshes block.geo (scripts/setup.sh installs it)");
        msh::read(&out).unwrap()
    };
    let (linear, quadratic) = (mesh("1"), mesh("2"));
    check_block(&linear);
    // Sorted by their corners (the same vertices); mid-nodes to gmsh's rounding.
    let sorted = |m: &ImportedMesh| {
        let mut tets: Vec<(Corners, [Vector3<f64>; 10])> = m
            .tets
            .iter()
            .map(|t| {
                let corners = t[..4].iter().map(|&n| m.nodes[n].map(f64::to_bits).into());
                (corners.collect(), t.map(|n| m.nodes[n]))
            })
            .collect();
        tets.sort_unstable_by(|a, b| a.0.cmp(&b.0));
        tets
    };
    assert_eq!(linear.nodes.len(), quadratic.nodes.len());
    let (a, b) = (sorted(&linear), sorted(&quadratic));
    assert_eq!(a.len(), b.len());
    let mut worst: f64 = 0.0;
    for (p, q) in a.iter().zip(&b) {
        assert_eq!(p.0, q.0);
        for k in 0..10 {
            worst = worst.max((p.1[k] - q.1[k]).norm());
        }
    }
    assert!(worst < 1e-12, "mid-nodes differ by {worst} mm");
}
