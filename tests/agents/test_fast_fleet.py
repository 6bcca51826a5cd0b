"""IPPO with shared parameters on the fast trainer (agents.fast.fleet, agents.fast.fleet_run).

Tiny budgets: 4 fleets of 2 UAVs on MARL_SCENARIO (20 x 12 surface, 59 moves an episode), three
rollouts of one episode each (1416 agent steps), a [16] network."""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest
import torch
import yaml

pytest.importorskip("pettingzoo")

from agents.fast import FastPPO  # noqa: E402
from agents.fast.fleet import FLEET_KEY, FleetSpec, fly_fleet, policy_act  # noqa: E402
from agents.fast.fleet_run import FLEET_HYPERPARAMS, FleetSettings, train_fleet  # noqa: E402
from baselines.fleet import MARL_SCENARIO, fleet_bound  # noqa: E402
from ios_uav_env.model.fleet import fleet_maxmin, fleet_setup  # noqa: E402
from ios_uav_env.model.separation import DEFAULT_SEPARATION  # noqa: E402

FLEETS, STEPS = 4, 3 * 4 * 2 * 59


pytestmark = pytest.mark.usefixtures("one_torch_thread")


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """The shipped recipe with a tiny network, minibatch and pass count."""
    with open(FLEET_HYPERPARAMS, encoding="utf-8") as fh:
        entry = yaml.safe_load(fh)[FLEET_KEY]
    entry.update(n_envs=FLEETS, n_timesteps=STEPS, batch_size=236, n_epochs=2,
                 policy_kwargs="dict(net_arch=dict(pi=[16], vf=[16]))")  # fmt: skip
    path = tmp_path_factory.mktemp("recipe") / "fleet.yml"
    path.write_text(yaml.safe_dump({FLEET_KEY: entry}), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def bound():
    """The certified bound on every separated flight of MARL_SCENARIO's two UAVs (baselines.fleet)."""
    configs = fleet_setup(MARL_SCENARIO, 2, None, None, DEFAULT_SEPARATION, "orthogonal", None)[2]
    return fleet_bound(configs)[0]


def run(tiny, folder, seed=0):
    settings = FleetSettings(seed=seed, out=str(folder), hyperparams_file=str(tiny), progress_bar=False)
    return train_fleet(settings)


def weights(run_dir):
    from stable_baselines3 import PPO

    return PPO.load(run_dir / "model.zip", device="cpu").policy.state_dict()


def test_the_shipped_recipe_trains_two_uavs_on_marl_scenario():
    hp, recipe, spec = FleetSettings().hyperparams()
    assert recipe.n_envs == hp.n_envs == 128  # fleets; the rows are 2 x 128
    assert spec.uavs == 2 and spec.vector_env(1).config == MARL_SCENARIO
    assert recipe.n_steps == MARL_SCENARIO.N - 1  # a rollout is one whole episode of every fleet


def test_a_fleet_run_saves_its_files_and_its_flights_stay_below_the_bound(tiny, tmp_path, bound):
    result = run(tiny, tmp_path / "a")
    folder = result.run_dir
    for name in ("config.json", "model.zip", "vecnormalize.pkl", "summary.json", "progress.csv"):
        assert (folder / name).is_file(), name
    assert (folder / "checkpoints" / f"rl_model_{STEPS}_steps.zip").is_file()
    config = json.loads((folder / "config.json").read_text())
    assert config["fleet"]["scenario"] == MARL_SCENARIO.to_dict() and config["fleet"]["uavs"] == 2
    assert (config["n_envs"], config["rows"], config["trainer"]) == (FLEETS, 2 * FLEETS, "fast")
    lines = [json.loads(line) for line in (folder / "progress.csv").read_text().splitlines()]
    assert [line["steps"] for line in lines] == [1 * STEPS // 3, 2 * STEPS // 3, STEPS]
    assert all(line["score_name"] == "min_rate" and 0 < line["episode_score"] for line in lines)
    # the saved policy's deterministic flights, scored by the model
    from stable_baselines3 import PPO

    model = PPO.load(folder / "model.zip", device="cpu")
    vecnormalize = pickle.loads((folder / "vecnormalize.pkl").read_bytes())
    flight = fly_fleet(policy_act(model, vecnormalize), FleetSpec({"uavs": 2}, MARL_SCENARIO))
    assert flight.trajectories.shape == (2, MARL_SCENARIO.N, 2) and flight.feasible
    best = fleet_maxmin(MARL_SCENARIO, flight.trajectories)
    assert best.value == pytest.approx(flight.best_schedule_rate, rel=1e-9)
    assert 0 < flight.min_rate <= best.value + 1e-9 and best.upper <= bound + 1e-9
    final = result.summary["final_eval"]
    assert final["score"] == flight.min_rate and final["best_schedule_rate"] == flight.best_schedule_rate


def test_two_runs_with_the_same_seed_give_the_same_weights(tiny, tmp_path):
    first, second = (weights(run(tiny, tmp_path / name).run_dir) for name in ("a", "b"))
    other = weights(run(tiny, tmp_path / "c", seed=1).run_dir)
    assert all(torch.equal(first[key], second[key]) for key in first)
    assert not all(torch.equal(first[key], other[key]) for key in first)


def test_a_finished_episode_is_scored_once_per_fleet(tiny):
    recipe = FleetSettings(hyperparams_file=str(tiny), n_envs=3).hyperparams()[1]
    algo = FastPPO(FleetSpec({"uavs": 2}, MARL_SCENARIO), recipe, 10_000, update="torch")
    ends = []
    step = algo.vec.step

    def recording(actions):
        out = step(actions)
        if "final_info" in out[4]:
            ends.append(np.array(out[4]["final_info"]["min_rate"]))
        return out

    algo.vec.step = recording
    try:
        assert algo.recipe.n_envs == 6 and algo.recipe.rollout_size == 6 * 59
        assert algo.collect()  # one episode of every fleet
        scores = algo.take_scores()
    finally:
        algo.close()
    (rows,) = ends  # the agent rows' team min rates: fleet b's in rows 2b and 2b + 1
    assert len(rows) == 6 and np.array_equal(rows[0::2], rows[1::2]) and len(set(rows[0::2])) == 3
    assert scores == rows[0::2].tolist()


def test_what_the_fleets_do_not_take_is_refused(tiny, tmp_path):
    with pytest.raises(ValueError, match="num_fleets"):
        FleetSpec({"num_fleets": 3})
    with pytest.raises(TypeError, match="env_kwargs must be a mapping"):
        FleetSpec([("uavs", 2)])
    recipe = FleetSettings(hyperparams_file=str(tiny)).hyperparams()[1]
    with pytest.raises(ValueError, match="env_kwargs: a FleetSpec carries its own"):
        FastPPO(FleetSpec({"uavs": 2}, MARL_SCENARIO), recipe, 1000, env_kwargs={"uavs": 3})
    with pytest.raises(TypeError, match="env_id must be an env id"):
        FastPPO(MARL_SCENARIO, recipe, 1000)
    entry = yaml.safe_load(tiny.read_text())
    entry[FLEET_KEY]["env_wrapper"] = [{"agents.wrappers.ExploringStarts": {"prob": 0.5}}]
    starts = tmp_path / "starts.yml"
    starts.write_text(yaml.safe_dump(entry), encoding="utf-8")
    with pytest.raises(ValueError, match="ExploringStarts is not applied on fleets"):
        train_fleet(FleetSettings(out=str(tmp_path / "run"), hyperparams_file=str(starts)))
    assert not (tmp_path / "run").exists()
    with pytest.raises(ValueError, match="batch_size must be in"):
        FleetSettings(hyperparams_file=str(tiny), n_envs=1).hyperparams()  # 236 > 1 x 2 x 59
    with pytest.raises(ValueError, match="eval_freq must be an integer >= 0"):
        FleetSettings(eval_freq=-1).validate()


def test_the_fast_trainer_imports_without_pettingzoo_and_the_fleets_name_the_extra():
    import subprocess
    import sys
    import textwrap

    code = textwrap.dedent(
        """
        import sys
        sys.modules["pettingzoo"] = None
        from agents.fast import FastPPO
        from agents.fast.fleet import FleetSpec
        try:
            FleetSpec({"uavs": 2}).vector_env(1)
        except ImportError as exc:
            print(exc)
        """
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "ios-uav-env[marl]" in proc.stdout
