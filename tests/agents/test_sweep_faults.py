"""Fault injection for ``python -m agents.sweep``: reruns with other settings, a killed parent, and
signals. Each fault is injected for real (changed settings, SIGKILL, SIGINT / SIGTERM to the
command) and fails on the code before the fix."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

pytest.importorskip("stable_baselines3")

from agents import sweep  # noqa: E402
from agents.loading import checkpoints  # noqa: E402
from tests.processes import alive, children, cmdline, wait_for  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
TINY = {"n_envs": [2], "n_steps": [32], "batch_size": [64], "n_epochs": [1]}
TINY_ARGS = ["--set", "n_envs=2", "--set", "n_steps=32", "--set", "batch_size=64", "--set", "n_epochs=1"]
ENV = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "OMP_NUM_THREADS": "1"}


def trials() -> list[sweep.Trial]:
    return sweep.make_trials(["ppo"], ["ios_uav_env/IOSUAV-v0"], [0], TINY)


# --- a rerun with other settings ------------------------------------------------------------
def test_the_record_key_covers_every_setting():
    # before: the key was the trial's name and its steps: other env kwargs read the old record back
    (trial,) = trials()
    base = {"timesteps": 64, "env_kwargs": {"T": 40}, "eval_freq": 0, "checkpoint_freq": 25_000}
    keys = {sweep.record_key(base, trial)}
    for change in ({"timesteps": 128}, {"env_kwargs": {"T": 50}}, {"env_kwargs": {}}, {"eval_freq": 64},
                   {"checkpoint_freq": 64}):  # fmt: skip
        keys.add(sweep.record_key({**base, **change}, trial))
    keys.add(sweep.record_key(base, sweep.Trial("ppo", "ios_uav_env/IOSUAV-v0", 1, trial.overrides)))
    assert len(keys) == 7
    assert all(re.fullmatch(r"[A-Za-z0-9_.=-]{1,160}", key) for key in keys), keys  # file names
    assert sweep.record_key(dict(base), trial) == sweep.record_key(base, trial)  # and is stable


def test_a_rerun_with_other_settings_is_refused_and_names_them(tmp_path, monkeypatch, capsys):
    # before: the rerun with other --env-kwargs printed "1 trials in 0.0 s" and the old numbers
    out = tmp_path / "s"
    base = ["--timesteps", "64", "--out", str(out), "--no-progress", "--jobs", "1", *TINY_ARGS]
    assert sweep.main([*base, "--eval-freq", "0", "--env-kwargs", "T:40"]) == 0
    (record,) = list((out / "results").glob("*.json"))
    capsys.readouterr()
    import agents.training

    monkeypatch.setattr(agents.training, "train", lambda *a, **k: pytest.fail("trained"))
    monkeypatch.setattr(agents.training, "resume", lambda *a, **k: pytest.fail("resumed"))
    for change, named in [
        (["--eval-freq", "0", "--env-kwargs", "T:50"],
         "env_kwargs (--env-kwargs): the run's {'T': 40}, this sweep's {'T': 50}"),
        (["--eval-freq", "32", "--env-kwargs", "T:40"],
         "eval_freq (--eval-freq): the run's 0, this sweep's 32"),
        (["--eval-freq", "0", "--checkpoint-freq", "32", "--env-kwargs", "T:40"],
         "checkpoint_freq (--checkpoint-freq): the run's 25000, this sweep's 32"),
    ]:  # fmt: skip
        with pytest.raises(SystemExit) as exc:
            sweep.main([*base, *change])
        err = capsys.readouterr().err
        assert exc.value.code == 2 and "argument --out" in err and named in err, err
        assert "use another --out" in err
    # the library refuses it too, before reading the run back
    with pytest.raises(ValueError, match=r"env_kwargs \(--env-kwargs\)"):
        sweep.run_sweep(
            trials(), out, timesteps=64, env_kwargs={"T": 50}, eval_freq=0, jobs=1, progress=False
        )
    assert list((out / "results").glob("*.json")) == [record]  # no stale record written


def test_an_edited_hyperparameter_file_is_a_changed_setting(tmp_path, monkeypatch):
    # before: the shipped entry was no part of the key: a rerun after an edit read the old run back
    (trial,) = trials()
    first = sweep.run_sweep([trial], tmp_path, timesteps=64, env_kwargs={"T": 40}, eval_freq=0, jobs=1,
                            progress=False)  # fmt: skip
    from agents import hyperparams

    edited = tmp_path / "ppo.yml"
    table = yaml.safe_load(hyperparams.hyperparams_path("ppo").read_text())
    table["ios_uav_env/IOSUAV-v0"]["gamma"] = 0.9
    edited.write_text(yaml.safe_dump(table))
    settings = {"timesteps": 64, "env_kwargs": {"T": 40}, "eval_freq": 0, "checkpoint_freq": 25_000}
    key = sweep.record_key(settings, trial)
    monkeypatch.setattr(hyperparams, "hyperparams_path", lambda algo: edited)
    assert sweep.record_key(settings, trial) != key
    with pytest.raises(ValueError, match=r"hyperparams \(--set\): the run's .*'gamma': 0.999.*'gamma': 0.9"):
        sweep.run_sweep([trial], tmp_path, timesteps=64, env_kwargs={"T": 40}, eval_freq=0, jobs=1,
                        progress=False)  # fmt: skip
    monkeypatch.undo()
    again = sweep.run_sweep([trial], tmp_path, timesteps=64, env_kwargs={"T": 40}, eval_freq=0, jobs=1,
                            progress=False)  # fmt: skip
    assert again == first  # the same settings: read back


# --- a killed parent ----------------------------------------------------------------------------
def _sweep_cmd(out: Path, *args: str) -> list[str]:
    return [sys.executable, "-m", "agents.sweep", "--timesteps", "100000000", "--env-kwargs", "T:40",
            "--eval-freq", "0", "--checkpoint-freq", "100000000", "--no-progress", "--out", str(out),
            *TINY_ARGS, *args]  # fmt: skip


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_workers_exit_when_the_sweep_is_killed(tmp_path):
    # before: after SIGKILL of the parent the workers trained on (PPID 1), then blocked on a pipe
    out = tmp_path / "s"
    log = tmp_path / "stderr.txt"
    with log.open("w") as err:  # a file, not a pipe: the workers must not keep a reader waiting
        proc = subprocess.Popen(_sweep_cmd(out, "--jobs", "2", "--seeds", "0", "1"), cwd=ROOT, env=ENV,
                                stderr=err)  # fmt: skip
    workers: list[int] = []

    def training() -> bool:
        nonlocal workers
        if proc.poll() is not None:
            return True
        workers = [p for p in children(proc.pid) if "spawn_main" in cmdline(p)]
        started = {path.parents[1] for path in (out / "runs").glob("*/monitor/*.csv")}  # its run folder
        return len(workers) == 2 and len(started) == 2

    try:
        wait_for(training, 180, "two workers training")
        assert proc.poll() is None, log.read_text()
        proc.kill()
        proc.wait(timeout=30)
        deadline = time.monotonic() + 20
        while [p for p in workers if alive(p)] and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not [p for p in workers if alive(p)], "the workers outlived their parent"
    finally:
        for pid in workers:  # the workers this test started, if the check above failed
            if alive(pid):
                os.kill(pid, signal.SIGKILL)
    from agents.training import check_unlocked

    for run_dir in (out / "runs").iterdir():
        assert checkpoints(run_dir), f"{run_dir}: no checkpoint saved on the way out"
        check_unlocked(run_dir)  # nobody writes it any more: a rerun may resume it


# --- signals with --jobs 1 --------------------------------------------------------------------
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_to_a_one_job_sweep_ends_in_one_line(tmp_path, signum):
    # before: a TrainingInterrupted traceback and exit status 1
    out = tmp_path / "s"
    proc = subprocess.Popen(
        _sweep_cmd(out, "--jobs", "1"), cwd=ROOT, env=ENV, stderr=subprocess.PIPE, text=True
    )
    try:
        wait_for(lambda: list((out / "runs").glob("*/monitor/*.csv")) or proc.poll() is not None, 120,
                 "the trial to start training")  # fmt: skip
        time.sleep(0.5)
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate(timeout=30)
    assert proc.returncode == 128 + signum, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert "Traceback" not in err and [line for line in lines if "interrupted" in line] == lines[-1:], err
    assert lines[-1].startswith(f"interrupted: {signal.Signals(signum).name} at step ")
    assert f"run the command again to resume {out}" in lines[-1]
    (run_dir,) = (out / "runs").iterdir()
    assert checkpoints(run_dir)
    config = json.loads((run_dir / "config.json").read_text())
    assert config["env_kwargs"] == {"T": 40}


# --- a write that fails -----------------------------------------------------------------------
def test_a_failed_write_ends_in_one_line_naming_the_file(tmp_path, monkeypatch, capsys):
    # a full disk used to end the sweep with a traceback; what was written is kept and resumes
    out = tmp_path / "s"

    def full_disk(*args, **kwargs):
        raise OSError(27, "File too large", str(out / "runs" / "x" / "model.zip"))

    monkeypatch.setattr(sweep, "run_sweep", full_disk)
    status = sweep.main(["--timesteps", "64", "--out", str(out), "--no-progress", "--jobs", "1", *TINY_ARGS])
    err = capsys.readouterr().err.strip()
    assert status == 1 and len(err.splitlines()) == 1, err
    assert "File too large" in err and "model.zip" in err and f"resume {out}" in err
