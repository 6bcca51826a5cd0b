"""examples/tianshou_collect.py: Tianshou's Collector fills a buffer (NaN check on) with the info keys."""

import re

from conftest import require

IDS = ["ios_uav_env/IOSUAV-v0", "ios_uav_env/IOSUAV-Random-v0"]


def test_tianshou_collect_fixed_and_random_ids(run_example):
    require("tianshou", "torch")
    out = run_example("tianshou_collect.py", "--env", *IDS, "--episodes", "2")
    for env_id in IDS:
        match = re.search(rf"{env_id}: 2 episodes, (\d+) transitions.*final slots \[(.*)\]", out)
        assert match, out
        slots = [int(s) for s in match.group(2).split(",")]
        assert len(slots) == 2 and sum(s - 1 for s in slots) == int(match.group(1))
