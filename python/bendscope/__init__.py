"""bendscope: measure soft pneumatic bending actuators from video, from Python.

A thin layer over the Rust library (the native module ``bendscope._native``): each
function does what the CLI command of the same name does, writes the same output
folder, and reads that folder's tables into pandas DataFrames (the same columns as the
CSV files). Nothing is measured or computed here.

    >>> import bendscope
    >>> r = bendscope.process("fixtures/sessions/example")
    >>> r.per_video[["pressure_kpa", "radius_mm_mean"]]

Errors raise :class:`bendscope.Error` (a ``ValueError``) with the CLI's one-line
message. Long calls release the GIL; ``progress=callback`` is called as
``callback(what, done, total)`` (``what`` names the stage), e.g. with tqdm::

    from tqdm import tqdm
    bar = tqdm()
    def progress(what, done, total):
        bar.set_description(what); bar.total = total; bar.n = done; bar.refresh()

The library has no cancellation hook: a Ctrl-C during a call (or an exception the
callback raises) is raised when the call returns. A run stopped by killing Python is
simply run again: ``process`` reuses the videos already measured.
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Optional, Sequence, Tuple, Union

import pandas as pd

from . import _native
from ._native import Error

__all__ = [
    "Error",
    "ProcessResult",
    "Simulation",
    "Comparison",
    "process",
    "calibrate",
    "simulate",
    "default_config",
    "compare",
    "material_fit",
]

PathLike = Union[str, "os.PathLike[str]"]
Progress = Callable[[str, int, int], None]


def _table(path: Path) -> Optional[pd.DataFrame]:
    """The CSV at ``path`` as a DataFrame, or None when the file does not exist."""
    return pd.read_csv(path) if path.is_file() else None


def _json(path: Path) -> Optional[dict]:
    """The JSON file at ``path``, or None when it does not exist."""
    if not path.is_file():
        return None
    with open(path, encoding="utf-8") as f:
        return json.load(f)


@dataclass
class ProcessResult:
    """What :func:`process` measured, read back from its output folder.

    Attributes:
        out: the output folder (per_frame.csv, per_video.csv, fit.json, plots/,
            report.html, ...).
        per_video: per_video.csv, one row per video (or pressure bin of a ramp).
        per_frame: per_frame.csv, one row per frame; None when the file is absent.
        markers: markers.csv (marker positions per frame) when the output folder holds
            one, else None (bendscope versions that do not write it).
        per_segment: per_segment.csv (segmented actuators) when the output folder
            holds one, else None.
        fits: fit.json as a dict (power-law fits of radius, curvature and angle vs
            pressure); empty when absent.
        measured: items (videos, or the ramp / RGB-D recording) measured.
        failed: items that failed or were skipped (their reasons are in per_video's
            status column and in ``problems``).
        problems: the warnings and notes the CLI prints on stderr, one line each.
        scale: how the scale (mm per px) was obtained, as the CLI prints it; None for
            RGB-D sessions.
    """

    out: Path
    per_video: pd.DataFrame
    per_frame: Optional[pd.DataFrame]
    markers: Optional[pd.DataFrame]
    per_segment: Optional[pd.DataFrame]
    fits: dict
    measured: int
    failed: int
    problems: list = field(default_factory=list)
    scale: Optional[str] = None


def process(
    session: PathLike,
    out: Optional[PathLike] = None,
    calibration: Optional[PathLike] = None,
    config: Optional[PathLike] = None,
    force: bool = False,
    progress: Optional[Progress] = None,
) -> ProcessResult:
    """Measure a session folder, like ``bendscope process SESSION``.

    Args:
        session: the session folder (pressures.csv and one video per pressure, or
            pressure_log.csv and one video, or an RGB-D folder; scale.jpg; calib/).
        out: output folder [default: SESSION/bendscope-out].
        calibration: calibration YAML to use (else the session's setting, else calib/
            is calibrated and cached in OUT).
        config: settings file [default: SESSION/bendscope.toml when present].
        force: reprocess videos whose cached results are current.
        progress: ``callback(what, done, total)``, called as work advances.

    Returns:
        a :class:`ProcessResult` with the tables of the output folder. A session where
        nothing could be measured still returns (``measured == 0``, the reasons in
        ``per_video.status`` and ``problems``), as the CLI writes its tables too.

    Raises:
        Error: the session cannot be measured at all (bad layout, manifest,
            calibration, scale photo, OUT in use, disk full), with the CLI's message
            ``SESSION: what is wrong and what to do``.
    """
    raw = json.loads(
        _native.process(
            os.fspath(session),
            None if out is None else os.fspath(out),
            None if calibration is None else os.fspath(calibration),
            None if config is None else os.fspath(config),
            bool(force),
            progress,
        )
    )
    folder = Path(raw["out"])
    return ProcessResult(
        out=folder,
        per_video=pd.read_csv(folder / "per_video.csv"),
        per_frame=_table(folder / "per_frame.csv"),
        markers=_table(folder / "markers.csv"),
        per_segment=_table(folder / "per_segment.csv"),
        fits=_json(folder / "fit.json") or {},
        measured=raw["measured"],
        failed=raw["failed"],
        problems=list(raw["notes"]),
        scale=raw["scale"],
    )


def calibrate(
    paths: Union[PathLike, Iterable[PathLike]],
    board: Tuple[int, int] = (9, 6),
    square_mm: float = 25,
    model: str = "fisheye",
    out: Optional[PathLike] = None,
    force: bool = False,
    progress: Optional[Progress] = None,
) -> dict:
    """Calibrate a camera from checkerboard views, like ``bendscope calibrate``.

    Args:
        paths: images, folders of images or videos of a checkerboard (one path or
            several); 20 frames are sampled evenly from each video.
        board: inner corners (columns, rows); a 10x7-square board has (9, 6).
        square_mm: side of one square, mm.
        model: "fisheye" (GoPro, Kannala-Brandt) or "pinhole" (5 Brown coefficients).
        out: YAML file to write [default: calibration/<folder-or-camera-name>.yaml].
        force: replace the default output even when it holds another camera's
            calibration.
        progress: ``callback(what, done, total)``, called per view searched.

    Returns:
        dict with ``model``, ``image_width``, ``image_height``, ``camera_matrix``
        (3x3 nested list, px), ``distortion`` (fisheye k1..k4; pinhole k1 k2 p1 p2
        k3), ``rms_px`` (RMS reprojection error), ``per_view_rms_px``, ``views_used``
        (names), ``views_rejected`` (name and reason each) and ``path`` (the YAML
        file written).

    Raises:
        Error: no views, no board found in enough views, bad board size, ...
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    cols, rows = board
    raw = json.loads(
        _native.calibrate(
            [os.fspath(p) for p in paths],
            int(cols),
            int(rows),
            float(square_mm),
            str(model),
            None if out is None else os.fspath(out),
            bool(force),
            progress,
        )
    )
    raw["path"] = Path(raw["path"])
    return raw


@dataclass
class Simulation:
    """What :func:`simulate` computed, read back from its output folder.

    Attributes:
        out: the output folder (steps.csv, markers.csv, side_face.json, vtu/,
            plots/, config.toml, summary.json).
        steps: steps.csv, one row per converged pressure step.
        markers: markers.csv, the simulated markers' x, z per step (None if absent).
        force: force.csv of the blocked-tip analysis, when asked for, else None.
        summary: summary.json as a dict (nodes, dofs, Newton iterations, seconds,
            failure, notes, warnings).
        problems: warnings and notes (the CLI's stderr lines), and the failure when the
            ramp stopped early (the converged steps are kept).
    """

    out: Path
    steps: pd.DataFrame
    markers: Optional[pd.DataFrame]
    force: Optional[pd.DataFrame]
    summary: dict
    problems: list = field(default_factory=list)


def _pressures_text(pressures: Union[str, Sequence[float], None]) -> Optional[str]:
    """The pressures as the CLI's --pressures text: 'start:stop:step' or 'a,b,c'."""
    if pressures is None or isinstance(pressures, str):
        return pressures
    return ",".join(repr(float(p)) for p in pressures)


def simulate(
    config: Union[PathLike, dict, None] = None,
    pressures: Union[str, Sequence[float], None] = None,
    mesh_size: Optional[float] = None,
    out: Optional[PathLike] = None,
    blocked: bool = False,
    vtu: bool = True,
    progress: Optional[Progress] = None,
) -> Simulation:
    """Simulate the actuator with the finite-element model, like ``bendscope simulate``.

    Args:
        config: actuator TOML file, or a dict such as :func:`default_config` returns
            (edited) [default: the reference actuator].
        pressures: kPa, a list ``[10, 20]`` or the CLI's text ``"10:115:5"``.
        mesh_size: largest element edge, mm [default: 1.5].
        out: output folder [default: fem-out, as the CLI].
        blocked: also run the blocked-tip analysis (force.csv).
        vtu: write the VTK files (vtu/, actuator.pvd).
        progress: ``callback(stage, done, total)``, called per converged step.

    Returns:
        a :class:`Simulation`.

    Raises:
        Error: a bad config or pressures, or no step converged.
    """
    out = Path("fem-out" if out is None else out)
    is_dict = isinstance(config, dict)
    raw = json.loads(
        _native.simulate(
            os.fspath(out),
            json.dumps(config) if is_dict else (None if config is None else os.fspath(config)),
            is_dict,
            _pressures_text(pressures),
            None if mesh_size is None else float(mesh_size),
            bool(blocked),
            bool(vtu),
            progress,
        )
    )
    summary = raw["summary"]
    problems = ["warning: " + w for w in raw["config_warnings"]]
    problems += ["note: " + n for n in summary.get("notes", [])]
    problems += ["warning: " + w for w in summary.get("warnings", [])]
    if raw["failure"]:
        problems.append("error: " + raw["failure"])
    return Simulation(
        out=out,
        steps=pd.read_csv(out / "steps.csv"),
        markers=_table(out / "markers.csv"),
        force=_table(out / "force.csv"),
        summary=summary,
        problems=problems,
    )


def default_config(family: str = "pneunets") -> dict:
    """The default actuator config as a dict (``bendscope simulate --print-config``).

    Edit it and pass it to :func:`simulate` (``config=``). Sections: geometry (mm,
    method.md section 4 names), material, mesh, load (pressures_kpa, gravity), solver.

    Args:
        family: the actuator family: "pneunets" (the reference PneuNets actuator),
            "glove" (Ecoflex 00-50 with a paper layer) or "strap" (Ecoflex 00-30 with
            PLA strips and a fabric sheet, hanging).

    Raises:
        Error: an unknown family.
    """
    return json.loads(_native.default_config(family))


@dataclass
class Comparison:
    """What :func:`compare` found, read back from its report folder.

    Attributes:
        out: the report folder (compare.csv, summary.txt, compare.json, plots/).
        table: compare.csv (NAME_measured, NAME_fem, NAME_deviation on the common
            pressure grid); None when no quantity could be compared.
        results: compare.json as a dict.
        summary: the text of summary.txt.
        problems: quantities that could not be compared (warnings) and rows left out
            of the fits (notes).
        compared: number of quantities compared.
    """

    out: Path
    table: Optional[pd.DataFrame]
    results: dict
    summary: str
    problems: list
    compared: int


def compare(
    measured: PathLike,
    fem: PathLike,
    force: Optional[PathLike] = None,
    out: Optional[PathLike] = None,
) -> Comparison:
    """Compare a measurement with a simulation, like ``bendscope compare``.

    Args:
        measured: the output folder of :func:`process` (per_video.csv), or its
            :class:`ProcessResult`.
        fem: the output folder of :func:`simulate` (steps.csv), or its
            :class:`Simulation`.
        force: measured blocked force, CSV with pressure_kpa and force_g columns.
        out: report folder [default: compare-out, as the CLI].

    Deviation = simulated - measured (each curve fitted with y = a p^b + c first).

    Raises:
        Error: a folder lacks its table, or the tables cannot be read.
    """
    measured = measured.out if isinstance(measured, ProcessResult) else measured
    fem = fem.out if isinstance(fem, Simulation) else fem
    out = Path("compare-out" if out is None else out)
    raw = json.loads(
        _native.compare(
            os.fspath(measured),
            os.fspath(fem),
            os.fspath(out),
            None if force is None else os.fspath(force),
        )
    )
    return Comparison(
        out=out,
        table=_table(out / "compare.csv"),
        results=_json(out / "compare.json") or {},
        summary=raw["summary"],
        problems=["warning: " + w for w in raw["warnings"]]
        + ["note: " + n for n in raw["notes"]],
        compared=raw["compared"],
    )


def material_fit(
    table: Union[PathLike, pd.DataFrame],
    model: str = "yeoh3",
    nonnegative: bool = False,
    out: Optional[PathLike] = None,
) -> dict:
    """Fit a hyperelastic model to uniaxial tensile data, like ``bendscope material fit``.

    Args:
        table: CSV file, or a DataFrame with the same columns: the stretch
            (``stretch``) or strain (``strain``, ``strain_pct``) and the nominal stress
            with its unit (``stress_mpa``, ``stress_kpa``, ``stress_pa``,
            ``stress_psi``).
        model: "yeoh3", "yeoh2", "neo-hookean" or "mooney-rivlin2".
        nonnegative: hold every coefficient at zero or above.
        out: output folder [default: material-fit, as the CLI] (material.toml,
            material_fit.json, material_fit.csv, plots/).

    Returns:
        material_fit.json as a dict, plus ``problems`` (the data's warnings, and why no
        material.toml was written if so) and ``out``.

    Raises:
        Error: the table cannot be read or the fit fails.
    """
    out = Path("material-fit" if out is None else out)
    with tempfile.TemporaryDirectory() as tmp:
        if isinstance(table, pd.DataFrame):
            path = Path(tmp) / "tensile.csv"
            table.to_csv(path, index=False)
        else:
            path = Path(table)
        raw = json.loads(
            _native.material_fit(os.fspath(path), os.fspath(out), str(model), bool(nonnegative))
        )
    result = _json(out / "material_fit.json") or {}
    result["problems"] = ["warning: " + w for w in raw["warnings"]]
    if raw["refused"]:
        result["problems"].append("note: " + raw["refused"])
    result["out"] = out
    return result
