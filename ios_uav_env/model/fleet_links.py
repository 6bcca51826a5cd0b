r"""The links of several UAVs and one surface: every UAV-node link's gain under every alignment of
the surface, for many fleets and slots at once (:func:`link_gains_batch`), and a per-slot cache
of them (:func:`cached_link_gains`) for planners that score many flights differing in a few
slots. The fleet's max-min and its pricers: :mod:`ios_uav_env.model.fleet`.
"""

from __future__ import annotations

from collections import OrderedDict
from functools import lru_cache

import numpy as np

from ios_uav_env.model import channel
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.surface import element_positions, element_to_ground

__all__ = ["GAIN_CACHE_SLOTS", "cached_link_gains", "link_gains", "link_gains_batch", "link_rates"]

#: Most slots whose link gains :func:`cached_link_gains` keeps per scenario (about 2.6 kB a slot
#: for U = 3, K = 6), and most scenarios it keeps them for.
GAIN_CACHE_SLOTS = 20_000
GAIN_CACHE_SCENARIOS = 4
_GAINS: OrderedDict[ScenarioConfig, OrderedDict[bytes, np.ndarray]] = OrderedDict()


@lru_cache(maxsize=32)
def _node_geometry(config: ScenarioConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(elements (M, 3), d_mG (K, M), the departure cosines cubed (K, M), e^{-j 2 pi d_mG / lambda}
    (K, M)) of ``config``'s surface and nodes (the per-element model's, ``channel``)."""
    w = element_positions(config)
    per_node = [element_to_ground(config.node_config(k)) for k in range(config.K)]
    d_mg = np.array([d for d, _ in per_node])
    cos3 = np.array([c for _, c in per_node]) ** 3
    return w, d_mg, cos3, np.exp(-1j * (2 * np.pi / config.wavelength) * d_mg)


def link_rates(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """(U, K, U, K) bps/Hz: r[u*, k*, u, k], node k's rate from UAV u at ``positions`` (U, 2) m when
    the surface's phases line up the link (u*, k*) (eq. (13) for node k* seen from UAV u*), alone
    in its band: log2(1 + eta g) of :func:`link_gains`."""
    return np.log2(1.0 + config.eta * link_gains(config, positions))


def link_gains(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """(U, K, U, K): g[u*, k*, u, k], the expected gain E|h|^2 of the link (u, k) from UAV u at
    ``positions`` (U, 2) m to node k when the surface's phases line up the link (u*, k*)
    (:func:`link_gains_batch` of one fleet)."""
    q = channel.as_positions(positions, "positions")
    return link_gains_batch(config, q[None])[0]


@lru_cache(maxsize=32)
def _node_constants(config: ScenarioConfig) -> tuple[np.ndarray, ...]:
    """Per node k (K,) arrays of its rate kernel's constants: x_c, the reflecting side's sign, the
    transmitting side's factor, whether there is a surface, k_direct, z_U^2, the direct exponent,
    and its (K, 2) positions (``channel.side_factor``'s and ``direct_amplitude``'s)."""
    kernels = [channel.rate_kernel(config.node_config(k)) for k in range(config.K)]
    columns = [[getattr(k, name) for k in kernels] for name in
               ("x_c", "g_side", "t_factor", "has_surface", "k_direct", "z_u2", "d_exp")]  # fmt: skip
    return (*(np.array(c, dtype=float) for c in columns), np.array([k.ground for k in kernels], dtype=float))


def link_gains_batch(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """(B, U, K, U, K): :func:`link_gains` of B fleets at ``positions`` (B, U, 2) m at once.

    The per-element model of ``channel.phased_rates``, factorised: with the element phases
    E_m^u = e^{-j 2 pi d_Um^u / lambda} and F_m^k = e^{-j 2 pi d_mG^k / lambda}, the surface term of
    link (u, k) under alignment l = (u*, k*) is e^{-j 2 pi d_UG^l / lambda} sum_m a_m^{uk} E_m^u F_m^k
    conj(E_m^{u*} F_m^{k*}), so every link under every alignment is one complex matrix product
    (U K x M by M x U K) per fleet. Its rate log2(1 + eta g) equals ``phased_rates`` with
    ``phase_shifts`` of the aligned link to 1e-12 relative (tested); the side factors and the
    direct amplitudes are ``channel.side_factor``'s and ``direct_amplitude``'s expressions."""
    q = np.asarray(positions, dtype=float)
    if q.ndim != 3 or q.shape[2] != 2 or not np.all(np.isfinite(q)):
        raise ValueError(f"positions must be a finite (B, U, 2) array in m, got shape {q.shape}")
    b_n, u_n, k_n = q.shape[0], q.shape[1], config.K
    w, d_mg, cos3, f = _node_geometry(config)
    x_c, g_side, t_factor, has_surface, k_direct, z_u2, d_exp, ground = _node_constants(config)
    wave = 2 * np.pi / config.wavelength
    dx = q[..., 0:1] - w[:, 0]  # (B, U, M)
    d_um = np.sqrt(dx**2 + (q[..., 1:2] - w[:, 1]) ** 2 + (config.uav_altitude - w[:, 2]) ** 2)
    k_a = np.abs(dx / d_um) ** 3
    rel = q[..., 0:1] - x_c  # (B, U, K)
    side = np.where(rel * g_side > 0, 1.0, np.where(rel == 0, 0.0, t_factor)) * (has_surface != 0)
    amp = config.J * k_a[:, :, None, :] * (side[..., None] * cos3) / (d_um[:, :, None, :] * d_mg)
    phase = np.exp(-1j * wave * d_um)[:, :, None, :] * f  # (B, U, K, M): E^u F^k
    flat = phase.reshape(b_n, u_n * k_n, -1)
    sums = np.matmul((amp * phase).reshape(b_n, u_n * k_n, -1), flat.conj().transpose(0, 2, 1))
    apart = ((q[:, :, None, :] - ground) ** 2).sum(axis=-1)  # (B, U, K): |q_u - w_k|^2
    d_ug = np.sqrt(apart + config.uav_altitude**2).reshape(b_n, -1)
    a_d = (k_direct * (apart + z_u2) ** d_exp).reshape(b_n, -1)
    los = sums + a_d[:, :, None] * np.exp(-1j * wave * (d_ug[:, :, None] - d_ug[:, None, :]))
    kappa = config.kappa
    total = amp.sum(axis=3).reshape(b_n, -1) + a_d  # sum_m a_m + a_D of each link
    gain = kappa / (1 + kappa) * np.abs(los) ** 2 + (total**2 / (1 + kappa))[:, :, None]  # [b, (u, k), l]
    return gain.transpose(0, 2, 1).reshape(b_n, u_n, k_n, u_n, k_n)


def cached_link_gains(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """:func:`link_gains_batch` of ``positions`` (B, U, 2) m, each row's gains kept by its
    positions' bytes (the last :data:`GAIN_CACHE_SLOTS` rows of the last
    :data:`GAIN_CACHE_SCENARIOS` scenarios): a row seen before is not computed again, so scoring
    flights that differ from earlier ones in a few slots costs those slots. The values are
    :func:`link_gains_batch`'s, bit for bit (each row is computed alone or in a batch of the same
    arithmetic; tested)."""
    q = np.ascontiguousarray(positions, dtype=float)
    if q.ndim != 3 or q.shape[2] != 2 or not np.all(np.isfinite(q)):
        raise ValueError(f"positions must be a finite (B, U, 2) array in m, got shape {q.shape}")
    table = _GAINS.pop(config, None)
    table = OrderedDict() if table is None else table
    _GAINS[config] = table  # the most recent scenario last
    while len(_GAINS) > GAIN_CACHE_SCENARIOS:
        _GAINS.popitem(last=False)
    keys = [row.tobytes() for row in q]
    missing = list(dict.fromkeys(key for key in keys if key not in table))
    if missing:
        rows = {key: b for b, key in enumerate(keys)}
        for key, gains in zip(missing, link_gains_batch(config, q[[rows[k] for k in missing]]), strict=True):
            table[key] = gains
    out = np.empty((len(q), *table[keys[0]].shape))
    for b, key in enumerate(keys):
        out[b] = table[key]
        table.move_to_end(key)
    while len(table) > GAIN_CACHE_SLOTS:
        table.popitem(last=False)
    return out
