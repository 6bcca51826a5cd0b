"""The row protocol: what a batched env asks of the single env whose episodes it batches.

A batched env (``ios_uav_env.envs.batched.BatchedEnv``) holds one *row env* per row, a copy of
the single env (its ``env_class``) with a generator of its own. The row env owns what makes an
episode: its ``np_random``, its scenario draws, pinned scenarios and their checks and, for moving
or roughly known nodes, the node paths, reports and measured rates; the batched env owns the
arrays and the kernels. They meet only in the public calls below, which the single envs make on
themselves in their own ``reset`` and ``step`` too: so row i of a batch is the single env seeded
``seed + i``, draw for draw. As Gymnasium documents its vector API, the protocol is documented
here once, as ``typing.Protocol`` classes (``runtime_checkable``: ``isinstance`` checks the names).

Every row env (:class:`ScenarioRow`; what ``BatchedEnv`` calls):

- ``begin_episode(seed, options) -> ScenarioConfig``: the scenario part of ``reset``. It seeds
  ``np_random`` (None: keeps the generator), chooses the episode's scenario (``options
  ["config"]`` when pinned, else a draw or the env's own), checks it, makes it ``config`` and
  returns it, without stepping or observing. ``BatchedEnv`` calls it with row i's seed and
  options at ``reset``, and with ``(None, None)`` at each autoreset and ``restart``.
- ``config``: the current episode's scenario (``N`` and ``D`` bound ``fly``'s flights).
- ``np_random``: Gymnasium's generator (each row gets its own at construction).
- ``check_scenario(cfg, field)``, optional: raise ``ValueError`` naming ``field`` unless
  ``cfg`` can be an episode of the env. ``BatchedEnv`` checks every scenario a ``reset``
  pins with it before any row resets; an env without it takes pinned scenarios as given.

A row env is a ``UAVEnv`` (``ios_uav_env.envs.core.env``): the calls below are its stepper's
(``UAVEnv.stepper``; the env forwards them, and the batched rows read them on the stepper). One
ground node (:class:`SingleNodeRow`: the view ``"v0"``; what ``single_rows.SingleNodeRows``
calls): the current scenario as one kernel row (``kernel``, ``episode_row``, ``flags``,
``base_config``, ``max_slots``, ``options``) and, for a ``mobile`` env only, after
``begin_episode``: ``start_track(cfg)`` draws the episode's node path, ``track`` holds each slot's
rate kernel and the records, ``observe_slot(slot, q, obs)`` writes what the UAV is told after the
slot (the batched env tells all its rows in compiled calls on their ``track`` arrays instead,
``knowledge_kernels``, with ``rate_clip``). A randomised moving env (``mobile_draws.takes_drawn_episodes``)
may skip ``begin_episode`` and ``start_track`` without options: its rows draw their episodes from
the row env's ``np_random`` together (``mobile_draws.DrawnEpisodes``, the same draws) and
``defer_episode(source, i)`` makes the row env build its scenario, kernel and track from them
when first read.

K >= 1 nodes (:class:`MultiNodeRow`: the view ``"node_blocks"``; what ``node_rows.NodeBlockRows``
calls): the settings of the kernels' rows (``max_nodes``, ``options``, ``share_sharpness``,
``softmin_beta``, ``energy_objective``, ``served_clip``, ``info_keys``) and, on row ``i`` of a
``multi_kernels.NodeRows``: ``load_row(rows, i)`` after ``begin_episode``, ``prepare_slot(rows,
i)`` before each step, ``observe_slot(rows, i, obs)`` after the start and each step (moving or
roughly known nodes; nothing otherwise), and ``mobile`` and ``truth`` for the episode's score.
``NodeBlockRows`` makes ``prepare_slot`` only where it draws (channel "rician"): it swaps
in its moving rows' kernels and tells them what they observe in compiled calls on their
``track`` arrays (``nodes_kernels``, with ``rate_clip`` and ``node_features``). A randomised
moving env (``node_draws.takes_drawn_nodes``) may skip ``begin_episode`` and ``load_row``
without options, as the single node's: ``defer_episode(source, i)`` (its rows drew the episodes
from the row env's ``np_random``, ``node_draws.DrawnNodeEpisodes``), then
``put_first_kernels(rows, i)`` for a row whose kernels the batch does not compute.

A batched ``reset(seed=..., options=...)`` becomes the rows' ``begin_episode`` arguments by
:func:`row_seeds` and :func:`rows_options` (every pinned scenario checked before any row resets).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

from ios_uav_env.model.config import ScenarioConfig, as_config

if TYPE_CHECKING:
    from ios_uav_env.envs.knowledge import NodesTrack, NodeTrack
    from ios_uav_env.envs.multi_kernels import NodeRows
    from ios_uav_env.envs.options import EnvOptions
    from ios_uav_env.model.channel import RateKernel

__all__ = ["MultiNodeRow", "ScenarioRow", "SingleNodeRow", "pinned_scenario", "row_seeds", "rows_options"]


@runtime_checkable
class ScenarioRow(Protocol):
    """What every row env offers ``BatchedEnv`` (the module's docstring; ``check_scenario`` is
    optional and not listed here)."""

    config: Any
    np_random: np.random.Generator

    def begin_episode(self, seed: int | None, options: dict[str, Any] | None) -> Any:
        """Seed ``np_random`` (None: keep it), choose the episode's scenario (pinned by
        ``options``, drawn, or the env's own), check it, make it ``config`` and return it; no
        step, no observation (the rest of ``reset`` is the batched env's kernel)."""
        ...


@runtime_checkable
class SingleNodeRow(ScenarioRow, Protocol):
    """A one-node row env (``UAVEnv`` of the view ``"v0"``), as ``SingleNodeRows`` uses it."""

    config: ScenarioConfig
    kernel: RateKernel
    options: EnvOptions
    mobile: bool

    @property
    def base_config(self) -> ScenarioConfig:
        """The construction scenario (a plain reset of a fixed id keeps this very object)."""
        ...

    @property
    def episode_row(self) -> np.ndarray:
        """The current scenario's episode constants, one kernel row."""
        ...

    @property
    def flags(self) -> np.ndarray:
        """The kernel's option flags."""
        ...

    @property
    def max_slots(self) -> int:
        """The most slots N of any episode the env's space holds."""
        ...

    def check_scenario(self, cfg: ScenarioConfig, field: str = ...) -> None:
        """Raise ``ValueError`` naming ``field`` unless ``cfg`` can be an episode of the env."""
        ...

    def start_track(self, cfg: ScenarioConfig) -> None:
        """(Mobile.) Draw the episode's node path on ``cfg`` from ``np_random`` into ``track``."""
        ...

    @property
    def track(self) -> NodeTrack | None:
        """(Mobile.) The episode's node track: ``track.nodes[n]``, ``track.params[n]`` is the rate
        kernel of slot n (0-based); None for a static, exactly known node."""
        ...

    def observe_slot(self, slot: int, q: np.ndarray, obs: np.ndarray) -> None:
        """(Mobile.) Write what the UAV at ``q`` is told of the node in ``slot`` into ``obs``."""
        ...

    def defer_episode(self, source: Any, i: int) -> None:
        """(Mobile.) Take the episode row ``i`` of ``source`` drew for this env (its ``np_random``'s
        draws): ``config``, ``kernel``, ``episode_row`` and ``track`` built from it when first read."""
        ...


@runtime_checkable
class MultiNodeRow(ScenarioRow, Protocol):
    """A K-node row env (``UAVEnv`` of the view ``"node_blocks"``), as ``NodeBlockRows`` uses it."""

    config: ScenarioConfig
    options: EnvOptions
    max_nodes: int
    share_sharpness: float
    softmin_beta: float
    energy_objective: bool
    served_clip: float
    info_keys: tuple[str, ...]
    mobile: bool

    def check_scenario(self, cfg: ScenarioConfig, field: str = ...) -> None:
        """Raise ``ValueError`` naming ``field`` unless ``cfg`` can be an episode of the env."""
        ...

    def load_row(self, rows: NodeRows, i: int) -> None:
        """Put the episode just begun in row ``i`` of ``rows`` (scenario, node paths, lambda_ref,
        slot 1's fading)."""
        ...

    def prepare_slot(self, rows: NodeRows, i: int) -> None:
        """Ready row ``i`` for its next step (the slot's node kernels and fading)."""
        ...

    def observe_slot(self, rows: NodeRows, i: int, obs: np.ndarray) -> None:
        """Write what the UAV is told of the nodes in row ``i``'s slot into ``obs`` (mobile)."""
        ...

    @property
    def track(self) -> NodesTrack | None:
        """The episode's node tracks; None for static, exactly known nodes."""
        ...

    @property
    def rate_clip(self) -> float:
        """bps/Hz, where a measured rate is clipped in the observation."""
        ...

    @property
    def truth(self) -> np.ndarray | None:
        """(N, K, 2) m: the episode's true node paths (None for static, exactly known nodes)."""
        ...

    def defer_episode(self, source: Any, i: int) -> None:
        """(Mobile.) Take the episode row ``i`` of ``source`` drew for this env (its ``np_random``'s
        draws): ``config`` and ``track`` built from it when first read."""
        ...

    def put_first_kernels(self, rows: NodeRows, i: int) -> None:
        """(Mobile.) Put the track's node kernels of the first slot in row ``i`` of ``rows``."""
        ...


# --- a batched reset's arguments as the rows' begin_episode arguments ---------------------------
def _is_integer(value: Any) -> bool:
    """Whether ``value`` is an integer (Python's or numpy's; a bool is not one)."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def row_seeds(seed: Any, num_envs: int) -> list[int | None]:
    """Each row's reset seed: None, ``seed + i`` for an integer ``seed``, or the i-th of a list
    of ``num_envs`` seeds (``ValueError`` naming the entry unless each is None or an integer >= 0)."""
    b = num_envs
    allowed = f"None, an integer >= 0 (row i is seeded with seed + i) or a list of {b} integers >= 0"
    if seed is None:
        return [None] * b
    if _is_integer(seed):
        if seed < 0:
            raise ValueError(f"seed must be {allowed}, got {seed!r}")
        return [int(seed) + i for i in range(b)]
    if isinstance(seed, (str, bytes, Mapping)) or not isinstance(seed, (Sequence, np.ndarray)):
        raise ValueError(f"seed must be {allowed}, got {seed!r}")
    seeds = list(seed)
    if len(seeds) != b:
        raise ValueError(f"seed must be an int or {b} seeds (one per env), got {len(seeds)}")
    for i, value in enumerate(seeds):
        if not (value is None or (_is_integer(value) and value >= 0)):
            raise ValueError(f"seed[{i}] must be None or an integer >= 0, got {value!r}")
    return [None if value is None else int(value) for value in seeds]


def rows_options(options: Mapping[str, Any] | None, envs: Sequence[Any]) -> list[Any]:
    """Each row's reset options (``envs``: the row envs): ``{"config": cfg}`` pins every row,
    ``{"configs": [cfg_0, ..., cfg_{B-1}]}`` one scenario per row (None for a row: its own draw).
    Every pinned scenario is checked here (:func:`pinned_scenario`; ``ValueError`` /
    ``TypeError`` naming it), before any row resets."""
    b = len(envs)
    if options is None or not isinstance(options, Mapping) or "configs" not in options:
        only_config = isinstance(options, Mapping) and set(options) == {"config"}
        pinned = options.get("config") if only_config else None
        if pinned is None:  # (any other key or type: the row env's reset refuses it)
            return [options] * b
        return [{"config": pinned_scenario(envs[0], pinned, 'options["config"]')}] * b
    if set(options) != {"configs"}:
        raise ValueError(
            f'reset takes options={{"config": cfg}} or {{"configs": [...]}}, got {sorted(options)}'
        )
    configs = options["configs"]
    if isinstance(configs, (ScenarioConfig, Mapping, str, bytes)) or not isinstance(
        configs, (Sequence, np.ndarray)
    ):
        raise TypeError(
            f'options["configs"] must be a list of {b} scenarios (one per row: a ScenarioConfig, a dict '
            f"of its fields, or None for the row's own), got {type(configs).__name__}; "
            'options={"config": cfg} pins every row to one scenario'
        )
    configs = list(configs)
    if len(configs) != b:
        raise ValueError(f'options["configs"] must hold {b} scenarios (one per row), got {len(configs)}')
    rows: list[Any] = []
    checked: dict[int, Any] = {}  # id of a config given for several rows -> it checked once
    for i, config in enumerate(configs):
        if config is not None and id(config) not in checked:
            checked[id(config)] = pinned_scenario(envs[i], config, f'options["configs"][{i}]')
        rows.append(None if config is None else {"config": checked[id(config)]})
    return rows


def pinned_scenario(env: Any, config: Any, field: str) -> Any:
    """The pinned scenario ``config`` checked by the row env's ``check_scenario`` when it has one
    (the package's envs: a ``ScenarioConfig`` or a dict of its fields, which must fit the env;
    ``ValueError`` / ``TypeError`` naming ``field``); other envs take it as given."""
    check = getattr(env, "check_scenario", None)
    if check is None:
        return config
    cfg = as_config(config, field)
    check(cfg, field)
    return cfg
