"""A parallel, cached, resumable map: every batch of planner solves runs through :func:`run_tasks`.

Each task's result is a JSON-serialisable record, cached as ``<cache_dir>/<key(task)>.json``
(written atomically with ``ios_uav_env.io.atomic_write_text`` as soon as the task finishes),
so an interrupted run resumes where it stopped and a finished one re-reads its records.
The key must change whenever anything that changes the record does (the task and the
solver settings): the cache never expires otherwise.

>>> import tempfile
>>> def square(x: int) -> dict:
...     return {"x": x, "y": x * x}
>>> with tempfile.TemporaryDirectory() as cache:
...     run_tasks(square, [3, 4], cache, key=str, jobs=1, progress=False)
[{'x': 3, 'y': 9}, {'x': 4, 'y': 16}]

The tasks run on a *backend*: ``"local"`` is a pool of spawned processes on this machine
(in this process for ``jobs=1``). A backend is a function ``(fn, items, jobs, done)`` that
calls ``fn(task)`` for every ``(index, task)`` of ``items`` and ``done(index, record)`` in
the calling process as each one finishes; another one (a cluster) registers in
:data:`BACKENDS` under its own name.

A cached record that cannot be read (truncated, empty, not JSON), lacks one of the
``required`` keys or holds a non-finite number is treated as missing: a warning names the
file and the task is computed again. SIGINT or SIGTERM during a map stops the worker
processes (none is left behind) and keeps the finished records; the interrupt then goes on
(``KeyboardInterrupt``, or ``SystemExit(143)`` for SIGTERM). A full disk ends the map with
``ios_uav_env.io.DiskFullError`` naming the cache file that did not fit (never left torn) after
a note on stderr of the records kept; run again once there is room.
"""

from __future__ import annotations

import json
import math
import multiprocessing
import os
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

from ios_uav_env.io import DiskFullError, atomic_write_text, naming_full_disk

T = TypeVar("T")
Record = dict[str, Any]
Backend = Callable[[Callable[[Any], Record], list[tuple[int, Any]], int, Callable[[int, Record], None]], None]


def _init_worker() -> None:
    os.environ["OMP_NUM_THREADS"] = "1"
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group: the parent decides


@contextmanager
def sigterm_raises() -> Iterator[None]:
    """SIGTERM raises ``SystemExit(143)`` in the main thread, as SIGINT raises ``KeyboardInterrupt``
    (so that ``finally`` blocks run and worker pools are shut down) instead of killing this process
    and orphaning its workers; elsewhere nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: object) -> None:
        raise SystemExit(128 + signum)

    old = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def _stop_pool(pool: ProcessPoolExecutor) -> None:
    """Stop the workers now (a task in progress is lost, finished ones are kept) and reap them."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(timeout=5)
        if process.is_alive():
            process.kill()
            process.join(timeout=5)


@contextmanager
def _one_thread_children() -> Iterator[None]:
    """``OMP_NUM_THREADS=1`` in the environment that spawned workers inherit, restored after."""
    old = os.environ.get("OMP_NUM_THREADS")
    os.environ["OMP_NUM_THREADS"] = "1"
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("OMP_NUM_THREADS", None)
        else:
            os.environ["OMP_NUM_THREADS"] = old


def local_backend(
    fn: Callable[[Any], Record],
    items: list[tuple[int, Any]],
    jobs: int,
    done: Callable[[int, Record], None],
) -> None:
    """``jobs`` spawned worker processes (fresh interpreters: no inherited BLAS threads, one
    OpenMP thread each); ``jobs=1`` runs in this process. A failing task stops the map: the
    tasks not yet started are cancelled, the finished ones stay cached."""
    if jobs == 1:
        for i, task in items:
            done(i, fn(task))
        return
    ctx = multiprocessing.get_context("spawn")
    with _one_thread_children():
        pool = ProcessPoolExecutor(max_workers=jobs, mp_context=ctx, initializer=_init_worker)
        try:
            futures = {pool.submit(fn, task): i for i, task in items}
            pending = set(futures)
            while pending:  # each record is cached (and counted) as soon as its task ends
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                failed = [f for f in finished if f.exception() is not None]
                for future in finished:
                    if future.exception() is None:
                        done(futures[future], future.result())
                if failed:
                    raise failed[0].exception()  # type: ignore[misc]
        except BaseException:  # an interrupt or a failed task: no worker may outlive the map
            _stop_pool(pool)
            raise
        pool.shutdown(wait=True)


def _ray_backend(
    fn: Callable[[Any], Record],
    items: list[tuple[int, Any]],
    jobs: int,
    done: Callable[[int, Record], None],
    **options: Any,
) -> None:
    """Ray tasks (:mod:`baselines.ray_backend`, imported only when used: Ray is an optional extra)."""
    from baselines.ray_backend import ray_backend

    ray_backend(fn, items, jobs, done, **options)


#: The backends by name.
BACKENDS: dict[str, Backend] = {"local": local_backend, "ray": _ray_backend}


def check_writable(folder: str | Path) -> Path:
    """``folder`` if it is a folder that can be written to, or can be created (``PermissionError``
    / ``NotADirectoryError`` naming the blocking path otherwise)."""
    folder = Path(folder)
    probe = folder
    while not probe.exists() and probe.parent != probe:
        probe = probe.parent
    if not probe.is_dir():
        raise NotADirectoryError(f"cannot create {folder}: {probe} is not a folder")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise PermissionError(f"cannot write to {folder}: {probe} is not writable")
    return folder


def record_problem(record: Any, required: Sequence[str] = ()) -> str | None:
    """Why ``record`` cannot be used (not a dict, a ``required`` key missing, a non-finite
    number anywhere in it), or None if it can."""
    if not isinstance(record, dict):
        return f"not a JSON object but a {type(record).__name__}"
    missing = [k for k in required if k not in record]
    if missing:
        return f"no {', '.join(map(repr, missing))}"

    def bad(value: Any, where: str) -> str | None:
        if isinstance(value, float) and not math.isfinite(value):
            return f"{where} is {value}"
        if isinstance(value, dict):
            return next((r for k, v in value.items() if (r := bad(v, f"{where}.{k}" if where else k))), None)
        if isinstance(value, list):
            return next((r for i, v in enumerate(value) if (r := bad(v, f"{where}[{i}]"))), None)
        return None

    return bad(record, "")


def cached_records(
    tasks: Sequence[T], cache_dir: str | Path, key: Callable[[T], str], required: Sequence[str] = ()
) -> dict[int, Record]:
    """The usable records of the tasks already in ``cache_dir``, by task index; an unreadable,
    incomplete or non-finite one (:func:`record_problem`) is left out with a warning naming
    its file (it will be computed again and replaced)."""
    cache_dir = Path(cache_dir)
    out = {}
    for i, task in enumerate(tasks):
        path = cache_dir / f"{key(task)}.json"
        if not path.exists():
            continue
        try:
            record = json.loads(path.read_text())
            problem = record_problem(record, required)
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            problem = f"unreadable ({type(exc).__name__}: {exc})"
        if problem is None:
            out[i] = record
        else:
            warnings.warn(
                f"cached record {path}: {problem}; computing it again", RuntimeWarning, stacklevel=2
            )
    return out


def run_tasks(
    fn: Callable[[T], Record],
    tasks: Sequence[T],
    cache_dir: str | Path,
    *,
    key: Callable[[T], str],
    jobs: int | None = None,
    backend: str = "local",
    order: Callable[[T], Any] | None = None,
    progress: bool = True,
    desc: str = "tasks",
    unit: str = "task",
    describe: Callable[[int, Record], str] | None = None,
    required: Sequence[str] = (),
    address: str | None = None,
) -> list[Record]:
    """``[fn(task) for task in tasks]``, each record read from the cache or computed and cached.

    ``fn`` must be picklable (a module-level function or a ``functools.partial`` of one) and
    return a JSON-serialisable dict. ``key(task)`` names the task's cache file. ``jobs``
    (default: all cores) caps the parallel tasks. ``order`` sorts the tasks to compute
    (e.g. slowest first, so that the pool ends evenly). ``describe(index, record)`` is the
    progress bar's note on each finished task. Tasks with the same key are computed once.
    ``required``: the keys every record must have (a cached one without them is computed again).
    ``backend="ray"`` runs the tasks as Ray tasks (:mod:`baselines.ray_backend`) on the cluster
    at ``address`` (default: a new local Ray; ``jobs`` default: no cap, Ray schedules them on
    its CPUs), with the same records and cache files as ``"local"``.
    On SIGINT / SIGTERM the workers are stopped, the finished records stay cached, and the
    interrupt propagates after a note on stderr. A full disk raises
    ``ios_uav_env.io.DiskFullError`` naming the cache file that did not fit (none is left torn),
    after the same note.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend: unknown backend {backend!r}; choose from {', '.join(BACKENDS)}")
    if jobs is not None and (not isinstance(jobs, int) or jobs < 1):
        raise ValueError(f"jobs: must be a positive integer, got {jobs!r}")
    if address is not None and backend != "ray":
        raise ValueError(f"address: a Ray cluster's address needs backend='ray', got backend={backend!r}")
    if backend == "ray":
        from baselines.ray_backend import require_ray

        require_ray()  # ImportError naming the extra, before any work
    cache_dir = Path(cache_dir)
    with naming_full_disk(cache_dir):
        cache_dir.mkdir(parents=True, exist_ok=True)
    keys = [key(task) for task in tasks]
    records = cached_records(tasks, cache_dir, key, required)
    twins: dict[str, list[int]] = {}  # key -> the indices of the tasks to compute, the first computes
    for i in range(len(tasks)):
        if i not in records:
            twins.setdefault(keys[i], []).append(i)
    missing = [group[0] for group in twins.values()]
    if order is not None:
        missing.sort(key=lambda i: order(tasks[i]))
    if missing:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(tasks), initial=len(records), desc=desc, unit=unit, disable=not progress)

        def done(i: int, record: Record) -> None:
            atomic_write_text(cache_dir / f"{keys[i]}.json", json.dumps(record))
            for j in twins[keys[i]]:
                records[j] = record
            if describe is not None:
                bar.set_postfix_str(describe(i, record))
            bar.update(len(twins[keys[i]]))

        default_jobs = len(missing) if backend == "ray" else os.cpu_count() or 1  # Ray: its CPUs
        workers = min(jobs or default_jobs, len(missing))
        options = {} if address is None else {"address": address}
        try:
            with sigterm_raises():
                BACKENDS[backend](fn, [(i, tasks[i]) for i in missing], workers, done, **options)
        except (KeyboardInterrupt, SystemExit):
            bar.close()
            print(f"interrupted: {len(records)} of {len(tasks)} records are kept in {cache_dir}; "
                  "run again to compute the rest", file=sys.stderr)  # fmt: skip
            raise
        except DiskFullError as exc:
            bar.close()
            print(f"disk full: {len(records)} of {len(tasks)} records are kept in {cache_dir}; free some "
                  f"space and run again to compute the rest ({exc})", file=sys.stderr)  # fmt: skip
            raise
        finally:
            bar.close()
    return [records[i] for i in range(len(tasks))]
