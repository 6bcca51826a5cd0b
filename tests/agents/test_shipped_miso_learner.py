"""The shipped MISO learner (agents/models/miso_learner_MISOControl-v0): a small numpy model that
plays every miso-v1 scenario, replays its record and holds its bar (the heuristic DirectMRT). Its
leaderboard row reruns in full in tests/benchmark/test_leaderboard.py."""

from __future__ import annotations

import json

import numpy as np
import pytest

from agents.miso_learner import DEFAULT_MODEL, MisoLearner
from ios_uav_env.benchmark import evaluate, load_suite
from tests.tolerances import RATE_REL

#: Its mean slot values (bps/Hz) on miso-v1's first scenarios (N_t = 2, K = 2: M = 16 sum and
#: max-min, M = 64 sum), printed by ``python -m ios_uav_env.benchmark evaluate --suite miso-v1
#: --policy agents.miso_learner:MisoLearner --n 3 --out DIR`` (DIR/results.json).
RECORD = (4.079990904631045, 0.9728097540647298, 7.2957746355727195)


def test_the_shipped_learner_is_small_and_says_how_it_was_trained():
    config = json.loads((DEFAULT_MODEL / "config.json").read_text(encoding="utf-8"))
    assert config["command"].startswith("python -m agents.miso_training --out agents/models/miso_learner")
    assert config["settings"] == 24 and config["seconds"] > 0 and config["suite"] == "miso-v1"
    assert (DEFAULT_MODEL / "weights.npz").stat().st_size < 100_000
    assert sorted(p.name for p in DEFAULT_MODEL.iterdir()) == ["config.json", "weights.npz"]


def test_the_shipped_learner_replays_its_record():
    """Its actions are float64 numpy products of float32 observations: on another CPU's BLAS they
    differ by a few ulps, which RATE_REL covers (tests/tolerances.py)."""
    results = evaluate(MisoLearner(), "miso-v1", n=len(RECORD))
    assert [r.rate for r in results.scenarios] == pytest.approx(RECORD, rel=RATE_REL)


def test_the_shipped_learner_beats_the_heuristic_on_the_suite():
    """Over miso-v1 its mean, 10th-percentile and worst % of the AO are above DirectMRT's (the
    suite's stored ``direct`` rollouts), and it is at most the certified bound on every scenario."""
    suite = load_suite("miso-v1")
    mine = evaluate(MisoLearner(), suite)
    direct = np.array([100 * s.value("direct") / s.value("optimum") for s in suite.scenarios])
    ours = np.array([r.pct_optimum for r in mine.scenarios])
    assert mine.aggregate.feasible == len(suite.scenarios)
    assert ours.mean() > direct.mean() + 10
    assert np.percentile(ours, 10) > np.percentile(direct, 10) and ours.min() > direct.min()
    assert all(r.rate <= s.value("bound") for r, s in zip(mine.scenarios, suite.scenarios, strict=True))
