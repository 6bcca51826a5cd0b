"""The package's and the tools' modules form no import circle (lazy imports inside functions
included), the layers hold (the wheel imports no tool, planners no agent or experiment, nor the
env faces), and every module imports on its own."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("ios_uav_env", "agents", "baselines", "experiments")


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for top in PACKAGES for p in sorted((ROOT / top).rglob("*.py"))}


def import_targets(node: ast.AST, package: str) -> tuple[str, list[str]] | None:
    """For an import statement ``node`` of a module in ``package``: the module it imports from (its
    relative form resolved) and the dotted names it imports, e.g. ``("a.b", ["a.b.c"])`` for
    ``from a.b import c``; None for any other node."""
    if isinstance(node, ast.Import):
        return "", [alias.name for alias in node.names]
    if not isinstance(node, ast.ImportFrom):
        return None
    base = node.module or ""
    if node.level:
        anchor = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
        base = f"{anchor}.{base}" if base else anchor
    return base, [f"{base}.{alias.name}" for alias in node.names]


def imports_of(path: Path, name: str) -> set[str]:
    """The modules of ``MODULES`` that ``path`` imports anywhere (top level or in a function)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if (imported := import_targets(node, package)) is None:
            continue
        base, names = imported
        found |= {t for t in [base, *names] if t in MODULES and t != name}
    return found


GRAPH = {name: imports_of(path, name) for name, path in MODULES.items()}


def test_no_module_imports_one_that_imports_it_back():
    state: dict[str, int] = {}  # 1: on the current path, 2: done

    def visit(name: str, path: list[str]) -> None:
        state[name] = 1
        for dep in sorted(GRAPH[name]):
            if state.get(dep) == 1:
                cycle = path[path.index(dep) :] + [dep] if dep in path else [name, dep]
                pytest.fail("import circle: " + " -> ".join(cycle))
            if dep not in state:
                visit(dep, [*path, dep])
        state[name] = 2

    for name in sorted(GRAPH):
        if name not in state:
            visit(name, [name])


def test_layers_the_wheel_imports_no_tool_planners_no_agent_agents_no_experiment():
    assert "agents.suite" in GRAPH and "agents.suite.report" in GRAPH  # the suite is a package
    assert "ios_uav_env.benchmark.scoring" in GRAPH and "baselines.references.solve" in GRAPH
    for name, deps in GRAPH.items():
        if name.startswith("ios_uav_env"):  # the wheel scores, it never plans
            assert not {d for d in deps if d.startswith(("agents", "baselines", "experiments"))}, name
        if name.startswith("baselines"):
            assert not {d for d in deps if d.startswith(("agents", "experiments"))}, name
        if name.startswith("agents"):
            assert not {d for d in deps if d.startswith("experiments")}, name


#: The env faces (Gymnasium envs, vector envs, registration, observation views, policies on
#: observations, renderers): a thin layer over the model that the planners never import.
FACES = "ios_uav_env.envs"
_IMPORTERS = ("import_module", "__import__")


def face_imports(source: str, name: str) -> list[str]:
    """Every module of the env faces (``ios_uav_env.envs`` or a submodule) that ``source``, the
    module ``name``, imports: at the top, in a function, by ``from ios_uav_env import envs``, by a
    relative import, or by ``importlib.import_module`` / ``__import__`` of a string literal."""
    package = name.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(source)):
        if (imported := import_targets(node, package)) is not None:
            base, names = imported
            targets = [base] if _is_face(base) else names
        elif isinstance(node, ast.Call):
            func = node.func
            called = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", None)
            first = node.args[0] if node.args else None
            if called not in _IMPORTERS or not isinstance(getattr(first, "value", None), str):
                continue
            targets = [first.value]
        else:
            continue
        found += [f"line {node.lineno}: {t}" for t in targets if _is_face(t)]
    return found


def _is_face(module: str) -> bool:
    return module == FACES or module.startswith(FACES + ".")


def test_the_planners_import_nothing_from_the_env_faces():
    """``baselines`` plans on the model (``ios_uav_env``'s names, ``ios_uav_env.model``), scores and
    flies the suites' policy rows through ``ios_uav_env.benchmark`` and draws with
    ``ios_uav_env.plotting``; ``agents`` drives the envs for training, so the rule is the planners'."""
    assert "baselines.references.content" in MODULES and "baselines.loiter" in MODULES
    found = {
        name: hits
        for name, path in MODULES.items()
        if name.split(".")[0] == "baselines" and (hits := face_imports(path.read_text(), name))
    }
    assert not found, (
        f"baselines imports the env faces ({FACES}): {found}; import the model's names from ios_uav_env "
        "(the scenario families, the env ids) or ios_uav_env.model, a policy's rollout from "
        "ios_uav_env.benchmark (fly, hover_episode), the drawing helpers from ios_uav_env.plotting"
    )


@pytest.mark.parametrize(
    "source",
    [
        "from ios_uav_env.envs.multi import sample_multinode",
        "import ios_uav_env.envs",
        "from ios_uav_env import ScenarioConfig, envs",
        "def draw():\n    from ios_uav_env.envs.rendering import plot_rate_map\n",
        "import importlib\nimportlib.import_module('ios_uav_env.envs.single')",
        "__import__('ios_uav_env.envs.policies')",
    ],
)
def test_the_rule_finds_an_import_of_the_env_faces_wherever_it_is(source):
    assert face_imports(source, "baselines.references.content")


def test_the_rule_resolves_relative_imports():
    assert face_imports("from ..envs import policies", "ios_uav_env.benchmark.heuristics")
    assert face_imports("from . import rollout", "ios_uav_env.envs.policies")
    assert not face_imports("from .suite import SUITES", "ios_uav_env.benchmark.heuristics")


def test_the_rule_lets_the_model_the_benchmark_and_the_plotting_modules_through():
    source = (
        "from ios_uav_env import MULTINODE_RANGES, RANDOM_ENV_ID, sample_multinode\n"
        "from ios_uav_env.model.flights import loiter_path\n"
        "from ios_uav_env.benchmark.heuristics import hover_episode\n"
        "import ios_uav_env.envsx\n"
        "def f():\n    from ios_uav_env.plotting import plot_rate_map\n    return 'ios_uav_env.envs.multi'\n"
    )
    assert face_imports(source, "baselines.x") == []


def test_every_module_imports_first_in_a_fresh_interpreter():
    pytest.importorskip("stable_baselines3")
    code = (
        "import importlib, sys\n"
        "for name in sys.argv[1:]:\n"
        "    tools = [m for m in sys.modules if m.split('.')[0] in ('agents', 'baselines', 'experiments')]\n"
        "    for loaded in tools:\n"
        "        del sys.modules[loaded]\n"
        "    importlib.import_module(name)\n"
    )
    names = sorted(n for n in MODULES if not n.endswith("__main__"))
    proc = subprocess.run(
        [sys.executable, "-c", code, *names], cwd=ROOT, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
