"""The multi-antenna UAV's slot channel: K users served at once by linear precoding (SDMA).

The UAV carries the N_t-antenna ULA of :mod:`ios_uav_env.model.array` and serves the K ground nodes
of a :class:`~ios_uav_env.model.config.ScenarioConfig` (``config.node_config(k)`` is user k) in one
slot. Notation (``docs/model.md``, "Multi-antenna UAV"): lambda the wavelength, k_w = 2 pi / lambda;
d_Um, d_mk, d_Uk the UAV-element, element-user and UAV-user distances; a_km the LoS amplitude via
element m towards user k (``channel.element_amplitudes`` of user k's config: eq. (6), the patterns
with user k's side factor, so a user across the surface is served by transmission, epsilon, a user
on the UAV's side by reflection); a_Dk the direct amplitude (``channel.direct_amplitude``);
a(.) the steering vectors; eta = P / sigma^2.

**The channel.** The surface's phase shifts psi_m (rad; the convention of ``channel.los_channel``
and eq. (13)) are one configuration per slot, shared by every user: an IOS element applies its one
phase to what it reflects and to what it transmits. With v_m = exp(-j psi_m), user k receives
y_k = h_k x + n_k, n_k ~ CN(0, sigma^2), through the row

    h_k(psi) = sqrt(eta) [ sum_m v_m a_km exp(-j k_w (d_Um + d_mk)) a_m^T + a_Dk exp(-j k_w d_Uk) a_k^T ]
             = sum_m v_m c_km g_m^T + d_k^T,

a_m the steering vector of the UAV-element link (the surface's centre for ``steering="centre"``),
a_k that of the UAV-user link. The sqrt(eta) scaling puts the powers in units of P and the noise
at 1: the precoder x = sum_k w_k s_k (unit-power symbols) has beams W = [w_1 ... w_K] with
sum_k ||w_k||^2 <= 1, and user k's rate is

    r_k = log2(1 + |h_k w_k|^2 / (sum_{j != k} |h_k w_j|^2 + 1))   (bps/Hz).

These are the LoS (kappa -> infinity) channels: with the closed-form phases of eq. (13), N_t = 1 and
w = 1, |h|^2 = eta zeta^2 and r is exactly ``channel.slot_rates`` (the expected-gain rate).

**One user: the closed form** (Wu & Zhang, IEEE TWC 2019, Section III, for a rank-one
UAV-surface channel). With ``steering="centre"`` every g_m is a_c, so h(psi) = s(v) a_c^T + d^T with
s(v) = sum_m v_m c_m and |s| <= S = sum_m |c_m|. For any beam with ||w|| <= 1, |h w|^2 <= ||h||^2
(Cauchy-Schwarz: MRT w = h^H / ||h|| attains it), and with beta = a_c^T conj(d),

    ||h||^2 = |s|^2 N_t + 2 Re{s beta} + ||d||^2 <= S^2 N_t + 2 S |beta| + ||d||^2 = G,

with equality iff every term of s has the phase of conj(beta): v_m = exp(-j (arg c_m + arg beta)),
i.e. psi_m = arg c_m + arg beta (mod 2 pi) (:func:`aligned_phases`), and the beam is MRT on the
combined channel. The optimum rate is log2(1 + G); for N_t = 1 it is (S + |d|)^2 = eta zeta^2, eq. (14).
With ``steering="element"`` the g_m differ, the aligned phases are a feasible point, and
G <= (sum_m |c_m| ||g_m|| + ||d||)^2 = (sqrt(N_t) S + ||d||)^2 is a certified bound
(:func:`user_gain_bound`).

**Upper bounds of a slot** (:func:`slot_bounds`). Dropping the interference and by Cauchy-Schwarz,
SINR_k <= ||w_k||^2 G_k for any surface, G_k the bound of user k alone; with p_k = ||w_k||^2 and
sum_k p_k <= 1: the sum rate is at most the water-filling value max sum_k log2(1 + p_k G_k), and the
max-min rate at most log2(1 + 1 / sum_k (1 / G_k)) (equal p_k G_k), which is at most the smallest
single-user optimum log2(1 + min_k G_k). By concavity of log2(1 + x), log2(1 + p G) >= p log2(1 + G),
so these bound TDMA (:func:`tdma_rates`) too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ios_uav_env.model import channel as ch
from ios_uav_env.model.array import ArrayConfig, link_response
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.surface import element_positions

#: The per-slot objectives: the sum rate and the max-min rate of the K users (bps/Hz).
SLOT_OBJECTIVES: tuple[str, ...] = ("sum", "maxmin")
#: Slack on the beams' total power sum ||w_k||^2 <= 1 (rounding of a normalisation).
POWER_TOL = 1e-9


@dataclass(frozen=True, eq=False)
class SlotChannel:
    """The K users' channels at one UAV position, as functions of the surface's phases
    (the module docstring: h_k(psi) = sum_m v_m c_km g_m^T + d_k^T, scaled by sqrt(eta))."""

    coef: np.ndarray  # (K, M) complex: c_km = sqrt(eta) a_km exp(-j k_w (d_Um + d_mk))
    to_elements: np.ndarray  # (M, N_t) complex: g_m, the UAV-element steering vectors
    direct: np.ndarray  # (K, N_t) complex: d_k = sqrt(eta) a_Dk exp(-j k_w d_Uk) a_k
    rank_one: bool  # every g_m equal (steering "centre"): the single-user optimum is closed form

    @property
    def K(self) -> int:
        """Number of users K."""
        return self.coef.shape[0]

    @property
    def M(self) -> int:
        """Number of surface elements M."""
        return self.coef.shape[1]

    @property
    def n_t(self) -> int:
        """Number of UAV antennas N_t."""
        return self.direct.shape[1]

    def matrix(self, phases: np.ndarray) -> np.ndarray:
        """H (K, N_t), row k = h_k(psi), for the surface's phase shifts ``phases`` psi (M,) rad."""
        return self.matrix_unchecked(self.check_phases(phases))

    def matrix_unchecked(self, phases: np.ndarray) -> np.ndarray:
        """:meth:`matrix` of ``phases`` that are a finite float (M,) array already (an optimiser's
        own iterates, in its inner loop), without :meth:`check_phases`."""
        return (self.coef * np.exp(-1j * phases)) @ self.to_elements + self.direct

    def check_phases(self, phases: np.ndarray) -> np.ndarray:
        """``phases`` as a finite float (M,) array (one shared configuration), else ``ValueError``."""
        psi = np.asarray(phases, dtype=float)
        if psi.shape != (self.M,) or not np.all(np.isfinite(psi)):
            raise ValueError(
                f"phases must be a finite array of shape ({self.M},) (one phase shift per element, rad), "
                f"got shape {psi.shape}"
            )
        return psi


def slot_channel(config: ScenarioConfig, array: ArrayConfig, position: np.ndarray) -> SlotChannel:
    """The :class:`SlotChannel` of ``config``'s K nodes for the UAV at horizontal ``position``
    (2,) m, built from the single-node channel's per-element functions of each node's config
    (:func:`slot_channels` of one position)."""
    return slot_channels(config, array, one_position(position))[0]


def one_position(position: np.ndarray) -> np.ndarray:
    """``position`` as a (1, 2) array of one horizontal position (x, y) m, else ``ValueError``."""
    q = ch.as_positions(position, "position")
    if len(q) != 1:
        raise ValueError(
            f"position must be one horizontal position (x, y) in m, got shape {np.shape(position)}"
        )
    return q


def slot_channels(config: ScenarioConfig, array: ArrayConfig, trajectory: np.ndarray) -> list[SlotChannel]:
    """The :class:`SlotChannel` of each horizontal position of ``trajectory`` (P, 2) m, all P at once:
    the per-element functions of ``ios_uav_env.model.channel`` and the steering vectors take arrays
    of positions. Each channel is :func:`slot_channel`'s at that position to rounding (the steering
    cosines are dot products, summed as the matrix product of P rows sums them)."""
    q = ch.as_positions(trajectory, "trajectory")
    if not isinstance(array, ArrayConfig):
        raise TypeError(f"array must be an ArrayConfig, got {array!r}")
    P = len(q)
    uav = np.column_stack([q, np.full(P, config.uav_altitude)])  # (P, 3)
    k_w, root = 2.0 * np.pi / config.wavelength, np.sqrt(config.eta)
    coef = np.empty((P, config.K, config.M), dtype=complex)
    direct = np.empty((P, config.K, array.n_t), dtype=complex)
    for k in range(config.K):  # K configs, each vectorised over the P positions and M elements
        user = config.node_config(k)
        geometry = _geometry(user, q)
        amplitude = ch.element_amplitudes(user, q)  # (P, M)
        coef[:, k] = root * amplitude * np.exp(-1j * k_w * (geometry["d_um"] + geometry["d_mg"]))
        ground = np.array([*user.ground_node, 0.0])
        phase = np.exp(-1j * k_w * geometry["d_ug"])  # (P,)
        scale = root * ch.direct_amplitude(user, q) * phase
        direct[:, k] = scale[:, None] * link_response(array, uav, ground)
    if array.steering == "centre":
        centre = link_response(array, uav, np.asarray(config.ios_center))  # (P, N_t)
        to_elements = np.broadcast_to(centre[:, None, :], (P, config.M, array.n_t))
    else:
        to_elements = link_response(array, uav[:, None, :], element_positions(config))  # (P, M, N_t)
    rank_one = array.steering == "centre"
    return [
        SlotChannel(coef[p], np.ascontiguousarray(to_elements[p]), direct[p], rank_one=rank_one)
        for p in range(P)
    ]


def _geometry(config: ScenarioConfig, q: np.ndarray) -> dict[str, np.ndarray]:
    """The single-node channel's distances (d_Um (1, M), d_mG (M,), d_UG (1,)) for one node."""
    return ch._element_geometry(config, q)


def sinr(H: np.ndarray, beams: np.ndarray) -> np.ndarray:
    """SINR_k = |h_k w_k|^2 / (sum_{j != k} |h_k w_j|^2 + 1) of each user, shape (K,): ``H`` (K, N_t)
    from :meth:`SlotChannel.matrix`, ``beams`` W (N_t, K) with sum_k ||w_k||^2 <= 1 (the power P)."""
    W = check_beams(beams, H.shape)
    gains = np.abs(H @ W) ** 2
    signal = np.diag(gains).copy()
    return signal / (gains.sum(axis=1) - signal + 1.0)


def user_rates(H: np.ndarray, beams: np.ndarray) -> np.ndarray:
    """Each user's rate log2(1 + SINR_k) (bps/Hz), shape (K,): :func:`sinr`."""
    return np.log2(1.0 + sinr(H, beams))


def check_objective(objective: str) -> None:
    """``ValueError`` unless ``objective`` is one of :data:`SLOT_OBJECTIVES`."""
    if objective not in SLOT_OBJECTIVES:
        raise ValueError(f"objective must be one of {SLOT_OBJECTIVES}, got {objective!r}")


def objective_value(rates: np.ndarray, objective: str) -> float:
    """The slot's objective of the users' ``rates``: their sum, or their minimum ("maxmin")."""
    check_objective(objective)
    return float(np.sum(rates) if objective == "sum" else np.min(rates))


def check_beams(beams: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """``beams`` as a complex (N_t, K) array of total power <= 1 (+ :data:`POWER_TOL`), else ValueError."""
    W = np.asarray(beams, dtype=complex)
    K, n_t = shape
    if W.shape != (n_t, K) or not np.all(np.isfinite(W)):
        raise ValueError(
            f"beams must be a finite complex array of shape ({n_t}, {K}) (N_t, K), got {W.shape}"
        )
    power = float(np.sum(np.abs(W) ** 2))
    if power > 1.0 + POWER_TOL:
        raise ValueError(f"beams must have total power sum_k ||w_k||^2 in [0, 1] (units of P), got {power!r}")
    return W


# --- one user: the closed form and the bounds ------------------------------------------------


def aligned_phases(channel: SlotChannel, k: int) -> np.ndarray:
    """Phase shifts (M,) rad that turn every surface path of user k in phase with its direct row:
    psi_m = arg(c_km g_m^T conj(d_k)) mod 2 pi. The joint optimum with MRT when the UAV-surface
    channel is rank one (the module docstring); eq. (13) for N_t = 1."""
    _check_user(channel, k)
    return np.mod(np.angle(channel.coef[k] * (channel.to_elements @ channel.direct[k].conj())), 2 * np.pi)


def mrt_beam(h: np.ndarray) -> np.ndarray:
    """Maximum-ratio transmission w = h^H / ||h|| (N_t,) of one row h at full power (zero row: zeros)."""
    norm = np.linalg.norm(h)
    return h.conj() / norm if norm > 0 else np.zeros_like(h, dtype=complex)


def user_gain_bound(channel: SlotChannel, k: int) -> float:
    """G_k >= max over the surface and beams ||w|| <= 1 of |h_k w|^2 (SNR units): exact (attained by
    :func:`aligned_phases` and MRT) when ``channel.rank_one``, else (sum_m |c_km| ||g_m|| + ||d_k||)^2
    (the triangle inequality and Cauchy-Schwarz: certified for any UAV-surface matrix, e.g. a Rician
    draw of ``model.miso_fading``; (sqrt(N_t) S + ||d_k||)^2 for unit-modulus steering rows)."""
    _check_user(channel, k)
    S = float(np.abs(channel.coef[k]).sum())
    d = channel.direct[k]
    if channel.rank_one:
        beta = abs(complex(channel.to_elements[0] @ d.conj())) if channel.M else 0.0
        return S * S * channel.n_t + 2.0 * S * beta + float(np.vdot(d, d).real)
    row_norms = np.linalg.norm(channel.to_elements, axis=1)
    return float((np.abs(channel.coef[k]) @ row_norms + np.linalg.norm(d)) ** 2)


def tdma_rates(channel: SlotChannel) -> np.ndarray:
    """Each user's rate log2(1 + |h_k w_k|^2) served alone at full power with its own aligned phases
    and MRT (today's TDMA: one node per share of the slot), shape (K,). The single-user optimum
    when ``channel.rank_one``."""
    out = np.empty(channel.K)
    for k in range(channel.K):
        h = channel.matrix(aligned_phases(channel, k))[k]
        out[k] = np.log2(1.0 + float(np.vdot(h, h).real))
    return out


def tdma_value(rates: np.ndarray, objective: str) -> float:
    """TDMA's best slot objective from the users' full-slot rates R_k: shares tau_k >= 0 summing to 1
    give tau_k R_k; the sum is at most max_k R_k (all to the best), the max-min 1 / sum_k (1 / R_k)."""
    r = np.asarray(rates, dtype=float)
    if objective_value(r, objective) <= 0:
        return 0.0
    return float(r.max()) if objective == "sum" else float(1.0 / np.sum(1.0 / r))


@dataclass(frozen=True)
class SlotBounds:
    """Certified upper bounds of a slot's objectives (bps/Hz; the module docstring)."""

    sum_rate: float  # water-filling over the single-user gains G_k
    maxmin_rate: float  # log2(1 + 1 / sum_k (1 / G_k))
    gains: np.ndarray  # (K,) G_k of :func:`user_gain_bound`

    def of(self, objective: str) -> float:
        """The bound of ``objective`` ("sum" or "maxmin")."""
        check_objective(objective)
        return self.sum_rate if objective == "sum" else self.maxmin_rate


def slot_bounds(channel: SlotChannel) -> SlotBounds:
    """The :class:`SlotBounds` of ``channel``: no precoder and surface serve the K users better."""
    gains = np.array([user_gain_bound(channel, k) for k in range(channel.K)])
    maxmin = 0.0 if np.any(gains <= 0) else float(np.log2(1.0 + 1.0 / np.sum(1.0 / gains)))
    return SlotBounds(float(np.sum(np.log2(1.0 + water_filling(gains) * gains))), maxmin, gains)


def water_filling(gains: np.ndarray, total: float = 1.0) -> np.ndarray:
    """Powers p >= 0, sum p = ``total``, maximising sum_k log2(1 + p_k G_k): p_k = (mu - 1 / G_k)^+."""
    g = np.asarray(gains, dtype=float)
    p = np.zeros_like(g)
    active = np.flatnonzero(g > 0)
    if active.size == 0:
        return p
    inverse = np.sort(1.0 / g[active])
    for n in range(inverse.size, 0, -1):  # the most users whose level stays above their floor
        mu = (total + inverse[:n].sum()) / n
        if mu > inverse[n - 1]:
            break
    p[active] = np.maximum(mu - 1.0 / g[active], 0.0)
    return p


def weighted_sum_bound(gains: np.ndarray, weights: np.ndarray) -> float:
    """A certified upper bound (bps/Hz) of the slot's weighted sum rate sum_k w_k R_k: every beam set
    of total power 1 gives SINR_k <= ||w_k||^2 G_k (no interference, each user's best gain), so
    the weighted sum is at most max_{p >= 0, sum p <= 1} sum_k w_k log2(1 + p_k G_k), and that is
    at most the Lagrangian dual D(mu) = [mu + sum_k max_{p >= 0} (w_k ln(1 + p G_k) - mu p)] / ln 2
    for every mu > 0; mu is the water level's (bisection on p_k = (w_k / mu - 1 / G_k)^+ summing
    to 1), where D is the maximum itself."""
    g, w = np.asarray(gains, dtype=float), np.asarray(weights, dtype=float)
    live = (g > 0) & (w > 0)
    if not np.any(live):
        return 0.0
    g, w = g[live], w[live]

    def dual(mu: float) -> tuple[float, float]:
        p = np.maximum(w / mu - 1.0 / g, 0.0)
        return float(p.sum()), float(mu + np.sum(w * np.log1p(p * g) - mu * p)) / math.log(2.0)

    lo, hi = 1e-300, float(np.max(w * g))  # at mu = max w_k G_k every p_k = 0 <= 1
    for _ in range(2000):  # the power sum falls with mu: the level where it is 1
        mid = math.sqrt(lo * hi) if hi / lo > 4.0 else 0.5 * (lo + hi)
        lo, hi = (mid, hi) if dual(mid)[0] > 1.0 else (lo, mid)
        if hi - lo <= 1e-15 * hi:
            break
    return min(dual(lo)[1], dual(hi)[1])


# --- linear precoders (the baselines) ---------------------------------------------------------


def mrt_beams(H: np.ndarray) -> np.ndarray:
    """MRT for every user, equal powers 1 / K: w_k = h_k^H / (||h_k|| sqrt(K)), shape (N_t, K)."""
    return np.stack([mrt_beam(h) for h in H], axis=1) / np.sqrt(H.shape[0])


def zf_beams(H: np.ndarray) -> np.ndarray:
    """Zero-forcing, equal powers 1 / K: the columns of H^H (H H^H)^-1 normalised, shape (N_t, K).
    Needs N_t >= K linearly independent rows: ``ValueError`` otherwise."""
    K, n_t = H.shape
    if n_t < K:
        raise ValueError(f"zero-forcing needs n_t >= K antennas (N_t = {n_t}, K = {K} users)")
    gram = H @ H.conj().T
    if np.linalg.cond(gram) > 1e12:
        raise ValueError("zero-forcing needs linearly independent user channels (H H^H is singular)")
    W = H.conj().T @ np.linalg.inv(gram)
    return W / np.linalg.norm(W, axis=0) / np.sqrt(K)


def random_phases(channel: SlotChannel, rng: np.random.Generator) -> np.ndarray:
    """Phase shifts drawn uniformly in [0, 2 pi) from ``rng``, shape (M,)."""
    return rng.uniform(0.0, 2.0 * np.pi, channel.M)


def baselines(channel: SlotChannel, objective: str, rng: np.random.Generator) -> dict[str, float]:
    """The slot objective of the reference schemes: MRT and ZF (equal powers) with the best of the
    K users' aligned phases, and with random phases (one draw from ``rng``); TDMA
    (:func:`tdma_value`). ZF is NaN when N_t < K."""
    aligned = [aligned_phases(channel, k) for k in range(channel.K)]
    drawn = random_phases(channel, rng)
    out: dict[str, float] = {}
    for name, precoder in (("MRT", mrt_beams), ("ZF", zf_beams)):
        for label, candidates in (("aligned", aligned), ("random", [drawn])):
            values = []
            for phases in candidates:
                H = channel.matrix(phases)
                try:
                    values.append(objective_value(user_rates(H, precoder(H)), objective))
                except ValueError:
                    values.append(np.nan)
            out[f"{name} {label}"] = float(np.nanmax(values)) if not np.all(np.isnan(values)) else np.nan
    out["TDMA"] = tdma_value(tdma_rates(channel), objective)
    return out


def _check_user(channel: SlotChannel, k: int) -> None:
    if not (isinstance(k, (int, np.integer)) and 0 <= k < channel.K):
        raise ValueError(f"user index k must be an integer in [0, {channel.K - 1}], got {k!r}")
