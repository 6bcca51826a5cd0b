"""Freeze a suite file from a planner run: scenarios, DP and SCA values, and the heuristics' rates.

The single-node suite is frozen from the repository's held-out suite file
(``agents/suite/heldout.json``, written by ``python -m agents.suite build``: each scenario's
config, DP optimum and SCA plan); this module reads that JSON (no planner is imported), drops
the trajectories, adds the rates of ``HoverAt("peak")`` and ``HoverAt("ground")`` rolled out in
the suite's env, and writes ``ios_uav_env/benchmark/suites/<name>.json``:

    python -m ios_uav_env.benchmark.freeze agents/suite/heldout.json --name single-node-v1

It prints the content hash to register in ``ios_uav_env.benchmark.suite.SUITES``. It refuses to
overwrite a suite file with different content (a suite never changes under its name).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ios_uav_env.benchmark.suite import FORMAT, REFERENCES, SUITE_DIR, content_hash, suite_text
from ios_uav_env.envs.registration import RANDOM_ENV_ID
from ios_uav_env.io import atomic_write_text
from ios_uav_env.model.config import ScenarioConfig

HEURISTICS = {"hover_peak": "peak", "hover_ground": "ground"}


def heuristic_reference(config: ScenarioConfig, target: str, env_id: str = RANDOM_ENV_ID) -> dict[str, Any]:
    """Rate and feasibility of ``HoverAt(target)`` on ``config`` (its env arguments, reset seed 0)."""
    import gymnasium as gym

    from ios_uav_env.envs.policies import HoverAt
    from ios_uav_env.envs.rollout import run_episode

    policy = HoverAt(target)
    env = gym.make(env_id, **policy.env_kwargs)
    try:
        episode = run_episode(env, policy, seed=0, options={"config": config})
    finally:
        env.close()
    return {"rate": episode.average_rate, "feasible": bool(episode.feasible)}


def single_node_content(heldout: Mapping[str, Any], name: str, version: int) -> dict[str, Any]:
    """The content of a single-node suite from a held-out suite file's parsed JSON."""
    scenarios = []
    for rec in heldout["scenarios"]:
        config = ScenarioConfig(**rec["config"])
        entry: dict[str, Any] = {
            "index": int(rec["index"]),
            "config": config.to_dict(),
            "dp": {"rate": float(rec["dp"]["rate"]), "resolution": float(rec["dp"]["resolution"])},
            "sca": {
                "rate": float(rec["sca"]["rate"]),
                "feasible": bool(rec["sca"]["feasible"]),
                "seconds": round(float(rec["sca"]["seconds"]), 3),
            },
        }
        for key, target in HEURISTICS.items():
            entry[key] = heuristic_reference(config, target)
        scenarios.append(entry)
    return {
        "format": FORMAT,
        "name": name,
        "version": int(version),
        "env_id": RANDOM_ENV_ID,
        "env_kwargs": {},
        "normalizer": "dp",
        "references": list(REFERENCES),
        "description": (
            f"{len(scenarios)} held-out scenarios of {RANDOM_ENV_ID} (sample_scenario(default_rng("
            f"{heldout['seed']}), ranges) drawn in turn; never a training seed). Per scenario: its "
            "ScenarioConfig; dp: the DP optimum's rate on a resolution-m grid (baselines.dp.solve); sca: "
            "the SCA plan's rate, feasibility and wall time in seconds (baselines.sca.solve, defaults, "
            "one of two worker processes on a 2-core machine); hover_peak / hover_ground: the rate and "
            "feasibility of ios_uav_env.envs.policies.HoverAt('peak') (env with peak_hint=True) / "
            "HoverAt('ground') in the env, reset with seed 0. Rates: eq. (9), bps/Hz."
        ),
        "source": {
            "seed": int(heldout["seed"]),
            "ranges": heldout["ranges"],
            "file": "agents/suite/heldout.json",
            "built": heldout.get("build", {}).get("created"),
        },
        "scenarios": scenarios,
    }


def freeze(content: Mapping[str, Any], directory: str | Path = SUITE_DIR) -> tuple[Path, str]:
    """Write ``content`` to ``<directory>/<name>.json`` (atomically); its path and hash.

    ``ValueError`` if a file of that name exists with different content.
    """
    path = Path(directory) / f"{content['name']}.json"
    digest = content_hash(content)
    if path.exists() and content_hash(json.loads(path.read_text(encoding="utf-8"))) != digest:
        raise ValueError(f"{path} exists with different content: a changed suite needs a new name")
    atomic_write_text(path, suite_text(content))
    return path, digest


def main(argv: Sequence[str] | None = None) -> int:
    prog = "python -m ios_uav_env.benchmark.freeze"
    p = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    p.add_argument("heldout", type=Path, help="a held-out suite file (agents/suite/heldout.json)")
    p.add_argument("--name", default="single-node-v1")
    p.add_argument("--version", type=int, default=1)
    p.add_argument("--dir", type=Path, default=SUITE_DIR)
    args = p.parse_args(argv)
    content = single_node_content(json.loads(args.heldout.read_text()), args.name, args.version)
    path, digest = freeze(content, args.dir)
    print(f"{path} ({path.stat().st_size / 1024:.0f} KB), sha256 {digest}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
