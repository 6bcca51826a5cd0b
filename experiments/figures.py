"""The paper's figures from the sweep's records, and the check of its qualitative claims.

Fig. 1 (a) trajectories of IA, RA, IA-FT and CUC at T = 150 s, M = 6000 (with the DP
optimum and any RL agents whose scenario applies); (b) average rate versus T per scheme.
Fig. 2 (a) IA trajectories for several M at T = 150 s; (b) IA average rate versus T per M.
Every panel also draws the DP optimum (dashed) beside the paper's SCA curves.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env import ScenarioConfig, average_rate
from ios_uav_env.io import atomic_write_text, save_figure

LABELS = {
    "ia": "IA (IOS, SCA)",
    "ra": "RA (RIS, SCA)",
    "ia-ft": "IA-FT (fixed)",
    "cuc": "CUC (no surface)",
    "dp-ia": "DP optimum, IOS",
    "dp-ra": "DP optimum, RIS",
    "dp-cuc": "DP optimum, none",
}
COLORS = {
    "ia": "#d62728",
    "ra": "#1f77b4",
    "ia-ft": "#ff7f0e",
    "cuc": "#2ca02c",
    "dp-ia": "#d62728",
    "dp-ra": "#1f77b4",
    "dp-cuc": "#2ca02c",
}
HOVER_FRACTION = 0.2  # a slot "hovers" when its move is below this fraction of D


def _select(records: Sequence[dict[str, Any]], **match: Any) -> list[dict[str, Any]]:
    return [r for r in records if all(r[k] == v for k, v in match.items())]


def _curve(records: Sequence[dict[str, Any]], scheme: str, M: int) -> tuple[np.ndarray, np.ndarray]:
    rows = sorted(_select(records, scheme=scheme, M=M), key=lambda r: r["T"])
    return np.array([r["T"] for r in rows]), np.array([r["average_rate"] for r in rows])


def _figure(ncols: int = 1, size: tuple[float, float] = (7.0, 4.2)) -> Any:
    from matplotlib.figure import Figure  # lazy: matplotlib is the [render] extra

    return Figure(figsize=size, layout="constrained")


def trajectory_panel(
    path: Path,
    config: ScenarioConfig,
    trajectories: Mapping[str, np.ndarray],
    title: str,
    colors: Mapping[str, str] | None = None,
    dashed: Sequence[str] = (),
) -> Path:
    """Trajectories over the rate map of ``config``, y stretched (the paths run along x), with
    each trajectory's hover points (moves < HOVER_FRACTION x D) as large dots."""
    from ios_uav_env.envs.rendering import default_extent, plot_rate_map

    x0, x1, _, _ = default_extent(config)
    ys = np.concatenate([np.asarray(q)[:, 1] for q in trajectories.values()] + [[config.ground_node[1]]])
    pad = max(30.0, 0.3 * float(np.ptp(ys)))
    extent = (x0, x1, float(ys.min()) - pad, float(ys.max()) + pad)
    fig = _figure(size=(9.0, 4.6))
    ax = fig.add_subplot()
    plot_rate_map(ax, config, extent=extent, resolution=(300, 120))
    ax.set_aspect("auto")
    for label, q in trajectories.items():
        q = np.asarray(q)
        color = (colors or {}).get(label)
        style = "--" if label in dashed else "-"
        (line,) = ax.plot(q[:, 0], q[:, 1], style, color=color, lw=1.6, marker=".", ms=3, label=label)
        hover = hover_slots(config, q)
        if hover.any():
            ax.plot(q[hover, 0], q[hover, 1], "o", ms=9, mfc=line.get_color(), mec="k", alpha=0.8, zorder=5)
    ax.legend(loc="lower right", fontsize=8, framealpha=0.8)
    ax.set_title(title + " (dots: hover slots; y stretched)")
    return save_figure(fig, path, dpi=110)


def rate_panel(
    path: Path, curves: Mapping[str, tuple[np.ndarray, np.ndarray, dict[str, Any]]], title: str
) -> Path:
    """Average rate versus T: one line per label, ``(T, rate, plot kwargs)``."""
    fig = _figure()
    ax = fig.add_subplot()
    for label, (ts, rates, kw) in curves.items():
        ax.plot(ts, rates, label=label, **kw)
    ax.set_xlabel("T (s)")
    ax.set_ylabel("average rate (bps/Hz)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title)
    return save_figure(fig, path, dpi=110)


def make_figures(
    records: Sequence[dict[str, Any]], spec: Any, out: Path, agents: Mapping[str, np.ndarray] | None = None
) -> list[Path]:
    """Write the four panels (and a % of DP panel) under ``out``; return their paths."""
    t_traj = 150.0 if 150.0 in spec.Ts else max(spec.Ts)
    m0 = spec.M_schemes
    cfg = spec.base.replace(T=t_traj, ios_shape=(spec.base.ios_shape[0], m0 // spec.base.ios_shape[0]))
    paths = []
    traj = {
        LABELS[s]: np.array(_select(records, scheme=s, T=t_traj, M=m0)[0]["trajectory"])
        for s in ("ia", "ra", "ia-ft", "cuc", "dp-ia")
    }
    colors = {LABELS[s]: COLORS[s] for s in ("ia", "ra", "ia-ft", "cuc")} | {LABELS["dp-ia"]: "white"}
    agent_colors = ["#9467bd", "#e377c2", "#7f7f7f", "#17becf", "#bcbd22"]
    for i, (name, q) in enumerate((agents or {}).items()):
        traj[name] = q
        colors[name] = agent_colors[i % len(agent_colors)]
    paths.append(
        trajectory_panel(
            out / "fig1a_trajectories.png",
            cfg,
            traj,
            f"Fig. 1(a): trajectories, T = {t_traj:g} s, M = {m0}",
            colors,
            dashed=[LABELS["dp-ia"]],
        )
    )
    curves = {}
    for s in ("ia", "ra", "ia-ft", "cuc"):
        curves[LABELS[s]] = (*_curve(records, s, m0), {"color": COLORS[s], "marker": "o", "ms": 4})
    for s in ("dp-ia", "dp-ra", "dp-cuc"):
        curves[LABELS[s]] = (*_curve(records, s, m0), {"color": COLORS[s], "ls": "--", "lw": 1})
    for name, q in (agents or {}).items():  # the agents' scenario only: one point each at t_traj
        rate = np.array([average_rate(cfg, q)])
        curves[name] = (
            np.array([t_traj]),
            rate,
            {"marker": "*", "ms": 11, "ls": "none", "color": colors[name]},
        )
    paths.append(rate_panel(out / "fig1b_rate_vs_T.png", curves, f"Fig. 1(b): average rate vs T, M = {m0}"))
    cmap = ["#1b9e77", "#7570b3", "#d62728", "#e7298a", "#66a61e"]
    traj_m = {
        f"IA, M = {M}": np.array(_select(records, scheme="ia", T=t_traj, M=M)[0]["trajectory"])
        for M in spec.Ms
    }
    colors_m = {f"IA, M = {M}": cmap[i % len(cmap)] for i, M in enumerate(spec.Ms)}
    paths.append(
        trajectory_panel(
            out / "fig2a_trajectories_M.png",
            cfg,
            traj_m,
            f"Fig. 2(a): IA trajectories for several M, T = {t_traj:g} s",
            colors_m,
        )
    )
    curves_m = {}
    for i, M in enumerate(spec.Ms):
        c = cmap[i % len(cmap)]
        curves_m[f"IA, M = {M}"] = (*_curve(records, "ia", M), {"color": c, "marker": "o", "ms": 4})
        curves_m[f"DP, M = {M}"] = (*_curve(records, "dp-ia", M), {"color": c, "ls": "--", "lw": 1})
    paths.append(rate_panel(out / "fig2b_rate_vs_T_M.png", curves_m, "Fig. 2(b): IA average rate vs T and M"))
    gap = {}
    for s in ("ia", "ra", "cuc", "ia-ft"):
        rows = sorted(_select(records, scheme=s, M=m0), key=lambda r: r["T"])
        gap[LABELS[s]] = (
            np.array([r["T"] for r in rows]),
            np.array([r["pct_of_dp"] for r in rows]),
            {"color": COLORS[s], "marker": "o", "ms": 4},
        )
    path = rate_panel(out / "fig_pct_of_dp.png", gap, f"% of the DP optimum (2.5 m grid) vs T, M = {m0}")
    paths.append(path)
    return paths


def hover_slots(config: ScenarioConfig, trajectory: np.ndarray) -> np.ndarray:
    """Mask of the slots n >= 2 whose move from q[n-1] is below HOVER_FRACTION x D."""
    q = np.asarray(trajectory)
    return np.r_[False, np.linalg.norm(np.diff(q, axis=0), axis=1) < HOVER_FRACTION * config.D]


def hover_sides(config: ScenarioConfig, trajectory: np.ndarray) -> dict[str, int]:
    """Slots spent hovering (move < HOVER_FRACTION x D) on the reflecting / transmitting side."""
    q = np.asarray(trajectory)
    slow = hover_slots(config, q)
    side = np.sign(q[:, 0] - config.ios_center[0]) == np.sign(config.ground_node[0] - config.ios_center[0])
    return {"reflecting": int(np.sum(slow & side)), "transmitting": int(np.sum(slow & ~side))}


def check_claims(records: Sequence[dict[str, Any]], spec: Any) -> tuple[str, bool]:
    """Markdown verdicts on the paper's qualitative claims, with the numbers; and all-hold."""
    m0, lines, ok_all = spec.M_schemes, [], True

    def verdict(ok: bool, text: str) -> None:
        nonlocal ok_all
        ok_all &= ok
        lines.append(f"- **{'holds' if ok else 'does NOT hold'}**: {text}")

    broken = [f"{r['scheme']} T={r['T']:g} M={r['M']}" for r in records if not np.isfinite(r["average_rate"])]
    if broken:  # a NaN compares false both ways: no claim can hold or fail on it
        lines.append(f"- **cannot be checked**: non-finite average rate for {', '.join(broken)}")
        return "\n".join(lines) + "\n", False
    rate = {(r["scheme"], r["T"], r["M"]): r["average_rate"] for r in records}
    ts = sorted(spec.Ts)
    order = [rate[("ia", t, m0)] > rate[("ra", t, m0)] > rate[("cuc", t, m0)] for t in ts]
    worst = min(rate[("ia", t, m0)] - rate[("ra", t, m0)] for t in ts)
    verdict(
        all(order),
        f"IA > RA > CUC at every T ({sum(order)}/{len(ts)} T values; smallest IA - RA "
        f"margin {worst:.4f} bps/Hz)",
    )
    ft = [rate[("ia-ft", t, m0)] < rate[("ia", t, m0)] for t in ts]
    pct = [100 * rate[("ia-ft", t, m0)] / rate[("ia", t, m0)] for t in ts]
    verdict(all(ft), f"IA-FT below IA at every T (IA-FT at {min(pct):.1f}-{max(pct):.1f}% of IA)")
    for s in ("ia", "ra", "cuc"):
        r = [rate[(s, t, m0)] for t in ts]
        verdict(
            all(np.diff(r) > 0),
            f"{s.upper()} rate grows with T ({r[0]:.4f} at T = {ts[0]:g} s to "
            f"{r[-1]:.4f} at T = {ts[-1]:g} s, M = {m0})",
        )
    ms = sorted(spec.Ms)
    grows_m = [all(np.diff([rate[("ia", t, m)] for m in ms]) > 0) for t in ts]
    t_mid = ts[len(ts) // 2]
    verdict(
        all(grows_m),
        f"IA rate grows with M at every T (at T = {t_mid:g} s: "
        + ", ".join(f"M = {m}: {rate[('ia', t_mid, m)]:.4f}" for m in ms)
        + ")",
    )
    t_traj = 150.0 if 150.0 in ts else ts[-1]
    cfg = spec.base.replace(T=t_traj, ios_shape=(spec.base.ios_shape[0], m0 // spec.base.ios_shape[0]))
    sides = {
        s: hover_sides(cfg, np.array(_select(records, scheme=s, T=t_traj, M=m0)[0]["trajectory"]))
        for s in ("ia", "ra")
    }
    ia_both = sides["ia"]["reflecting"] > 0 and sides["ia"]["transmitting"] > 0
    verdict(
        ia_both,
        f"the IA trajectory hovers on both sides of the IOS (T = {t_traj:g} s: "
        f"{sides['ia']['reflecting']} hover slots on the reflecting side, "
        f"{sides['ia']['transmitting']} on the transmitting side)",
    )
    ra_refl = sides["ra"]["transmitting"] == 0 and sides["ra"]["reflecting"] > 0
    verdict(
        ra_refl,
        f"the RA trajectory hovers only on the reflecting side ({sides['ra']['reflecting']} "
        f"hover slots there, {sides['ra']['transmitting']} on the other side)",
    )
    return "\n".join(lines) + "\n", ok_all


def write_claims(text: str, path: Path) -> Path:
    return atomic_write_text(path, "# The paper's qualitative claims in our model\n\n" + text)
