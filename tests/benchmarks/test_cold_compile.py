"""benchmarks/cold_compile.py: each id in a fresh process with an empty numba cache directory.

The plumbing runs on the plain-Python kernels (``IOS_UAV_ENV_NO_NUMBA=1``, inherited by the
child: nothing to compile, so the test takes seconds): a row per id with the import, single and
vector phases, the totals line, and a cache directory that is gone afterwards. Bad arguments are
refused before any process starts, naming the option.
"""

from __future__ import annotations

import importlib.util
import re
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _load():
    spec = importlib.util.spec_from_file_location("cold_compile", ROOT / "benchmarks" / "cold_compile.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_row_per_id_with_each_phase_and_no_cache_left(monkeypatch, capsys):
    cold = _load()
    monkeypatch.setenv("IOS_UAV_ENV_NO_NUMBA", "1")
    before = set(Path(tempfile.gettempdir()).glob("cold-numba-*"))
    cold.main(["--ids", "ios_uav_env/IOSUAV-v0", "ios_uav_env/MISOUAV-v0", "--num-envs", "2"])
    printed = capsys.readouterr().out
    cell = r"\s+\d+\.\d / +\d+\.\d"
    for env_id in ("ios_uav_env/IOSUAV-v0", "ios_uav_env/MISOUAV-v0"):
        assert re.search(rf"{re.escape(env_id)}{cell}{cell}{cell}\s*$", printed, re.M), printed
    assert re.search(r"single \+ vector, all ids and repeats: \d+\.\d s wall, \d+\.\d s CPU", printed)
    assert set(Path(tempfile.gettempdir()).glob("cold-numba-*")) == before


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--num-envs", "0"], "--num-envs must be >= 1"),
        (["--repeats", "0"], "--repeats must be >= 1"),
        (["--ids", "ios_uav_env/NoSuch-v0"], "--ids: not registered: ios_uav_env/NoSuch-v0"),
        (["--tree", "/"], "not a checkout of ios-uav-env"),
    ],
)
def test_bad_arguments_are_refused_naming_the_option(argv, message, capsys):
    with pytest.raises(SystemExit) as stop:
        _load().main(argv)
    assert stop.value.code == 2
    assert message in capsys.readouterr().err
