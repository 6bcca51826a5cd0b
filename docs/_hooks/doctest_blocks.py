"""Griffe extension for the API reference: docstrings written for the terminal, read as Markdown.

The docstrings are Markdown read by mkdocstrings. A doctest written without a fence
(``>>> import ...`` lines and their output) would render as nested block quotes, and a
Sphinx role (``:func:`zeta` ``) would show its markup. When the API pages are built this
wraps each such run of doctest lines in a ``pycon`` fence and reduces each role to its code
span; the docstrings themselves stay as they are (pytest runs the doctests).
"""

from __future__ import annotations

import re
from typing import Any

import griffe

FENCE = "```"
ROLE = re.compile(r":(?:py:)?(?:func|class|data|attr|meth|mod|exc|obj|const):`~?([^`]+)`")


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
    """Fence the bare doctests and reduce the roles of every docstring that griffe loads."""

    def on_object(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = ROLE.sub(r"`\1`", fence_doctests(obj.docstring.value))

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        self.on_object(obj=pkg)
