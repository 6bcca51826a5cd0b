"""A multi-node generalist trained from the tour heuristic (DAgger), from a checkout.

    python -m agents.imitation --out runs/dagger --scenarios 3000 --rounds 3 --hindsight-from 1 \
        --hindsight-block 10 --round-fraction 0.5 --policy node-set --net-arch 64 64   # the shipped recipe
    python -m agents.suite report --model runs/dagger                    # scored on multi-node-v1

Pure PPO on ``ios_uav_env/IOSUAV-MultiNode-Random-v0`` stays far below the bars on the held-out
suite (31% of SCA after 12M steps; the runs: ``results/log.md``): the tour, the hover times and
the shares of 2 to 4 random nodes are hard to find by exploration. Here the tour heuristic
(``baselines.tour``, 99.5% of SCA on the suite) teaches an SB3 PPO policy by imitation:

- **Expert** (:mod:`agents.expert`). ``baselines.tour.solve`` plans each training scenario
  (scenario i is ``sample_multinode(np.random.default_rng(first_seed + i))``, disjoint from
  the suite's seed sequence; cached one JSON file each). From any state the expert tracks its
  plan: at step n, full speed towards the plan's q[n+1], with the plan's shares of that slot,
  so it also labels states off the plan.
- **Rounds.** Round 0 plays the expert's own episodes, clean and with N(0, ``noise``^2) added to
  every executed move (so the data show how to come back to the plan); round r >= 1 plays the
  policy of round r - 1 and labels what it visits (DAgger). Each round fits the policy's action
  mean to every label so far (``epochs`` passes, Adam, one-cycle learning rate): the squared
  error of the move and of the node scores (``agents.fitting.imitation_loss``).
  ``round_fraction`` < 1 keeps that share of each DAgger round's states (each at random,
  seeded): consecutive states of an episode are alike, and the fit's passes over every label so
  far are most of a round's time.
- **Hindsight shares** (rounds >= ``hindsight_from``): the policy's episodes get the share labels
  of :func:`agents.expert.hindsight_shares`, the best continuation of the flight flown given what
  was served, and from then on the share loss keeps only labels that are a best schedule of
  the trajectory flown (:func:`share_rows`).
- **Network** (``policy``). ``"mlp"``: SB3's MlpPolicy over the whole observation.
  ``"node-set"`` (the shipped model): :mod:`agents.node_set`'s actor, the same weights for every node
  slot, equivariant by construction (renumbering the nodes permutes the node scores and keeps
  the move), with the observation statistics pooled over the nodes. Permuting the nodes
  (``permute``, the polish) gives it the same losses: its polish is plain passes.
- **Output.** A run folder that ``agents.loading.load_agent``, ``agents.evaluate`` and
  ``agents.suite report`` read (``model.zip``, ``vecnormalize.pkl`` with the observation
  statistics of round 0, ``config.json``, ``summary.json``), plus ``plans/``, ``data/round_<r>.npz``
  and ``rounds/<r>/``: an interrupted run resumes after its last finished round, and a larger
  ``rounds`` goes on from there; a smaller ``rounds`` than the rounds finished, and other changed
  settings, are refused (``settings.json``). Every file is written atomically (a temporary file,
  then a rename): a failed write leaves the folder's previous files whole.
  ``config.json`` records the observation normalisation (``hyperparams.normalize``), so that
  ``load_agent`` refuses the folder without its ``vecnormalize.pkl``.
- **Interrupts.** SIGINT or SIGTERM stops the command with one line on stderr (exit 130 or 143);
  the same command resumes after the last finished round.

The policy imitates a heuristic: it cannot beat the tour, and the report puts both side by side.
Its value is speed (one forward pass a slot instead of the tour's LPs), and it is an SB3 PPO
model that PPO can go on training: ``train.py --trainer fast --init-from <out>`` starts the fast
trainer from an ``mlp`` model whose network and normalisation the recipe shares
(``agents.fast.init_from``; the node-set actor is another network, and is refused by name).
"""

from __future__ import annotations

import json
import pickle
import signal
import sys
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from agents.expert import RANDOM_ID, Dataset, node_mask, rollouts, tour_plans
from agents.fitting import fit
from agents.imitation_settings import (  # noqa: F401 (the settings, re-exported)
    LATE,
    MAX_SEED,
    POLICIES,
    RESUMABLE,
    ImitationSettings,
    check_resume,
    finished_rounds,
    naming,
)
from ios_uav_env.io import atomic_write_bytes, atomic_write_text

#: The node-set encoder's widths when the CLI names none (the shipped model's; every node of every
#: label goes through the encoder, so its width costs K times an MLP layer's).
NODE_SET_ARCH = (64, 64)
#: How the observations (and rewards) of every imitation model are normalised: its VecNormalize.
NORMALIZE = {"norm_obs": True, "norm_reward": True}


def _new_model(settings: ImitationSettings, env: Any, obs: np.ndarray) -> tuple[Any, Any]:
    """A PPO of ``settings.policy`` on a one-env VecNormalize whose observation statistics are
    ``obs``'s (for the node-set policy, pooled over the nodes: ``agents.node_set.pooled_statistics``)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    venv = VecNormalize(DummyVecEnv([lambda: env]), gamma=1.0, norm_obs=True, norm_reward=True)
    arch = list(settings.net_arch)
    if settings.policy == "node-set":
        from agents.node_orders import NodeLayout
        from agents.node_set import NodeSetPolicy, pooled_statistics

        policy: Any = NodeSetPolicy
        layout = NodeLayout.from_names(env.observation_names, "the node-set policy")
        mean, var = pooled_statistics(obs, layout.k_max, layout.width, layout.extra)
        arch_kwargs = dict(pi=arch, vf=list(ImitationSettings.net_arch))  # the critic: the MLP's
        # the actor reads the layout by name (the energy features after the node blocks)
        extra_kwargs: dict[str, Any] = {"observation_names": tuple(env.observation_names)}
    else:
        policy, mean, var = "MlpPolicy", obs.mean(0), obs.var(0)
        arch_kwargs, extra_kwargs = dict(pi=arch, vf=arch), {}
    venv.obs_rms.mean, venv.obs_rms.var = mean.astype(np.float64), var.astype(np.float64)
    venv.obs_rms.count = float(len(obs))
    kwargs = dict(net_arch=arch_kwargs, log_std_init=settings.log_std_init, **extra_kwargs)
    model = PPO(policy, venv, gamma=1.0, policy_kwargs=kwargs, seed=settings.seed, device="cpu")
    return model, venv


def _hindsight(settings: ImitationSettings, r: int) -> bool:
    return settings.hindsight_from is not None and r >= settings.hindsight_from


def share_rows(settings: ImitationSettings, r: int, parts: list[Dataset], plans: list[Any]) -> np.ndarray:
    """Which rows of rounds 0 .. r (``parts``) the share loss of round r's fit uses: all of them in
    a run without hindsight labels; from round ``hindsight_from`` on, only the rows whose labels
    are a best schedule of the trajectory flown: round 0's clean pass (the expert's own episodes)
    and the hindsight rounds, not the plan's shares on states off the plan (round 0's noisy pass,
    the earlier policy rounds)."""
    if not _hindsight(settings, r):
        return np.ones(sum(len(p.obs) for p in parts), dtype=bool)
    clean = sum(len(p.trajectory) - 1 for p in plans)  # round 0's clean pass comes first
    keep = [np.arange(len(parts[0].obs)) < clean]
    keep += [np.full(len(p.obs), _hindsight(settings, i)) for i, p in enumerate(parts[1:], start=1)]
    return np.concatenate(keep)


def _fit_data(
    settings: ImitationSettings, r: int, parts: list[Dataset], plans: list[Any], k_max: int, width: int
) -> tuple[Dataset, np.ndarray]:
    """The labels of rounds 0 .. r and the fit's loss mask: the node mask, and :func:`share_rows`."""
    every = Dataset.concat(parts)
    return every, node_mask(every.obs, k_max, width) & share_rows(settings, r, parts, plans)[:, None]


def model_config(settings: ImitationSettings, **extra: Any) -> dict[str, Any]:
    """The ``config.json`` of a model of the run: what ``agents.loading.load_agent`` reads (the
    algorithm, env id and arguments, the normalisation as ``hyperparams.normalize``) and the
    run's settings."""
    policy = "agents.node_set.NodeSetPolicy" if settings.policy == "node-set" else "MlpPolicy"
    hyperparams = {"policy": policy, "gamma": 1.0, "normalize": dict(NORMALIZE)}
    return {"algo": "ppo", "env_id": RANDOM_ID, "seed": settings.seed, "env_kwargs": settings.env_kwargs,
            "hyperparams": hyperparams, "trained_by": "agents.imitation", "imitation": asdict(settings),
            **extra}  # fmt: skip


def save_model_folder(folder: str | Path, model: Any, venv: Any, config: dict[str, Any]) -> Path:
    """``vecnormalize.pkl``, ``model.zip`` and ``config.json`` of ``folder``, each written atomically
    (a failed write leaves the previous file whole); the statistics before the model."""
    from agents.callbacks import replace_into

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    with naming(folder / "vecnormalize.pkl"):
        atomic_write_bytes(folder / "vecnormalize.pkl", pickle.dumps(venv))  # what venv.save writes
    with naming(folder / "model.zip"):
        replace_into(folder / "model.zip", model.save)
    with naming(folder / "config.json"):
        atomic_write_text(folder / "config.json", json.dumps(config, indent=1))
    return folder


def run(settings: ImitationSettings) -> dict[str, Any]:
    """The rounds of the module docstring; resumes after the last round found in ``out/rounds``.
    Returns the summary written to ``out/summary.json``."""
    import gymnasium as gym
    import torch as th
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from agents.numpy_policy import NumpyPolicy

    settings.validate()
    out = Path(settings.out)
    out.mkdir(parents=True, exist_ok=True)
    check_resume(settings)
    th.manual_seed(settings.seed)
    t0 = time.perf_counter()
    plans = tour_plans(settings.scenarios, settings.plans or out / "plans", settings.first_seed,
                       jobs=settings.jobs, progress=settings.progress)  # fmt: skip
    env = gym.make(RANDOM_ID, **settings.env_kwargs).unwrapped
    k_max, width = env.max_nodes, len(env.node_features)
    summary_path = out / "summary.json"
    summary = json.loads(summary_path.read_text()) if summary_path.exists() else {"rounds": []}
    summary["rounds"] = [e for e in summary["rounds"] if e["round"] < settings.rounds]
    logged = {e["round"] for e in summary["rounds"]}
    parts, model, venv = [], None, None
    every, mask = None, None  # the last fit's labels and loss mask (all rounds so far)
    for r in range(settings.rounds):
        data_path, folder = out / "data" / f"round_{r}.npz", out / "rounds" / str(r)
        if r in logged and (folder / "model.zip").exists() and data_path.exists():  # resume after it
            parts.append(Dataset.load(data_path))
            venv = VecNormalize.load(str(folder / "vecnormalize.pkl"), DummyVecEnv([lambda: env]))
            model = PPO.load(folder / "model.zip", env=venv, device="cpu")
            continue
        start = time.perf_counter()
        if r == 0:
            clean = rollouts(plans, settings.env_kwargs, seed=settings.seed)
            noisy = rollouts(plans, settings.env_kwargs, noise=settings.noise, seed=settings.seed + 1)
            data = Dataset.concat([clean, noisy])
        else:
            act = NumpyPolicy.from_sb3(model, venv).act
            block = settings.hindsight_block if _hindsight(settings, r) else None
            data = rollouts(plans, settings.env_kwargs, policy=act, seed=settings.seed + 1 + r,
                            hindsight_block=block, jobs=settings.jobs)  # fmt: skip
            if settings.round_fraction < 1:  # consecutive states are alike: fewer labels to fit
                data = data.sample(settings.round_fraction, np.random.default_rng([settings.seed, r]))
        with naming(data_path):
            data.save(data_path)
        parts.append(data)
        if model is None:
            model, venv = _new_model(settings, env, data.obs)
        every, mask = _fit_data(settings, r, parts, plans, k_max, width)
        losses = fit(model, venv, every, mask, settings.epochs, settings.batch_size,
                     settings.learning_rate, settings.seed + r, settings.progress,
                     permute=settings.permute, observation_names=env.observation_names)  # fmt: skip
        save_model_folder(folder, model, venv, model_config(settings, round=r))
        ratio = data.ratio[: len(plans)]  # round 0: the clean pass
        summary["rounds"].append({
            "round": r, "labels": int(len(every.obs)), "played": "expert" if r == 0 else "policy",
            "ratio_mean": float(ratio.mean()), "ratio_p10": float(np.percentile(ratio, 10)),
            **losses, "seconds": round(time.perf_counter() - start, 1),
        })  # fmt: skip
        with naming(summary_path):
            atomic_write_text(summary_path, json.dumps(summary, indent=1))
        print(f"round {r}: {len(every.obs)} labels, played min rate / tour mean {ratio.mean():.4f}, "
              f"loss move {losses['move']:.4f} share {losses['share']:.4f}", flush=True)  # fmt: skip
    assert model is not None and venv is not None
    summary.pop("polish", None)
    if settings.polish_epochs:  # the last round's model, its nodes seen in every order
        start, last = time.perf_counter(), settings.rounds - 1
        if every is None:  # every round was read back: no fit ran this call
            every, mask = _fit_data(settings, last, parts, plans, k_max, width)
        losses = fit(model, venv, every, mask, settings.polish_epochs, settings.batch_size,
                     settings.polish_learning_rate, settings.seed + settings.rounds, settings.progress,
                     permute=True, observation_names=env.observation_names)  # fmt: skip
        summary["polish"] = {"after_round": last, "epochs": settings.polish_epochs, **losses,
                             "seconds": round(time.perf_counter() - start, 1)}  # fmt: skip
        print(f"polish: loss move {losses['move']:.4f} share {losses['share']:.4f}", flush=True)
    save_model_folder(out, model, venv, model_config(settings))
    summary.update(wall_time_s=round(time.perf_counter() - t0, 1), scenarios=settings.scenarios)
    with naming(summary_path):
        atomic_write_text(summary_path, json.dumps(summary, indent=1))
    return summary


def build_parser() -> Any:
    import argparse

    from agents.hyperparams import positive_int

    d = ImitationSettings(out="")
    p = argparse.ArgumentParser(prog="python -m agents.imitation", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="run folder (resumes a run that stopped there)")
    p.add_argument(
        "--scenarios", type=positive_int, default=d.scenarios, help=f"training scenarios ({d.scenarios})"
    )
    p.add_argument(
        "--rounds", type=positive_int, default=d.rounds, help=f"rounds, DAgger after the first ({d.rounds})"
    )
    p.add_argument(
        "--noise", type=float, default=d.noise, help=f"move noise of round 0, units of D ({d.noise})"
    )
    p.add_argument("--epochs", type=positive_int, default=d.epochs, help=f"passes per round ({d.epochs})")
    p.add_argument("--batch-size", type=positive_int, default=d.batch_size)
    p.add_argument("--learning-rate", type=float, default=d.learning_rate)
    p.add_argument(
        "--net-arch",
        type=positive_int,
        nargs="+",
        default=None,
        help=f"layer widths of the MLP ({' '.join(map(str, d.net_arch))}) or of the node-set encoder "
        f"({' '.join(map(str, NODE_SET_ARCH))}); the node-set critic is an MLP of the MLP's widths",
    )
    p.add_argument(
        "--policy",
        choices=POLICIES,
        default=d.policy,
        help="mlp: an MLP over the whole observation; node-set: the same weights for every "
        f"node, equivariant (agents.node_set) ({d.policy})",
    )
    p.add_argument(
        "--env-kwargs",
        nargs="*",
        default=None,
        help="key:value env arguments (default softmin_beta:20 peak_hint:True)",
    )
    p.add_argument(
        "--seed", type=int, default=d.seed, help=f"torch, the noise and the batch order, 0 to {MAX_SEED}"
    )
    p.add_argument("--jobs", type=positive_int, default=None, help="planner processes (default: all cores)")
    p.add_argument("--plans", default=None, help="cache folder of the tour plans (default <out>/plans)")
    p.add_argument(
        "--hindsight-from", type=positive_int, default=None,
        help="first round whose share labels are the hindsight best continuation (default: never)",
    )  # fmt: skip
    p.add_argument("--hindsight-block", type=positive_int, default=d.hindsight_block,
                   help=f"slots between hindsight re-solves ({d.hindsight_block})")  # fmt: skip
    p.add_argument("--polish-epochs", type=int, default=d.polish_epochs,
                   help="after the last round: passes with the nodes in random order (0)")  # fmt: skip
    p.add_argument("--polish-learning-rate", type=float, default=d.polish_learning_rate)
    p.add_argument("--round-fraction", type=float, default=d.round_fraction,
                   help="of each DAgger round's labelled states, the share kept (1: all)")  # fmt: skip
    p.add_argument("--permute", action="store_true",
                   help="every round's fit: the nodes in random order (as the polish's)")  # fmt: skip
    p.add_argument("--no-progress", action="store_true")
    return p


def main(argv: list[str] | None = None) -> int:
    from baselines.runner import sigterm_raises

    parser = build_parser()
    args = parser.parse_args(argv)
    settings = None
    try:
        with sigterm_raises():
            settings = _checked_settings(parser, args)
            summary = run(settings)
    except (KeyboardInterrupt, SystemExit) as exc:
        if isinstance(exc, SystemExit) and exc.code != 128 + signal.SIGTERM:
            raise  # argparse's exit
        signum = signal.SIGINT if isinstance(exc, KeyboardInterrupt) else signal.SIGTERM
        if settings is None:
            name = signal.Signals(signum).name
            note = f"interrupted by {name} while checking the arguments; nothing was computed"
            print(f"{parser.prog}: {note}", file=sys.stderr)
        elif not _noted_by_runner(exc):  # the plans' map says itself what it kept and how to go on
            print(f"{parser.prog}: {interrupted_note(settings, signum)}", file=sys.stderr)
        return 128 + signum
    except OSError as exc:  # a full disk, a folder gone: every file written before is whole
        print(f"{parser.prog}: error: {exc}; the run's other files are whole: run the same command again "
              "to resume", file=sys.stderr)  # fmt: skip
        return 1
    print(json.dumps(summary["rounds"][-1]))
    print(f"wrote {settings.out}: score it with python -m agents.suite report --model {settings.out}")
    return 0


def _checked_settings(parser: Any, args: Any) -> ImitationSettings:
    """The settings of ``args``, validated and recorded (:func:`check_resume`); a bad one is the
    parser's error (exit 2), naming the field, before anything is computed or written."""
    from agents.hyperparams import parse_env_kwargs

    try:
        extra = {} if args.env_kwargs is None else {"env_kwargs": parse_env_kwargs(args.env_kwargs)}
        default_arch = NODE_SET_ARCH if args.policy == "node-set" else ImitationSettings.net_arch
        arch = tuple(args.net_arch) if args.net_arch else default_arch
        settings = ImitationSettings(
            out=args.out, scenarios=args.scenarios, rounds=args.rounds, noise=args.noise, epochs=args.epochs,
            batch_size=args.batch_size, learning_rate=args.learning_rate, net_arch=arch,
            seed=args.seed, jobs=args.jobs, plans=args.plans, progress=not args.no_progress,
            hindsight_from=args.hindsight_from, hindsight_block=args.hindsight_block,
            polish_epochs=args.polish_epochs, polish_learning_rate=args.polish_learning_rate,
            permute=args.permute, round_fraction=args.round_fraction, policy=args.policy, **extra,
        )  # fmt: skip
        settings.validate()
        Path(settings.out).mkdir(parents=True, exist_ok=True)
        check_resume(settings)
    except (ValueError, OSError) as exc:
        parser.error(str(exc))
    return settings


def interrupted_note(settings: ImitationSettings, signum: int) -> str:
    """The line an interrupted run ends with: the signal, the rounds kept, how to resume."""
    try:
        done = finished_rounds(settings.out)
    except ValueError:
        done = 0
    return (f"interrupted by {signal.Signals(signum).name}: {done} of {settings.rounds} rounds are finished "
            f"and kept in {settings.out}; run the same command to resume")  # fmt: skip


def _noted_by_runner(exc: BaseException) -> bool:
    """Whether ``exc`` came out of ``baselines.runner.run_tasks``, which notes an interrupt itself."""
    import traceback

    from baselines.runner import run_tasks

    return any(frame.f_code is run_tasks.__code__ for frame, _ in traceback.walk_tb(exc.__traceback__))


if __name__ == "__main__":
    raise SystemExit(main())
