//! The parts of an imported mesh (`[geometry] family = "mesh"`) beside its silicone:
//! cavities at their own pressures, volumes with their own materials, threads and sheets,
//! each against CalculiX on the exported deck or an exact property, and their bad input.

mod common;

use std::path::Path;

use common::calculix::{
    assert_radius_and_deflection_agree, simulate_and_calculix_peer_with_deck,
    simulate_and_calculix_with_deck,
};
use common::mesh::{assert_refused, table};
use common::{col, Run};

/// The two-cavity block (`fixtures/mesh/two-cavities.geo`, `cavity.a` nearer the clamp,
/// `cavity.b` farther) with the factors `a`, `b`, clamped at x = 0, five markers on the
/// side face, 3 mm, no gravity.
fn two_cavities(dir: &Path, name: &str, a: f64, b: f64) -> String {
    let file = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/mesh/two-cavities.geo"
    );
    let text = format!("[geometry]\nfamily = \"mesh\"\nfile = \"{file}\"\nclamp = \"x-min\"\n[geometry.markers]\nfrom = [6.0, 0.0, 1.5]\nto = [30.0, 0.0, 1.5]\ncount = 5\n[mesh]\nsize_mm = 3.0\n[load]\ngravity = false\n[cavities]\na = {a:?}\nb = {b:?}\n");
    let toml = format!("{name}.toml");
    std::fs::write(dir.join(&toml), text).unwrap();
    toml
}

/// Cavities pressurised apart add up at small pressure: the tip's displacement with
/// only `a` at P plus that with only `b` at P is that with both, to 3.5% of the
/// displacement at 5 kPa (measured 2.7%; 4.9% at 10 kPa, 0.5% at 1 kPa), and what is
/// left is the response's second order: it grows 3 to 5 times when P doubles (measured
/// 3.6; a cavity loaded at a wrong factor would leave a first-order part, and a ratio
/// near 2). The nonlinearity is the cavities' 1.5 mm top walls bulging (each cavity's
/// volume +4% at 4 kPa). With `a` alone, `b`'s volume changes by under 1% of `a`'s
/// (measured 0.13%: the wall between them pulled); steps.csv has each cavity's pressure,
/// and the deck loads only the pressurised cavity's faces.
#[test]
fn cavities_pressurised_apart_add_up_at_small_pressure() {
    let dir = tempfile::tempdir().unwrap();
    let p = [5.0, 10.0];
    let mut tips = Vec::new();
    for (name, a, b) in [("a", 1.0, 0.0), ("b", 0.0, 1.0), ("ab", 1.0, 1.0)] {
        let toml = two_cavities(dir.path(), name, a, b);
        let mut args = vec![
            "simulate",
            "--config",
            &toml,
            "--pressures",
            "0,5,10",
            "--no-vtu",
            "-o",
            name,
        ];
        if name == "a" {
            args.extend(["--export-inp", "a.inp"]);
        }
        let r = Run::new(dir.path(), &args);
        assert_eq!(r.code, 0, "{r}");
        let out = dir.path().join(name);
        let (header, rows) = table(&out.join("steps.csv"));
        let c = |n: &str| col(&header, n);
        for (row, ramp) in rows.iter().zip([0.0, 5.0, 10.0]) {
            assert_eq!(row[c("pressure_a_kpa")], a * ramp, "{name}");
            assert_eq!(row[c("pressure_b_kpa")], b * ramp, "{name}");
            let sum = row[c("cavity_volume_a_mm3")] + row[c("cavity_volume_b_mm3")];
            assert!(
                (sum - row[c("cavity_volume_mm3")]).abs() < 2e-4,
                "{name}: {row:?}"
            );
        }
        // Drawn: 10 x 6 x 3.5 mm each.
        assert!((rows[0][c("cavity_volume_a_mm3")] - 210.0).abs() < 1e-3);
        if name == "a" {
            let grow = |k: &str| rows[2][c(k)] - rows[0][c(k)];
            let (da, db) = (grow("cavity_volume_a_mm3"), grow("cavity_volume_b_mm3"));
            assert!(da > 1.0 && db.abs() < 0.01 * da, "a grows {da}, b {db}");
        }
        // The tip: the last marker (x, z), to 5 decimals.
        let (header, rows) = table(&out.join("markers.csv"));
        let (x, z) = (col(&header, "m5_x_mm"), col(&header, "m5_z_mm"));
        tips.push(rows.iter().map(|r| [r[x], r[z]]).collect::<Vec<_>>());
    }
    let mut defects = Vec::new();
    for (k, pk) in p.iter().enumerate() {
        let d = |t: &Vec<[f64; 2]>| [t[k + 1][0] - t[0][0], t[k + 1][1] - t[0][1]];
        let (a, b, ab) = (d(&tips[0]), d(&tips[1]), d(&tips[2]));
        let defect = (a[0] + b[0] - ab[0]).hypot(a[1] + b[1] - ab[1]);
        let size = ab[0].hypot(ab[1]);
        eprintln!(
            "{pk} kPa: a {a:?} b {b:?} ab {ab:?}: defect {defect:.5} mm of {size:.5} mm ({:.2}%)",
            100.0 * defect / size
        );
        assert!(
            size > 0.02 && a[1] < 0.0 && b[1] < 0.0,
            "{pk} kPa: {a:?} {b:?}"
        );
        defects.push((defect, size));
    }
    let ((d5, s5), (d10, _)) = (defects[0], defects[1]);
    assert!(d5 < 0.035 * s5, "5 kPa: defect {d5} of {s5} mm");
    assert!(
        (3.0..5.0).contains(&(d10 / d5)),
        "defect {d5} then {d10} mm"
    );
    // The deck: each step loads cavity a's faces alone, at the step's pressure.
    let deck = std::fs::read_to_string(dir.path().join("a.inp")).unwrap();
    let faces = |cavity: &str| -> usize {
        let head = format!("** cavity {cavity}: ");
        let line = deck.lines().find(|l| l.starts_with(&head)).unwrap();
        line[head.len()..]
            .split(' ')
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    assert!(deck.contains("** cavity b: ") && deck.contains(" faces at 0 x the ramp's pressure"));
    let step = deck.split("** cavity pressure 5 kPa").nth(1).unwrap();
    let loads: Vec<&str> = step
        .split("*DLOAD\n")
        .nth(1)
        .unwrap()
        .lines()
        .take_while(|l| !l.starts_with('*'))
        .collect();
    assert_eq!(loads.len(), faces("a"), "{}", faces("b"));
    assert!(
        loads.iter().all(|l| l.ends_with(", 5.000000000e-3")),
        "{loads:?}"
    );
}

/// `[cavities]` that cannot be taken is refused in one line naming the key and what to
/// do, exit 2, nothing written: a NaN, a negative or absurd factor, a name that is no
/// cavity of the model (listing its cavities), factors on a model with one cavity. The
/// finger prints its channels and reads them back.
#[test]
fn cavity_factors_are_refused_by_key_and_the_fingers_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let finger = "[geometry]\nfamily = \"segmented-finger\"\n[cavities]\n";
    let block = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/mesh/block.msh");
    let cases: [(String, &[&str]); 7] = [
        (format!("{finger}mcp = nan\n"), &["[cavities] mcp = nan: not a finite number", "factor of the ramp's"]),
        (format!("{finger}mcp = -1\n"), &["parameter cavities.mcp: -1: give the cavity's pressure as a factor", "from 0 (not pressurised) to 100"]),
        (format!("{finger}pip_dip = 1e6\n"), &["parameter cavities.pip_dip: 1e6: give"]),
        (format!("{finger}dip = 0\n"), &["parameter cavities.dip: the model has no cavity `dip`: name one of its cavities (mcp, pip_dip)"]),
        ("[cavities]\nmcp = 0\n".into(), &["parameter cavities.mcp: the pneunets family has one cavity", "remove [cavities]"]),
        (format!("[geometry]\nfamily = \"mesh\"\nfile = \"{block}\"\n[cavities]\na = 0.5\n"), &["parameter cavities.a: ", "block.msh: the mesh has one unnamed cavity", "cavity.NAME"]),
        (
            std::fs::read_to_string(dir.path().join(two_cavities(dir.path(), "two", 1.0, 0.0)))
                .unwrap()
                .replace("b = 0.0", "c = 0.0"),
            &["parameter cavities.c: the model has no cavity `c`: name one of its cavities (a, b)"],
        ),
    ];
    for (text, needles) in &cases {
        std::fs::write(dir.path().join("bad.toml"), text).unwrap();
        let r = Run::new(
            dir.path(),
            &[
                "simulate",
                "--config",
                "bad.toml",
                "--no-vtu",
                "-o",
                "out",
                "--export-inp",
                "deck.inp",
            ],
        );
        r.assert_bad_input(needles);
        assert!(
            !dir.path().join("out").exists() && !dir.path().join("deck.inp").exists(),
            "{text}: {r}"
        );
    }
    let printed = Run::new(
        dir.path(),
        &["simulate", "--family", "segmented-finger", "--print-config"],
    );
    assert_eq!(printed.code, 0, "{printed}");
    assert!(
        printed
            .stdout
            .contains("[cavities]\nmcp = 1.0\npip_dip = 1.0\n"),
        "{printed}"
    );
    std::fs::write(dir.path().join("finger.toml"), &printed.stdout).unwrap();
    let again = Run::new(
        dir.path(),
        &["simulate", "--config", "finger.toml", "--print-config"],
    );
    assert_eq!(again.stdout, printed.stdout);
}

/// The segmented finger with its PIP-DIP channel off (`cavities.pip_dip = 0`, 30 kPa on
/// MCP; 2.5 mm mesh, the coarsest whose quadratic tetrahedra follow the bellows' 2.5 mm
/// tops): only the MCP segment bends. The markers past it and two more pitches (rest x
/// beyond 4 bellows at the 6.5 mm pitch and 13 mm, where the last pressurised bellow's
/// local strain has died out) stay on a straight line within 0.01 mm (measured 0.0022 mm;
/// with both channels at 30 kPa they leave it by 1.74 mm), turned as one by more than
/// 1 deg (measured 10.2 deg) as the MCP segment bends under them.
#[test]
fn a_finger_with_its_pip_dip_channel_off_bends_at_mcp_alone() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("finger.toml"),
        "[geometry]\nfamily = \"segmented-finger\"\n[mesh]\nsize_mm = 2.5\n[cavities]\npip_dip = 0\n",
    )
    .unwrap();
    let r = Run::new(
        dir.path(),
        &[
            "simulate",
            "--config",
            "finger.toml",
            "--pressures",
            "0,30",
            "--no-vtu",
            "-o",
            "out",
        ],
    );
    assert_eq!(r.code, 0, "{r}");
    let (header, steps) = table(&dir.path().join("out/steps.csv"));
    assert_eq!(steps[1][col(&header, "pressure_mcp_kpa")], 30.0);
    assert_eq!(steps[1][col(&header, "pressure_pip_dip_kpa")], 0.0);
    let (header, rows) = table(&dir.path().join("out/markers.csv"));
    let at = |row: &Vec<f64>, k: usize| {
        [
            row[col(&header, &format!("m{k}_x_mm"))],
            row[col(&header, &format!("m{k}_z_mm"))],
        ]
    };
    let settled = 4.0 * 6.5 + 2.0 * 6.5;
    let beyond: Vec<usize> = (1..=13).filter(|k| at(&rows[0], *k)[0] > settled).collect();
    assert_eq!(beyond.len(), 9, "{beyond:?}");
    let line: Vec<[f64; 2]> = beyond.iter().map(|k| at(&rows[1], *k)).collect();
    // The line's direction by total least squares; each marker's distance from it.
    let n = line.len() as f64;
    let c = [0, 1].map(|i| line.iter().map(|p| p[i]).sum::<f64>() / n);
    let s = |i: usize, j: usize| {
        line.iter()
            .map(|p| (p[i] - c[i]) * (p[j] - c[j]))
            .sum::<f64>()
    };
    let theta = 0.5 * (2.0 * s(0, 1)).atan2(s(0, 0) - s(1, 1));
    let normal = [-theta.sin(), theta.cos()];
    let off = line
        .iter()
        .map(|p| ((p[0] - c[0]) * normal[0] + (p[1] - c[1]) * normal[1]).abs())
        .fold(0.0, f64::max);
    let rest = [at(&rows[0], beyond[0]), at(&rows[0], 13)];
    let turned = (rest[1][1] - rest[0][1]).atan2(rest[1][0] - rest[0][0]) - theta;
    assert!(off < 0.01, "off the line by {off} mm");
    assert!(
        turned.to_degrees().abs() > 1.0,
        "turned {} deg",
        turned.to_degrees()
    );
}

/// The segmented finger's exported deck solved by CalculiX (ccx_peer, the follower
/// pressure's load stiffness for its curved cavities; C3D10, its bottom sheet as M3D6 on
/// the same nodes): the default finger at 2.5 mm, bulk modulus 3 mu0 (18.366 MPa, mu0 =
/// 2 C10, where C3D10 does not lock), 5 kPa. CalculiX's marker radius and tip deflection
/// within 3% of bendscope's (measured -0.78% and +2.33%; stock ccx -0.91% and +2.50%).
#[test]
fn calculix_agrees_with_the_finger_on_its_exported_deck() {
    let config = "[geometry]\nfamily = \"segmented-finger\"\n[mesh]\nsize_mm = 2.5\n";
    let args = [
        "--pressures",
        "5",
        "--no-gravity",
        "--bulk-modulus",
        "18.366",
    ];
    let (h, _, steps, deck) = simulate_and_calculix_peer_with_deck(&args, Some(config));
    assert!(deck.contains("*ELEMENT, TYPE=C3D10") && deck.contains("TYPE=M3D6, ELSET=SHEET"));
    assert_eq!(steps.len(), 1);
    // The tip lies at (130, 0, 0) at rest.
    let d = assert_radius_and_deflection_agree(&h, &steps[0], 0.03);
    assert!(d > 5.0, "the finger hardly bent: {d} mm");
}

/// An imported mesh's named volumes take their own materials (`[material.NAME]`): the
/// two-material block (`fixtures/mesh/two-materials.geo`, `silicone` near the clamp and
/// `stiff` beyond x = 15, 5 times the coefficients) against CalculiX C3D10 on the exported
/// deck, which writes each volume's material, at 20 kPa, 1.5 mm, 3 mu0. The markers (on
/// the bottom face) move as CalculiX's within 3% of their displacement (measured 2.51%;
/// C3D10 is the stiffer: 4.36% at 2 mm, and the block in one material differs as much,
/// 3.43% / 5.64%); the stiff half matters: with [material] everywhere the markers move
/// 42% differently.
#[test]
fn named_volumes_take_their_own_materials_as_calculix_does() {
    let file = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/mesh/two-materials.geo"
    );
    let bulk = 3.0 * 0.21488;
    let config = |stiff: &str| {
        format!(
            "[geometry]\nfamily = \"mesh\"\nfile = \"{file}\"\nclamp = \"x-min\"\n[geometry.markers]\nfrom = [3.0, 5.0, 0.0]\nto = [30.0, 5.0, 0.0]\ncount = 6\n\
             [mesh]\nsize_mm = 1.5\n[material]\nbulk_modulus_mpa = {bulk}\n{stiff}"
        )
    };
    let two = config(&format!(
        "[material.stiff]\nbulk_modulus_mpa = {bulk}\nscale = 5.0\ndensity_g_cm3 = 1.5\n"
    ));
    let args = ["--pressures", "20", "--no-gravity"];
    let (h, rest, steps, deck) = simulate_and_calculix_with_deck(&args, Some(&two));
    // Each volume's material in the deck: the stiff one at 5 x the preset's C10.
    let c10 = |name: &str| -> f64 {
        let head = format!("*MATERIAL, NAME={name}\n*HYPERELASTIC, YEOH\n");
        let at = deck
            .find(&head)
            .unwrap_or_else(|| panic!("{name} not in the deck"))
            + head.len();
        deck[at..]
            .split(',')
            .next()
            .unwrap()
            .trim()
            .parse()
            .unwrap()
    };
    assert!((c10("STIFF") / c10("SILICONE") - 5.0).abs() < 1e-9);
    assert!(deck.contains("*DENSITY\n1.500000000e-9"));
    let s = &steps[0];
    assert!(col(&h, "stress_mpa_stiff") > 0 && s.row[col(&h, "safety_factor_stiff")] > 1.0);
    let dir = tempfile::tempdir().unwrap();
    let ours = markers_moved(dir.path(), &two, &args, &rest);
    let theirs = calculix_moved(s, &rest);
    let soft = markers_moved(dir.path(), &config(""), &args, &rest);
    let (against_ccx, against_soft) = (
        relative_difference(&ours, &theirs),
        relative_difference(&ours, &soft),
    );
    eprintln!(
        "markers: CalculiX differs by {:.2}% of their displacement, one material by {:.1}%",
        100.0 * against_ccx,
        100.0 * against_soft
    );
    assert!(against_ccx < 0.03, "{ours:?} vs CalculiX {theirs:?}");
    assert!(against_soft > 0.2, "{ours:?} vs one material {soft:?}");
}

/// A `[material.NAME]` or `[threads.NAME]` table that cannot be taken is refused in one
/// line naming it, exit 2, no results: a name that is no volume (no thread) of the mesh
/// (its groups listed), a table on a family without named groups, a NaN or a negative
/// coefficient, a modulus given in Pa, a table for the silicone itself, a thread curve
/// without its section. The config written beside the results reads back.
#[test]
fn named_materials_and_threads_are_refused_by_key_and_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let file = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/mesh/two-materials.geo"
    );
    let mesh = format!("[geometry]\nfamily = \"mesh\"\nfile = \"{file}\"\nclamp = \"x-min\"\n[geometry.markers]\nfrom = [3.0, 5.0, 0.0]\nto = [30.0, 5.0, 0.0]\ncount = 6\n[mesh]\nsize_mm = 4.0\n");
    let thread = mesh.replace("two-materials.geo", "thread.geo");
    let cases: [(String, &[&str]); 10] = [
        (
            format!("{mesh}[material.nope]\nscale = 2.0\n"),
            &["[material.nope]", "no volume `nope`", "silicone, stiff"],
        ),
        (
            "[material.stiff]\nscale = 2.0\n".into(),
            &["[material.stiff]", "pneunets", "remove the table"],
        ),
        (
            format!("{mesh}[material.stiff]\nc1 = nan\n"),
            &["[material.stiff] c1"],
        ),
        (
            format!("{mesh}[material.stiff]\nc3 = -1.0\n"),
            &["[material.stiff] c3", ">= 0"],
        ),
        (
            format!("{mesh}[material.silicone]\nscale = 2.0\n"),
            &["[material.silicone]", "put these keys there"],
        ),
        (
            format!("{thread}[threads.nope]\ndiameter_mm = 0.3\nyoungs_modulus_mpa = 7e4\n"),
            &["[threads.nope]", "no curve `thread.nope`", "kevlar"],
        ),
        (
            thread.clone(),
            &["thread `kevlar` has no section", "[threads.kevlar]"],
        ),
        (
            format!("{thread}[threads.kevlar]\ndiameter_mm = nan\nyoungs_modulus_mpa = 7e4\n"),
            &["[threads.kevlar] diameter_mm"],
        ),
        (
            format!("{thread}[threads.kevlar]\ndiameter_mm = 0.3\nyoungs_modulus_mpa = 7e10\n"),
            &["[threads.kevlar] youngs_modulus_mpa", "70000"],
        ),
        (
            "[threads.kevlar]\ndiameter_mm = 0.3\nyoungs_modulus_mpa = 7e4\n".into(),
            &["[threads.kevlar]", "pneunets", "remove the table"],
        ),
    ];
    for (config, needles) in &cases {
        assert_refused(dir.path(), config, &["--pressures", "5"], needles);
    }
    let good = format!("{mesh}[load]\ngravity = false\n[material.stiff]\nscale = 3.0\n");
    std::fs::write(dir.path().join("model.toml"), good).unwrap();
    let steps = |config: &str, out: &str| -> String {
        let r = Run::new(
            dir.path(),
            &[
                "simulate",
                "--config",
                config,
                "-o",
                out,
                "--no-vtu",
                "--pressures",
                "5",
            ],
        );
        assert_eq!(r.code, 0, "{r}");
        std::fs::read_to_string(dir.path().join(out).join("steps.csv")).unwrap()
    };
    let first = steps("model.toml", "a");
    let written = std::fs::read_to_string(dir.path().join("a/config.toml")).unwrap();
    assert!(written.contains("[material.stiff]\n"), "{written}");
    assert_eq!(steps("a/config.toml", "b"), first);
}

/// An imported mesh's `thread.NAME` curves are threads with the section of
/// `[threads.NAME]`: the block of `fixtures/mesh/thread.geo` (a cavity at mid-height, a
/// Kevlar thread, 0.3 mm, 70 GPa, along its bottom face) bends toward its thread, and
/// agrees with CalculiX C3D10 on the exported deck (the thread as SPRINGA bars tied to
/// the nodes) at 20 kPa, 3 mu0: the six markers on the top face move as CalculiX's
/// within 3% of their displacement at 1.2 mm (measured 2.12%; 3.01% at 1.5 mm, 6.82% at
/// 2 mm: the elements', converging). With a thread of no stiffness (1 Pa) the tip moves
/// down 0.0027 mm against 0.162 (held to a third).
#[test]
fn threads_of_an_imported_mesh_bend_it_as_calculix_does() {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/mesh/thread.geo");
    let config = |threads: &str| {
        format!(
            "[geometry]\nfamily = \"mesh\"\nfile = \"{file}\"\nclamp = \"x-min\"\n[geometry.markers]\nfrom = [3.0, 5.0, 8.0]\nto = [30.0, 5.0, 8.0]\ncount = 6\n\
             [mesh]\nsize_mm = 1.2\n[material]\nbulk_modulus_mpa = {}\n{threads}",
            3.0 * 0.21488
        )
    };
    let kevlar = config("[threads.kevlar]\ndiameter_mm = 0.3\nyoungs_modulus_mpa = 70000.0\nstrength_mpa = 3000.0\n");
    let args = ["--pressures", "20", "--no-gravity"];
    let (h, rest, steps, deck) = simulate_and_calculix_with_deck(&args, Some(&kevlar));
    assert!(
        deck.contains("TYPE=SPRINGA, ELSET=KEVLAR"),
        "no thread in the deck"
    );
    let s = &steps[0];
    // Bent toward the thread (the tip down), the thread in tension, its safety factor.
    assert!(s.row[col(&h, "tip_z_mm")] < 7.9, "{:?}", s.row);
    assert!(s.row[col(&h, "stress_mpa_kevlar")] > 0.0);
    assert!(s.row[col(&h, "safety_factor_kevlar")] > 1.0);
    let dir = tempfile::tempdir().unwrap();
    let ours = markers_moved(dir.path(), &kevlar, &args, &rest);
    let theirs = calculix_moved(s, &rest);
    let off = relative_difference(&ours, &theirs);
    eprintln!(
        "markers: CalculiX differs by {:.2}% of their displacement",
        100.0 * off
    );
    assert!(off < 0.03, "{ours:?} vs CalculiX {theirs:?}");
    let bare = markers_moved(
        dir.path(),
        &config("[threads.kevlar]\ndiameter_mm = 0.3\nyoungs_modulus_mpa = 1e-6\n"),
        &args,
        &rest,
    );
    let (tip, bare_tip) = (ours[ours.len() - 1][1], bare[bare.len() - 1][1]);
    eprintln!("tip moves {tip:.4} mm down with the thread, {bare_tip:.4} mm without");
    assert!(tip < 3.0 * bare_tip.min(0.0) - 0.01, "{tip} vs {bare_tip}");
}

/// An imported mesh's `layer.NAME` surfaces are sheets with the section of the
/// `[[layer]]` table named NAME, as 6-node membranes on the tetrahedra's faces: the block
/// of `fixtures/mesh/layer.geo` (a cavity at mid-height, a paper sheet, 0.1 mm, 3 GPa, as
/// its bottom face) bends toward its sheet, and agrees with CalculiX C3D10 on the exported
/// deck (the sheet as M3D6 on the same nodes) at 20 kPa, 3 mu0: the six markers on the top
/// face move as CalculiX's within 3% of their displacement at 1.2 mm (measured 2.45%; the
/// block without the sheet's stiffness 2.24%). With a sheet of no stiffness (1 Pa) the
/// tip moves down 0.0025 mm against 0.171 mm (held to a third).
#[test]
fn layers_of_an_imported_mesh_bend_it_as_calculix_does() {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/mesh/layer.geo");
    let config = |modulus: &str| {
        format!(
            "[geometry]\nfamily = \"mesh\"\nfile = \"{file}\"\nclamp = \"x-min\"\n[geometry.markers]\nfrom = [3.0, 5.0, 8.0]\nto = [30.0, 5.0, 8.0]\ncount = 6\n\
             [mesh]\nsize_mm = 1.2\n[material]\nbulk_modulus_mpa = {}\n\
             [[layer]]\nname = \"paper\"\nthickness_mm = 0.1\nyoungs_modulus_mpa = {modulus}\ntensile_strength_mpa = 30.0\n",
            3.0 * 0.21488
        )
    };
    let paper = config("3000.0");
    let args = ["--pressures", "20", "--no-gravity"];
    let (h, rest, steps, deck) = simulate_and_calculix_with_deck(&args, Some(&paper));
    assert!(
        deck.contains("TYPE=M3D6, ELSET=PAPER"),
        "no sheet in the deck"
    );
    let s = &steps[0];
    assert!(s.row[col(&h, "tip_z_mm")] < 7.9, "{:?}", s.row);
    assert!(s.row[col(&h, "stress_mpa_paper")] > 0.0);
    assert!(s.row[col(&h, "safety_factor_paper")] > 1.0);
    let dir = tempfile::tempdir().unwrap();
    let ours = markers_moved(dir.path(), &paper, &args, &rest);
    let theirs = calculix_moved(s, &rest);
    let off = relative_difference(&ours, &theirs);
    eprintln!(
        "markers: CalculiX differs by {:.2}% of their displacement",
        100.0 * off
    );
    assert!(off < 0.03, "{ours:?} vs CalculiX {theirs:?}");
    let bare = markers_moved(dir.path(), &config("1e-6"), &args, &rest);
    let (tip, bare_tip) = (ours[ours.len() - 1][1], bare[bare.len() - 1][1]);
    eprintln!("tip moves {tip:.4} mm with the sheet, {bare_tip:.4} mm without");
    assert!(tip < 3.0 * bare_tip.min(0.0) - 0.05, "{tip} vs {bare_tip}");
}

/// A flat `layer.NAME` sheet with `element = "plate"` also bends
/// ([`bendscope::fem::plate_tri`]): the block of `fixtures/mesh/layer.geo` with its sheet
/// (`layer.paper`) a glass-fibre strip (0.5 mm, 6.5 GPa, its own bending stiffness about
/// 40% of the section's) agrees with CalculiX on the exported deck, the sheet as S6 shells
/// on the same nodes, at 20 kPa, 3 mu0: the six markers within 3% of their displacement
/// (measured 1.9%).
#[test]
fn plate_layers_of_an_imported_mesh_bend_it_as_calculix_shells_do() {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/mesh/layer.geo");
    let glass = format!(
        "[geometry]\nfamily = \"mesh\"\nfile = \"{file}\"\nclamp = \"x-min\"\n[geometry.markers]\nfrom = [3.0, 5.0, 8.0]\nto = [30.0, 5.0, 8.0]\ncount = 6\n\
         [mesh]\nsize_mm = 1.2\n[material]\nbulk_modulus_mpa = {}\n\
         [[layer]]\nname = \"paper\"\nthickness_mm = 0.5\nyoungs_modulus_mpa = 6500.0\npoisson_ratio = 0.22\nelement = \"plate\"\n",
        3.0 * 0.21488
    );
    let args = ["--pressures", "20", "--no-gravity"];
    let (_, rest, steps, deck) = simulate_and_calculix_with_deck(&args, Some(&glass));
    assert!(
        deck.contains("TYPE=S6, ELSET=PAPER"),
        "no shells in the deck"
    );
    assert!(deck.contains("*SHELL SECTION, ELSET=PAPER, MATERIAL=PAPER\n5.000000000e-1"));
    let dir = tempfile::tempdir().unwrap();
    let ours = markers_moved(dir.path(), &glass, &args, &rest);
    let theirs = calculix_moved(&steps[0], &rest);
    let off = relative_difference(&ours, &theirs);
    eprintln!(
        "plate sheet: CalculiX S6 differs by {:.2}% of the markers' displacement",
        100.0 * off
    );
    assert!(off < 0.03, "{ours:?} vs CalculiX {theirs:?}");
}

/// A layer of an imported mesh is placed and meshed by its surface: a table naming no
/// surface, a surface without its table, the keys that place a built-in family's layer,
/// another element, and a NaN, negative, out-of-range or absurdly large number are each
/// refused in one line naming the key, exit 2, no results.
#[test]
fn imported_layers_are_refused_by_key() {
    let dir = tempfile::tempdir().unwrap();
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/mesh/layer.geo");
    let mesh = format!("[geometry]\nfamily = \"mesh\"\nfile = \"{file}\"\nclamp = \"x-min\"\n[geometry.markers]\nfrom = [3.0, 5.0, 8.0]\nto = [30.0, 5.0, 8.0]\ncount = 6\n[mesh]\nsize_mm = 4.0\n");
    let sheet = "thickness_mm = 0.1\nyoungs_modulus_mpa = 3000.0\n";
    let cases: [(String, &[&str]); 10] = [
        (
            format!("{mesh}[[layer]]\nname = \"card\"\n{sheet}"),
            &["[[layer]] `card`", "no surface `layer.card`", "paper"],
        ),
        (mesh.clone(), &["layer `paper` has no section", "[[layer]]"]),
        (
            format!("{mesh}[[layer]]\nname = \"paper\"\n{sheet}height_mm = 2.0\n"),
            &["layer.paper.height_mm", "remove height_mm"],
        ),
        (
            format!("{mesh}[[layer]]\nname = \"paper\"\n{sheet}width_mm = 4.0\n"),
            &["layer.paper.width_mm", "remove width_mm"],
        ),
        (
            format!("{mesh}[[layer]]\nname = \"paper\"\n{sheet}element = \"solid\"\n"),
            &["layer.paper.element", "membrane or plate"],
        ),
        (
            format!("{mesh}[[layer]]\nname = \"paper\"\nthickness_mm = nan\nyoungs_modulus_mpa = 3000.0\n"),
            &["[layer.1] thickness_mm", "nan"],
        ),
        (
            format!("{mesh}[[layer]]\nname = \"paper\"\nthickness_mm = 0.1\nyoungs_modulus_mpa = -3000.0\n"),
            &["layer.youngs_modulus_mpa", "must be positive"],
        ),
        (
            format!("{mesh}[[layer]]\nname = \"paper\"\n{sheet}poisson_ratio = 0.7\n"),
            &["layer.poisson_ratio", "0.7"],
        ),
        (
            format!("{mesh}[[layer]]\nname = \"paper\"\nthickness_mm = 12.0\nyoungs_modulus_mpa = 3000.0\n"),
            &["layer.paper.thickness_mm", "at most 5 mm"],
        ),
        (
            format!("{mesh}[[layer]]\nname = \"paper\"\nthickness_mm = 0.1\nyoungs_modulus_mpa = 3e9\n"),
            &["layer.paper.youngs_modulus_mpa", "not Pa"],
        ),
    ];
    for (config, needles) in &cases {
        assert_refused(dir.path(), config, &["--pressures", "5"], needles);
    }
}

/// ||a - b|| / ||a|| over displacement pairs.
fn relative_difference(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    let norm = |v: &mut dyn Iterator<Item = [f64; 2]>| {
        v.map(|d| d[0] * d[0] + d[1] * d[1]).sum::<f64>().sqrt()
    };
    norm(&mut a.iter().zip(b).map(|(p, q)| [p[0] - q[0], p[1] - q[1]]))
        / norm(&mut a.iter().copied())
}

/// The markers' displacements (x, z) from `rest` in `simulate --config` of `config` with
/// `args` (its first pressure), run in `dir`.
fn markers_moved(dir: &Path, config: &str, args: &[&str], rest: &[[f64; 3]]) -> Vec<[f64; 2]> {
    std::fs::write(dir.join("m.toml"), config).unwrap();
    let mut all = vec!["simulate", "--config", "m.toml", "--no-vtu", "-o", "out"];
    all.extend_from_slice(args);
    let r = Run::new(dir, &all);
    assert_eq!(r.code, 0, "{r}");
    let (h, rows) = table(&dir.join("out/markers.csv"));
    (0..rest.len())
        .map(|k| {
            let x = rows[0][col(&h, &format!("m{}_x_mm", k + 1))];
            let z = rows[0][col(&h, &format!("m{}_z_mm", k + 1))];
            [x - rest[k][0], z - rest[k][2]]
        })
        .collect()
}

/// CalculiX's marker displacements (x, z) from `rest`.
fn calculix_moved(s: &common::calculix::BothSolvers, rest: &[[f64; 3]]) -> Vec<[f64; 2]> {
    s.markers
        .iter()
        .zip(rest)
        .map(|(p, r)| [p[0] - r[0], p[2] - r[2]])
        .collect()
}

/// `simulate --sweep` over a cavity's factor: sweep.csv has each named cavity's pressure
/// and volume per design, as steps.csv has them per step.
#[test]
fn a_sweep_over_a_cavity_factor_writes_each_cavitys_pressure() {
    let dir = tempfile::tempdir().unwrap();
    let toml = two_cavities(dir.path(), "ab", 1.0, 1.0);
    let r = Run::new(
        dir.path(),
        &[
            "simulate",
            "--config",
            &toml,
            "--pressures",
            "4",
            "--no-vtu",
            "--sweep",
            "cavities.b=0:1:1",
            "-o",
            "out",
        ],
    );
    assert_eq!(r.code, 0, "{r}");
    let (header, rows) = table(&dir.path().join("out/sweep.csv"));
    let c = |n: &str| col(&header, n);
    assert_eq!(rows.len(), 2);
    for (row, b) in rows.iter().zip([0.0, 1.0]) {
        assert_eq!(row[c("cavities.b")], b);
        assert_eq!(row[c("pressure_a_kpa")], 4.0);
        assert_eq!(row[c("pressure_b_kpa")], 4.0 * b);
        let sum = row[c("cavity_volume_a_mm3")] + row[c("cavity_volume_b_mm3")];
        assert!((sum - row[c("cavity_volume_mm3")]).abs() < 2e-3, "{row:?}");
    }
    // b pressurised: its volume grows.
    assert!(rows[1][c("cavity_volume_b_mm3")] > rows[0][c("cavity_volume_b_mm3")] + 0.1);
}
