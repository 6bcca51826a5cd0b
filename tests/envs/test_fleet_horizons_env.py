"""Per-UAV horizons in the fleet's envs (``envs.fleet``, ``fleet_vector``, ``fleet_central``): the
PettingZoo checks with unequal horizons, agents leave at their own horizon at their final point
whatever the actions, a finished UAV serves nothing and is not guarded, the batched fleets equal
the parallel env bit for bit, and the central env ignores a finished UAV's action."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pettingzoo")
from pettingzoo.test import parallel_api_test, parallel_seed_test  # noqa: E402

import ios_uav_env  # noqa: E402
from ios_uav_env import ScenarioConfig  # noqa: E402
from ios_uav_env.envs.fleet_central import FleetCentralEnv  # noqa: E402
from ios_uav_env.envs.fleet_vector import FleetVectorEnv  # noqa: E402
from ios_uav_env.model.fleet import fleet_maxmin, link_rates, slot_service  # noqa: E402

CONFIG = ScenarioConfig(
    ground_nodes=((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0)), ios_shape=(8, 6), T=12.0, v_max=50.0,
    q0=(-200.0, 20.0), qF=(200.0, 20.0),
)  # fmt: skip
STARTS = [[-200.0, 20.0], [-200.0, -60.0], [-200.0, 100.0]]
FINALS = [[200.0, 20.0], [200.0, -60.0], [200.0, 100.0]]
FLEET = {
    "uavs": 3,
    "starts": STARTS,
    "finals": FINALS,
    "min_separation": 15.0,
    "horizons": [12.0, 10.0, 11.0],
}


def test_the_pettingzoo_checks_pass_with_unequal_horizons():
    parallel_api_test(ios_uav_env.parallel_env(CONFIG, **FLEET), num_cycles=30)
    parallel_seed_test(lambda: ios_uav_env.parallel_env(CONFIG, **FLEET))


def _away(env, agent):  # full speed away from its final point, every node score and bid random
    u = int(agent.split("_")[1])
    q = env.trajectories[u, -1]
    away = (q - env.finals[u]) / max(np.hypot(*(q - env.finals[u])), 1e-9)
    return np.concatenate([1.5 * away, np.linspace(-1, 1, env.action_space(agent).shape[0] - 2)])


def test_each_agent_leaves_at_its_horizon_at_its_final_point():
    env = ios_uav_env.parallel_env(CONFIG, **FLEET)
    env.reset(seed=0)
    last_step, step, rewards = {}, 0, []
    while env.agents:
        live = list(env.agents)
        _, reward, term, _, infos = env.step({a: _away(env, a) for a in live})
        step += 1
        assert set(reward) == set(term) == set(live) and len(set(reward.values())) == 1  # the team's
        rewards.append(reward[live[0]])
        for agent in live:
            assert term[agent] == (agent not in env.agents)  # terminated = leaves now
            if term[agent]:
                last_step[agent] = step
                assert infos[agent]["terminal_miss"] == 0.0 and infos[agent]["feasible"]
    assert last_step == {"uav_0": 11, "uav_1": 9, "uav_2": 10}  # N_u - 1 steps each
    flights = env.trajectories
    for u, n_u in enumerate(env.horizon_slots):
        np.testing.assert_allclose(flights[u, n_u - 1], FINALS[u], atol=1e-9)  # arrived by its horizon
        np.testing.assert_array_equal(
            flights[u, n_u - 1 :], np.broadcast_to(flights[u, n_u - 1], (12 - n_u + 1, 2))
        )
        assert np.hypot(*np.diff(flights[u, :n_u], axis=0).T).max() <= CONFIG.D * (1 + 1e-9)
    assert infos["uav_0"]["best_schedule_rate"] == fleet_maxmin(CONFIG, flights, slots=[12, 10, 11]).value
    assert sum(r - 0.0 for r in rewards) == pytest.approx(CONFIG.N * infos["uav_0"]["min_rate"], rel=1e-12)


def test_a_finished_uav_serves_nothing_and_the_others_fly_on():
    """After UAV 1's horizon the team's service of a slot is slot_service of the UAVs still flying,
    with the surface shared between them only."""
    env = ios_uav_env.parallel_env(CONFIG, uavs=2, starts=STARTS[:2], finals=FINALS[:2], horizons=[12.0, 9.0])
    env.reset(seed=1)
    rng = np.random.default_rng(1)
    served = None
    while env.agents:
        live = list(env.agents)
        _, _, _, _, infos = env.step({a: rng.uniform(-1, 1, env.action_space(a).shape) for a in live})
        if live == ["uav_0"]:
            q = env.trajectories[:1, -1]
            shares = np.array([infos["uav_0"]["shares"]])
            assert infos["uav_0"]["surface_share"] == 1.0 and infos["uav_0"]["min_distance"] == np.inf
            slot = slot_service(link_rates(CONFIG, q), shares, np.ones(1))
            np.testing.assert_allclose(
                infos["uav_0"]["node_rates"] - served, slot / CONFIG.N, rtol=1e-9, atol=1e-15
            )
        served = infos[live[0]]["node_rates"].copy()
    assert infos["uav_0"]["min_rate"] <= infos["uav_0"]["best_schedule_rate"] * (1 + 1e-9)


def test_a_finished_uav_is_no_longer_guarded():
    """UAV 1 lands on UAV 0's lane at its horizon; UAV 0 flies through that point later, unhindered
    (with both horizons T the guard holds UAV 0 back)."""
    starts, finals = [[-200.0, 0.0], [-60.0, 100.0]], [[200.0, 0.0], [40.0, 0.0]]
    fractions = {}
    for horizons in ([12.0, 4.0], None):
        env = ios_uav_env.parallel_env(CONFIG, uavs=2, starts=starts, finals=finals, horizons=horizons)
        env.reset(seed=0)
        held = 1.0
        while env.agents:
            _, _, _, _, infos = env.step({a: _home(env, a) for a in env.agents})
            held = min(held, infos["uav_0"]["separation_fraction"])
        fractions[horizons is None] = held
    assert fractions[False] == 1.0 and fractions[True] < 1.0


def _home(env, agent):  # straight for its final point at its speed limit
    u = int(agent.split("_")[1])
    move = (env.finals[u] - env.trajectories[u, -1]) / CONFIG.D
    return np.concatenate([move, np.zeros(CONFIG.K), [0.0]])


@pytest.mark.parametrize("access", ["orthogonal", "shared"])
def test_the_batched_fleets_are_the_parallel_env_bit_for_bit(access):
    """Fleet b is the parallel env seeded seed + b; a finished agent's row idles (reward 0, not
    terminated, inactive) with a valid observation, the parallel env's state, until the fleet ends."""
    b_n, u_n = 2, 3
    vec = FleetVectorEnv(b_n, CONFIG, access=access, **FLEET)
    singles = [ios_uav_env.parallel_env(CONFIG, access=access, **FLEET) for _ in range(b_n)]
    obs, _ = vec.reset(seed=3)
    for b, env in enumerate(singles):
        env.reset(seed=3 + b)
    rng = np.random.default_rng(3)
    for _ in range(2 * (CONFIG.N - 1)):  # two episodes: across the autoreset
        for b, env in enumerate(singles):
            np.testing.assert_array_equal(obs[b * u_n : (b + 1) * u_n].reshape(-1), env.state())
            assert all(vec.single_observation_space.contains(o) for o in obs[b * u_n : (b + 1) * u_n])
        actions = rng.uniform(-1.5, 1.5, vec.action_space.shape)
        obs, reward, terminated, _, info = vec.step(actions)
        for b, env in enumerate(singles):
            live = list(env.agents)
            got, rewards, terms, _, infos = env.step({a: actions[b * u_n + int(a[4:])] for a in live})
            now = info.get("final_info", info)  # (this step's arrays; the fleet's end holds only these)
            for u in range(u_n):
                i, agent = b * u_n + u, f"uav_{u}"
                if agent not in live:  # idle until its fleet ends
                    assert reward[i] == 0.0 and not now["active"][i] and terminated[i] == (not env.agents)
                    continue
                assert reward[i] == rewards[agent] and terminated[i] == terms[agent]
                if terms[agent]:
                    assert info["_final_obs"][i] and info["_final_info"][i]
                    np.testing.assert_array_equal(info["final_obs"][i], got[agent])
                assert now["min_rate"][i] == infos[agent]["min_rate"] and now["active"][i]
            if not env.agents:
                env.reset(seed=None)  # (static, known nodes: the seed draws nothing)


def test_the_central_env_ignores_a_finished_uavs_action():
    from gymnasium.utils.env_checker import check_env

    check_env(FleetCentralEnv(CONFIG, **FLEET), skip_render_check=True)
    runs = []
    for noise in (0.0, 1.0):
        env = FleetCentralEnv(CONFIG, **FLEET)
        env.reset(seed=2)
        rng, other = np.random.default_rng(2), np.random.default_rng(99)
        out, done = [], False
        while not done:
            a = rng.uniform(-1, 1, env.action_space.shape)
            for u, agent in enumerate(env.fleet.possible_agents):
                if agent not in env.fleet.agents:  # a finished UAV's part: anything
                    a[u * 6 : (u + 1) * 6] = noise * other.uniform(-1, 1, 6)
            obs, reward, done, _, infos = env.step(a)
            out.append((obs, reward, sorted(infos)))
        runs.append(out)
    assert len(runs[0]) == CONFIG.N - 1 and runs[0][-1][2] == ["uav_0"]
    for (o1, r1, a1), (o2, r2, a2) in zip(*runs, strict=True):
        np.testing.assert_array_equal(o1, o2)
        assert r1 == r2 and a1 == a2


def test_horizons_are_refused_by_name_in_the_envs():
    with pytest.raises(ValueError, match=r"horizons\[1\] must be a multiple of dt = 1 s within \[2, 12\] s"):
        ios_uav_env.parallel_env(CONFIG, uavs=2, horizons=[12.0, 13.0])
    with pytest.raises(ValueError, match="horizons: one UAV flies the scenario's T = 12 s"):
        ios_uav_env.parallel_env(CONFIG, uavs=1, horizons=[10.0])
    with pytest.raises(ValueError, match=r"horizons\[0\] = 5 s: T=5.0 s is too short"):
        FleetVectorEnv(2, CONFIG, uavs=2, horizons=[5.0, 12.0])
    one = ios_uav_env.parallel_env(CONFIG, uavs=1, horizons=12.0)  # the scenario's T: the env itself
    assert one.horizon_slots.tolist() == [12]


def test_render_draws_each_uav_up_to_its_horizon():
    pytest.importorskip("matplotlib")
    env = ios_uav_env.parallel_env(CONFIG, render_mode="rgb_array", **FLEET)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    while env.agents:
        env.step({a: rng.uniform(-1, 1, env.action_space(a).shape) for a in env.agents})
    image = env.render()
    assert image.ndim == 3 and image.dtype == np.uint8
