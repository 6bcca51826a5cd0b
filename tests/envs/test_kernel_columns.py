"""No literal column index in the compiled kernels: they address the columns of their arrays by
name (the module constants derived from ``CORE_STATE``, ``CORE_EPISODE`` and ``FLAGS`` in
``ios_uav_env.envs.core.kernel``, the row-step core both views share; from ``STATE``, ``EPISODE``,
``INFO`` and the observation's layout in ``ios_uav_env.envs.single_kernels``; from ``STATE``, ``EPISODE``,
``POINT``, ``ACTION``, ``INFO``, ``MORE`` and the observation's features in
``ios_uav_env.envs.multi_table`` for ``multi_kernels``, ``multi_step`` and ``multi_writers``; from
``PARAMS`` in ``ios_uav_env.model.rate_rows``; from ``SIZES`` and ``OUT`` in
``ios_uav_env.model.maxmin_paths``; from ``LAYER``, ``SETTINGS`` and ``STATS`` in
``agents.fast.kernel``), never by number (``ep[i, 29]``, ``flags[6]``, ``ep[i, 13 + j]``).

The check reads each module's source: every array a function body subscripts (``self.<name>``
counts as ``<name>``) is either one whose columns have names (its column index may hold no int
literal at all: ``ep[i, EP_ELEMENTS + j]``, ``obs[i, k + OBS_MOVE_X]``) or one listed as having
none (actions, paths, the nets' activations, ...). An array name in neither list fails the test
until it is classified, so that a kernel cannot slip a literal index past the check under a new
name. In a module of :data:`JIT_ONLY` only the compiled functions count (the rest being numpy on
whole arrays).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from agents.fast import kernel as fast_kernel
from ios_uav_env.envs import multi_table as mt
from ios_uav_env.envs import observation_layout as layout
from ios_uav_env.envs import single_kernels as sk
from ios_uav_env.envs.core import kernel as core
from ios_uav_env.model import maxmin_paths, rate_rows

ROOT = Path(__file__).resolve().parents[2]

#: The multi-node kernels' arrays (the row table of ``multi_kernels``, the step of ``multi_step`` and
#: its writers in ``multi_writers`` share their names).
MULTI_NODE = (
    {"state", "st", "episode", "ep", "info", "row", "obs", "o", "points", "flags", "actions", "sizes"},
    {
        "rates", "served", "shares", "expected", "share_path", "rate_path",  # one entry per node
        "nodes", "params",  # the nodes' rate kernels (rate_kernels' layout), passed whole
        "normals", "path", "targets",  # (re, im) draws and (x, y) pairs
        "rows", "moves", "active", "norms", "reward", "terminated", "stored", "loaded",  # per row
        "ended", "envs", "ok", "values", "bare",  # episode_best_values' per ended row, NodeRows.load's
        "grown", "shape",  # NodeRows._grow's
    },
)  # fmt: skip

#: Per kernel module: (the names its functions give the arrays whose columns are named, the names
#: of arrays without named columns, whose indices are free).
MODULES = {
    "ios_uav_env/envs/core/kernel.py": (
        {"state", "episode", "flags", "obs"},
        {
            "actions", "path", "targets",  # (x, y) pairs per row
            "rows", "moves", "reward", "terminated", "planned",  # one entry per row / entry
        },
    ),
    "ios_uav_env/envs/single_kernels.py": (
        {"state", "st", "episode", "ep", "info", "flags", "obs", "row"},
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
            "obs", "actions", "mean", "d_mean", "h", "d", "y", "acts", "out",  # the nets' rows, activations
            "value", "d_value",  # the critic's single output
            "advantages", "old_logp", "logp", "returns", "orders", "inv_var", "g_log_std",
            "values",  # update_settings' keyword arguments
        },
    ),
    "ios_uav_env/envs/multi_kernels.py": MULTI_NODE,
    "ios_uav_env/envs/multi_step.py": MULTI_NODE,
    "ios_uav_env/envs/multi_writers.py": MULTI_NODE,
    "ios_uav_env/envs/multi_table.py": (
        {"row", "table"},
        {"columns", "out"},  # info_arrays' columns of the table and its dict
    ),
    "ios_uav_env/model/rate_rows.py": (
        {"params"},
        {
            "nodes", "points", "out",  # the (3, K) surface nodes per row, (x, y) pairs, one per point
            "t_re", "t_im", "offset", "order", "turn_re", "turn_im",  # discrete_zeta_row's, one per element
            "count", "bucket", "fill", "src", "dst",  # offset_order's and merge_order's
        },
    ),
    "ios_uav_env/model/maxmin_paths.py": (
        {"sizes", "size", "out"},
        {"rows", "idx", "stored", "rate_path", "path", "nodes", "params", "r", "k_got", "n_got"},
    ),
}  # fmt: skip
#: The modules in which only the compiled functions (decorated with ``jit``) count.
JIT_ONLY: set[str] = set()


def _array_name(node: ast.expr) -> str | None:
    """The array name of a subscripted expression: ``name`` or ``self.name``, else None."""
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "self":
        return node.attr
    return None


def _compiled(function: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    return any("jit" in ast.unparse(decorator) for decorator in function.decorator_list)


def literal_columns(source: str, named: set[str], free: set[str], jit_only: bool = False) -> list[str]:
    """The offending subscripts of ``source`` (as ``line: text``): a named array's column index
    (the last index; the only one of a 1-D array) holding an int literal, or any subscript of an
    array name in neither ``named`` nor ``free``. Only function bodies count (not annotations),
    with ``jit_only`` only those of compiled functions."""
    found = []
    tree = ast.parse(source)
    for function in ast.walk(tree):
        if not isinstance(function, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        if jit_only and not _compiled(function):
            continue
        annotations = {
            id(n) for a in ast.walk(function) if isinstance(a, ast.AnnAssign) for n in ast.walk(a.annotation)
        }
        for statement in function.body:
            for node in ast.walk(statement):
                if not isinstance(node, ast.Subscript) or id(node) in annotations:
                    continue
                name = _array_name(node.value)
                if name is None:
                    continue
                index = node.slice
                column = index.elts[-1] if isinstance(index, ast.Tuple) else index
                literal = any(isinstance(n, ast.Constant) and type(n.value) is int for n in ast.walk(column))
                if (name in named and literal) or name not in named | free:
                    found.append(f"{node.lineno}: {ast.unparse(node)}")
    return sorted(set(found), key=lambda s: int(s.split(":")[0]))


@pytest.mark.parametrize("path", sorted(MODULES))
def test_kernels_index_columns_by_name(path: str) -> None:
    named, free = MODULES[path]
    found = literal_columns((ROOT / path).read_text(), named, free, path in JIT_ONLY)
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


def test_the_check_reads_the_multi_kernels_and_self() -> None:
    """The multi-node kernels' old literals are refused, ``self.<array>`` is checked as ``<array>``,
    and in a ``jit_only`` module a plain function is not read."""
    named, free = MODULES["ios_uav_env/envs/multi_kernels.py"]
    old = (
        "def f(o, ep, st, row, points, actions, i, j, k):\n"
        "    o[j + 4] = min(served[i, k] / ep[5], ep[27])\n"
        "    row[12 + k] = actions[i, 2 + k]\n"
        "    o[j + 1] = points[i, k, 0]\n"
        "    st[3] = 0.0\n"
        "def g(self, i):\n"
        "    self.state[i, 0:2] = self.path[i, 0]\n"
    )
    assert {int(line.split(":")[0]) for line in literal_columns(old, named, free)} == {2, 3, 4, 5, 7}
    new = (
        "def f(o, ep, st, row, points, actions, i, j, k):\n"
        "    o[j + NODE_SERVED] = min(served[i, k] / ep[MEP_N], ep[MEP_SERVED_CLIP])\n"
        "    row[N_MINFO + k] = actions[i, ACT_SCORES + k]\n"
        "    o[j + NODE_DX_NODE] = points[i, k, PT_X]\n"
        "    st[MST_EXCESS] = 0.0\n"
        "def g(self, i):\n"
        "    self.loaded: list[int] = [0]\n"
        "    self.state[i, MST_X], self.state[i, MST_Y] = self.path[i, 0]\n"
    )
    assert literal_columns(new, named, free) == []
    plain = "def f(params):\n    return params[0, 4]\n"
    assert literal_columns(plain, {"params"}, set(), jit_only=True) == []
    assert literal_columns("@jit\n" + plain, {"params"}, set(), jit_only=True) == ["3: params[0, 4]"]


@pytest.mark.parametrize(
    "module, names, prefix",
    [
        (sk, sk.STATE, "ST_"),
        (sk, sk.EPISODE, "EP_"),
        (sk, sk.INFO, "INFO_"),
        (core, core.CORE_STATE, "S_"),
        (core, core.CORE_EPISODE, "E_"),
        (core, core.FLAGS, "FLAG_"),
        (sk, layout.OBS_NAMES, "OBS_"),
        (mt, mt.STATE, "MST_"),
        (mt, mt.EPISODE, "MEP_"),
        (mt, mt.POINT, "PT_"),
        (mt, mt.ACTION, "ACT_"),
        (mt, mt.INFO, "MINFO_"),
        (mt, mt.MORE, "MORE_"),
        (mt, mt.BASE_FEATURES, "MOBS_"),
        (mt, mt.NODE_FEATURES + mt.NODE_PEAK_FEATURES, "NODE_"),
        (rate_rows, rate_rows.PARAMS, "PARAM_"),
        (maxmin_paths, maxmin_paths.SIZES, "SIZE_"),
        (maxmin_paths, maxmin_paths.OUT, "OUT_"),
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
    for module, names, constants in (
        (sk, layout.INSTANCE_NAMES, ("OBS_ELEMENTS", "OBS_SECONDS_LEFT")),
        (core, layout.ENERGY_NAMES, ("OBS_MOVE_X", "OBS_MOVE_Y", "OBS_ENERGY_WEIGHT", "OBS_MIN_POWER_MOVE")),
        (sk, layout.PEAK_NAMES, ("OBS_DX_PEAK", "OBS_DY_PEAK", "OBS_RATE_PEAK")),
    ):
        for constant in constants:
            assert names[getattr(module, constant)] == constant.removeprefix("OBS_").lower()
    assert (sk.N_OBS, sk.N_INSTANCE, sk.N_ENERGY) == (
        len(layout.OBS_NAMES), len(layout.INSTANCE_NAMES), len(layout.ENERGY_NAMES),
    )  # fmt: skip
    run = sk.N_INSTANCE_VALUES
    copied = sk.EPISODE[sk.EP_ELEMENTS : sk.EP_ELEMENTS + run]
    assert copied == layout.INSTANCE_NAMES[sk.OBS_ELEMENTS : sk.OBS_ELEMENTS + run]
    assert sk.OBS_SECONDS_LEFT not in range(sk.OBS_ELEMENTS, sk.OBS_ELEMENTS + run)


def test_multi_layout_matches_the_env_and_the_single_kernels() -> None:
    """The multi-node kernels' observation constants name the components of ``MultiNodeEnv``'s
    ``observation_names`` (the base block, node block k at ``N_MOBS + width k``, the energy block
    after the node blocks at the single kernels' offsets); the ``info`` blocks fill
    ``info_columns``; and both views' ``state`` and ``episode`` rows begin with the core's
    columns (``core.kernel``, whose ``move_row``, ``reward_row``, ``toward`` ... read them)."""
    k_max = 3
    for peak in (False, True):
        features = mt.NODE_FEATURES + (mt.NODE_PEAK_FEATURES if peak else ())
        width = mt.N_NODE_PEAK if peak else mt.N_NODE
        assert width == len(features)
        names = mt.BASE_FEATURES + layout.node_block_names(features, k_max) + layout.ENERGY_NAMES
        for name in mt.BASE_FEATURES:
            assert names[getattr(mt, "MOBS_" + name.upper())] == name
        for k in range(k_max):
            for name in features:
                assert names[mt.N_MOBS + width * k + getattr(mt, "NODE_" + name.upper())] == f"{name}_{k}"
        energy = mt.N_MOBS + width * k_max
        for constant in ("OBS_MOVE_X", "OBS_MOVE_Y", "OBS_ENERGY_WEIGHT", "OBS_MIN_POWER_MOVE"):
            assert names[energy + getattr(core, constant)] == constant.removeprefix("OBS_").lower()
    assert mt.info_columns(k_max) == mt.N_MINFO + 3 * k_max + mt.N_MORE
    assert mt.BEST == mt.MINFO_BEST_SCHEDULE_RATE
    assert (mt.MST_X, mt.MST_Y, mt.MST_MOVES_MADE) == (sk.ST_X, sk.ST_Y, sk.ST_MOVES_MADE)
    assert (mt.MEP_D, mt.MEP_MOVES) == (sk.EP_D, sk.EP_MOVES)
    # both views' rows begin with the core's columns, which the shared row-step core reads
    assert sk.STATE[: len(core.CORE_STATE)] == mt.STATE[: len(core.CORE_STATE)] == core.CORE_STATE
    assert sk.EPISODE[: len(core.CORE_EPISODE)] == mt.EPISODE[: len(core.CORE_EPISODE)] == core.CORE_EPISODE
    assert (mt.ACT_MOVE_X, mt.ACT_MOVE_Y) == (0, 1)  # toward writes actions[i, :2]
    assert mt.ACTION[mt.ACT_MOVE] == ("move_x", "move_y")
    assert mt.INFO[mt.MINFO_POSITION] == ("position_x", "position_y")
