"""Schemes and the command line ``python -m baselines``."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import baselines.__main__ as cli
from baselines import schemes
from ios_uav_env import ScenarioConfig, average_rate

ROOT = Path(__file__).resolve().parents[2]
TINY = ["--T", "40", "--ios-shape", "10", "6", "--resolution", "5"]


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "baselines", *args], cwd=ROOT, capture_output=True, text=True, timeout=120
    )


def test_cli_writes_plans_table_and_figure(tmp_path: Path) -> None:
    out = tmp_path / "plans"
    res = _cli("--scheme", "ia-ft", "dp", *TINY, "--out", str(out))
    assert res.returncode == 0, res.stderr
    rows = [line.split() for line in res.stdout.splitlines() if line.split()[:1] in (["ia-ft"], ["dp"])]
    assert [r[0] for r in rows] == ["ia-ft", "dp"]
    config = ScenarioConfig(T=40, ios_shape=(10, 6))
    for name, row in zip(("ia-ft", "dp"), rows, strict=True):
        saved = json.loads((out / f"{name}_T40_M60.json").read_text())
        q = np.loadtxt(out / f"{name}_T40_M60.csv", delimiter=",", skiprows=1)
        assert q.shape == (40, 2) and np.allclose(q, saved["trajectory"])
        assert saved["scheme"] == name and saved["feasible"] is True
        assert float(row[3]) == pytest.approx(average_rate(config, q), abs=1e-6)
        assert row[4] == "yes"
    png = out / "plans_T40_M60_ia-ft_dp.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(out.glob("*.tmp*"))


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--scheme", "magic"], "argument --scheme: invalid choice: 'magic'"),
        (["--scheme", "dp", "--M", "150"], "argument --M"),
        (["--scheme", "dp", "--M", "0"], "argument --M"),
        (["--scheme", "dp", "--M", "abc"], "argument --M"),
        (["--scheme", "dp", "--T", "40", "--resolution", "30"], "argument --resolution"),
        (["--scheme", "dp", "--T", "10"], "T must be >= 33 s"),
        (["--scheme", "dp", "--star-access", "noma"], "argument --star-access: noma needs --surface star"),
    ],
)
def test_cli_bad_arguments(args: list[str], needle: str) -> None:
    res = _cli(*args, "--no-plot")
    assert res.returncode == 2
    assert needle in res.stderr


def test_cli_plans_a_noma_star_scenario_and_the_tdma_planners_name_dp_star(tmp_path: Path, capsys) -> None:
    args = ["--nodes=-5,2;5,-2", "--T", "16", "--q0", "-150", "-100", "--qF", "-150", "100", "--ios-shape",
            "4", "4", "--resolution", "12.5", "--surface", "star", "--star-access", "noma"]  # fmt: skip
    status = cli.main(["--scheme", "dp-star", "dp-sta", "ia-ft", *args, "--out", str(tmp_path)])
    assert status == 1  # dp-sta (the TDMA DP) refuses the NOMA scenario
    captured = capsys.readouterr()
    assert "dp-sta: failed" in captured.err and "use dp-star (baselines.dp_star:solve)" in captured.err
    assert "dp-star: certified upper bound" in captured.out
    saved = json.loads((tmp_path / "dp-star_T16_M16.json").read_text())
    assert saved["feasible"] and saved["mean_rate"] <= saved["info"]["upper_bound"]
    assert saved["config"]["star_access"] == "noma"
    assert (tmp_path / "plans_T16_M16_dp-star_ia-ft.png").exists()


def test_cli_m_sets_the_ios_shape(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    status = cli.main(["--scheme", "ia-ft", "--T", "40", "--M", "2000", "--out", str(tmp_path), "--no-plot"])
    assert status == 0
    saved = json.loads((tmp_path / "ia-ft_T40_M2000.json").read_text())
    assert saved["config"]["ios_shape"] == [100, 20]
    assert "2000" in capsys.readouterr().out


def test_cli_reports_missing_sca(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    monkeypatch.setitem(sys.modules, "baselines.sca", None)  # import fails as if the file were absent
    status = cli.main(["--scheme", "ia", "ia-ft", *TINY, "--out", str(tmp_path), "--no-plot"])
    assert status == 1
    captured = capsys.readouterr()
    assert "ia: skipped" in captured.err and "baselines.sca" in captured.err
    assert (tmp_path / "ia-ft_T40_M60.json").exists() and not (tmp_path / "ia_T40_M60.json").exists()


def test_run_scheme_sets_the_surface() -> None:
    config = ScenarioConfig(T=40, ios_shape=(10, 6), surface="ris")
    assert schemes.run_scheme("ia-ft", config).config.surface == "ios"
    assert schemes.run_scheme("dp", config, resolution=5.0).config.surface == "ris"
    for name, surface in (("dp-ia", "ios"), ("dp-ra", "ris"), ("dp-cuc", "none"), ("dp-sta", "star")):
        plan = schemes.run_scheme(name, config, resolution=5.0)
        assert plan.scheme == name and plan.config.surface == surface and plan.feasible
    for name, surface in (("ia", "ios"), ("ra", "ris"), ("cuc", "none")):
        assert schemes.scheme_config(name, config).surface == surface
    star = schemes.scheme_config("dp-star", config)  # a STAR surface serving both sides at once
    assert (star.surface, star.star_access) == ("star", "noma")
    assert schemes.scheme_config("dp-sta", config).star_access == "tdma"


def test_unknown_scheme_lists_the_valid_ones() -> None:
    with pytest.raises(ValueError, match="unknown scheme 'sac'.*ia, ra, ia-ft, cuc, dp"):
        schemes.run_scheme("sac", ScenarioConfig(ios_shape=(10, 6)))


def test_sca_schemes_need_baselines_sca(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "baselines.sca", None)
    assert not schemes.available("ia") and schemes.available("dp") and schemes.available("ia-ft")
    with pytest.raises(ImportError, match="baselines.sca"):
        schemes.run_scheme("cuc", ScenarioConfig(T=40, ios_shape=(10, 6)))


_NO_SCA = schemes.sca_unavailable_reason()


@pytest.mark.skipif(_NO_SCA is not None, reason=f"SCA schemes unavailable: {_NO_SCA}")
def test_sca_scheme_runs_through_run_scheme() -> None:
    config = ScenarioConfig(T=60, ios_shape=(10, 6))
    plan = schemes.run_scheme("cuc", config, max_iters=2)
    assert plan.scheme == "cuc" and plan.config.surface == "none" and plan.feasible
    assert plan.mean_rate == average_rate(plan.config, plan.trajectory)


def test_cli_several_nodes_prints_the_bound_and_draws_every_node(tmp_path: Path) -> None:
    out = tmp_path / "multi"
    res = _cli("--nodes=-100,-20;150,-60", "--scheme", "tour", "ia-ft", "dp", *TINY, "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert "dp: certified upper bound" in res.stdout
    saved = json.loads((out / "tour_T40_M60.json").read_text())
    config = ScenarioConfig(**saved["config"])
    assert config.K == 2 and saved["feasible"] is True
    from ios_uav_env import maxmin_rate

    assert saved["mean_rate"] == pytest.approx(maxmin_rate(config, np.array(saved["trajectory"])), abs=1e-12)
    assert (out / "plans_T40_M60_tour_ia-ft_dp.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("text", ["", "1,2;3", "a,b", "1,2;nan,3"])
def test_cli_bad_nodes(text: str) -> None:
    res = _cli(f"--nodes={text}", "--no-plot")
    assert res.returncode == 2 and "argument --nodes" in res.stderr
