//! `bendscope simulate` on 10-node tetrahedra: the reference actuator's CAD description
//! meshed by gmsh (`[geometry] family = "mesh"`) against its built-in mesh cut into
//! tetrahedra (`[mesh] element = "tet10"`), and the imported geometry's bad input.

mod common;

use std::path::Path;

use common::{col, read_csv, Run};

/// Radius column of `steps.csv` under `dir`.
fn radii(dir: &Path) -> Vec<f64> {
    let (header, rows) = read_csv(&dir.join("steps.csv"));
    let r = col(&header, "radius_mm");
    rows.iter().map(|row| row[r].parse().unwrap()).collect()
}

/// The reference actuator from `examples/geo/pneunets_reference.geo`, meshed by gmsh
/// at 3 mm (unstructured, 12.6k nodes), against the built-in structured mesh's
/// hexahedra cut into six tetrahedra each (3 mm, 29k nodes): the same element on two
/// independent meshes of one geometry. Measured 0.9% and 0.8% apart at 40 and 115 kPa
/// (docs/src/validation.md, "Quadratic tetrahedra in the solver"); both within 0.3% of
/// their 1.5 mm meshes there.
#[test]
fn the_reference_meshed_by_gmsh_agrees_with_its_built_in_mesh_in_tetrahedra() {
    let dir = tempfile::tempdir().unwrap();
    let geo = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/geo/pneunets_reference.geo"
    );
    std::fs::write(
        dir.path().join("geo.toml"),
        format!("[geometry]\nfamily = \"mesh\"\nfile = \"{geo}\"\n[mesh]\nsize_mm = 3.0\n"),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("cut.toml"),
        "[mesh]\nelement = \"tet10\"\nsize_mm = 3.0\n",
    )
    .unwrap();
    let run = |config: &str, out: &str| {
        let r = Run::new(
            dir.path(),
            &[
                "simulate",
                "--config",
                config,
                "--pressures",
                "40,115",
                "--no-gravity",
                "--no-vtu",
                "-o",
                out,
            ],
        );
        assert_eq!(r.code, 0, "{r}");
        radii(&dir.path().join(out))
    };
    let gmsh = run("geo.toml", "gmsh");
    let cut = run("cut.toml", "cut");
    assert_eq!(gmsh.len(), 2);
    for (a, b) in gmsh.iter().zip(&cut) {
        assert!((a / b - 1.0).abs() < 0.015, "gmsh {gmsh:?} vs cut {cut:?}");
    }
    // Bent well past a half turn at 115 kPa (radius ~42 mm over ~100 mm of markers).
    assert!(gmsh[1] > 38.0 && gmsh[1] < 46.0, "{gmsh:?}");
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
