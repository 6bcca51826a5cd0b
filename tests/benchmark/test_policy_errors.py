"""A policy that raises mid-evaluation: on every suite, batched or not, at once or one scenario at
a time, the error names the suite, the scenario and the policy, and chains the policy's own."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env.benchmark import SUITES, evaluate, load_suite
from ios_uav_env.benchmark.policy_errors import PolicyError


class Breaks:
    """Stays in place (the guard flies it to qF) and raises ZeroDivisionError at call ``at``."""

    name = "breaks"

    def __init__(self, at: int, width: int, batched: bool = False) -> None:
        self.at, self.width, self.batched, self.calls = at, width, batched, 0

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        self.calls += 1
        if self.calls == self.at:
            raise ZeroDivisionError("the policy's own bug")
        return np.zeros((len(obs), self.width) if self.batched else self.width)


def _width(suite) -> int:
    if suite.star_control:  # scenario 0's surface (the policy raises on scenario 1's first call)
        return _star_width(suite)
    if suite.fleets:  # the move, one score per node slot and the surface bid
        return 2 + suite.env_kwargs["max_nodes"] + 1
    return 2 + (4 if suite.schedules else 0)


def _star_width(suite) -> int:
    if suite.miso_control:  # 2 N_t K beam entries and M phases
        miso = suite[0].miso
        return 2 * miso["antennas"] * miso["users"] + miso["elements"][0] * miso["elements"][1]
    star = suite[0].star
    g = star["elements"][0] * star["elements"][1] // star["group"]
    return 2 * g + 1 if star["access"] == "tdma" else 3 * g + 1


def _calls(suite) -> int:
    """The policy's calls in one episode of scenario 0: one per step, per live agent of a fleet."""
    if suite.star_control:  # one per slot: the surface is set in every slot of the episode
        return suite[0].config.N
    if suite.fleets:
        from ios_uav_env.benchmark.fleet_suite import fleet_configs

        return sum(c.N - 1 for c in fleet_configs(suite[0].config, suite[0].fleet))
    return suite[0].config.N - 1


#: Every suite, batched or not (a fleet's agents are called one by one: a batched policy is refused
#: there, by test_fleet_suite).
CASES = [(name, batched) for name in sorted(SUITES) for batched in (False, True)
         if not (batched and (load_suite(name).fleets or load_suite(name).star_control))]  # fmt: skip


@pytest.mark.parametrize(("name", "batched"), CASES)
def test_the_error_names_the_suite_the_scenario_and_the_policy(name, batched):
    suite = load_suite(name)
    steps = _calls(suite)  # the warm-up episode plays scenario 0 first
    policy = Breaks(2 * steps + 1, _width(suite), batched)  # the first call of scenario 1
    with pytest.raises(PolicyError) as err:
        evaluate(policy, suite, n=2, batched=batched)
    message = str(err.value)
    assert f"suite {name}" in message and "scenario 1" in message and "'breaks'" in message, message
    assert "ZeroDivisionError" in message and "the policy's own bug" in message
    assert isinstance(err.value.__cause__, ZeroDivisionError)
    if suite.mobile or suite.star_control:
        assert f"(episode seed {suite[1].seed})" in message


def test_in_the_warm_up_and_at_once_the_error_says_which_episode():
    with pytest.raises(PolicyError, match=r"on scenario 0 \(the unscored warm-up episode\) of suite single"):
        evaluate(Breaks(1, 2), "single-node-v1", n=2)
    steps = load_suite("single-node-v1")[0].config.N - 1  # the warm-up batch: scenario 0 alone
    with pytest.raises(PolicyError, match=r"on the batch of scenarios 0\.\.2 at once of suite single-node"):
        evaluate(Breaks(steps + 10, 2, batched=True), "single-node-v1", n=3, batched=True, at_once=True)
