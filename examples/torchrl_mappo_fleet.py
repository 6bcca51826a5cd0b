"""MAPPO on several UAVs with TorchRL: PettingZoo's Parallel API through TorchRL's wrapper.

Run:  python examples/torchrl_mappo_fleet.py [--frames 120000] [--uavs 2] [--seed 0] [--ippo]

``ios_uav_env.parallel_env`` (U UAVs, one IOS, three nodes; a 20 x 12 surface and a 60-slot
mission so that it trains in minutes on a laptop CPU) wrapped by TorchRL's ``PettingZooWrapper``
(the agents ``uav_0 ..`` grouped as ``"uav"``), a policy shared by the UAVs (``MultiAgentMLP``
with ``share_params=True``) and a centralised critic (MAPPO; ``--ippo``: each agent's own), PPO's
clipped loss with GAE, as in TorchRL's multi-agent PPO tutorial. At the end the deterministic
policy flies one episode and its team max-min rate is printed as a share of the centralised
planner's plan and of its certified bound (``baselines.fleet``) on the same fleet.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch
from tensordict.nn import NormalParamExtractor, TensorDictModule
from torch import nn
from torchrl.collectors import Collector
from torchrl.data import LazyTensorStorage, ReplayBuffer, SamplerWithoutReplacement
from torchrl.envs import RewardSum, TransformedEnv
from torchrl.envs.libs.pettingzoo import PettingZooWrapper
from torchrl.envs.utils import ExplorationType, set_exploration_type
from torchrl.modules import MultiAgentMLP, ProbabilisticActor, TanhNormal
from torchrl.objectives import ClipPPOLoss, ValueEstimators

import ios_uav_env

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # baselines/ runs from a checkout
from baselines.fleet import MARL_SCENARIO, learner_report  # noqa: E402

#: The MARL recipes' scenario (``baselines.fleet.MARL_SCENARIO``).
CONFIG = MARL_SCENARIO
GROUP = "uav"


def make_env(uavs: int, seed: int) -> TransformedEnv:
    """The fleet as a TorchRL env, with each agent's episode reward summed."""
    env = PettingZooWrapper(env=ios_uav_env.parallel_env(CONFIG, uavs=uavs), return_state=False, seed=seed)
    return TransformedEnv(env, RewardSum(in_keys=[env.reward_key], out_keys=[(GROUP, "episode_reward")]))


def train(frames: int, uavs: int, seed: int, centralised: bool, batch: int = 6000) -> tuple[dict, float]:
    """MAPPO (or IPPO) for ``frames`` env steps; returns (the last evaluation's info, seconds)."""
    torch.manual_seed(seed)
    env = make_env(uavs, seed)
    obs_dim = env.observation_spec[GROUP, "observation"].shape[-1]
    act_dim = env.full_action_spec[env.action_key].shape[-1]
    actor_net = nn.Sequential(
        MultiAgentMLP(obs_dim, 2 * act_dim, n_agents=uavs, centralised=False, share_params=True, depth=2,
                      num_cells=64, activation_class=nn.Tanh),
        NormalParamExtractor(),
    )  # fmt: skip
    actor = ProbabilisticActor(
        TensorDictModule(
            actor_net, in_keys=[(GROUP, "observation")], out_keys=[(GROUP, "loc"), (GROUP, "scale")]
        ),
        spec=env.full_action_spec[env.action_key],
        in_keys=[(GROUP, "loc"), (GROUP, "scale")],
        out_keys=[env.action_key],
        distribution_class=TanhNormal,
        distribution_kwargs={"low": -1.0, "high": 1.0},
        return_log_prob=True,
    )
    critic_net = MultiAgentMLP(obs_dim, 1, n_agents=uavs, centralised=centralised, share_params=True, depth=2,
                               num_cells=64, activation_class=nn.Tanh)  # fmt: skip
    critic = TensorDictModule(critic_net, in_keys=[(GROUP, "observation")], out_keys=[(GROUP, "state_value")])
    collector = Collector(env, actor, frames_per_batch=batch, total_frames=frames)
    buffer = ReplayBuffer(
        storage=LazyTensorStorage(batch), sampler=SamplerWithoutReplacement(), batch_size=min(batch, 1000)
    )
    loss = ClipPPOLoss(actor_network=actor, critic_network=critic, clip_epsilon=0.2, entropy_coeff=1e-3,
                       normalize_advantage=False)  # fmt: skip
    loss.set_keys(reward=env.reward_key, action=env.action_key, value=(GROUP, "state_value"),
                  done=(GROUP, "done"), terminated=(GROUP, "terminated"))  # fmt: skip
    loss.make_value_estimator(ValueEstimators.GAE, gamma=0.99, lmbda=0.95)
    optim = torch.optim.Adam(loss.parameters(), 3e-4)
    start = time.perf_counter()
    for data in collector:
        with torch.no_grad():
            loss.value_estimator(
                data, params=loss.critic_network_params, target_params=loss.target_critic_network_params
            )
        buffer.extend(data.reshape(-1))
        for _ in range(4):  # epochs
            for _ in range(max(1, batch // buffer.batch_size)):
                parts = loss(buffer.sample())
                total = parts["loss_objective"] + parts["loss_critic"] + parts["loss_entropy"]
                total.backward()
                nn.utils.clip_grad_norm_(loss.parameters(), 1.0)
                optim.step()
                optim.zero_grad()
        collector.update_policy_weights_()
        done = data["next", GROUP, "done"].squeeze(-1).all(-1)
        if done.any():
            returns = data["next", GROUP, "episode_reward"][done].mean().item()
            print(f"frames {collector._frames:>7d}: mean episode return {returns:.3f}", flush=True)
    collector.shutdown()
    seconds = time.perf_counter() - start
    with set_exploration_type(ExplorationType.DETERMINISTIC), torch.no_grad():
        episode = env.rollout(CONFIG.N + 5, actor)
    last = episode["next", GROUP, "info"][-1]
    return {key: last[key][0].item() for key in ("min_rate", "best_schedule_rate", "feasible")}, seconds


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=120_000, help="env steps to train for")
    parser.add_argument("--uavs", type=int, default=2, help="U, the number of UAVs")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--batch", type=int, default=6000, help="env steps per PPO update")
    parser.add_argument("--ippo", action="store_true", help="a critic per agent instead of a centralised one")
    args = parser.parse_args(argv)
    info, seconds = train(args.frames, args.uavs, args.seed, not args.ippo, args.batch)
    label, trained = ("IPPO" if args.ippo else "MAPPO"), f"trained {args.frames} steps in {seconds:.0f} s"
    print(learner_report(label, CONFIG, args.uavs, info["min_rate"], info["feasible"], trained))
    return {**info, "seconds": seconds}


if __name__ == "__main__":
    main()
