"""Result folders: results already there are never replaced silently, and a replaced run leaves
none of its files beside the new ones.

Every command that writes results to a folder (``python -m ios_uav_env.benchmark evaluate
--out``, ``python -m agents.suite report|curve --out``, ``python -m agents.evaluate --out``)
names the files it may write (:data:`RESULT_FILES` for :meth:`Results.save
<ios_uav_env.benchmark.results.Results.save>`, patterns as :mod:`fnmatch`'s) and, before it
runs anything, checks the folder (:func:`claim`): if any of them is there, it refuses without
``--overwrite`` (``overwrite=True``), naming them. With it, the files of the previous run that
this run does not write again (e.g. ``pct_sca.png`` and ``shares.png`` of a multi-node run
under a single-node one) are removed once the new ones are written (:func:`remove_stale`).
Other files in the folder are never touched.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Iterable, Sequence
from pathlib import Path

#: The files :meth:`Results.save` may write.
RESULT_FILES: tuple[str, ...] = (
    "results.csv", "results.json", "results.md", "trajectories.npz", "pct_*.png", "shares.png",
    "mobile.png", "mobile_scenarios.png",
)  # fmt: skip


def existing(out: str | Path, patterns: Sequence[str]) -> list[Path]:
    """The files directly in ``out`` whose names match one of ``patterns`` (sorted)."""
    out = Path(out)
    if not out.is_dir():
        return []
    files = [p for p in out.iterdir() if p.is_file()]
    return sorted(p for p in files if any(fnmatch.fnmatch(p.name, q) for q in patterns))


def claim(out: str | Path, patterns: Sequence[str], overwrite: bool) -> list[Path]:
    """The result files of ``patterns`` already in ``out`` (a previous run's), to pass to
    :func:`remove_stale` once the new ones are written. ``FileExistsError`` naming them unless
    ``overwrite``."""
    found = existing(out, patterns)
    if found and not overwrite:
        names = ", ".join(p.name for p in found)
        raise FileExistsError(
            f"{out} already holds results ({names}): pass --overwrite (overwrite=True) to replace them; "
            "the files of that run this one does not write again are then removed"
        )
    return found


def remove_stale(previous: Iterable[Path], written: Iterable[str | Path]) -> list[Path]:
    """Remove each file of ``previous`` that is not one of ``written``; the removed files."""
    kept = {Path(p).resolve() for p in written}
    stale = [p for p in previous if p.resolve() not in kept and p.exists()]
    for path in stale:
        path.unlink()
    return stale
