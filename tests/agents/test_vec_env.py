"""agents.vec_env.BatchedVecEnv: SB3's VecEnv contract, and the same data as a DummyVecEnv of the
same seeds (one PPO rollout, terminal observations, VecNormalize / VecMonitor on top)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.env_util import make_vec_env  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv, VecMonitor, VecNormalize  # noqa: E402

import ios_uav_env  # noqa: E402, F401
from agents.vec_env import BatchedVecEnv  # noqa: E402

ENV_ID = "ios_uav_env/IOSUAV-v0"
SHORT = {"T": 40}  # 39 steps per episode: a short rollout crosses episode ends


def test_vecenv_contract() -> None:
    venv = BatchedVecEnv(ENV_ID, 3, env_kwargs=SHORT, seed=5)
    assert isinstance(venv, VecEnv)
    assert venv.num_envs == 3
    assert venv.observation_space == gym.make(ENV_ID, **SHORT).observation_space
    obs = venv.reset()
    assert obs.shape == (3, *venv.observation_space.shape) and obs.dtype == np.float32
    actions = np.stack([venv.action_space.sample() for _ in range(3)])
    obs, rewards, dones, infos = venv.step(actions)
    assert obs.shape == (3, *venv.observation_space.shape)
    assert rewards.shape == (3,) and rewards.dtype == np.float32
    assert dones.shape == (3,) and dones.dtype == np.bool_
    assert isinstance(infos, list) and len(infos) == 3 and all(isinstance(i, dict) for i in infos)
    assert venv.get_attr("config", 1)[0] == venv.vector_env.envs[1].config
    assert len(venv.env_method("get_wrapper_attr", "config")) == 3
    assert venv.env_is_wrapped(gym.Wrapper) == [False] * 3
    with pytest.raises(AttributeError):
        venv.set_attr("config", None)
    venv.close()


def test_seed_gives_the_first_observation_of_env_seed_plus_i() -> None:
    venv = BatchedVecEnv(ENV_ID, 2, env_kwargs=SHORT)
    venv.seed(7)
    obs = venv.reset()
    for i in range(2):
        single, _ = gym.make(ENV_ID, **SHORT).reset(seed=7 + i)
        np.testing.assert_array_equal(obs[i], single)


def _dummy(n: int, seed: int, env_kwargs: dict) -> VecEnv:
    return make_vec_env(ENV_ID, n_envs=n, seed=seed, env_kwargs=env_kwargs, vec_env_cls=DummyVecEnv)


@pytest.mark.parametrize("normalize", [False, True])
def test_one_ppo_rollout_matches_dummy_vec_env(normalize: bool) -> None:
    """Same seeds, same policy: the rollout buffers hold the same observations, actions, rewards
    (bootstrapped at episode ends from the terminal observation) and episode starts."""
    n, seed = 3, 11
    buffers = []
    for venv in (_dummy(n, seed, SHORT), VecMonitor(BatchedVecEnv(ENV_ID, n, env_kwargs=SHORT, seed=seed))):
        if normalize:
            venv = VecNormalize(venv, gamma=0.99, norm_obs=True, norm_reward=True)
        model = PPO("MlpPolicy", venv, n_steps=48, batch_size=48, n_epochs=1, seed=0, device="cpu")
        model.learn(n * 48)  # one rollout (48 steps cross the 39-step episode end), one update
        buffers.append(model.rollout_buffer)
        if normalize:
            buffers.append(venv.obs_rms.mean.copy())
    dummy, batched = buffers[0], buffers[-2 if normalize else 1]
    for key in ("observations", "actions", "rewards", "episode_starts", "values", "returns"):
        np.testing.assert_allclose(
            getattr(batched, key), getattr(dummy, key), rtol=1e-5, atol=1e-6, err_msg=key
        )
    assert dummy.episode_starts[1:].any()  # an episode did end inside the rollout
    if normalize:
        np.testing.assert_allclose(buffers[3], buffers[1], rtol=1e-6)


def test_terminal_observation_is_the_single_envs_last() -> None:
    n, seed = 2, 3
    venv = VecMonitor(BatchedVecEnv(ENV_ID, n, env_kwargs=SHORT, seed=seed))
    singles = [gym.make(ENV_ID, **SHORT) for _ in range(n)]
    firsts = [env.reset(seed=seed + i)[0] for i, env in enumerate(singles)]
    obs = venv.reset()
    np.testing.assert_array_equal(obs, np.stack(firsts))
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(39):
        actions = rng.uniform(-1, 1, (n, 2)).astype(np.float32)
        obs, rewards, dones, infos = venv.step(actions)
        for i, env in enumerate(singles):
            last, reward, terminated, truncated, info = env.step(actions[i])
            assert rewards[i] == np.float32(reward)
            assert dones[i] == (terminated or truncated)
            if dones[i]:
                ended += 1
                np.testing.assert_array_equal(infos[i]["terminal_observation"], last)
                assert infos[i]["TimeLimit.truncated"] is False
                assert infos[i]["average_rate"] == pytest.approx(info["average_rate"], rel=1e-12)
                assert infos[i]["feasible"] == info["feasible"]
                assert infos[i]["episode"]["l"] == 39  # VecMonitor's episode record
                np.testing.assert_array_equal(obs[i], env.reset()[0])  # the next episode's first
            else:
                np.testing.assert_array_equal(obs[i], last)
                assert "terminal_observation" not in infos[i]
    assert ended == n


def test_shift_reward_on_the_batched_env() -> None:
    from agents.vec_env import VecShiftReward, wrap_batched
    from agents.wrappers import ShiftReward

    plain = BatchedVecEnv(ENV_ID, 2, env_kwargs=SHORT, seed=1)
    shifted = wrap_batched(
        BatchedVecEnv(ENV_ID, 2, env_kwargs=SHORT, seed=1), [(ShiftReward, {"offset": 2.5, "scale": 2.0})]
    )
    assert isinstance(shifted, VecShiftReward)
    np.testing.assert_array_equal(plain.reset(), shifted.reset())
    actions = np.full((2, 2), 0.3, dtype=np.float32)
    _, r_plain, _, _ = plain.step(actions)
    _, r_shift, _, _ = shifted.step(actions)
    np.testing.assert_allclose(r_shift, 2.0 * (r_plain - 2.5), rtol=1e-6)
    with pytest.raises(ValueError, match="scale"):
        VecShiftReward(plain, scale=0.0)
    with pytest.raises(ValueError, match="cannot wrap the batched env"):
        wrap_batched(plain, [(gym.wrappers.ClipAction, {})])


def test_stagger_spreads_the_rows_over_the_episode() -> None:
    n, steps = 8, 39  # T = 40 s: 39 moves per episode
    venv = VecMonitor(BatchedVecEnv(ENV_ID, n, env_kwargs=SHORT, seed=0, stagger=True))
    obs = venv.reset()
    moves_left = np.rint(obs[:, 8] * steps).astype(int)  # time_left = moves_left / (N - 1)
    np.testing.assert_array_equal(moves_left, steps - (np.arange(n) * steps) // n)
    ends = np.zeros(n, dtype=int)
    for t in range(1, steps + 1):
        _, _, dones, infos = venv.step(np.zeros((n, 2), dtype=np.float32))
        ends[dones] = t
        for i in np.flatnonzero(dones):
            assert infos[i]["feasible"] and "terminal_observation" in infos[i]
    np.testing.assert_array_equal(ends, moves_left)  # each row ends when its moves run out
    plain = BatchedVecEnv(ENV_ID, n, env_kwargs=SHORT, seed=0)
    assert (plain.reset()[:, 8] == 1.0).all()  # without stagger every row starts at slot 1


MULTI_ID = "ios_uav_env/IOSUAV-MultiNode-v0"


def test_multinode_rows_are_the_single_envs_with_their_scores() -> None:
    """The multi-node id: same-step rows equal single MultiNodeEnvs seeded seed + i (terminal
    observations, rewards, the agent's own score as average_rate); no LP by default."""
    n, seed, kwargs = 2, 3, {"T": 34}  # 33 moves per episode
    venv = BatchedVecEnv(MULTI_ID, n, env_kwargs=kwargs, seed=seed)
    assert venv.vector_env.best_schedule is False
    assert BatchedVecEnv(MULTI_ID, 1, env_kwargs={**kwargs, "best_schedule": True}).vector_env.best_schedule
    singles = [gym.make(MULTI_ID, **kwargs) for _ in range(n)]
    obs = venv.reset()
    np.testing.assert_array_equal(
        obs, np.stack([env.reset(seed=seed + i)[0] for i, env in enumerate(singles)])
    )
    rng = np.random.default_rng(0)
    for _ in range(33):
        actions = rng.uniform(-1, 1, (n, 5)).astype(np.float32)
        obs, rewards, dones, infos = venv.step(actions)
        for i, env in enumerate(singles):
            last, reward, terminated, _, info = env.step(actions[i])
            assert rewards[i] == np.float32(reward) and dones[i] == terminated
            if terminated:
                np.testing.assert_array_equal(infos[i]["terminal_observation"], last)
                assert infos[i]["average_rate"] == info["min_rate"] and infos[i]["feasible"]
    assert dones.all()


def test_ppo_trains_on_the_batched_multinode_env_with_stagger() -> None:
    venv = VecMonitor(BatchedVecEnv(MULTI_ID, 8, env_kwargs={"T": 40}, seed=0, stagger=True))
    obs = venv.reset()
    assert len(set(np.round(obs[:, 6], 6))) == 8  # time_left: the rows spread over the episode
    model = PPO("MlpPolicy", venv, n_steps=32, batch_size=64, n_epochs=1, seed=0, device="cpu")
    model.learn(8 * 32 * 2)  # 512 steps: two rollouts, the staggered rows end episodes in both
    assert model.num_timesteps == 512 and len(model.ep_info_buffer) >= 8


def test_action_repeat_on_the_batched_env_is_the_wrapper_on_single_envs() -> None:
    """VecActionRepeat over staggered rows (episodes ending at different slots, some within a
    repeat) gives each row what agents.wrappers.ActionRepeat gives a single env."""
    from agents.vec_env import VecActionRepeat, wrap_batched
    from agents.wrappers import ActionRepeat

    n, moves, repeat, seed = 4, 39, 4, 2
    base = BatchedVecEnv(ENV_ID, n, env_kwargs=SHORT, seed=seed, stagger=True)
    venv = wrap_batched(base, [(ActionRepeat, {"repeat": repeat})])
    assert isinstance(venv, VecActionRepeat)
    obs = venv.reset()
    singles = [ActionRepeat(gym.make(ENV_ID, **SHORT), repeat) for _ in range(n)]
    for i, env in enumerate(singles):
        env.reset(seed=seed + i)
        for _ in range((i * moves) // n):  # the row's stagger: hover moves from q0
            env.unwrapped.step(np.zeros(2))
    rng = np.random.default_rng(0)
    lengths = []
    for _ in range(25):  # 100 slots: every row ends an episode, some within a repeat
        actions = rng.uniform(-1, 1, (n, 2)).astype(np.float32)
        obs, rewards, dones, infos = venv.step(actions)
        for i, env in enumerate(singles):
            last, reward, terminated, _, info = env.step(actions[i])
            assert rewards[i] == pytest.approx(reward, rel=1e-5, abs=1e-5) and dones[i] == terminated
            if terminated:
                np.testing.assert_array_equal(infos[i]["terminal_observation"], last)
                assert infos[i]["average_rate"] == pytest.approx(info["average_rate"], rel=1e-12)
                lengths.append(len(env.unwrapped.trajectory))
                last = env.reset()[0]
            np.testing.assert_array_equal(obs[i], last)
    assert lengths and set(lengths) == {moves + 1}  # whole episodes: the repeat never overran an end
    with pytest.raises(ValueError, match="wraps a BatchedVecEnv directly"):
        VecActionRepeat(VecMonitor(BatchedVecEnv(ENV_ID, 1, env_kwargs=SHORT)), repeat)
    with pytest.raises(ValueError, match="repeat must be an integer >= 1"):
        ActionRepeat(gym.make(ENV_ID), 0)


def test_exploring_starts_on_the_batched_env() -> None:
    """VecExploringStarts (under a monitor, over the action repeat): episodes after the first start
    part-way along a feasible flight; the seed fixes the prefixes."""
    from agents.vec_env import VecExploringStarts, wrap_batched
    from agents.wrappers import ActionRepeat, ExploringStarts

    def make(seed: int) -> VecEnv:
        base = BatchedVecEnv(MULTI_ID, 4, env_kwargs={"T": 60}, seed=seed)
        inner = VecMonitor(wrap_batched(base, [(ActionRepeat, {"repeat": 2})]))
        return wrap_batched(inner, [(ExploringStarts, {"prob": 1.0, "max_moves": 30})])

    runs = []
    for seed in (0, 0, 1):
        venv = make(seed)
        assert isinstance(venv, VecExploringStarts)
        obs = venv.reset()
        assert (obs[:, 6] == 1.0).all()  # the first episodes start at q0
        firsts = []
        for _ in range(75):  # 150 slots: the first episodes (59 slots) and at least one more each
            obs, _, dones, infos = venv.step(np.zeros((4, 5), dtype=np.float32))
            for i in np.flatnonzero(dones):
                assert infos[i]["feasible"]
                firsts.append(obs[i].copy())
        runs.append(np.array(firsts))
    assert len(runs[0]) >= 8 and (runs[0][:, 6] < 1.0).all()  # every later episode began part-way
    np.testing.assert_array_equal(runs[0], runs[1])
    assert not np.array_equal(runs[0], runs[2])
    with pytest.raises(ValueError, match="needs a BatchedVecEnv under it"):
        VecExploringStarts(DummyVecEnv([lambda: gym.make(MULTI_ID)]))


def test_exploring_starts_on_the_single_node_batched_env() -> None:
    """The single-node batched env flies the prefix through its generic fly (advance steps)."""
    from agents.vec_env import VecExploringStarts

    venv = VecExploringStarts(BatchedVecEnv(ENV_ID, 2, env_kwargs=SHORT, seed=0), prob=1.0, max_moves=20)
    venv.reset()
    starts = []
    for _ in range(39 + 20):
        obs, _, dones, infos = venv.step(np.zeros((2, 2), dtype=np.float32))
        for i in np.flatnonzero(dones):
            assert infos[i]["feasible"]
            starts.append(obs[i, 8])  # time_left of the next episode's first observation
    assert len(starts) >= 2 and all(0.45 <= s < 1.0 for s in starts)  # 1-20 of 39 moves gone


@pytest.mark.parametrize("env_id", ["ios_uav_env/STARControl-v0", "ios_uav_env/MISOControl-v0"])
def test_a_control_id_is_refused_with_what_to_use(env_id: str) -> None:
    """The control ids' batched envs do not fly the UAV (no ``advance``): the wrapper says so and
    names what to use, instead of failing at the first step."""
    with pytest.raises(ValueError, match=r"env_id: BatchedVecEnv wraps the flight ids.*DummyVecEnv"):
        BatchedVecEnv(env_id, 2)
