"""One result type for every suite: the kind's metrics name the columns, scores and summary."""

import numpy as np
import pytest

from ios_uav_env.benchmark import METRICS, load_suite, reference_results, score_trajectories
from ios_uav_env.benchmark.results import metrics_of


def test_the_columns_of_each_kind_are_the_documented_csv_columns():
    # the CSV/JSON columns are a contract (scripts read them by name)
    assert METRICS["single-node"].columns() == (
        "index", "rate", "feasible", "worst_violation", "pct_dp", "pct_sca", "seconds"
    )  # fmt: skip
    assert METRICS["multi-node"].columns() == (
        "index", "K", "rate", "best_schedule_rate", "feasible", "worst_violation", "pct_sca", "pct_bound",
        "best_pct_sca", "seconds", "own_shares",
    )  # fmt: skip


@pytest.mark.parametrize("name, normaliser", [("single-node-v1", "dp"), ("multi-node-v1", "sca")])
def test_a_reference_scored_as_a_policy_is_100_percent_of_itself(name, normaliser):
    suite = load_suite(name)
    assert metrics_of(suite).normaliser == normaliser == suite.normalizer
    results = reference_results(suite, normaliser, n=4)
    for r in results:
        assert (
            r.pct[normaliser] == pytest.approx(100.0) and getattr(r, f"pct_{normaliser}") == r.pct[normaliser]
        )
        assert set(r.to_dict()) == set(results.metrics.columns())
    assert results.aggregate.stats[f"mean_pct_{normaliser}"] == pytest.approx(100.0)
    assert results.aggregate.n == 4 and results.aggregate.sca_median_seconds > 0


def test_an_infeasible_plan_scores_zero_whatever_its_rate():
    suite = load_suite("single-node-v1")
    s = suite[0]
    q = np.linspace(s.config.q0, s.config.qF, s.config.N)
    q[-1] += 50.0  # misses qF
    row = score_trajectories({0: q}, suite).scenarios[0]
    assert not row.feasible and row.rate > 0 and row.pct_dp == row.pct_sca == 0.0


def test_single_and_multi_summaries_name_their_scores():
    single = reference_results(load_suite("single-node-v1"), "sca", n=2).summary()
    multi = reference_results(load_suite("multi-node-v1"), "tour", n=2).summary()
    assert "% of DP mean" in single and "% of SCA mean" in single and "bound" not in single
    assert "% of SCA mean" in multi and "% of bound mean" in multi and "best schedule % of SCA" in multi
    with pytest.raises(AttributeError, match="pct_bound"):
        _ = reference_results(load_suite("single-node-v1"), "sca", n=1).scenarios[0].pct_bound
