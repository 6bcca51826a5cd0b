"""Optional heavy parts stay optional: the model and env import without them."""

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


def test_multinode_env_runs_without_scipy_with_a_nan_best_schedule():
    proc = run_blocked(
        ["torch", "cvxpy", "matplotlib", "stable_baselines3", "scipy"],
        """
        import math, warnings
        import gymnasium as gym
        import ios_uav_env
        env = gym.make("ios_uav_env/IOSUAV-MultiNode-v0", T=40.0)
        env.reset(seed=0)
        done = False
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            while not done:
                _, _, done, _, info = env.step(env.action_space.sample())
        assert any("scipy is not installed" in str(w.message) for w in caught)
        assert math.isnan(info["best_schedule_rate"]) and info["min_rate"] > 0
        print("ok")
        """,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "ok"
