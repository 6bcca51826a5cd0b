"""The fast trainer's faults: its log written whole per update, a full disk, a resume that cuts
the log back to its checkpoint. Tiny budgets (the fixtures of ``tests/agents/test_fast.py``)."""

from __future__ import annotations

import errno
import json
import os
from pathlib import Path

import pytest

from tests.agents import test_fast

pytestmark = pytest.mark.usefixtures("one_torch_thread")

fast_file = test_fast.fast_file  # a tiny recipe file (a fixture)


def _lines(run: Path) -> list[dict]:
    return [json.loads(line) for line in (run / "progress.csv").read_text().splitlines()]


def _updates(run: Path, steps: int) -> int:
    """The updates the checkpoint of ``steps`` says were done."""
    import pickle

    from agents.fast.run import STATE_KIND
    from agents.loading import checkpoint_file

    with checkpoint_file(run, steps, STATE_KIND).open("rb") as fh:
        return int(pickle.load(fh)["updates"])


def test_every_update_is_logged_at_once_and_a_full_disk_leaves_no_half_line(fast_file, tmp_path, monkeypatch,
                                                                             capsys):  # fmt: skip
    # before: progress.csv was a buffered handle (a SIGKILL lost every line since its last flush;
    # here the lines of updates 1-3 were not on disk when update 4 began), and a full disk
    # ended in a raw OSError with half a line left, onto which the resumed run glued its next one
    import ios_uav_env.io as io
    import train
    from agents.fast.ppo import FastPPO

    run = tmp_path / "run"
    seen = []
    collect = FastPPO.collect

    def checked_collect(self, stop=None):  # what a SIGKILL now would leave: every finished update's line
        on_disk = (run / "progress.csv").read_text().count("\n") if (run / "progress.csv").exists() else 0
        seen.append((self.updates, on_disk))
        return collect(self, stop)

    write_all, lines = io._write_all, []

    def filling(fd: int, data: bytes) -> None:  # the 4th line: half fits, then the disk is full
        if b'"policy_loss"' in data:
            lines.append(data)
            if len(lines) == 4:
                os.write(fd, bytes(data[: len(data) // 2]))
                raise OSError(errno.ENOSPC, "No space left on device")
        write_all(fd, data)

    monkeypatch.setattr(FastPPO, "collect", checked_collect)
    monkeypatch.setattr(io, "_write_all", filling)
    argv = ["--algo", "ppo", "--trainer", "fast", "--hyperparams", str(fast_file), "--out", str(run),
            "--timesteps", "1024", "--env-kwargs", "T:40", "--checkpoint-freq", "512", "--eval-freq", "0",
            "--no-progress", "--threads", "1"]  # fmt: skip
    assert train.main(argv) == 1
    err = capsys.readouterr().err
    assert f"cannot write {run / 'progress.csv'}: the disk is full" in err and "Traceback" not in err
    assert f"python train.py --resume {run}" in err
    assert seen == [(0, 0), (1, 1), (2, 2), (3, 3)]
    assert [row["steps"] for row in _lines(run)] == [256, 512, 768]  # whole lines only
    monkeypatch.setattr(io, "_write_all", write_all)
    assert train.main(["--resume", str(run), "--no-progress"]) == 0  # from the checkpoint of 512 steps
    assert "1 lines past the checkpoint of 512 steps dropped" in capsys.readouterr().err
    rows = _lines(run)
    assert [row["steps"] for row in rows] == [256, 512, 768, 1024] and len(rows) == _updates(run, 1024)


def test_a_resume_cuts_the_log_back_to_its_checkpoint(tmp_path):
    # before: lines of updates past the checkpoint stayed (the resumed run logged them twice) and a
    # torn last line had the next record glued onto it
    from agents.fast.run import trim_progress

    log = tmp_path / "progress.csv"
    log.write_text('{"steps": 256}\n{"steps": 512}\n{"steps": 768}\n{"steps": 10')
    assert trim_progress(tmp_path, 512) == 2 and log.read_text() == '{"steps": 256}\n{"steps": 512}\n'
    assert trim_progress(tmp_path, 512) == 0 and trim_progress(tmp_path / "none", 0) == 0


def test_a_fast_run_killed_before_its_first_checkpoint_can_be_resumed_or_restarted(
    fast_file, tmp_path, capsys
):
    # before: its progress.csv and clone.json (and the temporary file of a write cut short) were
    # not on the list of what an unstarted run leaves: --resume and a new run both refused it
    import shutil

    import train
    from agents.training import check_new_run_dir

    run = tmp_path / "run"
    argv = ["--algo", "ppo", "--trainer", "fast", "--hyperparams", str(fast_file), "--out", str(run),
            "--timesteps", "512", "--env-kwargs", "T:40", "--eval-freq", "0", "--no-progress"]  # fmt: skip
    assert train.main(argv) == 0
    for name in ("checkpoints", "model.zip", "vecnormalize.pkl", "summary.json"):  # as a SIGKILL leaves it
        shutil.rmtree(run / name) if name == "checkpoints" else (run / name).unlink()
    (run / "clone.json").write_text("{}")
    (run / ".summary.json.k2x9_a.tmp").write_text('{"ste')
    assert check_new_run_dir(run) == run
    assert train.main(["--resume", str(run), "--no-progress"]) == 0
    assert "holds no checkpoint: starting it again from step 0" in capsys.readouterr().err
    assert [row["steps"] for row in _lines(run)] == [256, 512]  # the new run's lines only
    assert not (run / "clone.json").exists() and not (run / ".summary.json.k2x9_a.tmp").exists()
