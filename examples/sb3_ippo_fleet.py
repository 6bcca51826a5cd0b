"""IPPO with shared parameters on several UAVs: SB3's PPO on the fleet's batched form, agents as rows.

Run:  python examples/sb3_ippo_fleet.py [--steps 2000000] [--fleets 128] [--uavs 2] [--seed 0]

``ios_uav_env.envs.fleet_vector.FleetVectorEnv`` runs ``--fleets`` fleets of ``--uavs`` UAVs at
once, agent ``uav_u`` of fleet b in row ``b U + u`` with its fleet's team reward; one SB3 policy
acts for every row, so every UAV shares its parameters (IPPO with parameter sharing, the
standard recipe of PettingZoo's agents-as-rows conversion). ``VecAdapter`` is the few lines
that make the Gymnasium vector env (``SAME_STEP`` autoreset) an SB3 ``VecEnv``. The scenario is
the MARL recipe's (``examples/torchrl_mappo_fleet.py``). At the end the deterministic policy
flies the fleet of ``ios_uav_env.parallel_env`` and its team max-min rate is printed as a share
of the centralised planner's plan and of its certified bound (``baselines.fleet``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

import ios_uav_env
from ios_uav_env.envs.fleet_vector import FleetVectorEnv

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # baselines/ runs from a checkout
from baselines.fleet import MARL_SCENARIO, learner_report  # noqa: E402

#: The MARL recipes' scenario (``baselines.fleet.MARL_SCENARIO``).
CONFIG = MARL_SCENARIO


class VecAdapter(VecEnv):
    """A Gymnasium vector env with ``SAME_STEP`` autoreset as an SB3 ``VecEnv`` (each row's last
    observation under ``terminal_observation``)."""

    def __init__(self, env: Any) -> None:
        self.env = env
        super().__init__(env.num_envs, env.single_observation_space, env.single_action_space)
        self._actions: np.ndarray | None = None
        self._seed: int | None = None

    def reset(self) -> np.ndarray:
        obs, _ = self.env.reset(seed=self._seed)
        self._seed = None
        return obs

    def seed(self, seed: int | None = None) -> list[int | None]:
        self._seed = seed
        return [seed] * self.num_envs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict]]:
        obs, reward, terminated, truncated, info = self.env.step(self._actions)
        infos: list[dict] = [{} for _ in range(self.num_envs)]
        if "final_obs" in info:
            for i in np.flatnonzero(info["_final_obs"]):
                infos[i]["terminal_observation"] = info["final_obs"][i]
        return obs, reward.astype(np.float32), terminated | truncated, infos

    def close(self) -> None:
        self.env.close()

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        return [getattr(self.env, attr_name)] * self.num_envs

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        setattr(self.env, attr_name, value)

    def env_method(self, method_name: str, *args: Any, indices: Any = None, **kwargs: Any) -> list[Any]:
        return [getattr(self.env, method_name)(*args, **kwargs)] * self.num_envs

    def env_is_wrapped(self, wrapper_class: Any, indices: Any = None) -> list[bool]:
        return [False] * self.num_envs


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2_000_000, help="agent steps to train for")
    parser.add_argument("--fleets", type=int, default=128, help="fleets stepped at once")
    parser.add_argument("--uavs", type=int, default=2, help="U, the number of UAVs")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    venv = VecNormalize(VecAdapter(FleetVectorEnv(args.fleets, CONFIG, uavs=args.uavs)), gamma=0.995)
    venv.seed(args.seed)
    n_steps = max(8, 8192 // venv.num_envs)
    model = PPO("MlpPolicy", venv, n_steps=n_steps, batch_size=min(2048, n_steps * venv.num_envs),
                learning_rate=3e-4, gamma=0.995, seed=args.seed, verbose=0)  # fmt: skip
    start = time.perf_counter()
    model.learn(args.steps)
    seconds = time.perf_counter() - start
    venv.training = False
    env = ios_uav_env.parallel_env(CONFIG, uavs=args.uavs)
    obs, _ = env.reset(seed=args.seed)
    while env.agents:
        acts = {a: model.predict(venv.normalize_obs(obs[a]), deterministic=True)[0] for a in env.agents}
        obs, _, _, _, infos = env.step(acts)
    info, feasible = infos["uav_0"], all(bool(i["feasible"]) for i in infos.values())
    trained = f"trained {args.steps} agent steps in {seconds:.0f} s"
    print(learner_report("IPPO (SB3, shared)", CONFIG, args.uavs, info["min_rate"], feasible, trained))
    return {"min_rate": info["min_rate"]}


if __name__ == "__main__":
    main()
