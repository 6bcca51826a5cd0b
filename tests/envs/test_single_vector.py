"""The natively batched envs (ios_uav_env/envs/single_vector.py): parity with the single env, autoreset,
info as arrays, seeding, errors; both the compiled and the plain-Python kernels."""

from __future__ import annotations

import os
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env
from ios_uav_env import INFO_KEYS, RANDOM_ENV_ID, ScenarioConfig
from ios_uav_env.envs.core.vector import UAVVectorEnv
from ios_uav_env.envs.random_env import RandomIOSUAVEnv
from ios_uav_env.envs.single import IOSUAVEnv
from ios_uav_env.envs.single_vector import IOSUAVVectorEnv, RandomIOSUAVVectorEnv

SHORT = ScenarioConfig(T=40.0, ios_shape=(100, 20))


def make_vec(env_id: str, num_envs: int, **kwargs) -> IOSUAVVectorEnv:
    return gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs)


def replay(vec, singles, actions: np.ndarray, seed: int) -> float:
    """Step the batch and the single envs with the same actions (single envs reset themselves
    when their episode ends, as the batch's NEXT_STEP autoreset does); return the largest gap."""
    obs, info = vec.reset(seed=seed)
    gap = 0.0
    pending = [False] * len(singles)
    for i, env in enumerate(singles):
        o, _ = env.reset(seed=seed + i)
        gap = max(gap, float(np.abs(o - obs[i]).max()))
    for t in range(actions.shape[0]):
        obs, reward, terminated, truncated, info = vec.step(actions[t])
        assert not truncated.any()
        for i, env in enumerate(singles):
            if pending[i]:  # the batch reset this row at this step
                o, inf = env.reset()
                r, term = 0.0, False
                pending[i] = False
            else:
                o, r, term, _, inf = env.step(actions[t, i])
                pending[i] = term
            gap = max(gap, float(np.abs(o - obs[i]).max()), abs(r - reward[i]))
            gap = max(gap, float(np.abs(inf["position"] - info["position"][i]).max()))
            assert term == terminated[i] and inf["slot"] == info["slot"][i]
            assert inf["feasible"] == info["feasible"][i]
            gap = max(
                gap, abs(inf["average_rate"] - info["average_rate"][i]), abs(inf["rate"] - info["rate"][i])
            )
    return gap


@pytest.mark.parametrize("env_id", sorted(ios_uav_env.ENV_IDS))
def test_make_vec_gives_the_batched_env_for_every_id(env_id):
    vec = make_vec(env_id, 3)
    assert type(vec) is UAVVectorEnv and vec.num_envs == 3 and vec.envs[0].view == "v0"
    assert vec.single_observation_space == gym.make(env_id).observation_space
    obs, info = vec.reset(seed=0)
    assert obs.shape == (3, 11) and obs.dtype == np.float32 and vec.observation_space.contains(obs)
    assert make_vec(RANDOM_ENV_ID, 2).envs[0].draws


@pytest.mark.parametrize(
    "kwargs",
    [{}, {"channel": "rician"}, {"arrival_guard": False}, {"peak_hint": True, "instance_features": True}],
)
def test_batch_matches_single_envs_step_for_step_across_episodes(kwargs):
    actions = np.random.default_rng(1).uniform(-1.4, 1.4, (2 * SHORT.N + 5, 3, 2))
    vec = IOSUAVVectorEnv(3, SHORT, **kwargs)
    singles = [IOSUAVEnv(SHORT, **kwargs) for _ in range(3)]
    assert replay(vec, singles, actions, seed=7) <= 1e-9


def test_random_batch_draws_the_single_envs_scenarios():
    ranges = {"T": (40.0, 60.0)}
    actions = np.random.default_rng(2).uniform(-1.2, 1.2, (130, 4, 2))
    vec = RandomIOSUAVVectorEnv(4, ranges, peak_hint=True)
    singles = [RandomIOSUAVEnv(ranges, peak_hint=True) for _ in range(4)]
    assert replay(vec, singles, actions, seed=11) <= 1e-9
    assert [c.N for c in vec.configs] == [e.config.N for e in singles]  # new scenarios, the same ones


def test_autoreset_is_next_step_with_zero_reward():
    vec = IOSUAVVectorEnv(2, SHORT)
    vec.reset(seed=0)
    zeros = np.zeros((2, 2))
    for _ in range(SHORT.N - 2):
        _, _, terminated, _, info = vec.step(zeros)
        assert not terminated.any()
    _, reward, terminated, _, info = vec.step(zeros)
    assert terminated.all() and info["slot"].tolist() == [SHORT.N] * 2 and info["feasible"].all()
    assert [len(q) for q in vec.trajectories] == [SHORT.N] * 2
    obs, reward, terminated, _, info = vec.step(zeros)  # the reset step
    assert not terminated.any() and np.all(reward == 0.0) and info["slot"].tolist() == [1, 1]
    np.testing.assert_allclose(info["position"], [SHORT.q0, SHORT.q0])
    first, _ = IOSUAVEnv(SHORT).reset(seed=0)
    np.testing.assert_array_equal(obs[0], first)


def test_info_is_arrays_with_gymnasium_masks():
    vec = IOSUAVVectorEnv(5, SHORT)
    _, info = vec.reset(seed=0)
    _, _, _, _, info = vec.step(np.zeros((5, 2)))
    for key in INFO_KEYS:
        assert info[key].shape == ((5, 2) if key == "position" else (5,))
        assert info[f"_{key}"].all() and info[f"_{key}"].shape == (5,)
    assert info["slot"].dtype == np.int64 and info["feasible"].dtype == np.bool_


def test_seeds_a_list_and_outputs_are_fresh_arrays():
    vec = IOSUAVVectorEnv(2, SHORT, channel="rician")
    _, a = vec.reset(seed=[5, 9])  # the first slot's faded rate follows each row's seed
    _, b = IOSUAVVectorEnv(2, SHORT, channel="rician").reset(seed=5)  # rows seeded 5 and 6
    assert a["rate"][0] == b["rate"][0] and a["rate"][1] != b["rate"][1]
    obs1, *_ = vec.step(np.zeros((2, 2)))
    keep = obs1.copy()
    vec.step(np.ones((2, 2)))
    assert np.array_equal(obs1, keep)  # a later step does not overwrite what was returned


def test_bad_actions_are_refused_with_the_reason():
    """(The batch arguments, num_envs, seeds, ..., are the base's: tests/envs/test_batched.py.)"""
    vec = IOSUAVVectorEnv(3, SHORT)
    vec.reset(seed=0)
    with pytest.raises(ValueError, match=r"shape \(3, 2\)"):
        vec.step(np.zeros((2, 2)))
    bad = np.zeros((3, 2))
    bad[1, 0] = np.nan
    with pytest.raises(ValueError, match=r"rows \[1\]"):
        vec.step(bad)
    assert [len(q) for q in vec.trajectories] == [1, 1, 1]  # no row moved, the good ones neither
    with pytest.raises(TypeError, match="unexpected keyword argument 'frameskip'"):
        IOSUAVVectorEnv(2, frameskip=1)


def test_pinned_scenario_for_every_row():
    vec = RandomIOSUAVVectorEnv(2)
    vec.reset(seed=0, options={"config": SHORT})
    assert vec.configs == [SHORT, SHORT]


def test_plain_python_kernels_agree_with_the_compiled_ones(tmp_path):
    pytest.importorskip("numba")
    code = (
        "import numpy as np, ios_uav_env.jit as j\n"
        "from ios_uav_env import ScenarioConfig\n"
        "from ios_uav_env.envs.single_vector import IOSUAVVectorEnv\n"
        "assert j.HAVE_NUMBA == (j.os.environ.get('IOS_UAV_ENV_NO_NUMBA') is None)\n"
        "rng = np.random.default_rng(0)\n"
        "out = []\n"
        "for guard, scale in ((False, 0.95), (True, 0.0)):\n"
        "    vec = IOSUAVVectorEnv(3, ScenarioConfig(T=36.0), channel='rician', arrival_guard=guard)\n"
        "    vec.reset(seed=4)\n"
        "    acts = rng.uniform(-1, 1, (40, 3, 2))\n"
        "    acts *= scale / np.maximum(1.0, np.linalg.norm(acts, axis=2, keepdims=True))\n"
        "    out += [vec.step(a)[1] for a in acts] + [np.concatenate(vec.trajectories).ravel()]\n"
        "np.save(r'{path}', np.concatenate([np.ravel(o) for o in out]))\n"
    )
    results = []
    for flag in (None, "1"):
        env = {k: v for k, v in os.environ.items() if k != "IOS_UAV_ENV_NO_NUMBA"}
        if flag:
            env["IOS_UAV_ENV_NO_NUMBA"] = flag
        path = tmp_path / f"out{flag}.npy"
        run = subprocess.run(
            [sys.executable, "-c", code.format(path=path)], env=env, capture_output=True, text=True
        )
        assert run.returncode == 0, run.stderr
        results.append(np.load(path))
    # the compiled node sums are reassociated (vectorised): equal to rounding, not bit for bit.
    # (Random actions that put the guard's two circles near tangency amplify rounding through a
    # square root; these episodes stay away from that: the guard only pulls hovering UAVs home.)
    np.testing.assert_allclose(results[0], results[1], rtol=1e-11, atol=1e-11)


def test_same_step_autoreset_returns_the_new_episode_and_the_final_one_in_info():
    vec = IOSUAVVectorEnv(2, SHORT, autoreset_mode="same_step")
    first, _ = vec.reset(seed=0)
    zeros = np.zeros((2, 2))
    for _ in range(SHORT.N - 2):
        vec.step(zeros)
    obs, reward, terminated, _, info = vec.step(zeros)
    assert terminated.all() and info["_final_obs"].all() and reward.min() > 0
    np.testing.assert_array_equal(obs, first)  # already the next episode's first observation
    assert info["slot"].tolist() == [1, 1] and info["final_info"]["slot"].tolist() == [SHORT.N] * 2
    assert info["final_obs"][0][8] == 0.0 and info["final_info"]["feasible"].all()  # no time left
    obs, reward, terminated, _, info = vec.step(zeros)  # an ordinary step of the new episode
    assert info["slot"].tolist() == [2, 2] and not info["_final_obs"].any()
    with pytest.raises(ValueError, match="autoreset_mode"):
        IOSUAVVectorEnv(2, SHORT, autoreset_mode="sometimes")


def test_one_scenario_per_row_matches_single_envs_pinned_to_them():
    configs = [SHORT, SHORT.replace(T=50.0, surface="ris"), SHORT.replace(ground_node=(50.0, 30.0))]
    vec = RandomIOSUAVVectorEnv(3)
    obs, _ = vec.reset(seed=0, options={"configs": configs})
    assert vec.configs == configs
    for i, cfg in enumerate(configs):
        single, _ = RandomIOSUAVEnv().reset(seed=i, options={"config": cfg})
        np.testing.assert_array_equal(obs[i], single)
    with pytest.raises(ValueError, match="3 scenarios"):
        vec.reset(options={"configs": configs[:2]})
    with pytest.raises(ValueError, match="configs"):
        vec.reset(options={"configs": configs, "config": SHORT})


def test_restart_starts_new_episodes_on_the_given_rows_only():
    vec = IOSUAVVectorEnv(3, SHORT)
    vec.reset(seed=0)
    for _ in range(4):
        vec.step(np.zeros((3, 2)))
    obs = vec.restart([1])
    assert [len(q) for q in vec.trajectories] == [5, 1, 5]
    np.testing.assert_array_equal(obs[1], IOSUAVEnv(SHORT).reset(seed=1)[0])
    _, _, _, _, info = vec.step(np.zeros((3, 2)))
    assert info["slot"].tolist() == [6, 2, 6]


def test_a_pinned_row_goes_back_to_the_env_scenario_at_autoreset():
    # the autoreset keeps a row's scenario without the template's Python reset only when it is
    # the env's own: a pinned row must leave its pinned scenario, as the single env does
    ris = SHORT.replace(surface="ris")
    vec = IOSUAVVectorEnv(2, SHORT, channel="rician")
    vec.reset(seed=3, options={"configs": [ris, None]})
    singles = [IOSUAVEnv(SHORT, channel="rician") for _ in range(2)]
    singles[0].reset(seed=3, options={"config": ris})
    singles[1].reset(seed=4)
    zeros = np.zeros((2, 2))
    for _ in range(2 * SHORT.N):  # two episodes and a bit: pinned, then the env's own twice
        obs, reward, terminated, _, info = vec.step(zeros)
        for i, env in enumerate(singles):
            if env.trajectory.shape[0] == env.config.N:
                o, inf = env.reset()
            else:
                o, _, _, _, inf = env.step(zeros[i])
            # (to rounding: the batched kernel's rate sum may vectorise differently)
            np.testing.assert_allclose(o, obs[i], rtol=1e-6, atol=1e-6)
            assert inf["rate"] == pytest.approx(info["rate"][i], rel=1e-9)  # the faded draws too
    assert vec.configs == [SHORT, SHORT]


def test_thread_count_does_not_change_the_episodes():
    actions = np.random.default_rng(4).uniform(-1.3, 1.3, (SHORT.N + 3, 5, 2))
    runs = []
    for threads in (1, 2):
        vec = IOSUAVVectorEnv(5, SHORT, channel="rician", num_threads=threads)
        out = [vec.reset(seed=0)[0]]
        for a in actions:
            obs, reward, *_ = vec.step(a)
            out += [obs, reward]
        runs.append(out)
    for a, b in zip(*runs, strict=True):
        np.testing.assert_array_equal(a, b)


def _two_steps() -> list[np.ndarray]:
    """A step of the single-node and of the multi-node batched env."""
    from ios_uav_env.envs.multi_vector import MultiNodeVectorEnv

    out = []
    for vec in (IOSUAVVectorEnv(4, SHORT), MultiNodeVectorEnv(2, best_schedule=False)):
        vec.reset(seed=0)
        obs, *_ = vec.step(np.full((vec.num_envs, vec.single_action_space.shape[0]), 0.5))
        out.append(obs)
    return out


def _forked_steps(queue) -> None:  # runs in a child forked after the parent used numba's threads
    queue.put(_two_steps())


def test_a_process_forked_after_a_batched_step_can_step_too():
    # GNU OpenMP (numba's "omp" threading layer) does not survive a fork: numba terminates the
    # child at its first parallel launch; the batched env runs its serial kernel there instead
    import multiprocessing

    expected = _two_steps()
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    child = context.Process(target=_forked_steps, args=(queue,))
    child.start()
    child.join(60)
    assert child.exitcode == 0
    for got, want in zip(queue.get(timeout=5), expected, strict=True):
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("env_kwargs", [{}, {"channel": "rician"}])
def test_fly_is_the_steps_it_hides(env_kwargs):
    """fly(rows, targets, moves) (compiled in one call; rician rows step slot by slot for their
    fading draws) equals advance() steps of full-speed moves (the stepped flight,
    ``_fly_stepped``), leaves the other rows and the arrays returned last alone, and the episodes
    go on alike."""
    fast, slow = (RandomIOSUAVVectorEnv(3, **env_kwargs) for _ in range(2))
    first = fast.reset(seed=0)[0]
    slow.reset(seed=0)
    kept = first.copy()
    rows, targets = np.array([0, 2, 0]), np.array([[100.0, 0.0], [-40.0, 90.0], [0.0, -30.0]])
    moves = np.array([5, 12, 3])
    obs = fast.fly(rows, targets, moves)
    ref = slow._fly_stepped(*slow._fly_args(rows, targets, moves))
    np.testing.assert_allclose(obs, ref, rtol=1e-9, atol=1e-6)
    np.testing.assert_array_equal(obs[1], first[1])
    np.testing.assert_array_equal(first, kept)  # the arrays returned last are left as they were
    paths = fast.trajectories
    assert [len(p) for p in paths] == [9, 1, 13]
    np.testing.assert_allclose(paths[2], slow.trajectories[2], rtol=0, atol=1e-9)
    d = fast.envs[2].config.D
    np.testing.assert_allclose(np.hypot(*np.diff(paths[2], axis=0).T), d)  # full speed
    hover = np.zeros((3, 2))
    for _ in range(3):
        a, b = fast.step(hover), slow.step(hover)
        np.testing.assert_allclose(a[0], b[0], rtol=1e-9, atol=1e-6)
        np.testing.assert_allclose(a[1], b[1], rtol=1e-9, atol=1e-9)
    with pytest.raises(ValueError, match="leave each row's episode unfinished"):
        fast.fly([1], [[0.0, 0.0]], [fast.envs[1].config.N - 1])
