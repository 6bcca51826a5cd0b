"""The agents' side of the benchmark suites: ``python -m agents.suite``.

- :mod:`agents.suite.report`: a trained policy (or a heuristic) scored on a single-node suite
  through ``ios_uav_env.benchmark`` (default ``single-node-v1``), with its figures;
- :mod:`agents.suite.multi`: a multi-node model scored on ``multi-node-v1`` the same way;
- :mod:`agents.suite.curve`: every checkpoint of a run scored (the learning curve);
- ``build`` / ``show``: the single-node plan file of the reference pipeline
  (:mod:`baselines.references.heldout`).
"""
