"""PPO on the batched env's arrays: the rollout and the update of the fast trainer.

The batched env (``ios_uav_env.envs.single_vector`` / ``multi_vector``, same-step autoreset)
hands over a (B, obs) array per slot; :class:`FastPPO` keeps the whole rollout as (T, B, ...)
tensors, with no per-row dict or Python loop over rows, computes GAE on them
(:func:`agents.fast.gae.gae`) and updates in large minibatches. What a step does is SB3's PPO
with ``VecNormalize``, row for row:

- the network is SB3's own ``ActorCriticPolicy`` (``policy_kwargs`` as for SB3), so the model
  saves as an SB3 PPO ``.zip``, loads with ``agents.loading.load_agent`` and exports to
  ``agents.numpy_policy.NumpyPolicy``; actions are sampled from its diagonal Gaussian and
  clipped to the action space for the env, the unclipped sample kept for the loss;
- observations and rewards are normalised with a ``VecNormalize``'s statistics and rules
  (running mean and variance of the observations, of the discounted return for the rewards,
  the same clips and epsilon), saved as its pickle;
- the loss is SB3's: the clipped surrogate with advantages normalised per minibatch, the
  value's squared error (``vf_coef``), the entropy (``ent_coef``), the gradient clipped to
  ``max_grad_norm``, Adam on SB3's optimizer; ``learning_rate`` and ``clip_range`` follow the
  progress of the run as SB3's schedules do, the log-std schedule and the exploring starts'
  schedule as ``agents.callbacks`` defines them;
- the recipe's tricks (the exploring starts, the reward shift, the memory of the last
  observations) are ``agents.tricks``' on the rows' arrays, the implementation the SB3 VecEnv
  path (``agents.vec_env``) calls too.

The update runs on torch's autograd, or (``update="kernel"``, the default when numba is
installed and the network is a plain tanh MLP) as one compiled function per update
(:mod:`agents.fast.kernel`): the same loss, gradient and Adam step in float32, without torch's
per-op cost; the rollout's forward passes then run compiled too. The two agree to float rounding.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
import torch

import ios_uav_env  # noqa: F401  (registers the ids)
from agents.fast.fleet import FleetSpec
from agents.fast.gae import gae
from agents.fast.kernel import STATS
from agents.fast.kernel_policy import KernelUpdate
from agents.fast.network import new_model, new_statistics
from agents.fast.recipe import FastRecipe
from agents.tricks import ExploringStarts, FrameStack, RewardShift, scheduled_prob
from ios_uav_env.jit import HAVE_NUMBA, prefer_passive_threads

prefer_passive_threads()  # numba's threads must not spin while torch trains (see the function)

#: How :meth:`FastPPO.update` computes: ``auto`` (the compiled kernel if numba is installed and
#: it covers the network, else torch), ``kernel`` (an error if it cannot), ``torch``.
UPDATES = ("auto", "kernel", "torch")
#: The update's statistics, in :func:`agents.fast.kernel.ppo_update`'s order.
STAT_KEYS = STATS


class FastPPO:
    """PPO of ``recipe`` on ``n_envs`` rows of ``env_id`` (its batched form), for ``total`` env steps;
    ``env_id`` an ``agents.fast.fleet.FleetSpec``: IPPO with shared parameters on ``n_envs`` fleets,
    every agent a row (:mod:`agents.fast.fleet`; ``total`` and the steps count agent steps).

    ``model``: an SB3 PPO to go on training (its policy and Adam state, e.g. a checkpoint's),
    default a new one seeded ``seed``; ``vecnormalize``: its statistics (a ``VecNormalize``),
    default new ones if the recipe normalises. ``steps``: the env steps done so far (the
    schedules' progress). Row i of the env is seeded ``seed + i`` and the rows are staggered
    over the episode (``agents.vec_env.BatchedVecEnv(stagger=True)``). ``update``: one of
    :data:`UPDATES`. ``init_from``: a model or run folder, or an SB3 PPO ``.zip``, whose weights
    and observation statistics a new model starts from (:mod:`agents.fast.init_from`; not read
    with ``model``)."""

    def __init__(
        self,
        env_id: str | FleetSpec,
        recipe: FastRecipe,
        total: int,
        *,
        env_kwargs: Mapping[str, Any] | None = None,
        seed: int = 0,
        model: Any = None,
        vecnormalize: Any = None,
        steps: int = 0,
        env_threads: int | None = None,
        update: str = "auto",
        init_from: str | None = None,
    ) -> None:
        from agents.fast.envs import run_env

        run = run_env(env_id, recipe.n_envs, env_kwargs or {}, recipe, env_threads)
        if run.rows != recipe.n_envs:  # fleets: n_envs counts fleets, the rollout counts agent rows
            recipe = dataclasses.replace(recipe, n_envs=run.rows)
        self.env_id, self.recipe, self.total, self.seed = env_id, recipe, int(total), int(seed)
        self.env_kwargs = dict(env_kwargs or {})
        self.steps, self.updates = int(steps), 0
        self.base, template, self.score = run.base, run.template, run.score  # score: the episodes' scores
        self.vec = self.base.vector_env
        self._scored = np.arange(run.rows) % run.episode_rows == 0  # one row per episode (per fleet)
        self.model = model if model is not None else new_model(recipe, template, self.seed)
        self.vecnormalize = vecnormalize
        if vecnormalize is not None and getattr(vecnormalize, "venv", None) is None:
            vecnormalize.set_venv(template)  # unpickled statistics: attach them to envs of their spaces
        if self.vecnormalize is None:
            self.vecnormalize = new_statistics(recipe, template)
        self.init_model = None  # the model the run started from (init_from), None for a new one
        if init_from is not None and model is None:
            from agents.fast.init_from import start_from

            self.init_model = start_from(init_from, self.model, self.vecnormalize, recipe.clone)
        policy = self.model.policy
        if recipe.log_std is not None:
            policy.log_std.requires_grad_(False)
        self.policy, self.optimizer = policy, policy.optimizer
        self.kernel = self._kernel(update)
        # the recipe's tricks on the rows' arrays (agents.tricks, as the SB3 VecEnv path applies them)
        self.starts = ExploringStarts(**recipe.exploring) if recipe.exploring is not None else None
        self.shift = RewardShift(*recipe.reward_shift) if recipe.reward_shift is not None else None
        self.memory = FrameStack(recipe.frames) if recipe.frames > 1 else None
        self._rng = np.random.default_rng(self.seed)  # the starts' draws (reset() reseeds it)
        space = self.vec.single_action_space
        self._low, self._high = space.low.astype(np.float32), space.high.astype(np.float32)
        self._returns = np.zeros(recipe.n_envs)
        self._obs: np.ndarray | None = None
        self.cut_steps = 0  # env steps of the rollout a stop cut short (dropped)
        self.timing = {"env": 0.0, "forward": 0.0, "update": 0.0, "other": 0.0}
        self.scores: list[float] = []  # the finished episodes' scores (self.score) since the last read
        t, b = recipe.n_steps, recipe.n_envs
        obs_dim, act_dim = template.observation_space.shape[0], space.shape[0]
        self._buf = {
            "obs": torch.zeros(t, b, obs_dim), "actions": torch.zeros(t, b, act_dim),
            "logp": torch.zeros(t, b), "values": torch.zeros(t, b), "rewards": torch.zeros(t, b),
            "dones": torch.zeros(t, b),
        }  # fmt: skip

    def latest(self, obs: np.ndarray) -> np.ndarray:
        """The env's own observations (B, d) in the policy's ``obs`` (the newest frame of a memory)."""
        return obs if self.memory is None else self.memory.latest(obs)

    def _kernel(self, update: str) -> KernelUpdate | None:
        if update not in UPDATES:
            raise ValueError(f"update must be one of {', '.join(UPDATES)}, got {update!r}")
        if update == "torch" or (update == "auto" and not HAVE_NUMBA):
            return None
        if not HAVE_NUMBA:
            raise ValueError("update='kernel' needs numba (pip install ios-uav-env[fast])")
        kernel = KernelUpdate.of(self.policy, self.optimizer)
        if kernel is None and update == "kernel":
            raise ValueError(
                "update='kernel' covers separate tanh MLPs for the actor and critic with a Gaussian of "
                "state-independent std and plain Adam; this policy is not one (use update='torch')"
            )
        return kernel

    # --- the parts of one iteration ------------------------------------------------------
    @property
    def progress_remaining(self) -> float:
        """SB3's ``_current_progress_remaining``: 1 at the start, 0 at ``total`` steps."""
        return max(0.0, 1.0 - self.steps / max(1, self.total))

    def reset(self, seed: int | None = None) -> None:
        """Start every row's episode (row i seeded ``seed + i``; default the run's seed, shifted by
        the steps done so that a resumed run meets new episodes)."""
        base = self.seed if seed is None else seed
        self.base.seed(base + (self.steps // max(1, self.recipe.rollout_size)) * self.recipe.n_envs)
        obs = self.base.reset()
        if self.memory is not None:
            obs = self.memory.reset(obs)
        if self.vecnormalize is not None and self.vecnormalize.norm_obs:
            self.vecnormalize.obs_rms.update(obs)
        self._returns[:] = 0.0
        self._obs = obs
        self._rng = np.random.default_rng([self.seed, self.steps])
        if self.starts is not None:  # one generator: checkpoints keep its state (agents.fast.run)
            self.starts.rng = self._rng

    def _normalized_obs(self, obs: np.ndarray) -> np.ndarray:
        vn = self.vecnormalize
        return vn.normalize_obs(obs) if vn is not None and vn.norm_obs else obs

    def _forward(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """The Gaussian's mean and the value of ``obs`` (normalised observations)."""
        extractor = self.policy.mlp_extractor
        mean = self.policy.action_net(extractor.forward_actor(obs))
        value = self.policy.value_net(extractor.forward_critic(obs)).squeeze(-1)
        return mean, value

    def _log_prob(self, actions: torch.Tensor, mean: torch.Tensor) -> torch.Tensor:
        log_std = self.policy.log_std
        z = (actions - mean) * torch.exp(-log_std)
        return (-0.5 * z * z - log_std - 0.5 * math.log(2.0 * math.pi)).sum(-1)

    def _apply_schedules(self) -> None:
        r, done = self.recipe, 1.0 - self.progress_remaining
        if r.log_std is not None:
            with torch.no_grad():
                self.policy.log_std.fill_(r.log_std[0] + done * (r.log_std[1] - r.log_std[0]))
        if self.starts is not None and r.exploring_schedule is not None:
            self.starts.prob = scheduled_prob(self.starts.initial, done, *r.exploring_schedule)
        for group in self.optimizer.param_groups:
            group["lr"] = r.learning_rate(self.progress_remaining)

    def collect(self, stop: Any = None) -> bool:
        """One rollout of ``n_steps`` slots on every row into the buffers; False if ``stop()``
        became true (the rollout is then unfinished and must not be used)."""
        if self.kernel is None:
            return self._collect(stop)
        with self.kernel.one_blas_thread():
            return self._collect(stop)

    def _collect(self, stop: Any) -> bool:
        if self._obs is None:
            self.reset()
        self._apply_schedules()
        r, buf = self.recipe, self._buf
        obs, timing = self._obs, self.timing
        std = torch.exp(self.policy.log_std.detach())
        theta = self.kernel.parameters() if self.kernel is not None else None
        for t in range(r.n_steps):
            if stop is not None and stop():
                self.cut_steps = t * r.n_envs
                return False
            t0 = time.perf_counter()
            x = torch.from_numpy(np.asarray(self._normalized_obs(obs), dtype=np.float32))
            if theta is not None:  # the compiled forward pass (agents.fast.kernel.policy_step)
                noise = torch.randn(buf["actions"].shape[1:])
                actions, logp, value = (
                    torch.from_numpy(v) for v in self.kernel.act(theta, x.numpy(), noise.numpy())
                )
            else:
                with torch.no_grad():
                    mean, value = self._forward(x)
                    actions = mean + std * torch.randn_like(mean)
                    logp = self._log_prob(actions, mean)
            buf["obs"][t], buf["actions"][t], buf["logp"][t], buf["values"][t] = x, actions, logp, value
            t1 = time.perf_counter()
            clipped = np.clip(actions.numpy(), self._low, self._high)
            stepped = self.vec.step(clipped)
            t2 = time.perf_counter()
            obs, reward, dones = self._after_step(*stepped)
            buf["rewards"][t] = torch.from_numpy(np.asarray(reward, dtype=np.float32))
            buf["dones"][t] = torch.from_numpy(dones.astype(np.float32))
            t3 = time.perf_counter()
            timing["forward"] += t1 - t0
            timing["env"] += t2 - t1
            timing["other"] += t3 - t2
        self._obs = obs
        return True

    def _after_step(
        self, obs: np.ndarray, reward: Any, terminated: np.ndarray, truncated: np.ndarray,
        info: Mapping[str, Any], explore: bool = True,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
        """What the update keeps of one batched ``step``: (observations, rewards, dones), the
        finished episodes' scores recorded and their time-limit cuts bootstrapped, the exploring
        starts applied to the rows that ended (unless not ``explore``), the rewards shifted and
        normalised (:meth:`_normalized_rewards`)."""
        dones = terminated | truncated
        reward = np.asarray(reward, dtype=np.float64)
        if dones.any():
            reward = self._episode_ends(reward, terminated, truncated, info)
            if explore and self.starts is not None:
                obs = self.starts.apply(self.vec, dones, obs)
        if self.memory is not None:  # after the starts: a drawn row's history begins after its prefix
            obs = self.memory.step(obs, dones)
        return obs, self._normalized_rewards(obs, reward, dones), dones

    def _normalized_rewards(self, obs: np.ndarray, reward: np.ndarray, dones: np.ndarray) -> np.ndarray:
        """The slot's rewards as the update sees them (the recipe's shift, then ``VecNormalize``'s
        return scaling), updating the observation and return statistics with the slot."""
        vn = self.vecnormalize
        if self.shift is not None:
            reward = self.shift(reward)
        if vn is not None:
            if vn.norm_obs:
                vn.obs_rms.update(obs)
            if vn.norm_reward:
                self._returns = self._returns * vn.gamma + reward
                vn.ret_rms.update(self._returns)
            reward = vn.normalize_reward(reward)
            self._returns[dones] = 0.0
        return reward

    def _episode_ends(
        self, reward: np.ndarray, terminated: np.ndarray, truncated: np.ndarray, info: Mapping[str, Any]
    ) -> np.ndarray:
        """Record the finished episodes' scores; bootstrap the rows cut by a time limit (SB3's
        ``r += gamma V(final observation)``, with the value of the normalised final observation)."""
        final = info.get("final_info", {})
        mask = info.get("_final_info", terminated | truncated)
        if self.score.name in final:
            self.scores.extend(np.asarray(final[self.score.name])[mask & self._scored].tolist())
        cut = truncated & ~terminated
        if cut.any():
            last = np.asarray(info["final_obs"])[cut]
            if self.memory is not None:
                last = self.memory.final(np.flatnonzero(cut), last)
            x = torch.from_numpy(np.asarray(self._normalized_obs(last), dtype=np.float32))
            with torch.no_grad():
                reward = reward.copy()
                reward[cut] += self.recipe.gamma * self._forward(x)[1].numpy()
        return reward

    def update(self) -> dict[str, float]:
        """The PPO update on the collected rollout; its losses, the KL and the clip fraction."""
        t0 = time.perf_counter()
        r, buf = self.recipe, self._buf
        x = torch.from_numpy(np.asarray(self._normalized_obs(self._obs), dtype=np.float32))
        with torch.no_grad():
            last_values = self._forward(x)[1]
        rewards, values, dones = buf["rewards"], buf["values"], buf["dones"]
        advantages, returns = gae(rewards, values, dones, last_values, r.gamma, r.gae_lambda)
        n = r.rollout_size
        obs, actions = buf["obs"].reshape(n, -1), buf["actions"].reshape(n, -1)
        old_logp, advantages, returns = buf["logp"].reshape(n), advantages.reshape(n), returns.reshape(n)
        clip = r.clip_range(self.progress_remaining)
        if self.kernel is not None:
            orders = torch.stack([torch.randperm(n) for _ in range(r.n_epochs)]).numpy()
            arrays = (x.numpy() for x in (obs, actions, old_logp, advantages, returns))
            count, sums = self.kernel(
                *arrays, orders, r.batch_size, clip=clip, vf_coef=r.vf_coef, ent_coef=r.ent_coef,
                max_grad_norm=r.max_grad_norm, target_kl=r.target_kl,
                normalize_advantage=r.normalize_advantage,
            )  # fmt: skip
            stats = dict(zip(STAT_KEYS, sums.tolist(), strict=True))
        else:
            count, stats = self._torch_update(obs, actions, old_logp, advantages, returns, clip)
        self.steps += n
        self.updates += 1
        self.model.num_timesteps, self.model._total_timesteps = self.steps, self.total
        self.timing["update"] += time.perf_counter() - t0
        out = {key: value / max(count, 1) for key, value in stats.items()}
        out.update(learning_rate=float(self.optimizer.param_groups[0]["lr"]), clip_range=clip)
        return out

    def _torch_update(
        self, obs: torch.Tensor, actions: torch.Tensor, old_logp: torch.Tensor, advantages: torch.Tensor,
        returns: torch.Tensor, clip: float,
    ) -> tuple[int, dict[str, float]]:  # fmt: skip
        """The update's epochs on torch's autograd; (minibatches stepped, the sums of :data:`STAT_KEYS`)."""
        r, n = self.recipe, obs.shape[0]
        params = [p for p in self.policy.parameters() if p.requires_grad]
        stats = dict.fromkeys(STAT_KEYS, 0.0)
        count, stopped = 0, False
        for _ in range(r.n_epochs):
            order = torch.randperm(n)
            for start in range(0, n, r.batch_size):
                idx = order[start : start + r.batch_size]
                mean, value = self._forward(obs[idx])
                logp = self._log_prob(actions[idx], mean)
                log_ratio = logp - old_logp[idx]
                ratio = torch.exp(log_ratio)
                adv = advantages[idx]
                if r.normalize_advantage and adv.numel() > 1:
                    adv = (adv - adv.mean()) / (adv.std() + 1e-8)
                policy_loss = -torch.min(adv * ratio, adv * torch.clamp(ratio, 1.0 - clip, 1.0 + clip)).mean()
                value_loss = torch.mean((returns[idx] - value) ** 2)
                entropy = (self.policy.log_std + 0.5 * math.log(2.0 * math.pi * math.e)).sum()
                loss = policy_loss + r.vf_coef * value_loss - r.ent_coef * entropy
                with torch.no_grad():
                    kl = float(torch.mean(ratio - 1.0 - log_ratio))
                if r.target_kl is not None and kl > 1.5 * r.target_kl:
                    stopped = True
                    break
                self.optimizer.zero_grad(set_to_none=True)
                loss.backward()
                torch.nn.utils.clip_grad_norm_(params, r.max_grad_norm)
                self.optimizer.step()
                stats["policy_loss"] += float(policy_loss.detach())
                stats["value_loss"] += float(value_loss.detach())
                stats["approx_kl"] += kl
                stats["clip_fraction"] += float(torch.mean((torch.abs(ratio - 1.0) > clip).float()))
                count += 1
            if stopped:
                break
        return count, stats

    def take_scores(self) -> list[float]:
        """The scores (the value of the env's objective, :attr:`score`) of the episodes finished
        since the last call (and forget them)."""
        scores, self.scores = self.scores, []
        return scores

    def close(self) -> None:
        self.base.close()
