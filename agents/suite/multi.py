"""The suite report of a multi-node agent: ``python -m agents.suite report --model <multi-node run>``.

A model trained on ``ios_uav_env/IOSUAV-MultiNode-Random-v0`` (or ``-v0``) is scored on the frozen
multi-node suite ``multi-node-v1`` of ``ios_uav_env.benchmark`` (48 held-out scenarios, 2 to 4
nodes) through the benchmark's own scorer (``ios_uav_env.benchmark``): per scenario its own
min rate (its shares), the best schedule of its trajectory, % of SCA and of the certified bound,
feasibility and plan time (the SB3 model's numpy export). A model of the fixed 3-node id observes
at most 3 nodes: it runs in the randomised id with its ``max_nodes`` and is scored on the
scenarios with K <= max_nodes only (the report says how many). Writes the benchmark's files to
``--out``: ``results.{md,csv,json}``, ``trajectories.npz`` (with the shares), ``pct_sca.png`` and
``shares.png`` (the served-node trajectories and each node's share against the slot).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from agents.evaluate_multi import fast_act, model_max_nodes
from ios_uav_env.envs.registration import MULTINODE_IDS

MULTI_SUITE = "multi-node-v1"


def suite_env_kwargs(agent: Any, max_nodes: int, suite: Any = MULTI_SUITE) -> dict[str, Any]:
    """The suite env's arguments for ``agent``: its own without its training draw
    (``ios_uav_env.benchmark.overrides.policy_env_kwargs``), with the model's ``max_nodes`` for an
    agent of the fixed id (``random_nodes`` up to it: the randomised family's observation bounds)."""
    from ios_uav_env.benchmark import Suite, load_suite
    from ios_uav_env.benchmark.overrides import policy_env_kwargs

    kwargs = policy_env_kwargs(suite if isinstance(suite, Suite) else load_suite(suite), agent, None)
    if MULTINODE_IDS.get(getattr(agent, "env_id", ""), {}).get("random_nodes") is None:
        kwargs.update(max_nodes=max_nodes, random_nodes=(min(2, max_nodes), max_nodes))
    return kwargs


def suite_names(suite: Any, kwargs: dict[str, Any]) -> tuple[str, ...]:
    """The ``observation_names`` of ``suite``'s env made with ``kwargs`` (the layout a policy of
    the report reads, the energy features after the node blocks included)."""
    import gymnasium as gym

    env = gym.make(suite.env_id, **kwargs)
    try:
        return tuple(env.unwrapped.observation_names)
    finally:
        env.close()


def multi_report(
    policy: Any,
    out: str | Path,
    n: int | None = None,
    suite: str = MULTI_SUITE,
    node_orders: bool = False,
    *,
    overwrite: bool = False,
    allow_task_change: bool = False,
) -> dict[str, Any]:
    """Score ``policy`` on the multi-node suite, print the table, write the files to ``out``.
    ``node_orders``: its action averaged over every order of the nodes
    (:class:`agents.node_orders.NodeOrderAverage`). Results already in ``out`` are refused before
    anything runs unless ``overwrite`` (``Results.save``); env arguments of the policy that
    change the suite's task only run with ``allow_task_change`` (``ios_uav_env.benchmark.overrides``)."""
    from ios_uav_env.benchmark import load_suite
    from ios_uav_env.benchmark.outputs import RESULT_FILES, claim
    from ios_uav_env.benchmark.scoring import evaluate_scenarios

    claim(out, RESULT_FILES, overwrite)
    loaded = load_suite(suite)
    k_max = model_max_nodes(policy)
    chosen = loaded.subset(n)
    scenarios = [s for s in chosen if s.config.K <= k_max]
    if not scenarios:
        raise ValueError(f"no scenario of {loaded.name} has K <= {k_max} nodes (the model's max_nodes)")
    name = getattr(policy, "name", "policy")
    kwargs = suite_env_kwargs(policy, k_max, loaded)
    act = fast_act(policy)
    if node_orders:
        from agents.node_orders import NodeOrderAverage

        act, name = (
            NodeOrderAverage.for_layout(act, suite_names(loaded, kwargs)),
            f"{name} (node orders averaged)",
        )
    results = evaluate_scenarios(act, loaded, scenarios, kwargs, 0, name, allow_task_change=allow_task_change)
    print(results.markdown())
    if len(scenarios) < len(chosen):
        print(f"note: {len(chosen) - len(scenarios)} of {len(chosen)} scenarios have more than the model's "
              f"max_nodes = {k_max} nodes and were not scored")  # fmt: skip
    paths = results.save(out, overwrite=overwrite)
    print("wrote " + ", ".join(str(p) for p in paths.values()))
    return {"summary": results.aggregate.to_dict(), "results": results, "paths": paths}
