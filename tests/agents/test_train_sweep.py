"""python -m agents.sweep on the local backend: trials, overrides, resume (the Ray side is in
tests/baselines/test_ray_backend.py)."""

from __future__ import annotations

import json

import pytest

from agents import sweep

TINY = {"n_envs": [2], "n_steps": [64], "batch_size": [64], "n_epochs": [1]}


def test_overrides_and_trials():
    overrides = sweep.parse_overrides(
        ["learning_rate=1e-4", "learning_rate=3e-4", "n_epochs=5", "n_epochs=5"]
    )
    assert overrides == {"learning_rate": [1e-4, 3e-4], "n_epochs": [5]}
    trials = sweep.make_trials(["ppo", "sac"], ["ios_uav_env/IOSUAV-v0"], [0, 1, 1], overrides)
    assert len(trials) == 2 * 2 * 2  # algos x learning rates x seeds (the repeated seed once)
    assert trials[0].name == "IOSUAV-v0__ppo__seed0__learning_rate-0.0001__n_epochs-5"
    assert sweep.Trial.from_dict(trials[0].to_dict()) == trials[0]
    with pytest.raises(ValueError, match="KEY=VALUE"):
        sweep.parse_overrides(["learning_rate"])


def test_cli_checks_before_training(tmp_path, capsys):
    base = ["--timesteps", "64", "--out", str(tmp_path / "s")]
    with pytest.raises(SystemExit):
        sweep.main([*base, "--set", "n_steps=-3"])
    assert "argument --set" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        sweep.main([*base, "--address", "127.0.0.1:6379"])
    assert "needs --backend ray" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        sweep.main([*base, "--env", "ios_uav_env/Nope-v0"])
    assert "argument --env" in capsys.readouterr().err
    assert not (tmp_path / "s" / "runs").exists()


def test_sweep_resumes_and_extends(tmp_path):
    trials = sweep.make_trials(["ppo"], ["ios_uav_env/IOSUAV-v0"], [0], TINY)
    first = sweep.run_sweep(trials, tmp_path, timesteps=128, eval_freq=0, jobs=1, progress=False)
    assert first[0]["steps"] == 128 and first[0]["pct_of_dp"] > 0
    run_dir = tmp_path / first[0]["run_dir"]
    assert (tmp_path / "hyperparams" / f"{trials[0].name}.yml").exists()
    # a larger total: the finished run goes on from its checkpoint (a resume, same folder)
    longer = sweep.run_sweep(trials, tmp_path, timesteps=256, eval_freq=0, jobs=1, progress=False)
    assert longer[0]["steps"] == 256
    assert json.loads((run_dir / "config.json").read_text())["resumes"][0]["from_steps"] == 128
    # finished: read back, nothing trained
    again = sweep.run_sweep(trials, tmp_path, timesteps=256, eval_freq=0, jobs=1, progress=False)
    assert again == longer
    path = sweep.write_csv(again, tmp_path / "sweep.csv")
    assert path.read_text().splitlines()[0].split(",") == list(sweep.CSV_COLUMNS)


def test_every_fixed_id_has_the_dp_scheme_of_its_surface():
    """``DP_SCHEME`` maps each fixed id to the DP scheme on its surface; the shipped sweep holds the
    paper's three (the STAR id's ``dp-sta`` has no row: no % of DP, rather than another surface's)."""
    import ios_uav_env
    from baselines.schemes import get_scheme

    assert set(sweep.DP_SCHEME) == set(ios_uav_env.ENV_IDS)
    for env_id, scheme in sweep.DP_SCHEME.items():
        assert get_scheme(scheme).planner == "dp"
        assert get_scheme(scheme).surface == ios_uav_env.ENV_IDS[env_id]["surface"]
    assert sweep.dp_rate("ios_uav_env/IOSUAV-v0", {}) == pytest.approx(2.404, abs=1e-3)
    assert sweep.dp_rate("ios_uav_env/STARUAV-v0", {}) is None
