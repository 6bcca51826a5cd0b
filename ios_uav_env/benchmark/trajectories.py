"""Files of trajectories, one per scenario of a suite: ``.npz`` or CSV, read and written.

- ``.npz``: an array ``scenario_<index>`` of shape (N, 2) per scenario (way-points in m, q0
  first and qF last), and optionally a scalar ``seconds_<index>`` (its time to plan, s).
  Each index is named once (``scenario_1`` and ``scenario_01`` are the same scenario: refused),
  and a ``seconds_<index>`` or ``shares_<index>`` needs its ``scenario_<index>``.
- ``.csv``: a header with the columns ``scenario,slot,x,y`` (slot 0 .. N-1 per scenario, each
  once, in any row order) and optionally ``seconds`` (the scenario's time to plan, the same on
  each of its rows, or empty on all of them).

A time to plan is a finite number of seconds >= 0.

Plans of a multi-node suite may carry their TDMA shares (K, N): ``shares_<index>`` arrays in
``.npz``; columns ``share_0``, ``share_1``, ... in CSV (node k's share in the slot, empty beyond
the scenario's K). :func:`read_plans` returns them; without them a plan is scored with its
trajectory's best schedule.

:func:`read_trajectories` checks the file's layout (clear ``ValueError`` naming the scenario or
the line); :func:`~ios_uav_env.benchmark.trajectory_scoring.score_trajectories` checks each trajectory
against its scenario.
"""

from __future__ import annotations

import csv
import io
import math
import re
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env.io import atomic_write_bytes, atomic_write_text

CSV_COLUMNS = ("scenario", "slot", "x", "y")
_NPZ_KEY = re.compile(r"(scenario|seconds|shares)_(\d+)")
_SHARE_COLUMN = re.compile(r"share_(\d+)")
Plans = tuple[dict[int, np.ndarray], dict[int, float], dict[int, np.ndarray]]


def read_trajectories(path: str | Path) -> tuple[dict[int, np.ndarray], dict[int, float]]:
    """The trajectories of ``path`` by scenario index, and the plan times it gives."""
    trajectories, seconds, _ = read_plans(path)
    return trajectories, seconds


def read_plans(path: str | Path) -> Plans:
    """The trajectories, plan times and shares (multi-node plans; empty if none) of ``path``."""
    path = Path(path)
    if path.suffix not in (".npz", ".csv"):
        raise ValueError(f"{path}: a trajectories file must be .npz or .csv")
    if path.is_dir():
        raise ValueError(f"{path}: a trajectories file must be a file, got a folder")
    if path.suffix == ".npz":
        return _read_npz(path)
    try:
        return _read_csv(path)
    except (UnicodeDecodeError, csv.Error) as err:
        raise ValueError(f"{path}: not a readable CSV file of trajectories ({err})") from None


def _read_npz(path: Path) -> Plans:
    arrays: dict[str, dict[int, tuple[str, np.ndarray]]] = {"scenario": {}, "seconds": {}, "shares": {}}
    unreadable = f"{path}: not a readable .npz file (a zip archive of named numpy arrays, np.savez)"
    if not zipfile.is_zipfile(path):
        raise ValueError(unreadable)
    try:
        with np.load(path, allow_pickle=False) as data:
            for key in data.files:
                match = _NPZ_KEY.fullmatch(key)
                if match is None:
                    expected = "scenario_<index>, seconds_<index> or shares_<index>"
                    raise ValueError(f"{path}: unknown array {key!r}; expected {expected}")
                kind, index = match.group(1), int(match.group(2))
                if index in arrays[kind]:
                    first = arrays[kind][index][0]
                    raise ValueError(f"{path}: arrays {first!r} and {key!r} both name scenario {index}")
                try:
                    arrays[kind][index] = (key, np.asarray(data[key]))
                except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:
                    raise ValueError(f"{unreadable}: array {key!r}: {err}") from None
    except (OSError, EOFError, zipfile.BadZipFile) as err:
        raise ValueError(f"{unreadable}: {err}") from None
    for kind in ("seconds", "shares"):
        orphans = sorted(key for i, (key, _) in arrays[kind].items() if i not in arrays["scenario"])
        if orphans:
            raise ValueError(f"{path}: {orphans} name no scenario_<index> array of the file")
    trajectories: dict[int, np.ndarray] = {}
    seconds: dict[int, float] = {}
    shares: dict[int, np.ndarray] = {}
    for index, (key, array) in arrays["scenario"].items():
        if array.ndim not in (2, 3) or array.shape[-1] != 2:  # (U, N, 2): a fleet's flights
            raise ValueError(
                f"{path}: scenario {index}: {key} must have shape (N, 2) (a fleet's: (U, N, 2)), "
                f"got {array.shape}"
            )
        trajectories[index] = _numbers(array, path, key)
    for index, (key, array) in arrays["seconds"].items():
        if array.size != 1:
            raise ValueError(f"{path}: {key} must be a scalar (seconds), got shape {array.shape}")
        seconds[index] = check_plan_time(_numbers(array, path, key).reshape(()), f"{path}: {key}")
    for index, (key, array) in arrays["shares"].items():
        if array.ndim != 2:
            raise ValueError(f"{path}: scenario {index}: {key} must have shape (K, N), got {array.shape}")
        shares[index] = _numbers(array, path, key)
    return trajectories, seconds, shares


def _numbers(array: np.ndarray, path: Path, key: str) -> np.ndarray:
    """``array`` as float64 (``ValueError`` naming the array if it holds no numbers)."""
    if array.dtype.kind not in "biuf":
        raise ValueError(f"{path}: {key} must hold numbers, got dtype {array.dtype}")
    return array.astype(np.float64)


def check_plan_time(value: Any, where: str, *, unknown: bool = False) -> float:
    """A time to plan: a finite number of seconds >= 0, or NaN (unknown) if ``unknown``
    (``ValueError`` naming ``where`` otherwise)."""
    try:
        seconds = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: the time to plan must be a number of seconds, got {value!r}") from None
    if not ((math.isfinite(seconds) and seconds >= 0.0) or (unknown and math.isnan(seconds))):
        also = " (or NaN: unknown)" if unknown else ""
        raise ValueError(
            f"{where}: the time to plan must be a finite number of seconds >= 0{also}, got {seconds}"
        )
    return seconds


def _read_csv(path: Path) -> Plans:
    with path.open(newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        columns = reader.fieldnames or []
        if not set(CSV_COLUMNS) <= set(columns):
            need = ",".join(CSV_COLUMNS)
            raise ValueError(f"{path}: the header must have the columns {need}, got {columns}")
        share_columns = sorted((c for c in columns if _SHARE_COLUMN.fullmatch(c)), key=lambda c: int(c[6:]))
        if [int(c[6:]) for c in share_columns] != list(range(len(share_columns))):
            raise ValueError(f"{path}: the share columns must be share_0, share_1, ...; got {share_columns}")
        points: dict[int, dict[int, tuple[float, float]]] = {}
        slot_lines: dict[int, dict[int, int]] = {}  # the line of each slot, by scenario
        slot_shares: dict[int, dict[int, list[float]]] = {}
        seconds: dict[int, tuple[int, float | None]] = {}  # the first line of each scenario, its time
        for line, row in enumerate(reader, start=2):
            try:
                index, slot = int(row["scenario"]), int(row["slot"])
                point = (float(row["x"]), float(row["y"]))
                filled = [row.get(c) not in (None, "") for c in share_columns]
                given = [float(row[c]) for c, f in zip(share_columns, filled, strict=True) if f]
            except (TypeError, ValueError) as err:
                what = "scenario and slot must be integers, x, y and the shares numbers"
                raise ValueError(f"{path}:{line}: {what}") from err
            if slot < 0:
                raise ValueError(f"{path}:{line}: scenario {index}: slot must be >= 0 (0 .. N-1), got {slot}")
            slots, lines = points.setdefault(index, {}), slot_lines.setdefault(index, {})
            if slot in slots:
                raise ValueError(
                    f"{path}:{line}: scenario {index}: slot {slot} appears twice "
                    f"(lines {lines[slot]} and {line})"
                )
            slots[slot], lines[slot] = point, line
            if not all(filled[: len(given)]):  # a gap would shift the later shares to other nodes
                named = [c for c, f in zip(share_columns, filled, strict=True) if f]
                raise ValueError(f"{path}:{line}: scenario {index}: the shares must fill share_0 .. "
                                 f"share_<K-1> without gaps, got {named}")  # fmt: skip
            if given:
                slot_shares.setdefault(index, {})[slot] = given
            text = row.get("seconds")
            where = f"{path}:{line}: scenario {index}"
            given_seconds = None if text in (None, "") else _csv_seconds(text, where)
            first_line, first = seconds.setdefault(index, (line, given_seconds))
            if given_seconds != first:
                raise ValueError(
                    f"{path}:{line}: scenario {index}: seconds {text or '(empty)'} differs from "
                    f"{'(empty)' if first is None else repr(first)} on line {first_line}: a scenario has "
                    "one time to plan, the same on each of its rows (or empty on all)"
                )
    trajectories = {}
    for index, slots in points.items():
        if sorted(slots) != list(range(len(slots))):
            gaps = sorted(set(range(max(slots) + 1)) - set(slots))[:5]
            raise ValueError(f"{path}: scenario {index}: slots must be 0..N-1 without gaps; missing {gaps}")
        trajectories[index] = np.array([slots[k] for k in range(len(slots))], dtype=np.float64)
    shares = {}
    for index, by_slot in slot_shares.items():
        if sorted(by_slot) != sorted(points[index]) or len({len(v) for v in by_slot.values()}) != 1:
            raise ValueError(
                f"{path}: scenario {index}: every slot needs its K shares (share_0 .. share_<K-1>)"
            )
        shares[index] = np.array([by_slot[k] for k in range(len(by_slot))], dtype=np.float64).T
    times = {index: t for index, (_, t) in seconds.items() if t is not None}
    return trajectories, times, shares


def _csv_seconds(text: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{where}: seconds must be a number, got {text!r}") from None
    return check_plan_time(value, where)


def write_trajectories(
    path: str | Path,
    trajectories: Mapping[int, Any],
    seconds: Mapping[int, float] | None = None,
    shares: Mapping[int, Any] | None = None,
    *,
    compressed: bool = False,
) -> Path:
    """Write ``{index: (N, 2) trajectory}`` (and plan times, and multi-node shares ``{index: (K, N)}``)
    as ``.npz`` (``compressed``: ``np.savez_compressed``) or ``.csv``, atomically."""
    path = Path(path)
    seconds = dict(seconds or {})
    shares = {int(i): np.asarray(a, dtype=np.float64) for i, a in (shares or {}).items()}
    if path.suffix == ".npz":
        arrays: dict[str, np.ndarray] = {
            f"scenario_{int(i)}": np.asarray(q, dtype=np.float64) for i, q in trajectories.items()
        }
        arrays.update({f"seconds_{int(i)}": np.asarray(float(t)) for i, t in seconds.items()})
        arrays.update({f"shares_{i}": a for i, a in shares.items()})
        buf = io.BytesIO()
        (np.savez_compressed if compressed else np.savez)(buf, **arrays)
        return atomic_write_bytes(path, buf.getvalue())
    if path.suffix == ".csv":
        buf_text = io.StringIO()
        writer = csv.writer(buf_text, lineterminator="\n")
        k_max = max((a.shape[0] for a in shares.values()), default=0)
        writer.writerow([*CSV_COLUMNS, "seconds", *(f"share_{k}" for k in range(k_max))])
        for i, q in trajectories.items():
            t = seconds.get(i, math.nan)
            text = "" if math.isnan(t) else repr(float(t))
            a = shares.get(int(i))
            for slot, (x, y) in enumerate(np.asarray(q, dtype=np.float64)):
                cells = [] if a is None else [repr(float(v)) for v in a[:, slot]]
                cells += [""] * (k_max - len(cells))
                writer.writerow([int(i), slot, repr(float(x)), repr(float(y)), text, *cells])
        return atomic_write_text(path, buf_text.getvalue())
    raise ValueError(f"{path}: a trajectories file must be .npz or .csv")
