"""The compiled and cached forms of the per-scenario model work (what a randomised env's reset
runs) against the numpy forms they replace: the same results bit for bit.

- ``surface._beta_grid`` (the element weights of every ground position) and the stacked
  projection of ``surface.ground_weights``, a path of points side by side;
- ``surface._projection``, cached per geometry (shared by scenarios that differ in G, T, q0,
  qF or the surface's kind);
- ``motion._walk`` (the Gauss-Markov walk of ``node_paths`` with its slots' normals drawn at
  once);
- ``peak._candidates`` (``reachable`` and ``_on_side`` in one pass);
- ``ScenarioRanges`` of one scenario making no config.

Each compiled function is plain Python without numba, so these run both ways.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ios_uav_env.model import motion, peak, surface
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.mobility import reflect
from ios_uav_env.model.scenarios import DEFAULT_RANGES, ScenarioRanges, sample_scenario


def _numpy_betas(config: ScenarioConfig, grounds: np.ndarray) -> np.ndarray:
    ys, zs = surface._axes(config)
    dx2 = (grounds[:, 0] - config.ios_center[0]) ** 2
    dy2 = (grounds[:, 1, None] - ys[None, :]) ** 2
    d2 = dx2[:, None, None] + dy2[:, :, None] + (zs * zs)[None, None, :]
    return (dx2**1.5)[:, None, None] / (d2 * d2)


def _drawn(n: int, seed: int, ranges: ScenarioRanges = DEFAULT_RANGES) -> list[ScenarioConfig]:
    rng = np.random.default_rng(seed)
    return [sample_scenario(rng, ranges) for _ in range(n)]


def _numpy_interpolated(config: ScenarioConfig, grounds: np.ndarray) -> np.ndarray:
    """The ground side's node weights ky B kz^T (``surface`` module docstring) as plain numpy
    loops: B[c, d] = |x_G - x_c|^3 / d^4 at the interpolation points, each sum from 0 in order."""
    projection = surface._projection(config)
    dx2 = (grounds[:, 0] - config.ios_center[0]) ** 2
    out = np.zeros((len(grounds), projection.ky.shape[0], projection.kz.shape[0]))
    scale = dx2**1.5  # (numpy's array power, as the weights take it: a scalar's may round otherwise)
    for p, (x2, y) in enumerate(zip(dx2, grounds[:, 1], strict=True)):
        d2 = (x2 + (y - projection.gy)[:, None] ** 2) + projection.gz2[None, :]
        beta = scale[p] / (d2 * d2)
        half = np.zeros((projection.ky.shape[0], beta.shape[1]))
        for c in range(beta.shape[0]):
            half += projection.ky[:, c, None] * beta[c][None, :]
        for d in range(beta.shape[1]):
            out[p] += half[:, d, None] * projection.kz[None, :, d]
    return out.reshape(len(grounds), -1)


@pytest.mark.parametrize("exact", [False, True])
def test_ground_weights_are_the_numpy_weights_bit_for_bit(exact):
    rng = np.random.default_rng(0)
    for config in _drawn(6, 1):
        config = config.replace(ios_shape=(12, 9), quadrature_nodes=0) if exact else config
        grounds = rng.uniform(-300.0, 300.0, (7, 2))
        ys, zs = surface._axes(config)
        dx2 = (grounds[:, 0] - config.ios_center[0]) ** 2
        dy2 = (grounds[:, 1, None] - ys[None, :]) ** 2
        betas = _numpy_betas(config, grounds)
        assert np.array_equal(surface._beta_grid(dx2**1.5, dx2, dy2, zs * zs), betas)
        assert np.array_equal(surface._betas(config, grounds), betas)
        projection = surface._projection(config)
        assert (projection.ky is None) == exact  # the drawn families' grids: beta interpolated
        if exact:
            rows = np.stack([surface._weights(projection, beta) for beta in betas])
        else:
            rows = _numpy_interpolated(config, grounds)
        assert np.array_equal(surface.ground_weights(config, grounds), rows)
        single = surface.surface_nodes(config.replace(ground_node=tuple(grounds[3])))
        assert np.array_equal(single.weight, rows[3])


def test_a_long_path_of_grounds_is_weighted_point_by_point():
    """A moving node's path (more points than the compiled weights take side by side, and not a
    multiple of them): every point's weights are the numpy form's and its own alone, bit for bit."""
    rng = np.random.default_rng(5)
    for config in _drawn(3, 2):
        count = 2 * surface.WEIGHT_BLOCK + 11
        grounds = rng.uniform(-300.0, 300.0, (count, 2))
        got = surface.ground_weights(config, grounds)
        assert np.array_equal(got, _numpy_interpolated(config, grounds))
        for p in (0, surface.WEIGHT_BLOCK - 1, surface.WEIGHT_BLOCK, count - 1):
            assert np.array_equal(surface.ground_weights(config, grounds[p : p + 1])[0], got[p])


#: Geometries of the ground side's interpolation: the paper's, a low surface (more points), a
#: large one (more nodes and points), few rows, one just above the ground (points along y only,
#: z's rows themselves) and one whose bound asks for the whole grid (beta itself).
GEOMETRIES = [
    {},
    {"ios_center": (0.0, 0.0, 5.0)},
    {"ios_shape": (300, 120), "uav_altitude": 60.0},
    {"ios_shape": (100, 20), "ios_center": (30.0, -10.0, 40.0)},
    {"ios_center": (0.0, 0.0, 1.5)},
    {"ios_center": (0.0, 0.0, 0.5), "ios_shape": (30, 20)},
]


@pytest.mark.parametrize(
    "fields", GEOMETRIES, ids=["paper", "low", "large", "few-rows", "near-ground", "on-ground"]
)
def test_the_interpolated_beta_keeps_the_amplitude_within_the_tolerance(fields):
    """Against the element weights themselves (the exact beta, projected as before), at ground
    nodes anywhere, right at the foot of the surface and up to 1e-3 m from its plane: the surface
    amplitude of the nodes moves by at most GROUND_TOL_SHARE x quadrature_tol relative (what
    ground_count's bound promises), on both sides of the plane."""
    config = ScenarioConfig(**fields)
    projection = surface._projection(config)
    p = surface.ground_count(config)
    ys, zs = surface._axes(config)
    assert (p == 0) == (projection.ky is None) and (p == 0) == (fields == GEOMETRIES[-1])
    rng = np.random.default_rng(3)
    x_c, y_c = config.ios_center[0], config.ios_center[1]
    grounds = np.column_stack([x_c + rng.uniform(-300.0, 300.0, 60), y_c + rng.uniform(-200.0, 200.0, 60)])
    grounds[:30, 0] = x_c + rng.choice([-1.0, 1.0], 30) * 10.0 ** rng.uniform(-3.0, 0.0, 30)
    grounds[:20, 1] = rng.uniform(ys[0], ys[-1], 20)  # at the foot of the surface
    exact = np.stack([surface._weights(projection, beta) for beta in surface._betas(config, grounds)])
    got = surface.ground_weights(config, grounds)
    # the amplitude is a positive combination of the UAV-side values d_Um^-4 over the nodes: bound
    # the error of any such sum by |w - w_exact| summed against the sum of the exact element weights
    elements = surface._betas(config, grounds).reshape(len(grounds), -1).sum(axis=1)
    error = np.abs(got - exact).sum(axis=1) / elements
    tol = surface.GROUND_TOL_SHARE * config.quadrature_tol
    assert error.max() <= tol, error.max()
    if p:
        assert surface.ground_error_bound(config, p) <= tol < surface.ground_error_bound(config, p - 1)
        assert projection.ky.shape == (min(surface.node_count(config), ys.size), min(p, ys.size))


def test_the_ground_side_keeps_the_element_weights_where_asked():
    """The exact sum (quadrature_nodes = 0), the planners' coarse surrogates (quadrature_tol = inf)
    and a tolerance no interpolation reaches keep beta itself (the weights as before, bit for bit)."""
    config = ScenarioConfig()
    assert surface.ground_count(config) == 9  # the paper's geometry: 9 x 9 points of beta
    for fields in ({"quadrature_nodes": 0}, {"quadrature_tol": math.inf}, {"quadrature_tol": 1e-300}):
        changed = config.replace(**fields)
        assert surface.ground_count(changed) == 0 and surface._projection(changed).ky is None
        grounds = np.array([[-100.0, -20.0], [3.0, 1.0]])
        projection = surface._projection(changed)
        rows = [surface._weights(projection, beta) for beta in surface._betas(changed, grounds)]
        assert np.array_equal(surface.ground_weights(changed, grounds), np.stack(rows))


def test_the_projection_is_shared_by_scenarios_of_one_geometry():
    config = ScenarioConfig()
    other = config.replace(ground_node=(120.0, 40.0), T=180.0, q0=(-400.0, -60.0), surface="ris")
    assert surface._projection(other) is surface._projection(config)
    for change in ({"ios_shape": (100, 59)}, {"uav_altitude": 90.0}, {"quadrature_nodes": 9}):
        changed = config.replace(**change)
        assert surface._projection(changed) is not surface._projection(config)
        assert surface._projection(changed) is surface._projection(changed.replace(ground_node=(5.0, 5.0)))


def _numpy_walk(config: ScenarioConfig, rng: np.random.Generator) -> tuple[np.ndarray, int]:
    """``node_paths``'s loop as numpy, one draw of normals per slot (its form without numba),
    and how many steps left the rectangle (were reflected)."""
    m = config.motion
    lo, hi = motion.node_bounds(config)
    a, sigma = m.memory, m.sigma
    theta = rng.uniform(0.0, 2.0 * math.pi, config.K) if m.heading is None else np.full(config.K, m.heading)
    mean = m.speed * np.column_stack([np.cos(theta), np.sin(theta)])
    v = mean + sigma * rng.standard_normal((config.K, 2))
    w = np.asarray(config.nodes, dtype=float)
    out = np.empty((config.N, config.K, 2))
    out[0] = w
    gain = math.sqrt(1.0 - a * a) * sigma
    walls = 0
    for n in range(config.N - 1):
        step = w + v * config.dt
        walls += int(np.sum((step < lo) | (step > hi)))
        v = a * v + (1.0 - a) * mean + gain * rng.standard_normal((config.K, 2))
        w, flip = reflect(step, lo, hi)
        v, mean = np.where(flip, -v, v), np.where(flip, -mean, mean)
        out[n + 1] = w
    return out, walls


@pytest.mark.parametrize(
    "model",
    [
        {"kind": "gauss_markov"},
        {"kind": "gauss_markov", "speed": 40.0, "memory": 0.2, "heading": 1.0},  # walls, often
        {"kind": "gauss_markov", "speed": 20.0, "sigma": 8.0, "box": ((-300.0, 300.0), (-200.0, 200.0))},
    ],
)
def test_node_paths_are_the_numpy_walk_bit_for_bit(model):
    ranges = ScenarioRanges(base=DEFAULT_RANGES.base.replace(motion=model))
    walls = 0
    for i, config in enumerate(_drawn(12, 2, ranges)):
        if i % 3 == 0:  # several nodes, on both sides of the IOS plane
            (x, y) = config.ground_node
            config = config.replace(ground_nodes=((x, y), (x, -50.0), (-x, 10.0)))
        ours, theirs = np.random.default_rng(i), np.random.default_rng(i)
        expected, reflected = _numpy_walk(config, theirs)
        assert np.array_equal(motion.node_paths(config, ours), expected)
        assert ours.random() == theirs.random()  # the same draws, no more
        walls += reflected
    assert walls > 0  # the reflections are covered


@pytest.mark.parametrize("side", peak.SIDES)
def test_the_candidate_mask_is_reachable_and_on_side(side):
    rng = np.random.default_rng(3)
    for config in _drawn(10, 4):
        points = rng.uniform(-2500.0, 2500.0, (2000, 2))
        points[:300] = np.round(points[:300] / config.D) * config.D  # exact multiples of D
        points[300:350, 0] = config.ios_center[0]  # on the plane
        along = np.asarray(config.q0) + np.column_stack([np.arange(100) * config.D, np.zeros(100)])
        points[350:450] = along  # exactly k moves from q0
        code = 0 if side is None else 1 if side == "front" else -1
        q0, qf = np.asarray(config.q0, float), np.asarray(config.qF, float)
        x_c, g_x = config.ios_center[0], config.ground_node[0]
        mask = peak._candidates(points, q0, qf, config.D, config.N - 1, x_c, g_x, code)
        expected = peak.reachable(config, points) & peak._on_side(config, points, side)
        assert np.array_equal(mask, expected)
        assert np.array_equal(peak._mask(config, points, side), expected)


def test_a_one_scenario_family_makes_no_config():
    config = _drawn(1, 5)[0]
    ranges = ScenarioRanges.from_config(config)
    assert ranges.configs_per_surface()[0] is config
    wider = ScenarioRanges(ground_x=(-10.0, 10.0), ground_y=(0.0, 0.0), base=config)
    first = wider.configs_per_surface()[0]
    assert first is not config and first == config.replace(
        ground_node=(-10.0, 0.0), ios_shape=wider.shape(wider.ios_rows[0]), surface=wider.surfaces[0]
    )
    with pytest.raises(ValueError, match="invalid scenario"):  # the checks still run on a change
        ScenarioRanges(T=(20.0, 200.0), base=config)


def test_a_geometrys_rate_kernels_are_built_from_its_first_bit_for_bit():
    """``rate_kernel`` of a drawn scenario copies what its kernel geometry's first kernel shares and
    sets G's parts: every array and scalar of the kernel built from the config alone, bit for bit
    (drawn families of both surfaces, no surface, the exact sum, several nodes' configs)."""
    import dataclasses

    from ios_uav_env.model import rate_kernels
    from ios_uav_env.model.scenarios import MULTINODE_RANGES, sample_multinode

    configs = _drawn(8, 5) + _drawn(3, 6, ScenarioRanges(surfaces=("none",)))
    configs += [c.replace(ios_shape=(12, 9), quadrature_nodes=0) for c in _drawn(3, 7)]
    multi = sample_multinode(np.random.default_rng(8), MULTINODE_RANGES, (3, 3))
    configs += [multi.node_config(k) for k in range(3)]
    for config in configs:
        mine, own = rate_kernels.rate_kernel(config), rate_kernels._own_kernel(config)
        for field in dataclasses.fields(own):
            a, b = getattr(mine, field.name), getattr(own, field.name)
            assert type(a) is type(b) and np.array_equal(a, b), field.name
            if isinstance(b, np.ndarray):
                assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), field.name
    shared = {rate_kernels._kernel_key(c) for c in configs}
    assert len(shared) < len(configs)  # (kernels were built from a geometry's first)
