"""A policy that raises while it is scored: the error names where.

:class:`NamedPolicy` wraps a policy's action function for the scorer, which tells it the
scenario of each episode; an exception of the policy is raised again as :class:`PolicyError`,
naming the suite, the scenario (its index, and its episode seed on a mobile suite) and the
policy, with the policy's own exception chained (``__cause__``: its traceback is kept).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ios_uav_env.envs.rollout import decision_interval


class PolicyError(RuntimeError):
    """A policy raised while it was scored; ``__cause__`` is its exception."""


def where(scenario: Any) -> str:
    """``"scenario 3"`` (``"scenario 3 (episode seed 7)"`` on a mobile suite)."""
    seed = getattr(scenario, "seed", None)
    return f"scenario {scenario.index}" + ("" if seed is None else f" (episode seed {seed})")


class NamedPolicy:
    """``act`` (an action function) whose exceptions name the suite, the scenario and the policy.

    The scorer calls :meth:`at` before each episode; ``repeat``, ``batched`` and ``check_env``
    are ``act``'s (or its object's, for a bound method)."""

    def __init__(self, act: Callable[[np.ndarray], Any], suite: str, policy: str) -> None:
        self.act, self.suite, self.policy = act, suite, policy
        owner = getattr(act, "__self__", act)  # a bound method's object: what runners ask
        self.repeat = decision_interval(act)
        self.batched = bool(getattr(owner, "batched", False))
        if callable(getattr(owner, "check_env", None)):  # an agent's check of the env it runs in
            self.check_env = owner.check_env
        self.place = "its first episode"

    def at(self, scenario: Any, warm_up: bool = False) -> NamedPolicy:
        """The episode of ``scenario`` comes next (``warm_up``: the unscored warm-up episode)."""
        self.place = where(scenario) + (" (the unscored warm-up episode)" if warm_up else "")
        return self

    def at_once(self, scenarios: Sequence[Any]) -> NamedPolicy:
        """The scenarios come next as the rows of one batch."""
        indices = [s.index for s in scenarios]
        self.place = f"the batch of scenarios {indices[0]}..{indices[-1]} at once" if indices else "a batch"
        return self

    def __call__(self, obs: np.ndarray) -> Any:
        try:
            return self.act(obs)
        except PolicyError:
            raise
        except Exception as err:  # the policy's own error: raised again with where it happened
            raise PolicyError(
                f"the policy {self.policy!r} raised {type(err).__name__} on {self.place} of suite "
                f"{self.suite}: {err}"
            ) from err
