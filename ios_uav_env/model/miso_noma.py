"""NOMA from the multi-antenna UAV: superposition coding and SIC among the K users of one slot.

The slot of :mod:`ios_uav_env.model.miso` (K users, N_t antennas, M elements with one shared phase
setting psi; powers in units of P, noise 1): the UAV sends x = sum_k w_k s_k with beams
W = [w_1 ... w_K], sum_k ||w_k||^2 <= 1, as SDMA does, but the users cancel each other's signals by
successive interference cancellation (SIC) in a stated **decoding order** pi = (pi(1), ..., pi(K)):
every message is decoded in that order, and user pi(i) decodes the messages of pi(1), ..., pi(i - 1),
removes them, then decodes its own and treats the later ones as noise. So decoder pi(i) sees
message pi(j) (j <= i) at

    SINR_{i<-j} = |h_pi(i) w_pi(j)|^2 / (sum_{l > j} |h_pi(i) w_pi(l)|^2 + 1),

and message pi(j) is decodable by all of pi(j), ..., pi(K) (its own user and every user that must
remove it) iff its rate is at most the least of their capacities; the achievable rate is

    R_pi(j) = min_{i >= j} log2(1 + SINR_{i<-j})   (bps/Hz)

(the standard SIC rate condition of the MISO-NOMA downlink: Y. Liu, Z. Qin, M. Elkashlan, Z. Ding,
A. Nallanathan and L. Hanzo, *Nonorthogonal multiple access for 5G and beyond*, Proc. IEEE 105(12),
2017; M. F. Hanif, Z. Ding, T. Ratnarajah and G. K. Karagiannidis, *A
minorization-maximization method for optimizing sum rate in the downlink of non-orthogonal multiple
access systems*, IEEE TSP 64(1), 2016). The last user pi(K) decodes everything and
sees no interference. This is the convention of the STAR model's two-user NOMA
(``star.noma_rates``: the weaker user's message is decoded first, by both, and the stronger user
removes it), generalised to K users and beams: with N_t = 1, K = 2 and pi ascending in
|h_k(psi)|^2 the rates are ``star.noma_rates`` of the SNRs g_k = |h_k|^2 and the power split
(tested), because a stronger decoder's SINR of the weak message, g_s p_w / (g_s p_s + 1), is at
least the weak user's own.

**The default order** (:func:`decoding_order`): ascending G_k, each user's single-user gain bound
``miso.user_gain_bound`` (an upper bound of |h_k w|^2 over the surface settings and unit beams,
equal to its maximum for the rank-one UAV-surface link; on a full-rank one, e.g. Rician scattering
per element, the triangle inequality's bound), ties by index: the user the slot can serve least
well (by that measure) is decoded first, by everyone, and the best-served one decodes every
message. It is a function of the slot's channel alone, not of the setting, so a given order's
rates are continuous in the beams and the phases (an order read off |h_k(psi)|^2 would jump with
psi); any permutation can be given instead.

**Full power.** Scaling every beam by c > 1 turns every SINR a / (b + 1) into c^2 a / (c^2 b + 1),
larger: the optimum spends all of P, and the AO searches the unit sphere ||W||_F = 1.

**The certified bound holds for NOMA.** R_pi(j) <= log2(1 + SINR_{j<-j}) (the min includes the own
decoder) <= log2(1 + |h_pi(j) w_pi(j)|^2) (dropping the interference) <= log2(1 + p_pi(j) G_pi(j))
(Cauchy-Schwarz and G's definition, p_k = ||w_k||^2, sum p_k <= 1), the same per-user
interference-free inequality that ``miso.slot_bounds`` (the water-filling sum and the max-min
log2(1 + 1 / sum_k 1 / G_k)) and ``miso.weighted_sum_bound`` are built on: every NOMA setting, of
every order, lies below them (tested on drawn slots, against the AO and random settings).

The per-slot optimisation for a fixed order is ``ios_uav_env.model.miso_noma_slot``.
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.jit import jit
from ios_uav_env.model.miso import SlotChannel, check_beams, check_objective, user_gain_bound

__all__ = ["check_order", "decoding_order", "noma_value", "order_gains", "sic_rates"]


def order_gains(channel: SlotChannel) -> np.ndarray:
    """The gains G_k (K,) the default order sorts: ``miso.user_gain_bound`` of each user."""
    return np.array([user_gain_bound(channel, k) for k in range(channel.K)])


def decoding_order(channel: SlotChannel, order: object = None) -> np.ndarray:
    """The slot's decoding order (K,) int, first decoded first: ``order`` checked
    (:func:`check_order`), or by default the users by ascending G_k (:func:`order_gains`; a stable
    sort, ties by index)."""
    if order is not None:
        return check_order(order, channel.K)
    return np.argsort(order_gains(channel), kind="stable").astype(np.int64)


def check_order(order: object, K: int) -> np.ndarray:
    """``order`` as an int array (K,), a permutation of 0, ..., K - 1, else ``ValueError``."""
    try:
        arr = np.asarray(order)
    except Exception:  # noqa: BLE001 (any object that is no sequence of integers)
        arr = np.empty(0)
    ok = arr.shape == (K,) and arr.dtype.kind in "iu" and sorted(arr.tolist()) == list(range(K))
    if not ok:
        raise ValueError(
            f"order must be a permutation of 0, ..., {K - 1} (the decoding order, first decoded "
            f"first), got {order!r}"
        )
    return arr.astype(np.int64)


def sic_rates(H: np.ndarray, beams: np.ndarray, order: object) -> np.ndarray:
    """Each user's SIC rate R_k (bps/Hz), shape (K,), in user order (the module docstring):
    ``H`` (K, N_t) from ``SlotChannel.matrix``, ``beams`` W (N_t, K) of total power <= 1 and
    ``order`` the decoding order (a permutation of the users, first decoded first)."""
    W = check_beams(beams, H.shape)
    pi = check_order(order, H.shape[0])
    out = np.empty(H.shape[0])
    _rates(np.ascontiguousarray(H @ W), pi, out)
    return out


def noma_value(H: np.ndarray, beams: np.ndarray, order: object, objective: str) -> float:
    """The slot's objective ("sum" or "maxmin") of the SIC rates :func:`sic_rates`."""
    check_objective(objective)
    W = check_beams(beams, H.shape)
    pi = check_order(order, H.shape[0])
    return float(_value(np.ascontiguousarray(H @ W), pi, objective == "sum", np.empty(H.shape[0])))


@jit(fastmath=False)
def _rates(X: np.ndarray, order: np.ndarray, out: np.ndarray) -> None:
    """The SIC rates into ``out`` (K,) from the products ``X`` (K, K), X[k, j] = h_k w_j."""
    K = X.shape[0]
    for jp in range(K):
        j = order[jp]
        worst = np.inf
        for ip in range(jp, K):
            i = order[ip]
            rest = 1.0
            for lp in range(jp + 1, K):
                rest += abs(X[i, order[lp]]) ** 2
            worst = min(worst, np.log1p(abs(X[i, j]) ** 2 / rest) / math.log(2.0))
        out[j] = worst


@jit(fastmath=False)
def _value(X: np.ndarray, order: np.ndarray, total: bool, out: np.ndarray) -> float:
    """The objective of the SIC rates of ``X``: their sum (``total``) or their minimum."""
    _rates(X, order, out)
    if total:
        acc = 0.0
        for k in range(out.size):
            acc += out[k]
        return acc
    return out.min()
