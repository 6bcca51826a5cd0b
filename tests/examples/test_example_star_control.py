"""examples/star_control_ppo.py: PPO setting the STAR surface, its table of % of the per-slot optimum."""

import re

from conftest import require


def test_star_control_ppo_prints_its_table(run_example, tmp_path):
    require("stable_baselines3", "torch", "matplotlib")
    figure = tmp_path / "mxb.png"
    out = run_example("star_control_ppo.py", "--elements", "16", "--bits", "none", "1", "--steps", "512",
                      "--episodes", "1", "--control", "direct", "residual", "--imitate", "1",
                      "--plot", str(figure))  # fmt: skip
    assert figure.stat().st_size > 1000 and f"figure: {figure}" in out
    number = r"\s+([0-9.]+)"
    rows = re.findall(rf"^\s+16\s+(none|1)\s+(direct|residual)\s+0{number * 6}\s+\d+$", out, re.M)
    assert [row[:2] for row in rows] == [(b, c) for b in ("none", "1") for c in ("direct", "residual")], out
    for bits, _, ppo, imitated, zero, random, quantised, grid in rows:
        assert 0 < float(ppo) <= 100 and 0 < float(imitated) <= 100 and 0 < float(random) < 100, out
        if (
            bits == "none"
        ):  # continuous phases: nothing to round, no grid loss; the residual's zero is the optimum
            assert float(quantised) == 100.0 and float(grid) == 100.0 and float(zero) == 100.0, out
        else:  # rounded phases fall short of the exact b-bit optimum, which falls short of continuous
            assert float(quantised) <= 100.0 and float(grid) < 100.0 and float(zero) < 100.0, out


def test_star_control_ppo_never_overwrites_a_figure(tmp_path):
    import subprocess
    import sys

    from conftest import EXAMPLES, ROOT

    require("stable_baselines3", "torch")
    figure = tmp_path / "taken.png"
    figure.write_bytes(b"not ours")
    proc = subprocess.run([sys.executable, str(EXAMPLES / "star_control_ppo.py"), "--plot", str(figure)],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)  # fmt: skip
    assert proc.returncode == 2 and "exists" in proc.stderr and figure.read_bytes() == b"not ours"


def test_the_element_actor_is_shared_by_the_groups(run_example):
    """Swapping two groups' phase features swaps their actions and nothing else; the share reads
    the head only; and the script runs with it."""
    require("stable_baselines3", "torch")
    import importlib.util

    import torch
    from conftest import EXAMPLES

    spec = importlib.util.spec_from_file_location("star_control_ppo", EXAMPLES / "star_control_ppo.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    g = 16
    actor = module.ElementExtractor(module.HEAD + 2 * g)
    x = torch.rand(3, module.HEAD + 2 * g) * 2 - 1
    swapped = x.clone()
    for side in (0, g):  # groups 3 and 5, both sides
        a, b = module.HEAD + side + 3, module.HEAD + side + 5
        swapped[:, [a, b]] = x[:, [b, a]]
    out, new = actor.forward_actor(x).detach(), actor.forward_actor(swapped).detach()
    order = list(range(2 * g + 1))
    for side in (0, g):
        order[side + 3], order[side + 5] = side + 5, side + 3
    assert out.shape == (3, 2 * g + 1) and torch.equal(new, out[:, order]) and not torch.equal(new, out)
    text = run_example("star_control_ppo.py", "--elements", "16", "--bits", "none", "--steps", "256",
                       "--episodes", "1", "--control", "residual", "--policy", "element")  # fmt: skip
    assert re.search(r"^\s+16\s+none\s+residual\s+0\s+[0-9.]+\s+-\s+100.0\s", text, re.M), text


def test_the_residual_figure_is_drawn_by_one_command(run_example, tmp_path):
    """examples/star_control_figure.py runs the attempt (every M and b at the first seed, the
    smallest M at every seed) and writes the figure; at a tiny budget here."""
    require("stable_baselines3", "torch", "matplotlib")
    figure = tmp_path / "residual.png"
    out = run_example("star_control_figure.py", "--out", str(figure), "--elements", "16", "64", "--bits",
                      "none", "--steps", "256", "--episodes", "1", "--seeds", "0", "1")  # fmt: skip
    assert figure.stat().st_size > 1000 and f"figure: {figure}" in out
    runs = re.findall(r"^\s+(16|64)\s+none\s+(direct|residual)\s+(\d)\s", out, re.M)
    expected = [("16", c, s) for c in ("direct", "residual") for s in "01"]
    assert runs == expected + [("64", "direct", "0"), ("64", "residual", "0")], out
