"""Settings of the whole test session, made before any test module is imported.

``OMP_WAIT_POLICY=PASSIVE`` (unless the environment sets it): the OpenMP threads of numba's
parallel kernels and of torch sleep when their loop ends instead of spinning. Two xdist workers
share two cores, and a batch-of-one episode (the benchmark's, a trainer's) launches one parallel
kernel per slot: threads that spin between those launches hold the cores the other worker needs.
GNU OpenMP reads the variable once, when a library loads it, so it is set here, before the test
modules import numba's kernels or torch (``ios_uav_env.jit.prefer_passive_threads`` sets the same
in the trainers, at their import). Subprocesses that the tests start with ``os.environ`` inherit
it. What a test checks does not depend on it: the threads compute the same, only their waiting
changes (tests/agents/test_fast.py checks the trainers' own setting in a clean environment).

``SB3_LOGDIR`` (unless the environment sets it): a folder of this process's own, removed when it
exits. Stable-Baselines3 makes a logger's folder on every ``learn`` that is given none (``SB3-<date
and time>`` in the system's temporary folder, even when it writes nothing there): over a session,
the agents' tests and the examples they run in subprocesses (which inherit the variable) would
leave well over a thousand empty folders behind (tests/test_session.py).
"""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
if "SB3_LOGDIR" not in os.environ:
    os.environ["SB3_LOGDIR"] = tempfile.mkdtemp(prefix="ios-uav-env-tests-sb3-")
    atexit.register(shutil.rmtree, os.environ["SB3_LOGDIR"], ignore_errors=True)
