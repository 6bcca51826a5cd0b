"""The ``"ray"`` backend of :func:`baselines.runner.run_tasks`: every task is a Ray task.

    run_tasks(fn, tasks, cache_dir, key=..., backend="ray")                      # a local Ray
    run_tasks(fn, tasks, cache_dir, key=..., backend="ray", address="HOST:6379")  # a cluster

Each task runs as ``ray.remote(num_cpus=1)`` (one CPU of the cluster, one OpenMP thread) and its
record comes back to the calling process, which writes it to the same cache file, with the same
key and the same atomic JSON, as the local backend: the records and the cache do not depend on
the backend. Ray is started by :func:`init_ray` only if it is not running in this process yet
(``ray.init(address=...)``; a local instance on this machine's cores without an address).

The workers import the task function from this repository (``experiments``, ``baselines``,
``agents``): on a cluster every node needs the same checkout and environment at the same path
(the workers get the checkout's root on ``PYTHONPATH``); see ``docs/scale-out.md``.

Ray is the optional ``ray`` extra: ``pip install -e '.[ray]'``.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

#: The repository root (on the workers' ``PYTHONPATH``).
ROOT = Path(__file__).resolve().parents[1]
MISSING_RAY = "the ray backend needs Ray: pip install -e '.[ray]' (the 'ray' extra)"


def require_ray() -> Any:
    """The ``ray`` module, or ``ImportError`` naming the extra that installs it."""
    try:
        import ray
    except ImportError as exc:
        raise ImportError(MISSING_RAY) from exc
    return ray


def init_ray(address: str | None = None, num_cpus: int | None = None) -> Any:
    """Connect to Ray unless this process already is: ``address`` is a running cluster's
    (``HOST:PORT``, or ``"auto"`` for the one started on this machine), None starts a new local
    instance with ``num_cpus`` CPUs (default: all cores). Returns the ``ray`` module."""
    ray = require_ray()
    if ray.is_initialized():
        return ray
    if address is not None and num_cpus is not None:
        raise ValueError("num_cpus: a cluster (address) has its own CPUs; give one or the other")
    env_vars = {"OMP_NUM_THREADS": "1", "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT),
                os.environ.get("PYTHONPATH")]))}  # fmt: skip
    if address is None:
        _loopback_only()
    ray.init(
        address="local" if address is None else address,  # not a cluster `ray start` left here
        num_cpus=num_cpus,
        include_dashboard=False,
        log_to_driver=False,
        runtime_env={"env_vars": env_vars},
    )
    return ray


def _loopback_only() -> None:
    """A local instance on the loopback interface only (Ray's single-node mode, its default on
    macOS and Windows): on Linux Ray would otherwise listen on every interface and reach its own
    processes through the machine's network address."""
    from ray._private import ray_constants

    os.environ[ray_constants.ENABLE_RAY_CLUSTERS_ENV_VAR] = "0"  # Ray's processes started from here
    ray_constants.ENABLE_RAY_CLUSTER = False  # this one (the constant is read when ray is imported)


def _call(fn: Callable[[Any], dict[str, Any]], task: Any) -> dict[str, Any]:
    return fn(task)


def ray_backend(
    fn: Callable[[Any], dict[str, Any]],
    items: list[tuple[int, Any]],
    jobs: int,
    done: Callable[[int, dict[str, Any]], None],
    *,
    address: str | None = None,
) -> None:
    """Run ``fn(task)`` for every ``(index, task)`` of ``items`` as a Ray task, at most ``jobs``
    at a time, calling ``done(index, record)`` here as each finishes. A failing task stops the
    map: the tasks not finished are cancelled and its own exception is raised (the finished
    records are kept by ``done``); so does an interrupt."""
    ray = init_ray(address)
    remote = ray.remote(num_cpus=1)(_call)
    fn_ref = ray.put(fn)
    queue = list(items)
    running: dict[Any, int] = {}
    try:
        while queue or running:
            while queue and len(running) < jobs:
                i, task = queue.pop(0)
                running[remote.remote(fn_ref, task)] = i
            ready, _ = ray.wait(list(running), num_returns=1)
            for ref in ready:
                i = running.pop(ref)
                try:
                    record = ray.get(ref)
                except ray.exceptions.RayTaskError as exc:
                    raise exc.as_instanceof_cause() from None
                done(i, record)
    except BaseException:
        for ref in running:
            ray.cancel(ref, force=True)
        raise


def add_backend_arguments(parser: argparse.ArgumentParser) -> None:
    """``--backend {local,ray}`` and ``--address``: where a command's parallel jobs run."""
    parser.add_argument(
        "--backend", choices=["local", "ray"], default="local",
        help="local: processes on this machine (default); ray: Ray tasks / Ray Tune trials",
    )  # fmt: skip
    parser.add_argument(
        "--address", default=None,
        help="the Ray cluster to join (HOST:PORT or 'auto'; needs --backend ray; default: a local Ray)",
    )  # fmt: skip


def check_backend_arguments(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``parser.error`` if ``--address`` comes without ``--backend ray``, or Ray is not installed."""
    if args.address is not None and args.backend != "ray":
        parser.error("argument --address: a Ray cluster's address needs --backend ray")
    if args.backend == "ray":
        try:
            require_ray()
        except ImportError as exc:
            parser.error(f"argument --backend: {exc}")
