"""The batched moving multi-node env's compiled draw of its episodes (ios_uav_env/envs/node_draws.py)
equals the single env's reset bit for bit: the scenario (``sample_multinode``), the node paths
(``node_paths``), the report clips, the rows' scenario arrays and ground points; the batch equals
its single envs over episodes; the scenario's validation still refuses a bad draw with its own
error; configs are built only when read; a row whose surface the compiled weights do not take
reads its track's kernels."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env
from ios_uav_env import MULTINODE_MOBILE_ID
from ios_uav_env.envs import node_weights
from ios_uav_env.envs.multi import MultiNodeEnv
from ios_uav_env.envs.multi_table import episode_row, node_points
from ios_uav_env.envs.multi_vector import MultiNodeVectorEnv
from ios_uav_env.envs.node_draws import takes_drawn_nodes
from ios_uav_env.envs.node_weights import NodeWeights, start_bare_track
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.mobility import GaussMarkov
from ios_uav_env.model.scenarios import ScenarioRanges, sample_multinode
from tests.envs.batch_rows import OUTSIDE, refused_after, refused_ranges, same, step_batch_and_singles

# (their nodes start near the IOS plane and walk fast into their rectangles' edges; a fixed heading
# and a box of its own)
from tests.envs.test_mobile_draws import BOXED, NEAR_PLANE

pytestmark = pytest.mark.skipif(
    not HAVE_NUMBA, reason="the compiled draw needs numba (else: the per-row path)"
)

RECORDS = ("paths", "reports", "measured", "tally")


def drawn_vec(
    ranges: ScenarioRanges, rows: int, nodes: tuple[int, int] = (1, 4), **kwargs
) -> MultiNodeVectorEnv:
    vec = MultiNodeVectorEnv(rows, random_nodes=nodes, ranges=ranges, knowledge="reports", **kwargs)
    assert vec.rows._drawn is not None  # (the compiled draw is what is tested)
    return vec


@pytest.mark.parametrize(
    "ranges", [NEAR_PLANE, BOXED, ScenarioRanges(base=ScenarioConfig(motion=GaussMarkov()))]
)
def test_the_compiled_draw_is_the_single_envs_draw_bit_for_bit(ranges):
    rows, seed, sigma = 16, 5, 15.0
    vec = drawn_vec(ranges, rows, report_sigma=sigma)
    vec.reset(seed=seed)
    kernel_rows, weights = vec.rows.kernel_rows, vec.rows._weights
    moved, counts = 0, set()
    for i in range(rows):
        rng = np.random.default_rng(seed + i)  # (the seeded reset's generator)
        cfg = sample_multinode(rng, ranges, (1, 4))
        track = start_bare_track(cfg, rng, sigma, 1)  # (node_paths' draws: the same stream)
        env = vec.envs[i]
        assert env.config == cfg and env.config.to_dict() == cfg.to_dict()
        k, n = cfg.K, cfg.N
        assert same(env.track.paths, track.paths)
        assert same(env.track.lo, track.lo) and same(env.track.hi, track.hi)
        # (slot 0's reports and rates are the reset's observation: the later slots' are not drawn yet)
        assert same(env.track.reports[1:], track.reports[1:]) and same(
            env.track.measured[:, 1:], track.measured[:, 1:]
        )
        length_scale, sharpness, softmin_beta, _, clip = kernel_rows.settings
        assert same(
            kernel_rows.episode[i], episode_row(cfg, length_scale, sharpness, softmin_beta, False, 0.0, clip)
        )
        assert same(kernel_rows.points[i, :k], node_points(cfg))
        assert tuple(kernel_rows.sizes[i]) == (k, n)
        # the ground points and kernel entries NodeWeights.load makes of the config and its paths
        ref = NodeWeights(1, k, kernel_rows.params.shape[2])
        buffer = np.zeros((1, k, 3, kernel_rows.nodes.shape[3]))
        assert ref.load(0, cfg, track.paths, buffer)
        assert same(weights.points[i, :n, :k], ref.points[0, :n, :k]) and weights.cx[i] == ref.cx[0]
        assert same(weights.base[i], ref.base[0]) and weights.factors[i] == ref.factors[0]
        assert (weights.counts[i], weights.slots[i]) == (k, n)
        assert same(kernel_rows.nodes[i, :k, :2], buffer[0, :, :2])
        moved += sum(abs(x - cfg.ios_center[0]) == cfg.motion.plane_margin for x, _ in cfg.nodes)
        counts.add(k)
    assert counts == {1, 2, 3, 4}
    if ranges is NEAR_PLANE:
        assert moved > 0  # (some nodes were drawn inside the plane's strip and moved out of it)


def run_the_id_batch_and_its_singles(knowledge: str, rows: int, seed: int, steps: int, **vec: object) -> None:
    """The mobile id's batch of ``rows`` (drawn episodes) and its rows' single envs, reset with
    ``seed`` and stepped ``steps`` times alike: equal bit for bit, over two episodes a row or more."""
    make = {"knowledge": knowledge, "ranges": ScenarioRanges(T=(40.0, 60.0))}
    batch = gym.make_vec(
        MULTINODE_MOBILE_ID, num_envs=rows, vectorization_mode="vector_entry_point", **vec, **make
    )
    assert batch.rows._drawn is not None
    singles = [gym.make(MULTINODE_MOBILE_ID, **make).unwrapped for _ in range(rows)]
    obs, _ = batch.reset(seed=seed)
    for i, env in enumerate(singles):
        assert same(env.reset(seed=seed + i)[0], obs[i])
    actions = np.random.default_rng(seed).uniform(-1.2, 1.2, (steps, *batch.action_space.shape))
    assert step_batch_and_singles(batch, singles, actions, RECORDS, False) >= 2 * rows
    assert [env.config for env in singles] == batch.configs


@pytest.mark.parametrize("knowledge", ["reports", "rates", "exact"])
def test_the_mobile_id_batch_is_its_single_envs_over_episodes(knowledge):
    run_the_id_batch_and_its_singles(knowledge, 4, 3, 150)


@pytest.mark.parametrize("knowledge", ["reports", "rates"])
def test_small_calls_on_threads_are_the_single_envs(monkeypatch, knowledge):
    """A few rows' calls (autoresets) run on this thread alone (``jit.threads_for``); forced onto
    numba's threads here (every call of 5 rows), each row is still its single env's."""
    monkeypatch.setattr(ios_uav_env.jit, "FEW_ROWS", 2)
    assert ios_uav_env.jit.threads_for(2, 2) == 2
    run_the_id_batch_and_its_singles(knowledge, 5, 7, 130, num_threads=2)


def test_the_same_seed_gives_the_same_episodes():
    a, b = drawn_vec(NEAR_PLANE, 6), drawn_vec(NEAR_PLANE, 6)
    (oa, _), (ob, _) = a.reset(seed=9), b.reset(seed=9)
    assert same(oa, ob) and same(a.rows.kernel_rows.episode, b.rows.kernel_rows.episode)
    actions = np.random.default_rng(0).uniform(-1, 1, (90, *a.action_space.shape))
    for step in actions:
        assert same(a.step(step)[0], b.step(step)[0])


def test_configs_are_built_when_read():
    vec = drawn_vec(BOXED, 3)
    vec.reset(seed=0)
    steppers = [env.stepper for env in vec.envs]
    assert all(s.__dict__.get("_deferral") is not None for s in steppers)
    configs = vec.configs  # (reading one builds that row's)
    assert all(s.__dict__.get("_deferral") is None for s in steppers)
    singles = [MultiNodeEnv(random_nodes=(1, 4), ranges=BOXED, knowledge="reports") for _ in range(3)]
    for i, env in enumerate(singles):
        env.reset(seed=i)
    assert configs == [env.config for env in singles]
    # a track read during an episode keeps its numbers when the row begins the next one
    track = vec.envs[0].track
    paths, measured = track.paths.copy(), track.measured.copy()
    vec.reset(seed=50)
    assert same(track.paths, paths) and same(track.measured, measured)
    assert vec.envs[0].config != configs[0]


def test_a_draw_the_scenario_refuses_is_refused_with_its_error():
    """Ranges that check out at construction (their corners) but whose draw the config refuses
    (here forced after construction): the batched reset raises the config's own error, as the
    single env's does. Skipping the compiled draw's checks would let the bad scenario run (row 0,
    valid, is the one whose config the batch builds for the rows' kernel geometry)."""
    bad = refused_ranges()
    seed = refused_after(MultiNodeEnv(random_nodes=(2, 3), ranges=bad, knowledge="reports"))
    vec = drawn_vec(bad, 2, nodes=(2, 3))
    with pytest.raises(ValueError, match=OUTSIDE):
        vec.reset(seed=seed)
    with pytest.raises(RuntimeError, match="reset"):
        vec.step(np.zeros(vec.action_space.shape))


def test_a_row_whose_surface_the_compiled_weights_do_not_take_reads_its_track(monkeypatch):
    geometry = NodeWeights._geometry

    def no_ris(self, config):  # (as if the RIS's weights were not interpolated)
        return None if config.surface == "ris" else geometry(self, config)

    monkeypatch.setattr(node_weights.NodeWeights, "_geometry", no_ris)
    rows = 6
    kwargs = {"random_nodes": (2, 4), "ranges": ScenarioRanges(T=(40.0, 60.0), base=BOXED.base),
              "knowledge": "reports"}  # fmt: skip
    vec = MultiNodeVectorEnv(rows, **kwargs)
    singles = [MultiNodeEnv(**kwargs) for _ in range(rows)]
    obs, _ = vec.reset(seed=1)
    for i, env in enumerate(singles):
        assert same(env.reset(seed=1 + i)[0], obs[i])
    weights = vec.rows._weights
    ris = np.array([env.config.surface == "ris" for env in vec.envs])
    assert ris.any() and (~ris).any()
    assert (weights.slots[ris] == 0).all() and (weights.slots[~ris] > 0).all()
    actions = np.random.default_rng(1).uniform(-1.2, 1.2, (70, *vec.action_space.shape))
    assert step_batch_and_singles(vec, singles, actions, RECORDS, False) > 0


def test_only_the_envs_it_reproduces_take_the_compiled_draw():
    kwargs = {
        "random_nodes": (2, 3),
        "ranges": ScenarioRanges(T=(40.0, 60.0)),
        "motion": {"kind": "gauss_markov"},
    }
    assert takes_drawn_nodes(MultiNodeVectorEnv(2, **kwargs).envs[0])
    for extra in (
        {"filter_estimate": True, "knowledge": "reports"},
        {"objective": "energy_efficiency"},
        {"channel": "rician"},
    ):
        assert not takes_drawn_nodes(MultiNodeVectorEnv(2, **kwargs, **extra).envs[0]), extra
    assert not takes_drawn_nodes(gym.make("ios_uav_env/IOSUAV-MultiNode-Random-v0").unwrapped)
    assert ios_uav_env  # (registers the ids)


def test_pinned_and_drawn_rows_side_by_side():
    """A reset that pins some rows' scenarios (a narrower surface than the drawn ones, one alike)
    and draws the others: the drawn rows' compiled episodes next to the pinned rows' loads (the
    rows' arrays grown by either), every row its single env over episodes."""
    ranges = ScenarioRanges(T=(40.0, 60.0), ios_rows=(20, 30), base=ScenarioConfig(motion=GaussMarkov()))
    kwargs = {"random_nodes": (2, 4), "ranges": ranges, "knowledge": "reports"}
    nodes = ((40.0, 30.0), (-50.0, 60.0), (90.0, -20.0))
    pinned = [
        ranges.base.replace(T=50.0, ground_nodes=nodes, ios_shape=shape) for shape in ((10, 6), (100, 25))
    ]
    configs = [pinned[0], None, None, pinned[1], None]
    vec = MultiNodeVectorEnv(len(configs), **kwargs)
    singles = [MultiNodeEnv(**kwargs) for _ in configs]
    obs, _ = vec.reset(seed=2, options={"configs": configs})
    for i, env in enumerate(singles):
        options = None if configs[i] is None else {"config": configs[i]}
        assert same(env.reset(seed=2 + i, options=options)[0], obs[i])
    drawn = [env.stepper.__dict__.get("_deferral") is not None for env in vec.envs]
    assert drawn == [c is None for c in configs]
    actions = np.random.default_rng(2).uniform(-1.2, 1.2, (130, *vec.action_space.shape))
    assert step_batch_and_singles(vec, singles, actions, RECORDS, False) >= len(configs)
