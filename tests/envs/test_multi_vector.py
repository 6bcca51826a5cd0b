"""The batched multi-node env (ios_uav_env/envs/multi_vector.py): the same episodes as B single
MultiNodeEnvs in Gymnasium's SyncVectorEnv (both ids, both autoreset modes, across episode
ends, with and without numba), info as arrays, pinned scenarios, errors."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence
from gymnasium.vector import AutoresetMode

import ios_uav_env
from ios_uav_env import ScenarioConfig, maxmin_rate
from ios_uav_env.envs.core.vector import UAVVectorEnv
from ios_uav_env.envs.multi import DEFAULT_NODES, MULTI_INFO_KEYS, MultiNodeEnv
from ios_uav_env.envs.multi_vector import MultiNodeVectorEnv
from ios_uav_env.model.scenarios import ScenarioRanges
from tests.processes import run_without_numba

FIXED, RANDOM = "ios_uav_env/IOSUAV-MultiNode-v0", "ios_uav_env/IOSUAV-MultiNode-Random-v0"
#: Short episodes (39 to 59 moves) so that 130 steps cross two or three episode ends.
KWARGS = {FIXED: {"T": 40.0}, RANDOM: {"ranges": ScenarioRanges(T=(40.0, 60.0))}}
SMALL = ScenarioConfig(T=40.0, ground_nodes=DEFAULT_NODES[:2])


def make_vec(env_id: str, num_envs: int, **kwargs) -> MultiNodeVectorEnv:
    return gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs)


def replay_gap(
    env_id: str,
    mode: str,
    steps: int = 130,
    n: int = 3,
    seed: int = 7,
    extra: dict | None = None,
    kwargs: dict | None = None,
) -> float:
    """Step the batched env and Gymnasium's SyncVectorEnv of n single envs with the same seeds and
    random actions; return the largest difference of observations, rewards and every info
    value (final ones included). Asserts equal flags, dtypes and shapes, and the trajectories
    and shares of every finished episode. ``kwargs``: the envs' keywords (default: this module's
    ``KWARGS[env_id]``), updated with ``extra``."""
    kwargs = {**(KWARGS[env_id] if kwargs is None else kwargs), **(extra or {})}
    sync_mode = AutoresetMode.SAME_STEP if mode == "same_step" else AutoresetMode.NEXT_STEP
    vec = make_vec(env_id, n, autoreset_mode=mode, **kwargs)
    ref = gym.make_vec(
        env_id, n, vectorization_mode="sync", vector_kwargs={"autoreset_mode": sync_mode}, **kwargs
    )
    assert vec.metadata["autoreset_mode"] == ref.metadata["autoreset_mode"] == sync_mode
    (obs, info), (obs_ref, info_ref) = vec.reset(seed=seed), ref.reset(seed=seed)
    gap = info_gap(info, info_ref, np.ones(n, dtype=bool))
    gap = max(gap, float(np.abs(obs - obs_ref).max()))
    rng, ended = np.random.default_rng(seed), 0
    for _ in range(steps):
        actions = rng.uniform(-1.3, 1.3, (n, *vec.single_action_space.shape))
        for i, env in enumerate(ref.envs):  # the finished episodes, before the reference resets them
            if mode == "next_step" and ref._autoreset_envs[i]:
                last = env.unwrapped
                np.testing.assert_array_equal(vec.trajectories[i], last.trajectory)
                np.testing.assert_allclose(vec.schedules[i], last.shares, rtol=0, atol=1e-15)
        obs, reward, terminated, truncated, info = vec.step(actions)
        obs_ref, reward_ref, terminated_ref, truncated_ref, info_ref = ref.step(actions)
        assert obs.dtype == obs_ref.dtype and vec.observation_space.contains(obs)
        np.testing.assert_array_equal(terminated, terminated_ref)
        assert not truncated.any() and not truncated_ref.any()
        gap = max(gap, float(np.abs(obs - obs_ref).max()), float(np.abs(reward - reward_ref).max()))
        gap = max(gap, info_gap(info, info_ref, np.ones(n, dtype=bool)))
        if mode == "same_step":
            assert set(info_ref) <= set(info)  # (the batched env always has the final_* keys)
            done = info["_final_obs"]
            assert done.any() == ("final_obs" in info_ref)
            if done.any():
                np.testing.assert_array_equal(done, info_ref["_final_obs"])
                final_ref = np.stack([o for o, d in zip(info_ref["final_obs"], done, strict=True) if d])
                gap = max(gap, float(np.abs(info["final_obs"][done] - final_ref).max()))
                gap = max(gap, info_gap(info["final_info"], info_ref["final_info"], done))
        ended += int(terminated.sum())
    assert ended >= 2 * n  # every row crossed at least two episode ends
    return gap


def info_gap(info: dict, ref: dict, rows: np.ndarray) -> float:
    """Largest difference of every info key of ``info`` and ``ref`` on ``rows`` (the same keys, at
    least ``MULTI_INFO_KEYS``; same dtypes, shapes and masks asserted; SyncVectorEnv stacks
    ``np.bool_`` as objects)."""
    gap = 0.0
    keys = [k for k in info if not k.startswith("_") and k not in ("final_obs", "final_info")]
    assert set(MULTI_INFO_KEYS) <= set(keys)
    assert set(keys) == {k for k in ref if not k.startswith("_") and k not in ("final_obs", "final_info")}
    for key in keys:
        a, b = info[key], ref[key]
        b = b.astype(np.bool_) if key == "feasible" and b.dtype == object else b
        assert a.dtype == b.dtype and a.shape == b.shape, key
        assert info[f"_{key}"][rows].all() and ref[f"_{key}"][rows].all()
        if a.dtype == np.bool_ or a.dtype == np.int64:
            np.testing.assert_array_equal(a[rows], b[rows], err_msg=key)
        else:
            gap = max(gap, float(np.abs(a[rows] - b[rows]).max()))
    return gap


@pytest.mark.parametrize("env_id", [FIXED, RANDOM])
def test_make_vec_gives_the_batched_env_for_both_ids(env_id):
    vec = make_vec(env_id, 3)
    single = gym.make(env_id)
    assert type(vec) is UAVVectorEnv and vec.num_envs == 3 and vec.envs[0].view == "node_blocks"
    assert vec.single_observation_space == single.observation_space
    assert vec.single_action_space == single.action_space
    obs, info = vec.reset(seed=0)
    assert obs.shape == (3, *single.observation_space.shape) and vec.observation_space.contains(obs)
    assert info["shares"].shape == (3, vec.max_nodes)


@pytest.mark.parametrize("mode", ["next_step", "same_step"])
@pytest.mark.parametrize("env_id", [FIXED, RANDOM])
def test_batch_equals_single_envs_across_episode_ends(env_id, mode):
    assert replay_gap(env_id, mode) <= 1e-9


@pytest.mark.parametrize("env_id", [FIXED, RANDOM])
def test_batch_equals_single_envs_with_shaping_and_peak_hint(env_id):
    extra = {"softmin_beta": 20.0, "peak_hint": True}
    assert replay_gap(env_id, "same_step", extra=extra) <= 1e-9


@pytest.mark.parametrize("env_id", [FIXED, RANDOM])
def test_batch_equals_single_envs_with_the_reach_and_terminal_penalties(env_id):
    """Without the arrival guard random moves leave qF out of reach: the penalty terms are compared."""
    extra = {"arrival_guard": False}
    assert replay_gap(env_id, "next_step", extra=extra) <= 1e-9
    vec = make_vec(env_id, 3, **KWARGS[env_id], **extra)
    vec.reset(seed=7)
    rng, reach, terminal = np.random.default_rng(7), 0.0, 0.0
    for _ in range(130):
        _, _, _, _, info = vec.step(rng.uniform(-1.3, 1.3, (3, *vec.single_action_space.shape)))
        reach, terminal = min(reach, info["reward_reach"].min()), min(terminal, info["reward_terminal"].min())
    assert reach < 0 and terminal < 0  # (so the replay above compared both terms)


def test_parity_without_numba(tmp_path):
    """The plain-Python kernels (IOS_UAV_ENV_NO_NUMBA=1): the same parity, in a fresh interpreter."""
    code = (
        "import importlib.util, sys, ios_uav_env.jit as j\n"
        "assert not j.HAVE_NUMBA\n"
        f"spec = importlib.util.spec_from_file_location('mnv', {str(Path(__file__))!r})\n"
        "m = importlib.util.module_from_spec(spec)\n"
        "spec.loader.exec_module(m)\n"
        "print(max(m.replay_gap(m.FIXED, 'next_step', 90), m.replay_gap(m.RANDOM, 'same_step', 130, 2)))\n"
    )
    assert float(run_without_numba(code).split()[-1]) <= 1e-9


def test_last_step_reports_both_scores_and_the_lp_can_be_skipped():
    vec = make_vec(FIXED, 2, T=40.0)
    lean = make_vec(FIXED, 2, T=40.0, best_schedule=False)
    vec.reset(seed=3), lean.reset(seed=3)
    actions = np.random.default_rng(0).uniform(-1, 1, (SMALL.N - 1, 2, 5))
    for a in actions:
        _, reward, terminated, _, info = vec.step(a)
        _, reward_lean, _, _, info_lean = lean.step(a)
        np.testing.assert_array_equal(reward, reward_lean)
    assert terminated.all() and info["slot"].tolist() == [SMALL.N] * 2
    for i, (q, cfg) in enumerate(zip(vec.trajectories, vec.configs, strict=True)):
        best = maxmin_rate(cfg, q)  # (the env's rates are its kernels': equal to rounding)
        assert info["best_schedule_rate"][i] == pytest.approx(best, rel=1e-12)
        assert best >= info["min_rate"][i] > 0
    assert np.isnan(info_lean["best_schedule_rate"]).all()
    np.testing.assert_array_equal(info_lean["min_rate"], info["min_rate"])
    _, _, _, _, info = vec.step(actions[0])  # the reset step: 0 before the last slot
    assert (info["best_schedule_rate"] == 0).all() and info["slot"].tolist() == [1, 1]


def test_info_is_arrays_with_gymnasium_masks_and_outputs_are_fresh():
    vec = MultiNodeVectorEnv(4, SMALL, max_nodes=3)
    vec.reset(seed=0)
    obs, _, _, _, info = vec.step(np.zeros((4, 5)))
    assert list(info)[: len(MULTI_INFO_KEYS)] == list(MULTI_INFO_KEYS)
    for key in MULTI_INFO_KEYS:
        width = {"position": (4, 2), "shares": (4, 3), "node_rates": (4, 3)}
        assert info[key].shape == width.get(key, (4,)) and info[f"_{key}"].all()
    assert info["slot"].dtype == np.int64 and info["feasible"].dtype == np.bool_
    np.testing.assert_allclose(info["shares"], [[0.5, 0.5, 0.0]] * 4)  # K = 2 of 3: padded
    keep = obs.copy(), info["shares"].copy()
    vec.step(np.ones((4, 5)))
    assert np.array_equal(obs, keep[0]) and np.array_equal(info["shares"], keep[1])


def test_deterministic_for_a_seed():
    runs = []
    for _ in range(2):
        vec = make_vec(RANDOM, 3)
        out = [vec.reset(seed=4)]
        out += [vec.step(np.full((3, 6), 0.3)) for _ in range(5)]
        runs.append(out)
    assert data_equivalence(runs[0], runs[1], exact=True)


def test_pinned_scenarios_for_every_row_and_one_per_row():
    vec = make_vec(RANDOM, 3)
    vec.reset(seed=0, options={"config": SMALL})
    assert vec.configs == [SMALL] * 3
    configs = [SMALL, SMALL.replace(surface="ris"), SMALL.replace(ground_nodes=DEFAULT_NODES)]
    obs, info = vec.reset(seed=5, options={"configs": configs})
    for i, cfg in enumerate(configs):
        single, single_info = MultiNodeEnv(random_nodes=(2, 4)).reset(seed=5 + i, options={"config": cfg})
        np.testing.assert_array_equal(obs[i], single)
        np.testing.assert_array_equal(info["shares"][i], single_info["shares"])
    with pytest.raises(ValueError, match="3 scenarios"):
        vec.reset(options={"configs": configs[:2]})
    too_many = SMALL.replace(ground_nodes=(*DEFAULT_NODES, (10.0, 50.0)))
    with pytest.raises(ValueError, match="max_nodes = 3"):
        make_vec(FIXED, 2).reset(options={"config": too_many})


def test_restart_starts_new_episodes_on_the_given_rows_only():
    vec = MultiNodeVectorEnv(3, SMALL)
    vec.reset(seed=0)
    for _ in range(4):
        vec.step(np.zeros((3, 4)))
    obs = vec.restart([1])
    assert [len(q) for q in vec.trajectories] == [5, 1, 5]
    assert [s.shape for s in vec.schedules] == [(2, 5), (2, 1), (2, 5)]
    np.testing.assert_array_equal(obs[1], MultiNodeEnv(SMALL).reset(seed=1)[0])


def test_bad_actions_are_refused_naming_the_field():
    """(The batch arguments, num_envs, seeds, ..., are the base's: tests/envs/test_batched.py.)"""
    vec = MultiNodeVectorEnv(3, SMALL)
    vec.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions must have shape \(3, 4\)"):
        vec.step(np.zeros((3, 2)))
    bad = np.zeros((3, 4))
    bad[1, 3] = np.nan
    with pytest.raises(ValueError, match=r"rows \[1\] are not \(fields \['score_1'\]\)"):
        vec.step(bad)
    bad[1, 3], bad[2, 0] = 0.0, np.inf
    with pytest.raises(ValueError, match=r"rows \[2\] are not \(fields \['move_x'\]\)"):
        vec.step(bad)
    with pytest.raises(TypeError, match="unexpected keyword argument 'frameskip'"):
        MultiNodeVectorEnv(2, frameskip=1)


def test_every_id_of_the_package_has_a_batched_env():
    ids = [
        *ios_uav_env.ENV_IDS,
        *ios_uav_env.RANDOM_IDS,
        *ios_uav_env.MULTINODE_IDS,
        *ios_uav_env.ENERGY_IDS,
        *ios_uav_env.MOBILE_IDS,
        *ios_uav_env.MULTINODE_MOBILE_IDS,
        *ios_uav_env.MISO_IDS,
    ]
    assert all(gym.spec(env_id).vector_entry_point for env_id in ids)


def test_rows_grow_for_a_finer_surface_and_a_longer_horizon():
    """A row first holds a 4 x 4 surface (16 nodes) and 40 slots, then a pinned 100 x 20 one and
    60 slots: the arrays grow and the episodes still equal the single env's."""
    kwargs = {"random_nodes": (2, 4), "ranges": ScenarioRanges(T=(40.0, 60.0))}
    small = SMALL.replace(ios_shape=(4, 4))
    vec = MultiNodeVectorEnv(2, **kwargs)
    vec.reset(seed=0, options={"config": small})
    configs = [SMALL.replace(T=60.0), small]
    obs, _ = vec.reset(seed=3, options={"configs": configs})
    singles = [MultiNodeEnv(**kwargs) for _ in configs]
    first = [
        env.reset(seed=3 + i, options={"config": c})[0]
        for i, (env, c) in enumerate(zip(singles, configs, strict=True))
    ]
    np.testing.assert_array_equal(obs, np.stack(first))
    rng = np.random.default_rng(1)
    for _ in range(59):
        actions = rng.uniform(-1.2, 1.2, (2, 6))
        obs, reward, _, _, info = vec.step(actions)
        for i, env in enumerate(singles):
            if len(env.trajectory) == env.config.N:  # the batch reset this row at this step
                continue
            o, r, _, _, inf = env.step(actions[i])
            np.testing.assert_allclose(obs[i], o, rtol=0, atol=1e-9)
            assert abs(reward[i] - r) <= 1e-9 and np.array_equal(info["position"][i], inf["position"])
    np.testing.assert_array_equal(vec.trajectories[0], singles[0].trajectory)  # all 60 way-points


@pytest.mark.parametrize("mode", ["next_step", "same_step"])
def test_advance_steps_the_masked_rows_only(mode):
    """advance(actions, rows): the masked rows step as in step(); the others keep their state,
    observation and info (reward 0, not terminated); a held row waits for its NEXT_STEP autoreset."""
    n, moves = 3, SMALL.N - 1
    vec, ref = (MultiNodeVectorEnv(n, SMALL, autoreset_mode=mode) for _ in range(2))
    obs, info = vec.reset(seed=0)
    ref.reset(seed=0)
    actions = np.random.default_rng(1).uniform(-1, 1, (moves + 2, n, 4))
    rows = np.array([True, False, True])
    for t in range(moves):
        held_obs, held_info = obs.copy(), {k: np.copy(v) for k, v in info.items()}
        obs, reward, terminated, _, info = vec.advance(actions[t], rows)
        ref_obs, ref_reward, ref_terminated, _, _ = ref.step(actions[t])
        np.testing.assert_array_equal(obs[rows], ref_obs[rows])
        np.testing.assert_array_equal(reward[rows], ref_reward[rows])
        np.testing.assert_array_equal(obs[1], held_obs[1])
        assert reward[1] == 0.0 and not terminated[1]
        for key in MULTI_INFO_KEYS:
            np.testing.assert_array_equal(info[key][1], held_info[key][1])
    assert terminated[rows].all() and [len(q) for q in vec.trajectories] in ([SMALL.N, 1, SMALL.N], [1, 1, 1])
    # the held row now steps its whole episode alone; rows 0 and 2 wait
    if mode == "next_step":
        before = obs.copy()
        obs, reward, terminated, _, _ = vec.advance(actions[0], ~rows)
        np.testing.assert_array_equal(obs[rows], before[rows])  # their autoreset waits for their next step
        assert [len(q) for q in vec.trajectories] == [SMALL.N, 2, SMALL.N]
        obs, *_ = vec.advance(actions[0], rows)
        np.testing.assert_array_equal(obs[0], MultiNodeEnv(SMALL).reset(seed=0)[0])  # reset now
    with pytest.raises(ValueError, match="boolean mask of shape"):
        vec.advance(actions[0], np.array([1, 0, 1]))


def test_fly_is_the_steps_it_hides_in_one_call():
    """fly(rows, targets, moves): the compiled flight equals advance() steps of full-speed moves
    with equal shares (the stepped flight, ``_fly_stepped``), leaves the other rows and the
    arrays returned last alone, and refuses a flight that would end an episode."""
    fast, slow = (MultiNodeVectorEnv(3, SMALL) for _ in range(2))
    first = fast.reset(seed=0)[0]
    slow.reset(seed=0)
    rows, targets, moves = np.array([0, 2]), np.array([[100.0, 0.0], [-40.0, 90.0]]), np.array([5, 12])
    obs = fast.fly(rows, targets, moves)
    ref = slow._fly_stepped(*slow._fly_args(rows, targets, moves))
    np.testing.assert_allclose(obs, ref, atol=1e-6)
    np.testing.assert_array_equal(obs[1], first[1])
    np.testing.assert_array_equal(first[0], MultiNodeEnv(SMALL).reset(seed=0)[0])  # returned arrays kept
    paths = fast.trajectories
    assert [len(p) for p in paths] == [6, 1, 13]
    np.testing.assert_allclose(paths[2], slow.trajectories[2], atol=1e-9)
    np.testing.assert_allclose(np.hypot(*np.diff(paths[2], axis=0).T), SMALL.D)  # full speed
    np.testing.assert_allclose(fast.schedules[2][:, 1:], 1 / SMALL.K)  # equal shares
    hover = np.zeros((3, 4))  # and the episodes go on from there alike
    np.testing.assert_allclose(fast.step(hover)[0], slow.step(hover)[0], atol=1e-6)
    with pytest.raises(ValueError, match="leave each row's episode unfinished"):
        fast.fly([1], [[0.0, 0.0]], [SMALL.N - 1])
    with pytest.raises(ValueError, match="one target"):
        fast.fly([1, 2], [[0.0, 0.0]], [1, 1])
