"""The main job (``python -m ios_uav_env``) and the step-speed benchmark, run as the user runs them."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from ios_uav_env import ScenarioConfig, average_rate
from ios_uav_env.__main__ import straight_line

ROOT = Path(__file__).resolve().parents[1]


def run(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    out = subprocess.run([sys.executable, *args], cwd=cwd, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    return out


def test_main_job_rolls_out_scores_and_draws(tmp_path):
    pytest.importorskip("matplotlib")
    out = run(["-m", "ios_uav_env", "--surface", "ris", "--seed", "3", "--out", "frames/demo.png"], tmp_path)
    assert "ios_uav_env/RISUAV-v0" in out.stdout and "feasible: start error 0 m" in out.stdout
    heuristic = float(out.stdout.split("average rate (eq. 9)")[1].split()[0])
    line = average_rate(ScenarioConfig(surface="ris"), straight_line(ScenarioConfig(surface="ris")))
    assert heuristic > line  # hovering at the best-rate point beats flying straight through
    assert (tmp_path / "frames" / "demo.png").stat().st_size > 10_000
    assert not (tmp_path / "docs").exists()  # the docs frame only on request


def test_main_job_writes_the_docs_frame_on_request(tmp_path):
    pytest.importorskip("matplotlib")
    run(["-m", "ios_uav_env", "--out", "demo.png", "--docs-frame"], tmp_path)
    docs = tmp_path / "docs" / "demo_frame.png"
    assert 10_000 < docs.stat().st_size < 150_000


def test_step_speed_benchmark_runs(tmp_path):
    out = run([str(ROOT / "benchmarks" / "step_speed.py"), "--steps", "300", "--repeats", "1"], tmp_path)
    assert "CartPole-v1" in out.stdout and "raw ratio" in out.stdout and "the bar (>= 0.5" in out.stdout


def test_step_speed_benchmark_measures_another_id_with_its_keywords(tmp_path):
    """The STAR id with 2-bit phases (its own line, no bar); a bad keyword is an argument error."""
    script = str(ROOT / "benchmarks" / "step_speed.py")
    args = [script, "--steps", "50", "--repeats", "1", "--env", "ios_uav_env/STARUAV-v0"]
    out = run([*args, "--env-kwargs", "star_bits:2"], tmp_path)
    assert "ios_uav_env/STARUAV-v0 star_bits=2" in out.stdout
    assert "the bar is ios_uav_env/IOSUAV-v0's" in out.stdout
    bad = [sys.executable, *args, "--env-kwargs", "star_bits:9"]
    refused = subprocess.run(bad, capture_output=True, text=True, timeout=120)
    assert refused.returncode == 2 and "star_bits must be None" in refused.stderr


def test_main_job_runs_every_fixed_ids_surface_star_included(tmp_path):
    pytest.importorskip("matplotlib")
    out = run(["-m", "ios_uav_env", "--surface", "star", "--out", "demo.png"], tmp_path)
    assert "ios_uav_env/STARUAV-v0" in out.stdout and "feasible: start error 0 m" in out.stdout
