"""The shipped STAR-surface learner (agents/models/star_learner_STARControl-v0): a small numpy
model that plays every star-v1 scenario, replays its record and holds its bar (its zero residual,
ChannelPhases). Its leaderboard row reruns in full in tests/benchmark/test_leaderboard.py."""

from __future__ import annotations

import json

import pytest

from agents.star_learner import DEFAULT_MODEL, StarLearner
from ios_uav_env.benchmark import evaluate, load_suite
from tests.tolerances import RATE_REL

#: Its mean slot values (bps/Hz) on star-v1's first scenarios (M = 16, continuous phases: TDMA,
#: ES-NOMA, MS-NOMA), printed by ``python -m ios_uav_env.benchmark evaluate --suite star-v1
#: --policy agents.star_learner:StarLearner --n 3 --out DIR`` (DIR/results.json).
RECORD = (0.017074348022030696, 0.008292976759470093, 0.004067140828871538)


def test_the_shipped_learner_is_small_and_says_how_it_was_trained():
    config = json.loads((DEFAULT_MODEL / "config.json").read_text(encoding="utf-8"))
    assert config["command"].startswith("python -m agents.star_training --out agents/models/star_learner")
    assert config["settings"] == 27 and config["seconds"] > 0
    assert (DEFAULT_MODEL / "weights.npz").stat().st_size < 100_000
    assert sorted(p.name for p in DEFAULT_MODEL.iterdir()) == ["config.json", "weights.npz"]


def test_the_shipped_learner_replays_its_record():
    """Its actions are float64 numpy products of float32 observations: on another CPU's BLAS they
    differ by a few ulps, which RATE_REL covers (tests/tolerances.py)."""
    results = evaluate(StarLearner(), "star-v1", n=len(RECORD))
    assert [r.rate for r in results.scenarios] == pytest.approx(RECORD, rel=RATE_REL)


def test_the_shipped_learner_beats_its_zero_residual_on_the_suite():
    """Over star-v1 its mean % of the optimum is above ChannelPhases' (the suite's stored
    ``phases`` rollouts), its zero residual."""
    suite = load_suite("star-v1")
    mine = evaluate(StarLearner(), suite).aggregate
    phases = [100 * s.value("phases") / s.value("optimum") for s in suite.scenarios]
    assert mine.feasible == len(suite.scenarios)
    assert mine.mean_pct_optimum > sum(phases) / len(phases)
