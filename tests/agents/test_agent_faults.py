"""Fault injection for training and agents: interrupts, damaged checkpoints and statistics, bad
settings. Each test injects the fault for real (a signal, a truncated or missing file, a bad
YAML) and fails on the code before the fix (see each comment).
The planners', the sweep's and the runner's cases are in ``tests/test_faults.py``."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import gymnasium as gym
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("yaml")

from agents.evaluate import MODELS_DIR  # noqa: E402
from agents.loading import checkpoint_file, checkpoints, load_agent  # noqa: E402
from agents.training import TrainingInterrupted, TrainSettings, resume, train  # noqa: E402
from train import main  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
TINY_PPO = """
ios_uav_env/IOSUAV-v0:
  n_envs: 2
  n_timesteps: 512
  policy: 'MlpPolicy'
  normalize: "{'norm_obs': True, 'norm_reward': True}"
  n_steps: 32
  batch_size: 64
  n_epochs: 1
  policy_kwargs: "dict(net_arch=[8])"
"""
TINY_SAC = """
ios_uav_env/IOSUAV-v0:
  n_envs: 1
  n_timesteps: 400
  policy: 'MlpPolicy'
  learning_starts: 20
  batch_size: 16
  buffer_size: 1000
  train_freq: 1
  policy_kwargs: "dict(net_arch=[8])"
"""


def settings(tmp_path: Path, text: str = TINY_PPO, algo: str = "ppo", **changes) -> TrainSettings:
    (tmp_path / f"{algo}.yml").write_text(text)
    base = dict(algo=algo, env_kwargs={"T": 40.0}, out=str(tmp_path / "run"), checkpoint_freq=10_000,
                eval_freq=0, hyperparams_file=str(tmp_path / f"{algo}.yml"), progress_bar=False)  # fmt: skip
    return TrainSettings(**{**base, **changes})


def signal_at(monkeypatch, steps: int, signum: int = signal.SIGINT) -> None:
    """Send this process a real ``signum`` when training reaches ``steps`` env steps (a zoo
    ``callback`` slipped into the hyperparameters)."""
    from stable_baselines3.common.callbacks import BaseCallback

    import agents.training.run as run  # where the training loop looks load_hyperparams up

    class Kill(BaseCallback):
        def _on_step(self) -> bool:
            if self.num_timesteps == steps:
                os.kill(os.getpid(), signum)
            return True

    load = run.load_hyperparams

    def with_kill(*args, **kwargs):
        hp = load(*args, **kwargs)
        hp.callbacks = [*hp.callbacks, Kill()]
        return hp

    monkeypatch.setattr(run, "load_hyperparams", with_kill)


# --- 1. training interrupted -------------------------------------------------------------
def test_sigint_saves_a_checkpoint_of_the_last_update_and_resume_finishes(tmp_path, monkeypatch):
    # before: SIGINT killed the run; with checkpoint_freq > the steps done no checkpoint existed
    signal_at(monkeypatch, 150)  # mid-rollout: rollouts of 32 x 2 = 64 steps end at 128 and 192
    handler = signal.getsignal(signal.SIGINT)
    with pytest.raises(TrainingInterrupted) as stop:
        train(settings(tmp_path))
    assert stop.value.exit_status == 130 and stop.value.steps_at_signal == 150
    assert stop.value.steps == 128  # the last update; the unfinished rollout is redone
    run = tmp_path / "run"
    assert [s for s, _ in checkpoints(run)] == [128]
    for kind in ("vecnormalize", "progress"):
        assert checkpoint_file(run, 128, kind).with_suffix(".pkl" if kind != "progress" else ".json").exists()
    assert signal.getsignal(signal.SIGINT) is handler  # restored
    monkeypatch.undo()
    result = resume(run, progress_bar=False)
    assert result.summary["steps"] == 512
    config = json.loads((run / "config.json").read_text())
    assert config["resumes"][0]["from_steps"] == 128


def test_sigterm_in_sac_loses_no_step_and_keeps_the_replay_buffer(tmp_path, monkeypatch):
    # before: SIGTERM killed the run; SB3 also drops the transition of the step that stops it
    signal_at(monkeypatch, 57, signal.SIGTERM)
    with pytest.raises(TrainingInterrupted) as stop:
        train(settings(tmp_path, TINY_SAC, "sac"))
    assert stop.value.exit_status == 143 and stop.value.steps == stop.value.steps_at_signal == 57
    buffer = checkpoint_file(tmp_path / "run", 57, "replay_buffer")
    import pickle

    assert pickle.loads(buffer.read_bytes()).pos == 57  # every step of the run is in the buffer


def test_train_py_exits_143_on_sigterm_and_names_the_resume_command(tmp_path):
    # before: the process died with no checkpoint (a SIGTERM's default action)
    (tmp_path / "hp.yml").write_text(TINY_PPO.replace("512", "1000000"))
    cmd = [sys.executable, str(ROOT / "train.py"), "--algo", "ppo", "--hyperparams", "hp.yml", "--out", "run",
           "--env-kwargs", "T:40", "--eval-freq", "0", "--no-progress"]  # fmt: skip
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen(cmd, cwd=tmp_path, env=env, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while not list((tmp_path / "run" / "monitor").glob("*.csv")) and time.time() < deadline:
        time.sleep(0.2)
    time.sleep(1.0)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "SIGTERM at step" in err and f"python train.py --resume {Path('run')}" in err
    assert checkpoints(tmp_path / "run")


def test_a_failing_save_leaves_no_partial_checkpoint(tmp_path, monkeypatch):
    # before: model.save wrote rl_model_<n>_steps.zip in place: a crash left a truncated one
    from stable_baselines3 import PPO

    def broken_save(self, path, *args, **kwargs):
        Path(path).write_bytes(b"PK\x03\x04 half a zip")
        raise OSError("disk full")

    monkeypatch.setattr(PPO, "save", broken_save)
    with pytest.raises(OSError, match="disk full"):
        train(settings(tmp_path, checkpoint_freq=64))
    folder = tmp_path / "run" / "checkpoints"
    assert checkpoints(tmp_path / "run") == [] and not [p for p in folder.iterdir() if p.suffix == ".zip"]


def test_resume_falls_back_past_a_truncated_checkpoint(tmp_path, capsys):
    # before: AssertionError / BadZipFile from SB3 and no fallback
    train(settings(tmp_path, TINY_PPO.replace("512", "256"), checkpoint_freq=128))
    run = tmp_path / "run"
    assert [s for s, _ in checkpoints(run)] == [128, 256]
    newest = checkpoint_file(run, 256)
    newest.write_bytes(newest.read_bytes()[:300])
    with pytest.warns(RuntimeWarning, match=re.escape(f"checkpoint file {newest} cannot be loaded")):
        result = resume(run, timesteps=320, progress_bar=False)
    assert result.summary["steps"] == 320
    assert (run / "checkpoints" / "rl_model_256_steps.zip.unreadable").exists()  # set aside
    assert json.loads((run / "config.json").read_text())["resumes"][0]["from_steps"] == 128


def test_a_run_folder_without_checkpoint_is_no_dead_end(tmp_path, capsys):
    # before: --resume said "holds no checkpoint" and a new run refused the non-empty folder
    run = tmp_path / "run"
    (run / "monitor").mkdir(parents=True)
    (run / "checkpoints").mkdir()
    (run / "monitor" / "0.monitor.csv").write_text("#{}\nr,l,t\n")
    config = {"algo": "ppo", "total_timesteps": 64,
              "args": {**settings(tmp_path).__dict__, "timesteps": 64}}  # fmt: skip
    (run / "config.json").write_text(json.dumps(config))
    result = resume(run, progress_bar=False)  # from step 0, with its own settings
    assert result.summary["steps"] == 64 and "holds no checkpoint" in capsys.readouterr().err
    shutil.rmtree(run / "checkpoints")
    (run / "model.zip").unlink()
    (run / "summary.json").unlink()
    (run / "vecnormalize.pkl").unlink()
    assert train(settings(tmp_path, timesteps=64)).summary["steps"] == 64  # a new run reuses it


def _registered_env_failing_at_reset() -> str:
    from ios_uav_env.envs.single import IOSUAVEnv

    class FailsAtReset(IOSUAVEnv):
        def reset(self, *, seed=None, options=None):
            raise ValueError("this scenario cannot start: T is too long for the battery")

    env_id = "ios_uav_env_test/FailsAtReset-v0"
    if env_id not in gym.registry:
        gym.register(env_id, entry_point=FailsAtReset)
    return env_id


@pytest.mark.parametrize(
    ("yaml_text", "argument", "message"),
    [
        ("ios_uav_env/IOSUAV-v0: {n_envs: 2, policy: [", "--hyperparams", "is not valid YAML"),
        ("ios_uav_env/IOSUAV-v0: {learning_rate: abc}", "--hyperparams", "learning_rate must be a number"),
        (
            "ios_uav_env/IOSUAV-v0: {learnin_rate: 0.1}",
            "--hyperparams",
            "'learnin_rate' is neither a zoo key",
        ),
        ("ios_uav_env/IOSUAV-v0: {n_envs: -2}", "--hyperparams", "n_envs must be a positive integer"),
        ("ios_uav_env/IOSUAV-v0: {batch_size: 0}", "--hyperparams", "batch_size must be a positive integer"),
        ("ios_uav_env/IOSUAV-v0: {n_steps: 2.5}", "--hyperparams", "n_steps must be a positive integer"),
        ("ios_uav_env/IOSUAV-v0: {policy_kwargs: 'dict(net_arc=[8])'}", "--hyperparams", "PPO refuses"),
        ("ios_uav_env/IOSUAV-v0: {gamma: 1.5}", "--hyperparams", "gamma must be in [0, 1]"),
    ],
)
def test_bad_hyperparameters_name_the_key_before_the_run_folder_exists(tmp_path, capsys, yaml_text, argument,
                                                                        message):  # fmt: skip
    # before: tracebacks without the key's name (ValueError: could not convert string to float)
    (tmp_path / "hp.yml").write_text(yaml_text)
    with pytest.raises(SystemExit) as exc:
        main(["--algo", "ppo", "--hyperparams", str(tmp_path / "hp.yml"), "--out", str(tmp_path / "run")])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and f"argument {argument}" in err and message in err
    assert str(tmp_path / "hp.yml") in err and not (tmp_path / "run").exists()


def test_env_kwargs_are_checked_with_a_real_reset_and_the_output_path_first(tmp_path, capsys):
    # before: gym.make alone accepted them and the run failed at its first reset
    env_id = _registered_env_failing_at_reset()
    (tmp_path / "hp.yml").write_text(f"{env_id}: {{n_envs: 1}}")
    with pytest.raises(SystemExit) as exc:
        main(["--algo", "ppo", "--env", env_id, "--hyperparams", str(tmp_path / "hp.yml"),
              "--out", str(tmp_path / "run")])  # fmt: skip
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "argument --env-kwargs" in err and "too long for the battery" in err
    assert not (tmp_path / "run").exists()
    (tmp_path / "a_file").write_text("")
    with pytest.raises(SystemExit):  # before: accepted, then NotADirectoryError after the env checks
        main(["--algo", "ppo", "--out", str(tmp_path / "a_file" / "run")])
    assert "argument --out: cannot create" in capsys.readouterr().err


# --- 3. a normalised agent without its statistics; load errors name the file ------------------
@pytest.fixture
def generalist_copy(tmp_path) -> Path:
    folder = tmp_path / "generalist"
    shutil.copytree(MODELS_DIR / "ppo_IOSUAV-Random-v0", folder)
    return folder


def test_a_normalised_agent_without_its_statistics_is_refused(generalist_copy):
    # before: loaded without them and scored 7% of DP
    (generalist_copy / "vecnormalize.pkl").unlink()
    stats = generalist_copy / "vecnormalize.pkl"
    with pytest.raises(FileNotFoundError, match=re.escape(f"statistics {stats} are missing")):
        load_agent(generalist_copy)


@pytest.mark.parametrize("damage", ["truncate", "empty"])
def test_damaged_files_are_named_in_load_errors(generalist_copy, damage):
    # before: UnpicklingError / BadZipFile / JSONDecodeError without the file's name
    for name in ("vecnormalize.pkl", "model.zip", "config.json"):
        folder = generalist_copy.parent / f"{name}-{damage}"
        shutil.copytree(generalist_copy, folder)
        path = folder / name
        path.write_bytes(path.read_bytes()[:200] if damage == "truncate" else b"")
        with pytest.raises(ValueError, match=re.escape(str(path))):
            load_agent(folder)


def test_an_agent_in_an_env_of_another_observation_size_names_both(generalist_copy, tmp_path):
    # before: SB3's "Unexpected observation shape" at the first step, naming neither model nor env
    bare = tmp_path / "bare.zip"
    shutil.copy(generalist_copy / "model.zip", bare)
    with pytest.raises(ValueError, match=r"takes observations of shape \(20,\).*IOSUAV-v0 .* gives \(11,\)"):
        load_agent(bare, "ppo", env_id="ios_uav_env/IOSUAV-v0")
    from agents.rollout import rollout

    agent = load_agent(generalist_copy)
    with pytest.raises(ValueError, match=r"shape \(20,\).*gives \(17,\)"):
        rollout(agent, env_id="ios_uav_env/IOSUAV-Random-v0", env_kwargs={})


# --- 7. the learning curve keeps what it scored ----------------------------------------------------
def test_learning_curve_skips_a_truncated_checkpoint_and_keeps_rows_on_interrupt(tmp_path, monkeypatch):
    # before: the truncated checkpoint crashed the curve and the scored rows were lost
    import agents.suite.curve as curve

    run = tmp_path / "run"
    (run / "checkpoints").mkdir(parents=True)
    (run / "config.json").write_text(json.dumps({"algo": "sac", "env_id": "ios_uav_env/IOSUAV-v0"}))
    for steps in (100, 200, 300):
        shutil.copy(MODELS_DIR / "sac_IOSUAV-v0" / "model.zip", checkpoint_file(run, steps))
    broken = checkpoint_file(run, 200)
    broken.write_bytes(broken.read_bytes()[:500])
    scores = iter([{"mean_pct_dp": 90.0, "p10_pct_dp": 80.0, "min_pct_dp": 70.0, "feasible": 1, "n": 1}])

    def summarize(_):
        try:
            return next(scores)
        except StopIteration:
            raise KeyboardInterrupt from None  # Ctrl-C while scoring the third checkpoint

    monkeypatch.setattr(curve, "evaluate_suite", lambda agent, suite, n: [])
    monkeypatch.setattr(curve, "summarize", summarize)
    with pytest.warns(RuntimeWarning, match=re.escape(f"checkpoint {broken} skipped")):
        with pytest.raises(KeyboardInterrupt):
            curve.learning_curve(run, suite=None, out=tmp_path / "curve")
    lines = (tmp_path / "curve" / "suite_curve.csv").read_text().splitlines()
    assert len(lines) == 2 and lines[1].startswith("100,")


# --- 8. smaller cases -------------------------------------------------------------------------------
def test_resume_with_fewer_timesteps_than_done_is_refused_and_the_config_kept(tmp_path, capsys):
    # before: the config's total was silently rewritten to 50000 on a run at 130k steps
    (tmp_path / "checkpoints").mkdir()
    config = json.dumps({"algo": "ppo", "total_timesteps": 200_000, "args": {}})
    (tmp_path / "config.json").write_text(config)
    checkpoint_file(tmp_path, 130_000).write_bytes(b"")
    with pytest.raises(SystemExit) as exc:
        main(["--resume", str(tmp_path), "--timesteps", "50000"])
    assert exc.value.code == 2 and "at 130000 steps already" in capsys.readouterr().err
    assert (tmp_path / "config.json").read_text() == config
    with pytest.raises(ValueError, match="timesteps: .* at 130000 steps already"):
        resume(tmp_path, timesteps=50_000)


def test_a_sac_folder_without_config_is_not_loaded_as_ppo(tmp_path):
    # before: loaded as PPO; now the algorithm is asked for and checked against the zip
    folder = tmp_path / "sac"
    folder.mkdir()
    shutil.copy(MODELS_DIR / "sac_IOSUAV-v0" / "model.zip", folder / "model.zip")
    with pytest.raises(ValueError, match="pass the algorithm"):
        load_agent(folder)
    with pytest.raises(ValueError, match="holds a SAC model, not PPO"):
        load_agent(folder, "ppo")
    assert type(load_agent(folder, "sac").model).__name__ == "SAC"


# --- 2 and 4: the held-out suite: its file is never replaced by a trial build, and is validated ---------
def test_a_trial_suite_build_does_not_replace_the_shipped_suite(tmp_path, monkeypatch, capsys):
    # before: `python -m agents.suite build --n 1` replaced the 60-scenario heldout.json
    import agents.suite.__main__ as cli
    from baselines.references.heldout import SUITE_PATH

    class Built(Exception):
        pass

    def build_suite(out, *args, **kwargs):
        raise Built(out)  # where it would write; no solve

    monkeypatch.setattr(cli, "build_suite", build_suite)
    before = SUITE_PATH.stat().st_mtime_ns
    for argv in (["build"], ["build", "--out", str(SUITE_PATH), "--n", "1"]):
        with pytest.raises(SystemExit) as exc:
            cli.main(argv)
        assert exc.value.code == 2 and "exists; pass --overwrite" in capsys.readouterr().err
    monkeypatch.chdir(tmp_path)
    with pytest.raises(Built) as built:
        cli.main(["build", "--n", "1"])
    assert built.value.args == (Path("out/suite_n1_seed20261122.json"),)
    assert SUITE_PATH.stat().st_mtime_ns == before


def _suite_with(tmp_path: Path, change) -> Path:
    from baselines.references.heldout import SUITE_PATH

    data = json.loads(SUITE_PATH.read_text())
    change(data)
    path = tmp_path / "suite.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d["scenarios"][3]["dp"].pop("rate"), "scenario #3: dp has no 'rate'"),
        (lambda d: d["scenarios"][5]["dp"].update(rate=0.0), "scenario #5: DP rate 0.0 must be > 0"),
        (lambda d: d["scenarios"][7]["sca"].update(rate=float("nan")), "scenario #7: sca rate nan"),
        (lambda d: d["scenarios"][2]["config"].update(T=-1.0), "scenario #2: ValueError"),
        (lambda d: d["scenarios"].clear(), "the suite has no scenarios"),
        (lambda d: d.pop("ranges"), "no 'ranges'"),
    ],
)
def test_a_damaged_suite_file_names_the_file_and_the_scenario(tmp_path, change, message):
    # before: KeyError / ZeroDivisionError / an empty report, without the file or the scenario
    from baselines.references.heldout import load_suite

    path = _suite_with(tmp_path, change)
    with pytest.raises(ValueError, match=re.escape(f"{path}: ") + ".*" + re.escape(message)):
        load_suite(path)
    path.write_text(path.read_text()[:1000])  # truncated
    with pytest.raises(ValueError, match=re.escape(f"{path} cannot be read")):
        load_suite(path)
