"""``UAVEnv``: the one Gymnasium env of the single- and multi-node worlds."""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np

from ios_uav_env.envs.core.stepper import Stepper, choose_view, make_stepper, stepper_class
from ios_uav_env.model.config import ScenarioConfig

__all__ = ["UAVEnv"]


class UAVEnv(gym.Env):
    r"""A UAV flies from ``q0`` to ``qF`` in ``T`` seconds and serves K >= 1 ground nodes via a surface.

    ## Description

    The scenario of Liu et al. (IEEE WCL 2022; the model: ``docs/model.md``) and its extensions: a
    surface (IOS, RIS, STAR or none), K ground nodes (static or walking, known exactly or through
    reports), the objective (the rate, max-min for K > 1, or the energy efficiency), the UAV's
    antennas (``antennas``: N_t > 1 with the beam and the surface's phases set by the env at their
    closed-form optimum, ``MISOUAV-v0``). One step is one slot; the episode ends at slot N. Every
    single- and multi-node id of ``ios_uav_env.envs.registration`` is this class with a preset: its
    keywords (the world's scenario fields and options, ``view``, ``action``, ``draws``). The world
    runs in a *stepper* (``ios_uav_env.envs.core.stepper``) chosen by the view; this class is the
    Gymnasium face over it (reset, step, render, seeding, copying, pickling).
    ``env.unwrapped.stepper`` is it, and every attribute this class does not hold is the stepper's
    (``config``, ``options``, ``trajectory``, ``observation_names``, ``paths``, ``shares``, the row
    protocol's calls, ...).

    ## Action Space

    By the view's action type (``core.stepper.VIEWS``): ``"move"``, ``Box(-1, 1, (2,),
    float32)``, the slot's displacement in units of D = v_max dt (the v0 view); ``"move_scores"``,
    ``Box(-1, 1, (2 + K_max,), float32)``, the displacement and one score per node slot, whose
    softmax are the slot's TDMA shares (the node-block view). The contracts: ``IOSUAVEnv`` and
    ``MultiNodeEnv``.

    ## Observation Space

    By the view: ``"v0"`` (one node): the 11 v0 features, then as asked the 6 instance
    features, the 4 energy features (the energy objective) and the 3 of the peak hint
    (``IOSUAVEnv``, ``RandomIOSUAVEnv``); ``"node_blocks"`` (K >= 1 nodes): 12 base features
    and one block per node slot (``MultiNodeEnv``). ``env.unwrapped.observation_names`` holds
    the components' names (``ios_uav_env.envs.observation_layout``).

    ## Rewards, Starting State, Episode End, Info

    The stepper's: ``IOSUAVEnv`` (the v0 view) and ``MultiNodeEnv`` (the node blocks). Every
    episode ends with ``terminated=True`` at slot N; no id registers a ``TimeLimit``.
    ``reset(options={"config": cfg})`` runs one episode on ``cfg`` when it fits the spaces.

    ## Arguments

    - ``config``: the scenario (a ``ScenarioConfig`` or a dict of its fields).
    - ``view``: ``"v0"`` (None: the default) or ``"node_blocks"`` (K >= 1 nodes; the v0 view
      refuses several nodes, naming the multi-node ids).
    - ``action``: the view's action type (None: the view's; another is refused).
    - ``draws`` (False): the v0 view draws a new scenario at every reset from ``ranges``
      (``RandomIOSUAVEnv``'s arguments: ``ranges``, ``focus``, ``focus_prob``, and the instance
      features on by default).
    - ``render_mode``: None or ``"rgb_array"``.
    - ``**kwargs``: the stepper's (``EnvOptions`` fields, ``ScenarioConfig`` fields, and the
      view's own: ``IOSUAVEnv``, ``RandomIOSUAVEnv``, ``MultiNodeEnv``), checked as those
      classes check them.

    ```python
    >>> import gymnasium as gym
    >>> import ios_uav_env
    >>> env = gym.make("ios_uav_env/IOSUAV-v0")
    >>> type(env.unwrapped).__name__, env.unwrapped.view, env.observation_space.shape
    ('UAVEnv', 'v0', (11,))
    >>> env = gym.make("ios_uav_env/IOSUAV-MultiNode-v0")
    >>> env.unwrapped.view, env.action_space.shape
    ('node_blocks', (5,))

    ```

    ## Version History

    * v0: the ids of ``IOSUAVEnv``, ``RandomIOSUAVEnv`` and ``MultiNodeEnv``, their episodes,
      observations, ``info`` keys and rewards unchanged, made by this one class; then the
      multi-antenna id ``MISOUAV-v0`` (``IOSUAVEnv``'s view with ``antennas=4``).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}
    #: The keywords a preset subclass fixes (``IOSUAVEnv``, ``RandomIOSUAVEnv``, ``MultiNodeEnv``).
    preset: dict[str, Any] = {}

    @classmethod
    def stepper_class(cls, **kwargs: Any) -> type:
        """The stepper class an env of this class made with these keywords runs (the arguments it
        takes besides this class's own: e.g. for tools that read an id's arguments)."""
        kwargs = {**cls.preset, **kwargs}
        return stepper_class(choose_view(kwargs.get("view")), bool(kwargs.get("draws")))

    def __init__(
        self,
        config: ScenarioConfig | Mapping[str, Any] | None = None,
        *,
        view: str | None = None,
        action: str | None = None,
        draws: bool = False,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        #: The stepper that runs the world (``core.stepper.make_stepper``).
        self.stepper: Stepper = make_stepper(
            self, config, view, action, draws, {"render_mode": render_mode, **kwargs}
        )
        #: The observation view (``"v0"``, ``"node_blocks"``) and the action type it is read with.
        self.view: str = self.stepper.view
        self.action: str = self.stepper.action
        #: Whether each reset of the v0 view draws its scenario (``RandomIOSUAVEnv``'s ids).
        self.draws = bool(draws)
        self.observation_space = self.stepper.observation_space
        self.action_space = self.stepper.action_space
        self.render_mode = render_mode

    def begin_episode(self, seed: int | None, options: dict[str, Any] | None) -> ScenarioConfig:
        """The scenario part of ``reset`` (the row protocol's first call: the stepper's)."""
        return self.stepper.begin_episode(seed, options)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        self.stepper.begin_episode(seed, options)
        return self.stepper.start()

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        return self.stepper.step(action)

    def render(self) -> np.ndarray | None:
        """The episode so far as an (H, W, 3) uint8 array (``render_mode="rgb_array"``; the view's
        frame: the trajectory over the rate map, or over the best node's with every node)."""
        return self.stepper.render()

    def close(self) -> None:
        self.stepper.close()

    def __getattr__(self, name: str) -> Any:
        """Every attribute this class does not hold is its stepper's (class docstring), but for
        ``env``: the stepper's ``env`` is this env, and wrappers and tools walk ``.env`` down to the
        base env (a base env has none), so forwarding it would make the walk endless."""
        if name.startswith("__") or name in ("stepper", "env"):  # (unpickling, copying: no stepper yet)
            raise AttributeError(name)
        return getattr(self.stepper, name)

    def __copy__(self) -> UAVEnv:
        """A copy with a stepper of its own (a shallow copy of this one's), bound to the copy: what
        the batched env makes of its template for each row."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        stepper = copy.copy(self.stepper)
        stepper.env = new
        new.stepper = stepper
        return new
