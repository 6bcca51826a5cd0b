"""The node-block view batched: ``MultiNodeVectorEnv``, a preset of ``UAVVectorEnv``.

``gym.make_vec("ios_uav_env/IOSUAV-MultiNode-v0", num_envs=B,
vectorization_mode="vector_entry_point")`` (and the ``-Random-v0`` and ``-Mobile-v0`` ids)
returns a ``UAVVectorEnv`` (``ios_uav_env.envs.core.vector``) of the view ``"node_blocks"``; this
class makes the same batched env for code that names it. The rows are
``node_rows.NodeBlockRows``: the kernel of ``multi_kernels`` that the single env runs on a batch of
one, on B rows, so row i reproduces the single env reset with seed ``seed + i`` (tested); the
last step of an episode reports ``best_schedule_rate`` (``best_schedule=False``: NaN there).
``info`` is a dict of arrays (the single env's ``info_keys``: ``MULTI_INFO_KEYS``, and the energy
objective's and the Rician channel's keys; ``position`` (B, 2), ``shares``, ``node_rates`` and
``expected_node_rates`` (B, K_max)) with Gymnasium's ``_key`` masks.
"""

from __future__ import annotations

from typing import Any

from ios_uav_env.envs.core.vector import UAVVectorEnv

__all__ = ["MultiNodeVectorEnv"]


class MultiNodeVectorEnv(UAVVectorEnv):
    """``num_envs`` episodes of :class:`~ios_uav_env.envs.multi.MultiNodeEnv`: ``UAVVectorEnv`` with
    the view ``"node_blocks"``.

    Arguments: the single env's (``config``, ``max_nodes``, ``share_sharpness``,
    ``random_nodes``, ``ranges``, ``EnvOptions`` and ``ScenarioConfig`` keywords) plus
    ``num_envs``, ``autoreset_mode``, ``num_threads`` and ``best_schedule`` (True:
    ``maxmin_rate`` at each episode end, as the single env; False: NaN there, no LP).
    Observations (B, 12 + 6 K_max) float32 (``observation_names``: a row's, the single env's),
    actions (B, 2 + K_max), rewards (B,) float64. No rendering. ``schedules``: each row's shares
    so far.
    """

    def __init__(self, num_envs: int = 1, config: Any = None, **kwargs: Any):
        super().__init__(num_envs, config, view="node_blocks", **kwargs)
