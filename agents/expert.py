"""The tour heuristic as an expert for imitation (``agents.imitation``): its plans of training
scenarios, the action that tracks a plan from any state, and labelled episodes.

- :func:`tour_plans`: ``baselines.tour.solve`` on training scenarios ``first_seed + i``
  (``sample_multinode(np.random.default_rng(first_seed + i))``, disjoint from the suite's seed
  sequence), cached one JSON file each by ``baselines.runner.run_tasks`` (parallel, resumable,
  a progress bar).
- :meth:`ExpertPlan.action`: at step n, full speed towards the plan's q[n+1]
  (``policies.full_speed_move``) and the plan's shares of that slot as node scores
  (``multinode_env.share_scores``), so it labels states off the plan too.
- :func:`rollouts`: one episode per plan in the env pinned to its scenario, all in lockstep,
  played by the expert (with optional move noise) or a policy, every state labelled by the expert.
- :func:`hindsight_shares`: share labels that answer the state: at slot n, the shares of the best
  continuation of the episode's own trajectory given what its executed shares served before
  (``multinode.maxmin_schedule`` with ``fixed``). The plan's shares say whom the tour serves at
  step n; off the plan (late, early, another hover point) they can starve a node, and a policy
  that sees them only learns the step count, not the balance of what was served.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env.envs.multi import BASE_FEATURES, MULTINODE_RANGES, sample_multinode, share_scores
from ios_uav_env.envs.policies import full_speed_move
from ios_uav_env.io import atomic_write_bytes
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.schedule import maxmin_schedule, node_rates

RANDOM_ID = "ios_uav_env/IOSUAV-MultiNode-Random-v0"
#: Scenario seeds of the training plans start here (the suite draws from its own SeedSequence).
FIRST_SEED = 1_000_000
PLAN_KEYS = ("trajectory", "shares", "rate")


@dataclass(frozen=True)
class ExpertPlan:
    """A tour plan of one scenario, tracked from any state: ``trajectory`` (N, 2) m, ``shares`` (K, N)."""

    config: ScenarioConfig
    trajectory: np.ndarray
    shares: np.ndarray
    rate: float  # the plan's max-min rate (its best schedule), bps/Hz

    def action(self, step: int, position: np.ndarray, k_max: int, sharpness: float) -> np.ndarray:
        """The expert's action at ``step`` (moves made so far) from ``position``: full speed towards
        the plan's position after the move, the plan's shares of that slot as scores (padded)."""
        n = min(int(step) + 1, len(self.trajectory) - 1)
        action = np.zeros(2 + k_max, dtype=np.float32)
        action[:2] = full_speed_move(self.trajectory[n] - np.asarray(position, float), self.config.D)
        action[2 : 2 + self.config.K] = share_scores(self.shares[:, n], sharpness)
        return action


def tour_record(task: dict[str, Any]) -> dict[str, Any]:
    """``run_tasks`` worker: the tour plan of the scenario of ``task["seed"]`` (JSON record)."""
    from baselines import tour

    cfg = sample_multinode(np.random.default_rng(task["seed"]), MULTINODE_RANGES, tuple(task["nodes"]))
    plan = tour.solve(cfg)
    return {"seed": task["seed"], "config": cfg.to_dict(), "trajectory": plan.trajectory.tolist(),
            "shares": plan.info["shares"], "rate": plan.mean_rate, "seconds": plan.seconds}  # fmt: skip


def tour_plans(
    n: int,
    cache: str | Path,
    first_seed: int = FIRST_SEED,
    nodes: tuple[int, int] = (2, 4),
    jobs: int | None = None,
    progress: bool = True,
) -> list[ExpertPlan]:
    """The tour plans of training scenarios ``first_seed`` .. ``first_seed + n - 1`` (cached)."""
    from baselines.runner import run_tasks
    from ios_uav_env.model.config import as_config

    tasks = [{"seed": first_seed + i, "nodes": list(nodes)} for i in range(n)]
    records = run_tasks(tour_record, tasks, cache, key=_plan_key, jobs=jobs, progress=progress,
                        desc="tour plans", unit="scenario", required=PLAN_KEYS)  # fmt: skip
    return [
        ExpertPlan(
            as_config(r["config"]),
            np.array(r["trajectory"]),
            np.array(r["shares"]),
            float(r["rate"]),
        )  # fmt: skip
        for r in records
    ]


def _plan_key(task: dict[str, Any]) -> str:
    return f"tour_{task['seed']}_{task['nodes'][0]}-{task['nodes'][1]}"


@dataclass
class Dataset:
    """Labelled states: ``obs`` (S, obs_dim), expert ``labels`` (S, act_dim), ``episode`` (S,), and per
    episode the min rate reached with the executed actions over the plan's (``ratio``)."""

    obs: np.ndarray
    labels: np.ndarray
    episode: np.ndarray
    ratio: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @classmethod
    def concat(cls, parts: list[Dataset]) -> Dataset:
        fields = ("obs", "labels", "episode", "ratio")
        return cls(*(np.concatenate([getattr(p, f) for p in parts]) for f in fields))

    def save(self, path: str | Path) -> Path:
        """Write the ``.npz`` atomically (``ios_uav_env.io.atomic_write_bytes``)."""
        buf = io.BytesIO()
        np.savez(buf, obs=self.obs, labels=self.labels, episode=self.episode, ratio=self.ratio)
        return atomic_write_bytes(path, buf.getvalue())

    @classmethod
    def load(cls, path: str | Path) -> Dataset:
        with np.load(path) as d:
            return cls(d["obs"], d["labels"], d["episode"], d["ratio"])


def hindsight_shares(rates: np.ndarray, executed: np.ndarray, block: int = 5) -> np.ndarray:
    """Share labels (K, N) of an episode with node rates ``rates`` (K, N) along its trajectory and
    ``executed`` shares (K, N): for the slots n0 .. n0 + ``block`` - 1 (n0 = 1, 1 + block, ...), the
    shares of the best continuation from n0 (``maxmin_schedule(rates, executed[:, :n0])``), the
    max-min schedule of the rest of the flight given what was served. Slot 0 (q0, shared
    equally by the env) keeps its executed shares. ``block`` = 1 re-solves at every slot."""
    r, done = np.asarray(rates, dtype=float), np.asarray(executed, dtype=float)
    if r.ndim != 2 or done.shape != r.shape:
        raise ValueError(f"rates and executed must be (K, N) arrays of one shape: {r.shape}, {done.shape}")
    if isinstance(block, bool) or not isinstance(block, int) or block < 1:
        raise ValueError(f"block: must be an integer >= 1 (slots between re-solves), got {block!r}")
    labels = done.copy()
    for n0 in range(1, r.shape[1], block):
        labels[:, n0 : n0 + block] = maxmin_schedule(r, done[:, :n0]).shares[:, n0 : n0 + block]
    return labels


def _hindsight_job(args: tuple[ScenarioConfig, np.ndarray, np.ndarray, int]) -> np.ndarray:
    config, trajectory, executed, block = args
    return hindsight_shares(node_rates(config, trajectory), executed, block)


def rollouts(
    plans: list[ExpertPlan],
    env_kwargs: dict[str, Any],
    policy: Any = None,
    noise: float = 0.0,
    seed: int = 0,
    env_id: str = RANDOM_ID,
    hindsight_block: int | None = None,
    jobs: int | None = None,
) -> Dataset:
    """One episode per plan in ``env_id`` pinned to its scenario, all in lockstep: the executed action
    is ``policy(obs batch)`` (None: the expert's) plus N(0, ``noise``^2) on the move; every
    visited state is labelled with the expert's action, its shares replaced by
    :func:`hindsight_shares` (``hindsight_block``; ``jobs`` processes) when that is given.
    ``ratio``: each episode's own min rate over its plan's rate."""
    import gymnasium as gym

    if not (np.isfinite(noise) and noise >= 0):
        raise ValueError(f"noise must be a finite number >= 0 (units of D), got {noise!r}")
    rng = np.random.default_rng(seed)
    envs = [gym.make(env_id, **env_kwargs).unwrapped for _ in plans]
    first = [env.reset(options={"config": p.config}) for env, p in zip(envs, plans, strict=True)]
    obs = [o for o, _ in first]
    pos = [i["position"] for _, i in first]
    k_max, sharpness = envs[0].max_nodes, envs[0].share_sharpness
    ratio = np.zeros(len(plans))
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    alive, step = list(range(len(plans))), 0
    while alive:
        batch = np.array([obs[i] for i in alive])
        labels = np.array([plans[i].action(step, pos[i], k_max, sharpness) for i in alive])
        acts = labels.copy() if policy is None else np.asarray(policy(batch), dtype=np.float32).copy()
        if noise:
            acts[:, :2] += rng.normal(0.0, noise, (len(alive), 2))
        parts.append((batch, labels, np.array(alive)))
        still = []
        for j, i in enumerate(alive):
            obs[i], _, terminated, _, info = envs[i].step(np.clip(acts[j], -1.0, 1.0))
            pos[i] = info["position"]
            if terminated:
                ratio[i] = info["min_rate"] / plans[i].rate
            else:
                still.append(i)
        alive, step = still, step + 1
    data = Dataset(*(np.concatenate(x) for x in zip(*parts, strict=True)), ratio=ratio)
    if hindsight_block is not None:
        _relabel_shares(data, [len(p[2]) for p in parts], plans, envs, hindsight_block, sharpness, jobs)
    return data


def _relabel_shares(
    data: Dataset, alive: list[int], plans: list[ExpertPlan], envs: list[Any], block: int, sharpness: float,
    jobs: int | None,
) -> None:  # fmt: skip
    """Replace ``data``'s share labels by :func:`hindsight_shares` of each finished episode, in
    ``jobs`` processes (``baselines.runner.local_backend``: Ctrl-C is the parent's alone, and an
    interrupt stops every worker)."""
    import os

    from baselines.runner import local_backend

    tasks = [(p.config, env.trajectory, env.shares, block) for p, env in zip(plans, envs, strict=True)]
    labels: list[Any] = [None] * len(tasks)

    def done(i: int, shares: np.ndarray) -> None:
        labels[i] = shares

    workers = max(1, min(jobs or os.cpu_count() or 1, len(tasks)))
    local_backend(_hindsight_job, list(enumerate(tasks)), workers, done)
    step = np.repeat(np.arange(len(alive)), alive)  # a row's step: rows are in lockstep order
    by_episode = np.argsort(data.episode, kind="stable")  # each episode's rows, in step order
    ends = np.cumsum(np.bincount(data.episode, minlength=len(labels)))
    for shares, rows in zip(labels, np.split(by_episode, ends[:-1]), strict=True):
        k = shares.shape[0]
        data.labels[rows, 2 : 2 + k] = share_scores(shares[:, step[rows] + 1], sharpness).T


def node_mask(obs: np.ndarray, k_max: int, node_width: int) -> np.ndarray:
    """The node mask columns (1 for a node of the scenario) of raw multi-node observations (S, k_max)."""
    base = len(BASE_FEATURES)
    return obs[:, base : base + k_max * node_width : node_width] > 0.5
