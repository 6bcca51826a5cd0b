"""examples/miso_control_ppo.py: PPO setting the beams and phases, its table against the per-slot AO
and the certified bound."""

import re

from conftest import require


def test_miso_control_ppo_prints_its_table(run_example, tmp_path):
    require("stable_baselines3", "torch", "matplotlib")
    figure = tmp_path / "miso.png"
    out = run_example("miso_control_ppo.py", "--antennas", "2", "--users", "2", "--elements", "16", "--steps",
                      "512", "--episodes", "1", "--plot", str(figure))  # fmt: skip
    assert figure.stat().st_size > 1000 and f"figure: {figure}" in out
    rows = re.findall(r"^\s+2\s+2\s+16\s+" + r"([0-9.]+)\s+" * 6 + r"\d+\s+\d+$", out, re.M)
    assert len(rows) == 1, out
    ppo, ppo_bound, mrt, zf, random, ao_bound = (float(v) for v in rows[0])
    assert 0 < ppo_bound < ppo and 0 < random, out  # the bound is above the AO value
    assert ppo_bound <= 100 and ao_bound <= 100, out  # certified: no setting beats the bound
    assert 0 < mrt <= 100 and 0 < zf <= 100, out  # AO starts from MRT and ZF with aligned phases


def test_miso_control_ppo_never_overwrites_a_figure(tmp_path):
    import subprocess
    import sys

    from conftest import EXAMPLES, ROOT

    require("stable_baselines3", "torch")
    figure = tmp_path / "taken.png"
    figure.write_bytes(b"not ours")
    proc = subprocess.run([sys.executable, str(EXAMPLES / "miso_control_ppo.py"), "--plot", str(figure)],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)  # fmt: skip
    assert proc.returncode == 2 and "exists" in proc.stderr and figure.read_bytes() == b"not ours"
