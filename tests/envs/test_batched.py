"""The batched-env base (ios_uav_env/envs/batched.py) on a toy subclass: seeding, both autoreset
modes, advance masks, restart and fly are the base's, whatever the subclass's kernel; both
batched envs of the package extend it without redefining them."""

from __future__ import annotations

from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest

from ios_uav_env.envs.batched import BatchedEnv
from ios_uav_env.envs.multi_vector import MultiNodeVectorEnv
from ios_uav_env.envs.single_vector import IOSUAVVectorEnv


class Walk(gym.Env):
    """A toy single env: the UAV moves along x by the action's first entry; an episode has N
    slots, N drawn at each reset from ``np_random`` (or pinned: ``options={"config": N}``)."""

    observation_space = gym.spaces.Box(-np.inf, np.inf, (2,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)

    def __init__(self, config=None):
        self.config = SimpleNamespace(N=5, D=1.0)

    def _begin(self, seed, options):
        super().reset(seed=seed)
        n = options["config"] if options else int(self.np_random.integers(3, 8))
        self.config = SimpleNamespace(N=n, D=1.0)
        return self.config


class WalkVectorEnv(BatchedEnv):
    """The toy batched env: obs (x, N), reward 1 per move, info slot and N."""

    env_class = Walk
    info_keys = ("slot", "N")

    def _init_rows(self, template):
        self._state, self._path = np.zeros((self.num_envs, 3)), np.zeros((self.num_envs, 8, 2))
        self._n, self._info_width = np.zeros(self.num_envs), 2

    def _load_row(self, i, env):
        self._n[i] = env.config.N

    def _start_rows(self, rows):
        self._state[rows], self._path[rows, 0] = 0.0, 0.0
        self._obs[rows] = np.column_stack([np.zeros(rows.size), self._n[rows]])
        self._info[rows] = np.column_stack([np.ones(rows.size), self._n[rows]])

    def _check_actions(self, actions):
        return np.asarray(actions, dtype=np.float64)

    def _step_kernel(self, actions, active):
        for i in np.flatnonzero(active):
            self._state[i, 0] += actions[i, 0]
            self._state[i, 2] += 1
            moves = int(self._state[i, 2])
            self._path[i, moves] = self._state[i, 0], 0.0
            self._obs[i] = self._state[i, 0], self._n[i]
            self._reward[i], self._terminated[i] = 1.0, moves == self._n[i] - 1
            self._info[i] = moves + 1, self._n[i]

    def _info_arrays(self, table):
        return {"slot": table[:, 0].astype(np.int64), "N": table[:, 1]}


def test_reset_seeds_row_i_with_seed_plus_i_and_pins_scenarios():
    vec = WalkVectorEnv(4)
    obs, info = vec.reset(seed=10)
    expected = [Walk()._begin(10 + i, None).N for i in range(4)]
    assert [c.N for c in vec.configs] == expected and obs[:, 1].tolist() == expected
    assert list(info) == ["slot", "N", "_slot", "_N"] and info["_slot"].all()
    vec.reset(seed=[3, 3, 5, 5])
    assert [c.N for c in vec.configs] == [Walk()._begin(s, None).N for s in (3, 3, 5, 5)]
    vec.reset(options={"configs": [4, None, 6, None]})
    assert [vec.configs[i].N for i in (0, 2)] == [4, 6]
    with pytest.raises(ValueError, match="4 seeds"):
        vec.reset(seed=[1, 2])


@pytest.mark.parametrize("mode", ["next_step", "same_step"])
def test_autoreset_and_advance_follow_gymnasiums_conventions(mode):
    """A reference model of each row (its own ``Walk`` drawing its episodes) against the batch
    under random actions and random ``advance`` masks."""
    b, seed = 3, 7
    vec = WalkVectorEnv(b, autoreset_mode=mode)
    obs, _ = vec.reset(seed=seed)
    refs = [Walk() for _ in range(b)]
    lengths = [ref._begin(seed + i, None).N for i, ref in enumerate(refs)]
    x, moves, pending = [0.0] * b, [0] * b, [False] * b
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(60):
        actions, rows = rng.uniform(-1, 1, (b, 2)), rng.uniform(size=b) < 0.7
        previous = obs.copy()
        obs, reward, terminated, truncated, info = vec.advance(actions, rows)
        assert not truncated.any()
        for i in range(b):
            if not rows[i]:  # held: as returned last
                assert obs[i].tolist() == previous[i].tolist() and reward[i] == 0 and not terminated[i]
                continue
            if pending[i]:  # NEXT_STEP: the reset step
                lengths[i], x[i], moves[i], pending[i] = refs[i]._begin(None, None).N, 0.0, 0, False
                assert reward[i] == 0 and not terminated[i] and info["slot"][i] == 1
                assert obs[i].tolist() == [0.0, lengths[i]]
                continue
            x[i], moves[i] = x[i] + actions[i, 0], moves[i] + 1
            done = moves[i] == lengths[i] - 1
            assert reward[i] == 1.0 and terminated[i] == done
            if done and mode == "same_step":  # the next episode's first observation, the last in info
                assert info["_final_obs"][i] and info["final_info"]["slot"][i] == lengths[i]
                assert info["final_obs"][i].tolist() == pytest.approx([x[i], lengths[i]])
                lengths[i], x[i], moves[i] = refs[i]._begin(None, None).N, 0.0, 0
                assert obs[i].tolist() == [0.0, lengths[i]] and info["slot"][i] == 1
            else:
                assert obs[i].tolist() == pytest.approx([x[i], lengths[i]])
                assert info["slot"][i] == moves[i] + 1
                pending[i] = done and mode == "next_step"
            if mode == "same_step":
                assert info["_final_obs"][i] == done
            ended += done
    assert ended >= 2 * b
    assert [len(q) for q in vec.trajectories] == [m + 1 for m in moves]


def test_restart_and_fly_on_the_given_rows_only():
    vec = WalkVectorEnv(3)
    vec.reset(seed=0, options={"config": 7})
    vec.step(np.full((3, 2), 0.5))
    obs = vec.restart([1])
    assert [len(q) for q in vec.trajectories] == [2, 1, 2] and obs[1, 0] == 0.0
    obs = vec.fly([0, 2], [[10.0, 0.0], [0.0, 0.0]], [3, 2])  # full speed, then hover on the target
    np.testing.assert_allclose(vec.trajectories[0][:, 0], [0.0, 0.5, 1.5, 2.5, 3.5])
    np.testing.assert_allclose(vec.trajectories[2][:, 0], [0.0, 0.5, 0.0, 0.0])
    assert obs[0, 0] == 3.5 and len(vec.trajectories[1]) == 1
    with pytest.raises(ValueError, match="unfinished"):
        vec.fly([0], [[0.0, 0.0]], [2])  # 4 of its 6 moves made


@pytest.mark.parametrize("cls", [WalkVectorEnv, IOSUAVVectorEnv, MultiNodeVectorEnv])
def test_the_batch_arguments_are_checked_by_the_base(cls):
    vec = cls(2)
    width = vec.single_action_space.shape[0]
    calls = (
        lambda: vec.step(np.zeros((2, width))),
        lambda: vec.restart([0]),
        lambda: vec.fly([0], [[0, 0]], [1]),
    )
    for call in calls:
        with pytest.raises(RuntimeError, match="call reset"):
            call()
    with pytest.raises(ValueError, match="seed must be an int or 2 seeds"):
        vec.reset(seed=[1, 2, 3])
    for bad in (0, 1.5, True):
        with pytest.raises(ValueError, match="num_envs must be an integer >= 1"):
            cls(bad)
        with pytest.raises(ValueError, match="num_threads must be None .* or an integer >= 1"):
            cls(2, num_threads=bad)
    with pytest.raises(ValueError, match="autoreset_mode must be one of"):
        cls(2, autoreset_mode="sometimes")
    with pytest.raises(ValueError, match="render_mode must be None"):
        cls(2, render_mode="rgb_array")
    assert cls(2, autoreset_mode="SameStep").same_step and not cls(2, autoreset_mode="NextStep").same_step


@pytest.mark.parametrize("cls", [IOSUAVVectorEnv, MultiNodeVectorEnv])
def test_the_batched_envs_extend_the_base_without_redefining_it(cls):
    shared = ("reset", "step", "advance", "restart", "trajectories", "configs", "close", "_begin_step",
              "_end_step", "_row_options", "_reset_rows", "_fly_args", "_outputs", "_infos")  # fmt: skip
    assert issubclass(cls, BatchedEnv)
    assert not [name for name in shared if name in vars(cls)]
    hooks = ("_init_rows", "_load_row", "_start_rows", "_check_actions", "_step_kernel", "_info_arrays")
    assert all(name in vars(cls) for name in hooks)
