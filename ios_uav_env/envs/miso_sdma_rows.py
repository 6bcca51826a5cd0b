"""The SDMA flight's episodes as rows of arrays: the NOMA STAR flight's rows
(``star_noma_rows.StarNomaRows``: the moves, the arrival guard, the users' cumulative rates, the
reward and the score) with the multi-antenna UAV's slot.

:class:`MisoSdmaRows` holds B episodes of the view ``"miso_sdma"`` (the stepper
``ios_uav_env.envs.miso_sdma.MisoSdmaStepper`` holds one row; ``UAVVectorEnv`` holds B). A slot
is served at the lattice weight nearest the agent's (``model.miso_sdma.lattice_index``) with that
weight's setting (``model.miso_sdma.slot_setting``: the weighted-sum AO of the beams and the
surface's phases, or a user alone), on the slot channel built for the row's one position
(``slot_channel_at``), so a row's numbers never depend on the other rows and each slot's rates
are one of the settings ``score_plan`` credits that slot (``model.miso_sdma.slot_points``).
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.envs.star_noma_rows import INFO_KEYS, StarNomaRows
from ios_uav_env.model.miso import slot_bounds, tdma_rates, weighted_sum_bound
from ios_uav_env.model.miso_sdma import lattice_index, slot_channel_at, slot_setting, weight_lattice

__all__ = ["INFO_KEYS", "OBSERVATION_NAMES", "MisoSdmaRows"]

#: The observation's features (``MisoSdmaStepper``'s docstring), per user k = 0, 1 the last four.
OBSERVATION_NAMES = (
    "sdma_x", "sdma_y", "sdma_dx_final", "sdma_dy_final", "sdma_dx_surface", "sdma_dy_surface",
    "sdma_time_left", "sdma_slack",
    *(f"sdma_{f}_{k}" for k in (0, 1) for f in ("dx_user", "dy_user", "rate_alone", "rate")),
)  # fmt: skip
LATTICE = weight_lattice(2)


class MisoSdmaRows(StarNomaRows):
    """B episodes of the SDMA flight (module docstring). ``points`` is not used (the lattice
    is fixed: ``model.miso_sdma.LATTICE_LEVELS``); ``score`` and ``length_scale`` as the NOMA rows'."""

    def slot(self, i: int, x: float, y: float, w: float) -> tuple[float, float, float, np.ndarray]:
        """Row ``i``'s slot at (``x``, ``y``) m at the lattice weight nearest (``w``, 1 - ``w``):
        (that weight of user 0, w . R of its setting, the certified ``miso.weighted_sum_bound`` of
        the slot at it, the rates R (2,)); ``alone[i]``: each user alone (``miso.tdma_rates``)."""
        channel = slot_channel_at(self.configs[i], np.array([x, y]))
        weights = LATTICE[lattice_index(np.array([w, 1.0 - w]), LATTICE)]
        self.alone[i] = tdma_rates(channel)
        rates = slot_setting(channel, weights, self.alone[i])
        value = float(weights @ rates)
        # a user alone attains the bound (rank one): the two then differ by rounding at the most
        upper = max(weighted_sum_bound(slot_bounds(channel).gains, weights), value)
        return float(weights[0]), value, upper, rates
