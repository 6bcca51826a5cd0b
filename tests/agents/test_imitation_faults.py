"""Fault injection for ``python -m agents.imitation``: a smaller total on a finished run, a write
that fails (a tiny file-size limit, as a full disk), a folder without its statistics, bad
settings, SIGINT and SIGTERM. Each test injects the fault for real on a tiny run (one scenario,
an 8-unit network, one epoch a round) and fails on the code before the fix (see each comment)."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("cvxpy")

import agents.imitation  # noqa: E402
from agents.imitation import ImitationSettings, main  # noqa: E402
from agents.loading import load_agent  # noqa: E402

#: One training scenario (the default first seed), the smallest network and fit.
TINY = ["--scenarios", "1", "--epochs", "1", "--net-arch", "8", "--batch-size", "256", "--jobs", "1",
        "--no-progress"]  # fmt: skip
SEED_LIMIT = 2**32  # np.random.seed takes seeds below it
FILES = ("model.zip", "vecnormalize.pkl", "config.json", "summary.json", "settings.json")


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """A finished two-round run (its tour plan cached in its own ``plans/``)."""
    out = tmp_path_factory.mktemp("imitation") / "run"
    assert main(["--out", str(out), "--rounds", "2", *TINY]) == 0
    return out


@pytest.fixture
def run_copy(finished, tmp_path) -> Path:
    folder = tmp_path / "run"
    shutil.copytree(finished, folder)
    return folder


def contents(folder: Path) -> dict[str, bytes]:
    return {name: (folder / name).read_bytes() for name in FILES}


def test_a_smaller_rounds_total_on_a_finished_run_is_refused_and_nothing_replaced(run_copy, capsys):
    # before: exit 0, model.zip replaced by the one-round model and config.json saying 1
    before = contents(run_copy)
    with pytest.raises(SystemExit) as exc:
        main(["--out", str(run_copy), "--rounds", "1", *TINY])
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert re.search(r"rounds: .* has finished 2 rounds already \(its total is 2\); "
                     r"the new total must be at least 2, got 1", err), err  # fmt: skip
    assert contents(run_copy) == before
    assert main(["--out", str(run_copy), "--rounds", "2", *TINY]) == 0  # the same total still reruns


@pytest.mark.parametrize("limit, failing", [(1_000, "vecnormalize.pkl"), (10_000, "model.zip")])
def test_a_failing_write_leaves_the_previous_files_whole(run_copy, capsys, limit, failing):
    # before: model.save wrote model.zip in place: cut at the limit, it no longer loaded (BadZipFile)
    resource = pytest.importorskip("resource")
    before = contents(run_copy)
    assert len(before[failing]) > limit > len(before["settings.json"])
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, hard))  # as prlimit --fsize: writes past it fail
    try:
        code = main(["--out", str(run_copy), "--rounds", "2", *TINY])  # rewrites the final model
    except OSError as exc:
        code = exc
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
    after = contents(run_copy)
    assert {k: v for k, v in after.items() if k != "settings.json"} == {  # settings.json: its new "out"
        k: v for k, v in before.items() if k != "settings.json"
    }
    assert not [p.name for p in run_copy.iterdir() if p.name.startswith(".")]  # no temporary file left
    load_agent(run_copy)
    err = capsys.readouterr().err
    assert code == 1 and f"cannot write {run_copy / failing}: the file-size limit is reached" in err
    assert len(err.splitlines()) == 1


def test_an_imitation_model_without_its_statistics_is_refused(run_copy):
    # before: config.json did not record the normalisation: it loaded without them and scored 2% of SCA
    config = json.loads((run_copy / "config.json").read_text())
    assert config["hyperparams"]["normalize"] == {"norm_obs": True, "norm_reward": True}
    (run_copy / "vecnormalize.pkl").unlink()
    stats = run_copy / "vecnormalize.pkl"
    with pytest.raises(FileNotFoundError, match=re.escape(f"the statistics {stats} are missing")):
        load_agent(run_copy)
    (run_copy / "rounds" / "1" / "vecnormalize.pkl").unlink()  # a round's folder is a model folder too
    with pytest.raises(FileNotFoundError, match="vecnormalize.pkl are missing"):
        load_agent(run_copy / "rounds" / "1")
    del config["hyperparams"]  # an imitation run that did not record it (the shipped one): still refused
    (run_copy / "config.json").write_text(json.dumps(config))
    with pytest.raises(
        FileNotFoundError, match=re.escape(f"trained_by 'agents.imitation') but the statistics {stats}")
    ):
        load_agent(run_copy)


@pytest.mark.parametrize(
    "extra, field",
    [(["--env-kwargs", "bogus:1"], "env_kwargs"), (["--env-kwargs", "T:-4"], "env_kwargs"),
     (["--seed", "-1"], "seed"), (["--seed", str(SEED_LIMIT)], "seed"), (["--plans", "FILE"], "plans")],
)  # fmt: skip
def test_bad_settings_are_refused_before_anything_is_computed_or_written(tmp_path, capsys, monkeypatch,
                                                                         extra, field):  # fmt: skip
    # before: the tour plans were computed and settings.json written, then the run failed; the
    # corrected command was refused as "other settings"
    def no_plans(*args, **kwargs):
        raise AssertionError("the tour plans were computed before the settings were checked")

    monkeypatch.setattr(agents.imitation, "tour_plans", no_plans)
    (tmp_path / "FILE").write_text("not a folder")
    out = tmp_path / "run"
    argv = [
        "--out",
        str(out),
        "--rounds",
        "1",
        *TINY,
        *[str(tmp_path / a) if a == "FILE" else a for a in extra],
    ]
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2 and f"error: {field}: " in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize(
    "field, value",
    [("seed", -1), ("seed", SEED_LIMIT), ("first_seed", -5), ("jobs", 0), ("log_std_init", float("nan")),
     ("env_kwargs", {"bogus": 1}), ("env_kwargs", {"focus": object()}), ("plans", "FILE"), ("out", "FILE")],
)  # fmt: skip
def test_every_setting_is_checked_by_validate(tmp_path, field, value):
    # before: none of these was checked; each failed later (or, jobs and plans, inside the planner map)
    (tmp_path / "FILE").write_text("not a folder")
    value = str(tmp_path / value) if value == "FILE" else value
    out = str(tmp_path / "run") if field != "out" else value
    with pytest.raises((ValueError, OSError), match=f"^{field}: "):
        ImitationSettings(**{"out": out, field: value}).validate()


def fail_at_fit(monkeypatch, signum: int) -> None:
    """This process gets a real ``signum`` when a round's fit starts."""
    fit = agents.imitation.fit

    def signalled(*args, **kwargs):
        os.kill(os.getpid(), signum)
        return fit(*args, **kwargs)

    monkeypatch.setattr(agents.imitation, "fit", signalled)


class Terminated(Exception):
    """What SIGTERM raises here if the code under test installs no handler of its own."""


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_ends_the_run_with_one_line_and_the_same_command_resumes(run_copy, capsys, monkeypatch,
                                                                          signum):  # fmt: skip
    # before: SIGINT printed a raw KeyboardInterrupt traceback; SIGTERM killed it without a word
    def terminated(signum, frame):
        raise Terminated

    old = signal.signal(signal.SIGTERM, terminated)
    # SIGINT as a command line has it (KeyboardInterrupt), whatever an earlier test in this worker left
    old_int = signal.signal(signal.SIGINT, signal.default_int_handler)
    fail_at_fit(monkeypatch, signum)
    argv = ["--out", str(run_copy), "--rounds", "3", *TINY]
    try:
        code = main(argv)
    except (KeyboardInterrupt, Terminated) as exc:
        code = type(exc).__name__
    finally:
        signal.signal(signal.SIGTERM, old)
        signal.signal(signal.SIGINT, old_int)
    err = capsys.readouterr().err
    assert code == 128 + signum
    name = signal.Signals(signum).name
    assert err == (f"python -m agents.imitation: interrupted by {name}: 2 of 3 rounds are finished and kept "
                   f"in {run_copy}; run the same command to resume\n")  # fmt: skip
    monkeypatch.undo()  # the real fit
    assert main(argv) == 0
    summary = json.loads((run_copy / "summary.json").read_text())
    assert [r["round"] for r in summary["rounds"]] == [0, 1, 2]
