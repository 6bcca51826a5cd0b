"""The scenario's schema: the allowed values of ``ScenarioConfig``'s fields and their checks.

``ios_uav_env.model.config`` holds the dataclass (its fields, units and derived quantities); this
module holds what it validates against, each check a function of the config that raises a
``ValueError`` naming the field and the allowed values (and, where a field is normalised, sets it
with ``object.__setattr__`` on the frozen dataclass, as ``__post_init__`` does).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping
from typing import Any, Literal

import numpy as np

from ios_uav_env.model.array import MAX_ANTENNAS
from ios_uav_env.model.mobility import as_motion, rectangles
from ios_uav_env.model.propulsion import PropulsionModel

Surface = Literal["ios", "ris", "none", "star"]
#: The paper's surfaces, one env id each (``envs.registration.ENV_IDS``, which adds the STAR id;
#: the figures' schemes).
SURFACES: tuple[str, ...] = ("ios", "ris", "none")
#: Every surface a scenario may have: the paper's and ``"star"``, a STAR surface (``docs/model.md``,
#: "STAR surfaces"; its fields are :data:`STAR_FIELDS`).
SURFACE_KINDS: tuple[str, ...] = (*SURFACES, "star")
#: A STAR surface's protocols (``ios_uav_env.model.star.PROTOCOLS`` but the configured surface's own
#: split ``"fixed"``, which is surface ``"ios"`` or ``"ris"`` itself), phase models and access schemes.
STAR_PROTOCOLS: tuple[str, ...] = ("es", "ms", "ts")
STAR_PHASES: tuple[str, ...] = ("independent", "coupled", "shared")
STAR_ACCESS: tuple[str, ...] = ("tdma", "noma")
#: Most phase bits of a STAR element (``ios_uav_env.model.star.MAX_BITS``).
STAR_MAX_BITS = 8
#: The STAR surface's fields: set only with ``surface="star"``, left out of ``to_dict()`` at their
#: defaults (the dicts of every other scenario, their suite hashes and cache keys, hold).
STAR_FIELDS: tuple[str, ...] = ("star_protocol", "star_phases", "star_bits", "star_access")

#: Tolerance (m) within which a trajectory constraint of eq. (10) counts as met.
FEASIBILITY_TOL = 1e-6
#: Relative tolerance of the energy budget: a plan of energy E meets ``energy_budget_j`` when
#: E <= energy_budget_j * (1 + ENERGY_RTOL) (rounding of the sum over N - 1 moves).
ENERGY_RTOL = 1e-9
#: What a plan's score is (``ScenarioConfig.objective``): the average rate of eq. (9) (max-min
#: for K > 1 nodes), or the energy efficiency B T R / E (bits/J). The average rate under an
#: energy budget is ``"rate"`` with ``energy_budget_j`` set.
OBJECTIVES: tuple[str, ...] = ("rate", "energy_efficiency")


def as_pair(value: Any, name: str, length: int = 2) -> tuple[float, ...]:
    """``value`` as a tuple of ``length`` finite floats (``ValueError`` naming ``name``)."""
    if isinstance(value, (str, bytes)):
        raise ValueError(f"{name} must be a sequence of {length} numbers, got {value!r}")
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a sequence of {length} numbers, got {value!r}") from exc
    if len(out) != length:
        raise ValueError(f"{name} must have {length} entries, got {len(out)}: {value!r}")
    if not all(math.isfinite(v) for v in out):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return out


def is_real(value: Any) -> bool:  # (a plain float first: the ABC check is slow, per field and config)
    """Whether ``value`` is a real number (not a bool)."""
    return type(value) is float or (isinstance(value, numbers.Real) and not isinstance(value, bool))


def is_int(value: Any) -> bool:
    """Whether ``value`` is an integer (not a bool)."""
    return type(value) is int or (isinstance(value, numbers.Integral) and not isinstance(value, bool))


def check_star_fields(cfg: Any, defaults: Mapping[str, Any]) -> None:
    """Validate the STAR fields (:func:`check_star`) and refuse them away from their defaults
    with another surface than ``"star"``: they would do nothing."""
    check_star(cfg.star_protocol, cfg.star_phases, cfg.star_bits, cfg.star_access)
    if cfg.star_bits is not None:  # (a plain int: stable hashing, equality and JSON)
        object.__setattr__(cfg, "star_bits", int(cfg.star_bits))
    if cfg.surface == "star":
        return
    for name in STAR_FIELDS:
        value, default = getattr(cfg, name), defaults[name]
        if value != default:
            raise ValueError(
                f"{name}={value!r} is a field of the STAR surface: it needs surface='star' (this "
                f"config has surface={cfg.surface!r}); leave it at its default {default!r}"
            )


def check_numbers(cfg: Any) -> None:
    """Validate the surface's grid and the scalar fields, each error naming the field: ``ios_shape``
    two integers >= 1, the lengths, times, powers, gains and sizes finite and > 0, ``epsilon``,
    ``kappa`` and ``gamma`` finite and >= 0, ``noise_dbm`` finite, ``quadrature_nodes`` an integer in
    [0, 64] and ``quadrature_tol`` > 0; each is set to a plain Python number, and the derived powers
    ``noise_w`` and ``eta`` must be finite numbers in (1e-150, 1e150)."""
    shape = as_pair(cfg.ios_shape, "ios_shape")
    if any(isinstance(v, (bool, np.bool_)) for v in cfg.ios_shape) or not all(
        s == int(s) and s >= 1 for s in shape
    ):
        raise ValueError(f"ios_shape must be two integers >= 1 (M_y, M_z; M > 0), got {cfg.ios_shape!r}")
    object.__setattr__(cfg, "ios_shape", (int(shape[0]), int(shape[1])))
    positive = {
        "T": cfg.T, "dt": cfg.dt, "v_max": cfg.v_max, "uav_altitude": cfg.uav_altitude,
        "power_w": cfg.power_w, "wavelength": cfg.wavelength, "alpha": cfg.alpha,
        "g_tx": cfg.g_tx, "g_rx": cfg.g_rx, "g_element": cfg.g_element,
        "element_spacing_wl": cfg.element_spacing_wl, "element_size_wl": cfg.element_size_wl,
    }  # fmt: skip
    for name, value in positive.items():
        if not (is_real(value) and math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    nonneg = {"epsilon": cfg.epsilon, "kappa": cfg.kappa, "gamma": cfg.gamma}
    for name, value in nonneg.items():
        if not (is_real(value) and math.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    if not (is_real(cfg.noise_dbm) and math.isfinite(cfg.noise_dbm)):
        raise ValueError(f"noise_dbm must be finite, got {cfg.noise_dbm!r}")
    if not (is_int(cfg.quadrature_nodes) and 0 <= cfg.quadrature_nodes <= 64):
        raise ValueError(f"quadrature_nodes must be an integer in [0, 64], got {cfg.quadrature_nodes!r}")
    if not (is_real(cfg.quadrature_tol) and cfg.quadrature_tol > 0):
        raise ValueError(f"quadrature_tol must be a number > 0 (inf: none), got {cfg.quadrature_tol!r}")
    # plain Python numbers (numpy scalars accepted): stable hashing, equality and JSON
    for name in (*positive, *nonneg, "noise_dbm", "quadrature_tol"):
        object.__setattr__(cfg, name, float(getattr(cfg, name)))
    # derived powers must be finite numbers too: eta = P / sigma^2 enters every rate
    for name in ("noise_w", "eta"):
        try:
            value = getattr(cfg, name)
        except OverflowError:
            value = math.inf
        if not (math.isfinite(value) and 1e-150 < value < 1e150):
            raise ValueError(
                f"power_w={cfg.power_w!r} W and noise_dbm={cfg.noise_dbm!r} dBm give {name} = "
                f"{value!r}: it must be a finite number in (1e-150, 1e150) "
                "(e.g. noise_dbm in [-250, 250] dBm)"
            )
    object.__setattr__(cfg, "quadrature_nodes", int(cfg.quadrature_nodes))


def check_motion(cfg: Any) -> None:
    """Validate ``motion`` (a dict becomes the model): every node inside its motion rectangle
    (``ios_uav_env.model.mobility.rectangles``: the box, off the IOS plane's strip). The
    rectangles are kept on ``cfg`` (``motion.node_bounds`` hands out copies of them)."""
    object.__setattr__(cfg, "motion", as_motion(cfg.motion))
    if cfg.motion is not None:
        bounds = rectangles(cfg.motion, np.asarray(cfg.nodes, dtype=float), cfg.ios_center, cfg.surface)
        object.__setattr__(cfg, "_node_bounds", bounds)


def checked_antennas(n: Any, name: str = "antennas") -> int:
    """``n`` as the UAV's antenna count N_t (the scenario's or a link's), an integer in
    [1, ``array.MAX_ANTENNAS``]; else a ``ValueError`` naming the field ``name``."""
    if not (is_int(n) and 1 <= n <= MAX_ANTENNAS):
        raise ValueError(f"{name} must be an integer in [1, {MAX_ANTENNAS}] (N_t), got {n!r}")
    return int(n)


def check_antennas(cfg: Any) -> None:
    """Validate ``antennas`` (:func:`checked_antennas`)."""
    object.__setattr__(cfg, "antennas", checked_antennas(cfg.antennas))


def check_objective(cfg: Any) -> None:
    """Validate the objective's fields (``propulsion`` given as a dict becomes the model)."""
    model = cfg.propulsion
    if isinstance(model, Mapping):
        unknown = set(model) - {f.name for f in dataclasses.fields(PropulsionModel)}
        if unknown:
            raise ValueError(
                f"propulsion has unknown constants {sorted(unknown)}; allowed: "
                f"{[f.name for f in dataclasses.fields(PropulsionModel)]}"
            )
        object.__setattr__(cfg, "propulsion", PropulsionModel(**model))
    elif not isinstance(model, PropulsionModel):
        raise ValueError(f"propulsion must be a PropulsionModel (or a dict of its constants), got {model!r}")
    b = cfg.bandwidth_hz
    if not (is_real(b) and math.isfinite(b) and b > 0):
        raise ValueError(f"bandwidth_hz must be a finite number > 0 (Hz), got {b!r}")
    object.__setattr__(cfg, "bandwidth_hz", float(b))
    if cfg.objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {OBJECTIVES}, got {cfg.objective!r}")
    budget = cfg.energy_budget_j
    if budget is None:
        return
    if not (is_real(budget) and math.isfinite(budget) and budget > 0):
        raise ValueError(f"energy_budget_j must be None or a finite number > 0 (J), got {budget!r}")
    object.__setattr__(cfg, "energy_budget_j", float(budget))
    least = cfg.least_energy()
    if budget < least:
        raise ValueError(
            f"energy_budget_j={budget!r} J is below the least energy of any feasible flight of "
            f"this scenario, {least:.10g} J (N - 1 = {cfg.N - 1} moves from q0 to qF at "
            f"{cfg.least_energy_speed():.4g} m/s): it must be None or a number >= {least:.10g} J"
        )


def canonical_nodes(cfg: Any) -> None:
    """Validate ``ground_nodes``; set ``ground_node`` to its first node; K = 1 -> None."""
    nodes = cfg.ground_nodes
    if nodes is None:
        return
    if isinstance(nodes, (str, bytes)) or not hasattr(nodes, "__len__") or len(nodes) == 0:
        raise ValueError(
            f"ground_nodes must be a sequence of K >= 1 (x, y) pairs in m (None: the single "
            f"ground_node), got {nodes!r}"
        )
    pairs = tuple(as_pair(p, f"ground_nodes[{i}]") for i, p in enumerate(nodes))
    default = type(cfg).__dataclass_fields__["ground_node"].default
    if cfg.ground_node not in (pairs[0], default):
        raise ValueError(
            f"ground_node={cfg.ground_node} conflicts with ground_nodes[0]={pairs[0]}: give only "
            "ground_nodes (ground_node is set to its first node)"
        )
    object.__setattr__(cfg, "ground_node", pairs[0])
    object.__setattr__(cfg, "ground_nodes", pairs if len(pairs) > 1 else None)


def check_nodes_off_the_plane(cfg: Any) -> None:
    """With a surface, no ground node may lie on its plane x = x_c: which side the node is on
    (reflection or transmission) is what the surface's channel depends on, and on the plane
    it is undefined."""
    if cfg.surface == "none":
        return
    plane = cfg.ios_center[0]
    for i, node in enumerate(cfg.nodes):
        if node[0] == plane:
            name = "ground_node" if cfg.K == 1 else f"ground_nodes[{i}]"
            raise ValueError(
                f"{name}={node} lies on the IOS plane x = ios_center[0] = {plane:g} m, where its "
                f"side of the surface (reflect or transmit, surface={cfg.surface!r}) is undefined: "
                f"move the node off the plane (x != {plane:g} m) or use surface='none'"
            )


def check_star(protocol: Any, phases: Any, bits: Any, access: Any, prefix: str = "star_") -> None:
    """``ValueError`` naming the field (``prefix`` + protocol, phases, bits or access) and its
    allowed values unless these are a STAR surface the scenario's rate model runs: a protocol of
    :data:`STAR_PROTOCOLS`, a phase model of :data:`STAR_PHASES`, continuous phases (bits None) or
    b-bit ones (an integer in [1, :data:`STAR_MAX_BITS`]; with the coupled phase model b >= 2, as
    ``star.StarSurface`` asks: +-pi/2 is not on the 1-bit grid) and an access scheme of
    :data:`STAR_ACCESS` (NOMA with energy splitting, independent and continuous phases, the case
    whose flight optimum ``star_regions.star_maxmin`` certifies).

    b-bit phases are modelled under TDMA: the node served gets the whole surface on its side at
    its exact b-bit phases, slot by slot (``star_slot.slot_optimum``'s TDMA rate; in flight the
    rate kernel's ``rate_rows.discrete_zeta_row``). Under NOMA they are refused: the flight's
    optimum is certified for continuous phases only (``star_slot``'s per-slot NOMA max-min with
    b bits is a search whose bound is the continuous one)."""
    if not (isinstance(protocol, str) and protocol in STAR_PROTOCOLS):
        raise ValueError(
            f"{prefix}protocol must be one of {STAR_PROTOCOLS}, got {protocol!r} (the configured "
            "surface's own split, star.py's 'fixed', is surface='ios' or 'ris')"
        )
    if not (isinstance(phases, str) and phases in STAR_PHASES):
        raise ValueError(f"{prefix}phases must be one of {STAR_PHASES}, got {phases!r}")
    if bits is not None and not (is_int(bits) and 1 <= bits <= STAR_MAX_BITS):
        raise ValueError(
            f"{prefix}bits must be None (continuous phases) or an integer in [1, {STAR_MAX_BITS}], "
            f"got {bits!r}"
        )
    if not (isinstance(access, str) and access in STAR_ACCESS):
        raise ValueError(f"{prefix}access must be one of {STAR_ACCESS}, got {access!r}")
    if bits is not None and access == "noma":
        raise ValueError(
            f"{prefix}bits={bits!r} with {prefix}access='noma': b-bit phases are modelled with "
            f"{prefix}access='tdma' (the node served at its exact b-bit phases in each slot share); "
            "the NOMA flight's optimum (ios_uav_env.model.star_regions.star_maxmin) is certified for "
            "continuous phases only, and star_slot's per-slot NOMA max-min with b bits is a search "
            f"bounded by the continuous optimum: use {prefix}access='tdma', or {prefix}bits=None"
        )
    if bits == 1 and phases == "coupled":
        raise ValueError(
            f"{prefix}bits=1 with {prefix}phases='coupled': the coupled model's theta^t - theta^r = "
            f"+-pi/2 is not on the 1-bit grid {{0, pi}} (star.StarSurface); use {prefix}bits >= 2, or "
            "another phase model"
        )
    if access == "noma" and (protocol, phases) != ("es", "independent"):
        raise ValueError(
            f"{prefix}access='noma' is modelled for {prefix}protocol='es' with {prefix}phases="
            f"'independent' (the flight's optimum of ios_uav_env.model.star_regions.star_maxmin), got "
            f"{prefix}protocol={protocol!r}, {prefix}phases={phases!r}; "
            "ios_uav_env.model.star_slot.slot_optimum has every protocol's per-slot NOMA max-min"
        )
