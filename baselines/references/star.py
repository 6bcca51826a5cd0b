"""The STAR-control suite's draws, references and content (``star-v1``).

**Draws** (:func:`star_tasks`): scenario i takes the setting :data:`SETTINGS`\\ [i mod 27] (every
setting equally often: M in {16, 64, 256} elements, a square surface; bits in {None, 1, 2}; TDMA,
ES-NOMA and MS-NOMA, the access varying fastest; group 1, the UAV-user links blocked) and an
episode seed drawn in turn from ``default_rng(SeedSequence(entropy=seed,
spawn_key=STAR_SPAWN_KEY))``, a stream that no reset seed and no other suite's draws reproduce.
The seed's episode (its line) is recorded as its ``config``.

**References** (:func:`solve_star`), each a mean slot value (bps/Hz: an episode's return / N) of
the env's own reward sum, through ``ios_uav_env.benchmark.star_suite.star_episode``:

- ``optimum``: the per-slot optima (``info["optimum_return"] / N``), the normaliser; ``seconds``
  the time of ``slot_optimum`` over the episode's slots; ``replayed``: the optimum's settings
  played as actions (``action_of``), which the env scores as the optimum to rounding;
- ``bound``: the certified per-slot upper bounds (``info["optimum_upper"]``), = the optimum under
  TDMA;
- ``quantised``: the continuous-phase optimum's settings as actions, so rounded to the env's grid;
- ``aligned``: the aligned closed form (``star_policies.aligned_setting``);
- ``phases``: the heuristic policy ``star_policies.ChannelPhases`` on the observation;
- ``random``: uniform actions in [-1, 1], the mean of :data:`RANDOM_EPISODES` episodes, drawn from
  ``default_rng(SeedSequence(entropy=seed, spawn_key=(*STAR_SPAWN_KEY, index)))``.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from ios_uav_env import ScenarioConfig
from ios_uav_env.benchmark.star_policies import (
    ChannelPhases,
    aligned_setting,
    continuous_setting,
    optimum_setting,
    setting_policy,
)
from ios_uav_env.benchmark.star_suite import STAR_FIELDS, StarTask, make_star_env, star_episode
from ios_uav_env.benchmark.suite_registry import BOUND_REL, FORMAT, STAR_CONTROL, STAR_ENV_ID, STAR_REFERENCES
from ios_uav_env.model.star_slot import slot_optimum

__all__ = ["SETTINGS", "STAR_SIZE", "check_star_record", "solve_star", "star_content", "star_tasks"]

#: The STAR-control suite's spawn key (its entropy is ``draws.ENTROPY`` unless given) and size.
STAR_SPAWN_KEY = (37,)
#: The settings (M, bits, access, protocol), the access varying fastest, then the bits, then M.
SETTINGS = tuple(
    (m, bits, access, protocol)
    for m, bits, (access, protocol) in itertools.product(
        (16, 64, 256), (None, 1, 2), (("tdma", "es"), ("noma", "es"), ("noma", "ms"))
    )
)
STAR_SIZE = 2 * len(SETTINGS)
#: Episodes of uniform random actions per scenario (``random``'s mean).
RANDOM_EPISODES = 3
#: The env's arguments the suite shows the policy (its ``env_kwargs``).
STAR_ENV_KWARGS = {"channel_phases": True}


def drawn_tasks(
    n: int, seed: int, spawn_key: tuple[int, ...], field: str, keywords: Callable[[int], dict[str, Any]]
) -> list[dict[str, Any]]:
    """The first ``n`` tasks ``{"index", field, "seed"}`` of a surface-control suite: scenario i's
    env keywords ``keywords(i)`` and an episode seed drawn in turn from
    ``default_rng(SeedSequence(entropy=seed, spawn_key=spawn_key))``."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be an integer >= 1 (scenarios), got {n!r}")
    rng = np.random.default_rng(np.random.SeedSequence(entropy=int(seed), spawn_key=spawn_key))
    return [{"index": i, field: keywords(i), "seed": int(rng.integers(0, 2**31 - 1))} for i in range(int(n))]


def star_tasks(n: int, seed: int) -> list[dict[str, Any]]:
    """The first ``n`` STAR-control tasks ``{"index", "star", "seed"}`` (module docstring, "Draws")."""

    def keywords(i: int) -> dict[str, Any]:
        m, bits, access, protocol = SETTINGS[i % len(SETTINGS)]
        side = int(round(m**0.5))
        return {"elements": [side, side], "bits": bits, "group": 1, "protocol": protocol, "access": access,
                "direct_link": False}  # fmt: skip

    return drawn_tasks(n, seed, STAR_SPAWN_KEY, "star", keywords)


def solve_star(
    task: Mapping[str, Any], entropy: int, random_episodes: int = RANDOM_EPISODES
) -> dict[str, Any]:
    """The reference record of a STAR-control task (module docstring, "References"); ``entropy``:
    the draws' (the random actions' stream)."""
    star, seed, index = dict(task["star"]), int(task["seed"]), int(task["index"])
    env = make_star_env(star, STAR_ENV_KWARGS)
    try:
        env.reset(seed=seed)
        base = env.unwrapped
        config = base.config
        record: dict[str, Any] = {"index": index, "star": star, "seed": seed, "config": config.to_dict()}
        start = time.perf_counter()
        for ch in base.channels:
            slot_optimum(ch, base.surface, base.access)
        seconds = time.perf_counter() - start

        def play(act: Any) -> Any:
            return star_episode(env, act, seed, config, f"scenario {index}")

        best = play(setting_policy(env, optimum_setting))
        record["optimum"] = {"rate": best.optimum, "replayed": best.value, "seconds": seconds}
        record["bound"] = {"upper_bound": best.bound}
        record["quantised"] = {"rate": play(setting_policy(env, continuous_setting)).value}
        record["aligned"] = {"rate": play(setting_policy(env, aligned_setting)).value}
        record["phases"] = {"rate": play(ChannelPhases().bind(StarTask.of(star, env))).value}
        stream = np.random.SeedSequence(entropy=int(entropy), spawn_key=(*STAR_SPAWN_KEY, index))
        rng = np.random.default_rng(stream)
        shape = env.action_space.shape
        values = [play(lambda obs: rng.uniform(-1.0, 1.0, shape)).value for _ in range(random_episodes)]
        record["random"] = {"rate": float(np.mean(values)), "episodes": int(random_episodes)}
    finally:
        env.close()
    return record


def task_key(task: Mapping[str, Any], entropy: int, random_episodes: int, field: str) -> str:
    """A surface-control task's cache file stem: ``field`` (``star``, ``miso``), its index and a hash
    of its keywords ``task[field]``, seed and settings."""
    settings = [int(entropy), int(random_episodes), f"{field}:v1"]
    blob = json.dumps([task[field], task["seed"], *settings], sort_keys=True)
    return f"{field}_{int(task['index']):03d}_{hashlib.sha1(blob.encode()).hexdigest()[:16]}"


def star_key(task: Mapping[str, Any], entropy: int, random_episodes: int = RANDOM_EPISODES) -> str:
    """A task's cache file stem: ``star_``, its index and a hash of its keywords, seed and settings."""
    return task_key(task, entropy, random_episodes, "star")


def describe(index: int, record: Mapping[str, Any]) -> str:
    """The progress bar's note on a finished task."""
    o, b = record["optimum"]["rate"], record["bound"]["upper_bound"]
    return f"#{index}: optimum {o:.4f} / bound {b:.4f} bps/Hz, phases {record['phases']['rate']:.4f}"


def longest_first(task: Mapping[str, Any]) -> float:
    """The runner's order: ES under NOMA first (its optimum is a branch and bound), then by M."""
    s = task["star"]
    es_noma = s["access"] == "noma" and s["protocol"] == "es"
    return -(1000 * es_noma + s["elements"][0] * s["elements"][1] + (s["bits"] is not None))


#: Relative slack of the replayed optimum against the optimum (the action's float64 round trip
#: through phases / pi and the splits; a setting the action cannot express is far off).
REPLAY_REL = 1e-9


def check_star_record(rec: Mapping[str, Any]) -> list[str]:
    """The sanity notes of one record: a row above the bound or the optimum, the optimum's replay
    off, a TDMA bound other than its optimum, an optimum that is not > 0."""
    i, notes = rec["index"], []
    opt, ub = float(rec["optimum"]["rate"]), float(rec["bound"]["upper_bound"])
    if not opt > 0:
        notes.append(f"#{i}: optimum {opt!r} is not > 0")
    if opt > ub * (1.0 + BOUND_REL):
        notes.append(f"#{i}: optimum {opt:.9g} > bound {ub:.9g} bps/Hz")
    if rec["star"]["access"] == "tdma" and abs(opt - ub) > BOUND_REL * ub:
        notes.append(f"#{i}: a TDMA bound {ub:.12g} is not its closed-form optimum {opt:.12g}")
    if abs(rec["optimum"]["replayed"] - opt) > REPLAY_REL * opt:
        notes.append(f"#{i}: the optimum's actions score {rec['optimum']['replayed']:.12g}, not {opt:.12g}")
    for name in STAR_REFERENCES[2:]:
        if rec[name]["rate"] > opt * (1.0 + REPLAY_REL):
            notes.append(f"#{i}: {name} {rec[name]['rate']:.9g} > optimum {opt:.9g} bps/Hz")
    return notes


def scenario_entry(
    rec: Mapping[str, Any], check: Callable[[Mapping[str, Any]], list[str]], field: str, fields: Sequence[str]
) -> dict[str, Any]:
    """A surface-control record's scenario entry: its index, config, keywords ``rec[field]`` (the
    keys ``fields``), seed, optimum and bound (the other rows are the caller's); ``ValueError``
    naming the scenario where ``check(rec)`` has a note."""
    notes = check(rec)
    if notes:
        raise ValueError("; ".join(notes))
    o = rec["optimum"]
    return {
        "index": int(rec["index"]),
        "config": ScenarioConfig(**rec["config"]).to_dict(),
        field: {k: rec[field][k] for k in fields},
        "seed": int(rec["seed"]),
        "optimum": {"rate": float(o["rate"]), "replayed": float(o["replayed"]),
                    "seconds": round(float(o["seconds"]), 4)},
        "bound": {"upper_bound": float(rec["bound"]["upper_bound"])},
    }  # fmt: skip


def star_content(
    records: Sequence[Mapping[str, Any]], name: str, version: int, *, seed: int, random_episodes: int
) -> dict[str, Any]:
    """The content of a STAR-control suite from the records of :func:`solve_star` (``ValueError``
    naming the scenario where :func:`check_star_record` has a note)."""
    scenarios = []
    for rec in records:
        entry = scenario_entry(rec, check_star_record, "star", STAR_FIELDS)
        for r in ("quantised", "aligned", "phases"):
            entry[r] = {"rate": float(rec[r]["rate"])}
        entry["random"] = {"rate": float(rec["random"]["rate"]), "episodes": int(rec["random"]["episodes"])}
        scenarios.append(entry)
    return {
        "format": FORMAT,
        "name": name,
        "version": int(version),
        "kind": STAR_CONTROL,
        "env_id": STAR_ENV_ID,
        "env_kwargs": dict(STAR_ENV_KWARGS),
        "normalizer": "optimum",
        "references": list(STAR_REFERENCES),
        "description": " ".join(
            (
                f"{len(scenarios)} held-out episodes of STARControl-v0 (the agent sets a small STAR surface",
                "every slot as a UAV flies a drawn line past it): scenario i takes the setting i mod 27",
                "of M in {16, 64, 256} (square), bits in {None, 1, 2} and TDMA, ES-NOMA, MS-NOMA (group 1,",
                "UAV-user links blocked) and an episode seed drawn in turn from",
                f"default_rng(SeedSequence(entropy={int(seed)}, spawn_key={STAR_SPAWN_KEY})); config: the",
                "episode's scenario (its line), checked at every rollout. Values are mean slot values",
                "(bps/Hz, the env's reward sum / N). optimum: the per-slot optima (star_slot.slot_optimum,",
                "the normaliser; seconds: their time over the episode, one process on a busy 2-core",
                "machine; replayed: its settings played as actions); bound: the certified per-slot upper",
                "bounds; quantised: the continuous-phase optimum's settings as actions (rounded to the",
                "grid); aligned: the channel-aligned phases on the grid, the surface split equally, the",
                "share or power split best; phases: the ChannelPhases heuristic on the observation;",
                f"random: uniform actions, the mean of {int(random_episodes)} episodes drawn from",
                f"default_rng(SeedSequence(entropy={int(seed)}, spawn_key=({STAR_SPAWN_KEY[0]}, index))).",
            )
        ),
        "source": {
            "entropy": int(seed),
            "spawn_key": list(STAR_SPAWN_KEY),
            "sampler": "SETTINGS[i % 27], then rng.integers(0, 2**31 - 1): the episode seed",
            "random_episodes": int(random_episodes),
        },
        "scenarios": scenarios,
    }
