"""Memory in the observation (``agents.tricks.FrameStack``): Gymnasium's frame stack, once, on every
training path (the single env's wrapper, the batched VecEnv form, the fast trainer), and the same
observation rebuilt when the model is scored on the env's own observations (``agents.tricks.History``,
``agents.loading``, the benchmark)."""

from __future__ import annotations

import json
from collections import deque
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import torch

import ios_uav_env  # noqa: F401
from agents.fast import FastPPO, FastRecipe
from agents.tricks import FrameStack as Stack
from agents.tricks import History
from agents.wrappers import FrameStack, memory_frames
from tests.agents.test_fast import recipe

pytestmark = pytest.mark.usefixtures("one_torch_thread")

MOBILE = "ios_uav_env/IOSUAV-Mobile-v0"
MEMORY = [{"agents.wrappers.FrameStack": {"frames": 3}}]


def gymnasium_stack(env: gym.Env, frames: int) -> gym.Env:
    """Gymnasium's own frame stack, flattened (``FrameStack`` before Gymnasium 1.0: the same padding)."""
    from gymnasium.wrappers import FlattenObservation

    try:
        from gymnasium.wrappers import FrameStackObservation as Stacked
    except ImportError:  # Gymnasium 0.29
        from gymnasium.wrappers import FrameStack as Stacked
    return FlattenObservation(Stacked(env, frames))


def test_the_wrapper_is_gymnasiums_frame_stack_flattened():
    """Two seeded episodes in a row, the same random actions: every observation equal, bit for bit."""
    ours, theirs = FrameStack(gym.make(MOBILE), 3), gymnasium_stack(gym.make(MOBILE), 3)
    assert ours.observation_space == theirs.observation_space
    assert ours.observation_space.shape == (3 * gym.make(MOBILE).observation_space.shape[0],)
    rng = np.random.default_rng(0)
    for seed in (4, 5):
        a, _ = ours.reset(seed=seed)
        b, _ = theirs.reset(seed=seed)
        np.testing.assert_array_equal(a, np.asarray(b))
        done, steps = False, 0
        while not done:
            action = rng.uniform(-1, 1, ours.action_space.shape).astype(np.float32)
            a, _, term, trunc, _ = ours.step(action)
            b, *_ = theirs.step(action)
            np.testing.assert_array_equal(a, np.asarray(b))
            done, steps = term or trunc, steps + 1
        assert steps > 3  # the history was full of distinct frames


def test_the_batched_form_stacks_each_row_and_its_final_observation():
    """``VecFrameStack`` on the batched env against a per-row deque of the same env's raw rows,
    through an autoreset: a new episode starts with its first observation repeated and the
    finished row's ``terminal_observation`` is the stack of its final observation."""
    from agents.vec_env import BatchedVecEnv, VecFrameStack

    raw = BatchedVecEnv(MOBILE, 2, seed=3)
    stacked = VecFrameStack(BatchedVecEnv(MOBILE, 2, seed=3), frames=3)
    assert stacked.observation_space.shape == (3 * raw.observation_space.shape[0],)
    rows = [deque([o] * 3, maxlen=3) for o in raw.reset()]
    np.testing.assert_array_equal(stacked.reset(), [np.concatenate(r) for r in rows])
    rng, ends, step = np.random.default_rng(1), 0, 0
    while ends < 2 or step < 5:
        actions = rng.uniform(-1, 1, (2, *raw.action_space.shape)).astype(np.float32)
        obs, _, dones, infos = raw.step(actions)
        got, _, got_dones, got_infos = stacked.step(actions)
        np.testing.assert_array_equal(got_dones, dones)
        for i in range(2):
            if dones[i]:
                final = list(rows[i])[1:] + [infos[i]["terminal_observation"]]
                np.testing.assert_array_equal(got_infos[i]["terminal_observation"], np.concatenate(final))
                rows[i] = deque([obs[i]] * 3, maxlen=3)
                ends, step = ends + 1, 0
            else:
                rows[i].append(obs[i])
        np.testing.assert_array_equal(got, [np.concatenate(r) for r in rows])
        step += 1


def test_history_restarts_where_the_clock_says_a_new_episode_began():
    """The memory of a policy on the env's own observations equals the wrapper's stack over two
    episodes in a row, the second told by ``time_left``; without that guard it would carry the
    first episode's frames into the second."""
    env, wrapped = gym.make(MOBILE), FrameStack(gym.make(MOBILE), 3)
    clock = env.unwrapped.observation_names.index("time_left")
    memory = History(3, clock)
    rng = np.random.default_rng(2)
    for seed in (7, 8):
        obs, _ = env.reset(seed=seed)
        want, _ = wrapped.reset(seed=seed)
        for _ in range(10):
            np.testing.assert_array_equal(memory(obs), want)
            action = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
            obs, *_ = env.step(action)
            want, *_ = wrapped.step(action)
    batch = np.stack([obs, obs])
    assert memory(batch).shape == (2, want.shape[0])  # another batch size: a new history per row


def test_the_recipe_reads_the_memory_and_refuses_bad_settings():
    assert recipe(env_wrapper=MEMORY).frames == 3 and recipe().frames == 1
    with pytest.raises(ValueError, match="frames must be an integer >= 1"):
        recipe(env_wrapper=[{"agents.wrappers.FrameStack": {"frames": 0}}])
    with pytest.raises(ValueError, match="FrameStack'.*unexpected keyword argument 'frame'"):
        recipe(env_wrapper=[{"agents.wrappers.FrameStack": {"frame": 3}}])
    both = [*MEMORY, {"agents.wrappers.ActionRepeat": {"repeat": 2}}]
    with pytest.raises(ValueError, match="FrameStack and ActionRepeat cannot be combined"):
        memory_frames(both)
    with pytest.raises(ValueError, match="frames must be an integer >= 1, got 2.5"):
        Stack(2.5)


def _train(seed: int) -> tuple[list[torch.Tensor], FastPPO]:
    r = recipe(
        env_wrapper=MEMORY, normalize="{'norm_obs': True, 'norm_reward': True}", n_envs=16, batch_size=64
    )
    algo = FastPPO(MOBILE, r, total=2 * r.rollout_size, seed=seed)
    try:
        while algo.steps < algo.total:
            algo.collect()
            algo.update()
        return [p.detach().clone() for p in algo.policy.parameters()], algo
    finally:
        algo.close()


def test_the_fast_trainer_with_memory_is_reproducible_from_its_seed():
    """Two runs seeded alike end with the same parameters, another seed does not; the network
    reads three frames of the env's observation."""
    first, algo = _train(3)
    again, _ = _train(3)
    other, _ = _train(4)
    d = gym.make(MOBILE).observation_space.shape[0]
    assert algo.policy.observation_space.shape == (3 * d,) and algo._obs.shape == (16, 3 * d)
    np.testing.assert_array_equal(algo.latest(algo._obs), algo._obs[:, -d:])
    assert all(torch.equal(a, b) for a, b in zip(first, again, strict=True))
    assert not all(torch.equal(a, b) for a, b in zip(first, other, strict=True))


@pytest.fixture(scope="module")
def memory_run(tmp_path_factory) -> Path:
    """A tiny fast run with a memory of 3 frames on the moving-node id."""
    import yaml

    from agents.training import TrainSettings, train
    from tests.agents.test_fast import entry

    folder = tmp_path_factory.mktemp("memory")
    path = folder / "fast.yml"
    e = entry(
        n_envs=16, batch_size=64, env_wrapper=MEMORY, normalize="{'norm_obs': True, 'norm_reward': True}"
    )
    path.write_text(yaml.safe_dump({MOBILE: e}))
    before = torch.get_num_threads()
    settings = TrainSettings(algo="ppo", trainer="fast", env_id=MOBILE, timesteps=256,
                             hyperparams_file=str(path), out=str(folder / "run"), checkpoint_freq=256,
                             eval_freq=0, progress_bar=False, threads=1)  # fmt: skip
    try:
        return train(settings).run_dir
    finally:
        torch.set_num_threads(before)


def test_a_memory_model_is_scored_on_the_suite_with_the_observation_it_was_trained_on(memory_run):
    """``load_agent`` and ``load_numpy_agent`` read the memory from the run's recipe and take the
    env's own observations; the benchmark's score of the agent on a ``mobile-v2`` scenario is the
    rate of the model flown by hand in the frame-stacked env on that scenario, bit for bit."""
    from agents.loading import load_agent, load_numpy_agent
    from ios_uav_env import score_plan
    from ios_uav_env.benchmark import evaluate, load_suite

    agent = load_agent(memory_run)
    d = gym.make(MOBILE).observation_space.shape[0]
    assert agent.memory == 3 and agent.observation_space.shape == (d,)
    assert agent.model.observation_space.shape == (3 * d,)
    numpy_agent = load_numpy_agent(memory_run)
    assert numpy_agent.history is not None and numpy_agent.observation_space.shape == (d,)
    scenario = load_suite("mobile-v2")[0]
    env = FrameStack(gym.make(MOBILE), 3)
    obs, _ = env.reset(seed=scenario.seed, options={"config": scenario.config})
    done = False
    while not done:  # the model itself (no History) on the stacked observation
        x = agent.vecnormalize.normalize_obs(obs)
        obs, _, term, trunc, _ = env.step(agent.model.predict(x, deterministic=True)[0])
        done = term or trunc
    want = score_plan(scenario.config, env.unwrapped.trajectory, paths=scenario.paths()).rate
    got = evaluate(load_agent(memory_run), suite="mobile-v2", n=1).scenarios[0]
    assert got.rate == want
    plain = evaluate(numpy_agent, suite="mobile-v2", n=1).scenarios[0]  # float64 export: runs, feasible
    assert plain.feasible and np.isfinite(plain.rate)


def test_the_run_records_the_memory_and_sb3_trains_with_it_too(memory_run, tmp_path):
    """The fast run's config keeps the recipe's FrameStack; SB3's own loop (single envs, the
    wrapper) trains with the same entry and its agent loads with the memory."""
    from agents.loading import load_agent
    from agents.training import TrainSettings, check_hyperparams, train

    config = json.loads((memory_run / "config.json").read_text())
    assert memory_frames(config["hyperparams"]["env_wrapper"]) == 3
    import yaml

    path = tmp_path / "ppo.yml"
    e = {"n_envs": 2, "n_timesteps": 128, "policy": "MlpPolicy", "n_steps": 64, "batch_size": 64,
         "n_epochs": 1, "env_wrapper": MEMORY}  # fmt: skip
    path.write_text(yaml.safe_dump({MOBILE: e}))
    check_hyperparams("ppo", MOBILE, path, vec_env="batched")  # the VecEnv form exists
    settings = TrainSettings(algo="ppo", env_id=MOBILE, hyperparams_file=str(path), out=str(tmp_path / "sb3"),
                             eval_freq=0, progress_bar=False)  # fmt: skip
    result = train(settings)
    agent = load_agent(result.run_dir)
    assert agent.memory == 3 and agent.model.observation_space.shape == (
        3 * agent.observation_space.shape[0],
    )
    assert result.summary["final_eval"]["feasible"]


def test_the_memory_recipe_is_read_by_both_trainers():
    """``agents/hyperparams/fast_ppo_memory.yml``: the fast trainer reads its memory, clone and env
    arguments (its expert checked on the env)."""
    from agents.hyperparams import HYPERPARAMS_DIR
    from agents.training import check_hyperparams

    path = HYPERPARAMS_DIR / "fast_ppo_memory.yml"
    hp = check_hyperparams("ppo", MOBILE, path, trainer="fast")
    r = FastRecipe.from_hyperparams(hp)
    assert r.frames == 4 and r.clone is not None and hp.env_kwargs == {"filter_estimate": True}
    assert hp.memory == 4 and r.rollout_size % r.batch_size == 0


def test_a_memory_run_resumes_from_its_checkpoint(memory_run, tmp_path):
    """``--resume`` rebuilds the stacked observation's network and statistics from the checkpoint."""
    import shutil

    from agents.training import resume

    run = tmp_path / "run"
    shutil.copytree(memory_run, run)
    before = torch.get_num_threads()
    try:
        result = resume(run, timesteps=512, progress_bar=False)
    finally:
        torch.set_num_threads(before)
    assert result.summary["steps"] == 512
    assert result.summary["final_eval"]["feasible"]
