"""examples/rl_zoo3_train.py: rl_zoo3.train with the repo's YAML (--gym-packages), then enjoy --no-render."""

import pytest
from conftest import require


@pytest.mark.parametrize(("algo", "env_id"), [("ppo", "ios_uav_env/IOSUAV-v0")])
def test_rl_zoo3_train_and_enjoy(run_example, tmp_path, algo, env_id):
    require("rl_zoo3", "stable_baselines3", "torch")
    out = run_example(
        "rl_zoo3_train.py", "--algo", algo, "--env", env_id, "--steps", "128", "--enjoy-steps", "150",
        "--log-folder", str(tmp_path),
    )  # fmt: skip
    model = tmp_path / algo / f"{env_id.replace('/', '-')}_1" / f"{env_id.replace('/', '-')}.zip"
    assert model.is_file(), out
    assert "Mean episode length: 149.00" in out  # enjoy replayed one whole episode (N = 150)
