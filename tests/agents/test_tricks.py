"""agents.tricks: each training trick once, on the batched env's rows, and the same training as
before it was one implementation.

The parity cases re-run what ``tests/agents/data/record_tricks.py`` recorded in
``tricks_parity.npz`` from the code before (the SB3 batched path, the Gymnasium wrappers and
the fast trainer, on tiny budgets with every trick of the shipped recipes): on the recording
machine they are equal bit for bit. Flags and counts are compared exactly; floats within the
golden episodes' tolerances (``tests/tolerances.py``): numba's env kernels are compiled for the
host with fast-math, and the fast cases run a float32 torch policy in the loop, whose kernels
differ by instruction set, so another CPU moves them by ulps, far less than any change of a trick
(a changed shift, prefix or draw moves them by orders of magnitude more).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import ios_uav_env  # noqa: E402, F401
from agents import tricks  # noqa: E402
from tests.agents.data import record_tricks  # noqa: E402
from tests.tolerances import GOLDEN_OBS_ABS, GOLDEN_REL  # noqa: E402

MULTI = "ios_uav_env/IOSUAV-MultiNode-v0"
CASES = {
    "sb3_shipped_multi": lambda: record_tricks.batched_case(
        record_tricks.MULTI, _multi_kwargs(), _sb3_multi().raw["env_wrapper"], 8, 60, 0
    ),
    "sb3_all_multi": lambda: record_tricks.batched_case(MULTI, {"T": 40}, record_tricks.ALL_TRICKS, 6, 40, 2),
    "sb3_all_single": lambda: record_tricks.batched_case(
        record_tricks.SINGLE, {"T": 40}, record_tricks.ALL_TRICKS, 5, 40, 3
    ),
    "gym_sac_shift": lambda: record_tricks.single_case(
        record_tricks.SINGLE, {"T": 40}, _sac().raw["env_wrapper"], 2, 4
    ),
    "gym_all_multi": lambda: record_tricks.single_case(MULTI, {"T": 40}, record_tricks.GYM_TRICKS, 4, 5),
    "gym_starts_multi": lambda: record_tricks.single_case(
        MULTI, _multi_kwargs(), _sb3_multi().raw["env_wrapper"], 4, 6
    ),
    "fast_shipped_multi": lambda: record_tricks.fast_cases()["fast_shipped_multi"],
}


def _sb3_multi():
    from agents.hyperparams import load_hyperparams

    return load_hyperparams("ppo", MULTI, record_tricks.SB3_FILE)


def _multi_kwargs() -> dict:
    return {**_sb3_multi().env_kwargs, "T": 40}


def _sac():
    from agents.hyperparams import load_hyperparams

    return load_hyperparams("sac", record_tricks.SINGLE)


def _compare(case: str, arrays: dict[str, np.ndarray]) -> None:
    stored = np.load(record_tricks.PATH)
    keys = sorted(k.split("/", 1)[1] for k in stored.files if k.startswith(f"{case}/"))
    assert sorted(arrays) == keys, case
    for key in keys:
        ref, new = stored[f"{case}/{key}"], arrays[key]
        where = f"{case}/{key}"
        assert new.shape == ref.shape and new.dtype == ref.dtype, where
        if ref.dtype.kind in "biu" or key in ("dones", "terminated"):
            np.testing.assert_array_equal(new, ref, err_msg=where)
        elif key in ("obs", "terminal", "actions"):
            np.testing.assert_allclose(new, ref, rtol=0, atol=GOLDEN_OBS_ABS, err_msg=where)
        else:
            scale = max(1.0, float(np.max(np.abs(ref), initial=0.0)))
            np.testing.assert_allclose(new, ref, rtol=0, atol=GOLDEN_REL * scale, err_msg=where)


@pytest.mark.parametrize("case", list(CASES))
def test_the_tricks_train_as_before(case: str) -> None:
    """The same seed gives the same rollouts (and, for the fast trainer, the same parameters after
    each update) as the code before the tricks were one implementation."""
    _compare(case, CASES[case]())


def test_the_fast_trainers_shift_and_starts_train_as_before() -> None:
    """The fast trainer with the reward shift, the exploring starts and their schedule at once."""
    _compare("fast_shift_starts", record_tricks.fast_cases()["fast_shift_starts"])


def test_the_recorded_cases_exercise_the_tricks() -> None:
    """The record is not of plain envs: shifted rewards, episodes begun part-way."""
    stored = np.load(record_tricks.PATH)
    assert stored["gym_sac_shift/rewards"].min() < -2.0  # a rate (> 0) minus 2.5
    assert stored["sb3_all_multi/rewards"].min() < -0.9  # 2 * (rate - 0.5): some slots below 0.05
    assert (stored["gym_starts_multi/slot"][::14] > 1).any()  # some episode starts after slot 1
    after_end = stored["sb3_shipped_multi/obs"][1:][stored["sb3_shipped_multi/dones"]]
    assert (after_end[:, 6] < 1.0).any() and (after_end[:, 6] == 1.0).any()  # some began part-way


# --- the tricks on arrays --------------------------------------------------------------------
def test_reward_shift_keeps_the_dtype_and_names_a_bad_field() -> None:
    shift = tricks.RewardShift(2.5, 2.0)
    rewards = np.array([2.0, 3.0], dtype=np.float32)
    out = shift(rewards)
    assert out.dtype == np.float32
    np.testing.assert_array_equal(out, [-1.0, 1.0])
    assert shift(np.float64(3.0)) == 1.0
    for kwargs, message in (({"scale": 0.0}, "ShiftReward scale must be > 0"),
                            ({"offset": float("nan")}, "ShiftReward offset must be a finite number"),
                            ({"offset": True}, "ShiftReward offset")):  # fmt: skip
        with pytest.raises(ValueError, match=message):
            tricks.RewardShift(**kwargs)


def test_action_repeat_stops_each_row_at_its_end() -> None:
    """Three rows ending after 1 slot, 2 slots, never: each stops at its end, the rest finish."""
    ends = np.array([1, 2, 99])
    calls: list[np.ndarray] = []
    seen: list[np.ndarray] = []

    def advance(rows: np.ndarray):
        calls.append(rows.copy())
        slot = len(calls)
        done = rows & (ends == slot)
        return np.full(3, slot), np.where(rows, 1.5, 0.0), done, {"slot": slot}

    obs, total, dones, info = tricks.ActionRepeat(4).step(
        advance, 3, ended=lambda d, i: seen.append(d.copy())
    )
    np.testing.assert_array_equal(total, [1.5, 3.0, 6.0])
    np.testing.assert_array_equal(dones, [True, True, False])
    assert [c.tolist() for c in calls] == [[1, 1, 1], [0, 1, 1], [0, 0, 1], [0, 0, 1]]
    assert [s.tolist() for s in seen] == [[1, 0, 0], [0, 1, 0]] and info == {"slot": 4}
    everyone = tricks.ActionRepeat(3).step(lambda rows: (None, rows * 1.0, rows.copy(), None), 2, np.float32)
    assert everyone[1].tolist() == [1.0, 1.0] and everyone[1].dtype == np.float32 and everyone[2].all()
    calls.clear()
    tricks.ActionRepeat(4).step(advance, 3, ended=None)
    assert len(calls) == 4  # no callback needed
    with pytest.raises(ValueError, match="ActionRepeat repeat must be an integer >= 1"):
        tricks.ActionRepeat(0)


def test_exploring_starts_draw_one_row_as_the_batch_draws_it() -> None:
    """The single env's adapter draws through the same function: a row's draws are those of the
    batch's first drawn row, the moves at most N - 3, none when prob is 0."""
    cfg = gym.make(MULTI, T=40).unwrapped.config
    one, many = (
        tricks.ExploringStarts(prob=1.0, max_moves=110),
        tricks.ExploringStarts(prob=1.0, max_moves=110),
    )
    one.seed(5)
    many.seed(5)
    rows, targets, moves = one.draw(np.zeros(1, dtype=np.int64), lambda r: [cfg])
    rows_b, targets_b, moves_b = many.draw(np.arange(1), lambda r: [cfg] * len(r))
    np.testing.assert_array_equal(targets, targets_b)
    assert rows.tolist() == rows_b.tolist() == [0] and moves.tolist() == moves_b.tolist()
    capped = tricks.ExploringStarts(prob=1.0, max_moves=110)
    capped.seed(0)
    assert capped.draw(np.arange(64), lambda r: [cfg] * len(r))[2].max() == cfg.N - 3
    never = tricks.ExploringStarts(prob=0.0)
    assert never.draw(np.arange(8), lambda r: pytest.fail("no scenario needed"))[0].size == 0
    assert tricks.scheduled_prob(0.8, 0.5, 0.6, 0.0) == 0.8
    assert tricks.scheduled_prob(0.8, 0.8, 0.6, 0.0) == pytest.approx(0.4)
    assert tricks.scheduled_prob(0.8, 1.0, 1.0, 0.0) == 0.8


def test_the_single_env_prefix_is_the_batched_envs_flight() -> None:
    """One seed: the Gymnasium wrapper's reset (its prefix by the env's steps) and the batched env's
    row (the same draws flown by ``fly`` after an episode end) start at the same state."""
    from agents.wrappers import ExploringStarts

    for seed in (3, 4):
        wrapper = ExploringStarts(gym.make(MULTI, T=40), prob=1.0, max_moves=30, peak_prob=0.5)
        obs_single, _ = wrapper.reset(seed=seed)
        vec = gym.make_vec(
            MULTI, num_envs=1, vectorization_mode="vector_entry_point", autoreset_mode="same_step", T=40
        )
        vec.reset(seed=0)
        for _ in range(39):  # the first episode (39 slots), to its end: the row restarts at q0
            obs, _, terminated, _, _ = vec.step(np.zeros((1, 5)))
        assert terminated[0]
        starts = tricks.ExploringStarts(prob=1.0, max_moves=30, peak_prob=0.5)
        starts.seed(seed)
        obs = starts.apply(vec, terminated, obs)
        np.testing.assert_allclose(obs[0], obs_single, rtol=0, atol=GOLDEN_OBS_ABS)
        assert obs_single[6] < 1.0  # part-way
        vec.close()
