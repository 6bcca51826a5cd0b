"""examples/tianshou_collect.py: Tianshou's Collector fills a buffer (NaN check on) with the info keys."""

import re

from conftest import require

IDS = ["ios_uav_env/IOSUAV-v0", "ios_uav_env/IOSUAV-Random-v0"]


def test_tianshou_collect_fixed_and_random_ids(run_example):
    require("tianshou", "torch")
    # Tianshou compiles its buffer and return functions with numba on every run (not cached,
    # slow); the example is about Tianshou's API, so numba is off here (the env's kernels run as
    # plain Python, tested equal to the compiled ones in tests/envs/test_single_vector.py)
    no_jit = {"NUMBA_DISABLE_JIT": "1"}
    out = run_example("tianshou_collect.py", "--env", *IDS, "--episodes", "2", env_vars=no_jit)
    for env_id in IDS:
        match = re.search(rf"{env_id}: 2 episodes, (\d+) transitions.*final slots \[(.*)\]", out)
        assert match, out
        slots = [int(s) for s in match.group(2).split(",")]
        assert len(slots) == 2 and sum(s - 1 for s in slots) == int(match.group(1))
