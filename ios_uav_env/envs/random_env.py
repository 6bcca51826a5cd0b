"""Randomised scenarios: one policy for every instance of a family, drawn at each reset.

``RandomIOSUAVEnv`` (a preset of ``UAVEnv``: ``view="v0"``, ``draws=True``; the id
``ios_uav_env/IOSUAV-Random-v0`` is ``UAVEnv`` with those keywords) draws a new scenario
at every reset from a family ``ios_uav_env.model.scenarios.ScenarioRanges`` with its
``np_random``, observing the instance through the 6 instance features of ``IOSUAVEnv``.
``ios_uav_env/STARUAV-Random-v0`` is the same family with every scenario on a STAR surface
(``surface="star"``: ``ScenarioRanges.with_surface``); ``gym.make("ios_uav_env/STARUAV-Random-v0",
star_bits=2)`` draws it with 2-bit phases (the field applied to ``ranges.base``: every drawn
scenario's surface sets the node's exact 2-bit phases in every slot, ``IOSUAVEnv``'s "Rewards").
``ios_uav_env/IOSUAV-Energy-Random-v0`` is the same family with the objective
``"energy_efficiency"`` (``objective`` applied to ``ranges.base``): the energy features, reward
and score of ``IOSUAVEnv``'s "Energy", with lambda_ref the reference of each drawn scenario.
``ios_uav_env/IOSUAV-Mobile-v0`` is the same family with a walking node (``motion`` applied to
``ranges.base``) known through noisy reports (``knowledge="reports"``): ``IOSUAVEnv``'s "Moving
nodes". It takes the energy objective too (``gym.make("ios_uav_env/IOSUAV-Mobile-v0",
objective="energy_efficiency")``): lambda_ref is then each episode's, the scenario's reference
flights scored on the node's drawn path (``IOSUAVEnv``'s "Energy").
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ios_uav_env.envs.core.env import UAVEnv
from ios_uav_env.model.scenarios import DEFAULT_RANGES, RANGED_FIELDS, ScenarioRanges, sample_scenario

__all__ = ["DEFAULT_RANGES", "RANGED_FIELDS", "RandomIOSUAVEnv", "ScenarioRanges", "sample_scenario"]


class RandomIOSUAVEnv(UAVEnv):
    r"""``IOSUAVEnv`` on a new scenario at every reset, drawn from documented ranges.

    ``UAVEnv`` with the view ``"v0"`` and ``draws=True`` (a preset: the randomised single-node
    ids are ``UAVEnv`` with these keywords, ``registration``); the stepper is
    ``single_drawn.DrawnSingleNodeStepper``.

    ## Description

    On the paper's single scenario a planner solves the problem in seconds and an agent only
    memorises one trajectory; here every episode is a new instance of the family
    ``ranges`` (a :class:`ScenarioRanges`, default :data:`DEFAULT_RANGES`), so a policy has
    to plan for scenarios it has never seen. Default ranges (uniform): G at x in
    [-250, 250] m, y in [-150, 150] m; T in [60, 200] s (whole slots); M_z in [20, 60] IOS
    rows of M_y = 100 columns (M = 2000 ... 6000); surface "ios" or "ris" (or ``surface``); q0 = (-400, y0),
    qF = (400, yF) with y0, yF in [-100, 100] m; every other field at the paper's default.
    Everything else (the model, the arrival guard, the rewards, ``info``, the trajectory
    checks) is ``IOSUAVEnv``'s, on the episode's scenario ``env.unwrapped.config``.

    ## Action Space

    As ``IOSUAVEnv``: ``Box(-1, 1, (2,), float32)``, the displacement of the slot in units
    of D = v_max dt (projected onto the unit disk, then by the arrival guard).

    ## Observation Space

    A float32 ``ndarray`` of shape (17,): ``IOSUAVEnv``'s 11 components (names in
    ``OBS_NAMES``) and, with ``instance_features=True`` (the default here), the 6 instance
    features (names in ``INSTANCE_NAMES``). L = ``length_scale`` (400 m), q the UAV
    position, m the moves left, d_F = |qF - q|, N the episode's slot count.

    | Num | Observation                                            | Min | Max   |
    |-----|--------------------------------------------------------|-----|-------|
    | 0-1 | UAV position q / L                                     | -B  | B     |
    | 2-3 | final point, (qF - q) / L                              | -B  | B     |
    | 4-5 | ground node, (w_G - q) / L                             | -B  | B     |
    | 6-7 | IOS centre, (x_c - x, y_c - y) / L                     | -B  | B     |
    | 8   | time left, m / (N - 1)                                 | 0   | 1     |
    | 9   | slack s / (1 + abs(s)), s = m - d_F / D                | -1  | 1     |
    | 10  | expected-gain rate r(q) (bps/Hz)                       | 0   | r_max |
    | 11  | elements, M / 6000 (0 without a surface)               | 0   | 1     |
    | 12  | surface is the IOS (0 or 1)                            | 0   | 1     |
    | 13  | surface is a RIS (0 or 1)                              | 0   | 1     |
    | 14  | transmissive factor t / (1 + t) (IOS: epsilon, else 0) | 0   | 1     |
    | 15  | horizon, T / 200 s                                     | 0   | 1     |
    | 16  | seconds left, m dt / 200 s                             | 0   | 1     |

    Every point is relative to the UAV, so the values are O(1) on every scenario (with the
    guard the UAV stays within its reach of q0 and qF). The bounds hold for every scenario
    of the ranges: B is the largest value at q0 over the ranges plus (N_max - 1) D / L (no
    UAV gets farther, guard or not); r_max bounds the rate for any G
    (:func:`~ios_uav_env.envs.observation.ground_free_rate_bound`, over the ranges' surfaces and
    sizes); the maxima of 11, 15, 16 are those of the ranges, at least 1 (with margins of
    1e-6). Both env checkers pass; the observation's shape does not depend on the scenario.
    ``env.unwrapped.observation_names`` holds the names of the components, in order.

    ## Rewards

    As ``IOSUAVEnv``: the rate at the new position, minus the reach and terminal penalties
    (0 with the guard). The return is N R - r(q0); N varies per episode, so compare
    episodes by ``info["average_rate"]`` (eq. (9)). With the objective ``"energy_efficiency"``
    (the energy id) the energy term of ``IOSUAVEnv``'s "Energy" joins it, lambda_ref being each
    scenario's own reference (a moving node's: on each episode's drawn path; or
    ``energy_reference``), and episodes compare by
    ``info["energy_efficiency"]``; the observation then has 4 energy features after the 6
    instance features (shape (21,)).

    ## Starting State

    A scenario drawn by :func:`sample_scenario` from ``np_random`` (so ``reset(seed=s)``
    fixes it; the same seed gives the same scenarios), the UAV at its q0, slot 1.
    ``reset(options={"config": cfg})`` pins that episode to ``cfg`` instead (a
    ``ScenarioConfig`` or a dict of its fields; no other key); a ``cfg`` whose observations
    could leave the space (e.g. T > 200 s, G far outside the ranges) is refused with
    ``ValueError``. ``config=cfg`` at construction pins every episode (still observed in
    the ranges' space: a trained generalist evaluated on ``cfg``). Before the first reset
    ``config`` is ``ranges.base``.

    ## Episode End

    ``terminated=True`` at slot N of the episode's scenario (60 to 200 slots by default):
    after N - 1 steps, 59 to 199. The id registers no ``TimeLimit``.

    ## Arguments

    - ``ranges``: a :class:`ScenarioRanges` or a dict of its fields (default: the above).
    - ``config``: None (draw at every reset) or a scenario that every episode runs on.
    - ``focus`` (None) and ``focus_prob`` (0): narrower ranges inside ``ranges`` (a dict of
      the fields that differ, e.g. ``{"ground_x": (-150, 150), "ground_y": (-60, 60)}``),
      drawn instead with probability ``focus_prob``: a training distribution that visits
      more often the scenarios where the surface changes the best plan. The observation
      space stays that of ``ranges``. Each needs the other (``focus_prob`` > 0), and ``focus``
      is refused with ``config`` (never drawn): ``ValueError``.
    - ``instance_features`` (True), ``peak_hint`` (False: with True, 3 more components,
      the reachable rate peak; see ``IOSUAVEnv``), ``channel``, ``arrival_guard``, ``reach_weight``,
      ``terminal_weight``, ``length_scale``, ``render_mode``: as ``IOSUAVEnv``.
    - ``surface`` (None): every drawn scenario's surface (``ranges.with_surface(surface)``; the
      id ``ios_uav_env/STARUAV-Random-v0`` sets ``"star"``), and a pinned ``config``'s: as a fixed
      id's keyword, ranges (or a config) left at the default surfaces take it, and ranges (or a
      config) that chose another are refused with ``ValueError`` (``settings.check_ranges_surface``).
    - ``**overrides``: ``ScenarioConfig`` fields that the ranges do not draw (e.g.
      ``v_max``, ``alpha``, a STAR surface's ``star_bits``), applied to ``ranges.base``; a drawn field (``T``,
      ``ground_node``, ``q0``, ``qF``, ``ios_shape``) raises ``ValueError``:
      change ``ranges`` instead.

    ```python
    >>> import gymnasium as gym
    >>> import ios_uav_env
    >>> env = gym.make("ios_uav_env/IOSUAV-Random-v0")
    >>> obs, info = env.reset(seed=0)
    >>> obs.shape, env.unwrapped.config.N >= 60
    ((17,), True)
    >>> cfg = ios_uav_env.ScenarioConfig(T=100)
    >>> obs, info = env.reset(options={"config": cfg})
    >>> env.unwrapped.config == cfg
    True

    ```

    ## Version History

    * v0: Initial version; later, without changing its episodes: b-bit phases on the STAR
      surface (``star_bits``, ``STARUAV-Random-v0``).
    """

    preset = {"view": "v0", "draws": True}

    def __init__(self, ranges: ScenarioRanges | Mapping[str, Any] | None = None, **kwargs: Any) -> None:
        super().__init__(**self.preset, ranges=ranges, **kwargs)
