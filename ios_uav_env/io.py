"""Atomic file output: results are written to a temporary file and renamed into place."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (a unique temp file in the same folder, then rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.fchmod(fd, 0o666 & ~_umask())  # mkstemp makes 0600 files; results are ordinary files
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def save_figure(fig: object, path: str | Path, **savefig_kwargs: object) -> Path:
    """Save a matplotlib figure atomically; the format follows the path's suffix."""
    import io

    buf = io.BytesIO()
    fmt = Path(path).suffix.lstrip(".") or "png"
    fig.savefig(buf, format=fmt, **savefig_kwargs)  # type: ignore[attr-defined]
    return atomic_write_bytes(path, buf.getvalue())


def save_rows_csv(path: str | Path, columns: Sequence[str], rows: Iterable[Mapping[str, Any]]) -> Path:
    """Write one CSV row per mapping (keys ``columns``; floats at full precision, as ``repr``),
    with a header line, atomically."""
    import csv
    import io

    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: repr(v) if isinstance(v, float) else v for k, v in row.items()})
    return atomic_write_text(path, buf.getvalue())


def save_csv(path: str | Path, array: object, header: str, fmt: str = "%.10g") -> Path:
    """Write a 2-D array as CSV with a header line, atomically."""
    import io

    import numpy as np

    buf = io.StringIO()
    np.savetxt(buf, np.asarray(array), delimiter=",", header=header, comments="", fmt=fmt)
    return atomic_write_text(path, buf.getvalue())
