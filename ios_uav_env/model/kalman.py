r"""A Kalman filter of the node positions from position reports, on the Gauss-Markov model.

Per node and per axis the Gauss-Markov motion (``ios_uav_env.model.motion``) is linear in the
state s = (w, v, m): position, velocity and mean velocity (the mean heading of a node is
unknown when drawn per node, so its mean velocity is estimated with the rest):

    s[n+1] = F s[n] + (0, g u[n], 0),   F = [[1, dt, 0], [0, a, 1 - a], [0, 0, 1]],
    g = sqrt(1 - a^2) sigma,            Q = diag(0, g^2, 0),

and a report z[n] = w[n] + e[n], e[n] ~ N(0, s_r^2), observes H s with H = (1, 0, 0). The
axes and the nodes are independent, so the filter runs on (K, 2, 3) means with one (3, 3)
covariance shared by all of them (the model and the report noise are the same for every
node and axis).

**Start** (:meth:`NodeFilter.start`, the first reports z[0]): with no prior on the position,
the posterior after z[0] is w ~ N(z[0], s_r^2), independent of the velocity; the velocity and
the mean velocity take their prior second moments: m has mean s (cos theta, sin theta) and
variance 0 for a given heading theta, mean 0 and variance s^2 / 2 per axis for a heading
uniform on the circle; v = m + sigma x (standard normal), so Var v = Var m + sigma^2 and
Cov(v, m) = Var m. These are the exact first two moments of the motion's initial law, so the
filter is the best *linear* estimator from the reports and its covariance is the exact mean
squared error for any prior with those moments (the heading makes m non-Gaussian).

**Predict** s <- F s, P <- F P F^T + Q; **update** with the reports: K = P H^T / (H P H^T +
s_r^2), s <- s + K (z - H s), P <- (I - K H) P (I - K H)^T + K s_r^2 K^T (Joseph's form).

**Walls.** The motion reflects a node at its rectangle's edges (position mirrored, v and m
negated on that axis); no linear filter follows that exactly. The filter mirrors its own
estimate the same way when a predicted mean crosses an edge (the covariance, invariant under
negating the whole axis block, is unchanged). Its covariance is the exact mean squared error
only while no reflection happens; near the walls it is an approximation.

The static model (``motion=None``) is the case a = 0, sigma = 0, s = 0: the position is
constant and the filter averages the reports (P_ww = s_r^2 / n after n reports).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.motion import node_bounds, reflect
from ios_uav_env.model.reports import REPORT_SIGMA, _sigma

__all__ = ["NodeFilter", "transition"]


def transition(config: ScenarioConfig) -> tuple[np.ndarray, np.ndarray]:
    """(F, Q), each (3, 3): one slot of the per-axis state (w, v, m) (module docstring)."""
    motion, dt = config.motion, config.dt
    a, sigma = (0.0, 0.0) if motion is None else (motion.memory, motion.sigma)
    f = np.array([[1.0, dt, 0.0], [0.0, a, 1.0 - a], [0.0, 0.0, 1.0]])
    q = np.zeros((3, 3))
    q[1, 1] = (1.0 - a * a) * sigma * sigma
    return f, q


@dataclass
class NodeFilter:
    """The filter's state after the reports so far (module docstring); :meth:`start` makes one."""

    config: ScenarioConfig
    report_sigma: float  # m, s_r: std of each component of a report's error
    mean: np.ndarray  # (K, 2, 3): per node and axis, the estimate of (w, v, m)
    cov: np.ndarray  # (3, 3): the covariance of every node's and axis's estimation error
    slot: int  # index of the last slot the state describes (0: after the first reports)
    bounds: tuple[np.ndarray, np.ndarray] | None  # (lo, hi) (K, 2) m: the walls (None: static)

    @classmethod
    def start(
        cls, config: ScenarioConfig, reports: np.ndarray, report_sigma: float = REPORT_SIGMA
    ) -> NodeFilter:
        """The filter after the first slot's reports (K, 2) m (module docstring, "Start")."""
        s = _sigma(report_sigma)
        if s == 0:
            raise ValueError("report_sigma must be > 0 (m): exact positions need no filter")
        z = _reports(config, reports)
        motion = config.motion
        speed, sigma = (0.0, 0.0) if motion is None else (motion.speed, motion.sigma)
        if motion is None or motion.heading is not None:
            theta = 0.0 if motion is None else motion.heading
            m_mean, m_var = speed * np.array([math.cos(theta), math.sin(theta)]), 0.0
        else:
            m_mean, m_var = np.zeros(2), 0.5 * speed * speed
        mean = np.zeros((config.K, 2, 3))
        mean[:, :, 0] = z
        mean[:, :, 1] = m_mean
        mean[:, :, 2] = m_mean
        cov = np.zeros((3, 3))
        cov[0, 0] = s * s
        cov[1, 1] = m_var + sigma * sigma
        cov[1, 2] = cov[2, 1] = m_var
        cov[2, 2] = m_var
        bounds = None if motion is None else node_bounds(config)
        return cls(config, s, mean, cov, 0, bounds)

    @property
    def position(self) -> np.ndarray:
        """(K, 2) m: the position estimates."""
        return self.mean[:, :, 0].copy()

    @property
    def position_var(self) -> float:
        """m^2: the error variance of each position component (P_ww)."""
        return float(self.cov[0, 0])

    @property
    def position_mse(self) -> float:
        """m^2: the expected squared position error of a node, trace of its 2 x 2 block (2 P_ww)."""
        return 2.0 * self.position_var

    def predict(self) -> None:
        """Advance one slot without reports (module docstring, "Predict" and "Walls")."""
        f, q = transition(self.config)
        self.mean = self._reflected(self.mean @ f.T)
        self.cov = f @ self.cov @ f.T + q
        self.slot += 1

    def update(self, reports: np.ndarray) -> None:
        """Fold in the current slot's reports (K, 2) m (module docstring, "update")."""
        z = _reports(self.config, reports)
        p, r = self.cov, self.report_sigma**2
        gain = p[:, 0] / (p[0, 0] + r)  # (3,)
        self.mean = self.mean + gain * (z - self.mean[:, :, 0])[:, :, None]
        i_kh = np.eye(3) - np.outer(gain, [1.0, 0.0, 0.0])
        self.cov = i_kh @ p @ i_kh.T + r * np.outer(gain, gain)

    def step(self, reports: np.ndarray) -> None:
        """:meth:`predict` then :meth:`update` with the next slot's reports."""
        self.predict()
        self.update(reports)

    def predict_paths(self, steps: int) -> np.ndarray:
        """(steps, K, 2) m: the predicted positions of the next ``steps`` slots (1 to ``steps``
        ahead, mirrored at the walls); the filter's state is unchanged."""
        if isinstance(steps, bool) or not (isinstance(steps, (int, np.integer)) and steps >= 0):
            raise ValueError(f"steps must be an integer >= 0, got {steps!r}")
        f, _ = transition(self.config)
        out = np.empty((int(steps), self.config.K, 2))
        mean = self.mean
        for i in range(int(steps)):
            mean = self._reflected(mean @ f.T)
            out[i] = mean[:, :, 0]
        return out

    def _reflected(self, mean: np.ndarray) -> np.ndarray:
        if self.bounds is None:
            return mean
        lo, hi = self.bounds
        folded, flip = reflect(mean[:, :, 0], lo, hi)
        out = np.where(flip[:, :, None], -mean, mean)
        out[:, :, 0] = folded
        return out


def _reports(config: ScenarioConfig, reports: np.ndarray) -> np.ndarray:
    z = np.asarray(reports, dtype=float)
    if z.shape != (config.K, 2) or not np.all(np.isfinite(z)):
        raise ValueError(f"reports must be a finite (K, 2) = ({config.K}, 2) array (m), got shape {z.shape}")
    return z
