"""Score a CleanRL-style torch actor on the frozen held-out suite (ios_uav_env.benchmark).

Run:  python examples/benchmark_cleanrl.py [--n 60] [--checkpoint actor.pt] [--out out/benchmark_cleanrl]
The actor is CleanRL's ppo_continuous_action ``actor_mean`` (obs -> tanh MLP -> mean action),
untrained unless ``--checkpoint`` gives its state_dict. The scoring is three lines: wrap the
actor as a function from observations to actions, call ``evaluate``, read the results. The
actor takes a batch, so it runs in the batched env (``batched=True``). The observation is the
suite env's (``ios_uav_env/IOSUAV-Random-v0``, 17 features), as in training on that id.
"""

from __future__ import annotations

import argparse

import numpy as np
import torch
import torch.nn as nn

from ios_uav_env.benchmark import evaluate, load_suite, reference_results


def actor_mean(obs_dim: int = 17, act_dim: int = 2) -> nn.Sequential:
    """CleanRL's deterministic actor head (the Gaussian policy's mean)."""
    torch.manual_seed(0)
    return nn.Sequential(
        nn.Linear(obs_dim, 64), nn.Tanh(), nn.Linear(64, 64), nn.Tanh(), nn.Linear(64, act_dim)
    )  # fmt: skip


def main(argv: list[str] | None = None) -> float:
    """Score the actor; return its mean % of the DP optimum."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=None, help="the first n scenarios (default: all 60)")
    p.add_argument("--checkpoint", default=None, help="a state_dict of the actor (torch.save)")
    p.add_argument("--out", default=None, help="folder for the CSV, JSON, markdown and figure")
    p.add_argument("--overwrite", action="store_true", help="replace the results already in --out")
    args = p.parse_args(argv)

    actor = actor_mean()
    if args.checkpoint:
        actor.load_state_dict(torch.load(args.checkpoint, map_location="cpu"))

    @torch.no_grad()
    def policy(obs: np.ndarray) -> np.ndarray:  # (B, 17) -> (B, 2), clipped to the action space
        return actor(torch.as_tensor(obs, dtype=torch.float32)).clamp(-1.0, 1.0).numpy()

    results = evaluate(policy, "single-node-v1", n=args.n, batched=True, name="CleanRL actor")
    print(results.summary())
    for row in results.scenarios[:5]:
        ok = "feasible" if row.feasible else "INFEASIBLE"
        print(f"  scenario {row.index}: {row.rate:.4f} bps/Hz, {row.pct_dp:.2f}% of DP, {ok}")
    suite = load_suite("single-node-v1")
    for reference in ("sca", "hover_peak"):  # what to beat, on the same scenarios
        print("  reference:", reference_results(suite, reference, args.n).summary())
    if args.out:
        print("wrote", ", ".join(str(p) for p in results.save(args.out, overwrite=args.overwrite).values()))
    return results.aggregate.mean_pct_dp


if __name__ == "__main__":
    main()
