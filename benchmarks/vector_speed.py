"""Throughput of the natively batched envs against Gymnasium's CartPoleVectorEnv: whole episodes of
every registered id, and (``--steps``) the step-level tables.

The default: for every registered id of ``ios_uav_env`` (``--ids`` to choose) it times WHOLE
EPISODES of ``gym.make_vec(id, num_envs=B, vectorization_mode="vector_entry_point")`` (B =
``--num-envs``, 1024), a seeded random policy (actions drawn from the action space): the
``reset(seed=...)`` that draws the rows' scenarios, the steps, the autoresets and whatever an
episode computes for its ``info`` (the multi-node ids' best-schedule LP at each episode end)
all count. The run ends at the first episode end after the rows have ended ``--episodes`` x B
episodes between them and at least ``--min-seconds`` have been timed, or when ``--seconds``
are spent (at least one step after the reset): a PARTIAL run, marked ``*`` with the episodes
it ended, whose rate covers only what ran (the reset weighs more, and the episode ends not
reached are missing). Env steps are the rows' transitions: a row's autoreset call (Gymnasium's
next-step mode) is timed but not counted. Gymnasium's ``CartPoleVectorEnv`` at the same B runs
the same way (its reset, random actions, autoresets) interleaved with the id, in slices of
about equal time, so machine drift slows both alike; each id's ratio is to the CartPole rate
measured beside it. An id without a vector entry point has no batched form: it is reported
and skipped (``--sync``: timed as ``SyncVectorEnv`` instead).

The bars, by how the id's registration behaves (:func:`classify`, nothing hard-coded per id):
a fixed-scenario id >= 0.1 x CartPoleVectorEnv; a randomised or moving-node id (its reset
draws a scenario, or its nodes move) >= 0.03 x. An id the script cannot classify is reported
as such, without a bar. Our batched envs step their rows on numba's threads (``--threads``;
default: every core), ``CartPoleVectorEnv`` on one (numpy); on a machine whose cores are busy a
parallel kernel can lose far more than a one-thread env (it waits for its slowest thread), so
compare with ``--threads 1`` there. ``--json PATH`` writes the table (:data:`COLUMNS`), atomically.

``--steps``: the step-level tables instead. For each batch size B it times ``step`` of the
batched env of ``--id`` (autoresets included) and of ``CartPoleVectorEnv`` at the same B, next
to the raw single ``CartPole-v1`` (``.unwrapped``). The envs take turns and the best of
``--repeats`` runs counts. The bars: at B = 1024 our env >= 30 x CartPole-v1 raw and >= 0.5 x
CartPoleVectorEnv. Then the multi-node id (``--multinode-id``, "" to skip): the single
``MultiNodeEnv`` (it solves the best-schedule LP, ``maxmin_rate``, at every episode end)
against its batched env at the same B, timed without the LP (``best_schedule=False``, as
training runs it); the "+ LP" column adds the measured time of one LP per row and episode.

The classification and the episode runner live in ``vector_episodes.py``, the step-level tables in
``vector_steps.py``, beside this script.

    python benchmarks/vector_speed.py [--ids ID ...] [--num-envs 1024] [--episodes 2] [--seconds 30]
                                      [--json PATH]
    python benchmarks/vector_speed.py --steps [--id ios_uav_env/IOSUAV-v0] [--sizes 64 256 1024 4096]
    python benchmarks/vector_speed.py --steps --sizes 1024 --threads 1 --multinode-id ""
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.envs.classic_control.cartpole import CartPoleVectorEnv

import ios_uav_env  # noqa: F401  (registers the ids)
from ios_uav_env.io import atomic_write_text
from ios_uav_env.jit import HAVE_NUMBA

try:
    from tqdm import tqdm
except ImportError:  # pragma: no cover - tqdm comes with the planners and rl extras
    tqdm = None

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the sibling modules, when run by path

from vector_episodes import (  # noqa: E402
    FIXED,
    FIXED_BAR,
    NAMESPACE,
    RANDOM,
    RANDOM_BAR,
    Classification,
    EpisodeRunner,
    classify,
    registered_ids,
    run_interleaved,
    warm_up,
)
from vector_steps import numba_threads_available, step_tables  # noqa: E402

#: The episode table's columns (its rows in ``--json``), in order.
COLUMNS = (
    "id",
    "kind",  # "fixed", "random" (randomised or moving nodes) or None (cannot classify)
    "why",  # what the classification rests on
    "form",  # "vector_entry_point", "sync" or None (not timed)
    "episodes_ended",
    "episodes_target",
    "partial",  # the time budget ended the run before its episodes
    "seconds",  # timed seconds of the id (its calls only)
    "reset_seconds",  # of them, the first reset(seed): B scenarios drawn
    "steps",  # env steps (rows' transitions)
    "steps_per_s",
    "cartpole_steps_per_s",  # CartPoleVectorEnv at the same B, interleaved with this id
    "cartpole_seconds",  # its timed seconds and env steps beside this id
    "cartpole_steps",
    "x_cartpole",  # steps_per_s / cartpole_steps_per_s
    "bar",  # FIXED_BAR or RANDOM_BAR (None: no bar)
    "meets_bar",
    "note",
)


def time_id(
    env_id: str,
    *,
    num_envs: int,
    episodes: int,
    seconds: float,
    min_seconds: float,
    seed: int = 0,
    threads: int | None = None,
    sync: bool = False,
    kind: Classification | None = None,
    progress: Callable[[EpisodeRunner], None] | None = None,
) -> dict[str, Any]:
    """One row of the episode table (:data:`COLUMNS`) for ``env_id``."""
    kind = kind or classify(env_id)
    spec = gym.spec(env_id)
    row: dict[str, Any] = dict.fromkeys(COLUMNS)
    row.update(id=env_id, kind=kind.kind, why=kind.why, bar=kind.bar, episodes_target=episodes * num_envs)
    notes = [] if kind.kind else ["cannot classify: no bar"]
    if getattr(spec, "vector_entry_point", None) is not None:
        form = "vector_entry_point"
        extra = {} if threads is None else {"num_threads": threads}
    elif sync:
        form, extra = "sync", {}
        notes.append("no batched form: timed as SyncVectorEnv")
    else:
        row.update(
            partial=False, note="; ".join([*notes, "no batched form (no vector entry point): skipped"])
        )
        return row

    def make(size: int) -> gym.vector.VectorEnv:
        return gym.make_vec(env_id, num_envs=size, vectorization_mode=form, **extra)

    warm_up(make, seed)
    vec = make(num_envs)
    cart_env = CartPoleVectorEnv(num_envs=num_envs)
    try:
        ours, cartpole = EpisodeRunner(vec, seed), EpisodeRunner(cart_env, seed)
        complete = run_interleaved(
            ours, cartpole, episodes=episodes, seconds=seconds, min_seconds=min_seconds, progress=progress
        )
    finally:
        vec.close()
        cart_env.close()
    ratio = ours.rate / cartpole.rate
    if not complete:
        ended = f"{ours.ended:,} of {row['episodes_target']:,} episodes ended"
        missing = (
            "no episode end is in the rate" if ours.ended == 0 else "not all its episode ends are in the rate"
        )
        notes.append(f"partial: the {seconds:g} s budget ran out ({ended}; {missing}, the reset weighs more)")
    row.update(
        form=form,
        episodes_ended=ours.ended,
        partial=not complete,
        seconds=ours.seconds,
        reset_seconds=ours.reset_seconds,
        steps=ours.steps,
        steps_per_s=ours.rate,
        cartpole_steps_per_s=cartpole.rate,
        x_cartpole=ratio,
        meets_bar=None if kind.bar is None else bool(ratio >= kind.bar),
        note="; ".join(notes),
        cartpole_seconds=cartpole.seconds,
        cartpole_steps=cartpole.steps,
    )
    return row


#: The printed table: (heading, width) per column after the id.
_PRINTED = (
    ("kind", 6),
    ("episodes", 8),
    ("timed s", 7),
    ("reset s", 7),
    ("env steps/s", 12),
    ("CartPoleVec", 11),
    ("x CartPole", 10),
    ("bar", 8),
    ("meets", 5),
)
HEADER = " ".join([f"{'id (* partial)':<38}", *(f"{head:>{width}}" for head, width in _PRINTED)])


def _format_row(row: Mapping[str, Any]) -> str:
    """One printed line of the table."""
    bar = "-" if row["bar"] is None else f">= {row['bar']:g}x"
    if row["steps_per_s"] is None:
        cells = [row["kind"] or "?", "not timed", "", "", "", "", "", bar, "-"]
    else:
        cells = [
            row["kind"] or "?",
            f"{row['episodes_ended']:,}",
            f"{row['seconds']:.1f}",
            f"{row['reset_seconds']:.2f}",
            f"{row['steps_per_s']:,.0f}" + ("*" if row["partial"] else ""),
            f"{row['cartpole_steps_per_s']:,.0f}",
            f"{row['x_cartpole']:.3f}",
            bar,
            {None: "-", True: "yes", False: "NO"}[row["meets_bar"]],
        ]
    return " ".join(
        [f"{row['id']:<38}", *(f"{cell:>{width}}" for cell, (_, width) in zip(cells, _PRINTED, strict=True))]
    )


def _write_json(path: Path, meta: Mapping[str, Any], rows: Iterable[Mapping[str, Any]]) -> None:
    document = {**meta, "columns": list(COLUMNS), "rows": list(rows)}
    atomic_write_text(path, json.dumps(document, indent=2, allow_nan=False, default=str) + "\n")


def _json_safe(row: Mapping[str, Any]) -> dict[str, Any]:
    return {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in row.items()}


def episode_table(args: argparse.Namespace) -> list[dict[str, Any]]:
    """Time whole episodes of each of ``args.ids``; print the table (and write ``args.json``)."""
    ids = list(args.ids)
    threads = args.threads or (numba_threads_available() if HAVE_NUMBA else 1)
    kernels = "yes" if HAVE_NUMBA else "no (plain-Python kernels)"
    print(
        f"Whole episodes at B = {args.num_envs}, a seeded random policy (seed {args.seed}); per id until "
        f"{args.episodes} x B episodes have ended and >= {args.min_seconds:g} s, or {args.seconds:g} s "
        "(* partial: the budget ran out first; reset s: the first reset, B scenarios drawn)."
    )
    print(
        f"numba: {kernels}; our batched envs on {threads} thread(s), CartPoleVectorEnv (same B, interleaved "
        "with each id) on one. Env steps are rows' transitions (autoreset calls timed, not counted)."
    )
    print(
        f"Bars: fixed-scenario id >= {FIXED_BAR:g} x CartPoleVectorEnv; randomised or moving-node id "
        f">= {RANDOM_BAR:g} x."
    )
    print(HEADER)
    meta = {
        "num_envs": args.num_envs,
        "episodes": args.episodes,
        "seconds": args.seconds,
        "min_seconds": args.min_seconds,
        "seed": args.seed,
        "threads": threads,
        "numba": HAVE_NUMBA,
        "bars": {FIXED: FIXED_BAR, RANDOM: RANDOM_BAR},
    }
    rows: list[dict[str, Any]] = []
    bar = tqdm(ids, desc="ids", unit="id", mininterval=0.5) if tqdm is not None else None
    for env_id in bar if bar is not None else ids:

        def progress(runner: EpisodeRunner, env_id: str = env_id) -> None:
            if bar is not None:
                bar.set_postfix_str(
                    f"{env_id}: {runner.ended:,} episodes, {runner.seconds:.0f} s", refresh=False
                )

        kind = classify(env_id)
        row = time_id(
            env_id,
            num_envs=args.num_envs,
            episodes=args.episodes,
            seconds=args.seconds,
            min_seconds=args.min_seconds,
            seed=args.seed,
            threads=args.threads,
            sync=args.sync,
            kind=kind,
            progress=progress,
        )
        rows.append(_json_safe(row))
        line = _format_row(row)
        if bar is not None:
            tqdm.write(line)
        else:
            print(line, flush=True)
        if args.json is not None:  # after each id: an interrupted run keeps the ids it timed
            _write_json(args.json, {**meta, "cartpole_steps_per_s": _pooled(rows)}, rows)
    if bar is not None:
        bar.close()
    for row in rows:  # what each id's bar rests on, and what its figure is
        print(
            f"  {row['id']}: {row['kind'] or 'cannot classify'} ({row['why']})"
            + (f"; {row['note']}" if row["note"] else "")
        )
    timed = [row for row in rows if row["meets_bar"] is not None]
    pooled = _pooled(rows)
    if pooled is not None:
        print(f"CartPoleVectorEnv over all the ids' slices: {pooled:,.0f} env steps/s")
    print(
        f"{sum(row['meets_bar'] for row in timed)} of {len(timed)} timed, classified ids meet their bar. "
        "Absolute figures move with the machine's load (shared cores); compare the ratios."
    )
    if args.json is not None:
        _write_json(args.json, {**meta, "cartpole_steps_per_s": pooled}, rows)
    return rows


def _pooled(rows: Sequence[Mapping[str, Any]]) -> float | None:
    """CartPoleVectorEnv's env steps/s over every id's slices."""
    seconds = sum(row.get("cartpole_seconds") or 0.0 for row in rows)
    return sum(row.get("cartpole_steps") or 0 for row in rows) / seconds if seconds > 0 else None


def build_parser() -> argparse.ArgumentParser:
    """The command line (see the module's docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--ids", nargs="+", default=None, help=f"ids to time (default: every {NAMESPACE} id)")
    parser.add_argument("--num-envs", type=int, default=1024, help="rows B (default: %(default)s)")
    parser.add_argument(
        "--episodes", type=int, default=2, help="episodes per row to time, x B in all (default: %(default)s)"
    )
    parser.add_argument(
        "--seconds",
        type=float,
        default=30.0,
        help="time budget per id, s; then partial (default: %(default)s)",
    )
    parser.add_argument(
        "--min-seconds", type=float, default=2.0, help="time at least this per id, s (default: %(default)s)"
    )
    parser.add_argument(
        "--seed", type=int, default=0, help="seed of the resets and actions (default: %(default)s)"
    )
    parser.add_argument(
        "--sync", action="store_true", help="time an id without a batched form as SyncVectorEnv"
    )
    parser.add_argument("--json", type=Path, default=None, help="write the episode table here (atomically)")
    parser.add_argument(
        "--threads", type=int, default=None, help="num_threads of our batched envs (default: every core)"
    )
    steps = parser.add_argument_group("step-level tables (--steps)")
    steps.add_argument("--steps", action="store_true", help="time steps per batch size instead of episodes")
    steps.add_argument("--id", default="ios_uav_env/IOSUAV-v0", help="env id (default: %(default)s)")
    steps.add_argument("--sizes", type=int, nargs="+", default=[64, 256, 1024, 4096], help="batch sizes B")
    steps.add_argument("--env-steps", type=int, default=400_000, help="env steps per timed run and size")
    steps.add_argument("--repeats", type=int, default=5, help="timed runs per env (the best counts)")
    steps.add_argument(
        "--multinode-id", default="ios_uav_env/IOSUAV-MultiNode-v0", help='multi-node id ("" to skip)'
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.threads is not None and args.threads < 1:
        parser.error("--threads must be >= 1")
    if args.steps:
        if min([*args.sizes, args.env_steps, args.repeats]) < 1:
            parser.error("--sizes, --env-steps and --repeats must be >= 1")
        step_tables(args)
        return 0
    if args.num_envs < 1 or args.episodes < 1:
        parser.error("--num-envs and --episodes must be >= 1")
    if not (args.seconds > 0 and args.min_seconds >= 0):
        parser.error("--seconds must be > 0 and --min-seconds >= 0")
    args.ids = registered_ids() if args.ids is None else args.ids
    unknown = [env_id for env_id in args.ids if env_id not in gym.registry]
    if unknown:
        parser.error(f"unregistered id(s) {', '.join(unknown)}; registered: {', '.join(registered_ids())}")
    episode_table(args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
