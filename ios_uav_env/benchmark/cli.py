"""The benchmark's command line: list the suites, show their references, score a policy or a file.

    python -m ios_uav_env.benchmark list
    python -m ios_uav_env.benchmark show [--suite single-node-v1] [--reference dp|sca|hover_peak|hover_ground]
    python -m ios_uav_env.benchmark show --suite multi-node-v1 [--reference sca|tour|bound]
    python -m ios_uav_env.benchmark evaluate [--suite single-node-v1] --policy PKG.MODULE:ATTR \\
        [--batched] [--env-kwargs KEY:VALUE ...] [--allow-task-change] [--n N] [--name NAME] \\
        [--out DIR [--overwrite]]
    python -m ios_uav_env.benchmark evaluate [--suite single-node-v1] --trajectories FILE.npz|FILE.csv \\
        [--name NAME] [--out DIR [--overwrite]]

``--policy`` imports ``PKG.MODULE`` (the current directory is on the path) and takes ``ATTR``
(dotted for a nested attribute): a policy, or a class (instantiated without arguments), or a
call with literal arguments, e.g. ``"ios_uav_env.envs.policies:HoverAt('peak')"``. ``--env-kwargs``
values are JSON or Python literals (``peak_hint:true``), else strings; an argument the suite pins
(a scenario field, a reset's draw) is refused, and so is one that changes the suite's task
(``ios_uav_env.benchmark.overrides``: e.g. ``knowledge``, ``arrival_guard``) unless
``--allow-task-change`` is given: the summary, the files and the figures then name the changed
task (``mobile-v1 with knowledge='exact' [not mobile-v1's task]``). ``evaluate`` prints the
summary line (mean / p10 / min % of DP and of SCA, feasible count, median time to plan) and
writes ``results.csv``, ``results.json``, ``results.md`` and ``pct_dp.png`` (with matplotlib)
to ``--out``: a folder that already holds results (``ios_uav_env.benchmark.outputs``) is refused
before anything runs unless ``--overwrite`` is given, and then the previous run's result files
that this run does not write again are removed. The summary's "median plan" is the median of the
scenarios' plan times: each the wall time of its episode in the single env, warm (see
``ios_uav_env.benchmark.scoring``). ``show`` prints the same line for each stored reference (DP,
SCA, heuristics).

On a multi-node suite (``--suite multi-node-v1``) the line has % of SCA, % of the certified
bound and the best schedule's % of SCA (``ios_uav_env.benchmark.results``), the figures are
``pct_sca.png`` and ``shares.png``, and a trajectories file may hold each plan's shares
(``shares_<index>`` in ``.npz``, ``share_<k>`` columns in CSV); without them a plan is scored
with its best schedule.

On a STAR-control suite (``--suite star-v1``) the line has % of the per-slot optimum and of its
certified bound; the policy is bound to each scenario's widths if it has ``bind``
(``ios_uav_env.benchmark.star_suite``), and ``--trajectories`` does not apply. A MISO-control
suite (``--suite miso-v1``) is scored the same way, as % of the per-slot AO optimum
(``ios_uav_env.benchmark.miso_suite``).
"""

from __future__ import annotations

import argparse
import ast
import importlib
import json
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

from ios_uav_env.benchmark.outputs import RESULT_FILES, claim
from ios_uav_env.benchmark.overrides import policy_env_kwargs
from ios_uav_env.benchmark.results import reference_results
from ios_uav_env.benchmark.scoring import action_function, check_env_kwargs, evaluate
from ios_uav_env.benchmark.suite import list_suites, load_suite
from ios_uav_env.benchmark.suite_registry import DEFAULT_SUITE, KIND_REFERENCES, SUITES
from ios_uav_env.benchmark.trajectories import read_plans
from ios_uav_env.benchmark.trajectory_scoring import score_trajectories


def load_policy(spec: str) -> Any:
    """The policy named by ``spec``: ``pkg.module:attr``, ``pkg.module:Class`` (instantiated
    without arguments) or ``pkg.module:factory(literal, key=literal)`` (called); ``ValueError``
    naming ``spec`` for any failure (a bad spec, an import or attribute that fails, a call that
    raises)."""
    module_name, sep, expr = spec.partition(":")
    if not sep or not module_name or not expr:
        raise ValueError(f"a policy must be PKG.MODULE:ATTR, got {spec!r}")
    try:
        node = ast.parse(expr.strip(), mode="eval").body
    except SyntaxError as err:
        raise ValueError(f"{spec!r}: {expr!r} is not an attribute or a call") from err
    call = node if isinstance(node, ast.Call) else None
    target = call.func if call is not None else node
    dotted = ast.unparse(target)
    if not all(part.isidentifier() for part in dotted.split(".")):
        raise ValueError(f"{spec!r}: {dotted!r} is not a dotted attribute name")
    try:
        obj: Any = importlib.import_module(module_name)
    except Exception as err:  # any error of the import (a missing module, a broken one)
        raise ValueError(f"{spec!r}: cannot import {module_name!r}: {type(err).__name__}: {err}") from None
    for part in dotted.split("."):
        if not hasattr(obj, part):
            raise ValueError(f"{spec!r}: {module_name}.{dotted} does not exist (no attribute {part!r})")
        obj = getattr(obj, part)
    if call is not None:
        if any(k.arg is None for k in call.keywords) or any(isinstance(a, ast.Starred) for a in call.args):
            raise ValueError(f"{spec!r}: the arguments must be literals (no * or **)")
        try:
            args = [ast.literal_eval(a) for a in call.args]
            kwargs = {k.arg: ast.literal_eval(k.value) for k in call.keywords if k.arg}
        except (ValueError, TypeError, SyntaxError, MemoryError, RecursionError) as err:
            raise ValueError(f"{spec!r}: the arguments must be literals") from err
        return _called(spec, obj, args, kwargs)
    return _called(spec, obj, [], {}) if isinstance(obj, type) else obj


def _called(spec: str, factory: Any, args: list[Any], kwargs: dict[str, Any]) -> Any:
    if not callable(factory):
        raise ValueError(f"{spec!r}: {type(factory).__name__} object is not callable")
    try:
        return factory(*args, **kwargs)
    except Exception as err:  # the user's factory: any error is a bad --policy
        raise ValueError(f"{spec!r}: the call raised {type(err).__name__}: {err}") from None


def parse_env_kwargs(items: Sequence[str]) -> dict[str, Any]:
    """``["key:value", ...]`` as a dict (values as JSON, else Python literals, else strings)."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition(":")
        if not sep or not key.isidentifier():
            raise ValueError(f"env arguments are KEY:VALUE items (KEY a Python name), got {item!r}")
        value: Any
        try:
            value = json.loads(text)
        except json.JSONDecodeError:
            try:
                value = ast.literal_eval(text)
            except (ValueError, SyntaxError):
                value = text
        out[key] = value
    return out


def _count(text: str) -> int:
    """An ``--n``: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {value}")
    return value


def _seed(text: str) -> int:
    """A ``--seed``: an integer >= 0 (a Gymnasium reset seed)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be an integer >= 0 (a reset seed), got {value}")
    return value


def check_out(out: Path) -> None:
    """``ValueError`` unless ``out`` is (or can be made) a folder this process can write in: it
    is made, and a temporary file written in it and removed."""
    if out.exists() and not out.is_dir():
        raise ValueError(f"{out} is a file, not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out):
            pass
    except OSError as err:
        raise ValueError(f"{out} is not a folder this process can write in ({err.strerror or err})") from None


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m ios_uav_env.benchmark", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="the shipped suites")
    show = sub.add_parser("show", help="the stored reference values of a suite")
    show.add_argument("--suite", default=DEFAULT_SUITE, help=f"a suite name ({', '.join(SUITES)}) or file")
    show.add_argument("--n", type=_count, default=None, help="the first n scenarios only")
    show.add_argument(
        "--reference",
        choices=list(dict.fromkeys(r for refs in KIND_REFERENCES.values() for r in refs)),
        default=None,
        help="one reference only (default: all of the suite's)",
    )
    ev = sub.add_parser("evaluate", help="score a policy or a file of trajectories")
    ev.add_argument("--suite", default=DEFAULT_SUITE, help=f"a suite name ({', '.join(SUITES)}) or file")
    what = ev.add_mutually_exclusive_group(required=True)
    what.add_argument("--policy", help="PKG.MODULE:ATTR, a policy (see above)")
    what.add_argument("--trajectories", type=Path, help="a .npz or .csv file, one trajectory per scenario")
    ev.add_argument("--batched", action="store_true", help="the policy maps (B, obs_dim) to (B, 2)")
    ev.add_argument("--env-kwargs", nargs="*", default=None, metavar="KEY:VALUE",
                    help="env arguments (default: the policy's env_kwargs attribute)")  # fmt: skip
    ev.add_argument("--n", type=_count, default=None, help="the first n scenarios only (policies)")
    ev.add_argument("--seed", type=_seed, default=0, help="the reset seed of every scenario (>= 0)")
    ev.add_argument("--allow-task-change", action="store_true",
                    help="run env arguments that change the suite's task (the outputs name it)")  # fmt: skip
    ev.add_argument("--name", default=None, help="the name in the outputs")
    ev.add_argument("--out", type=Path, default=None, help="folder for the CSV, JSON, markdown and figure")
    ev.add_argument("--overwrite", action="store_true",
                    help="replace the results in --out (and remove the previous run's others)")  # fmt: skip
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; a bad argument or input is one ``error:`` line naming the argument
    and exit status 2, found before any scenario runs (``--out`` first)."""
    parser = _parser()
    args = parser.parse_args(argv)

    def refuse(argument: str, err: BaseException) -> NoReturn:
        message = err.args[0] if isinstance(err, KeyError) and err.args else err
        parser.error(f"argument {argument}: {message}")

    if args.command == "list":
        for row in list_suites():
            print(f"{row['name']}: {row['n']} scenarios of {row['env_id']}, scored as % of "
                  f"{row['normalizer']}, sha256 {row['sha256']}")  # fmt: skip
        return 0
    if args.command == "evaluate" and args.out is not None:
        try:
            check_out(args.out)
            claim(args.out, RESULT_FILES, args.overwrite)
        except (ValueError, FileExistsError) as err:
            refuse("--out", err)
    try:
        suite = load_suite(args.suite)
    except (ValueError, KeyError, OSError) as err:
        refuse("--suite", err)
    if args.command == "show":
        if args.reference is not None and args.reference not in suite.references:
            refuse("--reference", ValueError(f"suite {suite.name} has no reference {args.reference!r}; "
                                             f"it has {list(suite.references)}"))  # fmt: skip
        if args.reference is None:
            head = f"{suite.name} (version {suite.version}, sha256 {suite.sha256})"
            print(f"{head}: {len(suite)} scenarios of {suite.env_id}; the stored reference values:")
        for reference in suite.references if args.reference is None else (args.reference,):
            print(reference_results(suite, reference, args.n).summary())
        return 0
    try:
        if args.trajectories is not None:
            try:
                trajectories, seconds, shares = read_plans(args.trajectories)
                results = score_trajectories(trajectories, suite, seconds=seconds, shares=shares or None,
                                             name=args.name or args.trajectories.name)  # fmt: skip
            except (ValueError, OSError) as err:
                refuse("--trajectories", err)
        else:
            try:
                policy = load_policy(args.policy)
                action_function(policy)
            except (ValueError, TypeError) as err:
                refuse("--policy", err)
            try:
                env_kwargs = None if args.env_kwargs is None else parse_env_kwargs(args.env_kwargs)
                own = policy_env_kwargs(suite, policy, env_kwargs)
                check_env_kwargs(suite, own, policy, allow_task_change=args.allow_task_change)
            except (ValueError, TypeError) as err:
                refuse("--env-kwargs" if args.env_kwargs is not None else "--policy", err)
            results = evaluate(policy, suite, env_kwargs=env_kwargs, n=args.n, batched=args.batched or None,
                               seed=args.seed, name=args.name or args.policy,
                               allow_task_change=args.allow_task_change)  # fmt: skip
    except (ValueError, KeyError, ImportError) as err:
        parser.error(str(err))
    print(results.summary())
    if args.out is not None:
        paths = results.save(args.out, overwrite=args.overwrite)
        if "figure" not in paths:
            print("no figure: matplotlib is not installed (pip install 'ios-uav-env[render]')")
        print("wrote " + ", ".join(str(p) for p in paths.values()))
    return 0
