"""The energy-efficiency figures: ``python -m experiments energy [--quick] [--jobs N] [--out DIR]``.

Two parts, one ground node, every plotted value scored by ``ios_uav_env.score_plan``
(``baselines.plan.Plan``) on the scenario with ``objective="energy_efficiency"``:

* **EE vs T** for the three surfaces of the paper's schemes (IOS: IA, RIS: RA, no surface:
  CUC) at each T of :attr:`EnergySpec.Ts`: DP-EE (``baselines.dp_energy.solve_ee``), SCA-EE
  (``baselines.sca_energy.solve``, when :attr:`EnergySpec.sca`), the loiter and hover
  heuristics (``baselines.loiter``) and the rate DP's plan (``baselines.dp.solve`` on the rate
  objective, scored for EE), with the certified EE bound (``baselines.energy_bound.solve``,
  with the best plan as its reference when :attr:`EnergySpec.bound_reference`). The bound is
  above every plan of its point.
* **rate-energy trade-off** on the IOS at :attr:`EnergySpec.trade_T`: the budget DP
  (``dp_energy.solve_budget``) at budgets E_least + f (E_rate - E_least), f in
  :attr:`EnergySpec.fractions`, E_least the scenario's least energy
  (``ScenarioConfig.least_energy``, which the grid paths do not reach: f starts above 0) and
  E_rate the rate DP plan's energy (f = 1 gives the rate plan), and at the DP-EE plan's energy
  (a grid path within that budget, so the curve passes through or above the EE-optimal plan,
  which sits where a line through the origin touches it). The budget problem's optimum
  is non-decreasing in the budget; the Lagrangian returns hull vertices of the grid paths'
  (E, bits) points, so its rate is too.

Each point (a surface and T, or a budget) is one cached JSON file (``baselines.runner.run_tasks``:
parallel, written atomically, resumed after an interruption). Outputs in ``OUT``: ``energy.csv``,
``fig_energy_ee_vs_T.png``, ``fig_energy_trajectories.png`` (the EE-optimal plan against the rate
plan at ``trade_T`` on the IOS: the loitering around the peak) and ``fig_energy_tradeoff.png``
(the budget curve with the rate plan and the EE-optimal plan marked).
"""

from __future__ import annotations

import functools
import hashlib
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ios_uav_env import SURFACES, ScenarioConfig
from ios_uav_env.io import atomic_write_text

#: The paper's scheme names of the surfaces (baselines.schemes).
SURFACE_LABELS = {"ios": "IA (IOS)", "ris": "RA (RIS)", "none": "CUC (no surface)"}
PLANNERS = ("dp-ee", "sca-ee", "loiter", "hover", "rate-dp")
CSV_COLUMNS = (
    "part",
    "surface",
    "T",
    "planner",
    "budget_j",
    "energy_efficiency",
    "energy_j",
    "average_rate",
    "upper_bound",
    "feasible",
    "seconds",
)


@dataclass(frozen=True)
class EnergySpec:
    """What the energy sweep solves."""

    Ts: tuple[float, ...] = (60.0, 100.0, 150.0, 200.0)  # s, mission durations of EE vs T
    surfaces: tuple[str, ...] = SURFACES  # "ios", "ris", "none"
    sca: bool = True  # run SCA-EE (cvxpy) at every point
    dp_resolution: float = 2.5  # m, grid of DP-EE, the rate DP and the budget DP
    bound_resolution: float = 5.0  # m, fine cell side of the certified bound
    bound_reference: bool = True  # the bound's multipliers from the best plan (tighter, slower)
    trade_T: float = 150.0  # s, T of the trajectories and the trade-off curve (one of Ts)
    fractions: tuple[float, ...] = (0.1, 0.2, 0.35, 0.5, 0.65, 0.8, 0.9, 1.0)  # of E_rate - E_least
    base: ScenarioConfig = ScenarioConfig(objective="energy_efficiency")

    def __post_init__(self) -> None:
        if not self.Ts or any(not (isinstance(t, (int, float)) and t > 0) for t in self.Ts):
            raise ValueError(f"Ts must be a non-empty tuple of durations > 0 s, got {self.Ts!r}")
        if self.trade_T not in self.Ts:
            raise ValueError(f"trade_T must be one of Ts={self.Ts}, got {self.trade_T!r}")
        if "ios" not in self.surfaces or not set(self.surfaces) <= set(SURFACES):
            raise ValueError(f"surfaces must be a subset of {SURFACES} with 'ios', got {self.surfaces!r}")
        if not self.fractions or any(not (0 < f <= 1) for f in self.fractions):
            raise ValueError(
                f"fractions must be a non-empty tuple of numbers in (0, 1], got {self.fractions!r}"
            )
        if not (self.dp_resolution > 0 and self.bound_resolution > 0):
            raise ValueError("dp_resolution and bound_resolution must be > 0 m")
        if self.base.K != 1 or self.base.objective != "energy_efficiency":
            raise ValueError("base must have one ground node and objective='energy_efficiency'")

    def config(self, surface: str, T: float) -> ScenarioConfig:
        return self.base.replace(T=float(T), surface=surface)

    def points(self) -> list[dict[str, Any]]:
        """Every point: ``{"part": "T", "surface", "T"}`` or ``{"part": "budget", ..., "fraction"}``."""
        pts = [{"part": "T", "surface": s, "T": float(t)} for s in self.surfaces for t in self.Ts]
        pts += [
            {"part": "budget", "surface": "ios", "T": float(self.trade_T), "fraction": f}
            for f in (*map(float, self.fractions), None)
        ]  # None: at the DP-EE plan's energy
        return pts

    def settings(self) -> dict[str, Any]:
        return {
            "sca": self.sca,
            "dp_resolution": self.dp_resolution,
            "bound_resolution": self.bound_resolution,
            "bound_reference": self.bound_reference,
        }

    def key(self, point: dict[str, Any]) -> str:
        config = self.config(point["surface"], point["T"]).to_dict()
        blob = json.dumps([point, config, self.settings()], sort_keys=True)
        tail = (
            ""
            if point["part"] == "T"
            else "_f" + ("ee" if point["fraction"] is None else f"{point['fraction']:g}")
        )
        digest = hashlib.sha1(blob.encode()).hexdigest()[:10]
        return f"{point['part']}_{point['surface']}_T{point['T']:g}{tail}_{digest}"


QUICK = EnergySpec(
    Ts=(40.0, 50.0),
    sca=False,
    dp_resolution=5.0,
    bound_reference=False,
    trade_T=50.0,
    fractions=(0.2, 0.6, 1.0),
    base=ScenarioConfig(objective="energy_efficiency", ios_shape=(10, 6)),
)


def _row(plan: Any) -> dict[str, Any]:
    return {
        "energy_efficiency": plan.energy_efficiency,
        "energy": plan.energy,
        "rate": plan.mean_rate,
        "feasible": bool(plan.feasible),
        "seconds": plan.seconds,
        "trajectory": plan.trajectory.tolist(),
    }


def _rate_plan(spec: EnergySpec, config: ScenarioConfig) -> Any:
    """The rate DP's plan, scored on ``config`` (its EE objective)."""
    from baselines import dp
    from baselines.plan import Plan

    plan = dp.solve(config.replace(objective="rate"), resolution=spec.dp_resolution)
    return Plan.from_trajectory("rate-dp", config, plan.trajectory, plan.seconds)


def solve_point(point: dict[str, Any], spec: EnergySpec) -> dict[str, Any]:
    """Solve one point and return its record (trajectories included)."""
    import warnings

    from baselines import dp_energy, energy_bound, loiter

    config = spec.config(point["surface"], point["T"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        if point["part"] == "budget":
            rate = _rate_plan(spec, config)
            least = config.least_energy()
            if point["fraction"] is None:
                budget = dp_energy.solve_ee(config, resolution=spec.dp_resolution).energy
            else:
                budget = least + point["fraction"] * (rate.energy - least)
            plan = dp_energy.solve_budget(
                config.replace(objective="rate"), budget, resolution=spec.dp_resolution
            )
            return {
                **point,
                "budget": budget,
                "least_energy": least,
                "rate_energy": rate.energy,
                "dual_bound": plan.info["dual_bound"],
                **_row(plan),
            }
        plans = {"dp-ee": dp_energy.solve_ee(config, resolution=spec.dp_resolution)}
        if spec.sca:
            from baselines import sca_energy

            plans["sca-ee"] = sca_energy.solve(config)
        plans["loiter"], plans["hover"] = loiter.loiter(config), loiter.hover(config)
        plans["rate-dp"] = _rate_plan(spec, config)
        best = max(plans.values(), key=lambda p: p.energy_efficiency)
        bound = energy_bound.solve(
            config, resolution=spec.bound_resolution, reference=best if spec.bound_reference else None
        )
    return {
        **point,
        "upper_bound": bound.upper_bound,
        "bound_seconds": bound.seconds,
        "plans": {name: _row(p) for name, p in plans.items()},
    }


def run(
    spec: EnergySpec,
    cache_dir: Path,
    jobs: int | None = 1,
    *,
    backend: str = "local",
    address: str | None = None,
    progress: bool = False,
) -> list[dict[str, Any]]:
    """Solve every point missing from ``cache_dir`` and return all records in point order
    (``baselines.runner.run_tasks``: ``jobs`` processes, this one for ``jobs=1``; or Ray tasks)."""
    from baselines.runner import run_tasks

    return run_tasks(
        functools.partial(solve_point, spec=spec),
        spec.points(),
        cache_dir,
        key=spec.key,
        jobs=jobs,
        backend=backend,
        address=address,
        progress=progress,
        desc="energy",
        unit="solve",
        order=lambda p: (p["part"] != "T", -p["T"]),
    )


def rows(records: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """The CSV's rows: one per planner of each T point, one per budget."""
    out = []
    for r in records:
        if r["part"] == "T":
            for name, p in r["plans"].items():
                out.append(
                    {
                        "part": "T",
                        "surface": r["surface"],
                        "T": r["T"],
                        "planner": name,
                        "budget_j": None,
                        **p,
                        "upper_bound": r["upper_bound"],
                    }
                )
        else:
            out.append(
                {
                    "part": "budget",
                    "surface": r["surface"],
                    "T": r["T"],
                    "planner": "dp-budget",
                    "budget_j": r["budget"],
                    **r,
                    "upper_bound": None,
                }
            )
    return out


def write_csv(records: Sequence[dict[str, Any]], path: Path) -> Path:
    lines = [",".join(CSV_COLUMNS)]
    for r in rows(records):
        budget = "" if r["budget_j"] is None else f"{r['budget_j']:.6f}"
        ub = "" if r["upper_bound"] is None else f"{r['upper_bound']:.6f}"
        lines.append(
            f"{r['part']},{r['surface']},{r['T']:g},{r['planner']},{budget},{r['energy_efficiency']:.6f},"
            f"{r['energy']:.6f},{r['rate']:.8f},{ub},{int(r['feasible'])},{r['seconds']:.3f}"
        )
    return atomic_write_text(path, "\n".join(lines) + "\n")


def make_figures(records: Sequence[dict[str, Any]], spec: EnergySpec, out: Path) -> list[Path]:
    """EE vs T (one panel per surface), the trajectories at ``trade_T`` on the IOS and the
    trade-off curve."""
    from matplotlib.figure import Figure

    from ios_uav_env.io import save_figure
    from ios_uav_env.plotting import plot_rate_map, plot_trajectories

    paths = []
    part = [r for r in records if r["part"] == "T"]
    fig = Figure(figsize=(4.0 * len(spec.surfaces), 3.8), layout="constrained")
    axes = fig.subplots(1, len(spec.surfaces), squeeze=False)[0]
    for ax, surface in zip(axes, spec.surfaces, strict=True):
        pts = sorted((r for r in part if r["surface"] == surface), key=lambda r: r["T"])
        ts = [r["T"] for r in pts]
        for name in PLANNERS:
            if pts and name in pts[0]["plans"]:
                ax.plot(
                    ts,
                    [r["plans"][name]["energy_efficiency"] / 1e3 for r in pts],
                    marker="o",
                    ms=3,
                    label=name,
                )
        ax.plot(ts, [r["upper_bound"] / 1e3 for r in pts], "k--", label="certified bound")
        ax.set(xlabel="T (s)", ylabel="EE (kbit/J)", title=SURFACE_LABELS[surface])
    axes[0].legend(fontsize=7)
    paths.append(save_figure(fig, out / "fig_energy_ee_vs_T.png", dpi=100))

    surface = "ios"
    (point,) = [r for r in part if r["surface"] == surface and r["T"] == spec.trade_T]
    ee_name = max(("dp-ee", "sca-ee"), key=lambda n: point["plans"].get(n, {}).get("energy_efficiency", -1.0))
    config = spec.config(surface, spec.trade_T)
    fig = Figure(figsize=(9, 4.2), layout="constrained")
    ax = fig.add_subplot()
    plot_rate_map(ax, config, resolution=(200, 80))
    shown = {
        f"{name}: EE {point['plans'][name]['energy_efficiency']:.0f} bits/J": point["plans"][name][
            "trajectory"
        ]
        for name in (ee_name, "rate-dp")
    }
    plot_trajectories(ax, config, shown, colors=dict(zip(shown, ("#ff5a36", "#ffffff"), strict=True)))
    ax.set_title(f"EE-optimal plan vs the rate plan, T = {spec.trade_T:g} s ({SURFACE_LABELS[surface]})")
    paths.append(save_figure(fig, out / "fig_energy_trajectories.png", dpi=100))

    curve = sorted((r for r in records if r["part"] == "budget"), key=lambda r: r["budget"])
    fig = Figure(figsize=(6, 4), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(
        [r["budget"] / 1e3 for r in curve],
        [r["rate"] for r in curve],
        "o-",
        drawstyle="steps-post",
        label="budget DP: best rate at E <= E_max",
    )
    for name, marker in (("rate-dp", "s"), (ee_name, "*")):
        p = point["plans"][name]
        ax.plot(p["energy"] / 1e3, p["rate"], marker, ms=10, label=f"{name} (E, rate)")
    if curve:
        ax.axvline(curve[0]["least_energy"] / 1e3, color="grey", ls=":", label="least energy")
    ax.set(
        xlabel="energy budget E_max (kJ)",
        ylabel="average rate (bps/Hz)",
        title=f"rate-energy trade-off, IOS, T = {spec.trade_T:g} s",
    )
    ax.legend(fontsize=7)
    paths.append(save_figure(fig, out / "fig_energy_tradeoff.png", dpi=100))
    return paths


def summary(records: Sequence[dict[str, Any]]) -> str:
    """Plain-text checks: bound >= every plan, EE-optimal >= the rate plan, the curve monotone."""
    part = [r for r in records if r["part"] == "T"]
    above = all(r["upper_bound"] >= max(p["energy_efficiency"] for p in r["plans"].values()) for r in part)
    better = all(
        r["plans"]["dp-ee"]["energy_efficiency"] >= r["plans"]["rate-dp"]["energy_efficiency"] for r in part
    )
    curve = [
        r["rate"] for r in sorted((r for r in records if r["part"] == "budget"), key=lambda r: r["budget"])
    ]
    monotone = all(b >= a for a, b in zip(curve, curve[1:], strict=False))
    return (
        f"bound >= every plan: {'yes' if above else 'NO'}; DP-EE >= the rate plan's EE: "
        f"{'yes' if better else 'NO'}; trade-off rate non-decreasing in the budget: "
        f"{'yes' if monotone else 'NO'}"
    )
