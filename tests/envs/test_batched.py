"""The batched-env base (ios_uav_env/envs/batched.py, its fly and restart in batched_calls.py) on
a toy subclass: seeding, both autoreset modes, advance masks, restart and fly are the base's,
whatever the subclass's kernel; both batched envs of the package extend it without redefining
them, and use their row envs through the public row protocol only
(ios_uav_env/envs/row_protocol.py)."""

from __future__ import annotations

import ast
from pathlib import Path
from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env.envs as envs_package
from ios_uav_env.envs.batched import BatchedEnv
from ios_uav_env.envs.core.vector import UAVVectorEnv
from ios_uav_env.envs.multi import MultiNodeEnv
from ios_uav_env.envs.multi_vector import MultiNodeVectorEnv
from ios_uav_env.envs.policies import full_speed_move
from ios_uav_env.envs.random_env import RandomIOSUAVEnv
from ios_uav_env.envs.row_protocol import MultiNodeRow, ScenarioRow, SingleNodeRow
from ios_uav_env.envs.single import IOSUAVEnv
from ios_uav_env.envs.single_vector import IOSUAVVectorEnv, RandomIOSUAVVectorEnv


class Walk(gym.Env):
    """A toy single env: the UAV moves along x by the action's first entry; an episode has N
    slots, N drawn at each reset from ``np_random`` (or pinned: ``options={"config": N}``)."""

    observation_space = gym.spaces.Box(-np.inf, np.inf, (2,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)

    def __init__(self, config=None):
        self.config = SimpleNamespace(N=5, D=1.0)

    def begin_episode(self, seed, options):
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
    expected = [Walk().begin_episode(10 + i, None).N for i in range(4)]
    assert [c.N for c in vec.configs] == expected and obs[:, 1].tolist() == expected
    assert list(info) == ["slot", "N", "_slot", "_N"] and info["_slot"].all()
    vec.reset(seed=[3, 3, 5, 5])
    assert [c.N for c in vec.configs] == [Walk().begin_episode(s, None).N for s in (3, 3, 5, 5)]
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
    lengths = [ref.begin_episode(seed + i, None).N for i, ref in enumerate(refs)]
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
                lengths[i], x[i], moves[i], pending[i] = refs[i].begin_episode(None, None).N, 0.0, 0, False
                assert reward[i] == 0 and not terminated[i] and info["slot"][i] == 1
                assert obs[i].tolist() == [0.0, lengths[i]]
                continue
            x[i], moves[i] = x[i] + actions[i, 0], moves[i] + 1
            done = moves[i] == lengths[i] - 1
            assert reward[i] == 1.0 and terminated[i] == done
            if done and mode == "same_step":  # the next episode's first observation, the last in info
                assert info["_final_obs"][i] and info["final_info"]["slot"][i] == lengths[i]
                assert info["final_obs"][i].tolist() == pytest.approx([x[i], lengths[i]])
                lengths[i], x[i], moves[i] = refs[i].begin_episode(None, None).N, 0.0, 0
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


def test_the_presets_are_the_one_vector_class():
    assert issubclass(IOSUAVVectorEnv, UAVVectorEnv) and issubclass(MultiNodeVectorEnv, UAVVectorEnv)
    assert issubclass(RandomIOSUAVVectorEnv, UAVVectorEnv)
    for cls in (IOSUAVVectorEnv, RandomIOSUAVVectorEnv, MultiNodeVectorEnv):  # presets: an __init__ only
        assert [name for name in vars(cls) if not name.startswith("__")] == [], cls


@pytest.mark.parametrize("cls", [UAVVectorEnv])
def test_the_batched_envs_extend_the_base_without_redefining_it(cls):
    shared = ("reset", "step", "advance", "restart", "trajectories", "configs", "close", "_begin_step",
              "_end_step", "_reset_rows", "_fly_args", "_outputs", "_infos")  # fmt: skip
    assert issubclass(cls, BatchedEnv)
    assert not [name for name in shared if name in vars(cls)]
    hooks = ("_init_rows", "_load_row", "_start_rows", "_check_actions", "_step_kernel", "_info_arrays")
    assert all(name in vars(cls) for name in hooks)


# --- the row protocol ------------------------------------------------------------------------
BATCHED_MODULES = ("batched.py", "batched_calls.py", "single_vector.py", "multi_vector.py", "row_protocol.py",
                   "core/vector.py", "single_rows.py", "node_rows.py")  # fmt: skip
#: (module, attribute) pairs a batched module may take from another object although private:
#: none (numpy's private API never); add one only with the reason next to it.
ALLOWED_PRIVATE: frozenset[tuple[str, str]] = frozenset()


def _own(node: ast.expr) -> bool:
    """Whether ``node`` is the object itself: ``self``, ``cls`` or ``super()``."""
    if isinstance(node, ast.Name):
        return node.id in ("self", "cls")
    return isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "super"


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def foreign_private_names(source: str) -> list[tuple[int, str]]:
    """(line, expression) of every private attribute of another object in ``source``: ``x._name``
    (read, written or called) with ``x`` not ``self`` / ``cls`` / ``super()``, and
    ``getattr(x, "_name")`` and its kin."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute) and _private(node.attr) and not _own(node.value):
            found.append((node.lineno, node.attr, ast.unparse(node)))
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in ("getattr", "setattr", "hasattr", "delattr")
            and len(node.args) >= 2
            and isinstance(node.args[1], ast.Constant)
            and isinstance(node.args[1].value, str)
            and _private(node.args[1].value)
            and not _own(node.args[0])
        ):
            found.append((node.lineno, node.args[1].value, ast.unparse(node)))
    return found


def test_the_private_name_finder_finds_what_it_must():
    source = (
        "env._begin(1)\nself.envs[i]._observe(0)\nx = t._served_clip\nenv._np_random = None\n"
        "getattr(env, '_check_scenario', None)\nnp.random._bit_generator\n"
        "self._rows.state\nsuper()._init_rows(t)\ncls._x\ntype(x).__name__\ngetattr(env, 'check')\n"
    )
    assert sorted(line for line, _, _ in foreign_private_names(source)) == [1, 2, 3, 4, 5, 6]


@pytest.mark.parametrize("module", BATCHED_MODULES)
def test_a_batched_env_touches_no_private_name_of_another_object(module):
    """The batched envs use their row envs (and everything else) through public names only: the
    row protocol of ``ios_uav_env.envs.row_protocol``."""
    source = (Path(envs_package.__file__).parent / module).read_text(encoding="utf-8")
    found = [
        f"{module}:{line}: {text}"
        for line, name, text in foreign_private_names(source)
        if (module, name) not in ALLOWED_PRIVATE
    ]
    assert not found, "private names of other objects:\n" + "\n".join(found)


@pytest.mark.parametrize(
    ("make", "protocol"),
    [
        (lambda: IOSUAVEnv(), SingleNodeRow),
        (lambda: IOSUAVEnv(knowledge="reports"), SingleNodeRow),
        (lambda: RandomIOSUAVEnv(), SingleNodeRow),
        (lambda: MultiNodeEnv(), MultiNodeRow),
        (lambda: MultiNodeEnv(random_nodes=(1, 3), knowledge="reports"), MultiNodeRow),
        (lambda: Walk(), ScenarioRow),
    ],
)
def test_the_row_envs_offer_their_protocol(make, protocol):
    env = make()
    assert isinstance(env, protocol) and isinstance(env, ScenarioRow)
    assert env.begin_episode(3, None) is env.config
    if protocol is not ScenarioRow:
        env.check_scenario(env.config)
        assert env.track is None  # (drawn by the episode's row calls, after begin_episode)


def test_a_row_env_track_and_observations_are_the_single_envs():
    """``start_track`` / ``track`` / ``observe_slot`` on a begun episode are what ``reset`` does."""
    single, row = IOSUAVEnv(knowledge="reports", T=40.0), IOSUAVEnv(knowledge="reports", T=40.0)
    obs, _ = single.reset(seed=5)
    cfg = row.begin_episode(5, None)
    row.start_track(cfg)
    np.testing.assert_array_equal(row.track.paths, single.track.paths)
    seen = obs.copy()
    seen[4:6] = seen[10] = -7.0
    row.observe_slot(0, np.asarray(cfg.q0, dtype=np.float64), seen)
    np.testing.assert_array_equal(seen, obs)


def test_restart_and_fly_match_the_single_env_and_keep_the_rows_info():
    """``restart``: the row's next episode from its own generator (no seed), as the single env's
    next ``reset()``; ``fly``: the single env stepped by the same full-speed moves, draws included
    (Rician fading). Their info is returned by an ``advance`` that holds the row."""
    kwargs = {"channel": "rician"}
    vec = RandomIOSUAVVectorEnv(3, **kwargs)
    vec.reset(seed=11)
    singles = [RandomIOSUAVEnv(**kwargs) for _ in range(3)]
    for i, env in enumerate(singles):
        env.reset(seed=11 + i)
    for _ in range(2):
        vec.step(np.full((3, 2), 0.3))
        for env in singles:
            env.step(np.full(2, 0.3))
    obs = vec.restart([1])
    first, _ = singles[1].reset()
    np.testing.assert_allclose(obs[1], first, rtol=1e-12)
    assert vec.configs[1] == singles[1].config and len(vec.trajectories[1]) == 1
    target = np.array([40.0, -30.0])
    obs = vec.fly([0], [target], [3])
    for _ in range(3):
        q = singles[0].trajectory[-1]
        expected, _, _, _, info = singles[0].step(full_speed_move(target - q, singles[0].config.D))
    np.testing.assert_allclose(obs[0], expected, rtol=1e-12)
    np.testing.assert_allclose(vec.trajectories[0], singles[0].trajectory, rtol=1e-12)
    _, reward, _, _, held = vec.advance(np.zeros((3, 2)), np.zeros(3, dtype=bool))
    assert reward.tolist() == [0.0, 0.0, 0.0]
    assert held["slot"].tolist() == [6, 1, 3]  # flown to slot 3 + 3; restarted; as it was
    for key in ("average_rate", "rate", "distance_to_final"):
        assert held[key][0] == pytest.approx(info[key], rel=1e-12)
    np.testing.assert_allclose(held["position"][0], info["position"], rtol=1e-12)
