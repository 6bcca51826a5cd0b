"""b-bit phases in a STAR flight (``ScenarioConfig(surface="star", star_bits=b)``, TDMA): the slot
rate the frame flies on (``channel.zeta`` / ``slot_rates``, the compiled
``rate_rows.discrete_zeta_row`` that the envs' kernels, ``score_plan`` and the DP all read) is
the served node's rate in ``star_slot.slot_optimum``'s TDMA optimum for that slot (the whole surface
on its side at its exact b-bit phases); the search is exact against brute force; the rates order as
the phase grids nest; ``score_plan`` and moving nodes read the same rate."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig, node_rates, score_plan
from ios_uav_env.model import channel, star
from ios_uav_env.model.config import STAR_PHASES, STAR_PROTOCOLS
from ios_uav_env.model.rate_kernels import rate_kernel, rates_at
from ios_uav_env.model.star_slot import slot_optimum
from tests.processes import run_without_numba
from tests.tolerances import RATE_REL

#: A STAR surface of 30 x 20 elements (the exact per-element search on every slot).
STAR = ScenarioConfig(surface="star", T=40.0, ios_shape=(30, 20))
#: One node on each side of the plane x = 0.
NODES = ((-100.0, -20.0), (100.0, 30.0))
#: UAV positions on both sides of the plane, near and far from the surface.
POSITIONS = [(-100.0, -20.0), (-50.0, 40.0), (-300.0, 80.0), (20.0, 5.0), (120.0, 10.0), (300.0, -80.0)]
#: The searches agree with each other to rounding (1e-12 relative: thousands of ulps of the sums).
EXACT = 1e-12


def _surfaces():
    """Every (protocol, phases, bits) of a TDMA flight with b = 1, 2, 3 (coupled phases from 2 bits)."""
    for protocol, phases, bits in itertools.product(STAR_PROTOCOLS, STAR_PHASES, (1, 2, 3)):
        if not (phases == "coupled" and bits == 1):
            yield protocol, phases, bits


@pytest.mark.parametrize(("protocol", "phases", "bits"), list(_surfaces()))
def test_the_slot_rate_is_the_per_slot_b_bit_optimum(protocol, phases, bits):
    """At each position the node on the UAV's side is served by reflection, the other by
    transmission; each one's ``slot_rates`` is its rate served alone in ``slot_optimum``'s TDMA
    optimum of that slot (c_s = rates[s] / its share), and the slot's max-min follows."""
    config = STAR.replace(ground_nodes=NODES, star_protocol=protocol, star_phases=phases, star_bits=bits)
    surface = star.StarSurface(protocol, phases, bits)
    for q in POSITIONS:
        r = 0 if q[0] * NODES[0][0] > 0 else 1  # the node on the UAV's side reflects
        ch = star.star_channels(config, q, NODES[r], NODES[1 - r])
        c_r = channel.slot_rates(config.node_config(r), q)[0]
        c_t = channel.slot_rates(config.node_config(1 - r), q)[0]
        best = slot_optimum(ch, surface, "tdma")
        share = best.setting["share"]
        assert best.rates[0] / share == pytest.approx(c_r, rel=RATE_REL)
        assert best.rates[1] / (1 - share) == pytest.approx(c_t, rel=RATE_REL)
        assert best.value == pytest.approx(c_r * c_t / (c_r + c_t), rel=RATE_REL)
        # the served side's amplitude is star.best_discrete_phases' exact one, to rounding
        _, amp = star.best_discrete_phases(ch.a_r, ch.phi_r, ch.direct_r, bits)
        assert channel.zeta(config.node_config(r), q)[0] == pytest.approx(amp, rel=EXACT)


@pytest.mark.parametrize("bits", [1, 2])
def test_the_search_is_exact_against_brute_force(bits):
    """A 3 x 2 surface: the amplitude is the largest of every one of the 2^(b M) phase settings."""
    config = STAR.replace(ios_shape=(3, 2), star_bits=bits, ground_node=NODES[1])
    grid = star.phase_grid(bits)
    for q in POSITIONS:
        a = channel.element_amplitudes(config, np.array([q]))[0]
        phi = channel.phase_shifts(config, np.array([q]))[0]
        direct = channel.direct_amplitude(config, np.array([q]))[0]
        settings = np.array(list(itertools.product(grid, repeat=a.size)))  # (2^(b M), M)
        brute = np.abs(direct + (a * np.exp(1j * (phi - settings))).sum(axis=1)).max()
        assert channel.zeta(config, q)[0] == pytest.approx(brute, rel=EXACT)


@pytest.mark.slow_without_numba
def test_the_rates_order_as_the_phase_grids_nest():
    """b-bit grids nest (1 in 2 in 3), and every phase setting is below the aligned one: per slot
    r_1 <= r_2 <= r_3 <= r_continuous, at drawn positions on both sides, each node; 8 bits come
    within 1e-3 of continuous phases."""
    rng = np.random.default_rng(0)
    q = np.column_stack([rng.uniform(-400.0, 400.0, 100), rng.uniform(-150.0, 150.0, 100)])
    for node in NODES:
        config = STAR.replace(ground_node=node)
        rates = [channel.slot_rates(config.replace(star_bits=b), q) for b in (1, 2, 3)]
        rates.append(channel.slot_rates(config, q))
        for low, high in itertools.pairwise(rates):
            assert np.all(low <= high * (1 + EXACT))
        assert np.all(rates[0] < rates[-1])  # (one bit loses at every position here)
        fine = channel.slot_rates(config.replace(star_bits=8), q[:10])  # (2^8 passes each: a few)
        assert np.all(rates[2][:10] <= fine * (1 + EXACT)) and np.all(fine <= rates[3][:10] * (1 + EXACT))
        assert np.all(fine >= rates[3][:10] * (1 - 1e-3))


def test_zero_weight_nodes_change_nothing():
    """A batch row's kernel is padded with zero-weight nodes: the b-bit rate skips them, bit for bit."""
    config = STAR.replace(star_bits=2, ground_node=NODES[0])
    kernel = rate_kernel(config)
    points = np.array(POSITIONS)
    padded = np.concatenate([kernel.nodes, np.tile([[0.0], [1.0], [0.0]], (1, 7))], axis=1)
    assert np.array_equal(rates_at(points, padded, kernel.params), kernel.rates(points))
    assert np.array_equal(kernel.rates(points), channel.slot_rates(config, points))


def test_score_plan_and_moving_nodes_read_the_same_rate():
    """``score_plan`` of a b-bit flight is the mean of its slot rates; a node whose path stays put
    has the static node's rates bit for bit, and a moving node's slot i is the static node at
    w[i]'s."""
    config = STAR.replace(star_bits=2, ground_node=NODES[0])
    flight = np.linspace(config.q0, config.qF, config.N)
    rates = channel.slot_rates(config, flight)
    assert score_plan(config, flight).rate == pytest.approx(float(np.mean(rates)), rel=EXACT)
    still = np.tile(np.array(config.nodes), (config.N, 1, 1))
    assert np.array_equal(node_rates(config, flight, still)[0], rates)
    walk = np.linspace(NODES[0], (-80.0, 10.0), config.N)[:, None, :]
    moving = node_rates(config, flight, walk)[0]
    each = [
        channel.slot_rates(config.replace(ground_node=tuple(w[0])), q)[0]
        for q, w in zip(flight, walk, strict=True)
    ]
    np.testing.assert_allclose(moving, each, rtol=EXACT)


def test_the_plain_python_kernel_agrees_with_the_compiled_one():
    """Without numba the same search runs as plain Python (``ios_uav_env.jit``): equal to rounding."""
    config = STAR.replace(ios_shape=(8, 6), star_bits=2, ground_node=NODES[1])
    points = np.array(POSITIONS)
    code = (
        "import json, numpy as np\n"
        "from ios_uav_env import ScenarioConfig\n"
        "from ios_uav_env.model import channel\n"
        f"config = ScenarioConfig.from_dict(json.loads({json.dumps(config.to_dict())!r}))\n"
        f"print(json.dumps(channel.slot_rates(config, np.array({POSITIONS!r})).tolist()))\n"
    )
    plain = np.array(json.loads(run_without_numba(code)))
    np.testing.assert_allclose(plain, channel.slot_rates(config, points), rtol=EXACT)
