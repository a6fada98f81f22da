"""rover-power from Python: runs as pandas DataFrames; validation, diagnosis and planning.

The work is done by the host tool's own Rust library (the same calls as the ``host-tool``
command line), so ``validate``, ``diagnose`` and ``plan`` return exactly what the command's
``--json`` writes, as a dict::

    import rover_power as rp

    df = rp.read_run("demo-out/run-1.mcap")        # one row per sample, indexed by t_s
    report = rp.diagnose(None, ["demo-out/run-1.mcap", "demo-out/run-2.mcap"])
    print(report["effect"], report["regime"])
    print(rp.plan(90, 90, 10)["delta_e_pct"])

Units and signs are the run CSV's (docs/formats.md, "Run CSV"): time in s, bus voltage in V,
current in A (positive drawn from the battery), commanded side speeds in m/s, yaw in rad
(counter-clockwise positive), pitch in degrees (nose-up positive), the tracked point in m.

Errors are ``RoverPowerError`` with the command line's message (file, line and column where
there is one). What reading a run log found (a file cut short, a damaged stretch left out) is a
``RoverPowerWarning``; data lost to damage is an error unless ``salvage=True``, as the command
line's exit code 4 is unless ``--salvage``. A path that is not a regular file (a directory,
a FIFO, a device such as ``/dev/urandom``) is refused with a ``RoverPowerError`` naming it,
before anything is read: reading a FIFO waits for a writer, and a device may never end.
"""

from __future__ import annotations

import json
import os
from typing import Any, Iterable, Optional, Union

import numpy as np
import pandas as pd

from . import _native
from ._native import RoverPowerError, RoverPowerWarning

__all__ = [
    "COLUMNS",
    "RoverPowerError",
    "RoverPowerWarning",
    "diagnose",
    "plan",
    "read_run",
    "validate",
]

PathLike = Union[str, "os.PathLike[str]"]

#: The run CSV's columns in its order; ``read_run`` makes the first (``t_s``) the index.
COLUMNS: list[str] = _native.columns()


def read_run(
    path: PathLike, *, salvage: bool = False, rig_range: str = "physical"
) -> pd.DataFrame:
    """The run log at ``path`` (a run CSV or an MCAP log) as a DataFrame.

    Columns are the run CSV's (``COLUMNS`` without ``t_s``, which is the index), all float64;
    an optional value that was not measured (yaw, pitch, a position between tracker fixes) is
    NaN. ``df.attrs["events"]`` lists the run's events (device vanished, samples lost, board
    reset, wall clock, ...) as dicts with ``t_s`` and ``kind``: an MCAP log's own, or a run
    CSV's ``RUN.events.jsonl`` when it lies beside it.

    The frame's values are handed over without a copy, and the frame is yours: change it in
    place as any other.

    ``salvage`` and ``rig_range`` are the command line's ``--salvage`` and ``--rig-range``
    (``"physical"``, ``"board"`` or ``"BUS_V,CURRENT_A"``).
    """
    columns, events = _native.read_run(os.fspath(path), salvage, rig_range)
    # Each column is a vector the reader handed over: numpy views it in place (the array's
    # base owns it) and pandas keeps the views, one block per column.
    values = [np.asarray(column) for column in columns]
    frame = pd.DataFrame(
        dict(zip(COLUMNS[1:], values[1:])),
        index=pd.Index(values[0], name=COLUMNS[0], copy=False),
        copy=False,
    )
    frame.attrs["events"] = json.loads(events)
    return frame


def validate(
    rover: Optional[PathLike],
    runs: Union[PathLike, Iterable[PathLike]],
    *,
    salvage: bool = False,
    rig_range: str = "physical",
) -> dict[str, Any]:
    """``host-tool validate --json``'s report of ``runs`` (run CSVs or MCAP logs, each an
    independent run): the fitted ICR model, each manoeuvre's measured and modelled power, the
    departures. ``rover`` is a rover TOML, or None for the Husky A200
    (``rovers/husky-a200.toml``)."""
    text = _native.validate(_path_or_none(rover), _paths(runs), salvage, rig_range)
    return json.loads(text)


def diagnose(
    rover: Optional[PathLike],
    runs: Union[PathLike, Iterable[PathLike]],
    calibration: Union[PathLike, Iterable[PathLike], None] = None,
    *,
    salvage: bool = False,
    rig_range: str = "physical",
) -> dict[str, Any]:
    """``host-tool diagnose --json``'s report: where the hard-ground model departs from
    ``runs``, which effect explains it, how much of the gap it closes on held-out runs, and
    what to drive next. ``calibration`` runs fit the baseline (default: the calibration
    manoeuvres of ``runs``). ``runs`` may also be per-turn summary CSVs or path tables, as on
    the command line. ``rover`` as in ``validate``."""
    cal = [] if calibration is None else _paths(calibration)
    text = _native.diagnose(_path_or_none(rover), _paths(runs), cal, salvage, rig_range)
    return json.loads(text)


def plan(
    start_deg: float,
    end_deg: float,
    distance_m: float,
    model: Optional[PathLike] = None,
) -> dict[str, Any]:
    """``host-tool plan --json``: the energy of the optimal circle-line-circle path against the
    point-turn path between two poses. ``model`` is a model file (``diagnose``'s
    ``model.toml``, or one written by hand), or None for paper Table 2's Husky on hard
    ground."""
    text = _native.plan(
        float(start_deg), float(end_deg), float(distance_m), _path_or_none(model)
    )
    return json.loads(text)


def _path_or_none(path: Optional[PathLike]) -> Optional[str]:
    return None if path is None else os.fspath(path)


def _paths(paths: Union[PathLike, Iterable[PathLike]]) -> list[str]:
    if isinstance(paths, (str, bytes, os.PathLike)):
        return [os.fspath(paths)]
    return [os.fspath(p) for p in paths]
