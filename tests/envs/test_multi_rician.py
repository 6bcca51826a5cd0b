"""The multi-node env with channel "rician": one faded rate per node and slot served (drawn from
the env's ``np_random``), the expected-gain scoring kept in ``info`` beside it, the return's
identity, seeding bit for bit, the batched form row for row, the checker, and the refusals."""

from __future__ import annotations

import dataclasses
import json
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env, data_equivalence
from gymnasium.utils.seeding import np_random

from ios_uav_env import ScenarioConfig, maxmin_rate, score_plan
from ios_uav_env.envs.multi import DEFAULT_NODES, MULTI_INFO_KEYS, MULTINODE_RANGES, MultiNodeEnv
from ios_uav_env.envs.multi_table import ENERGY_INFO_KEYS, RICIAN_INFO_KEYS
from ios_uav_env.model.channel import faded_point, rate_kernel
from ios_uav_env.model.schedule import node_rates, scheduled_rates
from tests.envs.test_multi_energy import play
from tests.envs.test_multi_vector import replay_gap
from tests.processes import run_without_numba

FIXED, RANDOM = "ios_uav_env/IOSUAV-MultiNode-v0", "ios_uav_env/IOSUAV-MultiNode-Random-v0"
MOBILE = "ios_uav_env/IOSUAV-MultiNode-Mobile-v0"
RICIAN = {"channel": "rician"}
SHORT_RANGES = dataclasses.replace(MULTINODE_RANGES, T=(40.0, 50.0))
#: Short episodes of each id with channel "rician" (the mobile id's nodes exactly known: the
#: measured rates of "reports" are faded samples of their own).
KWARGS = {FIXED: {"T": 40.0, **RICIAN}, RANDOM: {"ranges": SHORT_RANGES, **RICIAN},
          MOBILE: {"ranges": SHORT_RANGES, "knowledge": "exact", **RICIAN}}  # fmt: skip
SHORT = ScenarioConfig(T=40.0, ground_nodes=DEFAULT_NODES)
RTOL = 1e-9


def test_each_node_is_served_its_faded_rate_of_the_slot():
    """The served rates S_k / N are the shares times one faded sample per node and slot, drawn
    (K, 2) at a time from the env's generator (the reset's slot, then each step's), with each
    node's kernel (``faded_point``)."""
    env = MultiNodeEnv(SHORT, channel="rician", kappa=3.0)
    out = play(env, seed=4)
    cfg, q, shares = env.config, env.trajectory, env.shares
    rng, _ = np_random(4)
    kernels = [rate_kernel(cfg.node_config(k)) for k in range(cfg.K)]
    faded = np.empty((cfg.K, cfg.N))
    for n in range(cfg.N):
        draws = rng.standard_normal((cfg.K, 2))
        for k, kn in enumerate(kernels):
            faded[k, n] = faded_point(q[n, 0], q[n, 1], draws[k, 0], draws[k, 1], kn.nodes, kn.params)
    served = np.mean(shares * faded, axis=1)
    info = out["infos"][-1]
    np.testing.assert_allclose(info["node_rates"][: cfg.K], served, rtol=1e-12)
    assert info["min_rate"] == pytest.approx(served.min(), rel=1e-12)
    # the expected-gain scoring of the same flight and shares, kept beside it
    expected = scheduled_rates(cfg, q, shares)
    np.testing.assert_allclose(info["expected_node_rates"][: cfg.K], expected, rtol=1e-12)
    assert info["expected_min_rate"] == pytest.approx(score_plan(cfg, q, shares).rate, rel=1e-12)
    assert info["best_schedule_rate"] == pytest.approx(maxmin_rate(cfg, q), rel=1e-6)
    assert not np.allclose(served, expected, rtol=1e-3)  # (the fading is there)
    # the observation's rate features stay the expected-gain rates r_k(q) at the UAV
    names = env.observation_names
    rates = [out["obs"][-1][names.index(f"rate_{k}")] for k in range(cfg.K)]
    np.testing.assert_allclose(rates, node_rates(cfg, q[-1:])[:, 0], rtol=1e-6)


def test_the_return_is_n_times_the_faded_min_rate():
    env = MultiNodeEnv(SHORT, channel="rician")
    out = play(env, seed=1)
    assert sum(out["rewards"]) == pytest.approx(SHORT.N * out["infos"][-1]["min_rate"], rel=1e-12)
    rates = MultiNodeEnv(SHORT)
    plain = play(rates, seed=1)
    np.testing.assert_array_equal(rates.trajectory, env.trajectory)  # the same flight, other rewards
    assert not np.allclose(plain["rewards"], out["rewards"])


@pytest.mark.parametrize("env_id", [FIXED, RANDOM, MOBILE])
def test_the_final_info_agrees_with_score_plan(env_id):
    env = gym.make(env_id, **KWARGS[env_id])
    info = play(env, seed=2)["infos"][-1]
    u = env.unwrapped
    score = score_plan(u.config, u.trajectory, u.shares, u.paths)
    assert info["expected_min_rate"] == pytest.approx(score.rate, rel=RTOL)
    assert info["feasible"] == score.feasible


def test_energy_and_rician_combine():
    """The reward's bits are the faded ones the agent got; the EE in info is score_plan's
    (expected-gain rates)."""
    cfg = SHORT.replace(objective="energy_efficiency")
    env = MultiNodeEnv(cfg, channel="rician")
    out = play(env, seed=3)
    info, q, shares = out["infos"][-1], env.trajectory, env.shares
    assert tuple(info) == MULTI_INFO_KEYS + ENERGY_INFO_KEYS + RICIAN_INFO_KEYS
    score = score_plan(cfg, q, shares)
    assert info["energy_efficiency"] == pytest.approx(score.energy_efficiency, rel=RTOL)
    lam, b = env.reference_efficiency, cfg.bandwidth_hz
    bits = b * cfg.T * info["min_rate"]  # the faded min rate
    assert sum(out["rewards"]) == pytest.approx((bits - lam * score.energy) / (b * cfg.dt), rel=RTOL)


@pytest.mark.parametrize("env_id", [FIXED, RANDOM, MOBILE])
def test_info_keys_and_observations_change_only_with_the_channel(env_id):
    kwargs = {k: v for k, v in KWARGS[env_id].items() if k != "channel"}
    rate, env = gym.make(env_id, **kwargs).unwrapped, gym.make(env_id, **KWARGS[env_id]).unwrapped
    assert env.observation_names == rate.observation_names
    assert tuple(env.reset(seed=0)[1]) == MULTI_INFO_KEYS + RICIAN_INFO_KEYS
    assert tuple(rate.reset(seed=0)[1]) == MULTI_INFO_KEYS


# --- checker, seeding, the batched form ------------------------------------------------------
@pytest.mark.parametrize("env_id", [FIXED, RANDOM, MOBILE])
def test_gymnasiums_checker_passes(env_id):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(env_id, **KWARGS[env_id]).unwrapped, skip_render_check=True)


@pytest.mark.parametrize("env_id", [FIXED, RANDOM])
def test_sb3s_checker_passes(env_id):
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    sb3_checker.check_env(gym.make(env_id, **KWARGS[env_id]).unwrapped, warn=True)


@pytest.mark.parametrize("env_id", [FIXED, RANDOM, MOBILE])
def test_a_seed_reproduces_an_episode_bit_for_bit(env_id):
    a, b = (play(gym.make(env_id, **KWARGS[env_id]), seed=5) for _ in range(2))
    assert data_equivalence(a, b, exact=True)
    c = play(gym.make(env_id, **KWARGS[env_id]), seed=6)
    assert not data_equivalence(a["rewards"], c["rewards"])


def _replay(env_id: str, mode: str, n: int = 3, steps: int = 110) -> float:
    """The batched env and SyncVectorEnv of single envs side by side (``replay_gap``: the largest
    gap of observations, rewards and every info key, final ones included; flags equal), after
    checking that info has this objective's and channel's keys."""
    vec = gym.make_vec(env_id, n, vectorization_mode="vector_entry_point", **KWARGS[env_id])
    assert vec.unwrapped.info_keys == MULTI_INFO_KEYS + RICIAN_INFO_KEYS
    return replay_gap(env_id, mode, steps=steps, n=n, seed=13, kwargs=KWARGS[env_id])


@pytest.mark.parametrize(
    ("env_id", "mode"), [(FIXED, "same_step"), (RANDOM, "next_step"), (MOBILE, "same_step")]
)
def test_the_batch_equals_single_envs_row_for_row(env_id, mode):
    assert _replay(env_id, mode) <= 1e-9


def test_a_batched_flight_steps_rician_rows_slot_by_slot():
    """``fly`` draws each slot's fading as the steps do: the flown rows match single envs stepped
    with the same full-speed moves."""
    vec = gym.make_vec(FIXED, 2, vectorization_mode="vector_entry_point", **KWARGS[FIXED]).unwrapped
    vec.reset(seed=0)
    obs = vec.fly(np.array([0, 1]), np.array([[0.0, 0.0], [100.0, 50.0]]), np.array([5, 3]))
    for i, (target, moves) in enumerate((((0.0, 0.0), 5), ((100.0, 50.0), 3))):
        env = MultiNodeEnv(**KWARGS[FIXED])
        env.reset(seed=i)
        for _ in range(moves):
            move = (np.asarray(target) - env.trajectory[-1]) / env.config.D
            move = move / max(1.0, float(np.hypot(*move)))
            single, *_ = env.step(np.concatenate([move, np.zeros(env.max_nodes)]))
        np.testing.assert_allclose(obs[i], single, rtol=1e-6, atol=1e-6)


# --- what is refused --------------------------------------------------------------------------
def test_refused_combinations_name_the_field():
    with pytest.raises(
        ValueError, match="channel='rician', knowledge='reports'.* a measured rate is the slot's own"
    ):
        gym.make(MOBILE, channel="rician")  # (the id's knowledge: reports)
    with pytest.raises(ValueError, match="kappa is the Rician factor"):
        MultiNodeEnv(T=40.0, kappa=5.0)
    env = MultiNodeEnv(T=40.0, kappa=5.0, **RICIAN)  # with faded rates it counts
    assert env.config.kappa == 5.0


def test_the_plain_python_kernels_give_the_same_episodes(tmp_path):
    """Without numba (IOS_UAV_ENV_NO_NUMBA=1, a fresh interpreter) the batch still equals the
    single envs, and an episode with both the energy objective and faded rates is the compiled
    kernels' to the rounding the guard amplifies."""
    code = (
        "import importlib.util, json, ios_uav_env.jit as j\n"
        "assert not j.HAVE_NUMBA\n"
        f"spec = importlib.util.spec_from_file_location('mr', {str(Path(__file__))!r})\n"
        "m = importlib.util.module_from_spec(spec)\n"
        "spec.loader.exec_module(m)\n"
        "gap = m._replay(m.FIXED, 'next_step', 2, 90)\n"
        "out = m.play(m.MultiNodeEnv(m.SHORT.replace(objective='energy_efficiency'), channel='rician'), 3)\n"
        "print(json.dumps([gap, [float(r) for r in out['rewards']]]))\n"
    )
    gap, rewards = json.loads(run_without_numba(code).split("\n")[-2])
    assert gap <= 1e-9
    compiled = play(MultiNodeEnv(SHORT.replace(objective="energy_efficiency"), channel="rician"), 3)[
        "rewards"
    ]
    # (the compiled channel rounds otherwise, and the arrival guard amplifies a last-bit
    # difference of a position, as in the rate objective's episodes: about 1e-7)
    np.testing.assert_allclose(rewards, compiled, rtol=1e-5, atol=1e-5)
