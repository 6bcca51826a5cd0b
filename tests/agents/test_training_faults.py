"""Fault injection for training runs: two processes on one run folder, the hyperparameter check's
warnings, and what ``config.json`` records. Each fault is injected for real (a second process, a
killed holder, settings that make SB3 warn) and fails on the code before the fix."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("yaml")

from agents.hyperparams import load_hyperparams  # noqa: E402
from agents.training import TrainSettings, check_resumable, train  # noqa: E402
from tests.processes import wait_for  # noqa: E402
from train import main  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
TINY_PPO = """
ios_uav_env/IOSUAV-v0:
  n_envs: {n_envs}
  n_timesteps: {n_timesteps}
  policy: 'MlpPolicy'
  normalize: "{normalize}"
  n_steps: {n_steps}
  batch_size: {batch_size}
  n_epochs: 1
  policy_kwargs: "dict(net_arch=[8])"
"""
MINI_BATCH = "mini-batch size"


def write_hp(path: Path, n_envs: int = 2, n_steps: int = 32, batch_size: int = 64, n_timesteps: int = 512,
             normalize: str = "{'norm_obs': True, 'norm_reward': True}") -> Path:  # fmt: skip
    path.write_text(TINY_PPO.format(n_envs=n_envs, n_steps=n_steps, batch_size=batch_size,
                                    n_timesteps=n_timesteps, normalize=normalize))  # fmt: skip
    return path


# --- two processes on one run folder -----------------------------------------------------
def test_a_second_process_on_a_run_folder_is_refused_until_the_holder_dies(tmp_path, capsys):
    # before: a second train.py --resume (or a new run with --out) of a folder another process was
    # training went ahead: it cleared the folder's files and both wrote the same checkpoints
    hp = write_hp(tmp_path / "hp.yml", n_timesteps=10**8)
    run = tmp_path / "run"
    cmd = [sys.executable, str(ROOT / "train.py"), "--algo", "ppo", "--hyperparams", str(hp), "--out",
           str(run), "--env-kwargs", "T:40", "--eval-freq", "0", "--checkpoint-freq", "100000000",
           "--no-progress"]  # fmt: skip
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "OMP_NUM_THREADS": "1"}
    holder = subprocess.Popen(cmd, cwd=tmp_path, env=env, stderr=subprocess.PIPE, text=True)
    try:
        # (the monitor files are written before config.json: wait for both, or --resume may find no run)
        started = lambda: list((run / "monitor").glob("*.csv")) and (run / "config.json").exists()  # noqa: E731
        wait_for(lambda: started() or holder.poll() is not None, 120, "the holder to start training")
        assert holder.poll() is None, holder.communicate(timeout=10)[1]
        quick = ["--timesteps", "64", "--no-progress"]
        with pytest.raises(SystemExit) as exc:
            main(["--resume", str(run), *quick])
        err = capsys.readouterr().err
        assert exc.value.code == 2 and "argument --resume" in err
        assert f"run folder {run} is in use by process {holder.pid}" in err
        with pytest.raises(SystemExit) as exc:
            main(["--algo", "ppo", "--hyperparams", str(hp), "--out", str(run), "--env-kwargs", "T:40",
                  "--eval-freq", "0", *quick])  # fmt: skip
        err = capsys.readouterr().err
        assert exc.value.code == 2 and "argument --out" in err and f"in use by process {holder.pid}" in err
        settings = TrainSettings(algo="ppo", env_kwargs={"T": 40}, timesteps=64, out=str(run), eval_freq=0,
                                 hyperparams_file=str(hp), progress_bar=False)  # fmt: skip
        with pytest.raises(OSError, match=f"in use by process {holder.pid}"):
            train(settings)  # the library refuses it too
        from agents.training import lock_run_dir

        with pytest.raises(OSError, match=f"in use by process {holder.pid}"), lock_run_dir(run):
            pass
        assert holder.poll() is None and not list((run / "checkpoints").glob("*.zip"))  # untouched
    finally:
        holder.kill()  # a crash: the system releases the lock
        holder.communicate(timeout=30)
    assert check_resumable(run) == run
    assert train(settings).summary["steps"] == 64  # the folder is free again (a new run reuses it)


# --- the hyperparameter check's warnings --------------------------------------------------
def _run_warnings(tmp_path: Path, recwarn, **hp) -> list[str]:
    """The mini-batch warnings of a ``train.py`` start (arguments checked, then the run)."""
    path = write_hp(tmp_path / "hp.yml", normalize="{'norm_obs': False, 'norm_reward': True}", **hp)
    code = main(["--algo", "ppo", "--hyperparams", str(path), "--out", str(tmp_path / "run"), "--timesteps",
                 "64", "--env-kwargs", "T:40", "--eval-freq", "0", "--no-progress"])  # fmt: skip
    assert code == 0
    return [str(w.message) for w in recwarn if MINI_BATCH in str(w.message)]


def test_checking_the_hyperparameters_adds_no_mini_batch_warning(tmp_path, recwarn):
    # before: the check built a 2-env model (buffer 2 x 8 = 16, not a multiple of 64) and SB3 warned
    # twice (the argument check, then the settings' check) about a buffer the run does not have
    assert _run_warnings(tmp_path, recwarn, n_envs=8, n_steps=8, batch_size=64) == []  # the run's: 64


def test_a_deserved_mini_batch_warning_is_given_once_about_the_run(tmp_path, recwarn):
    # before: three times, two of them about the check's 2 envs (buffer 10) instead of the run's 3
    warned = _run_warnings(tmp_path, recwarn, n_envs=3, n_steps=5, batch_size=16)
    assert len(warned) == 1 and "n_envs=3" in warned[0], warned


# --- what config.json records ---------------------------------------------------------------
@pytest.mark.parametrize(
    ("normalize", "expected"),
    [
        ("{'norm_obs': False, 'norm_reward': True}", {"obs": False, "reward": True}),
        ("{'norm_obs': True, 'norm_reward': False}", {"obs": True, "reward": False}),
        ("{'clip_obs': 5.0}", {"obs": True, "reward": True}),  # VecNormalize's defaults
        ("False", {"obs": False, "reward": False}),
    ],
)
def test_config_records_whether_observations_and_rewards_are_normalised(tmp_path, normalize, expected):
    # before: config.json had no such field; a reader had to parse the hyperparameters' string
    from agents.training import write_config

    path = write_hp(tmp_path / "hp.yml", normalize=normalize)
    hp = load_hyperparams("ppo", "ios_uav_env/IOSUAV-v0", path)
    settings = TrainSettings(algo="ppo", env_kwargs={"T": 40}, hyperparams_file=str(path), n_envs=2)
    config = json.loads(write_config(tmp_path, settings, hp, 64).read_text())
    assert config["normalize"] == expected


def test_the_lock_of_a_finished_run_is_released_in_the_same_process(tmp_path):
    # before: no lock; now a run releases its folder when it ends, so that it can be resumed at once
    hp = write_hp(tmp_path / "hp.yml", n_timesteps=64)
    settings = TrainSettings(algo="ppo", env_kwargs={"T": 40}, out=str(tmp_path / "run"), eval_freq=0,
                             hyperparams_file=str(hp), progress_bar=False)  # fmt: skip
    train(settings)
    lock = tmp_path / "run" / ".lock"
    assert lock.read_text().split() == [str(os.getpid()), socket.gethostname()]
    from agents.training import resume

    assert resume(tmp_path / "run", timesteps=128, progress_bar=False).summary["steps"] == 128


# --- the monitor files: append-only logs -------------------------------------------------
def _monitor_rows(run: Path) -> list[str]:
    return (run / "monitor" / "0.monitor.csv").read_text().splitlines()[2:]  # after the two header lines


def test_a_resume_appends_to_the_monitor_files_after_cutting_a_torn_line(tmp_path):
    # before: a run without VecNormalize started its monitor files anew on resume (the first
    # session's episodes lost), and a torn last line had the next episode glued onto it
    hp = write_hp(tmp_path / "hp.yml", n_timesteps=128, normalize="False")
    settings = TrainSettings(algo="ppo", env_kwargs={"T": 40}, out=str(tmp_path / "run"), eval_freq=0,
                             checkpoint_freq=64, hyperparams_file=str(hp), progress_bar=False)  # fmt: skip
    run = train(settings).run_dir
    first = _monitor_rows(run)
    assert first
    with (run / "monitor" / "0.monitor.csv").open("a") as fh:
        fh.write("12.5,3")  # a killed process's half line
    from agents.training import resume

    resume(run, timesteps=256, progress_bar=False)
    rows = _monitor_rows(run)
    assert rows[: len(first)] == first and len(rows) > len(first)
    assert all(len(row.split(",")) == 3 for row in rows)


def test_a_full_disk_in_a_librarys_own_write_names_the_run_folder(tmp_path, monkeypatch, capsys):
    # before: a raw "[Errno 28] No space left on device" traceback, naming no file
    import errno

    from stable_baselines3.common.monitor import ResultsWriter

    def full(self, epinfo):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(ResultsWriter, "write_row", full)
    hp = write_hp(tmp_path / "hp.yml", n_timesteps=128)
    run = tmp_path / "run"
    argv = ["--algo", "ppo", "--hyperparams", str(hp), "--out", str(run), "--env-kwargs", "T:40",
            "--eval-freq", "0", "--no-progress"]  # fmt: skip
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert f"cannot write {run}: the disk is full" in err and f"python train.py --resume {run}" in err


def test_resume_of_a_shipped_model_is_refused_before_anything_is_written(tmp_path, capsys):
    # before: the resume took the folder's lock (a stray .lock in agents/models/...) and then
    # failed with a FileExistsError traceback
    import shutil

    from agents.evaluate import MODELS_DIR

    shipped = tmp_path / "ppo_IOSUAV-v0"
    shutil.copytree(MODELS_DIR / "ppo_IOSUAV-v0", shipped)  # a copy: the test must not write the real one
    before = sorted(p.name for p in shipped.iterdir())
    with pytest.raises(SystemExit) as exc:
        main(["--resume", str(shipped), "--no-progress"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "argument --resume" in err and "has no checkpoint to resume from" in err
    assert "model.zip" in err and sorted(p.name for p in shipped.iterdir()) == before
    with pytest.raises(ValueError, match="has no checkpoint to resume from"):
        check_resumable(shipped)
