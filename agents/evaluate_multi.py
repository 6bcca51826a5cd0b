"""Multi-node agents (trained on ``ios_uav_env/IOSUAV-MultiNode-v0`` or ``-Random-v0``) against the
planners on one scenario: table (markdown + CSV) and the shares figure.

``python -m agents.evaluate <model folders>`` comes here when the models were trained on a
multi-node id (:data:`MULTINODE_IDS`); the scenario is the fixed id's, ``ScenarioConfig(
ground_nodes=DEFAULT_NODES)`` (``--scenario`` fields applied to it). The references are the
multi-node suite's (``baselines.references.solve_scenario``): SCA (BCD), the tour
heuristic and the certified upper bound (``baselines.dp_bound``, 2.5 m), each scenario's record
cached as one JSON file in :data:`REFERENCE_CACHE` (``baselines.references.task_key``, written
atomically; the key hashes the config and the settings) when every planner succeeded: a failed
solve raises and is never cached, so the next run solves again. On the default scenario: SCA
0.471001, tour 0.468872, bound 0.474066 bps/Hz.

The scenario must have K >= 2 nodes and at most each agent's ``max_nodes``
(:func:`check_agents`); both are checked before any reference is solved.

Each agent runs deterministically in its own env (a fixed id made on the scenario with the
model's ``max_nodes``; the randomised id pinned with ``reset(options={"config": cfg})``) and is
scored like every multi-node plan (``ios_uav_env.benchmark``): its own min rate (its
shares), the best schedule of its trajectory, % of SCA and of the bound, feasibility.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agents.report import Row
from ios_uav_env import ScenarioConfig
from ios_uav_env.benchmark.metrics import METRICS
from ios_uav_env.benchmark.results import ScenarioResult
from ios_uav_env.benchmark.scoring import episode
from ios_uav_env.benchmark.suite import MULTI_NODE, SuiteScenario
from ios_uav_env.envs.multi import DEFAULT_NODES
from ios_uav_env.envs.registration import MULTINODE_IDS
from ios_uav_env.io import atomic_write_text, save_figure, save_rows_csv
from ios_uav_env.model.score import score_plan

DEFAULT_MULTI = ScenarioConfig(ground_nodes=DEFAULT_NODES)
REFERENCE_CACHE = Path("out/multinode-references")
#: The files a comparison writes to its folder (one node, ``agents.evaluate``, or several).
COMPARISON_FILES: tuple[str, ...] = ("comparison.md", "comparison.csv", "comparison.png")
COLUMNS = ("scheme", "kind", "rate", "best_schedule_rate", "pct_sca", "pct_bound", "feasible", "wall_time_s")


def is_multinode(policy: Any) -> bool:
    """Whether ``policy`` (an ``agents.loading.Agent``) was trained on a multi-node id."""
    return getattr(policy, "env_id", None) in MULTINODE_IDS


def references(config: ScenarioConfig, cache: str | Path = REFERENCE_CACHE) -> dict[str, Any]:
    """SCA, tour and bound records of ``config`` (trajectories and shares included), read from
    ``cache`` or solved; a solved record is cached only if every planner succeeded
    (``RuntimeError`` naming the failures otherwise, nothing written)."""
    from baselines.references import solve as reference_solve
    from baselines.runner import cached_records

    (task,) = reference_solve.tasks_of([config])
    required = reference_solve.REQUIRED["multi-node"]
    cached = cached_records([task], cache, reference_solve.task_key, required)
    if 0 in cached and not reference_failures(cached[0]):
        return cached[0]
    record = reference_solve.solve_scenario(task)
    failures = reference_failures(record)
    if failures:
        raise RuntimeError(f"the references of {config} failed (not cached): " + "; ".join(failures))
    atomic_write_text(Path(cache) / f"{reference_solve.task_key(task)}.json", json.dumps(record))
    return record


def reference_failures(record: dict[str, Any]) -> list[str]:
    """What failed in a reference record: a planner that raised (its error), an SCA rate that is
    not > 0 (the normaliser), a bound that is missing."""
    parts = {k: record.get(k) for k in ("tour", "sca", "bound")}
    missing = [k for k, part in parts.items() if not isinstance(part, dict)]
    failures = [
        f"{k}: {part['error']}" for k, part in parts.items() if k not in missing and part.get("error")
    ]
    failures += [f"{k}: no record" for k in missing]
    if not missing and not (record["sca"].get("rate") or 0.0) > 0.0:
        failures.append(f"sca: rate {record['sca'].get('rate')!r} is not > 0")
    if not missing and record["bound"].get("upper_bound") is None:
        failures.append("bound: no upper bound")
    return list(dict.fromkeys(failures))


def reference_scenario(config: ScenarioConfig, record: dict[str, Any]) -> SuiteScenario:
    """``config`` with its reference values, as a suite scenario (the scorer's normalisers)."""
    reference = {
        k: {f: v for f, v in record[k].items() if f not in ("trajectory", "shares")}
        for k in ("sca", "tour", "bound")
    }
    if not reference["sca"]["rate"] or reference["bound"].get("upper_bound") is None:
        raise RuntimeError(f"no SCA rate or no bound for {config}: {record['sca']}, {record['bound']}")
    return SuiteScenario(0, config, reference)


def planner_rows(scenario: SuiteScenario, record: dict[str, Any]) -> list[Row]:
    """SCA and the tour (their plans scored again through the scorer) and the upper bound."""
    rows = []
    for key, label in (("sca", "SCA (BCD)"), ("tour", "tour heuristic")):
        rec = record[key]
        if rec.get("trajectory") is None:
            rows.append(Row(label, "planner", 0.0, False, rec["seconds"], config=scenario.config,
                            best_schedule_rate=0.0, pct={"sca": 0.0, "bound": 0.0}))  # fmt: skip
            continue
        q, a = np.asarray(rec["trajectory"]), np.asarray(rec["shares"])
        r = ScenarioResult.of(
            scenario, METRICS[MULTI_NODE], score_plan(scenario.config, q, a), rec["seconds"]
        )
        rows.append(_row(label, "planner", r, q, a))
    ub, b = scenario.rate("bound"), record["bound"]
    pct = {"sca": 100 * ub / scenario.rate("sca"), "bound": 100.0}
    rows.append(Row(f"upper bound ({b['resolution']:g} m)", "bound", ub, True, b["seconds"],
                    config=scenario.config, best_schedule_rate=ub, pct=pct))  # fmt: skip
    return rows


def node_width(env_kwargs: Any) -> int:
    """The features of a node block of the multi-node env made with ``env_kwargs``:
    ``NODE_FEATURES``, plus ``NODE_PEAK_FEATURES`` with ``peak_hint``."""
    from ios_uav_env.envs.multi import NODE_FEATURES, NODE_PEAK_FEATURES

    hint = bool(dict(env_kwargs or {}).get("peak_hint", False))
    return len(NODE_FEATURES) + (len(NODE_PEAK_FEATURES) if hint else 0)


def model_layout(agent: Any) -> Any:
    """The observation layout of the model of ``agent`` (``agents.node_orders.NodeLayout``): the
    multi-node env's with its env_kwargs' ``peak_hint`` (node blocks of :func:`node_width`) and,
    with ``objective="energy_efficiency"``, the energy features after the node blocks, K_max
    read from the observation's size; None without a model. ``ValueError`` naming the agent if
    the size is not such a layout's."""
    from agents.node_orders import exact_layout
    from ios_uav_env.envs.multi import BASE_FEATURES
    from ios_uav_env.envs.observation_layout import ENERGY_NAMES

    shape = getattr(getattr(getattr(agent, "model", None), "observation_space", None), "shape", None)
    if shape is None:
        return None
    kwargs = dict(getattr(agent, "env_kwargs", {}) or {})
    per_node = node_width(kwargs)
    energy = kwargs.get("objective") == "energy_efficiency"
    after = len(ENERGY_NAMES) if energy else 0
    k_max, extra = divmod(int(shape[0]) - len(BASE_FEATURES) - after, per_node)
    if extra or k_max < 1:
        energy_part = f" + {after} energy features ({', '.join(ENERGY_NAMES)})" if energy else ""
        raise ValueError(
            f"{getattr(agent, 'name', 'agent')}: observations of shape {tuple(shape)} are not "
            f"a multi-node env's ({len(BASE_FEATURES)} + {per_node} per node{energy_part}, as its "
            f"env_kwargs {kwargs} make)"
        )
    return exact_layout(k_max, bool(kwargs.get("peak_hint", False)), energy)


def model_max_nodes(agent: Any, default: int = 4) -> int:
    """K_max of the model's observation (:func:`model_layout`: ``len(BASE_FEATURES)`` + K_max
    node blocks of :func:`node_width` features each, then the energy features with the energy
    objective); ``default`` if unknown."""
    layout = model_layout(agent)
    return default if layout is None else layout.k_max


def agent_max_nodes(agent: Any) -> int | None:
    """The most nodes ``agent`` can act on: its model's observation's K_max
    (:func:`model_max_nodes`), else its env_kwargs' ``max_nodes``; None if neither is known."""
    if getattr(getattr(getattr(agent, "model", None), "observation_space", None), "shape", None) is not None:
        return model_max_nodes(agent)
    given = dict(getattr(agent, "env_kwargs", {}) or {}).get("max_nodes")
    return None if given is None else int(given)


def check_agents(agents: Sequence[Any], config: ScenarioConfig) -> None:
    """``ValueError`` naming the agent if ``config`` cannot be compared on: fewer than 2 nodes (the
    multi-node references), or more nodes than an agent's :func:`agent_max_nodes`."""
    if config.K < 2:
        raise ValueError(
            f"the multi-node comparison needs a scenario of K >= 2 ground_nodes, got K = {config.K}"
        )
    for agent in agents:
        k_max = agent_max_nodes(agent)
        if k_max is not None and config.K > k_max:
            raise ValueError(
                f"the scenario has K = {config.K} ground_nodes, but {getattr(agent, 'name', 'the agent')} "
                f"observes at most max_nodes = {k_max}: give at most {k_max} nodes"
            )


def agent_env(agent: Any, config: ScenarioConfig) -> Any:
    """The env ``agent`` runs in on ``config``: its fixed id made on it with the model's
    ``max_nodes``, or its randomised id (pinned per reset)."""
    import gymnasium as gym

    kwargs = dict(agent.env_kwargs)
    if MULTINODE_IDS.get(agent.env_id, {}).get("random_nodes") is None:
        kwargs.setdefault("max_nodes", model_max_nodes(agent, config.K))
        kwargs["config"] = config
    return gym.make(agent.env_id, **kwargs)


def fast_act(agent: Any) -> Any:
    """An SB3 agent's numpy export (the same actions without SB3's per-call overhead, and its
    ``repeat``), else its act."""
    if getattr(agent, "model", None) is not None:
        from agents.numpy_policy import NumpyPolicy

        repeat = getattr(agent, "repeat", 1)
        return NumpyPolicy.from_sb3(agent.model, getattr(agent, "vecnormalize", None), repeat).act
    return agent.act if hasattr(agent, "act") else agent


def agent_row(agent: Any, scenario: SuiteScenario) -> Row:
    """Roll ``agent`` out deterministically on the scenario and score its plan."""
    env = agent_env(agent, scenario.config)
    try:
        r = episode(env, fast_act(agent), scenario, 0, METRICS[MULTI_NODE])
    finally:
        env.close()
    return _row(getattr(agent, "name", "agent"), "agent", r, r.trajectory, r.shares)


def _row(scheme: str, kind: str, r: ScenarioResult, trajectory: Any, shares: Any) -> Row:
    """A table row from a plan's scores (% of SCA and of the bound 0 for an infeasible plan)."""
    return Row(scheme, kind, r.rate, r.feasible, r.seconds, trajectory, r.config,
               best_schedule_rate=r.best_schedule_rate, shares=shares, pct=dict(r.pct))  # fmt: skip


def compare_multi(
    agents: Sequence[Any], config: ScenarioConfig = DEFAULT_MULTI, cache: str | Path = REFERENCE_CACHE
) -> list[Row]:
    """The table's rows: SCA, the tour, the bound, then the agents, on ``config`` (checked by
    :func:`check_agents` first)."""
    check_agents(agents, config)
    record = references(config, cache)
    scenario = reference_scenario(config, record)
    return planner_rows(scenario, record) + [agent_row(a, scenario) for a in agents]


def markdown_table(rows: Sequence[Row]) -> str:
    lines = [
        "| scheme | min rate (own shares) | best-schedule rate | % of SCA | % of bound | feasible "
        "| wall time (s) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        feasible = "-" if r.kind == "bound" else "yes" if r.feasible else "NO"
        lines.append(
            f"| {r.scheme} | {r.rate:.6f} | {r.best_schedule_rate:.6f} | {r.pct_sca:.2f} | "
            f"{r.pct_bound:.2f} | {feasible} | {r.wall_time:.2f} |"
        )
    return "\n".join(lines)


def save_table_csv(rows: Sequence[Row], path: str | Path) -> Path:
    """Write the rows as CSV (full precision) atomically."""
    values = (
        {
            "scheme": r.scheme,
            "kind": r.kind,
            "rate": r.rate,
            "best_schedule_rate": r.best_schedule_rate,
            "pct_sca": r.pct_sca,
            "pct_bound": r.pct_bound,
            "feasible": r.feasible,
            "wall_time_s": r.wall_time,
        }
        for r in rows
    )
    return save_rows_csv(path, COLUMNS, values)


def save_shares_figure(rows: Sequence[Row], config: ScenarioConfig, path: str | Path) -> Path:
    """One column per plan (planners and agents): the trajectory coloured by the node served over
    the best-node rate map, above each node's share against the slot."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from ios_uav_env.benchmark.figures import shares_panels

    plans = [r for r in rows if r.trajectory is not None and r.shares is not None]
    fig = Figure(figsize=(5.2 * max(1, len(plans)), 6.2), dpi=100)
    FigureCanvasAgg(fig)
    for col, r in enumerate(plans):
        title = f"{r.scheme}: min rate {r.rate:.4f} ({r.pct_sca:.1f}% of SCA)"
        shares_panels(
            fig.add_subplot(2, len(plans), col + 1),
            fig.add_subplot(2, len(plans), len(plans) + col + 1),
            config,
            r.trajectory,
            r.shares,
            title if math.isfinite(r.rate) else r.scheme,
        )
    fig.tight_layout()
    return save_figure(fig, path)


def run(
    agents: Sequence[Any],
    config: ScenarioConfig,
    out: str | Path,
    cache: str | Path = REFERENCE_CACHE,
    *,
    overwrite: bool = False,
) -> None:
    """Compare, print the table, write ``comparison.md``, ``comparison.csv`` and ``comparison.png``
    (a comparison already in ``out`` is refused before anything is solved, ``FileExistsError``,
    unless ``overwrite``)."""
    from ios_uav_env.benchmark.outputs import claim, remove_stale

    out = Path(out)
    previous = claim(out, COMPARISON_FILES, overwrite)
    rows = compare_multi(agents, config, cache)
    table = markdown_table(rows)
    print(table)
    written = [atomic_write_text(out / "comparison.md", table + "\n")]
    written.append(save_table_csv(rows, out / "comparison.csv"))
    print(f"table: {written[0]}, {written[1]}")
    written.append(save_shares_figure(rows, config, out / "comparison.png"))
    print(f"figure: {written[-1]}")
    remove_stale(previous, written)
