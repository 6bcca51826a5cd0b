"""The MPC-DP clone (``agents.mpc_clone``): its labels fly the expert's trajectory through the env
(the same reports, the same score), the fit learns them, and the folder loads as a memory agent
and as a start of the fast trainer (``--init-from``) on its recipe."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from agents import mpc_clone  # noqa: E402
from ios_uav_env import MOBILE_ID  # noqa: E402

RECIPE = "agents/hyperparams/fast_ppo_memory_mpcclone.yml"


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("clone")
    mpc_clone.run(out, 2, epochs=2)
    return out


def test_the_labels_fly_the_mpc_trajectory_and_score():
    """The env reset with the episode seed draws run_online's path and reports; its actions
    rebuild the MPC's flight to float32 rounding and its rate on the true path."""
    e = mpc_clone.expert_episode(mpc_clone.FIRST_SEED)
    d = gym.make(MOBILE_ID, **mpc_clone.ENV_KWARGS).observation_space.shape[0]
    assert e["obs"].shape == (len(e["labels"]), mpc_clone.FRAMES * d)
    assert np.all(np.hypot(*e["labels"].T) <= 1 + 1e-6)
    assert e["max_gap"] < 1e-3
    assert e["replay_rate"] == pytest.approx(e["mpc_rate"], rel=1e-6)


def test_the_fit_learns_the_labels(folder):
    """A longer fit on the same two episodes has a far smaller loss than the first pass."""
    data = np.load(folder / "data.npz")
    losses = []
    for epochs in (1, 40):
        model, venv = mpc_clone.new_model(data["obs"])
        losses.append(mpc_clone.fit_actor(model, venv, data["obs"], data["labels"], epochs))
    assert losses[1] < 0.5 * losses[0]


def test_the_folder_loads_with_memory_and_as_a_start_of_the_fast_trainer(folder):
    from agents.fast.init_from import check_init_from
    from agents.loading import load_agent

    agent = load_agent(folder)
    assert agent.env_id == MOBILE_ID and agent.env_kwargs == {"filter_estimate": True} and agent.memory == 4
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["episodes"] == 2 and summary["replay_rel_gap_max"] < 1e-6
    check_init_from(folder, MOBILE_ID, dict(mpc_clone.ENV_KWARGS), RECIPE)
    with pytest.raises(ValueError, match="one warm start"):  # the memory recipe clones the tracker
        check_init_from(
            folder, MOBILE_ID, dict(mpc_clone.ENV_KWARGS), "agents/hyperparams/fast_ppo_memory.yml"
        )
