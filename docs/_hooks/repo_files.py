"""MkDocs hook: serve the repository files that a docs page links to with ``../``.

The pages link to figures and files where they live in the repository (``../results/...``),
so the links work when the Markdown is read on its own. MkDocs serves only ``docs/``: this
hook adds each such file to the site under ``repo/`` (copied at build time, never stored
twice in the repository) and points the page's link there. Markdown files outside ``docs/``
are not served (they would become pages); link to them by name instead.
"""

from __future__ import annotations

import posixpath
import re
from pathlib import Path

from mkdocs.structure.files import File

_LINK = re.compile(r"(\]\()(\.\./[^)\s#]+)")
_PREFIX = "repo"


def _repo_path(page_src: Path, link: str, root: Path) -> str | None:
    """The link's target relative to the repository root, if it is a file there outside docs/."""
    target = (page_src.parent / link).resolve()
    try:
        rel = target.relative_to(root)
    except ValueError:
        return None
    if not target.is_file() or target.suffix == ".md" or rel.parts[0] == "docs":
        return None
    return rel.as_posix()


def on_files(files, config):  # noqa: ANN001, ANN201 - the MkDocs hook signature
    docs_dir = Path(config["docs_dir"]).resolve()
    root = docs_dir.parent
    added: set[str] = set()
    for page in list(files.documentation_pages()):
        src = Path(page.abs_src_path)
        for _, link in _LINK.findall(src.read_text(encoding="utf-8")):
            rel = _repo_path(src, link, root)
            if rel is not None and rel not in added:
                added.add(rel)
                files.append(File.generated(config, f"{_PREFIX}/{rel}", abs_src_path=str(root / rel)))
    return files


def on_page_markdown(markdown, page, config, files):  # noqa: ANN001, ANN201
    docs_dir = Path(config["docs_dir"]).resolve()
    src = Path(page.file.abs_src_path)
    here = posixpath.dirname(page.file.src_uri) or "."

    def swap(match: re.Match[str]) -> str:
        rel = _repo_path(src, match.group(2), docs_dir.parent)
        if rel is None:
            return match.group(0)
        return match.group(1) + posixpath.relpath(f"{_PREFIX}/{rel}", here)

    return _LINK.sub(swap, markdown)
