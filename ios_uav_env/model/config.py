"""Scenario configuration: every parameter of the system model, with the paper's defaults.

The model is that of Liu et al., IEEE WCL 11(9), 2022 (``docs/model.md``). Each field
comment gives the unit and the paper's symbol. Choices the paper leaves open are marked
*(assumption)* and are fields, never hidden constants. Derived quantities (N, D, eta, M)
are properties. Variants are made with :func:`dataclasses.replace`, which re-validates.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ios_uav_env.model.config_checks import (  # noqa: F401 (the schema, re-exported)
    ENERGY_RTOL,
    FEASIBILITY_TOL,
    OBJECTIVES,
    STAR_ACCESS,
    STAR_FIELDS,
    STAR_MAX_BITS,
    STAR_PHASES,
    STAR_PROTOCOLS,
    SURFACE_KINDS,
    SURFACES,
    Surface,
    as_pair,
    canonical_nodes,
    check_antennas,
    check_motion,
    check_nodes_off_the_plane,
    check_numbers,
    check_objective,
    check_star,
    check_star_fields,
    is_int,
    is_real,
)
from ios_uav_env.model.mobility import GaussMarkov
from ios_uav_env.model.propulsion import PropulsionModel, least_energy_speed, propulsion_power


@dataclass(frozen=True)
class ScenarioConfig:
    """One instance of the IOS-aided UAV downlink of the paper (defaults: its Section IV)."""

    surface: Surface = "ios"  # "ios" (reflect + transmit), "ris" (reflect only), "none" (direct link), "star"
    T: float = 150.0  # s, mission duration T = N * delta_t
    dt: float = 1.0  # s, slot length delta_t
    v_max: float = 25.0  # m/s, maximum UAV speed v_max
    q0: tuple[float, float] = (-400.0, 20.0)  # m, initial horizontal position q_0 = q[1]
    qF: tuple[float, float] = (400.0, 20.0)  # m, final horizontal position q_F = q[N]
    ground_node: tuple[float, float] = (-100.0, -20.0)  # m, ground node G, w_G = (x_G, y_G), z = 0
    uav_altitude: float = 100.0  # m, fixed UAV altitude z_U (assumption: not given in the paper)
    ios_center: tuple[float, float, float] = (0.0, 0.0, 40.0)  # m, IOS centre; plane x = x_c (no node on it)
    ios_shape: tuple[int, int] = (100, 60)  # (M_y, M_z): columns along y, rows along z (assumption)
    epsilon: float = 3.55  # transmissive power-pattern factor epsilon, eq. (2)
    kappa: float = 3.0  # Rician factor kappa, eqs. (4)-(5)
    alpha: float = 5.0  # direct-link path-loss exponent alpha
    power_w: float = 0.1  # W, UAV transmit power P
    noise_dbm: float = -80.0  # dBm, noise power sigma^2
    wavelength: float = 0.05  # m, carrier wavelength lambda
    g_tx: float = 1.0  # UAV antenna gain G^tx
    g_rx: float = 1.0  # ground-node antenna gain G^rx
    g_element: float = 1.0  # element gain G_m (assumption)
    gamma: float = 1.0  # element amplitude ratio |gamma_m| (assumption)
    element_spacing_wl: float = 0.5  # wavelengths, element pitch on the grid (assumption: lambda/2)
    element_size_wl: float = 0.5  # wavelengths, element size delta_y = delta_z (assumption: lambda/2)
    # Chebyshev compression of the element sum (see ios_uav_env.model.surface): the exact per-element
    # sum is replaced by an equivalent one over n x n weighted nodes, exact for polynomials of
    # degree < n along each axis. n is at least quadrature_nodes, raised where the geometry needs
    # it (a UAV close above a large surface) until an a-priori bound of the relative amplitude
    # error is <= quadrature_tol; the exact sum once n reaches the grid size. 0 = always the
    # exact sum (slow for M = 6000); quadrature_tol = inf = exactly quadrature_nodes.
    quadrature_nodes: int = 8  # nodes per axis, at least (0: exact per-element sum)
    quadrature_tol: float = 1e-12  # relative amplitude error the compression must stay within
    # m, several ground nodes w_k (TDMA, max-min fairness; see ios_uav_env.model.schedule). None:
    # the single node ``ground_node``. When given (K >= 1 pairs), ``ground_node`` is set to
    # ground_nodes[0] and one node collapses to None (one canonical single-node value).
    ground_nodes: tuple[tuple[float, float], ...] | None = None
    # The objective and its parameters (``docs/model.md``, "Energy"); each is left out of
    # ``to_dict()`` at its default, so the rate scenarios' dicts (suite hashes, cache keys) hold.
    propulsion: PropulsionModel = PropulsionModel()  # rotary-wing power model P(V) (a dict of it is accepted)
    bandwidth_hz: float = 1e6  # Hz, bandwidth B (bits = B x bps/Hz x s)
    objective: str = "rate"  # one of OBJECTIVES: "rate" (eq. (9)) or "energy_efficiency" (bits/J)
    energy_budget_j: float | None = None  # J, energy budget E_max of the flight (None: no budget)
    # Node motion (``ios_uav_env.model.motion``, ``docs/model.md``, "Node motion"): None, the
    # paper's static nodes, or a GaussMarkov model (a dict of it is accepted); left out of
    # ``to_dict()`` when None. The configured nodes are the positions of slot 1.
    motion: GaussMarkov | None = None
    # The STAR surface (surface "star"; ``docs/model.md``, "STAR surfaces"): its protocol, phase
    # model, phase bits and access scheme, the choices of ``ios_uav_env.model.star.StarSurface``.
    # Refused with any other surface unless at their defaults; left out of ``to_dict()`` there.
    star_protocol: str = "es"  # one of STAR_PROTOCOLS: energy splitting, mode or time switching
    star_phases: str = "independent"  # one of STAR_PHASES: the phase model
    star_bits: int | None = None  # phase bits b (TDMA: the node's exact b-bit phases); None: continuous
    star_access: str = "tdma"  # one of STAR_ACCESS: one node per slot share, or both sides' at once
    # The UAV's antennas N_t (``docs/model.md``, "Multi-antenna UAV"; ``model.array.scenario_array``),
    # the phases and the beam in closed form for the node served (``model.miso``); left out of
    # ``to_dict()`` at 1, the paper's single antenna.
    antennas: int = 1  # N_t, an integer in [1, MAX_ANTENNAS]

    def __post_init__(self) -> None:
        if self.surface not in SURFACE_KINDS:
            raise ValueError(f"surface must be one of {SURFACE_KINDS}, got {self.surface!r}")
        check_star_fields(self, _STAR_DEFAULTS)
        object.__setattr__(self, "q0", as_pair(self.q0, "q0"))
        object.__setattr__(self, "qF", as_pair(self.qF, "qF"))
        object.__setattr__(self, "ground_node", as_pair(self.ground_node, "ground_node"))
        canonical_nodes(self)
        object.__setattr__(self, "ios_center", as_pair(self.ios_center, "ios_center", 3))
        check_nodes_off_the_plane(self)
        check_numbers(self)
        ratio = self.T / self.dt
        if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio):
            raise ValueError(f"T must be a whole number of slots dt={self.dt} s, got T={self.T} s")
        if self.N < 2:
            raise ValueError(f"T must give at least N = 2 slots (T >= {2 * self.dt} s), got T={self.T} s")
        half_height = 0.5 * (self.ios_shape[1] - 1) * self.element_spacing + 0.5 * self.element_size
        top, bottom = self.ios_center[2] + half_height, self.ios_center[2] - half_height
        if self.uav_altitude <= top:
            raise ValueError(f"uav_altitude must be > the IOS top edge {top:g} m, got {self.uav_altitude!r}")
        if bottom <= 0:
            raise ValueError(
                f"ios_center[2] must put the IOS bottom edge above ground (> 0 m), got {bottom:g} m"
            )
        t_min = self.min_horizon()
        if self.N < round(t_min / self.dt):
            raise ValueError(
                f"T={self.T} s is too short to fly from q0={self.q0} to qF={self.qF} at "
                f"v_max={self.v_max} m/s: T must be >= {t_min:g} s (N - 1 >= ceil(|qF - q0| / D) moves)"
            )
        check_objective(self)
        check_motion(self)
        check_antennas(self)

    # --- derived quantities -------------------------------------------------------
    @property
    def nodes(self) -> tuple[tuple[float, float], ...]:
        """The K ground nodes w_k (m): ``ground_nodes``, or ``(ground_node,)`` for one node."""
        return self.ground_nodes or (self.ground_node,)

    @property
    def K(self) -> int:
        """Number of ground nodes K >= 1."""
        return len(self.nodes)

    def node_config(self, k: int) -> ScenarioConfig:
        """The single-node config of node k (G = w_k, every other field unchanged): the model
        of node k's rate r_k. ``self`` itself when K = 1."""
        if not (isinstance(k, numbers.Integral) and 0 <= k < self.K):
            raise ValueError(f"node index k must be an integer in [0, {self.K - 1}], got {k!r}")
        if self.K == 1:
            return self
        return self._node_configs[int(k)]

    @functools.cached_property
    def _node_configs(self) -> tuple[ScenarioConfig, ...]:
        """Every node's single-node config, made once per config: the planners ask for them per
        leg and per slot, a drawn multi-node scenario's moving nodes at every reset. Each equals
        ``dataclasses.replace(self, ground_nodes=None, ground_node=w_k)`` field for field (tested)
        without running the checks again: every field is this config's, checked and normalised,
        and each node passed here what a one-node config checks of its node (its side of the IOS
        plane, its motion rectangle). Not a field: equality, hashing and ``to_dict`` ignore it."""
        values = [(f.name, getattr(self, f.name)) for f in dataclasses.fields(self)]
        out = []
        for w in self.nodes:
            node = object.__new__(type(self))
            for name, value in values:
                object.__setattr__(node, name, value)
            object.__setattr__(node, "ground_node", w)
            object.__setattr__(node, "ground_nodes", None)
            out.append(node)
        return tuple(out)

    def require_single_node(self, what: str) -> None:
        """Raise ``ValueError`` when K > 1: ``what`` models one ground node only."""
        if self.K > 1:
            raise ValueError(
                f"{what} models one ground node, but this config has K={self.K} ground_nodes: use "
                "ios_uav_env.node_rates / maxmin_rate (several nodes) or config.node_config(k) (node k)"
            )

    @property
    def N(self) -> int:
        """Number of slots N = T / delta_t (both end points included; N - 1 moves)."""
        return int(round(self.T / self.dt))

    @property
    def D(self) -> float:
        """Maximum horizontal move per slot D = v_max * delta_t (m)."""
        return self.v_max * self.dt

    @property
    def noise_w(self) -> float:
        """Noise power sigma^2 in W."""
        return 10.0 ** (self.noise_dbm / 10.0) * 1e-3

    @property
    def eta(self) -> float:
        """Transmit SNR eta = P / sigma^2 (inf when sigma^2 underflows to 0)."""
        noise = self.noise_w
        return self.power_w / noise if noise > 0 else math.inf

    @property
    def M(self) -> int:
        """Number of IOS elements M = M_y * M_z."""
        return self.ios_shape[0] * self.ios_shape[1]

    @property
    def element_spacing(self) -> float:
        """Element pitch in metres."""
        return self.element_spacing_wl * self.wavelength

    @property
    def element_size(self) -> float:
        """Element size delta_y = delta_z in metres."""
        return self.element_size_wl * self.wavelength

    @property
    def J(self) -> float:
        """J = lambda sqrt(G_tx G_rx G_m delta_y delta_z |gamma|^2) / (4 pi)^(3/2)."""
        root = math.sqrt(self.g_tx * self.g_rx * self.g_element * self.element_size**2 * self.gamma**2)
        return self.wavelength * root / (4.0 * math.pi) ** 1.5

    @property
    def transmit_factor(self) -> float:
        """Factor of the transmissive power pattern: epsilon (IOS), 1 (STAR), 0 (RIS and no surface).

        The rate kernel is a node's rate served alone. A STAR surface serving one node (TDMA,
        ``star_access="tdma"``; under NOMA these are the single-user rates c_s) is set for it:
        with energy splitting, mode or time switching the node gets the whole surface on its side,
        u^s = sqrt(beta^s) = 1 on every element, at phases aligned to it (with ``star_bits`` = b, at
        its exact b-bit phases: ``rate_rows.discrete_zeta_row``; where one side alone
        carries power the coupled and shared phase models bind nothing:
        ``ios_uav_env.model.star_slot``, "TDMA"). Its element is a unit
        element on either side, so its channel is the IOS's geometry with factor 1 on both sides.
        The IOS's epsilon (eq. (2), 3.55 by default) enters the amplitude linearly and is not
        energy-normalised, so on the transmission side the IOS's amplitude is epsilon times the
        STAR's: the IOS is above a STAR surface there when epsilon > 1 (the paper's value), equal
        at epsilon = 1 and below when epsilon < 1; on the reflection side they are equal."""
        if self.surface == "ios":
            return self.epsilon
        return 1.0 if self.surface == "star" else 0.0

    @property
    def ground_side(self) -> float:
        """The side of the surface plane x = x_c node G is on: sign(x_G - x_c), 1.0, -1.0 or 0.0 (in
        the plane). A UAV on this side is served by reflection (the side factor 1), on the other by
        transmission (``transmit_factor``): ``channel.side_factor``."""
        return float(np.sign(self.ground_node[0] - self.ios_center[0]))

    def min_horizon(self) -> float:
        """Shortest T (s) that still lets the UAV reach qF from q0 at v_max."""
        return (int(moves_needed(math.dist(self.q0, self.qF), self.D)) + 1) * self.dt

    def least_energy_speed(self) -> float:
        """The speed (m/s) of :meth:`least_energy`: clip(V_mp, |qF - q0| / ((N - 1) dt), v_max)."""
        distance = math.dist(self.q0, self.qF)
        return least_energy_speed(distance, self.N - 1, self.dt, self.v_max, self.propulsion)

    def least_energy(self) -> float:
        """A lower bound (J) on the energy of every feasible flight, exact for the straight one.

        A feasible flight makes N - 1 moves of one slot each, at speeds v_n in [0, v_max] whose
        distances add up to at least L = |qF - q0| (the triangle inequality): sum_n v_n dt >= L.
        Among flights at one constant speed c the energy (N - 1) dt P(c) is least at the c in
        [L / ((N - 1) dt), v_max] nearest to the minimum-power speed V_mp, P being unimodal
        with its minimum at V_mp: c* = clip(V_mp, L / ((N - 1) dt), v_max). Below V_mp a
        slower move costs more power and covers less, so no flight gains by one; above V_mp,
        where P is convex (it is for the Table I constants from about 4 m/s on; tested),
        Jensen's inequality gives sum_n P(v_n) >= (N - 1) P(mean v_n) >= (N - 1) P(c*). So
        E >= (N - 1) dt P(c*), with equality for the straight line flown at c* when
        c* = L / ((N - 1) dt), and for a path of N - 1 equal moves of c* dt (a detour) otherwise.
        A budget below this is refused (``energy_budget_j``).
        """
        return (self.N - 1) * self.dt * float(propulsion_power(self.least_energy_speed(), self.propulsion))

    def replace(self, **changes: Any) -> ScenarioConfig:
        """A copy with ``changes`` applied (an unknown field raises ``TypeError`` worded as
        Python's own); re-validated. A change of ``surface`` to another than ``"star"`` resets
        the STAR fields not given (:data:`STAR_FIELDS`) to their defaults: a STAR scenario's
        ``replace(surface="ios")`` is the IOS one."""
        for name in changes:
            if name not in SCENARIO_FIELDS:
                raise TypeError(f"ScenarioConfig.replace() got an unexpected keyword argument {name!r}")
        if changes.get("surface", "star") != "star":
            changes = {**_STAR_DEFAULTS, **changes}
        if "ground_nodes" in changes:
            if changes["ground_nodes"] is None:  # back to one node: keep the first one
                changes.setdefault("ground_node", self.ground_node)
            else:  # __post_init__ sets ground_node to the first new node
                changes.setdefault("ground_node", ScenarioConfig.__dataclass_fields__["ground_node"].default)
        elif "ground_node" in changes and self.K > 1:
            raise ValueError(
                f"ground_node cannot be replaced on a config with K={self.K} ground_nodes: set ground_nodes"
            )
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON dictionary of the fields (round-trips through :meth:`from_dict`, i.e.
        ``ScenarioConfig(**d)``).

        ``ground_nodes`` is omitted when None (one node), and each objective field
        (``propulsion``, ``bandwidth_hz``, ``objective``, ``energy_budget_j``), ``motion``, each
        STAR field (:data:`STAR_FIELDS`) and ``antennas`` at its default, so the dicts of the static
        rate scenarios are unchanged."""
        out = {k: list(v) if isinstance(v, tuple) else v for k, v in dataclasses.asdict(self).items()}
        if self.ground_nodes:
            out["ground_nodes"] = [list(p) for p in self.ground_nodes]
        else:
            del out["ground_nodes"]
        for name in _OMITTED_AT_DEFAULT:
            if getattr(self, name) == _DEFAULTS[name]:
                del out[name]
        if "propulsion" in out:
            out["propulsion"] = self.propulsion.to_dict()
        if "motion" in out:
            out["motion"] = self.motion.to_dict()
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ScenarioConfig:
        """The config of a :meth:`to_dict` dictionary (``ScenarioConfig(**data)``)."""
        return cls(**data)


#: The names of the ``ScenarioConfig`` fields (the scenario's keyword arguments everywhere).
SCENARIO_FIELDS: frozenset[str] = frozenset(f.name for f in dataclasses.fields(ScenarioConfig))
#: The objective's fields, ``motion``, the STAR fields and ``antennas``, left out of ``to_dict()`` at
#: their defaults.
_OMITTED_AT_DEFAULT = (
    "propulsion", "bandwidth_hz", "objective", "energy_budget_j", "motion", *STAR_FIELDS, "antennas",
)  # fmt: skip
_DEFAULTS = {f.name: f.default for f in dataclasses.fields(ScenarioConfig) if f.name in _OMITTED_AT_DEFAULT}
_STAR_DEFAULTS = {name: _DEFAULTS[name] for name in STAR_FIELDS}


def moves_needed(distance: Any, D: float) -> Any:
    """Moves of at most D needed to cover ``distance`` (m): ceil(distance / D), 0 for 0.

    A distance of exactly k D takes k moves (a relative slack of 1e-9 absorbs rounding).
    Vectorised: an array of distances gives an array of counts (floats), a number an int.
    """
    moves = np.maximum(np.ceil(np.asarray(distance, dtype=float) / D - 1e-9), 0.0)
    return int(moves) if moves.ndim == 0 else moves


def scene_box(config: ScenarioConfig, margin: float = 0.0, *, ends: bool = True) -> tuple[float, ...]:
    """(x_min, x_max, y_min, y_max) in m: the bounding box of the ground nodes and the IOS
    centre (and of q0 and qF with ``ends``), widened by ``margin`` on every side. The planners'
    grids, the peak search and the figures all start from this box."""
    points = [*config.nodes, config.ios_center[:2]] + ([config.q0, config.qF] if ends else [])
    pts = np.asarray(points, dtype=float)
    lo, hi = pts.min(axis=0) - margin, pts.max(axis=0) + margin
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])


def as_config(value: Any, name: str = "config") -> ScenarioConfig:
    """``value`` as a ``ScenarioConfig``: itself, the fields of a dict, or the defaults for None."""
    if value is None:
        return ScenarioConfig()
    if isinstance(value, ScenarioConfig):
        return value
    if isinstance(value, Mapping):
        return ScenarioConfig(**value)
    raise TypeError(f"{name} must be a ScenarioConfig, a dict of its fields or None, got {value!r}")


def scenario_option(options: Mapping[str, Any] | None) -> ScenarioConfig | None:
    """The scenario pinned by ``reset(options=...)``: ``options["config"]`` (a ``ScenarioConfig``
    or a dict of its fields) or None; any other key raises ``ValueError``."""
    if not isinstance(options, (Mapping, type(None))) or set(options or ()) - {"config"}:
        raise ValueError(
            'reset accepts only options={"config": ScenarioConfig(...)} (the episode\'s scenario) or '
            f"None, got options={options!r}"
        )
    config = (options or {}).get("config")
    return None if config is None else as_config(config, 'options["config"]')
