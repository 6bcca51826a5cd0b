"""Fault injection (nothing lost): bad numbers, broken solvers and extreme inputs.

Each test injects one fault and checks that it is refused with a clear error or handled
right; each fails on the code before the fix (see the comment on each)."""

from __future__ import annotations

import json
import math
import signal
from pathlib import Path

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig
from ios_uav_env.envs.options import EnvOptions
from ios_uav_env.envs.single import IOSUAVEnv
from ios_uav_env.model.channel import surface_amplitude
from ios_uav_env.model.surface import node_count, quadrature_error_bound
from tests.processes import alive, children, cmdline


def _near_surface_points(config: ScenarioConfig) -> np.ndarray:
    """UAV positions from 1 cm to 100 m off the surface plane, over and beside the surface."""
    xc, yc, _ = config.ios_center
    width = config.ios_shape[0] * config.element_spacing
    offsets = [(dx, dy) for dx in (0.01, 0.3, 2.0, 10.0, 100.0) for dy in (0.0, 0.5 * width, 2 * width)]
    return np.array([(xc + s * dx, yc + dy) for dx, dy in offsets for s in (1, -1)])


# --- numerics of the element sum: the default is accurate wherever a config is accepted --------
@pytest.mark.parametrize(
    "changes",
    [{"uav_altitude": 41.0}, {"uav_altitude": 45.0}, {"ios_shape": (1000, 1000)}, {"ios_shape": (400, 300)}],
)
def test_default_compression_matches_the_exact_sum_near_large_or_close_surfaces(changes):
    # before: 8 nodes always; 86% amplitude error at 41 m, 1.7e-4 for a 1000 x 1000 surface
    config = ScenarioConfig(**changes)
    exact = surface_amplitude(config.replace(quadrature_nodes=0), _near_surface_points(config))
    fast = surface_amplitude(config, _near_surface_points(config))
    assert np.max(np.abs(fast - exact) / exact) <= 1e-11
    assert node_count(config) > 8 or node_count(config) == 0  # it took more nodes (0: exact)
    # and the plain 8 nodes were indeed not enough there: the test can see the difference
    coarse = surface_amplitude(config.replace(quadrature_tol=math.inf), _near_surface_points(config))
    assert np.max(np.abs(coarse - exact) / exact) > config.quadrature_tol


def test_default_geometry_keeps_eight_nodes_and_the_bound_is_honest():
    config = ScenarioConfig()
    assert node_count(config) == 8 and quadrature_error_bound(config, 8) <= 1e-12
    assert node_count(config.replace(quadrature_nodes=0)) == 0
    assert node_count(config.replace(quadrature_nodes=2, quadrature_tol=math.inf)) == 2


@pytest.mark.parametrize("bad", [0.0, -1e-12, math.nan, "small"])
def test_quadrature_tol_is_validated(bad):
    with pytest.raises(ValueError, match="quadrature_tol"):
        ScenarioConfig(quadrature_tol=bad)


# --- parameters whose derived powers overflow ----------------------------------------------
@pytest.mark.parametrize(
    ("changes", "what"),
    [({"power_w": 1e300}, "eta"), ({"noise_dbm": 1e6}, "noise_w"), ({"noise_dbm": -1e6}, "noise_w")],
)
def test_parameters_with_non_finite_derived_powers_are_refused(changes, what):
    # before: inf / NaN rates or ZeroDivisionError deep in the model
    with pytest.raises(ValueError, match=rf"{what} = .*must be a finite number"):
        ScenarioConfig(**changes)


def test_bools_are_not_integers_and_numpy_floats_are_numbers():
    with pytest.raises(ValueError, match="ios_shape"):  # before: accepted as (1, 1)
        ScenarioConfig(ios_shape=(True, True))
    assert ScenarioConfig(v_max=np.float32(25.0), power_w=np.float16(0.1)).v_max == 25.0
    options = EnvOptions(reach_weight=np.float32(1.0), length_scale=np.float32(400.0))
    assert options.reach_weight == 1.0 and type(options.length_scale) is float
    env = IOSUAVEnv(terminal_weight=np.float32(2.0), arrival_guard=np.bool_(False))
    assert env.options.terminal_weight == 2.0 and env.arrival_guard is False


# --- actions ---------------------------------------------------------------------------------
@pytest.mark.parametrize("action", [[1e200, 1e200], [1e308, -1e308], [-3e300, 0.0]])
def test_huge_actions_move_a_full_step_along_their_direction(action):
    # before: the squared norm overflowed to inf and the UAV did not move at all
    env = IOSUAVEnv(arrival_guard=False)
    env.reset(seed=0)
    start = env.trajectory[-1]
    env.step(np.array(action))
    move = env.trajectory[-1] - start
    direction = np.array(action) / np.hypot(*np.array(action) / 1e300) / 1e300
    assert np.hypot(*move) == pytest.approx(env.config.D, rel=1e-12)
    np.testing.assert_allclose(move / env.config.D, direction, atol=1e-12)


# --- planners --------------------------------------------------------------------------------
def test_a_solver_returning_nan_is_a_solver_failure_not_an_abort(monkeypatch):
    pytest.importorskip("cvxpy")
    from baselines import sca
    from baselines.fixed import fly_hover_fly, straight_line
    from baselines.sca_problem import Surrogate

    small = ScenarioConfig(T=40.0, ios_shape=(10, 6))
    original = Surrogate.solve
    calls = {"n": 0}

    def nan_once(self, lin, verbose=False):  # the first start's first solve returns NaNs
        calls["n"] += 1
        q, value, status, seconds = original(self, lin, verbose)
        if calls["n"] == 1:
            q = np.full_like(q, np.nan)
        return q, value, status, seconds

    monkeypatch.setattr(Surrogate, "solve", nan_once)
    starts = [straight_line(small), fly_hover_fly(small)]
    plan = sca.solve(small, init=starts, max_iters=5)  # before: ValueError from the scorer
    summary = {s["start"]: s["stop"] for s in plan.info["starts"]}
    assert summary["init0"] == "solver_error" and summary["init1"] != "solver_error"
    assert plan.info["status"] == "partial_failure" and plan.feasible
    assert any("non-finite trajectory" in h["status"] for h in plan.history)


# ============ default outputs, damaged caches, interrupted sweeps ============
# (training, agents and the suite: tests/agents/test_agent_faults.py)
def _square(x: int) -> dict:
    return {"x": x, "y": float(x * x)}


@pytest.mark.parametrize(
    ("damage", "reason"),
    [('{"x": 3, "y": NaN}', "y is nan"), ('{"x": 3, "y": 9.0', "unreadable"), ("", "unreadable"),
     ('{"x": 3}', "no 'y'"), ("[1, 2]", "not a JSON object")],
)  # fmt: skip
def test_unreadable_incomplete_or_non_finite_cached_records_are_recomputed(tmp_path, damage, reason):
    # before: NaN flowed into the results; truncated / empty gave JSONDecodeError, a missing key KeyError
    from baselines.runner import run_tasks

    run_tasks(_square, [3, 4], tmp_path, key=str, jobs=1, progress=False, required=("x", "y"))
    (tmp_path / "3.json").write_text(damage)
    with pytest.warns(RuntimeWarning, match=rf"cached record {tmp_path / '3.json'}: .*{reason}"):
        records = run_tasks(_square, [3, 4], tmp_path, key=str, jobs=1, progress=False, required=("x", "y"))
    assert records == [{"x": 3, "y": 9.0}, {"x": 4, "y": 16.0}]
    assert (tmp_path / "3.json").read_text() == '{"x": 3, "y": 9.0}'  # replaced


def test_a_nan_in_a_sweep_cache_is_solved_again_and_claims_do_not_hold_on_nan(tmp_path):
    # before: the NaN went into sweep.csv and claims.md still said "holds"
    from experiments.__main__ import QUICK
    from experiments.figures import check_claims
    from experiments.sweep import Point, run_sweep

    point = Point("ia-ft", 40.0, 200)
    (first,) = run_sweep(QUICK, tmp_path, jobs=1, progress=False, points=[point])
    path = tmp_path / f"{QUICK.cache_key(point)}.json"
    path.write_text(path.read_text().replace(repr(first["average_rate"]), "NaN", 1))
    with pytest.warns(RuntimeWarning, match="average_rate is nan"):
        (again,) = run_sweep(QUICK, tmp_path, jobs=1, progress=False, points=[point])
    assert again["average_rate"] == first["average_rate"]
    text, ok = check_claims([{**again, "average_rate": math.nan}], QUICK)
    assert not ok and "cannot be checked" in text and "holds" not in text


def test_quick_figures_never_write_the_shipped_results(tmp_path, monkeypatch, capsys):
    # before: `figures --quick` rewrote results/ (110 rows became 18, claims.md replaced)
    import experiments.__main__ as cli

    seen = []

    def fake_sweep(spec, cache_dir, **kwargs):
        seen.append(cache_dir)
        raise KeyboardInterrupt  # stop before any solve

    monkeypatch.setattr(cli, "run_sweep", fake_sweep)
    monkeypatch.chdir(tmp_path)
    assert cli.main(["figures", "--quick", "--no-progress"]) == 130
    assert seen == [Path("out/figures-quick/cache")]
    before = {p.name: p.stat().st_mtime_ns for p in cli.RESULTS_DIR.iterdir()}
    monkeypatch.chdir(cli.RESULTS_DIR.parent)  # the full sweep's default --out is ./results
    for argv in (["figures", "--quick", "--out", str(cli.RESULTS_DIR)], ["figures"]):
        with pytest.raises(SystemExit) as exc:
            cli.main(argv)
        assert exc.value.code == 2 and "pass --overwrite" in capsys.readouterr().err
    assert cli.main(["figures", "--out", str(cli.RESULTS_DIR), "--overwrite"]) == 130  # explicit: allowed
    assert {p.name: p.stat().st_mtime_ns for p in cli.RESULTS_DIR.iterdir()} == before


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_sigterm_to_the_figures_command_stops_its_workers_and_keeps_finished_points(tmp_path):
    # before: the spawned workers outlived the command (73 s later, 147 MB each)
    import subprocess
    import sys
    import time

    pytest.importorskip("cvxpy")
    root = Path(__file__).resolve().parents[1]
    cmd = [sys.executable, "-m", "experiments", "figures", "--quick", "--out", str(tmp_path), "--jobs", "2",
           "--no-agents", "--no-progress"]  # fmt: skip
    env = {"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin"}
    proc = subprocess.Popen(cmd, cwd=root, env=env, stderr=subprocess.PIPE, text=True)
    deadline, workers = time.time() + 120, []
    while time.time() < deadline and proc.poll() is None:
        workers = [p for p in children(proc.pid) if "spawn_main" in cmdline(p)]
        if len(workers) == 2 and list((tmp_path / "cache").glob("*.json")):
            break
        time.sleep(0.2)
    assert len(workers) == 2, "the sweep ended before its workers could be seen"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143 and "records are kept in" in err
    time.sleep(0.5)
    assert not [p for p in workers if alive(p)]
    kept = list((tmp_path / "cache").glob("*.json"))
    assert kept and all(json.loads(p.read_text())["scheme"] for p in kept)  # whole records


def test_baselines_out_is_checked_before_planning(tmp_path, monkeypatch, capsys):
    # before: an unwritable --out failed only after the plan was solved
    import baselines.__main__ as cli

    monkeypatch.setattr(cli, "run_scheme", lambda *a, **k: pytest.fail("planned before checking --out"))
    (tmp_path / "a_file").write_text("")
    with pytest.raises(SystemExit) as exc:
        cli.main(["--scheme", "ia-ft", "--out", str(tmp_path / "a_file" / "plans")])
    assert exc.value.code == 2 and "argument --out: cannot create" in capsys.readouterr().err


# ============ a full disk: a clear error naming the path, no torn file ============
def _full_after(half: bool = True):
    """A stand-in for ``ios_uav_env.io._write_all`` on a disk that fills up: it writes the first
    half of the data (``half``), then fails with ENOSPC."""
    import errno
    import os

    def write_all(fd: int, data: bytes) -> None:
        if half:
            os.write(fd, bytes(data[: len(data) // 2]))
        raise OSError(errno.ENOSPC, "No space left on device")

    return write_all


def test_a_full_disk_names_the_path_and_leaves_the_old_file_whole(tmp_path, monkeypatch):
    # before: a raw "[Errno 28] No space left on device" without the path
    import errno

    import ios_uav_env.io as io

    path = io.atomic_write_text(tmp_path / "record.json", '{"old": 1}')
    monkeypatch.setattr(io, "_write_all", _full_after())
    with pytest.raises(io.DiskFullError) as raised:
        io.atomic_write_text(path, '{"new": 2, "padding": "' + "x" * 1000 + '"}')
    assert raised.value.errno == errno.ENOSPC and isinstance(raised.value, OSError)
    assert str(path) in str(raised.value) and "the disk is full" in str(raised.value)
    assert path.read_text() == '{"old": 1}' and sorted(p.name for p in tmp_path.iterdir()) == ["record.json"]


def test_an_appended_log_line_is_whole_or_absent_and_a_torn_tail_is_cut(tmp_path, monkeypatch):
    # before: the trainers' logs were buffered handles: a full disk left half a line for the next
    # record to be glued onto
    import ios_uav_env.io as io

    log = tmp_path / "progress.csv"
    io.append_line(log, '{"steps": 1}')
    write_all = io._write_all
    monkeypatch.setattr(io, "_write_all", _full_after())
    with pytest.raises(io.DiskFullError, match="progress.csv: the disk is full"):
        io.append_line(log, '{"steps": 2, "padding": "' + "x" * 500 + '"}')
    assert log.read_text() == '{"steps": 1}\n'
    monkeypatch.setattr(io, "_write_all", write_all)
    io.append_line(log, '{"steps": 2}')
    assert log.read_text().splitlines() == ['{"steps": 1}', '{"steps": 2}']
    with log.open("a") as fh:  # a torn line, as an older writer or a killed process may leave
        fh.write('{"steps": 3, "lo')
    assert io.cut_torn_tail(log) == len('{"steps": 3, "lo')
    assert io.cut_torn_tail(log) == 0 and log.read_text() == '{"steps": 1}\n{"steps": 2}\n'
    (tmp_path / "torn_only").write_text("no newline at all")
    assert io.cut_torn_tail(tmp_path / "torn_only") == 17 and (tmp_path / "torn_only").read_text() == ""
    assert io.cut_torn_tail(tmp_path / "missing") == 0
