"""A tiny version of the figure sweep, end to end: CSV, figures, claims, cache and resume."""

import csv
import json

import numpy as np
import pytest

pytest.importorskip("cvxpy")
pytest.importorskip("matplotlib")

from experiments.__main__ import QUICK, main  # noqa: E402
from experiments.figures import hover_sides  # noqa: E402
from experiments.sweep import Point, run_sweep, with_pct_of_dp  # noqa: E402
from ios_uav_env import ScenarioConfig  # noqa: E402


def test_quick_sweep_end_to_end_and_resume(tmp_path, capsys):
    assert (
        main(["figures", "--quick", "--out", str(tmp_path), "--jobs", "2", "--no-progress", "--no-agents"])
        == 0
    )
    rows = list(csv.DictReader((tmp_path / "sweep.csv").open()))
    assert len(rows) == len(QUICK.points()) == 18
    assert {r["scheme"] for r in rows} == {"ia", "ra", "ia-ft", "cuc", "dp-ia", "dp-ra", "dp-cuc"}
    assert {float(r["T"]) for r in rows} == {40.0, 60.0} and {int(r["M"]) for r in rows} == {200, 400}
    assert all(r["feasible"] == "1" for r in rows)
    for r in rows:
        if r["scheme"].startswith("dp"):
            assert float(r["pct_of_dp"]) == pytest.approx(100.0)
        elif r["scheme"] in ("ia", "ra", "cuc"):  # SCA is off-grid: at least the 5 m grid's optimum, nearly
            assert float(r["pct_of_dp"]) > 99.0
    for name in ("fig1a_trajectories", "fig1b_rate_vs_T", "fig2a_trajectories_M", "fig2b_rate_vs_T_M"):
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000
    claims = (tmp_path / "claims.md").read_text()
    assert "IA > RA > CUC" in claims and "IA-FT below IA" in claims
    cached = sorted((tmp_path / "cache").glob("*.json"))
    assert len(cached) == 18
    # resume: a second run solves nothing (every point comes from the cache) and gives the same CSV
    before = (tmp_path / "sweep.csv").read_text()
    records = run_sweep(QUICK, tmp_path / "cache", jobs=1, progress=False)
    assert [json.loads(p.read_text())["average_rate"] for p in cached]  # readable cache files
    assert main(["figures", "--quick", "--out", str(tmp_path), "--no-progress", "--no-agents"]) == 0
    assert (tmp_path / "sweep.csv").read_text() == before
    assert len(records) == 18


def test_interrupted_sweep_resumes_only_missing_points(tmp_path):
    some = [Point("dp-cuc", 40.0, 200), Point("ia-ft", 40.0, 200)]
    run_sweep(QUICK, tmp_path, jobs=1, progress=False, points=some[:1])
    assert len(list(tmp_path.glob("*.json"))) == 1
    (stamp,) = tmp_path.glob("*.json")
    mtime = stamp.stat().st_mtime_ns
    out = run_sweep(QUICK, tmp_path, jobs=1, progress=False, points=some)
    assert stamp.stat().st_mtime_ns == mtime  # not solved again
    assert len(out) == 2 and len(list(tmp_path.glob("*.json"))) == 2


def test_pct_of_dp_uses_the_dp_of_the_same_surface():
    recs = [{"scheme": "ia", "T": 40.0, "M": 200, "average_rate": 1.0},
            {"scheme": "ia-ft", "T": 40.0, "M": 200, "average_rate": 0.5},
            {"scheme": "dp-ia", "T": 40.0, "M": 200, "average_rate": 2.0}]  # fmt: skip
    pct = {r["scheme"]: r["pct_of_dp"] for r in with_pct_of_dp(recs)}
    assert pct == {"ia": 50.0, "ia-ft": 25.0, "dp-ia": 100.0}


def test_hover_sides_counts_slow_slots_per_side():
    cfg = ScenarioConfig(T=40.0, ios_shape=(10, 6))
    q = np.linspace(cfg.q0, cfg.qF, cfg.N)
    q[5:9] = (-50.0, 0.0)  # 3 hover slots on G's (reflecting) side
    q[20:26] = (60.0, 0.0)  # 5 on the other side
    assert hover_sides(cfg, q) == {"reflecting": 3, "transmitting": 5}
