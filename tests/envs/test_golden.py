"""Golden episodes: every registered id re-runs its recorded seeded episode, single and batched, and
gives the recorded observations, rewards, flags and infos (``tests/envs/golden/record.py`` records
them; re-record only with a reason stated in the commit).

Keys, dtypes and shapes must match exactly, as must booleans, integers, strings and the actions; float64
values to ``GOLDEN_REL`` of their key's scale and the float32 observations to
``GOLDEN_EXACT_OBS_ABS``, or ``GOLDEN_OBS_ABS`` on the ids that observe measured rates
(``tests/tolerances.py`` says why: what another CPU moves, what a regression moves).
"""

from __future__ import annotations

import json
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env  # noqa: F401  (registers the ids)
from tests.envs.golden.record import (
    GOLDEN_DIR,
    INDEX_NAME,
    golden_arrays,
    golden_names,
    has_vector,
    id_of,
    main,
    record,
    single_episode,
)
from tests.tolerances import GOLDEN_EXACT_OBS_ABS, GOLDEN_OBS_ABS, GOLDEN_REL, NORMALISATION_CHANGE

INDEX: dict[str, Any] = json.loads((GOLDEN_DIR / INDEX_NAME).read_text(encoding="utf-8"))
#: The id whose single episode the tests of the comparison perturb (a short, fixed scenario).
PAPER_ID = "ios_uav_env/IOSUAV-v0"


def _stored(env_id: str) -> dict[str, np.ndarray]:
    with np.load(GOLDEN_DIR / INDEX["ids"][env_id]["file"]) as data:
        return {key: data[key] for key in data.files}


def _part(arrays: dict[str, np.ndarray], part: str) -> dict[str, np.ndarray]:
    return {key: value for key, value in arrays.items() if key.startswith(f"{part}.")}


def observation_bound(env_id: str) -> float:
    """The largest absolute change of an observation feature that ``env_id``'s golden allows: the
    ids whose published layout holds measured (faded) rates move by up to ~1e-5 across CPUs
    (``GOLDEN_OBS_ABS``), the others by a float32 ulp (``GOLDEN_EXACT_OBS_ABS``)."""
    env = gym.make(env_id)
    try:
        names = env.unwrapped.observation_names
    finally:
        env.close()
    return GOLDEN_OBS_ABS if any("measured" in name for name in names) else GOLDEN_EXACT_OBS_ABS


def mismatches(
    stored: dict[str, np.ndarray], new: dict[str, np.ndarray], obs_bound: float = GOLDEN_EXACT_OBS_ABS
) -> list[str]:
    """What differs between a golden file's arrays and a re-run's (empty: they match); float32
    observations may move by ``obs_bound``."""
    if sorted(stored) != sorted(new):
        return [f"keys: missing {sorted(set(stored) - set(new))}, new {sorted(set(new) - set(stored))}"]
    out = []
    for key, ref in stored.items():
        value = new[key]
        if value.dtype != ref.dtype or value.shape != ref.shape:
            out.append(f"{key}: {value.dtype}{value.shape}, recorded {ref.dtype}{ref.shape}")
            continue
        if ref.dtype.kind != "f" or key.endswith(".action"):  # bool, int, str; actions are drawn exactly
            if not np.array_equal(value, ref):
                out.append(f"{key}: differs at {np.argwhere(value != ref)[:3].tolist()}")
            continue
        finite = np.isfinite(ref)
        if not np.array_equal(np.isfinite(value), finite) or not np.array_equal(
            value[~finite], ref[~finite], equal_nan=True
        ):
            out.append(f"{key}: NaN or inf elsewhere")
            continue
        gap = np.abs(value[finite].astype(np.float64) - ref[finite].astype(np.float64))
        if ref.dtype == np.float32:
            bound = obs_bound
        else:
            bound = GOLDEN_REL * max(1.0, float(np.abs(ref[finite]).max(initial=0.0)))
        if gap.size and gap.max() > bound:
            out.append(f"{key}: off by {gap.max():.3g} > {bound:.3g}")
    return out


def test_every_registered_id_has_a_golden() -> None:
    """A new id (or variant) needs its golden (python -m tests.envs.golden.record --new), a removed
    one loses its own; a variant's entry names its id."""
    assert sorted(INDEX["ids"]) == golden_names()
    for name, entry in INDEX["ids"].items():
        assert (GOLDEN_DIR / entry["file"]).is_file(), entry["file"]
        assert entry.get("id", name) == id_of(name)
        assert entry["batched"] or not has_vector(id_of(name)), f"{name}: its batched env has no golden"


@pytest.mark.parametrize("env_id", sorted(INDEX["ids"]))
def test_golden_episode(env_id: str) -> None:
    entry = INDEX["ids"][env_id]
    stored = _stored(env_id)
    batched = entry["batched"] and has_vector(id_of(env_id))  # (Gymnasium < 1.0 has no vector entry points)
    if not batched:
        stored = _part(stored, "single")
    new = golden_arrays(env_id, {**entry, "batched": batched})
    problems = mismatches(stored, new, observation_bound(id_of(env_id)))
    assert not problems, f"{env_id} ({entry['kwargs']}) left its golden episode:\n" + "\n".join(problems)


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        ({"noise_dbm": -80.0 + 0.01}, "single.reward"),  # a physics constant, slightly
        ({"length_scale": 400.0 * (1 + NORMALISATION_CHANGE)}, "single.obs"),  # a normalisation
    ],
)
def test_a_slight_regression_leaves_the_golden(change: dict[str, float], expected: str) -> None:
    """The tolerances still see a small real change (the paper's id, its recorded episode)."""
    entry = INDEX["ids"][PAPER_ID]
    assert gym.spec(PAPER_ID).kwargs == {"surface": "ios"} and entry["kwargs"] == {"T": 40.0}
    stored = _part(_stored(PAPER_ID), "single")
    assert not mismatches(stored, single_episode(PAPER_ID, entry["kwargs"], entry["seed"]))
    problems = mismatches(stored, single_episode(PAPER_ID, {**entry["kwargs"], **change}, entry["seed"]))
    assert any(problem.startswith(f"{expected}:") for problem in problems), problems


def test_the_comparison_sees_keys_dtypes_and_exact_values() -> None:
    stored = _part(_stored(PAPER_ID), "single")
    changed = dict(stored)
    del changed["single.info.rate"]  # an info key dropped
    assert mismatches(stored, changed)[0].startswith("keys:")
    rate = stored["single.info.rate"]
    for key, value in [
        ("single.info.slot", stored["single.info.slot"].astype(np.int32)),  # another dtype
        ("single.terminated", ~stored["single.terminated"]),  # a flag
        ("single.info.slot", stored["single.info.slot"] + 1),  # an integer
        ("single.obs", stored["single.obs"][:-1]),  # another shape
        ("single.action", np.nextafter(stored["single.action"], np.float32(2))),  # another action stream
        ("single.info_keys", stored["single.info_keys"][::-1]),  # the keys' order
        ("single.info.rate", np.where(np.arange(rate.size) == 3, np.nan, rate)),  # a NaN
        ("single.reward", stored["single.reward"] * (1 + 10 * GOLDEN_REL)),  # a float64 beyond the tolerance
    ]:
        assert [problem.split(":")[0] for problem in mismatches(stored, {**stored, key: value})] == [key]


def test_the_recorder_refuses_to_overwrite_goldens(tmp_path, capsys) -> None:
    (tmp_path / INDEX_NAME).write_text("{}", encoding="utf-8")
    with pytest.raises(FileExistsError, match="--overwrite"):
        record(tmp_path)
    assert main(["--out", str(tmp_path)]) == 1
    assert "--overwrite" in capsys.readouterr().err
    assert sorted(path.name for path in tmp_path.iterdir()) == [INDEX_NAME]
    assert (tmp_path / INDEX_NAME).read_text(encoding="utf-8") == "{}"


def test_only_the_ids_that_observe_measured_rates_get_the_looser_observation_bound() -> None:
    bounds = {env_id: observation_bound(id_of(env_id)) for env_id in INDEX["ids"]}
    loose = sorted(env_id for env_id, bound in bounds.items() if bound == GOLDEN_OBS_ABS)
    assert loose == ["ios_uav_env/IOSUAV-Mobile-v0", "ios_uav_env/IOSUAV-MultiNode-Mobile-v0"], loose
    assert bounds[PAPER_ID] == GOLDEN_EXACT_OBS_ABS < GOLDEN_OBS_ABS


@pytest.mark.parametrize("new_id", ["ios_uav_env/STARUAV-v0", "ios_uav_env/STARUAV-v0+star_bits=2"])
def test_the_recorder_adds_only_the_ids_its_index_lacks(tmp_path, capsys, new_id) -> None:
    """``--new``: the index without one id (or variant) gets its golden and entry (the shipped
    ones), and nothing else is written; another machine's versions are refused before anything runs."""
    shipped = json.loads((GOLDEN_DIR / INDEX_NAME).read_text(encoding="utf-8"))
    lacking = {**shipped, "ids": {i: e for i, e in shipped["ids"].items() if i != new_id}}
    (tmp_path / INDEX_NAME).write_text(json.dumps(lacking), encoding="utf-8")
    assert main(["--new", "--out", str(tmp_path)]) == 0
    assert json.loads((tmp_path / INDEX_NAME).read_text(encoding="utf-8")) == shipped
    written = sorted(path.name for path in tmp_path.iterdir())
    assert written == sorted([INDEX_NAME, shipped["ids"][new_id]["file"]])
    with np.load(tmp_path / shipped["ids"][new_id]["file"]) as data:
        assert not mismatches(_stored(new_id), {key: data[key] for key in data.files})
    other = {**lacking, "versions": {**shipped["versions"], "numpy": "0.0"}}
    (tmp_path / INDEX_NAME).write_text(json.dumps(other), encoding="utf-8")
    (tmp_path / shipped["ids"][new_id]["file"]).unlink()
    assert main(["--new", "--out", str(tmp_path)]) == 1
    assert "recorded with" in capsys.readouterr().err and len(list(tmp_path.iterdir())) == 1
