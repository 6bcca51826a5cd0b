"""Behaviour cloning before PPO: the fast trainer's warm start from a policy on the observation.

A recipe with the callback ``agents.callbacks.CloneStart`` (``agents/hyperparams/fast_ppo.yml``)
starts PPO from a clone of an *expert*, a policy that maps the raw observation to an action
(e.g. ``ios_uav_env.envs.policies:HoverAt('ground')``, which follows the node's told position):

- **Rounds.** Round 0 is flown by the expert, with N(0, ``noise``^2) added to each move (so the
  data show how to come back); round r >= 1 by the mean of the policy fitted so far (DAgger: the
  labels cover the states the policy itself reaches). Each round is ``slots`` slots of every row
  of the run's batched env; the expert labels every state visited with its action.
- **Fit.** After each round the policy's Gaussian mean is fitted to every label so far and its
  value to the discounted returns of that round's states (the recipe's gamma, bootstrapped by the
  value after the round's last slot; rewards normalised as PPO normalises them), by squared
  error with Adam (a separate optimiser: PPO's Adam starts fresh). The observation statistics
  (``VecNormalize``) are updated from every state visited, as PPO's rollouts update them, and
  each fit normalises every observation so far with the statistics of that moment (the raw
  observations are kept).
- **Then PPO** trains on from the clone with the recipe's schedules from step 0; the clone's env
  steps are not counted in the run's steps (``clone.json`` in the run folder records them).

With a memory in the recipe (``agents.wrappers.FrameStack``) the policy is fitted on its
stacked observations and the expert labels the newest frame, the env's own observation.

The policy starts where the expert is and RL can only move it from there: a warm start, not a
bound. The rows are reset after the clone (seeded as the run's first rollout).

The expert is checked with the recipe, on the run's env, before anything of the run is written
(``agents.fast.recipe.checked_expert``, called by ``agents.training.check_hyperparams``): it
must load, the observation features it declares (``observation_features``, e.g.
``HoverAt('peak')``'s peak hint) must be among the env's (``env.unwrapped.observation_names``;
the expert is then bound to that layout), and on the env's first observations it must return
finite actions of the env's shape.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np

from agents.fast.recipe import CloneSettings, checked_expert

if TYPE_CHECKING:
    from agents.fast.ppo import FastPPO


def clone(algo: FastPPO, settings: CloneSettings) -> dict[str, Any]:
    """Fit ``algo``'s policy to the expert of ``settings`` (module docstring); the fit's record."""
    import torch

    from agents.fast.gae import gae

    expert = checked_expert(settings.expert, algo.env_id, algo.env_kwargs)
    start = time.perf_counter()
    recipe, policy = algo.recipe, algo.policy
    params = [p for name, p in policy.named_parameters() if name != "log_std"]
    optimizer = torch.optim.Adam(params, lr=settings.learning_rate)
    rng = np.random.default_rng([algo.seed, 1])
    algo.reset(seed=algo.seed + 7_919 * recipe.n_envs)  # rows of their own, not the RL run's first
    obs = algo._obs
    seen_raw: list[np.ndarray] = []  # raw observations: each fit normalises them with the current statistics
    seen_labels: list[np.ndarray] = []
    rounds = []
    for r in range(settings.rounds):
        raws, labels, rewards, dones = [], [], [], []
        for _ in range(settings.slots):
            label = np.asarray(expert(algo.latest(obs)), dtype=np.float64)  # the env's own observation
            if not np.all(np.isfinite(label)):
                raise ValueError(
                    f"CloneStart expert {settings.expert!r} returned non-finite actions in round {r}"
                )
            label = np.clip(label, algo._low, algo._high)
            raws.append(np.asarray(obs, dtype=np.float64))
            if r == 0:
                act = label.copy()
                act[:, :2] += settings.noise * rng.standard_normal((len(act), 2))
            else:
                with torch.no_grad():
                    act = algo._forward(_normalized(algo, obs))[0].numpy().astype(np.float64)
            stepped = algo.vec.step(np.clip(act, algo._low, algo._high))
            obs, reward, done = algo._after_step(*stepped, explore=False)
            labels.append(label.astype(np.float32))
            rewards.append(reward)
            dones.append(done)
        raw = np.stack(raws)  # (slots, B, obs)
        flat = _normalized(algo, raw.reshape(-1, raw.shape[-1]))
        with torch.no_grad():
            values = algo._forward(flat)[1].reshape(raw.shape[:2])
            last = algo._forward(_normalized(algo, obs))[1]
        rew = torch.from_numpy(np.stack(rewards).astype(np.float32))
        don = torch.from_numpy(np.stack(dones).astype(np.float32))
        returns = gae(rew, values, don, last, recipe.gamma, 1.0)[1].reshape(-1)
        seen_raw.append(raw.reshape(-1, raw.shape[-1]))
        seen_labels.append(torch.from_numpy(np.stack(labels)).reshape(-1, labels[0].shape[-1]))
        data = (_normalized(algo, np.concatenate(seen_raw)), torch.cat(seen_labels))
        fit = _fit(algo, optimizer, params, *data, flat, returns, settings)
        scores = algo.take_scores()
        score = float(np.mean(scores)) if scores else float("nan")
        samples = int(sum(len(o) for o in seen_raw))
        rounds.append({"round": r, "samples": samples, "episode_score": score, "score_name": algo.score.name,
                       "score_unit": algo.score.unit, **fit})  # fmt: skip
    algo._obs = None  # PPO's first rollout resets the rows
    steps = settings.rounds * settings.slots * recipe.n_envs
    return {"settings": dict(settings.__dict__), "env_steps": steps,
            "seconds": round(time.perf_counter() - start, 2), "rounds": rounds}  # fmt: skip


def _normalized(algo: FastPPO, obs: np.ndarray) -> Any:
    """``obs`` as the policy takes them: normalised with the run's current statistics, float32."""
    import torch

    return torch.from_numpy(np.asarray(algo._normalized_obs(obs), dtype=np.float32))


def _fit(
    algo: FastPPO, optimizer: Any, params: list[Any], obs: Any, labels: Any, value_obs: Any, returns: Any,
    settings: CloneSettings,
) -> dict[str, float]:  # fmt: skip
    """``epochs`` passes of Adam: the mean's squared error to ``labels`` on ``obs``, and the value's
    to ``returns`` on ``value_obs`` (one value minibatch per mean minibatch, cycling)."""
    import torch

    n, m = len(obs), len(value_obs)
    size = min(settings.batch_size, n)
    action_loss = value_loss = 0.0
    count = 0
    for _ in range(settings.epochs):
        order, value_order = torch.randperm(n), torch.randperm(m)
        for k, begin in enumerate(range(0, n, size)):
            idx = order[begin : begin + size]
            vidx = value_order[(k * size) % m : (k * size) % m + size]
            mean = algo._forward(obs[idx])[0]
            value = algo._forward(value_obs[vidx])[1]
            a_loss = torch.mean((mean - labels[idx]) ** 2)
            v_loss = torch.mean((value - returns[vidx]) ** 2)
            optimizer.zero_grad(set_to_none=True)
            (a_loss + algo.recipe.vf_coef * v_loss).backward()
            torch.nn.utils.clip_grad_norm_(params, algo.recipe.max_grad_norm)
            optimizer.step()
            action_loss, value_loss, count = (
                action_loss + float(a_loss.detach()),
                value_loss + float(v_loss.detach()),
                count + 1,
            )
    return {"action_loss": action_loss / max(count, 1), "value_loss": value_loss / max(count, 1)}
