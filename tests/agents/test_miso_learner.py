"""agents.miso_learner: the observation's channel, the structured setting, the weights file and the
trainer."""

from __future__ import annotations

import json

import numpy as np
import pytest

from agents.miso_learner import NET_IN, NET_OUT, MisoLearner, estimated_rows, layout, setting, view
from ios_uav_env.benchmark.miso_suite import MisoTask
from ios_uav_env.envs.miso_control import MISOControlEnv
from ios_uav_env.model.miso import mrt_beams, zf_beams

#: Every (N_t, K, M_side) of miso-v1.
SHAPES = [(n_t, k, side) for n_t in (2, 4, 8) for k in (2, 4) for side in (4, 8)]


def _task(n_t: int, k: int, side: int, objective: str = "sum") -> tuple[MISOControlEnv, MisoTask]:
    env = MISOControlEnv(antennas=n_t, users=k, elements=(side, side), objective=objective, optimum=False)
    miso = dict(antennas=n_t, users=k, elements=[side, side], objective=objective)
    return env, MisoTask.of(miso, env)


def _write(folder, rng: np.random.Generator | None = None, width: int = 8) -> None:
    """A model folder: a zero last layer (rng None) or random weights."""
    rng_ = rng or np.random.default_rng(0)
    arrays = {}
    for j, (a, b) in enumerate(((NET_IN, width), (width, width), (width, NET_OUT))):
        arrays[f"user_w{j}"] = np.zeros((a, b)) if rng is None and j == 2 else rng_.normal(size=(a, b))
        arrays[f"user_b{j}"] = np.zeros(b)
    folder.mkdir(parents=True, exist_ok=True)
    np.savez(folder / "weights.npz", **arrays)
    (folder / "config.json").write_text(json.dumps({"trainer": "test"}), encoding="utf-8")


@pytest.mark.parametrize("n_t, k, side", SHAPES)
def test_the_observation_gives_the_channel_up_to_one_scale(n_t, k, side):
    """H-hat of any phases is the env's H(psi) over one positive scale (the SNR the observation
    lacks), to the equal-amplitude assumption's ~1 % and the float32 observation."""
    env, task = _task(n_t, k, side)
    obs, _ = env.reset(seed=11)
    rng = np.random.default_rng(0)
    for n in (0, 9):
        psi = rng.uniform(0, 2 * np.pi, env.M)
        rows = estimated_rows(view(obs[None], task, layout(task)), np.exp(-1j * psi)[None])[0]
        H = env.channels[n].matrix(psi)
        scale = np.linalg.norm(H) / np.linalg.norm(rows)
        assert np.abs(H - scale * rows).max() <= 1e-3 * np.abs(H).max()
        for _ in range(9 - n):
            obs = env.step(np.zeros(env.action_space.shape))[0]


def test_the_family_holds_mrt_and_zf_and_spends_the_power():
    """q -> 0 gives MRT on H-hat, large equal q the ZF directions (N_t >= K); every setting has
    total power 1 and its phases are the weighted user's aligned ones when one weight dominates."""
    env, task = _task(4, 2, 4)
    obs, _ = env.reset(seed=5)
    v = view(obs[None], task, layout(task))
    for z, reference in ((-40.0, mrt_beams), (25.0, zf_beams)):
        out = np.zeros((1, 2, 3))
        out[..., 0] = z
        out[0, 1, 2] = 30.0  # user 1's aligned phases
        phasor, beams = setting(out, v)
        np.testing.assert_allclose(np.angle(phasor[0] * v.aligned[0, 1]), 0.0, atol=1e-9)
        H = estimated_rows(v, phasor)[0]
        expected = reference(H) * np.sqrt(2)  # unit columns, equal powers 1 / 2
        overlap = np.abs(np.sum(beams[0].conj() * expected, axis=0))  # |<w_k, unit reference beam k>|
        np.testing.assert_allclose(overlap, 1 / np.sqrt(2), rtol=1e-6)
        assert np.sum(np.abs(beams) ** 2) == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize("n_t, k, side", SHAPES)
def test_the_action_is_valid_for_every_setting_of_the_suite(tmp_path, n_t, k, side):
    """The shipped and a random model: a finite action in the box, of the env's shape, that the env
    maps back to the policy's beams (full power) and pays a positive reward."""
    _write(tmp_path / "random", np.random.default_rng(3))
    for objective in ("sum", "maxmin"):
        env, task = _task(n_t, k, side, objective)
        for learner in (MisoLearner().bind(task), MisoLearner(tmp_path / "random").bind(task)):
            obs, _ = env.reset(seed=2)
            for _ in range(3):
                action = learner(obs)
                assert action.shape == env.action_space.shape and np.all(np.isfinite(action))
                assert np.all(np.abs(action) <= 1.0)
                _, beams = env.setting(action)
                assert np.sum(np.abs(beams) ** 2) == pytest.approx(1.0, rel=1e-12)
                obs, reward, *_ = env.step(action)
                assert reward > 0


def test_bad_folders_and_layouts_are_refused_by_name(tmp_path):
    with pytest.raises(ValueError, match="weights.npz: no such file"):
        MisoLearner(tmp_path / "none")
    _write(tmp_path / "bare")
    (tmp_path / "bare" / "config.json").unlink()
    with pytest.raises(ValueError, match="config.json: no such file"):
        MisoLearner(tmp_path / "bare")
    _write(tmp_path / "bad")
    with np.load(tmp_path / "bad" / "weights.npz") as data:
        arrays = dict(data)
    arrays["user_w2"] = np.zeros((8, NET_OUT + 1))
    np.savez(tmp_path / "bad" / "weights.npz", **arrays)
    with pytest.raises(ValueError, match=rf"user_w0.. must be layers from {NET_IN} to {NET_OUT}"):
        MisoLearner(tmp_path / "bad")
    _write(tmp_path / "zero")
    env, task = _task(2, 2, 4)
    names = tuple(name.replace("miso_gain_share_1", "other") for name in task.observation_names)
    with pytest.raises(ValueError, match="'miso_gain_share_1' is not among"):
        MisoLearner(tmp_path / "zero").bind(MisoTask(2, 2, (4, 4), "sum", names, task.action_dim))
    with pytest.raises(ValueError, match="unbound"):
        MisoLearner(tmp_path / "zero")(np.zeros(len(names)))


def test_the_trainer_pays_the_env_reward_and_writes_a_model_it_keeps(tmp_path, capsys, one_torch_thread):
    """Two steps on one episode a setting: the model is written, the numpy learner plays it, the
    trainer's differentiable value of its setting is the env's reward, and a model is not replaced
    without --overwrite."""
    import torch

    from agents import miso_training

    out = tmp_path / "model"
    argv = ["--out", str(out), "--iterations", "2", "--episodes", "1", "--no-progress"]
    assert miso_training.main(argv) == out
    config = json.loads((out / "config.json").read_text())
    assert config["command"].startswith("python -m agents.miso_training --out") and config["settings"] == 24
    assert (
        set(config["pct_of_bound"]) == {"start", "equal powers", "end"}
        and "model: " in capsys.readouterr().out
    )
    with pytest.raises(SystemExit):
        miso_training.main(argv)
    assert "--overwrite" in capsys.readouterr().err
    _write(out, np.random.default_rng(4))  # random weights: the outputs are far from zero
    kwargs = dict(antennas=8, users=4, elements=(8, 8), objective="maxmin")
    pool = miso_training.make_pool(0, kwargs, 1, set())
    env, task = _task(8, 4, 8, "maxmin")
    learner = MisoLearner(out).bind(task)
    inputs, v, channels = pool.tensors()
    net = miso_training.network(8)
    for j, layer in enumerate(m for m in net if isinstance(m, torch.nn.Linear)):
        layer.weight.data = torch.from_numpy(learner.layers[j][0].T.copy())
        layer.bias.data = torch.from_numpy(learner.layers[j][1].copy())
    with torch.no_grad():
        values = miso_training.slot_values(channels, *setting(net(inputs), v, torch), "maxmin").numpy()
    obs, _ = env.reset(seed=miso_training.TRAIN_SEED)
    for n in range(4):
        obs, reward, *_ = env.step(learner(obs))
        assert reward == pytest.approx(values[n], rel=1e-9)


@pytest.mark.parametrize("argv, message", [
    (["--iterations", "0"], "--iterations must be >= 1"),
    (["--episodes", "0"], "--episodes must be >= 1"),
    (["--seed", "-1"], "--seed must be >= 0"),
])  # fmt: skip
def test_the_trainer_refuses_bad_arguments(tmp_path, capsys, argv, message):
    from agents import miso_training

    with pytest.raises(SystemExit):
        miso_training.main(["--out", str(tmp_path), *argv])
    assert message in capsys.readouterr().err
