"""The Python package against the CLI built from the same tree, and against the example
session's ground truth (fixtures/sessions/example/truth.json).

The CLI is ``$BENDSCOPE_BIN`` when set, else ``$CARGO_TARGET_DIR/debug/bendscope``
(``target/debug/bendscope`` without CARGO_TARGET_DIR); scripts/test-python.sh builds it.
"""

import json
import math
import os
import re
import subprocess
from pathlib import Path

import pandas as pd
import pytest

import bendscope

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "fixtures" / "sessions" / "example"
# per_video.csv: the package and the CLI run the same code on the same files.
SAME_RUN_TOLERANCE = 1e-9
# The example's calibration: fx, fy, cx, cy within 0.2% of the camera that rendered it
# (measured: 0.036% at most).
INTRINSICS_TOLERANCE = 0.002
# Radius vs the rendered truth, as tests/process.rs (RADIUS_TOLERANCE; measured 0.12%).
RADIUS_TOLERANCE = 0.005


def cli() -> Path:
    if "BENDSCOPE_BIN" in os.environ:
        return Path(os.environ["BENDSCOPE_BIN"])
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return target / "debug" / "bendscope"


def run_cli(*args, cwd):
    return subprocess.run(
        [str(cli()), *map(str, args)], cwd=cwd, capture_output=True, text=True
    )


def assert_frames_close(a: pd.DataFrame, b: pd.DataFrame, tol: float):
    assert list(a.columns) == list(b.columns)
    assert len(a) == len(b)
    for c in a.columns:
        if pd.api.types.is_numeric_dtype(a[c]) and pd.api.types.is_numeric_dtype(b[c]):
            for x, y in zip(a[c], b[c]):
                if isinstance(x, float) and math.isnan(x):
                    assert isinstance(y, float) and math.isnan(y), c
                else:
                    assert abs(x - y) <= tol * max(1.0, abs(y)), (c, x, y)
        else:
            assert list(a[c].astype(str)) == list(b[c].astype(str)), c


def test_process_matches_the_cli(tmp_path):
    calls = []
    r = bendscope.process(EXAMPLE, out=tmp_path / "py", progress=lambda *a: calls.append(a))
    run = run_cli("process", EXAMPLE, "-o", tmp_path / "cli", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    expected = pd.read_csv(tmp_path / "cli" / "per_video.csv")
    assert_frames_close(r.per_video, expected, SAME_RUN_TOLERANCE)
    assert r.measured == 5 and r.failed == 0
    assert list(r.per_video["status"]) == ["ok"] * 5
    # Ground truth: every video's radius within 0.5% of the rendered one.
    truth = json.loads((EXAMPLE / "truth.json").read_text())
    for v in truth["videos"]:
        row = r.per_video[r.per_video["file"] == v["file"]].iloc[0]
        assert abs(row["radius_mm"] / v["radius_mm"] - 1) < RADIUS_TOLERANCE, (v["file"], row["radius_mm"])
    assert len(r.per_frame) == 5 * 8
    assert r.fits["radius_mm_vs_kpa"]["r_squared"] > 0.999
    assert r.out == tmp_path / "py"
    # Files this version may or may not write are None when absent.
    for name, table in [("markers.csv", r.markers), ("per_segment.csv", r.per_segment)]:
        assert (table is None) == (not (r.out / name).is_file())
    # Progress: (what, done, total) with done reaching total in some stage.
    assert calls and all(isinstance(w, str) and 0 <= d <= t for w, d, t in calls)
    assert any(d == t and t > 0 for _, d, t in calls)


def test_bad_session_raises_the_cli_message(tmp_path):
    missing = tmp_path / "no-such-session"
    run = run_cli("process", missing, "-o", tmp_path / "cli", cwd=tmp_path)
    assert run.returncode == 2
    line = run.stderr.strip()
    assert line.startswith("error: ") and "\n" not in line
    with pytest.raises(bendscope.Error) as e:
        bendscope.process(missing, out=tmp_path / "py")
    assert str(e.value) == line[len("error: "):]
    assert isinstance(e.value, ValueError)
    assert "no such session folder" in str(e.value)
    # The session's path once, not twice.
    assert str(e.value).count(str(missing)) == 1


def test_bad_simulate_config_raises_the_cli_message(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[geometry]\nchambers = -3\n")
    run = run_cli("simulate", "--config", bad, "-o", tmp_path / "cli", cwd=tmp_path)
    assert run.returncode == 2
    with pytest.raises(bendscope.Error) as e:
        bendscope.simulate(config=bad, out=tmp_path / "py")
    assert str(e.value) == run.stderr.strip()[len("error: "):]


def test_simulate_matches_the_cli(tmp_path):
    calls = []
    sim = bendscope.simulate(
        pressures=[20, 40], mesh_size=4, out=tmp_path / "py", vtu=False,
        progress=lambda *a: calls.append(a),
    )
    # One call per converged step.
    assert [(d, t) for _, d, t in calls] == [(1, 2), (2, 2)]
    run = run_cli(
        "simulate", "--pressures", "20,40", "--mesh-size", 4, "--no-vtu",
        "-o", tmp_path / "cli", cwd=tmp_path,
    )
    assert run.returncode == 0, run.stderr
    expected = pd.read_csv(tmp_path / "cli" / "steps.csv")
    assert list(sim.steps["pressure_kpa"]) == [20.0, 40.0]
    assert_frames_close(sim.steps, expected, SAME_RUN_TOLERANCE)
    assert sim.markers is not None and len(sim.markers) > 0
    assert sim.summary["steps_converged"] == 2
    # The actuator bends more at 40 kPa than at 20 kPa.
    assert sim.steps["bending_angle_deg"].iloc[1] > sim.steps["bending_angle_deg"].iloc[0] > 0


def test_default_config_round_trips_through_simulate(tmp_path):
    cfg = bendscope.default_config()
    assert cfg["mesh"]["size_mm"] == 1.5
    cfg["load"]["pressures_kpa"] = "30"
    cfg["mesh"]["size_mm"] = 4.0
    sim = bendscope.simulate(config=cfg, out=tmp_path / "fem", vtu=False)
    assert list(sim.steps["pressure_kpa"]) == [30.0]
    with pytest.raises(bendscope.Error, match="unknown actuator family 'no-such-family'"):
        bendscope.default_config("no-such-family")
    glove = bendscope.default_config("glove")
    assert glove["geometry"]["family"] == "glove"
    assert [layer["name"] for layer in glove["layer"]] == ["paper"]
    assert glove["layer"][0]["youngs_modulus_mpa"] == 3000.0


def test_calibrate_matches_the_cli_and_the_camera(tmp_path):
    calls = []
    c = bendscope.calibrate(
        EXAMPLE / "calib", out=tmp_path / "py.yaml", progress=lambda *a: calls.append(a)
    )
    # One call per view, from the threads that search them.
    views_given = len(list((EXAMPLE / "calib").iterdir()))
    assert sorted(d for _, d, _ in calls) == list(range(1, views_given + 1))
    assert all(w == "finding corners" and t == views_given for w, _, t in calls)
    run = run_cli("calibrate", EXAMPLE / "calib", "-o", tmp_path / "cli.yaml", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    rms = float(re.search(r"RMS reprojection error = ([0-9.]+) px", run.stdout).group(1))
    assert abs(c["rms_px"] - rms) <= 5e-5  # the CLI prints 4 decimals
    views = int(re.search(r"from (\d+) view", run.stdout).group(1))
    assert len(c["views_used"]) == views
    assert len(c["views_used"]) + len(c["views_rejected"]) == views_given
    assert c["rms_px"] < 1.0
    k = json.loads((EXAMPLE / "truth.json").read_text())["camera"]["k"]
    for (r, col) in [(0, 0), (1, 1), (0, 2), (1, 2)]:
        got = c["camera_matrix"][r][col]
        assert abs(got / k[r][col] - 1) < INTRINSICS_TOLERANCE, (r, col, got, k[r][col])
    assert c["path"].is_file()
    with pytest.raises(bendscope.Error):
        bendscope.calibrate(EXAMPLE / "calib", board=(1, 6), out=tmp_path / "bad.yaml")


def test_material_fit_recovers_a_neo_hookean_table(tmp_path):
    # Incompressible uniaxial neo-Hookean: nominal stress P = 2 C1 (l - l^-2), C1 = 0.05 MPa.
    c1_mpa = 0.05
    stretch = [1.0 + 0.05 * i for i in range(1, 21)]
    table = pd.DataFrame(
        {"stretch": stretch, "stress_mpa": [2 * c1_mpa * (l - l**-2) for l in stretch]}
    )
    fit = bendscope.material_fit(table, model="neo-hookean", out=tmp_path / "fit")
    (c1,) = fit["parameters"].values()
    assert abs(c1 / c1_mpa - 1) < 1e-6, c1
    assert (tmp_path / "fit" / "material_fit.csv").is_file()
    with pytest.raises(bendscope.Error):
        bendscope.material_fit(tmp_path / "missing.csv", out=tmp_path / "bad")


def test_compare_matches_the_cli(tmp_path):
    r = bendscope.process(EXAMPLE, out=tmp_path / "out")
    sim = bendscope.simulate(pressures=[20, 50, 80], mesh_size=4, out=tmp_path / "fem", vtu=False)
    py = bendscope.compare(r, sim, out=tmp_path / "py")
    run = run_cli(
        "compare", "--measured", r.out, "--fem", sim.out, "-o", tmp_path / "cli", cwd=tmp_path
    )
    assert run.returncode == 0, run.stderr
    assert py.compared > 0 and py.table is not None
    assert_frames_close(py.table, pd.read_csv(tmp_path / "cli" / "compare.csv"), SAME_RUN_TOLERANCE)
    assert py.summary == (tmp_path / "cli" / "summary.txt").read_text()
