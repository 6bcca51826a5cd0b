"""The batched moving-node env's compiled draw of its episodes (ios_uav_env/envs/mobile_draws.py)
equals the single env's reset bit for bit: the scenario (``sample_scenario``), the node path
(``node_paths``), the report clip, the episode row and the first rate kernel; the scenario's
validation still refuses a bad draw with its own error; configs are built only when read."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env
from ios_uav_env import MOBILE_ID
from ios_uav_env.envs.knowledge import start_track
from ios_uav_env.envs.mobile_draws import takes_drawn_episodes
from ios_uav_env.envs.random_env import RandomIOSUAVEnv
from ios_uav_env.envs.single_vector import RandomIOSUAVVectorEnv
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.mobility import GaussMarkov
from ios_uav_env.model.motion import node_paths
from ios_uav_env.model.rate_kernels import rate_kernel
from ios_uav_env.model.scenarios import ScenarioRanges, sample_scenario
from tests.envs.batch_rows import OUTSIDE, refused_after, refused_ranges, same, step_batch_and_singles

pytestmark = pytest.mark.skipif(
    not HAVE_NUMBA, reason="the compiled draw needs numba (else: the per-row path)"
)

#: Ranges whose nodes start near the IOS plane (moved off its strip), walk fast into their
#: rectangles' edges (reflected), on both surfaces and several IOS row counts.
NEAR_PLANE = ScenarioRanges(
    ground_x=(-3.0, 3.0), ground_y=(-20.0, 20.0), T=(40.0, 80.0), ios_rows=(20, 24),
    base=ScenarioConfig(motion=GaussMarkov(speed=6.0, sigma=3.0, plane_margin=2.5)),
)  # fmt: skip
#: A fixed heading and a box of its own (no heading draw; the rectangle is the box's).
BOXED = ScenarioRanges(
    T=(40.0, 60.0),
    base=ScenarioConfig(motion=GaussMarkov(heading=0.7, speed=4.0, box=((-300.0, 300.0), (-200.0, 200.0)))),
)


def drawn_vec(ranges, rows: int, **kwargs):
    vec = RandomIOSUAVVectorEnv(rows, ranges, knowledge="reports", **kwargs)
    assert vec.rows._drawn is not None  # (the compiled draw is what is tested)
    return vec


@pytest.mark.parametrize(
    "ranges", [NEAR_PLANE, BOXED, ScenarioRanges(base=ScenarioConfig(motion=GaussMarkov()))]
)
def test_the_compiled_draw_is_the_single_envs_draw_bit_for_bit(ranges):
    rows, seed = 24, 5
    vec = drawn_vec(ranges, rows, report_sigma=15.0)
    vec.reset(seed=seed)
    for i in range(2):  # (node_paths draws what start_track draws: the same stream)
        rng = np.random.default_rng(seed + i)
        cfg = sample_scenario(rng, ranges)
        assert same(node_paths(cfg, rng), vec.envs[i].track.paths)
    episode, nodes, params = vec.rows._episode.copy(), vec.rows._nodes.copy(), vec.rows._params.copy()
    moved = 0
    for i in range(rows):
        rng = np.random.default_rng(seed + i)  # (the seeded reset's generator)
        cfg = sample_scenario(rng, ranges)
        track = start_track(cfg, rng, 15.0)
        env = vec.envs[i]
        assert env.config == cfg and env.config.to_dict() == cfg.to_dict()
        assert same(env.track.paths, track.paths)
        assert same(env.track.lo, track.lo) and same(env.track.hi, track.hi)
        # (slot 0's report and rate are the reset's observation: the later slots' are not drawn yet)
        assert same(env.track.reports[1:], track.reports[1:]) and same(
            env.track.measured[1:], track.measured[1:]
        )
        assert same(episode[i], env.episode_row[0] if env.episode_row.ndim == 2 else env.episode_row)
        kernel = rate_kernel(cfg)
        k = kernel.nodes.shape[1]
        assert same(nodes[i, :, :k], kernel.nodes) and same(params[i], kernel.params)
        moved += abs(cfg.ground_node[0] - cfg.ios_center[0]) == cfg.motion.plane_margin
    if ranges is NEAR_PLANE:
        assert moved > 0  # (some nodes were drawn inside the plane's strip and moved out of it)


def test_the_mobile_id_batch_is_its_single_envs_over_episodes():
    rows = 4
    vec = gym.make_vec(MOBILE_ID, num_envs=rows, vectorization_mode="vector_entry_point")
    assert vec.rows._drawn is not None
    singles = [gym.make(MOBILE_ID).unwrapped for _ in range(rows)]
    obs, _ = vec.reset(seed=3)
    for i, env in enumerate(singles):
        assert same(env.reset(seed=3 + i)[0], obs[i])
    actions = np.random.default_rng(3).uniform(-1.2, 1.2, (260, rows, 2))
    assert step_batch_and_singles(vec, singles, actions, ("paths", "reports", "measured"), False) >= rows
    assert [env.config for env in singles] == vec.configs


def test_the_same_seed_gives_the_same_episodes():
    a, b = drawn_vec(NEAR_PLANE, 6), drawn_vec(NEAR_PLANE, 6)
    (oa, _), (ob, _) = a.reset(seed=9), b.reset(seed=9)
    assert same(oa, ob) and same(a.rows._episode, b.rows._episode)
    actions = np.random.default_rng(0).uniform(-1, 1, (90, 6, 2))
    for step in actions:
        assert same(a.step(step)[0], b.step(step)[0])


def test_configs_are_built_when_read():
    vec = drawn_vec(BOXED, 3)
    vec.reset(seed=0)
    steppers = [env.stepper for env in vec.envs]
    assert all(s.__dict__.get("_deferral") is not None for s in steppers)
    configs = vec.configs  # (reading one builds that row's)
    assert all(s.__dict__.get("_deferral") is None for s in steppers)
    singles = [RandomIOSUAVEnv(BOXED, knowledge="reports") for _ in range(3)]
    for i, env in enumerate(singles):
        env.reset(seed=i)
    assert configs == [env.config for env in singles]
    # a track read during an episode keeps its numbers when the row begins the next one
    track = vec.envs[0].track
    paths, n = track.paths.copy(), track.paths.shape[0]
    vec.reset(seed=50)
    assert same(track.paths, paths) and track.paths.shape[0] == n
    assert vec.envs[0].config != configs[0]


def test_a_draw_the_scenario_refuses_is_refused_with_its_error():
    """Ranges that check out at construction (their corners) but whose draw the config refuses
    (here forced after construction): the batched reset raises the config's own error, as the
    single env's does. Skipping the compiled draw's checks would let the bad scenario run (row 0,
    valid, is the one whose config the batch builds for the rows' kernel geometry)."""
    bad = refused_ranges()
    seed = refused_after(RandomIOSUAVEnv(bad, knowledge="reports"))
    vec = drawn_vec(bad, 2)
    with pytest.raises(ValueError, match=OUTSIDE):
        vec.reset(seed=seed)
    with pytest.raises(RuntimeError, match="reset"):
        vec.step(np.zeros((2, 2)))


def test_only_the_envs_it_reproduces_take_the_compiled_draw():
    kwargs = {"ranges": {"T": (40.0, 60.0)}, "motion": {"kind": "gauss_markov"}}
    assert takes_drawn_episodes(RandomIOSUAVVectorEnv(2, **kwargs).envs[0])
    for extra in ({"filter_estimate": True, "knowledge": "reports"}, {"objective": "energy_efficiency"}):
        assert not takes_drawn_episodes(RandomIOSUAVVectorEnv(2, **kwargs, **extra).envs[0]), extra
    assert not takes_drawn_episodes(gym.make("ios_uav_env/IOSUAV-Random-v0").unwrapped)
    assert ios_uav_env  # (registers the ids)
