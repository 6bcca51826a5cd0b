"""Bad input to the envs and the batched envs: refused with an error naming the argument and what
is allowed, before anything is written; and inputs at the edge of the model (huge node scores,
far nodes) give finite, certified values. The compiled kernels never write past a row's slot N."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env  # noqa: F401  (registers the ids)
from ios_uav_env import ScenarioConfig
from ios_uav_env.envs.batched import BatchedEnv
from ios_uav_env.envs.multi import MultiNodeEnv
from ios_uav_env.envs.multi_vector import MultiNodeVectorEnv
from ios_uav_env.envs.single import IOSUAVEnv
from ios_uav_env.envs.single_vector import IOSUAVVectorEnv

ONE = ScenarioConfig(T=40.0, ios_shape=(10, 6))
TWO = ONE.replace(ground_nodes=((-100.0, -20.0), (150.0, -60.0)))
RANDOM = "ios_uav_env/IOSUAV-MultiNode-Random-v0"


def batched(cls: type[BatchedEnv], num_envs: int = 2) -> BatchedEnv:
    vec = cls(num_envs, ONE if cls is IOSUAVVectorEnv else TWO)
    vec.reset(seed=0)
    return vec


def snapshot(vec: BatchedEnv, row: int) -> tuple[np.ndarray, np.ndarray]:
    return vec._state[row].copy(), vec._path[row].copy()


def assert_untouched(vec: BatchedEnv, row: int, before: tuple[np.ndarray, np.ndarray]) -> None:
    np.testing.assert_array_equal(vec._state[row], before[0])
    np.testing.assert_array_equal(vec._path[row], before[1])


# --- fly: the moves of a row, summed over its entries --------------------------------------


@pytest.mark.parametrize("cls", [IOSUAVVectorEnv, MultiNodeVectorEnv])
def test_fly_refuses_a_row_whose_entries_sum_past_its_episode(cls):
    """Each entry alone leaves the episode unfinished, their sum does not: refused, naming the
    row and its limit, and neither row moves (row 1's way-points are not overwritten)."""
    vec = batched(cls)
    n = vec.configs[0].N
    rows = [snapshot(vec, 0), snapshot(vec, 1)]
    with pytest.raises(ValueError, match=rf"row 0 is given {2 * (n - 2)} moves .*at most {n - 2}"):
        vec.fly([0, 0], [[50.0, 0.0], [50.0, 0.0]], [n - 2, n - 2])
    assert_untouched(vec, 0, rows[0])
    assert_untouched(vec, 1, rows[1])


def test_the_compiled_flight_checks_the_sum_itself():
    """The kernel behind MultiNodeVectorEnv.fly refuses the same flight when called without the
    Python checks, having written nothing."""
    vec = batched(MultiNodeVectorEnv)
    n = vec.configs[0].N
    before = snapshot(vec, 1)
    rows, targets = np.array([0, 0]), np.array([[50.0, 0.0], [50.0, 0.0]])
    with pytest.raises(ValueError, match="out of range"):
        vec.rows.kernel_rows.fly(rows, targets, np.array([n - 2, n - 2]), vec._obs.copy(), vec._info.copy())
    assert vec._state[0, 2] == 0
    assert_untouched(vec, 1, before)


def test_a_row_given_twice_flies_its_entries_in_order_alike_in_both_flights():
    """fly([0, 0], ...): the compiled flight and the stepped one (``_fly_stepped``, through advance)
    both fly row 0's first entry, then its second."""
    fast, slow = batched(MultiNodeVectorEnv), batched(MultiNodeVectorEnv)
    rows, targets, moves = np.array([0, 0]), np.array([[-300.0, 60.0], [-250.0, -60.0]]), np.array([3, 4])
    obs = fast.fly(rows, targets, moves)
    ref = slow._fly_stepped(*slow._fly_args(rows, targets, moves))
    np.testing.assert_allclose(obs, ref, atol=1e-6)
    assert len(fast.trajectories[0]) == len(slow.trajectories[0]) == 8
    np.testing.assert_allclose(fast.trajectories[0], slow.trajectories[0], atol=1e-9)


@pytest.mark.parametrize("cls", [IOSUAVVectorEnv, MultiNodeVectorEnv])
def test_a_step_kernel_never_writes_past_a_rows_last_slot(cls):
    """A row whose episode is over, stepped anyway (without the env's autoreset): its kernel
    leaves it as it is, and the next row's first way-point is not overwritten."""
    vec = batched(cls)
    cfg = vec.configs[0]
    vec._state[0, 2] = cfg.N - 1  # every move made
    rows = [snapshot(vec, 0), snapshot(vec, 1)]
    actions = np.zeros((2, vec.single_action_space.shape[0]))
    active = np.array([True, False])
    if cls is IOSUAVVectorEnv:
        with pytest.raises(RuntimeError, match="row 0's episode is over"):
            vec._step_kernel(actions, active)
    else:
        outputs = (vec._obs.copy(), np.zeros(2), np.zeros(2, dtype=np.bool_), vec._info.copy())
        vec.rows.kernel_rows.step(actions, active, outputs, np.zeros(2), serial=True)
        vec.rows.kernel_rows.step(actions, active, outputs, np.zeros(2))
    assert_untouched(vec, 0, rows[0])
    assert_untouched(vec, 1, rows[1])


# --- node scores ----------------------------------------------------------------------------


def test_a_huge_node_score_is_clipped_to_the_action_space():
    """A score of 1e308 gives the shares of a score of 1 (the space's bound): finite shares and
    reward, in the single env and in the batched one."""
    env, clipped = MultiNodeEnv(TWO), MultiNodeEnv(TWO)
    env.reset(seed=0)
    clipped.reset(seed=0)
    _, reward, _, _, info = env.step(np.array([0.0, 0.0, 1e308, 0.0]))
    _, ref_reward, _, _, ref_info = clipped.step(np.array([0.0, 0.0, 1.0, 0.0]))
    assert np.all(np.isfinite(info["shares"])) and np.isfinite(reward)
    np.testing.assert_array_equal(info["shares"], ref_info["shares"])
    assert reward == ref_reward and info["min_rate"] == ref_info["min_rate"]
    vec = batched(MultiNodeVectorEnv)
    _, rewards, _, _, infos = vec.step(np.array([[0.0, 0.0, 1e308, 0.0], [0.0, 0.0, -1e308, 1e308]]))
    assert np.all(np.isfinite(infos["shares"])) and np.all(np.isfinite(rewards))
    np.testing.assert_array_equal(infos["shares"][0], ref_info["shares"])
    np.testing.assert_allclose(infos["shares"].sum(axis=1), 1.0)
    assert infos["shares"][1, 1] > 0.99


@pytest.mark.parametrize("cls", [IOSUAVVectorEnv, MultiNodeVectorEnv])
def test_a_nan_in_the_y_column_alone_is_refused(cls):
    vec = batched(cls)
    actions = np.zeros((2, vec.single_action_space.shape[0]))
    actions[1, 1] = np.nan
    with pytest.raises(ValueError, match=r"finite .*rows \[1\]"):
        vec.step(actions)


# --- far nodes: the best schedule ------------------------------------------------------------


def test_a_far_node_gets_a_best_schedule_at_least_the_agents_own():
    """A node 10 km off: the episode's best_schedule_rate is certified, > 0 and at least the
    agent's own min rate (the LP is solved relative to the rates' scale)."""
    cfg = ONE.replace(ground_nodes=((-100.0, -20.0), (1.0, 1e4)))
    env = MultiNodeEnv(cfg)
    env.reset(seed=0)
    done = False
    while not done:
        _, _, done, _, info = env.step(np.array([0.0, 0.0, -1.0, 1.0]))
    assert 0 < info["min_rate"] <= info["best_schedule_rate"]


# --- max_nodes and random_nodes -------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs", [{"random_nodes": (2, 2)}, {"random_nodes": (2, 2), "max_nodes": 2}, {"random_nodes": (1, 2)}]
)
def test_random_nodes_need_not_fit_the_unused_default_scenario(kwargs):
    """Drawn scenarios have at most random_nodes' high nodes: max_nodes is checked against it,
    not against the default scenario's K = 3, which no episode runs on."""
    env = gym.make(RANDOM, **kwargs)
    env.reset(seed=0)
    assert env.unwrapped.max_nodes == kwargs.get("max_nodes", 2) >= env.unwrapped.config.K
    vec = gym.make_vec(RANDOM, num_envs=2, vectorization_mode="vector_entry_point", **kwargs)
    vec.reset(seed=0)
    assert vec.single_action_space.shape == (2 + kwargs.get("max_nodes", 2),)
    with pytest.raises(ValueError, match="max_nodes = 2"):  # a pinned scenario must still fit
        env.reset(options={"config": TWO.replace(ground_nodes=(*TWO.nodes, (50.0, 9.0)))})


def test_max_nodes_is_an_integer_of_at_least_the_most_nodes():
    with pytest.raises(ValueError, match=r"max_nodes must be an integer >= random_nodes' high = 2, got 1"):
        MultiNodeEnv(random_nodes=(2, 2), max_nodes=1)
    with pytest.raises(ValueError, match=r"max_nodes must be an integer >= random_nodes' high = 2, got 2.5"):
        MultiNodeEnv(random_nodes=(2, 2), max_nodes=2.5)
    with pytest.raises(ValueError, match=r"max_nodes must be an integer >= the scenario's K = 2, got 1"):
        MultiNodeEnv(TWO, max_nodes=1)


# --- the batched reset and restart ----------------------------------------------------------


@pytest.mark.parametrize("cls", [IOSUAVVectorEnv, MultiNodeVectorEnv])
def test_configs_must_be_a_list_of_one_scenario_per_row(cls):
    vec = batched(cls)
    cfg = vec.configs[0]
    for one in (cfg, cfg.to_dict()):
        with pytest.raises(TypeError, match=r'options\["configs"\] must be a list of 2 scenarios'):
            vec.reset(options={"configs": one})


@pytest.mark.parametrize("cls", [IOSUAVVectorEnv, MultiNodeVectorEnv])
@pytest.mark.parametrize(
    ("seed", "match"),
    [(1.5, r"seed must be None, an integer >= 0 .*got 1.5"), (-1, r"seed must be None, an integer >= 0"),
     (True, "seed must be None"), ([0, 1.5], r"seed\[1\] must be None or an integer >= 0, got 1.5"),
     ([0, -2], r"seed\[1\] must be None or an integer >= 0")],
)  # fmt: skip
def test_reset_seeds_are_integers_of_at_least_0(cls, seed, match):
    vec = batched(cls)
    with pytest.raises(ValueError, match=match):
        vec.reset(seed=seed)


@pytest.mark.parametrize("cls", [IOSUAVVectorEnv, MultiNodeVectorEnv])
@pytest.mark.parametrize("rows", [[5], [-1], [0.5], [0, 2]])
def test_restart_rows_are_row_indices(cls, rows):
    """restart([5]) or restart([-1]) of a batch of 2: refused (a negative row is not the last one),
    and no row restarts."""
    vec = batched(cls)
    vec.step(np.zeros((2, vec.single_action_space.shape[0])))
    before = [snapshot(vec, 0), snapshot(vec, 1)]
    with pytest.raises(ValueError, match=r"restart rows must be (row indices in 0\.\.1|whole numbers)"):
        vec.restart(rows)
    assert_untouched(vec, 0, before[0])
    assert_untouched(vec, 1, before[1])


def test_a_single_node_env_refuses_a_multi_node_scenario_before_any_row_resets():
    single = r'options\["config"\] has K = 2 ground_nodes, but ios_uav_env/IOSUAV-v0 is a single-node env'
    several = r".*several nodes: MultiNodeEnv, ios_uav_env/IOSUAV-MultiNode-v0"
    with pytest.raises(ValueError, match=single + several):
        IOSUAVEnv(ONE).reset(options={"config": TWO})
    vec = batched(IOSUAVVectorEnv)
    vec.step(np.zeros((2, 2)))
    before = snapshot(vec, 0)
    with pytest.raises(ValueError, match=r'options\["config"\] has K = 2 ground_nodes'):
        vec.reset(options={"config": TWO})
    with pytest.raises(ValueError, match=r'options\["configs"\]\[1\] has K = 2 ground_nodes'):
        vec.reset(seed=3, options={"configs": [ONE.replace(T=39.0), TWO]})
    assert_untouched(vec, 0, before)  # row 0 was not reset to its pinned scenario
    assert vec.configs[0] == ONE


def test_a_reset_that_fails_part_way_leaves_no_batch_to_step(monkeypatch):
    """A row whose own reset fails after row 0 has reset: the batch must be reset again before
    it steps (not stepped half-reset)."""
    vec = batched(MultiNodeVectorEnv)

    def broken(seed, options):
        raise RuntimeError("this row cannot reset")

    monkeypatch.setattr(vec.envs[1], "begin_episode", broken)
    with pytest.raises(RuntimeError, match="this row cannot reset"):
        vec.reset(seed=1)
    with pytest.raises(RuntimeError, match="call reset"):
        vec.step(np.zeros((2, 4)))
