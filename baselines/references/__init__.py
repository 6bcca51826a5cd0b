"""The reference pipeline: solve the held-out scenarios with the planners and freeze the suites.

The wheel (``ios_uav_env.benchmark``) only loads and scores suites; everything that plans lives
here, in a checkout:

- :mod:`~baselines.references.draws`: the held-out scenarios of each suite;
- :mod:`~baselines.references.solve`: one solve for any K (one node: DP and SCA; K > 1: the tour,
  SCA and the certified bound; an energy scenario: DP-EE, SCA-EE, loiter, hover and the EE
  bound; a mobile one: :mod:`~baselines.references.mobile`), cached per scenario and resumable
  (:func:`solve_all`);
- :mod:`~baselines.references.mobile`: the mobile suite's draws (scenarios with episode seeds),
  its references (the clairvoyant bound and tour, MPC, plan once, tracking) and its content;
- :mod:`~baselines.references.online`: the suites normalised by the clairvoyant optimum
  (``mobile-v2``, ``multi-node-mobile-v1``): their draws, references (the clairvoyant DP and bound,
  MPC-DP, MPC, plan once, the env rows), checks and content;
- :mod:`~baselines.references.heldout`: the single-node suite's plan file
  (``agents/suite/heldout.json``: each scenario's DP and SCA plans), built by ``python -m
  agents.suite build``;
- :mod:`~baselines.references.content`: a suite's content from the solved records, its checks,
  its plans, and :func:`freeze`, which never changes a suite under its name;
- ``python -m baselines.references``: the command line.

The command line freezes one suite at a time:

    python -m baselines.references single-node [--heldout agents/suite/heldout.json]
    python -m baselines.references multi-node [--n 48] [--cache out/multi-node-v1] [--plans DIR]
    python -m baselines.references energy [--n 40] [--cache out/energy-v1] [--jobs 2] [--quick]
    python -m baselines.references mobile [--n 40] [--cache out/mobile-v1] [--jobs 2] [--quick]
    python -m baselines.references mobile --version 2 [--n 40] [--cache out/mobile-v2] [--jobs 2] [--quick]
    python -m baselines.references multi-node-mobile [--n 24] [--cache out/multi-node-mobile-v1] [--jobs 2]

The single-node suite is frozen from its plan file; the multi-node and energy ones from the
records :func:`solve_all` caches (``energy --quick``: a tiny check suite in ``out/energy-quick``).
Each prints the content hash to register in ``ios_uav_env.benchmark.suite_registry.SUITES``.
"""

from baselines.references.content import (
    check_energy_record,
    check_record,
    energy_content,
    freeze,
    heuristic_reference,
    multinode_content,
    single_node_content,
    write_plans,
)
from baselines.references.draws import energy_configs, heldout_rng, multinode_configs, suite_configs
from baselines.references.solve import (
    BOUND_RESOLUTION,
    DP_RESOLUTION,
    ENERGY_BOUND_RESOLUTION,
    solve_all,
    solve_scenario,
    task_key,
)

__all__ = [
    "BOUND_RESOLUTION",
    "DP_RESOLUTION",
    "ENERGY_BOUND_RESOLUTION",
    "check_energy_record",
    "check_record",
    "energy_configs",
    "energy_content",
    "freeze",
    "heldout_rng",
    "heuristic_reference",
    "multinode_configs",
    "multinode_content",
    "single_node_content",
    "solve_all",
    "solve_scenario",
    "suite_configs",
    "task_key",
    "write_plans",
]
