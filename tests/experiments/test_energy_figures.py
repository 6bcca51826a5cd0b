"""The energy figures, tiny: the command's CSV and PNGs, every number the scorer's, the bound
above every plan, the EE optimum above the rate plan, the trade-off monotone, results/ kept."""

import csv

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from experiments import energy  # noqa: E402
from experiments.__main__ import RESULTS_DIR, build_parser, main  # noqa: E402
from ios_uav_env import ScenarioConfig, score_plan  # noqa: E402

TINY = energy.EnergySpec(
    Ts=(40.0,), surfaces=("ios", "none"), sca=False, dp_resolution=5.0, bound_resolution=10.0,
    bound_reference=False,
    trade_T=40.0, fractions=(0.3, 1.0),
    base=ScenarioConfig(objective="energy_efficiency", ios_shape=(10, 6), quadrature_nodes=4),
)  # fmt: skip


def test_energy_command_writes_scored_csv_and_figures(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(energy, "QUICK", TINY)
    assert main(["energy", "--quick", "--out", str(tmp_path), "--no-progress"]) == 0
    for name in ("fig_energy_ee_vs_T", "fig_energy_trajectories", "fig_energy_tradeoff"):
        assert (tmp_path / f"{name}.png").stat().st_size > 5_000
    rows = list(csv.DictReader((tmp_path / "energy.csv").open()))
    assert len(rows) == 2 * 4 + 3 and all(r["feasible"] == "1" for r in rows)
    # every number is the scorer's: the cached records' trajectories scored again
    monkeypatch.setattr(energy, "solve_point", lambda *a: pytest.fail("re-solved a cached point"))
    records = energy.rows(energy.run(TINY, tmp_path / "cache"))
    assert len(records) == len(rows)
    for row, rec in zip(rows, records, strict=True):
        config = TINY.config(row["surface"], float(row["T"]))
        score = score_plan(config, np.array(rec["trajectory"]))
        assert float(row["energy_efficiency"]) == pytest.approx(score.energy_efficiency, rel=1e-8)
        assert float(row["energy_j"]) == pytest.approx(score.energy, rel=1e-8)
        assert float(row["average_rate"]) == pytest.approx(score.rate, rel=1e-7)
    part = [r for r in rows if r["part"] == "T"]
    for surface in TINY.surfaces:
        point = {r["planner"]: r for r in part if r["surface"] == surface}
        assert set(point) == {"dp-ee", "loiter", "hover", "rate-dp"}
        ees = [float(r["energy_efficiency"]) for r in point.values()]
        assert all(float(r["upper_bound"]) >= max(ees) for r in point.values())
        assert float(point["dp-ee"]["energy_efficiency"]) >= float(point["rate-dp"]["energy_efficiency"])
    curve = sorted((r for r in rows if r["part"] == "budget"), key=lambda r: float(r["budget_j"]))
    rates = [float(r["average_rate"]) for r in curve]
    assert rates == sorted(rates) and rates[0] < rates[-1]
    assert all(float(r["energy_j"]) <= float(r["budget_j"]) * (1 + 1e-9) for r in curve)
    ios = {r["planner"]: r for r in part if r["surface"] == "ios"}
    assert float(curve[-1]["average_rate"]) == pytest.approx(float(ios["rate-dp"]["average_rate"]), rel=1e-12)
    assert "NO" not in capsys.readouterr().out


def test_default_run_never_writes_results(monkeypatch, capsys):
    monkeypatch.setattr(energy, "run", lambda *a, **k: pytest.fail("solved into the shipped results"))
    for argv in (["energy"], ["energy", "--out", str(RESULTS_DIR / "energy")]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2 and "pass --overwrite" in capsys.readouterr().err
    args = build_parser().parse_args(["energy", "--quick"])
    assert args.out is None and args.quick and not args.overwrite  # energy_main: out/energy-quick


def test_spec_refuses_bad_fields():
    with pytest.raises(ValueError, match="trade_T"):
        energy.EnergySpec(Ts=(60.0,), trade_T=150.0)
    with pytest.raises(ValueError, match="fractions"):
        energy.EnergySpec(fractions=(0.0, 1.0))
    with pytest.raises(ValueError, match="surfaces"):
        energy.EnergySpec(surfaces=("ris",))
