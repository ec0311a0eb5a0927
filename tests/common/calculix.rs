//! Both solvers on one model: `bendscope simulate --export-inp`, then CalculiX on the deck,
//! and what each left at the markers and the tip.

use std::path::Path;

use super::{col, Run};

/// A numeric CSV as (header, rows); non-numeric fields are NaN.
pub fn read_csv_numbers(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let (header, rows) = super::read_csv(path);
    let rows = rows
        .iter()
        .map(|r| {
            r.iter()
                .map(|v| v.parse::<f64>().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    (header, rows)
}

/// The data lines of a deck's first keyword block whose line starts with `head`, up to
/// the next keyword.
fn deck_block<'a>(deck: &'a str, head: &str) -> Vec<&'a str> {
    let lines: Vec<&str> = deck.lines().collect();
    let at = lines
        .iter()
        .position(|l| l.starts_with(head))
        .unwrap_or_else(|| panic!("deck lacks {head}"));
    lines[at + 1..]
        .iter()
        .take_while(|l| !l.starts_with('*'))
        .copied()
        .collect()
}

/// A deck's node coordinates by 1-based id and the ids of one `*NSET`.
pub fn deck_nodes_and_set(
    deck: &str,
    set: &str,
) -> (std::collections::HashMap<usize, [f64; 3]>, Vec<usize>) {
    let block = |head: &str| deck_block(deck, head);
    let nodes = block("*NODE,")
        .iter()
        .map(|l| {
            let v: Vec<f64> = l
                .split(',')
                .map(|t| t.trim().parse::<f64>().unwrap())
                .collect();
            (v[0] as usize, [v[1], v[2], v[3]])
        })
        .collect();
    let ids = block(&format!("*NSET, NSET={set}"))
        .iter()
        .flat_map(|l| l.split(',').map(|t| t.trim().parse::<usize>().unwrap()))
        .collect();
    (nodes, ids)
}

/// The displacement blocks CalculiX printed for `set` in a .dat file, in order: node id
/// to (ux, uy, uz).
pub fn dat_displacements(dat: &str, set: &str) -> Vec<std::collections::HashMap<usize, [f64; 3]>> {
    let head = format!("displacements (vx,vy,vz) for set {set} and time");
    let lines: Vec<&str> = dat.lines().collect();
    let mut out = Vec::new();
    for (k, l) in lines.iter().enumerate() {
        if l.trim_start().starts_with(&head) {
            let block = lines[k + 1..]
                .iter()
                .skip_while(|l| l.trim().is_empty())
                .take_while(|l| !l.trim().is_empty())
                .map(|l| {
                    let v: Vec<f64> = l
                        .split_whitespace()
                        .map(|t| t.parse::<f64>().unwrap())
                        .collect();
                    (v[0] as usize, [v[1], v[2], v[3]])
                })
                .collect();
            out.push(block);
        }
    }
    out
}

/// One ramp pressure as both solvers left it: bendscope's steps.csv row and CalculiX's
/// deformed marker, tip and twist-pair positions.
pub struct BothSolvers {
    /// bendscope's steps.csv row.
    pub row: Vec<f64>,
    /// CalculiX's deformed markers, mm.
    pub markers: Vec<[f64; 3]>,
    /// CalculiX's deformed tip, mm.
    pub tip: [f64; 3],
    /// CalculiX's deformed twist pair, mm.
    pub twist_pair: [[f64; 3]; 2],
}

impl BothSolvers {
    /// Pratt radius (x-z plane) of CalculiX's markers, mm.
    pub fn calculix_radius_mm(&self) -> f64 {
        let points: Vec<nalgebra::Point2<f64>> = self
            .markers
            .iter()
            .map(|p| nalgebra::Point2::new(p[0], p[2]))
            .collect();
        bendscope::fit::fit_circle_pratt(&points).unwrap().radius
    }
}

/// Runs `bendscope simulate ARGS --export-inp` (with `config` as its `--config` when
/// given), then stock `ccx` on the deck; returns the steps.csv header, the markers'
/// reference positions and both solvers' results per ramp pressure (CalculiX printing each
/// set once per pressure, in ramp order, is asserted).
pub fn simulate_and_calculix(
    args: &[&str],
    config: Option<&str>,
) -> (Vec<String>, Vec<[f64; 3]>, Vec<BothSolvers>) {
    assert_ccx_on_path();
    simulate_and_solve_with("ccx", args, config)
}

/// Stock ccx answers `ccx -v`.
fn assert_ccx_on_path() {
    let ccx = std::process::Command::new("ccx").arg("-v").output();
    assert!(
        ccx.is_ok_and(|o| String::from_utf8_lossy(&o.stdout).contains("2.")),
        "ccx (CalculiX, Debian package calculix-ccx) is not on PATH: run scripts/setup.sh (CI installs it)"
    );
}

/// [`simulate_and_calculix`] with ccx_peer, CalculiX 2.20 with the follower-pressure load
/// stiffness (`scripts/ccx-peer.sh`), for decks stock ccx gives up on: the same converged
/// answers where both converge.
pub fn simulate_and_calculix_peer(
    args: &[&str],
    config: Option<&str>,
) -> (Vec<String>, Vec<[f64; 3]>, Vec<BothSolvers>) {
    simulate_and_solve_with(ccx_peer(), args, config)
}

/// [`simulate_and_calculix_peer`] that also returns the deck's text.
pub fn simulate_and_calculix_peer_with_deck(
    args: &[&str],
    config: Option<&str>,
) -> (Vec<String>, Vec<[f64; 3]>, Vec<BothSolvers>, String) {
    simulate_and_solve_keeping_the_deck(ccx_peer(), args, config)
}

/// The ccx_peer binary `scripts/ccx-peer.sh` builds, asserted present.
fn ccx_peer() -> &'static str {
    let peer = concat!(env!("CARGO_MANIFEST_DIR"), "/target/ccx-peer/ccx_peer");
    assert!(
        std::path::Path::new(peer).is_file(),
        "{peer} is missing: run scripts/ccx-peer.sh (scripts/test.sh does)"
    );
    peer
}

/// [`simulate_and_calculix`] with the CalculiX binary `ccx`.
pub fn simulate_and_solve_with(
    ccx: &str,
    args: &[&str],
    config: Option<&str>,
) -> (Vec<String>, Vec<[f64; 3]>, Vec<BothSolvers>) {
    let (h, markers, steps, _) = simulate_and_solve_keeping_the_deck(ccx, args, config);
    (h, markers, steps)
}

/// [`simulate_and_calculix`] that also returns the deck's text.
pub fn simulate_and_calculix_with_deck(
    args: &[&str],
    config: Option<&str>,
) -> (Vec<String>, Vec<[f64; 3]>, Vec<BothSolvers>, String) {
    assert_ccx_on_path();
    simulate_and_solve_keeping_the_deck("ccx", args, config)
}

/// [`simulate_and_solve_with`] that also returns the deck's text.
fn simulate_and_solve_keeping_the_deck(
    ccx: &str,
    args: &[&str],
    config: Option<&str>,
) -> (Vec<String>, Vec<[f64; 3]>, Vec<BothSolvers>, String) {
    let dir = tempfile::tempdir().unwrap();
    let mut all: Vec<&str> = vec!["simulate", "--no-vtu", "--export-inp", "ccx/deck.inp"];
    all.extend_from_slice(&["-o", "fem"]);
    if let Some(text) = config {
        std::fs::write(dir.path().join("model.toml"), text).unwrap();
        all.extend_from_slice(&["--config", "model.toml"]);
    }
    all.extend_from_slice(args);
    let started = std::time::Instant::now();
    let run = Run::new(dir.path(), &all);
    let bendscope_s = started.elapsed().as_secs_f64();
    assert_eq!(run.code, 0, "{run}");
    let ccx_dir = dir.path().join("ccx");
    let started = std::time::Instant::now();
    let out = std::process::Command::new("timeout")
        .args(["900", ccx, "-i", "deck"])
        .env("OMP_NUM_THREADS", "1")
        .current_dir(&ccx_dir)
        .output()
        .unwrap();
    let ccx_s = started.elapsed().as_secs_f64();
    assert!(
        out.status.success() && !String::from_utf8_lossy(&out.stdout).contains("*ERROR"),
        "ccx failed: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    eprintln!("wall time: bendscope simulate {bendscope_s:.1} s, ccx {ccx_s:.1} s");
    let deck = std::fs::read_to_string(ccx_dir.join("deck.inp")).unwrap();
    let dat = std::fs::read_to_string(ccx_dir.join("deck.dat")).unwrap();
    let (nodes, markers) = deck_nodes_and_set(&deck, "MARKERS");
    let (_, tip) = deck_nodes_and_set(&deck, "TIP");
    let (_, twist) = deck_nodes_and_set(&deck, "TWIST");
    let (h, rows) = read_csv_numbers(&dir.path().join("fem/steps.csv"));
    let blocks = |set: &str| {
        let b = dat_displacements(&dat, set);
        assert_eq!(
            b.len(),
            rows.len(),
            "{set}: one print per ramp pressure: {dat}"
        );
        b
    };
    let (marker_blocks, tip_blocks, twist_blocks) =
        (blocks("MARKERS"), blocks("TIP"), blocks("TWIST"));
    let at = |id: usize, u: &std::collections::HashMap<usize, [f64; 3]>| {
        let (x, d) = (nodes[&id], u[&id]);
        [x[0] + d[0], x[1] + d[1], x[2] + d[2]]
    };
    let steps = rows
        .into_iter()
        .enumerate()
        .map(|(k, row)| BothSolvers {
            row,
            markers: markers.iter().map(|n| at(*n, &marker_blocks[k])).collect(),
            tip: at(tip[0], &tip_blocks[k]),
            twist_pair: [
                at(twist[0], &twist_blocks[k]),
                at(twist[1], &twist_blocks[k]),
            ],
        })
        .collect();
    (h, markers.iter().map(|n| nodes[n]).collect(), steps, deck)
}

/// Pratt radius (x-z plane) of CalculiX's markers and the tip's distance from bendscope's
/// (x-z), per pressure, printed; the radius is asserted within `radius_tol` and the tip
/// within `tip_mm`.
pub fn assert_radius_and_tip_agree(
    h: &[String],
    steps: &[BothSolvers],
    radius_tol: f64,
    tip_mm: f64,
) {
    for s in steps {
        let r_ccx = s.calculix_radius_mm();
        let r = s.row[col(h, "radius_mm")];
        let t = s.tip;
        let tip_gap = (t[0] - s.row[col(h, "tip_x_mm")]).hypot(t[2] - s.row[col(h, "tip_z_mm")]);
        eprintln!(
            "{} kPa: radius bendscope {r:.2} mm, CalculiX {r_ccx:.2} mm ({:+.2}%); tip apart {tip_gap:.3} mm",
            s.row[col(h, "pressure_kpa")],
            100.0 * (r_ccx / r - 1.0)
        );
        assert!(
            (r_ccx / r - 1.0).abs() < radius_tol,
            "radius {r_ccx} vs {r}"
        );
        assert!(tip_gap < tip_mm, "tip {t:?} vs {:?}", s.row);
    }
}

/// The markers' radius (Pratt, x-z) and the tip's deflection (-z, the tip on z = 0 at
/// rest) of both solvers at one pressure, printed and asserted within `tol` of each other;
/// returns bendscope's deflection, mm.
pub fn assert_radius_and_deflection_agree(h: &[String], s: &BothSolvers, tol: f64) -> f64 {
    let (r, r_ccx) = (s.row[col(h, "radius_mm")], s.calculix_radius_mm());
    let (d, d_ccx) = (-s.row[col(h, "tip_z_mm")], -s.tip[2]);
    eprintln!(
        "radius bendscope {r:.2} mm, CalculiX {r_ccx:.2} mm ({:+.2}%); tip deflection {d:.3} / {d_ccx:.3} mm ({:+.2}%)",
        100.0 * (r_ccx / r - 1.0),
        100.0 * (d_ccx / d - 1.0)
    );
    assert!((r_ccx / r - 1.0).abs() < tol, "radius {r_ccx} vs {r}");
    assert!(
        (d_ccx / d - 1.0).abs() < tol,
        "tip deflection {d_ccx} vs {d}"
    );
    d
}

/// The volume, mm³, that the first `*DLOAD`'s faces of a deck's C3D10 elements enclose
/// with the plane y = 0 (the half model's symmetry plane, which closes the cavity): the
/// divergence theorem with the field (0, y, 0), whose flux through y = 0 is nil, over
/// each face taken flat through its corners with the normal out of the cavity (into its
/// element). CalculiX's faces: F1 = 1-2-3, F2 = 1-4-2, F3 = 2-4-3, F4 = 3-4-1.
pub fn loaded_volume_mm3(deck: &str) -> f64 {
    const FACES: [[usize; 3]; 4] = [[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]];
    let (nodes, _) = deck_nodes_and_set(deck, "MARKERS");
    let block = |head: &str| -> Vec<Vec<&str>> {
        deck_block(deck, head)
            .into_iter()
            .map(|l| l.split(',').map(str::trim).collect())
            .collect()
    };
    let elements: std::collections::HashMap<usize, Vec<usize>> = block("*ELEMENT, TYPE=C3D10")
        .iter()
        .map(|v| {
            let ids: Vec<usize> = v.iter().map(|t| t.parse().unwrap()).collect();
            (ids[0], ids[1..].to_vec())
        })
        .collect();
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let mut volume = 0.0;
    for load in block("*DLOAD") {
        let element = &elements[&load[0].parse::<usize>().unwrap()];
        let face = FACES[load[1].trim_start_matches('P').parse::<usize>().unwrap() - 1];
        let p = face.map(|k| nodes[&element[k]]);
        let opposite = nodes[&element[6 - face.iter().sum::<usize>()]];
        let (e1, e2) = (sub(p[1], p[0]), sub(p[2], p[0]));
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let c = [0, 1, 2].map(|j| (p[0][j] + p[1][j] + p[2][j]) / 3.0);
        let d = sub(c, opposite);
        let out_of_cavity = if n[0] * d[0] + n[1] * d[1] + n[2] * d[2] > 0.0 {
            -1.0
        } else {
            1.0
        };
        volume += c[1] * out_of_cavity * n[1] / 2.0;
    }
    volume
}
