"""No accepted setting does nothing: on every registered id, every env option, env keyword and
scenario field, set to a value other than the id's, either changes the episode (its spaces,
observations, rewards, infos or flight) or is refused at construction with a message naming it."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

from ios_uav_env import MISO_CONTROL_IDS, STAR_CONTROL_IDS, ScenarioConfig, ScenarioRanges
from ios_uav_env.envs.multi import MULTINODE_RANGES
from ios_uav_env.envs.options import EnvOptions
from ios_uav_env.model.config import SCENARIO_FIELDS

#: The flight ids (the surface control ids' UAV flies a given line and takes none of their settings;
#: their own checks: ``test_star_control.py``, ``test_miso_control.py``).
CONTROL_IDS = {*STAR_CONTROL_IDS, *MISO_CONTROL_IDS}
IDS = sorted(i for i in gym.registry if i.startswith("ios_uav_env/") and i not in CONTROL_IDS)
#: Short episodes: the fixed ids' T, and the randomised ids' families (small surfaces too).
FIXED = {"T": 40.0}
RANGES = ScenarioRanges(T=(40.0, 50.0), ios_rows=(20, 22))
MULTI_RANGES = dataclasses.replace(MULTINODE_RANGES, T=(40.0, 50.0), ios_rows=(20, 22))
NODES = ((-100.0, -20.0), (150.0, -60.0))

#: A value other than the default for every env option, env keyword and scenario field.
VALUES: dict[str, object] = {
    # EnvOptions
    "channel": "rician", "arrival_guard": False, "reach_weight": 3.0, "terminal_weight": 5.0,
    "length_scale": 300.0, "instance_features": "toggle", "peak_hint": True, "energy_reference": 2.0e4,
    "knowledge": "other", "report_sigma": 3.0, "filter_estimate": True,
    # the env classes' own keywords (RandomIOSUAVEnv, MultiNodeEnv)
    "ranges": "other", "config": "other", "focus": {"ground_x": (-150.0, 150.0)}, "focus_prob": 0.5,
    "max_nodes": 5, "share_sharpness": 2.0, "softmin_beta": 3.0, "random_nodes": (2, 3),
    # ScenarioConfig
    "surface": "ris", "T": 50.0, "dt": 0.5, "v_max": 30.0, "q0": (-400.0, 0.0), "qF": (400.0, 0.0),
    "ground_node": (-50.0, 30.0), "uav_altitude": 120.0, "ios_center": (0.0, 10.0, 40.0),
    "ios_shape": (100, 24), "epsilon": 2.0, "kappa": 5.0, "alpha": 4.0, "power_w": 0.2, "noise_dbm": -85.0,
    "wavelength": 0.06, "g_tx": 2.0, "g_rx": 2.0, "g_element": 2.0, "gamma": 0.8, "element_spacing_wl": 0.6,
    "element_size_wl": 0.4, "quadrature_nodes": 12, "quadrature_tol": 1e-300, "ground_nodes": NODES,
    "propulsion": {"P0": 60.0}, "bandwidth_hz": 2.0e6, "objective": "energy_efficiency",
    "energy_budget_j": "exceeded", "motion": "other",
    "star_protocol": "ms", "star_phases": "shared", "star_bits": 2, "star_access": "noma", "antennas": 2,
}  # fmt: skip
#: Settings that may leave an episode unchanged, and why they are still accepted.
ALLOWED = {
    # the surface's geometry is validated without a surface too (the UAV flies above the IOS's top
    # edge): a scenario of surface "none" may need it changed to take a low altitude
    ("ios_uav_env/UAV-v0", "ios_shape"): "validated geometry",
    ("ios_uav_env/UAV-v0", "element_spacing_wl"): "validated geometry",
    ("ios_uav_env/UAV-v0", "element_size_wl"): "validated geometry",
    ("ios_uav_env/UAV-v0", "wavelength"): "validated geometry (the element pitch is in wavelengths)",
    # accuracy settings of the surface sum: the default compression is already exact to rounding
    # on most flights, so a finer one can leave every float as it was (it matters where the UAV
    # comes close to a large surface)
    **{(i, name): "accuracy" for i in IDS for name in ("quadrature_nodes", "quadrature_tol")},
}


def test_every_setting_is_walked():
    fields = {f.name for f in dataclasses.fields(EnvOptions)} | SCENARIO_FIELDS
    assert fields <= set(VALUES)


def _base_kwargs(env_id: str) -> dict:
    if "NOMA" in env_id:  # (the NOMA ids' scenario is their own; the Random one draws its line only)
        return {"ios_shape": (4, 4), "score": False}
    if "SDMA" in env_id:  # (the SDMA ids' too)
        return {"ios_shape": (2, 2), "score": False}
    if "MultiNode-v0" in env_id:
        return {"T": 40.0}
    if "MultiNode" in env_id:
        return {"ranges": MULTI_RANGES}
    if "Random" in env_id or "Mobile" in env_id:
        return {"ranges": RANGES}
    return dict(FIXED)


def _value(env_id: str, name: str, default_env: gym.Env) -> object:
    """The walked value of ``name`` on ``env_id`` (other than the id's own)."""
    base = default_env.unwrapped
    value = VALUES[name]
    if value == "toggle":
        return not getattr(base.options, name)
    if name == "knowledge":
        return "exact" if base.options.knowledge != "exact" else "reports"
    if name == "motion":
        return {"kind": "gauss_markov", "speed": 3.0}
    if name == "ranges":
        return dataclasses.replace(MULTI_RANGES if "MultiNode" in env_id else RANGES, T=(40.0, 45.0))
    if name == "config":  # (T given as a keyword too: the config's other fields differ)
        if "MultiNode" in env_id:
            return ScenarioConfig(ground_nodes=((-50.0, 30.0), (150.0, -60.0)))
        return ScenarioConfig(ground_node=(-50.0, 30.0))
    if name == "energy_budget_j":  # just above the first episode's least energy: random moves exceed it
        return _first_config(default_env).least_energy() * (1.0 + 1e-6)
    if name == "surface" and base.config.surface == "ris":
        return "ios"
    if name == "star_access" and base.config.star_access == value:
        return "tdma"
    if name == "objective" and base.config.objective == value:
        return "rate"
    return value


def _first_config(env: gym.Env) -> ScenarioConfig:
    env.reset(seed=0)
    return env.unwrapped.config


def _episode(env: gym.Env) -> list:
    """Everything an episode of seeded random actions shows: spaces, observations, rewards, infos,
    the flight and its scenario."""
    base = env.unwrapped
    out = [base.observation_space.low, base.observation_space.high, np.asarray(base.action_space.shape)]
    obs, info = env.reset(seed=0)
    rng = np.random.default_rng(0)
    out += [obs, *info.values()]
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(rng.uniform(-1.0, 1.0, env.action_space.shape))
        out += [obs, np.float64(reward), *info.values()]
        done = terminated or truncated
    return [*out, base.trajectory]


def _same(a: list, b: list) -> bool:
    """Whether two episodes show the same (the scenario object itself is not compared: a field
    that changes only the config, and nothing the env shows, does nothing)."""
    if len(a) != len(b):
        return False
    pairs = zip(a, b, strict=True)
    return all(np.array_equal(np.asarray(x), np.asarray(y), equal_nan=True) for x, y in pairs)


@pytest.mark.parametrize("env_id", IDS)
def test_every_accepted_setting_changes_the_episode(env_id):
    base_kwargs = _base_kwargs(env_id)
    default_env = gym.make(env_id, **base_kwargs)
    reference = _episode(default_env)
    inert, unnamed = [], []
    for name in sorted(VALUES):
        value = _value(env_id, name, default_env)
        try:
            env = gym.make(env_id, **{**base_kwargs, name: value})
        except (TypeError, ValueError) as err:
            if name not in str(err):
                unnamed.append((name, str(err)[:200]))
            continue
        if _same(_episode(env), reference) and (env_id, name) not in ALLOWED:
            inert.append(name)
    assert not unnamed, f"refused without naming the setting: {unnamed}"
    assert not inert, f"{env_id}: accepted settings that change nothing: {inert}"
