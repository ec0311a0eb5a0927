//! `bendscope simulate` on 10-node tetrahedra: the reference actuator's CAD description
//! meshed by gmsh (`[geometry] family = "mesh"`) against the converged hexahedra, and the
//! imported geometry's bad input.

mod common;

use std::path::Path;

use common::calculix::{
    assert_radius_and_deflection_agree, loaded_volume_mm3, simulate_and_calculix_with_deck,
};
use common::mesh::assert_refused;
use common::{col, read_csv, Run};

/// Radius column of `steps.csv` under `dir`.
fn radii(dir: &Path) -> Vec<f64> {
    let (header, rows) = read_csv(&dir.join("steps.csv"));
    let r = col(&header, "radius_mm");
    rows.iter().map(|row| row[r].parse().unwrap()).collect()
}

/// `examples/geo/pneunets_reference.geo` with the mesh study's 2 mm roof, written to
/// `dir/reference.geo`; its path.
fn write_reference_geo(dir: &Path) -> std::path::PathBuf {
    let geo = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/geo/pneunets_reference.geo"
    ))
    .unwrap();
    let roof = "roof = {1, ";
    assert!(geo.contains(roof), "the .geo's roof constant moved");
    let path = dir.join("reference.geo");
    std::fs::write(&path, geo.replace(roof, "roof = {2, ")).unwrap();
    path
}

/// The reference actuator from its CAD description (`examples/geo/pneunets_reference.geo`
/// with the mesh study's 2 mm roof), meshed by gmsh into 10-node tetrahedra at 3 mm,
/// against the converged hexahedra of that study (CalculiX C3D20R; bendscope's Q1/P0 at
/// 1 mm: 92.62 and 42.52 mm at 40 and 115 kPa, no gravity, 100 mu0). Measured 92.44 and
/// 42.50 mm (-0.19%, -0.05%) with the continuous pressure of Taylor-Hood (one pressure
/// per tetrahedron gave 90.20 and 41.92 mm, walls one element thick too soft in bending:
/// docs/src/validation.md, "Quadratic tetrahedra"): within the 1% the hexahedra meet.
#[test]
fn the_reference_meshed_by_gmsh_lands_on_the_converged_hexahedra() {
    let dir = tempfile::tempdir().unwrap();
    write_reference_geo(dir.path());
    std::fs::write(
        dir.path().join("geo.toml"),
        "[geometry]\nfamily = \"mesh\"\nfile = \"reference.geo\"\n[mesh]\nsize_mm = 3.0\n",
    )
    .unwrap();
    let r = Run::new(
        dir.path(),
        &[
            "simulate",
            "--config",
            "geo.toml",
            "--pressures",
            "40,115",
            "--no-gravity",
            "--bulk-modulus",
            "21.488",
            "--no-vtu",
            "-o",
            "fem",
        ],
    );
    assert_eq!(r.code, 0, "{r}");
    let got = radii(&dir.path().join("fem"));
    let converged = [92.62, 42.52];
    assert_eq!(got.len(), 2);
    for (g, c) in got.iter().zip(converged) {
        let e = g / c - 1.0;
        assert!(e.abs() < 0.01, "{got:?} against {converged:?}");
    }
}

/// A tetrahedral model exported as C3D10 and solved by stock CalculiX: the reference's .geo
/// cut to 4 chambers (b = 53.5, r = 42.5 mm, the 2 mm roof), gmsh at 2 mm, bulk modulus
/// 3 mu0 (nu = 0.35, where CalculiX's displacement-only C3D10 does not lock), no gravity,
/// 5 kPa. The deck's loaded faces enclose the cavity the .geo's numbers give (4 chambers
/// of 5 x 11 x 12 mm and the 42.5 x 7 x 2 mm channel: 3235 mm³) to 1e-9; CalculiX's marker
/// radius and tip deflection within 3% of bendscope's. Measured +1.87% and -2.41%
/// (CalculiX stiffer: C3D10 converges from the stiff side, +1.14% and -1.37% at 1.5 mm;
/// docs/src/validation.md, "Quadratic tetrahedra").
#[test]
fn calculix_agrees_with_the_tetrahedra_on_their_exported_deck() {
    let dir = tempfile::tempdir().unwrap();
    let geo = write_reference_geo(dir.path());
    let config = format!(
        "[geometry]\nfamily = \"mesh\"\nfile = \"{}\"\n[geometry.parameters]\nchambers = 4\nb = 53.5\nr = 42.5\n\
         [mesh]\nsize_mm = 2.0\n[material]\nbulk_modulus_mpa = {}\n",
        geo.display(),
        3.0 * 0.21488
    );
    let (h, _, steps, deck) =
        simulate_and_calculix_with_deck(&["--pressures", "5", "--no-gravity"], Some(&config));
    assert!(deck.contains("*ELEMENT, TYPE=C3D10") && !deck.contains("TYPE=C3D8"));
    let cavity = 4.0 * 5.0 * 11.0 * 12.0 + 42.5 * 7.0 * 2.0;
    let enclosed = 2.0 * loaded_volume_mm3(&deck);
    assert!(
        (enclosed / cavity - 1.0).abs() < 1e-9,
        "loaded faces enclose {enclosed} mm³, the cavity is {cavity}"
    );
    assert_eq!(steps.len(), 1);
    // The tip lies at (b, 0, 0) at rest.
    assert_radius_and_deflection_agree(&h, &steps[0], 0.03);
}

/// An imported geometry that cannot be simulated: one line naming what and where, exit 2,
/// no results.
#[test]
fn bad_imported_geometry_is_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let no_cavity = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n3 1 \"silicone\"\n$EndPhysicalNames\n";
    std::fs::write(dir.path().join("nocavity.msh"), no_cavity).unwrap();
    std::fs::write(dir.path().join("notes.txt"), "a text").unwrap();
    let cases: [(&str, &[&str]); 4] = [
        ("", &["geometry.file", "needs a file"]),
        (
            "file = \"missing.msh\"\n",
            &["missing.msh", "does not exist"],
        ),
        ("file = \"notes.txt\"\n", &["notes.txt", "not a gmsh mesh"]),
        ("file = \"nocavity.msh\"\n", &["nocavity.msh"]),
    ];
    for (line, needles) in cases {
        let config = format!("[geometry]\nfamily = \"mesh\"\n{line}");
        assert_refused(dir.path(), &config, &[], needles);
    }
}

/// Column `name` of a CSV file's rows.
fn column(path: &Path, name: &str) -> Vec<f64> {
    let (header, rows) = read_csv(path);
    let c = col(&header, name);
    rows.iter().map(|row| row[c].parse().unwrap()).collect()
}

/// A bare STEP file (no groups: `fixtures/mesh/block.step`, a 30 x 10 x 8 mm block with a
/// closed 20 x 4 x 4 mm void) simulates with its cavity found (the void), its clamp and
/// markers from the config, and the mesh gmsh made beside the results; its cavity
/// inflates as the same CAD's with its parts named in a .geo (`block-step.geo`, meshed
/// apart: within the two meshes' difference, 3%).
#[test]
fn a_bare_step_simulates_with_its_parts_from_the_config() {
    let dir = tempfile::tempdir().unwrap();
    let fixtures = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/mesh");
    let config = |file: &str, extra: &str| {
        format!("[geometry]\nfamily = \"mesh\"\nfile = \"{fixtures}/{file}\"\n{extra}[mesh]\nsize_mm = 3.0\n")
    };
    let parts = "clamp = \"x-min\"\n[geometry.markers]\nfrom = [6.0, 0.0, 4.0]\nto = [24.0, 0.0, 4.0]\ncount = 4\n";
    std::fs::write(dir.path().join("bare.toml"), config("block.step", parts)).unwrap();
    std::fs::write(dir.path().join("named.toml"), config("block-step.geo", "")).unwrap();
    let mut results = Vec::new();
    for name in ["bare", "named"] {
        let r = Run::new(
            dir.path(),
            &[
                "simulate",
                "--config",
                &format!("{name}.toml"),
                "--pressures",
                "2,4",
                "--no-gravity",
                "--no-vtu",
                "-o",
                name,
            ],
        );
        assert_eq!(r.code, 0, "{r}");
        let steps = dir.path().join(name).join("steps.csv");
        results.push((
            column(&steps, "cavity_volume_mm3"),
            column(&steps, "tip_x_mm"),
        ));
        let msh = std::fs::read(dir.path().join(name).join("mesh.msh")).unwrap();
        assert!(
            msh.starts_with(b"$MeshFormat\n4.1 0 8\n"),
            "{name}: mesh.msh"
        );
    }
    let (bare, named) = (&results[0], &results[1]);
    for k in 0..2 {
        let (vb, vn) = (bare.0[k] - 320.0, named.0[k] - 320.0);
        assert!(
            vb > 1.0 && (vb / vn - 1.0).abs() < 0.03,
            "cavity growth {vb} vs {vn}"
        );
        // The tip is the last marker: the named one on the .geo's point, the bare one
        // on the surface node nearest (24, 0, 4), within the 3 mm mesh size.
        let (tb, tn) = (bare.1[k], named.1[k]);
        assert!((tb - tn).abs() < 3.0, "tip x {tb} vs {tn}");
    }
}

/// A .geo's numbers from the config (`[geometry.parameters]`, gmsh's -setnumber) and
/// swept by name: the cavity height of a block whose cavity volume is 80 mm² times it.
#[test]
fn a_geo_parameter_is_set_and_swept_by_name() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("box.geo"),
        "SetFactory(\"OpenCASCADE\");\nDefineConstant[ ch = {4, Name \"Parameters/ch\"} ];\n\
         Box(1) = {0, 0, 0, 30, 10, 8};\nBox(2) = {5, 3, 4 - ch / 2, 20, 4, ch};\n\
         BooleanDifference{ Volume{1}; Delete; }{ Volume{2}; Delete; }\n",
    )
    .unwrap();
    let config = |extra: &str| {
        format!("[geometry]\nfamily = \"mesh\"\nfile = \"box.geo\"\nclamp = \"x-min\"\n{extra}[geometry.markers]\nfrom = [6.0, 0.0, 4.0]\nto = [24.0, 0.0, 4.0]\ncount = 4\n[mesh]\nsize_mm = 3.0\n")
    };
    std::fs::write(
        dir.path().join("box.toml"),
        config("[geometry.parameters]\nch = 4\n"),
    )
    .unwrap();
    let r = Run::new(
        dir.path(),
        &[
            "simulate",
            "--config",
            "box.toml",
            "--pressures",
            "0.01",
            "--no-gravity",
            "--no-vtu",
            "--sweep",
            "geometry.parameters.ch=2:6:2",
            "-o",
            "sweep",
        ],
    );
    assert_eq!(r.code, 0, "{r}");
    let volumes = column(&dir.path().join("sweep/sweep.csv"), "cavity_volume_mm3");
    assert_eq!(volumes.len(), 3);
    for (v, ch) in volumes.iter().zip([2.0, 4.0, 6.0]) {
        assert!((v / (80.0 * ch) - 1.0).abs() < 0.01, "{volumes:?}");
    }

    // A name the .geo does not hold; parameters for a file that is no .geo.
    std::fs::write(
        dir.path().join("typo.toml"),
        config("[geometry.parameters]\ncavity_h = 4\n"),
    )
    .unwrap();
    let run = Run::new(
        dir.path(),
        &["simulate", "--config", "typo.toml", "-o", "out", "--no-vtu"],
    );
    run.assert_bad_input(&["geometry.parameters.cavity_h", "has no `cavity_h`"]);
    // The geometry file's keys on a family built from its numbers.
    std::fs::write(
        dir.path().join("family.toml"),
        "[geometry]\nfamily = \"pneunets\"\nclamp = \"x-min\"\n",
    )
    .unwrap();
    let run = Run::new(
        dir.path(),
        &[
            "simulate",
            "--config",
            "family.toml",
            "-o",
            "out",
            "--no-vtu",
        ],
    );
    run.assert_bad_input(&["geometry.clamp", "family = \"mesh\""]);
}

/// The segmented finger's material, the finger-design study's Yeoh set (C20 < 0), is
/// Drucker-stable from stretch 0.2 to 4 in uniaxial, equibiaxial and planar
/// deformation, beyond every strain the finger reaches at 90 kPa.
#[test]
fn the_finger_material_is_drucker_stable() {
    use bendscope::fem::actuator::ActuatorConfig;
    use bendscope::fem::config::Family;
    use bendscope::material_fit::model::{Hyperelastic, ModelKind};
    let m = ActuatorConfig::for_family(Family::SegmentedFinger).material;
    let set = Hyperelastic {
        kind: ModelKind::Yeoh3,
        coefficients: vec![m.c1.unwrap(), m.c2.unwrap(), m.c3.unwrap()],
    };
    assert_eq!(set.coefficients, [3.061, -0.637651, 0.098623]);
    let s = set.stability(0.2, 4.0);
    assert!(s.stable, "{:?}", s.unstable);
}
