"""The NOMA STAR flight's episodes as rows of arrays: what the single env (one row) and its batched
form (B rows) both run, so a row of the batch is the single env's episode bit for bit.

:class:`StarNomaRows` holds B episodes of the view ``"star_noma"`` (the stepper
``ios_uav_env.envs.star_noma.StarNomaStepper`` holds one row; ``UAVVectorEnv`` holds B): the
UAV's position and path, the weights, the users' cumulative rates S_k (two users here; K = 2 to 4
for the SDMA rows, ``miso_sdma.MisoSdmaRows``, which replace the slot), and each slot's rates,
which are those of the surface setting and power split the env sets: the weighted-sum slot
optimum of the agent's weight at the slot's position, read off the ES frontier
(``ios_uav_env.model.star_maps``: ``frontier_maps``, ``FrontierMaps.weighted_sum``). Each row's
frontier is computed on its own (one position per call), so a row's numbers never depend on the
other rows. At an episode's end the flight is scored by ``ios_uav_env.score_plan`` (the
scorer of the planners, ``star_regions.scenario_maxmin``) unless ``score=False`` (NaN there);
before the end the score is 0 (as the multi-node ids' ``best_schedule_rate``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ios_uav_env.model.guard import guarded_position
from ios_uav_env.model.score import score_plan
from ios_uav_env.model.star_maps import frontier_maps

__all__ = ["INFO_KEYS", "OBSERVATION_NAMES", "StarNomaRows", "info_keys"]

#: The observation's features (``StarNomaStepper``'s docstring), per user k = 0, 1 the last four.
OBSERVATION_NAMES = (
    "noma_x", "noma_y", "noma_dx_final", "noma_dy_final", "noma_dx_surface", "noma_dy_surface",
    "noma_time_left", "noma_slack",
    *(f"noma_{f}_{k}" for k in (0, 1) for f in ("dx_user", "dy_user", "rate_alone", "rate")),
)  # fmt: skip


def info_keys(users: int = 2) -> tuple[str, ...]:
    """The keys of ``info`` of a flight of ``users`` users, in the info table's column order: for two
    users user 0's weight ``weight`` (``StarNomaStepper``'s docstring), for more each user's weight
    ``weight_k`` (``miso_sdma.MisoSdmaStepper``'s)."""
    k = range(users)
    weights = ("weight",) if users == 2 else tuple(f"weight_{j}" for j in k)
    return (
        "slot", "position_x", "position_y", "distance_to_final", *weights, *(f"slot_rate_{j}" for j in k),
        "slot_value", "slot_upper", *(f"rate_{j}" for j in k), "min_rate", "score",
    )  # fmt: skip


#: The keys of ``info`` of the two-user flights (``StarNomaStepper``'s docstring).
INFO_KEYS = info_keys(2)


class StarNomaRows:
    """B episodes of the NOMA STAR flight (module docstring). ``points``: the frontier angles of
    ``frontier_maps``; ``score``: whether an episode's end scores the flight (else NaN);
    ``length_scale`` (m): lengths in the observation are divided by it; ``users``: K, the users
    of every episode (two here; a subclass's slot may serve more: ``miso_sdma.MisoSdmaRows``).

    The action of a row is (a_x, a_y) then, for two users, a_w (user 0's weight w = (a_w + 1) / 2,
    user 1's 1 - w), for K > 2 one a_k per user (:meth:`action_weights`)."""

    def __init__(self, num_envs: int, points: int, score: bool, length_scale: float, users: int = 2) -> None:
        b = self.num_envs = int(num_envs)
        self.points, self.score, self.length_scale = int(points), bool(score), float(length_scale)
        k = self.k = int(users)
        self.info_keys = info_keys(k)
        self.info_width = len(self.info_keys)
        self._col = {key: j for j, key in enumerate(self.info_keys)}
        #: The action's length: the move, then one weight for two users, else one per user.
        self.action_size = 3 if k == 2 else 2 + k
        self.state = np.zeros((b, 3))  # the UAV's x, y and the moves made
        self.path = np.zeros((b, 1, 2))  # each row's way-points (grows with the longest episode)
        self.weights = np.zeros((b, 1, k))  # each row's users' weights per slot
        self.served = np.zeros((b, k))  # S_k: the users' rates summed over the slots so far
        self.alone = np.zeros((b, k))  # c_k at the current position: user k with everything
        self.configs: list[Any] = [None] * b
        self.users = np.zeros((b, k, 2))
        self.episode = np.zeros((b, 8))  # q0 x, y; qF x, y; surface centre x, y; D; N

    # --- episodes -----------------------------------------------------------------------
    def load(self, i: int, env: Any) -> None:
        """Put the episode just begun by row ``i``'s env (its ``config``, checked by its stepper) in
        row ``i``."""
        config = env.config
        n = config.N
        if n > self.path.shape[1]:
            grow = n - self.path.shape[1]
            self.path = np.pad(self.path, ((0, 0), (0, grow), (0, 0)))
            self.weights = np.pad(self.weights, ((0, 0), (0, grow), (0, 0)))
        self.configs[i] = config
        self.users[i] = np.asarray(config.nodes, dtype=np.float64)
        self.episode[i] = (*config.q0, *config.qF, *config.ios_center[:2], config.D, n)

    def start(self, rows: np.ndarray, obs: np.ndarray, info: np.ndarray) -> None:
        """Start the episodes of ``rows`` (loaded): slot 1 at q0 served at the users' equal weights
        (1 / K each; a subclass's slot may round them, as the SDMA rows round to the lattice point
        nearest them); their first observations and ``info`` rows."""
        for i in rows.tolist():
            ep = self.episode[i]
            self.state[i] = (ep[0], ep[1], 0.0)
            self.path[i] = 0.0
            self.path[i, 0] = ep[0:2]
            self.served[i] = 0.0
            self._serve(i, np.full(self.k, 1.0 / self.k), info[i])
            self._observe(i, obs[i])

    def _serve(self, i: int, w: np.ndarray, row: np.ndarray) -> None:
        """Serve row ``i``'s current slot at the users' weights ``w`` (K,): the slot's setting
        (:meth:`slot`), its rates added to S_k; the slot's entries of the info row ``row``."""
        x, y, n = self.state[i]
        w, value, upper, rates = self.slot(i, x, y, w)
        self.served[i] += rates
        self.weights[i, int(n)] = w
        ep = self.episode[i]
        dist = math.hypot(ep[2] - x, ep[3] - y)
        average = self.served[i] / ep[7]
        shown = w[:1] if self.k == 2 else w  # (two users: user 0's weight)
        row[:] = (n + 1.0, x, y, dist, *shown, *rates, value, upper, *average, average.min(), 0.0)

    def slot(self, i: int, x: float, y: float, w: np.ndarray) -> tuple[np.ndarray, float, float, np.ndarray]:
        """Row ``i``'s slot at (``x``, ``y``) m served at the users' weights ``w`` (K,): (the
        weights the setting is made for, w . R of the setting, a certified bound on the slot's best
        w . R, the rates R (K,)); writes each user's rate alone into ``alone[i]``. Here: the
        weighted-sum optimum of the slot's ES frontier."""
        maps = frontier_maps(self.configs[i], np.array([[x, y]]), self.users[i], self.points)
        value, upper, rates = maps.weighted_sum(w)
        self.alone[i] = np.log2(1.0 + maps.full_snr[:, 0])
        return w, float(value[0]), float(upper[0]), rates[:, 0]

    def action_weights(self, a: np.ndarray) -> np.ndarray:
        """The users' weights (K,) of one row's action ``a``: for two users (w, 1 - w) with
        w = (clip(a_w, -1, 1) + 1) / 2; for K > 2 the normalised shifted scores
        p_k = (clip(a_k, -1, 1) + 1) / 2, w = p / sum_j p_j (1 / K each when every p_k is 0):
        every point of the simplex is some action's (a vertex e_k: a_k > -1, the others -1)."""
        if self.k == 2:
            w = (min(1.0, max(-1.0, float(a[2]))) + 1.0) / 2.0
            return np.array([w, 1.0 - w])
        p = (np.clip(a[2:], -1.0, 1.0) + 1.0) / 2.0
        total = float(p.sum())
        return p / total if total > 0.0 else np.full(self.k, 1.0 / self.k)

    def _observe(self, i: int, out: np.ndarray) -> None:
        """Row ``i``'s observation at its current slot into ``out`` (float32)."""
        x, y, n = self.state[i]
        ep, inv = self.episode[i], 1.0 / self.length_scale
        left = ep[7] - 1.0 - n
        slack = left - math.hypot(ep[2] - x, ep[3] - y) / ep[6]
        head = [x * inv, y * inv, (ep[2] - x) * inv, (ep[3] - y) * inv, (ep[4] - x) * inv, (ep[5] - y) * inv,
                left / (ep[7] - 1.0), slack / (1.0 + abs(slack))]  # fmt: skip
        for k in range(self.k):
            u = self.users[i, k]
            head += [(u[0] - x) * inv, (u[1] - y) * inv, self.alone[i, k], self.served[i, k] / ep[7]]
        out[:] = head

    def step(self, actions: np.ndarray, active: np.ndarray, outputs: tuple) -> None:
        """One slot of the ``active`` rows into ``outputs`` (observations, rewards, terminated,
        info table): the move (unit-disk projection, x D, the arrival guard), the weight, the slot
        served, the reward min_k S_k - (its value before the slot); at slot N the score."""
        obs, reward, terminated, info = outputs
        for i in np.flatnonzero(active).tolist():
            ep, st = self.episode[i], self.state[i]
            ax, ay = float(actions[i, 0]), float(actions[i, 1])
            norm = math.hypot(ax, ay)
            if norm > 1.0:
                ax, ay = ax / norm, ay / norm
            w = self.action_weights(actions[i])
            x0, y0, n = st
            left = int(ep[7] - 2.0 - n)  # moves left after this one
            d = ep[6]
            x, y = guarded_position((x0, y0), (x0 + d * ax, y0 + d * ay), (ep[2], ep[3]), d, left)
            st[:] = (x, y, n + 1.0)
            self.path[i, int(n) + 1] = (x, y)
            before = self.served[i].min()
            self._serve(i, w, info[i])
            reward[i] = self.served[i].min() - before
            terminated[i] = left == 0
            if left == 0:
                info[i, self._col["score"]] = self.flight_score(i) if self.score else math.nan
            self._observe(i, obs[i])

    def flight_score(self, i: int) -> float:
        """``score_plan``'s rate (bps/Hz) of row ``i``'s flight so far (a whole flight: q0 to qF)."""
        n = int(self.state[i, 2]) + 1
        return float(score_plan(self.configs[i], self.path[i, :n].copy()).rate)

    def trajectory(self, i: int) -> np.ndarray:
        """Row ``i``'s way-points so far, (n + 1, 2) m."""
        return self.path[i, : int(self.state[i, 2]) + 1].copy()

    # --- the batched env's calls ----------------------------------------------------------
    def end(self, rows: np.ndarray, seeds: Any) -> None:
        """Before ``rows`` begin new episodes: nothing (no draw is made ahead of a slot)."""

    def restart(self, rows: np.ndarray, obs: np.ndarray, info: np.ndarray) -> np.ndarray:
        """The rows of an autoreset or ``restart`` left to reset through their envs: all."""
        return rows

    def fly(
        self, rows: np.ndarray, targets: np.ndarray, moves: np.ndarray, obs: np.ndarray, info: np.ndarray
    ) -> bool:
        """No compiled flight: ``BatchedEnv.fly`` steps the rows slot by slot."""
        return False

    def check_actions(self, actions: Any) -> np.ndarray:
        """``actions`` (B, :attr:`action_size`) as float64, checked (``ValueError`` naming the shape
        or the rows)."""
        a = np.asarray(actions, dtype=np.float64)
        shape = (self.num_envs, self.action_size)
        if a.shape != shape:
            what = "the weight" if self.k == 2 else f"{self.k} user weights"
            raise ValueError(f"actions must have shape {shape} (the move, then {what}), got {a.shape}")
        bad = ~np.isfinite(a).all(axis=1)
        if bad.any():
            raise ValueError(
                f"actions must be finite (no NaN or inf); rows {np.flatnonzero(bad).tolist()[:10]} are not"
            )
        return a

    def info_arrays(self, table: np.ndarray) -> dict[str, Any]:
        """``info`` as column views of the info table (``slot`` as int64)."""
        out: dict[str, Any] = {key: table[:, j] for key, j in self._col.items()}
        out["slot"] = out["slot"].astype(np.int64)
        return out
