"""A behaviour clone of MPC-DP on the online one-node task (``ios_uav_env/IOSUAV-Mobile-v0``), a
start for PPO fine-tuning (``train.py --trainer fast --init-from``).

**Expert.** ``baselines.mpc.MPC(k=10, planner="dp", resolution=5)`` flown online by
``baselines.mpc.run_online`` (the suite's ``mpc_dp_k10`` row) on training scenarios
``sample_scenario(default_rng(seed), MOBILE_RANGES)`` with episode seed ``seed``, for ``seed`` from
:data:`FIRST_SEED` on (the suite draws its scenarios from its own ``SeedSequence``, so none is a
suite scenario). The label of slot n is the env's action that moves the UAV from the MPC's q[n]
to its q[n+1]: ``(q[n+1] - q[n]) / D`` (the env moves by ``D`` times the action, in the unit disk).

**Observations.** The same episode in the env (``filter_estimate=True``, reset with the episode
seed and ``options={"config": config}``: the same true path and the same reports as the MPC saw)
wrapped in ``agents.wrappers.FrameStack(frames=4)``, flown with the labels: the observation
before each action. :func:`replay` returns the flown episode too, so the labels can be checked to
reproduce the MPC's trajectory and score (:func:`expert_episode`'s ``max_gap`` and ``rate``).

**Fit.** An SB3 PPO ``MlpPolicy`` with the memory recipe's network (pi and vf [128, 128],
``log_std_init`` -2) and ``VecNormalize`` observation statistics of the dataset; Adam on the
squared error of the actor's mean to the labels (the critic is left at its initial weights).
The folder (``model.zip``, ``vecnormalize.pkl``, ``config.json``) loads with
``agents.loading.load_agent`` (its memory from ``hyperparams.env_wrapper``) and with
``train.py --init-from`` on ``agents/hyperparams/fast_ppo_memory_mpcclone.yml``.

    python -m agents.mpc_clone --out /tmp/mpcclone/clone --episodes 120 --jobs 2
"""

from __future__ import annotations

import argparse
import io
import json
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from agents.imitation import save_model_folder
from ios_uav_env import MOBILE_ID, ScenarioConfig, sample_scenario, score_plan
from ios_uav_env.io import atomic_write_bytes, atomic_write_text

#: The first training seed (scenario and episode); the suite's draws come from its own SeedSequence.
FIRST_SEED = 10_000
#: The expert: MPC-DP re-planned every 10 slots on a 5 m grid (the suite's mpc_dp_k10 row).
EXPERT = {"k": 10, "planner": "dp", "resolution": 5.0}
#: Observations the policy sees at once (the memory recipe's FrameStack).
FRAMES = 4
#: The env's arguments (the Kalman filter's estimate of the node in the observation).
ENV_KWARGS = {"filter_estimate": True}
#: The memory recipe's network and starting log std.
NET_ARCH = {"pi": [128, 128], "vf": [128, 128]}
LOG_STD_INIT = -2.0


def training_scenario(seed: int) -> ScenarioConfig:
    """The training scenario of ``seed``: a draw of the mobile suite's family."""
    from baselines.references.mobile import MOBILE_RANGES

    return sample_scenario(np.random.default_rng(seed), MOBILE_RANGES)


def _env(frames: int = FRAMES) -> Any:
    import gymnasium as gym

    import ios_uav_env  # noqa: F401  (registers the ids)
    from agents.wrappers import FrameStack

    env = gym.make(MOBILE_ID, **ENV_KWARGS)
    return FrameStack(env, frames) if frames > 1 else env


def replay(
    config: ScenarioConfig, seed: int, actions: np.ndarray, frames: int = FRAMES
) -> tuple[np.ndarray, Any, np.ndarray]:
    """Fly ``actions`` (N-1, 2) through the env on ``config`` reset with ``seed``: (the observation
    before each action (N-1, obs_dim) float32, the ``Episode``, the node's true path (N, K, 2) m)."""
    from ios_uav_env.envs.rollout import run_episode

    seen: list[np.ndarray] = []

    def policy(obs: np.ndarray) -> np.ndarray:
        seen.append(np.asarray(obs, dtype=np.float32).copy())
        return actions[len(seen) - 1].astype(np.float32)

    env = _env(frames)
    try:
        episode = run_episode(env, policy, seed=seed, options={"config": config})
        paths = np.array(env.unwrapped.paths)
    finally:
        env.close()
    return np.stack(seen), episode, paths


def expert_episode(seed: int) -> dict[str, Any]:
    """One expert episode on the training scenario of ``seed`` (module docstring): its
    observations and labels, the MPC's rate and planning seconds, the replay's rate (on the true
    path) and its largest distance (m) from the MPC's trajectory."""
    from baselines.mpc import MPC, run_online

    config = training_scenario(seed)
    start = time.perf_counter()
    run = run_online(config, MPC(**EXPERT), seed)
    seconds = time.perf_counter() - start
    q = run.trajectory
    labels = (q[1:] - q[:-1]) / config.D
    obs, episode, paths = replay(config, seed, labels)
    if not np.array_equal(paths, run.paths):
        raise RuntimeError(f"seed {seed}: the env drew other node paths than run_online")
    gap = float(np.max(np.hypot(*(episode.trajectory - q).T)))
    replay_rate = score_plan(config, episode.trajectory, paths=paths).rate
    return {"seed": seed, "obs": obs, "labels": labels.astype(np.float32), "mpc_rate": float(run.score.rate),
            "replay_rate": float(replay_rate), "max_gap": gap, "seconds": seconds}  # fmt: skip


def collect(n: int, first_seed: int = FIRST_SEED, jobs: int = 1) -> list[dict[str, Any]]:
    """:func:`expert_episode` of seeds ``first_seed`` .. ``first_seed + n - 1`` on ``jobs`` processes."""
    seeds = list(range(first_seed, first_seed + n))
    if jobs <= 1:
        return [expert_episode(s) for s in seeds]
    with ProcessPoolExecutor(jobs) as pool:
        return list(pool.map(expert_episode, seeds))


def new_model(obs: np.ndarray, seed: int = 0) -> tuple[Any, Any]:
    """A PPO ``MlpPolicy`` of the memory recipe's network on a one-env ``VecNormalize`` whose
    observation statistics are ``obs``'s."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    venv = VecNormalize(DummyVecEnv([_env]), gamma=0.999, norm_obs=True, norm_reward=True)
    venv.obs_rms.mean = obs.mean(0).astype(np.float64)
    venv.obs_rms.var = obs.var(0).astype(np.float64)
    venv.obs_rms.count = float(len(obs))
    kwargs = {"net_arch": dict(NET_ARCH), "log_std_init": LOG_STD_INIT}
    model = PPO("MlpPolicy", venv, policy_kwargs=kwargs, seed=seed, device="cpu")
    return model, venv


def fit_actor(
    model: Any, venv: Any, obs: np.ndarray, labels: np.ndarray, epochs: int, batch_size: int = 256,
    learning_rate: float = 1e-3, seed: int = 0,
) -> float:  # fmt: skip
    """Adam (one-cycle rate peaking at ``learning_rate``) on the squared error of the actor's mean to
    ``labels`` on ``obs`` normalised by ``venv``; the last epoch's mean loss."""
    import torch as th

    from agents.fitting import obs_normalizer

    policy = model.policy
    gen = th.Generator().manual_seed(seed)
    x = obs_normalizer(venv)(th.as_tensor(obs, dtype=th.float32))
    y = th.as_tensor(labels, dtype=th.float32)
    params = [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters()]
    opt = th.optim.Adam(params, lr=learning_rate)
    per_epoch = -(-len(x) // batch_size)
    sched = th.optim.lr_scheduler.OneCycleLR(opt, learning_rate, max(epochs * per_epoch, 100), pct_start=0.05)
    loss_mean = float("nan")
    policy.set_training_mode(True)
    for _ in range(epochs):
        order = th.randperm(len(x), generator=gen)
        total = 0.0
        for begin in range(0, len(x), batch_size):
            idx = order[begin : begin + batch_size]
            latent = policy.mlp_extractor.forward_actor(
                policy.extract_features(x[idx], policy.pi_features_extractor)
            )
            loss = th.mean((policy.action_net(latent) - y[idx]) ** 2)
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            total += float(loss.detach()) * len(idx)
        loss_mean = total / len(x)
    policy.set_training_mode(False)
    return loss_mean


def model_config(**extra: Any) -> dict[str, Any]:
    """The folder's ``config.json``: what ``agents.loading.load_agent`` reads (the env, its memory
    and normalisation) and the run's settings."""
    normalize = {"norm_obs": True, "norm_reward": True}
    hyperparams = {"policy": "MlpPolicy", "gamma": 0.999, "normalize": normalize,
                   "env_wrapper": [{"agents.wrappers.FrameStack": {"frames": FRAMES}}],
                   "policy_kwargs": f"dict(net_arch={NET_ARCH}, log_std_init={LOG_STD_INIT})"}  # fmt: skip
    return {"algo": "ppo", "env_id": MOBILE_ID, "env_kwargs": dict(ENV_KWARGS), "hyperparams": hyperparams,
            "trained_by": "agents.mpc_clone", "expert": dict(EXPERT), **extra}  # fmt: skip


def run(out: str | Path, episodes: int, *, first_seed: int = FIRST_SEED, jobs: int = 1, epochs: int = 200,
        batch_size: int = 256, learning_rate: float = 1e-3, seed: int = 0) -> dict[str, Any]:  # fmt: skip
    """Collect ``episodes`` expert episodes (cached in ``out/data.npz``), fit, save the model in
    ``out``; the summary (also ``out/summary.json``)."""
    import torch as th

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    data_path = out / "data.npz"
    start = time.perf_counter()
    if data_path.is_file():
        data = dict(np.load(data_path))
    else:
        eps = collect(episodes, first_seed, jobs)
        data = {key: np.array([e[key] for e in eps]) for key in ("seed", "mpc_rate", "replay_rate", "max_gap",
                                                                  "seconds")}  # fmt: skip
        data["obs"] = np.concatenate([e["obs"] for e in eps])
        data["labels"] = np.concatenate([e["labels"] for e in eps])
        buffer = io.BytesIO()
        np.savez(buffer, **data)
        atomic_write_bytes(data_path, buffer.getvalue())  # a killed run leaves no half cache
    collect_seconds = time.perf_counter() - start
    th.manual_seed(seed)
    model, venv = new_model(data["obs"], seed)
    start = time.perf_counter()
    loss = fit_actor(model, venv, data["obs"], data["labels"], epochs, batch_size, learning_rate, seed)
    summary = {
        "episodes": len(data["seed"]), "samples": len(data["obs"]), "first_seed": first_seed,
        "expert_seconds_mean": float(np.mean(data["seconds"])), "collect_seconds": collect_seconds,
        "mpc_rate_mean": float(np.mean(data["mpc_rate"])),
        "replay_rel_gap_max": float(np.max(np.abs(data["replay_rate"] / data["mpc_rate"] - 1))),
        "trajectory_gap_max_m": float(np.max(data["max_gap"])), "fit_loss": loss, "epochs": epochs,
        "fit_seconds": time.perf_counter() - start,
    }  # fmt: skip
    save_model_folder(out, model, venv, model_config(summary=summary))
    atomic_write_text(out / "summary.json", json.dumps(summary, indent=1))
    return summary


def main(argv: list[str] | None = None) -> int:
    """The command line (module docstring)."""
    parser = argparse.ArgumentParser(prog="python -m agents.mpc_clone", description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--out", required=True, help="the model folder (data.npz caches the expert's episodes)"
    )
    parser.add_argument("--episodes", type=int, default=120, help="expert episodes")
    parser.add_argument("--first-seed", type=int, default=FIRST_SEED, help="the first training seed")
    parser.add_argument("--jobs", type=int, default=1, help="processes flying the expert")
    parser.add_argument("--epochs", type=int, default=200, help="passes of the fit over the dataset")
    parser.add_argument("--batch-size", type=int, default=256)
    parser.add_argument("--learning-rate", type=float, default=1e-3)
    parser.add_argument("--seed", type=int, default=0, help="torch and the batch order")
    args = parser.parse_args(argv)
    if args.episodes < 1 or args.epochs < 0 or args.jobs < 1:
        parser.error("--episodes and --jobs must be >= 1, --epochs >= 0")
    summary = run(args.out, args.episodes, first_seed=args.first_seed, jobs=args.jobs, epochs=args.epochs,
                  batch_size=args.batch_size, learning_rate=args.learning_rate, seed=args.seed)  # fmt: skip
    print(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
