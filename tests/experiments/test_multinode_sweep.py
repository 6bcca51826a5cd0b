"""The multi-node sweep, tiny: records, cache and resume, CSV, figures and claims."""

import csv

import pytest

pytest.importorskip("cvxpy")
pytest.importorskip("matplotlib")

from experiments import multinode  # noqa: E402
from experiments.__main__ import build_parser  # noqa: E402
from ios_uav_env import ScenarioConfig, maxmin_rate  # noqa: E402

TINY = multinode.MultiSpec(
    Ts=(40.0,), T_schemes=("ia", "tour", "dp-ia"), Ks=(1, 2), seeds=1, K_T=40.0, K_schemes=("tour", "dp-ia"),
    base=ScenarioConfig(ios_shape=(10, 6), quadrature_nodes=4),
)  # fmt: skip


def test_tiny_multinode_sweep_resumes_and_reports(tmp_path, monkeypatch):
    import numpy as np

    records = multinode.run(TINY, tmp_path / "cache")
    assert len(records) == len(TINY.points()) == 3 + 2 * 2
    for r in records:
        config = ScenarioConfig(**r["config"])
        assert r["feasible"] and r["rate"] == pytest.approx(
            maxmin_rate(config, np.array(r["trajectory"])), abs=1e-12
        )
        if r["scheme"] == "dp-ia" and config.K > 1:
            same = [s["rate"] for s in records if (s["part"], s["K"]) == (r["part"], r["K"])]
            assert r["upper_bound"] >= max(same)
    # resume: nothing is solved again
    monkeypatch.setattr(multinode, "solve_point", lambda *a: pytest.fail("re-solved a cached point"))
    assert multinode.run(TINY, tmp_path / "cache") == records
    rows = list(csv.DictReader(multinode.write_csv(records, tmp_path / "m.csv").open()))
    assert len(rows) == 7 and {r["scheme"] for r in rows} == {"ia", "tour", "dp-ia"}
    text = multinode.claims(records)
    assert "IA hovers on both sides of the IOS" in text and "every IOS plan at every point: **yes**" in text
    for path in multinode.make_figures(records, tmp_path):
        assert path.stat().st_size > 5_000


def test_quick_writes_elsewhere_by_default():
    args = build_parser().parse_args(["multinode", "--quick"])
    assert args.out is None and args.quick  # multinode_main then uses out/multinode-quick
