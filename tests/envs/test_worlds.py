"""Every combination of components, run as an env: the supported ones pass Gymnasium's checker,
single and batched, a batch equals its rows run alone and a seed gives the same episode bit
for bit; the unsupported ones are refused at construction, by ``make_world`` and by the envs
themselves, with the message of ``World.check``."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from ios_uav_env.components import UnsupportedWorld, World, combinations
from ios_uav_env.envs.worlds import default_scenario, make_world

#: Short episodes (the shortest horizon of the default scenarios): the physics is the same at any T.
T = 34.0
#: An energy budget every flight of this length meets (J), so the budget's branch runs.
BUDGET = 1e6
#: A batch equals its rows to rounding, not bit for bit: the single-node kernels are compiled with
#: fastmath, and numba vectorises the B-row loop's sums in another order than one row's (~1e-16
#: relative; a faded rate, log2 of a sum of squares of the draws, to ~1e-11), which can flip the
#: last bit of a float32 observation (~6e-8 relative).
BATCH_REL, BATCH_OBS = 1e-9, 1e-6
WORLDS = list(combinations(nodes=(1, 3), budgets=(None, BUDGET)))
#: The surface changes the physics' constants, not how components combine: the full matrix runs
#: on the IOS, the other surfaces on the default of every other family.
MATRIX = [
    w
    for w in WORLDS
    if w.surface.kind == "ios" or w.names() == World(surface=w.surface, nodes=w.nodes).names()
]
SUPPORTED = [w for w in MATRIX if not w.problems()]
UNSUPPORTED = [w for w in MATRIX if w.problems()]


def _name(world: World) -> str:
    return "-".join(v.replace(" ", "") for v in world.names().values())


def _sdma(world: World) -> bool:
    """Whether ``world`` serves several users at once with a multi-antenna UAV (the SDMA env)."""
    return world.link.kind == "multi_antenna" and world.nodes > 1


def _config(world: World):
    return default_scenario(world.nodes, sdma=_sdma(world)).replace(T=T)


def _episode(env, seed: int, steps: int) -> tuple[list[np.ndarray], list[float]]:
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    observations, rewards = [obs], []
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = env.step(rng.uniform(-1.0, 1.0, env.action_space.shape))
        observations.append(obs)
        rewards.append(float(reward))
        if terminated or truncated:
            break
    return observations, rewards


def test_the_matrix_has_both_kinds():
    assert len(SUPPORTED) >= 40 and UNSUPPORTED


@pytest.mark.parametrize("world", SUPPORTED, ids=_name)
def test_a_supported_world_runs_single_and_batched(world):
    own = {"score": False} if _sdma(world) else {}  # (the SDMA score: J per-slot AOs a slot; its own tests)
    env = make_world(world, _config(world), **own)
    check_env(env.unwrapped, skip_render_check=True)
    # the same seed gives the same episode, bit for bit
    first, again = _episode(env, 7, 20), _episode(make_world(world, _config(world), **own), 7, 20)
    assert all(np.array_equal(a, b) for a, b in zip(first[0], again[0], strict=True))
    assert first[1] == again[1]
    # a batch of 3 rows seeded 7, 8, 9 equals the three envs run alone
    batch = make_world(world, _config(world), num_envs=3, **own)
    obs, _ = batch.reset(seed=7)
    singles = [make_world(world, _config(world), **own) for _ in range(3)]
    rngs = [np.random.default_rng(7 + i) for i in range(3)]
    single_obs = [s.reset(seed=7 + i)[0] for i, s in enumerate(singles)]
    assert np.array_equal(obs, np.stack(single_obs))
    n_steps = int(T / _config(world).dt) - 1
    for _ in range(n_steps):
        actions = np.stack(
            [rng.uniform(-1.0, 1.0, s.action_space.shape) for rng, s in zip(rngs, singles, strict=True)]
        )
        obs, rewards, terminated, _, _ = batch.step(actions.astype(np.float32))
        for i, s in enumerate(singles):
            o, r, t, _, _ = s.step(actions[i].astype(np.float32))
            np.testing.assert_allclose(obs[i], o, rtol=BATCH_OBS, atol=BATCH_OBS)
            assert rewards[i] == pytest.approx(r, rel=BATCH_REL, abs=BATCH_REL) and bool(terminated[i]) == t
    assert terminated.all()


@pytest.mark.parametrize("world", UNSUPPORTED, ids=_name)
def test_an_unsupported_world_is_refused_by_name(world):
    with pytest.raises(UnsupportedWorld, match=world.problems()[0][:40]):
        make_world(world, _config(world))
    # the env itself refuses it, with the same reason, when given the world's settings by keyword
    env_id = "ios_uav_env/IOSUAV-v0" if world.nodes == 1 else "ios_uav_env/IOSUAV-MultiNode-v0"
    kwargs = {**world.option_fields(), "config": _config(world).replace(**world.config_fields())}
    if world.nodes == 1:
        kwargs["surface"] = world.surface.kind
    with pytest.raises(UnsupportedWorld, match=world.problems()[0][:40]):
        gym.make(env_id, **kwargs)
