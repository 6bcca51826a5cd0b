"""The fast trainer's network and the env it is built on: one env of the run's id as the policy sees
it (with the recipe's memory, ``agents.wrappers.FrameStack``), the SB3 PPO whose
``ActorCriticPolicy`` the recipe's ``policy_kwargs`` make, and the ``VecNormalize`` statistics the
recipe's ``normalize`` asks for. :class:`agents.fast.ppo.FastPPO` trains them;
:mod:`agents.fast.init_from` checks a model to start from against them."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym

import ios_uav_env  # noqa: F401  (registers the ids)
from agents.fast.recipe import FastRecipe


def policy_env(env_id: str, env_kwargs: Mapping[str, Any], recipe: FastRecipe) -> gym.Env:
    """One env of ``env_id`` with ``env_kwargs``, its observations as the policy of ``recipe`` sees
    them: the last ``recipe.frames`` of them stacked (``agents.wrappers.FrameStack``) if above 1."""
    env = gym.make(env_id, **env_kwargs)
    if recipe.frames > 1:
        from agents.wrappers import FrameStack

        env = FrameStack(env, recipe.frames)
    return env


def template_venv(env_id: str, env_kwargs: Mapping[str, Any], recipe: FastRecipe) -> Any:
    """A one-env ``DummyVecEnv`` of :func:`policy_env`: the spaces SB3's model and statistics take."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    return DummyVecEnv([lambda: policy_env(env_id, dict(env_kwargs), recipe)])


def new_model(recipe: FastRecipe, template: Any, seed: int) -> Any:
    """A new SB3 PPO of ``recipe``'s network on ``template`` (a VecEnv of :func:`template_venv`)."""
    from stable_baselines3 import PPO

    r = recipe
    return PPO(
        "MlpPolicy",
        template,
        learning_rate=r.learning_rate.initial,
        n_steps=r.batch_size,  # SB3's own buffer is not used; this size keeps its checks quiet
        batch_size=r.batch_size,
        n_epochs=r.n_epochs,
        gamma=r.gamma,
        gae_lambda=r.gae_lambda,
        ent_coef=r.ent_coef,
        vf_coef=r.vf_coef,
        max_grad_norm=r.max_grad_norm,
        policy_kwargs=r.policy_kwargs,
        seed=seed,
        device="cpu",
    )


def new_statistics(recipe: FastRecipe, template: Any) -> Any:
    """New ``VecNormalize`` statistics of ``recipe`` on ``template``; None if it does not normalise."""
    if recipe.normalize is None:
        return None
    from stable_baselines3.common.vec_env import VecNormalize

    return VecNormalize(template, gamma=recipe.gamma, **recipe.normalize)
