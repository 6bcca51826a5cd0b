"""benchmarks/log.py: the dated results log is regenerated section by section, atomically.

A run of a registered name replaces that name's section under "Latest runs" (appends it the first
time) and leaves every other section and the history as they were; the section carries the UTC
date, the exact command, the machine and the output. A failing command leaves the log alone, and
an unknown name is refused naming the allowed ones. The commands here are tiny ``python -c`` ones
put in the registry for the test; the shipped log is never written. The shipped log, the docs and
the benchmarks name a run by its date and what it did, never by a session, issue, ticket or stop
number.
"""

from __future__ import annotations

import datetime
import importlib.util
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def log_module():
    spec = importlib.util.spec_from_file_location("benchmarks_log", ROOT / "benchmarks" / "log.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    yield module
    sys.modules.pop(spec.name, None)


@pytest.fixture
def tiny(log_module, monkeypatch):
    registry = {
        "hello": log_module.Measurement(("-c", "print('hello ' + '1')"), "prints a line"),
        "other": log_module.Measurement(("-c", "print('other')"), "prints another"),
        "fails": log_module.Measurement(("-c", "import sys; print('half'); sys.exit(3)"), "exits 3"),
    }
    monkeypatch.setattr(log_module, "REGISTRY", registry)
    return log_module


HISTORY = "# History\n\n## 2026-11-30: an old entry\n\n## hello\n\nnot a latest run: kept as is\n"


def _log(tmp_path: Path) -> Path:
    path = tmp_path / "log.md"
    path.write_text(f"# Results log\n\nPreamble.\n\n# Latest runs\n\nOne section per command.\n\n{HISTORY}")
    return path


def test_list_names_every_registered_command(log_module, capsys):
    assert log_module.main(["--list"]) == 0
    printed = capsys.readouterr().out
    for name, measurement in log_module.REGISTRY.items():
        assert re.search(rf"^{name} +python benchmarks/\S+\.py", printed, re.M), name
        assert (ROOT / measurement.args[0]).is_file(), measurement.args[0]


def test_unknown_name_is_an_error_naming_the_allowed_ones(tiny, tmp_path, capsys):
    path = _log(tmp_path)
    before = path.read_text()
    with pytest.raises(SystemExit) as exit_:
        tiny.main(["hello", "nope", "--log", str(path)])
    assert exit_.value.code == 2
    assert "unknown name(s) nope; allowed: hello, other, fails" in capsys.readouterr().err
    assert path.read_text() == before  # nothing ran


def test_a_run_writes_a_dated_section_and_a_rerun_replaces_it(tiny, tmp_path, monkeypatch):
    path = _log(tmp_path)
    assert tiny.main(["hello", "--log", str(path)]) == 0
    assert tiny.main(["other", "--log", str(path)]) == 0
    writes: list[Path] = []
    write = tiny.atomic_write_text
    monkeypatch.setattr(tiny, "atomic_write_text", lambda p, text: writes.append(Path(p)) or write(p, text))
    assert tiny.record("hello", path, date=datetime.date(2030, 1, 2))  # the same name again
    assert writes == [path]  # through the atomic writer, once
    assert not [p for p in tmp_path.iterdir() if p.name != "log.md"]  # no temporary file left
    text = path.read_text()
    latest, history = text.split("\n# History\n")
    assert latest.count("## hello\n") == 1 and latest.count("## other\n") == 1  # replaced, not added
    assert latest.index("## hello") < latest.index("## other")  # in place
    assert "- date: 2030-01-02 (UTC)\n" in latest
    assert "- command: `python -c print('hello ' + '1')`\n" in latest
    assert re.search(r"^- machine: .+, \d+ CPUs, ", latest, re.M)
    assert latest.count("```text\nhello 1\n```") == 1 and "```text\nother\n```" in latest
    assert "One section per command." in latest and latest.startswith("# Results log\n\nPreamble.")
    assert "# History\n" + history == HISTORY  # the history untouched, its "## hello" included


def test_the_date_is_todays_in_utc(tiny, tmp_path):
    path = _log(tmp_path)
    before = datetime.datetime.now(datetime.timezone.utc).date()
    assert tiny.main(["hello", "--log", str(path)]) == 0
    after = datetime.datetime.now(datetime.timezone.utc).date()
    dates = re.findall(r"^- date: (\S+) \(UTC\)$", path.read_text(), re.M)
    assert len(dates) == 1 and dates[0] in {before.isoformat(), after.isoformat()}


def test_a_failing_command_leaves_the_log_alone(tiny, tmp_path, capsys):
    path = _log(tmp_path)
    before = path.read_text()
    assert tiny.main(["fails", "--log", str(path)]) == 1
    assert path.read_text() == before
    assert "exited with 3" in capsys.readouterr().err


def test_a_missing_log_starts_from_the_template(tiny, tmp_path):
    path = tmp_path / "new" / "log.md"
    assert tiny.main(["hello", "--log", str(path)]) == 0
    text = path.read_text()
    assert text.index("# Latest runs") < text.index("## hello") < text.index("# History")


def test_output_with_fences_and_headings_stays_inside_its_section(log_module):
    output = "## not a heading\n```\ninner\n```\n"
    section = log_module.entry("x", "python -c pass", output, datetime.date(2030, 1, 1))
    text = log_module.TEMPLATE
    once = log_module.replace_section(text, "x", section)
    twice = log_module.replace_section(once, "x", section)
    assert once == twice and once.count("## x\n") == 1 and "````text\n## not a heading" in once


def test_the_shipped_log_has_its_parts():
    text = (ROOT / "results" / "log.md").read_text(encoding="utf-8")
    assert text.startswith("# Results log\n")
    assert text.index("\n# Latest runs\n") < text.index("\n# History\n")
    dated = re.findall(r"^## (?:By )?(\d{4}-\d{2}-\d{2})", text.split("\n# History\n")[1], re.M)
    assert len(dated) >= 10 and dated == sorted(dated)  # the history, dated, in order


# Runs are named by their date and what they did, never by the numbered work period (session,
# issue, ticket, stop) that made them. NUMBERED holds in the log, the docs and the benchmarks
# (whose output the log records); a Markdown heading ("# History"), a link's anchor, a colour and
# a scenario index written "scenario 20" (or "scenario #20") are not references. "session" alone
# is the soak benchmarks' word for a child process, so the un-numbered forms ("this session's
# code", "the same session") are checked in the Markdown only, and the relative days ("last
# night", "today") in the dated log only.
NUMBERED = re.compile(
    r"(?<![\w&#/])(?<!scenario )(?<!Scenario )(?<!scenarios )#\d{1,4}\b"
    r"|(?i:\b(?:sessions?|issues?|tickets?|stops?|sprints?|milestones?)\s+(?:#\s*)?\d+)"
    r"|(?i:\bperiods?\s+#?\d+\b)(?!\s*(?:s|ms|us|min|h|slots?|steps?)\b)"
    r"|(?i:\bwork[\s-]+periods?\b)"
    r"|\bS\d{1,2}\b"  # "S7"; three digits are a lint code ("noqa: S307")
)
UNNUMBERED = re.compile(
    r"(?i:\b(?:this|that|the same|same|last|previous|earlier|in one)\s+sessions?\b)"
    r"|(?i:\bsessions?\s+(?:start|end)\b)"
    r"|(?i:\b(?:session|issue|ticket)'s\b)"
)
RELATIVE_DAYS = re.compile(r"(?i:\b(?:today|tonight|yesterday|last night)\b)")

#: Pages the rule does not cover yet (none).
NOT_YET: set[str] = set()


def _work_period_hits(path: Path) -> list[str]:
    patterns = [NUMBERED]
    if path.suffix == ".md":
        patterns.append(UNNUMBERED)
    if path == ROOT / "results" / "log.md":
        patterns.append(RELATIVE_DAYS)
    lines = enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
    where = path.relative_to(ROOT).as_posix()
    return [
        f"{where}:{number}: {m.group(0)!r} in {line.strip()!r}"
        for number, line in lines
        for pattern in patterns
        for m in pattern.finditer(line)
    ]


@pytest.mark.parametrize(
    "text",
    ["as in session 12", "sessions 4 and 5", "#28's race", "issue 20", "Issue #14", "S7's run", "stop 30",
     "ticket 3", "work period", "period 2", "this session's code", "in the same session",
     "session 6's result", "the issue's baseline", "torch update (session start)"],
)  # fmt: skip
def test_the_work_period_patterns_catch(text):
    assert NUMBERED.search(text) or UNNUMBERED.search(text), text


@pytest.mark.parametrize(
    "text",
    ["# History", "## 2026-12-02 (night): the compiled update", "scenario 20 (K = 4)", "on scenario #25",
     "[table](../docs/leaderboard.md#mobile-v1)", "each training session it starts", "SB3 at 8.0k", "S: as P",
     "--seed S", "class Session:", "--session-timeout", "the next session resumed", "a period of 10 s",
     "color #1f77b4", "round 4 of the DAgger run", "Q14", "# noqa: S603"],
)  # fmt: skip
def test_the_work_period_patterns_pass(text):
    assert not NUMBERED.search(text) and not UNNUMBERED.search(text), text


def test_relative_days_are_caught_and_dates_pass():
    assert RELATIVE_DAYS.search("against last night's recipe") and RELATIVE_DAYS.search("run twice today")
    assert not RELATIVE_DAYS.search("run twice on 2026-12-04; 2026-12-02 (night) above")


def test_no_work_period_references():
    """The log (its generated sections included), the README, the docs and the benchmarks name a
    run by its date and what it did."""
    paths = [
        ROOT / "results" / "log.md",
        ROOT / "README.md",
        *sorted((ROOT / "docs").glob("*.md")),
        *sorted((ROOT / "benchmarks").glob("*.md")),
        *sorted((ROOT / "benchmarks").glob("*.py")),
    ]
    checked = [path for path in paths if path.relative_to(ROOT).as_posix() not in NOT_YET]
    hits = [hit for path in checked for hit in _work_period_hits(path)]
    assert not hits, "name runs by date and what they did:\n" + "\n".join(hits)
