"""The row-step core (``ios_uav_env.envs.core.kernel``) is the one move, arrival guard, power and
reward assembly of both views' compiled steps: both views' kernel modules bind the core's functions
(the same objects), none holds a copy of what the core does, and a single-node env and a node-block
env on the same one-node scenario, given the same moves, fly the same flight and book the same
power, energy, reach, terminal and energy terms and eq. (10) check."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig
from ios_uav_env.envs import multi_kernels, multi_step, multi_writers, single_kernels, single_rows
from ios_uav_env.envs.core import kernel as core
from ios_uav_env.envs.multi import MultiNodeEnv
from ios_uav_env.envs.single import IOSUAVEnv
from tests.tolerances import GOLDEN_REL

ROOT = Path(__file__).resolve().parents[2]
VIEWS = {"ios_uav_env/envs/single_kernels.py": single_kernels, "ios_uav_env/envs/multi_step.py": multi_step}
#: The modules of the writers a view's step inlines (its observation and ``info`` rows), by the step's path.
WRITERS = {"ios_uav_env/envs/multi_step.py": {"ios_uav_env/envs/multi_writers.py": multi_writers}}
#: The core's row helpers that every view's step, reset and flight run.
SHARED = (
    "move_row", "reward_row", "start_row", "violation", "observe_energy", "toward", "fly_entry_out_of_range",
)  # fmt: skip
#: What only the core calls: the arrival guard, the propulsion power, the reach and terminal terms.
CORE_ONLY = ("guarded_position", "slot_power", "move_power", "penalties")


def _calls(function: ast.FunctionDef) -> set[str]:
    return {
        ast.unparse(node.func).rsplit(".", 1)[-1] for node in ast.walk(function) if isinstance(node, ast.Call)
    }


def _functions(path: str) -> dict[str, ast.FunctionDef]:
    tree = ast.parse((ROOT / path).read_text())
    return {node.name: node for node in tree.body if isinstance(node, ast.FunctionDef)}


@pytest.mark.parametrize("path", sorted(VIEWS))
def test_both_views_bind_the_one_core(path: str) -> None:
    """Each view's kernel modules (its step's and its writers') hold the core's helpers themselves
    (not copies of them): each helper is bound in one of them at least, and wherever bound is the core's."""
    modules = [VIEWS[path], *WRITERS.get(path, {}).values()]
    for name in SHARED:
        bound = [getattr(module, name) for module in modules if hasattr(module, name)]
        assert bound and all(f is getattr(core, name) for f in bound), (path, name)
    # and the env faces call these modules' kernels
    assert single_rows.step_rows is single_kernels.step_rows
    assert multi_kernels.step_rows is multi_step.step_rows


@pytest.mark.parametrize("path", sorted(VIEWS))
def test_the_views_step_through_the_core(path: str) -> None:
    """Each view's row step moves and rewards through the core (``move_row``, ``reward_row``), its
    reset through ``start_row``, its flight through ``toward``; no view calls the guard, the
    propulsion power or the reach and terminal terms itself (nor do its writers)."""
    functions = _functions(path)
    assert {"move_row", "reward_row"} <= _calls(functions["_step_row"])
    assert "start_row" in _calls(functions["reset_rows"])
    assert {"toward", "fly_entry_out_of_range", "_step_row"} <= _calls(functions["fly_rows"])
    for source in (path, *WRITERS.get(path, {})):
        for name, function in _functions(source).items():
            assert not _calls(function) & set(CORE_ONLY), (source, name)


def _flight(env, width: int, moves: np.ndarray) -> list[dict]:
    """The infos of an episode of ``moves`` (padded with zero node scores to ``width``)."""
    _, info = env.reset(seed=0)
    infos = [info]
    for move in moves:
        action = np.zeros(width, dtype=np.float32)
        action[:2] = move
        _, _, terminated, _, info = env.step(action)
        infos.append(info)
        if terminated:
            break
    return infos


@pytest.mark.parametrize("guard", [True, False])
def test_one_node_flies_alike_in_both_views(guard: bool) -> None:
    """The single-node env and the node-block env on one scenario with one node, the same moves
    (some past the unit disk; with the guard, some pulled home): the same way-points, power,
    energy, reach, terminal and energy terms and check, step by step (to ``GOLDEN_REL``: the two
    steps are compiled with different arithmetic flags, as two CPUs would round them)."""
    cfg = ScenarioConfig(T=40.0, objective="energy_efficiency", energy_budget_j=4.0e4)
    rng = np.random.default_rng(3)
    moves = rng.uniform(-1.4, 1.4, (cfg.N, 2))
    moves[cfg.N // 2 :, 0] = -1.3  # away from qF: the guard pulls it home, the unguarded UAV misses
    single = IOSUAVEnv(cfg, arrival_guard=guard, energy_reference=1.0e4)
    multi = MultiNodeEnv(cfg, arrival_guard=guard, energy_reference=1.0e4)
    a = _flight(single, single.action_space.shape[0], moves)
    b = _flight(multi, multi.action_space.shape[0], moves)
    assert len(a) == len(b) == cfg.N
    keys = ("position", "power", "energy", "reward_reach", "reward_terminal", "reward_energy",
            "worst_violation", "terminal_miss", "distance_to_final")  # fmt: skip
    for key in keys:
        x = np.array([info[key] for info in a], dtype=np.float64)
        y = np.array([info[key] for info in b], dtype=np.float64)
        np.testing.assert_allclose(x, y, rtol=GOLDEN_REL, atol=GOLDEN_REL, err_msg=key)
    assert [info["feasible"] for info in a] == [info["feasible"] for info in b]
    assert any(info["reward_energy"] < 0.0 for info in a)
    assert guard or a[-1]["reward_terminal"] < 0.0  # (the unguarded flight's last slot misses qF)
