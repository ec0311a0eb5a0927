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
import math
import numbers
import os
import re
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
    "Study",
    "study",
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


_BOARD_FORM = "give the inner corners as (columns, rows) or 'COLSxROWS', e.g. board=(9, 6) or board='9x6'"


def _whole(value) -> Optional[int]:
    """``value`` as an int when it is a whole number >= 1 (an int, or digits), else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, numbers.Integral):
        n = int(value)
    elif isinstance(value, str) and value.strip().isdigit():
        n = int(value.strip())
    else:
        return None
    return n if n >= 1 else None


def _board(board) -> Tuple[int, int]:
    """(columns, rows) of inner corners from ``(9, 6)`` or the CLI's ``"9x6"``; any other
    form raises :class:`Error` naming the board and the forms."""
    if isinstance(board, str):
        parts = re.split(r"\s*[xX\u00d7]\s*", board.strip())
    else:
        try:
            parts = list(board)
        except TypeError:
            parts = []
    whole = [_whole(p) for p in parts]
    if len(whole) != 2 or None in whole:
        raise Error(f"board={board!r}: {_BOARD_FORM}")
    return whole[0], whole[1]


def calibrate(
    paths: Union[PathLike, Iterable[PathLike]],
    board: Union[Tuple[int, int], str] = (9, 6),
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
        board: inner corners (columns, rows), or the CLI's text ``"9x6"``; a
            10x7-square board has (9, 6).
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
    cols, rows = _board(board)
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
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


def _finite(value) -> Optional[float]:
    """``value`` as a float when it is a finite real number (not a bool), else None."""
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, str)):
        return None
    try:
        v = float(value)
    except ValueError:
        return None
    return v if math.isfinite(v) else None


def _pressures_text(pressures: Union[str, float, Sequence[float], None]) -> Optional[str]:
    """The pressures as the CLI's --pressures text: 'start:stop:step' or 'a,b,c'; an empty
    list or a value that is not a finite number raises :class:`Error` naming it."""
    if pressures is None:
        return None
    if isinstance(pressures, str):
        if not pressures.strip():
            raise Error("pressures='': empty: give at least one pressure in kPa, e.g. pressures=[20, 40] or '10:115:5'")
        return pressures
    if isinstance(pressures, numbers.Real) and not isinstance(pressures, bool):
        pressures = [pressures]
    try:
        values = list(pressures)
    except TypeError:
        raise Error(
            f"pressures={pressures!r}: give a list of kPa, e.g. pressures=[20, 40], or the CLI's text '10:115:5'"
        ) from None
    if not values:
        raise Error("pressures: empty list: give at least one pressure in kPa, e.g. pressures=[20, 40]")
    out = []
    for i, p in enumerate(values):
        v = _finite(p)
        if v is None:
            raise Error(f"pressures[{i}] = {p!r}: not a finite number: give pressures in kPa, e.g. pressures=[20, 40]")
        out.append(repr(v))
    return ",".join(out)


def _mesh_size(mesh_size) -> Optional[float]:
    """``mesh_size`` as a float, refused unless a finite number > 0 (the library bounds
    the number of cells it gives)."""
    if mesh_size is None:
        return None
    v = _finite(mesh_size)
    if v is None or v <= 0:
        raise Error(
            f"mesh_size={mesh_size!r}: give the largest element edge in mm, a finite number > 0, e.g. mesh_size=4 (coarse) or 1.5 (the default)"
        )
    return v


def _non_finite(value, path: str):
    """(key path, value) of every NaN or infinity in a config dict, e.g. ("geometry.b", nan)."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _non_finite(v, f"{path}.{k}" if path else str(k))
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            yield from _non_finite(v, f"{path}[{i}]")
    elif isinstance(value, numbers.Real) and not isinstance(value, bool):
        if not math.isfinite(float(value)):
            yield path, value


def _config_json(config: dict) -> str:
    """A config dict as JSON text; a NaN or infinity in it raises :class:`Error` naming
    its key (JSON has no such numbers, and a value present is never dropped)."""
    for path, value in _non_finite(config, ""):
        raise Error(
            f"the config dict's {path} = {float(value)!r}: not a finite number: give a number (see bendscope.default_config())"
        )
    return json.dumps(config)


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
        pressures: kPa, a list ``[10, 20]`` (or one number) or the CLI's text
            ``"10:115:5"``.
        mesh_size: largest element edge, mm, a finite number > 0 [default: 1.5].
        out: output folder [default: fem-out, as the CLI].
        blocked: also run the blocked-tip analysis (force.csv).
        vtu: write the VTK files (vtu/, actuator.pvd).
        progress: ``callback(stage, done, total)``, called per converged step.

    Returns:
        a :class:`Simulation`.

    Raises:
        Error: a bad config (a NaN or infinity in a config dict is named by its key),
            pressures (an empty list, a value that is not a finite number) or
            mesh_size, or no step converged.
    """
    out = Path("fem-out" if out is None else out)
    is_dict = isinstance(config, dict)
    pressures_text = _pressures_text(pressures)
    mesh_size_mm = _mesh_size(mesh_size)
    raw = json.loads(
        _native.simulate(
            os.fspath(out),
            _config_json(config) if is_dict else (None if config is None else os.fspath(config)),
            is_dict,
            pressures_text,
            mesh_size_mm,
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


@dataclass
class Study:
    """What :func:`study` wrote, read back from its folder.

    Attributes:
        out: the study folder (study.csv, repeatability.csv, fits.json, fem.csv,
            plots/, report.html).
        table: study.csv (per sample and pressure, then the pooled rows `all`: n and
            the mean, std, min and max of each quantity over the sessions).
        repeatability: repeatability.csv (coefficients of variation, %).
        fits: fits.json as a dict (power laws with confidence bands, FEM comparisons).
        fem: fem.csv, or None without simulations.
        summary: the lines the CLI prints.
        problems: warnings (sessions that disagree, samples of one session) and notes.
    """

    out: Path
    table: pd.DataFrame
    repeatability: pd.DataFrame
    fits: dict
    fem: Optional[pd.DataFrame]
    summary: str
    problems: list = field(default_factory=list)


def study(
    path_or_samples: Union[PathLike, dict],
    out: Optional[PathLike] = None,
    fem: Optional[Iterable[PathLike]] = None,
) -> Study:
    """Summarize several samples of several sessions, like ``bendscope study``.

    Args:
        path_or_samples: a study.toml, or a dict {sample name: [process output or
            session folders]}.
        out: study folder [default: study-out, as the CLI].
        fem: `bendscope simulate` output folders to compare with (with a dict; a
            study.toml lists its own).

    Raises:
        Error: the CLI's one-line error (unknown key, empty sample, missing
            per_video.csv, sessions of different actuators in one sample, ...).
    """
    out = Path("study-out" if out is None else out)
    fem_paths = None if fem is None else [os.fspath(f) for f in fem]
    if isinstance(path_or_samples, dict):
        samples = [
            (str(name), [os.fspath(p) for p in ([paths] if isinstance(paths, (str, os.PathLike)) else paths)])
            for name, paths in path_or_samples.items()
        ]
        raw = _native.study(os.fspath(out), None, samples, fem_paths)
    else:
        if fem is not None:
            raise Error("fem=: a study.toml lists its own simulations (fem = [...]): give fem with a dict of samples")
        raw = _native.study(os.fspath(out), os.fspath(path_or_samples), None, None)
    raw = json.loads(raw)
    return Study(
        out=out,
        table=pd.read_csv(out / "study.csv"),
        repeatability=pd.read_csv(out / "repeatability.csv"),
        fits=_json(out / "fits.json") or {},
        fem=_table(out / "fem.csv"),
        summary=raw["summary"],
        problems=["warning: " + w for w in raw["warnings"]] + ["note: " + n for n in raw["notes"]],
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
    if not isinstance(table, pd.DataFrame):
        raw = _material_fit(Path(table), out, model, nonnegative, None)
    else:
        if len(table) == 0:
            raise Error(
                f"the DataFrame is empty (columns {list(table.columns)}, no rows): give the stretch or strain and the nominal stress, e.g. columns stretch, stress_mpa"
            )
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "tensile.csv"
            table.to_csv(path, index=False)
            try:
                raw = _material_fit(path, out, model, nonnegative, _DATAFRAME)
            except Error as e:
                raise Error(_of_dataframe(str(e), path, table)) from None
            raw["warnings"] = [_of_dataframe(w, path, table) for w in raw["warnings"]]
    result = _json(out / "material_fit.json") or {}
    result["problems"] = ["warning: " + w for w in raw["warnings"]]
    if raw["refused"]:
        result["problems"].append("note: " + raw["refused"])
    result["out"] = out
    return result


# How a DataFrame given to material_fit is named in messages and in the outputs.
_DATAFRAME = "the DataFrame"


def _material_fit(path: Path, out: Path, model: str, nonnegative: bool, data_name: Optional[str]) -> dict:
    return json.loads(
        _native.material_fit(os.fspath(path), os.fspath(out), str(model), bool(nonnegative), data_name)
    )


def _of_dataframe(message: str, path: Path, table: pd.DataFrame) -> str:
    """A message about the temporary CSV a DataFrame was written to, said of the
    DataFrame: a data line becomes its row (index label), the header line its columns."""
    text = message.replace(str(path), _DATAFRAME)
    m = re.match(re.escape(_DATAFRAME) + r": line (\d+)", text)
    if not m:
        return text
    position = int(m.group(1)) - 2  # line 1 is the header, one line per row
    if position < 0:
        where = f"columns {list(table.columns)}"
    elif position < len(table):
        label = table.index[position]
        label = label.item() if hasattr(label, "item") else label  # numpy scalar -> int
        where = f"row {label!r}"
    else:
        return text
    return f"{_DATAFRAME}: {where}{text[m.end():]}"
