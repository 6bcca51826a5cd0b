"""The system model: pure functions of a :class:`~ios_uav_env.model.config.ScenarioConfig` and
a trajectory, on numpy arrays, knowing nothing of Gymnasium.

- ``config``: the frozen, validated scenario (units and the paper's symbols);
- ``surface``: the IOS element layout; ``channel``: the cascaded channel and the slot rate;
- ``star``, ``star_slot``, ``star_frontier``: STAR surfaces (the IOS generalised) and their
  certified per-slot optima for two users;
- ``trajectory``: the one scorer of a flight (average rate, feasibility);
- ``schedule``: K >= 1 ground nodes, the TDMA shares and the max-min rate;
- ``peak``: the rate peak; ``scenarios``: the scenario families (random scenarios, one node or
  several) and their draws;
- ``guard``: the arrival guard; ``flights``: pure flight rules (the loiter flight);
- ``array``, ``miso``, ``miso_slot``: the multi-antenna UAV (a ULA serving K users at once), its
  slot channel, bounds and baselines, and the per-slot optimum over the beams and the phases;
  ``miso_sweep``: the UAV hovering, every scheme's rate and the bound against the transmit power.

Users import these names from ``ios_uav_env`` itself.
"""
