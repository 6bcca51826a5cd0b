"""``jit.copy_into`` and the rule it serves: no compiled function assigns an array to a slice.

numba compiles a slice assignment from an array with its shape-mismatch error path, an f-string of
the shapes (numba's string formatting with it): seconds of compile in every process that compiles
such a kernel, paid by a user's first reset. The kernels copy with ``copy_into`` instead; the scan
below reads every ``@jit`` function of the package, the planners and the agents. It sees slices
only: a row assigned by an integer index (``out[0] = w`` of a 2-D ``out``) compiles the same error
path but reads like an element's assignment without the types.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from ios_uav_env.jit import _copy_loop, _copy_slice, copy_into

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("ios_uav_env", "baselines", "agents")


def _is_jit(decorator: ast.expr) -> bool:
    name = decorator.func if isinstance(decorator, ast.Call) else decorator
    return isinstance(name, ast.Name) and name.id == "jit"


def slice_assignments(source: str) -> list[str]:
    """The statements of ``source``'s ``@jit`` functions that assign (or augment) a slice of an
    array from anything but a number: ``a[lo:hi] = b``, ``a[i, :] = b[j]``, ``a[2:] += b``."""
    found = []
    for function in ast.walk(ast.parse(source)):
        if not (isinstance(function, ast.FunctionDef) and any(map(_is_jit, function.decorator_list))):
            continue
        for node in ast.walk(function):
            if isinstance(node, ast.Assign):
                targets, value = node.targets, node.value
            elif isinstance(node, ast.AugAssign):
                targets, value = [node.target], node.value
            else:
                continue
            if isinstance(value, ast.Constant) or (
                isinstance(value, ast.UnaryOp) and isinstance(value.operand, ast.Constant)
            ):
                continue  # a number broadcast into the slice: no shape to mismatch
            for target in targets:
                for element in target.elts if isinstance(target, ast.Tuple) else [target]:
                    if isinstance(element, ast.Subscript):
                        index = element.slice
                        parts = index.elts if isinstance(index, ast.Tuple) else [index]
                        if any(isinstance(part, ast.Slice) for part in parts):
                            found.append(f"{node.lineno}: {ast.unparse(node)}")
    return found


def test_the_scan_finds_slice_assignments_and_leaves_numbers_and_elements():
    source = (
        "@jit\ndef f(a, b, i):\n    a[1:3] = b\n    a[i, :] = b[i]\n    a[2:] += b\n"
        "    a[:] = 0.0\n    a[:] = -1.0\n    a[i] = b[i]\n    x = b[1:3]\n"
        "def g(a, b):\n    a[:] = b\n"
        "@jit(fastmath=False)\ndef h(a, b):\n    a[0], a[1:] = b[0], b[1:]\n"
    )
    assert slice_assignments(source) == [
        "3: a[1:3] = b", "4: a[i, :] = b[i]", "5: a[2:] += b", "14: a[0], a[1:] = (b[0], b[1:])",
    ]  # fmt: skip


@pytest.mark.parametrize("package", PACKAGES)
def test_no_compiled_function_assigns_an_array_to_a_slice(package):
    found = {
        str(path.relative_to(ROOT)): hits
        for path in sorted((ROOT / package).rglob("*.py"))
        if (hits := slice_assignments(path.read_text()))
    }
    assert not found, f"copy with ios_uav_env.jit.copy_into instead (this module's docstring): {found}"


@pytest.mark.parametrize("copy", [copy_into, _copy_loop, _copy_slice], ids=["copy_into", "loop", "numpy"])
def test_copy_into_writes_the_sources_entries_at_the_start_and_nothing_else(copy):
    dst = np.full((3, 6), -1.0)
    src = np.arange(8.0).reshape(2, 4)[:, 1]  # a strided view: 1.0, 5.0
    copy(dst[1], src)
    copy(dst[2, 3:], np.array([7.0, 8.0, 9.0]))
    expected = np.full((3, 6), -1.0)
    expected[1, :2], expected[2, 3:] = [1.0, 5.0], [7.0, 8.0, 9.0]
    np.testing.assert_array_equal(dst, expected)
