"""TorchRL on an ios_uav_env id: ``GymEnv`` as a new user writes it, spec check, a rollout with info.

Run:  python examples/torchrl_env.py --steps 200 [--env ID [ID ...]]
Builds ``torchrl.envs.GymEnv(id)`` (TorchRL first tries ``frameskip=1``, which the env refuses
with Python's own TypeError wording), runs ``check_env_specs`` and a random rollout that reads ``info``.
"""

from __future__ import annotations

import argparse

import torch
from tensordict import TensorDictBase
from torchrl.envs import GymEnv
from torchrl.envs.libs.gym import default_info_dict_reader
from torchrl.envs.utils import check_env_specs

import ios_uav_env


def rollout(env_id: str, steps: int, seed: int) -> TensorDictBase:
    """``GymEnv(env_id)``, ``check_env_specs`` and a random rollout of ``steps`` steps with the info keys."""
    env = GymEnv(env_id)
    # TorchRL's own info reader puts the env's info (flat numpy numbers, the same keys at reset
    # and on every step) into the tensordict; it infers the specs (shape, dtype) from them
    env.set_info_dict_reader(default_info_dict_reader())
    env.set_seed(seed)
    check_env_specs(env)

    rollout = env.rollout(steps)  # random actions from the action spec
    n, done = rollout.batch_size[0], bool(rollout["next", "done"][-1])
    obs_dim = env.observation_spec["observation"].shape[-1]
    if rollout["next", "observation"].shape != (n, obs_dim) or (n < steps and not done):
        raise RuntimeError(f"unexpected rollout {rollout}")
    missing = [k for k in ios_uav_env.INFO_KEYS if ("next", k) not in rollout.keys(include_nested=True)]
    if missing:
        raise RuntimeError(f"rollout lacks info keys {missing}")
    rate = rollout["next", "rate"].float()
    if not torch.isfinite(rate).all():
        raise RuntimeError("non-finite rate in the rollout")
    print(
        f"{env_id}: {n} steps, mean rate {rate.mean():.3f} bps/Hz, episode done {done}, "
        f"final position {rollout['next', 'position'][-1].tolist()}"
    )
    env.close()
    return rollout


def main(argv: list[str] | None = None) -> list[TensorDictBase]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", nargs="+", default=["ios_uav_env/IOSUAV-v0"], help="one or more ids")
    parser.add_argument("--steps", type=int, default=200, help="rollout length (stops at the episode's end)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    return [rollout(env_id, args.steps, args.seed) for env_id in args.env]


if __name__ == "__main__":
    main()
