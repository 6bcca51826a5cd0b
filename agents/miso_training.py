"""Train :class:`agents.miso_learner.MisoLearner` on MISOControl-v0: one command, a few minutes.

    python -m agents.miso_training --out agents/models/miso_learner_MISOControl-v0 \\
        [--iterations 1500] [--episodes 8] [--seed 0] [--overwrite]

The training slots: for each of the 24 settings of the suite ``miso-v1`` (N_t in {2, 4, 8}, K in
{2, 4}, M in {16, 64}, sum and max-min rate; read from the suite, not restated) ``--episodes``
episodes of the env (``optimum=False``: no AO is run) seeded ``TRAIN_SEED + 1000 i + k`` for
setting i, none of them a suite episode's seed (checked). An episode's line is drawn at reset and
its slots do not depend on the actions, so every slot is a one-step problem: the pool holds each
slot's observation and channel (``env.channels``).

The method: gradient ascent on the slots' own objective. For a slot's channel the env's reward is
a differentiable function of the setting (``miso.user_rates`` of H(psi) and W, then the sum or
the minimum), and the setting is a differentiable function of the network's outputs
(``miso_learner.setting``, written once for numpy and torch). So the loss is minus the mean over
the settings of the mean over their slots of log(value / bound + ``RATIO_FLOOR``), the value
computed from the true channel and the setting the policy makes from the observation alone. The
log weighs every slot's relative gain alike, as the suite's % of the AO does (the mean of value /
bound itself, tried first, left max-min with K = 4 users on 2 antennas at 71 % of the AO on
miso-v1, against 80 % with the log, whose p10 and worst scenario are higher too); the certified bound
``miso.slot_bounds`` only puts the floor on the scale of the slot;
full-batch Adam, ``--iterations`` steps, the learning rate decaying linearly to 0. The network's
last layer starts at zero (equal powers and phase weights, q = exp(LOG_Q0)). For the first half of
the steps the power outputs are held at zero (equal powers): trained from the start, the powers
fall into serving one user alone before the directions have learned to separate the users
(gradient ascent reaches a local optimum: on miso-v1 the sum rate at N_t = 8, K = 2 then stayed at
70 to 78 % of the AO, below equal-power ZF's 92 to 94 %), and a user whose softmax power is
near 0 gets no gradient back.

Needs torch (the ``rl`` extra). Writes ``weights.npz`` and ``config.json`` (the command's
arguments, the time, the training slots' mean % of the bound at the start, after the equal-power
half and at the end) to ``--out``, each atomically; an existing model is replaced only with
``--overwrite``.
"""

from __future__ import annotations

import argparse
import dataclasses
import io
import json
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from agents.miso_learner import LOG_Q0, NET_IN, NET_OUT, View, layout, net_inputs, setting, view
from ios_uav_env.benchmark import load_suite
from ios_uav_env.benchmark.miso_suite import MisoTask, miso_kwargs
from ios_uav_env.envs.miso_control import MISOControlEnv
from ios_uav_env.envs.star_control import N_SLOTS
from ios_uav_env.io import atomic_write_bytes, atomic_write_text
from ios_uav_env.model.miso import slot_bounds

#: The first training seed (setting i's episodes: TRAIN_SEED + 1000 i + k).
TRAIN_SEED = 8_000_000
WIDTH, LEARNING_RATE = 32, 3e-3
#: Added to value / bound before its log (a slot where a user gets nothing keeps a finite loss).
RATIO_FLOOR = 1e-3
SUITE = "miso-v1"


def suite_settings(name: str = SUITE) -> list[dict[str, Any]]:
    """The suite's distinct env keywords (``miso``), in the order they first appear."""
    out: list[dict[str, Any]] = []
    for scenario in load_suite(name).scenarios:
        kw = miso_kwargs(scenario.miso)
        if kw not in out:
            out.append(kw)
    return out


@dataclass
class Pool:
    """One setting's training slots: the task, what the observations say (:class:`View`), the true
    channels (coef (S, K, M), to_elements (S, M, N_t), direct (S, K, N_t)) and each slot's bound."""

    task: MisoTask
    view: View
    coef: np.ndarray
    to_elements: np.ndarray
    direct: np.ndarray
    bound: np.ndarray

    def tensors(self) -> tuple[torch.Tensor, View, dict[str, torch.Tensor]]:
        """The network's inputs, the view and the channels as tensors."""
        v = View(**{f.name: torch.from_numpy(getattr(self.view, f.name)) for f in dataclasses.fields(View)})
        names = ("coef", "to_elements", "direct", "bound")
        channels = {name: torch.from_numpy(getattr(self, name)) for name in names}
        return torch.from_numpy(net_inputs(self.view)), v, channels


def make_pool(i: int, kwargs: dict[str, Any], episodes: int, forbidden: set[int]) -> Pool:
    """Setting ``i``'s (env keywords ``kwargs``) pool of ``episodes`` episodes (``ValueError`` if a
    seed is in ``forbidden``)."""
    env = MISOControlEnv(**kwargs, optimum=False)
    task = MisoTask.of(kwargs, env)
    obs_rows, channels = [], []
    for k in range(episodes):
        seed = TRAIN_SEED + 1000 * i + k
        if seed in forbidden:
            raise ValueError(f"training seed {seed} is a suite episode's seed: choose another TRAIN_SEED")
        obs, _ = env.reset(seed=seed)
        for n in range(N_SLOTS):  # the observation does not depend on the actions
            obs_rows.append(obs)
            channels.append(env.channels[n])
            obs = env.step(np.zeros(env.action_space.shape))[0]
    bound = np.array([slot_bounds(ch).of(task.objective) for ch in channels])
    stacked = {
        name: np.stack([getattr(ch, name) for ch in channels]) for name in ("coef", "to_elements", "direct")
    }
    return Pool(task, view(np.asarray(obs_rows), task, layout(task)), **stacked, bound=bound)


def slot_values(
    channels: dict[str, torch.Tensor], phasor: torch.Tensor, beams: torch.Tensor, objective: str
) -> torch.Tensor:
    """The env's reward (S,) of the settings (v (S, M), W (S, N_t, K)) at the slots' ``channels``:
    ``miso.user_rates`` of H = (c_km v_m) g + d, then the sum or the minimum over the users."""
    H = (channels["coef"] * phasor[:, None, :]) @ channels["to_elements"] + channels["direct"]
    gains = (H @ beams).abs() ** 2  # (S, K, K): |h_k w_j|^2
    signal = torch.diagonal(gains, dim1=-2, dim2=-1)
    rates = torch.log2(1.0 + signal / (gains.sum(dim=-1) - signal + 1.0))
    return rates.sum(dim=-1) if objective == "sum" else rates.min(dim=-1).values


def network(width: int = WIDTH) -> nn.Sequential:
    """The user network (``miso_learner.outputs``' torch form), its last layer zero."""
    net = nn.Sequential(nn.Linear(NET_IN, width), nn.Tanh(), nn.Linear(width, width), nn.Tanh(),
                        nn.Linear(width, NET_OUT)).double()  # fmt: skip
    nn.init.zeros_(net[-1].weight)
    nn.init.zeros_(net[-1].bias)
    return net


def ratios(net: nn.Sequential, data: Sequence[tuple[Any, ...]], powers: bool = True) -> list[torch.Tensor]:
    """Each setting's slots' value / bound (differentiable); ``data``: each pool's
    :meth:`Pool.tensors` and objective. ``powers=False`` holds the power outputs y at zero (equal
    powers)."""
    mask = torch.tensor([1.0, float(powers), 1.0], dtype=torch.float64)
    out = []
    for inputs, v, channels, objective in data:
        phasor, beams = setting(net(inputs) * mask, v, torch)
        out.append(slot_values(channels, phasor, beams, objective) / channels["bound"])
    return out


def pct_of_bound(parts: Sequence[torch.Tensor]) -> float:
    """The mean over the settings of their slots' mean value / bound, in %."""
    return float(100 * torch.stack([r.detach().mean() for r in parts]).mean())


def log_gain(parts: Sequence[torch.Tensor]) -> torch.Tensor:
    """The loss's negative: the mean over the settings of their slots' mean log(value / bound +
    ``RATIO_FLOOR``)."""
    return torch.stack([torch.log(r + RATIO_FLOOR).mean() for r in parts]).mean()


def train(
    pools: Sequence[Pool], iterations: int, seed: int, progress: bool = True
) -> tuple[nn.Sequential, dict[str, float]]:
    """The network after ``iterations`` Adam steps (module docstring; the first half with equal
    powers) and the pools' mean % of the bound at the start, after the first half and at the end."""
    from tqdm.auto import tqdm

    torch.manual_seed(seed)
    net = network()
    data = [(*pool.tensors(), pool.task.objective) for pool in pools]
    opt = torch.optim.Adam(net.parameters(), lr=LEARNING_RATE)
    decay = torch.optim.lr_scheduler.LambdaLR(opt, lambda it: 1 - it / iterations)  # linear, to 0
    with torch.no_grad():
        scores = {"start": pct_of_bound(ratios(net, data))}
    bar = tqdm(range(iterations), desc="miso learner", unit="step", disable=not progress)
    for it in bar:
        opt.zero_grad()
        if it == iterations // 2:
            with torch.no_grad():
                scores["equal powers"] = pct_of_bound(ratios(net, data, powers=False))
        parts = ratios(net, data, powers=it >= iterations // 2)
        (-log_gain(parts)).backward()
        torch.nn.utils.clip_grad_norm_(net.parameters(), 10.0)
        opt.step()
        decay.step()
        bar.set_postfix_str(f"{pct_of_bound(parts):.2f} % of the bound")
    with torch.no_grad():
        scores["end"] = pct_of_bound(ratios(net, data))
    return net, scores


def export(net: nn.Sequential) -> dict[str, np.ndarray]:
    """The network as ``weights.npz``'s arrays (``miso_learner.load_weights``)."""
    linears = [m for m in net if isinstance(m, nn.Linear)]
    out = {}
    for j, layer in enumerate(linears):
        out[f"user_w{j}"] = layer.weight.detach().numpy().T.copy()
        out[f"user_b{j}"] = layer.bias.detach().numpy().copy()
    return out


def main(argv: Sequence[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(
        prog="python -m agents.miso_training", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--out", type=Path, required=True, help="the model folder to write")
    parser.add_argument("--iterations", type=int, default=1500, help="full-batch gradient steps")
    parser.add_argument("--episodes", type=int, default=8, help="training episodes per setting")
    parser.add_argument("--seed", type=int, default=0, help="the initial weights' seed")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing model in --out")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    for name, low in (("iterations", 1), ("episodes", 1), ("seed", 0)):
        if getattr(args, name) < low:
            parser.error(f"--{name} must be >= {low}, got {getattr(args, name)}")
    if (args.out / "weights.npz").exists() and not args.overwrite:
        parser.error(f"--out {args.out} holds a model: pass --overwrite to replace it")
    torch.set_num_threads(1)
    start = time.perf_counter()
    forbidden = {s.seed for s in load_suite(SUITE).scenarios}
    settings = suite_settings()
    pools = [make_pool(i, kw, args.episodes, forbidden) for i, kw in enumerate(settings)]
    net, scores = train(pools, args.iterations, args.seed, progress=not args.no_progress)
    seconds = time.perf_counter() - start
    buffer = io.BytesIO()
    np.savez(buffer, **export(net))
    atomic_write_bytes(args.out / "weights.npz", buffer.getvalue())
    command = ["python -m agents.miso_training", "--out", str(args.out), "--iterations", str(args.iterations),
               "--episodes", str(args.episodes), "--seed", str(args.seed)]  # fmt: skip
    config = {
        "trainer": "agents.miso_training", "command": " ".join(command), "suite": SUITE,
        "settings": len(settings), "train_seed": TRAIN_SEED, "width": WIDTH, "log_q0": LOG_Q0,
        "learning_rate": LEARNING_RATE, "seconds": round(seconds, 1),
        "pct_of_bound": {name: round(value, 3) for name, value in scores.items()},
    }  # fmt: skip
    atomic_write_text(args.out / "config.json", json.dumps(config, indent=2) + "\n")
    print(f"model: {args.out} ({seconds:.0f} s; {scores['start']:.2f} -> {scores['end']:.2f} % of the bound)")
    return args.out


if __name__ == "__main__":
    main()
