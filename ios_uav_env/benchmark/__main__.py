"""``python -m ios_uav_env.benchmark``: see :mod:`ios_uav_env.benchmark.cli`."""

from ios_uav_env.benchmark.cli import main

raise SystemExit(main())
