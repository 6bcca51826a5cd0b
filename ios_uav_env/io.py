"""Atomic file output: results are written to a temporary file and renamed into place.

A write that finds no room (a full disk, a full quota or a file-size limit: :data:`NO_ROOM`)
raises :class:`DiskFullError`, an ``OSError`` of the same errno naming the path and saying that
the disk is full; the temporary file is removed, so the path holds its previous content or
nothing, never a torn file. :func:`append_line` appends one whole line to an append-only log
(or nothing), and :func:`cut_torn_tail` cuts the unfinished last line a log may have been left
with (by an older writer, or a process killed in the middle of a write).
"""

from __future__ import annotations

import errno
import os
import tempfile
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

#: The errno values of a write that found no room: a full disk (ENOSPC), a full quota (EDQUOT)
#: and a file-size limit (EFBIG, e.g. ``ulimit -f``).
NO_ROOM: frozenset[int] = frozenset(
    code for code in (errno.ENOSPC, getattr(errno, "EDQUOT", None), errno.EFBIG) if code is not None
)


#: How :class:`DiskFullError` says what found no room, by errno.
_NO_ROOM_REASONS = {errno.ENOSPC: "the disk is full", errno.EFBIG: "the file-size limit is reached"}
if hasattr(errno, "EDQUOT"):
    _NO_ROOM_REASONS[errno.EDQUOT] = "the disk quota is used up"


class DiskFullError(OSError):
    """A write to ``path`` that found no room (``errno`` one of :data:`NO_ROOM`); what was being
    written was not left torn (see the module docstring)."""

    def __init__(self, code: int, path: str | Path, reason: str = "") -> None:
        super().__init__(code, reason or os.strerror(code), str(path))
        self.path = Path(path)

    def __str__(self) -> str:
        reason = _NO_ROOM_REASONS.get(self.errno, "the disk is full")
        return (
            f"cannot write {self.path}: {reason} ({self.strerror}); nothing was left half written: make "
            "room and run again"
        )

    def __reduce__(self) -> tuple[Any, ...]:  # raised in a worker process, re-raised in its parent
        return type(self), (self.errno, self.path, self.strerror)


def is_no_room(exc: BaseException) -> bool:
    """Whether ``exc`` is an ``OSError`` of a write that found no room (:data:`NO_ROOM`)."""
    return isinstance(exc, OSError) and exc.errno in NO_ROOM


@contextmanager
def naming_full_disk(path: str | Path) -> Iterator[None]:
    """Turn an ``OSError`` of :data:`NO_ROOM` raised in the block into :class:`DiskFullError`
    naming ``path`` (one already named passes unchanged)."""
    try:
        yield
    except DiskFullError:
        raise
    except OSError as exc:
        if exc.errno not in NO_ROOM:
            raise
        raise DiskFullError(exc.errno, path, exc.strerror or "") from exc


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _write_all(fd: int, data: bytes) -> None:
    """Write every byte of ``data`` to ``fd`` (``os.write`` may write less than asked)."""
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view) :]


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (a unique temp file in the same folder, then rename);
    :class:`DiskFullError` naming ``path`` if the disk is full (``path`` is then unchanged)."""
    path = Path(path)
    with naming_full_disk(path):
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        try:
            try:
                os.fchmod(fd, 0o666 & ~_umask())  # mkstemp makes 0600 files; results are ordinary files
                _write_all(fd, data)
            finally:
                os.close(fd)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    return path


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def append_line(path: str | Path, line: str) -> Path:
    """Append ``line`` and a newline (UTF-8) to the log ``path`` (created if missing), whole or not
    at all: one unbuffered write, so a process killed after it returns has lost nothing, and a
    write cut short (a full disk: :class:`DiskFullError`) is cut back off the file."""
    path = Path(path)
    data = (line.rstrip("\n") + "\n").encode("utf-8")
    with naming_full_disk(path):
        fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        try:
            size = os.fstat(fd).st_size
            try:
                _write_all(fd, data)
            except BaseException:
                os.ftruncate(fd, size)  # no half line for the next record to be glued onto
                raise
        finally:
            os.close(fd)
    return path


def cut_torn_tail(path: str | Path) -> int:
    """Cut the unfinished last line (no newline after it) off the log ``path``; the bytes cut
    (0 if the file is missing, empty or ends with a newline)."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            fh.seek(0, os.SEEK_END)
            size = fh.tell()
            if size == 0:
                return 0
            end, chunk = size, b""
            while end > 0:  # back to the last newline, a block at a time
                start = max(0, end - 65536)
                fh.seek(start)
                chunk = fh.read(end - start)
                if b"\n" in chunk:
                    break
                end = start
    except FileNotFoundError:
        return 0
    keep = (end - len(chunk) + chunk.rfind(b"\n") + 1) if b"\n" in chunk else 0
    if keep == size:
        return 0
    with path.open("r+b") as fh:
        fh.truncate(keep)
    return size - keep


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
