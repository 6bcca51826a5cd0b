"""train.py and agents.training: smoke runs in subprocesses, --resume, and bad CLI input."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("yaml")

from agents.hyperparams import load_hyperparams, parse_env_kwargs  # noqa: E402
from train import main  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
# tiny but real hyperparameters, in the zoo format, so that a smoke run updates its networks
TINY = """
ios_uav_env/IOSUAV-v0:
  n_envs: 2
  n_timesteps: 256
  policy: 'MlpPolicy'
  normalize: "{'norm_obs': False, 'norm_reward': True}"
  n_steps: 64
  batch_size: 64
  n_epochs: 2
  gamma: 0.999
  learning_rate: lin_3e-4
  policy_kwargs: "dict(net_arch=[16, 16])"
"""
TINY_SAC = """
ios_uav_env/IOSUAV-v0:
  n_envs: 1
  n_timesteps: 200
  policy: 'MlpPolicy'
  learning_starts: 100
  batch_size: 32
  buffer_size: 1000
  train_freq: [1, "step"]
  policy_kwargs: "dict(net_arch=[16, 16])"
"""


def run_train(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    cmd = [sys.executable, str(ROOT / "train.py"), "--no-progress", *args]
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "OMP_NUM_THREADS": "1"}
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=120, env=env)


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory):
    """A PPO smoke run: 192 steps, one env, no guard, checkpoints every 128 steps."""
    cwd = tmp_path_factory.mktemp("ppo")
    (cwd / "hp.yml").write_text(TINY)
    out = cwd / "run"
    proc = run_train("--algo", "ppo", "--hyperparams", "hp.yml", "--out", str(out), "--timesteps", "192",
                     "--n-envs", "1", "--seed", "3", "--checkpoint-freq", "128", "--eval-freq", "128",
                     "--env-kwargs", "arrival_guard:False", cwd=cwd)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return cwd, out


def check_run(out: Path, algo: str) -> dict:
    assert (out / "model.zip").stat().st_size > 1000
    config = json.loads((out / "config.json").read_text())
    assert config["algo"] == algo and config["seed"] == 3 and config["env_kwargs"] == {"arrival_guard": False}
    assert config["arrival_guard"] is False and config["hyperparams"]["policy"] == "MlpPolicy"
    assert {"torch", "stable_baselines3", "gymnasium"} <= set(config["versions"])
    assert list((out / "checkpoints").glob("rl_model_*_steps.zip"))
    if algo == "sac":
        assert list((out / "checkpoints").glob("rl_model_replay_buffer_*_steps.pkl"))
    else:
        assert (out / "vecnormalize.pkl").exists()
        assert list((out / "checkpoints").glob("rl_model_vecnormalize_*_steps.pkl"))
    assert list((out / "tb").rglob("events.out.tfevents.*"))
    summary = json.loads((out / "summary.json").read_text())
    assert summary["steps"] >= int(config["total_timesteps"]) > 0 and summary["steps_per_s"] > 0
    assert summary["final_eval"]["steps"] == summary["steps"] and summary["final_eval"]["average_rate"] > 0
    return summary


def test_ppo_smoke_run_writes_model_config_checkpoint_and_tensorboard(ppo_run):
    _, out = ppo_run
    summary = check_run(out, "ppo")
    assert summary["steps"] == 192 and [h["steps"] for h in summary["eval_history"]] == [128, 192]


def test_sac_smoke_run_writes_model_config_replay_buffer_and_tensorboard(tmp_path):
    (tmp_path / "hp.yml").write_text(TINY_SAC)
    out = tmp_path / "run"
    proc = run_train("--algo", "sac", "--hyperparams", "hp.yml", "--out", str(out), "--seed", "3",
                     "--checkpoint-freq", "128", "--eval-freq", "0", "--env-kwargs", "arrival_guard:False",
                     cwd=tmp_path)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert check_run(out, "sac")["steps"] == 200


def test_resume_continues_the_step_count_in_the_same_folder(ppo_run):
    cwd, out = ppo_run
    first = json.loads((out / "summary.json").read_text())
    second = run_train("--resume", str(out), "--timesteps", "384", cwd=cwd)
    assert second.returncode == 0, second.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["steps"] == 384  # 192 before + 192 after: the count went on from the checkpoint
    steps = sorted(int(p.name.split("_")[2]) for p in (out / "checkpoints").glob("rl_model_*_steps.zip"))
    assert steps == [128, 192, 256, 384]  # every 128 steps and at the end of each session
    assert [h["steps"] for h in summary["eval_history"]] == [128, 256, 384]  # 192 was the first session's end
    assert [p.name for p in (out / "tb").iterdir()] == ["PPO_1"]  # one TensorBoard run, continued
    assert len(list((out / "tb" / "PPO_1").glob("events.out.tfevents.*"))) == 2
    lines = (out / "monitor" / "0.monitor.csv").read_text().splitlines()
    assert lines[0].startswith("#{") and lines[1] == "r,l,t" and len(lines) == 4  # one episode per session
    assert [int(row.split(",")[1]) for row in lines[2:]] == [149, 149]
    assert summary["wall_time_s"] > first["wall_time_s"]  # the clock went on too


@pytest.mark.parametrize(
    "argv, argument, message",
    [
        (["--algo", "dqn"], "--algo", "invalid choice"),
        (["--algo", "ppo", "--env", "CartPol-v9"], "--env", "unknown env id"),
        (["--algo", "ppo", "--timesteps", "-5"], "--timesteps", "positive integer"),
        (["--algo", "ppo", "--timesteps", "0"], "--timesteps", "positive integer"),
        (["--algo", "ppo", "--env-kwargs", "arrival_guard=False"], "--env-kwargs", "key:value"),
        (["--algo", "ppo", "--env-kwargs", "channel:(1,"], "--env-kwargs", "channel:(1,"),
        (["--algo", "ppo", "--env-kwargs", "warp:9"], "--env-kwargs", "warp"),
        (["--algo", "ppo", "--env-kwargs", "channel:rayleigh"], "--env-kwargs", "channel"),
        (["--timesteps", "10"], "--algo", "required"),
        (["--algo", "ppo", "--env", "CartPole-v1"], "--env", "no hyperparameters"),
        (["--algo", "ppo", "--hyperparams", "/nonexistent.yml"], "--hyperparams", "no such file"),
        (["--resume", "/nonexistent/run"], "--resume", "not a run folder"),
        (["--algo", "ppo", "--eval-freq", "-1"], "--eval-freq", "integer >= 0"),
        (["--algo", "ppo", "--out", str(ROOT)], "--out", "not empty"),
    ],
)
def test_bad_cli_input_names_the_argument_and_exits_non_zero(capsys, argv, argument, message):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {argument}" in err and message in err


def test_resume_takes_the_runs_own_settings(tmp_path, capsys):
    (tmp_path / "checkpoints").mkdir()
    (tmp_path / "config.json").write_text(json.dumps({"algo": "ppo", "total_timesteps": 128, "args": {}}))
    (tmp_path / "checkpoints" / "rl_model_64_steps.zip").write_bytes(b"")
    with pytest.raises(SystemExit) as exc:
        main(["--resume", str(tmp_path), "--seed", "1", "--env-kwargs", "T:60"])
    assert exc.value.code == 2
    assert (
        "argument --resume: the run's own settings are used; drop --seed, --env-kwargs"
        in capsys.readouterr().err
    )


def test_cli_errors_exit_non_zero_from_the_command_line(tmp_path):
    proc = run_train("--algo", "ppo", "--timesteps", "-1", cwd=tmp_path)
    assert proc.returncode == 2 and "argument --timesteps" in proc.stderr
    assert not (tmp_path / "runs").exists()


def test_env_kwargs_parse_like_the_zoo():
    parsed = parse_env_kwargs(
        ["arrival_guard:False", "channel:'rician'", "T:100", "q0:(-300, 0)", "channel:rician"]
    )
    assert parsed == {"arrival_guard": False, "channel": "rician", "T": 100, "q0": (-300, 0)}
    assert parse_env_kwargs(None) == {}


def test_shipped_hyperparameter_files_resolve():
    for algo in ("ppo", "sac"):
        hp = load_hyperparams(algo, "ios_uav_env/IOSUAV-v0")
        assert hp.n_timesteps > 0 and hp.policy == "MlpPolicy"
        assert isinstance(hp.model_kwargs["policy_kwargs"], dict) and hp.model_kwargs["gamma"] >= 0.99
    with pytest.raises(ValueError, match="no hyperparameters"):
        load_hyperparams("ppo", "CartPole-v1")


def test_log_std_schedule_anneals_the_exploration_noise():
    import gymnasium as gym
    import torch
    from stable_baselines3 import PPO

    from agents.callbacks import LogStdSchedule

    torch.set_num_threads(1)
    model = PPO("MlpPolicy", gym.make("ios_uav_env/IOSUAV-v0"), n_steps=64, batch_size=64, n_epochs=1,
                policy_kwargs={"net_arch": [8]}, seed=0, device="cpu")  # fmt: skip
    seen = []

    class Spy(LogStdSchedule):
        def _on_rollout_start(self) -> None:
            super()._on_rollout_start()
            seen.append(self.model.policy.log_std.detach().numpy().copy())

    model.learn(256, callback=Spy(start=-1.0, end=-3.0))
    assert [float(s[0]) for s in seen] == pytest.approx([-1.0, -1.5, -2.0, -2.5])  # rollouts at 0..192
    assert not model.policy.log_std.requires_grad and np.all(seen[-1] == seen[-1][0])


@pytest.mark.parametrize("batched", [True, False])
def test_exploring_starts_schedule_winds_the_starts_down(batched: bool):
    """ExploringStartsSchedule finds the exploring starts (the batched VecEnv form or the wrappers
    of a DummyVecEnv's envs) and holds, then lowers, their probability; no starts: refused."""
    import gymnasium as gym
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from agents.callbacks import ExploringStartsSchedule, exploring_starts
    from agents.vec_env import BatchedVecEnv, VecExploringStarts
    from agents.wrappers import ExploringStarts

    torch.set_num_threads(1)
    if batched:
        venv = VecExploringStarts(BatchedVecEnv("ios_uav_env/IOSUAV-v0", 2, {"T": 40}), prob=0.8)
    else:
        venv = DummyVecEnv([lambda: ExploringStarts(gym.make("ios_uav_env/IOSUAV-v0", T=40), prob=0.8)] * 2)
    venv = VecNormalize(venv)
    assert len(exploring_starts(venv)) == (1 if batched else 2)
    model = PPO("MlpPolicy", venv, n_steps=32, batch_size=64, n_epochs=1, policy_kwargs={"net_arch": [8]},
                seed=0, device="cpu")  # fmt: skip
    seen = []

    class Spy(ExploringStartsSchedule):
        def _on_rollout_start(self) -> None:
            super()._on_rollout_start()
            seen.append([w.prob for w in exploring_starts(self.training_env)])

    model.learn(256, callback=Spy(hold=0.5, end=0.0))  # rollouts start at 0, 64, 128, 192 steps
    assert [s[0] for s in seen] == pytest.approx([0.8, 0.8, 0.8, 0.4]) and all(len(set(s)) == 1 for s in seen)
    plain = PPO("MlpPolicy", gym.make("ios_uav_env/IOSUAV-v0", T=40), n_steps=32, batch_size=32, device="cpu")
    with pytest.raises(ValueError, match="needs agents.wrappers.ExploringStarts"):
        plain.learn(32, callback=ExploringStartsSchedule())


def test_target_entropy_schedule_anneals_sac_noise_and_refuses_ppo():
    import gymnasium as gym
    import torch
    from stable_baselines3 import PPO, SAC

    from agents.callbacks import TargetEntropySchedule

    torch.set_num_threads(1)
    env = gym.make("ios_uav_env/IOSUAV-v0")
    model = SAC("MlpPolicy", env, learning_starts=50, batch_size=16, policy_kwargs={"net_arch": [8]}, seed=0)
    seen = []

    class Spy(TargetEntropySchedule):
        def _on_step(self) -> bool:
            super()._on_step()
            seen.append(self.model.target_entropy)
            return True

    model.learn(100, callback=Spy(start=-2.0, end=-6.0))
    assert (
        seen[0] == pytest.approx(-2.04)
        and seen[49] == pytest.approx(-4.0)
        and seen[-1] == pytest.approx(-6.0)
    )
    ppo = PPO("MlpPolicy", env, n_steps=64, batch_size=64, n_epochs=1, policy_kwargs={"net_arch": [8]})
    with pytest.raises(TypeError, match="needs SAC"):
        ppo.learn(64, callback=TargetEntropySchedule())


def test_env_wrapper_key_wraps_the_training_envs_and_the_monitor_keeps_raw_rewards(tmp_path):
    from agents.hyperparams import resolve
    from agents.training import TrainSettings
    from agents.training.envs import make_venv
    from agents.wrappers import ShiftReward

    hp = resolve(
        {"n_envs": 1, "env_wrapper": [{"agents.wrappers.ShiftReward": {"offset": 2.0, "scale": 3.0}}]}
    )
    assert hp.env_wrappers == [(ShiftReward, {"offset": 2.0, "scale": 3.0})]
    venv = make_venv(TrainSettings("sac", n_envs=1, seed=0), hp, tmp_path, None)
    venv.reset()
    shifted, raw = [], []
    for _ in range(148):
        _, reward, _, info = venv.step(np.zeros((1, 2), dtype=np.float32))
        shifted.append(float(reward[0]))
        raw.append(info[0]["rate"])
    np.testing.assert_allclose(shifted, 3.0 * (np.array(raw) - 2.0), rtol=1e-6)
    _, _, done, info = venv.step(np.zeros((1, 2), dtype=np.float32))
    assert done[0] and info[0]["episode"]["r"] == pytest.approx(sum(raw) + info[0]["rate"], rel=1e-5)
    with pytest.raises(ValueError, match="env_wrapper: cannot import 'agents.wrappers.Nope'"):
        resolve({"env_wrapper": "agents.wrappers.Nope"})
    with pytest.raises(ValueError, match="scale must be > 0"):
        ShiftReward(venv.envs[0], scale=0.0)


def test_bad_env_wrapper_entries_are_refused_when_read():
    from agents.hyperparams import resolve

    for spec, match in (
        ({"agents.wrappers.ShiftReward": {"offst": 1.0}}, "bad arguments for 'agents.wrappers.ShiftReward'"),
        ([3], "each entry must be"),
        ({"agents.wrappers.ShiftReward": [1.0]}, "each entry must be"),
    ):
        with pytest.raises(ValueError, match=match):
            resolve({"env_wrapper": spec})


def test_target_entropy_schedule_refuses_a_fixed_entropy_coefficient():
    import gymnasium as gym
    from stable_baselines3 import SAC

    from agents.callbacks import TargetEntropySchedule

    model = SAC("MlpPolicy", gym.make("ios_uav_env/IOSUAV-v0"), ent_coef=0.1, learning_starts=10,
                policy_kwargs={"net_arch": [8]})  # fmt: skip
    with pytest.raises(ValueError, match="ent_coef: 'auto'"):
        model.learn(20, callback=TargetEntropySchedule())
