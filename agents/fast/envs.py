"""The rows a fast run steps (:class:`RunEnv`): a registered id's batched form, or B fleets of U
UAVs whose every agent is a row of one shared policy (:class:`agents.fast.fleet.FleetSpec`).

:func:`run_env` builds, for :class:`agents.fast.ppo.FastPPO`, the rows (an object with
``vector_env``, ``seed(s)``, ``reset()`` and ``close()``: ``agents.vec_env.BatchedVecEnv`` for an
id), the one-env ``DummyVecEnv`` with a row's spaces that SB3's model and ``VecNormalize`` are
built on, what a finished episode's score is, and how many rows one episode spans (1; U for a
fleet, whose rows share their fleet's episode and score: the score is counted once per fleet).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym

from agents.fast.recipe import FastRecipe
from agents.fast.rows import RunEnv
from agents.scores import score_label


def run_env(
    env: Any, n_envs: int, env_kwargs: Mapping[str, Any], recipe: FastRecipe, env_threads: int | None
) -> RunEnv:
    """The :class:`RunEnv` of ``env`` (a registered id of this package with a batched form, with
    ``env_kwargs``; or an ``agents.fast.fleet.FleetSpec``, ``n_envs`` fleets) for ``recipe``;
    ``ValueError`` naming what does not fit."""
    if not isinstance(env, str):
        from agents.fast.fleet import FleetSpec, fleet_run_env

        if not isinstance(env, FleetSpec):
            raise TypeError(f"env_id must be an env id (str) or a FleetSpec, got {type(env).__name__}")
        if env_kwargs:
            raise ValueError(f"env_kwargs: a FleetSpec carries its own (its env_kwargs), got {env_kwargs}")
        return fleet_run_env(env, n_envs, recipe, env_threads)
    from agents.fast.network import template_venv
    from agents.vec_env import BatchedVecEnv

    spec = gym.registry.get(env)
    if spec is None or not env.startswith("ios_uav_env/") or spec.vector_entry_point is None:
        ours = (i for i, s in gym.registry.items() if i.startswith("ios_uav_env/") and s.vector_entry_point)
        batched = sorted(ours)
        raise ValueError(
            f"env_id must be an id of this package with a batched form ({', '.join(batched)}), got {env!r}"
        )
    vector_kwargs = dict(env_kwargs)
    if env_threads is not None:
        vector_kwargs["num_threads"] = env_threads
    base = BatchedVecEnv(env, n_envs, vector_kwargs, stagger=True)
    template = template_venv(env, env_kwargs, recipe)
    score = score_label(template.envs[0])
    info_keys = base.vector_env.info_keys
    if score.name not in info_keys:
        base.close()
        raise ValueError(
            f"env_id {env!r}: its batched form does not report the score {score.name!r} of "
            f"its objective {score.objective!r} (it reports {', '.join(info_keys)})"
        )
    return RunEnv(base, template, score)
