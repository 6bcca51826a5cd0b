"""The fast trainer started from a trained model (``train.py --trainer fast --init-from PATH``).

``PATH`` is a model or run folder (``model.zip``, and ``vecnormalize.pkl`` when it normalised
its observations: what ``agents.imitation`` and every ``train.py`` run write) or a bare SB3 PPO
``.zip`` (its statistics, if any, the ``vecnormalize.pkl`` beside it). Its policy's weights (the
actor, the critic and the Gaussian's log std) are copied into the new run's network, and its
observation statistics (the running mean and variance of ``VecNormalize``) into the run's, so
that the run's first policy acts exactly as the model does: on a raw observation o both compute
``mean(clip((o - mu) / sqrt(var + eps), -c, c))`` with the same weights, mu, var, eps and c.
PPO's Adam starts fresh (the model's optimiser state is not read), and so do the reward
statistics and the step count: the recipe's schedules run from step 0.

The copy is refused, with a ``ValueError`` naming every mismatch, unless the model is a PPO
whose network the recipe would build: the same observation size (a memory recipe's stacked
size, ``agents.tricks.FrameStack``), the same action size, the same policy class (SB3's
``MlpPolicy``; a node-set actor is another network), the same layer sizes of the actor and the
critic (``policy_kwargs``' ``net_arch``) and activation; and the same observation normalisation:
statistics if and only if the recipe normalises observations, with ``VecNormalize``'s clip and
epsilon. A recipe that warm-starts by cloning (``agents.callbacks.CloneStart``) is refused too:
one warm start per run.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np


@dataclass
class InitModel:
    """A model to start from: the SB3 PPO, its ``VecNormalize`` statistics (or None), where it was read."""

    model: Any
    vecnormalize: Any
    path: Path


def read_init_model(path: str | Path) -> InitModel:
    """The PPO model of ``path`` (a folder with ``model.zip``, or a ``.zip``) and its statistics;
    ``ValueError`` naming the file that is missing or that is not an SB3 PPO model."""
    from agents.loading import _read_vecnormalize, zip_algorithm

    path = Path(path)
    zip_path = path if path.suffix == ".zip" else path / "model.zip"
    if not zip_path.is_file():
        raise ValueError(f"init_from: no model at {zip_path} (a model or run folder, or an SB3 PPO .zip)")
    try:
        algo = zip_algorithm(zip_path)  # None: an on-policy ActorCriticPolicy (PPO's), or unknown
    except ValueError as exc:
        raise ValueError(f"init_from: {exc}") from None
    if algo not in (None, "ppo"):
        raise ValueError(f"init_from: {zip_path} holds a {algo.upper()} model, not PPO")
    from stable_baselines3 import PPO

    try:
        model = PPO.load(zip_path, device="cpu")
    except Exception as exc:  # a damaged zip fails in many ways (zipfile, torch, SB3 asserts)
        reason = f"{type(exc).__name__}: {exc}"
        raise ValueError(f"init_from: {zip_path}: cannot load the PPO model: {reason}") from None
    stats = zip_path.parent / "vecnormalize.pkl"
    vecnormalize = _read_vecnormalize(stats) if stats.is_file() else None
    return InitModel(model, vecnormalize, zip_path)


def _layers(policy: Any) -> dict[str, list[int]]:
    """The widths of the actor's and the critic's hidden layers."""
    extractor = policy.mlp_extractor
    return {
        name: [m.out_features for m in getattr(extractor, net) if hasattr(m, "out_features")]
        for name, net in (("actor", "policy_net"), ("critic", "value_net"))
    }


def _activations(policy: Any) -> list[str]:
    leaves = (m for m in policy.mlp_extractor.modules() if not list(m.children()))
    return sorted({type(m).__name__ for m in leaves} - {"Linear"})


def _normalises(vecnormalize: Any) -> bool:
    return vecnormalize is not None and bool(getattr(vecnormalize, "norm_obs", False))


def mismatches(source: InitModel, model: Any, vecnormalize: Any) -> list[str]:
    """What differs between ``source`` and the run's ``model`` (an SB3 PPO) with its statistics
    ``vecnormalize``, each named with both values (empty: the weights can be copied)."""
    found: list[str] = []
    theirs, ours = source.model, model
    for name, a, b in (
        ("observation size", theirs.observation_space.shape, ours.observation_space.shape),
        ("action size", theirs.action_space.shape, ours.action_space.shape),
        ("policy class", type(theirs.policy).__name__, type(ours.policy).__name__),
    ):
        if a != b:
            found.append(f"{name}: the model's {a}, the run's {b}")
    if found and found[-1].startswith("policy class"):
        return found  # another network: its layers mean something else
    for name in ("actor", "critic"):
        a, b = _layers(theirs.policy)[name], _layers(ours.policy)[name]
        if a != b:
            found.append(f"{name} layer sizes: the model's {a}, the run's {b} (policy_kwargs net_arch)")
    if _activations(theirs.policy) != _activations(ours.policy):
        found.append(
            f"activation: the model's {_activations(theirs.policy)}, the run's {_activations(ours.policy)}"
        )
    if found:
        return found
    shapes = {k: tuple(v.shape) for k, v in theirs.policy.state_dict().items()}
    own = {k: tuple(v.shape) for k, v in ours.policy.state_dict().items()}
    if shapes != own:
        diff = sorted(k for k in shapes.keys() | own.keys() if shapes.get(k) != own.get(k))
        found.append(f"parameters: {', '.join(f'{k} {shapes.get(k)} vs {own.get(k)}' for k in diff)}")
    a, b = _normalises(source.vecnormalize), _normalises(vecnormalize)
    if a != b:
        has = "has observation statistics" if a else "has no observation statistics (vecnormalize.pkl)"
        does = "normalises observations" if b else "does not normalise observations"
        found.append(f"observation normalisation: the model {has}, the recipe {does} (normalize)")
    elif a:
        for name in ("clip_obs", "epsilon"):
            x, y = getattr(source.vecnormalize, name), getattr(vecnormalize, name)
            if x != y:
                found.append(f"VecNormalize {name}: the model's {x}, the recipe's {y}")
        shape = np.shape(source.vecnormalize.obs_rms.mean)
        if tuple(shape) != tuple(ours.observation_space.shape):
            found.append(f"observation statistics of shape {tuple(shape)}, the run's observations "
                         f"{tuple(ours.observation_space.shape)}")  # fmt: skip
    return found


def start_from(path: str | Path, model: Any, vecnormalize: Any, clone: Any = None) -> InitModel:
    """Copy the weights and observation statistics of the model at ``path`` into ``model`` (the
    run's PPO) and ``vecnormalize`` (its statistics, or None); ``ValueError`` naming every
    mismatch (:func:`mismatches`), or the recipe's ``CloneStart`` (``clone``) if it has one."""
    import torch

    if clone is not None:
        raise ValueError(
            f"init_from: the recipe warm-starts by cloning {clone.expert!r} (agents.callbacks.CloneStart); "
            "a run has one warm start: drop CloneStart from the recipe or init_from"
        )
    source = read_init_model(path)
    found = mismatches(source, model, vecnormalize)
    if found:
        raise ValueError(f"init_from: {source.path} does not fit the run's network: {'; '.join(found)}")
    with torch.no_grad():
        model.policy.load_state_dict(source.model.policy.state_dict())
    if _normalises(vecnormalize):
        rms, theirs = vecnormalize.obs_rms, source.vecnormalize.obs_rms
        rms.mean = np.array(theirs.mean, dtype=np.float64)
        rms.var = np.array(theirs.var, dtype=np.float64)
        rms.count = float(theirs.count)
    return source


def check_init_from(
    path: str | Path, env_id: str, env_kwargs: dict[str, Any], hyperparams_file: str | Path,
    n_envs: int | None = None,
) -> InitModel:  # fmt: skip
    """:func:`start_from` on a network the recipe of ``env_id`` in ``hyperparams_file`` builds on
    the env with ``env_kwargs`` (a throwaway, before a run writes anything): ``ValueError`` naming
    every mismatch. The model read."""
    from agents.fast.network import new_model, new_statistics, template_venv
    from agents.fast.recipe import FastRecipe
    from agents.hyperparams import load_hyperparams

    recipe = FastRecipe.from_hyperparams(load_hyperparams("ppo", env_id, hyperparams_file), n_envs)
    template = template_venv(env_id, env_kwargs, recipe)
    try:
        model, statistics = new_model(recipe, template, 0), new_statistics(recipe, template)
        return start_from(path, model, statistics, recipe.clone)
    finally:
        template.close()
