"""No literal column index in the compiled kernels: they address the columns of their arrays by
name (the module constants derived from ``STATE``, ``EPISODE``, ``INFO``, ``FLAGS`` and the
observation's layout in ``ios_uav_env.envs.single_kernels``; from ``LAYER``, ``SETTINGS`` and
``STATS`` in ``agents.fast.kernel``), never by number (``ep[i, 29]``, ``flags[6]``,
``ep[i, 13 + j]``).

The check reads each module's source: every array a function body subscripts is either one whose
columns have names (its column index may hold no int literal at all: ``ep[i, EP_ELEMENTS + j]``,
``obs[i, k + OBS_MOVE_X]``) or one listed as having none (actions, paths, the nets' activations,
...). An array name in neither list fails the test until it is classified, so that a kernel cannot
slip a literal index past the check under a new name.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from agents.fast import kernel as fast_kernel
from ios_uav_env.envs import observation_layout as layout
from ios_uav_env.envs import single_kernels as sk

ROOT = Path(__file__).resolve().parents[2]

#: Per kernel module: (the names its functions give the arrays whose columns are named, the names
#: of arrays without named columns, whose indices are free).
MODULES = {
    "ios_uav_env/envs/single_kernels.py": (
        {"state", "st", "episode", "ep", "info", "flags", "obs"},
        {
            "actions", "normals", "path", "targets",  # (x, y) pairs per row
            "rows", "moves", "active", "reward", "terminated", "planned",  # one entry per row / entry
            "peak",  # episode_row's (x, y, rate) argument
        },
    ),
    "agents/fast/kernel.py": (
        {"layers", "settings", "stats"},
        {
            "theta", "grad", "exp_avg", "exp_avg_sq", "db", "b",  # flat parameter vectors and slices
            "obs", "actions", "mean", "d_mean", "h", "d", "y", "acts",  # the nets' rows and activations
            "value", "d_value",  # the critic's single output
            "advantages", "old_logp", "logp", "returns", "orders", "inv_var", "g_log_std",
            "values",  # update_settings' keyword arguments
        },
    ),
}  # fmt: skip


def literal_columns(source: str, named: set[str], free: set[str]) -> list[str]:
    """The offending subscripts of ``source`` (as ``line: text``): a named array's column index
    (the last index; the only one of a 1-D array) holding an int literal, or any subscript of an
    array name in neither ``named`` nor ``free``. Only function bodies count (not annotations)."""
    found = []
    tree = ast.parse(source)
    for function in ast.walk(tree):
        if not isinstance(function, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        for statement in function.body:
            for node in ast.walk(statement):
                if not (isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name)):
                    continue
                name = node.value.id
                index = node.slice
                column = index.elts[-1] if isinstance(index, ast.Tuple) else index
                literal = any(isinstance(n, ast.Constant) and type(n.value) is int for n in ast.walk(column))
                if (name in named and literal) or name not in named | free:
                    found.append(f"{node.lineno}: {ast.unparse(node)}")
    return sorted(set(found), key=lambda s: int(s.split(":")[0]))


@pytest.mark.parametrize("path", sorted(MODULES))
def test_kernels_index_columns_by_name(path: str) -> None:
    named, free = MODULES[path]
    found = literal_columns((ROOT / path).read_text(), named, free)
    assert not found, (
        f"{path}: a literal column index, or an array the check does not know (name its columns "
        f"with the module's constants, or classify the array in {__name__}.MODULES):\n" + "\n".join(found)
    )


def test_the_check_catches_literal_columns() -> None:
    """What the kernels looked like before their columns had names is refused; names pass."""
    named, free = MODULES["ios_uav_env/envs/single_kernels.py"]
    old = (
        "def f(obs, ep, st, flags, info, e, i, k):\n"
        "    obs[i, k + 3] = ep[i, 29]\n"
        "    for j in range(5):\n"
        "        obs[i, k + j] = ep[i, 13 + j]\n"
        "    if flags[6] != 0.0:\n"
        "        info[i, 16] = st[i, 3]\n"
        "    return e[i, 0]\n"
    )
    assert {int(line.split(":")[0]) for line in literal_columns(old, named, free)} == {2, 4, 5, 6, 7}
    new = (
        "def f(obs, ep, st, flags, info, i, k):\n"
        "    obs[i, k + OBS_MOVE_X] = ep[i, EP_ENERGY_WEIGHT]\n"
        "    for j in range(N_INSTANCE_VALUES):\n"
        "        obs[i, k + OBS_ELEMENTS + j] = ep[i, EP_ELEMENTS + j]\n"
        "    if flags[FLAG_ENERGY] != 0.0:\n"
        "        info[i, INFO_ENERGY] = st[i, ST_ENERGY]\n"
    )
    assert literal_columns(new, named, free) == []


@pytest.mark.parametrize(
    "module, names, prefix",
    [
        (sk, sk.STATE, "ST_"),
        (sk, sk.EPISODE, "EP_"),
        (sk, sk.INFO, "INFO_"),
        (sk, sk.FLAGS, "FLAG_"),
        (sk, layout.OBS_NAMES, "OBS_"),
        (fast_kernel, fast_kernel.SETTINGS, "SETTING_"),
        (fast_kernel, fast_kernel.LAYER, "LAYER_"),
        (fast_kernel, fast_kernel.STATS, "STAT_"),
    ],
)
def test_every_column_has_its_constant(module: object, names: tuple[str, ...], prefix: str) -> None:
    """Each entry of a column tuple has the constant ``prefix + NAME`` at its position, a plain int
    (what numba compiles as a constant)."""
    for k, name in enumerate(names):
        value = getattr(module, prefix + name.upper())
        assert type(value) is int and value == k, (prefix + name.upper(), value, k)


def test_observation_blocks_match_the_layout() -> None:
    """The appended blocks' constants are offsets in ``observation_layout``'s blocks, and the
    instance values that ``_observe`` copies as a run of columns are the same names in the same
    order in ``EPISODE`` and in the observation."""
    for names, constants in (
        (layout.INSTANCE_NAMES, ("OBS_ELEMENTS", "OBS_SECONDS_LEFT")),
        (layout.ENERGY_NAMES, ("OBS_MOVE_X", "OBS_MOVE_Y", "OBS_ENERGY_WEIGHT", "OBS_MIN_POWER_MOVE")),
        (layout.PEAK_NAMES, ("OBS_DX_PEAK", "OBS_DY_PEAK", "OBS_RATE_PEAK")),
    ):
        for constant in constants:
            assert names[getattr(sk, constant)] == constant.removeprefix("OBS_").lower()
    assert (sk.N_OBS, sk.N_INSTANCE, sk.N_ENERGY) == (
        len(layout.OBS_NAMES), len(layout.INSTANCE_NAMES), len(layout.ENERGY_NAMES),
    )  # fmt: skip
    run = sk.N_INSTANCE_VALUES
    copied = sk.EPISODE[sk.EP_ELEMENTS : sk.EP_ELEMENTS + run]
    assert copied == layout.INSTANCE_NAMES[sk.OBS_ELEMENTS : sk.OBS_ELEMENTS + run]
    assert sk.OBS_SECONDS_LEFT not in range(sk.OBS_ELEMENTS, sk.OBS_ELEMENTS + run)
