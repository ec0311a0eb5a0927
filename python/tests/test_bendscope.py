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
import sys
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


def test_study_matches_the_cli_and_its_per_video_tables(tmp_path):
    # Two runs of one sample: the example processed, and a copy 1 % larger in radius.
    r = bendscope.process(EXAMPLE, out=tmp_path / "run1")
    run2 = tmp_path / "run2"
    run2.mkdir()
    pv = pd.read_csv(r.out / "per_video.csv")
    pv["radius_mm"] = (pv["radius_mm"] * 1.01).round(4)
    pv.to_csv(run2 / "per_video.csv", index=False)
    py = bendscope.study({"A": [r.out, run2]}, out=tmp_path / "py")
    run = run_cli("study", "--sample", f"A={r.out},{run2}", "-o", tmp_path / "cli", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert_frames_close(py.table, pd.read_csv(tmp_path / "cli" / "study.csv"), SAME_RUN_TOLERANCE)
    # The mean radius of each pressure is the mean of the two runs' (one video each).
    measured = pd.read_csv(r.out / "per_video.csv")
    measured = measured[measured["status"] == "ok"]
    a = py.table[py.table["sample"] == "A"].reset_index(drop=True)
    assert list(a["n"]) == [2] * len(measured)
    for (_, row), r1, r2 in zip(a.iterrows(), measured["radius_mm"], pv.loc[measured.index, "radius_mm"]):
        assert abs(row["radius_mm_mean"] - (r1 + r2) / 2) <= 1e-9 * abs(r1)
    assert {f["sample"] for f in py.fits["fits"]} == {"A", "all"}
    with pytest.raises(bendscope.Error) as e:
        bendscope.study({"A": []}, out=tmp_path / "bad")
    assert "sample `A` has no session" in str(e.value)
    assert not (tmp_path / "bad").exists()


# ---------------------------------------------------------------- bad input, by name

@pytest.mark.parametrize(
    "board",
    ["9 by 6", "9x6x2", (9,), (9, 6, 1), (9.5, 6), (-9, 6), (0, 6), (True, 6), 96, None],
)
def test_a_board_in_another_form_is_named_with_the_forms(tmp_path, board):
    with pytest.raises(bendscope.Error) as e:
        bendscope.calibrate(EXAMPLE / "calib", board=board, out=tmp_path / "c.yaml")
    assert str(e.value) == f"board={board!r}: " + (
        "give the inner corners as (columns, rows) or 'COLSxROWS', e.g. board=(9, 6) or board='9x6'"
    )


def test_the_clis_board_text_is_taken(tmp_path):
    # "9x6" passes the board check: the error is then the missing views', not the board's.
    for board in ["9x6", " 9 X 6 ", ("9", "6"), [9, 6]]:
        with pytest.raises(bendscope.Error) as e:
            bendscope.calibrate(tmp_path / "no-views", board=board, out=tmp_path / "c.yaml")
        assert str(e.value) == f"{tmp_path / 'no-views'}: no such file or folder", (board, str(e.value))


@pytest.mark.parametrize(
    "section, key, value, shown",
    [
        ("geometry", "b", math.nan, "geometry.b = nan"),
        ("material", "c1", math.inf, "material.c1 = inf"),
        ("mesh", "size_mm", -math.inf, "mesh.size_mm = -inf"),
    ],
)
def test_a_nan_or_inf_in_a_config_dict_is_named_by_its_key(tmp_path, section, key, value, shown):
    cfg = bendscope.default_config()
    cfg[section][key] = value
    with pytest.raises(bendscope.Error) as e:
        bendscope.simulate(config=cfg, out=tmp_path / "fem", vtu=False)
    assert str(e.value) == (
        f"the config dict's {shown}: not a finite number: give a number (see bendscope.default_config())"
    )
    assert not (tmp_path / "fem").exists()


def test_a_nan_in_a_config_dicts_list_is_named_by_its_index(tmp_path):
    cfg = bendscope.default_config()
    cfg["load"]["gravity_direction"] = [math.nan, 0.0, 0.0]
    with pytest.raises(bendscope.Error, match=r"^the config dict's load\.gravity_direction\[0\] = nan: "):
        bendscope.simulate(config=cfg, out=tmp_path / "fem", vtu=False)


@pytest.mark.parametrize(
    "pressures, message",
    [
        ([], "pressures: empty list: give at least one pressure in kPa, e.g. pressures=[20, 40]"),
        ((), "pressures: empty list: give at least one pressure in kPa, e.g. pressures=[20, 40]"),
        ("", "pressures='': empty: give at least one pressure in kPa, e.g. pressures=[20, 40] or '10:115:5'"),
        ([20, math.nan], "pressures[1] = nan: not a finite number: give pressures in kPa, e.g. pressures=[20, 40]"),
        ([math.inf], "pressures[0] = inf: not a finite number: give pressures in kPa, e.g. pressures=[20, 40]"),
        ([20, "forty"], "pressures[1] = 'forty': not a finite number: give pressures in kPa, e.g. pressures=[20, 40]"),
        ([None], "pressures[0] = None: not a finite number: give pressures in kPa, e.g. pressures=[20, 40]"),
    ],
)
def test_bad_pressures_are_named_as_given(tmp_path, pressures, message):
    with pytest.raises(bendscope.Error) as e:
        bendscope.simulate(pressures=pressures, mesh_size=4, out=tmp_path / "fem", vtu=False)
    assert str(e.value) == message


@pytest.mark.parametrize("mesh_size", [0, -1.5, math.nan, math.inf, "fine"])
def test_a_mesh_size_that_is_no_positive_number_is_refused(tmp_path, mesh_size):
    with pytest.raises(bendscope.Error) as e:
        bendscope.simulate(pressures=[20], mesh_size=mesh_size, out=tmp_path / "fem", vtu=False)
    assert str(e.value).startswith(f"mesh_size={mesh_size!r}: give the largest element edge in mm, a finite number > 0")


# Address space the child running a tiny mesh size gets: an allocation the library did not
# bound then aborts the child (as it would kill a notebook kernel), not this test run.
CHILD_ADDRESS_SPACE_BYTES = 3 << 30


def test_a_tiny_mesh_size_raises_instead_of_killing_the_interpreter(tmp_path):
    # 1e-9 mm is positive and finite: the library's bound on the mesh's cells refuses it.
    code = f"""
import resource
import bendscope
resource.setrlimit(resource.RLIMIT_AS, ({CHILD_ADDRESS_SPACE_BYTES}, {CHILD_ADDRESS_SPACE_BYTES}))
try:
    bendscope.simulate(pressures=[20], mesh_size=1e-9, out={str(tmp_path / 'fem')!r}, vtu=False)
    print("returned")
except bendscope.Error as e:
    print("Error:", e)
"""
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, (run.returncode, run.stderr[-2000:])
    assert run.stdout.startswith("Error:"), run.stdout
    assert "mesh" in run.stdout.lower(), run.stdout


def test_a_nan_in_a_config_file_is_refused_by_its_key(tmp_path):
    # A TOML file reaches the library as written: its check names the key.
    bad = tmp_path / "bnan.toml"
    bad.write_text("[geometry]\nb = nan\n")
    with pytest.raises(bendscope.Error) as e:
        bendscope.simulate(config=bad, pressures=[20], mesh_size=4, out=tmp_path / "fem", vtu=False)
    assert re.search(r"\bb\b", str(e.value)) and "nan" in str(e.value).lower(), str(e.value)
    assert not (tmp_path / "fem" / "steps.csv").exists()


def test_material_fit_errors_name_the_dataframes_row_and_column(tmp_path):
    stretch = [1.0 + 0.05 * i for i in range(1, 8)]
    good = pd.DataFrame({"stretch": stretch, "stress_mpa": [0.1 * (l - l**-2) for l in stretch]})
    nan = good.copy()
    nan.loc[2, "stretch"] = math.nan
    with pytest.raises(bendscope.Error) as e:
        bendscope.material_fit(nan, out=tmp_path / "fit")
    assert str(e.value) == "the DataFrame: row 2, column stretch: empty cell: give a number"
    # Index labels, not positions.
    labelled = nan.set_axis([f"s{i}" for i in range(len(nan))])
    with pytest.raises(bendscope.Error) as e:
        bendscope.material_fit(labelled, out=tmp_path / "fit")
    assert str(e.value).startswith("the DataFrame: row 's2', column stretch: ")
    # The header: the columns, not a file.
    with pytest.raises(bendscope.Error) as e:
        bendscope.material_fit(good.rename(columns={"stretch": "x"}), out=tmp_path / "fit")
    assert str(e.value).startswith("the DataFrame: columns ['x', 'stress_mpa']: no stretch or strain column"), str(e.value)
    for message in [str(e.value)]:
        assert "tensile.csv" not in message and "tmp" not in message
    # Too few rows for the model: the DataFrame, not a temporary file.
    with pytest.raises(bendscope.Error) as e:
        bendscope.material_fit(good.head(2), model="yeoh3", out=tmp_path / "fit")
    assert str(e.value).startswith("the DataFrame: material fit: 2 points for 3 coefficient(s)"), str(e.value)
    # The fit's own file names the DataFrame too.
    bendscope.material_fit(good, model="neo-hookean", out=tmp_path / "ok")
    assert "tensile.csv" not in (tmp_path / "ok" / "material.toml").read_text()
    assert json.loads((tmp_path / "ok" / "material_fit.json").read_text())["data"] == "the DataFrame"


def test_material_fit_of_an_empty_dataframe_says_so(tmp_path):
    for empty, columns in [(pd.DataFrame(), "[]"), (pd.DataFrame({"stretch": [], "stress_mpa": []}), "['stretch', 'stress_mpa']")]:
        with pytest.raises(bendscope.Error) as e:
            bendscope.material_fit(empty, out=tmp_path / "fit")
        assert str(e.value) == (
            f"the DataFrame is empty (columns {columns}, no rows): give the stretch or strain and the nominal stress, e.g. columns stretch, stress_mpa"
        )
