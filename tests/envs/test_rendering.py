"""Rendering (ios_uav_env/envs/rendering.py and IOSUAVEnv.render): frames, the plot helpers of
ios_uav_env/plotting.py, lazy import."""

from __future__ import annotations

import pickle
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from ios_uav_env import ScenarioConfig, slot_rates
from ios_uav_env.envs.rendering import (
    FrameRenderer,
    default_extent,
    plot_rate_map,
    plot_trajectories,
    rate_grid,
    save_png,
)
from ios_uav_env.envs.single import IOSUAVEnv

pytest.importorskip("matplotlib")
CONFIG = ScenarioConfig()


def distinct_colours(frame: np.ndarray) -> int:
    return len(np.unique(frame.reshape(-1, 3), axis=0))


def test_render_returns_a_non_blank_rgb_frame_that_shows_the_trajectory():
    env = IOSUAVEnv(render_mode="rgb_array")
    env.reset(seed=0)
    first = env.render()
    for _ in range(30):
        env.step(np.array([1.0, 0.3], dtype=np.float32))
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert frame.shape == first.shape and frame.shape[0] > 100 and frame.shape[1] > 100
    assert distinct_colours(frame) > 50  # the rate map's colour scale, markers, text
    assert (frame != first).any(axis=2).mean() > 0.002  # the trajectory (and title) changed pixels
    env.close()


def test_check_env_with_rendering_without_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make("ios_uav_env/RISUAV-v0", render_mode="rgb_array").unwrapped)


def test_render_without_render_mode_warns_and_returns_none():
    env = IOSUAVEnv()
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="render_mode"):
        assert env.render() is None


def test_env_pickles_after_rendering():
    env = IOSUAVEnv(render_mode="rgb_array")
    env.reset(seed=0)
    env.step(np.zeros(2, dtype=np.float32))
    env.render()
    clone = pickle.loads(pickle.dumps(env))
    assert clone.render().shape == env.render().shape


def test_rate_grid_is_the_models_rate_cached_and_read_only():
    extent = (-200.0, 200.0, -100.0, 100.0)
    xs, ys, rates = rate_grid(CONFIG, extent, (41, 21))
    assert rates.shape == (21, 41) and xs[0] == -200.0 and ys[-1] == 100.0
    assert rates[3, 7] == slot_rates(CONFIG, np.array([xs[7], ys[3]]))[0]
    assert rate_grid(CONFIG, extent, (41, 21))[2] is rates
    with pytest.raises(ValueError):
        rates[0, 0] = 1.0


def test_default_extent_covers_the_scene():
    x0, x1, y0, y1 = default_extent(CONFIG)
    for x, y in (CONFIG.q0, CONFIG.qF, CONFIG.ground_node, CONFIG.ios_center[:2]):
        assert x0 < x < x1 and y0 < y < y1
    assert (y1 - y0) >= 0.5 * (x1 - x0) - 1e-9


def test_plot_helpers_draw_on_a_given_axes():
    from matplotlib.figure import Figure

    fig = Figure()
    ax = fig.add_subplot()
    image = plot_rate_map(ax, CONFIG, resolution=(60, 30))
    assert image.get_array().shape == (30, 60)
    line = np.linspace(CONFIG.q0, CONFIG.qF, CONFIG.N)
    lines = plot_trajectories(ax, CONFIG, {"straight": line, "start": line[:10]})
    assert [ln.get_label() for ln in lines] == ["straight", "start"]
    assert np.array_equal(lines[0].get_xydata(), line)
    assert ax.get_legend() is not None


def test_frame_renderer_and_png(tmp_path):
    renderer = FrameRenderer(ScenarioConfig(surface="none"), size=(320, 200))
    frame = renderer.frame(np.array([CONFIG.q0, (0.0, 0.0)]), title="two points")
    assert frame.shape == (200, 320, 3) and distinct_colours(frame) > 20
    full = save_png(frame, tmp_path / "a" / "full.png")
    small = save_png(frame, tmp_path / "small.png", colors=64)
    assert full.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and small.stat().st_size < full.stat().st_size
    renderer.close()


def test_a_png_is_written_atomically(tmp_path, monkeypatch):
    """An interrupted save (the rename fails) leaves the previous file whole and no temp file."""
    import os

    frame = np.zeros((20, 30, 3), dtype=np.uint8)
    path = save_png(frame, tmp_path / "frame.png")
    before = path.read_bytes()

    def fail(*args, **kwargs):
        raise OSError("interrupted")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OSError, match="interrupted"):
        save_png(np.full((20, 30, 3), 255, dtype=np.uint8), path)
    assert path.read_bytes() == before and [p.name for p in tmp_path.iterdir()] == ["frame.png"]


def test_missing_matplotlib_says_what_to_install(monkeypatch):
    for name in ("matplotlib", "matplotlib.figure", "matplotlib.backends", "matplotlib.backends.backend_agg"):
        monkeypatch.setitem(sys.modules, name, None)
    env = IOSUAVEnv(render_mode="rgb_array")
    env.reset(seed=0)
    with pytest.raises(ImportError, match=r"pip install ios-uav-env\[render\]"):
        env.render()


def test_importing_the_env_does_not_import_matplotlib():
    code = (
        "import sys, ios_uav_env, ios_uav_env.plotting, ios_uav_env.envs.rendering\n"
        "import ios_uav_env.envs.rendering_multi\n"
        "print('matplotlib' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


def test_the_envs_renderers_draw_with_the_plotting_modules_helpers():
    import ios_uav_env.envs.rendering as rendering
    import ios_uav_env.envs.rendering_multi as rendering_multi
    import ios_uav_env.plotting as plotting

    for module in (rendering, rendering_multi):
        for name in module.__all__:
            if name != "FrameRenderer":  # the env's own frame, drawn with those helpers
                assert getattr(module, name) is getattr(plotting, name), (module.__name__, name)
