"""The tour heuristic as an expert for imitation (``agents.imitation``): its plans of training
scenarios, the action that tracks a plan from any state, and labelled episodes.

- :func:`tour_plans`: ``baselines.tour.solve`` on training scenarios ``first_seed + i``
  (``sample_multinode(np.random.default_rng(first_seed + i))``, disjoint from the suite's seed
  sequence), cached one JSON file each by ``baselines.runner.run_tasks`` (parallel, resumable,
  a progress bar).
- :meth:`ExpertPlan.action`: at step n, full speed towards the plan's q[n+1]
  (``policies.full_speed_move``) and the plan's shares of that slot as node scores
  (``multinode_env.share_scores``), so it labels states off the plan too.
- :func:`rollouts`: one episode per plan, each a row of the batched env pinned to its scenario,
  all in lockstep, played by the expert (with optional move noise) or a policy, every state
  labelled by the expert (:func:`expert_actions`, the batch of :meth:`ExpertPlan.action`).
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
        scores = [self.node_scores(sharpness)]
        return expert_actions(
            [self], scores, np.zeros(1, dtype=np.int64), step, np.reshape(position, (1, 2)), k_max
        )[0]

    def node_scores(self, sharpness: float) -> np.ndarray:
        """The plan's shares as node scores (``share_scores``), (K, N): the labels' scores of every
        slot an action can aim at (1 .. N - 1; column 0, q0's slot, which the env shares equally
        and no action aims at, is left 0)."""
        scores = np.zeros_like(self.shares, dtype=np.float64)
        scores[:, 1:] = share_scores(self.shares[:, 1:], sharpness)
        return scores


def expert_actions(
    plans: list[ExpertPlan], scores: list[np.ndarray], rows: np.ndarray, step: int, positions: np.ndarray,
    k_max: int,
) -> np.ndarray:  # fmt: skip
    """:meth:`ExpertPlan.action` of ``plans[i]`` for each i of ``rows`` at one ``step``, from
    ``positions`` ((len(rows), 2) m), as a (len(rows), 2 + k_max) float32 batch; ``scores[i]``: the
    node scores of ``plans[i]``'s shares (:meth:`ExpertPlan.node_scores`), computed once."""
    index = [int(i) for i in np.asarray(rows).reshape(-1)]
    slots = [min(int(step) + 1, len(plans[i].trajectory) - 1) for i in index]
    targets = np.zeros((len(index), 2))
    steps = np.zeros((len(index), 1))
    for j, (i, n) in enumerate(zip(index, slots, strict=True)):
        targets[j], steps[j] = plans[i].trajectory[n], plans[i].config.D
    actions = np.zeros((len(index), 2 + k_max), dtype=np.float32)
    actions[:, :2] = full_speed_move(targets - np.asarray(positions, dtype=np.float64), steps)
    for j, (i, n) in enumerate(zip(index, slots, strict=True)):
        actions[j, 2 : 2 + plans[i].config.K] = scores[i][:, n]
    return actions


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

    def sample(self, fraction: float, rng: np.random.Generator) -> Dataset:
        """Each state kept with probability ``fraction`` (in (0, 1]), independently; ``ratio``
        (per episode) kept whole."""
        if not (isinstance(fraction, (int, float)) and 0 < fraction <= 1):
            raise ValueError(f"fraction: must be in (0, 1], got {fraction!r}")
        keep = rng.random(len(self.obs)) < fraction
        return Dataset(self.obs[keep], self.labels[keep], self.episode[keep], self.ratio)

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
    """One episode per plan in ``env_id`` pinned to its scenario, all in lockstep as the rows of its
    batched env (``gym.make_vec``, one row per plan): the executed action is ``policy(obs batch)``
    (None: the expert's) plus N(0, ``noise``^2) on the move; every visited state is labelled
    with the expert's action, its shares replaced by :func:`hindsight_shares`
    (``hindsight_block``; ``jobs`` processes) when that is given. ``ratio``: each episode's own
    min rate over its plan's rate. A row whose episode has ended stands still
    (``BatchedEnv.advance``) until the longest one ends."""
    import gymnasium as gym

    if not (np.isfinite(noise) and noise >= 0):
        raise ValueError(f"noise must be a finite number >= 0 (units of D), got {noise!r}")
    rng = np.random.default_rng(seed)
    # one kernel thread: a parallel launch per slot stalls whenever other work (the hindsight
    # processes, a planner) holds a core, and the kernel is a small part of a rollout anyway
    vec = gym.make_vec(env_id, num_envs=len(plans), vectorization_mode="vector_entry_point",
                       best_schedule=False, num_threads=1, **env_kwargs)  # fmt: skip
    obs, info = vec.reset(options={"configs": [p.config for p in plans]})
    pos = info["position"]
    k_max, sharpness = vec.max_nodes, vec.envs[0].share_sharpness
    scores = [p.node_scores(sharpness) for p in plans]
    ratio = np.zeros(len(plans))
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    live, step = np.ones(len(plans), dtype=np.bool_), 0
    actions = np.zeros((len(plans), 2 + k_max))
    while live.any():
        alive = np.flatnonzero(live)
        batch = obs[alive]
        labels = expert_actions(plans, scores, alive, step, pos[alive], k_max)
        acts = labels.copy() if policy is None else np.asarray(policy(batch), dtype=np.float32).copy()
        if noise:
            acts[:, :2] += rng.normal(0.0, noise, (len(alive), 2))
        parts.append((batch, labels, alive))
        actions[alive] = np.clip(acts, -1.0, 1.0)
        obs, _, terminated, _, info = vec.advance(actions, live)
        pos = info["position"]
        for i in np.flatnonzero(terminated):
            ratio[i] = info["min_rate"][i] / plans[i].rate
        live &= ~terminated
        step += 1
    data = Dataset(*(np.concatenate(x) for x in zip(*parts, strict=True)), ratio=ratio)
    if hindsight_block is not None:
        episodes = list(zip(vec.trajectories, vec.schedules, strict=True))
        _relabel_shares(data, [len(p[2]) for p in parts], plans, episodes, hindsight_block, sharpness, jobs)
    vec.close()
    return data


def _relabel_shares(
    data: Dataset, alive: list[int], plans: list[ExpertPlan], episodes: list[tuple[np.ndarray, np.ndarray]],
    block: int, sharpness: float, jobs: int | None,
) -> None:  # fmt: skip
    """Replace ``data``'s share labels by :func:`hindsight_shares` of each finished episode, in
    ``jobs`` processes (``baselines.runner.local_backend``: Ctrl-C is the parent's alone, and an
    interrupt stops every worker)."""
    import os

    from baselines.runner import local_backend

    tasks = [(p.config, q, shares, block) for p, (q, shares) in zip(plans, episodes, strict=True)]
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
    """The node mask columns (1 for a node of the scenario) of raw multi-node observations (S, k_max):
    ``mask_<k>``, the first of each of the ``k_max`` node blocks of ``node_width`` features after
    ``BASE_FEATURES`` (what follows the blocks, the energy features of the energy objective, is
    not read). ``ValueError`` if the observations are shorter than the blocks."""
    base = len(BASE_FEATURES)
    end = base + k_max * node_width
    if obs.ndim != 2 or obs.shape[1] < end:
        raise ValueError(
            f"obs: shape {obs.shape}; multi-node observations of {base} + {k_max} x {node_width} features "
            "(or more after the node blocks) expected"
        )
    return obs[:, base:end:node_width] > 0.5
