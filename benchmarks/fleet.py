"""Several UAVs: the centralised plan's max-min rate against its certified bound, per fleet size.

    python benchmarks/fleet.py [--uavs 1 2 3] [--resolution 5]

On the multi-node env's scenario (the paper's defaults, its three nodes, M = 6000), the UAVs on
the default lanes (``ios_uav_env.model.fleet.default_lanes``), 10 m apart at least: per U, the best
separated fleet ``baselines.fleet.solve`` finds (bps/Hz, scored by ``fleet_maxmin``), the
certified bound, the gap, which candidate won and the seconds it took.
"""

from __future__ import annotations

import sys
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from baselines.fleet import main  # noqa: E402

if __name__ == "__main__":
    main()
