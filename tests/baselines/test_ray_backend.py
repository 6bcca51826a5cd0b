"""The Ray backend: a real local Ray of 2 CPUs, shared by the module's tests.

The same planner sweep and the same training sweep on the local backend and on Ray give the
same records and the same cache files (rates to 1e-9, wall times aside). Ray is the optional
``ray`` extra: skipped without it, except under CI (``CI`` set), which installs ``.[all]``.
"""

from __future__ import annotations

import functools
import json
import os
import signal
import sys
from pathlib import Path

import pytest

from baselines.runner import run_tasks

if os.environ.get("CI"):
    import ray  # CI installs the 'ray' extra: a missing Ray is a failure there
else:
    ray = pytest.importorskip("ray", reason="the Ray backend needs the 'ray' extra")

from agents import sweep as training_sweep  # noqa: E402
from baselines.ray_backend import init_ray  # noqa: E402
from experiments.sweep import Point, SweepSpec, run_sweep  # noqa: E402

# the quick figures' scenario, three of its fastest points (fly-hover-fly, SCA on the RIS, DP)
SPEC = SweepSpec(Ts=(40.0, 60.0), Ms=(200, 400), M_schemes=400, dp_resolution=5.0)
POINTS = [Point("ia-ft", 40.0, 400), Point("cuc", 40.0, 400), Point("dp-ia", 40.0, 400)]
TINY_PPO = {"n_envs": [2], "n_steps": [128], "batch_size": [128], "n_epochs": [1]}


@pytest.fixture(scope="module")
def ray_session():
    init_ray(num_cpus=2)
    yield ray
    ray.shutdown()


def _records(folder: Path, drop: str) -> dict[str, dict]:
    out = {}
    for path in sorted(folder.glob("*.json")):
        record = json.loads(path.read_text())
        record.pop(drop)
        out[path.name] = record
    return out


def test_planner_sweep_same_on_ray(ray_session, tmp_path):
    local = run_sweep(SPEC, tmp_path / "local", jobs=1, progress=False, points=POINTS)
    on_ray = run_sweep(SPEC, tmp_path / "ray", jobs=2, progress=False, points=POINTS, backend="ray")
    assert [(r["scheme"], r["T"], r["M"]) for r in on_ray] == [(p.scheme, p.T, p.M) for p in POINTS]
    for a, b in zip(local, on_ray, strict=True):
        assert abs(a["average_rate"] - b["average_rate"]) <= 1e-9
        assert a["feasible"] == b["feasible"]
    # the same cache files, the same records in them (the solve times aside)
    assert _records(tmp_path / "local", "seconds") == _records(tmp_path / "ray", "seconds")
    # a second run reads the cache, whichever backend wrote it
    again = run_sweep(SPEC, tmp_path / "ray", progress=False, points=POINTS, backend="local")
    assert again == on_ray


def _twice(x: int) -> dict:
    if x == 3:
        raise ValueError("task 3 fails")
    return {"x": x, "y": 2 * x}


def test_ray_task_failure_keeps_finished_records(ray_session, tmp_path):
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers need not import tests/
    with pytest.raises(ValueError, match="task 3 fails"):
        run_tasks(_twice, [1, 2, 3], tmp_path, key=str, jobs=1, backend="ray", progress=False)
    assert {p.name for p in tmp_path.glob("*.json")} == {"1.json", "2.json"}
    assert run_tasks(_twice, [1, 2], tmp_path, key=str, backend="ray", progress=False) == [
        {"x": 1, "y": 2}, {"x": 2, "y": 4},
    ]  # fmt: skip


def test_training_sweep_same_on_ray(ray_session, tmp_path):
    # one trial: the equivalence of the backends is per trial (two cost a second spawned worker
    # and a second Ray actor, each importing torch and SB3, and test nothing more)
    trials = training_sweep.make_trials(["ppo"], ["ios_uav_env/IOSUAV-v0"], [0], TINY_PPO)
    run = functools.partial(
        training_sweep.run_sweep, trials, timesteps=512, eval_freq=0, jobs=2, progress=False
    )
    local = run(tmp_path / "local")
    sigint = signal.getsignal(signal.SIGINT)
    on_ray = run(tmp_path / "ray", backend="ray")
    assert signal.getsignal(signal.SIGINT) is sigint  # Tune's own Ctrl-C handler does not outlive the sweep
    for a, b in zip(local, on_ray, strict=True):
        assert a["trial"] == b["trial"] and a["steps"] == b["steps"] == 512
        assert abs(a["average_rate"] - b["average_rate"]) <= 1e-9
    assert _records(tmp_path / "local" / "results", "wall_time_s") == _records(
        tmp_path / "ray" / "results", "wall_time_s"
    )
    assert (tmp_path / "ray" / "runs" / trials[0].name / "model.zip").exists()
    assert any((tmp_path / "ray" / "tune").iterdir())  # Tune's experiment records


def test_backend_arguments_checked(tmp_path, monkeypatch, capsys):
    with pytest.raises(ValueError, match="address"):
        run_tasks(_twice, [1], tmp_path, key=str, address="127.0.0.1:6379", progress=False)
    from agents.suite.__main__ import main as suite_main
    from experiments.__main__ import main as experiments_main

    for main, argv in [
        (experiments_main, ["figures", "--quick", "--out", str(tmp_path / "f")]),
        (experiments_main, ["multinode", "--quick", "--out", str(tmp_path / "m")]),
        (suite_main, ["build", "--n", "1", "--out", str(tmp_path / "s.json")]),
    ]:
        with pytest.raises(SystemExit):
            main([*argv, "--address", "127.0.0.1:6379"])
        assert "argument --address: a Ray cluster's address needs --backend ray" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "ray", None)  # as if Ray were not installed
    with pytest.raises(ImportError, match="'ray' extra"):
        run_tasks(_twice, [1], tmp_path, key=str, backend="ray", progress=False)
