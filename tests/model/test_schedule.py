"""Several ground nodes: the config's canonical form and the certified max-min scorer."""

import math
import sys

import numpy as np
import pytest

import ios_uav_env as ie
from ios_uav_env import ScenarioConfig
from ios_uav_env.model import channel as ch
from ios_uav_env.model.schedule import dual_value, maxmin_schedule

NODES = ((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0))
SMALL = {"ios_shape": (10, 6), "T": 60.0}


def _line(config):
    frac = np.arange(config.N) / (config.N - 1)
    return np.asarray(config.q0) + frac[:, None] * (np.asarray(config.qF) - np.asarray(config.q0))


# --- config ------------------------------------------------------------------------------


def test_one_node_is_the_single_node_config():
    one = ScenarioConfig(ground_nodes=((10.0, 5.0),))
    assert one == ScenarioConfig(ground_node=(10.0, 5.0))
    assert hash(one) == hash(ScenarioConfig(ground_node=(10, 5)))
    assert one.ground_nodes is None and one.K == 1 and one.nodes == ((10.0, 5.0),)
    assert "ground_nodes" not in ScenarioConfig().to_dict()  # stored single-node dicts unchanged
    assert ScenarioConfig().node_config(0) == ScenarioConfig()


def test_several_nodes_canonical_form_and_round_trip():
    c = ScenarioConfig(ground_nodes=[list(p) for p in NODES])
    assert c.K == 3 and c.nodes == NODES and c.ground_node == NODES[0]
    assert ScenarioConfig(**c.to_dict()) == c
    assert c.node_config(1) == ScenarioConfig(ground_node=NODES[1])
    assert c.replace(T=100.0).nodes == NODES
    assert c.replace(ground_nodes=None) == ScenarioConfig(ground_node=NODES[0])
    assert c.replace(ground_nodes=NODES[1:]).ground_node == NODES[1]
    with pytest.raises(ValueError, match="ground_node cannot be replaced.*set ground_nodes"):
        c.replace(ground_node=(0.0, 0.0))


@pytest.mark.parametrize(
    ("nodes", "match"),
    [
        ((), r"ground_nodes must be a sequence of K >= 1"),
        ("ab", r"ground_nodes must be a sequence"),
        (5, r"ground_nodes must be a sequence"),
        (((1.0, 2.0), (3.0,)), r"ground_nodes\[1\] must have 2 entries"),
        (((1.0, 2.0), (3.0, float("nan"))), r"ground_nodes\[1\] must be finite"),
        ((("a", 2.0), (3.0, 4.0)), r"ground_nodes\[0\] must be a sequence of 2 numbers"),
    ],
)
def test_bad_ground_nodes_name_the_field(nodes, match):
    with pytest.raises(ValueError, match=match):
        ScenarioConfig(ground_nodes=nodes)


def test_conflicting_ground_node_raises_and_node_index_is_checked():
    with pytest.raises(ValueError, match="conflicts with ground_nodes"):
        ScenarioConfig(ground_node=(1.0, 1.0), ground_nodes=NODES)
    with pytest.raises(ValueError, match=r"k must be an integer in \[0, 2\]"):
        ScenarioConfig(ground_nodes=NODES).node_config(3)


def test_single_node_functions_refuse_several_nodes():
    c = ScenarioConfig(ground_nodes=NODES, **SMALL)
    for call in (
        lambda: ie.slot_rates(c, np.zeros((1, 2))),
        lambda: ie.average_rate(c, _line(c)),
        lambda: ie.rate_peak(c),
        lambda: ie.rate_kernel(c),
        lambda: ch.element_amplitudes(c, np.zeros((1, 2))),
    ):
        with pytest.raises(ValueError, match="K=3 ground_nodes: use ios_uav_env.node_rates / maxmin_rate"):
            call()


# --- scorer ------------------------------------------------------------------------------


def test_node_rates_are_the_single_node_rates_per_node():
    c = ScenarioConfig(ground_nodes=NODES, **SMALL)
    q = _line(c)
    r = ie.node_rates(c, q)
    assert r.shape == (3, c.N)
    for k, w in enumerate(NODES):
        np.testing.assert_array_equal(r[k], ie.slot_rates(ScenarioConfig(ground_node=w, **SMALL), q))


def test_k1_score_is_average_rate_exactly_and_needs_no_lp():
    c = ScenarioConfig(**SMALL)
    q = _line(c)
    assert ie.maxmin_rate(c, q) == ie.average_rate(c, q)
    np.testing.assert_array_equal(ie.best_schedule(c, q), np.ones((1, c.N)))
    assert ie.scheduled_rates(c, q, np.ones((1, c.N)))[0] == ie.average_rate(c, q)


def test_k1_score_does_not_import_scipy():
    import subprocess

    code = (
        "import sys; sys.modules['scipy'] = None\n"
        "from ios_uav_env import ScenarioConfig, maxmin_rate\n"
        "import numpy as np\n"
        "c = ScenarioConfig(T=40, ios_shape=(10, 6))\n"
        "q = np.linspace(c.q0, c.qF, c.N)\n"
        "print(maxmin_rate(c, q))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr


def test_lp_is_certified_by_its_dual_and_beats_every_other_schedule():
    c = ScenarioConfig(ground_nodes=NODES, **SMALL)
    q = _line(c)
    best = ie.schedule(c, q)
    r = ie.node_rates(c, q)
    assert abs(best.dual_value - best.value) <= 1e-9 and abs(best.value - ie.maxmin_rate(c, q)) == 0
    assert best.value == pytest.approx(ie.scheduled_rates(c, q, best.shares).min(), abs=1e-15)
    assert np.all(best.shares >= 0) and np.all(best.shares.sum(axis=0) <= 1 + 1e-12)
    rng = np.random.default_rng(1)
    for _ in range(50):  # every schedule scores at most V; every w gives g(w) >= V
        a = rng.random((3, c.N))
        a /= a.sum(axis=0) * rng.uniform(1.0, 1.5)
        assert ie.scheduled_rates(c, q, a).min() <= best.value + 1e-12
        w = rng.dirichlet(np.ones(3))
        assert dual_value(r, w) >= best.value - 1e-12
    # equal time shares are a feasible schedule: V is at least their min rate
    assert best.value >= ie.scheduled_rates(c, q, np.full((3, c.N), 1 / 3)).min() - 1e-12


def test_lp_matches_an_independent_bisection_for_two_nodes():
    """K = 2: V = min over w in [0, 1] of g(w) (convex): a golden-section search on g."""
    rng = np.random.default_rng(7)
    for _ in range(5):
        r = rng.uniform(0.0, 3.0, size=(2, 40))

        def g(a, r=r):
            return dual_value(r, np.array([a, 1.0 - a]))

        lo, hi = 0.0, 1.0
        phi = (math.sqrt(5) - 1) / 2
        for _ in range(200):
            m1, m2 = hi - phi * (hi - lo), lo + phi * (hi - lo)
            if g(m1) <= g(m2):
                hi = m2
            else:
                lo = m1
        assert maxmin_schedule(r).value == pytest.approx(g(0.5 * (lo + hi)), abs=1e-9)


def test_fixed_slots_give_the_best_continuation():
    """``fixed``: the first slots keep their shares, the rest is the best continuation, certified by
    dual_value with the same ``fixed`` (an independent golden-section search for K = 2)."""
    rng = np.random.default_rng(11)
    r = rng.uniform(0.0, 3.0, size=(2, 30))
    best = maxmin_schedule(r)
    again = maxmin_schedule(r, best.shares[:, :12])  # the optimum's own start: same value
    assert again.value == pytest.approx(best.value, abs=1e-12)
    fixed = np.zeros((2, 12))
    fixed[0] = 1.0  # node 0 served first: node 1 must be made up for later
    cont = maxmin_schedule(r, fixed)
    np.testing.assert_array_equal(cont.shares[:, :12], fixed)
    assert cont.value == pytest.approx(np.mean(cont.shares * r, axis=1).min(), abs=1e-15)
    assert cont.value <= best.value + 1e-12 and cont.gap <= 1e-9

    def g(a):
        return dual_value(r, np.array([a, 1.0 - a]), fixed)

    lo, hi, phi = 0.0, 1.0, (math.sqrt(5) - 1) / 2
    for _ in range(200):
        m1, m2 = hi - phi * (hi - lo), lo + phi * (hi - lo)
        lo, hi = (lo, m2) if g(m1) <= g(m2) else (m1, hi)
    assert cont.value == pytest.approx(g(0.5 * (lo + hi)), abs=1e-9)
    # equal rates, the first half all to node 0: the whole second half goes to node 1
    flat = maxmin_schedule(np.ones((2, 10)), np.tile([[1.0], [0.0]], 5))
    np.testing.assert_allclose(flat.shares[:, 5:], np.tile([[0.0], [1.0]], 5), atol=1e-12)
    assert flat.value == pytest.approx(0.5)
    with pytest.raises(ValueError, match=r"fixed must be the shares \(K, n0\) of the first n0 < N"):
        maxmin_schedule(r, np.zeros((2, 30)))
    with pytest.raises(ValueError, match="fixed shares must be finite, >= 0"):
        maxmin_schedule(r, np.full((2, 3), 0.6))


def test_known_schedule_value():
    """Two nodes, two slots, each node good in one slot: V = min(a, b)/2 -> each gets its slot;
    with a dominant node, the best schedule shares the slot to equalise."""
    assert maxmin_schedule(np.array([[2.0, 0.0], [0.0, 1.0]])).value == pytest.approx(0.5, abs=1e-12)
    # one slot, rates 2 and 1: alpha_1 2 = alpha_2 1, alpha_1 + alpha_2 = 1 -> V = 2/3 (N = 1)
    assert maxmin_schedule(np.array([[2.0], [1.0]])).value == pytest.approx(2.0 / 3.0, abs=1e-12)


@pytest.mark.parametrize(
    ("shares", "match"),
    [
        (np.ones((2, 24)), r"shape \(K, N\) = \(3, 24\)"),
        (np.full((3, 24), np.nan), "finite"),
        (np.full((3, 24), -0.1), ">= 0"),
        (np.full((3, 24), 0.5), r"column sums .* <= 1"),
    ],
)
def test_bad_shares_raise(shares, match):
    c = ScenarioConfig(ground_nodes=NODES, ios_shape=(10, 6), T=24.0, q0=(-250.0, 20.0), qF=(250.0, 20.0))
    with pytest.raises(ValueError, match=match):
        ie.scheduled_rates(c, _line(c), shares)


def test_bad_rates_and_weights_raise():
    with pytest.raises(ValueError, match="rates must be a"):
        maxmin_schedule(np.ones(3))
    with pytest.raises(ValueError, match="finite and >= 0"):
        maxmin_schedule(np.array([[1.0, -1.0], [1.0, 1.0]]))
    with pytest.raises(ValueError, match="simplex"):
        dual_value(np.ones((2, 3)), np.array([0.7, 0.7]))


def test_plan_scores_several_nodes_with_maxmin_rate():
    from baselines.plan import Plan

    c = ScenarioConfig(ground_nodes=NODES, **SMALL)
    plan = Plan.from_trajectory("line", c, _line(c), 0.0)
    assert plan.mean_rate == ie.maxmin_rate(c, _line(c)) and plan.feasible
    assert np.array(plan.info["shares"]).shape == (3, c.N) and len(plan.info["node_rates"]) == 3


def test_an_uncertified_lp_answer_raises(monkeypatch):
    """The primal-dual check: corrupt the LP's dual weights and the scorer must refuse."""
    import dataclasses

    from ios_uav_env.model import lp, schedule_lp

    def corrupted(*args, **kwargs):
        res = lp.solve_lp(*args, **kwargs)
        duals = res.ub_duals.copy()
        duals[:3] = [-1.0, 0.0, 0.0]  # w = e_1: g(w) = mean r_1 > V
        return dataclasses.replace(res, ub_duals=duals)

    monkeypatch.setattr(schedule_lp, "solve_lp", corrupted)
    r = np.array([[2.0, 2.0], [0.0, 1.0], [1.0, 0.0]])
    with pytest.raises(RuntimeError, match="not certified"):
        maxmin_schedule(r)


def test_env_refuses_several_nodes():
    pytest.importorskip("gymnasium")
    c = ScenarioConfig(ground_nodes=NODES, **SMALL)
    with pytest.raises(ValueError, match="K = 3 ground_nodes, but ios_uav_env/IOSUAV-v0 is a single-node"):
        env = ie.IOSUAVEnv(config=c)
        env.reset(seed=0)
