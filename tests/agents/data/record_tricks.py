"""Record ``tricks_parity.npz``: what the training tricks (reward shift, action repeat, exploring
starts and their schedule) gave, on tiny budgets, before they became one implementation on the
batched arrays (``agents.tricks``); ``tests/agents/test_tricks.py`` re-runs the same cases and
compares. Recorded from the code before that change; re-record only when a trick, or the
tricks of a shipped recipe read here (``fast_ppo.yml``, ``ppo_fast.yml``, ``sac.yml``), are
meant to change (then say in the commit which case moved and why), from committed code:

    python -m tests.agents.data.record_tricks --overwrite

Uses only entry points that both forms of the code have: the zoo wrappers by name
(``agents.wrappers``), ``agents.vec_env.BatchedVecEnv`` / ``wrap_batched``, the exploring starts'
``prob`` as ``agents.callbacks.exploring_starts`` finds it, and ``agents.fast.FastPPO``.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
PATH = HERE / "tricks_parity.npz"
MULTI = "ios_uav_env/IOSUAV-MultiNode-v0"
SINGLE = "ios_uav_env/IOSUAV-v0"
FAST_FILE = HERE.parents[2] / "agents" / "hyperparams" / "fast_ppo.yml"
SB3_FILE = HERE.parents[2] / "agents" / "hyperparams" / "ppo_fast.yml"
#: Every trick at once, in the order a recipe may list them (the action repeat first).
ALL_TRICKS: list[Any] = [
    {"agents.wrappers.ActionRepeat": {"repeat": 3}},
    {"agents.wrappers.ExploringStarts": {"prob": 0.6, "max_moves": 30, "peak_prob": 0.5}},
    {"agents.wrappers.ShiftReward": {"offset": 0.5, "scale": 2.0}},
]

#: The same on a single env: the exploring starts under the action repeat (their hidden prefix
#: steps the env below them, and a repeat there would fly 3 slots a move).
GYM_TRICKS = [ALL_TRICKS[1], ALL_TRICKS[0], ALL_TRICKS[2]]


def _wrappers(spec: list[Any]) -> list[tuple[Any, dict[str, Any]]]:
    from agents.hyperparams import _wrappers as resolve_wrappers

    return resolve_wrappers(spec)


def batched_case(env_id: str, env_kwargs: dict, spec: list[Any], n: int, steps: int, seed: int) -> dict:
    """The SB3 batched path as ``train.py --vec-env batched`` stacks it (the action repeat under
    the monitor, the rest above), stepped with seeded uniform actions; the starts' ``prob`` is
    lowered half-way (what ``ExploringStartsSchedule`` does)."""
    from stable_baselines3.common.vec_env import VecMonitor

    from agents.callbacks import exploring_starts
    from agents.vec_env import BatchedVecEnv, wrap_batched
    from agents.wrappers import ActionRepeat

    wrappers = _wrappers(spec)
    batched = BatchedVecEnv(env_id, n, env_kwargs, seed=seed, stagger=True)
    inner = [w for w in wrappers if issubclass(w[0], ActionRepeat)]
    venv = wrap_batched(VecMonitor(wrap_batched(batched, inner)), [w for w in wrappers if w not in inner])
    rng = np.random.default_rng(seed)
    out: dict[str, list] = {"obs": [venv.reset()], "rewards": [], "dones": [], "terminal": [], "score": []}
    width = venv.action_space.shape[0]
    for t in range(steps):
        if t == steps // 2:
            for w in exploring_starts(venv):
                w.prob = 0.25
        obs, rewards, dones, infos = venv.step(rng.uniform(-1, 1, (n, width)).astype(np.float32))
        out["obs"].append(obs)
        out["rewards"].append(rewards)
        out["dones"].append(dones)
        for i in np.flatnonzero(dones):
            out["terminal"].append(infos[i]["terminal_observation"])
            out["score"].append(infos[i]["average_rate"])
    venv.close()
    return {k: np.asarray(v) for k, v in out.items()}


def single_case(env_id: str, env_kwargs: dict, spec: list[Any], episodes: int, seed: int) -> dict:
    """One wrapped single env (``apply_wrappers``, as the zoo and the DummyVecEnv path make it),
    ``episodes`` episodes reset with ``seed + e``, stepped with seeded uniform actions."""
    import gymnasium as gym

    from agents.wrappers import apply_wrappers

    env = apply_wrappers(gym.make(env_id, **env_kwargs), _wrappers(spec))
    rng = np.random.default_rng(seed)
    out: dict[str, list] = {"obs": [], "rewards": [], "terminated": [], "slot": []}
    for e in range(episodes):
        obs, info = env.reset(seed=seed + e)
        out["obs"].append(obs)
        out["slot"].append(info["slot"])
        terminated = truncated = False
        while not (terminated or truncated):
            action = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
            obs, reward, terminated, truncated, info = env.step(action)
            out["obs"].append(obs)
            out["rewards"].append(reward)
            out["terminated"].append(terminated)
            out["slot"].append(info["slot"])
    env.close()
    return {k: np.asarray(v) for k, v in out.items()}


def fast_case(env_id: str, hp: Any, env_kwargs: dict, n_envs: int, updates: int, seed: int) -> dict:
    """The fast trainer on ``hp`` (``n_envs`` rows, ``updates`` rollouts and updates, torch's
    update so that no compiled float32 kernel is in the loop): every rollout's buffers and the
    policy's parameters after the first and the last update."""
    import torch

    from agents.fast import FastPPO, FastRecipe

    torch.set_num_threads(1)
    torch.manual_seed(seed)
    recipe = FastRecipe.from_hyperparams(hp, n_envs)
    algo = FastPPO(env_id, recipe, updates * recipe.rollout_size, env_kwargs=env_kwargs, seed=seed,
                   update="torch")  # fmt: skip
    out: dict[str, list] = {k: [] for k in ("obs", "actions", "rewards", "dones", "params", "scores")}
    try:
        for _ in range(updates):
            algo.collect()
            for key in ("obs", "actions", "rewards", "dones"):
                out[key].append(algo._buf[key].numpy().copy())
            algo.update()
            out["params"].append(torch.cat([p.detach().flatten() for p in algo.policy.parameters()]).numpy())
        out["params"] = [out["params"][0], out["params"][-1]]  # after the first and the last update
        out["scores"] = algo.take_scores()
    finally:
        algo.close()
    return {k: np.asarray(v) for k, v in out.items()}


def fast_cases() -> dict[str, dict]:
    from agents.hyperparams import check_entry, load_hyperparams, resolve

    shipped = load_hyperparams("ppo", MULTI, FAST_FILE)  # exploring starts + their schedule
    shipped_kwargs = {**shipped.env_kwargs, "T": 40}
    shift = resolve(check_entry("ppo", {
        "n_envs": 16, "n_timesteps": 2048, "policy": "MlpPolicy", "n_steps": 8, "batch_size": 64,
        "n_epochs": 2, "gamma": 0.99, "learning_rate": "lin_1e-3",
        "normalize": "{'norm_obs': True, 'norm_reward': True}",
        "policy_kwargs": "dict(net_arch=dict(pi=[16], vf=[16]), log_std_init=-1.0)",
        "env_wrapper": ALL_TRICKS[1:],
        "callback": [{"agents.callbacks.ExploringStartsSchedule": {"hold": 0.3, "end": 0.0}}],
    }))  # fmt: skip
    return {
        "fast_shipped_multi": fast_case(MULTI, shipped, shipped_kwargs, 16, 3, 0),
        "fast_shift_starts": fast_case(SINGLE, shift, {"T": 40}, 16, 3, 1),
    }


def all_cases() -> dict[str, dict]:
    from agents.hyperparams import load_hyperparams

    multi = load_hyperparams("ppo", MULTI, SB3_FILE)
    sac = load_hyperparams("sac", SINGLE)
    multi_kwargs = {**multi.env_kwargs, "T": 40}
    cases = {
        "sb3_shipped_multi": batched_case(MULTI, multi_kwargs, multi.raw["env_wrapper"], 8, 60, 0),
        "sb3_all_multi": batched_case(MULTI, {"T": 40}, ALL_TRICKS, 6, 40, 2),
        "sb3_all_single": batched_case(SINGLE, {"T": 40}, ALL_TRICKS, 5, 40, 3),
        "gym_sac_shift": single_case(SINGLE, {"T": 40}, sac.raw["env_wrapper"], 2, 4),
        "gym_all_multi": single_case(MULTI, {"T": 40}, GYM_TRICKS, 4, 5),
        "gym_starts_multi": single_case(MULTI, multi_kwargs, multi.raw["env_wrapper"], 4, 6),
    }
    cases.update(fast_cases())
    return cases


def flatten(cases: dict[str, dict]) -> dict[str, np.ndarray]:
    return {f"{case}/{key}": value for case, arrays in cases.items() for key, value in arrays.items()}


def main(argv: list[str]) -> int:
    if PATH.exists() and "--overwrite" not in argv:
        print(f"{PATH} exists; pass --overwrite to replace it", file=sys.stderr)
        return 1
    arrays = flatten(all_cases())
    np.savez_compressed(PATH, **arrays)
    print(f"wrote {PATH} ({len(arrays)} arrays, {PATH.stat().st_size} bytes)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
