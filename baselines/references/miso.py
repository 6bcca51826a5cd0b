"""The MISO-control suite's draws, references and content (``miso-v1``).

**Draws** (:func:`miso_tasks`): scenario i takes the setting :data:`SETTINGS`\\ [i mod 24] (every
setting equally often: N_t in {2, 4, 8} antennas, K in {2, 4} users, M in {16, 64} elements, a
square surface, the objective ``"sum"`` or ``"maxmin"``, the objective varying fastest) and an
episode seed drawn in turn from ``default_rng(SeedSequence(entropy=seed,
spawn_key=MISO_SPAWN_KEY))``, a stream that no reset seed and no other suite's draws reproduce
(the training runs reset with small integers; every suite spawns its own key). The seed's episode
(its line) is recorded as its ``config``.

**References** (:func:`solve_miso`), each a mean slot objective (bps/Hz: an episode's return / N)
of the env's own reward sum, through ``ios_uav_env.benchmark.star_suite.star_episode``:

- ``optimum``: the per-slot AO optima (``info["optimum_return"] / N``, ``miso_slot.slot_optimum``
  warm-started from the previous slot's), the normaliser; ``seconds`` the scoring episode's time
  (the env's AO, bound and baselines of every slot); ``replayed``: the AO settings played as
  actions (``action_of``: the beams scaled to full power, which only raises a rate);
- ``bound``: the certified per-slot upper bounds (``info["bound"]``, ``miso.slot_bounds``);
- ``mrt_aligned`` / ``zf_aligned``: equal-power MRT / ZF with the best of the K users' aligned
  phases (``miso_policies.aligned_setting``) played as actions; ZF needs N_t >= K: with N_t < K
  its rate is 0 and ``feasible`` false;
- ``mrt_random``: MRT with uniformly random phases, the mean of :data:`RANDOM_EPISODES` episodes
  drawn from ``default_rng(SeedSequence(entropy=seed, spawn_key=(*MISO_SPAWN_KEY, index)))``;
- ``direct``: the heuristic policy ``miso_policies.DirectMRT`` on the observation.

**Checks** (:func:`check_miso_record`, before freezing and in the tests): optimum > 0, bound >=
optimum, the replay >= the optimum, no row above the optimum (slack :data:`ROW_REL`), and the AO
within :data:`AO_GAP` of its bound (optimum >= (1 - AO_GAP) bound) on every scenario.
"""

from __future__ import annotations

import functools
import itertools
import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from baselines.references.star import drawn_tasks, scenario_entry, task_key
from ios_uav_env.benchmark.miso_policies import DirectMRT, aligned_setting, random_setting
from ios_uav_env.benchmark.miso_suite import MISO_FIELDS, MisoTask, make_miso_env
from ios_uav_env.benchmark.star_policies import setting_policy
from ios_uav_env.benchmark.star_suite import star_episode
from ios_uav_env.benchmark.suite_registry import BOUND_REL, FORMAT, MISO_CONTROL, MISO_ENV_ID, MISO_REFERENCES
from ios_uav_env.model.miso import zf_beams

__all__ = ["AO_GAP", "MISO_SIZE", "SETTINGS", "check_miso_record", "miso_content", "miso_tasks", "solve_miso"]

#: The MISO-control suite's spawn key (its entropy is ``draws.ENTROPY`` unless given) and size.
MISO_SPAWN_KEY = (43,)
#: The settings (N_t, K, M, objective), the objective varying fastest, then M, then K, then N_t.
SETTINGS = tuple(itertools.product((2, 4, 8), (2, 4), (16, 64), ("sum", "maxmin")))
MISO_SIZE = 2 * len(SETTINGS)
#: Episodes of MRT with random phases per scenario (``mrt_random``'s mean).
RANDOM_EPISODES = 3
#: Relative slack of "no row above the AO optimum" and "the replay is not below it": the float
#: rounding of two float64 sums of the same slot values (a setting the AO missed would be far above).
ROW_REL = 1e-9
#: The AO's stated gap to its certified bound: on every scenario optimum >= (1 - AO_GAP) bound.
#: The bound (``miso.slot_bounds``) relaxes the users' interference, so the gap is that of a
#: relaxation, widest for max-min with K = 4 on 2 antennas; the frozen suite's largest is in its
#: description and docs/leaderboard.md.
AO_GAP = 0.9


def miso_tasks(n: int, seed: int) -> list[dict[str, Any]]:
    """The first ``n`` MISO-control tasks ``{"index", "miso", "seed"}`` (module docstring, "Draws")."""

    def keywords(i: int) -> dict[str, Any]:
        n_t, k, m, objective = SETTINGS[i % len(SETTINGS)]
        side = int(round(m**0.5))
        return {"antennas": n_t, "users": k, "elements": [side, side], "objective": objective}

    return drawn_tasks(n, seed, MISO_SPAWN_KEY, "miso", keywords)


def solve_miso(
    task: Mapping[str, Any], entropy: int, random_episodes: int = RANDOM_EPISODES
) -> dict[str, Any]:
    """The reference record of a MISO-control task (module docstring, "References"); ``entropy``:
    the draws' (the random phases' stream)."""
    miso, seed, index = dict(task["miso"]), int(task["seed"]), int(task["index"])
    scored, env = make_miso_env(miso, {}), make_miso_env(miso, {"optimum": False})
    try:
        base = scored.unwrapped
        solutions: list[Any] = []
        mrt = setting_policy(scored, aligned_setting)

        def keep(obs: np.ndarray) -> np.ndarray:  # MRT aligned, keeping the previous slot's AO setting
            if base.slot:
                solutions.append(base.solution)
            return mrt(obs)

        scored.reset(seed=seed)
        config = base.config
        record: dict[str, Any] = {"index": index, "miso": miso, "seed": seed, "config": config.to_dict()}
        start = time.perf_counter()
        best = star_episode(scored, keep, seed, config, f"scenario {index}", "bound")
        seconds = time.perf_counter() - start - best.seconds
        solutions.append(base.solution)
        plan = iter(solutions)

        def play(act: Any) -> float:
            return star_episode(env, act, seed, config, f"scenario {index}", "bound").value

        def replay(obs: np.ndarray) -> np.ndarray:  # the AO setting of the slot, as an action
            solution = next(plan)
            return env.unwrapped.action_of(solution.phases, solution.beams)

        replayed = play(replay)
        record["optimum"] = {"rate": best.optimum, "replayed": replayed, "seconds": seconds}
        record["bound"] = {"upper_bound": best.bound}
        record["mrt_aligned"] = {"rate": best.value}
        if miso["antennas"] >= miso["users"]:
            zf = functools.partial(aligned_setting, precoder=zf_beams)
            record["zf_aligned"] = {"rate": play(setting_policy(env, zf)), "feasible": True}
        else:
            record["zf_aligned"] = {"rate": 0.0, "feasible": False}
        stream = np.random.SeedSequence(entropy=int(entropy), spawn_key=(*MISO_SPAWN_KEY, index))
        rng = np.random.default_rng(stream)
        values = [play(setting_policy(env, random_setting(rng))) for _ in range(random_episodes)]
        record["mrt_random"] = {"rate": float(np.mean(values)), "episodes": int(random_episodes)}
        record["direct"] = {"rate": play(DirectMRT().bind(MisoTask.of(miso, env)))}
    finally:
        scored.close()
        env.close()
    return record


#: A task's cache file stem: ``miso_``, its index and a hash of its keywords, seed and settings.
miso_key = functools.partial(task_key, random_episodes=RANDOM_EPISODES, field="miso")


def describe(index: int, record: Mapping[str, Any]) -> str:
    """The progress bar's note on a finished task."""
    o, b = record["optimum"]["rate"], record["bound"]["upper_bound"]
    return f"#{index}: AO {o:.4f} / bound {b:.4f} bps/Hz, MRT aligned {record['mrt_aligned']['rate']:.4f}"


def longest_first(task: Mapping[str, Any]) -> float:
    """The runner's order: max-min first (its AO balances the rates), then by N_t K M."""
    s = task["miso"]
    return -(1000 * (s["objective"] == "maxmin") + s["antennas"] * s["users"] * s["elements"][0] ** 2)


def check_miso_record(rec: Mapping[str, Any]) -> list[str]:
    """The sanity notes of one record: an optimum that is not > 0, above the bound or further below
    it than :data:`AO_GAP`, its replay below it, a row above it (:data:`ROW_REL`)."""
    i, notes = rec["index"], []
    opt, ub = float(rec["optimum"]["rate"]), float(rec["bound"]["upper_bound"])
    if not opt > 0:
        notes.append(f"#{i}: optimum {opt!r} is not > 0")
    if opt > ub * (1.0 + BOUND_REL):
        notes.append(f"#{i}: optimum {opt:.9g} > bound {ub:.9g} bps/Hz")
    if opt < (1.0 - AO_GAP) * ub:
        notes.append(f"#{i}: optimum {opt:.9g} is {100 * (1 - opt / ub):.2f}% below its bound {ub:.9g}, "
                     f"more than the stated gap {100 * AO_GAP:g}%")  # fmt: skip
    if rec["optimum"]["replayed"] < opt * (1.0 - ROW_REL):
        notes.append(f"#{i}: the AO's actions score {rec['optimum']['replayed']:.12g}, below {opt:.12g}")
    for name in MISO_REFERENCES[2:]:
        if rec[name]["rate"] > opt * (1.0 + ROW_REL):
            notes.append(f"#{i}: {name} {rec[name]['rate']:.9g} > optimum {opt:.9g} bps/Hz")
    return notes


def ao_gaps(records: Sequence[Mapping[str, Any]]) -> np.ndarray:
    """Each record's AO gap to its bound, 1 - optimum / bound."""
    return np.array([1.0 - r["optimum"]["rate"] / r["bound"]["upper_bound"] for r in records])


def miso_content(
    records: Sequence[Mapping[str, Any]], name: str, version: int, *, seed: int, random_episodes: int
) -> dict[str, Any]:
    """The content of a MISO-control suite from the records of :func:`solve_miso` (``ValueError``
    naming the scenario where :func:`check_miso_record` has a note)."""
    scenarios = []
    for rec in records:
        entry = scenario_entry(rec, check_miso_record, "miso", MISO_FIELDS)
        entry["mrt_aligned"] = {"rate": float(rec["mrt_aligned"]["rate"])}
        entry["zf_aligned"] = {"rate": float(rec["zf_aligned"]["rate"]),
                               "feasible": bool(rec["zf_aligned"]["feasible"])}  # fmt: skip
        entry["mrt_random"] = {"rate": float(rec["mrt_random"]["rate"]),
                               "episodes": int(rec["mrt_random"]["episodes"])}  # fmt: skip
        entry["direct"] = {"rate": float(rec["direct"]["rate"])}
        scenarios.append(entry)
    gaps = ao_gaps(records)
    return {
        "format": FORMAT,
        "name": name,
        "version": int(version),
        "kind": MISO_CONTROL,
        "env_id": MISO_ENV_ID,
        "env_kwargs": {},
        "normalizer": "optimum",
        "references": list(MISO_REFERENCES),
        "description": " ".join(
            (
                f"{len(scenarios)} held-out episodes of MISOControl-v0 (the agent sets an N_t-antenna",
                "UAV's K beams and a small IOS's M phases every slot as it flies a drawn line past it):",
                "scenario i takes the setting i mod 24 of N_t in {2, 4, 8}, K in {2, 4}, M in {16, 64}",
                "(square) and the objective sum or maxmin, and an episode seed drawn in turn from",
                f"default_rng(SeedSequence(entropy={int(seed)}, spawn_key={MISO_SPAWN_KEY})); config: the",
                "episode's scenario (its line), checked at every rollout. Values are mean slot",
                "objectives (bps/Hz, the env's reward sum / N). optimum: the per-slot AO optima",
                "(miso_slot.slot_optimum warm-started, the normaliser; seconds: the scoring episode's",
                "time, one process on a busy 2-core machine; replayed: its settings played as actions);",
                "bound: the certified per-slot upper bounds (miso.slot_bounds). The AO is within its",
                f"stated gap of {100 * AO_GAP:g}% of the bound on every scenario (optimum >= (1 - gap)",
                f"bound; here the largest gap is {100 * gaps.max():.2f}%, the mean",
                f"{100 * gaps.mean():.2f}%). mrt_aligned / zf_aligned: equal-power MRT / ZF with the best",
                "user's aligned phases (ZF 0 and infeasible where N_t < K); mrt_random: MRT with uniform",
                f"random phases, the mean of {int(random_episodes)} episodes drawn from",
                f"default_rng(SeedSequence(entropy={int(seed)}, spawn_key=({MISO_SPAWN_KEY[0]}, index)));",
                "direct: the DirectMRT heuristic on the observation.",
            )
        ),
        "source": {
            "entropy": int(seed),
            "spawn_key": list(MISO_SPAWN_KEY),
            "sampler": "SETTINGS[i % 24], then rng.integers(0, 2**31 - 1): the episode seed",
            "random_episodes": int(random_episodes),
            "ao_gap": AO_GAP,
        },
        "scenarios": scenarios,
    }
