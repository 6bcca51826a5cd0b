"""A heuristic policy for the MISO-control suites, and the settings of their references.

:class:`DirectMRT` acts on the observation alone (bound to each scenario's
:class:`~ios_uav_env.benchmark.miso_suite.MisoTask`): the surface's phases are the observed aligned
phases (``miso_aligned_<k>_<m>``) of the user with the largest single-user gain share
(``miso_gain_share_<k>``), and user k's beam is MRT on its observed direct row
(``miso_direct_<k>_{re,im}_<n>``, w_k = conj(d_k) / ||d_k||), equal powers: blind to what the
surface adds to each user's channel.

The reference settings read the env's channels (what a controller that knows them sets; not a
policy of the observation): :func:`aligned_setting` (MRT or ZF, equal powers, with the best of the
K users' aligned phases: ``miso.baselines``' ``MRT aligned`` / ``ZF aligned`` as a setting) and
:func:`random_setting` (MRT with phases drawn uniformly). ``star_policies.setting_policy`` plays
any of them.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

import numpy as np

from ios_uav_env.benchmark.miso_suite import MisoTask
from ios_uav_env.model.miso import aligned_phases, mrt_beams, objective_value, random_phases, user_rates

__all__ = ["DirectMRT", "aligned_setting", "random_setting"]


class DirectMRT:
    """The best user's observed aligned phases, MRT on the direct rows (module docstring); ``bind``
    it to a scenario."""

    name = "the best user's aligned phases, MRT on the direct rows (heuristic, DirectMRT)"

    def __init__(self) -> None:
        self.task: MisoTask | None = None

    def bind(self, task: MisoTask) -> DirectMRT:
        """A copy that acts on ``task``'s scenario."""
        names = list(task.observation_names)
        bound = copy.copy(self)
        bound.task = task
        k, n_t = task.users, task.antennas
        bound._share = np.array([names.index(f"miso_gain_share_{u}") for u in range(k)])
        bound._aligned = np.array(
            [[names.index(f"miso_aligned_{u}_{m}") for m in range(task.M)] for u in range(k)]
        )
        bound._direct = np.array(
            [[[names.index(f"miso_direct_{u}_{p}_{n}") for n in range(n_t)] for p in ("re", "im")]
             for u in range(k)]
        )  # fmt: skip
        return bound

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        if self.task is None:
            raise ValueError("DirectMRT is unbound: bind it to the scenario (policy.bind(task))")
        o = np.asarray(obs, dtype=np.float64)
        best = int(np.argmax(o[self._share]))
        direct = o[self._direct]  # (K, 2, N_t): the unit direct rows' real and imaginary parts
        # w_k = conj(d_k): Re A[:, k] = Re d_k, Im A[:, k] = -Im d_k (the env normalises the power)
        return np.concatenate([direct[:, 0].ravel(), -direct[:, 1].ravel(), o[self._aligned[best]]])

    def __repr__(self) -> str:
        return "DirectMRT()"


def aligned_setting(env: Any, precoder: Callable[[np.ndarray], np.ndarray] = mrt_beams) -> Any:
    """(phases, beams) of the env's current slot: ``precoder`` (equal powers) with the best of the K
    users' aligned phases for the env's objective; None if ``precoder`` refuses every one (ZF when
    N_t < K)."""
    ch = env.channels[env.slot]
    best, value = None, -np.inf
    for k in range(ch.K):
        phases = aligned_phases(ch, k)
        H = ch.matrix(phases)
        try:
            beams = precoder(H)
        except ValueError:
            continue
        v = objective_value(user_rates(H, beams), env.objective)
        if v > value:
            best, value = (phases, beams), v
    return best


def random_setting(rng: np.random.Generator) -> Callable[[Any], tuple[np.ndarray, np.ndarray]]:
    """A setting function: MRT (equal powers) with phases drawn uniformly from ``rng`` every slot."""

    def setting(env: Any) -> tuple[np.ndarray, np.ndarray]:
        ch = env.channels[env.slot]
        phases = random_phases(ch, rng)
        return phases, mrt_beams(ch.matrix(phases))

    return setting
