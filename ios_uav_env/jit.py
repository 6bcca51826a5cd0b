"""Optional compilation of the hot loops with numba (``pip install ios-uav-env[fast]``).

:func:`jit` compiles a function written in the numba-compatible subset of Python (scalars,
``math``, numpy arrays, loops) when numba is installed and returns it unchanged otherwise, so
every kernel has one source and runs either way. ``IOS_UAV_ENV_NO_NUMBA=1`` in the
environment forces the plain-Python path (used by the tests to check both paths agree).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

try:  # numba is optional: the model and the env run without it
    if os.environ.get("IOS_UAV_ENV_NO_NUMBA", "") not in ("", "0"):
        raise ImportError("disabled by IOS_UAV_ENV_NO_NUMBA")
    from numba import njit as _njit
    from numba import prange
except ImportError:
    _njit = None
    prange = range  # type: ignore[assignment]  # (plain Python: a prange loop is a range loop)

#: (numba's on-disk cache is keyed by each kernel module's source, not by these options:
#: after changing them, delete the ``*.nbi`` / ``*.nbc`` files under ``__pycache__``.)
#: LLVM fast-math flags of the kernels: reassociation (the node sums vectorise), fused
#: multiply-add, reciprocals, no signed zeros; never "no NaNs / no infs" (the guards rely on them).
FASTMATH = {"reassoc", "contract", "arcp", "nsz"}

#: Whether the kernels are compiled (numba installed and not disabled).
HAVE_NUMBA: bool = _njit is not None


def jit(
    function: F | None = None, *, inline: bool = False, fastmath: bool = True, parallel: bool = False
) -> Any:
    """``function`` compiled by numba (no Python objects, cached on disk), or itself.
    ``inline=True``: a small helper inlined into the compiled functions that call it.
    ``parallel=True``: its ``prange`` loops run on numba's threads (``numba.set_num_threads``
    sets how many; a ``prange`` loop is a plain loop in the other compilations).
    ``fastmath=False``: IEEE arithmetic in the function's own code (no fused multiply-add, no
    reassociation), e.g. to reproduce plain-Python arithmetic bit for bit; the compiled
    functions it calls keep their own flags."""

    def compile_(f: F) -> F:
        if _njit is None:
            return f
        options: dict[str, Any] = {"inline": "always"} if inline else {}
        if parallel:
            options["parallel"] = True
        # error_model="numpy": a division by zero gives inf instead of raising, so the node sums
        # have no per-element branch and vectorise (2x); the kernels never divide by zero
        flags = FASTMATH if fastmath else False
        return _njit(cache=True, nogil=True, fastmath=flags, error_model="numpy", **options)(f)  # type: ignore[no-any-return]

    return compile_ if function is None else compile_(function)


_launcher_pid: int | None = None  # the process that first ran a parallel kernel


def parallel_safe() -> bool:
    """Whether this process may run the ``parallel`` kernels on numba's threads: not in a child
    forked from a process that already did with numba's "omp" threading layer (GNU OpenMP
    cannot survive a fork: numba terminates the child at its first parallel launch). The
    batched envs call their serial kernel there instead (same results, one core, slower)."""
    global _launcher_pid
    pid = os.getpid()
    if _launcher_pid is None:
        _launcher_pid = pid
    if pid == _launcher_pid or _njit is None:
        return True
    import numba

    try:
        return numba.threading_layer() != "omp"
    except ValueError:  # no parallel launch yet in the parent: nothing to inherit
        return True


def prefer_passive_threads() -> None:
    """Let numba's OpenMP threads sleep between the batched envs' kernels instead of spinning:
    ``OMP_WAIT_POLICY=PASSIVE`` unless the environment sets it. GNU OpenMP reads it when numba
    first launches its threads, so call this before the process's first batched step.

    A trainer alternates the env's kernels with torch's work: threads that spin after each
    kernel hold the cores the update needs (on 2 cores the update ran several times slower;
    ``results/log.md``). The env's own step pays a wake-up per kernel instead."""
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


def run_batched(parallel: Callable[..., Any], serial: Callable[..., Any], num_threads: int | None,
                *args: Any) -> Any:  # fmt: skip
    """``parallel(*args)`` (a ``jit(parallel=True)`` kernel) on ``num_threads`` of numba's threads
    (at most ``NUMBA_NUM_THREADS``, the cores by default; None: numba's current setting, which
    is restored afterwards), or ``serial(*args)``, the same kernel one row after the other, in
    a process where numba's threads cannot run (:func:`parallel_safe`)."""
    if not parallel_safe():
        return serial(*args)
    if num_threads is None or _njit is None:
        return parallel(*args)
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(min(num_threads, numba.config.NUMBA_NUM_THREADS))
    try:
        return parallel(*args)
    finally:
        numba.set_num_threads(before)


#: Fewer rows than this in a batched call run on the caller's thread alone (:func:`threads_for`:
#: the batched envs' small calls, e.g. a few autoresets): handing them to other threads costs more.
FEW_ROWS = 64


def threads_for(num_threads: int | None, size: int) -> int | None:
    """``num_threads`` for a batched call of ``size`` rows: 1 (this thread alone) below
    :data:`FEW_ROWS`."""
    return 1 if size < FEW_ROWS else num_threads


def _copy_loop(dst: Any, src: Any) -> None:
    for j in range(src.shape[0]):
        dst[j] = src[j]


def _copy_slice(dst: Any, src: Any) -> None:
    dst[: src.shape[0]] = src


#: ``copy_into(dst, src)``: ``dst[:len(src)] = src`` for 1-D arrays, in a kernel element by element.
#: A slice assignment from an array in a compiled function makes numba compile its shape-mismatch
#: error path (an f-string of the shapes: its string formatting), seconds of compile in every
#: process that compiles such a kernel; the kernels copy with this instead. Without numba: numpy's
#: slice assignment.
copy_into: Callable[[Any, Any], None] = (
    jit(inline=True, fastmath=False)(_copy_loop) if HAVE_NUMBA else _copy_slice
)
