"""The fleet's batched form (``envs.fleet_vector``): fleet b equals the parallel env seeded
seed + b, step for step and across the autoreset, bit for bit; its spaces hold every row; bad
input is refused by name."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pettingzoo")
import ios_uav_env  # noqa: E402
from ios_uav_env import ScenarioConfig  # noqa: E402
from ios_uav_env.envs.fleet_vector import FleetVectorEnv  # noqa: E402

CONFIG = ScenarioConfig(
    ground_nodes=((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0)), ios_shape=(8, 6), T=12.0, v_max=50.0,
    q0=(-200.0, 20.0), qF=(200.0, 20.0),
)  # fmt: skip


@pytest.mark.parametrize("access", ["orthogonal", "shared"])
def test_each_fleet_is_the_parallel_env_bit_for_bit(access):
    b_n, u_n = 3, 2
    vec = FleetVectorEnv(b_n, CONFIG, uavs=u_n, access=access, min_separation=15.0)
    singles = [
        ios_uav_env.parallel_env(CONFIG, uavs=u_n, access=access, min_separation=15.0) for _ in range(b_n)
    ]
    obs, _ = vec.reset(seed=7)
    want = [env.reset(seed=7 + b)[0] for b, env in enumerate(singles)]
    rng = np.random.default_rng(7)
    for _ in range(2 * (CONFIG.N - 1)):  # two episodes: across the autoreset
        for b in range(b_n):
            for u in range(u_n):
                np.testing.assert_array_equal(obs[b * u_n + u], want[b][f"uav_{u}"])
            assert vec.single_observation_space.contains(obs[b * u_n])
        actions = rng.uniform(-1.5, 1.5, vec.action_space.shape).astype(np.float32)
        obs, reward, terminated, _, info = vec.step(actions)
        for b, env in enumerate(singles):
            acts = {f"uav_{u}": actions[b * u_n + u] for u in range(u_n)}
            got, rewards, terms, _, infos = env.step(acts)
            assert reward[b * u_n] == rewards["uav_0"] == reward[b * u_n + 1]
            assert terminated[b * u_n] == terms["uav_0"]
            if terms["uav_0"]:  # the last observation under final_obs, the next episode's first now
                last = info["final_obs"]
                for u in range(u_n):
                    np.testing.assert_array_equal(last[b * u_n + u], got[f"uav_{u}"])
                assert info["final_info"]["min_rate"][b * u_n] == infos["uav_0"]["min_rate"]
                got = env.reset(seed=None)[0]  # (static, known nodes: the seed draws nothing)
            else:
                assert info["min_rate"][b * u_n] == infos["uav_0"]["min_rate"]
                assert info["separation_fraction"][b * u_n + 1] == infos["uav_1"]["separation_fraction"]
            want[b] = got


@pytest.mark.parametrize(
    ("args", "kwargs", "message"),
    [
        ((0,), {}, "num_fleets must be an integer >= 1"),
        ((2,), {"uavs": 1}, "FleetVectorEnv takes uavs >= 2"),
        ((2,), {"best_schedule": True}, "best_schedule=True"),
        ((2,), {"min_separation": -1.0}, "min_separation must be a finite number >= 0"),
    ],
)
def test_bad_arguments_are_refused_by_name(args, kwargs, message):
    with pytest.raises(ValueError, match=message):
        FleetVectorEnv(*args, CONFIG, **kwargs)


def test_bad_actions_are_refused_by_name():
    vec = FleetVectorEnv(2, CONFIG)
    vec.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions must be a finite array of shape \(4, 6\)"):
        vec.step(np.zeros((2, 6)))
    with pytest.raises(ValueError, match="finite"):
        vec.step(np.full((4, 6), np.nan))
