"""Golden episodes of every registered env id: the recorder (the comparison: ``tests/envs/test_golden.py``).

Run it from the repository root, as a module (``tests`` is a namespace package there)::

    python -m tests.envs.golden.record              # refuses to replace existing goldens
    python -m tests.envs.golden.record --new        # only the ids the index lacks (a new id)
    python -m tests.envs.golden.record --overwrite  # re-record (say why in the commit)

``--new`` records the ids registered (and the variants) but not in ``index.json`` and adds their
entries, leaving every other file and entry as it is; it refuses when this machine's versions
(:func:`versions`) are not the index's, which the index states for every golden.

For every id registered on ``import ios_uav_env`` it records, in one ``<id>.npz`` file
(``np.savez_compressed``; the id's ``/`` written ``__``):

- ``single.*``: one episode of ``gym.make(id, **kwargs)`` from ``reset(seed=SEED)`` to its end,
  its actions drawn uniformly over the action space by a separate ``np.random.default_rng(SEED)``
  (away from the heuristic policies' paths);
- ``batched.*`` (ids with a vector entry point, Gymnasium >= 1.0): ``gym.make_vec(id, num_envs=3,
  vectorization_mode="vector_entry_point", **kwargs)`` from ``reset(seed=SEED)`` (row i seeded
  ``SEED + i``), actions drawn the same way for the whole batch, stepped until every row has ended
  an episode and then ``EXTRA_STEPS`` more (so at least one row is autoreset and runs on).

``kwargs`` is ``{"T": SHORT_T}`` (a short mission, a small file) where the id takes ``T``, the
episode does run on it and the id's own mission is longer, else ``{}``: every other setting is the
id's default (an index entry keeps the kwargs it was recorded with). A *variant*
(:data:`VARIANTS`) is an id run with keywords of its own on top (a form its defaults do not run,
e.g. b-bit phases): a golden of its own, named ``<id>+<key>=<value>``, whose index entry names the
id (``"id"``); ``--new`` records a variant the index lacks as it records a new id. Each part holds the
observations (the reset's first), actions, rewards, terminated and truncated flags, and every
``info`` key (``<part>.info.<key>``, stacked over the reset and the steps), all with the dtypes
the env produced; a non-numeric value is stored as its ``repr``. ``<part>.info_keys`` is the list
of ``info``'s keys in order and ``<part>.kinds`` says what Python type each output was (a Python
scalar, a numpy scalar or an array). ``index.json`` lists the ids, their files and kwargs, and the
numpy, Gymnasium and Python versions that recorded them. Every file is written atomically.
"""

from __future__ import annotations

import argparse
import io
import json
import platform
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import ios_uav_env
from ios_uav_env.io import atomic_write_bytes, atomic_write_text

#: The folder of the shipped goldens (this module's).
GOLDEN_DIR = Path(__file__).resolve().parent
#: The index of the goldens in a folder.
INDEX_NAME = "index.json"
#: The seed of every reset and of the action draws.
SEED = 7
#: T (s) of the ids that take it: 39 moves, 32 of which the 800 m flight q0 -> qF needs.
SHORT_T = 40.0
#: Rows of the batched episode.
NUM_ENVS = 3
#: Steps of the batch after every row has ended one episode.
EXTRA_STEPS = 2
#: No episode of a registered id is longer (a safety stop of the loops).
MAX_STEPS = 1000
#: The parts of a golden file.
PARTS = ("single", "batched")


#: The variants' goldens: name -> (the id, its keywords besides the id's ``golden_kwargs``).
VARIANTS: dict[str, tuple[str, dict[str, Any]]] = {
    "ios_uav_env/STARUAV-v0+star_bits=2": ("ios_uav_env/STARUAV-v0", {"star_bits": 2}),
    "ios_uav_env/MISOControl-v0+channel=rician": ("ios_uav_env/MISOControl-v0", {"channel": "rician"}),
    "ios_uav_env/MISOControl-v0+channel=rician_element": (
        "ios_uav_env/MISOControl-v0",
        {"channel": "rician_element"},
    ),
}


def registered_ids() -> list[str]:
    """Every env id the package registers, sorted."""
    return sorted(env_id for env_id in gym.registry if env_id.startswith("ios_uav_env/"))


def golden_names() -> list[str]:
    """The name of every golden: each registered id and each variant of one, sorted."""
    ids = registered_ids()
    return sorted([*ids, *(name for name, (env_id, _) in VARIANTS.items() if env_id in ids)])


def id_of(name: str) -> str:
    """The env id a golden ``name`` runs (a variant's id, or the name itself)."""
    return VARIANTS[name][0] if name in VARIANTS else name


def file_name(name: str) -> str:
    """The golden file of the golden ``name`` (an id or a variant)."""
    return name.replace("/", "__") + ".npz"


def has_vector(env_id: str) -> bool:
    """Whether ``env_id`` names a natively batched env that this Gymnasium can make."""
    return getattr(gym.spec(env_id), "vector_entry_point", None) is not None


def golden_kwargs(env_id: str) -> dict[str, Any]:
    """``{"T": SHORT_T}`` if ``env_id`` takes ``T``, its episode runs on it and its own mission is
    longer, else ``{}`` (an id whose default mission is already short keeps it)."""
    try:
        env = gym.make(env_id, T=SHORT_T)
    except (TypeError, ValueError):
        return {}
    try:
        env.reset(seed=SEED)
        if env.unwrapped.config.T != SHORT_T:
            return {}
    finally:
        env.close()
    default = gym.make(env_id)
    try:
        default.reset(seed=SEED)
        return {"T": SHORT_T} if default.unwrapped.config.T > SHORT_T else {}
    finally:
        default.close()


def _kind(value: Any) -> str:
    """What Python type ``value`` is, in words that do not depend on the numpy version."""
    if isinstance(value, np.ndarray):
        return "ndarray"
    if isinstance(value, np.generic):
        return "numpy-scalar"
    return f"python-{type(value).__name__}"


def _as_array(value: Any) -> np.ndarray:
    """``value`` as an array of its own dtype; a non-numeric value as its ``repr``."""
    array = np.asarray(value)
    return array if array.dtype.kind in "biufc" else np.asarray(repr(value))


class _Recorder:
    """The outputs of one episode, step by step, stacked into named arrays by :meth:`arrays`."""

    def __init__(self, part: str) -> None:
        self.part = part
        self.columns: dict[str, list[np.ndarray]] = {}
        self.kinds: dict[str, str] = {}
        self.info_keys: list[str] | None = None

    def _add(self, name: str, value: Any) -> None:
        kind = self.kinds.setdefault(name, _kind(value))
        if kind != _kind(value):
            raise TypeError(f"{self.part} {name}: a {_kind(value)} after a {kind}")
        self.columns.setdefault(name, []).append(_as_array(value).copy())

    def _info(self, info: dict[str, Any]) -> None:
        keys = list(info)
        if self.info_keys is None:
            self.info_keys = keys
        elif keys != self.info_keys:
            raise KeyError(f"{self.part} info keys changed from {self.info_keys} to {keys}")
        for key in keys:
            self._add(f"info.{key}", info[key])

    def reset(self, obs: Any, info: dict[str, Any]) -> None:
        self._add("obs", obs)
        self._info(info)

    def step(self, action: Any, result: tuple[Any, Any, Any, Any, dict[str, Any]]) -> None:
        obs, reward, terminated, truncated, info = result
        self._add("action", action)
        self._add("obs", obs)
        self._add("reward", reward)
        self._add("terminated", terminated)
        self._add("truncated", truncated)
        self._info(info)

    def arrays(self) -> dict[str, np.ndarray]:
        out = {f"{self.part}.{name}": np.stack(values) for name, values in self.columns.items()}
        out[f"{self.part}.info_keys"] = np.array(self.info_keys or [], dtype=str)
        kinds = [f"{name}={kind}" for name, kind in self.kinds.items()]
        out[f"{self.part}.kinds"] = np.array(kinds, dtype=str)
        return out


def _draw(rng: np.random.Generator, space: gym.spaces.Box) -> np.ndarray:
    """An action uniform over the box ``space`` (float64 draws, then the space's dtype)."""
    return rng.uniform(space.low, space.high).astype(space.dtype)


def single_episode(env_id: str, kwargs: dict[str, Any], seed: int = SEED) -> dict[str, np.ndarray]:
    """The ``single.*`` arrays of one seeded episode of ``gym.make(env_id, **kwargs)``."""
    env = gym.make(env_id, **kwargs)
    rec = _Recorder("single")
    rng = np.random.default_rng(seed)
    try:
        rec.reset(*env.reset(seed=seed))
        for _ in range(MAX_STEPS):
            action = _draw(rng, env.action_space)
            result = env.step(action)
            rec.step(action, result)
            if result[2] or result[3]:
                return rec.arrays()
    finally:
        env.close()
    raise RuntimeError(f"{env_id}: no end in {MAX_STEPS} steps")


def batched_episode(
    env_id: str, kwargs: dict[str, Any], seed: int = SEED, num_envs: int = NUM_ENVS
) -> dict[str, np.ndarray]:
    """The ``batched.*`` arrays of ``num_envs`` seeded rows of ``env_id``'s batched env, stepped
    until every row has ended once, then ``EXTRA_STEPS`` more."""
    vec = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs)
    rec = _Recorder("batched")
    rng = np.random.default_rng(seed)
    ended = np.zeros(num_envs, dtype=bool)
    extra = 0
    try:
        rec.reset(*vec.reset(seed=seed))
        for _ in range(MAX_STEPS):
            action = _draw(rng, vec.action_space)
            result = vec.step(action)
            rec.step(action, result)
            extra += bool(ended.all())
            ended |= np.asarray(result[2]) | np.asarray(result[3])
            if extra == EXTRA_STEPS:
                return rec.arrays()
    finally:
        vec.close()
    raise RuntimeError(f"{env_id}: the batch did not end in {MAX_STEPS} steps")


def golden_arrays(name: str, entry: dict[str, Any]) -> dict[str, np.ndarray]:
    """Every array of the golden ``name``'s file for its ``index.json`` entry (a variant's runs its
    entry's ``id``)."""
    env_id = entry.get("id", name)
    arrays = single_episode(env_id, entry["kwargs"], entry["seed"])
    if entry["batched"]:
        arrays.update(batched_episode(env_id, entry["kwargs"], entry["seed"], entry["num_envs"]))
    return arrays


def versions() -> dict[str, str]:
    """The versions of the libraries that produce an episode's numbers."""
    out = {"python": platform.python_version(), "numpy": np.__version__, "gymnasium": gym.__version__}
    try:
        import numba

        out["numba"] = numba.__version__
    except ImportError:
        out["numba"] = "none"
    return out


def _entry(name: str) -> dict[str, Any]:
    """The ``index.json`` entry of the golden ``name`` (its file, seed, kwargs and batch; a variant's
    its id too)."""
    env_id, extra = VARIANTS.get(name, (name, {}))
    kwargs = {**golden_kwargs(env_id), **extra}
    entry: dict[str, Any] = {"file": file_name(name), "seed": SEED, "kwargs": kwargs}
    if name in VARIANTS:
        entry["id"] = env_id
    entry["batched"] = has_vector(env_id)
    if entry["batched"]:
        entry["num_envs"] = NUM_ENVS
    return entry


def _write_golden(out: Path, env_id: str, entry: dict[str, Any]) -> None:
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **golden_arrays(env_id, entry))
    atomic_write_bytes(out / entry["file"], buffer.getvalue())
    print(f"{env_id}: {entry['file']} {entry['kwargs']}")


def record_new(out: Path = GOLDEN_DIR) -> dict[str, Any]:
    """Record the golden file of every registered id (and variant) that ``out``'s index lacks and add
    its entry,
    leaving the other goldens and entries as they are. Refuses (before running anything):
    ``FileNotFoundError`` without an index, ``FileExistsError`` when a new id's file exists, and
    ``ValueError`` when this machine's :func:`versions` are not the index's. Returns the index."""
    path = out / INDEX_NAME
    if not path.is_file():
        raise FileNotFoundError(f"no {INDEX_NAME} in {out}: record every id first (without --new)")
    index = json.loads(path.read_text(encoding="utf-8"))
    if index["versions"] != versions():
        raise ValueError(
            f"the goldens in {out} were recorded with {index['versions']}, this machine has {versions()}: "
            "a new golden must come from the versions the index states"
        )
    new = [name for name in golden_names() if name not in index["ids"]]
    existing = [file_name(env_id) for env_id in new if (out / file_name(env_id)).exists()]
    if existing:
        raise FileExistsError(f"files of ids the index lacks exist in {out} ({', '.join(existing)})")
    for env_id in new:
        entry = _entry(env_id)
        _write_golden(out, env_id, entry)
        index["ids"][env_id] = entry
    atomic_write_text(path, json.dumps(index, indent=2, sort_keys=True) + "\n")
    return index


def record(out: Path = GOLDEN_DIR, overwrite: bool = False) -> dict[str, Any]:
    """Record the golden file of every registered id and the index into ``out``; refuse (``FileExistsError``,
    before running anything) to replace goldens unless ``overwrite``. Returns the index."""
    ids = golden_names()
    targets = [out / INDEX_NAME, *(out / file_name(env_id) for env_id in ids)]
    existing = [path.name for path in targets if path.exists()]
    if existing and not overwrite:
        names = ", ".join(existing)
        raise FileExistsError(f"goldens exist in {out} ({names}): pass --overwrite to re-record")
    entries = {}
    for env_id in ids:
        entry = _entry(env_id)
        _write_golden(out, env_id, entry)
        entries[env_id] = entry
    index = {"ids": entries, "versions": versions(), "package": ios_uav_env.__version__}
    atomic_write_text(out / INDEX_NAME, json.dumps(index, indent=2, sort_keys=True) + "\n")
    stale = {path.name for path in out.glob("*.npz")} - {entry["file"] for entry in entries.values()}
    for name in sorted(stale):  # goldens of ids no longer registered
        (out / name).unlink()
    return index


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    which = parser.add_mutually_exclusive_group()
    which.add_argument("--overwrite", action="store_true", help="replace the existing goldens")
    which.add_argument("--new", action="store_true", help="record only the ids the index lacks")
    parser.add_argument("--out", type=Path, default=GOLDEN_DIR, help="the folder of the goldens")
    args = parser.parse_args(argv)
    try:
        if args.new:
            record_new(args.out)
        else:
            record(args.out, args.overwrite)
    except (FileExistsError, FileNotFoundError, ValueError) as error:
        print(error, file=sys.stderr)
        return 1
    print(f"ios_uav_env from {Path(ios_uav_env.__file__).parent}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
