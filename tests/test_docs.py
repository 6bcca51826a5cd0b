"""The README and the documentation site: links, commands, glossary, citation and the strict build.

The repository stands alone: every relative link of README.md and docs/*.md points at a file
or folder of the repository, nothing points outside it (no web links, no path out of the
checkout), the commands in the README's code blocks name modules, files and make targets that
exist, the paper's terms are defined, CITATION.cff is valid CFF 1.2.0, and
``mkdocs build --strict`` passes (skipped only when the docs tools are not installed).
"""

from __future__ import annotations

import importlib.util
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
PAGES = sorted(DOCS.glob("*.md"))
MARKDOWN = [README, *PAGES]

# Markdown links and images: [text](target) / ![alt](target); the target up to a space or ')'.
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^```([\w-]*)\n(.*?)^```", re.S | re.M)
GLOSSARY_TERMS = ("IA", "RA", "IA-FT", "CUC", "q0", "qF", "G", "D")
# Commands of third-party tools that the docs show but that are not part of the repository.
EXTERNAL_MODULES = {"rl_zoo3"}
SKIP_DIRS = {".git", ".venv", "site", "out", "runs", "logs", "__pycache__", "cache", "build", "dist"}
TEXT_SUFFIXES = {".md", ".py", ".yml", ".yaml", ".toml", ".cff", ".cfg", ".txt", ".json"}
OUTSIDE = ("shared" + "/", ".." + "/" + "shared")  # split so that this file does not match itself


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def _links(path: Path) -> list[str]:
    text = FENCE.sub("", path.read_text(encoding="utf-8"))  # links inside code blocks are code
    return LINK.findall(text)


def _code_blocks(path: Path, languages: tuple[str, ...] = ("bash", "sh", "console", "")) -> list[str]:
    return [body for lang, body in FENCE.findall(path.read_text(encoding="utf-8")) if lang in languages]


def _commands(path: Path) -> list[list[str]]:
    """Every shell command line of the file's shell code blocks, split into words (comments off)."""
    out = []
    for block in _code_blocks(path):
        for line in block.splitlines():
            line = line.split(" #", 1)[0].strip()
            if line and not line.startswith("#"):
                words = shlex.split(line.replace("<", "").replace(">", ""))
                while words and "=" in words[0] and not words[0].startswith("-"):  # VAR=value prefix
                    words = words[1:]
                if words:
                    out.append(words)
    return out


def _anchors(path: Path) -> set[str]:
    """The anchors of the headings of a Markdown file (the slugs of GitHub and MkDocs' toc)."""
    text = FENCE.sub("", path.read_text(encoding="utf-8"))
    slugs = set()
    for heading in re.findall(r"^#{1,6}\s+(.+?)\s*$", text, re.M):
        slug = re.sub(r"[^\w\- ]", "", heading.strip().lower().replace("`", ""))
        slugs.add(re.sub(r"[ ]+", "-", slug).strip("-"))
    return slugs


def _searched(folder: Path) -> bool:
    """Whether a folder holds the project's own files (not a venv, a cache or a build)."""
    name = folder.name
    hidden = name.startswith(".") and name not in (".ci", ".github")
    return not (hidden or name in SKIP_DIRS or name.endswith(".egg-info") or (folder / "pyvenv.cfg").exists())


def _module_exists(name: str) -> bool:
    base = ROOT.joinpath(*name.split("."))
    return base.with_suffix(".py").is_file() or (base / "__init__.py").is_file()


def _make_targets() -> set[str]:
    text = (ROOT / "Makefile").read_text(encoding="utf-8")
    return set(re.findall(r"^([A-Za-z][\w.-]*)\s*:(?!=)", text, re.M))


@pytest.mark.parametrize("path", MARKDOWN, ids=_rel)
def test_links_point_at_files_of_the_repository(path: Path) -> None:
    broken = []
    for target in _links(path):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I):  # http:, https:, mailto:, file: ...
            broken.append(f"{target} (points outside the repository)")
            continue
        if target.startswith("#"):
            continue
        relative = target.split("#", 1)[0]
        resolved = (path.parent / relative).resolve()
        if resolved != ROOT and ROOT not in resolved.parents:
            broken.append(f"{target} (outside the repository)")
        elif not resolved.exists():
            broken.append(f"{target} (no such file)")
        elif "#" in target and resolved.suffix == ".md" and target.split("#", 1)[1] not in _anchors(resolved):
            broken.append(f"{target} (no such heading)")
    assert not broken, f"{_rel(path)} links to: {broken}"


def test_nothing_points_into_the_shared_folder() -> None:
    offenders = []
    for folder, dirs, files in os.walk(ROOT):
        dirs[:] = [d for d in dirs if _searched(Path(folder, d))]
        for name in files:
            path = Path(folder, name)
            if path.suffix in TEXT_SUFFIXES and path != Path(__file__).resolve():
                text = path.read_text(encoding="utf-8", errors="replace")
                offenders += [f"{_rel(path)}: {word}" for word in OUTSIDE if word in text]
    assert not offenders, f"the repository must stand alone: {offenders}"


@pytest.mark.parametrize("path", MARKDOWN, ids=_rel)
def test_commands_name_existing_modules_files_and_targets(path: Path) -> None:
    targets = _make_targets()
    bad = []
    for words in _commands(path):
        if words[0] in ("python", "python3") and len(words) > 1:
            if words[1] == "-m":
                module = words[2]
                if module.split(".")[0] not in EXTERNAL_MODULES and not _module_exists(module):
                    bad.append(" ".join(words))
            elif words[1].endswith(".py") and not (ROOT / words[1]).is_file():
                bad.append(" ".join(words))
        elif words[0] == "make":
            names = [w for w in words[1:] if not w.startswith("-") and "=" not in w]
            bad += [f"make {name}" for name in names if name not in targets]
    assert not bad, f"{_rel(path)}: commands naming nothing in the repository: {bad}"


def test_readme_commands_are_checked() -> None:
    """The README's code blocks do hold the commands the check above is about."""
    lines = {" ".join(words[:3]) for words in _commands(README)}
    for expected in ("make demo", "make test", "python train.py --algo", "python -m baselines"):
        assert any(line.startswith(expected) for line in lines), expected


@pytest.mark.parametrize("path", [README, DOCS / "glossary.md"], ids=_rel)
def test_glossary_defines_the_papers_terms(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    section = text.split("## Glossary", 1)[-1] if path == README else text
    rows = {m.group(1) for m in re.finditer(r"^\|\s*\*\*([^*|]+)\*\*\s*\|\s*\S", section, re.M)}
    missing = [term for term in GLOSSARY_TERMS if term not in rows]
    assert not missing, f"{_rel(path)} does not define {missing}"


def test_citation_file_is_valid_cff() -> None:
    yaml = pytest.importorskip("yaml", reason="CITATION.cff is checked with PyYAML (the rl extra)")
    data = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    assert data["cff-version"] == "1.2.0"
    for key in ("message", "title", "authors", "type"):
        assert data.get(key), key
    assert all(a.get("name") or a.get("family-names") for a in data["authors"])
    paper = data["preferred-citation"]
    assert paper["type"] == "article"
    assert paper["title"].startswith("Full-Dimensional Rate Enhancement for UAV-Enabled Communications")
    assert [a["family-names"] for a in paper["authors"]] == ["Liu", "Duo", "Wu", "Yuan", "Li"]
    assert (paper["journal"], paper["volume"], str(paper["issue"]), paper["year"]) == (
        "IEEE Wireless Communications Letters",
        11,
        "9",
        2022,
    )


def test_mkdocs_builds_strict(tmp_path: Path) -> None:
    missing = [m for m in ("mkdocs", "material", "mkdocstrings_handlers.python") if not _importable(m)]
    if missing:
        pytest.skip(f"the docs tools are not installed ({', '.join(missing)}): pip install -e '.[docs]'")
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "mkdocs",
            "build",
            "--strict",
            "-f",
            str(ROOT / "mkdocs.yml"),
            "-d",
            str(tmp_path),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert (tmp_path / "index.html").is_file()
    assert (tmp_path / "repo" / "results" / "fig1a_trajectories.png").is_file()  # figures served


def _importable(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:
        return False
