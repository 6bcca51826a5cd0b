"""A suite's name is its identity: a file whose name looks like a registered suite's (case,
spacing, separators, look-alike characters) is refused at load instead of loading as a new suite
that prints under the registered name; a canonical new name still loads with its own hash."""

from __future__ import annotations

import json

import pytest

from ios_uav_env.benchmark import SUITES, load_suite
from ios_uav_env.benchmark.suite import check_suite_name, content_hash, suite_path


def _variants(name: str) -> list[str]:
    """Names a reader takes for ``name``: other case, spaces around or inside, other separators,
    a look-alike dash (U+2010), a full-width letter."""
    return [
        f" {name}", f"{name} ", f"{name}\t", name.upper(), name.capitalize(), name.replace("-", "_"),
        name.replace("-", "."), name.replace("-", " "), name.replace("-", "\u2010"), name.replace("-", ""),
        "\uff4d" + name[1:] if name[0] == "m" else name[:-1] + "\uff11",
    ]  # fmt: skip


def _copy(tmp_path, registered: str, name: str, n: int = 2):
    data = json.loads(suite_path(registered).read_text())
    data = {**data, "name": name, "scenarios": data["scenarios"][:n]}
    path = tmp_path / "copy.json"
    path.write_text(json.dumps(data))
    return path, data


@pytest.mark.parametrize("registered", sorted(SUITES))
def test_a_file_named_like_a_registered_suite_is_refused(tmp_path, registered):
    for name in _variants(registered):
        assert name != registered
        path, _ = _copy(tmp_path, registered, name)
        with pytest.raises(ValueError, match=r"name") as err:
            load_suite(path)
        assert str(path) in str(err.value) and repr(name) in str(err.value), name
        if name.strip() == name and name.isascii() and name.islower():  # canonical but confusable
            assert f"registered suite {registered!r}" in str(err.value), name


@pytest.mark.parametrize("registered", sorted(SUITES))
def test_a_canonical_new_name_loads_with_its_own_hash(tmp_path, registered):
    path, data = _copy(tmp_path, registered, f"{registered}-dev")
    suite = load_suite(path)
    assert suite.name == f"{registered}-dev" and suite.sha256 == content_hash(data)


@pytest.mark.parametrize("name", ["", "a b", "A", "-v1", "v1-", "a--b", "\u00e9nergie-v1", 7, None])
def test_a_name_outside_the_pattern_is_refused_naming_the_rule(name):
    with pytest.raises(ValueError, match=r"lowercase ASCII letters and digits"):
        check_suite_name(name, "suite.json")


def test_every_registered_name_is_canonical():
    for name in SUITES:
        assert check_suite_name(name, "SUITES") == name
