"""Result folders (ios_uav_env.benchmark.outputs): results already in an ``--out`` are refused
without ``--overwrite``, before anything runs and untouched; with it, the previous run's result
files that the new run does not write are removed, and files that are not results are kept."""

from __future__ import annotations

import pytest

from ios_uav_env.benchmark import evaluate, scoring
from ios_uav_env.benchmark.cli import main
from ios_uav_env.benchmark.outputs import RESULT_FILES, claim, existing
from ios_uav_env.envs.policies import HoverAt

GROUND = "ios_uav_env.envs.policies:HoverAt('ground')"
STRAIGHT = "ios_uav_env.benchmark.multi_policies:StraightEqualShares"


def _refused_out(capsys, argv) -> str:
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert "error: argument --out: " in line and "--overwrite" in line, line
    return line


@pytest.mark.parametrize("name", ["results.md", "results.csv", "pct_sca.png", "mobile_scenarios.png"])
def test_an_out_holding_any_result_file_is_refused_before_any_scenario(tmp_path, capsys, monkeypatch, name):
    monkeypatch.setattr(scoring, "play", lambda *a, **k: pytest.fail("a scenario ran"))
    shipped = tmp_path / name  # e.g. `--out docs`: the shipped docs/results.md
    shipped.write_text("shipped\n")
    line = _refused_out(capsys, ["evaluate", "--policy", GROUND, "--n", "1", "--out", str(tmp_path)])
    assert name in line and shipped.read_text() == "shipped\n"


def test_overwrite_replaces_a_run_and_removes_its_files_the_new_run_does_not_write(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("mine\n")  # not a result: never touched
    multi = ["evaluate", "--suite", "multi-node-v1", "--policy", STRAIGHT, "--n", "1", "--out", str(tmp_path)]
    assert main(multi) == 0
    first = {p.name for p in tmp_path.iterdir()}
    assert {"pct_sca.png", "shares.png", "results.md"} <= first
    single = ["evaluate", "--policy", GROUND, "--n", "1", "--out", str(tmp_path)]
    _refused_out(capsys, single)
    assert {p.name for p in tmp_path.iterdir()} == first
    assert main([*single, "--overwrite"]) == 0
    second = {p.name for p in tmp_path.iterdir()}
    assert "pct_dp.png" in second and not {"pct_sca.png", "shares.png"} & second
    assert "on single-node-v1" in (tmp_path / "results.md").read_text() and "notes.txt" in second


def test_results_save_refuses_existing_results_unless_overwrite(tmp_path):
    results = evaluate(HoverAt("ground"), n=1)
    first = results.save(tmp_path)
    with pytest.raises(FileExistsError, match="results.csv, results.json, results.md"):
        results.save(tmp_path)
    (tmp_path / "pct_sca.png").write_bytes(b"a previous run's figure")
    again = results.save(tmp_path, overwrite=True)
    assert set(again) == set(first) and not (tmp_path / "pct_sca.png").exists()


def test_claim_lists_only_result_files(tmp_path):
    for name in ("results.json", "pct_bound.png", "README.md", "pct_dp.txt"):
        (tmp_path / name).write_text("")
    (tmp_path / "shares.png").mkdir()  # a folder is not a result file
    assert [p.name for p in existing(tmp_path, RESULT_FILES)] == ["pct_bound.png", "results.json"]
    assert claim(tmp_path / "new", RESULT_FILES, False) == []
