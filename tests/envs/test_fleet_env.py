"""Several UAVs on PettingZoo's Parallel API (``envs.fleet``): the API and seeding checks, one
UAV is the multi-node env bit for bit, the separation guard holds against adversarial actions,
the team's rates are a schedule of the fleet model (at most its best schedule), and bad input
is refused by name."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

pytest.importorskip("pettingzoo")
from pettingzoo.test import parallel_api_test, parallel_seed_test  # noqa: E402

import ios_uav_env  # noqa: E402
from ios_uav_env import MultiNodeEnv, ScenarioConfig  # noqa: E402
from ios_uav_env.model.fleet import fleet_maxmin, link_gains_batch, link_rates, slot_service  # noqa: E402
from ios_uav_env.model.separation import min_distance  # noqa: E402

# small surface and horizon: the physics of the paper's scenario at test speed
CONFIG = ScenarioConfig(
    ground_nodes=((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0)), ios_shape=(8, 6), T=24.0, v_max=50.0
)


@pytest.mark.parametrize("uavs", [1, 2, 3])
def test_parallel_api_and_seeding(uavs):
    parallel_api_test(ios_uav_env.parallel_env(CONFIG, uavs=uavs), num_cycles=40)
    parallel_seed_test(lambda: ios_uav_env.parallel_env(CONFIG, uavs=uavs))


def test_one_uav_is_the_multi_node_env_bit_for_bit():
    fleet = ios_uav_env.parallel_env(CONFIG, uavs=1)
    single = MultiNodeEnv(CONFIG)
    obs, info = fleet.reset(seed=4)
    want_obs, want_info = single.reset(seed=4)
    rng = np.random.default_rng(4)
    while True:
        np.testing.assert_array_equal(obs["uav_0"], want_obs)
        assert info["uav_0"].keys() == want_info.keys()
        for key, value in want_info.items():
            np.testing.assert_array_equal(info["uav_0"][key], value)
        if not fleet.agents:
            break
        a = rng.uniform(-1.5, 1.5, 2 + CONFIG.K).astype(np.float32)
        obs, reward, term, _, info = fleet.step({"uav_0": a})
        want_obs, want_reward, want_term, _, want_info = single.step(a)
        assert reward["uav_0"] == want_reward and term["uav_0"] == want_term
    np.testing.assert_array_equal(fleet.state(), want_obs)


def _fly(env, policy, seed=0):
    obs, infos = env.reset(seed=seed)
    closest, last, held = np.inf, infos, 1.0
    while env.agents:
        obs, rewards, terms, truncs, last = env.step({a: policy(env, a, obs[a]) for a in env.agents})
        closest = min(closest, min_distance(env.trajectories[:, -1]))
        held = min(held, last["uav_0"]["separation_fraction"])
        assert len(set(rewards.values())) == 1  # the team reward
    return closest, last, held


def test_separation_holds_against_uavs_steered_at_each_other():
    starts = np.array([[-60.0, 0.0], [60.0, 0.0], [0.0, 70.0]])
    finals = np.array([[60.0, 5.0], [-60.0, -5.0], [0.0, -70.0]])
    env = ios_uav_env.parallel_env(CONFIG, uavs=3, starts=starts, finals=finals, min_separation=15.0)
    centre = starts.mean(axis=0)

    def charge(env, agent, obs):  # everyone flies at full speed to the same point, then at the others
        u = int(agent.split("_")[1])
        q = env.trajectories[u, -1]
        aim = centre if len(env.trajectories[0]) < 5 else env.trajectories[(u + 1) % 3, -1]
        move = (aim - q) / max(np.hypot(*(aim - q)), 1e-9)
        return np.concatenate([move, np.zeros(CONFIG.K), [1.0]]).astype(np.float32)

    closest, last, held = _fly(env, charge)
    assert held < 1.0  # the guard acted
    assert closest >= 15.0
    flights = env.trajectories
    for s in np.linspace(0.0, 1.0, 11):  # between way-points too
        between = flights[:, :-1] + s * (flights[:, 1:] - flights[:, :-1])
        assert min(min_distance(between[:, n]) for n in range(between.shape[1])) >= 15.0
    assert all(np.all(np.hypot(*np.diff(f, axis=0).T) <= CONFIG.D * (1 + 1e-9)) for f in flights)


def test_random_flights_arrive_and_score_below_their_best_schedule():
    env = ios_uav_env.parallel_env(CONFIG, uavs=2)
    rng = np.random.default_rng(1)
    closest, last, held = _fly(env, lambda env, a, o: rng.uniform(-1, 1, env.action_space(a).shape), seed=1)
    assert closest >= env.min_separation
    flights = env.trajectories
    assert held == 1.0  # (this seed's flights never meet: the arrival guard alone shapes them)
    np.testing.assert_allclose(flights[:, -1], env.finals, atol=1e-9)
    info = last["uav_0"]
    best = fleet_maxmin(CONFIG, flights)
    assert info["best_schedule_rate"] == best.value
    assert info["min_rate"] <= best.upper * (1 + 1e-9) and info["min_rate"] > 0.0
    assert info["feasible"] and last["uav_1"]["feasible"]


def test_the_team_served_rate_is_in_the_observation():
    env = ios_uav_env.parallel_env(CONFIG, uavs=2)
    obs, _ = env.reset(seed=0)
    obs, _, _, _, infos = env.step({a: env.action_space(a).sample() for a in env.agents})
    names = env.observation_names
    served = [names.index(f"served_{k}") for k in range(CONFIG.K)]
    for agent in env.possible_agents:
        np.testing.assert_allclose(obs[agent][served], infos[agent]["node_rates"], rtol=1e-6)
        assert env.observation_space(agent).contains(obs[agent])
    assert obs["uav_0"][-2:] == pytest.approx(-obs["uav_1"][-2:])  # each sees the other


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"uavs": 0}, "uavs must be an integer >= 1"),
        ({"uavs": 2, "starts": [[0.0, 0.0]]}, r"starts must be a finite \(2, 2\) array"),
        ({"uavs": 2, "starts": [[-400.0, 20.0], [-400.0, 25.0]]}, "starts: UAVs 0 and 1 are 5 m apart"),
        ({"uavs": 2, "min_separation": -1.0}, "min_separation must be a finite number >= 0"),
        ({"uavs": 2, "channel": "rician"}, "channel='rician': several UAVs take channel='expected'"),
        ({"uavs": 2, "arrival_guard": False}, "arrival_guard=False"),
        ({"uavs": 2, "surface_sharpness": 0.0}, "surface_sharpness must be a finite number > 0"),
    ],
)
def test_bad_arguments_are_refused_by_name(kwargs, message):
    with pytest.raises(ValueError, match=message):
        ios_uav_env.parallel_env(CONFIG, **kwargs)


def test_bad_actions_are_refused_by_name():
    env = ios_uav_env.parallel_env(CONFIG, uavs=2)
    env.reset(seed=0)
    good = {a: np.zeros(env.action_space(a).shape, np.float32) for a in env.agents}
    with pytest.raises(ValueError, match="must map each live agent"):
        env.step({"uav_0": good["uav_0"]})
    with pytest.raises(ValueError, match=r"actions\['uav_1'\] must have shape \(6,\)"):
        env.step({**good, "uav_1": np.zeros(3)})
    with pytest.raises(ValueError, match=r"actions\['uav_0'\] must be finite"):
        env.step({**good, "uav_0": np.full(6, np.nan)})


def test_the_centralised_form_passes_gymnasiums_checker_and_is_the_fleet():
    from gymnasium.utils.env_checker import check_env

    from ios_uav_env.envs.fleet_central import FleetCentralEnv

    check_env(FleetCentralEnv(CONFIG, uavs=2), skip_render_check=True)
    central, fleet = FleetCentralEnv(CONFIG, uavs=2), ios_uav_env.parallel_env(CONFIG, uavs=2)
    obs, _ = central.reset(seed=3)
    fleet.reset(seed=3)
    rng = np.random.default_rng(3)
    done = False
    while not done:
        a = rng.uniform(-1, 1, central.action_space.shape).astype(np.float32)
        obs, reward, done, _, _ = central.step(a)
        _, rewards, _, _, _ = fleet.step({"uav_0": a[:6], "uav_1": a[6:]})
        np.testing.assert_array_equal(obs, fleet.state())
        assert reward == rewards["uav_0"]


def test_a_shared_band_serves_the_same_flights_less_and_below_its_best_schedule():
    rates = {}
    for access in ("orthogonal", "shared"):
        env = ios_uav_env.parallel_env(CONFIG, uavs=2, access=access)
        rng = np.random.default_rng(7)
        _, last, _ = _fly(
            env, lambda env, a, o, rng=rng: rng.uniform(-1, 1, env.action_space(a).shape), seed=7
        )
        info = last["uav_0"]
        assert info["min_rate"] <= info["best_schedule_rate"] * (1 + 1e-9)
        rates[access] = (info["node_rates"], env.trajectories)
    np.testing.assert_array_equal(rates["orthogonal"][1], rates["shared"][1])  # the same flights
    assert np.all(rates["shared"][0] < rates["orthogonal"][0])  # interference at every node
    with pytest.raises(ValueError, match="access must be one of"):
        ios_uav_env.parallel_env(CONFIG, uavs=2, access="tdma")


def test_the_state_passes_pettingzoos_state_test():
    state_test = importlib.import_module("pettingzoo.test.state_test")
    for uavs in (1, 2):
        state_test.test_parallel_env(ios_uav_env.parallel_env(CONFIG, uavs=uavs))


def test_scenario_keywords_are_the_fleets_scenario():
    env = ios_uav_env.parallel_env(CONFIG, uavs=2, T=30.0, noise_dbm=-70.0)
    assert env.config == CONFIG.replace(T=30.0, noise_dbm=-70.0)
    assert all(u.config == env.config.replace(q0=tuple(s), qF=tuple(f))
               for u, s, f in zip(env.uav_envs, env.starts, env.finals, strict=True))  # fmt: skip
    rng = np.random.default_rng(2)
    _, last, _ = _fly(env, lambda env, a, o: rng.uniform(-1, 1, env.action_space(a).shape), seed=2)
    assert env.trajectories.shape[1] == 30 and last["uav_0"]["feasible"] and last["uav_1"]["feasible"]
    with pytest.raises(ValueError, match="several UAVs have the rate objective"):
        ios_uav_env.parallel_env(CONFIG, uavs=2, objective="energy_efficiency")


def test_the_team_return_is_n_times_the_min_rate_and_the_service_is_the_models():
    """Sum of the rate terms = N x the final min rate (the potential starts at 0, as MultiNodeEnv's);
    the team's served sums are slot_service of the shares, surface shares and way-points, the
    surface shares the softmax of surface_sharpness x the clipped bids."""
    env = ios_uav_env.parallel_env(CONFIG, uavs=2, surface_sharpness=3.0)
    env.reset(seed=5)
    rng = np.random.default_rng(5)
    k_n = CONFIG.K
    served = slot_service(
        link_rates(CONFIG, env.trajectories[:, 0]), np.full((2, k_n), 1 / k_n), np.full(2, 0.5)
    )
    total = 0.0
    while env.agents:
        acts = {a: rng.uniform(-1.5, 1.5, env.action_space(a).shape) for a in env.agents}
        _, _, _, _, infos = env.step(acts)
        bids = 3.0 * np.clip([acts["uav_0"][-1], acts["uav_1"][-1]], -1, 1)
        beta = np.exp(bids - bids.max()) / np.exp(bids - bids.max()).sum()
        assert [infos[a]["surface_share"] for a in ("uav_0", "uav_1")] == pytest.approx(beta, rel=1e-12)
        shares = np.array([infos[a]["shares"] for a in ("uav_0", "uav_1")])
        served = served + slot_service(link_rates(CONFIG, env.trajectories[:, -1]), shares, beta)
        total += infos["uav_0"]["reward_rate"]
    np.testing.assert_allclose(infos["uav_0"]["node_rates"], served / CONFIG.N, rtol=1e-12)
    assert total == pytest.approx(CONFIG.N * infos["uav_0"]["min_rate"], rel=1e-12)


def test_reset_options():
    one, single = ios_uav_env.parallel_env(CONFIG, uavs=1), MultiNodeEnv(CONFIG)
    pinned = {"config": CONFIG.replace(ground_nodes=((-90.0, -20.0), (150.0, -60.0), (-40.0, 90.0)))}
    np.testing.assert_array_equal(
        one.reset(seed=1, options=pinned)[0]["uav_0"], single.reset(seed=1, options=pinned)[0]
    )
    two = ios_uav_env.parallel_env(CONFIG, uavs=2)
    two.reset(seed=0, options={"anything": 1})  # PettingZoo's API test passes such options: ignored
    with pytest.raises(ValueError, match=r'options\["config"\]: several UAVs fly the fleet'):
        two.reset(seed=0, options=pinned)


def test_a_bystander_keeps_flying_while_two_uavs_meet():
    starts = np.array([[-60.0, 0.0], [60.0, 0.0], [-60.0, 150.0]])
    finals = np.array([[60.0, 0.0], [-60.0, 0.0], [60.0, 150.0]])  # two head-on, one on a clear lane
    env = ios_uav_env.parallel_env(CONFIG, uavs=3, starts=starts, finals=finals)

    def home(env, agent, obs):
        u = int(agent.split("_")[1])
        move = (env.finals[u] - env.trajectories[u, -1]) / CONFIG.D
        return np.concatenate([move, np.zeros(CONFIG.K), [0.0]])

    closest, last, held = _fly(env, home)
    assert held < 1.0 and closest >= env.min_separation
    np.testing.assert_allclose(env.trajectories[2, -1], finals[2], atol=1e-9)  # the bystander arrives
    assert last["uav_2"]["terminal_miss"] == 0.0 and last["uav_0"]["terminal_miss"] > 0.0


def test_each_uav_keeps_its_own_speed_limit():
    env = ios_uav_env.parallel_env(CONFIG, uavs=2, speeds=[50.0, 40.0])
    assert [u.config.v_max for u in env.uav_envs] == [50.0, 40.0]
    rng = np.random.default_rng(9)
    _fly(env, lambda env, a, o: rng.uniform(-1.5, 1.5, env.action_space(a).shape), seed=9)
    steps = np.hypot(*np.diff(env.trajectories, axis=1).transpose(2, 0, 1))  # (U, N - 1) m
    assert steps[1].max() <= 40.0 * CONFIG.dt * (1 + 1e-9) < steps[0].max()
    np.testing.assert_allclose(env.trajectories[:, -1], env.finals, atol=1e-9)


@pytest.mark.parametrize("uavs", [1, 2])
def test_render_draws_the_flights_so_far(uavs):
    pytest.importorskip("matplotlib")
    env = ios_uav_env.parallel_env(CONFIG, uavs=uavs, render_mode="rgb_array")
    env.reset(seed=0)
    before = env.render()
    rng = np.random.default_rng(0)
    for _ in range(5):
        env.step({a: rng.uniform(-1, 1, env.action_space(a).shape) for a in env.agents})
    after = env.render()
    assert before.shape == after.shape and before.dtype == np.uint8 and before.shape[2] == 3
    assert not np.array_equal(before, after)  # the flights (and the title) moved on
    with pytest.warns(UserWarning, match="render_mode"):
        assert ios_uav_env.parallel_env(CONFIG, uavs=uavs).render() is None
    with pytest.raises(ValueError, match="render_mode must be None or 'rgb_array'"):
        ios_uav_env.parallel_env(CONFIG, uavs=uavs, render_mode="human")


def test_the_episode_end_scores_the_flights_from_the_gains_its_slots_computed(monkeypatch):
    """The parallel env keeps its slots' link gains in the model's per-slot cache, so its episode-end
    best schedule (``fleet_maxmin`` of the flights, over the cache) computes no gains again."""
    from ios_uav_env.model import fleet_links

    monkeypatch.setattr(fleet_links, "_GAINS", type(fleet_links._GAINS)())
    computed = []

    def counting(config, positions):
        computed.append(len(positions))
        return link_gains_batch(config, positions)

    monkeypatch.setattr(fleet_links, "link_gains_batch", counting)
    env = ios_uav_env.parallel_env(CONFIG, uavs=2)
    rng = np.random.default_rng(3)
    _, last, _ = _fly(env, lambda env, a, o: rng.uniform(-1, 1, env.action_space(a).shape), seed=3)
    in_flight = sum(computed)
    assert in_flight == CONFIG.N and computed.count(1) == len(computed)  # one row a slot, as it flew
    assert last["uav_0"]["best_schedule_rate"] == fleet_maxmin(CONFIG, env.trajectories).value
    assert sum(computed) == in_flight  # the episode end's schedule and this one: no row computed again
