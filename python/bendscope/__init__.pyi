"""Type stubs of the bendscope package (see __init__.py for the docstrings)."""

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable, Optional, Sequence, Tuple, Union

import pandas as pd

PathLike = Union[str, os.PathLike[str]]
Progress = Callable[[str, int, int], None]

class Error(ValueError):
    """Bad input or a failed run; the message is the CLI's one-line error."""

@dataclass
class ProcessResult:
    out: Path
    per_video: pd.DataFrame
    per_frame: Optional[pd.DataFrame]
    markers: Optional[pd.DataFrame]
    per_segment: Optional[pd.DataFrame]
    fits: dict
    measured: int
    failed: int
    problems: list[str]
    scale: Optional[str]

@dataclass
class Simulation:
    out: Path
    steps: pd.DataFrame
    markers: Optional[pd.DataFrame]
    force: Optional[pd.DataFrame]
    summary: dict
    problems: list[str]

@dataclass
class Comparison:
    out: Path
    table: Optional[pd.DataFrame]
    results: dict
    summary: str
    problems: list[str]
    compared: int

@dataclass
class Study:
    out: Path
    table: pd.DataFrame
    repeatability: pd.DataFrame
    fits: dict
    fem: Optional[pd.DataFrame]
    summary: str
    problems: list[str]

def process(
    session: PathLike,
    out: Optional[PathLike] = None,
    calibration: Optional[PathLike] = None,
    config: Optional[PathLike] = None,
    force: bool = False,
    progress: Optional[Progress] = None,
) -> ProcessResult: ...
def calibrate(
    paths: Union[PathLike, Iterable[PathLike]],
    board: Union[Tuple[int, int], str] = (9, 6),
    square_mm: float = 25,
    model: str = "fisheye",
    out: Optional[PathLike] = None,
    force: bool = False,
    progress: Optional[Progress] = None,
) -> dict: ...
def simulate(
    config: Union[PathLike, dict, None] = None,
    pressures: Union[str, float, Sequence[float], None] = None,
    mesh_size: Optional[float] = None,
    out: Optional[PathLike] = None,
    blocked: bool = False,
    vtu: bool = True,
    progress: Optional[Progress] = None,
) -> Simulation: ...
def default_config(family: str = "pneunets") -> dict: ...
def compare(
    measured: Union[PathLike, ProcessResult],
    fem: Union[PathLike, Simulation],
    force: Optional[PathLike] = None,
    out: Optional[PathLike] = None,
) -> Comparison: ...
def study(
    path_or_samples: Union[PathLike, dict[str, Union[PathLike, Sequence[PathLike]]]],
    out: Optional[PathLike] = None,
    fem: Optional[Iterable[PathLike]] = None,
) -> Study: ...
def material_fit(
    table: Union[PathLike, pd.DataFrame],
    model: str = "yeoh3",
    nonnegative: bool = False,
    out: Optional[PathLike] = None,
) -> dict: ...
