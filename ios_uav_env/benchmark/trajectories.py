"""Files of trajectories, one per scenario of a suite: ``.npz`` or CSV, read and written.

- ``.npz``: an array ``scenario_<index>`` of shape (N, 2) per scenario (way-points in m, q0
  first and qF last), and optionally a scalar ``seconds_<index>`` (its time to plan, s).
- ``.csv``: a header with the columns ``scenario,slot,x,y`` (slot 0 .. N-1 per scenario, in any
  row order) and optionally ``seconds`` (the scenario's time to plan, on each of its rows).

:func:`read_trajectories` checks the file's layout (clear ``ValueError`` naming the scenario or
the line); :func:`~ios_uav_env.benchmark.scoring.score_trajectories` checks each trajectory
against its scenario.
"""

from __future__ import annotations

import csv
import io
import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env.io import atomic_write_bytes, atomic_write_text

CSV_COLUMNS = ("scenario", "slot", "x", "y")
_NPZ_KEY = re.compile(r"(scenario|seconds)_(\d+)")


def read_trajectories(path: str | Path) -> tuple[dict[int, np.ndarray], dict[int, float]]:
    """The trajectories of ``path`` by scenario index, and the plan times it gives."""
    path = Path(path)
    if path.suffix == ".npz":
        return _read_npz(path)
    if path.suffix == ".csv":
        return _read_csv(path)
    raise ValueError(f"{path}: a trajectories file must be .npz or .csv")


def _read_npz(path: Path) -> tuple[dict[int, np.ndarray], dict[int, float]]:
    trajectories: dict[int, np.ndarray] = {}
    seconds: dict[int, float] = {}
    with np.load(path, allow_pickle=False) as data:
        for key in data.files:
            match = _NPZ_KEY.fullmatch(key)
            if match is None:
                expected = "scenario_<index> or seconds_<index>"
                raise ValueError(f"{path}: unknown array {key!r}; expected {expected}")
            index, array = int(match.group(2)), np.asarray(data[key])
            if match.group(1) == "seconds":
                if array.size != 1:
                    raise ValueError(f"{path}: {key} must be a scalar (seconds), got shape {array.shape}")
                seconds[index] = float(array.reshape(()))
            else:
                if array.ndim != 2 or array.shape[1] != 2:
                    shape = array.shape
                    raise ValueError(f"{path}: scenario {index}: {key} must have shape (N, 2), got {shape}")
                trajectories[index] = array.astype(np.float64)
    return trajectories, seconds


def _read_csv(path: Path) -> tuple[dict[int, np.ndarray], dict[int, float]]:
    with path.open(newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        columns = reader.fieldnames or []
        if not set(CSV_COLUMNS) <= set(columns):
            need = ",".join(CSV_COLUMNS)
            raise ValueError(f"{path}: the header must have the columns {need}, got {columns}")
        points: dict[int, dict[int, tuple[float, float]]] = {}
        seconds: dict[int, float] = {}
        for line, row in enumerate(reader, start=2):
            try:
                index, slot = int(row["scenario"]), int(row["slot"])
                point = (float(row["x"]), float(row["y"]))
            except (TypeError, ValueError) as err:
                what = "scenario and slot must be integers, x and y numbers"
                raise ValueError(f"{path}:{line}: {what}") from err
            slots = points.setdefault(index, {})
            if slot in slots:
                raise ValueError(f"{path}:{line}: scenario {index}: slot {slot} appears twice")
            slots[slot] = point
            if row.get("seconds") not in (None, ""):
                seconds[index] = float(row["seconds"])
    trajectories = {}
    for index, slots in points.items():
        if sorted(slots) != list(range(len(slots))):
            gaps = sorted(set(range(max(slots) + 1)) - set(slots))[:5]
            raise ValueError(f"{path}: scenario {index}: slots must be 0..N-1 without gaps; missing {gaps}")
        trajectories[index] = np.array([slots[k] for k in range(len(slots))], dtype=np.float64)
    return trajectories, seconds


def write_trajectories(
    path: str | Path, trajectories: Mapping[int, Any], seconds: Mapping[int, float] | None = None
) -> Path:
    """Write ``{index: (N, 2) trajectory}`` (and plan times) as ``.npz`` or ``.csv``, atomically."""
    path = Path(path)
    seconds = dict(seconds or {})
    if path.suffix == ".npz":
        arrays: dict[str, np.ndarray] = {
            f"scenario_{int(i)}": np.asarray(q, dtype=np.float64) for i, q in trajectories.items()
        }
        arrays.update({f"seconds_{int(i)}": np.asarray(float(t)) for i, t in seconds.items()})
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        return atomic_write_bytes(path, buf.getvalue())
    if path.suffix == ".csv":
        buf_text = io.StringIO()
        writer = csv.writer(buf_text, lineterminator="\n")
        writer.writerow([*CSV_COLUMNS, "seconds"])
        for i, q in trajectories.items():
            t = seconds.get(i, math.nan)
            text = "" if math.isnan(t) else repr(float(t))
            for slot, (x, y) in enumerate(np.asarray(q, dtype=np.float64)):
                writer.writerow([int(i), slot, repr(float(x)), repr(float(y)), text])
        return atomic_write_text(path, buf_text.getvalue())
    raise ValueError(f"{path}: a trajectories file must be .npz or .csv")
