//! `bendscope simulate` on 10-node tetrahedra: the reference actuator's CAD description
//! meshed by gmsh (`[geometry] family = "mesh"`) against the converged hexahedra, and the
//! imported geometry's bad input.

mod common;

use std::path::Path;

use common::{col, read_csv, Run};

/// Radius column of `steps.csv` under `dir`.
fn radii(dir: &Path) -> Vec<f64> {
    let (header, rows) = read_csv(&dir.join("steps.csv"));
    let r = col(&header, "radius_mm");
    rows.iter().map(|row| row[r].parse().unwrap()).collect()
}

/// The reference actuator from its CAD description (`examples/geo/pneunets_reference.geo`
/// with the mesh study's 2 mm roof), meshed by gmsh into 10-node tetrahedra at 3 mm,
/// against the converged hexahedra of that study (CalculiX C3D20R; bendscope's Q1/P0 at
/// 1 mm: 92.62 and 42.52 mm at 40 and 115 kPa, no gravity, 100 mu0). Measured 90.20 and
/// 41.92 mm (-2.6%, -1.4%): one pressure per tetrahedron leaves walls one element thick
/// too soft in bending (docs/src/validation.md, "Quadratic tetrahedra"), so the bound is
/// that known softness, not the 1% the hexahedra meet.
#[test]
fn the_reference_meshed_by_gmsh_lands_on_the_converged_hexahedra() {
    let dir = tempfile::tempdir().unwrap();
    let geo = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/geo/pneunets_reference.geo"
    ))
    .unwrap();
    let roof = "roof = {1, ";
    assert!(geo.contains(roof), "the .geo's roof constant moved");
    std::fs::write(
        dir.path().join("reference.geo"),
        geo.replace(roof, "roof = {2, "),
    )
    .unwrap();
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
        assert!(e < 0.0 && e > -0.035, "{got:?} against {converged:?}");
    }
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
        std::fs::write(dir.path().join("model.toml"), &config).unwrap();
        let run = Run::new(
            dir.path(),
            &[
                "simulate",
                "--config",
                "model.toml",
                "-o",
                "out",
                "--no-vtu",
            ],
        );
        run.assert_bad_input(needles);
        assert!(
            !dir.path().join("out/steps.csv").exists(),
            "{config}: {run}"
        );
    }
}
