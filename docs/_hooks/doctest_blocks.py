"""Griffe extension for the API reference: show bare ``>>>`` examples of a docstring as code.

The docstrings are Markdown read by mkdocstrings; a doctest written without a fence
(``>>> import ...`` lines and their output) would render as nested block quotes. This wraps
each such run of lines in a ``pycon`` fence when the API pages are built; the docstrings
themselves stay plain doctests (pytest runs them).
"""

from __future__ import annotations

from typing import Any

import griffe

FENCE = "```"


def fence_doctests(text: str) -> str:
    """``text`` with every unfenced run of ``>>>`` lines (and the output after them) fenced."""
    out: list[str] = []
    in_fence = in_doctest = False
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith(FENCE) and not in_doctest:
            in_fence = not in_fence
        elif not in_fence and not in_doctest and stripped.startswith(">>>"):
            out.append(FENCE + "pycon")
            in_doctest = True
        elif in_doctest and not stripped:
            out.append(FENCE)
            in_doctest = False
        out.append(line)
    if in_doctest:
        out.append(FENCE)
    return "\n".join(out)


class DoctestBlocks(griffe.Extension):
    """Fence the bare doctests of every docstring that griffe loads."""

    def on_object(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None and ">>>" in obj.docstring.value:
            obj.docstring.value = fence_doctests(obj.docstring.value)

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        self.on_object(obj=pkg)
