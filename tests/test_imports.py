"""The package's and the tools' modules form no import circle (lazy imports inside functions
included), the layers hold (the wheel imports no tool, planners no agent or experiment), and
every module imports on its own."""

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


def imports_of(path: Path, name: str) -> set[str]:
    """The modules of ``MODULES`` that ``path`` imports anywhere (top level or in a function)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                base = f"{anchor}.{base}" if base else anchor
            targets = [base] + [f"{base}.{alias.name}" for alias in node.names]
        else:
            continue
        found |= {t for t in targets if t in MODULES and t != name}
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
