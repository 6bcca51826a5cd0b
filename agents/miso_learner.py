"""A learned beam and surface controller for ``ios_uav_env/MISOControl-v0`` and its suite ``miso-v1``.

:class:`MisoLearner` plays every scenario of the suite (any N_t, K, M and objective) with one set
of weights: a small network maps per-user features of the observation to the 3 parameters per
user of a structured setting, and the setting is built from the observation. Everything is read
from the observation by name (:func:`layout`); nothing else of the slot is known to the policy.

**The channel the observation gives.** With the env's rank-one UAV-surface channel (``model/miso``:
h_k(psi) = sum_m v_m c_km a^T + d_k^T, v_m = exp(-j psi_m)) the observation holds the unit direct
rows d_k / ||d_k||, the steering vector a / sqrt(N_t), the aligned phases psi_km = arg c_km +
arg beta_k (beta_k = a^T conj(d_k)), the surface share sqrt(N_t) S_k / (sqrt(N_t) S_k + ||d_k||)
(S_k = sum_m |c_km|) and the gain shares G_k / sum_j G_j, G_k = S_k^2 N_t + 2 S_k |beta_k| +
||d_k||^2. So arg c_km = psi_km - arg beta_k, rho_k = S_k / ||d_k|| and, with the elements'
amplitudes taken equal (|c_km| = S_k / M: the small surface is in every user's far field, the
amplitudes differ by about 1 %), each row is known up to one common scale:

    h_k(psi) / ||d_k|| = (rho_k / M) sum_m exp(j arg c_km) v_m a^T + d_k^T / ||d_k||,

and ||d_k||^2 proportional to G_k share / (rho_k^2 N_t + 2 rho_k |beta_k| / ||d_k|| + 1). The rows
scaled so that the ||d_k||^2 sum to 1 are H-hat (:func:`estimated_rows`); the missing common scale
is the slot's SNR, which the network infers (from the UAV's and the users' positions, among its
features).

**The setting** (:func:`setting`) of the network's outputs (z_k, y_k, a_k) per user:

- phases: psi = arg sum_k omega_k exp(j psi_k), omega = softmax(a): a weighted combination of the
  users' aligned phase vectors (one user's when its weight dominates);
- beams: w_k = sqrt(p_k) u_k / ||u_k||, u_k = (I + sum_j q_j h-hat_j^H h-hat_j)^-1 h-hat_k^H with
  q_j = exp(``LOG_Q0`` + z_j) and p = softmax(y). This is the structure of every Pareto-optimal
  linear precoder of a MISO broadcast channel (Bjornson, Bengtsson & Ottersten, "Optimal
  multiuser transmit beamforming: a difficult problem with a simple solution structure", IEEE
  Signal Processing Magazine 2014: the MMSE directions of a virtual uplink with powers q_j, the
  downlink powers p_k), so the optimum of the sum rate and of the max-min rate for the phases is
  in the family (for the rows the observation gives); q_j -> 0 gives MRT, large equal q_j
  regularised ZF.

The network (:func:`outputs`) is shared by the users: user k's features and the global ones
(the task, the UAV's position, the users' means) -> (z_k, y_k, a_k), so one set of weights plays
every K. Its zero output is equal powers, equal phase weights and q_j = exp(``LOG_Q0``). It is
float64 numpy at play time (no torch). A model folder holds ``weights.npz`` and ``config.json``
(how it was trained: :mod:`agents.miso_training`). Play it on the suite with
``python -m ios_uav_env.benchmark evaluate --suite miso-v1 --policy agents.miso_learner:MisoLearner``.
"""

from __future__ import annotations

import copy
import json
import math
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from agents.star_learner import load_layers, mlp
from ios_uav_env.benchmark.miso_suite import MisoTask
from ios_uav_env.envs.miso_control import wrap

#: The shipped model.
DEFAULT_MODEL = Path(__file__).resolve().parent / "models" / "miso_learner_MISOControl-v0"
#: The zero output's log q_j (the virtual uplink powers in units of the rows' total gain).
LOG_Q0 = 4.0
#: The network's outputs are clipped to +-``OUT_CLIP`` (the softmax and exp stay finite).
OUT_CLIP = 30.0
#: Per-user and global features, the network's input and output widths.
USER_FEATURES = 10
GLOBAL_FEATURES = 9 + USER_FEATURES
NET_IN, NET_OUT = USER_FEATURES + GLOBAL_FEATURES, 3
#: Floors of the logs taken (a zero scale or eigenvalue keeps a finite feature).
LOG_FLOOR = 1e-6


@dataclass(frozen=True)
class Layout:
    """Where a task's observation holds what the policy reads (indices into the observation)."""

    uav: np.ndarray  # (3,): x, y, slot
    users: np.ndarray  # (K, 2): dx, dy
    surface: np.ndarray  # (K,)
    gain: np.ndarray  # (K,)
    direct: np.ndarray  # (K, 2, N_t): re, im
    steering: np.ndarray  # (2, N_t): re, im
    aligned: np.ndarray  # (K, M)


def layout(task: MisoTask) -> Layout:
    """The :class:`Layout` of ``task``'s observation names (``ValueError`` naming a missing one)."""
    names = {name: i for i, name in enumerate(task.observation_names)}
    k_range, n_range = range(task.users), range(task.antennas)

    def at(keys: Any) -> np.ndarray:
        missing = [str(key) for key in np.ravel(keys) if key not in names]
        if missing:
            raise ValueError(
                f"MisoLearner reads the MISOControl-v0 observation by name: {missing[0]!r} is not among "
                f"the task's {len(names)} observation_names"
            )
        return np.vectorize(names.__getitem__)(np.asarray(keys))

    return Layout(
        uav=at(["miso_uav_x", "miso_uav_y", "miso_slot"]),
        users=at([[f"miso_user_{k}_{a}" for a in ("dx", "dy")] for k in k_range]),
        surface=at([f"miso_surface_share_{k}" for k in k_range]),
        gain=at([f"miso_gain_share_{k}" for k in k_range]),
        direct=at([[[f"miso_direct_{k}_{p}_{n}" for n in n_range] for p in ("re", "im")] for k in k_range]),
        steering=at([[f"miso_steering_{p}_{n}" for n in n_range] for p in ("re", "im")]),
        aligned=at([[f"miso_aligned_{k}_{m}" for m in range(task.M)] for k in k_range]),
    )


@dataclass(frozen=True)
class View:
    """What a batch of B observations says of their slots (module docstring): the unit direct rows
    (B, K, N_t), the steering vector a (B, N_t) (unit-modulus entries), rho_k = S_k / ||d_k||
    (B, K), the rows' relative gains ||d_k||^2 / sum_j ||d_j||^2 (B, K), exp(j psi_km) of the
    aligned phases and exp(j arg c_km) of the surface coefficients (B, K, M), the per-user
    features (B, K, ``USER_FEATURES``) and the global ones (B, ``GLOBAL_FEATURES``)."""

    direct: Any
    steering: Any
    ratio: Any
    scale: Any
    aligned: Any
    coef: Any
    user: Any
    glob: Any


def view(obs: np.ndarray, task: MisoTask, where: Layout) -> View:
    """The :class:`View` of observations ``obs`` (B, width) of ``task`` laid out as ``where``."""
    o = np.asarray(obs, dtype=np.float64)
    n_t, k = task.antennas, task.users
    direct = o[:, where.direct[:, 0]] + 1j * o[:, where.direct[:, 1]]  # (B, K, N_t)
    direct = direct / np.maximum(np.linalg.norm(direct, axis=-1, keepdims=True), LOG_FLOOR)
    steering = math.sqrt(n_t) * (o[:, where.steering[0]] + 1j * o[:, where.steering[1]])
    share = np.clip(o[:, where.surface], 0.0, 1.0 - 1e-9)
    ratio = share / (math.sqrt(n_t) * (1.0 - share))
    beta = np.einsum("bn,bkn->bk", steering, direct.conj())
    gain = np.maximum(o[:, where.gain], 0.0)
    scale = gain / (ratio**2 * n_t + 2 * ratio * np.abs(beta) + 1.0)
    scale = scale / np.maximum(scale.sum(axis=1, keepdims=True), LOG_FLOOR)
    aligned = np.exp(1j * np.pi * o[:, where.aligned])
    coef = aligned * np.exp(-1j * np.angle(beta))[..., None]
    gram = direct @ direct.conj().swapaxes(-1, -2)  # (B, K, K), ones on the diagonal
    corr = np.abs(gram)
    others = np.where(np.eye(k, dtype=bool), np.nan, corr)
    uav, users = o[:, where.uav], o[:, where.users] * 10.0  # the users sit within 30 m of the surface
    distance = np.hypot(*(uav[:, None, :2] - o[:, where.users]).transpose(2, 0, 1))
    user = np.stack(
        [np.log(np.maximum(k * scale, LOG_FLOOR)) / 4, gain, o[:, where.surface],
         np.abs(beta) / math.sqrt(n_t), np.nanmean(others, axis=-1), np.nanmax(others, axis=-1),
         users[..., 0], users[..., 1], distance, np.log(np.maximum(distance, LOG_FLOOR))],
        axis=-1,
    )  # fmt: skip
    smallest = np.linalg.eigvalsh(gram)[:, 0]  # 0 when K > N_t
    task_row = [n_t / 8, k / 4, math.log2(task.M) / 6, task.objective == "sum", task.objective == "maxmin"]
    glob = np.column_stack(
        [np.broadcast_to(np.asarray(task_row, dtype=np.float64), (len(o), 5)), uav,
         np.log(np.maximum(smallest, LOG_FLOOR)) / 4, user.mean(axis=1)]
    )  # fmt: skip
    return View(direct, steering, ratio, scale, aligned, coef, user, glob)


def net_inputs(v: View) -> np.ndarray:
    """The network's input (B, K, ``NET_IN``): each user's features, then the global ones."""
    b, k = v.user.shape[:2]
    return np.concatenate([v.user, np.broadcast_to(v.glob[:, None, :], (b, k, v.glob.shape[1]))], axis=-1)


def outputs(layers: list[tuple[np.ndarray, np.ndarray]], v: View) -> np.ndarray:
    """The network's outputs (B, K, 3): (z_k, y_k, a_k) per user (module docstring)."""
    x = net_inputs(v)
    return mlp(layers, x.reshape(-1, NET_IN)).reshape(*x.shape[:2], NET_OUT)


def _softmax(x: Any, xp: ModuleType) -> Any:
    e = xp.exp(x - x.mean(axis=-1, keepdims=True))
    return e / e.sum(axis=-1, keepdims=True)


def estimated_rows(v: View, phasor: Any) -> Any:
    """H-hat (B, K, N_t) for the surface's v_m = exp(-j psi_m) ``phasor`` (B, M): the rows the
    observation gives, scaled so that their direct gains sum to 1 (module docstring)."""
    m = phasor.shape[-1]
    s = (v.coef * phasor[:, None, :]).sum(axis=-1) * v.ratio / m  # (B, K)
    return v.scale[..., None] ** 0.5 * (s[..., None] * v.steering[:, None, :] + v.direct)


def setting(out: Any, v: View, xp: ModuleType = np) -> tuple[Any, Any]:
    """The surface's v_m = exp(-j psi_m) (B, M) and the beams W (B, N_t, K), total power 1, of the
    outputs ``out`` (B, K, 3) (module docstring). ``xp``: numpy, or torch for the trainer (every
    array of ``v`` and ``out`` then a tensor; the same operations, differentiable)."""
    out = xp.clip(out, -OUT_CLIP, OUT_CLIP)
    omega = _softmax(out[..., 2], xp)
    combo = (omega[..., None] * v.aligned).sum(axis=1)  # (B, M)
    phasor = combo.conj() / xp.clip(xp.abs(combo), LOG_FLOOR, None)
    rows = estimated_rows(v, phasor)
    hermitian = rows.conj().swapaxes(-1, -2)  # (B, N_t, K)
    q = xp.exp(LOG_Q0 + out[..., 0])
    gram = hermitian @ (q[..., None] * rows) + xp.eye(rows.shape[-1])
    directions = xp.linalg.solve(gram, hermitian)
    directions = directions / xp.sqrt((xp.abs(directions) ** 2).sum(axis=-2, keepdims=True))
    return phasor, directions * xp.sqrt(_softmax(out[..., 1], xp))[:, None, :]


def actions(phasor: np.ndarray, beams: np.ndarray) -> np.ndarray:
    """Direct actions (B, 2 N_t K + M) of (v (B, M), W (B, N_t, K)): the env's ``action_of``,
    batched (the beams scaled into the box, the phases psi = -arg v wrapped / pi)."""
    columns = beams.swapaxes(-1, -2).reshape(len(beams), -1)  # user k's beam, then user k + 1's
    parts = np.concatenate([columns.real, columns.imag], axis=-1)
    peak = np.max(np.abs(parts), axis=-1, keepdims=True)
    return np.concatenate([parts / np.where(peak > 0, peak, 1.0), wrap(-np.angle(phasor))], axis=-1)


def load_weights(path: str | Path) -> list[tuple[np.ndarray, np.ndarray]]:
    """The user network of ``path/weights.npz`` (arrays ``user_w<i>``, ``user_b<i>``), checked
    against the feature widths (``ValueError`` naming the file)."""
    return load_layers(path, (("user", NET_IN, NET_OUT),), "MisoLearner")["user"]


class MisoLearner:
    """The learned structured setting (module docstring); ``bind`` it to a scenario. ``path``: the
    model folder (default: the shipped one)."""

    def __init__(self, path: str | Path = DEFAULT_MODEL) -> None:
        self.path = Path(path)
        self.layers = load_weights(self.path)
        if not (self.path / "config.json").exists():
            raise ValueError(f"{self.path / 'config.json'}: no such file (how the model was trained)")
        self.config: dict[str, Any] = json.loads((self.path / "config.json").read_text(encoding="utf-8"))
        self.name = f"learned beams and phases ({self.path.name}, MisoLearner)"
        self.task: MisoTask | None = None
        self.where: Layout | None = None

    def bind(self, task: MisoTask) -> MisoLearner:
        """A copy that acts on ``task``'s scenario (``ValueError`` if its observation lacks a
        feature the policy reads)."""
        bound = copy.copy(self)
        bound.task, bound.where = task, layout(task)
        return bound

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Actions (B, 2 N_t K + M) of observations (B, width) at the bound scenario."""
        if self.task is None or self.where is None:
            raise ValueError("MisoLearner is unbound: bind it to the scenario (policy.bind(task))")
        v = view(np.atleast_2d(np.asarray(obs, dtype=np.float64)), self.task, self.where)
        return actions(*setting(outputs(self.layers, v), v))

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return self.act(np.asarray(obs)[None])[0]

    def __repr__(self) -> str:
        return f"MisoLearner({str(self.path)!r})"
