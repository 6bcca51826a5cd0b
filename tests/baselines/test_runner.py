"""baselines.runner.run_tasks: cached, resumable, ordered, parallel in spawned one-thread workers."""

from __future__ import annotations

import json
import os
import time

import pytest

from baselines.runner import BACKENDS, run_tasks


def square(x: int) -> dict:
    return {"x": x, "y": x * x}


def where(x: int) -> dict:
    return {"x": x, "pid": os.getpid(), "omp": os.environ.get("OMP_NUM_THREADS")}


def fail_on_three(x: int) -> dict:
    if x == 3:
        raise RuntimeError("task 3 failed")
    return {"x": x}


def sees_the_first_record(task: dict) -> dict:
    """Task "first" ends at once; task "probe" waits (up to 20 s) for its cache file."""
    if task["name"] == "probe":
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline and not os.path.exists(task["first_file"]):
            time.sleep(0.02)
        return {"name": "probe", "saw_first": os.path.exists(task["first_file"])}
    if task["name"] == "fail":
        time.sleep(0.5)
        raise RuntimeError("the slow task failed")
    return {"name": task["name"]}


def test_parallel_records_are_cached_as_their_tasks_end(tmp_path):
    """A parallel map caches each record when its task ends, not when the map ends: progress
    shows, and an interrupted or failed map keeps what finished."""
    first = tmp_path / "first.json"
    tasks = [{"name": "first", "first_file": str(first)}, {"name": "probe", "first_file": str(first)}]
    out = run_tasks(sees_the_first_record, tasks, tmp_path, key=lambda t: t["name"], jobs=2, progress=False)
    assert out[1] == {"name": "probe", "saw_first": True}
    failing = [{"name": "quick"}, {"name": "fail"}]
    with pytest.raises(RuntimeError, match="the slow task failed"):
        run_tasks(
            sees_the_first_record, failing, tmp_path / "f", key=lambda t: t["name"], jobs=2, progress=False
        )
    assert [p.stem for p in (tmp_path / "f").glob("*.json")] == ["quick"]


def test_records_are_cached_by_key_and_an_interrupted_run_computes_only_the_missing(tmp_path):
    tasks = [1, 2, 3]
    out = run_tasks(square, tasks, tmp_path, key=lambda x: f"sq{x}", jobs=1, progress=False)
    assert out == [square(x) for x in tasks]
    assert sorted(p.name for p in tmp_path.glob("*.json")) == ["sq1.json", "sq2.json", "sq3.json"]
    assert json.loads((tmp_path / "sq2.json").read_text()) == {"x": 2, "y": 4}
    (tmp_path / "sq2.json").unlink()  # as if interrupted before task 2
    calls = []
    again = run_tasks(
        lambda x: calls.append(x) or square(x),
        tasks,
        tmp_path,
        key=lambda x: f"sq{x}",
        jobs=1,
        progress=False,
    )
    assert calls == [2] and again == out


def test_order_sets_which_tasks_run_first_and_twins_run_once(tmp_path):
    calls = []
    out = run_tasks(lambda x: calls.append(x) or square(x), [1, 5, 3, 5], tmp_path, key=str, jobs=1,
                    order=lambda x: -x, progress=False)  # fmt: skip
    assert calls == [5, 3, 1] and out == [square(x) for x in (1, 5, 3, 5)]


def test_parallel_workers_are_spawned_processes_with_one_thread(tmp_path):
    before = os.environ.get("OMP_NUM_THREADS")
    out = run_tasks(where, list(range(4)), tmp_path, key=str, jobs=2, progress=False)
    assert [r["x"] for r in out] == [0, 1, 2, 3]
    assert os.getpid() not in {r["pid"] for r in out} and {r["omp"] for r in out} == {"1"}
    assert os.environ.get("OMP_NUM_THREADS") == before
    assert run_tasks(where, list(range(4)), tmp_path, key=str, jobs=2, progress=False) == out  # cached


def test_a_failing_task_raises_and_the_finished_ones_stay_cached(tmp_path):
    with pytest.raises(RuntimeError, match="task 3 failed"):
        run_tasks(fail_on_three, [1, 2, 3], tmp_path, key=str, jobs=1, progress=False)
    assert sorted(p.stem for p in tmp_path.glob("*.json")) == ["1", "2"]


def test_bad_arguments_are_refused(tmp_path):
    assert set(BACKENDS) == {"local", "ray"}
    with pytest.raises(ValueError, match="backend: unknown backend 'dask'"):
        run_tasks(square, [1], tmp_path, key=str, backend="dask")
    with pytest.raises(ValueError, match="jobs: must be a positive integer"):
        run_tasks(square, [1], tmp_path, key=str, jobs=0)


def test_a_full_disk_names_the_cache_file_keeps_the_finished_records_and_leaves_nothing_torn(
    tmp_path, monkeypatch, capsys
):
    # before: a raw "[Errno 28] No space left on device" without the file or the records kept
    import errno

    import ios_uav_env.io as io

    write_all, writes = io._write_all, []

    def filling(fd: int, data: bytes) -> None:
        writes.append(data)
        if len(writes) == 2:  # the second record's file: half of it fits, then the disk is full
            os.write(fd, bytes(data[: len(data) // 2]))
            raise OSError(errno.ENOSPC, "No space left on device")
        write_all(fd, data)

    monkeypatch.setattr(io, "_write_all", filling)
    with pytest.raises(io.DiskFullError) as raised:
        run_tasks(square, [3, 4, 5], tmp_path, key=str, jobs=1, progress=False)
    assert str(tmp_path / "4.json") in str(raised.value) and "the disk is full" in str(raised.value)
    assert "disk full: 1 of 3 records are kept" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["3.json"]  # no torn 4.json, no temporary file
    monkeypatch.setattr(io, "_write_all", write_all)
    assert run_tasks(square, [3, 4, 5], tmp_path, key=str, jobs=1, progress=False)[1] == {"x": 4, "y": 16}
