"""Both views run the one compiled row step (``ios_uav_env.envs.row_step``): no view module holds
a reset, step or flight of its own, the envs call the views' entry points
(``ios_uav_env.envs.view_steps``), and each entry point hands its view's arrays to the row step's
function of the same kind, the single-node view's as the K = 1 case (``node_blocks`` False), the
node-block view's with the node axis folded into the rows (``node_blocks`` True)."""

from __future__ import annotations

import ast
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ios_uav_env.envs import multi_kernels, row_step, single_node, single_rows, view_steps

ROOT = Path(__file__).resolve().parents[2]
#: The row step's entry points, which both views call.
STEPS = ("reset_rows", "step_rows", "step_rows_batched", "fly_rows")
#: The modules of the views' own parts (columns, writers, rows), which must not step a row.
VIEW_MODULES = (
    "ios_uav_env/envs/single_kernels.py", "ios_uav_env/envs/multi_step.py",
    "ios_uav_env/envs/multi_kernels.py", "ios_uav_env/envs/view_steps.py",
)  # fmt: skip
#: What a row step calls: a view module calling one steps a row itself.
STEPPING = ("prange", "move_row", "rate_row", "faded_row", "rate_point", "faded_point", "reward_row")
#: Each view entry point: (the row step's function it calls, node_blocks).
ENTRIES = {
    "reset_rows": ("reset_rows", False),
    "step_rows": ("step_rows", False),
    "step_rows_batched": ("step_rows_batched", False),
    "fly_rows": ("fly_rows", False),
    "reset_node_rows": ("reset_rows", True),
    "step_node_rows": ("step_rows", True),
    "step_node_rows_batched": ("step_rows_batched", True),
    "fly_node_rows": ("fly_rows", True),
}


def _functions(path: str) -> dict[str, ast.FunctionDef]:
    tree = ast.parse((ROOT / path).read_text())
    return {node.name: node for node in tree.body if isinstance(node, ast.FunctionDef)}


@pytest.mark.parametrize("path", VIEW_MODULES)
def test_no_view_steps_a_row_itself(path: str) -> None:
    """The per-view resets, steps and flights are gone: a view module defines none of the row
    step's functions (nor a row step), runs no ``prange`` loop and computes no rate or move."""
    functions = _functions(path)
    if path.endswith("view_steps.py"):  # the entry points, under the views' names: no step in them
        functions = {name: f for name, f in functions.items() if name not in ENTRIES}
    assert not set(functions) & {*STEPS, "_step_row", "_step_each"}, path
    for name, function in functions.items():
        calls = {
            ast.unparse(n.func).rsplit(".", 1)[-1] for n in ast.walk(function) if isinstance(n, ast.Call)
        }
        assert not calls & set(STEPPING), (path, name, calls & set(STEPPING))


def test_the_envs_call_the_views_entry_points() -> None:
    """The single-node env, its batched rows and the node-block rows call ``view_steps``' entry
    points (and nothing else steps them)."""
    for name in STEPS:
        assert getattr(single_rows, name) is getattr(view_steps, name)
        node_name = name.replace("_rows", "_node_rows")
        assert getattr(multi_kernels, name) is getattr(view_steps, node_name)
    assert single_node.step_rows is view_steps.step_rows
    assert single_node.reset_rows is view_steps.reset_rows


def _view_arrays(b: int, k: int, q: int, p: int, n: int) -> dict[str, np.ndarray]:
    """Arrays of the shapes a view's entry points take (B rows, K nodes, Q surface nodes, P rate
    parameters, N way-points); the single-node view's ``nodes``, ``params``, ``normals`` have no
    node axis."""
    single = k == 0
    k = max(k, 1)
    return {
        "rows": np.arange(b, dtype=np.int64), "targets": np.zeros((b, 2)),
        "moves": np.ones(b, dtype=np.int64), "actions": np.zeros((b, 2 + k)), "state": np.zeros((b, 9)),
        "episode": np.zeros((b, 28)),
        "points": np.zeros((b, k, 6)),
        "nodes": np.zeros((b, 3, q)) if single else np.zeros((b, k, 3, q)),
        "params": np.zeros((b, p)) if single else np.zeros((b, k, p)),
        "normals": np.zeros((b, 2)) if single else np.zeros((b, k, 2)),
        "served": np.zeros((b, k)), "shares": np.zeros((b, k)), "rates": np.zeros((b, k)),
        "expected": np.zeros((b, k)), "flags": np.zeros(7), "obs": np.zeros((b, 20), dtype=np.float32),
        "reward": np.zeros(b), "terminated": np.zeros(b, dtype=np.bool_), "info": np.zeros((b, 30)),
        "path": np.zeros((b, n, 2)), "share_path": np.zeros((b, n, k)), "rate_path": np.zeros((b, n, k)),
        "active": np.ones(b, dtype=np.bool_), "norms": np.zeros(b),
    }  # fmt: skip


@pytest.mark.parametrize("entry", sorted(ENTRIES))
def test_each_entry_point_hands_its_view_to_the_one_step(entry: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each entry point (its Python source, ``py_func`` where numba compiled it) calls the row
    step's function of its kind once, with its view's ``node_blocks`` and its view's arrays: the
    single-node ``nodes`` / ``params`` / ``normals`` themselves, the node blocks' folded to
    (B K, ...) views of the same memory, node k of row i at row i K + k."""
    target, node_blocks = ENTRIES[entry]
    calls: list[tuple[Any, ...]] = []
    monkeypatch.setattr(row_step, target, lambda *args: calls.append(args) or -1)
    function = getattr(view_steps, entry)
    function = getattr(function, "py_func", function)
    b, k, q, p = 3, 2, 5, 4
    arrays = _view_arrays(b, k if node_blocks else 0, q, p, 6)
    names = function.__code__.co_varnames[: function.__code__.co_argcount]
    function(*(arrays[name] for name in names))
    assert len(calls) == 1, entry
    args = calls[0]
    assert args[-1] is node_blocks
    step_names = _parameters(target)
    passed = dict(zip(step_names, args, strict=True))
    for name in ("state", "episode", "flags", "obs", "info"):
        assert passed[name] is arrays[name], (entry, name)
    if node_blocks:
        for name in ("nodes", "params", "normals"):
            folded, whole = passed[name], arrays[name]
            assert folded.shape == (b * k, *whole.shape[2:]), (entry, name)
            assert np.shares_memory(folded, whole), (entry, name)
            whole[1, 1].flat[0] = 7.0  # node 1 of row 1 is folded row 1 K + 1
            assert folded[1 * k + 1].flat[0] == 7.0, (entry, name)
        own = ("points", "served", "shares", "rates", "expected", "share_path")
        for name in own + (() if "reset" in entry else ("path", "rate_path", "norms")):
            assert passed[name] is arrays[name], (entry, name)
    else:
        for name in ("nodes", "params", "normals"):
            assert passed[name] is arrays[name], (entry, name)


def _parameters(name: str) -> tuple[str, ...]:
    """The parameter names of the row step's function ``name`` (from its source)."""
    function = _functions("ios_uav_env/envs/row_step.py")[name]
    return tuple(a.arg for a in function.args.args)
