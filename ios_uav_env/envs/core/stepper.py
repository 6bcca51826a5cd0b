"""The steppers: what ``UAVEnv`` asks of the object that runs its world, and the one place that
chooses it.

A *stepper* holds one episode's state and runs it: the scenario at reset, the compiled step on a
batch of one, the observation of its view, ``info``, the trajectory and the frame. ``UAVEnv`` is
the Gymnasium face over it (``reset``, ``step``, ``render``, seeding, pickling, copying); the
batched env reads each row's stepper through the row protocol (``ios_uav_env.envs.row_protocol``).

Each observation view comes with the action type it is read with (:data:`VIEWS`):

- ``"v0"``, read with ``"move"`` (``Box(-1, 1, (2,))``): ``single_node.SingleNodeStepper``
  (``draws=True``: ``single_drawn.DrawnSingleNodeStepper``); the 11 v0 features, then as asked
  the instance features, the energy features and the peak hint (``observation_names``);
- ``"node_blocks"``, read with ``"move_scores"`` (``Box(-1, 1, (2 + K_max,))``):
  ``multi_node.MultiNodeStepper``; ``BASE_FEATURES``, one block per node slot
  (``node_block_names``), then the energy features;
- ``"star_noma"``, read with ``"move_weight"`` (``Box(-1, 1, (3,))``: the move and user 0's weight):
  ``star_noma.StarNomaStepper``; a STAR surface serving a user on each side by NOMA;
- ``"miso_sdma"``, read with ``"move_weight"`` as ``"star_noma"`` (for K > 2 users ``Box(-1, 1,
  (2 + K,))``: the move and one weight per user): ``miso_sdma.MisoSdmaStepper``; a multi-antenna UAV
  serving K = 2 to 4 users at once (SDMA).

:func:`choose_view` checks the view (``"v0"`` when none is given) and :func:`make_stepper` builds
the stepper: the only branching on the kind of world in the env
faces (the stepper itself refuses the worlds it does not run, ``settings.check_world``).
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import gymnasium as gym
import numpy as np

from ios_uav_env.envs.miso_sdma import MisoSdmaStepper
from ios_uav_env.envs.multi_node import MultiNodeStepper
from ios_uav_env.envs.single_drawn import DrawnSingleNodeStepper
from ios_uav_env.envs.single_node import SingleNodeStepper
from ios_uav_env.envs.star_noma import StarNomaStepper
from ios_uav_env.model.config import ScenarioConfig

__all__ = ["VIEWS", "Stepper", "choose_view", "make_stepper", "stepper_class"]

#: view -> the action type it is read with.
VIEWS: dict[str, str] = {
    "v0": "move", "node_blocks": "move_scores", "star_noma": "move_weight", "miso_sdma": "move_weight",
}  # fmt: skip


@runtime_checkable
class Stepper(Protocol):
    """What ``UAVEnv`` calls on its stepper (every stepper also makes its row protocol's calls)."""

    view: str
    action: str
    config: ScenarioConfig
    observation_space: gym.spaces.Box
    action_space: gym.spaces.Box
    observation_names: tuple[str, ...]
    render_mode: str | None

    def begin_episode(self, seed: int | None, options: dict[str, Any] | None) -> ScenarioConfig:
        """The scenario part of ``reset``: seed the env's ``np_random``, choose, check and make
        current the episode's scenario (row protocol)."""
        ...

    def start(self) -> tuple[np.ndarray, dict[str, Any]]:
        """The rest of ``reset``: the episode's first observation and ``info``."""
        ...

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One slot: Gymnasium's (observation, reward, terminated, truncated, ``info``)."""
        ...

    @property
    def trajectory(self) -> np.ndarray:
        """The way-points so far, (n + 1, 2) m."""
        ...

    def render(self) -> np.ndarray | None:
        """The frame of the episode so far (``render_mode="rgb_array"``)."""
        ...

    def close(self) -> None:
        """Release what rendering holds."""
        ...


def choose_view(view: str | None) -> str:
    """The observation view of a ``UAVEnv`` made with ``view``: one of :data:`VIEWS`, None taking
    ``"v0"`` (so the fixed single-node ids register only their world's keywords)."""
    if view is None:
        return "v0"
    if view not in VIEWS:
        raise ValueError(f"view must be one of {sorted(VIEWS)}, got {view!r}")
    return view


def stepper_class(view: str, draws: bool = False) -> type:
    """The stepper class of a view (one of :data:`VIEWS`; ``draws``: the v0 view's draws)."""
    if view == "node_blocks":
        return MultiNodeStepper
    if view == "star_noma":
        return StarNomaStepper
    if view == "miso_sdma":
        return MisoSdmaStepper
    return DrawnSingleNodeStepper if draws else SingleNodeStepper


def make_stepper(
    env: gym.Env, config: Any, view: str | None, action: str | None, draws: bool, kwargs: dict[str, Any]
) -> Stepper:
    """The stepper of ``env`` for these arguments (:func:`choose_view`; ``action`` must be the
    view's, None taking it; ``draws``: a new scenario at every reset, the v0 view's randomised
    ids; the node-block view draws with ``random_nodes``)."""
    view = choose_view(view)
    if action is not None and action != VIEWS[view]:
        raise ValueError(f"action must be {VIEWS[view]!r}, the action of the view {view!r}, got {action!r}")
    if not isinstance(draws, (bool, np.bool_)):
        raise ValueError(f"draws must be True or False, got {draws!r}")
    if view != "v0" and draws:
        raise ValueError(
            "draws is the v0 view's scenario draw; the node-block view draws with random_nodes=(low, high), "
            "the star_noma and miso_sdma views with random_line=True"
        )
    cls = stepper_class(view, draws)
    if cls is DrawnSingleNodeStepper:  # (its first argument is the family it draws from)
        return cls(env, kwargs.pop("ranges", None), config=config, **kwargs)
    return cls(env, config, **kwargs)
