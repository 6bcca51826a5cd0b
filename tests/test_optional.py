"""Optional heavy parts stay optional: the model and env import without them."""

import json
import math
import subprocess
import sys
import textwrap


def run_blocked(blocked: list[str], code: str) -> subprocess.CompletedProcess:
    prelude = "import sys\n" + "".join(f"sys.modules[{name!r}] = None\n" for name in blocked)
    return subprocess.run(
        [sys.executable, "-c", prelude + textwrap.dedent(code)], capture_output=True, text=True, timeout=120
    )


def test_env_runs_without_torch_cvxpy_matplotlib():
    proc = run_blocked(
        ["torch", "cvxpy", "matplotlib", "stable_baselines3", "scipy"],
        """
        import gymnasium as gym
        import ios_uav_env
        env = gym.make("ios_uav_env/IOSUAV-v0")
        env.reset(seed=0)
        env.step(env.action_space.sample())
        print("ok")
        """,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "ok"


def test_model_imports_without_gymnasium():
    proc = run_blocked(
        ["gymnasium", "torch", "cvxpy", "matplotlib"],
        """
        import ios_uav_env
        assert not hasattr(ios_uav_env, "IOSUAVEnv")
        trajectory = [[-400.0, 20.0]] * 20 + [[400.0, 20.0]] * 20
        print(ios_uav_env.average_rate(ios_uav_env.ScenarioConfig(T=40.0), trajectory))
        """,
    )
    assert proc.returncode == 0, proc.stderr
    assert float(proc.stdout) > 0


# One fixed episode per env (seeded actions), single and batched: its scenarios, flights and the
# best_schedule_rate of its last step. Run with and without scipy: the flights do not depend on it.
EPISODES = """
import numpy as np
import gymnasium as gym
from ios_uav_env import ScenarioConfig
from ios_uav_env.envs.multi_vector import MultiNodeVectorEnv

NODES = [(-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0), (60.0, 120.0), (-160.0, 40.0),
         (20.0, -110.0), (110.0, 30.0), (-80.0, -90.0), (170.0, 80.0)]


def episodes(counts, batch_counts):
    out = []
    for i, k in enumerate(counts):
        config = ScenarioConfig(ground_nodes=NODES[:k], T=40.0)
        env = gym.make("ios_uav_env/IOSUAV-MultiNode-v0", config=config)
        env.reset(seed=i)
        env.action_space.seed(i)
        done = False
        while not done:
            _, _, done, _, info = env.step(env.action_space.sample())
        out.append((env.unwrapped.config, env.unwrapped.trajectory, float(info["best_schedule_rate"])))
    configs = [ScenarioConfig(ground_nodes=NODES[:k], T=40.0) for k in batch_counts]
    vec = MultiNodeVectorEnv(len(configs), ScenarioConfig(ground_nodes=NODES[: max(batch_counts)], T=40.0))
    vec.reset(seed=0, options={"configs": configs})
    vec.action_space.seed(0)
    done = np.zeros(len(configs), dtype=bool)
    while not done.all():
        _, _, done, _, info = vec.step(vec.action_space.sample())
    assert done.all() and info["_best_schedule_rate"].all()
    for config, path, best in zip(vec.configs, vec.trajectories, info["best_schedule_rate"]):
        out.append((config, path, float(best)))
    return out
"""


def flown_without_scipy(counts: list[int], batch_counts: list[int]) -> tuple[list[dict], list[str]]:
    """The episodes of ``EPISODES`` flown without scipy: each one's trajectory and best value, and
    the warnings raised."""
    proc = run_blocked(
        ["torch", "cvxpy", "matplotlib", "stable_baselines3", "scipy"],
        EPISODES
        + f"""
import json, warnings
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    flown = episodes({counts!r}, {batch_counts!r})
print(json.dumps({{
    "episodes": [{{"trajectory": q.tolist(), "best": repr(best)}} for _, q, best in flown],
    "warnings": [str(w.message) for w in caught],
}}))
""",
    )
    assert proc.returncode == 0, proc.stderr
    got = json.loads(proc.stdout)
    return got["episodes"], got["warnings"]


def test_multinode_certified_best_schedule_needs_no_scipy():
    """Static rows of K <= 8 nodes get their value from the compiled certified schedule: without
    scipy the same finite value as with it, single and batched, and no warning."""
    import numpy as np

    import ios_uav_env

    namespace: dict = {}
    exec(EPISODES, namespace)
    counts, batch_counts = [1, 2, 3, 8], [2, 3, 5, 8]
    without, caught = flown_without_scipy(counts, batch_counts)
    with_scipy = namespace["episodes"](counts, batch_counts)
    assert len(without) == len(with_scipy) == len(counts) + len(batch_counts)
    for got, (config, q, best) in zip(without, with_scipy, strict=True):
        np.testing.assert_array_equal(np.array(got["trajectory"]), q)
        value = float(got["best"])
        assert math.isfinite(value) and value > 0
        assert abs(value - best) <= 1e-12 * abs(best), (value, best)
        exact = ios_uav_env.maxmin_rate(config, q)
        assert abs(value - exact) <= 1e-12 * abs(exact), (value, exact)
    assert not any("scipy is not installed" in message for message in caught)


def test_multinode_best_schedule_without_scipy_is_nan_where_it_needs_highs():
    """A row that falls back to HiGHS (here K = 9 > maxmin.MAX_NODES) gets NaN and the warning
    without scipy, single and batched; the batch's certified rows keep their values."""
    without, caught = flown_without_scipy([9], [3, 9, 2])
    assert any("scipy is not installed" in message for message in caught)
    single, certified, fallback, other = (float(got["best"]) for got in without)
    assert math.isnan(single) and math.isnan(fallback)
    assert math.isfinite(certified) and certified > 0 and math.isfinite(other) and other > 0
